/*
 * am.h -- libam, the active-message runtime of pdr.
 *
 * A job is P processing elements (PEs), one OS process each, ranks 0..P-1.
 * PEs talk only through active messages (AMs): one-sided asynchronous calls
 * of a handler that runs on the receiving PE when that PE polls. On top of
 * AMs the library offers cooperative threads (ucontext coroutines), futures
 * and conditions, an RPC helper for threads, timers, distributed termination
 * detection (Safra's token algorithm), collectives and time accounting. The
 * runtime knows nothing about meshes; see DESIGN.md section 2.
 *
 * Conventions
 *  - Every function that can fail returns 0 (or a count) or a negative AM_E*
 *    code; am_strerror() names each code. Strings returned by the library
 *    are owned by it.
 *  - One context per PE: am_init() creates an am_ctx_t that every call takes.
 *    There are no hidden globals, so a test can run several one-PE contexts
 *    in one process.
 *  - If a call that takes a callback fails, the callback is never called.
 *  - Every allocation goes through proto's hook (proto/pr_alloc.h), which
 *    in the installed library is the C library's malloc; a failed one is
 *    AM_ENOMEM.
 *  - The runtime is single-threaded: call it from the thread that called
 *    am_init(). ("Threads" below are the runtime's cooperative coroutines,
 *    which all run on that OS thread, one at a time.)
 *  - Three kinds of code run on a PE: the main program ("main context"),
 *    callbacks (AM handlers and timer callbacks, run by the runtime from the
 *    main context while it polls; they must not block), and cooperative
 *    threads. Blocking calls (am_wait, am_cond_wait, am_sleep, collectives)
 *    suspend the calling thread; from the main context they drive the loop
 *    (poll, run threads, block in libevent) until done; from a callback they
 *    fail with AM_ESTATE.
 *  - Fatal conditions after start-up (a peer went away) go to the error
 *    handler (am_set_error_handler). The default handler prints
 *    "am: PE <rank>: <message>" and exits with status 1, like MPI's default
 *    MPI_ERRORS_ARE_FATAL. During am_init they make it return the code
 *    (AM_EPROTO for a peer speaking another protocol version, with a
 *    message naming both versions on stderr).
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
    X(SYS, -10, "system call failed (see errno)")                            \
    X(FULL, -11, "the send queue to that PE is full (flow control)")

enum am_errno {
#define AM_ERRNO_ENUM(name, value, msg) AM_E##name = (value),
    AM_ERRNO_MAP(AM_ERRNO_ENUM)
#undef AM_ERRNO_ENUM
};

/* ------------------------------------------------------ types and limits */

typedef struct am_ctx_s am_ctx_t;       /* one PE's runtime */
typedef struct am_future_s am_future_t; /* single-assignment value */
typedef struct am_cond_s am_cond_t;     /* condition (wait queue) */
typedef struct am_timer_s am_timer_t;   /* one-shot timer */

/* User handler ids are 0..AM_HANDLER_MAX-1. */
#define AM_HANDLER_MAX 1024

/* Bytes a zero-copy buffer must reserve before its payload for the frame
 * header (see am_send_zc). Equal to the wire header size. */
#define AM_HEADROOM 24

/* Largest payload of one message (1 GiB, the wire format's limit). */
#define AM_MAX_PAYLOAD ((size_t)1 << 30)

/* Flow control (see am_send): what a message of len payload bytes counts
 * against the send window and the handler queue is len + AM_MSG_OVERHEAD
 * (the frame header and the runtime's and ZeroMQ's bookkeeping), so that a
 * flood of empty messages is bounded too. */
#define AM_MSG_OVERHEAD 88

/* Default bounds of flow control (am_opts_t.send_window, .send_queue). */
#define AM_SEND_WINDOW_DEFAULT ((size_t)4 << 20)
#define AM_SEND_QUEUE_DEFAULT ((size_t)64 << 20)

/* A received message, as seen by its handler. data is owned by the runtime
 * and valid only until the handler returns: copy what you keep. */
typedef struct am_msg {
    int src;          /* rank of the sender */
    unsigned handler; /* handler id it was sent to */
    const void *data; /* payload (NULL when len == 0) */
    size_t len;       /* payload length in bytes */
    uint64_t call_id; /* nonzero if sent by am_call(): answer with am_reply */
} am_msg_t;

