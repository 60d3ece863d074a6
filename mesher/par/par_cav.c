/* par/par_cav.c -- the distributed cavity: gather, migrate, abort (see
 * par/par_cav.h for the protocol). */
#include "config.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "base/pdr_util.h"
#include "mesh/dt.h"
#include "par/par_cav.h"
#include "par/par_verify.h"
#include "pr.h"

/* Message types (proto reserves 0x10..0x1f for the cavity messages; the
 * layouts are in proto/PROTOCOL.md, "Cavity messages"). */
enum {
    MSG_GATHER = 0x10,
    MSG_REPLY = 0x11,
    MSG_MIGRATE = 0x12,
    MSG_ABORT = 0x13,
    MSG_BAND = 0x14,
};

/* Reply status. */
enum {
    REPLY_OK = 0,
    REPLY_LOCKED = 1,
    REPLY_STALE = 2,
    REPLY_DUPLICATE = 3,
    REPLY_TOO_BIG = 4, /* more cavity tetrahedra than the origin's max */
};

/* The flags that travel with a tetrahedron: everything but the transient
 * DEAD and CAVITY bits. */
#define TRAVEL_FLAGS ((uint16_t) ~(TM_F_DEAD | TM_F_CAVITY))
/* On the wire only, in the place of TM_F_DEAD (never sent): the
 * tetrahedron was left for the merge where it was (par_cav_ctx.left). */
#define WIRE_LEFT ((uint16_t)TM_F_DEAD)

/* Bounds a decoder accepts before it allocates (a cavity of a few
 * thousand tetrahedra is already unusual). */
#define MAX_CAV_TETS (UINT32_C(1) << 22)
#define MAX_CAV_KEYS (UINT32_C(1) << 22)
/* From this many tetrahedra on, put_tets indexes vertices with an array
 * over all of them rather than a map. */
#define PUT_TETS_DENSE 1024

/* ------------------------------------------------------------ lists */

typedef par_u32list u32list;

static int push(u32list *l, uint32_t x)
{
    if (pdr_grow((void **)&l->a, &l->cap, l->n + 1, sizeof *l->a))
        return PDR_ENOMEM;
    l->a[l->n++] = x;
    return 0;
}

static void part_free(par_part *p)
{
    pr_free(p->cav.a);
    pr_free(p->held.a);
    pr_free(p->repoint.a);
    pr_free(p->ifcs.a);
    memset(p, 0, sizeof *p);
}

static void part_clear(par_part *p)
{
    p->cav.n = p->held.n = p->repoint.n = p->ifcs.n = 0;
    p->boxed = 0;
}

void par_box_empty(double lo[3], double hi[3])
{
    for (int k = 0; k < 3; k++) {
        lo[k] = HUGE_VAL;
        hi[k] = -HUGE_VAL;
    }
}

void par_box_tet(const tm_mesh *m, uint32_t t, double lo[3], double hi[3])
{
    for (int i = 0; i < 4; i++) {
        uint32_t v = m->tets[t].v[i];
        if (v == TM_VINF || v >= m->nv)
            continue;
        const double *x = m->xyz + 3 * (size_t)v;
        for (int k = 0; k < 3; k++) {
            lo[k] = x[k] < lo[k] ? x[k] : lo[k];
            hi[k] = x[k] > hi[k] ? x[k] : hi[k];
        }
    }
}

void par_part_box(const tm_mesh *m, par_part *p)
{
    if (p->boxed == 0)
        par_box_empty(p->lo, p->hi);
    for (; p->boxed < p->held.n; p->boxed++)
        if (p->held.a[p->boxed] < m->nslots)
            par_box_tet(m, p->held.a[p->boxed], p->lo, p->hi);
}

/* ------------------------------------------------- left for the merge */

/* A check of tetrahedron t's vertices, so that an entry of par_cav_ctx.left
 * names the tetrahedron it was made for and not a later one in its slot. */
static uint32_t tet_check(const tm_mesh *m, uint32_t t)
{
    const uint32_t *v = m->tets[t].v;
    uint32_t h = 2166136261u;
    for (int k = 0; k < 4; k++)
        h = (h ^ v[k]) * 16777619u;
    return h == HMAP_NONE ? 0 : h;
}

static void left_forget(hmap *left, uint32_t t)
{
    uint32_t x;
    while ((x = hmap_get(left, (uint64_t)t + 1)) != HMAP_NONE)
        hmap_del(left, (uint64_t)t + 1, x);
}

/* 1 if tetrahedron t was left for the merge here and is still that bad
 * tetrahedron (marked TM_F_QUEUED with no queue holding it). */
static int is_left(const hmap *left, const tm_mesh *m, uint32_t t)
{
    return left && left->n && (m->flags[t] & TM_F_QUEUED) &&
           hmap_get(left, (uint64_t)t + 1) == tet_check(m, t);
}

int par_cav_mark_left(par_cav_ctx *cc, uint32_t t)
{
    left_forget(&cc->left, t);
    return hmap_put(&cc->left, (uint64_t)t + 1, tet_check(&cc->s->r.m, t));
}

static void unlock_held(tm_mesh *m, uint32_t owner, const u32list *held)
{
    for (size_t i = 0; i < held->n; i++) {
        uint32_t t = held->a[i];
        if (t < m->nslots && m->lock[t] == owner)
            tm_set_lock(m, t, 0);
    }
}

/* A participant's record of one cavity it takes part in. */
typedef struct par_rec {
    uint32_t owner;   /* 0 when the slot is free */
    uint32_t origin;  /* PE of the thread; next free slot when free */
    par_part part;
} par_rec;

/* ------------------------------------------------------------ serving */

static void mark_cavity(tm_mesh *m, const u32list *cav, int on)
{
    for (size_t i = 0; i < cav->n; i++) {
        if (on)
            m->flags[cav->a[i]] |= TM_F_CAVITY;
        else
            m->flags[cav->a[i]] &= (uint16_t)~TM_F_CAVITY;
    }
}

/* Continues the cavity of p (lock owner 'owner') from tetrahedron t,
 * reached through interface entry k (TM_NONE: the origin's start). The
 * part's cavity tetrahedra must carry TM_F_CAVITY (mark_cavity) so that
 * the search does not enter them again; new ones are appended (marked).
 * Returns REPLY_OK, REPLY_LOCKED, REPLY_DUPLICATE or a negative code. */
static int serve_from(par_cav_ctx *cc, par_part *pt, uint32_t owner, const double p[3],
                      uint32_t t, uint32_t k)
{
    tm_mesh *m = &cc->s->r.m;
    uint32_t lk = m->lock[t];
    if (lk == owner && (m->flags[t] & TM_F_CAVITY))
        return REPLY_OK; /* a cavity tetrahedron: the face is inside */
    if (lk != 0 && lk != owner)
        return REPLY_LOCKED;
    /* Free, or held as closure. Closure behind a face of the cavity is not
     * in conflict, but closure behind a subfacet (the constrained mode's
     * DT_BND_MARKED) may be, and met now from another side it belongs to
     * the cavity, as the sequential search would find it: test it. */
    int s = dt_conflict(m, t, p);
    if (s == 0)
        return REPLY_DUPLICATE;
    if (s < 0) {
        int rc = 0;
        if (lk == 0) {
            tm_set_lock(m, t, owner);
            rc = push(&pt->held, t);
        }
        if (!rc && k != TM_NONE)
            rc = push(&pt->ifcs, k); /* the face will face the origin */
        return rc;
    }
    dt_cavity *c = &cc->scratch;
    c->lock_owner = owner;
    int rc = dt_cavity_search(m, p, t, DT_LOCK | cc->search_flags, c);
    /* The search's locks now belong to the part (released with it). */
    for (size_t i = 0; !rc && i < c->nheld; i++)
        rc = push(&pt->held, c->held[i]);
    c->nheld = 0;
    if (rc < 0) {
        dt_cavity_abandon(m, c);
        return rc;
    }
    if (c->status == DT_LOCKED)
        return REPLY_LOCKED;
    if (c->status != DT_OK)
        return REPLY_DUPLICATE;
    for (size_t i = 0; !rc && i < c->ntets; i++)
        rc = push(&pt->cav, c->tets[i]);
    /* Closure faces: those not in conflict, and in the constrained mode
     * those of constraints and ghost walls. */
    for (size_t i = 0; !rc && i < c->nbnd; i++)
        if (c->bnd[i].reason == DT_BND_OUTSIDE || c->bnd[i].reason == DT_BND_MARKED)
            rc = push(&pt->repoint, c->bnd[i].outer);
    /* Keep the marks (the caller clears the part's at the end) and the
     * locks; forget the search. */
    c->pending = 0;
    c->ntets = 0;
    return rc;
}

/* ------------------------------------------------------- records */

