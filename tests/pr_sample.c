/* pr_sample.c -- sample messages and the per-decoder check (see
 * pr_sample.h). */
#include "config.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pr_sample.h"

static const char *const kind_names[PRS_NKINDS] = {
    "header", "hello", "stats", "submesh", "vertex", "tet", "face_keys",
};

const char *prs_name(int kind)
{
    return kind >= 0 && kind < PRS_NKINDS ? kind_names[kind] : "?";
}

int prs_kind(const char *name)
{
    for (int k = 0; k < PRS_NKINDS; k++)
        if (!strcmp(name, kind_names[k]))
            return k;
    return -1;
}

/* ------------------------------------------------------------ fixed values */

#define G(rank, seq) pr_gid_make(rank, seq)

static int fixed_submesh(pr_buf *b)
{
    /* Two tetrahedra sharing the face {1, 2, 3} (face 0 of tetrahedron 0,
     * face 3 of tetrahedron 1); two faces of tetrahedron 1 border ranks 0
     * and 2. */
    uint64_t gid[5] = {G(0, 1), G(0, 2), G(0, 5), G(1, 0), G(2, 3)};
    double xyz[15] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1};
    uint32_t vflags[5] = {0, 1, 0, 2, 0};
    uint32_t tv[8] = {0, 1, 2, 3, 1, 2, 3, 4};
    int32_t marker[8] = {-1, 0, 1, 2, 3, -1, -1, -1};
    uint8_t subseg[2] = {0x07, 0x00};
    uint32_t face[2] = {4 * 1 + 1, 4 * 1 + 2};
    uint32_t remote[2] = {0, 2};
    pr_submesh sm = {.part = 1,
                     .rank = 1,
                     .size = 3,
                     .n_facets = 4,
                     .vert = {5, gid, xyz, vflags},
                     .tet = {2, tv, marker, subseg},
                     .iface = {2, face, remote}};
    return pr_submesh_put(b, &sm);
}

static int fixed_stats(pr_buf *b)
{
    pr_stats s = PR_STATS_INIT;
    s.rank = 3;
    int rc = pr_stats_add_u64(&s, "cavities.completed", 1234);
    if (!rc)
        rc = pr_stats_add_f64(&s, "time.execution", 12.5);
    if (!rc)
        rc = pr_stats_add_i64(&s, "balance", -42);
    if (!rc)
        rc = pr_stats_add_f64(&s, "latency.\xc2\xb5s", 0.25); /* µs */
    if (!rc)
        rc = pr_stats_put(b, &s);
    pr_stats_clear(&s);
    return rc;
}

int prs_fixed(int kind, pr_buf *b)
{
    switch (kind) {
    case PRS_HEADER: {
        pr_header h = {.flags = PR_FLAG_CONTROL,
                       .handler = 0x0102,
                       .sender = 3,
                       .payload_len = 19,
                       .seq = UINT64_C(0x0001020304050607)};
        return pr_header_put(b, &h);
    }
    case PRS_HELLO: {
        pr_hello h;
        pr_hello_init(&h, UINT64_C(0x1122334455667788), 2, 4);
        return pr_hello_put(b, &h);
    }
    case PRS_STATS:
        return fixed_stats(b);
    case PRS_SUBMESH:
        return fixed_submesh(b);
    case PRS_VERTEX: {
        pr_vertex v = {G(2, 5), {0.5, -2.25, 1e308}, 0x80000001u};
        return pr_vertex_put(b, &v);
    }
    case PRS_TET: {
        pr_tet t = {{G(0, 1), G(0, 7), G(1, 3), G(2, 4)},
                    {-1, 0, 5, -1},
                    0x21,
                    1};
        return pr_tet_put(b, &t);
    }
    case PRS_FACE_KEYS: {
        pr_face_key k[2];
        if (pr_face_key_make(&k[0], G(1, 1), G(0, 1), G(0, 2)) ||
            pr_face_key_make(&k[1], G(2, 9), G(0, 3), G(2, 0)))
            return PR_EINVAL;
        return pr_face_keys_put(b, k, 2);
    }
    }
    return PR_EINVAL;
}

/* ------------------------------------------------------ decode and check */

static int report(int kind, const char *what)
{
    fprintf(stderr, "prs_check(%s): accepted input, but %s\n",
            prs_name(kind), what);
    return 1;
}

