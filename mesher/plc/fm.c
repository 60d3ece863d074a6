/* plc/fm.c -- merging coplanar triangles into facets, and the sharp
 * segments and acute vertices of a PLC (see plc/fm.h). */
#include "config.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "base/hmap.h"
#include "base/pdr_util.h"
#include "base/v3.h"
#include "geom/pred.h"
#include "plc/fm.h"
#include "plc/plc_int.h"

#define NONE UINT32_MAX

static uint64_t dkey(uint32_t a, uint32_t b)
{
    return ((uint64_t)a << 32) | b;
}

static uint64_t ukey(uint32_t a, uint32_t b)
{
    return a < b ? dkey(a, b) : dkey(b, a);
}

/* The corners of facet f when it is a single triangle without holes:
 * returns 1 and c[], else 0. */
static int facet_tri(const plc *p, size_t f, uint32_t c[3])
{
    const plc_facet *F = &p->facets[f];
    if (F->npoly != 1 || F->nhole)
        return 0;
    const plc_polygon *q = &p->polys[F->poly_first];
    if (q->n != 3)
        return 0;
    memcpy(c, p->corners + q->first, 3 * sizeof *c);
    return 1;
}

/* The cosine of the angle between the half-planes bounded by line ab that
 * hold c and d (the dihedral angle at ab of triangles abc and abd); 1 when
 * one of them is degenerate. */
static double halfplane_cos(const double *a, const double *b, const double *c, const double *d)
{
    double e[3], u[3], w[3];
    v3_sub(b, a, e);
    v3_sub(c, a, u);
    v3_sub(d, a, w);
    double ee = v3_dot(e, e);
    if (!(ee > 0))
        return 1.0;
    double su = v3_dot(u, e) / ee, sw = v3_dot(w, e) / ee;
    for (int k = 0; k < 3; k++) {
        u[k] -= su * e[k];
        w[k] -= sw * e[k];
    }
    double nu = v3_dot(u, u), nw = v3_dot(w, w);
    if (!(nu > 0 && nw > 0))
        return 1.0;
    return v3_dot(u, w) / sqrt(nu * nw);
}

static void cross(const double *u, const double *w, double *n)
{
    n[0] = u[1] * w[2] - u[2] * w[1];
    n[1] = u[2] * w[0] - u[0] * w[2];
    n[2] = u[0] * w[1] - u[1] * w[0];
}

/* ------------------------------------------------------------- merging */

/* A PLC's facet arrays (plc.h) and its planar tolerance: those a merge
 * builds (fm_work.made), and those it replaced, kept so that fm_prepare
 * can undo a bent merge. */
typedef struct fm_saved {
    plc_facet *facets;
    size_t nfacet, cap_facet;
    plc_polygon *polys;
    size_t npoly, cap_poly;
    uint32_t *corners;
    size_t ncorner, cap_corner;
    plc_point *fholes;
    size_t nfhole, cap_fhole;
    double planar_tol;
} fm_saved;

static void saved_free(fm_saved *sv)
{
    pr_free(sv->facets);
    pr_free(sv->polys);
    pr_free(sv->corners);
    pr_free(sv->fholes);
    memset(sv, 0, sizeof *sv);
}

/* The merge's working state. */
typedef struct fm_work {
    plc *p;
    double cos_min;     /* merge when the dihedral cosine is at most this */
    double exact_tol;   /* absolute distance to the seed plane that counts
                           as coplanar (the PLC's planar tolerance) */
    double bend_tol;    /* ... that a bent facet allows (> exact_tol: the
                           exact groups are then joined into bent ones) */
    double seed_n[3], seed_x[3]; /* the bent group's plane: normal, point */
    uint32_t *group;    /* per facet: first facet of its group, or NONE */
    uint32_t (*ot)[3];  /* per triangle facet: corners, oriented in group */
    uint32_t *next;     /* per facet: next member of its group, or NONE */
    uint32_t *size;     /* per facet (group leader): members */
    uint8_t *merged;    /* per facet (group leader): group becomes a facet */
    uint8_t *bent;      /* per facet (group leader): a bent group, made of
                           more than one exact group */
    /* the exact groups, kept while bent groups are made of them */
    uint32_t *egroup, *enext, *esize;
    uint32_t (*eot)[3];
    uint32_t *queue;
    hmap explicit_segs; /* undirected keys of the input's own segments */
    /* one group at a time */
    hmap edges;         /* directed edge -> member facet */
    hmap out;           /* vertex + 1 -> the boundary edge leaving it */
    uint32_t (*bnd)[2]; /* boundary edges */
    size_t nbnd, cap_bnd;
    uint8_t *used;      /* per boundary edge: chained */
    size_t cap_used;
    uint32_t *vstamp;   /* per vertex: group leader + 1 that listed it */
    fm_saved made;      /* the new facet arrays (planar_tol set when they
                           are handed over) */
} fm_work;

/* The segment joining a and b, or NONE. */
static uint32_t seg_between(const plc *p, uint32_t a, uint32_t b)
{
    for (size_t i = p->v_sstart[a]; i < p->v_sstart[a + 1]; i++) {
        const uint32_t *v = p->segs[p->v_segs[i]].v;
        if ((v[0] == a && v[1] == b) || (v[0] == b && v[1] == a))
            return p->v_segs[i];
    }
    return NONE;
}

