/*
 * plc/plc_check.c -- plc_validate(): is the input a PLC the mesher can mesh?
 *
 * Stages (each runs only if the previous ones found nothing):
 *  1. structure: duplicate vertices (sort by coordinates), repeated corners
 *     and collinear polygons (exact), zero-length free segments; then the
 *     derived data (planes, segments, incidences);
 *  2. planarity of every facet against planar_tol * bounding-box diagonal;
 *  3. a constrained Delaunay triangulation of every facet (plc/plc_tri.c),
 *     which finds crossing edges and vertices on edges inside a facet;
 *  4. open boundaries (stage 5 runs even when this one fails): an edge of the facet triangulations that only one
 *     triangle of all facets has lies on the rim of one facet and of no
 *     other, so the surface is not closed there;
 *  5. intersections between facets (their triangles) and free segments: a
 *     uniform grid over the bounding boxes finds the candidate pairs, exact
 *     orientation tests decide. Two triangles may share vertices and edges
 *     (that is how facets meet) but must not meet anywhere else.
 */
#include "config.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "base/pdr_util.h"
#include "plc/plc.h"
#include "plc/plc_int.h"
#include "geom/pred.h"
#include "plc/plc_tri.h"

/* ---------------------------------------------------------- stage 1 */

struct vkey {
    double x[3];
    uint32_t v;
};

static int cmp_vkey(const void *a, const void *b)
{
    const struct vkey *p = a, *q = b;
    for (int k = 0; k < 3; k++)
        if (p->x[k] != q->x[k])
            return p->x[k] < q->x[k] ? -1 : 1;
    return p->v < q->v ? -1 : p->v > q->v;
}

/* Sorting by coordinates puts equal vertices next to each other:
 * O(n log n), and exact (no tolerance: near duplicates are legal input,
 * only the mesher's job gets harder). */
static int check_duplicates(const plc *p, pdr_diag *diag)
{
    if (p->nv < 2)
        return 0;
    struct vkey *k = pr_malloc(p->nv * sizeof *k);
    if (!k)
        return PDR_ENOMEM;
    for (size_t v = 0; v < p->nv; v++) {
        memcpy(k[v].x, p->xyz[v], sizeof k[v].x);
        k[v].v = (uint32_t)v;
    }
    qsort(k, p->nv, sizeof *k, cmp_vkey);
    int bad = 0;
    for (size_t i = 1; i < p->nv; i++) {
        const double *a = k[i - 1].x, *b = k[i].x;
        if (a[0] == b[0] && a[1] == b[1] && a[2] == b[2]) {
            pdr_diag_add(diag, p->vfile, p->vline[k[i].v],
                         "vertex %ld duplicates vertex %ld (same coordinates)",
                         plc_vnum(p, k[i].v), plc_vnum(p, k[i - 1].v));
            bad = 1;
        }
    }
    pr_free(k);
    return bad ? PDR_EGEOMETRY : 0;
}

static void proj(const double *x, int axis, double out[2])
{
    out[0] = x[(axis + 1) % 3];
    out[1] = x[(axis + 2) % 3];
}

/* Exactly: are the three points collinear (every coordinate projection
 * degenerate)? */
static int collinear3(const double *a, const double *b, const double *c)
{
    for (int k = 0; k < 3; k++) {
        double pa[2], pb[2], pc[2];
        proj(a, k, pa);
        proj(b, k, pb);
        proj(c, k, pc);
        if (pred_orient2d(pa, pb, pc) != 0)
            return 0;
    }
    return 1;
}

