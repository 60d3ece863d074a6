/*
 * am_int.h -- libam internals shared by the runtime's modules.
 *
 * Module map (one job each; internal names carry the module's word):
 *   am_ctx.c        init/finalize, options and environment, fatal errors
 *   am_boot.c       finding rank 0, hello exchange, endpoint table
 *   am_transport.c  the ROUTER socket, sending, send queues, receiving,
 *                   frame validation, peer failure detection
 *   am_flow.c       flow control: send windows, credits, waiting senders,
 *                   the queue of callback sends
 *   am_loop.c       libevent integration, am_poll, idle blocking, drive
 *                   loops, am_run_until_done
 *   am_thread.c     coroutines, stack pool; am_switch_x86_64.S fast switch
 *   am_future.c     futures, conditions, wait queues
 *   am_timer.c      timers, am_sleep
 *   am_term.c       Safra's termination detection
 *   am_coll.c       barrier, allreduce, gather
 *   am_rpc.c        am_call / am_reply
 *   am_stats.c      time accounting, counters, JSON
 *   am_latency.c    latency/bandwidth specs, delayed delivery
 *   am_control.c    bodies of the runtime's control messages
 *   am_launch.c     am-run / pdr run launcher and rendezvous server
 *   am_keys.c       the job's CURVE keys: reading and writing key blocks
 *   am_zap.c        the ZAP handler admitting only the job's CURVE keys
 *   am_shm.c        same-host rings between PEs, read and written by the
 *                   PEs themselves (no ZeroMQ I/O thread in the path)
 *
 * Control frames reach the module that handles them through one dispatch
 * table (section "control dispatch" below), and every send, of any kind,
 * is counted in one place: count_send in am_transport.c.
 */
#ifndef AM_INT_H
#define AM_INT_H

#include <event2/event.h>
#include <stdarg.h>
#include <stdint.h>
#include <ucontext.h>
#include <zmq.h>

#include "am.h"
#include "am_control.h"
#include "pr.h"

#if defined(__SANITIZE_ADDRESS__)
#define AM_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define AM_ASAN 1
#endif
#endif

/* ------------------------------------------------------------ small tools */

/* Seconds on CLOCK_MONOTONIC (about 20 ns a call on this hardware). */
double am__now(void);

/* Writes prefix, the formatted message and a newline to fd in one write
 * call (cut to 1 KiB), so that lines of several processes sharing fd never
 * interleave. */
void am__vline(int fd, const char *prefix, const char *fmt, va_list ap);

/* Prints "am: PE r: " and the message to stderr (diagnostics that are not
 * fatal errors: rejected frames, launch problems). */
void am__warn(const am_ctx_t *ctx, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));

/* Records a fatal error (first one wins), calls the error handler and, if
 * it returns, leaves ctx failed. Returns code. */