static int rec_find(const par_cav_ctx *cc, uint32_t owner)
{
    uint32_t i = hmap_get(&cc->served, owner);
    return i == HMAP_NONE ? -1 : (int)i;
}

static int rec_new(par_cav_ctx *cc, uint32_t owner, uint32_t origin, uint32_t *out)
{
    uint32_t i;
    if (cc->rec_free != UINT32_MAX) {
        i = cc->rec_free;
        cc->rec_free = cc->recs[i].origin;
    } else {
        if (pdr_grow((void **)&cc->recs, &cc->cap_recs, cc->nrecs + 1, sizeof *cc->recs))
            return PDR_ENOMEM;
        i = (uint32_t)cc->nrecs++;
        memset(&cc->recs[i], 0, sizeof cc->recs[i]);
    }
    if (hmap_put(&cc->served, owner, i)) {
        cc->recs[i].origin = cc->rec_free;
        cc->rec_free = i;
        return PDR_ENOMEM;
    }
    cc->recs[i].owner = owner;
    cc->recs[i].origin = origin;
    part_clear(&cc->recs[i].part);
    *out = i;
    return 0;
}

static void rec_drop(par_cav_ctx *cc, uint32_t i)
{
    par_rec *r = &cc->recs[i];
    hmap_del(&cc->served, r->owner, i);
    unlock_held(&cc->s->r.m, r->owner, &r->part.held);
    part_clear(&r->part);
    r->owner = 0;
    r->origin = cc->rec_free;
    cc->rec_free = i;
}

/* --------------------------------------------------------- encoding */

/* Appends tetrahedra tets[0..nt-1] of this PE, with their vertices and
 * the subsegments and subfacets on them, to a reply; those in left (if not
 * NULL) go with WIRE_LEFT. */
/* The reply index of local vertex v, or HMAP_NONE: from the dense array
 * when put_tets made one, else from the map. */
static uint32_t vidx_get(const hmap *vidx, const uint32_t *dense, uint32_t v)
{
    if (dense)
        return dense[v] ? dense[v] - 1 : HMAP_NONE;
    return hmap_get(vidx, (uint64_t)v + 1);
}

static int put_tets(const par_sub *s, const hmap *left, const uint32_t *tets, size_t nt,
                    pr_buf *b)
{
    const tm_mesh *m = &s->r.m;
    const bd_set *bd = &s->r.bd;
    hmap vidx = {0};   /* local vertex + 1 -> reply index */
    hmap seen = {0};   /* piece key -> 1 */
    u32list verts = {0};
    int rc = 0;
    /* A band (par_cav_give) has thousands of tetrahedra: an array over
     * the vertices (reply index + 1, 0 for none) costs less than the map
     * there; a cavity's few keep the map. */
    uint32_t *dense = NULL;
    if (nt >= PUT_TETS_DENSE) {
        dense = pr_calloc(m->nv, sizeof *dense);
        if (!dense)
            return PDR_ENOMEM;
    }
    for (size_t i = 0; i < nt && !rc; i++)
        for (int k = 0; k < 4 && !rc; k++) {
            uint32_t v = m->tets[tets[i]].v[k];
            if (v == TM_VINF || vidx_get(&vidx, dense, v) != HMAP_NONE)
                continue;
            if (dense)
                dense[v] = (uint32_t)verts.n + 1;
            else
                rc = hmap_put(&vidx, (uint64_t)v + 1, (uint32_t)verts.n);
            if (!rc)
                rc = push(&verts, v);
        }
    if (rc)
        goto out;
    /* Vertices: reply index 0 is the infinite vertex, so indices shift
     * by one. */
    pr_put_u32(b, (uint32_t)verts.n);
    for (size_t i = 0; i < verts.n; i++) {
        uint32_t v = verts.a[i];
        pr_put_u64(b, m->gid[v]);
        pr_put_f64_array(b, tm_xyz(m, v), 3);
        uint32_t rb;
        memcpy(&rb, &bd->vrins[v], sizeof rb);
        pr_put_u32(b, rb);
        pr_put_u32(b, bd->vfeat[v]);
        pr_put_u8(b, bd->vkind[v]);
    }
    pr_put_u32(b, (uint32_t)nt);
    u32list pieces = {0};
    for (size_t i = 0; i < nt && !rc; i++) {
        uint32_t t = tets[i];
        const tm_tet *T = &m->tets[t];
        uint16_t fl = m->flags[t];
        for (int k = 0; k < 4; k++) {
            uint32_t v = T->v[k];
            pr_put_u32(b, v == TM_VINF ? 0 : vidx_get(&vidx, dense, v) + 1);
        }
        for (int k = 0; k < 4; k++)
            pr_put_i32(b, tm_face_marker(m, t, k));
        for (int k = 0; k < 4; k++) {
            tm_link l = T->n[k];
            uint32_t pe = s->rank;
            if (l == TM_LINK_NONE || l == TM_LINK_UNSET)
                pe = PAR_PE_NONE;
            else if (tm_is_special(l))
                pe = s->ifc[l - TM_LINK_SPECIAL].pe;
            pr_put_u32(b, pe);
        }
        uint16_t wire = (uint16_t)(fl & TRAVEL_FLAGS);
        if (is_left(left, m, t))
            wire |= WIRE_LEFT;
        pr_put_u16(b, wire);
        pr_put_u16(b, s->r.region ? s->r.region[t] : 0);
        /* Pieces on this tetrahedron, each once per reply. */
        for (int e = 0; e < 6 && !rc; e++) {
            if (!(fl & TM_F_SUBSEG(e)))
                continue;
            uint32_t a = T->v[tm_edge_vtx[e][0]], c = T->v[tm_edge_vtx[e][1]];
            uint32_t id = bd_find_subseg(bd, a, c);
            if (id == BD_NONE || hmap_get(&seen, ((uint64_t)id << 1 | 0) + 1) != HMAP_NONE)
                continue;
            rc = hmap_put(&seen, ((uint64_t)id << 1 | 0) + 1, 1);
            if (!rc)
                rc = push(&pieces, id << 1 | 0);
        }
        for (int k = 0; k < 4 && !rc; k++) {
            if (!(fl & TM_F_FACEMARK(k)))
                continue;
            uint32_t id = bd_find_subfac(bd, T->v[tm_face_vtx[k][0]], T->v[tm_face_vtx[k][1]],
                                         T->v[tm_face_vtx[k][2]]);
            if (id == BD_NONE || hmap_get(&seen, ((uint64_t)id << 1 | 1) + 1) != HMAP_NONE)
                continue;
            rc = hmap_put(&seen, ((uint64_t)id << 1 | 1) + 1, 1);
            if (!rc)
                rc = push(&pieces, id << 1 | 1);
        }
    }
    pr_put_u32(b, (uint32_t)pieces.n);
    for (size_t i = 0; i < pieces.n && !rc; i++) {
        uint32_t id = pieces.a[i] >> 1;
        if (pieces.a[i] & 1) {
            const bd_subfac *f = &bd->facs[id];
            pr_put_u8(b, 3);
            for (int k = 0; k < 3; k++)
                pr_put_u32(b, vidx_get(&vidx, dense, f->v[k]) + 1);
            pr_put_u32(b, f->facet);
            pr_put_u16(b, f->flags);
        } else {
            const bd_subseg *g = &bd->segs[id];
            pr_put_u8(b, 2);
            for (int k = 0; k < 2; k++)
                pr_put_u32(b, vidx_get(&vidx, dense, g->v[k]) + 1);
            pr_put_u32(b, 0);
            pr_put_u32(b, g->seg);
            pr_put_u16(b, g->flags);
        }
    }
    pr_free(pieces.a);
out:
    pr_free(dense);
    pr_free(verts.a);
    hmap_free(&vidx);
    hmap_free(&seen);
    if (!rc && b->err)
        rc = PDR_ENOMEM;
    return rc;
}

