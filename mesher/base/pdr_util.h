/* base/pdr_util.h -- small helpers shared by the mesher's modules and commands:
 * clocks and resource usage, growable arrays, output paths, progress
 * lines. */
#ifndef PDR_UTIL_H
#define PDR_UTIL_H

#include <stddef.h>
#include <stdio.h>

#include "base/pdr_error.h"

/* Seconds on the monotonic clock (arbitrary origin). */
double pdr_now(void);
/* CPU time of the calling (OS) thread, seconds; about 25 times the cost
 * of pdr_now (a system call). */
double pdr_cpu_now(void);
/* Writes one formatted line (at most 511 bytes, the format ends it with
 * '\n') to f in a single call, so that the lines of several processes
 * sharing f do not interleave. */
void pdr_line(FILE *f, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
/* Peak resident set size of this process in bytes, or 0 if unknown. */
size_t pdr_peak_rss(void);
/* Figures of this process's memory now, in bytes, from one pass over
 * /proc/self/smaps (Linux); all 0 where the file cannot be read.
 * nonfile: the resident set without the unmodified pages of private file
 *   mappings: the whole resident part of anonymous mappings (the heap,
 *   malloc's arenas, stacks) and of shared mappings (libam's rings,
 *   counted whole in every process that touched them), and of private
 *   file mappings only the pages written to (relocations, .data, .bss).
 *   Left out: the program's and the libraries' code and read-only data,
 *   which every process running the same binary shares, and the kernel's
 *   [vdso] and [vvar].
 * pss: the proportional set size, the kernel's sum over every resident
 *   page of 1/(the number of processes that map it): each page counted
 *   once over all processes, a ring's pages half in each of its two PEs,
 *   the libraries' shared among every process using them.
 * Costs a pass of the kernel over the page tables: about 0.15 ms in a
 * small process, 5 ms in one of 60 MB. */
typedef struct pdr_mem_now {
    size_t nonfile;
    size_t pss;
    size_t rss; /* the whole resident set, for pdr_mem_peak */
} pdr_mem_now;
void pdr_mem_sample(pdr_mem_now *out);
/* pdr_mem_sample's figures at this process's peak so far, estimated from
 * a sample now: each is the figure now plus the resident memory given back
 * since the peak (the peak RSS, getrusage's, less the RSS now), which is
 * the heap and the mappings freed since (anonymous, private). Exact when
 * no file page was mapped in or dropped since the peak; where the program
 * faulted in more of its code since, low by that much (tens of KiB). A
 * sample taken at any time therefore covers the peaks before it, which a
 * bare sample misses (a buffer freed before the sample). */
void pdr_mem_peak(pdr_mem_now *out);

/* Makes the array *p of *cap elements of 'size' bytes hold at least 'need'
 * elements, doubling its capacity (from 64) so that n appends cost O(n).
 * Returns 0, or PDR_ENOMEM with *p and *cap unchanged. The check that
 * usually succeeds is inline; the reallocation is not. */
/* qsort and bsearch comparator of uint32_t values, ascending. */
int pdr_cmp_u32(const void *a, const void *b);

int pdr__grow_slow(void **p, size_t *cap, size_t need, size_t size);
static inline int pdr_grow(void **p, size_t *cap, size_t need, size_t size)
{
    return need <= *cap ? 0 : pdr__grow_slow(p, cap, need, size);
}

/* Length of path without its extension: up to the last '.' of its last
 * component, or all of it if that component has no '.'. */
size_t pdr_path_stem(const char *path);
/* The first n bytes of base followed by ext, in a new string the caller
 * frees; NULL if out of memory. */
char *pdr_path_ext(const char *base, size_t n, const char *ext);
/* base followed by ext (pdr_path_ext of all of base). */
char *pdr_path_join(const char *base, const char *ext);

/* A progress line on stderr for long runs: nothing during the first two
 * seconds; then, on a terminal, one line rewritten in place at most every
 * half second, otherwise one line every ten seconds (logs stay short). */
typedef struct pdr_progress {
    double t0, last; /* start, time of the last line */
    int quiet;       /* print nothing */
    int tty;         /* stderr is a terminal */
    int shown;       /* a line was printed */
} pdr_progress;

void pdr_progress_start(pdr_progress *p, double t0, int quiet);
/* Prints the formatted line (no newline needed) if one is due. */
void pdr_progress_line(pdr_progress *p, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));
/* Ends a line left open on a terminal. */
void pdr_progress_end(pdr_progress *p);

#endif /* PDR_UTIL_H */