/* 0 if b holds exactly data[0..len), else 1 (after saying so). */
static int same_bytes(int kind, const pr_buf *b, const uint8_t *data,
                      size_t len)
{
    if (b->err)
        return report(kind, "re-encoding the decoded value failed");
    if (b->len != len || (len && memcmp(b->data, data, len)))
        return report(kind, "re-encoding gives other bytes (not canonical)");
    return 0;
}

static int check_header(const uint8_t *data, size_t len)
{
    pr_header h, any;
    uint8_t version;
    int rc = pr_header_decode(&h, data, len);
    int rc_any = pr_header_decode_any(&any, data, len, &version);
    if (rc)
        return rc;
    if (rc_any || version != PR_VERSION || memcmp(&h, &any, sizeof h))
        return report(PRS_HEADER, "pr_header_decode_any disagrees");
    pr_buf b = PR_BUF_INIT;
    pr_header_put(&b, &h);
    int bad = same_bytes(PRS_HEADER, &b, data, PR_HEADER_SIZE);
    pr_buf_free(&b);
    return bad;
}

static int check_hello(const uint8_t *data, size_t len)
{
    pr_hello h;
    int rc = pr_hello_decode(&h, data, len);
    if (rc)
        return rc;
    pr_buf b = PR_BUF_INIT;
    pr_hello_put(&b, &h);
    int bad = same_bytes(PRS_HELLO, &b, data, len);
    pr_buf_free(&b);
    /* Negotiating with the peer must give an answer and, on refusal, an
     * explanation. */
    pr_hello local;
    pr_hello_init(&local, h.job, (h.rank + 1) % h.size, h.size);
    uint8_t version;
    char msg[256];
    rc = pr_negotiate(&local, &h, &version, msg, sizeof msg);
    if (rc == 0 && (version < PR_VERSION_MIN || version > PR_VERSION_MAX))
        bad |= report(PRS_HELLO, "negotiation chose a version not spoken");
    if (rc != 0 && msg[0] == '\0')
        bad |= report(PRS_HELLO, "negotiation refused without a message");
    return bad;
}

static int check_stats(const uint8_t *data, size_t len)
{
    pr_stats s = PR_STATS_INIT;
    int rc = pr_stats_decode(&s, data, len);
    if (rc) {
        if (s.n || s.item)
            return report(PRS_STATS, "a refused blob left items behind");
        return rc;
    }
    pr_buf b = PR_BUF_INIT;
    pr_stats_put(&b, &s);
    int bad = same_bytes(PRS_STATS, &b, data, len);
    pr_buf_free(&b);
    for (uint32_t i = 0; i < s.n && !bad; i++)
        if (pr_stats_find(&s, s.item[i].name) != &s.item[i])
            bad = report(PRS_STATS, "pr_stats_find misses a value");
    /* Merging a blob into an empty one copies it. */
    pr_stats acc = PR_STATS_INIT;
    acc.rank = s.rank;
    if (!bad && (pr_stats_merge(&acc, &s) || !prs_stats_equal(&acc, &s)))
        bad = report(PRS_STATS, "merging into an empty blob changes it");
    pr_stats_clear(&acc);
    pr_stats_clear(&s);
    return bad;
}

static int check_submesh(const uint8_t *data, size_t len)
{
    pr_submesh *sm;
    int rc = pr_submesh_decode(data, len, &sm);
    if (rc) {
        if (sm)
            return report(PRS_SUBMESH, "a refused submesh was returned");
        return rc;
    }
    pr_buf b = PR_BUF_INIT;
    pr_submesh_put(&b, sm);
    int bad = same_bytes(PRS_SUBMESH, &b, data, len);
    for (uint32_t i = 0; i < sm->vert.n && !bad; i++)
        if (pr_vtable_find(&sm->vert, sm->vert.gid[i]) != (int64_t)i)
            bad = report(PRS_SUBMESH, "pr_vtable_find misses a vertex");
    /* Every tetrahedron and interface face converts to a valid entity. */
    for (uint32_t i = 0; i < sm->tet.n && !bad; i++) {
        pr_tet t;
        pr_submesh_tet(sm, i, &t);
        pr_buf_reset(&b);
        if (pr_tet_put(&b, &t) || t.owner != sm->rank)
            bad = report(PRS_SUBMESH, "a tetrahedron is not a valid pr_tet");
    }
    for (uint32_t j = 0; j < sm->iface.n && !bad; j++) {
        pr_face_key k;
        pr_submesh_iface_key(sm, j, &k);
        pr_buf_reset(&b);
        if (pr_face_key_put(&b, &k))
            bad = report(PRS_SUBMESH, "an interface face has no valid key");
    }
    pr_buf_free(&b);
    pr_submesh_free(&sm);
    return bad;
}

