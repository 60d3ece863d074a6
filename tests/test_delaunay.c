/* Unit tests of the mesh, the Delaunay kernel, the spatial sort and the
 * verifier. Every tetrahedralization built here is re-checked by vf_check
 * (exact predicates); the verifier itself is shown to fail on corrupted
 * meshes. */
#include "config.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "mesh/dt.h"
#include "mesh/flip.h"
#include "geom/pred.h"
#include "geom/ss.h"
#include "mesh/tm.h"
#include "unit.h"
#include "mesh/vf.h"

static uint64_t rng_state;
static uint64_t rnd(void)
{
    uint64_t z = (rng_state += 0x9e3779b97f4a7c15u);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9u;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebu;
    return z ^ (z >> 31);
}
static double rnd01(void) { return (double)(rnd() >> 11) * 0x1p-53; }

static void add(tm_mesh *m, double x, double y, double z)
{
    double p[3] = {x, y, z};
    uint32_t v;
    ck_assert_int_eq(tm_add_vertex(m, p, &v), 0);
}

/* The mesh's counters agree with its slots: every slot is live or on the
 * free list, the free list holds exactly the dead slots, and nlive/nghost
 * count the live ones. */
static void check_counts(const tm_mesh *m)
{
    size_t live = 0, ghosts = 0, dead = 0, listed = 0;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t)) {
            dead++;
            continue;
        }
        live++;
        ghosts += (size_t)tm_is_ghost(m, t);
        ck_assert_uint_eq(m->flags[t] & TM_F_CAVITY, 0);
        for (int s = 0; s < 4; s++)
            ck_assert_uint_lt(m->tets[t].v[s], m->nv);
    }
    for (uint32_t t = m->free_head; t != TM_NONE && listed <= m->nslots; t = m->tets[t].n[0]) {
        ck_assert(tm_is_dead(m, t));
        listed++;
    }
    ck_assert_uint_eq(live, m->nlive);
    ck_assert_uint_eq(ghosts, m->nghost);
    ck_assert_uint_eq(dead, m->nfree);
    ck_assert_uint_eq(listed, m->nfree);
}

/* Builds the tetrahedralization of m's vertices and checks it fully. */
static void build_and_check(tm_mesh *m, size_t expect_dups)
{
    dt_build_opts o = {.seed = 7};
    dt_build_stats st;
    ck_assert_int_eq(dt_build(m, &o, &st), 0);
    ck_assert_uint_eq(st.duplicates, expect_dups);
    ck_assert_uint_eq(st.inserted + st.duplicates, m->nv - 1);
    vf_report r = {0};
    ck_assert_int_eq(vf_check(m, VF_ALL, &r), 0);
    if (vf_defects(&r))
        vf_print(&r, stderr);
    ck_assert_uint_eq(vf_defects(&r), 0);
    ck_assert_uint_eq(r.used_vertices, st.inserted);
    ck_assert_uint_eq(r.duplicates, expect_dups);
    ck_assert_uint_gt(r.tets, 0);
    ck_assert_uint_eq(r.hull_faces, m->nghost);
    ck_assert_uint_gt(r.probes, 0);
    check_counts(m);
}

START_TEST(random_points)
{
    tm_mesh m;
    ck_assert_int_eq(tm_init(&m, 0), 0);
    rng_state = 1;
    for (int i = 0; i < 3000; i++)
        add(&m, rnd01(), rnd01(), rnd01());
    build_and_check(&m, 0);
    /* Euler: for a triangulated ball V - E + F - T = 1, and for random
     * points T is about 6.5 V. */
    ck_assert_uint_gt(m.nlive - m.nghost, 5 * 3000);
    tm_free(&m);
}
END_TEST

START_TEST(grid_8x8x8)
{
    /* Every cube's eight corners are cospherical and many points are
     * coplanar with hull faces: symbolic perturbation decides all ties. */
    tm_mesh m;
    ck_assert_int_eq(tm_init(&m, 0), 0);
    for (int i = 0; i < 8; i++)
        for (int j = 0; j < 8; j++)
            for (int k = 0; k < 8; k++)
                add(&m, i, j, k);
    build_and_check(&m, 0);
    /* 7^3 cubes, each split into 5 or 6 tets of total volume 1: the tet
     * count is between 5 and 6 per cube. */
    size_t real = m.nlive - m.nghost;
    ck_assert_uint_ge(real, 5 * 343);
    ck_assert_uint_le(real, 6 * 343);
    /* The hull is the cube's surface: 6 faces of 7x7 squares, 2 triangles
     * each. */
    ck_assert_uint_eq(m.nghost, 6 * 49 * 2);
    tm_free(&m);
}
END_TEST

START_TEST(points_on_a_sphere)
{
    /* All lattice points of x^2+y^2+z^2 = 2*3*5*7*11*... exactly
     * cospherical: every insphere test is a tie. */
    tm_mesh m;
    ck_assert_int_eq(tm_init(&m, 0), 0);
    int n = 0;
    for (int x = -20; x <= 20; x++)
        for (int y = -20; y <= 20; y++)
            for (int z = -20; z <= 20; z++)
                if (x * x + y * y + z * z == 339) {
                    add(&m, x, y, z);
                    n++;
                }
    ck_assert_int_gt(n, 50);
    build_and_check(&m, 0);
    /* Nothing inside: every tet touches... the center is covered once. */
    tm_free(&m);

    /* Random points on the unit sphere (near-cospherical) plus the center. */
    ck_assert_int_eq(tm_init(&m, 0), 0);
    rng_state = 2;
    for (int i = 0; i < 1500; i++) {
        double z = 2 * rnd01() - 1, t = 2 * M_PI * rnd01(), r = sqrt(1 - z * z);
        add(&m, r * cos(t), r * sin(t), z);
    }
    add(&m, 0, 0, 0);
    build_and_check(&m, 0);
    tm_free(&m);
}
END_TEST

/* Points on a helix: cavities of hundreds of tetrahedra, whose boundary
 * has more vertices than the edge table of the bulk insertion holds, so
 * their new tetrahedra are linked through the edge hash. */
START_TEST(large_cavities_on_a_helix)
{
    tm_mesh m;
    ck_assert_int_eq(tm_init(&m, 0), 0);
    rng_state = 3;
    for (int i = 0; i < 600; i++) {
        double t = rnd01();
        add(&m, cos(50 * t), sin(50 * t), t);
    }
    dt_build_opts o = {.seed = 7};
    dt_build_stats st;
    ck_assert_int_eq(dt_build(&m, &o, &st), 0);
    /* More than 124 new tets = more than 64 boundary vertices. */
    ck_assert_uint_gt(st.largest_cavity, 124);
    ck_assert_uint_eq(st.inserted, 600);
    vf_report r = {0};
    ck_assert_int_eq(vf_check(&m, VF_ALL, &r), 0);
    if (vf_defects(&r))
        vf_print(&r, stderr);
    ck_assert_uint_eq(vf_defects(&r), 0);
    ck_assert_uint_eq(r.hull_faces, m.nghost);
    check_counts(&m);
    tm_free(&m);
}
END_TEST

/* With the optional per-tet arrays enabled (the quality mesher builds its
 * first mesh with markers on), the bulk build leaves them at zero. */
START_TEST(build_with_markers_and_locks)
{
    tm_mesh m;
    ck_assert_int_eq(tm_init(&m, TM_FEAT_MARKERS | TM_FEAT_LOCKS), 0);
    rng_state = 4;
    for (int i = 0; i < 4000; i++)
        add(&m, rnd01(), rnd01(), rnd01());
    build_and_check(&m, 0);
    for (uint32_t t = 0; t < m.nslots; t++) {
        if (tm_is_dead(&m, t))
            continue;
        ck_assert_uint_eq(m.lock[t], 0);
        for (int i = 0; i < 4; i++)
            ck_assert_int_eq(tm_marker(&m, t, i), 0);
    }
    tm_free(&m);
}
END_TEST

/* The face markers live in a map holding only the nonzero ones, with a
 * bit per slot that has one (tm.h): random writes (zeros among them, which
 * drop a face, and the slot's bit with its last one), slots freed and
 * taken again (their markers cleared) and the map's growth must read back
 * exactly as a dense array would. */
