/*
 * am_mp.c -- multi-process test driver for libam, run under am-run by the
 * tests/am-*.sh scripts. One program, several scenarios:
 *
 *   am_mp storm N MAXLEN   every PE sends N messages of random length (0..
 *                          MAXLEN bytes, random contents) to every PE; each
 *                          must arrive exactly once, in order per sender,
 *                          with the right bytes (checked against the
 *                          generator and a checksum)
 *   am_mp term SEEDS DEPTH randomized work-spawning: handlers and threads
 *                          (some sleeping a random time first) send more
 *                          work to random PEs; checks that termination is
 *                          declared, and only after the last message
 *   am_mp rpc              a thread blocked in am_call does not block the
 *                          other threads of its PE
 *   am_mp counts           every PE sends messages of known sizes to the
 *                          next one by each send path (am_send, am_send_buf,
 *                          am_send_zc, am_call with am_reply and with
 *                          am_reply_to); checks that the statistics count
 *                          each exactly once, sent and received, in total,
 *                          per handler and per control type
 *   am_mp rtt N            prints the mean AM round trip between ranks 0
 *                          and 1 ("rtt_us X")
 *   am_mp flush            rank 0 sends to rank 1, calls am_flush and then
 *                          computes for 3 s without polling; the message
 *                          must reach rank 1 long before (coalescing would
 *                          otherwise hold it until rank 0 polls again)
 *   am_mp coll             barrier, allreduce, gather
 *   am_mp affinity         prints "PE R cpus LIST threads N" (LIST: the
 *                          processors every thread of the PE may run on,
 *                          "mixed" if its threads differ), for the
 *                          --cpu-bind tests
 *   am_mp kill VICTIM      PE VICTIM kills itself with SIGKILL mid-run; the
 *                          others must report it and exit (never return)
 *   am_mp busy DIR SECONDS every PE writes its pid to DIR/pid-RANK, then
 *                          sends messages of up to 1 KiB to random PEs for
 *                          SECONDS (a job to kill or stop from outside)
 *   am_mp flood N SIZE T MIB  every PE floods PE 0: T threads and the main
 *                          context send N messages each (SIZE/2..SIZE
 *                          bytes), a handler on every PE but the last sends
 *                          a burst within AM_SEND_QUEUE, and a handler on
 *                          the last PE sends until the runtime refuses with
 *                          AM_EFULL; each message must arrive exactly once
 *                          (index per stream, checksum, counts), the job
 *                          must terminate, and no PE may peak above MIB MiB
 *                          of resident memory
 *   am_mp flood-pair N SIZE T  PEs 2k and 2k+1 flood each other from T
 *                          threads and the main context while their
 *                          handlers answer every message (no deadlock)
 *   am_mp malformed        rank 0 throws malformed frames at PE 1 from raw
 *                          ZeroMQ sockets; PE 1 must reject and count each
 *   am_mp stranger         like malformed, but only checks whether frames
 *                          from a socket without the job's CURVE key got in
 *   am_mp zap DIR N [S]    a target for strangers (tests/am-zap.sh): rank 0
 *                          writes DIR/info (PE 1's endpoint and CURVE key,
 *                          the rendezvous' endpoint and key, the job id,
 *                          PE 0's endpoint and key),
 *                          PE 1 computes S seconds without polling (default
 *                          0), every PE waits for DIR/go, then each PE sends
 *                          its peer N messages; each must arrive exactly
 *                          once and no frame may have been rejected
 *   am_mp sleep S          (no libam) sleeps S seconds: a PE to stop
 *   am_mp fake-peer EP V   (no libam) says hello to rank 0 at endpoint EP as
 *                          PE 1 speaking wire protocol version V
 *
 * AM_MP_LINGER_MS=N: after am_finalize the PE sleeps N ms before it exits
 * (a PE with work left after am_finalize, as pdr mesh's PEs have).
 *
 * Exit status 0 if every check held, 1 otherwise; every wait is bounded.
 * Extra arguments of the form tag=... are ignored (the scripts use them to
 * find leftover processes).
 */
#include "config.h"

#include <dirent.h>
#include <errno.h>

#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include <zmq.h>

#include "am.h"

static int failures;

#define CHECK(cond, ...)                                                     \
    do {                                                                     \
        if (!(cond)) {                                                       \
            fprintf(stderr, "am_mp: PE %d: check failed at line %d: ",       \
                    g_rank, __LINE__);                                       \
            fprintf(stderr, __VA_ARGS__);                                    \
            fputc('\n', stderr);                                             \
            failures++;                                                      \
        }                                                                    \
    } while (0)

static int g_rank = -1;

