/* Unit tests of the exact predicates against exact rational arithmetic (GMP).
 *
 * The reference evaluates the textbook determinants (rows [x y z |p|^2 1])
 * with mpq by Gaussian elimination, independently of the way geom/pred.c
 * translates, expands and filters. Inputs are exactly degenerate
 * configurations (integer points on a sphere, a circle or a plane, scaled
 * and translated without rounding) and the same configurations moved by a
 * few ulps, which is where a filter with a wrong bound or an inexact
 * fallback would give a wrong sign. */
#include "config.h"

#include <float.h>
#include <gmp.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "geom/pred.h"
#include "unit.h"

/* ------------------------------------------------------------ helpers */

static uint64_t rng_state = 0x9e3779b97f4a7c15u;
static uint64_t rnd(void)
{
    uint64_t z = (rng_state += 0x9e3779b97f4a7c15u);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9u;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebu;
    return z ^ (z >> 31);
}
static int rndint(int n) { return (int)(rnd() % (uint64_t)n); }
static double rnd01(void) { return (double)(rnd() >> 11) * 0x1p-53; }

/* Sign of the determinant of an n x n rational matrix (destroys it). */
static int ref_det(int n, mpq_t *m)
{
    int sign = 1;
    mpq_t f, t;
    mpq_init(f);
    mpq_init(t);
    for (int col = 0; col < n; col++) {
        int piv = -1;
        for (int r = col; r < n; r++)
            if (mpq_sgn(m[r * n + col])) {
                piv = r;
                break;
            }
        if (piv < 0) {
            sign = 0;
            break;
        }
        if (piv != col) {
            for (int k = 0; k < n; k++)
                mpq_swap(m[piv * n + k], m[col * n + k]);
            sign = -sign;
        }
        if (mpq_sgn(m[col * n + col]) < 0)
            sign = -sign;
        for (int r = col + 1; r < n; r++) {
            if (!mpq_sgn(m[r * n + col]))
                continue;
            mpq_div(f, m[r * n + col], m[col * n + col]);
            for (int k = col; k < n; k++) {
                mpq_mul(t, f, m[col * n + k]);
                mpq_sub(m[r * n + k], m[r * n + k], t);
            }
        }
    }
    mpq_clear(f);
    mpq_clear(t);
    return sign;
}

/* Rows [coords..., (lift + pert), 1] for np points of dimension dim;
 * pert[i] (may be NULL) is added to the lifted coordinate of point i. */
static int ref_lifted(int np, int dim, const double *const *p, int lift, mpq_t *pert)
{
    int n = dim + lift + 1;
    mpq_t m[25], t;
    mpq_init(t);
    for (int i = 0; i < n * n; i++)
        mpq_init(m[i]);
    for (int r = 0; r < np; r++) {
        for (int k = 0; k < dim; k++)
            mpq_set_d(m[r * n + k], p[r][k]);
        if (lift) {
            mpq_set_ui(m[r * n + dim], 0, 1);
            for (int k = 0; k < dim; k++) {
                mpq_mul(t, m[r * n + k], m[r * n + k]);
                mpq_add(m[r * n + dim], m[r * n + dim], t);
            }
            if (pert)
                mpq_add(m[r * n + dim], m[r * n + dim], pert[r]);
        }
        mpq_set_ui(m[r * n + n - 1], 1, 1);
    }
    int s = ref_det(n, m);
    for (int i = 0; i < n * n; i++)
        mpq_clear(m[i]);
    mpq_clear(t);
    return s;
}

static int ref_orient3d(const double *a, const double *b, const double *c, const double *d)
{
    const double *p[4] = {a, b, c, d};
    return -ref_lifted(4, 3, p, 0, NULL);
}
static int ref_insphere(const double *a, const double *b, const double *c, const double *d,
                        const double *e)
{
    const double *p[5] = {a, b, c, d, e};
    return -ref_lifted(5, 3, p, 1, NULL);
}
static int ref_orient2d(const double *a, const double *b, const double *c)
{
    const double *p[3] = {a, b, c};
    return ref_lifted(3, 2, p, 0, NULL);
}
static int ref_incircle(const double *a, const double *b, const double *c, const double *d)
{
    const double *p[4] = {a, b, c, d};
    return ref_lifted(4, 2, p, 1, NULL);
}

/* Perturbed reference: the lifted coordinate of the k-th lexicographically
 * largest point gets delta^(k+1), delta = 2^-100, which is small enough for
 * the integer-coordinate inputs used here that the sign equals the sign of
 * the infinitesimal perturbation. */
static int ref_sos(int np, int dim, const double *const *p)
{
    mpq_t pert[5];
    for (int i = 0; i < np; i++) {
        int rank = 0;
        for (int j = 0; j < np; j++) {
            int c = 0;
            for (int k = 0; k < dim && !c; k++)
                c = (p[j][k] > p[i][k]) - (p[j][k] < p[i][k]);
            if (c > 0)
                rank++;
        }
        mpq_init(pert[i]);
        mpq_set_ui(pert[i], 1, 1);
        mpq_div_2exp(pert[i], pert[i], (mp_bitcnt_t)(100 * (rank + 1)));
    }
    int s = ref_lifted(np, dim, p, 1, pert);
    for (int i = 0; i < np; i++)
        mpq_clear(pert[i]);
    return dim == 3 ? -s : s;
}

