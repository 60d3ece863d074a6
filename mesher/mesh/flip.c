/* mesh/flip.c -- Lawson's flips with constraints kept (see mesh/flip.h). */
#include "config.h"

#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "base/pdr_util.h"
#include "geom/pred.h"
#include "mesh/flip.h"

#define X(m, v) ((m)->xyz + 3 * (size_t)(v))

/* *rc of a try that found a tetrahedron locked by another owner (not an
 * error: the face is left). */
#define FLIP_LOCKED 1

static void sort3(uint32_t k[3])
{
    uint32_t x;
    if (k[0] > k[1])
        x = k[0], k[0] = k[1], k[1] = x;
    if (k[1] > k[2])
        x = k[1], k[1] = k[2], k[2] = x;
    if (k[0] > k[1])
        x = k[0], k[0] = k[1], k[1] = x;
}

static void face_key(const tm_tet *T, int f, uint32_t k[3])
{
    for (int i = 0; i < 3; i++)
        k[i] = T->v[tm_face_vtx[f][i]];
    sort3(k);
}

static int slot(const tm_tet *T, uint32_t v)
{
    return T->v[0] == v ? 0 : T->v[1] == v ? 1 : T->v[2] == v ? 2 : T->v[3] == v ? 3 : -1;
}

/* A face of the region being flipped, as seen from inside it. */
typedef struct outer_face {
    uint32_t key[3];
    tm_link outer; /* the link beyond the region (a neighbour or special) */
    int32_t marker;
    int marked;
} outer_face;

/* Orients (a, b, c, d) positively (the flips only make tetrahedra whose
 * orientation is known to be nonzero); a ghost gets the infinite vertex in
 * slot 3 and its face turned so that inside, the side of vertex in, is
 * negative (mesh/tm.h). */
static void oriented(const tm_mesh *m, uint32_t q[4], uint32_t in)
{
    int g = q[0] == TM_VINF ? 0 : q[1] == TM_VINF ? 1 : q[2] == TM_VINF ? 2 : q[3] == TM_VINF ? 3 : -1;
    if (g >= 0) {
        uint32_t x = q[g];
        q[g] = q[3];
        q[3] = x;
        if (pred_orient3d(X(m, q[0]), X(m, q[1]), X(m, q[2]), X(m, in)) > 0) {
            x = q[1];
            q[1] = q[2];
            q[2] = x;
        }
        return;
    }
    if (pred_orient3d(X(m, q[0]), X(m, q[1]), X(m, q[2]), X(m, q[3])) < 0) {
        uint32_t x = q[2];
        q[2] = q[3];
        q[3] = x;
    }
}

/* 1 if one of old[0..no) is locked by another owner than h's. */
static int locked(const tm_mesh *m, const flip_hooks *h, const uint32_t *old, int no)
{
    if (!m->lock)
        return 0;
    uint32_t own = h ? h->lock_owner : 0;
    for (int i = 0; i < no; i++)
        if (tm_held_by_other(m, old[i], own))
            return 1;
    return 0;
}

/* Replaces tetrahedra old[0..no) by tetrahedra with the vertices nv[0..nn)
 * (made positive here; a ghost's inside is the side of in[i]), linked to each other and to the region's outer
 * faces, which keep their marks; subsegment bits of the old edges are
 * kept. The new slots go to made[]. */