static uint64_t mix(uint64_t x)
{
    /* splitmix64 */
    x += UINT64_C(0x9E3779B97F4A7C15);
    x = (x ^ (x >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
    x = (x ^ (x >> 27)) * UINT64_C(0x94D049BB133111EB);
    return x ^ (x >> 31);
}

static uint64_t rng_state;

static uint64_t rnd(void)
{
    rng_state = mix(rng_state);
    return rng_state;
}

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static void put32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

static uint32_t get32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
           (uint32_t)p[3] << 24;
}

static void put64(uint8_t *p, uint64_t v)
{
    put32(p, (uint32_t)v);
    put32(p + 4, (uint32_t)(v >> 32));
}

static uint64_t get64(const uint8_t *p)
{
    return get32(p) | (uint64_t)get32(p + 4) << 32;
}

/* ---------------------------------------------------------------- storm */

enum { H_STORM = 1, H_WORK = 2, H_SLOW = 3, H_FAST = 4, H_PING = 5, H_PONG = 6,
       H_SPIN = 7, H_BUSY = 8, H_FLOOD = 9, H_KICK = 10, H_ACK = 11 };

#define STORM_HDR 20 /* src u32, idx u32, len u32, checksum u64 */

typedef struct storm {
    int n, maxlen, size;
    uint32_t *next_idx; /* per source: next index expected */
    long received, bad;
    int sent_to;        /* next destination round-robin */
    int sent;           /* messages sent to each destination so far */
} storm;

/* Length and contents of message idx from src to dst: a pure function of
 * (src, dst, idx), so the receiver can recompute them. */
static size_t storm_len(const storm *S, int src, int dst, uint32_t idx)
{
    uint64_t h = mix(((uint64_t)src << 40) ^ ((uint64_t)dst << 20) ^ idx ^ 0xABCD);
    /* Mostly small, sometimes up to maxlen. */
    size_t len = (size_t)(h % 64);
    if ((h >> 8) % 8 == 0)
        len = (size_t)((h >> 16) % (uint64_t)(S->maxlen + 1));
    return len;
}

static void storm_fill(uint8_t *p, size_t len, int src, int dst, uint32_t idx)
{
    uint64_t x = mix(((uint64_t)src << 40) ^ ((uint64_t)dst << 20) ^ idx);
    for (size_t i = 0; i < len; i++) {
        if (i % 8 == 0)
            x = mix(x);
        p[i] = (uint8_t)(x >> (8 * (i % 8)));
    }
}

static uint64_t checksum(const uint8_t *p, size_t len)
{
    uint64_t h = UINT64_C(1469598103934665603); /* FNV-1a */
    for (size_t i = 0; i < len; i++)
        h = (h ^ p[i]) * UINT64_C(1099511628211);
    return h;
}

static void storm_handler(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    storm *S = arg;
    const uint8_t *d = m->data;
    if (m->len < STORM_HDR) {
        CHECK(0, "storm message of %zu bytes", m->len);
        S->bad++;
        return;
    }
    uint32_t src = get32(d), idx = get32(d + 4), len = get32(d + 8);
    uint64_t sum = get64(d + 12);
    CHECK((int)src == m->src, "message says src %u, runtime says %d", src, m->src);
    CHECK(len == m->len - STORM_HDR, "length %u vs %zu", len, m->len - STORM_HDR);
    CHECK(idx == S->next_idx[m->src],
          "from PE %d got index %u, expected %u (lost, duplicated or reordered)",
          m->src, idx, S->next_idx[m->src]);
    size_t want = storm_len(S, m->src, am_rank(ctx), idx);
    CHECK(want == len, "message %u from %d: length %u, generator says %zu", idx,
          m->src, len, want);
    uint8_t *exp = malloc(want ? want : 1);
    storm_fill(exp, want, m->src, am_rank(ctx), idx);
    CHECK(want == len && !memcmp(exp, d + STORM_HDR, len) &&
              checksum(d + STORM_HDR, len) == sum,
          "message %u from %d: contents differ", idx, m->src);
    free(exp);
    S->next_idx[m->src] = idx + 1;
    S->received++;
}

static int storm_send_one(am_ctx_t *ctx, storm *S, int dst, uint32_t idx)
{
    int me = am_rank(ctx);
    size_t len = storm_len(S, me, dst, idx);
    size_t total = STORM_HDR + len;
    /* Alternate the copying and the zero-copy send. */
    int zc = idx % 2;
    uint8_t *p = zc ? am_buf_alloc(total) : malloc(total);
    put32(p, (uint32_t)me);
    put32(p + 4, idx);
    put32(p + 8, (uint32_t)len);
    storm_fill(p + STORM_HDR, len, me, dst, idx);
    put64(p + 12, checksum(p + STORM_HDR, len));
    int rc;
    if (zc) {
        rc = am_send_buf(ctx, dst, H_STORM, p, total);
        if (rc)
            am_buf_free(p);
    } else {
        rc = am_send(ctx, dst, H_STORM, p, total);
        free(p);
    }
    return rc;
}

/* Work step: a batch of sends per call, round-robin over destinations. */
static int storm_work(am_ctx_t *ctx, void *arg)
{
    storm *S = arg;
    if (S->sent >= S->n)
        return 0;
    for (int b = 0; b < 8 && S->sent < S->n; b++) {
        int rc = storm_send_one(ctx, S, S->sent_to, (uint32_t)S->sent);
        CHECK(rc == 0, "am_send: %s", am_strerror(rc));
        if (++S->sent_to == S->size) {
            S->sent_to = 0;
            S->sent++;
        }
    }
    return 1;
}

static int run_storm(am_ctx_t *ctx, int n, int maxlen)
{
    storm S = {0};
    S.n = n;
    S.maxlen = maxlen;
    S.size = am_size(ctx);
    S.next_idx = calloc((size_t)S.size, sizeof *S.next_idx);
    am_register(ctx, H_STORM, "storm", storm_handler, &S);
    /* All handlers are registered everywhere before anyone sends. */
    am_barrier(ctx);
    double t0 = now_s();
    int rc = am_run_until_done(ctx, storm_work, &S);
    double dt = now_s() - t0;
    CHECK(rc == 0, "am_run_until_done: %s", am_strerror(rc));
    for (int src = 0; src < S.size; src++)
        CHECK(S.next_idx[src] == (uint32_t)n, "got %u of %d messages from PE %d",
              S.next_idx[src], n, src);
    int64_t mine[2] = {S.received, (int64_t)failures}, all[2];
    am_allreduce_i64(ctx, mine, all, 2, AM_SUM);
    int64_t expect = (int64_t)S.size * S.size * n;
    CHECK(all[0] == expect, "job received %lld messages, expected %lld",
          (long long)all[0], (long long)expect);
    if (am_rank(ctx) == 0)
        printf("storm: %d PEs, %lld messages delivered exactly once in %.3f s, "
               "%lld failed checks\n",
               S.size, (long long)all[0], dt, (long long)all[1]);
    free(S.next_idx);
    return 0;
}

/* ----------------------------------------------------------------- term */

typedef struct term {
    int size;
    int depth;
    int64_t sent, handled;
    int terminated;      /* am_run_until_done returned, quiet window */
    int late;            /* messages delivered after that */
    int seeds;
    am_timer_t *timers[64];
    int ntimers;
} term;

static term T;

static void send_work(am_ctx_t *ctx, int depth)
{
    uint8_t msg[4];
    put32(msg, (uint32_t)depth);
    int dst = (int)(rnd() % (uint64_t)T.size);
    int rc = am_send(ctx, dst, H_WORK, msg, sizeof msg);
    CHECK(rc == 0, "am_send: %s", am_strerror(rc));
    T.sent++;
}

typedef struct spawn_arg {
    int depth;
    int children;
    double pause;
} spawn_arg;

static void work_thread(am_ctx_t *ctx, void *arg)
{
    spawn_arg *a = arg;
    /* Sleep a random time first, so that PEs go idle and are woken later. */
    if (a->pause > 0)
        am_sleep(ctx, a->pause);
    for (int i = 0; i < a->children; i++) {
        send_work(ctx, a->depth);
        am_yield(ctx);
    }
    free(a);
}

static void work_timer(am_ctx_t *ctx, am_timer_t *t, void *arg)
{
    (void)t;
    send_work(ctx, (int)(intptr_t)arg);
}

static void work_handler(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)arg;
    CHECK(!T.terminated, "work message from PE %d delivered after termination "
                         "was declared",
          m->src);
    if (T.terminated)
        T.late++;
    T.handled++;
    int depth = (int)get32(m->data);
    if (depth <= 0)
        return;
    int children = (int)(rnd() % 4); /* mean 1.5: the tree is finite */
    switch (rnd() % 3) {
    case 0: /* from the handler itself */
        for (int i = 0; i < children; i++)
            send_work(ctx, depth - 1);
        break;
    case 1: { /* from a thread, after a pause of up to 3 ms */
        spawn_arg *a = malloc(sizeof *a);
        a->depth = depth - 1;
        a->children = children;
        a->pause = (double)(rnd() % 3000) * 1e-6;
        int rc = am_thread_spawn(ctx, work_thread, a, NULL);
        CHECK(rc == 0, "spawn: %s", am_strerror(rc));
        break;
    }
    default: /* from a timer */
        if (children && T.ntimers < 64) {
            am_timer_t *t;
            am_timer_new(ctx, work_timer, (void *)(intptr_t)(depth - 1), &t);
            am_timer_start(t, (double)(rnd() % 2000) * 1e-6);
            T.timers[T.ntimers++] = t;
        }
        break;
    }
}

static int term_work(am_ctx_t *ctx, void *arg)
{
    (void)arg;
    if (T.seeds <= 0)
        return 0;
    T.seeds--;
    send_work(ctx, T.depth);
    return 1;
}

static int run_term(am_ctx_t *ctx, int seeds, int depth)
{
    T.size = am_size(ctx);
    T.depth = depth;
    am_register(ctx, H_WORK, "work", work_handler, NULL);
    am_barrier(ctx);
    for (int epoch = 0; epoch < 2; epoch++) {
        T.seeds = seeds;
        T.terminated = 0;
        double t0 = now_s();
        int rc = am_run_until_done(ctx, term_work, NULL);
        double dt = now_s() - t0;
        T.terminated = 1;
        CHECK(rc == 0, "am_run_until_done: %s", am_strerror(rc));
        CHECK(am_thread_count(ctx) == 0, "%zu threads alive after termination",
              am_thread_count(ctx));
        /* Keep polling a while: nothing may arrive any more. No PE can have
         * started the next epoch yet: that needs this PE's contribution to
         * the allreduce below. */
        am_sleep(ctx, 0.1);
        T.terminated = 0;
        for (int i = 0; i < T.ntimers; i++)
            am_timer_free(&T.timers[i]);
        T.ntimers = 0;
        int64_t mine[3] = {T.sent, T.handled, T.late}, all[3];
        rc = am_allreduce_i64(ctx, mine, all, 3, AM_SUM);
        CHECK(rc == 0, "allreduce: %s", am_strerror(rc));
        CHECK(all[0] == all[1], "termination declared with %lld sent but %lld "
                                "handled",
              (long long)all[0], (long long)all[1]);
        CHECK(all[2] == 0, "%lld messages delivered after termination",
              (long long)all[2]);
        if (am_rank(ctx) == 0)
            printf("term: epoch %d, %d PEs, %lld work messages, all handled "
                   "before termination was declared (%.3f s)\n",
                   epoch, T.size, (long long)all[0], dt);
    }
    return 0;
}

/* ---------------------------------------------------------------- flood */

/* A flood message: src u32, stream u32, idx u32, len u32, checksum u64 of
 * the body, then len body bytes made by storm_fill. Streams: 0 the main
 * context, 1..T the threads, T+1 the kick handler's burst, T+2 the overflow
 * handler. */
#define FLOOD_HDR 24
/* What the runtime charges a message against a window (am.h). */
#define FLOOD_COST(payload) ((size_t)(payload) + 88)

typedef struct flood {
    int size, nthreads, nstreams, n, maxlen;
    int target;            /* -1: pairs (rank ^ 1) */
    uint32_t *next;        /* receiver: [src * nstreams + stream] */
    uint32_t *sent;        /* sender: per stream */
    int64_t recv, recv_bytes, recv_sum;
    int64_t sent_n, sent_sum;
    int64_t acks_sent, acks_recv, ack_errors;
    size_t window, queue;  /* AM_SEND_WINDOW / AM_SEND_QUEUE, 0 if unset */
    int burst;             /* messages of the kick handler's burst */
    int64_t overflow_ok;   /* overflow handler: sends accepted */
    int overflow_code;     /* and the code that stopped it (0: none) */
    int threads_done;
} flood;

static flood F;

static size_t flood_len(int src, int stream, uint32_t idx)
{
    size_t half = (size_t)F.maxlen / 2;
    uint64_t h = mix(((uint64_t)src << 40) ^ ((uint64_t)stream << 32) ^ idx);
    return half + (size_t)(h % (half + 1));
}