/* Decodes the tetrahedra of a reply into c's gathered lists. */
static int get_tets(par_cav *c, pr_reader *rd, uint32_t src)
{
    uint32_t nv, nt, np;
    if (pr_get_count(rd, MAX_CAV_TETS * 4, 8 + 24 + 4 + 4 + 1, &nv))
        return PDR_EPARSE;
    /* Reply vertex i + 1 -> gathered vertex index; 0 is infinite. */
    uint32_t *map = pr_malloc(((size_t)nv + 1) * sizeof *map);
    if (!map)
        return PDR_ENOMEM;
    map[0] = UINT32_MAX;
    int rc = 0;
    for (uint32_t i = 0; i < nv && !rc; i++) {
        par_gvert g;
        uint32_t rb;
        pr_get_u64(rd, &g.gid);
        pr_get_f64_array(rd, g.xyz, 3);
        pr_get_u32(rd, &rb);
        memcpy(&g.rins, &rb, sizeof rb);
        pr_get_u32(rd, &g.feat);
        pr_get_u8(rd, &g.kind);
        if (rd->err || g.gid == PAR_GID_INF || !isfinite(g.xyz[0]) || !isfinite(g.xyz[1]) ||
            !isfinite(g.xyz[2])) {
            rc = PDR_EPARSE;
            break;
        }
        uint32_t gi = hmap_get(&c->gvmap, g.gid);
        if (gi == HMAP_NONE) {
            gi = (uint32_t)c->ngv;
            if (pdr_grow((void **)&c->gv, &c->cap_gv, c->ngv + 1, sizeof *c->gv) ||
                hmap_put(&c->gvmap, g.gid, gi)) {
                rc = PDR_ENOMEM;
                break;
            }
            c->gv[c->ngv++] = g;
        }
        map[i + 1] = gi;
    }
    if (!rc && pr_get_count(rd, MAX_CAV_TETS, 16 + 16 + 16 + 4, &nt))
        rc = PDR_EPARSE;
    if (!rc && pdr_grow((void **)&c->gt, &c->cap_gt, c->ngt + nt, sizeof *c->gt))
        rc = PDR_ENOMEM;
    for (uint32_t i = 0; i < nt && !rc; i++) {
        par_gtet *g = &c->gt[c->ngt];
        uint32_t vi[4];
        pr_get_u32_array(rd, vi, 4);
        pr_get_i32_array(rd, g->marker, 4);
        pr_get_u32_array(rd, g->nbr, 4);
        pr_get_u16(rd, &g->flags);
        pr_get_u16(rd, &g->region);
        if (rd->err) {
            rc = PDR_EPARSE;
            break;
        }
        for (int k = 0; k < 4; k++) {
            if (vi[k] > nv || g->marker[k] < 0) {
                rc = PDR_EPARSE;
                break;
            }
            g->v[k] = vi[k] == 0 ? UINT32_MAX : map[vi[k]];
        }
        /* four distinct vertices (two listed ones may share a gid) */
        for (int k = 0; k < 4 && !rc; k++)
            for (int j = k + 1; j < 4; j++)
                if (g->v[k] == g->v[j])
                    rc = PDR_EPARSE;
        if (rc)
            break;
        g->src = src;
        c->ngt++;
    }
    if (!rc && pr_get_count(rd, MAX_CAV_TETS * 10, 1 + 12 + 4 + 2, &np))
        rc = PDR_EPARSE;
    if (!rc && pdr_grow((void **)&c->gp, &c->cap_gp, c->ngp + np, sizeof *c->gp))
        rc = PDR_ENOMEM;
    for (uint32_t i = 0; i < np && !rc; i++) {
        par_gpiece *g = &c->gp[c->ngp];
        uint32_t vi[3];
        pr_get_u8(rd, &g->nv);
        pr_get_u32_array(rd, vi, 3);
        pr_get_u32(rd, &g->feat);
        pr_get_u16(rd, &g->flags);
        if (rd->err || (g->nv != 2 && g->nv != 3)) {
            rc = PDR_EPARSE;
            break;
        }
        for (int k = 0; k < g->nv; k++) {
            if (vi[k] == 0 || vi[k] > nv) {
                rc = PDR_EPARSE;
                break;
            }
            g->v[k] = map[vi[k]];
        }
        if (!rc && (g->v[0] == g->v[1] || (g->nv == 3 && (g->v[2] == g->v[0] || g->v[2] == g->v[1]))))
            rc = PDR_EPARSE;
        /* its input feature exists (known only with a submesh) */
        const plc *p = c->cc->s ? c->cc->s->r.p : NULL;
        if (!rc && p && g->feat >= (g->nv == 2 ? p->nseg : p->nfacet))
            rc = PDR_EPARSE;
        if (rc)
            break;
        c->ngp++;
    }
    pr_free(map);
    return rc;
}

/* ------------------------------------------------------- face records */

/* A face of the cavity: seen once (a boundary face, or a frontier face not
 * yet resolved) or twice (inside the cavity). Sides are local tetrahedra
 * (own cavity tetrahedra of the origin) or gathered ones. */
typedef struct par_cav_face {
    uint64_t key[3];
    uint32_t tet[2];   /* local slot, or gathered index */
    uint8_t face[2];
    uint8_t gathered[2];
    uint8_t count;
    uint8_t asked;     /* sent to (or searched by) the PE holding the far side */
    uint32_t pe;       /* PE holding the far side of the first side */
} par_cav_face;

typedef struct par_cav_req {
    uint32_t pe;
    uint32_t face; /* index into c->face */
} par_cav_req;

struct face_match {
    const par_cav *c;
    const uint64_t *key;
    uint32_t found;
};

static int face_match(void *arg, uint32_t i)
{
    struct face_match *a = arg;
    if (par_key_eq(a->c->face[i].key, a->key)) {
        a->found = i;
        return 1;
    }
    return 0;
}

static uint32_t face_find(const par_cav *c, const uint64_t key[3])
{
    struct face_match a = {c, key, UINT32_MAX};
    hmap_each(&c->facemap, par_key_hash(key), face_match, &a);
    return a.found;
}

/* Records a side of the face with this key; pe is the PE holding the far
 * side as this side sees it, asked whether that PE has already searched
 * it. */
static int face_add(par_cav *c, const uint64_t key[3], uint32_t tet, int face, int gathered,
                    uint32_t pe, int asked)
{
    uint32_t found = face_find(c, key);
    if (found != UINT32_MAX) {
        par_cav_face *f = &c->face[found];
        if (f->count >= 2)
            return PDR_ETOPOLOGY;
        f->tet[1] = tet;
        f->face[1] = (uint8_t)face;
        f->gathered[1] = (uint8_t)gathered;
        f->count = 2;
        return 0;
    }
    if (pdr_grow((void **)&c->face, &c->cap_face, c->nface + 1, sizeof *c->face))
        return PDR_ENOMEM;
    uint32_t i = (uint32_t)c->nface;
    if (hmap_put(&c->facemap, par_key_hash(key), i))
        return PDR_ENOMEM;
    par_cav_face *f = &c->face[c->nface++];
    memcpy(f->key, key, sizeof f->key);
    f->tet[0] = tet;
    f->face[0] = (uint8_t)face;
    f->gathered[0] = (uint8_t)gathered;
    f->count = 1;
    f->asked = (uint8_t)asked;
    f->pe = pe;
    return 0;
}

/* The key of face k of gathered tetrahedron g. */
static void gathered_key(const par_cav *c, const par_gtet *g, int k, uint64_t key[3])
{
    for (int j = 0; j < 3; j++) {
        uint32_t v = g->v[tm_face_vtx[k][j]];
        key[j] = v == UINT32_MAX ? PAR_GID_INF : c->gv[v].gid;
    }
    par_key_sort(key);
}

/* Records the interface faces of own cavity tetrahedra own.cav[from..]
 * (their other faces lead to local tetrahedra: the cavity's inside or the
 * origin's closure, both unchanged by the migration). */
static int add_own_faces(par_cav *c, size_t from)
{
    par_sub *s = c->cc->s;
    const tm_mesh *m = &s->r.m;
    for (size_t i = from; i < c->own.cav.n; i++) {
        uint32_t t = c->own.cav.a[i];
        for (int k = 0; k < 4; k++) {
            tm_link l = m->tets[t].n[k];
            if (!tm_is_special(l) || l == TM_LINK_NONE || l == TM_LINK_UNSET)
                continue;
            uint64_t key[3];
            par_face_key(s, t, k, key);
            int rc = face_add(c, key, t, k, 0, s->ifc[l - TM_LINK_SPECIAL].pe, 0);
            if (rc)
                return rc;
        }
    }
    return 0;
}

static int add_gathered_faces(par_cav *c, size_t from)
{
    for (size_t i = from; i < c->ngt; i++) {
        const par_gtet *g = &c->gt[i];
        for (int k = 0; k < 4; k++) {
            if (g->nbr[k] == PAR_PE_NONE || g->nbr[k] >= c->cc->s->size)
                return PDR_ETOPOLOGY;
            uint64_t key[3];
            gathered_key(c, g, k, key);
            /* A face whose far side is on the same PE was searched there. */
            int rc = face_add(c, key, (uint32_t)i, k, 1, g->nbr[k], g->nbr[k] == g->src);
            if (rc)
                return rc;
        }
    }
    return 0;
}

static int has(const u32list *l, uint32_t x)
{
    for (size_t i = 0; i < l->n; i++)
        if (l->a[i] == x)
            return 1;
    return 0;
}

static int cmp_req(const void *a, const void *b)
{
    const par_cav_req *x = a, *y = b;
    return x->pe < y->pe ? -1 : x->pe > y->pe ? 1 : (x->face > y->face) - (x->face < y->face);
}

