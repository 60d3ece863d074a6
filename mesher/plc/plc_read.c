/*
 * plc/plc_read.c -- readers of PLC files: TetGen .poly and .smesh, Geomview
 * .off, ASCII and binary .stl.
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

#define MAX_COUNT 1000000000L

static int oom(textin *t)
{
    pdr_diag_add(t->diag, t->path, t->line, "out of memory");
    return PDR_ENOMEM;
}

/* Reads the next content line, failing with "unexpected end of file while
 * reading WHAT" at the end. */
static int need_line(textin *t, const char *what)
{
    int rc = textin_next(t);
    if (rc == 1)
        return 0;
    if (rc == 0)
        return textin_error(t, "unexpected end of file while reading %s", what);
    return rc;
}

static int expect_eol(textin *t, const char *what)
{
    if (textin_at_eol(t))
        return 0;
    char *w = textin_word(t);
    return textin_error(t, "unexpected value '%s' after %s", w, what);
}

/* Reads the next integer of a record that may continue on following lines. */
static int record_long(textin *t, const char *what, long min, long max, long *out)
{
    if (textin_at_eol(t)) {
        int rc = need_line(t, what);
        if (rc)
            return rc;
    }
    return textin_long(t, what, min, max, out);
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
        (rc = expect_eol(t, "the vertex-list header")))
        return rc < 0 ? rc : PDR_EPARSE;
    if (nattr > 0 && plc__enable_vattr(p, (size_t)nattr))
        return oom(t);
    if (markers && plc_enable_vmarkers(p))
        return oom(t);
    for (long i = 0; i < count; i++) {
        if ((rc = need_line(t, "the vertex list")))
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
            return rc == PDR_ENOMEM ? oom(t) : textin_error(t, "too many vertices");
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
        if ((rc = expect_eol(t, "the vertex")))
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
    int rc = need_line(t, "the vertex-list header");
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
        return oom(t);
    textin nt;
    rc = textin_open(&nt, node, t->diag);
    if (rc) {
        textin_error(t, "the vertex count is 0, so the vertices must be in %s", node);
        pr_free(node);
        return rc;
    }
    pr_free(p->vfile);
    p->vfile = node;
    if (!(rc = need_line(&nt, "the vertex-list header")) &&
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
    int rc = record_long(t, "vertex index", -MAX_COUNT, MAX_COUNT, &num);
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
            return oom(t);
        if ((rc = read_corner(p, t, &cb->c[i])))
            return rc;
    }
    if (smesh && markers) {
        long m = 0;
        if ((rc = textin_opt_long(t, "facet marker", -MAX_COUNT, MAX_COUNT, &m)) < 0)
            return rc;
        *marker = (int)m;
    }
    if ((rc = expect_eol(t, "the polygon's corners")))
        return rc;
    if (smesh && (rc = plc_begin_facet(p, *marker, line)))
        return oom(t);
    if ((rc = plc_add_polygon(p, cb->c, (uint32_t)n, line)))
        return oom(t);
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
    int rc = need_line(t, "the facet-list header");
    long nf, markers = 0;
    if (rc || (rc = textin_long(t, "facet count", 0, MAX_COUNT, &nf)) ||
        (rc = textin_opt_long(t, "marker flag", 0, 1, &markers)) < 0 ||
        (rc = expect_eol(t, "the facet-list header")))
        return rc < 0 ? rc : PDR_EPARSE;
    struct corner_buf cb = {NULL, 0};
    for (long f = 0; f < nf && !rc; f++) {
        if ((rc = need_line(t, "the facet list")))
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
        if ((rc = expect_eol(t, "the facet header")))
            break;
        if (plc_begin_facet(p, (int)marker, line)) {
            rc = oom(t);
            break;
        }
        for (long k = 0; k < npoly && !rc; k++)
            if (!(rc = need_line(t, "a polygon")))
                rc = read_polygon(p, t, &cb, 0, 0, NULL);
        for (long h = 0; h < nhole && !rc; h++) {
            long num;
            double x[3];
            if ((rc = need_line(t, "a facet hole")) ||
                (rc = textin_long(t, "hole number", -MAX_COUNT, MAX_COUNT, &num)) ||
                (rc = textin_double(t, "x coordinate", &x[0])) ||
                (rc = textin_double(t, "y coordinate", &x[1])) ||
                (rc = textin_double(t, "z coordinate", &x[2])) ||
                (rc = expect_eol(t, "the facet hole")))
                break;
            if (plc_add_facet_hole(p, x, t->line))
                rc = oom(t);
        }
        if (!rc && demote_flat_facet(p))
            rc = oom(t);
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
        (rc = expect_eol(t, "the hole count")))
        return rc;
    for (long h = 0; h < n; h++) {
        long num;
        double x[3];
        if ((rc = need_line(t, "the hole list")) ||
            (rc = textin_long(t, "hole number", -MAX_COUNT, MAX_COUNT, &num)) ||
            (rc = textin_double(t, "x coordinate", &x[0])) ||
            (rc = textin_double(t, "y coordinate", &x[1])) ||
            (rc = textin_double(t, "z coordinate", &x[2])) ||
            (rc = expect_eol(t, "the hole")))
            return rc;
        if (plc_add_hole(p, x, t->line))
            return oom(t);
    }
    rc = textin_next(t);
    if (rc <= 0)
        return rc;
    if ((rc = textin_long(t, "region count", 0, MAX_COUNT, &n)) ||
        (rc = expect_eol(t, "the region count")))
        return rc;
    for (long r = 0; r < n; r++) {
        long num;
        double x[3], attr, maxvol = -1.0;
        if ((rc = need_line(t, "the region list")) ||
            (rc = textin_long(t, "region number", -MAX_COUNT, MAX_COUNT, &num)) ||
            (rc = textin_double(t, "x coordinate", &x[0])) ||
            (rc = textin_double(t, "y coordinate", &x[1])) ||
            (rc = textin_double(t, "z coordinate", &x[2])) ||
            (rc = textin_double(t, "region attribute", &attr)) ||
            (rc = textin_opt_double(t, "maximum volume", &maxvol)) < 0 ||
            (rc = expect_eol(t, "the region")))
            return rc < 0 ? rc : PDR_EPARSE;
        if (plc_add_region(p, x, attr, maxvol, t->line))
            return oom(t);
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

/* ------------------------------------------------------------ vertex merge */

/* Merges vertices with equal coordinates: open addressing on the bits of
 * the coordinates (with -0 folded into +0, so equal values hash equally). */
struct vmerge {
    uint32_t *slot; /* vertex index + 1, 0 when empty */
    size_t cap;     /* power of two */
};

static uint64_t hash_point(const double x[3])
{
    uint64_t h = 0x9e3779b97f4a7c15u;
    for (int k = 0; k < 3; k++) {
        double v = x[k] == 0.0 ? 0.0 : x[k];
        uint64_t b;
        memcpy(&b, &v, sizeof b);
        h ^= b + 0x9e3779b97f4a7c15u + (h << 6) + (h >> 2);
        h *= 0xff51afd7ed558ccdu;
        h ^= h >> 33;
    }
    return h;
}

static int vmerge_insert(struct vmerge *m, plc *p, const double x[3], long line,
                         uint32_t *out)
{
    if ((p->nv + 1) * 2 > m->cap) {
        size_t ncap = m->cap ? m->cap * 2 : 1024;
        uint32_t *s = pr_calloc(ncap, sizeof *s);
        if (!s)
            return PDR_ENOMEM;
        for (size_t v = 0; v < p->nv; v++) {
            size_t i = hash_point(p->xyz[v]) & (ncap - 1);
            while (s[i])
                i = (i + 1) & (ncap - 1);
            s[i] = (uint32_t)v + 1;
        }
        pr_free(m->slot);
        m->slot = s;
        m->cap = ncap;
    }
    size_t i = hash_point(x) & (m->cap - 1);
    while (m->slot[i]) {
        const double *y = p->xyz[m->slot[i] - 1];
        if (y[0] == x[0] && y[1] == x[1] && y[2] == x[2]) {
            *out = m->slot[i] - 1;
            return 0;
        }
        i = (i + 1) & (m->cap - 1);
    }
    int rc = plc_add_vertex(p, x, line, out);
    if (rc)
        return rc;
    m->slot[i] = *out + 1;
    return 0;
}

/* ----------------------------------------------------------- surface faces */

/* The faces of a surface file (.off, .stl) as CAD tools and scanners write
 * them, mended where the fix is certain and loses nothing:
 *  - a corner repeated next to itself is one corner; a face left with
 *    fewer than three has no area (a triangle whose two corners are one
 *    vertex after the STL vertices are merged) and is dropped: its other
 *    edge is used once in each direction by it, so the surface stays
 *    closed without it;
 *  - a polygon whose corners are not in one plane (quad meshes from
 *    scanners and modellers, nearly flat but beyond the planarity
 *    tolerance) is cut into triangles by ear clipping in its projection
 *    along its Newell normal, each triangle a facet of its own; one whose
 *    projection is no simple polygon is kept whole, and the validation
 *    then names it.
 * Counted in p->read_dropped and p->read_split. */

/* 1 if 2D point q lies inside or on the triangle abc (counterclockwise). */
static int in_triangle2(const double *a, const double *b, const double *c, const double *q)
{
    return pred_orient2d(a, b, q) >= 0 && pred_orient2d(b, c, q) >= 0 &&
           pred_orient2d(c, a, q) >= 0;
}

/* Flips the diagonals of an ear-clipped polygon (triangles tri[0..nt) of
 * corner positions, counterclockwise in the projection q) until each is
 * Delaunay there.
 * Ear clipping takes the first ear, so a quadrilateral is always cut
 * along the same diagonal whatever its shape; the Delaunay one is the
 * diagonal the tetrahedralization of the points most likely has already
 * (the surface is nearly flat there), so the boundary recovery need not
 * split it. Only small polygons (quadrilaterals from quad meshes, mostly):
 * the pair search is quadratic. */
static void delaunay_diagonals(const double (*q)[2], uint32_t n, uint32_t (*tri)[3],
                               uint32_t nt)
{
    if (nt < 2 || n > 32)
        return;
    for (uint32_t pass = 0, flipped = 1; flipped && pass < 4 * n; pass++) {
        flipped = 0;
        for (uint32_t i = 0; i < nt; i++)
            for (uint32_t j = i + 1; j < nt; j++)
                for (int e = 0; e < 3; e++) {
                    /* edge (x, y) of triangle i, apex w; triangle j has
                     * (y, x) with apex z */
                    uint32_t x = tri[i][e], y = tri[i][(e + 1) % 3], w = tri[i][(e + 2) % 3];
                    int f = -1;
                    for (int k = 0; k < 3; k++)
                        if (tri[j][k] == y && tri[j][(k + 1) % 3] == x)
                            f = k;
                    if (f < 0)
                        continue;
                    uint32_t z = tri[j][(f + 2) % 3];
                    const double *qx = q[x], *qy = q[y], *qw = q[w], *qz = q[z];
                    if (pred_incircle(qx, qy, qw, qz) <= 0)
                        continue;
                    /* the new diagonal (w, z) must leave two
                     * counterclockwise triangles: (w, x, z), (z, y, w) */
                    if (pred_orient2d(qw, qx, qz) <= 0 || pred_orient2d(qz, qy, qw) <= 0)
                        continue;
                    tri[i][0] = w, tri[i][1] = x, tri[i][2] = z;
                    tri[j][0] = z, tri[j][1] = y, tri[j][2] = w;
                    flipped = 1;
                    e = 3;
                }
    }
}

/* Ear clipping of polygon c[0..n) (n > 3, distinct corners) projected
 * along normal nrm; adds every triangle as a facet. Returns 0, 1 when the
 * projection has no ear at some step (not a simple polygon: nothing
 * added), or PDR_ENOMEM. */
static int clip_ears(plc *p, const uint32_t *c, uint32_t n, const double nrm[3], long line)
{
    int axis = 0;
    for (int k = 1; k < 3; k++)
        if (fabs(nrm[k]) > fabs(nrm[axis]))
            axis = k;
    /* (u, v) counterclockwise when seen against the normal */
    int u = (axis + 1) % 3, v = (axis + 2) % 3;
    if (nrm[axis] < 0) {
        int s = u;
        u = v;
        v = s;
    }
    double (*q)[2] = pr_malloc(n * sizeof *q);
    uint32_t *idx = pr_malloc(n * sizeof *idx);
    uint32_t(*tri)[3] = pr_malloc((n - 2) * sizeof *tri);
    int rc = q && idx && tri ? 0 : PDR_ENOMEM;
    uint32_t left = n, ntri = 0;
    for (uint32_t i = 0; i < n && !rc; i++) {
        q[i][0] = p->xyz[c[i]][u];
        q[i][1] = p->xyz[c[i]][v];
        idx[i] = i;
    }
    while (!rc && left > 3) {
        uint32_t ear = left;
        for (uint32_t i = 0; i < left && ear == left; i++) {
            uint32_t a = idx[(i + left - 1) % left], b = idx[i], d = idx[(i + 1) % left];
            if (pred_orient2d(q[a], q[b], q[d]) <= 0)
                continue;
            int empty = 1;
            for (uint32_t j = 0; j < left && empty; j++) {
                uint32_t o = idx[j];
                if (o != a && o != b && o != d)
                    empty = !in_triangle2(q[a], q[b], q[d], q[o]);
            }
            if (empty)
                ear = i;
        }
        if (ear == left) {
            rc = 1;
            break;
        }
        tri[ntri][0] = idx[(ear + left - 1) % left];
        tri[ntri][1] = idx[ear];
        tri[ntri][2] = idx[(ear + 1) % left];
        ntri++;
        memmove(idx + ear, idx + ear + 1, (left - ear - 1) * sizeof *idx);
        left--;
    }
    if (!rc) {
        if (pred_orient2d(q[idx[0]], q[idx[1]], q[idx[2]]) <= 0)
            rc = 1;
        else {
            tri[ntri][0] = idx[0];
            tri[ntri][1] = idx[1];
            tri[ntri][2] = idx[2];
            ntri++;
        }
    }
    if (!rc)
        delaunay_diagonals(q, n, tri, ntri);
    for (uint32_t i = 0; i < ntri && !rc; i++) {
        const uint32_t t[3] = {c[tri[i][0]], c[tri[i][1]], c[tri[i][2]]};
        if (plc_begin_facet(p, 0, line) || plc_add_polygon(p, t, 3, line))
            rc = PDR_ENOMEM;
    }
    pr_free(q);
    pr_free(idx);
    pr_free(tri);
    return rc;
}

/* Adds face c[0..n) of a surface file as a facet, mended as above (c is
 * changed). tol: the planarity tolerance in length units. Returns 0 or
 * PDR_ENOMEM. */
static int add_surface_face(plc *p, uint32_t *c, uint32_t n, long line, double tol)
{
    uint32_t k = 0;
    for (uint32_t i = 0; i < n; i++)
        if (!k || c[i] != c[k - 1])
            c[k++] = c[i];
    while (k > 1 && c[k - 1] == c[0])
        k--;
    if (k < 3) {
        p->read_dropped++;
        return 0;
    }
    if (k > 3) {
        double nrm[3] = {0, 0, 0}, ctr[3] = {0, 0, 0};
        for (uint32_t i = 0; i < k; i++) {
            const double *a = p->xyz[c[i]], *b = p->xyz[c[(i + 1) % k]];
            nrm[0] += (a[1] - b[1]) * (a[2] + b[2]);
            nrm[1] += (a[2] - b[2]) * (a[0] + b[0]);
            nrm[2] += (a[0] - b[0]) * (a[1] + b[1]);
            for (int j = 0; j < 3; j++)
                ctr[j] += a[j] / k;
        }
        double len = sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
        double worst = 0;
        for (uint32_t i = 0; i < k && len > 0; i++) {
            const double *a = p->xyz[c[i]];
            double d = fabs(nrm[0] * (a[0] - ctr[0]) + nrm[1] * (a[1] - ctr[1]) +
                            nrm[2] * (a[2] - ctr[2])) / len;
            if (d > worst)
                worst = d;
        }
        if (worst > tol) {
            int rc = clip_ears(p, c, k, nrm, line);
            if (rc <= 0) {
                p->read_split += !rc;
                return rc;
            }
        }
    }
    return plc_begin_facet(p, 0, line) || plc_add_polygon(p, c, k, line) ? PDR_ENOMEM : 0;
}

/* The planarity tolerance in length units of a surface whose vertices are
 * all read: as plc_validate measures it. */
static double surface_tol(const plc *p)
{
    double lo[3], hi[3], s = 0;
    for (int k = 0; k < 3; k++)
        lo[k] = hi[k] = p->nv ? p->xyz[0][k] : 0.0;
    for (size_t v = 1; v < p->nv; v++)
        for (int k = 0; k < 3; k++) {
            lo[k] = fmin(lo[k], p->xyz[v][k]);
            hi[k] = fmax(hi[k], p->xyz[v][k]);
        }
    for (int k = 0; k < 3; k++)
        s += (hi[k] - lo[k]) * (hi[k] - lo[k]);
    return p->planar_tol * sqrt(s);
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
    struct vmerge vm = {NULL, 0};
    uint32_t *map = NULL;
    size_t cap_map = 0;
    uint32_t *c = NULL;
    size_t cap = 0;
    if ((rc = need_line(&t, "the OFF header")))
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
    if (textin_at_eol(&t) && (rc = need_line(&t, "the OFF counts")))
        goto out;
    if ((rc = textin_long(&t, "vertex count", 0, MAX_COUNT, &nv)) ||
        (rc = textin_long(&t, "face count", 0, MAX_COUNT, &nf)) ||
        (rc = textin_opt_long(&t, "edge count", 0, MAX_COUNT, &ne)) < 0 ||
        (rc = expect_eol(&t, "the OFF counts")))
        goto out;
    /* Vertices with equal coordinates are one vertex (meshes exported
     * per part or per face repeat their seams' vertices): map[i] is file
     * vertex i's, and p->vnum keeps the file's numbers for messages. */
    for (long i = 0; i < nv; i++) {
        double x[3];
        if ((rc = need_line(&t, "the vertex list")) ||
            (rc = textin_double(&t, "x coordinate", &x[0])) ||
            (rc = textin_double(&t, "y coordinate", &x[1])) ||
            (rc = textin_double(&t, "z coordinate", &x[2])) ||
            (!extra && (rc = expect_eol(&t, "the vertex"))))
            goto out;
        size_t before = p->nv;
        if (plc__grow((void **)&map, &cap_map, (size_t)i + 1, sizeof *map) ||
            vmerge_insert(&vm, p, x, t.line, &map[i]) ||
            (p->nv > before && (p->vnum || p->nv != (size_t)i + 1) &&
             plc__number_vertex(p, p->nv - 1, i))) {
            rc = oom(&t);
            goto out;
        }
        p->read_welded += p->nv == before;
    }
    for (long f = 0; f < nf; f++) {
        long n;
        if ((rc = need_line(&t, "the face list")) ||
            (rc = textin_long(&t, "corner count", 3, MAX_COUNT, &n)))
            goto out;
        for (long i = 0; i < n; i++) {
            /* Grown with the corners read, as in read_polygon. */
            if (plc__grow((void **)&c, &cap, (size_t)i + 1, sizeof *c)) {
                rc = oom(&t);
                goto out;
            }
            long num;
            if ((rc = record_long(&t, "vertex index", -MAX_COUNT, MAX_COUNT, &num)))
                goto out;
            if (num < 0 || num >= nv) {
                rc = textin_error(&t, "vertex index %ld is out of range [0, %ld]", num, nv - 1);
                goto out;
            }
            c[i] = map[num];
        }
        /* Anything after the corners is a colour: ignored. */
        if (f == 0)
            tol = surface_tol(p);
        if (add_surface_face(p, c, (uint32_t)n, t.line, tol)) {
            rc = oom(&t);
            goto out;
        }
    }
    if (textin_next(&t) == 1)
        rc = textin_error(&t, "unexpected data after the last face");
out:
    pr_free(c);
    pr_free(map);
    pr_free(vm.slot);
    textin_close(&t);
    return rc;
}

/* --------------------------------------------------------------------- STL */

static int read_stl_binary(plc *p, FILE *f, const char *path, unsigned long ntri,
                           pdr_diag *diag)
{
    struct vmerge m = {NULL, 0};
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
            if (!rc && vmerge_insert(&m, p, x, 0, &c[k]))
                rc = PDR_ENOMEM;
        }
        if (!rc && add_surface_face(p, c, 3, 0, 0.0))
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
    struct vmerge m = {NULL, 0};
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
            (rc = expect_eol(&t, "the facet normal")) ||
            (rc = need_line(&t, "a facet")) ||
            (rc = expect_word(&t, "outer", "after the facet normal")) ||
            (rc = expect_word(&t, "loop", "after 'outer'")) ||
            (rc = expect_eol(&t, "'outer loop'")))
            break;
        size_t n = 0;
        for (;;) {
            if ((rc = need_line(&t, "a facet")))
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
                (rc = expect_eol(&t, "the vertex")))
                break;
            if (plc__grow((void **)&c, &cap, n + 1, sizeof *c) ||
                vmerge_insert(&m, p, x, t.line, &c[n])) {
                rc = oom(&t);
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
        if ((rc = need_line(&t, "a facet")) ||
            (rc = expect_word(&t, "endfacet", "after 'endloop'")))
            break;
        /* The vertices are not all read yet: a polygon of more than
         * three corners (which no STL writer makes) is kept whole. */
        if (add_surface_face(p, c, (uint32_t)n, line, INFINITY)) {
            rc = oom(&t);
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
enum { FMT_POLY, FMT_SMESH, FMT_OFF, FMT_STL };
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
    else {
        pdr_diag_add(diag, path, 0, "unknown input format '%s': expected .poly, "
                                    ".smesh, .off or .stl", *ext ? ext : "(no extension)");
        return PDR_EUNSUPPORTED;
    }
    return 0;
}

int plc_read_stream(plc *p, FILE *f, const char *path, pdr_diag *diag)
{
    int fmt, rc;
    if ((rc = set_paths(p, path, diag)) || (rc = format_of(path, diag, &fmt)))
        return rc;
    switch (fmt) {
    case FMT_POLY:
        return read_tetgen(p, f, path, diag, 0);
    case FMT_SMESH:
        return read_tetgen(p, f, path, diag, 1);
    case FMT_OFF:
        return read_off(p, f, path, diag);
    default:
        return read_stl(p, f, path, diag);
    }
}

int plc_read(plc *p, const char *path, pdr_diag *diag)
{
    int fmt, rc;
    if ((rc = set_paths(p, path, diag)) || (rc = format_of(path, diag, &fmt)))
        return rc;
    /* Binary for STL; the text formats read the same either way. */
    FILE *f = fopen(path, "rb");
    if (!f) {
        pdr_diag_add(diag, path, 0, "cannot open: %s", strerror(errno));
        return PDR_EIO;
    }
    rc = plc_read_stream(p, f, path, diag);
    fclose(f);
    return rc;
}
