/* am_keys.c -- the CURVE keys of a tcp job: the key block the launcher
 * writes for each PE, and reading it back in the PE.
 *
 * A key block is text, one item a line (CONTROL.md, "CURVE and ZAP"):
 *
 *     am-curve-keys 1
 *     public 0 <40 Z85 characters>
 *     ...
 *     public P-1 <key>
 *     secret R <key>           this PE's; a block may hold several
 *     rendezvous <key>         optional: the tcp rendezvous server's
 *     end
 *
 * It is about 50 bytes per PE, 200 KiB for 4096 PEs: more than Linux lets
 * one environment string be (128 KiB), which is why it travels in a
 * descriptor (am-run: a memfd for a forked PE, ssh's standard input for a
 * remote one) or a file, and never in the environment or on a command
 * line.
 */
#include "config.h"

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "pr_alloc.h"
#include "am_int.h"

#define KEYS_MAGIC "am-curve-keys 1"

void am__keys_free(am__keys **pk)
{
    am__keys *k = *pk;
    if (!k)
        return;
    pr_free(k->pub);
    /* The secret does not outlive its use in freed memory. */
    memset(k->secret, 0, sizeof k->secret);
    pr_free(k);
    *pk = NULL;
}

static am__keys *keys_new(int size)
{
    am__keys *k = pr_calloc(1, sizeof *k);
    if (!k)
        return NULL;
    k->n = size;
    k->pub = pr_calloc((size_t)size, sizeof *k->pub);
    if (!k->pub) {
        pr_free(k);
        return NULL;
    }
    return k;
}

/* 1 if s is a Z85 key of 40 characters. */
static int z85_key(const char *s)
{
    uint8_t bin[32];
    return strlen(s) == 40 && zmq_z85_decode(bin, s) != NULL;
}

int am__keys_shared(const char *pub, const char *sec, int size, am__keys **out)
{
    *out = NULL;
    if (!z85_key(pub) || !z85_key(sec))
        return AM_EINVAL;
    am__keys *k = keys_new(size);
    if (!k)
        return AM_ENOMEM;
    for (int i = 0; i < size; i++)
        memcpy(k->pub[i], pub, 41);
    memcpy(k->secret, sec, 41);
    memcpy(k->public_, pub, 41);
    *out = k;
    return 0;
}

/* Reads fd until the block's "end" line, EOF, or the time limit. A pipe
 * (ssh's standard input) may deliver the block in pieces. */
static char *slurp(int fd, size_t limit, double timeout, size_t *len)
{
    size_t cap = 4096, n = 0;
    char *buf = pr_malloc(cap + 1);
    double end = am__now() + timeout;
    while (buf) {
        buf[n] = '\0';
        if (n >= 4 && (!strcmp(buf + n - 4, "end\n") &&
                       (n == 4 || buf[n - 5] == '\n')))
            break;
        if (n == cap) {
            if (cap >= limit)
                break;
            char *nb = pr_realloc(buf, (cap *= 2) + 1);
            if (!nb) {
                pr_free(buf);
                return NULL;
            }
            buf = nb;
        }
        struct pollfd pf = {fd, POLLIN, 0};
        double left = end - am__now();
        if (left <= 0 || poll(&pf, 1, (int)(left * 1000) + 1) == 0)
            break;
        ssize_t r = read(fd, buf + n, cap - n);
        if (r < 0 && errno == EINTR)
            continue;
        if (r <= 0)
            break;
        n += (size_t)r;
    }
    if (buf)
        *len = n;
    return buf;
}

