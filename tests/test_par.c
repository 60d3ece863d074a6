/* Unit tests of the parallel mesher's data path without the network:
 * Mo is decomposed (METIS) into the submesh messages of P PEs, every PE's
 * submesh is built from its message in this process and checked, the
 * submeshes are encoded back and merged, and the merged mesh must be Mo
 * again, tetrahedron for tetrahedron and in its exported form. The PLC and
 * options messages round-trip; every decoder refuses every truncation of
 * a small message and survives corrupted bytes (run under ASan with
 * ./configure --enable-sanitizers); the merge counts seams that do not
 * fit. */
#include "config.h"

#include <sched.h>

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "base/hdup.h"
#include "par/par_cav.h"
#include "mesh/vf.h"
#include "par/par_decomp.h"
#include "par/par_merge.h"
#include "par/par_sub.h"
#include "par/par_verify.h"
#include "par/par_wire.h"
#include "plc/dom.h"
#include "plc/plc.h"
#include "pr.h"
#include "refine/im.h"
#include "refine/refine.h"
#include "unit.h"

/* ------------------------------------------------------------- fixtures */

static void domain_plc(plc *p, int kind)
{
    pdr_diag diag = {0};
    ck_assert_int_eq(plc_init(p, dom_name(kind)), 0);
    ck_assert_int_eq(dom_build_default(p, kind, &diag), 0);
    ck_assert_int_eq(plc_validate(p, &diag), 0);
    pdr_diag_free(&diag);
}

/* The unit cube: eight vertices, six square facets. */
static void unit_cube_plc(plc *p)
{
    ck_assert_int_eq(plc_init(p, "unit cube"), 0);
    for (int i = 0; i < 8; i++) {
        double x[3] = {i & 1, (i >> 1) & 1, (i >> 2) & 1};
        ck_assert_int_eq(plc_add_vertex(p, x, 0, NULL), 0);
    }
    static const uint32_t f[6][4] = {{0, 1, 3, 2}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                     {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 3, 7, 5}};
    for (int i = 0; i < 6; i++) {
        ck_assert_int_eq(plc_begin_facet(p, i + 1, 0), 0);
        ck_assert_int_eq(plc_add_polygon(p, f[i], 4, 0), 0);
    }
    pdr_diag diag = {0};
    ck_assert_int_eq(plc_validate(p, &diag), 0);
    pdr_diag_free(&diag);
}

/* Mo for p, refined to about ntets interior tetrahedra (0: as built). */
static void build_mo(const plc *p, const ref_opts *o, size_t ntets, ref_mesher *mo)
{
    pdr_diag diag = {0};
    im_opts io = {0, 0};
    ck_assert_int_eq(ref_init(mo, p, o), 0);
    ck_assert_int_eq(im_build(mo, &io, NULL, &diag), 0);
    if (ntets)
        ck_assert_int_eq(im_mo_size(mo, ntets), 0);
    ref_release_work(mo);
    pdr_diag_free(&diag);
}

/* The gids the decomposition gives Mo's vertices. */
static uint64_t *mo_gids(const ref_mesher *mo)
{
    uint64_t *g = malloc((size_t)mo->m.nv * sizeof *g);
    ck_assert_ptr_nonnull(g);
    g[0] = PAR_GID_INF;
    for (uint32_t v = 1; v < mo->m.nv; v++)
        g[v] = pr_gid_make(0, v);
    return g;
}

/* --------------------------------------------- comparing two meshes */

typedef struct tet_rec {
    uint64_t key[4]; /* sorted gids */
    uint64_t g[4];   /* gids in the tetrahedron's own order */
    int32_t mk[4];
    uint16_t flags;
    uint16_t region;
} tet_rec;

static int cmp_rec(const void *a, const void *b)
{
    return memcmp(((const tet_rec *)a)->key, ((const tet_rec *)b)->key, 4 * sizeof(uint64_t));
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* Every live tetrahedron of r by gids, sorted. */
static tet_rec *tet_records(const ref_mesher *r, const uint64_t *gid, size_t *n)
{
    const tm_mesh *m = &r->m;
    tet_rec *a = calloc(m->nlive ? m->nlive : 1, sizeof *a);
    ck_assert_ptr_nonnull(a);
    size_t k = 0;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t))
            continue;
        ck_assert_uint_lt(k, m->nlive);
        tet_rec *x = &a[k++];
        for (int i = 0; i < 4; i++) {
            x->g[i] = x->key[i] = gid[m->tets[t].v[i]];
            x->mk[i] = tm_face_marker(m, t, i);
        }
        qsort(x->key, 4, sizeof x->key[0], cmp_u64);
        x->flags = m->flags[t] & (uint16_t)~TM_F_CAVITY;
        x->region = r->region ? r->region[t] : 0;
    }
    ck_assert_uint_eq(k, m->nlive);
    qsort(a, k, sizeof *a, cmp_rec);
    *n = k;
    return a;
}

/* The merged mesh holds exactly Mo's tetrahedra, vertices and boundary. */
static void same_as_mo(const ref_mesher *mo, const ref_mesher *mg)
{
    ck_assert_uint_eq(mg->m.nlive, mo->m.nlive);
    ck_assert_uint_eq(mg->m.nghost, mo->m.nghost);
    uint64_t *g = mo_gids(mo);
    size_t na, nb;
    tet_rec *a = tet_records(mo, g, &na), *b = tet_records(mg, mg->m.gid, &nb);
    ck_assert_uint_eq(na, nb);
    for (size_t k = 0; k < na; k++)
        ck_assert(!memcmp(&a[k], &b[k], sizeof a[k]));
    free(a);
    free(b);
    /* every vertex used is Mo's vertex of the same number (gids are
     * numbered in order), with its coordinates and history */
    ck_assert_uint_le(mg->m.nv, mo->m.nv);
    for (uint32_t v = 1; v < mg->m.nv; v++) {
        uint64_t x = mg->m.gid[v];
        ck_assert_uint_eq(pr_gid_rank(x), 0);
        uint32_t w = (uint32_t)pr_gid_seq(x);
        ck_assert_uint_lt(w, mo->m.nv);
        ck_assert(!memcmp(tm_xyz(&mg->m, v), tm_xyz(&mo->m, w), 3 * sizeof(double)));
        ck_assert_uint_eq(mg->bd.vkind[v], mo->bd.vkind[w]);
        ck_assert_uint_eq(mg->bd.vfeat[v], mo->bd.vfeat[w]);
        ck_assert(!memcmp(&mg->bd.vrins[v], &mo->bd.vrins[w], sizeof(float)));
    }
    /* the same live subsegments and subfacets, by gids */
    ck_assert_uint_eq(mg->bd.live_segs, mo->bd.live_segs);
    ck_assert_uint_eq(mg->bd.live_facs, mo->bd.live_facs);
    for (uint32_t i = 0; i < mg->bd.nsegs; i++) {
        const bd_subseg *s = &mg->bd.segs[i];
        if (s->flags & BD_F_DEAD)
            continue;
        uint32_t a0 = (uint32_t)pr_gid_seq(mg->m.gid[s->v[0]]),
                 a1 = (uint32_t)pr_gid_seq(mg->m.gid[s->v[1]]);
        uint32_t id = bd_find_subseg(&mo->bd, a0, a1);
        ck_assert_uint_ne(id, BD_NONE);
        ck_assert_uint_eq(mo->bd.segs[id].seg, s->seg);
        ck_assert_uint_eq(mo->bd.segs[id].flags & PAR_WIRE_BDFLAGS, s->flags);
    }
    for (uint32_t i = 0; i < mg->bd.nfacs; i++) {
        const bd_subfac *s = &mg->bd.facs[i];
        if (s->flags & BD_F_DEAD)
            continue;
        uint32_t x[3];
        for (int c = 0; c < 3; c++)
            x[c] = (uint32_t)pr_gid_seq(mg->m.gid[s->v[c]]);
        uint32_t id = bd_find_subfac(&mo->bd, x[0], x[1], x[2]);
        ck_assert_uint_ne(id, BD_NONE);
        ck_assert_uint_eq(mo->bd.facs[id].facet, s->facet);
        ck_assert(!memcmp(mo->bd.facs[id].v, x, sizeof x));
    }
    free(g);
}

/* A tetrahedron or triangle of an export by its corners' coordinates. */
typedef struct geo_rec {
    double c[12];
    int tag; /* region attribute or facet marker */
} geo_rec;

static int cmp_pt(const void *a, const void *b)
{
    const double *x = a, *y = b;
    for (int k = 0; k < 3; k++)
        if (x[k] != y[k])
            return x[k] < y[k] ? -1 : 1;
    return 0;
}

static int cmp_geo(const void *a, const void *b)
{
    const geo_rec *x = a, *y = b;
    for (int k = 0; k < 12; k++)
        if (x->c[k] != y->c[k])
            return x->c[k] < y->c[k] ? -1 : 1;
    return (x->tag > y->tag) - (x->tag < y->tag);
}

static geo_rec *geo_records(const mesh_export *e, int tets)
{
    size_t n = tets ? e->nt : e->nf;
    int nc = tets ? 4 : 3;
    geo_rec *a = calloc(n ? n : 1, sizeof *a);
    ck_assert_ptr_nonnull(a);
    for (size_t k = 0; k < n; k++) {
        for (int c = 0; c < nc; c++) {
            uint32_t v = tets ? e->tet[k][c] : e->tri[k][c];
            memcpy(a[k].c + 3 * c, e->xyz[v], 3 * sizeof(double));
        }
        qsort(a[k].c, (size_t)nc, 3 * sizeof(double), cmp_pt);
        a[k].tag = tets ? (e->tet_region ? e->tet_region[k] : 0)
                        : (e->tri_marker ? e->tri_marker[k] : 0);
    }
    qsort(a, n, sizeof *a, cmp_geo);
    return a;
}

/* ref_export of both gives the same mesh; so do the quality figures. */
static void same_export(ref_mesher *mo, ref_mesher *mg)
{
    ref_output a, b;
    ck_assert_int_eq(ref_export(mo, &a), 0);
    ck_assert_int_eq(ref_export(mg, &b), 0);
    ck_assert_uint_eq(a.view.nt, b.view.nt);
    ck_assert_uint_eq(a.view.nv, b.view.nv);
    ck_assert_uint_eq(a.view.nf, b.view.nf);
    for (int tets = 0; tets < 2; tets++) {
        geo_rec *x = geo_records(&a.view, tets), *y = geo_records(&b.view, tets);
        size_t n = tets ? a.view.nt : a.view.nf;
        for (size_t k = 0; k < n; k++)
            ck_assert(!cmp_geo(&x[k], &y[k]));
        free(x);
        free(y);
    }
    ref_quality qa, qb;
    ref_quality_range(&a.view, &qa);
    ref_quality_range(&b.view, &qb);
    ck_assert(!memcmp(&qa, &qb, sizeof qa));
    ref_count_bad(mo);
    ref_count_bad(mg);
    ck_assert_uint_eq(mo->st.left_ratio, mg->st.left_ratio);
    ck_assert_uint_eq(mo->st.left_size, mg->st.left_size);
    ck_assert_uint_eq(mo->st.left_sliver, mg->st.left_sliver);
    ref_output_free(&a);
    ref_output_free(&b);
}

/* ------------------------------------------------------- round trip */

/* Decomposes mo for P PEs into N parts, builds and checks every PE's
 * submesh, merges them back and compares with Mo. */
static void round_trip(ref_mesher *mo, uint32_t P, uint32_t N, int full_checks)
{
    const plc *p = mo->p;
    par_decomp d;
    ck_assert_int_eq(par_decomp_run(mo, P, N, 7, &d), 0);
    par_sub *subs = calloc(P, sizeof *subs);
    pr_buf *back = calloc(P, sizeof *back);
    ck_assert_ptr_nonnull(subs);
    ck_assert_ptr_nonnull(back);
    size_t total = 0, ghosts = 0;
    for (uint32_t k = 0; k < P; k++) {
        ck_assert_int_eq(par_wire_load(d.msg[k].data, d.msg[k].len, p, &mo->o, &subs[k]), 0);
        par_sub *s = &subs[k];
        ck_assert_uint_eq(s->rank, k);
        ck_assert_uint_eq(s->size, P);
        ck_assert_uint_eq(s->next_seq, k == 0 ? mo->m.nv : 1);
        ck_assert_uint_eq(s->r.m.nlive, d.tets[k]);
        ck_assert_uint_eq(s->live_ifc, d.ifaces[k]);
        ck_assert_int_eq(s->r.classified, 1);
        if (N >= P)
            ck_assert_uint_gt(s->r.m.nlive, 0);
        /* the marks agree with the bd tables on every PE, and every
         * facet triangulation is whole where the PE holds it */
        ck_assert_uint_eq(ref_consistency(&s->r, stderr, 1), 0);
        ck_assert_uint_eq(par_verify_facets(s, stderr), 0);
        total += s->r.m.nlive;
        ghosts += s->r.m.nghost;
        if (P == 1)
            ck_assert_uint_eq(s->live_ifc, 0);
    }
    ck_assert_uint_eq(total, mo->m.nlive);
    ck_assert_uint_eq(ghosts, mo->m.nghost);
    par_verify_report vr;
    memset(&vr, 0, sizeof vr);
    ck_assert_uint_eq(par_verify_all(subs, P, &vr), 0);
    /* A submesh built from its message and not refined encodes to the
     * same bytes: tetrahedra keep their order, vertices are sorted by
     * gid, and everything the message carried is kept. */
    for (uint32_t k = 0; k < P; k++) {
        ck_assert_int_eq(par_merge_encode(&back[k], &subs[k]), 0);
        ck_assert_uint_eq(back[k].len, d.msg[k].len);
        ck_assert(!memcmp(back[k].data, d.msg[k].data, back[k].len));
    }
    /* a PE's next vertex gid is new everywhere */
    for (uint32_t k = 0; k < P; k++) {
        uint64_t g = par_sub_new_gid(&subs[k]);
        for (uint32_t j = 0; j < P; j++)
            ck_assert_uint_eq(par_sub_find_vertex(&subs[j], g), TM_NONE);
    }
    const void **msg = calloc(P, sizeof *msg);
    size_t *len = calloc(P, sizeof *len);
    for (uint32_t k = 0; k < P; k++) {
        msg[k] = back[k].data;
        len[k] = back[k].len;
    }
    ref_mesher mg;
    par_merge_report rep;
    int rc = par_merge_build(msg, len, P, p, &mo->o, &mg, &rep);
    ck_assert_uint_eq(par_merge_problems(&rep), 0);
    ck_assert_int_eq(rc, 0);
    ck_assert_uint_eq(rep.tets, mo->m.nlive);
    ck_assert_int_eq(mg.classified, 1);
    same_as_mo(mo, &mg);
    ck_assert_uint_eq(ref_consistency(&mg, stderr, 1), 0);
    same_export(mo, &mg);
    if (full_checks) {
        vf_report vf;
        memset(&vf, 0, sizeof vf);
        ck_assert_int_eq(vf_check(&mg.m, VF_ALL, &vf), 0);
        if (vf_defects(&vf))
            vf_print(&vf, stderr);
        ck_assert_uint_eq(vf_defects(&vf), 0);
    }
    ref_free(&mg);
    for (uint32_t k = 0; k < P; k++) {
        par_sub_free(&subs[k]);
        pr_buf_free(&back[k]);
    }
    free(subs);
    free(back);
    free(msg);
    free(len);
    par_decomp_free(&d);
}

