/*
 * plc_pred.c -- exact orient2d, incircle and orient3d for the PLC module.
 * TO BE REPLACED by mesher/pred.c from the kernel (see plc_pred.h).
 *
 * Expansions are arrays of doubles whose exact sum is the value, kept
 * nonoverlapping and in increasing magnitude by construction (two-sum
 * growth), with zero components dropped. The exact paths are slow (they
 * multiply expansions term by term) but are only taken when the filter
 * cannot decide, which for PLC input means exactly degenerate or nearly
 * degenerate configurations.
 */
#include "config.h"

#include <math.h>
#include <string.h>

#include "plc_pred.h"

#define EPS 0x1p-53 /* half an ulp of 1: the unit roundoff of double */

/* x + y == a + b exactly, x = fl(a + b). */
static void two_sum(double a, double b, double *x, double *y)
{
    double s = a + b;
    double bv = s - a;
    double av = s - bv;
    *x = s;
    *y = (a - av) + (b - bv);
}

/* x + y == a * b exactly: fma computes a * b - x with one rounding, which
 * is exact because the rounding error of a product is representable. */
static void two_prod(double a, double b, double *x, double *y)
{
    *x = a * b;
    *y = fma(a, b, -*x);
}

/* h = e + b (expansion plus scalar), zeros eliminated; returns length. */
static int grow(const double *e, int n, double b, double *h)
{
    int m = 0;
    double q = b;
    for (int i = 0; i < n; i++) {
        double x, y;
        two_sum(q, e[i], &x, &y);
        q = x;
        if (y != 0.0)
            h[m++] = y;
    }
    if (q != 0.0 || m == 0)
        h[m++] = q;
    return m;
}

/* h = e + f; h may not alias e or f. Returns the length. */
static int add(const double *e, int n, const double *f, int m, double *h,
               double *tmp)
{
    memcpy(h, e, (size_t)n * sizeof *h);
    int len = n;
    for (int j = 0; j < m; j++) {
        len = grow(h, len, f[j], tmp);
        memcpy(h, tmp, (size_t)len * sizeof *h);
    }
    return len;
}

/* h = e * f, term by term; h may not alias e or f. tmp needs room for
 * 2 * n * m + n doubles and tmp2 for as many. */
static int mul(const double *e, int n, const double *f, int m, double *h,
               double *tmp, double *tmp2)
{
    int len = 1;
    h[0] = 0.0;
    for (int j = 0; j < m; j++)
        for (int i = 0; i < n; i++) {
            double x, y;
            two_prod(e[i], f[j], &x, &y);
            len = grow(h, len, y, tmp);
            len = grow(tmp, len, x, tmp2);
            memcpy(h, tmp2, (size_t)len * sizeof *h);
        }
    return len;
}

static double estimate_sign(const double *e, int n)
{
    /* The largest component carries the sign of a nonoverlapping
     * expansion. */
    return e[n - 1];
}

/* An exact difference a - b as an expansion of at most 2 terms. */
static int diff(double a, double b, double *h)
{
    double x, y;
    two_sum(a, -b, &x, &y);
    int n = 0;
    if (y != 0.0)
        h[n++] = y;
    h[n++] = x;
    return n;
}

#define MAXE 4096

/* det = p*s - q*r with all four given as expansions. */
static int det2(const double *p, int np, const double *s, int ns, const double *q,
                int nq, const double *r, int nr, double *out)
{
    static _Thread_local double t1[MAXE], t2[MAXE], w1[MAXE], w2[MAXE];
    int a = mul(p, np, s, ns, t1, w1, w2);
    int b = mul(q, nq, r, nr, t2, w1, w2);
    for (int i = 0; i < b; i++)
        t2[i] = -t2[i];
    return add(t1, a, t2, b, out, w1);
}

static double orient2d_exact(const double a[2], const double b[2], const double c[2])
{
    double acx[2], acy[2], bcx[2], bcy[2], d[MAXE];
    int nax = diff(a[0], c[0], acx), nay = diff(a[1], c[1], acy);
    int nbx = diff(b[0], c[0], bcx), nby = diff(b[1], c[1], bcy);
    int n = det2(acx, nax, bcy, nby, acy, nay, bcx, nbx, d);
    return estimate_sign(d, n);
}

double plc_orient2d(const double a[2], const double b[2], const double c[2])
{
    double l = (a[0] - c[0]) * (b[1] - c[1]);
    double r = (a[1] - c[1]) * (b[0] - c[0]);
    double det = l - r;
    double bound = (3.0 + 16.0 * EPS) * EPS * (fabs(l) + fabs(r));
    if (det > bound || -det > bound)
        return det;
    return orient2d_exact(a, b, c);
}

