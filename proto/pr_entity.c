/* pr_entity.c -- mesh entities (vertex, tetrahedron, face key) and their
 * bulk tables (PROTOCOL.md, "Mesh entities" and "Tables"). */
#include "config.h"

#include <stdlib.h>
#include <string.h>

#include "pr.h"
#include "pr_alloc.h"
#include "pr_int.h"

/* -------------------------------------------------------------- entities */

static int vertex_error(const pr_vertex *v)
{
    if (v->gid == PR_GID_NONE)
        return PR_ERANGE;
    for (int k = 0; k < 3; k++)
        if (!pr__finite_bits(pr__f64_bits(v->xyz[k])))
            return PR_ERANGE;
    return 0;
}

int pr_vertex_put(pr_buf *b, const pr_vertex *v)
{
    if (b->err)
        return b->err;
    if (vertex_error(v))
        return pr__buf_fail(b, PR_EINVAL);
    pr_put_u64(b, v->gid);
    for (int k = 0; k < 3; k++)
        pr_put_f64(b, v->xyz[k]);
    pr_put_u32(b, v->flags);
    return b->err;
}

int pr_vertex_get(pr_reader *r, pr_vertex *v)
{
    pr_get_u64(r, &v->gid);
    for (int k = 0; k < 3; k++)
        pr_get_f64(r, &v->xyz[k]);
    pr_get_u32(r, &v->flags);
    if (r->err)
        return r->err;
    int rc = vertex_error(v);
    return rc ? pr_reader_fail(r, rc) : 0;
}

static int tet_error(const pr_tet *t)
{
    for (int i = 0; i < 4; i++) {
        if (t->v[i] == PR_GID_NONE || t->face_marker[i] < PR_MARKER_NONE)
            return PR_ERANGE;
    }
    if (t->subseg & ~PR_SUBSEG_MASK)
        return PR_ERANGE;
    for (int i = 0; i < 4; i++)
        for (int j = i + 1; j < 4; j++)
            if (t->v[i] == t->v[j])
                return PR_EDATA;
    return 0;
}

int pr_tet_put(pr_buf *b, const pr_tet *t)
{
    if (b->err)
        return b->err;
    if (tet_error(t))
        return pr__buf_fail(b, PR_EINVAL);
    for (int i = 0; i < 4; i++)
        pr_put_u64(b, t->v[i]);
    for (int i = 0; i < 4; i++)
        pr_put_i32(b, t->face_marker[i]);
    pr_put_u8(b, t->subseg);
    pr_put_u32(b, t->owner);
    return b->err;
}

int pr_tet_get(pr_reader *r, pr_tet *t)
{
    for (int i = 0; i < 4; i++)
        pr_get_u64(r, &t->v[i]);
    for (int i = 0; i < 4; i++)
        pr_get_i32(r, &t->face_marker[i]);
    pr_get_u8(r, &t->subseg);
    pr_get_u32(r, &t->owner);
    if (r->err)
        return r->err;
    int rc = tet_error(t);
    return rc ? pr_reader_fail(r, rc) : 0;
}

static int face_key_error(const pr_face_key *k)
{
    if (k->gid[2] == PR_GID_NONE)
        return PR_ERANGE;
    if (!(k->gid[0] < k->gid[1] && k->gid[1] < k->gid[2]))
        return PR_EDATA;
    return 0;
}

int pr_face_key_make(pr_face_key *k, uint64_t a, uint64_t b, uint64_t c)
{
    uint64_t t;
    /* Three compare-exchanges sort three values. */
    if (a > b)
        t = a, a = b, b = t;
    if (b > c)
        t = b, b = c, c = t;
    if (a > b)
        t = a, a = b, b = t;
    k->gid[0] = a;
    k->gid[1] = b;
    k->gid[2] = c;
    return face_key_error(k) ? PR_EINVAL : 0;
}

int pr_face_key_put(pr_buf *b, const pr_face_key *k)
{
    if (b->err)
        return b->err;
    if (face_key_error(k))
        return pr__buf_fail(b, PR_EINVAL);
    for (int i = 0; i < 3; i++)
        pr_put_u64(b, k->gid[i]);
    return b->err;
}

int pr_face_key_get(pr_reader *r, pr_face_key *k)
{
    for (int i = 0; i < 3; i++)
        pr_get_u64(r, &k->gid[i]);
    if (r->err)
        return r->err;
    int rc = face_key_error(k);
    return rc ? pr_reader_fail(r, rc) : 0;
}

