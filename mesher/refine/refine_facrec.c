/*
 * refine/refine_facrec.c -- the second phase of the constrained recovery
 * (ref_opts.constrained with segments first, refine_segrec.c): every
 * missing facet region (missing subfacets of one facet, bounded by edges
 * of the tetrahedralization) made faces of it by retriangulating the
 * tetrahedra it crosses, with no new vertex (Si 2015, TetGen's facet
 * recovery; Shewchuk 2002), before the subfacets become constraints.
 *
 * Why. After the segment recovery every subsegment is an edge, but on CAD
 * tessellations (long thin triangles nearly in the plane of their
 * neighbours) many triangles are still missing: edges of the Delaunay
 * tetrahedralization pierce them. Splitting them at their circumcentres,
 * as the recovery did, puts a vertex on the surface whose cavity reaches
 * round the neighbouring constraints (no star), or whose new subfacets
 * are missing again, down to the recovery's bound (mesher/refine/
 * RECOVERY.md). A missing triangle whose edges are present needs no new
 * vertex in most cases: the tetrahedra it crosses form a cavity that the
 * triangle cuts in two, and each half can usually be tetrahedralized with
 * the triangle as a face. The segment splits add edges inside the facets
 * (from a split point to the opposite corner) that may be missing too:
 * so the unit is a region of missing triangles joined across such edges.
 *
 * How, for one missing subfacet:
 *   0. Its region: the missing subfacets of its facet reached across
 *      edges that are not edges of the mesh (region()). The region's
 *      vertices are the floor; every other vertex is above or below all
 *      of its triangles, in their plane, or neither (vside()).
 *   1. The cavity C: the tetrahedra whose interior meets a triangle of the
 *      region (an exact separating-axis test, crosses_tri()), found from
 *      the tetrahedra around the region's present edges and across their
 *      faces.
 *   2. Every boundary face of C lies above or below the region (touching
 *      it at most at floor vertices): the UPPER faces and the LOWER
 *      faces. With the region's triangles they bound two polyhedra, the
 *      upper and the lower cavity.
 *   3. Each cavity is tetrahedralized by the Delaunay tetrahedralization
 *      of its vertices (a scratch tm_mesh, mesh/dt.c), or else by the cone
 *      from one of its vertices that sees every other face strictly from
 *      inside, restricted to it: if every boundary face of the cavity,
 *      floor included, is a face of that tetrahedralization (seen from
 *      the right side), the tetrahedra reached from those faces without
 *      crossing them fill the cavity exactly. Where a boundary face is
 *      missing from the Delaunay one and no cone does, the tetrahedron
 *      outside it (on the same side) joins C and the step is tried again,
 *      a few times (TetGen grows its cavities the same way).
 *   4. The two fills replace C: new tetrahedra linked to each other
 *      across the floor and to C's outside across its boundary faces,
 *      whose marks and subsegment bits they take.
 *   5. Where no tetrahedron crosses the region, or the steps above fail:
 *      faces of the mesh with corners on the floor that triangulate the
 *      region in the facet's own 2D view replace its subfacets in the
 *      facet's triangulation (adopt()), and the mesh does not change.
 *      Every vertex of the region lies on the facet by construction, so
 *      no 3D test decides "in the plane": a facet merged within a
 *      tolerance, or a triangle whose subfacets' corners are split points
 *      rounded off its plane, has no exact plane, and the mesh's faces
 *      across the region's other diagonals are as good a triangulation of
 *      it as the region's own (homer.off, rotor.off: Steiner points on a
 *      triangle's edges, the mesh and the facet taking other diagonals
 *      between them, a sliver of rounding error between the two layers
 *      that the cavity of steps 1-4 cannot split into an upper and a
 *      lower side).
 * It is done only when no subsegment edge and no subfacet face inside C
 * (a recovered neighbour) would be lost, and no vertex of C either. What
 * fails is left missing: ref_queue_boundary and ref_run split it as
 * before, with the subfacets this phase recovered already constraints;
 * ref_run first tries the region again (ref__recover_region), since its
 * neighbours may have changed.
 *
 * What it guarantees: every commit replaces a set of tetrahedra by a
 * tetrahedralization of the same polyhedron with the same boundary faces
 * and vertices (all new tetrahedra positively oriented, their unshared
 * faces exactly the old boundary faces seen from the same side: by the
 * winding number they cover it once), so the mesh stays a valid
 * tetrahedralization of the same points (no longer Delaunay: the flips of
 * ref_cdt_restore after the carving mend what they can, and
 * ref_mesher.keep_stuck leaves the rest, counted); every present
 * subsegment and every subfacet made present stays present; no point is
 * inserted, so the phase ends (passes repeat only while one recovers a
 * region). It does not guarantee that a region is recovered: a cavity may
 * need Steiner points (Schonhardt's polyhedron), and only the Delaunay
 * fill and cones are tried.
 *
 * Ownership: works in place on r's mesh; all scratch is its own and freed
 * before returning.
 */
#include "config.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "base/pdr_util.h"
#include "geom/pred.h"
#include "mesh/dt.h"
#include "refine/refine_int.h"

#define X(m, v) ((m)->xyz + 3 * (size_t)(v))

/* Limits of one recovery: tetrahedra in the cavity, and rounds of growth
 * across boundary faces the Delaunay fill lacks. Beyond them the subfacet
 * is left to the splits. */
#define FR_CAV_MAX 2048
#define FR_GROW_MAX 16
#define FR_PASSES 4

/* A face of the cavity's boundary, or a floor triangle (tet == TM_NONE,
 * face: its index in the region). */
typedef struct fr_face {
    uint32_t v[3];   /* mesh vertices; the cavity on the positive side */
    uint32_t key[3]; /* local numbers in the side's scratch mesh, sorted */
    uint32_t tet;    /* cavity tetrahedron, TM_NONE for the floor */
    uint32_t face;   /* its face; for the floor, the region's triangle */
    int8_t side;     /* 0 upper, 1 lower */
    tm_link outer;   /* the link across it */
    uint32_t su;     /* the scratch tetrahedron inside it, TM_NONE */
    uint8_t sf;      /* its face */
} fr_face;

/* Side of a mesh vertex (facrec.vside): not looked at yet, a vertex of the
 * region (on the floor), above or below the region (strictly for at least
 * one of its triangles, on no side of any other), in the plane of every
 * one of them (outside the region), or above some and below others (near
 * a bent region: no cavity). */
enum { FR_V_UNKNOWN = 0, FR_V_FLOOR, FR_V_UP, FR_V_DOWN, FR_V_PLANE, FR_V_NONE };

/* Why a region was left (facrec.why, the trace line). */
enum {
    FR_W_REGION,  /* a region edge on the facet's boundary is missing, or
                     the region is too large */
    FR_W_COLLECT, /* no crossing tetrahedron, or the cavity too large */
    FR_W_SIDES,   /* a vertex or boundary face on no side */
    FR_W_FILL,    /* no Delaunay tetrahedralization of a side's points */
    FR_W_FLOOR,   /* a floor triangle missing from every fill */
    FR_W_OPEN,    /* the faces found do not close a fill */
    FR_W_GROW,    /* the cavity cannot grow across a missing face */
    FR_W_KEEP,    /* a fill loses a kept edge, subfacet or vertex */
    FR_W_N
};

