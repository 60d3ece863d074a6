/* cli/cmd_check.c -- 'pdr check': verify a tetrahedral mesh given as TetGen
 * .node/.ele files with exact predicates and report every defect by kind;
 * for the mesh of a domain also its boundary (.face), its fit to the input
 * PLC (facet coverage, volume) and its quality. */
#include "config.h"

#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <unistd.h>

#include "pr_alloc.h"
#include "io/face.h"
#include "io/tg.h"
#include "check/mc.h"
#include "cli/pdr_cli.h"
#include "plc/fm.h"
#include "plc/plc.h"
#include "check/ql.h"
#include "base/pdr_util.h"
#include "mesh/tm.h"
#include "mesh/vf.h"

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
            "  - probe points are covered by exactly one tetrahedron.\n"
            "A mesh of a domain (MESH.face exists, or --plc is given) need not be convex;\n"
            "instead, with MESH.face: every face of only one tetrahedron is a boundary\n"
            "triangle and every boundary triangle is a face; with --plc IN: every\n"
            "boundary triangle lies in an input facet, each facet's triangles add up to\n"
            "its area, and the tetrahedra add up to the domain's volume computed from the\n"
            "input. The quality report gives the radius-edge ratio histogram, the\n"
            "shortest edge and the dihedral angle histograms of boundary and interior\n"
            "tetrahedra (Nave et al., fig. 9).\n\n"
            "Options:\n"
            "      --plc IN       the input the mesh was made from (.poly, .smesh, .off,\n"
            "                     .stl, .ply, .obj, .mesh)\n"
            "      --merge-angle A, --no-merge  prepare IN as 'pdr mesh' does: coplanar\n"
            "                     triangles merged into facets (default A = %g degrees;\n"
            "                     give the value pdr mesh was given)\n"
            "      --facet-tol T  prepare IN with near-planar facets as 'pdr mesh\n"
            "                     --facet-tol T' does (default %g; give the value pdr\n"
            "                     mesh was given): boundary triangles within 2T of such\n"
            "                     a facet, areas in its plane, the volume within its\n"
            "                     area times 2T\n"
            "      --face FILE    boundary triangles (default MESH.face when it exists)\n"
            "      --max-ratio B  a tetrahedron with radius-edge ratio >= B is a defect\n"
            "      --plot PNG     draw the dihedral angle histograms with gnuplot\n"
            "      --no-quality   skip the quality report\n"
            "      --no-delaunay  skip the Delaunay test (for non-Delaunay meshes)\n"
            "      --no-hull      the boundary need not be convex (a domain's mesh)\n"
            "  -q, --quiet        print only the verdict line\n"
            "  -h, --help         show this help\n\n"
            "Exit status: 0 no defect, 1 defects found or unreadable input, 2 usage error.\n",
            FM_MERGE_ANGLE, FM_FACET_TOL);
}