START_TEST(marker_map_reads_as_a_dense_array)
{
    enum { N = 3000 };
    tm_mesh m;
    ck_assert_int_eq(tm_init(&m, TM_FEAT_MARKERS), 0);
    ck_assert_int_eq(tm_room(&m, N), 0);
    static int32_t ref[4 * N];
    memset(ref, 0, sizeof ref);
    for (uint32_t k = 0; k < N; k++) {
        uint32_t t = tm_alloc_tet(&m);
        ck_assert_uint_eq(t, k);
        for (int i = 0; i < 4; i++)
            m.tets[t].v[i] = (uint32_t)i + 1;
    }
    rng_state = 11;
    for (int step = 0; step < 200000; step++) {
        uint32_t t = (uint32_t)(rnd01() * N) % N;
        int i = (int)(rnd01() * 4) & 3;
        double u = rnd01();
        if (u < 0.02) {
            /* freed and taken again: the same slot, its markers gone */
            tm_free_tet(&m, t);
            ck_assert_uint_eq(tm_alloc_tet(&m), t);
            memset(&ref[4 * t], 0, 4 * sizeof ref[0]);
            continue;
        }
        int32_t x = u < 0.5 ? 0 : (int32_t)(rnd01() * 2000) - 1000;
        ck_assert_int_eq(tm_set_marker(&m, t, i, x), 0);
        ref[4 * t + (uint32_t)i] = x;
        if (step % 20000 == 0 || step == 199999) {
            uint32_t held = 0;
            for (uint32_t s = 0; s < N; s++) {
                int any = 0;
                for (int f = 0; f < 4; f++) {
                    ck_assert_int_eq(tm_marker(&m, s, f), ref[4 * s + (uint32_t)f]);
                    any |= ref[4 * s + (uint32_t)f] != 0;
                    held += ref[4 * s + (uint32_t)f] != 0;
                }
                ck_assert_int_eq(tm__has_marks(&m, s), any);
            }
            ck_assert_uint_eq(m.mk_n, held);
            ck_assert_uint_le(2 * m.mk_n, m.mk_cap);
        }
    }
    for (uint32_t s = 0; s < N; s++)
        for (int f = 0; f < 4; f++)
            ck_assert_int_eq(tm_set_marker(&m, s, f, 0), 0);
    ck_assert_uint_eq(m.mk_n, 0);
    tm_free(&m);
    /* After tm_marker_room(k), k more slots take markers without a new
     * map (the commits that cannot fail midway count on it); a fresh
     * map is small. */
    ck_assert_int_eq(tm_init(&m, TM_FEAT_MARKERS), 0);
    ck_assert_int_eq(tm_room(&m, 1000), 0);
    for (uint32_t k = 0; k < 1000; k++)
        ck_assert_uint_eq(tm_alloc_tet(&m), k);
    ck_assert_uint_lt(m.mk_cap, 2000);
    ck_assert_int_eq(tm_marker_room(&m, 1000), 0);
    const uint32_t *keys = m.mk_key;
    for (uint32_t s = 0; s < 1000; s++)
        ck_assert_int_eq(tm_set_marker(&m, s, (int)(s & 3), 7), 0);
    ck_assert_ptr_eq(m.mk_key, keys);
    for (uint32_t s = 0; s < 1000; s++)
        ck_assert_int_eq(tm_marker(&m, s, (int)(s & 3)), 7);
    tm_free(&m);
}
END_TEST

START_TEST(points_on_a_few_planes)
{
    tm_mesh m;
    ck_assert_int_eq(tm_init(&m, 0), 0);
    rng_state = 3;
    /* Three parallel planes with random points, a tilted plane with grid
     * points, and a plane containing a hull face. */
    for (int i = 0; i < 400; i++)
        add(&m, rnd01(), rnd01(), (double)(i % 3) * 0.5);
    for (int i = 0; i < 10; i++)
        for (int j = 0; j < 10; j++)
            add(&m, i * 0.125, j * 0.125, (i + j) * 0.0625);
    for (int i = 0; i < 50; i++)
        add(&m, rnd01() * 2 - 0.5, -0.5, rnd01());
    build_and_check(&m, 0);
    tm_free(&m);
}
END_TEST

START_TEST(duplicates_are_skipped_and_counted)
{
    tm_mesh m;
    ck_assert_int_eq(tm_init(&m, 0), 0);
    rng_state = 4;
    double pts[500][3];
    for (int i = 0; i < 500; i++) {
        for (int k = 0; k < 3; k++)
            pts[i][k] = rnd01();
        add(&m, pts[i][0], pts[i][1], pts[i][2]);
    }
    for (int i = 0; i < 500; i += 5)
        add(&m, pts[i][0], pts[i][1], pts[i][2]);
    build_and_check(&m, 100);
    tm_free(&m);
}
END_TEST

START_TEST(degenerate_inputs_are_refused)
{
    tm_mesh m;
    ck_assert_int_eq(tm_init(&m, 0), 0);
    for (int i = 0; i < 20; i++)
        add(&m, i, 2 * i, 0.5 * i + 3); /* collinear */
    ck_assert_int_eq(dt_build(&m, NULL, NULL), PDR_EGEOMETRY);
    tm_free(&m);
    ck_assert_int_eq(tm_init(&m, 0), 0);
    for (int i = 0; i < 10; i++)
        for (int j = 0; j < 10; j++)
            add(&m, i, j, i + j); /* coplanar */
    ck_assert_int_eq(dt_build(&m, NULL, NULL), PDR_EGEOMETRY);
    tm_free(&m);
    ck_assert_int_eq(tm_init(&m, 0), 0);
    add(&m, 0, 0, 0);
    add(&m, 1, 0, 0);
    add(&m, 0, 1, 0);
    ck_assert_int_eq(dt_build(&m, NULL, NULL), PDR_EGEOMETRY);
    tm_free(&m);
}
END_TEST

static void random_mesh(tm_mesh *m, int n, uint64_t seed, unsigned features)
{
    ck_assert_int_eq(tm_init(m, features), 0);
    rng_state = seed;
    for (int i = 0; i < n; i++)
        add(m, rnd01(), rnd01(), rnd01());
    ck_assert_int_eq(dt_build(m, NULL, NULL), 0);
}

static void assert_clean(const tm_mesh *m)
{
    vf_report r = {0};
    ck_assert_int_eq(vf_check(m, VF_ALL, &r), 0);
    if (vf_defects(&r))
        vf_print(&r, stderr);
    ck_assert_uint_eq(vf_defects(&r), 0);
    for (uint32_t t = 0; t < m->nslots; t++)
        ck_assert(!(m->flags[t] & TM_F_CAVITY));
}

START_TEST(search_then_abandon_leaves_the_mesh_unchanged)
{
    tm_mesh m;
    random_mesh(&m, 800, 5, 0);
    uint32_t live = m.nlive, slots = m.nslots;
    dt_cavity c;
    dt_cavity_init(&c);
    double p[3] = {0.5, 0.5, 0.5};
    ck_assert_int_eq(dt_cavity_search(&m, p, TM_NONE, DT_LOCATE, &c), 0);
    ck_assert_int_eq(c.status, DT_OK);
    ck_assert_uint_gt(c.ntets, 0);
    ck_assert_uint_ge(c.nbnd, 4);
    for (size_t i = 0; i < c.ntets; i++) {
        ck_assert(m.flags[c.tets[i]] & TM_F_CAVITY);
        ck_assert_int_gt(dt_conflict(&m, c.tets[i], p), 0);
    }
    for (size_t i = 0; i < c.nbnd; i++) {
        ck_assert_int_eq(c.bnd[i].reason, DT_BND_OUTSIDE);
        ck_assert_int_lt(dt_conflict(&m, tm_ltet(c.bnd[i].outer), p), 0);
    }
    ck_assert(dt_cavity_is_star(&m, &c));
    dt_cavity_abandon(&m, &c);
    ck_assert_uint_eq(m.nlive, live);
    ck_assert_uint_eq(m.nslots, slots);
    assert_clean(&m);

    /* Now commit the same point: Euler for a star of a point inside. */
    ck_assert_int_eq(dt_cavity_search(&m, p, TM_NONE, DT_LOCATE, &c), 0);
    size_t ncav = c.ntets, nb = c.nbnd;
    uint32_t v;
    ck_assert_int_eq(tm_add_vertex(&m, p, &v), 0);
    ck_assert_int_eq(dt_cavity_commit(&m, v, &c), 0);
    ck_assert_uint_eq(c.nnew, nb);
    ck_assert_uint_eq(m.nlive, live - ncav + nb);
    for (size_t i = 0; i < c.nnew; i++)
        ck_assert_uint_eq(m.tets[c.newtets[i]].v[3], v);
    assert_clean(&m);
    dt_cavity_free(&c);
    tm_free(&m);
}
END_TEST