typedef struct facrec {
    ref_mesher *r;
    uint32_t *reg; /* the region: missing subfacets of one facet */
    size_t nreg, capreg;
    uint8_t *vside; /* per mesh vertex, FR_V_*; reset through touched */
    uint32_t *touched;
    size_t ntouched, captouched;
    uint32_t *cav; /* cavity tetrahedra (TM_F_CAVITY set on them) */
    size_t ncav, capcav;
    uint32_t ring[256];
    size_t nring;
    fr_face *bf; /* boundary faces, then the floors of both sides */
    size_t nbf, capbf;
    uint32_t *keep; /* subsegment edges to keep, 2 vertices each */
    size_t nkeepe, capkeepe; /* (entries, not edges) */
    uint32_t *keepf; /* subfacets to keep, 3 vertices each */
    size_t nkeepf, capkeepf;
    uint32_t *pts[2]; /* mesh vertices of each side, local number i + 1 */
    size_t npts[2], cappts[2];
    uint32_t *vloc[2]; /* per mesh vertex: local number on a side, 0 none */
    tm_mesh sub[2];  /* the sides' Delaunay tetrahedralizations */
    uint32_t *fill[2]; /* their tetrahedra inside the cavity */
    size_t nfill[2], capfill[2];
    int32_t *fidx[2]; /* per scratch face (4 t + f): index in bf, or -1 */
    size_t capfidx[2];
    uint32_t *map[2]; /* per scratch tetrahedron: the new mesh one */
    size_t capmap[2];
    struct fr_key *order; /* one side's faces, sorted by key */
    size_t norder, caporder;
    uint32_t *miss; /* faces the Delaunay fill lacks (indices in bf) */
    size_t capmiss;
    size_t cones; /* sides filled by a cone */
    struct fr_dedge *de; /* adopt(): directed edges */
    size_t capde;
    uint32_t *tris; /* adopt(): its triangles, 3 vertices each */
    size_t ntris, captris;
    size_t adopted; /* subfacets replaced by faces of the mesh (step 5) */
    size_t recovered, regions;
    int last; /* the reason of the last give-up */
    size_t why[FR_W_N]; /* regions left, by reason, for the trace */
} facrec;


#define FR_REGION_MAX 64

/* ------------------------------------------------------------ geometry */

static const double *tri_x(const facrec *s, size_t i, int k)
{
    return X(&s->r->m, s->r->bd.facs[s->reg[i]].v[k]);
}

/* The side of mesh vertex v (FR_V_*), computed once per region. */
static int vside(facrec *s, uint32_t v)
{
    if (s->vside[v])
        return s->vside[v];
    if (pdr_grow((void **)&s->touched, &s->captouched, s->ntouched + 1, sizeof *s->touched))
        return -1;
    s->touched[s->ntouched++] = v;
    int pos = 0, neg = 0;
    const double *p = X(&s->r->m, v);
    for (size_t i = 0; i < s->nreg; i++) {
        int o = pred_orient3d(tri_x(s, i, 0), tri_x(s, i, 1), tri_x(s, i, 2), p);
        pos |= o > 0;
        neg |= o < 0;
    }
    s->vside[v] = pos && neg ? FR_V_NONE : pos ? FR_V_UP : neg ? FR_V_DOWN : FR_V_PLANE;
    return s->vside[v];
}

static void vside_clear(facrec *s)
{
    for (size_t i = 0; i < s->ntouched; i++)
        s->vside[s->touched[i]] = FR_V_UNKNOWN;
    s->ntouched = 0;
}

/* 1 if the open tetrahedron t meets the open triangle abc, else 0, by
 * exact predicates: the tetrahedron must have vertices strictly on both
 * sides of the triangle's plane H; then its section P by H and the
 * triangle are convex polygons of H, whose interiors meet unless the line
 * of an edge of one separates them (the separating axis test): the plane
 * of a face of t with a, b and c weakly outside, or the line of an edge
 * of abc with every corner of P weakly outside. A corner of P is a vertex
 * of t on H or the crossing of an edge pq (p above H, q below); its side
 * of line ab is the sign of orient3d(p, q, a, b) (the same as for any
 * point of H with p above it), compared with c's, orient3d(p0, c, a, b)
 * with p0 any vertex above. */
static int crosses_tri(const tm_mesh *m, uint32_t t, const double *a, const double *b,
                       const double *c)
{
    const uint32_t *v = m->tets[t].v;
    const double *x[4];
    int sd[4], pos = -1, neg = 0;
    for (int k = 0; k < 4; k++) {
        x[k] = X(m, v[k]);
        sd[k] = pred_orient3d(a, b, c, x[k]);
        if (sd[k] > 0)
            pos = k;
        neg |= sd[k] < 0;
    }
    if (pos < 0 || !neg)
        return 0;
    for (int f = 0; f < 4; f++) {
        const uint8_t *fv = tm_face_vtx[f];
        const double *f0 = x[fv[0]], *f1 = x[fv[1]], *f2 = x[fv[2]];
        if (pred_orient3d(f0, f1, f2, a) <= 0 && pred_orient3d(f0, f1, f2, b) <= 0 &&
            pred_orient3d(f0, f1, f2, c) <= 0)
            return 0;
    }
    const double *tri[3] = {a, b, c};
    for (int e = 0; e < 3; e++) {
        const double *ea = tri[e], *eb = tri[(e + 1) % 3], *ec = tri[(e + 2) % 3];
        int in = pred_orient3d(x[pos], ec, ea, eb);
        int outside = 1;
        for (int i = 0; i < 4 && outside; i++) {
            if (sd[i] == 0) {
                int o = pred_orient3d(x[pos], x[i], ea, eb);
                outside = o == 0 || o != in;
                continue;
            }
            if (sd[i] < 0)
                continue;
            for (int j = 0; j < 4 && outside; j++) {
                if (sd[j] >= 0)
                    continue;
                int o = pred_orient3d(x[i], x[j], ea, eb);
                outside = o == 0 || o != in;
            }
        }
        if (outside)
            return 0;
    }
    return 1;
}

/* 1 if tetrahedron t crosses a triangle of the region, 0 if not, -1 on
 * failure (no memory). */
static int crosses(facrec *s, uint32_t t)
{
    const tm_mesh *m = &s->r->m;
    if (tm_is_ghost(m, t))
        return 0;
    int up = 0, down = 0;
    for (int k = 0; k < 4; k++) {
        int sd = vside(s, m->tets[t].v[k]);
        if (sd < 0)
            return -1;
        up |= sd == FR_V_UP || sd == FR_V_NONE;
        down |= sd == FR_V_DOWN || sd == FR_V_NONE;
    }
    if (!up || !down)
        return 0;
    for (size_t i = 0; i < s->nreg; i++)
        if (crosses_tri(m, t, tri_x(s, i, 0), tri_x(s, i, 1), tri_x(s, i, 2)))
            return 1;
    return 0;
}

/* ------------------------------------------------------------- cavity */

