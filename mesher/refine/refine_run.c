/*
 * refine/refine_run.c -- the insertion loop of refine/refine.h: the work
 * queues, the quality test of a tetrahedron, committing a point, the
 * splits of subsegments, subfacets and bad tetrahedra (Refine(tau) of the
 * paper, each asking refine_decide.c whether its point may go in), and
 * ref_run, which pops the queues until they are empty; ref_refine drives
 * it for the quality refinement.
 */
#include "config.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "base/pdr_util.h"
#include "geom/pred.h"
#include "refine/refine_int.h"
#include "base/v3.h"

#define X(m, v) ((m)->xyz + 3 * (size_t)(v))

/* ------------------------------------------------------------ helpers */

/* fmin/fmax are library calls (their NaN rules); these are not. */
static inline double dmin(double a, double b)
{
    return b < a ? b : a;
}
static inline double dmax(double a, double b)
{
    return b > a ? b : a;
}

/* ---------------------------------------------------------------- queues */

/* Room for one more entry; keyed: the queue keeps rmin (not a queue of
 * tetrahedra, see ref_queue). */
static int q_room(ref_queue *q, int keyed)
{
    if (q->n < q->cap)
        return 0;
    if (q->head > 0 && q->head >= q->cap / 2) {
        memmove(q->id, q->id + q->head, (q->n - q->head) * sizeof *q->id);
        if (keyed)
            memmove(q->rmin, q->rmin + q->head, (q->n - q->head) * sizeof *q->rmin);
        q->n -= q->head;
        q->head = 0;
        return 0;
    }
    size_t c = q->cap ? q->cap * 2 : 1024;
    uint32_t *ids = pr_realloc(q->id, c * sizeof *ids);
    if (!ids)
        return PDR_ENOMEM;
    q->id = ids;
    if (keyed) {
        float *rp = pr_realloc(q->rmin, c * sizeof *rp);
        if (!rp)
            return PDR_ENOMEM;
        q->rmin = rp;
    }
    q->cap = c;
    return 0;
}

/* A subsegment's or subfacet's entry, with its rmin. */
static int q_push(ref_queue *q, uint32_t id, float rmin)
{
    if (q_room(q, 1))
        return PDR_ENOMEM;
    q->id[q->n] = id;
    q->rmin[q->n] = rmin;
    q->n++;
    return 0;
}

/* A tetrahedron's entry (no rmin). */
static int q_push_tet(ref_queue *q, uint32_t t)
{
    if (q_room(q, 0))
        return PDR_ENOMEM;
    q->id[q->n++] = t;
    return 0;
}

static int q_empty(const ref_queue *q)
{
    return q->head == q->n;
}

static uint32_t q_pop(ref_queue *q, int lifo, float *rmin)
{
    size_t i = lifo ? --q->n : q->head++;
    uint32_t id = q->id[i];
    if (rmin)
        *rmin = q->rmin[i];
    if (q->head == q->n)
        q->head = q->n = 0;
    return id;
}

void ref__queue_free(ref_queue *q)
{
    pr_free(q->id);
    pr_free(q->rmin);
    memset(q, 0, sizeof *q);
}

int ref__queue_seg(ref_mesher *r, uint32_t id, float rmin)
{
    bd_subseg *s = &r->bd.segs[id];
    if (s->flags & (BD_F_DEAD | BD_F_QUEUED))
        return 0;
    s->flags |= BD_F_QUEUED;
    return q_push(&r->segq, id, rmin);
}

int ref__queue_fac(ref_mesher *r, uint32_t id, float rmin)
{
    bd_subfac *s = &r->bd.facs[id];
    if (s->flags & (BD_F_DEAD | BD_F_QUEUED))
        return 0;
    s->flags |= BD_F_QUEUED;
    return q_push(&r->facq, id, rmin);
}

static int queue_tet(ref_mesher *r, uint32_t t)
{
    if (r->m.flags[t] & TM_F_QUEUED)
        return 0;
    r->m.flags[t] |= TM_F_QUEUED;
    return q_push_tet(&r->tetq, t);
}

/* A bad tetrahedron whose split lies on another PE (parallel hooks):
 * not given up, but left for rank 0 to finish in the merged mesh. It
 * keeps TM_F_QUEUED though no queue holds it, which travels with it
 * (PAR_WIRE_TFLAGS) and tells the merge which tetrahedra to refine
 * (ref_refine_marked); meanwhile no step here queues it again. */
static void leave_to_merge(ref_mesher *r, uint32_t t)
{
    r->m.flags[t] |= TM_F_QUEUED;
    r->st.left_elsewhere++;
    if (r->hooks && r->hooks->left)
        r->hooks->left(r->hooks->arg, t);
}

/* -------------------------------------------------------- tet quality */

static double region_maxvol(const ref_mesher *r, uint32_t t)
{
    double mv = r->o.maxvol;
    if (r->region && r->o.use_region_maxvol && r->region[t]) {
        double rv = r->p->regions[r->region[t] - 1].maxvol;
        if (rv > 0 && (mv <= 0 || rv < mv))
            mv = rv;
    }
    return mv;
}

/* 1 if all four vertices of t lie on one facet by construction: a flat
 * tetrahedron on that facet (possible where the facet is not axis-aligned
 * and four of its vertices are cocircular up to rounding errors). Its
 * circumcentre lies on the facet, so splitting it splits a subfacet. */
int ref__flat_on_facet(const ref_mesher *r, const uint32_t *v)
{
    const bd_set *bd = &r->bd;
    for (int s = 0; s < 4; s++)
        if (bd->vkind[v[s]] == BD_V_VOLUME)
            return 0;
    const plc *p = r->p;
    uint32_t x = bd->vfeat[v[0]];
    const uint32_t *cand;
    size_t n;
    uint32_t one;
    switch (bd->vkind[v[0]]) {
    case BD_V_FACET:
        one = x;
        cand = &one;
        n = 1;
        break;
    case BD_V_SEGMENT:
        cand = p->seg_facets + p->seg_fstart[x];
        n = p->seg_fstart[x + 1] - p->seg_fstart[x];
        break;
    default:
        cand = p->v_facets + p->v_fstart[x];
        n = p->v_fstart[x + 1] - p->v_fstart[x];
        break;
    }
    for (size_t i = 0; i < n; i++)
        if (ref__on_facet(r, v[1], cand[i]) && ref__on_facet(r, v[2], cand[i]) &&
            ref__on_facet(r, v[3], cand[i]))
            return 1;
    return 0;
}

/* 1 if tetrahedron t, of six times the volume det and squared longest
 * edge hi, is above the volume bound of its region or the edge bound. */
static int too_big(const ref_mesher *r, uint32_t t, double det, double hi)
{
    double mv = region_maxvol(r, t);
    return (mv > 0 && det > 6.0 * mv) || (r->o.maxedge > 0 && hi > r->o.maxedge * r->o.maxedge);
}

/* 1 if interior tetrahedron t breaks a bound (2: only the dihedral angle
 * bound, 3: it lies flat on a facet); cc gets its circumcentre and
 * *ratio2 its squared radius-edge ratio. One pass without square roots:
 * this runs on every new tetrahedron. With u, v, w the edges at a, the
 * face normals (twice the areas) are n1 = v x w, n2 = w x u, n3 = u x v
 * and n0 = n1 + n2 + n3 (the four sum to zero with outward orientation),
 * and the dihedral angle at the edge e shared by faces i and j has
 * sin = 6V |e| / (4 A_i A_j) = det |e| / (|n_i| |n_j|). */
int ref__tet_bad(const ref_mesher *r, uint32_t t, double cc[3], double *ratio2)
{
    const tm_mesh *m = &r->m;
    const uint32_t *tv = m->tets[t].v;
    const double *a = X(m, tv[0]), *b = X(m, tv[1]), *c = X(m, tv[2]), *d = X(m, tv[3]);
    double u[3], v[3], w[3], n1[3], n2[3], n3[3];
    double det = v3_tet_frame(a, b, c, d, u, v, w, n1, n2, n3);
    double l2[6];
    l2[0] = v3_dot(u, u);
    l2[1] = v3_dot(v, v);
    l2[2] = v3_dot(w, w);
    l2[3] = v3_dist2(b, c);
    l2[4] = v3_dist2(b, d);
    l2[5] = v3_dist2(c, d);
    double lo = l2[0], hi = l2[0];
    for (int k = 1; k < 6; k++) {
        lo = dmin(lo, l2[k]);
        hi = dmax(hi, l2[k]);
    }
    double q = INFINITY;
    if (det > 0.0 && lo > 0.0) {
        double inv = 0.5 / det, x[3];
        for (int k = 0; k < 3; k++) {
            x[k] = (l2[0] * n1[k] + l2[1] * n2[k] + l2[2] * n3[k]) * inv;
            cc[k] = a[k] + x[k];
        }
        q = v3_dot(x, x) / lo;
    } else {
        cc[0] = cc[1] = cc[2] = NAN;
    }
    if (ratio2)
        *ratio2 = q;
    if (ref__flat_on_facet(r, tv))
        return 3;
    if (r->b2 > 0 && q >= r->b2)
        return 1;
    if (too_big(r, t, det, hi))
        return 1;
    if (r->sin_min > 0) {
        double n0[3] = {n1[0] + n2[0] + n3[0], n1[1] + n2[1] + n3[1], n1[2] + n2[2] + n3[2]};
        double f0 = v3_dot(n0, n0), f1 = v3_dot(n1, n1), f2 = v3_dot(n2, n2), f3 = v3_dot(n3, n3);
        double s2 = r->sin_min * r->sin_min, d2 = det * det;
        /* edges 01 02 03 12 13 23 lie on faces (2,3) (1,3) (1,2) (0,3)
         * (0,2) (0,1) */
        if (d2 * l2[0] < s2 * f2 * f3 || d2 * l2[1] < s2 * f1 * f3 ||
            d2 * l2[2] < s2 * f1 * f2 || d2 * l2[3] < s2 * f0 * f3 ||
            d2 * l2[4] < s2 * f0 * f2 || d2 * l2[5] < s2 * f0 * f1)
            return 2;
    }
    return 0;
}

static int queue_new_tets(ref_mesher *r)
{
    if (!r->classified)
        return 0;
    tm_mesh *m = &r->m;
    const dt_cavity *c = &r->cav;
    size_t nflip = 0;
    if (r->carved) {
        /* The constrained mode: what the insertion left not locally
         * Delaunay next to constraint faces is flipped (refine_cdt.c). */
        int rc = ref__cdt_flip(r, c->newtets, c->nnew);
        if (rc)
            return rc;
        nflip = r->flipped.n;
    }
    for (size_t i = 0; i < c->nnew + nflip; i++) {
        uint32_t n = i < c->nnew ? c->newtets[i] : r->flipped.tets[i - c->nnew];
        if (tm_is_dead(m, n))
            continue;
        if ((m->flags[n] & REF_F_EXTERIOR) || tm_is_ghost(m, n))
            continue;
        double cc[3];
        if (!ref__tet_bad(r, n, cc, NULL))
            continue;
        int rc;
        if (r->o.order == REF_ORDER_LOCAL_FIRST && !r->step_remote &&
            !(m->flags[n] & TM_F_QUEUED)) {
            m->flags[n] |= TM_F_QUEUED;
            rc = q_push_tet(&r->tetq_local, n);
        } else {
            rc = queue_tet(r, n);
        }
        if (rc)
            return rc;
    }
    return 0;
}

