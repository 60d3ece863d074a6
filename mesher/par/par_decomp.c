/* par/par_decomp.c -- partition of Mo by METIS, the per-PE submesh
 * messages, and the PLC and options messages (see par/par_decomp.h). */
#include "config.h"

#include <limits.h>
#include <math.h>
#include <metis.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "par/par_decomp.h"
#include "plc/fm.h"
#include "par/par_wire.h"

/* ------------------------------------------------------------- partition */

/* Part of a live ghost: that of the real tetrahedron across its hull face
 * (part 0 if there is none, which a closed mesh never has). */
static uint32_t ghost_part(const tm_mesh *m, uint32_t t, const uint32_t *part)
{
    int k = tm_ghost_slot(m, t);
    tm_link l = m->tets[t].n[k];
    if (tm_is_special(l))
        return 0;
    uint32_t u = tm_ltet(l);
    if (u >= m->nslots || tm_is_dead(m, u) || tm_is_ghost(m, u))
        return 0;
    return part[u];
}

/* The real neighbour across face i of t, or TM_NONE. */
static uint32_t real_neighbour(const tm_mesh *m, uint32_t t, int i)
{
    tm_link l = m->tets[t].n[i];
    if (tm_is_special(l))
        return TM_NONE;
    uint32_t u = tm_ltet(l);
    if (u >= m->nslots || tm_is_dead(m, u) || tm_is_ghost(m, u))
        return TM_NONE;
    return u;
}

/* Runs METIS on the dual graph of the n real tetrahedra listed in real[]
 * (dense[t] their index) and stores each one's part in part[slot]. */
static int metis_parts(const tm_mesh *m, const uint32_t *real, const uint32_t *dense, size_t n,
                       uint32_t nparts, int seed, uint32_t *part)
{
    if (4 * n > (size_t)((((uint64_t)1) << (PDR_METIS_IDXTYPEWIDTH - 1)) - 1))
        return PDR_ELIMIT;
    idx_t *xadj = pr_malloc((n + 1) * sizeof *xadj);
    idx_t *adj = pr_malloc((n ? 4 * n : 1) * sizeof *adj);
    idx_t *where = pr_malloc((n ? n : 1) * sizeof *where);
    int rc = 0;
    if (!xadj || !adj || !where) {
        rc = PDR_ENOMEM;
        goto out;
    }
    size_t na = 0;
    for (size_t k = 0; k < n; k++) {
        xadj[k] = (idx_t)na;
        for (int i = 0; i < 4; i++) {
            uint32_t u = real_neighbour(m, real[k], i);
            if (u != TM_NONE)
                adj[na++] = (idx_t)dense[u];
        }
    }
    xadj[n] = (idx_t)na;
    idx_t options[METIS_NOPTIONS];
    METIS_SetDefaultOptions(options);
    options[METIS_OPTION_SEED] = (idx_t)seed;
    options[METIS_OPTION_NUMBERING] = 0;
    idx_t nv = (idx_t)n, ncon = 1, np = (idx_t)nparts, cut = 0;
    int st = METIS_PartGraphKway(&nv, &ncon, xadj, adj, NULL, NULL, NULL, &np, NULL, NULL,
                                 options, &cut, where);
    if (st != METIS_OK) {
        rc = st == METIS_ERROR_MEMORY ? PDR_ENOMEM : PDR_EINVAL;
        goto out;
    }
    for (size_t k = 0; k < n; k++) {
        if (where[k] < 0 || (uint64_t)where[k] >= nparts) {
            rc = PDR_EINVAL;
            goto out;
        }
        part[real[k]] = (uint32_t)where[k];
    }
out:
    pr_free(xadj);
    pr_free(adj);
    pr_free(where);
    return rc;
}

