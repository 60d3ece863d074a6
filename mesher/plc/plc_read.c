/*
 * plc/plc_read.c -- readers of PLC files: TetGen .poly and .smesh, Geomview
 * .off, ASCII and binary .stl, and the dispatch by extension (.ply, .obj
 * and Medit .mesh have their own files: plc_ply.c, plc_obj.c,
 * plc_medit.c; the surface formats share plc_surf.c).
 *
 * Formats as TetGen 1.5 documents them (wias-berlin.de/software/tetgen,
 * "File formats"), with these decisions and limitations:
 *  - Vertex lists (.poly/.smesh part 1, or the separate .node file when the
 *    part-1 count is 0): "<count> <dim=3> <#attributes> <markers 0|1>",
 *    then "<number> x y z [attributes] [marker]". The first vertex number
 *    (0 or 1) fixes the base of every index in the file, as in TetGen;
 *    unlike TetGen, later numbers must follow consecutively (a gap means a
 *    broken file, and we would rather say so than renumber silently). The
 *    marker column is optional even when the header announces markers.
 *  - .poly facets: "<#polygons> [#holes [marker]]" (the marker only when
 *    the facet-list header says markers), then each polygon "<n> c1 .. cn"
 *    (the corner list may continue over several lines), then the facet's
 *    hole points "<number> x y z". A facet made only of 1- and 2-corner
 *    polygons has no area: its 2-corner polygons become free segments with
 *    the facet's marker (TetGen's way to give a dangling segment).
 *  - .smesh facets: "<n> c1 .. cn [marker]", one polygon, no facet holes
 *    (the format has none); corner lists may continue over lines.
 *  - Parts 3 (volume holes) and 4 (regions "<number> x y z attribute
 *    [maxvolume]") may be missing at the end of the file; anything after
 *    part 4 is an error. TetGen's .var/.mtr companions are not read.
 *  - Values left over at the end of a record are reported, not ignored:
 *    they usually mean a wrong count in a header.
 *  - .off: "OFF" (counts may follow on the same line), "<nv> <nf> [ne]",
 *    vertices "x y z", faces "<n> i1 .. in [colour ...]" with 0-based
 *    indices; every face is a facet with marker 0, mended as the surface
 *    faces below say. The STOFF, COFF, NOFF (and combined, e.g. CNOFF)
 *    variants are read with what follows x y z on a vertex line ignored;
 *    4OFF, nOFF and binary OFF are not supported. Vertices with equal
 *    coordinates are merged, as in STL; messages keep the file's vertex
 *    numbers.
 *  - .stl: binary when the size is exactly 84 + 50 * (triangle count in
 *    the header), ASCII otherwise (which must start with "solid"). Several
 *    solids in one ASCII file are read as one surface. Every triangle is a
 *    facet with marker 0 (coplanar neighbours are not merged into one
 *    facet, so their shared edges are segments for the mesher); vertices
 *    with equal coordinates are merged (-0 equals +0), and a triangle two
 *    of whose corners are then one vertex is dropped (see the surface
 *    faces below).
 * File names are matched on their extension, case-insensitively.
 */
#include "config.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/types.h>

#include "pr_alloc.h"
#include "base/pdr_util.h"
#include "geom/pred.h"
#include "plc/plc.h"
#include "plc/plc_int.h"
#include "base/textin.h"

#define MAX_COUNT PLC_MAX_COUNT

int plc__oom(textin *t)
{
    pdr_diag_add(t->diag, t->path, t->line, "out of memory");
    return PDR_ENOMEM;
}

/* Reads the next content line, failing with "unexpected end of file while
 * reading WHAT" at the end. */
int plc__need_line(textin *t, const char *what)
{
    int rc = textin_next(t);
    if (rc == 1)
        return 0;
    if (rc == 0)
        return textin_error(t, "unexpected end of file while reading %s", what);
    return rc;
}

