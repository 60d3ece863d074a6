/* base/fj.c -- fork-join of a few independent tasks (see base/fj.h). */
#include "config.h"

#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#include <unistd.h>

#include "base/fj.h"
#include "base/pdr_util.h"

/* At most this many threads besides the caller's: the writers are a
 * handful of tasks. */
#define FJ_MAX_THREADS 7

typedef struct fj_run_state {
    fj_task *t;
    size_t n;
    atomic_size_t next; /* the next task nobody has taken */
} fj_run_state;

static void *worker(void *arg)
{
    fj_run_state *s = arg;
    for (;;) {
        size_t i = atomic_fetch_add_explicit(&s->next, 1, memory_order_relaxed);
        if (i >= s->n)
            break;
        double t0 = pdr_now();
        s->t[i].rc = s->t[i].run(s->t[i].arg);
        s->t[i].seconds = pdr_now() - t0;
    }
    return NULL;
}

void fj_run(fj_task *t, size_t n, unsigned nthreads)
{
    fj_run_state s = {t, n, 0};
    atomic_init(&s.next, 0);
    pthread_t th[FJ_MAX_THREADS];
    /* Threads besides the caller's: no more than the tasks after the
     * first, nor than FJ_MAX_THREADS. */
    size_t extra = nthreads > 1 ? nthreads - 1 : 0, most = n > 1 ? n - 1 : 0;
    if (extra > most)
        extra = most;
    if (extra > FJ_MAX_THREADS)
        extra = FJ_MAX_THREADS;
    size_t started = 0;
    while (started < extra && pthread_create(&th[started], NULL, worker, &s) == 0)
        started++;
    worker(&s);
    for (size_t i = 0; i < started; i++)
        pthread_join(th[i], NULL);
}

unsigned fj_cores(void)
{
#ifdef CPU_COUNT
    /* The processors this process may run on (taskset, cgroups). */
    cpu_set_t set;
    if (sched_getaffinity(0, sizeof set, &set) == 0 && CPU_COUNT(&set) > 0)
        return (unsigned)CPU_COUNT(&set);
#endif
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n > 0 ? (unsigned)n : 1u;
}
