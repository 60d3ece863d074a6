/* refine/refine.c -- Delaunay refinement: queues, insertions, the cavity decision,
 * facet triangulation updates (see refine/refine.h). */
#include "config.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/pdr_util.h"
#include "geom/pred.h"
#include "refine/refine.h"
#include "base/v3.h"

#define X(m, v) ((m)->xyz + 3 * (size_t)(v))

/* ------------------------------------------------------------ geometry */

/* fmin/fmax are library calls (their NaN rules); these are not. */
static inline double dmin(double a, double b)
{
    return b < a ? b : a;
}
static inline double dmax(double a, double b)
{
    return b > a ? b : a;
}

double ref_tet_ratio2(const double *a, const double *b, const double *c, const double *d,
                      double *vol, double *lmax2, double cc[3])
{
    double u[3], v[3], w[3], vw[3], wu[3], uv[3];
    double det = v3_tet_frame(a, b, c, d, u, v, w, vw, wu, uv);
    double uu = v3_dot(u, u), vv = v3_dot(v, v), ww = v3_dot(w, w);
    double e3 = v3_dist2(b, c), e4 = v3_dist2(b, d), e5 = v3_dist2(c, d);
    double lo = uu, hi = uu;
    double e[5] = {vv, ww, e3, e4, e5};
    for (int k = 0; k < 5; k++) {
        if (e[k] < lo)
            lo = e[k];
        if (e[k] > hi)
            hi = e[k];
    }
    if (vol)
        *vol = det / 6.0;
    if (lmax2)
        *lmax2 = hi;
    if (!(det > 0.0) || !(lo > 0.0)) {
        if (cc)
            cc[0] = cc[1] = cc[2] = NAN;
        return INFINITY;
    }
    double inv = 0.5 / det;
    double x = (uu * vw[0] + vv * wu[0] + ww * uv[0]) * inv;
    double y = (uu * vw[1] + vv * wu[1] + ww * uv[1]) * inv;
    double z = (uu * vw[2] + vv * wu[2] + ww * uv[2]) * inv;
    if (cc) {
        cc[0] = a[0] + x;
        cc[1] = a[1] + y;
        cc[2] = a[2] + z;
    }
    return (x * x + y * y + z * z) / lo;
}

/* Circumcentre of triangle abc in space; *r2 its squared radius. Returns
 * 0, or -1 for a degenerate triangle. */
static int tri_circumcentre(const double *a, const double *b, const double *c, double cc[3],
                            double *r2)
{
    double u[3], v[3], n[3], vn[3], nu[3];
    v3_sub(b, a, u);
    v3_sub(c, a, v);
    v3_cross(u, v, n);
    double nn = v3_dot(n, n);
    if (!(nn > 0.0))
        return -1;
    v3_cross(v, n, vn);
    v3_cross(n, u, nu);
    double uu = v3_dot(u, u), vv = v3_dot(v, v), inv = 0.5 / nn;
    double x[3];
    for (int k = 0; k < 3; k++)
        x[k] = (uu * vn[k] + vv * nu[k]) * inv;
    for (int k = 0; k < 3; k++)
        cc[k] = a[k] + x[k];
    if (r2)
        *r2 = v3_dot(x, x);
    return isfinite(cc[0]) && isfinite(cc[1]) && isfinite(cc[2]) ? 0 : -1;
}

/* p strictly inside the diametral ball of ab. */
static int in_diametral(const double *a, const double *b, const double *p)
{
    double pa[3], pb[3];
    v3_sub(a, p, pa);
    v3_sub(b, p, pb);
    return v3_dot(pa, pb) < 0.0;
}

/* p strictly inside the equatorial ball of abc and off its plane. "Off"
 * has a tolerance: facets that are not axis-aligned hold vertices (facet
 * circumcentres, segment midpoints) that are off the plane by a rounding
 * error, and such a vertex on the equatorial circle of a neighbouring
 * subfacet must not count as encroaching it -- whether that subfacet is a
 * face of the mesh is then decided exactly, by the mesh, and a missing one
 * is recovered. */
static int in_equatorial(const double *a, const double *b, const double *c, const double *p)
{
    double cc[3], r2;
    if (tri_circumcentre(a, b, c, cc, &r2))
        return 0;
    if (!(v3_dist2(p, cc) < r2))
        return 0;
    double u[3], v[3], n[3], w[3];
    v3_sub(b, a, u);
    v3_sub(c, a, v);
    v3_cross(u, v, n);
    v3_sub(p, a, w);
    double h = v3_dot(n, w);
    return h * h > 1e-18 * v3_dot(n, n) * r2;
}

/* Orientation of abc projected on facet f's plane, positive when abc is
 * counterclockwise about the facet normal. The projection drops the
 * dominant axis k and keeps the axes (k+1, k+2) in that order, which keeps
 * the handedness, so the sign of normal[k] orients the result. */
static int orient_facet(const plc *pl, uint32_t f, const double *a, const double *b,
                        const double *c)
{
    int k = pl->facets[f].axis, i = (k + 1) % 3, j = (k + 2) % 3;
    double pa[2] = {a[i], a[j]}, pb[2] = {b[i], b[j]}, pc[2] = {c[i], c[j]};
    int o = pred_orient2d(pa, pb, pc);
    return pl->facets[f].normal[k] > 0 ? o : -o;
}

/* ---------------------------------------------------------------- queues */

static int q_push(ref_queue *q, uint32_t id, float rmin)
{
    if (q->n == q->cap) {
        if (q->head > 0 && q->head >= q->cap / 2) {
            memmove(q->id, q->id + q->head, (q->n - q->head) * sizeof *q->id);
            memmove(q->rmin, q->rmin + q->head, (q->n - q->head) * sizeof *q->rmin);
            q->n -= q->head;
            q->head = 0;
        } else {
            size_t c = q->cap ? q->cap * 2 : 1024;
            uint32_t *ids = realloc(q->id, c * sizeof *ids);
            if (!ids)
                return PDR_ENOMEM;
            q->id = ids;
            float *rp = realloc(q->rmin, c * sizeof *rp);
            if (!rp)
                return PDR_ENOMEM;
            q->rmin = rp;
            q->cap = c;
        }
    }
    q->id[q->n] = id;
    q->rmin[q->n] = rmin;
    q->n++;
    return 0;
}

static int q_empty(const ref_queue *q)
{
    return q->head == q->n;
}

static uint32_t q_pop(ref_queue *q, int lifo, float *rmin)
{
    size_t i = lifo ? --q->n : q->head++;
    uint32_t id = q->id[i];
    if (rmin)
        *rmin = q->rmin[i];
    if (q->head == q->n)
        q->head = q->n = 0;
    return id;
}

static void q_free(ref_queue *q)
{
    free(q->id);
    free(q->rmin);
    memset(q, 0, sizeof *q);
}

static int queue_seg(ref_mesher *r, uint32_t id, float rmin)
{
    bd_subseg *s = &r->bd.segs[id];
    if (s->flags & (BD_F_DEAD | BD_F_QUEUED))
        return 0;
    s->flags |= BD_F_QUEUED;
    return q_push(&r->segq, id, rmin);
}

static int queue_fac(ref_mesher *r, uint32_t id, float rmin)
{
    bd_subfac *s = &r->bd.facs[id];
    if (s->flags & (BD_F_DEAD | BD_F_QUEUED))
        return 0;
    s->flags |= BD_F_QUEUED;
    return q_push(&r->facq, id, rmin);
}

static int queue_tet(ref_mesher *r, uint32_t t)
{
    if (r->m.flags[t] & TM_F_QUEUED)
        return 0;
    r->m.flags[t] |= TM_F_QUEUED;
    return q_push(&r->tetq, t, 0.0f);
}

/* ---------------------------------------------------------------- marks */

static int marks_add(ref_marks *cm, ref_mark **out)
{
    if (cm->n == cm->cap) {
        size_t c = cm->cap ? cm->cap * 2 : 32;
        ref_mark *m = realloc(cm->m, c * sizeof *m);
        if (!m)
            return PDR_ENOMEM;
        cm->m = m;
        cm->cap = c;
    }
    *out = &cm->m[cm->n++];
    memset(*out, 0, sizeof **out);
    return 0;
}

void ref_marks_free(ref_marks *cm)
{
    free(cm->m);
    free(cm->seg);
    memset(cm, 0, sizeof *cm);
}

static size_t seg_hash(uint32_t a, uint32_t b, size_t mask)
{
    uint64_t h = ((uint64_t)a << 32 | b) * 0x9e3779b97f4a7c15u;
    return (size_t)(h >> 32) & mask;
}

/* The slot of subsegment a < b in cm's set: the one holding it, or the
 * empty one where it would go. */
static ref_seg_slot *seg_slot(ref_marks *cm, uint32_t a, uint32_t b)
{
    size_t mask = cm->seg_cap - 1;
    for (size_t h = seg_hash(a, b, mask);; h = (h + 1) & mask) {
        ref_seg_slot *s = &cm->seg[h];
        if (s->stamp != cm->stamp)
            return s;
        const ref_mark *mk = &cm->m[s->mark];
        if (mk->v[0] == a && mk->v[1] == b)
            return s;
    }
}

/* Makes room for one more subsegment (load at most one half). */
static int seg_room(ref_marks *cm)
{
    if (2 * (cm->nseg + 1) <= cm->seg_cap)
        return 0;
    size_t cap = cm->seg_cap ? 2 * cm->seg_cap : 16;
    ref_seg_slot *t = calloc(cap, sizeof *t);
    if (!t)
        return PDR_ENOMEM;
    free(cm->seg);
    cm->seg = t;
    cm->seg_cap = cap;
    cm->stamp = 1;
    for (size_t k = 0; k < cm->n; k++)
        if (cm->m[k].nv == 2) {
            ref_seg_slot *s = seg_slot(cm, cm->m[k].v[0], cm->m[k].v[1]);
            s->stamp = cm->stamp;
            s->mark = (uint32_t)k;
        }
    return 0;
}

/* Starts a new gather: no marks, an empty subsegment set. */
static void marks_reset(ref_marks *cm)
{
    cm->n = 0;
    cm->nseg = 0;
    if (++cm->stamp == 0) {
        if (cm->seg)
            memset(cm->seg, 0, cm->seg_cap * sizeof *cm->seg);
        cm->stamp = 1;
    }
}

static int slot_in(const tm_tet *T, uint32_t v)
{
    return T->v[0] == v ? 0 : T->v[1] == v ? 1 : T->v[2] == v ? 2 : T->v[3] == v ? 3 : -1;
}

/* Walks around edge ab starting at tetrahedron t (which has it), calling
 * fn on every tetrahedron; stops when fn returns nonzero (and returns
 * that) or when the walk is back at t (returns 0). A special link (domain
 * boundary, remote face) ends the walk with -1. */
static int around_edge(const tm_mesh *m, uint32_t t, uint32_t a, uint32_t b,
                       int (*fn)(const tm_mesh *m, uint32_t t, void *arg), void *arg)
{
    const tm_tet *T = &m->tets[t];
    uint32_t e = TM_NONE;
    for (int s = 0; s < 4; s++)
        if (T->v[s] != a && T->v[s] != b) {
            e = T->v[s];
            break;
        }
    uint32_t cur = t;
    for (size_t steps = 0; steps < 4096; steps++) {
        int r = fn(m, cur, arg);
        if (r)
            return r;
        const tm_tet *C = &m->tets[cur];
        int se = slot_in(C, e);
        uint32_t o = TM_NONE;
        for (int s = 0; s < 4; s++)
            if (C->v[s] != a && C->v[s] != b && C->v[s] != e)
                o = C->v[s];
        tm_link l = C->n[se];
        if (tm_is_special(l))
            return -1;
        cur = tm_ltet(l);
        e = o;
        if (cur == t)
            return 0;
    }
    return -1;
}

static int not_in_cavity(const tm_mesh *m, uint32_t t, void *arg)
{
    (void)arg;
    return (m->flags[t] & TM_F_CAVITY) ? 0 : 1;
}