/* Thread switch implementations (am_opts_t.switch_mode). */
enum am_switch_mode {
    AM_SWITCH_DEFAULT = 0,  /* the configure-time choice (fast if built) */
    AM_SWITCH_UCONTEXT = 1, /* glibc swapcontext (saves the signal mask) */
    AM_SWITCH_FAST = 2      /* register-only switch; AM_EINVAL if not built */
};

/* Reduction operators of am_allreduce_*(). */
typedef enum am_op { AM_SUM = 0, AM_MIN = 1, AM_MAX = 2 } am_op_t;

/* Options of am_init(). Zero-initialise (AM_OPTS_INIT), then set what you
 * need: a zero field means "from the environment, else the default". Fields
 * may be added at the end in later versions. Environment variables (set by
 * am-run) and --am-NAME=VALUE arguments are described in am_init(). */
typedef struct am_opts {
    size_t stack_size;    /* bytes per thread stack; default 64 KiB (256 KiB
                             under AddressSanitizer) */
    int switch_mode;      /* enum am_switch_mode */
    const char *latency;  /* injected latency, e.g. "200us", "100us-2ms" */
    const char *bandwidth;/* injected bandwidth cap, e.g. "100Mbit" */
    double boot_timeout;  /* seconds to wait for all PEs at start (60) */
    double heartbeat;     /* seconds without a sign of life before a peer
                             is declared dead (3.0); 0 = default */
    const char *stats_dir;/* if set, am_finalize writes stats-<rank>.json */
    unsigned poll_budget; /* max frames taken from the socket per am_poll
                             (256) */
    size_t send_window;   /* bytes of messages in flight to one PE before
                             its senders wait (AM_SEND_WINDOW_DEFAULT); every
                             PE of a job must use the same value */
    size_t send_queue;    /* bytes of handler sends that may wait for one
                             PE's window before am_send says AM_EFULL
                             (AM_SEND_QUEUE_DEFAULT; 0 is allowed) */
} am_opts_t;

#define AM_OPTS_INIT {0, 0, NULL, NULL, 0.0, 0.0, NULL, 0, 0, 0}

/* Runtime-wide counters of one PE (am_stats_get). Times in seconds. */
typedef struct am_stats {
    double wall_s;        /* since am_init */
    double poll_s;        /* inside am_poll, excluding callbacks */
    double poll_excess_s; /* part of poll_s in polls that delivered nothing */
    double idle_s;        /* blocked in libevent with nothing to do */
    double handler_s;     /* running AM handlers and timer callbacks */
    uint64_t polls;       /* am_poll calls */
    uint64_t polls_empty; /* of which delivered nothing */
    uint64_t msgs_sent, bytes_sent; /* user AMs (incl. RPC), payload bytes */
    uint64_t msgs_recv, bytes_recv;
    uint64_t ctl_sent, ctl_recv;    /* runtime control frames */
    uint64_t rejected;    /* malformed or unexpected frames dropped */
    uint64_t queued_sends;/* sends that had to wait in the local queue */
    uint64_t threads_spawned, thread_switches;
    uint64_t send_waits;  /* thread and main-context sends that waited for
                             room in a send window */
    double send_wait_s;   /* time they waited */
    uint64_t held_sends;  /* callback sends queued for a full window */
    uint64_t credits_recv;/* window credits received from the peers */
    uint64_t bundles_sent;/* ZeroMQ messages that carried several frames
                             (send coalescing) */
    uint64_t bundled_sent;/* frames sent in them */
    uint64_t bundles_recv, bundled_recv; /* the same, received */
} am_stats_t;

/* -------------------------------------------------------- callback types */

/* An AM handler. Runs in the main context of the receiving PE while it
 * polls; must not block (spawn a thread for work that waits). arg is the
 * pointer given to am_register. */
typedef void (*am_handler_fn)(am_ctx_t *ctx, const am_msg_t *msg, void *arg);

/* Body of a cooperative thread. */
typedef void (*am_thread_fn)(am_ctx_t *ctx, void *arg);

/* Timer callback; runs in the main context like a handler. */
typedef void (*am_timer_fn)(am_ctx_t *ctx, am_timer_t *timer, void *arg);

