/*
 * fuzz.h -- one libFuzzer entry point per proto decoder.
 *
 * Each tests/fuzz/fuzz_<decoder>.c is one line, PR_FUZZ_TARGET(kind, name),
 * which makes it a target of fuzz_input.h: its pdr_fuzz_run runs prs_check
 * (tests/pr_sample.c), where the decoder must refuse the input cleanly, or
 * accept it, re-encode it to exactly the same bytes, and agree with its own
 * accessors. Anything else aborts, which libFuzzer reports as a crash.
 * Memory errors are ASan's to find. The corpus is
 * tests/corpus/proto/<name>/.
 *
 * The same file links either with libFuzzer (clang -fsanitize=fuzzer; see
 * tools/fuzz) or with tests/fuzz/replay_input.c, the plain main that feeds
 * a corpus directory to the entry point under 'make check'.
 */
#ifndef PR_FUZZ_H
#define PR_FUZZ_H

#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

#include "../pr_sample.h"
#include "fuzz_input.h"

#define PR_FUZZ_TARGET(kind, name)                                           \
    const char pdr_fuzz_corpus[] = "proto/" name;                            \
    int pdr_fuzz_run(const uint8_t *data, size_t size)                       \
    {                                                                        \
        int rc = prs_check((kind), data, size);                              \
        if (rc == 1)                                                         \
            abort();                                                         \
        return rc == 0;                                                      \
    }                                                                        \
    PDR_FUZZ_ENTRY

#endif /* PR_FUZZ_H */