/* The triangle facet across edge a->b of oriented triangle (a, b, c) of
 * group lead that may join it as far as the edge tells (not in a group
 * yet, same marker, an edge of no other facet and no explicit segment,
 * a dihedral angle within the tolerance), with its far corner in *d; or
 * NONE. */
static uint32_t neighbour(const fm_work *w, uint32_t lead, uint32_t a, uint32_t b, uint32_t c,
                          uint32_t *d)
{
    const plc *p = w->p;
    uint32_t s = seg_between(p, a, b);
    if (s == NONE || p->seg_fstart[s + 1] - p->seg_fstart[s] != 2 ||
        hmap_get(&w->explicit_segs, ukey(a, b)) != HMAP_NONE)
        return NONE;
    uint32_t f0 = p->seg_facets[p->seg_fstart[s]], f1 = p->seg_facets[p->seg_fstart[s] + 1];
    uint32_t u = w->group[f0] == lead && w->group[f1] != lead ? f1 : f0;
    uint32_t uc[3];
    if (w->group[u] != NONE || !facet_tri(p, u, uc) ||
        p->facets[u].marker != p->facets[lead].marker)
        return NONE;
    *d = uc[0] != a && uc[0] != b ? uc[0] : uc[1] != a && uc[1] != b ? uc[1] : uc[2];
    const double *pa = p->xyz[a], *pb = p->xyz[b], *pc = p->xyz[c], *pd = p->xyz[*d];
    double cs = halfplane_cos(pa, pb, pc, pd);
    int flat = pred_orient3d(pa, pb, pc, pd) == 0 && cs < 0;
    if (!flat && !(cs <= w->cos_min))
        return NONE;
    return u;
}

/* Whether the triangle facet across edge a->b of oriented triangle (a, b,
 * c) of group lead joins it with the exact criterion; if so returns it
 * with its far corner in *d. */
static uint32_t joins(fm_work *w, uint32_t lead, uint32_t a, uint32_t b, uint32_t c, uint32_t *d)
{
    const plc *p = w->p;
    uint32_t u = neighbour(w, lead, a, b, c, d);
    if (u == NONE)
        return NONE;
    /* Against the plane of the group's first triangle. */
    const uint32_t *s0 = w->ot[lead];
    const double *q0 = p->xyz[s0[0]], *q1 = p->xyz[s0[1]], *q2 = p->xyz[s0[2]], *pd = p->xyz[*d];
    if (pred_orient3d(q0, q1, q2, pd) != 0) {
        double u1[3], u2[3], n[3], x[3];
        v3_sub(q1, q0, u1);
        v3_sub(q2, q0, u2);
        cross(u1, u2, n);
        v3_sub(pd, q0, x);
        double nn = sqrt(v3_dot(n, n));
        if (!(nn > 0) || fabs(v3_dot(x, n)) / nn > w->exact_tol)
            return NONE;
    }
    return u;
}

/* Grows the group of triangle facet lead breadth first. */
static void grow_group(fm_work *w, uint32_t lead)
{
    size_t head = 0, n = 0;
    w->queue[n++] = lead;
    w->group[lead] = lead;
    w->size[lead] = 1;
    uint32_t last = lead;
    while (head < n) {
        uint32_t t = w->queue[head++];
        for (int k = 0; k < 3; k++) {
            uint32_t a = w->ot[t][k], b = w->ot[t][(k + 1) % 3], c = w->ot[t][(k + 2) % 3], d;
            uint32_t u = joins(w, lead, a, b, c, &d);
            if (u == NONE)
                continue;
            w->group[u] = lead;
            w->ot[u][0] = b;
            w->ot[u][1] = a;
            w->ot[u][2] = d;
            w->next[last] = u;
            last = u;
            w->size[lead]++;
            w->queue[n++] = u;
        }
    }
}

/* The distance of point x from the bent group's plane. */
static double seed_distance(const fm_work *w, const double *x)
{
    double v[3];
    v3_sub(x, w->seed_x, v);
    return fabs(v3_dot(v, w->seed_n));
}

/* Sets the bent group's plane to that of the largest triangle of exact
 * group e (a thin triangle's plane is tilted most by rounding). */
static void seed_plane(fm_work *w, uint32_t e)
{
    const plc *p = w->p;
    double best = -1;
    for (uint32_t t = e; t != NONE; t = w->enext[t]) {
        const double *a = p->xyz[w->eot[t][0]], *b = p->xyz[w->eot[t][1]],
                     *c = p->xyz[w->eot[t][2]];
        double u1[3], u2[3], n[3];
        v3_sub(b, a, u1);
        v3_sub(c, a, u2);
        cross(u1, u2, n);
        double nn = v3_dot(n, n);
        if (nn > best) {
            best = nn;
            for (int k = 0; k < 3; k++) {
                w->seed_n[k] = n[k] / sqrt(nn);
                w->seed_x[k] = a[k];
            }
        }
    }
}

/* Whether every corner of exact group e lies within bend_tol of the bent
 * group's plane. */
