# Tests of libpdrmesh and the pdr program.
check_PROGRAMS += tests/test_pdr_error
TESTS += tests/test_pdr_error
tests_test_pdr_error_SOURCES = tests/test_pdr_error.c
tests_test_pdr_error_CFLAGS = $(UNIT_CFLAGS)
tests_test_pdr_error_LDADD = libpdrmesh.la $(UNIT_LIBS)

check_PROGRAMS += tests/test_textin
TESTS += tests/test_textin
tests_test_textin_SOURCES = tests/test_textin.c
tests_test_textin_CFLAGS = $(UNIT_CFLAGS)
tests_test_textin_LDADD = libpdrmesh.la $(UNIT_LIBS)

check_PROGRAMS += tests/test_pred
TESTS += tests/test_pred
tests_test_pred_SOURCES = tests/test_pred.c
tests_test_pred_CFLAGS = $(UNIT_CFLAGS)
tests_test_pred_LDADD = libpdrmesh.la $(UNIT_LIBS) $(GMP_LIBS) -lm

check_PROGRAMS += tests/test_delaunay
TESTS += tests/test_delaunay
tests_test_delaunay_SOURCES = tests/test_delaunay.c
tests_test_delaunay_CFLAGS = $(UNIT_CFLAGS)
tests_test_delaunay_LDADD = libpdrmesh.la $(UNIT_LIBS) -lm

TESTS += tests/delaunay-cli.sh tests/delaunay-errors.sh
dist_check_SCRIPTS += tests/delaunay-cli.sh tests/delaunay-errors.sh
