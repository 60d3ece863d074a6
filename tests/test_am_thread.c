/* Unit tests of libam's cooperative threads, futures, conditions and
 * timers, in a one-PE context. Every scheduler test runs twice: with
 * glibc's swapcontext and with the fast switch (when it was built). */
#include "config.h"

#include <fenv.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "am.h"
#include "am_int.h"
#include "unit.h"

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

#ifdef AM_FAST_SWITCH
static const int modes[] = {AM_SWITCH_UCONTEXT, AM_SWITCH_FAST};
#else
static const int modes[] = {AM_SWITCH_UCONTEXT};
#endif
#define NMODES ((int)(sizeof modes / sizeof modes[0]))

/* A one-PE context using switch mode number i (loop tests pass _i). */
static am_ctx_t *open_ctx(int i)
{
    am_opts_t o = AM_OPTS_INIT;
    o.switch_mode = modes[i % NMODES];
    am_ctx_t *ctx = NULL;
    ck_assert_int_eq(am_init(NULL, NULL, &o, &ctx), 0);
    ck_assert_int_eq(am_size(ctx), 1);
    ck_assert_int_eq(am_rank(ctx), 0);
    return ctx;
}

static void close_ctx(am_ctx_t **ctx)
{
    ck_assert_int_eq(am_finalize(ctx), 0);
    ck_assert_ptr_null(*ctx);
}

/* Runs threads until none is runnable (bounded). */
static void run_all(am_ctx_t *ctx)
{
    for (int i = 0; i < 100000 && am_run_threads(ctx) > 0; i++)
        ;
}

/* ------------------------------------------------------------ scheduler */

static char trace[256];
static size_t ntrace;

static void tracer(am_ctx_t *ctx, void *arg)
{
    char c = *(const char *)arg;
    for (int i = 0; i < 3; i++) {
        trace[ntrace++] = c;
        am_yield(ctx);
    }
}

START_TEST(yield_is_round_robin)
{
    am_ctx_t *ctx = open_ctx(_i);
    ntrace = 0;
    ck_assert_int_eq(am_in_thread(ctx), 0);
    static char names[] = "abc";
    ck_assert_int_eq(am_thread_spawn(ctx, tracer, names, NULL), 0);
    ck_assert_int_eq(am_thread_spawn(ctx, tracer, names + 1, NULL), 0);
    ck_assert_int_eq(am_thread_spawn(ctx, tracer, names + 2, NULL), 0);
    ck_assert_uint_eq(am_thread_count(ctx), 3);
    /* One round: each thread runs once, until its first yield. */
    ck_assert_int_eq(am_run_threads(ctx), 3);
    trace[ntrace] = '\0';
    ck_assert_str_eq(trace, "abc");
    run_all(ctx);
    trace[ntrace] = '\0';
    ck_assert_str_eq(trace, "abcabcabc");
    ck_assert_uint_eq(am_thread_count(ctx), 0);
    close_ctx(&ctx);
}
END_TEST

static void spawner(am_ctx_t *ctx, void *arg)
{
    int *n = arg;
    ck_assert_int_eq(am_in_thread(ctx), 1);
    if (++*n < 50)
        ck_assert_int_eq(am_thread_spawn(ctx, spawner, n, NULL), 0);
}

START_TEST(threads_spawn_threads_and_stacks_are_reused)
{
    am_ctx_t *ctx = open_ctx(_i);
    int n = 0;
    ck_assert_int_eq(am_thread_spawn(ctx, spawner, &n, NULL), 0);
    run_all(ctx);
    ck_assert_int_eq(n, 50);
    /* Many short threads one after another: the pool hands the same few
     * stacks out again, so this is cheap and maps no new memory. */
    am_stats_t st;
    for (int round = 0; round < 2000; round++) {
        n = 49;
        ck_assert_int_eq(am_thread_spawn(ctx, spawner, &n, NULL), 0);
        run_all(ctx);
    }
    am_stats_get(ctx, &st);
    ck_assert_uint_eq(st.threads_spawned, 50 + 2000);
    ck_assert_uint_le(ctx->sched.nfree_stacks, 2);
    close_ctx(&ctx);
}
END_TEST

static void deep(am_ctx_t *ctx, void *arg)
{
    /* Uses most of a 64 KiB stack legitimately: must not fault. */
    volatile char buf[40 * 1024];
    for (size_t i = 0; i < sizeof buf; i += 512)
        buf[i] = (char)i;
    *(int *)arg = buf[512];
    am_yield(ctx);
}

START_TEST(a_thread_may_use_its_stack)
{
    am_ctx_t *ctx = open_ctx(_i);
    int v = 0;
    ck_assert_int_eq(am_thread_spawn(ctx, deep, &v, NULL), 0);
    run_all(ctx);
    ck_assert_int_eq(v, (char)512);
    close_ctx(&ctx);
}
END_TEST

