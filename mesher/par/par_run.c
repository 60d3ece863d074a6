/* par/par_run.c -- the parallel refinement loop on one PE (see
 * par/par_run.h). */
#include "config.h"

#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "base/pdr_util.h"
#include "par/par_band.h"
#include "par/par_run.h"
#include "par/par_verify.h"

/* One cavity thread: the item it refines and its insertion state. */
typedef struct par_item {
    struct par_run *pr;
    int kind;          /* enum ref_kind */
    uint32_t id;
    float rmin;
    par_cav cav;
    double seg_start;  /* start of the current compute segment (work clock) */
    double seg_wall;   /* ... on the monotonic clock */
    double work;       /* compute time of the current attempt */
    double masked;     /* ... of it while another thread was blocked */
    double work_wall, masked_wall; /* the same on the monotonic clock */
    int blocked;       /* waiting for replies */
    int too_big;       /* the step gave up a cavity past PAR_RUN_MAX_IMPORT */
    struct par_item *next_free;
} par_item;

typedef struct par_run {
    am_ctx_t *am;
    par_sub *s;
    par_run_opts o;
    par_cav_ctx cc;
    ref_hooks hooks;
    par_item *current;  /* the thread running now (set on every resume) */
    par_item *free_items;
    int nthreads;
    uint64_t rng;
    par_table1 *row;
    int err;            /* first error of a thread */
    hmap tries;         /* item key -> setbacks in a row (live-lock guard) */
    double next_progress;
    /* the progress bound (PAR_RUN_STALL_WINDOW) */
    uint64_t work, points;  /* units of work and points inserted so far */
    uint64_t win_work, win_points; /* ... when the current stretch began */
    uint64_t seen_in;       /* cc.st.tets_in already counted as work */
    uint64_t clock_points;  /* pr->points when last_point_at was taken */
    double last_point_at;   /* pdr_now() when a point was last seen */
    /* the interface band (par_band.h; 2 PEs) */
    int band_margin;         /* 0: off */
    par_band_cut cut;
    unsigned win_steps, win_dist; /* finished steps in the window, and
                                     those that needed the other PE */
    int band_due;           /* give a band at the next start_work */
    unsigned band_tries;    /* bands picked (given or found empty) */
    par_u32list band;       /* scratch */
} par_run;

static uint64_t item_key(int kind, uint32_t id)
{
    return ((uint64_t)(unsigned)kind << 32 | id) + 1;
}

static double tolerance(double masked, double setback)
{
    double d = masked + setback;
    return d > 0 ? masked / d : 1.0;
}

double par_table1_tolerance(const par_table1 *t)
{
    return tolerance(t->masked_local_s + t->masked_dist_s, t->setback_s);
}

double par_table1_tolerance_wall(const par_table1 *t)
{
    return tolerance(t->masked_wall_s, t->setback_wall_s);
}

static double rnd(par_run *pr)
{
    pr->rng ^= pr->rng << 13;
    pr->rng ^= pr->rng >> 7;
    pr->rng ^= pr->rng << 17;
    return (double)(pr->rng >> 11) / 9007199254740992.0;
}

/* Starts the running thread's compute segment. */
static void segment_start(par_run *pr, par_item *it)
{
    it->seg_wall = pdr_now();
    it->seg_start = pr->o.cpu_clock ? pdr_cpu_now() : it->seg_wall;
}

/* Closes the running thread's compute segment (and starts the next). */
static void segment_end(par_run *pr, par_item *it)
{
    double now = pdr_now(), dw = now - it->seg_wall;
    double cnow = pr->o.cpu_clock ? pdr_cpu_now() : now, d = cnow - it->seg_start;
    it->work += d;
    it->work_wall += dw;
    if (pr->cc.nblocked_dist > 0) {
        it->masked += d;
        it->masked_wall += dw;
    }
    it->seg_wall = now;
    it->seg_start = cnow;
}

/* ------------------------------------------------------------ hooks */

