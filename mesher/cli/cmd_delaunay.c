/* cli/cmd_delaunay.c -- 'pdr delaunay': Delaunay tetrahedralization of a point
 * set (a TetGen .node file, or random points), with a summary of time and
 * memory. */
#include "config.h"

#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "pr_alloc.h"
#include "mesh/dt.h"
#include "io/tg.h"
#include "cli/pdr_cli.h"
#include "base/pdr_util.h"
#include "mesh/tm.h"
#include "mesh/vf.h"

static void usage(FILE *f)
{
    fprintf(f,
            "Usage: pdr delaunay [OPTIONS] IN.node\n"
            "       pdr delaunay [OPTIONS] --random N\n\n"
            "Builds the Delaunay tetrahedralization of the points of a TetGen .node file\n"
            "(or of N random points in the unit cube) and prints a summary: counts, time,\n"
            "tetrahedra per second and memory. Exactly cospherical and coplanar points\n"
            "(grids) are handled exactly; duplicate points are skipped and counted.\n\n"
            "Options:\n"
            "  -o, --output BASE  write BASE.node and BASE.ele (TetGen format, numbered\n"
            "                     from the input's first index; 1 with --random)\n"
            "      --faces        also write the convex hull faces to BASE.face\n"
            "      --points-only  write BASE.node (with --random: the points) and stop\n"
            "      --random N     use N points uniform in [0,1)^3 instead of a file\n"
            "      --seed S       seed of --random and of the insertion order (default 1)\n"
            "      --check        verify the result with exact predicates (as pdr check)\n"
            "  -q, --quiet        print nothing but errors\n"
            "  -h, --help         show this help\n\n"
            "Without -o nothing is written. Exit status: 0 done, 1 failed (bad input,\n"
            "out of memory, check failed), 2 usage error.\n");
}

