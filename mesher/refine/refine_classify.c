/*
 * refine/refine_classify.c -- what the refinement asks of a whole mesh
 * rather than of one cavity: classification (exterior, holes and regions
 * by components), the consistency check of the marks against the
 * subsegment and subfacet tables, counting what was left above the
 * bounds, the radius-edge and dihedral ranges of the summary, and the
 * export to the writers' neutral form.
 */
#include "config.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "base/fj.h"
#include "base/pdr_util.h"
#include "mesh/vf.h"
#include "plc/fm.h"
#include "refine/refine_int.h"
#include "base/v3.h"

#define X(m, v) ((m)->xyz + 3 * (size_t)(v))

/* ---------------------------------------------------- classification */

/* Classification: the tetrahedra fall into components joined across
 * faces that are not subfacets; the outside is every component with a
 * ghost and every one holding a hole point, a region is the component
 * holding its region point (the first point wins), and what is left is
 * inside, with no region. The components come from a union-find over the
 * slots, a scan in slot order, which on a mesh of 10^6 tetrahedra takes
 * about a third of the time of a flood fill from the seeds (whose walk
 * jumps around the tetrahedron array). */

/* The representative of t's component (path halving). */
static uint32_t uf_find(uint32_t *up, uint32_t t)
{
    while (up[t] != t) {
        up[t] = up[up[t]];
        t = up[t];
    }
    return t;
}

/* up[t]: the union-find forest of the components, every live slot in one
 * (dead slots are their own). */
static void components(const tm_mesh *m, uint32_t *up)
{
    for (uint32_t t = 0; t < m->nslots; t++)
        up[t] = t;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t))
            continue;
        for (int k = 0; k < 4; k++) {
            tm_link l = m->tets[t].n[k];
            if (tm_is_special(l) || tm_ltet(l) < t)
                continue; /* each link once, from its lower slot */
            uint32_t u = tm_ltet(l);
            if ((m->flags[t] & TM_F_FACEMARK(k)) && (m->flags[u] & TM_F_FACEMARK(tm_lface(l))))
                continue;
            uint32_t x = uf_find(up, t), y = uf_find(up, u);
            if (x < y)
                up[y] = x;
            else if (y < x)
                up[x] = y;
        }
    }
}

/* The component of the live tetrahedron holding point x, or TM_NONE (x
 * outside the hull, on a ghost, or not strictly inside one); *rc < 0 on
 * failure. */
static uint32_t located(ref_mesher *r, uint32_t *up, const double *x, int *rc)
{
    tm_mesh *m = &r->m;
    uint32_t t;
    tm_link exit;
    int l = dt_locate(m, x, TM_NONE, &t, &exit);
    *rc = l < 0 ? l : 0;
    if (l != 0 || tm_is_ghost(m, t))
        return TM_NONE;
    return uf_find(up, t);
}

