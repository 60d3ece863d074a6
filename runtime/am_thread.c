/* am_thread.c -- cooperative threads: creation with makecontext, a pool of
 * mmap'd stacks with guard pages, the run queue, and the two switch
 * implementations (glibc swapcontext, or the register-only am__switch of
 * am_switch_x86_64.S).
 *
 * Every switch goes through the scheduler: the main context switches into
 * a thread (am_run_threads), the thread switches back when it yields,
 * blocks or ends. With the fast switch a thread's first entry works like
 * this: makecontext prepares the ucontext as usual (stack, entry function,
 * arguments); we copy the registers setcontext would load (rip, rsp, rdi,
 * rsi, rbx) into boot_regs, and build in boot_frame an am__switch frame
 * whose return address is am__switch_boot and whose r12 points at boot_regs.
 * Switching to that frame lands in am__switch_boot, which loads those registers
 * and jumps to the entry function on the thread's own stack.
 *
 * AddressSanitizer must be told about every stack switch, or it takes the
 * thread stacks for stack overflow or reports false positives; each switch
 * is wrapped in __sanitizer_start_switch_fiber/finish_switch_fiber, and a
 * recycled stack is unpoisoned before reuse.
 */
#include "config.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#include "pr_alloc.h"
#include "am_int.h"

#ifdef AM_ASAN
#include <sanitizer/asan_interface.h>
#include <sanitizer/common_interface_defs.h>
#endif

#if defined(AM_FAST_SWITCH) && defined(__x86_64__)
#define AM_HAVE_FAST 1
void am__switch(void **save_sp, void *load_sp);
void am__switch_boot(void);
uint64_t am__fpctl_get(void);
#endif

/* Stacks kept for reuse at most; more are unmapped when freed. */
#define STACK_CACHE_MAX 256

/* ------------------------------------------------------------ stack pool */

static am__stack *stack_get(am__sched *s)
{
    am__stack *st = s->free_stacks;
    if (st) {
        s->free_stacks = st->next;
        s->nfree_stacks--;
#ifdef AM_ASAN
        /* Frames of the previous owner may have left poisoned redzones. */
        ASAN_UNPOISON_MEMORY_REGION(st->lo, st->size);
#endif
        return st;
    }
    st = pr_calloc(1, sizeof *st);
    if (!st)
        return NULL;
    st->map_size = s->stack_size + s->page;
    st->map = mmap(NULL, st->map_size, PROT_READ | PROT_WRITE,
                   MAP_PRIVATE | MAP_ANONYMOUS | MAP_STACK, -1, 0);
    if (st->map == MAP_FAILED) {
        pr_free(st);
        return NULL;
    }
    /* Stacks grow down: the guard page is the lowest page, so running off
     * the end faults instead of writing into whatever is mapped below. */
    if (mprotect(st->map, s->page, PROT_NONE) != 0) {
        munmap(st->map, st->map_size);
        pr_free(st);
        return NULL;
    }
    st->lo = (char *)st->map + s->page;
    st->size = s->stack_size;
    return st;
}

static void stack_unmap(am__stack *st)
{
    munmap(st->map, st->map_size);
    pr_free(st);
}

static void stack_put(am__sched *s, am__stack *st)
{
    if (s->nfree_stacks >= STACK_CACHE_MAX) {
        stack_unmap(st);
        return;
    }
    st->next = s->free_stacks;
    s->free_stacks = st;
    s->nfree_stacks++;
}

/* ------------------------------------------------------------- switching */

static void switch_into(am__sched *s, am__thread *t)
{
#ifdef AM_ASAN
    __sanitizer_start_switch_fiber(&s->main_fake_stack, t->stack->lo,
                                   t->stack->size);
#endif
#ifdef AM_HAVE_FAST
    if (s->mode == AM_SWITCH_FAST)
        am__switch(&s->main_sp, t->sp);
    else
#endif
        swapcontext(&s->main_uc, &t->uc);
#ifdef AM_ASAN
    __sanitizer_finish_switch_fiber(s->main_fake_stack, NULL, NULL);
#endif
    s->switches += 2;
}