/* keep of dt_cavity_shrink: the tetrahedron *arg. */
static int keep_one(void *arg, uint32_t t)
{
    return t == *(const uint32_t *)arg;
}

/* 1 if p sees face f of t from inside (a face at the infinite vertex
 * counts as seen), as dt_cavity_shrink decides it. */
static int sees(const tm_mesh *m, uint32_t t, int f, const double p[3])
{
    const uint32_t *v = m->tets[t].v;
    const uint8_t *fv = tm_face_vtx[f];
    if (v[fv[0]] == TM_VINF || v[fv[1]] == TM_VINF || v[fv[2]] == TM_VINF)
        return 1;
    return pred_orient3d(m->xyz + 3 * (size_t)v[fv[0]], m->xyz + 3 * (size_t)v[fv[1]],
                         m->xyz + 3 * (size_t)v[fv[2]], p) > 0;
}

START_TEST(cavity_shrink_takes_off_what_layer_by_layer_rounds_take)
{
    /* A ball of tetrahedra around the one holding p, a few neighbour
     * steps deep, is no star from p; dt_cavity_shrink must leave exactly
     * what taking off, round after round, every tetrahedron with a
     * boundary face p does not see leaves (or refuse when that takes
     * the tetrahedron its keep names). */
    int shrunk = 0, refused = 0;
    for (uint64_t seed = 1; seed <= 40; seed++) {
        tm_mesh m;
        random_mesh(&m, 400, seed, 0);
        double p[3] = {0.2 + 0.6 * rnd01(), 0.2 + 0.6 * rnd01(), 0.2 + 0.6 * rnd01()};
        dt_cavity c;
        dt_cavity_init(&c);
        ck_assert_int_eq(dt_cavity_search(&m, p, TM_NONE, DT_LOCATE, &c), 0);
        uint32_t t0 = c.located;
        dt_cavity_abandon(&m, &c);
        /* the ball: breadth first from t0, depth 1 + seed % 4 */
        uint8_t *in = calloc(m.nslots, 1);
        uint32_t *ball = malloc(m.nslots * sizeof *ball);
        ck_assert(in && ball);
        size_t n = 0, from = 0;
        ball[n++] = t0;
        in[t0] = 1;
        for (int depth = 0; depth < 1 + (int)(seed % 4); depth++) {
            size_t to = n;
            for (size_t i = from; i < to; i++)
                for (int f = 0; f < 4; f++) {
                    tm_link l = m.tets[ball[i]].n[f];
                    if (tm_is_special(l) || in[tm_ltet(l)] || tm_is_ghost(&m, tm_ltet(l)))
                        continue;
                    in[tm_ltet(l)] = 1;
                    ball[n++] = tm_ltet(l);
                }
            from = to;
        }
        /* kept: the tetrahedron holding p (which sees all its faces), or
         * for odd seeds one of the outer layer, which may have to go */
        uint32_t keep = seed % 2 ? ball[n - 1] : t0;
        /* the rounds */
        int kept_out = 0;
        for (int changed = 1; changed;) {
            changed = 0;
            uint8_t *leave = calloc(m.nslots, 1);
            ck_assert(leave);
            for (size_t i = 0; i < n; i++)
                for (int f = 0; f < 4 && in[ball[i]]; f++) {
                    tm_link l = m.tets[ball[i]].n[f];
                    if (!tm_is_special(l) && in[tm_ltet(l)])
                        continue;
                    if (!sees(&m, ball[i], f, p))
                        leave[ball[i]] = 1;
                }
            for (size_t i = 0; i < n; i++)
                if (in[ball[i]] && leave[ball[i]]) {
                    in[ball[i]] = 0;
                    changed = 1;
                    kept_out |= ball[i] == keep;
                }
            free(leave);
        }
        size_t left = 0;
        for (size_t i = 0; i < n; i++)
            left += in[ball[i]];
        ck_assert_int_eq(dt_cavity_set(&m, p, ball, n, 0, &c), 0);
        int rc = dt_cavity_shrink(&m, &c, keep_one, &keep);
        if (kept_out) {
            ck_assert_int_eq(rc, 1);
            refused++;
        } else {
            ck_assert_int_eq(rc, 0);
            ck_assert_uint_eq(c.ntets, left);
            size_t k = 0;
            for (size_t i = 0; i < n; i++)
                if (in[ball[i]])
                    ck_assert_uint_eq(c.tets[k++], ball[i]); /* same order */
            ck_assert(dt_cavity_is_star(&m, &c));
            shrunk += left < n;
            dt_cavity_abandon(&m, &c);
        }
        assert_clean(&m);
        free(in);
        free(ball);
        dt_cavity_free(&c);
        tm_free(&m);
    }
    /* both outcomes were met, and cavities did shrink */
    ck_assert_int_gt(shrunk, 5);
    ck_assert_int_gt(refused, 0);
}
END_TEST

START_TEST(single_insertions_inside_and_outside_the_hull)
{
    tm_mesh m;
    random_mesh(&m, 500, 6, 0);
    dt_cavity c;
    dt_cavity_init(&c);
    rng_state = 60;
    for (int i = 0; i < 300; i++) {
        /* Some inside, some far outside (the hull grows), some on the
         * planes of the cube's faces. */
        double p[3] = {rnd01() * 3 - 1, rnd01() * 3 - 1, rnd01() * 3 - 1};
        if (i % 3 == 0)
            p[i % 9 / 3] = 2.0;
        uint32_t v;
        ck_assert_int_eq(tm_add_vertex(&m, p, &v), 0);
        ck_assert_int_eq(dt_insert(&m, v, m.vhint[v - 1], &c), 0);
        ck_assert_int_eq(c.status, DT_OK);
    }
    assert_clean(&m);
    /* A point far away sees most of the hull: a cavity whose boundary has
     * more vertices than the commit's edge table, which then links the new
     * tets by turning around edges. */
    {
        double far[3] = {50, 60, 70};
        uint32_t vf;
        ck_assert_int_eq(tm_add_vertex(&m, far, &vf), 0);
        ck_assert_int_eq(dt_cavity_search(&m, far, TM_NONE, DT_LOCATE, &c), 0);
        ck_assert_uint_gt(c.nbnd, 2 * 64);
        ck_assert_int_eq(dt_cavity_commit(&m, vf, &c), 0);
        assert_clean(&m);
    }
    /* Inserting an existing vertex again is refused. */
    uint32_t v;
    ck_assert_int_eq(tm_add_vertex(&m, tm_xyz(&m, 17), &v), 0);
    ck_assert_int_eq(dt_insert(&m, v, TM_NONE, &c), 0);
    ck_assert_int_eq(c.status, DT_DUPLICATE);
    ck_assert_uint_eq(c.dup_vertex, 17);
    ck_assert_uint_eq(m.vhint[v], TM_NONE);
    dt_cavity_free(&c);
    tm_free(&m);
}
END_TEST

/* Finds the live tet and face holding the vertex set {a,b,c}. */
static int find_face(const tm_mesh *m, uint32_t a, uint32_t b, uint32_t c, uint32_t *t, int *f)
{
    for (uint32_t u = 0; u < m->nslots; u++) {
        if (tm_is_dead(m, u))
            continue;
        for (int i = 0; i < 4; i++) {
            int hits = 0;
            for (int s = 0; s < 3; s++) {
                uint32_t w = m->tets[u].v[tm_face_vtx[i][s]];
                hits += w == a || w == b || w == c;
            }
            if (hits == 3) {
                *t = u;
                *f = i;
                return 1;
            }
        }
    }
    return 0;
}