int am__fail(am_ctx_t *ctx, int code, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* ------------------------------------------------------------------ frames */

/* A received or outgoing frame (header + payload in one ZeroMQ message)
 * while it waits in one of the runtime's FIFOs: the per-peer send queue,
 * the per-peer latency queue, the loopback queue, the boot stash or the
 * deferred queue. */
typedef struct am__frame {
    struct am__frame *next;
    zmq_msg_t msg;  /* the whole frame; owned by the node */
    pr_header hdr;  /* decoded header */
    int src;        /* sender rank */
    double due;     /* latency queue: delivery time (am__now clock) */
    int refused;    /* send queue: ZeroMQ refused it once (counted in
                       queued_sends) */
    size_t off;     /* send queue, ring peers: bytes already in the ring */
    int via_zmq;    /* send queue, ring peers: a large frame that goes by
                       ZeroMQ (announced by the SHM_VIA before it) */
} am__frame;

typedef struct am__fifo {
    am__frame *head, *tail;
    size_t n;
} am__fifo;

/* A wait queue of threads or the main context (am_future.c). */
typedef struct am__waiter am__waiter;
typedef struct am__waitq {
    am__waiter *head, *tail;
} am__waitq;

void am__fifo_push(am__fifo *q, am__frame *f);
am__frame *am__fifo_pop(am__fifo *q);
/* Frees every node (closing its message). */
void am__fifo_clear(am__fifo *q);
am__frame *am__frame_new(void);
void am__frame_free(am__frame *f);

/* ------------------------------------------------------------------- peers */

/* Invariants: send_seq is the sequence number of the next frame to this
 * peer, recv_seq the one expected next from it (frames arrive in order on
 * one ZeroMQ pipe; a lower number is a duplicate and is refused). While
 * sendq is not empty every new frame to the peer is appended to it, so
 * frames never overtake each other. sendq holds the frames ZeroMQ could
 * not take yet and, while the PE runs with coalescing on, the frames sent
 * since the last flush (am__flush_sendq), which leave bundled; sendq_bytes
 * is their size, and in_sendq_peers says the peer is listed in the
 * context's sendq_peers. delayq is ordered by due time, which
 * never decreases along the queue (per-sender order is kept under random
 * latency); delay_ev is armed for the head whenever delayq is not empty.
 *
 * Flow control (am_flow.c), for basic frames (user AMs, RPC requests and
 * replies) only: win_used is the cost of the frames sent to the peer that
 * it has not handed back with CREDIT (for this PE itself: not yet
 * dispatched from the loopback queue). A frame enters the window only if
 * heldq is empty and the window has room, so frames leave in the order
 * they were sent. heldq holds callback sends waiting for room, held_bytes
 * their cost (at most the queue bound); their sequence numbers are given
 * when they leave heldq. roomq holds the threads and the main context
 * waiting for room. On the receiving side, consumed is the cost of this
 * peer's frames dispatched here since the last CREDIT to it. */
typedef struct am__peer {
    am_ctx_t *ctx;          /* back pointer for libevent callbacks */
    char *endpoint;         /* where it listens; owned */
    uint64_t send_seq;      /* next outgoing sequence number */
    uint64_t recv_seq;      /* next expected incoming sequence number */
    am__fifo sendq;         /* frames not yet handed to ZeroMQ */
    size_t sendq_bytes;     /* their size */
    int in_sendq_peers;     /* listed in ctx->sendq_peers */
    am__fifo delayq;        /* latency injection: not yet delivered */
    struct event *delay_ev; /* timer for delayq's head */
    int delay_armed;
    double link_free_at;    /* bandwidth emulation: link busy until */
    double last_due;        /* due time of the last frame queued */
    int hello;              /* boot: its hello arrived */
    int said_bye;           /* it finalized normally */
    int connected_to;       /* we connected to it (lower rank) */
    int suspect;            /* a disconnect may be this peer's */
    double suspect_since;
    int judged;             /* probed in the current am__check_peers */
    size_t win_used;        /* flow: bytes in flight to it, uncredited */
    size_t held_bytes;      /* flow: bytes waiting in heldq */
    am__fifo heldq;         /* flow: callback sends waiting for room */
    am__waitq roomq;        /* flow: senders waiting for room */
    size_t consumed;        /* flow: its bytes dispatched, not credited */
} am__peer;

/* Reasons a frame is rejected (counted in statistics). */
#define AM__REJECT_MAP(X)                                                    \
    X(PARTS, "wrong number of message parts")                                \
    X(IDENTITY, "unknown routing id")                                        \
    X(TRUNC, "shorter than the header")                                      \
    X(MAGIC, "bad magic")                                                    \
    X(VERSION, "other protocol version")                                     \
    X(FLAGS, "unknown flags")                                                \
    X(LENGTH, "payload length does not match the frame")                     \
    X(SENDER, "sender field differs from the routing id")                    \
    X(SEQ, "duplicate or out-of-order sequence number")                      \
    X(HANDLER, "no handler registered")                                      \
    X(BODY, "malformed control message")                                     \
    X(LATE, "message from a PE that said goodbye")

enum am__reject {
#define AM__REJ_ENUM(name, msg) AM__REJ_##name,
    AM__REJECT_MAP(AM__REJ_ENUM)
#undef AM__REJ_ENUM
    AM__REJ_COUNT
};

/* --------------------------------------------------------------- threads */

typedef struct am__stack {
    struct am__stack *next; /* free list */
    void *map;              /* mmap'd region, guard page first */
    size_t map_size;
    void *lo;               /* lowest usable byte (above the guard) */
    size_t size;            /* usable bytes */
} am__stack;

enum am__tstate { AM__T_RUNNABLE, AM__T_RUNNING, AM__T_BLOCKED, AM__T_DONE };

typedef struct am__thread am__thread;

/* A waiter in a future's or condition's queue. Threads put it on their own
 * stack (valid while they are blocked); the main context on its stack. */
struct am__waiter {
    struct am__waiter *next;
    am__thread *thread; /* NULL: the main context is waiting */
    int woken;
};

/* Invariants: a thread is in exactly one of: the run queue (RUNNABLE),
 * running (RUNNING, sched.current), a wait queue or a timer (BLOCKED), or
 * finished (DONE, its stack back in the pool). Only the scheduler (the main
 * context, inside am_run_threads) switches into a thread, and a thread
 * always switches back to the scheduler, never directly to another. */
struct am__thread {
    am__thread *next;       /* run queue or free list */
    am__thread *all_next;   /* every thread struct ever made, for cleanup */
    am_ctx_t *ctx;
    int state;              /* enum am__tstate */
    am_thread_fn fn;
    void *arg;
    am_future_t *done;      /* set when fn returns, may be NULL */
    am__stack *stack;
    void *sp;               /* fast switch: saved stack pointer */
    ucontext_t uc;          /* made by makecontext; ucontext switch */
    uintptr_t boot_frame[8];/* fast switch: first frame (see am_thread.c) */
    uintptr_t boot_regs[5]; /* rip, rsp, rdi, rsi, rbx from makecontext */
    struct event *sleep_ev; /* am_sleep's timer, made on first use */
    void *asan_fake_stack;  /* AddressSanitizer fiber bookkeeping */
};

typedef struct am__sched {
    int mode;               /* AM_SWITCH_UCONTEXT or AM_SWITCH_FAST */
    am__thread *current;    /* running thread, NULL in the main context */
    am__thread *runq_head, *runq_tail;
    size_t runq_n;
    size_t live;            /* threads not DONE */
    ucontext_t main_uc;     /* ucontext switch: the scheduler's context */
    void *main_sp;          /* fast switch: the scheduler's stack pointer */
    am__stack *free_stacks; /* pool */
    size_t nfree_stacks;
    am__thread *free_threads;
    am__thread *all;        /* list through all_next */
    size_t stack_size;      /* usable bytes per stack */
    size_t page;
    const void *main_stack_bottom; /* AddressSanitizer: main stack */
    size_t main_stack_size;
    void *main_fake_stack;
    uint64_t spawned, switches;
} am__sched;

/* ------------------------------------------------------- futures, timers */

struct am_future_s {
    am_ctx_t *ctx;
    void *value;
    int set;
    am__waitq waiters;
};

struct am_cond_s {
    am_ctx_t *ctx;
    am__waitq waiters;
};

struct am_timer_s {
    am_ctx_t *ctx;
    struct event *ev;
    am_timer_fn fn;
    void *arg;
    int armed;
    int in_callback; /* its callback is running */
    int free_later;  /* am_timer_free was called from the callback */
};

/* ------------------------------------------------------------ termination */

/* Safra's algorithm (EWD998). count = basic messages sent minus basic
 * messages delivered by this PE, over the whole run; black = a basic
 * message was delivered since this PE last passed the token. Basic
 * messages are user AMs and RPC requests/replies; control messages are not
 * counted. The token travels 0 -> 1 -> ... -> P-1 -> 0 and is held by a
 * PE until that PE is passive. */
typedef struct am__term {
    int64_t count;
    int black;
    int have_token;       /* this PE holds the token */
    int64_t tok_q;        /* its accumulated count */
    int tok_black;
    int probing;          /* rank 0: a token is travelling */
    uint64_t epoch;       /* terminations completed on this PE */
    int declared;         /* TERMINATE for the current epoch arrived */
    int defer;            /* hold basic messages back (after TERMINATE) */
    int passive;          /* last reported state */
} am__term;

/* ------------------------------------------------------------ collectives */

enum am__coll_kind { AM__COLL_BARRIER = 0, AM__COLL_F64 = 1, AM__COLL_I64 = 2,
                     AM__COLL_GATHER = 3 };

/* One collective operation, identified by its sequence number (every PE
 * numbers its collectives 1, 2, ...). Contributions of children in the
 * binary tree (children of r are 2r+1 and 2r+2) may arrive before this PE
 * enters the operation; they wait here, and are combined in a fixed order
 * (own, left, right) so that sums do not depend on arrival order. */
typedef struct am__coll {
    struct am__coll *next;
    uint64_t seq;
    int kind;
    int op;
    uint32_t n;          /* values per vector */
    uint8_t *child[2];   /* children's vectors (8n bytes each), owned */
    int child_got[2];
    uint8_t *result;     /* down phase: the result (8n bytes), owned */
    int result_got;
    void **blobs;        /* gather at rank 0: one per rank, owned */
    size_t *blens;
    int blobs_got;
    am__waiter waiter;   /* a thread of this PE waiting in it */
    int has_waiter;
} am__coll;

/* ------------------------------------------------------------------- RPC */

typedef struct am__call {
    struct am__call *next;
    uint64_t id;
    am__waiter w;
    void *reply;
    size_t reply_len;
    int done;
} am__call;

#define AM__CALL_BUCKETS 64

/* ------------------------------------------------------------- statistics */

typedef struct am__hstat {
    uint64_t sent, sent_bytes, recv, recv_bytes;
    double seconds; /* running the handler */
} am__hstat;

typedef struct am__handler {
    am_handler_fn fn;
    void *arg;
    char *name; /* owned, may be NULL */
    am__hstat st;
} am__handler;

#define AM__CAT_MAX 64

typedef struct am__category {
    char *name;        /* owned */
    double total;      /* closed spans */
    double open_since; /* valid while depth > 0 */
    int depth;
    int64_t begins;
    int64_t counter;
} am__category;

/* ---------------------------------------------------------------- latency */

typedef struct am__latency {
    int on;
    double lo, hi;     /* seconds; uniform in [lo, hi] */
    double bw;         /* bytes per second, 0 = unlimited */
    uint64_t rng;      /* xorshift state */
    char spec[64];     /* as given, for statistics */
    char bw_spec[64];
} am__latency;

/* ------------------------------------------------------- control dispatch */

/* Each module declares the control types it handles as a list of entries
 * (am__boot_ctls, am__term_ctls, ...); am_init gathers them into the
 * context's table, indexed by type, and checks that every type of
 * am_control.h is claimed by exactly one module. The transport decodes a
 * frame's header, looks its type up, and calls the entry: it knows no
 * subsystem by name, and a new control type is one enum value in
 * am_control.h plus one entry in the module that handles it. */

/* Handles a control frame from PE src. body is positioned after the header;
 * what is decoded from it stays valid during the call. The handler checks
 * the body itself and rejects one it cannot use (am__reject). */
typedef void (*am__ctl_fn)(am_ctx_t *ctx, int src, pr_reader *body);

/* What the transport needs to know about a type besides its handler. */
enum am__ctl_flags {
    /* Handled during start-up. Frames of other types that arrive then wait
     * in the boot stash until start-up is over. */
    AM__CTLF_BOOT = 1u << 0,
    /* A basic message of the termination detection (am_term.c): counted
     * when sent (by the transport) and when delivered (by its handler),
     * and held back once termination was declared. */
    AM__CTLF_BASIC = 1u << 1,
    /* Handled as soon as it is read: never held in the boot stash, the
     * injected-latency queue or the deferred queue (ABORT: a PE must learn
     * which peer failed before it judges the disconnects that follow). */
    AM__CTLF_URGENT = 1u << 2
};

typedef struct am__ctl_entry {
    unsigned type;    /* enum am__ctl_type; 0 ends a module's list */
    const char *name; /* its key in the statistics file, e.g. "hello" */
    unsigned flags;   /* enum am__ctl_flags */
    am__ctl_fn fn;
} am__ctl_entry;

/* ------------------------------------------------------------- the context */

enum am__boot_state { AM__BOOTING, AM__RUNNING, AM__CLOSING };

struct am_ctx_s {
    int rank, size;
    int state;             /* enum am__boot_state */
    int failed;            /* first fatal error code, 0 if none */
    int culprit;           /* the PE the failure is about: -1 this one,
                              -2 unknown (an ABORT that names none) */
    int report_fd;         /* AM_REPORT_FD: failure line to the launcher */
    char errmsg[256];
    am_error_fn on_error;
    void *on_error_arg;

    /* options, resolved */
    size_t stack_size;
    int switch_mode;
    double boot_timeout;
    double heartbeat;
    unsigned poll_budget;
    int hwm;
    size_t send_window;    /* flow control bounds, bytes (am_flow.c) */
    size_t send_queue;
    char *stats_dir;
    char *transport;       /* "ipc" or "tcp" */
    char *ipc_dir;
    int shm_enabled;       /* AM_SHM: same-host rings (am_shm.c) */
    size_t shm_ring;       /* AM_SHM_RING: bytes per ring, 0 = automatic */
    int oversubscribed;    /* more PEs on this host than its processors */
    size_t shm_big;        /* AM_SHM_BIG: frames of this many bytes or
                              more to a ring peer go by ZeroMQ (0: none) */
    char *bind_addr;
    char *root_ep;
    char *rendezvous;
    uint64_t job;
    /* CURVE (tcp): this PE's key pair, the public key of every PE (rank
     * order) and of the tcp rendezvous; all NULL if CURVE is off. */
    struct am__keys *keys;
    struct am__zap *zap;   /* ZAP handler admitting the job's keys */
    uint64_t hs_failed;    /* failed handshakes the monitor reported */
    int hs_warned;         /* ... of accepted connections, logged once */
    int hs_stranger;       /* the last monitor event was the failed
                              handshake of an accepted connection */
    unsigned char *hs_peer_warned; /* per PE: a failed handshake with it
                              was logged (size entries, CURVE only) */
    char **overrides;      /* "AM_NAME=VALUE" from --am-name=value args */
    int noverrides;
    char *rdv_file;        /* rank 0: rendezvous file it wrote */
    int boot_table;        /* boot: the endpoint table arrived */

    /* transport */
    void *zctx;            /* ZeroMQ context (NULL for a one-PE job) */
    void *sock;            /* the ROUTER */
    void *mon;             /* PAIR receiving the socket's monitor events */
    int zfd;               /* ZMQ_FD of sock */
    int events_stale;      /* a send may have eaten a ZMQ_FD edge since
                              the socket was last seen empty */
    int aborting;          /* telling peers about a failure */
    am__peer *peers;       /* size entries */
    size_t sendq_total;    /* frames in all send queues */
    int *sendq_peers;      /* the peers whose send queue may hold frames
                              (size entries, nsendq_peers used), so that a
                              flush does not scan every peer of a big job */
    int nsendq_peers;
    int coalesce;          /* AM_COALESCE: frames wait in the send queues
                              until the next flush and leave bundled */
    struct am__shm *shm;   /* same-host rings, NULL if none (am_shm.c) */
    double zmq_next;       /* am_poll: when to read ZeroMQ next while every
                              peer's frames come through rings */
    size_t held_total;     /* frames in all heldq (flow control) */
    am__fifo loopback;     /* frames sent to this PE */
    am__fifo early;        /* non-boot frames received while booting */
    am__fifo deferred;     /* basic frames held back after TERMINATE */
    int suspects;          /* peers with suspect set */
    double next_housekeeping;
    uint64_t rejected[AM__REJ_COUNT];
    int warned[AM__REJ_COUNT];

    /* loop */
    struct event_base *base;
    struct event *zmq_ev;  /* persistent read on ZMQ_FD */
    struct event *mon_ev;  /* persistent read on the monitor's fd */
    struct event *wake_ev; /* am_idle's time limit */
    int in_callback;       /* depth of handler/timer callbacks running */
    int timers_armed;      /* libevent timers armed (all kinds) */
    int user_timers_armed; /* am_timer timers and sleeps: keep PE active */
    uint64_t delivered;    /* messages + timers delivered, for am_poll */

    am__sched sched;
    am__term term;

    uint64_t coll_seq;     /* last collective started here */
    am__coll *colls;
    int coll_busy;         /* a collective is in progress on this PE */
    double coll_deadline;  /* main-context collectives give up then (0: no) */

    uint64_t next_call_id;
    am__call *calls[AM__CALL_BUCKETS];

    am__handler handlers[AM_HANDLER_MAX];
    /* The dispatch table: type -> the entry its module declared (NULL
     * for type 0). Filled by am_init, read-only afterwards. */
    const am__ctl_entry *ctl[AM__CTL_COUNT];
    am__hstat ctl_st[AM__CTL_COUNT];
    am__hstat rpc_reply_st;
    am__category cats[AM__CAT_MAX];
    int ncats;
    am_stats_t st;         /* runtime counters (times filled on read) */
    double t_init;

    am__latency lat;
};

/* ------------------------------------------------------------ CURVE keys */

/* The CURVE keys of one PE of a job (am_keys.c; format in CONTROL.md,
 * "CURVE and ZAP"). Z85 strings of 40 characters, NUL-terminated. */
typedef struct am__keys {
    int n;                  /* job size: entries of pub */
    char (*pub)[41];        /* every PE's public key, rank order */
    char secret[41];        /* this PE's secret key */
    char public_[41];       /* this PE's public key (= pub[rank]) */
    char rdv[41];           /* the tcp rendezvous' public key, "" if none */
} am__keys;

/* Reads a key block for PE rank of a job of size PEs from spec: "fd:N"
 * (a descriptor, read to the block's end; closed unless N <= 2) or the
 * path of a file that only its owner may read. Checks that every public
 * key is there and that the secret key belongs to pub[rank]. On error
 * prints why (am__warn) and returns AM_EINVAL or AM_ENOMEM. The caller
 * owns *out (am__keys_free). */
int am__keys_read(const am_ctx_t *ctx, const char *spec, int rank, int size,
                  double timeout, am__keys **out);
/* One key pair shared by every PE (AM_CURVE_SERVER_PUBLIC/SECRET). */
int am__keys_shared(const char *pub, const char *sec, int size, am__keys **out);
void am__keys_free(am__keys **k);
/* Appends the key block of PE rank to *buf (malloc'd, *len bytes):
 * every public key, rank's secret (every secret if rank < 0), and the
 * rendezvous key if rdv is not NULL. Returns 0 or AM_ENOMEM. */
int am__keys_format(char (*pub)[41], char (*sec)[41], int n, int rank,
                    const char *rdv, char **buf, size_t *len);

/* am_zap.c: a ZAP handler thread in zctx admitting CURVE clients whose
 * public key is one of keys[0..n-1] (Z85); the user id of an admitted
 * client is its index, or empty if the key appears twice. Refusals are
 * counted and logged once per address with prefix ("am: PE 3: ") and
 * naming what is protected ("this PE"). Must be started before the
 * server sockets bind and stopped after they are closed. */
typedef struct am__zap am__zap;
int am__zap_start(void *zctx, const char (*keys)[41], int n,
                  const char *prefix, const char *what, am__zap **out);
/* Stops the thread and frees; sets *z to NULL. */
void am__zap_stop(am__zap **z);
uint64_t am__zap_refused(am__zap *z);   /* clients refused */
uint64_t am__zap_strangers(am__zap *z); /* distinct addresses refused */

/* ------------------------------------------------- cross-module internals */

/* am_ctx.c */
/* getenv with --am-name=value overrides; NULL if unset or empty. */
const char *am__env(const am_ctx_t *ctx, const char *name);
/* BYE. */
extern const am__ctl_entry am__ctx_ctls[];

/* am_boot.c: connects the PEs; returns 0 or a code (diagnostic printed). */
int am__boot(am_ctx_t *ctx);
/* HELLO, TABLE and PEER_HELLO. */
extern const am__ctl_entry am__boot_ctls[];

/* am_transport.c */
int am__transport_open(am_ctx_t *ctx);   /* socket, options, bind */
void am__transport_close(am_ctx_t *ctx);
int am__connect_peer(am_ctx_t *ctx, int pe);
/* Encodes the routing id of rank into out[5]. */
void am__routing_id(int rank, uint8_t out[5]);
/* PING and ABORT (failure detection). */
extern const am__ctl_entry am__transport_ctls[];
/* Builds a control frame from body (encoded with a PR_HEADER_SIZE gap in
 * front, see am__ctl_begin) and sends it. Resets body. */
int am__send_ctl(am_ctx_t *ctx, int pe, unsigned type, pr_buf *body);
/* What a control frame carries for the user, for the statistics: an RPC
 * request carries a message for a user handler (its id, below
 * AM_HANDLER_MAX), an RPC reply carries AM__USER_REPLY. */
#define AM__USER_REPLY ((unsigned)AM_HANDLER_MAX)
/* As am__send_ctl, for a control frame that carries a user message of
 * user_len bytes: it is counted under user (handler or reply counters) as
 * well as under its control type. */
int am__send_ctl_carrying(am_ctx_t *ctx, int pe, unsigned type, pr_buf *body,
                          unsigned user, size_t user_len);
/* Starts a control body: leaves room for the header. */
void am__ctl_begin(pr_buf *body);
/* Receives up to budget frames (rings, then ZeroMQ); returns how many
 * were taken (>= 0). */
int am__recv_some(am_ctx_t *ctx, unsigned budget);
/* The same for am_poll: ZeroMQ is read only every ZMQ_GAP while all the
 * peers' frames come through rings. */
int am__recv_poll(am_ctx_t *ctx, unsigned budget);
/* 1 if ZeroMQ says a frame is waiting (re-reads ZMQ_EVENTS). */
int am__socket_readable(am_ctx_t *ctx);
/* Hands every peer's queued frames to ZeroMQ (bundled, with coalescing
 * on) until ZeroMQ would block; returns 0 or a fatal code. The flush
 * points of send coalescing: am_poll, each round of am_run_until_done, and
 * every path on which the PE may wait (am_idle, am_flush, finalize, the
 * failure exit; the blocking calls drive the loop). */
int am__flush_sendq(am_ctx_t *ctx);
/* Reads socket monitor events and probes suspected peers. */
void am__check_peers(am_ctx_t *ctx);
/* Reads socket monitor events only (counts failed handshakes; while
 * booting, disconnects are not judged). */
void am__read_monitor(am_ctx_t *ctx);
/* Validates a received frame (identity part and body); fills *src, *hdr.
 * Returns 0 or the reason (enum am__reject) + 1. Exposed for unit tests. */
int am__frame_check(const am_ctx_t *ctx, const void *id, size_t id_len,
                    const void *frame, size_t len, int *src, pr_header *hdr);
/* A peer failed: tells the other PEs (ABORT), then fails with AM_EPEER
 * and the message why. */
int am__peer_failed(am_ctx_t *ctx, int pe, const char *why);
/* Counts a rejected frame; warns once per reason. */
void am__reject(am_ctx_t *ctx, int reason, int src, const char *detail);
/* Frame passed validation (and latency): delivers or defers it. */
void am__arrive(am_ctx_t *ctx, am__frame *f);
/* Runs the handler of a user frame, or the dispatch table's handler of a
 * control frame. */
void am__dispatch(am_ctx_t *ctx, am__frame *f);
/* Delivers a user message to its handler; call_id 0 for plain AMs. */
void am__deliver_user(am_ctx_t *ctx, int src, unsigned id, const void *data,
                      size_t len, uint64_t call_id);

/* am_loop.c */
int am__loop_init(am_ctx_t *ctx);
/* Adds the socket's and the monitor's fds to libevent. */
int am__loop_watch(am_ctx_t *ctx);
void am__loop_free(am_ctx_t *ctx);
/* Drives the loop (poll, threads, idle) until *flag != 0 or ctx fails. */
int am__drive(am_ctx_t *ctx, const int *flag);
/* 0 if a blocking call may proceed in the caller's context, AM_ESTATE
 * from a callback, or the context's failure code. */
int am__may_block(const am_ctx_t *ctx);
/* Something is runnable or deliverable without waiting. */
int am__has_ready_work(const am_ctx_t *ctx);

/* am_thread.c */
int am__sched_init(am_ctx_t *ctx);
void am__sched_free(am_ctx_t *ctx);
/* Blocks the running thread (state already BLOCKED, queued somewhere) and
 * switches to the scheduler; returns when it runs again. */
void am__thread_block(am_ctx_t *ctx);
/* Makes a blocked thread runnable (appends to the run queue). */
void am__thread_wake(am_ctx_t *ctx, am__thread *t);

/* am_future.c */
void am__waitq_push(am__waitq *q, am__waiter *w);
void am__waitq_remove(am__waitq *q, am__waiter *w);
/* Wakes one waiter (thread to run queue, main flag set); 0 if none. */
int am__wake_one(am_ctx_t *ctx, am__waitq *q);
/* Waits on w, already queued: blocks the thread or drives the loop. */
int am__wait_on(am_ctx_t *ctx, am__waitq *q, am__waiter *w);

/* am_timer.c */
void am__timer_armed(am_ctx_t *ctx, int user, int delta);

/* am_term.c */
void am__term_on_send(am_ctx_t *ctx);    /* a basic message was sent */
void am__term_on_deliver(am_ctx_t *ctx); /* a basic message was delivered */
/* TOKEN and TERMINATE. */
extern const am__ctl_entry am__term_ctls[];
/* One detection step: reports passivity, moves the token. Returns 1 when
 * termination was declared for the current epoch. */
int am__term_step(am_ctx_t *ctx, int passive);

/* am_coll.c */
/* COLL_UP, COLL_DOWN and GATHER. */
extern const am__ctl_entry am__coll_ctls[];
void am__coll_free_all(am_ctx_t *ctx);

/* am_rpc.c */
/* RPC_REQ and RPC_REP. */
extern const am__ctl_entry am__rpc_ctls[];

/* am_flow.c */
/* Parses a byte count ("4194304", "4M", "64k", "1G"). */
int am__bytes_parse(const char *spec, size_t *out);
/* Before a basic frame of size bytes (header included) goes to pe: 0 if it
 * may go now (its cost is in the window), 1 if it must wait in heldq (a
 * callback's send: the caller queues it with am__flow_hold), or a
 * negative code (AM_EFULL: the queue is full). From a thread or the main
 * context it waits for room first. */
int am__flow_reserve(am_ctx_t *ctx, int pe, size_t size);
/* Gives back a reservation whose frame could not be sent. */
void am__flow_unreserve(am_ctx_t *ctx, int pe, size_t size);
/* Queues a frame in pe's heldq (header h without its seq); takes ownership
 * of msg on success only. */
int am__flow_hold(am_ctx_t *ctx, int pe, const pr_header *h, zmq_msg_t *msg);
/* A basic frame of size bytes from src was dispatched here. */
void am__flow_consumed(am_ctx_t *ctx, int src, size_t size);
/* Waits (bounded, main context) until every held frame left. */
void am__flow_drain(am_ctx_t *ctx, double seconds);
void am__flow_free(am_ctx_t *ctx);
/* CREDIT. */
extern const am__ctl_entry am__flow_ctls[];

/* am_transport.c, for am_flow.c: hands a frame that was held to ZeroMQ,
 * the peer's send queue or the loopback queue, giving it its sequence
 * number (h->seq). Takes ownership of msg on success only. */
int am__hand_over(am_ctx_t *ctx, int pe, pr_header *h, zmq_msg_t *msg);
/* 1 if the frame with this header is a basic message of the termination
 * detection (and so subject to flow control). */
int am__is_basic(const am_ctx_t *ctx, const pr_header *h);

/* am_stats.c */
void am__stats_free(am_ctx_t *ctx);

/* am_shm.c: same-host rings (design and guarantees at the top of the
 * file). All of them are no-ops or answer "no" when ctx->shm is NULL. */
/* Creates this PE's wake socket and incoming rings (before it binds);
 * on failure warns and goes without (returns 0), or AM_ENOMEM. */
int am__shm_open(am_ctx_t *ctx);
void am__shm_close(am_ctx_t *ctx);
/* Adds the wake socket to libevent. */
int am__shm_watch(am_ctx_t *ctx);
/* After boot: maps the rings to the same-host peers and sends each
 * SHM_ON; from then on every frame to such a peer goes to its ring. */
int am__shm_start(am_ctx_t *ctx);
int am__shm_out_on(const am_ctx_t *ctx, int pe); /* frames to pe by ring */
int am__shm_in_on(const am_ctx_t *ctx, int pe);  /* frames from pe by ring */
/* Every peer's frames come through a ring (and no large frame is
 * awaited from ZeroMQ). */
int am__shm_all_in(const am_ctx_t *ctx);
/* Bytes of data in each of this PE's incoming rings, 0 without rings. */
size_t am__shm_ring_bytes(const am_ctx_t *ctx);
/* Whether a frame of n bytes to a ring peer goes by ZeroMQ instead. */
int am__shm_big(const am_ctx_t *ctx, size_t n);
/* Reader: the ring of pe waits for a large frame from ZeroMQ (SHM_VIA);
 * am__shm_resume once it was taken. */
int am__shm_paused(const am_ctx_t *ctx, int pe);
void am__shm_resume(am_ctx_t *ctx, int pe);
/* Reader: a large frame from pe that came by ZeroMQ before its SHM_VIA
 * was read waits here (takes msg; 0 or AM_ENOMEM); am__shm_unstash gives
 * the oldest back in msg (initialized here), 1 if there was one. */
int am__shm_stash(am_ctx_t *ctx, int pe, zmq_msg_t *msg);
int am__shm_unstash(am_ctx_t *ctx, int pe, zmq_msg_t *msg);
/* Writer: free bytes in pe's ring (reads the reader's tail). */
size_t am__shm_room(am_ctx_t *ctx, int pe);
/* Writer: copies up to len bytes into pe's ring; returns how many fit.
 * Not visible to the reader before am__shm_publish. */
size_t am__shm_put(am_ctx_t *ctx, int pe, const void *src, size_t len);
void am__shm_publish(am_ctx_t *ctx, int pe);
/* Reader: 1 and the next whole frame from pe in msg (initialized here),
 * 0 if none is complete yet, -1 if ctx failed. Consumed room goes back
 * to the writer at am__shm_release. */
int am__shm_take(am_ctx_t *ctx, int pe, zmq_msg_t *msg);
void am__shm_release(am_ctx_t *ctx, int pe);
/* Reader: the peer to look at first this time (rotates). */
int am__shm_first(const am_ctx_t *ctx);
/* Before blocking: announces it to the writers and readers concerned;
 * 1 (and nothing announced) if a ring already has frames or room that
 * waiting frames need. am__shm_sleep_end after the block. */
int am__shm_sleep_begin(am_ctx_t *ctx);
void am__shm_sleep_end(am_ctx_t *ctx);
/* The wake socket's fd (-1 if none), and reading its pending bytes. */
int am__shm_fd(const am_ctx_t *ctx);
void am__shm_drain(am_ctx_t *ctx);
/* SHM_ON. */
extern const am__ctl_entry am__shm_ctls[];

/* am_ctx.c: sets this process's scheduling policy to AM_SCHED's value v
 * (other, batch, fifo, rr; fifo and rr at the lowest real-time priority).
 * Returns 0, -1 if v is none of them, or sched_setscheduler's errno, with
 * *hint a text to print after its strerror ("" unless it says why). */
int am__sched_set(const char *v, const char **hint);

/* am_latency.c */
/* Parses "200us", "100us-2ms", "0": seconds in *lo, *hi. */
int am__latency_parse(const char *spec, double *lo, double *hi);
/* Parses "100Mbit", "1Gbit", "12.5MB", "0": bytes per second in *bps. */
int am__bandwidth_parse(const char *spec, double *bps);
int am__latency_init(am_ctx_t *ctx, const char *lat, const char *bw);
/* Queues a received frame for delayed delivery (takes ownership). */
void am__latency_enqueue(am_ctx_t *ctx, am__frame *f);
void am__latency_free(am_ctx_t *ctx);
/* Frames waiting in latency queues (for tests and diagnostics). */
/* Delivers the delayed frames that are due now, outside the event loop
 * (am_finalize's waits, which do not run libevent's timers). */
void am__latency_deliver_due(am_ctx_t *ctx);
size_t am__latency_pending(const am_ctx_t *ctx);

#endif /* AM_INT_H */
