/* Unit tests of time accounting, the statistics JSON, options from argv,
 * and the loop on a one-PE job (messages to itself, termination). */
#include "config.h"

#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "am_int.h"
#include "unit.h"

static void spin(double seconds)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    double end = (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9 + seconds;
    do
        clock_gettime(CLOCK_MONOTONIC, &ts);
    while ((double)ts.tv_sec + (double)ts.tv_nsec * 1e-9 < end);
}

static am_ctx_t *open_ctx(void)
{
    am_ctx_t *ctx;
    ck_assert_int_eq(am_init(NULL, NULL, NULL, &ctx), 0);
    return ctx;
}

/* ------------------------------------------------------------ categories */

START_TEST(categories_nest_and_overlap)
{
    am_ctx_t *ctx = open_ctx();
    int a = am_category(ctx, "masked"), b = am_category(ctx, "setback");
    ck_assert_int_ge(a, 0);
    ck_assert_int_ne(a, b);
    ck_assert_int_eq(am_category(ctx, "masked"), a);
    ck_assert_int_eq(am_category(ctx, ""), AM_EINVAL);
    ck_assert(am_time_total(ctx, a) == 0);

    am_time_begin(ctx, a);
    spin(0.01);
    am_time_begin(ctx, a); /* nested: counted once */
    am_time_begin(ctx, b); /* overlapping: independent */
    spin(0.01);
    am_time_end(ctx, b);
    am_time_end(ctx, a);
    double open = am_time_total(ctx, a); /* still open once */
    ck_assert(open >= 0.02);
    spin(0.01);
    am_time_end(ctx, a);
    double ta = am_time_total(ctx, a), tb = am_time_total(ctx, b);
    ck_assert(ta >= 0.03 && ta < 0.5);
    ck_assert(tb >= 0.01 && tb < ta);
    /* Closed: no longer grows; an unbalanced end is ignored. */
    am_time_end(ctx, a);
    spin(0.005);
    ck_assert(am_time_total(ctx, a) == ta);
    am_count(ctx, b, 5);
    am_count(ctx, b, -2);
    ck_assert(ctx->cats[b].counter == 3);
    ck_assert(ctx->cats[a].begins == 2);
    /* Unknown ids are ignored, never a crash. */
    am_time_begin(ctx, 63);
    am_time_end(ctx, -1);
    am_count(ctx, 99, 1);
    ck_assert(am_time_total(ctx, 40) == 0);
    for (int i = 2; i < 64; i++) {
        char name[16];
        snprintf(name, sizeof name, "c%d", i);
        ck_assert_int_eq(am_category(ctx, name), i);
    }
    ck_assert_int_eq(am_category(ctx, "one too many"), AM_EINVAL);
    am_finalize(&ctx);
}
END_TEST

/* ------------------------------------------------------------------ JSON */

/* A small JSON validator: returns the position after one value, or NULL. */
static const char *skip_ws(const char *p)
{
    while (*p == ' ' || *p == '\n' || *p == '\t' || *p == '\r')
        p++;
    return p;
}

static const char *json_value(const char *p, int depth);

static const char *json_string(const char *p)
{
    if (*p++ != '"')
        return NULL;
    while (*p && *p != '"') {
        if ((unsigned char)*p < 0x20)
            return NULL;
        if (*p == '\\') {
            p++;
            if (*p == 'u') {
                for (int i = 1; i <= 4; i++)
                    if (!isxdigit((unsigned char)p[i]))
                        return NULL;
                p += 4;
            } else if (!strchr("\"\\/bfnrt", *p)) {
                return NULL;
            }
        }
        p++;
    }
    return *p == '"' ? p + 1 : NULL;
}

static const char *json_value(const char *p, int depth)
{
    if (depth > 20)
        return NULL;
    p = skip_ws(p);
    if (*p == '{' || *p == '[') {
        char close = *p == '{' ? '}' : ']';
        p = skip_ws(p + 1);
        if (*p == close)
            return p + 1;
        for (;;) {
            if (close == '}') {
                if (!(p = json_string(skip_ws(p))))
                    return NULL;
                p = skip_ws(p);
                if (*p++ != ':')
                    return NULL;
            }
            if (!(p = json_value(p, depth + 1)))
                return NULL;
            p = skip_ws(p);
            if (*p == close)
                return p + 1;
            if (*p++ != ',')
                return NULL;
        }
    }
    if (*p == '"')
        return json_string(p);
    if (!strncmp(p, "true", 4) || !strncmp(p, "null", 4))
        return p + 4;
    if (!strncmp(p, "false", 5))
        return p + 5;
    char *end;
    strtod(p, &end);
    return end == p ? NULL : end;
}

