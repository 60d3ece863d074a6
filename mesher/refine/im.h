/*
 * refine/im.h -- the initial conforming Delaunay mesh Mo (prefix im_).
 *
 * Two constructions, both ending with every input segment and facet a union
 * of edges and faces of a Delaunay tetrahedralization (conforming), no
 * subsegment or subfacet encroached, and the tetrahedra outside the domain
 * and in its holes flagged exterior:
 *
 *  - general (default): the Delaunay tetrahedralization of the input
 *    vertices, then Shewchuk's recovery: missing or encroached subsegments
 *    are split (midpoints, or power-of-two shells around input vertices
 *    where segments meet at acute angles), then missing or encroached
 *    subfacets at their circumcentres, a circumcentre that would encroach a
 *    subsegment being rejected for that subsegment's split. It takes any
 *    valid PLC, including those that break the angle conditions of the
 *    paper's construction (the tee's 60-degree dihedral angles).
 *
 *  - the paper's Mo (Nave et al. section 2.1): with d the smallest distance
 *    between two unrelated (disjoint) input features divided by sqrt 2,
 *    subsegments are split until shorter than 2d and subfacets until their
 *    circumradius is below d sqrt 2; all those vertices are in the Delaunay
 *    tetrahedralization. For inputs that meet the paper's angle conditions
 *    that alone conforms; otherwise the general recovery finishes the job.
 *    Computing d compares every pair of features: O(n^2) in the size of
 *    the PLC, meant for the small model problems (seconds for a few
 *    thousand facets).
 *
 * Then exterior and hole tetrahedra are flagged by flood fill from the
 * convex hull and from every hole point, never crossing a subfacet, and
 * region attributes spread the same way from region points.
 *
 * For the parallel mesher (the paper builds an Mo of about 100k
 * tetrahedra and partitions it), im_mo_size() refines the conforming mesh
 * with a volume bound alone until it has about the requested number of
 * tetrahedra.
 */
#ifndef PDR_INITMESH_H
#define PDR_INITMESH_H

#include <stddef.h>

#include "base/pdr_error.h"
#include "refine/refine.h"

typedef struct im_opts {
    int paper; /* build the paper's Mo (sizes from d) */
    double d;  /* > 0: use this d instead of computing it */
    /* The constrained mode: recover the segments first, while no facet is
     * a constraint (refine/refine_segrec.c), and narrow the 2D cavity of a
     * split whose constrained cavity cannot delete all of it
     * (refine_cdt.c). Off by default: the CLI retries with it when the
     * recovery stops on such a split (cli/mesh_pipeline.c), so that what
     * meshes without it keeps its output. */
    int segments_first;
} im_opts;

/* The bound on the points of the constrained recovery (im_build): this
 * many per input vertex and IM_RECOVERY_BASE more. */
#define IM_RECOVERY_PER_VERTEX 5
#define IM_RECOVERY_BASE 2000

typedef struct im_stats {
    double d;               /* the paper's d (0 when not computed) */
    size_t input_vertices;  /* PLC vertices inserted */
    size_t seg_points;      /* vertices added on segments */
    size_t fac_points;      /* vertices added on facets */
    size_t tets;            /* interior tetrahedra of Mo */
    size_t unreached_regions; /* region points outside the domain */
    double delaunay_seconds, recovery_seconds, classify_seconds;
} im_stats;

/* Builds Mo for r's PLC into r's (empty) mesh. Returns 0, PDR_EGEOMETRY
 * (fewer than four affinely independent vertices: message in diag),
 * PDR_ENOMEM, PDR_ELIMIT or PDR_ETOPOLOGY. Warnings (a region point
 * outside the domain) go to diag too. */
int im_build(ref_mesher *r, const im_opts *o, im_stats *st, pdr_diag *diag);

/* The paper's d: the smallest distance between two disjoint features of p
 * (vertices, segments, facets), divided by sqrt 2; INFINITY if there is
 * no such pair. p must be validated. */
double im_paper_d(const plc *p);

/* Refines the conforming, classified mesh with a volume bound alone until
 * it has about ntets interior tetrahedra (the volume bound is the domain
 * volume over ntets, scaled by a measured factor). */
int im_mo_size(ref_mesher *r, size_t ntets);

/* Volume of the interior tetrahedra. */
double im_interior_volume(const ref_mesher *r);

#endif /* PDR_INITMESH_H */
