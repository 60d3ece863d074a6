/*
 * base/outfile.h -- output files written atomically.
 *
 * outfile_open() creates a temporary file next to the destination; the
 * caller writes through of->f; outfile_commit() flushes, syncs and renames
 * it over the destination, so a reader (or a crash) never sees a half
 * written mesh. outfile_abort() removes the temporary and leaves any old
 * destination file untouched. Exactly one of commit/abort must be called.
 *
 * Files that belong together (BASE.node, BASE.ele and BASE.face, and the
 * other formats of the same mesh) are written as a set: an outfile opened
 * with outfile_open_in() keeps its finished temporary at commit, and
 * outset_commit() renames all of them at the end, or outset_abort()
 * removes them, so a run that fails half way (out of memory in the third
 * writer, say) leaves no file of the set and every old one untouched.
 */
#ifndef PDR_OUTFILE_H
#define PDR_OUTFILE_H

#include <stdio.h>

#include "base/pdr_error.h"

typedef struct outset outset;

typedef struct outfile {
    FILE *f;     /* owned until commit/abort */
    char *path;  /* owned copy of the destination */
    char *tmp;   /* owned name of the temporary */
    outset *set; /* not owned: commit hands path and tmp to it; or NULL */
} outfile;

/* Finished temporaries waiting to be renamed together. Zero-initialised
 * (OUTSET_INIT) it is empty; it holds at most OUTSET_MAX files, in fixed
 * room, so that adding one never needs memory. */
#define OUTSET_MAX 8
struct outset {
    size_t n;                /* files waiting */
    char *path[OUTSET_MAX];  /* owned destinations */
    char *tmp[OUTSET_MAX];   /* owned finished temporaries */
};
#define OUTSET_INIT {0, {NULL}, {NULL}}

/* Returns 0 or PDR_EIO/PDR_ENOMEM, with "path: reason" added to diag. */
int outfile_open(outfile *of, const char *path, pdr_diag *diag);
/* The same, as a member of set (NULL: as outfile_open). Also PDR_ELIMIT
 * when set already holds OUTSET_MAX files. */
int outfile_open_in(outfile *of, outset *set, const char *path, pdr_diag *diag);
/* Returns 0, or PDR_EIO (the temporary is removed, diag says why). In a
 * set, the flushed and synced temporary is left for outset_commit. */
int outfile_commit(outfile *of, pdr_diag *diag);
void outfile_abort(outfile *of);

/* Renames every waiting temporary over its destination, in the order they
 * were committed, and empties set. Returns 0, or PDR_EIO after a rename
 * failed (diag says which): the temporaries not yet renamed are removed,
 * those already renamed stay. */
int outset_commit(outset *set, pdr_diag *diag);
/* Moves the temporaries waiting in from to the end of set, in order, and
 * empties from (no memory needed). Returns 0, or PDR_ELIMIT (nothing
 * moved) when set would hold more than OUTSET_MAX files. */
int outset_move(outset *set, outset *from);
/* Removes every waiting temporary and empties set; no destination is
 * touched. Safe on an empty set. */
void outset_abort(outset *set);

#endif /* PDR_OUTFILE_H */
