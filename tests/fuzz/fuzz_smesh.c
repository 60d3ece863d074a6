/* Fuzz target: the .smesh reader (see fuzz_plc.h, tools/fuzz). */
#include "config.h"

#define FUZZ_EXT ".smesh"
const char pdr_fuzz_corpus[] = "plc/smesh";
#include "fuzz_plc.h"