int pr_face_keys_put(pr_buf *b, const pr_face_key *keys, uint32_t n)
{
    if (b->err)
        return b->err;
    if (n > PR_MAX_FACE_KEYS)
        return pr__buf_fail(b, PR_EINVAL);
    for (uint32_t i = 0; i < n; i++)
        if (face_key_error(&keys[i]))
            return pr__buf_fail(b, PR_EINVAL);
    pr_put_u32(b, n);
    uint8_t *p = n ? pr__buf_claim(b, (size_t)n * PR_FACE_KEY_SIZE) : NULL;
    for (uint32_t i = 0; p && i < n; i++)
        for (int k = 0; k < 3; k++)
            pr__st64(p + PR_FACE_KEY_SIZE * (size_t)i + 8 * k, keys[i].gid[k]);
    return b->err;
}

int pr_face_keys_get(pr_reader *r, pr_face_key **keys, uint32_t *n)
{
    *keys = NULL;
    *n = 0;
    uint32_t count;
    const uint8_t *p;
    if (pr_get_count(r, PR_MAX_FACE_KEYS, PR_FACE_KEY_SIZE, &count))
        return r->err;
    if (count == 0)
        return 0;
    pr_face_key *k = pr_malloc((size_t)count * sizeof *k);
    if (!k)
        return pr_reader_fail(r, PR_ENOMEM);
    pr_get_view(r, &p, (size_t)count * PR_FACE_KEY_SIZE); /* fits: checked */
    for (uint32_t i = 0; i < count; i++) {
        for (int j = 0; j < 3; j++)
            k[i].gid[j] = pr__ld64(p + PR_FACE_KEY_SIZE * (size_t)i + 8 * j);
        int rc = face_key_error(&k[i]);
        if (rc) {
            pr_free(k);
            return pr_reader_fail(r, rc);
        }
    }
    *keys = k;
    *n = count;
    return 0;
}

/* ---------------------------------------------------------- vertex table */

/* Bytes per vertex on the wire: gid, three coordinates, flags. */
#define VTABLE_ELEM (8 + 24 + 4)
/* Bytes per tetrahedron: four indices, four markers, subsegment mask. */
#define TTABLE_ELEM (16 + 16 + 1)

/* The table checks below are shared by encoder and decoder: a decoder
 * first copies the arrays out of the message (one memcpy each on a
 * little-endian host) and then checks the copy. The loops accumulate
 * failures with | instead of branching, so they run at a few cycles per
 * element and the compiler may vectorise them; a table is either valid or
 * refused as a whole, so knowing which element failed is not needed. */

/* 0, PR_ERANGE (a gid is PR_GID_NONE, a coordinate is not finite) or
 * PR_EDATA (gids not strictly ascending). */
static int vtable_check(const uint64_t *gid, const double *xyz, uint32_t n)
{
    unsigned bad_range = 0, bad_order = 0;
    for (uint32_t i = 0; i < n; i++)
        bad_range |= gid[i] == PR_GID_NONE;
    for (uint32_t i = 1; i < n; i++)
        bad_order |= gid[i] <= gid[i - 1];
    for (size_t i = 0; i < 3 * (size_t)n; i++)
        bad_range |= !pr__finite_bits(pr__f64_bits(xyz[i]));
    return bad_range ? PR_ERANGE : bad_order ? PR_EDATA : 0;
}

int pr_vtable_put(pr_buf *b, const pr_vtable *t)
{
    if (b->err)
        return b->err;
    if (t->n > PR_MAX_VERTICES || vtable_check(t->gid, t->xyz, t->n))
        return pr__buf_fail(b, PR_EINVAL);
    if (pr_buf_reserve(b, 4 + (size_t)t->n * VTABLE_ELEM))
        return b->err;
    pr_put_u32(b, t->n);
    pr_put_u64_array(b, t->gid, t->n);
    pr_put_f64_array(b, t->xyz, 3 * (size_t)t->n);
    pr_put_u32_array(b, t->flags, t->n);
    return b->err;
}

void pr_vtable_clear(pr_vtable *t)
{
    /* One allocation holds all three arrays; gid is its start. */
    pr_free(t->gid);
    *t = (pr_vtable){0};
}

int pr_vtable_get(pr_reader *r, pr_vtable *t)
{
    *t = (pr_vtable){0};
    uint32_t n;
    if (pr_get_count(r, PR_MAX_VERTICES, VTABLE_ELEM, &n))
        return r->err;
    if (n == 0)
        return 0;
    /* The count fits in the message, so this allocation is at most the
     * size of the message. Arrays are laid out gid, xyz, flags so that
     * each starts suitably aligned. */
    uint8_t *mem = pr_malloc((size_t)n * VTABLE_ELEM);
    if (!mem)
        return pr_reader_fail(r, PR_ENOMEM);
    t->n = n;
    t->gid = (uint64_t *)mem;
    t->xyz = (double *)(mem + 8 * (size_t)n);
    t->flags = (uint32_t *)(mem + 32 * (size_t)n);
    /* These reads fit: pr_get_count checked n * VTABLE_ELEM bytes. */
    pr_get_u64_array(r, t->gid, n);
    pr_get_f64_array(r, t->xyz, 3 * (size_t)n);
    pr_get_u32_array(r, t->flags, n);
    int rc = r->err ? r->err : vtable_check(t->gid, t->xyz, n);
    if (rc) {
        pr_vtable_clear(t);
        return pr_reader_fail(r, rc);
    }
    return 0;
}