static int exact_group_fits(const fm_work *w, uint32_t e)
{
    for (uint32_t t = e; t != NONE; t = w->enext[t])
        for (int k = 0; k < 3; k++)
            if (!(seed_distance(w, w->p->xyz[w->eot[t][k]]) <= w->bend_tol))
                return 0;
    return 1;
}

/* Adds exact group e to bent group lead (flip: its triangles turn the
 * other way in lead), queueing its triangles at queue[*n]. A group made of
 * more than one exact group is bent, even where its corners happen to lie
 * within exact_tol of one plane: it is then validated as one (bent_group_ok,
 * the PLC's tolerance, the intersection tests). */
static void absorb(fm_work *w, uint32_t lead, uint32_t e, int flip, size_t *n, uint32_t *last)
{
    if (e != lead)
        w->bent[lead] = 1;
    for (uint32_t t = e; t != NONE; t = w->enext[t]) {
        w->group[t] = lead;
        w->ot[t][0] = w->eot[t][0];
        w->ot[t][1] = w->eot[t][flip ? 2 : 1];
        w->ot[t][2] = w->eot[t][flip ? 1 : 2];
        if (*last != NONE)
            w->next[*last] = t;
        w->next[t] = NONE;
        *last = t;
        w->size[lead]++;
        w->queue[(*n)++] = t;
    }
}

/* Grows bent group lead, the leader of an exact group, breadth first over
 * whole exact groups: a neighbouring exact group joins when the edge
 * allows it (neighbour) and all its corners lie within bend_tol of the
 * plane of lead's largest triangle. */
static void grow_bent(fm_work *w, uint32_t lead)
{
    size_t head = 0, n = 0;
    uint32_t last = NONE;
    seed_plane(w, lead);
    w->size[lead] = 0;
    absorb(w, lead, lead, 0, &n, &last);
    while (head < n) {
        uint32_t t = w->queue[head++];
        for (int k = 0; k < 3; k++) {
            uint32_t a = w->ot[t][k], b = w->ot[t][(k + 1) % 3], c = w->ot[t][(k + 2) % 3], d;
            uint32_t u = neighbour(w, lead, a, b, c, &d);
            if (u == NONE)
                continue;
            uint32_t e = w->egroup[u];
            if (!exact_group_fits(w, e))
                continue;
            /* u must run along b->a in lead: flip its exact group if it
             * runs along a->b there */
            const uint32_t *o = w->eot[u];
            int flip = (o[0] == a && o[1] == b) || (o[1] == a && o[2] == b) ||
                       (o[2] == a && o[0] == b);
            absorb(w, lead, e, flip, &n, &last);
        }
    }
}

/* Appends a polygon of the given corners to the new arrays. */
static int put_polygon(fm_work *w, const uint32_t *c, uint32_t n, long line)
{
    if (pdr_grow((void **)&w->made.polys, &w->made.cap_poly, w->made.npoly + 1, sizeof *w->made.polys) ||
        pdr_grow((void **)&w->made.corners, &w->made.cap_corner, w->made.ncorner + n, sizeof *w->made.corners))
        return PDR_ENOMEM;
    plc_polygon *q = &w->made.polys[w->made.npoly++];
    q->first = w->made.ncorner;
    q->n = n;
    q->line = line;
    memcpy(w->made.corners + w->made.ncorner, c, n * sizeof *c);
    w->made.ncorner += n;
    w->made.facets[w->made.nfacet - 1].npoly++;
    return 0;
}

static int put_hole(fm_work *w, const double x[3], long line)
{
    if (pdr_grow((void **)&w->made.fholes, &w->made.cap_fhole, w->made.nfhole + 1, sizeof *w->made.fholes))
        return PDR_ENOMEM;
    memcpy(w->made.fholes[w->made.nfhole].xyz, x, sizeof w->made.fholes[0].xyz);
    w->made.fholes[w->made.nfhole++].line = line;
    w->made.facets[w->made.nfacet - 1].nhole++;
    return 0;
}

/* Starts a new facet like facet f of the input (marker, line). */
static int begin_facet(fm_work *w, size_t f)
{
    if (pdr_grow((void **)&w->made.facets, &w->made.cap_facet, w->made.nfacet + 1, sizeof *w->made.facets))
        return PDR_ENOMEM;
    plc_facet *F = &w->made.facets[w->made.nfacet++];
    memset(F, 0, sizeof *F);
    F->poly_first = w->made.npoly;
    F->hole_first = w->made.nfhole;
    F->marker = w->p->facets[f].marker;
    F->line = w->p->facets[f].line;
    return 0;
}

/* Copies facet f of the input as it is. */
static int copy_facet(fm_work *w, size_t f)
{
    const plc *p = w->p;
    const plc_facet *F = &p->facets[f];
    int rc = begin_facet(w, f);
    for (size_t k = 0; k < F->npoly && !rc; k++) {
        const plc_polygon *q = &p->polys[F->poly_first + k];
        rc = put_polygon(w, p->corners + q->first, q->n, q->line);
    }
    for (size_t k = 0; k < F->nhole && !rc; k++)
        rc = put_hole(w, p->fholes[F->hole_first + k].xyz, p->fholes[F->hole_first + k].line);
    return rc;
}

