/* mesh/dt.c -- point location, cavity search, retriangulation, bulk build. */
#include "config.h"

#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "mesh/dt.h"
#include "base/pdr_util.h"
#include "geom/pred.h"
#include "geom/ss.h"

#define X(m, v) ((m)->xyz + 3 * (size_t)(v))

void dt_cavity_init(dt_cavity *c)
{
    memset(c, 0, sizeof *c);
}

void dt_cavity_free(dt_cavity *c)
{
    pr_free(c->edge_table);
    pr_free(c->loc_ids);
    pr_free(c->tri);
    pr_free(c->edge_hash);
    pr_free(c->tets);
    pr_free(c->bnd);
    pr_free(c->newtets);
    pr_free(c->stack);
    pr_free(c->held);
    memset(c, 0, sizeof *c);
}

static uint32_t xorshift(tm_mesh *m)
{
    uint64_t x = m->rng;
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    m->rng = x;
    return (uint32_t)(x >> 32);
}

static uint32_t any_live_tet(const tm_mesh *m)
{
    for (uint32_t t = m->nslots; t-- > 0;)
        if (!tm_is_dead(m, t))
            return t;
    return TM_NONE;
}

/* ------------------------------------------------------------ location */

/* Visibility walk: from t, cross a face whose plane separates t from p
 * (exact orient3d < 0), until no face does. The faces are tried from a
 * random one on, which makes the walk terminate with probability 1 on any
 * triangulation (on a Delaunay one it terminates anyway); the face we came
 * through is skipped. */
int dt_locate(tm_mesh *m, const double p[3], uint32_t start, uint32_t *tet,
              tm_link *exit_link)
{
    uint32_t t = start;
    if (t == TM_NONE || t >= m->nslots || tm_is_dead(m, t))
        t = any_live_tet(m);
    if (t == TM_NONE)
        return PDR_EINVAL;
    int from = -1;
    size_t limit = (size_t)m->nlive * 4 + 64;
    for (size_t steps = 0; steps < limit; steps++) {
        const tm_tet *T = &m->tets[t];
        int k = tm_ghost_slot(m, t);
        if (k >= 0) {
            const uint8_t *f = tm_face_vtx[k];
            if (from == k ||
                pred_orient3d(X(m, T->v[f[0]]), X(m, T->v[f[1]]), X(m, T->v[f[2]]), p) > 0) {
                *tet = t;
                return 0;
            }
            /* p is not beyond this hull face: continue inside. */
            tm_link l = T->n[k];
            if (tm_is_special(l)) {
                *tet = t;
                if (exit_link)
                    *exit_link = l;
                return 1;
            }
            t = tm_ltet(l);
            from = tm_lface(l);
            continue;
        }
        /* The four vertices relative to p, once for all faces; the filter
         * bound uses column maxima over all four rows, a valid (slightly
         * looser) bound for each face (geom/pred.c). */
        double q[4][3], mx = 0, my = 0, mz = 0;
        for (int s = 0; s < 4; s++) {
            const double *x = X(m, T->v[s]);
            q[s][0] = x[0] - p[0];
            q[s][1] = x[1] - p[1];
            q[s][2] = x[2] - p[2];
            mx = pred_max_(mx, __builtin_fabs(q[s][0]));
            my = pred_max_(my, __builtin_fabs(q[s][1]));
            mz = pred_max_(mz, __builtin_fabs(q[s][2]));
        }
        double lo = pred_min_(mx, pred_min_(my, mz)), hi = pred_max_(mx, pred_max_(my, mz));
        double bound = lo >= 0x1p-330 && hi <= 0x1p+330 ? (48.0 * PRED_EPS_) * mx * my * mz
                                                          : __builtin_inf();
        uint32_t r = xorshift(m);
        int moved = 0;
        for (int i = 0; i < 4; i++) {
            int fi = (int)((r + (uint32_t)i) & 3u);
            if (fi == from)
                continue;
            const uint8_t *f = tm_face_vtx[fi];
            const double *u = q[f[0]], *v = q[f[1]], *w = q[f[2]];
            /* orient3d(face, p) = -det[u; v; w] */
            double det = u[0] * (v[1] * w[2] - v[2] * w[1]) + u[1] * (v[2] * w[0] - v[0] * w[2]) +
                         u[2] * (v[0] * w[1] - v[1] * w[0]);
            int o = det > bound    ? -1
                    : det < -bound ? 1
                                   : pred_orient3d(X(m, T->v[f[0]]), X(m, T->v[f[1]]),
                                                   X(m, T->v[f[2]]), p);
            if (o < 0) {
                tm_link l = T->n[fi];
                if (tm_is_special(l)) {
                    *tet = t;
                    if (exit_link)
                        *exit_link = l;
                    return 1;
                }
                t = tm_ltet(l);
                from = tm_lface(l);
                moved = 1;
                break;
            }
        }
        if (!moved) {
            *tet = t;
            return 0;
        }
    }
    return PDR_ETOPOLOGY;
}

/* ------------------------------------------------------------ conflict */

static inline __attribute__((always_inline)) int conflict(const tm_mesh *m, uint32_t t,
                                                          const double p[3])
{
    const uint32_t *v = m->tets[t].v;
    /* One test instead of four branches: is any vertex the infinite one? */
    if (((v[0] == TM_VINF) | (v[1] == TM_VINF) | (v[2] == TM_VINF) | (v[3] == TM_VINF)) == 0)
        return pred_insphere_sos_fast(X(m, v[0]), X(m, v[1]), X(m, v[2]), X(m, v[3]), p);
    /* A ghost: in conflict iff p is beyond its hull face, or on the face's
     * plane and inside its (perturbed) circumcircle. */
    int k = v[0] == TM_VINF ? 0 : v[1] == TM_VINF ? 1 : v[2] == TM_VINF ? 2 : 3;
    const uint8_t *f = tm_face_vtx[k];
    const double *a = X(m, v[f[0]]), *b = X(m, v[f[1]]), *c = X(m, v[f[2]]);
    int o = pred_orient3d(a, b, c, p);
    if (o)
        return o;
    return pred_incircle3d_sos(a, b, c, p);
}

int dt_conflict(const tm_mesh *m, uint32_t t, const double p[3])
{
    return conflict(m, t, p);
}

static uint32_t vertex_at(const tm_mesh *m, uint32_t t, const double *p)
{
    for (int s = 0; s < 4; s++) {
        uint32_t v = m->tets[t].v[s];
        if (v != TM_VINF && !pred_lexcmp3(X(m, v), p))
            return v;
    }
    return TM_NONE;
}

/* -------------------------------------------------------------- search */

static void clear_marks(tm_mesh *m, dt_cavity *c)
{
    for (size_t i = 0; i < c->ntets; i++)
        m->flags[c->tets[i]] &= (uint16_t)~TM_F_CAVITY;
    c->pending = 0;
}

void dt_cavity_unlock(tm_mesh *m, dt_cavity *c)
{
    if (m->lock)
        for (size_t i = 0; i < c->nheld; i++)
            if (m->lock[c->held[i]] == c->lock_owner)
                tm_set_lock(m, c->held[i], 0);
    c->nheld = 0;
}

void dt_cavity_abandon(tm_mesh *m, dt_cavity *c)
{
    if (c->pending)
        clear_marks(m, c);
    dt_cavity_unlock(m, c);
}

/* Returns 1 if t is free or ours (taking it if free and lock is 1; lock
 * 2 only looks), 0 if locked by someone else, PDR_ENOMEM. Out of line:
 * the search of the sequential mesher never calls it, and its callers
 * inline only the test of lock_free. */
__attribute__((noinline)) static int take_lock_slow(tm_mesh *m, dt_cavity *c, uint32_t t,
                                                    int lock)
{
    uint32_t owner = m->lock[t];
    if (owner == c->lock_owner)
        return 1;
    if (owner != 0)
        return 0;
    if (lock == 2)
        return 1;
    if (pdr_grow((void **)&c->held, &c->cap_held, c->nheld + 1, sizeof *c->held))
        return PDR_ENOMEM;
    tm_set_lock(m, t, c->lock_owner);
    c->held[c->nheld++] = t;
    return 1;
}

