/*
 * zap_stranger.c -- a socket outside a libam job trying to get in, for
 * tests/am-zap.sh. Runs without libam.
 *
 *   zap_stranger ENDPOINT curve SERVERKEY frame|TEXT
 *   zap_stranger ENDPOINT null frame|TEXT
 *
 * Connects a DEALER to ENDPOINT, as a CURVE client with a key pair of its
 * own (not one of the job's) that knows the server's public key SERVERKEY,
 * or in clear (ZeroMQ's NULL mechanism), and sends either a well-formed
 * libam frame (a user message to handler 12, "sender" 0, from routing id
 * "stranger"; see below) or the text TEXT (a rendezvous request such as "GET JOB").
 * It watches its own socket's handshake and waits up to 2 s for a reply.
 * Prints one line: "stranger: handshake succeeded|refused (...)|unknown,
 * reply: none|TEXT".
 *
 * With STRANGER_PUBLIC and STRANGER_SECRET set, it uses that key pair
 * instead of a fresh one (a key of the job: an impostor), and with
 * STRANGER_RANK=R it sends as PE R (routing id 'P' R, header sender R).
 *
 * Exit status: 0 if the stranger was kept out (no handshake succeeded, no
 * reply), 1 if it got in, 99 if it could not run (automake's hard error).
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <zmq.h>

static void put32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

int main(int argc, char **argv)
{
    int curve = argc == 5 && !strcmp(argv[2], "curve");
    if (!(curve || (argc == 4 && !strcmp(argv[2], "null")))) {
        fprintf(stderr, "usage: zap_stranger ENDPOINT curve SERVERKEY "
                        "frame|TEXT\n       zap_stranger ENDPOINT null "
                        "frame|TEXT\n");
        return 99;
    }
    const char *ep = argv[1], *what = argv[argc - 1];
    void *zctx = zmq_ctx_new();
    void *s = zctx ? zmq_socket(zctx, ZMQ_DEALER) : NULL;
    if (!s)
        return 99;
    /* Long enough for a frame to leave if the stranger got in. */
    int linger = 500;
    zmq_setsockopt(s, ZMQ_LINGER, &linger, sizeof linger);
    const char *as = getenv("STRANGER_RANK");
    uint32_t sender = as ? (uint32_t)strtoul(as, NULL, 10) : 0;
    if (as) {
        uint8_t id[5] = {'P'};
        put32(id + 1, sender);
        zmq_setsockopt(s, ZMQ_ROUTING_ID, id, sizeof id);
    } else {
        zmq_setsockopt(s, ZMQ_ROUTING_ID, "stranger", 8);
    }
    /* One attempt per run: the test counts the refusals. */
    int never = -1;
    zmq_setsockopt(s, ZMQ_RECONNECT_IVL, &never, sizeof never);
    if (curve) {
        char pub[41], sec[41];
        const char *gp = getenv("STRANGER_PUBLIC"), *gs = getenv("STRANGER_SECRET");
        if (gp && gs && strlen(gp) == 40 && strlen(gs) == 40) {
            memcpy(pub, gp, 41);
            memcpy(sec, gs, 41);
        } else if (zmq_curve_keypair(pub, sec) != 0) {
            return 99;
        }
        if (zmq_setsockopt(s, ZMQ_CURVE_SERVERKEY, argv[3], 40) ||
            zmq_setsockopt(s, ZMQ_CURVE_PUBLICKEY, pub, 40) ||
            zmq_setsockopt(s, ZMQ_CURVE_SECRETKEY, sec, 40)) {
            fprintf(stderr, "zap_stranger: CURVE: %s\n", zmq_strerror(zmq_errno()));
            return 99;
        }
    }
    if (zmq_socket_monitor(s, "inproc://stranger-mon", ZMQ_EVENT_ALL) != 0)
        return 99;
    void *mon = zmq_socket(zctx, ZMQ_PAIR);
    if (!mon || zmq_connect(mon, "inproc://stranger-mon") != 0 ||
        zmq_connect(s, ep) != 0) {
        fprintf(stderr, "zap_stranger: %s: %s\n", ep, zmq_strerror(zmq_errno()));
        return 99;
    }
    if (!strcmp(what, "frame")) {
        /* The header of proto/PROTOCOL.md: magic, version 1, no flags,
         * handler 12, sender 0, payload 4 bytes, sequence 0. */
        uint8_t f[28] = {'P', 'D', 'R', 0xA7, 1, 0, 12, 0};
        put32(f + 8, sender);
        put32(f + 12, 4);
        memcpy(f + 24, "evil", 4);
        zmq_send(s, f, sizeof f, ZMQ_DONTWAIT);
    } else {
        zmq_send(s, what, strlen(what), ZMQ_DONTWAIT);
    }
    const char *hs = "unknown";
    char hsbuf[64], reply[256] = "none";
    int got_reply = 0, done_hs = 0;
    for (int ms = 0; ms < 2000 && !(done_hs && got_reply); ms += 20) {
        zmq_pollitem_t it[2] = {{s, 0, ZMQ_POLLIN, 0}, {mon, 0, ZMQ_POLLIN, 0}};
        zmq_poll(it, 2, 20);
        if (it[0].revents & ZMQ_POLLIN) {
            int n = zmq_recv(s, reply, sizeof reply - 1, ZMQ_DONTWAIT);
            if (n >= 0) {
                reply[n < (int)sizeof reply - 1 ? n : (int)sizeof reply - 1] = '\0';
                got_reply = 1;
            }
        }
        while (it[1].revents & ZMQ_POLLIN) {
            zmq_msg_t ev;
            zmq_msg_init(&ev);
            if (zmq_msg_recv(&ev, mon, ZMQ_DONTWAIT) < 0) {
                zmq_msg_close(&ev);
                break;
            }
            uint16_t e = 0;
            uint32_t v = 0;
            if (zmq_msg_size(&ev) >= 6) {
                memcpy(&e, zmq_msg_data(&ev), 2);
                memcpy(&v, (uint8_t *)zmq_msg_data(&ev) + 2, 4);
            }
            int more = zmq_msg_more(&ev);
            zmq_msg_close(&ev);
            if (more) { /* the endpoint part */
                zmq_msg_init(&ev);
                zmq_msg_recv(&ev, mon, 0);
                zmq_msg_close(&ev);
            }
            if (e == ZMQ_EVENT_HANDSHAKE_SUCCEEDED) {
                hs = "succeeded";
                done_hs = 1;
            } else if (e == ZMQ_EVENT_HANDSHAKE_FAILED_AUTH) {
                snprintf(hsbuf, sizeof hsbuf, "refused (ZAP status %u)", v);
                hs = hsbuf;
                done_hs = 1;
            } else if (e == ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL) {
                snprintf(hsbuf, sizeof hsbuf, "refused (protocol error 0x%x)", v);
                hs = hsbuf;
                done_hs = 1;
            } else if (e == ZMQ_EVENT_HANDSHAKE_FAILED_NO_DETAIL) {
                snprintf(hsbuf, sizeof hsbuf, "refused (%s)", zmq_strerror((int)v));
                hs = hsbuf;
                done_hs = 1;
            }
        }
        /* Refused: nothing can come back. A frame has no reply to wait
         * for once the handshake is known. */
        if (done_hs && (strcmp(hs, "succeeded") || !strcmp(what, "frame")))
            break;
    }
    /* A refused stranger goes at once: while the frame lingers, ZeroMQ
     * would keep reconnecting, and each attempt is one more refusal. */
    if (strcmp(hs, "succeeded")) {
        linger = 0;
        zmq_setsockopt(s, ZMQ_LINGER, &linger, sizeof linger);
    }
    printf("stranger: handshake %s, reply: %s\n", hs, reply);
    zmq_socket_monitor(s, NULL, 0);
    zmq_close(mon);
    zmq_close(s);
    zmq_ctx_term(zctx);
    return !strcmp(hs, "succeeded") || got_reply;
}