int plc__expect_eol(textin *t, const char *what)
{
    if (textin_at_eol(t))
        return 0;
    char *w = textin_word(t);
    return textin_error(t, "unexpected value '%s' after %s", w, what);
}

/* Reads the next integer of a record that may continue on following lines. */
int plc__record_long(textin *t, const char *what, long min, long max, long *out)
{
    if (textin_at_eol(t)) {
        int rc = plc__need_line(t, what);
        if (rc)
            return rc;
    }
    return textin_long(t, what, min, max, out);
}

int plc__record_double(textin *t, const char *what, double *out)
{
    if (textin_at_eol(t)) {
        int rc = plc__need_line(t, what);
        if (rc)
            return rc;
    }
    return textin_double(t, what, out);
}

/* ---------------------------------------------------------------- vertices */

/* Reads a vertex list: the header on the current line, then the vertices. */
static int read_vertex_list(plc *p, textin *t, long count)
{
    long dim, nattr = 0, markers = 0;
    int rc;
    if ((rc = textin_long(t, "dimension", 3, 3, &dim)) ||
        (rc = textin_opt_long(t, "attribute count", 0, 1000, &nattr)) < 0 ||
        (rc = textin_opt_long(t, "marker flag", 0, 1, &markers)) < 0 ||
        (rc = plc__expect_eol(t, "the vertex-list header")))
        return rc < 0 ? rc : PDR_EPARSE;
    if (nattr > 0 && plc__enable_vattr(p, (size_t)nattr))
        return plc__oom(t);
    if (markers && plc_enable_vmarkers(p))
        return plc__oom(t);
    for (long i = 0; i < count; i++) {
        if ((rc = plc__need_line(t, "the vertex list")))
            return rc;
        long num;
        double x[3];
        if ((rc = textin_long(t, "vertex number", -MAX_COUNT, MAX_COUNT, &num)))
            return rc;
        if (i == 0) {
            if (num != 0 && num != 1)
                return textin_error(t, "the first vertex is numbered %ld; "
                                       "it must be 0 or 1", num);
            p->base = (int)num;
        } else if (num != p->base + i) {
            return textin_error(t, "vertex number %ld where %ld was expected "
                                   "(numbers must be consecutive)",
                                num, p->base + i);
        }
        if ((rc = textin_double(t, "x coordinate", &x[0])) ||
            (rc = textin_double(t, "y coordinate", &x[1])) ||
            (rc = textin_double(t, "z coordinate", &x[2])))
            return rc;
        uint32_t v;
        if ((rc = plc_add_vertex(p, x, t->line, &v)))
            return rc == PDR_ENOMEM ? plc__oom(t) : textin_error(t, "too many vertices");
        for (long k = 0; k < nattr; k++)
            if ((rc = textin_double(t, "vertex attribute",
                                    &p->vattr[(size_t)v * p->nvattr + (size_t)k])))
                return rc;
        if (markers) {
            long m = 0;
            if ((rc = textin_opt_long(t, "vertex marker", -MAX_COUNT, MAX_COUNT, &m)) < 0)
                return rc;
            p->vmarker[v] = (int)m;
        }
        if ((rc = plc__expect_eol(t, "the vertex")))
            return rc;
    }
    return 0;
}

/* Replaces the extension of path (after the last '.') by ext. */
static char *sibling_path(const char *path, const char *ext)
{
    return pdr_path_ext(path, pdr_path_stem(path), ext);
}

