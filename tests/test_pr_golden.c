/*
 * test_pr_golden -- pins the byte layout of every message type.
 *
 *   tests/test_pr_golden [--dir DIR]        compare with DIR/<type>.exp
 *   tests/test_pr_golden --regenerate DIR   write DIR/<type>.exp (deliberate
 *                                           layout change only)
 *   tests/test_pr_golden --write-corpus DIR write fuzz seed inputs to
 *                                           DIR/<type>/
 *
 * Each message type's fixed sample (tests/pr_sample.c) is encoded and
 * printed as an annotated hex dump, one field per line ("offset  bytes
 * name = value"), which is compared line by line with the .exp file in
 * tests/golden/proto. The field names and the way counts are followed come
 * from this file, so a dump reads as the layout in PROTOCOL.md; the bytes
 * come from the encoders. The comparison never rewrites a .exp file. On a
 * mismatch the actual dump is written to ./pr_golden_<type>.out for diff.
 * Output is TAP; exit 0 all match, 1 a mismatch, 99 harness error (a .exp
 * file missing or unreadable, bad usage).
 */
#include "config.h"

#include <errno.h>
#include <inttypes.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "pr.h"
#include "pr_sample.h"

/* ------------------------------------------------------------------ dumper */

/* Walks an encoding field by field and prints one line per field. */
typedef struct dump {
    const uint8_t *p; /* the encoding */
    size_t len;       /* its length */
    size_t off;       /* next field */
    int overrun;      /* a field ran past the end */
    FILE *out;
} dump;

enum ftype { F_U8, F_U16, F_U32, F_U64, F_X64, F_I32, F_I64, F_F64, F_GID, F_BYTES };

/* Prints the next field (size bytes, named by fmt) and returns its value as
 * an unsigned integer (0 for bytes and on overrun). */
static uint64_t field(dump *d, enum ftype t, size_t size, const char *fmt, ...)
{
    static const size_t sizes[] = {1, 2, 4, 8, 8, 4, 8, 8, 8, 0};
    if (t != F_BYTES)
        size = sizes[t];
    if (d->overrun || size > d->len - d->off) {
        d->overrun = 1;
        return 0;
    }
    const uint8_t *q = d->p + d->off;
    uint64_t u = 0;
    for (size_t i = 0; i < size && t != F_BYTES; i++)
        u |= (uint64_t)q[i] << (8 * i);

    char name[96];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(name, sizeof name, fmt, ap);
    va_end(ap);

    /* Bytes, at most 8 per line; longer fields continue on more lines. */
    for (size_t line = 0; line == 0 || line < size; line += 8) {
        fprintf(d->out, "%06zx ", d->off + line);
        size_t n = size - line < 8 ? size - line : 8;
        for (size_t i = 0; i < n; i++)
            fprintf(d->out, " %02x", q[line + i]);
        if (line > 0) { /* a continuation line has no name */
            fputc('\n', d->out);
            continue;
        }
        fprintf(d->out, "%*s  %s", (int)(3 * (8 - n)), "", name);
        switch (t) {
        case F_U8:
        case F_U16:
        case F_U32:
        case F_U64:
            fprintf(d->out, " = %" PRIu64, u);
            break;
        case F_X64:
            fprintf(d->out, " = 0x%016" PRIx64, u);
            break;
        case F_I32:
            fprintf(d->out, " = %" PRId32, (int32_t)(uint32_t)u);
            break;
        case F_I64:
            fprintf(d->out, " = %" PRId64, (int64_t)u);
            break;
        case F_F64: {
            double x;
            memcpy(&x, &u, 8);
            fprintf(d->out, " = %.17g", x);
            break;
        }
        case F_GID:
            fprintf(d->out, " = gid(rank %" PRIu32 ", seq %" PRIu64 ")",
                    pr_gid_rank(u), pr_gid_seq(u));
            break;
        case F_BYTES:
            break;
        }
        fputc('\n', d->out);
    }
    d->off += size;
    return t == F_BYTES ? 0 : u;
}

/* A wire string: its u16 length, then its bytes shown as text. */
static void str_field(dump *d, const char *name)
{
    uint64_t n = field(d, F_U16, 0, "%s.len", name);
    if (d->overrun || n > d->len - d->off) {
        d->overrun = 1;
        return;
    }
    field(d, F_BYTES, n, "%s = \"%.*s\"", name, (int)n, d->p + d->off);
}