/* A check only (lock 2) of a tetrahedron whose summary bit is clear
 * (tm_is_locked): free, answered without reading lock[t]. */
static inline int take_lock(tm_mesh *m, dt_cavity *c, uint32_t t, int lock)
{
    if (lock == 2 && !tm_is_locked(m, t))
        return 1;
    return take_lock_slow(m, c, t, lock);
}

static inline int add_bface(dt_cavity *c, uint32_t t, int f, int reason, tm_link outer)
{
    if (c->nbnd == c->cap_bnd &&
        pdr_grow((void **)&c->bnd, &c->cap_bnd, c->nbnd + 1, sizeof *c->bnd))
        return PDR_ENOMEM;
    dt_bface *b = &c->bnd[c->nbnd++];
    b->tet = t;
    b->face = (uint8_t)f;
    b->reason = (uint8_t)reason;
    b->spare = 0;
    b->outer = outer;
    return 0;
}

static inline int add_cavity_tet(tm_mesh *m, dt_cavity *c, uint32_t t, size_t *sp)
{
    if ((c->ntets == c->cap_tets &&
         pdr_grow((void **)&c->tets, &c->cap_tets, c->ntets + 1, sizeof *c->tets)) ||
        (*sp == c->cap_stack &&
         pdr_grow((void **)&c->stack, &c->cap_stack, *sp + 1, sizeof *c->stack)))
        return PDR_ENOMEM;
    m->flags[t] |= TM_F_CAVITY;
    c->tets[c->ntets++] = t;
    c->stack[(*sp)++] = t;
    return 0;
}

/* 0 if p lies on or behind face f of tetrahedron t (seen from t), the
 * test of dt_cavity_is_star for one boundary face; 1 for a ghost's face. */
static int face_sees(const tm_mesh *m, uint32_t t, int f, const double p[3])
{
    const tm_tet *T = &m->tets[t];
    const uint8_t *fv = tm_face_vtx[f];
    uint32_t a = T->v[fv[0]], b = T->v[fv[1]], d = T->v[fv[2]];
    if (a == TM_VINF || b == TM_VINF || d == TM_VINF)
        return 1;
    return pred_orient3d(X(m, a), X(m, b), X(m, d), p) > 0;
}

/* The search of dt_cavity_search once its mode of locking is known:
 * lock 0 none, 1 take (DT_LOCK), 2 check (DT_CHECK_LOCKS). Inlined once
 * per mode, so that each copy tests only what its mode needs: the
 * sequential mesher's has no lock test at all, and a PE's local search
 * reads one summary bit per tetrahedron it visits. */
static inline __attribute__((always_inline)) int search_locked(tm_mesh *m, const double p[3],
                                                               uint32_t start, unsigned flags,
                                                               dt_cavity *c, const int lock)
{
    uint32_t t0 = start;
    if (flags & DT_LOCATE) {
        tm_link exit = TM_LINK_NONE;
        int rc = dt_locate(m, p, start, &t0, &exit);
        if (rc < 0)
            return rc;
        if (rc == 1) {
            c->status = DT_OUTSIDE_DOMAIN;
            c->located = t0;
            c->exit_link = exit;
            return 0;
        }
        if (!tm_is_ghost(m, t0) && (c->dup_vertex = vertex_at(m, t0, p)) != TM_NONE) {
            c->status = DT_DUPLICATE;
            return 0;
        }
    } else {
        if (t0 >= m->nslots || tm_is_dead(m, t0))
            return PDR_EINVAL;
        int s = conflict(m, t0, p);
        if (s == 0) {
            c->dup_vertex = vertex_at(m, t0, p);
            c->status = DT_DUPLICATE;
            return 0;
        }
        if (s < 0)
            return PDR_EINVAL;
    }
    c->located = t0;
    if (lock) {
        int r = take_lock(m, c, t0, lock);
        if (r <= 0) {
            c->status = DT_LOCKED;
            c->blocker = t0;
            return r < 0 ? r : 0;
        }
    }

    size_t sp = 0;
    int rc = add_cavity_tet(m, c, t0, &sp);
    c->pending = 1;
    uint16_t *fl = m->flags;
    int stop_marked = (flags & DT_STOP_MARKED) != 0;
    int walls = stop_marked && (flags & DT_GHOST_WALLS);
    int star = !lock && (flags & DT_STAR);
    while (!rc && sp > 0) {
        if (!lock && c->max_tets && c->ntets > c->max_tets) {
            clear_marks(m, c);
            c->status = DT_TOO_BIG;
            return 0;
        }
        /* Room for the four faces of t, so that the appends below need no
         * checks. */
        if ((c->ntets + 4 > c->cap_tets &&
             pdr_grow((void **)&c->tets, &c->cap_tets, c->ntets + 4, sizeof *c->tets)) ||
            (sp + 4 > c->cap_stack &&
             pdr_grow((void **)&c->stack, &c->cap_stack, sp + 4, sizeof *c->stack)) ||
            (c->nbnd + 4 > c->cap_bnd &&
             pdr_grow((void **)&c->bnd, &c->cap_bnd, c->nbnd + 4, sizeof *c->bnd))) {
            rc = PDR_ENOMEM;
            break;
        }
        uint32_t t = c->stack[--sp];
        const tm_tet *T = &m->tets[t];
        uint16_t ft = fl[t];
        /* Start the memory loads of all four neighbours before testing the
         * first one. */
        for (int f = 0; f < 4; f++)
            if (!tm_is_special(T->n[f]))
                __builtin_prefetch(&m->tets[tm_ltet(T->n[f])]);
        for (int f = 0; f < 4; f++) {
            tm_link l = T->n[f];
            if (tm_is_special(l)) {
                int remote = l != TM_LINK_NONE;
                rc = add_bface(c, t, f, remote ? DT_BND_REMOTE : DT_BND_DOMAIN, l);
                c->nremote += (size_t)remote;
                if (star && !rc && !face_sees(m, t, f, p)) {
                    clear_marks(m, c);
                    c->status = DT_NOT_STAR;
                    return 0;
                }
                continue;
            }
            int crossed = 0;
            if (stop_marked && (ft & TM_F_FACEMARK(f))) {
                if (!(c->may_cross && c->may_cross(c->cross_arg, m, t, f))) {
                    /* The tetrahedron behind is the cavity's closure: the
                     * new one on this face will link to it. */
                    if (lock) {
                        int r = take_lock(m, c, tm_ltet(l), lock);
                        if (r <= 0) {
                            clear_marks(m, c);
                            c->status = DT_LOCKED;
                            c->blocker = tm_ltet(l);
                            return r;
                        }
                    }
                    rc = add_bface(c, t, f, DT_BND_MARKED, l);
                    c->nmarked++;
                    if (star && !rc && !face_sees(m, t, f, p)) {
                        clear_marks(m, c);
                        c->status = DT_NOT_STAR;
                        return 0;
                    }
                    continue;
                }
                crossed = 1;
            }
            uint32_t u = tm_ltet(l);
            uint16_t fu = fl[u];
            if (fu & TM_F_CAVITY)
                continue;
            if (walls && tm_is_ghost(m, u)) {
                /* A ghost wall: entered across the boundary piece the
                 * point splits, and nowhere else (see DT_GHOST_WALLS).
                 * From another ghost it is entered when its own face is
                 * such a piece (the search would enter it from inside
                 * anyway, and their common face is no boundary then). */
                int enter = crossed;
                if (tm_is_ghost(m, t)) {
                    int k = tm_ghost_slot(m, u);
                    enter = c->may_cross && (fu & TM_F_FACEMARK(k)) &&
                            c->may_cross(c->cross_arg, m, u, k);
                }
                if (!enter) {
                    if (lock) {
                        int r = take_lock(m, c, u, lock);
                        if (r <= 0) {
                            clear_marks(m, c);
                            c->status = DT_LOCKED;
                            c->blocker = u;
                            return r;
                        }
                    }
                    rc = add_bface(c, t, f, DT_BND_OUTSIDE, l);
                    continue;
                }
                if (lock) {
                    int r = take_lock(m, c, u, lock);
                    if (r <= 0) {
                        clear_marks(m, c);
                        c->status = DT_LOCKED;
                        c->blocker = u;
                        return r;
                    }
                }
                c->tets[c->ntets++] = u;
                c->stack[sp++] = u;
                fl[u] = (uint16_t)(fu | TM_F_CAVITY);
                continue;
            }
            if (lock) {
                int r = take_lock(m, c, u, lock);
                if (r <= 0) {
                    clear_marks(m, c);
                    c->status = DT_LOCKED;
                    c->blocker = u;
                    return r;
                }
            }
            int s = conflict(m, u, p);
            if (s == 0) {
                /* p is a vertex of u: only possible for a duplicate point
                 * (without DT_LOCATE, or equal to a ghost's hull vertex). */
                clear_marks(m, c);
                c->dup_vertex = vertex_at(m, u, p);
                c->status = DT_DUPLICATE;
                if (c->dup_vertex == TM_NONE)
                    return PDR_ETOPOLOGY;
                return 0;
            }
            /* In conflict: u joins the cavity; else face f bounds it. The
             * outcome is a coin toss for the branch predictor, so both
             * records are written and only the counters depend on it. */
            unsigned in = s > 0;
            c->tets[c->ntets] = u;
            c->stack[sp] = u;
            fl[u] = (uint16_t)(fu | in * TM_F_CAVITY);
            c->ntets += in;
            sp += in;
            dt_bface *b = &c->bnd[c->nbnd];
            b->tet = t;
            b->face = (uint8_t)f;
            b->reason = DT_BND_OUTSIDE;
            b->spare = 0;
            b->outer = l;
            c->nbnd += !in;
            if (star && !in && !face_sees(m, t, f, p)) {
                clear_marks(m, c);
                c->status = DT_NOT_STAR;
                return 0;
            }
        }
    }
    if (rc) {
        clear_marks(m, c);
        return rc;
    }
    return 0;
}

