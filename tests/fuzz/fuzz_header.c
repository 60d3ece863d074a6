/* Fuzz target: the header decoder (see fuzz.h, tools/fuzz). */
#include "config.h"

#include "fuzz.h"

PR_FUZZ_TARGET(PRS_HEADER, "header")