static void dump_kind(dump *d, int kind)
{
    uint64_t n, n2;
    switch (kind) {
    case PRS_HEADER:
        field(d, F_BYTES, 4, "magic");
        field(d, F_U8, 0, "version");
        field(d, F_U8, 0, "flags");
        field(d, F_U16, 0, "handler");
        field(d, F_U32, 0, "sender");
        field(d, F_U32, 0, "payload length");
        field(d, F_X64, 0, "sequence");
        break;
    case PRS_HELLO:
        field(d, F_U8, 0, "type (hello)");
        field(d, F_U8, 0, "version");
        field(d, F_U8, 0, "version min");
        field(d, F_U8, 0, "version max");
        field(d, F_X64, 0, "job");
        field(d, F_U32, 0, "rank");
        field(d, F_U32, 0, "size");
        break;
    case PRS_STATS:
        field(d, F_U8, 0, "type (stats)");
        field(d, F_U8, 0, "format");
        field(d, F_U32, 0, "rank");
        n = field(d, F_U32, 0, "count");
        for (uint64_t i = 0; i < n && !d->overrun; i++) {
            char name[32];
            snprintf(name, sizeof name, "stat[%" PRIu64 "].name", i);
            str_field(d, name);
            uint64_t t = field(d, F_U8, 0, "stat[%" PRIu64 "].type", i);
            field(d, t == PR_STAT_F64 ? F_F64 : t == PR_STAT_I64 ? F_I64 : F_U64,
                  0, "stat[%" PRIu64 "].value", i);
        }
        break;
    case PRS_SUBMESH:
        field(d, F_U8, 0, "type (submesh)");
        field(d, F_U32, 0, "part");
        field(d, F_U32, 0, "rank");
        field(d, F_U32, 0, "size");
        field(d, F_U32, 0, "n_facets");
        n = field(d, F_U32, 0, "vertex count");
        for (uint64_t i = 0; i < n && !d->overrun; i++)
            field(d, F_GID, 0, "gid[%" PRIu64 "]", i);
        for (uint64_t i = 0; i < n && !d->overrun; i++)
            for (int k = 0; k < 3; k++)
                field(d, F_F64, 0, "xyz[%" PRIu64 "].%c", i, "xyz"[k]);
        for (uint64_t i = 0; i < n && !d->overrun; i++)
            field(d, F_U32, 0, "vflags[%" PRIu64 "]", i);
        n = field(d, F_U32, 0, "tetrahedron count");
        for (uint64_t i = 0; i < n && !d->overrun; i++)
            for (int k = 0; k < 4; k++)
                field(d, F_U32, 0, "tet[%" PRIu64 "].v[%d]", i, k);
        for (uint64_t i = 0; i < n && !d->overrun; i++)
            for (int k = 0; k < 4; k++)
                field(d, F_I32, 0, "tet[%" PRIu64 "].marker[%d]", i, k);
        for (uint64_t i = 0; i < n && !d->overrun; i++)
            field(d, F_U8, 0, "tet[%" PRIu64 "].subseg", i);
        n2 = field(d, F_U32, 0, "interface face count");
        for (uint64_t i = 0; i < n2 && !d->overrun; i++)
            field(d, F_U32, 0, "iface[%" PRIu64 "].face (4 * tet + i)", i);
        for (uint64_t i = 0; i < n2 && !d->overrun; i++)
            field(d, F_U32, 0, "iface[%" PRIu64 "].remote", i);
        break;
    case PRS_VERTEX:
        field(d, F_GID, 0, "gid");
        field(d, F_F64, 0, "x");
        field(d, F_F64, 0, "y");
        field(d, F_F64, 0, "z");
        field(d, F_U32, 0, "flags");
        break;
    case PRS_TET:
        for (int k = 0; k < 4; k++)
            field(d, F_GID, 0, "v[%d]", k);
        for (int k = 0; k < 4; k++)
            field(d, F_I32, 0, "face_marker[%d]", k);
        field(d, F_U8, 0, "subseg");
        field(d, F_U32, 0, "owner");
        break;
    case PRS_FACE_KEYS:
        n = field(d, F_U32, 0, "count");
        for (uint64_t i = 0; i < n && !d->overrun; i++)
            for (int k = 0; k < 3; k++)
                field(d, F_GID, 0, "key[%" PRIu64 "].gid[%d]", i, k);
        break;
    }
}

/* The golden text of kind in a malloc'd string, or NULL after printing why
 * (as a TAP diagnostic) when the sample cannot be encoded or dumped. */
