# Tests of libpdrproto.
check_PROGRAMS += tests/test_pr_header
TESTS += tests/test_pr_header
tests_test_pr_header_SOURCES = tests/test_pr_header.c
tests_test_pr_header_CFLAGS = $(UNIT_CFLAGS)
tests_test_pr_header_LDADD = libpdrproto.la $(UNIT_LIBS)