/* The parallel cavity hook (see ref_hooks), noting whether the cavity
 * came from other PEs (for REF_ORDER_LOCAL_FIRST). */
static int cavity_hook(ref_mesher *r, const double p[3], uint32_t start)
{
    /* Other cavity threads run while this one waits: the state of its
     * step that they may change is put back. */
    int flat_step = r->flat_step;
    int h = r->hooks->cavity(r->hooks->arg, p, start, &r->cav);
    r->flat_step = flat_step;
    if (h == 0)
        r->step_remote = 1;
    return h;
}


/* ---------------------------------------------------------- commit */

uint16_t ref__cavity_flags(const ref_mesher *r)
{
    uint16_t any = 0;
    const dt_cavity *c = &r->cav;
    for (size_t i = 0; i < c->ntets; i++)
        any |= r->m.flags[c->tets[i]];
    return any;
}

/* Inserts p (the pending cavity's point) as a new vertex lying on a
 * feature of the given kind; new tetrahedra inherit the exterior flag and
 * region of the cavity tetrahedron they are built on. */
int ref__commit_point(ref_mesher *r, uint16_t any, int vkind, uint32_t feat, double rins,
                      uint32_t *vout)
{
    tm_mesh *m = &r->m;
    dt_cavity *c = &r->cav;
    size_t nb = c->nbnd;
    int keep_ext = (any & REF_F_EXTERIOR) != 0, keep_reg = r->region != NULL;
    if (keep_reg && ref_region_room(r))
        return PDR_ENOMEM;
    if (keep_ext || keep_reg) {
        size_t cap = r->cap_b;
        if (pdr_grow((void **)&r->bflag, &cap, nb, sizeof *r->bflag))
            return PDR_ENOMEM;
        cap = r->cap_b;
        if (pdr_grow((void **)&r->breg, &cap, nb, sizeof *r->breg))
            return PDR_ENOMEM;
        r->cap_b = cap;
        for (size_t i = 0; i < nb; i++) {
            uint32_t t = c->bnd[i].tet;
            r->bflag[i] = m->flags[t] & REF_F_EXTERIOR;
            r->breg[i] = keep_reg ? r->region[t] : 0;
        }
    }
    uint32_t v;
    int rc = tm_add_vertex(m, c->p, &v);
    if (!rc)
        rc = bd_vertex_room(&r->bd, m->nv);
    if (!rc)
        rc = dt_cavity_commit(m, v, c);
    if (!rc)
        rc = ref_region_room(r);
    if (!rc && r->hooks)
        rc = r->hooks->committed(r->hooks->arg, v, c);
    if (!rc && r->flat_step)
        rc = hmap_put(&r->flat_made, (uint64_t)v + 1, 1);
    if (rc)
        return rc;
    if (keep_ext || keep_reg)
        for (size_t i = 0; i < nb; i++) {
            uint32_t n = c->newtets[i];
            m->flags[n] |= r->bflag[i];
            if (keep_reg)
                r->region[n] = r->breg[i];
        }
    r->bd.vkind[v] = (uint8_t)vkind;
    r->bd.vfeat[v] = feat;
    r->bd.vrins[v] = (float)rins;
    r->last_v = v;
    *vout = v;
    return 0;
}

/* ------------------------------------------------------------- splits */

/* SPLIT_ELSEWHERE (parallel only): the piece or its split point is not on
 * this PE; nothing was decided about it here. */
enum { SPLIT_DONE = 0, SPLIT_DEFERRED = 1, SPLIT_REFUSED = 2, SPLIT_ELSEWHERE = 3 };

/* Slivers (small dihedral angles, good radius-edge ratio) are split only
 * when their circumradius is at least this times their shortest edge. */
#ifndef SLIVER_RHO
#define SLIVER_RHO 0.7
#endif

/* The insertion radius of the pending cavity's point: its distance to the
 * nearest vertex it will be joined to (every vertex of the cavity
 * boundary), which is the length of the shortest edge at it once
 * inserted. */
static double insertion_radius(const ref_mesher *r)
{
    const tm_mesh *m = &r->m;
    const dt_cavity *c = &r->cav;
    double best = INFINITY;
    for (size_t i = 0; i < c->nbnd; i++) {
        const tm_tet *T = &m->tets[c->bnd[i].tet];
        const uint8_t *f = tm_face_vtx[c->bnd[i].face];
        for (int k = 0; k < 3; k++) {
            uint32_t v = T->v[f[k]];
            if (v != TM_VINF)
                best = fmin(best, v3_dist2(c->p, X(m, v)));
        }
    }
    return sqrt(best);
}

int ref__add_root(void *arg, uint32_t s)
{
    struct ref_root_arg *a = arg;
    if (a->r->bd.facs[s].flags & BD_F_VISIT)
        return 0;
    if (ref__list_add(a->r, s)) {
        a->rc = PDR_ENOMEM;
        return 1;
    }
    return 0;
}

/* The cavity search of a new point p. Alone, it walks from vertex a's
 * tetrahedron to p. With the parallel hooks, it starts from a tetrahedron
 * of this PE in conflict with p, found around the piece being split (edge
 * ab, or face abc when c is not TM_NONE), after the cavity hook made p's
 * cavity local: the piece's face or edge found around one of its
 * vertices, or else (a missing piece has none) the end of a walk to p
 * from the star of one of them; when that walk leaves the PE before
 * reaching a tetrahedron in conflict, the piece is not split here.
 * Returns 0 with r->cav searched, 1 when the piece is not on this PE any more (nothing
 * searched: the PE holding it splits it), REF_SETBACK via *setback, or a
 * negative code. */
static int search_piece(ref_mesher *r, const double p[3], uint32_t a, uint32_t b, uint32_t c,
                        int *setback)
{
    tm_mesh *m = &r->m;
    *setback = 0;
    if (!r->hooks)
        return dt_cavity_search(m, p, m->vhint[a], DT_LOCATE, &r->cav);
    uint32_t t = TM_NONE;
    /* On a PE the star of a vertex can come in pieces (some of its
     * tetrahedra elsewhere): the face or edge may be found from another
     * of its vertices. */
    int found = ref__find_in_star(m, a, b, c, &t) || ref__find_in_star(m, b, a, c, &t) ||
                (c != TM_NONE && ref__find_in_star(m, c, a, b, &t));
    if (!found) {
        /* A missing piece is no face or edge to start from, and a present
         * one may lie beyond the parts of its stars this PE holds: walk to
         * p from the star of one of its vertices, without leaving this PE
         * (a walk that meets another PE's face stops on the last
         * tetrahedron here, which will do if it is in conflict). */
        const uint32_t v[3] = {a, b, c};
        for (int k = 0; k < 3 && !found; k++) {
            uint32_t h = v[k] == TM_NONE ? TM_NONE : ref__vertex_tet(m, v[k]);
            if (h == TM_NONE)
                continue;
            tm_link exit_link;
            int rc = dt_locate(m, p, h, &t, &exit_link);
            if (rc < 0)
                return rc;
            found = 1;
        }
    }
    if (!found || dt_conflict(m, t, p) <= 0)
        return 1;
    int rc = cavity_hook(r, p, t);
    if (rc == REF_SETBACK) {
        *setback = 1;
        return 0;
    }
    if (rc == REF_SEARCHED)
        return 0;
    if (rc)
        return rc;
    return dt_cavity_search(m, p, t, 0, &r->cav);
}

/* A boundary split that cannot be made: a present piece is left as it is
 * (tolerated, counted in *why too); a missing one cannot be, so the run
 * stops with PDR_ELIMIT and r->stop_at. */
static int refuse_piece(ref_mesher *r, const double *p, int missing, uint16_t *flags,
                        size_t *why)
{
    if (!missing) {
        *flags |= BD_F_TOLERATED;
        r->st.tolerated++;
        (*why)++;
        return 0;
    }
    memcpy(r->stop_at, p, sizeof r->stop_at);
    r->stopped_below = 1;
    r->stop_hidden = 0;
    return PDR_ELIMIT;
}

/* A boundary split whose new vertex would lie nearer than min_spacing to
 * another: below that, double precision no longer describes the geometry
 * (splits that cascade into a corner reach it, and the boundary then
 * falls apart). Refused as above, counted in tol_below. */
static int below_resolution(ref_mesher *r, const double *p, int missing, uint16_t *flags)
{
    return refuse_piece(r, p, missing, flags, &r->st.tol_below);
}

/* Refused as above (counted in tol_hidden), for a split whose constrained
 * cavity could not be made (refine_cdt.c: other constraints hide part of
 * what the point must replace), not because of the floor: a missing
 * piece stops the run with r->stop_hidden and the piece's input feature
 * (vkind BD_V_SEGMENT or BD_V_FACET, feat) for the message. */
static int hidden_piece(ref_mesher *r, const double *p, int missing, uint16_t *flags, int vkind,
                        uint32_t feat)
{
    int rc = refuse_piece(r, p, missing, flags, &r->st.tol_hidden);
    if (rc) {
        r->stop_hidden = 1;
        r->stop_vkind = vkind;
        r->stop_feat = feat;
    }
    return rc;
}

/* Splits subsegment id at its split point (ref__split_point), or with
 * 0 < at < 1 at that fraction of it from its first vertex. A split of a
 * present subsegment is refused (SPLIT_REFUSED, the subsegment flagged
 * TOLERATED) when the new vertex would be nearer than rmin to an existing
 * one: rmin is how the refinement keeps splits caused by nearby features
 * or bad tetrahedra from cascading (see ref_opts.rho and split_tet). A
 * missing subsegment is always split: the mesh must conform. queued: the
 * split comes from the subsegment queue (constrained mode: a face no flip
 * mends asked for it). */