/* Switches from thread t back to the scheduler. final: t has ended and
 * will never run again (its fake stack can go). */
static void switch_out(am__sched *s, am__thread *t, int final)
{
#ifdef AM_ASAN
    __sanitizer_start_switch_fiber(final ? NULL : &t->asan_fake_stack,
                                   s->main_stack_bottom, s->main_stack_size);
#else
    (void)final;
#endif
#ifdef AM_HAVE_FAST
    if (s->mode == AM_SWITCH_FAST)
        am__switch(&t->sp, s->main_sp);
    else
#endif
        swapcontext(&t->uc, &s->main_uc);
#ifdef AM_ASAN
    __sanitizer_finish_switch_fiber(t->asan_fake_stack, NULL, NULL);
#endif
}

/* Entry point given to makecontext, which passes int arguments only: the
 * thread pointer travels as two 32-bit halves. */
static void thread_entry(unsigned hi, unsigned lo)
{
    am__thread *t = (am__thread *)(((uintptr_t)hi << 32) | (uintptr_t)lo);
    am__sched *s = &t->ctx->sched;
#ifdef AM_ASAN
    __sanitizer_finish_switch_fiber(NULL, &s->main_stack_bottom,
                                    &s->main_stack_size);
#endif
    t->fn(t->ctx, t->arg);
    t->state = AM__T_DONE;
    if (t->done)
        am_future_set(t->done, NULL);
    switch_out(s, t, 1);
    abort(); /* a finished thread is never switched into */
}

static int thread_prepare(am__sched *s, am__thread *t)
{
    uintptr_t self = (uintptr_t)t;
    t->uc.uc_stack.ss_sp = t->stack->lo;
    t->uc.uc_stack.ss_size = t->stack->size;
    t->uc.uc_link = NULL;
    makecontext(&t->uc, (void (*)(void))thread_entry, 2,
                (unsigned)(self >> 32), (unsigned)(self & 0xffffffffu));
#ifdef AM_HAVE_FAST
    if (s->mode == AM_SWITCH_FAST) {
        const greg_t *g = t->uc.uc_mcontext.gregs;
        t->boot_regs[0] = (uintptr_t)g[REG_RIP];
        t->boot_regs[1] = (uintptr_t)g[REG_RSP];
        t->boot_regs[2] = (uintptr_t)g[REG_RDI];
        t->boot_regs[3] = (uintptr_t)g[REG_RSI];
        t->boot_regs[4] = (uintptr_t)g[REG_RBX];
        memset(t->boot_frame, 0, sizeof t->boot_frame);
        t->boot_frame[0] = (uintptr_t)am__fpctl_get();
        t->boot_frame[4] = (uintptr_t)t->boot_regs; /* popped into r12 */
        t->boot_frame[7] = (uintptr_t)am__switch_boot;     /* return address */
        t->sp = t->boot_frame;
    }
#else
    (void)s;
#endif
    return 0;
}

/* getcontext returns twice in principle (setcontext can resume it), which
 * makes the compiler distrust every local of its caller; keep it alone. */
__attribute__((noinline)) static int init_context(ucontext_t *uc)
{
    return getcontext(uc);
}

/* --------------------------------------------------------------- the API */

int am__sched_init(am_ctx_t *ctx)
{
    am__sched *s = &ctx->sched;
    memset(s, 0, sizeof *s);
    long page = sysconf(_SC_PAGESIZE);
    s->page = page > 0 ? (size_t)page : 4096;
    size_t size = ctx->stack_size;
    if (size < 4 * s->page)
        size = 4 * s->page;
    s->stack_size = (size + s->page - 1) / s->page * s->page;
    s->mode = ctx->switch_mode;
    return 0;
}

void am__sched_free(am_ctx_t *ctx)
{
    am__sched *s = &ctx->sched;
    for (am__thread *t = s->all, *n; t; t = n) {
        n = t->all_next;
        if (t->stack)
            stack_unmap(t->stack);
        if (t->sleep_ev)
            event_free(t->sleep_ev);
        pr_free(t);
    }
    s->all = NULL;
    for (am__stack *st = s->free_stacks, *n; st; st = n) {
        n = st->next;
        stack_unmap(st);
    }
    s->free_stacks = NULL;
    s->nfree_stacks = 0;
}

