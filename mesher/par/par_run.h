/*
 * par/par_run.h -- the parallel refinement on one PE (prefix par_run_):
 * the paper's ParRefinement loop (fig. 7) and its Table 1 accounting.
 *
 *   loop: poll the network; yield to the cavity threads;
 *         pop the next item (encroached or missing subsegment, then
 *         subfacet, then bad tetrahedron) and start Refine(item) as a
 *         cooperative thread, while fewer than max_threads run;
 *         stop when libam's termination detection says every PE is idle
 *         and no message is in flight.
 *
 * Refine(item) is the sequential mesher's step (refine/refine.h,
 * ref_step) with the parallel hooks installed: before a cavity is
 * searched, par_cav_gather makes it local (par/par_cav.h); a setback
 * gives the step up without changing anything, and the thread tries the
 * item again after yielding, after a random pause longer than a round
 * trip once it has failed PAR_RUN_BACKOFF_AFTER times in a row (the
 * paper's live-lock guard).
 *
 * Time accounting (DESIGN 5.5), per PE, measured around the code that
 * does each thing, on the monotonic clock:
 *   exec       the whole refinement loop;
 *   completed  compute time of steps that finished (inserted a point, or
 *              split what the point encroached, or gave the item up),
 *              excluding the time their thread was blocked on replies;
 *   setback    compute time of attempts that ended in a setback;
 *   masked     the part of completed (local and distributed steps apart)
 *              computed while at least one other thread of this PE was
 *              blocked waiting for remote data;
 *   service    time in the handlers serving other PEs' cavities;
 *   poll, poll excess, idle: the runtime's own figures (am_stats).
 * With cpu_clock set, completed, masked and setback are read on the PE's
 * CPU-time clock instead (the *_wall fields keep the monotonic ones):
 * where PEs outnumber cores, an interval of a few microseconds on the
 * wall clock now and then holds a whole time slice the kernel gave
 * another PE, which the paper's one PE per machine never saw; the CPU
 * clock counts only this PE's own work. It costs a system call per
 * reading (about 0.8 us here against 30 ns).
 */
#ifndef PDR_PAR_RUN_H
#define PDR_PAR_RUN_H

#include <stddef.h>
#include <stdint.h>

#include "am.h"
#include "par/par_cav.h"
#include "par/par_sub.h"

#define PAR_RUN_BACKOFF_AFTER 3
/* The busy test with busy_reach 0 (PDR_PAR_BUSY_REACH=0): a bad
 * tetrahedron with a cavity's lock at most this many neighbour steps away
 * is put back unstarted (ref_mesher.busy_depth). Measured on cube-in-cube
 * at 10^6 tetrahedra, 16 PEs, 100us-1ms: depth 1 turns 40% of the
 * setbacks into deferrals, depth 3 65%, depth 4 90%; but the walk costs
 * up to 161 tetrahedra per bad one popped, 13% of a PE's time on 2 PEs. */
#define PAR_RUN_BUSY_DEPTH 4
/* The busy test by default (par_run.c, hook_busy): a bad tetrahedron
 * waits when its bounding box, grown by this many times its largest
 * extent, meets the bounding box of the tetrahedra that a cavity in
 * progress holds here (each cavity's box grows with its locks). A few
 * comparisons per cavity in progress. Measured under SCHED_FIFO against
 * the depth-4 walk, cube-in-cube at 10^6: on 2 PEs the refinement 15%
 * faster (0.58-0.62 s against 0.68-0.73 s) and 191 setbacks instead of
 * 1,963; on 16 PEs with 100us-1ms 2,700 setbacks instead of 9,800, the
 * worst PE's tolerance 98.0% instead of 97.0%, as fast. Reach 2 or more
 * holds back most of the work (29 million deferrals, twice the time). */
