/*
 * refine/refine_segrec.c -- the first phase of the constrained recovery
 * (ref_opts.constrained, refine_cdt.c): every input segment made a chain
 * of edges of the tetrahedralization BEFORE any facet is a constraint,
 * as TetGen does (Si 2015, "segment recovery"), instead of splitting
 * missing segments in a mesh whose present subfacets are already
 * constraints.
 *
 * Why. With the subfacets constraints from the start, the split point p of
 * a missing segment must delete the present subfacets of its 2D cavity
 * (the triangles next to the segment whose circumcircle holds p), and its
 * cavity may cross only those. On CAD tessellations (long thin triangles
 * nearly in the plane of their neighbours) that cavity reaches round the
 * neighbouring constraints, is no star from p, and the only star inside it
 * drops one of those subfacets: there is no valid constrained cavity, and
 * the recovery stopped (19 of the public parts of tools/public-surfaces,
 * mesher/refine/RECOVERY.md). Without facet constraints nothing has to be
 * deleted: any star-shaped part of p's conflict region that holds p will
 * do, and one always exists (the tetrahedra that contain p).
 *
 * How. The mesh is the Delaunay tetrahedralization of the input vertices
 * and the box (im.c); no face carries a mark yet. Present subsegments get
 * their edge bits (TM_F_SUBSEG). A missing subsegment is split at
 * ref__split_point (midpoint or concentric shell) with the cavity:
 *   1. the Bowyer-Watson conflict region of p (no face is a constraint);
 *   2. minus tetrahedra until no present subsegment has all its
 *      tetrahedra in it (its edge would vanish) and p sees every boundary
 *      face from inside (the star test); the tetrahedra that contain p
 *      (closed) are never removed: if one had to go, p would lie on a
 *      present subsegment or a face that must stay, which a valid input
 *      does not allow, and the run stops with a clear error.
 * After the commit Lawson's flips (mesh/flip.c; subsegment edges are never
 * flipped) restore local Delaunayness wherever no subsegment blocks it,
 * so the mesh stays a Delaunay tetrahedralization constrained by the
 * present subsegments, and edges of short missing pieces appear as they do
 * in a Delaunay one. The facet triangulations follow each split (the 2D
 * cavity of p in the facets through the segment, as any boundary split,
 * less the subfacets whose fan triangle over a rim subsegment would be
 * flat: unflatten_cavity), but nothing is marked in the mesh: the next phase (ref_queue_boundary,
 * then ref_run) attaches the subfacets, makes the present ones
 * constraints and recovers the missing ones as before, now with every
 * segment present.
 *
 * What it guarantees: a present subsegment is never lost (no cavity
 * deletes its edge, no flip removes it), so every split point lies on a
 * piece that has never been present, and the number of points is bounded
 * by the recovery's own bound (im.c, IM_RECOVERY_*) and the resolution
 * floor (min_spacing): the phase either returns with every subsegment an
 * edge of the mesh, or stops with PDR_ELIMIT (r->stopped_below, and
 * r->stop_hidden when a cavity could not be made; r->stop_at says where).
 * Every commit is of a star-shaped cavity, so the mesh stays valid.
 */
#include "config.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "base/pdr_util.h"
#include "geom/pred.h"
#include "mesh/flip.h"
#include "refine/refine_int.h"
#include "base/v3.h"

#define X(m, v) ((m)->xyz + 3 * (size_t)(v))

/* Tetrahedra around one edge gathered by ref_around_edge; more than this
 * many around one edge does not happen in a mesh of sane input. */
#define SR_RING_MAX 256

typedef struct segrec {
    ref_mesher *r;
    uint32_t *queue; /* missing subsegments, FIFO */
    size_t qhead, qn, qcap;
    uint32_t *cav;   /* the cavity being shaped */
    size_t ncav, capcav;
    uint32_t ring[SR_RING_MAX];
    size_t nring;
    int ring_full;
} segrec;