int am_thread_spawn(am_ctx_t *ctx, am_thread_fn fn, void *arg,
                    am_future_t *done)
{
    if (!ctx || !fn)
        return AM_EINVAL;
    if (ctx->failed)
        return ctx->failed;
    am__sched *s = &ctx->sched;
    am__thread *t = s->free_threads;
    if (t) {
        s->free_threads = t->next;
    } else {
        t = pr_calloc(1, sizeof *t);
        if (!t)
            return AM_ENOMEM;
        /* getcontext costs a system call (the signal mask); a recycled
         * thread struct keeps its initialised ucontext and only goes
         * through makecontext again. */
        if (init_context(&t->uc) != 0) {
            pr_free(t);
            return AM_ESYS;
        }
        t->ctx = ctx;
        t->all_next = s->all;
        s->all = t;
    }
    t->stack = stack_get(s);
    if (!t->stack) {
        t->next = s->free_threads;
        s->free_threads = t;
        return AM_ENOMEM;
    }
    t->fn = fn;
    t->arg = arg;
    t->done = done;
    t->asan_fake_stack = NULL;
    thread_prepare(s, t);
    t->state = AM__T_RUNNABLE;
    t->next = NULL;
    if (s->runq_tail)
        s->runq_tail->next = t;
    else
        s->runq_head = t;
    s->runq_tail = t;
    s->runq_n++;
    s->live++;
    s->spawned++;
    return 0;
}

static am__thread *runq_pop(am__sched *s)
{
    am__thread *t = s->runq_head;
    if (t) {
        s->runq_head = t->next;
        if (!s->runq_head)
            s->runq_tail = NULL;
        t->next = NULL;
        s->runq_n--;
    }
    return t;
}

void am__thread_wake(am_ctx_t *ctx, am__thread *t)
{
    am__sched *s = &ctx->sched;
    if (t->state != AM__T_BLOCKED)
        return;
    t->state = AM__T_RUNNABLE;
    t->next = NULL;
    if (s->runq_tail)
        s->runq_tail->next = t;
    else
        s->runq_head = t;
    s->runq_tail = t;
    s->runq_n++;
}

void am__thread_block(am_ctx_t *ctx)
{
    am__sched *s = &ctx->sched;
    am__thread *t = s->current;
    t->state = AM__T_BLOCKED;
    switch_out(s, t, 0);
}

int am_run_threads(am_ctx_t *ctx)
{
    if (!ctx)
        return AM_EINVAL;
    am__sched *s = &ctx->sched;
    if (s->current || ctx->in_callback)
        return AM_ESTATE;
    /* Run only the threads runnable now: one that yields goes to the back
     * and waits for the next round, so the loop gets to poll in between. */
    size_t n = s->runq_n;
    int ran = 0;
    while (n-- > 0) {
        am__thread *t = runq_pop(s);
        if (!t)
            break;
        t->state = AM__T_RUNNING;
        s->current = t;
        switch_into(s, t);
        s->current = NULL;
        ran++;
        if (t->state == AM__T_DONE) {
            stack_put(s, t->stack);
            t->stack = NULL;
            t->next = s->free_threads;
            s->free_threads = t;
            s->live--;
        }
    }
    return ran;
}

int am_yield(am_ctx_t *ctx)
{
    if (!ctx)
        return AM_EINVAL;
    am__sched *s = &ctx->sched;
    am__thread *t = s->current;
    if (!t) {
        int rc = am_run_threads(ctx);
        return rc < 0 ? rc : 0;
    }
    t->state = AM__T_RUNNABLE;
    t->next = NULL;
    if (s->runq_tail)
        s->runq_tail->next = t;
    else
        s->runq_head = t;
    s->runq_tail = t;
    s->runq_n++;
    switch_out(s, t, 0);
    return 0;
}

int am_in_thread(const am_ctx_t *ctx)
{
    return ctx && ctx->sched.current != NULL;
}

size_t am_thread_count(const am_ctx_t *ctx)
{
    return ctx ? ctx->sched.live : 0;
}