/* The entity records are checked as a message made of one record (or one
 * list) and nothing else. */
static int check_entity(int kind, const uint8_t *data, size_t len)
{
    pr_reader r;
    pr_buf b = PR_BUF_INIT;
    pr_vertex v;
    pr_tet t;
    pr_face_key *keys = NULL;
    uint32_t n = 0;
    pr_reader_init(&r, data, len);
    switch (kind) {
    case PRS_VERTEX:
        if (!pr_vertex_get(&r, &v) && !pr_reader_finish(&r))
            pr_vertex_put(&b, &v);
        break;
    case PRS_TET:
        if (!pr_tet_get(&r, &t) && !pr_reader_finish(&r))
            pr_tet_put(&b, &t);
        break;
    default:
        if (!pr_face_keys_get(&r, &keys, &n) && !pr_reader_finish(&r))
            pr_face_keys_put(&b, keys, n);
        break;
    }
    free(keys);
    int rc = pr_reader_finish(&r);
    int bad = rc ? rc : same_bytes(kind, &b, data, len);
    pr_buf_free(&b);
    return bad;
}

int prs_check(int kind, const uint8_t *data, size_t len)
{
    switch (kind) {
    case PRS_HEADER:
        return check_header(data, len);
    case PRS_HELLO:
        return check_hello(data, len);
    case PRS_STATS:
        return check_stats(data, len);
    case PRS_SUBMESH:
        return check_submesh(data, len);
    case PRS_VERTEX:
    case PRS_TET:
    case PRS_FACE_KEYS:
        return check_entity(kind, data, len);
    }
    return report(kind, "no such decoder");
}

/* --------------------------------------------------------- random values */

