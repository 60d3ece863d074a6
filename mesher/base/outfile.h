/*
 * base/outfile.h -- output files written atomically.
 *
 * outfile_open() creates a temporary file next to the destination; the
 * caller writes through of->f; outfile_commit() flushes, syncs and renames
 * it over the destination, so a reader (or a crash) never sees a half
 * written mesh. outfile_abort() removes the temporary and leaves any old
 * destination file untouched. Exactly one of commit/abort must be called.
 */
#ifndef PDR_OUTFILE_H
#define PDR_OUTFILE_H

#include <stdio.h>

#include "base/pdr_error.h"

typedef struct outfile {
    FILE *f;     /* owned until commit/abort */
    char *path;  /* owned copy of the destination */
    char *tmp;   /* owned name of the temporary */
} outfile;

/* Returns 0 or PDR_EIO/PDR_ENOMEM, with "path: reason" added to diag. */
int outfile_open(outfile *of, const char *path, pdr_diag *diag);
/* Returns 0, or PDR_EIO (the temporary is removed, diag says why). */
int outfile_commit(outfile *of, pdr_diag *diag);
void outfile_abort(outfile *of);

#endif /* PDR_OUTFILE_H */
