/* cli/cli_util.c -- what the subcommands share: messages, the
 * --merge-angle option, and the parse-only switch for the command-line
 * fuzz target. Kept apart from pdr.c (main) so that the subcommands can
 * be linked into other programs (tests/fuzz/fuzz_cli.c). */
#include "config.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

#include "base/pdr_error.h"
#include "cli/pdr_cli.h"

int pdr_cli_parse_only;

void pdr_cli_error(const char *cmd, const char *fmt, ...)
{
    va_list ap;
    fprintf(stderr, "pdr %s: ", cmd);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
}

void pdr_cli_fail(const char *cmd, const void *diag, int rc)
{
    if (rc == PDR_ENOMEM) {
        pdr_diag_print_kept(diag, stderr);
        pdr_cli_error(cmd, "%s", pdr_strerror(rc));
    } else {
        pdr_diag_print(diag, stderr);
    }
}

int pdr_cli_merge_angle(const char *cmd, const char *arg, double *out)
{
    char *end;
    errno = 0;
    double x = strtod(arg, &end);
    if (errno || end == arg || *end || !(x >= 0 && x < 90)) {
        pdr_cli_error(cmd, "--merge-angle needs an angle in [0, 90) degrees, not '%s'", arg);
        return -1;
    }
    *out = x;
    return 0;
}

int pdr_cli_facet_tol(const char *cmd, const char *arg, double *out)
{
    char *end;
    errno = 0;
    double x = strtod(arg, &end);
    if (errno || end == arg || *end || !(x >= 0 && x <= 1e-3)) {
        pdr_cli_error(cmd, "--facet-tol needs a number in [0, 0.001], not '%s'", arg);
        return -1;
    }
    *out = x;
    return 0;
}
