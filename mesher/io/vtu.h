/*
 * io/vtu.h -- VTK XML UnstructuredGrid (.vtu) output (prefix vtu_), for
 * ParaView, VisIt and meshio.
 *
 * One piece with the tetrahedra (VTK cell type 10) only; boundary
 * triangles are not written (use .msh or .face for those). Cell data:
 * 'region' (Int32) when the mesh has region attributes, and
 * 'radius_edge' (Float64) when asked. Tetrahedra are written with positive
 * orientation ((p1-p0) . ((p2-p0) x (p3-p0)) > 0), swapping two corners of
 * those that are not. Binary output is inline base64 with a UInt64 size
 * header per array, encoded separately from the data as VTK itself does;
 * ASCII output is plain text. The file is written atomically.
 */
#ifndef PDR_IO_VTU_H
#define PDR_IO_VTU_H

#include "mesh/mesh_export.h"
#include "base/outfile.h"
#include "base/pdr_error.h"

typedef struct vtu_opts {
    int ascii;        /* nonzero: format="ascii" instead of base64 binary */
    int radius_edge;  /* nonzero: add the radius_edge cell array */
} vtu_opts;

/* Returns 0, PDR_EIO or PDR_ENOMEM with the reason in diag. With a set
 * (not NULL) the finished file waits in it for outset_commit
 * (base/outfile.h). */
int vtu_write(const mesh_export *m, const char *path, const vtu_opts *o, outset *set,
              pdr_diag *diag);

#endif /* PDR_IO_VTU_H */
