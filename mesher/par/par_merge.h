/*
 * par/par_merge.h -- the merge at the end of the parallel refinement
 * (prefix par_merge_): every PE encodes all its live tetrahedra, with
 * their links and its interface faces, as one message (par_wire); rank 0
 * takes the P messages and builds ONE ref_mesher holding the whole mesh,
 * exactly as the sequential mesher would hold it (exterior tetrahedra and
 * ghosts included), so that ref_export, ref_count_bad, ref_quality_range
 * and the writers work on it unchanged. It takes time linear in the mesh:
 * the PEs' links are kept, only the interface faces are matched (see
 * par/par_merge.c).
 *
 * The merge CHECKS that the pieces fit, counting every kind of mismatch
 * (par_merge_report) instead of stopping at the first:
 *  - a gid sent by two PEs with different coordinates or vertex data;
 *  - a tetrahedron (its four gids) sent twice: kept once;
 *  - a face of more than two tetrahedra;
 *  - a face with no neighbour: the union must be closed, as the
 *    sequential mesh is (ghosts close the hull); an interface face with no
 *    tetrahedron on the other side is counted apart;
 *  - two tetrahedra sharing a face where the face is not an interface face
 *    on both sides naming each other's PE (or is one within a PE);
 *  - two tetrahedra sharing a face with the same orientation, or with
 *    different markers;
 *  - a link within a message that does not come back;
 *  - a subsegment or subfacet sent twice with different input feature or
 *    orientation (equal copies are merged, their flags or-ed).
 * When something does not fit, the counts beyond the duplicates depend on
 * which copy was kept and on what the PEs linked: they say what kind of
 * fault there is and about how many, not which face to blame.
 *
 * The merged mesh: vertex 0 is the infinite vertex, vertices 1.. are the
 * distinct gids in ascending order (so a mesh that went out from rank 0
 * and back unrefined gets Mo's own vertex numbers), with TM_FEAT_GIDS
 * holding each vertex's gid; tetrahedra in the order of the PEs and of
 * each message; faces linked; markers, flags, regions, bd entries and
 * vertex data as sent; vertex hints rebuilt; classified = 1.
 */
#ifndef PDR_PAR_MERGE_H
#define PDR_PAR_MERGE_H

#include <stddef.h>
#include <stdint.h>

#include "par/par_sub.h"
#include "par/par_wire.h"
#include "pr.h"
#include "refine/refine.h"

typedef struct par_merge_report {
    size_t vertices;         /* merged vertices, the infinite one included */
    size_t tets;             /* merged tetrahedra, ghosts included */
    size_t vertex_conflicts; /* one gid, different coordinates or vertex data */
    size_t dup_tets;         /* tetrahedra sent more than once */
    size_t nonmanifold;      /* faces of more than two tetrahedra */
    size_t open_faces;       /* faces without a neighbour, not interface
                                (those of non-manifold faces included) */
    size_t iface_unmatched;  /* interface faces with nothing on the other side */
    size_t iface_mismatch;   /* shared faces not named as interface faces
                                by both sides, naming each other's PE */
    size_t misoriented;      /* shared faces seen with the same orientation
                                (or, linked by their PE, not one triangle) */
    size_t marker_mismatch;  /* shared faces whose two sides differ in marker */
    size_t bd_conflicts;     /* subsegments/subfacets sent twice, differing */
    size_t bad_links;        /* links within a message that do not come back */
    /* With unmarked_known, what ref_unmarked_bounds(out) returns: faces
     * between an interior tetrahedron and an exterior one or a ghost that
     * are not marked (a flag a PE passed on wrong), counted on the way
     * (not when the careful run was needed). Not a mismatch. */
    size_t unmarked_bounds;
    int unmarked_known;
} par_merge_report;

/* Number of mismatches in rep (everything but the sizes). */
size_t par_merge_problems(const par_merge_report *rep);

