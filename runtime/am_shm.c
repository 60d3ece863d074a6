/* am_shm.c -- the same-host data path: one shared-memory byte ring per
 * ordered pair of PEs, written and read by the PEs themselves, with no
 * thread in between.
 *
 * Why: over ZeroMQ every frame passes through the I/O thread of the
 * sender and of the receiver, and under SCHED_FIFO those threads get a
 * core only when a PE blocks (bench/parallel.md, runs 16 and 19). A ring
 * is written by the sender's own flush and read by the receiver's own
 * poll, and polling it is a memory read, not a system call.
 *
 * What it guarantees:
 * - Only for the ipc transport (every PE on this host): a PE whose peer's
 *   endpoint is not ipc://, or with AM_SHM=0, keeps ZeroMQ for it. Boot
 *   (HELLO, TABLE, PEER_HELLO) always goes over ZeroMQ.
 * - One channel per ordered pair. The receiver creates the ring file
 *   "rR.fromS" (and its wake socket "R.wake") in the job's private ipc
 *   directory before it binds, so once a sender has the endpoint table
 *   the file exists. After boot the sender maps it, sends SHM_ON over
 *   ZeroMQ as its last frame there, and from then on sends every frame to
 *   that peer (basic and control) through the ring. The receiver reads
 *   the ring only once SHM_ON was taken (it is urgent: handled as soon as
 *   read), so the frames sent over ZeroMQ before it are all taken first
 *   and the sequence numbers stay consecutive on one channel. The one
 *   exception is the liveness probe of failure detection, a PING sent
 *   over ZeroMQ, which carries no sequence number and is taken as such.
 * - Frames go into the ring as a byte stream, each frame (header and
 *   payload) as it would be on the wire; the header's payload length
 *   delimits it. A frame that does not fit in the free space waits in the
 *   peer's send queue (as when ZeroMQ says EAGAIN), and a frame larger
 *   than the ring is written in pieces as room frees up, at later flush
 *   points; the receiver reassembles it. So there is no size limit beyond
 *   the protocol's, and flow control (am_flow.c) still bounds what is in
 *   flight. Received frames are taken by the transport exactly as frames
 *   from ZeroMQ are (validation, sequence numbers, statistics, credits,
 *   injected latency).
 * - Single producer, single consumer: the writer alone stores head (bytes
 *   written, release), the reader alone stores tail (bytes consumed,
 *   release); each is on its own cache line, and the data starts a page
 *   after them.
 * - No lost wake-up: a reader about to block sets rd_sleep in each of its
 *   rings, issues a sequentially consistent fence and looks at every ring
 *   again; a writer publishes head, issues the same fence and, if it
 *   finds rd_sleep set, clears it and sends one byte to the reader's wake
 *   socket, which the reader's event loop watches. A writer waiting for
 *   room does the same with wr_sleep, and the reader wakes it after it
 *   freed room. Of the two stores at least one is seen by the other side.
 *   A byte sent to a reader that woke for another reason only causes one
 *   spurious wake-up.
 * - Failure detection stays ZeroMQ's (heartbeats, the socket monitor, the
 *   probe): the ZeroMQ connection between the two PEs stays up. A writer
 *   facing the full ring of a dead peer keeps its frames in the send
 *   queue and learns of the death like any other PE.
 * - Files: the receiver unlinks a ring file as soon as its sender said
 *   SHM_ON (both have it mapped), and at close every file of its own; the
 *   launcher removes whatever a killed PE left in the directory.
 * - Every wait ends in a block: a PE that has nothing it can take from a
 *   ring nor write into one blocks (am_idle, the blocking calls), and
 *   "something to take" is what am__shm_take can get on with (in_ready):
 *   a whole frame header, or a byte of a frame being reassembled. That
 *   matters under a real-time policy (SCHED_FIFO, SCHED_RR), where a PE
 *   keeps its processor until it blocks: a writer that meets a full ring
 *   writes what fits, which may end inside a frame's header, and waits
 *   for room; the reader takes every whole frame, frees the room (which
 *   makes the writer runnable) and then saw head != tail and went round
 *   its loop again instead of blocking, for good, since only the writer,
 *   queued behind it, could finish that header. With more PEs than
 *   processors (4 PEs on 2, 4 KiB rings: 7 runs of 9 hung) two such
 *   readers held both processors and the other PEs never ran again
 *   (bench/parallel.md, runs 21 and 24). So the rings are on there too,
 *   and with PEs bound to a processor each (AM_CPU_BIND=core), where a
 *   PE's ZeroMQ I/O thread shares its processor under the same policy and
 *   rings halve the 2-PE refinement (run 24). Under SCHED_OTHER the kernel
 *   shares the processors anyway, so the spin there only cost time.
 * - Memory: the rings of one PE's incoming traffic share a budget
 *   (SHM_BUDGET, divided over its peers, a power of two between
 *   SHM_RING_MIN and SHM_RING_MAX; SHM_RING_OVERSUB where the host has
 *   more PEs than processors; AM_SHM_RING sets it), and only the pages
 *   that traffic touched count in a PE's resident set.
 *
 * Ownership: the context owns its am__shm (am__shm_open/am__shm_close):
 * the mappings, the two sockets and the libevent event. A partly
 * reassembled frame is owned by its link.
 */
