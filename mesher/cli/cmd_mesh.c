/* cli/cmd_mesh.c -- 'pdr mesh': guaranteed-quality tetrahedral mesh of a PLC
 * (TetGen .poly/.smesh, .off, .stl, or a built-in model problem). */
#include "config.h"

#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "plc/dom.h"
#include "refine/im.h"
#include "io/face.h"
#include "io/msh.h"
#include "io/tg.h"
#include "io/vtu.h"
#include "cli/pdr_cli.h"
#include "base/pdr_util.h"
#include "plc/plc.h"
#include "refine/refine.h"
#include "mesh/vf.h"

/* Size bound of 'pdr mesh' without an input file: cube-in-cube meshed to
 * about 20 000 tetrahedra in well under a second. */
#define DEFAULT_DOMAIN_MAXVOL 1e-4

static void usage(FILE *f)
{
    fprintf(f,
            "Usage: pdr mesh [OPTIONS] [IN.poly | IN.smesh | IN.off | IN.stl]\n"
            "       pdr mesh [OPTIONS] --domain cube-in-cube|tee|sphere\n\n"
            "Builds a conforming Delaunay tetrahedral mesh of a piecewise linear complex\n"
            "whose tetrahedra have a circumradius to shortest edge ratio below B\n"
            "(Shewchuk's Delaunay refinement). Without an input it meshes the built-in\n"
            "cube-in-cube with -a %g.\n\n"
            "Options (TetGen's letters where TetGen has the switch):\n"
            "  -q, --quality B[/D]  radius-edge bound, B > 1 (default 2); below 2 the\n"
            "                       refinement is not guaranteed to terminate (a warning).\n"
            "                       D: smallest dihedral angle in degrees (default 10;\n"
            "                       slivers below it are split; 0 turns that off)\n"
            "      --min-dihedral D the same as -q B/D\n"
            "  -a, --max-volume V   maximum tetrahedron volume (regions of the input may\n"
            "                       set smaller ones; see --no-region-volume)\n"
            "  -L, --max-edge L     maximum edge length\n"
            "  -o, --output BASE    output base name (default: the input's, plus .1, as\n"
            "                       TetGen: IN.1.node ...; with --domain, NAME.1)\n"
            "  -f, --format LIST    comma-separated output formats (default node):\n"
            "                         node  TetGen BASE.node, BASE.ele, BASE.face\n"
            "                         vtu   VTK BASE.vtu (ParaView, meshio)\n"
            "                         msh   Gmsh BASE.msh (version 4.1)\n"
            "                         none  write nothing\n"
            "      --domain NAME    mesh a built-in domain (cube-in-cube, tee or sphere,\n"
            "                       with the defaults of 'pdr domain') instead of a file\n"
            "      --mo KIND        initial mesh: 'conform' (default: Shewchuk's recovery,\n"
            "                       any valid input) or 'paper' (Nave et al. section 2.1:\n"
            "                       segments below 2d, facets below d*sqrt(2))\n"
            "      --mo-only        stop after the initial mesh (no quality refinement)\n"
            "      --mo-size N      refine the initial mesh to about N tetrahedra with a\n"
            "                       volume bound (the parallel mesher's starting mesh)\n"
            "      --order ORDER    order of bad tetrahedra: lifo (default) or fifo\n"
            "      --rho R          small-angle safety net: refuse a boundary split whose\n"
            "                       insertion radius is below R times its cause's\n"
            "                       (default 0.354; 0 disables it)\n"
            "      --no-region-volume  ignore the volume bounds of the input's regions\n"
            "      --check          verify the result with exact predicates\n"
            "  -Q, --quiet          print only errors and warnings\n"
            "  -h, --help           show this help\n\n"
            "Input errors are reported as FILE:LINE: message and nothing is written. Files\n"
            "are written atomically. The summary gives counts, seconds per phase,\n"
            "tetrahedra per second, peak memory, the radius-edge and dihedral angle\n"
            "ranges and how many tetrahedra were left above the bound (only near input\n"
            "angles too small for the algorithm) and why.\n\n"
            "Exit status: 0 done, 1 failed (bad input, out of memory), 2 usage error.\n",
            DEFAULT_DOMAIN_MAXVOL);
}

/* The refinement's progress callback: a pdr_progress line on stderr. */
static void show_progress(void *arg, const ref_mesher *r)
{
    pdr_progress_line(arg, "pdr mesh: %u vertices, %u tetrahedra (with exterior)", r->m.nv - 1,
                      r->m.nlive - r->m.nghost);
}

