/*
 * refine/refine_cdt.c -- the constrained mode of the refinement
 * (ref_opts.constrained): the mesh is a constrained Delaunay
 * tetrahedralization (CDT) of the input, whose subsegments and subfacets
 * are constraints that no cavity crosses, instead of a conforming Delaunay
 * one.
 *
 * Why. A closed triangle surface exported by a CAD tool or a scanner makes
 * every triangle a facet and every edge a segment; segments meet at the
 * triangles' corners at 30 to 60 degrees everywhere, far below what the
 * conforming algorithm needs to terminate (Shewchuk: 90 degrees), and
 * splitting a piece there puts a vertex that encroaches the piece next to
 * it, down to the resolution of double precision. In a conforming mesh
 * a piece that is encroached but not split can vanish at the next
 * insertion (its tetrahedra are deleted) and must then be split anyway,
 * so refusing splits near small angles does not help; once pieces are
 * constraints, a refused piece stays, and refusing is safe. That is
 * Shewchuk's "Constrained Delaunay tetrahedralizations and provably good
 * boundary recovery" (2002) and what TetGen's -p does; see
 * mesher/refine/RECOVERY.md for the measurements that led here.
 *
 * How (the differences from the conforming mode, which stays the default
 * for inputs that meet its angle conditions):
 *
 *  - Every cavity is searched with DT_STOP_MARKED: it ends at marked faces
 *    (present subfacets). A boundary split may cross exactly the subfacets
 *    it replaces: its 2D cavities (subfacets of the piece's facets whose
 *    circumcircle holds the new point, by the perturbed in-circle test
 *    that agrees with the 3D predicates) are found FIRST, flagged
 *    BD_F_VISIT, and ref__cross_visited lets the 3D search through them.
 *    Subsegments need no test of their own: an edge between constrained
 *    faces is never inside a cavity that crosses none of them.
 *  - A cavity that is not a star from its point (it reached round a
 *    constraint to its back) is shrunk to one (dt_cavity_shrink); a
 *    boundary split whose 3D cavity then does not delete every subfacet of
 *    its 2D cavities is refused (the piece is tolerated: it stays).
 *  - The circumcentre of a bad tetrahedron that a constraint hides from
 *    it (the cavity from the tetrahedron holds no tetrahedron containing
 *    the point) encroaches that constraint: the subfacet crossed by the
 *    segment from the tetrahedron to the point is split instead, under the
 *    same floors as any split a bad tetrahedron asks for, or the
 *    tetrahedron is left (counted near small angles).
 *  - The initial mesh: the Delaunay tetrahedralization of the input
 *    vertices, then missing subsegments and missing subfacets are split
 *    (or, in the second attempt, segments first and missing facet regions
 *    retriangulated first: mesher/refine/RECOVERY.md) until every piece
 *    is present (present pieces are constraints from the
 *    start, so none is ever lost again; encroachment is not repaired
 *    there); then the exterior and the holes are classified, and CARVED:
 *    their tetrahedra are deleted and every boundary face gets a ghost
 *    tetrahedron (the infinite vertex beyond it), linked to its neighbours
 *    around the boundary edges. With DT_GHOST_WALLS a ghost joins a cavity
 *    only across the boundary piece being split, so a split on the
 *    boundary is the same search-and-commit as any other, and the new
 *    boundary faces get ghosts of their own.
 *
 * What it guarantees, and where: the mesh is a constrained Delaunay
 * tetrahedralization (every face that is not on an input facet is locally
 * Delaunay), except after the second attempt of the recovery (segments
 * first, then facets by cavity retriangulation: refine_segrec.c,
 * refine_facrec.c), where a face no flip mends is left and counted
 * (ref_mesher.keep_stuck) because the splits next to it cascade on those
 * inputs; every input facet is exactly covered by subfacets, and
 * every interior tetrahedron has radius-edge ratio below the bound except
 * those whose split was refused next to a small input angle (counted by
 * ref_count_bad as left near small angles) or that are degenerate.
 * Termination rests on the same floors as the conforming mode (a split a
 * bad tetrahedron asks for never goes below its shortest edge), on the
 * resolution floor and on the bound on inserted points; the recovery of
 * the initial mesh splits only pieces that have never been present.
 */
#include "config.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "base/pdr_util.h"
#include "geom/pred.h"
#include "plc/fm.h"
#include "refine/refine_int.h"
#include "base/v3.h"

#define X(m, v) ((m)->xyz + 3 * (size_t)(v))

/* The subfacet that face f of tetrahedron t is, or BD_NONE. */
static uint32_t face_subfac(const ref_mesher *r, uint32_t t, int f)
{
    const uint32_t *v = r->m.tets[t].v;
    const uint8_t *fv = tm_face_vtx[f];
    return bd_find_subfac(&r->bd, v[fv[0]], v[fv[1]], v[fv[2]]);
}

int ref__cross_visited(void *arg, const tm_mesh *m, uint32_t t, int f)
{
    (void)m;
    const ref_mesher *r = arg;
    uint32_t id = face_subfac(r, t, f);
    return id != BD_NONE && (r->bd.facs[id].flags & BD_F_VISIT);
}

/* keep of dt_cavity_shrink: a tetrahedron on a subfacet the split
 * replaces, or around the subsegment it splits (r->split_a, split_b). */