static void send_all(par_cav_ctx *cc, const u32list *parts, int type, uint32_t owner)
{
    uint8_t msg[5];
    msg[0] = (uint8_t)type;
    pr_store_u32(msg + 1, owner);
    unsigned h = type == MSG_MIGRATE ? cc->h_migrate : cc->h_abort;
    for (size_t i = 0; i < parts->n; i++)
        am_send(cc->am, (int)parts->a[i], h, msg, sizeof msg);
}

/* ------------------------------------------------------------ import */

/* With the refinement's check_each_step (PDR_REF_CHECK): the problems
 * ref_consistency and par_verify_facets count on this PE, 0 when off. */
static size_t dbg_count(par_sub *s)
{
    if (!s->r.o.check_each_step)
        return 0;
    return ref_consistency(&s->r, NULL, 0) + par_verify_facets(s, NULL);
}

/* Describes on the check's log the problems that 'what' (an import or a
 * migration of cavity owner, ntets tetrahedra) added to the count before
 * it, if any. */
static void dbg_report(par_sub *s, size_t before, const char *what, uint32_t owner,
                       size_t ntets)
{
    FILE *log = s->r.o.log;
    if (!log || dbg_count(s) <= before)
        return;
    fprintf(log, "PE %u: the %s of cavity %u (%zu tetrahedra) brought these problems:\n",
            s->rank, what, owner, ntets);
    ref_consistency(&s->r, log, 0);
    par_verify_facets(s, log);
}

/* Makes the gathered tetrahedra local tetrahedra of this PE, linked to the
 * origin's own cavity, to its closure and, by new interface faces, to the
 * closure on other PEs. */
static int import(par_cav *c)
{
    par_cav_ctx *cc = c->cc;
    par_sub *s = cc->s;
    ref_mesher *r = &s->r;
    tm_mesh *m = &r->m;
    uint32_t *loc = pr_malloc((c->ngv ? c->ngv : 1) * sizeof *loc);
    uint32_t *newt = pr_malloc((c->ngt ? c->ngt : 1) * sizeof *newt);
    int rc = loc && newt ? 0 : PDR_ENOMEM;
    size_t problems0 = dbg_count(s);
    for (size_t i = 0; i < c->ngv && !rc; i++) {
        const par_gvert *g = &c->gv[i];
        rc = par_sub_vertex(s, g->gid, g->xyz, g->kind, g->feat, g->rins, &loc[i]);
    }
    if (!rc)
        rc = tm_room(m, c->ngt);
    if (!rc)
        rc = tm_marker_room(m, c->ngt);
    if (!rc)
        rc = pdr_grow((void **)&c->own.held.a, &c->own.held.cap, c->own.held.n + c->ngt,
                      sizeof *c->own.held.a);
    if (rc)
        goto out;
    for (size_t i = 0; i < c->ngt; i++) {
        const par_gtet *g = &c->gt[i];
        uint32_t t = tm_alloc_tet(m);
        tm_tet *T = &m->tets[t];
        for (int k = 0; k < 4; k++) {
            T->v[k] = g->v[k] == UINT32_MAX ? TM_VINF : loc[g->v[k]];
            T->n[k] = TM_LINK_UNSET;
            tm_set_marker(m, t, k, g->marker[k]); /* room above */
        }
        /* A tetrahedron left for the merge stays so (marked, in no queue):
         * tried again here, its cavity would come back and forth between
         * the PEs without end (turbine.off on 2 PEs, issue 12). */
        int left = (g->flags & WIRE_LEFT) && (g->flags & TM_F_QUEUED);
        uint16_t keep = left ? TRAVEL_FLAGS : (uint16_t)(TRAVEL_FLAGS & ~TM_F_QUEUED);
        m->flags[t] = (uint16_t)(g->flags & keep);
        m->nghost += (uint32_t)tm_is_ghost(m, t);
        tm_set_lock(m, t, c->owner);
        c->own.held.a[c->own.held.n++] = t;
        newt[i] = t;
    }
    rc = ref_region_room(r);
    if (rc)
        goto out;
    for (size_t i = 0; i < c->ngt; i++) {
        uint32_t t = newt[i];
        if (r->region)
            r->region[t] = c->gt[i].region;
        for (int k = 0; k < 4; k++) {
            uint32_t v = m->tets[t].v[k];
            if (v != TM_VINF &&
                (m->vhint[v] == TM_NONE || m->vhint[v] >= m->nslots || tm_is_dead(m, m->vhint[v])))
                m->vhint[v] = t;
        }
    }
    /* Faces. */
    for (size_t i = 0; i < c->nface && !rc; i++) {
        par_cav_face *f = &c->face[i];
        uint32_t t0 = f->gathered[0] ? newt[f->tet[0]] : f->tet[0];
        int k0 = f->face[0];
        if (f->count == 2) {
            uint32_t t1 = f->gathered[1] ? newt[f->tet[1]] : f->tet[1];
            int k1 = f->face[1];
            if (!f->gathered[0] && tm_is_special(m->tets[t0].n[k0]))
                par_sub_drop_iface(s, m->tets[t0].n[k0] - TM_LINK_SPECIAL);
            if (!f->gathered[1] && tm_is_special(m->tets[t1].n[k1]))
                par_sub_drop_iface(s, m->tets[t1].n[k1] - TM_LINK_SPECIAL);
            m->tets[t0].n[k0] = tm_mklink(t1, k1);
            m->tets[t1].n[k1] = tm_mklink(t0, k0);
            continue;
        }
        if (!f->gathered[0])
            continue; /* own face to a closure elsewhere: unchanged */
        if (f->pe == s->rank) {
            /* The far side is this PE's own closure. */
            uint32_t k = par_sub_find_iface(s, f->key);
            if (k == PAR_PE_NONE) {
                rc = PDR_ETOPOLOGY;
                break;
            }
            tm_link w = s->ifc[k].local;
            par_sub_drop_iface(s, k);
            m->tets[t0].n[k0] = w;
            m->tets[tm_ltet(w)].n[tm_lface(w)] = tm_mklink(t0, k0);
        } else {
            rc = par_sub_add_iface(s, t0, k0, f->pe);
        }
    }
    for (size_t i = 0; i < c->ngt && !rc; i++)
        for (int k = 0; k < 4; k++)
            if (m->tets[newt[i]].n[k] == TM_LINK_UNSET)
                rc = PDR_ETOPOLOGY;
    if (rc)
        goto out;
    /* Subsegments and subfacets. */
    bd_set *bd = &r->bd;
    for (size_t i = 0; i < c->ngp && !rc; i++) {
        const par_gpiece *g = &c->gp[i];
        uint32_t a = loc[g->v[0]], b = loc[g->v[1]], id;
        uint16_t keep = g->flags & (BD_F_MISSING | BD_F_TOLERATED);
        if (g->nv == 2) {
            id = bd_find_subseg(bd, a, b);
            if (id == BD_NONE)
                rc = bd_add_subseg(bd, a, b, g->feat, &id);
            if (!rc) {
                bd->segs[id].flags |= keep;
                if ((g->flags & BD_F_QUEUED) && !(bd->segs[id].flags & BD_F_QUEUED) &&
                    cc->requeue)
                    rc = cc->requeue(cc->requeue_arg, 1, id);
            }
        } else {
            uint32_t d = loc[g->v[2]];
            id = bd_find_subfac(bd, a, b, d);
            if (id == BD_NONE)
                rc = bd_add_subfac(bd, a, b, d, g->feat, &id);
            if (!rc) {
                bd->facs[id].flags |= keep;
                if ((g->flags & BD_F_QUEUED) && !(bd->facs[id].flags & BD_F_QUEUED) &&
                    cc->requeue)
                    rc = cc->requeue(cc->requeue_arg, 2, id);
            }
        }
    }
    /* Every tetrahedron that arrives is looked at, not only those that
     * were queued where they come from: one whose item a thread there had
     * taken off the queue (the flag goes at the pop) and not yet finished
     * (starting, backing off after setbacks) travels unmarked, and when
     * the cavity that took it did not destroy it, no queue held it any
     * more: 2-PE runs with latency left one or two tetrahedra above the
     * bound in about 1 of 250 runs. Those left for the merge stay so. */
    for (size_t i = 0; i < c->ngt && !rc; i++) {
        uint16_t fl = c->gt[i].flags;
        if ((fl & TM_F_QUEUED) && (fl & WIRE_LEFT))
            rc = par_cav_mark_left(cc, newt[i]);
        else if (cc->requeue)
            rc = cc->requeue(cc->requeue_arg, 0, newt[i]);
    }
    cc->st.tets_in += c->ngt;
    if (r->o.check_each_step)
        dbg_report(s, problems0, "import", c->owner, c->ngt);
out:
    pr_free(loc);
    pr_free(newt);
    return rc;
}

