/*
 * par/par_cav.h -- the distributed cavity: breadth-first parallel search,
 * locking, migration to the origin, abort (prefix par_cav_). DESIGN
 * section 5.3-5.4, the paper's section 4.2.
 *
 * How a cavity that spans PEs is made local ("migrate, then decide"):
 *
 *   1. The origin O (the PE whose thread inserts p) searches the cavity of
 *      p from a local tetrahedron in conflict, locking the cavity and the
 *      ring of tetrahedra around it (its closure) with a lock naming this
 *      cavity (the owner id: O's rank and a counter). Every interface face
 *      met (TM_LINK_REMOTE) becomes a frontier face: (face key, PE).
 *   2. Scatter: one GATHER request per PE with p and its frontier faces.
 *      The PE continues the search from the tetrahedron behind each face:
 *      in conflict, a local search (locking); not in conflict, it locks
 *      that tetrahedron as closure. It replies with copies of its new
 *      cavity tetrahedra (vertices with their refinement data, face
 *      markers, subsegment bits, flags, region, the subsegments and
 *      subfacets on them, and for each face the PE holding the tetrahedron
 *      behind it). Gather; faces of gathered tetrahedra that lead to
 *      another PE and are not yet inside the cavity are the next frontier
 *      (faces leading back to O are searched by O itself). Repeat until
 *      the frontier is empty (the paper's fig. 5).
 *   3. A tetrahedron locked by another cavity, or a frontier face that no
 *      longer exists on the PE named (stale: the tetrahedron moved), makes
 *      the attempt a setback: ABORT to every PE asked releases the locks.
 *   4. Otherwise O imports the gathered tetrahedra into its own mesh,
 *      linking them to each other and to the closure (local links, or new
 *      interface faces to the PE holding the closure tetrahedron), and
 *      sends MIGRATE to every participant: each deletes its cavity
 *      tetrahedra, points its closure faces at O, and unlocks.
 *   5. The cavity is now local to O and still locked by O: the sequential
 *      mesher (refine/) searches it again, decides (ref_decide: commit, or
 *      split an encroached subsegment or subfacet instead) and
 *      retriangulates exactly as it does alone. Encroachment found in the
 *      cavity therefore turns into a split on O of a piece whose
 *      tetrahedra O already holds: migration, not forwarding, because the
 *      decision needs the whole cavity's marks anyway and forwarding would
 *      need a second protocol with its own races.
 *
 * Why no acknowledgement of MIGRATE is awaited: messages between two PEs
 * arrive in the order sent, every tetrahedron involved stays locked until
 * its PE has processed the MIGRATE, and O has imported the cavity before
 * it sends one; so any later request reaching a participant through a
 * changed face either finds the new link or meets a lock (a setback).
 * Termination detection counts the MIGRATE like any message in flight.
 *
 * Ownership: a par_cav belongs to one cooperative thread of the origin;
 * the participant-side records live in par_cav_ctx.
 */
#ifndef PDR_PAR_CAV_H
#define PDR_PAR_CAV_H

#include <stddef.h>
#include <stdint.h>

#include "am.h"
#include "base/hmap.h"
#include "par/par_sub.h"
#include "pr.h"

/* Outcome of par_cav_gather (besides negative error codes). */
enum par_cav_status {
    PAR_CAV_LOCAL = 0,   /* the cavity is local and locked: go on */
    PAR_CAV_SETBACK = 1, /* locked elsewhere or stale: try again later */
    PAR_CAV_SEARCHED = 2, /* local, and the caller's search is done */
    PAR_CAV_TOO_BIG = 3, /* more than max_import tetrahedra to migrate:
                            given up as a setback is (nothing changed) */
};

/* A gathered tetrahedron, as a participant sent it. */
typedef struct par_gtet {
    uint32_t v[4];      /* indices into the cavity's gathered vertices */
    int32_t marker[4];  /* face markers (facet + 1, 0 none) */
    uint32_t nbr[4];    /* PE holding the tetrahedron across face i */
    uint16_t flags;     /* tm/ref flags that travel (see par_cav.c) */
    uint16_t region;    /* region index + 1, 0 none */
    uint32_t src;       /* PE it came from */
} par_gtet;

typedef struct par_gvert {
    uint64_t gid;
    double xyz[3];
    float rins;
    uint32_t feat;
    uint8_t kind;
} par_gvert;

/* A subsegment (nv 2) or subfacet (nv 3) on gathered tetrahedra. */
typedef struct par_gpiece {
    uint32_t v[3];      /* gathered vertex indices (bd orientation) */
    uint32_t feat;      /* input segment or facet */
    uint16_t flags;     /* bd flags */
    uint8_t nv;
} par_gpiece;

struct par_cav_ctx;

/* A growable list of 32-bit values. */
typedef struct par_u32list {
    uint32_t *a;
    size_t n, cap;
} par_u32list;

