/*
 * mesh/dt.h -- Bowyer-Watson insertion on a tm_mesh (prefix dt_).
 *
 * Inserting a point p is two separate steps, so that a caller can look at a
 * cavity before deciding to change the mesh:
 *
 *   dt_cavity_search(m, p, start, flags, &cav)
 *       finds the cavity of p: the connected set of tetrahedra whose
 *       (perturbed) circumsphere contains p, by a depth-first search from a
 *       tetrahedron in conflict (found by walking from 'start' when flags
 *       has DT_LOCATE). It marks the cavity tetrahedra (TM_F_CAVITY) and
 *       lists them, and lists every boundary face of the cavity with the
 *       reason the search stopped there. Nothing else in the mesh changes.
 *   dt_cavity_commit(m, v, &cav)
 *       deletes the cavity and connects vertex v (whose coordinates are p)
 *       to every boundary face; cav.newtets lists the new tetrahedra.
 *   dt_cavity_abandon(m, &cav)
 *       clears the marks (and releases locks taken by the search); the
 *       cost of an abandoned insertion is the search alone.
 *
 * Between search and commit/abandon the caller must not change the mesh.
 * Plain insertion is dt_insert() = search + commit.
 *
 * Why the search stops at a face (dt_bface.reason):
 *   DT_BND_OUTSIDE  the neighbour is not in conflict with p;
 *   DT_BND_DOMAIN   no neighbour (TM_LINK_NONE: boundary of the domain);
 *   DT_BND_MARKED   the face carries a marker and DT_STOP_MARKED was asked
 *                   (a subfacet: the cavity does not cross it, whether or
 *                   not the tetrahedron behind it is in conflict), unless
 *                   the caller's may_cross says the point splits it;
 *   DT_BND_REMOTE   the neighbour is on another PE (TM_LINK_REMOTE(k), k in
 *                   'outer').
 * The commit gives each new tetrahedron's face 3 the link, marker and
 * subsegment bits of the boundary face it is built on, so markers move with
 * their faces.
 *
 * Degenerate input: symbolic perturbation (geom/pred.h) decides every cospherical
 * tie, so the result is the Delaunay tetrahedralization of the perturbed
 * points, which is a Delaunay tetrahedralization of the points. A point
 * equal to an existing vertex is reported (status DT_DUPLICATE, dup_vertex)
 * and never inserted.
 */
#ifndef PDR_DELAUNAY_H
#define PDR_DELAUNAY_H

#include <stddef.h>
#include <stdint.h>

#include "mesh/tm.h"

enum dt_reason {
    DT_BND_OUTSIDE = 0,
    DT_BND_DOMAIN = 1,
    DT_BND_MARKED = 2,
    DT_BND_REMOTE = 3,
};

typedef struct dt_bface {
    uint32_t tet;   /* cavity tetrahedron */
    uint8_t face;   /* its face on the cavity boundary */
    uint8_t reason; /* enum dt_reason */
    uint16_t spare;
    tm_link outer;  /* the link across that face (neighbour or special) */
} dt_bface;

enum dt_search_flags {
    DT_LOCATE = 1u << 0,      /* walk from start to a tet in conflict */
    DT_STOP_MARKED = 1u << 1, /* do not cross marked faces (but those
                                 may_cross allows: see dt_cavity) */
    DT_LOCK = 1u << 2,        /* lock cavity and ring (needs TM_FEAT_LOCKS) */
    DT_CHECK_LOCKS = 1u << 3, /* as DT_LOCK, but take no lock: only fail
                                 (DT_LOCKED) where another owner holds one;
                                 for a search committed before anything
                                 else can run */
    DT_GHOST_WALLS = 1u << 5, /* with DT_STOP_MARKED, for a carved domain
                                 whose boundary faces carry ghosts: a ghost
                                 joins the cavity exactly when the search
                                 crosses its marked face (may_cross: a
                                 boundary piece the point splits), whatever
                                 the conflict test says, and the search
                                 never goes from a ghost to another */
    DT_STAR = 1u << 6,        /* without locks: stop (DT_NOT_STAR, nothing
                                 marked) at the first boundary face that p
                                 does not see from inside, i.e. when the
                                 cavity cannot be a star from p; faces
                                 next to DT_GHOST_WALLS ghosts are not
                                 tested, so a cavity found may still fail
                                 dt_cavity_is_star */
};

