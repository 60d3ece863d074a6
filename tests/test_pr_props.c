/* Property tests of proto's codecs over seeded random contents: every
 * valid value round-trips exactly, every truncation and every trailing byte
 * is refused, and no corruption of a valid message is accepted unless it
 * is itself a canonical encoding (prs_check). Seeds are fixed, so a
 * failure repeats; PR_PROPS_ITERATIONS scales the number of cases. */
#include "config.h"

#include <stdint.h>
#include <stdlib.h>

#include "pr.h"
#include "pr_sample.h"
#include "unit.h"

static int iterations(int dflt)
{
    const char *s = getenv("PR_PROPS_ITERATIONS");
    int n = s ? atoi(s) : 0;
    return n > 0 ? n : dflt;
}

/* Encodes a random valid value of kind into b and returns 0, or the
 * encoder's error. */
static int random_message(int kind, prs_rng *r, pr_buf *b)
{
    switch (kind) {
    case PRS_HEADER: {
        pr_header h = {.flags = (uint8_t)(prs_next(r) & PR_FLAG_KNOWN),
                       .handler = (uint16_t)prs_next(r),
                       .sender = (uint32_t)prs_next(r),
                       .payload_len = (uint32_t)prs_below(r, PR_MAX_PAYLOAD + 1),
                       .seq = prs_next(r)};
        return pr_header_put(b, &h);
    }
    case PRS_HELLO: {
        pr_hello h;
        prs_random_hello(r, &h);
        return pr_hello_put(b, &h);
    }
    case PRS_STATS: {
        pr_stats s;
        prs_random_stats(r, &s);
        int rc = pr_stats_put(b, &s);
        pr_stats_clear(&s);
        return rc;
    }
    case PRS_SUBMESH: {
        pr_submesh sm;
        prs_random_submesh(r, &sm);
        int rc = pr_submesh_put(b, &sm);
        prs_submesh_free(&sm);
        return rc;
    }
    case PRS_VERTEX: {
        pr_vertex v;
        prs_random_vertex(r, &v);
        return pr_vertex_put(b, &v);
    }
    case PRS_TET: {
        pr_tet t;
        prs_random_tet(r, &t);
        return pr_tet_put(b, &t);
    }
    default: {
        pr_face_key *k;
        uint32_t n;
        prs_random_face_keys(r, &k, &n);
        int rc = pr_face_keys_put(b, k, n);
        free(k);
        return rc;
    }
    }
}

/* Random values survive encode and decode unchanged, field by field (not
 * only byte by byte: prs_check compares bytes). */
START_TEST(submesh_round_trips)
{
    prs_rng r = {1};
    int n = iterations(2000);
    for (int i = 0; i < n; i++) {
        pr_submesh sm, *back;
        pr_buf b = PR_BUF_INIT;
        prs_random_submesh(&r, &sm);
        ck_assert_int_eq(pr_submesh_put(&b, &sm), 0);
        ck_assert_int_eq(pr_submesh_decode(b.data, b.len, &back), 0);
        ck_assert_msg(prs_submesh_equal(&sm, back), "iteration %d differs", i);
        pr_submesh_free(&back);
        ck_assert_ptr_null(back);
        prs_submesh_free(&sm);
        pr_buf_free(&b);
    }
}
END_TEST

START_TEST(stats_round_trip)
{
    prs_rng r = {2};
    int n = iterations(2000);
    for (int i = 0; i < n; i++) {
        pr_stats s, back = PR_STATS_INIT;
        pr_buf b = PR_BUF_INIT;
        prs_random_stats(&r, &s);
        ck_assert_int_eq(pr_stats_put(&b, &s), 0);
        ck_assert_int_eq(pr_stats_decode(&back, b.data, b.len), 0);
        ck_assert_msg(prs_stats_equal(&s, &back), "iteration %d differs", i);
        pr_stats_clear(&back);
        pr_stats_clear(&s);
        pr_buf_free(&b);
    }
}
END_TEST

START_TEST(hello_and_entities_round_trip)
{
    prs_rng r = {3};
    int n = iterations(5000);
    for (int i = 0; i < n; i++) {
        pr_buf b = PR_BUF_INIT;
        pr_reader rd;

        pr_hello h, h2;
        prs_random_hello(&r, &h);
        ck_assert_int_eq(pr_hello_put(&b, &h), 0);
        ck_assert_int_eq(pr_hello_decode(&h2, b.data, b.len), 0);
        ck_assert(h.version == h2.version && h.version_min == h2.version_min &&
                  h.version_max == h2.version_max && h.job == h2.job &&
                  h.rank == h2.rank && h.size == h2.size);

        pr_vertex v, v2;
        prs_random_vertex(&r, &v);
        pr_buf_reset(&b);
        ck_assert_int_eq(pr_vertex_put(&b, &v), 0);
        ck_assert_uint_eq(b.len, PR_VERTEX_SIZE);
        pr_reader_init(&rd, b.data, b.len);
        ck_assert_int_eq(pr_vertex_get(&rd, &v2), 0);
        ck_assert_int_eq(pr_reader_finish(&rd), 0);
        ck_assert(v.gid == v2.gid && v.flags == v2.flags &&
                  !memcmp(v.xyz, v2.xyz, sizeof v.xyz));

        pr_tet t, t2;
        prs_random_tet(&r, &t);
        pr_buf_reset(&b);
        ck_assert_int_eq(pr_tet_put(&b, &t), 0);
        ck_assert_uint_eq(b.len, PR_TET_SIZE);
        pr_reader_init(&rd, b.data, b.len);
        ck_assert_int_eq(pr_tet_get(&rd, &t2), 0);
        ck_assert_int_eq(pr_reader_finish(&rd), 0);
        ck_assert(!memcmp(t.v, t2.v, sizeof t.v) &&
                  !memcmp(t.face_marker, t2.face_marker, sizeof t.face_marker) &&
                  t.subseg == t2.subseg && t.owner == t2.owner);

        pr_face_key *k, *k2;
        uint32_t nk, nk2;
        prs_random_face_keys(&r, &k, &nk);
        pr_buf_reset(&b);
        ck_assert_int_eq(pr_face_keys_put(&b, k, nk), 0);
        pr_reader_init(&rd, b.data, b.len);
        ck_assert_int_eq(pr_face_keys_get(&rd, &k2, &nk2), 0);
        ck_assert_int_eq(pr_reader_finish(&rd), 0);
        ck_assert_uint_eq(nk, nk2);
        ck_assert(nk == 0 || !memcmp(k, k2, nk * sizeof *k));
        free(k);
        free(k2);
        pr_buf_free(&b);
    }
}
END_TEST

