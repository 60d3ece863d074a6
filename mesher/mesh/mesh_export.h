/*
 * mesh/mesh_export.h -- a neutral, read-only view of a finished tetrahedral
 * mesh, for the output writers (io_vtu, io_msh) and the quality measures,
 * so they do not depend on the mesh data structure of the kernel.
 *
 * The view borrows every array; the caller keeps them alive while it is
 * used. Vertex indices are 0-based. Tetrahedra may have either
 * orientation (the writers reorder them where a format wants one). The
 * triangles are the boundary faces to write (typically the subfacets, each
 * with its facet marker); they may be absent (nf = 0).
 */
#ifndef PDR_MESH_EXPORT_H
#define PDR_MESH_EXPORT_H

#include <stddef.h>
#include <stdint.h>

typedef struct mesh_export {
    size_t nv;
    const double (*xyz)[3];  /* nv vertex coordinates */
    size_t nt;
    const uint32_t (*tet)[4]; /* nt tetrahedra */
    const int *tet_region;   /* NULL or nt region attributes */
    size_t nf;
    const uint32_t (*tri)[3]; /* nf boundary triangles */
    const int *tri_marker;   /* NULL or nf facet markers */
} mesh_export;

/* The corners of tetrahedron t ordered with positive orientation,
 * (p1 - p0) . ((p2 - p0) x (p3 - p0)) >= 0, as VTK and Gmsh expect: two
 * corners are swapped when the floating-point volume is negative. */
static inline void mesh_export_tet(const mesh_export *m, size_t t, uint32_t v[4])
{
    for (int k = 0; k < 4; k++)
        v[k] = m->tet[t][k];
    const double *a = m->xyz[v[0]], *b = m->xyz[v[1]], *c = m->xyz[v[2]],
                 *d = m->xyz[v[3]];
    double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    double p[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    double q[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
    double det = u[0] * (p[1] * q[2] - p[2] * q[1]) - u[1] * (p[0] * q[2] - p[2] * q[0]) +
                 u[2] * (p[0] * q[1] - p[1] * q[0]);
    if (det < 0) {
        uint32_t tmp = v[2];
        v[2] = v[3];
        v[3] = tmp;
    }
}

#endif /* PDR_MESH_EXPORT_H */
