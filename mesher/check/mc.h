/*
 * check/mc.h -- checks of a finished domain mesh against its boundary
 * triangles and its input PLC (prefix mc_), for 'pdr check'.
 *
 * The kernel's verifier (mesh/vf.h) checks a tetrahedralization on its own:
 * topology, orientation, the Delaunay property. A mesh of a domain also
 * has to fit the domain:
 *
 *   boundary   every face that only one tetrahedron has is one of the
 *              boundary triangles (the .face file), and every boundary
 *              triangle is a face of the mesh: the boundary is closed and
 *              described exactly;
 *   facets     every boundary triangle lies in an input facet (its corners
 *              on the facet's plane, its centroid inside the facet), and
 *              the triangles in each facet add up to its area: every input
 *              facet is covered by subfacets;
 *   volume     the tetrahedra add up to the volume of the domain computed
 *              from the PLC alone, by the divergence theorem over the
 *              facets' own triangulations, V = sum over boundary facets of
 *              s * (1/6) a . (b x c); the mesh is consulted only for the
 *              side s (+1, -1 or 0 for an internal facet or one outside
 *              the domain) on which each part of a facet has tetrahedra.
 *
 * Tolerances are relative: 1e-9 of the facet area or domain volume (the
 * mesh's vertices on facets that are not axis-aligned are off the plane by
 * rounding errors), and 1e-9 of the bounding-box diagonal for "on the
 * facet's plane". Areas are compared in projection on the facet's plane,
 * the same for every triangulation of one projected region: a facet's
 * corners may lie off one plane within that 1e-9 of the diagonal, which
 * on a small facet is far more than 1e-9 of its size, and mesh faces that
 * take other diagonals than its triangles then have another area in
 * space. A PLC whose facets are planar only within a larger tolerance T
 * (near-planar facets, plc/fm.h: its planar_tol is T) has mesh faces
 * within T of its triangles: a triangle then lies in a facet when its
 * corners are within 2T (a subfacet's circumcentre may lie off its
 * subfacet) of the facet's plane, and the volumes may differ by the
 * facets' areas times 2T besides. Locating a triangle's facet tests the
 * facets whose bounding box holds it: fast for the model problems,
 * quadratic in the worst case (an STL surface of many thousand facets).
 */
#ifndef PDR_MESHCHECK_H
#define PDR_MESHCHECK_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "plc/plc.h"
#include "mesh/tm.h"

typedef struct mc_report {
    int with_faces, with_plc;
    /* boundary */
    size_t faces;              /* boundary triangles given */
    size_t boundary_faces;     /* faces of exactly one tetrahedron */
    /* facets */
    size_t facets;             /* input facets */
    size_t facets_covered;     /* facets whose area is matched */
    size_t facets_outside;     /* facets with no triangle at all */
    double area_err_max;       /* largest relative area difference */
    /* volume */
    double volume_mesh, volume_plc, volume_err; /* volume_err relative */
    double volume_allow;       /* allowance for near-planar facets (absolute) */
    /* defects: keep every defect counter in this block (mc_defects) */
    size_t faces_not_in_mesh;  /* boundary triangles no tetrahedron has */
    size_t boundary_uncovered; /* boundary faces missing from the list */
    size_t facets_uncovered;   /* facets whose area is not matched */
    size_t faces_off_facet;    /* triangles lying in no input facet */
    size_t volume_mismatch;    /* 1 if the volumes differ */
    size_t facets_lost;        /* facets with no triangle although the
                                  input has no hole points (an empty mesh
                                  has all of them) */
} mc_report;

/* Checks mesh m (vertex i+1 is point i; tetrahedra linked with
 * tm_link_faces, no ghosts) against ntri boundary triangles (0-based point
 * numbers; may be 0) and, when p is not NULL, the validated PLC p.
 * Returns 0 or PDR_ENOMEM. */
int mc_check(const tm_mesh *m, const uint32_t (*tri)[3], size_t ntri, const plc *p,
             mc_report *r);
size_t mc_defects(const mc_report *r);
void mc_print(const mc_report *r, FILE *f);

/* Volume of the domain of p given the side of each part of each facet:
 * side(arg, facet, point) returns +1 if the domain lies on the side the
 * facet normal points away from at that point of the facet (the normal is
 * outward there), -1 if on the side it points to, 0 if on both or
 * neither. Exposed for the unit tests. */
double mc_plc_volume(const plc *p, int (*side)(void *arg, size_t facet, const double x[3]),
                     void *arg);

#endif /* PDR_MESHCHECK_H */
