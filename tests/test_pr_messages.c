/* Unit tests of proto's messages and entities: what each decoder refuses
 * and why (error codes), version negotiation, the statistics merge, and the
 * submesh accessors. The byte layouts themselves are pinned by
 * test_pr_golden; random contents are covered by test_pr_props. */
#include "config.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "pr.h"
#include "pr_sample.h"
#include "unit.h"

#define G(rank, seq) pr_gid_make(rank, seq)

/* ------------------------------------------------------------- global ids */

START_TEST(gid_packs_rank_and_counter)
{
    ck_assert_uint_eq(G(0, 0), 0);
    uint64_t g = G(PR_GID_RANK_MAX, PR_GID_SEQ_MAX);
    ck_assert(g != PR_GID_NONE);
    ck_assert_uint_eq(pr_gid_rank(g), PR_GID_RANK_MAX);
    ck_assert_uint_eq(pr_gid_seq(g), PR_GID_SEQ_MAX);
    ck_assert_uint_eq(pr_gid_rank(G(5, 7)), 5);
    ck_assert_uint_eq(pr_gid_seq(G(5, 7)), 7);
    ck_assert_uint_eq(G(3, 1), (UINT64_C(3) << 44) | 1);
    /* Out-of-range parts give the sentinel, never a wrapped id. */
    ck_assert_uint_eq(G(PR_GID_RANK_MAX + 1, 0), PR_GID_NONE);
    ck_assert_uint_eq(G(0, PR_GID_SEQ_MAX + 1), PR_GID_NONE);
    /* Integer order is (rank, counter) order. */
    ck_assert(G(1, 0) > G(0, PR_GID_SEQ_MAX));
}
END_TEST

/* --------------------------------------------------------------- entities */