/* For every kind: the fixed sample and random messages are accepted and
 * canonical; every proper prefix and the message plus one byte are
 * refused. */
START_TEST(truncations_and_trailing_bytes_are_refused)
{
    prs_rng r = {4};
    int n = iterations(2000) / 20;
    for (int kind = 0; kind < PRS_NKINDS; kind++) {
        for (int i = 0; i <= n; i++) {
            pr_buf b = PR_BUF_INIT;
            int rc = i == 0 ? prs_fixed(kind, &b) : random_message(kind, &r, &b);
            ck_assert_int_eq(rc, 0);
            ck_assert_int_eq(prs_check(kind, b.data, b.len), 0);
            /* A decoder must not look at bytes it was not given: each
             * prefix is copied to a buffer of exactly its length, so that
             * ASan catches any read past it. */
            for (size_t cut = 0; cut < b.len; cut++) {
                uint8_t *p = malloc(cut ? cut : 1);
                ck_assert_ptr_nonnull(p);
                memcpy(p, b.data, cut);
                int got = prs_check(kind, p, cut);
                if (kind == PRS_HEADER)
                    ck_assert_msg(got == (cut < PR_HEADER_SIZE ? PR_ETRUNC : 0),
                                  "header cut at %zu: %d", cut, got);
                else
                    ck_assert_msg(got < 0, "%s cut at %zu of %zu accepted (%d)",
                                  prs_name(kind), cut, b.len, got);
                free(p);
            }
            pr_put_u8(&b, 0);
            rc = prs_check(kind, b.data, b.len);
            if (kind == PRS_HEADER) /* a payload may follow a header */
                ck_assert_int_eq(rc, 0);
            else
                ck_assert_msg(rc == PR_ETRAILING, "%s with a trailing byte: %d",
                              prs_name(kind), rc);
            pr_buf_free(&b);
        }
    }
}
END_TEST

/* Every single-byte change of every fixed sample (all 255 other values at
 * every offset) is either refused or decodes to a value whose encoding is
 * exactly the changed bytes. No input is accepted and then misread. */
START_TEST(no_byte_change_is_misread)
{
    for (int kind = 0; kind < PRS_NKINDS; kind++) {
        pr_buf b = PR_BUF_INIT;
        ck_assert_int_eq(prs_fixed(kind, &b), 0);
        int accepted = 0, refused = 0;
        for (size_t at = 0; at < b.len; at++) {
            uint8_t keep = b.data[at];
            for (int x = 1; x < 256; x++) {
                b.data[at] = (uint8_t)(keep ^ x);
                int rc = prs_check(kind, b.data, b.len);
                ck_assert_msg(rc != 1, "%s: byte %zu ^ %d misread",
                              prs_name(kind), at, x);
                rc ? refused++ : accepted++;
            }
            b.data[at] = keep;
        }
        /* Both outcomes occur: the checks are neither blind nor paranoid. */
        ck_assert_int_gt(refused, 0);
        ck_assert_int_gt(accepted, 0);
        pr_buf_free(&b);
    }
}
END_TEST

/* Random garbage after a valid type byte never crashes a decoder and is
 * almost always refused. */
START_TEST(random_bytes_are_refused_or_canonical)
{
    prs_rng r = {5};
    int n = iterations(2000) * 5;
    uint8_t buf[256];
    for (int i = 0; i < n; i++) {
        int kind = (int)prs_below(&r, PRS_NKINDS);
        size_t len = prs_below(&r, sizeof buf + 1);
        for (size_t j = 0; j < len; j++)
            buf[j] = (uint8_t)prs_next(&r);
        if (len && kind != PRS_HEADER && kind < PRS_VERTEX)
            buf[0] = (uint8_t)(kind == PRS_HELLO     ? PR_MSG_HELLO
                               : kind == PRS_STATS ? PR_MSG_STATS
                                                   : PR_MSG_SUBMESH);
        ck_assert_int_ne(prs_check(kind, buf, len), 1);
    }
}
END_TEST

static Suite *props_suite(void)
{
    Suite *s = suite_create("pr_props");
    TCase *tc = tcase_create("roundtrip");
    tcase_set_timeout(tc, 120);
    tcase_add_test(tc, submesh_round_trips);
    tcase_add_test(tc, stats_round_trip);
    tcase_add_test(tc, hello_and_entities_round_trip);
    suite_add_tcase(s, tc);
    tc = tcase_create("malformed");
    tcase_set_timeout(tc, 120);
    tcase_add_test(tc, truncations_and_trailing_bytes_are_refused);
    tcase_add_test(tc, no_byte_change_is_misread);
    tcase_add_test(tc, random_bytes_are_refused_or_canonical);
    suite_add_tcase(s, tc);
    return s;
}

UNIT_MAIN(props_suite)
