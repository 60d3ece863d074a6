/* cli/cmd_mesh.c -- 'pdr mesh': guaranteed-quality tetrahedral mesh of a PLC
 * (TetGen .poly/.smesh, a surface file, or a built-in model problem). This file
 * is the command line: it parses the options into an mp_opts and runs the
 * stages of cli/mesh_pipeline.h in order. */
#include "config.h"

#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "cli/mesh_par.h"
#include "cli/mesh_pipeline.h"
#include "cli/pdr_cli.h"
#include "plc/dom.h"
#include "plc/fm.h"
#include "refine/refine.h"

/* Size bound of 'pdr mesh' without an input file: cube-in-cube meshed to
 * about 20 000 tetrahedra in well under a second. */
#define DEFAULT_DOMAIN_MAXVOL 1e-4

static void usage(FILE *f)
{
    fprintf(f,
            "Usage: pdr mesh [OPTIONS] [IN.poly | IN.smesh | IN.off | IN.stl | IN.ply |\n"
            "                           IN.obj | IN.mesh]\n"
            "       pdr mesh [OPTIONS] --domain cube-in-cube|tee|sphere\n\n"
            "Builds a Delaunay tetrahedral mesh of a piecewise linear complex whose\n"
            "tetrahedra have a circumradius to shortest edge ratio below B (Shewchuk's\n"
            "Delaunay refinement): conforming, or constrained for tessellated curved\n"
            "surfaces and inputs with acute vertices (--mo; tetrahedra left above B\n"
            "only next to input angles too small for it, counted and located in the\n"
            "summary). Without an input it meshes the built-in\n"
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
            "      --mo KIND        how the boundary is recovered and kept: 'auto'\n"
            "                       (default: 'cdt' for a surface file (.stl, .off,\n"
            "                       .ply, .obj, .mesh) and for an\n"
            "                       input with smooth segments (a tessellated curved\n"
            "                       surface) or acute vertices, else 'conform'),\n"
            "                       'conform' (a conforming Delaunay mesh:\n"
            "                       Shewchuk's recovery), 'cdt' (a constrained Delaunay\n"
            "                       tetrahedralization: the input's pieces are\n"
            "                       constraints, split only where quality asks; every\n"
            "                       face off the input's facets is locally Delaunay) or\n"
            "                       'paper' (Nave et al. section 2.1: segments below 2d,\n"
            "                       facets below d*sqrt(2))\n"
            "      --mo-only        stop after the initial mesh (no quality refinement)\n"
            "      --mo-size N      refine the initial mesh to about N tetrahedra with a\n"
            "                       volume bound (the parallel mesher's starting mesh)\n"
            "      --order ORDER    order of bad tetrahedra: lifo (default) or fifo\n"
            "      --rho R          small-angle safety net: refuse a boundary split whose\n"
            "                       insertion radius is below R times its cause's\n"
            "                       (default 0.354; 0 disables it)\n"
            "      --no-region-volume  ignore the volume bounds of the input's regions\n"
            "      --merge-angle A  input preparation: neighbouring triangles with the same\n"
            "                       marker whose dihedral angle is at least 180 - A degrees\n"
            "                       and that are coplanar (exactly, or within the planarity\n"
            "                       tolerance of facets) become one polygonal facet, the\n"
            "                       segment between them removed (default %g, TetGen's\n"
            "                       179.9 degrees; 0: exactly coplanar only)\n"
            "      --facet-tol T    input preparation: the merge also joins whole groups\n"
            "                       of coplanar triangles into facets planar only within\n"
            "                       T times the bounding-box diagonal (across edges where\n"
            "                       --merge-angle allows a merge), whose inner edges are\n"
            "                       no segments: CAD tessellations' strips, off one plane\n"
            "                       by the files' six digits. The mesh's boundary then\n"
            "                       lies within T of the input (no vertex moves). TetGen\n"
            "                       merges on the angle alone (179.9 degrees); T bounds the\n"
            "                       bend that angle would allow (a strip of width w bent\n"
            "                       by 0.1 degrees is off by 0.0017 w). Default %g; 0:\n"
            "                       exactly coplanar only; give pdr check the same value\n"
            "      --no-merge       keep every input triangle a facet\n"
            "      --presplit WHEN  constrained mode: before meshing, cut each segment\n"
            "                       whose facets lie within W of it into pieces shorter\n"
            "                       than 3 B W (every mesh with radius-edge below B cuts\n"
            "                       it below 4 B W: thin strips of tessellated cylinders;\n"
            "                       not at sharp segments or acute vertices): 'auto'\n"
            "                       (default: when the input has no sharp segment and no\n"
            "                       acute vertex), 'always' or 'never'\n"
            "      --max-points N   stop with an error after inserting N points (default:\n"
            "                       %.0f + %.0f per input vertex, segment and facet + %.0f\n"
            "                       per tetrahedron of the largest volume -a, -L or the\n"
            "                       regions allow that fits in the input's bounding box;\n"
            "                       0: no bound), so that a run that cannot finish says so\n"
            "                       instead of running on\n"
            "      --check          verify the result with exact predicates\n"
            "  -Q, --quiet          print only errors and warnings\n\n"
            "Parallel refinement (Nave, Chrisochoides and Chew; the paper's Table 1):\n"
            "  -n, --procs P        refine on P local PEs: starts P copies of this command\n"
            "                       with --parallel, like 'am-run -n P'\n"
            "      --parallel       this process is one PE of a job started by am-run,\n"
            "                       'pdr run', mpirun or srun (rank 0 reads the input and\n"
            "                       writes the merged mesh)\n"
            "      --parts N        partition the initial mesh into N >= P parts (default\n"
            "                       P; parts go to PEs round robin)\n"
            "      --max-threads K  cavity threads per PE (default 8)\n"
            "      --work-clock C   clock of Table 1's work times (completed, masked,\n"
            "                       setback): 'wall' (monotonic), 'cpu' (the PE's CPU time:\n"
            "                       leaves out time slices the kernel gives other PEs), or\n"
            "                       'auto' (default: cpu where PEs outnumber the cores)\n"
            "      --seed S         seed of the partition and of the back-off (default 1)\n"
            "      --rank0-points N without -a and --mo-size: rank 0 refines the initial\n"
            "                       mesh alone until N points were added (default 100000,\n"
            "                       about 4 10^5 tetrahedra), and the PEs go on from there; a\n"
            "                       mesh finished by then rank 0 writes alone (the\n"
            "                       sequential mesh; the summary says so); 0: the PEs\n"
            "                       refine the conforming mesh\n"
            "      --latency SPEC   with -n: inject latency per message (200us, 100us-1ms)\n"
            "      --bandwidth SPEC with -n: cap the bandwidth per link (100Mbit)\n"
            "      --sched POLICY   with -n: the PEs' scheduling policy: other (default),\n"
            "                       batch, fifo or rr (fifo, rr: root or CAP_SYS_NICE);\n"
            "                       with more PEs than cores fifo lets a PE run until it\n"
            "                       waits, as on a machine of its own\n"
            "      --cpu-bind MODE  with -n: none (default), core (each PE on a core of its\n"
            "                       own: steadier while other work runs) or auto (core\n"
            "                       where there are as many PEs as cores, not under fifo)\n"
            "      --stats DIR      with -n or --parallel: every PE writes\n"
            "                       DIR/table1-RANK.json (and, with -n, the runtime's\n"
            "                       DIR/stats-RANK.json); DIR and its missing parents\n"
            "                       are created (a sequential run writes none)\n"
            "      --submeshes      every PE also writes its part as BASE.pRANK.node/.ele\n"
            "With -a V the initial mesh of a parallel run is refined to about 10^5\n"
            "tetrahedra as in the paper, or a tenth of the expected final size if that is\n"
            "smaller; without -a it is the conforming mesh refined by rank 0 alone up to\n"
            "--rank0-points; --mo-size N sets it.\n"
            "The summary's PE memory line gives each PE's peak resident memory per\n"
            "tetrahedron it holds at the end (rank 0: up to the merge, and over the whole\n"
            "run per tetrahedron of the merged mesh): RSS, RSS without the program's and\n"
            "libraries' pages read from their files (which all PEs share), and PSS.\n"
            "A parallel run stops every PE with an error, and writes nothing, when a PE\n"
            "makes no progress (over a stretch of its work, fewer than one point\n"
            "inserted per 1024 units: 16 per cavity attempt, 1 per tetrahedron migrated\n"
            "in or created; or no point at all in 60 s of attempts) or inserts\n"
            "--max-points points by itself.\n"
            "  -h, --help           show this help\n\n"
            "Input errors are reported as FILE:LINE: message and nothing is written. Files\n"
            "are written atomically. The summary gives counts, seconds per phase,\n"
            "tetrahedra per second, peak memory, the radius-edge and dihedral angle\n"
            "ranges and how many tetrahedra were left above the bound (only near input\n"
            "angles too small for the algorithm) and why.\n\n"
            "Exit status: 0 done, 1 failed (bad input, out of memory), 2 usage error.\n",
            DEFAULT_DOMAIN_MAXVOL, FM_MERGE_ANGLE, FM_FACET_TOL, REF_LIMIT_BASE, REF_LIMIT_PER_INPUT,
            REF_LIMIT_PER_SIZE);
}

