/* am_ctx.c -- the PE context: am_init (options, environment, rank and size
 * from the launcher), am_finalize, fatal errors and small accessors. */
#include "config.h"

#include <ctype.h>
#include <sched.h>
#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "pr_alloc.h"
#include "am_int.h"

#define DEFAULT_STACK (64 * 1024)
#define DEFAULT_STACK_ASAN (256 * 1024)
#define DEFAULT_BOOT_TIMEOUT 60.0
#define DEFAULT_HEARTBEAT 3.0
#define DEFAULT_POLL_BUDGET 256

double am__now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

void am__vline(int fd, const char *prefix, const char *fmt, va_list ap)
{
    /* One write per line: PEs share the launcher's stderr, and a line
     * written in pieces (prefix, message, newline) can be cut by another
     * PE's line. A line longer than the buffer is cut, not split. */
    char line[1024];
    size_t n = 0;
    int k = snprintf(line, sizeof line - 1, "%s", prefix);
    if (k > 0)
        n = (size_t)k < sizeof line - 1 ? (size_t)k : sizeof line - 2;
    k = vsnprintf(line + n, sizeof line - 1 - n, fmt, ap);
    if (k > 0)
        n += (size_t)k < sizeof line - 1 - n ? (size_t)k : sizeof line - 2 - n;
    line[n++] = '\n';
    for (size_t off = 0; off < n;) {
        ssize_t w = write(fd, line + off, n - off);
        if (w < 0 && errno == EINTR)
            continue;
        if (w <= 0)
            break;
        off += (size_t)w;
    }
}

void am__warn(const am_ctx_t *ctx, const char *fmt, ...)
{
    char prefix[32] = "am: ";
    if (ctx && ctx->size > 0)
        snprintf(prefix, sizeof prefix, "am: PE %d: ", ctx->rank);
    va_list ap;
    va_start(ap, fmt);
    am__vline(2, prefix, fmt, ap);
    va_end(ap);
}

/* Tells the launcher (AM_REPORT_FD) which PE this failure is about, in one
 * write of one line, before the PE exits: the launcher names that PE, not
 * the first PE it happens to see exit (CONTROL.md, "Failure report"). */
static void report_failure(const am_ctx_t *ctx)
{
    if (ctx->report_fd < 0)
        return;
    char line[64];
    int culprit = ctx->culprit == -1 ? ctx->rank : ctx->culprit;
    int n = snprintf(line, sizeof line, "FAIL %d %d %d\n", ctx->rank,
                     culprit >= 0 ? culprit : -1, ctx->failed);
    ssize_t w;
    do
        w = write(ctx->report_fd, line, (size_t)n);
    while (w < 0 && errno == EINTR);
}

int am__fail(am_ctx_t *ctx, int code, const char *fmt, ...)
{
    if (ctx->failed)
        return ctx->failed;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(ctx->errmsg, sizeof ctx->errmsg, fmt, ap);
    va_end(ap);
    ctx->failed = code;
    report_failure(ctx);
    /* While am_init runs there is no handler to call yet: am_init prints
     * and returns the code. */
    if (ctx->state == AM__BOOTING) {
        am__warn(ctx, "%s", ctx->errmsg);
        return code;
    }
    if (ctx->on_error) {
        ctx->on_error(ctx, code, ctx->errmsg, ctx->on_error_arg);
        return code;
    }
    am__warn(ctx, "%s", ctx->errmsg);
    fflush(NULL);
    /* Give queued frames (the ABORTs to the other PEs) time to leave, then
     * stop: like MPI_ERRORS_ARE_FATAL. _exit, not exit: ZeroMQ's threads
     * and half-done collectives make atexit handlers a risk, not a help. */
    if (ctx->sock) {
        /* Frames still in the runtime's own queues (ABORTs to peers whose
         * pipes were full) are handed to ZeroMQ first; a peer that left
         * meanwhile is skipped (AM__CLOSING). */
        ctx->state = AM__CLOSING;
        double end = am__now() + 0.5;
        while (ctx->sendq_total && am__now() < end && !am__flush_sendq(ctx) &&
               ctx->sendq_total) {
            zmq_pollitem_t it = {ctx->sock, 0, ZMQ_POLLOUT, 0};
            zmq_poll(&it, 1, 10);
        }
        /* The socket is not closed: closing it while peers still send
         * makes libzmq 4.3 abort when a heartbeat falls due during the
         * linger (stream_engine_base.cpp: out_event's !_io_error
         * assertion, seen in tests/am-fault.sh). ZeroMQ's I/O thread
         * writes what is queued while this thread waits, and _exit closes
         * the connections. The monitor stops first, so that its events
         * cannot block that thread. */
        zmq_socket_monitor(ctx->sock, NULL, 0);
        struct timespec ts = {0, 300 * 1000 * 1000};
        while (nanosleep(&ts, &ts) != 0 && errno == EINTR)
            ;
    }
    _exit(1);
}