int dt_cavity_search(tm_mesh *m, const double p[3], uint32_t start, unsigned flags,
                     dt_cavity *c)
{
    if (c->pending)
        dt_cavity_abandon(m, c);
    memcpy(c->p, p, sizeof c->p);
    c->flags = flags;
    c->status = DT_OK;
    c->ntets = c->nbnd = c->nnew = c->nmarked = c->nremote = 0;
    c->located = c->dup_vertex = c->blocker = TM_NONE;
    int lock = !m->lock ? 0 : (flags & DT_LOCK) ? 1 : (flags & DT_CHECK_LOCKS) ? 2 : 0;
    if (lock == 1) {
        c->nheld = 0;
        return search_locked(m, p, start, flags, c, 1);
    }
    if (lock == 2)
        return search_locked(m, p, start, flags, c, 2);
    return search_locked(m, p, start, flags, c, 0);
}

int dt_cavity_is_star(const tm_mesh *m, const dt_cavity *c)
{
    for (size_t i = 0; i < c->nbnd; i++) {
        const tm_tet *T = &m->tets[c->bnd[i].tet];
        const uint8_t *f = tm_face_vtx[c->bnd[i].face];
        uint32_t a = T->v[f[0]], b = T->v[f[1]], d = T->v[f[2]];
        if (a == TM_VINF || b == TM_VINF || d == TM_VINF)
            continue; /* a new ghost: no orientation to check */
        if (pred_orient3d(X(m, a), X(m, b), X(m, d), c->p) <= 0)
            return 0;
    }
    return 1;
}

/* Sets the boundary of pending cavity c (its tetrahedra marked
 * TM_F_CAVITY) anew: every face of a cavity tetrahedron whose neighbour is
 * not in the cavity, in the order of c->tets, with the reasons of a search
 * with c->flags. 0, or PDR_ENOMEM with the cavity abandoned. */
static int set_boundary(tm_mesh *m, dt_cavity *c)
{
    const uint16_t *fl = m->flags;
    c->nbnd = c->nmarked = c->nremote = 0;
    for (size_t i = 0; i < c->ntets; i++) {
        uint32_t t = c->tets[i];
        const tm_tet *T = &m->tets[t];
        for (int f = 0; f < 4; f++) {
            tm_link l = T->n[f];
            int reason;
            if (tm_is_special(l))
                reason = l == TM_LINK_NONE ? DT_BND_DOMAIN : DT_BND_REMOTE;
            else if (fl[tm_ltet(l)] & TM_F_CAVITY)
                continue;
            else if ((c->flags & DT_STOP_MARKED) && (fl[t] & TM_F_FACEMARK(f)))
                reason = DT_BND_MARKED;
            else
                reason = DT_BND_OUTSIDE;
            if (add_bface(c, t, f, reason, l)) {
                dt_cavity_abandon(m, c);
                return PDR_ENOMEM;
            }
            c->nmarked += reason == DT_BND_MARKED;
            c->nremote += reason == DT_BND_REMOTE;
        }
    }
    return 0;
}

/* 1 if p sees face f of cavity tetrahedron t from inside (a face at the
 * infinite vertex counts as seen). */
static int sees_face(const tm_mesh *m, uint32_t t, int f, const double p[3])
{
    const tm_tet *T = &m->tets[t];
    const uint8_t *fv = tm_face_vtx[f];
    uint32_t a = T->v[fv[0]], b = T->v[fv[1]], d = T->v[fv[2]];
    return a == TM_VINF || b == TM_VINF || d == TM_VINF ||
           pred_orient3d(X(m, a), X(m, b), X(m, d), p) > 0;
}

/* Takes cavity tetrahedron t out (it has a face p does not see), unless
 * keep names it: 1 then, else 0 or PDR_ENOMEM. */
static int shrink_out(tm_mesh *m, dt_cavity *c, uint32_t t, size_t *top,
                      int (*keep)(void *arg, uint32_t t), void *arg)
{
    if (keep && keep(arg, t))
        return 1;
    m->flags[t] &= (uint16_t)~TM_F_CAVITY;
    if (*top == c->cap_stack && pdr_grow((void **)&c->stack, &c->cap_stack, *top + 1,
                                         sizeof *c->stack))
        return PDR_ENOMEM;
    c->stack[(*top)++] = t;
    return 0;
}

int dt_cavity_shrink(tm_mesh *m, dt_cavity *c, int (*keep)(void *arg, uint32_t t), void *arg)
{
    uint16_t *fl = m->flags;
    /* Tetrahedra with a boundary face p does not see from inside leave;
     * each one that leaves turns its faces against the tetrahedra that
     * stay into boundary faces, which are tested in turn. What leaves is
     * the same set whatever the order (leaving only adds boundary faces),
     * so one pass over the boundary and a work list do what rounds of
     * tests of the whole boundary did (a shrink cost its cavity's size
     * times the layers taken off). The search is over: its stack is the
     * work list. */
    size_t top = 0, out = 0;
    int rc = 0;
    for (size_t i = 0; i < c->nbnd && !rc; i++) {
        uint32_t t = c->bnd[i].tet;
        if (!(fl[t] & TM_F_CAVITY) || sees_face(m, t, c->bnd[i].face, c->p))
            continue; /* seen, or leaving already */
        rc = shrink_out(m, c, t, &top, keep, arg);
    }
    out = top;
    while (top && !rc) {
        const tm_tet *T = &m->tets[c->stack[--top]];
        for (int f = 0; f < 4 && !rc; f++) {
            tm_link l = T->n[f];
            if (tm_is_special(l))
                continue;
            uint32_t u = tm_ltet(l);
            if (!(fl[u] & TM_F_CAVITY) || sees_face(m, u, tm_lface(l), c->p))
                continue;
            rc = shrink_out(m, c, u, &top, keep, arg);
            out++;
        }
    }
    if (rc) {
        dt_cavity_abandon(m, c);
        return rc;
    }
    if (!out)
        return 0;
    size_t n = 0;
    for (size_t i = 0; i < c->ntets; i++)
        if (fl[c->tets[i]] & TM_F_CAVITY)
            c->tets[n++] = c->tets[i];
    c->ntets = n;
    if (!n) {
        dt_cavity_abandon(m, c);
        return 1;
    }
    /* The boundary again. */
    return set_boundary(m, c);
}