static int check_polygons(const plc *p, pdr_diag *diag)
{
    int bad = 0;
    uint32_t *tmp = NULL;
    size_t cap = 0;
    for (size_t f = 0; f < p->nfacet; f++) {
        const plc_facet *fa = &p->facets[f];
        for (size_t k = 0; k < fa->npoly; k++) {
            const plc_polygon *q = &p->polys[fa->poly_first + k];
            const uint32_t *c = p->corners + q->first;
            long line = q->line ? q->line : fa->line;
            if (q->n < 2)
                continue;
            if (plc__grow((void **)&tmp, &cap, q->n, sizeof *tmp)) {
                pr_free(tmp);
                return PDR_ENOMEM;
            }
            memcpy(tmp, c, q->n * sizeof *c);
            qsort(tmp, q->n, sizeof *tmp, pdr_cmp_u32);
            int rep = 0;
            for (uint32_t i = 1; i < q->n && !rep; i++)
                if (tmp[i] == tmp[i - 1]) {
                    pdr_diag_add(diag, p->path, line,
                                 "facet %zu: polygon uses vertex %ld more than once",
                                 f + 1, plc_vnum(p, tmp[i]));
                    rep = bad = 1;
                }
            if (rep || q->n < 3)
                continue;
            int flat = 1;
            for (uint32_t i = 2; i < q->n && flat; i++)
                flat = collinear3(p->xyz[c[0]], p->xyz[c[1]], p->xyz[c[i]]);
            if (flat) {
                pdr_diag_add(diag, p->path, line,
                             "facet %zu: polygon has zero area (its corners are "
                             "collinear)", f + 1);
                bad = 1;
            }
        }
    }
    for (size_t s = 0; s < p->nsegin; s++)
        if (p->segin[s].v[0] == p->segin[s].v[1]) {
            pdr_diag_add(diag, p->path, p->segin[s].line,
                         "segment (%ld, %ld) has zero length",
                         plc_vnum(p, p->segin[s].v[0]), plc_vnum(p, p->segin[s].v[1]));
            bad = 1;
        }
    pr_free(tmp);
    return bad ? PDR_EGEOMETRY : 0;
}

/* ---------------------------------------------------------- stage 2 */

static double bbox_diag(const plc *p)
{
    double s = 0;
    for (int k = 0; k < 3; k++)
        s += (p->bbox[1][k] - p->bbox[0][k]) * (p->bbox[1][k] - p->bbox[0][k]);
    return sqrt(s);
}

static int check_planarity(const plc *p, pdr_diag *diag)
{
    double tol = p->planar_tol * bbox_diag(p);
    int bad = 0;
    for (size_t f = 0; f < p->nfacet; f++) {
        const plc_facet *fa = &p->facets[f];
        double worst = 0;
        uint32_t wv = 0;
        for (size_t k = 0; k < fa->npoly; k++) {
            const plc_polygon *q = &p->polys[fa->poly_first + k];
            for (uint32_t i = 0; i < q->n; i++) {
                uint32_t v = p->corners[q->first + i];
                const double *x = p->xyz[v];
                double d = fabs(fa->normal[0] * x[0] + fa->normal[1] * x[1] +
                                fa->normal[2] * x[2] - fa->offset);
                if (d > worst) {
                    worst = d;
                    wv = v;
                }
            }
        }
        if (worst > tol) {
            pdr_diag_add(diag, p->path, fa->line,
                         "facet %zu is not planar: vertex %ld is %.3g away from "
                         "its plane (tolerance %.3g)",
                         f + 1, plc_vnum(p, wv), worst, tol);
            bad = 1;
        }
    }
    return bad ? PDR_EGEOMETRY : 0;
}

/* ---------------------------------------------------------- stage 3 */