static int cav_add(facrec *s, uint32_t t)
{
    if (s->ncav >= FR_CAV_MAX)
        return 1;
    if (pdr_grow((void **)&s->cav, &s->capcav, s->ncav + 1, sizeof *s->cav))
        return PDR_ENOMEM;
    s->cav[s->ncav++] = t;
    s->r->m.flags[t] |= TM_F_CAVITY;
    return 0;
}

static void cav_clear(facrec *s)
{
    for (size_t i = 0; i < s->ncav; i++)
        s->r->m.flags[s->cav[i]] &= (uint16_t)~TM_F_CAVITY;
    s->ncav = 0;
}

static int gather(const tm_mesh *m, uint32_t t, void *arg)
{
    (void)m;
    facrec *s = arg;
    if (s->nring == sizeof s->ring / sizeof s->ring[0])
        return 1;
    s->ring[s->nring++] = t;
    return 0;
}

/* The region of missing subfacet id: the missing subfacets of its facet
 * reached across edges that are not edges of the mesh (BD_F_VISIT marks
 * them while it is built). Returns 0, 1 (give up: an edge on the facet's
 * boundary missing, or too many) or a negative code. */
static int region(facrec *s, uint32_t id)
{
    ref_mesher *r = s->r;
    bd_set *bd = &r->bd;
    s->nreg = 0;
    int rc = 0;
    if (pdr_grow((void **)&s->reg, &s->capreg, 1, sizeof *s->reg))
        return PDR_ENOMEM;
    s->reg[s->nreg++] = id;
    bd->facs[id].flags |= BD_F_VISIT;
    for (size_t i = 0; i < s->nreg && !rc; i++) {
        const bd_subfac *F = &bd->facs[s->reg[i]];
        for (int k = 0; k < 3 && !rc; k++) {
            uint32_t a = F->v[(k + 1) % 3], b = F->v[(k + 2) % 3], t;
            if (ref__find_in_star(&r->m, a, b, TM_NONE, &t))
                continue;
            uint32_t n = bd_subfac_across(bd, s->reg[i], k);
            if (n == BD_NONE || s->nreg >= FR_REGION_MAX) {
                rc = 1;
                break;
            }
            if (bd->facs[n].flags & BD_F_VISIT)
                continue;
            if (pdr_grow((void **)&s->reg, &s->capreg, s->nreg + 1, sizeof *s->reg)) {
                rc = PDR_ENOMEM;
                break;
            }
            s->reg[s->nreg++] = n;
            bd->facs[n].flags |= BD_F_VISIT;
        }
    }
    for (size_t i = 0; i < s->nreg; i++)
        bd->facs[s->reg[i]].flags &= (uint16_t)~BD_F_VISIT;
    if (rc)
        return rc;
    /* Its vertices are the floor. */
    for (size_t i = 0; i < s->nreg; i++)
        for (int k = 0; k < 3; k++) {
            uint32_t v = bd->facs[s->reg[i]].v[k];
            if (s->vside[v])
                continue;
            if (pdr_grow((void **)&s->touched, &s->captouched, s->ntouched + 1,
                         sizeof *s->touched))
                return PDR_ENOMEM;
            s->touched[s->ntouched++] = v;
            s->vside[v] = FR_V_FLOOR;
        }
    return 0;
}

/* Adds tetrahedron u to the cavity if it is not in it and crosses the
 * region: 0, 1 (the cavity too large) or a negative code. */
static int take_if_crossing(facrec *s, uint32_t u)
{
    if (s->r->m.flags[u] & TM_F_CAVITY)
        return 0;
    int c = crosses(s, u);
    if (c < 0)
        return PDR_ENOMEM;
    return c > 0 ? cav_add(s, u) : 0;
}

/* Step 1: the tetrahedra crossing the region, from those around its
 * present edges. Returns 0, 1 (give up) or a negative code. */
static int collect(facrec *s)
{
    tm_mesh *m = &s->r->m;
    for (size_t i = 0; i < s->nreg; i++) {
        const uint32_t *fv = s->r->bd.facs[s->reg[i]].v;
        for (int e = 0; e < 3; e++) {
            uint32_t a = fv[e], b = fv[(e + 1) % 3], t;
            if (!ref__find_in_star(m, a, b, TM_NONE, &t))
                continue;
            s->nring = 0;
            if (ref_around_edge(m, t, a, b, gather, s) != 0)
                return 1;
            for (size_t j = 0; j < s->nring; j++) {
                int rc = take_if_crossing(s, s->ring[j]);
                if (rc)
                    return rc;
            }
        }
    }
    if (!s->ncav)
        return 1; /* coplanar: the mesh triangulates the region otherwise */
    for (size_t i = 0; i < s->ncav; i++) {
        const tm_tet *T = &m->tets[s->cav[i]];
        for (int f = 0; f < 4; f++) {
            tm_link l = T->n[f];
            if (tm_is_special(l))
                return 1;
            int rc = take_if_crossing(s, tm_ltet(l));
            if (rc)
                return rc;
        }
    }
    return 0;
}

static int push_keep(uint32_t **arr, size_t *n, size_t *cap, const uint32_t *v, size_t k)
{
    if (pdr_grow((void **)arr, cap, *n + k, sizeof **arr))
        return PDR_ENOMEM;
    memcpy(*arr + *n, v, k * sizeof *v);
    *n += k;
    return 0;
}

static int add_point(facrec *s, int k, uint32_t v)
{
    if (s->vloc[k][v])
        return 0;
    if (pdr_grow((void **)&s->pts[k], &s->cappts[k], s->npts[k] + 1, sizeof *s->pts[k]))
        return PDR_ENOMEM;
    s->pts[k][s->npts[k]++] = v;
    s->vloc[k][v] = (uint32_t)s->npts[k];
    return 0;
}

static void points_clear(facrec *s)
{
    for (int k = 0; k < 2; k++) {
        for (size_t i = 0; i < s->npts[k]; i++)
            s->vloc[k][s->pts[k][i]] = 0;
        s->npts[k] = 0;
    }
}

static int add_face(facrec *s, const uint32_t v[3], uint32_t t, int f, int side,
                    tm_link outer)
{
    if (pdr_grow((void **)&s->bf, &s->capbf, s->nbf + 1, sizeof *s->bf))
        return PDR_ENOMEM;
    fr_face *F = &s->bf[s->nbf++];
    memcpy(F->v, v, sizeof F->v);
    F->tet = t;
    F->face = (uint32_t)f;
    F->side = (int8_t)side;
    F->outer = outer;
    F->su = TM_NONE;
    F->sf = 0;
    return 0;
}

/* Step 2: the boundary faces with their sides, the points of each side
 * and what must be kept. Returns 0, 1 (give up) or a negative code. */
