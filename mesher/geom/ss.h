/*
 * geom/ss.h -- insertion orders for incremental Delaunay (prefix ss_).
 *
 * ss_brio_hilbert() returns a biased randomised insertion order (BRIO,
 * Amenta-Choi-Rote): points are dealt into rounds at random, each round
 * about four times the size of the previous one, and each round is sorted along
 * a 3D Hilbert curve. Randomness between rounds keeps the expected work of
 * incremental Delaunay optimal; the curve order inside a round makes
 * consecutive points close, so point location from the last tetrahedron
 * takes a few steps and the memory touched stays in cache. Consecutive
 * rounds run the curve in opposite directions, so the end of one round is
 * near the start of the next.
 */
#ifndef PDR_SPATIAL_SORT_H
#define PDR_SPATIAL_SORT_H

#include <stddef.h>
#include <stdint.h>

/* Hilbert index of a point with integer coordinates below 2^bits
 * (bits <= 21): a key of 3*bits bits. */
uint64_t ss_hilbert3(uint32_t x, uint32_t y, uint32_t z, int bits);

/* Fills order[0..n) with a permutation of 0..n-1 for the points
 * xyz[3*i..3*i+2]. seed makes the rounds reproducible. Rounds smaller than
 * min_round points are merged into the first (0 means 1000). Returns 0 or
 * PDR_ENOMEM. */
int ss_brio_hilbert(const double *xyz, size_t n, uint64_t seed, size_t min_round,
                    uint32_t *order);

#endif /* PDR_SPATIAL_SORT_H */
