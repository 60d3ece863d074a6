/*
 * refine/refine.h -- sequential Delaunay refinement (prefix ref_): Shewchuk's
 * algorithm in the form of the paper's SeqRefinement (Nave, Chrisochoides,
 * Chew, fig. 2), with Refine(tau) and Retriangulate(tau, p, Cp) kept apart
 * so that the parallel refinement reuses the decision with a cavity
 * gathered from several processing elements.
 *
 * One insertion, for tau a bad tetrahedron, an encroached or missing
 * subfacet, or an encroached or missing subsegment:
 *
 *   1. p = the insertion point of tau: circumcentre of a tetrahedron or a
 *      subfacet, midpoint of a subsegment (or a point on a power-of-two
 *      shell around an input vertex where segments meet at an acute angle,
 *      Ruppert's rule, so that splitting terminates).
 *   2. Cp = the cavity of p: every tetrahedron whose circumsphere contains p,
 *      found by dt_cavity_search WITHOUT stopping at subfacets. The mesh is
 *      a conforming Delaunay tetrahedralization of all its vertices, the
 *      part outside the domain included, so Cp is the ordinary Bowyer-
 *      Watson cavity.
 *   3. ref_gather_marks() lists the subsegments and subfacets that Cp
 *      touches (edges flagged TM_F_SUBSEG and faces carrying a facet marker
 *      of a cavity tetrahedron), each with a flag saying whether Cp
 *      contains every tetrahedron around it (committing would delete it).
 *   4. ref_decide() looks at p and that list ALONE and says: commit; or
 *      split these subsegments instead (p encroaches them); or split this
 *      subfacet instead (p encroaches it; the one containing p's
 *      orthogonal projection, Shewchuk's projection lemma).
 *   5. Commit, then update the subsegments and facet triangulations and
 *      queue what became bad, encroached or missing.
 *
 * Why the decision can use the cavity alone. While no subsegment or
 * subfacet is encroached (the refinement keeps it so: encroached ones have
 * priority), if p lies in the equatorial ball of a subfacet f, p lies in
 * the circumball of one of the two tetrahedra sharing f (their union
 * contains that ball), so a cavity tetrahedron carries f's marker; and the
 * cavity contains BOTH tetrahedra of f only if p lies in their lens, which
 * is inside f's equatorial ball. The same holds for a subsegment, its
 * diametral ball and the tetrahedra around it. The "deleted" flag makes
 * the decision safe even when those premises fail (rounding, a subfacet
 * tolerated by the small-angle safety net): a tetrahedron's circumcentre
 * is never inserted if that would delete a subsegment or subfacet.
 *
 * Exterior tetrahedra are KEPT, flagged REF_F_EXTERIOR, not deleted: the
 * mesh stays the Delaunay tetrahedralization of all vertices, closed by
 * ghosts, so point location and cavities work the same everywhere, and a
 * circumcentre outside the domain needs no special case: its cavity must
 * cross a boundary subfacet to get there, which shows as a deleted mark.
 * Deleting them would make every boundary insertion a special case (the
 * kernel would build flat tetrahedra on the split boundary faces). A
 * submesh on one processing element keeps the same flags; only the output
 * drops exterior tetrahedra. The region of a new tetrahedron is that of the
 * old cavity tetrahedron across whose boundary face it is built: both lie
 * on the same side of that face, next to it, and regions change only
 * across subfacets.
 *
 * Termination where input angles are small (the safety net). Shewchuk's
 * guarantee needs the projection condition (no two input features meeting
 * at less than 90 degrees); the tee has 60-degree edges, real inputs have
 * worse. Three rules keep the refinement finite on any input, and the
 * tetrahedra they leave above the bound are counted (ref_count_bad):
 *  - a subsegment or subfacet encroached by a vertex that lies on an
 *    input feature meeting its own at an acute angle (the two share an
 *    input vertex and the vertex projects into the piece's feature: the
 *    projection condition fails there) is not split eagerly: two facets
 *    meeting at an acute angle would otherwise split each other down to
 *    their common edge. Other encroachment is split, refused only when the
 *    new vertex would be nearer than rho times the encroacher's insertion
 *    radius to another vertex;
 *  - a split asked for by a bad tetrahedron (its circumcentre encroaches)
 *    is refused when the new vertex would be nearer to an existing one
 *    than the tetrahedron's shortest edge (half its circumradius when only
 *    its size is bad). On inputs meeting the projection condition that
 *    never happens: such a split point is at least r/sqrt(2) >= B l /
 *    sqrt(2) from every vertex. A refused split leaves the tetrahedron
 *    (REF_F_GIVEUP). So apart from recovering missing pieces, no vertex
 *    is inserted nearer to another than the shortest edge already near it;
 *  - slivers (bad only by a dihedral angle) whose circumradius is below
 *    0.7 of their shortest edge are left.
 * In the constrained mode, what is left above the radius-edge bound is
 * then retried once more with off-centre points (refine_offc.c), each
 * inserted only where its star leaves fewer tetrahedra above the bound
 * than the cavity it replaces.
 * Missing pieces are always split: the mesh must conform.
 *
 * Subsegments and subfacets are kept in a bd_set (refine/bd.h) next to the marks
 * on the mesh: marks say where they are in the tetrahedralization, the set
 * says which exist, so one that an insertion deletes (possible where input
 * angles are acute, and during recovery) is known to be missing and is
 * recovered by splitting it, as in Shewchuk's algorithm.
 *
 * The implementation is split over refine/refine*.c along these steps;
 * refine/refine_int.h says which file holds what and declares what they
 * share.
 */
#ifndef PDR_REFINE_H
#define PDR_REFINE_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "refine/bd.h"
#include "mesh/dt.h"
#include "mesh/flip.h"
#include "mesh/mesh_export.h"
#include "base/pdr_error.h"
#include "plc/plc.h"
#include "mesh/tm.h"

