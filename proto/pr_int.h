/* pr_int.h -- internals shared by libpdrproto's sources (not installed,
 * not for other modules). */
#ifndef PR_INT_H
#define PR_INT_H

#include <stdint.h>
#include <string.h>

#include "pr.h"

/* Two host-specific fast paths, each with a plain C twin:
 *   - on a little-endian host the wire order is the host order, and bulk
 *     arrays are copied with memcpy; elsewhere every value is assembled
 *     byte by byte;
 *   - with GCC or clang, the table checks use 4-lane vector extensions
 *     (SSE2 on x86-64, NEON on arm64); elsewhere they are scalar loops.
 * A build that defines PR_PORTABLE takes the plain C twins everywhere; the
 * *_portable tests are built that way, so both paths are tested to write the
 * same bytes and refuse the same messages. */
#if defined(__BYTE_ORDER__) && defined(__ORDER_LITTLE_ENDIAN__) &&           \
    __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__ && !defined(PR_PORTABLE)
#define PR__HOST_LE 1
#else
#define PR__HOST_LE 0
#endif

#if (defined(__GNUC__) || defined(__clang__)) && !defined(PR_PORTABLE)
#define PR__VECTOR 1
#else
#define PR__VECTOR 0
#endif

/* Inline loads and stores for the hot loops; pr_load_u64 and friends in
 * pr.h are the exported equivalents. memcpy of a fixed size compiles to one
 * unaligned load or store. */
static inline uint32_t pr__ld32(const uint8_t *p)
{
#if PR__HOST_LE
    uint32_t v;
    memcpy(&v, p, 4);
    return v;
#else
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
           (uint32_t)p[3] << 24;
#endif
}

static inline uint64_t pr__ld64(const uint8_t *p)
{
#if PR__HOST_LE
    uint64_t v;
    memcpy(&v, p, 8);
    return v;
#else
    return (uint64_t)pr__ld32(p) | (uint64_t)pr__ld32(p + 4) << 32;
#endif
}

static inline void pr__st32(uint8_t *p, uint32_t v)
{
#if PR__HOST_LE
    memcpy(p, &v, 4);
#else
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
#endif
}

static inline void pr__st64(uint8_t *p, uint64_t v)
{
#if PR__HOST_LE
    memcpy(p, &v, 8);
#else
    pr__st32(p, (uint32_t)v);
    pr__st32(p + 4, (uint32_t)(v >> 32));
#endif
}

static inline uint64_t pr__f64_bits(double d)
{
    uint64_t u;
    memcpy(&u, &d, 8);
    return u;
}

static inline double pr__bits_f64(uint64_t u)
{
    double d;
    memcpy(&d, &u, 8);
    return d;
}

/* True if the binary64 pattern u is finite (exponent not all ones). */
static inline int pr__finite_bits(uint64_t u)
{
    return (u & UINT64_C(0x7ff0000000000000)) != UINT64_C(0x7ff0000000000000);
}

/* Claims n bytes of room at the end of b and returns where they start, or
 * NULL (error stored in b). The caller fills all n bytes. */
uint8_t *pr__buf_claim(pr_buf *b, size_t n);
/* Stores err in b->err if b has no error yet; returns b->err. */
int pr__buf_fail(pr_buf *b, int err);

#endif /* PR_INT_H */
