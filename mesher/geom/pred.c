/*
 * geom/pred.c -- exact orientation and in-sphere predicates.
 *
 * Notation: eps = 2^-53 is the unit roundoff of IEEE double arithmetic with
 * round-to-nearest; fl(x op y) = (x op y)(1 + d) with |d| <= eps as long as
 * the result neither overflows nor is subnormal. The build turns off FMA
 * contraction (-ffp-contract=off), which these bounds depend on: a fused
 * multiply-add rounds once where the analysis below counts two roundings of
 * different sizes, and the bounds would no longer hold as written.
 *
 * ---------------------------------------------------------------- filters
 * Each filter translates the points so that the query point is the origin,
 * giving "entries" x = fl(p - q) (rounded differences, relative error
 * <= eps each), evaluates the determinant of the entries in a fixed order,
 * and compares it with a bound C * (product of column maxima) where Mx, My,
 * Mz are the largest |entry| of each column. Such a bound (a "semi-static"
 * filter) is cheaper than one built from the permanent. Derivations, first
 * order in eps (second-order terms are below 1e-13 relative and are covered
 * by the margin between the derived and the used constant):
 *
 * orient3d, rows u, v, w:  m1 = vy*wz - vz*wy (and cyclic), det = ux*m1 +
 *   uy*m2 + uz*m3. A product of two entries is off by <= eps*MyMz, the
 *   difference by <= eps*2MyMz, so |m1 - exact| <= 4eps*MyMz, |m1| <= 2MyMz.
 *   Each term ux*m1: 4eps*P + eps*2P = 6eps*P (P = MxMyMz), |term| <= 2P.
 *   The two additions: eps*4P + eps*6P. Evaluation error <= 28eps*P.
 *   Rounding of the 9 entries: the determinant has 6 monomials of 3 entries,
 *   each off by <= 3eps*P: 18eps*P. Total 46eps*P; we use 48eps*P.
 * insphere, rows a,b,c,d (translated by e), lifted l = x^2+y^2+z^2:
 *   2x2 minors m_ij = ix*jy - jx*iy (error 4eps*MxMy, |m| <= 2MxMy), 3x3
 *   minors D(i,j,k) = iz*m_jk - jz*m_ik + kz*m_ij (error 28eps*P, |D| <= 6P),
 *   lifts with S = Mx^2+My^2+Mz^2 (error 3eps*S, |l| <= S), terms l*D:
 *   3eps*S*6P + S*28eps*P + eps*6SP = 52eps*S*P each, |l*D| <= 6SP; the sum
 *   (t1 - t2) + (t3 - t4) adds eps*(12+12+24)SP. Evaluation <= 256eps*S*P.
 *   Entry rounding: 4 * S * 6P worth of degree-5 monomials, each off by
 *   <= 5eps: 120eps*S*P. Total 376eps*S*P. This filter runs about fifty
 *   times per inserted point, so the column maxima are replaced by a
 *   cheaper quantity already at hand: with L the largest lift, every entry
 *   is at most sqrt(L), so S*P <= 3L * L^(3/2) and the error is at most
 *   1128eps*L^(5/2). We test det^2 > (1140eps)^2 * L^5 (no square root;
 *   the margin of 12eps*L^(5/2) also covers the rounding of the lifts, of
 *   det^2 and of L^5).
 * orient2d, rows u, v: det = ux*vy - uy*vx: 4eps + 4eps = 8eps*MxMy; use 10.
 * incircle, rows a,b,c (translated by d), l = x^2+y^2, S = Mx^2+My^2:
 *   terms l*m: 2eps*S*2P + S*4eps*P + eps*2SP = 10eps*SP, sum (t1-t2)+t3 adds
 *   10eps*SP, entry rounding 6SP * 4eps: total 64eps*S*P; use 68.
 *
 * Overflow and underflow. The derivations assume neither happens. Overflow
 * needs no test: it produces an infinity or a NaN in the determinant or in
 * the bound, and then the comparison "|det| > bound" is false, so the
 * filter hands over to exact arithmetic. Underflow in a product adds an
 * absolute error <= 2^-1075, which later products multiply by at most the
 * column maxima; requiring every column maximum to lie in [2^-330, 2^330]
 * (orient3d), [2^-500, 2^500] (orient2d), [2^-240, 2^240] (incircle), and
 * for insphere the largest lift L to [2^-190, 2^190] (then L^5 and det^2
 * are normal numbers, and underflow terms, at most about 150*L^(3/2)*2^-1075,
 * are below 2^-800 of the margin) keeps all such contributions far below the
 * margin of the constants above and rules out overflow of the monomials.
 * Outside those ranges the filter declines and exact arithmetic decides.
 *
 * A third filter, in double-word arithmetic (orient3d and insphere, after
 * the permanent-bounded second one; derivation at pred__insphere_dw),
 * decides the nearly flat and nearly cospherical cases that are not
 * exactly degenerate, which tessellated CAD surfaces make common, for a
 * fraction of the cost of the exact stages below.
 *
 * ------------------------------------------------------ exact evaluation
 * A double is m * 2^e with an integer m < 2^53 (subnormals included). A
 * monomial of k doubles is the integer product of their mantissas (at most
 * 53k bits) times 2^(sum of exponents). All monomials of one determinant
 * have the same degree k, so with emin the smallest exponent among the
 * arguments, every monomial is an integer multiple of 2^(k*emin). We add
 * them, shifted to that common origin, into a two's complement fixed-point
 * integer of k*(emax-emin) + 53k + 11 bits, which holds the exact sum
 * (at most 360 monomials). For nearby points of ordinary magnitude that is
 * about ten 32-bit words; the widest possible case (subnormals next to
 * 2^1023, degree 5) needs 330 words, which is the size of the buffer. The
 * sign of the sum is the sign of the determinant. This is exact for every
 * finite double, unlike floating-point expansion arithmetic, which breaks
 * when a partial product underflows.
 */
#include "config.h"

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "geom/pred.h"

#define EPS (DBL_EPSILON / 2) /* 2^-53 */

/* Column-maximum ranges in which the 2D filters' bounds are proved (the 3D
 * filters are inline in geom/pred.h, with their constants). */
#define O2_LO 0x1p-500
#define O2_HI 0x1p+500
#define IC_LO 0x1p-240
#define IC_HI 0x1p+240

static const double o2_bound = 10.0 * EPS;
static const double ic_bound = 68.0 * EPS;

/* ================================================ fixed-point big integer */

#define BIG_LIMBS 336 /* >= (5 * 2045 + 5 * 53 + 11) / 32 + 2 */

typedef struct bigacc {
    uint32_t w[BIG_LIMBS]; /* two's complement, little-endian 32-bit words */
    int n;                 /* words in use */
    int base;              /* exponent of bit 0 */
} bigacc;

typedef struct dbits {
    uint64_t m; /* mantissa, < 2^53 */
    int e;      /* value = (neg ? -1 : 1) * m * 2^e */
    int neg;
} dbits;

static dbits decompose(double v)
{
    uint64_t u;
    memcpy(&u, &v, sizeof u);
    dbits d;
    d.neg = (int)(u >> 63);
    int ef = (int)((u >> 52) & 0x7ff);
    uint64_t frac = u & ((UINT64_C(1) << 52) - 1);
    if (ef == 0) {
        d.m = frac;
        d.e = -1074;
    } else {
        d.m = frac | (UINT64_C(1) << 52);
        d.e = ef - 1075;
    }
    return d;
}

