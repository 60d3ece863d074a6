/*
 * plc/plc_tri.c -- constrained Delaunay triangulation of a facet (see
 * plc/plc_tri.h).
 *
 * Triangles are stored with their vertices counterclockwise in the
 * projection: t.v[0], t.v[1], t.v[2]. Edge i of a triangle is the edge
 * opposite t.v[i], that is, the directed edge t.v[i+1] -> t.v[i+2] (indices
 * mod 3); t.nb[i] is the triangle across it and t.con[i] says whether it is
 * a constraint (a polygon edge). Across a shared edge the neighbour sees
 * the same edge reversed:
 *
 *            a                      a triangle t = (a, b, c) and its
 *           / \                     neighbour u = (d, c, b) across edge 0
 *          /   \                    of t (b -> c); in u that edge is
 *         /  t  \                   c -> b, edge 0 of u as well here.
 *        b ----- c                  Flipping edge b-c turns t, u into
 *         \  u  /                   (a, b, d) and (a, d, c).
 *          \   /
 *           \ /
 *            d
 *
 * Local vertex ids 0 .. m-1 are the facet's corners (in increasing PLC
 * index, gid maps them back), m .. m+2 the corners of an enclosing
 * triangle far outside the facet. Since that triangle encloses everything,
 * every facet vertex is interior and every walk stays inside.
 */
#include "config.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "base/pdr_util.h"
#include "plc/plc_int.h"
#include "geom/pred.h"
#include "plc/plc_tri.h"

#define NONE UINT32_MAX

struct plc_cdt_tri {
    uint32_t v[3];
    uint32_t nb[3];
    uint8_t con[3];
    uint8_t out;
};

typedef struct plc_cdt_tri tri;

#define NEXT(i) ((i) == 2 ? 0 : (i) + 1)
#define PREV(i) ((i) == 0 ? 2 : (i) - 1)

static uint32_t rng_next(plc_cdt *w)
{
    uint32_t x = w->rng ? w->rng : 2463534242u;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    return w->rng = x;
}

static int index_of(const tri *t, uint32_t v)
{
    return t->v[0] == v ? 0 : t->v[1] == v ? 1 : t->v[2] == v ? 2 : -1;
}

/* Index of neighbour n in t; n must be one (the adjacency invariant). */
static int nb_index(const tri *t, uint32_t n)
{
    return t->nb[0] == n ? 0 : t->nb[1] == n ? 1 : 2;
}

static void touch(plc_cdt *w, uint32_t ti)
{
    for (int k = 0; k < 3; k++)
        w->vtri[w->t[ti].v[k]] = ti;
}

static void replace_nb(plc_cdt *w, uint32_t n, uint32_t old, uint32_t neu)
{
    if (n == NONE)
        return;
    w->t[n].nb[nb_index(&w->t[n], old)] = neu;
}

static void set_tri(tri *t, uint32_t a, uint32_t b, uint32_t c, uint32_t na,
                    uint32_t nb, uint32_t nc, int ca, int cb, int cc)
{
    t->v[0] = a;
    t->v[1] = b;
    t->v[2] = c;
    t->nb[0] = na;
    t->nb[1] = nb;
    t->nb[2] = nc;
    t->con[0] = (uint8_t)ca;
    t->con[1] = (uint8_t)cb;
    t->con[2] = (uint8_t)cc;
    t->out = 0;
}

/* Flips edge i of triangle ti (opposite a = t.v[i]); afterwards ti is
 * (a, b, d) and its former neighbour is (a, d, c), so vertex a is at index
 * 0 of both and the two edges opposite it are the quadrilateral's far
 * sides. */