static int on_visited(void *arg, uint32_t t)
{
    const ref_mesher *r = arg;
    const tm_tet *T = &r->m.tets[t];
    if (r->split_b != TM_NONE && ref__slot_in(T, r->split_a) >= 0 &&
        ref__slot_in(T, r->split_b) >= 0)
        return 1;
    for (int f = 0; f < 4; f++)
        if ((r->m.flags[t] & TM_F_FACEMARK(f)) && ref__cross_visited(arg, &r->m, t, f))
            return 1;
    return 0;
}

unsigned ref__cdt_flags(const ref_mesher *r)
{
    return DT_STOP_MARKED | (r->carved ? DT_GHOST_WALLS : 0u);
}

unsigned ref_cavity_flags(const ref_mesher *r)
{
    return r->o.constrained ? ref__cdt_flags(r) : 0u;
}

struct start_arg {
    const double *p;
    uint32_t found;
};

static int real_in_conflict(const tm_mesh *m, uint32_t t, void *arg)
{
    struct start_arg *s = arg;
    if (!tm_is_ghost(m, t) && dt_conflict(m, t, s->p) > 0) {
        s->found = t;
        return 1;
    }
    return 0;
}

/* A real tetrahedron in conflict with p, on the piece ab (edge) or abc
 * (face, c != TM_NONE), or containing p for a missing piece; TM_NONE if
 * there is none. */
static uint32_t piece_start(const ref_mesher *r, const double p[3], uint32_t a, uint32_t b,
                            uint32_t c, int missing)
{
    tm_mesh *m = (tm_mesh *)&r->m;
    uint32_t t;
    if (missing) {
        tm_link exit_link;
        uint32_t h = ref__vertex_tet(m, a);
        if (dt_locate(m, p, h, &t, &exit_link) != 0 || tm_is_ghost(m, t))
            return TM_NONE;
        return t;
    }
    if (!ref__find_in_star(m, a, b, c, &t))
        return TM_NONE;
    if (c != TM_NONE) {
        /* a face: one of its two tetrahedra */
        if (!tm_is_ghost(m, t) && dt_conflict(m, t, p) > 0)
            return t;
        const tm_tet *T = &m->tets[t];
        int k = 6 - ref__slot_in(T, a) - ref__slot_in(T, b) - ref__slot_in(T, c);
        tm_link l = T->n[k];
        if (tm_is_special(l))
            return TM_NONE;
        uint32_t u = tm_ltet(l);
        return !tm_is_ghost(m, u) && dt_conflict(m, u, p) > 0 ? u : TM_NONE;
    }
    struct start_arg s = {p, TM_NONE};
    ref_around_edge(m, t, a, b, real_in_conflict, &s);
    return s.found;
}

/* 1 if the pending cavity deletes every present subfacet of the 2D
 * cavities (r->list): both its tetrahedra in the cavity. The faces crossed
 * (each seen from both sides) are counted against the present subfacets
 * of the list; on a PE an entry whose tetrahedra went to another PE is
 * not crossed. */
static int crosses_all(const ref_mesher *r)
{
    const tm_mesh *m = &r->m;
    const dt_cavity *cav = &r->cav;
    size_t present = 0, sides = 0;
    for (size_t i = 0; i < r->nlist; i++)
        present += !(r->bd.facs[r->list[i]].flags & BD_F_MISSING);
    for (size_t i = 0; i < cav->ntets; i++) {
        uint32_t u = cav->tets[i];
        for (int f = 0; f < 4; f++) {
            if (!(m->flags[u] & TM_F_FACEMARK(f)) || !ref__cross_visited((void *)r, m, u, f))
                continue;
            tm_link l = m->tets[u].n[f];
            if (!tm_is_special(l) && (m->flags[tm_ltet(l)] & TM_F_CAVITY))
                sides++;
        }
    }
    return sides == 2 * present;
}

struct star_arg {
    uint32_t *t;
    size_t n, cap;
    int rc;
};

static int collect(const tm_mesh *m, uint32_t t, void *arg)
{
    (void)m;
    struct star_arg *s = arg;
    if (pdr_grow((void **)&s->t, &s->cap, s->n + 1, sizeof *s->t)) {
        s->rc = PDR_ENOMEM;
        return 1;
    }
    s->t[s->n++] = t;
    return 0;
}

/* The lock owner of the running step on a PE (the parallel hooks): the
 * owner of the cavity its thread holds, 0 when it holds none (then every
 * lock is another's). Outside the hooks 0. Read afresh at each search:
 * r->cav is shared by the PE's cavity threads, and the owner a search of
 * another thread left in it may be that of a cavity still in progress,
 * its thread waiting for replies (whose locks this step must respect). */
static uint32_t step_owner(const ref_mesher *r)
{
    return r->hooks && r->hooks->owner ? r->hooks->owner(r->hooks->arg) : 0;
}

/* 1 if on a PE a tetrahedron of t[0..n-1] or a local neighbour of one is
 * locked by another owner than own (a cavity in progress here or served
 * for another PE's): what DT_CHECK_LOCKS finds for a searched cavity. */
static int star_locked(const ref_mesher *r, const uint32_t *t, size_t n, uint32_t own)
{
    const tm_mesh *m = &r->m;
    if (!r->hooks || !m->lock)
        return 0;
    for (size_t i = 0; i < n; i++) {
        if (tm_held_by_other(m, t[i], own))
            return 1;
        for (int k = 0; k < 4; k++) {
            tm_link l = m->tets[t[i]].n[k];
            if (!tm_is_special(l) && tm_held_by_other(m, tm_ltet(l), own))
                return 1;
        }
    }
    return 0;
}

