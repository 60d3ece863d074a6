/* Unit tests of the quality mesher: the subsegment/subfacet tables, the
 * cavity decision on hand-made cavities, the segment splitting rule, the
 * paper's d, the volume of a PLC, and whole runs whose results are
 * re-checked independently (exact verifier, tables against marks, facet
 * coverage and volume against the input). */
#include "config.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "refine/bd.h"
#include "mesh/dt.h"
#include "plc/dom.h"
#include "refine/im.h"
#include "check/mc.h"
#include "base/nf.h"
#include "plc/plc.h"
#include "refine/refine.h"
#include "refine/refine_int.h" /* ref__split_point */
#include "unit.h"
#include "base/v3.h"
#include "mesh/vf.h"

/* ------------------------------------------------------------- tables */

START_TEST(map_put_get_delete)
{
    hmap m;
    memset(&m, 0, sizeof m);
    /* many keys, some stored twice (a multimap), then half deleted */
    for (uint32_t i = 1; i <= 5000; i++) {
        ck_assert_int_eq(hmap_put(&m, (uint64_t)i * 7919u, i), 0);
        if (i % 10 == 0)
            ck_assert_int_eq(hmap_put(&m, (uint64_t)i * 7919u, i + 1000000u), 0);
    }
    ck_assert_uint_eq(m.n, 5500);
    for (uint32_t i = 1; i <= 5000; i += 2)
        ck_assert_int_eq(hmap_del(&m, (uint64_t)i * 7919u, i), 1);
    ck_assert_int_eq(hmap_del(&m, 12345u, 1), 0);
    for (uint32_t i = 1; i <= 5000; i++) {
        uint32_t v = hmap_get(&m, (uint64_t)i * 7919u);
        if (i % 2 == 0)
            ck_assert(v == i || v == i + 1000000u);
        else if (i % 10 == 0)
            ck_assert_uint_eq(v, i + 1000000u);
        else
            ck_assert_uint_eq(v, BD_NONE);
    }
    hmap_free(&m);
}
END_TEST

START_TEST(subfacet_and_subsegment_tables)
{
    bd_set b;
    bd_init(&b);
    uint32_t s0, s1, s2, g;
    /* two subfacets of facet 0 sharing edge 1-3, one of facet 1 on 2-3 */
    ck_assert_int_eq(bd_add_subfac(&b, 1, 2, 3, 0, &s0), 0);
    ck_assert_int_eq(bd_add_subfac(&b, 1, 3, 4, 0, &s1), 0);
    ck_assert_int_eq(bd_add_subfac(&b, 3, 2, 5, 1, &s2), 0);
    ck_assert_uint_eq(bd_find_subfac(&b, 3, 1, 2), s0);
    ck_assert_uint_eq(bd_find_subfac(&b, 4, 3, 1), s1);
    ck_assert_uint_eq(bd_find_subfac(&b, 1, 2, 4), BD_NONE);
    /* across the edge opposite vertex slot 1 (vertex 2: edge 3->1) */
    ck_assert_uint_eq(bd_subfac_across(&b, s0, 1), s1);
    /* edge 2-3 is shared with facet 1 only: no neighbour in facet 0 */
    ck_assert_uint_eq(bd_subfac_across(&b, s0, 0), BD_NONE);
    bd_kill_subfac(&b, s1);
    ck_assert_uint_eq(bd_subfac_across(&b, s0, 1), BD_NONE);
    ck_assert_uint_eq(b.live_facs, 2);
    ck_assert_int_eq(bd_add_subseg(&b, 9, 4, 7, &g), 0);
    ck_assert_uint_eq(bd_find_subseg(&b, 4, 9), g);
    ck_assert_uint_eq(b.segs[g].v[0], 4);
    ck_assert_uint_eq(b.segs[g].seg, 7);
    bd_kill_subseg(&b, g);
    ck_assert_uint_eq(bd_find_subseg(&b, 9, 4), BD_NONE);
    /* freed slots are reused */
    uint32_t g2;
    ck_assert_int_eq(bd_add_subseg(&b, 1, 2, 0, &g2), 0);
    ck_assert_uint_eq(g2, g);
    bd_free(&b);
}
END_TEST

/* --------------------------------------------------- cavity decisions */

static void add_seg(ref_marks *cm, const double a[3], const double b[3], int deleted)
{
    ref_mark *mk = &cm->m[cm->n++];
    memset(mk, 0, sizeof *mk);
    mk->nv = 2;
    mk->v[0] = (uint32_t)cm->n * 10;
    mk->v[1] = (uint32_t)cm->n * 10 + 1;
    memcpy(mk->x[0], a, sizeof mk->x[0]);
    memcpy(mk->x[1], b, sizeof mk->x[1]);
    mk->facet = -1;
    mk->deleted = (uint8_t)deleted;
}

static void add_fac(ref_marks *cm, const double a[3], const double b[3], const double c[3],
                    int facet, int deleted)
{
    ref_mark *mk = &cm->m[cm->n++];
    memset(mk, 0, sizeof *mk);
    mk->nv = 3;
    for (int k = 0; k < 3; k++)
        mk->v[k] = (uint32_t)cm->n * 10 + (uint32_t)k;
    memcpy(mk->x[0], a, sizeof mk->x[0]);
    memcpy(mk->x[1], b, sizeof mk->x[1]);
    memcpy(mk->x[2], c, sizeof mk->x[2]);
    mk->facet = facet;
    mk->deleted = (uint8_t)deleted;
}

/* A PLC with just the plane z = 0 as facet 0, all ref_decide reads. */
static plc_facet floor_facet = {.normal = {0, 0, 1}, .offset = 0, .axis = 2};
static plc floor_plc = {.nfacet = 1, .facets = &floor_facet};

static ref_mark mark_store[16];

