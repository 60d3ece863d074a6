/*
 * plc/plc.h -- piecewise linear complexes: the input of the mesher.
 *
 * A PLC is a set of vertices, segments and facets (Shewchuk; TetGen's .poly
 * model). A facet is a planar straight-line graph given, as in TetGen, by a
 * list of polygons and a list of hole points in its plane: a polygon with 3
 * or more corners bounds part of the facet (or a hole in it, when a hole
 * point lies inside), one with 2 corners is a segment inside the facet and
 * one with 1 corner an isolated vertex of the facet. The volume may have hole
 * points (tetrahedra reachable from them without crossing a facet are
 * removed) and region points (attribute and maximum volume for the
 * tetrahedra of the region around them).
 *
 * Ownership: one plc struct owns every array below. plc_init() makes an
 * empty PLC, plc_free() releases everything and leaves an empty PLC.
 *
 * Invariants of the input part (kept by the builders and the readers):
 *  - every corner and segment endpoint is a vertex index < nv;
 *  - facets[f] owns polys[poly_first .. poly_first + npoly - 1] and
 *    fholes[hole_first .. hole_first + nhole - 1]; the ranges of successive
 *    facets are consecutive, so the facets partition polys and fholes;
 *  - polys[p] owns corners[first .. first + n - 1], n >= 1, and the ranges
 *    partition corners;
 *  - every facet has at least one polygon with 3 or more corners (a .poly
 *    facet made only of 1- and 2-corner polygons is read as free segments);
 *  - vmarker is NULL or has nv entries; vattr is NULL or has nv * nvattr.
 * Line numbers (vline, poly and facet lines, ...) are 1-based lines of the
 * file the item was read from, or 0 when unknown (binary STL, built in
 * memory). Vertex lines refer to vfile, everything else to path.
 *
 * Invariants of the derived part (valid when 'derived' is nonzero; filled
 * by plc_derive(), which plc_validate() calls):
 *  - facets[f].normal is a unit vector (Newell's method on the polygon of
 *    largest area), offset = normal . x on that polygon's centroid, and
 *    axis = argmax |normal[i]| (the coordinate dropped to project the facet
 *    to 2D without degeneracy), and bend the largest distance of a corner
 *    from that plane (near-planar facets, plc/fm.h, have one above
 *    rounding: plc_facet_bent);
 *  - segs holds every explicit segment and every polygon edge of every
 *    facet, once each, with v[0] < v[1], sorted by (v[0], v[1]);
 *    seg_facets[seg_fstart[s] .. seg_fstart[s+1]-1] are the facets (sorted,
 *    distinct) having segment s as a polygon edge (none for a free segment);
 *  - v_segs[v_sstart[v] .. v_sstart[v+1]-1] are the segments incident to
 *    vertex v and v_facets[v_fstart[v] .. v_fstart[v+1]-1] the facets having
 *    v as a corner (sorted, distinct);
 *  - bbox is the bounding box of all vertices.
 * seg_mindih and v_minang belong to the derived data too, filled only by
 * fm_features (plc/fm.h).
 * After a successful plc_validate() also:
 *  - ftri[ftri_start[f] .. ftri_start[f+1]-1] triangulate facet f exactly
 *    (a constrained Delaunay triangulation of its polygons and segments,
 *    holes and the outside removed), with PLC vertex indices, oriented so
 *    that each triangle's normal points along facets[f].normal.
 */
#ifndef PDR_PLC_H
#define PDR_PLC_H

#include <stddef.h>
#include <stdio.h>
#include <stdint.h>

#include "base/pdr_error.h"

typedef struct plc_polygon {
    size_t first; /* first corner in plc.corners */
    uint32_t n;   /* number of corners, >= 1 */
    long line;    /* line of the polygon in path, 0 if unknown */
} plc_polygon;

typedef struct plc_facet {
    size_t poly_first, npoly; /* polygons in plc.polys */
    size_t hole_first, nhole; /* hole points in plc.fholes */
    int marker;               /* boundary marker, 0 if none */
    long line;                /* line of the facet header in path */
    /* derived */
    double normal[3]; /* unit normal */
    double offset;    /* plane: normal . x == offset */
    int axis;         /* dominant axis of normal */
    double bend;      /* largest distance of a corner from the plane */
} plc_facet;

typedef struct plc_segment {
    uint32_t v[2]; /* endpoints */
    int marker;    /* 0 if none */
    long line;     /* 0 if unknown or derived from a polygon */
} plc_segment;

typedef struct plc_point {
    double xyz[3];
    long line;
} plc_point;