/* The split of present subsegment ab at p whose constrained cavity is no
 * star (an encroaching vertex next to a subfacet of its 2D cavity, where
 * the cavity reaches round to the back of a face p does not see), asked
 * for by a face no flip mends (a CDT needs the split): the
 * cavity becomes the tetrahedra around ab, ghosts included, and the 2D
 * cavities the subfacets on ab; every one is split in two, which is
 * always valid for p on the edge, and the flips after the commit make the
 * mesh a CDT again (TetGen splits an edge the same way). Returns as
 * ref__cdt_search_piece. */
static int edge_star_cavity(ref_mesher *r, const double p[3], uint32_t a, uint32_t b)
{
    tm_mesh *m = &r->m;
    uint32_t t;
    if (!ref__find_in_star(m, a, b, TM_NONE, &t))
        return r->hooks ? REF_CDT_ELSEWHERE : 1;
    struct star_arg sa = {NULL, 0, 0, 0};
    int around = ref_around_edge(m, t, a, b, collect, &sa);
    int rc = sa.rc ? sa.rc : ref__cavity2d_edge(r, p, a, b);
    if (!rc && around < 0)
        rc = r->hooks ? REF_CDT_ELSEWHERE : 1; /* an edge ring left open */
    /* On a PE the star must be free, as a searched cavity must (see
     * ref__cdt_search_piece): another cavity in progress may hold some
     * of it, and a commit would delete its tetrahedra under it. */
    if (!rc && star_locked(r, sa.t, sa.n, step_owner(r)))
        rc = REF_CDT_LOCKED;
    /* Each tetrahedron around ab is cut in two: none may be flat (four
     * vertices in a plane: its halves would be too). */
    for (size_t i = 0; !rc && i < sa.n; i++) {
        const uint32_t *v = m->tets[sa.t[i]].v;
        if (!tm_is_ghost(m, sa.t[i]) &&
            pred_orient3d(X(m, v[0]), X(m, v[1]), X(m, v[2]), X(m, v[3])) == 0)
            rc = 1;
    }
    if (!rc)
        rc = dt_cavity_set(m, p, sa.t, sa.n, ref__cdt_flags(r), &r->cav);
    pr_free(sa.t);
    if (rc)
        return rc == PDR_EINVAL ? 1 : rc;
    /* p is rounded: each new tetrahedron must still be positive. */
    if (!dt_cavity_is_star(m, &r->cav)) {
        dt_cavity_abandon(m, &r->cav);
        return 1;
    }
    if (!crosses_all(r)) {
        dt_cavity_abandon(m, &r->cav);
        return r->hooks ? REF_CDT_ELSEWHERE : 1;
    }
    for (size_t i = 0; i < r->cav.nbnd; i++)
        if (r->cav.bnd[i].reason == DT_BND_REMOTE) {
            dt_cavity_abandon(m, &r->cav);
            return REF_CDT_ELSEWHERE;
        }
    r->st.edge_star_splits++;
    return 0;
}

/* keep of dt_cavity_shrink for a forced recovery cavity: a tetrahedron
 * that holds the point (closed), r->cav.p, or the split subsegment. */
static int holds_point(void *arg, uint32_t t)
{
    const ref_mesher *r = arg;
    const tm_mesh *m = &r->m;
    const tm_tet *T = &m->tets[t];
    /* Around the subsegment split: its edge must go, even where the
     * rounded p lies a hair off it. */
    if (r->split_b != TM_NONE && ref__slot_in(T, r->split_a) >= 0 &&
        ref__slot_in(T, r->split_b) >= 0)
        return 1;
    return ref__tet_holds(m, t, r->cav.p);
}

int ref__tet_holds(const tm_mesh *m, uint32_t t, const double p[3])
{
    const tm_tet *T = &m->tets[t];
    for (int f = 0; f < 4; f++) {
        const uint8_t *fv = tm_face_vtx[f];
        uint32_t x = T->v[fv[0]], y = T->v[fv[1]], z = T->v[fv[2]];
        if (x == TM_VINF || y == TM_VINF || z == TM_VINF)
            return 0;
        if (pred_orient3d(X(m, x), X(m, y), X(m, z), p) < 0)
            return 0;
    }
    return 1;
}

/* 1 while the initial recovery runs (sequentially, before the exterior is
 * classified): the only time pieces are missing. */
static int recovering(const ref_mesher *r)
{
    return r->narrow_recovery && !r->classified && !r->carved && !r->hooks;
}

/* 1 if the pending cavity deletes subfacet id's face (both tetrahedra
 * of it in the cavity), or id is missing (no face to keep). */
static int cavity_takes(const ref_mesher *r, uint32_t id)
{
    const tm_mesh *m = &r->m;
    const bd_subfac *S = &r->bd.facs[id];
    if (S->flags & BD_F_MISSING)
        return 1;
    uint32_t t;
    if (!ref__find_in_star(m, S->v[0], S->v[1], S->v[2], &t))
        return 1;
    const tm_tet *T = &m->tets[t];
    int k = 6 - ref__slot_in(T, S->v[0]) - ref__slot_in(T, S->v[1]) - ref__slot_in(T, S->v[2]);
    tm_link l = T->n[k];
    return (m->flags[t] & TM_F_CAVITY) && !tm_is_special(l) &&
           (m->flags[tm_ltet(l)] & TM_F_CAVITY);
}

