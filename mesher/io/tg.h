/*
 * io/tg.h -- TetGen .node/.ele/.face files (prefix tg_).
 *
 * Formats (TetGen manual, section 5.2):
 *   .node  first line: <#points> <dimension = 3> <#attributes> <markers 0|1>
 *          then one line per point: <index> <x> <y> <z> [attributes] [marker]
 *   .ele   first line: <#tetrahedra> <nodes per tet: 4 or 10> <#attributes>
 *          then <index> <n1> <n2> <n3> <n4> [6 more nodes] [attributes]
 *   .face  first line: <#faces> <markers 0|1>; then <index> <n1> <n2> <n3>
 * '#' starts a comment. Indices are consecutive from the first one, 0 or 1,
 * and .ele/.face node numbers use the .node file's first index. Tetrahedra
 * are positively oriented in the sense of pred_orient3d, faces of the hull
 * are oriented with the outside on their positive side (TetGen does the
 * same).
 *
 * Readers report every problem as "file:line: ..." in a pdr_diag and
 * return PDR_EPARSE/PDR_EIO/PDR_ENOMEM; writers write atomically (base/outfile.h),
 * so a failed run leaves no partial file and keeps an older one intact.
 */
#ifndef PDR_IO_TETGEN_H
#define PDR_IO_TETGEN_H

#include <stddef.h>
#include <stdio.h>
#include <stdint.h>

#include "mesh/mesh_export.h"
#include "base/outfile.h"
#include "base/pdr_error.h"
#include "mesh/tm.h"

typedef struct tg_nodes {
    size_t n;      /* points */
    long first;    /* index of the first point: 0 or 1 */
    int nattr;     /* attributes per point */
    int markers;   /* 1 if each point has a boundary marker */
    double *xyz;   /* owned, 3n */
    double *attr;  /* owned, n*nattr, NULL if nattr == 0 */
    long *marker;  /* owned, n, NULL if !markers */
} tg_nodes;

/* Reads a .node file; the caller owns *out (tg_nodes_free). */
int tg_read_node(const char *path, tg_nodes *out, pdr_diag *diag);
/* The same from an open stream (not closed); path names it in messages. */
int tg_read_node_stream(FILE *f, const char *path, tg_nodes *out, pdr_diag *diag);
void tg_nodes_free(tg_nodes *nodes);
/* The writers below write path atomically (base/outfile.h); with a set
 * (not NULL) the finished file waits in it for outset_commit. */
int tg_write_node(const char *path, const tg_nodes *nodes, outset *set, pdr_diag *diag);

/* Reads the corner nodes of a .ele file for 'nnodes' points numbered from
 * 'first'. *tets (owned by the caller, pr_free()) gets 4 point numbers per
 * tetrahedron, 0-based. */
int tg_read_ele(const char *path, size_t nnodes, long first, uint32_t **tets, size_t *ntets,
                pdr_diag *diag);

/* Writes the live real tetrahedra of m; mesh vertex v is point o-1, written
 * as o - 1 + first, where o = gid[v] if m has global ids, else v. */
int tg_write_ele(const char *path, const tm_mesh *m, long first, outset *set,
                 pdr_diag *diag);
/* Writes the tetrahedra of a mesh_export view, vertex i written as
 * i + first, with one attribute per tetrahedron (the region attribute)
 * when attr is not NULL. */
int tg_write_ele_view(const char *path, const mesh_export *m, const double *attr, long first,
                      outset *set, pdr_diag *diag);
/* Writes the convex hull faces (the real faces of ghosts) and the domain
 * boundary faces of m. */
int tg_write_face(const char *path, const tm_mesh *m, long first, outset *set,
                  pdr_diag *diag);

#endif /* PDR_IO_TETGEN_H */
