/* cli/mesh_pipeline.c -- the stages of 'pdr mesh': read, initial mesh,
 * refine, export, write, report, verify (see mesh_pipeline.h). */
#include "config.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "base/fj.h"
#include "base/pdr_util.h"
#include "cli/mesh_pipeline.h"
#include "cli/pdr_cli.h"
#include "io/face.h"
#include "io/msh.h"
#include "io/tg.h"
#include "io/vtu.h"
#include "mesh/tm.h"
#include "mesh/vf.h"
#include "plc/dom.h"
#include "plc/plc_split.h"

/* The command whose name the messages carry. */
#define MP_CMD "mesh"

void mp_default_opts(mp_opts *o)
{
    memset(o, 0, sizeof *o);
    ref_default_opts(&o->ref);
    o->formats = MP_FMT_NODE;
    o->merge_angle = FM_MERGE_ANGLE;
    o->facet_tol = FM_FACET_TOL;
    o->max_points = -1;
    o->mo_auto = 1;
}

/* The refinement's progress callback: a pdr_progress line on stderr. */
static void show_progress(void *arg, const ref_mesher *r)
{
    pdr_progress_line(arg, "pdr mesh: %u vertices, %u tetrahedra (with exterior)", r->m.nv - 1,
                      r->m.nlive - r->m.nghost);
}

void mp_init(mp_ctx *c, const mp_opts *o)
{
    memset(c, 0, sizeof *c);
    c->o = *o;
    c->o.ref.progress = show_progress;
    c->o.ref.progress_arg = &c->pg;
    c->t_start = pdr_now();
    pdr_progress_start(&c->pg, c->t_start, o->quiet);
}

int mp_retry_exact_facets(mp_ctx *c, const mp_opts *given, int rc, int read)
{
    if (!rc || rc == PDR_ENOMEM || !read || !c->fm.bent_facets)
        return 0;
    mp_opts exact = *given;
    exact.facet_tol = 0;
    if (!exact.quiet)
        printf("near-planar facets: the mesh failed with them; meshing again with exact "
               "facets\n");
    mp_free(c);
    mp_init(c, &exact);
    return 1;
}

void mp_free(mp_ctx *c)
{
    if (c->have_out)
        ref_output_free(&c->out);
    if (c->have_r)
        ref_free(&c->r);
    if (c->have_plc)
        plc_free(&c->p);
    c->have_out = c->have_r = c->have_plc = 0;
    pdr_diag_free(&c->diag);
    pr_free(c->base);
    c->base = NULL;
}

/* The common way a stage fails: whatever diagnostics are pending, then
 * the reason. Returns rc. */
static int fail(mp_ctx *c, int rc)
{
    if (rc == PDR_ENOMEM) {
        pdr_cli_fail(MP_CMD, &c->diag, rc);
    } else {
        pdr_diag_print(&c->diag, stderr);
        pdr_cli_error(MP_CMD, "%s", pdr_strerror(rc));
    }
    return rc;
}

/* The name of the input in messages and of the default output. */
static const char *input_name(const mp_ctx *c)
{
    return c->o.in ? c->o.in : c->o.domain;
}

/* ------------------------------------------------------------- read */

/* Fills the (initialised) PLC from the input file or the domain,
 * validates it, merges coplanar triangles (validating the result again)
 * and finds the sharp features; the reasons for a failure are in diag. */
static int load_plc(mp_ctx *c)
{
    int rc;
    if (c->o.in) {
        rc = plc_read(&c->p, c->o.in, &c->diag);
    } else {
        int dom = c->o.domain ? dom_lookup(c->o.domain) : -1;
        rc = dom < 0 ? PDR_EINVAL : dom_build_default(&c->p, dom, &c->diag);
    }
    if (!rc)
        rc = plc_validate(&c->p, &c->diag);
    if (!rc)
        rc = fm_prepare(&c->p, c->o.merge_angle, c->o.facet_tol, &c->fm, &c->diag);
    return rc;
}

/* IN.poly -> IN.1 (TetGen's naming, which never overwrites an input), or
 * the -o name as given. */
static char *output_base(const mp_ctx *c)
{
    if (c->o.out)
        return pr_strdup(c->o.out);
    const char *in = input_name(c);
    return pdr_path_ext(in, pdr_path_stem(in), ".1");
}

