/*
 * mesh_out_tool.c -- test helper (not installed): builds a structured
 * tetrahedral mesh of the unit cube (n^3 cells, each cut into 6
 * tetrahedra around its main diagonal, alternate cells mirrored so that
 * half the tetrahedra are negatively oriented), with its boundary
 * triangles (marker = side 1..6) and two regions (x < 1/2: 1, else 2),
 * and writes it with the output writers:
 *
 *   mesh_out_tool N OUT      writes OUT.vtu (binary), OUT-ascii.vtu,
 *                            OUT.msh, OUT.face (1-based), and prints
 *                            counts and checksums
 *   mesh_out_tool N -q       prints the quality statistics and histograms
 *   mesh_out_tool N -p PNG   plots the dihedral distribution to PNG
 *
 * The checksums are defined so that a reader can recompute them from what
 * it reads, whatever corner order it gets: see tests/output-meshio.sh.
 */
#include "config.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io/face.h"
#include "io/msh.h"
#include "io/vtu.h"
#include "mesh/mesh_export.h"
#include "check/ql.h"

/* The 6 tetrahedra of a cube around its diagonal 0-7 (corners x + 2y + 4z). */
static const int kuhn[6][4] = {{0, 1, 3, 7}, {0, 1, 5, 7}, {0, 2, 3, 7},
                               {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 4, 6, 7}};

static int cmp_u32(const void *x, const void *y)
{
    uint32_t a = *(const uint32_t *)x, b = *(const uint32_t *)y;
    return a < b ? -1 : a > b;
}

int main(int argc, char **argv)
{
    if (argc != 3 && argc != 4) {
        fprintf(stderr, "usage: mesh_out_tool N OUT | N -q | N -p PNG\n");
        return 2;
    }
    int n = atoi(argv[1]);
    if (n < 1 || n > 64)
        return 2;
    size_t n1 = (size_t)n + 1, nv = n1 * n1 * n1, nt = 6 * (size_t)n * n * n;
    size_t nf = 6 * 2 * (size_t)n * n;
    double(*xyz)[3] = malloc(nv * sizeof *xyz);
    uint32_t(*tet)[4] = malloc(nt * sizeof *tet);
    uint32_t(*tri)[3] = malloc(nf * sizeof *tri);
    int *reg = malloc(nt * sizeof *reg), *mark = malloc(nf * sizeof *mark);
    if (!xyz || !tet || !tri || !reg || !mark)
        return 99;
#define VID(i, j, k) ((uint32_t)(((size_t)(k) * n1 + (size_t)(j)) * n1 + (size_t)(i)))
    for (size_t k = 0; k < n1; k++)
        for (size_t j = 0; j < n1; j++)
            for (size_t i = 0; i < n1; i++) {
                double *x = xyz[VID(i, j, k)];
                x[0] = (double)i / n;
                x[1] = (double)j / n;
                x[2] = (double)k / n;
            }
    size_t t = 0;
    for (int k = 0; k < n; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++)
                for (int e = 0; e < 6; e++) {
                    for (int c = 0; c < 4; c++) {
                        int q = kuhn[e][c];
                        tet[t][c] = VID(i + (q & 1), j + (q >> 1 & 1), k + (q >> 2 & 1));
                    }
                    if ((i + j + k) % 2) { /* mix both orientations */
                        uint32_t s = tet[t][0];
                        tet[t][0] = tet[t][1];
                        tet[t][1] = s;
                    }
                    reg[t] = 2 * i < n ? 1 : 2;
                    t++;
                }
    /* Boundary: each boundary square split along the diagonal that the
     * cells' tetrahedra use (corner 0 to the opposite corner). */
    size_t f = 0;
    for (int side = 0; side < 6; side++) {
        int ax = side / 2, hi = side % 2;
        for (int b = 0; b < n; b++)
            for (int a = 0; a < n; a++) {
                uint32_t c[4];
                for (int q = 0; q < 4; q++) {
                    int p[3];
                    p[ax] = hi ? n : 0;
                    p[(ax + 1) % 3] = a + (q & 1);
                    p[(ax + 2) % 3] = b + (q >> 1);
                    c[q] = VID(p[0], p[1], p[2]);
                }
                /* corners: 0 (a,b) 1 (a+1,b) 2 (a,b+1) 3 (a+1,b+1) */
                tri[f][0] = c[0], tri[f][1] = c[1], tri[f][2] = c[3];
                mark[f++] = side + 1;
                tri[f][0] = c[0], tri[f][1] = c[3], tri[f][2] = c[2];
                mark[f++] = side + 1;
            }
    }
    mesh_export m = {nv, (const double(*)[3])xyz, nt, (const uint32_t(*)[4])tet, reg,
                     nf, (const uint32_t(*)[3])tri, mark};
    pdr_diag d = {0};
    int rc = 0;
    if (!strcmp(argv[2], "-q")) {
        ql_stats s;
        rc = ql_mesh_stats(&m, 2.0, &s);
        if (!rc)
            ql_print(&s, stdout, 5);
    } else if (!strcmp(argv[2], "-p") && argc == 4) {
        ql_stats s;
        rc = ql_mesh_stats(&m, 2.0, &s);
        if (!rc)
            rc = ql_plot_png(&s, argv[3], "Kuhn cube", 5, &d);
    } else {
        char path[4096];
        vtu_opts bin = {0, 1}, asc = {1, 0};
        snprintf(path, sizeof path, "%s.vtu", argv[2]);
        rc = vtu_write(&m, path, &bin, NULL, &d);
        snprintf(path, sizeof path, "%s-ascii.vtu", argv[2]);
        if (!rc)
            rc = vtu_write(&m, path, &asc, NULL, &d);
        snprintf(path, sizeof path, "%s.msh", argv[2]);
        if (!rc)
            rc = msh_write(&m, path, NULL, &d);
        snprintf(path, sizeof path, "%s.face", argv[2]);
        if (!rc)
            rc = face_write(&m, path, 1, NULL, &d);
        /* Checksums a reader can recompute: coordinates weighted by axis,
         * and each tetrahedron's sorted corners hashed into a sum, so the
         * corner order written does not matter. */
        double csum = 0;
        for (size_t v = 0; v < nv; v++)
            csum += xyz[v][0] + 2 * xyz[v][1] + 3 * xyz[v][2];
        unsigned long long tsum = 0, fsum = 0, rsum = 0, msum = 0;
        for (size_t i = 0; i < nt; i++) {
            uint32_t s[4];
            memcpy(s, tet[i], sizeof s);
            qsort(s, 4, sizeof *s, cmp_u32);
            tsum += s[0] + 3ull * s[1] + 7ull * s[2] + 13ull * s[3];
            rsum += (unsigned long long)reg[i];
        }
        for (size_t i = 0; i < nf; i++) {
            uint32_t s[3];
            memcpy(s, tri[i], sizeof s);
            qsort(s, 3, sizeof *s, cmp_u32);
            fsum += s[0] + 3ull * s[1] + 7ull * s[2];
            msum += (unsigned long long)mark[i];
        }
        printf("points %zu tetra %zu triangles %zu coordsum %.6f tetsum %llu trisum %llu "
               "regionsum %llu markersum %llu\n",
               nv, nt, nf, csum, tsum, fsum, rsum, msum);
    }
    pdr_diag_print(&d, stderr);
    pdr_diag_free(&d);
    free(xyz);
    free(tet);
    free(tri);
    free(reg);
    free(mark);
    return rc ? 1 : 0;
}