int dt_cavity_set(tm_mesh *m, const double p[3], const uint32_t *tets, size_t n, unsigned flags,
                  dt_cavity *c)
{
    if (c->pending)
        dt_cavity_abandon(m, c);
    if (!n)
        return PDR_EINVAL;
    memcpy(c->p, p, sizeof c->p);
    c->flags = flags;
    c->status = DT_OK;
    c->ntets = c->nbnd = c->nnew = c->nmarked = c->nremote = 0;
    c->located = tets[0];
    c->dup_vertex = c->blocker = TM_NONE;
    if (n > c->cap_tets && pdr_grow((void **)&c->tets, &c->cap_tets, n, sizeof *c->tets))
        return PDR_ENOMEM;
    uint16_t *fl = m->flags;
    for (size_t i = 0; i < n; i++) {
        if (tm_is_dead(m, tets[i]) || (fl[tets[i]] & TM_F_CAVITY)) {
            clear_marks(m, c);
            return PDR_EINVAL;
        }
        fl[tets[i]] |= TM_F_CAVITY;
        c->tets[c->ntets++] = tets[i];
    }
    c->pending = 1;
    return set_boundary(m, c);
}

/* -------------------------------------------------------------- commit */

/* Slot of vertex v in T (v must be there), without branches: the
 * comparisons are unpredictable and this runs in the innermost loop. */
static inline int slot_of(const tm_tet *T, uint32_t v)
{
    return (T->v[1] == v) + 2 * (T->v[2] == v) + 3 * (T->v[3] == v);
}

/* Moves the subsegment bits of face j of a cavity tetrahedron (flags ft) to
 * the new tetrahedron's edges among its slots 0,1,2. */
static uint16_t subseg_bits(uint16_t ft, int j)
{
    const uint8_t *f = tm_face_vtx[j];
    uint16_t out = 0;
    if (ft & TM_F_SUBSEG(tm_edge_of[f[0]][f[1]]))
        out |= TM_F_SUBSEG(0); /* slots 0-1 */
    if (ft & TM_F_SUBSEG(tm_edge_of[f[0]][f[2]]))
        out |= TM_F_SUBSEG(1); /* slots 0-2 */
    if (ft & TM_F_SUBSEG(tm_edge_of[f[1]][f[2]]))
        out |= TM_F_SUBSEG(3); /* slots 1-2 */
    return out;
}

/* Links the side faces of the new tetrahedra (faces 0-2, which contain
 * the new vertex). Face k of a new tet holds v and the edge {a,b} of its
 * boundary face. The other new tet on that edge sits on the next boundary
 * face met when turning around {a,b} through the cavity, starting from the
 * cavity tet's other face on {a,b}: every link out of a cavity tet now
 * leads to a new tet. */
/* Large cavities (more than DT_LOCAL_MAX boundary vertices; points far
 * outside the hull, or degenerate point sets such as points on a curve,
 * where one insertion can replace thousands of tets): the same pairing with
 * an open-addressing hash on the edge's two vertex numbers. Turning around
 * edges would cost the number of tets around each edge, which is then
 * unbounded. Returns PDR_ENOMEM (nothing changed) if the table cannot grow. */
struct dt_edge_slot {
    uint64_t key; /* (lo << 32 | hi) + 1; 0 = empty */
    tm_link link; /* waiting face, or TM_LINK_UNSET once paired */
};

static int link_by_hash(tm_mesh *m, dt_cavity *c)
{
    size_t nb = c->nbnd, cap = 64;
    int bits = 6;
    while (cap < 4 * nb) {
        cap *= 2;
        bits++;
    }
    if (cap > c->cap_hash) {
        struct dt_edge_slot *h = pr_realloc(c->edge_hash, cap * sizeof *h);
        if (!h)
            return PDR_ENOMEM;
        c->edge_hash = h;
        c->cap_hash = cap;
    }
    struct dt_edge_slot *h = c->edge_hash;
    memset(h, 0, cap * sizeof *h);
    tm_tet *tets = m->tets;
    for (size_t i = 0; i < nb; i++) {
        uint32_t n = c->newtets[i];
        for (int k = 0; k < 3; k++) {
            uint32_t a = tets[n].v[k == 0 ? 1 : 0], b = tets[n].v[k == 2 ? 1 : 2];
            uint32_t lo = a < b ? a : b, hi = a ^ b ^ lo;
            uint64_t key = ((uint64_t)lo << 32 | hi) + 1;
            /* The top bits of the product depend on every bit of the
             * key (its low bits would ignore the first vertex). */
            size_t j = (size_t)((key * 0x9E3779B97F4A7C15ULL) >> (64 - bits));
            while (h[j].key && h[j].key != key)
                j = (j + 1) & (cap - 1);
            tm_link me = tm_mklink(n, k);
            if (h[j].key == key && h[j].link != TM_LINK_UNSET) {
                tm_link e = h[j].link;
                tets[n].n[k] = e;
                tets[tm_ltet(e)].n[tm_lface(e)] = me;
                h[j].link = TM_LINK_UNSET;
            } else {
                h[j].key = key;
                h[j].link = me;
            }
        }
    }
    return 0;
}

static void link_by_rotation(tm_mesh *m, dt_cavity *c)
{
    tm_tet *tets = m->tets;
    const uint16_t *fl = m->flags;
    size_t nb = c->nbnd;
    for (size_t i = 0; i < nb; i++) {
        uint32_t n = c->newtets[i];
        tm_tet *N = &tets[n];
        uint32_t t = c->bnd[i].tet;
        int j = c->bnd[i].face;
        const uint8_t *f = tm_face_vtx[j];
        for (int k = 0; k < 3; k++) {
            if (N->n[k] != TM_LINK_UNSET)
                continue;
            int sa = f[(k + 1) % 3], sb = f[(k + 2) % 3];
            uint32_t a = tets[t].v[sa], b = tets[t].v[sb];
            uint32_t cur = t;
            int ex = 6 - j - sa - sb;
            for (;;) {
                tm_link l = tets[cur].n[ex];
                uint32_t u = tm_ltet(l);
                if (!(fl[u] & TM_F_CAVITY)) {
                    /* u is new: slots 0..2 hold a, b and one more, slot 3
                     * the new vertex; its face k2 is the one without that
                     * third vertex... i.e. opposite it: k2 = 3 - (a's slot
                     * + b's slot). */
                    const tm_tet *U = &tets[u];
                    int k2 = 3 - slot_of(U, a) - slot_of(U, b);
                    N->n[k] = tm_mklink(u, k2);
                    tets[u].n[k2] = tm_mklink(n, k);
                    break;
                }
                const tm_tet *U = &tets[u];
                int uf = tm_lface(l);
                ex = 6 - uf - slot_of(U, a) - slot_of(U, b);
                cur = u;
            }
        }
    }
}

#define DT_LOCAL_MAX 64
#define LOCAL_TAG 0xC0000000u /* vhint values >= this are never tets */

/* Side faces of the new tetrahedra are linked with an edge table: each
 * boundary vertex gets a small local number (kept for a moment in its vhint
 * slot, tagged so it cannot be mistaken for a tet), and the first new face
 * on edge {a,b} waits in table[min][max] for the second. The table is used
 * unless the boundary has more than DT_LOCAL_MAX vertices or the cavity was
 * cut by marked faces (its boundary might then not be a simple surface);
 * link_by_rotation() does those. */
static inline void pair_faces(uint32_t *table, tm_tet *tets, uint32_t a, uint32_t b, tm_link me)
{
    uint32_t lo = a < b ? a : b, hi = a ^ b ^ lo;
    uint32_t *slot = &table[lo * DT_LOCAL_MAX + hi];
    /* First face on the edge: wait in the table. Second: link both and
     * empty the entry. Without branches (the order is a coin toss): the
     * first face links to itself until its partner overwrites that. */
    uint32_t e = *slot;
    int first = e == TM_LINK_UNSET;
    *slot = first ? me : TM_LINK_UNSET;
    tets[tm_ltet(me)].n[tm_lface(me)] = e;
    tets[first ? tm_ltet(me) : tm_ltet(e)].n[first ? tm_lface(me) : tm_lface(e)] = me;
}