START_TEST(marked_faces_stop_the_search_and_move_with_commit)
{
    tm_mesh m;
    random_mesh(&m, 600, 7, TM_FEAT_MARKERS);
    dt_cavity c;
    dt_cavity_init(&c);
    double p[3] = {0.41, 0.52, 0.47};
    /* Mark an interior face inside p's cavity: the search must stop there. */
    ck_assert_int_eq(dt_cavity_search(&m, p, TM_NONE, DT_LOCATE, &c), 0);
    ck_assert_uint_gt(c.ntets, 2);
    uint32_t t = TM_NONE;
    int f = -1;
    for (size_t i = 0; i < c.ntets && t == TM_NONE; i++)
        for (int j = 0; j < 4; j++) {
            tm_link l = m.tets[c.tets[i]].n[j];
            if (c.tets[i] != c.located && !tm_is_ghost(&m, c.tets[i]) &&
                (m.flags[tm_ltet(l)] & TM_F_CAVITY) && tm_ltet(l) == c.located) {
                t = c.tets[i];
                f = j;
                break;
            }
        }
    ck_assert_uint_ne(t, TM_NONE);
    dt_cavity_abandon(&m, &c);
    uint32_t fa = m.tets[t].v[tm_face_vtx[f][0]], fb = m.tets[t].v[tm_face_vtx[f][1]],
             fc = m.tets[t].v[tm_face_vtx[f][2]];
    tm_mark_face(&m, t, f, 42);

    ck_assert_int_eq(dt_cavity_search(&m, p, c.located, DT_STOP_MARKED, &c), 0);
    int marked = 0;
    for (size_t i = 0; i < c.nbnd; i++)
        if (c.bnd[i].reason == DT_BND_MARKED) {
            marked++;
            ck_assert_int_eq(tm_face_marker(&m, c.bnd[i].tet, c.bnd[i].face), 42);
        }
    /* Reported from each side the search reached (a lone marked face in
     * the middle of the volume can be walked around). */
    ck_assert_int_ge(marked, 1);
    ck_assert_int_le(marked, 2);
    /* The cavity is cut by the marked face; commit only if p still sees
     * every boundary face (then the marker must move to the new tet). */
    if (dt_cavity_is_star(&m, &c)) {
        uint32_t v;
        ck_assert_int_eq(tm_add_vertex(&m, p, &v), 0);
        ck_assert_int_eq(dt_cavity_commit(&m, v, &c), 0);
        uint32_t t2;
        int f2;
        ck_assert(find_face(&m, fa, fb, fc, &t2, &f2));
        ck_assert_int_eq(tm_face_marker(&m, t2, f2), 42);
        tm_link l = m.tets[t2].n[f2];
        ck_assert_int_eq(tm_face_marker(&m, tm_ltet(l), tm_lface(l)), 42);
        vf_report r = {0};
        vf_check(&m, VF_TOPOLOGY | VF_ORIENTATION | VF_HULL, &r);
        ck_assert_uint_eq(vf_defects(&r), 0);
    } else {
        dt_cavity_abandon(&m, &c);
        assert_clean(&m);
    }
    dt_cavity_free(&c);
    tm_free(&m);
}
END_TEST

/* The constrained cavity (DT_STOP_MARKED with may_cross). Set-up: an
 * interior face (t, f) of a random mesh, its neighbour u across it, and
 * a point p just inside t next to the face's centroid (so that u is in
 * conflict with p too). All four faces of u are marked, so the search can
 * reach u only through a face it is allowed to cross. */
struct cross_face {
    uint32_t v[3];
    int calls;
};

static int cross_if_face(void *arg, const tm_mesh *m, uint32_t t, int f)
{
    struct cross_face *x = arg;
    x->calls++;
    int hit = 0;
    for (int k = 0; k < 3; k++) {
        uint32_t w = m->tets[t].v[tm_face_vtx[f][k]];
        hit += w == x->v[0] || w == x->v[1] || w == x->v[2];
    }
    return hit == 3;
}

static int in_list(const uint32_t *a, size_t n, uint32_t x)
{
    for (size_t i = 0; i < n; i++)
        if (a[i] == x)
            return 1;
    return 0;
}

/* A mesh with a wall: random points off the slab |z - 1/2| < 0.15 and a
 * jittered 8 x 8 grid on the plane z = 1/2, whose triangles (circumradii
 * below 0.15) are then faces of the Delaunay tetrahedralization; every
 * face with its three vertices on the plane is marked, like the subfacets
 * of a facet. */
static void wall_mesh(tm_mesh *m, uint64_t seed, int32_t marker)
{
    ck_assert_int_eq(tm_init(m, TM_FEAT_MARKERS), 0);
    rng_state = seed;
    for (int i = 0; i < 400; i++) {
        double z = rnd01();
        if (fabs(z - 0.5) < 0.15)
            continue;
        add(m, rnd01(), rnd01(), z);
    }
    for (int i = 0; i < 8; i++)
        for (int j = 0; j < 8; j++)
            add(m, (i + 0.5 + 0.3 * (rnd01() - 0.5)) / 8, (j + 0.5 + 0.3 * (rnd01() - 0.5)) / 8,
                0.5);
    ck_assert_int_eq(dt_build(m, NULL, NULL), 0);
    for (uint32_t x = 0; x < m->nslots; x++) {
        if (tm_is_dead(m, x))
            continue;
        for (int k = 0; k < 4; k++) {
            int on = 1;
            for (int s = 0; s < 3; s++) {
                uint32_t w = m->tets[x].v[tm_face_vtx[k][s]];
                on &= w != TM_VINF && tm_xyz(m, w)[2] == 0.5;
            }
            if (on)
                tm_mark_face(m, x, k, marker);
        }
    }
}

/* A marked face (t, f) near the middle of the wall, with t above it and u
 * below; p at height h above its centroid (h = 0: on it exactly). */
static void wall_face(const tm_mesh *m, uint32_t *t, int *f, uint32_t *u, double p[3], double h)
{
    for (uint32_t x = 0; x < m->nslots; x++) {
        if (tm_is_dead(m, x) || tm_is_ghost(m, x))
            continue;
        for (int k = 0; k < 4; k++) {
            if (!(m->flags[x] & TM_F_FACEMARK(k)) || tm_xyz(m, m->tets[x].v[k])[2] < 0.5)
                continue;
            double c[3] = {0, 0, 0};
            for (int s = 0; s < 3; s++)
                for (int d = 0; d < 3; d++)
                    c[d] += tm_xyz(m, m->tets[x].v[tm_face_vtx[k][s]])[d];
            if (fabs(c[0] / 3 - 0.5) > 0.15 || fabs(c[1] / 3 - 0.5) > 0.15)
                continue;
            *t = x;
            *f = k;
            *u = tm_ltet(m->tets[x].n[k]);
            p[0] = c[0] / 3;
            p[1] = c[1] / 3;
            p[2] = 0.5 + h;
            return;
        }
    }
    ck_abort_msg("no face on the wall");
}

/* may_cross for a point on the wall: the wall faces whose circumcircle
 * holds the point (its 2D cavity). */
struct cross_disc {
    const double *p;
    int calls;
};

static int cross_if_in_circle(void *arg, const tm_mesh *m, uint32_t t, int f)
{
    struct cross_disc *x = arg;
    x->calls++;
    const uint32_t *v = m->tets[t].v;
    const uint8_t *fv = tm_face_vtx[f];
    return pred_incircle3d_sos(tm_xyz(m, v[fv[0]]), tm_xyz(m, v[fv[1]]), tm_xyz(m, v[fv[2]]),
                               x->p) > 0;
}

static void assert_valid(const tm_mesh *m)
{
    vf_report r = {0};
    vf_check(m, VF_TOPOLOGY | VF_ORIENTATION | VF_HULL, &r);
    if (vf_defects(&r))
        vf_print(&r, stderr);
    ck_assert_uint_eq(vf_defects(&r), 0);
    for (uint32_t t = 0; t < m->nslots; t++)
        ck_assert(!(m->flags[t] & TM_F_CAVITY));
}

static size_t count_marks(const tm_mesh *m)
{
    size_t n = 0;
    for (uint32_t x = 0; x < m->nslots; x++)
        if (!tm_is_dead(m, x))
            for (int k = 0; k < 4; k++)
                n += (m->flags[x] & TM_F_FACEMARK(k)) != 0;
    return n;
}