/* Adds (neg ? -1 : 1) * val * 2^shift, val given as len 32-bit words. */
static void big_add_shifted(bigacc *acc, const uint32_t *val, int len, int shift, int neg)
{
    int q = shift >> 5, r = shift & 31;
    uint64_t carry = 0;
    int k = q;
    for (int i = 0; i <= len && k < acc->n; i++, k++) {
        uint32_t cur = i < len ? val[i] : 0;
        uint32_t prev = i > 0 ? val[i - 1] : 0;
        uint32_t word = r ? (uint32_t)(cur << r) | (prev >> (32 - r)) : cur;
        if (!neg) {
            uint64_t t = (uint64_t)acc->w[k] + word + carry;
            acc->w[k] = (uint32_t)t;
            carry = t >> 32;
        } else {
            uint64_t t = (uint64_t)acc->w[k] - word - carry;
            acc->w[k] = (uint32_t)t;
            carry = (t >> 63) & 1;
        }
    }
    for (; carry && k < acc->n; k++) {
        if (!neg) {
            uint64_t t = (uint64_t)acc->w[k] + carry;
            acc->w[k] = (uint32_t)t;
            carry = t >> 32;
        } else {
            uint64_t t = (uint64_t)acc->w[k] - carry;
            acc->w[k] = (uint32_t)t;
            carry = (t >> 63) & 1;
        }
    }
}

static int big_sign(const bigacc *acc)
{
    if (acc->w[acc->n - 1] >> 31)
        return -1;
    for (int i = 0; i < acc->n; i++)
        if (acc->w[i])
            return 1;
    return 0;
}

/* One determinant to evaluate exactly: n x n, rows given as 'dim'
 * coordinates each, the columns being the dim coordinates, then (if
 * has_lift) the sum of the squared coordinates, then (if has_one) a 1. */
typedef struct detspec {
    int n, dim, has_lift, has_one;
    dbits val[15]; /* val[r*dim + k] */
    int deg;
    bigacc acc;
} detspec;

static void add_monomial(detspec *s, const int *idx, int nf, int sign)
{
    uint32_t buf[2][12];
    uint32_t *prod = buf[0], *res = buf[1];
    int len = 0, esum = 0, neg = sign < 0;
    for (int f = 0; f < nf; f++) {
        const dbits *d = &s->val[idx[f]];
        esum += d->e;
        neg ^= d->neg;
        if (f == 0) {
            prod[0] = (uint32_t)d->m;
            prod[1] = (uint32_t)(d->m >> 32);
            len = 2;
            continue;
        }
        /* res = prod * m, with m < 2^53 taken as two 32-bit words */
        uint64_t m0 = d->m & 0xffffffffu, m1 = d->m >> 32, c = 0;
        for (int i = 0; i < len; i++) {
            uint64_t t = (uint64_t)prod[i] * m0 + c;
            res[i] = (uint32_t)t;
            c = t >> 32;
        }
        res[len] = (uint32_t)c;
        c = 0;
        for (int i = 0; i < len; i++) {
            uint64_t t = (uint64_t)prod[i] * m1 + res[i + 1] + c;
            res[i + 1] = (uint32_t)t;
            c = t >> 32;
        }
        res[len + 1] = (uint32_t)c;
        len += 2;
        while (len > 0 && res[len - 1] == 0)
            len--;
        uint32_t *t = prod;
        prod = res;
        res = t;
    }
    big_add_shifted(&s->acc, prod, len, esum - s->acc.base, neg);
}

static void visit_permutation(detspec *s, const int *perm, int sign)
{
    int idx[6], nf = 0, lift_row = -1;
    for (int r = 0; r < s->n; r++) {
        int col = perm[r];
        if (col < s->dim) {
            int i = r * s->dim + col;
            if (s->val[i].m == 0)
                return;
            idx[nf++] = i;
        } else if (s->has_lift && col == s->dim) {
            lift_row = r;
        }
    }
    if (lift_row < 0) {
        add_monomial(s, idx, nf, sign);
        return;
    }
    for (int k = 0; k < s->dim; k++) {
        int i = lift_row * s->dim + k;
        if (s->val[i].m == 0)
            continue;
        idx[nf] = idx[nf + 1] = i;
        add_monomial(s, idx, nf + 2, sign);
    }
}

/* Exact sign of the determinant described above; rows has n*dim values. */
static int exact_det_sign(int n, int dim, int has_lift, int has_one, const double *rows)
{
    detspec s;
    s.n = n;
    s.dim = dim;
    s.has_lift = has_lift;
    s.has_one = has_one;
    s.deg = dim + (has_lift ? 2 : 0);
    int emin = 1 << 20, emax = -(1 << 20), any = 0;
    for (int i = 0; i < n * dim; i++) {
        s.val[i] = decompose(rows[i]);
        if (s.val[i].m) {
            any = 1;
            if (s.val[i].e < emin)
                emin = s.val[i].e;
            if (s.val[i].e > emax)
                emax = s.val[i].e;
        }
    }
    if (!any)
        return 0;
    int nbits = s.deg * (emax - emin) + 53 * s.deg + 11;
    s.acc.n = nbits / 32 + 2;
    s.acc.base = s.deg * emin;
    memset(s.acc.w, 0, (size_t)s.acc.n * sizeof s.acc.w[0]);

    /* Heap's algorithm: each permutation differs from the previous one by a
     * single swap, so the sign alternates. perm[r] is the column of row r. */
    int perm[5], c[5] = {0}, sign = 1;
    for (int i = 0; i < n; i++)
        perm[i] = i;
    visit_permutation(&s, perm, sign);
    int i = 1;
    while (i < n) {
        if (c[i] < i) {
            int j = (i % 2 == 0) ? 0 : c[i];
            int t = perm[j];
            perm[j] = perm[i];
            perm[i] = t;
            sign = -sign;
            visit_permutation(&s, perm, sign);
            c[i]++;
            i = 1;
        } else {
            c[i] = 0;
            i++;
        }
    }
    return big_sign(&s.acc);
}

/* Rounded difference x = fl(a - b); returns nonzero if it is exact. */
static int diff_exact(double a, double b, double x)
{
    double bv = a - x;
    double av = x + bv;
    double br = bv - b;
    double ar = a - av;
    return ar + br == 0.0;
}

/* Fills out[] with p_i - q for the given points and reports whether every
 * difference is exact. */
static int diffs(const double *const *p, int np, const double *q, int dim, double *out)
{
    int exact = 1;
    for (int i = 0; i < np; i++)
        for (int k = 0; k < dim; k++) {
            double x = p[i][k] - q[k];
            out[i * dim + k] = x;
            exact &= diff_exact(p[i][k], q[k], x);
        }
    return exact;
}

/* Inline max/min: fmax/fmin are library calls at -O2 because of their NaN
 * rules. Entries are never NaN (differences of finite doubles); an infinite
 * entry makes the maximum infinite and the filter declines. */
static inline double dmax(double a, double b)
{
    return a > b ? a : b;
}
static inline double dmin(double a, double b)
{
    return a < b ? a : b;
}

static int neg_sign(int s)
{
    return -s;
}

/* Small integers. Exactly degenerate inputs are mostly grids: entries that
 * are multiples of one power of two 2^s with few significant bits. If
 * every entry is a multiple of 2^s and at most 2^(k+s) in magnitude, every
 * intermediate of a degree-d determinant evaluated as in the filters is an
 * integer multiple of 2^(d*s) below 2^53 of those units (k <= 16 for
 * orient3d: |det| <= 3*2^(3k+1); k <= 9 for insphere: |det| <= 72*2^(5k)),
 * so the floating-point evaluation is exact, sign 0 included. -190 <= s <=
 * 150 keeps every unit a normal number and the results far from overflow. This is about a hundred instructions
 * where the big-integer sum takes microseconds. */
