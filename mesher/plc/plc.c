/* plc/plc.c -- the PLC container: building, derived data, .poly output. */
#include "config.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "base/outfile.h"
#include "base/pdr_util.h"
#include "plc/plc.h"
#include "plc/plc_int.h"

int plc__grow(void **arr, size_t *cap, size_t need, size_t elsize)
{
    if (need <= *cap)
        return 0;
    size_t n = *cap ? *cap : 16;
    while (n < need) {
        if (n > SIZE_MAX / 2 / elsize)
            return PDR_ENOMEM;
        n *= 2;
    }
    void *q = pr_realloc(*arr, n * elsize);
    if (!q)
        return PDR_ENOMEM;
    *arr = q;
    *cap = n;
    return 0;
}

#define GROW(p, field, cap, need)                                            \
    plc__grow((void **)&(p)->field, &(p)->cap, (need), sizeof *(p)->field)

static char *dup_str(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = pr_malloc(n);
    if (d)
        memcpy(d, s, n);
    return d;
}

int plc_init(plc *p, const char *path)
{
    memset(p, 0, sizeof *p);
    p->planar_tol = PLC_PLANAR_TOL;
    p->base = 1;
    p->path = dup_str(path ? path : "");
    p->vfile = dup_str(path ? path : "");
    if (!p->path || !p->vfile) {
        plc_free(p);
        return PDR_ENOMEM;
    }
    return 0;
}

void plc__drop_derived(plc *p)
{
    pr_free(p->segs);
    pr_free(p->seg_fstart);
    pr_free(p->seg_facets);
    pr_free(p->v_sstart);
    pr_free(p->v_segs);
    pr_free(p->v_fstart);
    pr_free(p->v_facets);
    pr_free(p->ftri_start);
    pr_free(p->ftri);
    pr_free(p->seg_mindih);
    pr_free(p->v_minang);
    p->seg_mindih = p->v_minang = NULL;
    p->segs = NULL;
    p->seg_fstart = p->v_sstart = p->v_fstart = p->ftri_start = NULL;
    p->seg_facets = p->v_segs = p->v_facets = NULL;
    p->ftri = NULL;
    p->nseg = 0;
    p->derived = 0;
}

int plc__number_vertex(plc *p, uint32_t v, long num)
{
    if (plc__grow((void **)&p->vnum, &p->cap_vnum, (size_t)v + 1, sizeof *p->vnum))
        return PDR_ENOMEM;
    for (size_t k = p->nvnum; k < v; k++)
        p->vnum[k] = (long)k + p->base;
    p->vnum[v] = num + p->base;
    p->nvnum = (size_t)v + 1;
    return 0;
}

void plc_free(plc *p)
{
    plc__drop_derived(p);
    pr_free(p->path);
    pr_free(p->vfile);
    pr_free(p->xyz);
    pr_free(p->vmarker);
    pr_free(p->vattr);
    pr_free(p->vline);
    pr_free(p->vnum);
    pr_free(p->corners);
    pr_free(p->polys);
    pr_free(p->facets);
    pr_free(p->fholes);
    pr_free(p->segin);
    pr_free(p->holes);
    pr_free(p->regions);
    double tol = p->planar_tol;
    memset(p, 0, sizeof *p);
    p->planar_tol = tol ? tol : PLC_PLANAR_TOL;
}

