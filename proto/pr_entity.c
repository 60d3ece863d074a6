/* pr_entity.c -- mesh entities (vertex, tetrahedron, face key) and their
 * bulk tables (PROTOCOL.md, "Mesh entities" and "Tables"). */
#include "config.h"

#include <stdlib.h>
#include <string.h>

#include "pr.h"
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
    pr_face_key *k = malloc((size_t)count * sizeof *k);
    if (!k)
        return pr_reader_fail(r, PR_ENOMEM);
    pr_get_view(r, &p, (size_t)count * PR_FACE_KEY_SIZE); /* fits: checked */
    for (uint32_t i = 0; i < count; i++) {
        for (int j = 0; j < 3; j++)
            k[i].gid[j] = pr__ld64(p + PR_FACE_KEY_SIZE * (size_t)i + 8 * j);
        int rc = face_key_error(&k[i]);
        if (rc) {
            free(k);
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

static int vtable_error(const pr_vtable *t)
{
    if (t->n > PR_MAX_VERTICES)
        return PR_ERANGE;
    for (uint32_t i = 0; i < t->n; i++) {
        if (t->gid[i] == PR_GID_NONE)
            return PR_ERANGE;
        if (i && t->gid[i] <= t->gid[i - 1])
            return PR_EDATA;
    }
    for (size_t i = 0; i < 3 * (size_t)t->n; i++)
        if (!pr__finite_bits(pr__f64_bits(t->xyz[i])))
            return PR_ERANGE;
    return 0;
}

int pr_vtable_put(pr_buf *b, const pr_vtable *t)
{
    if (b->err)
        return b->err;
    if (vtable_error(t))
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
    free(t->gid);
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
    uint8_t *mem = malloc((size_t)n * VTABLE_ELEM);
    if (!mem)
        return pr_reader_fail(r, PR_ENOMEM);
    t->n = n;
    t->gid = (uint64_t *)mem;
    t->xyz = (double *)(mem + 8 * (size_t)n);
    t->flags = (uint32_t *)(mem + 32 * (size_t)n);

    const uint8_t *p;
    pr_get_view(r, &p, (size_t)n * VTABLE_ELEM); /* fits: checked */
    /* Copy and check in one pass over each array; 'bad' accumulates
     * without branches so the loops stay simple for the compiler. */
    uint64_t prev = 0;
    int bad_order = 0, bad_range = 0;
    for (uint32_t i = 0; i < n; i++) {
        uint64_t g = pr__ld64(p + 8 * (size_t)i);
        bad_range |= g == PR_GID_NONE;
        bad_order |= i > 0 && g <= prev;
        t->gid[i] = g;
        prev = g;
    }
    p += 8 * (size_t)n;
    for (size_t i = 0; i < 3 * (size_t)n; i++) {
        uint64_t u = pr__ld64(p + 8 * i);
        bad_range |= !pr__finite_bits(u);
        t->xyz[i] = pr__bits_f64(u);
    }
    p += 24 * (size_t)n;
#if PR__HOST_LE
    memcpy(t->flags, p, 4 * (size_t)n);
#else
    for (uint32_t i = 0; i < n; i++)
        t->flags[i] = pr__ld32(p + 4 * (size_t)i);
#endif
    int rc = bad_range ? PR_ERANGE : bad_order ? PR_EDATA : 0;
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

/* Marker m is allowed with n_facets facets: -1, or 0 <= m < n_facets. */
static inline int marker_ok(int32_t m, uint32_t n_facets)
{
    return m >= PR_MARKER_NONE && (m < 0 || (uint32_t)m < n_facets);
}

static int ttable_error(const pr_ttable *t, uint32_t nv, uint32_t n_facets)
{
    if (t->n > PR_MAX_TETS)
        return PR_ERANGE;
    for (uint32_t i = 0; i < t->n; i++) {
        const uint32_t *v = t->v + 4 * (size_t)i;
        if (v[0] >= nv || v[1] >= nv || v[2] >= nv || v[3] >= nv)
            return PR_EDATA;
        if (v[0] == v[1] || v[0] == v[2] || v[0] == v[3] || v[1] == v[2] ||
            v[1] == v[3] || v[2] == v[3])
            return PR_EDATA;
        for (int k = 0; k < 4; k++)
            if (!marker_ok(t->marker[4 * (size_t)i + k], n_facets))
                return PR_ERANGE;
        if (t->subseg[i] & ~PR_SUBSEG_MASK)
            return PR_ERANGE;
    }
    return 0;
}

int pr_ttable_put(pr_buf *b, const pr_ttable *t, uint32_t n_vertices,
                  uint32_t n_facets)
{
    if (b->err)
        return b->err;
    if (ttable_error(t, n_vertices, n_facets))
        return pr__buf_fail(b, PR_EINVAL);
    if (pr_buf_reserve(b, 4 + (size_t)t->n * TTABLE_ELEM))
        return b->err;
    pr_put_u32(b, t->n);
    pr_put_u32_array(b, t->v, 4 * (size_t)t->n);
    pr_put_i32_array(b, t->marker, 4 * (size_t)t->n);
    pr_put_bytes(b, t->subseg, t->n);
    return b->err;
}

void pr_ttable_clear(pr_ttable *t)
{
    free(t->v); /* one allocation, v is its start */
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
    uint8_t *mem = malloc((size_t)n * TTABLE_ELEM);
    if (!mem)
        return pr_reader_fail(r, PR_ENOMEM);
    t->n = n;
    t->v = (uint32_t *)mem;
    t->marker = (int32_t *)(mem + 16 * (size_t)n);
    t->subseg = mem + 32 * (size_t)n;

    const uint8_t *p;
    pr_get_view(r, &p, (size_t)n * TTABLE_ELEM); /* fits: checked */
    int bad_ref = 0, bad_range = 0;
    for (uint32_t i = 0; i < n; i++) {
        const uint8_t *q = p + 16 * (size_t)i;
        uint32_t a = pr__ld32(q), b = pr__ld32(q + 4), c = pr__ld32(q + 8),
                 d = pr__ld32(q + 12);
        bad_ref |= a >= n_vertices || b >= n_vertices || c >= n_vertices ||
                   d >= n_vertices;
        bad_ref |= a == b || a == c || a == d || b == c || b == d || c == d;
        uint32_t *v = t->v + 4 * (size_t)i;
        v[0] = a, v[1] = b, v[2] = c, v[3] = d;
    }
    p += 16 * (size_t)n;
    for (size_t i = 0; i < 4 * (size_t)n; i++) {
        int32_t m = (int32_t)pr__ld32(p + 4 * i);
        bad_range |= !marker_ok(m, n_facets);
        t->marker[i] = m;
    }
    p += 16 * (size_t)n;
    uint8_t any = 0;
    for (uint32_t i = 0; i < n; i++) {
        any |= p[i];
        t->subseg[i] = p[i];
    }
    bad_range |= (any & ~PR_SUBSEG_MASK) != 0;
    int rc = bad_range ? PR_ERANGE : bad_ref ? PR_EDATA : 0;
    if (rc) {
        pr_ttable_clear(t);
        return pr_reader_fail(r, rc);
    }
    return 0;
}
