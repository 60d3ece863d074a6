# proto/: libpdrproto, the wire formats (a convenience library linked into
# libam and the pdr program). No sockets, no mesh algorithms.
noinst_LTLIBRARIES += libpdrproto.la
noinst_HEADERS += proto/pr.h
EXTRA_DIST += proto/PROTOCOL.md

libpdrproto_la_SOURCES = \
	proto/pr_buf.c \
	proto/pr_header.c
