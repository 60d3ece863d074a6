/* Fuzz target: the .stl reader (see fuzz_plc.h, tools/fuzz). */
#include "config.h"

#define FUZZ_EXT ".stl"
const char pdr_fuzz_corpus[] = "plc/stl";
#include "fuzz_plc.h"