#define PAR_RUN_BUSY_REACH 0.5
/* The progress bound (issue 12: nothing runs forever). A PE counts its
 * work in units: PAR_RUN_WORK_ATTEMPT per attempt at an item (a step or a
 * setback), one per tetrahedron its cavities import from other PEs and
 * one per tetrahedron its insertions create. Over every stretch of
 * PAR_RUN_STALL_WINDOW units it must insert at least one point per
 * PAR_RUN_STALL_RATIO units, else it stops with PDR_ELIMIT (row->stalled
 * and the stretch's figures), and the others with it: a run that moves
 * tetrahedra back and forth between PEs, retries cavities that keep
 * failing or builds ever larger cavities around a few points goes on no
 * longer than a few windows. Measured: a terminating run spends 30 to 150
 * units per point (cube-in-cube and turbine.off on 2 PEs); turbine.off
 * once spent more than 10,000 (2.4 million tetrahedra migrated for a few
 * hundred points) and another time 2,500 (splits that each made 2,500
 * tetrahedra). A PE that only waits (a message that never comes) does no
 * work and is not caught here, nor one whose splits cascade, each cheap
 * (turbine.off: 323,000 subfacet points on one PE): --max-points bounds
 * each PE's points (row->point_limit). */
#define PAR_RUN_WORK_ATTEMPT 16
/* ... and one unit per this many seconds of an attempt's compute time (its
 * work clock, par_item.work: blocked waits not counted): attempts that
 * each take long count as the work they are. Without it a PE whose every
 * attempt spent some 100 ms in one cavity search (exact insphere tests
 * over thousands of tetrahedra; pinion.off on 2 PEs with --latency) and
 * inserted a point every few seconds went on for minutes: 16 units per
 * attempt fill a stretch in half an hour, and a point now and then resets
 * the clock's leg; now such a PE stops within a minute. A step of an
 * ordinary run takes 1-100 us: at most one unit more. One unit per 10 us
 * also stopped pinion_small.off on 2 PEs, which meshes. */
#define PAR_RUN_WORK_UNIT_S 1e-4
/* A bad tetrahedron whose cavity would bring more than this many
 * tetrahedra from other PEs is left for the merge (par_cav.max_import):
 * rank 0 refines it in the whole mesh. A cavity of cube-in-cube brings at
 * most 27, one of turbine.off 250 when the run goes well; runs of
 * turbine.off on 2 PEs that went on for minutes moved cavities of 2,000
 * to 96,000 tetrahedra back and forth (flat tetrahedra by the boundary,
 * their circumcentres far off), each time for a split that then lay on
 * the other PE. */
#define PAR_RUN_MAX_IMPORT 1024
#define PAR_RUN_STALL_WINDOW 262144.0
#define PAR_RUN_STALL_RATIO 1024.0
/* The bound's other leg, on the clock: a PE that keeps attempting items
 * and inserts no point for this many seconds stops the same way
 * (row->stalled 2). Steps that each take long, and so few units, escape
 * the stretch of units: CGAL's pinion.off on 2 PEs spent some 120 ms per
 * attempt on exact insphere tests of far-off circumcentres and inserted
 * nothing for minutes (about 30 minutes to one stretch). A terminating
 * run inserts a point every few milliseconds, under injected latency
 * too. */
#define PAR_RUN_STALL_SECONDS 60.0
/* The interface band of a 2-PE run (par_band.h): a PE gives its half of
 * the band once its local work is done, which it sees as a window of
 * PAR_RUN_BAND_WINDOW finished steps of which at least one in
 * PAR_RUN_BAND_SHARE needed the other PE (before, about one in 200 does,
 * after, one in two), or as soon as the other PE's half has come. The band
 * reaches PAR_RUN_BAND_MARGIN neighbour steps past the last bad
 * tetrahedron met from the interface; a PE gives at most PAR_RUN_BAND_MAX
 * bands. Measured on cube-in-cube at 10^6, 2 PEs, SCHED_FIFO (margin,
 * bands: refinement s): 2, 1: 0.48-0.51; 3, 1: 0.44-0.54, median 0.47
 * of 25; 4, 1: 0.48-0.50; 6, 1: 0.49-0.51; without: 0.57-0.66. A band of
 * all tetrahedra 10 or 16 steps deep: 0.47-0.52; 24: 0.62-0.70 (150,000
 * tetrahedra moved); four bands 6 deep: 0.59-0.72. */
