/* am_coll.c -- collectives built on control messages: barrier, allreduce
 * (sum/min/max of doubles or int64) over a binary tree rooted at rank 0,
 * and gather of variable-size blobs straight to rank 0.
 *
 * Tree: the children of rank r are 2r+1 and 2r+2, its parent (r-1)/2. Up
 * phase: a PE waits for its children's vectors, combines them with its own
 * in a fixed order (own, left, right) so that a floating-point sum does not
 * depend on which message came first, and sends the result to its parent.
 * Down phase: rank 0's result travels back down. A barrier is the same with
 * empty vectors. Depth is log2(P), so 16 PEs need 4 hops each way.
 *
 * Collectives are numbered per PE (coll_seq); all PEs call them in the
 * same order, so equal numbers name the same operation everywhere, and a
 * contribution that arrives before this PE entered the operation waits in
 * its record.
 */
#include "config.h"

#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "am_int.h"

static am__coll *coll_find(am_ctx_t *ctx, uint64_t seq, int create)
{
    for (am__coll *c = ctx->colls; c; c = c->next)
        if (c->seq == seq)
            return c;
    if (!create)
        return NULL;
    am__coll *c = pr_calloc(1, sizeof *c);
    if (!c)
        return NULL;
    c->seq = seq;
    c->kind = -1;
    c->next = ctx->colls;
    ctx->colls = c;
    return c;
}

static void coll_free(am_ctx_t *ctx, am__coll *c)
{
    for (am__coll **pp = &ctx->colls; *pp; pp = &(*pp)->next)
        if (*pp == c) {
            *pp = c->next;
            break;
        }
    pr_free(c->child[0]);
    pr_free(c->child[1]);
    pr_free(c->result);
    if (c->blobs) {
        for (int i = 0; i < ctx->size; i++)
            pr_free(c->blobs[i]);
        pr_free(c->blobs);
    }
    pr_free(c->blens);
    pr_free(c);
}

void am__coll_free_all(am_ctx_t *ctx)
{
    while (ctx->colls)
        coll_free(ctx, ctx->colls);
}

static int nchildren(const am_ctx_t *ctx)
{
    int r = ctx->rank;
    return (2 * r + 1 < ctx->size) + (2 * r + 2 < ctx->size);
}

/* Waiting: the record has one waiter at most (collectives are one at a
 * time per PE); every message that updates the record wakes it. */
static int coll_wait(am_ctx_t *ctx, am__coll *c, int (*ready)(const am_ctx_t *,
                                                             const am__coll *))
{
    while (!ready(ctx, c)) {
        if (ctx->failed)
            return ctx->failed;
        if (ctx->sched.current) {
            c->waiter.thread = ctx->sched.current;
            c->waiter.woken = 0;
            c->has_waiter = 1;
            am__thread_block(ctx);
            c->has_waiter = 0;
            continue;
        }
        /* Main context: drive the loop, one wake-up at a time. */
        int rc = am_poll(ctx);
        if (rc < 0)
            return rc;
        if (ready(ctx, c))
            break;
        if ((rc = am_run_threads(ctx)) < 0)
            return rc;
        if (ctx->coll_deadline > 0 && am__now() > ctx->coll_deadline)
            return AM_ETIMEOUT;
        if (!ready(ctx, c) && !am__has_ready_work(ctx) &&
            (rc = am_idle(ctx, -1)) < 0)
            return rc;
    }
    return ctx->failed;
}

static void coll_touch(am_ctx_t *ctx, am__coll *c)
{
    if (c->has_waiter) {
        c->has_waiter = 0;
        am__thread_wake(ctx, c->waiter.thread);
    }
}

static int up_ready(const am_ctx_t *ctx, const am__coll *c)
{
    int r = ctx->rank;
    return (2 * r + 1 >= ctx->size || c->child_got[0]) &&
           (2 * r + 2 >= ctx->size || c->child_got[1]);
}

static int down_ready(const am_ctx_t *ctx, const am__coll *c)
{
    (void)ctx;
    return c->result_got;
}