/* Frees a zero-copy send buffer. May be called from a ZeroMQ I/O thread,
 * so it must be thread-safe (free() is). frame is the pointer given to
 * am_send_zc (the start of the headroom). */
typedef void (*am_free_fn)(void *frame, void *hint);

/* "Start new work" step of am_run_until_done: start at most one unit of
 * work (typically spawn a thread). Return 1 if it started something, 0 if
 * it has nothing to start, or a negative code to stop the loop with that
 * code. Work must only appear through messages, threads or timers: once it
 * returned 0 and no thread or timer is alive, it must keep returning 0
 * until a message arrives. */
typedef int (*am_work_fn)(am_ctx_t *ctx, void *arg);

/* Fatal-error handler (am_set_error_handler). code is AM_EPEER, AM_EPROTO
 * or AM_ETRANSPORT; msg a complete sentence naming the PE concerned. */
typedef void (*am_error_fn)(am_ctx_t *ctx, int code, const char *msg,
                            void *arg);

/* --------------------------------------------------- errors and version */

/* Returns a static message for code; never NULL (unknown codes get a
 * generic message). */
AM_EXPORT const char *am_strerror(int code);

/* Returns the symbolic name of code ("AM_EINVAL"), or "AM_E?" if unknown. */
AM_EXPORT const char *am_errname(int code);

/* Version of the library actually linked, as "MAJOR.MINOR.PATCH"; static. */
AM_EXPORT const char *am_version(void);

/* ------------------------------------------------------ context and job */

/* Starts this PE and connects it with the others; returns 0 and *out, or a
 * negative code (with a diagnostic on stderr) and *out == NULL.
 *
 * argc/argv may be NULL; otherwise arguments "--am-NAME=VALUE" are taken
 * out of argv and read like the environment variable AM_NAME (upper case).
 * opts may be NULL (all defaults).
 *
 * Where rank and size come from, first match wins: AM_RANK/AM_SIZE (am-run,
 * pdr run); OMPI_COMM_WORLD_RANK/SIZE (Open MPI); PMI_RANK/PMI_SIZE (MPICH,
 * Intel MPI); SLURM_PROCID/SLURM_NTASKS (srun); otherwise a one-PE job.
 * Other variables: AM_TRANSPORT=ipc|tcp (tcp by default, ipc if AM_IPC_DIR
 * is set), AM_IPC_DIR (directory for ipc sockets), AM_BIND (address to bind
 * and advertise for tcp, default 127.0.0.1), AM_ROOT (rank 0's endpoint),
 * AM_RENDEZVOUS (file:PATH on a shared file system, or tcp://HOST:PORT of
 * an am-run rendezvous server) to publish and find rank 0's endpoint when
 * AM_ROOT is not given, AM_JOB (job id; PEs of other jobs are refused),
 * AM_LATENCY, AM_BANDWIDTH, AM_SCHED (the PE's scheduling policy: other,
 * batch, fifo or rr; fifo and rr need root or CAP_SYS_NICE, and am_init
 * fails without), AM_STATS_DIR, AM_STACK_SIZE, AM_SWITCH
 * (ucontext|fast), AM_BOOT_TIMEOUT, AM_HEARTBEAT (seconds), AM_HWM (ZeroMQ
 * high-water mark, default 0 = unlimited: the send windows bound memory),
 * AM_SEND_WINDOW and AM_SEND_QUEUE (bytes, suffix k, M or G for powers of
 * 1024; see am_send), AM_SHM (1, the default: with ipc, frames go through
 * shared-memory rings once the job started, under any scheduling policy;
 * 0: over ZeroMQ; 2 is taken as 1), AM_SHM_RING
 * and AM_SHM_BIG (bytes per ring; frames from this size go over ZeroMQ;
 * runtime/CONTROL.md, "Same-host rings"), AM_CURVE_KEYS (tcp: the job's CURVE keys, made by
 * am-run, as "fd:N" or the path of a file only its owner can read: only
 * the job's PEs can connect; AM_CURVE_SERVER_PUBLIC/SECRET, one key pair
 * shared by every PE, are still accepted; protocol notes:
 * runtime/CONTROL.md, "CURVE and ZAP"). opts fields, when set,
 * win over the environment. The caller owns *out (am_finalize). */
