/* am_latency.c -- latency and bandwidth injection at the receiver.
 *
 * Every frame taken from the network (after the boot) gets a due time:
 *   start = max(now, link_free_at)          the link is busy until then
 *   link_free_at = start + bytes / bandwidth   serialisation (if capped)
 *   due = max(link_free_at + latency, last_due)
 * with latency uniform in [lo, hi]. last_due keeps frames of one sender in
 * order even when a later one drew a shorter latency, as on a real link.
 * Frames wait in their sender's queue; one libevent timer per sender is
 * armed for the queue's head, and delivers every frame that is due when it
 * fires. Nothing sleeps: a PE with delayed frames still runs its threads,
 * and blocks in libevent until the next due time if it has nothing else.
 */
#include "config.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include "am_int.h"

/* ---------------------------------------------------------------- parsing */

/* Parses a number followed by a time unit at *s; advances *s. */
static int parse_time(const char **s, double *out)
{
    char *end;
    double v = strtod(*s, &end);
    if (end == *s || !isfinite(v) || v < 0)
        return AM_EINVAL;
    /* Divide by exact powers of ten: 200 / 1e6 is the double nearest to
     * 200e-6, 200 * 1e-6 is not. */
    static const struct {
        const char *unit;
        double per_second;
    } units[] = {{"ns", 1e9}, {"us", 1e6}, {"ms", 1e3}, {"s", 1.0}};
    for (size_t i = 0; i < sizeof units / sizeof units[0]; i++) {
        size_t n = strlen(units[i].unit);
        if (!strncmp(end, units[i].unit, n)) {
            *out = v / units[i].per_second;
            *s = end + n;
            return 0;
        }
    }
    /* A bare zero needs no unit. */
    if (v == 0 && (*end == '\0' || *end == '-')) {
        *out = 0;
        *s = end;
        return 0;
    }
    return AM_EINVAL;
}

int am__latency_parse(const char *spec, double *lo, double *hi)
{
    if (!spec || !*spec)
        return AM_EINVAL;
    const char *s = spec;
    if (parse_time(&s, lo))
        return AM_EINVAL;
    *hi = *lo;
    if (*s == '-') {
        s++;
        if (parse_time(&s, hi) || *hi < *lo)
            return AM_EINVAL;
    }
    if (*s != '\0' || *hi > 3600)
        return AM_EINVAL;
    return 0;
}

int am__bandwidth_parse(const char *spec, double *bps)
{
    if (!spec || !*spec)
        return AM_EINVAL;
    char *end;
    double v = strtod(spec, &end);
    if (end == spec || !isfinite(v) || v < 0)
        return AM_EINVAL;
    if (v == 0 && *end == '\0') {
        *bps = 0;
        return 0;
    }
    /* Bits are written with a lower-case b ("bit", "bps"), bytes with B. */
    static const struct {
        const char *unit;
        double bytes;
    } units[] = {
        {"Gbit", 1e9 / 8}, {"Mbit", 1e6 / 8}, {"kbit", 1e3 / 8}, {"bit", 1.0 / 8},
        {"Gbps", 1e9 / 8}, {"Mbps", 1e6 / 8}, {"kbps", 1e3 / 8}, {"bps", 1.0 / 8},
        {"GiB", 1073741824.0}, {"MiB", 1048576.0}, {"KiB", 1024.0},
        {"GB", 1e9}, {"MB", 1e6}, {"kB", 1e3}, {"KB", 1e3}, {"B", 1.0},
    };
    for (size_t i = 0; i < sizeof units / sizeof units[0]; i++) {
        size_t n = strlen(units[i].unit);
        if (strncmp(end, units[i].unit, n))
            continue;
        const char *rest = end + n;
        if (!strcmp(rest, "/s"))
            rest += 2;
        if (*rest != '\0' || v == 0)
            return AM_EINVAL;
        *bps = v * units[i].bytes;
        return 0;
    }
    return AM_EINVAL;
}

/* ---------------------------------------------------------------- delays */

static double rand01(am__latency *l)
{
    /* xorshift64*: plenty for drawing latencies. */
    uint64_t x = l->rng;
    x ^= x >> 12;
    x ^= x << 25;
    x ^= x >> 27;
    l->rng = x;
    return (double)((x * UINT64_C(2685821657736338717)) >> 11) * 0x1.0p-53;
}

