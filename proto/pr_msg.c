/* pr_msg.c -- the message envelope, the hello message and version
 * negotiation (PROTOCOL.md, "Message envelope" and "Hello"). */
#include "config.h"

#include <inttypes.h>
#include <stdio.h>

#include "pr.h"
#include "pr_int.h"

/* ---------------------------------------------------------------- envelope */

const char *pr_msg_name(int t)
{
    switch (t) {
    case PR_MSG_HELLO:
        return "hello";
    case PR_MSG_STATS:
        return "stats";
    case PR_MSG_SUBMESH:
        return "submesh";
    }
    return NULL;
}

void pr_msg_begin(pr_buf *b, uint8_t type)
{
    pr_put_u8(b, type);
}

int pr_msg_type(const void *payload, size_t len)
{
    if (!payload || len == 0)
        return PR_ETRUNC;
    return ((const uint8_t *)payload)[0];
}

int pr_msg_open(pr_reader *r, const void *payload, size_t len, uint8_t type)
{
    uint8_t t;
    pr_reader_init(r, payload, len);
    if (pr_get_u8(r, &t))
        return r->err;
    if (t != type)
        return pr_reader_fail(r, PR_ETYPE);
    return 0;
}

/* ------------------------------------------------------------------- hello */

void pr_hello_init(pr_hello *h, uint64_t job, uint32_t rank, uint32_t size)
{
    h->version = PR_VERSION;
    h->version_min = PR_VERSION_MIN;
    h->version_max = PR_VERSION_MAX;
    h->job = job;
    h->rank = rank;
    h->size = size;
}

/* The rules a hello must follow, shared by encoder and decoder. */
static int hello_valid(const pr_hello *h)
{
    return h->version_min >= 1 && h->version_min <= h->version &&
           h->version <= h->version_max && h->size >= 1 && h->rank < h->size;
}

int pr_hello_put(pr_buf *b, const pr_hello *h)
{
    if (b->err)
        return b->err;
    if (!hello_valid(h))
        return pr__buf_fail(b, PR_EINVAL);
    pr_msg_begin(b, PR_MSG_HELLO);
    pr_put_u8(b, h->version);
    pr_put_u8(b, h->version_min);
    pr_put_u8(b, h->version_max);
    pr_put_u64(b, h->job);
    pr_put_u32(b, h->rank);
    pr_put_u32(b, h->size);
    return b->err;
}

int pr_hello_decode(pr_hello *h, const void *payload, size_t len)
{
    pr_reader r;
    *h = (pr_hello){0};
    pr_msg_open(&r, payload, len, PR_MSG_HELLO);
    pr_get_u8(&r, &h->version);
    pr_get_u8(&r, &h->version_min);
    pr_get_u8(&r, &h->version_max);
    pr_get_u64(&r, &h->job);
    pr_get_u32(&r, &h->rank);
    pr_get_u32(&r, &h->size);
    int rc = pr_reader_finish(&r);
    if (rc == 0 && !hello_valid(h))
        rc = PR_EDATA;
    if (rc)
        *h = (pr_hello){0};
    return rc;
}

/* snprintf into an optional buffer. */
#define SAY(...)                                                             \
    do {                                                                     \
        if (msg && msgsize)                                                  \
            snprintf(msg, msgsize, __VA_ARGS__);                             \
    } while (0)

int pr_negotiate(const pr_hello *local, const pr_hello *remote,
                 uint8_t *version, char *msg, size_t msgsize)
{
    *version = 0;
    if (msg && msgsize)
        msg[0] = '\0';
    if (!hello_valid(local)) {
        SAY("this PE's own hello is invalid (versions %u <= %u <= %u, "
            "rank %" PRIu32 " of %" PRIu32 ")",
            local->version_min, local->version, local->version_max,
            local->rank, local->size);
        return PR_EINVAL;
    }
    if (!hello_valid(remote)) {
        SAY("a peer sent an invalid hello (versions %u <= %u <= %u, "
            "rank %" PRIu32 " of %" PRIu32 ")",
            remote->version_min, remote->version, remote->version_max,
            remote->rank, remote->size);
        return PR_EDATA;
    }
    /* Job identity first: a stray peer from another job is a more useful
     * diagnosis than the version it happens to speak. */
    if (remote->job != local->job) {
        SAY("rank %" PRIu32 " belongs to job %016" PRIx64
            ", this PE to job %016" PRIx64
            ": a PE of another job connected (stale process or reused "
            "endpoint?)",
            remote->rank, remote->job, local->job);
        return PR_EJOB;
    }
    if (remote->size != local->size) {
        SAY("rank %" PRIu32 " says the job has %" PRIu32
            " PEs, this PE says %" PRIu32,
            remote->rank, remote->size, local->size);
        return PR_EJOB;
    }
    if (remote->rank == local->rank) {
        SAY("a peer claims rank %" PRIu32
            ", which is this PE's own rank: two PEs were given the same rank",
            remote->rank);
        return PR_EJOB;
    }
    uint8_t lo = local->version_min > remote->version_min ? local->version_min
                                                          : remote->version_min;
    uint8_t hi = local->version_max < remote->version_max ? local->version_max
                                                          : remote->version_max;
    if (lo > hi) {
        SAY("rank %" PRIu32 " speaks protocol versions %u..%u, this PE "
            "(rank %" PRIu32 ") speaks %u..%u: run the same pdr release on "
            "every host",
            remote->rank, remote->version_min, remote->version_max,
            local->rank, local->version_min, local->version_max);
        return PR_EVERSION;
    }
    *version = hi;
    return 0;
}
