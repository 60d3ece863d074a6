/* Unit tests of the job's CURVE keys (am_keys.c: key blocks written and
 * read back, and every defect refused) and of the ZAP handler (am_zap.c:
 * the job's keys admitted with their rank as user id, others refused and
 * counted once per address), over tcp on 127.0.0.1. */
#include "config.h"

#include <fcntl.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "am_int.h"
#include "unit.h"

enum { NK = 3 };
static char pub[NK][41], sec[NK][41], rdv_pub[41], rdv_sec[41];

static void make_keys(void)
{
    for (int r = 0; r < NK; r++)
        ck_assert_int_eq(zmq_curve_keypair(pub[r], sec[r]), 0);
    ck_assert_int_eq(zmq_curve_keypair(rdv_pub, rdv_sec), 0);
}

/* Reads text as PE rank's key block through a pipe (AM_CURVE_KEYS=fd:N). */
static int read_text(const char *text, int rank, am__keys **k)
{
    int p[2];
    ck_assert_int_eq(pipe(p), 0);
    ck_assert_int_eq(write(p[1], text, strlen(text)), (ssize_t)strlen(text));
    close(p[1]);
    char spec[32];
    snprintf(spec, sizeof spec, "fd:%d", p[0]);
    return am__keys_read(NULL, spec, rank, NK, 5.0, k); /* closes p[0] */
}

START_TEST(block_round_trip)
{
    make_keys();
    char *block;
    size_t len;
    ck_assert_int_eq(am__keys_format(pub, sec, NK, 1, rdv_pub, &block, &len), 0);
    ck_assert_uint_eq(strlen(block), len);
    am__keys *k = NULL;
    ck_assert_int_eq(read_text(block, 1, &k), 0);
    ck_assert_int_eq(k->n, NK);
    for (int r = 0; r < NK; r++)
        ck_assert_str_eq(k->pub[r], pub[r]);
    ck_assert_str_eq(k->secret, sec[1]);
    ck_assert_str_eq(k->public_, pub[1]);
    ck_assert_str_eq(k->rdv, rdv_pub);
    am__keys_free(&k);
    ck_assert_ptr_null(k);
    /* The block holds rank 1's secret only. */
    ck_assert_ptr_null(strstr(block, sec[0]));
    ck_assert_ptr_null(strstr(block, sec[2]));
    ck_assert_int_eq(read_text(block, 2, &k), AM_EINVAL);
    free(block);
}
END_TEST

START_TEST(file_with_every_secret)
{
    make_keys();
    char *block;
    size_t len;
    ck_assert_int_eq(am__keys_format(pub, sec, NK, -1, NULL, &block, &len), 0);
    char path[] = "/tmp/test_am_keys.XXXXXX";
    int fd = mkstemp(path); /* mode 0600 */
    ck_assert_int_ge(fd, 0);
    ck_assert_int_eq(write(fd, block, len), (ssize_t)len);
    close(fd);
    for (int r = 0; r < NK; r++) {
        am__keys *k = NULL;
        ck_assert_int_eq(am__keys_read(NULL, path, r, NK, 5.0, &k), 0);
        ck_assert_str_eq(k->secret, sec[r]);
        ck_assert_str_eq(k->rdv, "");
        am__keys_free(&k);
    }
    /* A secret others can read is refused. */
    ck_assert_int_eq(chmod(path, 0644), 0);
    am__keys *k = NULL;
    ck_assert_int_eq(am__keys_read(NULL, path, 0, NK, 5.0, &k), AM_EINVAL);
    ck_assert_ptr_null(k);
    unlink(path);
    ck_assert_int_eq(am__keys_read(NULL, path, 0, NK, 5.0, &k), AM_EINVAL);
    free(block);
}
END_TEST

