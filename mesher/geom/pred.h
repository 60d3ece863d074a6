/*
 * geom/pred.h -- exact geometric predicates (prefix pred_).
 *
 * Every predicate returns the exact sign (-1, 0 or +1) of a determinant of
 * its double arguments, for every finite double input: no tolerance, no
 * overflow or underflow caveat. Each is evaluated in stages, the first
 * that can decide giving the answer:
 *
 *   1. a floating-point filter with a certified (proved) error bound,
 *      inlined in the hot loops; it decides almost every call;
 *   2. (3D) a second filter with a tighter bound (the permanent), for long
 *      thin tetrahedra;
 *   3. (3D) if the differences are exact small integers times a power of
 *      two (grids), the floating-point evaluation, which is then exact;
 *   4. (3D) the same formula in exact multi-word floating point, if the
 *      arguments span few enough binades (always, in practice);
 *   5. the determinant expanded into monomials (products of doubles) summed
 *      in a fixed-point big integer wide enough for any exponent range: of
 *      the differences if they are exact, else of the raw coordinates.
 *
 * geom/pred.c explains every bound and size. Stack use is below 8 KiB (stage 4
 * holds about 25 numbers of 28 words), fine for coroutine stacks.
 *
 * Orientation conventions (a right-handed frame):
 *   pred_orient3d(a,b,c,d) > 0  iff d lies on the side of the plane abc
 *       towards which (b-a) x (c-a) points, i.e. a,b,c appear
 *       counterclockwise seen from d. A tetrahedron (a,b,c,d) with
 *       pred_orient3d > 0 is "positively oriented"; TetGen's .ele files use
 *       the same convention.
 *   pred_insphere(a,b,c,d,e) > 0  iff e lies inside the sphere through
 *       a,b,c,d, when (a,b,c,d) is positively oriented (the sign flips for a
 *       negatively oriented tetrahedron; 0 if cospherical).
 *   pred_orient2d(a,b,c) > 0  iff a,b,c are counterclockwise.
 *   pred_incircle(a,b,c,d) > 0  iff d lies inside the circle through a,b,c,
 *       when a,b,c are counterclockwise.
 *
 * Symbolic perturbation (the *_sos variants). Exactly cospherical points
 * (a grid, points on a sphere) make pred_insphere return 0, and a
 * Delaunay algorithm needs a consistent tie-break. We use the lifting map:
 * point p is lifted to (p, |p|^2) and the insphere sign is the orientation of
 * five lifted points. Every lifted coordinate is perturbed to |p|^2 + eps_p,
 * where eps_p > 0 is infinitesimal and eps_p >> eps_q whenever p is
 * lexicographically larger than q (compare x, then y, then z). This is a
 * weight perturbation in the sense of Edelsbrunner-Muecke and
 * Devillers-Teillaud: it turns the point set into a generic weighted set whose
 * regular triangulation is unique, so every decision is consistent with one
 * triangulation. The order depends only on coordinates, never on vertex
 * numbers, so two processes that number vertices differently still agree.
 * When insphere is 0 the perturbed sign is that of the first non-zero
 * cofactor, taking the points by decreasing lexicographic order; each
 * cofactor is an orient3d of the other four points (orient2d in 2D).
 * pred_insphere_sos returns 0 only if the five points are coplanar or two of
 * them coincide; pred_incircle_sos likewise for collinear/coincident points.
 *
 * Points of the convex hull: a query point e exactly coplanar with a hull
 * face abc is in conflict with the (ghost) tetrahedron beyond that face iff
 * it is inside the perturbed circumcircle of abc: pred_incircle3d_sos. That
 * is the same lifted-plane test restricted to the plane of abc, so it agrees
 * with pred_insphere_sos on any real tetrahedron having abc as a face.
 */
#ifndef PDR_PRED_H
#define PDR_PRED_H

int pred_orient3d(const double *a, const double *b, const double *c, const double *d);
int pred_insphere(const double *a, const double *b, const double *c, const double *d,
                  const double *e);
int pred_orient2d(const double *a, const double *b, const double *c);
int pred_incircle(const double *a, const double *b, const double *c, const double *d);

