/* cli/mesh_par.c -- the parallel driver of 'pdr mesh' (see cli/mesh_par.h). */
#include "config.h"

#if defined HAVE_MALLOC_TRIM || defined HAVE_MALLOPT
#include <malloc.h>
#endif

#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "pr_alloc.h"
#include "am.h"
#include "base/outfile.h"
#include "base/pdr_util.h"
#include "cli/mesh_par.h"
#include "cli/pdr_cli.h"
#include "io/face.h"
#include "io/tg.h"
#include "par/par_decomp.h"
#include "par/par_merge.h"
#include "par/par_run.h"
#include "par/par_verify.h"
#include "par/par_wire.h"
#include "pr.h"
#include "refine/im.h"

/* Handler of the job message rank 0 sends every PE (below the parallel
 * refinement's own ids). */
#define H_JOB 90
/* Handler of the merge messages the PEs but rank 0 send it at the end. */
#define H_MERGE 91
/* Rank 0's threshold from which a block is mapped alone during the merge
 * (glibc's default, fixed: see mpar_run). */
#define MMAP_THRESHOLD_MERGE (128 * 1024)
/* The default Mo: about the paper's 10^5 tetrahedra, but no more than a
 * tenth of the final mesh when the volume bound tells how large that is. */
#define MO_SIZE_PAPER 100000.0

void mpar_default_opts(mpar_opts *o)
{
    memset(o, 0, sizeof *o);
    o->max_threads = 8;
    o->seed = 1;
    o->rank0_points = MPAR_RANK0_POINTS;
}

/* --------------------------------------------------------- job message */

/* Body: u8 status (0 go, 1 rank 0 failed, 2 rank 0 finished the mesh
 * alone: nothing to do), then, with 0, three length-prefixed blobs: the
 * PLC, the refinement options, the submesh. */
typedef struct job {
    int got;
    uint8_t status;
    void *data; /* owned copy of the payload */
    size_t len;
} job;

static void on_job(am_ctx_t *am, const am_msg_t *msg, void *arg)
{
    (void)am;
    job *j = arg;
    if (j->got || msg->len < 1)
        return;
    j->data = pr_malloc(msg->len);
    if (!j->data) {
        j->got = 1;
        j->status = 1;
        return;
    }
    memcpy(j->data, msg->data, msg->len);
    j->len = msg->len;
    j->status = ((const uint8_t *)msg->data)[0];
    j->got = 1;
}

static int put_blob(pr_buf *b, const pr_buf *blob)
{
    pr_put_u32(b, (uint32_t)blob->len);
    pr_put_bytes(b, blob->data, blob->len);
    return b->err;
}

static int get_blob(pr_reader *r, const uint8_t **p, size_t *len)
{
    uint32_t n;
    if (pr_get_count(r, UINT32_MAX, 1, &n) || pr_get_view(r, p, n))
        return PDR_EPARSE;
    *len = n;
    return 0;
}

/* Waits in the loop until the job message is here. */
static int wait_job(am_ctx_t *am, job *j)
{
    while (!j->got) {
        int rc = am_poll(am);
        if (rc < 0)
            return rc;
        if (!j->got && (rc = am_idle(am, 0.25)) < 0)
            return rc;
    }
    return 0;
}

/* ------------------------------------------------------ merge messages */

/* Rank 0's receipt of the merge messages. A PE sends its submesh in
 * pieces (par_merge_pieces), each as one message: u32 the piece's index,
 * u32 the PE's number of pieces, then the piece's par_wire message. Each
 * is decoded as it comes, in its handler (the handler's bytes go with it,
 * so the decoded form keeps its own copy of what it would read in place,
 * par_wire_decode_own). */
typedef struct merge_pe {
    par_wire *w;     /* [count]: the pieces, by index */
    uint8_t *seen;   /* [count] */
    uint32_t count;  /* pieces the PE sends (0: none in yet) */
    uint32_t got;    /* pieces in */
    int rc;          /* the first decoder's (or allocation's) error */
} merge_pe;

typedef struct merge_in {
    const plc *p;  /* rank 0's PLC: loaded before any merge message comes */
    int size;
    par_wire own;  /* rank 0's own submesh (par_wire_from_sub_pairs) */
    merge_pe *pe;  /* [size]: pe[k] PE k's pieces, k > 0 */
    int ndone;     /* PEs all of whose pieces are in, of size - 1 */
    int stray;     /* messages from rank 0 itself, malformed pieces, or a
                      piece a second time */
} merge_in;

/* A bound on a PE's pieces (a submesh below TM_MAX_TETS). */
#define MERGE_MAX_PIECES (TM_MAX_TETS / PAR_MERGE_PIECE + 1)

static void on_merge(am_ctx_t *am, const am_msg_t *msg, void *arg)
{
    (void)am;
    merge_in *in = arg;
    int k = msg->src;
    if (!in->pe || k <= 0 || k >= in->size || msg->len < 8) {
        in->stray++;
        return;
    }
    const uint8_t *d = msg->data;
    uint32_t idx = pr_load_u32(d), cnt = pr_load_u32(d + 4);
    merge_pe *e = &in->pe[k];
    if (cnt == 0 || cnt > MERGE_MAX_PIECES || idx >= cnt || (e->count && cnt != e->count) ||
        e->got >= cnt || (e->seen && e->seen[idx])) {
        in->stray++;
        return;
    }
    if (!e->count) {
        e->count = cnt;
        e->w = pr_calloc(cnt, sizeof *e->w);
        e->seen = pr_calloc(cnt, 1);
        if (!e->w || !e->seen) {
            pr_free(e->w);
            pr_free(e->seen);
            e->w = NULL;
            e->seen = NULL;
            e->rc = PDR_ENOMEM;
        }
    }
    if (e->seen) {
        e->seen[idx] = 1;
        int rc = par_wire_decode_own(d + 8, msg->len - 8, in->p, &e->w[idx]);
        if (rc && !e->rc)
            e->rc = rc;
    }
    if (++e->got == cnt)
        in->ndone++;
}

/* Frees what rank 0 received (the wires are cleared unless handed on). */
static void merge_in_free(merge_in *in)
{
    par_wire_clear(&in->own);
    for (int k = 0; in->pe && k < in->size; k++) {
        for (uint32_t i = 0; in->pe[k].w && i < in->pe[k].count; i++)
            par_wire_clear(&in->pe[k].w[i]);
        pr_free(in->pe[k].w);
        pr_free(in->pe[k].seen);
    }
    pr_free(in->pe);
    in->pe = NULL;
}

/* A frame handed to the runtime (am_send_zc) is freed here, maybe by a
 * ZeroMQ I/O thread: *hint counts the frames not freed yet. */
static void free_frame(void *frame, void *hint)
{
    pr_free(frame);
    if (hint)
        atomic_fetch_sub((atomic_int *)hint, 1);
}

/* A PE but rank 0: its submesh to rank 0, in pieces (par_merge_pieces),
 * each encoded after room for the runtime's header and handed over
 * without a copy (am_send_zc), and the next made only once the runtime
 * let go of it: the PE holds one piece's message at a time beside its
 * mesh. *held (0 on entry) counts the frames the runtime holds; it must
 * live until am_finalize, which frees those an error left. Returns 0, a
 * PDR_ code of the encoder or an AM_ code. */