/* The recovery's cavity of p when its constrained cavity cannot delete
 * every subfacet of its 2D cavity (what stopped the recovery on CAD
 * tessellations, RECOVERY.md): searched again from t as before and shrunk
 * to a star keeping only the tetrahedra that hold p (and, for a
 * subsegment split, those around its edge); then the 2D cavity is
 * narrowed to what that 3D cavity deletes (its missing subfacets and the
 * present ones whose both tetrahedra it holds). The subfacets it keeps
 * stay present constraints, so nothing is lost; the narrowed 2D cavity
 * must still be a star from p in every facet (else no cavity: 1), so the
 * facet triangulations stay triangulations, and the new subfacets of p's
 * fan that are not faces of the mesh are missing and queued. Returns 0
 * (r->cav pending, r->list and r->bedge the narrowed 2D cavity), 1
 * (nothing pending) or a negative code. */
static int narrowed_cavity(ref_mesher *r, const double p[3], uint32_t t)
{
    tm_mesh *m = &r->m;
    dt_cavity *cav = &r->cav;
    bd_set *bd = &r->bd;
    if (tm_is_dead(m, t) || dt_conflict(m, t, p) <= 0)
        return 1;
    cav->may_cross = ref__cross_visited;
    cav->cross_arg = r;
    int rc = dt_cavity_search(m, p, t, ref__cdt_flags(r), cav);
    cav->may_cross = NULL;
    cav->cross_arg = NULL;
    if (rc)
        return rc;
    if (cav->status != DT_OK) {
        dt_cavity_abandon(m, cav);
        return 1;
    }
    if (!dt_cavity_is_star(m, cav)) {
        rc = dt_cavity_shrink(m, cav, holds_point, r);
        if (rc)
            return rc; /* 1: abandoned already */
    }
    /* The narrowed 2D cavity: r->list keeps what the 3D cavity takes. */
    size_t n = 0;
    for (size_t i = 0; i < r->nlist; i++) {
        uint32_t id = r->list[i];
        if (cavity_takes(r, id))
            r->list[n++] = id;
        else
            bd->facs[id].flags &= (uint16_t)~BD_F_VISIT;
    }
    r->nlist = n;
    r->nbedge = 0;
    for (size_t i = 0; i < r->nlist && !rc; i++) {
        uint32_t id = r->list[i];
        for (int k = 0; k < 3; k++) {
            uint32_t x, y, u;
            int seg;
            if (!ref__cavity2d_rim(r, id, k, r->split_a, r->split_b, &x, &y, &seg, &u))
                continue;
            if (ref__orient_facet(r->p, bd->facs[id].facet, X(m, x), X(m, y), p) <= 0) {
                rc = 1; /* the narrowed 2D cavity is no star */
                break;
            }
            if ((rc = ref__add_bedge(r, x, y, id)))
                break;
        }
    }
    if (!rc && !r->nlist)
        rc = 1;
    if (rc) {
        dt_cavity_abandon(m, cav);
        return rc;
    }
    r->forced = 0;
    r->st.forced_cavities++;
    return 0;
}

int ref__cdt_search_piece(ref_mesher *r, const double p[3], uint32_t a, uint32_t b, uint32_t c,
                          int missing, int edge_star)
{
    tm_mesh *m = &r->m;
    dt_cavity *cav = &r->cav;
    uint32_t t = piece_start(r, p, a, b, c, missing);
    if (t == TM_NONE)
        return r->hooks ? REF_CDT_ELSEWHERE : 1;
    r->split_a = a;
    r->split_b = c == TM_NONE ? b : TM_NONE;
    cav->may_cross = ref__cross_visited;
    cav->cross_arg = r;
    /* On a PE (the parallel hooks): the split is made here only if its
     * cavity lies on this PE and no other cavity holds any of it; the
     * merged mesh gets the others at rank 0. */
    unsigned lk = r->hooks && m->lock ? DT_CHECK_LOCKS : 0u;
    /* Only this step's own locks count as its own (step_owner). */
    if (lk)
        cav->lock_owner = step_owner(r);
    int rc = dt_cavity_search(m, p, t, ref__cdt_flags(r) | lk, cav);
    cav->may_cross = NULL;
    cav->cross_arg = NULL;
    if (rc)
        return rc;
    if (cav->status == DT_LOCKED)
        return REF_CDT_LOCKED;
    if (cav->status != DT_OK) {
        dt_cavity_abandon(m, cav);
        return 1;
    }
    for (size_t i = 0; r->hooks && i < cav->nbnd; i++)
        if (cav->bnd[i].reason == DT_BND_REMOTE) {
            dt_cavity_abandon(m, cav);
            return REF_CDT_ELSEWHERE;
        }
    if (!dt_cavity_is_star(m, cav)) {
        rc = dt_cavity_shrink(m, cav, on_visited, r);
        if (rc < 0) {
            dt_cavity_abandon(m, cav);
            return rc;
        }
        if (rc && recovering(r))
            return narrowed_cavity(r, p, t);
        if (rc)
            return edge_star && c == TM_NONE && !missing ? edge_star_cavity(r, p, a, b) : rc;
        r->st.shrunk++;
    }
    if (!crosses_all(r)) {
        dt_cavity_abandon(m, cav);
        if (recovering(r))
            return narrowed_cavity(r, p, t);
        if (edge_star && c == TM_NONE && !missing)
            return edge_star_cavity(r, p, a, b);
        if (r->hooks)
            return REF_CDT_ELSEWHERE; /* a subfacet of it may be elsewhere */
        r->st.cdt_refused++;
        return 1;
    }
    return 0;
}

