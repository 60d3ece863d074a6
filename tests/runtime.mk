# Tests of libam.
check_PROGRAMS += tests/test_am_error
TESTS += tests/test_am_error
tests_test_am_error_SOURCES = tests/test_am_error.c
tests_test_am_error_CFLAGS = $(UNIT_CFLAGS)
tests_test_am_error_LDADD = libam.la $(UNIT_LIBS)
tests_test_am_error_LDFLAGS = $(AM_LDFLAGS) -static

# Multi-process driver run by the tests/am-*.sh scripts under am-run.
check_PROGRAMS += tests/am_mp
# A socket outside the job trying to get in (tests/am-zap.sh).
check_PROGRAMS += tests/zap_stranger
tests_zap_stranger_SOURCES = tests/zap_stranger.c
tests_zap_stranger_CFLAGS = $(AM_CFLAGS) $(ZMQ_CFLAGS)
tests_zap_stranger_LDADD = $(ZMQ_LIBS)
tests_am_mp_SOURCES = tests/am_mp.c
tests_am_mp_CFLAGS = $(AM_CFLAGS) $(ZMQ_CFLAGS)
tests_am_mp_LDADD = libam.la $(ZMQ_LIBS)

# Unit tests that reach into the runtime's internals (am_int.h) link libam
# statically: with -fvisibility=hidden only the static archive exposes them.
AM_UNIT_CFLAGS = $(UNIT_CFLAGS) $(ZMQ_CFLAGS) $(EVENT_CFLAGS)
AM_UNIT_LIBS = libam.la $(UNIT_LIBS) $(ZMQ_LIBS) $(EVENT_LIBS) -lm

check_PROGRAMS += tests/test_am_thread
TESTS += tests/test_am_thread
tests_test_am_thread_SOURCES = tests/test_am_thread.c
tests_test_am_thread_CFLAGS = $(AM_UNIT_CFLAGS)
tests_test_am_thread_LDADD = $(AM_UNIT_LIBS)
tests_test_am_thread_LDFLAGS = $(AM_LDFLAGS) -static

check_PROGRAMS += tests/test_am_control
TESTS += tests/test_am_control
tests_test_am_control_SOURCES = tests/test_am_control.c
tests_test_am_control_CFLAGS = $(AM_UNIT_CFLAGS)
tests_test_am_control_LDADD = $(AM_UNIT_LIBS)
tests_test_am_control_LDFLAGS = $(AM_LDFLAGS) -static

check_PROGRAMS += tests/test_am_latency
TESTS += tests/test_am_latency
tests_test_am_latency_SOURCES = tests/test_am_latency.c
tests_test_am_latency_CFLAGS = $(AM_UNIT_CFLAGS)
tests_test_am_latency_LDADD = $(AM_UNIT_LIBS)
tests_test_am_latency_LDFLAGS = $(AM_LDFLAGS) -static

check_PROGRAMS += tests/test_am_keys
TESTS += tests/test_am_keys
tests_test_am_keys_SOURCES = tests/test_am_keys.c
tests_test_am_keys_CFLAGS = $(AM_UNIT_CFLAGS)
tests_test_am_keys_LDADD = $(AM_UNIT_LIBS)
tests_test_am_keys_LDFLAGS = $(AM_LDFLAGS) -static

check_PROGRAMS += tests/test_am_stats
TESTS += tests/test_am_stats
tests_test_am_stats_SOURCES = tests/test_am_stats.c
tests_test_am_stats_CFLAGS = $(AM_UNIT_CFLAGS)
tests_test_am_stats_LDADD = $(AM_UNIT_LIBS)
tests_test_am_stats_LDFLAGS = $(AM_LDFLAGS) -static

check_PROGRAMS += tests/test_am_flow
TESTS += tests/test_am_flow
tests_test_am_flow_SOURCES = tests/test_am_flow.c
tests_test_am_flow_CFLAGS = $(AM_UNIT_CFLAGS)
tests_test_am_flow_LDADD = $(AM_UNIT_LIBS)
tests_test_am_flow_LDFLAGS = $(AM_LDFLAGS) -static

check_PROGRAMS += tests/test_am_lines
TESTS += tests/test_am_lines
tests_test_am_lines_SOURCES = tests/test_am_lines.c
tests_test_am_lines_CFLAGS = $(AM_UNIT_CFLAGS)
tests_test_am_lines_LDADD = $(AM_UNIT_LIBS)
tests_test_am_lines_LDFLAGS = $(AM_LDFLAGS) -static

# Multi-process tests: am_mp under am-run, on loopback only.
EXTRA_DIST += tests/am-lib.sh
AM_MP_TESTS = \
	tests/am-storm.sh \
	tests/am-term.sh \
	tests/am-rpc.sh \
	tests/am-counts.sh \
	tests/am-latency.sh \
	tests/am-kill.sh \
	tests/am-coll.sh \
	tests/am-malformed.sh \
	tests/am-launch.sh \
	tests/am-fault.sh \
	tests/am-signals.sh \
	tests/am-flood.sh \
	tests/am-zap.sh \
	tests/am-shm.sh \
	tests/am-fifo.sh
TESTS += $(AM_MP_TESTS)
dist_check_SCRIPTS += $(AM_MP_TESTS)