START_TEST(decide_far_point_commits)
{
    ref_marks cm = {mark_store, 0, 16};
    double a[3] = {0, 0, 0}, b[3] = {2, 0, 0}, c[3] = {0, 2, 0};
    add_seg(&cm, a, b, 0);
    add_fac(&cm, a, b, c, 0, 0);
    double p[3] = {1, 1, 5};
    ref_decision d;
    ref_decide(&floor_plc, p, REF_TET, &cm, &d);
    ck_assert_int_eq(d.action, REF_COMMIT);
    ck_assert_int_eq(cm.m[0].encroached + cm.m[1].encroached, 0);
}
END_TEST

START_TEST(decide_subsegment_first)
{
    ref_marks cm = {mark_store, 0, 16};
    double a[3] = {0, 0, 0}, b[3] = {2, 0, 0}, c[3] = {0, 2, 0};
    add_fac(&cm, a, b, c, 0, 0);
    add_seg(&cm, a, b, 0);
    double p[3] = {1, 0.2, 0.3}; /* in the diametral ball and the equatorial ball */
    ref_decision d;
    ref_decide(&floor_plc, p, REF_TET, &cm, &d);
    ck_assert_int_eq(d.action, REF_SPLIT_SUBSEGS);
    ck_assert_int_eq(cm.m[1].encroached, 1);
    ck_assert_int_eq(cm.m[0].encroached, 1);
    ref_decide(&floor_plc, p, REF_SUBFACET, &cm, &d);
    ck_assert_int_eq(d.action, REF_SPLIT_SUBSEGS);
    /* a subsegment point is always inserted */
    ref_decide(&floor_plc, p, REF_SUBSEG, &cm, &d);
    ck_assert_int_eq(d.action, REF_COMMIT);
}
END_TEST

START_TEST(decide_deleted_counts_as_encroached)
{
    ref_marks cm = {mark_store, 0, 16};
    double a[3] = {0, 0, 0}, b[3] = {2, 0, 0};
    add_seg(&cm, a, b, 1);
    double p[3] = {1, 3, 0}; /* outside the diametral ball */
    ref_decision d;
    ref_decide(&floor_plc, p, REF_TET, &cm, &d);
    ck_assert_int_eq(d.action, REF_SPLIT_SUBSEGS);
}
END_TEST

START_TEST(decide_projection_lemma)
{
    /* p encroaches both subfacets; A is the larger, but p's projection
     * onto the facet lies in B, which is the one to split. */
    ref_marks cm = {mark_store, 0, 16};
    double a0[3] = {0, 0, 0}, a1[3] = {6, 0, 0}, a2[3] = {0, 6, 0};
    double b0[3] = {4, 2, 0}, b1[3] = {4, 4, 0}, b2[3] = {2, 4, 0};
    add_fac(&cm, a0, a1, a2, 0, 0);
    add_fac(&cm, b0, b1, b2, 0, 0);
    double p[3] = {3.5, 3.5, 0.5};
    ref_decision d;
    ref_decide(&floor_plc, p, REF_TET, &cm, &d);
    ck_assert_int_eq(d.action, REF_SPLIT_SUBFACET);
    ck_assert_uint_eq(d.nfac_encroached, 2);
    ck_assert_uint_eq(d.which, 1);
    /* with the projection in A, A */
    double q[3] = {1, 1, 0.5};
    ref_decide(&floor_plc, q, REF_TET, &cm, &d);
    ck_assert_int_eq(d.action, REF_SPLIT_SUBFACET);
    ck_assert_uint_eq(d.which, 0);
    /* a subfacet's circumcentre is inserted even if it encroaches
     * subfacets */
    ref_decide(&floor_plc, p, REF_SUBFACET, &cm, &d);
    ck_assert_int_eq(d.action, REF_COMMIT);
}
END_TEST

START_TEST(decide_coplanar_point_does_not_encroach)
{
    ref_marks cm = {mark_store, 0, 16};
    double a[3] = {0, 0, 0}, b[3] = {2, 0, 0}, c[3] = {0, 2, 0};
    add_fac(&cm, a, b, c, 0, 0);
    double p[3] = {0.5, 0.5, 0}; /* inside the circumcircle, in the plane */
    ref_decision d;
    ref_decide(&floor_plc, p, REF_TET, &cm, &d);
    ck_assert_int_eq(d.action, REF_COMMIT);
    p[2] = 1e-3;
    ref_decide(&floor_plc, p, REF_TET, &cm, &d);
    ck_assert_int_eq(d.action, REF_SPLIT_SUBFACET);
}
END_TEST

/* --------------------------------------------------- segment splitting */

START_TEST(split_point_shells)
{
    ref_mesher r;
    memset(&r, 0, sizeof r);
    ck_assert_int_eq(tm_init(&r.m, 0), 0);
    bd_init(&r.bd);
    double pa[3] = {0, 0, 0}, pb[3] = {3, 0, 0};
    uint32_t a, b;
    ck_assert_int_eq(tm_add_vertex(&r.m, pa, &a), 0);
    ck_assert_int_eq(tm_add_vertex(&r.m, pb, &b), 0);
    ck_assert_int_eq(bd_vertex_room(&r.bd, r.m.nv), 0);
    uint32_t acute[1] = {1};
    r.seg_acute = acute;
    r.bd.vkind[a] = BD_V_INPUT;
    r.bd.vfeat[a] = 0;
    r.bd.vkind[b] = BD_V_SEGMENT;
    double p[3];
    /* from the acute input vertex: the power of two nearest to half the
     * length (1.5 -> 2) */
    ref__split_point(&r, a, b, p);
    ck_assert(p[0] == 2.0 && p[1] == 0.0 && p[2] == 0.0);
    ref__split_point(&r, b, a, p);
    ck_assert(p[0] == 2.0);
    /* the acute vertex at the other end */
    r.bd.vkind[a] = BD_V_SEGMENT;
    r.bd.vkind[b] = BD_V_INPUT;
    ref__split_point(&r, a, b, p);
    ck_assert(p[0] == 1.0);
    /* no acute input vertex: the midpoint */
    acute[0] = 0;
    ref__split_point(&r, a, b, p);
    ck_assert(p[0] == 1.5);
    r.seg_acute = NULL;
    bd_free(&r.bd);
    tm_free(&r.m);
}
END_TEST

