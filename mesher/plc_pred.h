/*
 * plc_pred.h -- exact geometric predicates for PLC validation and facet
 * triangulation.
 *
 * TO BE REPLACED by the kernel's mesher/pred.h (pred_orient2d,
 * pred_incircle, pred_orient3d) once that lands on main: these exist only
 * because the kernel was being written at the same time. Each function
 * returns a value whose sign is the exact sign of the determinant (the
 * magnitude is an approximation): a floating-point filter with Shewchuk's
 * a-priori error bounds, falling back to exact expansion arithmetic built
 * on two-sum and fma-based two-product. Finite inputs whose products do not
 * overflow are assumed.
 *
 * Sign conventions (as Shewchuk's):
 *   plc_orient2d(a,b,c)   > 0 when a, b, c turn counterclockwise;
 *   plc_incircle(a,b,c,d) > 0 when d is inside the circle through the
 *                           counterclockwise triangle a, b, c;
 *   plc_orient3d(a,b,c,d) > 0 when d lies below the plane of a, b, c, i.e.
 *                           a, b, c appear counterclockwise seen from
 *                           above (from the side opposite to d).
 */
#ifndef PDR_PLC_PRED_H
#define PDR_PLC_PRED_H

double plc_orient2d(const double a[2], const double b[2], const double c[2]);
double plc_incircle(const double a[2], const double b[2], const double c[2],
                    const double d[2]);
double plc_orient3d(const double a[3], const double b[3], const double c[3],
                    const double d[3]);

#endif /* PDR_PLC_PRED_H */