/* ------------------------------------------------------ the origin side */

static uint32_t new_owner(par_cav_ctx *cc)
{
    cc->seq = (cc->seq + 1) & 0xFFFFFu;
    if (cc->seq == 0)
        cc->seq = 1;
    return ((cc->s->rank + 1) << 20) | cc->seq;
}

void par_cav_release(par_cav *c)
{
    if (!c->owner)
        return;
    unlock_held(&c->cc->s->r.m, c->owner, &c->own.held);
    c->own.held.n = 0;
    c->own.boxed = 0;
    c->owner = 0;
}

static int boxes_meet(const par_part *p, const double lo[3], const double hi[3], double margin)
{
    for (int k = 0; k < 3; k++)
        if (lo[k] > p->hi[k] + margin || hi[k] < p->lo[k] - margin)
            return 0;
    return 1;
}

int par_cav_near_locks(par_cav_ctx *cc, const double lo[3], const double hi[3], double margin)
{
    const tm_mesh *m = &cc->s->r.m;
    for (size_t i = 0; i < cc->ncavs; i++) {
        par_part *p = &cc->cavs[i]->own;
        par_part_box(m, p);
        if (p->held.n && boxes_meet(p, lo, hi, margin))
            return 1;
    }
    for (size_t i = 0; i < cc->nrecs; i++) {
        par_rec *r = &cc->recs[i];
        if (!r->owner)
            continue;
        par_part_box(m, &r->part);
        if (r->part.held.n && boxes_meet(&r->part, lo, hi, margin))
            return 1;
    }
    return 0;
}

static void reset_attempt(par_cav *c)
{
    part_clear(&c->own);
    c->ngt = c->ngv = c->ngp = c->nface = c->nreq = 0;
    c->parts.n = 0;
    /* Only a distributed attempt fills the maps: a local one (nearly
     * every attempt) frees nothing. */
    if (c->gvmap.cap)
        hmap_free(&c->gvmap);
    if (c->facemap.cap)
        hmap_free(&c->facemap);
    c->pending = c->failed = c->err = c->distributed = 0;
}

/* Serves the requests of this round that lead back to this PE. */
static int serve_own(par_cav *c)
{
    par_cav_ctx *cc = c->cc;
    par_sub *s = cc->s;
    tm_mesh *m = &s->r.m;
    int st = REPLY_OK;
    mark_cavity(m, &c->own.cav, 1);
    for (size_t i = 0; i < c->nreq && st == REPLY_OK; i++) {
        if (c->req[i].pe != s->rank)
            continue;
        uint32_t k = par_sub_find_iface(s, c->face[c->req[i].face].key);
        if (k == PAR_PE_NONE) {
            st = REPLY_STALE;
            break;
        }
        st = serve_from(cc, &c->own, c->owner, c->p, tm_ltet(s->ifc[k].local), k);
    }
    mark_cavity(m, &c->own.cav, 0);
    return st;
}

/* The origin's own search from start into d (locking cavity and ring
 * with c's owner, the locks handed to c->own). Returns REPLY_* or a
 * negative code; *remote says whether the cavity reached an interface. */
static int own_search(par_cav *c, const double p[3], uint32_t start, dt_cavity *d, int *remote)
{
    tm_mesh *m = &c->cc->s->r.m;
    *remote = 0;
    d->lock_owner = c->owner;
    /* Most cavities lie on this PE alone and are committed before
     * anything else runs here: for those, checking that no other cavity
     * holds a lock is enough. Only one that reaches another PE, and so
     * waits, is searched again taking its locks. */
    unsigned fl = c->cc->search_flags;
    int rc = dt_cavity_search(m, p, start, DT_CHECK_LOCKS | fl, d);
    int local = !rc && d->status == DT_OK && d->nremote == 0;
    if (!rc && d->status == DT_OK && !local) {
        rc = dt_cavity_search(m, p, start, DT_LOCK | fl, d);
        *remote = 1; /* the same cavity, if it is one (DT_OK) */
    }
    for (size_t i = 0; !rc && i < d->nheld; i++)
        rc = push(&c->own.held, d->held[i]);
    d->nheld = 0;
    if (rc < 0) {
        dt_cavity_abandon(m, d);
        return rc;
    }
    if (d->status == DT_LOCKED)
        return REPLY_LOCKED;
    if (d->status != DT_OK)
        return REPLY_DUPLICATE;
    /* A local cavity searched for the caller is used as it stands
     * (par_cav_gather); only one that goes on from here keeps a copy. */
    int keep = *remote || d == &c->cc->scratch;
    for (size_t i = 0; !rc && keep && i < d->ntets; i++)
        rc = push(&c->own.cav, d->tets[i]);
    return rc;
}

int par_cav_gather(par_cav *c, const double p[3], uint32_t start, dt_cavity *search)
{
    par_cav_ctx *cc = c->cc;
    par_sub *s = cc->s;
    tm_mesh *m = &s->r.m;
    par_cav_release(c);
    reset_attempt(c);
    c->owner = new_owner(cc);
    memcpy(c->p, p, sizeof c->p);

    dt_cavity *d = search ? search : &cc->scratch;
    int remote;
    int st = own_search(c, p, start, d, &remote);
    if (st == REPLY_DUPLICATE) {
        /* p is a vertex of this PE: the caller's own search meets it
         * too and deals with it as it would alone. */
        cc->st.gathers_local++;
        return PAR_CAV_LOCAL;
    }
    if (st == REPLY_OK && !remote && search) {
        /* A local cavity, searched and locked: the caller uses it as it
         * stands (one search per insertion, not two). */
        cc->st.gathers_local++;
        return PAR_CAV_SEARCHED;
    }
    if (st >= 0)
        dt_cavity_abandon(m, d); /* marks off; the locks are c's */
    int rc = st < 0 ? st : 0;
    if (!rc && st == REPLY_OK)
        rc = add_own_faces(c, 0);
    while (!rc && st == REPLY_OK) {
        c->nreq = 0;
        for (size_t i = 0; i < c->nface && !rc; i++) {
            par_cav_face *f = &c->face[i];
            if (f->count != 1 || f->asked)
                continue;
            f->asked = 1;
            rc = pdr_grow((void **)&c->req, &c->cap_req, c->nreq + 1, sizeof *c->req);
            if (!rc)
                c->req[c->nreq++] = (par_cav_req){f->pe, (uint32_t)i};
        }
        if (rc || c->nreq == 0)
            break;
        qsort(c->req, c->nreq, sizeof *c->req, cmp_req);
        size_t from = c->own.cav.n;
        st = serve_own(c);
        if (st < 0)
            rc = st;
        if (rc || st != REPLY_OK)
            break;
        rc = add_own_faces(c, from);
        /* One GATHER per other PE. */
        size_t ngt0 = c->ngt;
        c->pending = 0;
        for (size_t i = 0; i < c->nreq && !rc;) {
            uint32_t pe = c->req[i].pe;
            size_t j = i;
            while (j < c->nreq && c->req[j].pe == pe)
                j++;
            if (pe == s->rank) {
                i = j;
                continue;
            }
            pr_buf b = PR_BUF_INIT;
            pr_msg_begin(&b, MSG_GATHER);
            pr_put_u32(&b, c->owner);
            pr_put_f64_array(&b, p, 3);
            pr_put_u32(&b, (uint32_t)(c->max_import < UINT32_MAX ? c->max_import : 0));
            pr_put_u32(&b, (uint32_t)(j - i));
            for (size_t q = i; q < j; q++)
                pr_put_u64_array(&b, c->face[c->req[q].face].key, 3);
            if (b.err)
                rc = PDR_ENOMEM;
            else if (am_send(cc->am, (int)pe, cc->h_gather, b.data, b.len))
                rc = PDR_EIO;
            pr_buf_free(&b);
            if (!rc && !has(&c->parts, pe))
                rc = push(&c->parts, pe);
            c->pending++;
            c->distributed = 1;
            i = j;
        }
        if (rc || c->pending == 0)
            continue;
        cc->st.rounds++;
        if (c->slot == UINT32_MAX) {
            uint32_t slot = (uint32_t)cc->ncavs;
            rc = pdr_grow((void **)&cc->cavs, &cc->cap_cavs, cc->ncavs + 1, sizeof *cc->cavs);
            if (!rc)
                rc = hmap_put(&cc->origin, c->owner, slot);
            if (rc)
                break;
            cc->cavs[cc->ncavs++] = c;
            c->slot = slot;
        }
        if (cc->on_block)
            cc->on_block(cc->hook_arg, c);
        cc->nblocked_dist++;
        double tw = pdr_now();
        int wrc = am_wait(cc->am, c->fut);
        tw = pdr_now() - tw;
        cc->rtt = cc->rtt > 0 ? 0.9 * cc->rtt + 0.1 * tw : tw;
        cc->nblocked_dist--;
        am_future_reset(c->fut);
        if (cc->on_resume)
            cc->on_resume(cc->hook_arg, c);
        if (wrc)
            rc = PDR_EIO;
        else if (c->err)
            rc = c->err;
        else if (c->failed)
            st = c->failed;
        else
            rc = add_gathered_faces(c, ngt0);
        if (!rc && st == REPLY_OK && c->max_import && c->ngt > c->max_import)
            st = REPLY_TOO_BIG;
    }
    if (c->slot != UINT32_MAX) {
        /* Unregister: move the last registered attempt into our slot. */
        uint32_t slot = c->slot;
        hmap_del(&cc->origin, c->owner, slot);
        par_cav *last = cc->cavs[cc->ncavs - 1];
        if (last != c) {
            hmap_del(&cc->origin, last->owner, last->slot);
            cc->cavs[slot] = last;
            last->slot = slot;
            hmap_put(&cc->origin, last->owner, slot);
        }
        cc->ncavs--;
        c->slot = UINT32_MAX;
    }
    if (!rc && st == REPLY_OK) {
        if (c->ngt)
            rc = import(c);
        if (!rc) {
            send_all(cc, &c->parts, c->ngt ? MSG_MIGRATE : MSG_ABORT, c->owner);
            if (c->distributed)
                cc->st.gathers_dist++;
            else
                cc->st.gathers_local++;
            return PAR_CAV_LOCAL;
        }
    }
    send_all(cc, &c->parts, MSG_ABORT, c->owner);
    par_cav_release(c);
    if (rc)
        return rc;
    if (st == REPLY_TOO_BIG) {
        cc->st.too_big++;
        return PAR_CAV_TOO_BIG;
    }
    if (st == REPLY_STALE)
        cc->st.setbacks_stale++;
    else
        cc->st.setbacks_locked++;
    return PAR_CAV_SETBACK;
}