#include "config.h"

#include <errno.h>
#include <fcntl.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include "pr_alloc.h"
#include "am_int.h"

/* The incoming rings of one PE share this many bytes ... (a PE also
 * writes into its peers' rings, whose pages count in its resident set
 * too: up to twice this. 2 MiB: 1 MiB rings up to 3 PEs, 128 KiB at 16,
 * 1.1 MB less per PE there than with 4 MiB; bench/parallel.md, run 23) */
#define SHM_BUDGET ((size_t)2 << 20)
/* ... each ring getting a power of two in these bounds. */
#define SHM_RING_MIN ((size_t)64 << 10)
#define SHM_RING_MAX ((size_t)1 << 20)
/* With more PEs than processors on the host a PE's peers mostly wait for
 * a processor, and a ring holds more than they take in a time slice at
 * any size: 16 KiB rings, as fast as the budget's and 35-45 bytes less
 * per tetrahedron on 16 PEs at 10^6 (bench/parallel.md, run 25). */
#define SHM_RING_OVERSUB ((size_t)16 << 10)
/* The counters' page: the data begins after it. */
#define SHM_HDR 4096
#define SHM_MAGIC UINT64_C(0x31474e49524d4d41) /* "AMMRING1" */
/* Room for a path in the ipc directory (ZeroMQ's ipc paths are shorter). */
#define PATH_MAX_AM 1200

/* The shared part of a ring (the first page of its file). */
typedef struct ring_hdr {
    _Alignas(64) _Atomic uint64_t head;     /* bytes written: writer only */
    _Alignas(64) _Atomic uint64_t tail;     /* bytes consumed: reader only */
    _Alignas(64) _Atomic uint32_t rd_sleep; /* reader may block: wake it */
    _Alignas(64) _Atomic uint32_t wr_sleep; /* writer waits for room */
    _Alignas(64) uint64_t magic;            /* constant once created */
    uint64_t job;
    uint64_t cap;                           /* data bytes, a power of two */
    uint32_t from, to;                      /* writer and reader ranks */
} ring_hdr;

_Static_assert(sizeof(ring_hdr) <= SHM_HDR, "ring header exceeds its page");

/* One ring's end as this PE sees it. */
typedef struct ring_end {
    ring_hdr *h;      /* NULL: not mapped */
    uint8_t *data;
    size_t cap, map;
    uint64_t pos;     /* writer: head written (published or not);
                         reader: tail consumed (published or not) */
    uint64_t seen;    /* writer: last tail read; reader: last head read */
} ring_end;

