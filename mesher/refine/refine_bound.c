/*
 * refine/refine_bound.c -- keeping the subsegment and subfacet tables
 * (refine/bd.h) in step with the mesh after a boundary split: finding the
 * new pieces among the new tetrahedra and marking them, the encroachment
 * tests that queue them (with the small-angle safety net's "incident"
 * rule), the 2D cavity that re-triangulates a facet around the new vertex,
 * attaching pieces to the mesh and repairing flipped diagonals, and the
 * point that splits a subsegment. ref_queue_boundary runs the same
 * attach-and-queue on every piece of the initial mesh.
 */
#include "config.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "base/hmap.h"
#include "base/pdr_util.h"
#include "geom/pred.h"
#include "plc/fm.h"
#include "refine/refine_int.h"
#include "base/v3.h"

#define X(m, v) ((m)->xyz + 3 * (size_t)(v))

/* --------------------------------------------- finding new features */

/* Sets the subsegment bit of edge (v, x) in every new tetrahedron around
 * it (they all contain v, so they are all new). Returns 1 if the edge
 * exists. */
static int mark_new_subseg(ref_mesher *r, uint32_t x)
{
    tm_mesh *m = &r->m;
    const dt_cavity *c = &r->cav;
    int found = 0;
    for (size_t i = 0; i < c->nnew; i++) {
        uint32_t n = c->newtets[i];
        const uint32_t *tv = m->tets[n].v;
        int s = tv[0] == x ? 0 : tv[1] == x ? 1 : tv[2] == x ? 2 : -1;
        if (s < 0)
            continue;
        m->flags[n] |= TM_F_SUBSEG(tm_edge_of[s][3]);
        found = 1;
    }
    return found;
}

/* Finds face (v, x, y) among the new tetrahedra: *t and *k (face number)
 * when found (returns 1). */
static int find_new_face(const ref_mesher *r, uint32_t x, uint32_t y, uint32_t *t, int *k)
{
    const tm_mesh *m = &r->m;
    const dt_cavity *c = &r->cav;
    for (size_t i = 0; i < c->nnew; i++) {
        uint32_t n = c->newtets[i];
        const uint32_t *tv = m->tets[n].v;
        int sx = tv[0] == x ? 0 : tv[1] == x ? 1 : tv[2] == x ? 2 : -1;
        if (sx < 0)
            continue;
        int sy = tv[0] == y ? 0 : tv[1] == y ? 1 : tv[2] == y ? 2 : -1;
        if (sy < 0)
            continue;
        *t = n;
        *k = 3 - sx - sy;
        return 1;
    }
    return 0;
}

static int incident(const ref_mesher *r, uint32_t w, uint32_t seg, uint32_t facet);

struct enc_arg {
    const ref_mesher *r;
    uint32_t a, b, seg;
    const double *pa, *pb;
    uint32_t found;
};

static int seg_apex(const tm_mesh *m, uint32_t t, void *arg)
{
    struct enc_arg *e = arg;
    const uint32_t *v = m->tets[t].v;
    for (int s = 0; s < 4; s++) {
        uint32_t w = v[s];
        if (w == TM_VINF || w == e->a || w == e->b)
            continue;
        if (ref__in_diametral(e->pa, e->pb, X(m, w)) && !incident(e->r, w, e->seg, BD_NONE)) {
            e->found = w;
            return 1;
        }
    }
    return 0;
}

/* A vertex of the tetrahedra around subsegment ab (of input segment seg)
 * that encroaches it, other than one on a feature meeting seg, or
 * TM_NONE. */
static uint32_t subseg_encroacher(const ref_mesher *r, uint32_t t, uint32_t a, uint32_t b,
                                  uint32_t seg)
{
    const tm_mesh *m = &r->m;
    struct enc_arg e = {r, a, b, seg, X(m, a), X(m, b), TM_NONE};
    ref_around_edge(m, t, a, b, seg_apex, &e);
    return e.found;
}

/* 1 if vertex v lies on facet f by construction (on it, on one of its
 * segments, or one of its corners): such a vertex never encroaches f's
 * subfacets, the facet triangulation accounts for it. */
int ref__on_facet(const ref_mesher *r, uint32_t v, uint32_t f)
{
    const plc *p = r->p;
    uint32_t x = r->bd.vfeat[v];
    switch (r->bd.vkind[v]) {
    case BD_V_FACET:
        return x == f;
    case BD_V_SEGMENT:
        for (size_t i = p->seg_fstart[x]; i < p->seg_fstart[x + 1]; i++)
            if (p->seg_facets[i] == f)
                return 1;
        return 0;
    case BD_V_INPUT:
        for (size_t i = p->v_fstart[x]; i < p->v_fstart[x + 1]; i++)
            if (p->v_facets[i] == f)
                return 1;
        return 0;
    default:
        return 0;
    }
}

static int facet_has_vertex(const plc *p, uint32_t f, uint32_t v)
{
    for (size_t i = p->v_fstart[v]; i < p->v_fstart[v + 1]; i++)
        if (p->v_facets[i] == f)
            return 1;
    return 0;
}

/* 1 if vertex w lies on an input feature that meets the feature of a
 * piece (segment seg when facet is BD_NONE, else facet 'facet'), without
 * one containing the other. */