static char *slurp(const char *path)
{
    FILE *f = fopen(path, "r");
    ck_assert_ptr_nonnull(f);
    static char buf[1 << 16];
    size_t n = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    buf[n] = '\0';
    return buf;
}

static void on_msg(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)ctx;
    *(size_t *)arg += m->len;
}

START_TEST(stats_json_is_valid_and_complete)
{
    am_ctx_t *ctx = open_ctx();
    size_t got = 0;
    am_register(ctx, 12, "tricky \"name\"\n", on_msg, &got);
    int cat = am_category(ctx, "completed");
    am_time_begin(ctx, cat);
    am_count(ctx, cat, 7);
    ck_assert_int_eq(am_send(ctx, 0, 12, "hello", 5), 0);
    ck_assert_int_eq(am_send(ctx, 0, 12, NULL, 0), 0);
    ck_assert_int_eq(am_send(ctx, 0, 13, "x", 1), 0); /* no handler */
    ck_assert_int_eq(am_poll(ctx), 3);
    ck_assert_uint_eq(got, 5);
    am_time_end(ctx, cat);
    char dir[] = "/tmp/am-stats-XXXXXX";
    ck_assert_ptr_nonnull(mkdtemp(dir));
    char path[64];
    snprintf(path, sizeof path, "%s/s.json", dir);
    ck_assert_int_eq(am_stats_write_json(ctx, path), 0);
    char *text = slurp(path);
    const char *end = json_value(text, 0);
    ck_assert_msg(end && !*skip_ws(end), "invalid JSON:\n%s", text);
    static const char *const keys[] = {
        "\"rank\": 0", "\"size\": 1", "\"poll_s\"", "\"poll_excess_s\"",
        "\"idle_s\"", "\"msgs_sent\": 3", "\"msgs_recv\": 2",
        "\"rejected\": {\"total\": 1", "\"handler\": 1",
        "\"completed\": {\"seconds\"", "\"count\": 7",
        "\"name\": \"tricky \\\"name\\\"\\u000a\"", "\"sent_bytes\": 5",
        "\"control\"", "\"token\""};
    for (size_t i = 0; i < sizeof keys / sizeof keys[0]; i++)
        ck_assert_msg(strstr(text, keys[i]), "no %s in\n%s", keys[i], text);
    unlink(path);
    rmdir(dir);
    ck_assert_int_eq(am_stats_write_json(ctx, "/nonexistent-dir/x.json"),
                     AM_ESYS);
    am_finalize(&ctx);
}
END_TEST

START_TEST(stats_dir_option_from_argv)
{
    char dir[] = "/tmp/am-stats-XXXXXX";
    ck_assert_ptr_nonnull(mkdtemp(dir));
    char opt[64];
    snprintf(opt, sizeof opt, "--am-stats-dir=%s", dir);
    char a0[] = "prog", a1[] = "keep", a3[] = "--am-stack-size=128k",
         a4[] = "--", a5[] = "--am-latency=1ms";
    char *args[] = {a0, a1, opt, a3, a4, a5, NULL};
    int argc = 6;
    char **argv = args;
    am_ctx_t *ctx;
    ck_assert_int_eq(am_init(&argc, &argv, NULL, &ctx), 0);
    /* The runtime took its options; "--" and what follows stay. */
    ck_assert_int_eq(argc, 4);
    ck_assert_str_eq(argv[1], "keep");
    ck_assert_str_eq(argv[2], "--");
    ck_assert_str_eq(argv[3], "--am-latency=1ms");
    ck_assert_ptr_null(argv[4]);
    ck_assert_uint_eq(ctx->sched.stack_size, 128 * 1024);
    ck_assert_int_eq(ctx->lat.on, 0);
    ck_assert_int_eq(am_finalize(&ctx), 0);
    char path[64];
    snprintf(path, sizeof path, "%s/stats-0.json", dir);
    ck_assert_int_eq(access(path, R_OK), 0);
    const char *end = json_value(slurp(path), 0);
    ck_assert_ptr_nonnull(end);
    unlink(path);
    rmdir(dir);
}
END_TEST

