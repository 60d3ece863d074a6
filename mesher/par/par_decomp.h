/*
 * par/par_decomp.h -- the decomposition of the initial mesh Mo on rank 0
 * (DESIGN.md 5.1, prefix par_decomp_): partition by METIS, one submesh
 * message per PE, and the messages every PE needs besides its submesh:
 * the PLC (the input) and the refinement options.
 *
 * Partition. The live real tetrahedra of Mo -- exterior ones included,
 * they are part of the Delaunay tetrahedralization every PE refines --
 * are the vertices of the dual graph, joined across shared faces;
 * METIS_PartGraphKway cuts it into nparts parts (seeded, so a run is
 * repeatable). A ghost goes to the part of the real tetrahedron across its
 * hull face, so a cavity that crosses the hull finds both on one PE. Part
 * q is served by PE q % size: with nparts > size each PE holds several
 * parts (over-decomposition), and a PE's parts form one submesh.
 *
 * Global ids. Mo is built on rank 0, so vertex v >= 1 of Mo gets the gid
 * pr_gid_make(0, v); the infinite vertex is PAR_GID_INF. Rank 0's submesh
 * therefore continues its own counter at mo->m.nv (the message's
 * next_seq), every other PE at 1.
 *
 * PLC message (little-endian, records in order):
 *   u32 magic PAR_DECOMP_PLC_MAGIC ("PDRP"), u32 version 1
 *   str path, str vfile (wire strings; "" when a name is not one)
 *   u8 base (0 or 1), f64 planar_tol (finite, > 0)
 *   u32 nv, nv x {f64 x, y, z; i64 line}
 *   u8 has_vmarker, then i32 vmarker[nv] if 1
 *   u32 nvattr (<= 4096), f64 vattr[nv * nvattr]
 *   u32 nfacet, nfacet x {i32 marker; i64 line; u32 npoly, then npoly x
 *       {i64 line; u32 n (>= 1); u32 corner[n] (< nv)}; u32 nhole, then
 *       nhole x {f64 x, y, z; i64 line}}
 *   u32 nsegin, nsegin x {u32 a, b (< nv); i32 marker; i64 line}
 *   u32 nhole, nhole x {f64 x, y, z; i64 line}
 *   u32 nregion, nregion x {f64 x, y, z, attr, maxvol; i64 line}
 * Coordinates and region values are finite and lines >= 0. The receiver
 * rebuilds the PLC with plc_add_* and validates it as pdr mesh does.
 *
 * Options message: u32 magic PAR_DECOMP_OPTS_MAGIC ("PDRO"), u32 version
 * 2, f64 ratio, maxvol, maxedge, min_dihedral, seg_maxlen, fac_maxrad, rho
 * (finite), u8 use_region_maxvol (0/1), u8 order (enum ref_order), u8
 * constrained (0/1: Mo is a carved constrained Delaunay mesh, see
 * refine/refine_cdt.c). The progress callback does not travel.
 */
#ifndef PDR_PAR_DECOMP_H
#define PDR_PAR_DECOMP_H

#include <stddef.h>
#include <stdint.h>

#include "par/par_sub.h"
#include "plc/plc.h"
#include "pr.h"
#include "refine/refine.h"

#define PAR_DECOMP_PLC_MAGIC UINT32_C(0x50524450)  /* "PDRP" */
#define PAR_DECOMP_OPTS_MAGIC UINT32_C(0x4f524450) /* "PDRO" */

/* The result of par_decomp_run. Owns every array (par_decomp_free). */
typedef struct par_decomp {
    uint32_t size, nparts;
    uint32_t nslots;  /* slots of Mo when partitioned */
    uint32_t *part;   /* [nslots]: part of each live tetrahedron, ghosts
                         included; PAR_PE_NONE for a dead slot */
    pr_buf *msg;      /* [size]: PE k's submesh message (par_wire) */
    size_t edgecut;   /* faces between real tetrahedra of different parts */
    size_t *tets;     /* [size]: tetrahedra sent to each PE, ghosts included */
    size_t *ifaces;   /* [size]: interface faces of each PE */
} par_decomp;

/* Partitions Mo's live tetrahedra into nparts parts (see the top of this
 * file): part[t] for every slot t < mo->m.nslots (PAR_PE_NONE when dead).
 * seed seeds METIS. *edgecut (if not NULL) gets the number of faces
 * between real tetrahedra of different parts. Returns 0, PDR_EINVAL
 * (nparts == 0, no real tetrahedron), PDR_ELIMIT (a graph larger than
 * METIS's idx_t) or PDR_ENOMEM. */
int par_decomp_partition(const ref_mesher *mo, uint32_t nparts, int seed, uint32_t *part,
                         size_t *edgecut);

/* Appends PE pe's submesh message to b: the tetrahedra of the parts
 * q with q % size == pe (par_wire format, gids as above). Returns as
 * par_wire_encode. */
int par_decomp_encode_pe(pr_buf *b, const ref_mesher *mo, const uint32_t *part, uint32_t size,
                         uint32_t pe);

/* Partitions Mo (classified, as im_build leaves it) into nparts parts for
 * size PEs and encodes every PE's submesh. *out is the caller's, released
 * by par_decomp_free (also after an error). Returns as the two above. */
int par_decomp_run(const ref_mesher *mo, uint32_t size, uint32_t nparts, int seed,
                   par_decomp *out);
void par_decomp_free(par_decomp *d);

/* Appends the PLC message for p. Returns 0, PDR_ELIMIT (a count beyond
 * 32 bits) or PDR_ENOMEM. */
int par_decomp_plc_put(pr_buf *b, const plc *p);
/* Rebuilds the PLC of a message into out (which this initialises; the
 * caller frees it with plc_free, also after an error) and validates it.
 * Returns 0, PDR_EPARSE (malformed message), PDR_EGEOMETRY (the PLC is
 * not valid: messages in diag), or PDR_ENOMEM. */
int par_decomp_plc_decode(const void *msg, size_t len, plc *out, pdr_diag *diag);

/* Appends the options message for o. Returns 0, PDR_EINVAL (a value not
 * finite, an order or flag out of range) or PDR_ENOMEM. */
int par_decomp_opts_put(pr_buf *b, const ref_opts *o);
/* Decodes an options message into *out (progress callback NULL). Returns
 * 0 or PDR_EPARSE. */
int par_decomp_opts_decode(const void *msg, size_t len, ref_opts *out);

#endif /* PDR_PAR_DECOMP_H */