static int flood_send(am_ctx_t *ctx, int dst, int stream, size_t len)
{
    uint32_t idx = F.sent[stream];
    uint8_t *p = malloc(FLOOD_HDR + len);
    if (!p)
        return AM_ENOMEM;
    put32(p, (uint32_t)am_rank(ctx));
    put32(p + 4, (uint32_t)stream);
    put32(p + 8, idx);
    put32(p + 12, (uint32_t)len);
    storm_fill(p + FLOOD_HDR, len, am_rank(ctx), stream, idx);
    uint64_t sum = checksum(p + FLOOD_HDR, len);
    put64(p + 16, sum);
    int rc = am_send(ctx, dst, H_FLOOD, p, FLOOD_HDR + len);
    free(p);
    if (rc == 0) {
        F.sent[stream]++;
        F.sent_n++;
        F.sent_sum += (uint32_t)sum;
    }
    return rc;
}

static int flood_dst(am_ctx_t *ctx)
{
    return F.target >= 0 ? F.target : am_rank(ctx) ^ 1;
}

static void flood_handler(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)arg;
    const uint8_t *d = m->data;
    if (m->len < FLOOD_HDR) {
        CHECK(0, "flood message of %zu bytes", m->len);
        return;
    }
    uint32_t src = get32(d), stream = get32(d + 4), idx = get32(d + 8);
    uint32_t len = get32(d + 12);
    uint64_t sum = get64(d + 16);
    if (!((int)src == m->src && (int)stream < F.nstreams &&
          len == m->len - FLOOD_HDR)) {
        CHECK(0, "flood message from PE %d: bad header (src %u stream %u len "
                 "%u of %zu)",
              m->src, src, stream, len, m->len);
        return;
    }
    uint32_t *next = &F.next[src * (uint32_t)F.nstreams + stream];
    CHECK(idx == *next, "from PE %u stream %u got index %u, expected %u "
                        "(lost, duplicated or reordered)",
          src, stream, idx, *next);
    CHECK(checksum(d + FLOOD_HDR, len) == sum,
          "from PE %u stream %u index %u: contents differ", src, stream, idx);
    *next = idx + 1;
    F.recv++;
    F.recv_bytes += (int64_t)m->len;
    F.recv_sum += (uint32_t)sum;
    if (F.target < 0) {
        /* Pairs: answer from the handler, toward a PE whose threads are
         * flooding this one. */
        uint8_t ack[4];
        put32(ack, idx);
        int rc = am_send(ctx, m->src, H_ACK, ack, sizeof ack);
        if (rc == 0)
            F.acks_sent++;
        else
            F.ack_errors++;
        CHECK(rc == 0, "ack from a handler: %s", am_errname(rc));
    }
}

static void ack_handler(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)ctx;
    (void)m;
    (void)arg;
    F.acks_recv++;
}

/* A handler's sends: a burst that fits in AM_SEND_QUEUE (every one must be
 * accepted), or, for the overflow kick, sends until the runtime refuses. */
static void kick_handler(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)arg;
    int stream = F.nthreads + 1;
    if (m->len == 1 && ((const uint8_t *)m->data)[0] == 'O') {
        stream = F.nthreads + 2;
        size_t limit = 2 * (F.window + F.queue) / FLOOD_COST(FLOOD_HDR) + 16;
        for (size_t i = 0; i < limit; i++) {
            int rc = flood_send(ctx, F.target, stream, (size_t)F.maxlen);
            if (rc) {
                F.overflow_code = rc;
                break;
            }
            F.overflow_ok++;
        }
        return;
    }
    for (int i = 0; i < F.burst; i++) {
        int rc = flood_send(ctx, F.target, stream, flood_len(am_rank(ctx), stream,
                                                          (uint32_t)i));
        CHECK(rc == 0, "send %d of a burst of %d from a handler: %s", i,
              F.burst, am_errname(rc));
        if (rc)
            break;
    }
}

static void flood_thread(am_ctx_t *ctx, void *arg)
{
    int stream = (int)(intptr_t)arg;
    int dst = flood_dst(ctx);
    for (int i = 0; i < F.n; i++) {
        int rc = flood_send(ctx, dst, stream,
                            flood_len(am_rank(ctx), stream, (uint32_t)i));
        CHECK(rc == 0, "send from a thread: %s", am_errname(rc));
        if (rc)
            break;
    }
    F.threads_done++;
}

/* A byte count from the environment as libam reads it ("4096", "64k",
 * "4M", "1G"), 0 if unset. */
static size_t env_size(const char *name)
{
    const char *v = getenv(name);
    if (!v)
        return 0;
    char *end;
    size_t n = (size_t)strtoull(v, &end, 10);
    switch (*end) {
    case 'k': case 'K': return n << 10;
    case 'm': case 'M': return n << 20;
    case 'g': case 'G': return n << 30;
    default: return n;
    }
}

/* Under AddressSanitizer the resident memory is mostly the sanitizer's:
 * its quarantine keeps freed blocks (256 MiB by default) and its shadow
 * adds an eighth. The memory bound is then reported, not checked. */
#if defined(__SANITIZE_ADDRESS__)
#define FLOOD_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define FLOOD_ASAN 1
#endif
#endif
#ifndef FLOOD_ASAN
#define FLOOD_ASAN 0
#endif

/* Peak resident memory of this process (VmHWM), in KiB. */
static long peak_rss_kib(void)
{
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    long kib = -1;
    while (f && fgets(line, sizeof line, f))
        if (!strncmp(line, "VmHWM:", 6))
            kib = strtol(line + 6, NULL, 10);
    if (f)
        fclose(f);
    return kib;
}

