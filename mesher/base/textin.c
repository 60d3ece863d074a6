/* base/textin.c -- line reader and number parsing with file:line errors. */
#include "config.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "base/textin.h"

int textin_open(textin *t, const char *path, pdr_diag *diag)
{
    memset(t, 0, sizeof *t);
    t->path = path;
    t->diag = diag;
    t->f = fopen(path, "r");
    if (!t->f) {
        pdr_diag_add(diag, path, 0, "cannot open: %s", strerror(errno));
        return PDR_EIO;
    }
    return 0;
}

void textin_attach(textin *t, FILE *f, const char *path, pdr_diag *diag)
{
    memset(t, 0, sizeof *t);
    t->path = path;
    t->diag = diag;
    t->f = f;
    t->borrowed = 1;
}

void textin_close(textin *t)
{
    if (t->f && !t->borrowed)
        fclose(t->f);
    pr_free(t->buf);
    t->f = NULL;
    t->buf = NULL;
    t->cur = NULL;
    t->cap = 0;
}

/* Reads the next line, up to and including its '\n' (or to the end of the
 * file), into t->buf, NUL-terminated, and stores its length in *len. This
 * is getline() on the allocation hook: t->buf grows by doubling through
 * pr_realloc, and keeps its old contents when that fails. Returns 1 on a
 * line, 0 at the end of the file or on a read error (ferror tells), or
 * PDR_ENOMEM. */
static int read_line(textin *t, size_t *len)
{
    size_t n = 0;
    int c = EOF;
    flockfile(t->f);
    for (;;) {
        if (n + 1 >= t->cap) {
            size_t cap = t->cap ? 2 * t->cap : 128;
            char *buf = cap > t->cap ? pr_realloc(t->buf, cap) : NULL;
            if (!buf) {
                funlockfile(t->f);
                return PDR_ENOMEM;
            }
            t->buf = buf;
            t->cap = cap;
        }
        c = getc_unlocked(t->f);
        if (c == EOF)
            break;
        t->buf[n++] = (char)c;
        if (c == '\n')
            break;
    }
    funlockfile(t->f);
    t->buf[n] = '\0';
    *len = n;
    return n > 0 && !(c == EOF && ferror(t->f));
}

int textin_next_raw(textin *t, int keep_comments)
{
    if (!t->f)
        return 0;
    for (;;) {
        size_t n;
        errno = 0;
        int rc = read_line(t, &n);
        if (rc == PDR_ENOMEM) {
            pdr_diag_add(t->diag, t->path, t->line + 1, "out of memory");
            return PDR_ENOMEM;
        }
        if (rc == 0) {
            if (ferror(t->f)) {
                pdr_diag_add(t->diag, t->path, t->line + 1, "read error: %s",
                             strerror(errno ? errno : EIO));
                return PDR_EIO;
            }
            t->cur = NULL;
            return 0;
        }
        t->line++;
        if (memchr(t->buf, '\0', n)) {
            pdr_diag_add(t->diag, t->path, t->line, "binary data in a text file");
            return PDR_EPARSE;
        }
        if (!keep_comments) {
            char *hash = strchr(t->buf, '#');
            if (hash)
                *hash = '\0';
        }
        t->cur = t->buf;
        if (!textin_at_eol(t))
            return 1;
    }
}

int textin_header(textin *t, const char *expected)
{
    int rc = textin_next(t);
    if (rc == 0) {
        pdr_diag_add(t->diag, t->path, 0, "empty file: expected '%s'", expected);
        return PDR_EPARSE;
    }
    return rc < 0 ? rc : 0;
}

int textin_next(textin *t)
{
    return textin_next_raw(t, 0);
}

static int is_space(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == ',' ||
           c == '\v' || c == '\f';
}

int textin_at_eol(const textin *t)
{
    const char *p = t->cur;
    if (!p)
        return 1;
    while (*p && is_space(*p))
        p++;
    return *p == '\0';
}

char *textin_word(textin *t)
{
    char *p = t->cur;
    if (!p)
        return NULL;
    while (*p && is_space(*p))
        p++;
    if (!*p) {
        t->cur = p;
        return NULL;
    }
    char *start = p;
    while (*p && !is_space(*p))
        p++;
    if (*p)
        *p++ = '\0';
    t->cur = p;
    return start;
}

int textin_error(textin *t, const char *fmt, ...)
{
    char msg[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    pdr_diag_add(t->diag, t->path, t->line, "%s", msg);
    return PDR_EPARSE;
}

static int parse_long(textin *t, const char *what, long min, long max, long *out,
                      int optional)
{
    char *w = textin_word(t);
    if (!w) {
        if (optional)
            return 1;
        return textin_error(t, "missing %s", what);
    }
    char *end;
    errno = 0;
    long v = strtol(w, &end, 10);
    if (*end != '\0' || end == w)
        return textin_error(t, "%s: '%s' is not an integer", what, w);
    if (errno == ERANGE || v < min || v > max)
        return textin_error(t, "%s %s is out of range [%ld, %ld]", what, w, min, max);
    *out = v;
    return 0;
}

static int parse_double(textin *t, const char *what, double *out, int optional)
{
    char *w = textin_word(t);
    if (!w) {
        if (optional)
            return 1;
        return textin_error(t, "missing %s", what);
    }
    char *end;
    errno = 0;
    double v = strtod(w, &end);
    if (*end != '\0' || end == w)
        return textin_error(t, "%s: '%s' is not a number", what, w);
    if (!isfinite(v) || (errno == ERANGE && fabs(v) > 1.0))
        return textin_error(t, "%s %s is not a finite number", what, w);
    *out = v;
    return 0;
}

int textin_long(textin *t, const char *what, long min, long max, long *out)
{
    return parse_long(t, what, min, max, out, 0);
}

int textin_opt_long(textin *t, const char *what, long min, long max, long *out)
{
    return parse_long(t, what, min, max, out, 1);
}

int textin_double(textin *t, const char *what, double *out)
{
    return parse_double(t, what, out, 0);
}

int textin_opt_double(textin *t, const char *what, double *out)
{
    return parse_double(t, what, out, 1);
}
