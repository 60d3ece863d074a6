/* base/pdr_error.c -- mesher error codes and file:line diagnostics. */
#include "config.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

#include "pr_alloc.h"
#include "base/pdr_error.h"

const char *pdr_strerror(int code)
{
    switch (code) {
#define PDR_ERRNO_CASE(name, value, msg)                                     \
    case PDR_E##name:                                                        \
        return msg;
        PDR_ERRNO_MAP(PDR_ERRNO_CASE)
#undef PDR_ERRNO_CASE
    }
    return "unknown pdr error";
}

int pdr_diag_add(pdr_diag *d, const char *file, long line, const char *fmt, ...)
{
    if (!d)
        return 0;
    d->ntotal++;
    if (d->nkept >= PDR_DIAG_KEEP)
        return (int)(d->ntotal > (size_t)1 << 30 ? 1 << 30 : d->ntotal);

    char prefix[512] = "";
    if (file && line > 0)
        snprintf(prefix, sizeof prefix, "%s:%ld: ", file, line);
    else if (file)
        snprintf(prefix, sizeof prefix, "%s: ", file);

    va_list ap;
    va_start(ap, fmt);
    va_list ap2;
    va_copy(ap2, ap);
    int n = vsnprintf(NULL, 0, fmt, ap);
    va_end(ap);
    if (n < 0) {
        va_end(ap2);
        return PDR_EINVAL;
    }
    size_t plen = 0;
    while (prefix[plen])
        plen++;
    char *msg = pr_malloc(plen + (size_t)n + 1);
    char **msgs = msg ? pr_realloc(d->msgs, (d->nkept + 1) * sizeof *msgs) : NULL;
    if (!msgs) {
        pr_free(msg);
        va_end(ap2);
        d->nlost++;
        return PDR_ENOMEM;
    }
    d->msgs = msgs;
    for (size_t i = 0; i < plen; i++)
        msg[i] = prefix[i];
    vsnprintf(msg + plen, (size_t)n + 1, fmt, ap2);
    va_end(ap2);
    d->msgs[d->nkept++] = msg;
    return (int)(d->ntotal > (size_t)1 << 30 ? 1 << 30 : d->ntotal);
}

static void diag_print(const pdr_diag *d, FILE *out, int lost)
{
    for (size_t i = 0; i < d->nkept; i++)
        fprintf(out, "%s\n", d->msgs[i]);
    size_t capped = d->ntotal - d->nkept - d->nlost;
    if (capped)
        fprintf(out, "(%zu more messages not shown)\n", capped);
    if (lost && d->nlost)
        fprintf(out, "(%zu message%s lost: out of memory)\n", d->nlost,
                d->nlost == 1 ? "" : "s");
}

void pdr_diag_print(const pdr_diag *d, void *f)
{
    diag_print(d, f, 1);
}

void pdr_diag_print_kept(const pdr_diag *d, void *f)
{
    diag_print(d, f, 0);
}

void pdr_diag_move(pdr_diag *d, pdr_diag *from)
{
    if (!d->ntotal) {
        *d = *from; /* the common case: nothing to merge, no memory needed */
        *from = (pdr_diag){0};
        return;
    }
    size_t room = d->nkept < PDR_DIAG_KEEP ? PDR_DIAG_KEEP - d->nkept : 0;
    size_t take = from->nkept < room ? from->nkept : room;
    char **msgs = take ? pr_realloc(d->msgs, (d->nkept + take) * sizeof *msgs) : d->msgs;
    if (!msgs) {
        d->nlost += take; /* counted, so never silent */
        take = 0;
    } else {
        d->msgs = msgs;
    }
    for (size_t i = 0; i < from->nkept; i++) {
        if (i < take)
            d->msgs[d->nkept++] = from->msgs[i];
        else
            pr_free(from->msgs[i]);
    }
    d->ntotal += from->ntotal;
    d->nlost += from->nlost;
    pr_free(from->msgs);
    *from = (pdr_diag){0};
}

void pdr_diag_free(pdr_diag *d)
{
    for (size_t i = 0; i < d->nkept; i++)
        pr_free(d->msgs[i]);
    pr_free(d->msgs);
    d->msgs = NULL;
    d->nkept = d->ntotal = d->nlost = 0;
}
