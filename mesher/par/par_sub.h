/*
 * par/par_sub.h -- one PE's submesh in the parallel refinement (prefix
 * par_sub_): the local part of the distributed mesh, with global vertex
 * ids and the interface faces to other PEs.
 *
 * ------------------------------------------------------------ invariants
 * The local mesh is a ref_mesher (refine/refine.h) whose tm_mesh has the
 * optional arrays TM_FEAT_GIDS | TM_FEAT_MARKERS | TM_FEAT_LOCKS. Every
 * live tetrahedron in it is owned by this PE; ghost tetrahedra (the
 * infinite vertex, local vertex 0) and exterior tetrahedra are partitioned
 * like the others, so the union over all PEs is the whole Delaunay
 * tetrahedralization that the sequential mesher would hold.
 *
 * Vertices. gid[v] is the vertex's global id (proto's pr_gid_make(rank,
 * seq), seq >= 1); the infinite vertex is local vertex 0 with gid
 * PAR_GID_INF (0) on every PE. A vertex is replicated on every PE holding
 * a tetrahedron that uses it; vmap maps gid -> local vertex for every
 * vertex this PE has ever held (a vertex is never removed from a PE's
 * arrays, only unused). The refinement's per-vertex data (bd.vkind, vfeat,
 * vrins) travels with the vertex.
 *
 * Interface faces. A face whose neighbour lives on another PE is linked
 * TM_LINK_REMOTE(k) on this side, k indexing ifc[]: ifc[k] holds the
 * face's key (its three vertex gids in ascending order), the PE on the
 * other side, and the local side (tm_mklink(tet, face)), so that
 * tets[ifc[k].local >> 2].n[ifc[k].local & 3] == TM_LINK_REMOTE(k). The
 * same face seen from the other PE has the same key. ifc_map maps the
 * 64-bit hash of a key to k (a multimap: compare the key). Free entries
 * have pe == PAR_PE_NONE and are chained through .local.
 *
 * Subsegments and subfacets. r.bd holds every subsegment that is an edge,
 * and every subfacet that is a face, of a local tetrahedron (possibly
 * more: an entry whose tetrahedra all moved away stays until it is met
 * again, and is then recognised as not local).
 */
#ifndef PDR_PAR_SUB_H
#define PDR_PAR_SUB_H

#include <stddef.h>
#include <stdint.h>

#include "base/hmap.h"
#include "refine/refine.h"

#define PAR_GID_INF UINT64_C(0)
#define PAR_PE_NONE UINT32_MAX

typedef struct par_iface {
    uint64_t key[3]; /* vertex gids, ascending */
    uint32_t pe;     /* PE on the other side; PAR_PE_NONE when free */
    tm_link local;   /* this side: tm_mklink(tet, face); next free when free */
} par_iface;

typedef struct par_sub {
    ref_mesher r;      /* the local mesh and the refinement state; owned */
    uint32_t rank, size;
    uint64_t next_seq; /* counter of the next vertex this PE creates */
    hmap vmap;         /* gid -> local vertex (gid 0 not stored), but for
                          the vertices this PE makes: */
    uint32_t *own_v;   /* own_v[seq - own_base]: the local vertex of this
                          PE's gid with counter seq >= own_base (TM_NONE:
                          none); a dense array where most gids are */
    size_t own_n, own_cap;
    uint64_t own_base; /* next_seq when the submesh was made */
    par_iface *ifc;
    size_t nifc, cap_ifc; /* slots used (live + free), capacity */
    uint32_t ifc_free;    /* free list head, PAR_PE_NONE if empty */
    size_t live_ifc;
    hmap ifc_map;      /* hash of key -> ifc index */
} par_sub;

/* Sorts three gids into a face key. */
static inline void par_key_sort(uint64_t key[3])
{
    uint64_t x;
    if (key[0] > key[1])
        x = key[0], key[0] = key[1], key[1] = x;
    if (key[1] > key[2])
        x = key[1], key[1] = key[2], key[2] = x;
    if (key[0] > key[1])
        x = key[0], key[0] = key[1], key[1] = x;
}

static inline int par_key_eq(const uint64_t a[3], const uint64_t b[3])
{
    return a[0] == b[0] && a[1] == b[1] && a[2] == b[2];
}

/* Hash of a face key (never 0, as hmap requires). */
uint64_t par_key_hash(const uint64_t key[3]);
/* The key of face i of tetrahedron t (gids sorted). */
void par_face_key(const par_sub *s, uint32_t t, int i, uint64_t key[3]);

/* Prepares an empty submesh for plc p (validated, must outlive s) with
 * refinement options o. Returns 0 or PDR_ENOMEM. */
int par_sub_init(par_sub *s, const plc *p, const ref_opts *o, uint32_t rank, uint32_t size);
void par_sub_free(par_sub *s);

/* Adds a vertex with global id gid (or returns the one this PE has):
 * *out gets the local number. New vertices get bd data kind/feat/rins.
 * Returns 0, PDR_ENOMEM or PDR_ELIMIT. */
int par_sub_vertex(par_sub *s, uint64_t gid, const double xyz[3], uint8_t kind,
                   uint32_t feat, float rins, uint32_t *out);
/* Local vertex of gid, or TM_NONE. */
uint32_t par_sub_find_vertex(const par_sub *s, uint64_t gid);
/* Records that gid is local vertex v. Returns 0 or PDR_ENOMEM. */
int par_sub_map_vertex(par_sub *s, uint64_t gid, uint32_t v);
/* A new global id for a vertex this PE creates. */
uint64_t par_sub_new_gid(par_sub *s);

/* Links face i of tetrahedron t to PE pe across the interface: a new
 * ifc entry, t's link set to TM_LINK_REMOTE(k). Returns 0 or PDR_ENOMEM /
 * PDR_ELIMIT. */
int par_sub_add_iface(par_sub *s, uint32_t t, int i, uint32_t pe);
/* The interface entry with this key, or PAR_PE_NONE. */
uint32_t par_sub_find_iface(const par_sub *s, const uint64_t key[3]);
/* Removes entry k (its local link is left as it is: the caller relinks or
 * deletes that face). */
void par_sub_drop_iface(par_sub *s, uint32_t k);

#endif /* PDR_PAR_SUB_H */
