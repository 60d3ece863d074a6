/* Unit tests of the mesher's error table and file:line diagnostics, and
 * of what the output stages share between threads: moving messages and
 * finished files from one list to another, and the fork-join. */
#include "config.h"

#include <stdatomic.h>
#include <stdio.h>
#include <unistd.h>

#include "base/fj.h"
#include "base/outfile.h"
#include "base/pdr_error.h"
#include "unit.h"

START_TEST(messages_carry_file_and_line)
{
    pdr_diag d = {0};
    ck_assert_int_eq(pdr_diag_add(&d, "box.poly", 17, "facet %d is not planar", 3), 1);
    ck_assert_int_eq(pdr_diag_add(&d, "box.poly", 0, "no facets"), 2);
    ck_assert_int_eq(pdr_diag_add(&d, NULL, 0, "plain"), 3);
    ck_assert_uint_eq(d.nkept, 3);
    ck_assert_str_eq(d.msgs[0], "box.poly:17: facet 3 is not planar");
    ck_assert_str_eq(d.msgs[1], "box.poly: no facets");
    ck_assert_str_eq(d.msgs[2], "plain");
    pdr_diag_free(&d);
    ck_assert_uint_eq(d.ntotal, 0);
}
END_TEST

START_TEST(storage_is_capped_but_everything_is_counted)
{
    pdr_diag d = {0};
    for (int i = 0; i < PDR_DIAG_KEEP + 50; i++)
        pdr_diag_add(&d, "f", i + 1, "error %d", i);
    ck_assert_uint_eq(d.nkept, PDR_DIAG_KEEP);
    ck_assert_uint_eq(d.ntotal, PDR_DIAG_KEEP + 50);

    char *text = NULL;
    size_t size = 0;
    FILE *f = open_memstream(&text, &size);
    ck_assert_ptr_nonnull(f);
    pdr_diag_print(&d, f);
    fclose(f);
    ck_assert_ptr_nonnull(strstr(text, "f:1: error 0\n"));
    ck_assert_ptr_nonnull(strstr(text, "(50 more messages not shown)"));
    free(text);
    pdr_diag_free(&d);
}
END_TEST

START_TEST(every_code_has_a_message)
{
    ck_assert_str_eq(pdr_strerror(PDR_EOK), "success");
    ck_assert_str_eq(pdr_strerror(PDR_EPARSE), "malformed input file");
    ck_assert_str_eq(pdr_strerror(-1000), "unknown pdr error");
}
END_TEST

START_TEST(diag_move_appends_in_order)
{
    pdr_diag a = {0}, b = {0};
    pdr_diag_add(&b, "x", 1, "first");
    pdr_diag_add(&b, "x", 2, "second");
    pdr_diag_move(&a, &b); /* into an empty list: taken whole */
    ck_assert_uint_eq(a.nkept, 2);
    ck_assert_uint_eq(b.nkept, 0);
    ck_assert_uint_eq(b.ntotal, 0);
    ck_assert_ptr_null(b.msgs);
    pdr_diag_add(&b, "y", 3, "third");
    pdr_diag_move(&a, &b);
    ck_assert_uint_eq(a.nkept, 3);
    ck_assert_uint_eq(a.ntotal, 3);
    ck_assert_str_eq(a.msgs[2], "y:3: third");
    /* beyond the cap: counted, not kept */
    for (int i = 0; i < PDR_DIAG_KEEP; i++)
        pdr_diag_add(&b, "z", i + 1, "many");
    pdr_diag_move(&a, &b);
    ck_assert_uint_eq(a.nkept, PDR_DIAG_KEEP);
    ck_assert_uint_eq(a.ntotal, PDR_DIAG_KEEP + 3);
    pdr_diag_free(&a);
    pdr_diag_free(&b);
}
END_TEST

START_TEST(outset_move_keeps_the_order_and_the_bound)
{
    char dir[] = "/tmp/pdr-outset-XXXXXX";
    ck_assert_ptr_nonnull(mkdtemp(dir));
    char path[3][64];
    outset s1 = OUTSET_INIT, s2 = OUTSET_INIT, all = OUTSET_INIT;
    for (int i = 0; i < 3; i++) {
        snprintf(path[i], sizeof path[i], "%s/f%d", dir, i);
        outfile of;
        ck_assert_int_eq(outfile_open_in(&of, i ? &s2 : &s1, path[i], NULL), 0);
        fprintf(of.f, "%d\n", i);
        ck_assert_int_eq(outfile_commit(&of, NULL), 0);
        ck_assert_int_ne(access(path[i], F_OK), 0); /* waits in its set */
    }
    ck_assert_int_eq(outset_move(&all, &s1), 0);
    ck_assert_int_eq(outset_move(&all, &s2), 0);
    ck_assert_uint_eq(s1.n + s2.n, 0);
    ck_assert_uint_eq(all.n, 3);
    for (int i = 0; i < 3; i++)
        ck_assert_str_eq(all.path[i], path[i]);
    outset full = OUTSET_INIT;
    full.n = OUTSET_MAX - 2;
    ck_assert_int_eq(outset_move(&full, &all), PDR_ELIMIT);
    ck_assert_uint_eq(all.n, 3); /* nothing moved */
    ck_assert_int_eq(outset_commit(&all, NULL), 0);
    for (int i = 0; i < 3; i++) {
        ck_assert_int_eq(access(path[i], F_OK), 0);
        ck_assert_int_eq(unlink(path[i]), 0);
    }
    ck_assert_int_eq(rmdir(dir), 0); /* no temporary left */
}
END_TEST

static int count_task(void *arg)
{
    atomic_int *n = arg;
    atomic_fetch_add(n, 1);
    return 7;
}

START_TEST(fork_join_runs_every_task_once)
{
    for (unsigned threads = 0; threads <= 9; threads += 3) {
        atomic_int n[5];
        fj_task t[5];
        for (int i = 0; i < 5; i++) {
            atomic_init(&n[i], 0);
            t[i] = (fj_task){.run = count_task, .arg = &n[i], .rc = -1};
        }
        fj_run(t, 5, threads);
        for (int i = 0; i < 5; i++) {
            ck_assert_int_eq(atomic_load(&n[i]), 1);
            ck_assert_int_eq(t[i].rc, 7);
            ck_assert(t[i].seconds >= 0);
        }
    }
    fj_run(NULL, 0, 4); /* nothing to do */
    ck_assert_uint_ge(fj_cores(), 1);
}
END_TEST

static Suite *pdr_error_suite(void)
{
    Suite *s = suite_create("pdr_error");
    TCase *tc = tcase_create("diag");
    tcase_add_test(tc, messages_carry_file_and_line);
    tcase_add_test(tc, storage_is_capped_but_everything_is_counted);
    tcase_add_test(tc, every_code_has_a_message);
    tcase_add_test(tc, diag_move_appends_in_order);
    tcase_add_test(tc, outset_move_keeps_the_order_and_the_bound);
    tcase_add_test(tc, fork_join_runs_every_task_once);
    suite_add_tcase(s, tc);
    return s;
}

UNIT_MAIN(pdr_error_suite)