int plc_add_vertex(plc *p, const double xyz[3], long line, uint32_t *index)
{
    if (p->nv >= UINT32_MAX - 1)
        return PDR_ELIMIT;
    if (p->nv == p->cap_v) {
        /* All per-vertex arrays share the capacity cap_v. */
        size_t cap = p->cap_v ? 2 * p->cap_v : 64;
        double(*xyz2)[3] = pr_realloc(p->xyz, cap * sizeof *xyz2);
        if (!xyz2)
            return PDR_ENOMEM;
        p->xyz = xyz2;
        long *vl = pr_realloc(p->vline, cap * sizeof *vl);
        if (!vl)
            return PDR_ENOMEM;
        p->vline = vl;
        if (p->vmarker) {
            int *vm = pr_realloc(p->vmarker, cap * sizeof *vm);
            if (!vm)
                return PDR_ENOMEM;
            p->vmarker = vm;
        }
        if (p->vattr) {
            double *va = pr_realloc(p->vattr, cap * p->nvattr * sizeof *va);
            if (!va)
                return PDR_ENOMEM;
            p->vattr = va;
        }
        p->cap_v = cap;
    }
    plc__drop_derived(p);
    memcpy(p->xyz[p->nv], xyz, sizeof p->xyz[0]);
    p->vline[p->nv] = line;
    if (p->vmarker)
        p->vmarker[p->nv] = 0;
    if (p->vattr)
        for (size_t k = 0; k < p->nvattr; k++)
            p->vattr[p->nv * p->nvattr + k] = 0.0;
    if (index)
        *index = (uint32_t)p->nv;
    p->nv++;
    return 0;
}

int plc_enable_vmarkers(plc *p)
{
    if (p->vmarker)
        return 0;
    p->vmarker = pr_calloc(p->cap_v ? p->cap_v : 1, sizeof *p->vmarker);
    return p->vmarker ? 0 : PDR_ENOMEM;
}

int plc__enable_vattr(plc *p, size_t nattr)
{
    if (p->vattr || nattr == 0)
        return 0;
    p->nvattr = nattr;
    p->vattr = pr_calloc((p->cap_v ? p->cap_v : 1) * nattr, sizeof *p->vattr);
    return p->vattr ? 0 : PDR_ENOMEM;
}

int plc_begin_facet(plc *p, int marker, long line)
{
    if (GROW(p, facets, cap_facet, p->nfacet + 1))
        return PDR_ENOMEM;
    plc__drop_derived(p);
    plc_facet *f = &p->facets[p->nfacet++];
    memset(f, 0, sizeof *f);
    f->poly_first = p->npoly;
    f->hole_first = p->nfhole;
    f->marker = marker;
    f->line = line;
    return 0;
}

int plc_add_polygon(plc *p, const uint32_t *corners, uint32_t n, long line)
{
    if (!p->nfacet || n == 0)
        return PDR_EINVAL;
    for (uint32_t i = 0; i < n; i++)
        if (corners[i] >= p->nv)
            return PDR_EINVAL;
    if (GROW(p, polys, cap_poly, p->npoly + 1) ||
        GROW(p, corners, cap_corner, p->ncorner + n))
        return PDR_ENOMEM;
    plc__drop_derived(p);
    plc_polygon *q = &p->polys[p->npoly++];
    q->first = p->ncorner;
    q->n = n;
    q->line = line;
    memcpy(p->corners + p->ncorner, corners, n * sizeof *corners);
    p->ncorner += n;
    p->facets[p->nfacet - 1].npoly++;
    return 0;
}

int plc_add_facet_hole(plc *p, const double xyz[3], long line)
{
    if (!p->nfacet)
        return PDR_EINVAL;
    if (GROW(p, fholes, cap_fhole, p->nfhole + 1))
        return PDR_ENOMEM;
    plc__drop_derived(p);
    memcpy(p->fholes[p->nfhole].xyz, xyz, sizeof p->fholes[0].xyz);
    p->fholes[p->nfhole++].line = line;
    p->facets[p->nfacet - 1].nhole++;
    return 0;
}

int plc_add_segment(plc *p, uint32_t a, uint32_t b, int marker, long line)
{
    if (a >= p->nv || b >= p->nv)
        return PDR_EINVAL;
    if (GROW(p, segin, cap_segin, p->nsegin + 1))
        return PDR_ENOMEM;
    plc__drop_derived(p);
    plc_segment *s = &p->segin[p->nsegin++];
    s->v[0] = a;
    s->v[1] = b;
    s->marker = marker;
    s->line = line;
    return 0;
}

int plc_add_hole(plc *p, const double xyz[3], long line)
{
    if (GROW(p, holes, cap_hole, p->nhole + 1))
        return PDR_ENOMEM;
    memcpy(p->holes[p->nhole].xyz, xyz, sizeof p->holes[0].xyz);
    p->holes[p->nhole++].line = line;
    return 0;
}

