/* Unit tests of latency injection: the spec parsers, and delayed delivery
 * (timing, order, bandwidth) inside one process. */
#include "config.h"

#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "am_int.h"
#include "unit.h"

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

START_TEST(latency_specs)
{
    double lo, hi;
    ck_assert_int_eq(am__latency_parse("200us", &lo, &hi), 0);
    ck_assert(lo == 200e-6 && hi == lo);
    ck_assert_int_eq(am__latency_parse("100us-2ms", &lo, &hi), 0);
    ck_assert(lo == 100e-6 && hi == 2e-3);
    ck_assert_int_eq(am__latency_parse("1.5ms", &lo, &hi), 0);
    ck_assert(lo == 1.5e-3);
    ck_assert_int_eq(am__latency_parse("0", &lo, &hi), 0);
    ck_assert(lo == 0 && hi == 0);
    ck_assert_int_eq(am__latency_parse("0-1ms", &lo, &hi), 0);
    ck_assert(lo == 0 && hi == 1e-3);
    ck_assert_int_eq(am__latency_parse("250ns", &lo, &hi), 0);
    ck_assert_int_eq(am__latency_parse("2s", &lo, &hi), 0);
    ck_assert(lo == 2);
    ck_assert_int_eq(am__latency_parse("1e-3s", &lo, &hi), 0);
    ck_assert(lo == 1e-3);
    static const char *const bad[] = {"", "200", "200 us", "2ms-1ms", "-1ms",
                                      "1ms-", "1ms-2", "5min", "nanus",
                                      "1ms2ms", "2h", "7200s"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        ck_assert_msg(am__latency_parse(bad[i], &lo, &hi) == AM_EINVAL,
                      "'%s' accepted", bad[i]);
    ck_assert_int_eq(am__latency_parse(NULL, &lo, &hi), AM_EINVAL);
}
END_TEST

START_TEST(bandwidth_specs)
{
    double b;
    ck_assert_int_eq(am__bandwidth_parse("100Mbit", &b), 0);
    ck_assert(b == 100e6 / 8);
    ck_assert_int_eq(am__bandwidth_parse("1Gbit/s", &b), 0);
    ck_assert(b == 1e9 / 8);
    ck_assert_int_eq(am__bandwidth_parse("100Mbps", &b), 0);
    ck_assert(b == 100e6 / 8);
    ck_assert_int_eq(am__bandwidth_parse("12.5MB", &b), 0);
    ck_assert(b == 12.5e6);
    ck_assert_int_eq(am__bandwidth_parse("1MiB", &b), 0);
    ck_assert(b == 1048576);
    ck_assert_int_eq(am__bandwidth_parse("0", &b), 0);
    ck_assert(b == 0);
    static const char *const bad[] = {"", "100", "100mbit", "0Mbit", "-1MB",
                                      "1MB/h", "fastest"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        ck_assert_msg(am__bandwidth_parse(bad[i], &b) == AM_EINVAL,
                      "'%s' accepted", bad[i]);
}
END_TEST

/* ------------------------------------------------------ delayed delivery */

#define NFRAMES 40

typedef struct record {
    int n;
    uint32_t order[NFRAMES];
    double at[NFRAMES];
} record;

static void recorder(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)ctx;
    record *r = arg;
    const uint8_t *p = m->data;
    if (r->n < NFRAMES) {
        r->order[r->n] = pr_load_u32(p);
        r->at[r->n] = now();
    }
    r->n++;
}

/* Puts a frame "received from PE 0" with a 4-byte index and len bytes of
 * payload in total into the latency queue. */
static void inject(am_ctx_t *ctx, uint32_t idx, size_t len)
{
    am__frame *f = am__frame_new();
    ck_assert_ptr_nonnull(f);
    ck_assert_int_eq(zmq_msg_init_size(&f->msg, PR_HEADER_SIZE + len), 0);
    uint8_t *d = zmq_msg_data(&f->msg);
    memset(d + PR_HEADER_SIZE, 0, len);
    pr_store_u32(d + PR_HEADER_SIZE, idx);
    f->hdr = (pr_header){0, 9, 0, (uint32_t)len, idx};
    pr_header_encode(&f->hdr, d);
    f->src = 0;
    am__latency_enqueue(ctx, f);
}

START_TEST(random_latency_keeps_order_and_minimum)
{
    am_opts_t o = AM_OPTS_INIT;
    o.latency = "1ms-8ms";
    am_ctx_t *ctx;
    ck_assert_int_eq(am_init(NULL, NULL, &o, &ctx), 0);
    record r = {0};
    am_register(ctx, 9, "rec", recorder, &r);
    double sent[NFRAMES];
    for (uint32_t i = 0; i < NFRAMES; i++) {
        sent[i] = now();
        inject(ctx, i, 8);
        /* A frame delivered by the time it was queued would be a bug. */
        ck_assert_int_eq(r.n, 0);
    }
    ck_assert_uint_eq(am__latency_pending(ctx), NFRAMES);
    double limit = now() + 5;
    while (r.n < NFRAMES && now() < limit)
        am_sleep(ctx, 0.002);
    ck_assert_int_eq(r.n, NFRAMES);
    double spread = 0;
    for (int i = 0; i < NFRAMES; i++) {
        ck_assert_uint_eq(r.order[i], (uint32_t)i); /* per-sender order */
        double d = r.at[i] - sent[i];
        ck_assert_msg(d >= 1e-3, "frame %d delivered after %.6f s", i, d);
        if (d > spread)
            spread = d;
    }
    /* Some frame must have drawn a latency well above the minimum. */
    ck_assert(spread > 2e-3);
    am_finalize(&ctx);
}
END_TEST

START_TEST(bandwidth_cap_serialises_frames)
{
    am_opts_t o = AM_OPTS_INIT;
    o.bandwidth = "1MB"; /* 1000 bytes per millisecond */
    am_ctx_t *ctx;
    ck_assert_int_eq(am_init(NULL, NULL, &o, &ctx), 0);
    record r = {0};
    am_register(ctx, 9, "rec", recorder, &r);
    double t0 = now();
    for (uint32_t i = 0; i < 10; i++)
        inject(ctx, i, 1000 - PR_HEADER_SIZE);
    double limit = now() + 5;
    while (r.n < 10 && now() < limit)
        am_sleep(ctx, 0.001);
    ck_assert_int_eq(r.n, 10);
    /* Frame k can arrive only after k+1 frames went through the link. */
    for (int i = 0; i < 10; i++)
        ck_assert_msg(r.at[i] - t0 >= (i + 1) * 1e-3 - 1e-5,
                      "frame %d after %.6f s", i, r.at[i] - t0);
    am_finalize(&ctx);
}
END_TEST

START_TEST(bad_specs_fail_init)
{
    am_opts_t o = AM_OPTS_INIT;
    o.latency = "fast";
    am_ctx_t *ctx = (am_ctx_t *)1;
    ck_assert_int_eq(am_init(NULL, NULL, &o, &ctx), AM_EINVAL);
    ck_assert_ptr_null(ctx);
    o.latency = NULL;
    o.bandwidth = "lots";
    ck_assert_int_eq(am_init(NULL, NULL, &o, &ctx), AM_EINVAL);
}
END_TEST

static Suite *latency_suite(void)
{
    Suite *s = suite_create("am_latency");
    TCase *tc = tcase_create("specs");
    tcase_add_test(tc, latency_specs);
    tcase_add_test(tc, bandwidth_specs);
    suite_add_tcase(s, tc);
    tc = tcase_create("delivery");
    tcase_set_timeout(tc, 20);
    tcase_add_test(tc, random_latency_keeps_order_and_minimum);
    tcase_add_test(tc, bandwidth_cap_serialises_frames);
    tcase_add_test(tc, bad_specs_fail_init);
    suite_add_tcase(s, tc);
    return s;
}

UNIT_MAIN(latency_suite)
