/* pdr_util.h -- clocks and resource usage for summaries and benchmarks. */
#ifndef PDR_UTIL_H
#define PDR_UTIL_H

#include <stddef.h>

/* Seconds on the monotonic clock (arbitrary origin). */
double pdr_now(void);
/* Peak resident set size of this process in bytes, or 0 if unknown. */
size_t pdr_peak_rss(void);

#endif /* PDR_UTIL_H */
