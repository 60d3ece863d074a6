/* Fuzz target: the .off reader (see fuzz_plc.h, tools/fuzz). */
#include "config.h"

#define FUZZ_EXT ".off"
const char pdr_fuzz_corpus[] = "plc/off";
#include "fuzz_plc.h"
