# Tests of libpdrmesh and the pdr program.
check_PROGRAMS += tests/test_pdr_error
TESTS += tests/test_pdr_error
tests_test_pdr_error_SOURCES = tests/test_pdr_error.c
tests_test_pdr_error_CFLAGS = $(UNIT_CFLAGS)
tests_test_pdr_error_LDADD = libpdrmesh.la libpdrproto.la $(UNIT_LIBS)

check_PROGRAMS += tests/test_textin
TESTS += tests/test_textin
tests_test_textin_SOURCES = tests/test_textin.c
tests_test_textin_CFLAGS = $(UNIT_CFLAGS)
tests_test_textin_LDADD = libpdrmesh.la libpdrproto.la $(UNIT_LIBS)

check_PROGRAMS += tests/test_pred
TESTS += tests/test_pred
tests_test_pred_SOURCES = tests/test_pred.c
tests_test_pred_CFLAGS = $(UNIT_CFLAGS)
tests_test_pred_LDADD = libpdrmesh.la libpdrproto.la $(UNIT_LIBS) $(GMP_LIBS) -lm

# PLC input, validation, domains, quality and output formats (meshio).
check_PROGRAMS += tests/plc_tool
tests_plc_tool_SOURCES = tests/plc_tool.c
tests_plc_tool_LDADD = libpdrmesh.la libpdrproto.la -lm
check_PROGRAMS += tests/mesh_out_tool
tests_mesh_out_tool_SOURCES = tests/mesh_out_tool.c
tests_mesh_out_tool_LDADD = libpdrmesh.la libpdrproto.la -lm

check_PROGRAMS += tests/test_plc tests/test_quality
TESTS += tests/test_plc tests/test_quality
tests_test_plc_SOURCES = tests/test_plc.c
tests_test_plc_CFLAGS = $(UNIT_CFLAGS)
tests_test_plc_LDADD = libpdrmesh.la libpdrproto.la $(UNIT_LIBS) -lm
tests_test_quality_SOURCES = tests/test_quality.c
tests_test_quality_CFLAGS = $(UNIT_CFLAGS)
tests_test_quality_LDADD = libpdrmesh.la libpdrproto.la $(UNIT_LIBS) -lm

# The stages of pdr mesh used one by one (cli/mesh_pipeline.c is part of
# the pdr program, not of the library, so the test compiles it in).
check_PROGRAMS += tests/test_mesh_pipeline
TESTS += tests/test_mesh_pipeline
tests_test_mesh_pipeline_SOURCES = tests/test_mesh_pipeline.c mesher/cli/mesh_pipeline.c \
	mesher/cli/cli_util.c
tests_test_mesh_pipeline_CFLAGS = $(UNIT_CFLAGS)
tests_test_mesh_pipeline_LDADD = libpdrmesh.la libpdrproto.la $(UNIT_LIBS) -lm

MESHIO_TESTS = tests/plc-errors.sh tests/plc-example.sh tests/domain-cli.sh \
	tests/domain-tetgen.sh tests/output-meshio.sh tests/output-plot.sh
TESTS += $(MESHIO_TESTS)
dist_check_SCRIPTS += $(MESHIO_TESTS)
EXTRA_DIST += \
	tests/data/plc/bad-number.poly \
	tests/data/plc/colour.off \
	tests/data/plc/four-d.off \
	tests/data/plc/welded.off \
	tests/data/plc/welded-open.off \
	tests/data/plc/crossing-segments.poly \
	tests/data/plc/cube.smesh \
	tests/data/plc/duplicate-vertex.poly \
	tests/data/plc/gap-numbering.poly \
	tests/data/plc/index-out-of-range.poly \
	tests/data/plc/intersecting.poly \
	tests/data/plc/missing-node.poly \
	tests/data/plc/no-endloop.stl \
	tests/data/plc/non-planar.poly \
	tests/data/plc/open-box.poly \
	tests/data/plc/open.off \
	tests/data/plc/repeated-corner.poly \
	tests/data/plc/t-junction.poly \
	tests/data/plc/tet.off \
	tests/data/plc/tet.stl \
	tests/data/plc/truncated.poly \
	tests/data/plc/unknown.xyz \
	tests/data/plc/zero-area.poly \
	tests/data/surf/bracket-0.2.off \
	tests/data/surf/boxcylsph-0.2.off \
	tests/data/surf/cone-0.2.off \
	tests/data/surf/fancone-64.off \
	tests/data/surf/fillet-0.2.off \
	tests/data/surf/frame.off \
	tests/data/surf/gridcube.off \
	tests/data/surf/gridtorus.off \
	tests/data/surf/needle.off \
	tests/data/surf/octa-6.off \
	tests/data/surf/quadtorus.off \
	tests/data/surf/sphere-0.2.off \
	tests/data/surf/strips-48.off \
	tests/data/surf/torus-0.3.off \
	tests/data/surf/tube-0.2.off \
	tests/data/surf/uvsphere.off

