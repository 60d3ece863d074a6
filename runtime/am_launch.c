/* am_launch.c -- the job launcher behind am-run and 'pdr run'.
 *
 * It starts P PEs (forked locally, or through ssh on the hosts of a
 * hostfile), gives each its rank, size, job id and transport in AM_*
 * environment variables, serves the tcp rendezvous where rank 0 publishes
 * its endpoint, waits for the PEs, and returns the exit status of the PE
 * that failed first. When a PE fails, the others get a grace period to
 * notice on their own (they report which peer went away), then are
 * terminated.
 *
 * Which PE failed first: a PE that fails writes one line "FAIL RANK
 * CULPRIT CODE" to the report pipe (AM_REPORT_FD) before it exits, naming
 * the peer that went away, or itself. The first line, or the first PE
 * that ends badly without a line of its own, names the culprit; the order
 * in which exits are reaped says nothing (a killed process can become a
 * zombie after its peers have noticed and left). The culprit's line is
 * printed first and its status is the job's. A culprit that the others
 * gave up while it was stopped (SIGSTOP) is killed at once, not after the
 * grace period.
 *
 * The launcher's own death: Ctrl-C, SIGTERM, SIGHUP and SIGQUIT are
 * forwarded to the PEs (SIGKILL 3 s later); local PEs get a parent-death
 * signal (SIGKILL), so they cannot outlive a launcher killed with SIGKILL;
 * and for ipc jobs a small helper process removes the socket directory if
 * the launcher dies without doing so.
 *
 * Transports: ipc (default for local jobs: sockets in a private temporary
 * directory that the launcher removes) or tcp (required for hostfiles;
 * bound to 127.0.0.1 unless --bind says otherwise). On tcp, when libzmq
 * has CURVE, the launcher makes a key pair per PE and one for the
 * rendezvous; each PE gets its own secret key and every PE's public key,
 * in a key block it reads from a descriptor (a memfd for a forked PE,
 * ssh's standard input for a remote one), and admits only the job's keys
 * (runtime/CONTROL.md, "CURVE and ZAP"). The rendezvous is a CURVE server
 * too, with a ZAP handler that admits the same keys, and takes rank 0's
 * endpoint from rank 0's key only.
 */
#include "config.h"

#include <dirent.h>
#include <errno.h>
#include <getopt.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <fcntl.h>
#include <limits.h>
#include <poll.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "pr_alloc.h"
#include "am_int.h"

#define EXIT_USAGE 2
#define EXIT_TIMEOUT 124

static volatile sig_atomic_t got_signal;

static void on_signal(int sig)
{
    got_signal = sig;
}

typedef struct launch {
    const char *prog;      /* "am-run" or "pdr run", for messages */
    int np;
    const char *transport;
    const char *bind;
    const char *latency, *bandwidth;
    const char *sched;      /* --sched: AM_SCHED of every PE */
    const char *cpu_bind;   /* --cpu-bind: AM_CPU_BIND of every PE */
    const char *hostfile;
    const char *rdv_host;
    const char *ssh;
    char *stats_dir;       /* absolute, owned */
    double timeout, grace;
    int curve;
    char **cmd;            /* PROGRAM ARGS */
    char **hosts;          /* per rank, NULL for local */
    char ipc_dir[64];
    uint64_t job;
    char (*pub)[41], (*sec)[41]; /* CURVE: a key pair per PE (tcp) */
    char rdv_pub[41], rdv_sec[41]; /* CURVE: the rendezvous' key pair */
    am__zap *zap;          /* the rendezvous' ZAP handler */
    void *zctx, *rdv;      /* rendezvous server (tcp) */
    char rdv_ep[512];
    char *root_ep;
    pid_t *pids;
    int *status;           /* wait status per rank, -1 while running */
    double *stopped_at;    /* when the PE was stopped, 0 if it is not */
    int *stop_status;      /* its wait status then */
    int *forced;           /* killed by the launcher because it was stopped */
    double *forced_after;  /* ... after that many seconds stopped */
    double heartbeat;      /* AM_HEARTBEAT: a PE stopped longer is gone */
    int *reported;         /* it wrote a failure line */
    int *printed;          /* its failure was printed */
    int report_rd, report_wr; /* the failure-report pipe, -1 if none */
    char rep_buf[4096];    /* report bytes read, up to a partial line */
    size_t rep_have;
    int watch_wr;          /* write end of the clean-up helper's pipe */
    pid_t watch_pid;
    pid_t self;            /* the launcher's pid, for the PEs' death signal */
} launch;

static void lerr(const launch *L, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));

static void lerr(const launch *L, const char *fmt, ...)
{
    char prefix[64];
    snprintf(prefix, sizeof prefix, "%s: ", L->prog);
    va_list ap;
    va_start(ap, fmt);
    am__vline(2, prefix, fmt, ap);
    va_end(ap);
}

static void usage(const launch *L, FILE *out)
{
    fprintf(out,
            "Usage: %s -n P [OPTIONS] [--] PROGRAM [ARGS...]\n\n"
            "Starts PROGRAM as a libam job of P processing elements (PEs).\n\n"
            "Options:\n"
            "  -n, --np P              number of PEs (required)\n"
            "  -t, --transport T       ipc (one host, default) or tcp\n"
            "      --bind ADDR         address tcp PEs bind and advertise "
            "(default 127.0.0.1)\n"
            "  -l, --latency SPEC      inject latency per message: 200us, "
            "100us-2ms (uniform)\n"
            "  -b, --bandwidth SPEC    cap bandwidth per link: 100Mbit, 1Gbit, "
            "12.5MB\n"
            "      --sched POLICY      the PEs' scheduling policy (AM_SCHED): "
            "other (default),\n"
            "                          batch, fifo or rr (fifo, rr: root or "
            "CAP_SYS_NICE; with\n"
            "                          more PEs than cores, fifo lets a PE run "
            "until it waits)\n"
            "      --cpu-bind MODE     none (default), core (bind each PE, with "
            "its threads, to a\n"
            "                          core of its own, round robin: steadier "
            "while other work\n"
            "                          runs) or auto (core where its host has "
            "as many PEs as cores,\n"
            "                          not under fifo or rr)\n"
            "      --hostfile FILE     start ranks on these hosts over ssh "
            "(lines: HOST [slots=N])\n"
            "      --rendezvous HOST   address the hosts reach this machine at "
            "(hostfile)\n"
            "      --ssh CMD           remote shell command (default $AM_SSH or "
            "ssh)\n"
            "      --stats DIR         every PE writes DIR/stats-RANK.json at "
            "am_finalize (DIR\n"
            "                          and its missing parents are created)\n"
            "      --no-curve          tcp without CURVE (no encryption, no keys)\n"
            "      --write-keys FILE   only write a CURVE key file for P PEs "
            "started by another\n"
            "                          launcher (AM_CURVE_KEYS=FILE on each)\n"
            "      --timeout SEC       stop the job after SEC seconds (exit %d)\n"
            "      --grace SEC         after a PE fails, wait SEC before "
            "stopping the others (10)\n"
            "  -h, --help              this text\n\n"
            "The exit status is 0 if every PE exited 0, else the status of the "
            "PE that failed\nfirst (128+N if it was killed by signal N). A PE "
            "stopped for longer than the\nheartbeat timeout (AM_HEARTBEAT, 3 s) "
            "is killed and counts as 128+its stop signal.\nSIGINT, SIGTERM, "
            "SIGHUP and SIGQUIT are passed on to the PEs. The PEs find their\n"
            "rank and peers in AM_* environment variables (see am_init in "
            "am.h).\n\n"
            "Without a hostfile the PEs talk over ipc, and after start-up "
            "through shared-memory\nrings they read and write themselves "
            "(runtime/CONTROL.md, \"Same-host rings\").\n"
            "AM_SHM=0 sends every frame over ZeroMQ instead; AM_SHM_RING=BYTES "
            "sets each\nring's size, AM_SHM_BIG=BYTES the frame size from "
            "which frames go over ZeroMQ\n(0: none).\n",
            L->prog, EXIT_TIMEOUT);
}

