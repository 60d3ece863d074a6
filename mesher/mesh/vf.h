/*
 * mesh/vf.h -- exact checks of a tetrahedral mesh (prefix vf_).
 *
 * vf_check() re-verifies a tm_mesh with exact predicates and counts every
 * defect by kind, so a test or 'pdr check' can say what is wrong and how
 * often, not only that something is. It is organised in sections (bits of
 * 'what'); each section fills its own fields of vf_report:
 *
 *   VF_TOPOLOGY     vertex numbers valid and distinct in each tet; every
 *                   link leads to a live tet that links back across a face
 *                   with the same three vertices; counts of interior,
 *                   hull, domain-boundary and remote faces.
 *   VF_ORIENTATION  every real tet positively oriented; across every
 *                   interior face the two opposite vertices lie strictly on
 *                   opposite sides (no fold), also across hull faces.
 *   VF_DELAUNAY     every interior face locally Delaunay: the vertex across
 *                   it is not strictly inside the tet's circumsphere
 *                   (cospherical is allowed).
 *   VF_HULL         with ghosts: every ghost face around a hull edge is
 *                   linked (the hull is closed) and the hull is locally
 *                   convex at every edge (coplanar hull faces allowed).
 *   VF_VERTICES     every vertex is used by a tet or equals one that is (a
 *                   skipped duplicate).
 *   VF_COVER        a few probe points strictly inside tets are covered by
 *                   exactly one tet: together with the local checks this
 *                   rules out a mesh that covers the domain twice.
 *
 * Adding a section (quality, dihedral angles, facet coverage, volume):
 * add a VF_ bit, its fields to vf_report (defects in the "defects" block so
 * vf_defects() counts them), a static function in mesh/vf.c called from
 * vf_check(), and its lines in vf_print().
 */
#ifndef PDR_VERIFY_H
#define PDR_VERIFY_H

#include <stddef.h>
#include <stdio.h>

#include "mesh/tm.h"

enum {
    VF_TOPOLOGY = 1u << 0,
    VF_ORIENTATION = 1u << 1,
    VF_DELAUNAY = 1u << 2,
    VF_HULL = 1u << 3,
    VF_VERTICES = 1u << 4,
    VF_COVER = 1u << 5,
    VF_ALL = 0x3fu,
    /* with VF_DELAUNAY: a face carrying a face mark (a constraint) need
     * not be locally Delaunay: the test of a constrained Delaunay
     * tetrahedralization. Not in VF_ALL. */
    VF_CONSTRAINED = 1u << 6,
};

typedef struct vf_report {
    unsigned checked; /* VF_ bits that ran */
    /* census */
    size_t vertices;       /* real vertices (nv - 1) */
    size_t used_vertices;  /* vertices of at least one live tet */
    size_t tets;           /* live real tetrahedra */
    size_t ghosts;         /* live ghost tetrahedra */
    size_t interior_faces; /* real-real faces */
    size_t hull_faces;     /* real-ghost faces */
    size_t domain_faces;   /* real faces with TM_LINK_NONE */
    size_t remote_faces;   /* faces with TM_LINK_REMOTE */
    size_t duplicates;     /* unused vertices equal to a used one */
    size_t probes;         /* VF_COVER probe points tried */
    /* defects: keep every defect counter in this block (vf_defects) */
    size_t bad_vertex;     /* out of range, repeated, misplaced vertex 0 */
    size_t bad_link;       /* dead/out-of-range/asymmetric link */
    size_t face_mismatch;  /* linked faces with different vertices */
    size_t nonmanifold;    /* faces in > 2 tets (set by the mesh builder) */
    size_t inverted;       /* orient3d < 0 */
    size_t flat;           /* orient3d == 0 */
    size_t folded;         /* both opposite vertices on one side of a face */
    size_t not_delaunay;   /* interior faces failing the insphere test */
    size_t open_hull;      /* hull edges not in exactly two hull faces */
    size_t nonconvex_hull; /* hull edges where the hull is reflex */
    size_t isolated;       /* vertices in no tet that are not duplicates */
    size_t overlaps;       /* probe points covered by != 1 tets */
} vf_report;

/* Runs the sections in 'what' on m and adds their counts to *r (zero it
 * first; a mesh builder may have put nonmanifold/open_hull counts in it).
 * Returns 0 or PDR_ENOMEM. */
int vf_check(const tm_mesh *m, unsigned what, vf_report *r);
/* Sum of the defect counters. */
size_t vf_defects(const vf_report *r);
/* Human-readable report, one line per count, defects marked. */
void vf_print(const vf_report *r, FILE *f);

#endif /* PDR_VERIFY_H */
