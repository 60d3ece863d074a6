/*
 * plc/plc_int.h -- shared between the plc_*.c files; not for other
 * modules.
 */
#ifndef PDR_PLC_INTERNAL_H
#define PDR_PLC_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include <stdio.h>

#include "base/textin.h"
#include "plc/plc.h"

/* Grows *arr (elements of elsize bytes, capacity *cap) to hold need
 * elements, doubling. Returns 0 or PDR_ENOMEM (*arr is then unchanged). */
int plc__grow(void **arr, size_t *cap, size_t need, size_t elsize);
/* Frees the derived arrays and clears 'derived'. */
void plc__drop_derived(plc *p);
/* Allocates nattr zeroed attributes per vertex (once). */
int plc__enable_vattr(plc *p, size_t nattr);
/* Newell area vector (twice the area times the unit normal) and corner
 * centroid of polygon q. */
void plc__newell(const plc *p, const plc_polygon *q, double n[3], double c[3]);
/* The same for the n >= 1 corners c of a ring of vertices xyz. */
void plc__newell_ring(const double (*xyz)[3], const uint32_t *c, uint32_t n, double nrm[3],
                      double cen[3]);
int plc__cmp_u64(const void *x, const void *y);
/* Gives vertex v (the last one added) the number num (0-based, the base
 * is added) in its file, where some vertex before it was merged away;
 * the vertices before v without one keep their own. Returns 0 or
 * PDR_ENOMEM. */
int plc__number_vertex(plc *p, uint32_t v, long num);

/* ------------------------------------------------ text readers (plc_read.c) */

/* Counts and indices in files are at most this. */
#define PLC_MAX_COUNT 1000000000L

/* Records "out of memory" at t's line; returns PDR_ENOMEM. */
int plc__oom(textin *t);
/* Reads the next content line, failing with "unexpected end of file while
 * reading WHAT" at the end. */
int plc__need_line(textin *t, const char *what);
/* Fails with "unexpected value ... after WHAT" unless the line is done. */
int plc__expect_eol(textin *t, const char *what);
/* Reads the next integer of a record that may continue on following lines. */
int plc__record_long(textin *t, const char *what, long min, long max, long *out);
/* The same for a number. */
int plc__record_double(textin *t, const char *what, double *out);

/* --------------------------------------------------- surfaces (plc_surf.c) */

/* Welds vertices with equal coordinates: open addressing on the bits of
 * the coordinates (with -0 folded into +0, so equal values hash equally).
 * Start from {NULL, 0}; the reader frees slot with pr_free. */
struct plc__vmerge {
    uint32_t *slot; /* vertex index + 1, 0 when empty */
    size_t cap;     /* power of two */
};
/* The vertex of p at x: an existing one with the same coordinates, or a
 * new one (line: where it was read, for messages). Returns 0 or
 * PDR_ENOMEM. */
int plc__vmerge_insert(struct plc__vmerge *m, plc *p, const double x[3], long line,
                       uint32_t *out);
/* A surface file's vertices as read: file vertex i is p's vertex map[i].
 * Start from all zeros; plc__welder_free releases it. */
struct plc__welder {
    struct plc__vmerge vm;
    uint32_t *map;
    size_t cap_map;
};
/* File vertex i (the next one: i vertices were read before it) at x,
 * read at line: welded into an equal vertex before it (counted in
 * p->read_welded) or added, and numbered i for messages when the file's
 * numbers and p's part. Returns 0 or PDR_ENOMEM. */
int plc__weld_vertex(plc *p, struct plc__welder *w, long i, const double x[3], long line);
void plc__welder_free(struct plc__welder *w);
/* Adds face c[0..n) of a surface file as a facet with marker 0, mended as
 * plc_surf.c says (c is changed); tol: the planarity tolerance in length
 * units (INFINITY: keep every polygon whole). Returns 0 or PDR_ENOMEM. */
int plc__add_surface_face(plc *p, uint32_t *c, uint32_t n, long line, double tol);
/* The same with the facet's marker. */
int plc__add_surface_face_marked(plc *p, uint32_t *c, uint32_t n, int marker, long line,
                                 double tol);
/* The planarity tolerance in length units of a surface whose vertices are
 * all read: as plc_validate measures it. */
double plc__surface_tol(const plc *p);

/* Faces kept until every vertex is read (formats whose faces may name
 * vertices defined after them): corners as the file's 0-based vertex
 * numbers. Start from all zeros; plc__faces_free releases it. */
struct plc__faces {
    uint32_t *corner; /* the corners of all faces, one after the other */
    size_t ncorner, cap_corner;
    struct plc__face_rec {
        size_t first;   /* into corner */
        uint32_t n;
        int marker;
        long line;
    } *face;
    size_t nface, cap_face;
};
/* Appends face c[0..n) with its marker and line. Returns 0 or PDR_ENOMEM. */
int plc__faces_add(struct plc__faces *fs, const uint32_t *c, uint32_t n, int marker,
                   long line);
/* Adds every face to p: corners through map (file vertex -> p's vertex,
 * nv_file entries), each one checked against nv_file ("path:line: vertex
 * N is out of range [base, ...]", numbered from base as the file does).
 * Returns 0, PDR_EPARSE or PDR_ENOMEM. */
int plc__faces_commit(plc *p, const struct plc__faces *fs, const uint32_t *map, size_t nv_file,
                      int base, const char *path, pdr_diag *diag);
void plc__faces_free(struct plc__faces *fs);

/* ------------------------------------------ more surface formats, one file
 * each: read from f (opened binary) into p; errors as "path:line: ..." in
 * diag. Return 0, PDR_EPARSE, PDR_EIO or PDR_ENOMEM. */
int plc__read_ply(plc *p, FILE *f, const char *path, pdr_diag *diag);
int plc__read_obj(plc *p, FILE *f, const char *path, pdr_diag *diag);
int plc__read_medit(plc *p, FILE *f, const char *path, pdr_diag *diag);

#endif /* PDR_PLC_INTERNAL_H */