static int table_ready(dt_cavity *c, size_t nb)
{
    if (c->nmarked)
        return 0;
    if (!c->edge_table) {
        c->edge_table = pr_malloc(DT_LOCAL_MAX * DT_LOCAL_MAX * sizeof *c->edge_table);
        if (!c->edge_table)
            return 0;
        for (size_t i = 0; i < DT_LOCAL_MAX * DT_LOCAL_MAX; i++)
            c->edge_table[i] = TM_LINK_UNSET;
    }
    return !pdr_grow((void **)&c->loc_ids, &c->cap_loc_ids, 3 * nb, 1);
}

/* The usual commit: everything needed from the cavity (face vertices,
 * marks) is copied out first, so the cavity's slots can be freed before the
 * new tetrahedra are made, and are reused by them while they are still in
 * the cache. Returns 0, having changed nothing but vertex hints, when the
 * edge table cannot be used (the general path then rewrites the hints). */
static int commit_reusing_cavity(tm_mesh *m, uint32_t v, dt_cavity *c)
{
    size_t nb = c->nbnd;
    if (!table_ready(c, nb) || pdr_grow((void **)&c->tri, &c->cap_tri, 4 * nb, sizeof *c->tri))
        return 0;
    tm_tet *tets = m->tets;
    uint16_t *fl = m->flags;
    uint32_t *hint = m->vhint;
    uint32_t nloc = 0;
    for (size_t i = 0; i < nb; i++) {
        dt_bface *b = &c->bnd[i];
        uint32_t t = b->tet;
        int j = b->face;
        const tm_tet *T = &tets[t];
        const uint8_t *f = tm_face_vtx[j];
        uint32_t *q = &c->tri[4 * i];
        q[0] = T->v[f[0]];
        q[1] = T->v[f[1]];
        q[2] = T->v[f[2]];
        uint16_t ft = fl[t], nf = 0;
        if (ft & (TM_F_FACEMARKS | TM_F_SUBSEGS)) {
            nf = subseg_bits(ft, j);
            if (ft & TM_F_FACEMARK(j)) {
                nf |= TM_F_FACEMARK(3);
                q[3] = (uint32_t)tm_marker(m, t, j);
            }
        }
        b->spare = nf;
        uint8_t *ids = &c->loc_ids[3 * i];
        for (int s = 0; s < 3; s++) {
            uint32_t w = q[s], k = hint[w] - LOCAL_TAG;
            if (k >= nloc || c->loc_vert[k] != w) {
                if (nloc == DT_LOCAL_MAX)
                    return 0;
                k = nloc++;
                c->loc_vert[k] = w;
                hint[w] = LOCAL_TAG + k;
            }
            ids[s] = (uint8_t)k;
        }
    }
    for (size_t i = 0; i < c->ntets; i++)
        tm_free_tet(m, c->tets[i]);
    uint32_t nghost = 0;
    for (size_t i = 0; i < nb; i++) {
        const dt_bface *b = &c->bnd[i];
        const uint32_t *q = &c->tri[4 * i];
        uint32_t n = tm_alloc_tet(m);
        tm_tet *N = &tets[n];
        N->v[0] = q[0];
        N->v[1] = q[1];
        N->v[2] = q[2];
        N->v[3] = v;
        N->n[3] = b->outer;
        if (!tm_is_special(b->outer))
            tets[tm_ltet(b->outer)].n[tm_lface(b->outer)] = tm_mklink(n, 3);
        unsigned ghost = (q[0] == TM_VINF) | (q[1] == TM_VINF) | (q[2] == TM_VINF);
        fl[n] = b->spare;
        if ((b->spare & TM_F_FACEMARK(3)) && tm_has_markers(m))
            tm_set_marker(m, n, 3, (int32_t)q[3]); /* room: dt_cavity_commit */
        nghost += ghost;
        c->newtets[i] = n;
    }
    m->nghost += nghost;
    uint32_t *tab = c->edge_table;
    for (size_t i = 0; i < nb; i++) {
        uint32_t n = c->newtets[i];
        const uint8_t *l = &c->loc_ids[3 * i];
        pair_faces(tab, tets, l[1], l[2], tm_mklink(n, 0));
        pair_faces(tab, tets, l[0], l[2], tm_mklink(n, 1));
        pair_faces(tab, tets, l[0], l[1], tm_mklink(n, 2));
    }
    for (size_t i = 0; i < nb; i++) {
        uint32_t n = c->newtets[i];
        const tm_tet *N = &tets[n];
        hint[N->v[0]] = hint[N->v[1]] = hint[N->v[2]] = n;
    }
    if (nb)
        hint[v] = c->newtets[nb - 1];
    return 1;
}

int dt_cavity_commit(tm_mesh *m, uint32_t v, dt_cavity *c)
{
    if (!c->pending || c->status != DT_OK)
        return PDR_EINVAL;
    size_t nb = c->nbnd;
    int rc = tm_room(m, nb);
    if (!rc)
        rc = tm_marker_room(m, nb);
    if (!rc)
        rc = pdr_grow((void **)&c->newtets, &c->cap_new, nb, sizeof *c->newtets);
    if (rc)
        return rc;
    if (commit_reusing_cavity(m, v, c)) {
        c->nnew = nb;
        c->pending = 0;
        return 0;
    }

    /* The general path: new slots, cavity kept intact until the end so
     * that links can be found by turning around edges if need be. */
    tm_tet *tets = m->tets;
    uint16_t *fl = m->flags;
    uint32_t *hint = m->vhint;
    uint32_t nghost = 0;
    /* 1. One new tetrahedron per boundary face, linked to the outside; the
     * cavity tetrahedron's link across that face is redirected to it, which
     * is how link_by_rotation() recognises the new tets. */
    for (size_t i = 0; i < nb; i++) {
        const dt_bface *b = &c->bnd[i];
        uint32_t t = b->tet;
        int j = b->face;
        uint32_t n = tm_alloc_tet(m);
        tm_tet *T = &tets[t], *N = &tets[n];
        const uint8_t *f = tm_face_vtx[j];
        uint32_t v0 = T->v[f[0]], v1 = T->v[f[1]], v2 = T->v[f[2]];
        N->v[0] = v0;
        N->v[1] = v1;
        N->v[2] = v2;
        N->v[3] = v;
        N->n[0] = N->n[1] = N->n[2] = TM_LINK_UNSET;
        N->n[3] = b->outer;
        if (!tm_is_special(b->outer))
            tets[tm_ltet(b->outer)].n[tm_lface(b->outer)] = tm_mklink(n, 3);
        uint16_t ft = fl[t];
        unsigned ghost = (v0 == TM_VINF) | (v1 == TM_VINF) | (v2 == TM_VINF);
        uint16_t nf = 0;
        if (ft & (TM_F_FACEMARKS | TM_F_SUBSEGS)) {
            nf |= subseg_bits(ft, j);
            if (ft & TM_F_FACEMARK(j)) {
                nf |= TM_F_FACEMARK(3);
                if (tm_has_markers(m)) /* room: above */
                    tm_set_marker(m, n, 3, tm_marker(m, t, j));
            }
        }
        fl[n] = nf;
        nghost += ghost;
        T->n[j] = tm_mklink(n, 3);
        c->newtets[i] = n;
    }
    m->nghost += nghost;
    /* 2. Links between the new tetrahedra. */
    if (c->nmarked || link_by_hash(m, c))
        link_by_rotation(m, c);
    /* 3. Vertex hints (this also clears local numbers left by an attempt of
     * commit_reusing_cavity), and the cavity
     * goes to the free list. */
    for (size_t i = 0; i < nb; i++) {
        uint32_t n = c->newtets[i];
        const tm_tet *N = &tets[n];
        hint[N->v[0]] = hint[N->v[1]] = hint[N->v[2]] = n;
    }
    if (nb)
        hint[v] = c->newtets[nb - 1];
    for (size_t i = 0; i < c->ntets; i++)
        tm_free_tet(m, c->tets[i]);
    c->nnew = nb;
    c->pending = 0;
    return 0;
}