static int send_merge(am_ctx_t *am, const par_sub *s, atomic_int *held, int *am_err)
{
    *am_err = 0;
    par_merge_pieces pc;
    int rc = par_merge_pieces_init(&pc, s, PAR_MERGE_PIECE);
    if (rc)
        return rc;
    const uint32_t *tets;
    uint32_t nt;
    for (uint32_t idx = 0; !rc && idx < pc.count; idx++) {
        if (!par_merge_pieces_next(&pc, &tets, &nt)) {
            rc = PDR_EINVAL; /* fewer live tetrahedra than counted */
            break;
        }
        pr_buf b = PR_BUF_INIT;
        if (pr_buf_reserve(&b, AM_HEADROOM + 8)) {
            rc = PDR_ENOMEM;
            break;
        }
        memset(b.data, 0, AM_HEADROOM);
        pr_store_u32(b.data + AM_HEADROOM, idx);
        pr_store_u32(b.data + AM_HEADROOM + 4, pc.count);
        b.len = AM_HEADROOM + 8;
        rc = par_wire_encode_tets(&b, s, tets, nt);
        if (rc) {
            pr_buf_free(&b);
            break;
        }
        size_t len;
        uint8_t *frame = pr_buf_take(&b, &len);
        if (!frame) {
            rc = PDR_ENOMEM;
            break;
        }
        atomic_fetch_add(held, 1);
        rc = am_send_zc(am, 0, H_MERGE, frame, len - AM_HEADROOM, free_frame, held);
        if (rc) {
            /* not handed over: freed here (am_send_zc's contract) */
            atomic_fetch_sub(held, 1);
            pr_free(frame);
            *am_err = 1;
            break;
        }
        /* out now, not at the rows' gather: rank 0 decodes it meanwhile */
        am_flush(am);
        while (!rc && atomic_load(held) > 0) {
            rc = am_poll(am);
            if (rc >= 0)
                rc = atomic_load(held) > 0 ? am_idle(am, 0.001) : 0;
            if (rc > 0)
                rc = 0;
            if (rc)
                *am_err = 1;
        }
    }
    par_merge_pieces_free(&pc);
    return rc;
}

/* ------------------------------------------------------- Table 1 rows */

/* A row travels as ROW_F64 f64 values, then ROW_U64 u64 counters, then
 * the refinement's insertion counts. */
#define ROW_F64 12
#define ROW_U64 20

static void put_row(pr_buf *b, const par_table1 *t, const ref_stats *st)
{
    double f[ROW_F64] = {t->exec_s,   t->completed_s, t->masked_local_s,
                         t->masked_dist_s, t->setback_s, t->service_s,
                         t->poll_s,   t->poll_excess_s, t->idle_s,
                         t->completed_wall_s, t->masked_wall_s, t->setback_wall_s};
    uint64_t u[ROW_U64] = {t->steps,   t->cav_local, t->cav_dist, t->setbacks,
                           t->backoffs, t->tets_in,  t->tets_out, t->msgs_sent,
                           t->bytes_sent, t->tets_end, t->slots_end, t->peak_rss,
                           t->missing_segs, t->missing_facs, t->deferred, t->cpu_clock,
                           t->region_doubts, t->left_elsewhere, t->peak_nonfile,
                           t->peak_pss};
    pr_put_f64_array(b, f, ROW_F64);
    pr_put_u64_array(b, u, ROW_U64);
    uint64_t s[7] = {st->tet_points, st->fac_points, st->seg_points, st->rejected,
                     st->tolerated, st->gave_up, st->missing_recovered};
    pr_put_u64_array(b, s, 7);
}

/* Reads a row from data[0..len); *rest gets where the PE's list of
 * missing pieces (par_merge_put_missing) starts. */
static int get_row(const void *data, size_t len, par_table1 *t, ref_stats *st, size_t *rest)
{
    pr_reader r;
    pr_reader_init(&r, data, len);
    double f[ROW_F64];
    uint64_t u[ROW_U64], s[7];
    pr_get_f64_array(&r, f, ROW_F64);
    pr_get_u64_array(&r, u, ROW_U64);
    pr_get_u64_array(&r, s, 7);
    if (r.err)
        return PDR_EPARSE;
    *rest = len - r.left;
    memset(t, 0, sizeof *t);
    t->exec_s = f[0];
    t->completed_s = f[1];
    t->masked_local_s = f[2];
    t->masked_dist_s = f[3];
    t->setback_s = f[4];
    t->service_s = f[5];
    t->poll_s = f[6];
    t->poll_excess_s = f[7];
    t->idle_s = f[8];
    t->completed_wall_s = f[9];
    t->masked_wall_s = f[10];
    t->setback_wall_s = f[11];
    t->steps = u[0];
    t->cav_local = u[1];
    t->cav_dist = u[2];
    t->setbacks = u[3];
    t->backoffs = u[4];
    t->tets_in = u[5];
    t->tets_out = u[6];
    t->msgs_sent = u[7];
    t->bytes_sent = u[8];
    t->tets_end = u[9];
    t->slots_end = u[10];
    t->peak_rss = u[11];
    t->missing_segs = u[12];
    t->missing_facs = u[13];
    t->deferred = u[14];
    t->cpu_clock = u[15];
    t->region_doubts = u[16];
    t->left_elsewhere = u[17];
    t->peak_nonfile = u[18];
    t->peak_pss = u[19];
    st->tet_points += s[0];
    st->fac_points += s[1];
    st->seg_points += s[2];
    st->rejected += s[3];
    st->tolerated += s[4];
    st->gave_up += s[5];
    st->missing_recovered += s[6];
    return 0;
}

static int write_row_json(const char *dir, int rank, int size, const par_table1 *t)
{
    char path[4096];
    if (snprintf(path, sizeof path, "%s/table1-%d.json", dir, rank) >= (int)sizeof path)
        return PDR_EINVAL;
    if (am_mkdir_p(dir))
        return PDR_EIO;
    outfile of;
    if (outfile_open(&of, path, NULL))
        return PDR_EIO;
    fprintf(of.f,
            "{\n  \"rank\": %d,\n  \"size\": %d,\n  \"execution_s\": %.9g,\n"
            "  \"completed_cavity_s\": %.9g,\n  \"masked_local_s\": %.9g,\n"
            "  \"masked_distributed_s\": %.9g,\n  \"setback_s\": %.9g,\n"
            "  \"latency_tolerance\": %.6f,\n  \"work_clock\": \"%s\",\n"
            "  \"completed_cavity_wall_s\": %.9g,\n  \"masked_wall_s\": %.9g,\n"
            "  \"setback_wall_s\": %.9g,\n  \"latency_tolerance_wall\": %.6f,\n"
            "  \"service_s\": %.9g,\n  \"poll_s\": %.9g,\n"
            "  \"poll_excess_s\": %.9g,\n  \"idle_s\": %.9g,\n  \"steps\": %llu,\n"
            "  \"cavities_local\": %llu,\n  \"cavities_distributed\": %llu,\n"
            "  \"setbacks\": %llu,\n  \"deferred\": %llu,\n  \"backoffs\": %llu,\n"
            "  \"tets_migrated_in\": %llu,\n"
            "  \"tets_migrated_out\": %llu,\n  \"messages_sent\": %llu,\n"
            "  \"bytes_sent\": %llu,\n  \"tets_held_at_end\": %llu,\n"
            "  \"tet_slots_at_end\": %llu,\n  \"peak_rss_bytes\": %llu,\n"
            "  \"peak_rss_nonfile_bytes\": %llu,\n  \"peak_pss_bytes\": %llu,\n"
            "  \"work_units\": %llu,\n  \"points_inserted\": %llu,\n"
            "  \"cavities_too_big\": %llu\n}\n",
            rank, size, t->exec_s, t->completed_s, t->masked_local_s, t->masked_dist_s,
            t->setback_s, par_table1_tolerance(t), t->cpu_clock ? "cpu" : "wall",
            t->completed_wall_s, t->masked_wall_s, t->setback_wall_s,
            par_table1_tolerance_wall(t), t->service_s, t->poll_s, t->poll_excess_s,
            t->idle_s, (unsigned long long)t->steps, (unsigned long long)t->cav_local,
            (unsigned long long)t->cav_dist, (unsigned long long)t->setbacks,
            (unsigned long long)t->deferred, (unsigned long long)t->backoffs, (unsigned long long)t->tets_in,
            (unsigned long long)t->tets_out, (unsigned long long)t->msgs_sent,
            (unsigned long long)t->bytes_sent, (unsigned long long)t->tets_end,
            (unsigned long long)t->slots_end, (unsigned long long)t->peak_rss,
            (unsigned long long)t->peak_nonfile, (unsigned long long)t->peak_pss,
            (unsigned long long)t->work, (unsigned long long)t->points,
            (unsigned long long)t->too_big);
    return outfile_commit(&of, NULL) ? PDR_EIO : 0;
}

