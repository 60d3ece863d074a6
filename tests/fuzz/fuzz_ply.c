/* Fuzz target: the .ply reader (see fuzz_plc.h, tools/fuzz). */
#include "config.h"

#define FUZZ_EXT ".ply"
const char pdr_fuzz_corpus[] = "plc/ply";
#include "fuzz_plc.h"