/* ------------------------------------------------------------ directories */

/* mkdir of a prefix of a path for am_mkdir_p: 0 when it is a directory
 * afterwards (made now, or before, perhaps by another process). */
static int make_dir(const char *dir)
{
    if (!mkdir(dir, 0777))
        return 0;
    int e = errno;
    struct stat sb;
    if (!stat(dir, &sb)) {
        if (S_ISDIR(sb.st_mode))
            return 0;
        e = ENOTDIR;
    }
    errno = e;
    return -1;
}

int am_mkdir_p(const char *path)
{
    size_t n = strlen(path);
    if (!n || n >= PATH_MAX) {
        errno = n ? ENAMETOOLONG : ENOENT;
        return -1;
    }
    char buf[PATH_MAX];
    memcpy(buf, path, n + 1);
    for (size_t i = 1; i < n; i++) {
        if (buf[i] != '/' || buf[i - 1] == '/')
            continue;
        buf[i] = '\0';
        int rc = make_dir(buf);
        buf[i] = '/';
        if (rc)
            return -1;
    }
    return make_dir(buf);
}

/* ---------------------------------------------------------------- hostfile */

static int read_hostfile(launch *L)
{
    FILE *f = fopen(L->hostfile, "r");
    if (!f) {
        lerr(L, "cannot open %s: %s", L->hostfile, strerror(errno));
        return -1;
    }
    L->hosts = pr_calloc((size_t)L->np, sizeof *L->hosts);
    if (!L->hosts) {
        lerr(L, "out of memory");
        fclose(f);
        return -1;
    }
    char line[512];
    int rank = 0, lineno = 0, bad = 0;
    while (fgets(line, sizeof line, f) && rank < L->np) {
        lineno++;
        line[strcspn(line, "#\r\n")] = '\0';
        char *save = NULL;
        char *host = strtok_r(line, " \t", &save);
        if (!host)
            continue;
        long slots = 1;
        for (char *tok; (tok = strtok_r(NULL, " \t", &save));) {
            char *end;
            if (strncmp(tok, "slots=", 6) ||
                (slots = strtol(tok + 6, &end, 10)) < 1 || *end) {
                lerr(L, "%s:%d: expected 'HOST [slots=N]', got '%s'",
                     L->hostfile, lineno, tok);
                bad = 1;
                break;
            }
        }
        for (long i = 0; i < slots && rank < L->np && !bad; i++)
            if (!(L->hosts[rank++] = pr_strdup(host))) {
                lerr(L, "out of memory");
                bad = 1;
            }
    }
    fclose(f);
    if (!bad && rank < L->np) {
        lerr(L, "%s lists %d slot%s, -n %d needs %d (add hosts or slots=N)",
             L->hostfile, rank, rank == 1 ? "" : "s", L->np, L->np);
        bad = 1;
    }
    return bad ? -1 : 0;
}

static int is_loopback(const char *h)
{
    return !strncmp(h, "127.", 4) || !strcmp(h, "localhost") || !strcmp(h, "::1");
}

/* ------------------------------------------------------------- rendezvous */

static int rdv_open(launch *L)
{
    L->zctx = zmq_ctx_new();
    L->rdv = L->zctx ? zmq_socket(L->zctx, ZMQ_ROUTER) : NULL;
    if (!L->rdv)
        return -1;
    int zero = 0, one = 1;
    zmq_setsockopt(L->rdv, ZMQ_LINGER, &zero, sizeof zero);
    if (L->curve) {
        /* The handler first: libzmq admits every client while none is
         * bound. */
        char prefix[64];
        snprintf(prefix, sizeof prefix, "%s: ", L->prog);
        if (am__zap_start(L->zctx, (const char (*)[41])L->pub, L->np, prefix,
                          "the rendezvous", &L->zap) ||
            zmq_setsockopt(L->rdv, ZMQ_CURVE_SERVER, &one, sizeof one) ||
            zmq_setsockopt(L->rdv, ZMQ_CURVE_SECRETKEY, L->rdv_sec, 40) ||
            zmq_setsockopt(L->rdv, ZMQ_ZAP_DOMAIN, "am", 2)) {
            lerr(L, "cannot make the rendezvous a CURVE server");
            return -1;
        }
    }
    const char *adv = L->rdv_host;
    char bind_ep[300];
    if (L->hosts) {
        int local = 1;
        for (int r = 0; r < L->np; r++)
            local &= is_loopback(L->hosts[r]);
        static char name[256];
        if (!adv && local)
            adv = "127.0.0.1";
        if (!adv) {
            if (gethostname(name, sizeof name) != 0)
                return -1;
            name[sizeof name - 1] = '\0';
            adv = name;
        }
        snprintf(bind_ep, sizeof bind_ep, "tcp://%s:0",
                 is_loopback(adv) ? "127.0.0.1" : "*");
    } else {
        adv = L->bind;
        snprintf(bind_ep, sizeof bind_ep, "tcp://%s:0", L->bind);
    }
    if (zmq_bind(L->rdv, bind_ep) != 0) {
        lerr(L, "cannot bind the rendezvous %s: %s", bind_ep, zmq_strerror(errno));
        return -1;
    }
    char last[256];
    size_t len = sizeof last;
    if (zmq_getsockopt(L->rdv, ZMQ_LAST_ENDPOINT, last, &len) != 0)
        return -1;
    const char *port = strrchr(last, ':');
    snprintf(L->rdv_ep, sizeof L->rdv_ep, "tcp://%s%s", adv, port ? port : "");
    return 0;
}

typedef struct pending {
    struct pending *next;
    size_t idlen;
    uint8_t id[256];
} pending;

static void rdv_reply(launch *L, const uint8_t *id, size_t idlen,
                      const char *text)
{
    zmq_send(L->rdv, id, idlen, ZMQ_SNDMORE | ZMQ_DONTWAIT);
    zmq_send(L->rdv, text, strlen(text), ZMQ_DONTWAIT);
}