int mp_read(mp_ctx *c)
{
    double t = pdr_now();
    int rc = plc_init(&c->p, input_name(c));
    if (rc)
        return fail(c, rc);
    c->have_plc = 1;
    if ((rc = load_plc(c))) {
        /* The reader's file:line messages say it all for a bad input;
         * anything else (memory, no input) gets its reason too. */
        if (rc == PDR_EPARSE || rc == PDR_EGEOMETRY || rc == PDR_EIO)
            pdr_diag_print(&c->diag, stderr);
        else
            fail(c, rc);
        return rc;
    }
    if (!(c->base = output_base(c)))
        return fail(c, PDR_ENOMEM);
    c->sec[MP_READ] = pdr_now() - t;
    const plc *p = &c->p;
    if (!c->o.quiet)
        printf("input: %s: %zu vertices, %zu segments, %zu facets, %zu hole%s, %zu region%s "
               "(%.3f s)\n",
               input_name(c), p->nv, p->nseg, p->nfacet, p->nhole, p->nhole == 1 ? "" : "s",
               p->nregion, p->nregion == 1 ? "" : "s", c->sec[MP_READ]);
    if (!c->o.quiet && p->read_welded)
        printf("input repair: %zu vert%s merged into an equal one before %s\n",
               p->read_welded, p->read_welded == 1 ? "ex" : "ices",
               p->read_welded == 1 ? "it" : "them");
    if (!c->o.quiet && p->read_dropped)
        printf("input repair: %zu face%s with fewer than 3 distinct corners dropped (no "
               "area)\n", p->read_dropped, p->read_dropped == 1 ? "" : "s");
    if (!c->o.quiet && p->read_split)
        printf("input repair: %zu non-planar polygon%s cut into triangles\n", p->read_split,
               p->read_split == 1 ? "" : "s");
    if (!c->o.quiet && (c->fm.triangles_merged || c->fm.sharp_segments || c->fm.acute_vertices ||
                        c->fm.smooth_segments))
        printf("input preparation: %zu coplanar triangles merged (%zu facets before, %zu "
               "after), %zu sharp segments (dihedral < %g degrees), %zu acute vertices "
               "(segments at < %g degrees), %zu smooth segments (dihedral >= %g degrees: a "
               "tessellated curved surface)\n",
               c->fm.triangles_merged, c->fm.facets_before, c->fm.facets_after,
               c->fm.sharp_segments, FM_SHARP_DIH, c->fm.acute_vertices, FM_ACUTE_ANG,
               c->fm.smooth_segments, FM_SMOOTH_DIH);
    if (!c->o.quiet && (c->fm.bent_facets || c->fm.bent_regrouped))
        printf("near-planar facets: %zu merged facets planar within --facet-tol %g of the "
               "bounding box (their inner edges no segments), %zu groups refused and merged "
               "exactly\n",
               c->fm.bent_facets, c->o.facet_tol, c->fm.bent_regrouped);
    if (!c->o.quiet && c->fm.bent_undone)
        printf("near-planar facets: undone (with them the facets did not validate: they "
               "crossed or did not triangulate); merged exactly\n");
    return 0;
}

/* ----------------------------------------------------- initial mesh */

/* Where a vertex of kind vkind (bd.h) on input feature feat lies, as " on
 * the segment between input vertices A and B", " on facet F (line L)" or
 * " inside the volume". */
/* "facet F (line L)", or "facet F" where the input has no lines (binary
 * STL). */
static void facet_label(const plc *p, size_t f, char *buf, size_t size)
{
    if (p->facets[f].line > 0)
        snprintf(buf, size, "facet %zu (line %ld)", f + 1, p->facets[f].line);
    else
        snprintf(buf, size, "facet %zu", f + 1);
}

static void feature_name(const plc *p, int vkind, uint32_t feat, char *buf, size_t size)
{
    char fl[64];
    switch (vkind) {
    case BD_V_SEGMENT:
        snprintf(buf, size, " on the segment between input vertices %ld and %ld",
                 plc_vnum(p, p->segs[feat].v[0]), plc_vnum(p, p->segs[feat].v[1]));
        break;
    case BD_V_FACET:
        facet_label(p, feat, fl, sizeof fl);
        snprintf(buf, size, " on %s", fl);
        break;
    default:
        snprintf(buf, size, " inside the volume");
        break;
    }
}

/* The message of a run stopped by the bound on inserted points: how many,
 * and where the last one went, which is where the refinement runs on. */
void mp_recovery_stuck_text(const ref_mesher *r, int digits, char *buf, size_t size)
{
    snprintf(buf, size,
             "the recovery of missing boundary pieces does not terminate: after %zu splits of "
             "missing pieces (the bound: %d per input vertex and %d more) a piece near (%.*g, "
             "%.*g, %.*g) is still missing; splits cascade where facets meet at a small angle",
             ref_recovery_splits(r), REF_RECOVERY_PER_VERTEX, REF_RECOVERY_BASE, digits,
             r->stop_at[0], digits, r->stop_at[1], digits, r->stop_at[2]);
}