START_TEST(face_key_is_sorted_and_checked)
{
    uint64_t g[3] = {G(2, 1), G(0, 9), G(1, 0)};
    static const int perm[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2},
                                   {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    for (int p = 0; p < 6; p++) {
        pr_face_key k;
        ck_assert_int_eq(
            pr_face_key_make(&k, g[perm[p][0]], g[perm[p][1]], g[perm[p][2]]), 0);
        ck_assert_uint_eq(k.gid[0], G(0, 9));
        ck_assert_uint_eq(k.gid[1], G(1, 0));
        ck_assert_uint_eq(k.gid[2], G(2, 1));
    }
    pr_face_key k;
    ck_assert_int_eq(pr_face_key_make(&k, 1, 2, 1), PR_EINVAL);
    ck_assert_int_eq(pr_face_key_make(&k, 1, 2, PR_GID_NONE), PR_EINVAL);

    /* A key that is not strictly ascending is refused by put and get. */
    pr_face_key bad = {{3, 2, 4}};
    pr_buf b = PR_BUF_INIT;
    ck_assert_int_eq(pr_face_key_put(&b, &bad), PR_EINVAL);
    ck_assert_uint_eq(b.len, 0);
    pr_buf_reset(&b);
    for (int i = 0; i < 3; i++)
        pr_put_u64(&b, bad.gid[i]);
    pr_reader r;
    pr_reader_init(&r, b.data, b.len);
    ck_assert_int_eq(pr_face_key_get(&r, &k), PR_EDATA);
    pr_buf_reset(&b);
    pr_put_u64(&b, 1);
    pr_put_u64(&b, 1);
    pr_put_u64(&b, 2);
    pr_reader_init(&r, b.data, b.len);
    ck_assert_int_eq(pr_face_key_get(&r, &k), PR_EDATA);
    pr_buf_reset(&b);
    pr_put_u64(&b, 1);
    pr_put_u64(&b, 2);
    pr_put_u64(&b, PR_GID_NONE);
    pr_reader_init(&r, b.data, b.len);
    ck_assert_int_eq(pr_face_key_get(&r, &k), PR_ERANGE);
    pr_buf_free(&b);
}
END_TEST

/* Decodes one vertex record from raw bytes. */
static int vertex_from(const pr_buf *b)
{
    pr_reader r;
    pr_vertex v;
    pr_reader_init(&r, b->data, b->len);
    return pr_vertex_get(&r, &v);
}

START_TEST(vertex_needs_a_gid_and_finite_coordinates)
{
    pr_buf b = PR_BUF_INIT;
    pr_vertex v = {G(1, 1), {1, 2, 3}, 0};
    ck_assert_int_eq(pr_vertex_put(&b, &v), 0);
    ck_assert_int_eq(vertex_from(&b), 0);

    double bad[] = {NAN, INFINITY, -INFINITY};
    for (int i = 0; i < 3; i++) {
        pr_vertex w = v;
        w.xyz[i] = bad[i];
        pr_buf c = PR_BUF_INIT;
        ck_assert_int_eq(pr_vertex_put(&c, &w), PR_EINVAL);
        ck_assert_uint_eq(c.len, 0);
        pr_buf_free(&c);
        /* The same bytes arriving from a peer. */
        pr_put_u64(&c, w.gid);
        for (int k = 0; k < 3; k++)
            pr_put_f64(&c, w.xyz[k]);
        pr_put_u32(&c, 0);
        ck_assert_int_eq(vertex_from(&c), PR_ERANGE);
        pr_buf_free(&c);
    }
    pr_store_u64(b.data, PR_GID_NONE);
    ck_assert_int_eq(vertex_from(&b), PR_ERANGE);
    pr_buf_free(&b);
}
END_TEST

/* Encodes t field by field, bypassing pr_tet_put's checks, and decodes. */
static int tet_from_fields(const pr_tet *t)
{
    pr_buf b = PR_BUF_INIT;
    for (int i = 0; i < 4; i++)
        pr_put_u64(&b, t->v[i]);
    for (int i = 0; i < 4; i++)
        pr_put_i32(&b, t->face_marker[i]);
    pr_put_u8(&b, t->subseg);
    pr_put_u32(&b, t->owner);
    pr_reader r;
    pr_tet back;
    pr_reader_init(&r, b.data, b.len);
    int rc = pr_tet_get(&r, &back);
    if (!rc)
        rc = pr_reader_finish(&r);
    pr_buf_free(&b);
    return rc;
}

START_TEST(tet_checks_vertices_markers_and_subsegments)
{
    pr_tet ok = {{1, 2, 3, 4}, {-1, 0, 7, INT32_MAX}, 0x3f, 9};
    ck_assert_int_eq(tet_from_fields(&ok), 0);
    pr_tet t = ok;
    t.v[3] = t.v[1];
    ck_assert_int_eq(tet_from_fields(&t), PR_EDATA);
    t = ok;
    t.v[0] = PR_GID_NONE;
    ck_assert_int_eq(tet_from_fields(&t), PR_ERANGE);
    t = ok;
    t.face_marker[2] = -2;
    ck_assert_int_eq(tet_from_fields(&t), PR_ERANGE);
    t = ok;
    t.subseg = 0x40;
    ck_assert_int_eq(tet_from_fields(&t), PR_ERANGE);
    pr_buf b = PR_BUF_INIT;
    ck_assert_int_eq(pr_tet_put(&b, &t), PR_EINVAL);
    ck_assert_uint_eq(b.len, 0);
    pr_buf_free(&b);
}
END_TEST

START_TEST(face_key_list_checks_its_count)
{
    pr_buf b = PR_BUF_INIT;
    pr_reader r;
    pr_face_key *k;
    uint32_t n;
    pr_put_u32(&b, PR_MAX_FACE_KEYS + 1);
    pr_reader_init(&r, b.data, b.len);
    ck_assert_int_eq(pr_face_keys_get(&r, &k, &n), PR_ERANGE);
    ck_assert_ptr_null(k);
    /* The largest allowed count, with no keys behind it: refused before
     * anything is allocated. */
    pr_buf_reset(&b);
    pr_put_u32(&b, PR_MAX_FACE_KEYS);
    pr_put_u64(&b, 1);
    pr_reader_init(&r, b.data, b.len);
    ck_assert_int_eq(pr_face_keys_get(&r, &k, &n), PR_ETRUNC);
    ck_assert_ptr_null(k);
    ck_assert_uint_eq(n, 0);
    /* An empty list is fine and allocates nothing. */
    pr_buf_reset(&b);
    ck_assert_int_eq(pr_face_keys_put(&b, NULL, 0), 0);
    pr_reader_init(&r, b.data, b.len);
    ck_assert_int_eq(pr_face_keys_get(&r, &k, &n), 0);
    ck_assert_ptr_null(k);
    ck_assert_int_eq(pr_reader_finish(&r), 0);
    pr_buf_free(&b);
}
END_TEST

/* ---------------------------------------------------------------- submesh */

/* Offsets of the fields of the fixed submesh sample (5 vertices, 2
 * tetrahedra, 2 interface faces), in the order PROTOCOL.md gives. */
enum {
    NV = 5,
    NT = 2,
    NF = 2,
    OFF_RANK = 5,
    OFF_SIZE = 9,
    OFF_VN = 17,
    OFF_GID = OFF_VN + 4,
    OFF_XYZ = OFF_GID + 8 * NV,
    OFF_VFLAGS = OFF_XYZ + 24 * NV,
    OFF_TN = OFF_VFLAGS + 4 * NV,
    OFF_TV = OFF_TN + 4,
    OFF_MARKER = OFF_TV + 16 * NT,
    OFF_SUBSEG = OFF_MARKER + 16 * NT,
    OFF_FN = OFF_SUBSEG + NT,
    OFF_FACE = OFF_FN + 4,
    OFF_REMOTE = OFF_FACE + 4 * NF,
    SUBMESH_LEN = OFF_REMOTE + 4 * NF
};

static pr_buf fixed_submesh(void)
{
    pr_buf b = PR_BUF_INIT;
    ck_assert_int_eq(prs_fixed(PRS_SUBMESH, &b), 0);
    ck_assert_uint_eq(b.len, SUBMESH_LEN);
    return b;
}

/* Decodes the fixed submesh with the u32 (or u64 if wide) at off replaced
 * by v, and returns the decoder's result. */
static int submesh_with(size_t off, uint64_t v, int wide)
{
    pr_buf b = fixed_submesh();
    if (wide)
        pr_store_u64(b.data + off, v);
    else
        pr_store_u32(b.data + off, (uint32_t)v);
    pr_submesh *sm = (pr_submesh *)&b; /* any non-NULL value */
    int rc = pr_submesh_decode(b.data, b.len, &sm);
    if (rc)
        ck_assert_ptr_null(sm);
    pr_submesh_free(&sm);
    pr_buf_free(&b);
    return rc;
}

START_TEST(submesh_decodes_and_converts_to_entities)
{
    pr_buf b = fixed_submesh();
    pr_submesh *sm;
    ck_assert_int_eq(pr_submesh_decode(b.data, b.len, &sm), 0);
    ck_assert_uint_eq(sm->rank, 1);
    ck_assert_uint_eq(sm->size, 3);
    ck_assert_uint_eq(sm->vert.n, NV);
    ck_assert_uint_eq(sm->tet.n, NT);
    ck_assert_uint_eq(sm->iface.n, NF);

    pr_tet t;
    pr_submesh_tet(sm, 1, &t);
    ck_assert_uint_eq(t.v[0], G(0, 2));
    ck_assert_uint_eq(t.v[3], G(2, 3));
    ck_assert_int_eq(t.face_marker[0], 3);
    ck_assert_uint_eq(t.owner, 1);

    pr_vertex v;
    pr_submesh_vertex(sm, 4, &v);
    ck_assert_uint_eq(v.gid, G(2, 3));
    ck_assert(v.xyz[0] == 1 && v.xyz[1] == 1 && v.xyz[2] == 1);

    /* Interface face 0 is face 1 of tetrahedron 1: its vertices other
     * than the one at index 1 (gid G(0, 5)). */
    pr_face_key k;
    pr_submesh_iface_key(sm, 0, &k);
    ck_assert_uint_eq(k.gid[0], G(0, 2));
    ck_assert_uint_eq(k.gid[1], G(1, 0));
    ck_assert_uint_eq(k.gid[2], G(2, 3));
    ck_assert_uint_eq(sm->iface.remote[0], 0);

    ck_assert_int_eq(pr_vtable_find(&sm->vert, G(0, 5)), 2);
    ck_assert_int_eq(pr_vtable_find(&sm->vert, G(0, 3)), -1);
    ck_assert_int_eq(pr_vtable_find(&sm->vert, G(2, 4)), -1);
    ck_assert_int_eq(pr_vtable_find(&sm->vert, 0), -1);
    pr_submesh_free(&sm);
    ck_assert_ptr_null(sm);
    pr_submesh_free(&sm); /* freeing NULL is harmless */
    pr_buf_free(&b);
}
END_TEST

START_TEST(submesh_refuses_bad_vertices)
{
    ck_assert_int_eq(submesh_with(OFF_GID + 8, G(0, 1), 1), PR_EDATA); /* dup */
    ck_assert_int_eq(submesh_with(OFF_GID + 16, G(0, 1), 1), PR_EDATA); /* order */
    ck_assert_int_eq(submesh_with(OFF_GID + 32, PR_GID_NONE, 1), PR_ERANGE);
    ck_assert_int_eq(submesh_with(OFF_GID + 32, G(3, 0), 1), PR_ERANGE); /* rank >= size */
    uint64_t nan = UINT64_C(0x7ff8000000000000), inf = UINT64_C(0x7ff0000000000000);
    ck_assert_int_eq(submesh_with(OFF_XYZ + 8 * 7, nan, 1), PR_ERANGE);
    ck_assert_int_eq(submesh_with(OFF_XYZ, inf | (UINT64_C(1) << 63), 1), PR_ERANGE);
    /* Flags are the mesher's: any value passes. */
    ck_assert_int_eq(submesh_with(OFF_VFLAGS, UINT32_MAX, 0), 0);
}
END_TEST

START_TEST(submesh_refuses_bad_tetrahedra)
{
    ck_assert_int_eq(submesh_with(OFF_TV + 4 * 3, NV, 0), PR_EDATA); /* no vertex 5 */
    ck_assert_int_eq(submesh_with(OFF_TV + 4 * 3, UINT32_MAX, 0), PR_EDATA);
    /* Tetrahedron 0 is (0, 1, 2, 3): repeat each of its vertices in each
     * later slot, so every one of the six pairs is tested. */
    for (int i = 0; i < 4; i++)
        for (int j = i + 1; j < 4; j++)
            ck_assert_msg(submesh_with(OFF_TV + 4 * (size_t)j, (uint32_t)i, 0) ==
                              PR_EDATA,
                          "vertex %d repeated in slot %d", i, j);
    ck_assert_int_eq(submesh_with(OFF_MARKER, (uint32_t)-2, 0), PR_ERANGE);
    ck_assert_int_eq(submesh_with(OFF_MARKER, 4, 0), PR_ERANGE); /* n_facets 4 */
    ck_assert_int_eq(submesh_with(OFF_MARKER, 3, 0), 0);
    pr_buf b = fixed_submesh();
    b.data[OFF_SUBSEG] = 0x40;
    pr_submesh *sm;
    ck_assert_int_eq(pr_submesh_decode(b.data, b.len, &sm), PR_ERANGE);
    pr_buf_free(&b);
}
END_TEST

START_TEST(submesh_refuses_bad_interface_faces)
{
    ck_assert_int_eq(submesh_with(OFF_FACE, 4 * NT, 0), PR_EDATA); /* no tet 2 */
    ck_assert_int_eq(submesh_with(OFF_FACE, 6, 0), PR_EDATA); /* 6, 6: twice */
    ck_assert_int_eq(submesh_with(OFF_FACE, 7, 0), PR_EDATA); /* 7, 6: order */
    ck_assert_int_eq(submesh_with(OFF_FACE, 0, 0), 0);        /* 0, 6 */
    ck_assert_int_eq(submesh_with(OFF_REMOTE, 1, 0), PR_ERANGE); /* own rank */
    ck_assert_int_eq(submesh_with(OFF_REMOTE, 3, 0), PR_ERANGE); /* >= size */
    ck_assert_int_eq(submesh_with(OFF_RANK, 3, 0), PR_ERANGE);
    ck_assert_int_eq(submesh_with(OFF_SIZE, 0, 0), PR_ERANGE);
}
END_TEST

START_TEST(submesh_never_trusts_a_count)
{
    ck_assert_int_eq(submesh_with(OFF_VN, PR_MAX_VERTICES + 1, 0), PR_ERANGE);
    ck_assert_int_eq(submesh_with(OFF_VN, PR_MAX_VERTICES, 0), PR_ETRUNC);
    ck_assert_int_eq(submesh_with(OFF_VN, 1000, 0), PR_ETRUNC);
    ck_assert_int_eq(submesh_with(OFF_TN, PR_MAX_TETS + 1, 0), PR_ERANGE);
    ck_assert_int_eq(submesh_with(OFF_TN, UINT32_MAX, 0), PR_ERANGE);
    ck_assert_int_eq(submesh_with(OFF_TN, 3, 0), PR_ETRUNC);
    ck_assert_int_eq(submesh_with(OFF_FN, 3, 0), PR_ETRUNC);
    ck_assert_int_eq(submesh_with(OFF_FN, PR_MAX_IFACES + 1, 0), PR_ERANGE);
    /* A count that fits the bytes but is wrong misaligns everything after
     * it; the decoder still refuses the message. */
    ck_assert_int_lt(submesh_with(OFF_VN, 4, 0), 0);
    ck_assert_int_lt(submesh_with(OFF_TN, 1, 0), 0);
    ck_assert_int_lt(submesh_with(OFF_FN, 1, 0), 0);
}
END_TEST

START_TEST(submesh_type_tag_is_checked)
{
    pr_buf b = fixed_submesh();
    pr_submesh *sm;
    static const uint8_t others[] = {0, PR_MSG_HELLO, PR_MSG_STATS, 0x10, 0xff};
    for (size_t i = 0; i < sizeof others; i++) {
        b.data[0] = others[i];
        ck_assert_int_eq(pr_submesh_decode(b.data, b.len, &sm), PR_ETYPE);
        ck_assert_ptr_null(sm);
    }
    ck_assert_int_eq(pr_submesh_decode(b.data, 0, &sm), PR_ETRUNC);
    ck_assert_int_eq(pr_submesh_decode(NULL, 0, &sm), PR_ETRUNC);
    pr_buf_free(&b);
}
END_TEST

START_TEST(submesh_encoder_refuses_bad_input)
{
    prs_rng r = {7};
    pr_submesh sm;
    do { /* a sample with at least two vertices and a tetrahedron */
        prs_random_submesh(&r, &sm);
        if (sm.vert.n >= 2 && sm.tet.n >= 1 && sm.size >= 2)
            break;
        prs_submesh_free(&sm);
    } while (1);
    pr_buf b = PR_BUF_INIT;
    pr_put_u32(&b, 0xdeadbeef); /* earlier content must survive a refusal */

    uint64_t g = sm.vert.gid[1];
    sm.vert.gid[1] = sm.vert.gid[0];
    ck_assert_int_eq(pr_submesh_put(&b, &sm), PR_EINVAL);
    ck_assert_uint_eq(b.len, 4);
    sm.vert.gid[1] = g;

    pr_buf_reset(&b);
    uint32_t v = sm.tet.v[0];
    sm.tet.v[0] = sm.vert.n;
    ck_assert_int_eq(pr_submesh_put(&b, &sm), PR_EINVAL);
    ck_assert_uint_eq(b.len, 0);
    ck_assert_int_eq(b.err, PR_EINVAL); /* sticky until reset */
    sm.tet.v[0] = v;

    pr_buf_reset(&b);
    uint32_t rank = sm.rank;
    sm.rank = sm.size;
    ck_assert_int_eq(pr_submesh_put(&b, &sm), PR_EINVAL);
    sm.rank = rank;

    pr_buf_reset(&b);
    ck_assert_int_eq(pr_submesh_put(&b, &sm), 0);
    prs_submesh_free(&sm);
    pr_buf_free(&b);
}
END_TEST

START_TEST(grid_submesh_is_what_the_benchmark_expects)
{
    pr_submesh sm, *back;
    ck_assert_int_eq(prs_grid_submesh(3, 3, 3, &sm), 0);
    ck_assert_uint_eq(sm.vert.n, 64);
    ck_assert_uint_eq(sm.tet.n, 6 * 27);
    /* Each unit square of a side is split into two triangles: 18 faces per
     * side; side x = 3 is shared with rank 1, the other five are marked. */
    ck_assert_uint_eq(sm.iface.n, 18);
    uint32_t marked = 0;
    for (uint32_t i = 0; i < 4 * sm.tet.n; i++)
        marked += sm.tet.marker[i] >= 0;
    ck_assert_uint_eq(marked, 5 * 18);
    pr_buf b = PR_BUF_INIT;
    ck_assert_int_eq(pr_submesh_put(&b, &sm), 0);
    ck_assert_int_eq(pr_submesh_decode(b.data, b.len, &back), 0);
    ck_assert(prs_submesh_equal(&sm, back));
    pr_submesh_free(&back);
    prs_submesh_free(&sm);
    pr_buf_free(&b);
}
END_TEST

/* ------------------------------------------------------- hello, versions */

static int hello_with(size_t off, uint8_t v)
{
    pr_buf b = PR_BUF_INIT;
    pr_hello h;
    ck_assert_int_eq(prs_fixed(PRS_HELLO, &b), 0);
    b.data[off] = v;
    int rc = pr_hello_decode(&h, b.data, b.len);
    pr_buf_free(&b);
    return rc;
}

START_TEST(hello_refuses_inconsistent_fields)
{
    ck_assert_int_eq(hello_with(1, 1), 0);
    ck_assert_int_eq(hello_with(1, 2), PR_EDATA); /* version above max */
    ck_assert_int_eq(hello_with(2, 0), PR_EDATA); /* min 0 */
    ck_assert_int_eq(hello_with(3, 0), PR_EDATA); /* max below min */
    ck_assert_int_eq(hello_with(12, 4), PR_EDATA); /* rank 4 of 4 */
    ck_assert_int_eq(hello_with(0, PR_MSG_STATS), PR_ETYPE);
    pr_buf b = PR_BUF_INIT;
    pr_hello h;
    pr_hello_init(&h, 1, 0, 1);
    ck_assert_uint_eq(h.version, PR_VERSION);
    h.size = 0;
    ck_assert_int_eq(pr_hello_put(&b, &h), PR_EINVAL);
    pr_buf_free(&b);
}
END_TEST

START_TEST(negotiation_agrees_or_says_why_not)
{
    pr_hello me, peer;
    uint8_t v = 99;
    char msg[200];
    pr_hello_init(&me, 42, 0, 4);
    pr_hello_init(&peer, 42, 3, 4);
    ck_assert_int_eq(pr_negotiate(&me, &peer, &v, msg, sizeof msg), 0);
    ck_assert_uint_eq(v, PR_VERSION);
    ck_assert_str_eq(msg, "");

    /* A newer peer that still speaks our version: ours is chosen. */
    peer.version_min = 1, peer.version = 3, peer.version_max = 3;
    ck_assert_int_eq(pr_negotiate(&me, &peer, &v, msg, sizeof msg), 0);
    ck_assert_uint_eq(v, 1);
    /* Two ranges that overlap in 2..3: the highest common version. */
    pr_hello wide = me;
    wide.version_max = 4;
    ck_assert_int_eq(pr_negotiate(&wide, &peer, &v, NULL, 0), 0);
    ck_assert_uint_eq(v, 3);

    peer.version_min = 2;
    ck_assert_int_eq(pr_negotiate(&me, &peer, &v, msg, sizeof msg), PR_EVERSION);
    ck_assert_uint_eq(v, 0);
    ck_assert_msg(strstr(msg, "rank 3 speaks protocol versions 2..3") &&
                      strstr(msg, "speaks 1..1"),
                  "unclear: %s", msg);
    ck_assert_int_eq(pr_negotiate(&me, &peer, &v, NULL, 0), PR_EVERSION);

    pr_hello_init(&peer, 43, 3, 4);
    ck_assert_int_eq(pr_negotiate(&me, &peer, &v, msg, sizeof msg), PR_EJOB);
    ck_assert_msg(strstr(msg, "another job"), "unclear: %s", msg);
    pr_hello_init(&peer, 42, 3, 5);
    ck_assert_int_eq(pr_negotiate(&me, &peer, &v, msg, sizeof msg), PR_EJOB);
    ck_assert_msg(strstr(msg, "5 PEs") && strstr(msg, "says 4"), "unclear: %s", msg);
    pr_hello_init(&peer, 42, 0, 4);
    ck_assert_int_eq(pr_negotiate(&me, &peer, &v, msg, sizeof msg), PR_EJOB);
    ck_assert_msg(strstr(msg, "same rank"), "unclear: %s", msg);
    /* A short buffer gets a truncated, terminated message. */
    char tiny[8];
    ck_assert_int_eq(pr_negotiate(&me, &peer, &v, tiny, sizeof tiny), PR_EJOB);
    ck_assert_uint_eq(strlen(tiny), sizeof tiny - 1);
}
END_TEST

START_TEST(frames_of_other_versions_are_refused_but_readable)
{
    pr_header h = {.handler = 7, .sender = 2, .payload_len = 20, .seq = 5};
    uint8_t raw[PR_HEADER_SIZE];
    ck_assert_int_eq(pr_header_encode(&h, raw), 0);
    pr_header out;
    uint8_t version;
    static const uint8_t versions[] = {0, 2, 255};
    for (size_t i = 0; i < sizeof versions; i++) {
        raw[4] = versions[i];
        ck_assert_int_eq(pr_header_decode(&out, raw, sizeof raw), PR_EVERSION);
        int rc = pr_header_decode_any(&out, raw, sizeof raw, &version);
        ck_assert_uint_eq(version, versions[i]);
        if (versions[i] == 0) {
            ck_assert_int_eq(rc, PR_EVERSION);
        } else {
            ck_assert_int_eq(rc, 0);
            ck_assert_uint_eq(out.sender, 2);
            ck_assert_uint_eq(out.payload_len, 20);
        }
    }
    /* Flag bits unknown to version 1 belong to the other version... */
    raw[4] = 2;
    raw[5] = 0x80;
    ck_assert_int_eq(pr_header_decode_any(&out, raw, sizeof raw, &version), 0);
    ck_assert_int_eq(pr_header_decode(&out, raw, sizeof raw), PR_EVERSION);
    /* ...but are refused in a version-1 frame. */
    raw[4] = PR_VERSION;
    ck_assert_int_eq(pr_header_decode_any(&out, raw, sizeof raw, &version),
                     PR_EFLAGS);
    ck_assert_int_eq(pr_header_decode(&out, raw, sizeof raw), PR_EFLAGS);
    raw[0] = 'X';
    ck_assert_int_eq(pr_header_decode_any(&out, raw, sizeof raw, &version),
                     PR_EMAGIC);
    ck_assert_uint_eq(version, 0);
}
END_TEST

START_TEST(envelope_names_and_checks_types)
{
    ck_assert_str_eq(pr_msg_name(PR_MSG_HELLO), "hello");
    ck_assert_str_eq(pr_msg_name(PR_MSG_STATS), "stats");
    ck_assert_str_eq(pr_msg_name(PR_MSG_SUBMESH), "submesh");
    ck_assert_ptr_null(pr_msg_name(0));
    ck_assert_ptr_null(pr_msg_name(PR_MSG_CAVITY_FIRST));
    uint8_t p[2] = {PR_MSG_STATS, 9};
    ck_assert_int_eq(pr_msg_type(p, 2), PR_MSG_STATS);
    ck_assert_int_eq(pr_msg_type(p, 0), PR_ETRUNC);
    pr_reader r;
    ck_assert_int_eq(pr_msg_open(&r, p, 2, PR_MSG_STATS), 0);
    ck_assert_uint_eq(r.left, 1);
    ck_assert_int_eq(pr_msg_open(&r, p, 2, PR_MSG_HELLO), PR_ETYPE);
    ck_assert_int_eq(pr_reader_finish(&r), PR_ETYPE);
    pr_hello h;
    ck_assert_int_eq(pr_hello_decode(&h, p, 2), PR_ETYPE);
}
END_TEST

/* -------------------------------------------------------------- statistics */

START_TEST(stats_keep_names_sorted_and_unique)
{
    pr_stats s = PR_STATS_INIT;
    ck_assert_int_eq(pr_stats_add_u64(&s, "zeta", 1), 0);
    ck_assert_int_eq(pr_stats_add_f64(&s, "alpha", 0.5), 0);
    ck_assert_int_eq(pr_stats_add_i64(&s, "mu", -1), 0);
    ck_assert_int_eq(pr_stats_add_u64(&s, "mu", 2), PR_EINVAL);
    ck_assert_uint_eq(s.n, 3);
    ck_assert_str_eq(s.item[0].name, "alpha");
    ck_assert_str_eq(s.item[2].name, "zeta");
    const pr_stat *x = pr_stats_find(&s, "mu");
    ck_assert_ptr_nonnull(x);
    ck_assert_int_eq(x->type, PR_STAT_I64);
    ck_assert_int_eq(x->v.i64, -1);
    ck_assert_ptr_null(pr_stats_find(&s, "m"));

    char long_name[PR_STAT_NAME_MAX + 2];
    memset(long_name, 'a', sizeof long_name - 1);
    long_name[sizeof long_name - 1] = '\0';
    ck_assert_int_eq(pr_stats_add_u64(&s, long_name, 1), PR_EINVAL);
    long_name[PR_STAT_NAME_MAX] = '\0'; /* exactly the maximum */
    ck_assert_int_eq(pr_stats_add_u64(&s, long_name, 1), 0);
    ck_assert_int_eq(pr_stats_add_u64(&s, "", 1), PR_EINVAL);
    ck_assert_int_eq(pr_stats_add_u64(&s, "tab\there", 1), PR_EINVAL);
    ck_assert_int_eq(pr_stats_add_u64(&s, "bad\xff", 1), PR_EINVAL);
    ck_assert_int_eq(pr_stats_add_u64(&s, "caf\xc3\xa9", 1), 0);
    pr_stats_clear(&s);
    ck_assert_uint_eq(s.n, 0);
}
END_TEST

START_TEST(stats_hold_at_most_the_maximum)
{
    pr_stats s = PR_STATS_INIT;
    char name[16];
    for (int i = 0; i < PR_MAX_STATS; i++) {
        snprintf(name, sizeof name, "n%05d", i);
        ck_assert_int_eq(pr_stats_add_u64(&s, name, (uint64_t)i), 0);
    }
    ck_assert_int_eq(pr_stats_add_u64(&s, "one.more", 1), PR_ERANGE);
    pr_buf b = PR_BUF_INIT;
    ck_assert_int_eq(pr_stats_put(&b, &s), 0);
    pr_stats back = PR_STATS_INIT;
    ck_assert_int_eq(pr_stats_decode(&back, b.data, b.len), 0);
    ck_assert(prs_stats_equal(&s, &back));
    /* Decoding into a blob that is not empty is a caller error. */
    ck_assert_int_eq(pr_stats_decode(&back, b.data, b.len), PR_EINVAL);
    pr_stats_clear(&back);
    pr_store_u32(b.data + 6, PR_MAX_STATS + 1);
    ck_assert_int_eq(pr_stats_decode(&back, b.data, b.len), PR_ERANGE);
    ck_assert_ptr_null(back.item);
    pr_stats_clear(&s);
    pr_buf_free(&b);
}
END_TEST

/* Decodes the fixed stats sample with byte off set to v. */
static int stats_with(size_t off, uint8_t v)
{
    pr_buf b = PR_BUF_INIT;
    ck_assert_int_eq(prs_fixed(PRS_STATS, &b), 0);
    b.data[off] = v;
    pr_stats s = PR_STATS_INIT;
    int rc = pr_stats_decode(&s, b.data, b.len);
    if (rc)
        ck_assert(s.n == 0 && s.item == NULL);
    pr_stats_clear(&s);
    pr_buf_free(&b);
    return rc;
}

START_TEST(stats_decoder_refuses_bad_blobs)
{
    /* Offsets in tests/golden/proto/stats.exp: format 1, count 6, first
     * name length 10, its text 12..18 ("balance"), its type 19. */
    ck_assert_int_eq(stats_with(1, 2), PR_ETYPE);   /* unknown format */
    ck_assert_int_eq(stats_with(19, 0), PR_ETYPE);  /* value type 0 */
    ck_assert_int_eq(stats_with(19, 4), PR_ETYPE);  /* value type 4 */
    ck_assert_int_eq(stats_with(12, 'z'), PR_EDATA); /* "zalance" > "cav..." */
    ck_assert_int_eq(stats_with(12, 0), PR_EDATA);   /* NUL */
    ck_assert_int_eq(stats_with(12, 0x0a), PR_EDATA); /* control */
    ck_assert_int_eq(stats_with(12, 0xc0), PR_EDATA); /* bad UTF-8 */
    ck_assert_int_eq(stats_with(10, PR_STAT_NAME_MAX + 1), PR_ERANGE);
    ck_assert_int_eq(stats_with(10, 0), PR_EDATA);    /* empty name */
    ck_assert_int_eq(stats_with(6, 5), PR_ETRUNC);    /* one more than sent */
    ck_assert_int_lt(stats_with(6, 3), 0);            /* one fewer: trailing */
    ck_assert_int_eq(stats_with(0, PR_MSG_SUBMESH), PR_ETYPE);
    /* The rank is anyone's: any value passes. */
    ck_assert_int_eq(stats_with(2, 0xff), 0);
}
END_TEST

START_TEST(stats_merge_sums_and_is_all_or_nothing)
{
    pr_stats acc = PR_STATS_INIT, in = PR_STATS_INIT;
    pr_stats_add_u64(&acc, "msgs", 10);
    pr_stats_add_f64(&acc, "time", 1.5);
    pr_stats_add_u64(&in, "msgs", 5);
    pr_stats_add_i64(&in, "delta", -3);
    pr_stats_add_f64(&in, "time", 0.25);
    ck_assert_int_eq(pr_stats_merge(&acc, &in), 0);
    ck_assert_uint_eq(acc.n, 3);
    ck_assert_uint_eq(pr_stats_find(&acc, "msgs")->v.u64, 15);
    ck_assert(pr_stats_find(&acc, "time")->v.f64 == 1.75);
    ck_assert_int_eq(pr_stats_find(&acc, "delta")->v.i64, -3);

    /* Overflow and type conflicts leave acc as it was. */
    pr_stats big = PR_STATS_INIT;
    pr_stats_add_u64(&big, "msgs", UINT64_MAX - 14);
    ck_assert_int_eq(pr_stats_merge(&acc, &big), PR_ERANGE);
    ck_assert_uint_eq(pr_stats_find(&acc, "msgs")->v.u64, 15);
    pr_stats_clear(&big);
    pr_stats_add_i64(&big, "delta", INT64_MIN);
    ck_assert_int_eq(pr_stats_merge(&acc, &big), PR_ERANGE);
    pr_stats_clear(&big);
    pr_stats_add_i64(&big, "aaa", 1); /* new, would be inserted first */
    pr_stats_add_u64(&big, "time", 1);
    ck_assert_int_eq(pr_stats_merge(&acc, &big), PR_ETYPE);
    ck_assert_uint_eq(acc.n, 3);
    ck_assert_ptr_null(pr_stats_find(&acc, "aaa"));
    pr_stats_clear(&big);
    pr_stats_clear(&in);
    pr_stats_clear(&acc);
}
END_TEST

static Suite *messages_suite(void)
{
    Suite *s = suite_create("pr_messages");
    TCase *tc = tcase_create("entities");
    tcase_add_test(tc, gid_packs_rank_and_counter);
    tcase_add_test(tc, face_key_is_sorted_and_checked);
    tcase_add_test(tc, vertex_needs_a_gid_and_finite_coordinates);
    tcase_add_test(tc, tet_checks_vertices_markers_and_subsegments);
    tcase_add_test(tc, face_key_list_checks_its_count);
    suite_add_tcase(s, tc);
    tc = tcase_create("submesh");
    tcase_add_test(tc, submesh_decodes_and_converts_to_entities);
    tcase_add_test(tc, submesh_refuses_bad_vertices);
    tcase_add_test(tc, submesh_refuses_bad_tetrahedra);
    tcase_add_test(tc, submesh_refuses_bad_interface_faces);
    tcase_add_test(tc, submesh_never_trusts_a_count);
    tcase_add_test(tc, submesh_type_tag_is_checked);
    tcase_add_test(tc, submesh_encoder_refuses_bad_input);
    tcase_add_test(tc, grid_submesh_is_what_the_benchmark_expects);
    suite_add_tcase(s, tc);
    tc = tcase_create("hello");
    tcase_add_test(tc, hello_refuses_inconsistent_fields);
    tcase_add_test(tc, negotiation_agrees_or_says_why_not);
    tcase_add_test(tc, frames_of_other_versions_are_refused_but_readable);
    tcase_add_test(tc, envelope_names_and_checks_types);
    suite_add_tcase(s, tc);
    tc = tcase_create("stats");
    tcase_add_test(tc, stats_keep_names_sorted_and_unique);
    tcase_add_test(tc, stats_hold_at_most_the_maximum);
    tcase_add_test(tc, stats_decoder_refuses_bad_blobs);
    tcase_add_test(tc, stats_merge_sums_and_is_all_or_nothing);
    suite_add_tcase(s, tc);
    return s;
}

UNIT_MAIN(messages_suite)
