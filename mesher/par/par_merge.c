/* par/par_merge.c -- the P messages of the PEs back into one ref_mesher,
 * with every seam checked (see par/par_merge.h). */
#include "config.h"

#include <stdlib.h>
#include <string.h>

#include "par/par_merge.h"
#include "par/par_wire.h"

size_t par_merge_problems(const par_merge_report *r)
{
    return r->vertex_conflicts + r->dup_tets + r->nonmanifold + r->open_faces +
           r->iface_unmatched + r->iface_mismatch + r->misoriented + r->marker_mismatch +
           r->bd_conflicts;
}

int par_merge_encode(pr_buf *b, const par_sub *s)
{
    return par_wire_encode_sub(b, s);
}

/* State of one merge; every pointer owned, freed by st_free. */
typedef struct merge {
    par_wire *w;      /* [n] decoded messages */
    uint32_t n;
    uint64_t *gids;   /* distinct real gids, ascending */
    size_t ngid;
    uint32_t **loc;   /* [n][vert.n]: merged vertex of each message vertex */
    uint32_t *src;    /* per merged slot: PE it came from */
    uint32_t *ipe;    /* per merged face 4t+i: PE named across it, or PAR_PE_NONE */
    hmap tet_map;     /* hash of the sorted vertices -> slot */
} merge;

static void st_free(merge *g)
{
    if (g->w)
        for (uint32_t k = 0; k < g->n; k++)
            par_wire_clear(&g->w[k]);
    if (g->loc)
        for (uint32_t k = 0; k < g->n; k++)
            free(g->loc[k]);
    free(g->w);
    free(g->loc);
    free(g->gids);
    free(g->src);
    free(g->ipe);
    hmap_free(&g->tet_map);
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* Index + 1 of gid among the distinct gids (they contain it). */
static uint32_t vertex_of(const merge *g, uint64_t gid)
{
    size_t lo = 0, hi = g->ngid;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (g->gids[mid] < gid)
            lo = mid + 1;
        else
            hi = mid;
    }
    return (uint32_t)lo + 1;
}

/* The distinct gids, and each message's vertices in the merged numbering. */
static int number_vertices(merge *g)
{
    size_t total = 0;
    for (uint32_t k = 0; k < g->n; k++)
        total += g->w[k].sm->vert.n;
    g->gids = malloc((total ? total : 1) * sizeof *g->gids);
    g->loc = calloc(g->n, sizeof *g->loc);
    if (!g->gids || !g->loc)
        return PDR_ENOMEM;
    size_t n = 0;
    for (uint32_t k = 0; k < g->n; k++) {
        const pr_vtable *vt = &g->w[k].sm->vert;
        for (uint32_t i = 0; i < vt->n; i++)
            if (vt->gid[i] != PAR_GID_INF)
                g->gids[n++] = vt->gid[i];
    }
    qsort(g->gids, n, sizeof *g->gids, cmp_u64);
    size_t u = 0;
    for (size_t i = 0; i < n; i++)
        if (u == 0 || g->gids[i] != g->gids[u - 1])
            g->gids[u++] = g->gids[i];
    g->ngid = u;
    if (u + 1 > TM_MAX_VERTS)
        return PDR_ELIMIT;
    for (uint32_t k = 0; k < g->n; k++) {
        const pr_vtable *vt = &g->w[k].sm->vert;
        g->loc[k] = malloc(((size_t)vt->n ? vt->n : 1) * sizeof *g->loc[k]);
        if (!g->loc[k])
            return PDR_ENOMEM;
        for (uint32_t i = 0; i < vt->n; i++)
            g->loc[k][i] = vt->gid[i] == PAR_GID_INF ? TM_VINF : vertex_of(g, vt->gid[i]);
    }
    return 0;
}

/* The merged vertices with their coordinates, gids and bd data, from the
 * first message holding each; later copies are compared. */
