/*
 * am.h -- libam, the active-message runtime of pdr.
 *
 * A job is P processing elements (PEs), one OS process each. PEs talk only
 * through active messages: one-sided asynchronous calls of a handler that
 * runs on the receiving PE when it polls. The runtime knows nothing about
 * meshes; see DESIGN.md section 2.
 *
 * Conventions: every function that can fail returns 0 or a negative AM_E*
 * code; am_strerror() names each code. Strings returned by the library are
 * static and owned by it.
 */
#ifndef AM_H
#define AM_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#if defined(__GNUC__) && defined(AM_BUILDING)
#define AM_EXPORT __attribute__((visibility("default")))
#else
#define AM_EXPORT
#endif

/* ------------------------------------------------------------ error codes */

/* X-macro table: code name, value, message. Values are stable ABI. */
#define AM_ERRNO_MAP(X)                                                      \
    X(OK, 0, "success")                                                      \
    X(NOMEM, -1, "out of memory")                                            \
    X(INVAL, -2, "invalid argument")                                         \
    X(STATE, -3, "call not allowed in the runtime's current state")          \
    X(TRANSPORT, -4, "transport error")                                      \
    X(PROTO, -5, "malformed or incompatible message")                        \
    X(PEER, -6, "a peer PE failed or went away")                             \
    X(TIMEOUT, -7, "timed out")                                              \
    X(LAUNCH, -8, "job launch failed")                                       \
    X(NOHANDLER, -9, "no handler registered for this id")                    \
    X(SYS, -10, "system call failed (see errno)")

enum am_errno {
#define AM_ERRNO_ENUM(name, value, msg) AM_E##name = (value),
    AM_ERRNO_MAP(AM_ERRNO_ENUM)
#undef AM_ERRNO_ENUM
};

/* Returns a static message for code; never NULL (unknown codes get a
 * generic message). */
AM_EXPORT const char *am_strerror(int code);

/* Returns the symbolic name of code ("AM_EINVAL"), or "AM_E?" if unknown. */
AM_EXPORT const char *am_errname(int code);

/* ----------------------------------------------------------------- version */

/* Version of the library actually linked, as "MAJOR.MINOR.PATCH"; static. */
AM_EXPORT const char *am_version(void);

#ifdef __cplusplus
}
#endif
#endif /* AM_H */
