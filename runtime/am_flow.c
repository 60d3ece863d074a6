/* am_flow.c -- flow control: bounded send windows with credits, senders
 * that wait for room, and a bounded queue for the sends of callbacks.
 *
 * Without it a PE that many PEs flood grows without bound: ZeroMQ's pipes
 * (high-water marks unlimited, so that no frame is ever dropped) take every
 * frame the peers write, long before the PE's handlers run them, and a
 * bandwidth-capped latency queue does the same. So each ordered pair of
 * PEs has a window: the sender may have at most send_window bytes of basic
 * frames (user AMs, RPC requests and replies; a frame costs its size plus
 * FRAME_EXTRA) that the receiver has not dispatched yet. The receiver adds
 * up what it dispatched from each peer and hands it back in a CREDIT frame
 * once that reaches half the window; the sender's window shrinks by that
 * much. So all that waits for a receiver anywhere (ZeroMQ's pipes and the
 * kernel's buffers, the latency queue, the boot stash, the deferred queue)
 * is bounded by its peers' windows.
 *
 * A frame may enter the window when it fits, or when at most half of the
 * window is in use (a frame larger than the window must go some time; it
 * then goes alone). Progress: a sender that waits has more than half a
 * window in flight; once the receiver dispatched all of it, the receiver's
 * uncredited sum has passed half the window, so a CREDIT was sent. CREDIT
 * and the other non-basic control frames never wait for a window, so
 * credits cannot be stuck behind data: two PEs flooding each other cannot
 * deadlock, as long as each keeps polling -- and every PE polls while its
 * threads wait, because waiting is the threads' and the main context's
 * alone: callbacks (handlers, timers) must not block, and their sends wait
 * in the peer's held queue instead, within send_queue bytes, beyond which
 * am_send refuses them with AM_EFULL. Frames leave the held queue in order,
 * and no new frame to that peer overtakes them. Both sides must use the
 * same window (the receiver's threshold is half of its own).
 *
 * Non-basic control frames (termination tokens, collectives, BYE, CREDIT
 * itself) may thus overtake held data. Nothing relies on the opposite:
 * Safra's algorithm counts messages, not their order; a PE with held frames
 * is not passive; am_finalize lets every held frame go before its BYE.
 */
#include "config.h"

#include <ctype.h>
#include <errno.h>
#include <stdlib.h>

#include "am_int.h"

/* What a frame costs on top of its size: ZeroMQ's message and pipe
 * entries and the runtime's queue node, about 64 bytes in all. A frame's
 * size is PR_HEADER_SIZE + payload, so a user message costs its payload
 * plus AM_MSG_OVERHEAD. */
#define FRAME_EXTRA ((size_t)AM_MSG_OVERHEAD - PR_HEADER_SIZE)

static size_t cost_of(size_t size)
{
    return size + FRAME_EXTRA;
}

int am__bytes_parse(const char *spec, size_t *out)
{
    if (!spec || !isdigit((unsigned char)*spec))
        return AM_EINVAL;
    char *end;
    errno = 0;
    unsigned long long v = strtoull(spec, &end, 10);
    unsigned shift = 0;
    switch (*end) {
    case 'k': case 'K': shift = 10; end++; break;
    case 'm': case 'M': shift = 20; end++; break;
    case 'g': case 'G': shift = 30; end++; break;
    default: break;
    }
    if (shift && (*end == 'i' || *end == 'I') && end[1] == 'B')
        end += 2;
    else if (shift && *end == 'B')
        end++;
    if (errno || *end || v > (1ULL << 40) >> shift)
        return AM_EINVAL;
    *out = (size_t)(v << shift);
    return 0;
}

/* pe's window has room for a frame of cost c. */
static int room(const am_ctx_t *ctx, const am__peer *p, size_t c)
{
    return p->win_used + c <= ctx->send_window ||
           p->win_used <= ctx->send_window / 2;
}

/* A new frame of cost c may enter pe's window now: nothing held before it. */
static int fits(const am_ctx_t *ctx, const am__peer *p, size_t c)
{
    return p->heldq.n == 0 && room(ctx, p, c);
}

