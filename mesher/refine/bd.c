/* refine/bd.c -- subsegment and subfacet tables with their maps (see refine/bd.h). */
#include "config.h"

#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "refine/bd.h"
#include "base/pdr_util.h"

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
    pr_free(b->segs);
    pr_free(b->facs);
    hmap_free(&b->seg_map);
    hmap_free(&b->edge_map);
    pr_free(b->vkind);
    pr_free(b->vfeat);
    pr_free(b->vrins);
    bd_init(b);
}

int bd_vertex_room(bd_set *b, size_t nv)
{
    if (nv <= b->vcap)
        return 0;
    size_t c = b->vcap ? b->vcap : 1024;
    while (c < nv)
        c += c / 2;
    uint8_t *k = pr_realloc(b->vkind, c * sizeof *k);
    if (!k)
        return PDR_ENOMEM;
    b->vkind = k;
    uint32_t *f = pr_realloc(b->vfeat, c * sizeof *f);
    if (!f)
        return PDR_ENOMEM;
    b->vfeat = f;
    float *r = pr_realloc(b->vrins, c * sizeof *r);
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
    if (hmap_put(&b->seg_map, ekey(a, c), i))
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
    hmap_del(&b->seg_map, ekey(s->v[0], s->v[1]), i);
    s->flags = BD_F_DEAD;
    s->seg = b->seg_free;
    b->seg_free = i;
    b->live_segs--;
}

void bd_count_missing(const bd_set *b, size_t *segs, size_t *facs)
{
    *segs = *facs = 0;
    for (size_t i = 0; i < b->nsegs; i++)
        *segs += (b->segs[i].flags & (BD_F_DEAD | BD_F_MISSING)) == BD_F_MISSING;
    for (size_t i = 0; i < b->nfacs; i++)
        *facs += (b->facs[i].flags & (BD_F_DEAD | BD_F_MISSING)) == BD_F_MISSING;
}

uint32_t bd_find_subseg(const bd_set *b, uint32_t a, uint32_t c)
{
    if (a > c) {
        uint32_t x = a;
        a = c;
        c = x;
    }
    return hmap_get(&b->seg_map, ekey(a, c));
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
        if (hmap_put(&b->edge_map, ekey(v[k], v[(k + 1) % 3]), i)) {
            while (k-- > 0)
                hmap_del(&b->edge_map, ekey(v[k], v[(k + 1) % 3]), i);
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
        hmap_del(&b->edge_map, ekey(s->v[k], s->v[(k + 1) % 3]), i);
    s->flags = BD_F_DEAD;
    s->facet = b->fac_free;
    b->fac_free = i;
    b->live_facs--;
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
    if (hmap_each(&b->edge_map, ekey(a, c), has_third, &fa) ||
        hmap_each(&b->edge_map, ekey(c, a), has_third, &fa))
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
    hmap_each(&b->edge_map, ekey(to, from), same_facet, &fa);
    return fa.found;
}

int bd_subfacs_on_edge(const bd_set *b, uint32_t a, uint32_t c,
                       int (*fn)(void *arg, uint32_t subfac), void *arg)
{
    int r = hmap_each(&b->edge_map, ekey(a, c), fn, arg);
    if (!r)
        r = hmap_each(&b->edge_map, ekey(c, a), fn, arg);
    return r;
}

size_t bd_bytes(const bd_set *b)
{
    return b->cap_segs * sizeof *b->segs + b->cap_facs * sizeof *b->facs +
           (b->seg_map.cap + b->edge_map.cap) * (sizeof(uint64_t) + sizeof(uint32_t)) +
           b->vcap * (sizeof *b->vkind + sizeof *b->vfeat + sizeof *b->vrins);
}
