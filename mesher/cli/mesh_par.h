/*
 * cli/mesh_par.h -- the parallel driver of 'pdr mesh' (prefix mpar_): the
 * pipeline of cli/mesh_pipeline.h with the refinement done by P PEs.
 *
 *   rank 0:   mp_read, mp_initial_mesh (Mo, about --mo-size tetrahedra;
 *             without -a the sequential refinement up to --rank0-points
 *             points, and when that finishes the mesh rank 0 writes it
 *             and the PEs end at once),
 *             METIS partition into --parts parts (par/par_decomp.h), one
 *             message per PE with the PLC, the options and its submesh;
 *   every PE: builds its submesh, queues its bad tetrahedra, runs the
 *             parallel refinement (par/par_run.h) until libam's
 *             termination detection ends it, sends its submesh and its
 *             Table 1 row to rank 0 (and writes its part with
 *             --submeshes, its row as JSON with --stats);
 *   rank 0:   merges the submeshes into one mesh, checking that every
 *             interface face matches (par/par_merge.h), then mp_export
 *             and mp_conclude: the files, the Table 1 rows of the worst
 *             PE and of the average, the report.
 *
 * A failure on rank 0 before the refinement (bad input) is sent to every
 * PE, which then exits 1 without a message of its own; rank 0 has
 * printed the reason. A PE that dies makes the runtime end every other PE
 * with an error naming it.
 *
 * mpar_launch is 'pdr mesh -n P': it starts P copies of this program with
 * --parallel, through libam's launcher (the same code as am-run).
 */
#ifndef PDR_MESH_PAR_H
#define PDR_MESH_PAR_H

#include <stdint.h>

#include "cli/mesh_pipeline.h"

typedef struct mpar_opts {
    int nprocs;           /* -n P: launch P PEs (0: not a launcher) */
    int parallel;         /* --parallel: this process is one PE */
    uint32_t parts;       /* --parts N: parts of Mo (0: one per PE) */
    int max_threads;      /* --max-threads K: cavity threads per PE */
    uint64_t seed;        /* --seed S */
    const char *latency;  /* --latency (launcher) */
    const char *bandwidth;/* --bandwidth (launcher) */
    const char *sched;    /* --sched (launcher) */
    const char *cpu_bind; /* --cpu-bind (launcher) */
    const char *stats;    /* --stats DIR: per-PE JSON */
    int submeshes;        /* --submeshes: each PE writes its part */
    int work_clock;       /* --work-clock: enum mpar_clock */
    long rank0_points;    /* --rank0-points N: without -a or --mo-size, rank
                             0 refines alone until N points were added
                             (cli/mesh_par.c, refine_alone); 0: not at all */
    int check_end;        /* PDR_REF_CHECK=end: every PE checks its tables,
                             facet triangulations and links once, when its
                             refinement ends */
} mpar_opts;

/* The clock of the work times of Table 1 (par_run.h, cpu_clock). AUTO:
 * the CPU clock when the job has more PEs than this machine has cores
 * (each PE decides for itself). */
enum mpar_clock { MPAR_CLOCK_AUTO = 0, MPAR_CLOCK_WALL, MPAR_CLOCK_CPU };

/* The default of --rank0-points: some 4 10^5 tetrahedra (about 4 per
 * vertex on the CAD surfaces). Below that the parallel refinement of a
 * CAD surface did not pay on 2 PEs (bench/surfaces.md: cheese.off, 47,189
 * points, took 24-82 s on 2 PEs with a pause at 25,000 points against
 * 7-30 s sequentially; turbine.off, 11,866, 2.3-13.7 s with a pause at
 * 5,000 against 1.3-6.9 s). */
#define MPAR_RANK0_POINTS 100000L

/* Defaults: not parallel, one part per PE, 8 threads, seed 1, rank 0
 * alone up to MPAR_RANK0_POINTS points. */
void mpar_default_opts(mpar_opts *o);

/* Runs this PE of a parallel 'pdr mesh' (--parallel) with pipeline
 * options mo. Returns the exit status (0, 1). */
int mpar_run(const mp_opts *mo, const mpar_opts *po);

/* 'pdr mesh -n P': starts P PEs running argv with --parallel added and
 * the launcher's own options (-n, --latency, --bandwidth, --sched, --cpu-bind,
 * --stats) given
 * to the launcher. Returns the exit status. */
int mpar_launch(int argc, char **argv, const mpar_opts *po);

#endif /* PDR_MESH_PAR_H */