enum dt_status {
    DT_OK = 0,          /* cavity found; commit or abandon it */
    DT_DUPLICATE,       /* p equals vertex dup_vertex; nothing marked */
    DT_LOCKED,          /* a tet is locked by another owner (blocker) */
    DT_OUTSIDE_DOMAIN,  /* the walk left the domain through a boundary or
                           remote face (exit_link); nothing marked */
    DT_TOO_BIG,         /* more than max_tets tetrahedra; nothing marked */
    DT_NOT_STAR,        /* DT_STAR: no star from p; nothing marked */
};

/* A reusable cavity: initialise once, search many times, free at the end.
 * The arrays grow as needed and are kept between searches. */
typedef struct dt_cavity {
    double p[3];
    int status;          /* enum dt_status */
    int pending;         /* a search left marks that need commit/abandon */
    uint32_t located;    /* first tetrahedron of the cavity */
    uint32_t dup_vertex; /* DT_DUPLICATE: the vertex equal to p */
    uint32_t blocker;    /* DT_LOCKED: the locked tetrahedron */
    tm_link exit_link;   /* DT_OUTSIDE_DOMAIN: the special link met */
    uint32_t lock_owner; /* DT_LOCK: our owner id (nonzero) */
    uint32_t *tets;      /* cavity tetrahedra */
    size_t ntets, cap_tets;
    dt_bface *bnd;       /* cavity boundary faces */
    size_t nbnd, cap_bnd;
    uint32_t *newtets;   /* after commit: new tets, newtets[i] on bnd[i] */
    size_t nnew, cap_new;
    uint32_t *stack;
    size_t cap_stack;
    uint32_t *held;      /* DT_LOCK: tets whose lock this search took */
    size_t nheld, cap_held;
    unsigned flags;      /* of the last search */
    /* DT_STOP_MARKED: the constrained cavity. A marked face met by the
     * search bounds the cavity (reason DT_BND_MARKED) unless may_cross is
     * set and returns nonzero for it (tetrahedron t's face f): the faces
     * that the new point itself splits, e.g. the subfacets of its 2D
     * cavity. A crossed face is then treated as any other face (conflict
     * test, and deleted if both sides are in conflict). The caller sets
     * may_cross and cross_arg (NULL: no marked face is crossed); init sets
     * them to NULL and the search never changes them. */
    int (*may_cross)(void *arg, const tm_mesh *m, uint32_t t, int f);
    void *cross_arg;
    /* A search without locks that has taken more than max_tets
     * tetrahedra stops there, with status DT_TOO_BIG and nothing marked
     * (0: no limit; init sets 0, the search never changes it). */
    size_t max_tets;
    size_t nmarked;      /* boundary faces of reason DT_BND_MARKED */
    size_t nremote;      /* boundary faces of reason DT_BND_REMOTE: 0 for
                            a cavity on this PE alone, which its callers
                            then need not look through */
    /* Commit scratch: local numbers of the boundary vertices and a table
     * edge (local a, local b) -> first new face seen on it; every entry is
     * consumed by the second face, so it is empty between commits. */
    uint32_t *edge_table; /* DT_LOCAL_MAX^2 links, TM_LINK_UNSET = empty */
    uint32_t loc_vert[64];
    uint8_t *loc_ids;     /* 3 per boundary face */
    size_t cap_loc_ids;
    uint32_t *tri;        /* 4 per boundary face: its vertices, its marker */
    size_t cap_tri;
    struct dt_edge_slot *edge_hash; /* large cavities: edge -> face */
    size_t cap_hash;
} dt_cavity;

void dt_cavity_init(dt_cavity *c);
void dt_cavity_free(dt_cavity *c);

/* Walks from start (any live tet; TM_NONE = anywhere) to a tetrahedron
 * containing p, or to a ghost whose hull face p lies strictly beyond.
 * Returns 0 with *tet set, 1 if the walk met a boundary or remote face
 * (*tet is the last tet, *exit_link the link), or PDR_EINVAL (empty mesh) /
 * PDR_ETOPOLOGY (walk did not end: broken mesh). */
int dt_locate(tm_mesh *m, const double p[3], uint32_t start, uint32_t *tet,
              tm_link *exit_link);

/* Conflict of p with tetrahedron t: +1 in conflict, -1 not, 0 if p equals
 * one of t's vertices. Uses the perturbed predicates. */
int dt_conflict(const tm_mesh *m, uint32_t t, const double p[3]);

/* See the top of this file. Without DT_LOCATE, start must be in conflict
 * with p (else PDR_EINVAL). Returns 0 (look at c->status) or PDR_ENOMEM /
 * PDR_EINVAL / PDR_ETOPOLOGY; on error nothing stays marked. */
