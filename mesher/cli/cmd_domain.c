/* cli/cmd_domain.c -- 'pdr domain': write the paper's model problems (and a
 * tessellated sphere) as TetGen .poly files. */
#include "config.h"

#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "plc/dom.h"
#include "cli/pdr_cli.h"
#include "plc/plc.h"

static void usage(FILE *out)
{
    fprintf(out,
            "Usage: pdr domain cube-in-cube [--outer L] [--inner L] [-o OUT.poly]\n"
            "       pdr domain tee [--length L] [--width W] [--height H] [--flange T]\n"
            "                      [--web W] [--angle DEG] [-o OUT.poly]\n"
            "       pdr domain sphere [--radius R] [--level N] [-o OUT.poly]\n"
            "\n"
            "Writes one of the two model problems of Nave, Chrisochoides and Chew,\n"
            "or a tessellated sphere, as a TetGen .poly file (default NAME.poly),\n"
            "after checking it with the same validation the mesher applies to its\n"
            "input.\n"
            "\n"
            "cube-in-cube  the cube [0,L]^3 with a suspended cubical void centred in\n"
            "              it; the void is a hole (its facets plus a hole point).\n"
            "  --outer L     side of the cube (default 1)\n"
            "  --inner L     side of the void (default 0.5)\n"
            "              Facet markers: 1 outer cube, 2 void.\n"
            "\n"
            "tee           a half-tee brace: a T-section beam along x, cut in half\n"
            "              along the web's symmetry plane y = 0. The flange's outer\n"
            "              edge is bevelled and the far end is mitred, both meeting\n"
            "              the underside at --angle degrees, so the boundary has\n"
            "              dihedral angles below 90 degrees.\n"
            "  --length L    length along x (default 4)\n"
            "  --width W     flange half-width along y (default 1)\n"
            "  --height H    total height along z (default 1.5)\n"
            "  --flange T    flange thickness (default 0.25)\n"
            "  --web W       web half-thickness (default 0.125)\n"
            "  --angle DEG   bevel and mitre angle, 0 < DEG <= 90 (default 60)\n"
            "              Facet markers: 1 square end, 2 mitred end, 3 underside,\n"
            "              4 bevel, 5 flange top, 6 web side, 7 web top, 8 symmetry\n"
            "              plane.\n"
            "\n"
            "sphere        a ball whose surface is an icosahedron subdivided N times\n"
            "              (20 * 4^N triangles, each a facet): many small facets at\n"
            "              nearly flat angles, as in tessellated CAD surfaces.\n"
            "  --radius R    radius (default 1)\n"
            "  --level N     subdivisions, 0 to 7 (default 4: 5120 triangles)\n"
            "              Facet marker: 1.\n"
            "\n"
            "Options:\n"
            "  -o, --output FILE   where to write (default NAME.poly in the current\n"
            "                      directory)\n"
            "  -h, --help          this text\n");
}

enum { OPT_OUTER = 256, OPT_INNER, OPT_LENGTH, OPT_WIDTH, OPT_HEIGHT, OPT_FLANGE,
       OPT_WEB, OPT_ANGLE, OPT_RADIUS, OPT_LEVEL };

static int parse_num(const char *opt, const char *arg, double *out)
{
    char *end;
    errno = 0;
    double v = strtod(arg, &end);
    if (end == arg || *end || errno || !isfinite(v)) {
        pdr_cli_error("domain", "--%s: '%s' is not a number", opt, arg);
        return -1;
    }
    *out = v;
    return 0;
}