int par_decomp_partition(const ref_mesher *mo, uint32_t nparts, int seed, uint32_t *part,
                         size_t *edgecut)
{
    const tm_mesh *m = &mo->m;
    if (nparts == 0)
        return PDR_EINVAL;
    uint32_t *real = pr_malloc(((size_t)m->nslots ? m->nslots : 1) * sizeof *real);
    uint32_t *dense = pr_malloc(((size_t)m->nslots ? m->nslots : 1) * sizeof *dense);
    if (!real || !dense) {
        pr_free(real);
        pr_free(dense);
        return PDR_ENOMEM;
    }
    size_t n = 0;
    for (uint32_t t = 0; t < m->nslots; t++) {
        part[t] = PAR_PE_NONE;
        dense[t] = UINT32_MAX;
        if (!tm_is_dead(m, t) && !tm_is_ghost(m, t)) {
            dense[t] = (uint32_t)n;
            real[n++] = t;
        }
    }
    int rc = 0;
    if (n == 0) {
        rc = PDR_EINVAL;
    } else if (nparts == 1) {
        for (size_t k = 0; k < n; k++)
            part[real[k]] = 0;
    } else if (n <= nparts) {
        /* METIS wants fewer parts than vertices: one tetrahedron each */
        for (size_t k = 0; k < n; k++)
            part[real[k]] = (uint32_t)k;
    } else {
        rc = metis_parts(m, real, dense, n, nparts, seed, part);
    }
    pr_free(real);
    pr_free(dense);
    if (rc)
        return rc;
    size_t cut = 0;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t))
            continue;
        if (tm_is_ghost(m, t)) {
            part[t] = ghost_part(m, t, part);
            continue;
        }
        for (int i = 0; i < 4; i++) {
            uint32_t u = real_neighbour(m, t, i);
            cut += u != TM_NONE && u > t && part[u] != part[t];
        }
    }
    /* Ghosts took their parts above in slot order; a ghost before its
     * real neighbour saw that neighbour's final part already, since real
     * parts were all set first. */
    if (edgecut)
        *edgecut = cut;
    return 0;
}

/* ---------------------------------------------------------------- encode */

int par_decomp_encode_pe(pr_buf *b, const ref_mesher *mo, const uint32_t *part, uint32_t size,
                         uint32_t pe)
{
    const tm_mesh *m = &mo->m;
    if (size == 0 || pe >= size || size - 1 > PR_GID_RANK_MAX)
        return PDR_EINVAL;
    size_t nt = 0;
    for (uint32_t t = 0; t < m->nslots; t++)
        nt += !tm_is_dead(m, t) && part[t] % size == pe;
    if (nt > PR_MAX_TETS)
        return PDR_ELIMIT;
    uint32_t *tets = pr_malloc((nt ? nt : 1) * sizeof *tets);
    uint32_t *fpe = pr_malloc((nt ? 4 * nt : 1) * sizeof *fpe);
    uint64_t *gid = pr_malloc((size_t)m->nv * sizeof *gid);
    if (!tets || !fpe || !gid) {
        pr_free(tets);
        pr_free(fpe);
        pr_free(gid);
        return PDR_ENOMEM;
    }
    gid[0] = PAR_GID_INF;
    for (uint32_t v = 1; v < m->nv; v++)
        gid[v] = pr_gid_make(0, v);
    size_t k = 0;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t) || part[t] % size != pe)
            continue;
        for (int i = 0; i < 4; i++) {
            tm_link l = m->tets[t].n[i];
            uint32_t q = PAR_PE_NONE;
            if (!tm_is_special(l)) {
                uint32_t u = tm_ltet(l);
                if (u < m->nslots && !tm_is_dead(m, u) && part[u] % size != pe)
                    q = part[u] % size;
            }
            fpe[4 * k + (size_t)i] = q;
        }
        tets[k++] = t;
    }
    par_wire_src src = {mo,   gid,  tets, (uint32_t)nt, fpe, pe, pe, size,
                        pe == 0 ? (uint64_t)m->nv : 1};
    int rc = par_wire_encode(b, &src);
    pr_free(tets);
    pr_free(fpe);
    pr_free(gid);
    return rc;
}

void par_decomp_free(par_decomp *d)
{
    if (d->msg)
        for (uint32_t k = 0; k < d->size; k++)
            pr_buf_free(&d->msg[k]);
    pr_free(d->msg);
    pr_free(d->part);
    pr_free(d->tets);
    pr_free(d->ifaces);
    memset(d, 0, sizeof *d);
}

