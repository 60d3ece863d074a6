/*
 * base/hmap.h -- open-addressing multimap from 64-bit keys (never 0) to
 * 32-bit values (prefix hmap_).
 *
 * Linear probing with backward-shift deletion: no tombstones, so a map that
 * sees millions of insertions and deletions never degrades. A zeroed struct
 * is an empty map; the map owns its arrays until hmap_free.
 */
#ifndef PDR_BASE_HMAP_H
#define PDR_BASE_HMAP_H

#include <stddef.h>
#include <stdint.h>

#define HMAP_NONE UINT32_MAX

typedef struct hmap {
    uint64_t *key; /* 0 = empty slot */
    uint32_t *val;
    size_t cap;    /* power of two */
    size_t n;      /* entries */
} hmap;

/* Adds (key, val); a key may hold several values. 0 or PDR_ENOMEM. */
int hmap_put(hmap *m, uint64_t key, uint32_t val);
/* Removes one (key, val) pair; returns 1 if it was there. */
int hmap_del(hmap *m, uint64_t key, uint32_t val);
/* First value for key, or HMAP_NONE. */
uint32_t hmap_get(const hmap *m, uint64_t key);
/* Calls fn(arg, val) for every value stored under key, stopping at and
 * returning the first nonzero result (0 when every call returned 0). */
int hmap_each(const hmap *m, uint64_t key, int (*fn)(void *arg, uint32_t val), void *arg);
/* Frees the arrays and leaves an empty map. */
void hmap_free(hmap *m);

#endif /* PDR_BASE_HMAP_H */