static int point_limit(mp_ctx *c)
{
    pdr_progress_end(&c->pg);
    const ref_mesher *r = &c->r;
    const plc *p = &c->p;
    size_t n = r->st.seg_points + r->st.fac_points + r->st.tet_points;
    if (r->stopped_below && r->stop_hidden) {
        char where[160];
        feature_name(p, r->stop_vkind, r->stop_feat, where, sizeof where);
        pdr_cli_error(MP_CMD,
                      "the boundary recovery cannot recover a missing piece of the boundary%s: "
                      "after %zu points, the split at (%.17g, %.17g, %.17g) has no valid "
                      "constrained cavity (facets around it, long thin triangles nearly in the "
                      "plane of their neighbours, hide part of what it must replace; the "
                      "recovery by cavity retriangulation, tried first, left it missing) "
                      "(nothing written)",
                      where, n, r->stop_at[0], r->stop_at[1], r->stop_at[2]);
        return PDR_ELIMIT;
    }
    if (r->recovery_capped) {
        pdr_cli_error(MP_CMD,
                      "the boundary recovery does not terminate: after %zu points (its bound: "
                      "%d per input vertex and %d more) pieces of the boundary are still "
                      "missing; splits cascade next to small angles of the input, where "
                      "the recovery by cavity retriangulation left pieces missing "
                      "(nothing written)",
                      r->recovery_capped, IM_RECOVERY_PER_VERTEX, IM_RECOVERY_BASE);
        return PDR_ELIMIT;
    }
    if (r->recovery_stuck) {
        char why[512];
        mp_recovery_stuck_text(r, 17, why, sizeof why);
        pdr_cli_error(MP_CMD, "%s (nothing written)", why);
        return PDR_ELIMIT;
    }
    if (r->stopped_below) {
        pdr_cli_error(MP_CMD,
                      "the boundary recovery does not terminate: after %zu points a missing "
                      "piece of the boundary needs a split at (%.17g, %.17g, %.17g) nearer "
                      "than %g to another vertex, the resolution of this mesher (%g times the "
                      "bounding-box diagonal; small angles of the input make the splits "
                      "cascade) (nothing written)",
                      n, r->stop_at[0], r->stop_at[1], r->stop_at[2], r->min_spacing,
                      REF_MIN_SPACING);
        return PDR_ELIMIT;
    }
    uint32_t v = r->last_v;
    char where[256] = "";
    if (v) {
        const double *x = r->m.xyz + 3 * (size_t)v;
        feature_name(p, r->bd.vkind[v], r->bd.vfeat[v], where, sizeof where);
        size_t l = strlen(where);
        snprintf(where + l, sizeof where - l, " at (%.6g, %.6g, %.6g)", x[0], x[1], x[2]);
    }
    pdr_cli_error(MP_CMD,
                  "stopped after inserting %zu points, the bound for this input (see "
                  "--max-points): the refinement does not terminate here; the last point "
                  "went%s (nothing written)",
                  n, where);
    return PDR_ELIMIT;
}

