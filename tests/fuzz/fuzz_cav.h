/*
 * fuzz_cav.h -- the promises every accepted cavity body keeps, for the
 * fuzz targets of mesher/par/par_cav.h's decoders (fuzz_reply.c,
 * fuzz_band.c): gathered vertices with a gid and finite coordinates,
 * tetrahedra of four distinct listed vertices (or the infinite one) that
 * came from PE src, pieces of two or three distinct listed vertices.
 * Aborts through PDR_FUZZ_ASSERT on the first broken one.
 */
#ifndef PDR_FUZZ_CAV_H
#define PDR_FUZZ_CAV_H

#include <math.h>

#include "fuzz_input.h"
#include "par/par_cav.h"
#include "par/par_sub.h"

static inline void fuzz_check_gathered(const par_cav *c, uint32_t src)
{
    for (size_t i = 0; i < c->ngv; i++) {
        PDR_FUZZ_ASSERT(c->gv[i].gid != PAR_GID_INF);
        for (int k = 0; k < 3; k++)
            PDR_FUZZ_ASSERT(isfinite(c->gv[i].xyz[k]));
    }
    for (size_t i = 0; i < c->ngt; i++) {
        PDR_FUZZ_ASSERT(c->gt[i].src == src);
        for (int k = 0; k < 4; k++) {
            PDR_FUZZ_ASSERT(c->gt[i].v[k] == UINT32_MAX || c->gt[i].v[k] < c->ngv);
            for (int j = k + 1; j < 4; j++)
                PDR_FUZZ_ASSERT(c->gt[i].v[k] != c->gt[i].v[j]);
        }
    }
    for (size_t i = 0; i < c->ngp; i++) {
        const par_gpiece *g = &c->gp[i];
        PDR_FUZZ_ASSERT(g->nv == 2 || g->nv == 3);
        for (int k = 0; k < g->nv; k++)
            PDR_FUZZ_ASSERT(g->v[k] < c->ngv);
        PDR_FUZZ_ASSERT(g->v[0] != g->v[1]);
        PDR_FUZZ_ASSERT(g->nv == 2 || (g->v[2] != g->v[0] && g->v[2] != g->v[1]));
    }
}

#endif /* PDR_FUZZ_CAV_H */
