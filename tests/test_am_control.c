/* Unit tests of libam's control message bodies (runtime/CONTROL.md) and of
 * the validation of received frames. */
#include "config.h"

#include <stdlib.h>
#include <string.h>

#include "am_control.h"
#include "am_int.h"
#include "unit.h"

/* Decodes buf with get(), and every strict prefix of it: the full message
 * must decode, every prefix must fail without reading past its end (each
 * prefix is copied to a buffer of exactly its size, so ASan catches an
 * overread), and one extra byte must give PR_ETRAILING. */
typedef int (*decoder)(pr_reader *r, void *out);

static void check_prefixes_and_trailing(const pr_buf *b, decoder get, void *out)
{
    for (size_t n = 0; n < b->len; n++) {
        uint8_t *copy = malloc(n ? n : 1);
        memcpy(copy, b->data, n);
        pr_reader r;
        pr_reader_init(&r, copy, n);
        ck_assert_int_ne(get(&r, out), 0);
        free(copy);
    }
    uint8_t *longer = malloc(b->len + 1);
    memcpy(longer, b->data, b->len);
    longer[b->len] = 0x5a;
    pr_reader r;
    pr_reader_init(&r, longer, b->len + 1);
    ck_assert_int_eq(get(&r, out), PR_ETRAILING);
    free(longer);
    pr_reader_init(&r, b->data, b->len);
    ck_assert_int_eq(get(&r, out), 0);
}

static int hello_get(pr_reader *r, void *out)
{
    return am__hello_get(r, out);
}

START_TEST(hello_round_trip)
{
    const char *ep = "tcp://10.0.0.7:41234";
    am__hello in = {.endpoint = {(const uint8_t *)ep, strlen(ep)}};
    pr_hello_init(&in.id, 0xDEADBEEFCAFEULL, 3, 16);
    am__hello out;
    pr_buf b = PR_BUF_INIT;
    am__hello_put(&b, &in);
    ck_assert_int_eq(b.err, 0);
    /* hello length, proto's hello message, endpoint length, endpoint */
    ck_assert_uint_eq(b.len, 4 + 20 + 4 + strlen(ep));
    ck_assert_uint_eq(pr_load_u32(b.data), 20);
    ck_assert_uint_eq(b.data[4], PR_MSG_HELLO);
    ck_assert_uint_eq(b.data[5], PR_VERSION);
    check_prefixes_and_trailing(&b, hello_get, &out);
    ck_assert_uint_eq(out.id.rank, 3);
    ck_assert_uint_eq(out.id.size, 16);
    ck_assert(out.id.job == in.id.job);
    ck_assert_uint_eq(out.id.version, PR_VERSION);
    ck_assert_uint_eq(out.endpoint.len, strlen(ep));
    ck_assert(!memcmp(out.endpoint.p, ep, strlen(ep)));
    /* rank >= size cannot even be encoded, and a forged one is refused */
    pr_buf_reset(&b);
    in.id.rank = 16;
    am__hello_put(&b, &in);
    ck_assert_int_eq(b.err, PR_EINVAL);
    pr_buf_reset(&b);
    in.id.rank = 3;
    am__hello_put(&b, &in);
    b.data[4 + 1 + 3 + 8] = 16; /* rank field of the nested hello */
    pr_reader r;
    pr_reader_init(&r, b.data, b.len);
    ck_assert_int_eq(am__hello_get(&r, &out), PR_EDATA);
    /* more PEs than the runtime supports */
    pr_buf_reset(&b);
    pr_hello_init(&in.id, 1, 0, AM__PE_MAX + 1);
    am__hello_put(&b, &in);
    pr_reader_init(&r, b.data, b.len);
    ck_assert_int_eq(am__hello_get(&r, &out), PR_ERANGE);
    pr_buf_free(&b);
}
END_TEST

static int peer_hello_get(pr_reader *r, void *out)
{
    return am__peer_hello_get(r, out);
}