static int boundary(facrec *s)
{
    ref_mesher *r = s->r;
    tm_mesh *m = &r->m;
    int rc;
    s->nbf = s->nkeepe = s->nkeepf = 0;
    points_clear(s);
    for (size_t i = 0; i < s->ncav; i++) {
        uint32_t t = s->cav[i];
        const tm_tet *T = &m->tets[t];
        for (int e = 0; e < 6; e++) {
            if (!(m->flags[t] & TM_F_SUBSEG(e)))
                continue;
            uint32_t ab[2] = {T->v[tm_edge_vtx[e][0]], T->v[tm_edge_vtx[e][1]]};
            if ((rc = push_keep(&s->keep, &s->nkeepe, &s->capkeepe, ab, 2)))
                return rc;
        }
        for (int f = 0; f < 4; f++) {
            tm_link l = T->n[f];
            const uint8_t *fv = tm_face_vtx[f];
            uint32_t v[3] = {T->v[fv[0]], T->v[fv[1]], T->v[fv[2]]};
            if (!tm_is_special(l) && (m->flags[tm_ltet(l)] & TM_F_CAVITY)) {
                if (t < tm_ltet(l) && bd_find_subfac(&r->bd, v[0], v[1], v[2]) != BD_NONE &&
                    (rc = push_keep(&s->keepf, &s->nkeepf, &s->capkeepf, v, 3)))
                    return rc;
                continue;
            }
            int pos = 0, neg = 0;
            for (int k = 0; k < 3; k++) {
                int sd = s->vside[v[k]];
                pos |= sd == FR_V_UP || sd == FR_V_NONE;
                neg |= sd == FR_V_DOWN || sd == FR_V_NONE;
            }
            if (pos == neg) {
                s->last = FR_W_SIDES;
                return 1; /* across the floor, or in it */
            }
            if ((rc = add_face(s, v, t, f, neg, l)))
                return rc;
        }
    }
    /* The points: every vertex of C on a side, and the region's vertices
     * on both. */
    for (size_t i = 0; i < s->ncav; i++)
        for (int k = 0; k < 4; k++) {
            uint32_t v = m->tets[s->cav[i]].v[k];
            int sd = s->vside[v];
            if ((sd == FR_V_UP || sd == FR_V_DOWN) && (rc = add_point(s, sd == FR_V_DOWN, v)))
                return rc;
        }
    for (int k = 0; k < 2; k++)
        for (size_t i = 0; i < s->nreg; i++)
            for (int j = 0; j < 3; j++)
                if ((rc = add_point(s, k, r->bd.facs[s->reg[i]].v[j])))
                    return rc;
    /* Every vertex of C must be a point of a side (else it would go). */
    for (size_t i = 0; i < s->ncav; i++)
        for (int k = 0; k < 4; k++) {
            uint32_t v = m->tets[s->cav[i]].v[k];
            if (!s->vloc[0][v] && !s->vloc[1][v]) {
                s->last = FR_W_SIDES;
                return 1;
            }
        }
    /* The floor, once for each side, seen from it. */
    for (size_t i = 0; i < s->nreg; i++) {
        const uint32_t *fv = r->bd.facs[s->reg[i]].v;
        uint32_t up[3] = {fv[0], fv[1], fv[2]}, down[3] = {fv[0], fv[2], fv[1]};
        if ((rc = add_face(s, up, TM_NONE, (int)i, 0, TM_LINK_UNSET)) ||
            (rc = add_face(s, down, TM_NONE, (int)i, 1, TM_LINK_UNSET)))
            return rc;
    }
    return 0;
}

/* ------------------------------------------------------------ fills */

static int key_cmp(const uint32_t *a, const uint32_t *b)
{
    for (int k = 0; k < 3; k++)
        if (a[k] != b[k])
            return a[k] < b[k] ? -1 : 1;
    return 0;
}

static void sort3(uint32_t k[3])
{
    uint32_t x;
    if (k[0] > k[1]) { x = k[0]; k[0] = k[1]; k[1] = x; }
    if (k[1] > k[2]) { x = k[1]; k[1] = k[2]; k[2] = x; }
    if (k[0] > k[1]) { x = k[0]; k[0] = k[1]; k[1] = x; }
}

/* A side's face in the sorted table: its key and its index in bf. */
typedef struct fr_key {
    uint32_t key[3];
    uint32_t i;
} fr_key;

static int fr_key_cmp(const void *x, const void *y)
{
    return key_cmp(((const fr_key *)x)->key, ((const fr_key *)y)->key);
}

/* The bf index with key k among order[0..n), or -1. */
static long find_key(const facrec *s, size_t n, const uint32_t k[3])
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        int c = key_cmp(s->order[mid].key, k);
        if (!c)
            return (long)s->order[mid].i;
        if (c < 0)
            lo = mid + 1;
        else
            hi = mid;
    }
    return -1;
}

/* The scratch mesh of side k with the side's points (local number i + 1
 * for pts[k][i]) and no tetrahedron. Returns 0 or a negative code. */
static int sub_points(facrec *s, int k)
{
    tm_mesh *S = &s->sub[k];
    size_t n = s->npts[k];
    tm_free(S);
    int rc = tm_init(S, 0);
    if (!rc)
        rc = tm_reserve(S, n + 1, 8 * n + 64);
    for (size_t i = 0; i < n && !rc; i++) {
        uint32_t lv;
        rc = tm_add_vertex(S, X(&s->r->m, s->pts[k][i]), &lv);
    }
    return rc;
}

/* Strategy 0: the Delaunay tetrahedralization of the side's points.
 * Returns 0, 2 (none) or a negative code. */
static int build_dt(facrec *s, int k)
{
    int rc = sub_points(s, k);
    if (rc)
        return rc;
    dt_build_opts bo;
    memset(&bo, 0, sizeof bo);
    bo.seed = 1;
    dt_build_stats bs;
    rc = dt_build(&s->sub[k], &bo, &bs);
    if (rc == PDR_EGEOMETRY)
        return 2;
    if (rc)
        return rc;
    return bs.inserted == s->npts[k] ? 0 : 2;
}

/* Strategy 1 + j: the cone from the side's point j to every face of the
 * side that does not hold it, if the cavity is a star from it (every such
 * face sees it strictly inside) and it leaves no point out. Returns 0, 2
 * (not a star) or a negative code. */
static int build_cone(facrec *s, int k, size_t j)
{
    const tm_mesh *m = &s->r->m;
    uint32_t apex = s->pts[k][j];
    const double *p = X(m, apex);
    size_t nf = 0;
    for (size_t i = 0; i < s->nbf; i++) {
        const fr_face *F = &s->bf[i];
        if (F->side != k || F->v[0] == apex || F->v[1] == apex || F->v[2] == apex)
            continue;
        if (pred_orient3d(X(m, F->v[0]), X(m, F->v[1]), X(m, F->v[2]), p) <= 0)
            return 2;
        nf++;
    }
    if (!nf)
        return 2;
    /* Every point must be a corner of a face (the apex excepted): the top
     * bit of vloc marks the points not seen yet (local numbers are far
     * below it). */
    for (size_t i = 0; i < s->npts[k]; i++)
        s->vloc[k][s->pts[k][i]] |= 0x80000000u;
    for (size_t i = 0; i < s->nbf; i++)
        if (s->bf[i].side == k)
            for (int c = 0; c < 3; c++)
                s->vloc[k][s->bf[i].v[c]] &= 0x7fffffffu;
    s->vloc[k][apex] &= 0x7fffffffu;
    int lost = 0;
    for (size_t i = 0; i < s->npts[k]; i++) {
        lost |= (s->vloc[k][s->pts[k][i]] & 0x80000000u) != 0;
        s->vloc[k][s->pts[k][i]] &= 0x7fffffffu;
    }
    if (lost)
        return 2;
    int rc = sub_points(s, k);
    if (!rc)
        rc = tm_room(&s->sub[k], nf);
    if (rc)
        return rc;
    tm_mesh *S = &s->sub[k];
    for (size_t i = 0; i < s->nbf; i++) {
        const fr_face *F = &s->bf[i];
        if (F->side != k || F->v[0] == apex || F->v[1] == apex || F->v[2] == apex)
            continue;
        uint32_t t = tm_alloc_tet(S);
        for (int c = 0; c < 3; c++)
            S->tets[t].v[c] = s->vloc[k][F->v[c]];
        S->tets[t].v[3] = s->vloc[k][apex];
    }
    size_t nonmanifold;
    rc = tm_link_faces(S, &nonmanifold);
    if (rc)
        return rc;
    return nonmanifold ? 2 : 0;
}