uint64_t prs_next(prs_rng *r)
{
    uint64_t z = (r->s += UINT64_C(0x9E3779B97F4A7C15));
    z = (z ^ (z >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94D049BB133111EB);
    return z ^ (z >> 31);
}

uint64_t prs_below(prs_rng *r, uint64_t n)
{
    return prs_next(r) % n; /* the bias is irrelevant for tests */
}

/* Any finite double, from every part of the range: zeros of both signs,
 * subnormals, huge values, and ordinary ones. */
static double random_finite(prs_rng *r)
{
    uint64_t u = prs_next(r);
    switch (prs_below(r, 4)) {
    case 0:
        return (double)(int64_t)prs_below(r, 2001) / 8 - 125; /* plain */
    case 1:
        u &= UINT64_C(0x800fffffffffffff); /* zero or subnormal */
        break;
    default:
        break;
    }
    if (!((u & UINT64_C(0x7ff0000000000000)) ^ UINT64_C(0x7ff0000000000000)))
        u &= ~UINT64_C(0x4000000000000000); /* not inf or NaN */
    double d;
    memcpy(&d, &u, 8);
    return d;
}

static uint64_t random_gid(prs_rng *r, uint32_t nranks)
{
    return pr_gid_make((uint32_t)prs_below(r, nranks),
                       prs_below(r, PR_GID_SEQ_MAX + 1));
}

void prs_random_hello(prs_rng *r, pr_hello *h)
{
    h->version_min = (uint8_t)(1 + prs_below(r, 200));
    h->version_max = (uint8_t)(h->version_min + prs_below(r, 256u - h->version_min));
    h->version = (uint8_t)(h->version_min +
                           prs_below(r, (uint64_t)h->version_max - h->version_min + 1));
    h->job = prs_next(r);
    h->size = (uint32_t)(1 + prs_below(r, prs_below(r, 2) ? 64 : UINT32_MAX));
    h->rank = (uint32_t)prs_below(r, h->size);
}

/* A random wire string of 1..PR_STAT_NAME_MAX bytes, from ASCII and a few
 * multi-byte characters. */
static void random_name(prs_rng *r, char *out)
{
    static const char *const pieces[] = {
        "a", "b", "z", "time", ".", "_", "-", "0", "9", " ", "~",
        "\xc3\xa9",         /* é */
        "\xc2\xb5",         /* µ */
        "\xe2\x86\x92",     /* → */
        "\xf0\x9f\x98\x80", /* U+1F600 */
    };
    size_t want = 1 + prs_below(r, PR_STAT_NAME_MAX), len = 0;
    while (len < want) {
        const char *p = pieces[prs_below(r, sizeof pieces / sizeof *pieces)];
        size_t n = strlen(p);
        if (len + n > PR_STAT_NAME_MAX)
            break;
        memcpy(out + len, p, n);
        len += n;
    }
    if (len == 0)
        out[len++] = 'x';
    out[len] = '\0';
}

void prs_random_stats(prs_rng *r, pr_stats *s)
{
    *s = (pr_stats)PR_STATS_INIT;
    s->rank = (uint32_t)prs_next(r);
    uint32_t want = (uint32_t)prs_below(r, 40);
    for (uint32_t i = 0; i < want; i++) {
        char name[PR_STAT_NAME_MAX + 1];
        random_name(r, name);
        uint64_t u = prs_next(r);
        double d;
        memcpy(&d, &u, 8); /* any bits, NaN included: a blob carries them */
        switch (prs_below(r, 3)) {
        case 0:
            pr_stats_add_f64(s, name, d); /* a duplicate name is refused */
            break;
        case 1:
            pr_stats_add_i64(s, name, (int64_t)u);
            break;
        default:
            pr_stats_add_u64(s, name, u);
            break;
        }
    }
}

void prs_submesh_free(pr_submesh *sm)
{
    free(sm->vert.gid);
    free(sm->vert.xyz);
    free(sm->vert.flags);
    free(sm->tet.v);
    free(sm->tet.marker);
    free(sm->tet.subseg);
    free(sm->iface.face);
    free(sm->iface.remote);
    *sm = (pr_submesh){0};
}

/* malloc that never returns NULL for a test (exit 99: harness error). */
static void *xcalloc(size_t n, size_t size)
{
    void *p = calloc(n ? n : 1, size);
    if (!p) {
        fprintf(stderr, "pr_sample: out of memory\n");
        exit(99);
    }
    return p;
}

void prs_random_submesh(prs_rng *r, pr_submesh *sm)
{
    *sm = (pr_submesh){0};
    sm->part = (uint32_t)prs_next(r);
    sm->size = (uint32_t)(1 + prs_below(r, prs_below(r, 2) ? 8 : 1u << 20));
    sm->rank = (uint32_t)prs_below(r, sm->size);
    sm->n_facets = prs_below(r, 4) ? (uint32_t)prs_below(r, 100) : PR_FACETS_ANY;

    uint32_t nv = (uint32_t)prs_below(r, 60);
    sm->vert.n = nv;
    sm->vert.gid = xcalloc(nv, 8);
    sm->vert.xyz = xcalloc(3 * (size_t)nv, 8);
    sm->vert.flags = xcalloc(nv, 4);
    /* Ascending gids: ranks < size, counters with random gaps. */
    uint64_t g = pr_gid_make((uint32_t)prs_below(r, sm->size), prs_below(r, 100));
    for (uint32_t i = 0; i < nv; i++) {
        sm->vert.gid[i] = g;
        if (prs_below(r, 8) == 0 && pr_gid_rank(g) + 1 < sm->size)
            g = pr_gid_make(pr_gid_rank(g) + 1, prs_below(r, 3));
        else /* at most 60 steps of 1e6 from a small start: no overflow */
            g += 1 + prs_below(r, prs_below(r, 2) ? 3 : 1000000);
    }
    for (size_t i = 0; i < 3 * (size_t)nv; i++)
        sm->vert.xyz[i] = random_finite(r);
    for (uint32_t i = 0; i < nv; i++)
        sm->vert.flags[i] = (uint32_t)prs_next(r);

    uint32_t nt = nv >= 4 ? (uint32_t)prs_below(r, 80) : 0;
    sm->tet.n = nt;
    sm->tet.v = xcalloc(4 * (size_t)nt, 4);
    sm->tet.marker = xcalloc(4 * (size_t)nt, 4);
    sm->tet.subseg = xcalloc(nt, 1);
    for (uint32_t t = 0; t < nt; t++) {
        uint32_t *v = sm->tet.v + 4 * (size_t)t;
        for (int k = 0; k < 4; k++) {
            int again;
            do { /* four distinct vertices */
                v[k] = (uint32_t)prs_below(r, nv);
                again = 0;
                for (int j = 0; j < k; j++)
                    again |= v[j] == v[k];
            } while (again);
            int32_t m = -1;
            if (sm->n_facets == PR_FACETS_ANY)
                m = prs_below(r, 2) ? (int32_t)(prs_next(r) >> 33) : -1;
            else if (sm->n_facets && prs_below(r, 2))
                m = (int32_t)prs_below(r, sm->n_facets);
            sm->tet.marker[4 * (size_t)t + k] = m;
        }
        sm->tet.subseg[t] = (uint8_t)(prs_next(r) & PR_SUBSEG_MASK);
    }

    uint32_t nf = 0;
    sm->iface.face = xcalloc(4 * (size_t)nt, 4);
    sm->iface.remote = xcalloc(4 * (size_t)nt, 4);
    if (sm->size > 1) {
        uint64_t keep = prs_below(r, 4); /* density of interface faces */
        for (uint32_t f = 0; f < 4 * nt; f++) {
            if (prs_below(r, 4) >= keep)
                continue;
            uint32_t other = (uint32_t)prs_below(r, sm->size - 1);
            sm->iface.face[nf] = f;
            sm->iface.remote[nf++] = other >= sm->rank ? other + 1 : other;
        }
    }
    sm->iface.n = nf;
}

void prs_random_vertex(prs_rng *r, pr_vertex *v)
{
    v->gid = random_gid(r, PR_GID_RANK_MAX + 1);
    for (int k = 0; k < 3; k++)
        v->xyz[k] = random_finite(r);
    v->flags = (uint32_t)prs_next(r);
}

void prs_random_tet(prs_rng *r, pr_tet *t)
{
    for (int k = 0; k < 4; k++) {
        int again;
        do {
            t->v[k] = random_gid(r, prs_below(r, 2) ? 2 : PR_GID_RANK_MAX + 1);
            again = 0;
            for (int j = 0; j < k; j++)
                again |= t->v[j] == t->v[k];
        } while (again);
        t->face_marker[k] =
            prs_below(r, 2) ? -1 : (int32_t)(prs_next(r) >> (33 + prs_below(r, 30)));
    }
    t->subseg = (uint8_t)(prs_next(r) & PR_SUBSEG_MASK);
    t->owner = (uint32_t)prs_next(r);
}

void prs_random_face_keys(prs_rng *r, pr_face_key **keys, uint32_t *n)
{
    *n = (uint32_t)prs_below(r, 30);
    *keys = xcalloc(*n, sizeof **keys);
    for (uint32_t i = 0; i < *n; i++) {
        uint64_t a, b, c;
        do {
            a = random_gid(r, 4);
            b = random_gid(r, 4);
            c = prs_below(r, 2) ? a + 1 + prs_below(r, 3) : random_gid(r, 4);
        } while (pr_face_key_make(&(*keys)[i], a, b, c));
    }
}

/* -------------------------------------------------------------- grid mesh */

int prs_grid_submesh(uint32_t nx, uint32_t ny, uint32_t nz, pr_submesh *sm)
{
    *sm = (pr_submesh){.part = 0, .rank = 0, .size = 2, .n_facets = 5};
    uint32_t px = nx + 1, py = ny + 1, pz = nz + 1;
    uint32_t nv = px * py * pz, nt = 6 * nx * ny * nz;
    sm->vert.gid = malloc((size_t)nv * 8);
    sm->vert.xyz = malloc((size_t)nv * 24);
    sm->vert.flags = malloc((size_t)nv * 4);
    sm->tet.v = malloc((size_t)nt * 16);
    sm->tet.marker = malloc((size_t)nt * 16);
    sm->tet.subseg = malloc(nt);
    sm->iface.face = malloc((size_t)nt * 16);
    sm->iface.remote = malloc((size_t)nt * 16);
    if (!sm->vert.gid || !sm->vert.xyz || !sm->vert.flags || !sm->tet.v ||
        !sm->tet.marker || !sm->tet.subseg || !sm->iface.face ||
        !sm->iface.remote) {
        prs_submesh_free(sm);
        return PR_ENOMEM;
    }
    sm->vert.n = nv;
    sm->tet.n = nt;

    /* side[v]: bit s set if vertex v lies on side s of the box, sides
     * x=0, y=0, y=ny, z=0, z=nz (facets 0..4) and x=nx (bit 5, shared
     * with rank 1). */
    uint8_t *side = malloc(nv);
    if (!side) {
        prs_submesh_free(sm);
        return PR_ENOMEM;
    }
    for (uint32_t k = 0; k < pz; k++)
        for (uint32_t j = 0; j < py; j++)
            for (uint32_t i = 0; i < px; i++) {
                uint32_t v = i + px * (j + py * k);
                sm->vert.gid[v] = pr_gid_make(0, v);
                sm->vert.xyz[3 * (size_t)v] = i * 0.125;
                sm->vert.xyz[3 * (size_t)v + 1] = j * 0.125;
                sm->vert.xyz[3 * (size_t)v + 2] = k * 0.125;
                side[v] = (uint8_t)((i == 0) | (j == 0) << 1 | (j == ny) << 2 |
                                    (k == 0) << 3 | (k == nz) << 4 |
                                    (i == nx) << 5);
                sm->vert.flags[v] = side[v] != 0;
            }

    /* The six tetrahedra of a cube around its diagonal (0,0,0)-(1,1,1):
     * one per order in which the path along the edges takes the axes. */
    static const int order[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2},
                                    {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    static const int edge[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
    uint32_t step[3] = {1, px, px * py};
    uint32_t t = 0, nf = 0;
    for (uint32_t k = 0; k < nz; k++)
        for (uint32_t j = 0; j < ny; j++)
            for (uint32_t i = 0; i < nx; i++)
                for (int o = 0; o < 6; o++, t++) {
                    uint32_t *v = sm->tet.v + 4 * (size_t)t;
                    v[0] = i + px * (j + py * k);
                    for (int s = 0; s < 3; s++)
                        v[s + 1] = v[s] + step[order[o][s]];
                    for (int f = 0; f < 4; f++) {
                        uint8_t common = 0x3f;
                        for (int c = 0; c < 4; c++)
                            if (c != f)
                                common &= side[v[c]];
                        int32_t m = -1;
                        for (int s = 0; s < 5 && m < 0; s++)
                            if (common & (1u << s))
                                m = s;
                        sm->tet.marker[4 * (size_t)t + f] = m;
                        if (common & 0x20) {
                            sm->iface.face[nf] = 4 * t + (uint32_t)f;
                            sm->iface.remote[nf++] = 1;
                        }
                    }
                    uint8_t mask = 0;
                    for (int e = 0; e < 6; e++) {
                        uint8_t c = side[v[edge[e][0]]] & side[v[edge[e][1]]];
                        if (c & (c - 1)) /* on two sides: a box edge */
                            mask |= (uint8_t)(1u << e);
                    }
                    sm->tet.subseg[t] = mask;
                }
    sm->iface.n = nf;
    free(side);
    return 0;
}

/* ---------------------------------------------------------------- equality */

static int same(const void *a, const void *b, size_t n)
{
    return n == 0 || memcmp(a, b, n) == 0;
}

int prs_submesh_equal(const pr_submesh *a, const pr_submesh *b)
{
    size_t nv = a->vert.n, nt = a->tet.n, nf = a->iface.n;
    return a->part == b->part && a->rank == b->rank && a->size == b->size &&
           a->n_facets == b->n_facets && nv == b->vert.n &&
           nt == b->tet.n && nf == b->iface.n &&
           same(a->vert.gid, b->vert.gid, 8 * nv) &&
           same(a->vert.xyz, b->vert.xyz, 24 * nv) && /* bitwise: -0.0 */
           same(a->vert.flags, b->vert.flags, 4 * nv) &&
           same(a->tet.v, b->tet.v, 16 * nt) &&
           same(a->tet.marker, b->tet.marker, 16 * nt) &&
           same(a->tet.subseg, b->tet.subseg, nt) &&
           same(a->iface.face, b->iface.face, 4 * nf) &&
           same(a->iface.remote, b->iface.remote, 4 * nf);
}

int prs_stats_equal(const pr_stats *a, const pr_stats *b)
{
    if (a->rank != b->rank || a->n != b->n)
        return 0;
    for (uint32_t i = 0; i < a->n; i++) {
        const pr_stat *x = &a->item[i], *y = &b->item[i];
        /* Values compare bitwise, so NaNs of equal bits are equal. */
        if (strcmp(x->name, y->name) || x->type != y->type ||
            memcmp(&x->v, &y->v, sizeof x->v))
            return 0;
    }
    return 1;
}
