/* Unit tests of the allocation hook (proto/pr_alloc.h): counting, failure
 * injection, the rules every allocator keeps (0 bytes, overflow, a failed
 * realloc keeps its block), another allocator installed, and proto's own
 * decoders failing cleanly at every allocation. Check runs each test in
 * its own process, so the hook's counters start from the program's. */
#include "config.h"

#include <pthread.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "pr.h"
#include "pr_alloc.h"
#include "pr_sample.h"
#include "unit.h"

START_TEST(every_allocating_call_counts_once)
{
    uint64_t c0 = pr_alloc_count();
    void *a = pr_malloc(10);
    ck_assert_uint_eq(pr_alloc_count(), c0 + 1);
    void *b = pr_calloc(3, 4);
    ck_assert_uint_eq(pr_alloc_count(), c0 + 2);
    a = pr_realloc(a, 100);
    ck_assert_uint_eq(pr_alloc_count(), c0 + 3);
    char *s = pr_strdup("mesh");
    ck_assert_uint_eq(pr_alloc_count(), c0 + 4);
    char *t = pr_strndup("tetrahedron", 3);
    ck_assert_uint_eq(pr_alloc_count(), c0 + 5);
    ck_assert_ptr_nonnull(a);
    ck_assert_ptr_nonnull(b);
    ck_assert_str_eq(s, "mesh");
    ck_assert_str_eq(t, "tet");
    pr_free(a);
    pr_free(b);
    pr_free(s);
    pr_free(t);
    pr_free(NULL);
    ck_assert_uint_eq(pr_alloc_count(), c0 + 5); /* freeing is not counted */
    ck_assert_uint_eq(pr_alloc_refused(), 0);
}
END_TEST

START_TEST(null_means_out_of_memory_only)
{
    /* 0 bytes is 1 byte: never a NULL that is not a failure. */
    void *p = pr_malloc(0);
    void *q = pr_calloc(0, 8);
    void *r = pr_realloc(NULL, 0);
    ck_assert_ptr_nonnull(p);
    ck_assert_ptr_nonnull(q);
    ck_assert_ptr_nonnull(r);
    r = pr_realloc(r, 0);
    ck_assert_ptr_nonnull(r);
    pr_free(p);
    pr_free(q);
    pr_free(r);
    /* n * size past SIZE_MAX fails instead of wrapping. */
    ck_assert_ptr_null(pr_calloc(SIZE_MAX / 2, 3));
    /* calloc is zeroed, strndup stops at the end of a shorter string. */
    unsigned char *z = pr_calloc(64, 4);
    ck_assert_ptr_nonnull(z);
    for (int i = 0; i < 256; i++)
        ck_assert_uint_eq(z[i], 0);
    pr_free(z);
    char *s = pr_strndup("ab", 100);
    ck_assert_str_eq(s, "ab");
    pr_free(s);
}
END_TEST

START_TEST(fail_after_n_fails_the_nth_and_every_later_one)
{
    pr_alloc_fail_after(3);
    void *a = pr_malloc(8);
    char *b = pr_strdup("x");
    ck_assert_ptr_nonnull(a);
    ck_assert_ptr_nonnull(b);
    ck_assert_ptr_null(pr_malloc(8));           /* the 3rd */
    ck_assert_ptr_null(pr_calloc(1, 1));        /* and every later one */
    ck_assert_ptr_null(pr_strdup("y"));
    ck_assert_ptr_null(pr_strndup("y", 1));
    ck_assert_ptr_null(pr_realloc(NULL, 4));
    ck_assert_uint_eq(pr_alloc_refused(), 5);
    /* A failed realloc leaves the block as it was, still owned. */
    memcpy(a, "abcdefg", 8);
    ck_assert_ptr_null(pr_realloc(a, 1 << 20));
    ck_assert_str_eq(a, "abcdefg");
    ck_assert_uint_eq(pr_alloc_refused(), 6);
    /* Off again. */
    pr_alloc_fail_after(0);
    void *c = pr_malloc(8);
    ck_assert_ptr_nonnull(c);
    ck_assert_uint_eq(pr_alloc_refused(), 6);
    /* n counts from the call: 1 is the very next allocation. */
    pr_alloc_fail_after(1);
    ck_assert_ptr_null(pr_malloc(8));
    pr_alloc_fail_after(0);
    pr_free(a);
    pr_free(b);
    pr_free(c);
}
END_TEST