int mp_initial_mesh(mp_ctx *c)
{
    double t = pdr_now();
    c->o.ref.max_points = c->o.max_points < 0 ? ref_point_limit(&c->p, &c->o.ref)
                                              : (size_t)c->o.max_points;
    /* The boundary's treatment (refine/refine_cdt.c): a constrained
     * Delaunay tetrahedralization for a closed triangle surface (STL, OFF,
     * PLY, OBJ, Medit: what CAD tools and scanners export), a tessellated curved surface or
     * an input with acute vertices, where splitting pieces into each
     * other cascades; conforming Delaunay elsewhere, where the input's
     * angles let Shewchuk's algorithm work (the paper's domains). */
    if (c->o.mo_auto && !c->o.mo.paper)
        c->o.ref.constrained = c->fm.smooth_segments > 0 || c->fm.acute_vertices > 0 ||
                               c->p.surface_input;
    int rc = 0;
    /* Segments along thin facets cut as every mesh with the bound cuts
     * them (plc/plc_split.h), before the Delaunay tetrahedralization of
     * the input; by default only on an input without small angles, where
     * the refinement should leave no tetrahedron above the bound (CGAL's
     * pipe.off: 728 left before, 1 after). Everywhere, it also helps most
     * parts with small angles, but not all (mpi.off, mpi_triang.off,
     * propeller.stl leave more; bench/surfaces.md). */
    int presplit = c->o.presplit == MP_PRESPLIT_ALWAYS ||
                   (c->o.presplit == MP_PRESPLIT_AUTO && !plc_small_angles(&c->p));
    if (presplit && c->o.ref.constrained && !c->o.mo.paper && c->o.ref.ratio > 1.0) {
        plc_split_stats ss;
        rc = plc_split_long(&c->p, c->o.ref.ratio, PLC_SPLIT_MAX_PIECES, &ss, &c->diag);
        if (rc == PDR_EGEOMETRY)
            pdr_diag_print(&c->diag, stderr);
        if (rc)
            return fail(c, rc);
        if (!c->o.quiet && ss.segments)
            printf("input preparation: %zu segments along thin facets cut into pieces "
                   "shorter than %g times the facets' width (%zu points; every mesh with "
                   "radius-edge below %g cuts them below %g times)\n",
                   ss.segments, PLC_SPLIT_FACTOR * c->o.ref.ratio, ss.points, c->o.ref.ratio,
                   4.0 * c->o.ref.ratio);
    }
    rc = ref_init(&c->r, &c->p, &c->o.ref);
    if (rc)
        return fail(c, rc);
    c->have_r = 1;
    rc = im_build(&c->r, &c->o.mo, &c->is, &c->diag);
    if (rc == PDR_ELIMIT &&
        ((c->r.stopped_below && c->r.stop_hidden) || c->r.recovery_capped) &&
        c->o.ref.constrained && !c->o.mo.paper) {
        /* A split of the constrained recovery had no valid cavity, or its
         * splits cascaded up to the recovery's bound (CAD tessellations:
         * RECOVERY.md): built again from the start with the segments
         * recovered first (refine/refine_segrec.c). Only then, so that
         * every input that meshes the first way keeps its output. */
        ref_free(&c->r);
        c->have_r = 0;
        pdr_diag_free(&c->diag);
        if ((rc = ref_init(&c->r, &c->p, &c->o.ref)))
            return fail(c, rc);
        c->have_r = 1;
        c->o.mo.segments_first = 1;
        rc = im_build(&c->r, &c->o.mo, &c->is, &c->diag);
    }
    /* Warnings (a region point outside the domain) are shown even when
     * Mo was built. */
    if (c->diag.ntotal) {
        if (rc == PDR_ENOMEM)
            pdr_diag_print_kept(&c->diag, stderr); /* fail() says why */
        else
            pdr_diag_print(&c->diag, stderr);
        pdr_diag_free(&c->diag);
    }
    if (rc == PDR_ELIMIT)
        return point_limit(c);
    if (rc)
        return fail(c, rc);
    if (c->o.mo_size > 0) {
        if ((rc = im_mo_size(&c->r, (size_t)c->o.mo_size)))
            return rc == PDR_ELIMIT ? point_limit(c) : fail(c, rc);
        c->is.tets = ref_interior_tets(&c->r);
    }
    c->sec[MP_MO] = pdr_now() - t;
    if (!c->o.quiet) {
        printf("initial mesh (%s): %zu tetrahedra, %zu points added on segments, %zu on "
               "facets",
               c->o.mo.paper         ? "paper"
               : c->o.ref.constrained ? "constrained Delaunay"
                                     : "conforming",
               c->is.tets, c->is.seg_points, c->is.fac_points);
        if (c->o.mo.paper)
            printf(", d = %.6g", c->is.d);
        printf(" (%.3f s)\n", c->sec[MP_MO]);
    }
    c->v0 = c->r.m.nv;
    c->st_mo = c->r.st;
    return 0;
}

/* ----------------------------------------------------------- refine */

int mp_refine(mp_ctx *c)
{
    double t = pdr_now();
    int rc = ref_refine(&c->r);
    if (!rc)
        rc = ref_offcentres(&c->r);
    if (rc == PDR_ELIMIT)
        return point_limit(c);
    if (rc)
        return fail(c, rc);
    c->sec[MP_REFINE] = pdr_now() - t;
    c->refined = 1;
    return 0;
}

/* ----------------------------------------------------------- export */

/* The lines about the refinement and the mesh it made come after the
 * export because the rate counts the exported tetrahedra. */
void mp_print_mesh_summary(const mp_ctx *c)
{
    const mesh_export *v = &c->out.view;
    if (c->o.quiet)
        return;
    if (c->refined) {
        double tref = c->sec[MP_REFINE];
        printf("refinement: %zu vertices added (%zu tetrahedra, %zu subfacet, %zu "
               "subsegment points), %zu circumcentres rejected (%.3f s, %.0f "
               "tetrahedra/s)\n",
               c->v_added, c->st.tet_points - c->st_mo.tet_points,
               c->st.fac_points - c->st_mo.fac_points, c->st.seg_points - c->st_mo.seg_points,
               c->st.rejected - c->st_mo.rejected, tref,
               tref > 0 ? (double)v->nt / tref : 0.0);
    }
    printf("mesh: %zu vertices, %zu tetrahedra, %zu boundary triangles\n", v->nv, v->nt,
           v->nf);
}

