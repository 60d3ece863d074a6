/*
 * refine/refine_int.h -- shared between the refine*.c files (prefix ref__);
 * not for other modules, which use refine/refine.h.
 *
 * The refinement is one algorithm in five files, cut where the data each
 * part works on changes:
 *
 *   refine.c           the ref_mesher: options, set-up, release
 *   refine_decide.c    one cavity: its marks and the decision (reads no
 *                      ref_mesher, so the parallel search can call it)
 *   refine_bound.c     the subsegment and subfacet tables after a
 *                      boundary split: new pieces, 2D cavity, repairs
 *   refine_run.c       the queues, tetrahedron quality, commit, the splits
 *                      and the insertion loop
 *   refine_classify.c  the whole mesh: regions, consistency, counts,
 *                      quality range, export
 *   refine_offc.c      after the refinement: off-centre points for the
 *                      tetrahedra left above the radius-edge bound
 *
 * Each function below is defined in the file named above its group; the
 * comment at its definition says what it does.
 */
#ifndef PDR_REFINE_INT_H
#define PDR_REFINE_INT_H

#include <stddef.h>
#include <stdint.h>

#include "base/v3.h"
#include "refine/refine.h"

/* ------------------------------------------------ refine_decide.c */

/* Circumcentre and squared circumradius of triangle abc in space; 0, or
 * -1 when degenerate. */
int ref__tri_circumcentre(const double *a, const double *b, const double *c, double cc[3],
                          double *r2);
/* p strictly inside the diametral ball of ab. */
int ref__in_diametral(const double *a, const double *b, const double *p);
/* p strictly inside the equatorial ball of abc and off its plane. */
int ref__in_equatorial(const double *a, const double *b, const double *c, const double *p);
/* Orientation of abc projected on facet f's plane. */
int ref__orient_facet(const plc *pl, uint32_t f, const double *a, const double *b,
                      const double *c);

/* The slot (0..3) of vertex v in tetrahedron T, or -1. */
static inline int ref__slot_in(const tm_tet *T, uint32_t v)
{
    return T->v[0] == v ? 0 : T->v[1] == v ? 1 : T->v[2] == v ? 2 : T->v[3] == v ? 3 : -1;
}

/* A live tetrahedron having vertex v (its hint), or TM_NONE when the hint
 * is stale or none (on one PE, v's tetrahedra may have left). */
static inline uint32_t ref__vertex_tet(const tm_mesh *m, uint32_t v)
{
    uint32_t h = m->vhint[v];
    if (h == TM_NONE || h >= m->nslots || tm_is_dead(m, h) || ref__slot_in(&m->tets[h], v) < 0)
        return TM_NONE;
    return h;
}

/* The shortest edge of tetrahedron t (0..5, as tm_edge_vtx numbers them;
 * the first of equal ones) and its squared length in *l2. */
static inline int ref__shortest_edge(const tm_mesh *m, uint32_t t, double *l2)
{
    const uint32_t *tv = m->tets[t].v;
    const double *xyz = m->xyz;
    int emin = 0;
    double lo = INFINITY;
    for (int e = 0; e < 6; e++) {
        double d2 = v3_dist2(xyz + 3 * (size_t)tv[tm_edge_vtx[e][0]],
                             xyz + 3 * (size_t)tv[tm_edge_vtx[e][1]]);
        if (d2 < lo) {
            lo = d2;
            emin = e;
        }
    }
    *l2 = lo;
    return emin;
}

/* ------------------------------------------------------ refine_run.c */

void ref__queue_free(ref_queue *q);
/* A bd_subfacs_on_edge callback that adds subfacet s to r's 2D cavity
 * (r->list) unless it is flagged BD_F_VISIT; arg is a struct
 * ref_root_arg, whose rc gets PDR_ENOMEM when that fails (the walk then
 * stops). */
struct ref_root_arg {
    ref_mesher *r;
    int rc;
};
int ref__add_root(void *arg, uint32_t s);
/* Queue a subsegment or subfacet for splitting (once: BD_F_QUEUED). */
int ref__queue_seg(ref_mesher *r, uint32_t id, float rmin);
int ref__queue_fac(ref_mesher *r, uint32_t id, float rmin);
/* 1 if all four vertices v lie on one facet by construction. */
int ref__flat_on_facet(const ref_mesher *r, const uint32_t *v);
/* Why interior tetrahedron t is bad (0: it is not; 1 a bound, 2 only the
 * dihedral angle, 3 flat on a facet), its circumcentre and squared
 * radius-edge ratio. */
int ref__tet_bad(const ref_mesher *r, uint32_t t, double cc[3], double *ratio2);
/* For tetrahedron t whose circumcentre is unusable (too flat): the
 * circumcentre of one of its faces that is in conflict with t. Returns 0
 * with cc set, or -1 when there is none. */