static void flip(plc_cdt *w, uint32_t ti, int i)
{
    tri *t = &w->t[ti];
    uint32_t a = t->v[i], b = t->v[NEXT(i)], c = t->v[PREV(i)];
    uint32_t ui = t->nb[i];
    tri *u = &w->t[ui];
    int j = nb_index(u, ti);
    uint32_t d = u->v[j];
    uint32_t n_ab = t->nb[PREV(i)], n_ca = t->nb[NEXT(i)];
    int c_ab = t->con[PREV(i)], c_ca = t->con[NEXT(i)];
    uint32_t n_bd = u->nb[NEXT(j)], n_dc = u->nb[PREV(j)];
    int c_bd = u->con[NEXT(j)], c_dc = u->con[PREV(j)];
    set_tri(t, a, b, d, n_bd, ui, n_ab, c_bd, 0, c_ab);
    set_tri(u, a, d, c, n_dc, n_ca, ti, c_dc, c_ca, 0);
    replace_nb(w, n_bd, ui, ti);
    replace_nb(w, n_ca, ti, ui);
    touch(w, ti);
    touch(w, ui);
}

static int reserve(plc_cdt *w, size_t m)
{
    size_t nt = 2 * m + 4;
    if (plc__grow((void **)&w->t, &w->cap_t, nt, sizeof *w->t))
        return PDR_ENOMEM;
    size_t cap = w->cap_pt;
    if (plc__grow((void **)&w->pt, &cap, m + 3, sizeof *w->pt))
        return PDR_ENOMEM;
    size_t cap2 = w->cap_pt;
    if (plc__grow((void **)&w->gid, &cap2, m + 3, sizeof *w->gid))
        return PDR_ENOMEM;
    cap2 = w->cap_pt;
    if (plc__grow((void **)&w->vtri, &cap2, m + 3, sizeof *w->vtri))
        return PDR_ENOMEM;
    w->cap_pt = cap;
    return 0;
}

static int push(plc_cdt *w, size_t *n, uint32_t x)
{
    if (plc__grow((void **)&w->stack, &w->cap_stack, *n + 1, sizeof *w->stack))
        return PDR_ENOMEM;
    w->stack[(*n)++] = x;
    return 0;
}

static int push_edge(plc_cdt *w, uint32_t a, uint32_t b)
{
    if (plc__grow((void **)&w->edges, &w->cap_edges, w->nedges + 1, sizeof *w->edges))
        return PDR_ENOMEM;
    w->edges[w->nedges++] = (uint64_t)a << 32 | b;
    return 0;
}

/* -------------------------------------------------------- point insertion */

/* Restores the Delaunay property around the new vertex p: the edges
 * opposite p in the triangles on the stack are tested and flipped. */
static int legalize(plc_cdt *w, uint32_t p, size_t n)
{
    while (n > 0) {
        uint32_t ti = w->stack[--n];
        tri *t = &w->t[ti];
        int i = index_of(t, p);
        if (i < 0)
            continue;
        uint32_t ui = t->nb[i];
        if (ui == NONE || t->con[i])
            continue;
        int j = nb_index(&w->t[ui], ti);
        uint32_t d = w->t[ui].v[j];
        if (pred_incircle(w->pt[t->v[0]], w->pt[t->v[1]], w->pt[t->v[2]], w->pt[d]) <= 0)
            continue;
        flip(w, ti, i);
        if (push(w, &n, ti) || push(w, &n, ui))
            return PDR_ENOMEM;
    }
    return 0;
}

/* Finds a triangle containing point q (closed) by a randomized visibility
 * walk, which terminates on Delaunay triangulations; a bounded number of
 * steps, then a scan, keeps it safe on constrained ones. */
