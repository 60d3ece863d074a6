/* am_transport.c -- the PE's ROUTER socket: options, sending (with a local
 * queue when ZeroMQ cannot take a frame), receiving and validating frames,
 * dispatching them, and noticing peers that go away.
 *
 * Sockets, as DESIGN.md section 2 asks: one ROUTER per PE; its routing id
 * ('P' and the rank as u32) is set before any bind or connect; each pair of
 * PEs shares one connection, made by the higher rank to the lower one with
 * ZMQ_CONNECT_ROUTING_ID naming the lower rank, so the connecting side can
 * queue frames at once and the accepting side can answer once the hello
 * arrived. ZMQ_ROUTER_MANDATORY turns a frame to an unknown or vanished
 * peer into EHOSTUNREACH instead of a silent drop. High-water marks are
 * unlimited by default (AM_HWM), so a burst is never dropped; when ZeroMQ
 * still says EAGAIN the frame waits in the peer's send queue, which the
 * loop flushes. What bounds memory is flow control (am_flow.c): a basic
 * frame gets here only once it fits in the peer's send window, so ZeroMQ's
 * pipes and the send queue hold at most a window of them per peer.
 * ZMQ_LINGER is bounded (2 s) so a dead peer cannot hold up exit.
 *
 * Send coalescing: while the PE runs, a basic frame (user AM, RPC) to
 * another PE is not handed to ZeroMQ at once but waits in the peer's send
 * queue until the next flush point, a place where the PE would wait
 * anyway or goes back to the network (am_poll, before am_idle blocks, the
 * end of each round of am_run_until_done, am_flush, the finalize and
 * failure paths; see am_loop.c); then the frames queued for each peer go
 * out as bundles, several frames back to back in one ZeroMQ message
 * (CONTROL.md, "Bundles"). Every ZeroMQ message costs a wake-up of its
 * I/O thread when that thread sleeps, its system calls, and the same on
 * the receiving side; measured on the 2-PE refinement, bundling carries
 * about 2.3 frames per message and halves the I/O threads' CPU and the
 * job's context switches (bench/runtime.md). Other control frames go at
 * once and flush every queue: they mark synchronisation points, after
 * which a PE may compute without polling. The receiver cuts a bundle into
 * frames and takes each as it takes a lone frame: validation, sequence numbers, statistics, termination counts,
 * credits and injected latency all stay per frame. Frames larger than
 * AM__BUNDLE_FRAME_MAX go alone (no copy); a queue that reaches
 * AM__BUNDLE_MAX bytes is flushed at once. AM_COALESCE=0 turns it off.
 *
 * ZMQ_FD is edge-triggered: it signals a change, not a level. The runtime
 * therefore never relies on it alone: am_poll receives until ZeroMQ says
 * EAGAIN (or the poll budget is spent), and before am_idle blocks it
 * re-reads ZMQ_EVENTS whenever a send happened since the socket was last
 * seen empty (events_stale): a send can process the command that carried
 * the edge of a frame that is already waiting. An EAGAIN receive or a
 * ZMQ_EVENTS read processes every pending command, so after one, the next
 * frame is sure to signal ZMQ_FD again.
 *
 * Failure detection: ZeroMQ heartbeats (ZMQ_HEARTBEAT_IVL/TIMEOUT/TTL, on
 * tcp and ipc) close a connection whose peer stopped answering, and the OS
 * closes the connections of a process that died. Both appear as
 * ZMQ_EVENT_DISCONNECTED on the socket monitor. A disconnect on a
 * connection we made names the peer by its endpoint; on an accepted one
 * the event names only our own endpoint, so the peers that connected to us
 * are probed: ROUTER_MANDATORY refuses a frame to a peer whose connection
 * is gone. A peer that said BYE (am_finalize) is allowed to go.
 *
 * The transport knows no control message by name: a received control frame
 * is handed to the entry of its type in the dispatch table (am_int.h,
 * "control dispatch"), and every send, user or control, is counted by
 * count_send once the frame was accepted.
 */
#include "config.h"

#include <arpa/inet.h>
#include <errno.h>
#include <netdb.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "pr_alloc.h"
#include "am_int.h"

/* How long a suspected peer is probed before it is cleared, and how long a
 * disconnect must stay unexplained (no BYE drained) before it is fatal. */
#define SUSPECT_WINDOW 2.0
#define SUSPECT_GRACE 0.2

static const char *const reject_msg[AM__REJ_COUNT] = {
#define AM__REJ_MSG(name, msg) msg,
    AM__REJECT_MAP(AM__REJ_MSG)
#undef AM__REJ_MSG
};

/* ------------------------------------------------------------------ FIFOs */

am__frame *am__frame_new(void)
{
    am__frame *f = pr_calloc(1, sizeof *f);
    if (f)
        zmq_msg_init(&f->msg);
    return f;
}

void am__frame_free(am__frame *f)
{
    if (!f)
        return;
    zmq_msg_close(&f->msg);
    pr_free(f);
}

void am__fifo_push(am__fifo *q, am__frame *f)
{
    f->next = NULL;
    if (q->tail)
        q->tail->next = f;
    else
        q->head = f;
    q->tail = f;
    q->n++;
}

am__frame *am__fifo_pop(am__fifo *q)
{
    am__frame *f = q->head;
    if (f) {
        q->head = f->next;
        if (!q->head)
            q->tail = NULL;
        f->next = NULL;
        q->n--;
    }
    return f;
}

void am__fifo_clear(am__fifo *q)
{
    am__frame *f;
    while ((f = am__fifo_pop(q)))
        am__frame_free(f);
}

/* ------------------------------------------------------------ the socket */

void am__routing_id(int rank, uint8_t out[5])
{
    out[0] = 'P';
    pr_store_u32(out + 1, (uint32_t)rank);
}

static int set_int(void *sock, int opt, int v)
{
    return zmq_setsockopt(sock, opt, &v, sizeof v);
}

/* Where a tcp PE binds and what it tells the others. AM_BIND may be an
 * address (bound and advertised as is), "*" (all interfaces, advertised as
 * this host's name), or a host name: ZeroMQ binds only interfaces and
 * addresses, so a name that resolves to loopback only ("localhost") binds
 * that address, and any other name (a hostfile entry) binds all
 * interfaces and is advertised as given, for the other hosts to resolve. */
static void tcp_bind_plan(const char *want, char *bind, char *adv, size_t n)
{
    struct in6_addr a6;
    struct in_addr a4;
    if (inet_pton(AF_INET, want, &a4) == 1) {
        snprintf(bind, n, "%s", want);
        snprintf(adv, n, "%s", want);
        return;
    }
    if (inet_pton(AF_INET6, want, &a6) == 1) {
        snprintf(bind, n, "[%s]", want);
        snprintf(adv, n, "[%s]", want);
        return;
    }
    if (!strcmp(want, "*")) {
        snprintf(bind, n, "*");
        if (gethostname(adv, n) != 0)
            snprintf(adv, n, "localhost");
        adv[n - 1] = '\0';
        return;
    }
    struct addrinfo hints, *res = NULL;
    memset(&hints, 0, sizeof hints);
    hints.ai_family = AF_INET;
    hints.ai_socktype = SOCK_STREAM;
    int loopback_only = getaddrinfo(want, NULL, &hints, &res) == 0 && res;
    char first[INET_ADDRSTRLEN] = "";
    for (struct addrinfo *ai = res; ai && loopback_only; ai = ai->ai_next) {
        const struct sockaddr_in *sin = (const struct sockaddr_in *)ai->ai_addr;
        loopback_only = (ntohl(sin->sin_addr.s_addr) >> 24) == 127;
        if (!first[0])
            inet_ntop(AF_INET, &sin->sin_addr, first, sizeof first);
    }
    if (res)
        freeaddrinfo(res);
    if (loopback_only) {
        snprintf(bind, n, "%s", first);
        snprintf(adv, n, "%s", first);
    } else {
        snprintf(bind, n, "*");
        snprintf(adv, n, "%s", want);
    }
}