static int replace(tm_mesh *m, const uint32_t *old, int no, uint32_t nv[][4], int nn,
                   const uint32_t *in, const flip_hooks *h, uint32_t *made)
{
    outer_face of[16];
    int nof = 0;
    uint32_t segs[24][2];
    int nseg = 0;
    for (int i = 0; i < no; i++) {
        uint32_t t = old[i];
        const tm_tet *T = &m->tets[t];
        for (int f = 0; f < 4; f++) {
            tm_link l = T->n[f];
            int inside = 0;
            for (int j = 0; j < no && !tm_is_special(l); j++)
                inside |= tm_ltet(l) == old[j];
            if (inside)
                continue;
            outer_face *o = &of[nof++];
            face_key(T, f, o->key);
            o->outer = l;
            o->marked = (m->flags[t] & TM_F_FACEMARK(f)) != 0;
            o->marker = tm_marker(m, t, f);
        }
        for (int e = 0; e < 6; e++) {
            if (!(m->flags[t] & TM_F_SUBSEG(e)))
                continue;
            uint32_t a = T->v[tm_edge_vtx[e][0]], b = T->v[tm_edge_vtx[e][1]];
            if (a > b) {
                uint32_t x = a;
                a = b;
                b = x;
            }
            int seen = 0;
            for (int k = 0; k < nseg && !seen; k++)
                seen = segs[k][0] == a && segs[k][1] == b;
            if (!seen) {
                segs[nseg][0] = a;
                segs[nseg][1] = b;
                nseg++;
            }
        }
    }
    /* The caller's data of old[0] (all old tetrahedra lie between the same
     * constraints) goes to every new one before the slots are reused. */
    uint32_t src = old[0];
    int rc = tm_room(m, (size_t)nn);
    if (!rc)
        rc = tm_marker_room(m, (size_t)nn);
    if (rc)
        return rc;
    for (int i = 0; i < no; i++)
        tm_free_tet(m, old[i]);
    for (int i = 0; i < nn; i++) {
        uint32_t n = tm_alloc_tet(m);
        made[i] = n;
        oriented(m, nv[i], in[i]);
        memcpy(m->tets[n].v, nv[i], sizeof m->tets[n].v);
        m->nghost += (uint32_t)tm_is_ghost(m, n);
        for (int f = 0; f < 4; f++)
            m->tets[n].n[f] = TM_LINK_UNSET;
    }
    for (int i = 0; i < nn; i++) {
        uint32_t n = made[i];
        tm_tet *N = &m->tets[n];
        for (int f = 0; f < 4; f++) {
            if (N->n[f] != TM_LINK_UNSET)
                continue;
            uint32_t k[3], k2[3];
            face_key(N, f, k);
            int done = 0;
            for (int j = 0; j < nn && !done; j++) {
                if (j == i)
                    continue;
                for (int g = 0; g < 4 && !done; g++) {
                    face_key(&m->tets[made[j]], g, k2);
                    if (k[0] == k2[0] && k[1] == k2[1] && k[2] == k2[2]) {
                        N->n[f] = tm_mklink(made[j], g);
                        m->tets[made[j]].n[g] = tm_mklink(n, f);
                        done = 1;
                    }
                }
            }
            for (int q = 0; q < nof && !done; q++) {
                if (of[q].key[0] != k[0] || of[q].key[1] != k[1] || of[q].key[2] != k[2])
                    continue;
                N->n[f] = of[q].outer;
                if (!tm_is_special(of[q].outer))
                    m->tets[tm_ltet(of[q].outer)].n[tm_lface(of[q].outer)] = tm_mklink(n, f);
                else if (of[q].outer != TM_LINK_NONE && h && h->relink)
                    h->relink(h->arg, of[q].outer, n, f);
                if (of[q].marked) {
                    m->flags[n] |= TM_F_FACEMARK(f);
                    if (tm_has_markers(m))
                        tm_set_marker(m, n, f, of[q].marker); /* room above */
                }
                done = 1;
            }
            if (!done)
                return PDR_ETOPOLOGY;
        }
        for (int e = 0; e < 6; e++) {
            uint32_t a = N->v[tm_edge_vtx[e][0]], b = N->v[tm_edge_vtx[e][1]];
            if (a > b) {
                uint32_t x = a;
                a = b;
                b = x;
            }
            for (int q = 0; q < nseg; q++)
                if (segs[q][0] == a && segs[q][1] == b)
                    m->flags[n] |= TM_F_SUBSEG(e);
        }
        for (int s = 0; s < 4; s++)
            if (N->v[s] != TM_VINF)
                m->vhint[N->v[s]] = n;
        if (h && h->copy && n != src && !tm_is_ghost(m, n))
            h->copy(h->arg, src, n);
    }
    return 0;
}

static int push(uint32_t **st, size_t *n, size_t *cap, tm_link l)
{
    if (pdr_grow((void **)st, cap, *n + 1, sizeof **st))
        return PDR_ENOMEM;
    (*st)[(*n)++] = l;
    return 0;
}

static int record(flip_out *out, const uint32_t *made, int nn)
{
    if (!out)
        return 0;
    if (pdr_grow((void **)&out->tets, &out->cap, out->n + (size_t)nn, sizeof *out->tets))
        return PDR_ENOMEM;
    for (int i = 0; i < nn; i++)
        out->tets[out->n++] = made[i];
    return 0;
}

/* The 3-2 flip of t and u, which share face (e1 e2 z), around their edge
 * (e1 e2) when the third tetrahedron around it is (e1 e2 p a), p and a
 * being the apexes of t and u: the ring p, a, z becomes a face with a
 * tetrahedron on each side. 1 if done. */
