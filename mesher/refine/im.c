/* refine/im.c -- the initial conforming mesh Mo (see refine/im.h). */
#include "config.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "mesh/dt.h"
#include "refine/im.h"
#include "base/pdr_util.h"
#include "base/v3.h"

#define X(m, v) ((m)->xyz + 3 * (size_t)(v))

/* ------------------------------------------------- distances (for d) */

static double clamp01(double t)
{
    return t < 0 ? 0 : t > 1 ? 1 : t;
}

static double pt_seg2(const double *p, const double *a, const double *b)
{
    double ab[3], ap[3];
    v3_sub(b, a, ab);
    v3_sub(p, a, ap);
    double l = v3_dot(ab, ab), t = l > 0 ? clamp01(v3_dot(ap, ab) / l) : 0.0, d[3];
    for (int k = 0; k < 3; k++)
        d[k] = ap[k] - t * ab[k];
    return v3_dot(d, d);
}

/* Closest points of segments p1q1 and p2q2 (the classic clamped
 * parametric solution). */
static double seg_seg2(const double *p1, const double *q1, const double *p2, const double *q2)
{
    double d1[3], d2[3], r[3];
    v3_sub(q1, p1, d1);
    v3_sub(q2, p2, d2);
    v3_sub(p1, p2, r);
    double a = v3_dot(d1, d1), e = v3_dot(d2, d2), f = v3_dot(d2, r), s, t;
    if (a <= 0 && e <= 0) {
        s = t = 0;
    } else if (a <= 0) {
        s = 0;
        t = clamp01(f / e);
    } else {
        double c = v3_dot(d1, r);
        if (e <= 0) {
            t = 0;
            s = clamp01(-c / a);
        } else {
            double b = v3_dot(d1, d2), den = a * e - b * b;
            s = den > 0 ? clamp01((b * f - c * e) / den) : 0.0;
            t = (b * s + f) / e;
            if (t < 0) {
                t = 0;
                s = clamp01(-c / a);
            } else if (t > 1) {
                t = 1;
                s = clamp01((b - c) / a);
            }
        }
    }
    double x[3];
    for (int k = 0; k < 3; k++)
        x[k] = (p1[k] + s * d1[k]) - (p2[k] + t * d2[k]);
    return v3_dot(x, x);
}

/* Distance from p to triangle abc: to the plane when p projects inside,
 * else to the nearest edge. */
static double pt_tri2(const double *p, const double *a, const double *b, const double *c)
{
    double ab[3], ac[3], ap[3], n[3];
    v3_sub(b, a, ab);
    v3_sub(c, a, ac);
    v3_sub(p, a, ap);
    n[0] = ab[1] * ac[2] - ab[2] * ac[1];
    n[1] = ab[2] * ac[0] - ab[0] * ac[2];
    n[2] = ab[0] * ac[1] - ab[1] * ac[0];
    double nn = v3_dot(n, n);
    if (nn > 0) {
        double h = v3_dot(ap, n) / nn, q[3];
        for (int k = 0; k < 3; k++)
            q[k] = p[k] - h * n[k];
        /* inside test by signed areas about n */
        const double *v[3] = {a, b, c};
        int inside = 1;
        for (int i = 0; i < 3 && inside; i++) {
            double e[3], w[3], x[3];
            v3_sub(v[(i + 1) % 3], v[i], e);
            v3_sub(q, v[i], w);
            x[0] = e[1] * w[2] - e[2] * w[1];
            x[1] = e[2] * w[0] - e[0] * w[2];
            x[2] = e[0] * w[1] - e[1] * w[0];
            inside = v3_dot(x, n) >= 0;
        }
        if (inside)
            return h * h * nn;
    }
    double d = pt_seg2(p, a, b), e = pt_seg2(p, b, c), f = pt_seg2(p, c, a);
    return fmin(d, fmin(e, f));
}

static double seg_tri2(const double *p, const double *q, const double *t[3])
{
    double d = fmin(pt_tri2(p, t[0], t[1], t[2]), pt_tri2(q, t[0], t[1], t[2]));
    for (int i = 0; i < 3; i++)
        d = fmin(d, seg_seg2(p, q, t[i], t[(i + 1) % 3]));
    return d;
}