static void round_trips(int kind, size_t ntets)
{
    plc p;
    domain_plc(&p, kind);
    ref_opts o;
    ref_default_opts(&o);
    ref_mesher mo;
    build_mo(&p, &o, ntets, &mo);
    size_t interior = ref_interior_tets(&mo);
    ck_assert_uint_ge(interior, ntets / 2);
    ck_assert_uint_le(interior, 2 * ntets);
    static const uint32_t pes[] = {1, 2, 4, 7};
    for (size_t i = 0; i < sizeof pes / sizeof pes[0]; i++) {
        round_trip(&mo, pes[i], pes[i], i == 3);
        round_trip(&mo, pes[i], 4 * pes[i], 0);
    }
    /* fewer parts than PEs: PE 2 holds nothing, and that works too */
    round_trip(&mo, 3, 2, 0);
    ref_free(&mo);
    plc_free(&p);
}

START_TEST(round_trip_cube_in_cube)
{
    round_trips(DOM_CUBE_IN_CUBE, 10000);
}
END_TEST

START_TEST(round_trip_tee)
{
    round_trips(DOM_TEE, 8000);
}
END_TEST

/* The partition: parts as asked, ghosts with their hull neighbour, the
 * cut counted, a fixed seed repeatable. */
START_TEST(partition_properties)
{
    plc p;
    domain_plc(&p, DOM_CUBE_IN_CUBE);
    ref_mesher mo;
    build_mo(&p, NULL, 5000, &mo);
    const tm_mesh *m = &mo.m;
    uint32_t *a = malloc(m->nslots * sizeof *a), *b = malloc(m->nslots * sizeof *b);
    size_t cut = 0, cut2 = 0;
    ck_assert_int_eq(par_decomp_partition(&mo, 9, 3, a, &cut), 0);
    ck_assert_int_eq(par_decomp_partition(&mo, 9, 3, b, &cut2), 0);
    ck_assert(!memcmp(a, b, m->nslots * sizeof *a));
    ck_assert_uint_eq(cut, cut2);
    ck_assert_uint_gt(cut, 0);
    size_t count[9] = {0}, faces = 0;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t)) {
            ck_assert_uint_eq(a[t], PAR_PE_NONE);
            continue;
        }
        ck_assert_uint_lt(a[t], 9);
        count[a[t]]++;
        int k = tm_ghost_slot(m, t);
        if (k >= 0) {
            ck_assert_uint_eq(a[t], a[tm_ltet(m->tets[t].n[k])]);
            continue;
        }
        for (int i = 0; i < 4; i++) {
            uint32_t u = tm_ltet(m->tets[t].n[i]);
            faces += !tm_is_ghost(m, u) && u > t && a[u] != a[t];
        }
    }
    ck_assert_uint_eq(faces, cut);
    for (int q = 0; q < 9; q++)
        ck_assert_uint_gt(count[q], m->nlive / 30);
    /* one part: no METIS, no cut */
    ck_assert_int_eq(par_decomp_partition(&mo, 1, 3, a, &cut), 0);
    ck_assert_uint_eq(cut, 0);
    ck_assert_int_eq(par_decomp_partition(&mo, 0, 3, a, &cut), PDR_EINVAL);
    free(a);
    free(b);
    ref_free(&mo);
    plc_free(&p);
}
END_TEST

/* ----------------------------------------------------- PLC and options */

/* A box with a chimney: the box's top is an annulus (a facet hole), a
 * free segment inside, vertex attributes and markers, a region. */
static const char chimney_poly[] =
    "18 3 1 1\n"
    "1 0 0 0 0.5 1\n2 2 0 0 0.5 1\n3 2 2 0 0.5 1\n4 0 2 0 0.5 1\n"
    "5 0 0 2 1.5 2\n6 2 0 2 1.5 2\n7 2 2 2 1.5 2\n8 0 2 2 1.5 2\n"
    "9 0.5 0.5 2 2 3\n10 1.5 0.5 2 2 3\n11 1.5 1.5 2 2 3\n12 0.5 1.5 2 2 3\n"
    "13 0.5 0.5 3 3 4\n14 1.5 0.5 3 3 4\n15 1.5 1.5 3 3 4\n16 0.5 1.5 3 3 4\n"
    "17 0.5 0.5 0.5 9 5\n18 1.5 1.5 1 9 5\n"
    "12 1\n"
    "1 0 1\n4 1 2 3 4\n"
    "1 0 2\n4 1 2 6 5\n"
    "1 0 2\n4 2 3 7 6\n"
    "1 0 2\n4 3 4 8 7\n"
    "1 0 2\n4 4 1 5 8\n"
    "2 1 3\n4 5 6 7 8\n4 9 10 11 12\n1 1 1 2\n"
    "1 0 4\n4 9 10 14 13\n"
    "1 0 4\n4 10 11 15 14\n"
    "1 0 4\n4 11 12 16 15\n"
    "1 0 4\n4 12 9 13 16\n"
    "1 0 5\n4 13 14 15 16\n"
    "1 0 6\n2 17 18\n"
    "0\n"
    "1\n1 1.8 1.8 1.8 7 0.25\n";

/* Reads text as a .poly from a fresh temporary directory. */
static void read_poly(plc *p, const char *text, char *dir, size_t dirsz)
{
    snprintf(dir, dirsz, "/tmp/test_par.XXXXXX");
    ck_assert_ptr_nonnull(mkdtemp(dir));
    char path[256];
    snprintf(path, sizeof path, "%s/in.poly", dir);
    FILE *f = fopen(path, "w");
    ck_assert_ptr_nonnull(f);
    fputs(text, f);
    ck_assert_int_eq(fclose(f), 0);
    pdr_diag diag = {0};
    ck_assert_int_eq(plc_init(p, NULL), 0);
    int rc = plc_read(p, path, &diag);
    if (!rc)
        rc = plc_validate(p, &diag);
    if (rc)
        pdr_diag_print(&diag, stderr);
    ck_assert_int_eq(rc, 0);
    pdr_diag_free(&diag);
    unlink(path);
}

static char *slurp(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    ck_assert_ptr_nonnull(f);
    char *s = malloc(1 << 20);
    ck_assert_ptr_nonnull(s);
    *n = fread(s, 1, 1 << 20, f);
    fclose(f);
    return s;
}

/* memcmp of n bytes, n may be 0 (then a pointer may be NULL). */
static int same_bytes(const void *a, const void *b, size_t n)
{
    return n == 0 || !memcmp(a, b, n);
}

/* plc_segment has padding: compare it field by field. */
static void same_segments(const plc_segment *a, const plc_segment *b, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        ck_assert_uint_eq(a[i].v[0], b[i].v[0]);
        ck_assert_uint_eq(a[i].v[1], b[i].v[1]);
        ck_assert_int_eq(a[i].marker, b[i].marker);
        ck_assert_int_eq(a[i].line, b[i].line);
    }
}

/* Writes both as .poly and compares the files; compares the fields. */
static void same_plc(const plc *a, const plc *b, const char *dir)
{
    ck_assert_str_eq(a->path, b->path);
    ck_assert_str_eq(a->vfile, b->vfile);
    ck_assert_int_eq(a->base, b->base);
    ck_assert(a->planar_tol == b->planar_tol);
    ck_assert_uint_eq(a->nv, b->nv);
    ck_assert(same_bytes(a->xyz, b->xyz, a->nv * sizeof a->xyz[0]));
    ck_assert(same_bytes(a->vline, b->vline, a->nv * sizeof a->vline[0]));
    ck_assert_int_eq(!a->vmarker, !b->vmarker);
    if (a->vmarker)
        ck_assert(same_bytes(a->vmarker, b->vmarker, a->nv * sizeof a->vmarker[0]));
    ck_assert_int_eq(!a->vattr, !b->vattr);
    if (a->vattr) {
        ck_assert_uint_eq(a->nvattr, b->nvattr);
        ck_assert(same_bytes(a->vattr, b->vattr, a->nv * a->nvattr * sizeof a->vattr[0]));
    }
    ck_assert_uint_eq(a->ncorner, b->ncorner);
    ck_assert(same_bytes(a->corners, b->corners, a->ncorner * sizeof a->corners[0]));
    ck_assert_uint_eq(a->npoly, b->npoly);
    for (size_t q = 0; q < a->npoly; q++) {
        ck_assert_uint_eq(a->polys[q].first, b->polys[q].first);
        ck_assert_uint_eq(a->polys[q].n, b->polys[q].n);
        ck_assert_int_eq(a->polys[q].line, b->polys[q].line);
    }
    ck_assert_uint_eq(a->nfacet, b->nfacet);
    for (size_t f = 0; f < a->nfacet; f++) {
        const plc_facet *x = &a->facets[f], *y = &b->facets[f];
        ck_assert_uint_eq(x->poly_first, y->poly_first);
        ck_assert_uint_eq(x->npoly, y->npoly);
        ck_assert_uint_eq(x->hole_first, y->hole_first);
        ck_assert_uint_eq(x->nhole, y->nhole);
        ck_assert_int_eq(x->marker, y->marker);
        ck_assert_int_eq(x->line, y->line);
        ck_assert(same_bytes(x->normal, y->normal, sizeof x->normal));
    }
    ck_assert_uint_eq(a->nfhole, b->nfhole);
    ck_assert(same_bytes(a->fholes, b->fholes, a->nfhole * sizeof a->fholes[0]));
    ck_assert_uint_eq(a->nsegin, b->nsegin);
    same_segments(a->segin, b->segin, a->nsegin);
    ck_assert_uint_eq(a->nhole, b->nhole);
    ck_assert(same_bytes(a->holes, b->holes, a->nhole * sizeof a->holes[0]));
    ck_assert_uint_eq(a->nregion, b->nregion);
    ck_assert(same_bytes(a->regions, b->regions, a->nregion * sizeof a->regions[0]));
    ck_assert_int_eq(b->derived, 1);
    ck_assert_uint_eq(a->nseg, b->nseg);
    same_segments(a->segs, b->segs, a->nseg);
    ck_assert(same_bytes(a->ftri_start, b->ftri_start, (a->nfacet + 1) * sizeof a->ftri_start[0]));
    char pa[256], pb[256];
    snprintf(pa, sizeof pa, "%s/a.poly", dir);
    snprintf(pb, sizeof pb, "%s/b.poly", dir);
    pdr_diag diag = {0};
    ck_assert_int_eq(plc_write_poly(a, pa, &diag), 0);
    ck_assert_int_eq(plc_write_poly(b, pb, &diag), 0);
    size_t na, nb;
    char *ta = slurp(pa, &na), *tb = slurp(pb, &nb);
    ck_assert_uint_eq(na, nb);
    ck_assert(same_bytes(ta, tb, na));
    free(ta);
    free(tb);
    unlink(pa);
    unlink(pb);
    pdr_diag_free(&diag);
}

static void plc_round_trip(const plc *a, const char *dir)
{
    pr_buf b = PR_BUF_INIT;
    ck_assert_int_eq(par_decomp_plc_put(&b, a), 0);
    plc c;
    pdr_diag diag = {0};
    ck_assert_int_eq(par_decomp_plc_decode(b.data, b.len, &c, &diag), 0);
    same_plc(a, &c, dir);
    plc_free(&c);
    pdr_diag_free(&diag);
    pr_buf_free(&b);
}

START_TEST(plc_round_trips)
{
    char dir[64];
    plc a;
    read_poly(&a, chimney_poly, dir, sizeof dir);
    ck_assert_uint_eq(a.nfhole, 1);
    ck_assert_uint_eq(a.nsegin, 1);
    ck_assert_ptr_nonnull(a.vattr);
    ck_assert_ptr_nonnull(a.vmarker);
    plc_round_trip(&a, dir);
    plc_free(&a);
    for (int kind = 0; kind < DOM_COUNT; kind++) {
        domain_plc(&a, kind);
        plc_round_trip(&a, dir);
        plc_free(&a);
    }
    rmdir(dir);
}
END_TEST

START_TEST(opts_round_trip)
{
    ref_opts o, r;
    ref_default_opts(&o);
    o.ratio = 1.4142135623730951;
    o.maxvol = 1e-3;
    o.maxedge = 0.25;
    o.min_dihedral = 12.5;
    o.seg_maxlen = 0.125;
    o.fac_maxrad = 0.0625;
    o.rho = 0.3;
    o.use_region_maxvol = 0;
    o.order = REF_ORDER_FIFO;
    o.constrained = 1;
    o.keep_stuck = 1;
    pr_buf b = PR_BUF_INIT;
    ck_assert_int_eq(par_decomp_opts_put(&b, &o), 0);
    ck_assert_int_eq(par_decomp_opts_decode(b.data, b.len, &r), 0);
    ck_assert(!memcmp(&o, &r, sizeof o));
    for (size_t n = 0; n < b.len; n++)
        ck_assert_int_eq(par_decomp_opts_decode(b.data, n, &r), PDR_EPARSE);
    o.order = 7;
    pr_buf_reset(&b);
    ck_assert_int_eq(par_decomp_opts_put(&b, &o), PDR_EINVAL);
    o.order = REF_ORDER_LIFO;
    o.rho = NAN;
    ck_assert_int_eq(par_decomp_opts_put(&b, &o), PDR_EINVAL);
    pr_buf_free(&b);
}
END_TEST