/* Moves x by k ulps (k may be negative). */
static double ulps(double x, int k)
{
    while (k > 0) {
        x = nextafter(x, INFINITY);
        k--;
    }
    while (k < 0) {
        x = nextafter(x, -INFINITY);
        k++;
    }
    return x;
}

/* Integer points on the sphere x^2+y^2+z^2 = r2. */
static int sphere_points(int r2, int (*out)[3], int max)
{
    int n = 0, r = (int)sqrt((double)r2) + 1;
    for (int x = -r; x <= r; x++)
        for (int y = -r; y <= r; y++)
            for (int z = -r; z <= r; z++)
                if (x * x + y * y + z * z == r2 && n < max) {
                    out[n][0] = x;
                    out[n][1] = y;
                    out[n][2] = z;
                    n++;
                }
    return n;
}

/* An exact affine image of integer points: scale by a power of two and
 * translate by an offset with few bits, both exact in double. */
typedef struct affine {
    double scale, off[3];
} affine;

static affine random_affine(int wide)
{
    affine t;
    t.scale = ldexp(1.0, rndint(wide ? 400 : 40) - (wide ? 200 : 20));
    for (int k = 0; k < 3; k++)
        t.off[k] = (double)(rndint(2001) - 1000) * t.scale * (rndint(3) ? 1 : 64);
    return t;
}

static void apply(const affine *t, const int *ip, double *p)
{
    for (int k = 0; k < 3; k++)
        p[k] = ip[k] * t->scale + t->off[k];
}

/* --------------------------------------------------------------- tests */

/* The insphere filter's determinant, written out in scalar operations in
 * the order geom/pred.c derives the bound for. */
static double scalar_insphere_det(const double *a, const double *b, const double *c,
                                  const double *d, const double *e, double *L)
{
    double ax = a[0] - e[0], ay = a[1] - e[1], az = a[2] - e[2];
    double bx = b[0] - e[0], by = b[1] - e[1], bz = b[2] - e[2];
    double cx = c[0] - e[0], cy = c[1] - e[1], cz = c[2] - e[2];
    double dx = d[0] - e[0], dy = d[1] - e[1], dz = d[2] - e[2];
    double la = (ax * ax + ay * ay) + az * az;
    double lb = (bx * bx + by * by) + bz * bz;
    double lc = (cx * cx + cy * cy) + cz * cz;
    double ld = (dx * dx + dy * dy) + dz * dz;
    double ab = ax * by - bx * ay, ac = ax * cy - cx * ay, ad = ax * dy - dx * ay;
    double bc = bx * cy - cx * by, bd = bx * dy - dx * by, cd = cx * dy - dx * cy;
    double dbcd = (bz * cd - cz * bd) + dz * bc;
    double dacd = (az * cd - cz * ad) + dz * ac;
    double dabd = (az * bd - bz * ad) + dz * ab;
    double dabc = (az * bc - bz * ac) + cz * ab;
    *L = fmax(fmax(la, lb), fmax(lc, ld));
    return (la * dbcd - lb * dacd) + (lc * dabd - ld * dabc);
}

/* geom/pred.h evaluates the insphere filter two operations at a time (vector
 * extensions); its certified bound holds only if every rounded operation is
 * the scalar one. Bit-for-bit equality of the determinant and of the
 * largest lift on random inputs of many magnitudes and signs, and on
 * near-cospherical ones where the determinant is mostly rounding error,
 * shows that each lane computes its own scalar operation (a swapped
 * operand or a different association changes the low bits at once). */
START_TEST(insphere_filter_is_the_scalar_formula)
{
    rng_state = 11;
    for (int it = 0; it < 200000; it++) {
        double p[5][3];
        int scale = rndint(41) - 20;
        for (int i = 0; i < 5; i++)
            for (int k = 0; k < 3; k++)
                p[i][k] = ldexp(2 * rnd01() - 1, scale + rndint(3)) + (it % 3 == 0 ? 1000.0 : 0.0);
        if (it % 2) {
            /* near-cospherical: five points of a sphere, rounded */
            double cx = rnd01(), cy = rnd01(), cz = rnd01(), r = 0.5 + rnd01();
            for (int i = 0; i < 5; i++) {
                double z = 2 * rnd01() - 1, t = 6.283185307179586 * rnd01(), q = sqrt(1 - z * z);
                p[i][0] = cx + r * q * cos(t);
                p[i][1] = cy + r * q * sin(t);
                p[i][2] = cz + r * z;
            }
        }
        double L1, L2;
        double d1 = pred_insphere_det_(p[0], p[1], p[2], p[3], p[4], &L1);
        double d2 = scalar_insphere_det(p[0], p[1], p[2], p[3], p[4], &L2);
        if (memcmp(&d1, &d2, sizeof d1) || L1 != L2)
            ck_abort_msg("iteration %d: det %a vs scalar %a, L %a vs %a", it, d1, d2, L1, L2);
        /* The bulk Delaunay search relies on this: a point at NaN (the
         * infinite vertex of a ghost) in any of the four tet slots makes
         * the filter decline. */
        double nanp[3] = {NAN, NAN, NAN};
        const double *q[4] = {p[0], p[1], p[2], p[3]};
        q[it % 4] = nanp;
        ck_assert_int_eq(pred_insphere_filter_(q[0], q[1], q[2], q[3], p[4]), 2);
    }
}
END_TEST