int ref_gather_marks(const tm_mesh *m, const dt_cavity *c, ref_marks *out)
{
    marks_reset(out);
    for (size_t i = 0; i < c->ntets; i++) {
        uint32_t t = c->tets[i];
        uint16_t f = m->flags[t];
        if (!(f & (TM_F_FACEMARKS | TM_F_SUBSEGS)))
            continue;
        const tm_tet *T = &m->tets[t];
        for (int k = 0; k < 4 && (f & TM_F_FACEMARKS); k++) {
            if (!(f & TM_F_FACEMARK(k)))
                continue;
            tm_link l = T->n[k];
            int del = 0;
            if (!tm_is_special(l) && (m->flags[tm_ltet(l)] & TM_F_CAVITY)) {
                del = 1;
                if (tm_ltet(l) < t)
                    continue; /* listed from the other side */
            }
            ref_mark *mk;
            if (marks_add(out, &mk))
                return PDR_ENOMEM;
            mk->nv = 3;
            for (int q = 0; q < 3; q++) {
                mk->v[q] = T->v[tm_face_vtx[k][q]];
                memcpy(mk->x[q], X(m, mk->v[q]), sizeof mk->x[q]);
            }
            mk->facet = m->marker[4 * (size_t)t + (size_t)k] - 1;
            mk->deleted = (uint8_t)del;
        }
        for (int e = 0; e < 6 && (f & TM_F_SUBSEGS); e++) {
            if (!(f & TM_F_SUBSEG(e)))
                continue;
            uint32_t a = T->v[tm_edge_vtx[e][0]], b = T->v[tm_edge_vtx[e][1]];
            if (a > b) {
                uint32_t x = a;
                a = b;
                b = x;
            }
            if (seg_room(out))
                return PDR_ENOMEM;
            ref_seg_slot *slot = seg_slot(out, a, b);
            if (slot->stamp == out->stamp)
                continue; /* listed from another tetrahedron around it */
            ref_mark *mk;
            if (marks_add(out, &mk))
                return PDR_ENOMEM;
            slot->stamp = out->stamp;
            slot->mark = (uint32_t)(out->n - 1);
            out->nseg++;
            mk->nv = 2;
            mk->v[0] = a;
            mk->v[1] = b;
            memcpy(mk->x[0], X(m, a), sizeof mk->x[0]);
            memcpy(mk->x[1], X(m, b), sizeof mk->x[1]);
            mk->facet = -1;
            mk->deleted = around_edge(m, t, a, b, not_in_cavity, NULL) == 0;
        }
    }
    return 0;
}

void ref_decide(const plc *pl, const double p[3], int kind, ref_marks *cm, ref_decision *d)
{
    memset(d, 0, sizeof *d);
    d->action = REF_COMMIT;
    size_t best = SIZE_MAX;
    double best_r2 = -1.0;
    for (size_t k = 0; k < cm->n; k++) {
        ref_mark *mk = &cm->m[k];
        if (mk->nv == 2) {
            mk->encroached = (uint8_t)(mk->deleted || in_diametral(mk->x[0], mk->x[1], p));
            d->nseg_encroached += mk->encroached;
        } else {
            mk->encroached =
                (uint8_t)(mk->deleted || in_equatorial(mk->x[0], mk->x[1], mk->x[2], p));
            if (mk->encroached) {
                d->nfac_encroached++;
                double cc[3], r2 = 0.0;
                tri_circumcentre(mk->x[0], mk->x[1], mk->x[2], cc, &r2);
                if (r2 > best_r2) {
                    best_r2 = r2;
                    best = k;
                }
            }
        }
    }
    if (kind == REF_SUBSEG)
        return;
    if (d->nseg_encroached) {
        d->action = REF_SPLIT_SUBSEGS;
        return;
    }
    if (kind == REF_SUBFACET || !d->nfac_encroached)
        return;
    /* Projection lemma: among the encroached subfacets of the facet of the
     * largest one, prefer the one containing p's orthogonal projection. */
    d->action = REF_SPLIT_SUBFACET;
    d->which = best;
    int32_t f = cm->m[best].facet;
    if (f < 0 || (size_t)f >= pl->nfacet)
        return;
    const plc_facet *F = &pl->facets[f];
    double h = v3_dot(F->normal, p) - F->offset, q[3];
    for (int i = 0; i < 3; i++)
        q[i] = p[i] - h * F->normal[i];
    for (size_t k = 0; k < cm->n; k++) {
        const ref_mark *mk = &cm->m[k];
        if (mk->nv != 3 || mk->facet != f || !mk->encroached)
            continue;
        /* mark vertices are in the face's order, which may be either
         * orientation about the normal: inside = all signs equal */
        int o0 = orient_facet(pl, (uint32_t)f, mk->x[0], mk->x[1], q);
        int o1 = orient_facet(pl, (uint32_t)f, mk->x[1], mk->x[2], q);
        int o2 = orient_facet(pl, (uint32_t)f, mk->x[2], mk->x[0], q);
        if ((o0 >= 0 && o1 >= 0 && o2 >= 0) || (o0 <= 0 && o1 <= 0 && o2 <= 0)) {
            d->which = k;
            return;
        }
    }
}

/* ------------------------------------------------------------- set-up */

void ref_default_opts(ref_opts *o)
{
    memset(o, 0, sizeof *o);
    o->ratio = 2.0;
    o->min_dihedral = 10.0;
    o->rho = 1.0 / (2.0 * sqrt(2.0));
    o->use_region_maxvol = 1;
    o->order = REF_ORDER_LIFO;
}

int ref_init(ref_mesher *r, const plc *p, const ref_opts *o)
{
    memset(r, 0, sizeof *r);
    r->p = p;
    if (o)
        r->o = *o;
    else
        ref_default_opts(&r->o);
    r->b2 = r->o.ratio > 0 ? r->o.ratio * r->o.ratio : 0.0;
    r->sin_min = r->o.min_dihedral > 0 ? sin(r->o.min_dihedral * M_PI / 180.0) : 0.0;
    bd_init(&r->bd);
    dt_cavity_init(&r->cav);
    int rc = tm_init(&r->m, TM_FEAT_MARKERS);
    if (rc)
        return rc;
    if (p->nregion) {
        rc = ref_region_room(r);
        if (rc) {
            ref_free(r);
            return rc;
        }
    }
    return 0;
}

void ref_free(ref_mesher *r)
{
    ref_release_work(r);
    tm_free(&r->m);
    bd_free(&r->bd);
    free(r->region);
    free(r->seg_acute);
    free(r->bflag);
    free(r->breg);
    free(r->list);
    free(r->bedge);
    free(r->miss);
    memset(r, 0, sizeof *r);
}

void ref_release_work(ref_mesher *r)
{
    dt_cavity_free(&r->cav);
    ref_marks_free(&r->marks);
    q_free(&r->segq);
    q_free(&r->facq);
    q_free(&r->tetq);
}

int ref_region_room(ref_mesher *r)
{
    if (!r->p->nregion || r->region_cap >= r->m.tcap)
        return 0;
    size_t c = r->m.tcap;
    uint16_t *g = realloc(r->region, c * sizeof *g);
    if (!g)
        return PDR_ENOMEM;
    memset(g + r->region_cap, 0, (c - r->region_cap) * sizeof *g);
    r->region = g;
    r->region_cap = c;
    return 0;
}

/* -------------------------------------------------------- tet quality */

static int on_facet(const ref_mesher *r, uint32_t v, uint32_t f);

static double region_maxvol(const ref_mesher *r, uint32_t t)
{
    double mv = r->o.maxvol;
    if (r->region && r->o.use_region_maxvol && r->region[t]) {
        double rv = r->p->regions[r->region[t] - 1].maxvol;
        if (rv > 0 && (mv <= 0 || rv < mv))
            mv = rv;
    }
    return mv;
}

/* 1 if all four vertices of t lie on one facet by construction: a flat
 * tetrahedron on that facet (possible where the facet is not axis-aligned
 * and four of its vertices are cocircular up to rounding errors). Its
 * circumcentre lies on the facet, so splitting it splits a subfacet. */
static int flat_on_facet(const ref_mesher *r, const uint32_t *v)
{
    const bd_set *bd = &r->bd;
    for (int s = 0; s < 4; s++)
        if (bd->vkind[v[s]] == BD_V_VOLUME)
            return 0;
    const plc *p = r->p;
    uint32_t x = bd->vfeat[v[0]];
    const uint32_t *cand;
    size_t n;
    uint32_t one;
    switch (bd->vkind[v[0]]) {
    case BD_V_FACET:
        one = x;
        cand = &one;
        n = 1;
        break;
    case BD_V_SEGMENT:
        cand = p->seg_facets + p->seg_fstart[x];
        n = p->seg_fstart[x + 1] - p->seg_fstart[x];
        break;
    default:
        cand = p->v_facets + p->v_fstart[x];
        n = p->v_fstart[x + 1] - p->v_fstart[x];
        break;
    }
    for (size_t i = 0; i < n; i++)
        if (on_facet(r, v[1], cand[i]) && on_facet(r, v[2], cand[i]) &&
            on_facet(r, v[3], cand[i]))
            return 1;
    return 0;
}

/* 1 if interior tetrahedron t breaks a bound (2: only the dihedral angle
 * bound, 3: it lies flat on a facet); cc gets its circumcentre and
 * *ratio2 its squared radius-edge ratio. One pass without square roots:
 * this runs on every new tetrahedron. With u, v, w the edges at a, the
 * face normals (twice the areas) are n1 = v x w, n2 = w x u, n3 = u x v
 * and n0 = n1 + n2 + n3 (the four sum to zero with outward orientation),
 * and the dihedral angle at the edge e shared by faces i and j has
 * sin = 6V |e| / (4 A_i A_j) = det |e| / (|n_i| |n_j|). */
static int tet_bad(const ref_mesher *r, uint32_t t, double cc[3], double *ratio2)
{
    const tm_mesh *m = &r->m;
    const uint32_t *tv = m->tets[t].v;
    const double *a = X(m, tv[0]), *b = X(m, tv[1]), *c = X(m, tv[2]), *d = X(m, tv[3]);
    double u[3], v[3], w[3], n1[3], n2[3], n3[3];
    double det = v3_tet_frame(a, b, c, d, u, v, w, n1, n2, n3);
    double l2[6];
    l2[0] = v3_dot(u, u);
    l2[1] = v3_dot(v, v);
    l2[2] = v3_dot(w, w);
    l2[3] = v3_dist2(b, c);
    l2[4] = v3_dist2(b, d);
    l2[5] = v3_dist2(c, d);
    double lo = l2[0], hi = l2[0];
    for (int k = 1; k < 6; k++) {
        lo = dmin(lo, l2[k]);
        hi = dmax(hi, l2[k]);
    }
    double q = INFINITY;
    if (det > 0.0 && lo > 0.0) {
        double inv = 0.5 / det, x[3];
        for (int k = 0; k < 3; k++) {
            x[k] = (l2[0] * n1[k] + l2[1] * n2[k] + l2[2] * n3[k]) * inv;
            cc[k] = a[k] + x[k];
        }
        q = v3_dot(x, x) / lo;
    } else {
        cc[0] = cc[1] = cc[2] = NAN;
    }
    if (ratio2)
        *ratio2 = q;
    if (flat_on_facet(r, tv))
        return 3;
    if (r->b2 > 0 && q >= r->b2)
        return 1;
    double mv = region_maxvol(r, t);
    if (mv > 0 && det > 6.0 * mv)
        return 1;
    if (r->o.maxedge > 0 && hi > r->o.maxedge * r->o.maxedge)
        return 1;
    if (r->sin_min > 0) {
        double n0[3] = {n1[0] + n2[0] + n3[0], n1[1] + n2[1] + n3[1], n1[2] + n2[2] + n3[2]};
        double f0 = v3_dot(n0, n0), f1 = v3_dot(n1, n1), f2 = v3_dot(n2, n2), f3 = v3_dot(n3, n3);
        double s2 = r->sin_min * r->sin_min, d2 = det * det;
        /* edges 01 02 03 12 13 23 lie on faces (2,3) (1,3) (1,2) (0,3)
         * (0,2) (0,1) */
        if (d2 * l2[0] < s2 * f2 * f3 || d2 * l2[1] < s2 * f1 * f3 ||
            d2 * l2[2] < s2 * f1 * f2 || d2 * l2[3] < s2 * f0 * f3 ||
            d2 * l2[4] < s2 * f0 * f2 || d2 * l2[5] < s2 * f0 * f1)
            return 2;
    }
    return 0;
}

