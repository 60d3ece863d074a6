/* base/nf.c -- exact %.17g formatting without printf (see base/nf.h). */
#include "config.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "base/nf.h"

static size_t slow(double x, char *buf)
{
    int n = snprintf(buf, NF_DOUBLE17_MAX, "%.17g", x);
    return n > 0 ? (size_t)n : 0;
}

#ifdef __SIZEOF_INT128__

typedef unsigned __int128 u128;

static const uint64_t pow10_64[20] = {1ULL,
                                      10ULL,
                                      100ULL,
                                      1000ULL,
                                      10000ULL,
                                      100000ULL,
                                      1000000ULL,
                                      10000000ULL,
                                      100000000ULL,
                                      1000000000ULL,
                                      10000000000ULL,
                                      100000000000ULL,
                                      1000000000000ULL,
                                      10000000000000ULL,
                                      100000000000000ULL,
                                      1000000000000000ULL,
                                      10000000000000000ULL,
                                      100000000000000000ULL,
                                      1000000000000000000ULL,
                                      10000000000000000000ULL};

/* round(m * 2^e2 * 10^k) for 0 <= k <= 19, half to even, or UINT64_MAX
 * when it does not fit the arithmetic. */
static uint64_t scaled(uint64_t m, int e2, int k)
{
    u128 num = (u128)m * pow10_64[k]; /* < 2^53 * 2^64 */
    if (e2 >= 0) {
        if (e2 > 10 || (num >> (127 - e2)) != 0)
            return UINT64_MAX;
        num <<= e2;
        return num >> 64 ? UINT64_MAX : (uint64_t)num;
    }
    int s = -e2;
    if (s >= 127)
        return UINT64_MAX;
    u128 q = num >> s, rem = num - (q << s), half = (u128)1 << (s - 1);
    if (rem > half || (rem == half && (q & 1)))
        q++;
    return q >> 64 ? UINT64_MAX : (uint64_t)q;
}

size_t nf_double17(double x, char *buf)
{
    if (!isfinite(x) || x == 0.0)
        return slow(x, buf);
    double ax = fabs(x);
    if (ax < 1e-3 || ax >= 1e16)
        return slow(x, buf);
    int E;
    double f = frexp(ax, &E); /* ax = f 2^E, f in [0.5, 1) */
    uint64_t m = (uint64_t)ldexp(f, 53);
    int e2 = E - 53;
    /* decimal exponent d: 10^d <= ax < 10^(d+1); k = 16 - d digits */
    int d = (int)floor(log10(ax));
    uint64_t q = 0;
    for (int tries = 0; tries < 3; tries++) {
        int k = 16 - d;
        if (k < 0 || k > 19)
            return slow(x, buf);
        q = scaled(m, e2, k);
        if (q == UINT64_MAX)
            return slow(x, buf);
        if (q < pow10_64[16]) {
            d--; /* log10 overestimated */
            continue;
        }
        if (q >= pow10_64[17]) {
            if (q == pow10_64[17]) { /* rounded up to the next power */
                q = pow10_64[16];
                d++;
                break;
            }
            d++;
            continue;
        }
        break;
    }
    if (q < pow10_64[16] || q >= pow10_64[17])
        return slow(x, buf);
    char dig[17];
    for (int i = 16; i >= 0; i--) {
        dig[i] = (char)('0' + q % 10);
        q /= 10;
    }
    int nd = 17; /* significant digits after dropping trailing zeros */
    while (nd > 1 && dig[nd - 1] == '0')
        nd--;
    size_t n = 0;
    if (x < 0)
        buf[n++] = '-';
    if (d < -4 || d >= 17) {
        /* %e style: never reached for the fast range, kept for clarity */
        return slow(x, buf);
    }
    if (d >= 0) {
        for (int i = 0; i <= d; i++)
            buf[n++] = dig[i];
        if (nd > d + 1) {
            buf[n++] = '.';
            for (int i = d + 1; i < nd; i++)
                buf[n++] = dig[i];
        }
    } else {
        buf[n++] = '0';
        buf[n++] = '.';
        for (int i = 0; i < -d - 1; i++)
            buf[n++] = '0';
        for (int i = 0; i < nd; i++)
            buf[n++] = dig[i];
    }
    buf[n] = 0;
    return n;
}

#else /* no 128-bit integers */

size_t nf_double17(double x, char *buf)
{
    return slow(x, buf);
}

#endif