static int split_subseg_at(ref_mesher *r, uint32_t id, double rmin, int queued, double at,
                           int *result)
{
    tm_mesh *m = &r->m;
    bd_subseg S = r->bd.segs[id];
    *result = SPLIT_REFUSED;
    int missing = (S.flags & BD_F_MISSING) != 0;
    double p[3];
    if (at > 0.0 && at < 1.0) {
        const double *pa = X(m, S.v[0]), *pb = X(m, S.v[1]);
        for (int k = 0; k < 3; k++)
            p[k] = pa[k] + at * (pb[k] - pa[k]);
    } else {
        ref__split_point(r, S.v[0], S.v[1], p);
    }
    int setback = 0, rc = 0;
    struct ref_root_arg ra = {r, 0};
    if (r->o.constrained) {
        /* The 2D cavities first: they say which subfacets the 3D cavity
         * crosses (refine_cdt.c). */
        ref__list_clear(r);
        bd_subfacs_on_edge(&r->bd, S.v[0], S.v[1], ref__add_root, &ra);
        uint32_t ea, eb;
        int g = ra.rc ? ra.rc : ref__grow_cavity2d(r, p, S.v[0], S.v[1], &ea, &eb);
        if (g > 0) {
            /* Not a star (p lies beyond a subsegment the circumcircles
             * reach round, or the growth gave up): the collection stopped
             * half way, so r->bedge is partial and a commit would leave
             * part of the facets without subfacets (turbine.off with
             * --no-merge: hull faces left unmarked, the exterior then
             * taken for inside). A present subsegment is left as it is
             * (tolerated); a missing one is split in the subfacets on it
             * alone, each in two, as the segment recovery does
             * (refine_segrec.c). */
            r->anomalies++;
            if (!missing) {
                ref__list_clear(r);
                r->bd.segs[id].flags |= BD_F_TOLERATED;
                r->st.tolerated++;
                return 0;
            }
            g = ref__cavity2d_edge(r, p, S.v[0], S.v[1]);
            if (g > 0) {
                ref__list_clear(r);
                return hidden_piece(r, p, missing, &r->bd.segs[id].flags, BD_V_SEGMENT, S.seg);
            }
        }
        /* A queued split of a present subsegment is one a face that no
         * flip mends asks for (ref__cdt_flip): the CDT needs it. So does
         * one that a tetrahedron left by the run before asks for in
         * shrink_passes (r->leftover_try): its cavity folds behind faces
         * no flip mends, which left the tetrahedron in the first place.
         * Not on a segment at a small input angle (sharp, or ending at an
         * acute vertex): there the tetrahedra those splits make are left
         * in turn (CGAL's handle.off 11,265 above ratio 2 against 11,770,
         * mpi_triang.off 8,531 against 8,846; QUALITY.md). */
        int star = queued || (r->leftover_try && !ref__seg_small_angle(r, S.seg));
        rc = g < 0 ? g
                   : ref__cdt_search_piece(r, p, S.v[0], S.v[1], TM_NONE, missing, star);
        if (rc) {
            ref__list_clear(r);
            if (rc < 0)
                return rc;
            if (rc == REF_CDT_LOCKED)
                return REF_SETBACK;
            if (rc == REF_CDT_ELSEWHERE) {
                *result = SPLIT_ELSEWHERE;
                return 0;
            }
            return hidden_piece(r, p, missing, &r->bd.segs[id].flags, BD_V_SEGMENT, S.seg);
        }
    } else {
        rc = search_piece(r, p, S.v[0], S.v[1], TM_NONE, &setback);
    }
    if (setback)
        return REF_SETBACK;
    if (rc > 0) {
        *result = SPLIT_ELSEWHERE; /* not on this PE any more */
        return 0;
    }
    if (rc)
        return rc;
    if (r->hooks) {
        /* While the hook waited, the table entry may have been dropped
         * and made again under another index (its tetrahedra left this
         * PE and came back): find it by its vertices. */
        id = bd_find_subseg(&r->bd, S.v[0], S.v[1]);
        if (id == BD_NONE) {
            dt_cavity_abandon(m, &r->cav);
            return 0;
        }
    }
    if (r->cav.status != DT_OK) {
        dt_cavity_abandon(m, &r->cav);
        r->bd.segs[id].flags |= BD_F_TOLERATED;
        r->st.tolerated++;
        return 0;
    }
    double rins = insertion_radius(r);
    if (rins < r->min_spacing) {
        ref__list_clear(r);
        dt_cavity_abandon(m, &r->cav);
        return below_resolution(r, p, missing, &r->bd.segs[id].flags);
    }
    if (!missing && rins < rmin) {
        ref__list_clear(r);
        dt_cavity_abandon(m, &r->cav);
        r->bd.segs[id].flags |= BD_F_TOLERATED;
        r->st.tolerated++;
        r->st.tol_floor++;
        return 0;
    }
    uint16_t any = ref__cavity_flags(r);
    rc = ref_gather_marks(m, &r->cav, &r->marks);
    ref_decision d;
    if (!rc)
        ref_decide(r->p, p, REF_SUBSEG, &r->marks, &d);
    uint32_t ea, eb;
    int g = rc;
    if (!rc && !r->o.constrained) {
        ref__list_clear(r);
        bd_subfacs_on_edge(&r->bd, S.v[0], S.v[1], ref__add_root, &ra);
        g = ra.rc ? ra.rc : ref__grow_cavity2d(r, p, S.v[0], S.v[1], &ea, &eb);
    }
    if (g < 0) {
        ref__list_clear(r);
        dt_cavity_abandon(m, &r->cav);
        return g;
    }
    if (g > 0)
        r->anomalies++; /* not expected for a point on the segment */
    uint32_t v;
    r->last_op = "subsegment point";
    rc = ref__commit_point(r, any, BD_V_SEGMENT, S.seg, rins, &v);
    if (rc) {
        ref__list_clear(r);
        dt_cavity_abandon(m, &r->cav);
        return rc;
    }
    rc = ref__update_boundary(r, v, id);
    if (!rc)
        rc = queue_new_tets(r);
    r->st.seg_points++;
    if (missing)
        r->st.missing_recovered++;
    *result = SPLIT_DONE;
    return rc;
}

/* split_subseg_at at the split point. When rank 0 finishes the merged
 * mesh of a parallel run in the constrained mode (r->finishing), a split
 * that a face no flip mends asked for (queued; ref__cdt_flip) and that is
 * refused there (the floor rmin, or a cavity that cannot be made) is
 * tried at other points of the subsegment: any point inside it removes
 * the face, since every tetrahedron around the subsegment is in conflict
 * with it, and a face left so would leave the mesh no CDT (one run in
 * eight of boxcylsph-0.2 on 3 PEs). */
static int split_subseg(ref_mesher *r, uint32_t id, double rmin, int queued, int *result)
{
    static const double other_at[] = {0.375, 0.625, 0.25, 0.75};
    uint16_t flags = r->bd.segs[id].flags;
    size_t tolerated = r->st.tolerated;
    int rc = split_subseg_at(r, id, rmin, queued, -1.0, result);
    /* Only where rank 0 finishes a merged mesh, and a few times: the
     * splits the floor refused are what keeps faces no flip mends from
     * asking for ever more splits next to acute vertices (in the
     * sequential refinement, unbounded retries made CGAL's
     * double-torus-example run on past 12,800 vertices, where it meshes
     * into 8,784 without them; at rank 0, 64 and one per hundred vertices
     * made its 2-PE run stop on its heartbeat). */
    int retry = queued && r->finishing && !(flags & BD_F_MISSING) &&
                r->st.moved_splits < REF_MOVED_SPLITS;
    size_t nat = sizeof other_at / sizeof *other_at;
    for (size_t k = 0; retry && !rc && *result == SPLIT_REFUSED && k < nat; k++) {
        r->bd.segs[id].flags = flags;
        r->st.tolerated = tolerated;
        rc = split_subseg_at(r, id, rmin, queued, other_at[k], result);
        r->st.moved_splits += !rc && *result == SPLIT_DONE;
    }
    return rc;
}

/* Splits, at once, the subsegments flagged encroached in r->marks, each
 * with the floor rmin; *done counts those split. */
static int split_encroached_subsegs(ref_mesher *r, double rmin, size_t *done, int *elsewhere)
{
    *done = 0;
    *elsewhere = 0;
    uint32_t ids[64];
    size_t n = 0;
    for (size_t k = 0; k < r->marks.n && n < 64; k++) {
        const ref_mark *mk = &r->marks.m[k];
        if (mk->nv != 2 || !mk->encroached)
            continue;
        uint32_t id = bd_find_subseg(&r->bd, mk->v[0], mk->v[1]);
        if (id != BD_NONE)
            ids[n++] = id;
    }
    for (size_t i = 0; i < n; i++) {
        if (r->bd.segs[ids[i]].flags & BD_F_DEAD)
            continue;
        int res, rc = split_subseg(r, ids[i], rmin, 0, &res);
        if (rc)
            return rc;
        if (res == SPLIT_DONE)
            (*done)++;
        else if (res == SPLIT_ELSEWHERE)
            *elsewhere = 1;
    }
    return 0;
}

static int split_subfac_cdt(ref_mesher *r, uint32_t id, const double c[3], double rmin,
                            int *result);

/* The recovery with segments first (r->keep_stuck): missing subfacet id,
 * whose split at c found no valid constrained cavity or went to a
 * subsegment that refused it, split at its centroid instead, once
 * (r->centroid_try). The circumcentre of a thin triangle lies far off,
 * beyond the facet's subsegments or with a wide 2D cavity; the centroid
 * lies inside it. Returns 1 (and *rc, *result as split_subfac_cdt sets
 * them) if it was tried, 0 if not (not missing, not in that recovery, or
 * already a centroid). */
static int split_at_centroid(ref_mesher *r, uint32_t id, const bd_subfac *G, int missing,
                             double rmin, int *result, int *rc)
{
    if (!missing || !r->keep_stuck || r->centroid_try)
        return 0;
    const tm_mesh *m = &r->m;
    double ctr[3];
    for (int k = 0; k < 3; k++)
        ctr[k] = (X(m, G->v[0])[k] + X(m, G->v[1])[k] + X(m, G->v[2])[k]) / 3.0;
    r->centroid_try = 1;
    *rc = split_subfac_cdt(r, id, ctr, rmin, result);
    r->centroid_try = 0;
    return 1;
}

/* split_subfac in the constrained mode (refine_cdt.c): the 2D cavity of
 * circumcentre c first, then the 3D cavity that crosses exactly its
 * subfacets. */