static uint32_t locate(plc_cdt *w, const double q[2], uint32_t start)
{
    uint32_t ti = start;
    size_t steps = 0, limit = 4 * w->nt + 64;
    for (;;) {
        const tri *t = &w->t[ti];
        int k0 = (int)(rng_next(w) % 3), moved = 0;
        for (int k = 0; k < 3 && !moved; k++) {
            int e = (k0 + k) % 3;
            if (pred_orient2d(w->pt[t->v[NEXT(e)]], w->pt[t->v[PREV(e)]], q) < 0 &&
                t->nb[e] != NONE) {
                ti = t->nb[e];
                moved = 1;
            }
        }
        if (!moved)
            return ti;
        if (++steps > limit)
            break;
    }
    for (uint32_t s = 0; s < w->nt; s++) {
        const tri *t = &w->t[s];
        if (pred_orient2d(w->pt[t->v[0]], w->pt[t->v[1]], q) >= 0 &&
            pred_orient2d(w->pt[t->v[1]], w->pt[t->v[2]], q) >= 0 &&
            pred_orient2d(w->pt[t->v[2]], w->pt[t->v[0]], q) >= 0)
            return s;
    }
    return NONE;
}

static int insert_point(plc_cdt *w, uint32_t p, uint32_t *hint, plc_cdt_fail *fail)
{
    const double *q = w->pt[p];
    uint32_t ti = locate(w, q, *hint);
    if (ti == NONE)
        return PDR_EGEOMETRY;
    tri *t = &w->t[ti];
    int on = -1;
    for (int e = 0; e < 3; e++) {
        const double *a = w->pt[t->v[e]];
        if (a[0] == q[0] && a[1] == q[1]) {
            fail->kind = PLC_CDT_COINCIDENT;
            fail->v[0] = w->gid[t->v[e]];
            fail->v[1] = w->gid[p];
            return PDR_EGEOMETRY;
        }
        if (pred_orient2d(w->pt[t->v[NEXT(e)]], w->pt[t->v[PREV(e)]], q) == 0)
            on = e;
    }
    size_t n = 0;
    if (on < 0) {
        uint32_t a = t->v[0], b = t->v[1], c = t->v[2];
        uint32_t na = t->nb[0], nb = t->nb[1], nc = t->nb[2];
        int ca = t->con[0], cb = t->con[1], cc = t->con[2];
        uint32_t t1 = (uint32_t)w->nt++, t2 = (uint32_t)w->nt++;
        set_tri(&w->t[ti], a, b, p, t1, t2, nc, 0, 0, cc);
        set_tri(&w->t[t1], b, c, p, t2, ti, na, 0, 0, ca);
        set_tri(&w->t[t2], c, a, p, ti, t1, nb, 0, 0, cb);
        replace_nb(w, na, ti, t1);
        replace_nb(w, nb, ti, t2);
        touch(w, ti);
        touch(w, t1);
        touch(w, t2);
        if (push(w, &n, ti) || push(w, &n, t1) || push(w, &n, t2))
            return PDR_ENOMEM;
    } else {
        int i = on;
        uint32_t a = t->v[i], b = t->v[NEXT(i)], c = t->v[PREV(i)];
        uint32_t ui = t->nb[i];
        tri *u = &w->t[ui];
        int j = nb_index(u, ti);
        uint32_t d = u->v[j];
        uint32_t n_ab = t->nb[PREV(i)], n_ca = t->nb[NEXT(i)];
        int c_ab = t->con[PREV(i)], c_ca = t->con[NEXT(i)], c_bc = t->con[i];
        uint32_t n_bd = u->nb[NEXT(j)], n_dc = u->nb[PREV(j)];
        int c_bd = u->con[NEXT(j)], c_dc = u->con[PREV(j)];
        uint32_t t1 = (uint32_t)w->nt++, u1 = (uint32_t)w->nt++;
        set_tri(&w->t[ti], a, b, p, ui, t1, n_ab, c_bc, 0, c_ab);
        set_tri(&w->t[t1], a, p, c, u1, n_ca, ti, c_bc, c_ca, 0);
        set_tri(&w->t[ui], p, b, d, n_bd, u1, ti, c_bd, 0, c_bc);
        set_tri(&w->t[u1], p, d, c, n_dc, t1, ui, c_dc, c_bc, 0);
        replace_nb(w, n_ca, ti, t1);
        replace_nb(w, n_dc, ui, u1);
        touch(w, ti);
        touch(w, t1);
        touch(w, ui);
        touch(w, u1);
        if (push(w, &n, ti) || push(w, &n, t1) || push(w, &n, ui) || push(w, &n, u1))
            return PDR_ENOMEM;
    }
    *hint = ti;
    return legalize(w, p, n);
}