AM_EXPORT int am_init(int *argc, char ***argv, const am_opts_t *opts,
                      am_ctx_t **out);

/* Collective: waits (bounded) until every PE reached am_finalize, says
 * goodbye to the peers, writes stats if a stats directory was given, closes
 * everything and frees *ctx; sets *ctx to NULL. Returns the first error
 * met, 0 otherwise. No thread may be alive. */
AM_EXPORT int am_finalize(am_ctx_t **ctx);

AM_EXPORT int am_rank(const am_ctx_t *ctx);
AM_EXPORT int am_size(const am_ctx_t *ctx);

/* The endpoint PE pe listens on ("ipc://..." or "tcp://..."), owned by ctx;
 * NULL if pe is out of range or the job has one PE. */
AM_EXPORT const char *am_endpoint(const am_ctx_t *ctx, int pe);

/* PE pe's CURVE public key (40 Z85 characters), or with pe =
 * AM_CURVE_RENDEZVOUS the key of the launcher's tcp rendezvous; owned by
 * ctx. NULL when CURVE is off (ipc, am-run --no-curve), for a rendezvous
 * without a key, or if pe is out of range. Public keys are not secrets:
 * they let a peer check whom it talks to (runtime/CONTROL.md). */
#define AM_CURVE_RENDEZVOUS (-1)
AM_EXPORT const char *am_curve_key(const am_ctx_t *ctx, int pe);

/* Replaces the fatal-error handler (NULL restores the default). A handler
 * that returns leaves the context failed: later calls return the error
 * code, blocking calls of the main context return it; threads that are
 * blocked stay blocked, so the program should finalize and exit. */
AM_EXPORT void am_set_error_handler(am_ctx_t *ctx, am_error_fn fn, void *arg);

/* Message of the first fatal error, or "" if none; owned by ctx. */
AM_EXPORT const char *am_last_error(const am_ctx_t *ctx);

/* ------------------------------------------------------ active messages */

/* Registers fn for handler id (0 <= id < AM_HANDLER_MAX) on this PE; name
 * (copied; may be NULL) labels the handler in statistics. Register every
 * handler right after am_init, before any PE can send to it: messages that
 * arrive for an unregistered id are dropped and counted as rejected. A
 * second registration of the same id replaces the first. */
AM_EXPORT int am_register(am_ctx_t *ctx, unsigned id, const char *name,
                          am_handler_fn fn, void *arg);

/* Sends len bytes of data to handler id on PE pe (which may be this PE).
 * Copies data: the caller keeps ownership and may reuse the buffer at
 * once. One-sided and asynchronous: it never waits for the receiver to run
 * the handler. Messages from one PE to another arrive in the order sent.
 *
 * Flow control. Each PE may have at most a window of send_window bytes
 * (AM_SEND_WINDOW, default 4 MiB; a message counts len + AM_MSG_OVERHEAD)
 * in flight to each PE: sent, and not yet run by the receiver's handler.
 * The receiver hands the room back as its handlers run (CREDIT frames,
 * runtime/CONTROL.md). A message goes out at once if the window has room
 * for it, or if at most half the window is in use (so one message of any
 * size can go), and no earlier message to that PE waits. Otherwise:
 *  - from a thread, am_send blocks that thread (the PE polls, delivers and
 *    runs other threads meanwhile) until there is room;
 *  - from the main context, it drives the loop like am_wait until there is
 *    room (handlers and threads run meanwhile);
 *  - from a callback (handler or timer), which must not block, the message
 *    is queued for the window if the PE's queued callback sends to pe stay
 *    within send_queue bytes (AM_SEND_QUEUE, default 64 MiB); otherwise
 *    nothing is sent and am_send returns AM_EFULL. Queued messages go out
 *    in order, before any later message to pe.
 * So a receiver holds at most (P-1) windows of messages from the others,
 * and a sender at most a window and a queue per destination, plus one
 * message per blocked thread. A PE that stops polling makes its senders
 * wait; this cannot deadlock, because handlers never wait and every PE
 * keeps receiving while its threads wait. The same applies to
 * am_send_zc, am_send_buf, am_call (requests) and am_reply/am_reply_to
 * (replies).
 *
 * Coalescing. A message to another PE is handed to the network at the
 * PE's next flush point: am_poll, am_idle before it blocks, the end of each
 * round of am_run_until_done, am_flush, any blocking call (they drive the
 * loop), any collective (its messages take the waiting ones along),
 * am_finalize. Messages
 * to the same PE that wait together travel in one network message
 * (runtime/CONTROL.md, "Bundles"), which costs the system calls and
 * thread wake-ups of one. A program that sends and then computes for long
 * without polling calls am_flush first. AM_COALESCE=0 sends every message
 * at once, alone. */