/* Part 1 of .poly/.smesh: inline vertices, or a separate .node file. */
static int read_part1(plc *p, textin *t)
{
    int rc = plc__need_line(t, "the vertex-list header");
    if (rc)
        return rc;
    long count;
    if ((rc = textin_long(t, "vertex count", 0, MAX_COUNT, &count)))
        return rc;
    if (count > 0)
        return read_vertex_list(p, t, count);

    /* TetGen: a count of 0 means the vertices are in NAME.node. The rest of
     * this header line is ignored, as TetGen does. */
    char *node = sibling_path(t->path, ".node");
    if (!node)
        return plc__oom(t);
    textin nt;
    rc = textin_open(&nt, node, t->diag);
    if (rc) {
        textin_error(t, "the vertex count is 0, so the vertices must be in %s", node);
        pr_free(node);
        return rc;
    }
    pr_free(p->vfile);
    p->vfile = node;
    if (!(rc = plc__need_line(&nt, "the vertex-list header")) &&
        !(rc = textin_long(&nt, "vertex count", 0, MAX_COUNT, &count)))
        rc = read_vertex_list(p, &nt, count);
    if (!rc && textin_next(&nt) == 1)
        rc = textin_error(&nt, "unexpected data after the last vertex");
    textin_close(&nt);
    return rc;
}

/* Reads a vertex reference of a record and converts it to an index. */
static int read_corner(plc *p, textin *t, uint32_t *out)
{
    long num;
    int rc = plc__record_long(t, "vertex index", -MAX_COUNT, MAX_COUNT, &num);
    if (rc)
        return rc;
    if (num < p->base || num - p->base >= (long)p->nv) {
        if (p->nv == 0)
            return textin_error(t, "vertex index %ld, but there are no vertices", num);
        return textin_error(t, "vertex index %ld is out of range [%d, %ld]", num,
                            p->base, (long)p->nv - 1 + p->base);
    }
    *out = (uint32_t)(num - p->base);
    return 0;
}

struct corner_buf {
    uint32_t *c;
    size_t cap;
};

static int read_polygon(plc *p, textin *t, struct corner_buf *cb, int smesh,
                        int markers, int *marker)
{
    long n;
    long line = t->line;
    int rc = textin_long(t, "corner count", 1, MAX_COUNT, &n);
    if (rc)
        return rc;
    if (smesh && n < 3)
        return textin_error(t, "a facet needs at least 3 corners, not %ld", n);
    /* The buffer grows with the corners read, not to the count: a count
     * of a billion in a small file must end in "unexpected end of file",
     * not in an allocation of gigabytes. */
    for (long i = 0; i < n; i++) {
        if (plc__grow((void **)&cb->c, &cb->cap, (size_t)i + 1, sizeof *cb->c))
            return plc__oom(t);
        if ((rc = read_corner(p, t, &cb->c[i])))
            return rc;
    }
    if (smesh && markers) {
        long m = 0;
        if ((rc = textin_opt_long(t, "facet marker", -MAX_COUNT, MAX_COUNT, &m)) < 0)
            return rc;
        *marker = (int)m;
    }
    if ((rc = plc__expect_eol(t, "the polygon's corners")))
        return rc;
    if (smesh && (rc = plc_begin_facet(p, *marker, line)))
        return plc__oom(t);
    if ((rc = plc_add_polygon(p, cb->c, (uint32_t)n, line)))
        return plc__oom(t);
    return 0;
}

/* A facet without a polygon of 3 or more corners is a set of free segments
 * (and vertices, which need nothing): move it out of the facet list. */
static int demote_flat_facet(plc *p)
{
    plc_facet *f = &p->facets[p->nfacet - 1];
    for (size_t k = 0; k < f->npoly; k++)
        if (p->polys[f->poly_first + k].n >= 3)
            return 0;
    size_t first = f->poly_first, npoly = f->npoly;
    int marker = f->marker;
    p->nfacet--;
    p->nfhole = f->hole_first;
    p->ncorner = npoly ? p->polys[first].first : p->ncorner;
    for (size_t k = 0; k < npoly; k++) {
        const plc_polygon *q = &p->polys[first + k];
        if (q->n == 2) {
            uint32_t a = p->corners[q->first], b = p->corners[q->first + 1];
            if (plc_add_segment(p, a, b, marker, q->line))
                return PDR_ENOMEM;
        }
    }
    p->npoly = first;
    return 0;
}

