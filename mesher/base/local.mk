# mesher/base: errors, small utilities, number formatting, text input,
# atomic output, the 3-vector helpers, the hash map and the search for
# repeated hashes, the fork-join of the output stages. Uses nothing else.
noinst_HEADERS += \
	mesher/base/fj.h \
	mesher/base/hdup.h \
	mesher/base/hmap.h \
	mesher/base/nf.h \
	mesher/base/outfile.h \
	mesher/base/pdr_error.h \
	mesher/base/pdr_util.h \
	mesher/base/textin.h \
	mesher/base/v3.h
libpdrmesh_la_SOURCES += \
	mesher/base/fj.c \
	mesher/base/hdup.c \
	mesher/base/hmap.c \
	mesher/base/nf.c \
	mesher/base/outfile.c \
	mesher/base/pdr_error.c \
	mesher/base/pdr_util.c \
	mesher/base/textin.c
