/* Fuzz target: the .obj reader (see fuzz_plc.h, tools/fuzz). */
#include "config.h"

#define FUZZ_EXT ".obj"
const char pdr_fuzz_corpus[] = "plc/obj";
#include "fuzz_plc.h"