/* The boundary of group lead: its directed edges whose reverse is not in
 * the group, into w->bnd, and w->out from each one's first vertex.
 * Returns 0, 1 when a vertex has two boundary edges leaving it (the
 * boundary touches itself there), or PDR_ENOMEM. */
static int group_boundary(fm_work *w, uint32_t lead)
{
    hmap_free(&w->edges);
    hmap_free(&w->out);
    w->nbnd = 0;
    for (uint32_t t = lead; t != NONE; t = w->next[t])
        for (int k = 0; k < 3; k++)
            if (hmap_put(&w->edges, dkey(w->ot[t][k], w->ot[t][(k + 1) % 3]), t))
                return PDR_ENOMEM;
    for (uint32_t t = lead; t != NONE; t = w->next[t])
        for (int k = 0; k < 3; k++) {
            uint32_t a = w->ot[t][k], b = w->ot[t][(k + 1) % 3];
            if (hmap_get(&w->edges, dkey(b, a)) != HMAP_NONE)
                continue;
            if (hmap_get(&w->out, (uint64_t)a + 1) != HMAP_NONE)
                return 1;
            if (pdr_grow((void **)&w->bnd, &w->cap_bnd, w->nbnd + 1, sizeof *w->bnd) ||
                hmap_put(&w->out, (uint64_t)a + 1, (uint32_t)w->nbnd))
                return PDR_ENOMEM;
            w->bnd[w->nbnd][0] = a;
            w->bnd[w->nbnd][1] = b;
            w->nbnd++;
        }
    return 0;
}

/* A point just inside the hole bounded by the loop whose longest edge is
 * a->b (the group lies on its left, seen along normal n): a thousandth of
 * that edge's length to its right, from its midpoint. */
static void hole_point(const plc *p, uint32_t a, uint32_t b, const double n[3], double x[3])
{
    double e[3], left[3];
    v3_sub(p->xyz[b], p->xyz[a], e);
    cross(n, e, left);
    for (int k = 0; k < 3; k++)
        x[k] = 0.5 * (p->xyz[a][k] + p->xyz[b][k]) - 1e-3 * left[k];
}

/* Whether bent group lead, emitted as the last facet of w with its outer
 * loop first, may stay one facet: every corner of the group within
 * bend_tol of the plane plc_derive will give the facet (Newell's, of the
 * outer loop), and every triangle of the group turning the same way about
 * that plane's normal in the projection that drops its dominant axis
 * (exact), so that the facet is a graph over its projection. */
static int bent_group_ok(const fm_work *w, uint32_t lead)
{
    const plc *p = w->p;
    const plc_polygon *q = &w->made.polys[w->made.facets[w->made.nfacet - 1].poly_first];
    double n[3], c[3];
    plc__newell_ring((const double(*)[3])p->xyz, w->made.corners + q->first, q->n, n, c);
    double len = sqrt(v3_dot(n, n));
    if (!(len > 0))
        return 0;
    int axis = 0;
    for (int k = 0; k < 3; k++) {
        n[k] /= len;
        if (fabs(n[k]) > fabs(n[axis]))
            axis = k;
    }
    double off = v3_dot(n, c);
    int i = (axis + 1) % 3, j = (axis + 2) % 3, turn = n[axis] > 0 ? 1 : -1;
    for (uint32_t t = lead; t != NONE; t = w->next[t]) {
        double x[3][2];
        for (int k = 0; k < 3; k++) {
            const double *v = p->xyz[w->ot[t][k]];
            if (!(fabs(v3_dot(n, v) - off) <= w->bend_tol))
                return 0;
            x[k][0] = v[i];
            x[k][1] = v[j];
        }
        if (pred_orient2d(x[0], x[1], x[2]) != turn)
            return 0;
    }
    return 1;
}

/* Emits group lead as one facet: loops (outer first), hole points,
 * isolated vertices. Returns 0, 1 when the group cannot be one facet
 * (nothing emitted), or PDR_ENOMEM. */