/* 1 if a tetrahedron just outside cavity c has a face on the interface:
 * the new work of such a step is near another PE's, and waits its turn
 * (see REF_ORDER_LOCAL_FIRST). Most cavities have none, so every outer
 * tetrahedron is looked at without branches: a link is an interface
 * face when it is special but not TM_LINK_NONE, that is when link -
 * TM_LINK_SPECIAL (mod 2^32) is below TM_LINK_NONE - TM_LINK_SPECIAL. */
static int near_interface(const tm_mesh *m, const dt_cavity *c)
{
    unsigned hit = 0;
    for (size_t i = 0; i < c->nbnd; i++) {
        tm_link l = c->bnd[i].outer;
        if (tm_is_special(l))
            continue;
        const tm_link *n = m->tets[tm_ltet(l)].n;
        for (int k = 0; k < 4; k++)
            hit |= (unsigned)(n[k] - TM_LINK_SPECIAL < TM_LINK_NONE - TM_LINK_SPECIAL);
    }
    return hit != 0;
}

static int hook_cavity(void *arg, const double p[3], uint32_t start, dt_cavity *c)
{
    par_run *pr = arg;
    par_item *it = pr->current;
    it->cav.max_import = it->kind == REF_TET ? PAR_RUN_MAX_IMPORT : 0;
    int rc = par_cav_gather(&it->cav, p, start, c);
    pr->current = it; /* other threads ran while this one waited */
    if (rc < 0)
        return rc;
    if (rc == PAR_CAV_TOO_BIG) {
        it->too_big = 1;
        return REF_SETBACK;
    }
    if (rc == PAR_CAV_SEARCHED && pr->o.strict_local && near_interface(&pr->s->r.m, c))
        pr->s->r.step_remote = 1;
    return rc == PAR_CAV_SETBACK ? REF_SETBACK : rc == PAR_CAV_SEARCHED ? REF_SEARCHED : 0;
}

static par_item *item_of(par_cav *c)
{
    return (par_item *)(void *)((char *)c - offsetof(par_item, cav));
}

static void on_block(void *arg, par_cav *c)
{
    par_run *pr = arg;
    par_item *it = item_of(c);
    segment_end(pr, it);
    it->blocked = 1;
}

static void on_resume(void *arg, par_cav *c)
{
    par_run *pr = arg;
    par_item *it = item_of(c);
    pr->current = it;
    it->blocked = 0;
    segment_start(pr, it);
}

/* A new vertex v was committed: give it a global id, and point the
 * interface entries of the cavity's remote boundary faces at the new
 * tetrahedra built on them (face 3 of each, see mesh/dt.h). */
static int hook_committed(void *arg, uint32_t v, const dt_cavity *c)
{
    par_run *pr = arg;
    par_sub *s = pr->s;
    pr->points++;
    pr->work += c->nbnd; /* the new tetrahedra */
    tm_mesh *m = &s->r.m;
    uint64_t gid = par_sub_new_gid(s);
    m->gid[v] = gid;
    int rc = par_sub_map_vertex(s, gid, v);
    for (size_t i = 0; i < c->nbnd && c->nremote && !rc; i++) {
        tm_link l = c->bnd[i].outer;
        if (c->bnd[i].reason == DT_BND_REMOTE && l != TM_LINK_NONE)
            s->ifc[l - TM_LINK_SPECIAL].local = tm_mklink(c->newtets[i], 3);
    }
    return rc;
}

static uint32_t hook_owner(void *arg)
{
    par_run *pr = arg;
    return pr->current ? pr->current->cav.owner : 0;
}

/* A flip gave interface face (t, f) a new tetrahedron (constrained mode). */
static void hook_relink(void *arg, tm_link outer, uint32_t t, int f)
{
    par_run *pr = arg;
    pr->s->ifc[outer - TM_LINK_SPECIAL].local = tm_mklink(t, f);
}

/* ref_hooks.busy: the bounding box of t, grown by PAR_RUN_BUSY_REACH times
 * its largest extent, meets that of a cavity in progress here (see
 * PAR_RUN_BUSY_REACH). */