int par_decomp_run(const ref_mesher *mo, uint32_t size, uint32_t nparts, int seed,
                   par_decomp *out)
{
    const tm_mesh *m = &mo->m;
    memset(out, 0, sizeof *out);
    if (size == 0 || nparts == 0)
        return PDR_EINVAL;
    out->size = size;
    out->nparts = nparts;
    out->nslots = m->nslots;
    out->part = pr_malloc(((size_t)m->nslots ? m->nslots : 1) * sizeof *out->part);
    out->msg = pr_calloc(size, sizeof *out->msg);
    out->tets = pr_calloc(size, sizeof *out->tets);
    out->ifaces = pr_calloc(size, sizeof *out->ifaces);
    if (!out->part || !out->msg || !out->tets || !out->ifaces)
        return PDR_ENOMEM;
    int rc = par_decomp_partition(mo, nparts, seed, out->part, &out->edgecut);
    for (uint32_t pe = 0; pe < size && !rc; pe++)
        rc = par_decomp_encode_pe(&out->msg[pe], mo, out->part, size, pe);
    if (rc)
        return rc;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t))
            continue;
        uint32_t pe = out->part[t] % size;
        out->tets[pe]++;
        for (int i = 0; i < 4; i++) {
            tm_link l = m->tets[t].n[i];
            out->ifaces[pe] += !tm_is_special(l) && out->part[tm_ltet(l)] % size != pe;
        }
    }
    return 0;
}

/* ------------------------------------------------------------------- PLC */

#define PLC_VERSION 1u
#define OPTS_VERSION 3u
#define MAX_VATTR 4096u

/* A name as a wire string, or "" when it is not one. */
static void put_name(pr_buf *b, const char *s)
{
    size_t n = s ? strlen(s) : 0;
    if (!s || pr_str_check(s, n))
        n = 0;
    pr_put_str(b, n ? s : "", n);
}

static void put_point(pr_buf *b, const double x[3], long line)
{
    for (int c = 0; c < 3; c++)
        pr_put_f64(b, x[c]);
    pr_put_i64(b, line);
}

int par_decomp_plc_put(pr_buf *b, const plc *p)
{
    if (p->nv > UINT32_MAX - 1 || p->nfacet > UINT32_MAX || p->nsegin > UINT32_MAX ||
        p->nhole > UINT32_MAX || p->nregion > UINT32_MAX ||
        (p->vattr && p->nvattr > MAX_VATTR))
        return PDR_ELIMIT;
    size_t start = b->len;
    pr_put_u32(b, PAR_DECOMP_PLC_MAGIC);
    pr_put_u32(b, PLC_VERSION);
    put_name(b, p->path);
    put_name(b, p->vfile);
    pr_put_u8(b, p->base ? 1 : 0);
    pr_put_f64(b, p->planar_tol);
    pr_put_u32(b, (uint32_t)p->nv);
    for (size_t v = 0; v < p->nv; v++)
        put_point(b, p->xyz[v], p->vline ? p->vline[v] : 0);
    pr_put_u8(b, p->vmarker ? 1 : 0);
    for (size_t v = 0; v < p->nv && p->vmarker; v++)
        pr_put_i32(b, p->vmarker[v]);
    size_t na = p->vattr ? p->nvattr : 0;
    pr_put_u32(b, (uint32_t)na);
    for (size_t j = 0; j < p->nv * na; j++)
        pr_put_f64(b, p->vattr[j]);
    pr_put_u32(b, (uint32_t)p->nfacet);
    for (size_t f = 0; f < p->nfacet; f++) {
        const plc_facet *F = &p->facets[f];
        pr_put_i32(b, F->marker);
        pr_put_i64(b, F->line);
        pr_put_u32(b, (uint32_t)F->npoly);
        for (size_t q = F->poly_first; q < F->poly_first + F->npoly; q++) {
            const plc_polygon *P = &p->polys[q];
            pr_put_i64(b, P->line);
            pr_put_u32(b, P->n);
            pr_put_u32_array(b, p->corners + P->first, P->n);
        }
        pr_put_u32(b, (uint32_t)F->nhole);
        for (size_t h = F->hole_first; h < F->hole_first + F->nhole; h++)
            put_point(b, p->fholes[h].xyz, p->fholes[h].line);
    }
    pr_put_u32(b, (uint32_t)p->nsegin);
    for (size_t s = 0; s < p->nsegin; s++) {
        pr_put_u32(b, p->segin[s].v[0]);
        pr_put_u32(b, p->segin[s].v[1]);
        pr_put_i32(b, p->segin[s].marker);
        pr_put_i64(b, p->segin[s].line);
    }
    pr_put_u32(b, (uint32_t)p->nhole);
    for (size_t h = 0; h < p->nhole; h++)
        put_point(b, p->holes[h].xyz, p->holes[h].line);
    pr_put_u32(b, (uint32_t)p->nregion);
    for (size_t g = 0; g < p->nregion; g++) {
        const plc_region *R = &p->regions[g];
        for (int c = 0; c < 3; c++)
            pr_put_f64(b, R->xyz[c]);
        pr_put_f64(b, R->attr);
        pr_put_f64(b, R->maxvol);
        pr_put_i64(b, R->line);
    }
    if (b->err) {
        if (b->len >= start)
            b->len = start;
        return b->err == PR_ENOMEM ? PDR_ENOMEM : PDR_EINVAL;
    }
    return 0;
}

