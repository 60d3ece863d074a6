# tools/: set-up script, launch helpers, domain generators, benchmarks.
dist_noinst_SCRIPTS += tools/bootstrap
dist_noinst_SCRIPTS += tools/bench-delaunay
EXTRA_DIST += bench/kernel.md