/* Serves requests for up to ms milliseconds. */
static void rdv_serve(launch *L, pending **waiting, int ms)
{
    zmq_pollitem_t it = {L->rdv, 0, ZMQ_POLLIN, 0};
    if (zmq_poll(&it, 1, ms) <= 0)
        return;
    for (;;) {
        uint8_t id[256];
        char req[1100];
        int idn = zmq_recv(L->rdv, id, sizeof id, ZMQ_DONTWAIT);
        if (idn < 0)
            return;
        int more = 0;
        size_t ml = sizeof more;
        zmq_getsockopt(L->rdv, ZMQ_RCVMORE, &more, &ml);
        if (!more || idn > (int)sizeof id)
            continue;
        zmq_msg_t m;
        zmq_msg_init(&m);
        int n = zmq_msg_recv(&m, L->rdv, ZMQ_DONTWAIT);
        if (n < 0) {
            zmq_msg_close(&m);
            continue;
        }
        size_t k = (size_t)n < sizeof req - 1 ? (size_t)n : sizeof req - 1;
        memcpy(req, zmq_msg_data(&m), k);
        req[k] = '\0';
        /* With CURVE, the ZAP handler named the client's rank: only rank
         * 0 may publish. */
        const char *uid = L->curve ? zmq_msg_gets(&m, "User-Id") : NULL;
        int from_root = !L->curve || (uid && !strcmp(uid, "0"));
        zmq_msg_close(&m);
        char job[32];
        snprintf(job, sizeof job, "%llu", (unsigned long long)L->job);
        size_t jl = strlen(job);
        if (!strncmp(req, "PUT ", 4) && !from_root) {
            rdv_reply(L, id, (size_t)idn, "ERR only rank 0 publishes");
        } else if (!strncmp(req, "PUT ", 4) && !strncmp(req + 4, job, jl) &&
                   req[4 + jl] == ' ' && !L->root_ep) {
            L->root_ep = pr_strdup(req + 5 + jl);
            rdv_reply(L, id, (size_t)idn, L->root_ep ? "OK" : "ERR no memory");
            char ep[1200];
            snprintf(ep, sizeof ep, "EP %s", L->root_ep ? L->root_ep : "");
            while (*waiting && L->root_ep) {
                pending *p = *waiting;
                *waiting = p->next;
                rdv_reply(L, p->id, p->idlen, ep);
                pr_free(p);
            }
        } else if (!strncmp(req, "GET ", 4) && !strcmp(req + 4, job)) {
            if (L->root_ep) {
                char ep[1200];
                snprintf(ep, sizeof ep, "EP %s", L->root_ep);
                rdv_reply(L, id, (size_t)idn, ep);
            } else {
                pending *p = pr_calloc(1, sizeof *p);
                if (p) {
                    memcpy(p->id, id, (size_t)idn);
                    p->idlen = (size_t)idn;
                    p->next = *waiting;
                    *waiting = p;
                } else {
                    /* The PE would wait for an answer that never comes:
                     * it is told, and says so. */
                    rdv_reply(L, id, (size_t)idn, "ERR no memory");
                }
            }
        } else {
            rdv_reply(L, id, (size_t)idn, "ERR wrong job or request");
        }
    }
}

/* -------------------------------------------------------------- starting */

/* Appends s to buf quoted for a POSIX shell. */
static int shquote(char **buf, size_t *len, size_t *cap, const char *s)
{
    size_t need = *len + 4 * strlen(s) + 4;
    if (need > *cap) {
        size_t ncap = need * 2;
        char *nb = pr_realloc(*buf, ncap);
        if (!nb)
            return -1;
        *buf = nb;
        *cap = ncap;
    }
    char *o = *buf + *len;
    *o++ = '\'';
    for (; *s; s++) {
        if (*s == '\'') {
            memcpy(o, "'\\''", 4);
            o += 4;
        } else {
            *o++ = *s;
        }
    }
    *o++ = '\'';
    *o++ = ' ';
    *o = '\0';
    *len = (size_t)(o - *buf);
    return 0;
}

enum { NENV = 24 };

/* The AM_* variables of rank r as "NAME=VALUE" strings in env[]. */
static int make_env(launch *L, int r, char env[NENV][1200])
{
    int n = 0;
    snprintf(env[n++], 1200, "AM_RANK=%d", r);
    snprintf(env[n++], 1200, "AM_SIZE=%d", L->np);
    snprintf(env[n++], 1200, "AM_JOB=%llu", (unsigned long long)L->job);
    snprintf(env[n++], 1200, "AM_TRANSPORT=%s", L->transport);
    if (!strcmp(L->transport, "ipc")) {
        snprintf(env[n++], 1200, "AM_IPC_DIR=%s", L->ipc_dir);
        snprintf(env[n++], 1200, "AM_ROOT=ipc://%s/0.sock", L->ipc_dir);
    } else {
        snprintf(env[n++], 1200, "AM_BIND=%s", L->hosts ? L->hosts[r] : L->bind);
        snprintf(env[n++], 1200, "AM_RENDEZVOUS=%s", L->rdv_ep);
    }
    if (L->latency)
        snprintf(env[n++], 1200, "AM_LATENCY=%s", L->latency);
    if (L->bandwidth)
        snprintf(env[n++], 1200, "AM_BANDWIDTH=%s", L->bandwidth);
    if (L->sched)
        snprintf(env[n++], 1200, "AM_SCHED=%s", L->sched);
    /* The PE's index among the PEs of its host, and their number. */
    int slot = 0, slots = 0;
    for (int q = 0; q < L->np; q++)
        if (!L->hosts || !strcmp(L->hosts[q], L->hosts[r])) {
            slot += q < r;
            slots++;
        }
    snprintf(env[n++], 1200, "AM_CPU_BIND=%s", L->cpu_bind ? L->cpu_bind : "none");
    snprintf(env[n++], 1200, "AM_CPU_SLOT=%d", slot);
    snprintf(env[n++], 1200, "AM_CPU_SLOTS=%d", slots);
    if (L->stats_dir)
        snprintf(env[n++], 1200, "AM_STATS_DIR=%s", L->stats_dir);
    if (!L->hosts && L->report_wr >= 0)
        snprintf(env[n++], 1200, "AM_REPORT_FD=%d", L->report_wr);
    return n;
}

static void default_signals(void);

/* Writes the n bytes at buf to fd, again after EINTR. Returns 0, or -1
 * with errno set (EIO when a write took nothing). */
static int write_all(int fd, const char *buf, size_t n)
{
    while (n) {
        ssize_t w = write(fd, buf, n);
        if (w < 0 && errno == EINTR)
            continue;
        if (w <= 0) {
            if (!w)
                errno = EIO;
            return -1;
        }
        buf += w;
        n -= (size_t)w;
    }
    return 0;
}

/* PE r's CURVE key block in a memfd (close-on-exec, read from the
 * start), or -1 with errno set. Not a file: nothing to remove, and
 * nothing another process can open by name. */