/* 1 if segment qp crosses the interior of triangle abc (exactly: q and p
 * strictly on both sides of its plane, and the line through them strictly
 * inside its three edges). */
static int crosses(const double *q, const double *p, const double *a, const double *b,
                   const double *c)
{
    int s1 = pred_orient3d(a, b, c, q), s2 = pred_orient3d(a, b, c, p);
    if (s1 == 0 || s2 == 0 || s1 == s2)
        return 0;
    int e1 = pred_orient3d(q, p, a, b), e2 = pred_orient3d(q, p, b, c),
        e3 = pred_orient3d(q, p, c, a);
    return e1 != 0 && e1 == e2 && e2 == e3;
}

uint32_t ref__cdt_blocker(const ref_mesher *r, uint32_t t, const double p[3])
{
    const tm_mesh *m = &r->m;
    const dt_cavity *c = &r->cav;
    const uint32_t *tv = m->tets[t].v;
    double q[3];
    for (int k = 0; k < 3; k++)
        q[k] = 0.25 * (X(m, tv[0])[k] + X(m, tv[1])[k] + X(m, tv[2])[k] + X(m, tv[3])[k]);
    uint32_t beyond = BD_NONE;
    for (size_t i = 0; i < c->nbnd; i++) {
        const dt_bface *b = &c->bnd[i];
        if (b->reason != DT_BND_MARKED)
            continue;
        const tm_tet *T = &m->tets[b->tet];
        const uint8_t *fv = tm_face_vtx[b->face];
        uint32_t x = T->v[fv[0]], y = T->v[fv[1]], z = T->v[fv[2]];
        if (x == TM_VINF || y == TM_VINF || z == TM_VINF)
            continue;
        uint32_t id = bd_find_subfac(&r->bd, x, y, z);
        if (id == BD_NONE)
            continue;
        if (crosses(q, p, X(m, x), X(m, y), X(m, z)))
            return id;
        if (beyond == BD_NONE && pred_orient3d(X(m, x), X(m, y), X(m, z), p) <= 0)
            beyond = id;
    }
    return beyond;
}

/* ---------------------------------------------------------------- flips */

struct fac_queue_arg {
    ref_mesher *r;
    int rc;
    size_t n;
};

static int queue_present_fac(void *arg, uint32_t s)
{
    struct fac_queue_arg *a = arg;
    if (a->r->bd.facs[s].flags & BD_F_MISSING)
        return 0;
    a->rc = ref__queue_fac(a->r, s, 0.0f);
    a->n++;
    return a->rc;
}

/* flip_hooks.copy: a tetrahedron made by a flip lies in the region of
 * the ones it replaces. */
static void copy_region(void *arg, uint32_t from, uint32_t to)
{
    ref_mesher *r = arg;
    r->m.flags[to] |= r->m.flags[from] & REF_F_EXTERIOR;
    if (r->region)
        r->region[to] = r->region[from];
}

/* flip_hooks.facet: a 2-2 flip of two subfacets of one facet (the
 * diagonal of a merged facet's quadrilateral): the facet triangulation
 * follows, and the new faces are marked. */
static int flip_facet(void *arg, uint32_t e1, uint32_t e2, uint32_t p, uint32_t a,
                      const uint32_t tets[4])
{
    ref_mesher *r = arg;
    tm_mesh *m = &r->m;
    bd_set *bd = &r->bd;
    uint32_t s1 = bd_find_subfac(bd, e1, e2, p), s2 = bd_find_subfac(bd, e1, e2, a);
    if (s1 == BD_NONE || s2 == BD_NONE || bd->facs[s1].facet != bd->facs[s2].facet) {
        return PDR_ETOPOLOGY;
    }
    uint32_t f = bd->facs[s1].facet;
    bd_kill_subfac(bd, s1);
    bd_kill_subfac(bd, s2);
    const uint32_t ends[2] = {e1, e2};
    for (int i = 0; i < 2; i++) {
        uint32_t x = p, y = a, z = ends[i], id;
        if (ref__orient_facet(r->p, f, X(m, x), X(m, y), X(m, z)) < 0) {
            x = a;
            y = p;
        }
        int rc = bd_add_subfac(bd, x, y, z, f, &id);
        if (rc)
            return rc;
        for (int k = 0; k < 2; k++) {
            const tm_tet *T = &m->tets[tets[k]];
            int sz = ref__slot_in(T, z);
            if (sz < 0)
                continue;
            int q = 6 - ref__slot_in(T, p) - ref__slot_in(T, a) - sz;
            rc = tm_mark_face(m, tets[k], q, (int32_t)f + 1);
            if (rc)
                return rc;
        }
    }
    m->flags[tets[2]] |= REF_F_EXTERIOR;
    m->flags[tets[3]] |= REF_F_EXTERIOR;
    r->st.flips22++;
    return 0;
}

/* flip_hooks.facet_ok: the quadrilateral e1 p e2 a of a 2-2 flip is
 * strictly convex in the facet's own 2D view (ref__orient_facet, the view
 * every 2D cavity and fan of the facet triangulation is built in): the
 * new diagonal p-a separates e1 from e2 and the old one e1-e2 separates p
 * from a. */
