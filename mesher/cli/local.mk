# mesher/cli: the pdr program (pdr.c dispatches to one cmd_*.c per
# subcommand; mesh_pipeline.c holds the stages of pdr mesh, mesh_par.c its parallel
# driver). Uses every
# layer.
noinst_HEADERS += mesher/cli/mesh_par.h mesher/cli/mesh_pipeline.h mesher/cli/pdr_cli.h
pdr_SOURCES += \
	mesher/cli/pdr.c \
	mesher/cli/cli_util.c \
	mesher/cli/cmd_check.c \
	mesher/cli/cmd_delaunay.c \
	mesher/cli/cmd_domain.c \
	mesher/cli/cmd_info.c \
	mesher/cli/cmd_mesh.c \
	mesher/cli/mesh_par.c \
	mesher/cli/cmd_run.c \
	mesher/cli/mesh_pipeline.c