static void print_row(const char *label, const par_table1 *t)
{
    printf("  %-12s %9.3f %10.3f %9.3f (%.3f) %9.3f %8.1f%% %9.3f (%.3f)\n", label, t->exec_s,
           t->completed_s, t->masked_local_s, t->masked_dist_s, t->setback_s,
           100.0 * par_table1_tolerance(t), t->poll_s, t->poll_excess_s);
}

/* Rank 0's whole-process peak with the merged mesh of tets interior
 * tetrahedra, bytes per tetrahedron: RSS, without file pages, PSS. */
typedef struct merged_mem {
    uint64_t rss, nonfile, pss;
} merged_mem;

/* The summary lines of the parallel run (rank 0). */
static void print_table1(const par_table1 *rows, int size, uint32_t parts, size_t mo_tets,
                         const merged_mem *mm)
{
    par_table1 avg = {0};
    uint64_t local = 0, dist = 0, setbacks = 0, moved = 0, deferred = 0;
    int worst = 0, worst_wall = 0, ncpu = 0;
    for (int k = 0; k < size; k++) {
        const par_table1 *t = &rows[k];
        avg.exec_s += t->exec_s / size;
        avg.completed_s += t->completed_s / size;
        avg.masked_local_s += t->masked_local_s / size;
        avg.masked_dist_s += t->masked_dist_s / size;
        avg.setback_s += t->setback_s / size;
        avg.masked_wall_s += t->masked_wall_s / size;
        avg.setback_wall_s += t->setback_wall_s / size;
        ncpu += t->cpu_clock != 0;
        deferred += t->deferred;
        avg.poll_s += t->poll_s / size;
        avg.poll_excess_s += t->poll_excess_s / size;
        local += t->cav_local;
        dist += t->cav_dist;
        setbacks += t->setbacks;
        moved += t->tets_in;
        if (par_table1_tolerance(t) < par_table1_tolerance(&rows[worst]))
            worst = k;
        if (par_table1_tolerance_wall(t) < par_table1_tolerance_wall(&rows[worst_wall]))
            worst_wall = k;
    }
    printf("parallel: %d PEs, %u parts, Mo %zu tetrahedra; cavities %llu local, %llu "
           "distributed, %llu setbacks, %llu deferred; %llu tetrahedra migrated\n",
           size, parts, mo_tets, (unsigned long long)local, (unsigned long long)dist,
           (unsigned long long)setbacks, (unsigned long long)deferred,
           (unsigned long long)moved);
    /* A PE's figures are of its whole run (its merge messages sent);
     * rank 0's row holds the input and Mo, up to the merge, and mm its
     * whole run, merge included, per tetrahedron of the merged mesh. The
     * second figure leaves out the file pages (the program's and the
     * libraries' code), which RSS counts in every PE. */
    uint64_t worst_b = 0, rank0_b = rows[0].tets_end ? rows[0].peak_rss / rows[0].tets_end : 0;
    uint64_t worst_nf = 0, rank0_nf = rows[0].tets_end ? rows[0].peak_nonfile / rows[0].tets_end : 0;
    uint64_t worst_ps = 0, rank0_ps = rows[0].tets_end ? rows[0].peak_pss / rows[0].tets_end : 0;
    for (int k = 1; k < size; k++) {
        if (rows[k].tets_end && rows[k].peak_pss / rows[k].tets_end > worst_ps)
            worst_ps = rows[k].peak_pss / rows[k].tets_end;
        if (rows[k].tets_end && rows[k].peak_rss / rows[k].tets_end > worst_b)
            worst_b = rows[k].peak_rss / rows[k].tets_end;
        if (rows[k].tets_end && rows[k].peak_nonfile / rows[k].tets_end > worst_nf)
            worst_nf = rows[k].peak_nonfile / rows[k].tets_end;
    }
    if (size > 1)
        printf("PE memory: peak RSS per interior tetrahedron held: at most %llu bytes on PEs "
               "1-%d (with its merge messages), on rank 0 %llu before the merge (with the "
               "input and Mo) and %llu with the merged mesh; without file pages: at most "
               "%llu, rank 0 %llu and %llu; proportional (PSS): at most %llu, rank 0 %llu and "
               "%llu\n",
               (unsigned long long)worst_b, size - 1, (unsigned long long)rank0_b,
               (unsigned long long)mm->rss, (unsigned long long)worst_nf,
               (unsigned long long)rank0_nf, (unsigned long long)mm->nonfile,
               (unsigned long long)worst_ps, (unsigned long long)rank0_ps,
               (unsigned long long)mm->pss);
    printf("table 1 (s):    execution  completed  masked local (dist)   setback  tolerance"
           "  poll (excess)\n");
    char label[32];
    snprintf(label, sizeof label, "worst PE %d", worst);
    print_row(label, &rows[worst]);
    print_row("average", &avg);
    if (ncpu)
        printf("work times on the CPU clock on %d of %d PEs (--work-clock); on the wall clock "
               "the tolerance is %.1f%% on the worst PE (%d), %.1f%% on average\n",
               ncpu, size, 100.0 * par_table1_tolerance_wall(&rows[worst_wall]), worst_wall,
               100.0 * par_table1_tolerance_wall(&avg));
}

/* Rank 0's lines about the parallel job: Table 1 and the times of its
 * stages (mp_conclude's lines). */
typedef struct job_info {
    const par_table1 *rows; /* one per PE */
    int size;               /* PEs */
    uint32_t parts;
    size_t mo_tets;
    /* seconds: distribute, refine, gather, merge, rank 0's finish (part
     * of the merge), and the distribution's Mo, partition and send */
    double sec[8];
} job_info;

static void job_lines(const mp_ctx *c, void *arg)
{
    const job_info *j = arg;
    const double *t = j->sec;
    if (c->o.quiet)
        return;
    /* rank 0's whole run, the merged mesh made and written */
    pdr_mem_now now;
    pdr_mem_peak(&now);
    size_t nt = c->out.view.nt ? c->out.view.nt : 1;
    merged_mem mm = {pdr_peak_rss() / nt, now.nonfile / nt, now.pss / nt};
    print_table1(j->rows, j->size, j->parts, j->mo_tets, &mm);
    printf("parallel time: distribute %.3f, refine %.3f, gather %.3f, merge %.3f s (of "
           "which rank 0's finish %.3f)\n",
           t[0], t[1], t[2], t[3], t[4]);
    /* The distribution's parts, for the paper's Table 2. */
    printf("distribute: Mo %.3f, partition %.3f, send %.3f s\n", t[5], t[6], t[7]);
}

