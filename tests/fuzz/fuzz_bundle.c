/*
 * Fuzz target: cutting a ZeroMQ message into frames (am__bundle_next,
 * runtime/am_control.h; CONTROL.md "Bundles"), the way a PE's receiver
 * does before it checks each frame as a lone one. The input is one
 * message. Promises: every cut lies inside the message and is exactly the
 * header size plus the payload length its header states; where proto's
 * header decoder accepts a frame it agrees with the cut (a frame inside a
 * bundle is framed as a lone frame would be); the frames of an accepted
 * message (every frame decodes) re-encode to the same bytes. A tail that
 * is not a whole frame refuses the message, as the receiver rejects it.
 */
#include "config.h"

#include <string.h>

#include "am_control.h"
#include "fuzz_input.h"

const char pdr_fuzz_corpus[] = "runtime/bundle";

/* Re-encodes one decoded frame at out and checks it is the input's. */
static void same_frame(const pr_header *h, const uint8_t *frame, size_t n)
{
    uint8_t head[PR_HEADER_SIZE];
    pr_header_encode(h, head);
    PDR_FUZZ_ASSERT(memcmp(head, frame, PR_HEADER_SIZE) == 0);
    PDR_FUZZ_ASSERT(n == PR_HEADER_SIZE + (size_t)h->payload_len);
}

int pdr_fuzz_run(const uint8_t *data, size_t size)
{
    size_t off = 0;
    int whole = size > 0;
    while (off < size) {
        size_t left = size - off;
        size_t n = am__bundle_next(data + off, left);
        pr_header h;
        if (n == 0) {
            /* The receiver checks the tail as one frame: the decoder must
             * refuse it too, or say its length is not the tail's. */
            int rc = pr_header_decode(&h, data + off, left);
            PDR_FUZZ_ASSERT(rc != 0 ||
                            PR_HEADER_SIZE + (size_t)h.payload_len != left);
            whole = 0;
            break;
        }
        PDR_FUZZ_ASSERT(n >= PR_HEADER_SIZE && n <= left);
        PDR_FUZZ_ASSERT(n == PR_HEADER_SIZE + (size_t)pr_load_u32(data + off + 12));
        if (pr_header_decode(&h, data + off, n) == 0)
            same_frame(&h, data + off, n);
        else
            whole = 0;
        off += n;
    }
    PDR_FUZZ_ASSERT(off <= size);
    return whole;
}

PDR_FUZZ_ENTRY