START_TEST(hand_made_signs)
{
    double o[3] = {0, 0, 0}, x[3] = {1, 0, 0}, y[3] = {0, 1, 0}, z[3] = {0, 0, 1};
    double in[3] = {0.25, 0.25, 0.25}, far[3] = {5, 5, 5}, c[3] = {1, 1, 1};
    ck_assert_int_eq(pred_orient3d(o, x, y, z), 1);
    ck_assert_int_eq(pred_orient3d(o, y, x, z), -1);
    ck_assert_int_eq(pred_orient3d(o, x, y, c), 1);
    double half[3] = {0.5, 0.5, 0};
    ck_assert_int_eq(pred_orient3d(o, x, y, half), 0);
    ck_assert_int_eq(pred_insphere(o, x, y, z, in), 1);
    ck_assert_int_eq(pred_insphere(o, x, y, z, far), -1);
    ck_assert_int_eq(pred_insphere(o, y, x, z, in), -1); /* flips with orientation */
    ck_assert_int_eq(pred_insphere(o, x, y, z, c), 0);   /* cube corners: cospherical */
    double o2[2] = {0, 0}, x2[2] = {1, 0}, y2[2] = {0, 1}, in2[2] = {0.4, 0.4},
           c2[2] = {1, 1};
    ck_assert_int_eq(pred_orient2d(o2, x2, y2), 1);
    ck_assert_int_eq(pred_orient2d(o2, y2, x2), -1);
    ck_assert_int_eq(pred_incircle(o2, x2, y2, in2), 1);
    ck_assert_int_eq(pred_incircle(o2, x2, y2, c2), 0);
    /* The perturbed tests never return 0 for distinct non-coplanar points. */
    ck_assert_int_ne(pred_insphere_sos(o, x, y, z, c), 0);
    ck_assert_int_ne(pred_incircle_sos(o2, x2, y2, c2), 0);
    /* ...and return 0 for coincident points. */
    ck_assert_int_eq(pred_insphere_sos(o, x, y, z, x), 0);
}
END_TEST

START_TEST(random_points_agree_with_gmp)
{
    for (int it = 0; it < 3000; it++) {
        double p[5][3];
        int wide = it % 3 == 0;
        for (int i = 0; i < 5; i++)
            for (int k = 0; k < 3; k++) {
                p[i][k] = rnd01() - 0.5;
                if (wide) /* mixed magnitudes: inexact differences */
                    p[i][k] = ldexp(p[i][k], rndint(120) - 60);
            }
        ck_assert_int_eq(pred_orient3d(p[0], p[1], p[2], p[3]),
                         ref_orient3d(p[0], p[1], p[2], p[3]));
        ck_assert_int_eq(pred__orient3d_exact(p[0], p[1], p[2], p[3], 3),
                         ref_orient3d(p[0], p[1], p[2], p[3]));
        int si = pred__orient3d_int(p[0], p[1], p[2], p[3]);
        if (si != 2)
            ck_assert_int_eq(si, ref_orient3d(p[0], p[1], p[2], p[3]));
        ck_assert_int_eq(pred_insphere(p[0], p[1], p[2], p[3], p[4]),
                         ref_insphere(p[0], p[1], p[2], p[3], p[4]));
        ck_assert_int_eq(pred__insphere_exact(p[0], p[1], p[2], p[3], p[4], 3),
                         ref_insphere(p[0], p[1], p[2], p[3], p[4]));
        for (int st = 0; st <= 2; st++) {
            int s3 = pred__insphere_exact(p[0], p[1], p[2], p[3], p[4], st);
            if (s3 != 2)
                ck_assert_int_eq(s3, ref_insphere(p[0], p[1], p[2], p[3], p[4]));
            s3 = pred__orient3d_exact(p[0], p[1], p[2], p[3], st);
            if (s3 != 2)
                ck_assert_int_eq(s3, ref_orient3d(p[0], p[1], p[2], p[3]));
        }
        ck_assert_int_eq(pred_orient2d(p[0], p[1], p[2]), ref_orient2d(p[0], p[1], p[2]));
        ck_assert_int_eq(pred_incircle(p[0], p[1], p[2], p[3]),
                         ref_incircle(p[0], p[1], p[2], p[3]));
    }
}
END_TEST

