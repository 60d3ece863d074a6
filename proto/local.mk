# proto/: libpdrproto, the wire formats (a convenience library linked into
# libam and the pdr program). No sockets, no mesh algorithms.
noinst_LTLIBRARIES += libpdrproto.la
noinst_HEADERS += proto/pr.h proto/pr_int.h proto/pr_alloc.h
EXTRA_DIST += proto/PROTOCOL.md

libpdrproto_la_SOURCES = \
	proto/pr_alloc.c \
	proto/pr_buf.c \
	proto/pr_header.c \
	proto/pr_msg.c \
	proto/pr_entity.c \
	proto/pr_submesh.c \
	proto/pr_stats.c