static int meets(const ref_mesher *r, uint32_t w, uint32_t seg, uint32_t facet)
{
    const plc *p = r->p;
    uint32_t x = r->bd.vfeat[w];
    switch (r->bd.vkind[w]) {
    case BD_V_SEGMENT: {
        const uint32_t *e = p->segs[x].v;
        if (facet == BD_NONE) {
            const uint32_t *s = p->segs[seg].v;
            return x != seg && (e[0] == s[0] || e[0] == s[1] || e[1] == s[0] || e[1] == s[1]);
        }
        return facet_has_vertex(p, facet, e[0]) || facet_has_vertex(p, facet, e[1]);
    }
    case BD_V_FACET: {
        if (facet == BD_NONE)
            for (size_t i = p->seg_fstart[seg]; i < p->seg_fstart[seg + 1]; i++)
                if (p->seg_facets[i] == x)
                    return 0; /* seg is an edge of w's facet */
        const plc_facet *F = &p->facets[x];
        for (size_t q = F->poly_first; q < F->poly_first + F->npoly; q++) {
            const plc_polygon *P = &p->polys[q];
            for (uint32_t i = 0; i < P->n; i++) {
                uint32_t c = p->corners[P->first + i];
                if (facet == BD_NONE ? (c == p->segs[seg].v[0] || c == p->segs[seg].v[1])
                                     : facet_has_vertex(p, facet, c))
                    return 1;
            }
        }
        return 0;
    }
    default:
        return 0;
    }
}

/* 1 if point w projects orthogonally into the interior of facet f (or of
 * segment seg when f is BD_NONE), with a relative margin. */
static int projects_inside(const ref_mesher *r, const double *w, uint32_t seg, uint32_t f)
{
    const plc *p = r->p;
    if (f == BD_NONE) {
        const double *a = p->xyz[p->segs[seg].v[0]], *b = p->xyz[p->segs[seg].v[1]];
        double ab[3], aw[3];
        v3_sub(b, a, ab);
        v3_sub(w, a, aw);
        double t = v3_dot(aw, ab) / v3_dot(ab, ab);
        return t > 1e-9 && t < 1 - 1e-9;
    }
    const plc_facet *F = &p->facets[f];
    double h = v3_dot(F->normal, w) - F->offset, q[3];
    for (int k = 0; k < 3; k++)
        q[k] = w[k] - h * F->normal[k];
    int i = (F->axis + 1) % 3, j = (F->axis + 2) % 3;
    for (size_t t = p->ftri_start[f]; t < p->ftri_start[f + 1]; t++) {
        const double *a = p->xyz[p->ftri[t][0]], *b = p->xyz[p->ftri[t][1]],
                     *c = p->xyz[p->ftri[t][2]];
        double d = (b[i] - a[i]) * (c[j] - a[j]) - (b[j] - a[j]) * (c[i] - a[i]);
        if (d == 0)
            continue;
        double l1 = ((q[i] - a[i]) * (c[j] - a[j]) - (q[j] - a[j]) * (c[i] - a[i])) / d;
        double l2 = ((b[i] - a[i]) * (q[j] - a[j]) - (b[j] - a[j]) * (q[i] - a[i])) / d;
        if (l1 > 1e-9 && l2 > 1e-9 && 1 - l1 - l2 > 1e-9)
            return 1;
    }
    return 0;
}

/* 1 if vertex w lies on an input feature that meets the feature of a
 * piece (segment seg when facet is BD_NONE, else facet 'facet') at an
 * acute angle: the two meet, and w's orthogonal projection onto the piece's
 * feature falls inside it. That is Shewchuk's projection condition, broken
 * locally. There encroachment is not split eagerly: the two features would
 * split each other down to where they meet (the tee's 60-degree edges
 * did); the bad tetrahedra there ask for the splits they need, under the
 * insertion-radius floor of split_tet (refine_run.c). Where features meet
 * at 90 degrees or more (a cube's edges, the creases of a curved surface
 * made of flat facets) the projection falls outside, and encroachment is
 * split as usual. */
static int incident(const ref_mesher *r, uint32_t w, uint32_t seg, uint32_t facet)
{
    return meets(r, w, seg, facet) && projects_inside(r, X(&r->m, w), seg, facet);
}

/* The apex of face k of t or of the tetrahedron across it that encroaches
 * that face (a subfacet of facet f), or TM_NONE. */
static uint32_t subfac_encroacher(const ref_mesher *r, uint32_t t, int k, uint32_t f)
{
    const tm_mesh *m = &r->m;
    const tm_tet *T = &m->tets[t];
    const double *a = X(m, T->v[tm_face_vtx[k][0]]), *b = X(m, T->v[tm_face_vtx[k][1]]),
                 *c = X(m, T->v[tm_face_vtx[k][2]]);
    uint32_t w = T->v[k];
    if (w != TM_VINF && !ref__on_facet(r, w, f) && !incident(r, w, BD_NONE, f) &&
        ref__in_equatorial(a, b, c, X(m, w)))
        return w;
    tm_link l = T->n[k];
    if (tm_is_special(l))
        return TM_NONE;
    w = m->tets[tm_ltet(l)].v[tm_lface(l)];
    if (w != TM_VINF && !ref__on_facet(r, w, f) && !incident(r, w, BD_NONE, f) &&
        ref__in_equatorial(a, b, c, X(m, w)))
        return w;
    return TM_NONE;
}