static int small_integers(const double *x, int n, int kmax)
{
    int smin = 1 << 20;
    double amax = 0;
    for (int i = 0; i < n; i++) {
        if (x[i] == 0)
            continue;
        uint64_t u;
        memcpy(&u, &x[i], sizeof u);
        int ef = (int)((u >> 52) & 0x7ff);
        if (ef == 0 || ef == 0x7ff)
            return 0; /* subnormal, infinite */
        uint64_t mant = (u & ((UINT64_C(1) << 52) - 1)) | (UINT64_C(1) << 52);
        int lsb = ef - 1075 + __builtin_ctzll(mant);
        if (lsb < smin)
            smin = lsb;
        double a = fabs(x[i]);
        if (a > amax)
            amax = a;
    }
    if (amax == 0)
        return 1;
    return smin >= -190 && smin <= 150 && amax <= ldexp(1.0, kmax + smin);
}

/* ============================================ exact floating point (xf)
 * A second exact method, much faster than summing monomials when the
 * arguments span few binades (the usual near-degenerate case: points on a
 * sphere, a scaled grid): numbers m * 2^base with m a multi-word integer of
 * at most XF_LIMBS words, and exact +, -, *. The determinant is evaluated
 * with the very formula of the filters, every operation exact. If a result
 * would not fit (arguments spanning hundreds of binades), the caller falls
 * back to the monomial sums above. About 3 KiB of stack. */

#define XF_LIMBS 28

typedef struct xf {
    int base; /* exponent of bit 0 of w[0], a multiple of 32 */
    int n;    /* words in use; 0 means the value 0 */
    int neg;
    uint32_t w[XF_LIMBS];
} xf;

static void xf_set(xf *r, double v)
{
    r->neg = 0;
    r->n = 0;
    r->base = 0;
    if (v == 0)
        return;
    dbits d = decompose(v);
    int q = d.e >= 0 ? d.e / 32 : -((31 - d.e) / 32); /* floor(e / 32) */
    int sh = d.e - 32 * q;                            /* 0..31 */
    uint64_t lo = d.m << sh;                          /* low 64 bits of m << sh */
    uint64_t hi = sh ? d.m >> (64 - sh) : 0;
    r->w[0] = (uint32_t)lo;
    r->w[1] = (uint32_t)(lo >> 32);
    r->w[2] = (uint32_t)hi;
    r->n = 3;
    while (r->n > 0 && r->w[r->n - 1] == 0)
        r->n--;
    r->base = 32 * q;
    r->neg = d.neg;
}

/* Drops zero words at both ends. */
static void xf_trim(xf *r)
{
    while (r->n > 0 && r->w[r->n - 1] == 0)
        r->n--;
    int z = 0;
    while (z < r->n && r->w[z] == 0)
        z++;
    if (z) {
        memmove(r->w, r->w + z, (size_t)(r->n - z) * sizeof r->w[0]);
        r->n -= z;
        r->base += 32 * z;
    }
    if (r->n == 0)
        r->neg = 0;
}

/* r = a * b (r distinct from a and b); -1 if it does not fit. */
static int xf_mul(xf *r, const xf *a, const xf *b)
{
    r->neg = 0;
    r->n = 0;
    r->base = 0;
    if (!a->n || !b->n)
        return 0;
    if (a->n + b->n > XF_LIMBS)
        return -1;
    int n = a->n + b->n;
    for (int i = 0; i < n; i++)
        r->w[i] = 0;
    for (int i = 0; i < a->n; i++) {
        uint64_t c = 0;
        for (int j = 0; j < b->n; j++) {
            uint64_t t = (uint64_t)a->w[i] * b->w[j] + r->w[i + j] + c;
            r->w[i + j] = (uint32_t)t;
            c = t >> 32;
        }
        r->w[i + b->n] = (uint32_t)c;
    }
    r->n = n;
    r->base = a->base + b->base;
    r->neg = a->neg ^ b->neg;
    xf_trim(r);
    return 0;
}

/* r = a + (sub ? -b : b); r may be a or b. -1 if it does not fit. */
static int xf_add(xf *r, const xf *a, const xf *b, int sub)
{
    int bneg = b->neg ^ sub;
    if (!b->n) {
        if (r != a)
            *r = *a;
        return 0;
    }
    if (!a->n) {
        if (r != b)
            *r = *b;
        r->neg = bneg;
        return 0;
    }
    int base = a->base < b->base ? a->base : b->base;
    int oa = (a->base - base) / 32, ob = (b->base - base) / 32;
    int top = (oa + a->n > ob + b->n ? oa + a->n : ob + b->n) + 1;
    if (top > XF_LIMBS)
        return -1;
    uint32_t x[XF_LIMBS], y[XF_LIMBS];
    for (int i = 0; i < top; i++) {
        x[i] = i >= oa && i < oa + a->n ? a->w[i - oa] : 0;
        y[i] = i >= ob && i < ob + b->n ? b->w[i - ob] : 0;
    }
    int neg = a->neg;
    if (a->neg == bneg) {
        uint64_t c = 0;
        for (int i = 0; i < top; i++) {
            uint64_t t = (uint64_t)x[i] + y[i] + c;
            r->w[i] = (uint32_t)t;
            c = t >> 32;
        }
    } else {
        int cmp = 0;
        for (int i = top - 1; i >= 0 && !cmp; i--)
            cmp = (x[i] > y[i]) - (x[i] < y[i]);
        const uint32_t *big = cmp >= 0 ? x : y, *small = cmp >= 0 ? y : x;
        neg = cmp >= 0 ? a->neg : bneg;
        uint64_t brw = 0;
        for (int i = 0; i < top; i++) {
            uint64_t t = (uint64_t)big[i] - small[i] - brw;
            r->w[i] = (uint32_t)t;
            brw = (t >> 63) & 1;
        }
    }
    r->n = top;
    r->base = base;
    r->neg = neg;
    xf_trim(r);
    return 0;
}

static int xf_sign(const xf *a)
{
    return a->n == 0 ? 0 : a->neg ? -1 : 1;
}

/* r = p - q for doubles, exactly. */
static int xf_diff(xf *r, double p, double q)
{
    xf a, b;
    xf_set(&a, p);
    xf_set(&b, q);
    return xf_add(r, &a, &b, 1);
}

/* r = u*v - w*x */
static int xf_cross(xf *r, const xf *u, const xf *v, const xf *w, const xf *x)
{
    xf s, t;
    if (xf_mul(&s, u, v) || xf_mul(&t, w, x))
        return -1;
    return xf_add(r, &s, &t, 1);
}

/* r = iz*m_jk - jz*m_ik + kz*m_ij */
static int xf_minor3(xf *r, const xf *iz, const xf *jz, const xf *kz, const xf *mjk,
                     const xf *mik, const xf *mij)
{
    xf t;
    if (xf_cross(r, iz, mjk, jz, mik) || xf_mul(&t, kz, mij))
        return -1;
    return xf_add(r, r, &t, 0);
}

/* Exact orient3d by xf: the sign, or 2 if a value did not fit. */
static int orient3d_xf(const double *a, const double *b, const double *c, const double *d)
{
    xf u[3], v[3], w[3], m[3], t, det;
    for (int k = 0; k < 3; k++)
        if (xf_diff(&u[k], a[k], d[k]) || xf_diff(&v[k], b[k], d[k]) ||
            xf_diff(&w[k], c[k], d[k]))
            return 2;
    if (xf_cross(&m[0], &v[1], &w[2], &v[2], &w[1]) ||
        xf_cross(&m[1], &v[2], &w[0], &v[0], &w[2]) ||
        xf_cross(&m[2], &v[0], &w[1], &v[1], &w[0]))
        return 2;
    if (xf_mul(&det, &u[0], &m[0]) || xf_mul(&t, &u[1], &m[1]) || xf_add(&det, &det, &t, 0) ||
        xf_mul(&t, &u[2], &m[2]) || xf_add(&det, &det, &t, 0))
        return 2;
    return -xf_sign(&det); /* orient3d = -det[a-d; b-d; c-d] */
}

