/* Unit tests of the quality measures and statistics (check/ql.c). */
#include "config.h"

#include <math.h>
#include <stdio.h>

#include "check/ql.h"
#include "unit.h"

#define PI 3.14159265358979323846

static void near(double got, double want, double tol)
{
    ck_assert_msg(fabs(got - want) <= tol, "got %.17g, want %.17g", got, want);
}

START_TEST(regular_tetrahedron)
{
    /* Alternate corners of a cube: a regular tetrahedron of edge sqrt 2. */
    const double a[3] = {0, 0, 0}, b[3] = {1, 1, 0}, c[3] = {1, 0, 1}, d[3] = {0, 1, 1};
    ql_tet q;
    ql_tet_measure(a, b, c, d, &q);
    near(q.radius_edge, sqrt(6.0) / 4.0, 1e-15);
    near(q.circumradius, sqrt(3.0) / 2.0, 1e-15);
    near(q.shortest, sqrt(2.0), 1e-15);
    near(q.longest, sqrt(2.0), 1e-15);
    near(fabs(q.volume), 1.0 / 3.0, 1e-15);
    for (int e = 0; e < 6; e++)
        near(q.dihedral[e], acos(1.0 / 3.0) * 180 / PI, 1e-12);
    near(q.min_dihedral, 70.528779365509308, 1e-12);
}
END_TEST

START_TEST(right_corner_tetrahedron_and_orientation)
{
    const double o[3] = {0, 0, 0}, x[3] = {1, 0, 0}, y[3] = {0, 1, 0}, z[3] = {0, 0, 1};
    ql_tet q;
    ql_tet_measure(o, x, y, z, &q);
    near(q.volume, 1.0 / 6.0, 1e-16);
    /* circumcentre (1/2, 1/2, 1/2): R = sqrt(3)/2, shortest edge 1 */
    near(q.circumradius, sqrt(3.0) / 2.0, 1e-15);
    near(q.radius_edge, sqrt(3.0) / 2.0, 1e-15);
    near(q.longest, sqrt(2.0), 1e-15);
    /* at the three edges through the corner: 90; at the others:
     * acos(1/sqrt 3) = 54.7356 degrees */
    near(q.dihedral[0], 90, 1e-12);
    near(q.dihedral[1], 90, 1e-12);
    near(q.dihedral[2], 90, 1e-12);
    near(q.dihedral[3], acos(1 / sqrt(3.0)) * 180 / PI, 1e-12);
    near(q.max_dihedral, 90, 1e-12);
    ql_tet_measure(o, y, x, z, &q); /* swapped: negative volume */
    near(q.volume, -1.0 / 6.0, 1e-16);
    near(q.radius_edge, sqrt(3.0) / 2.0, 1e-15);
}
END_TEST

START_TEST(sliver_and_flat_tetrahedra)
{
    /* A sliver: the four corners of a square, two of them lifted by h.
     * Good edges, tiny volume, dihedral angles near 0 and 180. */
    double h = 1e-3;
    const double a[3] = {0, 0, 0}, b[3] = {1, 0, h}, c[3] = {1, 1, 0}, d[3] = {0, 1, h};
    ql_tet q;
    ql_tet_measure(a, b, c, d, &q);
    ck_assert(fabs(q.volume) < 1e-3);
    ck_assert(q.min_dihedral < 1.0);
    ck_assert(q.max_dihedral > 179.0);
    /* Its circumsphere is about the square's circumcircle: R ~ sqrt(2)/2,
     * so the ratio stays moderate: slivers are not caught by it. */
    near(q.radius_edge, sqrt(2.0) / 2.0, 1e-3);
    const double e[3] = {0.5, 0.5, 0}; /* flat: zero volume */
    ql_tet_measure(a, c, (const double[3]){1, 0, 0}, e, &q);
    ck_assert(q.volume == 0);
    ck_assert(isinf(q.radius_edge));
}
END_TEST

