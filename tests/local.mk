# tests/: shared test infrastructure. Each library's tests are in
# tests/runtime.mk, tests/proto.mk and tests/mesher.mk.
noinst_HEADERS += tests/unit.h
UNIT_CFLAGS = $(AM_CFLAGS) $(CHECK_CFLAGS)
UNIT_LIBS = $(CHECK_LIBS)

TESTS += tests/pdr-cli.sh
dist_check_SCRIPTS += tests/pdr-cli.sh

# tools/table1, tools/table2 and tools/figures end to end at a tiny scale.
TESTS += tests/tables.sh
dist_check_SCRIPTS += tests/tables.sh

# tools/stress-parallel at a tiny scale: random runs, one PE killed.
TESTS += tests/stress-smoke.sh
dist_check_SCRIPTS += tests/stress-smoke.sh

# The include layering of mesher/ (tools/check-layers).
TESTS += tests/layering.sh
dist_check_SCRIPTS += tests/layering.sh

# The launchers for real (Open MPI's mpirun, ssh to an sshd the test starts,
# Slurm) and a job across two network namespaces over tcp with CURVE, each
# running pdr mesh --parallel. They skip where the launcher is missing or
# the test is not root. curve_keypair gives lan-netns.sh the job's keys.
check_PROGRAMS += tests/curve_keypair
tests_curve_keypair_SOURCES = tests/curve_keypair.c
tests_curve_keypair_CFLAGS = $(AM_CFLAGS) $(ZMQ_CFLAGS)
tests_curve_keypair_LDADD = $(ZMQ_LIBS)
EXTRA_DIST += tests/launch-lib.sh
LAUNCH_TESTS = \
	tests/launch-mpirun.sh \
	tests/launch-ssh.sh \
	tests/launch-slurm.sh \
	tests/lan-netns.sh
TESTS += $(LAUNCH_TESTS)
dist_check_SCRIPTS += $(LAUNCH_TESTS)

# 'make installcheck' (run by distcheck) compiles and runs a program against
# the installed libam using nothing but pkg-config.
EXTRA_DIST += tests/installcheck.c
installcheck-local:
	PKG_CONFIG_PATH='$(DESTDIR)$(pkgconfigdir)'$${PKG_CONFIG_PATH:+:$$PKG_CONFIG_PATH}; \
	export PKG_CONFIG_PATH; \
	flags=`$(PKG_CONFIG) --cflags --libs libam` || exit 1; \
	echo "pkg-config --cflags --libs libam: $$flags"; \
	$(CC) -o am-installcheck$(EXEEXT) $(srcdir)/tests/installcheck.c $$flags \
		-Wl,-rpath,'$(DESTDIR)$(libdir)' && ./am-installcheck$(EXEEXT); \
	rc=$$?; rm -f am-installcheck$(EXEEXT); exit $$rc

# Fuzz targets of the readers, libam's control frames and the command line
# (tests/fuzz/fuzz_<target>.c on tests/fuzz/fuzz_input.h). tools/fuzz
# builds and runs them with libFuzzer (also proto's, tests/proto.mk); here
# each is linked with a plain driver that replays its regression corpus
# tests/corpus/<dir>/ (hand-written seeds, plus what fuzzing found).
noinst_HEADERS += tests/fuzz/fuzz_input.h tests/fuzz/fuzz_plc.h tests/fuzz/fuzz_cav.h
EXTRA_DIST += tests/corpus/plc tests/corpus/runtime tests/corpus/cli tests/corpus/par
dist_noinst_SCRIPTS += tools/fuzz
FUZZ_REPLAY = \
	tests/fuzz/replay_poly \
	tests/fuzz/replay_smesh \
	tests/fuzz/replay_off \
	tests/fuzz/replay_stl \
	tests/fuzz/replay_ply \
	tests/fuzz/replay_obj \
	tests/fuzz/replay_medit \
	tests/fuzz/replay_node \
	tests/fuzz/replay_control \
	tests/fuzz/replay_bundle \
	tests/fuzz/replay_cli \
	tests/fuzz/replay_reply \
	tests/fuzz/replay_band \
	tests/fuzz/replay_merge
