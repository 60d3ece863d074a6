/* cli/pdr.c -- entry point of the pdr program: dispatches to a subcommand. */
#include "config.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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

int main(int argc, char **argv)
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
