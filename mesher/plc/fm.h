/*
 * plc/fm.h -- input preparation for tessellated surfaces (prefix fm_):
 * merging coplanar triangles into polygonal facets, and finding the sharp
 * segments and acute vertices that the refinement must treat specially.
 *
 * Why. A closed triangle surface from a CAD tool or a scanner (.stl, .off)
 * makes every triangle its own facet and every triangle edge a segment.
 * On a flat face split into many triangles, segments then meet at 45
 * degrees or less inside the face, and Delaunay refinement's boundary
 * recovery splits them into each other without end (the grid-triangulated
 * cube does that down to the last bit of double precision). Such edges are
 * not features of the shape: TetGen removes them (its 'mergefacets').
 *
 * Merging (fm_merge). Two triangle facets (one polygon of three corners,
 * no facet holes) are merged across their common edge when
 *  - they have the same marker, the edge belongs to no other facet and is
 *    not an explicit segment of the input;
 *  - their dihedral angle at the edge is at least 180 - angle_tol degrees
 *    (TetGen's default tolerance: 179.9 degrees); angle_tol = 0 merges
 *    only triangles that are exactly coplanar (orient3d, exact);
 *  - the new triangle's far corner is exactly coplanar with the triangle
 *    that started the group (orient3d), or within the validator's planar
 *    tolerance (plc.planar_tol times the bounding-box diagonal) of its
 *    plane. Testing against the group's first triangle, not the
 *    neighbour, stops a gently curved surface (a finely tessellated
 *    sphere, every dihedral angle near 180) from merging into one facet.
 * Groups grow breadth first from the lowest-numbered triangle. A group of
 * two or more triangles becomes one facet at the place of its first
 * triangle (same marker and line): its boundary edges, chained into
 * loops in the orientation of the group's triangles, become polygons
 * (the outer loop first), every inner loop gets a facet hole point just
 * inside it, and every vertex of the group on no loop becomes a 1-corner
 * polygon (an isolated vertex of the facet), so that no vertex is left
 * floating on a facet. The facet's triangulation is made again by
 * plc_validate (a constrained Delaunay triangulation), so a merged facet
 * covers exactly the union of its triangles when they are exactly
 * coplanar, and to within the planar tolerance otherwise. A group whose
 * boundary touches itself at a vertex, or that has no single outer loop,
 * is left as it was (its triangles stay facets).
 *
 * Near-planar facets (facet_tol > 0, 'pdr mesh --facet-tol T'). CAD
 * files tessellate curved faces into thin strips whose two triangles lie
 * off one plane only by the rounding of the file's coordinates (six
 * significant digits; a thin triangle magnifies it: up to 1e-5 of the
 * part's size). Exactly, they are two facets; the diagonal between them
 * is then a segment whose corners of 1-4 degrees force tetrahedra of
 * radius-edge ratio far above 2 whatever the mesher does
 * (fm_thin_corners), where TetGen, merging on the dihedral angle alone,
 * treats the strip as one surface and flips or splits its diagonal
 * freely. With facet_tol the groups of the exact criterion above are
 * joined, whole, into bent groups: across an edge that the merge's own
 * tests allow (same marker, no explicit segment, dihedral angle at least
 * 180 - angle_tol: TetGen's 179.9 degrees by default), a neighbouring
 * exact group joins when every corner of it lies within facet_tol times
 * the bounding-box diagonal of the plane of the bent group's first exact
 * group's largest triangle. The distance bound is what TetGen does not
 * have: the angle alone would fold a finely tessellated cylinder into one
 * facet; the distance keeps a facet within T of a plane. What stays
 * exact and consistent:
 *  - Representation. A bent facet is an ordinary facet (polygons, holes,
 *    one plane by Newell's method, a dominant axis), whose corners lie
 *    within T of its plane; plc_derive records the distance of the
 *    farthest as the facet's bend, and the PLC's planar_tol becomes T,
 *    which plc_validate checks and 'pdr check --plc' uses. No input
 *    vertex moves.
 *  - The projection is one-to-one. Everything two-dimensional about a
 *    facet is decided exactly in its projection that drops the dominant
 *    axis (plc_tri's constrained Delaunay triangulation, the refinement's
 *    ref__orient_facet and its point location on facets). A bent group is
 *    accepted only if every one of its triangles turns the same way about
 *    the facet's normal in that projection (exact orient2d) and every
 *    corner lies within T of the facet's own plane (the one plc_derive
 *    computes); otherwise it falls back to its exact groups. So the facet
 *    is the graph of a function over its projected polygons, and any
 *    triangulation of its vertices in the projection lifts to a surface
 *    that covers the same projected region, within T of the input's
 *    triangles.
 *  - The surface is a valid PLC. A merge of exactly coplanar triangles
 *    covers the same points, so fm_prepare skips the intersection tests
 *    when it validates the result; with bent facets it runs them (exact
 *    predicates on the facets' new triangulations), and if the result
 *    does not validate it undoes the whole merge and merges with the
 *    exact criterion only.
 *  - The diagonals inside a bent facet are no segments: no subsegment,
 *    no encroachment protects them, and the mesh's subfacets on the facet
 *    are any triangulation of its vertices (Steiner points included) in
 *    the projection: the boundary of the mesh lies within T of the input
 *    surface, not on it. 'pdr check --plc' compares areas in the
 *    projection on the facet's plane (equal for every triangulation of
 *    the same projected region) and the volume with an allowance of each
 *    bent facet's area times 2T.
 *  - Bent facets are unions of exact facets, so a mesh of the exact
 *    facets conforms to them too and passes the same check: 'pdr mesh'
 *    meshes again with exact facets when the recovery or the refinement
 *    fails with bent ones (cli/cmd_mesh.c; refine/QUALITY.md says where
 *    they are not yet safe).
 * Without facet_tol nothing changes: groups are those of the exact
 * criterion, the PLC's planar_tol stays.
 *
 * Features (fm_features). On a validated PLC: for every segment the
 * smallest dihedral angle between two of its facets (180 for a segment
 * of a single facet or none), and for every vertex the smallest angle
 * between two of its segments. A segment is sharp below FM_SHARP_DIH
 * degrees, a vertex acute below FM_ACUTE_ANG (TetGen 1.6's thresholds):
 * there Shewchuk's angle conditions fail and the refinement does not
 * split pieces into each other (see refine/refine.h). Stored in the PLC
 * as derived data (plc.seg_mindih, plc.v_minang).
 *
 * Ownership: both functions change the PLC in place; it keeps owning
 * everything.
 */