/* Perturbed variants (see above). */
int pred_insphere_sos(const double *a, const double *b, const double *c, const double *d,
                      const double *e);
int pred_incircle_sos(const double *a, const double *b, const double *c, const double *d);
/* pred_insphere_sos for a caller whose inlined filter (pred_insphere_filter_
 * below) declined: the first filter is not run again. */
int pred__insphere_sos_after_filter(const double *a, const double *b, const double *c,
                                    const double *d, const double *e);
/* e must be coplanar with the non-degenerate triangle abc (else the result
 * is the sign of an insphere test with an arbitrary fourth point). Returns
 * +1 if e is inside the perturbed circumcircle of abc, -1 if outside, 0 only
 * if e coincides with a, b or c or abc is degenerate. */
int pred_incircle3d_sos(const double *a, const double *b, const double *c, const double *e);

/* ------------------------------------------------------------------
 * Inline versions for hot loops: the filter of geom/pred.c, inlined so that the
 * caller's loads and the arithmetic can be scheduled together; when the
 * filter cannot decide they call the out-of-line predicate. Same results
 * as the functions above (the bounds are explained in geom/pred.c).
 */
#define PRED_EPS_ (1.1102230246251565e-16) /* 2^-53 */

static inline double pred_max_(double a, double b)
{
    return a > b ? a : b;
}
static inline double pred_min_(double a, double b)
{
    return a < b ? a : b;
}

/* The orient3d filter: the sign of pred_orient3d, or 2. */
static inline int pred_orient3d_filter_(const double *a, const double *b, const double *c,
                                        const double *d)
{
    double ux = a[0] - d[0], uy = a[1] - d[1], uz = a[2] - d[2];
    double vx = b[0] - d[0], vy = b[1] - d[1], vz = b[2] - d[2];
    double wx = c[0] - d[0], wy = c[1] - d[1], wz = c[2] - d[2];
    double det = ux * (vy * wz - vz * wy) + uy * (vz * wx - vx * wz) + uz * (vx * wy - vy * wx);
    double mx = pred_max_(__builtin_fabs(ux), pred_max_(__builtin_fabs(vx), __builtin_fabs(wx)));
    double my = pred_max_(__builtin_fabs(uy), pred_max_(__builtin_fabs(vy), __builtin_fabs(wy)));
    double mz = pred_max_(__builtin_fabs(uz), pred_max_(__builtin_fabs(vz), __builtin_fabs(wz)));
    double lo = pred_min_(mx, pred_min_(my, mz)), hi = pred_max_(mx, pred_max_(my, mz));
    if (lo >= 0x1p-330 && hi <= 0x1p+330) {
        double bound = (48.0 * PRED_EPS_) * mx * my * mz;
        if (det > bound)
            return -1;
        if (det < -bound)
            return 1;
    }
    return 2;
}

static inline int pred_orient3d_fast(const double *a, const double *b, const double *c,
                                     const double *d)
{
    int s = pred_orient3d_filter_(a, b, c, d);
    return s != 2 ? s : pred_orient3d(a, b, c, d);
}

/* The insphere determinant of the filter: rows a,b,c,d translated by e,
 * lifted l = (x*x + y*y) + z*z, 2x2 minors m_ij = ix*jy - jx*iy, 3x3
 * cofactors D(i,j,k) = (iz*m_jk - jz*m_ik) + kz*m_ij, and
 *     det = (la*D(b,c,d) - lb*D(a,c,d)) + (lc*D(a,b,d) - ld*D(a,b,c));
 * *L gets the largest lift. geom/pred.c derives the filter's error bound for
 * exactly this sequence of rounded operations.
 *
 * With GCC's vector extensions (two doubles per vector: SSE2 on x86-64,
 * plain scalar code elsewhere) every operation of that sequence is done in
 * one lane of a vector operation, two at a time; a lane operation is the
 * same IEEE double operation as the scalar one (no contraction: the build
 * has -ffp-contract=off), so the result is bit for bit that of
 * pred_insphere_det_scalar_, which tests/test_pred.c checks. The pairing:
 * lifts (la,lb), (lc,ld); minors (ab,ac), (ad,bc), (bd,cd); cofactors (D(b,c,d),D(a,c,d)),
 * (D(a,b,d),D(a,b,c)). It halves the arithmetic instructions of the test
 * that runs about fifty times per inserted point.
 *
 * The scalar evaluation: the operation order geom/pred.c derives the bound for
 * (also used by its exact stage). */