static int queue_new_tets(ref_mesher *r)
{
    if (!r->classified)
        return 0;
    tm_mesh *m = &r->m;
    const dt_cavity *c = &r->cav;
    for (size_t i = 0; i < c->nnew; i++) {
        uint32_t n = c->newtets[i];
        if ((m->flags[n] & REF_F_EXTERIOR) || tm_is_ghost(m, n))
            continue;
        double cc[3];
        if (tet_bad(r, n, cc, NULL)) {
            int rc = queue_tet(r, n);
            if (rc)
                return rc;
        }
    }
    return 0;
}

/* ---------------------------------------------------------- commit */

static uint16_t cavity_flags(const ref_mesher *r)
{
    uint16_t any = 0;
    const dt_cavity *c = &r->cav;
    for (size_t i = 0; i < c->ntets; i++)
        any |= r->m.flags[c->tets[i]];
    return any;
}

/* Inserts p (the pending cavity's point) as a new vertex lying on a
 * feature of the given kind; new tetrahedra inherit the exterior flag and
 * region of the cavity tetrahedron they are built on. */
static int commit_point(ref_mesher *r, uint16_t any, int vkind, uint32_t feat, double rins,
                        uint32_t *vout)
{
    tm_mesh *m = &r->m;
    dt_cavity *c = &r->cav;
    size_t nb = c->nbnd;
    int keep_ext = (any & REF_F_EXTERIOR) != 0, keep_reg = r->region != NULL;
    if (keep_reg && ref_region_room(r))
        return PDR_ENOMEM;
    if (keep_ext || keep_reg) {
        size_t cap = r->cap_b;
        if (pdr_grow((void **)&r->bflag, &cap, nb, sizeof *r->bflag))
            return PDR_ENOMEM;
        cap = r->cap_b;
        if (pdr_grow((void **)&r->breg, &cap, nb, sizeof *r->breg))
            return PDR_ENOMEM;
        r->cap_b = cap;
        for (size_t i = 0; i < nb; i++) {
            uint32_t t = c->bnd[i].tet;
            r->bflag[i] = m->flags[t] & REF_F_EXTERIOR;
            r->breg[i] = keep_reg ? r->region[t] : 0;
        }
    }
    uint32_t v;
    int rc = tm_add_vertex(m, c->p, &v);
    if (!rc)
        rc = bd_vertex_room(&r->bd, m->nv);
    if (!rc)
        rc = dt_cavity_commit(m, v, c);
    if (!rc)
        rc = ref_region_room(r);
    if (rc)
        return rc;
    if (keep_ext || keep_reg)
        for (size_t i = 0; i < nb; i++) {
            uint32_t n = c->newtets[i];
            m->flags[n] |= r->bflag[i];
            if (keep_reg)
                r->region[n] = r->breg[i];
        }
    r->bd.vkind[v] = (uint8_t)vkind;
    r->bd.vfeat[v] = feat;
    r->bd.vrins[v] = (float)rins;
    *vout = v;
    return 0;
}

/* --------------------------------------------- finding new features */

/* Sets the subsegment bit of edge (v, x) in every new tetrahedron around
 * it (they all contain v, so they are all new). Returns 1 if the edge
 * exists. */
static int mark_new_subseg(ref_mesher *r, uint32_t x)
{
    tm_mesh *m = &r->m;
    const dt_cavity *c = &r->cav;
    int found = 0;
    for (size_t i = 0; i < c->nnew; i++) {
        uint32_t n = c->newtets[i];
        const uint32_t *tv = m->tets[n].v;
        int s = tv[0] == x ? 0 : tv[1] == x ? 1 : tv[2] == x ? 2 : -1;
        if (s < 0)
            continue;
        m->flags[n] |= TM_F_SUBSEG(tm_edge_of[s][3]);
        found = 1;
    }
    return found;
}

/* Finds face (v, x, y) among the new tetrahedra: *t and *k (face number)
 * when found (returns 1). */
static int find_new_face(const ref_mesher *r, uint32_t x, uint32_t y, uint32_t *t, int *k)
{
    const tm_mesh *m = &r->m;
    const dt_cavity *c = &r->cav;
    for (size_t i = 0; i < c->nnew; i++) {
        uint32_t n = c->newtets[i];
        const uint32_t *tv = m->tets[n].v;
        int sx = tv[0] == x ? 0 : tv[1] == x ? 1 : tv[2] == x ? 2 : -1;
        if (sx < 0)
            continue;
        int sy = tv[0] == y ? 0 : tv[1] == y ? 1 : tv[2] == y ? 2 : -1;
        if (sy < 0)
            continue;
        *t = n;
        *k = 3 - sx - sy;
        return 1;
    }
    return 0;
}

static int incident(const ref_mesher *r, uint32_t w, uint32_t seg, uint32_t facet);

struct enc_arg {
    const ref_mesher *r;
    uint32_t a, b, seg;
    const double *pa, *pb;
    uint32_t found;
};

static int seg_apex(const tm_mesh *m, uint32_t t, void *arg)
{
    struct enc_arg *e = arg;
    const uint32_t *v = m->tets[t].v;
    for (int s = 0; s < 4; s++) {
        uint32_t w = v[s];
        if (w == TM_VINF || w == e->a || w == e->b)
            continue;
        if (in_diametral(e->pa, e->pb, X(m, w)) && !incident(e->r, w, e->seg, BD_NONE)) {
            e->found = w;
            return 1;
        }
    }
    return 0;
}

/* A vertex of the tetrahedra around subsegment ab (of input segment seg)
 * that encroaches it, other than one on a feature meeting seg, or
 * TM_NONE. */
static uint32_t subseg_encroacher(const ref_mesher *r, uint32_t t, uint32_t a, uint32_t b,
                                  uint32_t seg)
{
    const tm_mesh *m = &r->m;
    struct enc_arg e = {r, a, b, seg, X(m, a), X(m, b), TM_NONE};
    around_edge(m, t, a, b, seg_apex, &e);
    return e.found;
}

/* 1 if vertex v lies on facet f by construction (on it, on one of its
 * segments, or one of its corners): such a vertex never encroaches f's
 * subfacets, the facet triangulation accounts for it. */
static int on_facet(const ref_mesher *r, uint32_t v, uint32_t f)
{
    const plc *p = r->p;
    uint32_t x = r->bd.vfeat[v];
    switch (r->bd.vkind[v]) {
    case BD_V_FACET:
        return x == f;
    case BD_V_SEGMENT:
        for (size_t i = p->seg_fstart[x]; i < p->seg_fstart[x + 1]; i++)
            if (p->seg_facets[i] == f)
                return 1;
        return 0;
    case BD_V_INPUT:
        for (size_t i = p->v_fstart[x]; i < p->v_fstart[x + 1]; i++)
            if (p->v_facets[i] == f)
                return 1;
        return 0;
    default:
        return 0;
    }
}

static int facet_has_vertex(const plc *p, uint32_t f, uint32_t v)
{
    for (size_t i = p->v_fstart[v]; i < p->v_fstart[v + 1]; i++)
        if (p->v_facets[i] == f)
            return 1;
    return 0;
}

/* 1 if vertex w lies on an input feature that meets the feature of a
 * piece (segment seg when facet is BD_NONE, else facet 'facet'), without
 * one containing the other. */
static int meets(const ref_mesher *r, uint32_t w, uint32_t seg, uint32_t facet)
{
    const plc *p = r->p;
    uint32_t x = r->bd.vfeat[w];
    switch (r->bd.vkind[w]) {
    case BD_V_SEGMENT: {
        const uint32_t *e = p->segs[x].v;
        if (facet == BD_NONE) {
            const uint32_t *s = p->segs[seg].v;
            return x != seg && (e[0] == s[0] || e[0] == s[1] || e[1] == s[0] || e[1] == s[1]);
        }
        return facet_has_vertex(p, facet, e[0]) || facet_has_vertex(p, facet, e[1]);
    }
    case BD_V_FACET: {
        if (facet == BD_NONE)
            for (size_t i = p->seg_fstart[seg]; i < p->seg_fstart[seg + 1]; i++)
                if (p->seg_facets[i] == x)
                    return 0; /* seg is an edge of w's facet */
        const plc_facet *F = &p->facets[x];
        for (size_t q = F->poly_first; q < F->poly_first + F->npoly; q++) {
            const plc_polygon *P = &p->polys[q];
            for (uint32_t i = 0; i < P->n; i++) {
                uint32_t c = p->corners[P->first + i];
                if (facet == BD_NONE ? (c == p->segs[seg].v[0] || c == p->segs[seg].v[1])
                                     : facet_has_vertex(p, facet, c))
                    return 1;
            }
        }
        return 0;
    }
    default:
        return 0;
    }
}

/* 1 if point w projects orthogonally into the interior of facet f (or of
 * segment seg when f is BD_NONE), with a relative margin. */
static int projects_inside(const ref_mesher *r, const double *w, uint32_t seg, uint32_t f)
{
    const plc *p = r->p;
    if (f == BD_NONE) {
        const double *a = p->xyz[p->segs[seg].v[0]], *b = p->xyz[p->segs[seg].v[1]];
        double ab[3], aw[3];
        v3_sub(b, a, ab);
        v3_sub(w, a, aw);
        double t = v3_dot(aw, ab) / v3_dot(ab, ab);
        return t > 1e-9 && t < 1 - 1e-9;
    }
    const plc_facet *F = &p->facets[f];
    double h = v3_dot(F->normal, w) - F->offset, q[3];
    for (int k = 0; k < 3; k++)
        q[k] = w[k] - h * F->normal[k];
    int i = (F->axis + 1) % 3, j = (F->axis + 2) % 3;
    for (size_t t = p->ftri_start[f]; t < p->ftri_start[f + 1]; t++) {
        const double *a = p->xyz[p->ftri[t][0]], *b = p->xyz[p->ftri[t][1]],
                     *c = p->xyz[p->ftri[t][2]];
        double d = (b[i] - a[i]) * (c[j] - a[j]) - (b[j] - a[j]) * (c[i] - a[i]);
        if (d == 0)
            continue;
        double l1 = ((q[i] - a[i]) * (c[j] - a[j]) - (q[j] - a[j]) * (c[i] - a[i])) / d;
        double l2 = ((b[i] - a[i]) * (q[j] - a[j]) - (b[j] - a[j]) * (q[i] - a[i])) / d;
        if (l1 > 1e-9 && l2 > 1e-9 && 1 - l1 - l2 > 1e-9)
            return 1;
    }
    return 0;
}

/* 1 if vertex w lies on an input feature that meets the feature of a piece
 * (segment seg when facet is BD_NONE, else facet 'facet') at an acute
 * angle: the two meet, and w's orthogonal projection onto the piece's
 * feature falls inside it. That is Shewchuk's projection condition, broken
 * locally. There encroachment is not split eagerly: the two features would
 * split each other down to where they meet (the tee's 60-degree edges
 * did); the bad tetrahedra there ask for the splits they need, under the
 * insertion-radius floor of split_tet. Where features meet at 90 degrees
 * or more (a cube's edges, the creases of a curved surface made of flat
 * facets) the projection falls outside, and encroachment is split as
 * usual. */
static int incident(const ref_mesher *r, uint32_t w, uint32_t seg, uint32_t facet)
{
    return meets(r, w, seg, facet) && projects_inside(r, X(&r->m, w), seg, facet);
}

/* The apex of face k of t or of the tetrahedron across it that encroaches
 * that face (a subfacet of facet f), or TM_NONE. */
static uint32_t subfac_encroacher(const ref_mesher *r, uint32_t t, int k, uint32_t f)
{
    const tm_mesh *m = &r->m;
    const tm_tet *T = &m->tets[t];
    const double *a = X(m, T->v[tm_face_vtx[k][0]]), *b = X(m, T->v[tm_face_vtx[k][1]]),
                 *c = X(m, T->v[tm_face_vtx[k][2]]);
    uint32_t w = T->v[k];
    if (w != TM_VINF && !on_facet(r, w, f) && !incident(r, w, BD_NONE, f) &&
        in_equatorial(a, b, c, X(m, w)))
        return w;
    tm_link l = T->n[k];
    if (tm_is_special(l))
        return TM_NONE;
    w = m->tets[tm_ltet(l)].v[tm_lface(l)];
    if (w != TM_VINF && !on_facet(r, w, f) && !incident(r, w, BD_NONE, f) &&
        in_equatorial(a, b, c, X(m, w)))
        return w;
    return TM_NONE;
}