int am__latency_init(am_ctx_t *ctx, const char *lat, const char *bw)
{
    am__latency *l = &ctx->lat;
    memset(l, 0, sizeof *l);
    if (lat && am__latency_parse(lat, &l->lo, &l->hi)) {
        am__warn(ctx, "bad latency '%s' (examples: 200us, 100us-2ms, 0)", lat);
        return AM_EINVAL;
    }
    if (bw && am__bandwidth_parse(bw, &l->bw)) {
        am__warn(ctx, "bad bandwidth '%s' (examples: 100Mbit, 1Gbit, 12.5MB, 0)",
                 bw);
        return AM_EINVAL;
    }
    snprintf(l->spec, sizeof l->spec, "%s", lat ? lat : "0");
    snprintf(l->bw_spec, sizeof l->bw_spec, "%s", bw ? bw : "0");
    l->on = l->hi > 0 || l->bw > 0;
    l->rng = UINT64_C(0x9E3779B97F4A7C15) ^ ((uint64_t)ctx->rank << 32) ^
             (uint64_t)getpid() ^ ctx->job;
    if (!l->rng)
        l->rng = 1;
    return 0;
}

static void arm(am_ctx_t *ctx, am__peer *p, double now)
{
    double d = p->delayq.head->due - now;
    if (d < 0)
        d = 0;
    struct timeval tv;
    tv.tv_sec = (time_t)d;
    tv.tv_usec = (suseconds_t)((d - floor(d)) * 1e6) + 1;
    evtimer_add(p->delay_ev, &tv);
    if (!p->delay_armed) {
        p->delay_armed = 1;
        am__timer_armed(ctx, 0, +1);
    }
}

static void delay_cb(evutil_socket_t fd, short what, void *arg)
{
    (void)fd;
    (void)what;
    am__peer *p = arg;
    am_ctx_t *ctx = p->ctx;
    p->delay_armed = 0;
    am__timer_armed(ctx, 0, -1);
    double now = am__now();
    while (p->delayq.head && p->delayq.head->due <= now && !ctx->failed)
        am__arrive(ctx, am__fifo_pop(&p->delayq));
    /* libevent measures the delay from its cached time, which can be a
     * little older than ours: a timer may fire just before the head is
     * due. It is then simply armed again. */
    if (p->delayq.head)
        arm(ctx, p, am__now());
}

void am__latency_enqueue(am_ctx_t *ctx, am__frame *f)
{
    am__latency *l = &ctx->lat;
    am__peer *p = &ctx->peers[f->src];
    if (!p->delay_ev) {
        p->ctx = ctx;
        p->delay_ev = evtimer_new(ctx->base, delay_cb, p);
        if (!p->delay_ev) {
            am__frame_free(f);
            am__fail(ctx, AM_ENOMEM, "out of memory delaying a frame");
            return;
        }
    }
    double now = am__now();
    double start = now > p->link_free_at ? now : p->link_free_at;
    if (l->bw > 0)
        start += (double)zmq_msg_size(&f->msg) / l->bw;
    p->link_free_at = start;
    double due = start + l->lo + (l->hi - l->lo) * rand01(l);
    if (due < p->last_due)
        due = p->last_due;
    p->last_due = due;
    f->due = due;
    am__fifo_push(&p->delayq, f);
    if (p->delayq.head == f)
        arm(ctx, p, now);
}

void am__latency_deliver_due(am_ctx_t *ctx)
{
    if (!ctx->peers)
        return;
    double now = am__now();
    for (int pe = 0; pe < ctx->size; pe++) {
        am__peer *p = &ctx->peers[pe];
        while (p->delayq.head && p->delayq.head->due <= now && !ctx->failed)
            am__arrive(ctx, am__fifo_pop(&p->delayq));
    }
}

size_t am__latency_pending(const am_ctx_t *ctx)
{
    size_t n = 0;
    if (ctx->peers)
        for (int pe = 0; pe < ctx->size; pe++)
            n += ctx->peers[pe].delayq.n;
    return n;
}

void am__latency_free(am_ctx_t *ctx)
{
    if (!ctx->peers)
        return;
    for (int pe = 0; pe < ctx->size; pe++) {
        am__peer *p = &ctx->peers[pe];
        am__fifo_clear(&p->delayq);
        if (p->delay_ev)
            event_free(p->delay_ev);
        p->delay_ev = NULL;
        if (p->delay_armed)
            am__timer_armed(ctx, 0, -1);
        p->delay_armed = 0;
    }
}