START_TEST(peer_hello_round_trip)
{
    am__peer_hello in, out;
    pr_hello_init(&in.id, 42, 5, 8);
    pr_buf b = PR_BUF_INIT;
    am__peer_hello_put(&b, &in);
    ck_assert_int_eq(b.err, 0);
    ck_assert_uint_eq(b.len, 4 + 20);
    check_prefixes_and_trailing(&b, peer_hello_get, &out);
    ck_assert_uint_eq(out.id.rank, 5);
    ck_assert_uint_eq(out.id.size, 8);
    ck_assert(out.id.job == 42);
    pr_buf_free(&b);
}
END_TEST

START_TEST(table_round_trip_and_limits)
{
    static char e0[] = "ipc:///tmp/a/0.sock", e1[] = "ipc:///tmp/a/1.sock",
                e2[] = "";
    char *eps[3] = {e0, e1, e2};
    pr_buf b = PR_BUF_INIT;
    am__table_put(&b, 77, 3, eps);
    am__str out[3];
    uint64_t job;
    uint32_t n;
    pr_reader r;
    pr_reader_init(&r, b.data, b.len);
    ck_assert_int_eq(am__table_get(&r, &job, 3, &n, out), 0);
    ck_assert_uint_eq(n, 3);
    ck_assert(job == 77);
    ck_assert_uint_eq(out[1].len, strlen(eps[1]));
    ck_assert(!memcmp(out[1].p, eps[1], out[1].len));
    ck_assert_uint_eq(out[2].len, 0);
    /* More entries than the caller can hold: refused before any is read. */
    pr_reader_init(&r, b.data, b.len);
    ck_assert_int_eq(am__table_get(&r, &job, 2, &n, out), PR_ERANGE);
    ck_assert_uint_eq(n, 0);
    /* A count the bytes cannot hold: refused. */
    uint8_t lie[12] = {0};
    lie[8] = 0xff;
    lie[9] = 0xff;
    pr_reader_init(&r, lie, sizeof lie);
    ck_assert_int_eq(am__table_get(&r, &job, 1u << 20, &n, out), PR_ETRUNC);
    for (size_t k = 0; k < b.len; k++) {
        pr_reader_init(&r, b.data, k);
        ck_assert_int_ne(am__table_get(&r, &job, 3, &n, out), 0);
    }
    pr_buf_free(&b);
}
END_TEST

static int token_get(pr_reader *r, void *out)
{
    return am__token_get(r, out);
}

START_TEST(token_round_trip)
{
    am__token in = {5, -123456789012LL, 1}, out;
    pr_buf b = PR_BUF_INIT;
    am__token_put(&b, &in);
    ck_assert_uint_eq(b.len, 17);
    check_prefixes_and_trailing(&b, token_get, &out);
    ck_assert(out.epoch == 5 && out.q == -123456789012LL && out.black == 1);
    b.data[16] = 2; /* colour must be 0 or 1 */
    pr_reader r;
    pr_reader_init(&r, b.data, b.len);
    ck_assert_int_eq(am__token_get(&r, &out), PR_ERANGE);
    pr_buf_free(&b);
}
END_TEST

static int coll_get(pr_reader *r, void *out)
{
    return am__coll_get(r, out);
}

START_TEST(collective_round_trip)
{
    uint8_t vals[24];
    for (int i = 0; i < 24; i++)
        vals[i] = (uint8_t)i;
    am__coll_msg in = {9, AM__COLL_F64, AM_MAX, 3, vals}, out;
    pr_buf b = PR_BUF_INIT;
    am__coll_put(&b, &in);
    ck_assert_uint_eq(b.len, 8 + 1 + 1 + 4 + 24);
    check_prefixes_and_trailing(&b, coll_get, &out);
    ck_assert(out.seq == 9 && out.kind == AM__COLL_F64 && out.op == AM_MAX);
    ck_assert_uint_eq(out.n, 3);
    ck_assert(!memcmp(out.values, vals, 24));
    /* A barrier carries no values; an unknown kind or operator is refused. */
    pr_reader r;
    b.data[8] = AM__COLL_BARRIER;
    pr_reader_init(&r, b.data, b.len);
    ck_assert_int_eq(am__coll_get(&r, &out), PR_ERANGE);
    b.data[8] = 7;
    pr_reader_init(&r, b.data, b.len);
    ck_assert_int_eq(am__coll_get(&r, &out), PR_ERANGE);
    pr_buf_free(&b);
}
END_TEST