static int add_vertices(merge *g, ref_mesher *r, par_merge_report *rep)
{
    tm_mesh *m = &r->m;
    size_t nv = g->ngid + 1;
    int rc = tm_reserve(m, nv, 0);
    if (!rc)
        rc = bd_vertex_room(&r->bd, nv);
    uint8_t *set = calloc(nv, 1);
    if (rc || !set) {
        free(set);
        return rc ? rc : PDR_ENOMEM;
    }
    /* tm_add_vertex appends: add them all first, then fill them in */
    for (size_t v = 1; v < nv && !rc; v++) {
        const double zero[3] = {0, 0, 0};
        uint32_t x;
        rc = tm_add_vertex(m, zero, &x);
        if (!rc)
            m->gid[x] = g->gids[v - 1];
    }
    for (uint32_t k = 0; k < g->n && !rc; k++) {
        const par_wire *w = &g->w[k];
        const pr_vtable *vt = &w->sm->vert;
        for (uint32_t i = 0; i < vt->n; i++) {
            uint32_t v = g->loc[k][i];
            if (v == TM_VINF)
                continue;
            const double *x = vt->xyz + 3 * (size_t)i;
            double *y = m->xyz + 3 * (size_t)v;
            if (!set[v]) {
                set[v] = 1;
                memcpy(y, x, 3 * sizeof *y);
                r->bd.vkind[v] = w->vkind[i];
                r->bd.vfeat[v] = w->vfeat[i];
                r->bd.vrins[v] = w->vrins[i];
            } else if (memcmp(y, x, 3 * sizeof *y) || r->bd.vkind[v] != w->vkind[i] ||
                       r->bd.vfeat[v] != w->vfeat[i] ||
                       memcmp(&r->bd.vrins[v], &w->vrins[i], sizeof(float))) {
                rep->vertex_conflicts++;
            }
        }
    }
    free(set);
    return rc;
}

static void sort4(const uint32_t *v, uint32_t s[4])
{
    memcpy(s, v, 4 * sizeof *s);
    for (int i = 1; i < 4; i++)
        for (int j = i; j > 0 && s[j - 1] > s[j]; j--) {
            uint32_t x = s[j];
            s[j] = s[j - 1];
            s[j - 1] = x;
        }
}

static uint64_t tet_hash(const uint32_t s[4])
{
    uint64_t h = (uint64_t)s[0] * 0x9E3779B97F4A7C15ULL;
    h ^= (h >> 29) ^ (uint64_t)s[1] * 0xC2B2AE3D27D4EB4FULL;
    h ^= (h >> 31) ^ (uint64_t)s[2] * 0x165667B19E3779F9ULL;
    h ^= (h >> 27) ^ (uint64_t)s[3] * 0x27D4EB2F165667C5ULL;
    h ^= h >> 33;
    return h ? h : 1;
}

struct same_tet {
    const tm_mesh *m;
    const uint32_t *s;
};

static int is_same_tet(void *arg, uint32_t t)
{
    struct same_tet *a = arg;
    uint32_t s[4];
    sort4(a->m->tets[t].v, s);
    return !memcmp(s, a->s, sizeof s);
}

/* Every message's tetrahedra, each once, with flags, markers, subsegment
 * bits, regions, the PE they came from and their interface faces. */