START_TEST(constrained_cavity_stops_at_a_marked_face)
{
    tm_mesh m;
    wall_mesh(&m, 21, 5);
    size_t marks = count_marks(&m);
    ck_assert_uint_gt(marks, 100);
    uint32_t t, u;
    int f;
    double p[3];
    wall_face(&m, &t, &f, &u, p, 1e-3);
    uint32_t fv[3];
    for (int k = 0; k < 3; k++)
        fv[k] = m.tets[t].v[tm_face_vtx[f][k]];
    dt_cavity c;
    dt_cavity_init(&c);
    /* Ordinary: the cavity holds both t and u, it crosses the wall. */
    ck_assert_int_eq(dt_cavity_search(&m, p, t, 0, &c), 0);
    ck_assert_int_eq(c.status, DT_OK);
    ck_assert(in_list(c.tets, c.ntets, t));
    ck_assert(in_list(c.tets, c.ntets, u));
    size_t n0 = c.ntets;
    uint32_t *all = malloc(n0 * sizeof *all);
    memcpy(all, c.tets, n0 * sizeof *all);
    dt_cavity_abandon(&m, &c);

    /* Constrained, nothing may be crossed: the cavity stays above the
     * wall, part of the ordinary one, and face (t, f) bounds it. */
    struct cross_face none = {{0, 0, 0}, 0};
    c.may_cross = cross_if_face;
    c.cross_arg = &none;
    ck_assert_int_eq(dt_cavity_search(&m, p, t, DT_STOP_MARKED, &c), 0);
    ck_assert_int_eq(c.status, DT_OK);
    ck_assert(!in_list(c.tets, c.ntets, u));
    ck_assert_uint_lt(c.ntets, n0);
    for (size_t i = 0; i < c.ntets; i++) {
        ck_assert(in_list(all, n0, c.tets[i]));
        for (int s = 0; s < 4; s++) {
            uint32_t w = m.tets[c.tets[i]].v[s];
            ck_assert(w == TM_VINF || tm_xyz(&m, w)[2] >= 0.5);
        }
    }
    int stopped = 0;
    size_t nm = 0;
    for (size_t i = 0; i < c.nbnd; i++)
        if (c.bnd[i].reason == DT_BND_MARKED) {
            nm++;
            stopped += c.bnd[i].tet == t && c.bnd[i].face == f;
        }
    ck_assert_int_eq(stopped, 1);
    ck_assert_uint_eq(c.nmarked, nm);
    ck_assert_int_eq(none.calls, (int)nm);
    /* The cut cavity is a star; committed, the wall stays whole (its
     * marks move to the new tetrahedra, on both sides). */
    ck_assert(dt_cavity_is_star(&m, &c));
    uint32_t v;
    ck_assert_int_eq(tm_add_vertex(&m, p, &v), 0);
    ck_assert_int_eq(dt_cavity_commit(&m, v, &c), 0);
    ck_assert(!tm_is_dead(&m, u));
    ck_assert_uint_eq(count_marks(&m), marks);
    uint32_t t2;
    int f2;
    ck_assert(find_face(&m, fv[0], fv[1], fv[2], &t2, &f2));
    ck_assert_int_eq(tm_face_marker(&m, t2, f2), 5);
    tm_link l = m.tets[t2].n[f2];
    ck_assert_int_eq(tm_face_marker(&m, tm_ltet(l), tm_lface(l)), 5);
    assert_valid(&m);
    dt_cavity_free(&c);
    free(all);
    tm_free(&m);
}
END_TEST

START_TEST(constrained_cavity_crosses_the_face_it_splits)
{
    tm_mesh m;
    wall_mesh(&m, 22, 9);
    size_t marks = count_marks(&m);
    uint32_t t, u;
    int f;
    double p[3];
    wall_face(&m, &t, &f, &u, p, 0.0); /* p on the wall, in face f */
    uint32_t fv[3];
    for (int k = 0; k < 3; k++)
        fv[k] = m.tets[t].v[tm_face_vtx[f][k]];
    dt_cavity c;
    dt_cavity_init(&c);
    struct cross_disc allow = {p, 0};
    c.may_cross = cross_if_in_circle;
    c.cross_arg = &allow;
    ck_assert_int_eq(dt_cavity_search(&m, p, TM_NONE, DT_LOCATE | DT_STOP_MARKED, &c), 0);
    ck_assert_int_eq(c.status, DT_OK);
    ck_assert_int_ge(allow.calls, 1);
    /* Both sides of the split faces are in the cavity (so the same as the
     * ordinary cavity: every other wall face is outside p's circle, and so
     * are the tetrahedra on it). */
    ck_assert(in_list(c.tets, c.ntets, t));
    ck_assert(in_list(c.tets, c.ntets, u));
    ck_assert_uint_eq(c.nmarked, 0);
    ck_assert(dt_cavity_is_star(&m, &c));
    size_t split = 0;
    for (size_t i = 0; i < c.ntets; i++)
        for (int k = 0; k < 4; k++)
            split += (m.flags[c.tets[i]] & TM_F_FACEMARK(k)) != 0;
    ck_assert_uint_ge(split, 2);
    uint32_t v;
    ck_assert_int_eq(tm_add_vertex(&m, p, &v), 0);
    ck_assert_int_eq(dt_cavity_commit(&m, v, &c), 0);
    uint32_t t2;
    int f2;
    ck_assert(!find_face(&m, fv[0], fv[1], fv[2], &t2, &f2)); /* split */
    ck_assert_uint_eq(count_marks(&m), marks - split); /* the rest stays */
    assert_valid(&m);
    /* Without may_cross the same point stops at face f from either side:
     * no star (p lies on it), so a caller would not commit. */
    double q[3] = {p[0], p[1], p[2]};
    q[0] += 1e-9;
    dt_cavity_free(&c);
    tm_free(&m);
    wall_mesh(&m, 22, 9);
    dt_cavity_init(&c);
    ck_assert_int_eq(dt_cavity_search(&m, q, TM_NONE, DT_LOCATE | DT_STOP_MARKED, &c), 0);
    ck_assert_int_eq(c.status, DT_OK);
    ck_assert_uint_ge(c.nmarked, 1);
    ck_assert(!dt_cavity_is_star(&m, &c));
    dt_cavity_abandon(&m, &c);
    assert_valid(&m);
    dt_cavity_free(&c);
    tm_free(&m);
}
END_TEST

START_TEST(constrained_search_without_marks_changes_nothing)
{
    /* The same insertions into two copies of a mesh, one with plain
     * searches and one with DT_STOP_MARKED (no face marked): the same
     * cavities, the same new slots, the same mesh. */
    tm_mesh a, b;
    random_mesh(&a, 500, 23, TM_FEAT_MARKERS);
    random_mesh(&b, 500, 23, TM_FEAT_MARKERS);
    dt_cavity ca, cb;
    dt_cavity_init(&ca);
    dt_cavity_init(&cb);
    struct cross_face none = {{0, 0, 0}, 0};
    cb.may_cross = cross_if_face;
    cb.cross_arg = &none;
    rng_state = 99;
    for (int i = 0; i < 200; i++) {
        double p[3] = {rnd01(), rnd01(), rnd01()};
        ck_assert_int_eq(dt_cavity_search(&a, p, TM_NONE, DT_LOCATE, &ca), 0);
        ck_assert_int_eq(dt_cavity_search(&b, p, TM_NONE, DT_LOCATE | DT_STOP_MARKED, &cb), 0);
        ck_assert_int_eq(ca.status, DT_OK);
        ck_assert_int_eq(cb.status, DT_OK);
        ck_assert_uint_eq(cb.nmarked, 0);
        ck_assert_uint_eq(ca.ntets, cb.ntets);
        ck_assert_uint_eq(ca.nbnd, cb.nbnd);
        uint32_t va, vb;
        ck_assert_int_eq(tm_add_vertex(&a, p, &va), 0);
        ck_assert_int_eq(tm_add_vertex(&b, p, &vb), 0);
        ck_assert_int_eq(dt_cavity_commit(&a, va, &ca), 0);
        ck_assert_int_eq(dt_cavity_commit(&b, vb, &cb), 0);
        ck_assert_mem_eq(ca.newtets, cb.newtets, ca.nnew * sizeof *ca.newtets);
    }
    ck_assert_int_eq(none.calls, 0);
    ck_assert_uint_eq(a.nslots, b.nslots);
    ck_assert_mem_eq(a.tets, b.tets, a.nslots * sizeof *a.tets);
    assert_clean(&b);
    dt_cavity_free(&ca);
    dt_cavity_free(&cb);
    tm_free(&a);
    tm_free(&b);
}
END_TEST

