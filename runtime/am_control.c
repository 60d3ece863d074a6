/* am_control.c -- encoders and decoders of the control message bodies
 * (layouts in runtime/CONTROL.md). Every decoder checks counts against
 * the bytes left before it trusts them, and requires the body to end
 * exactly where the message ends. */
#include "config.h"

#include <string.h>

#include "am_control.h"

static void put_str(pr_buf *b, const char *s, size_t len)
{
    pr_put_u32(b, (uint32_t)len);
    pr_put_bytes(b, s, len);
}

static int get_str(pr_reader *r, size_t max, am__str *s)
{
    uint32_t n;
    s->p = NULL;
    s->len = 0;
    if (pr_get_count(r, (uint32_t)max, 1, &n))
        return r->err;
    s->len = n;
    return pr_get_view(r, &s->p, n);
}

/* The hello is nested length-prefixed, so that a hello of another protocol
 * version (which may be longer) still parses far enough to be named in an
 * error by pr_negotiate. */
static void put_id(pr_buf *b, const pr_hello *id)
{
    pr_buf inner = PR_BUF_INIT;
    int rc = pr_hello_put(&inner, id);
    if (rc) {
        if (!b->err)
            b->err = rc;
    } else {
        put_str(b, (const char *)inner.data, inner.len);
    }
    pr_buf_free(&inner);
}

static int get_id(pr_reader *r, pr_hello *id)
{
    am__str raw;
    if (get_str(r, AM__HELLO_MAX, &raw))
        return r->err;
    int rc = pr_hello_decode(id, raw.p, raw.len);
    if (rc)
        return pr_reader_fail(r, rc);
    if (id->size > AM__PE_MAX)
        return pr_reader_fail(r, PR_ERANGE);
    return 0;
}

void am__hello_put(pr_buf *b, const am__hello *m)
{
    put_id(b, &m->id);
    put_str(b, (const char *)m->endpoint.p, m->endpoint.len);
}

int am__hello_get(pr_reader *r, am__hello *m)
{
    get_id(r, &m->id);
    get_str(r, AM__EP_MAX, &m->endpoint);
    return pr_reader_finish(r);
}

void am__table_put(pr_buf *b, uint64_t job, uint32_t size,
                   char *const *endpoints)
{
    pr_put_u64(b, job);
    pr_put_u32(b, size);
    for (uint32_t i = 0; i < size; i++)
        put_str(b, endpoints[i], strlen(endpoints[i]));
}

int am__table_get(pr_reader *r, uint64_t *job, uint32_t max, uint32_t *size,
                  am__str *eps)
{
    *size = 0;
    pr_get_u64(r, job);
    /* Each entry takes at least its 4-byte length. */
    uint32_t n;
    if (pr_get_count(r, max, 4, &n))
        return r->err;
    if (n == 0)
        return pr_reader_fail(r, PR_ERANGE);
    for (uint32_t i = 0; i < n; i++)
        if (get_str(r, AM__EP_MAX, &eps[i]))
            return r->err;
    /* The count only for a body that ends where it should. */
    int rc = pr_reader_finish(r);
    if (!rc)
        *size = n;
    return rc;
}

void am__peer_hello_put(pr_buf *b, const am__peer_hello *m)
{
    put_id(b, &m->id);
}

int am__peer_hello_get(pr_reader *r, am__peer_hello *m)
{
    get_id(r, &m->id);
    return pr_reader_finish(r);
}

void am__token_put(pr_buf *b, const am__token *m)
{
    pr_put_u64(b, m->epoch);
    pr_put_i64(b, m->q);
    pr_put_u8(b, m->black);
}

int am__token_get(pr_reader *r, am__token *m)
{
    pr_get_u64(r, &m->epoch);
    pr_get_i64(r, &m->q);
    pr_get_u8(r, &m->black);
    if (!r->err && m->black > 1)
        pr_reader_fail(r, PR_ERANGE);
    return pr_reader_finish(r);
}

void am__terminate_put(pr_buf *b, uint64_t epoch)
{
    pr_put_u64(b, epoch);
}

int am__terminate_get(pr_reader *r, uint64_t *epoch)
{
    pr_get_u64(r, epoch);
    return pr_reader_finish(r);
}