static int sr_push(segrec *s, uint32_t id)
{
    if (s->qn == s->qcap) {
        if (s->qhead > 0) {
            memmove(s->queue, s->queue + s->qhead, (s->qn - s->qhead) * sizeof *s->queue);
            s->qn -= s->qhead;
            s->qhead = 0;
        }
        if (s->qn == s->qcap &&
            pdr_grow((void **)&s->queue, &s->qcap, s->qn + 1, sizeof *s->queue))
            return PDR_ENOMEM;
    }
    s->queue[s->qn++] = id;
    return 0;
}

/* Marks subsegment id's edge in the mesh if it is an edge: 1, else 0
 * (flagged missing). */
static int attach(ref_mesher *r, uint32_t id)
{
    uint32_t t;
    return ref__mark_subseg(r, id, &t);
}

static int gather_ring(const tm_mesh *m, uint32_t t, void *arg)
{
    (void)m;
    segrec *s = arg;
    if (s->nring == SR_RING_MAX) {
        s->ring_full = 1;
        return 1;
    }
    s->ring[s->nring++] = t;
    return 0;
}

/* 1 if p lies in the closed tetrahedron t. */
static int holds(const tm_mesh *m, uint32_t t, const double p[3])
{
    const tm_tet *T = &m->tets[t];
    for (int f = 0; f < 4; f++) {
        const uint8_t *fv = tm_face_vtx[f];
        if (pred_orient3d(X(m, T->v[fv[0]]), X(m, T->v[fv[1]]), X(m, T->v[fv[2]]), p) < 0)
            return 0;
    }
    return 1;
}

/* Takes tetrahedron t out of the cavity (TM_F_CAVITY marks membership);
 * 1 if it may go, 0 if it holds p. */
static int drop(tm_mesh *m, uint32_t t, const double p[3])
{
    if (holds(m, t, p))
        return 0;
    m->flags[t] &= (uint16_t)~TM_F_CAVITY;
    return 1;
}

/* Step 2 of the top comment on s->cav (TM_F_CAVITY set on its members):
 * returns 0 with the shaped cavity in s->cav (flags cleared), 1 when no
 * such cavity exists (flags cleared), or a negative code. */
static int shape_cavity(segrec *s, const double p[3])
{
    tm_mesh *m = &s->r->m;
    uint16_t *fl = m->flags;
    int rc = 0;
    for (int round = 0; round < 10000 && !rc; round++) {
        size_t out = 0;
        /* Present subsegments whose every tetrahedron is in the cavity. */
        for (size_t i = 0; i < s->ncav && !rc; i++) {
            uint32_t t = s->cav[i];
            if (!(fl[t] & TM_F_CAVITY) || !(fl[t] & TM_F_SUBSEGS))
                continue;
            const tm_tet *T = &m->tets[t];
            for (int e = 0; e < 6 && (fl[t] & TM_F_CAVITY); e++) {
                if (!(fl[t] & TM_F_SUBSEG(e)))
                    continue;
                uint32_t a = T->v[tm_edge_vtx[e][0]], b = T->v[tm_edge_vtx[e][1]];
                s->nring = 0;
                s->ring_full = 0;
                if (ref_around_edge(m, t, a, b, gather_ring, s) != 0 || s->ring_full) {
                    rc = 1; /* cannot walk round it: give up safely */
                    break;
                }
                size_t in = 0;
                for (size_t k = 0; k < s->nring; k++)
                    in += (fl[s->ring[k]] & TM_F_CAVITY) != 0;
                if (in < s->nring)
                    continue;
                int gone = 0;
                for (size_t k = 0; k < s->nring && !gone; k++)
                    gone = drop(m, s->ring[k], p);
                if (!gone)
                    rc = 1; /* p on the subsegment: a crossing input */
                out += (size_t)gone;
            }
        }
        /* The star test: a boundary face p does not see from inside. */
        for (size_t i = 0; i < s->ncav && !rc; i++) {
            uint32_t t = s->cav[i];
            if (!(fl[t] & TM_F_CAVITY))
                continue;
            const tm_tet *T = &m->tets[t];
            for (int f = 0; f < 4; f++) {
                tm_link l = T->n[f];
                if (!tm_is_special(l) && (fl[tm_ltet(l)] & TM_F_CAVITY))
                    continue;
                const uint8_t *fv = tm_face_vtx[f];
                if (pred_orient3d(X(m, T->v[fv[0]]), X(m, T->v[fv[1]]), X(m, T->v[fv[2]]), p) >
                    0)
                    continue;
                if (!drop(m, t, p))
                    rc = 1;
                else
                    out++;
                break;
            }
        }
        size_t n = 0;
        for (size_t i = 0; i < s->ncav; i++)
            if (fl[s->cav[i]] & TM_F_CAVITY)
                s->cav[n++] = s->cav[i];
        s->ncav = n;
        if (!out)
            break;
    }
    for (size_t i = 0; i < s->ncav; i++)
        fl[s->cav[i]] &= (uint16_t)~TM_F_CAVITY;
    if (!rc && !s->ncav)
        rc = 1;
    return rc;
}

