/* check/mc.c -- a domain mesh against its boundary triangles and its
 * input PLC (see check/mc.h). */
#include "config.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "check/mc.h"
#include "geom/pred.h"
#include "base/v3.h"

#define REL_TOL 1e-9

typedef struct fkey {
    uint32_t v[3]; /* sorted point numbers */
    uint32_t idx;  /* triangle index */
} fkey;

static int fkey_cmp(const void *pa, const void *pb)
{
    const fkey *a = pa, *b = pb;
    for (int k = 0; k < 3; k++)
        if (a->v[k] != b->v[k])
            return a->v[k] < b->v[k] ? -1 : 1;
    return 0;
}

/* The distance a mesh face may lie off facet f beyond rounding: 2T for a
 * near-planar facet (planar_tol T, see check/mc.h), else 0. */
static double bend_allowance(const plc *p, size_t f, double diag)
{
    return plc_facet_bent(p, f) ? 2.0 * p->planar_tol * diag : 0.0;
}

/* x inside triangle abc of facet f's plane, up to a relative tolerance,
 * in the projection that drops the facet's dominant axis. */
static int in_tri2d(const plc_facet *F, const double *a, const double *b, const double *c,
                    const double *x)
{
    int i = (F->axis + 1) % 3, j = (F->axis + 2) % 3;
    double d = (b[i] - a[i]) * (c[j] - a[j]) - (b[j] - a[j]) * (c[i] - a[i]);
    if (d == 0)
        return 0;
    double l1 = ((x[i] - a[i]) * (c[j] - a[j]) - (x[j] - a[j]) * (c[i] - a[i])) / d;
    double l2 = ((b[i] - a[i]) * (x[j] - a[j]) - (b[j] - a[j]) * (x[i] - a[i])) / d;
    double l0 = 1 - l1 - l2;
    return l0 >= -REL_TOL && l1 >= -REL_TOL && l2 >= -REL_TOL;
}

double mc_plc_volume(const plc *p, int (*side)(void *arg, size_t facet, const double x[3]),
                     void *arg)
{
    double vol = 0;
    for (size_t f = 0; f < p->nfacet; f++)
        for (size_t t = p->ftri_start[f]; t < p->ftri_start[f + 1]; t++) {
            const double *a = p->xyz[p->ftri[t][0]], *b = p->xyz[p->ftri[t][1]],
                         *c = p->xyz[p->ftri[t][2]];
            double x[3];
            for (int k = 0; k < 3; k++)
                x[k] = (a[k] + b[k] + c[k]) / 3.0;
            int s = side(arg, f, x);
            if (!s)
                continue;
            /* s says on which side of the facet's normal the domain lies;
             * the triangle's own turn about that normal (a merged facet's
             * triangulation need not follow it) gives its outward order. */
            double ab[3], ac[3], n[3], bc[3];
            v3_sub(b, a, ab);
            v3_sub(c, a, ac);
            v3_cross(ab, ac, n);
            if (v3_dot(n, p->facets[f].normal) < 0)
                s = -s;
            v3_cross(b, c, bc);
            vol += s * v3_dot(a, bc) / 6.0;
        }
    return vol;
}

struct ctx {
    const tm_mesh *m;
    const uint32_t (*tri)[3];
    const plc *p;
    int32_t *loc;      /* facet of each triangle, -1 */
    uint8_t *cnt;      /* tetrahedra having each triangle */
    uint32_t *tet;     /* one of them */
    size_t *fstart;    /* triangles sorted by facet */
    uint32_t *byfacet;
};

static const double *P(const struct ctx *c, uint32_t point)
{
    return c->m->xyz + 3 * ((size_t)point + 1);
}