void am_set_error_handler(am_ctx_t *ctx, am_error_fn fn, void *arg)
{
    if (!ctx)
        return;
    ctx->on_error = fn;
    ctx->on_error_arg = arg;
}

const char *am_last_error(const am_ctx_t *ctx)
{
    return ctx ? ctx->errmsg : "";
}

int am_rank(const am_ctx_t *ctx)
{
    return ctx ? ctx->rank : -1;
}

int am_size(const am_ctx_t *ctx)
{
    return ctx ? ctx->size : 0;
}

const char *am_endpoint(const am_ctx_t *ctx, int pe)
{
    if (!ctx || pe < 0 || pe >= ctx->size || !ctx->peers)
        return NULL;
    return ctx->peers[pe].endpoint;
}

const char *am_curve_key(const am_ctx_t *ctx, int pe)
{
    if (!ctx || !ctx->keys)
        return NULL;
    if (pe == AM_CURVE_RENDEZVOUS)
        return ctx->keys->rdv[0] ? ctx->keys->rdv : NULL;
    return pe >= 0 && pe < ctx->keys->n ? ctx->keys->pub[pe] : NULL;
}

/* ------------------------------------------------------------ environment */

const char *am__env(const am_ctx_t *ctx, const char *name)
{
    size_t n = strlen(name);
    for (int i = ctx->noverrides - 1; i >= 0; i--)
        if (!strncmp(ctx->overrides[i], name, n) && ctx->overrides[i][n] == '=')
            return ctx->overrides[i] + n + 1;
    const char *v = getenv(name);
    return v && *v ? v : NULL;
}

/* Moves --am-NAME=VALUE arguments out of argv into ctx->overrides as
 * AM_NAME=VALUE. */
static int take_args(am_ctx_t *ctx, int *argc, char ***argv)
{
    if (!argc || !argv || !*argv)
        return 0;
    char **av = *argv;
    int out = 1;
    for (int i = 1; i < *argc; i++) {
        const char *a = av[i];
        if (!strcmp(a, "--")) {
            while (i < *argc)
                av[out++] = av[i++];
            break;
        }
        if (strncmp(a, "--am-", 5) || !strchr(a, '=')) {
            av[out++] = av[i];
            continue;
        }
        char **grown = pr_realloc(ctx->overrides,
                               sizeof *grown * (size_t)(ctx->noverrides + 1));
        if (!grown)
            return AM_ENOMEM;
        ctx->overrides = grown;
        char *kv = pr_malloc(strlen(a) + 1);
        if (!kv)
            return AM_ENOMEM;
        size_t k = 0;
        kv[k++] = 'A';
        kv[k++] = 'M';
        kv[k++] = '_';
        const char *p = a + 5;
        for (; *p != '='; p++)
            kv[k++] = *p == '-' ? '_' : (char)toupper((unsigned char)*p);
        strcpy(kv + k, p);
        ctx->overrides[ctx->noverrides++] = kv;
    }
    av[out] = NULL;
    *argc = out;
    return 0;
}

static int parse_long(const char *s, long lo, long hi, long *out)
{
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi)
        return AM_EINVAL;
    *out = v;
    return 0;
}

/* Seconds: "3", "2.5", or with a unit as in latency specs ("500ms"). */
static int parse_seconds(const char *s, double *out)
{
    char *end;
    double v = strtod(s, &end);
    if (end != s && *end == '\0' && v >= 0) {
        *out = v;
        return 0;
    }
    double hi;
    return am__latency_parse(s, out, &hi) || hi != *out ? AM_EINVAL : 0;
}

static int parse_bytes(const char *s, size_t *out)
{
    char *end;
    errno = 0;
    unsigned long long v = strtoull(s, &end, 10);
    if (errno || end == s)
        return AM_EINVAL;
    unsigned long long scale = 1;
    if (!strcmp(end, "k") || !strcmp(end, "K") || !strcmp(end, "KiB"))
        scale = 1024;
    else if (!strcmp(end, "M") || !strcmp(end, "MiB"))
        scale = 1024 * 1024;
    else if (*end)
        return AM_EINVAL;
    if (v > (1ull << 32) / scale)
        return AM_EINVAL;
    *out = (size_t)(v * scale);
    return 0;
}

