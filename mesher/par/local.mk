# mesher/par: the parallel refinement (DESIGN section 5). Uses every layer
# up to refine, and the runtime (libam) and proto.
noinst_HEADERS += \
	mesher/par/par_band.h \
	mesher/par/par_cav.h \
	mesher/par/par_decomp.h \
	mesher/par/par_merge.h \
	mesher/par/par_run.h \
	mesher/par/par_sub.h \
	mesher/par/par_verify.h \
	mesher/par/par_wire.h
libpdrmesh_la_SOURCES += \
	mesher/par/par_band.c \
	mesher/par/par_cav.c \
	mesher/par/par_decomp.c \
	mesher/par/par_merge.c \
	mesher/par/par_run.c \
	mesher/par/par_sub.c \
	mesher/par/par_verify.c \
	mesher/par/par_wire.c
