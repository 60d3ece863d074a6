/* Built by 'make installcheck' against the installed libam, through
 * pkg-config only, to prove that another program can use the runtime: a
 * one-PE job that sends itself a message. */
#include <am.h>
#include <stdio.h>
#include <string.h>

static int got;

static void on_hello(am_ctx_t *ctx, const am_msg_t *m, void *arg)
{
    (void)ctx;
    (void)arg;
    got = m->len == 5 && !memcmp(m->data, "hello", 5);
}

int main(void)
{
    if (strcmp(am_strerror(AM_EINVAL), "invalid argument") != 0)
        return 1;
    am_ctx_t *ctx;
    if (am_init(NULL, NULL, NULL, &ctx) != 0 || am_size(ctx) != 1)
        return 1;
    if (am_register(ctx, 1, "hello", on_hello, NULL) != 0 ||
        am_send(ctx, 0, 1, "hello", 5) != 0 ||
        am_run_until_done(ctx, NULL, NULL) != 0 || !got)
        return 1;
    if (am_finalize(&ctx) != 0)
        return 1;
    printf("installed libam %s works\n", am_version());
    return 0;
}