static const struct {
    const char *rank, *size;
} rank_sources[] = {
    {"AM_RANK", "AM_SIZE"},
    {"OMPI_COMM_WORLD_RANK", "OMPI_COMM_WORLD_SIZE"},
    {"PMI_RANK", "PMI_SIZE"},
    {"SLURM_PROCID", "SLURM_NTASKS"},
};

static int detect_rank(am_ctx_t *ctx)
{
    for (size_t i = 0; i < sizeof rank_sources / sizeof rank_sources[0]; i++) {
        const char *r = am__env(ctx, rank_sources[i].rank);
        if (!r)
            continue;
        const char *s = am__env(ctx, rank_sources[i].size);
        long rank, size;
        if (!s || parse_long(s, 1, AM__PE_MAX, &size) ||
            parse_long(r, 0, size - 1, &rank)) {
            am__warn(NULL, "bad job environment: %s=%s, %s=%s (need 0 <= rank < "
                           "size <= %d)",
                     rank_sources[i].rank, r, rank_sources[i].size,
                     s ? s : "(unset)", AM__PE_MAX);
            return AM_ELAUNCH;
        }
        ctx->rank = (int)rank;
        ctx->size = (int)size;
        return 0;
    }
    ctx->rank = 0;
    ctx->size = 1;
    return 0;
}

static char *dup_or_null(const char *s)
{
    return s ? pr_strdup(s) : NULL;
}

static int bad_option(const am_ctx_t *ctx, const char *name, const char *value,
                      const char *expect)
{
    am__warn(ctx, "bad %s '%s' (expected %s)", name, value, expect);
    return AM_EINVAL;
}

/* AM_SCHED: the operating system's scheduling policy of this PE, set
 * before ZeroMQ starts its I/O thread, which inherits it (and by am-run
 * --sched on the launcher itself). Where PEs outnumber the cores (the
 * paper's latency experiment on one machine), 'fifo' lets each PE run
 * until it waits for something instead of being preempted whenever a
 * message wakes another PE: fewer task switches, and a woken PE runs as
 * soon as the running one waits. */
int am__sched_set(const char *v, const char **hint)
{
    static const struct {
        const char *name;
        int policy;
    } tab[] = {{"other", SCHED_OTHER}, {"batch", SCHED_BATCH}, {"fifo", SCHED_FIFO},
               {"rr", SCHED_RR}};
    *hint = "";
    for (size_t i = 0; i < sizeof tab / sizeof tab[0]; i++) {
        if (strcmp(v, tab[i].name))
            continue;
        int rt = tab[i].policy == SCHED_FIFO || tab[i].policy == SCHED_RR;
        /* The lowest real-time priority: above every ordinary process,
         * below the kernel's own real-time threads. */
        struct sched_param sp = {.sched_priority = rt ? 1 : 0};
        if (sched_setscheduler(0, tab[i].policy, &sp) == 0)
            return 0;
        int err = errno;
        if (err == EPERM)
            *hint = " (fifo and rr need root or CAP_SYS_NICE)";
        return err;
    }
    return -1;
}

static int set_os_sched(const am_ctx_t *ctx, const char *v)
{
    const char *hint;
    int err = am__sched_set(v, &hint);
    if (err < 0)
        return bad_option(ctx, "AM_SCHED", v, "other, batch, fifo or rr");
    if (err) {
        am__warn(ctx, "AM_SCHED=%s: cannot set the scheduling policy: %s%s", v, strerror(err),
                 hint);
        return AM_EINVAL;
    }
    return 0;
}

/* AM_CPU_BIND: whether this PE is bound to one processor. 'core' binds
 * it, with every thread it starts later (ZeroMQ's I/O thread among them),
 * to the AM_CPU_SLOT-th processor (mod their number) of those it may run
 * on; 'none' (am-run's default) leaves it; 'auto' binds when the
 * AM_CPU_SLOTS PEs of its host are exactly as many as those processors
 * (fewer: other jobs may want the rest, and two jobs bound alike would
 * share processors while others idle) and the policy is not fifo or rr
 * (a real-time PE would starve its own I/O thread on its processor). AM_CPU_SLOT and AM_CPU_SLOTS (am-run
 * sets them) are the PE's index among the PEs of its host and their
 * number.
 *
 * Why: with two PEs on two cores and the default policy, each PE's
 * messages wake ZeroMQ's I/O threads, and the kernel moves the four
 * threads between the cores; bound, a PE and its I/O thread take turns
 * on one core. While other work shares the machine that keeps the run
 * steady; on an idle machine it cost about 8% (bench/parallel.md, run
 * 10), hence not the default. */
