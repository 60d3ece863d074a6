/*
 * mesh/tm.h -- array-based tetrahedral mesh (prefix tm_).
 *
 * One tm_mesh holds vertices and tetrahedra in flat arrays: no per-tet
 * allocation, freed tetrahedra go on a free list and are reused first (so
 * the memory touched by one insertion is the memory the previous insertion
 * freed). Several meshes can live in one process (each PE's submesh, a
 * test's scratch mesh): there is no global state.
 *
 * ------------------------------------------------------------ invariants
 * Vertices. Vertex 0 is the infinite vertex: it has no coordinates of
 * meaning (they are NaN) and is the apex of every ghost tetrahedron. Real
 * vertices are 1..nv-1. vhint[v] is a live tetrahedron having v as a
 * vertex, or TM_NONE if v is in no tetrahedron (not inserted yet, or a
 * duplicate point that was skipped).
 *
 * Tetrahedra. Slot t holds v[4] (vertex numbers) and n[4] (neighbour
 * links). A real tetrahedron is positively oriented: pred_orient3d(v0, v1,
 * v2, v3) > 0. A ghost tetrahedron has the infinite vertex in one slot k;
 * its face k is a face of the convex hull, oriented so that the hull's
 * outside is on the positive side, exactly as if the infinite vertex were a
 * point far outside. Ghosts close the hull: in a Delaunay tetrahedralization
 * built by mesh/dt.c every face has a neighbour, the ghosts around the hull
 * link to each other across their faces that contain vertex 0, and the
 * convex hull is closed iff the ghost links are symmetric.
 *
 * Why ghosts rather than a bounding box: with a box, the tetrahedra
 * touching the box are not those of the Delaunay tetrahedralization of the
 * input, and points far outside the box cannot be inserted; with ghosts a
 * point outside the hull is simply in conflict with the ghosts whose hull
 * face it sees, so hull insertion is the same search-and-commit as interior
 * insertion, and the hull is explicit for verification and output.
 *
 * ------------------------------------------------------- adjacency algebra
 * Face i of a tetrahedron is the face opposite v[i]. Its vertices, in the
 * order of tm_face_vtx[i], are oriented so that v[i] lies on their positive
 * side (pred_orient3d(face, v[i]) > 0):
 *
 *      face 0: v1 v3 v2     face 1: v0 v2 v3
 *      face 2: v0 v3 v1     face 3: v0 v1 v2
 *
 * so a new tetrahedron (face, p) is positively oriented iff p is on the
 * same side of the face as v[i]. The link n[i] packs the neighbour across
 * face i and the number of the same face in the neighbour:
 *
 *      n[i] = (u << 2) | j    with u's face j == t's face i (same vertices)
 *      and then u.n[j] == (t << 2) | i                       (symmetry)
 *
 * Example: t = (1,2,3,4), u = (2,1,3,5). t's face 3 is {1,2,3}, u's face 3
 * is {2,1,3}: t.n[3] = u<<2|3 and u.n[3] = t<<2|3. Walking from t through
 * face i is u = n[i] >> 2; the vertex of u opposite the shared face is
 * u.v[n[i] & 3].
 *
 * Special links: values >= TM_LINK_SPECIAL are not neighbours. TM_LINK_NONE
 * marks a domain boundary (after exterior tetrahedra are removed); remote
 * faces, whose neighbour lives on another PE, are TM_LINK_REMOTE(k) with k
 * an index into a table the parallel layer keeps. One unsigned comparison
 * (link >= TM_LINK_SPECIAL) recognises all of them. Tetrahedron numbers are
 * therefore below TM_MAX_TETS (805 million).
 *
 * Edges: edge e of a tetrahedron joins the slots tm_edge_vtx[e]:
 *      e0: 0-1  e1: 0-2  e2: 0-3  e3: 1-2  e4: 1-3  e5: 2-3
 *
 * Flags (16 bits per tetrahedron): TM_F_DEAD (slot on the free list),
 * TM_F_CAVITY (in the cavity being searched; clear between operations),
 * TM_F_FACEMARK(i) (face i carries a marker, e.g. is a subfacet: a fast
 * test before reading the optional marker array), TM_F_SUBSEG(e) (edge e is
 * a subsegment; set in every tetrahedron around that edge), TM_F_QUEUED
 * (on a work queue), and three spare bits for the layers above (the
 * quality mesher uses TM_F_SPARE0..2, see refine/refine.h). Ghosts are recognised
 * by their vertices (tm_is_ghost), not by a flag.
 *
 * Optional arrays, allocated by tm_enable() only when a layer needs them,
 * so plain Delaunay stays lean: face markers (int32 per face, e.g. the
 * facet id of a subfacet, set on both tetrahedra sharing the face; read
 * with tm_marker, written with tm_set_marker), gid[v]
 * (uint64 global vertex id), lock[t] (owner of a tetrahedron's lock, 0 =
 * free) with its summary bit in locked[] (bit t set iff lock[t] != 0; see
 * tm_set_lock).
 *
 * Face markers are sparse: nearly every face of a quality mesh has none,
 * so instead of 16 bytes per slot the mesh keeps a map from a face
 * (4t + i) to its marker, holding only the nonzero ones (open addressing,
 * linear probing, backward-shift deletion, at most half full: 16 to 32
 * bytes per marked face), and one bit per slot in mk_has saying whether
 * the map holds a face of the slot: a slot without it reads four zeros
 * without a probe. The map behaves exactly as the array it replaces: a
 * marker is whatever was last written (0 if never, or since the slot was
 * taken), whatever the TM_F_FACEMARK bits say. At 10^6 tetrahedra, where
 * about a tenth of the slots have a marked face, that is about 2 bytes
 * per slot instead of 16.
 */
