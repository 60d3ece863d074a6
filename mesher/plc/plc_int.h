/*
 * plc/plc_int.h -- shared between the plc_*.c files; not for other
 * modules.
 */
#ifndef PDR_PLC_INTERNAL_H
#define PDR_PLC_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "plc/plc.h"

/* Grows *arr (elements of elsize bytes, capacity *cap) to hold need
 * elements, doubling. Returns 0 or PDR_ENOMEM (*arr is then unchanged). */
int plc__grow(void **arr, size_t *cap, size_t need, size_t elsize);
/* Frees the derived arrays and clears 'derived'. */
void plc__drop_derived(plc *p);
/* Allocates nattr zeroed attributes per vertex (once). */
int plc__enable_vattr(plc *p, size_t nattr);
/* Newell area vector (twice the area times the unit normal) and corner
 * centroid of polygon q. */
void plc__newell(const plc *p, const plc_polygon *q, double n[3], double c[3]);
/* The same for the n >= 1 corners c of a ring of vertices xyz. */
void plc__newell_ring(const double (*xyz)[3], const uint32_t *c, uint32_t n, double nrm[3],
                      double cen[3]);
int plc__cmp_u64(const void *x, const void *y);
/* Gives vertex v (the last one added) the number num (0-based, the base
 * is added) in its file, where some vertex before it was merged away;
 * the vertices before v without one keep their own. Returns 0 or
 * PDR_ENOMEM. */
int plc__number_vertex(plc *p, uint32_t v, long num);

#endif /* PDR_PLC_INTERNAL_H */