int dt_cavity_search(tm_mesh *m, const double p[3], uint32_t start, unsigned flags,
                     dt_cavity *c);
/* Returns 0, or PDR_ENOMEM/PDR_ELIMIT with the mesh unchanged and the
 * search still pending (abandon it). v's coordinates must be c->p. */
int dt_cavity_commit(tm_mesh *m, uint32_t v, dt_cavity *c);
void dt_cavity_abandon(tm_mesh *m, dt_cavity *c);
/* Releases the locks taken by the last DT_LOCK search (commit keeps them:
 * the caller decides when to release). */
void dt_cavity_unlock(tm_mesh *m, dt_cavity *c);
/* 1 if p sees every boundary face of the cavity from inside (each new
 * tetrahedron would be positively oriented), else 0. Bulk Delaunay never
 * needs it; a cavity cut short by DT_STOP_MARKED may fail it. A cavity
 * that passes holds p (p lies in the intersection of the inner sides of
 * its boundary faces, which the cavity contains). */
int dt_cavity_is_star(const tm_mesh *m, const dt_cavity *c);
/* Makes a pending cavity a star from p by taking out the tetrahedra whose
 * boundary faces p does not see from inside, as often as that changes the
 * boundary (TetGen's cavity shrinking: a cavity cut by constraints may
 * reach round one to its back). keep(arg, t), if not NULL, names
 * tetrahedra that must stay. Returns 0 with a star-shaped cavity (c->tets
 * and c->bnd rebuilt), 1 when that would drop a tetrahedron keep names or
 * empty the cavity (the cavity is then abandoned: nothing marked), or
 * PDR_ENOMEM (abandoned too). */
int dt_cavity_shrink(tm_mesh *m, dt_cavity *c, int (*keep)(void *arg, uint32_t t), void *arg);

/* Makes tets[0..n) the pending cavity of p (no conflict test: the caller
 * knows p sees every boundary face, e.g. p on an edge and the tetrahedra
 * around it), with the boundary reasons of a search with flags. Returns 0,
 * PDR_EINVAL (a tetrahedron dead or listed twice; nothing pending) or
 * PDR_ENOMEM. */
int dt_cavity_set(tm_mesh *m, const double p[3], const uint32_t *tets, size_t n, unsigned flags,
                  dt_cavity *c);

/* Inserts vertex v (already added with tm_add_vertex) by walking from
 * start. Returns 0 with c->status DT_OK (inserted; c->newtets), or
 * DT_DUPLICATE/DT_OUTSIDE_DOMAIN (not inserted), or a negative error. */
int dt_insert(tm_mesh *m, uint32_t v, uint32_t start, dt_cavity *c);

/* Starts a tetrahedralization with one tetrahedron (a,b,c,d) and its four
 * ghosts. The points must not be coplanar (PDR_EGEOMETRY). */
int dt_init_simplex(tm_mesh *m, uint32_t a, uint32_t b, uint32_t c, uint32_t d);

typedef struct dt_build_opts {
    uint64_t seed; /* BRIO rounds */
    /* Renumber the vertices in insertion order, so that vertices close in
     * space are close in memory (fewer cache misses). The vertex numbers
     * change: gid[v] (TM_FEAT_GIDS, enabled if needed) keeps the number
     * vertex v had before, and the writers in io/tg.h use it. */
    int renumber;
    /* Called about every 2^16 insertions if not NULL. */
    void (*progress)(void *arg, size_t done, size_t total);
    void *progress_arg;
} dt_build_opts;

typedef struct dt_build_stats {
    size_t inserted;   /* vertices in the tetrahedralization */
    size_t duplicates; /* points equal to an earlier point, skipped */
    size_t largest_cavity; /* most new tetrahedra made by one insertion */
    double sort_seconds, insert_seconds;
} dt_build_stats;

/* Delaunay tetrahedralization of the mesh's vertices 1..nv-1 (the mesh has
 * no tetrahedra yet): BRIO/Hilbert order, then one insertion per point,
 * each walk starting from the last new tetrahedron. Returns 0,
 * PDR_EGEOMETRY (fewer than 4 distinct points, or all coplanar),
 * PDR_ENOMEM or PDR_ELIMIT. */
int dt_build(tm_mesh *m, const dt_build_opts *opts, dt_build_stats *stats);

#endif /* PDR_DELAUNAY_H */