static int run_flood(am_ctx_t *ctx, int pairs, int n, int maxlen, int nthreads,
                     long rss_mib)
{
    int me = am_rank(ctx);
    F.size = am_size(ctx);
    F.n = n;
    F.maxlen = maxlen < 2 ? 2 : maxlen;
    F.nthreads = nthreads;
    F.nstreams = nthreads + 3;
    F.target = pairs ? -1 : 0;
    F.window = env_size("AM_SEND_WINDOW");
    F.queue = env_size("AM_SEND_QUEUE");
    /* A burst of at most half the handler queue, all of it accepted. */
    F.burst = n;
    if (F.queue && (size_t)F.burst * FLOOD_COST(FLOOD_HDR + F.maxlen) > F.queue / 2)
        F.burst = (int)(F.queue / 2 / FLOOD_COST(FLOOD_HDR + F.maxlen));
    if (pairs && (F.size % 2)) {
        CHECK(0, "flood-pair needs an even number of PEs");
        return 1;
    }
    F.next = calloc((size_t)F.size * (size_t)F.nstreams, sizeof *F.next);
    F.sent = calloc((size_t)F.nstreams, sizeof *F.sent);
    am_register(ctx, H_FLOOD, "flood", flood_handler, NULL);
    am_register(ctx, H_KICK, "kick", kick_handler, NULL);
    am_register(ctx, H_ACK, "ack", ack_handler, NULL);
    am_barrier(ctx);
    double t0 = now_s();
    int dst = flood_dst(ctx);
    for (int t = 1; t <= nthreads; t++) {
        int rc = am_thread_spawn(ctx, flood_thread, (void *)(intptr_t)t, NULL);
        CHECK(rc == 0, "spawn: %s", am_strerror(rc));
    }
    if (!pairs) {
        /* Handlers flood too: every PE but the last kicks its own handler
         * into a burst, and the last kicks it into sending until it is
         * refused. */
        if (me < F.size - 1) {
            int rc = am_send(ctx, me, H_KICK, "B", 1);
            CHECK(rc == 0, "kick: %s", am_errname(rc));
        } else if (F.window && F.queue) {
            int rc = am_send(ctx, me, H_KICK, "O", 1);
            CHECK(rc == 0, "overflow kick: %s", am_errname(rc));
        }
    }
    /* The main context floods as well, before it runs the loop. */
    for (int i = 0; i < n; i++) {
        int rc = flood_send(ctx, dst, 0, flood_len(me, 0, (uint32_t)i));
        CHECK(rc == 0, "send from the main context: %s", am_errname(rc));
        if (rc)
            break;
    }
    int rc = am_run_until_done(ctx, NULL, NULL);
    double dt = now_s() - t0;
    CHECK(rc == 0, "am_run_until_done: %s", am_strerror(rc));
    CHECK(F.threads_done == nthreads, "%d of %d threads finished",
          F.threads_done, nthreads);

    /* Exactly once: every stream's next index equals what its sender says
     * it sent (the receiver checked the order), and the totals agree. */
    uint8_t *mine = malloc((size_t)F.nstreams * 4);
    for (int s = 0; s < F.nstreams; s++)
        put32(mine + 4 * s, F.sent[s]);
    void *all = NULL;
    size_t *lens = NULL;
    rc = am_gather(ctx, mine, (size_t)F.nstreams * 4, &all, &lens);
    CHECK(rc == 0, "gather: %s", am_strerror(rc));
    if (all) {
        for (int src = 0; src < F.size; src++) {
            int to = pairs ? src ^ 1 : 0;
            for (int s = 0; s < F.nstreams; s++) {
                uint32_t sent = get32((uint8_t *)all + 4 * ((size_t)src * F.nstreams + s));
                if (to == 0 && !pairs) {
                    uint32_t got = F.next[(size_t)src * F.nstreams + s];
                    CHECK(got == sent, "PE %d stream %d: %u sent, %u arrived",
                          src, s, sent, got);
                }
            }
        }
    }
    free(all);
    free(lens);
    free(mine);
    /* In pairs, each stream arrived in order from index 0 and the totals
     * agree (below): every stream arrived whole, exactly once. */
    long rss = peak_rss_kib();
    int64_t v[9] = {F.sent_n, F.sent_sum, F.recv, F.recv_sum, F.recv_bytes,
                    F.acks_sent, F.acks_recv, F.ack_errors, (int64_t)failures};
    int64_t s[9];
    am_allreduce_i64(ctx, v, s, 9, AM_SUM);
    int64_t peaks[2] = {rss, me == 0 ? rss : 0}, pk[2];
    am_allreduce_i64(ctx, peaks, pk, 2, AM_MAX);
    int64_t of[2] = {F.overflow_ok, F.overflow_code ? 1 : 0}, ofs[2];
    am_allreduce_i64(ctx, of, ofs, 2, AM_SUM);
    if (me == 0) {
        CHECK(s[0] == s[2], "%lld messages sent, %lld arrived", (long long)s[0],
              (long long)s[2]);
        CHECK(s[1] == s[3], "checksums of sent and arrived messages differ");
        if (pairs)
            CHECK(s[5] == s[2] && s[6] == s[5] && s[7] == 0,
                  "%lld messages, %lld answers sent, %lld arrived, %lld refused",
                  (long long)s[2], (long long)s[5], (long long)s[6],
                  (long long)s[7]);
        CHECK(rss_mib <= 0 || FLOOD_ASAN || pk[0] <= rss_mib * 1024,
              "peak RSS %.1f MiB exceeds the bound of %ld MiB", pk[0] / 1024.0,
              rss_mib);
        printf("%s: %d PEs, %lld messages (%.1f MiB) delivered exactly once, "
               "checksums agree, termination in %.3f s; peak RSS PE 0 %.1f "
               "MiB, largest %.1f MiB (bound %ld MiB%s)\n",
               pairs ? "flood-pair" : "flood", F.size, (long long)s[2],
               s[4] / 1048576.0, dt, pk[1] / 1024.0, pk[0] / 1024.0, rss_mib,
               FLOOD_ASAN ? ", not checked under AddressSanitizer" : "");
    }
    if (!pairs && me == F.size - 1 && F.window && F.queue) {
        size_t cost = FLOOD_COST(FLOOD_HDR + F.maxlen);
        size_t took = (size_t)F.overflow_ok * cost;
        CHECK(F.overflow_code && !strcmp(am_errname(F.overflow_code), "AM_EFULL"),
              "a handler sent %lld messages (%.1f MiB) to one PE and was %s",
              (long long)F.overflow_ok, took / 1048576.0,
              F.overflow_code ? am_errname(F.overflow_code) : "never refused");
        CHECK(!F.overflow_code || (took + cost > F.queue &&
                                   took <= F.window + F.queue),
              "a handler's sends were refused after %zu bytes; the queue holds "
              "%zu, the window %zu", took, F.queue, F.window);
        printf("flood: a handler's sends to PE 0 stopped by %s after %lld "
               "messages (%.2f MiB; queue %.2f MiB, window %.2f MiB)\n",
               F.overflow_code ? am_errname(F.overflow_code) : "nothing",
               (long long)F.overflow_ok, took / 1048576.0, F.queue / 1048576.0, F.window / 1048576.0);
    }
    free(F.next);
    free(F.sent);
    return 0;
}

/* ------------------------------------------------------------------ rpc */

typedef struct slow_reply {
    int src;
    uint64_t call_id;
    uint32_t value;
} slow_reply;

static void slow_thread(am_ctx_t *ctx, void *arg)
{
    slow_reply *r = arg;
    am_sleep(ctx, 0.3);
    uint8_t out[4];
    put32(out, r->value * 2);
    int rc = am_reply_to(ctx, r->src, r->call_id, out, sizeof out);
    CHECK(rc == 0, "am_reply_to: %s", am_strerror(rc));
    free(r);
}

/* Answers after 300 ms, from a thread (a deferred reply). */
static void slow_handler(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)arg;
    slow_reply *r = malloc(sizeof *r);
    r->src = m->src;
    r->call_id = m->call_id;
    r->value = get32(m->data);
    am_thread_spawn(ctx, slow_thread, r, NULL);
}

static void fast_handler(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)arg;
    uint8_t out[4];
    put32(out, get32(m->data) + 1);
    am_reply(ctx, m, out, sizeof out);
}

typedef struct rpc_state {
    int peer;
    int slow_done;
    double slow_took;
    int fast_calls_while_blocked;
} rpc_state;

static void slow_caller(am_ctx_t *ctx, void *arg)
{
    rpc_state *s = arg;
    uint8_t req[4];
    put32(req, 21);
    void *reply = NULL;
    size_t len = 0;
    double t0 = now_s();
    int rc = am_call(ctx, s->peer, H_SLOW, req, sizeof req, &reply, &len);
    s->slow_took = now_s() - t0;
    CHECK(rc == 0 && len == 4 && get32(reply) == 42, "slow call: %s, %zu bytes",
          am_strerror(rc), len);
    free(reply);
    s->slow_done = 1;
}

static void fast_caller(am_ctx_t *ctx, void *arg)
{
    rpc_state *s = arg;
    for (uint32_t i = 0; !s->slow_done && i < 100000; i++) {
        uint8_t req[4];
        put32(req, i);
        void *reply = NULL;
        size_t len = 0;
        int rc = am_call(ctx, s->peer, H_FAST, req, sizeof req, &reply, &len);
        CHECK(rc == 0 && len == 4 && get32(reply) == i + 1, "fast call %u", i);
        free(reply);
        if (!s->slow_done)
            s->fast_calls_while_blocked++;
    }
}

static int run_rpc(am_ctx_t *ctx)
{
    am_register(ctx, H_SLOW, "slow", slow_handler, NULL);
    am_register(ctx, H_FAST, "fast", fast_handler, NULL);
    am_barrier(ctx);
    rpc_state s = {(am_rank(ctx) + 1) % am_size(ctx), 0, 0, 0};
    CHECK(am_call(ctx, 0, H_FAST, "abcd", 4, &(void *){NULL}, &(size_t){0}) ==
              AM_ESTATE,
          "am_call from the main context must fail with AM_ESTATE");
    am_future_t *done_slow, *done_fast;
    am_future_new(ctx, &done_slow);
    am_future_new(ctx, &done_fast);
    am_thread_spawn(ctx, slow_caller, &s, done_slow);
    am_thread_spawn(ctx, fast_caller, &s, done_fast);
    int rc = am_run_until_done(ctx, NULL, NULL);
    CHECK(rc == 0, "am_run_until_done: %s", am_strerror(rc));
    CHECK(am_future_ready(done_slow) && am_future_ready(done_fast),
          "threads did not finish");
    CHECK(s.slow_took >= 0.29, "slow call returned after %.3f s", s.slow_took);
    CHECK(s.fast_calls_while_blocked >= 10,
          "only %d fast calls completed while a thread was blocked in am_call",
          s.fast_calls_while_blocked);
    printf("rpc: PE %d: %d round trips by another thread while one waited "
           "%.3f s for its reply\n",
           am_rank(ctx), s.fast_calls_while_blocked, s.slow_took);
    am_future_free(&done_slow);
    am_future_free(&done_fast);
    return 0;
}

/* --------------------------------------------------------------- counts */

enum { H_C_SEND = 40, H_C_BUF = 41, H_C_ZC = 42, H_C_CALL = 43, H_C_LATER = 44 };

static const size_t c_send_lens[] = {0, 1, 10, 100, 70000};
static const size_t c_buf_lens[] = {7, 0, 64};
static const size_t c_zc_lens[] = {5, 16};
static const size_t c_call_lens[] = {0, 3, 12, 40};
static const size_t c_later_lens[] = {9, 20};

#define N_OF(a) (sizeof a / sizeof a[0])

static uint8_t c_junk[70000];

static uint64_t sum_of(const size_t *a, size_t n)
{
    uint64_t s = 0;
    for (size_t i = 0; i < n; i++)
        s += a[i];
    return s;
}

/* Reply sizes: am_reply answers 2 len + 1 bytes, am_reply_to len / 2 + 1. */
static size_t c_reply_len(size_t len, int later)
{
    return later ? len / 2 + 1 : 2 * len + 1;
}

static void c_count(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)ctx;
    (void)m;
    (*(int *)arg)++;
}