static int stop_hidden(ref_mesher *r, const double p[3], uint32_t seg)
{
    memcpy(r->stop_at, p, sizeof r->stop_at);
    r->stopped_below = 1;
    r->stop_hidden = 1;
    r->stop_vkind = BD_V_SEGMENT;
    r->stop_feat = seg;
    return PDR_ELIMIT;
}

/* Height over longest edge below which a fan triangle of a 2D cavity is
 * flat (SR_FLAT_FAN): its three corners lie on one line up to a few
 * roundings of the coordinates, so that later points on its edges,
 * rounded, fall on either side of the others. */
#define SR_FLAT_FAN 1e-6

/* 1 if triangle abc is flat (SR_FLAT_FAN; a measure, not a decision of
 * validity: the star test that follows is exact). */
static int flat_fan(const double *a, const double *b, const double *c)
{
    double u[3], v[3], w[3], n[3];
    v3_sub(b, a, u);
    v3_sub(c, a, v);
    v3_sub(c, b, w);
    v3_cross(u, v, n);
    double l2 = fmax(v3_dot(u, u), fmax(v3_dot(v, v), v3_dot(w, w)));
    return v3_dot(n, n) < SR_FLAT_FAN * SR_FLAT_FAN * l2 * l2;
}

/* 1 if subfacet id has edge a-b (a root of the 2D cavity of a point on
 * subsegment a-b). */
static int on_split_edge(const bd_set *bd, uint32_t id, uint32_t a, uint32_t b)
{
    const uint32_t *v = bd->facs[id].v;
    int ha = v[0] == a || v[1] == a || v[2] == a;
    int hb = v[0] == b || v[1] == b || v[2] == b;
    return ha && hb;
}

static int in_ids(const uint32_t *ids, size_t n, uint32_t id)
{
    for (size_t i = 0; i < n; i++)
        if (ids[i] == id)
            return 1;
    return 0;
}

/* The 2D cavity r->list cut down to the subfacets reached from its roots
 * (those on a-b) across edges that are no subsegment, none of them in
 * out[0..nout); then its rim in r->bedge. 0, 1 if p does not see a rim
 * edge from inside (no star), or PDR_ENOMEM. */