static double tri_tri2(const double *s[3], const double *t[3])
{
    double d = INFINITY;
    for (int i = 0; i < 3; i++) {
        d = fmin(d, pt_tri2(s[i], t[0], t[1], t[2]));
        d = fmin(d, pt_tri2(t[i], s[0], s[1], s[2]));
        for (int j = 0; j < 3; j++)
            d = fmin(d, seg_seg2(s[i], s[(i + 1) % 3], t[j], t[(j + 1) % 3]));
    }
    return d;
}

static int facet_has(const plc *p, uint32_t v, size_t f)
{
    for (size_t i = p->v_fstart[v]; i < p->v_fstart[v + 1]; i++)
        if (p->v_facets[i] == f)
            return 1;
    return 0;
}

/* Squared distance between two boxes (0 if they overlap). */
static double box2(const double a[2][3], const double b[2][3])
{
    double d = 0;
    for (int k = 0; k < 3; k++) {
        double g = fmax(0.0, fmax(a[0][k] - b[1][k], b[0][k] - a[1][k]));
        d += g * g;
    }
    return d;
}

static void facet_box(const plc *p, size_t f, double b[2][3])
{
    for (int k = 0; k < 3; k++) {
        b[0][k] = INFINITY;
        b[1][k] = -INFINITY;
    }
    for (size_t t = p->ftri_start[f]; t < p->ftri_start[f + 1]; t++)
        for (int i = 0; i < 3; i++)
            for (int k = 0; k < 3; k++) {
                double x = p->xyz[p->ftri[t][i]][k];
                b[0][k] = fmin(b[0][k], x);
                b[1][k] = fmax(b[1][k], x);
            }
}

double im_paper_d(const plc *p)
{
    double best = INFINITY;
    /* vertex - vertex */
    for (size_t i = 0; i < p->nv; i++)
        for (size_t j = i + 1; j < p->nv; j++) {
            double d[3];
            v3_sub(p->xyz[i], p->xyz[j], d);
            best = fmin(best, v3_dot(d, d));
        }
    /* vertex - segment */
    for (size_t v = 0; v < p->nv; v++)
        for (size_t s = 0; s < p->nseg; s++) {
            const uint32_t *e = p->segs[s].v;
            if (e[0] == v || e[1] == v)
                continue;
            best = fmin(best, pt_seg2(p->xyz[v], p->xyz[e[0]], p->xyz[e[1]]));
        }
    /* segment - segment */
    for (size_t s = 0; s < p->nseg; s++)
        for (size_t u = s + 1; u < p->nseg; u++) {
            const uint32_t *a = p->segs[s].v, *b = p->segs[u].v;
            if (a[0] == b[0] || a[0] == b[1] || a[1] == b[0] || a[1] == b[1])
                continue;
            best = fmin(best,
                        seg_seg2(p->xyz[a[0]], p->xyz[a[1]], p->xyz[b[0]], p->xyz[b[1]]));
        }
    double (*box)[2][3] = pr_malloc((p->nfacet ? p->nfacet : 1) * sizeof *box);
    if (!box)
        return sqrt(best) / M_SQRT2;
    for (size_t f = 0; f < p->nfacet; f++)
        facet_box(p, f, box[f]);
    for (size_t f = 0; f < p->nfacet; f++) {
        /* vertex - facet */
        for (size_t v = 0; v < p->nv; v++) {
            if (facet_has(p, (uint32_t)v, f))
                continue;
            double vb[2][3];
            memcpy(vb[0], p->xyz[v], sizeof vb[0]);
            memcpy(vb[1], p->xyz[v], sizeof vb[1]);
            if (box2(vb, box[f]) >= best)
                continue;
            for (size_t t = p->ftri_start[f]; t < p->ftri_start[f + 1]; t++) {
                const uint32_t *c = p->ftri[t];
                best = fmin(best, pt_tri2(p->xyz[v], p->xyz[c[0]], p->xyz[c[1]], p->xyz[c[2]]));
            }
        }
        /* segment - facet */
        for (size_t s = 0; s < p->nseg; s++) {
            const uint32_t *e = p->segs[s].v;
            if (facet_has(p, e[0], f) || facet_has(p, e[1], f))
                continue;
            for (size_t t = p->ftri_start[f]; t < p->ftri_start[f + 1]; t++) {
                const uint32_t *c = p->ftri[t];
                const double *tri[3] = {p->xyz[c[0]], p->xyz[c[1]], p->xyz[c[2]]};
                best = fmin(best, seg_tri2(p->xyz[e[0]], p->xyz[e[1]], tri));
            }
        }
        /* facet - facet */
        for (size_t g = f + 1; g < p->nfacet; g++) {
            if (box2(box[f], box[g]) >= best)
                continue;
            int shared = 0;
            for (size_t t = p->ftri_start[f]; t < p->ftri_start[f + 1] && !shared; t++)
                for (int i = 0; i < 3 && !shared; i++)
                    shared = facet_has(p, p->ftri[t][i], g);
            if (shared)
                continue;
            for (size_t t = p->ftri_start[f]; t < p->ftri_start[f + 1]; t++)
                for (size_t u = p->ftri_start[g]; u < p->ftri_start[g + 1]; u++) {
                    const uint32_t *a = p->ftri[t], *b = p->ftri[u];
                    const double *s3[3] = {p->xyz[a[0]], p->xyz[a[1]], p->xyz[a[2]]};
                    const double *t3[3] = {p->xyz[b[0]], p->xyz[b[1]], p->xyz[b[2]]};
                    best = fmin(best, tri_tri2(s3, t3));
                }
        }
    }
    pr_free(box);
    return sqrt(best) / M_SQRT2;
}