static int key_fd(const launch *L, int r)
{
    char *block;
    size_t len;
    if (am__keys_format(L->pub, L->sec, L->np, r, L->rdv_pub, &block, &len)) {
        errno = ENOMEM;
        return -1;
    }
    int fd = memfd_create("am-curve-keys", MFD_CLOEXEC);
    if (fd >= 0 && write_all(fd, block, len)) {
        close(fd);
        fd = -1;
    }
    memset(block, 0, len);
    pr_free(block);
    if (fd >= 0 && lseek(fd, 0, SEEK_SET) != 0) {
        close(fd);
        fd = -1;
    }
    return fd;
}

static pid_t start_local(launch *L, int r)
{
    char env[NENV][1200];
    int n = make_env(L, r, env);
    int kfd = -1;
    if (L->curve) {
        if ((kfd = key_fd(L, r)) < 0)
            return -1;
        snprintf(env[n++], 1200, "AM_CURVE_KEYS=fd:%d", kfd);
    }
    pid_t pid = fork();
    if (pid != 0) {
        if (kfd >= 0)
            close(kfd);
        return pid;
    }
    default_signals();
    /* A PE must not outlive its launcher, even one killed with SIGKILL. If
     * the launcher died before the death signal was set, leave now. */
    if (prctl(PR_SET_PDEATHSIG, SIGKILL) != 0 || getppid() != L->self)
        _exit(127);
    /* The report pipe's write end stays open across exec; the read end
     * (close-on-exec) does not. */
    if (L->report_wr >= 0)
        fcntl(L->report_wr, F_SETFD, 0);
    if (kfd >= 0)
        fcntl(kfd, F_SETFD, 0);
    /* Nothing of an enclosing job may leak into this one. */
    static const char *const stale[] = {
        "AM_ROOT", "AM_RENDEZVOUS", "AM_IPC_DIR", "AM_BIND", "AM_LATENCY",
        "AM_CPU_BIND", "AM_CPU_SLOT", "AM_CPU_SLOTS",
        "AM_BANDWIDTH", "AM_STATS_DIR", "AM_CURVE_KEYS",
        "AM_CURVE_SERVER_PUBLIC", "AM_CURVE_SERVER_SECRET", "AM_REPORT_FD"};
    for (size_t i = 0; i < sizeof stale / sizeof stale[0]; i++)
        unsetenv(stale[i]);
    for (int i = 0; i < n; i++)
        putenv(env[i]);
    execvp(L->cmd[0], L->cmd);
    fprintf(stderr, "%s: cannot run %s: %s\n", L->prog, L->cmd[0], strerror(errno));
    _exit(127);
}

/* The signals the launcher catches, back to their defaults in a child. */
static const int caught[] = {SIGINT, SIGTERM, SIGHUP, SIGQUIT};

static void default_signals(void)
{
    for (size_t i = 0; i < sizeof caught / sizeof caught[0]; i++)
        signal(caught[i], SIG_DFL);
}

/* Remote rank: ssh HOST sh -c 'cd DIR && exec env VARS PROGRAM ARGS'.
 * The CURVE key block goes through ssh's stdin (AM_CURVE_KEYS=fd:0), not
 * the command line or the environment, so that it shows in ps on neither
 * host and has no length limit. */
static pid_t start_remote(launch *L, int r)
{
    char env[NENV][1200];
    int n = make_env(L, r, env);
    if (L->curve)
        snprintf(env[n++], 1200, "AM_CURVE_KEYS=fd:0");
    char *script = NULL, *cmd = NULL;
    size_t sl = 0, sc = 0, cl = 0, cc = 0;
    char cwd[4096];
    if (!getcwd(cwd, sizeof cwd))
        snprintf(cwd, sizeof cwd, ".");
    int use_keys = L->curve;
    int bad = 0;
    const char *pre = "cd ";
    script = pr_malloc(sc = strlen(pre) + 1);
    if (!script)
        return -1;
    strcpy(script, pre);
    sl = strlen(script);
    bad |= shquote(&script, &sl, &sc, cwd);
    const char *mid = "&& exec env ";
    if (sl + strlen(mid) + 1 > sc) {
        char *nb = pr_realloc(script, sc = sl + strlen(mid) + 64);
        if (!nb)
            bad = 1;
        else
            script = nb;
    }
    if (!bad) {
        strcpy(script + sl, mid);
        sl += strlen(mid);
    }
    for (int i = 0; i < n && !bad; i++)
        bad |= shquote(&script, &sl, &sc, env[i]);
    for (char **a = L->cmd; *a && !bad; a++)
        bad |= shquote(&script, &sl, &sc, *a);
    cmd = pr_malloc(cc = 16);
    if (cmd)
        strcpy(cmd, "exec sh -c ");
    cl = cmd ? strlen(cmd) : 0;
    if (bad || !cmd || shquote(&cmd, &cl, &cc, script)) {
        pr_free(script);
        pr_free(cmd);
        return -1;
    }
    pr_free(script);
    int keys[2] = {-1, -1};
    if (use_keys && pipe(keys) != 0) {
        pr_free(cmd);
        return -1;
    }
    pid_t pid = fork();
    if (pid == 0) {
        default_signals();
        /* ssh ends its session when the launcher dies. */
        if (prctl(PR_SET_PDEATHSIG, SIGTERM) != 0 || getppid() != L->self)
            _exit(127);
        if (use_keys) {
            dup2(keys[0], 0);
            close(keys[0]);
            close(keys[1]);
        }
        execlp(L->ssh, L->ssh, L->hosts[r], cmd, (char *)NULL);
        fprintf(stderr, "%s: cannot run %s: %s\n", L->prog, L->ssh,
                strerror(errno));
        _exit(127);
    }
    pr_free(cmd);
    if (use_keys) {
        close(keys[0]);
        char *block = NULL;
        size_t len = 0;
        if (pid > 0 && !am__keys_format(L->pub, L->sec, L->np, r, L->rdv_pub,
                                        &block, &len)) {
            /* ssh takes the block into its channel window (2 MiB) without
             * waiting for the remote PE; a dead ssh must not kill the
             * launcher with SIGPIPE. */
            struct sigaction ign, old_pipe;
            memset(&ign, 0, sizeof ign);
            ign.sa_handler = SIG_IGN;
            sigaction(SIGPIPE, &ign, &old_pipe);
            (void)write_all(keys[1], block, len); /* the PE says if it lacks keys */
            sigaction(SIGPIPE, &old_pipe, NULL);
            memset(block, 0, len);
            pr_free(block);
        }
        close(keys[1]);
    }
    return pid;
}

/* ---------------------------------------------------------------- waiting */

/* What ended PE r, from its wait status. A PE the launcher killed because
 * it was stopped is described by its stop. */
