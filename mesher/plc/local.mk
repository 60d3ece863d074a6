# mesher/plc: PLC input, validation, facet triangulation and the built-in
# domains. Uses base, geom and mesh.
noinst_HEADERS += \
	mesher/plc/dom.h \
	mesher/plc/fm.h \
	mesher/plc/plc.h \
	mesher/plc/plc_int.h \
	mesher/plc/plc_tri.h \
	mesher/plc/plc_split.h
libpdrmesh_la_SOURCES += \
	mesher/plc/dom.c \
	mesher/plc/fm.c \
	mesher/plc/plc.c \
	mesher/plc/plc_check.c \
	mesher/plc/plc_read.c \
	mesher/plc/plc_surf.c \
	mesher/plc/plc_ply.c \
	mesher/plc/plc_obj.c \
	mesher/plc/plc_medit.c \
	mesher/plc/plc_tri.c \
	mesher/plc/plc_split.c