static char *golden_text(int kind)
{
    pr_buf b = PR_BUF_INIT;
    int rc = prs_fixed(kind, &b);
    if (rc) {
        printf("# %s: encoding the sample failed: %s\n", prs_name(kind),
               pr_strerror(rc));
        pr_buf_free(&b);
        return NULL;
    }
    char *text = NULL;
    size_t size = 0;
    FILE *out = open_memstream(&text, &size);
    if (!out) {
        pr_buf_free(&b);
        return NULL;
    }
    fprintf(out,
            "# pdr wire protocol %d: golden encoding of '%s' (see "
            "proto/PROTOCOL.md)\n"
            "# written by: tests/test_pr_golden --regenerate "
            "tests/golden/proto\n"
            "# offset bytes                     field = value\n",
            PR_VERSION, prs_name(kind));
    dump d = {b.data, b.len, 0, 0, out};
    dump_kind(&d, kind);
    if (d.overrun || d.off != d.len)
        fprintf(out, "!! layout description covers %zu of %zu bytes%s\n",
                d.off, d.len, d.overrun ? " (runs past the end)" : "");
    fclose(out);
    pr_buf_free(&b);
    return text;
}

/* ------------------------------------------------------------------- files */

static char *read_file(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    size_t cap = 4096, len = 0;
    char *s = malloc(cap);
    while (s) {
        len += fread(s + len, 1, cap - 1 - len, f);
        if (len < cap - 1)
            break;
        char *t = realloc(s, cap *= 2);
        if (!t) {
            free(s);
            s = NULL;
        } else {
            s = t;
        }
    }
    if (s)
        s[len] = '\0';
    if (ferror(f)) {
        free(s);
        s = NULL;
    }
    fclose(f);
    return s;
}

static int write_file(const char *path, const void *data, size_t len)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return -1;
    int ok = fwrite(data, 1, len, f) == len;
    ok &= fclose(f) == 0;
    return ok ? 0 : -1;
}

/* Copies line number 'line' (1-based) of s into out. */
static void nth_line(const char *s, int line, char *out, size_t size)
{
    for (int i = 1; i < line && s; i++) {
        s = strchr(s, '\n');
        if (s)
            s++;
    }
    if (!s || !*s) {
        snprintf(out, size, "(end of file)");
        return;
    }
    size_t n = strcspn(s, "\n");
    snprintf(out, size, "%.*s", (int)n, s);
}

/* First line where a and b differ (1-based). */
static int first_difference(const char *a, const char *b)
{
    int line = 1;
    while (*a && *a == *b) {
        if (*a == '\n')
            line++;
        a++, b++;
    }
    return line;
}

/* ------------------------------------------------------------------ modes */

static int compare_all(const char *dir)
{
    int failed = 0;
    printf("1..%d\n", PRS_NKINDS);
    for (int k = 0; k < PRS_NKINDS; k++) {
        char path[4096];
        snprintf(path, sizeof path, "%s/%s.exp", dir, prs_name(k));
        char *expect = read_file(path);
        if (!expect) {
            printf("Bail out! cannot read %s: %s\n", path, strerror(errno));
            return 99;
        }
        char *actual = golden_text(k);
        if (!actual) {
            printf("not ok %d - %s: no encoding to compare\n", k + 1, prs_name(k));
            failed = 1;
        } else if (strcmp(expect, actual)) {
            int line = first_difference(expect, actual);
            char e[200], a[200], out[64];
            nth_line(expect, line, e, sizeof e);
            nth_line(actual, line, a, sizeof a);
            snprintf(out, sizeof out, "pr_golden_%s.out", prs_name(k));
            int saved = write_file(out, actual, strlen(actual)) == 0;
            printf("not ok %d - %s: encoding differs from %s at line %d\n",
                   k + 1, prs_name(k), path, line);
            printf("#   expected: %s\n#   actual:   %s\n", e, a);
            if (saved)
                printf("#   whole dump: diff -u %s %s\n", path, out);
            printf("#   if the layout change is deliberate, update "
                   "PROTOCOL.md and run: tests/test_pr_golden --regenerate "
                   "DIR\n");
            failed = 1;
        } else {
            printf("ok %d - %s matches %s\n", k + 1, prs_name(k), path);
        }
        free(expect);
        free(actual);
    }
    return failed;
}

static int regenerate(const char *dir)
{
    for (int k = 0; k < PRS_NKINDS; k++) {
        char path[4096];
        snprintf(path, sizeof path, "%s/%s.exp", dir, prs_name(k));
        char *text = golden_text(k);
        if (!text || strstr(text, "\n!! ")) {
            fprintf(stderr, "test_pr_golden: %s: the sample cannot be dumped\n",
                    prs_name(k));
            free(text);
            return 99;
        }
        if (write_file(path, text, strlen(text))) {
            fprintf(stderr, "test_pr_golden: cannot write %s: %s\n", path,
                    strerror(errno));
            free(text);
            return 99;
        }
        printf("wrote %s\n", path);
        free(text);
    }
    return 0;
}

/* Seeds for the fuzzers and the regression corpus: each valid sample, a
 * few random valid messages, every fourth truncation, and single-byte
 * corruptions of the fields most likely to matter (counts, tags). */