/* Parses a key block. Returns 0, or a static description of the defect. */
static const char *parse(char *text, int rank, am__keys *k)
{
    char *save = NULL;
    char *line = strtok_r(text, "\n", &save);
    if (!line || strcmp(line, KEYS_MAGIC))
        return "it does not start with '" KEYS_MAGIC "'";
    int have = 0, ended = 0, secret = 0;
    while (!ended && (line = strtok_r(NULL, "\n", &save))) {
        char key[64];
        long r = -1;
        int got;
        if (!strcmp(line, "end")) {
            ended = 1;
        } else if (sscanf(line, "public %ld %63s%n", &r, key, &got) == 2 &&
                   !line[got]) {
            if (r < 0 || r >= k->n)
                return "a public key of a rank outside the job";
            if (!z85_key(key))
                return "a public key that is not 40 Z85 characters";
            if (k->pub[r][0])
                return "two public keys for one rank";
            memcpy(k->pub[r], key, 41);
            have++;
        } else if (sscanf(line, "secret %ld %63s%n", &r, key, &got) == 2 &&
                   !line[got]) {
            if (!z85_key(key))
                return "a secret key that is not 40 Z85 characters";
            if (r == rank) {
                memcpy(k->secret, key, 41);
                secret = 1;
            }
        } else if (sscanf(line, "rendezvous %63s%n", key, &got) == 1 &&
                   !line[got]) {
            if (!z85_key(key))
                return "a rendezvous key that is not 40 Z85 characters";
            memcpy(k->rdv, key, 41);
        } else {
            return "a line that is not 'public R KEY', 'secret R KEY', "
                   "'rendezvous KEY' or 'end'";
        }
    }
    if (!ended)
        return "it is cut short (no 'end' line)";
    if (have != k->n)
        return "it lacks the public key of some PE";
    if (!secret)
        return "it has no secret key for this PE";
    if (zmq_curve_public(k->public_, k->secret) != 0 ||
        strcmp(k->public_, k->pub[rank]))
        return "this PE's secret key does not belong to its public key";
    return NULL;
}

int am__keys_read(const am_ctx_t *ctx, const char *spec, int rank, int size,
                  double timeout, am__keys **out)
{
    *out = NULL;
    int fd = -1, own = 1;
    if (!strncmp(spec, "fd:", 3)) {
        char *end;
        long v = strtol(spec + 3, &end, 10);
        if (end == spec + 3 || *end || v < 0 || v > 1 << 20 ||
            fcntl((int)v, F_GETFD) < 0) {
            am__warn(ctx, "AM_CURVE_KEYS=%s: not an open descriptor", spec);
            return AM_EINVAL;
        }
        fd = (int)v;
        own = fd > 2;
    } else {
        fd = open(spec, O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
        struct stat sb;
        if (fd < 0 || fstat(fd, &sb) != 0) {
            am__warn(ctx, "cannot read the CURVE key file %s: %s", spec,
                     strerror(errno));
            if (fd >= 0)
                close(fd);
            return AM_EINVAL;
        }
        /* Like ssh with its private keys: a secret others can read is
         * no secret. */
        if (!S_ISREG(sb.st_mode) || sb.st_uid != geteuid() ||
            (sb.st_mode & 077)) {
            am__warn(ctx, "the CURVE key file %s must be a regular file of "
                          "this user that only its owner can read (mode %04o; "
                          "chmod 600 it)",
                     spec, (unsigned)(sb.st_mode & 07777));
            close(fd);
            return AM_EINVAL;
        }
    }
    size_t len = 0;
    char *text = slurp(fd, (size_t)size * 128 + 65536, timeout, &len);
    if (own)
        close(fd);
    am__keys *k = text ? keys_new(size) : NULL;
    if (!k) {
        pr_free(text);
        return AM_ENOMEM;
    }
    const char *why = parse(text, rank, k);
    memset(text, 0, len);
    pr_free(text);
    if (why) {
        am__warn(ctx, "bad CURVE keys in %s: %s", spec, why);
        am__keys_free(&k);
        return AM_EINVAL;
    }
    *out = k;
    return 0;
}

int am__keys_format(char (*pub)[41], char (*sec)[41], int n, int rank,
                    const char *rdv, char **buf, size_t *len)
{
    /* A line is at most 7 + 10 + 1 + 40 + 1 bytes. */
    size_t cap = (size_t)n * (rank < 0 ? 128 : 64) + 256;
    char *b = pr_malloc(cap);
    if (!b)
        return AM_ENOMEM;
    size_t k = (size_t)snprintf(b, cap, "%s\n", KEYS_MAGIC);
    for (int r = 0; r < n; r++)
        k += (size_t)snprintf(b + k, cap - k, "public %d %s\n", r, pub[r]);
    for (int r = 0; r < n; r++)
        if (rank < 0 || r == rank)
            k += (size_t)snprintf(b + k, cap - k, "secret %d %s\n", r, sec[r]);
    if (rdv)
        k += (size_t)snprintf(b + k, cap - k, "rendezvous %s\n", rdv);
    k += (size_t)snprintf(b + k, cap - k, "end\n");
    *buf = b;
    *len = k;
    return 0;
}