static int facet_ok(void *arg, uint32_t e1, uint32_t e2, uint32_t p, uint32_t a)
{
    const ref_mesher *r = arg;
    const tm_mesh *m = &r->m;
    uint32_t s = bd_find_subfac(&r->bd, e1, e2, p);
    if (s == BD_NONE)
        return 0;
    uint32_t f = r->bd.facs[s].facet;
    const double *P = X(m, p), *A = X(m, a), *E1 = X(m, e1), *E2 = X(m, e2);
    int d1 = ref__orient_facet(r->p, f, P, A, E1), d2 = ref__orient_facet(r->p, f, P, A, E2);
    int d3 = ref__orient_facet(r->p, f, E1, E2, P), d4 = ref__orient_facet(r->p, f, E1, E2, A);
    return d1 && d2 && d3 && d4 && d1 != d2 && d3 != d4;
}

/* flip_hooks.relink: the parallel hook's, with its own argument. */
static void relink(void *arg, tm_link outer, uint32_t t, int f)
{
    ref_mesher *r = arg;
    r->hooks->relink(r->hooks->arg, outer, t, f);
}

/* The flips' hooks: regions, facet triangulations, and with the parallel
 * hooks the interface faces and the running cavity's lock owner. */
static flip_hooks flip_hooks_of(ref_mesher *r)
{
    flip_hooks fh = {.copy = copy_region, .facet = flip_facet, .facet_ok = facet_ok, .arg = r};
    if (r->hooks) {
        fh.relink = r->hooks->relink ? relink : NULL;
        fh.lock_owner = step_owner(r);
    }
    return fh;
}

/* The floor of the split of subsegment a-b that a face no flip mends
 * asks for, apex the vertex of its tetrahedron off the face (refine.h,
 * REF_STUCK_FAR). */
static double stuck_floor(const ref_mesher *r, uint32_t a, uint32_t b, uint32_t apex)
{
    const tm_mesh *m = &r->m;
    const double *A = X(m, a), *B = X(m, b);
    double mid[3] = {0.5 * (A[0] + B[0]), 0.5 * (A[1] + B[1]), 0.5 * (A[2] + B[2])};
    double far = sqrt(v3_dist2(mid, X(m, apex)));
    double fl = r->bd.vrins[apex];
    if (far > REF_STUCK_FAR * sqrt(v3_dist2(A, B)) && 0.5 * far > fl)
        fl = 0.5 * far;
    return r->o.rho * fl;
}

/* 1 if the split of subsegment a-b that a face no flip mends asks for,
 * apex the vertex of its tetrahedron off the face, is one step of a
 * corner cascade past its bound (refine.h, REF_STUCK_CORNER): one end of
 * a-b, o, is an input vertex where segments meet at an acute angle (a-b
 * is split at o's concentric shells, ref__split_point), the apex lies on
 * another segment at o, and the split point is nearer to o than the apex;
 * only under a size bound (without one, stuck_past_bound in refine_run.c
 * bounds these splits in the quality refinement).
 * Counts such requests per corner (r->corner_steps); returns 0 for the
 * first REF_STUCK_CORNER of them, or PDR_ENOMEM. */
static int corner_cascade(ref_mesher *r, uint32_t a, uint32_t b, uint32_t apex)
{
    const bd_set *bd = &r->bd;
    if (!r->seg_acute || bd->vkind[apex] != BD_V_SEGMENT || !ref__size_bounded(r))
        return 0;
    int ia = bd->vkind[a] == BD_V_INPUT && r->seg_acute[bd->vfeat[a]];
    int ib = bd->vkind[b] == BD_V_INPUT && r->seg_acute[bd->vfeat[b]];
    if (ia == ib)
        return 0;
    uint32_t o = ia ? a : b, x = ia ? b : a, io = bd->vfeat[o];
    const uint32_t *sv = r->p->segs[bd->vfeat[apex]].v;
    if (sv[0] != io && sv[1] != io)
        return 0;
    /* The apex's segment is another than a-b's. */
    if (bd->vkind[x] == BD_V_SEGMENT && bd->vfeat[x] == bd->vfeat[apex])
        return 0;
    if (bd->vkind[x] == BD_V_INPUT && (sv[0] == bd->vfeat[x] || sv[1] == bd->vfeat[x]))
        return 0;
    const tm_mesh *m = &r->m;
    double p[3];
    ref__split_point(r, a, b, p);
    if (!(v3_dist2(X(m, o), p) < v3_dist2(X(m, o), X(m, apex))))
        return 0;
    if (!r->corner_steps) {
        r->corner_steps = pr_calloc(r->p->nv ? r->p->nv : 1, sizeof *r->corner_steps);
        if (!r->corner_steps)
            return PDR_ENOMEM;
    }
    if (r->corner_steps[io] >= REF_STUCK_CORNER)
        return 1;
    r->corner_steps[io]++;
    return 0;
}