/* "-f node,vtu": the MP_FMT_* bits of a comma-separated list. Returns 0,
 * or -1 for an unknown name (or no memory to split the list). */
static int parse_formats(const char *s, unsigned *out)
{
    static const struct {
        const char *name;
        unsigned fmt;
    } names[] = {{"node", MP_FMT_NODE}, {"ele", MP_FMT_NODE}, {"tetgen", MP_FMT_NODE},
                 {"vtu", MP_FMT_VTU},   {"vtk", MP_FMT_VTU},  {"msh", MP_FMT_MSH},
                 {"gmsh", MP_FMT_MSH},  {"none", 0}};
    unsigned f = 0;
    int ok = 1;
    /* Words between commas, compared in place (no copy to allocate). */
    for (const char *w = s; *w;) {
        size_t n = strcspn(w, ",");
        if (n > 0) {
            size_t i = 0;
            while (i < sizeof names / sizeof names[0] &&
                   (strlen(names[i].name) != n || strncmp(w, names[i].name, n)))
                i++;
            if (i < sizeof names / sizeof names[0])
                f |= names[i].fmt;
            else
                ok = 0;
        }
        w += n;
        if (*w == ',')
            w++;
    }
    *out = f;
    return ok ? 0 : -1;
}

/* A finite number and nothing else. Returns 0 or -1. */
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