int ref_classify(ref_mesher *r, size_t *unreached, size_t *changed, pdr_diag *diag)
{
    tm_mesh *m = &r->m;
    const plc *p = r->p;
    if (r->carved) {
        /* The exterior is gone and every insertion since gave its new
         * tetrahedra the region of the side they were built on, a side
         * of a constraint no cavity crosses: nothing to classify. */
        if (unreached)
            *unreached = 0;
        if (changed)
            *changed = 0;
        return 0;
    }
    int rc = ref_region_room(r);
    if (rc)
        return rc;
    /* state[c] and g[c] of component c's representative: 1 out, 2 in
     * with region g, 0 not reached (inside, no region) */
    uint8_t *state = pr_calloc(m->nslots ? m->nslots : 1, 1);
    uint32_t *up = pr_malloc((m->nslots ? m->nslots : 1) * sizeof *up);
    uint16_t *g = r->region ? pr_calloc(m->nslots ? m->nslots : 1, sizeof *g) : NULL;
    if (!state || !up || (r->region && !g)) {
        pr_free(state);
        pr_free(up);
        pr_free(g);
        return PDR_ENOMEM;
    }
    /* the previous regions, to count changes: a copy of the region array
     * (the exterior flags stay on the mesh until the end) */
    uint16_t *old = NULL;
    if (r->region && r->classified) {
        old = pr_malloc(r->region_cap * sizeof *old);
        if (!old) {
            pr_free(state);
            pr_free(up);
            pr_free(g);
            return PDR_ENOMEM;
        }
        memcpy(old, r->region, r->region_cap * sizeof *old);
    }
    if (r->region)
        memset(r->region, 0, r->region_cap * sizeof *r->region);
    components(m, up);
    /* Outside: the components of the ghosts and of the hole points. */
    for (uint32_t t = 0; t < m->nslots; t++)
        if (!tm_is_dead(m, t) && tm_is_ghost(m, t))
            state[uf_find(up, t)] = 1;
    for (size_t h = 0; h < p->nhole && !rc; h++) {
        uint32_t c = located(r, up, p->holes[h].xyz, &rc);
        if (c != TM_NONE && !state[c])
            state[c] = 1;
    }
    size_t lost = 0;
    for (size_t j = 0; j < p->nregion && !rc; j++) {
        uint32_t c = located(r, up, p->regions[j].xyz, &rc);
        if (rc)
            break;
        if (c == TM_NONE || state[c] == 1) {
            lost++;
            if (diag)
                pdr_diag_add(diag, p->path, p->regions[j].line,
                             "warning: region point %zu lies outside the domain; ignored", j + 1);
            continue;
        }
        if (state[c] == 2)
            continue; /* a region already seeded by an earlier point */
        state[c] = 2;
        if (g)
            g[c] = (uint16_t)(j + 1);
        /* Located once more, as the flood fill this replaced did from its
         * seed: the walk draws from the mesh's random state (m->rng), on
         * which every later location depends, so the meshes stay the
         * ones of before. */
        located(r, up, p->regions[j].xyz, &rc);
    }
    /* every tetrahedron takes its component's state and region */
    for (uint32_t t = 0; t < m->nslots && !rc; t++) {
        if (tm_is_dead(m, t))
            continue;
        uint32_t c = uf_find(up, t);
        state[t] = state[c];
        if (r->region)
            r->region[t] = state[c] == 2 ? g[c] : 0;
    }
    size_t nchanged = 0;
    if (!rc) {
        for (uint32_t t = 0; t < m->nslots; t++) {
            if (tm_is_dead(m, t))
                continue;
            uint16_t was = m->flags[t] & REF_F_EXTERIOR;
            if (state[t] == 1)
                m->flags[t] |= REF_F_EXTERIOR;
            else
                m->flags[t] &= (uint16_t)~REF_F_EXTERIOR;
            if (r->classified && !tm_is_ghost(m, t) &&
                (was != (m->flags[t] & REF_F_EXTERIOR) ||
                 (old && state[t] != 1 && old[t] != r->region[t]))) {
                nchanged++;
                m->flags[t] &= (uint16_t)~(REF_F_GIVEUP | REF_F_DEGENERATE);
            }
        }
        r->classified = 1;
    }
    if (unreached)
        *unreached = lost;
    if (changed)
        *changed = nchanged;
    pr_free(old);
    pr_free(up);
    pr_free(g);
    pr_free(state);
    return rc;
}

/* ---------------------------------------------------- checks and counts */

