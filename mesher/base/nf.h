/*
 * base/nf.h -- fast exact number formatting for the text writers (prefix
 * nf_).
 *
 * Writing a mesh of a million tetrahedra prints about a million
 * coordinates; glibc's printf("%.17g") spends some 300 ns on each (it
 * works in arbitrary precision for every call). nf_double17() writes the
 * same characters in a fraction of that for the doubles a mesh has
 * (magnitudes from 1e-3 to 1e16): the 17 significant digits are computed
 * exactly in 128-bit integer arithmetic, x * 10^k = m * 2^e * 10^k,
 * rounded half to even like printf in the default rounding mode. Other
 * values (and compilers without a 128-bit integer type) go to snprintf.
 * 17 significant digits read back to the same double.
 */
#ifndef PDR_NUMFMT_H
#define PDR_NUMFMT_H

#include <stddef.h>

/* Longest output of nf_double17, with the terminating NUL. */
#define NF_DOUBLE17_MAX 32

/* Writes x as printf("%.17g", x) would into buf (at least
 * NF_DOUBLE17_MAX bytes), NUL-terminated; returns the length. */
size_t nf_double17(double x, char *buf);

#endif /* PDR_NUMFMT_H */