static int side_of(void *arg, size_t f, const double x[3])
{
    struct ctx *c = arg;
    const plc_facet *F = &c->p->facets[f];
    for (size_t i = c->fstart[f]; i < c->fstart[f + 1]; i++) {
        uint32_t t = c->byfacet[i];
        const uint32_t *q = c->tri[t];
        if (!in_tri2d(F, P(c, q[0]), P(c, q[1]), P(c, q[2]), x))
            continue;
        if (c->cnt[t] != 1)
            return 0;
        /* The vertex of the one tetrahedron that is not on the triangle:
         * its side of the triangle's plane, exactly (a boundary
         * tetrahedron can be nearly flat, its fourth vertex on the next
         * facet of a concave crease, nearly on this facet's plane), against
         * the triangle's turn about the facet's normal. */
        const uint32_t *v = c->m->tets[c->tet[t]].v;
        for (int s = 0; s < 4; s++) {
            uint32_t w = v[s] - 1;
            if (w == q[0] || w == q[1] || w == q[2])
                continue;
            const double *a = P(c, q[0]), *b = P(c, q[1]), *cc = P(c, q[2]);
            int o = pred_orient3d(a, b, cc, P(c, w));
            double ab[3], ac[3], n[3];
            v3_sub(b, a, ab);
            v3_sub(cc, a, ac);
            v3_cross(ab, ac, n);
            int turn = v3_dot(n, F->normal) > 0 ? 1 : -1;
            return o == 0 ? 0 : o * turn > 0 ? -1 : 1;
        }
        return 0;
    }
    return 0;
}

/* The facet of p whose plane holds triangle q and whose area holds its
 * centroid, or -1. */
static int32_t locate(const struct ctx *c, const uint32_t q[3], double (*box)[2][3], double tol0,
                      const double *bend)
{
    const plc *p = c->p;
    double x[3];
    for (int k = 0; k < 3; k++)
        x[k] = (P(c, q[0])[k] + P(c, q[1])[k] + P(c, q[2])[k]) / 3.0;
    /* The facet nearest the triangle's plane among those that hold it
     * within the tolerance: where facets of very different sizes meet
     * (a needle), the tolerance of the domain's size lets a triangle of
     * one facet pass for one of its neighbours too. */
    int32_t best = -1;
    double best_d = INFINITY;
    for (size_t f = 0; f < p->nfacet; f++) {
        double tol = tol0 + bend[f];
        int in = 1;
        for (int k = 0; k < 3 && in; k++)
            in = x[k] >= box[f][0][k] - tol && x[k] <= box[f][1][k] + tol;
        if (!in)
            continue;
        const plc_facet *F = &p->facets[f];
        double d = 0;
        for (int s = 0; s < 3 && in; s++) {
            double e = fabs(v3_dot(F->normal, P(c, q[s])) - F->offset);
            in = e <= tol;
            d = fmax(d, e);
        }
        if (!in || d >= best_d)
            continue;
        for (size_t t = p->ftri_start[f]; t < p->ftri_start[f + 1]; t++)
            if (in_tri2d(F, p->xyz[p->ftri[t][0]], p->xyz[p->ftri[t][1]], p->xyz[p->ftri[t][2]],
                         x)) {
                best = (int32_t)f;
                best_d = d;
                break;
            }
    }
    return best;
}