/* Exact insphere by xf: the sign, or 2 if a value did not fit. */
static int insphere_xf(const double *a, const double *b, const double *c, const double *d,
                       const double *e)
{
    const double *pt[4] = {a, b, c, d};
    xf r[4][3], l[4], mi[6], t, u, det;
    for (int i = 0; i < 4; i++) {
        for (int k = 0; k < 3; k++)
            if (xf_diff(&r[i][k], pt[i][k], e[k]))
                return 2;
        if (xf_mul(&l[i], &r[i][0], &r[i][0]) || xf_mul(&t, &r[i][1], &r[i][1]) ||
            xf_add(&l[i], &l[i], &t, 0) || xf_mul(&t, &r[i][2], &r[i][2]) ||
            xf_add(&l[i], &l[i], &t, 0))
            return 2;
    }
    /* 2x2 minors of (x, y): ab ac ad bc bd cd */
    static const int pairs[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
    for (int q = 0; q < 6; q++) {
        int i = pairs[q][0], j = pairs[q][1];
        if (xf_cross(&mi[q], &r[i][0], &r[j][1], &r[j][0], &r[i][1]))
            return 2;
    }
    enum { AB, AC, AD, BC, BD, CD };
    /* det = la*D(bcd) - lb*D(acd) + lc*D(abd) - ld*D(abc) */
    det.n = 0;
    det.neg = 0;
    det.base = 0;
    static const int tri[4][6] = {
        /* rows i,j,k (z from them) and minors jk, ik, ij */
        {1, 2, 3, CD, BD, BC}, {0, 2, 3, CD, AD, AC}, {0, 1, 3, BD, AD, AB}, {0, 1, 2, BC, AC, AB}};
    for (int q = 0; q < 4; q++) {
        const int *T = tri[q];
        if (xf_minor3(&u, &r[T[0]][2], &r[T[1]][2], &r[T[2]][2], &mi[T[3]], &mi[T[4]],
                      &mi[T[5]]) ||
            xf_mul(&t, &l[q], &u) || xf_add(&det, &det, &t, q & 1))
            return 2;
    }
    return xf_sign(&det);
}

/* ============================================================ orient3d */

int pred__orient3d_exact(const double *a, const double *b, const double *c, const double *d,
                         int stage)
{
    if (stage == 1)
        return orient3d_xf(a, b, c, d);
    if (stage == 0 || stage == 2) {
        const double *p[3] = {a, b, c};
        double rows[9];
        if (!diffs(p, 3, d, 3, rows))
            return 2;
        /* orient3d = -det[a-d; b-d; c-d] */
        if (small_integers(rows, 9, 16)) {
            const double *u = rows, *v = rows + 3, *w = rows + 6;
            double det = u[0] * (v[1] * w[2] - v[2] * w[1]) + u[1] * (v[2] * w[0] - v[0] * w[2]) +
                         u[2] * (v[0] * w[1] - v[1] * w[0]);
            return (det < 0) - (det > 0);
        }
        if (stage == 0)
            return 2;
        return neg_sign(exact_det_sign(3, 3, 0, 0, rows));
    }
    double rows[12];
    memcpy(rows, a, 3 * sizeof(double));
    memcpy(rows + 3, b, 3 * sizeof(double));
    memcpy(rows + 6, c, 3 * sizeof(double));
    memcpy(rows + 9, d, 3 * sizeof(double));
    /* det[x y z 1] of (a,b,c,d) equals det[a-d; b-d; c-d] = -orient3d. */
    return neg_sign(exact_det_sign(4, 3, 0, 1, rows));
}

/* Exact orient3d in fixed-width integers, for the common exactly coplanar
 * case (points of a tilted facet) that every filter declines. When the
 * twelve coordinates, written as integers times 2^lo (lo the lowest set
 * bit among them), are all below 2^61, the differences fit in 62 bits,
 * the 2x2 minors (two products of 124 bits) in a signed 128-bit integer,
 * and each of the three terms u * minor (at most 2^187) and their sum (at
 * most 2^189) in 192-bit two's complement: every step is exact. Otherwise
 * returns 2. */
typedef struct i192 {
    uint64_t w[3]; /* two's complement, little-endian */
} i192;

/* w = -w in n-word two's complement. */
static void words_neg(uint64_t *w, int n)
{
    unsigned __int128 c = 1;
    for (int i = 0; i < n; i++) {
        c += (uint64_t)~w[i];
        w[i] = (uint64_t)c;
        c >>= 64;
    }
}

/* acc += t, n words, modulo 2^(64 n). */
static void words_add(uint64_t *acc, const uint64_t *t, int n)
{
    unsigned __int128 c = 0;
    for (int i = 0; i < n; i++) {
        c += (unsigned __int128)acc[i] + t[i];
        acc[i] = (uint64_t)c;
        c >>= 64;
    }
}

/* acc += u * m, exactly (|u| < 2^63, |m| < 2^126). */
static void i192_add_mul(i192 *acc, int64_t u, __int128 m)
{
    int neg = (u < 0) != (m < 0);
    uint64_t au = u < 0 ? (uint64_t)0 - (uint64_t)u : (uint64_t)u;
    unsigned __int128 am = m < 0 ? (unsigned __int128)0 - (unsigned __int128)m
                                 : (unsigned __int128)m;
    unsigned __int128 p0 = (unsigned __int128)au * (uint64_t)am;
    unsigned __int128 p1 = (unsigned __int128)au * (uint64_t)(am >> 64) + (p0 >> 64);
    uint64_t t[3] = {(uint64_t)p0, (uint64_t)p1, (uint64_t)(p1 >> 64)};
    if (neg) /* two's complement of the magnitude */
        words_neg(t, 3);
    words_add(acc->w, t, 3);
}

/* Writes the coordinates of np points as integers q times 2^lo, lo the
 * lowest set bit among them: 1 when every |q| < 2^61 (so differences fit
 * in 62 bits), 0 when all are zero, 2 when they span more than 61 bits or
 * one is not finite. */
static int int_coords(const double *const *pt, int np, int64_t (*q)[3])
{
    dbits x[5][3];
    int lo = INT32_MAX, hi = INT32_MIN;
    for (int i = 0; i < np; i++)
        for (int k = 0; k < 3; k++) {
            double v = pt[i][k];
            if (!isfinite(v))
                return 2;
            x[i][k] = decompose(v);
            uint64_t m = x[i][k].m;
            if (!m)
                continue;
            int z = __builtin_ctzll(m); /* an odd mantissa: its exponent is its lowest bit */
            x[i][k].m = m >>= z;
            x[i][k].e += z;
            int low = x[i][k].e, top = x[i][k].e + 64 - __builtin_clzll(m);
            lo = low < lo ? low : lo;
            hi = top > hi ? top : hi;
        }
    if (lo == INT32_MAX)
        return 0;
    if (hi - lo > 61)
        return 2;
    for (int i = 0; i < np; i++)
        for (int k = 0; k < 3; k++) {
            int64_t v = x[i][k].m ? (int64_t)(x[i][k].m << (x[i][k].e - lo)) : 0;
            q[i][k] = x[i][k].neg ? -v : v;
        }
    return 1;
}

static int i192_sign(const i192 *x)
{
    if (!x->w[0] && !x->w[1] && !x->w[2])
        return 0;
    return (x->w[2] >> 63) ? -1 : 1;
}

/* det[u; v; w] of three integer vectors (|entries| < 2^62), exactly:
 * the 2x2 minors below 2^125, each term below 2^187. */
static i192 i192_det3(const int64_t *u, const int64_t *v, const int64_t *w)
{
    __int128 m0 = (__int128)v[1] * w[2] - (__int128)v[2] * w[1];
    __int128 m1 = (__int128)v[2] * w[0] - (__int128)v[0] * w[2];
    __int128 m2 = (__int128)v[0] * w[1] - (__int128)v[1] * w[0];
    i192 det = {{0, 0, 0}};
    i192_add_mul(&det, u[0], m0);
    i192_add_mul(&det, u[1], m1);
    i192_add_mul(&det, u[2], m2);
    return det;
}

int pred__orient3d_int(const double *a, const double *b, const double *c, const double *d)
{
    const double *pt[4] = {a, b, c, d};
    int64_t q[4][3];
    int st = int_coords(pt, 4, q);
    if (st != 1)
        return st; /* 0: all zero */
    int64_t u[3], v[3], w[3];
    for (int k = 0; k < 3; k++) {
        u[k] = q[0][k] - q[3][k];
        v[k] = q[1][k] - q[3][k];
        w[k] = q[2][k] - q[3][k];
    }
    i192 det = i192_det3(u, v, w);
    return -i192_sign(&det); /* orient3d = -det[a-d; b-d; c-d] */
}

/* Exact insphere in fixed-width integers, for the exactly cospherical
 * points of tessellated cylinders and spheres that every filter declines
 * (before, the multi-word stage at about 15,000 instructions a test).
 * With the coordinates as integers below 2^61 (int_coords), the
 * differences r_i = p_i - e are below 2^62, their lifts |r_i|^2 below
 * 2^126 (a signed 128-bit integer), the 3x3 minors det[r_j; r_k; r_l]
 * below 2^189 (192 bits, as orient3d's), and the determinant, the
 * alternating sum of four lift * minor products each below 2^315, below
 * 2^317: 320-bit two's complement holds every step exactly. The sum is the
 * one the filters evaluate (expansion along the lift column). */
typedef struct i320 {
    uint64_t w[5]; /* two's complement, little-endian */
} i320;

/* acc += x * l, exactly (x a 192-bit value below 2^189, 0 <= l < 2^126,
 * neg: subtract instead). */
static void i320_add_mul(i320 *acc, const i192 *x, unsigned __int128 l, int neg)
{
    uint64_t mx[3];
    memcpy(mx, x->w, sizeof mx);
    if (mx[2] >> 63) { /* the magnitude of a negative x */
        neg = !neg;
        words_neg(mx, 3);
    }
    const uint64_t ml[2] = {(uint64_t)l, (uint64_t)(l >> 64)};
    uint64_t t[5] = {0, 0, 0, 0, 0};
    for (int i = 0; i < 3; i++) {
        unsigned __int128 c = 0;
        for (int j = 0; j < 2; j++) {
            c += (unsigned __int128)mx[i] * ml[j] + t[i + j];
            t[i + j] = (uint64_t)c;
            c >>= 64;
        }
        t[i + 2] = (uint64_t)c;
    }
    if (neg)
        words_neg(t, 5);
    words_add(acc->w, t, 5);
}

int pred__insphere_int(const double *a, const double *b, const double *c, const double *d,
                       const double *e)
{
    const double *pt[5] = {a, b, c, d, e};
    int64_t q[5][3];
    int st = int_coords(pt, 5, q);
    if (st != 1)
        return st; /* 0: all zero */
    int64_t r[4][3];
    unsigned __int128 lift[4];
    for (int i = 0; i < 4; i++) {
        lift[i] = 0;
        for (int k = 0; k < 3; k++) {
            r[i][k] = q[i][k] - q[4][k];
            lift[i] += (unsigned __int128)((__int128)r[i][k] * r[i][k]);
        }
    }
    /* det = l_a D(bcd) - l_b D(acd) + l_c D(abd) - l_d D(abc), D the
     * determinant of the rows' (x, y, z) as insphere_xf forms it */
    static const int others[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
    i320 det = {{0, 0, 0, 0, 0}};
    for (int i = 0; i < 4; i++) {
        const int *o = others[i];
        i192 m = i192_det3(r[o[0]], r[o[1]], r[o[2]]);
        i320_add_mul(&det, &m, lift[i], i & 1);
    }
    int zero = 1;
    for (int i = 0; i < 5; i++)
        zero &= det.w[i] == 0;
    if (zero)
        return 0;
    return (det.w[4] >> 63) ? -1 : 1;
}

static int orient3d_exact(const double *a, const double *b, const double *c, const double *d)
{
    /* Four points in a plane x = const, y = const or z = const (the faces
     * of a box, grid tessellations): the common case where the filters
     * always fail, decided without arithmetic. */
    for (int k = 0; k < 3; k++)
        if (a[k] == b[k] && b[k] == c[k] && c[k] == d[k])
            return 0;
    int s = pred__orient3d_exact(a, b, c, d, 0);
    if (s == 2)
        s = pred__orient3d_int(a, b, c, d);
    if (s == 2)
        s = pred__orient3d_dw(a, b, c, d);
    if (s == 2)
        s = pred__orient3d_exact(a, b, c, d, 1);
    if (s == 2)
        s = pred__orient3d_exact(a, b, c, d, 2);
    return s != 2 ? s : pred__orient3d_exact(a, b, c, d, 3);
}

int pred__orient3d_filter(const double *a, const double *b, const double *c, const double *d)
{
    return pred_orient3d_filter_(a, b, c, d);
}

/* Second filter, with a bound proportional to the permanent (the same
 * determinant with every product and sum taken in absolute value), which
 * is tight for long thin tetrahedra where the column maxima overestimate
 * the terms by orders of magnitude. Derivation for the evaluation of the
 * first filter: minors off by 2eps*P_m (P_m = |vy*wz| + |vz*wy|), terms
 * u*m by 3eps*|u|*P_m, the two sums by 2eps*P: 5eps*P; entry rounding
 * 3eps*P; total 8eps*P, used 9eps*P. Valid when P >= 2^-800 (underflow in a
 * partial product, at most 2^-1075 times column maxima below 2^330, is then
 * far below the margin) and the column maxima are at most 2^330. */
/* det[a-d; b-d; c-d] as filter2 evaluates it, with its permanent (*perm)
 * and the largest |entry| (*hi), from the rounded differences. */
static double orient3d_det_perm(const double *a, const double *b, const double *c,
                                const double *d, double *perm, double *hi)
{
    double ux = a[0] - d[0], uy = a[1] - d[1], uz = a[2] - d[2];
    double vx = b[0] - d[0], vy = b[1] - d[1], vz = b[2] - d[2];
    double wx = c[0] - d[0], wy = c[1] - d[1], wz = c[2] - d[2];
    double p1 = vy * wz, p2 = vz * wy, p3 = vz * wx, p4 = vx * wz, p5 = vx * wy, p6 = vy * wx;
    *perm = fabs(ux) * (fabs(p1) + fabs(p2)) + fabs(uy) * (fabs(p3) + fabs(p4)) +
            fabs(uz) * (fabs(p5) + fabs(p6));
    *hi = dmax(dmax(dmax(fabs(ux), fabs(vx)), dmax(fabs(wx), fabs(uy))),
               dmax(dmax(fabs(vy), fabs(wy)), dmax(dmax(fabs(uz), fabs(vz)), fabs(wz))));
    return ux * (p1 - p2) + uy * (p3 - p4) + uz * (p5 - p6);
}

int pred__orient3d_filter2(const double *a, const double *b, const double *c, const double *d)
{
    double perm, hi, det = orient3d_det_perm(a, b, c, d, &perm, &hi);
    if (perm >= 0x1p-800 && hi <= 0x1p+330) {
        double bound = 9.0 * EPS * perm;
        if (det > bound)
            return -1;
        if (det < -bound)
            return 1;
    }
    return 2;
}

int pred_orient3d(const double *a, const double *b, const double *c, const double *d)
{
    int s = pred__orient3d_filter(a, b, c, d);
    if (s == 2)
        s = pred__orient3d_filter2(a, b, c, d);
    return s != 2 ? s : orient3d_exact(a, b, c, d);
}

/* ============================================================ insphere */

/* The insphere determinant as the filter evaluates it. */
static double insphere_det(const double *a, const double *b, const double *c, const double *d,
                           const double *e)
{
    double L;
    return pred_insphere_det_scalar_(a, b, c, d, e, &L);
}

int pred__insphere_exact(const double *a, const double *b, const double *c, const double *d,
                         const double *e, int stage)
{
    if (stage == 1)
        return insphere_xf(a, b, c, d, e);
    if (stage == 0 || stage == 2) {
        const double *p[4] = {a, b, c, d};
        double rows[12];
        if (!diffs(p, 4, e, 3, rows))
            return 2;
        if (small_integers(rows, 12, 9)) {
            /* the filter's formula, exact here; it evaluates insphere */
            static const double origin[3] = {0, 0, 0};
            double det = insphere_det(rows, rows + 3, rows + 6, rows + 9, origin);
            return (det > 0) - (det < 0);
        }
        if (stage == 0)
            return 2;
        /* insphere = -det[x y z l] of the translated rows (see geom/pred.h). */
        return neg_sign(exact_det_sign(4, 3, 1, 0, rows));
    }
    double rows[15];
    memcpy(rows, a, 3 * sizeof(double));
    memcpy(rows + 3, b, 3 * sizeof(double));
    memcpy(rows + 6, c, 3 * sizeof(double));
    memcpy(rows + 9, d, 3 * sizeof(double));
    memcpy(rows + 12, e, 3 * sizeof(double));
    /* det[x y z |p|^2 1] of (a,b,c,d,e) is positive when e is outside. */
    return neg_sign(exact_det_sign(5, 3, 1, 1, rows));
}

static int insphere_exact(const double *a, const double *b, const double *c, const double *d,
                          const double *e)
{
    int s = pred__insphere_exact(a, b, c, d, e, 0);
    if (s == 2)
        s = pred__insphere_dw(a, b, c, d, e);
    if (s == 2)
        s = pred__insphere_int(a, b, c, d, e);
    if (s == 2)
        s = pred__insphere_exact(a, b, c, d, e, 1);
    if (s == 2)
        s = pred__insphere_exact(a, b, c, d, e, 2);
    return s != 2 ? s : pred__insphere_exact(a, b, c, d, e, 3);
}

int pred__insphere_filter(const double *a, const double *b, const double *c, const double *d,
                          const double *e)
{
    return pred_insphere_filter_(a, b, c, d, e);
}

/* Second insphere filter, bounded by the permanent P = sum over rows of
 * l_i * perm(D_i), perm(D) = |iz|*P_m(jk) + |jz|*P_m(ik) + |kz|*P_m(ij),
 * P_m(ij) = |ix*jy| + |jx*iy|. For the first filter's evaluation: minors off
 * by 2eps*P_m, 3x3 terms by 3eps*|z|*P_m and their sums by 2eps*perm(D)
 * (D off by 5eps*perm(D)), lifts by 3eps*l, products l*D by
 * (3 + 5 + 1)eps*l*perm(D), the final sums by 2eps*P: 11eps*P; entry
 * rounding of degree-5 monomials 5eps*P; total 16eps*P, used 17eps*P.
 * Valid when P >= 2^-700 and the largest lift is at most 2^190 (underflow
 * terms, at most about 2^-1075 * (2^95)^3 each, are then far below the
 * margin; no overflow). */
/* The insphere determinant as filter2 evaluates it, with its permanent
 * (*perm) and the largest lift (*L), from the rounded differences. */
static double insphere_det_perm(const double *a, const double *b, const double *c,
                                const double *d, const double *e, double *perm, double *L)
{
    double ax = a[0] - e[0], ay = a[1] - e[1], az = a[2] - e[2];
    double bx = b[0] - e[0], by = b[1] - e[1], bz = b[2] - e[2];
    double cx = c[0] - e[0], cy = c[1] - e[1], cz = c[2] - e[2];
    double dx = d[0] - e[0], dy = d[1] - e[1], dz = d[2] - e[2];
    double la = (ax * ax + ay * ay) + az * az;
    double lb = (bx * bx + by * by) + bz * bz;
    double lc = (cx * cx + cy * cy) + cz * cz;
    double ld = (dx * dx + dy * dy) + dz * dz;
    double ab1 = ax * by, ab2 = bx * ay, ac1 = ax * cy, ac2 = cx * ay, ad1 = ax * dy,
           ad2 = dx * ay;
    double bc1 = bx * cy, bc2 = cx * by, bd1 = bx * dy, bd2 = dx * by, cd1 = cx * dy,
           cd2 = dx * cy;
    double ab = ab1 - ab2, ac = ac1 - ac2, ad = ad1 - ad2;
    double bc = bc1 - bc2, bd = bd1 - bd2, cd = cd1 - cd2;
    double pab = fabs(ab1) + fabs(ab2), pac = fabs(ac1) + fabs(ac2), pad = fabs(ad1) + fabs(ad2);
    double pbc = fabs(bc1) + fabs(bc2), pbd = fabs(bd1) + fabs(bd2), pcd = fabs(cd1) + fabs(cd2);
    double dbcd = (bz * cd - cz * bd) + dz * bc;
    double dacd = (az * cd - cz * ad) + dz * ac;
    double dabd = (az * bd - bz * ad) + dz * ab;
    double dabc = (az * bc - bz * ac) + cz * ab;
    double pbcd = (fabs(bz) * pcd + fabs(cz) * pbd) + fabs(dz) * pbc;
    double pacd = (fabs(az) * pcd + fabs(cz) * pad) + fabs(dz) * pac;
    double pabd = (fabs(az) * pbd + fabs(bz) * pad) + fabs(dz) * pab;
    double pabc = (fabs(az) * pbc + fabs(bz) * pac) + fabs(cz) * pab;
    *perm = (la * pbcd + lb * pacd) + (lc * pabd + ld * pabc);
    *L = dmax(dmax(la, lb), dmax(lc, ld));
    return (la * dbcd - lb * dacd) + (lc * dabd - ld * dabc);
}

int pred__insphere_filter2(const double *a, const double *b, const double *c, const double *d,
                           const double *e)
{
    double perm, L, det = insphere_det_perm(a, b, c, d, e, &perm, &L);
    if (perm >= 0x1p-700 && L <= 0x1p+190) {
        double bound = 17.0 * EPS * perm;
        if (det > bound)
            return 1;
        if (det < -bound)
            return -1;
    }
    return 2;
}

/* ============================================ double-word filter
 * A third filter between the permanent-bounded one and the exact stages:
 * the insphere determinant in double-word arithmetic (a value is an
 * unevaluated sum hi + lo of two doubles, |lo| <= ulp(hi) / 2). Far more
 * cases reach it than degeneracies: a tetrahedron that is nearly flat (a
 * sliver on a thin input triangle, tessellated CAD surfaces) makes the
 * determinant tiny next to its permanent for every fifth point, and the
 * first two filters, with bounds near 2^-49 P, decline; the multi-word
 * exact stage then costs about a microsecond a test. This filter decides
 * all but determinants within about 2^-97 P of zero, exact zeros included
 * never.
 *
 * The bound. The differences are exact double-words (two_sum). The
 * building blocks are the accurate sum of two double-words and the
 * product of two double-words from Dekker's exact product (Joldes, Muller
 * and Popescu, "Tight and rigorous error bounds for basic building blocks
 * of double-word arithmetic", ACM TOMS 2017: relative errors below 3u^2
 * and 7u^2, u = 2^-53); we take g = 16u^2 per operation. With relative
 * errors g per operation, a value computed by a tree of operations is off
 * by at most ((1+g)^K - 1) times its permanent (the same tree with every
 * input and operation taken in absolute value), K the largest number of
 * operations on a path where products add their operands' counts and
 * sums take the larger: 3 for a lift (ax*ax + ay*ay) + az*az, 2 for a
 * 2x2 minor, 5 for a 3x3 one, 9 for a lift times a minor, 11 for the
 * determinant. So the error is below 11.01 g P = 176.2 u^2 P < 2^-98.5 P,
 * P the permanent of the exact differences; P as filter2 computes it from
 * the rounded differences is at most 1 + 2^-47 times smaller, and the
 * bound used is 2^-97 P. That model holds without underflow or overflow:
 * every difference at most 2^100 in magnitude keeps every value below
 * 2^510 (and Dekker's splitting far from overflow); an underflowed
 * product or error term is off by at most 2^-1074, amplified by at most
 * 2^510 through the later products, some hundreds of times: below 2^-550,
 * negligible next to the bound when P >= 2^-400, which is required. */

typedef struct dw {
    double h, l;
} dw;

static inline dw dw_two_sum(double a, double b)
{
    double s = a + b, bv = s - a, av = s - bv;
    dw r = {s, (a - av) + (b - bv)};
    return r;
}

static inline dw dw_fast_two_sum(double a, double b)
{
    double s = a + b;
    dw r = {s, b - (s - a)};
    return r;
}

/* Dekker's split: a = hi + lo, each with at most 26 significant bits. */
static inline void dw_split(double a, double *hi, double *lo)
{
    double c = 134217729.0 * a; /* 2^27 + 1 */
    double big = c - a;
    *hi = c - big;
    *lo = a - *hi;
}

/* The exact product a * b as a double-word (Dekker). */
static inline dw dw_two_prod(double a, double b)
{
    double p = a * b, ah, al, bh, bl;
    dw_split(a, &ah, &al);
    dw_split(b, &bh, &bl);
    double err = ((ah * bh - p) + ah * bl + al * bh) + al * bl;
    dw r = {p, err};
    return r;
}

/* Accurate double-word sum. */
static inline dw dw_add(dw x, dw y)
{
    dw s = dw_two_sum(x.h, y.h), t = dw_two_sum(x.l, y.l);
    double c = s.l + t.h;
    dw v = dw_fast_two_sum(s.h, c);
    double w = t.l + v.l;
    return dw_fast_two_sum(v.h, w);
}

static inline dw dw_neg(dw x)
{
    dw r = {-x.h, -x.l};
    return r;
}

/* Double-word product (without fused multiply-add). */
static inline dw dw_mul(dw x, dw y)
{
    dw c = dw_two_prod(x.h, y.h);
    double t = x.h * y.l + x.l * y.h;
    return dw_fast_two_sum(c.h, c.l + t);
}

/* r[i] = pt[i] - q exactly, as double words, for np points; returns the
 * largest |high part|. */
static double dw_diffs(const double *const *pt, int np, const double *q, dw (*r)[3])
{
    double hi = 0;
    for (int i = 0; i < np; i++)
        for (int k = 0; k < 3; k++) {
            r[i][k] = dw_two_sum(pt[i][k], -q[k]);
            hi = dmax(hi, fabs(r[i][k].h));
        }
    return hi;
}

int pred__insphere_dw(const double *a, const double *b, const double *c, const double *d,
                      const double *e)
{
    const double *pt[4] = {a, b, c, d};
    dw r[4][3], l[4];
    double hi = dw_diffs(pt, 4, e, r);
    if (!(hi <= 0x1p+100))
        return 2; /* also NaN and infinities */
    double perm, L;
    (void)insphere_det_perm(a, b, c, d, e, &perm, &L);
    if (!(perm >= 0x1p-400))
        return 2;
    for (int i = 0; i < 4; i++)
        l[i] = dw_add(dw_add(dw_mul(r[i][0], r[i][0]), dw_mul(r[i][1], r[i][1])),
                      dw_mul(r[i][2], r[i][2]));
    /* 2x2 minors of (x, y), as in filter2: ab ac ad bc bd cd */
    static const int pairs[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
    dw mi[6];
    for (int q = 0; q < 6; q++) {
        int i = pairs[q][0], j = pairs[q][1];
        mi[q] = dw_add(dw_mul(r[i][0], r[j][1]), dw_neg(dw_mul(r[j][0], r[i][1])));
    }
    enum { AB, AC, AD, BC, BD, CD };
    static const int tri[4][6] = {
        {1, 2, 3, CD, BD, BC}, {0, 2, 3, CD, AD, AC}, {0, 1, 3, BD, AD, AB}, {0, 1, 2, BC, AC, AB}};
    dw t[4];
    for (int q = 0; q < 4; q++) {
        const int *T = tri[q];
        dw m = dw_add(dw_add(dw_mul(r[T[0]][2], mi[T[3]]), dw_neg(dw_mul(r[T[1]][2], mi[T[4]]))),
                      dw_mul(r[T[2]][2], mi[T[5]]));
        t[q] = dw_mul(l[q], m);
    }
    /* det = (la*D(bcd) - lb*D(acd)) + (lc*D(abd) - ld*D(abc)) */
    dw det = dw_add(dw_add(t[0], dw_neg(t[1])), dw_add(t[2], dw_neg(t[3])));
    double v = det.h + det.l, bound = 0x1p-97 * perm;
    if (v > bound)
        return 1;
    if (v < -bound)
        return -1;
    return 2;
}

/* The same for orient3d: -det[a-d; b-d; c-d] evaluated as filter2 does,
 * K = 5 (2x2 minors 2, times an entry 3, two sums), so the error is below
 * 5.01 g P < 2^-99.6 P; the bound used is 2^-98 P, under the same
 * conditions on the differences and P. */
int pred__orient3d_dw(const double *a, const double *b, const double *c, const double *d)
{
    const double *pt[3] = {a, b, c};
    dw r[3][3];
    double hi = dw_diffs(pt, 3, d, r);
    if (!(hi <= 0x1p+100))
        return 2;
    double perm, rhi;
    (void)orient3d_det_perm(a, b, c, d, &perm, &rhi);
    if (!(perm >= 0x1p-400))
        return 2;
    const dw *u = r[0], *v = r[1], *w = r[2];
    dw m0 = dw_add(dw_mul(v[1], w[2]), dw_neg(dw_mul(v[2], w[1])));
    dw m1 = dw_add(dw_mul(v[2], w[0]), dw_neg(dw_mul(v[0], w[2])));
    dw m2 = dw_add(dw_mul(v[0], w[1]), dw_neg(dw_mul(v[1], w[0])));
    dw det = dw_add(dw_add(dw_mul(u[0], m0), dw_mul(u[1], m1)), dw_mul(u[2], m2));
    double x = det.h + det.l, bound = 0x1p-98 * perm;
    if (x > bound)
        return -1;
    if (x < -bound)
        return 1;
    return 2;
}

/* pred_insphere once the first filter has declined. */
static int insphere_after_filter(const double *a, const double *b, const double *c,
                                 const double *d, const double *e)
{
    int s = pred__insphere_filter2(a, b, c, d, e);
    return s != 2 ? s : insphere_exact(a, b, c, d, e);
}

int pred_insphere(const double *a, const double *b, const double *c, const double *d,
                  const double *e)
{
    int s = pred__insphere_filter(a, b, c, d, e);
    return s != 2 ? s : insphere_after_filter(a, b, c, d, e);
}

/* ============================================================ 2D */

int pred__orient2d_exact(const double *a, const double *b, const double *c, int stage)
{
    if (stage == 2) {
        const double *p[2] = {a, b};
        double rows[4];
        if (!diffs(p, 2, c, 2, rows))
            return 2;
        return exact_det_sign(2, 2, 0, 0, rows);
    }
    double rows[6] = {a[0], a[1], b[0], b[1], c[0], c[1]};
    return exact_det_sign(3, 2, 0, 1, rows);
}

int pred_orient2d(const double *a, const double *b, const double *c)
{
    double ux = a[0] - c[0], uy = a[1] - c[1];
    double vx = b[0] - c[0], vy = b[1] - c[1];
    double det = ux * vy - uy * vx;
    double mx = dmax(fabs(ux), fabs(vx)), my = dmax(fabs(uy), fabs(vy));
    double lo = dmin(mx, my), hi = dmax(mx, my);
    if (lo >= O2_LO && hi <= O2_HI) {
        double bound = o2_bound * mx * my;
        if (det > bound)
            return 1;
        if (det < -bound)
            return -1;
    }
    int s = pred__orient2d_exact(a, b, c, 2);
    return s != 2 ? s : pred__orient2d_exact(a, b, c, 3);
}

int pred__incircle_exact(const double *a, const double *b, const double *c, const double *d,
                         int stage)
{
    if (stage == 2) {
        const double *p[3] = {a, b, c};
        double rows[6];
        if (!diffs(p, 3, d, 2, rows))
            return 2;
        return exact_det_sign(3, 2, 1, 0, rows);
    }
    double rows[8] = {a[0], a[1], b[0], b[1], c[0], c[1], d[0], d[1]};
    return exact_det_sign(4, 2, 1, 1, rows);
}

int pred_incircle(const double *a, const double *b, const double *c, const double *d)
{
    double ax = a[0] - d[0], ay = a[1] - d[1];
    double bx = b[0] - d[0], by = b[1] - d[1];
    double cx = c[0] - d[0], cy = c[1] - d[1];
    double ab = ax * by - bx * ay, ac = ax * cy - cx * ay, bc = bx * cy - cx * by;
    double la = ax * ax + ay * ay, lb = bx * bx + by * by, lc = cx * cx + cy * cy;
    double det = (la * bc - lb * ac) + lc * ab;
    double mx = dmax(fabs(ax), dmax(fabs(bx), fabs(cx)));
    double my = dmax(fabs(ay), dmax(fabs(by), fabs(cy)));
    double lo = dmin(mx, my), hi = dmax(mx, my);
    if (lo >= IC_LO && hi <= IC_HI) {
        double bound = ic_bound * (mx * mx + my * my) * mx * my;
        if (det > bound)
            return 1;
        if (det < -bound)
            return -1;
    }
    int s = pred__incircle_exact(a, b, c, d, 2);
    return s != 2 ? s : pred__incircle_exact(a, b, c, d, 3);
}

/* ============================================ symbolic perturbation */

int pred_lexcmp3(const double *p, const double *q)
{
    for (int k = 0; k < 3; k++) {
        if (p[k] < q[k])
            return -1;
        if (p[k] > q[k])
            return 1;
    }
    return 0;
}

static int lexcmp2(const double *p, const double *q)
{
    for (int k = 0; k < 2; k++) {
        if (p[k] < q[k])
            return -1;
        if (p[k] > q[k])
            return 1;
    }
    return 0;
}

/* Sorts idx[0..n) so that pts[idx[0]] is the lexicographically largest.
 * Returns 0 if two points coincide. */
static int order_by_perturbation(const double *const *pts, int n, int dim, int *idx)
{
    for (int i = 0; i < n; i++)
        idx[i] = i;
    for (int i = 1; i < n; i++) {
        int v = idx[i], j = i;
        while (j > 0) {
            int c = dim == 3 ? pred_lexcmp3(pts[idx[j - 1]], pts[v])
                             : lexcmp2(pts[idx[j - 1]], pts[v]);
            if (c == 0)
                return 0;
            if (c > 0)
                break;
            idx[j] = idx[j - 1];
            j--;
        }
        idx[j] = v;
    }
    return 1;
}

/* pred_insphere is -det5 with rows (x, y, z, w, 1), w = |p|^2. Perturbing
 * w_r (row r, 1-based) by eps_r adds eps_r * (-1)^(r+4) * M_r to det5,
 * where the minor M_r = det[x y z 1] of the other rows = -orient3d of them.
 * So the perturbed insphere gains eps_r * (-1)^r * orient3d(others). */
static int insphere_perturbed(const double *a, const double *b, const double *c,
                              const double *d, const double *e);

int pred_insphere_sos(const double *a, const double *b, const double *c, const double *d,
                      const double *e)
{
    int s = pred_insphere(a, b, c, d, e);
    return s ? s : insphere_perturbed(a, b, c, d, e);
}

int pred__insphere_sos_after_filter(const double *a, const double *b, const double *c,
                                    const double *d, const double *e)
{
    int s = insphere_after_filter(a, b, c, d, e);
    return s ? s : insphere_perturbed(a, b, c, d, e);
}

/* The sign of the perturbed insphere when the exact one is 0. */
static int insphere_perturbed(const double *a, const double *b, const double *c,
                              const double *d, const double *e)
{
    const double *pts[5] = {a, b, c, d, e};
    int idx[5];
    if (!order_by_perturbation(pts, 5, 3, idx))
        return 0;
    for (int k = 0; k < 5; k++) {
        int r = idx[k];
        const double *o[4];
        for (int i = 0, j = 0; i < 5; i++)
            if (i != r)
                o[j++] = pts[i];
        int os = pred_orient3d(o[0], o[1], o[2], o[3]);
        if (os)
            return (r % 2 == 0) ? -os : os; /* (-1)^(r+1), r 0-based */
    }
    return 0;
}

/* pred_incircle is det4 with rows (x, y, w, 1); perturbing w_r adds
 * eps_r * (-1)^(r+3) * orient2d(others) (r 1-based). */
int pred_incircle_sos(const double *a, const double *b, const double *c, const double *d)
{
    int s = pred_incircle(a, b, c, d);
    if (s)
        return s;
    const double *pts[4] = {a, b, c, d};
    int idx[4];
    if (!order_by_perturbation(pts, 4, 2, idx))
        return 0;
    for (int k = 0; k < 4; k++) {
        int r = idx[k];
        const double *o[3];
        for (int i = 0, j = 0; i < 4; i++)
            if (i != r)
                o[j++] = pts[i];
        int os = pred_orient2d(o[0], o[1], o[2]);
        if (os)
            return (r % 2 == 0) ? os : -os; /* (-1)^r, r 0-based */
    }
    return 0;
}

/* The circle through a,b,c is the trace, on their plane, of every sphere
 * through a,b,c and a point q off the plane; so for e in the plane,
 * "inside the circle" is "inside the sphere (a,b,c,q)". Perturbing q's
 * lifted coordinate contributes eps_q * orient3d(a,b,c,e) = 0, so q never
 * takes part in the tie-break and the result does not depend on q. */
int pred_incircle3d_sos(const double *a, const double *b, const double *c, const double *e)
{
    for (int k = 0; k < 3; k++) {
        double q[3] = {a[0], a[1], a[2]};
        q[k] = a[k] != 0.0 ? 0.0 : 1.0;
        int o = pred_orient3d(a, b, c, q);
        if (o)
            return o * pred_insphere_sos(a, b, c, q, e);
    }
    return 0;
}