/* Long options without a short letter. */
enum {
    O_DOMAIN = 256, O_MO, O_MO_ONLY, O_MO_SIZE, O_ORDER, O_RHO, O_NOREGVOL, O_CHECK, O_MINDIH,
    O_PARALLEL, O_PARTS, O_THREADS, O_SEED, O_LATENCY, O_BANDWIDTH, O_SCHED, O_CPU_BIND, O_STATS, O_SUBMESHES,
    O_MERGE, O_NOMERGE, O_PRESPLIT, O_MAXPOINTS, O_WORKCLOCK, O_FACETTOL, O_RANK0_POINTS
};

static const struct option long_opts[] = {{"quality", required_argument, NULL, 'q'},
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
                                          {"procs", required_argument, NULL, 'n'},
                                          {"parallel", no_argument, NULL, O_PARALLEL},
                                          {"parts", required_argument, NULL, O_PARTS},
                                          {"max-threads", required_argument, NULL, O_THREADS},
                                          {"work-clock", required_argument, NULL, O_WORKCLOCK},
                                          {"seed", required_argument, NULL, O_SEED},
                                          {"rank0-points", required_argument, NULL, O_RANK0_POINTS},
                                          {"latency", required_argument, NULL, O_LATENCY},
                                          {"bandwidth", required_argument, NULL, O_BANDWIDTH},
                                          {"sched", required_argument, NULL, O_SCHED},
                                          {"cpu-bind", required_argument, NULL, O_CPU_BIND},
                                          {"stats", required_argument, NULL, O_STATS},
                                          {"submeshes", no_argument, NULL, O_SUBMESHES},
                                          {"merge-angle", required_argument, NULL, O_MERGE},
                                          {"no-merge", no_argument, NULL, O_NOMERGE},
                                          {"presplit", required_argument, NULL, O_PRESPLIT},
                                          {"facet-tol", required_argument, NULL, O_FACETTOL},
                                          {"max-points", required_argument, NULL, O_MAXPOINTS},
                                          {"help", no_argument, NULL, 'h'},
                                          {NULL, 0, NULL, 0}};