START_TEST(defects_refused)
{
    make_keys();
    char good[1024];
    int n = snprintf(good, sizeof good,
                     "am-curve-keys 1\npublic 0 %s\npublic 1 %s\npublic 2 %s\n"
                     "secret 1 %s\nend\n",
                     pub[0], pub[1], pub[2], sec[1]);
    ck_assert(n > 0 && (size_t)n < sizeof good);
    am__keys *k = NULL;
    ck_assert_int_eq(read_text(good, 1, &k), 0);
    am__keys_free(&k);
    char bad[16][1024];
    int nb = 0;
    /* no header; cut short; a public key missing; a duplicated rank; a
     * rank outside the job; a key too short; a character outside Z85; the
     * secret of another PE under rank 1; an unknown line; no secret */
    snprintf(bad[nb++], 1024, "%s", strchr(good, '\n') + 1);
    snprintf(bad[nb++], 1024, "%.*s", (int)(strstr(good, "end\n") - good), good);
    snprintf(bad[nb++], 1024, "am-curve-keys 1\npublic 0 %s\npublic 1 %s\n"
                              "secret 1 %s\nend\n", pub[0], pub[1], sec[1]);
    snprintf(bad[nb++], 1024, "am-curve-keys 1\npublic 0 %s\npublic 1 %s\n"
                              "public 1 %s\nsecret 1 %s\nend\n",
             pub[0], pub[1], pub[2], sec[1]);
    snprintf(bad[nb++], 1024, "%.*spublic 3 %s\nend\n",
             (int)(strstr(good, "end\n") - good), good, pub[0]);
    snprintf(bad[nb++], 1024, "am-curve-keys 1\npublic 0 %.39s\npublic 1 %s\n"
                              "public 2 %s\nsecret 1 %s\nend\n",
             pub[0], pub[1], pub[2], sec[1]);
    snprintf(bad[nb++], 1024, "am-curve-keys 1\npublic 0 %.39s,\npublic 1 %s\n"
                              "public 2 %s\nsecret 1 %s\nend\n",
             pub[0], pub[1], pub[2], sec[1]);
    snprintf(bad[nb++], 1024, "am-curve-keys 1\npublic 0 %s\npublic 1 %s\n"
                              "public 2 %s\nsecret 1 %s\nend\n",
             pub[0], pub[1], pub[2], sec[0]);
    snprintf(bad[nb++], 1024, "am-curve-keys 1\npublic 0 %s\npublic 1 %s\n"
                              "public 2 %s\nsecret 1 %s\nhello\nend\n",
             pub[0], pub[1], pub[2], sec[1]);
    snprintf(bad[nb++], 1024, "am-curve-keys 1\npublic 0 %s\npublic 1 %s\n"
                              "public 2 %s\nsecret 2 %s\nend\n",
             pub[0], pub[1], pub[2], sec[2]);
    for (int i = 0; i < nb; i++) {
        ck_assert_msg(read_text(bad[i], 1, &k) == AM_EINVAL,
                      "defect %d accepted:\n%s", i, bad[i]);
        ck_assert_ptr_null(k);
    }
    ck_assert_int_eq(am__keys_read(NULL, "fd:9999", 1, NK, 1.0, &k), AM_EINVAL);
    ck_assert_int_eq(am__keys_read(NULL, "fd:x", 1, NK, 1.0, &k), AM_EINVAL);
}
END_TEST

START_TEST(shared_pair)
{
    make_keys();
    am__keys *k = NULL;
    ck_assert_int_eq(am__keys_shared(pub[0], sec[0], NK, &k), 0);
    for (int r = 0; r < NK; r++)
        ck_assert_str_eq(k->pub[r], pub[0]);
    ck_assert_str_eq(k->secret, sec[0]);
    am__keys_free(&k);
    ck_assert_int_eq(am__keys_shared(pub[0], "short", NK, &k), AM_EINVAL);
}
END_TEST

/* One client connection with key pair (cpub, csec) to a CURVE server whose
 * ZAP handler holds the job's keys; returns the User-Id of its frame at
 * the server ("" if none), or NULL if the frame never arrived. */
static const char *try_client(void *zctx, void *server, const char *ep,
                              const char *cpub, const char *csec,
                              char *uid, size_t cap)
{
    void *c = zmq_socket(zctx, ZMQ_DEALER);
    int zero = 0, never = -1;
    zmq_setsockopt(c, ZMQ_LINGER, &zero, sizeof zero);
    zmq_setsockopt(c, ZMQ_RECONNECT_IVL, &never, sizeof never);
    ck_assert_int_eq(zmq_setsockopt(c, ZMQ_CURVE_SERVERKEY, pub[0], 40), 0);
    ck_assert_int_eq(zmq_setsockopt(c, ZMQ_CURVE_PUBLICKEY, cpub, 40), 0);
    ck_assert_int_eq(zmq_setsockopt(c, ZMQ_CURVE_SECRETKEY, csec, 40), 0);
    ck_assert_int_eq(zmq_connect(c, ep), 0);
    zmq_send(c, "hi", 2, ZMQ_DONTWAIT);
    const char *got = NULL;
    zmq_pollitem_t it = {server, 0, ZMQ_POLLIN, 0};
    if (zmq_poll(&it, 1, 1000) == 1) {
        zmq_msg_t id, m;
        zmq_msg_init(&id);
        zmq_msg_init(&m);
        ck_assert_int_ge(zmq_msg_recv(&id, server, 0), 0);
        ck_assert_int_eq(zmq_msg_recv(&m, server, 0), 2);
        const char *u = zmq_msg_gets(&m, "User-Id");
        snprintf(uid, cap, "%s", u ? u : "");
        got = uid;
        zmq_msg_close(&id);
        zmq_msg_close(&m);
    }
    zmq_close(c);
    return got;
}