int ref__flat_tet_centre(const tm_mesh *m, uint32_t t, double cc[3]);

/* ---------------------------------------------------- refine_bound.c */

/* 1 if vertex v lies on facet f by construction. */
int ref__on_facet(const ref_mesher *r, uint32_t v, uint32_t f);
/* The 2D cavity: r->list holds its subfacets, r->bedge its boundary. */
int ref__list_add(ref_mesher *r, uint32_t s);
void ref__list_clear(ref_mesher *r);
int ref__grow_cavity2d(ref_mesher *r, const double *p, uint32_t sa, uint32_t sb, uint32_t *ea,
                       uint32_t *eb);
/* The 2D cavity of point p on subsegment sa-sb made of the subfacets on
 * that edge alone (each split in two): r->list and r->bedge as
 * ref__grow_cavity2d leaves them. Returns 0, 1 when p (rounded) does not
 * lie strictly inside one of those subfacets' other edges, or
 * PDR_ENOMEM. */
int ref__cavity2d_edge(ref_mesher *r, const double *p, uint32_t sa, uint32_t sb);
/* Edge k of subfacet id of the 2D cavity r->list: 1 if it bounds the
 * cavity (it is not the split subsegment sa-sb, sb TM_NONE for none, and
 * the cavity holds no subfacet across it), with its ends in *x, *y, *seg
 * 1 when it is a subsegment, and else the subfacet across it in *u
 * (BD_NONE: none). */
int ref__cavity2d_rim(const ref_mesher *r, uint32_t id, int k, uint32_t sa, uint32_t sb,
                      uint32_t *x, uint32_t *y, int *seg, uint32_t *u);
/* Appends rim edge x-y of subfacet id to r->bedge (0 or PDR_ENOMEM). */
int ref__add_bedge(ref_mesher *r, uint32_t x, uint32_t y, uint32_t id);
/* If subsegment id is an edge of the mesh: its edge bits set in every
 * tetrahedron around it, *t one of them, the missing flag cleared, 1;
 * else flagged missing, 0. */
int ref__mark_subseg(ref_mesher *r, uint32_t id, uint32_t *t);
/* A tetrahedron with face abc (edge ab when c is TM_NONE), found from a's
 * star; 1 if found. */
int ref__find_in_star(const tm_mesh *m, uint32_t a, uint32_t b, uint32_t c, uint32_t *tout);
/* The subsegment and subfacet tables after committing vertex v for a
 * boundary split (of subsegment split_id, or BD_NONE). */
int ref__update_boundary(ref_mesher *r, uint32_t v, uint32_t split_id);
/* Constrained mode: 1 if an end of input segment seg, or a corner of facet
 * f, is a needle point (FM_NEEDLE_ANG); 0 in the conforming mode for a
 * facet. */
int ref__needle_seg(const ref_mesher *r, uint32_t seg);
int ref__needle_facet(const ref_mesher *r, uint32_t f);
/* The point that splits subsegment ab (tests/test_refine.c checks it). */
void ref__split_point(const ref_mesher *r, uint32_t a, uint32_t b, double p[3]);

/* --------------------------------------------------- refine_facrec.c */

/* Recovers missing subfacet id with its region as ref_recover_facets
 * does, in a mesh whose present subfacets are marked: on success the
 * region's subfacets (or the facet's new ones, when the mesh triangulates
 * a coplanar region otherwise) are marked faces, no longer missing or
 * queued. Returns 0 (recovered), 1 (left as it was) or a negative code. */
int ref__recover_region(ref_mesher *r, uint32_t id);

/* ------------------------------------------------------ refine_cdt.c */

/* may_cross of a constrained boundary split: a face whose subfacet is in
 * the split's 2D cavities (BD_F_VISIT). */
int ref__cross_visited(void *arg, const tm_mesh *m, uint32_t t, int f);
/* Faces between two interior tetrahedra, on no facet, that are not
 * locally Delaunay (the far apex strictly inside the circumsphere, as
 * pdr check tests). */
size_t ref__count_stuck(const ref_mesher *r);
/* The dt_cavity_search flags of the constrained mode. */
unsigned ref__cdt_flags(const ref_mesher *r);
/* The constrained cavity of point p splitting piece ab (edge) or abc
 * (face, c != TM_NONE), missing or present, whose 2D cavities are in
 * r->list: searched into r->cav crossing only those subfacets, made a star,
 * and deleting every present subfacet of the list. Returns 0 (r->cav
 * pending), 1 when there is no such cavity (nothing pending), with the
 * parallel hooks REF_CDT_ELSEWHERE when it is not all on this PE or
 * REF_CDT_LOCKED when another cavity holds some of it (nothing pending),
 * or a negative code. With edge_star, a present subsegment whose cavity
 * cannot be made a star is split in the tetrahedra around it instead. */
