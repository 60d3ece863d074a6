/*
 * io/msh.h -- Gmsh .msh 4.1 ASCII output (prefix msh_).
 *
 * Layout: $MeshFormat 4.1 0 8; $Entities with one surface entity per
 * distinct facet marker of the boundary triangles and one volume entity
 * per distinct region attribute (a single volume entity when the mesh has
 * none); each entity carries its marker/attribute as a physical tag when
 * that is positive (Gmsh physical tags must be). Entity tags are 1, 2, ...
 * in increasing marker order. $Nodes is one block of all vertices,
 * classified on the first volume entity (tags 1..nv, vertex i has tag
 * i + 1). $Elements has one block of triangles (type 2) per surface entity,
 * then one block of tetrahedra (type 4) per volume entity; element tags run
 * 1, 2, ... in that order. Tetrahedra are written with positive orientation
 * as Gmsh expects. Bounding boxes are those of the entity's elements;
 * bounding-entity lists are empty (the mesh is discrete). The file is
 * written atomically.
 */
#ifndef PDR_IO_MSH_H
#define PDR_IO_MSH_H

#include "mesh/mesh_export.h"
#include "base/outfile.h"
#include "base/pdr_error.h"

/* Returns 0, PDR_EIO or PDR_ENOMEM with the reason in diag. With a set
 * (not NULL) the finished file waits in it for outset_commit
 * (base/outfile.h). */
int msh_write(const mesh_export *m, const char *path, outset *set, pdr_diag *diag);

#endif /* PDR_IO_MSH_H */