/* ------------------------------------------------------------- one PE */

typedef struct chain {
    int left;
    int delivered;
    int spawned;
} chain;

static void chain_thread(am_ctx_t *ctx, void *arg)
{
    chain *c = arg;
    am_yield(ctx);
    if (c->left-- > 0)
        am_send(ctx, 0, 20, NULL, 0);
}

static void chain_handler(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)m;
    chain *c = arg;
    c->delivered++;
    /* Alternate: reply from the handler, or from a thread. */
    if (c->delivered % 2) {
        if (c->left-- > 0)
            am_send(ctx, 0, 20, NULL, 0);
    } else {
        c->spawned++;
        am_thread_spawn(ctx, chain_thread, c, NULL);
    }
}

static int chain_start(am_ctx_t *ctx, void *arg)
{
    chain *c = arg;
    if (c->delivered || c->left <= 0)
        return 0;
    c->left--;
    return am_send(ctx, 0, 20, NULL, 0) == 0;
}

START_TEST(one_pe_runs_until_done)
{
    am_ctx_t *ctx = open_ctx();
    chain c = {100, 0, 0};
    am_register(ctx, 20, "chain", chain_handler, &c);
    ck_assert_int_eq(am_run_until_done(ctx, chain_start, &c), 0);
    ck_assert_int_eq(c.delivered, 100);
    ck_assert_int_eq(c.spawned, 50);
    ck_assert_uint_eq(am_thread_count(ctx), 0);
    /* A second epoch, with nothing to do, ends at once. */
    ck_assert_int_eq(am_run_until_done(ctx, NULL, NULL), 0);
    ck_assert_int_eq(am_barrier(ctx), 0);
    double in = 2.5, out = 0;
    ck_assert_int_eq(am_allreduce_f64(ctx, &in, &out, 1, AM_SUM), 0);
    ck_assert(out == 2.5);
    ck_assert_int_eq(am_finalize(&ctx), 0);
}
END_TEST

static int work_error(am_ctx_t *ctx, void *arg)
{
    (void)ctx;
    (void)arg;
    return -42;
}

START_TEST(loop_errors)
{
    am_ctx_t *ctx = open_ctx();
    ck_assert_int_eq(am_run_until_done(ctx, work_error, NULL), -42);
    ck_assert_int_eq(am_send(ctx, 1, 1, "x", 1), AM_EINVAL);
    ck_assert_int_eq(am_send(ctx, 0, AM_HANDLER_MAX, "x", 1), AM_EINVAL);
    ck_assert_int_eq(am_send(ctx, 0, 1, NULL, 3), AM_EINVAL);
    ck_assert_int_eq(am_register(ctx, AM_HANDLER_MAX, "x", on_msg, NULL),
                     AM_EINVAL);
    ck_assert_ptr_null(am_endpoint(ctx, 0));
    ck_assert_str_eq(am_last_error(ctx), "");
    ck_assert_int_eq(am_finalize(&ctx), 0);
    ck_assert_int_eq(am_finalize(&ctx), AM_EINVAL);
}
END_TEST

static int freed;

static void count_free(void *frame, void *hint)
{
    free(frame);
    freed += hint == (void *)&freed;
}

START_TEST(zero_copy_ownership)
{
    am_ctx_t *ctx = open_ctx();
    size_t got = 0;
    am_register(ctx, 3, "zc", on_msg, &got);
    freed = 0;
    uint8_t *frame = malloc(AM_HEADROOM + 10);
    memcpy(frame + AM_HEADROOM, "0123456789", 10);
    ck_assert_int_eq(am_send_zc(ctx, 0, 3, frame, 10, count_free, &freed), 0);
    am_poll(ctx);
    ck_assert_uint_eq(got, 10);
    ck_assert_int_eq(freed, 1);
    /* A failing call never calls the free function: the caller still owns
     * the buffer. */
    frame = malloc(AM_HEADROOM + 10);
    ck_assert_int_eq(am_send_zc(ctx, 5, 3, frame, 10, count_free, &freed),
                     AM_EINVAL);
    ck_assert_int_eq(freed, 1);
    free(frame);
    void *p = am_buf_alloc(4);
    memcpy(p, "abcd", 4);
    ck_assert_int_eq(am_send_buf(ctx, 0, 3, p, 4), 0);
    am_poll(ctx);
    ck_assert_uint_eq(got, 14);
    am_finalize(&ctx);
}
END_TEST