AM_EXPORT int am_send(am_ctx_t *ctx, int pe, unsigned id, const void *data,
                      size_t len);

/* Zero-copy send (flow control as am_send). frame points to AM_HEADROOM
 * bytes that the runtime overwrites with the header, followed by len bytes
 * of payload. On success
 * the runtime takes ownership of frame and calls ffn(frame, hint) when it
 * is done with it (possibly from another OS thread, see am_free_fn); ffn
 * may be NULL for memory that outlives the job. On failure ffn is never
 * called and the caller keeps ownership. */
AM_EXPORT int am_send_zc(am_ctx_t *ctx, int pe, unsigned id, void *frame,
                         size_t len, am_free_fn ffn, void *hint);

/* Allocates a zero-copy buffer and returns a pointer to its len-byte
 * payload area (headroom reserved before it), or NULL. Caller owns it
 * until am_send_buf succeeds, or releases it with am_buf_free. */
AM_EXPORT void *am_buf_alloc(size_t len);
AM_EXPORT void am_buf_free(void *payload);

/* Sends a buffer from am_buf_alloc without copying; takes ownership of
 * payload on success only. */
AM_EXPORT int am_send_buf(am_ctx_t *ctx, int pe, unsigned id, void *payload,
                          size_t len);

/* Hands every message waiting for a flush point (see am_send,
 * "Coalescing") to the network now, bundled per destination. Never
 * blocks; callable from anywhere, callbacks and threads included. Returns
 * 0 or the context's failure code. */
AM_EXPORT int am_flush(am_ctx_t *ctx);

/* --------------------------------------------------------------- the loop */

/* One non-blocking poll: takes waiting frames from the network (at most
 * poll_budget), delivers messages whose injected latency has elapsed, runs
 * their handlers and due timer callbacks, flushes the send queue. Returns
 * the number of messages and timers delivered (0 if none), or a negative
 * code. Main context only. */
AM_EXPORT int am_poll(am_ctx_t *ctx);

/* Yields to the runnable threads: each thread that is runnable when the
 * call starts runs once, until it yields, blocks or ends. Returns how many
 * ran. Main context only. */
AM_EXPORT int am_run_threads(am_ctx_t *ctx);

/* Blocks in libevent until a frame arrives, a timer is due, or max_seconds
 * pass (max_seconds < 0: no limit; it may still return after a quarter of
 * a second, so call it in a loop), counting the time as idle. Returns at
 * once if a message or thread is already waiting. Main context only. */
AM_EXPORT int am_idle(am_ctx_t *ctx, double max_seconds);

/* Termination detection for a hand-written loop: call once per loop
 * iteration with passive != 0 when this PE has no work of its own (the
 * paper's |Q| = 0 and |L| = 0). The runtime adds its own conditions (no
 * live thread, no armed timer, nothing waiting for delivery). Returns 1
 * once all PEs are passive and no message is in flight (then all PEs
 * return 1 in the same round, after a barrier, and no user handler runs on
 * this PE between the detection and the return), 0 otherwise, or a
 * negative code. Detection may run again afterwards (a new epoch).
 * Main context only. */
AM_EXPORT int am_quiescent(am_ctx_t *ctx, int passive);

/* The paper's loop (Fig. 7): repeat { poll the network; yield to runnable
 * threads; start new work with work(ctx, arg); if nothing is runnable and
 * all PEs are done, return 0 }. When nothing is runnable and there is no
 * new work, the PE blocks in libevent on the socket and timers instead of
 * spinning. While work keeps being started, a poll that found nothing is
 * followed by the next one only 20 us later (not every time round). work
 * may be NULL. Returns 0, a negative code from work, or a
 * runtime error. Main context only. */
AM_EXPORT int am_run_until_done(am_ctx_t *ctx, am_work_fn work, void *arg);

