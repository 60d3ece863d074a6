/*
 * Fuzz target: the command lines of 'pdr mesh', 'pdr check', 'pdr
 * delaunay' and 'pdr domain' (see fuzz_input.h, tools/fuzz). The first
 * input byte picks the command (modulo 4); the rest is split into
 * arguments at every NUL or newline (at most 64). The command runs with
 * pdr_cli_parse_only set, so it parses its options and stops before the
 * job. Promises: the status is 0 (the job would run, or --help) or 2 (a
 * usage error), never anything else. Standard output (--help) goes to
 * /dev/null during the call.
 */
#include "config.h"

#include <fcntl.h>
#include <string.h>
#include <unistd.h>

#include "cli/pdr_cli.h"
#include "fuzz_input.h"

const char pdr_fuzz_corpus[] = "cli";

#define MAX_ARGS 64

int pdr_fuzz_run(const uint8_t *data, size_t size)
{
    static const char *const names[] = {"mesh", "check", "delaunay", "domain"};
    static int (*const cmds[])(int, char **) = {pdr_cmd_mesh, pdr_cmd_check,
                                                pdr_cmd_delaunay, pdr_cmd_domain};
    if (size == 0)
        return 0;
    int which = data[0] % 4;
    char *argv[MAX_ARGS + 2];
    int argc = 0;
    /* Each argument in its own allocation of its exact size, so that ASan
     * sees a read past its end. */
    argv[argc] = malloc(strlen(names[which]) + 1);
    PDR_FUZZ_ASSERT(argv[argc] != NULL);
    strcpy(argv[argc++], names[which]);
    size_t i = 1;
    while (i < size && argc <= MAX_ARGS) {
        size_t j = i;
        while (j < size && data[j] != '\0' && data[j] != '\n')
            j++;
        argv[argc] = malloc(j - i + 1);
        PDR_FUZZ_ASSERT(argv[argc] != NULL);
        memcpy(argv[argc], data + i, j - i);
        argv[argc++][j - i] = '\0';
        i = j + 1;
    }
    argv[argc] = NULL;

    fflush(stdout);
    int saved = dup(STDOUT_FILENO);
    int devnull = open("/dev/null", O_WRONLY);
    PDR_FUZZ_ASSERT(saved >= 0 && devnull >= 0);
    dup2(devnull, STDOUT_FILENO);
    close(devnull);
    pdr_cli_parse_only = 1;
    int status = cmds[which](argc, argv);
    fflush(stdout);
    dup2(saved, STDOUT_FILENO);
    close(saved);

    PDR_FUZZ_ASSERT(status == PDR_EXIT_OK || status == PDR_EXIT_USAGE);
    for (int k = 0; k < argc; k++)
        free(argv[k]);
    return status == PDR_EXIT_OK;
}

PDR_FUZZ_ENTRY