static int split_subfac_cdt(ref_mesher *r, uint32_t id, const double c[3], double rmin,
                            int *result)
{
    tm_mesh *m = &r->m;
    bd_subfac G = r->bd.facs[id];
    int missing = (G.flags & BD_F_MISSING) != 0;
    ref__list_clear(r);
    int rc = ref__list_add(r, id);
    uint32_t ea = 0, eb = 0;
    int g = rc ? rc : ref__grow_cavity2d(r, c, BD_NONE, BD_NONE, &ea, &eb);
    if (g != 0) {
        ref__list_clear(r);
        if (g < 0)
            return g;
        uint32_t sid = g == 1 ? bd_find_subseg(&r->bd, ea, eb) : BD_NONE;
        if (sid == BD_NONE) {
            r->anomalies++;
            r->bd.facs[id].flags |= BD_F_TOLERATED;
            return 0;
        }
        /* c lies beyond subsegment ea-eb of the facet: it encroaches it */
        r->st.beyond_seg++;
        int res;
        rc = split_subseg(r, sid, rmin, 0, &res);
        *result = res == SPLIT_DONE        ? SPLIT_DEFERRED
                  : res == SPLIT_ELSEWHERE ? SPLIT_ELSEWHERE
                                           : SPLIT_REFUSED;
        /* A missing subfacet is not left so (nothing would split it
         * again, and the exterior would flood in through it: cheese.off
         * renumbered, 30 subfacets): its centroid. */
        if (!rc && *result == SPLIT_REFUSED)
            split_at_centroid(r, id, &G, missing, rmin, result, &rc);
        return rc;
    }
    rc = ref__cdt_search_piece(r, c, G.v[0], G.v[1], G.v[2], missing, 0);
    if (rc) {
        ref__list_clear(r);
        if (rc < 0)
            return rc;
        if (rc == REF_CDT_LOCKED)
            return REF_SETBACK;
        if (rc == REF_CDT_ELSEWHERE) {
            *result = SPLIT_ELSEWHERE;
            return 0;
        }
        /* no valid constrained cavity at c */
        if (split_at_centroid(r, id, &G, missing, rmin, result, &rc))
            return rc;
        if (missing)
            return hidden_piece(r, c, missing, &r->bd.facs[id].flags, BD_V_FACET, G.facet);
        r->bd.facs[id].flags |= BD_F_TOLERATED;
        r->st.tolerated++;
        return 0;
    }
    uint16_t any = ref__cavity_flags(r);
    rc = ref_gather_marks(m, &r->cav, &r->marks);
    if (rc) {
        ref__list_clear(r);
        dt_cavity_abandon(m, &r->cav);
        return rc;
    }
    ref_decision d;
    ref_decide(r->p, c, REF_SUBFACET, &r->marks, &d);
    if (d.action == REF_SPLIT_SUBSEGS) {
        ref__list_clear(r);
        dt_cavity_abandon(m, &r->cav);
        size_t done;
        int elsewhere;
        rc = split_encroached_subsegs(r, rmin, &done, &elsewhere);
        *result = done ? SPLIT_DEFERRED : SPLIT_REFUSED;
        if (*result == SPLIT_REFUSED)
            r->bd.facs[id].flags |= BD_F_TOLERATED;
        return rc;
    }
    double rins = insertion_radius(r);
    if (rins < r->min_spacing || (!missing && rins < rmin)) {
        ref__list_clear(r);
        dt_cavity_abandon(m, &r->cav);
        if (rins < r->min_spacing)
            return below_resolution(r, c, missing, &r->bd.facs[id].flags);
        r->bd.facs[id].flags |= BD_F_TOLERATED;
        r->st.tolerated++;
        r->st.tol_floor++;
        return 0;
    }
    uint32_t v;
    r->last_op = "subfacet point (constrained)";
    rc = ref__commit_point(r, any, BD_V_FACET, G.facet, rins, &v);
    if (rc) {
        ref__list_clear(r);
        dt_cavity_abandon(m, &r->cav);
        return rc;
    }
    rc = ref__update_boundary(r, v, BD_NONE);
    if (!rc)
        rc = queue_new_tets(r);
    r->st.fac_points++;
    if (missing)
        r->st.missing_recovered++;
    *result = SPLIT_DONE;
    return rc;
}

/* 1 if the planes of facets f and g meet at an angle strictly between 0
 * and 90 degrees (up to rounding): neither parallel nor perpendicular. */
static int oblique_facets(const plc *p, uint32_t f, uint32_t g)
{
    double c = fabs(v3_dot(p->facets[f].normal, p->facets[g].normal));
    return c > 1e-9 && c < 1.0 - 1e-9;
}

/* 1 if some facet of the input is oblique to facet f (a linear scan: only
 * asked when a split would delete a subfacet of another facet, which is
 * rare). */
static int oblique_to_any(const plc *p, uint32_t f)
{
    for (uint32_t g = 0; g < p->nfacet; g++)
        if (oblique_facets(p, f, g))
            return 1;
    return 0;
}

/* The largest present subfacet of another facet than facet that the
 * pending cavity deletes (its marks, after ref_decide), where one of the
 * two facets is oblique to some facet of the input (oblique_to_any), or
 * BD_NONE. */
static uint32_t deleted_elsewhere(const ref_mesher *r, uint32_t facet)
{
    uint32_t best = BD_NONE;
    double best_r2 = -1.0;
    int own = -1; /* oblique_to_any(facet), once asked */
    for (size_t k = 0; k < r->marks.n; k++) {
        const ref_mark *mk = &r->marks.m[k];
        if (mk->nv != 3 || !mk->deleted || mk->facet < 0 || (size_t)mk->facet >= r->p->nfacet ||
            (uint32_t)mk->facet == facet)
            continue;
        if (own < 0)
            own = oblique_to_any(r->p, facet);
        if (!own && !oblique_to_any(r->p, (uint32_t)mk->facet))
            continue;
        uint32_t g = bd_find_subfac(&r->bd, mk->v[0], mk->v[1], mk->v[2]);
        double cc[3], r2;
        if (g == BD_NONE || (r->bd.facs[g].flags & BD_F_MISSING) ||
            ref__tri_circumcentre(mk->x[0], mk->x[1], mk->x[2], cc, &r2) || !(r2 > best_r2))
            continue;
        best = g;
        best_r2 = r2;
    }
    return best;
}

/* Splits subfacet id at its circumcentre; when that point encroaches
 * subsegments, splits them instead (SPLIT_DEFERRED: the subfacet is still
 * there). rmin as for split_subseg; SPLIT_REFUSED when nothing was
 * inserted. */
static int split_subfac(ref_mesher *r, uint32_t id, double rmin, int *result)
{
    tm_mesh *m = &r->m;
    bd_subfac G = r->bd.facs[id];
    *result = SPLIT_REFUSED;
    int missing = (G.flags & BD_F_MISSING) != 0;
    if (missing)
        rmin = 0;
    double c[3], r2;
    if (ref__tri_circumcentre(X(m, G.v[0]), X(m, G.v[1]), X(m, G.v[2]), c, &r2)) {
        r->bd.facs[id].flags |= BD_F_TOLERATED;
        return 0;
    }
    if (r->o.constrained)
        return split_subfac_cdt(r, id, c, rmin, result);
    int setback;
    int rc = search_piece(r, c, G.v[0], G.v[1], G.v[2], &setback);
    if (setback)
        return REF_SETBACK;
    if (rc > 0) {
        *result = SPLIT_ELSEWHERE; /* not on this PE any more */
        return 0;
    }
    if (rc)
        return rc;
    if (r->hooks) {
        /* As in split_subseg. */
        id = bd_find_subfac(&r->bd, G.v[0], G.v[1], G.v[2]);
        if (id == BD_NONE) {
            dt_cavity_abandon(m, &r->cav);
            return 0;
        }
    }
    if (r->cav.status != DT_OK) {
        dt_cavity_abandon(m, &r->cav);
        r->bd.facs[id].flags |= BD_F_TOLERATED;
        r->st.tolerated++;
        return 0;
    }
    uint16_t any = ref__cavity_flags(r);
    rc = ref_gather_marks(m, &r->cav, &r->marks);
    if (rc) {
        dt_cavity_abandon(m, &r->cav);
        return rc;
    }
    ref_decision d;
    ref_decide(r->p, c, REF_SUBFACET, &r->marks, &d);
    if (d.action == REF_SPLIT_SUBSEGS) {
        dt_cavity_abandon(m, &r->cav);
        size_t done;
        int elsewhere;
        rc = split_encroached_subsegs(r, rmin, &done, &elsewhere);
        *result = done ? SPLIT_DEFERRED : elsewhere ? SPLIT_ELSEWHERE : SPLIT_REFUSED;
        if (*result == SPLIT_REFUSED)
            r->bd.facs[id].flags |= BD_F_TOLERATED;
        return rc;
    }
    uint32_t other = missing ? BD_NONE : deleted_elsewhere(r, G.facet);
    if (other != BD_NONE) {
        /* c would delete a subfacet of another facet, which would go
         * missing, and the recovery of a missing piece has no floor.
         * Where facets meet at less than 90 degrees (example.poly's
         * inclined facet and the walls below it, at 63 degrees) its
         * splits make pieces of the other facet missing in turn, closer
         * and closer to the segment between them, without end (about one
         * parallel run of example.poly in 350 met this, from a wall at 63
         * degrees or from the perpendicular ones at the ends of that
         * segment; a PE then ran on for ever). That subfacet is split
         * instead, with this split's floor, as an encroached subsegment
         * is; this one is tried again after. One level only: where that
         * split would delete yet another facet's piece, both are refused
         * and left encroached (TOLERATED). Inputs whose facets are all
         * parallel or perpendicular (the paper's domains) keep
         * Shewchuk's rule, whose termination proof covers angles of 90
         * degrees and more, and their meshes as they were. */
        dt_cavity_abandon(m, &r->cav);
        int res = SPLIT_REFUSED;
        if (!r->deflecting) {
            r->deflecting = 1;
            rc = split_subfac(r, other, rmin, &res);
            r->deflecting = 0;
            r->st.deflected += !rc && (res == SPLIT_DONE || res == SPLIT_DEFERRED);
        }
        *result = res == SPLIT_DONE || res == SPLIT_DEFERRED ? SPLIT_DEFERRED
                  : res == SPLIT_ELSEWHERE                   ? SPLIT_ELSEWHERE
                                                             : SPLIT_REFUSED;
        if (!rc && *result == SPLIT_REFUSED) {
            /* by its vertices: the split above may have moved the table */
            uint32_t again = bd_find_subfac(&r->bd, G.v[0], G.v[1], G.v[2]);
            if (again != BD_NONE) {
                r->bd.facs[again].flags |= BD_F_TOLERATED;
                r->st.tolerated++;
            }
        }
        return rc;
    }
    ref__list_clear(r);
    rc = ref__list_add(r, id);
    uint32_t ea = 0, eb = 0;
    int g = rc ? rc : ref__grow_cavity2d(r, c, BD_NONE, BD_NONE, &ea, &eb);
    if (g != 0) {
        ref__list_clear(r);
        dt_cavity_abandon(m, &r->cav);
        if (g < 0)
            return g;
        uint32_t sid = g == 1 ? bd_find_subseg(&r->bd, ea, eb) : BD_NONE;
        if (sid == BD_NONE) {
            r->anomalies++;
            r->bd.facs[id].flags |= BD_F_TOLERATED;
            return 0;
        }
        /* c lies beyond subsegment ea-eb of the facet: it encroaches it */
        r->st.beyond_seg++;
        int res;
        rc = split_subseg(r, sid, rmin, 0, &res);
        *result = res == SPLIT_DONE        ? SPLIT_DEFERRED
                  : res == SPLIT_ELSEWHERE ? SPLIT_ELSEWHERE
                                           : SPLIT_REFUSED;
        return rc;
    }
    double rins = insertion_radius(r);
    if (rins < r->min_spacing) {
        ref__list_clear(r);
        dt_cavity_abandon(m, &r->cav);
        return below_resolution(r, c, missing, &r->bd.facs[id].flags);
    }
    if (!missing && rins < rmin) {
        ref__list_clear(r);
        dt_cavity_abandon(m, &r->cav);
        r->bd.facs[id].flags |= BD_F_TOLERATED;
        r->st.tolerated++;
        r->st.tol_floor++;
        return 0;
    }
    uint32_t v;
    r->last_op = r->forced ? "subfacet point (forced 2D cavity)" : "subfacet point";
    rc = ref__commit_point(r, any, BD_V_FACET, G.facet, rins, &v);
    if (rc) {
        ref__list_clear(r);
        dt_cavity_abandon(m, &r->cav);
        return rc;
    }
    rc = ref__update_boundary(r, v, BD_NONE);
    if (!rc)
        rc = queue_new_tets(r);
    r->st.fac_points++;
    if (missing)
        r->st.missing_recovered++;
    *result = SPLIT_DONE;
    return rc;
}