static int gather_ready(const am_ctx_t *ctx, const am__coll *c)
{
    return c->blobs_got == ctx->size - 1;
}

static void combine(int kind, int op, uint8_t *acc, const uint8_t *v,
                    uint32_t n)
{
    for (uint32_t i = 0; i < n; i++) {
        uint64_t a = pr_load_u64(acc + 8 * i), b = pr_load_u64(v + 8 * i);
        if (kind == AM__COLL_F64) {
            double x, y;
            memcpy(&x, &a, 8);
            memcpy(&y, &b, 8);
            x = op == AM_SUM ? x + y : op == AM_MIN ? (y < x ? y : x)
                                                    : (y > x ? y : x);
            memcpy(&a, &x, 8);
        } else {
            int64_t x = (int64_t)a, y = (int64_t)b;
            /* Wrap-around sum, computed unsigned: no undefined overflow. */
            x = op == AM_SUM ? (int64_t)(a + b) : op == AM_MIN ? (y < x ? y : x)
                                                               : (y > x ? y : x);
            a = (uint64_t)x;
        }
        pr_store_u64(acc + 8 * i, a);
    }
}

static int send_vec(am_ctx_t *ctx, int to, unsigned type, const am__coll *c,
                    const uint8_t *v)
{
    pr_buf b = PR_BUF_INIT;
    am__ctl_begin(&b);
    am__coll_msg m = {c->seq, (uint8_t)c->kind, (uint8_t)c->op, c->n, v};
    am__coll_put(&b, &m);
    int rc = am__send_ctl(ctx, to, type, &b);
    pr_buf_free(&b);
    return rc;
}

static int check_kind(am_ctx_t *ctx, am__coll *c, int kind, int op, uint32_t n)
{
    if (c->kind < 0) {
        c->kind = kind;
        c->op = op;
        c->n = n;
        return 0;
    }
    if (c->kind != kind || c->op != op || c->n != n) {
        am__warn(ctx, "collective #%llu: PEs disagree on its kind, operator "
                      "or length (a program bug: collectives must be called "
                      "in the same order with the same arguments)",
                 (unsigned long long)c->seq);
        return AM_EPROTO;
    }
    return 0;
}

/* acc holds this PE's 8n-byte vector on entry and the result on return. */
static int reduce(am_ctx_t *ctx, int kind, int op, uint8_t *acc, uint32_t n)
{
    int rc = am__may_block(ctx);
    if (rc)
        return rc;
    if (ctx->coll_busy)
        return AM_ESTATE;
    if (ctx->size == 1)
        return 0;
    ctx->coll_busy = 1;
    am__coll *c = coll_find(ctx, ++ctx->coll_seq, 1);
    if (!c) {
        ctx->coll_busy = 0;
        return AM_ENOMEM;
    }
    if ((rc = check_kind(ctx, c, kind, op, n)) == 0 &&
        (rc = coll_wait(ctx, c, up_ready)) == 0) {
        for (int i = 0; i < nchildren(ctx); i++)
            combine(kind, op, acc, c->child[i], n);
        if (ctx->rank != 0) {
            rc = send_vec(ctx, (ctx->rank - 1) / 2, AM__CTL_COLL_UP, c, acc);
            if (!rc)
                rc = coll_wait(ctx, c, down_ready);
            if (!rc && n)
                memcpy(acc, c->result, (size_t)n * 8);
        }
        for (int i = 0; !rc && i < nchildren(ctx); i++)
            rc = send_vec(ctx, 2 * ctx->rank + 1 + i, AM__CTL_COLL_DOWN, c, acc);
    }
    coll_free(ctx, c);
    ctx->coll_busy = 0;
    return rc;
}

int am_barrier(am_ctx_t *ctx)
{
    if (!ctx)
        return AM_EINVAL;
    return reduce(ctx, AM__COLL_BARRIER, AM_SUM, NULL, 0);
}