static void c_call(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)arg;
    int rc = am_reply(ctx, m, c_junk, c_reply_len(m->len, 0));
    CHECK(rc == 0, "am_reply: %s", am_strerror(rc));
}

typedef struct c_later_reply {
    int src;
    uint64_t call_id;
    size_t len;
} c_later_reply;

static void c_later_thread(am_ctx_t *ctx, void *arg)
{
    c_later_reply *r = arg;
    am_yield(ctx);
    int rc = am_reply_to(ctx, r->src, r->call_id, c_junk, c_reply_len(r->len, 1));
    CHECK(rc == 0, "am_reply_to: %s", am_strerror(rc));
    free(r);
}

static void c_later(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)arg;
    c_later_reply *r = malloc(sizeof *r);
    *r = (c_later_reply){m->src, m->call_id, m->len};
    am_thread_spawn(ctx, c_later_thread, r, NULL);
}

static void c_free(void *frame, void *hint)
{
    (void)hint;
    free(frame);
}

static void c_sender(am_ctx_t *ctx, void *arg)
{
    (void)arg;
    int to = (am_rank(ctx) + 1) % am_size(ctx), rc;
    for (size_t i = 0; i < N_OF(c_send_lens); i++) {
        rc = am_send(ctx, to, H_C_SEND, c_junk, c_send_lens[i]);
        CHECK(rc == 0, "am_send: %s", am_strerror(rc));
    }
    for (size_t i = 0; i < N_OF(c_buf_lens); i++) {
        void *p = am_buf_alloc(c_buf_lens[i]);
        rc = am_send_buf(ctx, to, H_C_BUF, p, c_buf_lens[i]);
        CHECK(rc == 0, "am_send_buf: %s", am_strerror(rc));
    }
    for (size_t i = 0; i < N_OF(c_zc_lens); i++) {
        uint8_t *frame = calloc(1, AM_HEADROOM + c_zc_lens[i]);
        rc = am_send_zc(ctx, to, H_C_ZC, frame, c_zc_lens[i], c_free, NULL);
        CHECK(rc == 0, "am_send_zc: %s", am_strerror(rc));
    }
    for (int later = 0; later < 2; later++) {
        const size_t *lens = later ? c_later_lens : c_call_lens;
        size_t n = later ? N_OF(c_later_lens) : N_OF(c_call_lens);
        for (size_t i = 0; i < n; i++) {
            void *reply = NULL;
            size_t got = 0;
            rc = am_call(ctx, to, later ? H_C_LATER : H_C_CALL, c_junk, lens[i],
                         &reply, &got);
            CHECK(rc == 0 && got == c_reply_len(lens[i], later),
                  "am_call: %s, %zu bytes", am_strerror(rc), got);
            free(reply);
        }
    }
}

/* Expects text to contain the statistics entry "KEY": {"sent": N,
 * "sent_bytes": B, "recv": N, "recv_bytes": B, ... */
static void expect_hstat(const char *text, const char *key, uint64_t n,
                         uint64_t bytes)
{
    char want[256];
    snprintf(want, sizeof want,
             "%s{\"sent\": %llu, \"sent_bytes\": %llu, \"recv\": %llu, "
             "\"recv_bytes\": %llu, ",
             key, (unsigned long long)n, (unsigned long long)bytes,
             (unsigned long long)n, (unsigned long long)bytes);
    CHECK(strstr(text, want), "the statistics have no %s", want);
}

static int run_counts(am_ctx_t *ctx)
{
    int plain = 0;
    am_register(ctx, H_C_SEND, "send", c_count, &plain);
    am_register(ctx, H_C_BUF, "buf", c_count, &plain);
    am_register(ctx, H_C_ZC, "zc", c_count, &plain);
    am_register(ctx, H_C_CALL, "call", c_call, NULL);
    am_register(ctx, H_C_LATER, "later", c_later, NULL);
    /* The statistics are compared whole: the start-up and the barrier
     * exchange control frames only, and a successor may deliver messages
     * while it is still in the barrier. */
    am_barrier(ctx);
    am_thread_spawn(ctx, c_sender, NULL, NULL);
    int rc = am_run_until_done(ctx, NULL, NULL);
    CHECK(rc == 0, "am_run_until_done: %s", am_strerror(rc));
    am_stats_t st;
    am_stats_get(ctx, &st);

    /* Every PE sends the same to its successor and answers its
     * predecessor's calls, so it receives what it sends. */
    uint64_t calls = N_OF(c_call_lens) + N_OF(c_later_lens);
    uint64_t req_bytes = sum_of(c_call_lens, N_OF(c_call_lens)) +
                         sum_of(c_later_lens, N_OF(c_later_lens));
    uint64_t rep_bytes = 0;
    for (size_t i = 0; i < N_OF(c_call_lens); i++)
        rep_bytes += c_reply_len(c_call_lens[i], 0);
    for (size_t i = 0; i < N_OF(c_later_lens); i++)
        rep_bytes += c_reply_len(c_later_lens[i], 1);
    uint64_t msgs = N_OF(c_send_lens) + N_OF(c_buf_lens) + N_OF(c_zc_lens) + calls;
    uint64_t bytes = sum_of(c_send_lens, N_OF(c_send_lens)) +
                     sum_of(c_buf_lens, N_OF(c_buf_lens)) +
                     sum_of(c_zc_lens, N_OF(c_zc_lens)) + req_bytes;
    CHECK(plain == (int)(msgs - calls), "%d plain messages handled", plain);
    CHECK(st.msgs_sent == msgs && st.bytes_sent == bytes,
          "sent %llu messages, %llu bytes; expected %llu, %llu",
          (unsigned long long)st.msgs_sent, (unsigned long long)st.bytes_sent,
          (unsigned long long)msgs, (unsigned long long)bytes);
    CHECK(st.msgs_recv == msgs && st.bytes_recv == bytes,
          "received %llu messages, %llu bytes; expected %llu, %llu",
          (unsigned long long)st.msgs_recv, (unsigned long long)st.bytes_recv,
          (unsigned long long)msgs, (unsigned long long)bytes);
    CHECK(st.rejected == 0, "%llu frames rejected",
          (unsigned long long)st.rejected);

    /* Per handler, per control type and replies: from the statistics
     * file. */
    char path[128];
    snprintf(path, sizeof path, "%s/am_mp-counts-%ld.json",
             getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp", (long)getpid());
    CHECK(am_stats_write_json(ctx, path) == 0, "cannot write %s", path);
    static char text[1 << 16];
    FILE *f = fopen(path, "r");
    size_t n = f ? fread(text, 1, sizeof text - 1, f) : 0;
    text[n] = '\0';
    if (f)
        fclose(f);
    unlink(path);
    expect_hstat(text, "\"name\": \"send\", \"stats\": ", N_OF(c_send_lens),
                 sum_of(c_send_lens, N_OF(c_send_lens)));
    expect_hstat(text, "\"name\": \"buf\", \"stats\": ", N_OF(c_buf_lens),
                 sum_of(c_buf_lens, N_OF(c_buf_lens)));
    expect_hstat(text, "\"name\": \"zc\", \"stats\": ", N_OF(c_zc_lens),
                 sum_of(c_zc_lens, N_OF(c_zc_lens)));
    expect_hstat(text, "\"name\": \"call\", \"stats\": ", N_OF(c_call_lens),
                 sum_of(c_call_lens, N_OF(c_call_lens)));
    expect_hstat(text, "\"name\": \"later\", \"stats\": ",
                 N_OF(c_later_lens), sum_of(c_later_lens, N_OF(c_later_lens)));
    expect_hstat(text, "\"rpc_replies\": ", calls, rep_bytes);
    /* Bodies: call id and handler id (10 bytes) before a request's payload,
     * the call id (8) before a reply's. */
    expect_hstat(text, "\"rpc_request\": ", calls, 10 * calls + req_bytes);
    expect_hstat(text, "\"rpc_reply\": ", calls, 8 * calls + rep_bytes);
    printf("counts: PE %d: %llu messages, %llu bytes each way, counted once\n",
           am_rank(ctx), (unsigned long long)msgs, (unsigned long long)bytes);
    return 0;
}

/* ------------------------------------------------------------------ rtt */

static int pongs;

static void ping_handler(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)arg;
    am_send(ctx, m->src, H_PONG, m->data, m->len);
}

static void pong_handler(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)ctx;
    (void)m;
    (void)arg;
    pongs++;
}