START_TEST(near_cospherical_agree_with_gmp)
{
    static int sp[400][3];
    int n = sphere_points(2 * 3 * 5 * 7, sp, 400); /* 210 = many lattice points */
    ck_assert_int_ge(n, 40);
    int decided_by_filter = 0, exact_zero = 0;
    for (int it = 0; it < 3000; it++) {
        affine t = random_affine(it % 4 == 0);
        double p[5][3];
        for (int i = 0; i < 5; i++)
            apply(&t, sp[rndint(n)], p[i]);
        int ref = ref_insphere(p[0], p[1], p[2], p[3], p[4]);
        ck_assert_int_eq(pred_insphere(p[0], p[1], p[2], p[3], p[4]), ref);
        /* the exact stages alone (stage 2 takes the small-integer shortcut
         * on these lattice points) */
        int s2u = pred__insphere_exact(p[0], p[1], p[2], p[3], p[4], 2);
        if (s2u != 2)
            ck_assert_int_eq(s2u, ref);
        ck_assert_int_eq(pred__insphere_exact(p[0], p[1], p[2], p[3], p[4], 3), ref);
        /* the integer stage takes these unless the scale is wide */
        int si = pred__insphere_int(p[0], p[1], p[2], p[3], p[4]);
        if (it % 4 != 0)
            ck_assert_int_ne(si, 2);
        if (si != 2)
            ck_assert_int_eq(si, ref);
        exact_zero += ref == 0;
        /* The SoS rule, checked against an actual rational perturbation. */
        if (ref == 0 && ref_orient3d(p[0], p[1], p[2], p[3]) != 0) {
            const double *pp[5] = {p[0], p[1], p[2], p[3], p[4]};
            int distinct = 1;
            for (int i = 0; i < 5; i++)
                for (int j = i + 1; j < 5; j++)
                    if (!pred_lexcmp3(p[i], p[j]))
                        distinct = 0;
            if (distinct) {
                ck_assert_int_ne(pred_insphere_sos(p[0], p[1], p[2], p[3], p[4]), 0);
                ck_assert_int_eq(pred_insphere_sos(p[0], p[1], p[2], p[3], p[4]),
                                 ref_sos(5, 3, pp));
            }
        }
        /* A few ulps away: near-degenerate, where the filter must decline
         * or be right. */
        int who = rndint(5), k = rndint(3);
        p[who][k] = ulps(p[who][k], rndint(9) - 4);
        ref = ref_insphere(p[0], p[1], p[2], p[3], p[4]);
        int f = pred__insphere_filter(p[0], p[1], p[2], p[3], p[4]);
        if (f != 2) {
            ck_assert_int_eq(f, ref);
            decided_by_filter++;
        }
        f = pred__insphere_filter2(p[0], p[1], p[2], p[3], p[4]);
        if (f != 2)
            ck_assert_int_eq(f, ref);
        ck_assert_int_eq(pred_insphere(p[0], p[1], p[2], p[3], p[4]), ref);
        for (int st = 0; st <= 2; st++) {
            int s2 = pred__insphere_exact(p[0], p[1], p[2], p[3], p[4], st);
            if (s2 != 2)
                ck_assert_int_eq(s2, ref);
        }
        ck_assert_int_eq(pred__insphere_exact(p[0], p[1], p[2], p[3], p[4], 3), ref);
    }
    ck_assert_int_gt(exact_zero, 100); /* the degenerate inputs really are */
    (void)decided_by_filter;
}
END_TEST

START_TEST(large_integer_points_agree_with_gmp)
{
    /* Integer points of a sphere of radius (a^2+b^2+c^2+d^2) from the
     * Pythagorean quadruples of the sign changes and permutations of one
     * (a,b,c,d): coordinates near 2^19, exactly cospherical, then moved by
     * one unit. The determinants are far too large for double evaluation to
     * be exact: this is where the small-integer shortcut must not be taken. */
    for (int it = 0; it < 2000; it++) {
        int q[4] = {300 + (int)(rnd() % 300), 200 + (int)(rnd() % 300), 100 + (int)(rnd() % 300),
                    1 + (int)(rnd() % 300)};
        double p[5][3], off[3];
        for (int k = 0; k < 3; k++)
            off[k] = (double)(rndint(2000001) - 1000000);
        for (int i = 0; i < 5; i++) {
            int w[4];
            for (int k = 0; k < 4; k++)
                w[k] = q[k];
            for (int k = 3; k > 0; k--) { /* random permutation and signs */
                int j = rndint(k + 1), t = w[k];
                w[k] = w[j];
                w[j] = t;
            }
            for (int k = 0; k < 4; k++)
                if (rndint(2))
                    w[k] = -w[k];
            double a = w[0], b = w[1], c = w[2], d = w[3];
            p[i][0] = a * a + b * b - c * c - d * d + off[0];
            p[i][1] = 2 * (a * d + b * c) + off[1];
            p[i][2] = 2 * (b * d - a * c) + off[2];
        }
        if (it % 2)
            p[rndint(5)][rndint(3)] += rndint(2) ? 1 : -1;
        int ref = ref_insphere(p[0], p[1], p[2], p[3], p[4]);
        ck_assert_int_eq(pred_insphere(p[0], p[1], p[2], p[3], p[4]), ref);
        for (int st = 0; st <= 2; st++) {
            int s2 = pred__insphere_exact(p[0], p[1], p[2], p[3], p[4], st);
            if (s2 != 2)
                ck_assert_int_eq(s2, ref);
        }
        ck_assert_int_eq(pred__insphere_int(p[0], p[1], p[2], p[3], p[4]), ref);
        int s2;
        /* coplanar: the first three and their integer combination */
        double r[3];
        int u = rndint(7) - 3, v = rndint(7) - 3;
        for (int k = 0; k < 3; k++)
            r[k] = p[0][k] + u * (p[1][k] - p[0][k]) + v * (p[2][k] - p[0][k]) +
                   (it % 2 ? (k == 0) : 0);
        ck_assert_int_eq(pred_orient3d(p[0], p[1], p[2], r), ref_orient3d(p[0], p[1], p[2], r));
        for (int st = 0; st <= 2; st++) {
            s2 = pred__orient3d_exact(p[0], p[1], p[2], r, st);
            if (s2 != 2)
                ck_assert_int_eq(s2, ref_orient3d(p[0], p[1], p[2], r));
        }
    }
}
END_TEST

