# Tests of libam.
check_PROGRAMS += tests/test_am_error
TESTS += tests/test_am_error
tests_test_am_error_SOURCES = tests/test_am_error.c
tests_test_am_error_CFLAGS = $(UNIT_CFLAGS)
tests_test_am_error_LDADD = libam.la $(UNIT_LIBS)
tests_test_am_error_LDFLAGS = $(AM_LDFLAGS) -static

# Multi-process driver run by the tests/am-*.sh scripts under am-run.
check_PROGRAMS += tests/am_mp
tests_am_mp_SOURCES = tests/am_mp.c
tests_am_mp_CFLAGS = $(AM_CFLAGS) $(ZMQ_CFLAGS)
tests_am_mp_LDADD = libam.la $(ZMQ_LIBS)
