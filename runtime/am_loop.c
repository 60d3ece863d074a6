/* am_loop.c -- the PE's loop: am_poll, am_idle, the drive loop behind
 * blocking calls of the main context, am_quiescent and am_run_until_done.
 *
 * libevent (2.1: no prepare/check watchers) watches three things: the
 * ROUTER's ZMQ_FD, the socket monitor's fd, and every timer (user timers,
 * sleeping threads, latency-delayed deliveries). The event callbacks on
 * the two fds do no work of their own: they only end the blocking wait.
 * The loop then polls, and am_poll drains the socket until ZMQ_EVENTS says
 * nothing is left (or the budget is spent). Re-reading ZMQ_EVENTS before
 * every block is what event_active() re-arming would give, but it lets
 * libevent return to the scheduler after each wake-up even while a flood
 * of frames keeps arriving, so threads are never starved by the network.
 *
 * Flush points of send coalescing (am_transport.c): frames sent since the
 * last one leave when am_poll starts (before new frames are handled) and
 * ends (the handlers' answers), before am_idle blocks, and at the end of
 * every round of am_run_until_done (the threads' and the work function's
 * frames), so that a frame waits at most for the rest of the round in
 * which it was sent, and never while the PE sleeps. Flushing only at
 * polls would let frames wait through the rounds that skip the poll
 * (POLL_GAP) for a few more bundles: on the 2-PE refinement 2.7 frames
 * per ZeroMQ message instead of 2.3, at up to 20 us more per frame. A PE
 * with queued frames is not passive (am_quiescent).
 *
 * Accounting: am_poll's own time (minus the handlers it runs) is poll
 * time, and polls that delivered nothing are excess poll time; time spent
 * blocked in libevent is idle time. Two clock reads per poll.
 */
#include "config.h"

#include <math.h>

#include "am_int.h"

/* Longest single block in libevent: a safety net, so that even an edge
 * ZeroMQ never signalled cannot park the PE for long. */
#define IDLE_SLICE 0.25
/* Housekeeping (socket monitor, suspected peers) period while busy. */
#define HOUSEKEEPING 0.05
/* am_run_until_done: after a poll that found nothing, the next one waits
 * this long while there is work to start (a cavity step is 5-15 us; a
 * poll about 3 us, mostly ZeroMQ asking its mailbox). */
#define POLL_GAP 20e-6

static void wake_cb(evutil_socket_t fd, short what, void *arg)
{
    (void)fd;
    (void)what;
    (void)arg;
}

static void mon_cb(evutil_socket_t fd, short what, void *arg)
{
    (void)fd;
    (void)what;
    am_ctx_t *ctx = arg;
    ctx->next_housekeeping = 0;
}

int am__loop_init(am_ctx_t *ctx)
{
    struct event_config *cfg = event_config_new();
    if (!cfg)
        return AM_ENOMEM;
    /* Without PRECISE_TIMER libevent 2.1 reads a coarse clock (ms steps)
     * and rounds epoll timeouts to ms: 200 us of injected latency would
     * be noise. With it, the epoll backend uses a timerfd. */
    event_config_set_flag(cfg, EVENT_BASE_FLAG_PRECISE_TIMER);
    event_config_set_flag(cfg, EVENT_BASE_FLAG_NOLOCK);
    ctx->base = event_base_new_with_config(cfg);
    event_config_free(cfg);
    if (!ctx->base)
        return AM_ENOMEM;
    ctx->wake_ev = evtimer_new(ctx->base, wake_cb, ctx);
    if (!ctx->wake_ev)
        return AM_ENOMEM;
    return 0;
}

/* Watches the sockets' fds; called once the transport is open. */
int am__loop_watch(am_ctx_t *ctx)
{
    if (!ctx->sock)
        return 0;
    ctx->events_stale = 1; /* the boot used the socket without us */
    ctx->zmq_ev = event_new(ctx->base, ctx->zfd, EV_READ | EV_PERSIST, wake_cb,
                            ctx);
    int mfd;
    size_t len = sizeof mfd;
    if (!ctx->zmq_ev || event_add(ctx->zmq_ev, NULL) != 0 ||
        zmq_getsockopt(ctx->mon, ZMQ_FD, &mfd, &len) != 0)
        return AM_ENOMEM;
    ctx->mon_ev = event_new(ctx->base, mfd, EV_READ | EV_PERSIST, mon_cb, ctx);
    if (!ctx->mon_ev || event_add(ctx->mon_ev, NULL) != 0)
        return AM_ENOMEM;
    return am__shm_watch(ctx);
}

