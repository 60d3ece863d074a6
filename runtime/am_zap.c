/* am_zap.c -- the ZAP handler (ZeroMQ RFC 27) of a tcp job with CURVE: it
 * admits a CURVE client only if its long-term public key is one of the
 * job's, counts the clients it refuses and logs each peer address once.
 *
 * libzmq asks the handler bound at inproc://zeromq.zap.01 in the socket's
 * context about every CURVE handshake on a socket that is the CURVE
 * server, and holds the handshake until the answer comes. With no handler
 * bound it admits every client that knows the server's public key, so the
 * handler is bound before any server socket binds and stays bound until
 * those sockets are closed (am__zap_start / am__zap_stop).
 *
 * Where it runs: in a thread of its own, not in the PE's loop. A PE asks
 * for handshakes at times when its loop does not run: the boot's waits
 * (the rendezvous, the hellos, the table), a handler or the main context
 * busy for seconds (a refinement step), am_finalize's waits, the
 * launcher's rendezvous loop. Answering from each of those places would
 * spread ZAP over every wait of the runtime, and a peer reconnecting after
 * a network hiccup would stall until the PE next polled. The thread owns
 * its two sockets (the REP and the end of a stop pipe) and a table of
 * addresses already logged; it shares with the PE only two counters,
 * which it writes with atomic adds and others read with atomic loads, and
 * the immutable list of keys. Lines are written with one write() each
 * (am__vline), so they do not mix with the PE's own.
 *
 * The keys are kept sorted in their 32-byte binary form and looked up by
 * binary search: one lookup per connection, about log2(P) compares.
 */
#include "config.h"

#include <errno.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "am_int.h"

/* Addresses remembered for the once-per-address log; beyond that many
 * distinct strangers, one last line says that further ones are only
 * counted (bounded memory against a scan from many addresses). */
#define ZAP_ADDR_MAX 256

typedef struct zap_key {
    uint8_t key[32];
    int rank;
} zap_key;

struct am__zap {
    void *rep;                  /* bound to inproc://zeromq.zap.01 */
    void *stop_tx, *stop_rx;    /* stop pipe: main thread -> handler */
    pthread_t thread;
    int running;
    zap_key *keys;              /* sorted by key; read-only once started */
    int nkeys;
    char prefix[64];            /* "am: PE 3: " or "am-run: " */
    char what[32];              /* "this PE" or "the rendezvous" */
    _Atomic uint64_t refused;   /* CURVE clients refused */
    _Atomic uint64_t strangers; /* distinct addresses refused */
    char **logged;              /* addresses logged (handler thread only) */
    int nlogged;
    int logged_full;
};

static int key_cmp(const void *a, const void *b)
{
    return memcmp(((const zap_key *)a)->key, ((const zap_key *)b)->key, 32);
}

static void zlog(const am__zap *z, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));

static void zlog(const am__zap *z, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    am__vline(2, z->prefix, fmt, ap);
    va_end(ap);
}

/* Notes a refused client at addr; logs it if the address is new. */
static void refused(am__zap *z, const char *addr, const char *why)
{
    atomic_fetch_add(&z->refused, 1);
    for (int i = 0; i < z->nlogged; i++)
        if (!strcmp(z->logged[i], addr))
            return;
    if (z->nlogged == ZAP_ADDR_MAX) {
        if (!z->logged_full)
            zlog(z, "refused clients from more than %d addresses; further "
                    "ones are only counted", ZAP_ADDR_MAX);
        z->logged_full = 1;
        atomic_fetch_add(&z->strangers, 1);
        return;
    }
    char *copy = pr_strdup(addr);
    if (copy)
        z->logged[z->nlogged++] = copy;
    atomic_fetch_add(&z->strangers, 1);
    zlog(z, "refused a connection to %s from %s: %s (further refusals of "
            "that address are only counted)",
         z->what, addr[0] ? addr : "an unknown address", why);
}

/* Receives one frame of a request into buf (cut, NUL-terminated); returns
 * its full size, or -1. *more tells whether frames follow. */
static int recv_part(void *s, char *buf, size_t cap, int *more)
{
    zmq_msg_t m;
    zmq_msg_init(&m);
    int n = zmq_msg_recv(&m, s, 0);
    if (n >= 0) {
        size_t k = (size_t)n < cap - 1 ? (size_t)n : cap - 1;
        memcpy(buf, zmq_msg_data(&m), k);
        buf[k] = '\0';
        *more = zmq_msg_more(&m);
    }
    zmq_msg_close(&m);
    return n;
}

/* Answers one ZAP request (RFC 27: version, request id, domain, address,
 * routing id, mechanism, credentials...; the reply: version, request id,
 * status code, status text, user id, metadata). The user id given to an
 * admitted client is its rank, readable as the "User-Id" property of its
 * frames. */
