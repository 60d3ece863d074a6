/* Unit tests of proto's primitives (buffer, reader, arrays, strings) and
 * frame header. */
#include "config.h"

#include <stdint.h>

#include "pr.h"
#include "unit.h"

START_TEST(header_has_the_documented_byte_layout)
{
    pr_header h = {.flags = PR_FLAG_CONTROL,
                   .handler = 0x1234,
                   .sender = 0x05060708,
                   .payload_len = 0x00010203,
                   .seq = UINT64_C(0x1122334455667788)};
    uint8_t raw[PR_HEADER_SIZE];
    ck_assert_int_eq(pr_header_encode(&h, raw), 0);
    static const uint8_t expect[PR_HEADER_SIZE] = {
        0x50, 0x44, 0x52, 0xA7, /* magic */
        0x01,                   /* version */
        0x01,                   /* flags */
        0x34, 0x12,             /* handler */
        0x08, 0x07, 0x06, 0x05, /* sender */
        0x03, 0x02, 0x01, 0x00, /* payload length */
        0x88, 0x77, 0x66, 0x55, 0x44, 0x33, 0x22, 0x11 /* seq */
    };
    ck_assert_mem_eq(raw, expect, PR_HEADER_SIZE);
}
END_TEST

START_TEST(header_round_trips)
{
    for (uint32_t i = 0; i < 1000; i++) {
        pr_header h = {.flags = (uint8_t)(i & 1),
                       .handler = (uint16_t)(i * 7919u),
                       .sender = i * 2654435761u,
                       .payload_len = (i * 40503u) % (PR_MAX_PAYLOAD + 1),
                       .seq = (uint64_t)i * UINT64_C(0x9E3779B97F4A7C15)};
        pr_buf b = PR_BUF_INIT;
        ck_assert_int_eq(pr_header_put(&b, &h), 0);
        ck_assert_uint_eq(b.len, PR_HEADER_SIZE);
        pr_header back;
        ck_assert_int_eq(pr_header_decode(&back, b.data, b.len), 0);
        ck_assert_uint_eq(back.flags, h.flags);
        ck_assert_uint_eq(back.handler, h.handler);
        ck_assert_uint_eq(back.sender, h.sender);
        ck_assert_uint_eq(back.payload_len, h.payload_len);
        ck_assert_uint_eq(back.seq, h.seq);
        pr_buf_free(&b);
    }
}
END_TEST

START_TEST(header_decode_rejects_bad_frames)
{
    pr_header h = {.handler = 1, .payload_len = 10};
    uint8_t raw[PR_HEADER_SIZE];
    ck_assert_int_eq(pr_header_encode(&h, raw), 0);
    pr_header out;
    for (size_t len = 0; len < PR_HEADER_SIZE; len++)
        ck_assert_int_eq(pr_header_decode(&out, raw, len), PR_ETRUNC);
    ck_assert_int_eq(pr_header_decode(&out, NULL, 100), PR_ETRUNC);

    uint8_t bad[PR_HEADER_SIZE];
    memcpy(bad, raw, sizeof bad);
    bad[0] = 'X';
    ck_assert_int_eq(pr_header_decode(&out, bad, sizeof bad), PR_EMAGIC);

    memcpy(bad, raw, sizeof bad);
    bad[4] = PR_VERSION + 1;
    ck_assert_int_eq(pr_header_decode(&out, bad, sizeof bad), PR_EVERSION);

    memcpy(bad, raw, sizeof bad);
    bad[5] = 0x80;
    ck_assert_int_eq(pr_header_decode(&out, bad, sizeof bad), PR_EFLAGS);

    memcpy(bad, raw, sizeof bad);
    pr_store_u32(bad + 12, PR_MAX_PAYLOAD + 1);
    ck_assert_int_eq(pr_header_decode(&out, bad, sizeof bad), PR_ERANGE);

    h.flags = 0x40;
    ck_assert_int_eq(pr_header_encode(&h, raw), PR_EINVAL);
}
END_TEST

START_TEST(reader_never_reads_past_the_end)
{
    uint8_t data[11] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11};
    pr_reader r;
    pr_reader_init(&r, data, sizeof data);
    uint64_t v64;
    uint32_t v32;
    ck_assert_int_eq(pr_get_u64(&r, &v64), 0);
    ck_assert_uint_eq(v64, UINT64_C(0x0807060504030201));
    ck_assert_int_eq(pr_get_u32(&r, &v32), PR_ETRUNC);
    ck_assert_uint_eq(v32, 0);
    /* The error is sticky: even a read that would fit now fails. */
    uint8_t v8;
    ck_assert_int_eq(pr_get_u8(&r, &v8), PR_ETRUNC);
    ck_assert_int_eq(pr_reader_finish(&r), PR_ETRUNC);
}
END_TEST

