/* Fuzz target: the tetrahedra part of a cavity REPLY, par_cav_decode_tets
 * (mesher/par/par_cav.h; proto/PROTOCOL.md, "Cavity messages"), the body a
 * participant sends the PE that gathers a cavity (see fuzz_input.h,
 * tools/fuzz). Promises: a refused body is PDR_EPARSE (or PDR_ENOMEM);
 * an accepted one names only vertices it lists (or the infinite one),
 * tetrahedra of four distinct vertices, pieces of two or three distinct
 * ones, finite coordinates and non-zero gids, and every tetrahedron comes
 * from the sending PE. Found by this target: pieces and tetrahedra with a
 * repeated vertex were accepted (a subsegment from a vertex to itself
 * then went into the PE's tables). */
#include "config.h"

#include <string.h>

#include "fuzz_cav.h"

const char pdr_fuzz_corpus[] = "par/reply";

int pdr_fuzz_run(const uint8_t *data, size_t size)
{
    par_cav_ctx cc;
    memset(&cc, 0, sizeof cc);
    par_cav c;
    par_cav_init(&c, &cc);
    int rc = par_cav_decode_tets(&c, data, size, 1);
    if (rc == 0)
        fuzz_check_gathered(&c, 1);
    else
        PDR_FUZZ_ASSERT(rc == PDR_EPARSE || rc == PDR_ENOMEM);
    par_cav_free(&c);
    return rc == 0;
}

PDR_FUZZ_ENTRY