static int check_plc(struct ctx *c, size_t ntri, mc_report *r)
{
    const plc *p = c->p;
    double diag = 0;
    for (int k = 0; k < 3; k++)
        diag += (p->bbox[1][k] - p->bbox[0][k]) * (p->bbox[1][k] - p->bbox[0][k]);
    double tol = REL_TOL * sqrt(diag);
    double (*box)[2][3] = pr_malloc((p->nfacet + 1) * sizeof *box);
    double *am = pr_calloc(p->nfacet + 1, sizeof *am);
    double *bend = pr_malloc((p->nfacet + 1) * sizeof *bend);
    c->loc = pr_malloc((ntri + 1) * sizeof *c->loc);
    c->fstart = pr_calloc(p->nfacet + 2, sizeof *c->fstart);
    c->byfacet = pr_malloc((ntri + 1) * sizeof *c->byfacet);
    if (!box || !am || !bend || !c->loc || !c->fstart || !c->byfacet) {
        pr_free(box);
        pr_free(am);
        pr_free(bend);
        return PDR_ENOMEM;
    }
    for (size_t f = 0; f < p->nfacet; f++)
        bend[f] = bend_allowance(p, f, sqrt(diag));
    for (size_t f = 0; f < p->nfacet; f++) {
        for (int k = 0; k < 3; k++) {
            box[f][0][k] = INFINITY;
            box[f][1][k] = -INFINITY;
        }
        for (size_t t = p->ftri_start[f]; t < p->ftri_start[f + 1]; t++)
            for (int s = 0; s < 3; s++)
                for (int k = 0; k < 3; k++) {
                    double x = p->xyz[p->ftri[t][s]][k];
                    box[f][0][k] = fmin(box[f][0][k], x);
                    box[f][1][k] = fmax(box[f][1][k], x);
                }
    }
    for (size_t i = 0; i < ntri; i++) {
        int32_t f = locate(c, c->tri[i], box, tol, bend);
        c->loc[i] = f;
        if (f < 0) {
            r->faces_off_facet++;
            continue;
        }
        am[f] += plc_facet_proj_area(p, (size_t)f, P(c, c->tri[i][0]), P(c, c->tri[i][1]),
                                     P(c, c->tri[i][2]));
        c->fstart[f + 1]++;
    }
    for (size_t f = 0; f < p->nfacet; f++)
        c->fstart[f + 1] += c->fstart[f];
    size_t *fill = pr_malloc((p->nfacet + 1) * sizeof *fill);
    if (!fill) {
        pr_free(box);
        pr_free(am);
        pr_free(bend);
        return PDR_ENOMEM;
    }
    memcpy(fill, c->fstart, (p->nfacet + 1) * sizeof *fill);
    for (size_t i = 0; i < ntri; i++)
        if (c->loc[i] >= 0)
            c->byfacet[fill[c->loc[i]]++] = (uint32_t)i;
    pr_free(fill);
    r->facets = p->nfacet;
    for (size_t f = 0; f < p->nfacet; f++) {
        double ap = 0;
        for (size_t t = p->ftri_start[f]; t < p->ftri_start[f + 1]; t++)
            ap += plc_facet_proj_area(p, f, p->xyz[p->ftri[t][0]], p->xyz[p->ftri[t][1]],
                                      p->xyz[p->ftri[t][2]]);
        r->volume_allow += ap * bend[f];
        if (am[f] == 0) {
            /* no boundary triangle on it: a facet with the outside or a
             * hole on both sides; a facet that should bound the mesh and
             * does not shows in the one-sided faces and the volume */
            r->facets_outside++;
            /* Without hole points every facet of a valid PLC bounds some
             * of the domain (outside the domain a closed surface encloses
             * a region of it): one with no triangle means the mesh lost
             * that part of the domain. */
            if (!p->nhole)
                r->facets_lost++;
            continue;
        }
        double err = ap > 0 ? fabs(am[f] - ap) / ap : 0;
        if (err > r->area_err_max)
            r->area_err_max = err;
        if (err <= REL_TOL)
            r->facets_covered++;
        else
            r->facets_uncovered++;
    }
    r->volume_plc = mc_plc_volume(p, side_of, c);
    pr_free(box);
    pr_free(am);
    pr_free(bend);
    return 0;
}

