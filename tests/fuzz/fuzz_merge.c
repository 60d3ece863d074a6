/* Fuzz target: a merge message, the submesh each PE sends rank 0 at the
 * end of the parallel refinement (mesher/par/par_wire.h; decoded by rank
 * 0 in the handler of 'pdr mesh', cli/mesh_par.c), for the unit cube's
 * PLC. Promises: a refused message is PDR_EPARSE (or PDR_ENOMEM); an
 * accepted one follows the decoder's rules (every link in range and not
 * to its own tetrahedron, IFACE exactly on the listed faces, flags and
 * regions in range), and one of PE 0 of 1 then merges (par_merge_build_
 * wires) to a mesh or to a counted mismatch, the same with its links
 * checked ahead (par_merge_check_ahead) as without. */
#include "config.h"

#include <string.h>

#include "fuzz_input.h"
#include "par/par_merge.h"
#include "par/par_wire.h"
#include "plc/plc.h"

const char pdr_fuzz_corpus[] = "par/merge";

/* The PLC the corpus's messages were made for. */
static void unit_cube(plc *p)
{
    PDR_FUZZ_ASSERT(plc_init(p, "unit cube") == 0);
    for (int i = 0; i < 8; i++) {
        double x[3] = {i & 1, (i >> 1) & 1, (i >> 2) & 1};
        PDR_FUZZ_ASSERT(plc_add_vertex(p, x, 0, NULL) == 0);
    }
    static const uint32_t f[6][4] = {{0, 1, 3, 2}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                     {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 3, 7, 5}};
    for (int i = 0; i < 6; i++) {
        PDR_FUZZ_ASSERT(plc_begin_facet(p, i + 1, 0) == 0);
        PDR_FUZZ_ASSERT(plc_add_polygon(p, f[i], 4, 0) == 0);
    }
    pdr_diag diag = {0};
    PDR_FUZZ_ASSERT(plc_validate(p, &diag) == 0);
    pdr_diag_free(&diag);
}

static void check_links(const par_wire *w)
{
    const pr_iftable *f = &w->sm->iface;
    size_t nf = 4 * (size_t)w->sm->tet.n;
    uint32_t q = 0;
    for (size_t x = 0; x < nf; x++) {
        uint32_t c = par_wire_link(w, x);
        int listed = q < f->n && f->face[q] == x;
        q += (uint32_t)listed;
        PDR_FUZZ_ASSERT(listed == (c == PAR_WIRE_LINK_IFACE));
        if (c < PAR_WIRE_LINK_IFACE)
            PDR_FUZZ_ASSERT(c < nf && c / 4 != x / 4);
    }
    for (uint32_t k = 0; k < w->sm->tet.n; k++)
        PDR_FUZZ_ASSERT(!(par_wire_tflags(w, k) & ~PAR_WIRE_TFLAGS));
}

static int merged(int rc)
{
    return rc == 0 || rc == PDR_ETOPOLOGY || rc == PDR_ENOMEM || rc == PDR_ELIMIT ||
           rc == PDR_EINVAL;
}

int pdr_fuzz_run(const uint8_t *data, size_t size)
{
    plc p;
    unit_cube(&p);
    par_wire w;
    int rc = par_wire_decode_own(data, size, &p, &w);
    if (rc) {
        PDR_FUZZ_ASSERT(rc == PDR_EPARSE || rc == PDR_ENOMEM);
        plc_free(&p);
        return 0;
    }
    check_links(&w);
    if (w.sm->rank == 0 && w.sm->size == 1) {
        ref_mesher m1, m2;
        par_merge_report r1, r2;
        int rc1 = par_merge_build_wires(&w, 1, NULL, 0, &p, NULL, &m1, &r1);
        PDR_FUZZ_ASSERT(merged(rc1));
        if (!rc1)
            ref_free(&m1);
        par_merge_ahead a;
        if (par_merge_check_ahead(&w, &a) == 0) {
            int rc2 = par_merge_build_wires(&w, 1, &a, 1, &p, NULL, &m2, &r2);
            PDR_FUZZ_ASSERT(rc2 == rc1 || rc1 == PDR_ENOMEM || rc2 == PDR_ENOMEM);
            if (rc2 == rc1)
                PDR_FUZZ_ASSERT(!memcmp(&r1, &r2, sizeof r1));
            if (!rc2)
                ref_free(&m2);
            par_merge_ahead_free(&a);
        }
    }
    par_wire_clear(&w);
    plc_free(&p);
    return 1;
}

PDR_FUZZ_ENTRY