static int emit_group(fm_work *w, uint32_t lead)
{
    const plc *p = w->p;
    int rc = group_boundary(w, lead);
    if (rc)
        return rc;
    if (pdr_grow((void **)&w->used, &w->cap_used, w->nbnd, 1))
        return PDR_ENOMEM;
    memset(w->used, 0, w->nbnd);
    /* The group's normal, from its first triangle. */
    double n[3], u1[3], u2[3];
    const uint32_t *s0 = w->ot[lead];
    v3_sub(p->xyz[s0[1]], p->xyz[s0[0]], u1);
    v3_sub(p->xyz[s0[2]], p->xyz[s0[0]], u2);
    cross(u1, u2, n);
    double nl = sqrt(v3_dot(n, n));
    for (int k = 0; k < 3; k++)
        n[k] /= nl;
    /* Chain the loops into queue (reused: corners of loop after loop),
     * with loop starts, areas and longest edges kept aside. */
    size_t nloop = 0, ncorner = 0, outer = SIZE_MAX;
    size_t *start = pr_malloc((w->nbnd + 1) * sizeof *start);
    uint32_t (*longest)[2] = pr_malloc((w->nbnd + 1) * sizeof *longest);
    if (!start || !longest) {
        pr_free(start);
        pr_free(longest);
        return PDR_ENOMEM;
    }
    for (size_t e0 = 0; e0 < w->nbnd && !rc; e0++) {
        if (w->used[e0])
            continue;
        start[nloop] = ncorner;
        double area[3] = {0, 0, 0}, lmax = -1;
        size_t e = e0;
        while (!w->used[e]) {
            w->used[e] = 1;
            uint32_t a = w->bnd[e][0], b = w->bnd[e][1];
            w->queue[ncorner++] = a;
            const double *pa = p->xyz[a], *pb = p->xyz[b];
            area[0] += (pa[1] - pb[1]) * (pa[2] + pb[2]);
            area[1] += (pa[2] - pb[2]) * (pa[0] + pb[0]);
            area[2] += (pa[0] - pb[0]) * (pa[1] + pb[1]);
            double l = v3_dist2(pa, pb);
            if (l > lmax) {
                lmax = l;
                longest[nloop][0] = a;
                longest[nloop][1] = b;
            }
            uint32_t ne = hmap_get(&w->out, (uint64_t)b + 1);
            if (ne == HMAP_NONE) {
                rc = 1; /* cannot happen on a closed chain */
                break;
            }
            e = ne;
        }
        if (!rc && v3_dot(area, n) > 0) {
            if (outer != SIZE_MAX)
                rc = 1; /* two outer loops */
            outer = nloop;
        }
        nloop++;
    }
    start[nloop] = ncorner;
    if (!rc && outer == SIZE_MAX)
        rc = 1;
    if (!rc)
        rc = begin_facet(w, lead);
    if (!rc)
        rc = put_polygon(w, w->queue + start[outer], (uint32_t)(start[outer + 1] - start[outer]),
                         p->polys[p->facets[lead].poly_first].line);
    if (!rc && w->bent[lead] && !bent_group_ok(w, lead))
        rc = 1;
    for (size_t l = 0; l < nloop && !rc; l++) {
        if (l == outer)
            continue;
        rc = put_polygon(w, w->queue + start[l], (uint32_t)(start[l + 1] - start[l]), 0);
        double x[3];
        hole_point(p, longest[l][0], longest[l][1], n, x);
        if (!rc)
            rc = put_hole(w, x, 0);
    }
    /* Vertices of the group on no loop: isolated vertices of the facet. */
    for (size_t i = 0; i < ncorner; i++)
        w->vstamp[w->queue[i]] = lead + 1;
    for (uint32_t t = lead; t != NONE && !rc; t = w->next[t])
        for (int k = 0; k < 3 && !rc; k++) {
            uint32_t v = w->ot[t][k];
            if (w->vstamp[v] == lead + 1)
                continue;
            w->vstamp[v] = lead + 1;
            rc = put_polygon(w, &v, 1, 0);
        }
    pr_free(start);
    pr_free(longest);
    return rc;
}

static void work_free(fm_work *w)
{
    pr_free(w->group);
    pr_free(w->ot);
    pr_free(w->next);
    pr_free(w->size);
    pr_free(w->merged);
    pr_free(w->bent);
    pr_free(w->egroup);
    pr_free(w->enext);
    pr_free(w->esize);
    pr_free(w->eot);
    pr_free(w->queue);
    hmap_free(&w->explicit_segs);
    hmap_free(&w->edges);
    hmap_free(&w->out);
    pr_free(w->bnd);
    pr_free(w->used);
    pr_free(w->vstamp);
    saved_free(&w->made);
}

/* Groups every triangle facet; returns 0 or PDR_ENOMEM. */
static int make_groups(fm_work *w)
{
    const plc *p = w->p;
    for (size_t i = 0; i < p->nsegin; i++)
        if (hmap_put(&w->explicit_segs, ukey(p->segin[i].v[0], p->segin[i].v[1]), 1))
            return PDR_ENOMEM;
    for (size_t f = 0; f < p->nfacet; f++) {
        w->group[f] = NONE;
        w->next[f] = NONE;
        w->size[f] = 0;
    }
    for (size_t f = 0; f < p->nfacet; f++)
        if (w->group[f] == NONE && facet_tri(p, f, w->ot[f]))
            grow_group(w, (uint32_t)f);
    if (!(w->bend_tol > w->exact_tol))
        return 0;
    /* Bent groups, made of whole exact groups. */
    size_t nf = p->nfacet;
    w->egroup = pr_malloc(nf * sizeof *w->egroup);
    w->enext = pr_malloc(nf * sizeof *w->enext);
    w->esize = pr_malloc(nf * sizeof *w->esize);
    w->eot = pr_malloc(nf * sizeof *w->eot);
    if (!w->egroup || !w->enext || !w->esize || !w->eot)
        return PDR_ENOMEM;
    memcpy(w->egroup, w->group, nf * sizeof *w->egroup);
    memcpy(w->enext, w->next, nf * sizeof *w->enext);
    memcpy(w->esize, w->size, nf * sizeof *w->esize);
    memcpy(w->eot, w->ot, nf * sizeof *w->eot);
    for (size_t f = 0; f < nf; f++)
        if (w->egroup[f] != NONE)
            w->group[f] = NONE;
    for (size_t f = 0; f < nf; f++)
        if (w->egroup[f] == f && w->group[f] == NONE)
            grow_bent(w, (uint32_t)f);
    return 0;
}

