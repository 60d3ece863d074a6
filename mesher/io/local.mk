# mesher/io: mesh files (TetGen .node/.ele/.face, VTK .vtu, Gmsh .msh).
# Uses base, geom, mesh, plc and check (the .vtu carries quality fields).
noinst_HEADERS += \
	mesher/io/face.h \
	mesher/io/msh.h \
	mesher/io/tg.h \
	mesher/io/vtu.h
libpdrmesh_la_SOURCES += \
	mesher/io/face.c \
	mesher/io/msh.c \
	mesher/io/tg.c \
	mesher/io/vtu.c
