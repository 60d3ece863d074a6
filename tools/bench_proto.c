/*
 * bench_proto -- submesh encode/decode throughput against memcpy.
 *
 *   tools/bench_proto [--cubes NX NY NZ] [--seconds S]
 *
 * Builds a synthetic submesh (tests/pr_sample.c: a grid of NX*NY*NZ cubes,
 * 6 tetrahedra each; default 26 x 26 x 25 = 101,400 tetrahedra), then
 * measures, on the same bytes and in the same run:
 *   memcpy       copying the encoded size between two warm buffers, the
 *                "memory speed" peer;
 *   alloc+copy   malloc, memcpy and free of that size, the peer for a
 *                decoder that hands out fresh memory;
 *   encode       pr_submesh_put into a reused pr_buf (with validation);
 *   decode       pr_submesh_decode + pr_submesh_free (with validation).
 * Each figure is the best of 5 trials of about S/5 seconds (default S = 2),
 * in MB/s of encoded bytes (1 MB = 10^6 bytes). Run it through
 * tools/bench-proto.
 */
#include "config.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/pdr_util.h"
#include "pr.h"
#include "../tests/pr_sample.h"

enum op { OP_MEMCPY, OP_ALLOC_COPY, OP_ENCODE, OP_DECODE, N_OPS };
static const char *const op_name[N_OPS] = {
    "memcpy (warm buffers)",
    "malloc+memcpy+free",
    "encode (pr_submesh_put)",
    "decode (pr_submesh_decode+free)",
};

static const pr_submesh *g_sm;
static const uint8_t *g_wire;
static size_t g_len;
static uint8_t *g_dst;
static pr_buf g_buf = PR_BUF_INIT;
static volatile uint8_t g_sink;

/* One repetition of op; returns 0 or a PR_E* code. */
static int run_once(enum op op)
{
    switch (op) {
    case OP_MEMCPY:
        memcpy(g_dst, g_wire, g_len);
        g_sink ^= g_dst[g_len / 2];
        return 0;
    case OP_ALLOC_COPY: {
        uint8_t *p = malloc(g_len);
        if (!p)
            return PR_ENOMEM;
        memcpy(p, g_wire, g_len);
        g_sink ^= p[g_len / 2];
        free(p);
        return 0;
    }
    case OP_ENCODE:
        pr_buf_reset(&g_buf);
        return pr_submesh_put(&g_buf, g_sm);
    case OP_DECODE: {
        pr_submesh *sm;
        int rc = pr_submesh_decode(g_wire, g_len, &sm);
        if (!rc)
            g_sink ^= (uint8_t)sm->tet.v[sm->tet.n / 2];
        pr_submesh_free(&sm);
        return rc;
    }
    default:
        return PR_EINVAL;
    }
}

/* Best seconds per repetition over 5 trials of about 'trial' seconds. */
static double measure(enum op op, double trial)
{
    double best = 1e30;
    for (int t = 0; t < 5; t++) {
        long reps = 0;
        double start = pdr_now(), now;
        do {
            if (run_once(op)) {
                fprintf(stderr, "bench_proto: %s failed\n", op_name[op]);
                exit(1);
            }
            reps++;
            now = pdr_now();
        } while (now - start < trial);
        double per = (now - start) / (double)reps;
        if (per < best)
            best = per;
    }
    return best;
}

int main(int argc, char **argv)
{
    uint32_t nx = 26, ny = 26, nz = 25;
    double seconds = 2;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--cubes") && i + 3 < argc) {
            nx = (uint32_t)atoi(argv[i + 1]);
            ny = (uint32_t)atoi(argv[i + 2]);
            nz = (uint32_t)atoi(argv[i + 3]);
            i += 3;
        } else if (!strcmp(argv[i], "--seconds") && i + 1 < argc) {
            seconds = atof(argv[++i]);
        } else {
            fprintf(stderr,
                    "usage: %s [--cubes NX NY NZ] [--seconds S]\n", argv[0]);
            return 2;
        }
    }
    if (nx < 1 || ny < 1 || nz < 1 || (uint64_t)6 * nx * ny * nz > PR_MAX_TETS ||
        !(seconds > 0)) {
        fprintf(stderr, "bench_proto: bad grid size or time\n");
        return 2;
    }

    pr_submesh sm;
    if (prs_grid_submesh(nx, ny, nz, &sm)) {
        fprintf(stderr, "bench_proto: out of memory\n");
        return 1;
    }
    pr_buf wire = PR_BUF_INIT;
    if (pr_submesh_put(&wire, &sm)) {
        fprintf(stderr, "bench_proto: cannot encode the submesh\n");
        return 1;
    }
    /* The benchmark measures a decoder that gets everything right. */
    pr_submesh *back;
    if (pr_submesh_decode(wire.data, wire.len, &back) ||
        !prs_submesh_equal(&sm, back)) {
        fprintf(stderr, "bench_proto: the submesh does not round-trip\n");
        return 1;
    }
    pr_submesh_free(&back);

    g_sm = &sm;
    g_wire = wire.data;
    g_len = wire.len;
    g_dst = malloc(g_len);
    if (!g_dst)
        return 1;
    memset(g_dst, 0, g_len);

    printf("submesh: %u tetrahedra, %u vertices, %u interface faces "
           "(%u x %u x %u cubes): %zu bytes encoded\n",
           sm.tet.n, sm.vert.n, sm.iface.n, nx, ny, nz, g_len);
    printf("%-34s %10s %10s %10s\n", "operation", "MB/s", "ms/op", "/memcpy");
    double t_memcpy = 0;
    for (int op = 0; op < N_OPS; op++) {
        double t = measure((enum op)op, seconds / 5);
        if (op == OP_MEMCPY)
            t_memcpy = t;
        printf("%-34s %10.0f %10.3f %10.2f\n", op_name[op], (double)g_len / t / 1e6,
               t * 1e3, t / t_memcpy);
    }
    printf("(best of 5 trials per line; /memcpy is time relative to memcpy, "
           "1.00 = memory speed)\n");

    free(g_dst);
    pr_buf_free(&g_buf);
    pr_buf_free(&wire);
    prs_submesh_free(&sm);
    return g_sink == 0x5a ? 0 : 0; /* g_sink only keeps the copies alive */
}