static int triangulate_facets(plc *p, pdr_diag *diag)
{
    plc_cdt w;
    memset(&w, 0, sizeof w);
    size_t cap = 0, n = 0;
    int bad = 0, rc = 0;
    pr_free(p->ftri_start);
    pr_free(p->ftri);
    p->ftri = NULL;
    p->ftri_start = pr_malloc((p->nfacet + 1) * sizeof *p->ftri_start);
    if (!p->ftri_start)
        return PDR_ENOMEM;
    for (size_t f = 0; f < p->nfacet; f++) {
        p->ftri_start[f] = n;
        plc_cdt_fail fail;
        const plc_facet *fa = &p->facets[f];
        rc = plc_cdt_facet(&w, p, f, &fail);
        if (rc == PDR_ENOMEM)
            break;
        if (rc) {
            bad = 1;
            rc = 0;
            switch (fail.kind) {
            case PLC_CDT_COINCIDENT:
                pdr_diag_add(diag, p->path, fa->line,
                             "facet %zu: vertices %ld and %ld coincide when "
                             "projected onto the facet's plane", f + 1,
                             plc_vnum(p, fail.v[0]), plc_vnum(p, fail.v[1]));
                break;
            case PLC_CDT_ON_SEGMENT:
                pdr_diag_add(diag, p->path, fa->line,
                             "facet %zu: vertex %ld lies on its edge (%ld, %ld)",
                             f + 1, plc_vnum(p, fail.v[2]), plc_vnum(p, fail.v[0]),
                             plc_vnum(p, fail.v[1]));
                break;
            case PLC_CDT_CROSSING:
                pdr_diag_add(diag, p->path, fa->line,
                             "facet %zu: edges (%ld, %ld) and (%ld, %ld) cross",
                             f + 1, plc_vnum(p, fail.v[0]), plc_vnum(p, fail.v[1]),
                             plc_vnum(p, fail.v[2]), plc_vnum(p, fail.v[3]));
                break;
            default:
                pdr_diag_add(diag, p->path, fa->line,
                             "facet %zu: triangulation failed", f + 1);
                break;
            }
            continue;
        }
        if (w.nout == 0) {
            pdr_diag_add(diag, p->path, fa->line,
                         "facet %zu has no area left once its holes are removed",
                         f + 1);
            bad = 1;
            continue;
        }
        if (plc__grow((void **)&p->ftri, &cap, n + w.nout, sizeof *p->ftri)) {
            rc = PDR_ENOMEM;
            break;
        }
        memcpy(p->ftri + n, w.out, w.nout * sizeof *w.out);
        n += w.nout;
    }
    p->ftri_start[p->nfacet] = n;
    plc_cdt_free(&w);
    if (rc)
        return rc;
    return bad ? PDR_EGEOMETRY : 0;
}

/* ---------------------------------------------------------- stage 4 */

struct tedge {
    uint32_t a, b, facet;
};

static int cmp_tedge(const void *x, const void *y)
{
    const struct tedge *e = x, *f = y;
    if (e->a != f->a)
        return e->a < f->a ? -1 : 1;
    if (e->b != f->b)
        return e->b < f->b ? -1 : 1;
    return e->facet < f->facet ? -1 : e->facet > f->facet;
}

static int check_closed(const plc *p, pdr_diag *diag)
{
    size_t nt = p->ftri_start[p->nfacet];
    struct tedge *e = pr_malloc((3 * nt + 1) * sizeof *e);
    if (!e)
        return PDR_ENOMEM;
    size_t n = 0;
    for (size_t f = 0; f < p->nfacet; f++)
        for (size_t t = p->ftri_start[f]; t < p->ftri_start[f + 1]; t++)
            for (int k = 0; k < 3; k++) {
                uint32_t a = p->ftri[t][k], b = p->ftri[t][(k + 1) % 3];
                e[n].a = a < b ? a : b;
                e[n].b = a < b ? b : a;
                e[n].facet = (uint32_t)f;
                n++;
            }
    qsort(e, n, sizeof *e, cmp_tedge);
    int bad = 0;
    for (size_t i = 0; i < n;) {
        size_t j = i + 1;
        while (j < n && e[j].a == e[i].a && e[j].b == e[i].b)
            j++;
        if (j - i == 1) {
            const plc_facet *fa = &p->facets[e[i].facet];
            pdr_diag_add(diag, p->path, fa->line,
                         "facet %u: edge (%ld, %ld) belongs to no other facet "
                         "(the surface is open there)",
                         e[i].facet + 1, plc_vnum(p, e[i].a), plc_vnum(p, e[i].b));
            bad = 1;
        }
        i = j;
    }
    pr_free(e);
    return bad ? PDR_EGEOMETRY : 0;
}

/* ---------------------------------------------------------- stage 5 */

/* The coordinate to drop so that triangle abc projects without
 * degeneracy (exact check, preferring the largest normal component). */