static int run_rtt(am_ctx_t *ctx, int n)
{
    am_register(ctx, H_PING, "ping", ping_handler, NULL);
    am_register(ctx, H_PONG, "pong", pong_handler, NULL);
    am_barrier(ctx);
    if (am_rank(ctx) == 0) {
        char payload[32] = "ping";
        double t0 = now_s(), min = 1e9;
        for (int i = 0; i < n; i++) {
            double s = now_s();
            int want = pongs + 1;
            am_send(ctx, 1, H_PING, payload, sizeof payload);
            double limit = now_s() + 10;
            while (pongs < want && now_s() < limit) {
                am_poll(ctx);
                if (pongs < want)
                    am_idle(ctx, 0.1);
            }
            CHECK(pongs == want, "no pong within 10 s");
            double d = now_s() - s;
            if (d < min)
                min = d;
        }
        double mean = (now_s() - t0) / n;
        printf("rtt_us %.1f min_us %.1f\n", mean * 1e6, min * 1e6);
    }
    am_barrier(ctx);
    return 0;
}

/* ---------------------------------------------------------------- flush */

static int run_flush(am_ctx_t *ctx)
{
    am_register(ctx, H_PING, "ping", ping_handler, NULL);
    am_register(ctx, H_PONG, "pong", pong_handler, NULL);
    am_barrier(ctx);
    if (am_rank(ctx) == 0) {
        char payload[8] = "flush";
        /* H_PONG: counted by rank 1, not answered. */
        CHECK(am_send(ctx, 1, H_PONG, payload, sizeof payload) == 0, "send");
        CHECK(am_flush(ctx) == 0, "am_flush");
        double end = now_s() + 3.0;
        while (now_s() < end)
            ; /* a computation that does not poll */
    } else if (am_rank(ctx) == 1) {
        double t0 = now_s(), limit = t0 + 10;
        while (pongs < 1 && now_s() < limit) {
            am_poll(ctx);
            if (pongs < 1)
                am_idle(ctx, 0.1);
        }
        double took = now_s() - t0;
        CHECK(pongs == 1 && took < 1.5,
              "the flushed message took %.2f s (rank 0 computed 3 s)", took);
        printf("flush: the message arrived after %.3f s\n", took);
    }
    am_barrier(ctx);
    return 0;
}

/* ----------------------------------------------------------------- wake */

/* A receiver blocked in am_idle must be woken by a message at once, not
 * at the end of its idle slice (0.25 s): rank 0 sends n messages at
 * random moments, each carrying its send time (CLOCK_MONOTONIC is the
 * same clock in every process of the host); rank 1 waits for each with
 * am_idle(30) and records how long it took to arrive. */
static double wake_delay[256];
static int wakes;

static void wake_handler(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)ctx;
    (void)arg;
    double sent;
    if (m->len == sizeof sent && wakes < 256) {
        memcpy(&sent, m->data, sizeof sent);
        wake_delay[wakes] = now_s() - sent;
    }
    wakes++;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static int run_wake(am_ctx_t *ctx, int n)
{
    if (n > 256)
        n = 256;
    am_register(ctx, H_PING, "wake", wake_handler, NULL);
    am_barrier(ctx);
    if (am_rank(ctx) == 0) {
        for (int i = 0; i < n; i++) {
            /* 20-80 ms apart: rank 1 is asleep by then, at any phase of
             * its idle slice. */
            am_sleep(ctx, 0.02 + (double)(rnd() % 60) * 1e-3);
            double t = now_s();
            CHECK(am_send(ctx, 1, H_PING, &t, sizeof t) == 0, "send");
            am_flush(ctx);
        }
    } else if (am_rank(ctx) == 1) {
        double limit = now_s() + 60;
        while (wakes < n && now_s() < limit) {
            am_poll(ctx);
            if (wakes < n)
                am_idle(ctx, 30);
        }
        CHECK(wakes == n, "%d of %d messages arrived", wakes, n);
        qsort(wake_delay, (size_t)wakes, sizeof *wake_delay, cmp_double);
        double med = wake_delay[wakes / 2];
        printf("wake: %d messages to a sleeping PE, delay median %.1f us, "
               "max %.1f us\n",
               wakes, med * 1e6, wake_delay[wakes - 1] * 1e6);
        /* A lost wake-up waits for the idle slice: 0-250 ms, 125 by the
         * median; a woken PE takes microseconds. */
        CHECK(med < 0.03, "median delay %.1f ms: the sleeping PE was not woken",
              med * 1e3);
    }
    am_barrier(ctx);
    return 0;
}

/* -------------------------------------------------------------- killfull */

static void spin_handler(am_ctx_t *ctx, const am_msg_t *m, void *arg);

/* The peer dies while this PE's ring to it is full: the victim stops
 * polling (it computes) while the others send kb KiB to it, until their
 * frames wait in their send queues, then kills itself. The senders,
 * blocked on the full ring and the window, must still exit with an error
 * naming it. */
static int run_killfull(am_ctx_t *ctx, int kb, int victim)
{
    am_register(ctx, H_SPIN, "spin", spin_handler, NULL);
    am_barrier(ctx);
    if (am_rank(ctx) == victim) {
        double end = now_s() + 1.0;
        while (now_s() < end)
            ; /* no polling: nothing is read from the rings */
        fprintf(stderr, "am_mp: PE %d: killing myself with SIGKILL\n", victim);
        fflush(stderr);
        raise(SIGKILL);
    }
    static uint8_t buf[1024];
    am_stats_t st;
    int said = 0;
    for (int i = 0; i < kb; i++) {
        int rc = am_send(ctx, victim, H_SPIN, buf, sizeof buf);
        if (rc)
            return 1; /* the error handler exits first */
        am_stats_get(ctx, &st);
        if (!said && st.queued_sends > 0) {
            fprintf(stderr, "am_mp: PE %d: frames wait for room in the ring "
                            "after %d KiB\n",
                    am_rank(ctx), i + 1);
            fflush(stderr);
            said = 1;
        }
    }
    double t0 = now_s();
    int rc = am_run_until_done(ctx, NULL, NULL);
    CHECK(0, "am_run_until_done returned %s after %.1f s instead of exiting",
          am_strerror(rc), now_s() - t0);
    return 1;
}

/* ----------------------------------------------------------------- coll */

static void coll_thread(am_ctx_t *ctx, void *arg)
{
    double one = 1;
    int rc = am_allreduce_f64(ctx, &one, arg, 1, AM_SUM);
    CHECK(rc == 0, "allreduce in a thread: %s", am_strerror(rc));
}

static int run_coll(am_ctx_t *ctx)
{
    int r = am_rank(ctx), P = am_size(ctx);
    CHECK(am_barrier(ctx) == 0, "barrier");
    double d[3] = {r + 0.5, -r, r * 2.0}, ds[3], dmin[3], dmax[3];
    CHECK(am_allreduce_f64(ctx, d, ds, 3, AM_SUM) == 0, "sum");
    CHECK(am_allreduce_f64(ctx, d, dmin, 3, AM_MIN) == 0, "min");
    CHECK(am_allreduce_f64(ctx, d, dmax, 3, AM_MAX) == 0, "max");
    double tri = (double)P * (P - 1) / 2;
    CHECK(ds[0] == tri + 0.5 * P && ds[1] == -tri && ds[2] == 2 * tri,
          "f64 sum %g %g %g", ds[0], ds[1], ds[2]);
    CHECK(dmin[0] == 0.5 && dmin[1] == -(P - 1) && dmax[2] == 2.0 * (P - 1),
          "f64 min/max");
    int64_t v[2] = {(int64_t)r * 1000000000000LL, -(int64_t)r}, vs[2], vmin[2];
    CHECK(am_allreduce_i64(ctx, v, vs, 2, AM_SUM) == 0, "i64 sum");
    CHECK(am_allreduce_i64(ctx, v, vmin, 2, AM_MIN) == 0, "i64 min");
    CHECK(vs[0] == (int64_t)tri * 1000000000000LL && vs[1] == -(int64_t)tri,
          "i64 sum %lld %lld", (long long)vs[0], (long long)vs[1]);
    CHECK(vmin[0] == 0 && vmin[1] == -(int64_t)(P - 1), "i64 min");
    /* Gather: rank r sends r*37 bytes of value r (rank 0 none). */
    size_t len = (size_t)r * 37;
    uint8_t *blob = malloc(len + 1);
    memset(blob, r & 0xff, len);
    void *all;
    size_t *lens;
    CHECK(am_gather(ctx, blob, len, &all, &lens) == 0, "gather");
    if (r == 0) {
        const uint8_t *p = all;
        for (int i = 0; i < P; i++) {
            CHECK(lens[i] == (size_t)i * 37, "gather length of %d: %zu", i, lens[i]);
            for (size_t k = 0; k < lens[i]; k++)
                if (p[k] != (uint8_t)i) {
                    CHECK(0, "gather byte %zu of PE %d", k, i);
                    break;
                }
            p += lens[i];
        }
        printf("coll: %d PEs: barrier, allreduce sum/min/max, gather ok\n", P);
    } else {
        CHECK(!all && !lens, "gather result outside rank 0");
    }
    free(all);
    free(lens);
    free(blob);
    /* A collective called from a thread blocks that thread only. */
    am_future_t *f;
    am_future_new(ctx, &f);
    double thread_sum = 0;
    CHECK(am_thread_spawn(ctx, coll_thread, &thread_sum, f) == 0, "spawn");
    CHECK(am_wait(ctx, f) == 0, "am_wait");
    CHECK(thread_sum == P, "allreduce from threads gave %g", thread_sum);
    am_future_free(&f);
    return 0;
}

