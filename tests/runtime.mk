# Tests of libam.
check_PROGRAMS += tests/test_am_error
TESTS += tests/test_am_error
tests_test_am_error_SOURCES = tests/test_am_error.c
tests_test_am_error_CFLAGS = $(UNIT_CFLAGS)
tests_test_am_error_LDADD = libam.la $(UNIT_LIBS)
tests_test_am_error_LDFLAGS = $(AM_LDFLAGS) -static