static int try32(tm_mesh *m, uint32_t t, uint32_t u, uint32_t p, uint32_t a, uint32_t e1,
                 uint32_t e2, uint32_t z, const flip_hooks *h, uint32_t *made, int *rc)
{
    const tm_tet *T = &m->tets[t], *U = &m->tets[u];
    int st = slot(T, z), su = slot(U, z);
    if (st < 0 || su < 0)
        return 0;
    tm_link lt = T->n[st], lu = U->n[su];
    if (tm_is_special(lt) || tm_is_special(lu) || tm_ltet(lt) != tm_ltet(lu))
        return 0;
    uint32_t w = tm_ltet(lt);
    if (tm_is_ghost(m, w) || (m->flags[t] & TM_F_FACEMARK(st)) ||
        (m->flags[u] & TM_F_FACEMARK(su)))
        return 0;
    int s1 = slot(T, e1), s2 = slot(T, e2);
    if (m->flags[t] & TM_F_SUBSEG(tm_edge_of[s1][s2]))
        return 0;
    const tm_tet *W = &m->tets[w];
    if (slot(W, e1) < 0 || slot(W, e2) < 0 || slot(W, p) < 0 || slot(W, a) < 0)
        return 0;
    const double *P = X(m, p), *A = X(m, a), *Z = X(m, z), *E1 = X(m, e1), *E2 = X(m, e2);
    int o1 = pred_orient3d(P, A, Z, E1), o2 = pred_orient3d(P, A, Z, E2);
    if (!o1 || !o2 || o1 == o2)
        return 0;
    int q1 = pred_orient3d(E1, E2, P, A), q2 = pred_orient3d(E1, E2, A, Z),
        q3 = pred_orient3d(E1, E2, Z, P);
    if (!q1 || q1 != q2 || q2 != q3)
        return 0;
    uint32_t old[3] = {t, u, w};
    if (locked(m, h, old, 3)) {
        *rc = FLIP_LOCKED;
        return 0;
    }
    uint32_t nv[2][4] = {{p, a, z, e1}, {p, a, z, e2}}, in[2] = {z, z};
    *rc = replace(m, old, 3, nv, 2, in, h, made);
    return *rc == 0;
}

/* 1 if the angle p-v-a is straight to within rounding (about 1e-6
 * radians): v a point that split segment pa. */
static int straight(const tm_mesh *m, uint32_t p, uint32_t v, uint32_t a)
{
    const double *P = X(m, p), *V = X(m, v), *A = X(m, a);
    double d1[3] = {P[0] - V[0], P[1] - V[1], P[2] - V[2]};
    double d2[3] = {A[0] - V[0], A[1] - V[1], A[2] - V[2]};
    double dot = d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2];
    double n1 = d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2];
    double n2 = d2[0] * d2[0] + d2[1] * d2[1] + d2[2] * d2[2];
    return dot < 0 && dot * dot >= (1.0 - 1e-12) * n1 * n2;
}

/* The 2-2 flip on the boundary (see flip.h): t and u share face (e1 e2 z)
 * and have marked boundary faces (e1 e2 p) and (e1 e2 a) with ghosts
 * behind them; 1 if done (made[0..4)). */
static int try22(tm_mesh *m, uint32_t t, uint32_t u, uint32_t p, uint32_t a, uint32_t e1,
                 uint32_t e2, uint32_t z, const flip_hooks *h, uint32_t *made, int *rc)
{
    if (!h || !h->facet || !tm_has_markers(m))
        return 0;
    const tm_tet *T = &m->tets[t], *U = &m->tets[u];
    int st = slot(T, z), su = slot(U, z);
    if (st < 0 || su < 0 || !(m->flags[t] & TM_F_FACEMARK(st)) ||
        !(m->flags[u] & TM_F_FACEMARK(su)) ||
        tm_marker(m, t, st) != tm_marker(m, u, su))
        return 0;
    int s1 = slot(T, e1), s2 = slot(T, e2);
    if (m->flags[t] & TM_F_SUBSEG(tm_edge_of[s1][s2]))
        return 0;
    /* p e1 a (or p e2 a) along one segment, e1 a point splitting it: the
     * quadrilateral is straight there, which rounding may show as convex,
     * and the new diagonal would run along the segment. */
    int tp = slot(T, p), ua = slot(U, a), u1 = slot(U, e1), u2 = slot(U, e2);
    if (((m->flags[t] & TM_F_SUBSEG(tm_edge_of[tp][s1])) &&
         (m->flags[u] & TM_F_SUBSEG(tm_edge_of[ua][u1])) && straight(m, p, e1, a)) ||
        ((m->flags[t] & TM_F_SUBSEG(tm_edge_of[tp][s2])) &&
         (m->flags[u] & TM_F_SUBSEG(tm_edge_of[ua][u2])) && straight(m, p, e2, a)))
        return 0;
    tm_link lt = T->n[st], lu = U->n[su];
    if (tm_is_special(lt) || tm_is_special(lu))
        return 0;
    uint32_t g1 = tm_ltet(lt), g2 = tm_ltet(lu);
    if (!tm_is_ghost(m, g1) || !tm_is_ghost(m, g2))
        return 0;
    /* The ghosts must be neighbours across their face (e1 e2 infinite). */
    const tm_tet *G = &m->tets[g1];
    int gp = slot(G, p);
    if (gp < 0 || tm_is_special(G->n[gp]) || tm_ltet(G->n[gp]) != g2)
        return 0;
    const double *P = X(m, p), *A = X(m, a), *Z = X(m, z), *E1 = X(m, e1), *E2 = X(m, e2);
    int o1 = pred_orient3d(P, A, Z, E1), o2 = pred_orient3d(P, A, Z, E2);
    if (!o1 || !o2 || o1 == o2)
        return 0;
    if (h->facet_ok && !h->facet_ok(h->arg, e1, e2, p, a))
        return 0;
    uint32_t old[4] = {t, u, g1, g2};
    if (locked(m, h, old, 4)) {
        *rc = FLIP_LOCKED;
        return 0;
    }
    uint32_t nv[4][4] = {{p, a, e1, z}, {p, a, e2, z}, {p, a, e1, TM_VINF}, {p, a, e2, TM_VINF}};
    uint32_t in[4] = {z, z, z, z};
    *rc = replace(m, old, 4, nv, 4, in, h, made);
    if (!*rc)
        *rc = h->facet(h->arg, e1, e2, p, a, made);
    return *rc == 0;
}