/* Puts the members of refused bent group lead back into their exact
 * groups (lead is the lowest-numbered of them all, so each exact group's
 * leader comes at or after it). */
static void regroup_exact(fm_work *w, uint32_t lead)
{
    uint32_t t = lead;
    while (t != NONE) {
        uint32_t nx = w->next[t];
        w->group[t] = w->egroup[t];
        w->next[t] = w->enext[t];
        w->size[t] = w->esize[t];
        w->bent[t] = 0;
        memcpy(w->ot[t], w->eot[t], sizeof w->ot[t]);
        t = nx;
    }
}

/* Emits group f (its leader) as one facet; returns 0, 1 when it stays
 * triangles (nothing emitted), or PDR_ENOMEM. */
static int try_group(fm_work *w, uint32_t f, fm_stats *s)
{
    size_t nf = w->made.nfacet, np = w->made.npoly, nc = w->made.ncorner, nh = w->made.nfhole;
    int rc = emit_group(w, f);
    if (rc == 0) {
        w->merged[f] = 1;
        s->triangles_merged += w->size[f];
        s->bent_facets += w->bent[f];
        return 0;
    }
    /* Keep the group's triangles: undo what was emitted. */
    w->made.nfacet = nf;
    w->made.npoly = np;
    w->made.ncorner = nc;
    w->made.nfhole = nh;
    return rc;
}

/* Writes the new facets into w: merged groups in place of their first
 * triangle, the rest copied. */
static int rebuild(fm_work *w, fm_stats *s)
{
    const plc *p = w->p;
    int rc = 0;
    for (size_t f = 0; f < p->nfacet && !rc; f++) {
        uint32_t g = w->group[f];
        if (g != NONE && g != f && w->merged[g])
            continue;
        if (g == f && w->size[f] > 1) {
            rc = try_group(w, (uint32_t)f, s);
            if (rc == 1 && w->bent[f]) {
                s->bent_regrouped++;
                regroup_exact(w, (uint32_t)f);
                rc = w->size[f] > 1 ? try_group(w, (uint32_t)f, s) : 2;
            }
            if (rc == 0)
                continue;
            if (rc < 0)
                return rc;
            s->groups_kept += rc == 1;
            rc = 0;
        }
        rc = copy_facet(w, f);
    }
    return rc;
}

/* Exchanges the facet arrays of p and sv. */
static void swap_facets(plc *p, fm_saved *sv)
{
    fm_saved t = {p->facets, p->nfacet, p->cap_facet, p->polys, p->npoly, p->cap_poly,
                  p->corners, p->ncorner, p->cap_corner, p->fholes, p->nfhole, p->cap_fhole,
                  p->planar_tol};
    p->facets = sv->facets;
    p->nfacet = sv->nfacet;
    p->cap_facet = sv->cap_facet;
    p->polys = sv->polys;
    p->npoly = sv->npoly;
    p->cap_poly = sv->cap_poly;
    p->corners = sv->corners;
    p->ncorner = sv->ncorner;
    p->cap_corner = sv->cap_corner;
    p->fholes = sv->fholes;
    p->nfhole = sv->nfhole;
    p->cap_fhole = sv->cap_fhole;
    p->planar_tol = sv->planar_tol;
    *sv = t;
}

/* fm_merge, handing the replaced facet arrays to old (emptied first;
 * still empty when nothing was merged). */
static int merge_keep(plc *p, double angle_tol, double facet_tol, fm_stats *st, fm_saved *old)
{
    fm_stats s;
    memset(&s, 0, sizeof s);
    memset(old, 0, sizeof *old);
    s.facets_before = s.facets_after = p->nfacet;
    if (!p->derived || !p->nfacet) {
        if (st)
            *st = s;
        return 0;
    }
    fm_work w;
    memset(&w, 0, sizeof w);
    w.p = p;
    /* With no tolerance only exactly coplanar triangles merge (the cosine
     * of an angle within 1e-8 degrees of 180 rounds to -1). */
    w.cos_min = angle_tol > 0 ? -cos(angle_tol * M_PI / 180.0) : -INFINITY;
    double d2 = 0;
    for (int k = 0; k < 3; k++)
        d2 += (p->bbox[1][k] - p->bbox[0][k]) * (p->bbox[1][k] - p->bbox[0][k]);
    w.exact_tol = p->planar_tol * sqrt(d2);
    w.bend_tol = facet_tol > p->planar_tol ? facet_tol * sqrt(d2) : w.exact_tol;
    size_t nf = p->nfacet;
    w.group = pr_malloc(nf * sizeof *w.group);
    w.ot = pr_malloc(nf * sizeof *w.ot);
    w.next = pr_malloc(nf * sizeof *w.next);
    w.size = pr_malloc(nf * sizeof *w.size);
    w.merged = pr_calloc(nf, 1);
    w.bent = pr_calloc(nf, 1);
    w.queue = pr_malloc((nf * 3 + 1) * sizeof *w.queue);
    w.vstamp = pr_calloc(p->nv ? p->nv : 1, sizeof *w.vstamp);
    int rc = w.group && w.ot && w.next && w.size && w.merged && w.bent && w.queue && w.vstamp
                 ? 0
                 : PDR_ENOMEM;
    if (!rc)
        rc = make_groups(&w);
    if (!rc)
        rc = rebuild(&w, &s);
    if (!rc && s.triangles_merged) {
        /* Swap the new facet arrays in; the old ones go to old. */
        fm_saved nw = w.made;
        nw.planar_tol = s.bent_facets ? facet_tol : p->planar_tol;
        memset(&w.made, 0, sizeof w.made);
        swap_facets(p, &nw);
        *old = nw;
        plc__drop_derived(p);
        s.facets_after = p->nfacet;
    }
    work_free(&w);
    if (st)
        *st = s;
    return rc;
}

