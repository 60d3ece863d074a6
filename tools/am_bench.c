/*
 * am_bench.c -- measurements behind tools/bench-runtime (not a test).
 *
 *   am_bench zmq-pingpong ipc|tcp N BYTES   raw ZeroMQ ROUTER/ROUTER ping-
 *                                           pong between two forked
 *                                           processes, blocking receives;
 *                                           median of N round trips
 *   am_bench zmq-rate ipc|tcp N BYTES       raw ZeroMQ one-way message rate
 *   am_bench am-pingpong N BYTES            (under am-run -n 2) AM round
 *                                           trips; the waiting PE blocks in
 *                                           libevent between messages;
 *                                           median of N round trips
 *   am_bench am-rate N BYTES                (under am-run -n 2) AM one-way
 *                                           message rate
 *   am_bench switch N                       thread switch cost, for each
 *                                           switch implementation built
 *   am_bench spawn N                        spawn + run + join of a thread
 *
 * Each prints one line "key value ..." for the script to pick up. The raw
 * ZeroMQ runs use the socket options libam uses (ROUTER_MANDATORY,
 * unlimited high-water marks, routing ids, one connection made with
 * ZMQ_CONNECT_ROUTING_ID) and send frames of BYTES + 24 bytes, the size of
 * an AM with a BYTES payload, so both sides move the same bytes.
 */
#include "config.h"

#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>
#include <zmq.h>

#include "am.h"

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Median of n samples (sorts them). Single round trips are timed one by
 * one and summarised by their median, which a busy shared machine
 * disturbs far less than a mean: a round trip during which the process
 * was preempted is an outlier, not a shift. */
static double median(double *v, long n)
{
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : (v[n / 2 - 1] + v[n / 2]) / 2;
}

static void die(const char *what)
{
    fprintf(stderr, "am_bench: %s: %s\n", what, zmq_strerror(zmq_errno()));
    exit(1);
}

/* ------------------------------------------------------------ raw ZeroMQ */

static void *raw_socket(void *zctx, const char *id)
{
    void *s = zmq_socket(zctx, ZMQ_ROUTER);
    int one = 1, zero = 0, linger = 1000;
    zmq_setsockopt(s, ZMQ_ROUTING_ID, id, strlen(id));
    zmq_setsockopt(s, ZMQ_ROUTER_MANDATORY, &one, sizeof one);
    zmq_setsockopt(s, ZMQ_SNDHWM, &zero, sizeof zero);
    zmq_setsockopt(s, ZMQ_RCVHWM, &zero, sizeof zero);
    zmq_setsockopt(s, ZMQ_LINGER, &linger, sizeof linger);
    return s;
}

static void raw_send(void *s, const char *to, const void *buf, size_t len)
{
    if (zmq_send(s, to, strlen(to), ZMQ_SNDMORE) < 0 ||
        zmq_send(s, buf, len, 0) < 0)
        die("zmq_send");
}

static void raw_recv(void *s, void *buf, size_t cap)
{
    char id[16];
    if (zmq_recv(s, id, sizeof id, 0) < 0 || zmq_recv(s, buf, cap, 0) < 0)
        die("zmq_recv");
}