START_TEST(count_is_checked_before_anything_is_allocated)
{
    pr_buf b = PR_BUF_INIT;
    pr_put_u32(&b, 1000000); /* claims a million 8-byte elements */
    pr_put_u64(&b, 42);      /* but carries one */
    pr_reader r;
    uint32_t n;
    pr_reader_init(&r, b.data, b.len);
    ck_assert_int_eq(pr_get_count(&r, UINT32_MAX, 8, &n), PR_ETRUNC);
    ck_assert_uint_eq(n, 0);

    pr_reader_init(&r, b.data, b.len);
    ck_assert_int_eq(pr_get_count(&r, 10, 8, &n), PR_ERANGE);

    pr_buf_reset(&b);
    pr_put_u32(&b, 1);
    pr_put_f64(&b, -0.5);
    pr_reader_init(&r, b.data, b.len);
    ck_assert_int_eq(pr_get_count(&r, 10, 8, &n), 0);
    ck_assert_uint_eq(n, 1);
    double d;
    ck_assert_int_eq(pr_get_f64(&r, &d), 0);
    ck_assert(d == -0.5);
    ck_assert_int_eq(pr_reader_finish(&r), 0);
    pr_buf_free(&b);
}
END_TEST

START_TEST(trailing_bytes_are_reported)
{
    uint8_t data[3] = {7, 0, 9};
    pr_reader r;
    pr_reader_init(&r, data, sizeof data);
    uint16_t v;
    ck_assert_int_eq(pr_get_u16(&r, &v), 0);
    ck_assert_uint_eq(v, 7);
    ck_assert_int_eq(pr_reader_finish(&r), PR_ETRAILING);
}
END_TEST

START_TEST(buffer_take_transfers_ownership)
{
    pr_buf b = PR_BUF_INIT;
    for (int i = 0; i < 1000; i++)
        pr_put_u32(&b, (uint32_t)i);
    ck_assert_int_eq(b.err, 0);
    size_t len;
    uint8_t *p = pr_buf_take(&b, &len);
    ck_assert_ptr_nonnull(p);
    ck_assert_uint_eq(len, 4000);
    ck_assert_ptr_null(b.data);
    ck_assert_uint_eq(pr_load_u32(p + 4 * 999), 999);
    free(p);
    pr_buf_free(&b);
}
END_TEST

START_TEST(arrays_are_little_endian_and_round_trip)
{
    uint32_t u32[3] = {0x01020304, 0, UINT32_MAX};
    int32_t i32[2] = {-1, INT32_MIN};
    uint64_t u64[2] = {UINT64_C(0x0102030405060708), 1};
    double f64[3] = {1.0, -0.0, 5e-324};
    pr_buf b = PR_BUF_INIT;
    pr_put_u32_array(&b, u32, 3);
    pr_put_i32_array(&b, i32, 2);
    pr_put_u64_array(&b, u64, 2);
    pr_put_f64_array(&b, f64, 3);
    pr_put_u32_array(&b, NULL, 0); /* empty arrays write nothing */
    ck_assert_int_eq(b.err, 0);
    ck_assert_uint_eq(b.len, 12 + 8 + 16 + 24);
    static const uint8_t head[] = {4, 3, 2, 1, 0, 0, 0, 0, 0xff, 0xff, 0xff, 0xff,
                                   0xff, 0xff, 0xff, 0xff, 0, 0, 0, 0x80,
                                   8, 7, 6, 5, 4, 3, 2, 1};
    ck_assert_mem_eq(b.data, head, sizeof head);
    /* -0.0 keeps its sign bit, the smallest subnormal its one bit. */
    ck_assert_uint_eq(pr_load_u64(b.data + 44), UINT64_C(0x8000000000000000));
    ck_assert_uint_eq(pr_load_u64(b.data + 52), 1);

    uint32_t u32b[3];
    int32_t i32b[2];
    uint64_t u64b[2];
    double f64b[3];
    pr_reader r;
    pr_reader_init(&r, b.data, b.len);
    ck_assert_int_eq(pr_get_u32_array(&r, u32b, 3), 0);
    ck_assert_int_eq(pr_get_i32_array(&r, i32b, 2), 0);
    ck_assert_int_eq(pr_get_u64_array(&r, u64b, 2), 0);
    ck_assert_int_eq(pr_get_f64_array(&r, f64b, 3), 0);
    ck_assert_int_eq(pr_get_u32_array(&r, NULL, 0), 0);
    ck_assert_int_eq(pr_reader_finish(&r), 0);
    ck_assert_mem_eq(u32, u32b, sizeof u32);
    ck_assert_mem_eq(i32, i32b, sizeof i32);
    ck_assert_mem_eq(u64, u64b, sizeof u64);
    ck_assert_mem_eq(f64, f64b, sizeof f64);

    /* One element too many is refused, and so is a count whose byte size
     * overflows. */
    pr_reader_init(&r, b.data, 11);
    ck_assert_int_eq(pr_get_u32_array(&r, u32b, 3), PR_ETRUNC);
    pr_reader_init(&r, b.data, b.len);
    ck_assert_int_eq(pr_get_u64_array(&r, u64b, SIZE_MAX / 4), PR_ETRUNC);
    pr_buf_free(&b);
}
END_TEST

