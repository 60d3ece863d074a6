/* base/pdr_util.c -- clocks and resource usage. */
#include "config.h"

#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

#include "pr_alloc.h"
#include "base/pdr_util.h"

double pdr_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

double pdr_cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

void pdr_line(FILE *f, const char *fmt, ...)
{
    char line[512];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    if (n > 0)
        fwrite(line, 1, (size_t)n < sizeof line ? (size_t)n : sizeof line - 1, f);
}

size_t pdr_peak_rss(void)
{
    struct rusage ru;
    if (getrusage(RUSAGE_SELF, &ru) != 0)
        return 0;
    return (size_t)ru.ru_maxrss * 1024; /* Linux reports KiB */
}

int pdr__grow_slow(void **p, size_t *cap, size_t need, size_t size)
{
    size_t c = *cap ? *cap : 64;
    while (c < need) {
        if (c > SIZE_MAX / 2)
            return PDR_ENOMEM;
        c *= 2;
    }
    if (size && c > SIZE_MAX / size)
        return PDR_ENOMEM;
    void *q = pr_realloc(*p, c * size);
    if (!q)
        return PDR_ENOMEM;
    *p = q;
    *cap = c;
    return 0;
}

size_t pdr_path_stem(const char *path)
{
    const char *slash = strrchr(path, '/');
    const char *dot = strrchr(path, '.');
    return dot && (!slash || dot > slash) ? (size_t)(dot - path) : strlen(path);
}

char *pdr_path_ext(const char *base, size_t n, const char *ext)
{
    size_t e = strlen(ext);
    char *s = pr_malloc(n + e + 1);
    if (s) {
        memcpy(s, base, n);
        memcpy(s + n, ext, e + 1);
    }
    return s;
}

char *pdr_path_join(const char *base, const char *ext)
{
    return pdr_path_ext(base, strlen(base), ext);
}

void pdr_progress_start(pdr_progress *p, double t0, int quiet)
{
    p->t0 = t0;
    p->last = 0;
    p->quiet = quiet;
    p->tty = isatty(2);
    p->shown = 0;
}

void pdr_progress_line(pdr_progress *p, const char *fmt, ...)
{
    double now = pdr_now();
    if (p->quiet || now - p->t0 < 2.0 || now - p->last < (p->tty ? 0.5 : 10.0))
        return;
    p->last = now;
    va_list ap;
    va_start(ap, fmt);
    if (p->tty)
        fputc('\r', stderr);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fprintf(stderr, ", %.1f s%s", now - p->t0, p->tty ? "" : "\n");
    p->shown = 1;
}

void pdr_progress_end(pdr_progress *p)
{
    if (p->shown && p->tty)
        fputc('\n', stderr);
}
