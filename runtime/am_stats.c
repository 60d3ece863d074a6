/* am_stats.c -- time accounting in named categories, and the per-PE
 * statistics file (JSON; layout in runtime/CONTROL.md, "Statistics").
 *
 * A category accumulates the wall time during which it is open at least
 * once: begin/end nest per category (depth), so two threads holding
 * "setback" open at the same time count that time once. Categories are
 * independent of each other, so "masked" can overlap "completed". One
 * clock read per outermost begin or end; nested ones cost an increment. */
#include "config.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "pr_alloc.h"
#include "am_int.h"

int am_category(am_ctx_t *ctx, const char *name)
{
    if (!ctx || !name || !*name)
        return AM_EINVAL;
    for (int i = 0; i < ctx->ncats; i++)
        if (!strcmp(ctx->cats[i].name, name))
            return i;
    if (ctx->ncats == AM__CAT_MAX)
        return AM_EINVAL;
    char *copy = pr_strdup(name);
    if (!copy)
        return AM_ENOMEM;
    am__category *c = &ctx->cats[ctx->ncats];
    memset(c, 0, sizeof *c);
    c->name = copy;
    return ctx->ncats++;
}

void am_time_begin(am_ctx_t *ctx, int cat)
{
    if (!ctx || cat < 0 || cat >= ctx->ncats)
        return;
    am__category *c = &ctx->cats[cat];
    c->begins++;
    if (c->depth++ == 0)
        c->open_since = am__now();
}

void am_time_end(am_ctx_t *ctx, int cat)
{
    if (!ctx || cat < 0 || cat >= ctx->ncats)
        return;
    am__category *c = &ctx->cats[cat];
    if (c->depth == 0)
        return;
    if (--c->depth == 0)
        c->total += am__now() - c->open_since;
}

void am_count(am_ctx_t *ctx, int cat, int64_t n)
{
    if (ctx && cat >= 0 && cat < ctx->ncats)
        ctx->cats[cat].counter += n;
}

double am_time_total(am_ctx_t *ctx, int cat)
{
    if (!ctx || cat < 0 || cat >= ctx->ncats)
        return 0;
    am__category *c = &ctx->cats[cat];
    return c->total + (c->depth ? am__now() - c->open_since : 0);
}

void am_stats_get(am_ctx_t *ctx, am_stats_t *out)
{
    if (!ctx || !out)
        return;
    *out = ctx->st;
    out->wall_s = am__now() - ctx->t_init;
    out->threads_spawned = ctx->sched.spawned;
    out->thread_switches = ctx->sched.switches;
}

void am__stats_free(am_ctx_t *ctx)
{
    for (int i = 0; i < ctx->ncats; i++)
        pr_free(ctx->cats[i].name);
    ctx->ncats = 0;
    for (int i = 0; i < AM_HANDLER_MAX; i++) {
        pr_free(ctx->handlers[i].name);
        ctx->handlers[i].name = NULL;
    }
}

/* ------------------------------------------------------------------- JSON */

static void json_str(FILE *f, const char *s)
{
    fputc('"', f);
    for (const unsigned char *p = (const unsigned char *)s; *p; p++) {
        if (*p == '"' || *p == '\\')
            fprintf(f, "\\%c", *p);
        else if (*p < 0x20)
            fprintf(f, "\\u%04x", *p);
        else
            fputc(*p, f);
    }
    fputc('"', f);
}

static void json_hstat(FILE *f, const am__hstat *h)
{
    fprintf(f,
            "{\"sent\": %llu, \"sent_bytes\": %llu, \"recv\": %llu, "
            "\"recv_bytes\": %llu, \"seconds\": %.9g}",
            (unsigned long long)h->sent, (unsigned long long)h->sent_bytes,
            (unsigned long long)h->recv, (unsigned long long)h->recv_bytes,
            h->seconds);
}

