/* am_rpc.c -- am_call: a request AM whose handler answers with am_reply;
 * the calling thread blocks (not the PE) until the reply handler wakes it.
 *
 * A pending call lives on the calling thread's stack (valid while it is
 * blocked) and is found by id in a small hash table. Requests and replies
 * are basic messages for termination detection: a PE waiting for a reply
 * has a live thread, so it is not passive anyway, and the reply itself is
 * work in flight. */
#include "config.h"

#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "am_int.h"

static am__call **bucket(am_ctx_t *ctx, uint64_t id)
{
    return &ctx->calls[id % AM__CALL_BUCKETS];
}

static void call_unlink(am_ctx_t *ctx, am__call *c)
{
    for (am__call **pp = bucket(ctx, c->id); *pp; pp = &(*pp)->next)
        if (*pp == c) {
            *pp = c->next;
            return;
        }
}

int am_call(am_ctx_t *ctx, int pe, unsigned id, const void *req, size_t len,
            void **reply, size_t *reply_len)
{
    if (!ctx || pe < 0 || pe >= ctx->size || id >= AM_HANDLER_MAX ||
        (len && !req) || !reply || !reply_len || len > AM_MAX_PAYLOAD - 10)
        return AM_EINVAL;
    *reply = NULL;
    *reply_len = 0;
    int rc = am__may_block(ctx);
    if (rc)
        return rc;
    if (!ctx->sched.current || ctx->state != AM__RUNNING)
        return AM_ESTATE;
    am__call c;
    memset(&c, 0, sizeof c);
    c.id = ++ctx->next_call_id;
    c.w.thread = ctx->sched.current;
    pr_buf b = PR_BUF_INIT;
    am__ctl_begin(&b);
    am__rpc_req_put(&b, c.id, (uint16_t)id, req, len);
    /* Counted by the transport as a message of handler id, len bytes. */
    rc = am__send_ctl_carrying(ctx, pe, AM__CTL_RPC_REQ, &b, id, len);
    pr_buf_free(&b);
    if (rc)
        return rc;
    c.next = *bucket(ctx, c.id);
    *bucket(ctx, c.id) = &c;
    while (!c.done) {
        am__thread_block(ctx);
        if (ctx->failed && !c.done) {
            call_unlink(ctx, &c);
            return ctx->failed;
        }
    }
    *reply = c.reply;
    *reply_len = c.reply_len;
    return 0;
}

int am_reply_to(am_ctx_t *ctx, int pe, uint64_t call_id, const void *data,
                size_t len)
{
    if (!ctx || pe < 0 || pe >= ctx->size || call_id == 0 || (len && !data) ||
        len > AM_MAX_PAYLOAD - 8)
        return AM_EINVAL;
    if (ctx->failed)
        return ctx->failed;
    pr_buf b = PR_BUF_INIT;
    am__ctl_begin(&b);
    am__rpc_rep_put(&b, call_id, data, len);
    int rc = am__send_ctl_carrying(ctx, pe, AM__CTL_RPC_REP, &b,
                                   AM__USER_REPLY, len);
    pr_buf_free(&b);
    return rc;
}

int am_reply(am_ctx_t *ctx, const am_msg_t *msg, const void *data, size_t len)
{
    if (!msg || msg->call_id == 0)
        return AM_EINVAL;
    return am_reply_to(ctx, msg->src, msg->call_id, data, len);
}

/* An RPC request is delivered to its user handler like an AM, with its
 * call id for am_reply. */
static void on_request(am_ctx_t *ctx, int src, pr_reader *body)
{
    am__rpc_msg m;
    if (am__rpc_req_get(body, &m)) {
        am__term_on_deliver(ctx); /* it was counted when sent */
        am__reject(ctx, AM__REJ_BODY, src, "malformed call");
        return;
    }
    am__deliver_user(ctx, src, m.handler, m.payload.p, m.payload.len,
                     m.call_id);
}

/* A reply wakes the thread blocked in am_call, which owns the copy. */
static void on_reply(am_ctx_t *ctx, int src, pr_reader *body)
{
    am__rpc_msg m;
    am__term_on_deliver(ctx);
    ctx->delivered++;
    if (am__rpc_rep_get(body, &m)) {
        am__reject(ctx, AM__REJ_BODY, src, "malformed reply");
        return;
    }
    am__call *c = *bucket(ctx, m.call_id);
    while (c && c->id != m.call_id)
        c = c->next;
    if (!c || c->done) {
        am__reject(ctx, AM__REJ_BODY, src, "reply to no pending call");
        return;
    }
    ctx->rpc_reply_st.recv++;
    ctx->rpc_reply_st.recv_bytes += m.payload.len;
    if (m.payload.len) {
        c->reply = pr_malloc(m.payload.len);
        if (!c->reply) {
            am__fail(ctx, AM_ENOMEM, "out of memory receiving a reply");
            return;
        }
        memcpy(c->reply, m.payload.p, m.payload.len);
    }
    c->reply_len = m.payload.len;
    c->done = 1;
    call_unlink(ctx, c);
    am__thread_wake(ctx, c->w.thread);
}

/* Requests and replies are basic messages (see the top of this file). */
const am__ctl_entry am__rpc_ctls[] = {
    {AM__CTL_RPC_REQ, "rpc_request", AM__CTLF_BASIC, on_request},
    {AM__CTL_RPC_REP, "rpc_reply", AM__CTLF_BASIC, on_reply},
    {0, NULL, 0, NULL},
};