/* ---------------------------------------------------------------- threads */

/* Starts a cooperative thread running fn(ctx, arg); it first runs at the
 * next am_run_threads (or the loop's yield step). If done is not NULL, the
 * runtime sets it (value NULL) when fn returns: that is how to join. The
 * thread's stack comes from a pool of mmap'd stacks with a guard page below
 * (overflow is a SIGSEGV, never silent corruption). */
AM_EXPORT int am_thread_spawn(am_ctx_t *ctx, am_thread_fn fn, void *arg,
                              am_future_t *done);

/* From a thread: goes to the back of the run queue and lets others run.
 * From the main context: same as am_run_threads. */
AM_EXPORT int am_yield(am_ctx_t *ctx);

/* 1 if the caller runs in a cooperative thread, 0 otherwise. */
AM_EXPORT int am_in_thread(const am_ctx_t *ctx);

/* Number of live threads (runnable, running or blocked). */
AM_EXPORT size_t am_thread_count(const am_ctx_t *ctx);

/* ------------------------------------------------ futures and conditions */

/* A future holds one value (a pointer) set once. Caller owns *out. */
AM_EXPORT int am_future_new(am_ctx_t *ctx, am_future_t **out);
/* Frees *f and sets it to NULL. Nothing may be waiting on it. */
AM_EXPORT void am_future_free(am_future_t **f);
/* Sets the value and makes every waiter runnable; AM_ESTATE if already
 * set. The future does not own value. */
AM_EXPORT int am_future_set(am_future_t *f, void *value);
AM_EXPORT int am_future_ready(const am_future_t *f);
/* The value set, or NULL if not set. */
AM_EXPORT void *am_future_value(const am_future_t *f);
/* Makes f unset again, for reuse; AM_ESTATE if something waits on it. */
AM_EXPORT int am_future_reset(am_future_t *f);
/* Waits until f is set (see "Blocking calls" at the top). */
AM_EXPORT int am_wait(am_ctx_t *ctx, am_future_t *f);

AM_EXPORT int am_cond_new(am_ctx_t *ctx, am_cond_t **out);
AM_EXPORT void am_cond_free(am_cond_t **c);
/* Waits until signalled. Mesa semantics: re-check your predicate. */
AM_EXPORT int am_cond_wait(am_ctx_t *ctx, am_cond_t *c);
/* Wakes the longest waiter / all waiters. */
AM_EXPORT int am_cond_signal(am_cond_t *c);
AM_EXPORT int am_cond_broadcast(am_cond_t *c);

/* -------------------------------------------------------------------- RPC */

/* Sends req to handler id on PE pe as a call and suspends the calling
 * thread (only; other threads and the PE go on) until the reply arrives.
 * On success *reply is a malloc'd copy of the reply payload (caller frees
 * it with free(), or pr_free() in a program that links proto's allocation
 * hook itself, as pdr does; NULL if the reply is empty) and *reply_len its
 * length.
 * Only from a thread (AM_ESTATE otherwise). */
AM_EXPORT int am_call(am_ctx_t *ctx, int pe, unsigned id, const void *req,
                      size_t len, void **reply, size_t *reply_len);

/* Answers a call from within its handler (msg->call_id != 0). Copies
 * data. AM_EINVAL if msg is not a call; AM_EFULL if the reply does not fit
 * in the send queue to the caller (flow control, see am_send): the call is
 * then still unanswered. */
AM_EXPORT int am_reply(am_ctx_t *ctx, const am_msg_t *msg, const void *data,
                       size_t len);

/* Answers later (e.g. from a thread the handler spawned): pass the src and
 * call_id the handler saw. Each call must be answered exactly once. */
AM_EXPORT int am_reply_to(am_ctx_t *ctx, int pe, uint64_t call_id,
                          const void *data, size_t len);

/* ----------------------------------------------------------------- timers */

/* A one-shot timer; fn runs in the main context when it fires (never
 * early; libevent's precise timers give microsecond resolution). An armed
 * timer keeps this PE active for termination detection. Caller owns *out
 * (am_timer_free). */
AM_EXPORT int am_timer_new(am_ctx_t *ctx, am_timer_fn fn, void *arg,
                           am_timer_t **out);