/* ------------------------------------------- malformed messages */

/* Decodes (and, when it decodes, builds and checks) msg[0..len); must
 * never crash. Returns 1 if it decoded. */
static int try_submesh(const uint8_t *msg, size_t len, const plc *p)
{
    par_wire w;
    int rc = par_wire_decode(msg, len, p, &w);
    if (rc) {
        ck_assert(rc == PDR_EPARSE || rc == PDR_ENOMEM);
        ck_assert_ptr_null(w.sm);
        return 0;
    }
    par_sub s;
    if (par_wire_build(&w, p, NULL, &s) == 0) {
        par_verify_report vr;
        memset(&vr, 0, sizeof vr);
        par_verify_sub(&s, &vr);
        ck_assert_uint_eq(vr.bad_remote + vr.stale_ifaces + vr.bad_vertices + vr.bad_counts, 0);
        pr_buf b = PR_BUF_INIT;
        par_wire_encode_sub(&b, &s);
        pr_buf_free(&b);
        par_sub_free(&s);
    }
    par_wire_clear(&w);
    return 1;
}

/* bad = src with 1-8 random bytes at a random place (xorshift state *x). */
static void damage_stretch(uint8_t *bad, const uint8_t *src, size_t len, uint64_t *x)
{
    memcpy(bad, src, len);
    *x ^= *x << 13, *x ^= *x >> 7, *x ^= *x << 17;
    size_t at = *x % len, n = 1 + (*x >> 32) % 8;
    for (size_t j = at; j < at + n && j < len; j++) {
        *x ^= *x << 13, *x ^= *x >> 7, *x ^= *x << 17;
        bad[j] = (uint8_t)*x;
    }
}

START_TEST(submesh_decoder_refuses_truncation)
{
    plc p;
    unit_cube_plc(&p);
    ref_mesher mo;
    build_mo(&p, NULL, 0, &mo);
    par_decomp d;
    ck_assert_int_eq(par_decomp_run(&mo, 2, 2, 1, &d), 0);
    for (int k = 0; k < 2; k++) {
        const uint8_t *msg = d.msg[k].data;
        size_t len = d.msg[k].len;
        ck_assert_int_eq(try_submesh(msg, len, &p), 1);
        for (size_t n = 0; n < len; n++) {
            par_wire w;
            ck_assert_int_eq(par_wire_decode(msg, n, &p, &w), PDR_EPARSE);
            ck_assert_ptr_null(w.sm);
            par_sub s;
            ck_assert_int_ne(par_wire_load(msg, n, &p, NULL, &s), 0);
        }
        /* one byte too many */
        uint8_t *longer = malloc(len + 1);
        memcpy(longer, msg, len);
        longer[len] = 0;
        par_wire w;
        ck_assert_int_eq(par_wire_decode(longer, len + 1, &p, &w), PDR_EPARSE);
        free(longer);
    }
    par_decomp_free(&d);
    ref_free(&mo);
    plc_free(&p);
}
END_TEST

START_TEST(submesh_decoder_survives_corruption)
{
    plc p;
    unit_cube_plc(&p);
    ref_mesher mo;
    build_mo(&p, NULL, 0, &mo);
    par_decomp d;
    ck_assert_int_eq(par_decomp_run(&mo, 2, 2, 1, &d), 0);
    const uint8_t *msg = d.msg[1].data;
    size_t len = d.msg[1].len;
    uint8_t *bad = malloc(len);
    size_t decoded = 0;
    static const uint8_t flips[] = {0xff, 0x01, 0x80, 0x10};
    for (size_t i = 0; i < len; i++)
        for (size_t f = 0; f < sizeof flips; f++) {
            memcpy(bad, msg, len);
            bad[i] ^= flips[f];
            decoded += (size_t)try_submesh(bad, len, &p);
        }
    /* random bytes over random stretches */
    uint64_t x = 88172645463325252ULL;
    for (int round = 0; round < 3000; round++) {
        damage_stretch(bad, msg, len, &x);
        decoded += (size_t)try_submesh(bad, len, &p);
    }
    /* coordinates and radii are free to change: some copies decode */
    ck_assert_uint_gt(decoded, 0);
    free(bad);
    par_decomp_free(&d);
    ref_free(&mo);
    plc_free(&p);
}
END_TEST

START_TEST(plc_decoder_refuses_malformed)
{
    plc p;
    unit_cube_plc(&p);
    pr_buf b = PR_BUF_INIT;
    ck_assert_int_eq(par_decomp_plc_put(&b, &p), 0);
    plc q;
    pdr_diag diag = {0};
    for (size_t n = 0; n < b.len; n++) {
        ck_assert_int_eq(par_decomp_plc_decode(b.data, n, &q, &diag), PDR_EPARSE);
        plc_free(&q);
    }
    uint8_t *bad = malloc(b.len);
    static const uint8_t flips[] = {0xff, 0x01, 0x80};
    for (size_t i = 0; i < b.len; i++)
        for (size_t f = 0; f < sizeof flips; f++) {
            memcpy(bad, b.data, b.len);
            bad[i] ^= flips[f];
            int rc = par_decomp_plc_decode(bad, b.len, &q, &diag);
            ck_assert(rc == 0 || rc == PDR_EPARSE || rc == PDR_EGEOMETRY);
            plc_free(&q);
            pdr_diag_free(&diag);
        }
    free(bad);
    pr_buf_free(&b);
    plc_free(&p);
}
END_TEST

/* ------------------------------------------------------ links on the wire */

/* Where the links of a par_wire message start (see par/par_wire.h), and
 * its tetrahedron count. */
static size_t link_offset(const uint8_t *msg, size_t len, uint32_t *nt)
{
    ck_assert_uint_ge(len, 20);
    size_t at = 20 + pr_load_u32(msg + 16); /* after the submesh */
    uint32_t nv = pr_load_u32(msg + at);
    at += 4 + 9 * (size_t)nv;
    *nt = pr_load_u32(msg + at);
    at += 4 + 4 * (size_t)*nt;
    ck_assert_uint_le(at + 16 * (size_t)*nt, len);
    return at;
}

/* A copy of msg with the link of face x set to c. */
static uint8_t *with_link(const uint8_t *msg, size_t len, uint32_t x, uint32_t c)
{
    uint32_t nt;
    size_t at = link_offset(msg, len, &nt);
    ck_assert_uint_lt(x, 4 * nt);
    uint8_t *b = malloc(len);
    ck_assert_ptr_nonnull(b);
    memcpy(b, msg, len);
    pr_store_u32(b + at + 4 * (size_t)x, c);
    return b;
}

static uint32_t link_of(const uint8_t *msg, size_t len, uint32_t x)
{
    uint32_t nt;
    size_t at = link_offset(msg, len, &nt);
    return pr_load_u32(msg + at + 4 * (size_t)x);
}

/* The decoder refuses every link it cannot follow; one that does not come
 * back decodes, and building the submesh refuses it. */
START_TEST(links_checked)
{
    plc p;
    unit_cube_plc(&p);
    ref_mesher mo;
    build_mo(&p, NULL, 0, &mo);
    par_decomp d;
    ck_assert_int_eq(par_decomp_run(&mo, 2, 2, 1, &d), 0);
    const uint8_t *msg = d.msg[1].data;
    size_t len = d.msg[1].len;
    uint32_t nt;
    link_offset(msg, len, &nt);
    /* a face linked within the message, one linked to the other PE, and
     * the face its first one links to */
    uint32_t in = UINT32_MAX, out = UINT32_MAX;
    for (uint32_t x = 0; x < 4 * nt; x++) {
        uint32_t c = link_of(msg, len, x);
        if (c == PAR_WIRE_LINK_IFACE && out == UINT32_MAX)
            out = x;
        else if (c < PAR_WIRE_LINK_IFACE && in == UINT32_MAX)
            in = x;
    }
    ck_assert_uint_ne(in, UINT32_MAX);
    ck_assert_uint_ne(out, UINT32_MAX);
    uint32_t peer = link_of(msg, len, in);
    ck_assert_uint_eq(link_of(msg, len, peer), in);
    const uint32_t bad[][2] = {
        {in, 4 * nt},                        /* past the last tetrahedron */
        {in, UINT32_C(0x7FFFFFFF)},          /* far past it */
        {in, (in & ~3u) | ((in + 1) & 3u)},  /* its own tetrahedron */
        {in, PAR_WIRE_LINK_IFACE},           /* not an interface face */
        {out, PAR_WIRE_LINK_NONE},           /* an interface face without */
        {out, peer},                         /* an interface face linked */
    };
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        uint8_t *b = with_link(msg, len, bad[k][0], bad[k][1]);
        par_wire w;
        ck_assert_int_eq(par_wire_decode(b, len, &p, &w), PDR_EPARSE);
        ck_assert_ptr_null(w.sm);
        free(b);
    }
    /* in range but not coming back: a face of another tetrahedron */
    uint32_t other = (in / 4 + 1) % nt * 4;
    if (other / 4 == peer / 4)
        other = (other + 4) % (4 * nt);
    uint8_t *b = with_link(msg, len, in, other);
    par_wire w;
    ck_assert_int_eq(par_wire_decode(b, len, &p, &w), 0);
    par_sub s;
    ck_assert_int_eq(par_wire_build(&w, &p, NULL, &s), PDR_ETOPOLOGY);
    par_wire_clear(&w);
    free(b);
    /* nothing across a face that has a neighbour */
    b = with_link(msg, len, in, PAR_WIRE_LINK_NONE);
    ck_assert_int_eq(par_wire_load(b, len, &p, NULL, &s), PDR_ETOPOLOGY);
    free(b);
    par_decomp_free(&d);
    ref_free(&mo);
    plc_free(&p);
}
END_TEST

/* par_verify_facets finds the hole a forgotten subfacet leaves, and
 * nothing where a subfacet's neighbour is on another PE. */
START_TEST(facet_gaps_found)
{
    plc p;
    unit_cube_plc(&p);
    ref_mesher mo;
    build_mo(&p, NULL, 2000, &mo);
    par_decomp d;
    ck_assert_int_eq(par_decomp_run(&mo, 2, 2, 1, &d), 0);
    par_sub s;
    ck_assert_int_eq(par_wire_load(d.msg[0].data, d.msg[0].len, &p, NULL, &s), 0);
    ck_assert_uint_eq(par_verify_facets(&s, NULL), 0);
    /* a subfacet none of whose edges is a subsegment, on a face whose
     * tetrahedron has no interface face */
    bd_set *bd = &s.r.bd;
    uint32_t victim = BD_NONE;
    for (uint32_t i = 0; i < bd->nfacs && victim == BD_NONE; i++) {
        const bd_subfac *f = &bd->facs[i];
        if (f->flags & (BD_F_DEAD | BD_F_MISSING))
            continue;
        int inner = 1;
        for (int k = 0; k < 3; k++)
            if (bd_find_subseg(bd, f->v[k], f->v[(k + 1) % 3]) != BD_NONE ||
                bd_subfac_across(bd, i, k) == BD_NONE)
                inner = 0;
        uint32_t t;
        if (inner && ref_find_local(&s.r, f->v[0], f->v[1], f->v[2], &t)) {
            int remote = 0;
            for (int k = 0; k < 4; k++)
                remote |= tm_is_special(s.r.m.tets[t].n[k]) && s.r.m.tets[t].n[k] != TM_LINK_NONE;
            if (!remote)
                victim = i;
        }
    }
    ck_assert_uint_ne(victim, BD_NONE);
    bd_kill_subfac(bd, victim);
    /* each of its three neighbours now has an edge with nothing across */
    ck_assert_uint_ge(par_verify_facets(&s, NULL), 3);
    par_sub_free(&s);
    par_decomp_free(&d);
    ref_free(&mo);
    plc_free(&p);
}
END_TEST

/* ---------------------------------------------- cavity replies */

/* Decodes b[0..len) into a fresh cavity record; returns the decoder's
 * code, and on success checks that every index it made is in range. */
static int try_cavity_tets(const uint8_t *b, size_t len)
{
    par_cav_ctx cc;
    memset(&cc, 0, sizeof cc);
    par_cav c;
    par_cav_init(&c, &cc);
    int rc = par_cav_decode_tets(&c, b, len, 1);
    if (!rc) {
        for (size_t i = 0; i < c.ngt; i++)
            for (int k = 0; k < 4; k++)
                ck_assert(c.gt[i].v[k] == UINT32_MAX || c.gt[i].v[k] < c.ngv);
        for (size_t i = 0; i < c.ngp; i++)
            for (int k = 0; k < c.gp[i].nv; k++)
                ck_assert_uint_lt(c.gp[i].v[k], c.ngv);
    }
    par_cav_free(&c);
    return rc;
}

/* Part 0 of cube-in-cube's Mo of 3,000 tetrahedra, cut in two, loaded as
 * a PE's submesh s (with the PLC p, Mo and the decomposition it came
 * from); free_cic_part releases the four. */
static void load_cic_part(plc *p, ref_mesher *mo, par_decomp *d, par_sub *s)
{
    domain_plc(p, DOM_CUBE_IN_CUBE);
    build_mo(p, NULL, 3000, mo);
    ck_assert_int_eq(par_decomp_run(mo, 2, 2, 3, d), 0);
    ck_assert_int_eq(par_wire_load(d->msg[0].data, d->msg[0].len, p, &mo->o, s), 0);
}

static void free_cic_part(plc *p, ref_mesher *mo, par_decomp *d, par_sub *s)
{
    par_sub_free(s);
    par_decomp_free(d);
    ref_free(mo);
    plc_free(p);
}

/* A bad tetrahedron left for the merge on one PE (par_cav_mark_left)
 * travels marked so, and only while it is that tetrahedron, still marked
 * queued: without the mark a PE that a cavity brought it to queued it
 * again, and turbine.off on 2 PEs moved cavities back and forth for
 * minutes (issue 12). */
