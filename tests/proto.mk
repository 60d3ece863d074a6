# Tests of libpdrproto.
check_PROGRAMS += tests/test_pr_header
TESTS += tests/test_pr_header
tests_test_pr_header_SOURCES = tests/test_pr_header.c
tests_test_pr_header_CFLAGS = $(UNIT_CFLAGS)
tests_test_pr_header_LDADD = libpdrproto.la $(UNIT_LIBS)

# Sample messages shared by the tests, the fuzz targets and the benchmark.
noinst_HEADERS += tests/pr_sample.h
PR_SAMPLE_SOURCES = tests/pr_sample.c tests/pr_sample.h

# The allocation hook (proto/pr_alloc.h): counting, fail-after-N, another
# allocator, and proto's decoders failing cleanly at every allocation.
check_PROGRAMS += tests/test_pr_alloc
TESTS += tests/test_pr_alloc
tests_test_pr_alloc_SOURCES = tests/test_pr_alloc.c $(PR_SAMPLE_SOURCES)
tests_test_pr_alloc_CFLAGS = $(UNIT_CFLAGS)
tests_test_pr_alloc_LDADD = libpdrproto.la $(UNIT_LIBS)

check_PROGRAMS += tests/test_pr_messages
TESTS += tests/test_pr_messages
tests_test_pr_messages_SOURCES = tests/test_pr_messages.c $(PR_SAMPLE_SOURCES)
tests_test_pr_messages_CFLAGS = $(UNIT_CFLAGS)
tests_test_pr_messages_LDADD = libpdrproto.la $(UNIT_LIBS)

check_PROGRAMS += tests/test_pr_props
TESTS += tests/test_pr_props
tests_test_pr_props_SOURCES = tests/test_pr_props.c $(PR_SAMPLE_SOURCES)
tests_test_pr_props_CFLAGS = $(UNIT_CFLAGS)
tests_test_pr_props_LDADD = libpdrproto.la $(UNIT_LIBS)

# Golden files: one annotated hex dump per message type. The comparison
# never rewrites them; 'tests/test_pr_golden --regenerate tests/golden/proto'
# does, deliberately, after a layout change (see proto/PROTOCOL.md).
PR_GOLDEN_FILES = \
	tests/golden/proto/header.exp \
	tests/golden/proto/hello.exp \
	tests/golden/proto/stats.exp \
	tests/golden/proto/submesh.exp \
	tests/golden/proto/vertex.exp \
	tests/golden/proto/tet.exp \
	tests/golden/proto/face_keys.exp
EXTRA_DIST += $(PR_GOLDEN_FILES)
check_PROGRAMS += tests/test_pr_golden
TESTS += tests/test_pr_golden
tests_test_pr_golden_SOURCES = tests/test_pr_golden.c $(PR_SAMPLE_SOURCES)
tests_test_pr_golden_LDADD = libpdrproto.la
CLEANFILES += pr_golden_*.out

# The same golden comparison with proto compiled to assemble every value
# byte by byte (as on a big-endian host) instead of using memcpy: both
# paths must write the same bytes.
check_PROGRAMS += tests/test_pr_golden_portable
TESTS += tests/test_pr_golden_portable
tests_test_pr_golden_portable_SOURCES = tests/test_pr_golden.c \
	$(PR_SAMPLE_SOURCES) $(libpdrproto_la_SOURCES)
tests_test_pr_golden_portable_CPPFLAGS = $(AM_CPPFLAGS) -DPR_PORTABLE

# Fuzz targets (tests/fuzz/fuzz_<decoder>.c, one per decoder). libFuzzer
# builds and runs them through tools/fuzz-proto; here each is linked with a
# plain driver that replays its regression corpus tests/corpus/proto/<decoder>/
# (seeds from 'tests/test_pr_golden --write-corpus', plus what fuzzing found).
noinst_HEADERS += tests/fuzz/fuzz.h
EXTRA_DIST += tests/corpus/proto
dist_noinst_SCRIPTS += tools/fuzz-proto
PR_REPLAY_SOURCES = tests/fuzz/replay_input.c tests/fuzz/fuzz.h tests/fuzz/fuzz_input.h \
	$(PR_SAMPLE_SOURCES)
