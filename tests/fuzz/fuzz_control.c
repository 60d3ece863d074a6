/*
 * Fuzz target: libam's control-frame body decoders (runtime/am_control.h;
 * see fuzz_input.h, tools/fuzz). The first input byte picks the frame type
 * (low four bits, modulo the 14 types) and, for TABLE, how many PEs the
 * receiving job has (high four bits, plus one); the rest is the body.
 * Promises: an accepted body re-encodes to
 * exactly the same bytes, with every view inside the body.
 */
#include "config.h"

#include <string.h>

#include "am_control.h"
#include "fuzz_input.h"

const char pdr_fuzz_corpus[] = "runtime/control";

static const uint8_t *body_lo, *body_hi;

static void check_view(const uint8_t *p, size_t len)
{
    if (len == 0)
        return;
    PDR_FUZZ_ASSERT(p != NULL && p >= body_lo && len <= (size_t)(body_hi - p));
}

/* The decoded message must be the body again, byte for byte. */
static void same_bytes(pr_buf *b, const uint8_t *body, size_t len)
{
    PDR_FUZZ_ASSERT(b->err == 0);
    PDR_FUZZ_ASSERT(b->len == len);
    PDR_FUZZ_ASSERT(len == 0 || memcmp(b->data, body, len) == 0);
    pr_buf_free(b);
}

int pdr_fuzz_run(const uint8_t *data, size_t size)
{
    if (size == 0)
        return 0;
    int type = (data[0] & 15) % (AM__CTL_COUNT - 1) + 1;
    uint32_t max_pes = (uint32_t)(data[0] >> 4) + 1;
    const uint8_t *body = data + 1;
    size_t len = size - 1;
    body_lo = body;
    body_hi = body + len;
    pr_reader r;
    pr_reader_init(&r, body, len);
    pr_buf b = PR_BUF_INIT;
    int rc;
    switch (type) {
    case AM__CTL_HELLO: {
        am__hello m;
        if (!(rc = am__hello_get(&r, &m))) {
            check_view(m.endpoint.p, m.endpoint.len);
            PDR_FUZZ_ASSERT(m.endpoint.len <= AM__EP_MAX && m.id.size <= AM__PE_MAX);
            am__hello_put(&b, &m);
        }
        break;
    }
    case AM__CTL_TABLE: {
        am__str eps[16];
        uint64_t job;
        uint32_t n;
        if (!(rc = am__table_get(&r, &job, max_pes, &n, eps))) {
            PDR_FUZZ_ASSERT(n >= 1 && n <= max_pes);
            pr_put_u64(&b, job);
            pr_put_u32(&b, n);
            for (uint32_t i = 0; i < n; i++) {
                check_view(eps[i].p, eps[i].len);
                PDR_FUZZ_ASSERT(eps[i].len <= AM__EP_MAX);
                pr_put_u32(&b, (uint32_t)eps[i].len);
                pr_put_bytes(&b, eps[i].p, eps[i].len);
            }
        } else {
            PDR_FUZZ_ASSERT(n == 0);
        }
        break;
    }
    case AM__CTL_PEER_HELLO: {
        am__peer_hello m;
        if (!(rc = am__peer_hello_get(&r, &m)))
            am__peer_hello_put(&b, &m);
        break;
    }
    case AM__CTL_BYE:
    case AM__CTL_PING:
        rc = am__empty_get(&r);
        break;
    case AM__CTL_TOKEN: {
        am__token m;
        if (!(rc = am__token_get(&r, &m)))
            am__token_put(&b, &m);
        break;
    }
    case AM__CTL_TERMINATE: {
        uint64_t epoch;
        if (!(rc = am__terminate_get(&r, &epoch)))
            am__terminate_put(&b, epoch);
        break;
    }
    case AM__CTL_COLL_UP:
    case AM__CTL_COLL_DOWN: {
        am__coll_msg m;
        if (!(rc = am__coll_get(&r, &m))) {
            check_view(m.values, (size_t)m.n * 8);
            PDR_FUZZ_ASSERT(m.n <= AM__COLL_MAX_N);
            am__coll_put(&b, &m);
        }
        break;
    }
    case AM__CTL_GATHER: {
        am__gather_msg m;
        if (!(rc = am__gather_get(&r, &m))) {
            check_view(m.blob.p, m.blob.len);
            am__gather_put(&b, &m);
        }
        break;
    }
    case AM__CTL_RPC_REQ: {
        am__rpc_msg m;
        if (!(rc = am__rpc_req_get(&r, &m))) {
            check_view(m.payload.p, m.payload.len);
            am__rpc_req_put(&b, m.call_id, m.handler, m.payload.p, m.payload.len);
        }
        break;
    }
    case AM__CTL_RPC_REP: {
        am__rpc_msg m;
        if (!(rc = am__rpc_rep_get(&r, &m))) {
            check_view(m.payload.p, m.payload.len);
            am__rpc_rep_put(&b, m.call_id, m.payload.p, m.payload.len);
        }
        break;
    }
    case AM__CTL_ABORT: {
        am__abort_msg m;
        if (!(rc = am__abort_get(&r, &m))) {
            check_view(m.reason.p, m.reason.len);
            PDR_FUZZ_ASSERT(m.reason.len <= AM__REASON_MAX);
            am__abort_put(&b, &m);
        }
        break;
    }
    default: { /* AM__CTL_CREDIT */
        uint64_t bytes;
        if (!(rc = am__credit_get(&r, &bytes))) {
            PDR_FUZZ_ASSERT(bytes >= 1 && bytes <= AM__CREDIT_MAX);
            am__credit_put(&b, bytes);
        }
        break;
    }
    }
    if (rc == 0)
        same_bytes(&b, body, len);
    pr_buf_free(&b);
    return rc == 0;
}

PDR_FUZZ_ENTRY