/* The mean of the n mesh vertices v (a point on the piece they span). */
static void mean_of(const double *xyz, const uint32_t *v, int n, double at[3])
{
    for (int d = 0; d < 3; d++) {
        at[d] = 0;
        for (int k = 0; k < n; k++)
            at[d] += xyz[3 * (size_t)v[k] + d] / n;
    }
}

/* Says in c->missing which boundary pieces are still missing when the
 * refinement ends (their splits were refused: below the resolution, or
 * no valid constrained cavity) and where the first one is: the place
 * where the inside/outside flood can cross the boundary. */
static void note_missing(mp_ctx *c)
{
    const bd_set *b = &c->r.bd;
    size_t ns, nf;
    c->missing[0] = 0;
    bd_count_missing(b, &ns, &nf);
    if (!ns && !nf)
        return;
    double at[3] = {0, 0, 0};
    char where[160] = "";
    const char *what = "";
    for (size_t i = 0; i < b->nfacs && !what[0]; i++) {
        const bd_subfac *f = &b->facs[i];
        if ((f->flags & (BD_F_DEAD | BD_F_MISSING)) != BD_F_MISSING)
            continue;
        mean_of(c->r.m.xyz, f->v, 3, at);
        feature_name(&c->p, BD_V_FACET, f->facet, where, sizeof where);
        what = "a subfacet";
    }
    for (size_t i = 0; i < b->nsegs && !what[0]; i++) {
        const bd_subseg *s = &b->segs[i];
        if ((s->flags & (BD_F_DEAD | BD_F_MISSING)) != BD_F_MISSING)
            continue;
        mean_of(c->r.m.xyz, s->v, 2, at);
        feature_name(&c->p, BD_V_SEGMENT, s->seg, where, sizeof where);
        what = "a subsegment";
    }
    snprintf(c->missing, sizeof c->missing,
             "; %zu subsegment%s and %zu subfacet%s stayed missing, their splits refused "
             "(the first: %s%s, near (%.9g, %.9g, %.9g))",
             ns, ns == 1 ? "" : "s", nf, nf == 1 ? "" : "s", what, where, at[0], at[1], at[2]);
}

/* The guard against a mesh that does not cover its input: no tetrahedra
 * at all, open (> 0) faces that bound the interior on no input facet, or
 * a facet whose subfacets in the output do not add up to its area. A facet may have no subfacet at all only when the input has hole
 * points (a facet with a hole or the outside on both sides bounds
 * nothing); without them every facet of a valid PLC bounds some of the
 * domain. Such a mesh means the boundary was lost (the classification
 * of inside and outside then leaks through it), never a valid result.
 * Returns 0, or PDR_ETOPOLOGY after saying what is wrong. */
static int guard_output(mp_ctx *c, size_t open)
{
    const ref_output *o = &c->out;
    const plc *p = &c->p;
    if (!o->view.nt) {
        pdr_cli_error(MP_CMD,
                      "the mesh is empty: the boundary of the domain was lost during the "
                      "refinement%s (nothing written)", c->missing);
        return PDR_ETOPOLOGY;
    }
    /* The domain's boundary is made of subfacets: a face that bounds the
     * interior without a mark (open, counted before the export took the
     * mesh) is a crack in the mesh or a wrong inside/outside flag. */
    if (open) {
        pdr_cli_error(MP_CMD,
                      "the mesh's boundary has %zu face%s on no input facet (a crack in the "
                      "mesh, or tetrahedra taken for inside that are not): a defect of the "
                      "refinement (nothing written)",
                      open, open == 1 ? "" : "s");
        return PDR_ETOPOLOGY;
    }
    double *got = pr_calloc(p->nfacet ? p->nfacet : 1, sizeof *got);
    if (!got)
        return fail(c, PDR_ENOMEM);
    for (size_t i = 0; i < o->view.nf; i++)
        got[o->tri_facet[i]] += plc_facet_proj_area(p, (size_t)o->tri_facet[i],
                                                    o->xyz[o->tri[i][0]], o->xyz[o->tri[i][1]],
                                                    o->xyz[o->tri[i][2]]);
    size_t bad = 0, first = 0;
    double worst = 0;
    for (size_t f = 0; f < p->nfacet; f++) {
        double want = 0;
        for (size_t t = p->ftri_start[f]; t < p->ftri_start[f + 1]; t++)
            want += plc_facet_proj_area(p, f, p->xyz[p->ftri[t][0]], p->xyz[p->ftri[t][1]],
                                        p->xyz[p->ftri[t][2]]);
        double err = want > 0 ? fabs(got[f] - want) / want : 0.0;
        if (err > 1e-6 && (got[f] > 0 || !p->nhole)) {
            if (!bad++)
                first = f;
            if (err > worst)
                worst = err;
        }
    }
    pr_free(got);
    if (!bad)
        return 0;
    char fl[64];
    facet_label(p, first, fl, sizeof fl);
    pdr_cli_error(MP_CMD,
                  "the mesh does not cover the input: %zu facet%s not covered by the mesh's "
                  "boundary (the first: %s of %s; area off by up to %.3g%%); "
                  "the boundary was lost during the refinement%s (nothing written)",
                  bad, bad == 1 ? "" : "s", fl, p->path, 100 * worst, c->missing);
    return PDR_ETOPOLOGY;
}