size_t ref_consistency(const ref_mesher *r, FILE *log, int what)
{
    const tm_mesh *m = &r->m;
    const bd_set *bd = &r->bd;
    size_t bad = 0;
    /* While a subfacet is missing, the marks do not yet separate the
     * regions there: check regions only when none is. */
    int regions = r->classified && (what & REF_CONSIST_REGIONS);
    for (uint32_t i = 0; i < bd->nfacs && regions; i++)
        if ((bd->facs[i].flags & (BD_F_DEAD | BD_F_MISSING)) == BD_F_MISSING)
            regions = 0;
    /* Which subfacets some tetrahedron marks: a scan, not a walk from the
     * vertices, because on one PE of the parallel refinement the star of a
     * vertex may be cut into pieces by interface faces. */
    uint8_t *marked = pr_calloc(bd->nfacs ? bd->nfacs : 1, 1);
    if (!marked) {
        if (log)
            fprintf(log, "no memory for the consistency check\n");
        return 1;
    }
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t))
            continue;
        const tm_tet *T = &m->tets[t];
        for (int k = 0; k < 4; k++) {
            if (!(m->flags[t] & TM_F_FACEMARK(k)))
                continue;
            uint32_t a = T->v[tm_face_vtx[k][0]], b = T->v[tm_face_vtx[k][1]],
                     c = T->v[tm_face_vtx[k][2]];
            uint32_t id = bd_find_subfac(bd, a, b, c);
            if (id == BD_NONE || (bd->facs[id].flags & BD_F_MISSING) ||
                (int32_t)bd->facs[id].facet + 1 != tm_marker(m, t, k)) {
                if (log)
                    fprintf(log, "marked face %u %u %u of tet %u is no live subfacet\n", a, b, c,
                            t);
                bad++;
            } else {
                marked[id] = 1;
            }
        }
        /* regions change only across subfacets */
        for (int k = 0; k < 4 && regions; k++) {
            tm_link l = T->n[k];
            if (tm_is_special(l) || (m->flags[t] & TM_F_FACEMARK(k)))
                continue;
            uint32_t u = tm_ltet(l);
            int et = (m->flags[t] & REF_F_EXTERIOR) || tm_is_ghost(m, t);
            int eu = (m->flags[u] & REF_F_EXTERIOR) || tm_is_ghost(m, u);
            if (et != eu || (r->region && !et && r->region[t] != r->region[u])) {
                if (log)
                    fprintf(log,
                            "tets %u (%u %u %u %u, flags %x) and %u (%u %u %u %u, flags %x) "
                            "differ in region across unmarked face %d (regions %d %d)\n",
                            t, T->v[0], T->v[1], T->v[2], T->v[3], m->flags[t], u,
                            m->tets[u].v[0], m->tets[u].v[1], m->tets[u].v[2], m->tets[u].v[3],
                            m->flags[u], k, r->region ? r->region[t] : -1,
                            r->region ? r->region[u] : -1);
                bad++;
            }
        }
        for (int e = 0; e < 6; e++) {
            if (!(m->flags[t] & TM_F_SUBSEG(e)))
                continue;
            uint32_t a = T->v[tm_edge_vtx[e][0]], b = T->v[tm_edge_vtx[e][1]];
            uint32_t id = bd_find_subseg(bd, a, b);
            if (id == BD_NONE || (bd->segs[id].flags & BD_F_MISSING)) {
                if (log)
                    fprintf(log, "flagged edge %u %u of tet %u is no live subsegment\n", a, b, t);
                bad++;
            }
        }
    }
    for (uint32_t i = 0; i < bd->nfacs; i++) {
        const bd_subfac *s = &bd->facs[i];
        if ((s->flags & (BD_F_DEAD | BD_F_MISSING)) || marked[i])
            continue;
        uint32_t t;
        if (log)
            fprintf(log, "present subfacet %u (%u %u %u) is %s\n", i, s->v[0], s->v[1], s->v[2],
                    ref__find_in_star(m, s->v[0], s->v[1], s->v[2], &t) ? "not marked"
                                                                        : "no face");
        bad++;
    }
    pr_free(marked);
    if (r->carved && !r->hooks && !(what & REF_CONSIST_PART) && r->segq.n == r->segq.head &&
        r->facq.n == r->facq.head) {
        /* The constrained mode keeps a CDT: every face that is no
         * constraint locally Delaunay, once the boundary splits that the
         * flips asked for (refine_run.c, queue_new_tets) are done. */
        vf_report vr;
        memset(&vr, 0, sizeof vr);
        if (vf_check(m, VF_DELAUNAY | VF_CONSTRAINED, &vr) == 0 && vr.not_delaunay) {
            if (log)
                fprintf(log, "%zu faces that are no constraint are not locally Delaunay\n",
                        vr.not_delaunay);
            bad += vr.not_delaunay;
        }
    }
    return bad;
}