/* ------------------------------------------------- d and PLC volume */

static void cube_plc(plc *p)
{
    pdr_diag diag = {0};
    dom_cube_opts o;
    dom_cube_defaults(&o);
    ck_assert_int_eq(plc_init(p, "cube-in-cube"), 0);
    ck_assert_int_eq(dom_cube_in_cube(p, &o, &diag), 0);
    ck_assert_int_eq(plc_validate(p, &diag), 0);
    pdr_diag_free(&diag);
}

/* The initial mesh (im_build, conforming) of cube_plc into r, with o. */
static void cube_mo(plc *p, const ref_opts *o, ref_mesher *r)
{
    cube_plc(p);
    pdr_diag diag = {0};
    ck_assert_int_eq(ref_init(r, p, o), 0);
    im_opts io = {0, 0};
    ck_assert_int_eq(im_build(r, &io, NULL, &diag), 0);
    pdr_diag_free(&diag);
}

static void tee_plc(plc *p, double angle, double length, double width)
{
    pdr_diag diag = {0};
    dom_tee_opts o;
    dom_tee_defaults(&o);
    if (angle > 0) {
        o.angle = angle;
        o.length = length;
        o.width = width;
    }
    ck_assert_int_eq(plc_init(p, "tee"), 0);
    ck_assert_int_eq(dom_tee(p, &o, &diag), 0);
    ck_assert_int_eq(plc_validate(p, &diag), 0);
    pdr_diag_free(&diag);
}

START_TEST(paper_d_cube_in_cube)
{
    plc p;
    cube_plc(&p);
    /* the void's facets are 0.25 from the outer cube's */
    ck_assert_double_eq_tol(im_paper_d(&p), 0.25 / sqrt(2.0), 1e-15);
    plc_free(&p);
}
END_TEST

/* Side of the cube-in-cube domain at a point of a facet, found by looking
 * a little along the normal. */
static int inside_cic(const double x[3])
{
    for (int k = 0; k < 3; k++)
        if (x[k] <= 0 || x[k] >= 1)
            return 0;
    int in_void = 1;
    for (int k = 0; k < 3; k++)
        in_void &= x[k] > 0.25 && x[k] < 0.75;
    return !in_void;
}

static int cic_side(void *arg, size_t f, const double x[3])
{
    const plc *p = arg;
    double up[3], dn[3];
    for (int k = 0; k < 3; k++) {
        up[k] = x[k] + 1e-6 * p->facets[f].normal[k];
        dn[k] = x[k] - 1e-6 * p->facets[f].normal[k];
    }
    return inside_cic(dn) - inside_cic(up);
}

START_TEST(plc_volume_cube_in_cube)
{
    plc p;
    cube_plc(&p);
    ck_assert_double_eq_tol(mc_plc_volume(&p, cic_side, &p), 0.875, 1e-14);
    plc_free(&p);
}
END_TEST

/* -------------------------------------------------------- whole runs */

/* Meshes p with the given options and checks the result every way we
 * can: the tables against the marks, the bounds, the exact verifier on
 * the interior mesh, coverage and volume against the input. Returns the
 * number of interior tetrahedra. */
