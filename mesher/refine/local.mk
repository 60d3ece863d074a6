# mesher/refine: boundary tables, the initial mesh Mo and the sequential
# Delaunay refinement. Uses base, geom, mesh and plc.
noinst_HEADERS += \
	mesher/refine/bd.h \
	mesher/refine/im.h \
	mesher/refine/refine.h \
	mesher/refine/refine_int.h
libpdrmesh_la_SOURCES += \
	mesher/refine/bd.c \
	mesher/refine/im.c \
	mesher/refine/refine.c \
	mesher/refine/refine_bound.c \
	mesher/refine/refine_cdt.c \
	mesher/refine/refine_classify.c \
	mesher/refine/refine_decide.c \
	mesher/refine/refine_facrec.c \
	mesher/refine/refine_offc.c \
	mesher/refine/refine_run.c \
	mesher/refine/refine_segrec.c
EXTRA_DIST += mesher/refine/RECOVERY.md mesher/refine/QUALITY.md