size_t ref_interior_tets(const ref_mesher *r)
{
    const tm_mesh *m = &r->m;
    size_t n = 0;
    for (uint32_t t = 0; t < m->nslots; t++)
        n += ref_is_interior(m, t);
    return n;
}

/* Counted from the side that is not interior: every face between an
 * interior and another tetrahedron has such a side, and those tetrahedra
 * are few (nothing outside the domain is refined), so that the one read
 * of a neighbour per face that a whole pass takes falls on them alone;
 * an interior tetrahedron's face without a neighbour is in its own
 * record. (A pass reading every face's neighbour took 6% of the
 * sequential run, twice that at rank 0 of a parallel one.) */
size_t ref_unmarked_bounds(const ref_mesher *r)
{
    const tm_mesh *m = &r->m;
    size_t n = 0;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t))
            continue;
        int in = ref_is_interior(m, t);
        for (int f = 0; f < 4; f++) {
            tm_link l = m->tets[t].n[f];
            if (in) {
                n += l == TM_LINK_NONE && !(m->flags[t] & TM_F_FACEMARK(f));
                continue;
            }
            if (tm_is_special(l))
                continue;
            uint32_t u = tm_ltet(l);
            n += u < m->nslots && ref_is_interior(m, u) &&
                 !(m->flags[u] & TM_F_FACEMARK(tm_lface(l)));
        }
    }
    return n;
}

/* The input feature tetrahedron t is left next to: the apex of the small
 * angle its seditious shortest edge is across (constrained mode), else an
 * input vertex of it, else a segment one of its vertices lies on, else a
 * facet, else the volume (kind BD_V_VOLUME). */
static void left_site(const ref_mesher *r, uint32_t t, int *kind, uint32_t *feature)
{
    const uint32_t *v = r->m.tets[t].v;
    uint32_t apex = r->o.constrained ? ref__cdt_seditious_tet(r, t) : UINT32_MAX;
    if (apex != UINT32_MAX) {
        *kind = BD_V_INPUT;
        *feature = apex;
        return;
    }
    static const int order[3] = {BD_V_INPUT, BD_V_SEGMENT, BD_V_FACET};
    for (int o = 0; o < 3; o++)
        for (int k = 0; k < 4; k++)
            if (r->bd.vkind[v[k]] == order[o]) {
                *kind = order[o];
                *feature = r->bd.vfeat[v[k]];
                return;
            }
    *kind = BD_V_VOLUME;
    *feature = 0;
}

int ref__seg_small_angle(const ref_mesher *r, uint32_t seg)
{
    const plc *p = r->p;
    if (!p->v_minang || !p->seg_mindih)
        return 1;
    return seg < p->nseg &&
           (p->seg_mindih[seg] < FM_SHARP_DIH || p->v_minang[p->segs[seg].v[0]] < FM_ACUTE_ANG ||
            p->v_minang[p->segs[seg].v[1]] < FM_ACUTE_ANG);
}

int ref__at_small_angle(const ref_mesher *r, uint32_t t)
{
    const plc *p = r->p;
    if (!p->v_minang || !p->seg_mindih)
        return 1;
    if (r->o.constrained && ref__cdt_seditious_tet(r, t) != UINT32_MAX)
        return 1;
    const uint32_t *v = r->m.tets[t].v;
    for (int k = 0; k < 4; k++) {
        uint32_t f = r->bd.vfeat[v[k]];
        switch (r->bd.vkind[v[k]]) {
        case BD_V_INPUT:
            if (f < p->nv && p->v_minang[f] < FM_ACUTE_ANG)
                return 1;
            break;
        case BD_V_SEGMENT:
            if (ref__seg_small_angle(r, f))
                return 1;
            break;
        default:
            break;
        }
    }
    return 0;
}

