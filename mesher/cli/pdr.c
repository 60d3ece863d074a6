/* cli/pdr.c -- entry point of the pdr program: dispatches to a subcommand. */
#include "config.h"

#include <errno.h>
#include <inttypes.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "cli/pdr_cli.h"

struct command {
    const char *name;
    int (*run)(int argc, char **argv);
    const char *summary;
};

static const struct command commands[] = {
#define PDR_CMD_ENTRY(name, summary) {#name, pdr_cmd_##name, summary},
    PDR_COMMANDS(PDR_CMD_ENTRY)
#undef PDR_CMD_ENTRY
};

static void usage(FILE *out)
{
    fprintf(out,
            "Usage: pdr COMMAND [OPTIONS] [ARGS]\n"
            "       pdr COMMAND --help\n"
            "       pdr --version\n\n"
            "pdr builds guaranteed-quality tetrahedral Delaunay meshes.\n\n"
            "Commands:\n");
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        fprintf(out, "  %-10s %s\n", commands[i].name, commands[i].summary);
    fprintf(out, "\nReport bugs with the command line, the input file and "
                 "the output of 'pdr info'.\n");
}

/* PDR_ALLOC_FAIL=N, for the allocation-failure tests (tests/alloc-fail.sh):
 * the N-th allocation through the hook (proto/pr_alloc.h) and every later
 * one fail, as when memory runs out; N = 0 fails none. Either way main
 * prints the number of allocations made and refused when the command
 * returns, so a test can learn how many a run makes. It is read here, in
 * the program, because the libraries never read the environment. Returns
 * 1 if set, 0 if not, -1 (after a message) if malformed. */
static int alloc_fail_from_env(void)
{
    const char *s = getenv("PDR_ALLOC_FAIL");
    if (!s)
        return 0;
    char *end;
    errno = 0;
    unsigned long long n = strtoull(s, &end, 10);
    if (*s < '0' || *s > '9' || *end != '\0' || errno == ERANGE) {
        fprintf(stderr, "pdr: PDR_ALLOC_FAIL='%s' is not a count of "
                        "allocations\n", s);
        return -1;
    }
    pr_alloc_fail_after((uint64_t)n);
    return 1;
}

static int run_command(int argc, char **argv)
{
    if (argc < 2) {
        usage(stderr);
        return PDR_EXIT_USAGE;
    }
    const char *name = argv[1];
    if (!strcmp(name, "--help") || !strcmp(name, "-h") || !strcmp(name, "help")) {
        usage(stdout);
        return PDR_EXIT_OK;
    }
    if (!strcmp(name, "--version") || !strcmp(name, "-V")) {
        printf("pdr %s\n", PACKAGE_VERSION);
        return PDR_EXIT_OK;
    }
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        if (!strcmp(name, commands[i].name))
            return commands[i].run(argc - 1, argv + 1);
    fprintf(stderr, "pdr: unknown command '%s' (try 'pdr --help')\n", name);
    return PDR_EXIT_USAGE;
}

int main(int argc, char **argv)
{
    int counting = alloc_fail_from_env();
    if (counting < 0)
        return PDR_EXIT_USAGE;
    int rc = run_command(argc, argv);
    if (counting) {
        fflush(stdout); /* the count is the last line, also in 2>&1 */
        fprintf(stderr, "pdr: allocations: %" PRIu64 " made, %" PRIu64
                        " refused\n", pr_alloc_count(), pr_alloc_refused());
    }
    return rc;
}