/* Matches side k's faces to the scratch mesh and floods the fill from
 * them. Returns 0 with s->fill[k], 1 when faces are missing (their
 * indices in s->bf flagged by su == TM_NONE), 2 when the faces do not
 * close the fill, or a negative code. */
static int match_and_flood(facrec *s, int k)
{
    tm_mesh *S = &s->sub[k];
    size_t no = 0;
    for (size_t i = 0; i < s->nbf; i++) {
        fr_face *F = &s->bf[i];
        if (F->side != k)
            continue;
        for (int j = 0; j < 3; j++)
            F->key[j] = s->vloc[k][F->v[j]];
        sort3(F->key);
        F->su = TM_NONE;
        if (pdr_grow((void **)&s->order, &s->caporder, no + 1, sizeof *s->order))
            return PDR_ENOMEM;
        memcpy(s->order[no].key, F->key, sizeof F->key);
        s->order[no++].i = (uint32_t)i;
    }
    qsort(s->order, no, sizeof *s->order, fr_key_cmp);
    for (size_t i = 1; i < no; i++)
        if (!key_cmp(s->order[i - 1].key, s->order[i].key))
            return 2; /* a face twice: a pinched cavity */
    s->norder = no;
    if (pdr_grow((void **)&s->fidx[k], &s->capfidx[k], 4 * (size_t)S->nslots,
                 sizeof *s->fidx[k]))
        return PDR_ENOMEM;
    for (size_t i = 0; i < 4 * (size_t)S->nslots; i++)
        s->fidx[k][i] = -1;
    for (uint32_t u = 0; u < S->nslots; u++) {
        if (tm_is_dead(S, u) || tm_is_ghost(S, u))
            continue;
        const uint32_t *v = S->tets[u].v;
        for (int f = 0; f < 4; f++) {
            const uint8_t *fv = tm_face_vtx[f];
            uint32_t key[3] = {v[fv[0]], v[fv[1]], v[fv[2]]};
            sort3(key);
            long i = find_key(s, no, key);
            if (i < 0)
                continue;
            fr_face *F = &s->bf[i];
            const double *p0 = X(S, s->vloc[k][F->v[0]]), *p1 = X(S, s->vloc[k][F->v[1]]),
                         *p2 = X(S, s->vloc[k][F->v[2]]);
            if (pred_orient3d(p0, p1, p2, X(S, v[f])) <= 0)
                continue; /* the tetrahedron outside it */
            F->su = u;
            F->sf = (uint8_t)f;
            S->flags[u] |= TM_F_FACEMARK(f);
            s->fidx[k][4 * (size_t)u + (size_t)f] = (int32_t)i;
        }
    }
    for (size_t j = 0; j < no; j++)
        if (s->bf[s->order[j].i].su == TM_NONE)
            return 1;
    s->nfill[k] = 0;
    for (size_t j = 0; j < no; j++) {
        uint32_t u = s->bf[s->order[j].i].su;
        if (S->flags[u] & TM_F_CAVITY)
            continue;
        S->flags[u] |= TM_F_CAVITY;
        if (pdr_grow((void **)&s->fill[k], &s->capfill[k], s->nfill[k] + 1, sizeof *s->fill[k]))
            return PDR_ENOMEM;
        s->fill[k][s->nfill[k]++] = u;
    }
    for (size_t i = 0; i < s->nfill[k]; i++) {
        uint32_t u = s->fill[k][i];
        for (int f = 0; f < 4; f++) {
            if (S->flags[u] & TM_F_FACEMARK(f))
                continue;
            tm_link l = S->tets[u].n[f];
            if (tm_is_special(l) || tm_is_ghost(S, tm_ltet(l)))
                return 2; /* the faces do not close the cavity */
            uint32_t w = tm_ltet(l);
            if (S->flags[w] & TM_F_CAVITY)
                continue;
            S->flags[w] |= TM_F_CAVITY;
            if (pdr_grow((void **)&s->fill[k], &s->capfill[k], s->nfill[k] + 1,
                         sizeof *s->fill[k]))
                return PDR_ENOMEM;
            s->fill[k][s->nfill[k]++] = w;
        }
    }
    return 0;
}

static int in_side(const facrec *s, int k, const uint32_t *v, int n);

/* 1 if side k's fill keeps every point of the side and every kept edge
 * and face whose vertices are all on side k and not all on the other. */
static int side_keeps(const facrec *s, int k)
{
    const uint32_t *arr[2] = {s->keep, s->keepf};
    size_t len[2] = {s->nkeepe, s->nkeepf};
    for (int w = 0; w < 2; w++) {
        int n = w + 2;
        for (size_t i = 0; i < len[w]; i += (size_t)n) {
            const uint32_t *v = arr[w] + i;
            int mine = 1, theirs = 1;
            for (int j = 0; j < n; j++) {
                mine &= s->vloc[k][v[j]] != 0;
                theirs &= s->vloc[1 - k][v[j]] != 0;
            }
            if (mine && !theirs && !in_side(s, k, v, n))
                return 0;
        }
    }
    for (size_t i = 0; i < s->npts[k]; i++)
        if (!in_side(s, k, &s->pts[k][i], 1))
            return 0;
    return 1;
}

/* Step 3 for side k: 0 with the fill in s->fill[k], 1 when a boundary
 * face is missing from every tetrahedralization tried (the cavity grown
 * across them: call again), 2 to give up, or a negative code. */