struct ref_mesher;

/* Tetrahedron flags of the refinement (spare bits of mesh/tm.h). */
#define REF_F_EXTERIOR TM_F_SPARE0 /* outside the domain or in a hole */
#define REF_F_GIVEUP TM_F_SPARE1   /* bad, but left (reason counted) */
#define REF_F_DEGENERATE TM_F_SPARE2 /* ... because its circumcentre is unusable */

/* t is a live tetrahedron of the domain: not dead, not a ghost, not
 * exterior (outside or in a hole). */
static inline int ref_is_interior(const tm_mesh *m, uint32_t t)
{
    return !tm_is_dead(m, t) && !tm_is_ghost(m, t) && !(m->flags[t] & REF_F_EXTERIOR);
}

/* ---------------------------------------------------- cavity decision */

/* What an insertion point splits. */
enum ref_kind { REF_TET = 0, REF_SUBFACET = 1, REF_SUBSEG = 2 };

/* A subsegment (nv == 2) or subfacet (nv == 3) touched by a cavity. */
typedef struct ref_mark {
    uint32_t v[3];     /* mesh vertices (v[2] unused for a subsegment) */
    double x[3][3];    /* their coordinates */
    int32_t facet;     /* subfacet: facet index; subsegment: -1 */
    uint8_t nv;        /* 2 or 3 */
    uint8_t deleted;   /* the cavity holds every tetrahedron around it */
    uint8_t encroached; /* set by ref_decide */
    uint8_t spare;
} ref_mark;

/* A slot of ref_marks' subsegment set: valid when its stamp is the
 * current gather's. */
typedef struct ref_seg_slot {
    uint32_t stamp;
    uint32_t mark; /* index into ref_marks.m */
} ref_seg_slot;

typedef struct ref_marks {
    ref_mark *m;
    size_t n, cap;
    /* The subsegments listed by the current ref_gather_marks (each shows
     * in every cavity tetrahedron around it): open addressing on the
     * edge, emptied in O(1) by a new stamp. Scratch, owned. */
    ref_seg_slot *seg;
    size_t seg_cap, nseg; /* seg_cap a power of two, or 0 */
    uint32_t stamp;
} ref_marks;

enum ref_action {
    REF_COMMIT = 0,        /* insert p */
    REF_SPLIT_SUBSEGS = 1, /* split the marks flagged encroached that are
                              subsegments instead */
    REF_SPLIT_SUBFACET = 2 /* split mark 'which' (a subfacet) instead */
};

typedef struct ref_decision {
    int action;   /* enum ref_action */
    size_t which; /* REF_SPLIT_SUBFACET: index into the marks */
    size_t nseg_encroached, nfac_encroached;
} ref_decision;

/* Collects the marks of cavity c of mesh m (whose tetrahedra carry
 * TM_F_CAVITY). Facet markers are facet index + 1. Returns 0 or
 * PDR_ENOMEM. */
int ref_gather_marks(const tm_mesh *m, const dt_cavity *c, ref_marks *out);

/* Decides what to do with point p, inserted for a tau of the given kind,
 * from the marks of its cavity alone (see the top of this file); sets
 * every mark's 'encroached' flag. p encroaches a subsegment if it lies
 * strictly inside its diametral ball, a subfacet if it lies strictly inside
 * its equatorial ball and off its plane; a deleted mark counts as
 * encroached. Rules: a subsegment point is always committed; a subfacet
 * circumcentre is rejected if it encroaches a subsegment; a tetrahedron
 * circumcentre is rejected if it encroaches a subsegment (split them) or
 * else a subfacet (split, among the encroached subfacets of the facet of
 * the largest one, the one containing p's orthogonal projection onto that
 * facet, or the largest if none does). p's facet planes come from pl. */
void ref_decide(const plc *pl, const double p[3], int kind, ref_marks *cm, ref_decision *d);

void ref_marks_free(ref_marks *cm);

/* ---------------------------------------------------------- the mesher */

/* Order in which bad tetrahedra are split. */
enum ref_order {
    REF_ORDER_FIFO = 0, /* first queued, first split */
    REF_ORDER_LIFO = 1, /* last queued first: stays where the work is */
    /* For the parallel refinement: the bad tetrahedra a step made are
     * split next, newest first, when the step's cavity stayed on this PE
     * (hooks->cavity returned REF_SEARCHED and did not set step_remote);
     * all other work waits its turn, oldest first. Newest first
     * everywhere would follow the work across an interface and chase the
     * other PE; oldest first everywhere loses the cache. */
    REF_ORDER_LOCAL_FIRST = 2,
};

#define REF_LEFT_SITES 3