/* Appends the merge message of PE s (all its live tetrahedra) to b.
 * Returns as par_wire_encode_sub. */
int par_merge_encode(pr_buf *b, const par_sub *s);

/* A PE's submesh in pieces for the merge. Encoded whole, the message
 * (about 70 bytes per tetrahedron) and the tables it is made from (about
 * 40) would be held beside the mesh, which is where a PE's memory peaks;
 * sent in pieces of at most PAR_MERGE_PIECE tetrahedra, each made once the
 * one before is gone, only one piece's are. A piece grows breadth first
 * over the links from the lowest live slot no piece has taken (and from
 * the next such slot when what it reaches is used up), so that it is
 * compact and the faces it shares with other pieces, which rank 0 matches
 * by their vertices as it does interface faces, are few. Every live
 * tetrahedron is in exactly one piece, and every piece but the last has
 * PAR_MERGE_PIECE of them, so the count is known before the first. */
#define PAR_MERGE_PIECE 8192u
typedef struct par_merge_pieces {
    const tm_mesh *m; /* borrowed */
    uint64_t *taken;  /* bit per slot: in a piece already */
    uint32_t *list;   /* [max]: the current piece's slots */
    uint32_t scan;    /* the slots below are taken or dead */
    uint32_t left;    /* live tetrahedra in no piece yet */
    uint32_t count;   /* pieces in all */
    uint32_t max;     /* tetrahedra per piece */
} par_merge_pieces;
/* Pieces of at most max (> 0) tetrahedra of s, which must not change
 * until par_merge_pieces_free. Returns 0 or PDR_ENOMEM. */
int par_merge_pieces_init(par_merge_pieces *pc, const par_sub *s, uint32_t max);
/* The next piece: its slots in ascending order in *tets (valid until the
 * next call) and their number in *nt. Returns 1, or 0 when every
 * tetrahedron is in a piece already. */
int par_merge_pieces_next(par_merge_pieces *pc, const uint32_t **tets, uint32_t *nt);
void par_merge_pieces_free(par_merge_pieces *pc);

/* Builds the whole mesh into *out (which this initialises with ref_init
 * for p and o; p must outlive it) from msg[k][0..len[k]), k < n, the
 * messages of PEs 0..size-1 in ascending order of PE: one per PE, or
 * several where a PE sent its submesh in pieces (par_merge_pieces; the
 * faces between two pieces are matched as interface faces are, and must
 * name no PE). *rep gets the counts. Returns 0; PDR_EPARSE when a
 * message does not decode, or they are not in that order; PDR_ETOPOLOGY when
 * par_merge_problems(rep) > 0; PDR_ENOMEM or PDR_ELIMIT. On error *out is
 * freed (empty) and *rep holds what was counted. */
int par_merge_build(const void *const *msg, const size_t *len, uint32_t n, const plc *p,
                    const ref_opts *o, ref_mesher *out, par_merge_report *rep);

/* Step 4 of the merge (par/par_merge.c: every pair of faces linked
 * within a message checked and hashed) of one message, done ahead of the
 * merge: rank 0 checks its own while the other PEs encode and send
 * theirs (par_wire_from_sub_pairs). */
typedef par_wire_pairs par_merge_ahead;

/* Checks w's links as the merge would (w as par_wire_decode or
 * par_wire_from_sub gives it), from the three tables of the message
 * (par_wire_from_sub_pairs gets the same from a submesh's mesh, faster).
 * The merge's first run uses only whether a fault is found (and suspect);
 * what it reports when there is one comes from the careful run, see
 * par_merge_build. Returns 0 or PDR_ENOMEM (*a empty). */
int par_merge_check_ahead(const par_wire *w, par_merge_ahead *a);
#define par_merge_ahead_free par_wire_pairs_free

