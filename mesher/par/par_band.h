/*
 * par/par_band.h -- the interface band of a 2-PE run, cut in two and each
 * half handed to one PE (prefix par_band_).
 *
 * Once a PE's local work is done, what is left lies along the interface,
 * and every cavity there spans both PEs (about 35 us of CPU against 4.5 us
 * for a local one, bench/parallel.md). A PE then hands the tetrahedra of
 * its side of the interface where work is left, and a margin, to the other PE,
 * in one transfer (par_cav_give), but only along one half of the
 * interface: the interface is cut across its longest extent, and each PE
 * receives the other's band in "its" half. Afterwards the old interface
 * lies inside one part in each half, and its cavities are local.
 *
 * Both PEs must classify a shared interface face alike (two bands that
 * share a face would cross in flight): the cut is computed once, before
 * any refinement, from the interface faces, which are then the same on
 * both PEs, and a face is classified by the smallest coordinate of its
 * vertices along the cut's axis, which both PEs compute exactly alike.
 *
 * Ownership: a par_band_cut is a plain value; par_band_pick fills a list
 * the caller owns.
 */
#ifndef PDR_PAR_BAND_H
#define PDR_PAR_BAND_H

#include <stddef.h>
#include <stdint.h>

#include "par/par_cav.h"
#include "par/par_sub.h"

typedef struct par_band_cut {
    int axis;    /* 0, 1, 2; -1: no interface to cut */
    double at;   /* faces below go to the lower rank, the rest the higher */
} par_band_cut;

/* The cut of the interface between this PE and PE other: the axis of the
 * largest extent of its faces, at the median of their smallest vertex
 * coordinates along it. Call before either PE changes the interface.
 * Returns 0 or PDR_ENOMEM. */
int par_band_cut_init(const par_sub *s, uint32_t other, par_band_cut *cut);

/* The band this PE gives PE to: starting from its tetrahedra on an
 * interface face to PE to, through local faces, every tetrahedron met at
 * most margin neighbour steps past a bad one (TM_F_QUEUED; the interface
 * counts as one), so that the work along the interface and the cavities
 * of its points lie inside; but only tetrahedra on to's side of the cut,
 * free of locks, whose interface faces all lead to PE to and lie on to's
 * side too; and of those, the ones whose local neighbours are all free
 * (what par_cav_give requires). Appends them to *out. Returns 0 or
 * PDR_ENOMEM. */
int par_band_pick(const par_sub *s, const par_band_cut *cut, uint32_t to, int margin,
                  par_u32list *out);

#endif /* PDR_PAR_BAND_H */