PR_REPLAY = \
	tests/fuzz/replay_header \
	tests/fuzz/replay_hello \
	tests/fuzz/replay_stats \
	tests/fuzz/replay_submesh \
	tests/fuzz/replay_vertex \
	tests/fuzz/replay_tet \
	tests/fuzz/replay_face_keys
check_PROGRAMS += $(PR_REPLAY)
TESTS += $(PR_REPLAY)
tests_fuzz_replay_header_SOURCES = tests/fuzz/fuzz_header.c $(PR_REPLAY_SOURCES)
tests_fuzz_replay_header_LDADD = libpdrproto.la
tests_fuzz_replay_hello_SOURCES = tests/fuzz/fuzz_hello.c $(PR_REPLAY_SOURCES)
tests_fuzz_replay_hello_LDADD = libpdrproto.la
tests_fuzz_replay_stats_SOURCES = tests/fuzz/fuzz_stats.c $(PR_REPLAY_SOURCES)
tests_fuzz_replay_stats_LDADD = libpdrproto.la
tests_fuzz_replay_submesh_SOURCES = tests/fuzz/fuzz_submesh.c $(PR_REPLAY_SOURCES)
tests_fuzz_replay_submesh_LDADD = libpdrproto.la
tests_fuzz_replay_vertex_SOURCES = tests/fuzz/fuzz_vertex.c $(PR_REPLAY_SOURCES)
tests_fuzz_replay_vertex_LDADD = libpdrproto.la
tests_fuzz_replay_tet_SOURCES = tests/fuzz/fuzz_tet.c $(PR_REPLAY_SOURCES)
tests_fuzz_replay_tet_LDADD = libpdrproto.la
tests_fuzz_replay_face_keys_SOURCES = tests/fuzz/fuzz_face_keys.c $(PR_REPLAY_SOURCES)
tests_fuzz_replay_face_keys_LDADD = libpdrproto.la

# Benchmark of the submesh codec against memcpy: tools/bench-proto builds
# and runs tools/bench_proto (results in bench/proto.md).
noinst_PROGRAMS += tools/bench_proto
tools_bench_proto_SOURCES = tools/bench_proto.c $(PR_SAMPLE_SOURCES)
tools_bench_proto_LDADD = libpdrmesh.la libpdrproto.la $(METIS_LIBS) -lm
dist_noinst_SCRIPTS += tools/bench-proto

# The refusal and property tests again, with proto built with PR_PORTABLE
# (byte-by-byte order, scalar table checks), so the plain C twins of the
# fast paths are held to the same results.
check_PROGRAMS += tests/test_pr_messages_portable tests/test_pr_props_portable
TESTS += tests/test_pr_messages_portable tests/test_pr_props_portable
tests_test_pr_messages_portable_SOURCES = tests/test_pr_messages.c \
	$(PR_SAMPLE_SOURCES) $(libpdrproto_la_SOURCES)
tests_test_pr_messages_portable_CPPFLAGS = $(AM_CPPFLAGS) -DPR_PORTABLE
tests_test_pr_messages_portable_CFLAGS = $(UNIT_CFLAGS)
tests_test_pr_messages_portable_LDADD = $(UNIT_LIBS)
tests_test_pr_props_portable_SOURCES = tests/test_pr_props.c \
	$(PR_SAMPLE_SOURCES) $(libpdrproto_la_SOURCES)
tests_test_pr_props_portable_CPPFLAGS = $(AM_CPPFLAGS) -DPR_PORTABLE
tests_test_pr_props_portable_CFLAGS = $(UNIT_CFLAGS)
tests_test_pr_props_portable_LDADD = $(UNIT_LIBS)
