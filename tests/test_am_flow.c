/* Unit tests of libam's flow control (runtime/am_flow.c) in a one-PE
 * context, where every message goes through the loopback queue under the
 * same window and queue bounds as between PEs: threads and the main
 * context wait for room, callbacks queue within the bound and are then
 * refused with AM_EFULL, nothing is lost or reordered, and the window is
 * never exceeded. The multi-PE floods are in tests/am-flood.sh. */
#include "config.h"

#include <stdlib.h>

#include "am.h"
#include "am_int.h"
#include "unit.h"

#define WINDOW 4096
#define QUEUE 16384

enum { H_DATA = 1, H_KICK = 2, H_ECHO = 3 };

typedef struct flow_test {
    uint32_t next;       /* index expected next */
    int got;
    int bad;             /* out of order, or the window was exceeded */
    size_t largest;      /* largest cost seen in flight at a delivery */
    int accepted;        /* kick handler: sends accepted */
    int refused_with;    /* and the code that stopped it */
    size_t len;          /* message length to send */
    int count;           /* messages to send */
} flow_test;

static am_ctx_t *open_ctx(size_t window, size_t queue)
{
    am_opts_t o = AM_OPTS_INIT;
    o.send_window = window;
    o.send_queue = queue;
    am_ctx_t *ctx;
    ck_assert_int_eq(am_init(NULL, NULL, &o, &ctx), 0);
    return ctx;
}

static void on_data(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    flow_test *t = arg;
    uint32_t idx = 0;
    if (m->len >= 4)
        memcpy(&idx, m->data, 4);
    if (idx != t->next)
        t->bad++;
    t->next = idx + 1;
    t->got++;
    /* This message is still counted in the window while its handler runs. */
    size_t used = ctx->peers[0].win_used;
    if (used > t->largest)
        t->largest = used;
}

static int send_data(am_ctx_t *ctx, flow_test *t, uint32_t idx)
{
    uint8_t *p = calloc(1, t->len);
    memcpy(p, &idx, 4);
    int rc = am_send(ctx, 0, H_DATA, p, t->len);
    free(p);
    return rc;
}

static void sender(am_ctx_t *ctx, void *arg)
{
    flow_test *t = arg;
    for (int i = 0; i < t->count; i++)
        ck_assert_int_eq(send_data(ctx, t, (uint32_t)i), 0);
}

static size_t cost(size_t len)
{
    return len + AM_MSG_OVERHEAD;
}

START_TEST(bytes_parse)
{
    size_t v;
    ck_assert_int_eq(am__bytes_parse("4096", &v), 0);
    ck_assert_uint_eq(v, 4096);
    ck_assert_int_eq(am__bytes_parse("4k", &v), 0);
    ck_assert_uint_eq(v, 4096);
    ck_assert_int_eq(am__bytes_parse("64M", &v), 0);
    ck_assert_uint_eq(v, (size_t)64 << 20);
    ck_assert_int_eq(am__bytes_parse("2MiB", &v), 0);
    ck_assert_uint_eq(v, (size_t)2 << 20);
    ck_assert_int_eq(am__bytes_parse("1G", &v), 0);
    ck_assert_uint_eq(v, (size_t)1 << 30);
    ck_assert_int_eq(am__bytes_parse("0", &v), 0);
    ck_assert_uint_eq(v, 0);
    const char *bad[] = {"", "x", "-1", "4T", "1e3", "4 k", "4kx", "99999999999999"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        ck_assert_int_eq(am__bytes_parse(bad[i], &v), AM_EINVAL);
    /* Through the environment: a window below 4 KiB is refused. */
    setenv("AM_SEND_WINDOW", "1000", 1);
    am_ctx_t *ctx = NULL;
    ck_assert_int_eq(am_init(NULL, NULL, NULL, &ctx), AM_EINVAL);
    ck_assert_ptr_null(ctx);
    unsetenv("AM_SEND_WINDOW");
    ck_assert_str_eq(am_errname(AM_EFULL), "AM_EFULL");
}
END_TEST

/* A thread sending far more than the window waits for room; the loop
 * keeps delivering; everything arrives in order, and the window holds at
 * most WINDOW bytes at any time. */
START_TEST(thread_waits_for_room)
{
    am_ctx_t *ctx = open_ctx(WINDOW, QUEUE);
    flow_test t = {.len = 1000, .count = 300};
    am_register(ctx, H_DATA, "data", on_data, &t);
    am_future_t *done;
    am_future_new(ctx, &done);
    ck_assert_int_eq(am_thread_spawn(ctx, sender, &t, done), 0);
    ck_assert_int_eq(am_run_until_done(ctx, NULL, NULL), 0);
    ck_assert(am_future_ready(done));
    ck_assert_int_eq(t.got, 300);
    ck_assert_int_eq(t.bad, 0);
    ck_assert_uint_le(t.largest, WINDOW);
    am_stats_t st;
    am_stats_get(ctx, &st);
    ck_assert_uint_gt(st.send_waits, 0);
    ck_assert_uint_eq(ctx->peers[0].win_used, 0);
    am_future_free(&done);
    ck_assert_int_eq(am_finalize(&ctx), 0);
}
END_TEST

/* The main context waits like a thread: it drives the loop meanwhile. */
START_TEST(main_context_waits_for_room)
{
    am_ctx_t *ctx = open_ctx(WINDOW, QUEUE);
    flow_test t = {.len = 700, .count = 200};
    am_register(ctx, H_DATA, "data", on_data, &t);
    for (int i = 0; i < t.count; i++) {
        ck_assert_int_eq(send_data(ctx, &t, (uint32_t)i), 0);
        ck_assert_uint_le(ctx->loopback.n * cost(t.len), WINDOW);
    }
    ck_assert_int_eq(am_run_until_done(ctx, NULL, NULL), 0);
    ck_assert_int_eq(t.got, 200);
    ck_assert_int_eq(t.bad, 0);
    ck_assert_uint_le(t.largest, WINDOW);
    ck_assert_int_eq(am_finalize(&ctx), 0);
}
END_TEST

/* A handler cannot wait: its sends beyond the window are queued up to
 * QUEUE bytes, then refused with AM_EFULL; what was accepted arrives. */
static void on_kick(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)m;
    flow_test *t = arg;
    for (int i = 0; i < 1000; i++) {
        int rc = send_data(ctx, t, (uint32_t)i);
        if (rc) {
            t->refused_with = rc;
            return;
        }
        t->accepted++;
    }
}