static size_t mesh_and_check(const plc *p, const ref_opts *o, const im_opts *io, int expect_clean)
{
    ref_mesher r;
    pdr_diag diag = {0};
    ck_assert_int_eq(ref_init(&r, p, o), 0);
    ck_assert_int_eq(im_build(&r, io, NULL, &diag), 0);
    ck_assert_uint_eq(ref_consistency(&r, stderr, 1), 0);
    ck_assert_int_eq(ref_refine(&r), 0);
    ck_assert_uint_eq(ref_consistency(&r, stderr, 1), 0);
    ref_count_bad(&r);
    if (expect_clean) {
        ck_assert_uint_eq(r.st.left_ratio, 0);
        ck_assert_uint_eq(r.st.left_size, 0);
    }
    /* every live subsegment and subfacet is in the mesh */
    for (uint32_t i = 0; i < r.bd.nsegs; i++)
        if (!(r.bd.segs[i].flags & BD_F_DEAD))
            ck_assert(!(r.bd.segs[i].flags & BD_F_MISSING));
    for (uint32_t i = 0; i < r.bd.nfacs; i++)
        if (!(r.bd.facs[i].flags & BD_F_DEAD))
            ck_assert(!(r.bd.facs[i].flags & BD_F_MISSING));
    /* the whole tetrahedralization, exterior included, is Delaunay */
    vf_report vr;
    memset(&vr, 0, sizeof vr);
    ck_assert_int_eq(vf_check(&r.m, VF_ALL, &vr), 0);
    if (vf_defects(&vr))
        vf_print(&vr, stderr);
    ck_assert_uint_eq(vf_defects(&vr), 0);
    /* the interior mesh on its own, against the input, exported as
     * 'pdr mesh' does: after the work memory is gone */
    ref_release_work(&r);
    ck_assert_uint_eq(ref_consistency(&r, stderr, 1), 0);
    ref_output copy, out;
    ck_assert_int_eq(ref_export(&r, &copy), 0);
    ck_assert_int_eq(ref_export_take(&r, &out), 0);
    ck_assert_uint_eq(r.m.nslots, 0);
    ck_assert_ptr_null(r.m.tets);
    /* the in-place export writes what the copying one writes */
    ck_assert_uint_eq(out.view.nt, copy.view.nt);
    ck_assert_uint_eq(out.view.nv, copy.view.nv);
    ck_assert_uint_eq(out.view.nf, copy.view.nf);
    ck_assert_int_eq(memcmp(out.tet, copy.tet, copy.view.nt * sizeof *copy.tet), 0);
    ck_assert_int_eq(memcmp(out.xyz, copy.xyz, copy.view.nv * sizeof *copy.xyz), 0);
    ck_assert_int_eq(memcmp(out.tri, copy.tri, copy.view.nf * sizeof *copy.tri), 0);
    ck_assert_int_eq(memcmp(out.tri_marker, copy.tri_marker,
                            copy.view.nf * sizeof *copy.tri_marker), 0);
    ck_assert_int_eq(!out.tet_region, !copy.tet_region);
    if (copy.tet_region)
        ck_assert_int_eq(memcmp(out.tet_region, copy.tet_region,
                                copy.view.nt * sizeof *copy.tet_region), 0);
    ref_output_free(&copy);
    const mesh_export *e = &out.view;
    ref_quality q;
    ref_quality_range(e, &q);
    if (expect_clean)
        ck_assert(q.re_max < o->ratio);
    tm_mesh m;
    ck_assert_int_eq(tm_init(&m, 0), 0);
    for (size_t i = 0; i < e->nv; i++) {
        uint32_t v;
        ck_assert_int_eq(tm_add_vertex(&m, e->xyz[i], &v), 0);
    }
    ck_assert_int_eq(tm_room(&m, e->nt), 0);
    for (size_t t = 0; t < e->nt; t++) {
        uint32_t s = tm_alloc_tet(&m);
        for (int k = 0; k < 4; k++) {
            m.tets[s].v[k] = e->tet[t][k] + 1;
            m.tets[s].n[k] = TM_LINK_NONE;
        }
    }
    size_t nonman;
    ck_assert_int_eq(tm_link_faces(&m, &nonman), 0);
    ck_assert_uint_eq(nonman, 0);
    mc_report mr;
    ck_assert_int_eq(mc_check(&m, e->tri, e->nf, p, &mr), 0);
    if (mc_defects(&mr))
        mc_print(&mr, stderr);
    ck_assert_uint_eq(mc_defects(&mr), 0);
    memset(&vr, 0, sizeof vr);
    ck_assert_int_eq(vf_check(&m, VF_TOPOLOGY | VF_ORIENTATION | VF_DELAUNAY, &vr), 0);
    ck_assert_uint_eq(vf_defects(&vr), 0);
    size_t nt = e->nt;
    tm_free(&m);
    ref_output_free(&out);
    ref_free(&r);
    pdr_diag_free(&diag);
    return nt;
}

/* xorshift64: the tests' reproducible random numbers. */
static uint64_t rng = 88172645463325252ULL;
static uint64_t next_rand(void)
{
    rng ^= rng << 13;
    rng ^= rng >> 7;
    rng ^= rng << 17;
    return rng;
}

static int edge_cmp(const void *pa, const void *pb)
{
    const uint32_t *a = pa, *b = pb;
    return a[0] != b[0] ? (a[0] < b[0] ? -1 : 1) : a[1] != b[1] ? (a[1] < b[1] ? -1 : 1) : 0;
}

/* Sorts n edges and drops repeats; returns how many are left. */
static size_t unique_edges(uint32_t (*e)[2], size_t n)
{
    qsort(e, n, sizeof *e, edge_cmp);
    size_t u = 0;
    for (size_t i = 0; i < n; i++)
        if (!u || edge_cmp(e[i], e[u - 1]))
            memcpy(e[u++], e[i], sizeof e[0]);
    return u;
}

/* ref_gather_marks lists every subsegment of a cavity once, however many
 * cavity tetrahedra share it: checked against a brute-force list on the
 * cavities of random points in the initial mesh, large ones included (the
 * set of listed subsegments grows past its first table). */
START_TEST(gather_lists_each_subsegment_once)
{
    plc p;
    ref_opts o;
    ref_default_opts(&o);
    ref_mesher r;
    cube_mo(&p, &o, &r);
    tm_mesh *m = &r.m;
    uint32_t start = 0;
    while (tm_is_dead(m, start) || tm_is_ghost(m, start))
        start++;
    size_t most = 0, cavities = 0;
    for (int trial = 0; trial < 400; trial++) {
        double x[3];
        for (int k = 0; k < 3; k++)
            x[k] = (double)(next_rand() >> 11) * 0x1p-53 * 1.2 - 0.1;
        ck_assert_int_eq(dt_cavity_search(m, x, start, DT_LOCATE, &r.cav), 0);
        if (r.cav.status != DT_OK) {
            dt_cavity_abandon(m, &r.cav);
            continue;
        }
        cavities++;
        ck_assert_int_eq(ref_gather_marks(m, &r.cav, &r.marks), 0);
        uint32_t(*want)[2] = malloc((6 * r.cav.ntets + 1) * sizeof *want);
        uint32_t(*got)[2] = malloc((r.marks.n + 1) * sizeof *got);
        ck_assert(want && got);
        size_t nw = 0, ng = 0;
        for (size_t i = 0; i < r.cav.ntets; i++) {
            uint32_t t = r.cav.tets[i];
            for (int e = 0; e < 6; e++)
                if (m->flags[t] & TM_F_SUBSEG(e)) {
                    uint32_t a = m->tets[t].v[tm_edge_vtx[e][0]];
                    uint32_t b = m->tets[t].v[tm_edge_vtx[e][1]];
                    want[nw][0] = a < b ? a : b;
                    want[nw][1] = a < b ? b : a;
                    nw++;
                }
        }
        nw = unique_edges(want, nw);
        for (size_t k = 0; k < r.marks.n; k++)
            if (r.marks.m[k].nv == 2) {
                ck_assert_uint_lt(r.marks.m[k].v[0], r.marks.m[k].v[1]);
                memcpy(got[ng++], r.marks.m[k].v, sizeof got[0]);
            }
        ck_assert_uint_eq(unique_edges(got, ng), ng); /* no repeats */
        ck_assert_uint_eq(ng, nw);
        for (size_t k = 0; k < ng; k++)
            ck_assert_int_eq(edge_cmp(got[k], want[k]), 0);
        if (ng > most)
            most = ng;
        free(want);
        free(got);
        dt_cavity_abandon(m, &r.cav);
    }
    ck_assert_uint_gt(cavities, 100);
    ck_assert_uint_gt(most, 16); /* the set (16 slots, half full at most) grew twice */
    ref_free(&r);
    plc_free(&p);
}
END_TEST