static int recut_cavity(ref_mesher *r, const double *p, uint32_t a, uint32_t b,
                        const uint32_t *out, size_t nout, const uint32_t *old, size_t nold)
{
    bd_set *bd = &r->bd;
    const tm_mesh *m = &r->m;
    ref__list_clear(r);
    for (size_t i = 0; i < nold; i++)
        if (on_split_edge(bd, old[i], a, b) && ref__list_add(r, old[i]))
            return PDR_ENOMEM;
    for (size_t scan = 0; scan < r->nlist; scan++) {
        uint32_t t = r->list[scan];
        for (int k = 0; k < 3; k++) {
            uint32_t x, y, u;
            int seg;
            if (!ref__cavity2d_rim(r, t, k, a, b, &x, &y, &seg, &u) || seg || u == BD_NONE)
                continue;
            if (in_ids(old, nold, u) && !in_ids(out, nout, u) && ref__list_add(r, u))
                return PDR_ENOMEM;
        }
    }
    r->nbedge = 0;
    for (size_t i = 0; i < r->nlist; i++) {
        uint32_t t = r->list[i];
        for (int k = 0; k < 3; k++) {
            uint32_t x, y, u;
            int seg;
            if (!ref__cavity2d_rim(r, t, k, a, b, &x, &y, &seg, &u))
                continue;
            if (ref__orient_facet(r->p, bd->facs[t].facet, X(m, x), X(m, y), p) <= 0)
                return 1;
            if (ref__add_bedge(r, x, y, t))
                return PDR_ENOMEM;
        }
    }
    return 0;
}

/* Keeps flat triangles out of the fan of p (flat_fan). Where a facet's
 * boundary bends by almost nothing at a vertex c (two segments of a merged
 * facet nearly in line: CAD faces, rotor_small.off), the Delaunay 2D
 * cavity of a point p on one segment next to c may take every subfacet at
 * c, and the fan over the rim subsegment x-c of the other segment is then
 * a triangle x c p whose orientation, though exact, depends on the last
 * bits of the coordinates: no rounded point of x-c sees the rest of its
 * cavity from inside any more, and the segment recovery stopped there.
 * The subfacet on such a rim subsegment stays (the facet triangulation is
 * then not Delaunay there, which no later step needs), and so do those it
 * alone joined to the cavity. Returns as recut_cavity. */
static int unflatten_cavity(ref_mesher *r, const double *p, uint32_t a, uint32_t b)
{
    const tm_mesh *m = &r->m;
    uint32_t *old = NULL, *out = NULL;
    size_t nold = r->nlist, nout = 0, capout = 0;
    int rc = 0;
    for (int round = 0; round < 64 && !rc; round++) {
        size_t n0 = nout;
        for (size_t i = 0; i < r->nbedge && !rc; i++) {
            const uint32_t *e = r->bedge[i];
            if (bd_find_subseg(&r->bd, e[0], e[1]) == BD_NONE ||
                on_split_edge(&r->bd, e[3], a, b) || !flat_fan(X(m, e[0]), X(m, e[1]), p) ||
                in_ids(out, nout, e[3]))
                continue;
            if (pdr_grow((void **)&out, &capout, nout + 1, sizeof *out))
                rc = PDR_ENOMEM;
            else
                out[nout++] = e[3];
        }
        if (rc || nout == n0)
            break;
        if (!old) {
            nold = r->nlist;
            old = pr_malloc(nold * sizeof *old);
            if (!old) {
                rc = PDR_ENOMEM;
                break;
            }
            memcpy(old, r->list, nold * sizeof *old);
        }
        rc = recut_cavity(r, p, a, b, out, nout, old, nold);
    }
    if (!rc)
        r->st.flat_fans_kept += nout;
    pr_free(old);
    pr_free(out);
    return rc;
}

/* The 2D cavity of point p on subsegment a-b in the facets through it
 * (r->list, r->bedge): 0, 1 when there is none (p, rounded, outside a thin
 * subfacet on the edge), or a negative code. */
static int facets_cavity(ref_mesher *r, uint32_t a, uint32_t b, const double *p)
{
    struct ref_root_arg ra = {r, 0};
    ref__list_clear(r);
    bd_subfacs_on_edge(&r->bd, a, b, ref__add_root, &ra);
    uint32_t ea, eb;
    int g = ra.rc ? ra.rc : ref__grow_cavity2d(r, p, a, b, &ea, &eb);
    if (g == 0)
        g = unflatten_cavity(r, p, a, b);
    if (g > 0) {
        /* Not a star in some facet (a rounded p): the subfacets on the
         * edge alone, each split in two. */
        r->anomalies++;
        g = ref__cavity2d_edge(r, p, a, b);
    }
    if (g) {
        ref__list_clear(r);
        return g < 0 ? g : 1;
    }
    return 0;
}