static double subseg_len2(const ref_mesher *r, uint32_t id)
{
    const bd_subseg *s = &r->bd.segs[id];
    return v3_dist2(X(&r->m, s->v[0]), X(&r->m, s->v[1]));
}

static double subfac_rad2(const ref_mesher *r, uint32_t id)
{
    const bd_subfac *s = &r->bd.facs[id];
    double cc[3], r2;
    if (tri_circumcentre(X(&r->m, s->v[0]), X(&r->m, s->v[1]), X(&r->m, s->v[2]), cc, &r2))
        return 0.0;
    return r2;
}

/* After a subsegment became present in tetrahedron t: queue it if a
 * vertex encroaches it or it is too long. */
static int check_subseg(ref_mesher *r, uint32_t id, uint32_t t)
{
    const bd_subseg *s = &r->bd.segs[id];
    if (r->o.seg_maxlen > 0 && subseg_len2(r, id) >= r->o.seg_maxlen * r->o.seg_maxlen)
        return queue_seg(r, id, 0.0f);
    uint32_t w = subseg_encroacher(r, t, s->v[0], s->v[1], s->seg);
    if (w != TM_NONE)
        return queue_seg(r, id, (float)(r->o.rho * r->bd.vrins[w]));
    return 0;
}

static int check_subfac(ref_mesher *r, uint32_t id, uint32_t t, int k)
{
    if (r->o.fac_maxrad > 0 && subfac_rad2(r, id) >= r->o.fac_maxrad * r->o.fac_maxrad)
        return queue_fac(r, id, 0.0f);
    uint32_t w = subfac_encroacher(r, t, k, r->bd.facs[id].facet);
    if (w != TM_NONE)
        return queue_fac(r, id, (float)(r->o.rho * r->bd.vrins[w]));
    return 0;
}

/* --------------------------------------------------------- 2D cavity */

/* Whether live subfacet u of the facet triangulation belongs to the 2D
 * cavity of p. A present subfacet does iff the 3D cavity deletes it (both
 * its tetrahedra conflict with p): for p in its plane that is exactly "p in
 * its circumcircle", and deciding it from the 3D cavity keeps D and T
 * consistent on cocircular points. A missing one is tested directly with
 * the perturbed in-circle test that agrees with the 3D predicates. */
static int in_cavity2d(const ref_mesher *r, uint32_t u, const double *p)
{
    const bd_subfac *U = &r->bd.facs[u];
    if (!(U->flags & BD_F_MISSING)) {
        for (size_t k = 0; k < r->marks.n; k++) {
            const ref_mark *mk = &r->marks.m[k];
            if (mk->nv != 3 || !mk->deleted || (uint32_t)mk->facet != U->facet)
                continue;
            int hit = 0;
            for (int i = 0; i < 3; i++)
                hit += mk->v[i] == U->v[0] || mk->v[i] == U->v[1] || mk->v[i] == U->v[2];
            if (hit == 3)
                return 1;
        }
        return 0;
    }
    const tm_mesh *m = &r->m;
    return pred_incircle3d_sos(X(m, U->v[0]), X(m, U->v[1]), X(m, U->v[2]), p) > 0;
}

static int list_add(ref_mesher *r, uint32_t s)
{
    if (pdr_grow((void **)&r->list, &r->cap_list, r->nlist + 1, sizeof *r->list))
        return PDR_ENOMEM;
    r->list[r->nlist++] = s;
    r->bd.facs[s].flags |= BD_F_VISIT;
    return 0;
}

static void list_clear(ref_mesher *r)
{
    for (size_t i = 0; i < r->nlist; i++)
        r->bd.facs[r->list[i]].flags &= (uint16_t)~BD_F_VISIT;
    r->nlist = 0;
    r->nbedge = 0;
}

static int is_split_edge(uint32_t x, uint32_t y, uint32_t sa, uint32_t sb)
{
    return (x == sa && y == sb) || (x == sb && y == sa);
}

/* Grows the 2D cavity of p from the subfacets in r->list (the roots) over
 * neighbours in the same facet, never across a subsegment (the facet
 * triangulations are constrained by them), and collects its boundary
 * edges, skipping the subsegment sa-sb being split. Returns 0 when every
 * boundary edge sees p on its inner side (the fan from p is a valid
 * triangulation), 1 when p lies beyond a boundary subsegment (*ea, *eb: p
 * encroaches it), PDR_ENOMEM, or 2 if no star-shaped cavity was found. */
static int grow_cavity2d(ref_mesher *r, const double *p, uint32_t sa, uint32_t sb, uint32_t *ea,
                         uint32_t *eb)
{
    const tm_mesh *m = &r->m;
    bd_set *bd = &r->bd;
    size_t scan = 0;
    r->forced = 0;
    for (int round = 0; round < 64; round++) {
        for (; scan < r->nlist; scan++) {
            uint32_t t = r->list[scan];
            for (int k = 0; k < 3; k++) {
                const bd_subfac *T = &bd->facs[t];
                uint32_t x = T->v[(k + 1) % 3], y = T->v[(k + 2) % 3];
                if (is_split_edge(x, y, sa, sb) || bd_find_subseg(bd, x, y) != BD_NONE)
                    continue;
                uint32_t u = bd_subfac_across(bd, t, k);
                if (u == BD_NONE || (bd->facs[u].flags & BD_F_VISIT))
                    continue;
                if (in_cavity2d(r, u, p) && list_add(r, u))
                    return PDR_ENOMEM;
            }
        }
        /* boundary edges and the star test */
        r->nbedge = 0;
        int grew = 0;
        for (size_t i = 0; i < r->nlist; i++) {
            uint32_t t = r->list[i];
            for (int k = 0; k < 3; k++) {
                const bd_subfac *T = &bd->facs[t];
                uint32_t x = T->v[(k + 1) % 3], y = T->v[(k + 2) % 3];
                if (is_split_edge(x, y, sa, sb))
                    continue;
                int seg = bd_find_subseg(bd, x, y) != BD_NONE;
                uint32_t u = seg ? BD_NONE : bd_subfac_across(bd, t, k);
                if (u != BD_NONE && (bd->facs[u].flags & BD_F_VISIT))
                    continue;
                if (orient_facet(r->p, T->facet, X(m, x), X(m, y), p) <= 0) {
                    if (seg || u == BD_NONE) {
                        *ea = x;
                        *eb = y;
                        return 1;
                    }
                    if (list_add(r, u))
                        return PDR_ENOMEM;
                    r->forced = 1;
                    grew = 1;
                    continue;
                }
                if (pdr_grow((void **)&r->bedge, &r->cap_bedge, r->nbedge + 1, sizeof *r->bedge))
                    return PDR_ENOMEM;
                uint32_t *e = r->bedge[r->nbedge++];
                e[0] = x;
                e[1] = y;
                e[2] = T->facet;
                e[3] = t;
            }
        }
        if (!grew)
            return 0;
    }
    return 2;
}

struct root_arg {
    ref_mesher *r;
    int rc;
};

static int add_root(void *arg, uint32_t s)
{
    struct root_arg *a = arg;
    if (a->r->bd.facs[s].flags & BD_F_VISIT)
        return 0;
    if (list_add(a->r, s)) {
        a->rc = PDR_ENOMEM;
        return 1;
    }
    return 0;
}

/* ------------------------------------------------ boundary updates */

/* The general search for a face of the mesh: tetrahedra around vertex a
 * (a breadth-first walk over the faces containing a) until one has b and
 * c too (c == TM_NONE: edge ab). Slow, used where no cavity tells where
 * to look (the initial mesh, rare repairs). */
static int find_in_star4(const tm_mesh *m, uint32_t a, uint32_t b, uint32_t c, uint32_t d,
                         uint32_t *tout)
{
    uint32_t start = m->vhint[a];
    if (start == TM_NONE)
        return 0;
    uint32_t stackbuf[256], *stack = stackbuf;
    size_t n = 0, cap = 256, head = 0;
    int found = 0;
    stack[n++] = start;
    while (head < n && !found) {
        uint32_t t = stack[head++];
        const tm_tet *T = &m->tets[t];
        int sa = slot_in(T, a);
        if (slot_in(T, b) >= 0 && (c == TM_NONE || slot_in(T, c) >= 0) &&
            (d == TM_NONE || slot_in(T, d) >= 0)) {
            *tout = t;
            found = 1;
            break;
        }
        for (int k = 0; k < 4; k++) {
            if (k == sa || tm_is_special(T->n[k]))
                continue;
            uint32_t u = tm_ltet(T->n[k]);
            int seen = 0;
            for (size_t i = 0; i < n && !seen; i++)
                seen = stack[i] == u;
            if (seen)
                continue;
            if (n == cap) {
                uint32_t *ns = malloc(2 * cap * sizeof *ns);
                if (!ns)
                    break;
                memcpy(ns, stack, n * sizeof *ns);
                if (stack != stackbuf)
                    free(stack);
                stack = ns;
                cap *= 2;
            }
            stack[n++] = u;
        }
    }
    if (stack != stackbuf)
        free(stack);
    return found;
}

static int find_in_star(const tm_mesh *m, uint32_t a, uint32_t b, uint32_t c, uint32_t *tout)
{
    return find_in_star4(m, a, b, c, TM_NONE, tout);
}

static int set_subseg_bit(const tm_mesh *m, uint32_t t, void *arg)
{
    const uint32_t *ab = arg;
    const tm_tet *T = &m->tets[t];
    int sa = slot_in(T, ab[0]), sb = slot_in(T, ab[1]);
    ((tm_mesh *)m)->flags[t] |= TM_F_SUBSEG(tm_edge_of[sa][sb]);
    return 0;
}

/* Marks existing subsegment id in the mesh if its edge exists; else flags
 * it missing. Returns 1 if present, 0 if missing, <0 on error. */
static int attach_subseg(ref_mesher *r, uint32_t id)
{
    bd_subseg *s = &r->bd.segs[id];
    uint32_t t;
    if (!find_in_star(&r->m, s->v[0], s->v[1], TM_NONE, &t)) {
        s->flags |= BD_F_MISSING;
        return 0;
    }
    s->flags &= (uint16_t)~BD_F_MISSING;
    uint32_t ab[2] = {s->v[0], s->v[1]};
    around_edge(&r->m, t, ab[0], ab[1], set_subseg_bit, ab);
    int rc = check_subseg(r, id, t);
    return rc < 0 ? rc : 1;
}

static int attach_subfac(ref_mesher *r, uint32_t id)
{
    bd_subfac *s = &r->bd.facs[id];
    uint32_t t;
    if (!find_in_star(&r->m, s->v[0], s->v[1], s->v[2], &t)) {
        s->flags |= BD_F_MISSING;
        return 0;
    }
    s->flags &= (uint16_t)~BD_F_MISSING;
    const tm_tet *T = &r->m.tets[t];
    int k = 6 - slot_in(T, s->v[0]) - slot_in(T, s->v[1]) - slot_in(T, s->v[2]);
    tm_mark_face(&r->m, t, k, (int32_t)s->facet + 1);
    int rc = check_subfac(r, id, t, k);
    return rc < 0 ? rc : 1;
}

/* Matches the facet triangulation to the mesh where the two differ by the
 * diagonal of a (nearly) cocircular quadrilateral. On facets that are not
 * axis-aligned the vertices are off the plane by rounding errors, and the
 * mesh, deciding with exact predicates, may take the other diagonal of a
 * quadrilateral whose corners are cocircular up to those errors. Shewchuk:
 * "an implementation must detect these cases and correct the triangulation
 * so that it matches the tetrahedralization". A missing subfacet whose
 * neighbour across an edge, flipped to the other diagonal, gives two faces
 * of the mesh is replaced by them; subfacets still missing afterwards are
 * queued for splitting. ids (n entries) is scratch owned by the caller. */