int am__transport_open(am_ctx_t *ctx)
{
    ctx->zctx = zmq_ctx_new();
    if (!ctx->zctx)
        return AM_ENOMEM;
    ctx->sock = zmq_socket(ctx->zctx, ZMQ_ROUTER);
    if (!ctx->sock)
        return AM_ETRANSPORT;
    uint8_t id[5];
    am__routing_id(ctx->rank, id);
    int hb_ms = (int)(ctx->heartbeat * 1000);
    int rc = zmq_setsockopt(ctx->sock, ZMQ_ROUTING_ID, id, sizeof id);
    rc |= set_int(ctx->sock, ZMQ_ROUTER_MANDATORY, 1);
    rc |= set_int(ctx->sock, ZMQ_SNDHWM, ctx->hwm);
    rc |= set_int(ctx->sock, ZMQ_RCVHWM, ctx->hwm);
    rc |= set_int(ctx->sock, ZMQ_LINGER, 2000);
    rc |= set_int(ctx->sock, ZMQ_RECONNECT_IVL, 20);
    rc |= set_int(ctx->sock, ZMQ_RECONNECT_IVL_MAX, 500);
    /* Ping every third of the timeout; the TTL tells the peer to drop us
     * after the same silence. */
    rc |= set_int(ctx->sock, ZMQ_HEARTBEAT_IVL, hb_ms / 3 > 0 ? hb_ms / 3 : 1);
    rc |= set_int(ctx->sock, ZMQ_HEARTBEAT_TIMEOUT, hb_ms);
    rc |= set_int(ctx->sock, ZMQ_HEARTBEAT_TTL, hb_ms);
    int64_t maxmsg = (int64_t)PR_HEADER_SIZE + (int64_t)PR_MAX_PAYLOAD;
    rc |= zmq_setsockopt(ctx->sock, ZMQ_MAXMSGSIZE, &maxmsg, sizeof maxmsg);
    if (rc) {
        am__warn(ctx, "cannot set socket options: %s", zmq_strerror(errno));
        return AM_ETRANSPORT;
    }

    /* The monitor reports disconnects (failure detection) and failed
     * handshakes (strangers, and peers that refuse our key). */
    char mon_ep[64];
    snprintf(mon_ep, sizeof mon_ep, "inproc://am-monitor-%p", (void *)ctx);
    if (zmq_socket_monitor(ctx->sock, mon_ep,
                           ZMQ_EVENT_DISCONNECTED |
                               ZMQ_EVENT_HANDSHAKE_FAILED_NO_DETAIL |
                               ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL |
                               ZMQ_EVENT_HANDSHAKE_FAILED_AUTH) != 0)
        return AM_ETRANSPORT;
    /* libzmq's I/O thread blocks on a full monitor pipe, heartbeats and
     * all; every stranger's attempt queues two events, and a PE that
     * computes for seconds does not read them. So the pipe holds about
     * 100,000 messages (a few MiB), not libzmq's 2,000 (1,000 a side). */
    ctx->mon = zmq_socket(ctx->zctx, ZMQ_PAIR);
    if (!ctx->mon || set_int(ctx->mon, ZMQ_RCVHWM, 100000) != 0 ||
        zmq_connect(ctx->mon, mon_ep) != 0)
        return AM_ETRANSPORT;
    set_int(ctx->mon, ZMQ_LINGER, 0);

    /* CURVE (CONTROL.md, "CURVE and ZAP"): this socket is the server on
     * the connections it accepts, with this PE's key pair, and the ZAP
     * handler admits only the job's keys. The handler is bound before the
     * socket binds: libzmq admits every client while none is. The server
     * options are copied into the listener at bind time; the client
     * options set before each connect (am__connect_peer) use the same
     * key pair and only name the peer's public key. */
    int tcp = !strcmp(ctx->transport, "tcp");
    if (tcp && ctx->keys) {
        char prefix[32];
        snprintf(prefix, sizeof prefix, "am: PE %d: ", ctx->rank);
        if (!(ctx->hs_peer_warned = pr_calloc((size_t)ctx->size, 1)))
            return AM_ENOMEM;
        rc = am__zap_start(ctx->zctx, (const char (*)[41])ctx->keys->pub,
                           ctx->keys->n, prefix, "this PE", &ctx->zap);
        if (rc) {
            am__warn(ctx, "cannot start the ZAP handler: %s", am_strerror(rc));
            return rc;
        }
        rc = set_int(ctx->sock, ZMQ_CURVE_SERVER, 1);
        rc |= zmq_setsockopt(ctx->sock, ZMQ_CURVE_SECRETKEY,
                             ctx->keys->secret, 40);
        rc |= zmq_setsockopt(ctx->sock, ZMQ_ZAP_DOMAIN, "am", 2);
        if (rc) {
            am__warn(ctx, "cannot enable CURVE: %s", zmq_strerror(errno));
            return AM_ETRANSPORT;
        }
    }

    char ep[AM__EP_MAX], bind[256] = "", adv[256] = "";
    if (tcp)
        tcp_bind_plan(ctx->bind_addr, bind, adv, sizeof bind);
    if (ctx->rank == 0 && ctx->root_ep)
        snprintf(ep, sizeof ep, "%s", ctx->root_ep);
    else if (tcp)
        snprintf(ep, sizeof ep, "tcp://%s:0", bind);
    else
        snprintf(ep, sizeof ep, "ipc://%s/%d.sock", ctx->ipc_dir, ctx->rank);
    /* The same-host rings exist before anyone can learn our endpoint. */
    if ((rc = am__shm_open(ctx)))
        return rc;
    if (zmq_bind(ctx->sock, ep) != 0) {
        am__warn(ctx, "cannot bind %s: %s", ep, zmq_strerror(errno));
        return AM_ETRANSPORT;
    }
    char last[AM__EP_MAX + 300];
    size_t len = AM__EP_MAX;
    if (zmq_getsockopt(ctx->sock, ZMQ_LAST_ENDPOINT, last, &len) != 0)
        return AM_ETRANSPORT;
    last[sizeof last - 1] = '\0';
    /* A tcp socket bound to a wildcard reports 0.0.0.0; others must be
     * told a name or address they can reach. */
    if (tcp && !strncmp(last, "tcp://0.0.0.0:", 14)) {
        long port = strtol(last + 14, NULL, 10);
        snprintf(last, sizeof last, "tcp://%s:%ld", adv, port);
    }
    ctx->peers[ctx->rank].endpoint = pr_strdup(last);
    if (!ctx->peers[ctx->rank].endpoint)
        return AM_ENOMEM;
    size_t fdlen = sizeof ctx->zfd;
    if (zmq_getsockopt(ctx->sock, ZMQ_FD, &ctx->zfd, &fdlen) != 0)
        return AM_ETRANSPORT;
    return 0;
}

void am__transport_close(am_ctx_t *ctx)
{
    /* Order matters: libzmq's I/O thread sends monitor events with a
     * blocking send while it holds the monitor's lock. Once our end of the
     * monitor pair is closed, the next event (a peer disconnecting) would
     * block that thread for ever, and zmq_socket_monitor(NULL) would wait
     * for the lock. So monitoring stops first, then the pair is closed. */
    if (ctx->sock)
        zmq_socket_monitor(ctx->sock, NULL, 0);
    if (ctx->mon) {
        zmq_close(ctx->mon);
        ctx->mon = NULL;
    }
    if (ctx->sock) {
        zmq_close(ctx->sock);
        ctx->sock = NULL;
    }
    /* After the socket: while it may still accept, ZAP must answer. */
    am__zap_stop(&ctx->zap);
    am__shm_close(ctx);
    if (ctx->zctx) {
        zmq_ctx_term(ctx->zctx);
        ctx->zctx = NULL;
    }
}

int am__connect_peer(am_ctx_t *ctx, int pe)
{
    am__peer *p = &ctx->peers[pe];
    uint8_t id[5];
    am__routing_id(pe, id);
    if (zmq_setsockopt(ctx->sock, ZMQ_CONNECT_ROUTING_ID, id, sizeof id))
        return AM_ETRANSPORT;
    if (!strncmp(p->endpoint, "tcp://", 6) && ctx->keys) {
        int rc = zmq_setsockopt(ctx->sock, ZMQ_CURVE_SERVERKEY,
                                ctx->keys->pub[pe], 40);
        rc |= zmq_setsockopt(ctx->sock, ZMQ_CURVE_PUBLICKEY,
                             ctx->keys->public_, 40);
        rc |= zmq_setsockopt(ctx->sock, ZMQ_CURVE_SECRETKEY,
                             ctx->keys->secret, 40);
        if (rc)
            return AM_ETRANSPORT;
    }
    if (zmq_connect(ctx->sock, p->endpoint) != 0) {
        am__warn(ctx, "cannot connect to PE %d at %s: %s", pe, p->endpoint,
                 zmq_strerror(errno));
        return AM_ETRANSPORT;
    }
    p->connected_to = 1;
    return 0;
}

int am__socket_readable(am_ctx_t *ctx)
{
    if (!ctx->sock)
        return 0;
    int ev = 0;
    size_t len = sizeof ev;
    if (zmq_getsockopt(ctx->sock, ZMQ_EVENTS, &ev, &len) != 0)
        return 0;
    if (ev & ZMQ_POLLIN)
        return 1;
    /* ZMQ_EVENTS processed every pending command: the next frame will
     * signal ZMQ_FD again. */
    ctx->events_stale = 0;
    return 0;
}

