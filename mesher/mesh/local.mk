# mesher/mesh: the tetrahedral mesh, the Delaunay kernel, mesh
# verification and the exported-mesh view. Uses base and geom.
noinst_HEADERS += \
	mesher/mesh/dt.h \
	mesher/mesh/flip.h \
	mesher/mesh/mesh_export.h \
	mesher/mesh/tm.h \
	mesher/mesh/vf.h
libpdrmesh_la_SOURCES += \
	mesher/mesh/dt.c \
	mesher/mesh/flip.c \
	mesher/mesh/tm.c \
	mesher/mesh/vf.c
