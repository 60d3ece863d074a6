/*
 * am_switch_x86_64.S -- libam's register-only context switch for x86-64
 * (System V ABI), used instead of glibc's swapcontext when the runtime is
 * configured with the fast switch (the default on x86-64).
 *
 * Why: swapcontext saves and restores the signal mask with an
 * rt_sigprocmask system call on every switch (about 230 ns here); a switch
 * between cooperative threads only has to save what the ABI says a callee
 * preserves. Consequence, documented in am.h's users' terms: the signal
 * mask is per process, not per thread -- a thread that blocks a signal
 * blocks it for every thread of its PE.
 *
 * void am__switch(void **save_sp, void *load_sp)
 *   Pushes the callee-saved registers (rbp, rbx, r12-r15) and the control
 *   words of SSE (MXCSR) and x87 (FPU control word), stores the stack
 *   pointer in *save_sp, loads load_sp and pops the same set from there,
 *   then returns on the new stack. Frame at a saved stack pointer, from
 *   low to high addresses:
 *     +0  MXCSR (4 bytes), x87 control word (2 bytes), 2 bytes unused
 *     +8  r15, +16 r14, +24 r13, +32 r12, +40 rbx, +48 rbp, +56 return
 *   Caller-saved registers need no saving: the switch is a function call
 *   (rax and rcx are used as scratch). A control word is reloaded only if
 *   it differs from the current one: ldmxcsr and fldcw are slow (they made
 *   a switch cost 26 ns instead of about 15 ns here).
 *
 * am__switch_boot
 *   Never called: a new thread's first frame (built in am_thread.c) makes
 *   am__switch "return" here with r12 pointing at five words taken from
 *   the ucontext that makecontext prepared: rip, rsp, rdi, rsi, rbx. It
 *   loads them and jumps, which is what setcontext would do minus the
 *   signal-mask system call and the FPU environment reload (a new thread
 *   inherits the current control words, as with setcontext from the same
 *   process).
 *
 * uint64_t am__fpctl_get(void)
 *   Current MXCSR | x87 control word << 32, to seed a first frame.
 */
#if defined(__x86_64__)

    .text

    .globl am__switch
    .hidden am__switch
    .type am__switch, @function
    .p2align 4
am__switch:
    .cfi_startproc
    pushq %rbp
    pushq %rbx
    pushq %r12
    pushq %r13
    pushq %r14
    pushq %r15
    subq $8, %rsp
    stmxcsr (%rsp)
    fnstcw 4(%rsp)
    movl (%rsp), %eax
    movzwl 4(%rsp), %ecx
    movq %rsp, (%rdi)
    movq %rsi, %rsp
    /* Reloading a control word stalls the pipeline; threads almost never
     * change them, so reload only what differs. */
    cmpl (%rsp), %eax
    je 1f
    ldmxcsr (%rsp)
1:  cmpw 4(%rsp), %cx
    je 2f
    fldcw 4(%rsp)
2:  addq $8, %rsp
    popq %r15
    popq %r14
    popq %r13
    popq %r12
    popq %rbx
    popq %rbp
    ret
    .cfi_endproc
    .size am__switch, .-am__switch

    .globl am__switch_boot
    .hidden am__switch_boot
    .type am__switch_boot, @function
    .p2align 4
am__switch_boot:
    .cfi_startproc
    .cfi_undefined rip
    movq 16(%r12), %rdi
    movq 24(%r12), %rsi
    movq 32(%r12), %rbx
    movq 8(%r12), %rsp
    jmpq *(%r12)
    .cfi_endproc
    .size am__switch_boot, .-am__switch_boot

    .globl am__fpctl_get
    .hidden am__fpctl_get
    .type am__fpctl_get, @function
    .p2align 4
am__fpctl_get:
    .cfi_startproc
    movq $0, -8(%rsp)
    stmxcsr -8(%rsp)
    fnstcw -4(%rsp)
    movq -8(%rsp), %rax
    ret
    .cfi_endproc
    .size am__fpctl_get, .-am__fpctl_get

#endif /* __x86_64__ */

/* No executable stack. */
#if defined(__linux__) && defined(__ELF__)
    .section .note.GNU-stack,"",%progbits
#endif