static int hook_busy(void *arg, uint32_t t)
{
    par_run *pr = arg;
    const tm_mesh *m = &pr->s->r.m;
    double lo[3], hi[3];
    par_box_empty(lo, hi);
    par_box_tet(m, t, lo, hi);
    double ext = fmax(hi[0] - lo[0], fmax(hi[1] - lo[1], hi[2] - lo[2]));
    return par_cav_near_locks(&pr->cc, lo, hi, pr->o.busy_reach * ext);
}

/* ref_hooks.left: t is left for the merge (par_cav_mark_left). */
static void hook_left(void *arg, uint32_t t)
{
    par_run *pr = arg;
    if (par_cav_mark_left(&pr->cc, t) && !pr->err)
        pr->err = PDR_ENOMEM;
}

static int requeue(void *arg, int kind, uint32_t id)
{
    par_run *pr = arg;
    ref_mesher *r = &pr->s->r;
    if (kind == 0)
        return ref_check_tet(r, id);
    float rmin = 0;
    const bd_set *bd = &r->bd;
    if (kind == 1 && !(bd->segs[id].flags & BD_F_MISSING))
        rmin = (float)(r->o.rho * fmin(bd->vrins[bd->segs[id].v[0]], bd->vrins[bd->segs[id].v[1]]));
    if (kind == 2 && !(bd->facs[id].flags & BD_F_MISSING)) {
        const uint32_t *v = bd->facs[id].v;
        rmin = (float)(r->o.rho * fmin(bd->vrins[v[0]], fmin(bd->vrins[v[1]], bd->vrins[v[2]])));
    }
    return ref_requeue(r, kind == 1 ? REF_SUBSEG : REF_SUBFACET, id, rmin);
}

/* The refinement's debugging aid (ref_opts.check_each_step) in parallel:
 * the marks against the tables, the facet triangulations and the
 * submesh's links, after every step and before starting new work (which
 * catches what handlers changed). Slow; stops at the first problem. */
static int check_sub(par_run *pr, const char *when)
{
    ref_mesher *r = &pr->s->r;
    if (!r->o.check_each_step)
        return 0;
    par_verify_report rep;
    memset(&rep, 0, sizeof rep);
    size_t bad = ref_consistency(r, r->o.log, 0) + par_verify_facets(pr->s, r->o.log) +
                 par_verify_sub(pr->s, &rep);
    if (!bad)
        return 0;
    if (r->o.log)
        fprintf(r->o.log,
                "PE %u: %zu problems %s (step %llu, %s; links: %zu asymmetric, %zu misoriented, "
                "%zu bad remote, %zu stale interface, %zu open, %zu vertices, %zu counts)\n",
                pr->s->rank, bad, when, (unsigned long long)pr->row->steps,
                r->last_op ? r->last_op : "-", rep.asym_links,
                rep.misoriented, rep.bad_remote, rep.stale_ifaces, rep.open_faces,
                rep.bad_vertices, rep.bad_counts);
    return PDR_ETOPOLOGY;
}

/* ref_interior_tets(r) without reading every tetrahedron: the live ones
 * that are no ghost (m->nlive - m->nghost, kept exact: par_verify_sub
 * checks both) less those flagged exterior, found in the flags (2 bytes
 * a slot instead of the tetrahedra's 32). Taken at the end of the
 * refinement, whose time it counts in. */
static size_t interior_tets(const ref_mesher *r)
{
    const tm_mesh *m = &r->m;
    size_t n = (size_t)m->nlive - m->nghost;
    for (uint32_t t = 0; t < m->nslots; t++)
        if ((m->flags[t] & (TM_F_DEAD | REF_F_EXTERIOR)) == REF_F_EXTERIOR && !tm_is_ghost(m, t))
            n--;
    return n;
}

/* ------------------------------------------------------------ threads */

/* 1 (and row->point_limit) once this PE has inserted r->o.max_points
 * points (--max-points; 0 none): the whole run has then inserted more. */
static int past_point_limit(par_run *pr)
{
    size_t max = pr->s->r.o.max_points;
    if (!max || pr->points < max)
        return 0;
    pr->row->point_limit = 1;
    return 1;
}