#ifndef PDR_FM_H
#define PDR_FM_H

#include <stddef.h>

#include "base/pdr_error.h"
#include "plc/plc.h"

/* Default angular tolerance of the merge, degrees (TetGen: 179.9). */
#define FM_MERGE_ANGLE 0.1
/* Default distance tolerance of near-planar facets, relative to the
 * bounding-box diagonal (see above); 0: exactly coplanar merges only.
 * The rounding of six-digit CAD files, magnified by their strips'
 * thinness, puts 70-90 % of the strips within 1e-6 and most of the rest
 * within 1e-5 (up to 1e-4 on some). 1e-5 since 2026-11-27 (it was 1e-6,
 * when sh2.stl ran on with 1e-5): on CGAL's parts it leaves 7 % fewer
 * tetrahedra above ratio 2 than 1e-6 in 4 % fewer tetrahedra, nothing
 * that meshed stops, and the generated corpus is unchanged; 3e-5 and
 * 1e-4 lower the leftovers further on some parts but run past 30 s on
 * others (propeller.stl, mpi_triang.off). refine/QUALITY.md has the
 * measurements. */
#define FM_FACET_TOL 1e-5
/* Thresholds of fm_features, degrees. */
#define FM_SHARP_DIH 72.0
#define FM_ACUTE_ANG 60.0
/* A segment whose facets all meet at this many degrees or more is a
 * crease of a tessellated curved surface rather than a feature of the
 * shape (gmsh's OpenCASCADE tessellations: mostly 150-180 degrees there,
 * 70-110 at the parts' real edges; the paper's tee has real 120-degree
 * edges); such an input is meshed in the constrained mode, which does not
 * split pieces next to these creases for one another
 * (refine/refine_cdt.c). */