/* Reads a wire string into a new NUL-terminated string (*out, the
 * caller's). */
static int get_name(pr_reader *rd, char **out)
{
    uint16_t n;
    const uint8_t *s;
    *out = NULL;
    if (pr_get_u16(rd, &n) || pr_get_view(rd, &s, n) || pr_str_check((const char *)s, n))
        return PDR_EPARSE;
    *out = pr_malloc((size_t)n + 1);
    if (!*out)
        return PDR_ENOMEM;
    memcpy(*out, s, n);
    (*out)[n] = 0;
    return 0;
}

static int get_line(pr_reader *rd, long *line)
{
    int64_t x;
    if (pr_get_i64(rd, &x) || x < 0 || x > (int64_t)LONG_MAX)
        return PDR_EPARSE;
    *line = (long)x;
    return 0;
}

static int get_i32(pr_reader *rd, int *out)
{
    int32_t x;
    if (pr_get_i32(rd, &x))
        return PDR_EPARSE;
    *out = x;
    return 0;
}

/* n finite doubles. */
static int get_finite(pr_reader *rd, double *x, int n)
{
    for (int c = 0; c < n; c++)
        if (pr_get_f64(rd, &x[c]) || !isfinite(x[c]))
            return PDR_EPARSE;
    return 0;
}

static int get_point(pr_reader *rd, double x[3], long *line)
{
    int rc = get_finite(rd, x, 3);
    return rc ? rc : get_line(rd, line);
}

/* Converts a builder's code: a bad index is a malformed message. */
static int from_builder(int rc)
{
    return rc == PDR_EINVAL ? PDR_EPARSE : rc;
}

static int get_vertices(pr_reader *rd, plc *p)
{
    uint32_t nv, na;
    uint8_t has_marker;
    if (pr_get_count(rd, UINT32_MAX - 1, 32, &nv))
        return PDR_EPARSE;
    for (uint32_t v = 0; v < nv; v++) {
        double x[3];
        long line;
        int rc = get_point(rd, x, &line);
        if (!rc)
            rc = plc_add_vertex(p, x, line, NULL);
        if (rc)
            return from_builder(rc);
    }
    if (pr_get_u8(rd, &has_marker) || has_marker > 1)
        return PDR_EPARSE;
    if (has_marker) {
        if (rd->left / 4 < nv)
            return PDR_EPARSE;
        if (plc_enable_vmarkers(p))
            return PDR_ENOMEM;
        for (uint32_t v = 0; v < nv; v++)
            if (get_i32(rd, &p->vmarker[v]))
                return PDR_EPARSE;
    }
    if (pr_get_u32(rd, &na) || na > MAX_VATTR)
        return PDR_EPARSE;
    if (na && nv) {
        if (rd->left / 8 / na < nv)
            return PDR_EPARSE;
        /* plc.h: vattr holds nvattr values per vertex for cap_v vertices,
         * owned by the PLC and released by plc_free. */
        p->vattr = pr_calloc(p->cap_v * na, sizeof *p->vattr);
        if (!p->vattr)
            return PDR_ENOMEM;
        p->nvattr = na;
        for (size_t j = 0; j < (size_t)nv * na; j++)
            if (get_finite(rd, &p->vattr[j], 1))
                return PDR_EPARSE;
    }
    return 0;
}

