/*
 * pr_alloc.h -- the one allocation hook of pdr (libpdrproto).
 *
 * Every allocation of proto, the runtime (libam) and the mesher goes
 * through pr_malloc, pr_calloc, pr_realloc, pr_strdup or pr_strndup, and
 * every block they return is released with pr_free. By default they call
 * the C library. A program may install another allocator (pr_alloc_set),
 * and a test may make allocations fail (pr_alloc_fail_after) to check that
 * every failure ends in a clean error (PR_ENOMEM, AM_ENOMEM, PDR_ENOMEM):
 * no crash, no leak, no half-written file. proto is the lowest library, so
 * this header is the one header of proto every mesher layer may include.
 *
 * Whatever the allocator, these hold:
 *   - a request for 0 bytes is served as a request for 1 byte, so NULL
 *     always means "out of memory", never "empty";
 *   - pr_calloc returns NULL when n * size overflows size_t;
 *   - when pr_realloc fails it returns NULL and leaves p allocated and
 *     unchanged: the caller still owns p and must free it;
 *   - pr_free(NULL) does nothing.
 *
 * Counting and failure injection. Each call of an allocating function
 * (pr_malloc, pr_calloc, pr_realloc, pr_strdup, pr_strndup) is one
 * allocation; pr_alloc_count() says how many were made since the program
 * started. pr_alloc_fail_after(n) makes the n-th allocation after the call
 * and every later one fail: they return NULL without reaching the
 * allocator, as when memory is exhausted and stays exhausted. Failing
 * every later allocation too means an error path may not count on memory
 * to report the error, and a caller that retries or falls back cannot hide
 * the failure. The counters are atomic, so threads may allocate
 * concurrently; the order in which allocations are numbered is then the
 * order in which the threads reached the counter.
 *
 * No library reads the environment: a program chooses (pdr's main reads
 * PDR_ALLOC_FAIL, see mesher/cli/pdr.c).
 */
#ifndef PR_ALLOC_H
#define PR_ALLOC_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* --------------------------------------------------------------- allocate */

/* Like malloc, calloc, realloc, strdup and free, with the rules above.
 * The caller owns every block returned and releases it with pr_free. */
void *pr_malloc(size_t size);
void *pr_calloc(size_t n, size_t size);
void *pr_realloc(void *p, size_t size);
char *pr_strdup(const char *s);
/* A copy of the first n bytes of s, or fewer if s ends before (like
 * strndup), always NUL-terminated. */
char *pr_strndup(const char *s, size_t n);
void pr_free(void *p);

/* ------------------------------------------------------ other allocators */

/* An allocator: the functions pr_malloc and the others call. ud is passed
 * back to every call. alloc, resize and release are required; zalloc
 * (zeroed memory, n * size bytes, n * size known not to overflow) may be
 * NULL, then pr_calloc uses alloc and clears the block. Sizes are never 0,
 * resize and release never get NULL. resize follows realloc: on failure it
 * returns NULL and leaves the block as it was. */
typedef struct pr_allocator {
    void *(*alloc)(void *ud, size_t size);
    void *(*zalloc)(void *ud, size_t n, size_t size);
    void *(*resize)(void *ud, void *p, size_t size);
    void (*release)(void *ud, void *p);
    void *ud;
} pr_allocator;

/* Installs a copy of *a, or the C library's allocator when a is NULL.
 * Blocks must be released by the allocator that made them, so install one
 * before anything is allocated (or after everything is freed), and never
 * while another thread may allocate. Returns 0, or PR_EINVAL (nothing
 * changed) when a required function is missing. */
int pr_alloc_set(const pr_allocator *a);
/* Copies the installed allocator into *out. */
void pr_alloc_get(pr_allocator *out);

/* ------------------------------------------------- counting and failing */

/* Number of allocations made since the program started, failed ones
 * included. */
uint64_t pr_alloc_count(void);
/* Number of allocations that failed because of pr_alloc_fail_after. */
uint64_t pr_alloc_refused(void);
/* From now on, the n-th allocation (n >= 1; the next one is the first)
 * and every later one fail. n = 0 turns failure injection off again. */
void pr_alloc_fail_after(uint64_t n);

#ifdef __cplusplus
}
#endif
#endif /* PR_ALLOC_H */
