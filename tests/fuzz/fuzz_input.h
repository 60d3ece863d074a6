/*
 * fuzz_input.h -- the fuzz targets of tests/fuzz/ that are not proto's
 * decoders: the PLC and .node readers, libam's control-frame decoders and
 * the pdr command line (tools/fuzz builds and runs them).
 *
 * A target file defines
 *     const char pdr_fuzz_corpus[] = "plc/poly";
 *     int pdr_fuzz_run(const uint8_t *data, size_t size);
 * and ends with PDR_FUZZ_ENTRY. pdr_fuzz_run returns 1 if the input was
 * accepted and 0 if it was refused (cleanly, with an error message where
 * the code under test has one), and aborts when the code under test
 * breaks one of its promises; memory errors and leaks are the sanitizers'
 * to find. The corpus is tests/corpus/<pdr_fuzz_corpus>/.
 *
 * The same file links either with libFuzzer or with
 * tests/fuzz/replay_input.c, a plain main that feeds the regression corpus
 * to pdr_fuzz_run under 'make check'.
 */
#ifndef PDR_FUZZ_INPUT_H
#define PDR_FUZZ_INPUT_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

extern const char pdr_fuzz_corpus[];
int pdr_fuzz_run(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* A failed promise: says which, then aborts (libFuzzer saves the input). */
#define PDR_FUZZ_ASSERT(cond)                                                \
    do {                                                                     \
        if (!(cond)) {                                                       \
            fprintf(stderr, "%s:%d: fuzz check failed: %s\n", __FILE__,      \
                    __LINE__, #cond);                                        \
            abort();                                                         \
        }                                                                    \
    } while (0)

#define PDR_FUZZ_ENTRY                                                       \
    int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)             \
    {                                                                        \
        pdr_fuzz_run(data, size);                                            \
        return 0;                                                            \
    }

/* A read-only stream over the input (an empty one for size 0, which
 * fmemopen does not take). NULL only when out of memory. */
static inline FILE *pdr_fuzz_stream(const uint8_t *data, size_t size)
{
    if (size == 0)
        return fopen("/dev/null", "r");
    return fmemopen((void *)(uintptr_t)data, size, "r");
}

#endif /* PDR_FUZZ_INPUT_H */