START_TEST(cavity_reply_left)
{
    plc p;
    ref_mesher mo;
    par_decomp d;
    par_sub s;
    load_cic_part(&p, &mo, &d, &s);
    tm_mesh *m = &s.r.m;
    uint32_t tets[3];
    size_t n = 0;
    for (uint32_t t = 0; t < m->nslots && n < 3; t++)
        if (!tm_is_dead(m, t) && !tm_is_ghost(m, t))
            tets[n++] = t;
    ck_assert_uint_eq(n, 3);
    par_cav_ctx cc;
    memset(&cc, 0, sizeof cc);
    cc.s = &s;
    /* 0: left; 1: queued, not left; 2: recorded but no longer marked */
    m->flags[tets[0]] |= TM_F_QUEUED;
    m->flags[tets[1]] |= TM_F_QUEUED;
    m->flags[tets[2]] &= (uint16_t)~TM_F_QUEUED;
    ck_assert_int_eq(par_cav_mark_left(&cc, tets[0]), 0);
    ck_assert_int_eq(par_cav_mark_left(&cc, tets[2]), 0);
    for (int pass = 0; pass < 2; pass++) {
        pr_buf b = PR_BUF_INIT;
        ck_assert_int_eq(par_cav_encode_left_tets(&cc, tets, n, &b), 0);
        par_cav c;
        par_cav_init(&c, &cc);
        ck_assert_int_eq(par_cav_decode_tets(&c, b.data, b.len, 1), 0);
        ck_assert_uint_eq(c.ngt, n);
        /* pass 1: slot tets[0] holds another tetrahedron (its vertices
         * in another order): not the one left */
        ck_assert_int_eq((c.gt[0].flags & TM_F_DEAD) != 0, pass == 0);
        ck_assert(c.gt[0].flags & TM_F_QUEUED);
        ck_assert(!(c.gt[1].flags & TM_F_DEAD));
        ck_assert(c.gt[1].flags & TM_F_QUEUED);
        ck_assert(!(c.gt[2].flags & (TM_F_DEAD | TM_F_QUEUED)));
        /* the plain encoder knows of no PE's marks */
        pr_buf_free(&b);
        ck_assert_int_eq(par_cav_encode_tets(&s, tets, 1, &b), 0);
        par_cav_free(&c);
        par_cav_init(&c, &cc);
        ck_assert_int_eq(par_cav_decode_tets(&c, b.data, b.len, 1), 0);
        ck_assert(!(c.gt[0].flags & TM_F_DEAD));
        par_cav_free(&c);
        pr_buf_free(&b);
        uint32_t *v = m->tets[tets[0]].v, x = v[0];
        v[0] = v[1];
        v[1] = x;
    }
    hmap_free(&cc.left);
    free_cic_part(&p, &mo, &d, &s);
}
END_TEST

/* The tetrahedra of a REPLY: a round trip keeps every vertex, marker and
 * region and brings each subsegment and subfacet once; a cut anywhere or
 * a byte too many is refused; damaged bytes never crash the decoder. */
START_TEST(cavity_reply_tets)
{
    plc p;
    ref_mesher mo;
    par_decomp d;
    par_sub s;
    load_cic_part(&p, &mo, &d, &s);
    const tm_mesh *m = &s.r.m;
    /* 200 live tetrahedra, ghosts and boundary ones among them */
    uint32_t tets[200];
    size_t n = 0;
    size_t marked = 0, ghosts = 0;
    for (uint32_t t = 0; t < m->nslots && n < 200; t++) {
        if (tm_is_dead(m, t))
            continue;
        tets[n++] = t;
        ghosts += tm_is_ghost(m, t);
        marked += (m->flags[t] & TM_F_FACEMARKS) != 0;
    }
    ck_assert_uint_eq(n, 200);
    ck_assert_uint_gt(marked, 0);
    pr_buf b = PR_BUF_INIT;
    ck_assert_int_eq(par_cav_encode_tets(&s, tets, n, &b), 0);
    ck_assert_int_eq(b.err, 0);

    par_cav_ctx cc;
    memset(&cc, 0, sizeof cc);
    par_cav c;
    par_cav_init(&c, &cc);
    ck_assert_int_eq(par_cav_decode_tets(&c, b.data, b.len, 1), 0);
    ck_assert_uint_eq(c.ngt, n);
    size_t nseg = 0, nfac = 0;
    for (size_t i = 0; i < n; i++) {
        const tm_tet *T = &m->tets[tets[i]];
        const par_gtet *g = &c.gt[i];
        ck_assert_uint_eq(g->src, 1);
        for (int k = 0; k < 4; k++) {
            if (T->v[k] == TM_VINF) {
                ck_assert_uint_eq(g->v[k], UINT32_MAX);
                continue;
            }
            const par_gvert *v = &c.gv[g->v[k]];
            ck_assert_uint_eq(v->gid, m->gid[T->v[k]]);
            ck_assert(!memcmp(v->xyz, tm_xyz(m, T->v[k]), sizeof v->xyz));
            ck_assert_uint_eq(v->kind, s.r.bd.vkind[T->v[k]]);
            ck_assert_int_eq(g->marker[k], tm_face_marker(m, tets[i], k));
        }
        ck_assert_uint_eq(g->region, s.r.region ? s.r.region[tets[i]] : 0);
    }
    for (size_t i = 0; i < c.ngp; i++) {
        nseg += c.gp[i].nv == 2;
        nfac += c.gp[i].nv == 3;
    }
    /* each piece once: the distinct subsegments and subfacets marked on
     * those tetrahedra */
    hmap seen = {0};
    size_t want_seg = 0, want_fac = 0;
    for (size_t i = 0; i < n; i++) {
        const tm_tet *T = &m->tets[tets[i]];
        for (int e = 0; e < 6; e++) {
            if (!(m->flags[tets[i]] & TM_F_SUBSEG(e)))
                continue;
            uint32_t id = bd_find_subseg(&s.r.bd, T->v[tm_edge_vtx[e][0]], T->v[tm_edge_vtx[e][1]]);
            if (id != BD_NONE && hmap_get(&seen, 2 * (uint64_t)id + 1) == HMAP_NONE) {
                ck_assert_int_eq(hmap_put(&seen, 2 * (uint64_t)id + 1, 1), 0);
                want_seg++;
            }
        }
        for (int k = 0; k < 4; k++) {
            if (!(m->flags[tets[i]] & TM_F_FACEMARK(k)))
                continue;
            uint32_t id = bd_find_subfac(&s.r.bd, T->v[tm_face_vtx[k][0]],
                                         T->v[tm_face_vtx[k][1]], T->v[tm_face_vtx[k][2]]);
            if (id != BD_NONE && hmap_get(&seen, 2 * (uint64_t)id + 2) == HMAP_NONE) {
                ck_assert_int_eq(hmap_put(&seen, 2 * (uint64_t)id + 2, 1), 0);
                want_fac++;
            }
        }
    }
    hmap_free(&seen);
    ck_assert_uint_eq(nseg, want_seg);
    ck_assert_uint_eq(nfac, want_fac);
    ck_assert_uint_gt(nfac, 0);
    par_cav_free(&c);

    /* every cut is refused, and so is a byte too many */
    for (size_t len = 0; len < b.len; len++)
        ck_assert_int_eq(try_cavity_tets(b.data, len), PDR_EPARSE);
    uint8_t *bad = malloc(b.len + 1);
    ck_assert_ptr_nonnull(bad);
    memcpy(bad, b.data, b.len);
    bad[b.len] = 0;
    ck_assert_int_eq(try_cavity_tets(bad, b.len + 1), PDR_EPARSE);
    /* random bytes over random stretches: refused or in range */
    uint64_t x = 0x9E3779B97F4A7C15ULL;
    size_t refused = 0;
    for (int round = 0; round < 3000; round++) {
        damage_stretch(bad, b.data, b.len, &x);
        refused += try_cavity_tets(bad, b.len) == PDR_EPARSE;
    }
    ck_assert_uint_gt(refused, 0);
    free(bad);
    pr_buf_free(&b);
    free_cic_part(&p, &mo, &d, &s);
}
END_TEST

/* Decodes a BAND body for s's PE from PE 1; a decoded one has every
 * vertex index in range. */
static int try_band(par_sub *s, const uint8_t *b, size_t len)
{
    par_cav_ctx cc;
    memset(&cc, 0, sizeof cc);
    cc.s = s;
    par_cav c;
    par_cav_init(&c, &cc);
    int rc = par_cav_decode_band(&c, b, len, 1);
    if (!rc)
        for (size_t i = 0; i < c.ngt; i++)
            for (int k = 0; k < 4; k++)
                ck_assert(c.gt[i].v[k] == UINT32_MAX || c.gt[i].v[k] < c.ngv);
    par_cav_free(&c);
    return rc;
}

/* The body of a BAND (a 2-PE run's interface band, par_cav_give): a
 * connected band of 300 tetrahedra decodes with one face record per
 * face (inner faces once); its adjacency made asymmetric, a cut anywhere
 * or a byte too many is refused; damaged bytes never crash the decoder. */
START_TEST(cavity_band_adjacency)
{
    plc p;
    ref_mesher mo;
    par_decomp d;
    par_sub s;
    load_cic_part(&p, &mo, &d, &s);
    tm_mesh *m = &s.r.m;
    /* 300 finite tetrahedra, breadth first over local links */
    enum { N = 300 };
    uint32_t tets[N];
    uint8_t *in = calloc(m->nslots, 1);
    ck_assert_ptr_nonnull(in);
    size_t n = 0;
    for (uint32_t t = 0; t < m->nslots && !n; t++)
        if (!tm_is_dead(m, t) && !tm_is_ghost(m, t)) {
            tets[n++] = t;
            in[t] = 1;
        }
    for (size_t h = 0; h < n && n < N; h++)
        for (int k = 0; k < 4 && n < N; k++) {
            tm_link l = m->tets[tets[h]].n[k];
            if (l == TM_LINK_NONE || l == TM_LINK_UNSET || tm_is_special(l))
                continue;
            uint32_t w = tm_ltet(l);
            if (in[w] || tm_is_dead(m, w) || tm_is_ghost(m, w))
                continue;
            in[w] = 1;
            tets[n++] = w;
        }
    ck_assert_uint_eq(n, N);
    size_t inner = 0;
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 4; k++) {
            tm_link l = m->tets[tets[i]].n[k];
            inner += !tm_is_special(l) && in[tm_ltet(l)];
        }
    ck_assert_uint_eq(inner % 2, 0);
    inner /= 2;
    ck_assert_uint_gt(inner, N / 2);

    pr_buf b = PR_BUF_INIT;
    ck_assert_int_eq(par_cav_encode_band(&s, tets, n, &b), 0);
    for (size_t i = 0; i < n; i++)
        ck_assert(!(m->flags[tets[i]] & TM_F_CAVITY));
    par_cav_ctx cc;
    memset(&cc, 0, sizeof cc);
    cc.s = &s;
    par_cav c;
    par_cav_init(&c, &cc);
    ck_assert_int_eq(par_cav_decode_band(&c, b.data, b.len, 1), 0);
    ck_assert_uint_eq(c.ngt, n);
    ck_assert_uint_eq(c.nface, 4 * n - inner);
    par_cav_free(&c);

    /* the adjacency follows the tetrahedra part (as par_cav_encode_tets
     * writes it) and its count: point an inner face elsewhere */
    pr_buf t = PR_BUF_INIT;
    ck_assert_int_eq(par_cav_encode_tets(&s, tets, n, &t), 0);
    ck_assert_uint_eq(b.len, t.len + 4 + 16 * n);
    uint8_t *bad = malloc(b.len + 1);
    ck_assert_ptr_nonnull(bad);
    size_t at = 0;
    while (at < 4 * n && !memcmp(b.data + t.len + 4 + 4 * at, "\xff\xff\xff\xff", 4))
        at++;
    ck_assert_uint_lt(at, 4 * n);
    for (uint32_t wrong = 0; wrong < 4; wrong++) {
        memcpy(bad, b.data, b.len);
        uint8_t *a = bad + t.len + 4 + 4 * at;
        uint32_t v = (uint32_t)a[0] | (uint32_t)a[1] << 8 | (uint32_t)a[2] << 16 |
                     (uint32_t)a[3] << 24;
        /* another face of the same neighbour, or the tetrahedron itself */
        uint32_t w = wrong < 3 ? (v & ~3u) | ((v + 1 + wrong) & 3u) : 4 * (uint32_t)(at / 4);
        a[0] = (uint8_t)w, a[1] = (uint8_t)(w >> 8), a[2] = (uint8_t)(w >> 16),
        a[3] = (uint8_t)(w >> 24);
        ck_assert_int_eq(try_band(&s, bad, b.len), PDR_EPARSE);
    }
    pr_buf_free(&t);

    /* every cut is refused, and so is a byte too many */
    for (size_t len = 0; len < b.len; len++)
        ck_assert_int_ne(try_band(&s, b.data, len), 0);
    memcpy(bad, b.data, b.len);
    bad[b.len] = 0;
    ck_assert_int_eq(try_band(&s, bad, b.len + 1), PDR_EPARSE);
    /* random bytes over random stretches: refused or in range */
    uint64_t x = 0x2545F4914F6CDD1DULL;
    size_t refused = 0;
    for (int round = 0; round < 3000; round++) {
        damage_stretch(bad, b.data, b.len, &x);
        refused += try_band(&s, bad, b.len) != 0;
    }
    ck_assert_uint_gt(refused, 0);
    free(bad);
    free(in);
    pr_buf_free(&b);
    free_cic_part(&p, &mo, &d, &s);
}
END_TEST

