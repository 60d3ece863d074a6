/*
 * base/hdup.h -- which 64-bit hashes occur more than once among millions
 * (prefix hdup_).
 *
 * The merge at the end of a parallel run must show that no tetrahedron
 * and no face of a million-tetrahedron mesh is there twice. One hash
 * table over all of them costs a cache miss per entry; hashing every
 * entity to 64 bits and looking for repeated values is the same question
 * in bulk: the values are first split by their top bits into partitions
 * of a few thousand (one counting pass and one scatter, both streaming),
 * and each partition is then checked with a small open-addressing table
 * that stays in cache. Equal entities give equal hashes, so every real
 * repeat is found; a repeated hash may still be two different entities
 * (about n^2 / 2^65 of them by chance), which the caller tells apart by
 * looking only at the entities with a repeated hash.
 */
#ifndef PDR_BASE_HDUP_H
#define PDR_BASE_HDUP_H

#include <stddef.h>
#include <stdint.h>

/* Scratch memory for hdup_find, kept between calls: fresh pages cost as
 * much as the search itself, so several searches share them. A zeroed
 * struct is empty; hdup_buf_free releases it. */
typedef struct hdup_buf {
    uint64_t *part; /* the values, partitioned */
    size_t cap;
} hdup_buf;

/* Finds the values occurring at least twice in h[0..n), which it does not
 * modify, with scratch buf. *rep gets them, each once, in ascending order
 * (pr_malloc'd, the caller pr_frees it; NULL when there is none) and *nrep
 * their number. Returns 0 or PDR_ENOMEM (then *rep is NULL and *nrep 0). */
int hdup_find(const uint64_t *h, size_t n, hdup_buf *buf, uint64_t **rep, size_t *nrep);

void hdup_buf_free(hdup_buf *buf);

/* 1 if x is in rep[0..nrep), sorted ascending (as hdup_find gives it). */
int hdup_has(const uint64_t *rep, size_t nrep, uint64_t x);

#endif /* PDR_BASE_HDUP_H */