/* A tetrahedron so flat that its circumcentre cannot be computed, or lies
 * outside the tetrahedron's own circumball once rounded, has four nearly
 * cocircular vertices: its circumball meets their common plane in (about)
 * the circle through them, so the centre of the circle through any three of
 * them lies inside the ball. That centre is the point to insert instead;
 * the conflict test decides exactly whether it is in the ball. Returns 0
 * with cc set, or -1 when no face gives a point in conflict with t. */
int ref__flat_tet_centre(const tm_mesh *m, uint32_t t, double cc[3])
{
    const uint32_t *tv = m->tets[t].v;
    for (int k = 0; k < 4; k++) {
        double c[3], r2;
        if (ref__tri_circumcentre(X(m, tv[tm_face_vtx[k][0]]), X(m, tv[tm_face_vtx[k][1]]),
                                  X(m, tv[tm_face_vtx[k][2]]), c, &r2) == 0 &&
            dt_conflict(m, t, c) > 0) {
            memcpy(cc, c, sizeof c);
            return 0;
        }
    }
    return -1;
}

/* The distance from p to the nearest vertex of cavity c's boundary: the
 * nearest vertex of the whole mesh when the cavity is an unconstrained
 * Bowyer-Watson cavity (p's nearest neighbour is joined to p). */
double ref__cavity_clearance(const tm_mesh *m, const dt_cavity *c, const double *p)
{
    double d2 = INFINITY;
    for (size_t i = 0; i < c->nbnd; i++) {
        const uint32_t *tv = m->tets[c->bnd[i].tet].v;
        for (int j = 0; j < 3; j++)
            d2 = dmin(d2, v3_dist2(p, X(m, tv[tm_face_vtx[c->bnd[i].face][j]])));
    }
    return sqrt(d2);
}

static void give_up(ref_mesher *r, uint32_t t, int degenerate)
{
    r->m.flags[t] |= REF_F_GIVEUP | (degenerate ? REF_F_DEGENERATE : 0);
    r->st.gave_up++;
    if (degenerate)
        r->st.degenerate++;
}

/* A bad tetrahedron t whose circumcentre (at distance rp from its
 * vertices) encroaches a piece: splits the subsegments flagged encroached
 * in r->marks (segs), or subfacet g, instead, never nearer to a vertex
 * than t's shortest edge (see split_tet); t is queued again when a split
 * was made, left (given up) when it was refused. */
static int split_instead(ref_mesher *r, uint32_t t, int why, double rp, int segs, uint32_t g)
{
    tm_mesh *m = &r->m;
    r->st.rejected++;
    /* Whether one of the pieces to split ends at a needle point. */
    int needle = g != BD_NONE && ref__needle_facet(r, r->bd.facs[g].facet);
    for (size_t k = 0; segs && k < r->marks.n; k++) {
        const ref_mark *mk = &r->marks.m[k];
        uint32_t id = mk->nv == 2 && mk->encroached ? bd_find_subseg(&r->bd, mk->v[0], mk->v[1])
                                                    : BD_NONE;
        needle |= id != BD_NONE && ref__needle_seg(r, r->bd.segs[id].seg);
    }
    if (why == 2 && r->o.constrained) {
        /* A sliver (bad by a dihedral angle alone) does not split the
         * boundary in the constrained mode: on a tessellated curved
         * surface such splits make more slivers next to the new boundary
         * vertices, and the surface is refined several times over
         * (torus-0.15 of the corpus: 24,320 tetrahedra against 4,591
         * without). It is left, and counted. */
        give_up(r, t, 0);
        r->st.slivers_left++;
        return 0;
    }
    double lmin;
    ref__shortest_edge(m, t, &lmin);
    /* For a tetrahedron that is bad by its size alone the floor is half
     * its circumradius instead (the clean bound is r/sqrt(2)): its splits
     * are then never smaller than a fixed fraction of the size bound. */
    double floor = fmin(sqrt(lmin) * fmin(1.0, 0.9 * r->o.ratio / M_SQRT2), 0.5 * rp);
    /* A flat tetrahedron lying on a facet is a rounding artifact that only
     * the split of that facet's subfacet removes. */
    if (why == 3)
        floor = 0;
    /* The constrained mode splits no piece eagerly (refine_bound.c), so
     * the bad tetrahedra next to a piece ask for its splits themselves,
     * and Shewchuk's bound for their new vertices (the floor above) needs
     * pieces that no vertex encroaches: the floor is a quarter there, and
     * whole only next to a needle point, where splits could cascade into
     * it. On the corpus the long strips leave 0 tetrahedra above the bound
     * instead of 1,373, the thin slab 0 instead of 2,602. */
    if (r->o.constrained && !needle)
        floor *= 0.25;
    else if (r->o.constrained)
        r->st.needle_floor++;
    int outcome = SPLIT_REFUSED, rc = 0;
    /* With the parallel hooks the splits below may wait for other PEs,
     * during which t may be split or moved away and its slot reused:
     * remember what t was. */
    uint32_t was[4];
    memcpy(was, m->tets[t].v, sizeof was);
    if (segs) {
        size_t done;
        int elsewhere;
        rc = split_encroached_subsegs(r, floor, &done, &elsewhere);
        outcome = done ? SPLIT_DONE : elsewhere ? SPLIT_ELSEWHERE : SPLIT_REFUSED;
    } else if (g != BD_NONE) {
        rc = split_subfac(r, g, floor, &outcome);
    }
    if (rc)
        return rc;
    if (tm_is_dead(m, t) || memcmp(was, m->tets[t].v, sizeof was))
        return 0;
    if (outcome == SPLIT_REFUSED)
        give_up(r, t, 0);
    else if (outcome == SPLIT_ELSEWHERE)
        leave_to_merge(r, t);
    else
        rc = queue_tet(r, t);
    return rc;
}

/* keep of dt_cavity_shrink for shrink_unseen: a tetrahedron that holds
 * the cavity's point (closed). */
static int holds_centre(void *arg, uint32_t t)
{
    const ref_mesher *r = arg;
    return t == r->shrink_keep || ref__tet_holds(&r->m, t, r->cav.p);
}

/* The pending constrained cavity r->cav of bad tetrahedron t's
 * circumcentre is no star from it, and no constraint on its boundary is
 * in the way: faces that are not locally Delaunay (no flip mended them)
 * fold it. It is shrunk to a star from the circumcentre (TetGen's cavity
 * shrinking), keeping the tetrahedra that hold the point; the flips after
 * the insertion mend what it leaves. Returns 0 (r->cav pending, a star),
 * 1 (nothing pending: no such star) or a negative code (nothing
 * pending). */
static int shrink_unseen(ref_mesher *r, uint32_t t)
{
    r->shrink_keep = t;
    int rc = dt_cavity_shrink(&r->m, &r->cav, holds_centre, r);
    if (rc < 0) {
        dt_cavity_abandon(&r->m, &r->cav);
        return rc;
    }
    if (!rc)
        r->st.shrunk++;
    return rc;
}

/* 1 if tetrahedron t, bad by its radius-edge ratio, is not too big, has
 * a seditious shortest edge (ref__cdt_seditious) and has the apex of that
 * small angle for a vertex: it is left. Its circumcentre lies about
 * halfway to the apex, and its split makes the same tetrahedron at half
 * the size, down to the resolution. A tetrahedron away from the apex
 * whose shortest edge is seditious is split as usual: its circumcentre
 * does not lead towards the apex (the UV sphere of the corpus: 67
 * tetrahedra left at its poles, 3,020 in all, instead of 177 and 2,192
 * when those were left too). */
static int seditious_tet(const ref_mesher *r, uint32_t t)
{
    const tm_mesh *m = &r->m;
    const uint32_t *tv = m->tets[t].v;
    double vol, hi;
    ref_tet_ratio2(X(m, tv[0]), X(m, tv[1]), X(m, tv[2]), X(m, tv[3]), &vol, &hi, NULL);
    if (too_big(r, t, 6.0 * vol, hi))
        return 0;
    uint32_t o = ref__cdt_seditious_tet(r, t);
    if (o == UINT32_MAX)
        return 0;
    for (int k = 0; k < 4; k++)
        if (r->bd.vkind[tv[k]] == BD_V_INPUT && r->bd.vfeat[tv[k]] == o)
            return 1;
    return 0;
}

/* The key of tetrahedron t in r->leftover (and what flat_key hashes): its
 * vertices, ascending. */
static void leftover_key(const ref_mesher *r, uint32_t t, uint32_t k[4])
{
    memcpy(k, r->m.tets[t].v, 4 * sizeof *k);
    for (int i = 1; i < 4; i++)
        for (int j = i; j > 0 && k[j] < k[j - 1]; j--) {
            uint32_t x = k[j];
            k[j] = k[j - 1];
            k[j - 1] = x;
        }
}

/* The key of tetrahedron t's vertex set in r->flat_tries: a hash of its
 * sorted vertices, never 0 (a collision only leaves a flat tetrahedron
 * early). */
static uint64_t flat_key(const ref_mesher *r, uint32_t t)
{
    uint32_t v[4];
    leftover_key(r, t, v);
    uint64_t h = 1469598103934665603ull;
    for (int i = 0; i < 4; i++)
        h = (h ^ v[i]) * 1099511628211ull;
    return h | 1;
}

/* 1 if flat tetrahedron t is past its floorless splits (REF_FLAT_TRIES):
 * a split of a flat tetrahedron inserted one of its vertices
 * (ref__commit_point), or its own splits left it standing that many
 * times (flat_count). Only in the constrained mode. */
static int flat_spent(const ref_mesher *r, uint32_t t)
{
    if (!r->o.constrained)
        return 0;
    for (int k = 0; k < 4; k++)
        if (hmap_get(&r->flat_made, (uint64_t)r->m.tets[t].v[k] + 1) != HMAP_NONE)
            return 1;
    uint32_t n = hmap_get(&r->flat_tries, flat_key(r, t));
    return n != HMAP_NONE && n >= REF_FLAT_TRIES;
}

/* After split_tet_at(t) split a flat tetrahedron (r->flat_step): t, if
 * it still stands (vertices was), has one more try counted. 0 or
 * PDR_ENOMEM. */
static int flat_count(ref_mesher *r, uint32_t t, const uint32_t was[4])
{
    tm_mesh *m = &r->m;
    if (tm_is_dead(m, t) || memcmp(was, m->tets[t].v, 4 * sizeof *was))
        return 0;
    uint64_t key = flat_key(r, t);
    uint32_t n = hmap_get(&r->flat_tries, key);
    if (n != HMAP_NONE)
        hmap_del(&r->flat_tries, key, n);
    return hmap_put(&r->flat_tries, key, n == HMAP_NONE ? 1 : n + 1);
}