int am__flow_reserve(am_ctx_t *ctx, int pe, size_t size)
{
    am__peer *p = &ctx->peers[pe];
    size_t c = cost_of(size);
    if (!fits(ctx, p, c)) {
        if (ctx->in_callback) {
            if (p->held_bytes + c > ctx->send_queue)
                return AM_EFULL;
            return 1;
        }
        int rc = am__may_block(ctx);
        if (rc)
            return rc;
        double t0 = am__now();
        ctx->st.send_waits++;
        while (!fits(ctx, p, c)) {
            am__waiter w = {NULL, ctx->sched.current, 0};
            am__waitq_push(&p->roomq, &w);
            rc = am__wait_on(ctx, &p->roomq, &w);
            if (!rc && ctx->failed)
                rc = ctx->failed;
            if (rc) {
                ctx->st.send_wait_s += am__now() - t0;
                return rc;
            }
        }
        ctx->st.send_wait_s += am__now() - t0;
    }
    p->win_used += c;
    return 0;
}

void am__flow_unreserve(am_ctx_t *ctx, int pe, size_t size)
{
    am__peer *p = &ctx->peers[pe];
    size_t c = cost_of(size);
    p->win_used = p->win_used > c ? p->win_used - c : 0;
}

int am__flow_hold(am_ctx_t *ctx, int pe, const pr_header *h, zmq_msg_t *msg)
{
    am__frame *f = am__frame_new();
    if (!f)
        return AM_ENOMEM;
    am__peer *p = &ctx->peers[pe];
    zmq_msg_move(&f->msg, msg);
    f->hdr = *h;
    f->src = pe;
    am__fifo_push(&p->heldq, f);
    p->held_bytes += cost_of(zmq_msg_size(&f->msg));
    ctx->held_total++;
    ctx->st.held_sends++;
    return 0;
}

/* pe handed back bytes of its window (or this PE dispatched its own
 * frames): held frames go out while they fit, then the waiting senders
 * are woken to try again. */
static void grant(am_ctx_t *ctx, int pe, size_t bytes)
{
    am__peer *p = &ctx->peers[pe];
    p->win_used = p->win_used > bytes ? p->win_used - bytes : 0;
    am__frame *f;
    while ((f = p->heldq.head) && !ctx->failed) {
        size_t c = cost_of(zmq_msg_size(&f->msg));
        if (!room(ctx, p, c))
            break;
        am__fifo_pop(&p->heldq);
        p->held_bytes -= c;
        ctx->held_total--;
        p->win_used += c;
        if (am__hand_over(ctx, pe, &f->hdr, &f->msg)) {
            p->win_used -= c;
            am__fail(ctx, AM_ENOMEM, "out of memory sending to PE %d", pe);
        }
        am__frame_free(f);
    }
    if (!p->heldq.head)
        while (am__wake_one(ctx, &p->roomq))
            ;
}

void am__flow_consumed(am_ctx_t *ctx, int src, size_t size)
{
    size_t c = cost_of(size);
    if (src == ctx->rank) {
        grant(ctx, src, c);
        return;
    }
    am__peer *p = &ctx->peers[src];
    p->consumed += c;
    if (p->consumed < ctx->send_window / 2)
        return;
    /* A peer that said goodbye sends nothing more; while closing, peers
     * may be gone. */
    if (ctx->state != AM__RUNNING || p->said_bye || ctx->failed)
        return;
    pr_buf b = PR_BUF_INIT;
    am__ctl_begin(&b);
    am__credit_put(&b, (uint64_t)p->consumed);
    if (am__send_ctl(ctx, src, AM__CTL_CREDIT, &b) == 0)
        p->consumed = 0;
    pr_buf_free(&b);
}

static void on_credit(am_ctx_t *ctx, int src, pr_reader *body)
{
    uint64_t bytes;
    if (am__credit_get(body, &bytes) || bytes > ctx->peers[src].win_used) {
        am__reject(ctx, AM__REJ_BODY, src, "credit");
        return;
    }
    ctx->st.credits_recv++;
    grant(ctx, src, (size_t)bytes);
}

void am__flow_drain(am_ctx_t *ctx, double seconds)
{
    double end = am__now() + seconds;
    while (ctx->held_total && !ctx->failed && am__now() < end) {
        if (am_poll(ctx) < 0)
            break;
        if (ctx->held_total)
            am_idle(ctx, 0.01);
    }
}

void am__flow_free(am_ctx_t *ctx)
{
    if (!ctx->peers)
        return;
    for (int pe = 0; pe < ctx->size; pe++)
        am__fifo_clear(&ctx->peers[pe].heldq);
    ctx->held_total = 0;
}

const am__ctl_entry am__flow_ctls[] = {
    {AM__CTL_CREDIT, "credit", 0, on_credit},
    {0, NULL, 0, NULL},
};
