/* plc/plc_split.c -- cutting the segments along thin facets that every
 * mesh with a radius-edge bound cuts (see plc/plc_split.h). */
#include "config.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "base/v3.h"
#include "plc/fm.h"
#include "plc/plc_int.h"
#include "plc/plc_split.h"

/* Distance from x to the line through a and b (a != b). */
static double line_dist(const double *x, const double *a, const double *b)
{
    double ab[3], ax[3], c[3];
    v3_sub(b, a, ab);
    v3_sub(x, a, ax);
    v3_cross(ab, ax, c);
    return sqrt(v3_dot(c, c) / v3_dot(ab, ab));
}

/* The largest distance of a corner of facet f from the line ab. */
static double facet_width(const plc *p, size_t f, const double *a, const double *b)
{
    const plc_facet *F = &p->facets[f];
    double w = 0;
    for (size_t q = F->poly_first; q < F->poly_first + F->npoly; q++) {
        const plc_polygon *P = &p->polys[q];
        for (uint32_t i = 0; i < P->n; i++) {
            double d = line_dist(p->xyz[p->corners[P->first + i]], a, b);
            if (d > w)
                w = d;
        }
    }
    return w;
}

/* The number of pieces segment s is cut into (1: not cut). */
static size_t pieces_of(const plc *p, size_t s, double B, size_t max_pieces)
{
    const uint32_t *v = p->segs[s].v;
    if (p->seg_fstart[s] == p->seg_fstart[s + 1] || p->seg_mindih[s] < FM_SHARP_DIH ||
        p->v_minang[v[0]] < FM_ACUTE_ANG || p->v_minang[v[1]] < FM_ACUTE_ANG)
        return 1;
    const double *a = p->xyz[v[0]], *b = p->xyz[v[1]];
    double w = INFINITY;
    for (size_t i = p->seg_fstart[s]; i < p->seg_fstart[s + 1]; i++) {
        double fw = facet_width(p, p->seg_facets[i], a, b);
        if (fw < w)
            w = fw;
    }
    double len = sqrt(v3_dist2(a, b));
    if (!(w > 0) || !(len > 0))
        return 1;
    /* the fewest pieces shorter than PLC_SPLIT_FACTOR B w */
    double n = floor(len / (PLC_SPLIT_FACTOR * B * w)) + 1.0;
    if (!(n >= 2.0))
        return 1;
    return n > (double)max_pieces ? max_pieces : (size_t)n;
}

/* Index of segment (a, b), a < b, in the sorted p->segs, or SIZE_MAX. */
static size_t find_seg(const plc *p, uint32_t a, uint32_t b)
{
    size_t lo = 0, hi = p->nseg;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        const uint32_t *v = p->segs[mid].v;
        if (v[0] < a || (v[0] == a && v[1] < b))
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < p->nseg && p->segs[lo].v[0] == a && p->segs[lo].v[1] == b ? lo : SIZE_MAX;
}

/* The cut of each segment: first[s] .. first[s] + cnt[s] - 1 are its new
 * vertices, from segs[s].v[0] to v[1]. */
struct cuts {
    uint32_t *first;
    uint32_t *cnt;
};

/* Appends to out (growing it) the new vertices of edge x -> y in that
 * direction; none if the edge is no cut segment. */
static int append_cut(const plc *p, const struct cuts *c, uint32_t x, uint32_t y, uint32_t **out,
                      size_t *n, size_t *cap)
{
    uint32_t a = x < y ? x : y, b = x < y ? y : x;
    size_t s = find_seg(p, a, b);
    if (s == SIZE_MAX || !c->cnt[s])
        return 0;
    if (plc__grow((void **)out, cap, *n + c->cnt[s], sizeof **out))
        return PDR_ENOMEM;
    for (uint32_t k = 0; k < c->cnt[s]; k++)
        (*out)[(*n)++] = c->first[s] + (x == a ? k : c->cnt[s] - 1 - k);
    return 0;
}

/* The corners of every polygon with the new vertices of its cut edges,
 * and the explicit segments cut into pieces, built aside (p unchanged):
 * r->cor and r->poly (first, n per polygon), r->seg. */
struct rebuilt {
    uint32_t *cor;
    size_t ncor, capc;
    plc_polygon *poly;
    plc_segment *seg;
    size_t nseg, caps;
};

static void rebuilt_free(struct rebuilt *r)
{
    pr_free(r->cor);
    pr_free(r->poly);
    pr_free(r->seg);
    memset(r, 0, sizeof *r);
}