typedef struct ref_stats {
    size_t tet_points;   /* circumcentres of tetrahedra inserted */
    size_t fac_points;   /* circumcentres of subfacets inserted */
    size_t seg_points;   /* subsegment split points inserted */
    size_t rejected;     /* tetrahedron circumcentres turned into splits */
    size_t tolerated;    /* boundary splits refused by the safety net */
    /* ... of which (PDR_REF_TRACE prints them; see mesher/refine/
     * QUALITY.md): */
    size_t tol_floor;    /* the new vertex nearer than the floor rmin */
    size_t tol_hidden;   /* constrained: its cavity could not be made */
    size_t tol_below;    /* nearer than min_spacing to a vertex */
    size_t needle_floor; /* splits for a bad tetrahedron under the whole
                            floor because a piece ends at a needle point */
    size_t beyond_seg;   /* subfacet splits given to the subsegment their
                            circumcentre lies beyond */
    size_t unseen;       /* constrained: tetrahedra whose circumcentre a
                            constraint hides and no subfacet on the
                            cavity's boundary is in the way (given up,
                            counted degenerate) */
    size_t gave_up;      /* tetrahedra left alone when popped */
    size_t degenerate;   /* tetrahedra whose circumcentre was unusable */
    size_t flat_centres; /* flat tetrahedra split at a face's circumcentre */
    size_t shrunk;       /* constrained: cavities shrunk to a star */
    size_t offcentres;   /* constrained: off-centre points inserted for
                            tetrahedra left above the bound
                            (refine_offc.c) */
    size_t moved_splits; /* constrained, at rank 0's finish: subsegment
                            splits a face no flip mends asked for, made
                            elsewhere than at the split point, which was
                            refused */
    size_t cdt_refused;  /* constrained: boundary splits refused because
                            their 3D cavity kept a subfacet of their 2D one */
    size_t flips23, flips32, flips22, flips_stuck; /* constrained: Lawson's
                            flips (22: of two boundary subfacets) */
    size_t stuck_splits; /* constrained: subsegments queued for a split by
                            a face that no flip mends (ref__cdt_flip) */
    size_t stuck_corner; /* constrained: such splits not asked for past
                            REF_STUCK_CORNER at an acute corner
                            (corner_cascade in refine_cdt.c) */
    size_t stuck_quality; /* constrained: splits of present subsegments
                            that faces no flip mends asked for during the
                            quality refinement (process_seg in
                            refine_run.c), bounded by
                            REF_STUCK_QUALITY_BASE and _INPUTS */
    size_t flips_blocked; /* parallel constrained: faces not flipped
                            because another cavity held a tetrahedron (the
                            merged mesh is flipped once more at rank 0) */
    size_t missing_recovered; /* missing subsegments/subfacets split */
    size_t deflected;    /* conforming: subfacet splits that would have
                            deleted a subfacet of an oblique facet, made
                            there instead (split_subfac in refine_run.c) */
    size_t forced_cavities; /* constrained recovery: splits whose cavity
                            kept subfacets of their 2D cavity (unmarked,
                            their replacements recovered in turn) */
    size_t segrec_points; /* constrained: points of the segment recovery
                            (ref_recover_segments), before any facet is
                            a constraint */
    size_t facrec_faces; /* constrained: missing subfacets made faces by
                            retriangulating the tetrahedra they cross
                            (ref_recover_facets), no point inserted */
    size_t flat_fans_kept; /* constrained: subfacets the segment recovery
                            kept out of a 2D cavity because the fan over
                            their subsegment would be flat (refine_segrec.c) */
    size_t slivers_left; /* slivers not split (circumradius too small) */
    size_t edge_star_splits; /* constrained: subsegment splits made in the
                            tetrahedra around the edge (its constrained
                            cavity was no star) */
    size_t flats_removed; /* constrained: flat tetrahedra on merged facets
                            removed (flip_remove_flat) */
    size_t seditious;    /* constrained: tetrahedra left because their
                            shortest edge is seditious (ref__cdt_seditious) */
    size_t reclassified; /* tetrahedra the final classification moved */
    size_t deferred;     /* parallel: bad tetrahedra put back unstarted
                            because a cavity in progress held them */
    size_t left_elsewhere; /* parallel: bad tetrahedra dropped because the
                            split they needed lay on another PE (not given
                            up: the merged mesh is refined once more) */
    /* after ref_count_bad() */
    size_t left_ratio;   /* interior tetrahedra with ratio >= bound */
    size_t left_ratio_angle;  /* ... given up (the split they needed was
                                 refused) next to a small input angle: a
                                 vertex on an acute input vertex or a
                                 segment that is sharp or ends at one
                                 (plc/fm.h thresholds), or, constrained,
                                 across a seditious small angle */
    size_t left_ratio_refused; /* ... given up away from those: their
                                  splits refused by the floors and bounds
                                  of the constrained mode or the safety net */
    size_t left_ratio_degenerate; /* ... given up for want of a usable
                                     circumcentre, flat: none finite, or
                                     none in conflict with them
                                     (ref_count_bad tells them apart from
                                     the next by that geometry) */
    size_t left_ratio_hidden; /* ... given up so with a circumcentre in
                                 conflict with them: its cavity could not
                                 be made (constrained: behind faces no
                                 flip mends, no constraint between; or a
                                 walk that leaves the domain) or it lay
                                 too near a vertex */
    size_t left_stuck;   /* constrained: faces off the facets left not
                            locally Delaunay (ref_count_bad) */
    size_t left_size;    /* interior tetrahedra above the size bound */
    size_t left_sliver;  /* ... with a dihedral angle below the bound */
    /* Where the given-up tetrahedra (left_ratio_angle and
     * left_ratio_refused) are: the input features they touch, most
     * tetrahedra first (count 0: unused). */
    struct ref_left_site {
        int kind;        /* BD_V_INPUT (feature: PLC vertex), BD_V_SEGMENT
                            (plc.segs index), BD_V_FACET, BD_V_VOLUME */
        uint32_t feature;
        size_t count;
    } left_site[REF_LEFT_SITES];
} ref_stats;