static int recurse(int n)
{
    volatile char pad[256];
    pad[0] = (char)n;
    return n > 0 ? recurse(n + 1) + pad[0] : 0;
}

static void overflow(am_ctx_t *ctx, void *arg)
{
    (void)ctx;
    (void)arg;
    recurse(1);
}

/* Writes the byte right below the thread's usable stack. */
static void poke_guard(am_ctx_t *ctx, void *arg)
{
    (void)arg;
    volatile char *below = (char *)ctx->sched.current->stack->lo - 1;
    *below = 1;
}

START_TEST(the_page_below_a_stack_is_a_guard)
{
    pid_t pid = fork();
    ck_assert_int_ge(pid, 0);
    if (pid == 0) {
        am_ctx_t *ctx = open_ctx(_i);
        am_thread_spawn(ctx, poke_guard, NULL, NULL);
        am_run_threads(ctx);
        _exit(0); /* reached only if the page was writable */
    }
    int status;
    ck_assert_int_eq(waitpid(pid, &status, 0), pid);
#ifdef AM_ASAN
    ck_assert(WIFSIGNALED(status) || (WIFEXITED(status) && WEXITSTATUS(status)));
#else
    ck_assert(WIFSIGNALED(status) && WTERMSIG(status) == SIGSEGV);
#endif
}
END_TEST

START_TEST(stack_overflow_hits_the_guard_page)
{
    /* In a child: the overflow must kill it with SIGSEGV (the guard page),
     * not scribble over the memory below the stack. Under AddressSanitizer
     * its SEGV handler reports the stack overflow and exits instead. */
    pid_t pid = fork();
    ck_assert_int_ge(pid, 0);
    if (pid == 0) {
        am_ctx_t *ctx = open_ctx(_i);
        am_thread_spawn(ctx, overflow, NULL, NULL);
        am_run_threads(ctx);
        _exit(0); /* not reached */
    }
    int status;
    ck_assert_int_eq(waitpid(pid, &status, 0), pid);
#ifdef AM_ASAN
    ck_assert(WIFSIGNALED(status) || (WIFEXITED(status) && WEXITSTATUS(status)));
#else
    ck_assert(WIFSIGNALED(status));
    ck_assert(WTERMSIG(status) == SIGSEGV || WTERMSIG(status) == SIGBUS);
#endif
}
END_TEST

static void fp_thread(am_ctx_t *ctx, void *arg)
{
    int *ok = arg;
    fesetround(FE_UPWARD);
    am_yield(ctx);
    *ok = fegetround() == FE_UPWARD;
    fesetround(FE_TONEAREST);
}

START_TEST(floating_point_control_is_per_thread)
{
    am_ctx_t *ctx = open_ctx(_i);
    int ok = 0;
    ck_assert_int_eq(fegetround(), FE_TONEAREST);
    am_thread_spawn(ctx, fp_thread, &ok, NULL);
    am_run_threads(ctx);
    ck_assert_int_eq(fegetround(), FE_TONEAREST);
    run_all(ctx);
    ck_assert_int_eq(ok, 1);
    close_ctx(&ctx);
}
END_TEST

START_TEST(bad_arguments)
{
    am_ctx_t *ctx = open_ctx(0);
    ck_assert_int_eq(am_thread_spawn(ctx, NULL, NULL, NULL), AM_EINVAL);
    ck_assert_int_eq(am_thread_spawn(NULL, tracer, NULL, NULL), AM_EINVAL);
    /* Not in a thread: am_yield runs the threads instead, am_call refuses. */
    ck_assert_int_eq(am_yield(ctx), 0);
    void *r;
    size_t rl;
    ck_assert_int_eq(am_call(ctx, 0, 1, "x", 1, &r, &rl), AM_ESTATE);
    close_ctx(&ctx);
#ifndef AM_FAST_SWITCH
    am_opts_t o = AM_OPTS_INIT;
    o.switch_mode = AM_SWITCH_FAST;
    ck_assert_int_eq(am_init(NULL, NULL, &o, &ctx), AM_EINVAL);
#endif
}
END_TEST

/* ------------------------------------------------------------- futures */

typedef struct waiter_arg {
    am_future_t *f;
    int woke;
    void *value;
} waiter_arg;

static void future_waiter(am_ctx_t *ctx, void *arg)
{
    waiter_arg *w = arg;
    ck_assert_int_eq(am_wait(ctx, w->f), 0);
    w->woke = 1;
    w->value = am_future_value(w->f);
}

static void future_setter(am_ctx_t *ctx, void *arg)
{
    am_yield(ctx);
    am_yield(ctx);
    ck_assert_int_eq(am_future_set(arg, (void *)0x1234), 0);
}