/* Counts tetrahedra per site and keeps the REF_LEFT_SITES largest. */
static void tally_sites(ref_mesher *r, const uint64_t *keys, size_t n)
{
    memset(r->st.left_site, 0, sizeof r->st.left_site);
    size_t i = 0;
    while (i < n) {
        size_t j = i;
        while (j < n && keys[j] == keys[i])
            j++;
        size_t cnt = j - i;
        for (int s = 0; s < REF_LEFT_SITES; s++) {
            if (cnt <= r->st.left_site[s].count)
                continue;
            memmove(&r->st.left_site[s + 1], &r->st.left_site[s],
                    (REF_LEFT_SITES - 1 - (size_t)s) * sizeof r->st.left_site[0]);
            r->st.left_site[s].kind = (int)(keys[i] >> 32);
            r->st.left_site[s].feature = (uint32_t)keys[i];
            r->st.left_site[s].count = cnt;
            break;
        }
        i = j;
    }
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* One share of ref_count_bad's slots, counted on its own (base/fj.h). */
typedef struct count_share {
    const ref_mesher *r;
    uint32_t lo, hi;          /* slots [lo, hi) */
    size_t ratio, angle, refused, degenerate, hidden, size, sliver;
    uint64_t *keys;           /* (kind, feature) of each given up */
    size_t nkeys, cap;
} count_share;

static int count_share_run(void *arg)
{
    count_share *c = arg;
    const ref_mesher *r = c->r;
    const tm_mesh *m = &r->m;
    for (uint32_t t = c->lo; t < c->hi; t++) {
        if (!ref_is_interior(m, t))
            continue;
        double cc[3], q;
        int why = ref__tet_bad(r, t, cc, &q);
        if (!why)
            continue;
        if (r->b2 > 0 && q >= r->b2) {
            c->ratio++;
            if (m->flags[t] & REF_F_GIVEUP) {
                int finite = isfinite(q) && isfinite(cc[0]) && isfinite(cc[1]) &&
                             isfinite(cc[2]);
                if (m->flags[t] & REF_F_DEGENERATE) {
                    /* split_tet's test of a flat tetrahedron: no
                     * circumcentre in conflict with it; or flat on a
                     * facet (why 3), left once its splits were spent,
                     * whose circumcentre is finite but ill-conditioned.
                     * Otherwise that point was usable and its cavity
                     * was not. */
                    if (why != 3 && finite && dt_conflict(m, t, cc) > 0)
                        c->hidden++;
                    else
                        c->degenerate++;
                } else if (!finite) {
                    c->degenerate++;
                } else {
                    if (ref__at_small_angle(r, t))
                        c->angle++;
                    else
                        c->refused++;
                    int kind;
                    uint32_t f;
                    left_site(r, t, &kind, &f);
                    /* no memory for the tally: the counts stay right */
                    if (!pdr_grow((void **)&c->keys, &c->cap, c->nkeys + 1, sizeof *c->keys))
                        c->keys[c->nkeys++] = (uint64_t)kind << 32 | f;
                }
            }
        } else if (why == 2) {
            c->sliver++;
        } else {
            c->size++;
        }
    }
    return 0;
}

/* Below this many slots one share does it all, on the calling thread. */
#define COUNT_SHARES_FROM 400000
#define COUNT_MAX_SHARES 8

void ref_count_bad(ref_mesher *r)
{
    const tm_mesh *m = &r->m;
    unsigned n = m->nslots >= COUNT_SHARES_FROM ? fj_cores() : 1;
    if (n > COUNT_MAX_SHARES)
        n = COUNT_MAX_SHARES;
    count_share sh[COUNT_MAX_SHARES];
    fj_task ft[COUNT_MAX_SHARES];
    for (unsigned i = 0; i < n; i++) {
        sh[i] = (count_share){.r = r,
                              .lo = (uint32_t)((uint64_t)m->nslots * i / n),
                              .hi = (uint32_t)((uint64_t)m->nslots * (i + 1) / n)};
        ft[i] = (fj_task){.run = count_share_run, .arg = &sh[i]};
    }
    fj_run(ft, n, n);
    r->st.left_ratio = r->st.left_ratio_angle = r->st.left_ratio_degenerate = 0;
    r->st.left_ratio_hidden = 0;
    r->st.left_ratio_refused = 0;
    r->st.left_size = r->st.left_sliver = 0;
    /* Also without keep_stuck: a split that a face no flip mends asks for
     * may be refused (the floor, a cavity that cannot be made), and the
     * face is then left too; the summary must say so. */
    r->st.left_stuck = r->keep_stuck || r->o.constrained ? ref__count_stuck(r) : 0;
    for (unsigned i = 0; i < n; i++) {
        r->st.left_ratio += sh[i].ratio;
        r->st.left_ratio_angle += sh[i].angle;
        r->st.left_ratio_refused += sh[i].refused;
        r->st.left_ratio_degenerate += sh[i].degenerate;
        r->st.left_ratio_hidden += sh[i].hidden;
        r->st.left_size += sh[i].size;
        r->st.left_sliver += sh[i].sliver;
    }
    /* The shares' sites in one list (the first share's list, grown; no
     * memory for it: the tally keeps what fits). */
    uint64_t *keys = sh[0].keys;
    size_t have = sh[0].nkeys, cap = sh[0].cap;
    for (unsigned i = 1; i < n; i++) {
        if (sh[i].nkeys && !pdr_grow((void **)&keys, &cap, have + sh[i].nkeys, sizeof *keys)) {
            memcpy(keys + have, sh[i].keys, sh[i].nkeys * sizeof *keys);
            have += sh[i].nkeys;
        }
        pr_free(sh[i].keys);
    }
    if (have)
        qsort(keys, have, sizeof *keys, cmp_u64);
    tally_sites(r, keys, have);
    pr_free(keys);
}

/* ------------------------------------------------------------ summary */

double ref_tet_ratio2(const double *a, const double *b, const double *c, const double *d,
                      double *vol, double *lmax2, double cc[3])
{
    double u[3], v[3], w[3], vw[3], wu[3], uv[3];
    double det = v3_tet_frame(a, b, c, d, u, v, w, vw, wu, uv);
    double uu = v3_dot(u, u), vv = v3_dot(v, v), ww = v3_dot(w, w);
    double e3 = v3_dist2(b, c), e4 = v3_dist2(b, d), e5 = v3_dist2(c, d);
    double lo = uu, hi = uu;
    double e[5] = {vv, ww, e3, e4, e5};
    for (int k = 0; k < 5; k++) {
        if (e[k] < lo)
            lo = e[k];
        if (e[k] > hi)
            hi = e[k];
    }
    if (vol)
        *vol = det / 6.0;
    if (lmax2)
        *lmax2 = hi;
    if (!(det > 0.0) || !(lo > 0.0)) {
        if (cc)
            cc[0] = cc[1] = cc[2] = NAN;
        return INFINITY;
    }
    double inv = 0.5 / det;
    double x = (uu * vw[0] + vv * wu[0] + ww * uv[0]) * inv;
    double y = (uu * vw[1] + vv * wu[1] + ww * uv[1]) * inv;
    double z = (uu * vw[2] + vv * wu[2] + ww * uv[2]) * inv;
    if (cc) {
        cc[0] = a[0] + x;
        cc[1] = a[1] + y;
        cc[2] = a[2] + z;
    }
    return (x * x + y * y + z * z) / lo;
}

void ref_quality_range(const mesh_export *e, ref_quality *q)
{
    double re2_lo = INFINITY, re2_hi = 0, c_lo = INFINITY, c_hi = -INFINITY;
    for (size_t t = 0; t < e->nt; t++) {
        const double *p[4];
        for (int k = 0; k < 4; k++)
            p[k] = e->xyz[e->tet[t][k]];
        double q2 = ref_tet_ratio2(p[0], p[1], p[2], p[3], NULL, NULL, NULL);
        if (q2 < re2_lo)
            re2_lo = q2;
        if (q2 > re2_hi)
            re2_hi = q2;
        /* face normals (either orientation of the tetrahedron: the sign of
         * every normal flips together, the dot products do not) */
        double n[4][3], len[4];
        for (int i = 0; i < 4; i++) {
            const uint8_t *f = tm_face_vtx[i];
            double u[3], v[3];
            v3_sub(p[f[1]], p[f[0]], u);
            v3_sub(p[f[2]], p[f[0]], v);
            v3_cross(u, v, n[i]);
            len[i] = sqrt(v3_dot(n[i], n[i]));
        }
        for (int i = 0; i < 4; i++)
            for (int j = i + 1; j < 4; j++) {
                /* the dihedral angle at the edge shared by faces i and j:
                 * cos = -(n_i . n_j) / (|n_i| |n_j|) */
                double c = -v3_dot(n[i], n[j]) / (len[i] * len[j]);
                if (c < c_lo)
                    c_lo = c;
                if (c > c_hi)
                    c_hi = c;
            }
    }
    q->re_min = sqrt(re2_lo);
    q->re_max = sqrt(re2_hi);
    q->dih_min = acos(fmax(-1.0, fmin(1.0, c_hi))) * 180.0 / M_PI;
    q->dih_max = acos(fmax(-1.0, fmin(1.0, c_lo))) * 180.0 / M_PI;
}

/* ------------------------------------------------------------- export */

void ref_output_free(ref_output *out)
{
    pr_free(out->xyz);
    pr_free(out->tet);
    pr_free(out->tet_region);
    pr_free(out->tet_attr);
    pr_free(out->tri);
    pr_free(out->tri_marker);
    pr_free(out->tri_facet);
    pr_free(out->vmap);
    memset(out, 0, sizeof *out);
}

/* The export of ref_export; with_tets 0 leaves out->tet (and the view's
 * tet) NULL for ref_export_take to fill. */
static int export_mesh(const ref_mesher *r, ref_output *out, int with_tets)
{
    memset(out, 0, sizeof *out);
    const tm_mesh *m = &r->m;
    const bd_set *bd = &r->bd;
    size_t nt = ref_interior_tets(r);
    out->vmap = pr_malloc((size_t)m->nv * sizeof *out->vmap);
    if (with_tets)
        out->tet = pr_malloc((nt ? nt : 1) * sizeof *out->tet);
    if (!out->vmap || (with_tets && !out->tet))
        goto nomem;
    memset(out->vmap, 0xff, (size_t)m->nv * sizeof *out->vmap);
    if (r->region) {
        out->tet_region = pr_malloc((nt ? nt : 1) * sizeof *out->tet_region);
        out->tet_attr = pr_malloc((nt ? nt : 1) * sizeof *out->tet_attr);
        if (!out->tet_region || !out->tet_attr)
            goto nomem;
    }
    /* Vertices numbered in the order tetrahedra first use them, which
     * keeps the output's memory order close to the mesh's. */
    size_t nv = 0, k = 0;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (!ref_is_interior(m, t))
            continue;
        for (int s = 0; s < 4; s++) {
            uint32_t v = m->tets[t].v[s];
            if (out->vmap[v] == UINT32_MAX)
                out->vmap[v] = (uint32_t)nv++;
            if (with_tets)
                out->tet[k][s] = out->vmap[v];
        }
        if (r->region) {
            int g = r->region[t];
            double a = g ? r->p->regions[g - 1].attr : 0.0;
            out->tet_attr[k] = a;
            out->tet_region[k] = (int)lrint(a);
        }
        k++;
    }
    out->xyz = pr_malloc((nv ? nv : 1) * sizeof *out->xyz);
    if (!out->xyz)
        goto nomem;
    for (uint32_t v = 1; v < m->nv; v++)
        if (out->vmap[v] != UINT32_MAX)
            memcpy(out->xyz[out->vmap[v]], X(m, v), sizeof out->xyz[0]);
    /* Subfacets with an interior tetrahedron on at least one side (a facet
     * with the outside or a hole on both sides bounds nothing), taken from
     * the marked faces of the interior tetrahedra, in the facet
     * triangulation's orientation. */
    size_t nf = 0, capf = 0;
    for (int pass = 0; pass < 2; pass++) {
        if (pass == 1) {
            capf = nf ? nf : 1;
            out->tri = pr_malloc(capf * sizeof *out->tri);
            out->tri_marker = pr_malloc(capf * sizeof *out->tri_marker);
            out->tri_facet = pr_malloc(capf * sizeof *out->tri_facet);
            if (!out->tri || !out->tri_marker || !out->tri_facet)
                goto nomem;
            nf = 0;
        }
        for (uint32_t t = 0; t < m->nslots; t++) {
            uint16_t fl = m->flags[t];
            if (!(fl & TM_F_FACEMARKS) || (fl & (TM_F_DEAD | REF_F_EXTERIOR)) || tm_is_ghost(m, t))
                continue;
            const tm_tet *T = &m->tets[t];
            for (int fi = 0; fi < 4; fi++) {
                if (!(fl & TM_F_FACEMARK(fi)))
                    continue;
                tm_link l = T->n[fi];
                if (!tm_is_special(l)) {
                    uint32_t u = tm_ltet(l);
                    if (u < t && !(m->flags[u] & REF_F_EXTERIOR) && !tm_is_ghost(m, u))
                        continue; /* listed from u */
                }
                if (pass == 0) {
                    nf++;
                    continue;
                }
                uint32_t a = T->v[tm_face_vtx[fi][0]], b = T->v[tm_face_vtx[fi][1]],
                         c = T->v[tm_face_vtx[fi][2]];
                uint32_t id = bd_find_subfac(bd, a, b, c);
                uint32_t tv[3] = {a, b, c};
                const uint32_t *q = id != BD_NONE ? bd->facs[id].v : tv;
                for (int j = 0; j < 3; j++)
                    out->tri[nf][j] = out->vmap[q[j]];
                int32_t f = tm_marker(m, t, fi) - 1;
                out->tri_marker[nf] = r->p->facets[f].marker;
                out->tri_facet[nf] = f;
                nf++;
            }
        }
    }
    mesh_export *e = &out->view;
    e->nv = nv;
    e->xyz = (const double(*)[3])out->xyz;
    e->nt = nt;
    e->tet = (const uint32_t(*)[4])out->tet;
    e->tet_region = out->tet_region;
    e->nf = nf;
    e->tri = (const uint32_t(*)[3])out->tri;
    e->tri_marker = out->tri_marker;
    return 0;
nomem:
    ref_output_free(out);
    return PDR_ENOMEM;
}

int ref_export(const ref_mesher *r, ref_output *out)
{
    return export_mesh(r, out, 1);
}

int ref_export_take(ref_mesher *r, ref_output *out)
{
    int rc = export_mesh(r, out, 0);
    if (rc)
        return rc;
    /* Output tetrahedron k (16 bytes) goes to bytes [16k, 16k + 16) of the
     * slot array (32-byte slots): inside slot k / 2, and k <= t, so no
     * slot is overwritten before it has been read (slot 0 is read whole
     * first). */
    tm_mesh *m = &r->m;
    uint32_t(*dst)[4] = (uint32_t(*)[4])(void *)m->tets;
    size_t k = 0;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (!ref_is_interior(m, t))
            continue;
        uint32_t v[4];
        for (int s = 0; s < 4; s++)
            v[s] = out->vmap[m->tets[t].v[s]];
        memcpy(dst[k], v, sizeof v);
        k++;
    }
    size_t bytes = (k ? k : 1) * sizeof *dst;
    uint32_t(*shrunk)[4] = pr_realloc(dst, bytes);
    out->tet = shrunk ? shrunk : dst;
    m->tets = NULL;
    tm_free(m);
    out->view.tet = (const uint32_t(*)[4])out->tet;
    return 0;
}