static int get_facets(pr_reader *rd, plc *p)
{
    uint32_t nf;
    /* a facet is at least marker, line and two counts */
    if (pr_get_count(rd, UINT32_MAX, 20, &nf))
        return PDR_EPARSE;
    uint32_t *corner = NULL;
    size_t cap = 0;
    int rc = 0;
    for (uint32_t f = 0; f < nf && !rc; f++) {
        int marker;
        long line;
        uint32_t np, nh;
        if (get_i32(rd, &marker) || get_line(rd, &line) || pr_get_count(rd, UINT32_MAX, 12, &np)) {
            rc = PDR_EPARSE;
            break;
        }
        rc = plc_begin_facet(p, marker, line);
        for (uint32_t q = 0; q < np && !rc; q++) {
            uint32_t n;
            if (get_line(rd, &line) || pr_get_count(rd, UINT32_MAX, 4, &n) || n == 0) {
                rc = PDR_EPARSE;
                break;
            }
            if (n > cap) {
                uint32_t *c2 = pr_realloc(corner, (size_t)n * sizeof *c2);
                if (!c2) {
                    rc = PDR_ENOMEM;
                    break;
                }
                corner = c2;
                cap = n;
            }
            pr_get_u32_array(rd, corner, n);
            for (uint32_t c = 0; c < n && !rc; c++)
                if (corner[c] >= p->nv)
                    rc = PDR_EPARSE;
            if (!rc)
                rc = from_builder(plc_add_polygon(p, corner, n, line));
        }
        if (!rc && pr_get_count(rd, UINT32_MAX, 32, &nh))
            rc = PDR_EPARSE;
        for (uint32_t h = 0; h < nh && !rc; h++) {
            double x[3];
            rc = get_point(rd, x, &line);
            if (!rc)
                rc = from_builder(plc_add_facet_hole(p, x, line));
        }
    }
    pr_free(corner);
    return rc;
}

static int get_rest(pr_reader *rd, plc *p)
{
    uint32_t n;
    if (pr_get_count(rd, UINT32_MAX, 20, &n))
        return PDR_EPARSE;
    for (uint32_t s = 0; s < n; s++) {
        uint32_t a, c;
        int marker;
        long line;
        if (pr_get_u32(rd, &a) || pr_get_u32(rd, &c) || get_i32(rd, &marker) ||
            get_line(rd, &line) || a >= p->nv || c >= p->nv)
            return PDR_EPARSE;
        int rc = plc_add_segment(p, a, c, marker, line);
        if (rc)
            return from_builder(rc);
    }
    if (pr_get_count(rd, UINT32_MAX, 32, &n))
        return PDR_EPARSE;
    for (uint32_t h = 0; h < n; h++) {
        double x[3];
        long line;
        int rc = get_point(rd, x, &line);
        if (!rc)
            rc = from_builder(plc_add_hole(p, x, line));
        if (rc)
            return rc;
    }
    if (pr_get_count(rd, UINT32_MAX, 48, &n))
        return PDR_EPARSE;
    for (uint32_t g = 0; g < n; g++) {
        double x[5];
        long line;
        if (get_finite(rd, x, 5) || get_line(rd, &line))
            return PDR_EPARSE;
        int rc = plc_add_region(p, x, x[3], x[4], line);
        if (rc)
            return from_builder(rc);
    }
    return 0;
}

