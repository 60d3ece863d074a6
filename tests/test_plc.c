/* Unit tests of the PLC module: building, derived data, readers, facet
 * triangulation, validation. */
#include "config.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "plc/dom.h"
#include "plc/fm.h"
#include "plc/plc.h"
#include "plc/plc_split.h"
#include "plc/plc_tri.h"
#include "unit.h"

/* ------------------------------------------------------------- helpers */

static char tmpdir[64];

static void make_tmpdir(void)
{
    snprintf(tmpdir, sizeof tmpdir, "/tmp/pdr-test-plc-XXXXXX");
    ck_assert_ptr_nonnull(mkdtemp(tmpdir));
}

static void remove_tmpdir(void)
{
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmpdir);
    ck_assert_int_eq(system(cmd), 0);
}

static const char *write_file(const char *name, const char *text)
{
    static char path[256];
    snprintf(path, sizeof path, "%s/%s", tmpdir, name);
    FILE *f = fopen(path, "w");
    ck_assert_ptr_nonnull(f);
    fputs(text, f);
    fclose(f);
    return path;
}

static double facet_area(const plc *p, size_t f)
{
    double a = 0;
    for (size_t t = p->ftri_start[f]; t < p->ftri_start[f + 1]; t++) {
        const double *x = p->xyz[p->ftri[t][0]], *y = p->xyz[p->ftri[t][1]],
                     *z = p->xyz[p->ftri[t][2]];
        double u[3] = {y[0] - x[0], y[1] - x[1], y[2] - x[2]};
        double v[3] = {z[0] - x[0], z[1] - x[1], z[2] - x[2]};
        double c[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                       u[0] * v[1] - u[1] * v[0]};
        /* signed along the facet normal: all triangles must be positive */
        double s = c[0] * p->facets[f].normal[0] + c[1] * p->facets[f].normal[1] +
                   c[2] * p->facets[f].normal[2];
        ck_assert(s > 0);
        a += 0.5 * s;
    }
    return a;
}

static void dump(const pdr_diag *d)
{
    for (size_t i = 0; i < d->nkept; i++)
        fprintf(stderr, "  diag: %s\n", d->msgs[i]);
}

/* ------------------------------------------------------------- building */

START_TEST(cube_in_cube_derived_data)
{
    plc p;
    pdr_diag d = {0};
    dom_cube_opts o;
    dom_cube_defaults(&o);
    ck_assert_int_eq(plc_init(&p, "cube"), 0);
    ck_assert_int_eq(dom_cube_in_cube(&p, &o, &d), 0);
    ck_assert_int_eq(plc_validate(&p, &d), 0);
    ck_assert_uint_eq(p.nv, 16);
    ck_assert_uint_eq(p.nfacet, 12);
    ck_assert_uint_eq(p.nseg, 24);
    for (size_t s = 0; s < p.nseg; s++) {
        ck_assert_uint_lt(p.segs[s].v[0], p.segs[s].v[1]);
        ck_assert_uint_eq(p.seg_fstart[s + 1] - p.seg_fstart[s], 2);
    }
    for (size_t v = 0; v < p.nv; v++) {
        ck_assert_uint_eq(p.v_sstart[v + 1] - p.v_sstart[v], 3);
        ck_assert_uint_eq(p.v_fstart[v + 1] - p.v_fstart[v], 3);
    }
    for (size_t f = 0; f < p.nfacet; f++) {
        const double *n = p.facets[f].normal;
        ck_assert(fabs(n[0] * n[0] + n[1] * n[1] + n[2] * n[2] - 1) < 1e-15);
        ck_assert(fabs(n[p.facets[f].axis]) == 1.0);
        double side = f < 6 ? 1.0 : 0.5;
        ck_assert(fabs(facet_area(&p, f) - side * side) < 1e-15);
    }
    ck_assert_uint_eq(p.nhole, 1);
    ck_assert_uint_eq(p.nregion, 1);
    plc_free(&p);
    plc_free(&p); /* idempotent */
    pdr_diag_free(&d);
}
END_TEST

START_TEST(tee_is_valid_and_has_acute_angles)
{
    plc p;
    pdr_diag d = {0};
    dom_tee_opts o;
    dom_tee_defaults(&o);
    ck_assert_int_eq(plc_init(&p, "tee"), 0);
    ck_assert_int_eq(dom_tee(&p, &o, &d), 0);
    int rc = plc_validate(&p, &d);
    dump(&d);
    ck_assert_int_eq(rc, 0);
    /* Find the dihedral angle between the underside (marker 3) and the
     * bevel (4) and the mitred end (2): both 60 degrees inside. */
    int under = -1, bevel = -1, mitre = -1;
    for (size_t f = 0; f < p.nfacet; f++) {
        if (p.facets[f].marker == 3)
            under = (int)f;
        if (p.facets[f].marker == 4)
            bevel = (int)f;
        if (p.facets[f].marker == 2)
            mitre = (int)f;
    }
    ck_assert(under >= 0 && bevel >= 0 && mitre >= 0);
    /* Outward normals at an edge of a convex corner of interior angle a
     * make an angle of 180 - a. */
    const double *nu = p.facets[under].normal;
    for (int k = 0; k < 2; k++) {
        const double *nb = p.facets[k ? mitre : bevel].normal;
        double c = nu[0] * nb[0] + nu[1] * nb[1] + nu[2] * nb[2];
        double interior = 180 - acos(c) * 180 / 3.14159265358979323846;
        ck_assert_msg(fabs(interior - 60) < 1e-9, "angle %g", interior);
    }
    /* The bad parameter combinations are refused. */
    plc q;
    plc_init(&q, "tee");
    o.web = 0.9;
    ck_assert_int_eq(dom_tee(&q, &o, &d), PDR_EINVAL);
    plc_free(&q);
    plc_free(&p);
    pdr_diag_free(&d);
}
END_TEST

/* -------------------------------------------------------------- readers */

/* A unit cube whose top facet has a square hole, filled by a second facet
 * (like TetGen's example), a facet that is only a segment, volume holes
 * and regions; vertex attributes and markers. */
static const char poly_text[] =
    "# cube with a window\n"
    "12 3 1 1\n"
    "1 0 0 0  0.5 7\n2 1 0 0 0.5 7\n3 0 1 0 0.5 7\n4 1 1 0 0.5 7\n"
    "5 0 0 1 1 8\n6 1 0 1 1 8\n7 0 1 1 1 8\n8 1 1 1 1 8\n"
    "9 0.25 0.25 1 2 9\n10 0.75 0.25 1 2 9\n11 0.75 0.75 1 2 9\n12 0.25 0.75 1 2 9\n"
    "8 1\n"
    "1 0 1\n4 1 5 7 3\n"
    "1 0 2\n4 2 4 8 6\n"
    "1 0 3\n4 1 2 6 5\n"
    "1 0 4\n4 3 7 8 4\n"
    "1 0 5\n4 1 3 4 2\n"
    "2 1 6\n4 5 6 8\n 7\n4 9 10 11 12\n1 0.5 0.5 1\n"
    "1 0 7\n4 9 10 11 12\n"
    "1 0 8\n2 1 8\n"
    "1\n1 0.5 0.5 0.5\n"
    "2\n1 0.1 0.1 0.1 3 0.5\n2 0.9 0.9 0.9 4\n";