static int gather_get(pr_reader *r, void *out)
{
    return am__gather_get(r, out);
}

static int rpc_rep_get(pr_reader *r, void *out)
{
    return am__rpc_rep_get(r, out);
}

START_TEST(gather_and_rpc_round_trip)
{
    am__gather_msg g = {4, {(const uint8_t *)"blob!", 5}}, go;
    pr_buf b = PR_BUF_INIT;
    am__gather_put(&b, &g);
    check_prefixes_and_trailing(&b, gather_get, &go);
    ck_assert(go.seq == 4 && go.blob.len == 5 && !memcmp(go.blob.p, "blob!", 5));

    pr_buf_reset(&b);
    am__rpc_req_put(&b, 42, 7, "request", 7);
    am__rpc_msg m;
    pr_reader r;
    pr_reader_init(&r, b.data, b.len);
    ck_assert_int_eq(am__rpc_req_get(&r, &m), 0);
    ck_assert(m.call_id == 42 && m.handler == 7 && m.payload.len == 7);
    ck_assert(!memcmp(m.payload.p, "request", 7));
    /* Shorter than id + handler: refused. The payload takes the rest, so
     * a request has no "trailing bytes". */
    pr_reader_init(&r, b.data, 9);
    ck_assert_int_ne(am__rpc_req_get(&r, &m), 0);

    pr_buf_reset(&b);
    am__rpc_rep_put(&b, 42, "", 0);
    pr_reader_init(&r, b.data, b.len);
    ck_assert_int_eq(am__rpc_rep_get(&r, &m), 0);
    ck_assert(m.call_id == 42 && m.payload.len == 0);
    pr_reader_init(&r, b.data, 7);
    ck_assert_int_ne(rpc_rep_get(&r, &m), 0);
    /* Call id 0 means "not a call" and never travels. */
    pr_buf_reset(&b);
    am__rpc_rep_put(&b, 0, "x", 1);
    pr_reader_init(&r, b.data, b.len);
    ck_assert_int_eq(am__rpc_rep_get(&r, &m), PR_ERANGE);
    pr_buf_free(&b);
}
END_TEST

static int abort_get(pr_reader *r, void *out)
{
    return am__abort_get(r, out);
}

START_TEST(abort_round_trip)
{
    const char *why = "PE 5 went away";
    am__abort_msg in = {5, {(const uint8_t *)why, strlen(why)}}, out;
    pr_buf b = PR_BUF_INIT;
    am__abort_put(&b, &in);
    ck_assert_uint_eq(b.len, 4 + 4 + strlen(why));
    check_prefixes_and_trailing(&b, abort_get, &out);
    ck_assert_uint_eq(out.culprit, 5);
    ck_assert(out.reason.len == strlen(why) && !memcmp(out.reason.p, why, out.reason.len));
    /* A reason longer than AM__REASON_MAX is refused. */
    pr_buf_reset(&b);
    pr_put_u32(&b, 1);
    pr_put_u32(&b, AM__REASON_MAX + 1);
    for (int i = 0; i <= AM__REASON_MAX; i++)
        pr_put_u8(&b, 'x');
    pr_reader r;
    pr_reader_init(&r, b.data, b.len);
    ck_assert_int_eq(am__abort_get(&r, &out), PR_ERANGE);
    pr_buf_free(&b);
}
END_TEST

static int credit_get(pr_reader *r, void *out)
{
    return am__credit_get(r, out);
}

START_TEST(credit_round_trip)
{
    uint64_t out;
    pr_buf b = PR_BUF_INIT;
    am__credit_put(&b, 123456);
    ck_assert_uint_eq(b.len, 8);
    check_prefixes_and_trailing(&b, credit_get, &out);
    ck_assert_uint_eq(out, 123456);
    /* Zero and absurd amounts are refused. */
    uint64_t bad[] = {0, AM__CREDIT_MAX + 1, UINT64_MAX};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        pr_buf_reset(&b);
        am__credit_put(&b, bad[i]);
        pr_reader r;
        pr_reader_init(&r, b.data, b.len);
        ck_assert_int_eq(am__credit_get(&r, &out), PR_ERANGE);
    }
    pr_buf_free(&b);
}
END_TEST