START_TEST(near_coplanar_agree_with_gmp)
{
    int zero = 0;
    for (int it = 0; it < 4000; it++) {
        affine t = random_affine(it % 4 == 0);
        int u[3], v[3], ip[4][3];
        for (int k = 0; k < 3; k++) {
            u[k] = rndint(21) - 10;
            v[k] = rndint(21) - 10;
        }
        for (int i = 0; i < 4; i++) {
            int s = rndint(41) - 20, r = rndint(41) - 20;
            for (int k = 0; k < 3; k++)
                ip[i][k] = s * u[k] + r * v[k];
        }
        double p[4][3];
        for (int i = 0; i < 4; i++)
            apply(&t, ip[i], p[i]);
        int ref = ref_orient3d(p[0], p[1], p[2], p[3]);
        zero += ref == 0;
        ck_assert_int_eq(pred_orient3d(p[0], p[1], p[2], p[3]), ref);
        /* the integer stage takes these (coordinates within 61 bits of
         * each other) unless the scale is wide */
        int si = pred__orient3d_int(p[0], p[1], p[2], p[3]);
        if (it % 4 != 0)
            ck_assert_int_ne(si, 2);
        if (si != 2)
            ck_assert_int_eq(si, ref);
        int s2u = pred__orient3d_exact(p[0], p[1], p[2], p[3], 2);
        if (s2u != 2)
            ck_assert_int_eq(s2u, ref);
        int who = rndint(4), k = rndint(3);
        p[who][k] = ulps(p[who][k], rndint(9) - 4);
        ref = ref_orient3d(p[0], p[1], p[2], p[3]);
        int f = pred__orient3d_filter(p[0], p[1], p[2], p[3]);
        if (f != 2)
            ck_assert_int_eq(f, ref);
        f = pred__orient3d_filter2(p[0], p[1], p[2], p[3]);
        if (f != 2)
            ck_assert_int_eq(f, ref);
        f = pred__orient3d_int(p[0], p[1], p[2], p[3]);
        if (f != 2)
            ck_assert_int_eq(f, ref);
        ck_assert_int_eq(pred_orient3d(p[0], p[1], p[2], p[3]), ref);
        ck_assert_int_eq(pred__orient3d_exact(p[0], p[1], p[2], p[3], 3), ref);
        for (int st = 0; st <= 2; st++) {
            int s2 = pred__orient3d_exact(p[0], p[1], p[2], p[3], st);
            if (s2 != 2)
                ck_assert_int_eq(s2, ref);
        }
    }
    ck_assert_int_gt(zero, 3000);
}
END_TEST