/* mode 0: ping-pong, 1: one-way rate. */
static int raw_bench(int rate, const char *transport, long n, size_t bytes)
{
    char ep[256], dir[] = "/tmp/am-bench-XXXXXX";
    int tcp = !strcmp(transport, "tcp");
    void *zctx = zmq_ctx_new();
    void *srv = raw_socket(zctx, "P0");
    if (tcp) {
        if (zmq_bind(srv, "tcp://127.0.0.1:0"))
            die("bind");
    } else {
        if (!mkdtemp(dir))
            return 1;
        snprintf(ep, sizeof ep, "ipc://%s/0.sock", dir);
        if (zmq_bind(srv, ep))
            die("bind");
    }
    size_t len = sizeof ep;
    zmq_getsockopt(srv, ZMQ_LAST_ENDPOINT, ep, &len);
    size_t frame = bytes + 24;
    char *buf = calloc(1, frame);
    fflush(NULL);
    pid_t pid = fork();
    if (pid == 0) {
        /* ZeroMQ contexts do not survive fork: the child makes its own. */
        void *cctx = zmq_ctx_new();
        void *cli = raw_socket(cctx, "P1");
        zmq_setsockopt(cli, ZMQ_CONNECT_ROUTING_ID, "P0", 2);
        if (zmq_connect(cli, ep))
            die("connect");
        raw_send(cli, "P0", "hello", 5);
        if (rate) {
            for (long i = 0; i < n; i++)
                raw_recv(cli, buf, frame);
            raw_send(cli, "P0", buf, frame);
        } else {
            for (long i = 0; i < n + 100; i++) {
                raw_recv(cli, buf, frame);
                raw_send(cli, "P0", buf, frame);
            }
        }
        zmq_close(cli);
        zmq_ctx_term(cctx);
        _exit(0);
    }
    raw_recv(srv, buf, frame); /* hello: the route to P1 exists now */
    double t0 = 0;
    if (rate) {
        t0 = now();
        for (long i = 0; i < n; i++)
            raw_send(srv, "P1", buf, frame);
        raw_recv(srv, buf, frame);
        double dt = now() - t0;
        printf("raw_rate %.0f\n", n / dt);
    } else {
        double *rtt = malloc(sizeof *rtt * (size_t)n);
        for (long i = 0; i < n + 100; i++) {
            t0 = now();
            raw_send(srv, "P1", buf, frame);
            raw_recv(srv, buf, frame);
            if (i >= 100) /* after 100 warm-up rounds */
                rtt[i - 100] = now() - t0;
        }
        printf("raw_rtt_us %.2f\n", median(rtt, n) * 1e6);
        free(rtt);
    }
    int status;
    waitpid(pid, &status, 0);
    zmq_close(srv);
    zmq_ctx_term(zctx);
    if (!tcp) {
        char path[300];
        snprintf(path, sizeof path, "%s/0.sock", dir);
        unlink(path);
        rmdir(dir);
    }
    free(buf);
    return 0;
}

/* ------------------------------------------------------------ AM side */

enum { H_PING = 1, H_PONG = 2, H_DATA = 3, H_ACK = 4 };

static long counter;

static void ping(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)arg;
    am_send(ctx, m->src, H_PONG, m->data, m->len);
}

static void count(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)ctx;
    (void)m;
    (void)arg;
    counter++;
}

static long rate_n;

static void data(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)arg;
    if (++counter == rate_n)
        am_send(ctx, m->src, H_ACK, NULL, 0);
}

/* Waits for counter to reach want: poll, and block in libevent when
 * nothing came (the idle path a real PE takes). */
static void wait_count(am_ctx_t *ctx, long want)
{
    while (counter < want) {
        am_poll(ctx);
        if (counter < want)
            am_idle(ctx, -1);
    }
}

static int am_bench(int rate, int argc, char **argv)
{
    am_ctx_t *ctx;
    if (am_init(&argc, &argv, NULL, &ctx))
        return 1;
    if (am_size(ctx) != 2) {
        fprintf(stderr, "am_bench: run me under am-run -n 2\n");
        am_finalize(&ctx);
        return 1;
    }
    long n = atol(argv[2]);
    size_t bytes = (size_t)atol(argv[3]);
    char *buf = calloc(1, bytes + 1);
    am_register(ctx, H_PING, "ping", ping, NULL);
    am_register(ctx, H_PONG, "pong", count, NULL);
    am_register(ctx, H_DATA, "data", data, NULL);
    am_register(ctx, H_ACK, "ack", count, NULL);
    rate_n = n;
    am_barrier(ctx);
    if (am_rank(ctx) == 0 && !rate) {
        double *rtt = malloc(sizeof *rtt * (size_t)n);
        for (long i = 0; i < n + 100; i++) {
            double t0 = now();
            am_send(ctx, 1, H_PING, buf, bytes);
            wait_count(ctx, i + 1);
            if (i >= 100)
                rtt[i - 100] = now() - t0;
        }
        printf("am_rtt_us %.2f\n", median(rtt, n) * 1e6);
        free(rtt);
    } else if (am_rank(ctx) == 0) {
        double t0 = now();
        for (long i = 0; i < n; i++) {
            am_send(ctx, 1, H_DATA, buf, bytes);
            /* Let the loop flush now and then, as a real PE would. */
            if (i % 256 == 255)
                am_poll(ctx);
        }
        wait_count(ctx, 1);
        printf("am_rate %.0f\n", n / (now() - t0));
    }
    am_run_until_done(ctx, NULL, NULL);
    free(buf);
    return am_finalize(&ctx) ? 1 : 0;
}