void am__loop_free(am_ctx_t *ctx)
{
    if (ctx->zmq_ev)
        event_free(ctx->zmq_ev);
    if (ctx->mon_ev)
        event_free(ctx->mon_ev);
    if (ctx->wake_ev)
        event_free(ctx->wake_ev);
    ctx->zmq_ev = ctx->mon_ev = ctx->wake_ev = NULL;
    if (ctx->base)
        event_base_free(ctx->base);
    ctx->base = NULL;
}

int am__may_block(const am_ctx_t *ctx)
{
    if (ctx->failed)
        return ctx->failed;
    if (ctx->in_callback)
        return AM_ESTATE;
    return 0;
}

int am__has_ready_work(const am_ctx_t *ctx)
{
    return ctx->sched.runq_n > 0 || ctx->loopback.n > 0 ||
           (ctx->early.n > 0 && ctx->state == AM__RUNNING) ||
           (ctx->deferred.n > 0 && !ctx->term.defer);
}

static int main_context_only(const am_ctx_t *ctx)
{
    if (!ctx)
        return AM_EINVAL;
    if (ctx->sched.current || ctx->in_callback)
        return AM_ESTATE;
    return ctx->failed;
}

/* Frames that need no network: the boot stash, deferred basic messages
 * (once deferral ended) and messages this PE sent itself. */
static void poll_local(am_ctx_t *ctx)
{
    am__frame *f;
    /* Frames that came during the boot go through latency injection like
     * any other (they were not delayed yet). */
    while (ctx->state == AM__RUNNING && (f = am__fifo_pop(&ctx->early))) {
        if (ctx->lat.on)
            am__latency_enqueue(ctx, f);
        else
            am__arrive(ctx, f);
    }
    /* A handler may declare termination again (TERMINATE of the next
     * epoch cannot overtake these, but the check is cheap). */
    while (!ctx->term.defer && (f = am__fifo_pop(&ctx->deferred))) {
        am__dispatch(ctx, f);
        am__frame_free(f);
    }
    /* Only what is queued now: a handler that sends to its own PE must not
     * keep this poll going for ever. */
    for (size_t n = ctx->loopback.n; n > 0 && (f = am__fifo_pop(&ctx->loopback));
         n--)
        am__arrive(ctx, f);
}

int am_poll(am_ctx_t *ctx)
{
    int rc = main_context_only(ctx);
    if (rc)
        return rc;
    double t0 = am__now();
    double h0 = ctx->st.handler_s;
    uint64_t d0 = ctx->delivered;
    if (ctx->sendq_total)
        am__flush_sendq(ctx);
    poll_local(ctx);
    if (ctx->sock)
        am__recv_poll(ctx, ctx->poll_budget);
    /* NONBLOCK alone would loop for as long as some event is active, and
     * the ZMQ_FD stays readable until ZeroMQ processes its commands: ONCE
     * makes it a single pass over due timers. */
    if (ctx->timers_armed > 0)
        event_base_loop(ctx->base, EVLOOP_NONBLOCK | EVLOOP_ONCE);
    if (ctx->sendq_total)
        am__flush_sendq(ctx);
    if (ctx->sock && t0 >= ctx->next_housekeeping) {
        am__check_peers(ctx);
        ctx->next_housekeeping = t0 + HOUSEKEEPING;
    }
    double spent = am__now() - t0 - (ctx->st.handler_s - h0);
    int n = (int)(ctx->delivered - d0);
    ctx->st.polls++;
    ctx->st.poll_s += spent;
    if (n == 0) {
        ctx->st.polls_empty++;
        ctx->st.poll_excess_s += spent;
    }
    return ctx->failed ? ctx->failed : n;
}