static int allreduce(am_ctx_t *ctx, int kind, const void *in, void *out,
                     size_t n, am_op_t op)
{
    if (!ctx || (n && (!in || !out)) || n > AM__COLL_MAX_N ||
        (op != AM_SUM && op != AM_MIN && op != AM_MAX))
        return AM_EINVAL;
    uint8_t *acc = pr_malloc(n ? n * 8 : 1);
    if (!acc)
        return AM_ENOMEM;
    for (size_t i = 0; i < n; i++) {
        uint64_t v;
        memcpy(&v, (const uint8_t *)in + 8 * i, 8);
        pr_store_u64(acc + 8 * i, v);
    }
    int rc = reduce(ctx, kind, op, acc, (uint32_t)n);
    if (!rc)
        for (size_t i = 0; i < n; i++) {
            uint64_t v = pr_load_u64(acc + 8 * i);
            memcpy((uint8_t *)out + 8 * i, &v, 8);
        }
    pr_free(acc);
    return rc;
}

int am_allreduce_f64(am_ctx_t *ctx, const double *in, double *out, size_t n,
                     am_op_t op)
{
    return allreduce(ctx, AM__COLL_F64, in, out, n, op);
}

int am_allreduce_i64(am_ctx_t *ctx, const int64_t *in, int64_t *out, size_t n,
                     am_op_t op)
{
    return allreduce(ctx, AM__COLL_I64, in, out, n, op);
}

int am_gather(am_ctx_t *ctx, const void *data, size_t len, void **all,
              size_t **lens)
{
    if (!ctx || !all || !lens || (len && !data) || len > AM_MAX_PAYLOAD)
        return AM_EINVAL;
    *all = NULL;
    *lens = NULL;
    int rc = am__may_block(ctx);
    if (rc)
        return rc;
    if (ctx->coll_busy)
        return AM_ESTATE;
    uint64_t seq = ++ctx->coll_seq;
    if (ctx->rank != 0) {
        pr_buf b = PR_BUF_INIT;
        am__ctl_begin(&b);
        am__gather_msg m = {seq, {data, len}};
        am__gather_put(&b, &m);
        rc = am__send_ctl(ctx, 0, AM__CTL_GATHER, &b);
        pr_buf_free(&b);
        return rc;
    }
    ctx->coll_busy = 1;
    am__coll *c = coll_find(ctx, seq, 1);
    if (!c) {
        ctx->coll_busy = 0;
        return AM_ENOMEM;
    }
    if (!(rc = check_kind(ctx, c, AM__COLL_GATHER, 0, 0)))
        rc = coll_wait(ctx, c, gather_ready);
    size_t total = len;
    for (int i = 1; !rc && i < ctx->size; i++)
        total += c->blens[i];
    /* When one PE sent every byte (rank 0 adding none, as pdr's merge
     * with two PEs), its blob is the concatenation: it is handed over
     * instead of copied, tens of megabytes of fresh memory less. */
    int only = -1; /* the PE that sent bytes; -2 when several did */
    for (int i = 1; !rc && i < ctx->size && len == 0; i++)
        if (c->blens[i])
            only = only == -1 ? i : -2;
    uint8_t *buf = NULL;
    size_t *l = NULL;
    if (!rc) {
        if (only > 0) {
            buf = c->blobs[only];
            c->blobs[only] = NULL;
        } else {
            buf = pr_malloc(total ? total : 1);
        }
        l = pr_malloc(sizeof *l * (size_t)ctx->size);
        if (!buf || !l)
            rc = AM_ENOMEM;
    }
    if (!rc) {
        size_t off = 0;
        for (int i = 0; i < ctx->size; i++) {
            const void *src = i == 0 ? data : c->blobs[i];
            l[i] = i == 0 ? len : c->blens[i];
            if (l[i] && only <= 0)
                memcpy(buf + off, src, l[i]);
            off += l[i];
        }
        *all = buf;
        *lens = l;
    } else {
        pr_free(buf);
        pr_free(l);
    }
    coll_free(ctx, c);
    ctx->coll_busy = 0;
    return rc;
}