int mp_export(mp_ctx *c)
{
    double t = pdr_now();
    /* The progress line, open on a terminal, ends before the summary. */
    pdr_progress_end(&c->pg);
    ref_count_bad(&c->r);
    note_missing(c);
    /* The work memory goes first, so that the export's peak is lower. */
    ref_release_work(&c->r);
    c->v_added = (size_t)(c->r.m.nv - c->v0);
    size_t open = ref_unmarked_bounds(&c->r);
    int rc = ref_export_take(&c->r, &c->out);
    if (rc)
        return fail(c, rc);
    c->have_out = 1;
    c->st = c->r.st;
    c->sec[MP_EXPORT] = pdr_now() - t;
    mp_print_mesh_summary(c);
    return guard_output(c, open);
}

/* ------------------------------------------------------------ write */

/* One output stage of mp_write: a file (or the quality measure), with
 * its own set of finished temporaries and its own messages, so that the
 * stages can run side by side (base/fj.h). */
typedef struct mp_out_task {
    mp_ctx *c;
    int kind;       /* enum mp_out_kind */
    outset set;     /* its file, until mp_write commits them all */
    pdr_diag diag;  /* its messages */
} mp_out_task;

enum mp_out_kind { MP_OUT_NODE, MP_OUT_ELE, MP_OUT_FACE, MP_OUT_VTU, MP_OUT_MSH, MP_OUT_QUALITY };

static const char *const mp_out_ext[] = {".node", ".ele", ".face", ".vtu", ".msh", NULL};

/* Writes one file: BASE.node, .ele, .face (TetGen's, 1-based, region
 * attributes), .vtu (binary, without the quality fields) or .msh (Gmsh
 * 4.1); or measures the quality of the exported mesh into c->quality. */
static int run_out_task(void *arg)
{
    mp_out_task *k = arg;
    const ref_output *o = &k->c->out;
    if (k->kind == MP_OUT_QUALITY) {
        ref_quality_range(&o->view, &k->c->quality);
        return 0;
    }
    char *path = pdr_path_join(k->c->base, mp_out_ext[k->kind]);
    if (!path)
        return PDR_ENOMEM; /* said once, by pdr_cli_fail */
    int rc;
    tg_nodes nodes = {.n = o->view.nv, .first = 1, .xyz = (double *)o->xyz};
    vtu_opts vo = {0, 0};
    switch (k->kind) {
    case MP_OUT_NODE:
        rc = tg_write_node(path, &nodes, &k->set, &k->diag);
        break;
    case MP_OUT_ELE:
        rc = tg_write_ele_view(path, &o->view, o->tet_attr, 1, &k->set, &k->diag);
        break;
    case MP_OUT_FACE:
        rc = face_write(&o->view, path, 1, &k->set, &k->diag);
        break;
    case MP_OUT_VTU:
        rc = vtu_write(&o->view, path, &vo, &k->set, &k->diag);
        break;
    default:
        rc = msh_write(&o->view, path, &k->set, &k->diag);
        break;
    }
    pr_free(path);
    return rc;
}

/* The "wrote ..." lines, once every file is in place (a file name is the
 * base followed by its extension, as pdr_path_join makes it). */
static void print_written(const mp_ctx *c)
{
    unsigned f = c->o.formats;
    const char *b = c->base;
    if (f & MP_FMT_NODE)
        printf("wrote %s.node, %s.ele, %s.face\n", b, b, b);
    if (f & MP_FMT_VTU)
        printf("wrote %s.vtu\n", b);
    if (f & MP_FMT_MSH)
        printf("wrote %s.msh\n", b);
}

/* Below this many tetrahedra the files are written one after the other
 * on the calling thread: threads would cost more than they save. */
#define MP_WRITE_THREADS_FROM 50000

/* Threads for the output stages: one per core, or PDR_THREADS (a
 * positive count; 1 writes the files one after the other, as small
 * meshes always are). */
static unsigned write_threads(const mp_ctx *c)
{
    if (c->out.view.nt < MP_WRITE_THREADS_FROM)
        return 1;
    const char *e = getenv("PDR_THREADS");
    if (e && *e) {
        char *end;
        long v = strtol(e, &end, 10);
        if (!*end && v >= 1 && v <= 64)
            return (unsigned)v;
        fprintf(stderr, "pdr %s: PDR_THREADS='%s' is not a count from 1 to 64; ignored\n", MP_CMD,
                e);
    }
    return fj_cores();
}