static double subseg_len2(const ref_mesher *r, uint32_t id)
{
    const bd_subseg *s = &r->bd.segs[id];
    return v3_dist2(X(&r->m, s->v[0]), X(&r->m, s->v[1]));
}

static double subfac_rad2(const ref_mesher *r, uint32_t id)
{
    const bd_subfac *s = &r->bd.facs[id];
    double cc[3], r2;
    if (ref__tri_circumcentre(X(&r->m, s->v[0]), X(&r->m, s->v[1]), X(&r->m, s->v[2]), cc, &r2))
        return 0.0;
    return r2;
}

/* The constrained mode splits a piece where it is missing, where a bad
 * tetrahedron's circumcentre encroaches it (split_tet in refine_run.c) or
 * where a face next to it cannot be flipped to local Delaunayness, never
 * eagerly because some vertex encroaches it: a CDT exists without that
 * (its pieces are constraints, and one left encroached stays), and eager
 * splits are what made tessellated surfaces cascade: neighbouring facets
 * meet at nearly 180 degrees and encroach each other everywhere (the
 * torus-0.15 of the corpus: 21,572 tetrahedra eagerly, 2,035 lazily; the
 * thin slab: 325,629 against 22,841, TetGen 128,599). */
static int skip_encroachment(const ref_mesher *r)
{
    return r->o.constrained;
}

int ref__needle_seg(const ref_mesher *r, uint32_t seg)
{
    const plc *p = r->p;
    const uint32_t *e = p->segs[seg].v;
    return p->v_minang && (p->v_minang[e[0]] < FM_NEEDLE_ANG || p->v_minang[e[1]] < FM_NEEDLE_ANG);
}

int ref__needle_facet(const ref_mesher *r, uint32_t f)
{
    return r->fac_needle && r->fac_needle[f];
}

/* After a subsegment became present in tetrahedron t: queue it if a
 * vertex encroaches it or it is too long. */
static int check_subseg(ref_mesher *r, uint32_t id, uint32_t t)
{
    const bd_subseg *s = &r->bd.segs[id];
    if (r->o.seg_maxlen > 0 && subseg_len2(r, id) >= r->o.seg_maxlen * r->o.seg_maxlen)
        return ref__queue_seg(r, id, 0.0f);
    if (skip_encroachment(r))
        return 0;
    uint32_t w = subseg_encroacher(r, t, s->v[0], s->v[1], s->seg);
    if (w != TM_NONE)
        return ref__queue_seg(r, id, (float)(r->o.rho * r->bd.vrins[w]));
    return 0;
}

static int check_subfac(ref_mesher *r, uint32_t id, uint32_t t, int k)
{
    if (r->o.fac_maxrad > 0 && subfac_rad2(r, id) >= r->o.fac_maxrad * r->o.fac_maxrad)
        return ref__queue_fac(r, id, 0.0f);
    if (skip_encroachment(r))
        return 0;
    uint32_t w = subfac_encroacher(r, t, k, r->bd.facs[id].facet);
    if (w != TM_NONE)
        return ref__queue_fac(r, id, (float)(r->o.rho * r->bd.vrins[w]));
    return 0;
}

/* --------------------------------------------------------- 2D cavity */

/* Whether live subfacet u of the facet triangulation belongs to the 2D
 * cavity of p. A present subfacet does iff the 3D cavity deletes it (both
 * its tetrahedra conflict with p): for p in its plane that is exactly "p in
 * its circumcircle", and deciding it from the 3D cavity keeps D and T
 * consistent on cocircular points. A missing one is tested directly with
 * the perturbed in-circle test that agrees with the 3D predicates. */
static int in_cavity2d(const ref_mesher *r, uint32_t u, const double *p)
{
    const bd_subfac *U = &r->bd.facs[u];
    /* In the constrained mode the 2D cavity comes first and says which
     * subfacets the 3D search may cross (refine_cdt.c). */
    if (!(U->flags & BD_F_MISSING) && !r->o.constrained) {
        for (size_t k = 0; k < r->marks.n; k++) {
            const ref_mark *mk = &r->marks.m[k];
            if (mk->nv != 3 || !mk->deleted || (uint32_t)mk->facet != U->facet)
                continue;
            int hit = 0;
            for (int i = 0; i < 3; i++)
                hit += mk->v[i] == U->v[0] || mk->v[i] == U->v[1] || mk->v[i] == U->v[2];
            if (hit == 3)
                return 1;
        }
        return 0;
    }
    const tm_mesh *m = &r->m;
    return pred_incircle3d_sos(X(m, U->v[0]), X(m, U->v[1]), X(m, U->v[2]), p) > 0;
}

int ref__list_add(ref_mesher *r, uint32_t s)
{
    if (pdr_grow((void **)&r->list, &r->cap_list, r->nlist + 1, sizeof *r->list))
        return PDR_ENOMEM;
    r->list[r->nlist++] = s;
    r->bd.facs[s].flags |= BD_F_VISIT;
    return 0;
}