static int set_cpu_bind(const am_ctx_t *ctx, const char *v, const char *sched)
{
    int core = !strcmp(v, "core"), autob = !strcmp(v, "auto");
    if (!core && !autob && strcmp(v, "none"))
        return bad_option(ctx, "AM_CPU_BIND", v, "auto, core or none");
    if (!core && !autob)
        return 0;
    const char *sv = am__env(ctx, "AM_CPU_SLOT"), *nv = am__env(ctx, "AM_CPU_SLOTS");
    long slot = ctx->rank, slots = ctx->size;
    if (sv && parse_long(sv, 0, AM__PE_MAX, &slot))
        return bad_option(ctx, "AM_CPU_SLOT", sv, "a PE index");
    if (nv && parse_long(nv, 1, AM__PE_MAX, &slots))
        return bad_option(ctx, "AM_CPU_SLOTS", nv, "a count of PEs");
    cpu_set_t set;
    if (sched_getaffinity(0, sizeof set, &set) != 0)
        return 0; /* nothing known to bind to: left as it is */
    int ncpu = CPU_COUNT(&set);
    if (ncpu <= 1)
        return 0;
    if (autob && (slots != ncpu || (sched && (!strcmp(sched, "fifo") || !strcmp(sched, "rr")))))
        return 0;
    long want = slot % ncpu;
    for (int cpu = 0; cpu < CPU_SETSIZE; cpu++) {
        if (!CPU_ISSET(cpu, &set) || want--)
            continue;
        cpu_set_t one;
        CPU_ZERO(&one);
        CPU_SET(cpu, &one);
        if (sched_setaffinity(0, sizeof one, &one) != 0)
            am__warn(ctx, "AM_CPU_BIND=%s: cannot bind to processor %d: %s", v, cpu,
                     strerror(errno));
        break;
    }
    return 0;
}

