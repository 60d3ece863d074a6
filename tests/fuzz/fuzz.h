/*
 * fuzz.h -- one libFuzzer entry point per proto decoder.
 *
 * Each tests/fuzz/fuzz_<decoder>.c is one line, PR_FUZZ_TARGET(kind, name).
 * The entry point runs prs_check (tests/pr_sample.c): the decoder must
 * refuse the input cleanly, or accept it, re-encode it to exactly the same
 * bytes, and agree with its own accessors. Anything else aborts, which
 * libFuzzer reports as a crash. Memory errors are ASan's to find.
 *
 * The same file links either with libFuzzer (clang -fsanitize=fuzzer; see
 * tools/fuzz-proto) or with tests/fuzz/replay.c, a plain main that feeds a
 * corpus directory to the entry point under 'make check'.
 */
#ifndef PR_FUZZ_H
#define PR_FUZZ_H

#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

#include "../pr_sample.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
/* The target's decoder (enum prs_kind), for the replay driver. */
extern const int pr_fuzz_kind;

#define PR_FUZZ_TARGET(kind)                                                 \
    const int pr_fuzz_kind = (kind);                                         \
    int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)             \
    {                                                                        \
        if (prs_check((kind), data, size) == 1)                              \
            abort();                                                         \
        return 0;                                                            \
    }

#endif /* PR_FUZZ_H */