#define FM_SMOOTH_DIH 150.0
/* A vertex where two segments meet below this many degrees is a needle
 * point (the pole of a UV sphere, the apex of a fan), unlike the 30-60
 * degree corners every triangulated surface has: splits of the pieces
 * around it can cascade into it, and the constrained refinement keeps
 * its full floor there (refine/refine_run.c, split_instead). */
#define FM_NEEDLE_ANG 20.0

typedef struct fm_stats {
    size_t facets_before;    /* facets of the input */
    size_t facets_after;     /* facets after merging */
    size_t triangles_merged; /* triangles now part of a merged facet */
    size_t groups_kept;      /* groups left unmerged (pinched boundary) */
    size_t sharp_segments;   /* after fm_features */
    size_t acute_vertices;
    size_t smooth_segments;  /* at FM_SMOOTH_DIH or more, between two facets */
    size_t bent_facets;      /* merged facets planar only within facet_tol */
    size_t bent_regrouped;   /* bent groups refused (projection, plane) and
                                grouped again exactly */
    int bent_undone;         /* the bent merge made an invalid PLC: undone */
} fm_stats;

/* Merges coplanar neighbouring triangle facets of p (see above), with the
 * angular tolerance angle_tol in degrees, >= 0, and the distance
 * tolerance facet_tol (relative to the bounding-box diagonal; at most
 * p->planar_tol: exactly coplanar only). p must be derived (plc_derive or
 * plc_validate); afterwards its derived data is dropped: call
 * plc_validate again. When bent facets were made, p->planar_tol becomes
 * facet_tol. st (may be NULL) receives the counts. Returns 0 or
 * PDR_ENOMEM (p then unchanged). */
int fm_merge(plc *p, double angle_tol, double facet_tol, fm_stats *st);

/* Fills p->seg_mindih and p->v_minang of the validated PLC p and counts
 * the sharp segments and acute vertices into st (may be NULL). Returns 0
 * or PDR_ENOMEM. */
int fm_features(plc *p, fm_stats *st);

/* The whole preparation of a validated PLC p, as 'pdr mesh' does it and
 * 'pdr check --plc' repeats it (so that a mesh is compared with the
 * facets the mesher was given): fm_merge with merge_angle degrees (none
 * when merge_angle is negative) and facet_tol, plc_validate again when
 * anything was merged (with the intersection tests when facets are
 * bent; if they fail, the merge again without facet_tol), fm_features.
 * st receives the counts. Returns 0, PDR_EGEOMETRY (messages in diag) or
 * PDR_ENOMEM. */
int fm_prepare(plc *p, double merge_angle, double facet_tol, fm_stats *st, pdr_diag *diag);

/* The corners of facets of p whose angle inside the facet is below
 * max_angle degrees, counted on facets bounded by one polygon of three
 * or more corners and without holes (other polygons of one or two
 * corners, which only cut the facet, allowed). Each forces a bad
 * tetrahedron: the facet's triangles at such a corner have an angle of at
 * most max_angle there, and a tetrahedron on a face whose angle at a
 * vertex is a has a circumradius at least that face's, |opposite edge| /
 * (2 sin a), so a radius-edge ratio of at least 1/(2 sin a), whatever the
 * mesher does, unless it changes the facets. For B = 1/(2 sin(max_angle)),
 * every mesh of these facets has a tetrahedron of ratio >= B at each such
 * corner, on the domain's side. Needs the derived PLC (plc_validate). */
size_t fm_thin_corners(const plc *p, double max_angle);

#endif /* PDR_FM_H */
