/* Fuzz target: the vertex decoder (see fuzz.h, tools/fuzz). */
#include "config.h"

#include "fuzz.h"

PR_FUZZ_TARGET(PRS_VERTEX, "vertex")
