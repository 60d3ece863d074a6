/*
 * fuzz_plc.h -- body of the PLC reader targets (fuzz_poly.c, fuzz_smesh.c,
 * fuzz_off.c, fuzz_stl.c, fuzz_ply.c, fuzz_obj.c, fuzz_medit.c): the input is a file of the format FUZZ_EXT,
 * read from memory by plc_read_stream and, when read, checked by
 * plc_validate. Promises: a refused input has at least one message naming
 * the file; an accepted one has every corner, segment end and marker array
 * in range.
 */
#include <string.h>

#include "fuzz_input.h"
#include "plc/plc.h"

/* A directory that does not exist, so that a .poly whose vertex count is
 * 0 fails to open its .node file the same way every time. */
#define FUZZ_PATH "/nonexistent-pdr-fuzz/input" FUZZ_EXT

static int diag_names_file(const pdr_diag *d)
{
    if (d->ntotal == 0 || d->nkept == 0)
        return 0;
    for (size_t i = 0; i < d->nkept; i++)
        if (strncmp(d->msgs[i], "/nonexistent-pdr-fuzz/input", 27) != 0)
            return 0;
    return 1;
}

int pdr_fuzz_run(const uint8_t *data, size_t size)
{
    plc p;
    pdr_diag d = {0};
    PDR_FUZZ_ASSERT(plc_init(&p, FUZZ_PATH) == 0);
    FILE *f = pdr_fuzz_stream(data, size);
    PDR_FUZZ_ASSERT(f != NULL);
    int rc = plc_read_stream(&p, f, FUZZ_PATH, &d);
    fclose(f);
    if (rc == 0) {
        for (size_t i = 0; i < p.ncorner; i++)
            PDR_FUZZ_ASSERT(p.corners[i] < p.nv);
        for (size_t k = 0; k < p.npoly; k++)
            PDR_FUZZ_ASSERT(p.polys[k].n >= 1 &&
                            p.polys[k].first + p.polys[k].n <= p.ncorner);
        for (size_t s = 0; s < p.nsegin; s++)
            PDR_FUZZ_ASSERT(p.segin[s].v[0] < p.nv && p.segin[s].v[1] < p.nv);
        for (size_t k = 0; k < p.nfacet; k++)
            PDR_FUZZ_ASSERT(p.facets[k].poly_first + p.facets[k].npoly <= p.npoly &&
                            p.facets[k].hole_first + p.facets[k].nhole <= p.nfhole);
        rc = plc_validate(&p, &d);
    }
    if (rc != 0 && rc != PDR_ENOMEM)
        PDR_FUZZ_ASSERT(diag_names_file(&d));
    plc_free(&p);
    pdr_diag_free(&d);
    return rc == 0;
}

PDR_FUZZ_ENTRY
