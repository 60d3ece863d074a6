/* mesher/refine: off-centre points for the tetrahedra the quality
 * refinement leaves above the radius-edge bound (constrained mode).
 *
 * What the refinement leaves on CAD tessellations (QUALITY.md) are
 * tetrahedra whose circumcentre is refused: it lies beyond a constraint
 * (hidden), or it encroaches a piece whose split the floors refuse (next
 * to small input angles, given up elsewhere). The circumcentre is not the
 * only point that removes such a tetrahedron t: every point strictly
 * inside t's circumsphere has t in its cavity. This pass tries points on
 * the segment from the midpoint of t's shortest edge towards the
 * circumcentre (Ungor's off-centres lie on it), at 2, 1, 0.6, 3.9 and 0.35
 * times that edge's length from the midpoint (at most 0.9 of the way to the
 * circumcentre). That segment lies inside the circumsphere, so each
 * candidate is in conflict with t; near the edge it is also near t, on
 * t's side of the constraints the circumcentre lies beyond.
 *
 * A candidate x is inserted when:
 *   - its constrained cavity (the search stops at subfacets, as every
 *     insertion of the constrained mode) is a star from x: the insertion
 *     then keeps the mesh a constrained Delaunay tetrahedralization, with
 *     the faces no flip mends left as they were; the search stops at 128
 *     tetrahedra and at the first face x does not see (DT_STAR), since a
 *     large or folded cavity is what fails;
 *   - x is at least half t's shortest edge from every vertex it is joined
 *     to;
 *   - the new tetrahedra include fewer above the bound than the cavity
 *     they replace (radius-edge ratio, exactly the summary's count).
 * Encroached pieces are not split: the refinement is over, and the count
 * is what decides. Tried only for tetrahedra of ratio below 8 (above it
 * nearly no candidate passes, and their cavities are the large ones),
 * next to small angles too; in two passes over the mesh. Every insertion
 * lowers the number above the bound, so the passes end; the points made
 * are counted in ref_stats.tet_points and offcentres. What a new point
 * leaves above the bound is flagged given up (the summary's kinds).
 *
 * Owns nothing: works on r's mesh and cavity (r->cav), whose max_tets it
 * sets for its searches and clears again. QUALITY.md, "Off-centres for
 * the leftovers", has the measurements. */
#include "config.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "geom/pred.h"
#include "refine/refine_int.h"
#include "base/v3.h"

#define X(m, v) ((m)->xyz + 3 * (size_t)(v))

/* Passes over the mesh; the largest cavity searched; the largest
 * radius-edge ratio tried (squared). */
#define OFFC_PASSES 2
#define OFFC_MAX_CAVITY 128
#define OFFC_RATIO2_MAX 64.0

/* Distances of the candidates from the shortest edge's midpoint, in units
 * of that edge, in the order tried. */
static const double offc_dist[] = {2.0, 1.0, 0.6, 3.9, 0.35};

/* Squared radius-edge ratio of tetrahedron (a, b, c, d), either
 * orientation. */
static double ratio2_any(const double *a, const double *b, const double *c, const double *d)
{
    double q = ref_tet_ratio2(a, b, c, d, NULL, NULL, NULL);
    if (isinf(q))
        q = ref_tet_ratio2(b, a, c, d, NULL, NULL, NULL);
    return q;
}

/* 1 if the pending cavity of r->cav.p replaced by its star would leave
 * fewer tetrahedra above the bound than it removes. */
static int star_improves(const ref_mesher *r)
{
    const tm_mesh *m = &r->m;
    const dt_cavity *c = &r->cav;
    size_t before = 0, after = 0;
    for (size_t j = 0; j < c->ntets; j++) {
        const uint32_t *v = m->tets[c->tets[j]].v;
        before += ratio2_any(X(m, v[0]), X(m, v[1]), X(m, v[2]), X(m, v[3])) >= r->b2;
    }
    for (size_t j = 0; j < c->nbnd && after < before; j++) {
        const uint32_t *v = m->tets[c->bnd[j].tet].v;
        const uint8_t *fv = tm_face_vtx[c->bnd[j].face];
        after += ratio2_any(X(m, v[fv[0]]), X(m, v[fv[1]]), X(m, v[fv[2]]), c->p) >= r->b2;
    }
    return after < before;
}

