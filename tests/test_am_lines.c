/* Unit tests of how a PE writes what others read line by line: every
 * diagnostic line goes out in one write call (PEs share the launcher's
 * stderr, and a line written in pieces can be cut by another PE's), and so
 * does the failure line a PE sends the launcher (AM_REPORT_FD).
 *
 * A SOCK_SEQPACKET socket keeps the boundaries of writes: each write is
 * one record, so the tests count the records a line took. */
#include "config.h"

#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "am_int.h"
#include "unit.h"

/* The records written to fd 2 (or to the context's report fd) while fn
 * runs, one per element of out[] (NUL-terminated); returns their number. */
typedef struct capture {
    int sv[2];
    int saved;
} capture;

static void capture_begin(capture *c, int fd)
{
    ck_assert_int_eq(socketpair(AF_UNIX, SOCK_SEQPACKET, 0, c->sv), 0);
    c->saved = dup(fd);
    ck_assert_int_ge(c->saved, 0);
    ck_assert_int_eq(dup2(c->sv[0], fd), fd);
}

static int capture_end(capture *c, int fd, char out[][2048], int max)
{
    ck_assert_int_eq(dup2(c->saved, fd), fd);
    close(c->saved);
    close(c->sv[0]);
    fcntl(c->sv[1], F_SETFL, O_NONBLOCK);
    int n = 0;
    for (;;) {
        char tmp[2048];
        ssize_t k = recv(c->sv[1], tmp, sizeof tmp - 1, 0);
        if (k <= 0)
            break;
        if (n < max) {
            memcpy(out[n], tmp, (size_t)k);
            out[n][k] = '\0';
        }
        n++;
    }
    close(c->sv[1]);
    return n;
}

static am_ctx_t *fake_ctx(int rank, int size)
{
    am_ctx_t *ctx = calloc(1, sizeof *ctx);
    ck_assert_ptr_nonnull(ctx);
    ctx->rank = rank;
    ctx->size = size;
    ctx->culprit = -1;
    ctx->report_fd = -1;
    ctx->state = AM__BOOTING; /* am__fail records and returns */
    return ctx;
}

START_TEST(a_warning_is_one_write)
{
    am_ctx_t *ctx = fake_ctx(3, 8);
    char rec[4][2048];
    capture c;
    capture_begin(&c, 2);
    am__warn(ctx, "PE %d went away: %s", 5, "its connection is gone");
    am__warn(NULL, "no context");
    int n = capture_end(&c, 2, rec, 4);
    ck_assert_int_eq(n, 2);
    ck_assert_str_eq(rec[0], "am: PE 3: PE 5 went away: its connection is gone\n");
    ck_assert_str_eq(rec[1], "am: no context\n");
    free(ctx);
}
END_TEST

static void vline(int fd, const char *prefix, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    am__vline(fd, prefix, fmt, ap);
    va_end(ap);
}

START_TEST(a_long_line_is_cut_not_split)
{
    char big[3000];
    memset(big, 'x', sizeof big - 1);
    big[sizeof big - 1] = '\0';
    char rec[4][2048];
    capture c;
    capture_begin(&c, 2);
    vline(2, "am-run: ", "%s", big);
    int n = capture_end(&c, 2, rec, 4);
    ck_assert_int_eq(n, 1);
    size_t len = strlen(rec[0]);
    ck_assert_uint_le(len, 1024);
    ck_assert_uint_ge(len, 1000);
    ck_assert_int_eq(strncmp(rec[0], "am-run: xxx", 11), 0);
    ck_assert_int_eq(rec[0][len - 1], '\n');
}
END_TEST

/* The records of sv[1] after sv[0] was closed. */
static int records(int sv[2], char out[][2048], int max)
{
    close(sv[0]);
    fcntl(sv[1], F_SETFL, O_NONBLOCK);
    int n = 0;
    ssize_t k;
    while ((k = recv(sv[1], out[n < max ? n : max - 1], 2047, 0)) > 0) {
        out[n < max ? n : max - 1][k] = '\0';
        n++;
    }
    close(sv[1]);
    return n;
}

START_TEST(a_failure_is_reported_in_one_line)
{
    /* Its own failure names itself; a peer's failure names the peer; an
     * ABORT that names nobody (culprit -2) reports -1. */
    static const int culprits[][3] = {{-1, 3, AM_ETIMEOUT},
                                      {5, 5, AM_EPEER},
                                      {-2, -1, AM_EPEER}};
    for (int i = 0; i < 3; i++) {
        am_ctx_t *ctx = fake_ctx(3, 8);
        int sv[2];
        char rec[4][2048], err[4][2048], want[64];
        ck_assert_int_eq(socketpair(AF_UNIX, SOCK_SEQPACKET, 0, sv), 0);
        ctx->report_fd = sv[0];
        ctx->culprit = culprits[i][0];
        capture e;
        capture_begin(&e, 2);
        am__fail(ctx, culprits[i][2], "the reason");
        ck_assert_int_eq(capture_end(&e, 2, err, 4), 1);
        ck_assert_str_eq(err[0], "am: PE 3: the reason\n");
        ck_assert_int_eq(records(sv, rec, 4), 1);
        snprintf(want, sizeof want, "FAIL 3 %d %d\n", culprits[i][1],
                 culprits[i][2]);
        ck_assert_str_eq(rec[0], want);
        free(ctx);
    }
}
END_TEST

static Suite *am_lines_suite(void)
{
    Suite *s = suite_create("am_lines");
    TCase *tc = tcase_create("lines");
    tcase_add_test(tc, a_warning_is_one_write);
    tcase_add_test(tc, a_long_line_is_cut_not_split);
    tcase_add_test(tc, a_failure_is_reported_in_one_line);
    suite_add_tcase(s, tc);
    return s;
}

UNIT_MAIN(am_lines_suite)