int fm_merge(plc *p, double angle_tol, double facet_tol, fm_stats *st)
{
    fm_saved old;
    int rc = merge_keep(p, angle_tol, facet_tol, st, &old);
    saved_free(&old);
    return rc;
}

/* ------------------------------------------------------------ features */

/* One apex per facet around a segment, collected through hmap_each. */
typedef struct fm_apexes {
    const plc *p;
    const uint32_t *tf; /* facet of each facet triangle */
    uint32_t a, b;      /* the segment */
    uint32_t apex[16], fac[16];
    size_t n;
} fm_apexes;

static int collect_apex(void *arg, uint32_t t)
{
    fm_apexes *c = arg;
    for (size_t i = 0; i < c->n; i++)
        if (c->fac[i] == c->tf[t])
            return 0;
    if (c->n == 16)
        return 1;
    const uint32_t *v = c->p->ftri[t];
    c->apex[c->n] = v[0] != c->a && v[0] != c->b ? v[0] : v[1] != c->a && v[1] != c->b ? v[1] : v[2];
    c->fac[c->n++] = c->tf[t];
    return 0;
}

/* The smallest dihedral angle, degrees, between two facets at segment s. */
static float segment_angle(const plc *p, const hmap *tri_of, const uint32_t *tf, size_t s)
{
    fm_apexes c = {.p = p, .tf = tf, .a = p->segs[s].v[0], .b = p->segs[s].v[1], .n = 0};
    hmap_each(tri_of, ukey(c.a, c.b), collect_apex, &c);
    double best = 180.0;
    for (size_t i = 0; i < c.n; i++)
        for (size_t j = i + 1; j < c.n; j++) {
            double cs = halfplane_cos(p->xyz[c.a], p->xyz[c.b], p->xyz[c.apex[i]],
                                      p->xyz[c.apex[j]]);
            double ang = acos(fmax(-1.0, fmin(1.0, cs))) * 180.0 / M_PI;
            if (ang < best)
                best = ang;
        }
    return (float)best;
}

/* The smallest angle, degrees, between two segments at vertex v. */
static float vertex_angle(const plc *p, size_t v)
{
    double best = 180.0;
    for (size_t i = p->v_sstart[v]; i < p->v_sstart[v + 1]; i++)
        for (size_t j = i + 1; j < p->v_sstart[v + 1]; j++) {
            const uint32_t *e = p->segs[p->v_segs[i]].v, *g = p->segs[p->v_segs[j]].v;
            uint32_t x = e[0] == v ? e[1] : e[0], y = g[0] == v ? g[1] : g[0];
            double u[3], w[3];
            v3_sub(p->xyz[x], p->xyz[v], u);
            v3_sub(p->xyz[y], p->xyz[v], w);
            double nn = sqrt(v3_dot(u, u) * v3_dot(w, w));
            if (!(nn > 0))
                continue;
            double ang = acos(fmax(-1.0, fmin(1.0, v3_dot(u, w) / nn))) * 180.0 / M_PI;
            if (ang < best)
                best = ang;
        }
    return (float)best;
}

int fm_features(plc *p, fm_stats *st)
{
    if (!p->derived || !p->ftri_start)
        return PDR_EINVAL;
    pr_free(p->seg_mindih);
    pr_free(p->v_minang);
    p->seg_mindih = pr_malloc((p->nseg ? p->nseg : 1) * sizeof *p->seg_mindih);
    p->v_minang = pr_malloc((p->nv ? p->nv : 1) * sizeof *p->v_minang);
    size_t ntri = p->ftri_start[p->nfacet];
    uint32_t *tf = pr_malloc((ntri ? ntri : 1) * sizeof *tf);
    hmap tri_of = {0};
    int rc = p->seg_mindih && p->v_minang && tf ? 0 : PDR_ENOMEM;
    /* Every facet triangle under each of its edges, and its facet. */
    for (size_t f = 0; f < p->nfacet && !rc; f++)
        for (size_t t = p->ftri_start[f]; t < p->ftri_start[f + 1] && !rc; t++) {
            tf[t] = (uint32_t)f;
            for (int k = 0; k < 3 && !rc; k++)
                rc = hmap_put(&tri_of, ukey(p->ftri[t][k], p->ftri[t][(k + 1) % 3]),
                              (uint32_t)t);
        }
    size_t sharp = 0, acute = 0;
    for (size_t s = 0; s < p->nseg && !rc; s++) {
        p->seg_mindih[s] = segment_angle(p, &tri_of, tf, s);
        sharp += p->seg_mindih[s] < FM_SHARP_DIH;
    }
    for (size_t v = 0; v < p->nv && !rc; v++) {
        p->v_minang[v] = vertex_angle(p, v);
        acute += p->v_minang[v] < FM_ACUTE_ANG;
    }
    hmap_free(&tri_of);
    pr_free(tf);
    if (rc) {
        pr_free(p->seg_mindih);
        pr_free(p->v_minang);
        p->seg_mindih = p->v_minang = NULL;
        return rc;
    }
    if (st) {
        st->sharp_segments = sharp;
        st->acute_vertices = acute;
        st->smooth_segments = 0;
        for (size_t s = 0; s < p->nseg; s++)
            st->smooth_segments += p->seg_mindih[s] >= FM_SMOOTH_DIH &&
                                   p->seg_fstart[s + 1] - p->seg_fstart[s] >= 2;
    }
    return 0;
}