static int tri_axis(const double *a, const double *b, const double *c)
{
    double u[3], v[3], n[3];
    for (int k = 0; k < 3; k++) {
        u[k] = b[k] - a[k];
        v[k] = c[k] - a[k];
    }
    n[0] = fabs(u[1] * v[2] - u[2] * v[1]);
    n[1] = fabs(u[2] * v[0] - u[0] * v[2]);
    n[2] = fabs(u[0] * v[1] - u[1] * v[0]);
    int order[3] = {0, 1, 2};
    for (int i = 0; i < 3; i++)
        for (int j = i + 1; j < 3; j++)
            if (n[order[j]] > n[order[i]]) {
                int t = order[i];
                order[i] = order[j];
                order[j] = t;
            }
    for (int i = 0; i < 3; i++) {
        double pa[2], pb[2], pc[2];
        proj(a, order[i], pa);
        proj(b, order[i], pb);
        proj(c, order[i], pc);
        if (pred_orient2d(pa, pb, pc) != 0)
            return order[i];
    }
    return order[0]; /* degenerate triangle: cannot happen after stage 1 */
}

static int sgn(double x)
{
    return (x > 0) - (x < 0);
}

/* Closed point-in-triangle in 2D, triangle of either orientation. */
static int in_tri2(const double *a, const double *b, const double *c, const double *x)
{
    int s = sgn(pred_orient2d(a, b, c));
    return s * sgn(pred_orient2d(a, b, x)) >= 0 && s * sgn(pred_orient2d(b, c, x)) >= 0 &&
           s * sgn(pred_orient2d(c, a, x)) >= 0;
}

/* Closed segment-segment intersection in 2D. */
static int seg_seg2(const double *p, const double *q, const double *r, const double *s)
{
    int o1 = sgn(pred_orient2d(p, q, r)), o2 = sgn(pred_orient2d(p, q, s));
    int o3 = sgn(pred_orient2d(r, s, p)), o4 = sgn(pred_orient2d(r, s, q));
    if (o1 * o2 > 0 || o3 * o4 > 0)
        return 0;
    if (o1 || o2 || o3 || o4)
        return 1;
    /* Collinear: do the intervals overlap along a non-constant axis? */
    for (int k = 0; k < 2; k++) {
        double lo1 = fmin(p[k], q[k]), hi1 = fmax(p[k], q[k]);
        double lo2 = fmin(r[k], s[k]), hi2 = fmax(r[k], s[k]);
        if (hi1 < lo2 || hi2 < lo1)
            return 0;
    }
    return 1;
}

/* Closed 3D segment pq against closed triangle abc. */
static int seg_tri(const double *p, const double *q, const double *a, const double *b,
                   const double *c)
{
    int op = sgn(pred_orient3d(a, b, c, p)), oq = sgn(pred_orient3d(a, b, c, q));
    if (op * oq > 0)
        return 0;
    int ax = -1;
    double pa[2], pb[2], pc[2], pp[2], pq[2];
    if (op == 0 || oq == 0) {
        ax = tri_axis(a, b, c);
        proj(a, ax, pa);
        proj(b, ax, pb);
        proj(c, ax, pc);
        proj(p, ax, pp);
        proj(q, ax, pq);
    }
    if (op == 0 && oq == 0)
        return in_tri2(pa, pb, pc, pp) || in_tri2(pa, pb, pc, pq) ||
               seg_seg2(pp, pq, pa, pb) || seg_seg2(pp, pq, pb, pc) ||
               seg_seg2(pp, pq, pc, pa);
    if (op == 0)
        return in_tri2(pa, pb, pc, pp);
    if (oq == 0)
        return in_tri2(pa, pb, pc, pq);
    int s1 = sgn(pred_orient3d(p, q, a, b)), s2 = sgn(pred_orient3d(p, q, b, c));
    int s3 = sgn(pred_orient3d(p, q, c, a));
    return (s1 >= 0 && s2 >= 0 && s3 >= 0) || (s1 <= 0 && s2 <= 0 && s3 <= 0);
}

/* Does segment v->x, with v a corner of triangle (v, e, f), meet the
 * triangle anywhere but at v? Only if x is in the triangle's plane and the
 * direction v->x lies in the closed angle of the triangle at v. */
