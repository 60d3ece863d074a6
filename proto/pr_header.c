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

int pr_header_decode_any(pr_header *h, const void *buf, size_t len,
                         uint8_t *version)
{
    const uint8_t *p = buf;
    *h = (pr_header){0};
    *version = 0;
    if (!p || len < PR_HEADER_SIZE)
        return PR_ETRUNC;
    if (p[0] != PR_MAGIC0 || p[1] != PR_MAGIC1 || p[2] != PR_MAGIC2 ||
        p[3] != PR_MAGIC3)
        return PR_EMAGIC;
    *version = p[4];
    if (p[4] == 0)
        return PR_EVERSION;
    /* Flag bits are this version's; another version may define more, and
     * its frames are only read far enough to refuse them clearly. */
    if (p[4] == PR_VERSION && (p[5] & ~PR_FLAG_KNOWN))
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

int pr_header_decode(pr_header *h, const void *buf, size_t len)
{
    const uint8_t *p = buf;
    uint8_t version;
    /* The version is checked before the fields whose rules it defines. */
    if (p && len >= PR_HEADER_SIZE && p[0] == PR_MAGIC0 &&
        p[1] == PR_MAGIC1 && p[2] == PR_MAGIC2 && p[3] == PR_MAGIC3 &&
        p[4] != PR_VERSION) {
        *h = (pr_header){0};
        return PR_EVERSION;
    }
    return pr_header_decode_any(h, buf, len, &version);
}
