# runtime/: libam, the active-message runtime (installed, with am.h and
# libam.pc). Only symbols marked AM_EXPORT are visible outside the library.
lib_LTLIBRARIES += libam.la
include_HEADERS += runtime/am.h
pkgconfig_DATA += runtime/libam.pc
EXTRA_DIST += runtime/libam.pc.in

libam_la_SOURCES = \
	runtime/am_error.c
libam_la_CPPFLAGS = $(AM_CPPFLAGS) -DAM_BUILDING
libam_la_CFLAGS = $(AM_CFLAGS) $(ZMQ_CFLAGS) $(EVENT_CFLAGS)
libam_la_LIBADD = libpdrproto.la $(ZMQ_LIBS) $(EVENT_LIBS)
libam_la_LDFLAGS = $(AM_LDFLAGS) -version-info $(LIBAM_LT_VERSION) -no-undefined
