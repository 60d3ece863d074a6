/* Fuzz target: the body of a BAND after its owner, par_cav_decode_band
 * (mesher/par/par_cav.h; proto/PROTOCOL.md, "Band"): the tetrahedra part
 * of a reply, then their adjacency, as a PE gives half of the interface
 * band to the other PE on 2-PE runs (see fuzz_input.h, tools/fuzz).
 *
 * The receiver is PE 0 of 2 (a zeroed submesh of that size: no PLC, so
 * pieces name any feature). Promises: a refused body is PDR_EPARSE,
 * PDR_ETOPOLOGY (an outer face towards no PE) or PDR_ENOMEM; an accepted
 * one holds what a reply holds (fuzz_cav.h), and its adjacency, read
 * here from the input's last 16 bytes per tetrahedron, is symmetric, joins
 * faces on the same three vertices, sends every other face to PE 0 or 1,
 * and yields one face record per face: 4 nt less the inner faces.
 *
 * Seeds: valid-cic-N are bands of N tetrahedra picked breadth first from
 * a face towards PE 1 in PE 0's part of a 3,000-tetrahedron cube-in-cube
 * (as test_par's cavity_band_adjacency builds its band), written by
 * par_cav_encode_band; the bad-* ones are valid-cic-5 with its adjacency
 * made asymmetric, one-sided or miscounted, cut short by a byte, or with
 * one byte too many. */
#include "config.h"

#include <string.h>

#include "fuzz_cav.h"

const char pdr_fuzz_corpus[] = "par/band";

static uint32_t load_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* The gids of face k of gathered tetrahedron g (the three vertices other
 * than vertex k), sorted. */
static void face_gids(const par_cav *c, const par_gtet *g, int k, uint64_t out[3])
{
    int n = 0;
    for (int j = 0; j < 4; j++)
        if (j != k)
            out[n++] = g->v[j] == UINT32_MAX ? PAR_GID_INF : c->gv[g->v[j]].gid;
    for (int a = 0; a < 3; a++)
        for (int b = a + 1; b < 3; b++)
            if (out[b] < out[a]) {
                uint64_t t = out[a];
                out[a] = out[b];
                out[b] = t;
            }
}

int pdr_fuzz_run(const uint8_t *data, size_t size)
{
    par_sub s;
    memset(&s, 0, sizeof s);
    s.rank = 0;
    s.size = 2;
    par_cav_ctx cc;
    memset(&cc, 0, sizeof cc);
    cc.s = &s;
    par_cav c;
    par_cav_init(&c, &cc);
    int rc = par_cav_decode_band(&c, data, size, 1);
    if (rc == 0) {
        fuzz_check_gathered(&c, 1);
        /* the adjacency ends the body: 4 nt entries */
        size_t na = 4 * c.ngt;
        PDR_FUZZ_ASSERT(size >= 4 + 4 * na);
        const uint8_t *adj = data + size - 4 * na;
        PDR_FUZZ_ASSERT(load_u32(adj - 4) == na);
        size_t inner_sides = 0;
        for (size_t e = 0; e < na; e++) {
            uint32_t a = load_u32(adj + 4 * e);
            const par_gtet *g = &c.gt[e / 4];
            int k = (int)(e % 4);
            if (a == UINT32_MAX) {
                PDR_FUZZ_ASSERT(g->nbr[k] < s.size);
                continue;
            }
            PDR_FUZZ_ASSERT(a < na && a / 4 != e / 4);
            PDR_FUZZ_ASSERT(load_u32(adj + 4 * (size_t)a) == e);
            uint64_t f0[3], f1[3];
            face_gids(&c, g, k, f0);
            face_gids(&c, &c.gt[a / 4], (int)(a % 4), f1);
            PDR_FUZZ_ASSERT(!memcmp(f0, f1, sizeof f0));
            inner_sides++;
        }
        PDR_FUZZ_ASSERT(inner_sides % 2 == 0);
        PDR_FUZZ_ASSERT(c.nface == na - inner_sides / 2);
    } else {
        PDR_FUZZ_ASSERT(rc == PDR_EPARSE || rc == PDR_ETOPOLOGY || rc == PDR_ENOMEM);
    }
    par_cav_free(&c);
    return rc == 0;
}

PDR_FUZZ_ENTRY