typedef struct ref_opts {
    double ratio;      /* radius-edge bound B > 1; 0: no quality bound */
    double maxvol;     /* maximum volume; <= 0: none (regions may set one) */
    double maxedge;    /* maximum edge length; <= 0: none */
    double min_dihedral; /* split tetrahedra with a dihedral angle below
                            this (degrees) or above 180 minus it; 0: none */
    double seg_maxlen; /* split subsegments at least this long (0: none) */
    double fac_maxrad; /* split subfacets with circumradius at least this */
    double rho;        /* safety net: refuse a boundary split whose
                          insertion radius is below rho times its
                          encroacher's (default 1/(2 sqrt 2)); 0: never */
    int use_region_maxvol; /* apply the PLC's regional volume bounds */
    size_t max_points; /* ref_run stops with PDR_ELIMIT once this many
                          points were inserted in all (0: no limit; see
                          ref_point_limit) */
    int order;         /* enum ref_order */
    int constrained;   /* keep a constrained Delaunay tetrahedralization
                          whose subsegments and subfacets no cavity
                          crosses (refine/refine_cdt.c); 0: conforming */
    int keep_stuck;    /* start as ref_mesher.keep_stuck: the mesh comes
                          from the recovery with segments first (a
                          parallel run's PEs and merge: its Mo did) */
    /* Called about every 2^14 insertions when not NULL. */
    void (*progress)(void *arg, const struct ref_mesher *r);
    void *progress_arg;
    /* Debugging aids, off after ref_default_opts. The library reads no
     * environment and never aborts: a caller that wants them sets them
     * (pdr mesh does from PDR_REF_CHECK and PDR_REF_TRACE). */
    int check_each_step; /* ref_run checks the marks against the tables
                            (ref_consistency) before every step and, at the
                            first disagreement, stops with PDR_ETOPOLOGY;
                            slow */
    FILE *log;         /* where check_each_step describes a disagreement;
                          NULL: nowhere (the error code still says it) */
    FILE *trace;       /* ref_run's trace lines (queue lengths, counters);
                          NULL: none */
    size_t trace_every; /* a trace line every this many steps; 0: only
                           the line at the end of each ref_run */
} ref_opts;

/* The parallel refinement's hooks (par/par_run.c). With hooks installed
 * (ref_mesher.hooks), every new point's cavity is searched from a
 * tetrahedron of this PE in conflict with it (no walk), after the
 * cavity hook has made that cavity local; a piece whose tetrahedra are
 * no longer on this PE is left to the PE that holds them. */
#define REF_SETBACK 1  /* a step gave up without changing anything */
#define REF_SEARCHED 2 /* the cavity hook left the search done in c */

typedef struct ref_hooks {
    /* Called before the cavity of point p is searched, with start a
     * tetrahedron in conflict with p. Returns 0 when the cavity of p and
     * the tetrahedra around it are now all in this mesh (the step goes
     * on and searches it in c), REF_SEARCHED when moreover c holds that
     * search, pending, REF_SETBACK to give the step up, or a negative
     * code. */
    int (*cavity)(void *arg, const double p[3], uint32_t start, dt_cavity *c);
    /* Called after vertex v was committed; c->newtets are the new
     * tetrahedra. Returns 0 or a negative code. */
    int (*committed)(void *arg, uint32_t v, const dt_cavity *c);
    /* The constrained mode's flips: the lock owner of the running step
     * (tetrahedra locked by any other are not flipped), and a new
     * tetrahedron's face t, f that took over interface link outer. */
    uint32_t (*owner)(void *arg);
    void (*relink)(void *arg, tm_link outer, uint32_t t, int f);
    /* While busy_depth > 0: 1 if the search of bad tetrahedron t would
     * likely meet a cavity in progress (a setback), so that it waits;
     * NULL: the locks within busy_depth neighbour steps tell. */
    int (*busy)(void *arg, uint32_t t);
    /* Called when bad tetrahedron t is left for the merge (its split lies
     * on another PE: ref_stats.left_elsewhere); it keeps TM_F_QUEUED,
     * though no queue holds it. NULL: nothing to do. */
    void (*left)(void *arg, uint32_t t);
    void *arg;
} ref_hooks;

/* Queue of refinement work: 32-bit ids, each with a float (rmin) in the
 * queues of subsegments and subfacets; the tetrahedra's queues keep no
 * rmin (NULL: they would be all 0). Only the refine*.c files use it; it
 * is here because ref_mesher holds four. */
typedef struct ref_queue {
    uint32_t *id;
    float *rmin;   /* smallest acceptable insertion radius of the split,
                      or NULL in a queue of tetrahedra */
    size_t head, n, cap; /* entries head..n-1 are pending */
} ref_queue;