static int fill_side(facrec *s, int k)
{
    tm_mesh *m = &s->r->m;
    int rc = build_dt(s, k);
    s->last = FR_W_FILL;
    if (rc < 0)
        return rc;
    int dt = rc == 0 ? match_and_flood(s, k) : 2;
    if (dt < 0)
        return dt;
    if (dt == 0 && side_keeps(s, k))
        return 0;
    /* Keep the missing faces of the Delaunay try for the growth. */
    size_t nmiss = 0;
    if (dt == 1)
        for (size_t j = 0; j < s->norder; j++)
            if (s->bf[s->order[j].i].su == TM_NONE) {
                if (pdr_grow((void **)&s->miss, &s->capmiss, nmiss + 1, sizeof *s->miss))
                    return PDR_ENOMEM;
                s->miss[nmiss++] = s->order[j].i;
            }
    for (size_t j = 0; j < s->npts[k]; j++) {
        rc = build_cone(s, k, j);
        if (rc < 0)
            return rc;
        if (rc)
            continue;
        rc = match_and_flood(s, k);
        if (rc < 0)
            return rc;
        if (rc == 0 && side_keeps(s, k)) {
            s->cones++;
            return 0;
        }
    }
    if (dt != 1) {
        s->last = dt == 0 ? FR_W_KEEP : FR_W_OPEN;
        return 2;
    }
    /* Missing faces: grow the cavity across them. */
    int grew = 0;
    for (size_t j = 0; j < nmiss; j++) {
        const fr_face *F = &s->bf[s->miss[j]];
        s->last = FR_W_FLOOR;
        if (F->tet == TM_NONE)
            return 2; /* the floor */
        s->last = FR_W_GROW;
        uint32_t u = tm_ltet(F->outer);
        if (tm_is_special(F->outer) || tm_is_ghost(m, u))
            return 2;
        if (m->flags[u] & TM_F_CAVITY)
            continue; /* grown already this round */
        int sd = vside(s, m->tets[u].v[tm_lface(F->outer)]);
        if (sd < 0)
            return PDR_ENOMEM;
        if (sd == FR_V_NONE || (k == 0 && sd == FR_V_DOWN) || (k == 1 && sd == FR_V_UP))
            return 2;
        if ((rc = cav_add(s, u)))
            return rc < 0 ? rc : 2;
        grew = 1;
    }
    return grew ? 1 : 2;
}

/* 1 if a fill tetrahedron of side k has the mesh vertices v[0..n). */
static int in_side(const facrec *s, int k, const uint32_t *v, int n)
{
    uint32_t l[3];
    for (int j = 0; j < n; j++)
        if (!(l[j] = s->vloc[k][v[j]]))
            return 0;
    const tm_mesh *S = &s->sub[k];
    for (size_t i = 0; i < s->nfill[k]; i++) {
        const tm_tet *T = &S->tets[s->fill[k][i]];
        int c = 0;
        for (int j = 0; j < n; j++)
            c += ref__slot_in(T, l[j]) >= 0;
        if (c == n)
            return 1;
    }
    return 0;
}

/* 1 if a fill tetrahedron of either side has the mesh vertices v[0..n)
 * (n = 2: an edge, 3: a face). */
static int in_fill(const facrec *s, const uint32_t *v, int n)
{
    return in_side(s, 0, v, n) || in_side(s, 1, v, n);
}

/* Every vertex, subsegment edge and inner subfacet of C in the fills. */
static int keeps_all(facrec *s)
{
    for (size_t i = 0; i < s->nkeepe; i += 2)
        if (!in_fill(s, s->keep + i, 2))
            return 0;
    for (size_t i = 0; i < s->nkeepf; i += 3)
        if (!in_fill(s, s->keepf + i, 3))
            return 0;
    for (int k = 0; k < 2; k++)
        for (size_t i = 0; i < s->npts[k]; i++) {
            uint32_t v = s->pts[k][i];
            if (!in_fill(s, &v, 1))
                return 0;
        }
    return 1;
}

/* Step 4. Returns 0 or a negative code (nothing changed then). */
static int commit(facrec *s)
{
    ref_mesher *r = s->r;
    tm_mesh *m = &r->m;
    int rc = tm_room(m, s->nfill[0] + s->nfill[1]);
    if (!rc)
        rc = tm_marker_room(m, s->nfill[0] + s->nfill[1]);
    for (int k = 0; k < 2 && !rc; k++)
        if (pdr_grow((void **)&s->map[k], &s->capmap[k], s->sub[k].nslots, sizeof *s->map[k]))
            rc = PDR_ENOMEM;
    if (rc)
        return rc;
    for (int k = 0; k < 2; k++)
        for (size_t i = 0; i < s->nfill[k]; i++) {
            uint32_t u = s->fill[k][i], t = tm_alloc_tet(m);
            s->map[k][u] = t;
            for (int j = 0; j < 4; j++)
                m->tets[t].v[j] = s->pts[k][s->sub[k].tets[u].v[j] - 1];
        }
    /* The floor's entries come in pairs (boundary()): 2i upper, 2i + 1
     * lower after the nbf - 2 nreg boundary faces. */
    size_t floor0 = s->nbf - 2 * s->nreg;
    for (int k = 0; k < 2; k++) {
        const tm_mesh *S = &s->sub[k];
        for (size_t i = 0; i < s->nfill[k]; i++) {
            uint32_t u = s->fill[k][i], t = s->map[k][u];
            for (int f = 0; f < 4; f++) {
                int32_t bi = s->fidx[k][4 * (size_t)u + (size_t)f];
                if (bi < 0) {
                    tm_link l = S->tets[u].n[f];
                    m->tets[t].n[f] = tm_mklink(s->map[k][tm_ltet(l)], tm_lface(l));
                    continue;
                }
                const fr_face *F = &s->bf[bi];
                if (F->tet == TM_NONE) {
                    const fr_face *G = &s->bf[floor0 + 2 * F->face + (size_t)(1 - k)];
                    m->tets[t].n[f] = tm_mklink(s->map[1 - k][G->su], G->sf);
                    continue;
                }
                m->tets[t].n[f] = F->outer;
                if (!tm_is_special(F->outer))
                    m->tets[tm_ltet(F->outer)].n[tm_lface(F->outer)] = tm_mklink(t, f);
                if (m->flags[F->tet] & TM_F_FACEMARK(F->face)) {
                    m->flags[t] |= TM_F_FACEMARK(f);
                    if (tm_has_markers(m)) /* room: above */
                        tm_set_marker(m, t, f, tm_marker(m, F->tet, F->face));
                }
            }
        }
    }
    for (int k = 0; k < 2; k++)
        for (size_t i = 0; i < s->nfill[k]; i++) {
            uint32_t t = s->map[k][s->fill[k][i]];
            const tm_tet *T = &m->tets[t];
            for (int e = 0; e < 6; e++) {
                uint32_t id = bd_find_subseg(&r->bd, T->v[tm_edge_vtx[e][0]],
                                             T->v[tm_edge_vtx[e][1]]);
                if (id != BD_NONE && !(r->bd.segs[id].flags & BD_F_MISSING))
                    m->flags[t] |= TM_F_SUBSEG(e);
            }
            for (int j = 0; j < 4; j++)
                m->vhint[T->v[j]] = t;
        }
    for (size_t i = 0; i < s->ncav; i++)
        tm_free_tet(m, s->cav[i]);
    s->ncav = 0;
    return ref_region_room(r);
}

/* ------------------------------------------------ coplanar regions */

/* A directed edge of the retriangulation and how often it is used. */
typedef struct fr_dedge {
    uint32_t a, b;
    int boundary; /* an edge of the region's boundary, region on its left */
    int used;     /* triangles having it (a to b) */
} fr_dedge;

static long dedge_find(const fr_dedge *e, size_t n, uint32_t a, uint32_t b)
{
    for (size_t i = 0; i < n; i++)
        if (e[i].a == a && e[i].b == b)
            return (long)i;
    return -1;
}

static int dedge_add(facrec *s, size_t *n, uint32_t a, uint32_t b, int boundary)
{
    if (pdr_grow((void **)&s->de, &s->capde, *n + 1, sizeof *s->de))
        return PDR_ENOMEM;
    s->de[*n] = (fr_dedge){a, b, boundary, 0};
    (*n)++;
    return 0;
}

