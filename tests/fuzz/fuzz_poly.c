/* Fuzz target: the .poly reader (see fuzz_plc.h, tools/fuzz). */
#include "config.h"

#define FUZZ_EXT ".poly"
const char pdr_fuzz_corpus[] = "plc/poly";
#include "fuzz_plc.h"