check_PROGRAMS += tests/test_delaunay
TESTS += tests/test_delaunay
tests_test_delaunay_SOURCES = tests/test_delaunay.c
tests_test_delaunay_CFLAGS = $(UNIT_CFLAGS)
tests_test_delaunay_LDADD = libpdrmesh.la libpdrproto.la $(UNIT_LIBS) -lm

TESTS += tests/delaunay-cli.sh tests/delaunay-errors.sh
dist_check_SCRIPTS += tests/delaunay-cli.sh tests/delaunay-errors.sh

# Memory failure: pdr mesh, pdr delaunay and pdr check with their N-th
# allocation failing, for every N (PDR_ALLOC_FAIL, proto/pr_alloc.h).
TESTS += tests/alloc-fail.sh
dist_check_SCRIPTS += tests/alloc-fail.sh

# The quality mesher (refine branch).
check_PROGRAMS += tests/test_refine
TESTS += tests/test_refine
tests_test_refine_SOURCES = tests/test_refine.c
tests_test_refine_CFLAGS = $(UNIT_CFLAGS)
tests_test_refine_LDADD = libpdrmesh.la libpdrproto.la $(UNIT_LIBS) -lm
REFINE_TESTS = tests/mesh-models.sh tests/mesh-example.sh tests/mesh-errors.sh \
	tests/mesh-output.sh tests/mesh-threads.sh tests/mesh-surfaces.sh tests/check-damaged.sh \
	tests/check-bent-area.sh tests/mesh-tessellated.sh tests/mesh-strips.sh \
	tests/mesh-cad.sh tests/mesh-cad-public.sh tests/mesh-cad-cascade.sh tests/mesh-cad-size.sh \
	tests/mesh-cad-quality.sh tests/mesh-cad-pinion.sh tests/mesh-formats.sh \
	tests/mesh-cad-leftover.sh tests/mesh-cad-bent.sh tests/mesh-cad-offcentre.sh \
	tests/mesh-cad-flat.sh
TESTS += $(REFINE_TESTS)
dist_check_SCRIPTS += $(REFINE_TESTS)
EXTRA_DIST += tests/cad-lib.sh

# The parallel mesher's data path without the network: decomposition,
# submesh messages, merge.
check_PROGRAMS += tests/test_par
TESTS += tests/test_par
tests_test_par_SOURCES = tests/test_par.c
tests_test_par_CFLAGS = $(UNIT_CFLAGS) $(METIS_CFLAGS)
tests_test_par_LDADD = libpdrmesh.la libam.la libpdrproto.la $(METIS_LIBS) $(ZMQ_LIBS) \
	$(EVENT_LIBS) $(UNIT_LIBS) -lm

# The parallel refinement end to end on local PEs (pdr mesh -n P).
TESTS += tests/mesh-parallel.sh tests/mesh-cad-parallel.sh tests/mesh-parallel-stall.sh \
	tests/mesh-parallel-band.sh tests/mesh-parallel-cad.sh
dist_check_SCRIPTS += tests/mesh-parallel.sh tests/mesh-cad-parallel.sh \
	tests/mesh-parallel-stall.sh tests/mesh-parallel-band.sh tests/mesh-parallel-cad.sh