#ifndef PDR_TETMESH_H
#define PDR_TETMESH_H

#include <stddef.h>
#include <stdint.h>

#include "base/pdr_error.h"

typedef uint32_t tm_link;

#define TM_NONE UINT32_MAX /* "no tetrahedron / no vertex" */
#define TM_VINF 0u         /* the infinite vertex */

#define TM_LINK_SPECIAL 0xC0000000u
#define TM_LINK_NONE 0xFFFFFFFFu  /* domain boundary: no neighbour */
#define TM_LINK_UNSET 0xFFFFFFFEu /* transient, never in a finished mesh */
#define TM_LINK_REMOTE(k) (TM_LINK_SPECIAL + (uint32_t)(k))
#define TM_REMOTE_MAX (TM_LINK_UNSET - TM_LINK_SPECIAL) /* k < this */
#define TM_MAX_TETS (TM_LINK_SPECIAL >> 2)
#define TM_MAX_VERTS 0xFFFFFFF0u

enum {
    TM_F_DEAD = 1u << 0,
    TM_F_CAVITY = 1u << 1,
    TM_F_FACEMARK0 = 1u << 2, /* bits 2..5: face i marked */
    TM_F_SUBSEG0 = 1u << 6,   /* bits 6..11: edge e is a subsegment */
    TM_F_QUEUED = 1u << 12,
    TM_F_SPARE0 = 1u << 13,
    TM_F_SPARE1 = 1u << 14,
    TM_F_SPARE2 = 1u << 15,
};
#define TM_F_FACEMARK(i) ((uint16_t)(TM_F_FACEMARK0 << (i)))
#define TM_F_FACEMARKS ((uint16_t)(0xfu << 2))
#define TM_F_SUBSEG(e) ((uint16_t)(TM_F_SUBSEG0 << (e)))
#define TM_F_SUBSEGS ((uint16_t)(0x3fu << 6))

/* Optional features for tm_enable(). */
enum {
    TM_FEAT_MARKERS = 1u << 0, /* per-face int32 markers */
    TM_FEAT_GIDS = 1u << 1,    /* per-vertex uint64 global ids */
    TM_FEAT_LOCKS = 1u << 2,   /* per-tet uint32 lock owner */
};

typedef struct tm_tet {
    uint32_t v[4]; /* vertices; v[i] == TM_VINF in a ghost */
    tm_link n[4];  /* neighbour links, see the algebra above */
} tm_tet;