int pdr_cmd_check(int argc, char **argv)
{
    enum { O_PLC = 256, O_FACE, O_MAXRATIO, O_PLOT, O_NOQ, O_MERGE, O_NOMERGE, O_FACETTOL };
    static const struct option opts[] = {{"no-delaunay", no_argument, NULL, 'D'},
                                         {"plc", required_argument, NULL, O_PLC},
                                         {"face", required_argument, NULL, O_FACE},
                                         {"max-ratio", required_argument, NULL, O_MAXRATIO},
                                         {"plot", required_argument, NULL, O_PLOT},
                                         {"no-quality", no_argument, NULL, O_NOQ},
                                         {"merge-angle", required_argument, NULL, O_MERGE},
                                         {"no-merge", no_argument, NULL, O_NOMERGE},
                                         {"facet-tol", required_argument, NULL, O_FACETTOL},
                                         {"no-hull", no_argument, NULL, 'H'},
                                         {"quiet", no_argument, NULL, 'q'},
                                         {"help", no_argument, NULL, 'h'},
                                         {NULL, 0, NULL, 0}};
    unsigned what = VF_ALL;
    int quiet = 0, hull = 1, c, quality = 1;
    const char *plc_path = NULL, *face_path = NULL, *plot = NULL;
    double max_ratio = 0, merge_angle = FM_MERGE_ANGLE, facet_tol = FM_FACET_TOL;
    /* 0, not 1: glibc (and musl) then also forget where an earlier parse
     * stopped inside a cluster of short options ("-Qh"), which would
     * otherwise be read from that parse's argv. */
    optind = 0;
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
        case O_PLC:
            plc_path = optarg;
            break;
        case O_FACE:
            face_path = optarg;
            break;
        case O_PLOT:
            plot = optarg;
            break;
        case O_NOQ:
            quality = 0;
            break;
        case O_MERGE:
            if (pdr_cli_merge_angle("check", optarg, &merge_angle))
                return PDR_EXIT_USAGE;
            break;
        case O_NOMERGE:
            merge_angle = -1;
            break;
        case O_FACETTOL:
            if (pdr_cli_facet_tol("check", optarg, &facet_tol))
                return PDR_EXIT_USAGE;
            break;
        case O_MAXRATIO: {
            char *end;
            max_ratio = strtod(optarg, &end);
            if (end == optarg || *end || !(max_ratio > 0)) {
                pdr_cli_error("check", "--max-ratio needs a positive number, not '%s'", optarg);
                return PDR_EXIT_USAGE;
            }
            break;
        }
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
    if (pdr_cli_parse_only)
        return PDR_EXIT_OK;
    const char *arg = argv[optind];
    size_t n = strlen(arg);
    if (n > 5 && (!strcmp(arg + n - 5, ".node")))
        n -= 5;
    else if (n > 4 && !strcmp(arg + n - 4, ".ele"))
        n -= 4;
    char *pnode = pdr_path_ext(arg, n, ".node"), *pele = pdr_path_ext(arg, n, ".ele");
    char *pface = face_path ? pr_strdup(face_path) : pdr_path_ext(arg, n, ".face");
    int status = PDR_EXIT_FAIL;
    pdr_diag diag = {0};
    tg_nodes nodes = {0};
    uint32_t *tv = NULL, *ftri = NULL;
    int *fmark = NULL;
    size_t ntets = 0, nface = 0;
    tm_mesh m;
    plc p;
    int have_mesh = 0, have_plc = 0;
    if (!pnode || !pele || !pface) {
        pdr_cli_error("check", "out of memory");
        goto done;
    }
    int with_face = face_path != NULL || access(pface, R_OK) == 0;
    if (with_face || plc_path) {
        hull = 0;
        what &= ~(unsigned)VF_HULL;
    }
    if (plc_path) {
        if (plc_init(&p, plc_path)) {
            pdr_cli_error("check", "out of memory");
            goto done;
        }
        have_plc = 1;
        fm_stats fs;
        int rc = plc_read(&p, plc_path, &diag);
        if (!rc)
            rc = plc_validate(&p, &diag);
        if (!rc)
            rc = fm_prepare(&p, merge_angle, facet_tol, &fs, &diag);
        if (rc) {
            pdr_cli_fail("check", &diag, rc);
            goto done;
        }
    }
    double t0 = pdr_now();
    int rrc = tg_read_node(pnode, &nodes, &diag);
    if (!rrc)
        rrc = tg_read_ele(pele, nodes.n, nodes.first, &tv, &ntets, &diag);
    if (!rrc && with_face)
        rrc = face_read(pface, nodes.n, nodes.first, &ftri, &fmark, &nface, &diag);
    if (rrc) {
        pdr_cli_fail("check", &diag, rrc);
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
    vf_report r = {0};
    mc_report mr;
    memset(&mr, 0, sizeof mr);
    ql_stats qs;
    memset(&qs, 0, sizeof qs);
    if (!rc)
        rc = tm_link_faces(&m, &r.nonmanifold);
    if (!rc && (with_face || have_plc))
        rc = mc_check(&m, (const uint32_t(*)[3])ftri, nface, have_plc ? &p : NULL, &mr);
    if (!rc && (quality || max_ratio > 0 || plot)) {
        mesh_export view = {nodes.n, (const double(*)[3])nodes.xyz, ntets,
                            (const uint32_t(*)[4])tv, NULL, nface,
                            (const uint32_t(*)[3])ftri, fmark};
        rc = ql_mesh_stats(&view, max_ratio > 0 ? max_ratio : 2.0, &qs);
    }
    pr_free(tv);
    tv = NULL;
    if (!rc && hull)
        rc = tm_add_ghosts(&m, NULL);
    if (!rc)
        rc = vf_check(&m, what, &r);
    if (rc) {
        pdr_cli_error("check", "%s", pdr_strerror(rc));
        goto done;
    }
    size_t bad_ratio = max_ratio > 0 ? qs.re_above : 0;
    size_t d = vf_defects(&r) + mc_defects(&mr) + bad_ratio;
    if (!quiet) {
        printf("%s, %s%s%s\n", pnode, pele, with_face ? ", " : "", with_face ? pface : "");
        vf_print(&r, stdout);
        if (with_face || have_plc)
            mc_print(&mr, stdout);
        if (quality) {
            printf("quality\n");
            ql_print(&qs, stdout, 5);
        }
        if (max_ratio > 0)
            printf("tetrahedra with radius-edge ratio >= %g: %zu%s\n", max_ratio, bad_ratio,
                   bad_ratio ? "   <-- DEFECT" : "");
        printf("check seconds: %.3f\n", pdr_now() - t0);
    }
    if (plot) {
        const char *slash = strrchr(arg, '/');
        int prc = ql_plot_png(&qs, plot, slash ? slash + 1 : arg, 5, &diag);
        if (prc) {
            pdr_cli_fail("check", &diag, prc);
            goto done;
        }
        if (!quiet)
            printf("wrote %s\n", plot);
    }
    printf("%s: %zu defect%s\n", d ? "FAILED" : "ok", d, d == 1 ? "" : "s");
    status = d ? PDR_EXIT_FAIL : PDR_EXIT_OK;
done:
    if (have_mesh)
        tm_free(&m);
    if (have_plc)
        plc_free(&p);
    pr_free(tv);
    pr_free(ftri);
    pr_free(fmark);
    pr_free(pface);
    tg_nodes_free(&nodes);
    pdr_diag_free(&diag);
    pr_free(pnode);
    pr_free(pele);
    return status;
}