/* With busy_depth set (parallel runs), ref_next leaves a bad tetrahedron
 * near a locked one queued and hands out the others; once only busy ones
 * are left it returns 0 with them still queued, and after the unlock it
 * hands them out. */
START_TEST(busy_tetrahedra_wait)
{
    plc p;
    ref_opts o;
    ref_default_opts(&o);
    o.maxvol = 1e-4;
    o.order = REF_ORDER_FIFO; /* the parallel runs' order for remote work */
    ref_mesher r;
    cube_mo(&p, &o, &r);
    ck_assert_int_eq(tm_enable(&r.m, TM_FEAT_LOCKS), 0);
    ck_assert_int_eq(ref_queue_all_tets(&r), 0);
    int kind;
    uint32_t t0, id;
    float rmin;
    ck_assert_int_eq(ref_next(&r, &kind, &t0, &rmin), 1);
    ck_assert_int_eq(kind, REF_TET);
    ck_assert_int_eq(ref_requeue(&r, REF_TET, t0, 0), 0);
    /* Lock a neighbour of t0: t0 is busy at depth 1, not at depth 0. */
    uint32_t locked = UINT32_MAX;
    for (int k = 0; k < 4 && locked == UINT32_MAX; k++)
        if (!tm_is_special(r.m.tets[t0].n[k]))
            locked = tm_ltet(r.m.tets[t0].n[k]);
    ck_assert_uint_ne(locked, UINT32_MAX);
    tm_set_lock(&r.m, locked, 7);
    r.busy_depth = 1;
    size_t handed = 0;
    while (ref_next(&r, &kind, &id, &rmin)) {
        ck_assert_uint_ne(id, t0);
        ck_assert_uint_ne(id, locked);
        handed++;
    }
    ck_assert_uint_gt(handed, 10);
    ck_assert_uint_ge(r.st.deferred, 1);
    ck_assert(r.m.flags[t0] & TM_F_QUEUED);
    /* Still busy: nothing; unlocked: t0 comes out. */
    ck_assert_int_eq(ref_next(&r, &kind, &id, &rmin), 0);
    tm_set_lock(&r.m, locked, 0);
    ck_assert_int_eq(ref_next(&r, &kind, &id, &rmin), 1);
    ck_assert_uint_eq(id, t0);
    ref_free(&r);
    plc_free(&p);
}
END_TEST

/* The parallel hooks of a PE whose refinement step holds no cavity
 * (step_owner 0): a new vertex needs no global id here. */
static int stub_committed(void *arg, uint32_t v, const dt_cavity *c)
{
    (void)arg;
    (void)v;
    (void)c;
    return 0;
}

static uint32_t stub_owner(void *arg)
{
    return *(const uint32_t *)arg;
}

/* On a PE a constrained split of a subsegment leaves a tetrahedron that
 * another cavity in progress holds (its thread waiting for replies) as it
 * is: a setback, even when r->cav still carries that cavity's lock owner
 * (the PE's threads share r->cav, and the waiting thread's search was the
 * last one). Once the lock is gone the split is made. */
START_TEST(piece_split_respects_a_waiting_cavity)
{
    plc p;
    ref_opts o;
    ref_default_opts(&o);
    o.constrained = 1;
    ref_mesher r;
    cube_mo(&p, &o, &r);
    ck_assert(r.carved);
    ck_assert_int_eq(tm_enable(&r.m, TM_FEAT_LOCKS), 0);
    uint32_t own = 0;
    ref_hooks h;
    memset(&h, 0, sizeof h);
    h.committed = stub_committed;
    h.owner = stub_owner;
    h.arg = &own;
    r.hooks = &h;
    /* A present subsegment and a tetrahedron on its edge: the cavity of
     * its midpoint contains every tetrahedron around the edge. */
    uint32_t id = BD_NONE, t = TM_NONE;
    for (uint32_t i = 0; i < r.bd.nsegs && id == BD_NONE; i++) {
        const bd_subseg *S = &r.bd.segs[i];
        if (!(S->flags & (BD_F_DEAD | BD_F_MISSING)) &&
            ref__find_in_star(&r.m, S->v[0], S->v[1], TM_NONE, &t))
            id = i;
    }
    ck_assert_uint_ne(id, BD_NONE);
    const uint32_t waiting = 7; /* the owner of a cavity in progress */
    tm_set_lock(&r.m, t, waiting);
    r.cav.lock_owner = waiting;
    size_t nv = r.m.nv;
    ck_assert_int_eq(ref_step(&r, REF_SUBSEG, id, 0.0f), REF_SETBACK);
    ck_assert(!tm_is_dead(&r.m, t));
    ck_assert_uint_eq(r.m.nv, nv);
    tm_set_lock(&r.m, t, 0);
    ck_assert_int_eq(ref_step(&r, REF_SUBSEG, id, 0.0f), 0);
    ck_assert_uint_eq(r.m.nv, nv + 1);
    ck_assert(tm_is_dead(&r.m, t));
    r.hooks = NULL;
    ref_free(&r);
    plc_free(&p);
}
END_TEST