/* base/hdup: exactly the repeated values, whatever their partition. */
START_TEST(hdup_finds_repeats)
{
    size_t n = 300000;
    uint64_t *h = malloc(n * sizeof *h);
    ck_assert_ptr_nonnull(h);
    uint64_t x = 88172645463325252ULL;
    for (size_t i = 0; i < n; i++) {
        x ^= x << 13, x ^= x >> 7, x ^= x << 17;
        h[i] = x | 1; /* odd: distinct from the planted values below */
    }
    /* planted: a pair, a triple, and two zeros (zero marks a free slot) */
    h[10] = h[200000] = 42;
    h[7] = h[70] = h[299999] = UINT64_MAX - 1;
    h[5] = h[6] = 0;
    hdup_buf buf = {NULL, 0};
    uint64_t *rep;
    size_t nrep;
    ck_assert_int_eq(hdup_find(h, n, &buf, &rep, &nrep), 0);
    ck_assert_uint_eq(nrep, 3);
    ck_assert_uint_eq(rep[0], 0);
    ck_assert_uint_eq(rep[1], 42);
    ck_assert_uint_eq(rep[2], UINT64_MAX - 1);
    ck_assert(hdup_has(rep, nrep, 42) && !hdup_has(rep, nrep, 43));
    free(rep);
    /* h untouched, buf reused: no repeat among the first 5 */
    ck_assert_int_eq(hdup_find(h, 5, &buf, &rep, &nrep), 0);
    ck_assert_uint_eq(nrep, 0);
    ck_assert_ptr_null(rep);
    ck_assert_int_eq(hdup_find(h, 0, &buf, &rep, &nrep), 0);
    ck_assert_uint_eq(nrep, 0);
    hdup_buf_free(&buf);
    free(h);
}
END_TEST

/* ------------------------------------------------- merge mismatches */

/* Builds the submeshes of Mo (the unit cube refined a little) for P PEs. */
/* The unit cube, meshed sequentially with a volume bound of 0.002 (the
 * merge tests' mesh); *o gets the options. */
static void refined_cube(plc *p, ref_opts *o, ref_mesher *mo)
{
    unit_cube_plc(p);
    ref_default_opts(o);
    o->maxvol = 0.002;
    build_mo(p, o, 0, mo);
    ck_assert_int_eq(ref_refine(mo), 0);
}

static void subs_of(const ref_mesher *mo, uint32_t P, par_sub *subs)
{
    par_decomp d;
    ck_assert_int_eq(par_decomp_run(mo, P, P, 1, &d), 0);
    for (uint32_t k = 0; k < P; k++)
        ck_assert_int_eq(par_wire_load(d.msg[k].data, d.msg[k].len, mo->p, NULL, &subs[k]), 0);
    par_decomp_free(&d);
}

/* The PEs' merge messages of subs (in the given order, or their own),
 * into b, msg and len (at most 8). */
static void encode_subs(const par_sub *subs, const uint32_t *order, uint32_t P, pr_buf *b,
                        const void **msg, size_t *len)
{
    ck_assert_uint_le(P, 8);
    for (uint32_t k = 0; k < P; k++) {
        b[k] = (pr_buf)PR_BUF_INIT;
        ck_assert_int_eq(par_merge_encode(&b[k], &subs[order ? order[k] : k]), 0);
        msg[k] = b[k].data;
        len[k] = b[k].len;
    }
}

static int merge_subs(const par_sub *subs, const uint32_t *order, uint32_t P, const plc *p,
                      par_merge_report *rep)
{
    pr_buf b[8];
    const void *msg[8];
    size_t len[8];
    encode_subs(subs, order, P, b, msg, len);
    ref_mesher mg;
    int rc = par_merge_build(msg, len, P, p, NULL, &mg, rep);
    if (!rc)
        ref_free(&mg);
    else
        ck_assert_ptr_null(mg.m.tets);
    for (uint32_t k = 0; k < P; k++)
        pr_buf_free(&b[k]);
    return rc;
}

/* A wrong exterior flag that a PE passed on (refine_bound.c: flat
 * tetrahedra on inclined facets, flips) left a hole in the merged mesh
 * that rank 0's output guard then refused: par_merge_reclassify puts such
 * tetrahedra back inside, and on a finished mesh adds no point. */
START_TEST(merge_reclassifies)
{
    plc p;
    domain_plc(&p, DOM_TEE);
    ref_opts o;
    ref_default_opts(&o);
    o.maxvol = 2e-3;
    ref_mesher mo;
    pdr_diag diag = {0};
    im_opts io = {0, 0};
    ck_assert_int_eq(ref_init(&mo, &p, &o), 0);
    ck_assert_int_eq(im_build(&mo, &io, NULL, &diag), 0);
    ck_assert_int_eq(ref_refine(&mo), 0);
    ref_release_work(&mo);
    size_t interior = ref_interior_tets(&mo);
    ck_assert_uint_gt(interior, 1000);
    enum { P = 3 };
    par_decomp d;
    ck_assert_int_eq(par_decomp_run(&mo, P, P, 7, &d), 0);
    par_sub subs[P];
    pr_buf back[P];
    const void *msg[P];
    size_t len[P];
    for (uint32_t k = 0; k < P; k++) {
        ck_assert_int_eq(par_wire_load(d.msg[k].data, d.msg[k].len, &p, &mo.o, &subs[k]), 0);
        back[k] = (pr_buf)PR_BUF_INIT;
        ck_assert_int_eq(par_merge_encode(&back[k], &subs[k]), 0);
        msg[k] = back[k].data;
        len[k] = back[k].len;
    }
    ref_mesher mg;
    par_merge_report rep;
    ck_assert_int_eq(par_merge_build(msg, len, P, &p, &mo.o, &mg, &rep), 0);
    /* five interior tetrahedra taken for outside */
    size_t flipped = 0;
    for (uint32_t t = 0; t < mg.m.nslots && flipped < 5; t += 97)
        if (!tm_is_dead(&mg.m, t) && !tm_is_ghost(&mg.m, t) &&
            !(mg.m.flags[t] & REF_F_EXTERIOR)) {
            mg.m.flags[t] |= REF_F_EXTERIOR;
            flipped++;
        }
    ck_assert_uint_eq(flipped, 5);
    ck_assert_uint_eq(ref_interior_tets(&mg), interior - 5);
    /* the wrong flags show as unmarked faces between inside and outside
     * (tetrahedra every 97 slots: none of the five is next to another) */
    ck_assert_uint_eq(ref_unmarked_bounds(&mo), 0);
    ck_assert_uint_gt(ref_unmarked_bounds(&mg), 0);
    size_t moved, added;
    ck_assert_int_eq(par_merge_reclassify(&mg, 0, 0, &moved, &added), 0);
    ck_assert_uint_eq(moved, 5);
    ck_assert_uint_eq(added, 0);
    ck_assert_uint_eq(ref_interior_tets(&mg), interior);
    ck_assert_uint_eq(ref_consistency(&mg, stderr, 1), 0);
    ck_assert_uint_eq(ref_unmarked_bounds(&mg), 0);
    same_export(&mo, &mg);
    /* nothing to do the second time */
    ck_assert_int_eq(par_merge_reclassify(&mg, 0, 0, &moved, &added), 0);
    ck_assert_uint_eq(moved, 0);
    /* A PE's list of missing pieces: one subfacet of PE 0 flagged
     * missing there travels by gids; the merged mesh has it present, so
     * nothing is added. Damaged lists are refused. */
    bd_set *bd0 = &subs[0].r.bd;
    uint32_t f0 = 0;
    while (f0 < bd0->nfacs && (bd0->facs[f0].flags & BD_F_DEAD))
        f0++;
    ck_assert_uint_lt(f0, bd0->nfacs);
    bd0->facs[f0].flags |= BD_F_MISSING;
    pr_buf lb = PR_BUF_INIT;
    size_t nmiss;
    ck_assert_int_eq(par_merge_put_missing(&lb, &subs[0], &nmiss), 0);
    ck_assert_uint_eq(nmiss, 1);
    size_t nadd = 99;
    ck_assert_int_eq(par_merge_add_missing(&mg, lb.data, lb.len, &nadd), 0);
    ck_assert_uint_eq(nadd, 0);
    for (size_t cut = 0; cut < lb.len; cut++)
        ck_assert_int_eq(par_merge_add_missing(&mg, lb.data, cut, &nadd), PDR_EPARSE);
    uint8_t *bad = malloc(lb.len + 1);
    memcpy(bad, lb.data, lb.len);
    bad[lb.len] = 0;
    ck_assert_int_eq(par_merge_add_missing(&mg, bad, lb.len + 1, &nadd), PDR_EPARSE);
    bad[4] = 4; /* nv */
    ck_assert_int_eq(par_merge_add_missing(&mg, bad, lb.len, &nadd), PDR_EPARSE);
    memcpy(bad, lb.data, lb.len);
    memset(bad + 5, 0xEE, 8); /* a gid nobody has */
    ck_assert_int_eq(par_merge_add_missing(&mg, bad, lb.len, &nadd), PDR_EPARSE);
    free(bad);
    pr_buf_free(&lb);
    ref_free(&mg);
    for (uint32_t k = 0; k < P; k++) {
        par_sub_free(&subs[k]);
        pr_buf_free(&back[k]);
    }
    par_decomp_free(&d);
    ref_free(&mo);
    plc_free(&p);
    pdr_diag_free(&diag);
}
END_TEST

/* The merge of subs with the options o (a smaller volume bound than
 * theirs makes their tetrahedra bad); with mark, n interior tetrahedra
 * get the mark of one a PE left for the merge (TM_F_QUEUED, no queue). */
static void merge_marked(const par_sub *subs, uint32_t P, const plc *p, const ref_opts *o,
                         size_t n, ref_mesher *mg)
{
    pr_buf b[8];
    const void *msg[8];
    size_t len[8];
    encode_subs(subs, NULL, P, b, msg, len);
    par_merge_report rep;
    ck_assert_int_eq(par_merge_build(msg, len, P, p, o, mg, &rep), 0);
    for (uint32_t k = 0; k < P; k++)
        pr_buf_free(&b[k]);
    size_t marked = 0;
    for (uint32_t t = 0; t < mg->m.nslots && marked < n; t += n > 10 ? 1 : 7)
        if (ref_is_interior(&mg->m, t)) {
            ck_assert(!(mg->m.flags[t] & TM_F_QUEUED));
            mg->m.flags[t] |= TM_F_QUEUED;
            marked++;
        }
    ck_assert_uint_eq(marked, n);
}

/* What the PEs left for a split on another PE is marked; rank 0 refines
 * just that (par_merge_finish_left), and the full finish
 * (par_merge_reclassify) does not skip marked tetrahedra. */
START_TEST(merge_finishes_left)
{
    plc p;
    ref_opts o;
    ref_mesher mo;
    refined_cube(&p, &o, &mo);
    enum { P = 3 };
    par_sub subs[P];
    subs_of(&mo, P, subs);
    ref_opts small = o;
    small.maxvol = 0.0002;
    ref_mesher mg;
    size_t moved, added;
    /* nothing marked: nothing to do, though every tetrahedron is bad */
    merge_marked(subs, P, &p, &small, 0, &mg);
    ck_assert_int_eq(par_merge_finish_left(&mg, &moved, &added), 0);
    ck_assert_uint_eq(added, 0);
    ref_free(&mg);
    /* all marked, the full finish: every one is looked at */
    merge_marked(subs, P, &p, &small, ref_interior_tets(&mo), &mg);
    uint32_t nt = mg.m.nslots;
    ck_assert_int_eq(par_merge_reclassify(&mg, 0, 1, &moved, &added), 0);
    size_t added_all = added;
    ck_assert_uint_gt(added_all, nt / 4);
    ref_free(&mg);
    /* three marked: they are split, and the work spreads from them only */
    merge_marked(subs, P, &p, &small, 3, &mg);
    ck_assert_int_eq(par_merge_finish_left(&mg, &moved, &added), 0);
    ck_assert_uint_gt(added, 0);
    ck_assert_uint_lt(added, added_all);
    ck_assert_uint_eq(ref_consistency(&mg, stderr, 1), 0);
    for (uint32_t t = 0; t < mg.m.nslots; t++)
        ck_assert(tm_is_dead(&mg.m, t) || !(mg.m.flags[t] & TM_F_QUEUED));
    ref_free(&mg);
    for (uint32_t k = 0; k < P; k++)
        par_sub_free(&subs[k]);
    ref_free(&mo);
    plc_free(&p);
}
END_TEST

START_TEST(merge_counts_mismatches)
{
    plc p;
    ref_opts o;
    ref_mesher mo;
    refined_cube(&p, &o, &mo);
    par_sub subs[3];
    par_merge_report rep;

    /* the PEs' messages in the wrong order */
    subs_of(&mo, 3, subs);
    uint32_t swapped[3] = {1, 0, 2};
    ck_assert_int_eq(merge_subs(subs, swapped, 3, &p, &rep), PDR_EPARSE);
    ck_assert_int_eq(merge_subs(subs, NULL, 3, &p, &rep), 0);

    /* an interface face of PE 0 names PE 2 where PE 1 is */
    uint32_t k;
    for (k = 0; k < subs[0].nifc && subs[0].ifc[k].pe != 1; k++)
        ;
    ck_assert_uint_lt(k, subs[0].nifc);
    subs[0].ifc[k].pe = 2;
    ck_assert_int_eq(merge_subs(subs, NULL, 3, &p, &rep), PDR_ETOPOLOGY);
    ck_assert_uint_eq(rep.iface_mismatch, 1);
    ck_assert_uint_eq(par_merge_problems(&rep), 1);
    subs[0].ifc[k].pe = 1;

    /* PE 1 loses a tetrahedron at the interface: a hole in the union */
    tm_mesh *m1 = &subs[1].r.m;
    uint32_t t = tm_ltet(subs[1].ifc[0].local);
    tm_delete_tet(m1, t);
    ck_assert_int_eq(merge_subs(subs, NULL, 3, &p, &rep), PDR_ETOPOLOGY);
    ck_assert_uint_gt(rep.iface_unmatched + rep.open_faces, 0);
    ck_assert_uint_eq(rep.nonmanifold + rep.dup_tets + rep.iface_mismatch, 0);
    for (int c = 0; c < 3; c++)
        par_sub_free(&subs[c]);

    /* PE 2 holds one tetrahedron twice */
    subs_of(&mo, 3, subs);
    tm_mesh *m2 = &subs[2].r.m;
    ck_assert_int_eq(tm_room(m2, 1), 0);
    uint32_t u = tm_alloc_tet(m2);
    for (int i = 0; i < 4; i++) {
        m2->tets[u].v[i] = m2->tets[0].v[i];
        m2->tets[u].n[i] = TM_LINK_NONE;
    }
    ck_assert_int_eq(merge_subs(subs, NULL, 3, &p, &rep), PDR_ETOPOLOGY);
    ck_assert_uint_eq(rep.dup_tets, 1);
    ck_assert_uint_eq(par_merge_problems(&rep), 1);

    /* two PEs disagree on a shared vertex */
    tm_free_tet(m2, u);
    ck_assert_int_eq(merge_subs(subs, NULL, 3, &p, &rep), 0);
    /* a vertex of an interface face is on both sides */
    tm_link l = subs[0].ifc[0].local;
    const uint32_t *tv = subs[0].r.m.tets[tm_ltet(l)].v;
    uint32_t v = tv[tm_face_vtx[tm_lface(l)][0]];
    if (v == TM_VINF)
        v = tv[tm_face_vtx[tm_lface(l)][1]];
    subs[0].r.m.xyz[3 * (size_t)v] += 1e-9;
    ck_assert_int_eq(merge_subs(subs, NULL, 3, &p, &rep), PDR_ETOPOLOGY);
    ck_assert_uint_ge(rep.vertex_conflicts, 1);
    ck_assert_uint_eq(par_merge_problems(&rep), rep.vertex_conflicts);
    for (int c = 0; c < 3; c++)
        par_sub_free(&subs[c]);
    ref_free(&mo);
    plc_free(&p);
}
END_TEST

