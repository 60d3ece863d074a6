/* Unit tests of the mesher's error table and file:line diagnostics. */
#include "config.h"

#include <stdio.h>

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

static Suite *pdr_error_suite(void)
{
    Suite *s = suite_create("pdr_error");
    TCase *tc = tcase_create("diag");
    tcase_add_test(tc, messages_carry_file_and_line);
    tcase_add_test(tc, storage_is_capped_but_everything_is_counted);
    tcase_add_test(tc, every_code_has_a_message);
    suite_add_tcase(s, tc);
    return s;
}

UNIT_MAIN(pdr_error_suite)