/* -q B or -q B/D (TetGen's form, which also gives the smallest dihedral
 * angle). The slash is overwritten, so that a bad B is quoted alone.
 * Returns 0 or PDR_EXIT_USAGE after the message. */
static int parse_quality(char *arg, ref_opts *ro)
{
    double x;
    char *slash = strchr(arg, '/');
    if (slash) {
        *slash = 0;
        if (parse_double(slash + 1, &x) || x < 0 || x >= 60) {
            pdr_cli_error("mesh", "-q B/D needs an angle D in [0, 60) degrees, not '%s'",
                          slash + 1);
            return PDR_EXIT_USAGE;
        }
        ro->min_dihedral = x;
    }
    if (parse_double(arg, &x) || !(x > 1.0)) {
        pdr_cli_error("mesh", "-q needs a radius-edge bound greater than 1, not '%s'", arg);
        return PDR_EXIT_USAGE;
    }
    ro->ratio = x;
    return 0;
}

/* The options that take a number: checks the range and stores it.
 * Returns 0 or PDR_EXIT_USAGE after the message. */
static int parse_number(int c, const char *arg, mp_opts *o)
{
    double x = 0;
    int bad = parse_double(arg, &x);
    switch (c) {
    case O_MINDIH:
        if (bad || x < 0 || x >= 60) {
            pdr_cli_error("mesh", "--min-dihedral needs an angle in [0, 60) degrees, not '%s'",
                          arg);
            return PDR_EXIT_USAGE;
        }
        o->ref.min_dihedral = x;
        return 0;
    case 'a':
        if (bad || !(x > 0.0)) {
            pdr_cli_error("mesh", "-a needs a positive volume, not '%s'", arg);
            return PDR_EXIT_USAGE;
        }
        o->ref.maxvol = x;
        return 0;
    case 'L':
        if (bad || !(x > 0.0)) {
            pdr_cli_error("mesh", "-L needs a positive length, not '%s'", arg);
            return PDR_EXIT_USAGE;
        }
        o->ref.maxedge = x;
        return 0;
    case O_MAXPOINTS:
        if (bad || x < 0 || x != floor(x)) {
            pdr_cli_error("mesh", "--max-points needs a number of points (0: no bound), not '%s'",
                          arg);
            return PDR_EXIT_USAGE;
        }
        o->max_points = x;
        return 0;
    case O_MO_SIZE:
        if (bad || !(x >= 1)) {
            pdr_cli_error("mesh", "--mo-size needs a number of tetrahedra, not '%s'", arg);
            return PDR_EXIT_USAGE;
        }
        o->mo_size = x;
        return 0;
    default: /* O_RHO */
        if (bad || x < 0 || x >= 1) {
            pdr_cli_error("mesh", "--rho needs a number in [0, 1), not '%s'", arg);
            return PDR_EXIT_USAGE;
        }
        o->ref.rho = x;
        return 0;
    }
}