/* Validates p after a merge that made bent facets, with the
 * intersection tests. On failure puts the facets of old back, merges them
 * exactly (angle_tol) and validates that; *undone says so. */
static int validate_bent(plc *p, double angle_tol, fm_saved *old, fm_stats *st, pdr_diag *diag)
{
    pdr_diag bent_diag = {0};
    int rc = plc_validate(p, &bent_diag);
    if (rc != PDR_EGEOMETRY) {
        pdr_diag_move(diag, &bent_diag);
        pdr_diag_free(&bent_diag);
        return rc;
    }
    pdr_diag_free(&bent_diag);
    swap_facets(p, old);
    saved_free(old);
    plc__drop_derived(p);
    rc = plc_derive(p, diag);
    if (!rc)
        rc = merge_keep(p, angle_tol, 0.0, st, old);
    st->bent_undone = 1;
    if (!rc && st->triangles_merged) {
        p->skip_intersections = 1;
        rc = plc_validate(p, diag);
        p->skip_intersections = 0;
    } else if (!rc) {
        rc = plc_validate(p, diag);
    }
    return rc;
}

int fm_prepare(plc *p, double merge_angle, double facet_tol, fm_stats *st, pdr_diag *diag)
{
    memset(st, 0, sizeof *st);
    st->facets_before = st->facets_after = p->nfacet;
    fm_saved old;
    memset(&old, 0, sizeof old);
    int rc = merge_angle >= 0 ? merge_keep(p, merge_angle, facet_tol, st, &old) : 0;
    if (!rc && st->bent_facets) {
        rc = validate_bent(p, merge_angle, &old, st, diag);
    } else if (!rc && st->triangles_merged) {
        p->skip_intersections = 1;
        rc = plc_validate(p, diag);
        p->skip_intersections = 0;
    }
    saved_free(&old);
    if (rc == PDR_EGEOMETRY)
        pdr_diag_add(diag, p->path, 0,
                     "the facets made by merging coplanar triangles are not valid "
                     "(a defect of the merge: try --no-merge)");
    if (!rc)
        rc = fm_features(p, st);
    return rc;
}

size_t fm_thin_corners(const plc *p, double max_angle)
{
    double cmax = cos(max_angle * M_PI / 180.0);
    size_t n = 0;
    for (size_t f = 0; f < p->nfacet; f++) {
        const plc_facet *F = &p->facets[f];
        const plc_polygon *outer = NULL;
        int ok = F->nhole == 0;
        for (size_t q = F->poly_first; ok && q < F->poly_first + F->npoly; q++)
            if (p->polys[q].n >= 3) {
                ok = outer == NULL;
                outer = &p->polys[q];
            }
        if (!ok || !outer)
            continue;
        const uint32_t *c = p->corners + outer->first;
        uint32_t m = outer->n;
        /* The polygon's own normal (Newell): its corners turn
         * counterclockwise about it, so a convex corner turns left. */
        double nrm[3] = {0, 0, 0};
        for (uint32_t i = 0; i < m; i++) {
            const double *a = p->xyz[c[i]], *b = p->xyz[c[(i + 1) % m]];
            nrm[0] += (a[1] - b[1]) * (a[2] + b[2]);
            nrm[1] += (a[2] - b[2]) * (a[0] + b[0]);
            nrm[2] += (a[0] - b[0]) * (a[1] + b[1]);
        }
        for (uint32_t i = 0; i < m; i++) {
            const double *a = p->xyz[c[(i + m - 1) % m]], *v = p->xyz[c[i]],
                         *b = p->xyz[c[(i + 1) % m]];
            double e1[3], e2[3], t[3];
            v3_sub(a, v, e1);
            v3_sub(b, v, e2);
            double l1 = v3_dot(e1, e1), l2 = v3_dot(e2, e2);
            if (!(l1 > 0 && l2 > 0))
                continue;
            /* the turn (v - a) x (b - v) = e2 x e1 along the normal: convex */
            cross(e2, e1, t);
            if (!(v3_dot(t, nrm) > 0))
                continue;
            n += v3_dot(e1, e2) > cmax * sqrt(l1 * l2);
        }
    }
    return n;
}