static uint64_t splitmix(uint64_t *s)
{
    uint64_t z = (*s += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

/* dt_build's progress callback: a pdr_progress line on stderr. */
static void show_progress(void *arg, size_t done, size_t total)
{
    pdr_progress_line(arg, "pdr delaunay: %zu of %zu points inserted (%.0f%%)", done, total,
                      100.0 * (double)done / (double)total);
}

int pdr_cmd_delaunay(int argc, char **argv)
{
    static const struct option opts[] = {{"output", required_argument, NULL, 'o'},
                                         {"faces", no_argument, NULL, 'F'},
                                         {"points-only", no_argument, NULL, 'P'},
                                         {"random", required_argument, NULL, 'r'},
                                         {"seed", required_argument, NULL, 's'},
                                         {"check", no_argument, NULL, 'c'},
                                         {"quiet", no_argument, NULL, 'q'},
                                         {"help", no_argument, NULL, 'h'},
                                         {NULL, 0, NULL, 0}};
    const char *out = NULL;
    int faces = 0, check = 0, quiet = 0, points_only = 0;
    long long nrandom = -1;
    unsigned long long seed = 1;
    int c;
    char *end;
    /* 0, not 1: glibc (and musl) then also forget where an earlier parse
     * stopped inside a cluster of short options ("-Qh"), which would
     * otherwise be read from that parse's argv. */
    optind = 0;
    while ((c = getopt_long(argc, argv, "o:qh", opts, NULL)) != -1) {
        switch (c) {
        case 'o':
            out = optarg;
            break;
        case 'F':
            faces = 1;
            break;
        case 'P':
            points_only = 1;
            break;
        case 'r':
            nrandom = strtoll(optarg, &end, 10);
            if (*end || end == optarg || nrandom < 0 || nrandom > (long long)TM_MAX_VERTS - 2) {
                pdr_cli_error("delaunay", "--random: '%s' is not a valid point count", optarg);
                return PDR_EXIT_USAGE;
            }
            break;
        case 's':
            seed = strtoull(optarg, &end, 10);
            if (*end || end == optarg) {
                pdr_cli_error("delaunay", "--seed: '%s' is not a number", optarg);
                return PDR_EXIT_USAGE;
            }
            break;
        case 'c':
            check = 1;
            break;
        case 'q':
            quiet = 1;
            break;
        case 'h':
            usage(stdout);
            return PDR_EXIT_OK;
        default:
            fprintf(stderr, "Try 'pdr delaunay --help'.\n");
            return PDR_EXIT_USAGE;
        }
    }
    const char *in = NULL;
    if (nrandom >= 0) {
        if (optind != argc) {
            pdr_cli_error("delaunay", "--random and an input file are exclusive");
            return PDR_EXIT_USAGE;
        }
    } else {
        if (optind + 1 != argc) {
            pdr_cli_error("delaunay", optind == argc ? "no input file (try --help)"
                                                     : "more than one input file");
            return PDR_EXIT_USAGE;
        }
        in = argv[optind];
    }
    if ((faces || points_only) && !out) {
        pdr_cli_error("delaunay", "--%s needs -o BASE", faces ? "faces" : "points-only");
        return PDR_EXIT_USAGE;
    }
    if (pdr_cli_parse_only)
        return PDR_EXIT_OK;

    int status = PDR_EXIT_FAIL;
    pdr_diag diag = {0};
    tg_nodes nodes = {0};
    tm_mesh m;
    int have_mesh = 0;
    char *pnode = NULL, *pele = NULL, *pface = NULL;
    double t_start = pdr_now();

    /* 1. Points. */
    if (in) {
        int rrc = tg_read_node(in, &nodes, &diag);
        if (rrc) {
            pdr_cli_fail("delaunay", &diag, rrc);
            goto done;
        }
    } else {
        nodes.n = nrandom > 0 && nrandom < (1LL << 34) ? (size_t)nrandom : 0;
        nodes.first = 1;
        nodes.xyz = pr_calloc(nodes.n * 3 + 1, sizeof(double));
        if (!nodes.xyz) {
            pdr_cli_error("delaunay", "out of memory for %zu points", nodes.n);
            goto done;
        }
        uint64_t s = seed;
        for (size_t i = 0; i < 3 * nodes.n; i++)
            nodes.xyz[i] = (double)(splitmix(&s) >> 11) * 0x1p-53;
    }
    double t_read = pdr_now();
    if (points_only) {
        pnode = pdr_path_join(out, ".node");
        int wrc = pnode ? tg_write_node(pnode, &nodes, NULL, &diag) : PDR_ENOMEM;
        if (wrc) {
            pdr_cli_fail("delaunay", &diag, wrc);
            goto done;
        }
        if (!quiet)
            printf("points:               %zu (written to %s)\n", nodes.n, pnode);
        status = PDR_EXIT_OK;
        goto done;
    }
    if (nodes.n < 4) {
        if (in)
            pdr_cli_error("delaunay", "%s: %zu point%s: a tetrahedralization needs at least 4",
                          in, nodes.n, nodes.n == 1 ? "" : "s");
        else
            pdr_cli_error("delaunay", "--random %zu: at least 4 points are needed", nodes.n);
        goto done;
    }

    /* 2. The mesh. */
    if (tm_init(&m, 0)) {
        pdr_cli_error("delaunay", "out of memory");
        goto done;
    }
    have_mesh = 1;
    int rc = tm_reserve(&m, nodes.n + 1, nodes.n * 7 + 64);
    for (size_t i = 0; i < nodes.n && !rc; i++) {
        uint32_t v;
        rc = tm_add_vertex(&m, nodes.xyz + 3 * i, &v);
    }
    if (rc) {
        pdr_cli_error("delaunay", "%s", pdr_strerror(rc));
        goto done;
    }
    if (!out) { /* the mesh has its own copy: keep the peak memory down */
        pr_free(nodes.xyz);
        nodes.xyz = NULL;
    }
    pdr_progress prog;
    pdr_progress_start(&prog, t_read, quiet);
    dt_build_opts bo = {.seed = seed, .renumber = 1, .progress = show_progress, .progress_arg = &prog};
    dt_build_stats st;
    rc = dt_build(&m, &bo, &st);
    pdr_progress_end(&prog);
    if (rc == PDR_EGEOMETRY) {
        pdr_cli_error("delaunay",
                      "%s: the points are all coplanar (or fewer than 4 are distinct): "
                      "there is no tetrahedralization",
                      in ? in : "--random");
        goto done;
    }
    if (rc) {
        pdr_cli_error("delaunay", "%s", pdr_strerror(rc));
        goto done;
    }
    double t_built = pdr_now();
    size_t ntets = m.nlive - m.nghost;
    size_t mesh_bytes = tm_bytes_used(&m);
    size_t rss = pdr_peak_rss();

    /* 3. Check. */
    int check_failed = 0;
    if (check) {
        vf_report r = {0};
        if (vf_check(&m, VF_ALL, &r)) {
            pdr_cli_error("delaunay", "out of memory while checking");
            goto done;
        }
        if (vf_defects(&r)) {
            vf_print(&r, stderr);
            check_failed = 1;
        }
    }
    double t_checked = pdr_now();

    /* 4. Output. */
    if (out) {
        pnode = pdr_path_join(out, ".node");
        pele = pdr_path_join(out, ".ele");
        pface = pdr_path_join(out, ".face");
        if (!pnode || !pele || !pface) {
            pdr_cli_error("delaunay", "out of memory");
            goto done;
        }
        /* All files or none: they wait in the set until the last is
         * written. */
        outset set = OUTSET_INIT;
        int wrc = tg_write_node(pnode, &nodes, &set, &diag);
        if (!wrc)
            wrc = tg_write_ele(pele, &m, nodes.first, &set, &diag);
        if (!wrc && faces)
            wrc = tg_write_face(pface, &m, nodes.first, &set, &diag);
        if (wrc)
            outset_abort(&set);
        else
            wrc = outset_commit(&set, &diag);
        if (wrc) {
            pdr_cli_fail("delaunay", &diag, wrc);
            goto done;
        }
    }
    double t_written = pdr_now();

    if (!quiet) {
        double dt = st.sort_seconds + st.insert_seconds;
        printf("points:               %zu\n", nodes.n);
        printf("duplicate points:     %zu (skipped)\n", st.duplicates);
        printf("tetrahedra:           %zu\n", ntets);
        printf("convex hull faces:    %u\n", m.nghost);
        printf("read seconds:         %.3f\n", t_read - t_start);
        printf("delaunay seconds:     %.3f (sort %.3f, insert %.3f)\n", dt, st.sort_seconds,
               st.insert_seconds);
        printf("tetrahedra per second: %.0f\n", dt > 0 ? (double)ntets / dt : 0.0);
        if (check)
            printf("check seconds:        %.3f (%s)\n", t_checked - t_built,
                   check_failed ? "FAILED" : "ok");
        if (out)
            printf("write seconds:        %.3f (%s.node, %s.ele%s)\n", t_written - t_checked, out,
                   out, faces ? ", .face" : "");
        printf("mesh bytes per tet:   %.1f (%g bytes per tet slot, %zu per vertex)\n",
               ntets ? (double)mesh_bytes / (double)ntets : 0.0, tm_bytes_per_tet(&m),
               tm_bytes_per_vertex(&m));
        printf("peak RSS bytes:       %zu (%.1f per tet)\n", rss,
               ntets ? (double)rss / (double)ntets : 0.0);
    }
    status = check_failed ? PDR_EXIT_FAIL : PDR_EXIT_OK;
done:
    if (have_mesh)
        tm_free(&m);
    tg_nodes_free(&nodes);
    pdr_diag_free(&diag);
    pr_free(pnode);
    pr_free(pele);
    pr_free(pface);
    return status;
}