/* Refine(t) for a bad tetrahedron: its circumcentre, or the split of the
 * subsegments or the subfacet that circumcentre encroaches. Those splits
 * must not put a vertex nearer to another than t's shortest edge (on an
 * input that meets Shewchuk's conditions they never do: the new vertex is
 * at least r/sqrt(2) >= B l/sqrt(2) from every vertex, r the circumradius,
 * l the shortest edge); where they would, near a boundary piece left
 * encroached at an acute input angle, t is left as it is and counted. That
 * floor is what makes the refinement terminate on any input: apart from
 * the recovery of missing pieces, no vertex is inserted nearer to another
 * than the shortest edge already in the mesh. */
static int split_tet_at(ref_mesher *r, uint32_t t)
{
    tm_mesh *m = &r->m;
    double cc[3], q2;
    int why = ref__tet_bad(r, t, cc, &q2);
    if (!why)
        return 0;
    if (why == 2 && q2 < SLIVER_RHO * SLIVER_RHO) {
        /* A sliver whose circumradius is small against its shortest edge:
         * its circumcentre would crowd its vertices, and splitting such
         * slivers is what could cascade; they are rare and left. */
        give_up(r, t, 0);
        r->st.slivers_left++;
        return 0;
    }
    if (why == 1 && r->o.constrained && r->b2 > 0 && q2 >= r->b2 && seditious_tet(r, t)) {
        give_up(r, t, 0);
        r->st.seditious++;
        return 0;
    }
    if (why == 3 && r->o.constrained) {
        /* Flat on a merged facet, between the facet's two triangulations
         * of a quadrilateral: removed, the other one taken. */
        int rc = ref__cdt_remove_flat(r, t);
        if (rc)
            return rc < 0 ? rc : 0;
        if (flat_spent(r, t)) {
            give_up(r, t, 1);
            return 0;
        }
        r->flat_step = 1;
    }
    if (why == 3) {
        /* Flat on a facet: its circumcentre is ill-conditioned, and what
         * removes it is the split of the subfacet it lies on. */
        int rc = 0, outcome = SPLIT_REFUSED;
        for (int k = 0; k < 4 && outcome == SPLIT_REFUSED && !rc; k++) {
            if (!(m->flags[t] & TM_F_FACEMARK(k)))
                continue;
            const uint32_t *tv = m->tets[t].v;
            uint32_t g = bd_find_subfac(&r->bd, tv[tm_face_vtx[k][0]], tv[tm_face_vtx[k][1]],
                                        tv[tm_face_vtx[k][2]]);
            if (g != BD_NONE)
                rc = split_subfac(r, g, 0.0, &outcome);
        }
        if (!rc && outcome == SPLIT_ELSEWHERE) {
            leave_to_merge(r, t);
            return 0;
        }
        if (rc || outcome != SPLIT_REFUSED) {
            if (!rc && !tm_is_dead(m, t))
                rc = queue_tet(r, t);
            return rc;
        }
    }
    int flat = !isfinite(cc[0]) || !isfinite(cc[1]) || !isfinite(cc[2]) ||
               dt_conflict(m, t, cc) <= 0;
    if (flat && ref__flat_tet_centre(m, t, cc) != 0) {
        give_up(r, t, 1);
        return 0;
    }
    int h = r->hooks ? cavity_hook(r, cc, t) : 0;
    if (h && h != REF_SEARCHED)
        return h;
    unsigned sflags = r->o.constrained ? ref__cdt_flags(r) : 0;
    int shrunk = 0;
    int rc = h == REF_SEARCHED ? 0 : dt_cavity_search(m, cc, t, sflags, &r->cav);
    if (rc)
        return rc;
    if (r->cav.status != DT_OK) {
        dt_cavity_abandon(m, &r->cav);
        give_up(r, t, 1);
        return 0;
    }
    if (r->o.constrained && !dt_cavity_is_star(m, &r->cav)) {
        /* A constraint hides cc from t (refine_cdt.c): what cc encroaches
         * on the cavity's boundary is split as usual (ref_decide), else
         * the subfacet between t and cc. */
        double rt = sqrt(v3_dist2(cc, X(m, m->tets[t].v[0])));
        rc = ref_gather_marks(m, &r->cav, &r->marks);
        if (rc) {
            dt_cavity_abandon(m, &r->cav);
            return rc;
        }
        ref_decision d;
        ref_decide(r->p, cc, REF_TET, &r->marks, &d);
        uint32_t g = BD_NONE;
        if (d.action == REF_SPLIT_SUBFACET) {
            const ref_mark *mk = &r->marks.m[d.which];
            g = bd_find_subfac(&r->bd, mk->v[0], mk->v[1], mk->v[2]);
        } else if (d.action == REF_COMMIT) {
            g = ref__cdt_blocker(r, t, cc);
        }
        if (d.action == REF_COMMIT && g == BD_NONE) {
            rc = r->shrink_pass ? shrink_unseen(r, t) : (dt_cavity_abandon(m, &r->cav), 1);
            if (rc < 0)
                return rc;
            if (rc) {
                r->st.unseen++;
                give_up(r, t, 1);
                return 0;
            }
            shrunk = 1;
        } else {
            dt_cavity_abandon(m, &r->cav);
            return split_instead(r, t, why, rt, d.action == REF_SPLIT_SUBSEGS, g);
        }
    }
    uint16_t any = ref__cavity_flags(r);
    const uint32_t *tv = m->tets[t].v;
    double rp = sqrt(v3_dist2(cc, X(m, tv[0])));
    if (flat || shrunk) {
        /* The circle's centre may lie near the ball's surface, close to a
         * vertex outside the ball: its insertion radius is its distance
         * to the nearest vertex, and a point nearer than half t's
         * shortest edge is not inserted. The same for a shrunk cavity:
         * the vertices of the conflicting tetrahedra it dropped may lie
         * nearer than t's circumradius. */
        rp = dmin(rp, ref__cavity_clearance(m, &r->cav, cc));
        double lmin2;
        ref__shortest_edge(m, t, &lmin2);
        if (!(rp >= 0.5 * sqrt(lmin2))) {
            dt_cavity_abandon(m, &r->cav);
            give_up(r, t, 1);
            return 0;
        }
        if (flat)
            r->st.flat_centres++;
    }
    if (any & (TM_F_FACEMARKS | TM_F_SUBSEGS)) {
        rc = ref_gather_marks(m, &r->cav, &r->marks);
        if (rc) {
            dt_cavity_abandon(m, &r->cav);
            return rc;
        }
        ref_decision d;
        ref_decide(r->p, cc, REF_TET, &r->marks, &d);
        if (d.action != REF_COMMIT) {
            dt_cavity_abandon(m, &r->cav);
            uint32_t g = BD_NONE;
            if (d.action == REF_SPLIT_SUBFACET) {
                const ref_mark *mk = &r->marks.m[d.which];
                g = bd_find_subfac(&r->bd, mk->v[0], mk->v[1], mk->v[2]);
            }
            return split_instead(r, t, why, rp, d.action == REF_SPLIT_SUBSEGS, g);
        }
    }
    uint32_t v;
    r->last_op = any & (TM_F_FACEMARKS | TM_F_SUBSEGS) ? "circumcentre (cavity with marks)"
                                                        : "circumcentre";
    rc = ref__commit_point(r, any, BD_V_VOLUME, 0, rp, &v);
    if (rc) {
        dt_cavity_abandon(m, &r->cav);
        return rc;
    }
    r->st.tet_points++;
    return queue_new_tets(r);
}

static int cmp_key(const void *a, const void *b)
{
    const uint32_t *x = a, *y = b;
    for (int i = 0; i < 4; i++)
        if (x[i] != y[i])
            return x[i] < y[i] ? -1 : 1;
    return 0;
}

/* split_tet_at, with r->leftover_try set while t is one of the
 * tetrahedra the run before shrink_passes' current pass left. */
static int split_tet(ref_mesher *r, uint32_t t)
{
    r->leftover_try = 0;
    if (r->shrink_pass && r->nleftover) {
        uint32_t k[4];
        leftover_key(r, t, k);
        r->leftover_try =
            bsearch(k, r->leftover, r->nleftover, sizeof *r->leftover, cmp_key) != NULL;
    }
    uint32_t was[4];
    memcpy(was, r->m.tets[t].v, sizeof was);
    r->flat_step = 0;
    int rc = split_tet_at(r, t);
    if (!rc && r->flat_step)
        rc = flat_count(r, t, was);
    r->flat_step = 0;
    r->leftover_try = 0;
    return rc;
}

void ref_bound_recovery(ref_mesher *r)
{
    r->recovery_from = r->st.missing_recovered;
    r->recovery_limit = r->st.missing_recovered + REF_RECOVERY_PER_VERTEX * r->p->nv +
                        REF_RECOVERY_BASE;
    r->recovery_stuck = 0;
}

size_t ref_recovery_splits(const ref_mesher *r)
{
    return r->st.missing_recovered - r->recovery_from;
}

/* Before the split of a missing piece with vertices v[0..nv-1]: PDR_ELIMIT
 * (r->recovery_stuck, r->stop_at its centroid) once the refinement has
 * split r->recovery_limit of them, else 0. */
static int recovery_bound(ref_mesher *r, const uint32_t *v, int nv)
{
    if (!r->recovery_limit || r->st.missing_recovered < r->recovery_limit)
        return 0;
    for (int k = 0; k < 3; k++) {
        double x = 0;
        for (int i = 0; i < nv; i++)
            x += X(&r->m, v[i])[k];
        r->stop_at[k] = x / nv;
    }
    r->recovery_stuck = 1;
    r->stopped_below = 0;
    return PDR_ELIMIT;
}

/* 1 if present subsegment id is at least the size bound seg_maxlen. */
static int seg_too_long(const ref_mesher *r, uint32_t id)
{
    const bd_subseg *s = &r->bd.segs[id];
    double l = r->o.seg_maxlen;
    return l > 0 && v3_dist2(X(&r->m, s->v[0]), X(&r->m, s->v[1])) >= l * l;
}

/* 1 if subfacet id's circumradius is at least the size bound fac_maxrad. */
static int fac_too_big(const ref_mesher *r, uint32_t id)
{
    const bd_subfac *s = &r->bd.facs[id];
    double l = r->o.fac_maxrad, cc[3], r2;
    return l > 0 &&
           !ref__tri_circumcentre(X(&r->m, s->v[0]), X(&r->m, s->v[1]), X(&r->m, s->v[2]), cc,
                                  &r2) &&
           r2 >= l * l;
}

/* 1 if a queued piece (flags, too_big: above its size bound) is to be
 * dropped: the constrained recovery (before the classification) queues a
 * piece only because it is missing or too big, and one that is present
 * when popped (the split of a neighbour recovered it) is a constraint
 * from then on, which nothing asks to split. Splitting it anyway (at its
 * circumcentre, or the subsegments that circumcentre encroaches, with no
 * floor: a missing piece has none) made most of the recovery's points on
 * CAD tessellations: dragknob.off 273 of its 288 subsegment points. */