int mp_write(mp_ctx *c)
{
    double t = pdr_now();
    unsigned f = c->o.formats;
    /* Every format or none: the files wait in the sets until the last one
     * is written. The quality measure runs alongside them. */
    mp_out_task k[6];
    fj_task ft[6];
    size_t n = 0;
    static const struct {
        unsigned fmt;
        int kind;
    } plan[] = {{MP_FMT_NODE, MP_OUT_NODE}, {MP_FMT_NODE, MP_OUT_ELE},
                {MP_FMT_NODE, MP_OUT_FACE}, {MP_FMT_VTU, MP_OUT_VTU},
                {MP_FMT_MSH, MP_OUT_MSH},   {0, MP_OUT_QUALITY}};
    for (size_t i = 0; i < sizeof plan / sizeof plan[0]; i++) {
        if (plan[i].fmt && !(f & plan[i].fmt))
            continue;
        k[n] = (mp_out_task){.c = c, .kind = plan[i].kind, .set = OUTSET_INIT};
        ft[n] = (fj_task){.run = run_out_task, .arg = &k[n]};
        n++;
    }
    fj_run(ft, n, write_threads(c));
    /* The first failure in the order above is the one reported (later
     * ones are often its echo, such as a second "out of memory"). */
    int rc = 0;
    for (size_t i = 0; i < n; i++) {
        if (k[i].kind == MP_OUT_QUALITY) {
            c->have_quality = 1;
            c->sec[MP_REPORT] = ft[i].seconds;
        } else if (!rc && ft[i].rc) {
            rc = ft[i].rc;
            pdr_diag_move(&c->diag, &k[i].diag);
        }
    }
    outset set = OUTSET_INIT;
    for (size_t i = 0; i < n; i++) {
        /* At most five files: the set has room for them. */
        if (rc || outset_move(&set, &k[i].set))
            outset_abort(&k[i].set);
        pdr_diag_free(&k[i].diag);
    }
    rc = rc ? rc : outset_commit(&set, &c->diag);
    if (rc) {
        /* The writers name the file and the reason in diag; only a lack
         * of memory gets a further "pdr mesh:" line, since its message
         * may have been lost. */
        pdr_cli_fail(MP_CMD, &c->diag, rc);
        return rc;
    }
    if (!c->o.quiet)
        print_written(c);
    c->t_written = pdr_now();
    c->sec[MP_WRITE] = c->t_written - t;
    return 0;
}

/* ----------------------------------------------------------- report */

/* "left above the bound: ...": printed also when quiet if anything was
 * left, since that is a warning about the mesh. */
static void print_left(const mp_ctx *c)
{
    const ref_stats *st = &c->st;
    if (st->left_stuck)
        printf("left not locally Delaunay: %zu faces next to thin input triangles (no flip "
               "mends them and the splits next to them were refused: the mesh is no "
               "constrained Delaunay tetrahedralization there)\n",
               st->left_stuck);
    if (!st->left_ratio && !st->left_size && !st->left_sliver && c->o.quiet)
        return;
    printf("left above the bound: %zu tetrahedra with radius-edge >= %g", st->left_ratio,
           c->o.ref.ratio);
    if (st->left_ratio)
        printf(" (%zu next to small input angles, %zu given up elsewhere (their splits "
               "refused), %zu degenerate (flat: no usable circumcentre), %zu hidden "
               "(circumcentre's cavity not made), %zu other)",
               st->left_ratio_angle, st->left_ratio_refused, st->left_ratio_degenerate,
               st->left_ratio_hidden,
               st->left_ratio - st->left_ratio_angle - st->left_ratio_refused -
                   st->left_ratio_degenerate - st->left_ratio_hidden);
    if (st->left_size)
        printf(", %zu above the size bound", st->left_size);
    if (st->left_sliver)
        printf(", %zu with a dihedral angle below %g degrees", st->left_sliver,
               c->o.ref.min_dihedral);
    printf("\n");
    const plc *p = &c->p;
    /* How many of them no mesher could avoid without changing the facets
     * (fm_thin_corners). */
    double B = c->o.ref.ratio;
    size_t thin = st->left_ratio && c->have_plc && B > 1 && p->derived
                      ? fm_thin_corners(p, asin(0.5 / B) * 180.0 / M_PI)
                      : 0;
    if (thin)
        printf("  the input's facets have %zu corners below %.1f degrees: any mesh of them has "
               "a tetrahedron with radius-edge >= %g at each (on a face at such a corner)\n",
               thin, asin(0.5 / B) * 180.0 / M_PI, B);
    /* Where the given-up ones are (input numbering). */
    for (int s = 0; s < REF_LEFT_SITES && c->have_plc && st->left_site[s].count; s++) {
        const struct ref_left_site *ls = &st->left_site[s];
        printf(s ? "; " : "  next to: ");
        if (ls->kind == BD_V_INPUT && ls->feature < p->nv)
            printf("input vertex %ld (%.6g, %.6g, %.6g)", plc_vnum(p, ls->feature),
                   p->xyz[ls->feature][0], p->xyz[ls->feature][1], p->xyz[ls->feature][2]);
        else if (ls->kind == BD_V_SEGMENT && ls->feature < p->nseg)
            printf("segment %ld-%ld", plc_vnum(p, p->segs[ls->feature].v[0]),
                   plc_vnum(p, p->segs[ls->feature].v[1]));
        else if (ls->kind == BD_V_FACET && ls->feature < p->nfacet)
            printf("facet %u", ls->feature + 1);
        else
            printf("the interior");
        printf(": %zu", ls->count);
    }
    if (st->left_site[0].count && c->have_plc)
        printf("\n");
}

