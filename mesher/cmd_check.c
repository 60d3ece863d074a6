/* cmd_check.c -- 'pdr check': verify a tetrahedral mesh given as TetGen
 * .node/.ele files with exact predicates and report every defect by kind. */
#include "config.h"

#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io_tetgen.h"
#include "pdr_cli.h"
#include "pdr_util.h"
#include "tetmesh.h"
#include "verify.h"

static void usage(FILE *f)
{
    fprintf(f,
            "Usage: pdr check [OPTIONS] MESH\n\n"
            "Reads MESH.node and MESH.ele (MESH may also name either file) and verifies\n"
            "the tetrahedralization with exact arithmetic:\n"
            "  - vertex numbers valid, no face shared by more than two tetrahedra;\n"
            "  - every tetrahedron positively oriented, no folded faces;\n"
            "  - every interior face locally Delaunay (cospherical ties allowed);\n"
            "  - the boundary is a closed, convex surface (the convex hull);\n"
            "  - every point is a vertex or a duplicate of one;\n"
            "  - probe points are covered by exactly one tetrahedron.\n\n"
            "Options:\n"
            "      --no-delaunay  skip the Delaunay test (for non-Delaunay meshes)\n"
            "      --no-hull      the boundary need not be convex (a domain's mesh)\n"
            "  -q, --quiet        print only the verdict line\n"
            "  -h, --help         show this help\n\n"
            "Exit status: 0 no defect, 1 defects found or unreadable input, 2 usage error.\n");
}

static char *with_ext(const char *base, size_t n, const char *ext)
{
    char *s = malloc(n + strlen(ext) + 1);
    if (s) {
        memcpy(s, base, n);
        strcpy(s + n, ext);
    }
    return s;
}

int pdr_cmd_check(int argc, char **argv)
{
    static const struct option opts[] = {{"no-delaunay", no_argument, NULL, 'D'},
                                         {"no-hull", no_argument, NULL, 'H'},
                                         {"quiet", no_argument, NULL, 'q'},
                                         {"help", no_argument, NULL, 'h'},
                                         {NULL, 0, NULL, 0}};
    unsigned what = VF_ALL;
    int quiet = 0, hull = 1, c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "qh", opts, NULL)) != -1) {
        switch (c) {
        case 'D':
            what &= ~(unsigned)VF_DELAUNAY;
            break;
        case 'H':
            hull = 0;
            what &= ~(unsigned)VF_HULL;
            break;
        case 'q':
            quiet = 1;
            break;
        case 'h':
            usage(stdout);
            return PDR_EXIT_OK;
        default:
            fprintf(stderr, "Try 'pdr check --help'.\n");
            return PDR_EXIT_USAGE;
        }
    }
    if (optind + 1 != argc) {
        pdr_cli_error("check", optind == argc ? "no mesh given (try --help)"
                                              : "more than one mesh given");
        return PDR_EXIT_USAGE;
    }
    const char *arg = argv[optind];
    size_t n = strlen(arg);
    if (n > 5 && (!strcmp(arg + n - 5, ".node")))
        n -= 5;
    else if (n > 4 && !strcmp(arg + n - 4, ".ele"))
        n -= 4;
    char *pnode = with_ext(arg, n, ".node"), *pele = with_ext(arg, n, ".ele");
    int status = PDR_EXIT_FAIL;
    pdr_diag diag = {0};
    tg_nodes nodes = {0};
    uint32_t *tv = NULL;
    size_t ntets = 0;
    tm_mesh m;
    int have_mesh = 0;
    if (!pnode || !pele) {
        pdr_cli_error("check", "out of memory");
        goto done;
    }
    double t0 = pdr_now();
    if (tg_read_node(pnode, &nodes, &diag) ||
        tg_read_ele(pele, nodes.n, nodes.first, &tv, &ntets, &diag)) {
        pdr_diag_print(&diag, stderr);
        goto done;
    }
    if (tm_init(&m, 0)) {
        pdr_cli_error("check", "out of memory");
        goto done;
    }
    have_mesh = 1;
    int rc = tm_reserve(&m, nodes.n + 1, ntets + ntets / 4 + 64);
    for (size_t i = 0; i < nodes.n && !rc; i++) {
        uint32_t v;
        rc = tm_add_vertex(&m, nodes.xyz + 3 * i, &v);
    }
    if (!rc)
        rc = tm_room(&m, ntets);
    for (size_t t = 0; t < ntets && !rc; t++) {
        uint32_t s = tm_alloc_tet(&m);
        for (int k = 0; k < 4; k++) {
            m.tets[s].v[k] = tv[4 * t + (size_t)k] + 1; /* point i is vertex i+1 */
            m.tets[s].n[k] = TM_LINK_NONE;
        }
    }
    free(tv);
    tv = NULL;
    vf_report r = {0};
    if (!rc)
        rc = tm_link_faces(&m, &r.nonmanifold);
    if (!rc && hull)
        rc = tm_add_ghosts(&m, NULL);
    if (!rc)
        rc = vf_check(&m, what, &r);
    if (rc) {
        pdr_cli_error("check", "%s", pdr_strerror(rc));
        goto done;
    }
    if (!quiet) {
        printf("%s, %s\n", pnode, pele);
        vf_print(&r, stdout);
        printf("check seconds: %.3f\n", pdr_now() - t0);
    } else {
        size_t d = vf_defects(&r);
        printf("%s: %zu defect%s\n", d ? "FAILED" : "ok", d, d == 1 ? "" : "s");
    }
    status = vf_defects(&r) ? PDR_EXIT_FAIL : PDR_EXIT_OK;
done:
    if (have_mesh)
        tm_free(&m);
    free(tv);
    tg_nodes_free(&nodes);
    pdr_diag_free(&diag);
    free(pnode);
    free(pele);
    return status;
}