/* The merge of P encoded messages b[0..P), which this edits nothing of,
 * into out, with this process allowed on its first processor only (the
 * merge's steps that share work among the processors then run in one
 * pass) or on all it had. */
static int merge_mesh_on(const pr_buf *b, uint32_t P, const plc *p, par_merge_report *rep,
                         int one_cpu, ref_mesher *out)
{
    cpu_set_t all, one;
    ck_assert_int_eq(sched_getaffinity(0, sizeof all, &all), 0);
    if (one_cpu) {
        CPU_ZERO(&one);
        for (int c = 0; c < CPU_SETSIZE; c++)
            if (CPU_ISSET(c, &all)) {
                CPU_SET(c, &one);
                break;
            }
        ck_assert_int_eq(sched_setaffinity(0, sizeof one, &one), 0);
    }
    const void *msg[8];
    size_t len[8];
    for (uint32_t k = 0; k < P; k++) {
        msg[k] = b[k].data;
        len[k] = b[k].len;
    }
    int rc = par_merge_build(msg, len, P, p, NULL, out, rep);
    ck_assert_int_eq(sched_setaffinity(0, sizeof all, &all), 0);
    return rc;
}

/* merge_mesh_on without the mesh: freed, or none made on a failure. */
static int merge_bufs_on(const pr_buf *b, uint32_t P, const plc *p, par_merge_report *rep,
                         int one_cpu)
{
    ref_mesher mg;
    int rc = merge_mesh_on(b, P, p, rep, one_cpu, &mg);
    if (!rc)
        ref_free(&mg);
    else
        ck_assert_ptr_null(mg.m.tets);
    return rc;
}

/* merge_bufs_on on all processors. */
static int merge_bufs(const pr_buf *b, uint32_t P, const plc *p, par_merge_report *rep)
{
    return merge_bufs_on(b, P, p, rep, 0);
}

/* 1 if a live tetrahedron of m has the face {a, b, c}. */
static int has_face(const tm_mesh *m, uint32_t a, uint32_t b, uint32_t c)
{
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t))
            continue;
        const uint32_t *v = m->tets[t].v;
        int n = 0;
        for (int i = 0; i < 4; i++)
            n += v[i] == a || v[i] == b || v[i] == c;
        if (n == 3)
            return 1;
    }
    return 0;
}

/* Links sent by a PE that do not fit, and a tetrahedron or a face too
 * many across PEs: each counted, and nothing else. */
/* Two pairs of faces linked within msg (nt tetrahedra), x-a and y-c, of
 * four different tetrahedra. */
static void two_linked_pairs(const uint8_t *msg, size_t len, uint32_t nt, uint32_t *x,
                             uint32_t *a, uint32_t *y, uint32_t *c)
{
    *x = *y = UINT32_MAX;
    *a = *c = 0;
    for (uint32_t f = 0; f < 4 * nt && *y == UINT32_MAX; f++) {
        uint32_t l = link_of(msg, len, f);
        if (l >= PAR_WIRE_LINK_IFACE || l < f)
            continue;
        if (*x == UINT32_MAX) {
            *x = f, *a = l;
        } else if (f / 4 != *x / 4 && f / 4 != *a / 4 && l / 4 != *x / 4 && l / 4 != *a / 4) {
            *y = f, *c = l;
        }
    }
    ck_assert_uint_ne(*y, UINT32_MAX);
}

/* Releases what a merge test made: P messages, P submeshes, Mo, the PLC. */
static void free_merge_case(pr_buf *b, par_sub *subs, uint32_t P, ref_mesher *mo, plc *p)
{
    for (uint32_t k = 0; k < P; k++) {
        pr_buf_free(&b[k]);
        par_sub_free(&subs[k]);
    }
    ref_free(mo);
    plc_free(p);
}

/* The unit cube refined to more than 420,000 tetrahedra (above
 * LINK_SHARES_FROM and MERGE_THREADS_FROM of par_merge.c), cut into 3
 * submeshes encoded in b; free_merge_case releases it. */
static void large_merge_case(plc *p, ref_mesher *mo, par_sub subs[3], pr_buf b[3])
{
    unit_cube_plc(p);
    ref_opts o;
    ref_default_opts(&o);
    o.maxvol = 4e-6;
    build_mo(p, &o, 0, mo);
    ck_assert_int_eq(ref_refine(mo), 0);
    ck_assert_uint_ge(mo->m.nlive, 420000);
    subs_of(mo, 3, subs);
    const void *msg[3];
    size_t len[3];
    encode_subs(subs, NULL, 3, b, msg, len);
}

static void same_merged(const ref_mesher *pm1, const ref_mesher *pm2);

/* Step 4 of the merge shares a large mesh's slots among the processors
 * (par_merge.c, check_links_shared): it finds what one pass finds, on a
 * mesh that fits and on one with a link that does not come back and two
 * pairs linked across the wrong faces. */
START_TEST(merge_shares_agree)
{
    plc p;
    ref_mesher mo;
    par_sub subs[3];
    pr_buf b[3];
    large_merge_case(&p, &mo, subs, b);
    par_merge_report one, all;
    ck_assert_int_eq(merge_bufs_on(b, 3, &p, &one, 1), 0);
    ck_assert_int_eq(merge_bufs_on(b, 3, &p, &all, 0), 0);
    ck_assert(!memcmp(&one, &all, sizeof one));
    /* faults: x links to y, which links elsewhere; a and c cross-linked */
    uint8_t *keep = b[1].data;
    uint32_t nt;
    link_offset(keep, b[1].len, &nt);
    uint32_t x, a, y, c;
    two_linked_pairs(keep, b[1].len, nt, &x, &a, &y, &c);
    uint8_t *t1 = with_link(keep, b[1].len, x, y);
    b[1].data = with_link(t1, b[1].len, a, c);
    free(t1);
    ck_assert_int_eq(merge_bufs_on(b, 3, &p, &one, 1), PDR_ETOPOLOGY);
    ck_assert_int_eq(merge_bufs_on(b, 3, &p, &all, 0), PDR_ETOPOLOGY);
    ck_assert_uint_ge(one.bad_links + one.misoriented, 1);
    ck_assert(!memcmp(&one, &all, sizeof one));
    free(b[1].data);
    b[1].data = keep;
    free_merge_case(b, subs, 3, &mo, &p);
}
END_TEST

/* The merge of a large mesh decodes and stores the messages a message
 * per task and runs the face checks beside the boundary tables
 * (par_merge.c): on the processors of the machine it builds the very mesh
 * one processor builds -- the same slots, vertices, links, markers,
 * flags, regions and boundary tables -- and counts the same. */
START_TEST(merge_threads_same_mesh)
{
    plc p;
    ref_mesher mo;
    par_sub subs[3];
    pr_buf b[3];
    large_merge_case(&p, &mo, subs, b);
    par_merge_report r1, r2;
    ref_mesher m1, m2;
    ck_assert_int_eq(merge_mesh_on(b, 3, &p, &r1, 1, &m1), 0);
    ck_assert_int_eq(merge_mesh_on(b, 3, &p, &r2, 0, &m2), 0);
    ck_assert(!memcmp(&r1, &r2, sizeof r1));
    same_merged(&m1, &m2);
    ref_free(&m1);
    ref_free(&m2);
    /* a fault: a link of PE 1 that does not come back */
    uint8_t *keep = b[1].data;
    uint32_t nt;
    link_offset(keep, b[1].len, &nt);
    uint32_t x, u, y, z;
    two_linked_pairs(keep, b[1].len, nt, &x, &u, &y, &z);
    b[1].data = with_link(keep, b[1].len, x, y);
    ck_assert_int_eq(merge_mesh_on(b, 3, &p, &r1, 1, &m1), PDR_ETOPOLOGY);
    ck_assert_int_eq(merge_mesh_on(b, 3, &p, &r2, 0, &m2), PDR_ETOPOLOGY);
    ck_assert(!memcmp(&r1, &r2, sizeof r1));
    free(b[1].data);
    b[1].data = keep;
    free_merge_case(b, subs, 3, &mo, &p);
}
END_TEST

/* The live tetrahedra of m as rows of their four vertices' gids, each row
 * sorted and the rows sorted: *n rows of 4, malloc'd. */
static int cmp_gid_row(const void *a, const void *b)
{
    const uint64_t *x = a, *y = b;
    for (int i = 0; i < 4; i++)
        if (x[i] != y[i])
            return x[i] < y[i] ? -1 : 1;
    return 0;
}

static uint64_t *gid_rows(const tm_mesh *m, size_t *n)
{
    uint64_t *r = malloc(((size_t)m->nlive + 1) * 4 * sizeof *r);
    ck_assert_ptr_nonnull(r);
    size_t k = 0;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t))
            continue;
        uint64_t *row = r + 4 * k++;
        for (int i = 0; i < 4; i++)
            row[i] = m->gid[m->tets[t].v[i]];
        for (int i = 1; i < 4; i++)
            for (int j = i; j > 0 && row[j - 1] > row[j]; j--) {
                uint64_t x = row[j];
                row[j] = row[j - 1];
                row[j - 1] = x;
            }
    }
    qsort(r, k, 4 * sizeof *r, cmp_gid_row);
    *n = k;
    return r;
}

/* A PE's submesh in pieces (par_merge_pieces, as pdr mesh -n sends it):
 * the pieces hold every live tetrahedron once, in ascending slots, every
 * piece but the last as many as asked; merged in order of PE, with the
 * faces between pieces matched by their vertices, they make the mesh the
 * whole messages make (the same tetrahedra, by their vertices' gids) with
 * no mismatch. Out of order the merge refuses them, and with a piece left
 * out it finds the faces left open. */
START_TEST(merge_pieces_same_mesh)
{
    plc p;
    unit_cube_plc(&p);
    ref_opts o;
    ref_default_opts(&o);
    o.maxvol = 2e-4;
    ref_mesher mo;
    build_mo(&p, &o, 0, &mo);
    ck_assert_int_eq(ref_refine(&mo), 0);
    enum { P = 3, PIECE = 97, MAXN = 1024 };
    par_sub subs[P];
    subs_of(&mo, P, subs);
    pr_buf wb[P];
    const void *wmsg[P];
    size_t wlen[P];
    encode_subs(subs, NULL, P, wb, wmsg, wlen);
    ref_mesher m1, m2;
    par_merge_report r1, r2;
    ck_assert_int_eq(par_merge_build(wmsg, wlen, P, &p, NULL, &m1, &r1), 0);

    pr_buf *pb = calloc(MAXN, sizeof *pb);
    const void **pmsg = calloc(MAXN, sizeof *pmsg);
    size_t *plen = calloc(MAXN, sizeof *plen);
    ck_assert(pb && pmsg && plen);
    uint32_t n = 0, first_of[P + 1];
    for (uint32_t k = 0; k < P; k++) {
        const tm_mesh *m = &subs[k].r.m;
        par_merge_pieces pc;
        ck_assert_int_eq(par_merge_pieces_init(&pc, &subs[k], PIECE), 0);
        uint8_t *seen = calloc(m->nslots + 1, 1);
        ck_assert_ptr_nonnull(seen);
        const uint32_t *tets;
        uint32_t nt, got = 0;
        size_t total = 0;
        first_of[k] = n;
        while (par_merge_pieces_next(&pc, &tets, &nt)) {
            ck_assert_uint_lt(n, MAXN);
            got++;
            if (got < pc.count)
                ck_assert_uint_eq(nt, PIECE);
            ck_assert_uint_ge(nt, 1);
            ck_assert_uint_le(nt, PIECE);
            for (uint32_t i = 0; i < nt; i++) {
                ck_assert_uint_lt(tets[i], m->nslots);
                ck_assert(!tm_is_dead(m, tets[i]));
                ck_assert(!seen[tets[i]]);
                seen[tets[i]] = 1;
                if (i > 0)
                    ck_assert_uint_gt(tets[i], tets[i - 1]);
            }
            total += nt;
            pb[n] = (pr_buf)PR_BUF_INIT;
            ck_assert_int_eq(par_wire_encode_tets(&pb[n], &subs[k], tets, nt), 0);
            pmsg[n] = pb[n].data;
            plen[n] = pb[n].len;
            n++;
        }
        ck_assert_uint_eq(got, pc.count);
        ck_assert_uint_eq(total, m->nlive);
        ck_assert_uint_ge(pc.count, 3);
        par_merge_pieces_free(&pc);
        free(seen);
    }
    first_of[P] = n;
    ck_assert_int_eq(par_merge_build(pmsg, plen, n, &p, NULL, &m2, &r2), 0);
    ck_assert_uint_eq(par_merge_problems(&r2), 0);
    ck_assert_uint_eq(r2.tets, r1.tets);
    ck_assert_uint_eq(r2.vertices, r1.vertices);
    size_t n1, n2;
    uint64_t *g1 = gid_rows(&m1.m, &n1), *g2 = gid_rows(&m2.m, &n2);
    ck_assert_uint_eq(n1, n2);
    ck_assert(!memcmp(g1, g2, n1 * 4 * sizeof *g1));
    free(g1);
    free(g2);
    ref_free(&m1);
    ref_free(&m2);

    /* out of the PEs' order: PE 2's first piece before PE 1's */
    const void *xm = pmsg[first_of[1]];
    size_t xl = plen[first_of[1]];
    pmsg[first_of[1]] = pmsg[first_of[2]];
    plen[first_of[1]] = plen[first_of[2]];
    pmsg[first_of[2]] = xm;
    plen[first_of[2]] = xl;
    ck_assert_int_eq(par_merge_build(pmsg, plen, n, &p, NULL, &m2, &r2), PDR_EPARSE);
    pmsg[first_of[2]] = pmsg[first_of[1]];
    plen[first_of[2]] = plen[first_of[1]];
    pmsg[first_of[1]] = xm;
    plen[first_of[1]] = xl;
    /* PE 1's second piece left out */
    uint32_t gone = first_of[1] + 1;
    memmove(&pmsg[gone], &pmsg[gone + 1], (n - gone - 1) * sizeof *pmsg);
    memmove(&plen[gone], &plen[gone + 1], (n - gone - 1) * sizeof *plen);
    ck_assert_int_eq(par_merge_build(pmsg, plen, n - 1, &p, NULL, &m2, &r2), PDR_ETOPOLOGY);
    ck_assert_uint_gt(r2.open_faces, 0);

    for (uint32_t i = 0; i < n; i++)
        pr_buf_free(&pb[i]);
    free(pb);
    free(pmsg);
    free(plen);
    free_merge_case(wb, subs, P, &mo, &p);
}
END_TEST

