/* Fuzz target: the .mesh reader (see fuzz_plc.h, tools/fuzz). */
#include "config.h"

#define FUZZ_EXT ".mesh"
const char pdr_fuzz_corpus[] = "plc/medit";
#include "fuzz_plc.h"