typedef struct shm_link {
    ring_end out;     /* this PE -> peer (mapped after boot) */
    ring_end in;      /* peer -> this PE (created before boot) */
    int out_on;       /* SHM_ON sent: frames go through out */
    int in_on;        /* SHM_ON taken: frames come through in */
    int paused;       /* SHM_VIA taken: the next frame comes by ZeroMQ */
    am__fifo zq;      /* large frames that came by ZeroMQ before their
                         SHM_VIA was read from the ring */
    int in_linked;    /* in's file still exists */
    int out_dirty;    /* out.pos not yet published */
    int in_dirty;     /* in.pos not yet published */
    zmq_msg_t part;   /* a frame being reassembled */
    size_t part_len, part_got;
    int part_on;
    struct sockaddr_un wake; /* the peer's wake socket */
    socklen_t wake_len;
} shm_link;

struct am__shm {
    shm_link *link;   /* size entries */
    int wake_fd;      /* this PE's wake socket (bound datagram socket) */
    int send_fd;      /* unbound datagram socket to wake peers */
    struct event *wake_ev;
    size_t cap;       /* bytes of data per incoming ring */
    int nin_on;       /* peers whose frames come through a ring */
    int nout_on;
    int npaused;      /* links paused */
    int sleeping;     /* sleep flags are set (am__shm_sleep_begin) */
    int next;         /* peer to read first at the next receive */
};

static void ring_path(const am_ctx_t *ctx, int to, int from, char *buf,
                      size_t n)
{
    snprintf(buf, n, "%s/r%d.from%d", ctx->ipc_dir, to, from);
}

static int wake_addr(const am_ctx_t *ctx, int pe, struct sockaddr_un *a,
                     socklen_t *len)
{
    memset(a, 0, sizeof *a);
    a->sun_family = AF_UNIX;
    int n = snprintf(a->sun_path, sizeof a->sun_path, "%s/%d.wake",
                     ctx->ipc_dir, pe);
    if (n < 0 || (size_t)n >= sizeof a->sun_path)
        return -1;
    *len = (socklen_t)(offsetof(struct sockaddr_un, sun_path) + (size_t)n + 1);
    return 0;
}

static size_t ring_cap(const am_ctx_t *ctx)
{
    if (ctx->shm_ring)
        return ctx->shm_ring;
    if (ctx->oversubscribed)
        return SHM_RING_OVERSUB;
    size_t share = SHM_BUDGET / (size_t)(ctx->size > 1 ? ctx->size - 1 : 1);
    size_t cap = SHM_RING_MIN;
    while (cap * 2 <= share && cap * 2 <= SHM_RING_MAX)
        cap *= 2;
    return cap;
}

static void unmap_end(ring_end *e)
{
    if (e->h)
        munmap(e->h, e->map);
    memset(e, 0, sizeof *e);
}

