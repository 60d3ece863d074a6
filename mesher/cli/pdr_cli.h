/*
 * cli/pdr_cli.h -- the subcommands of the pdr program.
 *
 * Each subcommand NAME lives in mesher/cli/cmd_NAME.c as
 *     int pdr_cmd_NAME(int argc, char **argv);
 * which receives argv[0] == "NAME", parses its own options, and returns the
 * process exit status (0 success, 1 failure of the job, 2 usage error).
 * Adding a command means adding one line to PDR_COMMANDS.
 */
#ifndef PDR_CLI_H
#define PDR_CLI_H

#define PDR_COMMANDS(X)                                                      \
    X(info, "print the version, build configuration and libraries")          \
    X(delaunay, "Delaunay tetrahedralization of a point set (.node)")        \
    X(check, "verify a tetrahedral mesh (.node/.ele) with exact predicates") \
    X(domain, "write a model problem (cube-in-cube, tee) as a .poly file")   \
    X(run, "start a program as a parallel libam job (like am-run)")          \
    X(mesh, "quality tetrahedral mesh of a PLC (.poly/.smesh/.off/.stl)")

#define PDR_CMD_DECLARE(name, summary) int pdr_cmd_##name(int argc, char **argv);
PDR_COMMANDS(PDR_CMD_DECLARE)
#undef PDR_CMD_DECLARE

/* Exit statuses shared by all commands. */
enum { PDR_EXIT_OK = 0, PDR_EXIT_FAIL = 1, PDR_EXIT_USAGE = 2 };

/* Prints "pdr NAME: " and the formatted message to stderr. */
void pdr_cli_error(const char *cmd, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));
/* After a step failed with rc: prints the messages in diag (a pdr_diag *;
 * void * keeps base/ out of this header), and when rc is PDR_ENOMEM
 * "pdr NAME: out of memory", the one line that says why whatever messages
 * memory was too short to keep. */
void pdr_cli_fail(const char *cmd, const void *diag, int rc);

/* --merge-angle A of 'pdr mesh' and 'pdr check': A in [0, 90) degrees
 * into *out. Returns 0, or -1 after a usage message naming cmd. */
int pdr_cli_merge_angle(const char *cmd, const char *arg, double *out);
/* --facet-tol T of 'pdr mesh' and 'pdr check': T in [0, 1e-3] into *out.
 * Returns 0, or -1 after a usage message naming cmd. */
int pdr_cli_facet_tol(const char *cmd, const char *arg, double *out);

/* When nonzero, the commands mesh, check, delaunay and domain stop after
 * parsing their command line: they print the same usage errors and return
 * the same usage status, but return PDR_EXIT_OK instead of running the
 * job (no file is read or written). For the command-line fuzz target. */
extern int pdr_cli_parse_only;

#endif /* PDR_CLI_H */