check_PROGRAMS += $(FUZZ_REPLAY)
TESTS += $(FUZZ_REPLAY)
FUZZ_MESH_CFLAGS = $(AM_CFLAGS) $(METIS_CFLAGS) $(ZMQ_CFLAGS) $(EVENT_CFLAGS)
FUZZ_MESH_LIBS = libpdrmesh.la libpdrproto.la -lm
tests_fuzz_replay_poly_SOURCES = tests/fuzz/fuzz_poly.c tests/fuzz/replay_input.c
tests_fuzz_replay_poly_LDADD = $(FUZZ_MESH_LIBS)
tests_fuzz_replay_smesh_SOURCES = tests/fuzz/fuzz_smesh.c tests/fuzz/replay_input.c
tests_fuzz_replay_smesh_LDADD = $(FUZZ_MESH_LIBS)
tests_fuzz_replay_off_SOURCES = tests/fuzz/fuzz_off.c tests/fuzz/replay_input.c
tests_fuzz_replay_off_LDADD = $(FUZZ_MESH_LIBS)
tests_fuzz_replay_stl_SOURCES = tests/fuzz/fuzz_stl.c tests/fuzz/replay_input.c
tests_fuzz_replay_stl_LDADD = $(FUZZ_MESH_LIBS)
tests_fuzz_replay_ply_SOURCES = tests/fuzz/fuzz_ply.c tests/fuzz/replay_input.c
tests_fuzz_replay_ply_LDADD = $(FUZZ_MESH_LIBS)
tests_fuzz_replay_obj_SOURCES = tests/fuzz/fuzz_obj.c tests/fuzz/replay_input.c
tests_fuzz_replay_obj_LDADD = $(FUZZ_MESH_LIBS)
tests_fuzz_replay_medit_SOURCES = tests/fuzz/fuzz_medit.c tests/fuzz/replay_input.c
tests_fuzz_replay_medit_LDADD = $(FUZZ_MESH_LIBS)
tests_fuzz_replay_node_SOURCES = tests/fuzz/fuzz_node.c tests/fuzz/replay_input.c
tests_fuzz_replay_node_LDADD = $(FUZZ_MESH_LIBS)
tests_fuzz_replay_control_SOURCES = tests/fuzz/fuzz_control.c tests/fuzz/replay_input.c
tests_fuzz_replay_control_LDADD = libam.la libpdrproto.la $(ZMQ_LIBS) $(EVENT_LIBS) -lm
tests_fuzz_replay_control_LDFLAGS = $(AM_LDFLAGS) -static
tests_fuzz_replay_bundle_SOURCES = tests/fuzz/fuzz_bundle.c tests/fuzz/replay_input.c
tests_fuzz_replay_bundle_LDADD = libam.la libpdrproto.la $(ZMQ_LIBS) $(EVENT_LIBS) -lm
tests_fuzz_replay_bundle_LDFLAGS = $(AM_LDFLAGS) -static
tests_fuzz_replay_cli_SOURCES = tests/fuzz/fuzz_cli.c tests/fuzz/replay_input.c \
	mesher/cli/cli_util.c mesher/cli/cmd_check.c mesher/cli/cmd_delaunay.c \
	mesher/cli/cmd_domain.c mesher/cli/cmd_mesh.c mesher/cli/mesh_par.c \
	mesher/cli/mesh_pipeline.c
tests_fuzz_replay_cli_CFLAGS = $(FUZZ_MESH_CFLAGS)
tests_fuzz_replay_cli_LDADD = libpdrmesh.la libam.la libpdrproto.la \
	$(METIS_LIBS) $(ZMQ_LIBS) $(EVENT_LIBS) -lm
tests_fuzz_replay_cli_LDFLAGS = $(AM_LDFLAGS) -static
tests_fuzz_replay_reply_SOURCES = tests/fuzz/fuzz_reply.c tests/fuzz/replay_input.c
tests_fuzz_replay_reply_CFLAGS = $(FUZZ_MESH_CFLAGS)
tests_fuzz_replay_reply_LDADD = libpdrmesh.la libam.la libpdrproto.la \
	$(METIS_LIBS) $(ZMQ_LIBS) $(EVENT_LIBS) -lm
tests_fuzz_replay_reply_LDFLAGS = $(AM_LDFLAGS) -static
tests_fuzz_replay_band_SOURCES = tests/fuzz/fuzz_band.c tests/fuzz/replay_input.c
tests_fuzz_replay_band_CFLAGS = $(FUZZ_MESH_CFLAGS)
tests_fuzz_replay_band_LDADD = libpdrmesh.la libam.la libpdrproto.la \
	$(METIS_LIBS) $(ZMQ_LIBS) $(EVENT_LIBS) -lm
tests_fuzz_replay_band_LDFLAGS = $(AM_LDFLAGS) -static
tests_fuzz_replay_merge_SOURCES = tests/fuzz/fuzz_merge.c tests/fuzz/replay_input.c
tests_fuzz_replay_merge_CFLAGS = $(FUZZ_MESH_CFLAGS)
tests_fuzz_replay_merge_LDADD = libpdrmesh.la libam.la libpdrproto.la \
	$(METIS_LIBS) $(ZMQ_LIBS) $(EVENT_LIBS) -lm
tests_fuzz_replay_merge_LDFLAGS = $(AM_LDFLAGS) -static

# Absurd counts in headers are refused before anything is allocated for
# them (run under a small ulimit -v).
TESTS += tests/huge-counts.sh
dist_check_SCRIPTS += tests/huge-counts.sh