/* What one PE holds of one cavity: its cavity tetrahedra, the tetrahedra
 * it locked for it (cavity and closure), the closure faces that will face
 * the origin after migration (links towards cavity tetrahedra), and the
 * interface entries of closure faces that led to cavity tetrahedra on
 * other PEs. */
typedef struct par_part {
    par_u32list cav, held, repoint, ifcs;
    /* The bounding box of the held tetrahedra's finite vertices, over
     * held.a[0..boxed) (par_part_box). */
    double lo[3], hi[3];
    size_t boxed;
} par_part;

/* One insertion attempt of one thread of the origin. */
typedef struct par_cav {
    struct par_cav_ctx *cc;
    uint32_t owner;     /* lock owner id of the current attempt, 0 none */
    double p[3];
    par_part own;       /* this PE's part; own.held also lists imported
                           tetrahedra (locked by owner until release) */
    /* gathered from other PEs */
    par_gtet *gt;
    size_t ngt, cap_gt;
    par_gvert *gv;
    size_t ngv, cap_gv;
    hmap gvmap;         /* gid -> gathered vertex index */
    par_gpiece *gp;
    size_t ngp, cap_gp;
    /* faces of the cavity met so far: key hash -> index into face */
    struct par_cav_face *face;
    size_t nface, cap_face;
    hmap facemap;
    struct par_cav_req *req; /* this round's requests */
    size_t nreq, cap_req;
    par_u32list parts;  /* PEs asked in this attempt */
    /* waiting for replies */
    am_future_t *fut;
    int pending;        /* replies still expected this round */
    int failed;         /* first setback status a reply gave, 0 none */
    int err;            /* a reply could not be decoded */
    int distributed;    /* the current attempt involved another PE */
    size_t max_import;  /* set by the caller: an attempt that gathers more
                           tetrahedra from other PEs is given up
                           (PAR_CAV_TOO_BIG); 0 no bound */
    uint32_t slot;      /* index in par_cav_ctx.cavs while waiting, else
                           UINT32_MAX */
} par_cav;

/* Bounding boxes: an empty one, and one grown over the finite vertices
 * of tetrahedron t. */
void par_box_empty(double lo[3], double hi[3]);
void par_box_tet(const tm_mesh *m, uint32_t t, double lo[3], double hi[3]);

/* Extends p's bounding box over the tetrahedra held since the last call
 * (held lists only grow until the part is cleared). */
void par_part_box(const tm_mesh *m, par_part *p);

/* 1 if the box [lo, hi] grown by margin meets the bounding box of the
 * tetrahedra locked on this PE by a cavity in progress: one of this PE's
 * threads waiting for replies, or another PE's cavity served here. */
struct par_cav_ctx;
int par_cav_near_locks(struct par_cav_ctx *cc, const double lo[3], const double hi[3],
                       double margin);

/* Statistics of the protocol on one PE. */
typedef struct par_cav_stats {
    uint64_t gathers_local;   /* attempts that stayed on this PE */
    uint64_t gathers_dist;    /* attempts that needed other PEs */
    uint64_t setbacks_locked, setbacks_stale;
    uint64_t rounds;          /* scatter-gather rounds */
    uint64_t tets_in, tets_out; /* tetrahedra imported / migrated away */
    uint64_t served;          /* GATHER requests served */
    uint64_t too_big;         /* attempts given up past max_import */
    uint64_t bands_out, bands_in; /* bands given (sent) and taken */
} par_cav_stats;

/* Per-PE protocol state: handlers, the participant-side records. */
typedef struct par_cav_ctx {
    am_ctx_t *am;
    par_sub *s;
    unsigned h_gather, h_reply, h_migrate, h_abort, h_band;
    uint32_t seq;        /* counter for owner ids */
    hmap origin;         /* owner -> index into cavs (waiting threads) */
    par_cav **cavs;
    size_t ncavs, cap_cavs;
    hmap served;         /* owner -> index into recs */
    hmap left;           /* tetrahedron slot + 1 -> a check of its vertices:
                            bad tetrahedra left here for the merge
                            (par_cav_mark_left); they travel marked so
                            and are not queued again where they arrive */
    struct par_rec *recs;
    size_t nrecs, cap_recs;
    uint32_t rec_free;
    dt_cavity scratch;   /* searches run by handlers */
    int nblocked_dist;   /* threads blocked waiting for replies */
    double rtt;          /* moving average of a scatter-gather round's
                            wait, seconds (0 until measured) */
    int cat_service;     /* am_category of serving remote requests */
    unsigned search_flags; /* dt_cavity_search flags of every search, with
                            the locking ones (the constrained mode's:
                            ref_cavity_flags) */
    /* Puts an imported piece of work back on this PE's queues: kind 0 a
     * tetrahedron, 1 a subsegment, 2 a subfacet (ids of this PE). */
    int (*requeue)(void *arg, int kind, uint32_t id);
    void *requeue_arg;
    /* Called when the running thread blocks waiting for replies and when
     * it resumes (time accounting); may be NULL. */
    void (*on_block)(void *arg, struct par_cav *c);
    void (*on_resume)(void *arg, struct par_cav *c);
    void *hook_arg;
    par_cav_stats st;
    struct par_cav *band; /* decoding a band another PE gives (on_band);
                            allocated on the first */
    int err;             /* a handler's failure that ends the run (a band
                            half imported), 0 none */
} par_cav_ctx;

