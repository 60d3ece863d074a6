/*
 * io/face.h -- TetGen .face output of a mesh's boundary triangles (prefix
 * face_), over the neutral mesh_export view.
 *
 * Format (TetGen 1.5): a header "<#faces> <markers 0|1>", then one line per
 * triangle "<number> <v1> <v2> <v3> [marker]". Numbers and vertex indices
 * start at 'base', which must be the first index of the .node file written
 * next to it (TetGen's own files use 1; TetGen decides from the .node).
 * The kernel's io_tetgen writes .node and .ele; this writer exists because
 * that module had no .face writer when the output formats were written.
 * Written atomically.
 */
#ifndef PDR_IO_FACE_H
#define PDR_IO_FACE_H

#include <stddef.h>
#include <stdint.h>

#include "mesh/mesh_export.h"
#include "base/outfile.h"
#include "base/pdr_error.h"

/* Returns 0, PDR_EIO or PDR_ENOMEM with the reason in diag. With a set
 * (not NULL) the finished file waits in it for outset_commit
 * (base/outfile.h). */
int face_write(const mesh_export *m, const char *path, int base, outset *set,
               pdr_diag *diag);

/* Reads a .face file whose vertex numbers refer to nnodes points numbered
 * from 'first' (the .node file's first index). *tri gets 3 0-based point
 * numbers per face and *marker one marker per face, or NULL when the file
 * has none; the caller frees both. Returns 0, or PDR_EIO/PDR_EPARSE/
 * PDR_ENOMEM with "file:line: ..." messages in diag. */
int face_read(const char *path, size_t nnodes, long first, uint32_t **tri, int **marker,
              size_t *nface, pdr_diag *diag);

#endif /* PDR_IO_FACE_H */