int dt_insert(tm_mesh *m, uint32_t v, uint32_t start, dt_cavity *c)
{
    double p[3];
    memcpy(p, X(m, v), sizeof p);
    int rc = dt_cavity_search(m, p, start, DT_LOCATE, c);
    if (rc || c->status != DT_OK)
        return rc;
    rc = dt_cavity_commit(m, v, c);
    if (rc)
        dt_cavity_abandon(m, c);
    return rc;
}

/* ------------------------------------------------- fused bulk insertion */

/* dt_build inserts points one after the other and always commits, so it
 * has an insertion of its own (bulk_insert) that keeps no public cavity
 * record and is shaped for speed (measurements in bench/kernel.md):
 *
 * - The search runs over a flat queue of faces (links out of cavity
 *   tetrahedra) and does not branch on the outcome of a conflict test (a
 *   coin toss for the branch predictor): the cavity record and the
 *   boundary record are both written, only the counts move. It prefetches
 *   the neighbours of every tetrahedron that joins the cavity.
 * - Cavity membership is a mark bit in the tetrahedron record itself (bit
 *   31 of v[0]), not TM_F_CAVITY in the flags array: the search reads the
 *   neighbour's record anyway, so the mark costs no extra memory access.
 *   Vertex numbers stay below 2^31 whenever the mesh can hold the
 *   tetrahedra (a tetrahedralization of n points has at least n - 3
 *   tetrahedra, and TM_MAX_TETS < 2^31); dt_build checks it. Marked records
 *   are never visible outside an insertion: every marked tetrahedron is
 *   deleted by it (or unmarked if it fails).
 * - The new tetrahedra are made from the boundary list afterwards and
 *   linked around their edges through a half-edge table indexed by small
 *   local vertex numbers, filled and read without branches.
 * - Slots of deleted tetrahedra go to a private pool instead of the free
 *   list, and the next insertion takes its new tetrahedra from the pool
 *   first: a slot that goes from live to pool to live keeps flags 0 (bulk
 *   building sets no flag), so the flags array is not touched at all in
 *   the usual case, and the slots are the ones the previous insertion just
 *   had in the cache. Pool slots are dead but not on the free list and
 *   counted neither in nlive nor in nfree; dt_build hands them to the free
 *   list at the end (bulk_flush).
 * - The outer tetrahedra's links are redirected to the new tetrahedra only
 *   once nothing can fail any more, so that an insertion that fails (out
 *   of memory) is undone without a trace. */
#define DT_MARK 0x80000000u

struct dt_bulk {
    uint32_t *pool; /* dead slots with flags 0, not on the free list */
    size_t npool, cap_pool;
    /* Local vertex k: its number and a new tetrahedron on it. Entry
     * DT_LOCAL_MAX is a sink for the vertices that do not fit. */
    uint32_t loc_vert[DT_LOCAL_MAX + 1];
    uint32_t loc_tet[DT_LOCAL_MAX + 1];
    /* half[a * DT_LOCAL_MAX + b]: the side face of the new tetrahedron
     * whose boundary face has the directed edge a -> b. Entries are only
     * read after this insertion wrote them, so it is never cleared. */
    uint32_t *half;
    uint8_t *ids; /* 3 local numbers per new tetrahedron */
    size_t cap_ids;
    uint32_t *fq; /* faces to look at: links out of cavity tets */
    size_t cap_fq;
    uint32_t *bf; /* boundary faces: links out of cavity tets */
    size_t cap_bf;
};

static void bulk_flush(tm_mesh *m, struct dt_bulk *bk)
{
    for (size_t i = 0; i < bk->npool; i++)
        tm__release_slot(m, bk->pool[i]);
    bk->npool = 0;
}

/* A slot for a new tetrahedron: from the pool, else the free list, else the
 * end (the caller made room). */
static inline uint32_t bulk_slot(tm_mesh *m, struct dt_bulk *bk)
{
    if (__builtin_expect(bk->npool > 0, 1))
        return bk->pool[--bk->npool];
    /* Tetrahedra made by dt_build carry no markers and no locks, so pool
     * slots have zeros there already; these slots may not. */
    return tm__take_slot(m);
}

/* Undoes a bulk insertion that failed half-way: the cavity is unmarked,
 * the new slots go to the free list, and every vertex whose hint holds a
 * local number gets a cavity tetrahedron as its hint (each such vertex is
 * on a face of one, and the cavity lives on). c->tets holds links (see
 * bulk_insert). */
static void bulk_undo(tm_mesh *m, dt_cavity *c, size_t nt, size_t nn)
{
    for (size_t i = 0; i < nn; i++)
        tm__release_slot(m, c->newtets[i]);
    for (size_t i = 0; i < nt; i++) {
        uint32_t t = tm_ltet(c->tets[i]);
        tm_tet *T = &m->tets[t];
        T->v[0] &= ~DT_MARK;
        for (int s = 0; s < 4; s++)
            if (m->vhint[T->v[s]] >= LOCAL_TAG)
                m->vhint[T->v[s]] = t;
    }
}

/* The local number of boundary vertex w (see commit_reusing_cavity), or
 * DT_LOCAL_MAX when the boundary has too many vertices for the table.
 * Without branches: whether w is new is a coin toss. For a vertex seen
 * before, the stores rewrite what is there (loc_tet gets another new
 * tetrahedron on w, as good as the first). */
static inline uint32_t bulk_local(uint32_t *restrict hint, struct dt_bulk *restrict bk,
                                  uint32_t *restrict nloc, uint32_t w, uint32_t n)
{
    uint32_t k = hint[w] - LOCAL_TAG, next = *nloc;
    uint32_t fresh = -(uint32_t)(k >= next); /* all ones if w is new */
    k ^= (k ^ next) & fresh;
    bk->loc_vert[k] = w;
    bk->loc_tet[k] = n;
    hint[w] = LOCAL_TAG + k;
    *nloc = next + (fresh & (next < DT_LOCAL_MAX));
    return k;
}

/* Inserts vertex v (coordinates p) by walking from start. Returns 0 with
 * c->status DT_OK or DT_DUPLICATE, or a negative error with the mesh as it
 * was. c->tets gets the cavity as links (u << 2 | j: tetrahedron u, reached
 * through its face j; the located tetrahedron first, with j = 0),
 * c->newtets the new tetrahedra. */
