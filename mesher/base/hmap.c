/* base/hmap.c -- open-addressing multimap from 64-bit keys to 32-bit values
 * (see base/hmap.h). */
#include "config.h"

#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "base/hmap.h"
#include "base/pdr_error.h"

/* Linear probing; deletion shifts the following entries back instead of
 * leaving tombstones, so a map that sees millions of insertions and
 * deletions (every split replaces subfacets) never degrades. */

static size_t slot_of(uint64_t k, size_t mask)
{
    k *= 0x9E3779B97F4A7C15ULL;
    return (size_t)(k ^ (k >> 29)) & mask;
}

static int hmap_resize(hmap *m, size_t cap)
{
    uint64_t *key = pr_calloc(cap, sizeof *key);
    uint32_t *val = pr_malloc(cap * sizeof *val);
    if (!key || !val) {
        pr_free(key);
        pr_free(val);
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
    pr_free(m->key);
    pr_free(m->val);
    m->key = key;
    m->val = val;
    m->cap = cap;
    return 0;
}

int hmap_put(hmap *m, uint64_t key, uint32_t val)
{
    if ((m->n + 1) * 10 > m->cap * 7) {
        int rc = hmap_resize(m, m->cap ? m->cap * 2 : 256);
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

int hmap_del(hmap *m, uint64_t key, uint32_t val)
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

uint32_t hmap_get(const hmap *m, uint64_t key)
{
    if (!m->cap)
        return HMAP_NONE;
    size_t mask = m->cap - 1;
    for (size_t s = slot_of(key, mask); m->key[s]; s = (s + 1) & mask)
        if (m->key[s] == key)
            return m->val[s];
    return HMAP_NONE;
}

void hmap_free(hmap *m)
{
    pr_free(m->key);
    pr_free(m->val);
    memset(m, 0, sizeof *m);
}

int hmap_each(const hmap *m, uint64_t key, int (*fn)(void *, uint32_t), void *arg)
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
