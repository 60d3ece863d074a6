/* Unit tests of the stages of 'pdr mesh' (cli/mesh_pipeline.h) used one by
 * one, the way the parallel driver will: a refinement run outside the
 * pipeline, and the write, report and verify stages given nothing but a
 * finished ref_output in a fresh context. The command itself is tested
 * through the pdr program by tests/mesh-*.sh. */
#include "config.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cli/mesh_pipeline.h"
#include "cli/pdr_cli.h"
#include "unit.h"

/* Quiet options for the built-in cube-in-cube, coarse enough to be quick;
 * it is meshed with nothing left above the bounds, so nothing is printed. */
static void cube_opts(mp_opts *o)
{
    mp_default_opts(o);
    o->domain = "cube-in-cube";
    o->ref.maxvol = 0.01;
    o->formats = 0;
    o->quiet = 1;
}

/* Runs read and initial mesh, refines outside the pipeline as a parallel
 * driver would, and exports. */
static void mesh_by_hand(mp_ctx *c)
{
    ck_assert_int_eq(mp_read(c), 0);
    ck_assert_str_eq(c->base, "cube-in-cube.1");
    ck_assert_int_eq(mp_initial_mesh(c), 0);
    ck_assert_uint_gt(c->is.tets, 0);
    ck_assert_uint_gt(c->v0, 0);
    double t = pdr_now();
    ck_assert_int_eq(ref_refine(&c->r), 0);
    c->sec[MP_REFINE] = pdr_now() - t;
    c->refined = 1;
    ck_assert_int_eq(mp_export(c), 0);
    ck_assert(c->have_out);
}

START_TEST(refinement_outside_the_pipeline)
{
    mp_opts o;
    cube_opts(&o);
    mp_ctx c;
    mp_init(&c, &o);
    mesh_by_hand(&c);
    ck_assert_uint_gt(c.v_added, 0);
    ck_assert_uint_gt(c.out.view.nt, c.is.tets);
    ck_assert_uint_eq(c.st.left_ratio + c.st.left_size + c.st.left_sliver, 0);
    ck_assert_int_eq(mp_write(&c), 0); /* no formats: nothing written */
    ck_assert_int_eq(mp_report(&c), 0);
    ck_assert_int_eq(mp_verify(&c), 0);
    for (int s = 0; s < MP_NSTAGE; s++)
        ck_assert(c.sec[s] >= 0);
    ck_assert(c.t_written >= c.t_start);
    mp_free(&c);
    mp_free(&c); /* a second time is harmless */
}
END_TEST

/* A tetrahedron taken for outside although it is inside: the interior's
 * boundary then has faces on no input facet, and the export refuses the
 * mesh (pdr mesh writes nothing). */
START_TEST(export_refuses_a_boundary_off_the_facets)
{
    mp_opts o;
    cube_opts(&o);
    mp_ctx c;
    mp_init(&c, &o);
    ck_assert_int_eq(mp_read(&c), 0);
    ck_assert_int_eq(mp_initial_mesh(&c), 0);
    ck_assert_int_eq(ref_refine(&c.r), 0);
    c.refined = 1;
    ck_assert_uint_eq(ref_unmarked_bounds(&c.r), 0);
    uint32_t t = 0;
    while (t < c.r.m.nslots && !ref_is_interior(&c.r.m, t))
        t++;
    ck_assert_uint_lt(t, c.r.m.nslots);
    c.r.m.flags[t] |= REF_F_EXTERIOR;
    ck_assert_uint_gt(ref_unmarked_bounds(&c.r), 0);
    ck_assert_int_eq(mp_export(&c), PDR_ETOPOLOGY);
    mp_free(&c);
}
END_TEST

static int file_size(const char *dir, const char *name, off_t *size)
{
    char path[512];
    struct stat st;
    snprintf(path, sizeof path, "%s/%s", dir, name);
    if (stat(path, &st))
        return -1;
    *size = st.st_size;
    return 0;
}

START_TEST(write_report_verify_from_an_output_alone)
{
    mp_opts o;
    cube_opts(&o);
    mp_ctx made;
    mp_init(&made, &o);
    mesh_by_hand(&made);

    /* A fresh context that never read a PLC or built a mesh receives the
     * finished mesh, its counts and an output name, as a driver would
     * after a merge. */
    char dir[] = "test_mesh_pipeline.XXXXXX";
    ck_assert_ptr_nonnull(mkdtemp(dir));
    o.formats = MP_FMT_NODE | MP_FMT_VTU | MP_FMT_MSH;
    mp_ctx c;
    mp_init(&c, &o);
    c.out = made.out;
    c.have_out = 1;
    made.have_out = 0;
    c.st = made.st;
    mp_free(&made);
    size_t n = strlen(dir) + 3;
    ck_assert_ptr_nonnull(c.base = malloc(n));
    snprintf(c.base, n, "%s/m", dir);

    ck_assert_int_eq(mp_write(&c), 0);
    ck_assert_int_eq(mp_report(&c), 0);
    ck_assert_int_eq(mp_verify(&c), 0);
    static const char *const files[] = {"m.node", "m.ele", "m.face", "m.vtu", "m.msh"};
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        off_t size = 0;
        ck_assert_int_eq(file_size(dir, files[i], &size), 0);
        ck_assert_int_gt(size, 0);
        char path[512];
        snprintf(path, sizeof path, "%s/%s", dir, files[i]);
        unlink(path);
    }
    rmdir(dir);
    mp_free(&c);
}
END_TEST

START_TEST(read_failures)
{
    mp_opts o;
    cube_opts(&o);
    o.domain = NULL;
    o.in = "no-such-input.poly";
    mp_ctx c;
    mp_init(&c, &o);
    ck_assert_int_eq(mp_read(&c), PDR_EIO);
    ck_assert_ptr_null(c.base);
    mp_free(&c);

    o.in = NULL; /* neither a file nor a domain */
    mp_init(&c, &o);
    ck_assert_int_eq(mp_read(&c), PDR_EINVAL);
    mp_free(&c);
}
END_TEST

static Suite *suite(void)
{
    Suite *s = suite_create("mesh_pipeline");
    TCase *t = tcase_create("stages");
    tcase_set_timeout(t, 60);
    tcase_add_test(t, refinement_outside_the_pipeline);
    tcase_add_test(t, export_refuses_a_boundary_off_the_facets);
    tcase_add_test(t, write_report_verify_from_an_output_alone);
    tcase_add_test(t, read_failures);
    suite_add_tcase(s, t);
    return s;
}

UNIT_MAIN(suite)