void ref__list_clear(ref_mesher *r)
{
    for (size_t i = 0; i < r->nlist; i++)
        r->bd.facs[r->list[i]].flags &= (uint16_t)~BD_F_VISIT;
    r->nlist = 0;
    r->nbedge = 0;
}

static int is_split_edge(uint32_t x, uint32_t y, uint32_t sa, uint32_t sb)
{
    return (x == sa && y == sb) || (x == sb && y == sa);
}

int ref__cavity2d_rim(const ref_mesher *r, uint32_t id, int k, uint32_t sa, uint32_t sb,
                      uint32_t *x, uint32_t *y, int *seg, uint32_t *u)
{
    const bd_set *bd = &r->bd;
    const bd_subfac *T = &bd->facs[id];
    *x = T->v[(k + 1) % 3];
    *y = T->v[(k + 2) % 3];
    if (is_split_edge(*x, *y, sa, sb))
        return 0;
    *seg = bd_find_subseg(bd, *x, *y) != BD_NONE;
    *u = *seg ? BD_NONE : bd_subfac_across(bd, id, k);
    return *u == BD_NONE || !(bd->facs[*u].flags & BD_F_VISIT);
}

int ref__add_bedge(ref_mesher *r, uint32_t x, uint32_t y, uint32_t id)
{
    if (pdr_grow((void **)&r->bedge, &r->cap_bedge, r->nbedge + 1, sizeof *r->bedge))
        return PDR_ENOMEM;
    uint32_t *e = r->bedge[r->nbedge++];
    e[0] = x;
    e[1] = y;
    e[2] = r->bd.facs[id].facet;
    e[3] = id;
    return 0;
}

/* Grows the 2D cavity of p from the subfacets in r->list (the roots) over
 * neighbours in the same facet, never across a subsegment (the facet
 * triangulations are constrained by them), and collects its boundary
 * edges, skipping the subsegment sa-sb being split. Returns 0 when every
 * boundary edge sees p on its inner side (the fan from p is a valid
 * triangulation), 1 when p lies beyond a boundary subsegment (*ea, *eb: p
 * encroaches it), PDR_ENOMEM, or 2 if no star-shaped cavity was found. */
int ref__grow_cavity2d(ref_mesher *r, const double *p, uint32_t sa, uint32_t sb, uint32_t *ea,
                       uint32_t *eb)
{
    const tm_mesh *m = &r->m;
    bd_set *bd = &r->bd;
    size_t scan = 0;
    r->forced = 0;
    for (int round = 0; round < 64; round++) {
        for (; scan < r->nlist; scan++) {
            uint32_t t = r->list[scan];
            for (int k = 0; k < 3; k++) {
                const bd_subfac *T = &bd->facs[t];
                uint32_t x = T->v[(k + 1) % 3], y = T->v[(k + 2) % 3];
                if (is_split_edge(x, y, sa, sb) || bd_find_subseg(bd, x, y) != BD_NONE)
                    continue;
                uint32_t u = bd_subfac_across(bd, t, k);
                if (u == BD_NONE || (bd->facs[u].flags & BD_F_VISIT))
                    continue;
                if (in_cavity2d(r, u, p) && ref__list_add(r, u))
                    return PDR_ENOMEM;
            }
        }
        /* boundary edges and the star test */
        r->nbedge = 0;
        int grew = 0;
        for (size_t i = 0; i < r->nlist; i++) {
            uint32_t t = r->list[i];
            for (int k = 0; k < 3; k++) {
                uint32_t x, y, u;
                int seg;
                if (!ref__cavity2d_rim(r, t, k, sa, sb, &x, &y, &seg, &u))
                    continue;
                if (ref__orient_facet(r->p, bd->facs[t].facet, X(m, x), X(m, y), p) <= 0) {
                    if (seg || u == BD_NONE) {
                        *ea = x;
                        *eb = y;
                        return 1;
                    }
                    if (ref__list_add(r, u))
                        return PDR_ENOMEM;
                    r->forced = 1;
                    grew = 1;
                    continue;
                }
                if (ref__add_bedge(r, x, y, t))
                    return PDR_ENOMEM;
            }
        }
        if (!grew)
            return 0;
    }
    return 2;
}

struct edge_root {
    ref_mesher *r;
    int rc;
};

static int edge_root(void *arg, uint32_t s)
{
    struct edge_root *a = arg;
    if (!(a->r->bd.facs[s].flags & BD_F_VISIT) && ref__list_add(a->r, s)) {
        a->rc = PDR_ENOMEM;
        return 1;
    }
    return 0;
}

int ref__cavity2d_edge(ref_mesher *r, const double *p, uint32_t sa, uint32_t sb)
{
    ref__list_clear(r);
    struct edge_root er = {r, 0};
    bd_subfacs_on_edge(&r->bd, sa, sb, edge_root, &er);
    if (er.rc)
        return er.rc;
    const bd_set *bd = &r->bd;
    for (size_t i = 0; i < r->nlist; i++) {
        uint32_t t = r->list[i];
        for (int k = 0; k < 3; k++) {
            const bd_subfac *T = &bd->facs[t];
            uint32_t x = T->v[(k + 1) % 3], y = T->v[(k + 2) % 3];
            if (is_split_edge(x, y, sa, sb))
                continue;
            if (ref__orient_facet(r->p, T->facet, X(&r->m, x), X(&r->m, y), p) <= 0)
                return 1; /* the rounded point falls on or beyond this edge */
            if (ref__add_bedge(r, x, y, t))
                return PDR_ENOMEM;
        }
    }
    return 0;
}