START_TEST(future_wakes_every_waiter_once)
{
    am_ctx_t *ctx = open_ctx(_i);
    am_future_t *f;
    ck_assert_int_eq(am_future_new(ctx, &f), 0);
    waiter_arg w[3];
    for (int i = 0; i < 3; i++) {
        w[i] = (waiter_arg){f, 0, NULL};
        am_thread_spawn(ctx, future_waiter, &w[i], NULL);
    }
    am_run_threads(ctx);
    for (int i = 0; i < 3; i++)
        ck_assert_int_eq(w[i].woke, 0);
    ck_assert_int_eq(am_future_ready(f), 0);
    ck_assert_ptr_null(am_future_value(f));
    /* Waiting on an unset future from the main context drives the loop,
     * which runs the setter thread. */
    am_thread_spawn(ctx, future_setter, f, NULL);
    ck_assert_int_eq(am_wait(ctx, f), 0);
    ck_assert_ptr_eq(am_future_value(f), (void *)0x1234);
    run_all(ctx);
    for (int i = 0; i < 3; i++) {
        ck_assert_int_eq(w[i].woke, 1);
        ck_assert_ptr_eq(w[i].value, (void *)0x1234);
    }
    ck_assert_int_eq(am_future_set(f, NULL), AM_ESTATE);
    ck_assert_int_eq(am_future_reset(f), 0);
    ck_assert_int_eq(am_future_ready(f), 0);
    am_future_free(&f);
    ck_assert_ptr_null(f);
    close_ctx(&ctx);
}
END_TEST

static void noop_thread(am_ctx_t *ctx, void *arg)
{
    (void)ctx;
    ++*(int *)arg;
}

START_TEST(join_a_thread_through_its_future)
{
    am_ctx_t *ctx = open_ctx(_i);
    am_future_t *done;
    am_future_new(ctx, &done);
    int n = 0;
    for (int i = 0; i < 100; i++) {
        am_future_reset(done);
        ck_assert_int_eq(am_thread_spawn(ctx, noop_thread, &n, done), 0);
        ck_assert_int_eq(am_wait(ctx, done), 0);
        ck_assert_int_eq(n, i + 1);
    }
    am_future_free(&done);
    close_ctx(&ctx);
}
END_TEST

static int cond_value;

static void cond_waiter(am_ctx_t *ctx, void *arg)
{
    am_cond_t *c = arg;
    while (cond_value == 0)
        ck_assert_int_eq(am_cond_wait(ctx, c), 0);
    cond_value++;
}

START_TEST(condition_signal_and_broadcast)
{
    am_ctx_t *ctx = open_ctx(_i);
    am_cond_t *c;
    ck_assert_int_eq(am_cond_new(ctx, &c), 0);
    cond_value = 0;
    for (int i = 0; i < 4; i++)
        am_thread_spawn(ctx, cond_waiter, c, NULL);
    run_all(ctx);
    ck_assert_uint_eq(am_thread_count(ctx), 4);
    cond_value = 1;
    am_cond_signal(c);
    run_all(ctx);
    ck_assert_int_eq(cond_value, 2);
    ck_assert_uint_eq(am_thread_count(ctx), 3);
    am_cond_broadcast(c);
    run_all(ctx);
    ck_assert_int_eq(cond_value, 5);
    ck_assert_uint_eq(am_thread_count(ctx), 0);
    am_cond_free(&c);
    close_ctx(&ctx);
}
END_TEST

/* ---------------------------------------------------------------- timers */

typedef struct tick {
    int fired;
    double at;
    int wait_rc;
    int self_free;
} tick;

static void on_tick(am_ctx_t *ctx, am_timer_t *t, void *arg)
{
    tick *k = arg;
    k->fired++;
    k->at = now();
    /* Blocking from a callback is refused. */
    am_future_t *f;
    am_future_new(ctx, &f);
    k->wait_rc = am_wait(ctx, f);
    am_future_free(&f);
    if (k->self_free)
        am_timer_free(&t);
}

START_TEST(timer_fires_once_after_its_delay)
{
    am_ctx_t *ctx = open_ctx(0);
    tick k = {0, 0, 0, 0};
    am_timer_t *t;
    ck_assert_int_eq(am_timer_new(ctx, on_tick, &k, &t), 0);
    double t0 = now();
    ck_assert_int_eq(am_timer_start(t, 0.02), 0);
    am_sleep(ctx, 0.06);
    ck_assert_int_eq(k.fired, 1);
    ck_assert(k.at - t0 >= 0.02);
    ck_assert_int_eq(k.wait_rc, AM_ESTATE);
    /* Stopped before it is due: never fires. */
    am_timer_start(t, 0.01);
    am_timer_stop(t);
    am_sleep(ctx, 0.03);
    ck_assert_int_eq(k.fired, 1);
    /* Re-armed while armed: fires once, at the later time. */
    am_timer_start(t, 0.005);
    t0 = now();
    am_timer_start(t, 0.02);
    am_sleep(ctx, 0.05);
    ck_assert_int_eq(k.fired, 2);
    ck_assert(k.at - t0 >= 0.02);
    ck_assert_int_eq(am_timer_start(t, -1), AM_EINVAL);
    am_timer_free(&t);
    ck_assert_ptr_null(t);
    close_ctx(&ctx);
}
END_TEST