/* The options that take a word. Returns 0 or PDR_EXIT_USAGE after the
 * message. */
static int parse_word(int c, const char *arg, mp_opts *o)
{
    switch (c) {
    case 'f':
        if (parse_formats(arg, &o->formats)) {
            pdr_cli_error("mesh", "unknown output format in '%s' (node, vtu, msh, none)", arg);
            return PDR_EXIT_USAGE;
        }
        return 0;
    case O_MO:
        if (strcmp(arg, "paper") && strcmp(arg, "conform") && strcmp(arg, "cdt") &&
            strcmp(arg, "auto")) {
            pdr_cli_error("mesh", "--mo is 'auto', 'conform', 'cdt' or 'paper', not '%s'", arg);
            return PDR_EXIT_USAGE;
        }
        o->mo.paper = !strcmp(arg, "paper");
        o->ref.constrained = !strcmp(arg, "cdt");
        o->mo_auto = !strcmp(arg, "auto");
        return 0;
    default: /* O_ORDER */
        if (strcmp(arg, "lifo") && strcmp(arg, "fifo")) {
            pdr_cli_error("mesh", "--order is 'lifo' or 'fifo', not '%s'", arg);
            return PDR_EXIT_USAGE;
        }
        o->ref.order = strcmp(arg, "lifo") ? REF_ORDER_FIFO : REF_ORDER_LIFO;
        return 0;
    }
}

/* The options of the parallel refinement that take a number. Returns 0
 * or PDR_EXIT_USAGE after the message. */
static int parse_par_number(int c, const char *arg, mpar_opts *po)
{
    char *end;
    errno = 0;
    unsigned long long v = strtoull(arg, &end, 10);
    int bad = errno || end == arg || *end || arg[0] == '-';
    switch (c) {
    case 'n':
        if (bad || v < 1 || v > 4096) {
            pdr_cli_error("mesh", "-n needs a number of PEs from 1 to 4096, not '%s'", arg);
            return PDR_EXIT_USAGE;
        }
        po->nprocs = (int)v;
        return 0;
    case O_PARTS:
        if (bad || v < 1 || v > 1000000) {
            pdr_cli_error("mesh", "--parts needs a positive number of parts, not '%s'", arg);
            return PDR_EXIT_USAGE;
        }
        po->parts = (uint32_t)v;
        return 0;
    case O_RANK0_POINTS:
        if (bad || v > 1000000000) {
            pdr_cli_error("mesh", "--rank0-points needs a number of points (0: none), not '%s'",
                          arg);
            return PDR_EXIT_USAGE;
        }
        po->rank0_points = (long)v;
        return 0;
    case O_THREADS:
        if (bad || v < 1 || v > 4096) {
            pdr_cli_error("mesh", "--max-threads needs a number from 1 to 4096, not '%s'", arg);
            return PDR_EXIT_USAGE;
        }
        po->max_threads = (int)v;
        return 0;
    default: /* O_SEED */
        if (bad) {
            pdr_cli_error("mesh", "--seed needs a non-negative integer, not '%s'", arg);
            return PDR_EXIT_USAGE;
        }
        po->seed = v;
        return 0;
    }
}

/* The input: one file, or a domain, or by default the cube-in-cube with
 * its own volume bound (unless -a gave one). Returns 0 or PDR_EXIT_USAGE
 * after the message. */
static int parse_input(int argc, char **argv, int have_a, mp_opts *o)
{
    if (optind < argc - 1 || (optind < argc && o->domain)) {
        pdr_cli_error("mesh", "give one input file or --domain, not both or several");
        return PDR_EXIT_USAGE;
    }
    o->in = optind < argc ? argv[optind] : NULL;
    if (!o->in && !o->domain) {
        o->domain = "cube-in-cube";
        if (!have_a)
            o->ref.maxvol = DEFAULT_DOMAIN_MAXVOL;
    }
    if (o->domain && dom_lookup(o->domain) < 0) {
        pdr_cli_error("mesh", "unknown domain '%s' (cube-in-cube, tee, sphere)", o->domain);
        return PDR_EXIT_USAGE;
    }
    return 0;
}