int plc_add_region(plc *p, const double xyz[3], double attr, double maxvol,
                   long line)
{
    if (GROW(p, regions, cap_region, p->nregion + 1))
        return PDR_ENOMEM;
    plc_region *r = &p->regions[p->nregion++];
    memcpy(r->xyz, xyz, sizeof r->xyz);
    r->attr = attr;
    r->maxvol = maxvol;
    r->line = line;
    return 0;
}

/* ----------------------------------------------------------- derived data */

void plc__newell_ring(const double (*xyz)[3], const uint32_t *c, uint32_t n, double nrm[3],
                      double cen[3])
{
    nrm[0] = nrm[1] = nrm[2] = 0.0;
    cen[0] = cen[1] = cen[2] = 0.0;
    for (uint32_t i = 0; i < n; i++) {
        const double *a = xyz[c[i]];
        const double *b = xyz[c[(i + 1) % n]];
        /* Newell's method: the sum over the edges of (a - b) x (a + b)
         * components gives twice the area vector of the polygon, for any
         * simple polygon, and is well defined even if it is nearly
         * degenerate or slightly non-planar. */
        nrm[0] += (a[1] - b[1]) * (a[2] + b[2]);
        nrm[1] += (a[2] - b[2]) * (a[0] + b[0]);
        nrm[2] += (a[0] - b[0]) * (a[1] + b[1]);
        for (int k = 0; k < 3; k++)
            cen[k] += a[k];
    }
    for (int k = 0; k < 3; k++)
        cen[k] /= n;
}

void plc__newell(const plc *p, const plc_polygon *q, double n[3], double c[3])
{
    plc__newell_ring((const double(*)[3])p->xyz, p->corners + q->first, q->n, n, c);
}

/* Computes each facet's plane from its polygon of largest area. */
static int derive_planes(plc *p, pdr_diag *diag)
{
    int rc = 0;
    for (size_t f = 0; f < p->nfacet; f++) {
        plc_facet *fa = &p->facets[f];
        double best = 0.0, bn[3] = {0, 0, 0}, bc[3] = {0, 0, 0};
        for (size_t k = 0; k < fa->npoly; k++) {
            const plc_polygon *q = &p->polys[fa->poly_first + k];
            if (q->n < 3)
                continue;
            double n[3], c[3];
            plc__newell(p, q, n, c);
            double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            if (len > best) {
                best = len;
                memcpy(bn, n, sizeof bn);
                memcpy(bc, c, sizeof bc);
            }
        }
        if (!(best > 0.0)) {
            pdr_diag_add(diag, p->path, fa->line,
                         "facet %zu has no polygon of nonzero area", f + 1);
            rc = PDR_EGEOMETRY;
            continue;
        }
        int axis = 0;
        for (int k = 0; k < 3; k++) {
            fa->normal[k] = bn[k] / best;
            if (fabs(fa->normal[k]) > fabs(fa->normal[axis]))
                axis = k;
        }
        fa->axis = axis;
        fa->offset = fa->normal[0] * bc[0] + fa->normal[1] * bc[1] +
                     fa->normal[2] * bc[2];
        fa->bend = 0.0;
        for (size_t k = 0; k < fa->npoly; k++) {
            const plc_polygon *q = &p->polys[fa->poly_first + k];
            for (uint32_t i = 0; i < q->n; i++) {
                const double *x = p->xyz[p->corners[q->first + i]];
                double d = fabs(fa->normal[0] * x[0] + fa->normal[1] * x[1] +
                                fa->normal[2] * x[2] - fa->offset);
                fa->bend = d > fa->bend ? d : fa->bend;
            }
        }
    }
    return rc;
}

int plc_facet_bent(const plc *p, size_t f)
{
    if (!(p->planar_tol > PLC_PLANAR_TOL))
        return 0;
    double s = 0;
    for (int k = 0; k < 3; k++)
        s += (p->bbox[1][k] - p->bbox[0][k]) * (p->bbox[1][k] - p->bbox[0][k]);
    return p->facets[f].bend > PLC_PLANAR_TOL * sqrt(s);
}