static inline double pred_insphere_det_scalar_(const double *a, const double *b,
                                               const double *c, const double *d,
                                               const double *e, double *L)
{
    double ex = e[0], ey = e[1], ez = e[2];
    double ax = a[0] - ex, ay = a[1] - ey, az = a[2] - ez;
    double bx = b[0] - ex, by = b[1] - ey, bz = b[2] - ez;
    double cx = c[0] - ex, cy = c[1] - ey, cz = c[2] - ez;
    double dx = d[0] - ex, dy = d[1] - ey, dz = d[2] - ez;
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
    *L = pred_max_(pred_max_(la, lb), pred_max_(lc, ld));
    return (la * dbcd - lb * dacd) + (lc * dabd - ld * dabc);
}

#if defined(__GNUC__) && !defined(__clang__) && !defined(PRED_SCALAR_FILTER)
typedef double pred_v2_ __attribute__((vector_size(16)));
typedef long long pred_v2i_ __attribute__((vector_size(16)));
#define PRED_SHUF_(x, y, i, j) __builtin_shuffle((x), (y), (pred_v2i_){(i), (j)})

static inline double pred_insphere_det_(const double *a, const double *b, const double *c,
                                        const double *d, const double *e, double *L)
{
    pred_v2_ ex = {e[0], e[0]}, ey = {e[1], e[1]}, ez = {e[2], e[2]};
    pred_v2_ xab = (pred_v2_){a[0], b[0]} - ex, xcd = (pred_v2_){c[0], d[0]} - ex;
    pred_v2_ yab = (pred_v2_){a[1], b[1]} - ey, ycd = (pred_v2_){c[1], d[1]} - ey;
    pred_v2_ zab = (pred_v2_){a[2], b[2]} - ez, zcd = (pred_v2_){c[2], d[2]} - ez;
    pred_v2_ lab = (xab * xab + yab * yab) + zab * zab; /* la, lb */
    pred_v2_ lcd = (xcd * xcd + ycd * ycd) + zcd * zcd; /* lc, ld */
    /* Lane selectors: 0,1 pick from the first vector, 2,3 the second. */
    pred_v2_ m1 = PRED_SHUF_(xab, xab, 0, 0) * PRED_SHUF_(yab, ycd, 1, 2) -
                  PRED_SHUF_(xab, xcd, 1, 2) * PRED_SHUF_(yab, yab, 0, 0); /* ab, ac */
    pred_v2_ m2 = xab * PRED_SHUF_(ycd, ycd, 1, 0) -
                  PRED_SHUF_(xcd, xcd, 1, 0) * yab; /* ad, bc */
    pred_v2_ m3 = PRED_SHUF_(xab, xcd, 1, 2) * PRED_SHUF_(ycd, ycd, 1, 1) -
                  PRED_SHUF_(xcd, xcd, 1, 1) * PRED_SHUF_(yab, ycd, 1, 2); /* bd, cd */
    /* D(b,c,d) = (bz*cd - cz*bd) + dz*bc, D(a,c,d) = (az*cd - cz*ad) + dz*ac */
    pred_v2_ d1 = (PRED_SHUF_(zab, zab, 1, 0) * PRED_SHUF_(m3, m3, 1, 1) -
                   PRED_SHUF_(zcd, zcd, 0, 0) * PRED_SHUF_(m3, m2, 0, 2)) +
                  PRED_SHUF_(zcd, zcd, 1, 1) * PRED_SHUF_(m2, m1, 1, 3);
    /* D(a,b,d) = (az*bd - bz*ad) + dz*ab, D(a,b,c) = (az*bc - bz*ac) + cz*ab */
    pred_v2_ d2 = (PRED_SHUF_(zab, zab, 0, 0) * PRED_SHUF_(m3, m2, 0, 3) -
                   PRED_SHUF_(zab, zab, 1, 1) * PRED_SHUF_(m2, m1, 0, 3)) +
                  PRED_SHUF_(zcd, zcd, 1, 0) * PRED_SHUF_(m1, m1, 0, 0);
    pred_v2_ t1 = lab * d1, t2 = lcd * d2; /* la*Dbcd, lb*Dacd; lc*Dabd, ld*Dabc */
    pred_v2_ u = PRED_SHUF_(t1, t2, 0, 2) - PRED_SHUF_(t1, t2, 1, 3);
    *L = pred_max_(pred_max_(lab[0], lab[1]), pred_max_(lcd[0], lcd[1]));
    return u[0] + u[1];
}
#else
static inline double pred_insphere_det_(const double *a, const double *b, const double *c,
                                        const double *d, const double *e, double *L)
{
    return pred_insphere_det_scalar_(a, b, c, d, e, L);
}
#endif

