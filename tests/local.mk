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