/* A custom allocator that keeps its own books through ud: a header before
 * each block holds its size, so the test can check that every byte handed
 * out came back. */
struct books {
    int allocs, zallocs, resizes, releases;
    long live;   /* blocks not yet released */
    size_t last; /* size of the latest request */
};

static void *b_alloc(void *ud, size_t size)
{
    struct books *bk = ud;
    bk->allocs++;
    bk->last = size;
    size_t *h = malloc(sizeof(size_t) + size);
    if (!h)
        return NULL;
    *h = size;
    bk->live++;
    memset(h + 1, 0xA5, size); /* not zero: pr_calloc must clear it */
    return h + 1;
}

static void *b_resize(void *ud, void *p, size_t size)
{
    struct books *bk = ud;
    bk->resizes++;
    bk->last = size;
    size_t *h = realloc((size_t *)p - 1, sizeof(size_t) + size);
    if (!h)
        return NULL;
    *h = size;
    return h + 1;
}

static void b_release(void *ud, void *p)
{
    struct books *bk = ud;
    bk->releases++;
    bk->live--;
    free((size_t *)p - 1);
}

static void *b_zalloc(void *ud, size_t n, size_t size)
{
    struct books *bk = ud;
    bk->zallocs++;
    void *p = b_alloc(ud, n * size);
    bk->allocs--;
    if (p)
        memset(p, 0, n * size);
    return p;
}

START_TEST(another_allocator_gets_every_call)
{
    struct books bk = {0};
    pr_allocator a = {b_alloc, NULL, b_resize, b_release, &bk};
    ck_assert_int_eq(pr_alloc_set(&a), 0);
    pr_allocator got;
    pr_alloc_get(&got);
    ck_assert_ptr_eq(got.ud, &bk);

    char *s = pr_strdup("refine");
    ck_assert_int_eq(bk.allocs, 1);
    ck_assert_str_eq(s, "refine");
    unsigned char *z = pr_calloc(10, 10);
    ck_assert_int_eq(bk.allocs, 2); /* no zalloc: alloc, then cleared */
    for (int i = 0; i < 100; i++)
        ck_assert_uint_eq(z[i], 0);
    s = pr_realloc(s, 4096);
    ck_assert_int_eq(bk.resizes, 1);
    ck_assert_str_eq(s, "refine");
    void *e = pr_malloc(0);
    ck_assert_uint_eq(bk.last, 1); /* never asked for 0 bytes */
    void *f = pr_realloc(NULL, 5);
    ck_assert_int_eq(bk.allocs, 4); /* realloc of NULL is an alloc */
    ck_assert_int_eq(bk.resizes, 1);

    /* Failure injection sits in front of the allocator: a refused call
     * never reaches it. */
    pr_alloc_fail_after(1);
    ck_assert_ptr_null(pr_malloc(1));
    ck_assert_ptr_null(pr_realloc(s, 10));
    ck_assert_int_eq(bk.allocs, 4);
    ck_assert_int_eq(bk.resizes, 1);
    pr_alloc_fail_after(0);

    pr_free(s);
    pr_free(z);
    pr_free(e);
    pr_free(f);
    pr_free(NULL); /* not passed on */
    ck_assert_int_eq(bk.releases, 4);
    ck_assert_int_eq(bk.live, 0);

    /* With a zalloc, pr_calloc uses it. */
    a.zalloc = b_zalloc;
    ck_assert_int_eq(pr_alloc_set(&a), 0);
    z = pr_calloc(3, 5);
    ck_assert_int_eq(bk.zallocs, 1);
    ck_assert_uint_eq(bk.last, 15);
    pr_free(z);
    ck_assert_int_eq(bk.live, 0);

    /* A required function missing: refused, the installed one stays. */
    pr_allocator bad = {b_alloc, NULL, NULL, b_release, &bk};
    ck_assert_int_eq(pr_alloc_set(&bad), PR_EINVAL);
    pr_alloc_get(&got);
    ck_assert_ptr_eq((void *)got.resize, (void *)b_resize);

    /* NULL puts the C library's back. */
    ck_assert_int_eq(pr_alloc_set(NULL), 0);
    int before = bk.allocs;
    void *g = pr_malloc(16);
    pr_free(g);
    ck_assert_int_eq(bk.allocs, before);
}
END_TEST

