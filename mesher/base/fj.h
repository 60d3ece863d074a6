/*
 * base/fj.h -- fork-join of a few independent tasks on threads (prefix
 * fj_).
 *
 * The stages after the refinement are independent of each other once the
 * mesh is exported: each output file is formatted from the same read-only
 * arrays, and the quality measure reads them too. On a machine with two
 * or more cores fj_run lets them share the cores. A task must touch
 * nothing another task of the same run writes: its own output file, its
 * own outset and pdr_diag, its own result. The tasks are taken in order
 * by whichever thread is free, so a run on one thread does them in order,
 * exactly as plain calls would.
 *
 * Ownership: the caller owns the task array and what the arguments point
 * to; fj_run keeps nothing after it returns.
 */
#ifndef PDR_FJ_H
#define PDR_FJ_H

#include <stddef.h>

typedef struct fj_task {
    int (*run)(void *arg); /* the work; returns 0 or an error code */
    void *arg;
    int rc;                /* out: what run returned */
    double seconds;        /* out: how long run took (monotonic clock) */
} fj_task;

/* Runs every task of t[0..n) once, on up to nthreads threads counting the
 * caller's, and returns when all are done. With nthreads <= 1, or when no
 * thread can be started, the caller runs them all itself, in order. */
void fj_run(fj_task *t, size_t n, unsigned nthreads);

/* The processors this process may run on (its affinity mask, else those
 * online; at least 1). */
unsigned fj_cores(void);

#endif /* PDR_FJ_H */