static void serve_one(am__zap *z)
{
    char part[7][256];
    int sizes[7] = {0}, more = 1, n = 0;
    uint8_t cred[32];
    int cred_len = -1;
    while (more) {
        char buf[256];
        int len = recv_part(z->rep, buf, sizeof buf, &more);
        if (len < 0)
            return;
        if (n < 6) {
            memcpy(part[n], buf, sizeof buf);
            sizes[n] = len;
        } else if (n == 6) {
            cred_len = len;
            if (len == 32)
                memcpy(cred, buf, 32);
        }
        n++;
    }
    /* A request too short to carry an id cannot be answered at all; REP
     * still needs a reply to read the next request. */
    const char *id = n >= 2 ? part[1] : "";
    size_t id_len = n >= 2 ? (size_t)sizes[1] : 0;
    if (id_len >= sizeof part[1])
        id_len = sizeof part[1] - 1;
    const char *addr = n >= 4 ? part[3] : "";
    char user[16] = "";
    const char *code = "400", *text = "not a key of this job";
    if (n < 6 || strcmp(part[0], "1.0")) {
        text = "malformed ZAP request";
    } else if (strcmp(part[5], "CURVE")) {
        text = "only CURVE is accepted";
        refused(z, addr, "not CURVE");
    } else {
        zap_key k;
        const zap_key *hit = NULL;
        if (cred_len == 32) {
            memcpy(k.key, cred, 32);
            hit = bsearch(&k, z->keys, (size_t)z->nkeys, sizeof *z->keys,
                          key_cmp);
        }
        if (hit) {
            code = "200";
            text = "OK";
            if (hit->rank >= 0)
                snprintf(user, sizeof user, "%d", hit->rank);
        } else {
            refused(z, addr, "its CURVE key is not one of the job's");
        }
    }
    zmq_send(z->rep, "1.0", 3, ZMQ_SNDMORE);
    zmq_send(z->rep, id, id_len, ZMQ_SNDMORE);
    zmq_send(z->rep, code, 3, ZMQ_SNDMORE);
    zmq_send(z->rep, text, strlen(text), ZMQ_SNDMORE);
    zmq_send(z->rep, user, strlen(user), ZMQ_SNDMORE);
    zmq_send(z->rep, "", 0, 0);
}

static void *zap_main(void *arg)
{
    am__zap *z = arg;
    for (;;) {
        zmq_pollitem_t it[2] = {{z->rep, 0, ZMQ_POLLIN, 0},
                                {z->stop_rx, 0, ZMQ_POLLIN, 0}};
        if (zmq_poll(it, 2, -1) < 0) {
            if (zmq_errno() == EINTR)
                continue;
            break; /* the context is going away */
        }
        if (it[1].revents & ZMQ_POLLIN)
            break;
        if (it[0].revents & ZMQ_POLLIN)
            serve_one(z);
    }
    zmq_close(z->rep);
    zmq_close(z->stop_rx);
    z->rep = z->stop_rx = NULL;
    return NULL;
}

int am__zap_start(void *zctx, const char (*keys)[41], int nkeys,
                  const char *prefix, const char *what, am__zap **out)
{
    *out = NULL;
    am__zap *z = pr_calloc(1, sizeof *z);
    if (!z)
        return AM_ENOMEM;
    z->keys = pr_calloc((size_t)(nkeys > 0 ? nkeys : 1), sizeof *z->keys);
    z->logged = pr_calloc(ZAP_ADDR_MAX, sizeof *z->logged);
    if (!z->keys || !z->logged) {
        am__zap_stop(&z);
        return AM_ENOMEM;
    }
    for (int i = 0; i < nkeys; i++) {
        if (!zmq_z85_decode(z->keys[i].key, keys[i])) {
            am__zap_stop(&z);
            return AM_EINVAL;
        }
        z->keys[i].rank = i;
    }
    z->nkeys = nkeys;
    qsort(z->keys, (size_t)nkeys, sizeof *z->keys, key_cmp);
    /* One key pair shared by every PE (AM_CURVE_SERVER_PUBLIC/SECRET)
     * names no rank: such clients get an empty user id. */
    for (int i = 1; i < nkeys; i++)
        if (!key_cmp(&z->keys[i - 1], &z->keys[i]))
            z->keys[i - 1].rank = z->keys[i].rank = -1;
    snprintf(z->prefix, sizeof z->prefix, "%s", prefix);
    snprintf(z->what, sizeof z->what, "%s", what);
    char stop_ep[64];
    snprintf(stop_ep, sizeof stop_ep, "inproc://am-zap-stop-%p", (void *)z);
    int zero = 0;
    z->rep = zmq_socket(zctx, ZMQ_REP);
    z->stop_tx = zmq_socket(zctx, ZMQ_PAIR);
    z->stop_rx = zmq_socket(zctx, ZMQ_PAIR);
    if (!z->rep || !z->stop_tx || !z->stop_rx ||
        zmq_setsockopt(z->rep, ZMQ_LINGER, &zero, sizeof zero) ||
        zmq_setsockopt(z->stop_tx, ZMQ_LINGER, &zero, sizeof zero) ||
        zmq_bind(z->stop_rx, stop_ep) || zmq_connect(z->stop_tx, stop_ep) ||
        zmq_bind(z->rep, "inproc://zeromq.zap.01")) {
        am__zap_stop(&z);
        return AM_ETRANSPORT;
    }
    /* The sockets move to the thread: pthread_create is the full memory
     * barrier libzmq asks for when a socket changes threads. */
    if (pthread_create(&z->thread, NULL, zap_main, z) != 0) {
        am__zap_stop(&z);
        return AM_ESYS;
    }
    z->running = 1;
    *out = z;
    return 0;
}

void am__zap_stop(am__zap **pz)
{
    am__zap *z = *pz;
    if (!z)
        return;
    if (z->running) {
        zmq_send(z->stop_tx, "", 0, 0);
        pthread_join(z->thread, NULL);
    } else {
        if (z->rep)
            zmq_close(z->rep);
        if (z->stop_rx)
            zmq_close(z->stop_rx);
    }
    if (z->stop_tx)
        zmq_close(z->stop_tx);
    if (z->logged)
        for (int i = 0; i < z->nlogged; i++)
            pr_free(z->logged[i]);
    pr_free(z->logged);
    pr_free(z->keys);
    pr_free(z);
    *pz = NULL;
}

uint64_t am__zap_refused(am__zap *z)
{
    return z ? atomic_load(&z->refused) : 0;
}

uint64_t am__zap_strangers(am__zap *z)
{
    return z ? atomic_load(&z->strangers) : 0;
}
