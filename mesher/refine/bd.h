/*
 * refine/bd.h -- boundary bookkeeping for Delaunay refinement (prefix bd_):
 * subsegments, the facet triangulations and per-vertex history.
 *
 * Shewchuk's algorithm keeps, next to the tetrahedralization T, the set of
 * subsegments (pieces of the input segments) and D, one two-dimensional
 * triangulation per input facet whose triangles are the subfacets. This
 * module is that bookkeeping, with no geometry beyond what a table needs:
 * refine/refine.c decides what to split and keeps T and D consistent.
 *
 * ------------------------------------------------------------ invariants
 * Subsegments. segs[i] joins mesh vertices v[0] < v[1] and lies on input
 * segment 'seg' (an index into plc.segs). The live subsegments of one input
 * segment partition it. seg_map maps the key (v[0], v[1]) of every live
 * subsegment to its index. A live subsegment is PRESENT (no BD_F_MISSING)
 * iff it is an edge of T; then every tetrahedron around that edge, ghosts
 * included, has its TM_F_SUBSEG bit set.
 *
 * Subfacets. facs[i] is a triangle v[0] v[1] v[2] of facet 'facet', counter-
 * clockwise seen from the side facets[facet].normal points to. The live
 * subfacets of one facet triangulate it (a triangulation constrained by the
 * subsegments in it). edge_map maps every directed edge (v[k], v[k+1 mod 3])
 * of every live subfacet to the subfacet: the neighbour of a subfacet
 * across an edge a->b inside the same facet is the subfacet of that facet
 * holding b->a. Two facets may hold the same directed edge (a segment where
 * facets meet), so the map is a multimap. A live subfacet is PRESENT iff it
 * is a face of T; then both tetrahedra sharing that face carry the face
 * marker facet + 1.
 *
 * A subfacet or subsegment that is not present is MISSING. The refinement
 * queues every missing one for splitting; none is missing when the mesh is
 * finished. QUEUED says an entry is on a work queue (so it is queued once).
 * TOLERATED marks an encroached but present one that the refinement decided
 * not to split (the small-angle safety net in refine/refine.c).
 *
 * Vertices. For every mesh vertex: what it lies on (BD_V_* kind and the
 * index of that feature: PLC vertex, plc.segs index, facet index) and its
 * insertion radius (Shewchuk: the length of the shortest edge at the vertex
 * when it was inserted, or the radius the insertion rule gives).
 *
 * Slots of dead subsegments and subfacets are reused through free lists.
 */
#ifndef PDR_BND_H
#define PDR_BND_H

#include <stddef.h>
#include <stdint.h>

#include "base/hmap.h"
#include "base/pdr_error.h"

#define BD_NONE HMAP_NONE

enum {
    BD_F_DEAD = 1u << 0,
    BD_F_MISSING = 1u << 1,
    BD_F_QUEUED = 1u << 2,
    BD_F_TOLERATED = 1u << 3,
    BD_F_VISIT = 1u << 4, /* scratch mark of an algorithm; clear after use */
};

/* What a vertex lies on. */
enum { BD_V_VOLUME = 0, BD_V_INPUT = 1, BD_V_SEGMENT = 2, BD_V_FACET = 3 };

typedef struct bd_subseg {
    uint32_t v[2];  /* v[0] < v[1] */
    uint32_t seg;   /* input segment (plc.segs); next free slot when dead */
    uint16_t flags; /* BD_F_* */
} bd_subseg;

typedef struct bd_subfac {
    uint32_t v[3];  /* counterclockwise about facets[facet].normal */
    uint32_t facet; /* input facet; next free slot when dead */
    uint16_t flags; /* BD_F_* */
} bd_subfac;

typedef struct bd_set {
    bd_subseg *segs;
    size_t nsegs, cap_segs; /* slots used (live + dead), capacity */
    uint32_t seg_free;      /* free list through .seg */
    size_t live_segs;
    bd_subfac *facs;
    size_t nfacs, cap_facs;
    uint32_t fac_free;
    size_t live_facs;
    hmap seg_map;  /* (v0 << 32 | v1), v0 < v1 -> subsegment */
    hmap edge_map; /* (a << 32 | b) directed -> subfacet */
    /* per vertex */
    uint8_t *vkind;
    uint32_t *vfeat;
    float *vrins;
    size_t vcap;
} bd_set;

void bd_init(bd_set *b);
void bd_free(bd_set *b);

/* Makes room for per-vertex data of vertices 0..nv-1 (new entries are
 * BD_V_VOLUME, feature 0, radius 0). Returns 0 or PDR_ENOMEM. */
int bd_vertex_room(bd_set *b, size_t nv);

/* Adds a live, present subsegment of input segment seg (a != b, any
 * order); *out gets its index. Returns 0 or PDR_ENOMEM. */
int bd_add_subseg(bd_set *b, uint32_t a, uint32_t c, uint32_t seg, uint32_t *out);
/* Frees subsegment i (removes it from the map). */
void bd_kill_subseg(bd_set *b, uint32_t i);
/* Counts the live subsegments and subfacets flagged missing. */
void bd_count_missing(const bd_set *b, size_t *segs, size_t *facs);
/* The live subsegment joining a and c, or BD_NONE. */
uint32_t bd_find_subseg(const bd_set *b, uint32_t a, uint32_t c);

/* Adds a live, present subfacet (a, c, d) of facet f, in that order (the
 * caller orients it). Returns 0 or PDR_ENOMEM. */
int bd_add_subfac(bd_set *b, uint32_t a, uint32_t c, uint32_t d, uint32_t f, uint32_t *out);
void bd_kill_subfac(bd_set *b, uint32_t i);
/* The live subfacet with vertices {a, c, d} (any order), or BD_NONE. */
uint32_t bd_find_subfac(const bd_set *b, uint32_t a, uint32_t c, uint32_t d);
/* The live subfacet of the same facet across the edge of subfacet i
 * opposite its vertex slot k, or BD_NONE (boundary of the facet). */
uint32_t bd_subfac_across(const bd_set *b, uint32_t i, int k);
/* Calls fn(arg, subfacet) for every live subfacet having the edge {a, c};
 * stops early and returns fn's value when fn returns nonzero. */
int bd_subfacs_on_edge(const bd_set *b, uint32_t a, uint32_t c,
                       int (*fn)(void *arg, uint32_t subfac), void *arg);

/* Bytes held by the tables (for the memory summary). */
size_t bd_bytes(const bd_set *b);

#endif /* PDR_BND_H */