/* Which faces adopt_layer() takes where several faces of the mesh through
 * a boundary edge have a third corner on the region: the first one found
 * around the edge, or one whose tetrahedron has its fourth vertex above
 * (below) every triangle of the region, a face of the upper (lower)
 * envelope of the faces with corners on the floor. */
enum { FR_LAYER_ANY, FR_LAYER_UP, FR_LAYER_DOWN, FR_LAYERS };

/* The third corner x of a face a b x of the mesh that adopt_layer() takes
 * for boundary edge a-b (region on its left, turning as turn in facet f's
 * 2D view): x a corner of the region on its side, and for FR_LAYER_UP or
 * FR_LAYER_DOWN the tetrahedron holding a b x with its fourth vertex on
 * that side of the region. *x is TM_NONE when there is none. Returns 0,
 * 1 (give up) or a negative code. */
static int adopt_corner(facrec *s, uint32_t a, uint32_t b, uint32_t f, int turn, int layer,
                        uint32_t *x)
{
    ref_mesher *r = s->r;
    tm_mesh *m = &r->m;
    uint32_t t;
    *x = TM_NONE;
    if (!ref__find_in_star(m, a, b, TM_NONE, &t))
        return 1;
    s->nring = 0;
    if (ref_around_edge(m, t, a, b, gather, s) != 0)
        return 1;
    for (size_t j = 0; j < s->nring; j++) {
        const uint32_t *tv = m->tets[s->ring[j]].v;
        for (int k = 0; k < 4; k++) {
            uint32_t c = tv[k];
            if (c == a || c == b || c == TM_VINF || s->vside[c] != FR_V_FLOOR)
                continue;
            if (ref__orient_facet(r->p, f, X(m, a), X(m, b), X(m, c)) != turn)
                continue;
            if (layer != FR_LAYER_ANY) {
                /* the fourth vertex: the one that is none of a, b, c */
                uint32_t d = tv[0] + tv[1] + tv[2] + tv[3] - a - b - c;
                if (d == TM_VINF)
                    continue;
                int sd = vside(s, d);
                if (sd < 0)
                    return PDR_ENOMEM;
                if (sd != (layer == FR_LAYER_UP ? FR_V_UP : FR_V_DOWN))
                    continue;
            }
            *x = c;
            return 0;
        }
    }
    return 0;
}

/* Step 5 of the top comment: the faces of the mesh that triangulate the
 * region otherwise (the mesh took other diagonals: cocircular vertices of
 * a planar face, or a facet that is planar only up to rounding or the
 * merge's tolerance). They are found from the region's boundary inwards
 * (for each edge, a face of the mesh through it whose third corner is a
 * corner of the region on the region's side in the facet's 2D view,
 * ref__orient_facet, chosen as layer says) and, if they triangulate the
 * region exactly (every boundary edge used once, every inner edge once
 * each way, all turning as the region's triangles do: by the winding
 * number they tile it), they replace its subfacets in the facet's
 * triangulation. Only corners of the region are used, and they lie on the
 * facet by construction, so the new subfacets do too. Returns 0
 * (replaced), 1 (not so) or a negative code. */
static int adopt_layer(facrec *s, int layer)
{
    ref_mesher *r = s->r;
    tm_mesh *m = &r->m;
    bd_set *bd = &r->bd;
    const uint32_t *t0 = bd->facs[s->reg[0]].v;
    uint32_t f = bd->facs[s->reg[0]].facet;
    const double *p0 = X(m, t0[0]), *p1 = X(m, t0[1]), *p2 = X(m, t0[2]);
    int turn = ref__orient_facet(r->p, f, p0, p1, p2);
    if (!turn)
        return 1;
    size_t nde = 0;
    int rc;
    for (size_t i = 0; i < s->nreg; i++) {
        const uint32_t *v = bd->facs[s->reg[i]].v;
        for (int k = 0; k < 3; k++)
            if ((rc = dedge_add(s, &nde, v[k], v[(k + 1) % 3], 1)))
                return rc;
    }
    /* Boundary: directed edges whose reverse is no edge of the region. */
    size_t nb = nde;
    for (size_t i = 0; i < nb; i++)
        s->de[i].boundary = dedge_find(s->de, nb, s->de[i].b, s->de[i].a) < 0;
    size_t n = 0;
    for (size_t i = 0; i < nb; i++)
        if (s->de[i].boundary)
            s->de[n++] = s->de[i];
    nde = n;
    size_t ntri = 0, maxtri = 4 * s->nreg + 16;
    s->ntris = 0;
    for (size_t i = 0; i < nde; i++) {
        fr_dedge e = s->de[i];
        if (e.used)
            continue;
        uint32_t x;
        if ((rc = adopt_corner(s, e.a, e.b, f, turn, layer, &x)))
            return rc;
        if (x == TM_NONE || ntri == maxtri)
            return 1;
        uint32_t tri[3] = {e.a, e.b, x};
        if (pdr_grow((void **)&s->tris, &s->captris, 3 * (ntri + 1), sizeof *s->tris))
            return PDR_ENOMEM;
        memcpy(s->tris + 3 * ntri++, tri, sizeof tri);
        s->ntris = ntri;
        for (int k = 0; k < 3; k++) {
            uint32_t a = tri[k], b = tri[(k + 1) % 3];
            long j = dedge_find(s->de, nde, a, b);
            if (j < 0) {
                if ((rc = dedge_add(s, &nde, a, b, 0)))
                    return rc;
                j = (long)nde - 1;
            }
            if (++s->de[j].used > 1)
                return 1;
            /* An inner edge needs the triangle on its other side. */
            if (!s->de[j].boundary && dedge_find(s->de, nde, b, a) < 0 &&
                (rc = dedge_add(s, &nde, b, a, 0)))
                return rc;
        }
    }
    for (size_t i = 0; i < nde; i++)
        if (s->de[i].used != 1)
            return 1;
    for (size_t i = 0; i < s->nreg; i++)
        bd_kill_subfac(bd, s->reg[i]);
    for (size_t i = 0; i < ntri; i++) {
        const uint32_t *tri = s->tris + 3 * i;
        if ((rc = bd_add_subfac(bd, tri[0], tri[1], tri[2], f, NULL)))
            return rc;
    }
    s->adopted += s->nreg;
    return 0;
}

/* adopt_layer with the first face found through each edge, as before;
 * where that mixes layers (flat tetrahedra with all four corners on the
 * region lie between faces of the mesh that triangulate it in two ways:
 * a triangle of one layer then overlaps one of the other, an edge used
 * twice), with the faces of the upper envelope, then of the lower one. */
static int adopt(facrec *s)
{
    int rc = 1;
    for (int layer = 0; layer < FR_LAYERS && rc == 1; layer++)
        rc = adopt_layer(s, layer);
    return rc;
}

/* Recovers the region of missing subfacet id: 0 done (cavity
 * retriangulated), 2 done (the mesh's faces adopted), 1 left, or a
 * negative code. */
