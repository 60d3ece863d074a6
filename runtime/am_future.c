/* am_future.c -- futures, conditions and the wait queues under them.
 *
 * A waiter is a small node on the waiting party's own stack: a blocked
 * thread's stack stays put while it is blocked, and the main context's
 * stack frame lives until its drive loop returns. Waking a thread moves it
 * to the run queue; waking the main context sets a flag its drive loop
 * watches. */
#include "config.h"

#include <stdlib.h>

#include "pr_alloc.h"
#include "am_int.h"

void am__waitq_push(am__waitq *q, am__waiter *w)
{
    w->next = NULL;
    if (q->tail)
        q->tail->next = w;
    else
        q->head = w;
    q->tail = w;
}

void am__waitq_remove(am__waitq *q, am__waiter *w)
{
    am__waiter *prev = NULL;
    for (am__waiter *it = q->head; it; prev = it, it = it->next) {
        if (it != w)
            continue;
        if (prev)
            prev->next = it->next;
        else
            q->head = it->next;
        if (q->tail == it)
            q->tail = prev;
        it->next = NULL;
        return;
    }
}

static void wake(am_ctx_t *ctx, am__waiter *w)
{
    w->woken = 1;
    if (w->thread)
        am__thread_wake(ctx, w->thread);
}

int am__wake_one(am_ctx_t *ctx, am__waitq *q)
{
    am__waiter *w = q->head;
    if (!w)
        return 0;
    q->head = w->next;
    if (!q->head)
        q->tail = NULL;
    w->next = NULL;
    wake(ctx, w);
    return 1;
}

int am__wait_on(am_ctx_t *ctx, am__waitq *q, am__waiter *w)
{
    if (w->thread) {
        am__thread_block(ctx);
        return 0;
    }
    int rc = am__drive(ctx, &w->woken);
    if (!w->woken)
        am__waitq_remove(q, w);
    return rc;
}

/* ---------------------------------------------------------------- futures */

int am_future_new(am_ctx_t *ctx, am_future_t **out)
{
    if (!ctx || !out)
        return AM_EINVAL;
    am_future_t *f = pr_calloc(1, sizeof *f);
    if (!f)
        return AM_ENOMEM;
    f->ctx = ctx;
    *out = f;
    return 0;
}

void am_future_free(am_future_t **f)
{
    if (!f || !*f)
        return;
    /* Freeing a future that a party still waits on would leave a dangling
     * queue; that is a program bug the runtime cannot repair. */
    if ((*f)->waiters.head)
        abort();
    pr_free(*f);
    *f = NULL;
}

int am_future_set(am_future_t *f, void *value)
{
    if (!f)
        return AM_EINVAL;
    if (f->set)
        return AM_ESTATE;
    f->value = value;
    f->set = 1;
    while (am__wake_one(f->ctx, &f->waiters))
        ;
    return 0;
}

int am_future_ready(const am_future_t *f)
{
    return f && f->set;
}

void *am_future_value(const am_future_t *f)
{
    return f && f->set ? f->value : NULL;
}

int am_future_reset(am_future_t *f)
{
    if (!f)
        return AM_EINVAL;
    if (f->waiters.head)
        return AM_ESTATE;
    f->set = 0;
    f->value = NULL;
    return 0;
}

int am_wait(am_ctx_t *ctx, am_future_t *f)
{
    if (!ctx || !f)
        return AM_EINVAL;
    if (f->set)
        return 0;
    int rc = am__may_block(ctx);
    if (rc)
        return rc;
    am__waiter w = {NULL, ctx->sched.current, 0};
    am__waitq_push(&f->waiters, &w);
    rc = am__wait_on(ctx, &f->waiters, &w);
    if (rc)
        return rc;
    return f->set ? 0 : (ctx->failed ? ctx->failed : AM_ESTATE);
}

/* ------------------------------------------------------------- conditions */

int am_cond_new(am_ctx_t *ctx, am_cond_t **out)
{
    if (!ctx || !out)
        return AM_EINVAL;
    am_cond_t *c = pr_calloc(1, sizeof *c);
    if (!c)
        return AM_ENOMEM;
    c->ctx = ctx;
    *out = c;
    return 0;
}

void am_cond_free(am_cond_t **c)
{
    if (!c || !*c)
        return;
    if ((*c)->waiters.head)
        abort();
    pr_free(*c);
    *c = NULL;
}

int am_cond_wait(am_ctx_t *ctx, am_cond_t *c)
{
    if (!ctx || !c)
        return AM_EINVAL;
    int rc = am__may_block(ctx);
    if (rc)
        return rc;
    am__waiter w = {NULL, ctx->sched.current, 0};
    am__waitq_push(&c->waiters, &w);
    return am__wait_on(ctx, &c->waiters, &w);
}

int am_cond_signal(am_cond_t *c)
{
    if (!c)
        return AM_EINVAL;
    am__wake_one(c->ctx, &c->waiters);
    return 0;
}

int am_cond_broadcast(am_cond_t *c)
{
    if (!c)
        return AM_EINVAL;
    while (am__wake_one(c->ctx, &c->waiters))
        ;
    return 0;
}
