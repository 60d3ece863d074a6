/* base/hdup.c -- repeated 64-bit hashes, found partition by partition (see
 * base/hdup.h). */
#include "config.h"

#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "base/hdup.h"
#include "base/pdr_error.h"
#include "base/pdr_util.h"

/* About this many values per partition: its table (twice as many 8-byte
 * slots, 32 KB) and the values themselves fit in a core's L2 cache. */
#define PART_TARGET 2048
/* At most 2^16 partitions: beyond that the scatter's write streams no
 * longer fit in the cache and TLB (a partition then simply grows). */
#define PART_BITS_MAX 16

typedef struct found {
    uint64_t *v;
    size_t n, cap;
} found;

static int add_found(found *f, uint64_t x)
{
    if (pdr_grow((void **)&f->v, &f->cap, f->n + 1, sizeof *f->v))
        return PDR_ENOMEM;
    f->v[f->n++] = x;
    return 0;
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* The repeats within one partition p[0..n), with a table of cap slots
 * (a power of two > n, all empty on entry and on return). used[] has room
 * for n slot numbers. Zero never reaches here (it marks an empty slot). */
static int part_repeats(const uint64_t *p, size_t n, uint64_t *tab, uint8_t *seen,
                        size_t cap, size_t *used, found *f)
{
    unsigned shift = 64;
    for (size_t c = cap; c > 1; c >>= 1)
        shift--;
    size_t mask = cap - 1, nused = 0;
    int rc = 0;
    for (size_t k = 0; k < n && !rc; k++) {
        uint64_t x = p[k];
        /* The top bits are the partition's, the same for all of p: the
         * multiply spreads the others over the slot number. */
        size_t s = shift < 64 ? (size_t)((x * UINT64_C(0x9E3779B97F4A7C15)) >> shift) : 0;
        while (tab[s] && tab[s] != x)
            s = (s + 1) & mask;
        if (!tab[s]) {
            tab[s] = x;
            used[nused++] = s;
        } else if (!seen[s]) {
            seen[s] = 1;
            rc = add_found(f, x);
        }
    }
    /* Empty the table by the slots used, not all cap of them: a partition
     * touches few of its slots' cache lines twice. */
    for (size_t k = 0; k < nused; k++) {
        tab[used[k]] = 0;
        seen[used[k]] = 0;
    }
    return rc;
}

/* The partition of x among np = 2^bits; zero (an empty table slot) gets
 * partition np of its own, counted but not searched. */
static size_t part_of(uint64_t x, unsigned bits, size_t np)
{
    return x == 0 ? np : bits ? (size_t)(x >> (64 - bits)) : 0;
}

int hdup_find(const uint64_t *h, size_t n, hdup_buf *buf, uint64_t **rep, size_t *nrep)
{
    *rep = NULL;
    *nrep = 0;
    unsigned bits = 0;
    while (bits < PART_BITS_MAX && (n >> bits) > PART_TARGET)
        bits++;
    size_t np = (size_t)1 << bits;
    size_t *start = pr_calloc(np + 2, sizeof *start);
    size_t *at = pr_malloc((np + 1) * sizeof *at);
    found f = {NULL, 0, 0};
    uint64_t *tab = NULL;
    uint8_t *seen = NULL;
    size_t *used = NULL;
    int rc = start && at ? 0 : PDR_ENOMEM;
    /* Scatter, not permute in place: moving each value once along its
     * displacement chain reads at random and took twice as long. */
    if (!rc && pdr_grow((void **)&buf->part, &buf->cap, n ? n : 1, sizeof *buf->part))
        rc = PDR_ENOMEM;
    if (!rc) {
        uint64_t *part = buf->part;
        for (size_t k = 0; k < n; k++)
            start[part_of(h[k], bits, np) + 1]++;
        for (size_t q = 0; q <= np; q++)
            start[q + 1] += start[q];
        memcpy(at, start, (np + 1) * sizeof *at);
        for (size_t k = 0; k < n; k++)
            part[at[part_of(h[k], bits, np)]++] = h[k];
        size_t most = 0;
        for (size_t q = 0; q < np; q++)
            if (start[q + 1] - start[q] > most)
                most = start[q + 1] - start[q];
        size_t cap = 2;
        while (cap <= 2 * most)
            cap *= 2;
        tab = pr_calloc(cap, sizeof *tab);
        seen = pr_calloc(cap, 1);
        used = pr_malloc((most ? most : 1) * sizeof *used);
        rc = tab && seen && used ? 0 : PDR_ENOMEM;
        if (!rc && start[np + 1] - start[np] > 1)
            rc = add_found(&f, 0);
        for (size_t q = 0; q < np && !rc; q++)
            if (start[q + 1] - start[q] > 1)
                rc = part_repeats(part + start[q], start[q + 1] - start[q], tab, seen, cap,
                                  used, &f);
    }
    pr_free(start);
    pr_free(at);
    pr_free(tab);
    pr_free(seen);
    pr_free(used);
    if (rc) {
        pr_free(f.v);
        return rc;
    }
    if (f.n)
        qsort(f.v, f.n, sizeof *f.v, cmp_u64);
    *rep = f.v;
    *nrep = f.n;
    return 0;
}

void hdup_buf_free(hdup_buf *buf)
{
    pr_free(buf->part);
    buf->part = NULL;
    buf->cap = 0;
}

int hdup_has(const uint64_t *rep, size_t nrep, uint64_t x)
{
    size_t lo = 0, hi = nrep;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (rep[mid] < x)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < nrep && rep[lo] == x;
}
