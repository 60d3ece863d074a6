/* par/par_sub.c -- one PE's submesh: vertices by global id and the
 * interface table (see par/par_sub.h). */
#include "config.h"

#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "base/pdr_util.h"
#include "par/par_sub.h"
#include "pr.h"

uint64_t par_key_hash(const uint64_t key[3])
{
    uint64_t h = key[0] * 0x9E3779B97F4A7C15ULL;
    h ^= (h >> 31) ^ key[1] * 0xC2B2AE3D27D4EB4FULL;
    h ^= (h >> 29) ^ key[2] * 0x165667B19E3779F9ULL;
    h ^= h >> 32;
    return h ? h : 1;
}

void par_face_key(const par_sub *s, uint32_t t, int i, uint64_t key[3])
{
    const tm_mesh *m = &s->r.m;
    const uint32_t *v = m->tets[t].v;
    for (int k = 0; k < 3; k++)
        key[k] = m->gid[v[tm_face_vtx[i][k]]];
    par_key_sort(key);
}

int par_sub_init(par_sub *s, const plc *p, const ref_opts *o, uint32_t rank, uint32_t size)
{
    memset(s, 0, sizeof *s);
    s->rank = rank;
    s->size = size;
    s->next_seq = 1;
    s->own_base = 1;
    s->ifc_free = PAR_PE_NONE;
    int rc = ref_init(&s->r, p, o);
    if (!rc)
        rc = tm_enable(&s->r.m, TM_FEAT_GIDS | TM_FEAT_MARKERS | TM_FEAT_LOCKS);
    if (!rc)
        s->r.m.gid[0] = PAR_GID_INF;
    if (rc)
        par_sub_free(s);
    return rc;
}

void par_sub_free(par_sub *s)
{
    ref_free(&s->r);
    hmap_free(&s->vmap);
    pr_free(s->own_v);
    hmap_free(&s->ifc_map);
    pr_free(s->ifc);
    memset(s, 0, sizeof *s);
}

uint32_t par_sub_find_vertex(const par_sub *s, uint64_t gid)
{
    if (gid == PAR_GID_INF)
        return TM_VINF;
    if (pr_gid_rank(gid) == s->rank && pr_gid_seq(gid) >= s->own_base) {
        uint64_t i = pr_gid_seq(gid) - s->own_base;
        return i < s->own_n ? s->own_v[i] : TM_NONE;
    }
    uint32_t v = hmap_get(&s->vmap, gid);
    return v == HMAP_NONE ? TM_NONE : v;
}

int par_sub_map_vertex(par_sub *s, uint64_t gid, uint32_t v)
{
    if (pr_gid_rank(gid) != s->rank || pr_gid_seq(gid) < s->own_base)
        return hmap_put(&s->vmap, gid, v);
    uint64_t i = pr_gid_seq(gid) - s->own_base;
    if (i >= s->own_n) {
        if (i >= SIZE_MAX / sizeof *s->own_v - 1)
            return PDR_ENOMEM;
        if (pdr_grow((void **)&s->own_v, &s->own_cap, (size_t)i + 1, sizeof *s->own_v))
            return PDR_ENOMEM;
        for (size_t k = s->own_n; k <= i; k++)
            s->own_v[k] = TM_NONE;
        s->own_n = (size_t)i + 1;
    }
    s->own_v[i] = v;
    return 0;
}

int par_sub_vertex(par_sub *s, uint64_t gid, const double xyz[3], uint8_t kind,
                   uint32_t feat, float rins, uint32_t *out)
{
    uint32_t v = par_sub_find_vertex(s, gid);
    if (v != TM_NONE) {
        *out = v;
        return 0;
    }
    tm_mesh *m = &s->r.m;
    int rc = tm_add_vertex(m, xyz, &v);
    if (!rc)
        rc = bd_vertex_room(&s->r.bd, m->nv);
    if (!rc)
        rc = par_sub_map_vertex(s, gid, v);
    if (rc)
        return rc;
    m->gid[v] = gid;
    s->r.bd.vkind[v] = kind;
    s->r.bd.vfeat[v] = feat;
    s->r.bd.vrins[v] = rins;
    *out = v;
    return 0;
}

uint64_t par_sub_new_gid(par_sub *s)
{
    return pr_gid_make(s->rank, s->next_seq++);
}

int par_sub_add_iface(par_sub *s, uint32_t t, int i, uint32_t pe)
{
    uint32_t k;
    if (s->ifc_free != PAR_PE_NONE) {
        k = s->ifc_free;
        s->ifc_free = s->ifc[k].local;
    } else {
        if (s->nifc >= TM_REMOTE_MAX)
            return PDR_ELIMIT;
        if (pdr_grow((void **)&s->ifc, &s->cap_ifc, s->nifc + 1, sizeof *s->ifc))
            return PDR_ENOMEM;
        k = (uint32_t)s->nifc++;
    }
    par_iface *f = &s->ifc[k];
    par_face_key(s, t, i, f->key);
    f->pe = pe;
    f->local = tm_mklink(t, i);
    int rc = hmap_put(&s->ifc_map, par_key_hash(f->key), k);
    if (rc) {
        f->pe = PAR_PE_NONE;
        f->local = s->ifc_free;
        s->ifc_free = k;
        return rc;
    }
    s->r.m.tets[t].n[i] = TM_LINK_REMOTE(k);
    s->live_ifc++;
    return 0;
}

struct find_ifc {
    const par_sub *s;
    const uint64_t *key;
    uint32_t found;
};

static int same_key(void *arg, uint32_t k)
{
    struct find_ifc *a = arg;
    const par_iface *f = &a->s->ifc[k];
    if (f->pe != PAR_PE_NONE && par_key_eq(f->key, a->key)) {
        a->found = k;
        return 1;
    }
    return 0;
}

uint32_t par_sub_find_iface(const par_sub *s, const uint64_t key[3])
{
    struct find_ifc a = {s, key, PAR_PE_NONE};
    hmap_each(&s->ifc_map, par_key_hash(key), same_key, &a);
    return a.found;
}

void par_sub_drop_iface(par_sub *s, uint32_t k)
{
    par_iface *f = &s->ifc[k];
    if (f->pe == PAR_PE_NONE)
        return;
    hmap_del(&s->ifc_map, par_key_hash(f->key), k);
    f->pe = PAR_PE_NONE;
    f->local = s->ifc_free;
    s->ifc_free = k;
    s->live_ifc--;
}