/* PDR_PAR_TRACE=SECONDS: a line per PE that often on stderr (debugging). */
static void trace_line(void *arg, const par_sub *s, const par_table1 *t)
{
    (void)arg;
    const ref_mesher *r = &s->r;
    pdr_line(stderr,
             "trace PE %u: nv %u live %u | q seg %zu fac %zu tet %zu | pts tet %zu fac %zu "
             "seg %zu miss %zu | steps %llu local %llu dist %llu setbacks %llu in %llu "
             "out %llu bands %llu/%llu %.3f s\n",
             s->rank, r->m.nv, r->m.nlive, r->segq.n - r->segq.head,
             r->facq.n - r->facq.head, r->tetq.n - r->tetq.head, r->st.tet_points,
             r->st.fac_points, r->st.seg_points, r->st.missing_recovered,
             (unsigned long long)t->steps, (unsigned long long)t->cav_local,
             (unsigned long long)t->cav_dist, (unsigned long long)t->setbacks,
             (unsigned long long)t->tets_in, (unsigned long long)t->tets_out,
             (unsigned long long)t->bands_out, (unsigned long long)t->bands_in, t->band_s);
}

/* --------------------------------------------------------- submeshes */

static int write_submesh(const par_sub *s, const char *base)
{
    char stem[4096];
    if (snprintf(stem, sizeof stem, "%s.p%u", base, s->rank) >= (int)sizeof stem)
        return PDR_EINVAL;
    ref_output out;
    int rc = ref_export(&s->r, &out);
    if (rc)
        return rc;
    char *pn = pdr_path_join(stem, ".node"), *pe = pdr_path_join(stem, ".ele"),
         *pf = pdr_path_join(stem, ".face");
    pdr_diag diag = {0};
    rc = pn && pe && pf ? 0 : PDR_ENOMEM;
    tg_nodes nodes = {.n = out.view.nv, .first = 1, .xyz = (double *)out.xyz};
    outset set = OUTSET_INIT;
    if (!rc)
        rc = tg_write_node(pn, &nodes, &set, &diag);
    if (!rc)
        rc = tg_write_ele_view(pe, &out.view, out.tet_attr, 1, &set, &diag);
    if (!rc)
        rc = face_write(&out.view, pf, 1, &set, &diag);
    if (rc)
        outset_abort(&set);
    else
        rc = outset_commit(&set, &diag);
    pdr_diag_print(&diag, stderr);
    pdr_diag_free(&diag);
    pr_free(pn);
    pr_free(pe);
    pr_free(pf);
    ref_output_free(&out);
    return rc;
}

/* ---------------------------------------------------------- the run */

/* Rank 0, before Mo is partitioned: drops the mark of rank 0's queue of
 * bad tetrahedra (TM_F_QUEUED) from Mo. The mark travels with a
 * tetrahedron (PAR_WIRE_TFLAGS), where it means "left for the merge"
 * (refine_run.c, leave_to_merge), and a PE does not queue a tetrahedron
 * that has it (ref_queue_all_tets): but the queue itself stays here. A
 * Mo whose recovery went on after its classification (points on
 * segments of near-planar facets: pinion.off, 22,000 of its 24,000
 * tetrahedra marked) reached the PEs with its bad tetrahedra marked and
 * queued nowhere: they were never split there, and the cavities of
 * their neighbours' splits grew over them, past what a PE imports, each
 * such step slower than the last. */
static void mo_unqueue(ref_mesher *r)
{
    tm_mesh *m = &r->m;
    for (uint32_t t = 0; t < m->nslots; t++)
        m->flags[t] &= (uint16_t)~TM_F_QUEUED;
}

/* What rank 0's refinement before the PEs' did (refine_alone). */
enum { PRE_NONE, PRE_ALONE, PRE_PAUSED };

/* Rank 0, without a volume bound or --mo-size: the sequential quality
 * refinement of the conforming mesh (mp_refine), paused before the first
 * bad tetrahedron's split past po->rank0_points added points (no
 * subsegment or subfacet queued then). Without a volume bound the final
 * size is unknown, and the conforming mesh of a CAD surface is coarse
 * (pinion_small.off: 1,255 tetrahedra), so that nearly every cavity of
 * the PEs crossed the interface and 2 PEs took 10 to 100 times the
 * sequential time, or stopped on the progress bound. A mesh that is
 * finished before the pause (*alone PRE_ALONE) is the sequential mesh,
 * exported, which rank 0 writes alone; otherwise (PRE_PAUSED) the paused
 * mesh, of about 4 rank0_points tetrahedra, is Mo, and the PEs go on
 * with its refinement (the same bounds: the mesh is as fine as the
 * sequential one). */
static int refine_alone(mp_ctx *c, const mpar_opts *po, int *alone)
{
    *alone = PRE_NONE;
    if (c->o.mo_size > 0 || c->o.ref.maxvol > 0 || c->o.mo_only || po->rank0_points <= 0)
        return 0;
    ref_mesher *r = &c->r;
    r->pause_points =
        r->st.seg_points + r->st.fac_points + r->st.tet_points + (size_t)po->rank0_points;
    r->paused = 0;
    int rc = mp_refine(c);
    r->pause_points = 0;
    if (!rc && !r->paused) {
        *alone = PRE_ALONE;
        rc = mp_export(c);
    } else if (!rc) {
        *alone = PRE_PAUSED;
    }
    c->refined = *alone == PRE_ALONE;
    return rc;
}

/* Rank 0: the job messages (PLC, options, each PE's submesh), and the
 * size of Mo; t[0] when the conforming mesh is done, t[1] when Mo is,
 * t[2] when it is partitioned into submeshes; *alone what
 * refine_alone did (PRE_ALONE: no message built) and *mo_st Mo's counts.
 * Returns 0 or a code (its message printed). */
static int prepare(mp_ctx *c, const mp_opts *given, const mpar_opts *po, int size, pr_buf *msg,
                   size_t *mo_tets, double t[3], int *alone, ref_stats *mo_st)
{
    mp_opts *o = &c->o;
    /* As pdr mesh alone does (cmd_mesh.c, run_pipeline): a failure with
     * near-planar facets makes the initial mesh again with exact facets
     * (TR12J_OCC.stl's recovery fails with them). Only rank 0's stages
     * are retried: the PEs get the PLC that meshed. */
    int rc, read;
    do {
        rc = mp_read(c);
        read = !rc;
        if (!rc)
            rc = mp_initial_mesh(c);
        t[0] = pdr_now();
        if (!rc)
            rc = refine_alone(c, po, alone);
    } while (mp_retry_exact_facets(c, given, rc, read));
    if (rc || *alone == PRE_ALONE)
        return rc;
    if (!(o->mo_size > 0) && o->ref.maxvol > 0) {
        /* The paper's 10^5 tetrahedra, or a tenth of the final mesh when
         * that is smaller: a mesh with radius-edge bound 2 and volume
         * bound V has about 2 vol/V tetrahedra (1.98 on cube-in-cube, 1.97
         * on the tee at V = 1e-5). Without a volume bound the final size
         * is unknown, and a volume bound on Mo would make the result finer
         * than the sequential one: rank 0 refined it with the job's own
         * bounds instead (refine_alone). */
        double est = fmin(MO_SIZE_PAPER, 0.2 * im_interior_volume(&c->r) / o->ref.maxvol);
        if (est > (double)ref_interior_tets(&c->r) && (rc = im_mo_size(&c->r, (size_t)est))) {
            fprintf(stderr, "pdr mesh: cannot refine the initial mesh: %s\n", pdr_strerror(rc));
            return rc;
        }
    }
    *mo_tets = ref_interior_tets(&c->r);
    *mo_st = c->r.st;
    mo_unqueue(&c->r);
    t[1] = pdr_now();
    uint32_t parts = po->parts ? po->parts : (uint32_t)size;
    par_decomp d;
    rc = par_decomp_run(&c->r, (uint32_t)size, parts, (int)po->seed, &d);
    t[2] = pdr_now();
    pr_buf plcb = PR_BUF_INIT, optb = PR_BUF_INIT;
    if (!rc)
        rc = par_decomp_plc_put(&plcb, &c->p);
    /* A Mo from the recovery with segments first leaves the faces no flip
     * mends (ref_mesher.keep_stuck): so do the PEs, and rank 0's merge,
     * which starts from the same options. */
    c->o.ref.keep_stuck = c->r.keep_stuck;
    if (!rc)
        rc = par_decomp_opts_put(&optb, &c->o.ref);
    for (int k = 0; k < size && !rc; k++) {
        pr_put_u8(&msg[k], 0);
        put_blob(&msg[k], &plcb);
        put_blob(&msg[k], &optb);
        put_blob(&msg[k], &d.msg[k]);
        if (msg[k].err)
            rc = PDR_ENOMEM;
    }
    pr_buf_free(&plcb);
    pr_buf_free(&optb);
    par_decomp_free(&d);
    if (rc)
        fprintf(stderr, "pdr mesh: cannot distribute the initial mesh: %s\n", pdr_strerror(rc));
    return rc;
}