/* ------------------------------------------------------- send accounting */

/* Every send path, with messages of known sizes, to this PE: each message
 * must be counted exactly once when sent and once when received, in the
 * runtime totals, under its handler, and (RPC) under its control type and
 * the reply counters. */
enum { H_SEND = 40, H_BUF = 41, H_ZC = 42, H_CALL = 43, H_LATER = 44 };

static const size_t send_lens[] = {0, 1, 10, 100, 70000};
static const size_t buf_lens[] = {7, 0, 64};
static const size_t zc_lens[] = {5, 16};
static const size_t call_lens[] = {0, 3, 12, 40};
static const size_t later_lens[] = {9, 20};

#define N_OF(a) (sizeof a / sizeof a[0])

static size_t sum_of(const size_t *a, size_t n)
{
    size_t s = 0;
    for (size_t i = 0; i < n; i++)
        s += a[i];
    return s;
}

/* The reply to a request of len bytes: am_reply answers 2 len + 1 bytes,
 * am_reply_to (from a thread) len / 2 + 1. */
static size_t reply_len(size_t len, int later)
{
    return later ? len / 2 + 1 : 2 * len + 1;
}

static uint8_t junk[70000];

static void count_handler(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)ctx;
    (void)m;
    (*(int *)arg)++;
}

static void call_handler(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)arg;
    ck_assert_int_eq(am_reply(ctx, m, junk, reply_len(m->len, 0)), 0);
}

typedef struct later_reply {
    int src;
    uint64_t call_id;
    size_t len;
} later_reply;

static void later_thread(am_ctx_t *ctx, void *arg)
{
    later_reply *r = arg;
    am_yield(ctx);
    ck_assert_int_eq(am_reply_to(ctx, r->src, r->call_id, junk,
                                 reply_len(r->len, 1)),
                     0);
    free(r);
}

static void later_handler(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)arg;
    later_reply *r = malloc(sizeof *r);
    *r = (later_reply){m->src, m->call_id, m->len};
    ck_assert_int_eq(am_thread_spawn(ctx, later_thread, r, NULL), 0);
}

static void zc_free(void *frame, void *hint)
{
    (void)hint;
    free(frame);
}

static void sender_thread(am_ctx_t *ctx, void *arg)
{
    (void)arg;
    for (size_t i = 0; i < N_OF(send_lens); i++)
        ck_assert_int_eq(am_send(ctx, 0, H_SEND, junk, send_lens[i]), 0);
    for (size_t i = 0; i < N_OF(buf_lens); i++) {
        void *p = am_buf_alloc(buf_lens[i]);
        ck_assert_ptr_nonnull(p);
        ck_assert_int_eq(am_send_buf(ctx, 0, H_BUF, p, buf_lens[i]), 0);
    }
    for (size_t i = 0; i < N_OF(zc_lens); i++) {
        uint8_t *frame = calloc(1, AM_HEADROOM + zc_lens[i]);
        ck_assert_int_eq(am_send_zc(ctx, 0, H_ZC, frame, zc_lens[i], zc_free,
                                    NULL),
                         0);
    }
    for (int later = 0; later < 2; later++) {
        const size_t *lens = later ? later_lens : call_lens;
        size_t n = later ? N_OF(later_lens) : N_OF(call_lens);
        for (size_t i = 0; i < n; i++) {
            void *reply = NULL;
            size_t got = 0;
            ck_assert_int_eq(am_call(ctx, 0, later ? H_LATER : H_CALL, junk,
                                     lens[i], &reply, &got),
                             0);
            ck_assert_uint_eq(got, reply_len(lens[i], later));
            free(reply);
        }
    }
}

static void check_hstat(const am__hstat *h, uint64_t n, uint64_t bytes)
{
    ck_assert_uint_eq(h->sent, n);
    ck_assert_uint_eq(h->sent_bytes, bytes);
    ck_assert_uint_eq(h->recv, n);
    ck_assert_uint_eq(h->recv_bytes, bytes);
}