static int read_poly_facets(plc *p, textin *t, int smesh)
{
    int rc = plc__need_line(t, "the facet-list header");
    long nf, markers = 0;
    if (rc || (rc = textin_long(t, "facet count", 0, MAX_COUNT, &nf)) ||
        (rc = textin_opt_long(t, "marker flag", 0, 1, &markers)) < 0 ||
        (rc = plc__expect_eol(t, "the facet-list header")))
        return rc < 0 ? rc : PDR_EPARSE;
    struct corner_buf cb = {NULL, 0};
    for (long f = 0; f < nf && !rc; f++) {
        if ((rc = plc__need_line(t, "the facet list")))
            break;
        if (smesh) {
            int marker = 0;
            rc = read_polygon(p, t, &cb, 1, (int)markers, &marker);
            continue;
        }
        long npoly, nhole = 0, marker = 0;
        long line = t->line;
        if ((rc = textin_long(t, "polygon count", 1, MAX_COUNT, &npoly)) ||
            (rc = textin_opt_long(t, "facet hole count", 0, MAX_COUNT, &nhole)) < 0)
            break;
        if (markers &&
            (rc = textin_opt_long(t, "facet marker", -MAX_COUNT, MAX_COUNT, &marker)) < 0)
            break;
        if ((rc = plc__expect_eol(t, "the facet header")))
            break;
        if (plc_begin_facet(p, (int)marker, line)) {
            rc = plc__oom(t);
            break;
        }
        for (long k = 0; k < npoly && !rc; k++)
            if (!(rc = plc__need_line(t, "a polygon")))
                rc = read_polygon(p, t, &cb, 0, 0, NULL);
        for (long h = 0; h < nhole && !rc; h++) {
            long num;
            double x[3];
            if ((rc = plc__need_line(t, "a facet hole")) ||
                (rc = textin_long(t, "hole number", -MAX_COUNT, MAX_COUNT, &num)) ||
                (rc = textin_double(t, "x coordinate", &x[0])) ||
                (rc = textin_double(t, "y coordinate", &x[1])) ||
                (rc = textin_double(t, "z coordinate", &x[2])) ||
                (rc = plc__expect_eol(t, "the facet hole")))
                break;
            if (plc_add_facet_hole(p, x, t->line))
                rc = plc__oom(t);
        }
        if (!rc && demote_flat_facet(p))
            rc = plc__oom(t);
    }
    pr_free(cb.c);
    return rc;
}

/* Parts 3 and 4: volume holes and regions, both optional at end of file. */
static int read_holes_regions(plc *p, textin *t)
{
    int rc = textin_next(t);
    if (rc <= 0)
        return rc;
    long n;
    if ((rc = textin_long(t, "hole count", 0, MAX_COUNT, &n)) ||
        (rc = plc__expect_eol(t, "the hole count")))
        return rc;
    for (long h = 0; h < n; h++) {
        long num;
        double x[3];
        if ((rc = plc__need_line(t, "the hole list")) ||
            (rc = textin_long(t, "hole number", -MAX_COUNT, MAX_COUNT, &num)) ||
            (rc = textin_double(t, "x coordinate", &x[0])) ||
            (rc = textin_double(t, "y coordinate", &x[1])) ||
            (rc = textin_double(t, "z coordinate", &x[2])) ||
            (rc = plc__expect_eol(t, "the hole")))
            return rc;
        if (plc_add_hole(p, x, t->line))
            return plc__oom(t);
    }
    rc = textin_next(t);
    if (rc <= 0)
        return rc;
    if ((rc = textin_long(t, "region count", 0, MAX_COUNT, &n)) ||
        (rc = plc__expect_eol(t, "the region count")))
        return rc;
    for (long r = 0; r < n; r++) {
        long num;
        double x[3], attr, maxvol = -1.0;
        if ((rc = plc__need_line(t, "the region list")) ||
            (rc = textin_long(t, "region number", -MAX_COUNT, MAX_COUNT, &num)) ||
            (rc = textin_double(t, "x coordinate", &x[0])) ||
            (rc = textin_double(t, "y coordinate", &x[1])) ||
            (rc = textin_double(t, "z coordinate", &x[2])) ||
            (rc = textin_double(t, "region attribute", &attr)) ||
            (rc = textin_opt_double(t, "maximum volume", &maxvol)) < 0 ||
            (rc = plc__expect_eol(t, "the region")))
            return rc < 0 ? rc : PDR_EPARSE;
        if (plc_add_region(p, x, attr, maxvol, t->line))
            return plc__oom(t);
    }
    rc = textin_next(t);
    if (rc == 1)
        return textin_error(t, "unexpected data after the region list");
    return rc;
}

