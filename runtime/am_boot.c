/* am_boot.c -- connecting the PEs of a job.
 *
 * 1. Every PE has bound its ROUTER (am__transport_open). Rank 0's endpoint
 *    is found from AM_ROOT, from the rendezvous (AM_RENDEZVOUS: a file on a
 *    shared file system, or the launcher's tcp rendezvous server, where
 *    rank 0 publishes it), or for ipc from AM_IPC_DIR/0.sock.
 * 2. Every rank r > 0 connects to rank 0 and sends HELLO (rank, size, job,
 *    its endpoint). Rank 0 waits for all P-1 hellos, checks that everyone
 *    agrees on the size and the job, and sends each the TABLE of all
 *    endpoints.
 * 3. With the table, rank r connects to ranks 1..r-1 and sends each a
 *    PEER_HELLO; it waits for the PEER_HELLOs of ranks r+1..P-1. A ROUTER
 *    can answer a peer only after hearing from it, so after this step
 *    every PE can send to every other one: to lower ranks over the
 *    connection it made (named with ZMQ_CONNECT_ROUTING_ID), to higher ranks
 *    over the connection they made.
 * Every wait is bounded by the boot timeout. Frames that are not part of
 * the boot (a faster PE may already send work) wait in ctx->early.
 */
#include "config.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "pr_alloc.h"
#include "am_int.h"

static void nap(double seconds)
{
    struct timespec ts = {(time_t)seconds,
                          (long)((seconds - (double)(time_t)seconds) * 1e9)};
    nanosleep(&ts, NULL);
}

/* -------------------------------------------------------------- rendezvous */

static int file_publish(am_ctx_t *ctx, const char *path, const char *ep)
{
    size_t n = strlen(path) + 32;
    char *tmp = pr_malloc(n);
    if (!tmp)
        return AM_ENOMEM;
    snprintf(tmp, n, "%s.tmp.%ld", path, (long)getpid());
    FILE *f = fopen(tmp, "w");
    int ok = f && fprintf(f, "%s\n", ep) > 0;
    ok = f && !fclose(f) && ok && !rename(tmp, path);
    if (!ok) {
        am__warn(ctx, "cannot write the rendezvous file %s: %s", path,
                 strerror(errno));
        unlink(tmp);
        pr_free(tmp);
        return AM_ELAUNCH;
    }
    pr_free(tmp);
    ctx->rdv_file = pr_strdup(path);
    return 0;
}

static int file_lookup(am_ctx_t *ctx, const char *path, double deadline,
                       char *ep, size_t cap)
{
    double pause = 0.001;
    for (;;) {
        FILE *f = fopen(path, "r");
        if (f) {
            int ok = fgets(ep, (int)cap, f) != NULL;
            fclose(f);
            if (ok) {
                ep[strcspn(ep, "\r\n")] = '\0';
                if (*ep)
                    return 0;
            }
        }
        if (am__now() > deadline) {
            am__warn(ctx, "rank 0 did not publish its endpoint in %s within "
                          "%.0f s",
                     path, ctx->boot_timeout);
            return AM_ETIMEOUT;
        }
        nap(pause);
        if (pause < 0.05)
            pause *= 2;
    }
}

/* The launcher's rendezvous server: one request, one reply, as text.
 * Protocol in runtime/CONTROL.md. */