static int ray_in_corner(const double *v, const double *x, const double *e,
                         const double *f)
{
    if (pred_orient3d(v, e, f, x) != 0)
        return 0;
    int ax = tri_axis(v, e, f);
    double pv[2], px[2], pe[2], pf[2];
    proj(v, ax, pv);
    proj(x, ax, px);
    proj(e, ax, pe);
    proj(f, ax, pf);
    int s = sgn(pred_orient2d(pv, pe, pf));
    return s * sgn(pred_orient2d(pv, pe, px)) >= 0 && -s * sgn(pred_orient2d(pv, pf, px)) >= 0;
}

static int tri_tri(const plc *p, const uint32_t *t1, const uint32_t *t2)
{
    const double(*X)[3] = (const double(*)[3])p->xyz;
    int shared = 0, i1[3] = {-1, -1, -1};
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            if (t1[i] == t2[j]) {
                i1[i] = j;
                shared++;
            }
    if (shared == 3)
        return 1;
    if (shared == 2) {
        int c = i1[0] < 0 ? 0 : i1[1] < 0 ? 1 : 2;
        int d = 0;
        while (t2[d] == t1[0] || t2[d] == t1[1] || t2[d] == t1[2])
            d++;
        const double *u = X[t1[(c + 1) % 3]], *w = X[t1[(c + 2) % 3]];
        const double *pc = X[t1[c]], *pd = X[t2[d]];
        if (pred_orient3d(u, w, pc, pd) != 0)
            return 0;
        int ax = tri_axis(u, w, pc);
        double a2[2], b2[2], c2[2], d2[2];
        proj(u, ax, a2);
        proj(w, ax, b2);
        proj(pc, ax, c2);
        proj(pd, ax, d2);
        return sgn(pred_orient2d(a2, b2, c2)) == sgn(pred_orient2d(a2, b2, d2));
    }
    if (shared == 1) {
        int i = i1[0] >= 0 ? 0 : i1[1] >= 0 ? 1 : 2, j = i1[i];
        const double *v = X[t1[i]];
        const double *b = X[t1[(i + 1) % 3]], *c = X[t1[(i + 2) % 3]];
        const double *e = X[t2[(j + 1) % 3]], *f = X[t2[(j + 2) % 3]];
        return seg_tri(b, c, v, e, f) || seg_tri(e, f, v, b, c) ||
               ray_in_corner(v, b, e, f) || ray_in_corner(v, c, e, f) ||
               ray_in_corner(v, e, b, c) || ray_in_corner(v, f, b, c);
    }
    for (int k = 0; k < 3; k++) {
        if (seg_tri(X[t1[k]], X[t1[(k + 1) % 3]], X[t2[0]], X[t2[1]], X[t2[2]]) ||
            seg_tri(X[t2[k]], X[t2[(k + 1) % 3]], X[t1[0]], X[t1[1]], X[t1[2]]))
            return 1;
    }
    return 0;
}

static int seg_tri_shared(const plc *p, const uint32_t *s, const uint32_t *t)
{
    const double(*X)[3] = (const double(*)[3])p->xyz;
    int is0 = -1, is1 = -1;
    for (int j = 0; j < 3; j++) {
        if (t[j] == s[0])
            is0 = j;
        if (t[j] == s[1])
            is1 = j;
    }
    if (is0 >= 0 && is1 >= 0)
        return 0; /* the segment is an edge of the triangle */
    if (is0 >= 0 || is1 >= 0) {
        int j = is0 >= 0 ? is0 : is1;
        const double *v = X[t[j]], *x = X[is0 >= 0 ? s[1] : s[0]];
        return ray_in_corner(v, x, X[t[(j + 1) % 3]], X[t[(j + 2) % 3]]);
    }
    return seg_tri(X[s[0]], X[s[1]], X[t[0]], X[t[1]], X[t[2]]);
}