/* Counts an attempt at an item, its compute time work_s
 * (PAR_RUN_WORK_UNIT_S) and the tetrahedra imported since the last call
 * as work, and checks the progress bound (PAR_RUN_STALL_WINDOW),
 * and its leg on the clock at now (the attempt's end, read by
 * segment_end: PAR_RUN_STALL_SECONDS): 1 when the stretch that just ended
 * inserted too few points, or no point came for too long (the figures go
 * to the row), else 0. */
static int stalled(par_run *pr, double now, double work_s)
{
    if (pr->points != pr->clock_points) {
        pr->clock_points = pr->points;
        pr->last_point_at = now;
    } else if (now - pr->last_point_at > pr->o.stall_seconds) {
        pr->row->stalled = 2;
        pr->row->stall_s = now - pr->last_point_at;
        pr->row->stall_points = 0;
        return 1;
    }
    pr->work += PAR_RUN_WORK_ATTEMPT + (pr->cc.st.tets_in - pr->seen_in) +
                (uint64_t)(work_s / PAR_RUN_WORK_UNIT_S);
    pr->seen_in = pr->cc.st.tets_in;
    uint64_t w = pr->work - pr->win_work, pts = pr->points - pr->win_points;
    if ((double)w < pr->o.stall_window)
        return 0;
    if ((double)pts * pr->o.stall_ratio < (double)w) {
        pr->row->stalled = 1;
        pr->row->stall_work = w;
        pr->row->stall_points = pts;
        return 1;
    }
    pr->win_work = pr->work;
    pr->win_points = pr->points;
    return 0;
}

/* Counts a finished step for the band's trigger (PAR_RUN_BAND_WINDOW). */
static void count_for_band(par_run *pr, int dist)
{
    pr->win_steps++;
    pr->win_dist += dist != 0;
    if (pr->win_steps < PAR_RUN_BAND_WINDOW)
        return;
    unsigned share = pr->o.band_share > 0 ? (unsigned)pr->o.band_share : PAR_RUN_BAND_SHARE;
    if (pr->win_dist * share >= pr->win_steps &&
        pr->band_tries < (unsigned)(pr->o.band_max > 0 ? pr->o.band_max : PAR_RUN_BAND_MAX))
        pr->band_due = 1;
    pr->win_steps = pr->win_dist = 0;
}

/* Gives this PE's half of the interface band to the other PE (2 PEs). */
static int give_band(par_run *pr)
{
    double t0 = pdr_now();
    uint32_t other = 1 - pr->s->rank;
    pr->band_due = 0;
    pr->band_tries++;
    pr->band.n = 0;
    int rc = par_band_pick(pr->s, &pr->cut, other, pr->band_margin, &pr->band);
    /* Any part of a band is one too: the first ones, nearest the
     * interface, within what a receiver decodes. */
    if (pr->band.n > PAR_CAV_BAND_MAX)
        pr->band.n = PAR_CAV_BAND_MAX;
    if (!rc)
        rc = par_cav_give(&pr->cc, other, pr->band.a, pr->band.n);
    if (rc == 1) {
        pr->row->bands_out++;
        pr->row->band_tets += pr->band.n;
        rc = 0;
    }
    pr->row->band_s += pdr_now() - t0;
    return rc;
}

/* A bad tetrahedron whose step gave up a cavity too large to migrate
 * (PAR_RUN_MAX_IMPORT) is left for the merge, as one whose split lies on
 * another PE is (ref_hooks.left). Returns 0 or PDR_ENOMEM. */
static int leave_too_big(par_run *pr, uint32_t t)
{
    ref_mesher *r = &pr->s->r;
    tm_mesh *m = &r->m;
    pr->row->too_big++;
    if (t >= m->nslots || tm_is_dead(m, t) || tm_is_ghost(m, t) ||
        (m->flags[t] & (REF_F_EXTERIOR | REF_F_GIVEUP | TM_F_QUEUED)))
        return 0;
    m->flags[t] |= TM_F_QUEUED;
    r->st.left_elsewhere++;
    return par_cav_mark_left(&pr->cc, t);
}