static void describe(const launch *L, int r, int status, char *buf, size_t n)
{
    const char *where = L->hosts ? L->hosts[r] : NULL;
    char at[300] = "";
    if (where)
        snprintf(at, sizeof at, " on %s", where);
    if (WIFSTOPPED(status))
        snprintf(buf, n, "PE %d (pid %ld%s) was stopped by signal %d (%s) "
                         "for %.1f s; killed it",
                 r, (long)L->pids[r], at, WSTOPSIG(status),
                 strsignal(WSTOPSIG(status)), L->forced_after[r]);
    else if (WIFSIGNALED(status))
        snprintf(buf, n, "PE %d (pid %ld%s) was killed by signal %d (%s)", r,
                 (long)L->pids[r], at, WTERMSIG(status),
                 strsignal(WTERMSIG(status)));
    else
        snprintf(buf, n, "PE %d (pid %ld%s) exited with status %d", r,
                 (long)L->pids[r], at, WEXITSTATUS(status));
}

static int exit_code(int status)
{
    if (WIFSTOPPED(status))
        return 128 + WSTOPSIG(status);
    return WIFSIGNALED(status) ? 128 + WTERMSIG(status) : WEXITSTATUS(status);
}

static int failed(int status)
{
    return status != -1 && !(WIFEXITED(status) && WEXITSTATUS(status) == 0);
}

static void signal_all(launch *L, int sig)
{
    for (int r = 0; r < L->np; r++)
        if (L->pids[r] > 0 && L->status[r] == -1) {
            kill(L->pids[r], sig);
            /* A stopped PE acts on the signal only once continued. */
            if (L->stopped_at[r] > 0 && sig != SIGKILL)
                kill(L->pids[r], SIGCONT);
        }
}

/* The state of a job that is being waited for. */
typedef struct waitstate {
    int alive;        /* PEs not reaped */
    int culprit;      /* the PE that failed first, -1 while unknown */
    int shown;        /* the culprit's line was printed */
    double fail_at;   /* first sign of a failure, 0 if none */
    double lone_at;   /* when the culprit became the only PE left */
    int stopping;     /* 1: SIGTERM sent, 2: SIGKILL sent */
    double term_at;   /* when SIGTERM was sent */
    int signalled;    /* the launcher got a signal */
} waitstate;

/* Reads the failure lines the PEs wrote ("FAIL RANK CULPRIT CODE"). The
 * first one that names a PE of the job names the culprit. */
static void read_reports(launch *L, waitstate *W)
{
    char *buf = L->rep_buf;
    size_t have = L->rep_have;
    if (L->report_rd < 0)
        return;
    for (;;) {
        ssize_t n = read(L->report_rd, buf + have, sizeof L->rep_buf - 1 - have);
        if (n == 0) {
            /* Every PE closed its end (am_finalize): no line can come, and
             * an open read end would stay readable, so that wait_job's
             * poll returned at once and the launcher spun until the last
             * PE exited; under SCHED_FIFO on the PEs' processor that spin
             * kept them from ever finishing their exit. */
            close(L->report_rd);
            L->report_rd = -1;
            break;
        }
        if (n < 0)
            break;
        have += (size_t)n;
        char *line = buf, *nl;
        while ((nl = memchr(line, '\n', have - (size_t)(line - buf)))) {
            *nl = '\0';
            int rank, culprit, code;
            if (sscanf(line, "FAIL %d %d %d", &rank, &culprit, &code) == 3 &&
                rank >= 0 && rank < L->np) {
                L->reported[rank] = 1;
                if (W->culprit < 0 && culprit >= 0 && culprit < L->np)
                    W->culprit = culprit;
                if (!W->fail_at)
                    W->fail_at = am__now();
            }
            line = nl + 1;
        }
        have -= (size_t)(line - buf);
        memmove(buf, line, have);
        if (have == sizeof L->rep_buf - 1)
            have = 0; /* a line that long is not ours */
    }
    L->rep_have = have;
}

/* Prints the culprit's line once its end is known, then those of the other
 * PEs that failed, so that the first line names the PE that failed first.
 * At the end (final) everything left is printed. */
static void show_failures(launch *L, waitstate *W, int final)
{
    char what[400];
    if (!W->shown && W->culprit >= 0 && L->status[W->culprit] != -1) {
        if (failed(L->status[W->culprit])) {
            describe(L, W->culprit, L->status[W->culprit], what, sizeof what);
            lerr(L, "%s", what);
            L->printed[W->culprit] = 1;
        }
        W->shown = 1;
    }
    if (!W->shown && !final)
        return;
    for (int r = 0; r < L->np; r++) {
        if (L->printed[r] || !failed(L->status[r]))
            continue;
        describe(L, r, L->status[r], what, sizeof what);
        lerr(L, "%s", what);
        L->printed[r] = 1;
    }
}

/* Takes one reaped (or stopped, or continued) child. */
static void took(launch *L, waitstate *W, pid_t pid, int status)
{
    int r = 0;
    while (r < L->np && L->pids[r] != pid)
        r++;
    if (r == L->np)
        return; /* the clean-up helper */
    if (WIFSTOPPED(status) || WIFCONTINUED(status)) {
        L->stop_status[r] = WIFSTOPPED(status) ? status : 0;
        L->stopped_at[r] = WIFSTOPPED(status) ? am__now() : 0;
        return;
    }
    /* A PE the launcher killed because it was stopped is described by its
     * stop, not by the launcher's SIGKILL. */
    L->status[r] = L->forced[r] ? L->stop_status[r] : status;
    W->alive--;
    if (W->stopping) {
        L->printed[r] = 1; /* ended by the launcher: not a failure */
    } else if (failed(L->status[r])) {
        /* Failed without a line of its own: it is the first failure
         * unless a PE already named another. */
        if (W->culprit < 0 && !L->reported[r])
            W->culprit = r;
        if (!W->fail_at)
            W->fail_at = am__now();
    }
}

/* Kills PE r, which is stopped; it is then described by its stop. */
static void force_end(launch *L, int r, double now)
{
    L->forced[r] = 1;
    L->forced_after[r] = now - L->stopped_at[r];
    kill(L->pids[r], SIGKILL);
}

/* A PE stopped for longer than the heartbeat timeout is as gone as a
 * silent one (CONTROL.md, "Failure detection"), and its peers may not be
 * able to tell: their heartbeats wait behind the data they queued for it.
 * So the launcher, which sees the stop, ends it; its peers then see it
 * die. A stop of the whole job (Ctrl-Z) is left alone. */
static void end_stopped(launch *L, waitstate *W, double now)
{
    if (W->stopping)
        return;
    int running = 0;
    for (int r = 0; r < L->np; r++)
        running += L->status[r] == -1 && L->stopped_at[r] == 0;
    if (!running)
        return;
    for (int r = 0; r < L->np; r++) {
        if (L->status[r] != -1 || L->forced[r] || L->stopped_at[r] == 0 ||
            now < L->stopped_at[r] + L->heartbeat)
            continue;
        force_end(L, r, now);
        if (W->culprit < 0)
            W->culprit = r;
        if (!W->fail_at)
            W->fail_at = now;
    }
}