static int seg_seg(const plc *p, const uint32_t *s, const uint32_t *r)
{
    const double(*X)[3] = (const double(*)[3])p->xyz;
    if ((s[0] == r[0] && s[1] == r[1]) || (s[0] == r[1] && s[1] == r[0]))
        return 1; /* the same segment twice */
    if (s[0] == r[0] || s[0] == r[1] || s[1] == r[0] || s[1] == r[1]) {
        uint32_t v = s[0] == r[0] || s[0] == r[1] ? s[0] : s[1];
        const double *pv = X[v], *x = X[s[0] == v ? s[1] : s[0]],
                     *y = X[r[0] == v ? r[1] : r[0]];
        if (!collinear3(pv, x, y))
            return 0;
        for (int k = 0; k < 3; k++)
            if (x[k] != pv[k])
                return (x[k] > pv[k]) == (y[k] > pv[k]);
        return 0;
    }
    const double *a = X[s[0]], *b = X[s[1]], *c = X[r[0]], *d = X[r[1]];
    if (pred_orient3d(a, b, c, d) != 0)
        return 0;
    for (int k = 0; k < 3; k++) {
        double a2[2], b2[2], c2[2], d2[2];
        proj(a, k, a2);
        proj(b, k, b2);
        proj(c, k, c2);
        proj(d, k, d2);
        if (!seg_seg2(a2, b2, c2, d2))
            return 0;
    }
    return 1;
}

/* An item of the broad phase: a facet triangle or a free segment. */
struct item {
    double lo[3], hi[3];
    uint32_t owner; /* facet index, or nfacet + free segment index */
    uint32_t ref;   /* triangle index in ftri, or free segment index */
    int seg;
};

struct hit {
    uint32_t a, b; /* owners, a < b */
    double at[3];
};

struct hits {
    struct hit *h;
    size_t n, cap;
};

static int record(struct hits *hs, const struct item *x, const struct item *y)
{
    if (plc__grow((void **)&hs->h, &hs->cap, hs->n + 1, sizeof *hs->h))
        return PDR_ENOMEM;
    struct hit *h = &hs->h[hs->n++];
    h->a = x->owner < y->owner ? x->owner : y->owner;
    h->b = x->owner < y->owner ? y->owner : x->owner;
    for (int k = 0; k < 3; k++)
        h->at[k] = 0.5 * (fmax(x->lo[k], y->lo[k]) + fmin(x->hi[k], y->hi[k]));
    return 0;
}

static int overlap(const struct item *x, const struct item *y)
{
    for (int k = 0; k < 3; k++)
        if (x->hi[k] < y->lo[k] || y->hi[k] < x->lo[k])
            return 0;
    return 1;
}

static int test_pair(const plc *p, struct hits *hs, const struct item *x,
                     const struct item *y)
{
    if (x->owner == y->owner || !overlap(x, y))
        return 0;
    int bad;
    if (!x->seg && !y->seg)
        bad = tri_tri(p, p->ftri[x->ref], p->ftri[y->ref]);
    else if (x->seg && y->seg)
        bad = seg_seg(p, p->segin[x->ref].v, p->segin[y->ref].v);
    else if (x->seg)
        bad = seg_tri_shared(p, p->segin[x->ref].v, p->ftri[y->ref]);
    else
        bad = seg_tri_shared(p, p->segin[y->ref].v, p->ftri[x->ref]);
    return bad ? record(hs, x, y) : 0;
}

static int cmp_hit(const void *x, const void *y)
{
    const struct hit *a = x, *b = y;
    if (a->a != b->a)
        return a->a < b->a ? -1 : 1;
    return a->b < b->b ? -1 : a->b > b->b;
}

