/*
 * base/pdr_error.h -- error codes and diagnostics shared by the mesher modules.
 *
 * Functions of the mesher return 0 or a negative PDR_E* code. When an error
 * concerns a place in an input file, the module also records a diagnostic
 * ("file:line: message") in a pdr_diag the caller owns, so the program can
 * print every problem found, not only the first.
 */
#ifndef PDR_ERROR_H
#define PDR_ERROR_H

#include <stddef.h>

#define PDR_ERRNO_MAP(X)                                                     \
    X(OK, 0, "success")                                                      \
    X(NOMEM, -1, "out of memory")                                            \
    X(INVAL, -2, "invalid argument")                                         \
    X(IO, -3, "input/output error")                                          \
    X(PARSE, -4, "malformed input file")                                     \
    X(GEOMETRY, -5, "invalid geometry in input")                             \
    X(TOPOLOGY, -6, "mesh is inconsistent")                                  \
    X(LIMIT, -7, "a size limit was exceeded")                                \
    X(UNSUPPORTED, -8, "not supported")

enum pdr_errno {
#define PDR_ERRNO_ENUM(name, value, msg) PDR_E##name = (value),
    PDR_ERRNO_MAP(PDR_ERRNO_ENUM)
#undef PDR_ERRNO_ENUM
};

/* Static message for code, never NULL. */
const char *pdr_strerror(int code);

/* A list of diagnostics. Zero-initialised it is empty and valid; the caller
 * owns it and releases it with pdr_diag_free(). At most PDR_DIAG_KEEP
 * messages are stored; later ones are only counted, so a hopeless input
 * cannot exhaust memory through its error list. A message that cannot be
 * stored for lack of memory is counted as lost, and pdr_diag_print says
 * so: an error found while memory is short is never silent. */
#define PDR_DIAG_KEEP 100

typedef struct pdr_diag {
    char **msgs;    /* owned, nkept strings "file:line: text" */
    size_t nkept;   /* messages stored */
    size_t ntotal;  /* messages reported, stored or not */
    size_t nlost;   /* of those, not stored for lack of memory */
} pdr_diag;

/* Records "file:line: text". file may be NULL (then "line" is omitted too
 * when line is 0). d may be NULL: the message is dropped (returns 0). Returns the number of messages reported so far, or
 * PDR_ENOMEM if the message could not be stored (it counts as lost). */
int pdr_diag_add(pdr_diag *d, const char *file, long line, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
/* Writes every stored message, one per line, a count of those that were
 * not stored because of the PDR_DIAG_KEEP cap, and one of those lost for
 * lack of memory ("(N messages lost: out of memory)"), to f (a FILE *; void * keeps stdio out of this header). */
void pdr_diag_print(const pdr_diag *d, void *f);
/* The same without the count of lost messages, for a caller that prints
 * "out of memory" itself. */
void pdr_diag_print_kept(const pdr_diag *d, void *f);
/* Appends the messages of from to d, in order, and empties from (its
 * messages change owner; those beyond d's cap are only counted, and if d
 * cannot grow they count as lost). */
void pdr_diag_move(pdr_diag *d, pdr_diag *from);
void pdr_diag_free(pdr_diag *d);

#endif /* PDR_ERROR_H */