/* Refine(item), one item: the paper's Refine with its setbacks. A
 * setback puts the item back on the queue and ends the item (the paper's
 * L.append), so that the PE goes on with other work, away from the
 * cavity that blocked it; once the same item has failed
 * PAR_RUN_BACKOFF_AFTER times in a row, its thread instead pauses for a
 * random time longer than a round trip and tries again itself. The
 * compute segment is open on entry (segment_start, or the previous
 * item's segment_end). Returns 1 when the item is done with (a step, or
 * put back), 0 when the thread must stop (pr->err says why). */
static int refine_item(am_ctx_t *am, par_item *it)
{
    par_run *pr = it->pr;
    par_table1 *row = pr->row;
    uint64_t key = item_key(it->kind, it->id);
    for (;;) {
        pr->current = it;
        it->work = it->masked = it->work_wall = it->masked_wall = 0;
        it->too_big = 0;
        int rc = ref_step(&pr->s->r, it->kind, it->id, it->rmin);
        pr->current = it;
        segment_end(pr, it);
        if (rc == REF_SETBACK && it->too_big)
            rc = leave_too_big(pr, it->id); /* a step done, not a setback */
        int dist = it->cav.distributed;
        par_cav_release(&it->cav);
        uint32_t n = hmap_get(&pr->tries, key);
        if (rc == PDR_ELIMIT && pr->s->r.stopped_below) {
            /* A missing piece whose split here would fall below the
             * resolution floor (refine_run.c, below_resolution; the
             * cavity is abandoned): it stays missing and goes to rank 0
             * with the others (par_merge_add_missing), which recovers it
             * in the whole mesh or stops there with the error. */
            const double *x = pr->s->r.stop_at;
            pdr_line(stderr,
                     "pdr mesh: PE %u: a missing boundary piece near (%.9g, %.9g, %.9g) is "
                     "left to rank 0 (%s)\n",
                     pr->s->rank, x[0], x[1], x[2],
                     pr->s->r.stop_hidden ? "its split has no valid constrained cavity here"
                                          : "its split would fall below the resolution floor here");
            pr->s->r.stopped_below = 0;
            if (n != HMAP_NONE)
                hmap_del(&pr->tries, key, n); /* the item is done here */
            return 0;
        }
        if (rc < 0) {
            if (!pr->err)
                pr->err = rc;
            return 0;
        }
        if (stalled(pr, it->seg_wall, it->work) || past_point_limit(pr)) {
            if (!pr->err)
                pr->err = PDR_ELIMIT;
            return 0;
        }
        if (rc >= 0 && check_sub(pr, rc == REF_SETBACK ? "after a setback" : "after a step")) {
            rc = PDR_ETOPOLOGY;
            if (!pr->err)
                pr->err = rc;
            return 0;
        }
        if (rc != REF_SETBACK) {
            row->completed_s += it->work;
            row->completed_wall_s += it->work_wall;
            row->masked_wall_s += it->masked_wall;
            if (dist)
                row->masked_dist_s += it->masked;
            else
                row->masked_local_s += it->masked;
            row->steps++;
            if (n != HMAP_NONE)
                hmap_del(&pr->tries, key, n);
            if (pr->band_margin)
                count_for_band(pr, dist);
            return 1;
        }
        row->setback_s += it->work;
        row->setback_wall_s += it->work_wall;
        row->setbacks++;
        if (n != HMAP_NONE)
            hmap_del(&pr->tries, key, n);
        n = n == HMAP_NONE ? 1 : n + 1;
        if (hmap_put(&pr->tries, key, n)) {
            pr->err = PDR_ENOMEM;
            return 0;
        }
        if (n < PAR_RUN_BACKOFF_AFTER) {
            rc = ref_requeue(&pr->s->r, it->kind, it->id, it->rmin);
            if (rc && !pr->err)
                pr->err = rc;
            return !rc;
        }
        /* A pause of a few round trips, doubling with each failure in a
         * row (up to 64 times), randomised so that two PEs fighting for
         * the same tetrahedra do not come back together. */
        row->backoffs++;
        double base = fmax(pr->o.backoff_s, 2.0 * pr->cc.rtt);
        unsigned doublings = n - PAR_RUN_BACKOFF_AFTER < 6 ? n - PAR_RUN_BACKOFF_AFTER : 6;
        am_sleep(am, base * (double)(1u << doublings) * (0.5 + rnd(pr)));
        pr->current = it;
        segment_start(pr, it);
    }
}