typedef struct plc_region {
    double xyz[3];
    double attr;   /* region attribute */
    double maxvol; /* maximum tetrahedron volume, <= 0 for none */
    long line;
} plc_region;

typedef struct plc {
    char *path;  /* owned; the file read, used in messages ("" in memory) */
    char *vfile; /* owned; file the vertices came from (path or its .node) */
    int base;    /* index of the first vertex in the file: 0 or 1 */

    size_t nv, cap_v;
    double (*xyz)[3]; /* vertex coordinates */
    int *vmarker;     /* NULL or nv vertex boundary markers */
    size_t nvattr;    /* attributes per vertex */
    double *vattr;    /* NULL or nv * nvattr attributes */
    long *vline;      /* nv lines in vfile */

    size_t ncorner, cap_corner;
    uint32_t *corners;
    size_t npoly, cap_poly;
    plc_polygon *polys;
    size_t nfacet, cap_facet;
    plc_facet *facets;
    size_t nfhole, cap_fhole;
    plc_point *fholes; /* facet hole points */

    size_t nsegin, cap_segin;
    plc_segment *segin; /* explicit (free) segments */
    size_t nhole, cap_hole;
    plc_point *holes; /* volume hole points */
    size_t nregion, cap_region;
    plc_region *regions;

    /* Derived data, see the invariants above. */
    int derived;
    double bbox[2][3];
    size_t nseg;
    plc_segment *segs;
    size_t *seg_fstart;  /* nseg + 1 */
    uint32_t *seg_facets;
    size_t *v_sstart;    /* nv + 1 */
    uint32_t *v_segs;
    size_t *v_fstart;    /* nv + 1 */
    uint32_t *v_facets;
    size_t *ftri_start;  /* nfacet + 1, NULL until validated */
    uint32_t (*ftri)[3];
    /* Features (plc/fm.h, fm_features), NULL until computed: the smallest
     * dihedral angle in degrees between two facets of each segment (180
     * with fewer than two), and the smallest angle between two segments
     * at each vertex (180 with fewer than two). */
    float *seg_mindih;   /* nseg */
    float *v_minang;     /* nv */

    /* Validation setting: a facet is planar when every corner is within
     * planar_tol times the bounding-box diagonal of its plane. plc_init()
     * sets PLC_PLANAR_TOL. */
    double planar_tol;
    /* Validation setting: do not test facets and segments for
     * intersections (fm_prepare's second validation: a merge of coplanar
     * triangles into polygons covers the same points, so it makes none);
     * plc_init() sets 0. */
    int skip_intersections;
    /* 1 when read from a surface file (.off, .stl, .ply, .obj, .mesh):
     * closed triangle surfaces as CAD tools and scanners export them. */
    int surface_input;
    /* What the surface readers mended (plc/plc_surf.c):
     * faces dropped because their corners are fewer than three distinct
     * vertices, polygons that were not planar cut into triangles. */
    size_t read_dropped, read_split;
    /* ... and vertices merged into an equal one before them; vnum
     * (NULL unless some were) gives each vertex its number in the file. */
    size_t read_welded;
    long *vnum;
    size_t nvnum, cap_vnum;
} plc;

/* Relative flatness tolerance of facets (TetGen-like; see plc_validate). */
#define PLC_PLANAR_TOL 1e-9

/* ------------------------------------------------------------ life cycle */

/* Makes an empty PLC whose messages name 'path' (may be NULL). Returns 0 or
 * PDR_ENOMEM. */
int plc_init(plc *p, const char *path);
/* Releases every array and leaves p empty (safe on an empty PLC). */
void plc_free(plc *p);

/* ----------------------------------------------------------- building it */

/* Each returns 0 or PDR_ENOMEM (PDR_EINVAL on a bad index). Builders drop
 * the derived data. */

/* Appends a vertex (marker 0, attributes 0; set vmarker[]/vattr[] after
 * plc_enable_vmarkers). *index receives its index (index may be NULL);
 * PDR_ELIMIT beyond 2^32 - 2 vertices. */
int plc_add_vertex(plc *p, const double xyz[3], long line, uint32_t *index);
int plc_enable_vmarkers(plc *p);
/* Starts a new facet; the following polygons and facet holes belong to it. */
int plc_begin_facet(plc *p, int marker, long line);
/* Appends a polygon of n >= 1 corners to the current facet. */
int plc_add_polygon(plc *p, const uint32_t *corners, uint32_t n, long line);
/* Appends a hole point to the current facet. */
int plc_add_facet_hole(plc *p, const double xyz[3], long line);
/* Appends a free segment, a volume hole point, a region. */
int plc_add_segment(plc *p, uint32_t a, uint32_t b, int marker, long line);
int plc_add_hole(plc *p, const double xyz[3], long line);
int plc_add_region(plc *p, const double xyz[3], double attr, double maxvol,
                   long line);