/* ------------------------------------------------------------- build */

double im_interior_volume(const ref_mesher *r)
{
    const tm_mesh *m = &r->m;
    double v = 0;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (!ref_is_interior(m, t))
            continue;
        const uint32_t *q = m->tets[t].v;
        double vol;
        ref_tet_ratio2(X(m, q[0]), X(m, q[1]), X(m, q[2]), X(m, q[3]), &vol, NULL, NULL);
        v += vol;
    }
    return v;
}

/* Per input vertex: 1 if two of its segments meet at less than 90
 * degrees (Ruppert's shells are used next to it). */
static int find_acute(ref_mesher *r)
{
    const plc *p = r->p;
    r->seg_acute = pr_calloc(p->nv ? p->nv : 1, sizeof *r->seg_acute);
    if (!r->seg_acute)
        return PDR_ENOMEM;
    for (size_t v = 0; v < p->nv; v++)
        for (size_t i = p->v_sstart[v]; i < p->v_sstart[v + 1]; i++)
            for (size_t j = i + 1; j < p->v_sstart[v + 1]; j++) {
                const uint32_t *a = p->segs[p->v_segs[i]].v, *b = p->segs[p->v_segs[j]].v;
                uint32_t oa = a[0] == v ? a[1] : a[0], ob = b[0] == v ? b[1] : b[0];
                double u[3], w[3];
                v3_sub(p->xyz[oa], p->xyz[v], u);
                v3_sub(p->xyz[ob], p->xyz[v], w);
                if (v3_dot(u, w) > 0)
                    r->seg_acute[v] = 1;
            }
    return 0;
}

/* The end of the recovery's bound on points (im_build): max_points back
 * to saved, and a stop at the bound cap (0: none was set) recorded.
 * Returns rc. */
static int recovery_end(ref_mesher *r, int rc, size_t cap, size_t saved)
{
    r->o.max_points = saved;
    if (rc == PDR_ELIMIT && cap && !r->stopped_below)
        r->recovery_capped = cap;
    return rc;
}