/* ---------------------------------------------------------------- sending */

static void suspect(am_ctx_t *ctx, int pe, double now);

static int peer_gone(am_ctx_t *ctx, int pe)
{
    char why[AM__REASON_MAX];
    if (ctx->peers[pe].said_bye)
        snprintf(why, sizeof why,
                 "PE %d already finalized; a message to it cannot be delivered",
                 pe);
    else
        snprintf(why, sizeof why,
                 "PE %d went away: its connection is gone (the process died, "
                 "or was silent for %.1f s)",
                 pe, ctx->heartbeat);
    return am__peer_failed(ctx, pe, why);
}

int am__peer_failed(am_ctx_t *ctx, int pe, const char *why)
{
    if (ctx->failed)
        return ctx->failed;
    ctx->culprit = pe;
    /* Tell the others first: a PE that exits because of PE 3 would
     * otherwise be reported as the one that went away by PEs that notice
     * its own exit before PE 3's. */
    if (ctx->sock && ctx->state == AM__RUNNING) {
        ctx->aborting = 1;
        for (int to = 0; to < ctx->size; to++) {
            if (to == ctx->rank || to == pe || ctx->peers[to].said_bye)
                continue;
            pr_buf b = PR_BUF_INIT;
            am__ctl_begin(&b);
            am__abort_msg m = {(uint32_t)pe, {(const uint8_t *)why, strlen(why)}};
            am__abort_put(&b, &m);
            am__send_ctl(ctx, to, AM__CTL_ABORT, &b);
            pr_buf_free(&b);
        }
        ctx->aborting = 0;
    }
    return am__fail(ctx, AM_EPEER, "%s", why);
}

/* Hands msg to ZeroMQ. Returns 0 (msg consumed), 1 (would block: msg still
 * ours), 2 (dropped: while finalizing, a peer that already left cannot be
 * told goodbye; msg still ours), 3 (no route to the peer: msg still ours)
 * or a fatal code (msg still ours).
 *
 * No route is not a verdict: the peer may have left because a third PE
 * failed, and its ABORT naming that PE may still wait in our socket. So the
 * peer becomes a suspect, the frame waits in its send queue, and
 * am__check_peers judges it after the same grace as a disconnect, once
 * everything that arrived was read. */
static int zsend(am_ctx_t *ctx, int pe, zmq_msg_t *msg)
{
    uint8_t id[5];
    am__routing_id(pe, id);
    /* A send may process the commands that carried a ZMQ_FD edge. */
    ctx->events_stale = 1;
    if (zmq_send(ctx->sock, id, sizeof id, ZMQ_SNDMORE | ZMQ_DONTWAIT) < 0) {
        if (errno == EAGAIN)
            return 1;
        if (errno == EHOSTUNREACH &&
            (ctx->state == AM__CLOSING || ctx->aborting))
            return 2;
        if (errno == EHOSTUNREACH) {
            if (ctx->state != AM__RUNNING)
                return peer_gone(ctx, pe);
            suspect(ctx, pe, am__now());
            return 3;
        }
        return am__fail(ctx, AM_ETRANSPORT, "sending to PE %d failed: %s", pe,
                        zmq_strerror(errno));
    }
    /* Once the routing part is accepted the ROUTER takes the rest. */
    if (zmq_msg_send(msg, ctx->sock, ZMQ_DONTWAIT) < 0)
        return am__fail(ctx, AM_ETRANSPORT, "sending to PE %d failed: %s", pe,
                        zmq_strerror(errno));
    return 0;
}

/* A control frame that carries nothing for the user (count_send). */
#define USER_NONE (AM__USER_REPLY + 1u)

/* Counts one frame the transport accepted (handed to ZeroMQ, queued, or
 * looped back to this PE). This is the only place where sends are counted,
 * so no path can count a frame twice or not at all: a control frame counts
 * under its type; the user message a frame carries (a user AM's own, or an
 * RPC request's) counts under its handler and in msgs_sent/bytes_sent with
 * the user's payload length, and an RPC reply under the reply counters;
 * a basic message (a user AM, or a control type flagged AM__CTLF_BASIC)
 * advances the termination count. It runs on every am_send, so it only
 * adds to counters it indexes directly. */
static void count_send(am_ctx_t *ctx, unsigned flags, unsigned type,
                       size_t body_len, unsigned user, size_t user_len)
{
    int basic = 1;
    if (flags & PR_FLAG_CONTROL) {
        am__hstat *c = &ctx->ctl_st[type];
        c->sent++;
        c->sent_bytes += body_len;
        ctx->st.ctl_sent++;
        basic = (ctx->ctl[type]->flags & AM__CTLF_BASIC) != 0;
    }
    if (user < AM_HANDLER_MAX) {
        am__hstat *h = &ctx->handlers[user].st;
        h->sent++;
        h->sent_bytes += user_len;
        ctx->st.msgs_sent++;
        ctx->st.bytes_sent += user_len;
    } else if (user == AM__USER_REPLY) {
        ctx->rpc_reply_st.sent++;
        ctx->rpc_reply_st.sent_bytes += user_len;
    }
    if (basic)
        am__term_on_send(ctx);
}

/* Whether a frame to another PE waits in its send queue for the next
 * flush instead of going to ZeroMQ at once: while the PE runs with
 * coalescing on, except while it tells its peers about a failure (its
 * ABORTs leave at once: it is about to exit). */
static int defer_send(const am_ctx_t *ctx)
{
    return ctx->coalesce && ctx->state == AM__RUNNING && !ctx->aborting;
}

/* A queued frame's size, from its header: once ZeroMQ has sent it, its
 * message is empty. */
static size_t frame_size(const am__frame *f)
{
    return PR_HEADER_SIZE + (size_t)f->hdr.payload_len;
}

/* Appends f to pe's send queue and lists pe among the peers to flush. */
static void sendq_push(am_ctx_t *ctx, int pe, am__frame *f)
{
    am__peer *p = &ctx->peers[pe];
    am__fifo_push(&p->sendq, f);
    p->sendq_bytes += frame_size(f);
    ctx->sendq_total++;
    if (!p->in_sendq_peers) {
        p->in_sendq_peers = 1;
        ctx->sendq_peers[ctx->nsendq_peers++] = pe;
    }
}

/* Frees the frame at the head of pe's send queue (it was sent, or dropped
 * while finalizing). */
static void sendq_drop_head(am_ctx_t *ctx, int pe)
{
    am__peer *p = &ctx->peers[pe];
    am__frame *f = am__fifo_pop(&p->sendq);
    p->sendq_bytes -= frame_size(f);
    ctx->sendq_total--;
    am__frame_free(f);
}

static int flush_peer(am_ctx_t *ctx, int pe);

/* A ring peer's large frame (am__shm_big) goes by ZeroMQ: without a copy,
 * and streamed by the I/O threads while both PEs compute, where the ring
 * would hold only its size at a time and move on at the receiver's polls.
 * A SHM_VIA frame before it in the ring tells the receiver to take it
 * from ZeroMQ before it reads on; both wait in the send queue, in order,
 * and leave at once if nothing waits before them. h already holds the
 * next sequence number (the SHM_VIA's): the frame gets the one after. */
static int hand_over_big(am_ctx_t *ctx, int pe, pr_header *h, zmq_msg_t *msg)
{
    am__peer *p = &ctx->peers[pe];
    am__frame *mk = am__frame_new(), *f = am__frame_new();
    if (!mk || !f || (zmq_msg_close(&mk->msg),
                      zmq_msg_init_size(&mk->msg, PR_HEADER_SIZE) != 0)) {
        am__frame_free(mk);
        am__frame_free(f);
        return AM_ENOMEM;
    }
    pr_header mh = {PR_FLAG_CONTROL, AM__CTL_SHM_VIA, (uint32_t)ctx->rank, 0,
                    p->send_seq++};
    pr_header_encode(&mh, zmq_msg_data(&mk->msg));
    mk->hdr = mh;
    mk->src = pe;
    h->seq = p->send_seq++;
    pr_header_encode(h, zmq_msg_data(msg));
    zmq_msg_move(&f->msg, msg);
    f->hdr = *h;
    f->src = pe;
    f->via_zmq = 1;
    sendq_push(ctx, pe, mk);
    sendq_push(ctx, pe, f);
    count_send(ctx, PR_FLAG_CONTROL, AM__CTL_SHM_VIA, 0, USER_NONE, 0);
    if (p->sendq.n == 2) {
        int rc = flush_peer(ctx, pe);
        if (rc < 0)
            return rc;
    }
    return 0;
}