#define REF_CDT_ELSEWHERE 2
#define REF_CDT_LOCKED 3
/* At most this many subsegment splits moved off their refused point at
 * rank 0's finish (refine_run.c, split_subseg). */
#define REF_MOVED_SPLITS 8
int ref__cdt_search_piece(ref_mesher *r, const double p[3], uint32_t a, uint32_t b, uint32_t c,
                          int missing, int edge_star);
/* Lawson's flips from tetrahedra seed[0..n) (mesh/flip.h), the facet
 * triangulations following its 2-2 flips; faces no flip mends have their
 * subsegment or subfacets queued for splitting. r->flipped lists the
 * tetrahedra the flips made. Returns 0 or a negative code. */
int ref__cdt_flip(ref_mesher *r, const uint32_t *seed, size_t n);

/* 1 if the refinement has a size bound: a volume bound (global, or a
 * region's when those apply) or an edge bound (refine_run.c). */
int ref__size_bounded(const ref_mesher *r);
/* Removes t if it is a flat tetrahedron on a merged facet that
 * flip_remove_flat removes (the facet triangulation follows). Returns 1 if
 * removed, 0 if not, or a negative code. */
int ref__cdt_remove_flat(ref_mesher *r, uint32_t t);
/* For a circumcentre p that the constrained cavity r->cav searched from
 * tetrahedron t does not hold: the subfacet on the cavity's boundary that
 * the segment from t to p crosses (else one p lies beyond), or BD_NONE. */
uint32_t ref__cdt_blocker(const ref_mesher *r, uint32_t t, const double p[3]);

/* Shewchuk's seditious edges (his 2D refinement's rule for small input
 * angles), here for the constrained mode: edge ab whose ends lie on two
 * input segments that meet at an input vertex o at less than FM_NEEDLE_ANG
 * (a needle point), at distances from o within a factor SEDITIOUS_SHELL
 * of each other (on one of the concentric shells of ref__split_point, or
 * two input vertices equally far from o). Such an edge is much shorter
 * than its distance to o, and a tetrahedron whose shortest edge it is
 * stays bad whatever is inserted next to it until o's neighbourhood is
 * refined down to the resolution: the refinement leaves it. On the corpus
 * the needle keeps its one tetrahedron instead of growing to 306, all bad;
 * the 64-triangle fan cone its 64 instead of 1,331 (510 bad); Shewchuk's
 * 60 degrees also caught the 30-60 degree corners of ordinary tessellated
 * spheres and tori and left bad tetrahedra there (sphere-0.08: 17).
 * Returns o (a PLC vertex) or UINT32_MAX. */
#define SEDITIOUS_SHELL 1.001
uint32_t ref__cdt_seditious(const ref_mesher *r, uint32_t a, uint32_t b);
/* The same for the shortest edge of tetrahedron t. */
uint32_t ref__cdt_seditious_tet(const ref_mesher *r, uint32_t t);

/* refine_classify.c: 1 if tetrahedron t is next to a small input angle
 * (the summary's kind of a given-up tetrahedron): across a seditious small
 * angle (constrained mode), or with a vertex on an acute input vertex, on
 * a sharp segment or on a segment that ends at an acute vertex (plc/fm.h
 * thresholds); every one without the PLC's feature angles. */
int ref__at_small_angle(const ref_mesher *r, uint32_t t);
/* 1 if input segment seg is sharp or ends at an acute input vertex (the
 * segment half of ref__at_small_angle; 1 without the feature angles). */
int ref__seg_small_angle(const ref_mesher *r, uint32_t seg);
/* 1 if finite tetrahedron t of m holds p (closed: on a face counts),
 * exactly; 0 for a ghost or when p lies beyond a face. */
int ref__tet_holds(const tm_mesh *m, uint32_t t, const double p[3]);

/* refine_run.c, for refine_offc.c: the flags of the pending cavity's
 * tetrahedra, OR-ed; the insertion of its point (a new vertex of kind
 * vkind on feature feat, insertion radius rins: new tetrahedra inherit the
 * exterior flag and region of the ones they replace); the distance from p
 * to the nearest vertex of cavity c's boundary. */
uint16_t ref__cavity_flags(const ref_mesher *r);
int ref__commit_point(ref_mesher *r, uint16_t any, int vkind, uint32_t feat, double rins,
                      uint32_t *vout);
double ref__cavity_clearance(const tm_mesh *m, const dt_cavity *c, const double *p);

#endif /* PDR_REFINE_INT_H */