/* The new tetrahedra of the last insertion and of the flips after it that
 * are still above the bound are left: flagged given up. */
static void flag_left(ref_mesher *r)
{
    tm_mesh *m = &r->m;
    const dt_cavity *c = &r->cav;
    size_t nflip = r->flipped.n;
    for (size_t j = 0; j < c->nnew + nflip; j++) {
        uint32_t n = j < c->nnew ? c->newtets[j] : r->flipped.tets[j - c->nnew];
        if (tm_is_dead(m, n) || !ref_is_interior(m, n))
            continue;
        double cc[3];
        if (ref__tet_bad(r, n, cc, NULL))
            m->flags[n] |= REF_F_GIVEUP;
    }
}

/* Tries the off-centres of tetrahedron t; *made counts the insertions. */
static int offc_try(ref_mesher *r, uint32_t t, size_t *made)
{
    tm_mesh *m = &r->m;
    if (!ref_is_interior(m, t))
        return 0;
    double cc[3], q2;
    if (ref__tet_bad(r, t, cc, &q2) != 1 || !(r->b2 > 0 && q2 >= r->b2) ||
        !(q2 < OFFC_RATIO2_MAX) || !isfinite(cc[0]) || !isfinite(cc[1]) || !isfinite(cc[2]))
        return 0;
    const uint32_t *tv = m->tets[t].v;
    double l2;
    int emin = ref__shortest_edge(m, t, &l2);
    const double *a = X(m, tv[tm_edge_vtx[emin][0]]), *b = X(m, tv[tm_edge_vtx[emin][1]]);
    double mid[3];
    for (int k = 0; k < 3; k++)
        mid[k] = 0.5 * (a[k] + b[k]);
    double l = sqrt(l2), dc = sqrt(v3_dist2(cc, mid));
    if (!(dc > 0))
        return 0;
    unsigned flags = ref__cdt_flags(r) | DT_STAR;
    for (size_t i = 0; i < sizeof offc_dist / sizeof *offc_dist; i++) {
        double f = fmin(0.9, offc_dist[i] * l / dc), x[3];
        for (int k = 0; k < 3; k++)
            x[k] = mid[k] + f * (cc[k] - mid[k]);
        if (dt_conflict(m, t, x) <= 0)
            continue;
        int rc = dt_cavity_search(m, x, t, flags, &r->cav);
        if (rc)
            return rc;
        if (r->cav.status != DT_OK)
            continue; /* too big, no star, or a vertex: nothing pending */
        double clr = ref__cavity_clearance(m, &r->cav, x);
        if (!dt_cavity_is_star(m, &r->cav) || !(clr >= 0.5 * l) || !star_improves(r)) {
            dt_cavity_abandon(m, &r->cav);
            continue;
        }
        uint32_t v;
        r->last_op = "off-centre";
        rc = ref__commit_point(r, ref__cavity_flags(r), BD_V_VOLUME, 0, clr, &v);
        if (rc) {
            dt_cavity_abandon(m, &r->cav);
            return rc;
        }
        r->st.tet_points++;
        r->st.offcentres++;
        (*made)++;
        r->flipped.n = 0;
        rc = ref__cdt_flip(r, r->cav.newtets, r->cav.nnew);
        if (!rc)
            flag_left(r);
        return rc;
    }
    return 0;
}

int ref_offcentres(ref_mesher *r)
{
    /* Nothing given up, nothing left above the bound: no scan (the
     * paper's domains). */
    if (r->paused || !r->o.constrained || !r->carved || r->hooks || !r->st.gave_up)
        return 0;
    int rc = 0;
    r->cav.max_tets = OFFC_MAX_CAVITY;
    uint32_t vnew = 0; /* later passes: tetrahedra at the last one's points */
    for (int pass = 0; pass < OFFC_PASSES && !rc; pass++) {
        size_t made = 0;
        uint32_t n = r->m.nslots, nv = r->m.nv;
        for (uint32_t t = 0; t < n && !rc; t++) {
            if (tm_is_dead(&r->m, t))
                continue;
            const uint32_t *v = r->m.tets[t].v;
            if (v[0] < vnew && v[1] < vnew && v[2] < vnew && v[3] < vnew)
                continue;
            rc = offc_try(r, t, &made);
        }
        if (!made)
            break;
        vnew = nv;
    }
    r->cav.max_tets = 0;
    return rc;
}