/* proto's own allocations under the hook: a growing pr_buf keeps
 * PR_ENOMEM and its old bytes, and decoding a sample submesh fails with
 * PR_ENOMEM (nothing leaked: ASan in the sanitizer build) at every one of
 * its allocations, then succeeds. */
START_TEST(proto_fails_cleanly_at_every_allocation)
{
    pr_buf b = PR_BUF_INIT;
    pr_put_u32(&b, 7);
    ck_assert_int_eq(b.err, 0);
    pr_alloc_fail_after(1);
    for (int i = 0; i < 100000 && !b.err; i++)
        pr_put_u64(&b, (uint64_t)i);
    ck_assert_int_eq(b.err, PR_ENOMEM);
    ck_assert_uint_eq(pr_load_u32(b.data), 7);
    pr_alloc_fail_after(0);
    pr_buf_free(&b);

    pr_buf msg = PR_BUF_INIT;
    ck_assert_int_eq(prs_fixed(PRS_SUBMESH, &msg), 0);
    uint64_t n;
    for (n = 1;; n++) {
        pr_submesh *sm = NULL;
        pr_alloc_fail_after(n);
        uint64_t refused = pr_alloc_refused();
        int rc = pr_submesh_decode(msg.data, msg.len, &sm);
        int hit = pr_alloc_refused() > refused;
        pr_alloc_fail_after(0);
        if (!hit) {
            ck_assert_int_eq(rc, 0);
            pr_submesh_free(&sm);
            break;
        }
        ck_assert_int_eq(rc, PR_ENOMEM);
        ck_assert_ptr_null(sm);
    }
    ck_assert_uint_ge(n, 2); /* it did allocate */
    pr_buf_free(&msg);
}
END_TEST

/* Threads allocating at once: every allocation is counted exactly once. */
#define THREADS 4
#define PER_THREAD 20000

static void *alloc_loop(void *arg)
{
    (void)arg;
    for (int i = 0; i < PER_THREAD; i++)
        pr_free(pr_malloc((size_t)i % 64));
    return NULL;
}

START_TEST(threads_are_counted_exactly)
{
    uint64_t c0 = pr_alloc_count();
    pthread_t t[THREADS];
    for (int i = 0; i < THREADS; i++)
        ck_assert_int_eq(pthread_create(&t[i], NULL, alloc_loop, NULL), 0);
    for (int i = 0; i < THREADS; i++)
        pthread_join(t[i], NULL);
    ck_assert_uint_eq(pr_alloc_count(), c0 + (uint64_t)THREADS * PER_THREAD);
}
END_TEST

static Suite *pr_alloc_suite(void)
{
    Suite *s = suite_create("pr_alloc");
    TCase *tc = tcase_create("hook");
    tcase_add_test(tc, every_allocating_call_counts_once);
    tcase_add_test(tc, null_means_out_of_memory_only);
    tcase_add_test(tc, fail_after_n_fails_the_nth_and_every_later_one);
    tcase_add_test(tc, another_allocator_gets_every_call);
    tcase_add_test(tc, proto_fails_cleanly_at_every_allocation);
    tcase_add_test(tc, threads_are_counted_exactly);
    suite_add_tcase(s, tc);
    return s;
}

UNIT_MAIN(pr_alloc_suite)