START_TEST(every_send_path_counted_once)
{
    am_ctx_t *ctx = open_ctx();
    int plain = 0;
    am_register(ctx, H_SEND, "send", count_handler, &plain);
    am_register(ctx, H_BUF, "buf", count_handler, &plain);
    am_register(ctx, H_ZC, "zc", count_handler, &plain);
    am_register(ctx, H_CALL, "call", call_handler, NULL);
    am_register(ctx, H_LATER, "later", later_handler, NULL);
    ck_assert_int_eq(am_thread_spawn(ctx, sender_thread, NULL, NULL), 0);
    ck_assert_int_eq(am_run_until_done(ctx, NULL, NULL), 0);
    ck_assert_int_eq(plain, N_OF(send_lens) + N_OF(buf_lens) + N_OF(zc_lens));

    size_t n_calls = N_OF(call_lens) + N_OF(later_lens);
    size_t req_bytes = sum_of(call_lens, N_OF(call_lens)) +
                       sum_of(later_lens, N_OF(later_lens));
    size_t rep_bytes = 0;
    for (size_t i = 0; i < N_OF(call_lens); i++)
        rep_bytes += reply_len(call_lens[i], 0);
    for (size_t i = 0; i < N_OF(later_lens); i++)
        rep_bytes += reply_len(later_lens[i], 1);

    check_hstat(&ctx->handlers[H_SEND].st, N_OF(send_lens),
                sum_of(send_lens, N_OF(send_lens)));
    check_hstat(&ctx->handlers[H_BUF].st, N_OF(buf_lens),
                sum_of(buf_lens, N_OF(buf_lens)));
    check_hstat(&ctx->handlers[H_ZC].st, N_OF(zc_lens),
                sum_of(zc_lens, N_OF(zc_lens)));
    check_hstat(&ctx->handlers[H_CALL].st, N_OF(call_lens),
                sum_of(call_lens, N_OF(call_lens)));
    check_hstat(&ctx->handlers[H_LATER].st, N_OF(later_lens),
                sum_of(later_lens, N_OF(later_lens)));
    check_hstat(&ctx->rpc_reply_st, n_calls, rep_bytes);
    /* A request's body is its call id (8 bytes) and handler id (2) before
     * the payload; a reply's, the call id. */
    check_hstat(&ctx->ctl_st[AM__CTL_RPC_REQ], n_calls, 10 * n_calls + req_bytes);
    check_hstat(&ctx->ctl_st[AM__CTL_RPC_REP], n_calls, 8 * n_calls + rep_bytes);

    am_stats_t st;
    am_stats_get(ctx, &st);
    uint64_t msgs = N_OF(send_lens) + N_OF(buf_lens) + N_OF(zc_lens) + n_calls;
    uint64_t bytes = sum_of(send_lens, N_OF(send_lens)) +
                     sum_of(buf_lens, N_OF(buf_lens)) +
                     sum_of(zc_lens, N_OF(zc_lens)) + req_bytes;
    ck_assert_uint_eq(st.msgs_sent, msgs);
    ck_assert_uint_eq(st.bytes_sent, bytes);
    ck_assert_uint_eq(st.msgs_recv, msgs);
    ck_assert_uint_eq(st.bytes_recv, bytes);
    /* One PE exchanges no other control frames. */
    ck_assert_uint_eq(st.ctl_sent, 2 * n_calls);
    ck_assert_uint_eq(st.ctl_recv, 2 * n_calls);
    ck_assert_uint_eq(st.rejected, 0);
    /* Requests and replies are basic messages, like AMs: as many counted
     * sent as delivered. */
    ck_assert_int_eq(ctx->term.count, 0);
    ck_assert_int_eq(am_finalize(&ctx), 0);
}
END_TEST

static Suite *stats_suite(void)
{
    Suite *s = suite_create("am_stats");
    TCase *tc = tcase_create("accounting");
    tcase_add_test(tc, categories_nest_and_overlap);
    tcase_add_test(tc, stats_json_is_valid_and_complete);
    tcase_add_test(tc, stats_dir_option_from_argv);
    suite_add_tcase(s, tc);
    tc = tcase_create("one_pe");
    tcase_add_test(tc, one_pe_runs_until_done);
    tcase_add_test(tc, loop_errors);
    tcase_add_test(tc, zero_copy_ownership);
    tcase_add_test(tc, every_send_path_counted_once);
    suite_add_tcase(s, tc);
    return s;
}

UNIT_MAIN(stats_suite)
