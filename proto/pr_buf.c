/* pr_buf.c -- little-endian primitives, the growable write buffer and the
 * bounds-checked reader. */
#include "config.h"

#include <stdlib.h>
#include <string.h>

#include "pr.h"

const char *pr_strerror(int code)
{
    switch (code) {
#define PR_ERRNO_CASE(name, value, msg)                                      \
    case PR_E##name:                                                         \
        return msg;
        PR_ERRNO_MAP(PR_ERRNO_CASE)
#undef PR_ERRNO_CASE
    }
    return "unknown protocol error";
}

/* ------------------------------------------------------------ byte order */

void pr_store_u16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}

void pr_store_u32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
}

void pr_store_u64(uint8_t *p, uint64_t v)
{
    pr_store_u32(p, (uint32_t)v);
    pr_store_u32(p + 4, (uint32_t)(v >> 32));
}

uint16_t pr_load_u16(const uint8_t *p)
{
    return (uint16_t)(p[0] | (unsigned)p[1] << 8);
}

uint32_t pr_load_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
           (uint32_t)p[3] << 24;
}

uint64_t pr_load_u64(const uint8_t *p)
{
    return (uint64_t)pr_load_u32(p) | (uint64_t)pr_load_u32(p + 4) << 32;
}

/* ----------------------------------------------------------- write buffer */

void pr_buf_free(pr_buf *b)
{
    free(b->data);
    b->data = NULL;
    b->len = b->cap = 0;
    b->err = 0;
}

void pr_buf_reset(pr_buf *b)
{
    b->len = 0;
    b->err = 0;
}

int pr_buf_reserve(pr_buf *b, size_t n)
{
    if (b->err)
        return b->err;
    if (n <= b->cap - b->len)
        return 0;
    if (n > SIZE_MAX / 2 - b->len) {
        b->err = PR_ENOMEM;
        return b->err;
    }
    /* Grow geometrically so that appending k bytes costs O(k) overall. */
    size_t cap = b->cap ? b->cap : 64;
    while (cap - b->len < n)
        cap *= 2;
    uint8_t *p = realloc(b->data, cap);
    if (!p) {
        b->err = PR_ENOMEM;
        return b->err;
    }
    b->data = p;
    b->cap = cap;
    return 0;
}

uint8_t *pr_buf_take(pr_buf *b, size_t *len)
{
    if (b->err || b->len == 0) {
        *len = 0;
        return NULL;
    }
    uint8_t *p = b->data;
    *len = b->len;
    b->data = NULL;
    b->len = b->cap = 0;
    return p;
}

void pr_put_bytes(pr_buf *b, const void *p, size_t n)
{
    if (n == 0 || pr_buf_reserve(b, n))
        return;
    memcpy(b->data + b->len, p, n);
    b->len += n;
}

void pr_put_u8(pr_buf *b, uint8_t v)
{
    pr_put_bytes(b, &v, 1);
}

void pr_put_u16(pr_buf *b, uint16_t v)
{
    if (pr_buf_reserve(b, 2))
        return;
    pr_store_u16(b->data + b->len, v);
    b->len += 2;
}

void pr_put_u32(pr_buf *b, uint32_t v)
{
    if (pr_buf_reserve(b, 4))
        return;
    pr_store_u32(b->data + b->len, v);
    b->len += 4;
}

void pr_put_u64(pr_buf *b, uint64_t v)
{
    if (pr_buf_reserve(b, 8))
        return;
    pr_store_u64(b->data + b->len, v);
    b->len += 8;
}

void pr_put_i64(pr_buf *b, int64_t v)
{
    pr_put_u64(b, (uint64_t)v);
}

void pr_put_f64(pr_buf *b, double v)
{
    uint64_t bits;
    memcpy(&bits, &v, sizeof bits);
    pr_put_u64(b, bits);
}

/* ----------------------------------------------------------------- reader */

void pr_reader_init(pr_reader *r, const void *data, size_t len)
{
    r->p = data;
    r->left = data ? len : 0;
    r->err = 0;
}

int pr_reader_fail(pr_reader *r, int err)
{
    if (!r->err)
        r->err = err;
    r->left = 0;
    return r->err;
}

/* Claims n bytes or fails; returns a pointer to them or NULL. */
static const uint8_t *reader_claim(pr_reader *r, size_t n)
{
    if (r->err)
        return NULL;
    if (n > r->left) {
        pr_reader_fail(r, PR_ETRUNC);
        return NULL;
    }
    const uint8_t *p = r->p;
    r->p += n;
    r->left -= n;
    return p;
}

int pr_get_bytes(pr_reader *r, void *out, size_t n)
{
    const uint8_t *p = reader_claim(r, n);
    if (!p) {
        memset(out, 0, n);
        return r->err;
    }
    memcpy(out, p, n);
    return 0;
}

int pr_get_view(pr_reader *r, const uint8_t **out, size_t n)
{
    *out = reader_claim(r, n);
    return *out ? 0 : r->err;
}

int pr_get_u8(pr_reader *r, uint8_t *out)
{
    const uint8_t *p = reader_claim(r, 1);
    *out = p ? p[0] : 0;
    return p ? 0 : r->err;
}

int pr_get_u16(pr_reader *r, uint16_t *out)
{
    const uint8_t *p = reader_claim(r, 2);
    *out = p ? pr_load_u16(p) : 0;
    return p ? 0 : r->err;
}

int pr_get_u32(pr_reader *r, uint32_t *out)
{
    const uint8_t *p = reader_claim(r, 4);
    *out = p ? pr_load_u32(p) : 0;
    return p ? 0 : r->err;
}

int pr_get_u64(pr_reader *r, uint64_t *out)
{
    const uint8_t *p = reader_claim(r, 8);
    *out = p ? pr_load_u64(p) : 0;
    return p ? 0 : r->err;
}

int pr_get_i64(pr_reader *r, int64_t *out)
{
    uint64_t u;
    int rc = pr_get_u64(r, &u);
    *out = (int64_t)u;
    return rc;
}

int pr_get_f64(pr_reader *r, double *out)
{
    uint64_t bits;
    int rc = pr_get_u64(r, &bits);
    memcpy(out, &bits, sizeof *out);
    return rc;
}

int pr_get_count(pr_reader *r, uint32_t max, size_t elem_size, uint32_t *out)
{
    *out = 0;
    uint32_t n;
    if (pr_get_u32(r, &n))
        return r->err;
    if (n > max)
        return pr_reader_fail(r, PR_ERANGE);
    /* Division avoids overflow of n * elem_size on 32-bit size_t. */
    if (elem_size && n > r->left / elem_size)
        return pr_reader_fail(r, PR_ETRUNC);
    *out = n;
    return 0;
}

int pr_reader_finish(const pr_reader *r)
{
    if (r->err)
        return r->err;
    return r->left ? PR_ETRAILING : 0;
}