int pdr_cmd_domain(int argc, char **argv)
{
    static const struct option opts[] = {
        {"output", required_argument, NULL, 'o'}, {"help", no_argument, NULL, 'h'},
        {"outer", required_argument, NULL, OPT_OUTER},
        {"inner", required_argument, NULL, OPT_INNER},
        {"length", required_argument, NULL, OPT_LENGTH},
        {"width", required_argument, NULL, OPT_WIDTH},
        {"height", required_argument, NULL, OPT_HEIGHT},
        {"flange", required_argument, NULL, OPT_FLANGE},
        {"web", required_argument, NULL, OPT_WEB},
        {"angle", required_argument, NULL, OPT_ANGLE},
        {"radius", required_argument, NULL, OPT_RADIUS},
        {"level", required_argument, NULL, OPT_LEVEL},
        {NULL, 0, NULL, 0}};
    dom_cube_opts cube;
    dom_tee_opts tee;
    dom_sphere_opts sphere;
    dom_cube_defaults(&cube);
    dom_tee_defaults(&tee);
    dom_sphere_defaults(&sphere);
    const char *out = NULL;
    double level = sphere.level;
    /* how many options of each domain were given */
    int given[DOM_COUNT] = {0}, c, idx;
    /* 0, not 1: glibc (and musl) then also forget where an earlier parse
     * stopped inside a cluster of short options ("-Qh"), which would
     * otherwise be read from that parse's argv. */
    optind = 0;
    while ((c = getopt_long(argc, argv, "o:h", opts, &idx)) != -1) {
        double *dst = NULL;
        switch (c) {
        case 'o':
            out = optarg;
            continue;
        case 'h':
            usage(stdout);
            return PDR_EXIT_OK;
        case OPT_OUTER: dst = &cube.outer; given[DOM_CUBE_IN_CUBE]++; break;
        case OPT_INNER: dst = &cube.inner; given[DOM_CUBE_IN_CUBE]++; break;
        case OPT_LENGTH: dst = &tee.length; given[DOM_TEE]++; break;
        case OPT_WIDTH: dst = &tee.width; given[DOM_TEE]++; break;
        case OPT_HEIGHT: dst = &tee.height; given[DOM_TEE]++; break;
        case OPT_FLANGE: dst = &tee.flange; given[DOM_TEE]++; break;
        case OPT_WEB: dst = &tee.web; given[DOM_TEE]++; break;
        case OPT_ANGLE: dst = &tee.angle; given[DOM_TEE]++; break;
        case OPT_RADIUS: dst = &sphere.radius; given[DOM_SPHERE]++; break;
        case OPT_LEVEL: dst = &level; given[DOM_SPHERE]++; break;
        default:
            usage(stderr);
            return PDR_EXIT_USAGE;
        }
        if (parse_num(opts[idx].name, optarg, dst))
            return PDR_EXIT_USAGE;
    }
    if (optind != argc - 1) {
        pdr_cli_error("domain", optind == argc ? "which domain? cube-in-cube, tee or sphere"
                                               : "unexpected argument '%s'",
                      argv[argc - 1]);
        return PDR_EXIT_USAGE;
    }
    const char *name = argv[optind];
    int which = dom_lookup(name);
    if (which < 0) {
        pdr_cli_error("domain", "unknown domain '%s' (cube-in-cube, tee or sphere)", name);
        return PDR_EXIT_USAGE;
    }
    for (int k = 0; k < DOM_COUNT; k++)
        if (k != which && given[k]) {
            pdr_cli_error("domain", "%s options given for %s", dom_name(k), name);
            return PDR_EXIT_USAGE;
        }
    if (level != floor(level) || level < 0 || level > 7) {
        pdr_cli_error("domain", "--level: %g is not a whole number from 0 to 7", level);
        return PDR_EXIT_USAGE;
    }
    sphere.level = (int)level;
    char defname[32];
    if (!out) {
        snprintf(defname, sizeof defname, "%s.poly", name);
        out = defname;
    }

    if (pdr_cli_parse_only)
        return PDR_EXIT_OK;
    plc p;
    pdr_diag d = {0};
    int rc = plc_init(&p, out);
    if (!rc)
        rc = which == DOM_TEE      ? dom_tee(&p, &tee, &d)
             : which == DOM_SPHERE ? dom_sphere(&p, &sphere, &d)
                                   : dom_cube_in_cube(&p, &cube, &d);
    int status = PDR_EXIT_OK;
    if (rc == PDR_EINVAL) {
        for (size_t i = 0; i < d.nkept; i++)
            pdr_cli_error("domain", "%s", d.msgs[i]);
        status = PDR_EXIT_USAGE;
    } else if (rc || (rc = plc_validate(&p, &d)) || (rc = plc_write_poly(&p, out, &d))) {
        pdr_cli_fail("domain", &d, rc);
        status = PDR_EXIT_FAIL;
    } else {
        printf("pdr domain: wrote %s (%s: %zu vertices, %zu facets, %zu holes)\n", out,
               name, p.nv, p.nfacet, p.nhole);
    }
    plc_free(&p);
    pdr_diag_free(&d);
    return status;
}
