# runtime/: libam, the active-message runtime (installed, with am.h and
# libam.pc), and am-run, its launcher. Only symbols marked AM_EXPORT are
# visible outside the library.
lib_LTLIBRARIES += libam.la
include_HEADERS += runtime/am.h
noinst_HEADERS += runtime/am_int.h runtime/am_control.h
pkgconfig_DATA += runtime/libam.pc
EXTRA_DIST += runtime/libam.pc.in runtime/CONTROL.md

libam_la_SOURCES = \
	runtime/am_error.c \
	runtime/am_ctx.c \
	runtime/am_boot.c \
	runtime/am_transport.c \
	runtime/am_flow.c \
	runtime/am_loop.c \
	runtime/am_thread.c \
	runtime/am_future.c \
	runtime/am_timer.c \
	runtime/am_term.c \
	runtime/am_coll.c \
	runtime/am_rpc.c \
	runtime/am_stats.c \
	runtime/am_latency.c \
	runtime/am_control.c \
	runtime/am_launch.c \
	runtime/am_keys.c \
	runtime/am_zap.c \
	runtime/am_shm.c
if LIBAM_FAST_SWITCH
libam_la_SOURCES += runtime/am_switch_x86_64.S
endif
EXTRA_DIST += runtime/am_switch_x86_64.S
libam_la_CPPFLAGS = $(AM_CPPFLAGS) -DAM_BUILDING
libam_la_CFLAGS = $(AM_CFLAGS) $(ZMQ_CFLAGS) $(EVENT_CFLAGS) -pthread
libam_la_LIBADD = libpdrproto.la $(ZMQ_LIBS) $(EVENT_LIBS) -lm
libam_la_LDFLAGS = $(AM_LDFLAGS) -version-info $(LIBAM_LT_VERSION) -no-undefined \
	-pthread

bin_PROGRAMS += am-run
am_run_SOURCES = runtime/am_run.c
am_run_LDADD = libam.la