int par_decomp_plc_decode(const void *msg, size_t len, plc *out, pdr_diag *diag)
{
    memset(out, 0, sizeof *out);
    pr_reader rd;
    pr_reader_init(&rd, msg, len);
    uint32_t magic = 0, version = 0;
    pr_get_u32(&rd, &magic);
    pr_get_u32(&rd, &version);
    if (rd.err || magic != PAR_DECOMP_PLC_MAGIC || version != PLC_VERSION)
        return PDR_EPARSE;
    char *path = NULL, *vfile = NULL;
    int rc = get_name(&rd, &path);
    if (!rc)
        rc = get_name(&rd, &vfile);
    if (!rc)
        rc = plc_init(out, path);
    pr_free(path);
    if (rc) {
        pr_free(vfile);
        return rc;
    }
    pr_free(out->vfile);
    out->vfile = vfile;
    uint8_t base = 0;
    double tol = 0;
    if (pr_get_u8(&rd, &base) || base > 1 || pr_get_f64(&rd, &tol) || !isfinite(tol) ||
        !(tol > 0))
        return PDR_EPARSE;
    out->base = base;
    out->planar_tol = tol;
    rc = get_vertices(&rd, out);
    if (!rc)
        rc = get_facets(&rd, out);
    if (!rc)
        rc = get_rest(&rd, out);
    if (!rc && pr_reader_finish(&rd))
        rc = PDR_EPARSE;
    if (!rc)
        rc = plc_validate(out, diag);
    /* The derived data the refinement reads (needle points, sharp
     * segments), as rank 0 computed them. */
    if (!rc)
        rc = fm_features(out, NULL);
    return rc;
}

/* --------------------------------------------------------------- options */

int par_decomp_opts_put(pr_buf *b, const ref_opts *o)
{
    const double x[7] = {o->ratio,        o->maxvol,     o->maxedge, o->min_dihedral,
                         o->seg_maxlen,   o->fac_maxrad, o->rho};
    for (int k = 0; k < 7; k++)
        if (!isfinite(x[k]))
            return PDR_EINVAL;
    if ((o->use_region_maxvol != 0 && o->use_region_maxvol != 1) ||
        (o->order != REF_ORDER_FIFO && o->order != REF_ORDER_LIFO) ||
        (o->constrained != 0 && o->constrained != 1) || (o->keep_stuck != 0 && o->keep_stuck != 1))
        return PDR_EINVAL;
    size_t start = b->len;
    pr_put_u32(b, PAR_DECOMP_OPTS_MAGIC);
    pr_put_u32(b, OPTS_VERSION);
    for (int k = 0; k < 7; k++)
        pr_put_f64(b, x[k]);
    pr_put_u8(b, (uint8_t)o->use_region_maxvol);
    pr_put_u8(b, (uint8_t)o->order);
    pr_put_u8(b, (uint8_t)o->constrained);
    pr_put_u8(b, (uint8_t)o->keep_stuck);
    if (b->err) {
        if (b->len >= start)
            b->len = start;
        return b->err == PR_ENOMEM ? PDR_ENOMEM : PDR_EINVAL;
    }
    return 0;
}

int par_decomp_opts_decode(const void *msg, size_t len, ref_opts *out)
{
    pr_reader rd;
    pr_reader_init(&rd, msg, len);
    uint32_t magic = 0, version = 0;
    double x[7];
    uint8_t urm = 0, order = 0, cdt = 0, keep = 0;
    pr_get_u32(&rd, &magic);
    pr_get_u32(&rd, &version);
    if (rd.err || magic != PAR_DECOMP_OPTS_MAGIC || version != OPTS_VERSION ||
        get_finite(&rd, x, 7) || pr_get_u8(&rd, &urm) || pr_get_u8(&rd, &order) ||
        pr_get_u8(&rd, &cdt) || pr_get_u8(&rd, &keep) || urm > 1 || cdt > 1 || keep > 1 ||
        (order != REF_ORDER_FIFO && order != REF_ORDER_LIFO) || pr_reader_finish(&rd))
        return PDR_EPARSE;
    ref_default_opts(out);
    out->ratio = x[0];
    out->maxvol = x[1];
    out->maxedge = x[2];
    out->min_dihedral = x[3];
    out->seg_maxlen = x[4];
    out->fac_maxrad = x[5];
    out->rho = x[6];
    out->use_region_maxvol = urm;
    out->order = order;
    out->constrained = cdt;
    out->keep_stuck = keep;
    out->progress = NULL;
    out->progress_arg = NULL;
    return 0;
}