static int tcp_rendezvous(am_ctx_t *ctx, const char *server, const char *req,
                          double deadline, char *reply, size_t cap)
{
    void *s = zmq_socket(ctx->zctx, ZMQ_DEALER);
    if (!s)
        return AM_ETRANSPORT;
    int zero = 0;
    zmq_setsockopt(s, ZMQ_LINGER, &zero, sizeof zero);
    int rc = AM_ETIMEOUT;
    /* With the launcher's key the rendezvous is a CURVE server whose ZAP
     * handler admits the job's keys only: strangers can neither read nor
     * publish rank 0's endpoint. */
    const am__keys *k = ctx->keys;
    if (k && k->rdv[0] &&
        (zmq_setsockopt(s, ZMQ_CURVE_SERVERKEY, k->rdv, 40) ||
         zmq_setsockopt(s, ZMQ_CURVE_PUBLICKEY, k->public_, 40) ||
         zmq_setsockopt(s, ZMQ_CURVE_SECRETKEY, k->secret, 40))) {
        am__warn(ctx, "cannot set CURVE keys for the rendezvous: %s",
                 zmq_strerror(errno));
        rc = AM_ETRANSPORT;
    } else if (zmq_connect(s, server) != 0) {
        am__warn(ctx, "cannot reach the rendezvous %s: %s", server,
                 zmq_strerror(errno));
        rc = AM_ELAUNCH;
    } else if (zmq_send(s, req, strlen(req), 0) >= 0) {
        for (;;) {
            double left = deadline - am__now();
            if (left <= 0)
                break;
            zmq_pollitem_t it = {s, 0, ZMQ_POLLIN, 0};
            if (zmq_poll(&it, 1, (long)(left * 1000) + 1) < 0 && errno != EINTR)
                break;
            if (!(it.revents & ZMQ_POLLIN))
                continue;
            int n = zmq_recv(s, reply, cap - 1, 0);
            if (n < 0)
                break;
            reply[(size_t)n < cap - 1 ? (size_t)n : cap - 1] = '\0';
            rc = 0;
            break;
        }
        if (rc)
            am__warn(ctx, "no answer from the rendezvous %s within %.0f s",
                     server, ctx->boot_timeout);
    }
    zmq_close(s);
    return rc;
}

static int find_root(am_ctx_t *ctx, double deadline, char *ep, size_t cap)
{
    const char *rdv = ctx->rendezvous;
    const char *own = ctx->peers[ctx->rank].endpoint;
    if (ctx->rank == 0) {
        snprintf(ep, cap, "%s", own);
        if (!rdv)
            return 0;
        if (!strncmp(rdv, "file:", 5))
            return file_publish(ctx, rdv + 5, own);
        char req[AM__EP_MAX + 64], reply[64];
        snprintf(req, sizeof req, "PUT %llu %s", (unsigned long long)ctx->job,
                 own);
        int rc = tcp_rendezvous(ctx, rdv, req, deadline, reply, sizeof reply);
        if (!rc && strcmp(reply, "OK")) {
            am__warn(ctx, "the rendezvous %s refused rank 0's endpoint: %s", rdv,
                     reply);
            rc = AM_ELAUNCH;
        }
        return rc;
    }
    if (ctx->root_ep) {
        snprintf(ep, cap, "%s", ctx->root_ep);
        return 0;
    }
    if (rdv && !strncmp(rdv, "file:", 5))
        return file_lookup(ctx, rdv + 5, deadline, ep, cap);
    if (rdv) {
        char req[64], reply[AM__EP_MAX + 8];
        snprintf(req, sizeof req, "GET %llu", (unsigned long long)ctx->job);
        int rc = tcp_rendezvous(ctx, rdv, req, deadline, reply, sizeof reply);
        if (rc)
            return rc;
        if (strncmp(reply, "EP ", 3)) {
            am__warn(ctx, "the rendezvous %s answered: %s", rdv, reply);
            return AM_ELAUNCH;
        }
        snprintf(ep, cap, "%s", reply + 3);
        return 0;
    }
    if (!strcmp(ctx->transport, "ipc")) {
        snprintf(ep, cap, "ipc://%s/0.sock", ctx->ipc_dir);
        return 0;
    }
    am__warn(ctx, "rank %d of %d cannot find rank 0: set AM_ROOT=tcp://HOST:PORT "
                  "(rank 0 binds it) or AM_RENDEZVOUS=file:PATH on a shared "
                  "file system",
             ctx->rank, ctx->size);
    return AM_ELAUNCH;
}

/* ------------------------------------------------------------------ hellos */

static int all_hellos(const am_ctx_t *ctx)
{
    for (int pe = 1; pe < ctx->size; pe++)
        if (!ctx->peers[pe].hello)
            return 0;
    return 1;
}

static int higher_hellos(const am_ctx_t *ctx)
{
    for (int pe = ctx->rank + 1; pe < ctx->size; pe++)
        if (!ctx->peers[pe].hello)
            return 0;
    return 1;
}

static int table_arrived(const am_ctx_t *ctx)
{
    return ctx->boot_table;
}