static int map_end(ring_end *e, int fd, size_t map)
{
    void *p = mmap(NULL, map, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
    if (p == MAP_FAILED)
        return -1;
    e->h = p;
    e->data = (uint8_t *)p + SHM_HDR;
    e->map = map;
    e->cap = map - SHM_HDR;
    e->pos = e->seen = 0;
    return 0;
}

/* Creates and maps the ring from `from` to this PE. */
static int create_in(am_ctx_t *ctx, int from, size_t cap)
{
    char path[PATH_MAX_AM];
    ring_path(ctx, ctx->rank, from, path, sizeof path);
    int fd = open(path, O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
    if (fd < 0)
        return -1;
    shm_link *l = &ctx->shm->link[from];
    l->in_linked = 1;
    int rc = ftruncate(fd, (off_t)(SHM_HDR + cap)) == 0 &&
                     map_end(&l->in, fd, SHM_HDR + cap) == 0
                 ? 0
                 : -1;
    close(fd);
    if (rc)
        return -1;
    ring_hdr *h = l->in.h;
    h->job = ctx->job;
    h->cap = cap;
    h->from = (uint32_t)from;
    h->to = (uint32_t)ctx->rank;
    atomic_store_explicit(&h->head, 0, memory_order_relaxed);
    atomic_store_explicit(&h->tail, 0, memory_order_relaxed);
    atomic_store_explicit(&h->rd_sleep, 0, memory_order_relaxed);
    atomic_store_explicit(&h->wr_sleep, 0, memory_order_relaxed);
    /* The magic last: a writer that sees it sees the rest (the file is
     * complete long before any writer looks, after the boot). */
    atomic_thread_fence(memory_order_release);
    h->magic = SHM_MAGIC;
    return 0;
}

/* Maps the ring from this PE to pe, made by pe. */
static int open_out(am_ctx_t *ctx, int pe)
{
    char path[PATH_MAX_AM];
    ring_path(ctx, pe, ctx->rank, path, sizeof path);
    int fd = open(path, O_RDWR | O_CLOEXEC);
    if (fd < 0)
        return -1;
    struct stat st;
    shm_link *l = &ctx->shm->link[pe];
    int rc = -1;
    if (fstat(fd, &st) == 0 && st.st_size > SHM_HDR &&
        map_end(&l->out, fd, (size_t)st.st_size) == 0)
        rc = 0;
    close(fd);
    if (rc)
        return -1;
    const ring_hdr *h = l->out.h;
    atomic_thread_fence(memory_order_acquire);
    size_t cap = l->out.cap;
    if (h->magic != SHM_MAGIC || h->job != ctx->job || h->cap != cap ||
        (cap & (cap - 1)) || h->from != (uint32_t)ctx->rank ||
        h->to != (uint32_t)pe ||
        wake_addr(ctx, pe, &l->wake, &l->wake_len)) {
        unmap_end(&l->out);
        return -1;
    }
    return 0;
}

void am__shm_close(am_ctx_t *ctx)
{
    struct am__shm *s = ctx->shm;
    if (!s)
        return;
    if (s->wake_ev)
        event_free(s->wake_ev);
    for (int pe = 0; pe < ctx->size; pe++) {
        shm_link *l = &s->link[pe];
        if (l->in_linked) {
            char path[PATH_MAX_AM];
            ring_path(ctx, ctx->rank, pe, path, sizeof path);
            unlink(path);
        }
        if (l->part_on)
            zmq_msg_close(&l->part);
        am__fifo_clear(&l->zq);
        unmap_end(&l->in);
        unmap_end(&l->out);
    }
    if (s->wake_fd >= 0) {
        struct sockaddr_un a;
        socklen_t len;
        close(s->wake_fd);
        if (!wake_addr(ctx, ctx->rank, &a, &len))
            unlink(a.sun_path);
    }
    if (s->send_fd >= 0)
        close(s->send_fd);
    pr_free(s->link);
    pr_free(s);
    ctx->shm = NULL;
}

int am__shm_open(am_ctx_t *ctx)
{
    if (!ctx->shm_enabled || strcmp(ctx->transport, "ipc") || !ctx->ipc_dir ||
        ctx->size < 2)
        return 0;
    struct am__shm *s = pr_calloc(1, sizeof *s);
    if (!s)
        return AM_ENOMEM;
    s->wake_fd = s->send_fd = -1;
    ctx->shm = s;
    if (!(s->link = pr_calloc((size_t)ctx->size, sizeof *s->link)))
        return AM_ENOMEM;
    s->cap = ring_cap(ctx);
    struct sockaddr_un a;
    socklen_t len;
    const char *what = "the wake socket";
    if (wake_addr(ctx, ctx->rank, &a, &len))
        goto off;
    s->wake_fd = socket(AF_UNIX, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (s->wake_fd < 0 || bind(s->wake_fd, (struct sockaddr *)&a, len) != 0) {
        if (s->wake_fd >= 0)
            close(s->wake_fd);
        s->wake_fd = -1;
        goto off;
    }
    s->send_fd = socket(AF_UNIX, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (s->send_fd < 0)
        goto off;
    what = "a ring file";
    for (int pe = 0; pe < ctx->size; pe++)
        if (pe != ctx->rank && create_in(ctx, pe, s->cap))
            goto off;
    return 0;
off:
    /* Not fatal: this PE's peers then use ZeroMQ to reach it. */
    am__warn(ctx, "cannot create %s in %s (%s); this PE's peers reach it "
                  "through ZeroMQ",
             what, ctx->ipc_dir, strerror(errno));
    am__shm_close(ctx);
    return 0;
}

static void wake_cb(evutil_socket_t fd, short what, void *arg)
{
    (void)what;
    (void)arg;
    char buf[256];
    while (recv((int)fd, buf, sizeof buf, MSG_DONTWAIT) > 0)
        ;
}

int am__shm_watch(am_ctx_t *ctx)
{
    struct am__shm *s = ctx->shm;
    if (!s)
        return 0;
    s->wake_ev = event_new(ctx->base, s->wake_fd, EV_READ | EV_PERSIST,
                           wake_cb, ctx);
    if (!s->wake_ev || event_add(s->wake_ev, NULL) != 0)
        return AM_ENOMEM;
    return 0;
}

int am__shm_fd(const am_ctx_t *ctx)
{
    return ctx->shm ? ctx->shm->wake_fd : -1;
}

void am__shm_drain(am_ctx_t *ctx)
{
    if (ctx->shm)
        wake_cb(ctx->shm->wake_fd, 0, NULL);
}

int am__shm_start(am_ctx_t *ctx)
{
    struct am__shm *s = ctx->shm;
    if (!s)
        return 0;
    for (int pe = 0; pe < ctx->size; pe++) {
        const char *ep = ctx->peers[pe].endpoint;
        if (pe == ctx->rank || !ep || strncmp(ep, "ipc://", 6) ||
            open_out(ctx, pe))
            continue;
        pr_buf b = PR_BUF_INIT;
        am__ctl_begin(&b);
        int rc = am__send_ctl(ctx, pe, AM__CTL_SHM_ON, &b);
        pr_buf_free(&b);
        if (rc)
            return rc;
        /* SHM_ON must be ZeroMQ's last frame to pe: if ZeroMQ queued it,
         * that queue goes first (bounded; unlimited high-water marks make
         * this the exception). */
        double end = am__now() + ctx->boot_timeout;
        while (ctx->peers[pe].sendq.n && !ctx->failed) {
            am__flush_sendq(ctx);
            if (am__now() > end)
                return am__fail(ctx, AM_ETIMEOUT, "could not hand SHM_ON to "
                                                  "ZeroMQ for PE %d", pe);
            if (ctx->peers[pe].sendq.n) {
                zmq_pollitem_t it = {ctx->sock, 0, ZMQ_POLLOUT, 0};
                zmq_poll(&it, 1, 10);
            }
        }
        if (ctx->failed)
            return ctx->failed;
        s->link[pe].out_on = 1;
        s->nout_on++;
    }
    return 0;
}

int am__shm_out_on(const am_ctx_t *ctx, int pe)
{
    return ctx->shm && ctx->shm->link[pe].out_on;
}

int am__shm_in_on(const am_ctx_t *ctx, int pe)
{
    return ctx->shm && ctx->shm->link[pe].in_on;
}

int am__shm_all_in(const am_ctx_t *ctx)
{
    return ctx->shm && ctx->shm->nin_on == ctx->size - 1 &&
           ctx->shm->npaused == 0;
}

size_t am__shm_ring_bytes(const am_ctx_t *ctx)
{
    return ctx->shm ? ctx->shm->cap : 0;
}

int am__shm_big(const am_ctx_t *ctx, size_t n)
{
    return ctx->shm_big && n >= ctx->shm_big;
}

int am__shm_paused(const am_ctx_t *ctx, int pe)
{
    return ctx->shm && ctx->shm->link[pe].paused;
}

int am__shm_stash(am_ctx_t *ctx, int pe, zmq_msg_t *msg)
{
    am__frame *f = am__frame_new();
    if (!f)
        return AM_ENOMEM;
    zmq_msg_move(&f->msg, msg);
    am__fifo_push(&ctx->shm->link[pe].zq, f);
    return 0;
}

int am__shm_unstash(am_ctx_t *ctx, int pe, zmq_msg_t *msg)
{
    am__frame *f = am__fifo_pop(&ctx->shm->link[pe].zq);
    if (!f)
        return 0;
    zmq_msg_init(msg);
    zmq_msg_move(msg, &f->msg);
    am__frame_free(f);
    return 1;
}

void am__shm_resume(am_ctx_t *ctx, int pe)
{
    if (ctx->shm->link[pe].paused) {
        ctx->shm->link[pe].paused = 0;
        ctx->shm->npaused--;
    }
}

/* ---------------------------------------------------------------- writing */

static void wake(struct am__shm *s, const shm_link *l)
{
    /* Errors are not ours to judge: a full socket buffer means the peer
     * has wake-ups pending; a refused one, that it went away, which
     * failure detection reports. */
    (void)sendto(s->send_fd, "w", 1, MSG_DONTWAIT | MSG_NOSIGNAL,
                 (const struct sockaddr *)&l->wake, l->wake_len);
}

size_t am__shm_room(am_ctx_t *ctx, int pe)
{
    ring_end *e = &ctx->shm->link[pe].out;
    e->seen = atomic_load_explicit(&e->h->tail, memory_order_acquire);
    return e->cap - (size_t)(e->pos - e->seen);
}

size_t am__shm_put(am_ctx_t *ctx, int pe, const void *src, size_t len)
{
    shm_link *l = &ctx->shm->link[pe];
    ring_end *e = &l->out;
    size_t room = e->cap - (size_t)(e->pos - e->seen);
    if (room < len) {
        e->seen = atomic_load_explicit(&e->h->tail, memory_order_acquire);
        room = e->cap - (size_t)(e->pos - e->seen);
    }
    if (len > room)
        len = room;
    if (len == 0)
        return 0;
    size_t at = (size_t)(e->pos & (e->cap - 1));
    size_t first = e->cap - at < len ? e->cap - at : len;
    memcpy(e->data + at, src, first);
    if (len > first)
        memcpy(e->data, (const uint8_t *)src + first, len - first);
    e->pos += len;
    l->out_dirty = 1;
    return len;
}

/* Publishes a ring counter (head by the writer, tail by the reader) and
 * claims the other side's sleep flag: 1 when it was about to block and
 * must be woken. The seq_cst fence pairs with the sleeper's (header, "No
 * lost wake-up"). */
static int publish_counter(_Atomic uint64_t *counter, uint64_t value, _Atomic uint32_t *sleep)
{
    atomic_store_explicit(counter, value, memory_order_release);
    atomic_thread_fence(memory_order_seq_cst);
    return atomic_load_explicit(sleep, memory_order_relaxed) &&
           atomic_exchange_explicit(sleep, 0, memory_order_relaxed);
}

void am__shm_publish(am_ctx_t *ctx, int pe)
{
    shm_link *l = &ctx->shm->link[pe];
    if (!l->out_dirty)
        return;
    l->out_dirty = 0;
    if (publish_counter(&l->out.h->head, l->out.pos, &l->out.h->rd_sleep))
        wake(ctx->shm, l);
}

/* ---------------------------------------------------------------- reading */

static void ring_copy_out(const ring_end *e, uint64_t pos, void *dst,
                          size_t len)
{
    size_t at = (size_t)(pos & (e->cap - 1));
    size_t first = e->cap - at < len ? e->cap - at : len;
    memcpy(dst, e->data + at, first);
    if (len > first)
        memcpy((uint8_t *)dst + first, e->data, len - first);
}

int am__shm_take(am_ctx_t *ctx, int pe, zmq_msg_t *msg)
{
    shm_link *l = &ctx->shm->link[pe];
    ring_end *e = &l->in;
    size_t avail = (size_t)(e->seen - e->pos);
    if (avail == 0) {
        e->seen = atomic_load_explicit(&e->h->head, memory_order_acquire);
        avail = (size_t)(e->seen - e->pos);
        if (avail == 0)
            return 0;
    }
    if (!l->part_on) {
        if (avail < PR_HEADER_SIZE) {
            e->seen = atomic_load_explicit(&e->h->head, memory_order_acquire);
            avail = (size_t)(e->seen - e->pos);
            if (avail < PR_HEADER_SIZE)
                return 0;
        }
        uint8_t hdr[PR_HEADER_SIZE];
        ring_copy_out(e, e->pos, hdr, sizeof hdr);
        uint32_t payload = pr_load_u32(hdr + 12);
        if (payload > PR_MAX_PAYLOAD ||
            (size_t)(e->seen - e->pos) > e->cap) {
            am__fail(ctx, AM_EPROTO, "the ring from PE %d is corrupt (a frame "
                                     "of %u bytes)",
                     pe, (unsigned)payload);
            return -1;
        }
        size_t total = PR_HEADER_SIZE + (size_t)payload;
        if (avail < total) {
            e->seen = atomic_load_explicit(&e->h->head, memory_order_acquire);
            avail = (size_t)(e->seen - e->pos);
        }
        if (zmq_msg_init_size(avail >= total ? msg : &l->part, total) != 0) {
            am__fail(ctx, AM_ENOMEM, "out of memory taking a frame of %zu "
                                     "bytes from PE %d",
                     total, pe);
            return -1;
        }
        if (avail >= total) {
            ring_copy_out(e, e->pos, zmq_msg_data(msg), total);
            e->pos += total;
            l->in_dirty = 1;
            return 1;
        }
        l->part_on = 1;
        l->part_len = total;
        l->part_got = 0;
    }
    size_t n = l->part_len - l->part_got;
    if (n > avail)
        n = avail;
    ring_copy_out(e, e->pos, (uint8_t *)zmq_msg_data(&l->part) + l->part_got,
                  n);
    e->pos += n;
    l->part_got += n;
    l->in_dirty = 1;
    if (l->part_got < l->part_len)
        return 0;
    zmq_msg_init(msg);
    zmq_msg_move(msg, &l->part);
    zmq_msg_close(&l->part);
    l->part_on = 0;
    return 1;
}

void am__shm_release(am_ctx_t *ctx, int pe)
{
    shm_link *l = &ctx->shm->link[pe];
    if (!l->in_dirty)
        return;
    l->in_dirty = 0;
    if (publish_counter(&l->in.h->tail, l->in.pos, &l->in.h->wr_sleep)) {
        /* The writer's wake socket: the same name scheme, its rank. */
        if (!l->wake_len)
            wake_addr(ctx, pe, &l->wake, &l->wake_len);
        wake(ctx->shm, l);
    }
}

int am__shm_first(const am_ctx_t *ctx)
{
    struct am__shm *s = ctx->shm;
    int pe = s->next;
    s->next = (s->next + 1) % ctx->size;
    return pe;
}

/* --------------------------------------------------------------- sleeping */

/* 1 if this PE has frames for pe's ring that wait in its send queue. */
static int out_waiting(const am_ctx_t *ctx, int pe)
{
    return ctx->shm->link[pe].out_on && ctx->peers[pe].sendq.n > 0;
}

void am__shm_sleep_end(am_ctx_t *ctx)
{
    struct am__shm *s = ctx->shm;
    if (!s || !s->sleeping)
        return;
    s->sleeping = 0;
    for (int pe = 0; pe < ctx->size; pe++) {
        shm_link *l = &s->link[pe];
        if (l->in_on)
            atomic_store_explicit(&l->in.h->rd_sleep, 0, memory_order_relaxed);
        if (l->out_on)
            atomic_store_explicit(&l->out.h->wr_sleep, 0,
                                  memory_order_relaxed);
    }
}

/* 1 if am__shm_take would get on with l's ring, head being its writer's
 * published count: a new frame needs its whole header there (take starts
 * on a frame only then), the rest of a frame being reassembled needs a
 * byte. The writer may have stopped after part of a header (a full ring),
 * and such bytes are not work: counting them kept a reader from blocking
 * while the writer, which alone can finish the header, waited for a
 * processor the spinning reader held (the oversubscribed SCHED_FIFO hang
 * of bench/parallel.md, run 21). */
static int in_ready(const shm_link *l, uint64_t head)
{
    uint64_t avail = head - l->in.pos;
    return l->part_on ? avail > 0 : avail >= PR_HEADER_SIZE;
}

int am__shm_sleep_begin(am_ctx_t *ctx)
{
    struct am__shm *s = ctx->shm;
    if (!s || (!s->nin_on && !s->nout_on))
        return 0;
    for (int pe = 0; pe < ctx->size; pe++) {
        shm_link *l = &s->link[pe];
        if (l->in_on)
            atomic_store_explicit(&l->in.h->rd_sleep, 1, memory_order_relaxed);
        if (out_waiting(ctx, pe))
            atomic_store_explicit(&l->out.h->wr_sleep, 1,
                                  memory_order_relaxed);
    }
    s->sleeping = 1;
    atomic_thread_fence(memory_order_seq_cst);
    for (int pe = 0; pe < ctx->size; pe++) {
        shm_link *l = &s->link[pe];
        int ready = 0;
        if (l->in_on && !l->paused)
            ready = in_ready(l, atomic_load_explicit(&l->in.h->head,
                                                     memory_order_relaxed));
        if (!ready && out_waiting(ctx, pe))
            ready = atomic_load_explicit(&l->out.h->tail,
                                         memory_order_relaxed) != l->out.seen;
        if (ready) {
            am__shm_sleep_end(ctx);
            return 1;
        }
    }
    return 0;
}

/* ---------------------------------------------------------------- SHM_ON */

static void on_shm_on(am_ctx_t *ctx, int src, pr_reader *body)
{
    struct am__shm *s = ctx->shm;
    if (am__empty_get(body) || !s || !s->link[src].in.h ||
        s->link[src].in_on) {
        am__reject(ctx, AM__REJ_BODY, src, "shm_on without a ring");
        return;
    }
    shm_link *l = &s->link[src];
    l->in_on = 1;
    s->nin_on++;
    /* Both ends have it mapped: the name is no longer needed. */
    if (l->in_linked) {
        char path[PATH_MAX_AM];
        ring_path(ctx, ctx->rank, src, path, sizeof path);
        unlink(path);
        l->in_linked = 0;
    }
}

/* A ring peer's large frame comes by ZeroMQ next: the ring is not read
 * until it was taken, so that the order stays the sender's. */
static void on_shm_via(am_ctx_t *ctx, int src, pr_reader *body)
{
    struct am__shm *s = ctx->shm;
    if (am__empty_get(body) || !s || !s->link[src].in_on ||
        s->link[src].paused) {
        am__reject(ctx, AM__REJ_BODY, src, "shm_via outside a ring");
        return;
    }
    s->link[src].paused = 1;
    s->npaused++;
}

const am__ctl_entry am__shm_ctls[] = {
    {AM__CTL_SHM_ON, "shm_on", AM__CTLF_URGENT, on_shm_on},
    {AM__CTL_SHM_VIA, "shm_via", AM__CTLF_URGENT, on_shm_via},
    {0, NULL, 0, NULL},
};
