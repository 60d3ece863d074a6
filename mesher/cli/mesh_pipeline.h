/*
 * cli/mesh_pipeline.h -- the stages of 'pdr mesh' (prefix mp_), from an
 * input PLC to written mesh files and the summary.
 *
 * The data path, one function per stage, each taking the pipeline context:
 *
 *   mp_read          PLC from a file or a built-in domain, validated; names
 *                    the output                          "input: ..."
 *   mp_initial_mesh  the initial conforming mesh Mo      "initial mesh: ..."
 *   mp_refine        the sequential quality refinement
 *   mp_export        the finished mesh as a ref_output   "refinement: ...",
 *                                                        "mesh: ..."
 *   mp_write         every requested format, atomically  "wrote ..."
 *   mp_report        quality, what was left above the bound, the times
 *   mp_verify        exact verification (--check)        "check: ..."
 *
 * mp_conclude runs the last three in order, with a driver's own lines
 * after the files are written.
 *
 * Each stage returns 0 or a negative PDR_E* code. A stage that fails has
 * already told the user why (the reader's or a writer's file messages, or
 * "pdr mesh: <reason>", on stderr; mp_verify's defects on stdout), so its
 * caller only turns the code into the exit status; the stages after a
 * failed one must not be run. Each stage prints its own summary lines on
 * stdout unless the options say quiet, and records its duration in sec[]
 * (durations, so that a driver may run stages in any process and fill in
 * the ones it ran elsewhere).
 *
 * The parallel mesher reuses the stages around its own refinement: rank 0
 * runs mp_read and mp_initial_mesh, hands the Mo in r to the distributed
 * refinement instead of calling mp_refine, gets the merged mesh back into
 * r, sets sec[MP_REFINE] and 'refined', and runs mp_export, mp_write and
 * mp_report. mp_write, mp_report and mp_verify read only out, st, base,
 * the options and the times, never r; a driver that receives the merged
 * mesh as a ref_output may therefore skip mp_export as well: it fills out
 * (setting have_out), st and v_added itself and prints their summary with
 * mp_print_mesh_summary.
 *
 * Ownership: the context owns the PLC, the mesher, the output, the
 * diagnostics and the output base name, and mp_free releases them. It
 * must stay at one address from mp_init to mp_free: the mesher points to
 * the PLC and the progress callback to the context's progress line.
 */
#ifndef PDR_MESH_PIPELINE_H
#define PDR_MESH_PIPELINE_H

#include <stddef.h>

#include "base/pdr_error.h"
#include "base/pdr_util.h"
#include "plc/fm.h"
#include "plc/plc.h"
#include "refine/im.h"
#include "refine/refine.h"

/* Output formats, bits of mp_opts.formats. */
enum { MP_FMT_NODE = 1, MP_FMT_VTU = 2, MP_FMT_MSH = 4 };

/* Everything 'pdr mesh' can be told on its command line. The strings are
 * borrowed (typically from argv) and must outlive the pipeline. */
typedef struct mp_opts {
    const char *in;      /* input file (.poly, .smesh, .off, .stl), or NULL */
    const char *domain;  /* --domain NAME: built-in domain when in is NULL */
    const char *out;     /* -o BASE, or NULL: IN.1 (TetGen's naming) */
    unsigned formats;    /* -f: MP_FMT_* bits; 0 writes nothing */
    ref_opts ref;        /* -q, -a, -L, --min-dihedral, --order, --rho,
                            --no-region-volume; the pipeline sets the
                            progress callback itself */
    im_opts mo;          /* --mo conform|paper (cdt: ref.constrained) */
    int mo_auto;         /* --mo auto (the default): the constrained mode
                            for an input with smooth segments or acute
                            vertices (mp_initial_mesh), else conforming */
    double mo_size;      /* --mo-size N: tetrahedra of Mo, or 0 */
    int mo_only;         /* --mo-only: the driver skips mp_refine */
    int check;           /* --check: the driver runs mp_verify */
    int quiet;           /* -Q: print only errors and warnings */
    double max_points;   /* --max-points: bound on inserted points; < 0:
                            automatic (ref_point_limit), 0: none */
    double merge_angle;  /* --merge-angle: tolerance of the coplanar merge
                            (plc/fm.h), degrees; < 0 (--no-merge): none */
    double facet_tol;    /* --facet-tol: distance tolerance of near-planar
                            facets (plc/fm.h), relative to the bounding-box
                            diagonal; 0: exactly coplanar merges only */
    int presplit;        /* --presplit: MP_PRESPLIT_*, whether the
                            constrained mode cuts the segments along thin
                            facets first (plc/plc_split.h) */
} mp_opts;

/* mp_opts.presplit */
enum { MP_PRESPLIT_AUTO = 0, MP_PRESPLIT_ALWAYS, MP_PRESPLIT_NEVER };

/* The stages, as indices of mp_ctx.sec. */
enum mp_stage {
    MP_READ, MP_MO, MP_REFINE, MP_EXPORT, MP_WRITE, MP_REPORT, MP_VERIFY, MP_NSTAGE
};