static int repair_and_queue(ref_mesher *r, uint32_t *ids, size_t n)
{
    bd_set *bd = &r->bd;
    tm_mesh *m = &r->m;
    int changed = 1, rc = 0;
    for (int round = 0; changed && round < 8 && !rc; round++) {
        changed = 0;
        for (size_t i = 0; i < n && !rc; i++) {
            uint32_t t = ids[i];
            if (t == BD_NONE)
                continue;
            bd_subfac T = bd->facs[t];
            if ((T.flags & BD_F_DEAD) || !(T.flags & BD_F_MISSING)) {
                ids[i] = BD_NONE;
                continue;
            }
            for (int k = 0; k < 3; k++) {
                uint32_t a = T.v[(k + 1) % 3], b = T.v[(k + 2) % 3], c = T.v[k];
                if (bd_find_subseg(bd, a, b) != BD_NONE)
                    continue;
                uint32_t u = bd_subfac_across(bd, t, k);
                if (u == BD_NONE)
                    continue;
                bd_subfac U = bd->facs[u];
                uint32_t w = U.v[0] != a && U.v[0] != b ? U.v[0] : U.v[1] != a && U.v[1] != b ? U.v[1] : U.v[2];
                uint32_t f = T.facet, t1, t2;
                if (orient_facet(r->p, f, X(m, a), X(m, w), X(m, c)) <= 0 ||
                    orient_facet(r->p, f, X(m, w), X(m, b), X(m, c)) <= 0 ||
                    !find_in_star(m, a, w, c, &t1) || !find_in_star(m, w, b, c, &t2))
                    continue;
                if (!(U.flags & BD_F_MISSING) && find_in_star(m, U.v[0], U.v[1], U.v[2], &t1)) {
                    const tm_tet *Q = &m->tets[t1];
                    int q = 6 - slot_in(Q, U.v[0]) - slot_in(Q, U.v[1]) - slot_in(Q, U.v[2]);
                    tm_mark_face(m, t1, q, 0);
                }
                bd_kill_subfac(bd, t);
                bd_kill_subfac(bd, u);
                uint32_t n1, n2;
                rc = bd_add_subfac(bd, a, w, c, f, &n1);
                if (!rc)
                    rc = bd_add_subfac(bd, w, b, c, f, &n2);
                if (!rc && (rc = attach_subfac(r, n1)) > 0)
                    rc = attach_subfac(r, n2);
                if (rc > 0)
                    rc = 0;
                ids[i] = BD_NONE;
                changed = 1;
                r->flips++;
                if (r->classified)
                    r->region_doubts++;
                break;
            }
        }
    }
    for (size_t i = 0; i < n && !rc; i++) {
        uint32_t t = ids[i];
        if (t != BD_NONE && !(bd->facs[t].flags & BD_F_DEAD) &&
            (bd->facs[t].flags & BD_F_MISSING))
            rc = queue_fac(r, t, 0.0f);
    }
    return rc;
}

/* Gives tetrahedron dst the region (and exterior flag) of src. */
static void copy_region(ref_mesher *r, uint32_t dst, uint32_t src)
{
    tm_mesh *m = &r->m;
    if ((m->flags[src] & REF_F_EXTERIOR) || tm_is_ghost(m, src))
        m->flags[dst] |= REF_F_EXTERIOR;
    else
        m->flags[dst] &= (uint16_t)~REF_F_EXTERIOR;
    if (r->region)
        r->region[dst] = r->region[src];
}

/* Regions of the new tetrahedra of a boundary insertion, once their
 * subfacets are marked. commit_point gave each the region of the cavity
 * tetrahedron it was built on: both lie on the same side of that face,
 * next to it, which is the right region wherever "the same side of a
 * face" means "the same side of the facet". A tetrahedron lying flat on a
 * facet that is not axis-aligned (four vertices cocircular up to rounding)
 * has no such side: it takes the region of a neighbour across an
 * unmarked face, to which it is joined without crossing a facet. (Spreading
 * regions across unmarked faces in general would be wrong while a subfacet
 * is missing: the faces where it should be are not marked yet.) */
static int reclassify_new(ref_mesher *r)
{
    tm_mesh *m = &r->m;
    const dt_cavity *c = &r->cav;
    for (size_t i = 0; i < c->nnew; i++) {
        uint32_t n = c->newtets[i];
        if (tm_is_ghost(m, n) || !flat_on_facet(r, m->tets[n].v))
            continue;
        r->region_doubts++;
        for (int k = 0; k < 4; k++) {
            tm_link l = m->tets[n].n[k];
            if ((m->flags[n] & TM_F_FACEMARK(k)) || tm_is_special(l))
                continue;
            copy_region(r, n, tm_ltet(l));
            break;
        }
    }
    return 0;
}

/* After committing vertex v for a boundary split: replaces the 2D cavity
 * (r->list) by the fan of v over its boundary edges (r->bedge), replaces
 * subsegment split_id (if not BD_NONE) by its two halves, attaches the new
 * pieces to the mesh, and queues what the insertion made missing or
 * encroached. */
static int update_boundary(ref_mesher *r, uint32_t v, uint32_t split_id)
{
    tm_mesh *m = &r->m;
    bd_set *bd = &r->bd;
    int rc = 0;
    float rv = bd->vrins[v];
    /* Subfacets the 2D cavity took although the 3D cavity kept their
     * face (only when the star test forced them in): unmark the face. */
    if (r->forced)
        for (size_t i = 0; i < r->nlist; i++) {
            const bd_subfac *s = &bd->facs[r->list[i]];
            uint32_t t;
            if (!(s->flags & BD_F_MISSING) && find_in_star(m, s->v[0], s->v[1], s->v[2], &t)) {
                const tm_tet *T = &m->tets[t];
                int k = 6 - slot_in(T, s->v[0]) - slot_in(T, s->v[1]) - slot_in(T, s->v[2]);
                tm_mark_face(m, t, k, 0);
            }
        }
    for (size_t i = 0; i < r->nlist; i++)
        bd_kill_subfac(bd, r->list[i]);
    r->nlist = 0;
    if (split_id != BD_NONE) {
        bd_subseg s = bd->segs[split_id];
        bd_kill_subseg(bd, split_id);
        for (int h = 0; h < 2 && !rc; h++) {
            uint32_t id;
            rc = bd_add_subseg(bd, s.v[h], v, s.seg, &id);
            if (rc)
                break;
            if (mark_new_subseg(r, s.v[h])) {
                uint32_t t = TM_NONE; /* a new tetrahedron with the edge */
                for (size_t i = 0; i < r->cav.nnew && t == TM_NONE; i++)
                    if (slot_in(&m->tets[r->cav.newtets[i]], s.v[h]) >= 0)
                        t = r->cav.newtets[i];
                rc = check_subseg(r, id, t);
            } else {
                bd->segs[id].flags |= BD_F_MISSING;
                rc = queue_seg(r, id, 0.0f);
            }
        }
    }
    for (size_t i = 0; i < r->nbedge && !rc; i++) {
        const uint32_t *e = r->bedge[i];
        uint32_t id;
        rc = bd_add_subfac(bd, e[0], e[1], v, e[2], &id);
        if (rc)
            break;
        uint32_t t;
        int k;
        if (find_new_face(r, e[0], e[1], &t, &k)) {
            tm_mark_face(m, t, k, (int32_t)e[2] + 1);
            rc = check_subfac(r, id, t, k);
        } else {
            bd->facs[id].flags |= BD_F_MISSING;
            rc = pdr_grow((void **)&r->miss, &r->cap_miss, r->nmiss + 1, sizeof *r->miss);
            if (!rc)
                r->miss[r->nmiss++] = id;
        }
    }
    r->nbedge = 0;
    if (!rc && r->nmiss)
        rc = repair_and_queue(r, r->miss, r->nmiss);
    r->nmiss = 0;
    /* Pieces the cavity deleted are missing now; pieces it touched that
     * v encroaches are queued. */
    for (size_t k = 0; k < r->marks.n && !rc; k++) {
        const ref_mark *mk = &r->marks.m[k];
        if (!mk->deleted && !mk->encroached)
            continue;
        if (mk->nv == 2) {
            uint32_t id = bd_find_subseg(bd, mk->v[0], mk->v[1]);
            if (id == BD_NONE)
                continue;
            if (mk->deleted) {
                bd->segs[id].flags |= BD_F_MISSING;
                rc = queue_seg(r, id, 0.0f);
            } else if (!incident(r, v, bd->segs[id].seg, BD_NONE)) {
                rc = queue_seg(r, id, (float)(r->o.rho * rv));
            }
        } else {
            uint32_t id = bd_find_subfac(bd, mk->v[0], mk->v[1], mk->v[2]);
            if (id == BD_NONE)
                continue;
            if (mk->deleted) {
                bd->facs[id].flags |= BD_F_MISSING;
                rc = queue_fac(r, id, 0.0f);
            } else if (!on_facet(r, v, (uint32_t)mk->facet) &&
                       !incident(r, v, BD_NONE, (uint32_t)mk->facet)) {
                rc = queue_fac(r, id, (float)(r->o.rho * rv));
            }
        }
    }
    if (!rc && r->classified)
        rc = reclassify_new(r);
    return rc;
}

/* ------------------------------------------------------------- splits */

enum { SPLIT_DONE = 0, SPLIT_DEFERRED = 1, SPLIT_REFUSED = 2 };

/* Slivers (small dihedral angles, good radius-edge ratio) are split only
 * when their circumradius is at least this times their shortest edge. */
#ifndef SLIVER_RHO
#define SLIVER_RHO 0.7
#endif

/* The point splitting subsegment ab: its midpoint, or, when exactly one
 * end is an input vertex where segments meet at an acute angle, the point
 * at a power-of-two distance from it nearest to the midpoint (Ruppert's
 * concentric shells: splits from both sides of an acute corner then meet
 * on common spheres and do not cascade). */
void ref__split_point(const ref_mesher *r, uint32_t a, uint32_t b, double p[3])
{
    const tm_mesh *m = &r->m;
    const double *pa = X(m, a), *pb = X(m, b);
    int ia = r->bd.vkind[a] == BD_V_INPUT && r->seg_acute && r->seg_acute[r->bd.vfeat[a]];
    int ib = r->bd.vkind[b] == BD_V_INPUT && r->seg_acute && r->seg_acute[r->bd.vfeat[b]];
    if (ia != ib) {
        const double *o = ia ? pa : pb, *e = ia ? pb : pa;
        double len = sqrt(v3_dist2(pa, pb));
        int ex;
        double f = frexp(len / 2.0, &ex); /* len/2 = f 2^ex, f in [0.5, 1) */
        double d = f < M_SQRT1_2 ? ldexp(1.0, ex - 1) : ldexp(1.0, ex);
        double t = d / len;
        if (t > 0.2 && t < 0.8) {
            for (int k = 0; k < 3; k++)
                p[k] = o[k] + t * (e[k] - o[k]);
            return;
        }
    }
    for (int k = 0; k < 3; k++)
        p[k] = 0.5 * (pa[k] + pb[k]);
}

/* The insertion radius of the pending cavity's point: its distance to the
 * nearest vertex it will be joined to (every vertex of the cavity
 * boundary), which is the length of the shortest edge at it once
 * inserted. */
static double insertion_radius(const ref_mesher *r)
{
    const tm_mesh *m = &r->m;
    const dt_cavity *c = &r->cav;
    double best = INFINITY;
    for (size_t i = 0; i < c->nbnd; i++) {
        const tm_tet *T = &m->tets[c->bnd[i].tet];
        const uint8_t *f = tm_face_vtx[c->bnd[i].face];
        for (int k = 0; k < 3; k++) {
            uint32_t v = T->v[f[k]];
            if (v != TM_VINF)
                best = fmin(best, v3_dist2(c->p, X(m, v)));
        }
    }
    return sqrt(best);
}

/* Splits subsegment id. A split of a present subsegment is refused
 * (SPLIT_REFUSED, the subsegment flagged TOLERATED) when the new vertex
 * would be nearer than rmin to an existing one: rmin is how the
 * refinement keeps splits caused by nearby features or bad tetrahedra
 * from cascading (see ref_opts.rho and split_tet). A missing subsegment is
 * always split: the mesh must conform. */
