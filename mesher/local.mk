# mesher/: libpdrmesh (geometry, meshes, refinement; a convenience library)
# and the pdr program.
noinst_LTLIBRARIES += libpdrmesh.la
noinst_HEADERS += \
	mesher/pdr_error.h \
	mesher/pdr_cli.h \
	mesher/pdr_util.h \
	mesher/vec3.h \
	mesher/textin.h \
	mesher/outfile.h
# PLC input, validation and output formats (issue 4, meshio branch).
noinst_HEADERS += \
	mesher/plc.h \
	mesher/plc_internal.h \
	mesher/plc_tri.h \
	mesher/domain.h \
	mesher/mesh_export.h \
	mesher/quality.h \
	mesher/io_vtu.h \
	mesher/io_msh.h \
	mesher/io_face.h

libpdrmesh_la_SOURCES = \
	mesher/pdr_error.c \
	mesher/pdr_util.c \
	mesher/textin.c \
	mesher/outfile.c
libpdrmesh_la_SOURCES += \
	mesher/plc.c \
	mesher/plc_read.c \
	mesher/plc_tri.c \
	mesher/plc_check.c \
	mesher/domain.c \
	mesher/quality.c \
	mesher/io_vtu.c \
	mesher/io_msh.c \
	mesher/io_face.c
libpdrmesh_la_CFLAGS = $(AM_CFLAGS) $(METIS_CFLAGS)
libpdrmesh_la_LIBADD = $(METIS_LIBS) -lm

bin_PROGRAMS += pdr
pdr_SOURCES = \
	mesher/pdr.c \
	mesher/cmd_info.c \
	mesher/cmd_run.c
pdr_SOURCES += mesher/cmd_domain.c
pdr_CFLAGS = $(AM_CFLAGS) $(METIS_CFLAGS) $(ZMQ_CFLAGS) $(EVENT_CFLAGS)
pdr_LDADD = libpdrmesh.la libam.la libpdrproto.la $(METIS_LIBS) $(ZMQ_LIBS) \
	$(EVENT_LIBS) -lm
pdr_LDFLAGS = $(AM_LDFLAGS) -static

# The Delaunay kernel: exact predicates.
noinst_HEADERS += mesher/pred.h mesher/tetmesh.h mesher/delaunay.h \
	mesher/spatial_sort.h mesher/verify.h mesher/io_tetgen.h
libpdrmesh_la_SOURCES += mesher/pred.c mesher/tetmesh.c mesher/delaunay.c \
	mesher/spatial_sort.c mesher/verify.c mesher/io_tetgen.c
pdr_SOURCES += mesher/cmd_delaunay.c mesher/cmd_check.c

# Quality refinement: boundary bookkeeping, the refinement engine, the
# initial mesh, 'pdr mesh' (issue 4, refine branch).
noinst_HEADERS += mesher/bnd.h mesher/refine.h mesher/initmesh.h mesher/meshcheck.h \
	mesher/numfmt.h
libpdrmesh_la_SOURCES += mesher/bnd.c mesher/refine.c mesher/initmesh.c mesher/meshcheck.c \
	mesher/numfmt.c
pdr_SOURCES += mesher/cmd_mesh.c