/* IN.poly -> IN.1 (TetGen's naming, which never overwrites an input). */
static char *default_base(const char *in)
{
    return pdr_path_ext(in, pdr_path_stem(in), ".1");
}

enum { FMT_NODE = 1, FMT_VTU = 2, FMT_MSH = 4 };

static int parse_formats(const char *s, unsigned *out)
{
    unsigned f = 0;
    char *copy = strdup(s);
    if (!copy)
        return -1;
    int ok = 1;
    for (char *tok = strtok(copy, ","); tok; tok = strtok(NULL, ",")) {
        if (!strcmp(tok, "node") || !strcmp(tok, "ele") || !strcmp(tok, "tetgen"))
            f |= FMT_NODE;
        else if (!strcmp(tok, "vtu") || !strcmp(tok, "vtk"))
            f |= FMT_VTU;
        else if (!strcmp(tok, "msh") || !strcmp(tok, "gmsh"))
            f |= FMT_MSH;
        else if (!strcmp(tok, "none"))
            ;
        else
            ok = 0;
    }
    free(copy);
    *out = f;
    return ok ? 0 : -1;
}

static int parse_double(const char *s, double *out)
{
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (errno || end == s || *end || !isfinite(v))
        return -1;
    *out = v;
    return 0;
}

static int write_outputs(const ref_output *o, const char *base, unsigned fmt, int quiet,
                         pdr_diag *diag)
{
    int rc = 0;
    const mesh_export *v = &o->view;
    if (fmt & FMT_NODE) {
        tg_nodes nodes = {.n = v->nv, .first = 1, .xyz = (double *)o->xyz};
        char *pn = pdr_path_join(base, ".node"), *pe = pdr_path_join(base, ".ele"),
             *pf = pdr_path_join(base, ".face");
        if (!pn || !pe || !pf)
            rc = PDR_ENOMEM;
        if (!rc)
            rc = tg_write_node(pn, &nodes, diag);
        if (!rc)
            rc = tg_write_ele_view(pe, v, o->tet_attr, 1, diag);
        if (!rc)
            rc = face_write(v, pf, 1, diag);
        if (!rc && !quiet)
            printf("wrote %s, %s, %s\n", pn, pe, pf);
        free(pn);
        free(pe);
        free(pf);
    }
    if (!rc && (fmt & FMT_VTU)) {
        char *p = pdr_path_join(base, ".vtu");
        vtu_opts vo = {0, 0};
        rc = p ? vtu_write(v, p, &vo, diag) : PDR_ENOMEM;
        if (!rc && !quiet)
            printf("wrote %s\n", p);
        free(p);
    }
    if (!rc && (fmt & FMT_MSH)) {
        char *p = pdr_path_join(base, ".msh");
        rc = p ? msh_write(v, p, diag) : PDR_ENOMEM;
        if (!rc && !quiet)
            printf("wrote %s\n", p);
        free(p);
    }
    return rc;
}

/* Exact verification of the finished mesh (interior tetrahedra only),
 * like 'pdr check': topology, orientation, local Delaunay property. */
static int self_check(const ref_output *o, int quiet)
{
    tm_mesh m;
    if (tm_init(&m, 0))
        return PDR_ENOMEM;
    const mesh_export *v = &o->view;
    int rc = tm_reserve(&m, v->nv + 1, v->nt + 16);
    for (size_t i = 0; i < v->nv && !rc; i++) {
        uint32_t id;
        rc = tm_add_vertex(&m, v->xyz[i], &id);
    }
    if (!rc)
        rc = tm_room(&m, v->nt);
    for (size_t t = 0; t < v->nt && !rc; t++) {
        uint32_t s = tm_alloc_tet(&m);
        for (int k = 0; k < 4; k++) {
            m.tets[s].v[k] = v->tet[t][k] + 1;
            m.tets[s].n[k] = TM_LINK_NONE;
        }
    }
    vf_report r;
    memset(&r, 0, sizeof r);
    if (!rc)
        rc = tm_link_faces(&m, &r.nonmanifold);
    if (!rc)
        rc = vf_check(&m, VF_TOPOLOGY | VF_ORIENTATION | VF_DELAUNAY | VF_VERTICES, &r);
    tm_free(&m);
    if (rc)
        return rc;
    size_t d = vf_defects(&r);
    if (!quiet || d)
        printf("check: %zu defect%s (topology, orientation, Delaunay)\n", d, d == 1 ? "" : "s");
    if (d)
        vf_print(&r, stdout);
    return d ? PDR_ETOPOLOGY : 0;
}

