/*
 * base/textin.h -- line-oriented reader for the TetGen-style text formats
 * (.node, .ele, .poly, .smesh, .off, ascii .stl).
 *
 * It yields one logical line at a time with comments ('#' to end of line)
 * and blank lines skipped, and parses whitespace-separated numbers with
 * every failure reported as "file:line: ..." into a pdr_diag. The reader
 * owns its FILE and line buffer; textin_close() releases both.
 */
#ifndef PDR_TEXTIN_H
#define PDR_TEXTIN_H

#include <stdio.h>

#include "base/pdr_error.h"

typedef struct textin {
    FILE *f;          /* owned unless borrowed */
    int borrowed;     /* f belongs to the caller (textin_attach) */
    const char *path; /* not owned; used in messages */
    char *buf;        /* owned line buffer */
    size_t cap;
    long line;        /* number of the current line, 1-based */
    char *cur;        /* parse position in buf */
    pdr_diag *diag;   /* not owned; where errors go */
} textin;

/* Opens path for reading. On failure records "path: strerror" in diag and
 * returns PDR_EIO. */
int textin_open(textin *t, const char *path, pdr_diag *diag);
/* Reads from an open stream the caller keeps owning (f is not closed). */
void textin_attach(textin *t, FILE *f, const char *path, pdr_diag *diag);
void textin_close(textin *t);

/* Advances to the next line that has content after comment stripping.
 * Returns 1 on a line, 0 at end of file, PDR_EIO on a read error.
 * keep_comments: do not strip '#' (for formats where '#' is data). */
int textin_next(textin *t);
int textin_next_raw(textin *t, int keep_comments);
/* Advances to the header line of a file. Returns 0 on a line; at end of
 * file records "path: empty file: expected '<expected>'" and returns
 * PDR_EPARSE; PDR_EIO on a read error. */
int textin_header(textin *t, const char *expected);

/* Parse the next token of the current line. Each returns 0, or records a
 * diagnostic naming 'what' ("vertex count", "x coordinate") and returns
 * PDR_EPARSE if the token is missing or malformed or out of range. */
int textin_long(textin *t, const char *what, long min, long max, long *out);
int textin_double(textin *t, const char *what, double *out);
/* Like textin_long/double, but a missing token is not an error: returns 1
 * and leaves *out unchanged if the line has no more tokens. */
int textin_opt_long(textin *t, const char *what, long min, long max, long *out);
int textin_opt_double(textin *t, const char *what, double *out);
/* Next whitespace-separated word (NUL-terminated in place), or NULL. */
char *textin_word(textin *t);
/* Nonzero if only white space remains on the current line. */
int textin_at_eol(const textin *t);
/* Records "file:line: <formatted>" for the current line; returns
 * PDR_EPARSE. */
int textin_error(textin *t, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));

#endif /* PDR_TEXTIN_H */