/* What parse_args returns when the pipeline is to run. */
#define RUN_PIPELINE (-1)

/* Parses the command line into *o. Returns RUN_PIPELINE, or the exit
 * status when the command is done already: --help, or a usage error
 * (after its message). */
static int parse_args(int argc, char **argv, mp_opts *o, mpar_opts *po)
{
    int have_a = 0, c, rc = 0;
    mp_default_opts(o);
    mpar_default_opts(po);
    /* 0, not 1: glibc (and musl) then also forget where an earlier parse
     * stopped inside a cluster of short options ("-Qh"), which would
     * otherwise be read from that parse's argv. */
    optind = 0;
    while (!rc && (c = getopt_long(argc, argv, "q:a:L:o:f:Qhn:", long_opts, NULL)) != -1) {
        switch (c) {
        case 'q':
            rc = parse_quality(optarg, &o->ref);
            break;
        case 'a':
            have_a = 1;
            rc = parse_number(c, optarg, o);
            break;
        case 'L':
        case O_MINDIH:
        case O_MO_SIZE:
        case O_RHO:
        case O_MAXPOINTS:
            rc = parse_number(c, optarg, o);
            break;
        case 'f':
        case O_MO:
        case O_ORDER:
            rc = parse_word(c, optarg, o);
            break;
        case 'o':
            o->out = optarg;
            break;
        case O_DOMAIN:
            o->domain = optarg;
            break;
        case O_MO_ONLY:
            o->mo_only = 1;
            break;
        case O_NOREGVOL:
            o->ref.use_region_maxvol = 0;
            break;
        case O_MERGE:
            if (pdr_cli_merge_angle("mesh", optarg, &o->merge_angle))
                rc = PDR_EXIT_USAGE;
            break;
        case O_NOMERGE:
            o->merge_angle = -1;
            break;
        case O_PRESPLIT:
            if (!strcmp(optarg, "auto")) {
                o->presplit = MP_PRESPLIT_AUTO;
            } else if (!strcmp(optarg, "always")) {
                o->presplit = MP_PRESPLIT_ALWAYS;
            } else if (!strcmp(optarg, "never")) {
                o->presplit = MP_PRESPLIT_NEVER;
            } else {
                pdr_cli_error("mesh", "--presplit: '%s' is none of auto, always, never", optarg);
                rc = PDR_EXIT_USAGE;
            }
            break;
        case O_FACETTOL:
            if (pdr_cli_facet_tol("mesh", optarg, &o->facet_tol))
                rc = PDR_EXIT_USAGE;
            break;
        case O_CHECK:
            o->check = 1;
            break;
        case 'Q':
            o->quiet = 1;
            break;
        case 'n':
        case O_PARTS:
        case O_THREADS:
        case O_SEED:
        case O_RANK0_POINTS:
            rc = parse_par_number(c, optarg, po);
            break;
        case O_PARALLEL:
            po->parallel = 1;
            break;
        case O_LATENCY:
            po->latency = optarg;
            break;
        case O_BANDWIDTH:
            po->bandwidth = optarg;
            break;
        case O_SCHED:
            po->sched = optarg;
            break;
        case O_CPU_BIND:
            po->cpu_bind = optarg;
            break;
        case O_STATS:
            po->stats = optarg;
            break;
        case O_SUBMESHES:
            po->submeshes = 1;
            break;
        case O_WORKCLOCK:
            if (!strcmp(optarg, "auto"))
                po->work_clock = MPAR_CLOCK_AUTO;
            else if (!strcmp(optarg, "wall"))
                po->work_clock = MPAR_CLOCK_WALL;
            else if (!strcmp(optarg, "cpu"))
                po->work_clock = MPAR_CLOCK_CPU;
            else {
                pdr_cli_error("mesh", "--work-clock is 'auto', 'wall' or 'cpu', not '%s'", optarg);
                return PDR_EXIT_USAGE;
            }
            break;
        case 'h':
            usage(stdout);
            return PDR_EXIT_OK;
        default:
            fprintf(stderr, "Try 'pdr mesh --help'.\n");
            return PDR_EXIT_USAGE;
        }
    }
    if (!rc)
        rc = parse_input(argc, argv, have_a, o);
    if (rc)
        return rc;
    if (o->ref.ratio < 2.0)
        fprintf(stderr,
                "pdr mesh: warning: with -q %g below 2, termination is not guaranteed "
                "(refinement is attempted)\n",
                o->ref.ratio);
    return RUN_PIPELINE;
}