int pdr_cmd_mesh(int argc, char **argv)
{
    enum {
        O_DOMAIN = 256, O_MO, O_MO_ONLY, O_MO_SIZE, O_ORDER, O_RHO, O_NOREGVOL, O_CHECK,
        O_MINDIH
    };
    static const struct option opts[] = {{"quality", required_argument, NULL, 'q'},
                                         {"max-volume", required_argument, NULL, 'a'},
                                         {"max-edge", required_argument, NULL, 'L'},
                                         {"min-dihedral", required_argument, NULL, O_MINDIH},
                                         {"output", required_argument, NULL, 'o'},
                                         {"format", required_argument, NULL, 'f'},
                                         {"domain", required_argument, NULL, O_DOMAIN},
                                         {"mo", required_argument, NULL, O_MO},
                                         {"mo-only", no_argument, NULL, O_MO_ONLY},
                                         {"mo-size", required_argument, NULL, O_MO_SIZE},
                                         {"order", required_argument, NULL, O_ORDER},
                                         {"rho", required_argument, NULL, O_RHO},
                                         {"no-region-volume", no_argument, NULL, O_NOREGVOL},
                                         {"check", no_argument, NULL, O_CHECK},
                                         {"quiet", no_argument, NULL, 'Q'},
                                         {"help", no_argument, NULL, 'h'},
                                         {NULL, 0, NULL, 0}};
    ref_opts ro;
    ref_default_opts(&ro);
    im_opts io = {0, 0};
    const char *out = NULL, *domain = NULL;
    unsigned fmt = FMT_NODE;
    int quiet = 0, mo_only = 0, check = 0, have_a = 0;
    double mo_size = 0;
    int c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "q:a:L:o:f:Qh", opts, NULL)) != -1) {
        double x;
        switch (c) {
        case 'q': {
            /* TetGen's form B/D also gives the smallest dihedral angle */
            char *slash = strchr(optarg, '/');
            if (slash) {
                *slash = 0;
                double dd;
                if (parse_double(slash + 1, &dd) || dd < 0 || dd >= 60) {
                    pdr_cli_error("mesh", "-q B/D needs an angle D in [0, 60) degrees, not '%s'",
                                  slash + 1);
                    return PDR_EXIT_USAGE;
                }
                ro.min_dihedral = dd;
            }
            if (parse_double(optarg, &x) || !(x > 1.0)) {
                pdr_cli_error("mesh", "-q needs a radius-edge bound greater than 1, not '%s'",
                              optarg);
                return PDR_EXIT_USAGE;
            }
            ro.ratio = x;
            break;
        }
        case O_MINDIH:
            if (parse_double(optarg, &x) || x < 0 || x >= 60) {
                pdr_cli_error("mesh", "--min-dihedral needs an angle in [0, 60) degrees, not '%s'",
                              optarg);
                return PDR_EXIT_USAGE;
            }
            ro.min_dihedral = x;
            break;
        case 'a':
            if (parse_double(optarg, &x) || !(x > 0.0)) {
                pdr_cli_error("mesh", "-a needs a positive volume, not '%s'", optarg);
                return PDR_EXIT_USAGE;
            }
            ro.maxvol = x;
            have_a = 1;
            break;
        case 'L':
            if (parse_double(optarg, &x) || !(x > 0.0)) {
                pdr_cli_error("mesh", "-L needs a positive length, not '%s'", optarg);
                return PDR_EXIT_USAGE;
            }
            ro.maxedge = x;
            break;
        case 'o':
            out = optarg;
            break;
        case 'f':
            if (parse_formats(optarg, &fmt)) {
                pdr_cli_error("mesh", "unknown output format in '%s' (node, vtu, msh, none)",
                              optarg);
                return PDR_EXIT_USAGE;
            }
            break;
        case O_DOMAIN:
            domain = optarg;
            break;
        case O_MO:
            if (!strcmp(optarg, "paper"))
                io.paper = 1;
            else if (!strcmp(optarg, "conform"))
                io.paper = 0;
            else {
                pdr_cli_error("mesh", "--mo is 'conform' or 'paper', not '%s'", optarg);
                return PDR_EXIT_USAGE;
            }
            break;
        case O_MO_ONLY:
            mo_only = 1;
            break;
        case O_MO_SIZE:
            if (parse_double(optarg, &mo_size) || !(mo_size >= 1)) {
                pdr_cli_error("mesh", "--mo-size needs a number of tetrahedra, not '%s'", optarg);
                return PDR_EXIT_USAGE;
            }
            break;
        case O_ORDER:
            if (!strcmp(optarg, "lifo"))
                ro.order = REF_ORDER_LIFO;
            else if (!strcmp(optarg, "fifo"))
                ro.order = REF_ORDER_FIFO;
            else {
                pdr_cli_error("mesh", "--order is 'lifo' or 'fifo', not '%s'", optarg);
                return PDR_EXIT_USAGE;
            }
            break;
        case O_RHO:
            if (parse_double(optarg, &x) || x < 0 || x >= 1) {
                pdr_cli_error("mesh", "--rho needs a number in [0, 1), not '%s'", optarg);
                return PDR_EXIT_USAGE;
            }
            ro.rho = x;
            break;
        case O_NOREGVOL:
            ro.use_region_maxvol = 0;
            break;
        case O_CHECK:
            check = 1;
            break;
        case 'Q':
            quiet = 1;
            break;
        case 'h':
            usage(stdout);
            return PDR_EXIT_OK;
        default:
            fprintf(stderr, "Try 'pdr mesh --help'.\n");
            return PDR_EXIT_USAGE;
        }
    }
    if (optind < argc - 1 || (optind < argc && domain)) {
        pdr_cli_error("mesh", "give one input file or --domain, not both or several");
        return PDR_EXIT_USAGE;
    }
    const char *in = optind < argc ? argv[optind] : NULL;
    if (!in && !domain) {
        domain = "cube-in-cube";
        if (!have_a)
            ro.maxvol = DEFAULT_DOMAIN_MAXVOL;
    }
    int dom = domain ? dom_lookup(domain) : -1;
    if (domain && dom < 0) {
        pdr_cli_error("mesh", "unknown domain '%s' (cube-in-cube, tee, sphere)", domain);
        return PDR_EXIT_USAGE;
    }
    if (ro.ratio < 2.0)
        fprintf(stderr,
                "pdr mesh: warning: with -q %g below 2, termination is not guaranteed "
                "(refinement is attempted)\n",
                ro.ratio);

    int status = PDR_EXIT_FAIL, rc;
    pdr_diag diag = {0};
    plc p;
    ref_mesher r;
    ref_output o;
    int have_plc = 0, have_r = 0, have_o = 0;
    char *base = NULL;
    memset(&o, 0, sizeof o);
    double t0 = pdr_now();
    pdr_progress pg;
    pdr_progress_start(&pg, t0, quiet);

    if ((rc = plc_init(&p, in ? in : domain)))
        goto fail;
    have_plc = 1;
    if (in) {
        rc = plc_read(&p, in, &diag);
        if (!rc)
            rc = plc_validate(&p, &diag);
    } else {
        rc = dom_build_default(&p, dom, &diag);
    }
    if (!rc && !in)
        rc = plc_validate(&p, &diag);
    if (rc) {
        pdr_diag_print(&diag, stderr);
        if (rc != PDR_EPARSE && rc != PDR_EGEOMETRY && rc != PDR_EIO)
            pdr_cli_error("mesh", "%s", pdr_strerror(rc));
        goto done;
    }
    base = out ? strdup(out) : default_base(in ? in : domain);
    if (!base) {
        rc = PDR_ENOMEM;
        goto fail;
    }
    double t_read = pdr_now();
    if (!quiet)
        printf("input: %s: %zu vertices, %zu segments, %zu facets, %zu hole%s, %zu region%s "
               "(%.3f s)\n",
               in ? in : domain, p.nv, p.nseg, p.nfacet, p.nhole, p.nhole == 1 ? "" : "s",
               p.nregion, p.nregion == 1 ? "" : "s", t_read - t0);

    ro.progress = show_progress;
    ro.progress_arg = &pg;
    /* The refinement's debugging aids, turned on from the environment
     * here because the library reads none: PDR_REF_CHECK checks the marks
     * against the subsegment and subfacet tables before every step (slow)
     * and fails at the first disagreement, described on stderr;
     * PDR_REF_TRACE=N prints the queues and counters every N steps. */
    if (getenv("PDR_REF_CHECK")) {
        ro.check_each_step = 1;
        ro.log = stderr;
    }
    const char *trace = getenv("PDR_REF_TRACE");
    if (trace && atol(trace) > 0) {
        ro.trace = stderr;
        ro.trace_every = (size_t)atol(trace);
    }
    if ((rc = ref_init(&r, &p, &ro)))
        goto fail;
    have_r = 1;
    im_stats is;
    rc = im_build(&r, &io, &is, &diag);
    if (diag.ntotal) {
        pdr_diag_print(&diag, stderr);
        pdr_diag_free(&diag);
    }
    if (rc)
        goto fail;
    if (mo_size > 0 && !(rc = im_mo_size(&r, (size_t)mo_size)))
        is.tets = ref_interior_tets(&r);
    if (rc)
        goto fail;
    double t_mo = pdr_now();
    if (!quiet) {
        printf("initial mesh (%s): %zu tetrahedra, %zu points added on segments, %zu on "
               "facets",
               io.paper ? "paper" : "conforming", is.tets, is.seg_points, is.fac_points);
        if (io.paper)
            printf(", d = %.6g", is.d);
        printf(" (%.3f s)\n", t_mo - t_read);
    }
    size_t v0 = r.m.nv;
    if (!mo_only) {
        if ((rc = ref_refine(&r)))
            goto fail;
    }
    double t_ref = pdr_now();
    pdr_progress_end(&pg);
    ref_count_bad(&r);
    ref_release_work(&r);
    size_t v_added = (size_t)(r.m.nv - v0);
    if ((rc = ref_export_take(&r, &o)))
        goto fail;
    have_o = 1;
    double t_exp = pdr_now();
    size_t nt = o.view.nt;
    if (!quiet) {
        double tref = t_ref - t_mo;
        if (!mo_only)
            printf("refinement: %zu vertices added (%zu tetrahedra, %zu subfacet, %zu "
                   "subsegment points), %zu circumcentres rejected (%.3f s, %.0f "
                   "tetrahedra/s)\n",
                   v_added, r.st.tet_points, r.st.fac_points, r.st.seg_points, r.st.rejected,
                   tref, tref > 0 ? (double)nt / tref : 0.0);
        printf("mesh: %zu vertices, %zu tetrahedra, %zu boundary triangles\n", o.view.nv, nt,
               o.view.nf);
    }
    if (fmt) {
        rc = write_outputs(&o, base, fmt, quiet, &diag);
        if (rc) {
            pdr_diag_print(&diag, stderr);
            goto done;
        }
    }
    double t_out = pdr_now();
    /* Quality of the result. */
    ref_quality qs;
    ref_quality_range(&o.view, &qs);
    double t_q = pdr_now();
    if (!quiet) {
        printf("quality: radius-edge %.4f .. %.4f, dihedral %.2f .. %.2f degrees\n", qs.re_min,
               qs.re_max, qs.dih_min, qs.dih_max);
    }
    if (r.st.left_ratio || r.st.left_size || r.st.left_sliver || !quiet) {
        printf("left above the bound: %zu tetrahedra with radius-edge >= %g", r.st.left_ratio,
               ro.ratio);
        if (r.st.left_ratio)
            printf(" (%zu next to input angles too small to refine, %zu degenerate, %zu other)",
                   r.st.left_ratio_angle, r.st.left_ratio_degenerate,
                   r.st.left_ratio - r.st.left_ratio_angle - r.st.left_ratio_degenerate);
        if (r.st.left_size)
            printf(", %zu above the size bound", r.st.left_size);
        if (r.st.left_sliver)
            printf(", %zu with a dihedral angle below %g degrees", r.st.left_sliver,
                   ro.min_dihedral);
        printf("\n");
    }
    if (!quiet) {
        double total = t_out - t0;
        printf("time: read %.3f, initial mesh %.3f, refine %.3f, export %.3f, write %.3f, "
               "quality %.3f s\n",
               t_read - t0, t_mo - t_read, t_ref - t_mo, t_exp - t_ref, t_out - t_exp,
               t_q - t_out);
        printf("total: %.3f s to written mesh, %.0f tetrahedra/s, peak memory %.1f MB\n", total,
               total > 0 ? (double)nt / total : 0.0, (double)pdr_peak_rss() / 1048576.0);
    }
    if (check) {
        rc = self_check(&o, quiet);
        if (rc == PDR_ETOPOLOGY)
            goto done;
        if (rc)
            goto fail;
    }
    status = PDR_EXIT_OK;
    goto done;
fail:
    pdr_diag_print(&diag, stderr);
    pdr_cli_error("mesh", "%s", pdr_strerror(rc));
done:
    if (have_o)
        ref_output_free(&o);
    if (have_r)
        ref_free(&r);
    if (have_plc)
        plc_free(&p);
    pdr_diag_free(&diag);
    free(base);
    return status;
}
