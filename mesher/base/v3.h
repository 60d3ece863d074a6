/*
 * base/v3.h -- the small 3-vector and index-triple helpers the mesher's
 * modules share (inline, no state). Plain floating point: anything whose
 * sign must be right goes through geom/pred.h instead.
 */
#ifndef PDR_VEC3_H
#define PDR_VEC3_H

#include <math.h>
#include <stdint.h>

/* o = a - b */
static inline void v3_sub(const double *a, const double *b, double *o)
{
    o[0] = a[0] - b[0];
    o[1] = a[1] - b[1];
    o[2] = a[2] - b[2];
}

static inline double v3_dot(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* o = a x b; o must not alias a or b. */
static inline void v3_cross(const double *a, const double *b, double *o)
{
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}

static inline double v3_norm(const double *a)
{
    return sqrt(v3_dot(a, a));
}

/* Squared distance |a - b|^2. */
static inline double v3_dist2(const double *a, const double *b)
{
    double d[3];
    v3_sub(a, b, d);
    return v3_dot(d, d);
}

/* The frame of tetrahedron abcd: edge vectors u = b - a, v = c - a,
 * w = d - a, and n1 = v x w, n2 = w x u, n3 = u x v, the normals of the
 * faces opposite b, c and d, each as long as twice its face's area.
 * Returns u . n1, six times the signed volume. */
static inline double v3_tet_frame(const double *a, const double *b, const double *c,
                                  const double *d, double u[3], double v[3], double w[3],
                                  double n1[3], double n2[3], double n3[3])
{
    v3_sub(b, a, u);
    v3_sub(c, a, v);
    v3_sub(d, a, w);
    v3_cross(v, w, n1);
    v3_cross(w, u, n2);
    v3_cross(u, v, n3);
    return v3_dot(u, n1);
}

/* o = {a, b, c} in increasing order (a face key). */
static inline void v3_sort3u(uint32_t a, uint32_t b, uint32_t c, uint32_t o[3])
{
    uint32_t x;
    if (a > b) { x = a; a = b; b = x; }
    if (b > c) { x = b; b = c; c = x; }
    if (a > b) { x = a; a = b; b = x; }
    o[0] = a;
    o[1] = b;
    o[2] = c;
}

#endif /* PDR_VEC3_H */