/* A ROUTER that is a CURVE server (PE 0's secret) on a loopback port,
 * behind a ZAP handler admitting keys[0..n); its endpoint in ep. */
static void *zap_server(void *zctx, const char (*keys)[41], int n, am__zap **z, char *ep,
                        size_t eplen)
{
    ck_assert_int_eq(am__zap_start(zctx, keys, n, "test_am_keys: ", "the test server", z), 0);
    void *server = zmq_socket(zctx, ZMQ_ROUTER);
    int one = 1, zero = 0;
    zmq_setsockopt(server, ZMQ_LINGER, &zero, sizeof zero);
    zmq_setsockopt(server, ZMQ_CURVE_SERVER, &one, sizeof one);
    zmq_setsockopt(server, ZMQ_CURVE_SECRETKEY, sec[0], 40);
    ck_assert_int_eq(zmq_bind(server, "tcp://127.0.0.1:*"), 0);
    zmq_getsockopt(server, ZMQ_LAST_ENDPOINT, ep, &eplen);
    return server;
}

START_TEST(zap_admits_the_jobs_keys_only)
{
    make_keys();
    void *zctx = zmq_ctx_new();
    am__zap *z = NULL;
    char ep[128], uid[32];
    void *server = zap_server(zctx, (const char (*)[41])pub, NK, &z, ep, sizeof ep);
    /* PE 2's key: admitted, and named. */
    const char *u = try_client(zctx, server, ep, pub[2], sec[2], uid, sizeof uid);
    ck_assert_ptr_nonnull(u);
    ck_assert_str_eq(u, "2");
    /* A stranger, twice: refused both times, one address. */
    char spub[41], ssec[41];
    ck_assert_int_eq(zmq_curve_keypair(spub, ssec), 0);
    ck_assert_ptr_null(try_client(zctx, server, ep, spub, ssec, uid, sizeof uid));
    ck_assert_ptr_null(try_client(zctx, server, ep, spub, ssec, uid, sizeof uid));
    ck_assert_uint_eq(am__zap_refused(z), 2);
    ck_assert_uint_eq(am__zap_strangers(z), 1);
    zmq_close(server);
    am__zap_stop(&z);
    ck_assert_ptr_null(z);
    zmq_ctx_term(zctx);
}
END_TEST

START_TEST(zap_shared_key_names_no_rank)
{
    make_keys();
    char same[2][41];
    memcpy(same[0], pub[1], 41);
    memcpy(same[1], pub[1], 41);
    void *zctx = zmq_ctx_new();
    am__zap *z = NULL;
    char ep[128], uid[32];
    void *server = zap_server(zctx, (const char (*)[41])same, 2, &z, ep, sizeof ep);
    const char *u = try_client(zctx, server, ep, pub[1], sec[1], uid, sizeof uid);
    ck_assert_ptr_nonnull(u);
    ck_assert_str_eq(u, "");
    zmq_close(server);
    am__zap_stop(&z);
    zmq_ctx_term(zctx);
}
END_TEST

static Suite *keys_suite(void)
{
    Suite *s = suite_create("am_keys");
    TCase *tc = tcase_create("blocks");
    tcase_add_test(tc, block_round_trip);
    tcase_add_test(tc, file_with_every_secret);
    tcase_add_test(tc, defects_refused);
    tcase_add_test(tc, shared_pair);
    suite_add_tcase(s, tc);
    tc = tcase_create("zap");
    tcase_set_timeout(tc, 20);
    tcase_add_test(tc, zap_admits_the_jobs_keys_only);
    tcase_add_test(tc, zap_shared_key_names_no_rank);
    suite_add_tcase(s, tc);
    return s;
}

UNIT_MAIN(keys_suite)