static void write_json(am_ctx_t *ctx, FILE *f)
{
    am_stats_t st;
    am_stats_get(ctx, &st);
    fprintf(f, "{\n  \"rank\": %d,\n  \"size\": %d,\n  \"libam\": ", ctx->rank,
            ctx->size);
    json_str(f, am_version());
    fprintf(f, ",\n  \"transport\": ");
    json_str(f, ctx->size > 1 ? ctx->transport : "none");
    fprintf(f, ",\n  \"switch\": \"%s\",\n  \"stack_size\": %zu,\n",
            ctx->sched.mode == AM_SWITCH_FAST ? "fast" : "ucontext",
            ctx->sched.stack_size);
    fprintf(f, "  \"send_window\": %zu, \"send_queue\": %zu,\n",
            ctx->send_window, ctx->send_queue);
    fprintf(f, "  \"shm_ring_bytes\": %zu,\n", am__shm_ring_bytes(ctx));
    fprintf(f, "  \"wall_s\": %.9g,\n", st.wall_s);
    fprintf(f,
            "  \"runtime\": {\"poll_s\": %.9g, \"poll_excess_s\": %.9g, "
            "\"idle_s\": %.9g, \"handler_s\": %.9g, \"polls\": %llu, "
            "\"polls_empty\": %llu,\n    \"msgs_sent\": %llu, \"bytes_sent\": "
            "%llu, \"msgs_recv\": %llu, \"bytes_recv\": %llu, \"ctl_sent\": "
            "%llu, \"ctl_recv\": %llu,\n    \"queued_sends\": %llu, "
            "\"threads_spawned\": %llu, \"thread_switches\": %llu,\n    "
            "\"send_waits\": %llu, \"send_wait_s\": %.9g, \"held_sends\": "
            "%llu, \"credits_recv\": %llu,\n    \"bundles_sent\": %llu, "
            "\"bundled_sent\": %llu, \"bundles_recv\": %llu, "
            "\"bundled_recv\": %llu},\n",
            st.poll_s, st.poll_excess_s, st.idle_s, st.handler_s,
            (unsigned long long)st.polls, (unsigned long long)st.polls_empty,
            (unsigned long long)st.msgs_sent, (unsigned long long)st.bytes_sent,
            (unsigned long long)st.msgs_recv, (unsigned long long)st.bytes_recv,
            (unsigned long long)st.ctl_sent, (unsigned long long)st.ctl_recv,
            (unsigned long long)st.queued_sends,
            (unsigned long long)st.threads_spawned,
            (unsigned long long)st.thread_switches,
            (unsigned long long)st.send_waits, st.send_wait_s,
            (unsigned long long)st.held_sends,
            (unsigned long long)st.credits_recv,
            (unsigned long long)st.bundles_sent,
            (unsigned long long)st.bundled_sent,
            (unsigned long long)st.bundles_recv,
            (unsigned long long)st.bundled_recv);
    static const char *const reasons[AM__REJ_COUNT] = {
#define AM__REJ_NAME(name, msg) #name,
        AM__REJECT_MAP(AM__REJ_NAME)
#undef AM__REJ_NAME
    };
    fprintf(f, "  \"rejected\": {\"total\": %llu", (unsigned long long)st.rejected);
    for (int i = 0; i < AM__REJ_COUNT; i++) {
        char lower[32];
        size_t k = 0;
        for (const char *p = reasons[i]; *p && k + 1 < sizeof lower; p++)
            lower[k++] = (char)(*p >= 'A' && *p <= 'Z' ? *p - 'A' + 'a' : *p);
        lower[k] = '\0';
        fprintf(f, ", \"%s\": %llu", lower, (unsigned long long)ctx->rejected[i]);
    }
    /* CURVE: clients the ZAP handler refused (a key not of the job), the
     * distinct addresses they came from, and every failed handshake the
     * socket monitor reported (those too, plus clients without CURVE or
     * without this PE's public key, and peers that refused our key). */
    fprintf(f, "},\n  \"security\": {\"curve\": %s, \"keys\": %d, "
               "\"zap_refused\": %llu, \"strangers\": %llu, "
               "\"handshakes_failed\": %llu",
            ctx->keys ? "true" : "false", ctx->keys ? ctx->keys->n : 0,
            (unsigned long long)am__zap_refused(ctx->zap),
            (unsigned long long)am__zap_strangers(ctx->zap),
            (unsigned long long)ctx->hs_failed);
    fprintf(f, "},\n  \"latency\": {\"spec\": ");
    json_str(f, ctx->lat.spec);
    fprintf(f, ", \"bandwidth\": ");
    json_str(f, ctx->lat.bw_spec);
    fprintf(f, ", \"min_s\": %.9g, \"max_s\": %.9g, \"bytes_per_s\": %.9g},\n",
            ctx->lat.lo, ctx->lat.hi, ctx->lat.bw);
    fprintf(f, "  \"categories\": {");
    for (int i = 0; i < ctx->ncats; i++) {
        const am__category *c = &ctx->cats[i];
        fprintf(f, "%s\n    ", i ? "," : "");
        json_str(f, c->name);
        fprintf(f, ": {\"seconds\": %.9g, \"begins\": %lld, \"count\": %lld}",
                am_time_total(ctx, i), (long long)c->begins,
                (long long)c->counter);
    }
    fprintf(f, "%s},\n  \"handlers\": {", ctx->ncats ? "\n  " : "");
    int first = 1;
    for (int i = 0; i < AM_HANDLER_MAX; i++) {
        const am__handler *h = &ctx->handlers[i];
        if (!h->fn && !h->st.sent && !h->st.recv)
            continue;
        fprintf(f, "%s\n    \"%d\": {\"name\": ", first ? "" : ",", i);
        json_str(f, h->name ? h->name : "");
        fprintf(f, ", \"stats\": ");
        json_hstat(f, &h->st);
        fputc('}', f);
        first = 0;
    }
    fprintf(f, "%s},\n  \"rpc_replies\": ", first ? "" : "\n  ");
    json_hstat(f, &ctx->rpc_reply_st);
    fprintf(f, ",\n  \"control\": {");
    for (int t = 1; t < AM__CTL_COUNT; t++) {
        fprintf(f, "%s\n    \"%s\": ", t > 1 ? "," : "", ctx->ctl[t]->name);
        json_hstat(f, &ctx->ctl_st[t]);
    }
    fprintf(f, "\n  }\n}\n");
}

int am_stats_write_json(am_ctx_t *ctx, const char *path)
{
    if (!ctx || !path || !*path)
        return AM_EINVAL;
    /* Written next to the target and renamed into place, so a reader
     * never sees half a file (the mesher's outfile module does the same,
     * but libam cannot depend on the mesher). */
    size_t n = strlen(path) + 32;
    char *tmp = pr_malloc(n);
    if (!tmp)
        return AM_ENOMEM;
    snprintf(tmp, n, "%s.tmp.%ld", path, (long)getpid());
    FILE *f = fopen(tmp, "w");
    if (!f) {
        am__warn(ctx, "cannot write %s: %s", tmp, strerror(errno));
        pr_free(tmp);
        return AM_ESYS;
    }
    write_json(ctx, f);
    int bad = ferror(f);
    bad |= fclose(f) != 0;
    if (bad || rename(tmp, path) != 0) {
        am__warn(ctx, "cannot write %s: %s", path, strerror(errno));
        unlink(tmp);
        pr_free(tmp);
        return AM_ESYS;
    }
    pr_free(tmp);
    return 0;
}
