/*
 * unit.h -- shared main() for the Check-based unit tests.
 *
 * Every unit-test program builds one Suite and ends with UNIT_MAIN(suite).
 * Under 'make check' the program prints TAP, which automake's tap-driver
 * turns into one result per test function. Run by hand:
 *     tests/test_foo -v            verbose Check output instead of TAP
 *     tests/test_foo -t CASE       only the test case named CASE
 * Check forks each test into its own process with a timeout (see
 * tcase_set_timeout), so a crash or a hang fails one test, not the run.
 */
#ifndef PDR_TESTS_UNIT_H
#define PDR_TESTS_UNIT_H

#include <check.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static inline int unit_main(Suite *suite, int argc, char **argv)
{
    int verbose = 0;
    const char *only = NULL;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "-v"))
            verbose = 1;
        else if (!strcmp(argv[i], "-t") && i + 1 < argc)
            only = argv[++i];
        else {
            fprintf(stderr, "usage: %s [-v] [-t CASE]\n", argv[0]);
            return 99; /* automake: hard error of the harness */
        }
    }
    SRunner *sr = srunner_create(suite);
    if (!verbose)
        srunner_set_tap(sr, "-");
    srunner_run(sr, NULL, only, verbose ? CK_VERBOSE : CK_SILENT);
    int failed = srunner_ntests_failed(sr);
    srunner_free(sr);
    return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}

#define UNIT_MAIN(make_suite)                                                \
    int main(int argc, char **argv)                                          \
    {                                                                        \
        return unit_main(make_suite(), argc, argv);                          \
    }

#endif /* PDR_TESTS_UNIT_H */