/* Every PE: the submesh from the job message. */
static int load(const job *j, plc *p, ref_opts *ro, par_sub *s, int *have_plc)
{
    pr_reader r;
    pr_reader_init(&r, j->data, j->len);
    uint8_t st;
    const uint8_t *b[3];
    size_t n[3];
    pr_get_u8(&r, &st);
    for (int k = 0; k < 3; k++)
        if (get_blob(&r, &b[k], &n[k]))
            return PDR_EPARSE;
    if (pr_reader_finish(&r))
        return PDR_EPARSE;
    pdr_diag diag = {0};
    int rc = par_decomp_plc_decode(b[0], n[0], p, &diag);
    *have_plc = 1;
    pdr_diag_print(&diag, stderr);
    pdr_diag_free(&diag);
    if (!rc)
        rc = par_decomp_opts_decode(b[1], n[1], ro);
    if (!rc)
        rc = par_wire_load(b[2], n[2], p, ro, s);
    return rc;
}

/* Rank 0, when it finished the mesh alone (refine_alone): the line that
 * says so in place of Table 1 (mp_conclude's lines). */
typedef struct alone_info {
    int size;           /* PEs in the job */
    long rank0_points;  /* --rank0-points */
} alone_info;

static void alone_lines(const mp_ctx *c, void *arg)
{
    const alone_info *a = arg;
    if (!c->o.quiet)
        printf("parallel: %d PEs; rank 0 refined the mesh alone: it was finished within "
               "--rank0-points %ld points, too small a job for the parallel refinement to "
               "pay; the other PEs had nothing to do\n",
               a->size, a->rank0_points);
}