static int recover_one(facrec *s, uint32_t id)
{
    s->ncav = 0;
    s->last = FR_W_REGION;
    int rc = region(s, id);
    int have_region = rc == 0;
    if (!rc) {
        s->last = FR_W_COLLECT;
        rc = collect(s);
    }
    for (int round = 0; !rc && round < FR_GROW_MAX; round++) {
        rc = boundary(s);
        int again = 0;
        for (int k = 0; k < 2 && !rc && !again; k++) {
            int f = fill_side(s, k);
            if (f == 1)
                again = 1;
            else
                rc = f;
        }
        if (rc || again) {
            if (again && round + 1 == FR_GROW_MAX) {
                s->last = FR_W_GROW;
                rc = 1;
            }
            continue;
        }
        if (!keeps_all(s)) {
            s->last = FR_W_KEEP;
            rc = 1;
            break;
        }
        rc = commit(s);
        if (!rc)
            break;
    }
    cav_clear(s);
    points_clear(s);
    if (rc > 0 && have_region) {
        /* Steps 1-4 of the top comment failed (or no tetrahedron crosses
         * the region): the mesh may triangulate it otherwise (step 5). */
        int a = adopt(s);
        if (a <= 0) {
            vside_clear(s);
            return a < 0 ? a : 2;
        }
    }
    vside_clear(s);
    if (rc > 0)
        s->why[s->last]++;
    return rc < 0 ? rc : rc > 0 ? 1 : 0;
}

/* The scratch of a recovery for r's mesh. Returns 0 or PDR_ENOMEM. */
static int fr_open(facrec *s, ref_mesher *r)
{
    memset(s, 0, sizeof *s);
    s->r = r;
    s->vside = pr_calloc(r->m.nv ? r->m.nv : 1, 1);
    if (!s->vside)
        return PDR_ENOMEM;
    for (int k = 0; k < 2; k++) {
        s->vloc[k] = pr_calloc(r->m.nv ? r->m.nv : 1, sizeof *s->vloc[k]);
        if (!s->vloc[k])
            return PDR_ENOMEM;
        int rc = tm_init(&s->sub[k], 0);
        if (rc)
            return rc;
    }
    return 0;
}

static void fr_close(facrec *s)
{
    pr_free(s->cav);
    pr_free(s->de);
    pr_free(s->tris);
    pr_free(s->miss);
    pr_free(s->reg);
    pr_free(s->vside);
    pr_free(s->touched);
    pr_free(s->bf);
    pr_free(s->keep);
    pr_free(s->keepf);
    pr_free(s->order);
    for (int k = 0; k < 2; k++) {
        pr_free(s->pts[k]);
        pr_free(s->vloc[k]);
        tm_free(&s->sub[k]);
        pr_free(s->fill[k]);
        pr_free(s->fidx[k]);
        pr_free(s->map[k]);
    }
}

/* Marks the face of the mesh that subfacet i is (present): 0, or 1 if it
 * is no face. */
static int mark_subfac(ref_mesher *r, uint32_t i)
{
    bd_subfac *F = &r->bd.facs[i];
    uint32_t t;
    if (!ref__find_in_star(&r->m, F->v[0], F->v[1], F->v[2], &t))
        return 1;
    const tm_tet *T = &r->m.tets[t];
    int k = 6 - ref__slot_in(T, F->v[0]) - ref__slot_in(T, F->v[1]) - ref__slot_in(T, F->v[2]);
    int rc = tm_mark_face(&r->m, t, k, (int32_t)F->facet + 1);
    if (rc)
        return rc;
    F->flags &= (uint16_t)~(BD_F_MISSING | BD_F_QUEUED);
    return 0;
}

int ref__recover_region(ref_mesher *r, uint32_t id)
{
    facrec s;
    int rc = fr_open(&s, r);
    if (!rc)
        rc = recover_one(&s, id);
    if (rc == 0) {
        /* The region's subfacets are faces now, and the subfacets inside
         * the cavity are faces again: their marks. */
        for (size_t i = 0; i < s.nreg && rc >= 0; i++)
            rc = mark_subfac(r, s.reg[i]);
        for (size_t i = 0; i < s.nkeepf && rc >= 0; i += 3) {
            uint32_t f = bd_find_subfac(&r->bd, s.keepf[i], s.keepf[i + 1], s.keepf[i + 2]);
            if (f != BD_NONE)
                rc = mark_subfac(r, f);
        }
        rc = rc < 0 ? rc : 0; /* 1: no such face, as before */
        r->st.facrec_faces += s.nreg;
    } else if (rc == 2) {
        /* Retriangulated in its facet: the new subfacets are faces. */
        for (size_t i = 0; i < s.ntris; i++) {
            const uint32_t *t = s.tris + 3 * i;
            uint32_t f = bd_find_subfac(&r->bd, t[0], t[1], t[2]);
            if (f != BD_NONE && mark_subfac(r, f) < 0)
                rc = PDR_ENOMEM;
        }
        rc = rc == PDR_ENOMEM ? rc : 0;
    }
    fr_close(&s);
    return rc;
}

int ref_recover_facets(ref_mesher *r)
{
    facrec s;
    int rc = fr_open(&s, r);
    const bd_set *bd = &r->bd;
    /* tried[i]: subfacet i was in a region that failed in this pass. */
    uint8_t *tried = NULL;
    size_t captried = 0;
    for (int pass = 0; pass < FR_PASSES && !rc; pass++) {
        size_t progress = 0;
        for (uint32_t i = 0; i < bd->nfacs && !rc; i++) {
            if (i == 0 || captried < bd->nfacs) {
                size_t old = i == 0 ? 0 : captried;
                if (pdr_grow((void **)&tried, &captried, bd->nfacs, 1)) {
                    rc = PDR_ENOMEM;
                    break;
                }
                memset(tried + old, 0, captried - old);
            }
            const bd_subfac *F = &bd->facs[i];
            uint32_t t;
            if ((F->flags & BD_F_DEAD) || tried[i] ||
                ref__find_in_star(&r->m, F->v[0], F->v[1], F->v[2], &t))
                continue;
            rc = recover_one(&s, i);
            if (rc == 2) {
                progress++; /* retriangulated in its facet (adopt) */
                rc = 0;
            } else if (rc == 0) {
                s.recovered += s.nreg;
                s.regions++;
                progress++;
            } else if (rc == 1) {
                rc = 0;
                for (size_t j = 0; j < s.nreg; j++)
                    tried[s.reg[j]] = 1;
                tried[i] = 1;
            }
        }
        if (!progress)
            break;
    }
    pr_free(tried);
    r->st.facrec_faces += s.recovered;
    if (r->o.trace)
        fprintf(r->o.trace,
                "facet recovery: %zu subfacets in %zu regions recovered (%zu sides by a cone), %zu "
                "retriangulated in their facet; regions left: "
                "%zu region, %zu collect, %zu sides, %zu fill, %zu floor, %zu open, "
                "%zu grow, %zu keep\n",
                s.recovered, s.regions, s.cones, s.adopted, s.why[FR_W_REGION], s.why[FR_W_COLLECT],
                s.why[FR_W_SIDES], s.why[FR_W_FILL], s.why[FR_W_FLOOR], s.why[FR_W_OPEN],
                s.why[FR_W_GROW], s.why[FR_W_KEEP]);
    fr_close(&s);
    return rc;
}