/* The next item of the PE's queues (ref_next), with the busy test on
 * while locks are about: they exist here only while a thread of this PE
 * waits for replies or another PE's cavity holds some of ours. Returns 1
 * with *kind, *id, *rmin set, 0 when nothing is ready. */
static int pick_item(par_run *pr, int *kind, uint32_t *id, float *rmin)
{
    pr->s->r.busy_depth = pr->cc.nblocked_dist > 0 || pr->cc.served.n > 0 ? PAR_RUN_BUSY_DEPTH : 0;
    return ref_next(&pr->s->r, kind, id, rmin);
}

/* The next item for a thread whose item is done, taken as start_work
 * would take it (with its check between steps), when nothing else is
 * due: no error, no band to give, no progress report (those stay
 * start_work's). Returns 1 with it->kind, id, rmin set, else 0. */
static int chain_item(par_run *pr, par_item *it)
{
    if (pr->err || pr->cc.err || pr->band_due ||
        (pr->band_margin && pr->cc.st.bands_in > 0 && pr->band_tries == 0) ||
        (pr->o.progress && it->seg_wall >= pr->next_progress))
        return 0;
    if (check_sub(pr, "between steps")) {
        pr->err = PDR_ETOPOLOGY;
        return 0;
    }
    return pick_item(pr, &it->kind, &it->id, &it->rmin);
}

/* A cavity thread: refines its item, then, while its first item began
 * less than chain_s ago, goes on with the next one (chain_item) instead
 * of ending and leaving the loop to start a thread for it. A chain
 * saves a thread start and a round of the loop per item, and a clock
 * read: the next item's compute segment starts where the last one ended
 * (segment_end), so the bookkeeping between two items counts in the
 * second's time. The loop polls between chains (at most every POLL_GAP,
 * 20 us), so the bound is also how long a frame for this PE may wait:
 * PAR_RUN_CHAIN_S (par_run.h) weighs that against the loop rounds. */
static void refine_thread(am_ctx_t *am, void *arg)
{
    par_item *it = arg;
    par_run *pr = it->pr;
    pr->current = it;
    segment_start(pr, it);
    double chain_end = it->seg_wall + pr->o.chain_s;
    while (refine_item(am, it) && it->seg_wall < chain_end && chain_item(pr, it))
        pr->row->chained++;
    pr->nthreads--;
    it->next_free = pr->free_items;
    pr->free_items = it;
}

/* The loop's "start new work" step: one thread per item, up to the cap. */
static int start_work(am_ctx_t *am, void *arg)
{
    par_run *pr = arg;
    if (pr->err)
        return pr->err;
    if (check_sub(pr, "between steps"))
        return pr->err = PDR_ETOPOLOGY;
    if (pr->cc.err)
        return pr->err = pr->cc.err;
    /* The other PE gave its half: give ours now, while its cavities
     * still find the interface where they left it. */
    if (pr->band_margin && pr->cc.st.bands_in > 0 && pr->band_tries == 0)
        pr->band_due = 1;
    if (pr->band_due) {
        int rc = give_band(pr);
        if (rc < 0)
            return pr->err = rc;
    }
    if (pr->o.progress) {
        double now = pdr_now();
        if (now >= pr->next_progress) {
            pr->next_progress = now + pr->o.progress_s;
            pr->row->cav_local = pr->cc.st.gathers_local;
            pr->row->cav_dist = pr->cc.st.gathers_dist;
            pr->row->tets_in = pr->cc.st.tets_in;
            pr->row->tets_out = pr->cc.st.tets_out;
            pr->row->bands_in = pr->cc.st.bands_in;
            pr->o.progress(pr->o.progress_arg, pr->s, pr->row);
        }
    }
    if (pr->nthreads >= pr->o.max_threads)
        return 0;
    int kind;
    uint32_t id;
    float rmin;
    if (!pick_item(pr, &kind, &id, &rmin))
        return 0;
    par_item *it = pr->free_items;
    if (it) {
        pr->free_items = it->next_free;
    } else {
        it = pr_calloc(1, sizeof *it);
        if (!it)
            return PDR_ENOMEM;
        it->pr = pr;
        par_cav_init(&it->cav, &pr->cc);
        if (!it->cav.fut) {
            pr_free(it);
            return PDR_ENOMEM;
        }
    }
    it->kind = kind;
    it->id = id;
    it->rmin = rmin;
    int rc = am_thread_spawn(am, refine_thread, it, NULL);
    if (rc) {
        it->next_free = pr->free_items;
        pr->free_items = it;
        return rc;
    }
    pr->nthreads++;
    return 1;
}