static int split_subseg(ref_mesher *r, uint32_t id, double rmin, int *result)
{
    tm_mesh *m = &r->m;
    bd_subseg S = r->bd.segs[id];
    *result = SPLIT_REFUSED;
    int missing = (S.flags & BD_F_MISSING) != 0;
    double p[3];
    ref__split_point(r, S.v[0], S.v[1], p);
    int rc = dt_cavity_search(m, p, m->vhint[S.v[0]], DT_LOCATE, &r->cav);
    if (rc)
        return rc;
    if (r->cav.status != DT_OK) {
        dt_cavity_abandon(m, &r->cav);
        r->bd.segs[id].flags |= BD_F_TOLERATED;
        r->st.tolerated++;
        return 0;
    }
    double rins = insertion_radius(r);
    if (!missing && rins < rmin) {
        dt_cavity_abandon(m, &r->cav);
        r->bd.segs[id].flags |= BD_F_TOLERATED;
        r->st.tolerated++;
        return 0;
    }
    uint16_t any = cavity_flags(r);
    rc = ref_gather_marks(m, &r->cav, &r->marks);
    ref_decision d;
    if (!rc)
        ref_decide(r->p, p, REF_SUBSEG, &r->marks, &d);
    struct root_arg ra = {r, 0};
    list_clear(r);
    if (!rc) {
        bd_subfacs_on_edge(&r->bd, S.v[0], S.v[1], add_root, &ra);
        rc = ra.rc;
    }
    uint32_t ea, eb;
    int g = rc ? rc : grow_cavity2d(r, p, S.v[0], S.v[1], &ea, &eb);
    if (g < 0) {
        list_clear(r);
        dt_cavity_abandon(m, &r->cav);
        return g;
    }
    if (g > 0)
        r->anomalies++; /* not expected for a point on the segment */
    uint32_t v;
    r->last_op = "subsegment point";
    rc = commit_point(r, any, BD_V_SEGMENT, S.seg, rins, &v);
    if (rc) {
        list_clear(r);
        dt_cavity_abandon(m, &r->cav);
        return rc;
    }
    rc = update_boundary(r, v, id);
    if (!rc)
        rc = queue_new_tets(r);
    r->st.seg_points++;
    if (missing)
        r->st.missing_recovered++;
    *result = SPLIT_DONE;
    return rc;
}

/* Splits, at once, the subsegments flagged encroached in r->marks, each
 * with the floor rmin; *done counts those split. */
static int split_encroached_subsegs(ref_mesher *r, double rmin, size_t *done)
{
    *done = 0;
    uint32_t ids[64];
    size_t n = 0;
    for (size_t k = 0; k < r->marks.n && n < 64; k++) {
        const ref_mark *mk = &r->marks.m[k];
        if (mk->nv != 2 || !mk->encroached)
            continue;
        uint32_t id = bd_find_subseg(&r->bd, mk->v[0], mk->v[1]);
        if (id != BD_NONE)
            ids[n++] = id;
    }
    for (size_t i = 0; i < n; i++) {
        if (r->bd.segs[ids[i]].flags & BD_F_DEAD)
            continue;
        int res, rc = split_subseg(r, ids[i], rmin, &res);
        if (rc)
            return rc;
        if (res == SPLIT_DONE)
            (*done)++;
    }
    return 0;
}

/* Splits subfacet id at its circumcentre; when that point encroaches
 * subsegments, splits them instead (SPLIT_DEFERRED: the subfacet is still
 * there). rmin as for split_subseg; SPLIT_REFUSED when nothing was
 * inserted. */
static int split_subfac(ref_mesher *r, uint32_t id, double rmin, int *result)
{
    tm_mesh *m = &r->m;
    bd_subfac G = r->bd.facs[id];
    *result = SPLIT_REFUSED;
    int missing = (G.flags & BD_F_MISSING) != 0;
    if (missing)
        rmin = 0;
    double c[3], r2;
    if (tri_circumcentre(X(m, G.v[0]), X(m, G.v[1]), X(m, G.v[2]), c, &r2)) {
        r->bd.facs[id].flags |= BD_F_TOLERATED;
        return 0;
    }
    int rc = dt_cavity_search(m, c, m->vhint[G.v[0]], DT_LOCATE, &r->cav);
    if (rc)
        return rc;
    if (r->cav.status != DT_OK) {
        dt_cavity_abandon(m, &r->cav);
        r->bd.facs[id].flags |= BD_F_TOLERATED;
        r->st.tolerated++;
        return 0;
    }
    uint16_t any = cavity_flags(r);
    rc = ref_gather_marks(m, &r->cav, &r->marks);
    if (rc) {
        dt_cavity_abandon(m, &r->cav);
        return rc;
    }
    ref_decision d;
    ref_decide(r->p, c, REF_SUBFACET, &r->marks, &d);
    if (d.action == REF_SPLIT_SUBSEGS) {
        dt_cavity_abandon(m, &r->cav);
        size_t done;
        rc = split_encroached_subsegs(r, rmin, &done);
        *result = done ? SPLIT_DEFERRED : SPLIT_REFUSED;
        if (!done)
            r->bd.facs[id].flags |= BD_F_TOLERATED;
        return rc;
    }
    list_clear(r);
    rc = list_add(r, id);
    uint32_t ea = 0, eb = 0;
    int g = rc ? rc : grow_cavity2d(r, c, BD_NONE, BD_NONE, &ea, &eb);
    if (g != 0) {
        list_clear(r);
        dt_cavity_abandon(m, &r->cav);
        if (g < 0)
            return g;
        uint32_t sid = g == 1 ? bd_find_subseg(&r->bd, ea, eb) : BD_NONE;
        if (sid == BD_NONE) {
            r->anomalies++;
            r->bd.facs[id].flags |= BD_F_TOLERATED;
            return 0;
        }
        /* c lies beyond subsegment ea-eb of the facet: it encroaches it */
        int res;
        rc = split_subseg(r, sid, rmin, &res);
        *result = res == SPLIT_DONE ? SPLIT_DEFERRED : SPLIT_REFUSED;
        return rc;
    }
    double rins = insertion_radius(r);
    if (!missing && rins < rmin) {
        list_clear(r);
        dt_cavity_abandon(m, &r->cav);
        r->bd.facs[id].flags |= BD_F_TOLERATED;
        r->st.tolerated++;
        return 0;
    }
    uint32_t v;
    r->last_op = r->forced ? "subfacet point (forced 2D cavity)" : "subfacet point";
    rc = commit_point(r, any, BD_V_FACET, G.facet, rins, &v);
    if (rc) {
        list_clear(r);
        dt_cavity_abandon(m, &r->cav);
        return rc;
    }
    rc = update_boundary(r, v, BD_NONE);
    if (!rc)
        rc = queue_new_tets(r);
    r->st.fac_points++;
    if (missing)
        r->st.missing_recovered++;
    *result = SPLIT_DONE;
    return rc;
}

static void give_up(ref_mesher *r, uint32_t t, int degenerate)
{
    r->m.flags[t] |= REF_F_GIVEUP | (degenerate ? REF_F_DEGENERATE : 0);
    r->st.gave_up++;
    if (degenerate)
        r->st.degenerate++;
}

/* Refine(t) for a bad tetrahedron: its circumcentre, or the split of the
 * subsegments or the subfacet that circumcentre encroaches. Those splits
 * must not put a vertex nearer to another than t's shortest edge (on an
 * input that meets Shewchuk's conditions they never do: the new vertex is
 * at least r/sqrt(2) >= B l/sqrt(2) from every vertex, r the circumradius,
 * l the shortest edge); where they would, near a boundary piece left
 * encroached at an acute input angle, t is left as it is and counted. That
 * floor is what makes the refinement terminate on any input: apart from
 * the recovery of missing pieces, no vertex is inserted nearer to another
 * than the shortest edge already in the mesh. */
static int split_tet(ref_mesher *r, uint32_t t)
{
    tm_mesh *m = &r->m;
    double cc[3], q2;
    int why = tet_bad(r, t, cc, &q2);
    if (!why)
        return 0;
    if (why == 2 && q2 < SLIVER_RHO * SLIVER_RHO) {
        /* A sliver whose circumradius is small against its shortest edge:
         * its circumcentre would crowd its vertices, and splitting such
         * slivers is what could cascade; they are rare and left. */
        give_up(r, t, 0);
        r->st.slivers_left++;
        return 0;
    }
    if (why == 3) {
        /* Flat on a facet: its circumcentre is ill-conditioned, and what
         * removes it is the split of the subfacet it lies on. */
        int rc = 0, outcome = SPLIT_REFUSED;
        for (int k = 0; k < 4 && outcome == SPLIT_REFUSED && !rc; k++) {
            if (!(m->flags[t] & TM_F_FACEMARK(k)))
                continue;
            const uint32_t *tv = m->tets[t].v;
            uint32_t g = bd_find_subfac(&r->bd, tv[tm_face_vtx[k][0]], tv[tm_face_vtx[k][1]],
                                        tv[tm_face_vtx[k][2]]);
            if (g != BD_NONE)
                rc = split_subfac(r, g, 0.0, &outcome);
        }
        if (rc || outcome != SPLIT_REFUSED) {
            if (!rc && !tm_is_dead(m, t))
                rc = queue_tet(r, t);
            return rc;
        }
    }
    if (!isfinite(cc[0]) || !isfinite(cc[1]) || !isfinite(cc[2]) || dt_conflict(m, t, cc) <= 0) {
        give_up(r, t, 1);
        return 0;
    }
    int rc = dt_cavity_search(m, cc, t, 0, &r->cav);
    if (rc)
        return rc;
    if (r->cav.status != DT_OK) {
        dt_cavity_abandon(m, &r->cav);
        give_up(r, t, 1);
        return 0;
    }
    uint16_t any = cavity_flags(r);
    const uint32_t *tv = m->tets[t].v;
    double rp = sqrt(v3_dist2(cc, X(m, tv[0])));
    if (any & (TM_F_FACEMARKS | TM_F_SUBSEGS)) {
        rc = ref_gather_marks(m, &r->cav, &r->marks);
        if (rc) {
            dt_cavity_abandon(m, &r->cav);
            return rc;
        }
        ref_decision d;
        ref_decide(r->p, cc, REF_TET, &r->marks, &d);
        if (d.action != REF_COMMIT) {
            dt_cavity_abandon(m, &r->cav);
            r->st.rejected++;
            double lmin = INFINITY;
            for (int e = 0; e < 6; e++)
                lmin = fmin(lmin,
                            v3_dist2(X(m, tv[tm_edge_vtx[e][0]]), X(m, tv[tm_edge_vtx[e][1]])));
            /* For a tetrahedron that is bad by its size alone the floor is
             * half its circumradius instead (the clean bound is
             * r/sqrt(2)): its splits are then never smaller than a
             * fixed fraction of the size bound. */
            double floor = fmin(sqrt(lmin) * fmin(1.0, 0.9 * r->o.ratio / M_SQRT2), 0.5 * rp);
            /* A flat tetrahedron lying on a facet is a rounding artifact
             * that only the split of that facet's subfacet removes. */
            if (why == 3)
                floor = 0;
            int outcome = SPLIT_REFUSED;
            if (d.action == REF_SPLIT_SUBSEGS) {
                size_t done;
                rc = split_encroached_subsegs(r, floor, &done);
                outcome = done ? SPLIT_DONE : SPLIT_REFUSED;
            } else {
                const ref_mark *mk = &r->marks.m[d.which];
                uint32_t g = bd_find_subfac(&r->bd, mk->v[0], mk->v[1], mk->v[2]);
                if (g != BD_NONE)
                    rc = split_subfac(r, g, floor, &outcome);
            }
            if (rc)
                return rc;
            if (tm_is_dead(m, t))
                return 0;
            if (outcome == SPLIT_REFUSED)
                give_up(r, t, 0);
            else
                rc = queue_tet(r, t);
            return rc;
        }
    }
    uint32_t v;
    r->last_op = any & (TM_F_FACEMARKS | TM_F_SUBSEGS) ? "circumcentre (cavity with marks)"
                                                        : "circumcentre";
    rc = commit_point(r, any, BD_V_VOLUME, 0, rp, &v);
    if (rc) {
        dt_cavity_abandon(m, &r->cav);
        return rc;
    }
    r->st.tet_points++;
    return queue_new_tets(r);
}

static int process_seg(ref_mesher *r, uint32_t id, float rmin)
{
    bd_subseg *s = &r->bd.segs[id];
    if (s->flags & BD_F_DEAD)
        return 0;
    s->flags &= (uint16_t)~BD_F_QUEUED;
    int res;
    return split_subseg(r, id, rmin, &res);
}