START_TEST(empty_bodies)
{
    pr_reader r;
    pr_reader_init(&r, "", 0);
    ck_assert_int_eq(am__empty_get(&r), 0);
    pr_reader_init(&r, "x", 1);
    ck_assert_int_eq(am__empty_get(&r), PR_ETRAILING);
}
END_TEST

/* ------------------------------------------------------------- dispatch */

/* Every control type has exactly one entry, under the name the statistics
 * file has always used for it (CONTROL.md), and the transport's two
 * special classes are the types they always were. */
START_TEST(dispatch_table_is_complete)
{
    static const char *const names[AM__CTL_COUNT] = {
        [AM__CTL_HELLO] = "hello",         [AM__CTL_TABLE] = "table",
        [AM__CTL_PEER_HELLO] = "peer_hello", [AM__CTL_BYE] = "bye",
        [AM__CTL_PING] = "ping",           [AM__CTL_TOKEN] = "token",
        [AM__CTL_TERMINATE] = "terminate", [AM__CTL_COLL_UP] = "coll_up",
        [AM__CTL_COLL_DOWN] = "coll_down", [AM__CTL_GATHER] = "gather",
        [AM__CTL_RPC_REQ] = "rpc_request", [AM__CTL_RPC_REP] = "rpc_reply",
        [AM__CTL_ABORT] = "abort",         [AM__CTL_CREDIT] = "credit",
        [AM__CTL_SHM_ON] = "shm_on",       [AM__CTL_SHM_VIA] = "shm_via"};
    am_ctx_t *ctx;
    ck_assert_int_eq(am_init(NULL, NULL, NULL, &ctx), 0);
    ck_assert_ptr_null(ctx->ctl[0]);
    for (unsigned t = 1; t < AM__CTL_COUNT; t++) {
        const am__ctl_entry *e = ctx->ctl[t];
        ck_assert_ptr_nonnull(e);
        ck_assert_uint_eq(e->type, t);
        ck_assert_ptr_nonnull(e->fn);
        ck_assert_ptr_nonnull(names[t]);
        ck_assert_str_eq(e->name, names[t]);
        int boot = t == AM__CTL_HELLO || t == AM__CTL_TABLE ||
                   t == AM__CTL_PEER_HELLO;
        int basic = t == AM__CTL_RPC_REQ || t == AM__CTL_RPC_REP;
        ck_assert_int_eq(!!(e->flags & AM__CTLF_BOOT), boot);
        ck_assert_int_eq(!!(e->flags & AM__CTLF_BASIC), basic);
    }
    am_finalize(&ctx);
}
END_TEST

static int seen_calls, seen_src;
static size_t seen_len;

static void seen(am_ctx_t *ctx, int src, pr_reader *body)
{
    (void)ctx;
    seen_calls++;
    seen_src = src;
    seen_len = body->left;
}

/* Dispatches a control frame of type with a body of len bytes (0x5a) that
 * came from this PE. */
static void dispatch_ctl(am_ctx_t *ctx, unsigned type, size_t len)
{
    am__frame f;
    memset(&f, 0, sizeof f);
    ck_assert_int_eq(zmq_msg_init_size(&f.msg, PR_HEADER_SIZE + len), 0);
    memset((uint8_t *)zmq_msg_data(&f.msg) + PR_HEADER_SIZE, 0x5a, len);
    f.hdr = (pr_header){PR_FLAG_CONTROL, (uint16_t)type, 0, (uint32_t)len, 0};
    f.src = 0;
    am__dispatch(ctx, &f);
    zmq_msg_close(&f.msg);
}

/* The transport calls whatever the table holds for a type, counts the
 * frame under that type, and rejects types without an entry. */