/* ------------------------------------------------ boundary updates */

/* Stars up to this many tetrahedra are searched with a small open-
 * addressed set on the stack (find_in_star_of: STAR_SLOTS slots, at most
 * half full), larger ones with a hash set. */
#define STAR_SCAN_MAX 64
#define STAR_SLOTS 128

/* Inserts u into the small set; returns 1 if it was there already. */
static int star_seen(uint32_t *slots, uint32_t u)
{
    uint32_t i = (u * 2654435761u) >> 25; /* 7 bits: STAR_SLOTS */
    while (slots[i] != TM_NONE) {
        if (slots[i] == u)
            return 1;
        i = (i + 1) & (STAR_SLOTS - 1);
    }
    slots[i] = u;
    return 0;
}

/* The general search for a face of the mesh: tetrahedra around vertex a
 * (a breadth-first walk over the faces containing a) until one has b and
 * c too (c == TM_NONE: edge ab). Slow, used where no cavity tells where
 * to look (the initial mesh, rare repairs). Returns 1 when found (*tout
 * set), 0 when not found in a star the walk saw cut (a neighbour across
 * a face containing a is special: an interface face on one PE of the
 * parallel refinement), and -1 when not found in a star the walk closed:
 * the link of a vertex of a tetrahedralization is one sphere, so a closed
 * walk has seen every tetrahedron at a and the face is not in the mesh. */
static int find_in_star_of(const tm_mesh *m, uint32_t a, uint32_t b, uint32_t c, uint32_t d,
                           uint32_t *tout)
{
    uint32_t start = ref__vertex_tet(m, a);
    if (start == TM_NONE)
        return 0;
    uint32_t stackbuf[256], *stack = stackbuf;
    size_t n = 0, cap = 256, head = 0;
    int found = 0, hashed = 0, oom = 0, cut = 0;
    hmap visited = {0};
    uint32_t slots[STAR_SLOTS];
    memset(slots, 0xff, sizeof slots); /* every slot TM_NONE */
    stack[n++] = start;
    star_seen(slots, start);
    while (head < n && !found) {
        uint32_t t = stack[head++];
        const tm_tet *T = &m->tets[t];
        int sa = ref__slot_in(T, a);
        if (ref__slot_in(T, b) >= 0 && (c == TM_NONE || ref__slot_in(T, c) >= 0) &&
            (d == TM_NONE || ref__slot_in(T, d) >= 0)) {
            *tout = t;
            found = 1;
            break;
        }
        for (int k = 0; k < 4; k++) {
            if (k == sa)
                continue;
            if (tm_is_special(T->n[k])) {
                cut = 1;
                continue;
            }
            uint32_t u = tm_ltet(T->n[k]);
            /* Seen already? The small set while the star is small, a
             * hash set once it is not (a vertex where splits cascaded can
             * have thousands of tetrahedra). */
            int seen = 0;
            if (n < STAR_SCAN_MAX) {
                seen = star_seen(slots, u);
            } else {
                if (!hashed) {
                    for (size_t i = 0; i < n && !oom; i++)
                        oom = hmap_put(&visited, stack[i], 1) != 0;
                    hashed = 1;
                }
                seen = hmap_get(&visited, u) != HMAP_NONE;
            }
            if (seen)
                continue;
            if (hashed && !oom)
                oom = hmap_put(&visited, u, 1) != 0;
            if (oom)
                break;
            if (n == cap) {
                uint32_t *ns = pr_malloc(2 * cap * sizeof *ns);
                if (!ns) {
                    oom = 1;
                    break;
                }
                memcpy(ns, stack, n * sizeof *ns);
                if (stack != stackbuf)
                    pr_free(stack);
                stack = ns;
                cap *= 2;
            }
            stack[n++] = u;
        }
    }
    if (stack != stackbuf)
        pr_free(stack);
    hmap_free(&visited);
    if (found)
        return 1;
    /* An early stop (out of memory) saw only part of the star. */
    return cut || oom || head < n ? 0 : -1;
}

/* find_in_star_of from a, then from the other vertices: on one PE of the
 * parallel refinement the star of a vertex may be cut by interface faces
 * into pieces the walk cannot join, while the star of a vertex inserted
 * here is whole; alone, the first walk decides and the others run only
 * for a face that is not there. A walk that closed the star decides too:
 * the face is not there (shape.stl's recovery asks for 13,000 absent
 * faces, and walking three more stars for each was a sixth of its time). */
static int find_in_star4(const tm_mesh *m, uint32_t a, uint32_t b, uint32_t c, uint32_t d,
                         uint32_t *tout)
{
    const uint32_t v[4] = {a, b, c, d};
    for (int k = 0; k < 4; k++) {
        if (v[k] == TM_NONE || v[k] == TM_VINF)
            continue;
        uint32_t o[3], n = 0;
        for (int j = 0; j < 4; j++)
            if (j != k)
                o[n++] = v[j];
        int r = find_in_star_of(m, v[k], o[0], o[1], o[2], tout);
        if (r != 0)
            return r > 0;
    }
    return 0;
}