/* ----------------------------------------------------------------- kill */

static int spin_work(am_ctx_t *ctx, void *arg)
{
    (void)arg;
    /* Keep a ring of messages going for ever. */
    static double next;
    if (now_s() < next)
        return 0;
    next = now_s() + 0.01;
    am_send(ctx, (am_rank(ctx) + 1) % am_size(ctx), H_SPIN, "x", 1);
    return 1;
}

static void spin_handler(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)ctx;
    (void)m;
    (void)arg;
}

static void spin_timer(am_ctx_t *ctx, am_timer_t *t, void *arg)
{
    (void)ctx;
    (void)arg;
    am_timer_start(t, 0.01); /* keeps the PE active: never terminates */
}

static int run_kill(am_ctx_t *ctx, int victim)
{
    am_register(ctx, H_SPIN, "spin", spin_handler, NULL);
    am_barrier(ctx);
    am_timer_t *t;
    am_timer_new(ctx, spin_timer, NULL, &t);
    am_timer_start(t, 0.01);
    if (am_rank(ctx) == victim) {
        am_sleep(ctx, 0.3);
        fprintf(stderr, "am_mp: PE %d: killing myself with SIGKILL\n", victim);
        fflush(stderr);
        raise(SIGKILL);
    }
    double t0 = now_s();
    int rc = am_run_until_done(ctx, spin_work, NULL);
    /* Only reached if the default error handler did not exit. */
    CHECK(0, "am_run_until_done returned %s after %.1f s instead of exiting",
          am_strerror(rc), now_s() - t0);
    return 1;
}

/* ----------------------------------------------------------------- busy */

static double busy_end;

static int busy_work(am_ctx_t *ctx, void *arg)
{
    (void)arg;
    static double next;
    double t = now_s();
    if (t > busy_end || t < next)
        return 0;
    next = t + 0.001;
    static uint8_t buf[1024];
    for (int i = 0; i < 8; i++) {
        int dst = (int)(rnd() % (uint64_t)am_size(ctx));
        am_send(ctx, dst, H_BUSY, buf, (size_t)(rnd() % sizeof buf));
    }
    return 1;
}

static void busy_timer(am_ctx_t *ctx, am_timer_t *t, void *arg)
{
    (void)ctx;
    (void)arg;
    if (now_s() < busy_end)
        am_timer_start(t, 0.001); /* keeps the PE active until the end */
}

static int run_busy(am_ctx_t *ctx, const char *dir, int seconds)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/pid-%d", dir, am_rank(ctx));
    FILE *f = fopen(path, "w");
    CHECK(f != NULL, "cannot write %s", path);
    if (f) {
        fprintf(f, "%ld\n", (long)getpid());
        fclose(f);
    }
    am_register(ctx, H_BUSY, "busy", spin_handler, NULL);
    am_barrier(ctx);
    busy_end = now_s() + seconds;
    am_timer_t *t;
    am_timer_new(ctx, busy_timer, NULL, &t);
    am_timer_start(t, 0.001);
    int rc = am_run_until_done(ctx, busy_work, NULL);
    CHECK(rc == 0, "am_run_until_done: %s", am_strerror(rc));
    am_timer_free(&t);
    return 0;
}

/* ------------------------------------------------------------------ zap */

enum { H_ZAP = 12 };

static int zap_got, zap_bad;

static void zap_handler(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)ctx;
    (void)arg;
    uint32_t i;
    if (m->len != sizeof i || m->src != 1 - g_rank) {
        zap_bad++;
        return;
    }
    memcpy(&i, m->data, sizeof i);
    zap_bad += i != (uint32_t)zap_got;
    zap_got++;
}

static int run_zap(am_ctx_t *ctx, const char *dir, int n, double spin)
{
    int r = am_rank(ctx);
    CHECK(am_size(ctx) == 2, "zap wants 2 PEs");
    am_register(ctx, H_ZAP, "zap", zap_handler, NULL);
    am_barrier(ctx);
    char path[4200], tmp[4300];
    if (r == 0) {
        const char *rdv = getenv("AM_RENDEZVOUS"), *job = getenv("AM_JOB");
        const char *k1 = am_curve_key(ctx, 1);
        const char *kr = am_curve_key(ctx, AM_CURVE_RENDEZVOUS);
        snprintf(path, sizeof path, "%s/info", dir);
        snprintf(tmp, sizeof tmp, "%s.tmp", path);
        FILE *f = fopen(tmp, "w");
        CHECK(f != NULL, "cannot write %s", tmp);
        if (f) {
            const char *k0 = am_curve_key(ctx, 0);
            fprintf(f, "%s %s %s %s %s %s %s\n", am_endpoint(ctx, 1),
                    k1 ? k1 : "-", rdv ? rdv : "-", kr ? kr : "-",
                    job ? job : "-", am_endpoint(ctx, 0), k0 ? k0 : "-");
            fclose(f);
            rename(tmp, path);
        }
    }
    /* A PE busy computing does not poll: strangers may come meanwhile. */
    if (r == 1 && spin > 0) {
        double end = now_s() + spin;
        while (now_s() < end)
            ;
    }
    /* The strangers come now; the PEs keep polling. */
    snprintf(path, sizeof path, "%s/go", dir);
    double limit = now_s() + 60;
    while (access(path, F_OK) != 0 && now_s() < limit)
        am_sleep(ctx, 0.02);
    CHECK(access(path, F_OK) == 0, "no %s within 60 s", path);
    for (uint32_t i = 0; i < (uint32_t)n; i++)
        CHECK(am_send(ctx, 1 - r, H_ZAP, &i, sizeof i) == 0, "send %u", i);
    limit = now_s() + 30;
    while (zap_got < n && now_s() < limit)
        am_sleep(ctx, 0.01);
    am_barrier(ctx);
    am_stats_t st;
    am_stats_get(ctx, &st);
    CHECK(zap_got == n && zap_bad == 0, "PE %d got %d of %d messages (%d bad)",
          r, zap_got, n, zap_bad);
    CHECK(st.rejected == 0, "PE %d rejected %llu frames", r,
          (unsigned long long)st.rejected);
    printf("zap: PE %d got its peer's %d messages in order, rejected %llu "
           "frames (curve %s)\n",
           r, zap_got, (unsigned long long)st.rejected,
           am_curve_key(ctx, 0) ? "on" : "off");
    return 0;
}

/* ------------------------------------------------------------ malformed */

/* Sends one message from a fresh DEALER socket. The ROUTER refuses a
 * second connection with a routing id already in use, so each call gets
 * its own id: id[1] is bumped every time. */
static void raw_send(void *zctx, const char *ep, uint8_t *id, size_t idlen,
                     const void *frame, size_t len, int parts)
{
    id[1]++;
    void *s = zmq_socket(zctx, ZMQ_DEALER);
    int linger = 1000;
    zmq_setsockopt(s, ZMQ_LINGER, &linger, sizeof linger);
    zmq_setsockopt(s, ZMQ_ROUTING_ID, id, idlen);
    zmq_connect(s, ep);
    if (parts == 2)
        zmq_send(s, frame, len, ZMQ_SNDMORE);
    zmq_send(s, frame, len, 0);
    zmq_close(s);
}

static void frame_header(uint8_t *f, uint8_t version, uint8_t flags,
                         uint32_t sender, uint32_t len)
{
    memset(f, 0, 24);
    f[0] = 'P';
    f[1] = 'D';
    f[2] = 'R';
    f[3] = 0xA7;
    f[4] = version;
    f[5] = flags;
    put32(f + 8, sender);
    put32(f + 12, len);
}