static int recovered_meanwhile(const ref_mesher *r, uint16_t flags, int too_big)
{
    return r->o.constrained && !r->classified && !(flags & BD_F_MISSING) && !too_big;
}

/* 1 if subfacet id is bad as a triangle: its circumradius is at least
 * the ratio bound times its shortest side (or cannot be computed). Every
 * tetrahedron on such a face is above the bound, and the quality
 * refinement seldom mends it: the splits its tetrahedra ask for lie
 * beyond the face's short side or next to it, under their floors, or
 * their constrained cavities cannot be made. So the recovery splits it
 * even when it is present by the time it is popped (recovered_meanwhile),
 * as it did before that rule, but with the floor of its shortest side (as
 * unfloored_present): with no floor, the splits cascaded on CGAL's
 * handle.off until a missing piece could not be split (an empty mesh).
 * On joint.off 77 tetrahedra are left above ratio 2 instead of 472
 * (TetGen 5), oblong 239 instead of 793, and pinion's mesh has 30,072
 * tetrahedra instead of 56,039 (mesher/refine/QUALITY.md). */
static int bad_subfac(const ref_mesher *r, uint32_t id)
{
    if (!(r->b2 > 0))
        return 0;
    const bd_subfac *s = &r->bd.facs[id];
    const double *a = X(&r->m, s->v[0]), *b = X(&r->m, s->v[1]), *c = X(&r->m, s->v[2]);
    double l2 = dmin(v3_dist2(b, c), dmin(v3_dist2(a, c), v3_dist2(a, b))), cc[3], r2;
    return ref__tri_circumcentre(a, b, c, cc, &r2) || !(r2 < r->b2 * l2);
}

/* 1 if a queued subfacet (flags, too_big as above, rmin its floor) is
 * present and has no floor in the constrained mode: after the recovery,
 * a face that no flip mends asked for its split (ref__cdt_flip, against
 * an inner edge of a merged facet), or it was queued missing and has been
 * recovered since. Such a split is then made under the floor of the
 * subfacet's shortest side (shortest_side), for its circumcentre and for
 * the subsegments that circumcentre encroaches or lies beyond: like the
 * splits a bad tetrahedron asks for (split_tet), it never puts a vertex
 * nearer to another than the piece it splits is small. Without a floor
 * those subsegment splits made the faces next to them stuck in turn, and
 * the splits cascaded along the thin triangles of CAD tessellations
 * (dragknob.off: 406 subsegment points asked for this way, 7,273
 * tetrahedra against 4,762 with the floor, TetGen 1,227). A refused split
 * leaves the face, counted as not locally Delaunay. */
static int unfloored_present(const ref_mesher *r, uint16_t flags, int too_big, float rmin)
{
    return r->o.constrained && r->classified && !(flags & BD_F_MISSING) && !too_big &&
           rmin == 0.0f;
}

/* The shortest side of subfacet id. */
static double shortest_side(const ref_mesher *r, uint32_t id)
{
    const bd_subfac *s = &r->bd.facs[id];
    double l = INFINITY;
    for (int k = 0; k < 3; k++)
        l = dmin(l, v3_dist2(X(&r->m, s->v[k]), X(&r->m, s->v[(k + 1) % 3])));
    return sqrt(l);
}

/* 1 if the refinement has a size bound: a volume bound (global, or a
 * region's when those apply) or an edge bound. */
int ref__size_bounded(const ref_mesher *r)
{
    if (r->o.maxvol > 0 || r->o.maxedge > 0)
        return 1;
    for (size_t i = 0; r->o.use_region_maxvol && i < r->p->nregion; i++)
        if (r->p->regions[i].maxvol > 0)
            return 1;
    return 0;
}

/* 1 if present subsegment (flags), queued with floor rmin, is one a
 * face that no flip mends asked to split during the quality refinement
 * (constrained mode: after the classification nothing else queues a
 * present subsegment with a floor) past that refinement's bound on them
 * (REF_STUCK_QUALITY_BASE): it is then left. Counts the others. Not with
 * a size bound: the boundary is then split far below the tessellation's
 * scale, and so are the faces next to it (the torus of tests/mesh-cad.sh
 * under -a 2e-5 needs more). */
static int stuck_past_bound(ref_mesher *r, uint16_t flags, float rmin)
{
    if (!r->o.constrained || !r->classified || !r->refining || (flags & BD_F_MISSING) ||
        !(rmin > 0.0f) || ref__size_bounded(r))
        return 0;
    size_t bound = REF_STUCK_QUALITY_BASE + r->p->nv / REF_STUCK_QUALITY_INPUTS;
    if (r->st.stuck_quality >= bound)
        return 1;
    r->st.stuck_quality++;
    return 0;
}

static int process_seg(ref_mesher *r, uint32_t id, float rmin)
{
    bd_subseg *s = &r->bd.segs[id];
    if (s->flags & BD_F_DEAD)
        return 0;
    if (stuck_past_bound(r, s->flags, rmin)) {
        s->flags &= (uint16_t)~BD_F_QUEUED;
        s->flags |= BD_F_TOLERATED;
        r->st.tolerated++;
        return 0;
    }
    if (recovered_meanwhile(r, s->flags, seg_too_long(r, id))) {
        s->flags &= (uint16_t)~BD_F_QUEUED;
        return 0;
    }
    if ((s->flags & BD_F_MISSING) && recovery_bound(r, s->v, 2))
        return PDR_ELIMIT;
    s->flags &= (uint16_t)~BD_F_QUEUED;
    int res;
    return split_subseg(r, id, rmin, 1, &res);
}

static int process_fac(ref_mesher *r, uint32_t id, float rmin)
{
    bd_subfac *s = &r->bd.facs[id];
    if (s->flags & BD_F_DEAD)
        return 0;
    if (r->narrow_recovery && !r->carved) {
        /* The recovery with segments first: a missing subfacet is first
         * recovered with its region by cavity retriangulation, now that
         * its neighbours are constraints (refine_facrec.c); one that was,
         * with another's region, is no longer queued. */
        if (!(s->flags & BD_F_QUEUED))
            return 0;
        if (s->flags & BD_F_MISSING) {
            s->flags &= (uint16_t)~BD_F_QUEUED;
            int rc = ref__recover_region(r, id);
            if (rc <= 0)
                return rc;
            s = &r->bd.facs[id];
            if (s->flags & BD_F_DEAD)
                return 0;
            s->flags |= BD_F_QUEUED;
        }
    }
    int too_big = fac_too_big(r, id);
    if (recovered_meanwhile(r, s->flags, too_big) && !bad_subfac(r, id)) {
        s->flags &= (uint16_t)~BD_F_QUEUED;
        return 0;
    }
    if ((s->flags & BD_F_MISSING) && recovery_bound(r, s->v, 3))
        return PDR_ELIMIT;
    s->flags &= (uint16_t)~BD_F_QUEUED;
    int outcome;
    /* A present piece split here (bad_subfac in the recovery, or one a
     * face no flip mends asked for) has the floor of its shortest side. */
    if (unfloored_present(r, s->flags, too_big, rmin) ||
        (recovered_meanwhile(r, s->flags, too_big) && rmin == 0.0f))
        rmin = (float)shortest_side(r, id);
    int rc = split_subfac(r, id, rmin, &outcome);
    if (!rc && outcome == SPLIT_DEFERRED)
        rc = ref__queue_fac(r, id, rmin);
    return rc;
}

int ref_step(ref_mesher *r, int kind, uint32_t id, float rmin)
{
    tm_mesh *m = &r->m;
    r->step_remote = 0;
    r->flat_step = 0; /* another thread's, if it waits (cavity_hook) */
    switch (kind) {
    case REF_SUBSEG:
        return id < r->bd.nsegs ? process_seg(r, id, rmin) : PDR_EINVAL;
    case REF_SUBFACET:
        return id < r->bd.nfacs ? process_fac(r, id, rmin) : PDR_EINVAL;
    case REF_TET:
        if (id >= m->nslots)
            return PDR_EINVAL;
        if (tm_is_dead(m, id) || tm_is_ghost(m, id) ||
            (m->flags[id] & (REF_F_EXTERIOR | REF_F_GIVEUP)))
            return 0;
        return split_tet(r, id);
    }
    return PDR_EINVAL;
}

/* 1 if a tetrahedron at most depth neighbour steps from t is locked by
 * a cavity in progress (parallel runs: see ref_mesher.busy_depth). The
 * circumcentre of t lies in its circumsphere, so its cavity holds t and
 * its ring t's neighbours; a lock one or two steps further usually meets
 * the search too. */
static int tet_busy(const tm_mesh *m, uint32_t t, uint32_t from, int depth)
{
    if (m->lock[t])
        return 1;
    if (depth == 0)
        return 0;
    for (int k = 0; k < 4; k++) {
        tm_link l = m->tets[t].n[k];
        if (!tm_is_special(l) && tm_ltet(l) != from && tet_busy(m, tm_ltet(l), t, depth - 1))
            return 1;
    }
    return 0;
}

/* Pops the next bad tetrahedron to split into *t, in the order of
 * r->o.order (the local-first stack before the rest), skipping stale
 * entries: dead slots, tetrahedra no longer queued, exterior ones and
 * those given up. Returns 0 when no queue holds one, or when every one
 * is busy (busy_depth). */
#define REF_DEFER_MAX 256
static int pop_tet(ref_mesher *r, uint32_t *t)
{
    tm_mesh *m = &r->m;
    int lifo = r->o.order == REF_ORDER_LIFO;
    /* A busy tetrahedron goes to the back of the (FIFO) queue, once per
     * entry pending now at most: when all are busy, nothing is started
     * until some cavity ends, which only a message or a thread brings.
     * (The LIFO order would pop it again at once: no check there.) */
    size_t defer_left = r->busy_depth > 0 && !lifo
                            ? (r->tetq.n - r->tetq.head) + (r->tetq_local.n - r->tetq_local.head)
                            : 0;
    /* ... and at most REF_DEFER_MAX of them per call: where a cavity's
     * locks span a PE's whole part, every entry is busy, and a PE that
     * went through its whole queue (200,000 entries on turbine.off) each
     * time it looked for work spent its time there while it waited. */
    if (defer_left > REF_DEFER_MAX)
        defer_left = REF_DEFER_MAX;
    for (;;) {
        int local = !q_empty(&r->tetq_local);
        if (!local && q_empty(&r->tetq))
            return 0;
        uint32_t x = local ? q_pop(&r->tetq_local, 1, NULL) : q_pop(&r->tetq, lifo, NULL);
        if (tm_is_dead(m, x) || !(m->flags[x] & TM_F_QUEUED))
            continue;
        int busy = defer_left && (r->hooks && r->hooks->busy
                                      ? r->hooks->busy(r->hooks->arg, x)
                                      : tet_busy(m, x, UINT32_MAX, r->busy_depth));
        if (busy && q_push_tet(&r->tetq, x) == 0) {
            r->st.deferred++;
            if (!--defer_left)
                return 0;
            continue;
        }
        m->flags[x] &= (uint16_t)~TM_F_QUEUED;
        if (m->flags[x] & (REF_F_EXTERIOR | REF_F_GIVEUP))
            continue;
        *t = x;
        return 1;
    }
}