#define PAR_RUN_BAND_WINDOW 256
#define PAR_RUN_BAND_SHARE 4
#define PAR_RUN_BAND_MAX 1
#define PAR_RUN_BAND_MARGIN 3
/* Chains (par_run.c, refine_thread): a cavity thread whose item is done
 * takes the next one itself while its first item began less than this
 * many seconds ago, instead of ending (pdr mesh: PDR_PAR_CHAIN=SECONDS,
 * negative for none). The loop polls between chains, so this is also
 * how long a reply or request may wait here; it costs little next to a
 * round trip between two busy PEs under --sched fifo (0.2-0.5 ms, most
 * of it ZeroMQ's I/O threads waiting for a core: bench/parallel.md, run
 * 18). 20 us (run 15: three items in four chained on 2 PEs) was about
 * 2-4% slower there than 50 us, which chains about 10 items. */
#define PAR_RUN_CHAIN_S 50e-6
/* Handler ids used by the parallel refinement (5 of them from here). */
#define PAR_RUN_HANDLER_BASE 100

/* One PE's Table 1 row and counts. */
typedef struct par_table1 {
    double exec_s;
    double completed_s;
    double masked_local_s, masked_dist_s;
    double setback_s;
    /* the same three on the monotonic clock (equal without cpu_clock) */
    double completed_wall_s, masked_wall_s, setback_wall_s;
    double service_s;
    double poll_s, poll_excess_s, idle_s;
    uint64_t steps;          /* items finished */
    uint64_t cav_local;      /* attempts whose cavity stayed on this PE */
    uint64_t cav_dist;       /* ... that needed other PEs */
    uint64_t setbacks;       /* attempts that failed (locked or stale) */
    uint64_t backoffs;       /* pauses of the live-lock guard */
    uint64_t tets_in, tets_out; /* tetrahedra migrated in / out */
    uint64_t msgs_sent, bytes_sent;
    uint64_t tets_end;       /* live interior tetrahedra held at the end */
    uint64_t slots_end;      /* tetrahedron slots of the submesh at the end
                                (exterior, ghosts and free ones included) */
    uint64_t peak_rss;       /* the PE's peak resident memory, bytes
                                (getrusage's ru_maxrss; par_run_refine sets
                                it at the end of the refinement, pdr mesh
                                again once the PE's merge messages are
                                sent: the PE holds its submesh and one
                                piece of it encoded at a time then,
                                par_merge_pieces; rank 0's before its
                                merge) */
    uint64_t peak_nonfile;   /* the largest resident memory without file
                                pages of the PE's samples, bytes, each
                                taken with pdr_mem_peak (an estimate of the
                                figure at the peak so far, base/pdr_util.h):
                                at the end of the refinement (set here),
                                and pdr mesh's once the submesh was built,
                                on rank 0 once Mo was cut into the parts'
                                messages, and once the merge messages were
                                sent (rank 0: before it takes its own
                                submesh for the merge). Not more often: a
                                sample is a pass over /proc/self/smaps,
                                whose cost grows with the resident pages
                                (5 ms at 60 MB) */
    uint64_t peak_pss;       /* the largest proportional set size
                                (pdr_mem_sample's pss) of the same samples,
                                bytes */
    uint64_t missing_segs, missing_facs; /* pieces still missing at the end
                                (0 unless the mesh fails to conform) */
    uint64_t deferred;       /* bad tetrahedra put back unstarted, held by
                                a cavity in progress */
    uint64_t cpu_clock;      /* 1: the work times are CPU times */
    uint64_t region_doubts;  /* steps that may have passed on a wrong region
                                or exterior flag (ref_mesher.region_doubts) */
    uint64_t left_elsewhere; /* bad tetrahedra dropped: their split lay on
                                another PE (ref_stats.left_elsewhere) */
    /* The progress bound (PAR_RUN_STALL_WINDOW; not sent to rank 0): */
    uint64_t work;           /* units of work of the whole run */
    uint64_t points;         /* points this PE inserted */
    uint64_t too_big;        /* cavities given up past PAR_RUN_MAX_IMPORT */
    uint64_t bands_out, bands_in; /* bands given and taken (par_band.h) */
    uint64_t band_tets;      /* tetrahedra in the bands given */
    double band_s;           /* picking and sending them (wall clock) */
    uint64_t chained;        /* items a thread went on with (chain_s) */
    int point_limit;         /* 1: stopped after s->r.o.max_points points
                                (of this PE alone: a bound for the job) */
    int stalled;             /* 1: stopped by the bound, after stall_work
                                units that inserted stall_points points;
                                2: after stall_s seconds of attempts that
                                inserted none */
    uint64_t stall_work, stall_points;
    double stall_s;
} par_table1;

