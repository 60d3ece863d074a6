# mesher/check: mesh quality measures and the checks of a mesh against its
# domain. Uses base, geom, mesh and plc.
noinst_HEADERS += \
	mesher/check/mc.h \
	mesher/check/ql.h
libpdrmesh_la_SOURCES += \
	mesher/check/mc.c \
	mesher/check/ql.c