static int boot_wait(am_ctx_t *ctx, int (*done)(const am_ctx_t *),
                     double deadline, const char *what)
{
    for (;;) {
        am__recv_some(ctx, 4096);
        if (ctx->failed)
            return ctx->failed;
        if (done(ctx))
            return 0;
        double left = deadline - am__now();
        if (left <= 0)
            break;
        zmq_pollitem_t it[2] = {{ctx->sock, 0, ZMQ_POLLIN, 0},
                                {ctx->mon, 0, ZMQ_POLLIN, 0}};
        zmq_poll(it, 2, left > 0.05 ? 50 : (long)(left * 1000) + 1);
        am__read_monitor(ctx);
    }
    char missing[256] = "";
    size_t len = 0;
    int first = ctx->rank == 0 ? 1 : ctx->rank + 1;
    for (int pe = first; pe < ctx->size && len + 16 < sizeof missing; pe++)
        if (!ctx->peers[pe].hello)
            len += (size_t)snprintf(missing + len, sizeof missing - len, "%s%d",
                                    len ? ", " : "", pe);
    am__warn(ctx, "timed out after %.0f s waiting for %s%s%s", ctx->boot_timeout,
             what, *missing && done != table_arrived ? ": PEs " : "",
             done != table_arrived ? missing : "");
    return AM_ETIMEOUT;
}

static int send_hello(am_ctx_t *ctx, int to, unsigned type)
{
    pr_buf b = PR_BUF_INIT;
    am__ctl_begin(&b);
    if (type == AM__CTL_HELLO) {
        const char *ep = ctx->peers[ctx->rank].endpoint;
        am__hello h = {.endpoint = {(const uint8_t *)ep, strlen(ep)}};
        pr_hello_init(&h.id, ctx->job, (uint32_t)ctx->rank, (uint32_t)ctx->size);
        am__hello_put(&b, &h);
    } else if (type == AM__CTL_PEER_HELLO) {
        am__peer_hello h;
        pr_hello_init(&h.id, ctx->job, (uint32_t)ctx->rank, (uint32_t)ctx->size);
        am__peer_hello_put(&b, &h);
    } else {
        char **eps = pr_malloc(sizeof *eps * (size_t)ctx->size);
        if (!eps) {
            pr_buf_free(&b);
            return AM_ENOMEM;
        }
        for (int pe = 0; pe < ctx->size; pe++)
            eps[pe] = ctx->peers[pe].endpoint;
        am__table_put(&b, ctx->job, (uint32_t)ctx->size, eps);
        pr_free(eps);
    }
    int rc = am__send_ctl(ctx, to, type, &b);
    pr_buf_free(&b);
    return rc;
}

int am__boot(am_ctx_t *ctx)
{
    double deadline = am__now() + ctx->boot_timeout;
    char root[AM__EP_MAX + 16];
    int rc = find_root(ctx, deadline, root, sizeof root);
    if (rc)
        return rc;
    if (ctx->rank == 0) {
        if ((rc = boot_wait(ctx, all_hellos, deadline, "hellos")))
            return rc;
        for (int pe = 1; pe < ctx->size && !rc; pe++)
            rc = send_hello(ctx, pe, AM__CTL_TABLE);
        return rc;
    }
    if (!(ctx->peers[0].endpoint = pr_strdup(root)))
        return AM_ENOMEM;
    if ((rc = am__connect_peer(ctx, 0)) || (rc = send_hello(ctx, 0, AM__CTL_HELLO)))
        return rc;
    if ((rc = boot_wait(ctx, table_arrived, deadline,
                        "the endpoint table from rank 0")))
        return rc;
    for (int pe = 1; pe < ctx->rank && !rc; pe++) {
        rc = am__connect_peer(ctx, pe);
        if (!rc)
            rc = send_hello(ctx, pe, AM__CTL_PEER_HELLO);
    }
    if (!rc)
        rc = boot_wait(ctx, higher_hellos, deadline, "peer hellos");
    return rc;
}

static int check_job(am_ctx_t *ctx, int src, uint64_t job, uint32_t size)
{
    if (job != ctx->job) {
        am__warn(ctx, "ignored a hello from PE %d of another job (job id %llu, "
                      "ours %llu)",
                 src, (unsigned long long)job, (unsigned long long)ctx->job);
        return 1;
    }
    if (size && size != (uint32_t)ctx->size) {
        am__fail(ctx, AM_ELAUNCH,
                 "PE %d was started as one of %u PEs, this PE as one of %d",
                 src, size, ctx->size);
        return 1;
    }
    return 0;
}