double plc_facet_proj_area(const plc *p, size_t f, const double *a, const double *b,
                           const double *c)
{
    double u[3], v[3], n[3];
    for (int k = 0; k < 3; k++) {
        u[k] = b[k] - a[k];
        v[k] = c[k] - a[k];
    }
    n[0] = u[1] * v[2] - u[2] * v[1];
    n[1] = u[2] * v[0] - u[0] * v[2];
    n[2] = u[0] * v[1] - u[1] * v[0];
    const double *N = p->facets[f].normal;
    return 0.5 * fabs(n[0] * N[0] + n[1] * N[1] + n[2] * N[2]);
}

struct edge_rec {
    uint32_t a, b;  /* a < b */
    uint32_t facet; /* UINT32_MAX for an explicit segment */
    uint32_t src;   /* explicit segment index, or 0 */
};

static int cmp_edge_rec(const void *x, const void *y)
{
    const struct edge_rec *e = x, *f = y;
    if (e->a != f->a)
        return e->a < f->a ? -1 : 1;
    if (e->b != f->b)
        return e->b < f->b ? -1 : 1;
    if (e->facet != f->facet)
        return e->facet < f->facet ? -1 : 1;
    return 0;
}

static void put_edge(struct edge_rec *r, size_t *n, uint32_t a, uint32_t b,
                     uint32_t facet, uint32_t src)
{
    if (a == b)
        return; /* a repeated corner; plc_validate reports it */
    r[*n].a = a < b ? a : b;
    r[*n].b = a < b ? b : a;
    r[*n].facet = facet;
    r[*n].src = src;
    (*n)++;
}

static int derive_segments(plc *p)
{
    size_t cap = p->nsegin;
    for (size_t k = 0; k < p->npoly; k++)
        cap += p->polys[k].n;
    struct edge_rec *r = pr_malloc((cap ? cap : 1) * sizeof *r);
    if (!r)
        return PDR_ENOMEM;
    size_t n = 0;
    for (size_t f = 0; f < p->nfacet; f++) {
        const plc_facet *fa = &p->facets[f];
        for (size_t k = 0; k < fa->npoly; k++) {
            const plc_polygon *q = &p->polys[fa->poly_first + k];
            const uint32_t *c = p->corners + q->first;
            if (q->n == 2)
                put_edge(r, &n, c[0], c[1], (uint32_t)f, 0);
            else if (q->n >= 3)
                for (uint32_t i = 0; i < q->n; i++)
                    put_edge(r, &n, c[i], c[(i + 1) % q->n], (uint32_t)f, 0);
        }
    }
    for (size_t s = 0; s < p->nsegin; s++)
        put_edge(r, &n, p->segin[s].v[0], p->segin[s].v[1], UINT32_MAX,
                 (uint32_t)s);
    qsort(r, n, sizeof *r, cmp_edge_rec);

    size_t nseg = 0, nsf = 0;
    for (size_t i = 0; i < n; i++) {
        int new_seg = i == 0 || r[i].a != r[i - 1].a || r[i].b != r[i - 1].b;
        nseg += new_seg;
        if (r[i].facet != UINT32_MAX &&
            (new_seg || r[i].facet != r[i - 1].facet))
            nsf++;
    }
    p->segs = pr_malloc((nseg ? nseg : 1) * sizeof *p->segs);
    p->seg_fstart = pr_malloc((nseg + 1) * sizeof *p->seg_fstart);
    p->seg_facets = pr_malloc((nsf ? nsf : 1) * sizeof *p->seg_facets);
    if (!p->segs || !p->seg_fstart || !p->seg_facets) {
        pr_free(r);
        return PDR_ENOMEM;
    }
    size_t s = 0, sf = 0;
    for (size_t i = 0; i < n; i++) {
        int new_seg = i == 0 || r[i].a != r[i - 1].a || r[i].b != r[i - 1].b;
        if (new_seg) {
            p->seg_fstart[s] = sf;
            plc_segment *sg = &p->segs[s++];
            sg->v[0] = r[i].a;
            sg->v[1] = r[i].b;
            sg->marker = 0;
            sg->line = 0;
        }
        plc_segment *sg = &p->segs[s - 1];
        if (r[i].facet == UINT32_MAX) {
            sg->marker = p->segin[r[i].src].marker;
            sg->line = p->segin[r[i].src].line;
        } else if (new_seg || r[i].facet != r[i - 1].facet) {
            p->seg_facets[sf++] = r[i].facet;
        }
    }
    p->seg_fstart[s] = sf;
    p->nseg = nseg;
    pr_free(r);
    return 0;
}

