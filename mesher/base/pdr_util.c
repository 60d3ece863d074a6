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

/* The value in KiB of "Key:   N kB" at line, or -1 if line is not key's. */
static long long smaps_kib(const char *line, const char *key)
{
    size_t k = strlen(key);
    if (strncmp(line, key, k) != 0 || line[k] != ':')
        return -1;
    char *end;
    long long v = strtoll(line + k + 1, &end, 10);
    return end != line + k + 1 && v >= 0 ? v : -1;
}

void pdr_mem_sample(pdr_mem_now *out)
{
    out->nonfile = out->pss = out->rss = 0;
    FILE *f = fopen("/proc/self/smaps", "re");
    if (!f)
        return;
    char line[512];
    unsigned long long kib = 0, pss_kib = 0, rss_kib = 0;
    /* The mapping whose fields follow: 0 anonymous or shared (its Rss
     * counts), 1 private file mapping (its Anonymous counts: the pages
     * written to), 2 the kernel's ([vdso], [vvar]: neither). */
    int kind = 2, seen = 0;
    while (fgets(line, sizeof line, f)) {
        size_t n = strlen(line);
        int whole = n > 0 && line[n - 1] == '\n';
        if (line[0] >= 'A' && line[0] <= 'Z') { /* "Field:   N kB" */
            long long v = kind == 0 ? smaps_kib(line, "Rss")
                          : kind == 1 ? smaps_kib(line, "Anonymous")
                                      : -1;
            if (v > 0)
                kib += (unsigned long long)v;
            v = smaps_kib(line, "Pss");
            if (v > 0)
                pss_kib += (unsigned long long)v;
            v = smaps_kib(line, "Rss");
            if (v > 0)
                rss_kib += (unsigned long long)v;
        } else { /* "lo-hi perms offset dev inode [name]" */
            char *p = strchr(line, ' ');
            char *perms = p ? p + 1 : NULL;
            char *q = perms && strlen(perms) > 5 ? perms + 5 : NULL; /* offset */
            q = q ? strchr(q, ' ') : NULL;                          /* dev */
            q = q ? strchr(q + 1, ' ') : NULL;                      /* inode */
            kind = 2;
            if (q) {
                char *end;
                unsigned long long inode = strtoull(q + 1, &end, 10);
                while (*end == ' ')
                    end++;
                kind = !strncmp(end, "[v", 2) ? 2 : perms[3] == 's' || inode == 0 ? 0 : 1;
                seen = 1;
            }
        }
        /* a line longer than the buffer (a long path): skip its rest */
        while (!whole && fgets(line, sizeof line, f)) {
            n = strlen(line);
            whole = n > 0 && line[n - 1] == '\n';
        }
    }
    fclose(f);
    if (seen) {
        out->nonfile = (size_t)kib * 1024;
        out->pss = (size_t)pss_kib * 1024;
        out->rss = (size_t)rss_kib * 1024;
    }
}

void pdr_mem_peak(pdr_mem_now *out)
{
    pdr_mem_sample(out);
    size_t hwm = pdr_peak_rss();
    if (out->rss == 0 || hwm <= out->rss)
        return;
    size_t given_back = hwm - out->rss;
    out->nonfile += given_back;
    out->pss += given_back;
    out->rss = hwm;
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

int pdr_cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}
