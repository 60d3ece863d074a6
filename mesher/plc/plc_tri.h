/*
 * plc/plc_tri.h -- constrained Delaunay triangulation of one PLC facet.
 *
 * The facet's corners are projected to 2D by dropping the dominant axis of
 * its normal (the projected coordinates are exact copies of two input
 * coordinates, so exact 2D predicates decide exactly on the projection).
 * The triangulation is built by incremental insertion with Lawson flips
 * inside a large enclosing triangle, every polygon edge is then inserted as
 * a constraint by flipping away the edges it crosses (Sloan's method),
 * Delaunay flips restore the constrained Delaunay property, and the
 * triangles outside the outer boundary or reachable from a facet hole point
 * without crossing a constraint are removed, as TetGen does.
 *
 * A workspace is reused from facet to facet; plc_cdt_free() releases it.
 */
#ifndef PDR_PLC_TRI_H
#define PDR_PLC_TRI_H

#include <stddef.h>
#include <stdint.h>

#include "plc/plc.h"

enum plc_cdt_error {
    PLC_CDT_OK = 0,
    PLC_CDT_COINCIDENT, /* v[0], v[1] project to the same point */
    PLC_CDT_ON_SEGMENT, /* vertex v[2] lies inside segment (v[0], v[1]) */
    PLC_CDT_CROSSING    /* segments (v[0], v[1]) and (v[2], v[3]) cross */
};

typedef struct plc_cdt_fail {
    enum plc_cdt_error kind;
    uint32_t v[4]; /* PLC vertex indices */
} plc_cdt_fail;

struct plc_cdt_tri; /* private */

typedef struct plc_cdt {
    /* output: triangles of the last facet, PLC vertex indices, oriented
     * along the facet normal */
    uint32_t (*out)[3];
    size_t nout, cap_out;
    /* private workspace */
    struct plc_cdt_tri *t;
    size_t nt, cap_t;
    double (*pt)[2];
    uint32_t *gid, *vtri, *stack;
    size_t cap_pt, cap_stack;
    uint64_t *edges;
    size_t nedges, cap_edges;
    uint32_t rng;
} plc_cdt;

/* Triangulates facet f of p (whose planes must be derived). Returns 0,
 * PDR_ENOMEM, or PDR_EGEOMETRY with *fail describing why. */
int plc_cdt_facet(plc_cdt *w, const plc *p, size_t f, plc_cdt_fail *fail);
void plc_cdt_free(plc_cdt *w);

#endif /* PDR_PLC_TRI_H */