int ref__find_in_star(const tm_mesh *m, uint32_t a, uint32_t b, uint32_t c, uint32_t *tout)
{
    return find_in_star4(m, a, b, c, TM_NONE, tout);
}

int ref_find_local(const ref_mesher *r, uint32_t a, uint32_t b, uint32_t c, uint32_t *t)
{
    return find_in_star4(&r->m, a, b, c, TM_NONE, t);
}

static int set_subseg_bit(const tm_mesh *m, uint32_t t, void *arg)
{
    const uint32_t *ab = arg;
    const tm_tet *T = &m->tets[t];
    int sa = ref__slot_in(T, ab[0]), sb = ref__slot_in(T, ab[1]);
    ((tm_mesh *)m)->flags[t] |= TM_F_SUBSEG(tm_edge_of[sa][sb]);
    return 0;
}

int ref__mark_subseg(ref_mesher *r, uint32_t id, uint32_t *t)
{
    bd_subseg *s = &r->bd.segs[id];
    if (!ref__find_in_star(&r->m, s->v[0], s->v[1], TM_NONE, t)) {
        s->flags |= BD_F_MISSING;
        return 0;
    }
    s->flags &= (uint16_t)~BD_F_MISSING;
    uint32_t ab[2] = {s->v[0], s->v[1]};
    ref_around_edge(&r->m, *t, ab[0], ab[1], set_subseg_bit, ab);
    return 1;
}

/* Marks existing subsegment id in the mesh if its edge exists; else flags
 * it missing. Returns 1 if present, 0 if missing, <0 on error. */
static int attach_subseg(ref_mesher *r, uint32_t id)
{
    uint32_t t;
    if (!ref__mark_subseg(r, id, &t))
        return 0;
    int rc = check_subseg(r, id, t);
    return rc < 0 ? rc : 1;
}

static int attach_subfac(ref_mesher *r, uint32_t id)
{
    bd_subfac *s = &r->bd.facs[id];
    uint32_t t;
    if (!ref__find_in_star(&r->m, s->v[0], s->v[1], s->v[2], &t)) {
        s->flags |= BD_F_MISSING;
        return 0;
    }
    s->flags &= (uint16_t)~BD_F_MISSING;
    const tm_tet *T = &r->m.tets[t];
    int k = 6 - ref__slot_in(T, s->v[0]) - ref__slot_in(T, s->v[1]) - ref__slot_in(T, s->v[2]);
    int rc = tm_mark_face(&r->m, t, k, (int32_t)s->facet + 1);
    if (!rc)
        rc = check_subfac(r, id, t, k);
    return rc < 0 ? rc : 1;
}

/* Matches the facet triangulation to the mesh where the two differ by the
 * diagonal of a (nearly) cocircular quadrilateral. On facets that are not
 * axis-aligned the vertices are off the plane by rounding errors, and the
 * mesh, deciding with exact predicates, may take the other diagonal of a
 * quadrilateral whose corners are cocircular up to those errors. Shewchuk:
 * "an implementation must detect these cases and correct the triangulation
 * so that it matches the tetrahedralization". A missing subfacet whose
 * neighbour across an edge, flipped to the other diagonal, gives two faces
 * of the mesh is replaced by them; subfacets still missing afterwards are
 * queued for splitting. ids (n entries) is scratch owned by the caller. */
static int repair_and_queue(ref_mesher *r, uint32_t *ids, size_t n)
{
    bd_set *bd = &r->bd;
    tm_mesh *m = &r->m;
    int changed = 1, rc = 0;
    for (int round = 0; changed && round < 8 && !rc; round++) {
        changed = 0;
        for (size_t i = 0; i < n && !rc; i++) {
            uint32_t t = ids[i];
            if (t == BD_NONE)
                continue;
            bd_subfac T = bd->facs[t];
            if ((T.flags & BD_F_DEAD) || !(T.flags & BD_F_MISSING)) {
                ids[i] = BD_NONE;
                continue;
            }
            for (int k = 0; k < 3; k++) {
                uint32_t a = T.v[(k + 1) % 3], b = T.v[(k + 2) % 3], c = T.v[k];
                if (bd_find_subseg(bd, a, b) != BD_NONE)
                    continue;
                uint32_t u = bd_subfac_across(bd, t, k);
                if (u == BD_NONE)
                    continue;
                bd_subfac U = bd->facs[u];
                uint32_t w = U.v[0] != a && U.v[0] != b ? U.v[0] : U.v[1] != a && U.v[1] != b ? U.v[1] : U.v[2];
                uint32_t f = T.facet, t1, t2;
                if (ref__orient_facet(r->p, f, X(m, a), X(m, w), X(m, c)) <= 0 ||
                    ref__orient_facet(r->p, f, X(m, w), X(m, b), X(m, c)) <= 0 ||
                    !ref__find_in_star(m, a, w, c, &t1) || !ref__find_in_star(m, w, b, c, &t2))
                    continue;
                if (!(U.flags & BD_F_MISSING) &&
                    ref__find_in_star(m, U.v[0], U.v[1], U.v[2], &t1)) {
                    const tm_tet *Q = &m->tets[t1];
                    int q = 6 - ref__slot_in(Q, U.v[0]) - ref__slot_in(Q, U.v[1]) -
                            ref__slot_in(Q, U.v[2]);
                    tm_mark_face(m, t1, q, 0); /* clearing: cannot fail */
                }
                bd_kill_subfac(bd, t);
                bd_kill_subfac(bd, u);
                uint32_t n1, n2;
                rc = bd_add_subfac(bd, a, w, c, f, &n1);
                if (!rc)
                    rc = bd_add_subfac(bd, w, b, c, f, &n2);
                if (!rc && (rc = attach_subfac(r, n1)) > 0)
                    rc = attach_subfac(r, n2);
                if (rc > 0)
                    rc = 0;
                ids[i] = BD_NONE;
                changed = 1;
                r->flips++;
                if (r->classified)
                    r->region_doubts++;
                break;
            }
        }
    }
    for (size_t i = 0; i < n && !rc; i++) {
        uint32_t t = ids[i];
        if (t != BD_NONE && !(bd->facs[t].flags & BD_F_DEAD) &&
            (bd->facs[t].flags & BD_F_MISSING))
            rc = ref__queue_fac(r, t, 0.0f);
    }
    return rc;
}

