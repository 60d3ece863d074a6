# mesher/geom: exact predicates and the spatial sort. Uses base.
noinst_HEADERS += \
	mesher/geom/pred.h \
	mesher/geom/ss.h
libpdrmesh_la_SOURCES += \
	mesher/geom/pred.c \
	mesher/geom/ss.c