static int process_fac(ref_mesher *r, uint32_t id, float rmin)
{
    bd_subfac *s = &r->bd.facs[id];
    if (s->flags & BD_F_DEAD)
        return 0;
    s->flags &= (uint16_t)~BD_F_QUEUED;
    int outcome;
    int rc = split_subfac(r, id, rmin, &outcome);
    if (!rc && outcome == SPLIT_DEFERRED)
        rc = queue_fac(r, id, rmin);
    return rc;
}

int ref_run(ref_mesher *r, int tets)
{
    tm_mesh *m = &r->m;
    int lifo = r->o.order == REF_ORDER_LIFO;
    size_t iter = 0;
    int rc = 0;
    /* Debugging aids: PDR_REF_TRACE=N prints the queues and counters
     * every N steps; PDR_REF_CHECK=1 checks the marks against the tables
     * after every step (slow) and aborts at the first disagreement. */
    const char *tr = getenv("PDR_REF_TRACE");
    size_t trace = tr ? (size_t)atol(tr) : 0;
    int cons = getenv("PDR_REF_CHECK") != NULL;
    while (!rc) {
        if ((++iter & 0x3fff) == 0 && r->o.progress)
            r->o.progress(r->o.progress_arg, r);
        if (cons && ref_consistency(r, stderr, 0)) {
            fprintf(stderr, "pdr: refinement tables disagree with the mesh after step %zu (%s)\n",
                    iter, r->last_op);
            abort();
        }
        if (trace && iter % trace == 0)
            fprintf(stderr,
                    "trace %zu (%s): nv %u segq %zu facq %zu tetq %zu | seg %zu fac %zu tet %zu "
                    "rej %zu tol %zu gave %zu miss %zu anom %zu flips %zu\n",
                    iter, r->last_op ? r->last_op : "-", r->m.nv, r->segq.n - r->segq.head, r->facq.n - r->facq.head,
                    r->tetq.n - r->tetq.head, r->st.seg_points, r->st.fac_points,
                    r->st.tet_points, r->st.rejected, r->st.tolerated, r->st.gave_up,
                    r->st.missing_recovered, r->anomalies, r->flips);
        float rmin;
        if (!q_empty(&r->segq)) {
            uint32_t id = q_pop(&r->segq, 0, &rmin);
            r->last_op = "subsegment";
            rc = process_seg(r, id, rmin);
        } else if (!q_empty(&r->facq)) {
            uint32_t id = q_pop(&r->facq, 0, &rmin);
            r->last_op = "subfacet";
            rc = process_fac(r, id, rmin);
        } else if (tets && r->classified && !q_empty(&r->tetq)) {
            uint32_t t = q_pop(&r->tetq, lifo, NULL);
            if (tm_is_dead(m, t) || !(m->flags[t] & TM_F_QUEUED))
                continue;
            m->flags[t] &= (uint16_t)~TM_F_QUEUED;
            if (m->flags[t] & (REF_F_EXTERIOR | REF_F_GIVEUP))
                continue;
            r->last_op = "tetrahedron";
            rc = split_tet(r, t);
        } else {
            break;
        }
    }
    if (trace)
        fprintf(stderr,
                "trace end %zu: nv %u | seg %zu fac %zu tet %zu rej %zu tol %zu gave %zu "
                "slivers %zu miss %zu anom %zu flips %zu\n",
                iter, r->m.nv, r->st.seg_points, r->st.fac_points, r->st.tet_points,
                r->st.rejected, r->st.tolerated, r->st.gave_up, r->st.slivers_left,
                r->st.missing_recovered, r->anomalies, r->flips);
    return rc;
}

/* ---------------------------------------------------- classification */

/* Classification is a flood fill over faces that are not subfacets: from
 * the ghosts (the outside), from every hole point, and, with a region
 * number, from every region point; what is left is inside, with no
 * region. */

static int push(uint32_t **st, size_t *n, size_t *cap, uint32_t t)
{
    if (*n == *cap) {
        size_t c = *cap ? *cap * 2 : 1024;
        uint32_t *s = realloc(*st, c * sizeof *s);
        if (!s)
            return PDR_ENOMEM;
        *st = s;
        *cap = c;
    }
    (*st)[(*n)++] = t;
    return 0;
}

/* Spreads state s (and region g) from the tetrahedra on the stack over
 * faces that are not subfacets. */
static int flood(ref_mesher *r, uint8_t *state, uint8_t s, uint16_t g, uint32_t **st, size_t *n,
                 size_t *cap)
{
    tm_mesh *m = &r->m;
    while (*n) {
        uint32_t t = (*st)[--*n];
        for (int k = 0; k < 4; k++) {
            if (m->flags[t] & TM_F_FACEMARK(k))
                continue;
            tm_link l = m->tets[t].n[k];
            if (tm_is_special(l))
                continue;
            uint32_t u = tm_ltet(l);
            if (state[u])
                continue;
            state[u] = s;
            if (r->region && s == 2)
                r->region[u] = g;
            if (push(st, n, cap, u))
                return PDR_ENOMEM;
        }
    }
    return 0;
}

/* Seeds the flood at the tetrahedron containing point x; returns 1 if it
 * was seeded, 0 if x is outside the hull or already classified. */
static int seed(ref_mesher *r, const double *x, uint8_t *state, uint8_t s, uint16_t g,
                uint32_t **st, size_t *n, size_t *cap, int *rc)
{
    tm_mesh *m = &r->m;
    uint32_t t;
    tm_link exit;
    int l = dt_locate(m, x, TM_NONE, &t, &exit);
    *rc = 0;
    if (l != 0) {
        *rc = l < 0 ? l : 0;
        return 0;
    }
    if (tm_is_ghost(m, t) || state[t])
        return 0;
    state[t] = s;
    if (r->region && s == 2)
        r->region[t] = g;
    *rc = push(st, n, cap, t);
    if (!*rc)
        *rc = flood(r, state, s, g, st, n, cap);
    return 1;
}

int ref_classify(ref_mesher *r, size_t *unreached, size_t *changed, pdr_diag *diag)
{
    tm_mesh *m = &r->m;
    const plc *p = r->p;
    int rc = ref_region_room(r);
    if (rc)
        return rc;
    uint8_t *state = calloc(m->nslots ? m->nslots : 1, 1); /* 1 out, 2 in */
    uint32_t *st = NULL;
    size_t n = 0, cap = 0;
    if (!state)
        return PDR_ENOMEM;
    /* the previous regions, to count changes: a copy of the region array
     * (the exterior flags stay on the mesh until the end) */
    uint16_t *old = NULL;
    if (r->region && r->classified) {
        old = malloc(r->region_cap * sizeof *old);
        if (!old) {
            free(state);
            return PDR_ENOMEM;
        }
        memcpy(old, r->region, r->region_cap * sizeof *old);
    }
    if (r->region)
        memset(r->region, 0, r->region_cap * sizeof *r->region);
    /* Outside: everything reachable from the hull without crossing a
     * subfacet. */
    for (uint32_t t = 0; t < m->nslots && !rc; t++)
        if (!tm_is_dead(m, t) && tm_is_ghost(m, t)) {
            state[t] = 1;
            rc = push(&st, &n, &cap, t);
        }
    if (!rc)
        rc = flood(r, state, 1, 0, &st, &n, &cap);
    for (size_t h = 0; h < p->nhole && !rc; h++)
        seed(r, p->holes[h].xyz, state, 1, 0, &st, &n, &cap, &rc);
    size_t lost = 0;
    for (size_t j = 0; j < p->nregion && !rc; j++) {
        uint32_t t;
        tm_link exit;
        int l = dt_locate(m, p->regions[j].xyz, TM_NONE, &t, &exit);
        if (l < 0) {
            rc = l;
            break;
        }
        if (l != 0 || tm_is_ghost(m, t) || state[t] == 1) {
            lost++;
            if (diag)
                pdr_diag_add(diag, p->path, p->regions[j].line,
                             "warning: region point %zu lies outside the domain; ignored", j + 1);
            continue;
        }
        if (state[t] == 2)
            continue; /* a region already seeded by an earlier point */
        seed(r, p->regions[j].xyz, state, 2, (uint16_t)(j + 1), &st, &n, &cap, &rc);
    }
    size_t nchanged = 0;
    if (!rc) {
        for (uint32_t t = 0; t < m->nslots; t++) {
            if (tm_is_dead(m, t))
                continue;
            uint16_t was = m->flags[t] & REF_F_EXTERIOR;
            if (state[t] == 1)
                m->flags[t] |= REF_F_EXTERIOR;
            else
                m->flags[t] &= (uint16_t)~REF_F_EXTERIOR;
            if (r->classified && !tm_is_ghost(m, t) &&
                (was != (m->flags[t] & REF_F_EXTERIOR) ||
                 (old && state[t] != 1 && old[t] != r->region[t]))) {
                nchanged++;
                m->flags[t] &= (uint16_t)~(REF_F_GIVEUP | REF_F_DEGENERATE);
            }
        }
        r->classified = 1;
    }
    if (unreached)
        *unreached = lost;
    if (changed)
        *changed = nchanged;
    free(old);
    free(st);
    free(state);
    return rc;
}

int ref_queue_all_tets(ref_mesher *r)
{
    tm_mesh *m = &r->m;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (!ref_is_interior(m, t))
            continue;
        double cc[3];
        if (tet_bad(r, t, cc, NULL)) {
            int rc = queue_tet(r, t);
            if (rc)
                return rc;
        }
    }
    return 0;
}

int ref_queue_boundary(ref_mesher *r)
{
    bd_set *bd = &r->bd;
    for (uint32_t i = 0; i < bd->nsegs; i++) {
        if (bd->segs[i].flags & BD_F_DEAD)
            continue;
        int rc = attach_subseg(r, i);
        if (rc < 0)
            return rc;
        if (rc == 0 && (rc = queue_seg(r, i, 0.0f)))
            return rc;
    }
    r->nmiss = 0;
    for (uint32_t i = 0; i < bd->nfacs; i++) {
        if (bd->facs[i].flags & BD_F_DEAD)
            continue;
        int rc = attach_subfac(r, i);
        if (rc < 0)
            return rc;
        if (rc == 0) {
            if (pdr_grow((void **)&r->miss, &r->cap_miss, r->nmiss + 1, sizeof *r->miss))
                return PDR_ENOMEM;
            r->miss[r->nmiss++] = i;
        }
    }
    int rc = repair_and_queue(r, r->miss, r->nmiss);
    r->nmiss = 0;
    return rc;
}