int mpar_run(const mp_opts *mo, const mpar_opts *po)
{
    am_opts_t ao = AM_OPTS_INIT;
    /* The refinement's searches keep their stacks on the heap; 256 KiB
     * leaves room for the sanitizers. */
    ao.stack_size = 256 * 1024;
    ao.stats_dir = NULL;
    am_ctx_t *am = NULL;
    int rc = am_init(NULL, NULL, &ao, &am);
    if (rc) {
        fprintf(stderr, "pdr mesh: cannot start the runtime: %s\n", am_strerror(rc));
        return PDR_EXIT_FAIL;
    }
    int rank = am_rank(am), size = am_size(am);
    job j = {0};
    mp_ctx c;
    mp_init(&c, mo);
    plc p;
    memset(&p, 0, sizeof p);
    int have_plc = 0, have_sub = 0;
    atomic_int merge_held; /* send_merge's frames, until am_finalize */
    atomic_init(&merge_held, 0);
    par_sub s;
    ref_opts ro = mo->ref;
    ref_stats sum;
    memset(&sum, 0, sizeof sum);
    par_table1 row, *rows = NULL;
    size_t mo_tets = 0;
    int status = PDR_EXIT_FAIL;
    merge_in min = {.p = &p, .size = size};
    par_merge_ahead ahead;
    memset(&ahead, 0, sizeof ahead);
    if (rank == 0) {
        min.pe = pr_calloc((size_t)size, sizeof *min.pe);
        if (!min.pe) {
            fprintf(stderr, "pdr mesh: PE 0: out of memory\n");
            goto done;
        }
    }
    /* Rank 0's clock: conforming mesh, Mo and partition done, refinement
     * started and ended, submeshes gathered (the merge's own time is
     * measured around it). */
    double t_prep[3] = {0, 0, 0}, t_start = 0, t_end = 0, t_gathered = 0;
    /* Rank 0's sample of par_table1.peak_nonfile and peak_pss with Mo and
     * the parts' messages held (its resident set peaks there). */
    pdr_mem_now mem_prepared = {0, 0, 0};
    rc = am_register(am, H_JOB, "mesh-job", on_job, &j);
    if (!rc)
        rc = am_register(am, H_MERGE, "mesh-merge", on_merge, &min);
    if (!rc)
        rc = am_barrier(am);
    if (rc)
        goto done;

    if (rank == 0) {
        pr_buf *msg = pr_calloc((size_t)size, sizeof *msg);
        int pre = PRE_NONE;
        ref_stats mo_st;
        memset(&mo_st, 0, sizeof mo_st);
        int prc = msg ? prepare(&c, mo, po, size, msg, &mo_tets, t_prep, &pre, &mo_st)
                      : PDR_ENOMEM;
        pdr_mem_peak(&mem_prepared);
        for (int k = 1; k < size; k++) {
            if (prc)
                am_send(am, k, H_JOB, "\1", 1);
            else if (pre == PRE_ALONE)
                am_send(am, k, H_JOB, "\2", 1);
            else
                am_send(am, k, H_JOB, msg[k].data, msg[k].len);
        }
        if (!prc && pre != PRE_ALONE) {
            j.got = 1;
            j.len = msg[0].len;
            j.data = pr_buf_take(&msg[0], &j.len);
        }
        for (int k = 0; msg && k < size; k++)
            pr_buf_free(&msg[k]);
        pr_free(msg);
        if (prc)
            goto done;
        if (pre == PRE_ALONE) {
            alone_info a = {size, po->rank0_points};
            status = mp_conclude(&c, alone_lines, &a) ? PDR_EXIT_FAIL : PDR_EXIT_OK;
            goto done;
        }
        /* The refinement's counts start from Mo's, which rank 0 refined
         * part of the way (refine_alone). A Mo refined to its size
         * (prepare) gives its points and rejections only, which the
         * summary counts from the conforming mesh on (mp_print_mesh_summary);
         * the other counts, bounds of rank 0's finish among them
         * (stuck_splits), start from the PEs' alone. */
        if (pre == PRE_PAUSED) {
            sum = mo_st;
        } else {
            sum.tet_points = mo_st.tet_points;
            sum.fac_points = mo_st.fac_points;
            sum.seg_points = mo_st.seg_points;
            sum.rejected = mo_st.rejected;
        }
        /* Mo's memory goes before the submeshes are built. */
        ref_free(&c.r);
        c.have_r = 0;
    } else if ((rc = wait_job(am, &j))) {
        goto done;
    }
    if (j.status == 2) {
        status = PDR_EXIT_OK; /* rank 0 finished the mesh alone */
        goto done;
    }
    if (j.status)
        goto done; /* rank 0 said why */
    if ((rc = load(&j, &p, &ro, &s, &have_plc))) {
        fprintf(stderr, "pdr mesh: PE %d: cannot build its submesh: %s\n", rank,
                pdr_strerror(rc));
        goto done;
    }
    have_sub = 1;
    /* The submesh and the message it came in, both held here: a sample
     * of par_table1.peak_nonfile and peak_pss. */
    pdr_mem_now mem_loaded;
    pdr_mem_peak(&mem_loaded);
    /* This PE's own debugging aids (its environment, not rank 0's). */
    s.r.o.check_each_step = mo->ref.check_each_step;
    s.r.o.log = mo->ref.log;
    /* --max-points bounds the points of each PE too (par_run.h) */
    s.r.o.max_points = mo->max_points < 0 ? ref_point_limit(&p, &s.r.o) : (size_t)mo->max_points;
    pr_free(j.data);
    j.data = NULL;

    /* Refine. */
    t_start = pdr_now();
    rc = ref_queue_all_tets(&s.r);
    par_run_opts ro_run;
    memset(&ro_run, 0, sizeof ro_run);
    ro_run.max_threads = po->max_threads;
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    ro_run.cpu_clock = po->work_clock == MPAR_CLOCK_CPU ||
                       (po->work_clock == MPAR_CLOCK_AUTO && cores > 0 && size > cores);
    ro_run.seed = po->seed;
    /* PDR_PAR_ORDER=local|local-all|fifo|lifo: the order of the bad
     * tetrahedra, for comparisons. Default local: REF_ORDER_LOCAL_FIRST,
     * where a step next to the interface counts as remote (local-all:
     * it does not). */
    const char *order = getenv("PDR_PAR_ORDER");
    int local = !order || !strcmp(order, "local"), local_all = order && !strcmp(order, "local-all");
    ro_run.strict_local = local;
    ro_run.order = local || local_all         ? REF_ORDER_LOCAL_FIRST
                   : !strcmp(order, "lifo")   ? REF_ORDER_LIFO
                                              : REF_ORDER_FIFO;
    const char *reach = getenv("PDR_PAR_BUSY_REACH");
    ro_run.busy_reach = reach ? atof(reach) : -1;
    const char *chain = getenv("PDR_PAR_CHAIN");
    ro_run.chain_s = chain ? atof(chain) : 0;
    /* PDR_PAR_STALL=WINDOW[,RATIO[,SECONDS]]: the progress bound's
     * stretch of work, the units allowed per point and the seconds without
     * a point (par_run.h, PAR_RUN_STALL_WINDOW), for tests. */
    const char *stall = getenv("PDR_PAR_STALL");
    if (stall) {
        char *end;
        ro_run.stall_window = strtod(stall, &end);
        if (*end == ',')
            ro_run.stall_ratio = strtod(end + 1, &end);
        if (*end == ',')
            ro_run.stall_seconds = strtod(end + 1, NULL);
    }
    /* PDR_PAR_BAND=MARGIN[,MAX[,SHARE]]: the interface band of 2 PEs
     * (par_run.h, PAR_RUN_BAND_MARGIN) with that margin, at most MAX
     * bands per PE, due once 1/SHARE of a window's steps were distributed;
     * MARGIN 0 or less: off (for comparisons and tests). */
    const char *band = getenv("PDR_PAR_BAND");
    if (band) {
        ro_run.band_margin = atoi(band) > 0 ? atoi(band) : -1;
        const char *comma = strchr(band, ',');
        if (comma)
            ro_run.band_max = atoi(comma + 1);
        if (comma && (comma = strchr(comma + 1, ',')) != NULL)
            ro_run.band_share = atoi(comma + 1);
    }
    const char *tr = getenv("PDR_PAR_TRACE");
    if (tr && atof(tr) > 0) {
        ro_run.progress = trace_line;
        ro_run.progress_s = atof(tr);
    }
    if (!rc)
        rc = par_run_refine(am, &s, &ro_run, &row);
    if (row.peak_nonfile < mem_loaded.nonfile)
        row.peak_nonfile = mem_loaded.nonfile;
    if (row.peak_nonfile < mem_prepared.nonfile)
        row.peak_nonfile = mem_prepared.nonfile;
    if (row.peak_pss < mem_loaded.pss)
        row.peak_pss = mem_loaded.pss;
    if (row.peak_pss < mem_prepared.pss)
        row.peak_pss = mem_prepared.pss;
    if (rc && s.r.recovery_stuck) {
        char why[512];
        mp_recovery_stuck_text(&s.r, 9, why, sizeof why);
        fprintf(stderr, "pdr mesh: PE %d: %s\n", rank, why);
        fflush(stderr);
        _exit(PDR_EXIT_FAIL); /* as below */
    }
    if (rc && row.point_limit) {
        fprintf(stderr,
                "pdr mesh: PE %d: inserted %llu points, the bound of --max-points; stopped\n",
                rank, (unsigned long long)row.points);
        fflush(stderr);
        _exit(PDR_EXIT_FAIL); /* as below */
    }
    if (rc && row.stalled == 2) {
        fprintf(stderr,
                "pdr mesh: PE %d: the parallel refinement makes no progress: it inserted no "
                "point in the last %.3g s while it kept attempting steps (each step slow, or "
                "failing over and over); stopped\n",
                rank, row.stall_s);
        fflush(stderr);
        _exit(PDR_EXIT_FAIL); /* as below */
    }
    if (rc && row.stalled) {
        fprintf(stderr,
                "pdr mesh: PE %d: the parallel refinement makes no progress: its last %llu "
                "units of work (%d per cavity attempt, 1 per tetrahedron migrated in or "
                "created, 1 per %g s of an attempt's compute time) inserted %llu points, fewer than one per %g units (cavities moved "
                "between PEs or failing over and over); stopped\n",
                rank, (unsigned long long)row.stall_work, PAR_RUN_WORK_ATTEMPT, PAR_RUN_WORK_UNIT_S,
                (unsigned long long)row.stall_points,
                ro_run.stall_ratio > 0 ? ro_run.stall_ratio : PAR_RUN_STALL_RATIO);
        fflush(stderr);
        _exit(PDR_EXIT_FAIL); /* as below */
    }
    if (rc) {
        fprintf(stderr, "pdr mesh: PE %d: parallel refinement failed: %s\n", rank,
                rc < 0 && rc > -100 ? pdr_strerror(rc) : am_strerror(rc));
        /* Cavity threads may still be blocked, their handlers registered
         * (par_run.h): end this PE now; the others see it go away and
         * end too. No output file exists yet. */
        fflush(stdout);
        fflush(stderr);
        _exit(PDR_EXIT_FAIL);
    }
    t_end = pdr_now();
    if (po->check_end) {
        par_verify_report rep;
        memset(&rep, 0, sizeof rep);
        size_t bad = ref_consistency(&s.r, stderr, REF_CONSIST_PART) + par_verify_facets(&s, stderr) +
                     par_verify_sub(&s, &rep);
        fprintf(stderr, "pdr mesh: PE %d: check at the end of the refinement: %zu problem%s\n",
                rank, bad, bad == 1 ? "" : "s");
    }
    if (po->submeshes) {
        const char *base = c.base ? c.base : mo->out ? mo->out : "pdr-mesh";
        if (write_submesh(&s, base))
            fprintf(stderr, "pdr mesh: PE %d: cannot write its submesh\n", rank);
    }

    /* The submeshes and the rows to rank 0. Each PE but rank 0 sends its
     * merge messages (send_merge), which rank 0 decodes as they come
     * (on_merge); rank 0 meanwhile takes its own submesh as it is and
     * checks its links on the way (par_wire_from_sub_pairs: no message),
     * then the rows are gathered. */
    int am_err = 0;
    /* What only the refinement used goes first, and the heap's free
     * pages back to the system, before the merge messages are made. */
    ref_release_work(&s.r);
    tm_drop_locks(&s.r.m);
#ifdef HAVE_MALLOC_TRIM
    malloc_trim(0);
#endif
    /* A PE's merge messages held a piece of its submesh encoded beside
     * it (and the tables each was made from, freed since): a sample after
     * them makes the row's memory figures those of the whole run. Rank
     * 0's row stops before the merge, where it comes to hold the whole
     * mesh (job_lines gives that peak apart). */
    if (rank != 0)
        rc = send_merge(am, &s, &merge_held, &am_err);
    pdr_mem_now mem_merge;
    pdr_mem_peak(&mem_merge);
    row.peak_rss = pdr_peak_rss();
    if (row.peak_nonfile < mem_merge.nonfile)
        row.peak_nonfile = mem_merge.nonfile;
    if (row.peak_pss < mem_merge.pss)
        row.peak_pss = mem_merge.pss;
    if (rank == 0) {
#if defined HAVE_MALLOPT && defined M_MMAP_THRESHOLD
        /* The merge frees each piece's tables once it has taken them
         * (par_merge_build_wires_spent). glibc raises its threshold for
         * mapping a block alone to the largest such block freed, and the
         * pieces' blocks (a few hundred KiB) would then come from the
         * heap, whose freed pages stay resident: a fixed threshold gives
         * them back as they go (10^6 tetrahedra on 2 PEs: rank 0's peak
         * 118-130 MB against 133-138 without, bench/parallel.md run
         * 31). */
        mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD_MERGE);
#endif
        rc = par_wire_from_sub_pairs(&s, &min.own, size > 1 ? &ahead : NULL);
    }
    if (po->stats && write_row_json(po->stats, rank, size, &row))
        fprintf(stderr, "pdr mesh: PE %d: cannot write %s/table1-%d.json\n", rank, po->stats,
                rank);
    pr_buf rb = PR_BUF_INIT;
    size_t nmissing;
    if (!rc) {
        put_row(&rb, &row, &s.r.st);
        rc = rb.err ? PDR_ENOMEM : par_merge_put_missing(&rb, &s, &nmissing);
    }
    par_sub_free(&s);
    have_sub = 0;
    if (rc && !am_err) {
        fprintf(stderr, "pdr mesh: PE %d: cannot %s: %s\n", rank,
                rank ? "make its merge messages" : "take its own submesh for the merge",
                pdr_strerror(rc));
        fflush(stderr);
        _exit(PDR_EXIT_FAIL); /* the others would wait for its message */
    }
    void *all_rows = NULL;
    size_t *row_lens = NULL;
    if (!rc)
        rc = am_gather(am, rb.data, rb.len, &all_rows, &row_lens);
    pr_buf_free(&rb);
    /* Rank 0: the others' merge messages, each decoded in its handler. */
    while (!rc && rank == 0 && min.ndone < size - 1) {
        rc = am_poll(am);
        if (rc >= 0)
            rc = min.ndone < size - 1 ? am_idle(am, 0.25) : 0;
        if (rc > 0)
            rc = 0;
    }
    if (rc) {
        fprintf(stderr, "pdr mesh: PE %d: gathering the mesh failed: %s\n", rank,
                am_strerror(rc));
        goto done;
    }
    if (rank != 0) {
        status = PDR_EXIT_OK;
        goto done;
    }
    t_gathered = pdr_now();
    rows = pr_calloc((size_t)size, sizeof *rows);
    size_t *rests = pr_calloc((size_t)size, sizeof *rests);
    rc = rows && rests ? 0 : PDR_ENOMEM;
    const uint8_t *pr = all_rows;
    for (int k = 0; k < size && !rc; k++) {
        rc = get_row(pr, row_lens[k], &rows[k], &sum, &rests[k]);
        pr += row_lens[k];
    }
    if (!rc && min.stray) {
        fprintf(stderr, "pdr mesh: %d merge message%s from rank 0 itself, malformed, or a "
                "second time from a PE\n", min.stray, min.stray == 1 ? "" : "s");
        rc = PDR_EPARSE;
    }
    for (int k = 1; k < size && !rc; k++)
        if (min.pe[k].rc) {
            fprintf(stderr, "pdr mesh: PE %d's merge message: %s\n", k,
                    pdr_strerror(min.pe[k].rc));
            rc = min.pe[k].rc;
        }
    /* Every PE's pieces in order of PE, rank 0's own first, moved into
     * wall (the merge frees their tables as it goes; cleared below). */
    uint32_t nw = 1;
    for (int k = 1; k < size; k++)
        nw += min.pe[k].count;
    par_wire *wall = rc ? NULL : pr_malloc((size_t)nw * sizeof *wall);
    if (!rc && !wall)
        rc = PDR_ENOMEM;
    if (!rc) {
        uint32_t at = 0;
        wall[at++] = min.own;
        memset(&min.own, 0, sizeof min.own);
        for (int k = 1; k < size; k++)
            for (uint32_t i = 0; i < min.pe[k].count; i++) {
                wall[at++] = min.pe[k].w[i];
                memset(&min.pe[k].w[i], 0, sizeof min.pe[k].w[i]);
            }
    }
    uint64_t miss_s = 0, miss_f = 0;
    for (int k = 0; k < size && !rc; k++) {
        miss_s += rows[k].missing_segs;
        miss_f += rows[k].missing_facs;
    }
    par_merge_report rep;
    memset(&rep, 0, sizeof rep);
    double tm = pdr_now();
    /* The merge frees each piece's tables once it has taken them, but
     * then cannot count a fault in full (its careful run):
     * PDR_REF_CHECK keeps them for that. */
    if (!rc && (po->check_end || mo->ref.check_each_step))
        rc = par_merge_build_wires(wall, nw, &ahead, size > 1 ? 1 : 0, &c.p, &c.o.ref, &c.r,
                                   &rep);
    else if (!rc)
        rc = par_merge_build_wires_spent(wall, nw, &ahead, size > 1 ? 1 : 0, &c.p, &c.o.ref,
                                         &c.r, &rep);
    for (uint32_t k = 0; wall && k < nw; k++)
        par_wire_clear(&wall[k]);
    pr_free(wall);
    merge_in_free(&min);
    par_merge_ahead_free(&ahead);
    /* A subsegment or subfacet still missing on some PE (its split point
     * lay on a PE that did not know of it) goes into the merged mesh as
     * missing, for rank 0 to recover below. */
    size_t recovered = 0;
    int rc_missing = 0;
    pr = all_rows;
    for (int k = 0; k < size && !rc && !rc_missing; k++) {
        size_t n = 0;
        rc_missing = par_merge_add_missing(&c.r, pr + rests[k], row_lens[k] - rests[k], &n);
        if (rc_missing)
            fprintf(stderr, "pdr mesh: PE %d's list of missing pieces: %s\n", k,
                    pdr_strerror(rc_missing));
        recovered += n;
        pr += row_lens[k];
    }
    pr_free(rests);
    pr_free(all_rows);
    pr_free(row_lens);
    if (!rc && rc_missing) {
        rc = rc_missing;
        ref_free(&c.r);
        goto done;
    } else if (rc) {
        fprintf(stderr,
                "pdr mesh: the submeshes do not fit together (%s): %zu interface faces "
                "unmatched, %zu mismatched, %zu open faces, %zu non-manifold, %zu duplicate "
                "tetrahedra, %zu links not coming back, %zu faces misoriented, %zu with two "
                "markers\n",
                pdr_strerror(rc), rep.iface_unmatched, rep.iface_mismatch, rep.open_faces,
                rep.nonmanifold, rep.dup_tets, rep.bad_links, rep.misoriented,
                rep.marker_mismatch);
        goto done;
    }
    c.have_r = 1;
    c.refined = 1;
    c.r.st = sum;
    /* "vertices added" counts from the conforming mesh's vertices (v0,
     * mp_export); the merged mesh holds only those of the PEs'
     * tetrahedra (in the constrained mode not the corners of the box
     * around the domain, im.c), and they get its first numbers. */
    c.v0 = 1 + par_merge_vertices_below(&c.r.m, pr_gid_make(0, c.v0));
    /* When some PE may have passed on a wrong region or exterior flag, or
     * left a piece missing, rank 0 finishes the merged mesh itself
     * (par_merge_reclassify): a few sequential steps. */
    double t_cls = pdr_now();
    if (po->check_end) {
        size_t bad = ref_consistency(&c.r, stderr, 0);
        fprintf(stderr, "pdr mesh: the merged mesh, before rank 0 finishes it: %zu problem%s\n",
                bad, bad == 1 ? "" : "s");
    }
    size_t moved = 0, added = 0;
    uint64_t doubts = 0, elsewhere = 0;
    for (int k = 0; k < size; k++) {
        doubts += rows[k].region_doubts;
        elsewhere += rows[k].left_elsewhere;
    }
    /* The constrained mode: the merged mesh is carved as Mo was; faces
     * that a PE could not flip (next to its interface, or to another
     * cavity's tetrahedra) are flipped here, and whatever that leaves bad
     * is refined. */
    int cdt = c.o.ref.constrained != 0;
    if (cdt) {
        c.r.carved = 1;
        c.r.finishing = 1;
        /* What a PE gave up it may have given up for want of the other
         * PEs' tetrahedra (a split whose cavity reached them): tried
         * again here. */
        for (uint32_t t = 0; t < c.r.m.nslots; t++)
            c.r.m.flags[t] &= (uint16_t)~(REF_F_GIVEUP | REF_F_DEGENERATE | TM_F_QUEUED);
        rc = ref_cdt_restore(&c.r);
    }
    /* A PE may also pass on a wrong flag without a doubt (about one run
     * in 50 of cube-in-cube on 4 PEs with 32 parts and latency kept a
     * tetrahedron of the void): an unmarked face between inside and
     * outside tells, since the domain's boundary is marked. */
    if (!rc && !cdt && !doubts)
        doubts = rep.unmarked_known ? rep.unmarked_bounds : ref_unmarked_bounds(&c.r);
    if (!rc && !doubts && !recovered && !cdt && elsewhere)
        rc = par_merge_finish_left(&c.r, &moved, &added);
    else if (!rc && (doubts || recovered || elsewhere || cdt))
        rc = par_merge_reclassify(&c.r, recovered > 0, elsewhere > 0 || cdt, &moved, &added);
    if (!rc && (moved || recovered || elsewhere || added) && !c.o.quiet)
        printf("merge: %zu tetrahedra classified again (inside/outside or region), %zu "
               "missing pieces recovered (from %llu subsegments and %llu subfacets left on the "
               "PEs), %llu bad tetrahedra left by the PEs for a split on another PE, %zu points "
               "added at rank 0\n",
               moved, recovered, (unsigned long long)miss_s, (unsigned long long)miss_f,
               (unsigned long long)elsewhere, added);
    if (!rc) {
        /* Still missing after that: a hole in the boundary; nothing is
         * written. */
        size_t left_s, left_f;
        bd_count_missing(&c.r.bd, &left_s, &left_f);
        if (left_s || left_f) {
            fprintf(stderr,
                    "pdr mesh: %zu subsegments and %zu subfacets are still missing from the "
                    "merged mesh: it does not conform to the input; nothing written\n",
                    left_s, left_f);
            rc = PDR_ETOPOLOGY;
            goto done;
        }
    }
    if (rc) {
        if (c.r.recovery_stuck) {
            char why[512];
            mp_recovery_stuck_text(&c.r, 9, why, sizeof why);
            fprintf(stderr, "pdr mesh: finishing the merged mesh at rank 0: %s; nothing written\n",
                    why);
        } else if (c.r.stopped_below) {
            fprintf(stderr,
                    "pdr mesh: finishing the merged mesh at rank 0: a missing boundary piece "
                    "near (%.9g, %.9g, %.9g) %s; nothing written\n",
                    c.r.stop_at[0], c.r.stop_at[1], c.r.stop_at[2],
                    c.r.stop_hidden ? "has no split with a valid constrained cavity"
                                    : "would need a split closer than the resolution floor");
        } else {
            fprintf(stderr, "pdr mesh: finishing the merged mesh at rank 0 failed: %s\n",
                    pdr_strerror(rc));
        }
        goto done;
    }
    t_cls = pdr_now() - t_cls;
    double t_merged = pdr_now();
    /* The parallel stage, for the summary's rate: from Mo to the merged
     * mesh (distribution, refinement, gathering, merge). */
    c.sec[MP_REFINE] = t_merged - t_prep[0];
    if ((rc = mp_export(&c)))
        goto done;
    job_info ji = {rows,
                   size,
                   po->parts ? po->parts : (uint32_t)size,
                   mo_tets,
                   {t_start - t_prep[0], t_end - t_start, t_gathered - t_end, t_merged - tm, t_cls,
                    t_prep[1] - t_prep[0], t_prep[2] - t_prep[1], t_start - t_prep[2]}};
    rc = mp_conclude(&c, job_lines, &ji);
    status = rc ? PDR_EXIT_FAIL : PDR_EXIT_OK;