START_TEST(near_degenerate_2d_agree_with_gmp)
{
    int cp[200][2], n = 0;
    for (int x = -26; x <= 26; x++)
        for (int y = -26; y <= 26; y++)
            if (x * x + y * y == 625 && n < 200) {
                cp[n][0] = x;
                cp[n][1] = y;
                n++;
            }
    ck_assert_int_ge(n, 12);
    for (int it = 0; it < 3000; it++) {
        affine t = random_affine(it % 4 == 0);
        double p[4][2];
        for (int i = 0; i < 4; i++) {
            const int *q = cp[rndint(n)];
            p[i][0] = q[0] * t.scale + t.off[0];
            p[i][1] = q[1] * t.scale + t.off[1];
        }
        int ref = ref_incircle(p[0], p[1], p[2], p[3]);
        ck_assert_int_eq(pred_incircle(p[0], p[1], p[2], p[3]), ref);
        if (ref == 0 && ref_orient2d(p[0], p[1], p[2]) != 0 &&
            ref_orient2d(p[0], p[1], p[3]) != 0) {
            const double *pp[4] = {p[0], p[1], p[2], p[3]};
            int distinct = 1;
            for (int i = 0; i < 4; i++)
                for (int j = i + 1; j < 4; j++)
                    if (p[i][0] == p[j][0] && p[i][1] == p[j][1])
                        distinct = 0;
            if (distinct)
                ck_assert_int_eq(pred_incircle_sos(p[0], p[1], p[2], p[3]), ref_sos(4, 2, pp));
        }
        {
            int who = rndint(4), k = rndint(2);
            p[who][k] = ulps(p[who][k], rndint(9) - 4);
        }
        ck_assert_int_eq(pred_incircle(p[0], p[1], p[2], p[3]),
                         ref_incircle(p[0], p[1], p[2], p[3]));
        ck_assert_int_eq(pred__incircle_exact(p[0], p[1], p[2], p[3], 3),
                         ref_incircle(p[0], p[1], p[2], p[3]));
        /* collinear triples and their neighbours */
        double a[2] = {p[0][0], p[0][1]}, b[2], c[2];
        int dx = rndint(9) - 4, dy = rndint(9) - 4, s = rndint(7) - 3;
        b[0] = a[0] + dx * t.scale;
        b[1] = a[1] + dy * t.scale;
        c[0] = a[0] + s * dx * t.scale;
        c[1] = a[1] + s * dy * t.scale;
        ck_assert_int_eq(pred_orient2d(a, b, c), ref_orient2d(a, b, c));
        {
            int k = rndint(2);
            c[k] = ulps(c[k], rndint(5) - 2);
        }
        ck_assert_int_eq(pred_orient2d(a, b, c), ref_orient2d(a, b, c));
        ck_assert_int_eq(pred__orient2d_exact(a, b, c, 3), ref_orient2d(a, b, c));
    }
}
END_TEST

START_TEST(extreme_exponents_agree_with_gmp)
{
    /* Huge, tiny and subnormal coordinates, where floating-point expansions
     * would overflow or underflow: the filter must decline and the exact
     * stage must still be right. */
    static const int exps[] = {-1074, -1060, -1022, -600, -300, -50, 0, 50, 300, 600, 1000, 1020};
    int ne = (int)(sizeof exps / sizeof exps[0]);
    for (int it = 0; it < 1500; it++) {
        double p[5][3];
        int e = exps[rndint(ne)];
        for (int i = 0; i < 5; i++)
            for (int k = 0; k < 3; k++) {
                int ee = rndint(4) ? e : exps[rndint(ne)];
                double m = (double)(rndint(2001) - 1000);
                if (ee == -1074)
                    p[i][k] = m * 0x1p-1074;
                else
                    p[i][k] = ldexp(m / 1024.0, ee);
                if (!isfinite(p[i][k]))
                    p[i][k] = DBL_MAX * (m < 0 ? -1 : 1);
            }
        if (it % 2) /* make some exactly degenerate: coplanar via z = x */
            for (int i = 0; i < 5; i++)
                p[i][2] = p[i][0];
        int ro = ref_orient3d(p[0], p[1], p[2], p[3]), ri = ref_insphere(p[0], p[1], p[2], p[3], p[4]);
        ck_assert_int_eq(pred_orient3d(p[0], p[1], p[2], p[3]), ro);
        ck_assert_int_eq(pred_insphere(p[0], p[1], p[2], p[3], p[4]), ri);
        int xw = pred__orient3d_dw(p[0], p[1], p[2], p[3]);
        if (xw != 2)
            ck_assert_int_eq(xw, ro);
        xw = pred__orient3d_int(p[0], p[1], p[2], p[3]);
        if (xw != 2)
            ck_assert_int_eq(xw, ro);
        xw = pred__insphere_dw(p[0], p[1], p[2], p[3], p[4]);
        if (xw != 2)
            ck_assert_int_eq(xw, ri);
        xw = pred__insphere_int(p[0], p[1], p[2], p[3], p[4]);
        if (xw != 2)
            ck_assert_int_eq(xw, ri);
        for (int st = 0; st <= 3; st++) {
            int x = pred__orient3d_exact(p[0], p[1], p[2], p[3], st);
            if (x != 2)
                ck_assert_int_eq(x, ro);
            x = pred__insphere_exact(p[0], p[1], p[2], p[3], p[4], st);
            if (x != 2)
                ck_assert_int_eq(x, ri);
        }
        ck_assert_int_eq(pred_orient2d(p[0], p[1], p[2]), ref_orient2d(p[0], p[1], p[2]));
        ck_assert_int_eq(pred_incircle(p[0], p[1], p[2], p[3]),
                         ref_incircle(p[0], p[1], p[2], p[3]));
    }
}
END_TEST

/* Nearly flat tetrahedra and nearly cospherical points with arbitrary
 * doubles (not lattice points: the differences are inexact), as tessellated
 * CAD surfaces give them: the two permanent-bounded filters decline, and
 * the double-word filter must either decline or give the exact sign. It
 * must also decide most of them (else it would be no filter at all). */