/* The facet triangulations after the split at vertex v: the 2D cavity
 * (facets_cavity) replaced by the fan of v. */
static int split_facets(ref_mesher *r, uint32_t v)
{
    for (size_t i = 0; i < r->nlist; i++)
        bd_kill_subfac(&r->bd, r->list[i]);
    r->nlist = 0;
    int rc = 0;
    for (size_t i = 0; i < r->nbedge && !rc; i++) {
        const uint32_t *e = r->bedge[i];
        rc = bd_add_subfac(&r->bd, e[0], e[1], v, e[2], NULL);
    }
    r->nbedge = 0;
    return rc;
}

static int place(segrec *s, uint32_t id, const double p[3]);

/* Splits missing subsegment id. Returns 0 or a negative code (PDR_ELIMIT
 * with r->stopped_below when it cannot be split). */
static int split_one(segrec *s, uint32_t id)
{
    ref_mesher *r = s->r;
    tm_mesh *m = &r->m;
    bd_subseg S = r->bd.segs[id];
    double p[3];
    /* The split point, and its 2D cavity first: where the rounded point
     * falls outside a thin subfacet on the segment, other points of it. */
    static const double at[] = {0.0, 0.375, 0.625, 0.25, 0.75};
    int rc = 1;
    for (size_t k = 0; k < sizeof at / sizeof at[0] && rc > 0; k++) {
        const double *pa = X(m, S.v[0]), *pb = X(m, S.v[1]);
        if (k == 0)
            ref__split_point(r, S.v[0], S.v[1], p);
        else
            for (int j = 0; j < 3; j++)
                p[j] = pa[j] + at[k] * (pb[j] - pa[j]);
        rc = facets_cavity(r, S.v[0], S.v[1], p);
    }
    if (rc)
        return rc < 0 ? rc : stop_hidden(r, p, S.seg);
    rc = place(s, id, p);
    if (rc) {
        ref__list_clear(r);
        return rc;
    }
    if ((rc = split_facets(r, r->last_v)))
        return rc;
    bd_kill_subseg(&r->bd, id);
    for (int k = 0; k < 2 && !rc; k++) {
        uint32_t half;
        rc = bd_add_subseg(&r->bd, S.v[k], r->last_v, S.seg, &half);
        if (!rc && !attach(r, half))
            rc = sr_push(s, half);
    }
    return rc;
}

/* Inserts the split point p of missing subsegment id (r->last_v the new
 * vertex), with Lawson's flips. Returns 0 or a negative code (PDR_ELIMIT
 * with r->stopped_below when it has no valid cavity or would go below the
 * resolution floor). */