START_TEST(strings_are_utf8_without_controls)
{
    static const char *const good[] = {
        "", "plain ascii", "caf\xc3\xa9", "\xe2\x86\x92", "\xf0\x9f\x98\x80",
        "\xf4\x8f\xbf\xbf", /* U+10FFFF */
        "\xc2\x80",          /* U+0080 */
    };
    static const char *const bad[] = {
        "tab\t", "\x7f", "\x1b[0m", "\xc0\x80", /* overlong NUL */
        "\xe0\x80\xaf",                       /* overlong '/' */
        "\xed\xa0\x80",                       /* surrogate U+D800 */
        "\xf4\x90\x80\x80",                   /* U+110000 */
        "\xc3",                               /* cut short */
        "\x80", "\xf8\x88\x80\x80\x80", "\xc3\x28",
    };
    for (size_t i = 0; i < sizeof good / sizeof *good; i++)
        ck_assert_msg(pr_str_check(good[i], strlen(good[i])) == 0, "good %zu", i);
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++)
        ck_assert_msg(pr_str_check(bad[i], strlen(bad[i])) == PR_EDATA, "bad %zu", i);
    ck_assert_int_eq(pr_str_check("a\0b", 3), PR_EDATA); /* embedded NUL */
    ck_assert_int_eq(pr_str_check("x", (size_t)PR_STR_MAX + 1), PR_ERANGE);

    pr_buf b = PR_BUF_INIT;
    ck_assert_int_eq(pr_put_str(&b, "caf\xc3\xa9", 5), 0);
    ck_assert_uint_eq(b.len, 7);
    ck_assert_uint_eq(pr_load_u16(b.data), 5);
    char out[8];
    size_t len;
    pr_reader r;
    pr_reader_init(&r, b.data, b.len);
    ck_assert_int_eq(pr_get_str(&r, 7, out, &len), 0);
    ck_assert_str_eq(out, "caf\xc3\xa9");
    ck_assert_uint_eq(len, 5);
    pr_reader_init(&r, b.data, b.len);
    ck_assert_int_eq(pr_get_str(&r, 4, out, &len), PR_ERANGE);
    ck_assert_str_eq(out, "");
    b.data[3] = 0; /* a NUL inside the string */
    pr_reader_init(&r, b.data, b.len);
    ck_assert_int_eq(pr_get_str(&r, 7, out, NULL), PR_EDATA);
    pr_reader_init(&r, b.data, b.len - 1);
    ck_assert_int_eq(pr_get_str(&r, 7, out, NULL), PR_ETRUNC);

    /* A refused string is not written and the error sticks. */
    pr_buf_reset(&b);
    ck_assert_int_eq(pr_put_str(&b, "\xff", 1), PR_EINVAL);
    ck_assert_uint_eq(b.len, 0);
    pr_put_u32(&b, 1);
    ck_assert_uint_eq(b.len, 0);
    ck_assert_int_eq(b.err, PR_EINVAL);
    pr_buf_free(&b);
}
END_TEST

START_TEST(every_error_has_a_message)
{
    for (int code = 0; code >= PR_EJOB; code--)
        ck_assert_str_ne(pr_strerror(code), "unknown protocol error");
    ck_assert_str_eq(pr_strerror(-1000), "unknown protocol error");
}
END_TEST

static Suite *pr_header_suite(void)
{
    Suite *s = suite_create("pr_header");
    TCase *tc = tcase_create("header");
    tcase_add_test(tc, header_has_the_documented_byte_layout);
    tcase_add_test(tc, header_round_trips);
    tcase_add_test(tc, header_decode_rejects_bad_frames);
    suite_add_tcase(s, tc);
    tc = tcase_create("reader");
    tcase_add_test(tc, reader_never_reads_past_the_end);
    tcase_add_test(tc, count_is_checked_before_anything_is_allocated);
    tcase_add_test(tc, trailing_bytes_are_reported);
    tcase_add_test(tc, buffer_take_transfers_ownership);
    tcase_add_test(tc, arrays_are_little_endian_and_round_trip);
    tcase_add_test(tc, strings_are_utf8_without_controls);
    tcase_add_test(tc, every_error_has_a_message);
    suite_add_tcase(s, tc);
    return s;
}

UNIT_MAIN(pr_header_suite)