static int add_tets(merge *g, ref_mesher *r, par_merge_report *rep)
{
    tm_mesh *m = &r->m;
    size_t total = 0;
    for (uint32_t k = 0; k < g->n; k++)
        total += g->w[k].sm->tet.n;
    if (total > TM_MAX_TETS)
        return PDR_ELIMIT;
    int rc = tm_reserve(m, 0, total);
    if (!rc)
        rc = ref_region_room(r);
    g->src = malloc((total ? total : 1) * sizeof *g->src);
    g->ipe = malloc((total ? 4 * total : 1) * sizeof *g->ipe);
    if (rc || !g->src || !g->ipe)
        return rc ? rc : PDR_ENOMEM;
    uint32_t *slot = NULL;
    for (uint32_t k = 0; k < g->n && !rc; k++) {
        const par_wire *w = &g->w[k];
        const pr_submesh *sm = w->sm;
        free(slot);
        slot = malloc(((size_t)sm->tet.n ? sm->tet.n : 1) * sizeof *slot);
        if (!slot) {
            rc = PDR_ENOMEM;
            break;
        }
        for (uint32_t j = 0; j < sm->tet.n && !rc; j++) {
            uint32_t v[4], s[4];
            for (int c = 0; c < 4; c++)
                v[c] = g->loc[k][sm->tet.v[4 * (size_t)j + (size_t)c]];
            sort4(v, s);
            uint64_t h = tet_hash(s);
            struct same_tet a = {m, s};
            if (hmap_each(&g->tet_map, h, is_same_tet, &a)) {
                rep->dup_tets++;
                slot[j] = TM_NONE;
                continue;
            }
            uint32_t t = tm_alloc_tet(m);
            rc = hmap_put(&g->tet_map, h, t);
            slot[j] = t;
            uint16_t fl = w->tflags[j];
            for (int i = 0; i < 4; i++) {
                m->tets[t].v[i] = v[i];
                m->tets[t].n[i] = TM_LINK_UNSET;
                int32_t mk = sm->tet.marker[4 * (size_t)j + (size_t)i];
                m->marker[4 * (size_t)t + (size_t)i] = mk + 1;
                if (mk != PR_MARKER_NONE)
                    fl |= TM_F_FACEMARK(i);
                g->ipe[4 * (size_t)t + (size_t)i] = PAR_PE_NONE;
            }
            fl |= (uint16_t)((sm->tet.subseg[j] & PR_SUBSEG_MASK) * TM_F_SUBSEG0);
            m->flags[t] = fl;
            m->nghost += (uint32_t)tm_is_ghost(m, t);
            if (r->region)
                r->region[t] = w->region[j];
            g->src[t] = k;
        }
        for (uint32_t q = 0; q < sm->iface.n && !rc; q++) {
            uint32_t t = slot[sm->iface.face[q] >> 2];
            if (t != TM_NONE)
                g->ipe[4 * (size_t)t + (sm->iface.face[q] & 3)] = sm->iface.remote[q];
        }
    }
    free(slot);
    return rc;
}

static int face_opposed(const uint32_t x[3], const uint32_t y[3])
{
    for (int k = 0; k < 3; k++)
        if (y[0] == x[k])
            return y[1] == x[(k + 2) % 3] && y[2] == x[(k + 1) % 3];
    return 0;
}

static void face_of(const tm_mesh *m, uint32_t t, int i, uint32_t f[3])
{
    for (int c = 0; c < 3; c++)
        f[c] = m->tets[t].v[tm_face_vtx[i][c]];
}

/* The seams: every face against what the PEs said about it. */
static void check_faces(const merge *g, const tm_mesh *m, par_merge_report *rep)
{
    for (uint32_t t = 0; t < m->nslots; t++) {
        for (int i = 0; i < 4; i++) {
            tm_link l = m->tets[t].n[i];
            uint32_t named = g->ipe[4 * (size_t)t + (size_t)i];
            if (tm_is_special(l)) {
                if (named != PAR_PE_NONE)
                    rep->iface_unmatched++;
                else
                    rep->open_faces++;
                continue;
            }
            uint32_t u = tm_ltet(l);
            int j = tm_lface(l);
            if (u < t)
                continue; /* seen from u */
            uint32_t back = g->ipe[4 * (size_t)u + (size_t)j];
            if (g->src[t] == g->src[u]) {
                if (named != PAR_PE_NONE || back != PAR_PE_NONE)
                    rep->iface_mismatch++;
            } else if (named != g->src[u] || back != g->src[t]) {
                rep->iface_mismatch++;
            }
            uint32_t x[3], y[3];
            face_of(m, t, i, x);
            face_of(m, u, j, y);
            if (!face_opposed(x, y))
                rep->misoriented++;
            if (tm_face_marker(m, t, i) != tm_face_marker(m, u, j))
                rep->marker_mismatch++;
        }
    }
}

