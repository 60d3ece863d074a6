# mesher/: libpdrmesh (geometry, meshes, refinement; a convenience library)
# and the pdr program, in layers. Each layer's fragment adds its sources;
# mesher/README.md says what each layer holds and which layers it may use,
# and tests/layering.sh enforces that in 'make check'.
noinst_LTLIBRARIES += libpdrmesh.la
libpdrmesh_la_SOURCES =
libpdrmesh_la_CFLAGS = $(AM_CFLAGS) $(METIS_CFLAGS)
libpdrmesh_la_LIBADD = $(METIS_LIBS) -lm

bin_PROGRAMS += pdr
pdr_SOURCES =
pdr_CFLAGS = $(AM_CFLAGS) $(METIS_CFLAGS) $(ZMQ_CFLAGS) $(EVENT_CFLAGS)
pdr_LDADD = libpdrmesh.la libam.la libpdrproto.la $(METIS_LIBS) $(ZMQ_LIBS) \
	$(EVENT_LIBS) -lm
pdr_LDFLAGS = $(AM_LDFLAGS) -static

EXTRA_DIST += mesher/README.md

include mesher/base/local.mk
include mesher/geom/local.mk
include mesher/mesh/local.mk
include mesher/plc/local.mk
include mesher/refine/local.mk
include mesher/par/local.mk
include mesher/check/local.mk
include mesher/io/local.mk
include mesher/cli/local.mk
