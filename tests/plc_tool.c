/*
 * plc_tool.c -- test helper (not installed): reads a PLC with plc_read,
 * validates it and prints what it found, so shell tests can drive the
 * readers and the validator end to end.
 *
 *   plc_tool IN              read + validate; print a summary line
 *   plc_tool IN -o OUT.poly  ... and write the PLC as .poly (only if valid)
 *   plc_tool -n IN           read only, no validation
 *
 * Diagnostics go to stderr, one per line, exactly as the mesher prints
 * them. Exit status: 0 valid, 1 invalid or unreadable, 2 usage.
 */
#include "config.h"

#include <stdio.h>
#include <string.h>

#include "plc/plc.h"

int main(int argc, char **argv)
{
    const char *in = NULL, *out = NULL;
    int validate = 1;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "-o") && i + 1 < argc)
            out = argv[++i];
        else if (!strcmp(argv[i], "-n"))
            validate = 0;
        else if (!in && argv[i][0] != '-')
            in = argv[i];
        else {
            fprintf(stderr, "usage: plc_tool [-n] IN [-o OUT.poly]\n");
            return 2;
        }
    }
    if (!in) {
        fprintf(stderr, "usage: plc_tool [-n] IN [-o OUT.poly]\n");
        return 2;
    }
    plc p;
    pdr_diag d = {0};
    int rc = plc_init(&p, in);
    if (!rc)
        rc = plc_read(&p, in, &d);
    if (!rc && validate)
        rc = plc_validate(&p, &d);
    if (!rc && out)
        rc = plc_write_poly(&p, out, &d);
    pdr_diag_print(&d, stderr);
    if (!rc) {
        size_t ntri = p.ftri_start ? p.ftri_start[p.nfacet] : 0;
        printf("vertices %zu facets %zu polygons %zu segments %zu free-segments %zu "
               "holes %zu regions %zu triangles %zu base %d\n",
               p.nv, p.nfacet, p.npoly, p.nseg, p.nsegin, p.nhole, p.nregion, ntri,
               p.base);
    }
    plc_free(&p);
    pdr_diag_free(&d);
    return rc ? 1 : 0;
}