/* Writes h (its seq filled in here) into the header room of msg and hands
 * msg to ZeroMQ, the peer's send queue (later: to wait for the next flush
 * point), or the loopback queue. Takes ownership of msg on success only;
 * on failure the caller closes it. */
static int hand_over_frame(am_ctx_t *ctx, int pe, pr_header *h,
                           zmq_msg_t *msg, int later)
{
    am__frame *f;
    if (pe == ctx->rank) {
        if (!(f = am__frame_new()))
            return AM_ENOMEM;
        pr_header_encode(h, zmq_msg_data(msg));
        zmq_msg_move(&f->msg, msg);
        f->hdr = *h;
        f->src = pe;
        am__fifo_push(&ctx->loopback, f);
        return 0;
    }
    am__peer *p = &ctx->peers[pe];
    h->seq = p->send_seq;
    pr_header_encode(h, zmq_msg_data(msg));
    /* A ring peer: the frame goes into the ring now if it fits whole
     * (there is nothing to bundle, and the sooner the receiver sees it
     * the better), else it waits in the send queue, and what fits of it
     * goes at once. */
    int ring = am__shm_out_on(ctx, pe);
    if (ring) {
        size_t n = zmq_msg_size(msg);
        if (am__shm_big(ctx, n))
            return hand_over_big(ctx, pe, h, msg);
        if (p->sendq.n == 0 && am__shm_room(ctx, pe) >= n) {
            am__shm_put(ctx, pe, zmq_msg_data(msg), n);
            am__shm_publish(ctx, pe);
            p->send_seq++;
            zmq_msg_close(msg);
            return 0;
        }
        later = 0;
    }
    if (p->sendq.n == 0 && !later && !ring) {
        int rc = zsend(ctx, pe, msg);
        if (rc == 2) /* dropped while finalizing */
            zmq_msg_close(msg);
        if (rc != 1 && rc != 3) {
            if (rc >= 0)
                p->send_seq++;
            return rc < 0 ? rc : 0;
        }
    }
    /* It waits for the next flush, or ZeroMQ cannot take it now (or
     * earlier frames wait): queue it. On failure nothing was sent, and msg
     * is still the caller's. */
    if (!(f = am__frame_new()))
        return AM_ENOMEM;
    p->send_seq++;
    zmq_msg_move(&f->msg, msg);
    f->hdr = *h;
    f->src = pe;
    /* Counted in queued_sends if ZeroMQ refused it or an earlier frame it
     * refused holds it back; deferred frames are counted by flush_peer if
     * ZeroMQ refuses them there. */
    if (!later && (p->sendq.n == 0 || p->sendq.tail->refused)) {
        f->refused = 1;
        ctx->st.queued_sends++;
    }
    sendq_push(ctx, pe, f);
    /* A full bundle's worth goes now: waiting longer would not make the
     * messages fewer. A ring peer's frame starts at once. */
    if (ring ? p->sendq.n == 1
             : later && p->sendq_bytes >= AM__BUNDLE_MAX) {
        int rc = flush_peer(ctx, pe);
        if (rc < 0)
            return rc;
    }
    return 0;
}

int am__hand_over(am_ctx_t *ctx, int pe, pr_header *h, zmq_msg_t *msg)
{
    /* Basic frames (user AMs, RPC) wait for a flush point. Any other
     * control frame (a collective's, the termination token, a credit,
     * BYE...) marks a point where the PE synchronises and may then compute
     * without polling (a barrier that finds its children's contributions
     * already there returns at once): it leaves now, and takes with it
     * every frame that waits, to every peer, in order. */
    int coalescing = defer_send(ctx);
    int later = coalescing && am__is_basic(ctx, h);
    int rc = hand_over_frame(ctx, pe, h, msg, later);
    /* The frame is ours now: a failure of the flush is the context's
     * (am__fail), not this send's. */
    if (rc == 0 && coalescing && !later && ctx->sendq_total)
        am__flush_sendq(ctx);
    return rc;
}

/* Sends a frame already holding header room (every send path ends here,
 * the probe in unreachable() excepted) and counts it. user and user_len
 * say what it carries for the user (count_send): a user AM carries itself,
 * its handler id and payload length. A basic frame passes flow control
 * first (am_flow.c): it may wait for room in the window (threads, main
 * context) or in the held queue (callbacks), or be refused (AM_EFULL).
 * Takes ownership of msg on success only. */
static int send_frame(am_ctx_t *ctx, int pe, unsigned flags, unsigned handler,
                      zmq_msg_t *msg, unsigned user, size_t user_len)
{
    size_t size = zmq_msg_size(msg);
    size_t body_len = size - PR_HEADER_SIZE;
    pr_header h = {(uint8_t)flags, (uint16_t)handler, (uint32_t)ctx->rank,
                   (uint32_t)body_len, 0};
    int basic = am__is_basic(ctx, &h);
    int rc = basic ? am__flow_reserve(ctx, pe, size) : 0;
    if (rc < 0)
        return rc;
    if (rc == 1) {
        rc = am__flow_hold(ctx, pe, &h, msg);
    } else {
        rc = am__hand_over(ctx, pe, &h, msg);
        if (rc && basic)
            am__flow_unreserve(ctx, pe, size);
    }
    if (rc == 0)
        count_send(ctx, flags, handler, body_len, user, user_len);
    return rc;
}

/* How many frames from the head of q go out in the next ZeroMQ message,
 * and their bytes in *bytes: the longest run of frames of at most
 * AM__BUNDLE_FRAME_MAX bytes each and AM__BUNDLE_MAX in all (with
 * coalescing on), else the head alone. */
static size_t bundle_span(const am_ctx_t *ctx, const am__fifo *q,
                          size_t *bytes)
{
    size_t k = 0, sum = 0;
    for (const am__frame *f = q->head; f && ctx->coalesce; f = f->next) {
        size_t n = zmq_msg_size(&f->msg);
        if (n > AM__BUNDLE_FRAME_MAX || sum + n > AM__BUNDLE_MAX)
            break;
        sum += n;
        k++;
    }
    if (k < 2) {
        *bytes = zmq_msg_size(&q->head->msg);
        return 1;
    }
    *bytes = sum;
    return k;
}

/* Copies the first k frames of q, back to back, into msg (bytes long). */
static int bundle_build(am__fifo *q, size_t k, size_t bytes, zmq_msg_t *msg)
{
    if (zmq_msg_init_size(msg, bytes) != 0)
        return AM_ENOMEM;
    uint8_t *out = zmq_msg_data(msg);
    am__frame *f = q->head;
    for (size_t i = 0; i < k; i++, f = f->next) {
        size_t n = zmq_msg_size(&f->msg);
        memcpy(out, zmq_msg_data(&f->msg), n);
        out += n;
    }
    return 0;
}

/* Counts the frames of an attempt ZeroMQ refused (queued_sends), each
 * once however many times it is refused. */
static void count_refused(am_ctx_t *ctx, am__fifo *q, size_t k)
{
    am__frame *f = q->head;
    for (size_t i = 0; i < k && f; i++, f = f->next)
        if (!f->refused) {
            f->refused = 1;
            ctx->st.queued_sends++;
        }
}

/* Writes pe's queued frames into its ring until it is full; the frame
 * at the head may be written in pieces (f->off), over several flushes. */
static int flush_ring(am_ctx_t *ctx, int pe)
{
    am__peer *p = &ctx->peers[pe];
    int wrote = 0;
    while (p->sendq.head) {
        am__frame *f = p->sendq.head;
        if (f->via_zmq) {
            /* Its SHM_VIA must be visible first. */
            if (wrote)
                am__shm_publish(ctx, pe);
            wrote = 0;
            int rc = zsend(ctx, pe, &f->msg);
            if (rc < 0 || rc == 3)
                return rc;
            if (rc == 1) {
                count_refused(ctx, &p->sendq, 1);
                break;
            }
            sendq_drop_head(ctx, pe);
            continue;
        }
        size_t n = zmq_msg_size(&f->msg);
        size_t put = am__shm_put(ctx, pe, (const uint8_t *)zmq_msg_data(&f->msg)
                                              + f->off, n - f->off);
        f->off += put;
        wrote |= put > 0;
        if (f->off < n) {
            count_refused(ctx, &p->sendq, 1);
            break;
        }
        sendq_drop_head(ctx, pe);
    }
    if (wrote)
        am__shm_publish(ctx, pe);
    return 0;
}

/* Hands pe's queued frames to ZeroMQ, bundled, until it would block (or
 * to its ring). Returns 0, 3 if the peer has no route (zsend), or a fatal
 * code. */