START_TEST(poly_reader_full_format)
{
    make_tmpdir();
    const char *path = write_file("window.poly", poly_text);
    plc p;
    pdr_diag d = {0};
    plc_init(&p, NULL);
    ck_assert_int_eq(plc_read(&p, path, &d), 0);
    ck_assert_int_eq(p.base, 1);
    ck_assert_uint_eq(p.nv, 12);
    ck_assert_uint_eq(p.nvattr, 1);
    ck_assert(p.vattr[8] == 2.0);
    ck_assert_int_eq(p.vmarker[0], 7);
    ck_assert_int_eq(p.vmarker[11], 9);
    ck_assert_uint_eq(p.nfacet, 7); /* the 8th is a free segment */
    ck_assert_uint_eq(p.nsegin, 1);
    ck_assert_int_eq(p.segin[0].marker, 8);
    ck_assert_uint_eq(p.segin[0].v[0], 0);
    ck_assert_uint_eq(p.segin[0].v[1], 7);
    ck_assert_int_eq(p.facets[5].marker, 6);
    ck_assert_uint_eq(p.facets[5].npoly, 2);
    ck_assert_uint_eq(p.facets[5].nhole, 1);
    ck_assert_int_eq(p.facets[5].line, 26);
    ck_assert_uint_eq(p.nhole, 1);
    ck_assert_uint_eq(p.nregion, 2);
    ck_assert(p.regions[0].attr == 3 && p.regions[0].maxvol == 0.5);
    ck_assert(p.regions[1].attr == 4 && p.regions[1].maxvol < 0);
    /* The free segment is the cube's diagonal: it crosses the inside
     * and meets the facets only at its ends, so the PLC is valid. */
    int rc = plc_validate(&p, &d);
    dump(&d);
    ck_assert_int_eq(rc, 0);
    ck_assert(fabs(facet_area(&p, 5) - 0.75) < 1e-15); /* 1 - 0.5^2 */
    ck_assert(fabs(facet_area(&p, 6) - 0.25) < 1e-15);
    /* Write it back and read it again: the same PLC. */
    char out[256];
    snprintf(out, sizeof out, "%s/again.poly", tmpdir);
    ck_assert_int_eq(plc_write_poly(&p, out, &d), 0);
    plc q;
    plc_init(&q, NULL);
    ck_assert_int_eq(plc_read(&q, out, &d), 0);
    ck_assert_int_eq(plc_validate(&q, &d), 0);
    ck_assert_uint_eq(q.nv, p.nv);
    ck_assert_uint_eq(q.nfacet, p.nfacet);
    ck_assert_uint_eq(q.ncorner, p.ncorner);
    ck_assert_uint_eq(q.nsegin, 1);
    ck_assert_uint_eq(q.nregion, 2);
    for (size_t v = 0; v < p.nv; v++)
        for (int k = 0; k < 3; k++)
            ck_assert(q.xyz[v][k] == p.xyz[v][k]);
    for (size_t c = 0; c < p.ncorner; c++)
        ck_assert_uint_eq(q.corners[c], p.corners[c]);
    plc_free(&q);
    plc_free(&p);
    pdr_diag_free(&d);
    remove_tmpdir();
}
END_TEST

START_TEST(poly_with_separate_zero_based_node_file)
{
    make_tmpdir();
    write_file("tet.node", "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n");
    char path[256];
    snprintf(path, sizeof path, "%s", write_file("tet.poly", "0 3 0 0\n4 0\n1\n3 0 2 1\n"
                                                 "1\n3 0 1 3\n1\n3 0 3 2\n1\n3 1 2 3\n0\n"));
    plc p;
    pdr_diag d = {0};
    plc_init(&p, NULL);
    ck_assert_int_eq(plc_read(&p, path, &d), 0);
    ck_assert_int_eq(p.base, 0);
    ck_assert_uint_eq(p.nv, 4);
    ck_assert_ptr_nonnull(strstr(p.vfile, "tet.node"));
    ck_assert_int_eq(plc_validate(&p, &d), 0);
    plc_free(&p);
    /* A vertex error in the .node file is reported against the .node. */
    write_file("tet.node", "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 1 0 0\n");
    plc_init(&p, NULL);
    ck_assert_int_eq(plc_read(&p, path, &d), 0);
    ck_assert_int_eq(plc_validate(&p, &d), PDR_EGEOMETRY);
    ck_assert_uint_ge(d.nkept, 1);
    ck_assert_ptr_nonnull(strstr(d.msgs[0], "tet.node:5: vertex 3 duplicates vertex 1"));
    plc_free(&p);
    pdr_diag_free(&d);
    remove_tmpdir();
}
END_TEST

static void put_f32(FILE *f, float v)
{
    uint32_t b;
    memcpy(&b, &v, 4);
    unsigned char o[4] = {(unsigned char)b, (unsigned char)(b >> 8),
                          (unsigned char)(b >> 16), (unsigned char)(b >> 24)};
    fwrite(o, 1, 4, f);
}

/* A binary STL: the 80-byte header holding text, the triangle count. */
static void put_stl_header(FILE *f, const char *text, unsigned char ntri)
{
    char head[80] = {0};
    strncpy(head, text, sizeof head - 1);
    fwrite(head, 1, 80, f);
    unsigned char n[4] = {ntri, 0, 0, 0};
    fwrite(n, 1, 4, f);
}

/* One binary STL triangle: a zero normal, corners c, no attribute. */
static void put_stl_triangle(FILE *f, const float c[3][3])
{
    for (int k = 0; k < 3; k++)
        put_f32(f, 0);
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++)
            put_f32(f, c[i][k]);
    fputc(0, f);
    fputc(0, f);
}