typedef struct ref_mesher {
    tm_mesh m;         /* the tetrahedralization, ghosts and exterior kept */
    const plc *p;      /* the input, validated; not owned */
    bd_set bd;         /* subsegments, facet triangulations, vertex data */
    ref_opts o;
    ref_stats st;
    double b2;         /* ratio^2, or 0 */
    double sin_min;    /* sin(min_dihedral), or 0 */
    int classified;    /* exterior marked, regions assigned */
    int refining;      /* ref_run is splitting bad tetrahedra too, or a
                          PE's parallel refinement (par_run.c) is */
    size_t pause_points; /* > 0: ref_run(r, 1) pauses (returns 0 with
                            'paused' set) before a bad tetrahedron's
                            split once this many points were added and no
                            subsegment or subfacet is queued: rank 0 of a
                            parallel run refining Mo alone (cli/mesh_par.c);
                            set by the caller, 0 from ref_init */
    int paused;        /* ref_run stopped at pause_points; ref_refine
                          then returns 0 with its work not done (no
                          shrink passes); the bad tetrahedra are queued
                          again by whoever goes on (ref_queue_all_tets) */
    int finishing;     /* rank 0 finishes the merged mesh of a parallel
                          run in the constrained mode (no hooks there;
                          split_subseg's retries) */
    int carved;        /* exterior deleted, ghosts on the boundary faces
                          (constrained mode, ref_carve) */
    uint16_t *region;  /* per tet slot: region index + 1 (0 none), or NULL
                          when the PLC has no regions */
    size_t region_cap;
    uint8_t *fac_needle; /* constrained mode, per facet: 1 if one of its
                            corners is a needle point (FM_NEEDLE_ANG);
                            NULL: none */
    uint16_t *corner_steps; /* per PLC vertex: requests for splits of a
                            corner cascade there (refine_cdt.c,
                            corner_cascade; NULL until the first) */
    uint32_t *seg_acute; /* per PLC vertex: 1 if two of its segments meet
                            at less than 90 degrees */
    /* work queues */
    ref_queue segq, facq, tetq;
    ref_queue tetq_local; /* REF_ORDER_LOCAL_FIRST: work of local steps */
    int step_remote;      /* the current step's cavity came from other PEs
                             (or hooks->cavity set it: next to them) */
    /* scratch */
    dt_cavity cav;
    ref_marks marks;
    uint16_t *bflag;   /* saved flags/regions per cavity boundary face */
    uint16_t *breg;
    size_t cap_b;
    uint32_t *list;    /* 2D cavity: subfacets */
    size_t nlist, cap_list;
    uint32_t (*bedge)[4]; /* 2D cavity boundary: a, b, facet, subfacet */
    size_t nbedge, cap_bedge;
    int forced;        /* the 2D cavity holds a subfacet the 3D cavity
                          does not delete */
    size_t anomalies;  /* 2D cavities that were not star-shaped */
    size_t flips;      /* facet triangulation edges flipped to match T */
    const char *last_op; /* what the last step split (for debugging) */
    size_t region_doubts; /* flat tetrahedra on facets met, flips after
                             classification: reasons to classify again */
    const ref_hooks *hooks; /* NULL when sequential; not owned */
    int busy_depth;    /* parallel, set by the caller before ref_next: a bad
                          tetrahedron with a lock at most this many
                          neighbour steps away (or that hooks->busy calls
                          busy) goes to the back of the queue unstarted
                          (its search would be a setback);
                          not with REF_ORDER_LIFO; 0: no check (m->lock
                          may be NULL) */
    int shrink_pass;           /* constrained: shrink unseen cavities (shrink_passes) */
    uint32_t (*leftover)[4];   /* constrained, in shrink_passes: the
                                  tetrahedra the run before left (each
                                  one's vertices, ascending; sorted);
                                  owned */
    size_t nleftover, cap_leftover;
    int leftover_try;          /* split_tet works on one of them: a
                                  subsegment split it asks for whose
                                  cavity folds takes the edge star
                                  (refine_run.c, split_subseg_at) */
    /* constrained, without hooks: what stops a flat tetrahedron's
     * floorless splits from cascading (refine_run.c, flat_spent) */
    hmap flat_made;            /* vertex + 1 -> 1: inserted while a flat
                                  tetrahedron was split */
    hmap flat_tries;           /* hash of a flat tetrahedron's vertices ->
                                  its splits that left it standing */
    int flat_step;             /* split_tet_at is splitting a flat one */
    uint32_t shrink_keep;      /* constrained: the bad tetrahedron whose
                                  circumcentre's cavity is shrunk (kept) */
    uint32_t split_a, split_b; /* constrained: the subsegment being split
                                  (split_b TM_NONE: a subfacet) */
    uint32_t last_v;   /* the vertex inserted last (0: none) */
    double min_spacing; /* no boundary split nearer than this to a vertex:
                           REF_MIN_SPACING times the bounding-box diagonal */
    int stopped_below; /* a run stopped because a missing piece needed a
                          split below min_spacing, at stop_at */
    int stop_hidden;   /* ... or, in the constrained mode, because that
                          split's cavity could not be made: nearby
                          constraints hide part of what it replaces; the
                          piece lies on input feature stop_feat of kind
                          stop_vkind (BD_V_SEGMENT, BD_V_FACET) */
    int stop_vkind;
    uint32_t stop_feat;
    int centroid_try;  /* split_subfac_cdt is trying a missing subfacet's
                          centroid (keep_stuck only) */
    int keep_stuck;    /* the recovery with segments first ran (im_build):
                          a face no flip mends is left as it is, not
                          mended by splitting the pieces next to it
                          (ref__cdt_flip), and counted at the end */
    int narrow_recovery; /* im_build with segments_first, while the
                            recovery runs: narrowed_cavity in
                            refine_cdt.c may replace a refused split */
    size_t recovery_capped; /* the constrained recovery stopped at its own
                               bound on points (im_build), this one */
    int deflecting;    /* split_subfac is splitting an oblique facet's
                          subfacet instead of its own (one level only) */
    size_t recovery_limit; /* the refinement stops (PDR_ELIMIT,
                              recovery_stuck) before splitting a missing
                              piece once st.missing_recovered reaches this
                              (0: no bound; set by ref_refine and the
                              parallel refinement, see
                              REF_RECOVERY_PER_VERTEX) */
    size_t recovery_from; /* st.missing_recovered when the bound was set */
    int recovery_stuck; /* a run stopped there, near stop_at */
    double stop_at[3];
    flip_out flipped;  /* constrained: the last insertion's flips */
    uint32_t *miss;    /* new subfacets missing from T */
    size_t nmiss, cap_miss;
} ref_mesher;

/* A bound on the points a run may insert, for an input that makes the
 * refinement run on (small angles the safety net does not catch): REF_
 * LIMIT_BASE plus REF_LIMIT_PER_INPUT per input vertex, segment and facet,
 * plus REF_LIMIT_PER_SIZE times the number of tetrahedra of the largest
 * volume the size bounds allow (maxvol, maxedge, the regions' volumes)
 * that fit in the input's bounding box. Terminating runs stay far below
 * it (the model problems by a factor of 20 or more). */
#define REF_LIMIT_BASE 100000.0
/* Relative resolution of boundary splits (ref_mesher.min_spacing). */
#define REF_MIN_SPACING 1e-10
#define REF_LIMIT_PER_INPUT 200.0
#define REF_LIMIT_PER_SIZE 20.0
size_t ref_point_limit(const plc *p, const ref_opts *o);

