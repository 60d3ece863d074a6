/*
 * refine/refine_decide.c -- the cavity decision (refine/refine.h, steps 3
 * and 4): ref_gather_marks lists the subsegments and subfacets a cavity
 * touches, ref_decide says from that list alone whether the point is
 * committed or which pieces are split instead. Here too the geometry of
 * that decision (circumcentre of a triangle, diametral and equatorial
 * balls, orientation in a facet's plane) and the walk around an edge, which
 * the boundary updates and the splits share.
 *
 * Nothing in this file reads a ref_mesher: it works on a tm_mesh, a
 * dt_cavity and a plc only, so that the parallel refinement can run the
 * same decision on a cavity gathered from several processing elements.
 */
#include "config.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "geom/pred.h"
#include "refine/refine_int.h"
#include "base/v3.h"

#define X(m, v) ((m)->xyz + 3 * (size_t)(v))

/* ------------------------------------------------------------ geometry */

/* Circumcentre of triangle abc in space; *r2 its squared radius. Returns
 * 0, or -1 for a degenerate triangle. */
int ref__tri_circumcentre(const double *a, const double *b, const double *c, double cc[3],
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
int ref__in_diametral(const double *a, const double *b, const double *p)
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
int ref__in_equatorial(const double *a, const double *b, const double *c, const double *p)
{
    double cc[3], r2;
    if (ref__tri_circumcentre(a, b, c, cc, &r2))
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
int ref__orient_facet(const plc *pl, uint32_t f, const double *a, const double *b,
                      const double *c)
{
    int k = pl->facets[f].axis, i = (k + 1) % 3, j = (k + 2) % 3;
    double pa[2] = {a[i], a[j]}, pb[2] = {b[i], b[j]}, pc[2] = {c[i], c[j]};
    int o = pred_orient2d(pa, pb, pc);
    return pl->facets[f].normal[k] > 0 ? o : -o;
}

/* ---------------------------------------------------------------- marks */

static int marks_add(ref_marks *cm, ref_mark **out)
{
    if (cm->n == cm->cap) {
        size_t c = cm->cap ? cm->cap * 2 : 32;
        ref_mark *m = pr_realloc(cm->m, c * sizeof *m);
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
    pr_free(cm->m);
    pr_free(cm->seg);
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
    ref_seg_slot *t = pr_calloc(cap, sizeof *t);
    if (!t)
        return PDR_ENOMEM;
    pr_free(cm->seg);
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

/* Walks around edge ab starting at tetrahedron t (which has it), calling
 * fn on every tetrahedron; stops when fn returns nonzero (and returns
 * that) or when the walk is back at t (returns 0). A special link (domain
 * boundary, remote face) ends the walk with -1. */
int ref_around_edge(const tm_mesh *m, uint32_t t, uint32_t a, uint32_t b,
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
        int se = ref__slot_in(C, e);
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
            mk->facet = tm_marker(m, t, k) - 1;
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
            mk->deleted = ref_around_edge(m, t, a, b, not_in_cavity, NULL) == 0;
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
            mk->encroached = (uint8_t)(mk->deleted || ref__in_diametral(mk->x[0], mk->x[1], p));
            d->nseg_encroached += mk->encroached;
        } else {
            mk->encroached =
                (uint8_t)(mk->deleted || ref__in_equatorial(mk->x[0], mk->x[1], mk->x[2], p));
            if (mk->encroached) {
                d->nfac_encroached++;
                double cc[3], r2 = 0.0;
                ref__tri_circumcentre(mk->x[0], mk->x[1], mk->x[2], cc, &r2);
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
        int o0 = ref__orient_facet(pl, (uint32_t)f, mk->x[0], mk->x[1], q);
        int o1 = ref__orient_facet(pl, (uint32_t)f, mk->x[1], mk->x[2], q);
        int o2 = ref__orient_facet(pl, (uint32_t)f, mk->x[2], mk->x[0], q);
        if ((o0 >= 0 && o1 >= 0 && o2 >= 0) || (o0 <= 0 && o1 <= 0 && o2 <= 0)) {
            d->which = k;
            return;
        }
    }
}