/* par_merge_build on messages already decoded, w[0..n) in the order of
 * par_merge_build's (borrowed: the caller clears them after), with
 * ahead[k] par_merge_check_ahead's
 * result for w[k] when k < na (na may be 0). The same mesh, report and
 * return codes as par_merge_build on the messages' bytes (PDR_EINVAL
 * when an ahead[k] is not w[k]'s). */
int par_merge_build_wires(const par_wire *w, uint32_t n, const par_merge_ahead *ahead,
                          uint32_t na, const plc *p, const ref_opts *o, ref_mesher *out,
                          par_merge_report *rep);

/* par_merge_build_wires that frees each message's vertex and
 * tetrahedron tables once it has taken them (par_wire_drop_vertices,
 * par_wire_drop_tets), so that the messages and the merged mesh are not
 * held whole at once: at 10^6 tetrahedra the tables are about 55 bytes
 * per tetrahedron beside the mesh's 70. The careful run cannot be made
 * then: when the first run finds a fault, its own counts are returned
 * with PDR_ETOPOLOGY (they say that the pieces do not fit and of what
 * kind, but count less than the careful run would; two linked
 * tetrahedra with one vertex set count as one tetrahedron sent twice).
 * The caller still clears w. */
int par_merge_build_wires_spent(par_wire *w, uint32_t n, const par_merge_ahead *ahead,
                                uint32_t na, const plc *p, const ref_opts *o, ref_mesher *out,
                                par_merge_report *rep);

/* The subsegments and subfacets still missing on PE s when its
 * refinement ends (a piece whose split point lay on another PE, which
 * did not know of it): appended to b as u32 n, then n times u8 nv (2 or
 * 3), 3 x u64 vertex gids (the third 0 for a subsegment; a subfacet in
 * its table's orientation), u32 input feature, u16 flags. *n gets the
 * count. Returns 0 or PDR_ENOMEM. */
int par_merge_put_missing(pr_buf *b, const par_sub *s, size_t *n);
/* Adds the pieces of such a list (data[0..len), exactly) to the merged
 * mesh r as missing and queues them, so that ref_refine recovers them;
 * pieces r holds present already are skipped. *added gets the pieces
 * added. Returns 0, PDR_EPARSE (malformed: a gid r does not have, a
 * feature out of range, trailing bytes), or PDR_ENOMEM. */
int par_merge_add_missing(ref_mesher *r, const void *data, size_t len, size_t *added);

/* The exterior flag and the regions follow the tetrahedra through every
 * insertion, and a flat tetrahedron on an inclined facet or a flip of
 * subfacets can pass on the wrong one (refine_bound.c); the sequential
 * mesher classifies its finished mesh again (ref_refine), which a PE
 * cannot do across the others. This does it on the merged mesh r: the
 * flood fill of ref_classify, then, when a tetrahedron moved, ref_refine
 * (sequential: what the move made bad is split here). With missing set
 * (pieces added by par_merge_add_missing, queued), ref_refine first
 * recovers them and classifies after that; with refine set, ref_refine
 * runs even when the classification moved nothing (bad tetrahedra that a
 * PE left, ref_stats.left_elsewhere). *moved gets the tetrahedra
 * whose exterior flag or region changed, *added the vertices inserted.
 * Returns 0 or a negative code. */
int par_merge_reclassify(ref_mesher *r, int missing, int refine, size_t *moved,
                         size_t *added);

/* par_merge_reclassify's cheap case: nothing missing, no PE in doubt about
 * a flag, and the only work left the tetrahedra that PEs left for a split
 * on another PE (marked, see ref_refine_marked): refines just those, and
 * classifies only if a step here meets a doubt. Same outputs. */
int par_merge_finish_left(ref_mesher *r, size_t *moved, size_t *added);

/* How many of the merged mesh's vertices 1.. have a gid below g (they
 * hold their gids in ascending order, see the top of this file). */
uint32_t par_merge_vertices_below(const tm_mesh *m, uint64_t g);

#endif /* PDR_PAR_MERGE_H */