/* The culprit is still there while the others gave it up. A stopped one
 * cannot be on its way out: it is killed at once. A running one may be a
 * process that is still dying (a core dump takes a while), so it gets a
 * second before it is stopped like the rest of the job. */
static void end_culprit(launch *L, waitstate *W, double now)
{
    int c = W->culprit;
    if (c < 0 || L->status[c] != -1 || W->stopping || L->forced[c])
        return;
    if (W->alive > 1 && now < W->fail_at + L->grace)
        return;
    if (!W->lone_at)
        W->lone_at = now;
    if (L->stopped_at[c] > 0) {
        force_end(L, c, now);
    } else if (now > W->lone_at + 1.0) {
        lerr(L, "PE %d (pid %ld) did not end after the other PEs gave it up; "
                "stopping it", c, (long)L->pids[c]);
        W->stopping = 1;
        W->term_at = now;
        signal_all(L, SIGTERM);
    }
}

static void stop_job(launch *L, waitstate *W, double now)
{
    W->stopping = 1;
    W->term_at = now;
    signal_all(L, SIGTERM);
}

static int wait_job(launch *L)
{
    pending *waiting = NULL;
    waitstate W = {0, -1, 0, 0, 0, 0, 0};
    int result = 0;
    for (int r = 0; r < L->np; r++)
        W.alive += L->pids[r] > 0;
    double start = am__now();
    while (W.alive > 0) {
        /* Every child that changed, then every report line (a PE writes
         * its line before it exits), then what they mean. */
        pid_t pids[64];
        int sts[64], n = 0;
        while (n < 64) {
            pid_t pid = waitpid(-1, &sts[n], WNOHANG | WUNTRACED | WCONTINUED);
            if (pid < 0 && errno == ECHILD)
                W.alive = 0; /* nothing left to wait for */
            if (pid <= 0)
                break;
            pids[n++] = pid;
        }
        read_reports(L, &W);
        for (int i = 0; i < n; i++)
            took(L, &W, pids[i], sts[i]);
        show_failures(L, &W, 0);
        if (n == 64)
            continue;
        if (W.alive <= 0)
            break;
        if (L->rdv) {
            rdv_serve(L, &waiting, 20);
        } else {
            struct pollfd pf = {L->report_rd, POLLIN, 0};
            poll(&pf, L->report_rd >= 0, 20);
        }
        double now = am__now();
        end_stopped(L, &W, now);
        end_culprit(L, &W, now);
        if (got_signal && W.stopping < 2 && !W.signalled) {
            lerr(L, "%s: stopping the job", strsignal(got_signal));
            result = 128 + got_signal;
            W.signalled = 1;
            W.stopping = 1;
            W.term_at = now;
            signal_all(L, got_signal == SIGQUIT ? SIGTERM : got_signal);
        } else if (!W.stopping && W.fail_at && now > W.fail_at + L->grace) {
            lerr(L, "stopping the %d PE%s still running %.0f s after the "
                    "first failure",
                 W.alive, W.alive == 1 ? "" : "s", L->grace);
            stop_job(L, &W, now);
        } else if (!W.stopping && L->timeout > 0 && now > start + L->timeout) {
            lerr(L, "the job ran out of its %.0f s (--timeout); stopping it",
                 L->timeout);
            result = EXIT_TIMEOUT;
            stop_job(L, &W, now);
        } else if (W.stopping == 1 && now > W.term_at + 3.0) {
            W.stopping = 2;
            signal_all(L, SIGKILL);
        }
    }
    show_failures(L, &W, 1);
    while (waiting) {
        pending *p = waiting;
        waiting = p->next;
        pr_free(p);
    }
    if (result)
        return result;
    int c = W.culprit;
    if (c >= 0 && failed(L->status[c]))
        return exit_code(L->status[c]);
    for (int r = 0; r < L->np; r++)
        if (failed(L->status[r]))
            return exit_code(L->status[r]);
    return 0;
}

/* am-run -n P --write-keys FILE: a CURVE key file for a job of P PEs
 * started by another launcher (mpirun, srun, by hand: AM_CURVE_KEYS=FILE
 * on every PE). It holds every PE's secret, so it is made with mode 0600
 * and never over an existing file. */
static int keys_file(const launch *L, const char *path)
{
    if (!zmq_has("curve")) {
        lerr(L, "this libzmq has no CURVE");
        return 1;
    }
    size_t np = (size_t)L->np;
    char (*pub)[41] = pr_calloc(np, sizeof *pub), (*sec)[41] = pr_calloc(np, sizeof *sec);
    char *block = NULL;
    size_t len = 0;
    int ok = pub && sec;
    for (int r = 0; ok && r < L->np; r++)
        ok = zmq_curve_keypair(pub[r], sec[r]) == 0;
    ok = ok && !am__keys_format(pub, sec, L->np, -1, NULL, &block, &len);
    int fd = ok ? open(path, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600) : -1;
    if (ok && fd < 0)
        lerr(L, "cannot make %s: %s", path, strerror(errno));
    int written = fd >= 0 && write_all(fd, block, len) == 0;
    if (fd >= 0 && !written) {
        lerr(L, "cannot write %s: %s", path, strerror(errno));
        close(fd);
    }
    int done = written && close(fd) == 0;
    if (fd >= 0 && !done)
        unlink(path);
    if (block)
        memset(block, 0, len);
    if (sec)
        memset(sec, 0, sizeof *sec * np);
    pr_free(block);
    pr_free(pub);
    pr_free(sec);
    return done ? 0 : 1;
}

/* ------------------------------------------------------------------ main */

static int parse_double(const char *s, double *out)
{
    char *end;
    double v = strtod(s, &end);
    if (end == s || *end || !(v >= 0))
        return -1;
    *out = v;
    return 0;
}

/* Removes the ipc directory and what the PEs left in it: their sockets,
 * and the wake sockets and ring files of the same-host rings (am_shm.c)
 * of PEs that did not get to close them. The directory is the job's own
 * (mkdtemp), so every entry in it is the job's. */
static void remove_ipc_dir(const launch *L)
{
    if (!L->ipc_dir[0])
        return;
    DIR *d = opendir(L->ipc_dir);
    if (d) {
        struct dirent *e;
        while ((e = readdir(d))) {
            if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, ".."))
                continue;
            char path[sizeof L->ipc_dir + 300];
            snprintf(path, sizeof path, "%s/%s", L->ipc_dir, e->d_name);
            unlink(path);
        }
        closedir(d);
    }
    rmdir(L->ipc_dir);
}

/* The clean-up helper of an ipc job: a child that outlives a launcher
 * killed with SIGKILL just long enough to remove the socket directory (the
 * PEs die of their parent-death signal). It waits for the end of a pipe
 * from the launcher; a 'D' before the end means the launcher cleaned up
 * itself. It holds no descriptor of the launcher's besides its pipe, so
 * nothing waiting for the launcher's output waits for it. */
