/* am_timer.c -- one-shot timers and am_sleep, on libevent timers.
 *
 * The context counts armed timers: am_poll runs libevent's non-blocking
 * pass only while some timer is armed (otherwise there is nothing it could
 * fire, and the system call is saved), and armed user timers and sleeping
 * threads keep the PE active for termination detection. */
#include "config.h"

#include <math.h>
#include <stdlib.h>

#include "pr_alloc.h"
#include "am_int.h"

void am__timer_armed(am_ctx_t *ctx, int user, int delta)
{
    ctx->timers_armed += delta;
    if (user)
        ctx->user_timers_armed += delta;
}

static struct timeval to_timeval(double seconds)
{
    struct timeval tv;
    if (!(seconds > 0))
        seconds = 0;
    double whole = floor(seconds);
    tv.tv_sec = (time_t)whole;
    tv.tv_usec = (suseconds_t)((seconds - whole) * 1e6 + 0.5);
    if (tv.tv_usec >= 1000000) {
        tv.tv_sec++;
        tv.tv_usec -= 1000000;
    }
    return tv;
}

static void timer_free_now(am_timer_t *t)
{
    if (t->armed)
        am__timer_armed(t->ctx, 1, -1);
    event_free(t->ev);
    pr_free(t);
}

static void timer_cb(evutil_socket_t fd, short what, void *arg)
{
    (void)fd;
    (void)what;
    am_timer_t *t = arg;
    am_ctx_t *ctx = t->ctx;
    t->armed = 0;
    am__timer_armed(ctx, 1, -1);
    ctx->delivered++;
    double t0 = am__now();
    t->in_callback = 1;
    ctx->in_callback++;
    t->fn(ctx, t, t->arg);
    ctx->in_callback--;
    t->in_callback = 0;
    ctx->st.handler_s += am__now() - t0;
    if (t->free_later)
        timer_free_now(t);
}

int am_timer_new(am_ctx_t *ctx, am_timer_fn fn, void *arg, am_timer_t **out)
{
    if (!ctx || !fn || !out)
        return AM_EINVAL;
    am_timer_t *t = pr_calloc(1, sizeof *t);
    if (!t)
        return AM_ENOMEM;
    t->ctx = ctx;
    t->fn = fn;
    t->arg = arg;
    t->ev = evtimer_new(ctx->base, timer_cb, t);
    if (!t->ev) {
        pr_free(t);
        return AM_ENOMEM;
    }
    *out = t;
    return 0;
}

int am_timer_start(am_timer_t *t, double seconds)
{
    if (!t || !(seconds >= 0) || t->free_later)
        return AM_EINVAL;
    struct timeval tv = to_timeval(seconds);
    if (evtimer_add(t->ev, &tv) != 0)
        return AM_ESYS;
    if (!t->armed) {
        t->armed = 1;
        am__timer_armed(t->ctx, 1, +1);
    }
    return 0;
}

int am_timer_stop(am_timer_t *t)
{
    if (!t)
        return AM_EINVAL;
    if (t->armed) {
        evtimer_del(t->ev);
        t->armed = 0;
        am__timer_armed(t->ctx, 1, -1);
    }
    return 0;
}

void am_timer_free(am_timer_t **tp)
{
    if (!tp || !*tp)
        return;
    am_timer_t *t = *tp;
    *tp = NULL;
    am_timer_stop(t);
    if (t->in_callback)
        t->free_later = 1;
    else
        timer_free_now(t);
}

/* ------------------------------------------------------------------ sleep */

static void sleep_thread_cb(evutil_socket_t fd, short what, void *arg)
{
    (void)fd;
    (void)what;
    am__thread *t = arg;
    am__timer_armed(t->ctx, 1, -1);
    t->ctx->delivered++;
    am__thread_wake(t->ctx, t);
}

static void sleep_main_cb(evutil_socket_t fd, short what, void *arg)
{
    (void)fd;
    (void)what;
    *(int *)arg = 1;
}

int am_sleep(am_ctx_t *ctx, double seconds)
{
    if (!ctx || !(seconds >= 0))
        return AM_EINVAL;
    int rc = am__may_block(ctx);
    if (rc)
        return rc;
    struct timeval tv = to_timeval(seconds);
    am__thread *t = ctx->sched.current;
    if (t) {
        if (!t->sleep_ev) {
            t->sleep_ev = evtimer_new(ctx->base, sleep_thread_cb, t);
            if (!t->sleep_ev)
                return AM_ENOMEM;
        }
        if (evtimer_add(t->sleep_ev, &tv) != 0)
            return AM_ESYS;
        am__timer_armed(ctx, 1, +1);
        am__thread_block(ctx);
        return 0;
    }
    int fired = 0;
    struct event *ev = evtimer_new(ctx->base, sleep_main_cb, &fired);
    if (!ev)
        return AM_ENOMEM;
    if (evtimer_add(ev, &tv) != 0) {
        event_free(ev);
        return AM_ESYS;
    }
    am__timer_armed(ctx, 1, +1);
    rc = am__drive(ctx, &fired);
    if (!fired)
        evtimer_del(ev);
    am__timer_armed(ctx, 1, -1);
    event_free(ev);
    return rc;
}
