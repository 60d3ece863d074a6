/* bnd.c -- subsegment and subfacet tables with their maps (see bnd.h). */
#include "config.h"

#include <stdlib.h>
#include <string.h>

#include "bnd.h"
#include "pdr_util.h"

/* ------------------------------------------------------------------ map */

/* Linear probing; deletion shifts the following entries back instead of
 * leaving tombstones, so a map that sees millions of insertions and
 * deletions (every split replaces subfacets) never degrades. */

static size_t slot_of(uint64_t k, size_t mask)
{
    k *= 0x9E3779B97F4A7C15ULL;
    return (size_t)(k ^ (k >> 29)) & mask;
}

static int map_resize(bd_map *m, size_t cap)
{
    uint64_t *key = calloc(cap, sizeof *key);
    uint32_t *val = malloc(cap * sizeof *val);
    if (!key || !val) {
        free(key);
        free(val);
        return PDR_ENOMEM;
    }
    size_t mask = cap - 1;
    for (size_t i = 0; i < m->cap; i++) {
        if (!m->key[i])
            continue;
        size_t s = slot_of(m->key[i], mask);
        while (key[s])
            s = (s + 1) & mask;
        key[s] = m->key[i];
        val[s] = m->val[i];
    }
    free(m->key);
    free(m->val);
    m->key = key;
    m->val = val;
    m->cap = cap;
    return 0;
}

int bd_map_put(bd_map *m, uint64_t key, uint32_t val)
{
    if ((m->n + 1) * 10 > m->cap * 7) {
        int rc = map_resize(m, m->cap ? m->cap * 2 : 256);
        if (rc)
            return rc;
    }
    size_t mask = m->cap - 1, s = slot_of(key, mask);
    while (m->key[s])
        s = (s + 1) & mask;
    m->key[s] = key;
    m->val[s] = val;
    m->n++;
    return 0;
}

int bd_map_del(bd_map *m, uint64_t key, uint32_t val)
{
    if (!m->cap)
        return 0;
    size_t mask = m->cap - 1, i = slot_of(key, mask);
    while (m->key[i] && !(m->key[i] == key && m->val[i] == val))
        i = (i + 1) & mask;
    if (!m->key[i])
        return 0;
    /* Backward shift: move later entries of the run into the hole when
     * their home slot does not lie cyclically in (hole, entry]. */
    size_t j = i;
    for (;;) {
        j = (j + 1) & mask;
        if (!m->key[j])
            break;
        size_t h = slot_of(m->key[j], mask);
        int stays = i <= j ? (i < h && h <= j) : (i < h || h <= j);
        if (stays)
            continue;
        m->key[i] = m->key[j];
        m->val[i] = m->val[j];
        i = j;
    }
    m->key[i] = 0;
    m->n--;
    return 1;
}

uint32_t bd_map_get(const bd_map *m, uint64_t key)
{
    if (!m->cap)
        return BD_NONE;
    size_t mask = m->cap - 1;
    for (size_t s = slot_of(key, mask); m->key[s]; s = (s + 1) & mask)
        if (m->key[s] == key)
            return m->val[s];
    return BD_NONE;
}

void bd_map_free(bd_map *m)
{
    free(m->key);
    free(m->val);
    memset(m, 0, sizeof *m);
}

static uint64_t ekey(uint32_t a, uint32_t b)
{
    return ((uint64_t)a << 32) | b;
}

/* ---------------------------------------------------------------- setup */

void bd_init(bd_set *b)
{
    memset(b, 0, sizeof *b);
    b->seg_free = b->fac_free = BD_NONE;
}

void bd_free(bd_set *b)
{
    free(b->segs);
    free(b->facs);
    bd_map_free(&b->seg_map);
    bd_map_free(&b->edge_map);
    free(b->vkind);
    free(b->vfeat);
    free(b->vrins);
    bd_init(b);
}

int bd_vertex_room(bd_set *b, size_t nv)
{
    if (nv <= b->vcap)
        return 0;
    size_t c = b->vcap ? b->vcap : 1024;
    while (c < nv)
        c += c / 2;
    uint8_t *k = realloc(b->vkind, c * sizeof *k);
    if (!k)
        return PDR_ENOMEM;
    b->vkind = k;
    uint32_t *f = realloc(b->vfeat, c * sizeof *f);
    if (!f)
        return PDR_ENOMEM;
    b->vfeat = f;
    float *r = realloc(b->vrins, c * sizeof *r);
    if (!r)
        return PDR_ENOMEM;
    b->vrins = r;
    memset(b->vkind + b->vcap, 0, (c - b->vcap) * sizeof *k);
    memset(b->vfeat + b->vcap, 0, (c - b->vcap) * sizeof *f);
    memset(b->vrins + b->vcap, 0, (c - b->vcap) * sizeof *r);
    b->vcap = c;
    return 0;
}

/* ---------------------------------------------------------- subsegments */

int bd_add_subseg(bd_set *b, uint32_t a, uint32_t c, uint32_t seg, uint32_t *out)
{
    if (a > c) {
        uint32_t x = a;
        a = c;
        c = x;
    }
    uint32_t i = b->seg_free;
    if (i == BD_NONE) {
        if (pdr_grow((void **)&b->segs, &b->cap_segs, b->nsegs + 1, sizeof *b->segs))
            return PDR_ENOMEM;
        i = (uint32_t)b->nsegs;
    }
    if (bd_map_put(&b->seg_map, ekey(a, c), i))
        return PDR_ENOMEM;
    if (i == b->seg_free)
        b->seg_free = b->segs[i].seg;
    else
        b->nsegs++;
    bd_subseg *s = &b->segs[i];
    s->v[0] = a;
    s->v[1] = c;
    s->seg = seg;
    s->flags = 0;
    b->live_segs++;
    if (out)
        *out = i;
    return 0;
}