static void start_watch(launch *L)
{
    int p[2];
    if (pipe2(p, O_CLOEXEC) != 0)
        return;
    pid_t pid = fork();
    if (pid < 0) {
        close(p[0]);
        close(p[1]);
        return;
    }
    if (pid == 0) {
        for (size_t i = 0; i < sizeof caught / sizeof caught[0]; i++)
            signal(caught[i], SIG_IGN);
        int null = open("/dev/null", O_RDWR);
        for (int fd = 0; fd < 3 && null >= 0; fd++)
            dup2(null, fd);
        for (int fd = 3; fd < 1024; fd++)
            if (fd != p[0])
                close(fd);
        char c, last = 0;
        for (;;) {
            ssize_t n = read(p[0], &c, 1);
            if (n > 0)
                last = c;
            else if (n == 0 || errno != EINTR)
                break;
        }
        if (last != 'D')
            remove_ipc_dir(L);
        _exit(0);
    }
    close(p[0]);
    L->watch_wr = p[1];
    L->watch_pid = pid;
}

/* Tells the helper the launcher cleaned up, and waits for it to go. */
static void stop_watch(launch *L)
{
    if (L->watch_wr < 0)
        return;
    ssize_t w = write(L->watch_wr, "D", 1);
    (void)w;
    close(L->watch_wr);
    L->watch_wr = -1;
    while (waitpid(L->watch_pid, NULL, 0) < 0 && errno == EINTR)
        ;
}

static void cleanup(launch *L)
{
    remove_ipc_dir(L);
    stop_watch(L);
    if (L->report_rd >= 0)
        close(L->report_rd);
    if (L->report_wr >= 0)
        close(L->report_wr);
    if (L->rdv)
        zmq_close(L->rdv);
    if (am__zap_refused(L->zap))
        lerr(L, "the rendezvous refused %llu connection%s from %llu "
                "address%s (keys not of the job)",
             (unsigned long long)am__zap_refused(L->zap),
             am__zap_refused(L->zap) == 1 ? "" : "s",
             (unsigned long long)am__zap_strangers(L->zap),
             am__zap_strangers(L->zap) == 1 ? "" : "es");
    am__zap_stop(&L->zap);
    if (L->zctx)
        zmq_ctx_term(L->zctx);
    if (L->sec)
        memset(L->sec, 0, sizeof *L->sec * (size_t)L->np);
    memset(L->rdv_sec, 0, sizeof L->rdv_sec);
    pr_free(L->pub);
    pr_free(L->sec);
    if (L->hosts)
        for (int r = 0; r < L->np; r++)
            pr_free(L->hosts[r]);
    pr_free(L->hosts);
    pr_free(L->stats_dir);
    pr_free(L->root_ep);
    pr_free(L->pids);
    pr_free(L->status);
    pr_free(L->stopped_at);
    pr_free(L->stop_status);
    pr_free(L->forced);
    pr_free(L->forced_after);
    pr_free(L->reported);
    pr_free(L->printed);
}