/* The bound on the subsegment splits that faces no flip mends ask for in
 * one run (ref_stats.stuck_splits, ref__cdt_flip): REF_STUCK_BASE plus
 * REF_STUCK_PER_INPUT per input vertex. Past it such faces are left, as
 * after the recovery with segments first, and counted (left_stuck). On
 * thin tessellations (CGAL's pipe.off, 160 vertices, and u.off) those
 * splits cascade, each new vertex's floor lower than the last, for
 * minutes, and on CGAL's anchor_dense a bound of 8 per input vertex
 * still took 96 s. Most runs stay below it (turbine: 14,859 for 9,210
 * vertices; the generated corpus: at most 2 in all; the parts meshed
 * after the recovery with segments first: none); those that end by
 * themselves above it (CGAL's 3torus, 126 for 19 vertices; dragknob,
 * 1,031 for 161; double-torus-example, 1,606 for 231) now leave a few more
 * such faces (9, 76 and 158 instead of 3, 53 and 95) in fewer tetrahedra.
 * Fewer splits are no worse a mesh: pipe.off with none has 5,826
 * tetrahedra, 1,418 above ratio 2; with this bound 11,809 and 2,054; with
 * 1,500, 27,011 and 5,399. */
#define REF_STUCK_BASE 64
#define REF_STUCK_PER_INPUT 2

/* Such a split asks for a floor from the apex of the face (the vertex of
 * its tetrahedron off it): rho times the apex's insertion radius, which
 * says how fine the mesh is around the apex. When the apex lies more
 * than REF_STUCK_FAR times the subsegment's length from its midpoint,
 * the floor is rho times half that distance instead, which no midpoint
 * split passes: the face is left. A far apex's insertion radius says
 * nothing about the subsegment; on CGAL's pinion.off two such faces on
 * the diagonals of two tooth strips 0.22 apart, each the other's apex,
 * halved both diagonals towards their midpoints 14 times (down to 2.4e-7),
 * in ten places: 30,072 tetrahedra, 18,730 with this rule. */
#define REF_STUCK_FAR 4.0

/* At an input vertex o where segments meet at an acute angle, such a
 * split of a subsegment o-x whose face's apex lies on another segment at
 * o, at a point nearer to o than the apex (one of o's concentric shells,
 * ref__split_point), makes the point that is the apex of the next such
 * face, on the segment beside it, one shell nearer still, with half the
 * insertion radius: a floor from the apex never stops it, and under a
 * size bound nothing else did. On tests/data/surf/torus-0.3.off with -a
 * 2e-4 on 2 PEs (one run in a hundred under load, from the timing of the
 * interface exchanges) two segments 44 degrees apart at one vertex were
 * split in turn down to 2^-16 of their length (1,795 such splits, 21,000
 * tetrahedra against 16,600, 922 left above ratio 2); sequentially the
 * queues' order never started it. Under a size bound (where
 * REF_STUCK_QUALITY_BASE does not apply) REF_STUCK_CORNER requests for
 * such splits are granted per corner and run (a subsegment already queued
 * counts again); past them the face is left and counted (left_stuck).
 * The sequential meshes of the generated corpus and of torus-0.3 under
 * -a 1e-4 to 3e-4 stay the same (their requests end by themselves; up
 * to 10 at one corner, mostly for subsegments already queued). */
#define REF_STUCK_CORNER 6

/* A flat tetrahedron on a facet (four vertices on it by construction) is
 * removed by splitting the subfacet it lies on, with no floor: its
 * circumcentre is meaningless. In the constrained mode that split may go
 * to a subsegment the subfacet's circumcentre lies beyond, and leave the
 * flat tetrahedron standing, or make a new one of the same subfacet and
 * the new point on the subsegment: either way the next split halves the
 * same piece again, with no end (rank 0's finish of part.off on 2 PEs,
 * about one run in ten with latency: pieces down to 2^-33 of the
 * bounding box, 14,605 tetrahedra against 3,846 sequentially). So,
 * without parallel hooks, a flat tetrahedron having a vertex that such a
 * split inserted, or whose splits left it standing REF_FLAT_TRIES times,
 * is left (counted as degenerate). */
#define REF_FLAT_TRIES 3

/* Of those, the ones the quality refinement (ref_refine, after the
 * initial mesh) may make: REF_STUCK_QUALITY_BASE plus one per
 * REF_STUCK_QUALITY_INPUTS input vertices (ref_stats.stuck_quality); past
 * it the subsegment is left (tolerated) and the face counted. There, on
 * thin CAD tessellations whose initial mesh is a CDT (CGAL's handle.off
 * once its recovery stopped making splits no piece needed), each split
 * makes bad tetrahedra whose constrained cavities reach across thousands
 * of flat ones, and the run went past 30 s (TetGen: 2.7 s); with this
 * bound it takes 2 s. PDR_REF_TRACE prints the count. The generated
 * corpus asks for at most 1; of CGAL's parts, turbine.off, pipe.off and
 * handle.off reach the bound (1,215, 84, 209), dragknob.off and u.off
 * ask for none, eight.off for 91 (bound 103). */
#define REF_STUCK_QUALITY_BASE 64
#define REF_STUCK_QUALITY_INPUTS 8
/* Passes of the quality refinement that shrink folded cavities
 * (refine_run.c, shrink_passes). */
#define REF_SHRINK_PASSES 4
/* No further pass once the passes have added more than this fraction of
 * the vertices the mesh had before them. Of the public corpus's parts
 * only pipe.off (0.52 without it: 9,492 tetrahedra, 1.55 times TetGen's,
 * for 883 -> 815 above ratio 2) and cheese.off (0.28) pass it; pinion.off
 * (0.16) is the largest below (bench/surfaces.md). */
#define REF_SHRINK_GROWTH 0.25

