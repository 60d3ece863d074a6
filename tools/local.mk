# tools/: set-up script, launch helpers, domain generators, benchmarks.
dist_noinst_SCRIPTS += tools/bootstrap

# libam's benchmark driver, run by tools/bench-runtime.
noinst_PROGRAMS += tools/am_bench
tools_am_bench_SOURCES = tools/am_bench.c
tools_am_bench_CFLAGS = $(AM_CFLAGS) $(ZMQ_CFLAGS)
tools_am_bench_LDADD = libam.la $(ZMQ_LIBS)
dist_noinst_SCRIPTS += tools/bench-runtime
# Send coalescing on and off (bench/runtime.md, "Send coalescing").
dist_noinst_SCRIPTS += tools/bench-coalesce
dist_noinst_SCRIPTS += tools/bench-delaunay
EXTRA_DIST += bench/README.md bench/kernel.md bench/runtime.md bench/proto.md
dist_noinst_SCRIPTS += tools/bench-mesh
EXTRA_DIST += bench/mesh.md
dist_noinst_SCRIPTS += tools/check-layers
dist_noinst_SCRIPTS += tools/bench-parallel
# Repeated parallel runs with faults (tests/stress-smoke.sh runs it small).
dist_noinst_SCRIPTS += tools/stress-parallel
EXTRA_DIST += bench/parallel.md
dist_noinst_SCRIPTS += tools/gen-surfaces tools/bench-surfaces tools/public-surfaces
EXTRA_DIST += bench/surfaces.md
# The paper's Table 1, Table 2 and figures (tests/tables.sh runs them small).
dist_noinst_SCRIPTS += tools/table1 tools/table2 tools/figures
dist_noinst_DATA += tools/tables-lib.sh
