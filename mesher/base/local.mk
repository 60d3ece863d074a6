# mesher/base: errors, small utilities, number formatting, text input,
# atomic output, the 3-vector helpers and the hash map. Uses nothing else.
noinst_HEADERS += \
	mesher/base/hmap.h \
	mesher/base/nf.h \
	mesher/base/outfile.h \
	mesher/base/pdr_error.h \
	mesher/base/pdr_util.h \
	mesher/base/textin.h \
	mesher/base/v3.h
libpdrmesh_la_SOURCES += \
	mesher/base/hmap.c \
	mesher/base/nf.c \
	mesher/base/outfile.c \
	mesher/base/pdr_error.c \
	mesher/base/pdr_util.c \
	mesher/base/textin.c