/* Highest collective number this PE has finished. */
static uint64_t completed_seq(const am_ctx_t *ctx)
{
    return ctx->coll_busy ? ctx->coll_seq - 1 : ctx->coll_seq;
}

/* A gather contribution: rank 0 keeps one blob per PE. */
static void on_gather(am_ctx_t *ctx, int src, pr_reader *body)
{
    am__gather_msg m;
    am__coll *c;
    if (am__gather_get(body, &m) || ctx->rank != 0 ||
        m.seq <= completed_seq(ctx)) {
        am__reject(ctx, AM__REJ_BODY, src, "unexpected gather message");
        return;
    }
    if (!(c = coll_find(ctx, m.seq, 1)) ||
        (!c->blobs && (!(c->blobs = pr_calloc((size_t)ctx->size, sizeof *c->blobs)) ||
                       !(c->blens = pr_calloc((size_t)ctx->size, sizeof *c->blens))))) {
        am__fail(ctx, AM_ENOMEM, "out of memory in a gather");
        return;
    }
    if (c->kind < 0)
        c->kind = AM__COLL_GATHER;
    if (c->kind != AM__COLL_GATHER || c->blobs[src] || c->blens[src]) {
        am__reject(ctx, AM__REJ_BODY, src, "duplicate gather contribution");
        return;
    }
    c->blobs[src] = pr_malloc(m.blob.len ? m.blob.len : 1);
    if (!c->blobs[src]) {
        am__fail(ctx, AM_ENOMEM, "out of memory in a gather");
        return;
    }
    if (m.blob.len)
        memcpy(c->blobs[src], m.blob.p, m.blob.len);
    c->blens[src] = m.blob.len;
    c->blobs_got++;
    coll_touch(ctx, c);
}

/* A vector of the reduction tree: up is 1 for a child's contribution
 * (COLL_UP), 0 for the parent's result (COLL_DOWN). */
static void on_vector(am_ctx_t *ctx, int src, pr_reader *body, int up)
{
    am__coll_msg m;
    if (am__coll_get(body, &m)) {
        am__reject(ctx, AM__REJ_BODY, src, "malformed collective message");
        return;
    }
    int slot = -1;
    if (up) {
        if (src == 2 * ctx->rank + 1)
            slot = 0;
        else if (src == 2 * ctx->rank + 2)
            slot = 1;
    } else if (ctx->rank > 0 && src == (ctx->rank - 1) / 2) {
        slot = 2;
    }
    am__coll *c = slot < 0 || m.seq <= completed_seq(ctx)
                      ? NULL
                      : coll_find(ctx, m.seq, 1);
    if (!c || check_kind(ctx, c, m.kind, m.op, m.n) ||
        (slot < 2 ? c->child_got[slot] : c->result_got)) {
        am__reject(ctx, AM__REJ_BODY, src, "unexpected collective message");
        return;
    }
    uint8_t *copy = pr_malloc(m.n ? (size_t)m.n * 8 : 1);
    if (!copy) {
        am__fail(ctx, AM_ENOMEM, "out of memory in a collective");
        return;
    }
    if (m.n)
        memcpy(copy, m.values, (size_t)m.n * 8);
    if (slot < 2) {
        c->child[slot] = copy;
        c->child_got[slot] = 1;
    } else {
        c->result = copy;
        c->result_got = 1;
    }
    coll_touch(ctx, c);
}

static void on_up(am_ctx_t *ctx, int src, pr_reader *body)
{
    on_vector(ctx, src, body, 1);
}

static void on_down(am_ctx_t *ctx, int src, pr_reader *body)
{
    on_vector(ctx, src, body, 0);
}

const am__ctl_entry am__coll_ctls[] = {
    {AM__CTL_COLL_UP, "coll_up", 0, on_up},
    {AM__CTL_COLL_DOWN, "coll_down", 0, on_down},
    {AM__CTL_GATHER, "gather", 0, on_gather},
    {0, NULL, 0, NULL},
};