size_t ref_consistency(const ref_mesher *r, FILE *log, int check_regions)
{
    const tm_mesh *m = &r->m;
    const bd_set *bd = &r->bd;
    size_t bad = 0;
    /* While a subfacet is missing, the marks do not yet separate the
     * regions there: check regions only when none is. */
    int regions = r->classified && check_regions;
    for (uint32_t i = 0; i < bd->nfacs && regions; i++)
        if ((bd->facs[i].flags & (BD_F_DEAD | BD_F_MISSING)) == BD_F_MISSING)
            regions = 0;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t))
            continue;
        const tm_tet *T = &m->tets[t];
        for (int k = 0; k < 4; k++) {
            if (!(m->flags[t] & TM_F_FACEMARK(k)))
                continue;
            uint32_t a = T->v[tm_face_vtx[k][0]], b = T->v[tm_face_vtx[k][1]],
                     c = T->v[tm_face_vtx[k][2]];
            uint32_t id = bd_find_subfac(bd, a, b, c);
            if (id == BD_NONE || (bd->facs[id].flags & BD_F_MISSING) ||
                (int32_t)bd->facs[id].facet + 1 != m->marker[4 * (size_t)t + (size_t)k]) {
                if (log)
                    fprintf(log, "marked face %u %u %u of tet %u is no live subfacet\n", a, b, c, t);
                bad++;
            }
        }
        /* regions change only across subfacets */
        for (int k = 0; k < 4 && regions; k++) {
            tm_link l = T->n[k];
            if (tm_is_special(l) || (m->flags[t] & TM_F_FACEMARK(k)))
                continue;
            uint32_t u = tm_ltet(l);
            int et = (m->flags[t] & REF_F_EXTERIOR) || tm_is_ghost(m, t);
            int eu = (m->flags[u] & REF_F_EXTERIOR) || tm_is_ghost(m, u);
            if (et != eu || (r->region && !et && r->region[t] != r->region[u])) {
                if (log)
                    fprintf(log,
                            "tets %u (%u %u %u %u, flags %x) and %u (%u %u %u %u, flags %x) "
                            "differ in region across unmarked face %d (regions %d %d)\n",
                            t, T->v[0], T->v[1], T->v[2], T->v[3], m->flags[t], u,
                            m->tets[u].v[0], m->tets[u].v[1], m->tets[u].v[2], m->tets[u].v[3],
                            m->flags[u], k, r->region ? r->region[t] : -1,
                            r->region ? r->region[u] : -1);
                bad++;
            }
        }
        for (int e = 0; e < 6; e++) {
            if (!(m->flags[t] & TM_F_SUBSEG(e)))
                continue;
            uint32_t a = T->v[tm_edge_vtx[e][0]], b = T->v[tm_edge_vtx[e][1]];
            uint32_t id = bd_find_subseg(bd, a, b);
            if (id == BD_NONE || (bd->segs[id].flags & BD_F_MISSING)) {
                if (log)
                    fprintf(log, "flagged edge %u %u of tet %u is no live subsegment\n", a, b, t);
                bad++;
            }
        }
    }
    for (uint32_t i = 0; i < bd->nfacs; i++) {
        const bd_subfac *s = &bd->facs[i];
        if (s->flags & (BD_F_DEAD | BD_F_MISSING))
            continue;
        uint32_t t;
        if (!find_in_star(m, s->v[0], s->v[1], s->v[2], &t)) {
            if (log)
                fprintf(log, "present subfacet %u (%u %u %u) is no face\n", i, s->v[0], s->v[1],
                        s->v[2]);
            bad++;
            continue;
        }
        const tm_tet *T = &m->tets[t];
        int k = 6 - slot_in(T, s->v[0]) - slot_in(T, s->v[1]) - slot_in(T, s->v[2]);
        if (!(m->flags[t] & TM_F_FACEMARK(k))) {
            if (log)
                fprintf(log, "present subfacet %u (%u %u %u) is not marked\n", i, s->v[0],
                        s->v[1], s->v[2]);
            bad++;
        }
    }
    return bad;
}

int ref_refine(ref_mesher *r)
{
    int rc = ref_queue_all_tets(r);
    if (!rc)
        rc = ref_run(r, 1);
    /* Regions follow the tetrahedra through every insertion; a flat
     * tetrahedron on a facet that is not axis-aligned can pass on the
     * wrong one (see reclassify_new). When one was met, the finished mesh
     * is classified afresh (a flood fill, cheap); when that moves a
     * tetrahedron, refinement resumes (that tetrahedron may need it now),
     * at most a few times. */
    for (int round = 0; round < 4 && !rc && r->region_doubts; round++) {
        size_t changed = 0;
        r->region_doubts = 0;
        rc = ref_classify(r, NULL, &changed, NULL);
        if (rc || !changed)
            break;
        r->st.reclassified += changed;
        rc = ref_queue_all_tets(r);
        if (!rc)
            rc = ref_run(r, 1);
    }
    return rc;
}

size_t ref_interior_tets(const ref_mesher *r)
{
    const tm_mesh *m = &r->m;
    size_t n = 0;
    for (uint32_t t = 0; t < m->nslots; t++)
        n += ref_is_interior(m, t);
    return n;
}

void ref_count_bad(ref_mesher *r)
{
    const tm_mesh *m = &r->m;
    r->st.left_ratio = r->st.left_ratio_angle = r->st.left_ratio_degenerate = 0;
    r->st.left_size = r->st.left_sliver = 0;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (!ref_is_interior(m, t))
            continue;
        double cc[3], q;
        int why = tet_bad(r, t, cc, &q);
        if (!why)
            continue;
        if (r->b2 > 0 && q >= r->b2) {
            r->st.left_ratio++;
            if (m->flags[t] & REF_F_GIVEUP) {
                if ((m->flags[t] & REF_F_DEGENERATE) || !isfinite(q) || !isfinite(cc[0]))
                    r->st.left_ratio_degenerate++;
                else
                    r->st.left_ratio_angle++;
            }
        } else if (why == 2) {
            r->st.left_sliver++;
        } else {
            r->st.left_size++;
        }
    }
}

/* ------------------------------------------------------------ summary */

void ref_quality_range(const mesh_export *e, ref_quality *q)
{
    double re2_lo = INFINITY, re2_hi = 0, c_lo = INFINITY, c_hi = -INFINITY;
    for (size_t t = 0; t < e->nt; t++) {
        const double *p[4];
        for (int k = 0; k < 4; k++)
            p[k] = e->xyz[e->tet[t][k]];
        double q2 = ref_tet_ratio2(p[0], p[1], p[2], p[3], NULL, NULL, NULL);
        if (q2 < re2_lo)
            re2_lo = q2;
        if (q2 > re2_hi)
            re2_hi = q2;
        /* face normals (either orientation of the tetrahedron: the sign of
         * every normal flips together, the dot products do not) */
        double n[4][3], len[4];
        for (int i = 0; i < 4; i++) {
            const uint8_t *f = tm_face_vtx[i];
            double u[3], v[3];
            v3_sub(p[f[1]], p[f[0]], u);
            v3_sub(p[f[2]], p[f[0]], v);
            v3_cross(u, v, n[i]);
            len[i] = sqrt(v3_dot(n[i], n[i]));
        }
        for (int i = 0; i < 4; i++)
            for (int j = i + 1; j < 4; j++) {
                /* the dihedral angle at the edge shared by faces i and j:
                 * cos = -(n_i . n_j) / (|n_i| |n_j|) */
                double c = -v3_dot(n[i], n[j]) / (len[i] * len[j]);
                if (c < c_lo)
                    c_lo = c;
                if (c > c_hi)
                    c_hi = c;
            }
    }
    q->re_min = sqrt(re2_lo);
    q->re_max = sqrt(re2_hi);
    q->dih_min = acos(fmax(-1.0, fmin(1.0, c_hi))) * 180.0 / M_PI;
    q->dih_max = acos(fmax(-1.0, fmin(1.0, c_lo))) * 180.0 / M_PI;
}

/* ------------------------------------------------------------- export */

void ref_output_free(ref_output *out)
{
    free(out->xyz);
    free(out->tet);
    free(out->tet_region);
    free(out->tet_attr);
    free(out->tri);
    free(out->tri_marker);
    free(out->tri_facet);
    free(out->vmap);
    memset(out, 0, sizeof *out);
}

/* The export of ref_export; with_tets 0 leaves out->tet (and the view's
 * tet) NULL for ref_export_take to fill. */
static int export_mesh(const ref_mesher *r, ref_output *out, int with_tets)
{
    memset(out, 0, sizeof *out);
    const tm_mesh *m = &r->m;
    const bd_set *bd = &r->bd;
    size_t nt = ref_interior_tets(r);
    out->vmap = malloc((size_t)m->nv * sizeof *out->vmap);
    if (with_tets)
        out->tet = malloc((nt ? nt : 1) * sizeof *out->tet);
    if (!out->vmap || (with_tets && !out->tet))
        goto nomem;
    memset(out->vmap, 0xff, (size_t)m->nv * sizeof *out->vmap);
    if (r->region) {
        out->tet_region = malloc((nt ? nt : 1) * sizeof *out->tet_region);
        out->tet_attr = malloc((nt ? nt : 1) * sizeof *out->tet_attr);
        if (!out->tet_region || !out->tet_attr)
            goto nomem;
    }
    /* Vertices numbered in the order tetrahedra first use them, which
     * keeps the output's memory order close to the mesh's. */
    size_t nv = 0, k = 0;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (!ref_is_interior(m, t))
            continue;
        for (int s = 0; s < 4; s++) {
            uint32_t v = m->tets[t].v[s];
            if (out->vmap[v] == UINT32_MAX)
                out->vmap[v] = (uint32_t)nv++;
            if (with_tets)
                out->tet[k][s] = out->vmap[v];
        }
        if (r->region) {
            int g = r->region[t];
            double a = g ? r->p->regions[g - 1].attr : 0.0;
            out->tet_attr[k] = a;
            out->tet_region[k] = (int)lrint(a);
        }
        k++;
    }
    out->xyz = malloc((nv ? nv : 1) * sizeof *out->xyz);
    if (!out->xyz)
        goto nomem;
    for (uint32_t v = 1; v < m->nv; v++)
        if (out->vmap[v] != UINT32_MAX)
            memcpy(out->xyz[out->vmap[v]], X(m, v), sizeof out->xyz[0]);
    /* Subfacets with an interior tetrahedron on at least one side (a facet
     * with the outside or a hole on both sides bounds nothing), taken from
     * the marked faces of the interior tetrahedra, in the facet
     * triangulation's orientation. */
    size_t nf = 0, capf = 0;
    for (int pass = 0; pass < 2; pass++) {
        if (pass == 1) {
            capf = nf ? nf : 1;
            out->tri = malloc(capf * sizeof *out->tri);
            out->tri_marker = malloc(capf * sizeof *out->tri_marker);
            out->tri_facet = malloc(capf * sizeof *out->tri_facet);
            if (!out->tri || !out->tri_marker || !out->tri_facet)
                goto nomem;
            nf = 0;
        }
        for (uint32_t t = 0; t < m->nslots; t++) {
            uint16_t fl = m->flags[t];
            if (!(fl & TM_F_FACEMARKS) || (fl & (TM_F_DEAD | REF_F_EXTERIOR)) || tm_is_ghost(m, t))
                continue;
            const tm_tet *T = &m->tets[t];
            for (int fi = 0; fi < 4; fi++) {
                if (!(fl & TM_F_FACEMARK(fi)))
                    continue;
                tm_link l = T->n[fi];
                if (!tm_is_special(l)) {
                    uint32_t u = tm_ltet(l);
                    if (u < t && !(m->flags[u] & REF_F_EXTERIOR) && !tm_is_ghost(m, u))
                        continue; /* listed from u */
                }
                if (pass == 0) {
                    nf++;
                    continue;
                }
                uint32_t a = T->v[tm_face_vtx[fi][0]], b = T->v[tm_face_vtx[fi][1]],
                         c = T->v[tm_face_vtx[fi][2]];
                uint32_t id = bd_find_subfac(bd, a, b, c);
                uint32_t tv[3] = {a, b, c};
                const uint32_t *q = id != BD_NONE ? bd->facs[id].v : tv;
                for (int j = 0; j < 3; j++)
                    out->tri[nf][j] = out->vmap[q[j]];
                int32_t f = m->marker[4 * (size_t)t + (size_t)fi] - 1;
                out->tri_marker[nf] = r->p->facets[f].marker;
                out->tri_facet[nf] = f;
                nf++;
            }
        }
    }
    mesh_export *e = &out->view;
    e->nv = nv;
    e->xyz = (const double(*)[3])out->xyz;
    e->nt = nt;
    e->tet = (const uint32_t(*)[4])out->tet;
    e->tet_region = out->tet_region;
    e->nf = nf;
    e->tri = (const uint32_t(*)[3])out->tri;
    e->tri_marker = out->tri_marker;
    return 0;
nomem:
    ref_output_free(out);
    return PDR_ENOMEM;
}

int ref_export(const ref_mesher *r, ref_output *out)
{
    return export_mesh(r, out, 1);
}

int ref_export_take(ref_mesher *r, ref_output *out)
{
    int rc = export_mesh(r, out, 0);
    if (rc)
        return rc;
    /* Output tetrahedron k (16 bytes) goes to bytes [16k, 16k + 16) of the
     * slot array (32-byte slots): inside slot k / 2, and k <= t, so no
     * slot is overwritten before it has been read (slot 0 is read whole
     * first). */
    tm_mesh *m = &r->m;
    uint32_t(*dst)[4] = (uint32_t(*)[4])(void *)m->tets;
    size_t k = 0;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (!ref_is_interior(m, t))
            continue;
        uint32_t v[4];
        for (int s = 0; s < 4; s++)
            v[s] = out->vmap[m->tets[t].v[s]];
        memcpy(dst[k], v, sizeof v);
        k++;
    }
    size_t bytes = (k ? k : 1) * sizeof *dst;
    uint32_t(*shrunk)[4] = realloc(dst, bytes);
    out->tet = shrunk ? shrunk : dst;
    m->tets = NULL;
    tm_free(m);
    out->view.tet = (const uint32_t(*)[4])out->tet;
    return 0;
}
