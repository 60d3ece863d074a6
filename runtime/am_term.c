/* am_term.c -- distributed termination detection: Safra's token algorithm
 * as Dijkstra wrote it down in EWD998.
 *
 * Each PE keeps count (basic messages it sent minus basic messages it
 * delivered) and a colour: it turns black when it delivers a basic message.
 * Rank 0, when passive, starts a probe: it whitens itself and sends a white
 * token with q = 0 along the ring 0 -> 1 -> ... -> P-1 -> 0. A PE holds the
 * token until it is passive, then adds its count to q, blackens the token
 * if it is black itself, whitens itself and passes it on. When the token is
 * back at a passive rank 0, termination holds iff the token and rank 0 are
 * white and q + count(0) == 0: then no PE was re-activated during the round
 * and no basic message is in flight (the counts sum to the messages sent
 * but not yet delivered, including those waiting in latency queues). If
 * not, rank 0 starts another round once it is passive again.
 *
 * Rank 0 then sends TERMINATE to every PE; am_quiescent finishes with a
 * barrier. Counts and colours are never reset: an epoch ends, the next one
 * continues from the same totals, which stay exact.
 */
#include "config.h"

#include "am_int.h"

void am__term_on_send(am_ctx_t *ctx)
{
    ctx->term.count++;
}

void am__term_on_deliver(am_ctx_t *ctx)
{
    ctx->term.count--;
    ctx->term.black = 1;
}

static void send_token(am_ctx_t *ctx, int to, int64_t q, int black)
{
    pr_buf b = PR_BUF_INIT;
    am__ctl_begin(&b);
    am__token tok = {ctx->term.epoch, q, (uint8_t)(black ? 1 : 0)};
    am__token_put(&b, &tok);
    am__send_ctl(ctx, to, AM__CTL_TOKEN, &b);
    pr_buf_free(&b);
}

static void declare(am_ctx_t *ctx)
{
    am__term *t = &ctx->term;
    t->declared = 1;
    t->defer = 1;
    for (int pe = 1; pe < ctx->size; pe++) {
        pr_buf b = PR_BUF_INIT;
        am__ctl_begin(&b);
        am__terminate_put(&b, t->epoch);
        am__send_ctl(ctx, pe, AM__CTL_TERMINATE, &b);
        pr_buf_free(&b);
    }
}

int am__term_step(am_ctx_t *ctx, int passive)
{
    am__term *t = &ctx->term;
    t->passive = passive;
    if (t->declared)
        return 1;
    if (!passive || ctx->failed)
        return 0;
    if (ctx->size == 1) {
        if (t->count == 0) {
            t->declared = 1;
            t->defer = 1;
            return 1;
        }
        return 0;
    }
    if (ctx->rank != 0) {
        if (t->have_token) {
            int64_t q = t->tok_q + t->count;
            int black = t->tok_black || t->black;
            t->have_token = 0;
            t->black = 0;
            send_token(ctx, (ctx->rank + 1) % ctx->size, q, black);
        }
        return 0;
    }
    if (t->have_token) {
        t->have_token = 0;
        t->probing = 0;
        if (!t->tok_black && !t->black && t->tok_q + t->count == 0) {
            declare(ctx);
            return 1;
        }
    }
    if (!t->probing) {
        t->probing = 1;
        t->black = 0;
        send_token(ctx, 1, 0, 0);
    }
    return 0;
}

/* The token may only come from the previous PE on the ring, and only one
 * can be travelling (rank 0 starts it only while probing). */
static void on_token(am_ctx_t *ctx, int src, pr_reader *body)
{
    am__term *t = &ctx->term;
    am__token tok;
    int expected_src = (ctx->rank + ctx->size - 1) % ctx->size;
    if (am__token_get(body, &tok) || src != expected_src || t->have_token ||
        (ctx->rank == 0 && !t->probing)) {
        am__reject(ctx, AM__REJ_BODY, src, "unexpected termination token");
        return;
    }
    t->have_token = 1;
    t->tok_q = tok.q;
    t->tok_black = tok.black;
}

static void on_terminate(am_ctx_t *ctx, int src, pr_reader *body)
{
    am__term *t = &ctx->term;
    uint64_t epoch;
    if (am__terminate_get(body, &epoch) || src != 0 || epoch != t->epoch) {
        am__reject(ctx, AM__REJ_BODY, src, "unexpected terminate message");
        return;
    }
    t->declared = 1;
    t->defer = 1;
}

const am__ctl_entry am__term_ctls[] = {
    {AM__CTL_TOKEN, "token", 0, on_token},
    {AM__CTL_TERMINATE, "terminate", 0, on_terminate},
    {0, NULL, 0, NULL},
};