static int run_malformed(am_ctx_t *ctx, int stranger)
{
    int r = am_rank(ctx);
    am_barrier(ctx);
    int expected = 0;
    if (r == 0) {
        const char *ep = am_endpoint(ctx, 1);
        void *zctx = zmq_ctx_new();
        uint8_t f[96]; /* room for the three-frame bundle of case 8 */
        uint8_t bad_id[5] = {'P', 99, 0, 0, 0}; /* rank 99: not in the job */
        uint8_t other_id[2] = {'X', 'A'};
        /* 1: truncated */
        raw_send(zctx, ep, bad_id, 5, (const uint8_t *)"abc", 3, 1);
        /* 2: bad magic */
        memset(f, 'z', sizeof f);
        raw_send(zctx, ep, bad_id, 5, f, 30, 1);
        /* 3: another version */
        frame_header(f, 9, 0, 99, 0);
        raw_send(zctx, ep, bad_id, 5, f, 24, 1);
        /* 4: unknown flags */
        frame_header(f, 1, 0x80, 99, 0);
        raw_send(zctx, ep, bad_id, 5, f, 24, 1);
        /* 5: length mismatch */
        frame_header(f, 1, 0, 99, 10);
        raw_send(zctx, ep, bad_id, 5, f, 24, 1);
        /* 6: well-formed, but from a routing id outside the job */
        frame_header(f, 1, 0, 99, 0);
        raw_send(zctx, ep, bad_id, 5, f, 24, 1);
        raw_send(zctx, ep, other_id, 2, f, 24, 1);
        /* 7: two parts */
        raw_send(zctx, ep, bad_id, 5, f, 24, 2);
        /* 8: a bundle of two frames and a cut-off third: its first frame
         * is rejected (the routing id), and the rest goes with it, so it
         * counts once */
        frame_header(f, 1, 0, 99, 0);
        frame_header(f + 24, 1, 0, 99, 0);
        frame_header(f + 48, 1, 0, 99, 8);
        raw_send(zctx, ep, bad_id, 5, f, 60, 1);
        zmq_ctx_term(zctx);
    }
    if (r == 1) {
        expected = 9;
        am_stats_t st;
        double limit = now_s() + 10;
        do {
            am_sleep(ctx, 0.02);
            am_stats_get(ctx, &st);
        } while (st.rejected < (uint64_t)expected && now_s() < limit);
        if (stranger) {
            /* Give stray frames a chance to arrive before concluding. */
            am_sleep(ctx, 1.0);
            am_stats_get(ctx, &st);
            printf("stranger: PE 1 counted %llu frames from sockets outside "
                   "the job (curve %s)\n",
                   (unsigned long long)st.rejected,
                   am_curve_key(ctx, 0) ? "on" : "off");
        } else {
            CHECK(st.rejected == (uint64_t)expected,
                  "PE 1 rejected %llu frames, expected %d",
                  (unsigned long long)st.rejected, expected);
            printf("malformed: PE 1 rejected %llu malformed frames and lives\n",
                   (unsigned long long)st.rejected);
        }
    }
    am_barrier(ctx);
    return 0;
}

/* Pretends to be PE 1 of a job speaking wire protocol VERSION: connects to
 * rank 0's ENDPOINT and says hello. Runs without libam. */
static int fake_peer(const char *endpoint, int version)
{
    void *zctx = zmq_ctx_new();
    void *s = zmq_socket(zctx, ZMQ_DEALER);
    uint8_t id[5] = {'P', 1, 0, 0, 0};
    int linger = 2000;
    zmq_setsockopt(s, ZMQ_ROUTING_ID, id, sizeof id);
    zmq_setsockopt(s, ZMQ_LINGER, &linger, sizeof linger);
    zmq_connect(s, endpoint);
    uint8_t f[24];
    frame_header(f, (uint8_t)version, 1, 1, 0);
    f[6] = 1; /* HELLO */
    int rc = zmq_send(s, f, sizeof f, 0);
    zmq_close(s);
    zmq_ctx_term(zctx);
    return rc == (int)sizeof f ? 0 : 1;
}

/* The processors each thread of this process may run on, from
 * /proc/self/task/ * /status ("Cpus_allowed_list:"); the same for all:
 * that list, else "mixed". */
static int run_affinity(am_ctx_t *ctx)
{
    char first[256] = "", line[512];
    int nthreads = 0, mixed = 0;
    DIR *d = opendir("/proc/self/task");
    if (!d) {
        fprintf(stderr, "am_mp: PE %d: /proc/self/task: %s\n", g_rank, strerror(errno));
        return 1;
    }
    struct dirent *e;
    while ((e = readdir(d))) {
        if (e->d_name[0] == '.')
            continue;
        char path[300];
        snprintf(path, sizeof path, "/proc/self/task/%s/status", e->d_name);
        FILE *f = fopen(path, "r");
        if (!f)
            continue;
        while (fgets(line, sizeof line, f))
            if (!strncmp(line, "Cpus_allowed_list:", 18)) {
                char cpus[256];
                if (sscanf(line + 18, " %255s", cpus) == 1) {
                    if (!nthreads++)
                        snprintf(first, sizeof first, "%s", cpus);
                    else if (strcmp(first, cpus))
                        mixed = 1;
                }
            }
        fclose(f);
    }
    closedir(d);
    printf("PE %d cpus %s threads %d\n", g_rank, mixed ? "mixed" : first, nthreads);
    fflush(stdout);
    return am_barrier(ctx) ? 1 : 0;
}

/* ----------------------------------------------------------------- main */

int main(int argc, char **argv)
{
    if (argc == 4 && !strcmp(argv[1], "fake-peer"))
        return fake_peer(argv[2], atoi(argv[3]));
    if (argc >= 3 && !strcmp(argv[1], "sleep")) {
        sleep((unsigned)atoi(argv[2]));
        return 0;
    }
    am_ctx_t *ctx;
    int rc = am_init(&argc, &argv, NULL, &ctx);
    if (rc) {
        fprintf(stderr, "am_mp: am_init: %s\n", am_strerror(rc));
        return 1;
    }
    g_rank = am_rank(ctx);
    rng_state = mix((uint64_t)g_rank * 7919 + 17);
    /* Drop tag=... arguments. */
    int n = 1;
    for (int i = 1; i < argc; i++)
        if (strncmp(argv[i], "tag=", 4))
            argv[n++] = argv[i];
    argc = n;
    const char *mode = argc > 1 ? argv[1] : "";
    int arg1 = argc > 2 ? atoi(argv[2]) : 0, arg2 = argc > 3 ? atoi(argv[3]) : 0;
    if (!strcmp(mode, "idle"))
        rc = 0; /* init and finalize only */
    else if (!strcmp(mode, "storm"))
        rc = run_storm(ctx, arg1 > 0 ? arg1 : 100, arg2 > 0 ? arg2 : 1000);
    else if (!strcmp(mode, "term"))
        rc = run_term(ctx, arg1 > 0 ? arg1 : 4, arg2 > 0 ? arg2 : 6);
    else if (!strcmp(mode, "rpc"))
        rc = run_rpc(ctx);
    else if (!strcmp(mode, "counts"))
        rc = run_counts(ctx);
    else if (!strcmp(mode, "rtt"))
        rc = run_rtt(ctx, arg1 > 0 ? arg1 : 50);
    else if (!strcmp(mode, "flush"))
        rc = run_flush(ctx);
    else if (!strcmp(mode, "coll"))
        rc = run_coll(ctx);
    else if (!strcmp(mode, "affinity"))
        rc = run_affinity(ctx);
    else if (!strcmp(mode, "kill"))
        rc = run_kill(ctx, arg1);
    else if (!strcmp(mode, "wake"))
        rc = run_wake(ctx, arg1 > 0 ? arg1 : 20);
    else if (!strcmp(mode, "killfull"))
        rc = run_killfull(ctx, arg1 > 0 ? arg1 : 16384, arg2);
    else if (!strcmp(mode, "busy") && argc > 3)
        rc = run_busy(ctx, argv[2], arg2);
    else if (!strcmp(mode, "flood") || !strcmp(mode, "flood-pair"))
        rc = run_flood(ctx, !strcmp(mode, "flood-pair"), arg1 > 0 ? arg1 : 1000,
                       arg2 > 0 ? arg2 : 1024, argc > 4 ? atoi(argv[4]) : 4,
                       argc > 5 ? atol(argv[5]) : 0);
    else if (!strcmp(mode, "malformed"))
        rc = run_malformed(ctx, 0);
    else if (!strcmp(mode, "stranger"))
        rc = run_malformed(ctx, 1);
    else if (!strcmp(mode, "zap") && argc > 3)
        rc = run_zap(ctx, argv[2], arg2, argc > 4 ? atof(argv[4]) : 0);
    else {
        fprintf(stderr, "usage: am_mp idle|storm|term|rpc|counts|rtt|flush|coll|affinity|kill|"
                        "wake|killfull|"
                        "busy|flood|flood-pair|malformed|stranger|zap [ARGS]\n");
        rc = 2;
    }
    double fin_start = now_s();
    int frc = am_finalize(&ctx);
    if (!strcmp(mode, "idle")) {
        /* How long am_finalize held this PE: what am-latency.sh bounds,
         * apart from the time the job took to start. */
        printf("PE %d finalize_s %.3f\n", g_rank, now_s() - fin_start);
        fflush(stdout);
    }
    if (frc) {
        fprintf(stderr, "am_mp: PE %d: am_finalize: %s\n", g_rank,
                am_strerror(frc));
        failures++;
    }
    const char *linger = getenv("AM_MP_LINGER_MS");
    if (linger && atol(linger) > 0) {
        long ms = atol(linger) > 10000 ? 10000 : atol(linger);
        struct timespec ts = {ms / 1000, (ms % 1000) * 1000000L};
        while (nanosleep(&ts, &ts) != 0 && errno == EINTR)
            ;
    }
    if (rc == 2)
        return 2;
    return rc || failures ? 1 : 0;
}