START_TEST(double_word_filter_agrees_with_gmp)
{
    int hard_i = 0, decided_i = 0, hard_o = 0, decided_o = 0;
    for (int it = 0; it < 6000; it++) {
        double sc = ldexp(1.0, it % 5 == 0 ? rndint(120) - 60 : rndint(8) - 4);
        double off = it % 3 == 0 ? 0 : (rnd01() - 0.5) * 1000 * sc;
        double p[5][3];
        if (it % 2 == 0) {
            /* a flat tetrahedron abcd (d on the plane of abc, rounded, then
             * moved by a few ulps) and a fifth point near it */
            for (int i = 0; i < 3; i++)
                for (int k = 0; k < 3; k++)
                    p[i][k] = (rnd01() - 0.5) * sc + off;
            double s1 = rnd01() * 2 - 0.5, s2 = rnd01() * 2 - 0.5;
            for (int k = 0; k < 3; k++)
                p[3][k] = p[0][k] + s1 * (p[1][k] - p[0][k]) + s2 * (p[2][k] - p[0][k]);
            p[3][rndint(3)] = ulps(p[3][rndint(3)], rndint(7) - 3);
            double near = it % 4 == 0 ? 1e-6 : 1;
            for (int k = 0; k < 3; k++)
                p[4][k] = p[rndint(4)][k] + (rnd01() - 0.5) * sc * near;
        } else {
            /* five points on a sphere, each rounded */
            double c[3] = {off + sc * rnd01(), off - sc * rnd01(), off}, r = sc * (0.5 + rnd01());
            for (int i = 0; i < 5; i++) {
                double v[3], n = 0;
                for (int k = 0; k < 3; k++) {
                    v[k] = rnd01() - 0.5;
                    n += v[k] * v[k];
                }
                n = sqrt(n);
                for (int k = 0; k < 3; k++)
                    p[i][k] = c[k] + r * v[k] / n;
            }
        }
        int ri = ref_insphere(p[0], p[1], p[2], p[3], p[4]);
        int f = pred__insphere_filter2(p[0], p[1], p[2], p[3], p[4]);
        int w = pred__insphere_dw(p[0], p[1], p[2], p[3], p[4]);
        if (w != 2)
            ck_assert_int_eq(w, ri);
        if (f == 2 && ri != 0) {
            hard_i++;
            decided_i += w != 2;
        }
        ck_assert_int_eq(pred_insphere(p[0], p[1], p[2], p[3], p[4]), ri);
        int ro = ref_orient3d(p[0], p[1], p[2], p[3]);
        f = pred__orient3d_filter2(p[0], p[1], p[2], p[3]);
        w = pred__orient3d_dw(p[0], p[1], p[2], p[3]);
        if (w != 2)
            ck_assert_int_eq(w, ro);
        w = pred__orient3d_int(p[0], p[1], p[2], p[3]);
        if (w != 2)
            ck_assert_int_eq(w, ro);
        if (f == 2 && ro != 0) {
            hard_o++;
            decided_o += w != 2;
        }
        ck_assert_int_eq(pred_orient3d(p[0], p[1], p[2], p[3]), ro);
    }
    /* the inputs really are hard for the first filters, and the double-word
     * filter takes nearly all of them */
    ck_assert_int_gt(hard_i, 500);
    ck_assert_int_gt(hard_o, 200);
    ck_assert_int_ge(decided_i * 10, hard_i * 9);
    ck_assert_int_ge(decided_o * 10, hard_o * 9);
}
END_TEST

/* The integer insphere at the edge of its range: coordinates whose
 * integer forms reach 2^61 - 2^8 next to a coordinate 1 (the largest
 * differences, lifts and minors its word sizes allow), and exactly
 * cospherical integer points near 2^52, against GMP; one more bit of span
 * and it must decline. */
START_TEST(integer_insphere_at_its_bounds)
{
    const double big = ldexp((double)((UINT64_C(1) << 53) - 1), 8); /* 2^61 - 2^8 */
    int zero = 0;
    for (int it = 0; it < 4000; it++) {
        double p[5][3];
        if (it % 2 == 0) {
            const double pick[6] = {big, -big, ldexp(1.0, 60), -ldexp(1.0, 60), 0, 1};
            for (int i = 0; i < 5; i++)
                for (int k = 0; k < 3; k++)
                    p[i][k] = rndint(4) ? pick[rndint(6)]
                                        : ldexp((double)(rnd() >> 11), 8) * (rndint(2) ? 1 : -1);
            p[rndint(5)][rndint(3)] = 1; /* lowest bit 0: the span is 61 bits */
        } else {
            /* exactly cospherical integer points near 2^52: the sphere of
             * radius a^2+b^2+c^2+d^2 through the points of Pythagorean
             * quadruples of the sign changes and permutations of
             * (a, b, c, d), each below 2^25, offset by integers below 2^51 */
            int64_t q0[4], off[3];
            for (int k = 0; k < 4; k++)
                q0[k] = (int64_t)(rnd() >> 39) + 1;
            for (int k = 0; k < 3; k++)
                off[k] = (int64_t)(rnd() >> 13) - (INT64_C(1) << 50);
            for (int i = 0; i < 5; i++) {
                int64_t w[4];
                memcpy(w, q0, sizeof w);
                for (int k = 3; k > 0; k--) {
                    int j = rndint(k + 1);
                    int64_t t = w[k];
                    w[k] = w[j];
                    w[j] = t;
                }
                for (int k = 0; k < 4; k++)
                    if (rndint(2))
                        w[k] = -w[k];
                p[i][0] = (double)(w[0] * w[0] + w[1] * w[1] - w[2] * w[2] - w[3] * w[3] + off[0]);
                p[i][1] = (double)(2 * (w[0] * w[3] + w[1] * w[2]) + off[1]);
                p[i][2] = (double)(2 * (w[1] * w[3] - w[0] * w[2]) + off[2]);
            }
            if (it % 4 == 3)
                p[rndint(5)][rndint(3)] += 1;
        }
        int ref = ref_insphere(p[0], p[1], p[2], p[3], p[4]);
        zero += ref == 0;
        int si = pred__insphere_int(p[0], p[1], p[2], p[3], p[4]);
        ck_assert_int_ne(si, 2);
        ck_assert_int_eq(si, ref);
        ck_assert_int_eq(pred_insphere(p[0], p[1], p[2], p[3], p[4]), ref);
        int so = pred__orient3d_int(p[0], p[1], p[2], p[3]);
        ck_assert_int_ne(so, 2);
        ck_assert_int_eq(so, ref_orient3d(p[0], p[1], p[2], p[3]));
        /* one bit more: beyond the stage */
        p[0][0] = 1;
        p[1 + rndint(4)][rndint(3)] = ldexp(1.0, 61) * (rndint(2) ? 1 : -1);
        ck_assert_int_eq(pred__insphere_int(p[0], p[1], p[2], p[3], p[4]), 2);
    }
    ck_assert_int_gt(zero, 300); /* the cospherical ones really are */
}
END_TEST