/* 1 if y is x rotated (the same oriented triangle). */
static int same_rotation(const uint32_t x[3], const uint32_t y[3])
{
    for (int k = 0; k < 3; k++)
        if (y[0] == x[k])
            return y[1] == x[(k + 1) % 3] && y[2] == x[(k + 2) % 3];
    return 0;
}

static int add_bd(const merge *g, ref_mesher *r, par_merge_report *rep)
{
    bd_set *bd = &r->bd;
    for (uint32_t k = 0; k < g->n; k++) {
        const par_wire *w = &g->w[k];
        for (uint32_t j = 0; j < w->nseg; j++) {
            uint32_t a = g->loc[k][w->seg_v[2 * (size_t)j]],
                     b = g->loc[k][w->seg_v[2 * (size_t)j + 1]];
            uint32_t id = bd_find_subseg(bd, a, b);
            if (id != BD_NONE) {
                if (bd->segs[id].seg != w->seg_id[j])
                    rep->bd_conflicts++;
                bd->segs[id].flags |= w->seg_flags[j];
                continue;
            }
            int rc = bd_add_subseg(bd, a, b, w->seg_id[j], &id);
            if (rc)
                return rc;
            bd->segs[id].flags = w->seg_flags[j];
        }
        for (uint32_t j = 0; j < w->nfac; j++) {
            const uint32_t *x = w->fac_v + 3 * (size_t)j;
            uint32_t f[3] = {g->loc[k][x[0]], g->loc[k][x[1]], g->loc[k][x[2]]};
            uint32_t id = bd_find_subfac(bd, f[0], f[1], f[2]);
            if (id != BD_NONE) {
                if (bd->facs[id].facet != w->fac_id[j] || !same_rotation(bd->facs[id].v, f))
                    rep->bd_conflicts++;
                bd->facs[id].flags |= w->fac_flags[j];
                continue;
            }
            int rc = bd_add_subfac(bd, f[0], f[1], f[2], w->fac_id[j], &id);
            if (rc)
                return rc;
            bd->facs[id].flags = w->fac_flags[j];
        }
    }
    return 0;
}

static int merge_all(merge *g, const void *const *msg, const size_t *len, const plc *p,
                     ref_mesher *out, par_merge_report *rep)
{
    g->w = calloc(g->n ? g->n : 1, sizeof *g->w);
    if (!g->w)
        return PDR_ENOMEM;
    for (uint32_t k = 0; k < g->n; k++) {
        int rc = par_wire_decode(msg[k], len[k], p, &g->w[k]);
        if (rc)
            return rc;
        if (g->w[k].sm->rank != k || g->w[k].sm->size != g->n)
            return PDR_EPARSE;
    }
    int rc = number_vertices(g);
    if (!rc)
        rc = tm_enable(&out->m, TM_FEAT_GIDS);
    if (!rc) {
        out->m.gid[0] = PAR_GID_INF;
        rc = add_vertices(g, out, rep);
    }
    if (!rc)
        rc = add_tets(g, out, rep);
    size_t nonmanifold = 0;
    if (!rc)
        rc = tm_link_faces(&out->m, &nonmanifold);
    if (rc)
        return rc;
    rep->nonmanifold = nonmanifold;
    check_faces(g, &out->m, rep);
    rc = add_bd(g, out, rep);
    if (!rc)
        rc = par_wire_seg_acute(out);
    if (rc)
        return rc;
    tm_rebuild_hints(&out->m);
    out->classified = 1;
    rep->vertices = out->m.nv;
    rep->tets = out->m.nlive;
    return par_merge_problems(rep) ? PDR_ETOPOLOGY : 0;
}

int par_merge_build(const void *const *msg, const size_t *len, uint32_t n, const plc *p,
                    const ref_opts *o, ref_mesher *out, par_merge_report *rep)
{
    memset(rep, 0, sizeof *rep);
    int rc = ref_init(out, p, o);
    if (rc)
        return rc;
    merge g;
    memset(&g, 0, sizeof g);
    g.n = n;
    rc = n ? merge_all(&g, msg, len, p, out, rep) : PDR_EINVAL;
    st_free(&g);
    if (rc)
        ref_free(out);
    return rc;
}