/* Registers the protocol's handlers (ids base .. base+4) on this PE. Call
 * on every PE after am_init, before any PE starts refining. s must outlive
 * cc. Returns 0 or a negative code. */
int par_cav_ctx_init(par_cav_ctx *cc, am_ctx_t *am, par_sub *s, unsigned base);
void par_cav_ctx_free(par_cav_ctx *cc);

void par_cav_init(par_cav *c, par_cav_ctx *cc);
void par_cav_free(par_cav *c);

/* From a thread: makes the cavity of p local to this PE, starting from
 * local tetrahedron start, which must be in conflict with p (see the top
 * of this file). Releases the locks of the thread's previous attempt
 * first. Returns PAR_CAV_LOCAL (the cavity and its closure are on this
 * PE, locked by c->owner, until par_cav_release), PAR_CAV_SEARCHED (the
 * same, and the cavity lay on this PE alone: search, if not NULL, holds
 * its pending search from start, ready to commit or abandon),
 * PAR_CAV_SETBACK, PAR_CAV_TOO_BIG (c->max_import), or a negative code. */
int par_cav_gather(par_cav *c, const double p[3], uint32_t start, dt_cavity *search);

/* Records that bad tetrahedron t of this PE is left for the merge (its
 * split lies on another PE; ref_hooks.left): it keeps TM_F_QUEUED, and a
 * cavity that migrates it takes it as left, not as work to queue (see
 * proto/PROTOCOL.md, Reply). Returns 0 or PDR_ENOMEM. */
int par_cav_mark_left(par_cav_ctx *cc, uint32_t t);

/* Hands tetrahedra tets[0..n-1] of this PE (distinct, live, free of
 * locks, their local neighbours free, their interface faces all to PE to)
 * to PE to in one BAND message, as a cavity migrates but with no point to
 * insert: this PE locks them and their local neighbours as a cavity and
 * its closure are locked for another PE, and PE to imports them and
 * answers MIGRATE (this PE deletes them, its faces towards them now face
 * PE to) or ABORT (nothing changes) when a tetrahedron of PE to behind
 * the band belongs to a band of PE to's own. Returns 1 when sent, 0 when
 * tets break a condition (nothing sent), or a negative code. */
int par_cav_give(par_cav_ctx *cc, uint32_t to, const uint32_t *tets, size_t n);
/* The most tetrahedra par_cav_give sends in one band (more: 0, nothing
 * sent); a receiver decodes up to 4 times as many tetrahedra. */
#define PAR_CAV_BAND_MAX ((size_t)1 << 20)

/* Releases every lock the thread's last attempt holds on this PE. */
void par_cav_release(par_cav *c);

/* The tetrahedra part of a REPLY (proto/PROTOCOL.md, after the owner and
 * status), on its own for tests: encode appends tetrahedra tets[0..n-1]
 * of s with their vertices, subsegments and subfacets to b (0 or
 * PDR_ENOMEM); decode adds exactly those bytes to c's gathered lists as
 * sent by PE src (0, PDR_EPARSE on anything malformed or trailing, or
 * PDR_ENOMEM). A par_cav for decoding alone may be initialised with a
 * par_cav_ctx whose am is NULL. */
int par_cav_encode_tets(const par_sub *s, const uint32_t *tets, size_t n, pr_buf *b);
int par_cav_decode_tets(par_cav *c, const void *data, size_t len, uint32_t src);
/* par_cav_encode_tets as cc's PE replies: a tetrahedron it left for the
 * merge (par_cav_mark_left) goes with flag bit 0 set (proto/PROTOCOL.md,
 * Reply). */
int par_cav_encode_left_tets(const par_cav_ctx *cc, const uint32_t *tets, size_t n, pr_buf *b);
/* The body of a BAND after its owner (proto/PROTOCOL.md), on its own for
 * tests: encode appends band tetrahedra tets[0..n-1] of s (distinct, none
 * marked TM_F_CAVITY; marked and unmarked here) and their adjacency to b
 * (0 or PDR_ENOMEM); decode adds exactly those bytes to c's gathered
 * lists and face records as sent by PE src (0, PDR_EPARSE on anything
 * malformed, trailing or an adjacency that is not symmetric or not on
 * the same vertices, PDR_ETOPOLOGY on an outer face towards no PE, or
 * PDR_ENOMEM). c's par_cav_ctx must name the receiving par_sub (its size
 * bounds the PEs a face may lead to); its am may be NULL. */
int par_cav_encode_band(par_sub *s, const uint32_t *tets, size_t n, pr_buf *b);
int par_cav_decode_band(par_cav *c, const void *data, size_t len, uint32_t src);

#endif /* PDR_PAR_CAV_H */