static int write_corpus(const char *dir)
{
    prs_rng rng = {12345};
    for (int k = 0; k < PRS_NKINDS; k++) {
        char sub[4096], path[4200];
        snprintf(sub, sizeof sub, "%s/%s", dir, prs_name(k));
        if (mkdir(sub, 0777) && errno != EEXIST) {
            fprintf(stderr, "test_pr_golden: cannot create %s: %s\n", sub,
                    strerror(errno));
            return 99;
        }
        pr_buf samples[4] = {PR_BUF_INIT, PR_BUF_INIT, PR_BUF_INIT, PR_BUF_INIT};
        prs_fixed(k, &samples[0]);
        for (int s = 1; s < 4; s++) {
            pr_submesh sm;
            pr_stats st;
            pr_hello h;
            pr_vertex v;
            pr_tet t;
            pr_face_key *keys;
            uint32_t n;
            pr_header hd = {.flags = (uint8_t)(s & 1),
                            .handler = (uint16_t)prs_next(&rng),
                            .sender = (uint32_t)prs_next(&rng),
                            .payload_len = (uint32_t)prs_below(&rng, PR_MAX_PAYLOAD),
                            .seq = prs_next(&rng)};
            switch (k) {
            case PRS_HEADER:
                pr_header_put(&samples[s], &hd);
                break;
            case PRS_HELLO:
                prs_random_hello(&rng, &h);
                pr_hello_put(&samples[s], &h);
                break;
            case PRS_STATS:
                prs_random_stats(&rng, &st);
                pr_stats_put(&samples[s], &st);
                pr_stats_clear(&st);
                break;
            case PRS_SUBMESH:
                prs_random_submesh(&rng, &sm);
                pr_submesh_put(&samples[s], &sm);
                prs_submesh_free(&sm);
                break;
            case PRS_VERTEX:
                prs_random_vertex(&rng, &v);
                pr_vertex_put(&samples[s], &v);
                break;
            case PRS_TET:
                prs_random_tet(&rng, &t);
                pr_tet_put(&samples[s], &t);
                break;
            default:
                prs_random_face_keys(&rng, &keys, &n);
                pr_face_keys_put(&samples[s], keys, n);
                free(keys);
                break;
            }
        }
        int rc = 0;
        for (int s = 0; s < 4 && !rc; s++) {
            const pr_buf *b = &samples[s];
            if (b->err) {
                fprintf(stderr, "test_pr_golden: %s sample %d: %s\n",
                        prs_name(k), s, pr_strerror(b->err));
                rc = 99;
                break;
            }
            snprintf(path, sizeof path, "%s/valid-%d", sub, s);
            rc |= write_file(path, b->data, b->len);
            if (s > 0)
                continue;
            for (size_t cut = 0; cut < b->len; cut += 4) {
                snprintf(path, sizeof path, "%s/trunc-%zu", sub, cut);
                rc |= write_file(path, b->data, cut);
            }
            uint8_t *c = malloc(b->len + 1);
            if (!c)
                return 99;
            for (size_t at = 0; at < b->len && at < 64; at += 3) {
                memcpy(c, b->data, b->len);
                c[at] ^= 0xff;
                snprintf(path, sizeof path, "%s/flip-%zu", sub, at);
                rc |= write_file(path, c, b->len);
            }
            memcpy(c, b->data, b->len);
            c[b->len] = 0;
            /* A payload may follow a frame header; any other message
             * with a byte too many is refused. */
            snprintf(path, sizeof path, "%s/%s", sub,
                     k == PRS_HEADER ? "valid-with-payload" : "trailing");
            rc |= write_file(path, c, b->len + 1);
            free(c);
        }
        for (int s = 0; s < 4; s++)
            pr_buf_free(&samples[s]);
        if (rc) {
            fprintf(stderr, "test_pr_golden: cannot write into %s\n", sub);
            return 99;
        }
        printf("wrote %s\n", sub);
    }
    return 0;
}

int main(int argc, char **argv)
{
    if (argc == 3 && !strcmp(argv[1], "--regenerate"))
        return regenerate(argv[2]);
    if (argc == 3 && !strcmp(argv[1], "--write-corpus"))
        return write_corpus(argv[2]);
    if (argc == 3 && !strcmp(argv[1], "--dir"))
        return compare_all(argv[2]);
    if (argc == 1) {
        const char *top = getenv("top_srcdir");
        char dir[4096];
        snprintf(dir, sizeof dir, "%s/tests/golden/proto", top ? top : ".");
        return compare_all(dir);
    }
    fprintf(stderr,
            "usage: %s [--dir DIR | --regenerate DIR | --write-corpus DIR]\n",
            argv[0]);
    return 99;
}