/* ------------------------------------------------------------ handlers */

static void on_gather(am_ctx_t *am, const am_msg_t *msg, void *arg)
{
    par_cav_ctx *cc = arg;
    par_sub *s = cc->s;
    tm_mesh *m = &s->r.m;
    am_time_begin(am, cc->cat_service);
    pr_reader rd;
    uint32_t owner, nkeys, max;
    double p[3];
    pr_msg_open(&rd, msg->data, msg->len, MSG_GATHER);
    pr_get_u32(&rd, &owner);
    pr_get_f64_array(&rd, p, 3);
    pr_get_u32(&rd, &max);
    if (rd.err || owner == 0 || pr_get_count(&rd, MAX_CAV_KEYS, 24, &nkeys) ||
        !isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2])) {
        am_time_end(am, cc->cat_service);
        return; /* malformed: the runtime counts nothing more we can do */
    }
    cc->st.served++;
    int idx = rec_find(cc, owner);
    uint32_t ri = 0;
    int rc = 0;
    if (idx >= 0)
        ri = (uint32_t)idx;
    else
        rc = rec_new(cc, owner, (uint32_t)msg->src, &ri);
    int have_rec = !rc;
    int st = REPLY_OK;
    size_t from = 0;
    if (have_rec) {
        par_part *pt = &cc->recs[ri].part;
        from = pt->cav.n;
        mark_cavity(m, &pt->cav, 1);
        for (uint32_t i = 0; i < nkeys && st == REPLY_OK; i++) {
            uint64_t key[3];
            if (pr_get_u64_array(&rd, key, 3)) {
                st = REPLY_STALE;
                break;
            }
            uint32_t k = par_sub_find_iface(s, key);
            if (k == PAR_PE_NONE) {
                st = REPLY_STALE;
                break;
            }
            st = serve_from(cc, pt, owner, p, tm_ltet(s->ifc[k].local), k);
        }
        mark_cavity(m, &pt->cav, 0);
        if (st < 0)
            st = REPLY_STALE; /* out of memory here: the origin backs off */
        if (st == REPLY_OK && max && pt->cav.n - from > max)
            st = REPLY_TOO_BIG; /* not sent: the origin gives it up */
    } else {
        st = REPLY_STALE;
    }
    /* A failed search keeps nothing: release this PE's locks at once (the
     * origin's ABORT then finds no record). */
    if (have_rec && st != REPLY_OK)
        rec_drop(cc, ri);
    pr_buf b = PR_BUF_INIT;
    pr_msg_begin(&b, MSG_REPLY);
    pr_put_u32(&b, owner);
    pr_put_u8(&b, (uint8_t)st);
    if (st == REPLY_OK && put_tets(cc->s, &cc->left, cc->recs[ri].part.cav.a + from,
                                     cc->recs[ri].part.cav.n - from, &b))
        b.err = PR_ENOMEM;
    if (!b.err)
        am_send(am, msg->src, cc->h_reply, b.data, b.len);
    pr_buf_free(&b);
    am_time_end(am, cc->cat_service);
}

static void on_reply(am_ctx_t *am, const am_msg_t *msg, void *arg)
{
    (void)am;
    par_cav_ctx *cc = arg;
    pr_reader rd;
    uint32_t owner;
    uint8_t st;
    pr_msg_open(&rd, msg->data, msg->len, MSG_REPLY);
    pr_get_u32(&rd, &owner);
    pr_get_u8(&rd, &st);
    if (rd.err)
        return;
    uint32_t slot = hmap_get(&cc->origin, owner);
    if (slot == HMAP_NONE)
        return;
    par_cav *c = cc->cavs[slot];
    if (st != REPLY_OK) {
        if (!c->failed)
            c->failed = st == REPLY_STALE || st == REPLY_TOO_BIG ? st : REPLY_LOCKED;
    } else if (!c->err) {
        int rc = get_tets(c, &rd, (uint32_t)msg->src);
        if (!rc && pr_reader_finish(&rd))
            rc = PDR_EPARSE;
        if (rc)
            c->err = rc;
    }
    if (--c->pending == 0)
        am_future_set(c->fut, c);
}

static void on_migrate(am_ctx_t *am, const am_msg_t *msg, void *arg)
{
    par_cav_ctx *cc = arg;
    par_sub *s = cc->s;
    tm_mesh *m = &s->r.m;
    pr_reader rd;
    uint32_t owner;
    pr_msg_open(&rd, msg->data, msg->len, MSG_MIGRATE);
    pr_get_u32(&rd, &owner);
    int idx = rd.err ? -1 : rec_find(cc, owner);
    if (idx < 0)
        return;
    am_time_begin(am, cc->cat_service);
    par_rec *rec = &cc->recs[idx];
    par_part *pt = &rec->part;
    uint32_t origin = (uint32_t)msg->src;
    size_t problems0 = dbg_count(s);
    /* The subfacets on the cavity that no tetrahedron of this PE will
     * have any more: a face belongs to two tetrahedra, so one on a cavity
     * tetrahedron stays here only if the tetrahedron across it is a local
     * one outside the cavity. Those entries are forgotten below (a stale
     * one would disturb the facet's 2D cavities here). Subsegment entries
     * stay: an edge may have tetrahedra here that no walk from the cavity
     * reaches, and a stale one is harmless (splits happen only where a
     * local tetrahedron has the edge). */
    u32list facs = {0};
    mark_cavity(m, &pt->cav, 1);
    const bd_set *bd = &s->r.bd;
    for (size_t i = 0; i < pt->cav.n; i++) {
        uint32_t t = pt->cav.a[i];
        const tm_tet *T = &m->tets[t];
        for (int k = 0; k < 4; k++) {
            if (!(m->flags[t] & TM_F_FACEMARK(k)))
                continue;
            tm_link l = T->n[k];
            if (!tm_is_special(l) && !(m->flags[tm_ltet(l)] & TM_F_CAVITY))
                continue;
            uint32_t id = bd_find_subfac(bd, T->v[tm_face_vtx[k][0]], T->v[tm_face_vtx[k][1]],
                                         T->v[tm_face_vtx[k][2]]);
            if (id != BD_NONE && !has(&facs, id))
                push(&facs, id);
        }
    }
    mark_cavity(m, &pt->cav, 0);
    for (size_t i = 0; i < pt->cav.n; i++) {
        uint32_t t = pt->cav.a[i];
        for (int k = 0; k < 4; k++) {
            tm_link l = m->tets[t].n[k];
            if (tm_is_special(l) && l != TM_LINK_NONE && l != TM_LINK_UNSET)
                par_sub_drop_iface(s, l - TM_LINK_SPECIAL);
        }
        left_forget(&cc->left, t); /* it went with WIRE_LEFT if it was */
        tm_free_tet(m, t);
    }
    for (size_t i = 0; i < pt->repoint.n; i++) {
        tm_link l = pt->repoint.a[i];
        uint32_t w = tm_ltet(l);
        int j = tm_lface(l);
        tm_link far = m->tets[w].n[j];
        if (tm_is_dead(m, w) || tm_is_special(far) || !tm_is_dead(m, tm_ltet(far)))
            continue;
        par_sub_add_iface(s, w, j, origin);
    }
    for (size_t i = 0; i < pt->ifcs.n; i++) {
        uint32_t k = pt->ifcs.a[i];
        if (s->ifc[k].pe != PAR_PE_NONE)
            s->ifc[k].pe = origin;
    }
    /* Vertex hints that pointed into the cavity: the first closure
     * tetrahedron (in held order) still holding the vertex, else none (the
     * vertex left this PE). One pass over held for all of them: a band
     * (par_cav_give) has thousands of tetrahedra. */
    hmap lost = {0}; /* vertex + 1 -> 1: its hint pointed into the cavity */
    int lost_err = 0;
    for (size_t i = 0; i < pt->cav.n; i++) {
        const uint32_t *v = m->tets[pt->cav.a[i]].v;
        for (int k = 0; k < 4; k++) {
            uint32_t x = v[k];
            if (x == TM_VINF || m->vhint[x] == TM_NONE || !tm_is_dead(m, m->vhint[x]))
                continue;
            m->vhint[x] = TM_NONE;
            if (hmap_put(&lost, (uint64_t)x + 1, 1))
                lost_err = 1;
        }
    }
    for (size_t j = 0; j < pt->held.n && lost.n; j++) {
        uint32_t w = pt->held.a[j];
        if (tm_is_dead(m, w))
            continue;
        for (int k = 0; k < 4; k++) {
            uint32_t x = m->tets[w].v[k];
            if (x != TM_VINF && m->vhint[x] == TM_NONE &&
                (lost_err || hmap_get(&lost, (uint64_t)x + 1) != HMAP_NONE))
                m->vhint[x] = w;
        }
    }
    hmap_free(&lost);
    for (size_t i = 0; i < facs.n; i++)
        if (!(s->r.bd.facs[facs.a[i]].flags & BD_F_DEAD))
            bd_kill_subfac(&s->r.bd, facs.a[i]);
    pr_free(facs.a);
    if (s->r.o.check_each_step)
        dbg_report(s, problems0, "migration", owner, pt->cav.n);
    cc->st.tets_out += pt->cav.n;
    rec_drop(cc, (uint32_t)idx);
    am_time_end(am, cc->cat_service);
}