START_TEST(dispatch_goes_through_the_table)
{
    am_ctx_t *ctx;
    ck_assert_int_eq(am_init(NULL, NULL, NULL, &ctx), 0);
    const am__ctl_entry probe = {AM__CTL_PING, "ping", 0, seen};
    const am__ctl_entry *saved = ctx->ctl[AM__CTL_PING];
    ctx->ctl[AM__CTL_PING] = &probe;
    seen_calls = 0;
    dispatch_ctl(ctx, AM__CTL_PING, 3);
    ck_assert_int_eq(seen_calls, 1);
    ck_assert_int_eq(seen_src, 0);
    ck_assert_uint_eq(seen_len, 3);
    ck_assert_uint_eq(ctx->ctl_st[AM__CTL_PING].recv, 1);
    ck_assert_uint_eq(ctx->ctl_st[AM__CTL_PING].recv_bytes, 3);
    ck_assert_uint_eq(ctx->st.ctl_recv, 1);
    ctx->ctl[AM__CTL_PING] = saved;

    /* Types outside the table are dropped and counted, nothing else. */
    dispatch_ctl(ctx, 0, 0);
    dispatch_ctl(ctx, AM__CTL_COUNT, 0);
    dispatch_ctl(ctx, 0xffff, 1);
    ck_assert_uint_eq(ctx->rejected[AM__REJ_BODY], 3);
    ck_assert_uint_eq(ctx->st.ctl_recv, 1);
    /* A module's handler checks its body: a BYE must be empty. */
    dispatch_ctl(ctx, AM__CTL_BYE, 1);
    ck_assert_uint_eq(ctx->rejected[AM__REJ_BODY], 4);
    ck_assert_int_eq(ctx->peers[0].said_bye, 0);
    dispatch_ctl(ctx, AM__CTL_BYE, 0);
    ck_assert_int_eq(ctx->peers[0].said_bye, 1);
    ck_assert_uint_eq(ctx->ctl_st[AM__CTL_BYE].recv, 2);
    ck_assert_uint_eq(ctx->st.ctl_recv, 3);
    am_finalize(&ctx);
}
END_TEST

/* ------------------------------------------------------- frame validation */

static am_ctx_t *fake_ctx(int rank, int size)
{
    am_ctx_t *ctx = calloc(1, sizeof *ctx);
    ctx->rank = rank;
    ctx->size = size;
    ctx->peers = calloc((size_t)size, sizeof *ctx->peers);
    return ctx;
}

static void free_fake(am_ctx_t *ctx)
{
    free(ctx->peers);
    free(ctx);
}

static size_t frame(uint8_t *f, uint8_t flags, uint32_t sender, uint32_t len,
                    uint64_t seq)
{
    pr_header h = {flags, 3, sender, len, seq};
    ck_assert_int_eq(pr_header_encode(&h, f), 0);
    memset(f + PR_HEADER_SIZE, 0xab, len);
    return PR_HEADER_SIZE + len;
}