static void report_hits(const plc *p, struct hits *hs, pdr_diag *diag)
{
    qsort(hs->h, hs->n, sizeof *hs->h, cmp_hit);
    size_t nf = p->nfacet;
    for (size_t i = 0; i < hs->n; i++) {
        if (i > 0 && hs->h[i].a == hs->h[i - 1].a && hs->h[i].b == hs->h[i - 1].b)
            continue;
        const struct hit *h = &hs->h[i];
        if (h->b < nf) {
            /* The second facet's line, where the file has lines (a binary
             * STL has none: the facet numbers are the triangles' order). */
            char at[32] = "";
            if (p->facets[h->b].line > 0)
                snprintf(at, sizeof at, " (line %ld)", p->facets[h->b].line);
            pdr_diag_add(diag, p->path, p->facets[h->a].line,
                         "facets %u and %u%s intersect near (%.6g, %.6g, %.6g)", h->a + 1,
                         h->b + 1, at, h->at[0], h->at[1], h->at[2]);
        } else {
            const plc_segment *s = &p->segin[h->b - nf];
            if (h->a < nf)
                pdr_diag_add(diag, p->path, s->line,
                             "segment (%ld, %ld) intersects facet %u near "
                             "(%.6g, %.6g, %.6g)",
                             plc_vnum(p, s->v[0]), plc_vnum(p, s->v[1]), h->a + 1,
                             h->at[0], h->at[1], h->at[2]);
            else
                pdr_diag_add(diag, p->path, s->line,
                             "segment (%ld, %ld) intersects segment (%ld, %ld) near "
                             "(%.6g, %.6g, %.6g)",
                             plc_vnum(p, s->v[0]), plc_vnum(p, s->v[1]),
                             plc_vnum(p, p->segin[h->a - nf].v[0]),
                             plc_vnum(p, p->segin[h->a - nf].v[1]), h->at[0],
                             h->at[1], h->at[2]);
        }
    }
}

static int check_intersections(const plc *p, pdr_diag *diag)
{
    size_t ntri = p->ftri_start[p->nfacet], n = ntri + p->nsegin;
    if (n < 2)
        return 0;
    struct item *it = pr_malloc(n * sizeof *it);
    if (!it)
        return PDR_ENOMEM;
    double mean = 0;
    for (size_t f = 0, i = 0; f < p->nfacet; f++)
        for (size_t t = p->ftri_start[f]; t < p->ftri_start[f + 1]; t++, i++) {
            it[i].owner = (uint32_t)f;
            it[i].ref = (uint32_t)t;
            it[i].seg = 0;
        }
    for (size_t s = 0; s < p->nsegin; s++) {
        it[ntri + s].owner = (uint32_t)(p->nfacet + s);
        it[ntri + s].ref = (uint32_t)s;
        it[ntri + s].seg = 1;
    }
    for (size_t i = 0; i < n; i++) {
        const uint32_t *v = it[i].seg ? p->segin[it[i].ref].v : p->ftri[it[i].ref];
        int nv = it[i].seg ? 2 : 3;
        double ext = 0;
        for (int k = 0; k < 3; k++) {
            it[i].lo[k] = it[i].hi[k] = p->xyz[v[0]][k];
            for (int j = 1; j < nv; j++) {
                it[i].lo[k] = fmin(it[i].lo[k], p->xyz[v[j]][k]);
                it[i].hi[k] = fmax(it[i].hi[k], p->xyz[v[j]][k]);
            }
            ext = fmax(ext, it[i].hi[k] - it[i].lo[k]);
        }
        mean += ext;
    }
    mean /= (double)n;

    /* Grid: cells about twice the mean item size, at most ~4n cells. */
    double h = 2 * mean;
    if (!(h > 0))
        h = 1;
    size_t g[3];
    for (;;) {
        double cells = 1;
        for (int k = 0; k < 3; k++) {
            double e = p->bbox[1][k] - p->bbox[0][k];
            g[k] = (size_t)fmin(e / h, 1e6) + 1;
            cells *= (double)g[k];
        }
        if (cells <= 4.0 * (double)n + 64)
            break;
        h *= 1.5;
    }
    size_t ncell = g[0] * g[1] * g[2];
    size_t *start = pr_calloc(ncell + 1, sizeof *start);
    uint32_t *big = pr_malloc(n * sizeof *big);
    unsigned char *isbig = pr_calloc(n, 1);
    uint32_t *cellv = NULL;
    size_t nbig = 0;
    int rc = 0;
    struct hits hs = {NULL, 0, 0};
    if (!start || !big || !isbig) {
        rc = PDR_ENOMEM;
        goto out;
    }
#define CELL(k, x) ((size_t)fmin((double)(g[k] - 1), floor(((x) - p->bbox[0][k]) / h)))
    /* Items spanning many cells go to a 'big' list tested against all;
     * the others are bucketed into every cell their box touches: count,
     * allocate, fill (start[c] is a cursor during the fill, then shifted
     * back to be the beginning of cell c). */
    for (int pass = 0; pass < 2; pass++) {
        for (size_t i = 0; i < n; i++) {
            size_t lo[3], hi[3], cnt = 1;
            for (int k = 0; k < 3; k++) {
                lo[k] = CELL(k, it[i].lo[k]);
                hi[k] = CELL(k, it[i].hi[k]);
                cnt *= hi[k] - lo[k] + 1;
            }
            if (cnt > 64) {
                if (pass == 0) {
                    big[nbig++] = (uint32_t)i;
                    isbig[i] = 1;
                }
                continue;
            }
            for (size_t x = lo[0]; x <= hi[0]; x++)
                for (size_t y = lo[1]; y <= hi[1]; y++)
                    for (size_t z = lo[2]; z <= hi[2]; z++) {
                        size_t c = (x * g[1] + y) * g[2] + z;
                        if (pass == 0)
                            start[c + 1]++;
                        else
                            cellv[start[c]++] = (uint32_t)i;
                    }
        }
        if (pass == 0) {
            for (size_t c = 0; c < ncell; c++)
                start[c + 1] += start[c];
            cellv = pr_malloc((start[ncell] + 1) * sizeof *cellv);
            if (!cellv) {
                rc = PDR_ENOMEM;
                goto out;
            }
        }
    }
    for (size_t c = ncell; c > 0; c--)
        start[c] = start[c - 1];
    start[0] = 0;

    for (size_t c = 0; c < ncell && !rc; c++) {
        size_t cx = c / (g[1] * g[2]), cy = c / g[2] % g[1], cz = c % g[2];
        for (size_t i = start[c]; i < start[c + 1] && !rc; i++)
            for (size_t j = i + 1; j < start[c + 1] && !rc; j++) {
                const struct item *x = &it[cellv[i]], *y = &it[cellv[j]];
                /* Test a pair only in the cell holding the low corner of
                 * the overlap of the two boxes, so it is tested once. */
                if (CELL(0, fmax(x->lo[0], y->lo[0])) != cx ||
                    CELL(1, fmax(x->lo[1], y->lo[1])) != cy ||
                    CELL(2, fmax(x->lo[2], y->lo[2])) != cz)
                    continue;
                rc = test_pair(p, &hs, x, y);
            }
    }
    /* Big items against everything; a pair of big items only once. */
    for (size_t b = 0; b < nbig && !rc; b++)
        for (size_t i = 0; i < n && !rc; i++)
            if (!isbig[i] || i > big[b])
                rc = test_pair(p, &hs, &it[big[b]], &it[i]);
#undef CELL
    if (!rc && hs.n) {
        report_hits(p, &hs, diag);
        rc = PDR_EGEOMETRY;
    }
out:
    pr_free(hs.h);
    pr_free(start);
    pr_free(big);
    pr_free(isbig);
    pr_free(cellv);
    pr_free(it);
    return rc;
}