int am_launch_main(int argc, char **argv, const char *prog)
{
    launch L;
    memset(&L, 0, sizeof L);
    L.prog = prog ? prog : "am-run";
    L.transport = NULL;
    L.bind = "127.0.0.1";
    L.grace = 10;
    L.curve = 1;
    L.ssh = getenv("AM_SSH") && *getenv("AM_SSH") ? getenv("AM_SSH") : "ssh";
    const char *stats = NULL, *write_keys = NULL;
    enum { O_BIND = 256, O_HOSTFILE, O_RDV, O_SSH, O_STATS, O_NOCURVE,
           O_TIMEOUT, O_GRACE, O_WRITE_KEYS, O_SCHED, O_CPU_BIND };
    static const struct option opts[] = {
        {"np", required_argument, NULL, 'n'},
        {"transport", required_argument, NULL, 't'},
        {"bind", required_argument, NULL, O_BIND},
        {"latency", required_argument, NULL, 'l'},
        {"bandwidth", required_argument, NULL, 'b'},
        {"hostfile", required_argument, NULL, O_HOSTFILE},
        {"rendezvous", required_argument, NULL, O_RDV},
        {"ssh", required_argument, NULL, O_SSH},
        {"stats", required_argument, NULL, O_STATS},
        {"no-curve", no_argument, NULL, O_NOCURVE},
        {"timeout", required_argument, NULL, O_TIMEOUT},
        {"grace", required_argument, NULL, O_GRACE},
        {"write-keys", required_argument, NULL, O_WRITE_KEYS},
        {"sched", required_argument, NULL, O_SCHED},
        {"cpu-bind", required_argument, NULL, O_CPU_BIND},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0}};
    int c;
    double lo, hi, bps;
    optind = 1;
    while ((c = getopt_long(argc, argv, "+n:t:l:b:h", opts, NULL)) != -1) {
        switch (c) {
        case 'n': {
            char *end;
            long v = strtol(optarg, &end, 10);
            if (*end || v < 1 || v > 4096) {
                lerr(&L, "-n wants a number of PEs from 1 to 4096, not '%s'",
                     optarg);
                return EXIT_USAGE;
            }
            L.np = (int)v;
            break;
        }
        case 't':
            if (strcmp(optarg, "ipc") && strcmp(optarg, "tcp")) {
                lerr(&L, "--transport is ipc or tcp, not '%s'", optarg);
                return EXIT_USAGE;
            }
            L.transport = optarg;
            break;
        case O_BIND:
            L.bind = optarg;
            break;
        case 'l':
            if (am__latency_parse(optarg, &lo, &hi)) {
                lerr(&L, "bad --latency '%s' (examples: 200us, 100us-2ms, 0)",
                     optarg);
                return EXIT_USAGE;
            }
            L.latency = optarg;
            break;
        case 'b':
            if (am__bandwidth_parse(optarg, &bps)) {
                lerr(&L, "bad --bandwidth '%s' (examples: 100Mbit, 1Gbit, 12.5MB)",
                     optarg);
                return EXIT_USAGE;
            }
            L.bandwidth = optarg;
            break;
        case O_SCHED: {
            /* The launcher too: real-time PEs that keep their cores would
             * otherwise leave it the throttled remainder, late to see a
             * PE fail. Refused here, before any PE starts, with the
             * reason. */
            const char *hint;
            int err = am__sched_set(optarg, &hint);
            if (err < 0) {
                lerr(&L, "--sched is other, batch, fifo or rr, not '%s'", optarg);
                return EXIT_USAGE;
            }
            if (err) {
                lerr(&L, "--sched %s: cannot set the scheduling policy: %s%s", optarg,
                     strerror(err), hint);
                return EXIT_USAGE;
            }
            L.sched = optarg;
            break;
        }
        case O_CPU_BIND:
            if (strcmp(optarg, "auto") && strcmp(optarg, "core") && strcmp(optarg, "none")) {
                lerr(&L, "--cpu-bind is auto, core or none, not '%s'", optarg);
                return EXIT_USAGE;
            }
            L.cpu_bind = optarg;
            break;
        case O_HOSTFILE:
            L.hostfile = optarg;
            break;
        case O_RDV:
            L.rdv_host = optarg;
            break;
        case O_SSH:
            L.ssh = optarg;
            break;
        case O_STATS:
            stats = optarg;
            break;
        case O_WRITE_KEYS:
            write_keys = optarg;
            break;
        case O_NOCURVE:
            L.curve = 0;
            break;
        case O_TIMEOUT:
        case O_GRACE:
            if (parse_double(optarg, c == O_TIMEOUT ? &L.timeout : &L.grace)) {
                lerr(&L, "--%s wants seconds, not '%s'",
                     c == O_TIMEOUT ? "timeout" : "grace", optarg);
                return EXIT_USAGE;
            }
            break;
        case 'h':
            usage(&L, stdout);
            return 0;
        default:
            fprintf(stderr, "Try '%s --help'.\n", L.prog);
            return EXIT_USAGE;
        }
    }
    if (write_keys && L.np)
        return keys_file(&L, write_keys);
    if (L.np == 0 || optind >= argc) {
        lerr(&L, L.np ? "no PROGRAM to run" : "-n P is required");
        fprintf(stderr, "Try '%s --help'.\n", L.prog);
        return EXIT_USAGE;
    }
    L.cmd = argv + optind;
    if (!L.transport)
        L.transport = L.hostfile ? "tcp" : "ipc";
    if (L.hostfile && strcmp(L.transport, "tcp")) {
        lerr(&L, "a --hostfile job needs --transport tcp");
        return EXIT_USAGE;
    }
    /* A one-PE job has no connection to protect. */
    L.curve = L.curve && !strcmp(L.transport, "tcp") && zmq_has("curve") &&
              L.np > 1;

    int rc = 1, handlers_set = 0;
    if (getrandom(&L.job, sizeof L.job, 0) != (ssize_t)sizeof L.job)
        L.job = (uint64_t)getpid() << 32 ^ (uint64_t)time(NULL);
    L.job &= (UINT64_C(1) << 62) - 1;
    L.report_rd = L.report_wr = L.watch_wr = -1;
    /* The PEs' heartbeat timeout (am_ctx.c reads the same variable). */
    L.heartbeat = 3.0;
    const char *hb = getenv("AM_HEARTBEAT");
    double hb_hi;
    if (hb && parse_double(hb, &L.heartbeat) != 0 &&
        am__latency_parse(hb, &L.heartbeat, &hb_hi) != 0)
        L.heartbeat = 3.0;
    if (L.heartbeat < 0.05)
        L.heartbeat = 0.05;
    L.self = getpid();
    size_t np = (size_t)L.np;
    L.pids = pr_calloc(np, sizeof *L.pids);
    L.status = pr_malloc(sizeof *L.status * np);
    L.stopped_at = pr_calloc(np, sizeof *L.stopped_at);
    L.stop_status = pr_calloc(np, sizeof *L.stop_status);
    L.forced = pr_calloc(np, sizeof *L.forced);
    L.forced_after = pr_calloc(np, sizeof *L.forced_after);
    L.reported = pr_calloc(np, sizeof *L.reported);
    L.printed = pr_calloc(np, sizeof *L.printed);
    if (!L.pids || !L.status || !L.stopped_at || !L.stop_status || !L.forced ||
        !L.forced_after ||
        !L.reported || !L.printed) {
        lerr(&L, "out of memory");
        goto out;
    }
    for (int r = 0; r < L.np; r++)
        L.status[r] = -1;
    if (stats) {
        if (am_mkdir_p(stats)) {
            lerr(&L, "cannot create --stats directory %s: %s", stats,
                 strerror(errno));
            goto out;
        }
        /* realpath's own result is the C library's, not the hook's. */
        char *abs = realpath(stats, NULL);
        if (!abs) {
            lerr(&L, "--stats %s: %s", stats, strerror(errno));
            goto out;
        }
        L.stats_dir = pr_strdup(abs);
        free(abs);
        if (!L.stats_dir) {
            lerr(&L, "--stats %s: out of memory", stats);
            goto out;
        }
    }
    if (L.hostfile && read_hostfile(&L))
        goto out;
    /* Caught from here on, so that no signal can leave the socket
     * directory behind; forwarded to the PEs once they run. */
    struct sigaction sa, old_sa[sizeof caught / sizeof caught[0]];
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    got_signal = 0;
    for (size_t i = 0; i < sizeof caught / sizeof caught[0]; i++)
        sigaction(caught[i], &sa, &old_sa[i]);
    handlers_set = 1;
    if (!strcmp(L.transport, "ipc")) {
        const char *tmp = getenv("TMPDIR");
        if (!tmp || !*tmp || strlen(tmp) > 40)
            tmp = "/tmp";
        snprintf(L.ipc_dir, sizeof L.ipc_dir, "%s/am-XXXXXX", tmp);
        if (!mkdtemp(L.ipc_dir)) {
            lerr(&L, "cannot make a directory for ipc sockets in %s: %s", tmp,
                 strerror(errno));
            L.ipc_dir[0] = '\0';
            goto out;
        }
        start_watch(&L);
    } else {
        /* A key pair per PE and one for the rendezvous. */
        if (L.curve) {
            L.pub = pr_calloc(np, sizeof *L.pub);
            L.sec = pr_calloc(np, sizeof *L.sec);
            int ok = L.pub && L.sec &&
                     zmq_curve_keypair(L.rdv_pub, L.rdv_sec) == 0;
            for (int r = 0; ok && r < L.np; r++)
                ok = zmq_curve_keypair(L.pub[r], L.sec[r]) == 0;
            if (!ok) {
                lerr(&L, "cannot make CURVE keys: %s", zmq_strerror(errno));
                goto out;
            }
        }
        if (rdv_open(&L)) {
            lerr(&L, "cannot start the rendezvous server");
            goto out;
        }
    }

    /* Non-blocking: a PE never waits to report (a full pipe loses the
     * line, and the launcher falls back on the order of the exits). */
    if (!L.hosts) {
        int rp[2];
        if (pipe2(rp, O_CLOEXEC | O_NONBLOCK) == 0) {
            L.report_rd = rp[0];
            L.report_wr = rp[1];
        }
    }
    fflush(NULL);
    int started = 0;
    for (int r = 0; r < L.np; r++) {
        L.pids[r] = L.hosts ? start_remote(&L, r) : start_local(&L, r);
        if (L.pids[r] < 0) {
            lerr(&L, "cannot start PE %d: %s", r, strerror(errno));
            L.pids[r] = 0;
            signal_all(&L, SIGTERM);
            break;
        }
        started++;
    }
    if (L.report_wr >= 0) {
        close(L.report_wr);
        L.report_wr = -1;
    }
    rc = wait_job(&L);
    if (started < L.np && rc == 0)
        rc = 1;
out:
    cleanup(&L);
    if (handlers_set)
        for (size_t i = 0; i < sizeof caught / sizeof caught[0]; i++)
            sigaction(caught[i], &old_sa[i], NULL);
    return rc;
}