int ref_next(ref_mesher *r, int *kind, uint32_t *id, float *rmin)
{
    if (!q_empty(&r->segq)) {
        *kind = REF_SUBSEG;
        *id = q_pop(&r->segq, 0, rmin);
        return 1;
    }
    if (!q_empty(&r->facq)) {
        *kind = REF_SUBFACET;
        *id = q_pop(&r->facq, 0, rmin);
        return 1;
    }
    uint32_t t;
    if (!r->classified || !pop_tet(r, &t))
        return 0;
    *kind = REF_TET;
    *id = t;
    *rmin = 0;
    return 1;
}

int ref_requeue(ref_mesher *r, int kind, uint32_t id, float rmin)
{
    switch (kind) {
    case REF_SUBSEG:
        return ref__queue_seg(r, id, rmin);
    case REF_SUBFACET:
        return ref__queue_fac(r, id, rmin);
    case REF_TET:
        return queue_tet(r, id);
    }
    return PDR_EINVAL;
}

int ref_check_tet(ref_mesher *r, uint32_t t)
{
    tm_mesh *m = &r->m;
    if (!r->classified || tm_is_dead(m, t) || tm_is_ghost(m, t) ||
        (m->flags[t] & (REF_F_EXTERIOR | REF_F_GIVEUP)))
        return 0;
    double cc[3];
    return ref__tet_bad(r, t, cc, NULL) ? queue_tet(r, t) : 0;
}

int ref_run(ref_mesher *r, int tets)
{
    size_t iter = 0;
    int rc = 0;
    /* Debugging aids (ref_opts): trace lines every trace_every steps,
     * and with check_each_step the marks checked against the tables
     * before every step (slow), stopping at the first disagreement, which
     * the step just done (iter - 1, r->last_op) brought in. */
    FILE *trace = r->o.trace;
    size_t every = r->o.trace_every;
    r->refining = tets != 0;
    while (!rc) {
        if ((++iter & 0x3fff) == 0 && r->o.progress)
            r->o.progress(r->o.progress_arg, r);
        if (r->o.max_points &&
            r->st.seg_points + r->st.fac_points + r->st.tet_points >= r->o.max_points) {
            rc = PDR_ELIMIT;
            break;
        }
        if (r->o.check_each_step && ref_consistency(r, r->o.log, 0)) {
            if (r->o.log)
                fprintf(r->o.log,
                        "refinement tables disagree with the mesh after step %zu (%s)\n",
                        iter - 1, r->last_op ? r->last_op : "-");
            rc = PDR_ETOPOLOGY;
            break;
        }
        if (trace && every && iter % every == 0)
            fprintf(trace,
                    "trace %zu (%s): nv %u segq %zu facq %zu tetq %zu | seg %zu fac %zu tet %zu "
                    "rej %zu tol %zu gave %zu miss %zu anom %zu flips %zu\n",
                    iter, r->last_op ? r->last_op : "-", r->m.nv, r->segq.n - r->segq.head,
                    r->facq.n - r->facq.head, r->tetq.n - r->tetq.head, r->st.seg_points,
                    r->st.fac_points, r->st.tet_points, r->st.rejected, r->st.tolerated,
                    r->st.gave_up, r->st.missing_recovered, r->anomalies, r->flips);
        float rmin;
        uint32_t t;
        if (!q_empty(&r->segq)) {
            uint32_t id = q_pop(&r->segq, 0, &rmin);
            r->last_op = "subsegment";
            rc = process_seg(r, id, rmin);
        } else if (!q_empty(&r->facq)) {
            uint32_t id = q_pop(&r->facq, 0, &rmin);
            r->last_op = "subfacet";
            rc = process_fac(r, id, rmin);
        } else if (tets && r->pause_points && !q_empty(&r->tetq) &&
                   r->st.seg_points + r->st.fac_points + r->st.tet_points >= r->pause_points) {
            r->paused = 1;
            break;
        } else if (tets && r->classified && pop_tet(r, &t)) {
            r->last_op = "tetrahedron";
            rc = split_tet(r, t);
        } else {
            break;
        }
    }
    if (trace)
        fprintf(trace,
                "trace end %zu: nv %u | seg %zu fac %zu tet %zu rej %zu tol %zu gave %zu "
                "slivers %zu miss %zu anom %zu flips %zu | tol: floor %zu hidden %zu below %zu; "
                "needle floor %zu, beyond a subsegment %zu, unseen %zu; stuck splits in the "
                "quality refinement %zu, not asked at acute corners %zu\n",
                iter, r->m.nv, r->st.seg_points, r->st.fac_points, r->st.tet_points,
                r->st.rejected, r->st.tolerated, r->st.gave_up, r->st.slivers_left,
                r->st.missing_recovered, r->anomalies, r->flips, r->st.tol_floor,
                r->st.tol_hidden, r->st.tol_below, r->st.needle_floor, r->st.beyond_seg,
                r->st.unseen, r->st.stuck_quality, r->st.stuck_corner);
    return rc;
}

/* -------------------------------------------- the quality refinement */

int ref_queue_all_tets(ref_mesher *r)
{
    tm_mesh *m = &r->m;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (!ref_is_interior(m, t))
            continue;
        double cc[3];
        if (ref__tet_bad(r, t, cc, NULL)) {
            int rc = queue_tet(r, t);
            if (rc)
                return rc;
        }
    }
    return 0;
}

/* Runs the queues empty, then classifies again while that moves a
 * tetrahedron (see ref_refine). */
static int run_and_reclassify(ref_mesher *r)
{
    int rc = ref_run(r, 1);
    /* Regions follow the tetrahedra through every insertion; a flat
     * tetrahedron on a facet that is not axis-aligned can pass on the
     * wrong one (see reclassify_new in refine_bound.c). When one was met,
     * the finished mesh is classified afresh (a flood fill, cheap); when
     * that moves a tetrahedron, refinement resumes (that tetrahedron may
     * need it now), at most a few times. */
    for (int round = 0; round < 4 && !rc && r->region_doubts; round++) {
        size_t changed = 0;
        r->region_doubts = 0;
        rc = ref_classify(r, NULL, &changed, NULL);
        if (rc || !changed)
            break;
        r->st.reclassified += changed;
        rc = ref_queue_all_tets(r);
        if (!rc)
            rc = ref_run(r, 1);
    }
    return rc;
}

/* Second passes for the constrained mode. Queued again, with
 * r->shrink_pass set: the tetrahedra given up as degenerate (mostly
 * "unseen": faces no flip mends fold the cavity of their circumcentre,
 * which is then shrunk to a star, shrink_unseen), and those given up with
 * a radius-edge ratio above the bound away from small input angles
 * (ref__at_small_angle), most of them because the cavity of the
 * subsegment split they asked for folds the same way: such a split, asked
 * for by one of them (r->leftover; not by the tetrahedra the passes
 * make), takes the tetrahedra around the subsegment (edge_star_cavity,
 * refine_cdt.c). While points are added, at most REF_SHRINK_PASSES
 * times, not after the passes have added more than REF_SHRINK_GROWTH
 * of the vertices before them (pipe.off: faces no flip mends along a
 * thin tube wall keep asking for splits that resolve little), and not
 * after a pass that left no fewer tetrahedra to retry than it started
 * with (CGAL's rotor_small.off: 967, 1,420, 1,948, 2,408 queued in four
 * passes, each pass leaving more above the bound, the last ones seconds
 * long). Left alone: those next to small angles (retried, CGAL's
 * handle.off left 13,803 above ratio 2 instead of 11,269), and those
 * left for the size bound or as slivers (retried, gridtorus.off -a 2e-4
 * on 2 PEs kept faces no flip mends). QUALITY.md has the measurements. */
/* What shrink_passes does with tetrahedron t: 0 nothing, 1 clear its
 * marks, 2 clear them and queue it. */
static int shrink_retry(ref_mesher *r, uint32_t t)
{
    tm_mesh *m = &r->m;
    if (!ref_is_interior(m, t) || !(m->flags[t] & REF_F_GIVEUP))
        return 0;
    double cc[3], q2;
    int why = ref__tet_bad(r, t, cc, &q2);
    if (!(m->flags[t] & REF_F_DEGENERATE) &&
        (!why || !(r->b2 > 0 && q2 >= r->b2) || ref__at_small_angle(r, t)))
        return 0;
    return why ? 2 : 1;
}

static int shrink_passes(ref_mesher *r)
{
    tm_mesh *m = &r->m;
    int rc = 0;
    size_t nv0 = m->nv, added = 0, queued_before = SIZE_MAX;
    for (int pass = 0; pass < REF_SHRINK_PASSES && !rc && added <= REF_SHRINK_GROWTH * nv0;
         pass++) {
        size_t queued = 0;
        for (uint32_t t = 0; t < m->nslots; t++)
            queued += shrink_retry(r, t) == 2;
        if (!queued || queued >= queued_before)
            break; /* done, or the last pass left no fewer: more only grow */
        queued_before = queued;
        r->nleftover = 0;
        for (uint32_t t = 0; t < m->nslots && !rc; t++) {
            int what = shrink_retry(r, t);
            if (!what)
                continue;
            m->flags[t] &= (uint16_t)~(REF_F_GIVEUP | REF_F_DEGENERATE);
            if (what == 1)
                continue;
            rc = queue_tet(r, t);
            if (!rc)
                rc = pdr_grow((void **)&r->leftover, &r->cap_leftover, r->nleftover + 1,
                              sizeof *r->leftover);
            if (!rc)
                leftover_key(r, t, r->leftover[r->nleftover++]);
        }
        if (rc)
            break;
        qsort(r->leftover, r->nleftover, sizeof *r->leftover, cmp_key);
        size_t before = r->st.seg_points + r->st.fac_points + r->st.tet_points;
        r->shrink_pass = 1;
        rc = run_and_reclassify(r);
        r->shrink_pass = 0;
        r->nleftover = 0;
        size_t now = r->st.seg_points + r->st.fac_points + r->st.tet_points;
        if (now == before)
            break;
        added += now - before;
    }
    return rc;
}

int ref_refine(ref_mesher *r)
{
    ref_bound_recovery(r);
    int rc = ref_queue_all_tets(r);
    if (!rc)
        rc = run_and_reclassify(r);
    if (!rc && !r->paused && r->o.constrained && r->carved && !r->hooks)
        rc = shrink_passes(r);
    return rc;
}

int ref_refine_marked(ref_mesher *r)
{
    tm_mesh *m = &r->m;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (!(m->flags[t] & TM_F_QUEUED) || tm_is_dead(m, t))
            continue;
        m->flags[t] &= (uint16_t)~TM_F_QUEUED;
        if (!ref_is_interior(m, t))
            continue;
        int rc = queue_tet(r, t);
        if (rc)
            return rc;
    }
    return run_and_reclassify(r);
}