/* The stages up to the mesh in memory; each one that fails has told the
 * user why. *read says whether the input was read and prepared. */
static int mesh_stages(mp_ctx *c, int *read)
{
    int rc = mp_read(c);
    *read = !rc;
    if (!rc)
        rc = mp_initial_mesh(c);
    if (!rc && !c->o.mo_only)
        rc = mp_refine(c);
    if (!rc)
        rc = mp_export(c);
    return rc;
}

/* The stages in order; when the mesh fails with near-planar facets it is
 * made again with exact facets (mp_retry_exact_facets), whose boundary
 * lies on the input's triangles, which pdr check --facet-tol accepts as
 * well. */
static int run_pipeline(mp_ctx *c, const mp_opts *opts)
{
    int read, rc;
    do
        rc = mesh_stages(c, &read);
    while (mp_retry_exact_facets(c, opts, rc, read));
    return rc ? rc : mp_conclude(c, NULL, NULL);
}

int pdr_cmd_mesh(int argc, char **argv)
{
    mp_opts o;
    mpar_opts po;
    int status = parse_args(argc, argv, &o, &po);
    if (status != RUN_PIPELINE)
        return status;
    if (po.parts && po.nprocs && po.parts < (uint32_t)po.nprocs) {
        pdr_cli_error("mesh", "--parts %u is fewer than the %d PEs", po.parts, po.nprocs);
        return PDR_EXIT_USAGE;
    }
    if ((po.latency || po.bandwidth || po.sched || po.cpu_bind) && !po.nprocs) {
        pdr_cli_error("mesh", "--latency, --bandwidth, --sched and --cpu-bind go with -n (the "
                              "launcher applies them)");
        return PDR_EXIT_USAGE;
    }
    if (pdr_cli_parse_only)
        return PDR_EXIT_OK;
    if (po.nprocs && !po.parallel)
        return mpar_launch(argc, argv, &po);
    /* The refinement's debugging aids, turned on from the environment
     * here because the library reads none: PDR_REF_CHECK checks the marks
     * against the subsegment and subfacet tables before every step (slow)
     * and fails at the first disagreement, described on stderr
     * (PDR_REF_CHECK=end: with -n, once on every PE when its refinement
     * ends, which is affordable on large meshes);
     * PDR_REF_TRACE=N prints the queues and counters every N steps. */
    const char *check = getenv("PDR_REF_CHECK");
    if (check) {
        po.check_end = !strcmp(check, "end");
        o.ref.check_each_step = !po.check_end;
        o.ref.log = stderr;
    }
    const char *trace = getenv("PDR_REF_TRACE");
    if (trace && atol(trace) > 0) {
        o.ref.trace = stderr;
        o.ref.trace_every = (size_t)atol(trace);
    }
    if (po.parallel)
        return mpar_run(&o, &po);
    mp_ctx c;
    mp_init(&c, &o);
    int rc = run_pipeline(&c, &o);
    mp_free(&c);
    return rc ? PDR_EXIT_FAIL : PDR_EXIT_OK;
}