static void on_abort(am_ctx_t *am, const am_msg_t *msg, void *arg)
{
    (void)am;
    par_cav_ctx *cc = arg;
    pr_reader rd;
    uint32_t owner;
    pr_msg_open(&rd, msg->data, msg->len, MSG_ABORT);
    pr_get_u32(&rd, &owner);
    int idx = rd.err ? -1 : rec_find(cc, owner);
    if (idx >= 0)
        rec_drop(cc, (uint32_t)idx);
}

/* ------------------------------------------------------------ bands */

/* The body of a BAND after its owner (proto/PROTOCOL.md): tetrahedra
 * tets[0..n-1] of s as a reply carries them, then the band's own
 * adjacency. The tetrahedra must carry TM_F_CAVITY (mark_cavity) and no
 * other tetrahedron may. Returns 0 or PDR_ENOMEM. */
static int put_band(const par_sub *s, const hmap *left, const uint32_t *tets, size_t n,
                    pr_buf *b)
{
    const tm_mesh *m = &s->r.m;
    /* tetrahedron -> its index in the band + 1 (0: not in it), over all
     * slots: a band has thousands. */
    uint32_t *idx = pr_calloc(m->nslots, sizeof *idx);
    if (!idx)
        return PDR_ENOMEM;
    for (size_t i = 0; i < n; i++)
        idx[tets[i]] = (uint32_t)i + 1;
    if (put_tets(s, left, tets, n, b))
        b->err = PR_ENOMEM;
    /* For face k of tetrahedron i, 4 j + k' when face k' of band
     * tetrahedron j is across, else none: the receiver links the band
     * with these instead of matching face keys. */
    pr_put_u32(b, (uint32_t)(4 * n));
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 4; k++) {
            tm_link l = m->tets[tets[i]].n[k];
            uint32_t j = tm_is_special(l) || !(m->flags[tm_ltet(l)] & TM_F_CAVITY)
                             ? 0
                             : idx[tm_ltet(l)];
            pr_put_u32(b, j == 0 ? UINT32_MAX : 4 * (j - 1) + (uint32_t)tm_lface(l));
        }
    pr_free(idx);
    return b->err ? PDR_ENOMEM : 0;
}

int par_cav_give(par_cav_ctx *cc, uint32_t to, const uint32_t *tets, size_t n)
{
    par_sub *s = cc->s;
    tm_mesh *m = &s->r.m;
    if (!n || n > PAR_CAV_BAND_MAX || to == s->rank || to >= s->size)
        return 0;
    /* Every tetrahedron and every local neighbour free; every interface
     * face leads to 'to'. */
    for (size_t i = 0; i < n; i++) {
        uint32_t t = tets[i];
        if (t >= m->nslots || tm_is_dead(m, t) || m->lock[t] ||
            (m->flags[t] & TM_F_CAVITY))
            return 0;
        for (int k = 0; k < 4; k++) {
            tm_link l = m->tets[t].n[k];
            if (l == TM_LINK_NONE || l == TM_LINK_UNSET)
                return 0;
            if (tm_is_special(l) ? s->ifc[l - TM_LINK_SPECIAL].pe != to
                                 : m->lock[tm_ltet(l)] != 0)
                return 0;
        }
    }
    uint32_t owner = new_owner(cc), ri;
    int rc = rec_new(cc, owner, to, &ri);
    if (rc)
        return rc;
    par_part *pt = &cc->recs[ri].part;
    for (size_t i = 0; i < n && !rc; i++) {
        tm_set_lock(m, tets[i], owner);
        rc = push(&pt->cav, tets[i]);
        if (!rc)
            rc = push(&pt->held, tets[i]);
    }
    /* The closure: the faces of local tetrahedra outside the band that
     * face it will face 'to' (on_migrate). */
    mark_cavity(m, &pt->cav, 1);
    for (size_t i = 0; i < n && !rc; i++)
        for (int k = 0; k < 4 && !rc; k++) {
            tm_link l = m->tets[tets[i]].n[k];
            if (tm_is_special(l))
                continue;
            uint32_t w = tm_ltet(l);
            if (m->flags[w] & TM_F_CAVITY)
                continue;
            rc = push(&pt->repoint, l);
            if (!rc && m->lock[w] != owner) {
                tm_set_lock(m, w, owner);
                rc = push(&pt->held, w);
            }
        }
    pr_buf b = PR_BUF_INIT;
    if (!rc) {
        pr_msg_begin(&b, MSG_BAND);
        pr_put_u32(&b, owner);
        rc = put_band(s, &cc->left, pt->cav.a, pt->cav.n, &b);
    }
    mark_cavity(m, &pt->cav, 0);
    if (!rc)
        rc = am_send(cc->am, (int)to, cc->h_band, b.data, b.len);
    pr_buf_free(&b);
    if (rc) {
        rec_drop(cc, ri);
        return rc < 0 ? rc : PDR_ENOMEM;
    }
    cc->st.bands_out++;
    return 1;
}

/* The face records of a band (import) from the adjacency that follows its
 * tetrahedra (par_cav_give): a face inside the band once with both sides,
 * every other face once with the PE across and its key. Returns 0,
 * PDR_EPARSE (an adjacency that is not symmetric or does not match the
 * vertices) or PDR_ENOMEM. */