static int resolve_options(am_ctx_t *ctx, const am_opts_t *o)
{
    static const am_opts_t none = AM_OPTS_INIT;
    if (!o)
        o = &none;
    const char *v;

#ifdef AM_ASAN
    ctx->stack_size = DEFAULT_STACK_ASAN;
#else
    ctx->stack_size = DEFAULT_STACK;
#endif
    if (o->stack_size)
        ctx->stack_size = o->stack_size;
    else if ((v = am__env(ctx, "AM_STACK_SIZE")) &&
             parse_bytes(v, &ctx->stack_size))
        return bad_option(ctx, "AM_STACK_SIZE", v, "bytes, e.g. 65536 or 64k");

#if defined(AM_FAST_SWITCH) && defined(__x86_64__)
    ctx->switch_mode = AM_SWITCH_FAST;
    int fast_built = 1;
#else
    ctx->switch_mode = AM_SWITCH_UCONTEXT;
    int fast_built = 0;
#endif
    int mode = o->switch_mode;
    if (!mode && (v = am__env(ctx, "AM_SWITCH"))) {
        if (!strcmp(v, "ucontext"))
            mode = AM_SWITCH_UCONTEXT;
        else if (!strcmp(v, "fast"))
            mode = AM_SWITCH_FAST;
        else
            return bad_option(ctx, "AM_SWITCH", v, "ucontext or fast");
    }
    if (mode == AM_SWITCH_FAST && !fast_built) {
        am__warn(ctx, "the fast thread switch was not built (configure "
                      "--disable-fast-switch, or not x86-64)");
        return AM_EINVAL;
    }
    if (mode == AM_SWITCH_UCONTEXT || mode == AM_SWITCH_FAST)
        ctx->switch_mode = mode;
    else if (mode)
        return AM_EINVAL;

    ctx->boot_timeout = DEFAULT_BOOT_TIMEOUT;
    if (o->boot_timeout > 0)
        ctx->boot_timeout = o->boot_timeout;
    else if ((v = am__env(ctx, "AM_BOOT_TIMEOUT")) &&
             (parse_seconds(v, &ctx->boot_timeout) || ctx->boot_timeout <= 0))
        return bad_option(ctx, "AM_BOOT_TIMEOUT", v, "seconds");

    ctx->heartbeat = DEFAULT_HEARTBEAT;
    if (o->heartbeat > 0)
        ctx->heartbeat = o->heartbeat;
    else if ((v = am__env(ctx, "AM_HEARTBEAT")) &&
             (parse_seconds(v, &ctx->heartbeat) || ctx->heartbeat < 0.05))
        return bad_option(ctx, "AM_HEARTBEAT", v, "seconds, at least 0.05");

    ctx->poll_budget = o->poll_budget ? o->poll_budget : DEFAULT_POLL_BUDGET;

    /* Send coalescing (am_transport.c): on unless AM_COALESCE=0, which
     * hands every frame to ZeroMQ at once, alone, as before it existed
     * (kept for measuring the difference). */
    long coalesce = 1;
    if ((v = am__env(ctx, "AM_COALESCE")) && parse_long(v, 0, 1, &coalesce))
        return bad_option(ctx, "AM_COALESCE", v, "1 (on) or 0 (off)");
    ctx->coalesce = (int)coalesce;

    /* Same-host rings (am_shm.c): on unless AM_SHM=0 (2, which forced
     * them where they used to be off, is taken as 1); AM_SHM_RING sets
     * the bytes of each ring (a power of two, at least 4096; rounded
     * down), else a share of a per-PE budget. */
    long shm = 1;
    if ((v = am__env(ctx, "AM_SHM")) && parse_long(v, 0, 2, &shm))
        return bad_option(ctx, "AM_SHM", v, "1 (on) or 0 (off)");
    ctx->shm_enabled = (int)shm;
    if ((v = am__env(ctx, "AM_SHM_RING"))) {
        size_t b = 0;
        if (am__bytes_parse(v, &b) || b < 4096 || b > ((size_t)1 << 30))
            return bad_option(ctx, "AM_SHM_RING", v,
                              "bytes, at least 4096 and at most 1G");
        ctx->shm_ring = 4096;
        while (ctx->shm_ring * 2 <= b)
            ctx->shm_ring *= 2;
    }
    ctx->shm_big = (size_t)256 << 10;
    if ((v = am__env(ctx, "AM_SHM_BIG")) && am__bytes_parse(v, &ctx->shm_big))
        return bad_option(ctx, "AM_SHM_BIG", v,
                          "bytes (frames this large go by ZeroMQ), 0 = none");

    long hwm = 0;
    if ((v = am__env(ctx, "AM_HWM")) && parse_long(v, 0, 1 << 30, &hwm))
        return bad_option(ctx, "AM_HWM", v, "a message count, 0 = unlimited");
    ctx->hwm = (int)hwm;

    ctx->send_window = AM_SEND_WINDOW_DEFAULT;
    if (o->send_window)
        ctx->send_window = o->send_window;
    else if ((v = am__env(ctx, "AM_SEND_WINDOW")) &&
             (am__bytes_parse(v, &ctx->send_window) || ctx->send_window < 4096))
        return bad_option(ctx, "AM_SEND_WINDOW", v, "bytes, at least 4096");
    if (ctx->send_window < 4096)
        return AM_EINVAL;
    ctx->send_queue = AM_SEND_QUEUE_DEFAULT;
    if (o->send_queue)
        ctx->send_queue = o->send_queue;
    else if ((v = am__env(ctx, "AM_SEND_QUEUE")) &&
             am__bytes_parse(v, &ctx->send_queue))
        return bad_option(ctx, "AM_SEND_QUEUE", v, "bytes, e.g. 64M, or 0");

    v = o->stats_dir ? o->stats_dir : am__env(ctx, "AM_STATS_DIR");
    if (v && !(ctx->stats_dir = pr_strdup(v)))
        return AM_ENOMEM;

    ctx->ipc_dir = dup_or_null(am__env(ctx, "AM_IPC_DIR"));
    v = am__env(ctx, "AM_TRANSPORT");
    if (!v)
        v = ctx->ipc_dir ? "ipc" : "tcp";
    if (strcmp(v, "ipc") && strcmp(v, "tcp"))
        return bad_option(ctx, "AM_TRANSPORT", v, "ipc or tcp");
    ctx->transport = pr_strdup(v);
    if (!strcmp(v, "ipc") && !ctx->ipc_dir && ctx->size > 1) {
        am__warn(ctx, "AM_TRANSPORT=ipc needs AM_IPC_DIR, a directory for the "
                      "sockets");
        return AM_EINVAL;
    }
    ctx->bind_addr = pr_strdup((v = am__env(ctx, "AM_BIND")) ? v : "127.0.0.1");
    ctx->root_ep = dup_or_null(am__env(ctx, "AM_ROOT"));
    ctx->rendezvous = dup_or_null(am__env(ctx, "AM_RENDEZVOUS"));
    if ((v = am__env(ctx, "AM_JOB"))) {
        char *end;
        errno = 0;
        ctx->job = strtoull(v, &end, 0);
        if (errno || *end)
            return bad_option(ctx, "AM_JOB", v, "an integer job id");
    }
    /* CURVE keys (tcp only; ipc never uses them): AM_CURVE_KEYS, or the
     * older single key pair shared by every PE. */
    const char *keys = am__env(ctx, "AM_CURVE_KEYS");
    const char *pub = am__env(ctx, "AM_CURVE_SERVER_PUBLIC");
    const char *sec = am__env(ctx, "AM_CURVE_SERVER_SECRET");
    if ((keys || pub || sec) && !strcmp(ctx->transport, "tcp") &&
        ctx->size > 1) {
        if (!zmq_has("curve")) {
            am__warn(ctx, "CURVE keys given but this libzmq has no CURVE");
            return AM_EINVAL;
        }
        int rc;
        if (keys)
            rc = am__keys_read(ctx, keys, ctx->rank, ctx->size,
                               ctx->boot_timeout, &ctx->keys);
        else if ((rc = am__keys_shared(pub ? pub : "", sec ? sec : "",
                                       ctx->size, &ctx->keys)) == AM_EINVAL)
            return bad_option(ctx, "AM_CURVE_SERVER_PUBLIC/SECRET", "...",
                              "two Z85 keys of 40 characters");
        if (rc)
            return rc;
    } else if (keys && !strncmp(keys, "fd:", 3)) {
        /* Not needed (one PE, or ipc): the descriptor is not left open
         * for the program and what it starts. */
        long fd;
        if (!parse_long(keys + 3, 3, 1 << 20, &fd))
            close((int)fd);
    }
    if (!ctx->transport || !ctx->bind_addr)
        return AM_ENOMEM;

    const char *sched = am__env(ctx, "AM_SCHED");
    if (sched) {
        int rc = set_os_sched(ctx, sched);
        if (rc)
            return rc;
    }
    /* More PEs on this host (AM_CPU_SLOTS, else the job's size) than
     * processors it may run on, read before AM_CPU_BIND narrows them to
     * one (am_shm.c sizes its rings by it). */
    long slots = ctx->size;
    const char *nv = am__env(ctx, "AM_CPU_SLOTS");
    if (nv && parse_long(nv, 1, AM__PE_MAX, &slots))
        slots = ctx->size; /* reported by set_cpu_bind where it matters */
    cpu_set_t cpus;
    ctx->oversubscribed = sched_getaffinity(0, sizeof cpus, &cpus) == 0 && slots > CPU_COUNT(&cpus);
    const char *bind = am__env(ctx, "AM_CPU_BIND");
    if (bind) {
        int rc = set_cpu_bind(ctx, bind, sched);
        if (rc)
            return rc;
    }
    const char *lat = o->latency ? o->latency : am__env(ctx, "AM_LATENCY");
    const char *bw = o->bandwidth ? o->bandwidth : am__env(ctx, "AM_BANDWIDTH");
    return am__latency_init(ctx, lat, bw);
}