START_TEST(mesh_cube_in_cube)
{
    plc p;
    cube_plc(&p);
    ref_opts o;
    ref_default_opts(&o);
    o.maxvol = 0.002;
    im_opts io = {0, 0};
    size_t nt = mesh_and_check(&p, &o, &io, 1);
    ck_assert_uint_gt(nt, 500);
    plc_free(&p);
}
END_TEST

START_TEST(mesh_cube_in_cube_paper_mo)
{
    plc p;
    cube_plc(&p);
    ref_opts o;
    ref_default_opts(&o);
    ref_mesher r;
    pdr_diag diag = {0};
    ck_assert_int_eq(ref_init(&r, &p, &o), 0);
    im_opts io = {1, 0};
    im_stats st;
    ck_assert_int_eq(im_build(&r, &io, &st, &diag), 0);
    ck_assert_uint_eq(ref_consistency(&r, stderr, 1), 0);
    /* the paper's sizes: subsegments below 2d, subfacets below d sqrt 2 */
    double d = st.d;
    ck_assert_double_eq_tol(d, 0.25 / sqrt(2.0), 1e-15);
    for (uint32_t i = 0; i < r.bd.nsegs; i++) {
        const bd_subseg *s = &r.bd.segs[i];
        if (s->flags & BD_F_DEAD)
            continue;
        ck_assert(!(s->flags & BD_F_MISSING));
        const double *a = r.m.xyz + 3 * (size_t)s->v[0], *b = r.m.xyz + 3 * (size_t)s->v[1];
        ck_assert(sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                       (a[2] - b[2]) * (a[2] - b[2])) < 2 * d);
    }
    for (uint32_t i = 0; i < r.bd.nfacs; i++)
        if (!(r.bd.facs[i].flags & BD_F_DEAD))
            ck_assert(!(r.bd.facs[i].flags & BD_F_MISSING));
    ck_assert_double_eq_tol(im_interior_volume(&r), 0.875, 1e-12);
    ref_free(&r);
    pdr_diag_free(&diag);
    plc_free(&p);
}
END_TEST

START_TEST(mesh_tee)
{
    plc p;
    tee_plc(&p, 0, 0, 0);
    ref_opts o;
    ref_default_opts(&o);
    o.maxvol = 0.004;
    im_opts io = {0, 0};
    ck_assert_uint_gt(mesh_and_check(&p, &o, &io, 1), 1000);
    plc_free(&p);
}
END_TEST

START_TEST(mesh_rotated_cube)
{
    /* a cube turned about two axes: no facet is axis-aligned, so every
     * vertex on a facet is off its plane by rounding errors */
    plc p;
    ck_assert_int_eq(plc_init(&p, "rotated cube"), 0);
    double ca = cos(0.5), sa = sin(0.5), cb = cos(0.3), sb = sin(0.3);
    for (int i = 0; i < 8; i++) {
        double x = i & 1, y = (i >> 1) & 1, z = (i >> 2) & 1;
        double x1 = ca * x - sa * y, y1 = sa * x + ca * y;
        double y2 = cb * y1 - sb * z, z2 = sb * y1 + cb * z;
        double q[3] = {x1, y2, z2};
        ck_assert_int_eq(plc_add_vertex(&p, q, 0, NULL), 0);
    }
    static const uint32_t f[6][4] = {{0, 1, 3, 2}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                     {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 3, 7, 5}};
    for (int i = 0; i < 6; i++) {
        ck_assert_int_eq(plc_begin_facet(&p, 0, 0), 0);
        ck_assert_int_eq(plc_add_polygon(&p, f[i], 4, 0), 0);
    }
    pdr_diag diag = {0};
    ck_assert_int_eq(plc_validate(&p, &diag), 0);
    ref_opts o;
    ref_default_opts(&o);
    o.maxvol = 0.002;
    im_opts io = {0, 0};
    ck_assert_uint_gt(mesh_and_check(&p, &o, &io, 1), 500);
    pdr_diag_free(&diag);
    plc_free(&p);
}
END_TEST

/* The bound on splits of missing pieces (ref_bound_recovery): once the
 * refinement has split as many as the bound allows, the next missing piece
 * stops the run with PDR_ELIMIT, recovery_stuck and the piece's centroid
 * in stop_at, instead of going on (such splits cascading into each other
 * ran a parallel run of example.poly for ever). */
START_TEST(missing_piece_bound_stops)
{
    plc p;
    ref_opts o;
    ref_default_opts(&o);
    ref_mesher r;
    cube_mo(&p, &o, &r);
    ck_assert_int_eq(ref_run(&r, 0), 0); /* what im_build left queued */
    ref_bound_recovery(&r);
    size_t bound = REF_RECOVERY_PER_VERTEX * p.nv + REF_RECOVERY_BASE;
    ck_assert_uint_eq(r.recovery_limit, r.st.missing_recovered + bound);
    ck_assert_uint_eq(ref_recovery_splits(&r), 0);
    /* The bound spent: as many splits made as it allows. */
    r.st.missing_recovered = r.recovery_limit;
    ck_assert_uint_eq(ref_recovery_splits(&r), bound);
    /* A subfacet taken for missing and queued. */
    uint32_t g = 0;
    while (r.bd.facs[g].flags & BD_F_DEAD)
        g++;
    uint32_t v[3];
    memcpy(v, r.bd.facs[g].v, sizeof v);
    r.bd.facs[g].flags |= BD_F_MISSING;
    ck_assert_int_eq(ref_requeue(&r, REF_SUBFACET, g, 0.0f), 0);
    uint32_t nv = r.m.nv;
    ck_assert_int_eq(ref_run(&r, 0), PDR_ELIMIT);
    ck_assert_int_eq(r.recovery_stuck, 1);
    ck_assert_int_eq(r.stopped_below, 0);
    ck_assert_uint_eq(r.m.nv, nv); /* stopped before the split */
    for (int k = 0; k < 3; k++) {
        double c = 0;
        for (int i = 0; i < 3; i++)
            c += r.m.xyz[3 * (size_t)v[i] + (size_t)k] / 3.0;
        ck_assert_double_eq_tol(r.stop_at[k], c, 1e-12);
    }
    ref_free(&r);
    plc_free(&p);
}
END_TEST