int flip_restore(tm_mesh *m, const uint32_t *seed, size_t nseed, const flip_hooks *h,
                 flip_out *out, size_t limit)
{
    uint32_t *st = NULL;
    size_t n = 0, cap = 0, flips = 0;
    int rc = 0;
    if (!limit)
        limit = 64 * nseed + 64;
    for (size_t i = 0; i < nseed && !rc; i++)
        for (int f = 0; f < 4 && !rc; f++)
            rc = push(&st, &n, &cap, tm_mklink(seed[i], f));
    while (!rc && n > 0 && flips < limit) {
        tm_link l = st[--n];
        uint32_t t = tm_ltet(l);
        int f = tm_lface(l);
        if (tm_is_dead(m, t) || tm_is_ghost(m, t) || (m->flags[t] & TM_F_FACEMARK(f)))
            continue;
        tm_link nl = m->tets[t].n[f];
        if (tm_is_special(nl))
            continue;
        uint32_t u = tm_ltet(nl);
        if (tm_is_ghost(m, u))
            continue;
        const tm_tet *T = &m->tets[t];
        uint32_t p = T->v[f], a = m->tets[u].v[tm_lface(nl)];
        if (pred_insphere_sos(X(m, T->v[0]), X(m, T->v[1]), X(m, T->v[2]), X(m, T->v[3]),
                              X(m, a)) <= 0)
            continue;
        uint32_t x = T->v[tm_face_vtx[f][0]], y = T->v[tm_face_vtx[f][1]],
                 z = T->v[tm_face_vtx[f][2]];
        const double *P = X(m, p), *A = X(m, a);
        int o[3] = {pred_orient3d(P, A, X(m, x), X(m, y)), pred_orient3d(P, A, X(m, y), X(m, z)),
                    pred_orient3d(P, A, X(m, z), X(m, x))};
        uint32_t made[4];
        int nn = 0;
        if (o[0] && o[0] == o[1] && o[1] == o[2] && locked(m, h, (uint32_t[2]){t, u}, 2)) {
            if (out)
                out->blocked++;
        } else if (o[0] && o[0] == o[1] && o[1] == o[2]) {
            uint32_t old[2] = {t, u};
            uint32_t nv[3][4] = {{x, y, p, a}, {y, z, p, a}, {z, x, p, a}}, in[3] = {p, p, p};
            rc = replace(m, old, 2, nv, 3, in, h, made);
            nn = 3;
            if (out && !rc)
                out->flips23++;
        } else {
            /* The edge the segment pa passes beyond: 3-2 around it. */
            const uint32_t ev[3][3] = {{x, y, z}, {y, z, x}, {z, x, y}};
            for (int k = 0; k < 3 && !nn && !rc; k++) {
                int major = o[(k + 1) % 3] != 0 && o[(k + 1) % 3] == o[(k + 2) % 3];
                if (!major || o[k] == o[(k + 1) % 3])
                    continue;
                if (try32(m, t, u, p, a, ev[k][0], ev[k][1], ev[k][2], h, made, &rc))
                    nn = 2;
                else if (!rc && try22(m, t, u, p, a, ev[k][0], ev[k][1], ev[k][2], h, made, &rc))
                    nn = 4;
            }
            if (rc == FLIP_LOCKED) {
                rc = 0;
                if (out)
                    out->blocked++;
            } else if (out && nn == 4) {
                out->flips22++;
            } else if (out && nn) {
                out->flips32++;
            } else if (out && !rc) {
                out->stuck++;
                if (pdr_grow((void **)&out->stuck_faces, &out->cap_stuck, out->nstuck + 1,
                             sizeof *out->stuck_faces))
                    rc = PDR_ENOMEM;
                else
                    out->stuck_faces[out->nstuck++] = l;
            }
        }
        if (!nn || rc)
            continue;
        flips++;
        rc = record(out, made, nn);
        for (int i = 0; i < nn && !rc; i++)
            for (int g = 0; g < 4 && !rc; g++)
                rc = push(&st, &n, &cap, tm_mklink(made[i], g));
    }
    pr_free(st);
    return rc;
}

