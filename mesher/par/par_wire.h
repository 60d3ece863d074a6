/*
 * par/par_wire.h -- the wire form of a submesh as the parallel refinement
 * needs it (prefix par_wire_): proto's submesh message (pr_submesh: the
 * vertices with gids and coordinates, the tetrahedra with vertex indices,
 * face markers and subsegment bits, the interface faces) followed by what
 * the refinement keeps beside the tetrahedralization: per vertex its bd
 * data, per tetrahedron its flags and region, and the subsegments and
 * subfacets lying on the tetrahedra sent.
 *
 * ----------------------------------------------------------------- format
 * All integers little-endian, written field by field (proto/pr.h):
 *
 *   u32 magic PAR_WIRE_MAGIC ("PDRW"), u32 version PAR_WIRE_VERSION
 *   u64 next_seq         counter the receiving PE continues its gids from
 *   u32 sublen, then sublen bytes: a pr_submesh message (type 0x03)
 *   u32 nv  (== the submesh's vertex count)
 *       u8  vkind[nv]    BD_V_* (<= BD_V_FACET)
 *       u32 vfeat[nv]    PLC vertex / plc.segs / facet index by kind
 *                        (checked for BD_V_INPUT, _SEGMENT, _FACET)
 *       u32 vrins[nv]    float bits of the insertion radius, >= 0 or +inf
 *   u32 nt  (== the submesh's tetrahedron count)
 *       u16 tflags[nt]   only PAR_WIRE_TFLAGS bits
 *       u16 region[nt]   region index + 1, 0 for none; <= plc.nregion
 *       u32 link[4 nt]   per face 4t+i, what is across it (below)
 *   u32 nseg, then u32 a[nseg], u32 b[nseg], u32 seg[nseg], u16 flags[nseg]
 *                        vertex indices (distinct, not the infinite
 *                        vertex), input segment < plc.nseg, flags only
 *                        PAR_WIRE_BDFLAGS
 *   u32 nfac, then u32 v[3 nfac] (three per subfacet, in the bd table's
 *                        orientation), u32 facet[nfac] (< plc.nfacet),
 *                        u16 flags[nfac]
 *
 * The submesh's face markers are -1 or the facet index (the mesh's marker
 * minus one) and its n_facets is plc.nfacet. The infinite vertex travels
 * as gid PAR_GID_INF (0) with coordinates 0 (proto wants finite ones); as
 * the smallest gid it is vertex 0 of the table whenever a ghost is sent.
 * Vertex flags of the vertex table are 0 (reserved). A face whose
 * neighbour is neither sent with it nor named as an interface face
 * arrives with no neighbour (TM_LINK_NONE).
 *
 * Links. link[4t+i] says what lies across face i of tetrahedron t:
 * 4u+j when it is face j of tetrahedron u of this message, as tm_mesh
 * links are (tm_mklink); PAR_WIRE_LINK_IFACE when the face is in the
 * interface table; PAR_WIRE_LINK_NONE when there is nothing. They let a
 * receiver take the tetrahedra as they are, without matching every face
 * by its vertices again: the merge at rank 0 only has to match the
 * interface faces, a few percent of the faces. The decoder refuses (as
 * PDR_EPARSE) a link to a tetrahedron not in the message, a tetrahedron
 * linked to itself, and an IFACE code on a face the interface table does
 * not list, or a listed face without it; so a receiver can follow every
 * link without a range check. Whether a link comes back (u's link j is
 * 4t+i) and joins the same triangle seen from its two sides, with one
 * marker, is the receiver's check (par_wire_build refuses, par_merge_build
 * counts): it reads the other side of every face, a cache miss each in a
 * large message, which a receiver pays once for all of these.
 *
 * Every decoder checks each length and count against the bytes left
 * before reading (pr_reader), and every index and value against its range;
 * a malformed message is PDR_EPARSE, never an out-of-bounds access.
 */
#ifndef PDR_PAR_WIRE_H
#define PDR_PAR_WIRE_H

#include <stddef.h>
#include <stdint.h>

#include "par/par_sub.h"
#include "pr.h"
#include "refine/refine.h"

#define PAR_WIRE_MAGIC UINT32_C(0x57524450) /* "PDRW" */
/* Version 2 added the links. */
#define PAR_WIRE_VERSION 2u
/* link codes that are not a face 4u+j (which is below 4 * PR_MAX_TETS) */
#define PAR_WIRE_LINK_IFACE UINT32_C(0xFFFFFFFE)
#define PAR_WIRE_LINK_NONE UINT32_C(0xFFFFFFFF)
/* Tetrahedron flags that travel (the face and edge bits travel as the
 * submesh's markers and subsegment masks). */
#define PAR_WIRE_TFLAGS ((uint16_t)(REF_F_EXTERIOR | REF_F_GIVEUP | REF_F_DEGENERATE | TM_F_QUEUED))
/* Subsegment and subfacet flags that travel (dead ones are not sent). */
#define PAR_WIRE_BDFLAGS ((uint16_t)(BD_F_MISSING | BD_F_QUEUED | BD_F_TOLERATED))