static int rebuild(const plc *p, const struct cuts *c, struct rebuilt *r)
{
    memset(r, 0, sizeof *r);
    r->poly = pr_malloc((p->npoly ? p->npoly : 1) * sizeof *r->poly);
    if (!r->poly)
        return PDR_ENOMEM;
    int rc = 0;
    for (size_t q = 0; q < p->npoly && !rc; q++) {
        const plc_polygon *P = &p->polys[q];
        size_t start = r->ncor;
        /* a polygon of two corners is a segment (not closed) */
        uint32_t nedge = P->n >= 3 ? P->n : P->n - 1;
        for (uint32_t i = 0; i < P->n && !rc; i++) {
            if (plc__grow((void **)&r->cor, &r->capc, r->ncor + 1, sizeof *r->cor)) {
                rc = PDR_ENOMEM;
                break;
            }
            uint32_t x = p->corners[P->first + i];
            r->cor[r->ncor++] = x;
            if (i < nedge)
                rc = append_cut(p, c, x, p->corners[P->first + (i + 1) % P->n], &r->cor,
                                &r->ncor, &r->capc);
        }
        if (!rc && r->ncor - start > UINT32_MAX)
            rc = PDR_ELIMIT;
        r->poly[q] = *P;
        r->poly[q].first = start;
        r->poly[q].n = (uint32_t)(r->ncor - start);
    }
    for (size_t i = 0; i < p->nsegin && !rc; i++) {
        const plc_segment *S = &p->segin[i];
        uint32_t *chain = NULL;
        size_t nch = 0, capch = 0;
        if (plc__grow((void **)&chain, &capch, 1, sizeof *chain)) {
            rc = PDR_ENOMEM;
            break;
        }
        chain[nch++] = S->v[0];
        rc = append_cut(p, c, S->v[0], S->v[1], &chain, &nch, &capch);
        if (!rc && plc__grow((void **)&chain, &capch, nch + 1, sizeof *chain))
            rc = PDR_ENOMEM;
        if (!rc)
            chain[nch++] = S->v[1];
        if (!rc && plc__grow((void **)&r->seg, &r->caps, r->nseg + nch - 1, sizeof *r->seg))
            rc = PDR_ENOMEM;
        for (size_t k = 0; !rc && k + 1 < nch; k++) {
            r->seg[r->nseg] = *S;
            r->seg[r->nseg].v[0] = chain[k];
            r->seg[r->nseg].v[1] = chain[k + 1];
            r->nseg++;
        }
        pr_free(chain);
    }
    if (rc)
        rebuilt_free(r);
    return rc;
}

/* Puts r into p (taking its arrays). */
static void commit(plc *p, struct rebuilt *r)
{
    pr_free(p->corners);
    p->corners = r->cor;
    p->ncorner = r->ncor;
    p->cap_corner = r->capc;
    memcpy(p->polys, r->poly, p->npoly * sizeof *p->polys);
    pr_free(r->poly);
    if (p->nsegin) {
        pr_free(p->segin);
        p->segin = r->seg;
        p->nsegin = r->nseg;
        p->cap_segin = r->caps;
    } else {
        pr_free(r->seg);
    }
    memset(r, 0, sizeof *r);
}

int plc_small_angles(const plc *p)
{
    if (!p->seg_mindih || !p->v_minang)
        return 1;
    for (size_t s = 0; s < p->nseg; s++)
        if (p->seg_mindih[s] < FM_SHARP_DIH)
            return 1;
    for (size_t v = 0; v < p->nv; v++)
        if (p->v_minang[v] < FM_ACUTE_ANG)
            return 1;
    return 0;
}

int plc_split_long(plc *p, double B, size_t max_pieces, plc_split_stats *st, pdr_diag *diag)
{
    memset(st, 0, sizeof *st);
    if (!p->derived || !p->ftri || !p->seg_mindih || !p->v_minang || !(B > 1.0) ||
        max_pieces < 2)
        return PDR_EINVAL;
    struct cuts c = {pr_calloc(p->nseg ? p->nseg : 1, sizeof *c.first),
                     pr_calloc(p->nseg ? p->nseg : 1, sizeof *c.cnt)};
    if (!c.first || !c.cnt) {
        pr_free(c.first);
        pr_free(c.cnt);
        return PDR_ENOMEM;
    }
    /* the counts first: the PLC's derived data goes with the first vertex
     * added */
    size_t total = 0;
    for (size_t s = 0; s < p->nseg; s++) {
        size_t n = pieces_of(p, s, B, max_pieces);
        if (n < 2)
            continue;
        c.cnt[s] = (uint32_t)(n - 1);
        total += n - 1;
        st->segments++;
    }
    int rc = 0;
    if (total && p->nv + total >= UINT32_MAX - 1)
        rc = PDR_ELIMIT;
    /* new vertex positions, taken before the derived data is dropped */
    double(*xyz)[3] = total && !rc ? pr_malloc(total * sizeof *xyz) : NULL;
    if (total && !rc && !xyz)
        rc = PDR_ENOMEM;
    size_t k = 0;
    for (size_t s = 0; s < p->nseg && !rc && total; s++) {
        if (!c.cnt[s])
            continue;
        c.first[s] = (uint32_t)(p->nv + k);
        const double *a = p->xyz[p->segs[s].v[0]], *b = p->xyz[p->segs[s].v[1]];
        double n = (double)c.cnt[s] + 1.0;
        for (uint32_t j = 1; j <= c.cnt[s]; j++, k++)
            for (int d = 0; d < 3; d++)
                xyz[k][d] = a[d] + ((double)j / n) * (b[d] - a[d]);
    }
    /* the polygons and explicit segments, built aside while p->segs
     * still says which edges are cut; then the vertices (which drop the
     * derived data), then the polygons that use them */
    struct rebuilt rb;
    memset(&rb, 0, sizeof rb);
    if (!rc && total)
        rc = rebuild(p, &c, &rb);
    for (size_t i = 0; i < total && !rc; i++)
        rc = plc_add_vertex(p, xyz[i], 0, NULL);
    if (!rc && total)
        commit(p, &rb);
    rebuilt_free(&rb);
    pr_free(xyz);
    pr_free(c.first);
    pr_free(c.cnt);
    if (rc || !total)
        return rc;
    st->points = total;
    /* The points lie on segments that are edges of facets already
     * validated: no new crossing is possible. */
    p->skip_intersections = 1;
    rc = plc_validate(p, diag);
    p->skip_intersections = 0;
    if (!rc)
        rc = fm_features(p, NULL);
    return rc;
}