/* ------------------------------------------------------ segment insertion */

/* Finds the triangle and edge index of edge {a, b}; returns the triangle or
 * NONE. a must be a vertex of the triangulation. */
static uint32_t find_edge(plc_cdt *w, uint32_t a, uint32_t b, int *edge)
{
    /* Around a one way, and if that meets the outer boundary (a is a
     * corner of the enclosing triangle: its fan is open) the other way
     * from the start. */
    for (int way = 0; way < 2; way++) {
        uint32_t start = w->vtri[a], ti = start;
        do {
            const tri *t = &w->t[ti];
            int i = index_of(t, a);
            if (t->v[NEXT(i)] == b) {
                *edge = PREV(i);
                return ti;
            }
            if (t->v[PREV(i)] == b) {
                *edge = NEXT(i);
                return ti;
            }
            /* across a -> v[i+1], or across v[i-1] -> a */
            ti = way == 0 ? t->nb[PREV(i)] : t->nb[NEXT(i)];
        } while (ti != start && ti != NONE);
        if (ti == start)
            break; /* a closed fan, all seen */
    }
    return NONE;
}

static void set_constrained(plc_cdt *w, uint32_t ti, int e)
{
    w->t[ti].con[e] = 1;
    uint32_t ui = w->t[ti].nb[e];
    if (ui != NONE)
        w->t[ui].con[nb_index(&w->t[ui], ti)] = 1;
}

/* Whether collinear point x lies strictly between a and b. */
static int between(const double *a, const double *b, const double *x)
{
    int k = fabs(b[0] - a[0]) >= fabs(b[1] - a[1]) ? 0 : 1;
    if (a[k] < b[k])
        return a[k] < x[k] && x[k] < b[k];
    return b[k] < x[k] && x[k] < a[k];
}

static int on_segment(plc_cdt_fail *fail, const plc_cdt *w, uint32_t a, uint32_t b,
                      uint32_t x)
{
    fail->kind = PLC_CDT_ON_SEGMENT;
    fail->v[0] = w->gid[a];
    fail->v[1] = w->gid[b];
    fail->v[2] = w->gid[x];
    return PDR_EGEOMETRY;
}

/* Pushes on w->edges every edge crossed by segment a-b, in order. */
static int crossed_edges(plc_cdt *w, uint32_t a, uint32_t b, plc_cdt_fail *fail)
{
    const double *pa = w->pt[a], *pb = w->pt[b];
    uint32_t start = w->vtri[a], ti = start;
    int e = -1;
    do {
        const tri *t = &w->t[ti];
        int i = index_of(t, a);
        uint32_t x = t->v[NEXT(i)], y = t->v[PREV(i)];
        double ox = pred_orient2d(pa, pb, w->pt[x]);
        double oy = pred_orient2d(pa, pb, w->pt[y]);
        if (ox == 0 && between(pa, pb, w->pt[x]))
            return on_segment(fail, w, a, b, x);
        if (oy == 0 && between(pa, pb, w->pt[y]))
            return on_segment(fail, w, a, b, y);
        if (ox < 0 && oy > 0) {
            e = i;
            break;
        }
        ti = t->nb[PREV(i)];
    } while (ti != start && ti != NONE);
    if (e < 0)
        return PDR_EGEOMETRY; /* cannot happen with a valid triangulation */
    for (;;) {
        const tri *t = &w->t[ti];
        uint32_t x = t->v[NEXT(e)], y = t->v[PREV(e)];
        if (t->con[e]) {
            fail->kind = PLC_CDT_CROSSING;
            fail->v[0] = w->gid[a];
            fail->v[1] = w->gid[b];
            fail->v[2] = w->gid[x];
            fail->v[3] = w->gid[y];
            return PDR_EGEOMETRY;
        }
        if (push_edge(w, x, y))
            return PDR_ENOMEM;
        uint32_t ui = t->nb[e];
        const tri *u = &w->t[ui];
        int j = nb_index(u, ti);
        uint32_t z = u->v[j];
        if (z == b)
            return 0;
        double oz = pred_orient2d(pa, pb, w->pt[z]);
        if (oz == 0)
            return on_segment(fail, w, a, b, z);
        /* x is right of a->b and y left; the segment leaves u through the
         * edge whose endpoints are still on opposite sides. */
        e = oz < 0 ? index_of(u, x) : index_of(u, y);
        ti = ui;
    }
}