static int bulk_insert(tm_mesh *m, uint32_t v, uint32_t start, dt_cavity *c,
                       struct dt_bulk *bk)
{
    double p[3];
    memcpy(p, X(m, v), sizeof p);
    uint32_t t0;
    int rc = dt_locate(m, p, start, &t0, NULL);
    if (rc)
        return rc < 0 ? rc : PDR_ETOPOLOGY; /* no boundary in a hull mesh */
    if (!tm_is_ghost(m, t0) && (c->dup_vertex = vertex_at(m, t0, p)) != TM_NONE) {
        c->status = DT_DUPLICATE;
        return 0;
    }
    c->status = DT_OK;
    /* Every real vertex of the mesh is different from p, so no conflict
     * test below can return 0 (p is no vertex of any tetrahedron). */
    tm_tet *tets = m->tets;
    uint32_t *half = bk->half, *hint = m->vhint;
    size_t nt = 1, nb = 0, nn = 0, nq = 4;
    uint32_t nloc = 0, overflow = 0;
    int ghosts = tm_is_ghost(m, t0) ? -1 : 0; /* new minus deleted */
    c->tets[0] = tm_mklink(t0, 0);
    tets[t0].v[0] |= DT_MARK;
    if (bk->cap_fq < 4 && pdr_grow((void **)&bk->fq, &bk->cap_fq, 4, sizeof *bk->fq)) {
        tets[t0].v[0] &= ~DT_MARK;
        return PDR_ENOMEM;
    }
    uint32_t *fq = bk->fq, *bf = bk->bf;
    for (int f = 0; f < 4; f++)
        fq[f] = tets[t0].n[f];
    rc = 0;
    /* 1. The search, over a queue of faces of cavity tets, each given by
     * its link (u << 2 | j: the neighbour u across it, and the face's
     * number j in u). A neighbour in the cavity already is skipped; any
     * other is tested. Each test's outcome is a coin toss, so the search
     * does not branch on it: a tet in conflict is marked, appended to the
     * cavity and its three other faces to the queue; a tet not in
     * conflict makes the face a boundary face, appended to bk->bf (as the
     * same link); both records are written and only the counts depend on
     * the outcome. The loop goes on while there is room for three more
     * queued faces, one cavity tet and one boundary face. */
    size_t lim_q = 0, lim_t = 0, lim_b = 0;
    for (size_t q = 0; q < nq; q++) {
        if (__builtin_expect(nq + 3 > lim_q || nt + 1 > lim_t || nb + 1 > lim_b, 0)) {
            if (pdr_grow((void **)&bk->fq, &bk->cap_fq, nq + 3, sizeof *bk->fq) ||
                pdr_grow((void **)&c->tets, &c->cap_tets, nt + 1, sizeof *c->tets) ||
                pdr_grow((void **)&bk->bf, &bk->cap_bf, nb + 1, sizeof *bk->bf)) {
                rc = PDR_ENOMEM;
                break;
            }
            fq = bk->fq;
            bf = bk->bf;
            lim_q = bk->cap_fq;
            lim_t = c->cap_tets;
            lim_b = bk->cap_bf;
        }
        tm_link l = fq[q];
        if (__builtin_expect(tm_is_special(l), 0)) {
            rc = PDR_ETOPOLOGY; /* no boundary in a hull mesh */
            break;
        }
        uint32_t u = tm_ltet(l);
        tm_tet *U = &tets[u];
        uint32_t u0 = U->v[0];
        if (u0 & DT_MARK)
            continue;
        /* The filter first, ghost or not: the infinite vertex's
         * coordinates are NaN, which makes the determinant NaN and the
         * filter decline, so ghosts are told apart only on the rare path
         * where the filter could not decide. */
        int s = pred_insphere_filter_(X(m, u0), X(m, U->v[1]), X(m, U->v[2]), X(m, U->v[3]), p);
        int ug = 0;
        if (__builtin_expect(s == 2, 0)) {
            ug = tm_is_ghost(m, u);
            s = ug ? conflict(m, u, p)
                   : pred__insphere_sos_after_filter(X(m, u0), X(m, U->v[1]), X(m, U->v[2]),
                                                     X(m, U->v[3]), p);
            if (s == 0) {
                rc = PDR_ETOPOLOGY;
                break;
            }
        }
        uint32_t in = s > 0;
        U->v[0] = u0 | (in << 31);
        c->tets[nt] = l;
        nt += in;
        ghosts -= (int)in & ug;
        unsigned j = tm_lface(l);
        tm_link l1 = U->n[(j + 1) & 3], l2 = U->n[(j + 2) & 3], l3 = U->n[(j + 3) & 3];
        fq[nq] = l1;
        fq[nq + 1] = l2;
        fq[nq + 2] = l3;
        nq += 3 * in;
        /* The queued neighbours are read soon: start loading them (for a
         * boundary face, slot 0 instead, which is hot). The addresses are
         * integers (a special link, impossible here, would only prefetch
         * some address). */
        uintptr_t base = (uintptr_t)tets, keep = -(uintptr_t)in;
        __builtin_prefetch((const void *)(base + (((uintptr_t)tm_ltet(l1) * sizeof *tets) & keep)));
        __builtin_prefetch((const void *)(base + (((uintptr_t)tm_ltet(l2) * sizeof *tets) & keep)));
        __builtin_prefetch((const void *)(base + (((uintptr_t)tm_ltet(l3) * sizeof *tets) & keep)));
        bf[nb] = l;
        nb += in ^ 1u;
    }
    /* 2. Room for the new tets (arrays and slots). */
    if (!rc) {
        size_t slots = bk->npool + m->nfree + (m->tcap - m->nslots);
        if (pdr_grow((void **)&c->newtets, &c->cap_new, nb, sizeof *c->newtets) ||
            pdr_grow((void **)&bk->ids, &bk->cap_ids, 3 * nb, 1) ||
            (slots < nb && tm_room(m, m->nfree + nb + (m->tcap >> 3))))
            rc = PDR_ENOMEM;
        tets = m->tets;
    }
    if (rc) {
        for (size_t i = 0; i < nt; i++)
            tets[tm_ltet(c->tets[i])].v[0] &= ~DT_MARK;
        return rc;
    }
    /* 3. One new tet per boundary face, (face, v), its side faces entered
     * in the half-edge table. */
    for (size_t i = 0; i < nb; i++) {
        /* The face is face j of the outer tet u, which is not in the
         * cavity; seen from the cavity it has the opposite orientation. */
        tm_link l = bf[i];
        const tm_tet *U = &tets[tm_ltet(l)];
        const uint8_t *fv = tm_face_vtx[tm_lface(l)];
        uint32_t a = U->v[fv[0]], bb = U->v[fv[2]], d = U->v[fv[1]];
        uint32_t n = bulk_slot(m, bk);
        tm_tet *N = &tets[n];
        N->v[0] = a;
        N->v[1] = bb;
        N->v[2] = d;
        N->v[3] = v;
        N->n[3] = l;
        ghosts += (a == TM_VINF) | (bb == TM_VINF) | (d == TM_VINF);
        uint32_t ka = bulk_local(hint, bk, &nloc, a, n);
        uint32_t kb = bulk_local(hint, bk, &nloc, bb, n);
        uint32_t kd = bulk_local(hint, bk, &nloc, d, n);
        overflow |= (ka | kb | kd) >= DT_LOCAL_MAX;
        /* Face k of n holds the boundary edge opposite slot k: its directed
         * edges are a->b (face 2), b->d (face 0), d->a (face 1). The sink
         * number DT_LOCAL_MAX keeps the stores inside the table (of
         * (DT_LOCAL_MAX + 1)^2 entries) when it overflows. */
        half[ka * DT_LOCAL_MAX + kb] = tm_mklink(n, 2);
        half[kb * DT_LOCAL_MAX + kd] = tm_mklink(n, 0);
        half[kd * DT_LOCAL_MAX + ka] = tm_mklink(n, 1);
        uint8_t *id = &bk->ids[3 * i];
        id[0] = (uint8_t)ka;
        id[1] = (uint8_t)kb;
        id[2] = (uint8_t)kd;
        c->newtets[i] = n;
    }
    nn = nb;
    /* Everything that can fail comes before the first change to the mesh
     * outside the new slots. */
    if (!rc && (bk->npool + nt > bk->cap_pool &&
                pdr_grow((void **)&bk->pool, &bk->cap_pool, bk->npool + nt, sizeof *bk->pool)))
        rc = PDR_ENOMEM;
    if (!rc && overflow) {
        c->nbnd = nn;
        rc = link_by_hash(m, c);
    }
    if (rc) {
        bulk_undo(m, c, nt, nn);
        return rc;
    }
    if (!overflow) {
        /* The side face over a -> b meets the neighbour's face over
         * b -> a (the boundary is a closed oriented surface). */
        for (size_t i = 0; i < nn; i++) {
            tm_tet *N = &tets[c->newtets[i]];
            const uint8_t *id = &bk->ids[3 * i];
            uint32_t ka = id[0], kb = id[1], kd = id[2];
            N->n[0] = half[kd * DT_LOCAL_MAX + kb];
            N->n[1] = half[ka * DT_LOCAL_MAX + kd];
            N->n[2] = half[kb * DT_LOCAL_MAX + ka];
        }
    }
    for (size_t i = 0; i < nn; i++) {
        uint32_t n = c->newtets[i];
        tm_link l = tets[n].n[3];
        tets[tm_ltet(l)].n[tm_lface(l)] = tm_mklink(n, 3);
    }
    if (!overflow) {
        for (uint32_t k = 0; k < nloc; k++)
            hint[bk->loc_vert[k]] = bk->loc_tet[k];
    } else {
        for (size_t i = 0; i < nn; i++) {
            uint32_t n = c->newtets[i];
            const tm_tet *N = &tets[n];
            hint[N->v[0]] = hint[N->v[1]] = hint[N->v[2]] = n;
        }
    }
    hint[v] = c->newtets[nn - 1];
    uint32_t *pool = bk->pool + bk->npool;
    for (size_t i = 0; i < nt; i++)
        pool[i] = tm_ltet(c->tets[i]);
    bk->npool += nt;
    m->nlive = m->nlive + (uint32_t)nn - (uint32_t)nt;
    m->nghost = (uint32_t)((int64_t)m->nghost + ghosts);
    c->ntets = nt;
    c->nnew = nn;
    return 0;
}

