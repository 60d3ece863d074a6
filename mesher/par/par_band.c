/* par/par_band.c -- the interface band handed over in halves (see
 * par/par_band.h). */
#include "config.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "base/pdr_util.h"
#include "par/par_band.h"

/* The smallest coordinate along axis of the finite vertices among the
 * first n of v (n 3: a face, 4: a tetrahedron); +inf if none. */
static double low_coord(const tm_mesh *m, const uint32_t *v, int n, int axis)
{
    double x = INFINITY;
    for (int i = 0; i < n; i++)
        if (v[i] != TM_VINF)
            x = fmin(x, tm_xyz(m, v[i])[axis]);
    return x;
}

static double face_coord(const tm_mesh *m, uint32_t t, int k, int axis)
{
    uint32_t v[3];
    for (int j = 0; j < 3; j++)
        v[j] = m->tets[t].v[tm_face_vtx[k][j]];
    return low_coord(m, v, 3, axis);
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int par_band_cut_init(const par_sub *s, uint32_t other, par_band_cut *cut)
{
    const tm_mesh *m = &s->r.m;
    cut->axis = -1;
    cut->at = 0;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    size_t n = 0;
    for (size_t k = 0; k < s->nifc; k++) {
        if (s->ifc[k].pe != other)
            continue;
        uint32_t t = tm_ltet(s->ifc[k].local);
        int f = tm_lface(s->ifc[k].local);
        for (int j = 0; j < 3; j++) {
            uint32_t v = m->tets[t].v[tm_face_vtx[f][j]];
            if (v == TM_VINF)
                continue;
            for (int a = 0; a < 3; a++) {
                lo[a] = fmin(lo[a], tm_xyz(m, v)[a]);
                hi[a] = fmax(hi[a], tm_xyz(m, v)[a]);
            }
        }
        n++;
    }
    if (!n)
        return 0;
    int axis = 0;
    for (int a = 1; a < 3; a++)
        if (hi[a] - lo[a] > hi[axis] - lo[axis])
            axis = a;
    double *x = pr_malloc(n * sizeof *x);
    if (!x)
        return PDR_ENOMEM;
    size_t i = 0;
    for (size_t k = 0; k < s->nifc; k++)
        if (s->ifc[k].pe == other)
            x[i++] = face_coord(m, tm_ltet(s->ifc[k].local), tm_lface(s->ifc[k].local), axis);
    qsort(x, n, sizeof *x, cmp_double);
    cut->axis = axis;
    cut->at = x[n / 2];
    pr_free(x);
    return 0;
}

/* 1 if coordinate x lies on PE to's side of the cut, seen from this PE. */
static int on_side(const par_sub *s, const par_band_cut *cut, uint32_t to, double x)
{
    return to > s->rank ? x >= cut->at : x < cut->at;
}

/* 1 if t may go to PE to: live, free, its interface faces lead to to and
 * lie on to's side, and so does t. */
static int eligible(const par_sub *s, const par_band_cut *cut, uint32_t to, uint32_t t)
{
    const tm_mesh *m = &s->r.m;
    if (tm_is_dead(m, t) || m->lock[t])
        return 0;
    if (!on_side(s, cut, to, low_coord(m, m->tets[t].v, 4, cut->axis)))
        return 0;
    for (int k = 0; k < 4; k++) {
        tm_link l = m->tets[t].n[k];
        if (l == TM_LINK_NONE || l == TM_LINK_UNSET)
            return 0;
        if (!tm_is_special(l))
            continue;
        if (s->ifc[l - TM_LINK_SPECIAL].pe != to ||
            !on_side(s, cut, to, face_coord(m, t, k, cut->axis)))
            return 0;
    }
    return 1;
}

/* Appends t to q with its distance r (rings since the last bad
 * tetrahedron met) in qr. */
static int enqueue(par_u32list *q, par_u32list *qr, uint32_t t, uint32_t r)
{
    if (pdr_grow((void **)&q->a, &q->cap, q->n + 1, sizeof *q->a) ||
        pdr_grow((void **)&qr->a, &qr->cap, qr->n + 1, sizeof *qr->a))
        return PDR_ENOMEM;
    q->a[q->n++] = t;
    qr->a[qr->n++] = r;
    return 0;
}

int par_band_pick(const par_sub *s, const par_band_cut *cut, uint32_t to, int margin,
                  par_u32list *out)
{
    const tm_mesh *m = &s->r.m;
    if (cut->axis < 0 || margin < 1)
        return 0;
    /* 1 for a tetrahedron met (in the band or not), over all slots: a
     * band has thousands. */
    uint8_t *seen = pr_calloc(m->nslots, 1);
    if (!seen)
        return PDR_ENOMEM;
    par_u32list q = {0}, qr = {0};
    int rc = 0;
    size_t start = out->n;
    /* From the tetrahedra on the interface, through local faces, as long
     * as a bad tetrahedron (queued) lies at most margin rings back. */
    for (size_t k = 0; k < s->nifc && !rc; k++) {
        if (s->ifc[k].pe != to)
            continue;
        uint32_t t = tm_ltet(s->ifc[k].local);
        if (seen[t])
            continue;
        seen[t] = 1;
        if (eligible(s, cut, to, t))
            rc = enqueue(&q, &qr, t, (m->flags[t] & TM_F_QUEUED) ? 0 : 1);
    }
    for (size_t i = 0; i < q.n && !rc; i++) {
        uint32_t r = qr.a[i];
        if (r >= (uint32_t)margin)
            continue;
        for (int k = 0; k < 4 && !rc; k++) {
            tm_link l = m->tets[q.a[i]].n[k];
            if (tm_is_special(l))
                continue;
            uint32_t w = tm_ltet(l);
            if (seen[w])
                continue;
            seen[w] = 1;
            if (eligible(s, cut, to, w))
                rc = enqueue(&q, &qr, w, (m->flags[w] & TM_F_QUEUED) ? 0 : r + 1);
        }
    }
    /* Keep those whose local neighbours are all free. */
    for (size_t i = 0; i < q.n && !rc; i++) {
        uint32_t t = q.a[i];
        int ok = 1;
        for (int k = 0; k < 4 && ok; k++) {
            tm_link l = m->tets[t].n[k];
            ok = tm_is_special(l) || !m->lock[tm_ltet(l)];
        }
        if (!ok)
            continue;
        if (pdr_grow((void **)&out->a, &out->cap, out->n + 1, sizeof *out->a))
            rc = PDR_ENOMEM;
        else
            out->a[out->n++] = t;
    }
    if (rc)
        out->n = start;
    pr_free(q.a);
    pr_free(qr.a);
    pr_free(seen);
    return rc;
}