/* What to send: tetrahedra of a ref_mesher, with the gids of its
 * vertices and, per face, where its neighbour lives. Borrows everything. */
typedef struct par_wire_src {
    const ref_mesher *r;
    const uint64_t *gid;     /* per vertex of r->m; gid[0] = PAR_GID_INF */
    const uint32_t *tets;    /* nt live slots of r->m, each once */
    uint32_t nt;
    const uint32_t *face_pe; /* [4 nt]: for face i of tets[k], face_pe[4k+i]
                                is the PE across it, or PAR_PE_NONE when
                                the neighbour is sent too (or there is none);
                                NULL: see ifc */
    uint32_t part, rank, size; /* as in pr_submesh */
    uint64_t next_seq;       /* the receiver's next vertex counter */
    const par_iface *ifc;    /* without face_pe: a face linked
                                TM_LINK_REMOTE(j) has ifc[j].pe across it
                                (a par_sub's table), any other none */
    size_t nifc;
} par_wire_src;

/* A decoded message. Owns every array (par_wire_clear) but, from
 * par_wire_decode, the per-tetrahedron ones of the extension, which it
 * reads in place in the message, little-endian (par_wire_tflags, _region,
 * _link): 20 bytes per tetrahedron, which for a merge message of 10^6
 * tetrahedra took longer to copy (into fresh pages) than to read twice.
 * From par_wire_decode_own and par_wire_from_sub they are in own. */
typedef struct par_wire {
    pr_submesh *sm;     /* vertex table, tetrahedron table, interface faces */
    uint64_t next_seq;
    uint8_t *vkind;     /* [sm->vert.n] */
    uint32_t *vfeat;
    float *vrins;
    const uint8_t *tflags_le; /* u16 [sm->tet.n], in the message */
    const uint8_t *region_le; /* u16 [sm->tet.n], in the message */
    const uint8_t *link_le;   /* u32 [4 sm->tet.n], in the message */
    uint8_t *own;       /* NULL, or the block of the three arrays above */
    uint32_t nseg;
    uint32_t *seg_v;    /* [2 nseg] */
    uint32_t *seg_id;   /* [nseg] */
    uint16_t *seg_flags;
    uint32_t nfac;
    uint32_t *fac_v;    /* [3 nfac] */
    uint32_t *fac_id;
    uint16_t *fac_flags;
} par_wire;

/* The merge's hashes of vertex sets (par/par_merge.c, steps 4-6): a key
 * per vertex, one mix of its gid, summed over a face's vertices (so that
 * their order does not matter) and mixed again. */
static inline uint64_t par_wire_mix(uint64_t x)
{
    x *= UINT64_C(0x9E3779B97F4A7C15);
    x ^= x >> 32;
    x *= UINT64_C(0xD6E8FEB86659FD93);
    x ^= x >> 32;
    return x;
}
static inline uint64_t par_wire_vkey(uint64_t gid)
{
    return par_wire_mix(gid + UINT64_C(0x2545F4914F6CDD1D));
}
static inline uint64_t par_wire_face_hash(uint64_t ka, uint64_t kb, uint64_t kc)
{
    return par_wire_mix(ka + kb + kc + 1);
}

/* What the merge's step 4 finds in one message (par/par_merge.h,
 * par_merge_check_ahead): each pair of faces linked within it, seen from
 * its lower face 4t+i < 4u+j, checked as the merge checks it. Owns hash. */
typedef struct par_wire_pairs {
    uint32_t tets;                 /* the message's tetrahedra (a check) */
    size_t up, down;               /* links up (to a higher face) and down */
    size_t bad_links;              /* links up whose other side does not
                                      link back */
    size_t misoriented;            /* pairs not one triangle seen from its
                                      two sides */
    size_t marker_mismatch;        /* pairs with two markers */
    int suspect;                   /* a pair with one vertex opposite on both
                                      sides (two tetrahedra, one vertex set) */
    size_t unmarked;               /* pairs with one side interior (not
                                      exterior, not a ghost) whose face is
                                      unmarked there (ref_unmarked_bounds) */
    uint64_t *hash;                /* [nhash] each pair's face hash, in face
                                      order (par_wire_face_hash of gids) */
    size_t nhash;
} par_wire_pairs;

void par_wire_pairs_free(par_wire_pairs *a);

/* Appends the message for src to b. A face whose neighbour is sent too
 * gets its link; one with a PE in face_pe gets PAR_WIRE_LINK_IFACE; any
 * other PAR_WIRE_LINK_NONE. Returns 0, PDR_EINVAL (a bad slot, gid or PE,
 * a face_pe given for a face whose neighbour is sent too), PDR_ETOPOLOGY
 * (a marked edge or face of a sent tetrahedron has no live subsegment or
 * subfacet in r->bd), PDR_ELIMIT (more than proto's table limits) or
 * PDR_ENOMEM; b is unchanged on error except for its error state. */
