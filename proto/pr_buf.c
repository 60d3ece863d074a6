/* pr_buf.c -- little-endian primitives, the growable write buffer and the
 * bounds-checked reader. */
#include "config.h"

#include <stdlib.h>
#include <string.h>

#include "pr.h"
#include "pr_alloc.h"
#include "pr_int.h"

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
    pr_free(b->data);
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
    uint8_t *p = pr_realloc(b->data, cap);
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

uint8_t *pr__buf_claim(pr_buf *b, size_t n)
{
    if (pr_buf_reserve(b, n))
        return NULL;
    uint8_t *p = b->data + b->len;
    b->len += n;
    return p;
}

int pr__buf_fail(pr_buf *b, int err)
{
    if (!b->err)
        b->err = err;
    return b->err;
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

void pr_put_i32(pr_buf *b, int32_t v)
{
    pr_put_u32(b, (uint32_t)v);
}

/* ------------------------------------------------------------ bulk arrays */

/* Kinds of bulk array element: the low bits are the width in bytes. */
enum { ELEM_U32 = 4, ELEM_U64 = 8, ELEM_F64 = 8 | 16 };
#define ELEM_WIDTH(kind) ((size_t)(kind)&15u)

/* Appends n elements of one kind: a copy on a little-endian host, an
 * element-wise store elsewhere. n * width cannot overflow: n is checked
 * here and pr_buf_reserve refuses anything near SIZE_MAX / 2. */
static void put_array(pr_buf *b, const void *v, size_t n, int kind)
{
    size_t w = ELEM_WIDTH(kind);
    if (n > SIZE_MAX / (2 * w)) {
        pr__buf_fail(b, PR_ENOMEM);
        return;
    }
    uint8_t *p = n ? pr__buf_claim(b, w * n) : NULL;
    if (!p)
        return;
#if PR__HOST_LE
    (void)kind;
    memcpy(p, v, w * n);
#else
    for (size_t i = 0; i < n; i++) {
        if (kind == ELEM_U32)
            pr__st32(p + 4 * i, ((const uint32_t *)v)[i]);
        else if (kind == ELEM_U64)
            pr__st64(p + 8 * i, ((const uint64_t *)v)[i]);
        else
            pr__st64(p + 8 * i, pr__f64_bits(((const double *)v)[i]));
    }
#endif
}

void pr_put_u32_array(pr_buf *b, const uint32_t *v, size_t n)
{
    put_array(b, v, n, ELEM_U32);
}

void pr_put_i32_array(pr_buf *b, const int32_t *v, size_t n)
{
    put_array(b, v, n, ELEM_U32);
}

void pr_put_u64_array(pr_buf *b, const uint64_t *v, size_t n)
{
    put_array(b, v, n, ELEM_U64);
}

void pr_put_f64_array(pr_buf *b, const double *v, size_t n)
{
    put_array(b, v, n, ELEM_F64);
}

/* ---------------------------------------------------------------- strings */

int pr_str_check(const char *s, size_t len)
{
    if (len > PR_STR_MAX)
        return PR_ERANGE;
    const uint8_t *p = (const uint8_t *)s;
    size_t i = 0;
    while (i < len) {
        uint8_t c = p[i];
        if (c < 0x80) {
            if (c < 0x20 || c == 0x7f)
                return PR_EDATA;
            i++;
            continue;
        }
        /* A multi-byte sequence (RFC 3629): the lead byte gives the length,
         * continuation bytes are 10xxxxxx, and the code point must need
         * that length (no overlong form), must not be a UTF-16 surrogate
         * and must be at most U+10FFFF. */
        size_t n;
        uint32_t cp, min;
        if ((c & 0xe0) == 0xc0) {
            n = 2, cp = c & 0x1fu, min = 0x80;
        } else if ((c & 0xf0) == 0xe0) {
            n = 3, cp = c & 0x0fu, min = 0x800;
        } else if ((c & 0xf8) == 0xf0) {
            n = 4, cp = c & 0x07u, min = 0x10000;
        } else {
            return PR_EDATA;
        }
        if (n > len - i)
            return PR_EDATA;
        for (size_t k = 1; k < n; k++) {
            uint8_t d = p[i + k];
            if ((d & 0xc0) != 0x80)
                return PR_EDATA;
            cp = cp << 6 | (d & 0x3fu);
        }
        if (cp < min || cp > 0x10ffff || (cp >= 0xd800 && cp <= 0xdfff))
            return PR_EDATA;
        i += n;
    }
    return 0;
}

int pr_put_str(pr_buf *b, const char *s, size_t len)
{
    if (b->err)
        return b->err;
    if (pr_str_check(s, len))
        return pr__buf_fail(b, PR_EINVAL);
    pr_put_u16(b, (uint16_t)len);
    pr_put_bytes(b, s, len);
    return b->err;
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
    if (n == 0) /* memcpy and memset want non-NULL pointers even then */
        return r->err;
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

int pr_get_i32(pr_reader *r, int32_t *out)
{
    uint32_t u;
    int rc = pr_get_u32(r, &u);
    *out = (int32_t)u;
    return rc;
}

/* Reads n elements of one kind into out; the mirror of put_array. */
static int get_array(pr_reader *r, void *out, size_t n, int kind)
{
    size_t w = ELEM_WIDTH(kind);
    const uint8_t *p = n <= SIZE_MAX / w ? reader_claim(r, w * n) : NULL;
    if (!p) {
        if (n > SIZE_MAX / w)
            pr_reader_fail(r, PR_ETRUNC);
        return r->err;
    }
#if PR__HOST_LE
    (void)kind;
    if (n)
        memcpy(out, p, w * n);
#else
    for (size_t i = 0; i < n; i++) {
        if (kind == ELEM_U32)
            ((uint32_t *)out)[i] = pr__ld32(p + 4 * i);
        else if (kind == ELEM_U64)
            ((uint64_t *)out)[i] = pr__ld64(p + 8 * i);
        else
            ((double *)out)[i] = pr__bits_f64(pr__ld64(p + 8 * i));
    }
#endif
    return 0;
}

int pr_get_u32_array(pr_reader *r, uint32_t *out, size_t n)
{
    return get_array(r, out, n, ELEM_U32);
}

int pr_get_i32_array(pr_reader *r, int32_t *out, size_t n)
{
    return get_array(r, out, n, ELEM_U32);
}

int pr_get_u64_array(pr_reader *r, uint64_t *out, size_t n)
{
    return get_array(r, out, n, ELEM_U64);
}

int pr_get_f64_array(pr_reader *r, double *out, size_t n)
{
    return get_array(r, out, n, ELEM_F64);
}

int pr_get_str(pr_reader *r, size_t max, char *out, size_t *len)
{
    uint16_t n;
    const uint8_t *p;
    out[0] = '\0';
    if (len)
        *len = 0;
    if (pr_get_u16(r, &n))
        return r->err;
    if (n > max)
        return pr_reader_fail(r, PR_ERANGE);
    if (pr_get_view(r, &p, n))
        return r->err;
    if (pr_str_check((const char *)p, n))
        return pr_reader_fail(r, PR_EDATA);
    memcpy(out, p, n);
    out[n] = '\0';
    if (len)
        *len = n;
    return 0;
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