/* Gives tetrahedron dst the region (and exterior flag) of src. */
static void copy_region(ref_mesher *r, uint32_t dst, uint32_t src)
{
    tm_mesh *m = &r->m;
    if ((m->flags[src] & REF_F_EXTERIOR) || tm_is_ghost(m, src))
        m->flags[dst] |= REF_F_EXTERIOR;
    else
        m->flags[dst] &= (uint16_t)~REF_F_EXTERIOR;
    if (r->region)
        r->region[dst] = r->region[src];
}

/* Regions of the new tetrahedra of a boundary insertion, once their
 * subfacets are marked. commit_point (refine_run.c) gave each the region
 * of the cavity tetrahedron it was built on: both lie on the same side of
 * that face, next to it, which is the right region wherever "the same side
 * of a face" means "the same side of the facet". A tetrahedron lying flat
 * on a facet that is not axis-aligned (four vertices cocircular up to
 * rounding) has no such side: it takes the region of a neighbour across an
 * unmarked face, to which it is joined without crossing a facet. (Spreading
 * regions across unmarked faces in general would be wrong while a subfacet
 * is missing: the faces where it should be are not marked yet.) */
static int reclassify_new(ref_mesher *r)
{
    tm_mesh *m = &r->m;
    const dt_cavity *c = &r->cav;
    for (size_t i = 0; i < c->nnew; i++) {
        uint32_t n = c->newtets[i];
        if (tm_is_ghost(m, n) || !ref__flat_on_facet(r, m->tets[n].v))
            continue;
        r->region_doubts++;
        for (int k = 0; k < 4; k++) {
            tm_link l = m->tets[n].n[k];
            if ((m->flags[n] & TM_F_FACEMARK(k)) || tm_is_special(l))
                continue;
            copy_region(r, n, tm_ltet(l));
            break;
        }
    }
    return 0;
}

/* After committing vertex v for a boundary split: replaces the 2D cavity
 * (r->list) by the fan of v over its boundary edges (r->bedge), replaces
 * subsegment split_id (if not BD_NONE) by its two halves, attaches the new
 * pieces to the mesh, and queues what the insertion made missing or
 * encroached. */