int par_wire_encode(pr_buf *b, const par_wire_src *src);

/* Decodes msg[0..len) for PLC p (validated): *out gets the content, which
 * the caller releases with par_wire_clear (also after an error: out is
 * then empty); msg must outlive *out, which reads parts of it in place.
 * Returns 0, PDR_EPARSE (malformed: truncated, trailing bytes, a count or
 * value out of range) or PDR_ENOMEM. */
int par_wire_decode(const void *msg, size_t len, const plc *p, par_wire *out);
void par_wire_clear(par_wire *w);
/* Free w's vertex table (gids, coordinates, flags, kinds, features,
 * insertion radii), or its tetrahedron table with the extension's
 * per-tetrahedron arrays when w owns them (own), keeping the counts
 * sm->vert.n and sm->tet.n; w is good then only for par_wire_clear and
 * what reads neither (the merge, see par_merge_build_wires_spent). */
void par_wire_drop_vertices(par_wire *w);
void par_wire_drop_tets(par_wire *w);

/* par_wire_decode, then the per-tetrahedron arrays of the extension
 * copied into out->own (20 bytes per tetrahedron, against the whole
 * message): msg need not outlive *out. For a receiver that must let the
 * message go (an active message's handler). Returns as par_wire_decode. */
int par_wire_decode_own(const void *msg, size_t len, const plc *p, par_wire *out);

/* The decoded form of the message par_wire_encode_sub would make of s,
 * built in memory without the bytes (no message to write, check and
 * read): the merge of rank 0's own submesh. Every field equals what
 * par_wire_decode gives for that message (test_par compares them); out
 * borrows nothing from s, which may be freed next. Returns as
 * par_wire_encode_sub; out is empty on error. */
int par_wire_from_sub(const par_sub *s, par_wire *out);

/* par_wire_from_sub, and with pairs not NULL the pairs of out checked on
 * the way, from s's mesh, where the two sides of a face lie closer than in
 * the message's tables: *pairs gets what par_merge_check_ahead(out)
 * would (test_par compares them), empty on error. */
int par_wire_from_sub_pairs(const par_sub *s, par_wire *out, par_wire_pairs *pairs);

/* The flags (PAR_WIRE_TFLAGS bits) and region of tetrahedron k < sm->tet.n
 * and the link of face x < 4 sm->tet.n of a decoded message (each checked
 * by the decoder). */
static inline uint16_t par_wire_tflags(const par_wire *w, size_t k)
{
    const uint8_t *p = w->tflags_le + 2 * k;
    return (uint16_t)(p[0] | p[1] << 8);
}
static inline uint16_t par_wire_region(const par_wire *w, size_t k)
{
    const uint8_t *p = w->region_le + 2 * k;
    return (uint16_t)(p[0] | p[1] << 8);
}
static inline uint32_t par_wire_link(const par_wire *w, size_t x)
{
    const uint8_t *p = w->link_le + 4 * x;
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* Builds the submesh of a decoded message: par_sub_init(out, p, o,
 * w->sm->rank, w->sm->size), then every vertex (par_sub_vertex) and
 * tetrahedron, faces linked among them, interface faces
 * (par_sub_add_iface), markers, flags, regions, subsegments and subfacets,
 * vertex hints, and r.classified = 1. The faces are linked by their
 * vertices (tm_link_faces: a scattered submesh is small) and the result
 * must be the message's links. Returns 0, PDR_ETOPOLOGY (a face of more
 * than two tetrahedra, an interface face that is also shared locally, two
 * tetrahedra that disagree on a shared face's marker or orientation, links
 * that are not the faces', a subsegment or subfacet given twice),
 * PDR_ENOMEM or PDR_ELIMIT. On error out is freed (empty). p and o as for
 * par_sub_init. */
int par_wire_build(const par_wire *w, const plc *p, const ref_opts *o, par_sub *out);

/* par_wire_decode and par_wire_build in one. */
int par_wire_load(const void *msg, size_t len, const plc *p, const ref_opts *o, par_sub *out);

/* Appends the message of every live tetrahedron of s, with its interface
 * faces (the PE each TM_LINK_REMOTE face names), s->next_seq, and part =
 * rank. Returns as par_wire_encode. */
int par_wire_encode_sub(pr_buf *b, const par_sub *s);
/* The same for the live tetrahedra tets[0..nt) of s only (a piece of its
 * merge message, par_merge_pieces): their faces whose neighbour is not
 * among them and on no other PE go as PAR_WIRE_LINK_NONE. */
int par_wire_encode_tets(pr_buf *b, const par_sub *s, const uint32_t *tets, uint32_t nt);

/* Per PLC vertex, 1 where two of its segments meet at less than 90
 * degrees (ref_mesher.seg_acute, which the sequential mesher computes in
 * im_build): allocates r->seg_acute (freed by ref_free). Returns 0 or
 * PDR_ENOMEM. */
int par_wire_seg_acute(ref_mesher *r);

#endif /* PDR_PAR_WIRE_H */