int flip_remove_flat(tm_mesh *m, uint32_t t, const flip_hooks *h, uint32_t made[2])
{
    if (!h || !h->facet || !tm_has_markers(m) || tm_is_dead(m, t) || tm_is_ghost(m, t))
        return 0;
    const tm_tet *T = &m->tets[t];
    const uint32_t *v = T->v;
    int mk[2], um[2], nm = 0, nu = 0;
    for (int f = 0; f < 4; f++) {
        if (m->flags[t] & TM_F_FACEMARK(f)) {
            if (nm == 2)
                return 0;
            mk[nm++] = f;
        } else {
            if (nu == 2)
                return 0;
            um[nu++] = f;
        }
    }
    if (tm_marker(m, t, mk[0]) != tm_marker(m, t, mk[1]))
        return 0;
    /* The marked faces (e1 e2 p) and (e1 e2 a) share the diagonal e1 e2;
     * face f is opposite vertex v[f]. */
    uint32_t p = v[mk[0]], a = v[mk[1]], e1 = v[um[0]], e2 = v[um[1]];
    if (m->flags[t] & TM_F_SUBSEG(tm_edge_of[um[0]][um[1]]))
        return 0;
    tm_link lg1 = T->n[mk[0]], lg2 = T->n[mk[1]], ln1 = T->n[um[0]], ln2 = T->n[um[1]];
    if (tm_is_special(lg1) || tm_is_special(lg2) || tm_is_special(ln1) || tm_is_special(ln2))
        return 0;
    uint32_t g1 = tm_ltet(lg1), g2 = tm_ltet(lg2), n1 = tm_ltet(ln1), n2 = tm_ltet(ln2);
    if (!tm_is_ghost(m, g1) || !tm_is_ghost(m, g2) || tm_is_ghost(m, n1) || tm_is_ghost(m, n2))
        return 0;
    /* n1 lies across face (e2 p a), n2 across (e1 p a); their far apexes
     * are off the plane (else they are flat too: later). */
    uint32_t q1 = m->tets[n1].v[tm_lface(ln1)], q2 = m->tets[n2].v[tm_lface(ln2)];
    const double *P = X(m, p), *A = X(m, a), *E1 = X(m, e1), *E2 = X(m, e2);
    const double *Q1 = X(m, q1), *Q2 = X(m, q2);
    if (pred_orient3d(P, A, E2, Q1) == 0 || pred_orient3d(P, A, E1, Q2) == 0)
        return 0;
    /* The quadrilateral is convex: its diagonals cross (a 2D test, seen
     * from q1 off the plane). */
    int d1 = pred_orient3d(E1, E2, Q1, P), d2 = pred_orient3d(E1, E2, Q1, A);
    int d3 = pred_orient3d(P, A, Q1, E1), d4 = pred_orient3d(P, A, Q1, E2);
    if (!d1 || !d2 || !d3 || !d4 || d1 == d2 || d3 == d4)
        return 0;
    if (h->facet_ok && !h->facet_ok(h->arg, e1, e2, p, a))
        return 0;
    uint32_t old[3] = {t, g1, g2};
    if (locked(m, h, old, 3))
        return 0;
    uint32_t nv[2][4] = {{p, a, e2, TM_VINF}, {p, a, e1, TM_VINF}}, in[2] = {q1, q2};
    int rc = replace(m, old, 3, nv, 2, in, h, made);
    if (rc)
        return rc;
    const uint32_t tets[4] = {n1, n2, made[0], made[1]};
    rc = h->facet(h->arg, e1, e2, p, a, tets);
    return rc ? rc : 1;
}