/* Arms (or re-arms) t to fire after seconds (>= 0). */
AM_EXPORT int am_timer_start(am_timer_t *t, double seconds);
/* Disarms t; fn will not run. No effect if not armed. */
AM_EXPORT int am_timer_stop(am_timer_t *t);
/* Stops and frees *t, sets it to NULL. Allowed from t's own callback. */
AM_EXPORT void am_timer_free(am_timer_t **t);

/* Suspends the calling thread for seconds without blocking the PE (a
 * libevent timer wakes it). From the main context it drives the loop for
 * that long. */
AM_EXPORT int am_sleep(am_ctx_t *ctx, double seconds);

/* ------------------------------------------------------------ collectives */

/* Collectives must be called by every PE, in the same order, one at a time
 * per PE (like MPI on one communicator); from the main context or a
 * thread. They use runtime control messages, which termination detection
 * does not count. */
AM_EXPORT int am_barrier(am_ctx_t *ctx);

/* Element-wise reduction of n values over all PEs; every PE gets the
 * result in out (in and out may be the same array). */
AM_EXPORT int am_allreduce_f64(am_ctx_t *ctx, const double *in, double *out,
                               size_t n, am_op_t op);
AM_EXPORT int am_allreduce_i64(am_ctx_t *ctx, const int64_t *in, int64_t *out,
                               size_t n, am_op_t op);

/* Gathers a blob of len bytes from every PE to rank 0. On rank 0, *all is
 * a malloc'd concatenation in rank order and *lens a malloc'd array of P
 * lengths (caller frees both, as am_call's reply); on other ranks both are
 * set to NULL. */
AM_EXPORT int am_gather(am_ctx_t *ctx, const void *data, size_t len,
                        void **all, size_t **lens);

/* ------------------------------------------------------- time accounting */

/* Named categories of wall-clock time (e.g. "completed", "masked",
 * "setback"). Returns the category's id (>= 0; the same name gives the
 * same id) or a negative code. At most 64 categories. */
AM_EXPORT int am_category(am_ctx_t *ctx, const char *name);

/* Opens/closes category cat. Categories are independent and may overlap;
 * begin/end pairs on one category nest (several threads may hold it open):
 * a category accumulates the wall time during which it is open at least
 * once, and counts its begin calls. Unbalanced ends are ignored. An
 * outermost begin or end reads the monotonic clock once; nested ones do
 * not read it. */
AM_EXPORT void am_time_begin(am_ctx_t *ctx, int cat);
AM_EXPORT void am_time_end(am_ctx_t *ctx, int cat);

/* Adds n to the counter of category cat (for counts such as setbacks). */
AM_EXPORT void am_count(am_ctx_t *ctx, int cat, int64_t n);

/* Seconds accumulated in cat so far (including a currently open span). */
AM_EXPORT double am_time_total(am_ctx_t *ctx, int cat);

/* Fills *out with this PE's runtime counters. */
AM_EXPORT void am_stats_get(am_ctx_t *ctx, am_stats_t *out);

/* Writes this PE's statistics as JSON to path (atomically: a temporary
 * file renamed into place). Layout in runtime/CONTROL.md. */
AM_EXPORT int am_stats_write_json(am_ctx_t *ctx, const char *path);

/* --------------------------------------------------------------- launcher */

/* The am-run launcher, also run by 'pdr run': parses "[OPTIONS] --
 * PROGRAM ARGS" (argv[0] is the command name; prog names it in messages,
 * e.g. "am-run" or "pdr run"), starts the PEs, waits for them and returns
 * the exit status for the launcher process: 0, the first failing PE's
 * status (128+N for a PE killed by signal N), or 2 for a usage error.
 * Try 'am-run --help'. */
AM_EXPORT int am_launch_main(int argc, char **argv, const char *prog);

/* Creates the directory path and any missing directory above it, as
 * 'mkdir -p' does (mode 0777 less the umask), for a --stats directory;
 * one that exists already is fine, also when another process makes it
 * at the same time. Returns 0 when path names a directory afterwards,
 * else -1 with errno set (ENOTDIR when a component is a file,
 * ENAMETOOLONG past PATH_MAX bytes). */
AM_EXPORT int am_mkdir_p(const char *path);

#ifdef __cplusplus
}
#endif
#endif /* AM_H */