done:
    merge_in_free(&min);
    par_merge_ahead_free(&ahead);
    pr_free(rows);
    pr_free(j.data);
    if (have_sub)
        par_sub_free(&s);
    if (have_plc)
        plc_free(&p);
    mp_free(&c);
    int frc = am_finalize(&am);
    if (frc && status == PDR_EXIT_OK)
        status = PDR_EXIT_FAIL;
    return status;
}

/* ---------------------------------------------------------- launcher */

int mpar_launch(int argc, char **argv, const mpar_opts *po)
{
    /* am-run's argv: NAME -n P [--latency L] [--bandwidth B] [--sched S] [--cpu-bind M]
     * [--stats D]
     * -- /proc/self/exe mesh --parallel ARGS (without the launcher's own
     * options). */
    /* The launcher's options that are not the PEs' (--stats is both). */
    const struct {
        const char *name;
        size_t len;
        const char *value;
    } own[] = {{"--latency", 9, po->latency},
               {"--bandwidth", 11, po->bandwidth},
               {"--sched", 7, po->sched},
               {"--cpu-bind", 10, po->cpu_bind}};
    enum { NOWN = sizeof own / sizeof own[0] };
    /* room for the name, -n P, each option and its value, --stats D, the
     * four words before ARGS, ARGS and the NULL */
    char **av = pr_calloc((size_t)argc + 3 + 2 * NOWN + 2 + 4 + 1, sizeof *av);
    if (!av) {
        pdr_cli_error("mesh", "out of memory");
        return PDR_EXIT_FAIL;
    }
    char np[32];
    snprintf(np, sizeof np, "%d", po->nprocs);
    int n = 0;
    av[n++] = (char *)"pdr mesh";
    av[n++] = (char *)"-n";
    av[n++] = np;
    for (int k = 0; k < NOWN; k++)
        if (own[k].value) {
            av[n++] = (char *)own[k].name;
            av[n++] = (char *)own[k].value;
        }
    if (po->stats) {
        av[n++] = (char *)"--stats";
        av[n++] = (char *)po->stats;
    }
    av[n++] = (char *)"--";
    av[n++] = (char *)"/proc/self/exe";
    av[n++] = (char *)"mesh";
    av[n++] = (char *)"--parallel";
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        int skip = !strcmp(a, "-n") ? 2 : !strncmp(a, "-n", 2) ? 1 : 0;
        for (int k = 0; k < NOWN && !skip; k++)
            if (!strncmp(a, own[k].name, own[k].len))
                skip = a[own[k].len] == '\0' ? 2 : a[own[k].len] == '=' ? 1 : 0;
        if (skip) {
            i += skip - 1; /* the option's value too when it is the next word */
            continue;
        }
        av[n++] = argv[i];
    }
    av[n] = NULL;
    int rc = am_launch_main(n, av, "pdr mesh");
    pr_free(av);
    return rc;
}