static int flush_peer(am_ctx_t *ctx, int pe)
{
    am__peer *p = &ctx->peers[pe];
    if (am__shm_out_on(ctx, pe))
        return flush_ring(ctx, pe);
    while (p->sendq.head) {
        size_t bytes, k = bundle_span(ctx, &p->sendq, &bytes);
        zmq_msg_t bundle, *m = &p->sendq.head->msg;
        if (k > 1) {
            if (bundle_build(&p->sendq, k, bytes, &bundle))
                return am__fail(ctx, AM_ENOMEM, "out of memory bundling "
                                                "frames to PE %d", pe);
            m = &bundle;
        }
        int rc = zsend(ctx, pe, m);
        if (k > 1 && rc != 0)
            zmq_msg_close(&bundle);
        if (rc < 0 || rc == 3)
            return rc;
        if (rc == 1) {
            count_refused(ctx, &p->sendq, k);
            break;
        }
        if (k > 1 && rc == 0) {
            ctx->st.bundles_sent++;
            ctx->st.bundled_sent += k;
        }
        /* Sent (0) or dropped while finalizing (2). */
        while (k-- > 0)
            sendq_drop_head(ctx, pe);
    }
    return 0;
}

int am__flush_sendq(am_ctx_t *ctx)
{
    /* Peers whose queue empties leave the list; those ZeroMQ refused stay
     * for the next flush. */
    int kept = 0, rc = 0;
    for (int i = 0; i < ctx->nsendq_peers; i++) {
        int pe = ctx->sendq_peers[i];
        if (!rc && (rc = flush_peer(ctx, pe)) > 0)
            rc = 0;
        if (ctx->peers[pe].sendq.n)
            ctx->sendq_peers[kept++] = pe;
        else
            ctx->peers[pe].in_sendq_peers = 0;
    }
    ctx->nsendq_peers = kept;
    return rc;
}

int am_flush(am_ctx_t *ctx)
{
    if (!ctx)
        return AM_EINVAL;
    if (ctx->failed)
        return ctx->failed;
    return ctx->sendq_total ? am__flush_sendq(ctx) : 0;
}

void am__ctl_begin(pr_buf *body)
{
    pr_buf_reset(body);
    static const uint8_t gap[PR_HEADER_SIZE];
    pr_put_bytes(body, gap, sizeof gap);
}

static void free_buf(void *data, void *hint)
{
    (void)hint;
    pr_free(data);
}

static int send_ctl(am_ctx_t *ctx, int pe, unsigned type, pr_buf *body,
                    unsigned user, size_t user_len)
{
    if (type == 0 || type >= AM__CTL_COUNT) {
        pr_buf_reset(body);
        return AM_EINVAL;
    }
    if (body->err) {
        pr_buf_reset(body);
        return AM_ENOMEM;
    }
    size_t len;
    uint8_t *data = pr_buf_take(body, &len);
    if (!data || len < PR_HEADER_SIZE || len - PR_HEADER_SIZE > PR_MAX_PAYLOAD) {
        pr_free(data);
        return AM_EINVAL;
    }
    zmq_msg_t m;
    if (zmq_msg_init_data(&m, data, len, free_buf, NULL) != 0) {
        pr_free(data);
        return AM_ENOMEM;
    }
    int rc = send_frame(ctx, pe, PR_FLAG_CONTROL, type, &m, user, user_len);
    if (rc)
        zmq_msg_close(&m);
    return rc;
}

int am__send_ctl(am_ctx_t *ctx, int pe, unsigned type, pr_buf *body)
{
    return send_ctl(ctx, pe, type, body, USER_NONE, 0);
}

int am__send_ctl_carrying(am_ctx_t *ctx, int pe, unsigned type, pr_buf *body,
                          unsigned user, size_t user_len)
{
    return send_ctl(ctx, pe, type, body, user, user_len);
}

static int check_send_args(am_ctx_t *ctx, int pe, unsigned id, size_t len)
{
    if (!ctx || pe < 0 || pe >= ctx->size || id >= AM_HANDLER_MAX ||
        len > AM_MAX_PAYLOAD)
        return AM_EINVAL;
    if (ctx->failed)
        return ctx->failed;
    if (ctx->state != AM__RUNNING)
        return AM_ESTATE;
    return 0;
}

int am_send(am_ctx_t *ctx, int pe, unsigned id, const void *data, size_t len)
{
    int rc = check_send_args(ctx, pe, id, len);
    if (rc)
        return rc;
    if (len && !data)
        return AM_EINVAL;
    zmq_msg_t m;
    if (zmq_msg_init_size(&m, PR_HEADER_SIZE + len) != 0)
        return AM_ENOMEM;
    if (len)
        memcpy((uint8_t *)zmq_msg_data(&m) + PR_HEADER_SIZE, data, len);
    rc = send_frame(ctx, pe, 0, id, &m, id, len);
    if (rc)
        zmq_msg_close(&m);
    return rc;
}

/* Zero-copy frames go to ZeroMQ with this trampoline as their free
 * function, so that a send that fails can release the ZeroMQ message
 * without calling the user's function (the contract of am_send_zc). */
typedef struct zc_owner {
    am_free_fn ffn;
    void *hint;
    int armed;
} zc_owner;

static void zc_release(void *frame, void *hint)
{
    zc_owner *o = hint;
    if (o->armed && o->ffn)
        o->ffn(frame, o->hint);
    pr_free(o);
}

int am_send_zc(am_ctx_t *ctx, int pe, unsigned id, void *frame, size_t len,
               am_free_fn ffn, void *hint)
{
    int rc = check_send_args(ctx, pe, id, len);
    if (rc)
        return rc;
    if (!frame)
        return AM_EINVAL;
    zc_owner *o = pr_malloc(sizeof *o);
    if (!o)
        return AM_ENOMEM;
    *o = (zc_owner){ffn, hint, 1};
    zmq_msg_t m;
    if (zmq_msg_init_data(&m, frame, PR_HEADER_SIZE + len, zc_release, o)) {
        pr_free(o);
        return AM_ENOMEM;
    }
    rc = send_frame(ctx, pe, 0, id, &m, id, len);
    if (rc) {
        o->armed = 0;
        zmq_msg_close(&m);
    }
    return rc;
}

void *am_buf_alloc(size_t len)
{
    if (len > AM_MAX_PAYLOAD)
        return NULL;
    uint8_t *p = pr_malloc(AM_HEADROOM + (len ? len : 1));
    return p ? p + AM_HEADROOM : NULL;
}

void am_buf_free(void *payload)
{
    if (payload)
        pr_free((uint8_t *)payload - AM_HEADROOM);
}

int am_send_buf(am_ctx_t *ctx, int pe, unsigned id, void *payload, size_t len)
{
    if (!payload)
        return AM_EINVAL;
    return am_send_zc(ctx, pe, id, (uint8_t *)payload - AM_HEADROOM, len,
                      free_buf, NULL);
}

int am_register(am_ctx_t *ctx, unsigned id, const char *name, am_handler_fn fn,
                void *arg)
{
    if (!ctx || id >= AM_HANDLER_MAX || !fn)
        return AM_EINVAL;
    am__handler *h = &ctx->handlers[id];
    char *copy = NULL;
    if (name && !(copy = pr_strdup(name)))
        return AM_ENOMEM;
    pr_free(h->name);
    h->name = copy;
    h->fn = fn;
    h->arg = arg;
    return 0;
}

/* -------------------------------------------------------------- receiving */

int am__frame_check(const am_ctx_t *ctx, const void *id, size_t id_len,
                    const void *frame, size_t len, int *src, pr_header *hdr)
{
    /* The routing id is checked after the header, so that garbage from a
     * stranger is counted under what is wrong with it, but it is read
     * first, to name the sender in messages when it is a PE of the job. */
    const uint8_t *ip = id;
    uint32_t r = id_len == 5 && ip[0] == 'P' ? pr_load_u32(ip + 1) : UINT32_MAX;
    *src = r < (uint32_t)ctx->size && (int)r != ctx->rank ? (int)r : -1;
    switch (pr_header_decode(hdr, frame, len)) {
    case 0:
        break;
    case PR_ETRUNC:
        return AM__REJ_TRUNC + 1;
    case PR_EMAGIC:
        return AM__REJ_MAGIC + 1;
    case PR_EVERSION:
        return AM__REJ_VERSION + 1;
    case PR_EFLAGS:
        return AM__REJ_FLAGS + 1;
    default:
        return AM__REJ_LENGTH + 1;
    }
    if ((size_t)hdr->payload_len != len - PR_HEADER_SIZE)
        return AM__REJ_LENGTH + 1;
    if (*src < 0)
        return AM__REJ_IDENTITY + 1;
    if (hdr->sender != r)
        return AM__REJ_SENDER + 1;
    if (hdr->seq < ctx->peers[r].recv_seq)
        return AM__REJ_SEQ + 1;
    return 0;
}