/* ---------------------------------------------------------- driver */

int plc_validate(plc *p, pdr_diag *diag)
{
    int rc;
    if (p->nfacet == 0) {
        pdr_diag_add(diag, p->path, 0, "the input has no facets");
        return PDR_EGEOMETRY;
    }
    int r1 = check_duplicates(p, diag);
    int r2 = check_polygons(p, diag);
    if (r1 == PDR_ENOMEM || r2 == PDR_ENOMEM)
        goto nomem;
    if (r1 || r2)
        return PDR_EGEOMETRY;
    if ((rc = plc_derive(p, diag)))
        return rc;
    if ((rc = check_planarity(p, diag)))
        return rc;
    rc = triangulate_facets(p, diag);
    if (rc == PDR_ENOMEM)
        goto nomem;
    if (rc)
        return rc;
    /* Stages 4 and 5 both run: a vertex on another facet's edge shows up
     * as an open edge and as an intersection, and the second says why. */
    int closed = check_closed(p, diag);
    rc = closed == PDR_ENOMEM || p->skip_intersections ? closed : check_intersections(p, diag);
    if (rc == PDR_ENOMEM)
        goto nomem;
    return rc ? rc : closed;
nomem:
    pdr_diag_add(diag, p->path, 0, "out of memory while validating");
    return PDR_ENOMEM;
}