int am_idle(am_ctx_t *ctx, double max_seconds)
{
    int rc = main_context_only(ctx);
    if (rc)
        return rc;
    if (am__has_ready_work(ctx))
        return 0;
    /* Nothing may wait for a flush while the PE sleeps. Before the edge
     * check: a send may eat the edge. */
    if (ctx->sendq_total)
        am__flush_sendq(ctx);
    /* The edge rule: a send since the socket was last seen empty may have
     * consumed the ZMQ_FD edge of frames that are already waiting; then
     * ZMQ_EVENTS must be read again (a system call, so only then). */
    if (ctx->events_stale && am__socket_readable(ctx)) {
        /* The next poll reads it, even inside the rings' ZeroMQ gap
         * (am__recv_poll): else the loop would come back here, find it
         * again and not block, until the gap ended. */
        ctx->zmq_next = 0;
        return 0;
    }
    /* The rings: writers are told to wake this PE from now on, then the
     * rings are looked at once more (am_shm.c, "no lost wake-up"). */
    if (am__shm_sleep_begin(ctx))
        return 0;
    double slice = ctx->suspects ? HOUSEKEEPING : IDLE_SLICE;
    if (max_seconds >= 0 && max_seconds < slice)
        slice = max_seconds;
    struct timeval tv;
    tv.tv_sec = (time_t)slice;
    tv.tv_usec = (suseconds_t)((slice - floor(slice)) * 1e6);
    evtimer_add(ctx->wake_ev, &tv);
    double t0 = am__now();
    double h0 = ctx->st.handler_s;
    event_base_loop(ctx->base, EVLOOP_ONCE);
    ctx->st.idle_s += am__now() - t0 - (ctx->st.handler_s - h0);
    evtimer_del(ctx->wake_ev);
    am__shm_sleep_end(ctx);
    return ctx->failed;
}

int am__drive(am_ctx_t *ctx, const int *flag)
{
    while (!*flag) {
        int rc = am_poll(ctx);
        if (rc < 0)
            return rc;
        if (*flag)
            break;
        rc = am_run_threads(ctx);
        if (rc < 0)
            return rc;
        if (*flag)
            break;
        if (!am__has_ready_work(ctx) && (rc = am_idle(ctx, -1)) < 0)
            return rc;
    }
    return ctx->failed;
}

int am_quiescent(am_ctx_t *ctx, int passive)
{
    int rc = main_context_only(ctx);
    if (rc)
        return rc;
    passive = passive && ctx->sched.live == 0 && ctx->user_timers_armed == 0 &&
              !am__has_ready_work(ctx) && ctx->sendq_total == 0 &&
              ctx->held_total == 0;
    if (!am__term_step(ctx, passive))
        return ctx->failed;
    /* Declared. The barrier makes every PE leave together; until it ends,
     * basic messages (which can only be the next epoch's, sent by a PE
     * that already left) wait in the deferred queue. */
    rc = am_barrier(ctx);
    ctx->term.declared = 0;
    ctx->term.defer = 0;
    ctx->term.epoch++;
    return rc ? rc : 1;
}

int am_run_until_done(am_ctx_t *ctx, am_work_fn work, void *arg)
{
    int rc = main_context_only(ctx);
    if (rc)
        return rc;
    /* Poll every time round, except shortly after an empty poll while
     * work keeps being started: then the loop would mostly pay for
     * finding nothing. */
    double next_poll = 0;
    int started = 0;
    for (;;) {
        if (!started || next_poll == 0 || am__now() >= next_poll) {
            if ((rc = am_poll(ctx)) < 0)
                return rc;
            next_poll = rc == 0 ? am__now() + POLL_GAP : 0;
        }
        if ((rc = am_run_threads(ctx)) < 0)
            return rc;
        started = 0;
        if (work && !ctx->term.declared) {
            started = work(ctx, arg);
            if (started < 0)
                return started;
        }
        /* The round's frames leave before the PE reports passivity. */
        if (ctx->sendq_total && (rc = am__flush_sendq(ctx)) < 0)
            return rc;
        rc = am_quiescent(ctx, started == 0);
        if (rc < 0)
            return rc;
        if (rc == 1)
            return 0;
        if (!started && !am__has_ready_work(ctx) && (rc = am_idle(ctx, -1)) < 0)
            return rc;
    }
}