/* The launcher's failure-report pipe (AM_REPORT_FD, set by am-run for the
 * PEs it forks). Kept away from programs the PE starts. A number that is
 * not an open descriptor is ignored: the variable may have leaked from an
 * enclosing job. */
static void open_report(am_ctx_t *ctx)
{
    const char *v = am__env(ctx, "AM_REPORT_FD");
    long fd;
    if (!v || parse_long(v, 3, 1 << 20, &fd))
        return;
    int flags = fcntl((int)fd, F_GETFD);
    if (flags < 0)
        return;
    fcntl((int)fd, F_SETFD, flags | FD_CLOEXEC);
    ctx->report_fd = (int)fd;
}

/* ------------------------------------------------ control dispatch table */

/* The modules that handle control frames, each with its list of entries.
 * A new module that handles control types is added here once. */
static const am__ctl_entry *const ctl_modules[] = {
    am__boot_ctls, am__ctx_ctls,  am__transport_ctls,
    am__term_ctls, am__coll_ctls, am__rpc_ctls,  am__flow_ctls,
    am__shm_ctls,
};

/* Fills the context's dispatch table from the modules' lists. A type
 * claimed twice or by no module is a defect of the library itself, not a
 * condition a program could handle, so it stops the process at once (any
 * test catches it). */