typedef struct mp_ctx {
    mp_opts o;           /* a copy of the options */
    pdr_diag diag;       /* messages not yet printed; owned */
    pdr_progress pg;     /* the progress line of Mo and refinement */
    char *base;          /* output base name (mp_read); owned */
    plc p;               /* the input (mp_read); owned when have_plc */
    ref_mesher r;        /* the mesh (mp_initial_mesh); owned when have_r */
    ref_output out;      /* the finished mesh (mp_export); owned when
                            have_out */
    int have_plc, have_r, have_out;
    im_stats is;         /* what building Mo did */
    fm_stats fm;         /* what the input preparation did */
    size_t v0;           /* mesh vertices of Mo */
    ref_stats st_mo;     /* the refinement's counts when Mo was done (the
                            summary's refinement line counts from there) */
    int refined;         /* a refinement ran (its summary line is due) */
    size_t v_added;      /* vertices the refinement added */
    ref_stats st;        /* the refinement's counts, with those left above
                            the bounds (ref_count_bad) */
    double t_start;      /* pdr_now() at mp_init */
    double t_written;    /* pdr_now() when mp_write was done */
    double sec[MP_NSTAGE]; /* seconds spent in each stage (the report's
                              is its quality measure, which mp_write
                              runs alongside the files) */
    ref_quality quality; /* of out, once have_quality */
    int have_quality;
    char missing[256];   /* what of the boundary stayed missing when the
                            refinement ended ("" when nothing), for the
                            guard's message (mp_export) */
} mp_ctx;

/* Sets *o to the defaults of 'pdr mesh': ref_default_opts, the general
 * Mo, TetGen files, no input (the caller names one). */
void mp_default_opts(mp_opts *o);

/* Makes an empty context for options o (copied) and starts the clock and
 * the progress line. Release it with mp_free. */
void mp_init(mp_ctx *c, const mp_opts *o);
/* Releases everything the context owns (safe after any stage failed). */
void mp_free(mp_ctx *c);
/* After stages that failed with code rc (read: mp_read succeeded):
 * near-planar facets (--facet-tol, plc/fm.h) are not yet safe in every
 * recovery and refinement (refine/QUALITY.md), so when c used some and rc
 * is not PDR_ENOMEM, says so (unless quiet), makes c again for the
 * options 'given' (as the caller was given them: the stages write their
 * choices into c->o) with exact facets, and returns 1: the caller runs
 * its stages again. Else returns 0 and leaves c as it is. */
int mp_retry_exact_facets(mp_ctx *c, const mp_opts *given, int rc, int read);

/* Reads and validates o.in, or builds o.domain, into p, merges its
 * coplanar triangles and finds its sharp features (plc/fm.h), and makes
 * the output base name. Returns 0, PDR_EIO, PDR_EPARSE, PDR_EGEOMETRY,
 * PDR_EUNSUPPORTED, PDR_EINVAL (neither input nor known domain) or
 * PDR_ENOMEM. */
int mp_read(mp_ctx *c);

/* Builds Mo of p into r (after mp_read), refined to o.mo_size tetrahedra
 * when that is set. Warnings are printed. Returns 0, PDR_EGEOMETRY,
 * PDR_ENOMEM, PDR_ELIMIT or PDR_ETOPOLOGY. */
int mp_initial_mesh(mp_ctx *c);

/* The quality refinement of r (after mp_initial_mesh). Returns 0 or
 * PDR_ENOMEM, PDR_ELIMIT, PDR_ETOPOLOGY. */
int mp_refine(mp_ctx *c);

/* Ends the progress line, counts what r left above the bounds into st,
 * then moves the mesh into out (ref_export_take: afterwards r holds no
 * mesh, only its boundary and statistics) and prints the summary of both
 * (mp_print_mesh_summary). Then the guard: a mesh with no tetrahedra, or
 * whose boundary does not cover every input facet (the boundary was lost,
 * and inside and outside with it), fails with PDR_ETOPOLOGY after a
 * message, so that such a mesh is never written. Returns 0, PDR_ENOMEM
 * or PDR_ETOPOLOGY. */
int mp_export(mp_ctx *c);

/* "refinement: ..." (when 'refined') and "mesh: ..." from out, st,
 * v_added and sec[MP_REFINE]; nothing when quiet. */
void mp_print_mesh_summary(const mp_ctx *c);

/* Writes into buf (size bytes) why r stopped when its recovery of missing
 * boundary pieces reached its bound (r->recovery_stuck): the splits made,
 * the bound, and where the piece left is, with digits significant digits.
 * The sequential run, a PE and rank 0's merge each say it in their own
 * frame. */
void mp_recovery_stuck_text(const ref_mesher *r, int digits, char *buf, size_t size);

/* Writes out in every format of o.formats under base (nothing when none),
 * each file atomically. Returns 0, PDR_EIO or PDR_ENOMEM. */
int mp_write(mp_ctx *c);

/* Measures the quality of out and prints the summary: quality, what was
 * left above the bounds (also when quiet, if anything was), the time per
 * stage and the total from mp_init to the end of mp_write. Returns 0. */
int mp_report(mp_ctx *c);

/* Verifies out with exact predicates, like 'pdr check': topology,
 * orientation, local Delaunay property. Returns 0, PDR_ETOPOLOGY (defects
 * found and listed on stdout) or PDR_ENOMEM. */
int mp_verify(mp_ctx *c);

/* A driver's own summary lines, printed between "wrote ..." and the
 * quality (mp_conclude); arg is the driver's. */
typedef void mp_lines_fn(const mp_ctx *c, void *arg);

/* The tail of every run once out holds the mesh: mp_write, then
 * lines(c, arg) when lines is not NULL, mp_report, and mp_verify with
 * --check; each only when the stages before it succeeded. Returns 0 or
 * the first failure's code. */
int mp_conclude(mp_ctx *c, mp_lines_fn *lines, void *arg);

#endif /* PDR_MESH_PIPELINE_H */