int64_t pr_vtable_find(const pr_vtable *t, uint64_t gid)
{
    uint32_t lo = 0, hi = t->n;
    while (lo < hi) {
        uint32_t mid = lo + (hi - lo) / 2;
        if (t->gid[mid] < gid)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < t->n && t->gid[lo] == gid ? (int64_t)lo : -1;
}

/* ----------------------------------------------------- tetrahedron table */

/* On a little-endian host a tetrahedron table has the same bytes in memory
 * and on the wire, so encoding and decoding are the same copy, and with
 * GCC or clang the check runs on the registers of that copy, one
 * tetrahedron per 4-lane vector. That avoids a second pass over the arrays:
 * bench_proto measured encode and decode at about 1.7 times the time of a
 * memcpy of the same bytes with a separate check, 1.2 times fused. Other
 * hosts and PR_PORTABLE builds convert the arrays and check them with
 * plain loops (ttable_check). The rules are the same:
 *   - every vertex index < nv, and a tetrahedron's four indices distinct
 *     (else PR_EDATA); comparing (a, b, c, d) with its rotations by one and
 *     by two places covers all six pairs;
 *   - every marker m has -1 <= m < n_facets, that is, m + 1 computed as an
 *     unsigned (no overflow) is at most the limit n_facets, capped at 2^31
 *     because a marker is an int32; subsegment bits 6 and 7 are clear
 *     (else PR_ERANGE). */
#define PR__TTABLE_FUSED (PR__VECTOR && PR__HOST_LE)

static uint32_t marker_limit(uint32_t n_facets)
{
    return n_facets < UINT32_C(0x80000000) ? n_facets : UINT32_C(0x80000000);
}

/* OR of the bytes p[0..n), eight at a time. */
static unsigned or_bytes(const uint8_t *p, size_t n)
{
    uint64_t acc = 0;
    size_t i = 0;
    for (; i + 8 <= n; i += 8) {
        uint64_t w;
        memcpy(&w, p + i, 8);
        acc |= w;
    }
    for (; i < n; i++)
        acc |= p[i];
    for (int shift = 32; shift >= 8; shift /= 2)
        acc |= acc >> shift;
    return (unsigned)(acc & 0xff);
}

#if PR__TTABLE_FUSED
/* Four u32 lanes; GCC and clang spell a lane permutation differently. */
typedef uint32_t v4u __attribute__((vector_size(16)));
#if defined(__clang__)
#define V4_ROTATE(x, a, b, c, d) __builtin_shufflevector((x), (x), a, b, c, d)
#else
#define V4_ROTATE(x, a, b, c, d) __builtin_shuffle((x), (v4u){a, b, c, d})
#endif

/* Copies a table of n tetrahedra to dst, laid out like the wire (16n
 * bytes of indices, 16n of markers, n of masks), from its three arrays,
 * and checks it on the way. Returns 0, PR_EDATA or PR_ERANGE. */
static int ttable_copy_check(uint8_t *dst, const uint8_t *src_v,
                             const uint8_t *src_m, const uint8_t *src_s,
                             uint32_t n, uint32_t nv, uint32_t n_facets)
{
    uint32_t lim = marker_limit(n_facets);
    v4u ref = {0, 0, 0, 0}, range = {0, 0, 0, 0};
    const v4u nvv = {nv, nv, nv, nv}, limv = {lim, lim, lim, lim};
    const v4u one = {1, 1, 1, 1};
    uint8_t *dst_v = dst, *dst_m = dst + 16 * (size_t)n;
    for (uint32_t t = 0; t < n; t++) {
        v4u x, m;
        memcpy(&x, src_v + 16 * (size_t)t, sizeof x);
        memcpy(&m, src_m + 16 * (size_t)t, sizeof m);
        memcpy(dst_v + 16 * (size_t)t, &x, sizeof x);
        memcpy(dst_m + 16 * (size_t)t, &m, sizeof m);
        ref |= (v4u)(x >= nvv);
        ref |= (v4u)(x == V4_ROTATE(x, 1, 2, 3, 0));
        ref |= (v4u)(x == V4_ROTATE(x, 2, 3, 0, 1));
        range |= (v4u)(m + one > limv);
    }
    memcpy(dst + 32 * (size_t)n, src_s, n);
    int bad_ref = (ref[0] | ref[1] | ref[2] | ref[3]) != 0;
    int bad_range = (range[0] | range[1] | range[2] | range[3]) != 0;
    bad_range |= (or_bytes(src_s, n) & ~PR_SUBSEG_MASK) != 0;
    return bad_range ? PR_ERANGE : bad_ref ? PR_EDATA : 0;
}
#else
/* Checks a table in memory; same rules and results as the fused copy. */
static int ttable_check(const uint32_t *v, const int32_t *marker,
                        const uint8_t *subseg, uint32_t n, uint32_t nv,
                        uint32_t n_facets)
{
    uint32_t lim = marker_limit(n_facets);
    unsigned bad_ref = 0, bad_range = 0;
    for (uint32_t t = 0; t < n; t++) {
        const uint32_t *x = v + 4 * (size_t)t;
        uint32_t a = x[0], b = x[1], c = x[2], d = x[3];
        bad_ref |= (a >= nv) | (b >= nv) | (c >= nv) | (d >= nv);
        bad_ref |= (a == b) | (b == c) | (c == d) | (d == a) | (a == c) |
                   (b == d);
    }
    for (size_t i = 0; i < 4 * (size_t)n; i++)
        bad_range |= (uint32_t)marker[i] + 1u > lim;
    bad_range |= (or_bytes(subseg, n) & ~PR_SUBSEG_MASK) != 0;
    return bad_range ? PR_ERANGE : bad_ref ? PR_EDATA : 0;
}
#endif

int pr_ttable_put(pr_buf *b, const pr_ttable *t, uint32_t n_vertices,
                  uint32_t n_facets)
{
    if (b->err)
        return b->err;
    if (t->n > PR_MAX_TETS)
        return pr__buf_fail(b, PR_EINVAL);
#if PR__TTABLE_FUSED
    size_t start = b->len;
    pr_put_u32(b, t->n);
    uint8_t *p = pr__buf_claim(b, (size_t)t->n * TTABLE_ELEM);
    if (!p)
        return b->err;
    if (t->n && ttable_copy_check(p, (const uint8_t *)t->v,
                                  (const uint8_t *)t->marker, t->subseg, t->n,
                                  n_vertices, n_facets)) {
        b->len = start; /* a refused table leaves nothing behind */
        return pr__buf_fail(b, PR_EINVAL);
    }
#else
    if (ttable_check(t->v, t->marker, t->subseg, t->n, n_vertices, n_facets))
        return pr__buf_fail(b, PR_EINVAL);
    if (pr_buf_reserve(b, 4 + (size_t)t->n * TTABLE_ELEM))
        return b->err;
    pr_put_u32(b, t->n);
    pr_put_u32_array(b, t->v, 4 * (size_t)t->n);
    pr_put_i32_array(b, t->marker, 4 * (size_t)t->n);
    pr_put_bytes(b, t->subseg, t->n);
#endif
    return b->err;
}

void pr_ttable_clear(pr_ttable *t)
{
    pr_free(t->v); /* one allocation, v is its start */
    *t = (pr_ttable){0};
}

int pr_ttable_get(pr_reader *r, pr_ttable *t, uint32_t n_vertices,
                  uint32_t n_facets)
{
    *t = (pr_ttable){0};
    uint32_t n;
    if (pr_get_count(r, PR_MAX_TETS, TTABLE_ELEM, &n))
        return r->err;
    if (n == 0)
        return 0;
    uint8_t *mem = pr_malloc((size_t)n * TTABLE_ELEM);
    if (!mem)
        return pr_reader_fail(r, PR_ENOMEM);
    t->n = n;
    t->v = (uint32_t *)mem;
    t->marker = (int32_t *)(mem + 16 * (size_t)n);
    t->subseg = mem + 32 * (size_t)n;
    /* These reads fit: pr_get_count checked n * TTABLE_ELEM bytes. */
#if PR__TTABLE_FUSED
    const uint8_t *p;
    pr_get_view(r, &p, (size_t)n * TTABLE_ELEM);
    int rc = r->err ? r->err
                    : ttable_copy_check(mem, p, p + 16 * (size_t)n,
                                        p + 32 * (size_t)n, n, n_vertices,
                                        n_facets);
#else
    pr_get_u32_array(r, t->v, 4 * (size_t)n);
    pr_get_i32_array(r, t->marker, 4 * (size_t)n);
    pr_get_bytes(r, t->subseg, n);
    int rc = r->err ? r->err
                    : ttable_check(t->v, t->marker, t->subseg, n, n_vertices,
                                   n_facets);
#endif
    if (rc) {
        pr_ttable_clear(t);
        return pr_reader_fail(r, rc);
    }
    return 0;
}