static int derive_incidence(plc *p)
{
    size_t nv = p->nv;
    p->v_sstart = pr_calloc(nv + 1, sizeof *p->v_sstart);
    p->v_fstart = pr_calloc(nv + 1, sizeof *p->v_fstart);
    if (!p->v_sstart || !p->v_fstart)
        return PDR_ENOMEM;
    for (size_t s = 0; s < p->nseg; s++) {
        p->v_sstart[p->segs[s].v[0] + 1]++;
        p->v_sstart[p->segs[s].v[1] + 1]++;
    }
    for (size_t v = 0; v < nv; v++)
        p->v_sstart[v + 1] += p->v_sstart[v];
    p->v_segs = pr_malloc((p->v_sstart[nv] ? p->v_sstart[nv] : 1) * sizeof *p->v_segs);
    size_t *fill = pr_malloc((nv ? nv : 1) * sizeof *fill);
    if (!p->v_segs || !fill) {
        pr_free(fill);
        return PDR_ENOMEM;
    }
    memcpy(fill, p->v_sstart, nv * sizeof *fill);
    for (size_t s = 0; s < p->nseg; s++)
        for (int e = 0; e < 2; e++)
            p->v_segs[fill[p->segs[s].v[e]]++] = (uint32_t)s;

    /* Facet incidence: (vertex, facet) pairs, sorted and made unique. */
    size_t npair = p->ncorner;
    uint64_t *pairs = pr_malloc((npair ? npair : 1) * sizeof *pairs);
    if (!pairs) {
        pr_free(fill);
        return PDR_ENOMEM;
    }
    size_t m = 0;
    for (size_t f = 0; f < p->nfacet; f++) {
        const plc_facet *fa = &p->facets[f];
        for (size_t k = 0; k < fa->npoly; k++) {
            const plc_polygon *q = &p->polys[fa->poly_first + k];
            for (uint32_t i = 0; i < q->n; i++)
                pairs[m++] = (uint64_t)p->corners[q->first + i] << 32 | f;
        }
    }
    /* Sorting the 64-bit keys orders them by vertex, then facet. */
    qsort(pairs, m, sizeof *pairs, plc__cmp_u64);
    size_t u = 0;
    for (size_t i = 0; i < m; i++)
        if (i == 0 || pairs[i] != pairs[i - 1])
            pairs[u++] = pairs[i];
    p->v_facets = pr_malloc((u ? u : 1) * sizeof *p->v_facets);
    if (!p->v_facets) {
        pr_free(pairs);
        pr_free(fill);
        return PDR_ENOMEM;
    }
    for (size_t i = 0; i < u; i++) {
        p->v_fstart[(pairs[i] >> 32) + 1]++;
        p->v_facets[i] = (uint32_t)(pairs[i] & 0xffffffffu);
    }
    for (size_t v = 0; v < nv; v++)
        p->v_fstart[v + 1] += p->v_fstart[v];
    pr_free(pairs);
    pr_free(fill);
    /* Segments around a vertex are listed in segment order already (the
     * fill loop runs over s increasing); keep them sorted for lookups. */
    for (size_t v = 0; v < nv; v++)
        qsort(p->v_segs + p->v_sstart[v], p->v_sstart[v + 1] - p->v_sstart[v],
              sizeof *p->v_segs, pdr_cmp_u32);
    return 0;
}

int plc__cmp_u64(const void *x, const void *y)
{
    uint64_t a = *(const uint64_t *)x, b = *(const uint64_t *)y;
    return a < b ? -1 : a > b;
}