START_TEST(markers_on_the_cavity_boundary_move_to_the_new_tets)
{
    /* Without DT_STOP_MARKED: a marked face on the boundary of an ordinary
     * cavity (the usual, slot-reusing commit) moves to the new tet, and the
     * subsegment bits of its edges too. */
    tm_mesh m;
    random_mesh(&m, 600, 13, TM_FEAT_MARKERS);
    dt_cavity c;
    dt_cavity_init(&c);
    double p[3] = {0.37, 0.61, 0.44};
    ck_assert_int_eq(dt_cavity_search(&m, p, TM_NONE, DT_LOCATE, &c), 0);
    const dt_bface *b = &c.bnd[c.nbnd / 2];
    uint32_t t = b->tet;
    int f = b->face;
    uint32_t fa = m.tets[t].v[tm_face_vtx[f][0]], fb = m.tets[t].v[tm_face_vtx[f][1]],
             fc = m.tets[t].v[tm_face_vtx[f][2]];
    dt_cavity_abandon(&m, &c);
    tm_mark_face(&m, t, f, 7);
    /* mark edge fa-fb as a subsegment in every tet around it */
    for (uint32_t u = 0; u < m.nslots; u++) {
        if (tm_is_dead(&m, u))
            continue;
        int sa = -1, sb = -1;
        for (int s2 = 0; s2 < 4; s2++) {
            if (m.tets[u].v[s2] == fa)
                sa = s2;
            if (m.tets[u].v[s2] == fb)
                sb = s2;
        }
        if (sa >= 0 && sb >= 0)
            m.flags[u] |= TM_F_SUBSEG(tm_edge_of[sa][sb]);
    }
    ck_assert_int_eq(dt_cavity_search(&m, p, TM_NONE, DT_LOCATE, &c), 0);
    uint32_t v;
    ck_assert_int_eq(tm_add_vertex(&m, p, &v), 0);
    ck_assert_int_eq(dt_cavity_commit(&m, v, &c), 0);
    uint32_t t2;
    int f2;
    ck_assert(find_face(&m, fa, fb, fc, &t2, &f2));
    ck_assert_int_eq(tm_face_marker(&m, t2, f2), 7);
    tm_link l = m.tets[t2].n[f2];
    ck_assert_int_eq(tm_face_marker(&m, tm_ltet(l), tm_lface(l)), 7);
    /* every live tet with edge fa-fb still has its subsegment bit */
    int around = 0;
    for (uint32_t u = 0; u < m.nslots; u++) {
        if (tm_is_dead(&m, u))
            continue;
        int sa = -1, sb = -1;
        for (int s2 = 0; s2 < 4; s2++) {
            if (m.tets[u].v[s2] == fa)
                sa = s2;
            if (m.tets[u].v[s2] == fb)
                sb = s2;
        }
        if (sa >= 0 && sb >= 0) {
            ck_assert(m.flags[u] & TM_F_SUBSEG(tm_edge_of[sa][sb]));
            around++;
        }
    }
    ck_assert_int_ge(around, 3);
    assert_clean(&m);
    dt_cavity_free(&c);
    tm_free(&m);
}
END_TEST

START_TEST(special_links_are_reported_once_each)
{
    tm_mesh m;
    random_mesh(&m, 400, 8, 0);
    /* Without ghosts, the hull faces become domain boundary faces. */
    tm_remove_ghosts(&m);
    ck_assert_uint_eq(m.nghost, 0);
    /* Turn one interior face into a remote face on both sides. */
    dt_cavity c;
    dt_cavity_init(&c);
    double p[3] = {0.5, 0.5, 0.5};
    ck_assert_int_eq(dt_cavity_search(&m, p, TM_NONE, DT_LOCATE, &c), 0);
    uint32_t t = c.located;
    dt_cavity_abandon(&m, &c);
    tm_link l = m.tets[t].n[0];
    ck_assert(!tm_is_special(l));
    m.tets[t].n[0] = TM_LINK_REMOTE(7);
    m.tets[tm_ltet(l)].n[tm_lface(l)] = TM_LINK_REMOTE(8);
    ck_assert_int_eq(dt_cavity_search(&m, p, t, 0, &c), 0);
    int remote = 0;
    for (size_t i = 0; i < c.nbnd; i++)
        if (c.bnd[i].reason == DT_BND_REMOTE) {
            ck_assert(c.bnd[i].outer == TM_LINK_REMOTE(7) || c.bnd[i].outer == TM_LINK_REMOTE(8));
            remote |= c.bnd[i].outer == TM_LINK_REMOTE(7) ? 1 : 2;
            ck_assert_uint_eq(c.bnd[i].tet, c.bnd[i].outer == TM_LINK_REMOTE(7) ? t : tm_ltet(l));
        }
    ck_assert_int_ne(remote, 0); /* each side reported at most once (bits) */
    /* nremote counts them, for callers that skip the boundary of a cavity
     * with none. */
    size_t nremote = 0;
    for (size_t i = 0; i < c.nbnd; i++)
        nremote += c.bnd[i].reason == DT_BND_REMOTE;
    ck_assert_uint_eq(c.nremote, nremote);
    ck_assert_uint_gt(c.nremote, 0);
    for (size_t i = 0; i < c.nbnd; i++)
        for (size_t j = 0; j < i; j++)
            ck_assert(c.bnd[i].tet != c.bnd[j].tet || c.bnd[i].face != c.bnd[j].face);
    dt_cavity_abandon(&m, &c);
    /* A point near a corner reaches the domain boundary. */
    double q[3] = {0.001, 0.002, 0.001};
    ck_assert_int_eq(dt_cavity_search(&m, q, m.vhint[1], DT_LOCATE, &c), 0);
    if (c.status == DT_OK) {
        int domain = 0;
        for (size_t i = 0; i < c.nbnd; i++)
            domain += c.bnd[i].reason == DT_BND_DOMAIN;
        ck_assert_int_gt(domain, 0);
        ck_assert_uint_eq(c.nremote, 0);
        dt_cavity_abandon(&m, &c);
    } else {
        ck_assert_int_eq(c.status, DT_OUTSIDE_DOMAIN);
    }
    vf_report r = {0};
    vf_check(&m, VF_TOPOLOGY, &r);
    ck_assert_uint_eq(r.remote_faces, 2);
    ck_assert_uint_gt(r.domain_faces, 0);
    dt_cavity_free(&c);
    tm_free(&m);
}
END_TEST

/* A search of p with flags in a mesh with no lock held: it finds a
 * cavity and holds at least nheld_min more locks than the cavity has
 * tetrahedra (DT_LOCK: their neighbours too), or none when nheld_min is
 * 0; abandoned, it leaves no lock behind. Returns the cavity's last
 * tetrahedron. */
static uint32_t search_then_unlocked(tm_mesh *m, dt_cavity *c, const double p[3], unsigned flags,
                                     size_t nheld_min)
{
    ck_assert_int_eq(dt_cavity_search(m, p, TM_NONE, flags, c), 0);
    ck_assert_int_eq(c->status, DT_OK);
    if (nheld_min)
        ck_assert_uint_ge(c->nheld, nheld_min + c->ntets);
    else
        ck_assert_uint_eq(c->nheld, 0);
    uint32_t t = c->tets[c->ntets - 1];
    dt_cavity_abandon(m, c);
    for (uint32_t u = 0; u < m->nslots; u++)
        ck_assert_uint_eq(m->lock[u], 0);
    return t;
}

START_TEST(locked_tets_block_the_search)
{
    tm_mesh m;
    random_mesh(&m, 300, 9, TM_FEAT_LOCKS);
    dt_cavity c;
    dt_cavity_init(&c);
    c.lock_owner = 1;
    double p[3] = {0.5, 0.5, 0.5};
    uint32_t t = search_then_unlocked(&m, &c, p, DT_LOCATE | DT_LOCK, 1);
    tm_set_lock(&m, t, 2); /* another cavity holds it */
    ck_assert_int_eq(dt_cavity_search(&m, p, TM_NONE, DT_LOCATE | DT_LOCK, &c), 0);
    ck_assert_int_eq(c.status, DT_LOCKED);
    ck_assert_uint_eq(c.blocker, t);
    dt_cavity_abandon(&m, &c);
    for (uint32_t u = 0; u < m.nslots; u++)
        ck_assert_uint_eq(m.lock[u], u == t ? 2 : 0);
    tm_set_lock(&m, t, 0);
    assert_clean(&m);
    dt_cavity_free(&c);
    tm_free(&m);
}
END_TEST

/* The memory accounting counts the lock summary bits: enabling locks on
 * a built mesh adds an owner word and a bit per slot (tm_bytes_per_tet),
 * and the owner words and the bit words of the slots in use
 * (tm_bytes_used). */
START_TEST(bytes_per_tet_count_the_lock_bits)
{
    tm_mesh m;
    random_mesh(&m, 300, 5, 0);
    ck_assert_double_eq(tm_bytes_per_tet(&m), (double)(sizeof(tm_tet) + sizeof(uint16_t)));
    double per = tm_bytes_per_tet(&m);
    size_t used = tm_bytes_used(&m), n = m.nslots;
    ck_assert_uint_gt(n, 64);
    ck_assert_int_eq(tm_enable(&m, TM_FEAT_LOCKS), 0);
    ck_assert_uint_eq(m.nslots, n);
    ck_assert_double_eq(tm_bytes_per_tet(&m) - per, 4.0 + 1.0 / 8.0);
    ck_assert_uint_eq(tm_bytes_used(&m) - used, 4 * n + (n + 63) / 64 * 8);
    tm_free(&m);
}
END_TEST

