/* Fuzz target: the TetGen .node reader, tg_read_node_stream (see
 * fuzz_input.h, tools/fuzz). Promises: a refused input has a message
 * naming the file and nothing to free; an accepted one has as many points
 * as its header said, numbered from 0 or 1, with the arrays its header
 * asked for. */
#include "config.h"

#include <string.h>

#include "fuzz_input.h"
#include "io/tg.h"

const char pdr_fuzz_corpus[] = "plc/node";

int pdr_fuzz_run(const uint8_t *data, size_t size)
{
    static const char path[] = "input.node";
    tg_nodes n;
    pdr_diag d = {0};
    FILE *f = pdr_fuzz_stream(data, size);
    PDR_FUZZ_ASSERT(f != NULL);
    int rc = tg_read_node_stream(f, path, &n, &d);
    fclose(f);
    if (rc == 0) {
        PDR_FUZZ_ASSERT(n.xyz != NULL);
        PDR_FUZZ_ASSERT(n.first == 0 || n.first == 1);
        PDR_FUZZ_ASSERT(n.nattr == 0 || n.n == 0 || n.attr != NULL);
        PDR_FUZZ_ASSERT(!n.markers || n.n == 0 || n.marker != NULL);
        /* Touch every value, so that ASan sees a short array. */
        double sum = 0;
        for (size_t i = 0; i < 3 * n.n; i++)
            sum += n.xyz[i];
        for (size_t i = 0; n.attr && i < n.n * (size_t)n.nattr; i++)
            sum += n.attr[i];
        for (size_t i = 0; n.marker && i < n.n; i++)
            sum += (double)n.marker[i];
        (void)sum;
        tg_nodes_free(&n);
    } else {
        PDR_FUZZ_ASSERT(n.xyz == NULL && n.attr == NULL && n.marker == NULL);
        if (rc != PDR_ENOMEM) {
            PDR_FUZZ_ASSERT(d.nkept > 0);
            for (size_t i = 0; i < d.nkept; i++)
                PDR_FUZZ_ASSERT(strncmp(d.msgs[i], path, sizeof path - 1) == 0);
        }
    }
    pdr_diag_free(&d);
    return rc == 0;
}

PDR_FUZZ_ENTRY