void am__reject(am_ctx_t *ctx, int reason, int src, const char *detail)
{
    ctx->rejected[reason]++;
    ctx->st.rejected++;
    if (ctx->warned[reason]++)
        return;
    char from[32] = "an unknown sender";
    if (src >= 0)
        snprintf(from, sizeof from, "PE %d", src);
    am__warn(ctx, "dropped a frame from %s: %s%s%s (further such frames are "
                  "only counted)",
             from, reject_msg[reason], detail ? ": " : "", detail ? detail : "");
}

/* The dispatch table's entry of a control frame's type; NULL for a user
 * frame, and for a type no module handles (am__dispatch rejects those). */
static const am__ctl_entry *ctl_entry(const am_ctx_t *ctx, const pr_header *h)
{
    if (!(h->flags & PR_FLAG_CONTROL) || h->handler >= AM__CTL_COUNT)
        return NULL;
    return ctx->ctl[h->handler];
}

static int is_boot_frame(const am_ctx_t *ctx, const am__frame *f)
{
    const am__ctl_entry *e = ctl_entry(ctx, &f->hdr);
    return e && (e->flags & AM__CTLF_BOOT);
}

int am__is_basic(const am_ctx_t *ctx, const pr_header *h)
{
    if (!(h->flags & PR_FLAG_CONTROL))
        return 1;
    const am__ctl_entry *e = ctl_entry(ctx, h);
    return e && (e->flags & AM__CTLF_BASIC);
}

/* Moves a frame that lives on the stack into a queue node. */
static am__frame *keep(am_ctx_t *ctx, am__frame *f)
{
    am__frame *k = am__frame_new();
    if (!k) {
        zmq_msg_close(&f->msg);
        am__fail(ctx, AM_ENOMEM, "out of memory queueing a frame");
        return NULL;
    }
    zmq_msg_move(&k->msg, &f->msg);
    zmq_msg_close(&f->msg);
    k->hdr = f->hdr;
    k->src = f->src;
    return k;
}

/* Takes one validated frame (on the stack) from the network to its next
 * stage: the boot stash, a latency queue, the deferred queue (each needs
 * a node), or straight to its handler (no allocation). */
static void route_frame(am_ctx_t *ctx, am__frame *f)
{
    am__frame *k;
    const am__ctl_entry *e = ctl_entry(ctx, &f->hdr);
    if (e && (e->flags & AM__CTLF_URGENT)) {
        am__dispatch(ctx, f);
        zmq_msg_close(&f->msg);
    } else if (ctx->state == AM__BOOTING && !is_boot_frame(ctx, f)) {
        if ((k = keep(ctx, f)))
            am__fifo_push(&ctx->early, k);
    } else if (ctx->lat.on && ctx->state == AM__RUNNING) {
        if ((k = keep(ctx, f)))
            am__latency_enqueue(ctx, k);
    } else if (ctx->term.defer && am__is_basic(ctx, &f->hdr)) {
        if ((k = keep(ctx, f)))
            am__fifo_push(&ctx->deferred, k);
    } else {
        am__dispatch(ctx, f);
        zmq_msg_close(&f->msg);
    }
}

/* Validates one frame taken from the network (fr->msg holds exactly the
 * frame) and routes it. id is the routing id of the message that carried
 * it, uid the CURVE user id ZAP gave that message (NULL or "": none).
 * Returns 0 if the frame was routed, 1 if it was rejected (counted; the
 * rest of its bundle is dropped with it: after a bad frame the framing of
 * the rest is no longer trusted). Consumes fr->msg. */
static int take_frame(am_ctx_t *ctx, const void *id, size_t id_len,
                      const char *uid, int ring, am__frame *fr)
{
    int src;
    const uint8_t *data = zmq_msg_data(&fr->msg);
    size_t len = zmq_msg_size(&fr->msg);
    int why = am__frame_check(ctx, id, id_len, data, len, &src, &fr->hdr);
    /* From a peer whose frames come through its ring, ZeroMQ carries only
     * the liveness probe (unreachable()): a PING without a sequence
     * number of its own. Anything else there would break the order. */
    if (!ring && src >= 0 && (!why || why == AM__REJ_SEQ + 1) &&
        am__shm_in_on(ctx, src)) {
        int ping = (fr->hdr.flags & PR_FLAG_CONTROL) &&
                   fr->hdr.handler == AM__CTL_PING;
        if (ping) {
            fr->src = src;
            route_frame(ctx, fr);
            return 0;
        }
        /* A large frame a SHM_VIA announces: taken as any other if the
         * ring waits for it (then the ring is read on); else it overtook
         * its SHM_VIA, and waits for it. */
        if (why) {
            am__reject(ctx, AM__REJ_SEQ, src, "a frame beside the ring");
            zmq_msg_close(&fr->msg);
            return 1;
        }
        if (!am__shm_paused(ctx, src)) {
            if (am__shm_stash(ctx, src, &fr->msg)) {
                zmq_msg_close(&fr->msg);
                am__fail(ctx, AM_ENOMEM, "out of memory queueing a frame");
                return 1;
            }
            return 0;
        }
        am__shm_resume(ctx, src);
    }
    if (why) {
        if (why - 1 == AM__REJ_VERSION) {
            char detail[96];
            snprintf(detail, sizeof detail,
                     "it speaks wire protocol version %u, this PE speaks "
                     "version %d",
                     len > 4 ? data[4] : 0, PR_VERSION);
            if (ctx->state == AM__BOOTING && src >= 0) {
                zmq_msg_close(&fr->msg);
                am__fail(ctx, AM_EPROTO, "PE %d %s", src, detail + 3);
                return 1;
            }
            am__reject(ctx, AM__REJ_VERSION, src, detail);
        } else {
            am__reject(ctx, why - 1, src, NULL);
        }
        zmq_msg_close(&fr->msg);
        return 1;
    }
    /* With CURVE, a client's frames carry the rank the ZAP handler found
     * for its key: a PE cannot speak under another's routing id. (Frames
     * on connections this PE made carry none: there the server proved it
     * holds the key of the PE we meant.) */
    if (uid && *uid && strtol(uid, NULL, 10) != src) {
        char detail[64];
        snprintf(detail, sizeof detail, "its CURVE key is PE %.8s's", uid);
        am__reject(ctx, AM__REJ_IDENTITY, src, detail);
        zmq_msg_close(&fr->msg);
        return 1;
    }
    am__peer *p = &ctx->peers[src];
    if (fr->hdr.seq > p->recv_seq)
        am__warn(ctx, "sequence gap from PE %d (expected %llu, got %llu): "
                      "frames were lost",
                 src, (unsigned long long)p->recv_seq,
                 (unsigned long long)fr->hdr.seq);
    p->recv_seq = fr->hdr.seq + 1;
    if (p->said_bye) {
        am__reject(ctx, AM__REJ_LATE, src, NULL);
        zmq_msg_close(&fr->msg);
        return 1;
    }
    fr->src = src;
    route_frame(ctx, fr);
    return 0;
}

/* Takes a bundle (msg holds several frames back to back): each frame is
 * copied into a message of its own (frames may wait in queues, and a
 * bundle holds small frames only) and taken as a lone frame would be, in
 * order. A tail that is not a whole frame is checked as one, and so
 * rejected for what is wrong with it. Returns the number of frames taken.
 * Consumes msg. */
static int take_bundle(am_ctx_t *ctx, zmq_msg_t *id, zmq_msg_t *msg)
{
    const uint8_t *data = zmq_msg_data(msg);
    size_t len = zmq_msg_size(msg), off = 0;
    const char *uid = ctx->zap ? zmq_msg_gets(msg, "User-Id") : NULL;
    int taken = 0;
    while (off < len && !ctx->failed) {
        size_t n = am__bundle_next(data + off, len - off);
        if (n == 0)
            n = len - off;
        am__frame fr;
        memset(&fr, 0, sizeof fr);
        if (zmq_msg_init_size(&fr.msg, n) != 0) {
            am__fail(ctx, AM_ENOMEM, "out of memory taking a bundle apart");
            break;
        }
        memcpy(zmq_msg_data(&fr.msg), data + off, n);
        off += n;
        taken++;
        if (take_frame(ctx, zmq_msg_data(id), zmq_msg_size(id), uid, 0, &fr))
            break;
    }
    if (taken > 1) {
        ctx->st.bundles_recv++;
        ctx->st.bundled_recv += (uint64_t)taken;
    }
    zmq_msg_close(msg);
    return taken;
}

/* Takes up to budget frames from the rings, each peer's in turn (the
 * first one rotates, so that no peer is starved). */