int ref__cdt_flip(ref_mesher *r, const uint32_t *seed, size_t nseed)
{
    tm_mesh *m = &r->m;
    int rc = ref_region_room(r);
    flip_hooks fh = flip_hooks_of(r);
    r->flipped.n = r->flipped.nstuck = 0;
    if (!rc)
        rc = flip_restore(m, seed, nseed, &fh, &r->flipped, 0);
    /* A face no flip mends lies against a subsegment that is not strongly
     * Delaunay (a CDT with it may not exist): it is split (unless
     * r->keep_stuck: after the recovery with segments first, on CAD
     * tessellations, those splits cascade next to the thin triangles and
     * never end; the face is then left and counted), under the same
     * floor as a split some vertex's encroachment asks for (none lets the
     * splits cascade into acute input vertices), in the tetrahedra around
     * it if its constrained cavity is no star; up to a bound per run
     * (REF_STUCK_BASE), past which they cascade under shrinking floors
     * and the face is left as with keep_stuck. */
    size_t budget = REF_STUCK_BASE + REF_STUCK_PER_INPUT * r->p->nv;
    for (size_t i = 0; i < r->flipped.nstuck && !rc && !r->keep_stuck && r->st.stuck_splits < budget;
         i++) {
        tm_link l = r->flipped.stuck_faces[i];
        uint32_t t = tm_ltet(l);
        if (tm_is_dead(m, t))
            continue;
        const uint32_t *tv = m->tets[t].v;
        const uint8_t *fv = tm_face_vtx[tm_lface(l)];
        int found = 0;
        for (int k = 0; k < 3 && !rc; k++) {
            uint32_t a = tv[fv[k]], b = tv[fv[(k + 1) % 3]];
            uint32_t id = bd_find_subseg(&r->bd, a, b);
            int cc = id != BD_NONE ? corner_cascade(r, a, b, tv[tm_lface(l)]) : 0;
            if (cc < 0) {
                rc = cc;
            } else if (cc) {
                found = 1; /* left, counted at the end (ref__count_stuck) */
                r->st.stuck_corner++;
            } else if (id != BD_NONE) {
                found = 1;
                r->st.stuck_splits += !(r->bd.segs[id].flags & BD_F_QUEUED);
                rc = ref__queue_seg(r, id, (float)stuck_floor(r, a, b, tv[tm_lface(l)]));
            }
        }
        /* ... or against subfacets whose common edge it needs removed (a
         * merged facet's inner diagonal that no 2-2 flip changes): they
         * are split. */
        for (int k = 0; k < 3 && !rc && !found; k++) {
            uint32_t a = tv[fv[k]], b = tv[fv[(k + 1) % 3]];
            struct fac_queue_arg fa = {r, 0, 0};
            bd_subfacs_on_edge(&r->bd, a, b, queue_present_fac, &fa);
            rc = fa.rc;
            found = fa.n > 0;
        }
    }
    r->st.flips23 += r->flipped.flips23;
    r->st.flips32 += r->flipped.flips32;
    r->st.flips_stuck += r->flipped.stuck;
    r->st.flips_blocked += r->flipped.blocked;
    r->flipped.flips23 = r->flipped.flips32 = r->flipped.flips22 = r->flipped.stuck = 0;
    r->flipped.blocked = 0;
    return rc;
}

size_t ref__count_stuck(const ref_mesher *r)
{
    const tm_mesh *m = &r->m;
    size_t n = 0;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t) || tm_is_ghost(m, t) || (m->flags[t] & REF_F_EXTERIOR))
            continue;
        const tm_tet *T = &m->tets[t];
        for (int f = 0; f < 4; f++) {
            tm_link l = T->n[f];
            if ((m->flags[t] & TM_F_FACEMARK(f)) || tm_is_special(l) || tm_ltet(l) < t)
                continue;
            uint32_t u = tm_ltet(l);
            if (tm_is_ghost(m, u) || (m->flags[u] & REF_F_EXTERIOR))
                continue;
            const double *apex = X(m, m->tets[u].v[tm_lface(l)]);
            if (pred_insphere(X(m, T->v[0]), X(m, T->v[1]), X(m, T->v[2]), X(m, T->v[3]),
                              apex) > 0)
                n++;
        }
    }
    return n;
}

int ref__cdt_remove_flat(ref_mesher *r, uint32_t t)
{
    tm_mesh *m = &r->m;
    if (!r->carved || !ref__flat_on_facet(r, m->tets[t].v))
        return 0;
    int rc = ref_region_room(r);
    if (rc)
        return rc;
    flip_hooks fh = flip_hooks_of(r);
    uint32_t made[2];
    rc = flip_remove_flat(m, t, &fh, made);
    if (rc == 1) {
        r->st.flips22--; /* flip_facet counted it */
        r->st.flats_removed++;
    }
    return rc;
}

int ref_cdt_restore(ref_mesher *r)
{
    tm_mesh *m = &r->m;
    if (!r->carved)
        return PDR_EINVAL;
    /* Flat tetrahedra on merged facets first (four cocircular vertices of
     * a quadrilateral): removed while any goes (one may wait for a flat
     * neighbour). */
    int rc = 0;
    for (int again = 1; again && !rc;) {
        again = 0;
        for (uint32_t t = 0; t < m->nslots && !rc; t++) {
            if (tm_is_dead(m, t) || tm_is_ghost(m, t))
                continue;
            rc = ref__cdt_remove_flat(r, t);
            if (rc == 1) {
                again = 1;
                rc = 0;
            }
        }
    }
    if (rc)
        return rc;
    uint32_t *all = pr_malloc((m->nslots ? m->nslots : 1) * sizeof *all);
    if (!all)
        return PDR_ENOMEM;
    size_t n = 0;
    for (uint32_t t = 0; t < m->nslots; t++)
        if (!tm_is_dead(m, t) && !tm_is_ghost(m, t))
            all[n++] = t;
    size_t f23 = r->st.flips23, f32 = r->st.flips32, st0 = r->st.flips_stuck;
    rc = ref__cdt_flip(r, all, n);
    if (r->o.trace)
        fprintf(r->o.trace, "cdt restore: %zu 2-3 flips, %zu 3-2 flips, %zu faces stuck\n",
                r->st.flips23 - f23, r->st.flips32 - f32, r->st.flips_stuck - st0);
    pr_free(all);
    return rc;
}

/* ------------------------------------------------------------- carving */