START_TEST(handler_sends_queue_then_refuse)
{
    am_ctx_t *ctx = open_ctx(WINDOW, QUEUE);
    flow_test t = {.len = 1000};
    am_register(ctx, H_DATA, "data", on_data, &t);
    am_register(ctx, H_KICK, "kick", on_kick, &t);
    ck_assert_int_eq(am_send(ctx, 0, H_KICK, NULL, 0), 0);
    ck_assert_int_eq(am_run_until_done(ctx, NULL, NULL), 0);
    ck_assert_int_eq(t.refused_with, AM_EFULL);
    size_t took = (size_t)t.accepted * cost(t.len);
    /* The window had room for all but the kick itself; then the queue. */
    ck_assert_uint_gt(took + cost(t.len), QUEUE);
    ck_assert_uint_le(took, WINDOW + QUEUE);
    ck_assert_int_eq(t.got, t.accepted);
    ck_assert_int_eq(t.bad, 0);
    ck_assert_uint_le(t.largest, WINDOW);
    am_stats_t st;
    am_stats_get(ctx, &st);
    ck_assert_uint_gt(st.held_sends, 0);
    ck_assert_uint_eq(ctx->held_total, 0);
    ck_assert_int_eq(am_finalize(&ctx), 0);
}
END_TEST

/* A message larger than the window goes alone, once at most half of the
 * window is in use; it is never refused from a thread. */
START_TEST(oversized_messages_go_alone)
{
    am_ctx_t *ctx = open_ctx(WINDOW, QUEUE);
    flow_test t = {.len = 3 * WINDOW, .count = 5};
    am_register(ctx, H_DATA, "data", on_data, &t);
    ck_assert_int_eq(am_thread_spawn(ctx, sender, &t, NULL), 0);
    ck_assert_int_eq(am_run_until_done(ctx, NULL, NULL), 0);
    ck_assert_int_eq(t.got, 5);
    ck_assert_int_eq(t.bad, 0);
    ck_assert_uint_eq(t.largest, cost(t.len));
    ck_assert_int_eq(am_finalize(&ctx), 0);
}
END_TEST

/* RPC requests and replies are under flow control too: requests from
 * threads wait, replies from the handler queue. */
static void on_echo(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)arg;
    ck_assert_int_eq(am_reply(ctx, m, m->data, m->len), 0);
}

static void caller(am_ctx_t *ctx, void *arg)
{
    int *ok = arg;
    uint8_t req[3000];
    for (int i = 0; i < 40; i++) {
        memset(req, i, sizeof req);
        void *rep = NULL;
        size_t len = 0;
        ck_assert_int_eq(am_call(ctx, 0, H_ECHO, req, sizeof req, &rep, &len), 0);
        *ok += len == sizeof req && !memcmp(rep, req, len);
        free(rep);
    }
}

START_TEST(rpc_under_flow_control)
{
    am_ctx_t *ctx = open_ctx(WINDOW, QUEUE);
    am_register(ctx, H_ECHO, "echo", on_echo, NULL);
    int ok[4] = {0};
    for (int i = 0; i < 4; i++)
        ck_assert_int_eq(am_thread_spawn(ctx, caller, &ok[i], NULL), 0);
    ck_assert_int_eq(am_run_until_done(ctx, NULL, NULL), 0);
    for (int i = 0; i < 4; i++)
        ck_assert_int_eq(ok[i], 40);
    ck_assert_int_eq(am_finalize(&ctx), 0);
}
END_TEST

static Suite *flow_suite(void)
{
    Suite *s = suite_create("am_flow");
    TCase *tc = tcase_create("flow");
    tcase_set_timeout(tc, 20);
    tcase_add_test(tc, bytes_parse);
    tcase_add_test(tc, thread_waits_for_room);
    tcase_add_test(tc, main_context_waits_for_room);
    tcase_add_test(tc, handler_sends_queue_then_refuse);
    tcase_add_test(tc, oversized_messages_go_alone);
    tcase_add_test(tc, rpc_under_flow_control);
    suite_add_tcase(s, tc);
    return s;
}

UNIT_MAIN(flow_suite)