static double orient3d_exact(const double a[3], const double b[3], const double c[3],
                             const double d[3])
{
    static _Thread_local double m[3][MAXE], t[MAXE], sum[MAXE], w1[MAXE], w2[MAXE];
    double ad[3][2], bd[3][2], cd[3][2];
    int na[3], nb[3], nc[3];
    for (int k = 0; k < 3; k++) {
        na[k] = diff(a[k], d[k], ad[k]);
        nb[k] = diff(b[k], d[k], bd[k]);
        nc[k] = diff(c[k], d[k], cd[k]);
    }
    /* det = ad . (bd x cd) */
    int nm0 = det2(bd[1], nb[1], cd[2], nc[2], bd[2], nb[2], cd[1], nc[1], m[0]);
    int nm1 = det2(bd[2], nb[2], cd[0], nc[0], bd[0], nb[0], cd[2], nc[2], m[1]);
    int nm2 = det2(bd[0], nb[0], cd[1], nc[1], bd[1], nb[1], cd[0], nc[0], m[2]);
    int ns = mul(ad[0], na[0], m[0], nm0, sum, w1, w2);
    int nt = mul(ad[1], na[1], m[1], nm1, t, w1, w2);
    double acc[MAXE];
    int nacc = add(sum, ns, t, nt, acc, w1);
    nt = mul(ad[2], na[2], m[2], nm2, t, w1, w2);
    ns = add(acc, nacc, t, nt, sum, w1);
    return estimate_sign(sum, ns);
}

double plc_orient3d(const double a[3], const double b[3], const double c[3],
                    const double d[3])
{
    double adx = a[0] - d[0], ady = a[1] - d[1], adz = a[2] - d[2];
    double bdx = b[0] - d[0], bdy = b[1] - d[1], bdz = b[2] - d[2];
    double cdx = c[0] - d[0], cdy = c[1] - d[1], cdz = c[2] - d[2];
    double bdxcdy = bdx * cdy, cdxbdy = cdx * bdy;
    double cdxady = cdx * ady, adxcdy = adx * cdy;
    double adxbdy = adx * bdy, bdxady = bdx * ady;
    double det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) +
                 cdz * (adxbdy - bdxady);
    double perm = (fabs(bdxcdy) + fabs(cdxbdy)) * fabs(adz) +
                  (fabs(cdxady) + fabs(adxcdy)) * fabs(bdz) +
                  (fabs(adxbdy) + fabs(bdxady)) * fabs(cdz);
    double bound = (7.0 + 56.0 * EPS) * EPS * perm;
    if (det > bound || -det > bound)
        return det;
    /* Same sign convention: the expansion computes ad . (bd x cd), which is
     * the determinant above. */
    return orient3d_exact(a, b, c, d);
}

static double incircle_exact(const double a[2], const double b[2], const double c[2],
                             const double d[2])
{
    static _Thread_local double lift[MAXE], t[MAXE], m[MAXE], acc[MAXE], acc2[MAXE],
        w1[MAXE], w2[MAXE];
    const double *p[3] = {a, b, c};
    double dx[3][2], dy[3][2];
    int nx[3], ny[3];
    for (int k = 0; k < 3; k++) {
        nx[k] = diff(p[k][0], d[0], dx[k]);
        ny[k] = diff(p[k][1], d[1], dy[k]);
    }
    int nacc = 1;
    acc[0] = 0.0;
    for (int k = 0; k < 3; k++) {
        int i = (k + 1) % 3, j = (k + 2) % 3;
        /* lift_k * (dx_i dy_j - dy_i dx_j) */
        int nl1 = mul(dx[k], nx[k], dx[k], nx[k], t, w1, w2);
        int nl2 = mul(dy[k], ny[k], dy[k], ny[k], m, w1, w2);
        int nl = add(t, nl1, m, nl2, lift, w1);
        int nm = det2(dx[i], nx[i], dy[j], ny[j], dy[i], ny[i], dx[j], nx[j], m);
        int np = mul(lift, nl, m, nm, t, w1, w2);
        nacc = add(acc, nacc, t, np, acc2, w1);
        memcpy(acc, acc2, (size_t)nacc * sizeof *acc);
    }
    return estimate_sign(acc, nacc);
}

double plc_incircle(const double a[2], const double b[2], const double c[2],
                    const double d[2])
{
    double adx = a[0] - d[0], ady = a[1] - d[1];
    double bdx = b[0] - d[0], bdy = b[1] - d[1];
    double cdx = c[0] - d[0], cdy = c[1] - d[1];
    double bdxcdy = bdx * cdy, cdxbdy = cdx * bdy;
    double cdxady = cdx * ady, adxcdy = adx * cdy;
    double adxbdy = adx * bdy, bdxady = bdx * ady;
    double alift = adx * adx + ady * ady;
    double blift = bdx * bdx + bdy * bdy;
    double clift = cdx * cdx + cdy * cdy;
    double det = alift * (bdxcdy - cdxbdy) + blift * (cdxady - adxcdy) +
                 clift * (adxbdy - bdxady);
    double perm = (fabs(bdxcdy) + fabs(cdxbdy)) * alift +
                  (fabs(cdxady) + fabs(adxcdy)) * blift +
                  (fabs(adxbdy) + fabs(bdxady)) * clift;
    double bound = (10.0 + 96.0 * EPS) * EPS * perm;
    if (det > bound || -det > bound)
        return det;
    return incircle_exact(a, b, c, d);
}