typedef struct par_run_opts {
    int max_threads;  /* cavity threads per PE (>= 1) */
    uint64_t seed;    /* random back-off */
    double backoff_s; /* base pause after repeated setbacks (a round trip) */
    int strict_local; /* with REF_ORDER_LOCAL_FIRST: a local step next to
                         the interface counts as remote */
    int order;        /* enum ref_order of the bad tetrahedra (see
                         refine.h: REF_ORDER_LOCAL_FIRST is the default
                         of pdr mesh) */
    int cpu_clock;    /* work times on the CPU clock (see above) */
    double busy_reach; /* the busy test (PAR_RUN_BUSY_REACH; -1: that
                          default; 0: the locks within PAR_RUN_BUSY_DEPTH
                          neighbour steps instead) */
    /* Called about every progress_s seconds while the PE works (NULL:
     * never), with the row so far. */
    void (*progress)(void *arg, const par_sub *s, const par_table1 *row);
    void *progress_arg;
    double progress_s;
    /* The progress bound: units per stretch and units allowed per point
     * (0: PAR_RUN_STALL_WINDOW, PAR_RUN_STALL_RATIO). */
    double stall_window, stall_ratio;
    /* ... and the seconds without a point (0: PAR_RUN_STALL_SECONDS). */
    double stall_seconds;
    /* The interface band (par_band.h): 0 the default (on with 2 PEs,
     * PAR_RUN_BAND_MARGIN), > 0 that margin with 2 PEs, < 0 off. */
    int band_margin;
    int band_max;     /* bands a PE gives at most (0: PAR_RUN_BAND_MAX) */
    int band_share;   /* the trigger's share (0: PAR_RUN_BAND_SHARE) */
    double chain_s;   /* a thread goes on with the next item while its
                         first began less than this ago (0:
                         PAR_RUN_CHAIN_S; < 0: one item per thread) */
} par_run_opts;

/* Latency tolerance masked / (masked + setback), in [0, 1] (1 when
 * neither happened). */
double par_table1_tolerance(const par_table1 *t);
/* The same on the monotonic clock. */
double par_table1_tolerance_wall(const par_table1 *t);

/* Runs the parallel refinement of s on this PE until every PE is done.
 * Collective: every PE of am calls it once, after registering nothing
 * else under the handler ids PAR_RUN_HANDLER_BASE..+4. The submesh must
 * have its work queued (ref_queue_all_tets, ref_queue_boundary). Fills
 * *row. Returns 0 or a negative code (PDR_E* or AM_E*). After a failure
 * cavity threads may still be blocked and the protocol's handlers stay
 * registered: their state is then left allocated (not freed) so that a
 * message arriving before the process ends finds it, and the caller must
 * end the process without am_finalize (which needs every thread ended)
 * and without freeing s; the other PEs see this PE go away. */
int par_run_refine(am_ctx_t *am, par_sub *s, const par_run_opts *o, par_table1 *row);

#endif /* PDR_PAR_RUN_H */