/* The bound on the splits of missing pieces in one refinement
 * (ref_mesher.recovery_limit): this many per input vertex and
 * REF_RECOVERY_BASE more, as the constrained recovery's bound
 * (IM_RECOVERY_PER_VERTEX). Splits of missing pieces have no floor (the
 * mesh must conform), so nothing else stops them where facets meet at a
 * small angle and each split makes a piece of the other facet missing:
 * only --max-points, hours away. A refinement that terminates splits
 * few missing pieces, mostly none; the cascade on TetGen's example.poly
 * (fixed, see split_subfac) passed 2,000 in about two seconds. */
#define REF_RECOVERY_PER_VERTEX 5
#define REF_RECOVERY_BASE 2000

/* Sets r->recovery_limit for a refinement starting now. */
void ref_bound_recovery(ref_mesher *r);
/* The splits of missing pieces since ref_bound_recovery. */
size_t ref_recovery_splits(const ref_mesher *r);

/* Sets *o to the defaults: ratio 2, smallest dihedral angle 10 degrees,
 * no size bound, rho 1/(2 sqrt 2), regional volume bounds on, LIFO
 * order, no progress callback, no checks, no trace. */
void ref_default_opts(ref_opts *o);

/* Prepares an empty mesher for PLC p (validated; p must outlive r).
 * Returns 0, PDR_ENOMEM. */
int ref_init(ref_mesher *r, const plc *p, const ref_opts *o);
void ref_free(ref_mesher *r);
/* Frees the refinement's work memory (queues, cavity scratch, edge marks)
 * and keeps the mesh, the boundary and the statistics: a caller that has
 * done refining calls it before ref_export to lower the peak. Afterwards r
 * is good for ref_count_bad, ref_consistency, ref_export and ref_free
 * only. */
void ref_release_work(ref_mesher *r);

/* The constrained recovery's first phase (refine_segrec.c): every missing
 * subsegment of the initial Delaunay tetrahedralization split until all
 * are edges of the mesh, with no facet a constraint yet. Returns 0, or
 * PDR_ELIMIT (the bound o.max_points, or r->stopped_below and r->stop_at
 * when a piece cannot be split), PDR_ENOMEM, PDR_ETOPOLOGY. */
int ref_recover_segments(ref_mesher *r);

/* The constrained recovery's second phase (refine_facrec.c), after the
 * first: every missing subfacet whose edges are edges of the mesh made a
 * face by retriangulating the tetrahedra it crosses (a cavity on each
 * side of it, each filled by the Delaunay tetrahedralization of its
 * vertices when that has every boundary face), with no new vertex and no
 * facet a constraint yet; what cannot be done so is left missing (counted
 * in st.facrec_faces: those recovered). Returns 0 or PDR_ENOMEM. */
int ref_recover_facets(ref_mesher *r);

/* Splits queued subsegments and subfacets (recovery and encroachment)
 * until none is queued; with tets != 0 and the mesh classified, also bad
 * tetrahedra. Stops with PDR_ELIMIT when o.max_points points were
 * inserted (r->last_v is the last one), or when a missing subsegment or
 * subfacet needs a split nearer than min_spacing to a vertex
 * (r->stopped_below, r->stop_at). Returns 0 or PDR_ENOMEM/
 * PDR_ELIMIT/PDR_ETOPOLOGY (also when
 * the option check_each_step finds the tables and the mesh disagree; r is
 * then left as it was after the last step, good for ref_consistency and
 * ref_free). */
int ref_run(ref_mesher *r, int tets);

/* One item of work, as ref_run does it (for a driver with its own loop,
 * the parallel refinement): kind REF_TET (id a tetrahedron), REF_SUBSEG
 * or REF_SUBFACET (id a table index, rmin its floor). Returns 0, REF_SETBACK
 * (the cavity hook gave up: nothing changed, the caller tries again
 * later), or a negative code. */
int ref_step(ref_mesher *r, int kind, uint32_t id, float rmin);
/* Pops the next item, subsegments first, then subfacets, then bad
 * tetrahedra of a classified mesh (skipping stale entries); returns 1
 * with *kind, *id, *rmin set, or 0 when every queue is empty. */
int ref_next(ref_mesher *r, int *kind, uint32_t *id, float *rmin);

/* Calls fn on every tetrahedron around edge ab (an edge of t), starting
 * at t, until fn returns nonzero. Returns that value, 0 when the walk
 * came back to t, or -1 when it met a face with no local neighbour (the
 * domain boundary, or another PE's tetrahedra in a submesh). */
int ref_around_edge(const tm_mesh *m, uint32_t t, uint32_t a, uint32_t b,
                    int (*fn)(const tm_mesh *m, uint32_t t, void *arg), void *arg);
/* Puts an item back on its queue (once, as the queues do). */
int ref_requeue(ref_mesher *r, int kind, uint32_t id, float rmin);
/* Queues interior tetrahedron t if it is bad. Returns 0 or PDR_ENOMEM. */
int ref_check_tet(ref_mesher *r, uint32_t t);
/* A tetrahedron of the mesh with face abc (edge ab when c is TM_NONE),
 * found by walks around the vertices' stars: 1 and *t, or 0 if none. */
int ref_find_local(const ref_mesher *r, uint32_t a, uint32_t b, uint32_t c, uint32_t *t);
/* Ensures the per-tet region array covers every slot of the mesh (for a
 * caller that adds tetrahedra itself). Returns 0 or PDR_ENOMEM. */
int ref_region_room(ref_mesher *r);

/* Flags exterior and hole tetrahedra and assigns regions by flood fill
 * over faces that are not subfacets, from the convex hull, the hole
 * points and the region points (see refine/im.h). *unreached (if not NULL)
 * counts region points outside the domain, each warned about in diag (if
 * not NULL); *changed (if not NULL) counts tetrahedra whose region or
 * exterior flag changed, on a mesh classified before. Returns 0 or
 * PDR_ENOMEM/PDR_ETOPOLOGY. */
int ref_classify(ref_mesher *r, size_t *unreached, size_t *changed, pdr_diag *diag);

