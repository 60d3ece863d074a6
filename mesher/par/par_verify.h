/*
 * par/par_verify.h -- consistency checks of submeshes (prefix
 * par_verify_): what must hold of one PE's par_sub on its own, and of the
 * interface faces of all PEs together. For tests, the decomposition and
 * debugging runs; every check counts, none stops at the first problem.
 *
 * On one submesh (par_verify_sub):
 *  - every local link is symmetric, joins the same face seen from its two
 *    sides (opposite orientations) and both sides carry the same marker;
 *  - every TM_LINK_REMOTE(k) names a live interface entry whose local
 *    side is that face, and every live entry is named by its local side
 *    and holds that face's key;
 *  - no face is left without a neighbour (TM_LINK_NONE): ghosts close the
 *    hull and the rest is interface;
 *  - gid[0] is PAR_GID_INF and vmap maps every other vertex's gid back to
 *    it; every tetrahedron's vertices exist;
 *  - nlive, nghost and live_ifc agree with a recount.
 * Across the submeshes of PEs 0..n-1 (par_verify_all, which also runs the
 * above on each): an interface face on PE a naming PE b is an interface
 * face of b with the same key naming a, seen from the other side, with the
 * same marker.
 */
#ifndef PDR_PAR_VERIFY_H
#define PDR_PAR_VERIFY_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "par/par_sub.h"

typedef struct par_verify_report {
    size_t asym_links;       /* local link not returned, or to a dead slot */
    size_t misoriented;      /* linked faces not opposed or marked unequally */
    size_t bad_remote;       /* remote link without a live entry pointing back */
    size_t stale_ifaces;     /* live entry not linked from its side, or wrong key */
    size_t open_faces;       /* faces with no neighbour at all */
    size_t bad_vertices;     /* gid/vmap disagreements, vertices out of range */
    size_t bad_counts;       /* nlive, nghost or live_ifc wrong, or a
                                lock's summary bit (tm_set_lock) */
    size_t unmatched_ifaces; /* no interface back from the PE named */
    size_t marker_mismatch;  /* the two sides of an interface face differ */
} par_verify_report;

/* Sum of the counts. */
size_t par_verify_total(const par_verify_report *rep);
/* Checks s alone, adding to *rep (zero it first). Returns the number of
 * problems found in this call. */
size_t par_verify_sub(const par_sub *s, par_verify_report *rep);
/* Checks subs[0..n-1], subs[k] being PE k's submesh, alone and together,
 * adding to *rep. Returns the number of problems found. */
size_t par_verify_all(const par_sub *subs, uint32_t n, par_verify_report *rep);

/* The facet triangulations of s: every present subfacet has, across each
 * of its edges, a subfacet of the same facet, unless that edge is a
 * subsegment or some tetrahedron around it lies on another PE (where
 * the neighbour may be). A gap means part of a facet has no subfacets.
 * Writes one line per gap to log (if not NULL); returns the count. */
size_t par_verify_facets(const par_sub *s, FILE *log);

#endif /* PDR_PAR_VERIFY_H */