/* A peer's hello, decided by proto's negotiation rules. Returns 0 if the
 * peer may take part; otherwise the hello is ignored (a PE of another job,
 * with a warning) or the job fails with the negotiation's one-line
 * explanation. */
static int check_hello(am_ctx_t *ctx, int src, const pr_hello *remote)
{
    if (remote->job != ctx->job)
        return check_job(ctx, src, remote->job, remote->size);
    pr_hello local;
    pr_hello_init(&local, ctx->job, (uint32_t)ctx->rank, (uint32_t)ctx->size);
    uint8_t version;
    char why[256];
    int rc = pr_negotiate(&local, remote, &version, why, sizeof why);
    if (rc) {
        am__fail(ctx, rc == PR_EVERSION ? AM_EPROTO : AM_ELAUNCH, "%s", why);
        return 1;
    }
    if (remote->rank != (uint32_t)src) {
        am__reject(ctx, AM__REJ_BODY, src, "hello names another rank");
        return 1;
    }
    return 0;
}

/* Boot messages are only valid while this PE is starting. */
static int booting(am_ctx_t *ctx, int src)
{
    if (ctx->state == AM__BOOTING)
        return 1;
    am__reject(ctx, AM__REJ_BODY, src, "boot message after the start");
    return 0;
}

static void on_hello(am_ctx_t *ctx, int src, pr_reader *body)
{
    if (!booting(ctx, src))
        return;
    am__peer *p = &ctx->peers[src];
    am__hello h;
    if (am__hello_get(body, &h) || ctx->rank != 0) {
        am__reject(ctx, AM__REJ_BODY, src, "bad hello");
        return;
    }
    if (check_hello(ctx, src, &h.id))
        return;
    pr_free(p->endpoint);
    p->endpoint = pr_strndup((const char *)h.endpoint.p, h.endpoint.len);
    if (!p->endpoint) {
        am__fail(ctx, AM_ENOMEM, "out of memory at boot");
        return;
    }
    p->hello = 1;
}

static void on_peer_hello(am_ctx_t *ctx, int src, pr_reader *body)
{
    if (!booting(ctx, src))
        return;
    am__peer_hello h;
    if (am__peer_hello_get(body, &h) || src <= ctx->rank) {
        am__reject(ctx, AM__REJ_BODY, src, "bad peer hello");
        return;
    }
    if (!check_hello(ctx, src, &h.id))
        ctx->peers[src].hello = 1;
}

static void on_table(am_ctx_t *ctx, int src, pr_reader *body)
{
    if (!booting(ctx, src))
        return;
    am__str *eps = pr_calloc((size_t)ctx->size, sizeof *eps);
    uint64_t job;
    uint32_t n;
    if (!eps) {
        am__fail(ctx, AM_ENOMEM, "out of memory at boot");
        return;
    }
    if (src != 0 || ctx->rank == 0 || ctx->boot_table ||
        am__table_get(body, &job, (uint32_t)ctx->size, &n, eps) ||
        n != (uint32_t)ctx->size) {
        pr_free(eps);
        am__reject(ctx, AM__REJ_BODY, src, "bad endpoint table");
        return;
    }
    if (check_job(ctx, src, job, n)) {
        pr_free(eps);
        return;
    }
    for (int pe = 1; pe < ctx->size; pe++) {
        if (pe == ctx->rank)
            continue;
        pr_free(ctx->peers[pe].endpoint);
        ctx->peers[pe].endpoint = pr_strndup((const char *)eps[pe].p, eps[pe].len);
        if (!ctx->peers[pe].endpoint) {
            pr_free(eps);
            am__fail(ctx, AM_ENOMEM, "out of memory at boot");
            return;
        }
    }
    pr_free(eps);
    ctx->boot_table = 1;
}

/* These three are handled while the PE boots; frames of other types that
 * arrive meanwhile wait until the start is over. */
const am__ctl_entry am__boot_ctls[] = {
    {AM__CTL_HELLO, "hello", AM__CTLF_BOOT, on_hello},
    {AM__CTL_TABLE, "table", AM__CTLF_BOOT, on_table},
    {AM__CTL_PEER_HELLO, "peer_hello", AM__CTLF_BOOT, on_peer_hello},
    {0, NULL, 0, NULL},
};