static int recv_rings(am_ctx_t *ctx, unsigned budget)
{
    int taken = 0;
    int first = am__shm_first(ctx);
    for (int i = 0; i < ctx->size && !ctx->failed; i++) {
        int pe = (first + i) % ctx->size;
        if (!am__shm_in_on(ctx, pe) || am__shm_paused(ctx, pe))
            continue;
        uint8_t id[5];
        am__routing_id(pe, id);
        while ((unsigned)taken < budget && !ctx->failed) {
            am__frame fr;
            memset(&fr, 0, sizeof fr);
            if (am__shm_take(ctx, pe, &fr.msg) <= 0)
                break;
            taken++;
            take_frame(ctx, id, sizeof id, NULL, 1, &fr);
            /* A SHM_VIA: its frame may have come already. */
            if (am__shm_paused(ctx, pe)) {
                memset(&fr, 0, sizeof fr);
                if (!am__shm_unstash(ctx, pe, &fr.msg))
                    break;
                take_frame(ctx, id, sizeof id, NULL, 0, &fr);
            }
        }
        /* The room goes back, and a writer waiting for it is woken. */
        am__shm_release(ctx, pe);
    }
    return taken;
}

static int recv_zmq(am_ctx_t *ctx, unsigned budget);

int am__recv_some(am_ctx_t *ctx, unsigned budget)
{
    int taken = ctx->shm ? recv_rings(ctx, budget) : 0;
    if ((unsigned)taken < budget)
        taken += recv_zmq(ctx, budget - (unsigned)taken);
    return taken;
}

/* While every peer's frames come through rings, ZeroMQ carries nothing
 * but probes (and the rings' polls cost no system call, where asking
 * ZeroMQ costs one): am_poll then reads it only this often; am_idle
 * always looks before blocking (events_stale stays set). */
#define ZMQ_GAP 0.5e-3

int am__recv_poll(am_ctx_t *ctx, unsigned budget)
{
    int taken = ctx->shm ? recv_rings(ctx, budget) : 0;
    if ((unsigned)taken >= budget)
        return taken;
    if (am__shm_all_in(ctx)) {
        double now = am__now();
        if (now < ctx->zmq_next) {
            ctx->events_stale = 1;
            return taken;
        }
        ctx->zmq_next = now + ZMQ_GAP;
    }
    return taken + recv_zmq(ctx, budget - (unsigned)taken);
}

static int recv_zmq(am_ctx_t *ctx, unsigned budget)
{
    int taken = 0;
    while (!ctx->failed) {
        if ((unsigned)taken >= budget) {
            /* Frames may remain: re-read ZMQ_EVENTS before blocking. */
            ctx->events_stale = 1;
            break;
        }
        zmq_msg_t id;
        zmq_msg_init(&id);
        if (zmq_msg_recv(&id, ctx->sock, ZMQ_DONTWAIT) < 0) {
            int e = errno;
            zmq_msg_close(&id);
            if (e == EINTR)
                continue;
            if (e != EAGAIN)
                am__fail(ctx, AM_ETRANSPORT, "receiving failed: %s",
                         zmq_strerror(e));
            else
                ctx->events_stale = 0; /* as after ZMQ_EVENTS */
            break;
        }
        am__frame fr;
        memset(&fr, 0, sizeof fr);
        zmq_msg_init(&fr.msg);
        int parts_ok = zmq_msg_more(&id) &&
                       zmq_msg_recv(&fr.msg, ctx->sock, ZMQ_DONTWAIT) >= 0 &&
                       !zmq_msg_more(&fr.msg);
        if (!parts_ok) {
            /* Swallow the rest of a multipart message. */
            zmq_msg_t junk;
            zmq_msg_init(&junk);
            int more = zmq_msg_more(&fr.msg);
            while (more && zmq_msg_recv(&junk, ctx->sock, ZMQ_DONTWAIT) >= 0)
                more = zmq_msg_more(&junk);
            zmq_msg_close(&junk);
            zmq_msg_close(&id);
            zmq_msg_close(&fr.msg);
            am__reject(ctx, AM__REJ_PARTS, -1, NULL);
            taken++;
            continue;
        }
        /* One frame (or a bad one) is taken without a copy; a message
         * holding more than its first frame is a bundle. */
        size_t len = zmq_msg_size(&fr.msg);
        size_t first = am__bundle_next(zmq_msg_data(&fr.msg), len);
        if (first != 0 && first < len) {
            taken += take_bundle(ctx, &id, &fr.msg);
        } else {
            const char *uid =
                ctx->zap ? zmq_msg_gets(&fr.msg, "User-Id") : NULL;
            taken++;
            take_frame(ctx, zmq_msg_data(&id), zmq_msg_size(&id), uid, 0,
                       &fr);
        }
        zmq_msg_close(&id);
    }
    return taken;
}

void am__arrive(am_ctx_t *ctx, am__frame *f)
{
    if (ctx->term.defer && am__is_basic(ctx, &f->hdr)) {
        am__fifo_push(&ctx->deferred, f);
        return;
    }
    am__dispatch(ctx, f);
    am__frame_free(f);
}

void am__deliver_user(am_ctx_t *ctx, int src, unsigned id, const void *data,
                      size_t len, uint64_t call_id)
{
    /* Counted as delivered for termination even when dropped: otherwise a
     * message to a missing handler would stay "in flight" for ever. */
    am__term_on_deliver(ctx);
    ctx->delivered++;
    if (id >= AM_HANDLER_MAX || !ctx->handlers[id].fn) {
        char detail[48];
        snprintf(detail, sizeof detail, "handler id %u", id);
        am__reject(ctx, AM__REJ_HANDLER, src, detail);
        return;
    }
    am__handler *h = &ctx->handlers[id];
    h->st.recv++;
    h->st.recv_bytes += len;
    ctx->st.msgs_recv++;
    ctx->st.bytes_recv += len;
    am_msg_t m = {src, id, len ? data : NULL, len, call_id};
    double t0 = am__now();
    ctx->in_callback++;
    h->fn(ctx, &m, h->arg);
    ctx->in_callback--;
    double dt = am__now() - t0;
    h->st.seconds += dt;
    ctx->st.handler_s += dt;
}

void am__dispatch(am_ctx_t *ctx, am__frame *f)
{
    const uint8_t *payload = (const uint8_t *)zmq_msg_data(&f->msg) + PR_HEADER_SIZE;
    size_t len = f->hdr.payload_len;
    if (!(f->hdr.flags & PR_FLAG_CONTROL)) {
        am__deliver_user(ctx, f->src, f->hdr.handler, payload, len, 0);
    } else {
        const am__ctl_entry *e = ctl_entry(ctx, &f->hdr);
        if (!e) {
            am__reject(ctx, AM__REJ_BODY, f->src, "unknown control type");
            return;
        }
        am__hstat *st = &ctx->ctl_st[f->hdr.handler];
        st->recv++;
        st->recv_bytes += len;
        ctx->st.ctl_recv++;
        pr_reader r;
        pr_reader_init(&r, payload, len);
        e->fn(ctx, f->src, &r);
        if (!(e->flags & AM__CTLF_BASIC))
            return;
    }
    /* Its handler ran (or refused it): the room goes back to the sender. */
    am__flow_consumed(ctx, f->src, PR_HEADER_SIZE + len);
}

/* ------------------------------------------------------ failure detection */

static void suspect(am_ctx_t *ctx, int pe, double now)
{
    am__peer *p = &ctx->peers[pe];
    if (p->said_bye || p->suspect)
        return;
    p->suspect = 1;
    p->suspect_since = now;
    ctx->suspects++;
}

/* Why a handshake failed, from a monitor event and its value. */
static const char *handshake_why(uint16_t event, uint32_t value, char *buf,
                                 size_t n)
{
    if (event == ZMQ_EVENT_HANDSHAKE_FAILED_AUTH)
        snprintf(buf, n, "the other side refused the key (ZAP status %u)",
                 (unsigned)value);
    else if (event == ZMQ_EVENT_HANDSHAKE_FAILED_NO_DETAIL)
        snprintf(buf, n, "the connection ended during the handshake (%s)",
                 zmq_strerror((int)value));
    else if (value == ZMQ_PROTOCOL_ERROR_ZMTP_MECHANISM_MISMATCH)
        snprintf(buf, n, "the other side does not use CURVE");
    else if (value == ZMQ_PROTOCOL_ERROR_ZMTP_CRYPTOGRAPHIC)
        snprintf(buf, n, "a CURVE box did not open: the client does not "
                         "know the server's public key");
    else
        snprintf(buf, n, "protocol error 0x%x", (unsigned)value);
    return buf;
}