static int read_tetgen(plc *p, FILE *f, const char *path, pdr_diag *diag, int smesh)
{
    textin t;
    int rc;
    textin_attach(&t, f, path, diag);
    if (!(rc = read_part1(p, &t)) && !(rc = read_poly_facets(p, &t, smesh)))
        rc = read_holes_regions(p, &t);
    textin_close(&t);
    return rc;
}

/* --------------------------------------------------------------------- OFF */

static int read_off(plc *p, FILE *in, const char *path, pdr_diag *diag)
{
    textin t;
    int rc;
    textin_attach(&t, in, path, diag);
    p->base = 0;
    long nv, nf, ne;
    double tol = 0;
    struct plc__welder wv;
    memset(&wv, 0, sizeof wv);
    uint32_t *c = NULL;
    size_t cap = 0;
    if ((rc = plc__need_line(&t, "the OFF header")))
        goto out;
    char *w = textin_word(&t);
    /* The variants whose vertices carry more than x y z: texture
     * coordinates (ST), a colour (C), a normal (N), in that order; what
     * follows x y z on a vertex line is then ignored. */
    const char *k = w;
    int extra = 0;
    if (!strncmp(k, "ST", 2))
        k += 2, extra = 1;
    if (*k == 'C')
        k++, extra = 1;
    if (*k == 'N')
        k++, extra = 1;
    if (strcmp(k, "OFF") != 0) {
        if (strstr(w, "OFF"))
            rc = textin_error(&t, "the %s variant of OFF is not supported (plain OFF, "
                                  "and COFF, NOFF, CNOFF, STOFF with their extra vertex "
                                  "data ignored)", w);
        else
            rc = textin_error(&t, "not an OFF file: it must start with 'OFF'");
        goto out;
    }
    if (textin_at_eol(&t) && (rc = plc__need_line(&t, "the OFF counts")))
        goto out;
    if ((rc = textin_long(&t, "vertex count", 0, MAX_COUNT, &nv)) ||
        (rc = textin_long(&t, "face count", 0, MAX_COUNT, &nf)) ||
        (rc = textin_opt_long(&t, "edge count", 0, MAX_COUNT, &ne)) < 0 ||
        (rc = plc__expect_eol(&t, "the OFF counts")))
        goto out;
    /* Vertices with equal coordinates are one vertex (meshes exported
     * per part or per face repeat their seams' vertices): wv.map[i] is file
     * vertex i's, and p->vnum keeps the file's numbers for messages. */
    for (long i = 0; i < nv; i++) {
        double x[3];
        if ((rc = plc__need_line(&t, "the vertex list")) ||
            (rc = textin_double(&t, "x coordinate", &x[0])) ||
            (rc = textin_double(&t, "y coordinate", &x[1])) ||
            (rc = textin_double(&t, "z coordinate", &x[2])) ||
            (!extra && (rc = plc__expect_eol(&t, "the vertex"))))
            goto out;
        if (plc__weld_vertex(p, &wv, i, x, t.line)) {
            rc = plc__oom(&t);
            goto out;
        }
    }
    for (long f = 0; f < nf; f++) {
        long n;
        if ((rc = plc__need_line(&t, "the face list")) ||
            (rc = textin_long(&t, "corner count", 3, MAX_COUNT, &n)))
            goto out;
        for (long i = 0; i < n; i++) {
            /* Grown with the corners read, as in read_polygon. */
            if (plc__grow((void **)&c, &cap, (size_t)i + 1, sizeof *c)) {
                rc = plc__oom(&t);
                goto out;
            }
            long num;
            if ((rc = plc__record_long(&t, "vertex index", -MAX_COUNT, MAX_COUNT, &num)))
                goto out;
            if (num < 0 || num >= nv) {
                rc = textin_error(&t, "vertex index %ld is out of range [0, %ld]", num, nv - 1);
                goto out;
            }
            c[i] = wv.map[num];
        }
        /* Anything after the corners is a colour: ignored. */
        if (f == 0)
            tol = plc__surface_tol(p);
        if (plc__add_surface_face(p, c, (uint32_t)n, t.line, tol)) {
            rc = plc__oom(&t);
            goto out;
        }
    }
    if (textin_next(&t) == 1)
        rc = textin_error(&t, "unexpected data after the last face");
out:
    pr_free(c);
    plc__welder_free(&wv);
    textin_close(&t);
    return rc;
}