static void ctl_table_build(am_ctx_t *ctx)
{
    size_t n = sizeof ctl_modules / sizeof ctl_modules[0];
    for (size_t i = 0; i < n; i++) {
        for (const am__ctl_entry *e = ctl_modules[i]; e->type; e++) {
            if (e->type >= AM__CTL_COUNT || ctx->ctl[e->type] || !e->fn ||
                !e->name) {
                am__warn(ctx, "internal error: control type %u (%s) is "
                              "declared twice or wrongly",
                         e->type, e->name ? e->name : "?");
                abort();
            }
            ctx->ctl[e->type] = e;
        }
    }
    for (unsigned t = 1; t < AM__CTL_COUNT; t++) {
        if (!ctx->ctl[t]) {
            am__warn(ctx, "internal error: no module handles control type %u",
                     t);
            abort();
        }
    }
}

/* ------------------------------------------------------- init / finalize */

static void destroy(am_ctx_t *ctx)
{
    am__latency_free(ctx);
    am__flow_free(ctx);
    am__coll_free_all(ctx);
    am__fifo_clear(&ctx->loopback);
    am__fifo_clear(&ctx->early);
    am__fifo_clear(&ctx->deferred);
    if (ctx->peers)
        for (int pe = 0; pe < ctx->size; pe++)
            am__fifo_clear(&ctx->peers[pe].sendq);
    pr_free(ctx->sendq_peers);
    am__transport_close(ctx);
    am__sched_free(ctx);
    am__loop_free(ctx);
    am__stats_free(ctx);
    if (ctx->peers)
        for (int pe = 0; pe < ctx->size; pe++)
            pr_free(ctx->peers[pe].endpoint);
    pr_free(ctx->peers);
    for (int i = 0; i < ctx->noverrides; i++)
        pr_free(ctx->overrides[i]);
    pr_free(ctx->overrides);
    pr_free(ctx->stats_dir);
    pr_free(ctx->transport);
    pr_free(ctx->ipc_dir);
    pr_free(ctx->bind_addr);
    pr_free(ctx->root_ep);
    pr_free(ctx->rendezvous);
    pr_free(ctx->rdv_file);
    am__keys_free(&ctx->keys);
    pr_free(ctx->hs_peer_warned);
    if (ctx->report_fd >= 0)
        close(ctx->report_fd);
    pr_free(ctx);
}

int am_init(int *argc, char ***argv, const am_opts_t *opts, am_ctx_t **out)
{
    if (!out)
        return AM_EINVAL;
    *out = NULL;
    am_ctx_t *ctx = pr_calloc(1, sizeof *ctx);
    if (!ctx)
        return AM_ENOMEM;
    ctx->t_init = am__now();
    ctx->state = AM__BOOTING;
    ctx->culprit = -1;
    ctx->report_fd = -1;
    ctl_table_build(ctx);
    int rc = take_args(ctx, argc, argv);
    if (!rc)
        rc = detect_rank(ctx);
    if (!rc)
        open_report(ctx);
    if (!rc)
        rc = resolve_options(ctx, opts);
    if (!rc && !(ctx->peers = pr_calloc((size_t)ctx->size, sizeof *ctx->peers)))
        rc = AM_ENOMEM;
    if (!rc && !(ctx->sendq_peers = pr_calloc((size_t)ctx->size,
                                              sizeof *ctx->sendq_peers)))
        rc = AM_ENOMEM;
    for (int pe = 0; !rc && pe < ctx->size; pe++)
        ctx->peers[pe].ctx = ctx;
    if (!rc)
        rc = am__loop_init(ctx);
    if (!rc)
        rc = am__sched_init(ctx);
    if (!rc && ctx->size > 1) {
        rc = am__transport_open(ctx);
        if (!rc)
            rc = am__boot(ctx);
        if (!rc)
            rc = am__shm_start(ctx);
        if (!rc)
            rc = am__loop_watch(ctx);
    }
    if (rc) {
        if (rc == AM_ENOMEM)
            am__warn(ctx, "am_init: out of memory");
        destroy(ctx);
        return rc;
    }
    ctx->state = AM__RUNNING;
    *out = ctx;
    return 0;
}

/* A PE sends BYE to every other once it passed the final barrier of
 * am_finalize: from then on it may go without that being a failure. */
static void on_bye(am_ctx_t *ctx, int src, pr_reader *body)
{
    if (am__empty_get(body))
        am__reject(ctx, AM__REJ_BODY, src, "bye");
    else
        ctx->peers[src].said_bye = 1;
}

const am__ctl_entry am__ctx_ctls[] = {
    {AM__CTL_BYE, "bye", 0, on_bye},
    {0, NULL, 0, NULL},
};