void am__coll_put(pr_buf *b, const am__coll_msg *m)
{
    pr_put_u64(b, m->seq);
    pr_put_u8(b, m->kind);
    pr_put_u8(b, m->op);
    pr_put_u32(b, m->n);
    pr_put_bytes(b, m->values, (size_t)m->n * 8);
}

int am__coll_get(pr_reader *r, am__coll_msg *m)
{
    m->values = NULL;
    pr_get_u64(r, &m->seq);
    pr_get_u8(r, &m->kind);
    pr_get_u8(r, &m->op);
    if (!r->err && (m->kind > 2 || m->op > 2))
        return pr_reader_fail(r, PR_ERANGE);
    if (pr_get_count(r, AM__COLL_MAX_N, 8, &m->n))
        return r->err;
    if (m->kind == 0 && m->n != 0)
        return pr_reader_fail(r, PR_ERANGE);
    pr_get_view(r, &m->values, (size_t)m->n * 8);
    return pr_reader_finish(r);
}

void am__gather_put(pr_buf *b, const am__gather_msg *m)
{
    pr_put_u64(b, m->seq);
    put_str(b, (const char *)m->blob.p, m->blob.len);
}

int am__gather_get(pr_reader *r, am__gather_msg *m)
{
    pr_get_u64(r, &m->seq);
    get_str(r, PR_MAX_PAYLOAD, &m->blob);
    return pr_reader_finish(r);
}

void am__rpc_req_put(pr_buf *b, uint64_t call_id, uint16_t handler,
                     const void *data, size_t len)
{
    pr_put_u64(b, call_id);
    pr_put_u16(b, handler);
    pr_put_bytes(b, data, len);
}

int am__rpc_req_get(pr_reader *r, am__rpc_msg *m)
{
    pr_get_u64(r, &m->call_id);
    pr_get_u16(r, &m->handler);
    if (!r->err && m->call_id == 0)
        return pr_reader_fail(r, PR_ERANGE);
    m->payload.len = r->left;
    pr_get_view(r, &m->payload.p, r->left);
    return pr_reader_finish(r);
}

void am__rpc_rep_put(pr_buf *b, uint64_t call_id, const void *data,
                     size_t len)
{
    pr_put_u64(b, call_id);
    pr_put_bytes(b, data, len);
}

int am__rpc_rep_get(pr_reader *r, am__rpc_msg *m)
{
    m->handler = 0;
    pr_get_u64(r, &m->call_id);
    if (!r->err && m->call_id == 0)
        return pr_reader_fail(r, PR_ERANGE);
    m->payload.len = r->left;
    pr_get_view(r, &m->payload.p, r->left);
    return pr_reader_finish(r);
}

void am__abort_put(pr_buf *b, const am__abort_msg *m)
{
    pr_put_u32(b, m->culprit);
    put_str(b, (const char *)m->reason.p, m->reason.len);
}

int am__abort_get(pr_reader *r, am__abort_msg *m)
{
    pr_get_u32(r, &m->culprit);
    get_str(r, AM__REASON_MAX, &m->reason);
    return pr_reader_finish(r);
}

int am__empty_get(pr_reader *r)
{
    return pr_reader_finish(r);
}

void am__credit_put(pr_buf *b, uint64_t bytes)
{
    pr_put_u64(b, bytes);
}

int am__credit_get(pr_reader *r, uint64_t *bytes)
{
    if (pr_get_u64(r, bytes) == 0 && (*bytes == 0 || *bytes > AM__CREDIT_MAX))
        return pr_reader_fail(r, PR_ERANGE);
    return pr_reader_finish(r);
}

/* ---------------------------------------------------------------- bundles */

size_t am__bundle_next(const uint8_t *msg, size_t len)
{
    if (len < PR_HEADER_SIZE)
        return 0;
    /* The payload length is the u32 at offset 12 (PROTOCOL.md, "Frame
     * header"); compared against what is left before any addition, so
     * that no length can wrap. */
    uint32_t payload = pr_load_u32(msg + 12);
    if (payload > len - PR_HEADER_SIZE)
        return 0;
    return PR_HEADER_SIZE + (size_t)payload;
}