/* --------------------------------------------------------------------- STL */

static int read_stl_binary(plc *p, FILE *f, const char *path, unsigned long ntri,
                           pdr_diag *diag)
{
    struct plc__vmerge m = {NULL, 0};
    unsigned char rec[50];
    int rc = 0;
    p->base = 1;
    for (unsigned long i = 0; i < ntri; i++) {
        if (fread(rec, 1, sizeof rec, f) != sizeof rec) {
            pdr_diag_add(diag, path, 0, "triangle %lu: unexpected end of file", i + 1);
            rc = PDR_EPARSE;
            break;
        }
        uint32_t c[3];
        for (int k = 0; k < 3 && !rc; k++) {
            double x[3];
            for (int j = 0; j < 3; j++) {
                const unsigned char *b = rec + 12 + 12 * k + 4 * j;
                uint32_t bits = (uint32_t)b[0] | (uint32_t)b[1] << 8 |
                                (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24;
                float fl;
                memcpy(&fl, &bits, sizeof fl);
                x[j] = fl;
                if (!isfinite(x[j])) {
                    pdr_diag_add(diag, path, 0,
                                 "triangle %lu: vertex %d has a non-finite coordinate",
                                 i + 1, k + 1);
                    rc = PDR_EPARSE;
                }
            }
            if (!rc && plc__vmerge_insert(&m, p, x, 0, &c[k]))
                rc = PDR_ENOMEM;
        }
        if (!rc && plc__add_surface_face(p, c, 3, 0, 0.0))
            rc = PDR_ENOMEM;
        if (rc)
            break;
    }
    if (rc == PDR_ENOMEM)
        pdr_diag_add(diag, path, 0, "out of memory");
    pr_free(m.slot);
    return rc;
}

static int expect_word(textin *t, const char *want, const char *context)
{
    char *w = textin_word(t);
    if (!w || strcmp(w, want) != 0)
        return textin_error(t, "expected '%s' %s, found '%s'", want, context,
                            w ? w : "end of line");
    return 0;
}

static int read_stl_ascii(plc *p, FILE *f, const char *path, pdr_diag *diag)
{
    textin t;
    textin_attach(&t, f, path, diag);
    struct plc__vmerge m = {NULL, 0};
    uint32_t *c = NULL;
    size_t cap = 0;
    int rc = 0, in_solid = 0, nsolid = 0;
    p->base = 1;
    /* A token-level state machine over the keywords of ASCII STL. */
    while ((rc = textin_next(&t)) == 1) {
        char *w = textin_word(&t);
        if (!in_solid) {
            if (strcmp(w, "solid") != 0) {
                rc = textin_error(&t, "expected 'solid', found '%s'", w);
                break;
            }
            in_solid = 1;
            nsolid++;
            continue; /* the rest of the line is the solid's name */
        }
        if (!strcmp(w, "endsolid")) {
            in_solid = 0;
            continue;
        }
        if (strcmp(w, "facet") != 0) {
            rc = textin_error(&t, "expected 'facet' or 'endsolid', found '%s'", w);
            break;
        }
        long line = t.line;
        double nrm;
        if ((rc = expect_word(&t, "normal", "after 'facet'")) ||
            (rc = textin_double(&t, "normal x", &nrm)) ||
            (rc = textin_double(&t, "normal y", &nrm)) ||
            (rc = textin_double(&t, "normal z", &nrm)) ||
            (rc = plc__expect_eol(&t, "the facet normal")) ||
            (rc = plc__need_line(&t, "a facet")) ||
            (rc = expect_word(&t, "outer", "after the facet normal")) ||
            (rc = expect_word(&t, "loop", "after 'outer'")) ||
            (rc = plc__expect_eol(&t, "'outer loop'")))
            break;
        size_t n = 0;
        for (;;) {
            if ((rc = plc__need_line(&t, "a facet")))
                break;
            char *k = textin_word(&t);
            if (!strcmp(k, "endloop"))
                break;
            if (strcmp(k, "vertex") != 0) {
                rc = textin_error(&t, "expected 'vertex' or 'endloop', found '%s'", k);
                break;
            }
            double x[3];
            if ((rc = textin_double(&t, "x coordinate", &x[0])) ||
                (rc = textin_double(&t, "y coordinate", &x[1])) ||
                (rc = textin_double(&t, "z coordinate", &x[2])) ||
                (rc = plc__expect_eol(&t, "the vertex")))
                break;
            if (plc__grow((void **)&c, &cap, n + 1, sizeof *c) ||
                plc__vmerge_insert(&m, p, x, t.line, &c[n])) {
                rc = plc__oom(&t);
                break;
            }
            n++;
        }
        if (rc)
            break;
        if (n < 3) {
            rc = textin_error(&t, "a facet needs at least 3 vertices, not %zu", n);
            break;
        }
        if ((rc = plc__need_line(&t, "a facet")) ||
            (rc = expect_word(&t, "endfacet", "after 'endloop'")))
            break;
        /* The vertices are not all read yet: a polygon of more than
         * three corners (which no STL writer makes) is kept whole. */
        if (plc__add_surface_face(p, c, (uint32_t)n, line, INFINITY)) {
            rc = plc__oom(&t);
            break;
        }
    }
    if (rc == 0 && in_solid)
        rc = textin_error(&t, "unexpected end of file: missing 'endsolid'");
    if (rc == 0 && nsolid == 0)
        rc = textin_error(&t, "empty STL file");
    pr_free(c);
    pr_free(m.slot);
    textin_close(&t);
    return rc;
}

/* The size of the stream in bytes, or -1 if it cannot be told (a pipe).
 * Leaves the position at the start. */
static long long stream_size(FILE *f)
{
    if (fseeko(f, 0, SEEK_END) != 0)
        return -1;
    off_t end = ftello(f);
    if (fseeko(f, 0, SEEK_SET) != 0)
        return -1;
    return end < 0 ? -1 : (long long)end;
}

static int read_stl(plc *p, FILE *f, const char *path, pdr_diag *diag)
{
    unsigned char head[84];
    long long size = stream_size(f);
    size_t got = fread(head, 1, sizeof head, f);
    unsigned long n = 0;
    if (got == sizeof head) {
        n = (unsigned long)head[80] | (unsigned long)head[81] << 8 |
            (unsigned long)head[82] << 16 | (unsigned long)head[83] << 24;
        if (size >= 0 && (unsigned long long)size == 84ull + 50ull * n)
            return read_stl_binary(p, f, path, n, diag);
    }
    if (got < 5 || memcmp(head, "solid", 5) != 0) {
        /* Say what the header promised: a count that does not fit the
         * file is refused here, before anything is allocated for it. */
        if (got == sizeof head && size >= 0)
            pdr_diag_add(diag, path, 0, "neither ASCII STL (no 'solid' at the start) "
                                        "nor binary STL (the header's %lu triangles "
                                        "need %llu bytes, the file has %lld)",
                         n, 84ull + 50ull * n, size);
        else
            pdr_diag_add(diag, path, 0, "neither ASCII STL (no 'solid' at the start) "
                                        "nor binary STL (the size does not match the "
                                        "triangle count)");
        return PDR_EPARSE;
    }
    if (fseeko(f, 0, SEEK_SET) != 0) {
        pdr_diag_add(diag, path, 0, "cannot rewind: %s", strerror(errno));
        return PDR_EIO;
    }
    return read_stl_ascii(p, f, path, diag);
}

/* ---------------------------------------------------------------- dispatch */

/* Records the names of the input in p. */
static int set_paths(plc *p, const char *path, pdr_diag *diag)
{
    pr_free(p->path);
    pr_free(p->vfile);
    size_t n = strlen(path) + 1;
    p->path = pr_malloc(n);
    p->vfile = pr_malloc(n);
    if (!p->path || !p->vfile) {
        pdr_diag_add(diag, path, 0, "out of memory");
        return PDR_ENOMEM;
    }
    memcpy(p->path, path, n);
    memcpy(p->vfile, path, n);
    return 0;
}

/* The reader of path's extension; set *fmt to it, or report it unknown. */
enum { FMT_POLY, FMT_SMESH, FMT_OFF, FMT_STL, FMT_PLY, FMT_OBJ, FMT_MEDIT };
static int format_of(const char *path, pdr_diag *diag, int *fmt)
{
    const char *slash = strrchr(path, '/');
    const char *dot = strrchr(path, '.');
    const char *ext = dot && (!slash || dot > slash) ? dot : "";
    if (!strcasecmp(ext, ".poly"))
        *fmt = FMT_POLY;
    else if (!strcasecmp(ext, ".smesh"))
        *fmt = FMT_SMESH;
    else if (!strcasecmp(ext, ".off"))
        *fmt = FMT_OFF;
    else if (!strcasecmp(ext, ".stl"))
        *fmt = FMT_STL;
    else if (!strcasecmp(ext, ".ply"))
        *fmt = FMT_PLY;
    else if (!strcasecmp(ext, ".obj"))
        *fmt = FMT_OBJ;
    else if (!strcasecmp(ext, ".mesh"))
        *fmt = FMT_MEDIT;
    else {
        pdr_diag_add(diag, path, 0, "unknown input format '%s': expected .poly, "
                                    ".smesh, .off, .stl, .ply, .obj or .mesh",
                     *ext ? ext : "(no extension)");
        return PDR_EUNSUPPORTED;
    }
    return 0;
}

int plc_read_stream(plc *p, FILE *f, const char *path, pdr_diag *diag)
{
    int fmt, rc;
    if ((rc = set_paths(p, path, diag)) || (rc = format_of(path, diag, &fmt)))
        return rc;
    p->surface_input = fmt != FMT_POLY && fmt != FMT_SMESH;
    switch (fmt) {
    case FMT_POLY:
        return read_tetgen(p, f, path, diag, 0);
    case FMT_SMESH:
        return read_tetgen(p, f, path, diag, 1);
    case FMT_OFF:
        return read_off(p, f, path, diag);
    case FMT_PLY:
        return plc__read_ply(p, f, path, diag);
    case FMT_OBJ:
        return plc__read_obj(p, f, path, diag);
    case FMT_MEDIT:
        return plc__read_medit(p, f, path, diag);
    default:
        return read_stl(p, f, path, diag);
    }
}

int plc_read(plc *p, const char *path, pdr_diag *diag)
{
    int fmt, rc;
    if ((rc = set_paths(p, path, diag)) || (rc = format_of(path, diag, &fmt)))
        return rc;
    /* Binary for STL and PLY; the text formats read the same either way. */
    FILE *f = fopen(path, "rb");
    if (!f) {
        pdr_diag_add(diag, path, 0, "cannot open: %s", strerror(errno));
        return PDR_EIO;
    }
    rc = plc_read_stream(p, f, path, diag);
    fclose(f);
    return rc;
}