/* Lawson flips on the given edges (pairs in w->stack) until every
 * unconstrained one among them and those they touch is locally Delaunay. */
static int delaunay_flips(plc_cdt *w, size_t n)
{
    while (n >= 2) {
        uint32_t y = w->stack[--n], x = w->stack[--n];
        int e;
        uint32_t ti = find_edge(w, x, y, &e);
        if (ti == NONE || w->t[ti].con[e] || w->t[ti].nb[e] == NONE)
            continue;
        tri *t = &w->t[ti];
        uint32_t ui = t->nb[e];
        uint32_t d = w->t[ui].v[nb_index(&w->t[ui], ti)];
        if (pred_incircle(w->pt[t->v[0]], w->pt[t->v[1]], w->pt[t->v[2]], w->pt[d]) <= 0)
            continue;
        flip(w, ti, e); /* ti = (c, x, d), ui = (c, d, y) */
        const tri *t2 = &w->t[ti], *u2 = &w->t[ui];
        uint32_t q[8] = {t2->v[1], t2->v[2], t2->v[0], t2->v[1],
                         u2->v[1], u2->v[2], u2->v[2], u2->v[0]};
        for (int k = 0; k < 8; k++)
            if (push(w, &n, q[k]))
                return PDR_ENOMEM;
    }
    return 0;
}

static int insert_segment(plc_cdt *w, uint32_t a, uint32_t b, plc_cdt_fail *fail)
{
    int e;
    uint32_t ti = find_edge(w, a, b, &e);
    if (ti != NONE) {
        set_constrained(w, ti, e);
        return 0;
    }
    w->nedges = 0;
    int rc = crossed_edges(w, a, b, fail);
    if (rc)
        return rc;
    const double *pa = w->pt[a], *pb = w->pt[b];
    /* Sloan's method: flip crossing edges whose quadrilateral is convex;
     * an edge that still crosses goes back in the queue. The queue is a
     * ring over w->edges (its length never grows). New edges that no
     * longer cross are collected on the stack for the Delaunay pass. */
    size_t qn = w->nedges, head = 0, len = qn, ns = 0;
    size_t guard = 0, limit = 64 * qn * qn + 1024;
    while (len > 0) {
        if (++guard > limit)
            return PDR_ELIMIT;
        uint64_t ed = w->edges[head];
        head = (head + 1) % qn;
        len--;
        uint32_t x = (uint32_t)(ed >> 32), y = (uint32_t)ed;
        ti = find_edge(w, x, y, &e);
        if (ti == NONE)
            return PDR_EGEOMETRY;
        const tri *t = &w->t[ti];
        uint32_t c = t->v[e];
        uint32_t ui = t->nb[e];
        uint32_t d = w->t[ui].v[nb_index(&w->t[ui], ti)];
        double o1 = pred_orient2d(w->pt[c], w->pt[d], w->pt[x]);
        double o2 = pred_orient2d(w->pt[c], w->pt[d], w->pt[y]);
        int convex = (o1 > 0 && o2 < 0) || (o1 < 0 && o2 > 0);
        uint64_t back = ed;
        if (convex) {
            flip(w, ti, e);
            double oc = pred_orient2d(pa, pb, w->pt[c]);
            double od = pred_orient2d(pa, pb, w->pt[d]);
            if ((oc > 0 && od < 0) || (oc < 0 && od > 0)) {
                back = (uint64_t)c << 32 | d;
            } else {
                if (push(w, &ns, c) || push(w, &ns, d))
                    return PDR_ENOMEM;
                continue;
            }
        }
        w->edges[(head + len) % qn] = back;
        len++;
    }
    ti = find_edge(w, a, b, &e);
    if (ti == NONE)
        return PDR_EGEOMETRY;
    set_constrained(w, ti, e);
    return delaunay_flips(w, ns);
}