static int place(segrec *s, uint32_t id, const double p[3])
{
    ref_mesher *r = s->r;
    tm_mesh *m = &r->m;
    bd_subseg S = r->bd.segs[id];
    uint32_t t = TM_NONE;
    tm_link exit_link;
    uint32_t h = ref__vertex_tet(m, S.v[0]);
    int rc = dt_locate(m, p, h, &t, &exit_link);
    if (rc < 0)
        return rc;
    if (rc != 0 || t == TM_NONE || tm_is_ghost(m, t) || dt_conflict(m, t, p) <= 0)
        return stop_hidden(r, p, S.seg);
    rc = dt_cavity_search(m, p, t, 0, &r->cav);
    if (rc)
        return rc;
    if (r->cav.status != DT_OK) {
        dt_cavity_abandon(m, &r->cav);
        return stop_hidden(r, p, S.seg);
    }
    if (pdr_grow((void **)&s->cav, &s->capcav, r->cav.ntets, sizeof *s->cav)) {
        dt_cavity_abandon(m, &r->cav);
        return PDR_ENOMEM;
    }
    s->ncav = r->cav.ntets;
    memcpy(s->cav, r->cav.tets, s->ncav * sizeof *s->cav);
    dt_cavity_abandon(m, &r->cav);
    for (size_t i = 0; i < s->ncav; i++)
        m->flags[s->cav[i]] |= TM_F_CAVITY;
    rc = shape_cavity(s, p);
    if (rc)
        return rc < 0 ? rc : stop_hidden(r, p, S.seg);
    rc = dt_cavity_set(m, p, s->cav, s->ncav, 0, &r->cav);
    if (rc)
        return rc;
    if (!dt_cavity_is_star(m, &r->cav)) {
        dt_cavity_abandon(m, &r->cav);
        return stop_hidden(r, p, S.seg);
    }
    /* The insertion radius: the nearest vertex joined to p. */
    double best = INFINITY;
    for (size_t i = 0; i < r->cav.nbnd; i++) {
        const tm_tet *T = &m->tets[r->cav.bnd[i].tet];
        const uint8_t *fv = tm_face_vtx[r->cav.bnd[i].face];
        for (int k = 0; k < 3; k++)
            if (T->v[fv[k]] != TM_VINF)
                best = fmin(best, v3_dist2(p, X(m, T->v[fv[k]])));
    }
    double rins = sqrt(best);
    if (rins < r->min_spacing) {
        dt_cavity_abandon(m, &r->cav);
        memcpy(r->stop_at, p, sizeof r->stop_at);
        r->stopped_below = 1;
        r->stop_hidden = 0;
        return PDR_ELIMIT;
    }
    uint32_t v;
    rc = tm_add_vertex(m, p, &v);
    if (!rc)
        rc = bd_vertex_room(&r->bd, m->nv);
    if (!rc)
        rc = dt_cavity_commit(m, v, &r->cav);
    if (!rc)
        rc = ref_region_room(r);
    if (rc) {
        dt_cavity_abandon(m, &r->cav);
        return rc;
    }
    r->bd.vkind[v] = BD_V_SEGMENT;
    r->bd.vfeat[v] = S.seg;
    r->bd.vrins[v] = (float)rins;
    r->last_v = v;
    r->last_op = "subsegment point (segment recovery)";
    r->st.seg_points++;
    r->st.missing_recovered++;
    r->st.segrec_points++;
    /* Lawson's flips from the new tetrahedra: no face is marked yet, and
     * subsegment edges are never flipped. */
    flip_hooks fh;
    memset(&fh, 0, sizeof fh);
    r->flipped.n = r->flipped.nstuck = 0;
    rc = flip_restore(m, r->cav.newtets, r->cav.nnew, &fh, &r->flipped, 0);
    r->st.flips23 += r->flipped.flips23;
    r->st.flips32 += r->flipped.flips32;
    r->flipped.flips23 = r->flipped.flips32 = r->flipped.flips22 = r->flipped.stuck = 0;
    r->flipped.blocked = 0;
    return rc;
}

int ref_recover_segments(ref_mesher *r)
{
    segrec s;
    memset(&s, 0, sizeof s);
    s.r = r;
    int rc = 0;
    bd_set *bd = &r->bd;
    for (uint32_t i = 0; i < bd->nsegs && !rc; i++)
        if (!(bd->segs[i].flags & BD_F_DEAD) && !attach(r, i))
            rc = sr_push(&s, i);
    while (!rc && s.qhead < s.qn) {
        uint32_t id = s.queue[s.qhead++];
        if (bd->segs[id].flags & BD_F_DEAD)
            continue;
        if (attach(r, id))
            continue; /* a flip made it an edge */
        if (r->o.max_points &&
            r->st.seg_points + r->st.fac_points + r->st.tet_points >= r->o.max_points) {
            rc = PDR_ELIMIT;
            break;
        }
        rc = split_one(&s, id);
    }
    pr_free(s.queue);
    pr_free(s.cav);
    return rc;
}
