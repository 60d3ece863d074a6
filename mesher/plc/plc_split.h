/*
 * plc/plc_split.h -- splitting the input segments that every mesh with a
 * radius-edge bound must split: a segment along a thin facet.
 *
 * Why. A facet whose corners all lie within W of the line of one of its
 * segments s (a strip of a tessellated cylinder: 1 long, 0.03 wide) gives
 * every mesh a boundary triangle on each piece of s, with its third corner
 * in the facet, at most W from the piece. A triangle with a side of length
 * l and height h over it has circumradius ab / (2h) >= l / (2h) times half
 * (a, b its other sides, the larger at least l / 2) and a shortest side at
 * most a and b, so a radius-edge ratio of at least l / (4h) >= l / (4W);
 * a tetrahedron on it has a circumradius at least the triangle's and a
 * shortest edge at most its. So in every mesh whose tetrahedra have
 * radius-edge ratios below B, every piece of s is shorter than 4 B W: s is
 * split into at least len / (4 B W) pieces, whatever the mesher.
 *
 * The constrained refinement (refine/refine_cdt.c) makes those splits late
 * and one at a time, each where a bad tetrahedron asks for it; a split
 * point in the middle of a long segment lies inside the diametral balls of
 * the long segments across the thin walls next to it, which are then no
 * longer strongly Delaunay, the constrained Delaunay tetrahedralization
 * may cease to exist, and the flips after the insertion leave faces that
 * no flip mends (mesher/refine/QUALITY.md, "pipe.off"). Made before the
 * Delaunay tetrahedralization of the input, as input vertices, the same
 * splits cost nothing of that: the recovery then starts from them.
 *
 * plc_split_long puts those points in: each segment that is no small
 * angle's (not sharp, neither end acute: plc/fm.h, FM_SHARP_DIH and
 * FM_ACUTE_ANG; the refinement leaves what is next to small angles
 * anyway) and lies on at least one facet is cut into the fewest equal
 * pieces shorter than PLC_SPLIT_FACTOR B W, W the smallest over its
 * facets of the largest distance of a facet corner from its line, at
 * most max_pieces pieces. The factor is 3, not the 4 of the bound: at
 * most a third more pieces than every mesh needs, and the refinement's
 * own splits of them then come out better on the measured cylinders
 * (bench/surfaces.md: CGAL's pipe 0 left above 2 with 3, 1 with 4;
 * joint 2 and 10; strips-48 of the generated corpus 9,332 tetrahedra
 * and none left with 3, 11,276 and 2 with 4, 9,639 and none without the
 * cut). The points become vertices of the PLC (after the others), and
 * corners of every polygon that has s as an edge, between its ends; an
 * explicit segment that is s is cut the same way. Nothing moves, so the
 * facets cover the same points.
 *
 * Ownership: works in place on p, which must be validated with its
 * features (fm_prepare); the new polygons are built aside and put in only
 * once every vertex is added. On success p is validated again and has
 * its features; on failure its facets and segments are unchanged, but it
 * may have lost its derived data and have some of the new vertices
 * (unused).
 */
#ifndef PDR_PLC_SPLIT_H
#define PDR_PLC_SPLIT_H

#include <stddef.h>

#include "base/pdr_error.h"
#include "plc/plc.h"

/* Pieces shorter than this times B W (see above). */
#define PLC_SPLIT_FACTOR 3.0

/* The most pieces a segment is cut into (a guard against a degenerate
 * facet: no segment of the measured inputs needs more than 20). */
#define PLC_SPLIT_MAX_PIECES 64

typedef struct plc_split_stats {
    size_t segments; /* segments cut */
    size_t points;   /* vertices added */
} plc_split_stats;

/* See above. B > 1 is the radius-edge bound; max_pieces >= 2. Returns 0
 * (st filled; nothing changed when st->segments is 0), PDR_EINVAL (p not
 * prepared, B or max_pieces out of range), PDR_EGEOMETRY (the validation
 * afterwards failed: a message in diag) or PDR_ENOMEM. */
int plc_split_long(plc *p, double B, size_t max_pieces, plc_split_stats *st, pdr_diag *diag);

/* 1 if the prepared PLC p (with its features) has a sharp segment or an
 * acute vertex (plc/fm.h), or no features: where 'pdr mesh' cuts no
 * segment by default (--presplit auto). */
int plc_small_angles(const plc *p);

#endif /* PDR_PLC_SPLIT_H */