/* ---------------------------------------------------------- threads */

static void yielder(am_ctx_t *ctx, void *arg)
{
    long n = *(long *)arg;
    for (long i = 0; i < n; i++)
        am_yield(ctx);
}

static void nothing(am_ctx_t *ctx, void *arg)
{
    (void)ctx;
    (void)arg;
}

static int thread_bench(int spawn, long n)
{
    static const struct {
        int mode;
        const char *name;
    } modes[] = {{AM_SWITCH_UCONTEXT, "ucontext"}, {AM_SWITCH_FAST, "fast"}};
    for (size_t k = 0; k < 2; k++) {
        am_opts_t o = AM_OPTS_INIT;
        o.switch_mode = modes[k].mode;
        am_ctx_t *ctx;
        /* Unset launcher variables: this is a one-PE measurement. */
        if (am_init(NULL, NULL, &o, &ctx)) {
            printf("%s_%s_ns unavailable\n", spawn ? "spawn" : "switch",
                   modes[k].name);
            continue;
        }
        double t0, dt;
        if (!spawn) {
            am_thread_spawn(ctx, yielder, &n, NULL);
            t0 = now();
            while (am_run_threads(ctx) > 0)
                ;
            dt = now() - t0;
            /* Each yield is two switches: into the thread and back out. */
            printf("switch_%s_ns %.1f\n", modes[k].name, dt / (2.0 * n) * 1e9);
        } else {
            am_future_t *done;
            am_future_new(ctx, &done);
            t0 = now();
            for (long i = 0; i < n; i++) {
                am_future_reset(done);
                am_thread_spawn(ctx, nothing, NULL, done);
                am_run_threads(ctx);
                if (!am_future_ready(done))
                    return 1;
            }
            dt = now() - t0;
            am_future_free(&done);
            printf("spawn_%s_ns %.1f\n", modes[k].name, dt / n * 1e9);
        }
        am_finalize(&ctx);
    }
    return 0;
}

int main(int argc, char **argv)
{
    const char *mode = argc > 1 ? argv[1] : "";
    if (argc == 5 && !strcmp(mode, "zmq-pingpong"))
        return raw_bench(0, argv[2], atol(argv[3]), (size_t)atol(argv[4]));
    if (argc == 5 && !strcmp(mode, "zmq-rate"))
        return raw_bench(1, argv[2], atol(argv[3]), (size_t)atol(argv[4]));
    if (argc >= 4 && !strcmp(mode, "am-pingpong"))
        return am_bench(0, argc, argv);
    if (argc >= 4 && !strcmp(mode, "am-rate"))
        return am_bench(1, argc, argv);
    if (argc == 3 && !strcmp(mode, "switch"))
        return thread_bench(0, atol(argv[2]));
    if (argc == 3 && !strcmp(mode, "spawn"))
        return thread_bench(1, atol(argv[2]));
    fprintf(stderr, "usage: am_bench zmq-pingpong|zmq-rate ipc|tcp N BYTES\n"
                    "       am_bench am-pingpong|am-rate N BYTES (under am-run)\n"
                    "       am_bench switch|spawn N\n");
    return 2;
}