/* Two merged meshes are the same: slots, vertices, links, markers, flags,
 * regions and boundary tables. */
static void same_merged(const ref_mesher *pm1, const ref_mesher *pm2)
{
    const ref_mesher m1 = *pm1, m2 = *pm2;
    const tm_mesh *a = &m1.m, *c = &m2.m;
    ck_assert_uint_eq(a->nslots, c->nslots);
    ck_assert_uint_eq(a->nlive, c->nlive);
    ck_assert_uint_eq(a->nghost, c->nghost);
    ck_assert_uint_eq(a->nv, c->nv);
    size_t ns = a->nslots;
    ck_assert(!memcmp(a->tets, c->tets, ns * sizeof *a->tets));
    ck_assert(!memcmp(a->flags, c->flags, ns * sizeof *a->flags));
    for (uint32_t t = 0; t < ns; t++)
        for (int i = 0; i < 4; i++)
            ck_assert_int_eq(tm_marker(a, t, i), tm_marker(c, t, i));
    ck_assert(!memcmp(a->xyz, c->xyz, 3 * (size_t)a->nv * sizeof *a->xyz));
    ck_assert(!memcmp(a->gid, c->gid, (size_t)a->nv * sizeof *a->gid));
    ck_assert_int_eq(m1.region != NULL, m2.region != NULL);
    if (m1.region)
        ck_assert(!memcmp(m1.region, m2.region, ns * sizeof *m1.region));
    ck_assert_uint_eq(m1.bd.nsegs, m2.bd.nsegs);
    ck_assert_uint_eq(m1.bd.nfacs, m2.bd.nfacs);
    /* field by field: the structures have padding */
    for (size_t i = 0; i < m1.bd.nsegs; i++) {
        const bd_subseg *e = &m1.bd.segs[i], *f = &m2.bd.segs[i];
        ck_assert(e->v[0] == f->v[0] && e->v[1] == f->v[1] && e->seg == f->seg &&
                  e->flags == f->flags);
    }
    for (size_t i = 0; i < m1.bd.nfacs; i++) {
        const bd_subfac *e = &m1.bd.facs[i], *f = &m2.bd.facs[i];
        ck_assert(!memcmp(e->v, f->v, sizeof e->v) && e->facet == f->facet &&
                  e->flags == f->flags);
    }
    ck_assert(!memcmp(m1.bd.vkind, m2.bd.vkind, (size_t)a->nv * sizeof *m1.bd.vkind));
    ck_assert(!memcmp(m1.bd.vfeat, m2.bd.vfeat, (size_t)a->nv * sizeof *m1.bd.vfeat));
    ck_assert(!memcmp(m1.bd.vrins, m2.bd.vrins, (size_t)a->nv * sizeof *m1.bd.vrins));
}

/* par_wire_from_sub's decoded form of a submesh is the decoder's of its
 * message, array by array; par_wire_decode_own's too. */
static void same_wire(const par_wire *x, const par_wire *y)
{
    const pr_submesh *a = x->sm, *b = y->sm;
    ck_assert(a->part == b->part && a->rank == b->rank && a->size == b->size &&
              a->n_facets == b->n_facets);
    uint32_t nv = a->vert.n, nt = a->tet.n, nf = a->iface.n;
    ck_assert(nv == b->vert.n && nt == b->tet.n && nf == b->iface.n);
    ck_assert(!memcmp(a->vert.gid, b->vert.gid, nv * sizeof *a->vert.gid));
    ck_assert(!memcmp(a->vert.xyz, b->vert.xyz, 3 * (size_t)nv * sizeof *a->vert.xyz));
    ck_assert(!memcmp(a->vert.flags, b->vert.flags, nv * sizeof *a->vert.flags));
    ck_assert(!memcmp(a->tet.v, b->tet.v, 4 * (size_t)nt * sizeof *a->tet.v));
    ck_assert(!memcmp(a->tet.marker, b->tet.marker, 4 * (size_t)nt * sizeof *a->tet.marker));
    ck_assert(!memcmp(a->tet.subseg, b->tet.subseg, nt));
    ck_assert(!nf || !memcmp(a->iface.face, b->iface.face, nf * sizeof *a->iface.face));
    ck_assert(!nf || !memcmp(a->iface.remote, b->iface.remote, nf * sizeof *a->iface.remote));
    ck_assert_uint_eq(x->next_seq, y->next_seq);
    ck_assert(!memcmp(x->vkind, y->vkind, nv));
    ck_assert(!memcmp(x->vfeat, y->vfeat, nv * sizeof *x->vfeat));
    ck_assert(!memcmp(x->vrins, y->vrins, nv * sizeof *x->vrins));
    ck_assert(!memcmp(x->tflags_le, y->tflags_le, 2 * (size_t)nt));
    ck_assert(!memcmp(x->region_le, y->region_le, 2 * (size_t)nt));
    ck_assert(!memcmp(x->link_le, y->link_le, 16 * (size_t)nt));
    ck_assert(x->nseg == y->nseg && x->nfac == y->nfac);
    ck_assert(!memcmp(x->seg_v, y->seg_v, 2 * (size_t)x->nseg * sizeof *x->seg_v));
    ck_assert(!memcmp(x->seg_id, y->seg_id, x->nseg * sizeof *x->seg_id));
    ck_assert(!memcmp(x->seg_flags, y->seg_flags, x->nseg * sizeof *x->seg_flags));
    ck_assert(!memcmp(x->fac_v, y->fac_v, 3 * (size_t)x->nfac * sizeof *x->fac_v));
    ck_assert(!memcmp(x->fac_id, y->fac_id, x->nfac * sizeof *x->fac_id));
    ck_assert(!memcmp(x->fac_flags, y->fac_flags, x->nfac * sizeof *x->fac_flags));
}

static void same_pairs(const par_merge_ahead *a, const par_merge_ahead *b)
{
    ck_assert(a->tets == b->tets && a->up == b->up && a->down == b->down &&
              a->bad_links == b->bad_links && a->misoriented == b->misoriented &&
              a->marker_mismatch == b->marker_mismatch && a->suspect == b->suspect);
    ck_assert_uint_eq(a->nhash, b->nhash);
    ck_assert(!a->nhash || !memcmp(a->hash, b->hash, a->nhash * sizeof *a->hash));
}

/* The merge as 'pdr mesh' runs it at rank 0 (cli/mesh_par.c): its own
 * submesh taken as it is (par_wire_from_sub_pairs: no message, its links
 * checked from the mesh ahead of the merge), the others' messages decoded
 * as they come (par_wire_decode_own), merged by par_merge_build_wires
 * (and by par_merge_build_wires_spent, which frees the tables it took).
 * Every wire and every check ahead is the same as from the messages'
 * bytes, and so are the merged mesh and the counts: with and without the
 * checks ahead, on a mesh that fits and with faults in PE 0's links. */
static void merge_own_case(const pr_buf *b, const par_sub *subs, uint32_t P, const plc *p,
                           int expect)
{
    par_wire w[3], wd[3];
    par_merge_ahead pairs[3], ah[3];
    ck_assert_uint_le(P, 3);
    for (uint32_t k = 0; k < P; k++) {
        ck_assert_int_eq(par_wire_from_sub_pairs(&subs[k], &w[k], &pairs[k]), 0);
        ck_assert_int_eq(par_wire_decode_own(b[k].data, b[k].len, p, &wd[k]), 0);
        same_wire(&w[k], &wd[k]);
        ck_assert_int_eq(par_merge_check_ahead(&wd[k], &ah[k]), 0);
        same_pairs(&pairs[k], &ah[k]);
    }
    ref_mesher m0;
    par_merge_report r0;
    ck_assert_int_eq(merge_mesh_on(b, P, p, &r0, 0, &m0), expect);
    for (uint32_t na = 0; na <= P; na++) {
        ref_mesher m1;
        par_merge_report r1;
        ck_assert_int_eq(par_merge_build_wires(w, P, pairs, na, p, NULL, &m1, &r1), expect);
        ck_assert(!memcmp(&r0, &r1, sizeof r0));
        if (!expect) {
            ck_assert_int_eq(r1.unmarked_known, 1);
            ck_assert_uint_eq(r1.unmarked_bounds, ref_unmarked_bounds(&m1));
            same_merged(&m0, &m1);
            ref_free(&m1);
        }
        ck_assert_int_eq(par_merge_build_wires(wd, P, ah, na, p, NULL, &m1, &r1), expect);
        ck_assert(!memcmp(&r0, &r1, sizeof r0));
        if (!expect)
            ref_free(&m1);
    }
    /* a check ahead of another message is refused */
    if (P > 1 && w[0].sm->tet.n != w[1].sm->tet.n) {
        ref_mesher m1;
        par_merge_report r1;
        ck_assert_int_eq(par_merge_build_wires(w, P, pairs + 1, 1, p, NULL, &m1, &r1),
                         PDR_EINVAL);
    }
    /* the merge that frees the tables as it takes them (as 'pdr mesh'
     * runs it, par_merge_build_wires_spent): the same mesh and counts on a
     * mesh that fits; on a fault, the same code with the first run's
     * counts, which find it */
    for (uint32_t na = 0; na <= P; na += P) {
        par_wire ws[3];
        par_merge_ahead ps[3];
        for (uint32_t k = 0; k < P; k++)
            ck_assert_int_eq(par_wire_from_sub_pairs(&subs[k], &ws[k], &ps[k]), 0);
        ref_mesher m1;
        par_merge_report r1;
        ck_assert_int_eq(par_merge_build_wires_spent(ws, P, ps, na, p, NULL, &m1, &r1), expect);
        if (!expect) {
            ck_assert(!memcmp(&r0, &r1, sizeof r0));
            same_merged(&m0, &m1);
            ref_free(&m1);
        } else {
            ck_assert_uint_gt(par_merge_problems(&r1), 0);
        }
        for (uint32_t k = 0; k < P; k++) {
            /* taken and freed, the counts kept */
            ck_assert_ptr_null(ws[k].sm->vert.gid);
            ck_assert_uint_eq(ws[k].sm->vert.n, w[k].sm->vert.n);
            if (!expect) {
                ck_assert_ptr_null(ws[k].sm->tet.v);
                ck_assert_ptr_null(ws[k].own);
            }
            ck_assert_uint_eq(ws[k].sm->tet.n, w[k].sm->tet.n);
            par_wire_clear(&ws[k]);
            par_merge_ahead_free(&ps[k]);
        }
    }
    if (!expect)
        ref_free(&m0);
    for (uint32_t k = 0; k < P; k++) {
        par_wire_clear(&w[k]);
        par_wire_clear(&wd[k]);
        par_merge_ahead_free(&pairs[k]);
        par_merge_ahead_free(&ah[k]);
    }
}