/* Two tetrahedra sharing the face (1, 2, 3). */
static const double two_xyz[5][3] = {{0, 0, -1}, {1, 0, 0}, {0, 1, 0}, {0, 0, 0}, {0.3, 0.3, 1}};
static const uint32_t two_tet[2][4] = {{0, 1, 2, 3}, {4, 1, 3, 2}};

START_TEST(mesh_statistics_boundary_by_adjacency)
{
    mesh_export m = {5, two_xyz, 2, two_tet, NULL, 0, NULL, NULL};
    ql_stats s;
    ck_assert_int_eq(ql_mesh_stats(&m, 2.0, &s), 0);
    ck_assert_uint_eq(s.ntet, 2);
    ck_assert_uint_eq(s.nboundary, 2); /* each has three free faces */
    ck_assert_uint_eq(s.npositive + s.nnegative, 2);
    near(s.volume, 1.0 / 6.0 + 1.0 / 6.0, 1e-15);
    size_t total = 0;
    for (int i = 0; i < QL_RE_NBINS; i++)
        total += s.re_hist[i];
    ck_assert_uint_eq(total, 2);
    total = 0;
    for (int i = 0; i < QL_DIH_NBINS; i++)
        total += s.dih_hist[0][i] + s.dih_hist[1][i];
    ck_assert_uint_eq(total, 12);
    ck_assert(s.re_min <= s.re_max);
    ck_assert(s.dih_min > 0 && s.dih_max < 180);
}
END_TEST

START_TEST(mesh_statistics_boundary_from_triangles)
{
    /* Only the second tetrahedron's face (4, 1, 3) is listed: only it is a
     * boundary element. */
    const uint32_t tri[1][3] = {{3, 4, 1}};
    mesh_export m = {5, two_xyz, 2, two_tet, NULL, 1, tri, NULL};
    ql_stats s;
    ck_assert_int_eq(ql_mesh_stats(&m, 0.5, &s), 0);
    ck_assert_uint_eq(s.nboundary, 1);
    ck_assert_uint_eq(s.re_above, 2); /* every ratio >= 0.612 > 0.5 */
    size_t b = 0;
    for (int i = 0; i < QL_DIH_NBINS; i++)
        b += s.dih_hist[0][i];
    ck_assert_uint_eq(b, 6);
}
END_TEST

START_TEST(text_and_gnuplot_output)
{
    mesh_export m = {5, two_xyz, 2, two_tet, NULL, 0, NULL, NULL};
    ql_stats s;
    ck_assert_int_eq(ql_mesh_stats(&m, 2.0, &s), 0);
    char *buf = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&buf, &len);
    ql_print(&s, f, 5);
    fclose(f);
    ck_assert_ptr_nonnull(strstr(buf, "tetrahedra 2 (2 boundary, 0 interior)"));
    ck_assert_ptr_nonnull(strstr(buf, "dihedral angles of boundary elements"));
    ck_assert_ptr_nonnull(strstr(buf, "  [175, 180)"));
    free(buf);
    f = open_memstream(&buf, &len);
    ck_assert_int_eq(ql_write_gnuplot(&s, f, "it's.png", NULL, 5), 0);
    fclose(f);
    ck_assert_ptr_nonnull(strstr(buf, "set output 'it''s.png'"));
    ck_assert_ptr_nonnull(strstr(buf, "Boundary Elements"));
    ck_assert_ptr_nonnull(strstr(buf, "\n177.5 "));
    free(buf);
}
END_TEST

static Suite *quality_suite(void)
{
    Suite *s = suite_create("quality");
    TCase *tc = tcase_create("tet");
    tcase_add_test(tc, regular_tetrahedron);
    tcase_add_test(tc, right_corner_tetrahedron_and_orientation);
    tcase_add_test(tc, sliver_and_flat_tetrahedra);
    suite_add_tcase(s, tc);
    tc = tcase_create("mesh");
    tcase_add_test(tc, mesh_statistics_boundary_by_adjacency);
    tcase_add_test(tc, mesh_statistics_boundary_from_triangles);
    tcase_add_test(tc, text_and_gnuplot_output);
    suite_add_tcase(s, tc);
    return s;
}

UNIT_MAIN(quality_suite)