START_TEST(binary_stl_merges_vertices)
{
    make_tmpdir();
    char path[256];
    snprintf(path, sizeof path, "%s/tet.stl", tmpdir);
    FILE *f = fopen(path, "wb");
    ck_assert_ptr_nonnull(f);
    /* The header starts with "solid" on purpose: the size decides. */
    put_stl_header(f, "solid but binary", 4);
    const float v[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    const int tri[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
    for (int t = 0; t < 4; t++) {
        float c[3][3];
        for (int i = 0; i < 3; i++)
            for (int k = 0; k < 3; k++) /* -0 must merge with +0 */
                c[i][k] = t == 3 && v[tri[t][i]][k] == 0 ? -0.0f : v[tri[t][i]][k];
        put_stl_triangle(f, c);
    }
    fclose(f);
    plc p;
    pdr_diag d = {0};
    plc_init(&p, NULL);
    ck_assert_int_eq(plc_read(&p, path, &d), 0);
    ck_assert_uint_eq(p.nv, 4);
    ck_assert_uint_eq(p.nfacet, 4);
    ck_assert_int_eq(plc_validate(&p, &d), 0);
    plc_free(&p);
    /* Truncated: one triangle short. */
    ck_assert_int_eq(truncate(path, 84 + 3 * 50), 0);
    f = fopen(path, "r+b");
    fseek(f, 80, SEEK_SET);
    fputc(3, f); /* now consistent: 3 triangles, an open surface */
    fclose(f);
    plc_init(&p, NULL);
    ck_assert_int_eq(plc_read(&p, path, &d), 0);
    ck_assert_int_eq(plc_validate(&p, &d), PDR_EGEOMETRY);
    ck_assert_ptr_nonnull(strstr(d.msgs[0], "belongs to no other facet"));
    plc_free(&p);
    pdr_diag_free(&d);
    remove_tmpdir();
}
END_TEST

/* Two tetrahedron surfaces that cross each other, as a binary STL: no
 * lines to name, so the message names the facets (the triangles' order)
 * and no "line 0". */
START_TEST(binary_stl_intersection_names_no_line)
{
    make_tmpdir();
    char path[256];
    snprintf(path, sizeof path, "%s/two.stl", tmpdir);
    FILE *f = fopen(path, "wb");
    ck_assert_ptr_nonnull(f);
    put_stl_header(f, "two tetrahedra", 8);
    const float v[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    const int tri[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
    for (int copy = 0; copy < 2; copy++)
        for (int t = 0; t < 4; t++) {
            float c[3][3];
            for (int i = 0; i < 3; i++)
                for (int k = 0; k < 3; k++)
                    c[i][k] = v[tri[t][i]][k] + (copy ? 0.25f : 0.0f);
            put_stl_triangle(f, c);
        }
    fclose(f);
    plc p;
    pdr_diag d = {0};
    plc_init(&p, NULL);
    ck_assert_int_eq(plc_read(&p, path, &d), 0);
    ck_assert_int_eq(plc_validate(&p, &d), PDR_EGEOMETRY);
    ck_assert_uint_gt(d.nkept, 0);
    int named = 0;
    for (size_t i = 0; i < d.nkept; i++) {
        ck_assert_ptr_null(strstr(d.msgs[i], "line 0"));
        named += strstr(d.msgs[i], " intersect near ") != NULL;
    }
    ck_assert_int_gt(named, 0);
    plc_free(&p);
    pdr_diag_free(&d);
    remove_tmpdir();
}
END_TEST

/* A non-planar quadrilateral (quad meshes) is cut along its Delaunay
 * diagonal in projection, not the first ear's: here the corners 0 and 2
 * have the obtuse angles, so the cut joins them. A square pyramid whose
 * base is that quadrilateral, twisted out of its plane. */
START_TEST(nonplanar_quad_cut_along_delaunay_diagonal)
{
    make_tmpdir();
    char path[256];
    snprintf(path, sizeof path, "%s/pyramid.off", tmpdir);
    FILE *f = fopen(path, "w");
    ck_assert_ptr_nonnull(f);
    fputs("OFF\n5 5 0\n"
          "0 -1 0\n2 0 0.05\n0 1 0\n-2 0 0.05\n0 0 2\n"
          "4 2 1 0 3\n3 0 1 4\n3 1 2 4\n3 2 3 4\n3 3 0 4\n",
          f);
    fclose(f);
    plc p;
    pdr_diag d = {0};
    plc_init(&p, NULL);
    ck_assert_int_eq(plc_read(&p, path, &d), 0);
    ck_assert_uint_eq(p.read_split, 1);
    ck_assert_uint_eq(p.nfacet, 6);
    int cut02 = 0, cut13 = 0;
    for (size_t k = 0; k < p.nfacet; k++) {
        const plc_polygon *q = &p.polys[p.facets[k].poly_first];
        int has[4] = {0, 0, 0, 0};
        for (uint32_t i = 0; i < q->n; i++)
            if (p.corners[q->first + i] < 4)
                has[p.corners[q->first + i]] = 1;
        if (q->n == 3 && has[0] && has[2] && (has[1] || has[3]))
            cut02++;
        if (q->n == 3 && has[1] && has[3] && (has[0] || has[2]))
            cut13++;
    }
    ck_assert_int_eq(cut02, 2);
    ck_assert_int_eq(cut13, 0);
    ck_assert_int_eq(plc_validate(&p, &d), 0);
    plc_free(&p);
    pdr_diag_free(&d);
    remove_tmpdir();
}
END_TEST

/* A facet of three nearly collinear corners (from a public CAD part):
 * in the facet's triangulation the side from the third corner to the
 * first crosses an edge that ends at a corner of the enclosing triangle,
 * whose fan is open; the edge must still be found there. */
START_TEST(sliver_facet_triangulates)
{
    plc p;
    plc_init(&p, NULL);
    const double v[4][3] = {{6.00721, 4.00481, 0},
                            {6.00721, 2.0024, 0},
                            {6.01099, 0.861366, 0},
                            {6.0, 2.0, 1.0}};
    for (int i = 0; i < 4; i++)
        ck_assert_int_eq(plc_add_vertex(&p, v[i], 0, NULL), 0);
    static const uint32_t f[4][3] = {{0, 1, 2}, {0, 3, 1}, {1, 3, 2}, {2, 3, 0}};
    for (int i = 0; i < 4; i++) {
        ck_assert_int_eq(plc_begin_facet(&p, 0, 0), 0);
        ck_assert_int_eq(plc_add_polygon(&p, f[i], 3, 0), 0);
    }
    pdr_diag d = {0};
    ck_assert_int_eq(plc_derive(&p, &d), 0);
    /* Every insertion order of the corners (the workspace's random
     * state decides it): one of them gives that triangulation. */
    for (uint32_t seed = 1; seed <= 64; seed++) {
        plc_cdt w = {0};
        w.rng = seed * 2654435761u;
        plc_cdt_fail fail;
        ck_assert_int_eq(plc_cdt_facet(&w, &p, 0, &fail), 0);
        ck_assert_uint_eq(w.nout, 1);
        plc_cdt_free(&w);
    }
    int rc = plc_validate(&p, &d);
    if (rc)
        pdr_diag_print(&d, stderr);
    ck_assert_int_eq(rc, 0);
    pdr_diag_free(&d);
    plc_free(&p);
}
END_TEST

static const char *fixture(const char *name)
{
    static char path[4096];
    const char *top = getenv("top_srcdir");
    snprintf(path, sizeof path, "%s/tests/data/plc/%s", top ? top : ".", name);
    return path;
}

START_TEST(smesh_off_stl_fixtures)
{
    const char *names[] = {"cube.smesh", "tet.off", "tet.stl"};
    const size_t nv[] = {8, 4, 4}, nf[] = {6, 4, 4};
    for (int i = 0; i < 3; i++) {
        plc p;
        pdr_diag d = {0};
        plc_init(&p, NULL);
        int rc = plc_read(&p, fixture(names[i]), &d);
        if (!rc)
            rc = plc_validate(&p, &d);
        dump(&d);
        ck_assert_int_eq(rc, 0);
        ck_assert_uint_eq(p.nv, nv[i]);
        ck_assert_uint_eq(p.nfacet, nf[i]);
        if (i == 0) {
            ck_assert_int_eq(p.facets[2].marker, 12); /* corners over 2 lines */
            ck_assert_uint_eq(p.nregion, 1);
            ck_assert(p.regions[0].maxvol == 0.01);
        }
        plc_free(&p);
        pdr_diag_free(&d);
    }
}
END_TEST

/* ----------------------------------------------------------- validation */

static int validate_text(const char *name, const char *text, pdr_diag *d)
{
    make_tmpdir();
    const char *path = write_file(name, text);
    plc p;
    plc_init(&p, NULL);
    int rc = plc_read(&p, path, d);
    if (!rc)
        rc = plc_validate(&p, d);
    plc_free(&p);
    remove_tmpdir();
    return rc;
}

/* ------------------------------------------------ more surface formats */

static const char *surf_fixture(const char *name)
{
    static char path[4096];
    const char *top = getenv("top_srcdir");
    snprintf(path, sizeof path, "%s/tests/data/surf/%s", top ? top : ".", name);
    return path;
}

/* Corner k of the only polygon of facet f. */
static uint32_t facet_corner(const plc *p, size_t f, uint32_t k)
{
    return p->corners[p->polys[p->facets[f].poly_first].first + k];
}

static uint32_t facet_ncorner(const plc *p, size_t f)
{
    return p->polys[p->facets[f].poly_first].n;
}

/* A value in n bytes, little-endian (be: big-endian). */
static void put_bytes(FILE *f, uint64_t u, int n, int be)
{
    for (int i = 0; i < n; i++)
        fputc((int)(u >> (8 * (be ? n - 1 - i : i))) & 0xff, f);
}

static void put_double(FILE *f, double x, int be)
{
    uint64_t u;
    memcpy(&u, &x, sizeof u);
    put_bytes(f, u, 8, be);
}

/* Writes surface s in format fmt (0 PLY ascii, 1 PLY binary
 * little-endian, 2 PLY binary big-endian, 3 OBJ, 4 Medit) with the
 * decorations other writers add (properties and elements to skip,
 * texture and normal indices, relative indices, continued lines,
 * sections to skip); Medit references are facet k's k % 3 + 1 when
 * refs, else 0. Returns the path. */
static const char *write_surface(const plc *s, int fmt, int refs)
{
    static const char *names[] = {"s.ply", "sle.ply", "sbe.ply", "s.obj", "s.mesh"};
    static char path[256];
    snprintf(path, sizeof path, "%s/%s", tmpdir, names[fmt]);
    FILE *f = fopen(path, "wb");
    ck_assert_ptr_nonnull(f);
    size_t nv = s->nv, nf = s->nfacet;
    if (fmt <= 2) {
        static const char *form[] = {"ascii", "binary_little_endian", "binary_big_endian"};
        fprintf(f, "ply\nformat %s 1.0\ncomment written by test_plc\n"
                   "element material 1\nproperty float shine\n"
                   "element vertex %zu\nproperty double x\nproperty float64 y\n"
                   "property float nx\nproperty double z\nproperty uchar red\n"
                   "element face %zu\nproperty uchar flags\n"
                   "property list uchar int vertex_indices\n"
                   "element edge 1\nproperty int vertex1\nproperty int vertex2\n"
                   "end_header\n",
                form[fmt], nv, nf);
        int be = fmt == 2;
        if (fmt == 0)
            fprintf(f, "0.5\n");
        else
            put_bytes(f, 0x3f000000u, 4, be);
        for (size_t v = 0; v < nv; v++) {
            const double *x = s->xyz[v];
            if (fmt == 0) {
                fprintf(f, "%.17g %.17g 0.5 %.17g 200\n", x[0], x[1], x[2]);
            } else {
                put_double(f, x[0], be);
                put_double(f, x[1], be);
                put_bytes(f, 0x3f000000u, 4, be);
                put_double(f, x[2], be);
                put_bytes(f, 200, 1, be);
            }
        }
        for (size_t k = 0; k < nf; k++) {
            uint32_t n = facet_ncorner(s, k);
            if (fmt == 0) {
                fprintf(f, "7 %u", n);
                for (uint32_t i = 0; i < n; i++)
                    fprintf(f, " %u", facet_corner(s, k, i));
                fprintf(f, "\n");
            } else {
                put_bytes(f, 7, 1, be);
                put_bytes(f, n, 1, be);
                for (uint32_t i = 0; i < n; i++)
                    put_bytes(f, facet_corner(s, k, i), 4, be);
            }
        }
        if (fmt == 0)
            fprintf(f, "0 1\n");
        else
            put_bytes(f, 0, 4, be), put_bytes(f, 1, 4, be);
    } else if (fmt == 3) {
        fprintf(f, "# written by test_plc\nmtllib none.mtl\no part\n");
        /* the first face before the vertices it names */
        fprintf(f, "f %u %u %u\n", facet_corner(s, 0, 0) + 1, facet_corner(s, 0, 1) + 1,
                facet_corner(s, 0, 2) + 1);
        for (size_t v = 0; v < nv; v++)
            fprintf(f, "v %.17g %.17g %.17g 1 0 0\nvt 0.5 0.5\nvn 0 0 1\n", s->xyz[v][0],
                    s->xyz[v][1], s->xyz[v][2]);
        fprintf(f, "g side\ns 1\nusemtl steel\n");
        for (size_t k = 1; k < nf; k++) {
            fprintf(f, "f");
            for (uint32_t i = 0; i < facet_ncorner(s, k); i++) {
                uint32_t c = facet_corner(s, k, i);
                if (k % 4 == 1)
                    fprintf(f, " %u/%u/%u", c + 1, c + 1, c + 1);
                else if (k % 4 == 2)
                    fprintf(f, " %u//%u", c + 1, c + 1);
                else if (k % 4 == 3)
                    fprintf(f, " %ld", (long)c - (long)nv); /* relative */
                else
                    fprintf(f, " %u/%u%s", c + 1, c + 1, i == 0 ? " \\\n " : "");
            }
            fprintf(f, "\n");
        }
        fprintf(f, "l 1 2\n");
    } else {
        fprintf(f, "MeshVersionFormatted 2\n\nDimension\n3\n\nVertices\n%zu\n", nv);
        for (size_t v = 0; v < nv; v++)
            fprintf(f, "%.17g %.17g %.17g 0\n", s->xyz[v][0], s->xyz[v][1], s->xyz[v][2]);
        fprintf(f, "# a comment\nEdges\n1\n1 2 5\nTriangles\n%zu\n", nf);
        for (size_t k = 0; k < nf; k++)
            fprintf(f, "%u %u %u %d\n", facet_corner(s, k, 0) + 1, facet_corner(s, k, 1) + 1,
                    facet_corner(s, k, 2) + 1, refs ? (int)(k % 3) + 1 : 0);
        fprintf(f, "Corners 2 1 2\nEnd\n");
    }
    fclose(f);
    return path;
}

/* One closed surface written in five more formats reads as the same PLC:
 * the same vertices in the same order, the same faces with the same
 * corners, and it validates. */
START_TEST(surface_formats_read_alike)
{
    plc s;
    pdr_diag d = {0};
    plc_init(&s, NULL);
    ck_assert_int_eq(plc_read(&s, surf_fixture("torus-0.3.off"), &d), 0);
    ck_assert_uint_gt(s.nfacet, 100);
    make_tmpdir();
    for (int fmt = 0; fmt < 5; fmt++) {
        const char *path = write_surface(&s, fmt, 0);
        plc p;
        plc_init(&p, NULL);
        int rc = plc_read(&p, path, &d);
        if (!rc)
            rc = plc_validate(&p, &d);
        dump(&d);
        ck_assert_msg(rc == 0, "format %d", fmt);
        ck_assert_uint_eq(p.nv, s.nv);
        for (size_t v = 0; v < s.nv; v++)
            for (int k = 0; k < 3; k++)
                ck_assert(p.xyz[v][k] == s.xyz[v][k]);
        ck_assert_uint_eq(p.nfacet, s.nfacet);
        for (size_t k = 0; k < s.nfacet; k++) {
            ck_assert_uint_eq(facet_ncorner(&p, k), facet_ncorner(&s, k));
            for (uint32_t i = 0; i < facet_ncorner(&s, k); i++)
                ck_assert_uint_eq(facet_corner(&p, k, i), facet_corner(&s, k, i));
            ck_assert_int_eq(p.facets[k].marker, 0);
        }
        plc_free(&p);
    }
    /* Medit's triangle references are the facets' markers. */
    plc p;
    plc_init(&p, NULL);
    ck_assert_int_eq(plc_read(&p, write_surface(&s, 4, 1), &d), 0);
    for (size_t k = 0; k < s.nfacet; k++)
        ck_assert_int_eq(p.facets[k].marker, (int)(k % 3) + 1);
    plc_free(&p);
    plc_free(&s);
    pdr_diag_free(&d);
    remove_tmpdir();
}
END_TEST

/* What the readers refuse, and that the message names the file and, in
 * text, the line. */
START_TEST(surface_format_errors)
{
    static const struct {
        const char *name, *text, *expect;
    } bad[] = {
        {"a.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty "
                  "float y\nproperty float z\nend_header\n0 0 0\n",
         "a.ply:7: the file has no faces (a point cloud?)"},
        {"b.ply", "ply\nformat ascii 2.0\nend_header\n", "b.ply:2: PLY version '2.0'"},
        {"c.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty "
                  "float y\nproperty float z\nelement face 1\nproperty list uchar int "
                  "vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
         "c.ply:13: vertex index 3 is out of range [0, 2]"},
        {"d.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float "
                  "x\nproperty float y\nproperty float z\nelement face 1\nproperty list "
                  "uchar int vertex_indices\nend_header\n",
         "d.ply: vertex 0: unexpected end of file"},
        {"e.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n",
         "e.ply:4: unexpected end of file in the header"},
        {"f.ply", "solid\n", "f.ply:1: not a PLY file"},
        {"a.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 9\n",
         "a.obj:5: vertex 9 is out of range [1, 4]"},
        {"b.obj", "v 0 0 0\nf -2 1 1\n", "b.obj:2: relative vertex number -2 reaches"},
        {"c.obj", "v 0 0 0\ncstype bspline\n", "c.obj:2: free-form geometry ('cstype')"},
        {"d.obj", "v 0 0 0\nf 1 x 2\n", "d.obj:2: face corner 'x' is not a vertex number"},
        {"e.obj", "v 0 0 0\nl 1 1\n", "e.obj: the file has no faces"},
        {"a.mesh", "MeshVersionFormatted 2\nDimension 2\n", "a.mesh:2: Dimension 2"},
        {"b.mesh", "MeshVersionFormatted 1\nDimension 3\nPolygons 0\n",
         "b.mesh:3: unknown keyword 'Polygons'"},
        {"c.mesh", "MeshVersionFormatted 1\nVertices 1\n0 0 0 0\nTriangles 1\n1 1 2 0\n",
         "c.mesh:5: vertex 2 is out of range [1, 1]"},
        {"d.mesh", "Vertices 1\n0 0 0 0\n", "d.mesh:1: not a Medit mesh"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        pdr_diag d = {0};
        ck_assert_int_ne(validate_text(bad[i].name, bad[i].text, &d), 0);
        ck_assert_uint_ge(d.nkept, 1);
        ck_assert_msg(strstr(d.msgs[0], bad[i].expect) != NULL, "%s: got '%s'", bad[i].name,
                      d.msgs[0]);
        pdr_diag_free(&d);
    }
}
END_TEST

START_TEST(coplanar_overlap_and_touching_vertex_are_intersections)
{
    pdr_diag d = {0};
    /* Two tetrahedra whose bottom faces overlap in the plane z = 0. */
    const char *overlap =
        "8 3 0 0\n1 0 0 0\n2 2 0 0\n3 0 2 0\n4 0 0 1\n"
        "5 0.5 0.5 0\n6 3 0.5 0\n7 0.5 3 0\n8 0.5 0.5 -1\n"
        "8 0\n1\n3 1 3 2\n1\n3 1 2 4\n1\n3 1 4 3\n1\n3 2 3 4\n"
        "1\n3 5 6 7\n1\n3 5 8 6\n1\n3 5 7 8\n1\n3 6 8 7\n0\n";
    ck_assert_int_eq(validate_text("o.poly", overlap, &d), PDR_EGEOMETRY);
    ck_assert_ptr_nonnull(strstr(d.msgs[0], "facets 1 and 5"));
    pdr_diag_free(&d);
    /* A tetrahedron whose apex touches another's face from outside. */
    const char *touch =
        "8 3 0 0\n1 0 0 0\n2 2 0 0\n3 0 2 0\n4 0 0 1\n"
        "5 0.5 0.5 0\n6 1 1 -1\n7 0 1 -1\n8 1 0 -1\n"
        "8 0\n1\n3 1 3 2\n1\n3 1 2 4\n1\n3 1 4 3\n1\n3 2 3 4\n"
        "1\n3 6 7 8\n1\n3 5 6 7\n1\n3 5 7 8\n1\n3 5 8 6\n0\n";
    ck_assert_int_eq(validate_text("t.poly", touch, &d), PDR_EGEOMETRY);
    ck_assert_uint_ge(d.nkept, 1);
    ck_assert_ptr_nonnull(strstr(d.msgs[0], "intersect"));
    pdr_diag_free(&d);
    /* Two cubes sharing a face exactly, with the face listed once each:
     * coplanar facets covering the same region overlap. */
    const char *twin =
        "12 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 1 1 0\n5 0 0 1\n6 1 0 1\n7 0 1 1\n"
        "8 1 1 1\n9 2 0 0\n10 2 1 0\n11 2 0 1\n12 2 1 1\n"
        "12 0\n1\n4 1 5 7 3\n1\n4 2 4 8 6\n1\n4 1 2 6 5\n1\n4 3 7 8 4\n1\n4 1 3 4 2\n"
        "1\n4 5 6 8 7\n1\n4 2 6 8 4\n1\n4 9 10 12 11\n1\n4 2 9 11 6\n1\n4 4 8 12 10\n"
        "1\n4 2 4 10 9\n1\n4 6 11 12 8\n0\n";
    ck_assert_int_eq(validate_text("w.poly", twin, &d), PDR_EGEOMETRY);
    int found = 0;
    for (size_t i = 0; i < d.nkept; i++)
        found |= strstr(d.msgs[i], "facets 2 and 7") != NULL;
    ck_assert_msg(found, "no overlap reported for the doubled facet");
    pdr_diag_free(&d);
}
END_TEST

START_TEST(shared_internal_facet_is_valid)
{
    /* Two cubes glued along one facet, listed once (a material
     * interface): four facets meet at each of its edges, and the PLC is
     * valid. */
    const char *glued =
        "12 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 1 1 0\n5 0 0 1\n6 1 0 1\n7 0 1 1\n"
        "8 1 1 1\n9 2 0 0\n10 2 1 0\n11 2 0 1\n12 2 1 1\n"
        "11 0\n1\n4 1 5 7 3\n1\n4 2 4 8 6\n1\n4 1 2 6 5\n1\n4 3 7 8 4\n1\n4 1 3 4 2\n"
        "1\n4 5 6 8 7\n1\n4 9 10 12 11\n1\n4 2 9 11 6\n1\n4 4 8 12 10\n"
        "1\n4 2 4 10 9\n1\n4 6 11 12 8\n0\n";
    pdr_diag d = {0};
    int rc = validate_text("g.poly", glued, &d);
    dump(&d);
    ck_assert_int_eq(rc, 0);
    pdr_diag_free(&d);
}
END_TEST

/* A cube [0,2]^3 whose faces are each four triangles around the face's
 * centre (OFF, vertices 0-7 the corners, 8-13 the centres), with the top
 * face (z = 2) tilted up at its centre by 'lift' so that its triangles are
 * not coplanar when lift is nonzero. */
static void fan_cube_off(char *buf, size_t n, const char *lift)
{
    snprintf(buf, n,
             "OFF\n14 24 0\n"
             "0 0 0\n2 0 0\n2 2 0\n0 2 0\n0 0 2\n2 0 2\n2 2 2\n0 2 2\n"
             "1 1 0\n1 1 %s\n1 0 1\n1 2 1\n0 1 1\n2 1 1\n"
             /* bottom z=0 (centre 8), top z=2 (9) */
             "3 0 3 8\n3 3 2 8\n3 2 1 8\n3 1 0 8\n"
             "3 4 5 9\n3 5 6 9\n3 6 7 9\n3 7 4 9\n"
             /* y=0 (10), y=2 (11) */
             "3 0 1 10\n3 1 5 10\n3 5 4 10\n3 4 0 10\n"
             "3 3 7 11\n3 7 6 11\n3 6 2 11\n3 2 3 11\n"
             /* x=0 (12), x=2 (13) */
             "3 0 4 12\n3 4 7 12\n3 7 3 12\n3 3 0 12\n"
             "3 1 2 13\n3 2 6 13\n3 6 5 13\n3 5 1 13\n",
             lift);
}

/* Reads and validates OFF text, then prepares it (fm_prepare) with the
 * facet tolerance facet_tol. */
static int prepare_text_tol(const char *text, double angle, double facet_tol, plc *p,
                            fm_stats *st, pdr_diag *d)
{
    make_tmpdir();
    const char *path = write_file("s.off", text);
    plc_init(p, NULL);
    int rc = plc_read(p, path, d);
    if (!rc)
        rc = plc_validate(p, d);
    if (!rc)
        rc = fm_prepare(p, angle, facet_tol, st, d);
    remove_tmpdir();
    return rc;
}

/* The same with the default facet tolerance. */
static int prepare_text(const char *text, double angle, plc *p, fm_stats *st, pdr_diag *d)
{
    return prepare_text_tol(text, angle, FM_FACET_TOL, p, st, d);
}

START_TEST(coplanar_triangles_merge_into_facets)
{
    char off[1024];
    fan_cube_off(off, sizeof off, "2");
    plc p;
    fm_stats st;
    pdr_diag d = {0};
    int rc = prepare_text(off, FM_MERGE_ANGLE, &p, &st, &d);
    dump(&d);
    ck_assert_int_eq(rc, 0);
    /* Six square facets, each with its centre as an isolated vertex; the
     * twelve cube edges are the only segments left. */
    ck_assert_uint_eq(st.facets_before, 24);
    ck_assert_uint_eq(st.triangles_merged, 24);
    ck_assert_uint_eq(p.nfacet, 6);
    ck_assert_uint_eq(p.nseg, 12);
    for (size_t f = 0; f < p.nfacet; f++) {
        const plc_facet *F = &p.facets[f];
        ck_assert_uint_eq(F->npoly, 2);
        ck_assert_uint_eq(p.polys[F->poly_first].n, 4);
        ck_assert_uint_eq(p.polys[F->poly_first + 1].n, 1);
        /* each facet triangulated with its centre: four triangles */
        ck_assert_uint_eq(p.ftri_start[f + 1] - p.ftri_start[f], 4);
    }
    /* Cube edges meet at 90 degrees: nothing sharp or acute. */
    ck_assert_uint_eq(st.sharp_segments, 0);
    ck_assert_uint_eq(st.acute_vertices, 0);
    for (size_t s = 0; s < p.nseg; s++)
        ck_assert_double_eq_tol(p.seg_mindih[s], 90.0, 1e-4);
    plc_free(&p);
    pdr_diag_free(&d);

    /* With the merge off, every triangle stays a facet. */
    rc = prepare_text(off, -1, &p, &st, &d);
    ck_assert_int_eq(rc, 0);
    ck_assert_uint_eq(p.nfacet, 24);
    ck_assert_uint_eq(st.triangles_merged, 0);
    plc_free(&p);
    pdr_diag_free(&d);
}
END_TEST

START_TEST(merge_respects_the_angle_tolerance)
{
    /* The top centre lifted by 1e-12: the top's triangles are coplanar
     * within the planar tolerance but not exactly, and meet at an angle
     * within 0.1 degrees of 180. The default tolerance merges them, an
     * angular tolerance of 0 (exactly coplanar only) does not. */
    char off[1024];
    fan_cube_off(off, sizeof off, "2.000000000001");
    plc p;
    fm_stats st;
    pdr_diag d = {0};
    ck_assert_int_eq(prepare_text(off, FM_MERGE_ANGLE, &p, &st, &d), 0);
    ck_assert_uint_eq(p.nfacet, 6);
    plc_free(&p);
    ck_assert_int_eq(prepare_text(off, 0, &p, &st, &d), 0);
    ck_assert_uint_eq(p.nfacet, 5 + 4);
    plc_free(&p);
    /* Lifted by 1e-3 the top's triangles meet at 179.92 degrees, within
     * the angular tolerance, but they are not planar: merging them would
     * move the surface, so they stay four facets, whatever the
     * tolerance. */
    fan_cube_off(off, sizeof off, "2.001");
    ck_assert_int_eq(prepare_text(off, 10, &p, &st, &d), 0);
    ck_assert_uint_eq(p.nfacet, 5 + 4);
    ck_assert_uint_eq(st.sharp_segments, 0);
    plc_free(&p);
    pdr_diag_free(&d);
}
END_TEST

START_TEST(near_planar_facets_within_facet_tol)
{
    /* The top centre lifted by 1e-6 (the diagonal is 2 sqrt(3)): beyond
     * the planar tolerance, so with facet_tol 0 the top stays four
     * triangles; with facet_tol 1e-6 it is one bent facet (its corners
     * within 3.5e-6 of its plane), the PLC says so, its four inner edges
     * are no segments, and only the top is bent. */
    char off[1024];
    fan_cube_off(off, sizeof off, "2.000001");
    plc p;
    fm_stats st;
    pdr_diag d = {0};
    ck_assert_int_eq(prepare_text_tol(off, FM_MERGE_ANGLE, 0, &p, &st, &d), 0);
    ck_assert_uint_eq(p.nfacet, 5 + 4);
    ck_assert_uint_eq(st.bent_facets, 0);
    ck_assert(p.planar_tol == PLC_PLANAR_TOL);
    plc_free(&p);
    ck_assert_int_eq(prepare_text_tol(off, FM_MERGE_ANGLE, 1e-6, &p, &st, &d), 0);
    dump(&d);
    ck_assert_uint_eq(p.nfacet, 6);
    ck_assert_uint_eq(p.nseg, 12);
    ck_assert_uint_eq(st.bent_facets, 1);
    ck_assert_uint_eq(st.bent_regrouped, 0);
    ck_assert_int_eq(st.bent_undone, 0);
    ck_assert(p.planar_tol == 1e-6);
    size_t bent = 0;
    for (size_t f = 0; f < p.nfacet; f++) {
        if (!plc_facet_bent(&p, f))
            continue;
        bent++;
        ck_assert(p.facets[f].bend > 1e-8 && p.facets[f].bend < 3.5e-6);
        /* the facet triangulated in its projection: four triangles about
         * the lifted centre, covering the square's projected area */
        ck_assert_uint_eq(p.ftri_start[f + 1] - p.ftri_start[f], 4);
        double a = 0;
        for (size_t t = p.ftri_start[f]; t < p.ftri_start[f + 1]; t++)
            a += plc_facet_proj_area(&p, f, p.xyz[p.ftri[t][0]], p.xyz[p.ftri[t][1]],
                                     p.xyz[p.ftri[t][2]]);
        ck_assert(fabs(a - 4.0) < 1e-9);
    }
    ck_assert_uint_eq(bent, 1);
    plc_free(&p);
    /* Lifted by 1e-3 it is beyond that tolerance too: four facets. */
    fan_cube_off(off, sizeof off, "2.001");
    ck_assert_int_eq(prepare_text_tol(off, FM_MERGE_ANGLE, 1e-6, &p, &st, &d), 0);
    ck_assert_uint_eq(p.nfacet, 5 + 4);
    ck_assert_uint_eq(st.bent_facets, 0);
    plc_free(&p);
    pdr_diag_free(&d);
}
END_TEST

START_TEST(sharp_segments_and_acute_vertices)
{
    /* A wedge: triangle (0,0,0) (1,0,0) (0,0.25,0) extruded to z = 1;
     * the edge at (1,0,z) has a dihedral angle of atan(0.25) = 14 degrees,
     * and its two corners see segments at 14 degrees. */
    const char *wedge = "OFF\n6 8 0\n0 0 0\n1 0 0\n0 0.25 0\n0 0 1\n1 0 1\n0 0.25 1\n"
                        "3 0 2 1\n3 3 4 5\n"
                        "3 0 1 4\n3 0 4 3\n3 1 2 5\n3 1 5 4\n3 2 0 3\n3 2 3 5\n";
    plc p;
    fm_stats st;
    pdr_diag d = {0};
    int rc = prepare_text(wedge, FM_MERGE_ANGLE, &p, &st, &d);
    dump(&d);
    ck_assert_int_eq(rc, 0);
    ck_assert_uint_eq(p.nfacet, 5); /* three rectangles and two triangles */
    ck_assert_uint_eq(st.sharp_segments, 1);
    /* the corners of the thin end: the 14-degree angle of each end
     * triangle, the other corners have 90 degrees or 76 */
    ck_assert_uint_eq(st.acute_vertices, 2);
    /* one 14-degree corner per end triangle: a bad tetrahedron at each
     * for a bound of 2 (below asin(1/4) = 14.48 degrees), none for 14 */
    ck_assert_uint_eq(fm_thin_corners(&p, 14.5), 2);
    ck_assert_uint_eq(fm_thin_corners(&p, 14.0), 0);
    plc_free(&p);
    pdr_diag_free(&d);
}
END_TEST

START_TEST(thin_corners_of_a_dart)
{
    /* A prism over the dart A (0,0), B (4,0.5), C (0,1), D (3.95,0.5):
     * convex corners at A and C (0.1 degrees) and B (14.25), a reflex
     * one at D (345.6 inside, its edges 14.4 degrees apart), which is
     * not thin; the sides are rectangles. */
    const char *dart = "OFF\n8 6 0\n0 0 0\n4 0.5 0\n0 1 0\n3.95 0.5 0\n"
                       "0 0 1\n4 0.5 1\n0 1 1\n3.95 0.5 1\n"
                       "4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 1 2 6 5\n4 2 3 7 6\n4 3 0 4 7\n";
    plc p;
    fm_stats st;
    pdr_diag d = {0};
    int rc = prepare_text(dart, FM_MERGE_ANGLE, &p, &st, &d);
    dump(&d);
    ck_assert_int_eq(rc, 0);
    ck_assert_uint_eq(fm_thin_corners(&p, 14.5), 6);
    ck_assert_uint_eq(fm_thin_corners(&p, 14.0), 4);
    ck_assert_uint_eq(fm_thin_corners(&p, 0.05), 0);
    plc_free(&p);
    pdr_diag_free(&d);
}
END_TEST

START_TEST(segments_along_thin_facets_cut)
{
    /* A bar 1 long and 0.05 x 0.05 across, its sides rectangles of two
     * triangles each: the four long segments lie on facets 0.05 wide, so
     * every mesh below B = 2 cuts them into pieces shorter than 0.4;
     * plc_split_long cuts them below 3 B W = 0.3 (4 pieces, 3 points
     * each); the short ones (facets 1 wide on one side) stay. No sharp
     * segment (90 degrees) and no acute vertex. */
    const char *bar = "OFF\n8 12 0\n0 0 0\n1 0 0\n1 0.05 0\n0 0.05 0\n"
                      "0 0 0.05\n1 0 0.05\n1 0.05 0.05\n0 0.05 0.05\n"
                      "3 0 2 1\n3 0 3 2\n3 4 5 6\n3 4 6 7\n3 0 1 5\n3 0 5 4\n"
                      "3 1 2 6\n3 1 6 5\n3 2 3 7\n3 2 7 6\n3 3 0 4\n3 3 4 7\n";
    plc p;
    fm_stats st;
    pdr_diag d = {0};
    int rc = prepare_text(bar, FM_MERGE_ANGLE, &p, &st, &d);
    dump(&d);
    ck_assert_int_eq(rc, 0);
    ck_assert_uint_eq(p.nfacet, 6);
    ck_assert_uint_eq(p.nseg, 12);
    ck_assert_int_eq(plc_small_angles(&p), 0);
    double area[6];
    for (size_t f = 0; f < 6; f++)
        area[f] = facet_area(&p, f);
    plc_split_stats ss;
    ck_assert_int_eq(plc_split_long(&p, 2.0, PLC_SPLIT_MAX_PIECES, &ss, &d), 0);
    dump(&d);
    ck_assert_uint_eq(ss.segments, 4);
    ck_assert_uint_eq(ss.points, 12);
    ck_assert_uint_eq(p.nv, 20);
    ck_assert_uint_eq(p.nseg, 24);
    ck_assert_ptr_nonnull(p.ftri);
    ck_assert_ptr_nonnull(p.v_minang);
    for (size_t f = 0; f < 6; f++)
        ck_assert(fabs(facet_area(&p, f) - area[f]) < 1e-12);
    /* the new vertices lie on the long edges, at quarters */
    for (uint32_t v = 8; v < 20; v++) {
        double x = p.xyz[v][0];
        ck_assert(fabs(x - 0.25) < 1e-12 || fabs(x - 0.5) < 1e-12 || fabs(x - 0.75) < 1e-12);
        ck_assert(p.xyz[v][1] == 0 || p.xyz[v][1] == 0.05);
        ck_assert(p.xyz[v][2] == 0 || p.xyz[v][2] == 0.05);
        ck_assert(p.v_minang[v] > 179.0);
    }
    /* every piece now shorter than 3 B W: nothing more to cut */
    ck_assert_int_eq(plc_split_long(&p, 2.0, PLC_SPLIT_MAX_PIECES, &ss, &d), 0);
    ck_assert_uint_eq(ss.segments, 0);
    ck_assert_uint_eq(p.nv, 20);
    /* a bound ten times as loose cuts nothing */
    plc_free(&p);
    rc = prepare_text(bar, FM_MERGE_ANGLE, &p, &st, &d);
    ck_assert_int_eq(rc, 0);
    ck_assert_int_eq(plc_split_long(&p, 20.0, PLC_SPLIT_MAX_PIECES, &ss, &d), 0);
    ck_assert_uint_eq(ss.segments, 0);
    ck_assert_uint_eq(p.nv, 8);
    plc_free(&p);
    pdr_diag_free(&d);
}
END_TEST

START_TEST(segments_at_small_angles_not_cut)
{
    /* The dart of thin_corners_of_a_dart: its vertices are acute and
     * its long sides are not cut, however thin the facets next to them. */
    const char *dart = "OFF\n8 6 0\n0 0 0\n4 0.5 0\n0 1 0\n3.95 0.5 0\n"
                       "0 0 1\n4 0.5 1\n0 1 1\n3.95 0.5 1\n"
                       "4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 1 2 6 5\n4 2 3 7 6\n4 3 0 4 7\n";
    plc p;
    fm_stats st;
    pdr_diag d = {0};
    ck_assert_int_eq(prepare_text(dart, FM_MERGE_ANGLE, &p, &st, &d), 0);
    ck_assert_int_eq(plc_small_angles(&p), 1);
    plc_split_stats ss;
    ck_assert_int_eq(plc_split_long(&p, 2.0, PLC_SPLIT_MAX_PIECES, &ss, &d), 0);
    ck_assert_uint_eq(ss.points, 0);
    ck_assert_uint_eq(p.nv, 8);
    plc_free(&p);
    pdr_diag_free(&d);
}
END_TEST

static Suite *plc_suite(void)
{
    Suite *s = suite_create("plc");
    TCase *tc = tcase_create("build");
    tcase_add_test(tc, cube_in_cube_derived_data);
    tcase_add_test(tc, tee_is_valid_and_has_acute_angles);
    suite_add_tcase(s, tc);
    tc = tcase_create("read");
    tcase_add_test(tc, poly_reader_full_format);
    tcase_add_test(tc, poly_with_separate_zero_based_node_file);
    tcase_add_test(tc, binary_stl_merges_vertices);
    tcase_add_test(tc, binary_stl_intersection_names_no_line);
    tcase_add_test(tc, sliver_facet_triangulates);
    tcase_add_test(tc, nonplanar_quad_cut_along_delaunay_diagonal);
    tcase_add_test(tc, smesh_off_stl_fixtures);
    suite_add_tcase(s, tc);
    tc = tcase_create("validate");
    tcase_add_test(tc, coplanar_overlap_and_touching_vertex_are_intersections);
    tcase_add_test(tc, shared_internal_facet_is_valid);
    tcase_add_test(tc, surface_formats_read_alike);
    tcase_add_test(tc, surface_format_errors);
    suite_add_tcase(s, tc);
    tc = tcase_create("prepare");
    tcase_add_test(tc, coplanar_triangles_merge_into_facets);
    tcase_add_test(tc, merge_respects_the_angle_tolerance);
    tcase_add_test(tc, near_planar_facets_within_facet_tol);
    tcase_add_test(tc, sharp_segments_and_acute_vertices);
    tcase_add_test(tc, thin_corners_of_a_dart);
    tcase_add_test(tc, segments_along_thin_facets_cut);
    tcase_add_test(tc, segments_at_small_angles_not_cut);
    suite_add_tcase(s, tc);
    return s;
}

UNIT_MAIN(plc_suite)