static int band_faces(par_cav *c, pr_reader *rd)
{
    uint32_t na;
    if (pr_get_count(rd, MAX_CAV_TETS * 4, 4, &na) || na != 4 * c->ngt)
        return PDR_EPARSE;
    uint32_t *adj = pr_malloc(((size_t)na + 1) * sizeof *adj);
    if (!adj)
        return PDR_ENOMEM;
    int rc = pr_get_u32_array(rd, adj, na) ? PDR_EPARSE : 0;
    if (!rc && pdr_grow((void **)&c->face, &c->cap_face, c->nface + na, sizeof *c->face))
        rc = PDR_ENOMEM;
    for (uint32_t i = 0; i < c->ngt && !rc; i++) {
        const par_gtet *g = &c->gt[i];
        for (int k = 0; k < 4 && !rc; k++) {
            uint32_t a = adj[4 * i + (uint32_t)k];
            par_cav_face *f = &c->face[c->nface];
            memset(f, 0, sizeof *f);
            f->tet[0] = i;
            f->face[0] = (uint8_t)k;
            f->gathered[0] = 1;
            if (a == UINT32_MAX) {
                if (g->nbr[k] == PAR_PE_NONE || g->nbr[k] >= c->cc->s->size) {
                    rc = PDR_ETOPOLOGY;
                    break;
                }
                gathered_key(c, g, k, f->key);
                f->count = 1;
                f->pe = g->nbr[k];
                c->nface++;
                continue;
            }
            uint32_t j = a >> 2;
            int kk = (int)(a & 3);
            if (j >= c->ngt || j == i || adj[4 * j + (uint32_t)kk] != 4 * i + (uint32_t)k) {
                rc = PDR_EPARSE;
                break;
            }
            /* The shared face has the same three vertices on both sides. */
            uint64_t ki[3], kj[3];
            gathered_key(c, g, k, ki);
            gathered_key(c, &c->gt[j], kk, kj);
            if (!par_key_eq(ki, kj)) {
                rc = PDR_EPARSE;
                break;
            }
            if (j < i)
                continue; /* recorded from j */
            memcpy(f->key, ki, sizeof ki);
            f->tet[1] = j;
            f->face[1] = (uint8_t)kk;
            f->gathered[1] = 1;
            f->count = 2;
            c->nface++;
        }
    }
    pr_free(adj);
    return rc;
}

/* The body of a BAND after its owner, into c's gathered lists and face
 * records (c reset): 0, PDR_EPARSE on anything malformed or trailing, or
 * PDR_ENOMEM. */
static int get_band(par_cav *c, pr_reader *rd, uint32_t src)
{
    int rc = get_tets(c, rd, src);
    if (!rc)
        rc = band_faces(c, rd);
    if (!rc && pr_reader_finish(rd))
        rc = PDR_EPARSE;
    return rc;
}

/* Marks (on 1) or unmarks the tetrahedra of the bands this PE gives
 * (par_cav_give) and that have not yet migrated: records in served with
 * an owner of this PE's own rank. */
static void mark_own_bands(par_cav_ctx *cc, int on)
{
    for (size_t i = 0; i < cc->nrecs; i++)
        if (cc->recs[i].owner && cc->recs[i].owner >> 20 == cc->s->rank + 1)
            mark_cavity(&cc->s->r.m, &cc->recs[i].part.cav, on);
}

/* Takes a band another PE gives (par_cav_give): imports it, unlocked,
 * and sends MIGRATE, or ABORT when one of this PE's tetrahedra next to it
 * belongs to a band this PE gives, whose MIGRATE will delete it (the cut
 * keeps two bands from sharing a face, par_band.h: this is the check).
 * A tetrahedron next to it may be held by a cavity in progress (that
 * attempt then meets the band's locks or the moved faces, a setback) or
 * be in the closure of this PE's own band (its faces towards that band
 * are repointed, not this one). */
static void on_band(am_ctx_t *am, const am_msg_t *msg, void *arg)
{
    par_cav_ctx *cc = arg;
    par_sub *s = cc->s;
    tm_mesh *m = &s->r.m;
    pr_reader rd;
    uint32_t owner, src = (uint32_t)msg->src;
    pr_msg_open(&rd, msg->data, msg->len, MSG_BAND);
    pr_get_u32(&rd, &owner);
    if (rd.err || owner == 0)
        return;
    am_time_begin(am, cc->cat_service);
    int rc = 0;
    if (!cc->band) {
        cc->band = pr_calloc(1, sizeof *cc->band);
        if (!cc->band)
            rc = PDR_ENOMEM;
        else
            par_cav_init(cc->band, cc);
    }
    par_cav *c = cc->band;
    int take = 0;
    if (!rc) {
        reset_attempt(c);
        rc = get_band(c, &rd, src);
    }
    if (!rc) {
        take = 1;
        mark_own_bands(cc, 1);
        for (size_t i = 0; i < c->nface && take; i++) {
            const par_cav_face *f = &c->face[i];
            if (f->count == 2 || f->pe == src)
                continue;
            uint32_t k = f->pe == s->rank ? par_sub_find_iface(s, f->key) : PAR_PE_NONE;
            take = k != PAR_PE_NONE && s->ifc[k].pe == src &&
                   !(m->flags[tm_ltet(s->ifc[k].local)] & TM_F_CAVITY);
        }
        mark_own_bands(cc, 0);
    }
    uint8_t out[5];
    pr_store_u32(out + 1, owner);
    if (take) {
        c->owner = new_owner(cc);
        rc = import(c);
        par_cav_release(c);
        if (!rc)
            cc->st.bands_in++;
    }
    if (rc && !cc->err)
        cc->err = rc; /* a band half imported: the run stops */
    out[0] = (uint8_t)(take && !rc ? MSG_MIGRATE : MSG_ABORT);
    if (!rc || !take)
        am_send(am, (int)src, take ? cc->h_migrate : cc->h_abort, out, sizeof out);
    am_time_end(am, cc->cat_service);
}

/* ------------------------------------------------------------ set-up */

int par_cav_ctx_init(par_cav_ctx *cc, am_ctx_t *am, par_sub *s, unsigned base)
{
    memset(cc, 0, sizeof *cc);
    cc->am = am;
    cc->s = s;
    cc->rec_free = UINT32_MAX;
    cc->h_gather = base;
    cc->h_reply = base + 1;
    cc->h_migrate = base + 2;
    cc->h_abort = base + 3;
    cc->h_band = base + 4;
    dt_cavity_init(&cc->scratch);
    int rc = am_register(am, cc->h_gather, "cavity-gather", on_gather, cc);
    if (!rc)
        rc = am_register(am, cc->h_reply, "cavity-reply", on_reply, cc);
    if (!rc)
        rc = am_register(am, cc->h_migrate, "cavity-migrate", on_migrate, cc);
    if (!rc)
        rc = am_register(am, cc->h_abort, "cavity-abort", on_abort, cc);
    if (!rc)
        rc = am_register(am, cc->h_band, "cavity-band", on_band, cc);
    if (!rc) {
        cc->cat_service = am_category(am, "cavity_service");
        if (cc->cat_service < 0)
            rc = cc->cat_service;
    }
    return rc;
}

void par_cav_ctx_free(par_cav_ctx *cc)
{
    for (size_t i = 0; i < cc->nrecs; i++)
        part_free(&cc->recs[i].part);
    pr_free(cc->recs);
    pr_free(cc->cavs);
    hmap_free(&cc->origin);
    hmap_free(&cc->served);
    hmap_free(&cc->left);
    dt_cavity_free(&cc->scratch);
    if (cc->band) {
        par_cav_free(cc->band);
        pr_free(cc->band);
    }
    memset(cc, 0, sizeof *cc);
}

void par_cav_init(par_cav *c, par_cav_ctx *cc)
{
    memset(c, 0, sizeof *c);
    c->cc = cc;
    c->slot = UINT32_MAX;
    if (cc->am)
        am_future_new(cc->am, &c->fut);
}

int par_cav_encode_tets(const par_sub *s, const uint32_t *tets, size_t n, pr_buf *b)
{
    return put_tets(s, NULL, tets, n, b);
}

int par_cav_encode_left_tets(const par_cav_ctx *cc, const uint32_t *tets, size_t n, pr_buf *b)
{
    return put_tets(cc->s, &cc->left, tets, n, b);
}

int par_cav_decode_tets(par_cav *c, const void *data, size_t len, uint32_t src)
{
    pr_reader rd;
    pr_reader_init(&rd, data, len);
    int rc = get_tets(c, &rd, src);
    if (!rc && pr_reader_finish(&rd))
        rc = PDR_EPARSE;
    return rc;
}

int par_cav_encode_band(par_sub *s, const uint32_t *tets, size_t n, pr_buf *b)
{
    tm_mesh *m = &s->r.m;
    for (size_t i = 0; i < n; i++)
        m->flags[tets[i]] |= TM_F_CAVITY;
    hmap none = {0};
    int rc = put_band(s, &none, tets, n, b);
    for (size_t i = 0; i < n; i++)
        m->flags[tets[i]] &= (uint16_t)~TM_F_CAVITY;
    return rc;
}

int par_cav_decode_band(par_cav *c, const void *data, size_t len, uint32_t src)
{
    pr_reader rd;
    pr_reader_init(&rd, data, len);
    return get_band(c, &rd, src);
}

void par_cav_free(par_cav *c)
{
    par_cav_release(c);
    part_free(&c->own);
    pr_free(c->gt);
    pr_free(c->gv);
    pr_free(c->gp);
    pr_free(c->face);
    pr_free(c->req);
    pr_free(c->parts.a);
    hmap_free(&c->gvmap);
    hmap_free(&c->facemap);
    if (c->fut)
        am_future_free(&c->fut);
    memset(c, 0, sizeof *c);
}