typedef struct tm_mesh {
    /* vertices */
    double *xyz;     /* 3 per vertex; vertex 0 is NaN */
    uint32_t *vhint; /* a live tet incident to v, or TM_NONE */
    uint64_t *gid;   /* optional (TM_FEAT_GIDS) */
    uint32_t nv;     /* vertices including vertex 0 */
    uint32_t vcap;
    /* tetrahedra */
    tm_tet *tets;
    uint16_t *flags;
    /* optional (TM_FEAT_MARKERS): the sparse face markers (above) */
    uint64_t *mk_has; /* bit t set iff the map holds a face of slot t */
    uint32_t *mk_key; /* mk_cap keys: a face 4t + i, or TM_NONE (empty) */
    int32_t *mk_val;  /* its marker, never 0 */
    uint32_t mk_cap;  /* power of two (0 before tm_enable) */
    uint32_t mk_n;    /* faces held */
    uint32_t *lock;  /* optional (TM_FEAT_LOCKS) */
    uint64_t *locked; /* with lock: bit t of word t/64 set iff lock[t] != 0 */
    uint32_t nslots; /* slots in use (live + free) */
    uint32_t tcap;
    uint32_t nlive;  /* live tetrahedra, ghosts included */
    uint32_t nghost; /* live ghosts */
    uint32_t free_head; /* free list through n[0], TM_NONE if empty */
    uint32_t nfree;
    unsigned features;
    uint64_t rng; /* xorshift state for randomised walks */
} tm_mesh;