int plc_derive(plc *p, pdr_diag *diag)
{
    if (p->derived)
        return 0;
    plc__drop_derived(p);
    for (int k = 0; k < 3; k++) {
        p->bbox[0][k] = p->nv ? p->xyz[0][k] : 0.0;
        p->bbox[1][k] = p->nv ? p->xyz[0][k] : 0.0;
    }
    for (size_t v = 1; v < p->nv; v++)
        for (int k = 0; k < 3; k++) {
            if (p->xyz[v][k] < p->bbox[0][k])
                p->bbox[0][k] = p->xyz[v][k];
            if (p->xyz[v][k] > p->bbox[1][k])
                p->bbox[1][k] = p->xyz[v][k];
        }
    int rc = derive_planes(p, diag);
    if (rc)
        return rc;
    if ((rc = derive_segments(p)) || (rc = derive_incidence(p))) {
        plc__drop_derived(p);
        pdr_diag_add(diag, p->path, 0, "out of memory");
        return rc;
    }
    p->derived = 1;
    return 0;
}

/* ---------------------------------------------------------- .poly output */

int plc_write_poly(const plc *p, const char *path, pdr_diag *diag)
{
    outfile of;
    int rc = outfile_open(&of, path, diag);
    if (rc)
        return rc;
    FILE *f = of.f;
    fprintf(f, "# PLC written by pdr %s\n", PACKAGE_VERSION);
    fprintf(f, "# part 1: vertices\n%zu 3 %zu %d\n", p->nv, p->vattr ? p->nvattr : 0,
            p->vmarker ? 1 : 0);
    for (size_t v = 0; v < p->nv; v++) {
        fprintf(f, "%zu %.17g %.17g %.17g", v + 1, p->xyz[v][0], p->xyz[v][1],
                p->xyz[v][2]);
        if (p->vattr)
            for (size_t k = 0; k < p->nvattr; k++)
                fprintf(f, " %.17g", p->vattr[v * p->nvattr + k]);
        if (p->vmarker)
            fprintf(f, " %d", p->vmarker[v]);
        fputc('\n', f);
    }
    /* Free segments are written as facets made of one 2-corner polygon,
     * which is how TetGen's .poly expresses them. */
    fprintf(f, "# part 2: facets\n%zu 1\n", p->nfacet + p->nsegin);
    for (size_t k = 0; k < p->nfacet; k++) {
        const plc_facet *fa = &p->facets[k];
        fprintf(f, "%zu %zu %d  # facet %zu\n", fa->npoly, fa->nhole, fa->marker,
                k + 1);
        for (size_t j = 0; j < fa->npoly; j++) {
            const plc_polygon *q = &p->polys[fa->poly_first + j];
            fprintf(f, "%u", q->n);
            for (uint32_t i = 0; i < q->n; i++)
                fprintf(f, " %u", p->corners[q->first + i] + 1);
            fputc('\n', f);
        }
        for (size_t j = 0; j < fa->nhole; j++) {
            const double *h = p->fholes[fa->hole_first + j].xyz;
            fprintf(f, "%zu %.17g %.17g %.17g\n", j + 1, h[0], h[1], h[2]);
        }
    }
    for (size_t s = 0; s < p->nsegin; s++)
        fprintf(f, "1 0 %d\n2 %u %u\n", p->segin[s].marker, p->segin[s].v[0] + 1,
                p->segin[s].v[1] + 1);
    fprintf(f, "# part 3: volume holes\n%zu\n", p->nhole);
    for (size_t h = 0; h < p->nhole; h++)
        fprintf(f, "%zu %.17g %.17g %.17g\n", h + 1, p->holes[h].xyz[0],
                p->holes[h].xyz[1], p->holes[h].xyz[2]);
    fprintf(f, "# part 4: regions (x y z attribute maxvolume)\n%zu\n", p->nregion);
    for (size_t r = 0; r < p->nregion; r++) {
        const plc_region *g = &p->regions[r];
        fprintf(f, "%zu %.17g %.17g %.17g %.17g %.17g\n", r + 1, g->xyz[0],
                g->xyz[1], g->xyz[2], g->attr, g->maxvol > 0 ? g->maxvol : -1.0);
    }
    return outfile_commit(&of, diag);
}