START_TEST(coplanar_incircle_agrees_with_every_sphere)
{
    /* Points of the circle x+y+z = 0, x^2+y^2+z^2 = r2: coplanar and
     * concyclic. For e in the plane of abc and any d off the plane, the
     * hull rule pred_incircle3d_sos(a,b,c,e) must equal the perturbed
     * insphere of (a,b,c,d) normalised by its orientation. */
    /* x^2+xy+y^2 = 1729 = 7*13*19 has many solutions; then z = -x-y and
     * x^2+y^2+z^2 = 3458. */
    int cp[100][3], m = 0;
    for (int x = -60; x <= 60; x++)
        for (int y = -60; y <= 60; y++)
            if (x * x + x * y + y * y == 1729 && m < 100) {
                cp[m][0] = x;
                cp[m][1] = y;
                cp[m][2] = -x - y;
                m++;
            }
    ck_assert_int_ge(m, 6);
    int checked = 0;
    for (int it = 0; it < 2000; it++) {
        affine t = random_affine(0);
        int ia = rndint(m), ib = rndint(m), ic = rndint(m);
        if (ia == ib || ib == ic || ia == ic)
            continue;
        double a[3], b[3], c[3], e[3], d[3];
        apply(&t, cp[ia], a);
        apply(&t, cp[ib], b);
        apply(&t, cp[ic], c);
        /* e: on the circle, or elsewhere in the plane */
        int ie[3];
        if (rndint(2)) {
            memcpy(ie, cp[rndint(m)], sizeof ie);
        } else {
            ie[0] = rndint(41) - 20;
            ie[1] = rndint(41) - 20;
            ie[2] = -ie[0] - ie[1];
        }
        apply(&t, ie, e);
        if (!pred_lexcmp3(e, a) || !pred_lexcmp3(e, b) || !pred_lexcmp3(e, c))
            continue;
        int id[3] = {rndint(41) - 20, rndint(41) - 20, rndint(41) - 20};
        if (id[0] + id[1] + id[2] == 0)
            id[2]++;
        apply(&t, id, d);
        int o = pred_orient3d(a, b, c, d);
        ck_assert_int_ne(o, 0);
        int s = pred_incircle3d_sos(a, b, c, e);
        ck_assert_int_ne(s, 0);
        ck_assert_int_eq(s, o * pred_insphere_sos(a, b, c, d, e));
        checked++;
    }
    ck_assert_int_gt(checked, 1000);
}
END_TEST

static Suite *pred_suite(void)
{
    Suite *s = suite_create("pred");
    TCase *tc = tcase_create("pred");
    tcase_set_timeout(tc, 120);
    tcase_add_test(tc, hand_made_signs);
    tcase_add_test(tc, insphere_filter_is_the_scalar_formula);
    tcase_add_test(tc, random_points_agree_with_gmp);
    tcase_add_test(tc, near_cospherical_agree_with_gmp);
    tcase_add_test(tc, near_coplanar_agree_with_gmp);
    tcase_add_test(tc, large_integer_points_agree_with_gmp);
    tcase_add_test(tc, near_degenerate_2d_agree_with_gmp);
    tcase_add_test(tc, extreme_exponents_agree_with_gmp);
    tcase_add_test(tc, coplanar_incircle_agrees_with_every_sphere);
    tcase_add_test(tc, double_word_filter_agrees_with_gmp);
    tcase_add_test(tc, integer_insphere_at_its_bounds);
    suite_add_tcase(s, tc);
    return s;
}

UNIT_MAIN(pred_suite)