START_TEST(small_angles_terminate)
{
    /* a 20-degree bevel and mitre: far below what the algorithm can
     * guarantee; the run must end with a conforming Delaunay mesh, the
     * tetrahedra left above the bound counted */
    plc p;
    tee_plc(&p, 20, 8, 2);
    ref_opts o;
    ref_default_opts(&o);
    o.maxvol = 0.02;
    im_opts io = {0, 0};
    ck_assert_uint_gt(mesh_and_check(&p, &o, &io, 0), 1000);
    plc_free(&p);
}
END_TEST

/* ---------------------------------------------------- debugging aids */

/* Builds Mo for p and refines it; *nv gets the number of vertices. */
static int refine_once(const plc *p, const ref_opts *o, uint32_t *nv)
{
    ref_mesher r;
    pdr_diag diag = {0};
    im_opts io = {0, 0};
    ck_assert_int_eq(ref_init(&r, p, o), 0);
    int rc = im_build(&r, &io, NULL, &diag);
    if (!rc)
        rc = ref_refine(&r);
    *nv = r.m.nv;
    ref_free(&r);
    pdr_diag_free(&diag);
    return rc;
}

/* The library's debugging aids are options (it reads no environment):
 * with check_each_step the marks are checked against the tables before
 * every step of both runs (recovery and quality); a sound run completes
 * with 0, the same mesh as without the check and nothing on the log; the
 * trace goes to the stream given. */
START_TEST(check_each_step_passes)
{
    plc p;
    cube_plc(&p);
    ref_opts o;
    ref_default_opts(&o);
    ck_assert_int_eq(o.check_each_step, 0);
    ck_assert_ptr_null(o.log);
    ck_assert_ptr_null(o.trace);
    o.maxvol = 0.01;
    uint32_t nv_plain, nv_checked;
    ck_assert_int_eq(refine_once(&p, &o, &nv_plain), 0);
    FILE *log = tmpfile(), *trace = tmpfile();
    ck_assert_ptr_nonnull(log);
    ck_assert_ptr_nonnull(trace);
    o.check_each_step = 1;
    o.log = log;
    o.trace = trace;
    o.trace_every = 100;
    ck_assert_int_eq(refine_once(&p, &o, &nv_checked), 0);
    ck_assert_uint_eq(nv_checked, nv_plain);
    ck_assert_int_eq(ftell(log), 0);
    ck_assert_int_gt(ftell(trace), 0);
    char line[256];
    rewind(trace);
    ck_assert_ptr_nonnull(fgets(line, sizeof line, trace));
    ck_assert_int_eq(strncmp(line, "trace ", 6), 0);
    fclose(trace);
    fclose(log);
    plc_free(&p);
}
END_TEST

/* A broken state (a face marked that is no subfacet) makes ref_run with
 * check_each_step return PDR_ETOPOLOGY, described on the log, instead of
 * ending the process; with no log, the error code alone. */
START_TEST(check_each_step_reports_broken_tables)
{
    plc p;
    ref_opts o;
    ref_default_opts(&o);
    ref_mesher r;
    cube_mo(&p, &o, &r);
    ck_assert_uint_eq(ref_consistency(&r, NULL, 0), 0);
    uint32_t t = 0;
    while (t < r.m.nslots && (!ref_is_interior(&r.m, t) || (r.m.flags[t] & TM_F_FACEMARKS)))
        t++;
    ck_assert_uint_lt(t, r.m.nslots);
    tm_mark_face(&r.m, t, 0, 1);
    ck_assert_uint_gt(ref_consistency(&r, NULL, 0), 0);
    FILE *log = tmpfile();
    ck_assert_ptr_nonnull(log);
    r.o.check_each_step = 1;
    r.o.log = log;
    ck_assert_int_eq(ref_run(&r, 1), PDR_ETOPOLOGY);
    rewind(log);
    char line[256];
    int no_subfacet = 0, disagree = 0;
    while (fgets(line, sizeof line, log)) {
        no_subfacet |= strstr(line, "is no live subfacet") != NULL;
        disagree |= strstr(line, "refinement tables disagree") != NULL;
    }
    ck_assert(no_subfacet && disagree);
    r.o.log = NULL;
    ck_assert_int_eq(ref_run(&r, 1), PDR_ETOPOLOGY);
    fclose(log);
    ref_free(&r);
    plc_free(&p);
}
END_TEST

/* ---------------------------------------------------- number format */

static void same_as_printf(double x)
{
    char want[64], got[NF_DOUBLE17_MAX];
    snprintf(want, sizeof want, "%.17g", x);
    size_t n = nf_double17(x, got);
    ck_assert_str_eq(got, want);
    ck_assert_uint_eq(n, strlen(want));
}

START_TEST(double17_matches_printf)
{
    static const double special[] = {0.0, -0.0, 1.0, -1.0, 0.5, 0.1, 0.001, 0.000999,
                                     1e16, 9999999999999998.0, 1234567890123456.25,
                                     0.59143204004695962, 3.1339745962155612, 1e-300,
                                     1e300, 0.3, 2.0 / 3.0, 1e15 + 0.5, 123.456};
    for (size_t i = 0; i < sizeof special / sizeof special[0]; i++)
        same_as_printf(special[i]);
    for (int i = 0; i < 30000; i++) {
        /* random bits (all magnitudes) and random values in [-8, 8] */
        uint64_t b = next_rand();
        double x;
        memcpy(&x, &b, sizeof x);
        if (isfinite(x))
            same_as_printf(x);
        x = ((double)(next_rand() >> 11) * 0x1p-53 - 0.5) * 16.0;
        same_as_printf(x);
        same_as_printf(x * 1e-3);
        same_as_printf(ldexp(x, (int)(next_rand() % 60) - 10));
    }
}
END_TEST

