/*
 * mesh/flip.h -- restoring local Delaunayness by 2-3 and 3-2 flips (prefix
 * flip_), constraints kept.
 *
 * A Bowyer-Watson insertion into a constrained Delaunay tetrahedralization
 * (refine/refine_cdt.c) can leave faces that are not locally Delaunay: a
 * new tetrahedron built on a constraint face (a subfacet, which no cavity
 * crosses) has no old tetrahedron beyond that face to vouch for its
 * circumsphere, and two such tetrahedra on two constraint faces that meet
 * at an edge may each hold the other's apex; a cavity shrunk to a star
 * leaves the same kind of face. TetGen repairs both with Lawson's flips
 * ("lawsonflip3d"); so does this module.
 *
 * flip_restore checks every face of the given tetrahedra, and every face
 * that a flip creates: a face between two real tetrahedra that carries no
 * face mark (TM_F_FACEMARK) and whose far apex lies inside the near
 * tetrahedron's circumsphere (perturbed test, as the kernel decides) is
 * flipped, 2-3 when the segment joining the two apexes crosses the face,
 * else 3-2 when an edge of the face has exactly three tetrahedra around
 * it, is not a subsegment (TM_F_SUBSEG) and the three faces around it are
 * unmarked, and the flip is valid. On a carved domain (ghosts on the
 * boundary faces) an edge that two marked boundary faces with the same
 * marker share, with the two tetrahedra of the face and their two ghosts
 * around it, is flipped 2-2 (with its ghosts: 4-4) when the quadrilateral
 * of the two boundary faces is convex: the other diagonal of a merged
 * facet; hook->facet then updates the caller's facet triangulation and
 * marks the two new boundary faces. A face that is none of these is left
 * (counted in *stuck). Flips never touch a marked face or a subsegment edge: a new
 * tetrahedron's face that was a face of the flipped region's boundary
 * takes that face's mark and marker, its edges that were subsegments keep
 * their bits. Ghosts, special links and other per-tetrahedron data are not
 * touched; hook copies a caller's per-tetrahedron data (regions) from an
 * old tetrahedron of the flip (they all lie between the same constraints)
 * to each new one.
 *
 * Ownership: works in place on m; *out (if not NULL) is a growable array
 * of the caller's, to which every tetrahedron a flip made is appended (some
 * may be dead again at the end: check tm_is_dead).
 */
#ifndef PDR_FLIP_H
#define PDR_FLIP_H

#include <stddef.h>
#include <stdint.h>

#include "mesh/tm.h"

typedef struct flip_hooks {
    void (*copy)(void *arg, uint32_t from, uint32_t to); /* may be NULL */
    /* A new tetrahedron's face f took the special link outer (not
     * TM_LINK_NONE: an interface face to another PE) of the face it
     * replaces; may be NULL. */
    void (*relink)(void *arg, tm_link outer, uint32_t t, int f);
    /* A 2-2 flip on the boundary replaced faces (e1 e2 p) and (e1 e2 a) by
     * (p a e1) and (p a e2), faces of tets[0..4) (the two new tetrahedra
     * and their ghosts); it must mark them (and return 0, or a negative
     * code). NULL: no 2-2 flips. */
    int (*facet)(void *arg, uint32_t e1, uint32_t e2, uint32_t p, uint32_t a,
                 const uint32_t tets[4]);
    /* Asked before such a flip (may be NULL: every flip the 3D tests
     * allow): 1 if the facet's triangulation allows it, i.e. the
     * quadrilateral e1 p e2 a is strictly convex as the facet sees it.
     * The 3D tests look at it from a vertex off the plane; for four
     * points that are coplanar only up to rounding, three of them nearly
     * collinear, that view and the facet's own 2D view can disagree, and
     * the flip would then fold the facet's triangulation over itself. */
    int (*facet_ok)(void *arg, uint32_t e1, uint32_t e2, uint32_t p, uint32_t a);
    void *arg;
    /* With m->lock (the parallel refinement), a flip whose tetrahedra
     * include one locked by another owner than this one (0: any lock)
     * is not made: that face is left (flip_out.blocked). */
    uint32_t lock_owner;
} flip_hooks;

typedef struct flip_out {
    uint32_t *tets; /* tetrahedra made by flips (caller frees) */
    size_t n, cap;
    tm_link *stuck_faces; /* faces left not locally Delaunay (caller frees;
                             they may be gone by the end) */
    size_t nstuck, cap_stuck;
    size_t flips23, flips32, flips22, stuck;
    size_t blocked; /* faces left because a tetrahedron was locked */
} flip_out;

/* Flips until every face reachable as described above is locally Delaunay
 * or stuck (at most limit flips; 0: 64 per seed tetrahedron). Returns 0 or
 * PDR_ENOMEM. */
int flip_restore(tm_mesh *m, const uint32_t *seed, size_t nseed, const flip_hooks *h,
                 flip_out *out, size_t limit);

/* Removes tetrahedron t, which the caller knows to be flat (its four
 * vertices on one planar facet, up to rounding: a quadrilateral of a
 * merged facet with both diagonals, as the Delaunay tetrahedralization of
 * four cocircular points can leave), when two of
 * its faces are marked boundary faces with the same marker and ghosts
 * behind them, and its other two faces have real tetrahedra behind them
 * that are not flat: those two faces become the boundary (the other
 * diagonal of the quadrilateral), with new ghosts made[0..2), and
 * hook->facet updates the facet triangulation and marks them as after a
 * 2-2 flip (tets: the two real tetrahedra, then the two ghosts). Returns 1
 * if removed, 0 if t is not such a tetrahedron, or a negative code. */
int flip_remove_flat(tm_mesh *m, uint32_t t, const flip_hooks *h, uint32_t made[2]);

#endif /* PDR_FLIP_H */