int im_build(ref_mesher *r, const im_opts *o, im_stats *st, pdr_diag *diag)
{
    im_stats s;
    memset(&s, 0, sizeof s);
    tm_mesh *m = &r->m;
    const plc *p = r->p;
    double t0 = pdr_now();
    int rc = tm_reserve(m, p->nv + 1, 8 * p->nv + 64);
    for (size_t i = 0; i < p->nv && !rc; i++) {
        uint32_t v;
        rc = tm_add_vertex(m, p->xyz[i], &v);
    }
    if (!rc)
        rc = bd_vertex_room(&r->bd, m->nv);
    if (rc)
        return rc;
    for (uint32_t v = 1; v < m->nv; v++) {
        r->bd.vkind[v] = BD_V_INPUT;
        r->bd.vfeat[v] = v - 1;
        r->bd.vrins[v] = INFINITY;
    }
    /* A box around the domain, at twice the diagonal of its bounding box.
     * It keeps every face of the domain's boundary an interior face of
     * the tetrahedralization: a point inserted on a boundary facet or
     * segment that is not axis-aligned is off it by a rounding error, and
     * on the convex hull that error decides whether the point is inside
     * (leaving the hull face, hence the subfacet, in place) or outside;
     * with the box, every tetrahedron around the face has a circumsphere
     * that contains the point with a wide margin. */
    double lo[3], hi[3], bdiag = 0;
    for (int k = 0; k < 3; k++) {
        lo[k] = p->bbox[0][k];
        hi[k] = p->bbox[1][k];
        bdiag += (hi[k] - lo[k]) * (hi[k] - lo[k]);
    }
    bdiag = sqrt(bdiag);
    for (int c = 0; c < 8 && !rc; c++) {
        double x[3];
        uint32_t v;
        for (int k = 0; k < 3; k++)
            x[k] = ((c >> k) & 1) ? hi[k] + 2 * bdiag : lo[k] - 2 * bdiag;
        rc = tm_add_vertex(m, x, &v);
        if (!rc)
            rc = bd_vertex_room(&r->bd, m->nv);
        if (!rc) {
            r->bd.vkind[v] = BD_V_VOLUME;
            r->bd.vfeat[v] = UINT32_MAX;
            r->bd.vrins[v] = INFINITY;
        }
    }
    if (rc)
        return rc;
    dt_build_opts bo = {.seed = 1};
    dt_build_stats bs;
    rc = dt_build(m, &bo, &bs);
    if (rc == PDR_EGEOMETRY) {
        pdr_diag_add(diag, p->path, 0, "the input vertices are coplanar or fewer than four");
        return rc;
    }
    if (rc)
        return rc;
    s.input_vertices = bs.inserted;
    /* Insertion radius of an input vertex: its nearest neighbour. */
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t) || tm_is_ghost(m, t))
            continue;
        const uint32_t *q = m->tets[t].v;
        for (int e = 0; e < 6; e++) {
            uint32_t a = q[tm_edge_vtx[e][0]], b = q[tm_edge_vtx[e][1]];
            double d[3];
            v3_sub(X(m, a), X(m, b), d);
            float l = (float)sqrt(v3_dot(d, d));
            if (l < r->bd.vrins[a])
                r->bd.vrins[a] = l;
            if (l < r->bd.vrins[b])
                r->bd.vrins[b] = l;
        }
    }
    rc = find_acute(r);
    for (size_t f = 0; f < p->nfacet && !rc; f++)
        for (size_t t = p->ftri_start[f]; t < p->ftri_start[f + 1] && !rc; t++) {
            const uint32_t *c = p->ftri[t];
            rc = bd_add_subfac(&r->bd, c[0] + 1, c[1] + 1, c[2] + 1, (uint32_t)f, NULL);
        }
    for (size_t i = 0; i < p->nseg && !rc; i++)
        rc = bd_add_subseg(&r->bd, p->segs[i].v[0] + 1, p->segs[i].v[1] + 1, (uint32_t)i, NULL);
    if (rc)
        return rc;
    double t1 = pdr_now();
    s.delaunay_seconds = t1 - t0;
    double save_len = r->o.seg_maxlen, save_rad = r->o.fac_maxrad;
    if (o && o->paper) {
        s.d = o->d > 0 ? o->d : im_paper_d(p);
        if (isfinite(s.d) && s.d > 0) {
            r->o.seg_maxlen = 2.0 * s.d;
            r->o.fac_maxrad = s.d * M_SQRT2;
        }
    }
    size_t seg0 = r->st.seg_points, fac0 = r->st.fac_points;
    /* The constrained recovery inserts points only on missing pieces, a
     * few per input vertex at most on every surface measured (the
     * armadillo scan: 2.6); where it cascades (splits of missing segments
     * next to small angles, on points along curves whose Delaunay
     * tetrahedralization grows quadratically) it would run for hours
     * before the general bound, so it has a bound of its own. */
    size_t save_max = r->o.max_points;
    size_t cap = IM_RECOVERY_PER_VERTEX * p->nv + IM_RECOVERY_BASE;
    if (!r->o.constrained || (o && o->paper) || (save_max && cap >= save_max))
        cap = 0; /* no bound of its own */
    if (cap)
        r->o.max_points = r->st.seg_points + r->st.fac_points + r->st.tet_points + cap;
    /* The constrained recovery: segments first, while no facet is a
     * constraint (refine_segrec.c), then the facets by retriangulating
     * the tetrahedra they cross (refine_facrec.c), then the rest by
     * splits, the subfacets present being constraints. */
    r->narrow_recovery = r->o.constrained && o && !o->paper && o->segments_first;
    r->keep_stuck = r->narrow_recovery;
    rc = r->narrow_recovery ? ref_recover_segments(r) : 0;
    if (!rc && r->narrow_recovery)
        rc = ref_recover_facets(r);
    if (!rc)
        rc = ref_queue_boundary(r);
    if (!rc && r->narrow_recovery && r->o.trace) {
        size_t ms, mf;
        bd_count_missing(&r->bd, &ms, &mf);
        fprintf(r->o.trace,
                "recovery: %zu subsegments and %zu subfacets missing before the splits "
                "(segment recovery: %zu points, %zu flat fans kept out; facet recovery: "
                "%zu subfacets)\n",
                ms, mf, r->st.segrec_points, r->st.flat_fans_kept, r->st.facrec_faces);
    }
    if (!rc)
        rc = ref_run(r, 0);
    r->o.seg_maxlen = save_len;
    r->o.fac_maxrad = save_rad;
    if (rc) {
        r->narrow_recovery = 0;
        return recovery_end(r, rc, cap, save_max);
    }
    double t2 = pdr_now();
    s.recovery_seconds = t2 - t1;
    rc = ref_classify(r, &s.unreached_regions, NULL, diag);
    /* The constrained mode: the exterior carved away; the recovery's
     * insertions next to constraints may have left faces that are not
     * locally Delaunay: flipped, and what blocks the flips split. */
    if (!rc && r->o.constrained)
        rc = ref_carve(r);
    if (!rc && r->o.constrained)
        rc = ref_cdt_restore(r);
    if (!rc && r->o.constrained)
        rc = ref_run(r, 0);
    rc = recovery_end(r, rc, cap, save_max);
    r->narrow_recovery = 0;
    /* the points of the whole stage: the recovery's and, in the
     * constrained mode, those of the repair after the classification */
    s.seg_points = r->st.seg_points - seg0;
    s.fac_points = r->st.fac_points - fac0;
    s.classify_seconds = pdr_now() - t2;
    s.tets = ref_interior_tets(r);
    if (st)
        *st = s;
    return rc;
}

int im_mo_size(ref_mesher *r, size_t ntets)
{
    if (!ntets)
        return PDR_EINVAL;
    double vol = im_interior_volume(r);
    double save = r->o.maxvol;
    /* Delaunay refinement under a volume bound a (with the quality
     * bounds) leaves tetrahedra of about a / 2 on average (measured on
     * the model problems at 2e4 and 1e5 tetrahedra). */
    r->o.maxvol = 2.0 * vol / (double)ntets;
    int rc = ref_refine(r);
    r->o.maxvol = save;
    return rc;
}