/* A failed handshake the monitor reported, while booting or running. On
 * a connection this PE made, libzmq names the peer's endpoint: logged once
 * per peer (a PE of another job, or keys that do not match; libzmq keeps
 * retrying). On an accepted one it names only this PE's endpoint, not the
 * client's address: a refusal by the ZAP handler was logged there, with
 * the address; other failures (a client without CURVE, or without this
 * PE's public key) are logged once. All are counted. */
static void handshake_failed(am_ctx_t *ctx, uint16_t event, uint32_t value,
                             const char *where)
{
    char why[160];
    ctx->hs_failed++;
    for (int pe = 0; pe < ctx->size; pe++) {
        am__peer *p = &ctx->peers[pe];
        if (pe == ctx->rank || !p->connected_to || !p->endpoint ||
            strcmp(p->endpoint, where))
            continue;
        if (ctx->hs_peer_warned && !ctx->hs_peer_warned[pe]) {
            ctx->hs_peer_warned[pe] = 1;
            am__warn(ctx, "the CURVE handshake with PE %d at %s failed: %s "
                          "(keys of another job?); retrying",
                     pe, where, handshake_why(event, value, why, sizeof why));
        }
        return;
    }
    ctx->hs_stranger = 1;
    if (event == ZMQ_EVENT_HANDSHAKE_FAILED_AUTH || ctx->hs_warned++)
        return;
    am__warn(ctx, "a client of %s failed its handshake: %s (not one of the "
                  "job's PEs; libzmq does not say from where; further failed "
                  "handshakes are only counted)",
             where, handshake_why(event, value, why, sizeof why));
}

/* Reads the monitor's queued events: counts failed handshakes and, while
 * running, marks the peers a disconnect may concern. Also called while
 * booting, so that events do not pile up (libzmq's I/O thread blocks on a
 * full monitor pipe). */
static void read_monitor(am_ctx_t *ctx, double now)
{
    for (;;) {
        zmq_msg_t ev, addr;
        zmq_msg_init(&ev);
        if (zmq_msg_recv(&ev, ctx->mon, ZMQ_DONTWAIT) < 0) {
            zmq_msg_close(&ev);
            return;
        }
        uint16_t event = 0;
        uint32_t value = 0;
        if (zmq_msg_size(&ev) >= 6) { /* native byte order */
            memcpy(&event, zmq_msg_data(&ev), 2);
            memcpy(&value, (const uint8_t *)zmq_msg_data(&ev) + 2, 4);
        }
        int more = zmq_msg_more(&ev);
        zmq_msg_close(&ev);
        char where[AM__EP_MAX] = "";
        if (more) {
            zmq_msg_init(&addr);
            if (zmq_msg_recv(&addr, ctx->mon, ZMQ_DONTWAIT) >= 0) {
                size_t n = zmq_msg_size(&addr);
                if (n >= sizeof where)
                    n = sizeof where - 1;
                memcpy(where, zmq_msg_data(&addr), n);
                where[n] = '\0';
            }
            zmq_msg_close(&addr);
        }
        if (event == ZMQ_EVENT_HANDSHAKE_FAILED_NO_DETAIL ||
            event == ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL ||
            event == ZMQ_EVENT_HANDSHAKE_FAILED_AUTH) {
            ctx->hs_stranger = 0;
            handshake_failed(ctx, event, value, where);
            continue;
        }
        /* libzmq reports a failed handshake and then, at once, from the
         * same I/O thread, the disconnect of that connection. An unnamed
         * disconnect right after a stranger's failed handshake is the
         * stranger's: it does not make the accepted peers suspects (which
         * would probe each of them for the next 2 s, a PING per peer per
         * housekeeping round, for every attempt of a port scanner). */
        int stranger = ctx->hs_stranger;
        ctx->hs_stranger = 0;
        if (event != ZMQ_EVENT_DISCONNECTED || ctx->state != AM__RUNNING)
            continue;
        int named = 0;
        for (int pe = 0; pe < ctx->size; pe++) {
            if (pe != ctx->rank && ctx->peers[pe].connected_to &&
                !strcmp(ctx->peers[pe].endpoint, where)) {
                suspect(ctx, pe, now);
                named = 1;
            }
        }
        if (!named && !stranger)
            for (int pe = 0; pe < ctx->size; pe++)
                if (pe != ctx->rank && !ctx->peers[pe].connected_to)
                    suspect(ctx, pe, now);
    }
}

void am__read_monitor(am_ctx_t *ctx)
{
    if (ctx->mon)
        read_monitor(ctx, am__now());
}

/* 1 if ROUTER_MANDATORY refuses a PING to pe (its connection is gone). */
static int unreachable(am_ctx_t *ctx, int pe)
{
    /* ZMQ_EVENTS processes pending commands without the throttling that
     * send applies, so a pipe that was closed is gone before we probe. */
    am__socket_readable(ctx);
    pr_buf b = PR_BUF_INIT;
    am__ctl_begin(&b);
    uint8_t id[5];
    am__routing_id(pe, id);
    int gone = 0;
    int ring = am__shm_out_on(ctx, pe);
    ctx->events_stale = 1;
    if (ctx->peers[pe].sendq.n && !ring) {
        /* Frames wait for it: handing them over is the probe. */
        gone = flush_peer(ctx, pe) == 3;
    } else {
        if (zmq_send(ctx->sock, id, sizeof id, ZMQ_SNDMORE | ZMQ_DONTWAIT) < 0) {
            gone = errno == EHOSTUNREACH;
        } else {
            /* Routable: send a real PING so sequence numbers stay right.
             * To a ring peer it carries none: its frames' sequence is the
             * ring's, and the receiver takes a PING beside it as a probe. */
            size_t len;
            uint8_t *data = pr_buf_take(&b, &len);
            pr_header h = {PR_FLAG_CONTROL, AM__CTL_PING, (uint32_t)ctx->rank, 0,
                           ring ? ctx->peers[pe].send_seq
                                : ctx->peers[pe].send_seq++};
            pr_header_encode(&h, data);
            zmq_send(ctx->sock, data, len, ZMQ_DONTWAIT);
            pr_free(data);
            count_send(ctx, PR_FLAG_CONTROL, AM__CTL_PING, 0, USER_NONE, 0);
        }
    }
    pr_buf_free(&b);
    return gone;
}

void am__check_peers(am_ctx_t *ctx)
{
    if (!ctx->mon || ctx->state != AM__RUNNING)
        return;
    double now = am__now();
    read_monitor(ctx, now);
    if (!ctx->suspects)
        return;
    /* A peer that finalized sent BYE before it closed: take everything
     * that is waiting, so its BYE is seen before its disconnect is judged. */
    am__recv_some(ctx, 1u << 16);
    /* Judged in the order they became suspects: when PE 6 leaves because
     * PE 5 died and both disconnects are pending, PE 5's came first. */
    while (ctx->suspects && !ctx->failed) {
        int first = -1;
        for (int pe = 0; pe < ctx->size; pe++) {
            am__peer *p = &ctx->peers[pe];
            if (!p->suspect)
                continue;
            if (p->said_bye || now - p->suspect_since > SUSPECT_WINDOW) {
                p->suspect = 0;
                ctx->suspects--;
                continue;
            }
            if (now - p->suspect_since >= SUSPECT_GRACE && !p->judged &&
                (first < 0 ||
                 p->suspect_since < ctx->peers[first].suspect_since))
                first = pe;
        }
        if (first < 0)
            break;
        am__peer *p = &ctx->peers[first];
        p->judged = 1;
        if (p->connected_to || unreachable(ctx, first))
            peer_gone(ctx, first);
    }
    for (int pe = 0; pe < ctx->size; pe++)
        ctx->peers[pe].judged = 0;
}

/* A PING only tests whether its connection is still there (unreachable()
 * above): its receiver has nothing to do, and does not look at the body. */
static void on_ping(am_ctx_t *ctx, int src, pr_reader *body)
{
    (void)ctx;
    (void)src;
    (void)body;
}

static void on_abort(am_ctx_t *ctx, int src, pr_reader *body)
{
    am__abort_msg m;
    if (am__abort_get(body, &m)) {
        am__reject(ctx, AM__REJ_BODY, src, "abort");
        return;
    }
    /* Passed on as is: the sender already named the PE concerned, and
     * this PE reports that one to the launcher too. */
    if (!ctx->failed)
        ctx->culprit = m.culprit < (uint32_t)ctx->size ? (int)m.culprit : -2;
    am__fail(ctx, AM_EPEER, "%.*s (noticed by PE %d)", (int)m.reason.len,
             (const char *)m.reason.p, src);
}

const am__ctl_entry am__transport_ctls[] = {
    {AM__CTL_PING, "ping", 0, on_ping},
    {AM__CTL_ABORT, "abort", AM__CTLF_URGENT, on_abort},
    {0, NULL, 0, NULL},
};