/* Copies the marker and subsegment bits of face i of t to ghost g (its
 * face 3 is the same face). Returns 0 or PDR_ENOMEM. */
static int ghost_marks(tm_mesh *m, uint32_t g, uint32_t t, int i)
{
    uint16_t ft = m->flags[t];
    if (ft & TM_F_FACEMARK(i)) {
        m->flags[g] |= TM_F_FACEMARK(3);
        int rc = tm_set_marker(m, g, 3, tm_marker(m, t, i));
        if (rc)
            return rc;
    }
    const tm_tet *T = &m->tets[t], *G = &m->tets[g];
    for (int e = 0; e < 6; e++) {
        if (!(ft & TM_F_SUBSEG(e)))
            continue;
        uint32_t a = T->v[tm_edge_vtx[e][0]], b = T->v[tm_edge_vtx[e][1]];
        int sa = ref__slot_in(G, a), sb = ref__slot_in(G, b);
        if (sa >= 0 && sb >= 0)
            m->flags[g] |= TM_F_SUBSEG(tm_edge_of[sa][sb]);
    }
    return 0;
}

int ref_carve(ref_mesher *r)
{
    tm_mesh *m = &r->m;
    if (!r->classified)
        return PDR_EINVAL;
    for (uint32_t t = 0; t < m->nslots; t++)
        if (!tm_is_dead(m, t) && (tm_is_ghost(m, t) || (m->flags[t] & REF_F_EXTERIOR)))
            tm_delete_tet(m, t);
    size_t open;
    int rc = tm_add_ghosts(m, &open);
    if (rc)
        return rc;
    if (open)
        return PDR_ETOPOLOGY; /* a boundary edge of more than two faces */
    rc = ref_region_room(r);
    if (rc)
        return rc;
    for (uint32_t g = 0; g < m->nslots; g++) {
        if (tm_is_dead(m, g) || !tm_is_ghost(m, g))
            continue;
        tm_link l = m->tets[g].n[3];
        rc = ghost_marks(m, g, tm_ltet(l), tm_lface(l));
        if (rc)
            return rc;
        m->flags[g] |= REF_F_EXTERIOR;
        if (r->region)
            r->region[g] = 0;
    }
    tm_rebuild_hints(m);
    r->carved = 1;
    return 0;
}

/* ------------------------------------------------- seditious edges */

/* The input segments mesh vertex v lies on: its own, or every segment
 * at an input vertex. Returns how many (at most cap); *pv is the PLC
 * vertex v is, or UINT32_MAX. */
static size_t vertex_segments(const ref_mesher *r, uint32_t v, uint32_t *out, size_t cap,
                              uint32_t *pv)
{
    const plc *p = r->p;
    *pv = UINT32_MAX;
    if (r->bd.vkind[v] == BD_V_SEGMENT) {
        out[0] = r->bd.vfeat[v];
        return 1;
    }
    if (r->bd.vkind[v] != BD_V_INPUT)
        return 0;
    uint32_t q = r->bd.vfeat[v];
    *pv = q;
    size_t n = 0;
    for (size_t i = p->v_sstart[q]; i < p->v_sstart[q + 1] && n < cap; i++)
        out[n++] = p->v_segs[i];
    return n;
}

uint32_t ref__cdt_seditious(const ref_mesher *r, uint32_t a, uint32_t b)
{
    enum { CAP = 64 };
    const plc *p = r->p;
    uint32_t sa[CAP], sb[CAP], pa, pb;
    size_t na = vertex_segments(r, a, sa, CAP, &pa), nb = vertex_segments(r, b, sb, CAP, &pb);
    const double *xa = X(&r->m, a), *xb = X(&r->m, b);
    const double c = cos(FM_NEEDLE_ANG * M_PI / 180.0), cos2 = c * c;
    for (size_t i = 0; i < na; i++)
        for (size_t j = 0; j < nb; j++) {
            if (sa[i] == sb[j])
                continue;
            const uint32_t *s = p->segs[sa[i]].v, *u = p->segs[sb[j]].v;
            uint32_t o = s[0] == u[0] || s[0] == u[1] ? s[0]
                         : s[1] == u[0] || s[1] == u[1] ? s[1]
                                                        : UINT32_MAX;
            if (o == UINT32_MAX || o == pa || o == pb)
                continue;
            const double *xo = p->xyz[o];
            const double *ea = p->xyz[s[0] == o ? s[1] : s[0]];
            const double *eb = p->xyz[u[0] == o ? u[1] : u[0]];
            double da[3], db[3];
            v3_sub(ea, xo, da);
            v3_sub(eb, xo, db);
            /* the angle at o below FM_NEEDLE_ANG */
            double dot = v3_dot(da, db);
            if (!(dot > 0 && dot * dot > cos2 * v3_dot(da, da) * v3_dot(db, db)))
                continue;
            double ra = v3_dist2(xa, xo), rb = v3_dist2(xb, xo);
            double lo = fmin(ra, rb), hi = fmax(ra, rb);
            if (hi <= SEDITIOUS_SHELL * SEDITIOUS_SHELL * lo)
                return o;
        }
    return UINT32_MAX;
}

uint32_t ref__cdt_seditious_tet(const ref_mesher *r, uint32_t t)
{
    const tm_mesh *m = &r->m;
    const uint32_t *tv = m->tets[t].v;
    double l2;
    int e = ref__shortest_edge(m, t, &l2);
    return ref__cdt_seditious(r, tv[tm_edge_vtx[e][0]], tv[tm_edge_vtx[e][1]]);
}