/* Deletes the exterior and hole tetrahedra of a classified mesh and puts a
 * ghost on every boundary face, linked around the boundary edges (the
 * constrained mode's carved domain, see refine/refine_cdt.c). Returns 0,
 * PDR_EINVAL (not classified), PDR_ETOPOLOGY (a boundary edge shared by
 * more than two boundary faces) or PDR_ENOMEM. */
int ref_carve(ref_mesher *r);

/* The dt_cavity_search flags of a point's cavity in r: the constrained
 * mode's (constraints not crossed, ghost walls once carved), or 0. */
unsigned ref_cavity_flags(const ref_mesher *r);
/* Makes a carved mesh a constrained Delaunay tetrahedralization again:
 * Lawson's flips over every face, and the subsegments and subfacets next
 * to faces no flip mends queued for splitting (ref_run splits them).
 * Returns 0, PDR_EINVAL (not carved) or PDR_ENOMEM. */
int ref_cdt_restore(ref_mesher *r);

/* The quality refinement of a classified mesh: queues the bad
 * tetrahedra and splits until none is left (or those left are counted);
 * then classifies again and resumes if that moved a tetrahedron. */
int ref_refine(ref_mesher *r);

/* ref_refine for a merged parallel mesh whose flags are right and whose
 * only work is what the PEs left for the merge (ref_stats.left_elsewhere:
 * tetrahedra marked TM_F_QUEUED that no queue holds): queues just those,
 * not every tetrahedron, and classifies again only when a step met a
 * doubt (ref_mesher.region_doubts). */
int ref_refine_marked(ref_mesher *r);

/* Queues every bad interior tetrahedron (after classification). */
int ref_queue_all_tets(ref_mesher *r);

/* Checks every live subsegment and subfacet against the mesh: present
 * ones get their marks, missing and encroached ones (and, with the size
 * options, too large ones) are queued. Used on the initial mesh. */
int ref_queue_boundary(ref_mesher *r);

/* Counts the interior tetrahedra left above the bounds into r->st. */
void ref_count_bad(ref_mesher *r);

/* Checks that the marks on the mesh and the subsegment/subfacet tables
 * agree (every mark is a live, present piece; every present subfacet is a
 * marked face); with REF_CONSIST_REGIONS in what and no subfacet missing,
 * that regions change only across subfacets; in the constrained mode
 * with no boundary split pending, that every face that is no constraint
 * is locally Delaunay, unless what has REF_CONSIST_PART (a PE's part,
 * whose faces next to other PEs or other cavities may wait for the
 * merge). Returns the number of disagreements, each described on log when
 * not NULL. Slow: for tests and debugging. */
#define REF_CONSIST_REGIONS 1
#define REF_CONSIST_PART 2
size_t ref_consistency(const ref_mesher *r, FILE *log, int what);

/* Number of interior (non-exterior, non-ghost) tetrahedra. */
size_t ref_interior_tets(const ref_mesher *r);

/* Number of faces of interior tetrahedra that bound the interior (their
 * other side exterior, a ghost or nothing) without a face mark: each is
 * an inside/outside flag that the classification would change, since the
 * domain's boundary is made of marked faces. One pass over the faces,
 * cheaper than classifying again. */
size_t ref_unmarked_bounds(const ref_mesher *r);

/* After ref_refine, in the sequential constrained mode (nothing without
 * the constrained mode, with parallel hooks, or after a pause): off-centre
 * points for the tetrahedra left above the radius-edge bound, each
 * inserted only where its star leaves fewer of them (refine_offc.c).
 * Not run on the parallel path's merged mesh, where it left a face not
 * locally Delaunay (tests/mesh-cad-parallel.sh, torus-0.3 on 3 PEs).
 * Returns 0 or a negative code. */
int ref_offcentres(ref_mesher *r);

/* Radius-edge ratio and volume of tetrahedron abcd (positively oriented):
 * returns the squared ratio circumradius^2 / shortest-edge^2 (INFINITY if
 * degenerate); *vol, *lmax2 and *cc (circumcentre) when not NULL. */
double ref_tet_ratio2(const double *a, const double *b, const double *c, const double *d,
                      double *vol, double *lmax2, double cc[3]);

/* Radius-edge and dihedral angle ranges of a mesh, in one cheap pass (the
 * summary of 'pdr mesh'; check/ql.h has the full statistics). */
typedef struct ref_quality {
    double re_min, re_max;   /* radius-edge ratio */
    double dih_min, dih_max; /* dihedral angles, degrees */
} ref_quality;

void ref_quality_range(const mesh_export *e, ref_quality *q);

/* ----------------------------------------------------------- export */

/* A finished mesh in the neutral form of the writers: interior
 * tetrahedra, the vertices they use (renumbered from 0), the subfacets
 * with the input facet markers, region attributes. Owns its arrays. */
typedef struct ref_output {
    mesh_export view;      /* borrows the arrays below */
    double (*xyz)[3];
    uint32_t (*tet)[4];
    int *tet_region;       /* NULL without regions */
    double *tet_attr;      /* region attributes as doubles, or NULL */
    uint32_t (*tri)[3];
    int *tri_marker;
    int32_t *tri_facet;    /* input facet index of each triangle */
    uint32_t *vmap;        /* mesh vertex -> output index (UINT32_MAX) */
} ref_output;

int ref_export(const ref_mesher *r, ref_output *out);
/* ref_export for a caller that is done with the mesh: the output's
 * tetrahedra are written over the mesh's own slot array, which out then
 * owns, and the rest of r->m is freed (r->bd, r->st stay). Saves 16 bytes
 * per tetrahedron at the peak. Returns 0 or PDR_ENOMEM (r unchanged). */
int ref_export_take(ref_mesher *r, ref_output *out);
void ref_output_free(ref_output *out);

#endif /* PDR_REFINE_H */