/* ------------------------------------------------------------ the facet */

static uint32_t local_id(const plc_cdt *w, size_t m, uint32_t g)
{
    const uint32_t *hit = bsearch(&g, w->gid, m, sizeof *w->gid, pdr_cmp_u32);
    return (uint32_t)(hit - w->gid);
}

/* Marks as outside every triangle reachable from 'seed' without crossing a
 * constraint. */
static int flood_out(plc_cdt *w, uint32_t seed)
{
    size_t n = 0;
    if (w->t[seed].out)
        return 0;
    w->t[seed].out = 1;
    if (push(w, &n, seed))
        return PDR_ENOMEM;
    while (n > 0) {
        const tri *t = &w->t[w->stack[--n]];
        for (int e = 0; e < 3; e++) {
            uint32_t u = t->nb[e];
            if (u == NONE || t->con[e] || w->t[u].out)
                continue;
            w->t[u].out = 1;
            if (push(w, &n, u))
                return PDR_ENOMEM;
        }
    }
    return 0;
}

int plc_cdt_facet(plc_cdt *w, const plc *p, size_t f, plc_cdt_fail *fail)
{
    const plc_facet *fa = &p->facets[f];
    memset(fail, 0, sizeof *fail);
    w->nout = 0;
    w->nt = 0;

    /* The facet's distinct corners, sorted: local id = rank. */
    size_t ncorner = 0;
    for (size_t k = 0; k < fa->npoly; k++)
        ncorner += p->polys[fa->poly_first + k].n;
    if (reserve(w, ncorner))
        return PDR_ENOMEM;
    size_t m = 0;
    for (size_t k = 0; k < fa->npoly; k++) {
        const plc_polygon *q = &p->polys[fa->poly_first + k];
        for (uint32_t i = 0; i < q->n; i++)
            w->gid[m++] = p->corners[q->first + i];
    }
    qsort(w->gid, m, sizeof *w->gid, pdr_cmp_u32);
    size_t u = 0;
    for (size_t i = 0; i < m; i++)
        if (i == 0 || w->gid[i] != w->gid[i - 1])
            w->gid[u++] = w->gid[i];
    m = u;
    if (reserve(w, m))
        return PDR_ENOMEM;

    int ax = fa->axis, c0 = (ax + 1) % 3, c1 = (ax + 2) % 3;
    double lo[2] = {0, 0}, hi[2] = {0, 0};
    for (size_t i = 0; i < m; i++) {
        const double *x = p->xyz[w->gid[i]];
        w->pt[i][0] = x[c0];
        w->pt[i][1] = x[c1];
        for (int k = 0; k < 2; k++) {
            if (i == 0 || w->pt[i][k] < lo[k])
                lo[k] = w->pt[i][k];
            if (i == 0 || w->pt[i][k] > hi[k])
                hi[k] = w->pt[i][k];
        }
    }
    double cx = 0.5 * (lo[0] + hi[0]), cy = 0.5 * (lo[1] + hi[1]);
    double s = fmax(hi[0] - lo[0], hi[1] - lo[1]);
    if (!(s > 0))
        s = 1.0;
    s *= 64.0;
    uint32_t A = (uint32_t)m, B = A + 1, C = A + 2;
    w->pt[A][0] = cx - 3 * s;
    w->pt[A][1] = cy - 2 * s;
    w->pt[B][0] = cx + 3 * s;
    w->pt[B][1] = cy - 2 * s;
    w->pt[C][0] = cx;
    w->pt[C][1] = cy + 3 * s;
    w->gid[A] = w->gid[B] = w->gid[C] = NONE;
    set_tri(&w->t[0], A, B, C, NONE, NONE, NONE, 0, 0, 0);
    w->nt = 1;
    touch(w, 0);

    /* Insert the corners in a random order (expected linear walks). */
    uint32_t *order = pr_malloc((m ? m : 1) * sizeof *order);
    if (!order)
        return PDR_ENOMEM;
    for (size_t i = 0; i < m; i++)
        order[i] = (uint32_t)i;
    for (size_t i = m; i > 1; i--) {
        size_t j = rng_next(w) % i;
        uint32_t tmp = order[i - 1];
        order[i - 1] = order[j];
        order[j] = tmp;
    }
    uint32_t hint = 0;
    int rc = 0;
    for (size_t i = 0; i < m && !rc; i++)
        rc = insert_point(w, order[i], &hint, fail);
    pr_free(order);
    if (rc)
        return rc;

    for (size_t k = 0; k < fa->npoly && !rc; k++) {
        const plc_polygon *q = &p->polys[fa->poly_first + k];
        if (q->n < 2)
            continue;
        uint32_t ne = q->n == 2 ? 1 : q->n;
        for (uint32_t i = 0; i < ne && !rc; i++) {
            uint32_t a = p->corners[q->first + i];
            uint32_t b = p->corners[q->first + (i + 1) % q->n];
            if (a != b)
                rc = insert_segment(w, local_id(w, m, a), local_id(w, m, b), fail);
        }
    }
    if (rc)
        return rc;

    /* Remove the outside (reachable from the enclosing triangle) and the
     * holes (reachable from a hole point's projection). */
    for (uint32_t t = 0; t < w->nt && !rc; t++)
        if (w->t[t].v[0] >= A || w->t[t].v[1] >= A || w->t[t].v[2] >= A)
            rc = flood_out(w, t);
    for (size_t h = 0; h < fa->nhole && !rc; h++) {
        const double *x = p->fholes[fa->hole_first + h].xyz;
        double q[2] = {x[c0], x[c1]};
        for (uint32_t t = 0; t < w->nt; t++) {
            const tri *tt = &w->t[t];
            if (!tt->out && pred_orient2d(w->pt[tt->v[0]], w->pt[tt->v[1]], q) >= 0 &&
                pred_orient2d(w->pt[tt->v[1]], w->pt[tt->v[2]], q) >= 0 &&
                pred_orient2d(w->pt[tt->v[2]], w->pt[tt->v[0]], q) >= 0) {
                rc = flood_out(w, t);
                break;
            }
        }
    }
    if (rc)
        return rc;

    int flipped = fa->normal[ax] < 0;
    for (uint32_t t = 0; t < w->nt; t++) {
        const tri *tt = &w->t[t];
        if (tt->out)
            continue;
        if (plc__grow((void **)&w->out, &w->cap_out, w->nout + 1, sizeof *w->out))
            return PDR_ENOMEM;
        uint32_t *o = w->out[w->nout++];
        o[0] = w->gid[tt->v[0]];
        o[1] = w->gid[tt->v[flipped ? 2 : 1]];
        o[2] = w->gid[tt->v[flipped ? 1 : 2]];
    }
    return 0;
}

void plc_cdt_free(plc_cdt *w)
{
    pr_free(w->out);
    pr_free(w->t);
    pr_free(w->pt);
    pr_free(w->gid);
    pr_free(w->vtri);
    pr_free(w->stack);
    pr_free(w->edges);
    memset(w, 0, sizeof *w);
}