/* -------------------------------------------------------------- reading */

/* Reads a PLC from path; the format follows the extension:
 *   .poly   TetGen PLC (points inline, or in the .node file of the same base
 *           name when the point count is 0), facets with polygons, facet
 *           holes and markers, volume holes, regions;
 *   .smesh  TetGen's simple variant: one polygon per facet, no facet holes;
 *   .off    Geomview OFF: every face is a facet (0-based indices);
 *   .stl    ASCII or binary STL: every triangle is a facet, vertices with
 *           equal coordinates are merged.
 * p must be empty (plc_init). On failure returns PDR_EIO, PDR_EPARSE,
 * PDR_EUNSUPPORTED or PDR_ENOMEM with "file:line: ..." messages in diag,
 * and p holds whatever was read (free it). Reading does not validate the
 * geometry: call plc_validate(). See plc/plc_read.c for the format details
 * and limitations. */
int plc_read(plc *p, const char *path, pdr_diag *diag);
/* The same from an open stream (read from its start, not closed; it must
 * be seekable to tell binary STL by its size). path names the input in
 * messages, its extension picks the format, and a .poly/.smesh with a
 * vertex count of 0 reads the .node file next to it. */
int plc_read_stream(plc *p, FILE *f, const char *path, pdr_diag *diag);

/* Writes p as a TetGen .poly (1-based, facet markers, holes, regions),
 * atomically. Returns 0, PDR_EIO or PDR_ENOMEM with a message in diag. */
int plc_write_poly(const plc *p, const char *path, pdr_diag *diag);

/* ---------------------------------------------------- derived and checks */

/* Computes the derived data (planes, segments, incidences, bbox). Returns 0,
 * PDR_ENOMEM, or PDR_EGEOMETRY when a facet has no polygon of nonzero area
 * (a message names it). Idempotent. */
int plc_derive(plc *p, pdr_diag *diag);

/* Checks that p is a valid PLC for meshing, reporting every problem found
 * as "file:line: ..." in diag:
 *  - duplicate vertices (exactly equal coordinates);
 *  - polygons with a vertex repeated, or with 3+ corners and zero area;
 *  - free segments of zero length;
 *  - non-planar facets: a corner farther than planar_tol times the bounding
 *    box diagonal from the facet plane;
 *  - crossing segments inside a facet, and vertices in a facet that
 *    coincide when projected to its plane;
 *  - open boundaries: an edge of a facet (after triangulation) that no
 *    other facet has, i.e. a surface edge used by exactly one facet;
 *  - intersecting facets and segments: two facets (or a free segment and a
 *    facet or segment) meeting anywhere except at shared vertices and shared
 *    edges. A vertex inside another facet or on another facet's edge counts
 *    as an intersection; exact predicates decide.
 * Checks run in stages; a stage runs only if the previous ones passed, so
 * the messages describe causes, not consequences. Returns 0 (p's derived
 * data and facet triangulations are then valid), PDR_EGEOMETRY or
 * PDR_ENOMEM. */
int plc_validate(plc *p, pdr_diag *diag);

/* 1 if facet f of the derived PLC p is near-planar (plc/fm.h): p's
 * planar_tol is above PLC_PLANAR_TOL (a merge with a facet tolerance made
 * it so) and a corner of f lies farther than PLC_PLANAR_TOL times the
 * bounding-box diagonal from its plane. Mesh faces on such a facet lie
 * within planar_tol of it, not on its triangles. */
int plc_facet_bent(const plc *p, size_t f);
/* The area of the projection of triangle abc on facet f's plane: how a
 * facet's coverage is measured, the same for every triangulation of one
 * projected region. A facet's corners may lie off one plane by rounding
 * or by a merge's tolerance (a bent facet, or one within PLC_PLANAR_TOL),
 * and triangles that take other diagonals than the input's then have
 * another area in space; on an exactly planar facet it is the area. */
double plc_facet_proj_area(const plc *p, size_t f, const double *a, const double *b,
                           const double *c);

/* The number the input file uses for vertex v (index plus base). */
static inline long plc_vnum(const plc *p, uint32_t v)
{
    return v < p->nvnum ? p->vnum[v] : (long)v + p->base;
}

#endif /* PDR_PLC_H */
