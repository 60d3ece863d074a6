# Tests of libpdrmesh and the pdr program.
check_PROGRAMS += tests/test_pdr_error
TESTS += tests/test_pdr_error
tests_test_pdr_error_SOURCES = tests/test_pdr_error.c
tests_test_pdr_error_CFLAGS = $(UNIT_CFLAGS)
tests_test_pdr_error_LDADD = libpdrmesh.la $(UNIT_LIBS)

check_PROGRAMS += tests/test_textin
TESTS += tests/test_textin
tests_test_textin_SOURCES = tests/test_textin.c
tests_test_textin_CFLAGS = $(UNIT_CFLAGS)
tests_test_textin_LDADD = libpdrmesh.la $(UNIT_LIBS)

# PLC input, validation, domains, quality and output formats (meshio).
check_PROGRAMS += tests/plc_tool
tests_plc_tool_SOURCES = tests/plc_tool.c
tests_plc_tool_LDADD = libpdrmesh.la -lm
check_PROGRAMS += tests/mesh_out_tool
tests_mesh_out_tool_SOURCES = tests/mesh_out_tool.c
tests_mesh_out_tool_LDADD = libpdrmesh.la -lm