/* The summary bits of the locks (tm_is_locked) against the owners. */
static void assert_lock_bits(const tm_mesh *m)
{
    for (uint32_t t = 0; t < m->nslots; t++)
        ck_assert_int_eq(tm_is_locked(m, t), m->lock[t] != 0);
}

START_TEST(check_locks_reads_the_lock_bits)
{
    tm_mesh m;
    random_mesh(&m, 300, 11, TM_FEAT_LOCKS);
    dt_cavity c;
    dt_cavity_init(&c);
    c.lock_owner = 1;
    double p[3] = {0.5, 0.5, 0.5};
    /* Checking takes no lock. */
    uint32_t t = search_then_unlocked(&m, &c, p, DT_LOCATE | DT_CHECK_LOCKS, 0);
    assert_lock_bits(&m);
    /* Another owner's lock on a cavity tetrahedron blocks it; our own
     * does not. */
    tm_set_lock(&m, t, 2);
    assert_lock_bits(&m);
    ck_assert_int_eq(dt_cavity_search(&m, p, TM_NONE, DT_LOCATE | DT_CHECK_LOCKS, &c), 0);
    ck_assert_int_eq(c.status, DT_LOCKED);
    ck_assert_uint_eq(c.blocker, t);
    dt_cavity_abandon(&m, &c);
    tm_set_lock(&m, t, 1);
    ck_assert_int_eq(dt_cavity_search(&m, p, TM_NONE, DT_LOCATE | DT_CHECK_LOCKS, &c), 0);
    ck_assert_int_eq(c.status, DT_OK);
    dt_cavity_abandon(&m, &c);
    ck_assert_uint_eq(m.lock[t], 1);
    /* The bits follow every third tetrahedron locked through a growth of
     * the arrays, and a freed slot comes back unlocked. */
    for (uint32_t u = 0; u < m.nslots; u += 3)
        if (!tm_is_dead(&m, u))
            tm_set_lock(&m, u, 3 + u % 5);
    assert_lock_bits(&m);
    uint32_t slots = m.nslots;
    /* The arrays grow into memory that held other data (freed just
     * before, so that the allocator hands it out again): every slot up to
     * the new capacity must still read free, lock and bit alike, since
     * tm__take_slot clears a lock only where the bit says one is held. */
    size_t junk_n = 8 * (size_t)m.tcap;
    void *junk[8];
    for (int k = 0; k < 8; k++) {
        junk[k] = malloc(junk_n * sizeof(uint32_t));
        ck_assert_ptr_nonnull(junk[k]);
        memset(junk[k], 0xA5, junk_n * sizeof(uint32_t));
    }
    for (int k = 0; k < 8; k++)
        free(junk[k]);
    ck_assert_int_eq(tm_reserve(&m, m.nv, 8 * (size_t)m.tcap), 0);
    assert_lock_bits(&m);
    for (uint32_t u = slots; u < m.tcap; u++)
        ck_assert_uint_eq(m.lock[u], 0);
    uint32_t v = 0;
    while (v < slots && (tm_is_dead(&m, v) || !m.lock[v]))
        v++;
    ck_assert_uint_lt(v, slots);
    tm_free_tet(&m, v);
    ck_assert_uint_eq(tm_alloc_tet(&m), v);
    ck_assert_uint_eq(m.lock[v], 0);
    ck_assert_int_eq(tm_is_locked(&m, v), 0);
    /* New slots (the free list's, then past the old end) are free. */
    for (int i = 0; i < 200; i++) {
        uint32_t u = tm_alloc_tet(&m);
        ck_assert_int_eq(tm_is_locked(&m, u), 0);
        ck_assert_uint_eq(m.lock[u], 0);
    }
    assert_lock_bits(&m);
    dt_cavity_free(&c);
    tm_free(&m);
}
END_TEST

START_TEST(verifier_finds_corruption)
{
    tm_mesh m;
    random_mesh(&m, 300, 10, 0);
    assert_clean(&m);
    uint32_t t = 0;
    while (tm_is_dead(&m, t) || tm_is_ghost(&m, t))
        t++;
    /* Swapping two vertices inverts the tet and breaks its faces. */
    uint32_t x = m.tets[t].v[0];
    m.tets[t].v[0] = m.tets[t].v[1];
    m.tets[t].v[1] = x;
    vf_report r = {0};
    vf_check(&m, VF_ALL, &r);
    ck_assert_uint_eq(r.inverted, 1);
    ck_assert_uint_gt(r.face_mismatch, 0);
    m.tets[t].v[1] = m.tets[t].v[0];
    m.tets[t].v[0] = x;
    /* An asymmetric link. */
    tm_link saved = m.tets[t].n[2];
    m.tets[t].n[2] = m.tets[t].n[3];
    memset(&r, 0, sizeof r);
    vf_check(&m, VF_ALL, &r);
    ck_assert_uint_gt(r.bad_link, 0);
    m.tets[t].n[2] = saved;
    /* Moving a vertex breaks the Delaunay property (or orientation). */
    uint32_t v = m.tets[t].v[2];
    double keep[3];
    memcpy(keep, tm_xyz(&m, v), sizeof keep);
    m.xyz[3 * v] += 0.3;
    memset(&r, 0, sizeof r);
    vf_check(&m, VF_ALL, &r);
    ck_assert_uint_gt(r.not_delaunay + r.inverted + r.folded, 0);
    memcpy(m.xyz + 3 * v, keep, sizeof keep);
    /* Deleting a tet opens a hole: faces without neighbours. */
    assert_clean(&m);
    tm_delete_tet(&m, t);
    memset(&r, 0, sizeof r);
    vf_check(&m, VF_ALL, &r);
    ck_assert_uint_eq(r.domain_faces, 4);
    tm_free(&m);
}
END_TEST

START_TEST(link_faces_and_ghosts_rebuild_the_same_mesh)
{
    tm_mesh m;
    random_mesh(&m, 500, 11, 0);
    size_t tets = m.nlive - m.nghost, ghosts = m.nghost;
    tm_remove_ghosts(&m);
    for (uint32_t t = 0; t < m.nslots; t++)
        if (!tm_is_dead(&m, t))
            for (int i = 0; i < 4; i++)
                m.tets[t].n[i] = TM_LINK_UNSET;
    size_t bad = 9, open = 9;
    ck_assert_int_eq(tm_link_faces(&m, &bad), 0);
    ck_assert_uint_eq(bad, 0);
    ck_assert_int_eq(tm_add_ghosts(&m, &open), 0);
    ck_assert_uint_eq(open, 0);
    ck_assert_uint_eq(m.nghost, ghosts);
    ck_assert_uint_eq(m.nlive - m.nghost, tets);
    tm_rebuild_hints(&m);
    assert_clean(&m);
    /* ...and the rebuilt mesh takes further insertions. */
    dt_cavity c;
    dt_cavity_init(&c);
    double p[3] = {0.3, 0.3, 0.3};
    uint32_t v;
    ck_assert_int_eq(tm_add_vertex(&m, p, &v), 0);
    ck_assert_int_eq(dt_insert(&m, v, TM_NONE, &c), 0);
    assert_clean(&m);
    dt_cavity_free(&c);
    tm_free(&m);
}
END_TEST

START_TEST(hilbert_curve_steps_to_neighbours)
{
    /* Along the curve, consecutive cells of an 8x8x8 grid are adjacent. */
    static int cell[512][3];
    for (int x = 0; x < 8; x++)
        for (int y = 0; y < 8; y++)
            for (int z = 0; z < 8; z++) {
                uint64_t h = ss_hilbert3((uint32_t)x, (uint32_t)y, (uint32_t)z, 3);
                ck_assert_uint_lt(h, 512);
                cell[h][0] = x;
                cell[h][1] = y;
                cell[h][2] = z;
            }
    for (int i = 1; i < 512; i++) {
        int d = abs(cell[i][0] - cell[i - 1][0]) + abs(cell[i][1] - cell[i - 1][1]) +
                abs(cell[i][2] - cell[i - 1][2]);
        ck_assert_int_eq(d, 1);
    }
    /* BRIO gives a permutation. */
    double xyz[3 * 5000];
    rng_state = 12;
    for (int i = 0; i < 3 * 5000; i++)
        xyz[i] = rnd01();
    uint32_t order[5000];
    static unsigned char seen[5000];
    ck_assert_int_eq(ss_brio_hilbert(xyz, 5000, 1, 100, order), 0);
    for (int i = 0; i < 5000; i++) {
        ck_assert_uint_lt(order[i], 5000);
        ck_assert(!seen[order[i]]);
        seen[order[i]] = 1;
    }
}
END_TEST

