/*
 * am_control.h -- bodies of libam's control messages (frames with
 * PR_FLAG_CONTROL; the header's handler field is the type below).
 *
 * Encoders append to a pr_buf, decoders read from a pr_reader positioned
 * after the frame header and require the body to be consumed exactly
 * (pr_reader_finish). Decoded strings and payloads are views into the
 * message: valid while the message is. Layouts: runtime/CONTROL.md.
 */
#ifndef AM_CONTROL_H
#define AM_CONTROL_H

#include <stddef.h>
#include <stdint.h>

#include "pr.h"

/* The control types: the header's handler field of a control frame. The
 * numbers are the wire format (runtime/CONTROL.md); what a PE does with
 * each type, and its name in the statistics, is declared by the module
 * that handles it (the dispatch table, am_int.h). */
enum am__ctl_type {
    AM__CTL_HELLO = 1,      /* rank > 0 -> 0 at boot */
    AM__CTL_TABLE = 2,      /* 0 -> all: endpoint table */
    AM__CTL_PEER_HELLO = 3, /* higher -> lower rank at boot */
    AM__CTL_BYE = 4,        /* finalize: goodbye */
    AM__CTL_PING = 5,       /* liveness probe */
    AM__CTL_TOKEN = 6,      /* termination token */
    AM__CTL_TERMINATE = 7,  /* 0 -> all: termination declared */
    AM__CTL_COLL_UP = 8,    /* child -> parent contribution */
    AM__CTL_COLL_DOWN = 9,  /* parent -> child result */
    AM__CTL_GATHER = 10,    /* blob -> rank 0 */
    AM__CTL_RPC_REQ = 11,   /* am_call request */
    AM__CTL_RPC_REP = 12,   /* am_call reply */
    AM__CTL_ABORT = 13,     /* a PE saw a peer fail; it exits */
    AM__CTL_CREDIT = 14,    /* receiver -> sender: window room back */
    AM__CTL_SHM_ON = 15,    /* after boot: later frames come by the ring */
    AM__CTL_SHM_VIA = 16,   /* in a ring: the next frame comes by ZeroMQ */
    AM__CTL_COUNT           /* one past the highest type */
};

/* Longest endpoint string accepted in a message. */
#define AM__EP_MAX 1024
/* Most PEs a table may list. */
#define AM__PE_MAX 65536
/* Most values in one reduction message. */
#define AM__COLL_MAX_N (1u << 24)

typedef struct am__str {
    const uint8_t *p; /* not NUL-terminated */
    size_t len;
} am__str;

/* Longest hello message (proto's pr_hello, envelope included) accepted in
 * a HELLO or PEER_HELLO body; version 1's is 20 bytes. */
#define AM__HELLO_MAX 64

/* HELLO: proto's hello message (versions, job, rank, size), which every
 * protocol version lays out the same way, then the sender's endpoint. */
typedef struct am__hello {
    pr_hello id;
    am__str endpoint;
} am__hello;

void am__hello_put(pr_buf *b, const am__hello *m);
int am__hello_get(pr_reader *r, am__hello *m);

/* TABLE: job, then size endpoint strings. ep[i] is read into eps[i] by the
 * decoder, which allocates nothing: eps is the caller's array of max
 * entries, and a table of more than max (or of none) is refused. *size is
 * the count on success and 0 otherwise. */
void am__table_put(pr_buf *b, uint64_t job, uint32_t size,
                   char *const *endpoints);
int am__table_get(pr_reader *r, uint64_t *job, uint32_t max, uint32_t *size,
                  am__str *eps);

/* PEER_HELLO: proto's hello message only. */
typedef struct am__peer_hello {
    pr_hello id;
} am__peer_hello;

void am__peer_hello_put(pr_buf *b, const am__peer_hello *m);
int am__peer_hello_get(pr_reader *r, am__peer_hello *m);

typedef struct am__token {
    uint64_t epoch;
    int64_t q;
    uint8_t black;
} am__token;

void am__token_put(pr_buf *b, const am__token *m);
int am__token_get(pr_reader *r, am__token *m);

void am__terminate_put(pr_buf *b, uint64_t epoch);
int am__terminate_get(pr_reader *r, uint64_t *epoch);

/* COLL_UP and COLL_DOWN: a vector of n 8-byte values (f64 bit patterns or
 * i64), or none for a barrier. values is a view of 8n bytes. */
typedef struct am__coll_msg {
    uint64_t seq;
    uint8_t kind; /* enum am__coll_kind */
    uint8_t op;   /* am_op_t */
    uint32_t n;
    const uint8_t *values;
} am__coll_msg;

void am__coll_put(pr_buf *b, const am__coll_msg *m);
int am__coll_get(pr_reader *r, am__coll_msg *m);

typedef struct am__gather_msg {
    uint64_t seq;
    am__str blob;
} am__gather_msg;

void am__gather_put(pr_buf *b, const am__gather_msg *m);
int am__gather_get(pr_reader *r, am__gather_msg *m);

/* RPC_REQ: call id, user handler id, then the request payload to the end
 * of the frame. RPC_REP: call id, then the reply payload. */
typedef struct am__rpc_msg {
    uint64_t call_id;
    uint16_t handler; /* RPC_REQ only */
    am__str payload;
} am__rpc_msg;

void am__rpc_req_put(pr_buf *b, uint64_t call_id, uint16_t handler,
                     const void *data, size_t len);
int am__rpc_req_get(pr_reader *r, am__rpc_msg *m);
void am__rpc_rep_put(pr_buf *b, uint64_t call_id, const void *data,
                     size_t len);
int am__rpc_rep_get(pr_reader *r, am__rpc_msg *m);

/* ABORT: the PE that failed (or UINT32_MAX if none in particular) and
 * the sender's one-line reason. */
#define AM__REASON_MAX 512
typedef struct am__abort_msg {
    uint32_t culprit;
    am__str reason;
} am__abort_msg;

void am__abort_put(pr_buf *b, const am__abort_msg *m);
int am__abort_get(pr_reader *r, am__abort_msg *m);

/* CREDIT: bytes of the sender's window the receiver hands back (at least
 * 1, at most AM__CREDIT_MAX). */
#define AM__CREDIT_MAX ((uint64_t)1 << 40)
void am__credit_put(pr_buf *b, uint64_t bytes);
int am__credit_get(pr_reader *r, uint64_t *bytes);

/* BYE and PING have empty bodies. */
int am__empty_get(pr_reader *r);

/* ---------------------------------------------------------------- bundles */

/* A ZeroMQ message between PEs carries one frame or a bundle: several
 * frames to the same PE back to back, in the order they were sent
 * (CONTROL.md, "Bundles"). A sender bundles only frames of at most
 * AM__BUNDLE_FRAME_MAX bytes (larger ones go alone, without a copy), and
 * at most AM__BUNDLE_MAX bytes in all; a receiver takes any bundle that
 * fits ZeroMQ's message size limit, and checks each frame as it checks a
 * lone one. */
#define AM__BUNDLE_FRAME_MAX 8192
#define AM__BUNDLE_MAX 65536

/* The length of the frame at the start of msg[0..len): the header size
 * plus the payload length its header states, if a whole header is there
 * and the frame ends within len; 0 otherwise. Reads the length field only
 * (the frame is validated whole afterwards, like a lone frame), so that a
 * receiver can cut a bundle into frames. */
size_t am__bundle_next(const uint8_t *msg, size_t len);

#endif /* AM_CONTROL_H */