/* The seconds per stage, and the whole run to the written mesh. */
static void print_times(const mp_ctx *c)
{
    const double *s = c->sec;
    double total = c->t_written - c->t_start;
    size_t nt = c->out.view.nt;
    printf("time: read %.3f, initial mesh %.3f, refine %.3f, export %.3f, write %.3f, "
           "quality %.3f s\n",
           s[MP_READ], s[MP_MO], s[MP_REFINE], s[MP_EXPORT], s[MP_WRITE], s[MP_REPORT]);
    printf("total: %.3f s to written mesh, %.0f tetrahedra/s, peak memory %.1f MB\n", total,
           total > 0 ? (double)nt / total : 0.0, (double)pdr_peak_rss() / 1048576.0);
}

int mp_report(mp_ctx *c)
{
    /* Measured alongside the writing (mp_write), or here. */
    if (!c->have_quality) {
        double t = pdr_now();
        ref_quality_range(&c->out.view, &c->quality);
        c->have_quality = 1;
        c->sec[MP_REPORT] = pdr_now() - t;
    }
    const ref_quality q = c->quality;
    if (!c->o.quiet)
        printf("quality: radius-edge %.4f .. %.4f, dihedral %.2f .. %.2f degrees\n", q.re_min,
               q.re_max, q.dih_min, q.dih_max);
    print_left(c);
    if (!c->o.quiet)
        print_times(c);
    return 0;
}

/* ----------------------------------------------------------- verify */

/* Builds a tm_mesh of the exported tetrahedra (1-based vertices, no
 * ghosts) with its face adjacency, the form vf_check reads. Non-manifold
 * faces are counted into r. */
static int rebuild_mesh(const mesh_export *v, tm_mesh *m, vf_report *r)
{
    int rc = tm_reserve(m, v->nv + 1, v->nt + 16);
    for (size_t i = 0; i < v->nv && !rc; i++) {
        uint32_t id;
        rc = tm_add_vertex(m, v->xyz[i], &id);
    }
    if (!rc)
        rc = tm_room(m, v->nt);
    for (size_t t = 0; t < v->nt && !rc; t++) {
        uint32_t s = tm_alloc_tet(m);
        for (int k = 0; k < 4; k++) {
            m->tets[s].v[k] = v->tet[t][k] + 1;
            m->tets[s].n[k] = TM_LINK_NONE;
        }
    }
    return rc ? rc : tm_link_faces(m, &r->nonmanifold);
}

int mp_verify(mp_ctx *c)
{
    double t = pdr_now();
    tm_mesh m;
    if (tm_init(&m, 0))
        return fail(c, PDR_ENOMEM);
    vf_report r;
    memset(&r, 0, sizeof r);
    int rc = rebuild_mesh(&c->out.view, &m, &r);
    if (!rc)
        rc = vf_check(&m, VF_TOPOLOGY | VF_ORIENTATION | VF_DELAUNAY | VF_VERTICES, &r);
    tm_free(&m);
    if (rc)
        return fail(c, rc);
    size_t d = vf_defects(&r);
    c->sec[MP_VERIFY] = pdr_now() - t;
    if (!c->o.quiet || d)
        printf("check: %zu defect%s (topology, orientation, Delaunay)\n", d, d == 1 ? "" : "s");
    if (d)
        vf_print(&r, stdout);
    return d ? PDR_ETOPOLOGY : 0;
}

/* ----------------------------------------------------------- conclude */

int mp_conclude(mp_ctx *c, mp_lines_fn *lines, void *arg)
{
    int rc = mp_write(c);
    if (!rc && lines)
        lines(c, arg);
    if (!rc)
        rc = mp_report(c);
    if (!rc && c->o.check)
        rc = mp_verify(c);
    return rc;
}