/* ------------------------------------------------------------- flips */

/* Five points: triangle xyz in the plane z = 0, apexes p above and a
 * below it at height h; tets are (x y z p) and (y x z a), or the three
 * around edge pa; ghosts close the hull. */
static void bipyramid(tm_mesh *m, double h, int three, int mark)
{
    ck_assert_int_eq(tm_init(m, TM_FEAT_MARKERS), 0);
    add(m, 0, 0, 0);       /* 1 x */
    add(m, 1, 0, 0);       /* 2 y */
    add(m, 0, 1, 0);       /* 3 z */
    add(m, 0.3, 0.3, h);   /* 4 p */
    add(m, 0.3, 0.3, -h);  /* 5 a */
    static const uint32_t two[2][4] = {{1, 2, 3, 4}, {2, 1, 3, 5}};
    static const uint32_t thr[3][4] = {{1, 2, 4, 5}, {2, 3, 4, 5}, {3, 1, 4, 5}};
    int n = three ? 3 : 2;
    ck_assert_int_eq(tm_room(m, 16), 0);
    for (int i = 0; i < n; i++) {
        uint32_t t = tm_alloc_tet(m);
        memcpy(m->tets[t].v, three ? thr[i] : two[i], sizeof m->tets[t].v);
        if (pred_orient3d(m->xyz + 3 * m->tets[t].v[0], m->xyz + 3 * m->tets[t].v[1],
                          m->xyz + 3 * m->tets[t].v[2], m->xyz + 3 * m->tets[t].v[3]) < 0) {
            uint32_t x = m->tets[t].v[2];
            m->tets[t].v[2] = m->tets[t].v[3];
            m->tets[t].v[3] = x;
        }
        for (int k = 0; k < 4; k++)
            m->tets[t].n[k] = TM_LINK_NONE;
    }
    size_t bad;
    ck_assert_int_eq(tm_link_faces(m, &bad), 0);
    ck_assert_uint_eq(bad, 0);
    ck_assert_int_eq(tm_add_ghosts(m, &bad), 0);
    ck_assert_uint_eq(bad, 0);
    tm_rebuild_hints(m);
    if (mark) /* the face xyz between the two real tets */
        for (int k = 0; k < 4; k++)
            if (m->tets[0].v[k] == 4)
                tm_mark_face(m, 0, k, 7);
}

static size_t real_tets(const tm_mesh *m)
{
    size_t n = 0;
    for (uint32_t t = 0; t < m->nslots; t++)
        n += !tm_is_dead(m, t) && !tm_is_ghost(m, t);
    return n;
}

static size_t not_delaunay(const tm_mesh *m, unsigned extra)
{
    vf_report r;
    memset(&r, 0, sizeof r);
    ck_assert_int_eq(vf_check(m, VF_TOPOLOGY | VF_ORIENTATION | VF_DELAUNAY | VF_HULL | extra, &r), 0);
    ck_assert_uint_eq(r.bad_link + r.face_mismatch + r.inverted + r.flat + r.open_hull, 0);
    return r.not_delaunay;
}

START_TEST(flip23_makes_a_bipyramid_delaunay)
{
    tm_mesh m;
    bipyramid(&m, 0.05, 0, 0);
    ck_assert_uint_gt(not_delaunay(&m, 0), 0);
    uint32_t seed[2] = {0, 1};
    flip_out out;
    memset(&out, 0, sizeof out);
    ck_assert_int_eq(flip_restore(&m, seed, 2, NULL, &out, 0), 0);
    ck_assert_uint_eq(out.flips23, 1);
    ck_assert_uint_eq(out.stuck, 0);
    ck_assert_uint_eq(real_tets(&m), 3);
    ck_assert_uint_eq(not_delaunay(&m, 0), 0);
    check_counts(&m);
    free(out.tets);
    free(out.stuck_faces);
    tm_free(&m);
}
END_TEST

START_TEST(flip32_makes_a_bipyramid_delaunay)
{
    tm_mesh m;
    bipyramid(&m, 2.0, 1, 0);
    ck_assert_uint_gt(not_delaunay(&m, 0), 0);
    uint32_t seed[3] = {0, 1, 2};
    flip_out out;
    memset(&out, 0, sizeof out);
    ck_assert_int_eq(flip_restore(&m, seed, 3, NULL, &out, 0), 0);
    ck_assert_uint_eq(out.flips32, 1);
    ck_assert_uint_eq(real_tets(&m), 2);
    ck_assert_uint_eq(not_delaunay(&m, 0), 0);
    check_counts(&m);
    free(out.tets);
    free(out.stuck_faces);
    tm_free(&m);
}
END_TEST

/* A marked face is a constraint: never flipped, and not locally Delaunay
 * only in the unconstrained sense. */
START_TEST(flips_keep_marked_faces)
{
    tm_mesh m;
    bipyramid(&m, 0.05, 0, 1);
    uint32_t seed[2] = {0, 1};
    flip_out out;
    memset(&out, 0, sizeof out);
    ck_assert_int_eq(flip_restore(&m, seed, 2, NULL, &out, 0), 0);
    ck_assert_uint_eq(out.flips23 + out.flips32, 0);
    ck_assert_uint_eq(real_tets(&m), 2);
    ck_assert_uint_gt(not_delaunay(&m, 0), 0);
    ck_assert_uint_eq(not_delaunay(&m, VF_CONSTRAINED), 0);
    free(out.tets);
    free(out.stuck_faces);
    tm_free(&m);
}
END_TEST


static Suite *delaunay_suite(void)
{
    Suite *s = suite_create("delaunay");
    TCase *tc = tcase_create("build");
    tcase_set_timeout(tc, 120);
    tcase_add_test(tc, random_points);
    tcase_add_test(tc, grid_8x8x8);
    tcase_add_test(tc, points_on_a_sphere);
    tcase_add_test(tc, points_on_a_few_planes);
    tcase_add_test(tc, large_cavities_on_a_helix);
    tcase_add_test(tc, build_with_markers_and_locks);
    tcase_add_test(tc, marker_map_reads_as_a_dense_array);
    tcase_add_test(tc, duplicates_are_skipped_and_counted);
    tcase_add_test(tc, degenerate_inputs_are_refused);
    suite_add_tcase(s, tc);
    tc = tcase_create("insert");
    tcase_set_timeout(tc, 120);
    tcase_add_test(tc, search_then_abandon_leaves_the_mesh_unchanged);
    tcase_add_test(tc, cavity_shrink_takes_off_what_layer_by_layer_rounds_take);
    tcase_add_test(tc, single_insertions_inside_and_outside_the_hull);
    tcase_add_test(tc, marked_faces_stop_the_search_and_move_with_commit);
    tcase_add_test(tc, markers_on_the_cavity_boundary_move_to_the_new_tets);
    tcase_add_test(tc, constrained_cavity_stops_at_a_marked_face);
    tcase_add_test(tc, constrained_cavity_crosses_the_face_it_splits);
    tcase_add_test(tc, constrained_search_without_marks_changes_nothing);
    tcase_add_test(tc, special_links_are_reported_once_each);
    tcase_add_test(tc, locked_tets_block_the_search);
    tcase_add_test(tc, check_locks_reads_the_lock_bits);
    tcase_add_test(tc, bytes_per_tet_count_the_lock_bits);
    tcase_add_test(tc, flip23_makes_a_bipyramid_delaunay);
    tcase_add_test(tc, flip32_makes_a_bipyramid_delaunay);
    tcase_add_test(tc, flips_keep_marked_faces);
    suite_add_tcase(s, tc);
    tc = tcase_create("verify");
    tcase_set_timeout(tc, 120);
    tcase_add_test(tc, verifier_finds_corruption);
    tcase_add_test(tc, link_faces_and_ghosts_rebuild_the_same_mesh);
    tcase_add_test(tc, hilbert_curve_steps_to_neighbours);
    suite_add_tcase(s, tc);
    return s;
}

UNIT_MAIN(delaunay_suite)