void bd_kill_subseg(bd_set *b, uint32_t i)
{
    bd_subseg *s = &b->segs[i];
    if (s->flags & BD_F_DEAD)
        return;
    bd_map_del(&b->seg_map, ekey(s->v[0], s->v[1]), i);
    s->flags = BD_F_DEAD;
    s->seg = b->seg_free;
    b->seg_free = i;
    b->live_segs--;
}

uint32_t bd_find_subseg(const bd_set *b, uint32_t a, uint32_t c)
{
    if (a > c) {
        uint32_t x = a;
        a = c;
        c = x;
    }
    return bd_map_get(&b->seg_map, ekey(a, c));
}

/* ------------------------------------------------------------ subfacets */

int bd_add_subfac(bd_set *b, uint32_t a, uint32_t c, uint32_t d, uint32_t f, uint32_t *out)
{
    uint32_t i = b->fac_free;
    if (i == BD_NONE) {
        if (pdr_grow((void **)&b->facs, &b->cap_facs, b->nfacs + 1, sizeof *b->facs))
            return PDR_ENOMEM;
        i = (uint32_t)b->nfacs;
    }
    uint32_t v[3] = {a, c, d};
    for (int k = 0; k < 3; k++) {
        if (bd_map_put(&b->edge_map, ekey(v[k], v[(k + 1) % 3]), i)) {
            while (k-- > 0)
                bd_map_del(&b->edge_map, ekey(v[k], v[(k + 1) % 3]), i);
            return PDR_ENOMEM;
        }
    }
    if (i == b->fac_free)
        b->fac_free = b->facs[i].facet;
    else
        b->nfacs++;
    bd_subfac *s = &b->facs[i];
    memcpy(s->v, v, sizeof v);
    s->facet = f;
    s->flags = 0;
    b->live_facs++;
    if (out)
        *out = i;
    return 0;
}

void bd_kill_subfac(bd_set *b, uint32_t i)
{
    bd_subfac *s = &b->facs[i];
    if (s->flags & BD_F_DEAD)
        return;
    for (int k = 0; k < 3; k++)
        bd_map_del(&b->edge_map, ekey(s->v[k], s->v[(k + 1) % 3]), i);
    s->flags = BD_F_DEAD;
    s->facet = b->fac_free;
    b->fac_free = i;
    b->live_facs--;
}

/* Calls fn for every value stored under key; returns the first nonzero. */
static int map_each(const bd_map *m, uint64_t key, int (*fn)(void *, uint32_t), void *arg)
{
    if (!m->cap)
        return 0;
    size_t mask = m->cap - 1;
    for (size_t s = slot_of(key, mask); m->key[s]; s = (s + 1) & mask)
        if (m->key[s] == key) {
            int r = fn(arg, m->val[s]);
            if (r)
                return r;
        }
    return 0;
}

struct find_arg {
    const bd_set *b;
    uint32_t third;
    uint32_t facet;
    uint32_t found;
};

static int has_third(void *arg, uint32_t i)
{
    struct find_arg *a = arg;
    const uint32_t *v = a->b->facs[i].v;
    if (v[0] == a->third || v[1] == a->third || v[2] == a->third) {
        a->found = i;
        return 1;
    }
    return 0;
}

uint32_t bd_find_subfac(const bd_set *b, uint32_t a, uint32_t c, uint32_t d)
{
    struct find_arg fa = {b, d, 0, BD_NONE};
    if (map_each(&b->edge_map, ekey(a, c), has_third, &fa) ||
        map_each(&b->edge_map, ekey(c, a), has_third, &fa))
        return fa.found;
    return BD_NONE;
}

static int same_facet(void *arg, uint32_t i)
{
    struct find_arg *a = arg;
    if (a->b->facs[i].facet == a->facet) {
        a->found = i;
        return 1;
    }
    return 0;
}

uint32_t bd_subfac_across(const bd_set *b, uint32_t i, int k)
{
    const bd_subfac *s = &b->facs[i];
    uint32_t from = s->v[(k + 1) % 3], to = s->v[(k + 2) % 3];
    struct find_arg fa = {b, 0, s->facet, BD_NONE};
    map_each(&b->edge_map, ekey(to, from), same_facet, &fa);
    return fa.found;
}

int bd_subfacs_on_edge(const bd_set *b, uint32_t a, uint32_t c,
                       int (*fn)(void *arg, uint32_t subfac), void *arg)
{
    int r = map_each(&b->edge_map, ekey(a, c), fn, arg);
    if (!r)
        r = map_each(&b->edge_map, ekey(c, a), fn, arg);
    return r;
}

size_t bd_bytes(const bd_set *b)
{
    return b->cap_segs * sizeof *b->segs + b->cap_facs * sizeof *b->facs +
           (b->seg_map.cap + b->edge_map.cap) * (sizeof(uint64_t) + sizeof(uint32_t)) +
           b->vcap * (sizeof *b->vkind + sizeof *b->vfeat + sizeof *b->vrins);
}