START_TEST(frame_check_names_each_reason)
{
    am_ctx_t *ctx = fake_ctx(1, 4);
    uint8_t id2[5], id1[5], f[64];
    am__routing_id(2, id2);
    am__routing_id(1, id1);
    int src;
    pr_header h;
    size_t n = frame(f, 0, 2, 8, 0);
    ck_assert_int_eq(am__frame_check(ctx, id2, 5, f, n, &src, &h), 0);
    ck_assert_int_eq(src, 2);
    ck_assert_uint_eq(h.payload_len, 8);

    /* The reasons, in the order they are checked. */
    ck_assert_int_eq(am__frame_check(ctx, id2, 5, f, 23, &src, &h),
                     AM__REJ_TRUNC + 1);
    f[1] = 'X';
    ck_assert_int_eq(am__frame_check(ctx, id2, 5, f, n, &src, &h),
                     AM__REJ_MAGIC + 1);
    f[1] = 'D';
    f[4] = 2;
    ck_assert_int_eq(am__frame_check(ctx, id2, 5, f, n, &src, &h),
                     AM__REJ_VERSION + 1);
    ck_assert_int_eq(src, 2); /* known sender: named in the message */
    f[4] = PR_VERSION;
    f[5] = 0x40;
    ck_assert_int_eq(am__frame_check(ctx, id2, 5, f, n, &src, &h),
                     AM__REJ_FLAGS + 1);
    f[5] = 0;
    ck_assert_int_eq(am__frame_check(ctx, id2, 5, f, n - 1, &src, &h),
                     AM__REJ_LENGTH + 1);
    ck_assert_int_eq(am__frame_check(ctx, id1, 5, f, n, &src, &h),
                     AM__REJ_IDENTITY + 1); /* our own id */
    ck_assert_int_eq(am__frame_check(ctx, "P\x09\0\0\0", 5, f, n, &src, &h),
                     AM__REJ_IDENTITY + 1); /* rank 9 of 4 */
    ck_assert_int_eq(am__frame_check(ctx, "X", 1, f, n, &src, &h),
                     AM__REJ_IDENTITY + 1);
    ck_assert_int_eq(src, -1);
    n = frame(f, 0, 3, 8, 0);
    ck_assert_int_eq(am__frame_check(ctx, id2, 5, f, n, &src, &h),
                     AM__REJ_SENDER + 1);
    n = frame(f, 0, 2, 8, 4);
    ctx->peers[2].recv_seq = 5;
    ck_assert_int_eq(am__frame_check(ctx, id2, 5, f, n, &src, &h),
                     AM__REJ_SEQ + 1);
    free_fake(ctx);
}
END_TEST

/* A bundle is cut at each header's stated length; a tail that is not a
 * whole frame is not cut (the receiver checks it as one frame). */
START_TEST(bundle_cuts_at_each_frame)
{
    uint8_t b[256];
    size_t n1 = frame(b, 0, 2, 8, 0);
    size_t n2 = frame(b + n1, PR_FLAG_CONTROL, 2, 0, 1);
    size_t n3 = frame(b + n1 + n2, 0, 2, 100, 2);
    size_t len = n1 + n2 + n3;
    ck_assert_uint_eq(am__bundle_next(b, len), n1);
    ck_assert_uint_eq(am__bundle_next(b + n1, len - n1), n2);
    ck_assert_uint_eq(am__bundle_next(b + n1 + n2, n3), n3);
    /* A lone frame is its own length. */
    ck_assert_uint_eq(am__bundle_next(b, n1), n1);
    /* Tails: shorter than a header, or a length past the end. */
    ck_assert_uint_eq(am__bundle_next(b + n1 + n2, PR_HEADER_SIZE - 1), 0);
    ck_assert_uint_eq(am__bundle_next(b + n1 + n2, n3 - 1), 0);
    ck_assert_uint_eq(am__bundle_next(b, 0), 0);
    /* The largest length cannot wrap the arithmetic. */
    pr_store_u32(b + 12, UINT32_MAX);
    ck_assert_uint_eq(am__bundle_next(b, len), 0);
}
END_TEST

static Suite *control_suite(void)
{
    Suite *s = suite_create("am_control");
    TCase *tc = tcase_create("codecs");
    tcase_add_test(tc, hello_round_trip);
    tcase_add_test(tc, peer_hello_round_trip);
    tcase_add_test(tc, table_round_trip_and_limits);
    tcase_add_test(tc, token_round_trip);
    tcase_add_test(tc, collective_round_trip);
    tcase_add_test(tc, gather_and_rpc_round_trip);
    tcase_add_test(tc, abort_round_trip);
    tcase_add_test(tc, credit_round_trip);
    tcase_add_test(tc, empty_bodies);
    suite_add_tcase(s, tc);
    tc = tcase_create("dispatch");
    tcase_add_test(tc, dispatch_table_is_complete);
    tcase_add_test(tc, dispatch_goes_through_the_table);
    tcase_add_test(tc, bundle_cuts_at_each_frame);
    suite_add_tcase(s, tc);
    tc = tcase_create("frames");
    tcase_add_test(tc, frame_check_names_each_reason);
    suite_add_tcase(s, tc);
    return s;
}

UNIT_MAIN(control_suite)