int mc_check(const tm_mesh *m, const uint32_t (*tri)[3], size_t ntri, const plc *p,
             mc_report *r)
{
    memset(r, 0, sizeof *r);
    r->with_faces = ntri > 0;
    r->with_plc = p != NULL;
    r->faces = ntri;
    struct ctx c = {m, tri, p, NULL, NULL, NULL, NULL, NULL};
    fkey *keys = pr_malloc((ntri + 1) * sizeof *keys);
    c.cnt = pr_calloc(ntri + 1, 1);
    c.tet = pr_malloc((ntri + 1) * sizeof *c.tet);
    int rc = 0;
    if (!keys || !c.cnt || !c.tet) {
        rc = PDR_ENOMEM;
        goto done;
    }
    for (size_t i = 0; i < ntri; i++) {
        v3_sort3u(tri[i][0], tri[i][1], tri[i][2], keys[i].v);
        keys[i].idx = (uint32_t)i;
    }
    qsort(keys, ntri, sizeof *keys, fkey_cmp);
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t) || tm_is_ghost(m, t))
            continue;
        const tm_tet *T = &m->tets[t];
        const double *a = m->xyz + 3 * (size_t)T->v[0], *b = m->xyz + 3 * (size_t)T->v[1],
                     *cc = m->xyz + 3 * (size_t)T->v[2], *d = m->xyz + 3 * (size_t)T->v[3];
        double u[3], v[3], w[3], vw[3];
        v3_sub(b, a, u);
        v3_sub(cc, a, v);
        v3_sub(d, a, w);
        v3_cross(v, w, vw);
        r->volume_mesh += v3_dot(u, vw) / 6.0;
        for (int k = 0; k < 4; k++) {
            fkey key;
            v3_sort3u(T->v[tm_face_vtx[k][0]] - 1, T->v[tm_face_vtx[k][1]] - 1,
                  T->v[tm_face_vtx[k][2]] - 1, key.v);
            const fkey *hit = ntri ? bsearch(&key, keys, ntri, sizeof *keys, fkey_cmp) : NULL;
            int boundary = T->n[k] == TM_LINK_NONE;
            r->boundary_faces += boundary;
            if (hit) {
                if (c.cnt[hit->idx] < 255)
                    c.cnt[hit->idx]++;
                c.tet[hit->idx] = t;
            } else if (boundary && ntri) {
                r->boundary_uncovered++;
            }
        }
    }
    for (size_t i = 0; i < ntri; i++)
        r->faces_not_in_mesh += c.cnt[i] == 0;
    if (p) {
        rc = check_plc(&c, ntri, r);
        if (rc)
            goto done;
        double ref = fabs(r->volume_plc) > 0 ? fabs(r->volume_plc) : 1.0;
        r->volume_err = fabs(r->volume_mesh - r->volume_plc) / ref;
        r->volume_mismatch =
            r->volume_allow > 0
                ? fabs(r->volume_mesh - r->volume_plc) > REL_TOL * ref + r->volume_allow
                : r->volume_err > REL_TOL;
    }
done:
    pr_free(keys);
    pr_free(c.cnt);
    pr_free(c.tet);
    pr_free(c.loc);
    pr_free(c.fstart);
    pr_free(c.byfacet);
    return rc;
}

size_t mc_defects(const mc_report *r)
{
    return r->faces_not_in_mesh + r->boundary_uncovered + r->facets_uncovered +
           r->faces_off_facet + r->volume_mismatch + r->facets_lost;
}

static void line(FILE *f, const char *what, size_t n, int defect)
{
    fprintf(f, "  %-34s %12zu%s\n", what, n, defect && n ? "   <-- DEFECT" : "");
}

void mc_print(const mc_report *r, FILE *f)
{
    if (r->with_faces) {
        fprintf(f, "boundary\n");
        line(f, "boundary triangles given", r->faces, 0);
        line(f, "faces of exactly one tetrahedron", r->boundary_faces, 0);
        line(f, "triangles that are no mesh face", r->faces_not_in_mesh, 1);
        line(f, "one-sided faces not among them", r->boundary_uncovered, 1);
    }
    if (r->with_plc) {
        fprintf(f, "facets\n");
        line(f, "input facets", r->facets, 0);
        line(f, "facets covered by subfacets", r->facets_covered, 0);
        line(f, "facets with no triangle (outside)", r->facets_outside, 0);
        line(f, "... of an input without holes", r->facets_lost, 1);
        line(f, "facets not covered (area differs)", r->facets_uncovered, 1);
        line(f, "triangles in no input facet", r->faces_off_facet, 1);
        fprintf(f, "  %-34s %12.3g\n", "largest relative area difference", r->area_err_max);
        fprintf(f, "volume\n");
        fprintf(f, "  %-34s %12.10g\n", "tetrahedra", r->volume_mesh);
        fprintf(f, "  %-34s %12.10g\n", "domain (from the input)", r->volume_plc);
        fprintf(f, "  %-34s %12.3g%s\n", "relative difference", r->volume_err,
                r->volume_mismatch ? "   <-- DEFECT" : "");
        if (r->volume_allow > 0)
            fprintf(f, "  %-34s %12.3g\n", "allowed (near-planar facets)",
                    r->volume_allow / (fabs(r->volume_plc) > 0 ? fabs(r->volume_plc) : 1.0));
    }
}