START_TEST(timer_may_free_itself)
{
    am_ctx_t *ctx = open_ctx(0);
    tick k = {0, 0, 0, 1};
    am_timer_t *t;
    am_timer_new(ctx, on_tick, &k, &t);
    am_timer_start(t, 0.001);
    am_sleep(ctx, 0.02);
    ck_assert_int_eq(k.fired, 1);
    close_ctx(&ctx);
}
END_TEST

typedef struct sleeper {
    double delay;
    double woke_at;
    int order;
} sleeper;

static int wake_order;

static void sleeper_thread(am_ctx_t *ctx, void *arg)
{
    sleeper *s = arg;
    ck_assert_int_eq(am_sleep(ctx, s->delay), 0);
    s->woke_at = now();
    s->order = wake_order++;
}

static void counter_thread(am_ctx_t *ctx, void *arg)
{
    long *n = arg;
    double end = now() + 0.05;
    while (now() < end) {
        ++*n;
        am_yield(ctx);
    }
}

START_TEST(sleeping_threads_do_not_block_the_pe)
{
    am_ctx_t *ctx = open_ctx(_i);
    /* Random back-off style: sleepers wake in deadline order, while another
     * thread keeps running. */
    sleeper s[5] = {{0.030, 0, 0}, {0.010, 0, 0}, {0.040, 0, 0},
                    {0.001, 0, 0}, {0.020, 0, 0}};
    wake_order = 0;
    long spins = 0;
    double t0 = now();
    for (int i = 0; i < 5; i++)
        am_thread_spawn(ctx, sleeper_thread, &s[i], NULL);
    am_thread_spawn(ctx, counter_thread, &spins, NULL);
    ck_assert_int_eq(am_run_until_done(ctx, NULL, NULL), 0);
    ck_assert_uint_eq(am_thread_count(ctx), 0);
    static const int expect[5] = {3, 1, 4, 0, 2};
    for (int i = 0; i < 5; i++) {
        ck_assert_int_eq(s[i].order, expect[i]);
        ck_assert(s[i].woke_at - t0 >= s[i].delay);
    }
    ck_assert(spins > 100);
    close_ctx(&ctx);
}
END_TEST

START_TEST(idle_blocks_instead_of_spinning)
{
    am_ctx_t *ctx = open_ctx(0);
    /* Nothing to do for 50 ms: am_sleep from the main context blocks in
     * libevent, which shows up as idle time, not as polls. */
    am_stats_t st;
    am_sleep(ctx, 0.05);
    am_stats_get(ctx, &st);
    ck_assert(st.idle_s >= 0.04);
    ck_assert_uint_lt(st.polls, 50);
    close_ctx(&ctx);
}
END_TEST

static Suite *thread_suite(void)
{
    Suite *s = suite_create("am_thread");
    TCase *tc = tcase_create("scheduler");
    tcase_add_loop_test(tc, yield_is_round_robin, 0, NMODES);
    tcase_add_loop_test(tc, threads_spawn_threads_and_stacks_are_reused, 0, NMODES);
    tcase_add_loop_test(tc, a_thread_may_use_its_stack, 0, NMODES);
    tcase_add_loop_test(tc, the_page_below_a_stack_is_a_guard, 0, NMODES);
    tcase_add_loop_test(tc, stack_overflow_hits_the_guard_page, 0, NMODES);
    tcase_add_loop_test(tc, floating_point_control_is_per_thread, 0, NMODES);
    tcase_add_test(tc, bad_arguments);
    suite_add_tcase(s, tc);
    tc = tcase_create("futures");
    tcase_add_loop_test(tc, future_wakes_every_waiter_once, 0, NMODES);
    tcase_add_loop_test(tc, join_a_thread_through_its_future, 0, NMODES);
    tcase_add_loop_test(tc, condition_signal_and_broadcast, 0, NMODES);
    suite_add_tcase(s, tc);
    tc = tcase_create("timers");
    tcase_set_timeout(tc, 20);
    tcase_add_test(tc, timer_fires_once_after_its_delay);
    tcase_add_test(tc, timer_may_free_itself);
    tcase_add_loop_test(tc, sleeping_threads_do_not_block_the_pe, 0, NMODES);
    tcase_add_test(tc, idle_blocks_instead_of_spinning);
    suite_add_tcase(s, tc);
    return s;
}

UNIT_MAIN(thread_suite)