static const uint8_t tm_face_vtx[4][3] = {{1, 3, 2}, {0, 2, 3}, {0, 3, 1}, {0, 1, 2}};
static const uint8_t tm_edge_vtx[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
/* tm_edge_of[a][b]: the edge joining slots a != b. */
static const uint8_t tm_edge_of[4][4] = {
    {9, 0, 1, 2}, {0, 9, 3, 4}, {1, 3, 9, 5}, {2, 4, 5, 9}};

static inline tm_link tm_mklink(uint32_t t, int face)
{
    return (t << 2) | (uint32_t)face;
}
static inline uint32_t tm_ltet(tm_link l)
{
    return l >> 2;
}
static inline int tm_lface(tm_link l)
{
    return (int)(l & 3u);
}
static inline int tm_is_special(tm_link l)
{
    return l >= TM_LINK_SPECIAL;
}

static inline int tm_is_dead(const tm_mesh *m, uint32_t t)
{
    return (m->flags[t] & TM_F_DEAD) != 0;
}
/* The slot of the infinite vertex in t, or -1 for a real tetrahedron. */
static inline int tm_ghost_slot(const tm_mesh *m, uint32_t t)
{
    const uint32_t *v = m->tets[t].v;
    return v[0] == TM_VINF ? 0 : v[1] == TM_VINF ? 1 : v[2] == TM_VINF ? 2 : v[3] == TM_VINF ? 3 : -1;
}
static inline int tm_is_ghost(const tm_mesh *m, uint32_t t)
{
    const uint32_t *v = m->tets[t].v;
    return !(v[0] && v[1] && v[2] && v[3]);
}
static inline const double *tm_xyz(const tm_mesh *m, uint32_t v)
{
    return m->xyz + 3 * (size_t)v;
}
/* Initialises an empty mesh with the infinite vertex. features: TM_FEAT_*.
 * Returns 0 or PDR_ENOMEM. */
int tm_init(tm_mesh *m, unsigned features);
/* Releases every array and resets the struct. */
void tm_free(tm_mesh *m);
/* Allocates the optional arrays for features (idempotent). */
int tm_enable(tm_mesh *m, unsigned features);
/* Frees the lock arrays (TM_FEAT_LOCKS) once no lock is needed again. */
void tm_drop_locks(tm_mesh *m);
/* Makes room for nverts vertices and ntets tetrahedra in total, so later
 * additions do not reallocate. Returns 0, PDR_ENOMEM or PDR_ELIMIT. */
int tm_reserve(tm_mesh *m, size_t nverts, size_t ntets);

/* Appends a vertex (no tetrahedron refers to it yet); *out gets its
 * number. Returns 0, PDR_ENOMEM or PDR_ELIMIT. */
int tm_add_vertex(tm_mesh *m, const double p[3], uint32_t *out);

/* Ensures that 'count' more tetrahedra can be allocated without failure. */
int tm_room(tm_mesh *m, size_t count);
/* Lock state (TM_FEAT_LOCKS). Every write of lock[t] goes through
 * tm_set_lock, which keeps bit t of locked[] equal to lock[t] != 0: a
 * search testing the tetrahedra it visits (mesh/dt.h, DT_CHECK_LOCKS)
 * reads that bit, in an array 32 times smaller than lock[] that stays in
 * cache, and reads lock[t] only when the bit is set. */
static inline void tm_set_lock(tm_mesh *m, uint32_t t, uint32_t owner)
{
    uint64_t bit = (uint64_t)1 << (t & 63u);
    m->lock[t] = owner;
    if (owner)
        m->locked[t >> 6] |= bit;
    else
        m->locked[t >> 6] &= ~bit;
}
/* 1 if t's lock is held by some owner (m->lock is set). */
static inline int tm_is_locked(const tm_mesh *m, uint32_t t)
{
    return (int)((m->locked[t >> 6] >> (t & 63u)) & 1u);
}
/* 1 if t's lock is held by another owner than own (0 matches no
 * owner: then any held lock is another's). */
static inline int tm_held_by_other(const tm_mesh *m, uint32_t t, uint32_t own)
{
    return tm_is_locked(m, t) && m->lock[t] != own;
}
/* tm_set_lock(m, t, 0) out of line, for tm__take_slot: the sequential
 * mesher (no lock array) keeps its insertion code as small as before. */
void tm__unlock_slot(tm_mesh *m, uint32_t t);
/* Face markers (TM_FEAT_MARKERS; see the header comment). */
static inline int tm_has_markers(const tm_mesh *m)
{
    return m->mk_has != NULL;
}
/* 1 if the marker map holds a face of t (one has a nonzero marker). */
static inline int tm__has_marks(const tm_mesh *m, uint32_t t)
{
    return (int)((m->mk_has[t >> 6] >> (t & 63u)) & 1u);
}
/* The marker of face i of t, a slot the map holds (tm__has_marks). */
int32_t tm__marker(const tm_mesh *m, uint32_t t, int i);
/* Forgets t's markers (all four 0). */
void tm__clear_marks(tm_mesh *m, uint32_t t);
/* The marker of face i of t: 0 if none, and 0 without TM_FEAT_MARKERS. */
static inline int32_t tm_marker(const tm_mesh *m, uint32_t t, int i)
{
    if (!m->mk_has || !tm__has_marks(m, t))
        return 0;
    return tm__marker(m, t, i);
}
/* Sets the marker of face i of t alone (not the neighbour's face, not the
 * flags; needs TM_FEAT_MARKERS). Returns 0 or PDR_ENOMEM; it cannot fail
 * while at most `count` faces without a marker got one since
 * tm_marker_room(m, count) returned 0. */
int tm_set_marker(tm_mesh *m, uint32_t t, int i, int32_t marker);
/* Makes room in the marker map for `count` more slots' markers, a face
 * each (0 without TM_FEAT_MARKERS). Returns 0 or PDR_ENOMEM. */
int tm_marker_room(tm_mesh *m, size_t count);

/* Takes a slot from the free list or the end (the caller ensured room)
 * and clears its flags, markers and lock, without counting it live: for
 * callers that count new tetrahedra in bulk (dt_build). */
static inline uint32_t tm__take_slot(tm_mesh *m)
{
    uint32_t t;
    if (m->free_head != TM_NONE) {
        t = m->free_head;
        m->free_head = m->tets[t].n[0];
        m->nfree--;
    } else {
        t = m->nslots++;
    }
    m->flags[t] = 0;
    if (m->mk_has && tm__has_marks(m, t))
        tm__clear_marks(m, t);
    /* A slot freed while locked keeps its lock until it is taken again;
     * every other slot's lock is 0 already (the arrays grow with free
     * locks, tm.c): only the summary bit, which stays in cache, is read,
     * and lock[t], an array the search seldom touches, only written when
     * the bit is set. */
    if (m->lock && tm_is_locked(m, t))
        tm__unlock_slot(m, t);
    return t;
}
/* Takes a slot as tm__take_slot and counts it live: vertices and links are
 * unset, flags 0, markers 0, lock 0. Inline: it runs once per new
 * tetrahedron. */
static inline uint32_t tm_alloc_tet(tm_mesh *m)
{
    uint32_t t = tm__take_slot(m);
    m->nlive++;
    return t;
}
/* Marks slot t dead and puts it on the free list, without counting it
 * out of the live ones: the inverse of tm__take_slot. */
static inline void tm__release_slot(tm_mesh *m, uint32_t t)
{
    m->flags[t] = TM_F_DEAD;
    m->tets[t].n[0] = m->free_head;
    m->free_head = t;
    m->nfree++;
}
/* Puts t on the free list. Links of neighbours are not touched. */
static inline void tm_free_tet(tm_mesh *m, uint32_t t)
{
    m->nghost -= (uint32_t)tm_is_ghost(m, t);
    m->nlive--;
    tm__release_slot(m, t);
}
/* Frees t and sets the links of its neighbours towards t to
 * TM_LINK_NONE (they become domain-boundary faces). */
void tm_delete_tet(tm_mesh *m, uint32_t t);

/* Sets a face marker on face i of t and on the same face of its
 * neighbour, with their TM_F_FACEMARK bits (needs TM_FEAT_MARKERS).
 * marker 0 clears it. Returns 0 or PDR_ENOMEM (tm_set_marker). */
int tm_mark_face(tm_mesh *m, uint32_t t, int i, int32_t marker);
static inline int32_t tm_face_marker(const tm_mesh *m, uint32_t t, int i)
{
    return (m->flags[t] & TM_F_FACEMARK(i)) ? tm_marker(m, t, i) : 0;
}

/* 1 if triangle y is triangle x seen from its other side: x reversed, in
 * any of its three rotations (the two faces of one link). Without
 * branches: which rotation is anyone's guess. */
static inline int tm_faces_opposed(const uint32_t x[3], const uint32_t y[3])
{
    return ((y[0] == x[0]) & (y[1] == x[2]) & (y[2] == x[1])) |
           ((y[0] == x[2]) & (y[1] == x[1]) & (y[2] == x[0])) |
           ((y[0] == x[1]) & (y[1] == x[0]) & (y[2] == x[2]));
}

/* Builds the neighbour links of all live tetrahedra from their vertices by
 * sorting faces: faces shared by two tetrahedra are linked, faces of one
 * tetrahedron get TM_LINK_NONE. *nonmanifold (if not NULL) gets the number
 * of faces shared by more than two tetrahedra (those are left unlinked).
 * Returns 0 or PDR_ENOMEM. */
int tm_link_faces(tm_mesh *m, size_t *nonmanifold);
/* Closes the hull: a ghost tetrahedron on every face with TM_LINK_NONE,
 * and the ghosts linked to each other around hull edges. *open_edges gets
 * the number of hull edges not shared by exactly two hull faces (those
 * ghost faces stay TM_LINK_NONE). Returns 0 or PDR_ENOMEM/PDR_ELIMIT. */
int tm_add_ghosts(tm_mesh *m, size_t *open_edges);
/* Recomputes vhint for every vertex from the live tetrahedra. */
void tm_rebuild_hints(tm_mesh *m);
/* Deletes every ghost tetrahedron (their real neighbours get
 * TM_LINK_NONE). */
void tm_remove_ghosts(tm_mesh *m);

/* Bytes held by the mesh arrays for the slots and vertices in use (the
 * lock summary bits in whole 64-bit words), with the marker map's whole
 * capacity. */
size_t tm_bytes_used(const tm_mesh *m);
/* Bytes per tetrahedron slot and per vertex, with the enabled features;
 * a slot's is fractional with locks and markers (a summary bit each, an
 * eighth of a byte), and leaves out the marker map (tm_bytes_used counts
 * it). */
double tm_bytes_per_tet(const tm_mesh *m);
size_t tm_bytes_per_vertex(const tm_mesh *m);

#endif /* PDR_TETMESH_H */
