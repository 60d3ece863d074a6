/* am_error.c -- error codes and version of libam. */
#include "config.h"

#include "am.h"

const char *am_strerror(int code)
{
    switch (code) {
#define AM_ERRNO_CASE(name, value, msg)                                      \
    case AM_E##name:                                                         \
        return msg;
        AM_ERRNO_MAP(AM_ERRNO_CASE)
#undef AM_ERRNO_CASE
    }
    return "unknown libam error";
}

const char *am_errname(int code)
{
    switch (code) {
#define AM_ERRNO_NAME(name, value, msg)                                      \
    case AM_E##name:                                                         \
        return "AM_E" #name;
        AM_ERRNO_MAP(AM_ERRNO_NAME)
#undef AM_ERRNO_NAME
    }
    return "AM_E?";
}

const char *am_version(void)
{
    return PACKAGE_VERSION;
}
