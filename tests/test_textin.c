/* Unit tests of the text reader and of atomic output files. */
#include "config.h"

#include <stdio.h>
#include <sys/stat.h>
#include <unistd.h>

#include "base/outfile.h"
#include "base/pdr_util.h"
#include "base/textin.h"
#include "unit.h"

static textin open_text(const char *text, pdr_diag *d)
{
    FILE *f = fmemopen((void *)text, strlen(text), "r");
    ck_assert_ptr_nonnull(f);
    textin t;
    textin_attach(&t, f, "in.node", d);
    return t;
}

START_TEST(comments_and_blank_lines_are_skipped_and_lines_counted)
{
    pdr_diag d = {0};
    textin t = open_text("# header\n\n  4 3 # four points\n\t\n1 0.5 -2e3 7\n", &d);
    long n;
    double x;
    ck_assert_int_eq(textin_next(&t), 1);
    ck_assert_int_eq(t.line, 3);
    ck_assert_int_eq(textin_long(&t, "count", 0, 100, &n), 0);
    ck_assert_int_eq(n, 4);
    ck_assert_int_eq(textin_long(&t, "dim", 3, 3, &n), 0);
    ck_assert(textin_at_eol(&t));
    ck_assert_int_eq(textin_next(&t), 1);
    ck_assert_int_eq(t.line, 5);
    ck_assert_int_eq(textin_long(&t, "index", 0, 100, &n), 0);
    ck_assert_int_eq(textin_double(&t, "x", &x), 0);
    ck_assert(x == 0.5);
    ck_assert_int_eq(textin_double(&t, "y", &x), 0);
    ck_assert(x == -2e3);
    ck_assert_int_eq(textin_opt_double(&t, "z", &x), 0);
    ck_assert(x == 7);
    ck_assert_int_eq(textin_opt_double(&t, "attribute", &x), 1);
    ck_assert_int_eq(textin_next(&t), 0);
    ck_assert_uint_eq(d.ntotal, 0);
    FILE *f = t.f;
    textin_close(&t);
    fclose(f);
}
END_TEST

START_TEST(bad_numbers_are_reported_with_file_and_line)
{
    pdr_diag d = {0};
    textin t = open_text("1 2\n3 x4\n5 1e999\n6 -1\n7\n", &d);
    long n;
    double x;
    ck_assert_int_eq(textin_next(&t), 1);
    ck_assert_int_eq(textin_next(&t), 1);
    ck_assert_int_eq(textin_long(&t, "index", 0, 9, &n), 0);
    ck_assert_int_eq(textin_double(&t, "x coordinate", &x), PDR_EPARSE);
    ck_assert_int_eq(textin_next(&t), 1);
    textin_long(&t, "index", 0, 9, &n);
    ck_assert_int_eq(textin_double(&t, "y coordinate", &x), PDR_EPARSE);
    ck_assert_int_eq(textin_next(&t), 1);
    textin_long(&t, "index", 0, 9, &n);
    ck_assert_int_eq(textin_long(&t, "count", 0, 9, &n), PDR_EPARSE);
    ck_assert_int_eq(textin_next(&t), 1);
    textin_long(&t, "index", 0, 9, &n);
    ck_assert_int_eq(textin_double(&t, "z coordinate", &x), PDR_EPARSE);
    ck_assert_uint_eq(d.nkept, 4);
    ck_assert_str_eq(d.msgs[0], "in.node:2: x coordinate: 'x4' is not a number");
    ck_assert_str_eq(d.msgs[1], "in.node:3: y coordinate 1e999 is not a finite number");
    ck_assert_str_eq(d.msgs[2], "in.node:4: count -1 is out of range [0, 9]");
    ck_assert_str_eq(d.msgs[3], "in.node:5: missing z coordinate");
    FILE *f = t.f;
    textin_close(&t);
    fclose(f);
    pdr_diag_free(&d);
}
END_TEST

START_TEST(missing_file_is_a_clear_error)
{
    pdr_diag d = {0};
    textin t;
    ck_assert_int_eq(textin_open(&t, "/nonexistent/x.node", &d), PDR_EIO);
    ck_assert_uint_eq(d.nkept, 1);
    ck_assert_str_eq(d.msgs[0], "/nonexistent/x.node: cannot open: No such file or directory");
    pdr_diag_free(&d);
}
END_TEST

START_TEST(outfile_replaces_atomically_or_not_at_all)
{
    char dir[] = "/tmp/pdr-outfile-XXXXXX";
    ck_assert_ptr_nonnull(mkdtemp(dir));
    char path[256];
    snprintf(path, sizeof path, "%s/mesh.node", dir);
    pdr_diag d = {0};

    outfile of;
    ck_assert_int_eq(outfile_open(&of, path, &d), 0);
    fprintf(of.f, "old\n");
    ck_assert_int_eq(outfile_commit(&of, &d), 0);

    /* An aborted write leaves the old file as it was and no temporary. */
    ck_assert_int_eq(outfile_open(&of, path, &d), 0);
    fprintf(of.f, "new but abandoned\n");
    outfile_abort(&of);
    FILE *f = fopen(path, "r");
    char line[64] = "";
    ck_assert_ptr_nonnull(fgets(line, sizeof line, f));
    fclose(f);
    ck_assert_str_eq(line, "old\n");

    char cmd[300];
    snprintf(cmd, sizeof cmd, "test $(ls %s | wc -l) -eq 1", dir);
    ck_assert_int_eq(system(cmd), 0);

    ck_assert_int_eq(outfile_open(&of, "/nonexistent/dir/x.ele", &d), PDR_EIO);
    ck_assert_uint_eq(d.nkept, 1);
    unlink(path);
    rmdir(dir);
    pdr_diag_free(&d);
}
END_TEST

START_TEST(clock_advances)
{
    double t0 = pdr_now();
    usleep(2000);
    ck_assert(pdr_now() - t0 >= 0.0015);
    ck_assert_uint_gt(pdr_peak_rss(), 0);
}
END_TEST

static Suite *textin_suite(void)
{
    Suite *s = suite_create("textin");
    TCase *tc = tcase_create("textin");
    tcase_add_test(tc, comments_and_blank_lines_are_skipped_and_lines_counted);
    tcase_add_test(tc, bad_numbers_are_reported_with_file_and_line);
    tcase_add_test(tc, missing_file_is_a_clear_error);
    suite_add_tcase(s, tc);
    tc = tcase_create("outfile");
    tcase_add_test(tc, outfile_replaces_atomically_or_not_at_all);
    tcase_add_test(tc, clock_advances);
    suite_add_tcase(s, tc);
    return s;
}

UNIT_MAIN(textin_suite)