int ref__update_boundary(ref_mesher *r, uint32_t v, uint32_t split_id)
{
    tm_mesh *m = &r->m;
    bd_set *bd = &r->bd;
    int rc = 0;
    float rv = bd->vrins[v];
    /* Subfacets the 2D cavity took although the 3D cavity kept their
     * face (only when the star test forced them in): unmark the face. */
    if (r->forced)
        for (size_t i = 0; i < r->nlist; i++) {
            const bd_subfac *s = &bd->facs[r->list[i]];
            uint32_t t;
            if (!(s->flags & BD_F_MISSING) && ref__find_in_star(m, s->v[0], s->v[1], s->v[2], &t)) {
                const tm_tet *T = &m->tets[t];
                int k = 6 - ref__slot_in(T, s->v[0]) - ref__slot_in(T, s->v[1]) -
                        ref__slot_in(T, s->v[2]);
                tm_mark_face(m, t, k, 0); /* clearing: cannot fail */
            }
        }
    for (size_t i = 0; i < r->nlist; i++)
        bd_kill_subfac(bd, r->list[i]);
    r->nlist = 0;
    if (split_id != BD_NONE) {
        bd_subseg s = bd->segs[split_id];
        bd_kill_subseg(bd, split_id);
        for (int h = 0; h < 2 && !rc; h++) {
            uint32_t id;
            rc = bd_add_subseg(bd, s.v[h], v, s.seg, &id);
            if (rc)
                break;
            if (mark_new_subseg(r, s.v[h])) {
                uint32_t t = TM_NONE; /* a new tetrahedron with the edge */
                for (size_t i = 0; i < r->cav.nnew && t == TM_NONE; i++)
                    if (ref__slot_in(&m->tets[r->cav.newtets[i]], s.v[h]) >= 0)
                        t = r->cav.newtets[i];
                rc = check_subseg(r, id, t);
            } else {
                bd->segs[id].flags |= BD_F_MISSING;
                rc = ref__queue_seg(r, id, 0.0f);
            }
        }
    }
    for (size_t i = 0; i < r->nbedge && !rc; i++) {
        const uint32_t *e = r->bedge[i];
        uint32_t id;
        rc = bd_add_subfac(bd, e[0], e[1], v, e[2], &id);
        if (rc)
            break;
        uint32_t t;
        int k;
        if (find_new_face(r, e[0], e[1], &t, &k)) {
            rc = tm_mark_face(m, t, k, (int32_t)e[2] + 1);
            if (!rc)
                rc = check_subfac(r, id, t, k);
        } else {
            bd->facs[id].flags |= BD_F_MISSING;
            rc = pdr_grow((void **)&r->miss, &r->cap_miss, r->nmiss + 1, sizeof *r->miss);
            if (!rc)
                r->miss[r->nmiss++] = id;
        }
    }
    r->nbedge = 0;
    if (!rc && r->nmiss)
        rc = repair_and_queue(r, r->miss, r->nmiss);
    r->nmiss = 0;
    /* Pieces the cavity deleted are missing now; pieces it touched that
     * v encroaches are queued. */
    for (size_t k = 0; k < r->marks.n && !rc; k++) {
        const ref_mark *mk = &r->marks.m[k];
        if (!mk->deleted && (!mk->encroached || skip_encroachment(r)))
            continue;
        if (mk->nv == 2) {
            uint32_t id = bd_find_subseg(bd, mk->v[0], mk->v[1]);
            if (id == BD_NONE)
                continue;
            if (mk->deleted) {
                bd->segs[id].flags |= BD_F_MISSING;
                rc = ref__queue_seg(r, id, 0.0f);
            } else if (!incident(r, v, bd->segs[id].seg, BD_NONE)) {
                rc = ref__queue_seg(r, id, (float)(r->o.rho * rv));
            }
        } else {
            uint32_t id = bd_find_subfac(bd, mk->v[0], mk->v[1], mk->v[2]);
            if (id == BD_NONE)
                continue;
            if (mk->deleted) {
                bd->facs[id].flags |= BD_F_MISSING;
                rc = ref__queue_fac(r, id, 0.0f);
            } else if (!ref__on_facet(r, v, (uint32_t)mk->facet) &&
                       !incident(r, v, BD_NONE, (uint32_t)mk->facet)) {
                rc = ref__queue_fac(r, id, (float)(r->o.rho * rv));
            }
        }
    }
    if (!rc && r->classified)
        rc = reclassify_new(r);
    return rc;
}

int ref_queue_boundary(ref_mesher *r)
{
    bd_set *bd = &r->bd;
    for (uint32_t i = 0; i < bd->nsegs; i++) {
        if (bd->segs[i].flags & BD_F_DEAD)
            continue;
        int rc = attach_subseg(r, i);
        if (rc < 0)
            return rc;
        if (rc == 0 && (rc = ref__queue_seg(r, i, 0.0f)))
            return rc;
    }
    r->nmiss = 0;
    for (uint32_t i = 0; i < bd->nfacs; i++) {
        if (bd->facs[i].flags & BD_F_DEAD)
            continue;
        int rc = attach_subfac(r, i);
        if (rc < 0)
            return rc;
        if (rc == 0) {
            if (pdr_grow((void **)&r->miss, &r->cap_miss, r->nmiss + 1, sizeof *r->miss))
                return PDR_ENOMEM;
            r->miss[r->nmiss++] = i;
        }
    }
    int rc = repair_and_queue(r, r->miss, r->nmiss);
    r->nmiss = 0;
    return rc;
}

/* ------------------------------------------- subsegment split points */

/* The point splitting subsegment ab: its midpoint, or, when exactly one
 * end is an input vertex where segments meet at an acute angle, the point
 * at a power-of-two distance from it nearest to the midpoint (Ruppert's
 * concentric shells: splits from both sides of an acute corner then meet
 * on common spheres and do not cascade). */
void ref__split_point(const ref_mesher *r, uint32_t a, uint32_t b, double p[3])
{
    const tm_mesh *m = &r->m;
    const double *pa = X(m, a), *pb = X(m, b);
    int ia = r->bd.vkind[a] == BD_V_INPUT && r->seg_acute && r->seg_acute[r->bd.vfeat[a]];
    int ib = r->bd.vkind[b] == BD_V_INPUT && r->seg_acute && r->seg_acute[r->bd.vfeat[b]];
    if (ia != ib) {
        const double *o = ia ? pa : pb, *e = ia ? pb : pa;
        double len = sqrt(v3_dist2(pa, pb));
        int ex;
        double f = frexp(len / 2.0, &ex); /* len/2 = f 2^ex, f in [0.5, 1) */
        double d = f < M_SQRT1_2 ? ldexp(1.0, ex - 1) : ldexp(1.0, ex);
        double t = d / len;
        if (t > 0.2 && t < 0.8) {
            for (int k = 0; k < 3; k++)
                p[k] = o[k] + t * (e[k] - o[k]);
            return;
        }
    }
    for (int k = 0; k < 3; k++)
        p[k] = 0.5 * (pa[k] + pb[k]);
}