START_TEST(merge_own_submesh_same)
{
    plc p;
    ref_mesher mo;
    par_sub subs[3];
    pr_buf b[3];
    large_merge_case(&p, &mo, subs, b);
    merge_own_case(b, subs, 3, &p, 0);
    /* faults in PE 0's mesh (slot k is its message's tetrahedron k): a
     * link that does not come back, then also two pairs joined across
     * the wrong faces */
    uint32_t nt;
    link_offset(b[0].data, b[0].len, &nt);
    uint32_t x, a, y, c;
    two_linked_pairs(b[0].data, b[0].len, nt, &x, &a, &y, &c);
    tm_mesh *m = &subs[0].r.m;
    tm_link keep[4] = {m->tets[x / 4].n[x % 4], m->tets[y / 4].n[y % 4],
                       m->tets[a / 4].n[a % 4], m->tets[c / 4].n[c % 4]};
    m->tets[x / 4].n[x % 4] = tm_mklink(y / 4, (int)(y % 4));
    pr_buf_free(&b[0]);
    b[0] = (pr_buf)PR_BUF_INIT;
    ck_assert_int_eq(par_merge_encode(&b[0], &subs[0]), 0);
    merge_own_case(b, subs, 3, &p, PDR_ETOPOLOGY);
    m->tets[y / 4].n[y % 4] = tm_mklink(x / 4, (int)(x % 4));
    m->tets[a / 4].n[a % 4] = tm_mklink(c / 4, (int)(c % 4));
    m->tets[c / 4].n[c % 4] = tm_mklink(a / 4, (int)(a % 4));
    pr_buf_free(&b[0]);
    b[0] = (pr_buf)PR_BUF_INIT;
    ck_assert_int_eq(par_merge_encode(&b[0], &subs[0]), 0);
    merge_own_case(b, subs, 3, &p, PDR_ETOPOLOGY);
    m->tets[x / 4].n[x % 4] = keep[0];
    m->tets[y / 4].n[y % 4] = keep[1];
    m->tets[a / 4].n[a % 4] = keep[2];
    m->tets[c / 4].n[c % 4] = keep[3];
    /* flags passed on wrong: interior tetrahedra of PE 0 and PE 2 taken
     * for exterior ones, and an exterior one of PE 1 for interior: the
     * unmarked faces between inside and outside counted on the way are
     * those ref_unmarked_bounds finds (checked in merge_own_case) */
    for (uint32_t k = 0; k < 3; k++) {
        tm_mesh *mk = &subs[k].r.m;
        int want_in = k == 1, done = 0;
        for (uint32_t t = 0; t < mk->nslots && done < 3; t += 5)
            if (!tm_is_dead(mk, t) && !tm_is_ghost(mk, t) &&
                ref_is_interior(mk, t) == want_in) {
                mk->flags[t] ^= REF_F_EXTERIOR;
                done++;
            }
        ck_assert_int_eq(done, 3);
        pr_buf_free(&b[k]);
        b[k] = (pr_buf)PR_BUF_INIT;
        ck_assert_int_eq(par_merge_encode(&b[k], &subs[k]), 0);
    }
    {
        ref_mesher mw;
        par_merge_report rw;
        ck_assert_int_eq(merge_mesh_on(b, 3, &p, &rw, 0, &mw), 0);
        ck_assert_int_eq(rw.unmarked_known, 1);
        ck_assert_uint_gt(rw.unmarked_bounds, 0);
        ck_assert_uint_eq(rw.unmarked_bounds, ref_unmarked_bounds(&mw));
        ref_free(&mw);
    }
    merge_own_case(b, subs, 3, &p, 0);
    /* one PE alone, as 'pdr mesh -n 1' */
    par_sub one[1];
    pr_buf b1[1] = {PR_BUF_INIT};
    subs_of(&mo, 1, one);
    ck_assert_int_eq(par_merge_encode(&b1[0], &one[0]), 0);
    merge_own_case(b1, one, 1, &p, 0);
    pr_buf_free(&b1[0]);
    par_sub_free(&one[0]);
    free_merge_case(b, subs, 3, &mo, &p);
}
END_TEST

START_TEST(merge_counts_link_faults)
{
    plc p;
    ref_opts o;
    ref_mesher mo;
    refined_cube(&p, &o, &mo);
    par_sub subs[3];
    subs_of(&mo, 3, subs);
    pr_buf b[3];
    for (uint32_t k = 0; k < 3; k++) {
        b[k] = (pr_buf)PR_BUF_INIT;
        ck_assert_int_eq(par_merge_encode(&b[k], &subs[k]), 0);
    }
    par_merge_report rep;
    ck_assert_int_eq(merge_bufs(b, 3, &p, &rep), 0);
    uint8_t *keep = b[1].data;
    uint32_t nt;
    link_offset(keep, b[1].len, &nt);
    /* two pairs linked within PE 1, x-a and y-b, of four tetrahedra */
    uint32_t x, a, y, c;
    two_linked_pairs(keep, b[1].len, nt, &x, &a, &y, &c);

    /* x links to y, which does not link back */
    b[1].data = with_link(keep, b[1].len, x, y);
    ck_assert_int_eq(merge_bufs(b, 3, &p, &rep), PDR_ETOPOLOGY);
    ck_assert_uint_ge(rep.bad_links, 1);
    free(b[1].data);

    /* x-y and a-c: every link comes back, but joins two triangles */
    b[1].data = with_link(keep, b[1].len, x, y);
    uint8_t *t1 = b[1].data;
    b[1].data = with_link(t1, b[1].len, y, x);
    free(t1);
    t1 = b[1].data;
    b[1].data = with_link(t1, b[1].len, a, c);
    free(t1);
    t1 = b[1].data;
    b[1].data = with_link(t1, b[1].len, c, a);
    free(t1);
    ck_assert_int_eq(merge_bufs(b, 3, &p, &rep), PDR_ETOPOLOGY);
    ck_assert_uint_eq(rep.bad_links, 0);
    ck_assert_uint_ge(rep.misoriented, 1);
    free(b[1].data);
    b[1].data = keep;
    pr_buf_free(&b[1]);

    /* PE 1 holds a tetrahedron of PE 0 as well, linked to nothing: one
     * duplicate, and nothing else (the later copy is dropped) */
    const tm_mesh *m0 = &subs[0].r.m;
    uint32_t t0 = 0;
    while (tm_is_dead(m0, t0) || tm_is_ghost(m0, t0))
        t0++;
    tm_mesh *m1 = &subs[1].r.m;
    uint32_t lv[4];
    for (int i = 0; i < 4; i++) {
        uint32_t v = m0->tets[t0].v[i];
        const bd_set *bd = &subs[0].r.bd;
        ck_assert_int_eq(par_sub_vertex(&subs[1], m0->gid[v], tm_xyz(m0, v), bd->vkind[v],
                                        bd->vfeat[v], bd->vrins[v], &lv[i]),
                         0);
    }
    ck_assert_int_eq(tm_room(m1, 1), 0);
    uint32_t u = tm_alloc_tet(m1);
    for (int i = 0; i < 4; i++) {
        m1->tets[u].v[i] = lv[i];
        m1->tets[u].n[i] = TM_LINK_NONE;
    }
    b[1] = (pr_buf)PR_BUF_INIT;
    ck_assert_int_eq(par_merge_encode(&b[1], &subs[1]), 0);
    ck_assert_int_eq(merge_bufs(b, 3, &p, &rep), PDR_ETOPOLOGY);
    ck_assert_uint_eq(rep.dup_tets, 1);
    ck_assert_uint_eq(par_merge_problems(&rep), 1);

    /* ... and instead a tetrahedron on a face of PE 1's, with another
     * apex: that face is in three tetrahedra */
    pr_buf_free(&b[1]);
    /* (slot k of PE 1 is its message's tetrahedron k; the apex is not
     * the one across the face either, or this were a duplicate) */
    uint32_t t = x / 4, apex = TM_NONE, across = m1->tets[a / 4].v[a % 4];
    for (uint32_t k = 0; k < m1->nslots && apex == TM_NONE; k++)
        for (int i = 0; i < 4 && !tm_is_dead(m1, k); i++) {
            uint32_t v = m1->tets[k].v[i], *tv = m1->tets[t].v;
            if (v != TM_VINF && v != across && v != tv[0] && v != tv[1] && v != tv[2] &&
                v != tv[3])
                apex = v;
        }
    ck_assert_uint_ne(apex, TM_NONE);
    for (int i = 0; i < 4; i++) {
        m1->tets[u].v[i] = m1->tets[t].v[i];
        m1->tets[u].n[i] = TM_LINK_NONE;
    }
    m1->tets[u].v[x % 4] = apex; /* shares face x % 4 of t */
    b[1] = (pr_buf)PR_BUF_INIT;
    ck_assert_int_eq(par_merge_encode(&b[1], &subs[1]), 0);
    ck_assert_int_eq(merge_bufs(b, 3, &p, &rep), PDR_ETOPOLOGY);
    ck_assert_uint_ge(rep.nonmanifold, 1);
    ck_assert_uint_eq(rep.dup_tets + rep.bad_links, 0);
    pr_buf_free(&b[1]);
    tm_free_tet(m1, u);
    b[1] = (pr_buf)PR_BUF_INIT;
    ck_assert_int_eq(par_merge_encode(&b[1], &subs[1]), 0);
    ck_assert_int_eq(merge_bufs(b, 3, &p, &rep), 0);

    /* PE 2 adds a tetrahedron and its mirror image, glued on all four
     * faces: every link fits, only the vertices are twice (and no face of
     * theirs is one of the mesh's, or that would show too) */
    pr_buf_free(&b[2]);
    tm_mesh *m2 = &subs[2].r.m;
    uint32_t v2[4];
    for (uint32_t seed = 1;; seed++) {
        ck_assert_uint_lt(seed, 1000);
        for (int i = 0; i < 4; i++)
            v2[i] = 1 + (seed * 7919u * (uint32_t)(i + 1) + 31u * (uint32_t)i) % (m2->nv - 1);
        int ok = v2[0] != v2[1] && v2[0] != v2[2] && v2[0] != v2[3] && v2[1] != v2[2] &&
                 v2[1] != v2[3] && v2[2] != v2[3];
        for (int i = 0; i < 4 && ok; i++)
            ok = !has_face(m2, v2[(i + 1) % 4], v2[(i + 2) % 4], v2[(i + 3) % 4]);
        if (ok)
            break;
    }
    ck_assert_int_eq(tm_room(m2, 2), 0);
    uint32_t X = tm_alloc_tet(m2), Y = tm_alloc_tet(m2);
    static const int mirror[4] = {1, 0, 2, 3}; /* Y = (v1, v0, v2, v3) */
    for (int i = 0; i < 4; i++) {
        m2->tets[X].v[i] = v2[i];
        m2->tets[Y].v[i] = v2[mirror[i]];
        /* X's face i is opposite v[i], which is at mirror[i] in Y */
        m2->tets[X].n[i] = tm_mklink(Y, mirror[i]);
        m2->tets[Y].n[mirror[i]] = tm_mklink(X, i);
    }
    b[2] = (pr_buf)PR_BUF_INIT;
    ck_assert_int_eq(par_merge_encode(&b[2], &subs[2]), 0);
    ck_assert_int_eq(merge_bufs(b, 3, &p, &rep), PDR_ETOPOLOGY);
    ck_assert_uint_eq(rep.dup_tets, 1);
    /* the copy kept has its faces open then: they joined the one dropped */
    ck_assert_uint_eq(rep.open_faces, 4);
    ck_assert_uint_eq(par_merge_problems(&rep), 5);

    free_merge_case(b, subs, 3, &mo, &p);
}
END_TEST

/* Corrupted merge messages: refused or counted, never a crash (run under
 * ASan), in the links above all. */
START_TEST(merge_survives_corruption)
{
    plc p;
    unit_cube_plc(&p);
    ref_opts o;
    ref_default_opts(&o);
    o.maxvol = 0.01;
    ref_mesher mo;
    build_mo(&p, &o, 0, &mo);
    ck_assert_int_eq(ref_refine(&mo), 0);
    par_sub subs[2];
    subs_of(&mo, 2, subs);
    pr_buf b[2];
    for (uint32_t k = 0; k < 2; k++) {
        b[k] = (pr_buf)PR_BUF_INIT;
        ck_assert_int_eq(par_merge_encode(&b[k], &subs[k]), 0);
    }
    uint8_t *keep = b[1].data;
    size_t len = b[1].len;
    uint32_t nt;
    size_t at = link_offset(keep, len, &nt);
    uint8_t *bad = malloc(len);
    ck_assert_ptr_nonnull(bad);
    b[1].data = bad;
    par_merge_report rep;
    size_t merged = 0, counted = 0;
    uint64_t r = 88172645463325252ULL;
    for (int round = 0; round < 4000; round++) {
        memcpy(bad, keep, len);
        r ^= r << 13, r ^= r >> 7, r ^= r << 17;
        if (round % 2) {
            /* a link: to another face, or a code */
            uint32_t f = (uint32_t)(r % (4 * (uint64_t)nt));
            static const uint32_t codes[] = {PAR_WIRE_LINK_NONE, PAR_WIRE_LINK_IFACE};
            uint32_t c = (r >> 40) % 8 ? (uint32_t)((r >> 20) % (4 * (uint64_t)nt))
                                       : codes[(r >> 40) % 2];
            pr_store_u32(bad + at + 4 * (size_t)f, c);
        } else {
            /* anywhere: a few random bytes */
            size_t w = r % len, n = 1 + (r >> 32) % 4;
            for (size_t j = w; j < w + n && j < len; j++) {
                r ^= r << 13, r ^= r >> 7, r ^= r << 17;
                bad[j] = (uint8_t)r;
            }
        }
        int rc = merge_bufs(b, 2, &p, &rep);
        ck_assert(rc == 0 || rc == PDR_EPARSE || rc == PDR_ETOPOLOGY);
        merged += rc == 0;
        counted += rc == PDR_ETOPOLOGY;
    }
    /* the links are checked: most of those changes are counted */
    ck_assert_uint_gt(counted, 1000);
    b[1].data = keep;
    free(bad);
    (void)merged;
    for (uint32_t k = 0; k < 2; k++) {
        pr_buf_free(&b[k]);
        par_sub_free(&subs[k]);
    }
    ref_free(&mo);
    plc_free(&p);
}
END_TEST

static Suite *suite(void)
{
    Suite *s = suite_create("par");
    TCase *t = tcase_create("roundtrip");
    tcase_set_timeout(t, 300);
    tcase_add_test(t, round_trip_cube_in_cube);
    tcase_add_test(t, round_trip_tee);
    tcase_add_test(t, partition_properties);
    suite_add_tcase(s, t);
    t = tcase_create("setup");
    tcase_add_test(t, plc_round_trips);
    tcase_add_test(t, opts_round_trip);
    suite_add_tcase(s, t);
    t = tcase_create("malformed");
    tcase_set_timeout(t, 300);
    tcase_add_test(t, submesh_decoder_refuses_truncation);
    tcase_add_test(t, submesh_decoder_survives_corruption);
    tcase_add_test(t, plc_decoder_refuses_malformed);
    tcase_add_test(t, links_checked);
    tcase_add_test(t, facet_gaps_found);
    tcase_add_test(t, cavity_reply_tets);
    tcase_add_test(t, cavity_band_adjacency);
    tcase_add_test(t, cavity_reply_left);
    suite_add_tcase(s, t);
    t = tcase_create("merge");
    tcase_set_timeout(t, 120);
    tcase_add_test(t, merge_counts_mismatches);
    tcase_add_test(t, merge_counts_link_faults);
    tcase_add_test(t, merge_survives_corruption);
    tcase_add_test(t, merge_reclassifies);
    tcase_add_test(t, merge_finishes_left);
    tcase_add_test(t, merge_shares_agree);
    tcase_add_test(t, merge_threads_same_mesh);
    tcase_add_test(t, merge_own_submesh_same);
    tcase_add_test(t, merge_pieces_same_mesh);
    tcase_add_test(t, hdup_finds_repeats);
    suite_add_tcase(s, t);
    return s;
}

UNIT_MAIN(suite)
