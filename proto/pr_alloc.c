/* pr_alloc.c -- the allocation hook: the installed allocator, the counter
 * and failure injection (pr_alloc.h says what holds). */
#include "config.h"

#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "pr.h"
#include "pr_alloc.h"

static void *libc_alloc(void *ud, size_t size)
{
    (void)ud;
    return malloc(size);
}

static void *libc_zalloc(void *ud, size_t n, size_t size)
{
    (void)ud;
    return calloc(n, size);
}

static void *libc_resize(void *ud, void *p, size_t size)
{
    (void)ud;
    return realloc(p, size);
}

static void libc_release(void *ud, void *p)
{
    (void)ud;
    free(p);
}

static const pr_allocator libc_allocator = {libc_alloc, libc_zalloc,
                                            libc_resize, libc_release, NULL};

/* The installed allocator. Written only by pr_alloc_set, which must not
 * race with allocations, so plain reads are enough. */
static pr_allocator cur = {libc_alloc, libc_zalloc, libc_resize, libc_release,
                           NULL};

/* Allocations made, refused, and the number of the first one to refuse
 * (0: none). Relaxed atomics: they order nothing else, they only have to
 * count every call exactly once when threads allocate at the same time. */
static atomic_uint_fast64_t n_made;
static atomic_uint_fast64_t n_refused;
static atomic_uint_fast64_t fail_from;

/* Numbers one allocation; true if it must fail. */
static int alloc_tick(void)
{
    uint_fast64_t k =
        atomic_fetch_add_explicit(&n_made, 1, memory_order_relaxed) + 1;
    uint_fast64_t from = atomic_load_explicit(&fail_from, memory_order_relaxed);
    if (from != 0 && k >= from) {
        atomic_fetch_add_explicit(&n_refused, 1, memory_order_relaxed);
        return 1;
    }
    return 0;
}

void *pr_malloc(size_t size)
{
    if (alloc_tick())
        return NULL;
    return cur.alloc(cur.ud, size ? size : 1);
}

void *pr_calloc(size_t n, size_t size)
{
    if (alloc_tick())
        return NULL;
    if (n == 0 || size == 0)
        n = size = 1;
    else if (n > SIZE_MAX / size)
        return NULL;
    if (cur.zalloc)
        return cur.zalloc(cur.ud, n, size);
    void *p = cur.alloc(cur.ud, n * size);
    if (p)
        memset(p, 0, n * size);
    return p;
}

void *pr_realloc(void *p, size_t size)
{
    if (alloc_tick())
        return NULL;
    if (size == 0)
        size = 1;
    return p ? cur.resize(cur.ud, p, size) : cur.alloc(cur.ud, size);
}

char *pr_strdup(const char *s)
{
    size_t n = strlen(s);
    if (alloc_tick())
        return NULL;
    char *d = cur.alloc(cur.ud, n + 1);
    if (d)
        memcpy(d, s, n + 1);
    return d;
}

char *pr_strndup(const char *s, size_t n)
{
    n = strnlen(s, n);
    if (alloc_tick())
        return NULL;
    char *d = cur.alloc(cur.ud, n + 1);
    if (d) {
        memcpy(d, s, n);
        d[n] = '\0';
    }
    return d;
}

void pr_free(void *p)
{
    if (p)
        cur.release(cur.ud, p);
}

int pr_alloc_set(const pr_allocator *a)
{
    if (!a) {
        cur = libc_allocator;
        return 0;
    }
    if (!a->alloc || !a->resize || !a->release)
        return PR_EINVAL;
    cur = *a;
    return 0;
}

void pr_alloc_get(pr_allocator *out)
{
    *out = cur;
}

uint64_t pr_alloc_count(void)
{
    return atomic_load_explicit(&n_made, memory_order_relaxed);
}

uint64_t pr_alloc_refused(void)
{
    return atomic_load_explicit(&n_refused, memory_order_relaxed);
}

void pr_alloc_fail_after(uint64_t n)
{
    uint_fast64_t from = 0;
    if (n != 0)
        from = atomic_load_explicit(&n_made, memory_order_relaxed) + n;
    atomic_store_explicit(&fail_from, from, memory_order_relaxed);
}
