/* pr_header.c -- the fixed 24-byte frame header (layout in pr.h and
 * proto/PROTOCOL.md). */
#include "config.h"

#include "pr.h"

int pr_header_encode(const pr_header *h, uint8_t out[PR_HEADER_SIZE])
{
    if ((h->flags & ~PR_FLAG_KNOWN) || h->payload_len > PR_MAX_PAYLOAD)
        return PR_EINVAL;
    out[0] = PR_MAGIC0;
    out[1] = PR_MAGIC1;
    out[2] = PR_MAGIC2;
    out[3] = PR_MAGIC3;
    out[4] = PR_VERSION;
    out[5] = h->flags;
    pr_store_u16(out + 6, h->handler);
    pr_store_u32(out + 8, h->sender);
    pr_store_u32(out + 12, h->payload_len);
    pr_store_u64(out + 16, h->seq);
    return 0;
}

int pr_header_put(pr_buf *b, const pr_header *h)
{
    uint8_t raw[PR_HEADER_SIZE];
    int rc = pr_header_encode(h, raw);
    if (rc)
        return rc;
    pr_put_bytes(b, raw, sizeof raw);
    return b->err;
}

int pr_header_decode(pr_header *h, const void *buf, size_t len)
{
    const uint8_t *p = buf;
    *h = (pr_header){0};
    if (!p || len < PR_HEADER_SIZE)
        return PR_ETRUNC;
    if (p[0] != PR_MAGIC0 || p[1] != PR_MAGIC1 || p[2] != PR_MAGIC2 ||
        p[3] != PR_MAGIC3)
        return PR_EMAGIC;
    if (p[4] != PR_VERSION)
        return PR_EVERSION;
    if (p[5] & ~PR_FLAG_KNOWN)
        return PR_EFLAGS;
    uint32_t payload_len = pr_load_u32(p + 12);
    if (payload_len > PR_MAX_PAYLOAD)
        return PR_ERANGE;
    h->flags = p[5];
    h->handler = pr_load_u16(p + 6);
    h->sender = pr_load_u32(p + 8);
    h->payload_len = payload_len;
    h->seq = pr_load_u64(p + 16);
    return 0;
}
