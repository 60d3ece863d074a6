/*
 * plc/plc_surf.c -- what the readers of surface files (.off, .stl, .ply,
 * .obj, .mesh) share: vertices with equal coordinates welded into one, and
 * faces mended as CAD tools and scanners write them (see
 * plc__add_surface_face). Declared in plc/plc_int.h.
 */
#include "config.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "pr_alloc.h"
#include "geom/pred.h"
#include "plc/plc.h"
#include "plc/plc_int.h"

/* ------------------------------------------------------------ vertex merge */

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

int plc__vmerge_insert(struct plc__vmerge *m, plc *p, const double x[3], long line,
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

int plc__weld_vertex(plc *p, struct plc__welder *w, long i, const double x[3], long line)
{
    size_t before = p->nv;
    if (plc__grow((void **)&w->map, &w->cap_map, (size_t)i + 1, sizeof *w->map) ||
        plc__vmerge_insert(&w->vm, p, x, line, &w->map[i]) ||
        (p->nv > before && (p->vnum || p->nv != (size_t)i + 1) &&
         plc__number_vertex(p, p->nv - 1, i)))
        return PDR_ENOMEM;
    p->read_welded += p->nv == before;
    return 0;
}

void plc__welder_free(struct plc__welder *w)
{
    pr_free(w->vm.slot);
    pr_free(w->map);
    memset(w, 0, sizeof *w);
}

/* ----------------------------------------------------------- surface faces */

/* The faces of a surface file (.off, .stl, .ply, .obj, .mesh) as CAD tools and scanners write
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
static int clip_ears(plc *p, const uint32_t *c, uint32_t n, const double nrm[3], int marker,
                     long line)
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
        if (plc_begin_facet(p, marker, line) || plc_add_polygon(p, t, 3, line))
            rc = PDR_ENOMEM;
    }
    pr_free(q);
    pr_free(idx);
    pr_free(tri);
    return rc;
}

/* Adds face c[0..n) of a surface file as a facet with the marker, mended
 * as above (c is changed). tol: the planarity tolerance in length units.
 * Returns 0 or PDR_ENOMEM. */
int plc__add_surface_face_marked(plc *p, uint32_t *c, uint32_t n, int marker, long line,
                                 double tol)
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
            int rc = clip_ears(p, c, k, nrm, marker, line);
            if (rc <= 0) {
                p->read_split += !rc;
                return rc;
            }
        }
    }
    return plc_begin_facet(p, marker, line) || plc_add_polygon(p, c, k, line) ? PDR_ENOMEM
                                                                                 : 0;
}

int plc__add_surface_face(plc *p, uint32_t *c, uint32_t n, long line, double tol)
{
    return plc__add_surface_face_marked(p, c, n, 0, line, tol);
}

/* The planarity tolerance in length units of a surface whose vertices are
 * all read: as plc_validate measures it. */
double plc__surface_tol(const plc *p)
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

/* ----------------------------------------------------------- kept faces */

int plc__faces_add(struct plc__faces *fs, const uint32_t *c, uint32_t n, int marker,
                   long line)
{
    if (plc__grow((void **)&fs->corner, &fs->cap_corner, fs->ncorner + n, sizeof *fs->corner) ||
        plc__grow((void **)&fs->face, &fs->cap_face, fs->nface + 1, sizeof *fs->face))
        return PDR_ENOMEM;
    memcpy(fs->corner + fs->ncorner, c, n * sizeof *c);
    fs->face[fs->nface++] = (struct plc__face_rec){fs->ncorner, n, marker, line};
    fs->ncorner += n;
    return 0;
}

int plc__faces_commit(plc *p, const struct plc__faces *fs, const uint32_t *map, size_t nv_file,
                      int base, const char *path, pdr_diag *diag)
{
    double tol = plc__surface_tol(p);
    uint32_t *c = NULL;
    size_t cap = 0;
    int rc = 0;
    for (size_t f = 0; f < fs->nface && !rc; f++) {
        const struct plc__face_rec *r = &fs->face[f];
        if (plc__grow((void **)&c, &cap, r->n, sizeof *c)) {
            rc = PDR_ENOMEM;
            break;
        }
        for (uint32_t i = 0; i < r->n && !rc; i++) {
            uint32_t v = fs->corner[r->first + i];
            if (v >= nv_file) {
                pdr_diag_add(diag, path, r->line,
                             "vertex %llu is out of range [%d, %lld]",
                             (unsigned long long)v + (unsigned)base, base,
                             (long long)nv_file - 1 + base);
                rc = PDR_EPARSE;
            } else {
                c[i] = map[v];
            }
        }
        if (!rc && plc__add_surface_face_marked(p, c, r->n, r->marker, r->line, tol))
            rc = PDR_ENOMEM;
    }
    if (rc == PDR_ENOMEM)
        pdr_diag_add(diag, path, 0, "out of memory");
    pr_free(c);
    return rc;
}

void plc__faces_free(struct plc__faces *fs)
{
    pr_free(fs->corner);
    pr_free(fs->face);
    memset(fs, 0, sizeof *fs);
}