/* The insphere filter (see geom/pred.c for the bound): the sign of
 * pred_insphere, or 2 if the filter cannot decide. */
static inline int pred_insphere_filter_(const double *a, const double *b, const double *c,
                                        const double *d, const double *e)
{
    double L, det = pred_insphere_det_(a, b, c, d, e, &L);
    if (L >= 0x1p-190 && L <= 0x1p+190) {
        double L2 = L * L;
        if (det * det > (1140.0 * PRED_EPS_) * (1140.0 * PRED_EPS_) * (L2 * L2 * L))
            return det > 0 ? 1 : -1;
    }
    return 2;
}

/* pred_insphere_sos with the filter inlined. */
static inline int pred_insphere_sos_fast(const double *a, const double *b, const double *c,
                                         const double *d, const double *e)
{
    int s = pred_insphere_filter_(a, b, c, d, e);
    return s != 2 ? s : pred__insphere_sos_after_filter(a, b, c, d, e);
}

/* Lexicographic comparison of 3D points: -1, 0, +1. */
int pred_lexcmp3(const double *p, const double *q);

/* Internal entry points for the tests: the exact stages alone, bypassing the
 * filters; each returns the sign, or 2 when it does not apply. For orient3d
 * and insphere: stage 0 = floating-point evaluation when the differences
 * are exact small integers (times a power of two); stage 1 = exact
 * floating-point arithmetic (multi-word mantissas) when the values fit;
 * stage 2 = sum of monomials of the differences, when they are exact;
 * stage 3 = sum of monomials of the raw coordinates (always applies). 2D
 * predicates have stages 2 and 3. */
int pred__orient3d_exact(const double *a, const double *b, const double *c, const double *d,
                         int stage);
int pred__insphere_exact(const double *a, const double *b, const double *c, const double *d,
                         const double *e, int stage);
int pred__orient2d_exact(const double *a, const double *b, const double *c, int stage);
int pred__incircle_exact(const double *a, const double *b, const double *c, const double *d,
                         int stage);
/* The filters alone: the sign, or 2 when the filter cannot decide (filter2
 * is the permanent-bounded second filter). */
int pred__orient3d_filter2(const double *a, const double *b, const double *c, const double *d);
int pred__insphere_filter2(const double *a, const double *b, const double *c, const double *d,
                           const double *e);
int pred__orient3d_filter(const double *a, const double *b, const double *c, const double *d);
int pred__insphere_filter(const double *a, const double *b, const double *c, const double *d,
                          const double *e);
/* The double-word filter between filter2 and the exact stages (bound and
 * its derivation in geom/pred.c): the sign, or 2 when it cannot decide. */
int pred__insphere_dw(const double *a, const double *b, const double *c, const double *d,
                      const double *e);
int pred__orient3d_dw(const double *a, const double *b, const double *c, const double *d);
/* Exact orient3d in 64/128/192-bit integers when the coordinates span at
 * most 61 bits (geom/pred.c); 2 when they do not. */
int pred__orient3d_int(const double *a, const double *b, const double *c, const double *d);
/* Exact insphere in 64/128/192/320-bit integers under the same condition
 * (geom/pred.c); 2 when it does not apply. */
int pred__insphere_int(const double *a, const double *b, const double *c, const double *d,
                       const double *e);

#endif /* PDR_PRED_H */
