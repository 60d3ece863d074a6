/*
 * check/ql.h -- tetrahedron quality measures and mesh statistics (ql_).
 *
 * These are measurements in floating point, not predicates: a decision
 * that must be exact (is this tetrahedron inverted? is it Delaunay?)
 * belongs to the predicates. Accuracy: the circumradius is computed from
 * the edge vectors at one vertex,
 *     c - a = (|u|^2 (v x w) + |v|^2 (w x u) + |w|^2 (u x v)) / (2 u . (v x w)),
 * u = b - a, v = c - a, w = d - a; its relative error is a small multiple
 * of the unit roundoff times the conditioning of the tetrahedron, which is
 * about longest edge^3 / (6 volume): a few ulps for well-shaped elements,
 * and large only for slivers and flat elements, whose ratio is then large
 * anyway (a zero volume gives an infinite radius). Dihedral angles use
 * atan2(|n1 x n2|, n1 . n2), accurate near 0 and 180 degrees where acos is
 * not.
 */
#ifndef PDR_QUALITY_H
#define PDR_QUALITY_H

#include <stddef.h>
#include <stdio.h>

#include "mesh/mesh_export.h"
#include "base/pdr_error.h"

/* Measures of one tetrahedron (a, b, c, d). */
typedef struct ql_tet {
    double volume;       /* signed: (b - a) . ((c - a) x (d - a)) / 6 */
    double circumradius; /* INFINITY when the volume is zero */
    double shortest;     /* shortest edge length */
    double longest;      /* longest edge length */
    double radius_edge;  /* circumradius / shortest edge */
    double dihedral[6];  /* degrees, at edges 01 02 03 12 13 23 */
    double min_dihedral, max_dihedral;
} ql_tet;

void ql_tet_measure(const double a[3], const double b[3], const double c[3],
                    const double d[3], ql_tet *m);

/* Histogram bins: radius-edge ratios from QL_RE_LO in steps of QL_RE_STEP,
 * the last bin open-ended; dihedral angles in 1-degree bins. */
#define QL_RE_LO 0.6
#define QL_RE_STEP 0.1
#define QL_RE_NBINS 25 /* [0.6, 0.7) ... [2.9, 3.0), [3.0, inf) */
#define QL_DIH_NBINS 180

typedef struct ql_stats {
    size_t ntet;
    size_t nboundary;     /* tetrahedra with a face on the boundary */
    size_t npositive;     /* tetrahedra of positive signed volume */
    size_t nnegative;     /* ... negative */
    size_t ndegenerate;   /* ... zero */
    double volume;        /* sum of |volume| */
    double min_volume;    /* smallest |volume| */
    double re_min, re_max;
    double re_bound;      /* the bound the caller asked about */
    size_t re_above;      /* tetrahedra with ratio >= re_bound */
    double dih_min, dih_max;
    double shortest_edge; /* over the whole mesh */
    size_t re_hist[QL_RE_NBINS];
    size_t dih_hist[2][QL_DIH_NBINS]; /* [0] boundary, [1] interior tets */
} ql_stats;

/* Measures every tetrahedron of m. A tetrahedron is a boundary element if
 * one of its faces is among m's triangles or, when m has none, if a face
 * belongs to no other tetrahedron. re_bound (e.g. 2) is only counted
 * against. Returns 0 or PDR_ENOMEM. */
int ql_mesh_stats(const mesh_export *m, double re_bound, ql_stats *s);

/* Writes the summary line and both histograms as text (the paper's fig. 9
 * as a table); dih_bin is the dihedral bin width in degrees (1, 2, 3, 5,
 * ... dividing 180). */
void ql_print(const ql_stats *s, FILE *out, int dih_bin);

/* Writes a self-contained gnuplot script (data inline) that draws the
 * dihedral distributions of boundary and interior elements, like fig. 9,
 * into the PNG file png_path. Returns 0 or PDR_EIO. */
int ql_write_gnuplot(const ql_stats *s, FILE *out, const char *png_path,
                     const char *title, int dih_bin);

/* Runs gnuplot ($PDR_GNUPLOT, else 'gnuplot' from PATH) on such a script
 * and renames its output to png_path only when it succeeded, so the PNG
 * appears whole or not at all. Returns 0, or PDR_EIO with the reason in
 * diag. */
int ql_plot_png(const ql_stats *s, const char *png_path, const char *title,
                int dih_bin, pdr_diag *diag);

#endif /* PDR_QUALITY_H */