/* A sliver whose four vertices are cocircular but for rounding (two
 * mirror-image pairs whose mirror images were rounded apart), as a
 * parallel run on the triangulated cube made it: its circumcentre,
 * computed in floating point, is not inside its own circumball, and the
 * refinement used to leave it (radius-edge about 5) as degenerate. The
 * centre of one of its faces' circumcircles is inside the ball. */
START_TEST(flat_sliver_has_a_split_point)
{
    static const double sl[4][3] = {
        {-0.5, -0.8333333333333334, -1.0},
        {-0.5, -1.0, -0.8333333333333334},
        {-0.5833333333333334, -0.6130645371012478, -0.8015770679226383},
        {-0.5833333333333334, -0.8015770679226384, -0.6130645371012478},
    };
    tm_mesh m;
    ck_assert_int_eq(tm_init(&m, 0), 0);
    uint32_t v[4], u;
    for (int i = 0; i < 4; i++)
        ck_assert_int_eq(tm_add_vertex(&m, sl[i], &v[i]), 0);
    for (int i = 0; i < 8; i++) {
        double c[3] = {i & 1 ? 3 : -3, i & 2 ? 3 : -3, i & 4 ? 3 : -3};
        ck_assert_int_eq(tm_add_vertex(&m, c, &u), 0);
    }
    dt_build_opts bo = {.seed = 7};
    dt_build_stats bs;
    ck_assert_int_eq(dt_build(&m, &bo, &bs), 0);
    /* dt_build may renumber: find the sliver by its coordinates */
    uint32_t t = TM_NONE;
    for (uint32_t s = 0; s < m.nslots && t == TM_NONE; s++) {
        if (tm_is_dead(&m, s) || tm_is_ghost(&m, s))
            continue;
        int hits = 0;
        for (int k = 0; k < 4; k++)
            for (int i = 0; i < 4; i++)
                hits += !memcmp(m.xyz + 3 * (size_t)m.tets[s].v[k], sl[i], sizeof sl[i]);
        if (hits == 4)
            t = s;
    }
    ck_assert_uint_ne(t, TM_NONE);
    /* the circumcentre as the refinement computes it is unusable */
    const uint32_t *tv = m.tets[t].v;
    const double *a = m.xyz + 3 * (size_t)tv[0];
    double uu[3], vv[3], ww[3], n1[3], n2[3], n3[3], cc[3];
    double det = v3_tet_frame(a, m.xyz + 3 * (size_t)tv[1], m.xyz + 3 * (size_t)tv[2],
                              m.xyz + 3 * (size_t)tv[3], uu, vv, ww, n1, n2, n3);
    double l0 = v3_dot(uu, uu), l1 = v3_dot(vv, vv), l2 = v3_dot(ww, ww);
    for (int k = 0; k < 3; k++)
        cc[k] = a[k] + (l0 * n1[k] + l1 * n2[k] + l2 * n3[k]) * (0.5 / det);
    ck_assert(!(det > 0) || dt_conflict(&m, t, cc) <= 0);
    /* the fallback point is in conflict with it */
    double fc[3];
    ck_assert_int_eq(ref__flat_tet_centre(&m, t, fc), 0);
    ck_assert_int_gt(dt_conflict(&m, t, fc), 0);
    tm_free(&m);
}
END_TEST

static Suite *suite(void)
{
    Suite *s = suite_create("refine");
    TCase *t = tcase_create("tables");
    tcase_add_test(t, map_put_get_delete);
    tcase_add_test(t, subfacet_and_subsegment_tables);
    suite_add_tcase(s, t);
    t = tcase_create("decide");
    tcase_add_test(t, decide_far_point_commits);
    tcase_add_test(t, decide_subsegment_first);
    tcase_add_test(t, decide_deleted_counts_as_encroached);
    tcase_add_test(t, decide_projection_lemma);
    tcase_add_test(t, decide_coplanar_point_does_not_encroach);
    tcase_add_test(t, split_point_shells);
    tcase_add_test(t, flat_sliver_has_a_split_point);
    suite_add_tcase(s, t);
    t = tcase_create("numfmt");
    /* 120,000 conversions: seconds under the sanitizers on a busy machine */
    tcase_set_timeout(t, 60);
    tcase_add_test(t, double17_matches_printf);
    suite_add_tcase(s, t);
    t = tcase_create("plc");
    tcase_add_test(t, paper_d_cube_in_cube);
    tcase_add_test(t, plc_volume_cube_in_cube);
    suite_add_tcase(s, t);
    t = tcase_create("mesh");
    tcase_set_timeout(t, 120);
    tcase_add_test(t, gather_lists_each_subsegment_once);
    tcase_add_test(t, mesh_cube_in_cube);
    tcase_add_test(t, mesh_cube_in_cube_paper_mo);
    tcase_add_test(t, mesh_tee);
    tcase_add_test(t, busy_tetrahedra_wait);
    tcase_add_test(t, piece_split_respects_a_waiting_cavity);
    tcase_add_test(t, mesh_rotated_cube);
    tcase_add_test(t, small_angles_terminate);
    tcase_add_test(t, missing_piece_bound_stops);
    tcase_add_test(t, check_each_step_passes);
    tcase_add_test(t, check_each_step_reports_broken_tables);
    suite_add_tcase(s, t);
    return s;
}

UNIT_MAIN(suite)