/* -------------------------------------------------------- bulk building */

int dt_init_simplex(tm_mesh *m, uint32_t a, uint32_t b, uint32_t c, uint32_t d)
{
    int o = pred_orient3d(X(m, a), X(m, b), X(m, c), X(m, d));
    if (o == 0)
        return PDR_EGEOMETRY;
    if (o < 0) {
        uint32_t x = a;
        a = b;
        b = x;
    }
    int rc = tm_room(m, 5);
    if (rc)
        return rc;
    uint32_t t = tm_alloc_tet(m);
    tm_tet *T = &m->tets[t];
    T->v[0] = a;
    T->v[1] = b;
    T->v[2] = c;
    T->v[3] = d;
    uint32_t g[4];
    for (int i = 0; i < 4; i++) {
        g[i] = tm_alloc_tet(m);
        tm_tet *G = &m->tets[g[i]];
        const uint8_t *f = tm_face_vtx[i];
        G->v[0] = T->v[f[0]];
        G->v[1] = T->v[f[2]];
        G->v[2] = T->v[f[1]];
        G->v[3] = TM_VINF;
        G->n[3] = tm_mklink(t, i);
        T->n[i] = tm_mklink(g[i], 3);
        m->nghost++;
    }
    /* Ghost faces j < 3 contain vertex 0 and a hull edge: match them. */
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 3; j++) {
            const tm_tet *G = &m->tets[g[i]];
            uint32_t e0 = G->v[(j + 1) % 3], e1 = G->v[(j + 2) % 3];
            for (int i2 = 0; i2 < 4; i2++) {
                if (i2 == i)
                    continue;
                const tm_tet *H = &m->tets[g[i2]];
                for (int j2 = 0; j2 < 3; j2++) {
                    uint32_t f0 = H->v[(j2 + 1) % 3], f1 = H->v[(j2 + 2) % 3];
                    if ((f0 == e0 && f1 == e1) || (f0 == e1 && f1 == e0))
                        m->tets[g[i]].n[j] = tm_mklink(g[i2], j2);
                }
            }
        }
    for (int s = 0; s < 4; s++)
        m->vhint[T->v[s]] = t;
    m->vhint[TM_VINF] = g[0];
    return 0;
}

static int collinear(const double *a, const double *b, const double *c)
{
    double a2[3][2] = {{a[0], a[1]}, {a[1], a[2]}, {a[2], a[0]}};
    double b2[3][2] = {{b[0], b[1]}, {b[1], b[2]}, {b[2], b[0]}};
    double c2[3][2] = {{c[0], c[1]}, {c[1], c[2]}, {c[2], c[0]}};
    for (int k = 0; k < 3; k++)
        if (pred_orient2d(a2[k], b2[k], c2[k]))
            return 0;
    return 1;
}

/* Moves vertex order[i] to number i+1, recording old numbers in gid. */
static int renumber(tm_mesh *m, uint32_t *order, size_t n)
{
    int rc = tm_enable(m, TM_FEAT_GIDS);
    if (rc)
        return rc;
    double *xyz = pr_malloc((n + 1) * 3 * sizeof *xyz);
    uint64_t *gid = pr_malloc((n + 1) * sizeof *gid);
    if (!xyz || !gid) {
        pr_free(xyz);
        pr_free(gid);
        return PDR_ENOMEM;
    }
    memcpy(xyz, m->xyz, 3 * sizeof *xyz);
    gid[0] = m->gid[0];
    for (size_t i = 0; i < n; i++) {
        memcpy(xyz + 3 * (i + 1), X(m, order[i]), 3 * sizeof *xyz);
        gid[i + 1] = m->gid[order[i]];
        order[i] = (uint32_t)(i + 1);
    }
    memcpy(m->xyz, xyz, (n + 1) * 3 * sizeof *xyz);
    memcpy(m->gid, gid, (n + 1) * sizeof *gid);
    pr_free(xyz);
    pr_free(gid);
    return 0;
}

int dt_build(tm_mesh *m, const dt_build_opts *opts, dt_build_stats *stats)
{
    dt_build_stats st;
    memset(&st, 0, sizeof st);
    size_t n = m->nv - 1;
    if (n < 4)
        return PDR_EGEOMETRY;
    /* About 6.7 tetrahedra per point for random points; untouched
     * reserve costs address space only. */
    int rc = tm_room(m, n * 7 + 64);
    if (rc)
        return rc;
    uint32_t *order = pr_malloc(n * sizeof *order);
    if (!order)
        return PDR_ENOMEM;
    double t0 = pdr_now();
    rc = ss_brio_hilbert(X(m, 1), n, opts ? opts->seed : 0, 0, order);
    if (rc) {
        pr_free(order);
        return rc;
    }
    for (size_t i = 0; i < n; i++)
        order[i] += 1; /* point i is vertex i+1 */
    if (opts && opts->renumber) {
        rc = renumber(m, order, n);
        if (rc) {
            pr_free(order);
            return rc;
        }
    }
    double t1 = pdr_now();
    st.sort_seconds = t1 - t0;

    /* The first four points in general position, in insertion order. */
    size_t pick[4] = {0, 0, 0, 0};
    int found = 1;
    size_t i = 1;
    while (i < n && !pred_lexcmp3(X(m, order[i]), X(m, order[0])))
        i++;
    pick[1] = i;
    while (i < n && collinear(X(m, order[0]), X(m, order[pick[1]]), X(m, order[i])))
        i++;
    pick[2] = i;
    while (i < n && !pred_orient3d(X(m, order[0]), X(m, order[pick[1]]), X(m, order[pick[2]]),
                                   X(m, order[i])))
        i++;
    pick[3] = i;
    if (i >= n)
        found = 0;
    if (!found) {
        pr_free(order);
        return PDR_EGEOMETRY;
    }
    rc = dt_init_simplex(m, order[0], order[pick[1]], order[pick[2]], order[pick[3]]);
    if (rc) {
        pr_free(order);
        return rc;
    }
    st.inserted = 4;
    dt_cavity c;
    dt_cavity_init(&c);
    struct dt_bulk bk;
    memset(&bk, 0, sizeof bk);
    /* The bulk insertion needs the mark bit free in vertex numbers, the
     * infinite vertex at NaN (as tm_init leaves it) and its scratch
     * arrays. */
    bk.half = pr_malloc((DT_LOCAL_MAX + 1) * (DT_LOCAL_MAX + 1) * sizeof *bk.half);
    int fused = bk.half && m->nv <= DT_MARK &&
                m->xyz[0] != m->xyz[0] && /* NaN: ghosts fail the filter */
                !pdr_grow((void **)&c.tets, &c.cap_tets, 256, sizeof *c.tets) &&
                !pdr_grow((void **)&c.newtets, &c.cap_new, 256, sizeof *c.newtets);
    uint32_t last = m->vhint[order[0]];
    for (i = 1; i < n && !rc; i++) {
        if (i == pick[1] || i == pick[2] || i == pick[3])
            continue;
        uint32_t v = order[i];
        rc = fused ? bulk_insert(m, v, last, &c, &bk) : dt_insert(m, v, last, &c);
        if (rc)
            break;
        if (c.status == DT_DUPLICATE) {
            st.duplicates++;
            continue;
        }
        if (c.status != DT_OK) { /* cannot happen on a convex hull */
            rc = PDR_ETOPOLOGY;
            break;
        }
        st.inserted++;
        if (c.nnew > st.largest_cavity)
            st.largest_cavity = c.nnew;
        last = m->vhint[v];
        if (opts && opts->progress && (i & 0xffff) == 0)
            opts->progress(opts->progress_arg, i, n);
    }
    bulk_flush(m, &bk);
    pr_free(bk.pool);
    pr_free(bk.half);
    pr_free(bk.ids);
    pr_free(bk.bf);
    pr_free(bk.fq);
    dt_cavity_free(&c);
    pr_free(order);
    st.insert_seconds = pdr_now() - t1;
    if (stats)
        *stats = st;
    return rc;
}