/* Waits at most ms milliseconds for the socket (events: ZMQ_POLLIN or
 * ZMQ_POLLOUT) or for a ring (frames in, or room for frames waiting). */
static void wait_io(am_ctx_t *ctx, short events, long ms)
{
    if (am__shm_sleep_begin(ctx))
        return;
    zmq_pollitem_t it[2] = {{ctx->sock, 0, events, 0},
                            {NULL, am__shm_fd(ctx), ZMQ_POLLIN, 0}};
    zmq_poll(it, am__shm_fd(ctx) >= 0 ? 2 : 1, ms);
    am__shm_sleep_end(ctx);
    am__shm_drain(ctx);
}

/* Waits (bounded) until every peer said goodbye. A peer closes only after
 * it has our BYE too, so when this returns everything we sent has arrived
 * and closing the socket has nothing left to linger for. */
static void wait_byes(am_ctx_t *ctx, double seconds)
{
    double end = am__now() + seconds;
    for (;;) {
        am__recv_some(ctx, 1024);
        /* A BYE that came in while this PE was still in the final
         * barrier sits in the injected-latency queue, whose timers only
         * the event loop runs: deliver it here when it is due. */
        am__latency_deliver_due(ctx);
        int missing = 0;
        for (int pe = 0; pe < ctx->size; pe++)
            missing += pe != ctx->rank && !ctx->peers[pe].said_bye;
        if (!missing || ctx->failed || am__now() > end)
            return;
        wait_io(ctx, ZMQ_POLLIN, am__latency_pending(ctx) ? 1 : 10);
    }
}

/* Waits (bounded) until the send queues are empty. */
static void drain_sendq(am_ctx_t *ctx, double seconds)
{
    double end = am__now() + seconds;
    while (ctx->sendq_total && !ctx->failed && am__now() < end) {
        if (am__flush_sendq(ctx))
            break;
        if (ctx->sendq_total)
            wait_io(ctx, ZMQ_POLLOUT, 10);
    }
}

int am_finalize(am_ctx_t **pctx)
{
    /* The state goes to AM__CLOSING after the final barrier: it tells the
     * transport that peers may vanish without that being a failure. */
    if (!pctx || !*pctx)
        return AM_EINVAL;
    am_ctx_t *ctx = *pctx;
    if (ctx->sched.current || ctx->in_callback)
        return AM_ESTATE;
    int rc = 0;
    if (ctx->state == AM__RUNNING && !ctx->failed && ctx->size > 1) {
        /* Callback sends still waiting for a window go before the barrier
         * and the BYEs, which would overtake them. */
        am__flow_drain(ctx, ctx->boot_timeout);
        ctx->coll_deadline = am__now() + ctx->boot_timeout;
        rc = am_barrier(ctx);
        ctx->coll_deadline = 0;
        if (rc == AM_ETIMEOUT)
            am__warn(ctx, "am_finalize: the other PEs did not all reach "
                          "am_finalize within %.0f s; leaving anyway",
                     ctx->boot_timeout);
        /* From here on a peer that already left is no error. */
        ctx->state = AM__CLOSING;
        if (!ctx->failed) {
            for (int pe = 0; pe < ctx->size; pe++) {
                if (pe == ctx->rank)
                    continue;
                pr_buf b = PR_BUF_INIT;
                am__ctl_begin(&b);
                am__send_ctl(ctx, pe, AM__CTL_BYE, &b);
                pr_buf_free(&b);
            }
            drain_sendq(ctx, 2.0);
            wait_byes(ctx, 5.0);
        }
    }
    if (ctx->sched.live) {
        am__warn(ctx, "am_finalize: %zu thread(s) still alive; their stacks "
                      "are freed",
                 ctx->sched.live);
        if (!rc)
            rc = AM_ESTATE;
    }
    if (ctx->stats_dir) {
        am__read_monitor(ctx); /* failed handshakes, for the counts */
        size_t n = strlen(ctx->stats_dir) + 32;
        char *path = pr_malloc(n);
        if (path) {
            snprintf(path, n, "%s/stats-%d.json", ctx->stats_dir, ctx->rank);
            int src = am_stats_write_json(ctx, path);
            if (src && !rc)
                rc = src;
            pr_free(path);
        }
    }
    if (ctx->rank == 0 && ctx->rdv_file)
        unlink(ctx->rdv_file);
    if (ctx->failed && !rc)
        rc = ctx->failed;
    ctx->state = AM__CLOSING;
    destroy(ctx);
    *pctx = NULL;
    return rc;
}
