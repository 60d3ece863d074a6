# mesher/cli: the pdr program (pdr.c dispatches to one cmd_*.c per
# subcommand). Uses every layer.
noinst_HEADERS += mesher/cli/pdr_cli.h
pdr_SOURCES += \
	mesher/cli/pdr.c \
	mesher/cli/cmd_check.c \
	mesher/cli/cmd_delaunay.c \
	mesher/cli/cmd_domain.c \
	mesher/cli/cmd_info.c \
	mesher/cli/cmd_mesh.c \
	mesher/cli/cmd_run.c