int par_run_refine(am_ctx_t *am, par_sub *s, const par_run_opts *o, par_table1 *row)
{
    memset(row, 0, sizeof *row);
    par_run *pr = pr_calloc(1, sizeof *pr);
    if (!pr)
        return PDR_ENOMEM;
    pr->am = am;
    pr->s = s;
    pr->o = *o;
    if (pr->o.max_threads < 1)
        pr->o.max_threads = 1;
    if (pr->o.busy_reach < 0)
        pr->o.busy_reach = PAR_RUN_BUSY_REACH;
    if (!(pr->o.backoff_s > 0))
        pr->o.backoff_s = 200e-6;
    if (!(pr->o.stall_window > 0))
        pr->o.stall_window = PAR_RUN_STALL_WINDOW;
    if (!(pr->o.stall_ratio > 0))
        pr->o.stall_ratio = PAR_RUN_STALL_RATIO;
    if (!(pr->o.stall_seconds > 0))
        pr->o.stall_seconds = PAR_RUN_STALL_SECONDS;
    if (pr->o.chain_s == 0)
        pr->o.chain_s = PAR_RUN_CHAIN_S;
    pr->rng = (o->seed ^ 0x9E3779B97F4A7C15ULL) * (s->rank + 1) | 1;
    pr->row = row;
    int rc = par_cav_ctx_init(&pr->cc, am, s, PAR_RUN_HANDLER_BASE);
    if (rc) {
        pr_free(pr);
        return rc;
    }
    pr->cc.requeue = requeue;
    pr->cc.requeue_arg = pr;
    pr->cc.on_block = on_block;
    pr->cc.on_resume = on_resume;
    pr->cc.hook_arg = pr;
    pr->hooks.cavity = hook_cavity;
    pr->hooks.committed = hook_committed;
    pr->hooks.owner = hook_owner;
    pr->hooks.relink = hook_relink;
    pr->hooks.left = hook_left;
    if (pr->o.busy_reach > 0)
        pr->hooks.busy = hook_busy;
    pr->hooks.arg = pr;
    pr->cc.search_flags = ref_cavity_flags(&s->r);
    /* The band's cut, before any PE changes the interface (the barrier
     * below comes first on the other PE too). */
    if (s->size == 2 && o->band_margin >= 0) {
        pr->band_margin = o->band_margin > 0 ? o->band_margin : PAR_RUN_BAND_MARGIN;
        rc = par_band_cut_init(s, 1 - s->rank, &pr->cut);
        if (rc) {
            par_cav_ctx_free(&pr->cc);
            pr_free(pr);
            return rc;
        }
    }
    s->r.hooks = &pr->hooks;
    /* The order of the bad tetrahedra (o->order). Newest first
     * everywhere (the sequential default, for the cache) makes a PE next
     * to an interface follow it: each insertion there pulls tetrahedra
     * across, whose bad neighbours are then the newest work, and cavities
     * collide and migrate back and forth (measured: 8x the distributed
     * cavities, 25x the setbacks, 7x the time on 2 PEs at 10^6
     * tetrahedra). Oldest first everywhere avoids that but loses the
     * cache. REF_ORDER_LOCAL_FIRST takes the new work of a step whose
     * cavity stayed here newest first, and everything else oldest first:
     * the chase stops at the first distributed cavity. With strict_local
     * a step next to the interface (near_interface) counts as remote
     * too: on 2 PEs at 10^6 tetrahedra that is 30% fewer setbacks than
     * without, and the refinement 20% faster than oldest first. */
    int order = s->r.o.order;
    s->r.o.order = o->order;
    /* The refinement's bound on splits of missing pieces, from now on
     * this PE (refine.h, REF_RECOVERY_PER_VERTEX). */
    ref_bound_recovery(&s->r);
    /* The PEs run the quality refinement (the bad tetrahedra too), as
     * ref_run(r, 1) does sequentially; its rules for that stage depend
     * on the flag (refine_run.c, stuck_past_bound: the bound on the
     * subsegment splits that faces no flip mends ask for). Without it a
     * PE went on splitting those subsegments with no bound: on CAD
     * surfaces (pinion_small.off) the points piled up along segments in
     * thin space, with tens of thousands of tetrahedra between them,
     * each step slower, and the parallel run crawled where the
     * sequential one takes 0.1 s. Each PE has the bound once (its own
     * ref_stats.stuck_quality). */
    int refining = s->r.refining;
    s->r.refining = 1;

    am_stats_t a0, a1;
    /* Every PE has its handlers before anyone sends. */
    rc = am_barrier(am);
    am_stats_get(am, &a0);
    double t0 = pdr_now();
    pr->last_point_at = t0;
    if (!rc)
        rc = am_run_until_done(am, start_work, pr);
    if (!rc && pr->err)
        rc = pr->err;
    row->exec_s = pdr_now() - t0;
    row->cpu_clock = pr->o.cpu_clock != 0;
    row->deferred = s->r.st.deferred;
    row->region_doubts = s->r.region_doubts;
    row->left_elsewhere = s->r.st.left_elsewhere;
    size_t miss_s, miss_f;
    bd_count_missing(&s->r.bd, &miss_s, &miss_f);
    row->missing_segs = miss_s;
    row->missing_facs = miss_f;
    am_stats_get(am, &a1);
    row->poll_s = a1.poll_s - a0.poll_s;
    row->poll_excess_s = a1.poll_excess_s - a0.poll_excess_s;
    row->idle_s = a1.idle_s - a0.idle_s;
    row->msgs_sent = a1.msgs_sent - a0.msgs_sent;
    row->bytes_sent = a1.bytes_sent - a0.bytes_sent;
    row->service_s = am_time_total(am, pr->cc.cat_service);
    row->cav_local = pr->cc.st.gathers_local;
    row->cav_dist = pr->cc.st.gathers_dist;
    row->tets_in = pr->cc.st.tets_in;
    row->tets_out = pr->cc.st.tets_out;
    row->tets_end = interior_tets(&s->r);
    row->slots_end = s->r.m.nslots;
    row->peak_rss = pdr_peak_rss();
    pdr_mem_now mem;
    pdr_mem_peak(&mem); /* a sample (par_run.h) */
    row->peak_nonfile = mem.nonfile;
    row->peak_pss = mem.pss;
    row->work = pr->work;
    row->points = pr->points;
    row->bands_in = pr->cc.st.bands_in;
    if (rc && pr->nthreads > 0)
        return rc; /* see par_run.h: the state stays for the handlers */
    s->r.hooks = NULL;
    s->r.o.order = order;
    s->r.refining = refining;
    hmap_free(&pr->tries);
    pr_free(pr->band.a);
    while (pr->free_items) {
        par_item *it = pr->free_items;
        pr->free_items = it->next_free;
        par_cav_free(&it->cav);
        pr_free(it);
    }
    par_cav_ctx_free(&pr->cc);
    pr_free(pr);
    return rc;
}
