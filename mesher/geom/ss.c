/* geom/ss.c -- Hilbert curve keys and the BRIO insertion order. */
#include "config.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "base/pdr_error.h"
#include "geom/ss.h"

/* Bits per axis of the Hilbert keys: enough for about 2^12 cells per point
 * (uniform points then almost never share a cell, and clustered ones have
 * room to spread), at most 19 (2^57 cells). Fewer bits than the maximum
 * make the keys cheaper and the radix sort shorter: for 10^6 points, 11
 * bits, keys of 33 bits plus the round, 5 radix passes instead of 8. */
#define KEY_BITS_MAX 19
static int key_bits(size_t n)
{
    int lg = 0;
    while (lg < 63 && ((size_t)1 << lg) < n)
        lg++;
    int bits = (lg + 12 + 2) / 3;
    return bits < 4 ? 4 : bits > KEY_BITS_MAX ? KEY_BITS_MAX : bits;
}

/* Spreads the low 21 bits of x so that bit i moves to bit 3i. */
static uint64_t spread3(uint64_t x)
{
    x &= 0x1fffff;
    x = (x | x << 32) & 0x1f00000000ffffULL;
    x = (x | x << 16) & 0x1f0000ff0000ffULL;
    x = (x | x << 8) & 0x100f00f00f00f00fULL;
    x = (x | x << 4) & 0x10c30c30c30c30c3ULL;
    x = (x | x << 2) & 0x1249249249249249ULL;
    return x;
}

/* Skilling's method (J. Skilling, "Programming the Hilbert curve", AIP
 * Conf. Proc. 707, 2004): turn the coordinates into the "transposed"
 * Hilbert index in place, whose bits, read across the three words from the
 * most significant level down, are the index. */
uint64_t ss_hilbert3(uint32_t x, uint32_t y, uint32_t z, int bits)
{
    uint32_t X[3] = {x, y, z};
    uint32_t M = 1u << (bits - 1);
    for (uint32_t Q = M; Q > 1; Q >>= 1) {
        uint32_t P = Q - 1;
        for (int i = 0; i < 3; i++) {
            /* If bit Q of X[i] is set, invert the low bits of X[0], else
             * exchange the low bits of X[0] and X[i]; without branches, as
             * the bits are random. */
            uint32_t set = 0u - ((X[i] & Q) != 0);
            uint32_t t = (X[0] ^ X[i]) & P & ~set;
            X[0] ^= t ^ (P & set);
            X[i] ^= t;
        }
    }
    X[1] ^= X[0]; /* Gray encode */
    X[2] ^= X[1];
    uint32_t t = 0;
    for (uint32_t Q = M; Q > 1; Q >>= 1)
        if (X[2] & Q)
            t ^= Q - 1;
    for (int i = 0; i < 3; i++)
        X[i] ^= t;
    return spread3(X[0]) << 2 | spread3(X[1]) << 1 | spread3(X[2]);
}

static uint64_t splitmix(uint64_t *s)
{
    uint64_t z = (*s += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

/* LSD radix sort of 64-bit words by their bits lo..63, 8 bits a pass,
 * skipping passes where every word has the same digit; stable. */
static void radix_sort(uint64_t *a, uint64_t *tmp, size_t n, int lo)
{
    for (int shift = lo; shift < 64; shift += 8) {
        size_t count[257] = {0};
        for (size_t i = 0; i < n; i++)
            count[((a[i] >> shift) & 0xff) + 1]++;
        int trivial = 0;
        for (int d = 1; d <= 256; d++)
            if (count[d] == n)
                trivial = 1;
        if (trivial)
            continue;
        for (int d = 0; d < 256; d++)
            count[d + 1] += count[d];
        for (size_t i = 0; i < n; i++)
            tmp[count[(a[i] >> shift) & 0xff]++] = a[i];
        memcpy(a, tmp, n * sizeof *a);
    }
}

int ss_brio_hilbert(const double *xyz, size_t n, uint64_t seed, size_t min_round,
                    uint32_t *order)
{
    if (n == 0)
        return 0;
    if (min_round == 0)
        min_round = 1000;
    uint64_t *a = pr_malloc(n * sizeof *a), *tmp = pr_malloc(n * sizeof *tmp);
    if (!a || !tmp) {
        pr_free(a);
        pr_free(tmp);
        return PDR_ENOMEM;
    }
    double lo[3], hi[3];
    for (int k = 0; k < 3; k++)
        lo[k] = hi[k] = xyz[k];
    for (size_t i = 1; i < n; i++)
        for (int k = 0; k < 3; k++) {
            double c = xyz[3 * i + k];
            if (c < lo[k])
                lo[k] = c;
            if (c > hi[k])
                hi[k] = c;
        }
    double ext = 0;
    for (int k = 0; k < 3; k++)
        if (hi[k] - lo[k] > ext)
            ext = hi[k] - lo[k];
    /* Rounds grow by a factor of 4 (three quarters of the points in the
     * last round, 3/16 in the one before, ...; the rest in round 0, of at
     * least min_round points). Against a factor of 2, consecutive points
     * of a round are closer compared with the spacing of the mesh they are
     * inserted into, so the walks are shorter (random points: -9% walk
     * instructions, -6% insertion time) while the cavities grow a little
     * (+2% conflict tests). A factor of 8 shortens the walks a bit more but
     * makes grids and cospherical inputs slower. */
    int rounds = 0; /* index of the last round */
    while (rounds < 30 && (n >> (2 * (rounds + 1))) >= min_round)
        rounds++;
    /* Each point is sorted as one word: round, Hilbert key, point number,
     * from the high bits down (half the memory traffic of a key and a
     * number side by side). ib bits for the number, rb for the round,
     * and the key gets at most the rest; that only lowers the resolution
     * for more than 10^7 points, and for 2^32 points keeps 2^27 cells. */
    int ib = 1, rb = 1;
    while (ib < 32 && (n - 1) >> ib)
        ib++;
    while ((rounds >> rb) != 0)
        rb++;
    int kb = key_bits(n);
    if (3 * kb > 64 - ib - rb)
        kb = (64 - ib - rb) / 3;
    /* One scale for all axes keeps the cells cubes. */
    double cells = (double)((1u << kb) - 1);
    double scale = ext > 0 && isfinite(ext) ? cells / ext : 0;

    uint64_t s = seed;
    const uint64_t curve_max = (UINT64_C(1) << (3 * kb)) - 1;
    for (size_t i = 0; i < n; i++) {
        uint32_t q[3];
        for (int k = 0; k < 3; k++) {
            double c = (xyz[3 * i + k] - lo[k]) * scale;
            q[k] = c >= cells ? (uint32_t)cells : c > 0 ? (uint32_t)c : 0;
        }
        uint64_t h = ss_hilbert3(q[0], q[1], q[2], kb);
        /* Geometric: z = 0 with probability 3/4 (last round), 1 with
         * 3/16, ... the rest in round 0. */
        uint64_t r = splitmix(&s) | (UINT64_C(1) << 63);
        int z = __builtin_ctzll(r) / 2;
        int round = z >= rounds ? 0 : rounds - z;
        if ((rounds - round) & 1)
            h = curve_max - h;
        a[i] = (((uint64_t)round << (3 * kb) | h) << ib) | (uint64_t)i;
    }
    radix_sort(a, tmp, n, ib);
    const uint64_t idx_mask = (UINT64_C(1) << ib) - 1;
    for (size_t i = 0; i < n; i++)
        order[i] = (uint32_t)(a[i] & idx_mask);
    pr_free(a);
    pr_free(tmp);
    return 0;
}
