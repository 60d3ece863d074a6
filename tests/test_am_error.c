/* Unit tests of libam's error table and version. */
#include "config.h"

#include "am.h"
#include "unit.h"

static const int all_codes[] = {
#define CODE(name, value, msg) AM_E##name,
    AM_ERRNO_MAP(CODE)
#undef CODE
};

START_TEST(every_code_has_a_distinct_message_and_name)
{
    size_t n = sizeof all_codes / sizeof all_codes[0];
    for (size_t i = 0; i < n; i++) {
        const char *m = am_strerror(all_codes[i]);
        ck_assert_ptr_nonnull(m);
        ck_assert_str_ne(m, am_strerror(12345));
        ck_assert_str_ne(am_errname(all_codes[i]), "AM_E?");
        for (size_t j = 0; j < i; j++) {
            ck_assert_int_ne(all_codes[i], all_codes[j]);
            ck_assert_str_ne(m, am_strerror(all_codes[j]));
        }
    }
}
END_TEST

START_TEST(codes_are_zero_or_negative)
{
    ck_assert_int_eq(AM_EOK, 0);
    for (size_t i = 1; i < sizeof all_codes / sizeof all_codes[0]; i++)
        ck_assert_int_lt(all_codes[i], 0);
    ck_assert_str_eq(am_errname(AM_EINVAL), "AM_EINVAL");
    ck_assert_str_eq(am_errname(-999), "AM_E?");
}
END_TEST

START_TEST(version_is_the_package_version)
{
    ck_assert_str_eq(am_version(), PACKAGE_VERSION);
}
END_TEST

static Suite *am_error_suite(void)
{
    Suite *s = suite_create("am_error");
    TCase *tc = tcase_create("errors");
    tcase_add_test(tc, every_code_has_a_distinct_message_and_name);
    tcase_add_test(tc, codes_are_zero_or_negative);
    tcase_add_test(tc, version_is_the_package_version);
    suite_add_tcase(s, tc);
    return s;
}

UNIT_MAIN(am_error_suite)
