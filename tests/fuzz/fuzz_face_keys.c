/* Fuzz target: the face_keys decoder (see fuzz.h, tools/fuzz). */
#include "config.h"

#include "fuzz.h"

PR_FUZZ_TARGET(PRS_FACE_KEYS, "face_keys")
