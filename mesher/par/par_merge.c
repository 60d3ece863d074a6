/* par/par_merge.c -- the P messages of the PEs back into one ref_mesher,
 * with every seam checked (see par/par_merge.h).
 *
 * In time linear in the mesh and without a sort of all its faces: at 10^6
 * tetrahedra, linking 4*10^6 faces by their vertices (tm_link_faces) and
 * hashing every tetrahedron into one table cost the merge over a second,
 * a third of a whole two-PE run. Each PE now sends its own links, so:
 *  1. vertices: every message lists its vertices by ascending gid, so a
 *     k-way merge of the P lists numbers the distinct gids in ascending
 *     order and meets the copies of one gid one after the other, to be
 *     compared;
 *  2. tetrahedra: concatenated, tetrahedron j of message k in slot
 *     base[k] + j, so that the message's link 4u+j is the mesh link
 *     tm_mklink(base[k] + u, j), in range (the decoder checked it);
 *  3. a tetrahedron sent twice (only in the careful run, see
 *     par_merge_build): the hashes of all tetrahedra searched for repeats
 *     (base/hdup), those with a repeated hash compared, later copies
 *     dropped;
 *  4. every pair linked within a message: it comes back, and joins one
 *     triangle seen from its two sides with one marker. In the first run
 *     (see par_merge_build) a message checked ahead (par_merge_ahead:
 *     rank 0's own, from its mesh, while the others still encode and
 *     send theirs) is not read again, and the others are checked within
 *     step 2, each pair from its higher side when it is stored, against
 *     the lower side stored a while before; the careful run checks every
 *     pair in a pass of its own, from its lower side;
 *  5. the faces not linked within their message (interface faces, and
 *     faces with nothing across) matched by their vertices in a hash
 *     table, and checked as the seams they are: a few percent of the
 *     faces;
 *  6. a face of more than two tetrahedra: each linked pair of step 4 and
 *     each group of step 5 hashed by its vertices, the hashes searched for
 *     repeats like the tetrahedra;
 *  7. the subsegments and subfacets, as sent.
 * A mesh that fits takes no sort and no hash table of all faces or
 * tetrahedra: the repeats are searched in cache-sized partitions, and
 * only a repeat (a fault, or a rare chance) is looked at one by one.
 *
 * Rank 0 merges alone, the other PEs done: on a large mesh the steps
 * that split cleanly use the other cores (base/fj) -- the messages are
 * decoded and their tetrahedra stored a message per task (step 2 takes
 * the slots first, in order, and joins the tasks' loose faces and step
 * 4's hashes in message order), the careful run's step 4 runs in shares
 * of the slots, and steps 5-6 run beside step 7. The mesh, the lists and
 * the counts are those of one pass. */
#include "config.h"

#include <stdlib.h>
#ifdef HAVE_MALLOC_TRIM
#include <malloc.h>
#endif
#include <string.h>

#include "pr_alloc.h"
#include "base/fj.h"
#include "base/hdup.h"
#include "base/pdr_util.h"
#include "base/v3.h"
#include "par/par_merge.h"
#include "par/par_wire.h"

size_t par_merge_problems(const par_merge_report *r)
{
    return r->vertex_conflicts + r->dup_tets + r->nonmanifold + r->open_faces +
           r->iface_unmatched + r->iface_mismatch + r->misoriented + r->marker_mismatch +
           r->bd_conflicts + r->bad_links;
}

int par_merge_encode(pr_buf *b, const par_sub *s)
{
    return par_wire_encode_sub(b, s);
}

int par_merge_pieces_init(par_merge_pieces *pc, const par_sub *s, uint32_t max)
{
    memset(pc, 0, sizeof *pc);
    const tm_mesh *m = &s->r.m;
    if (max == 0)
        return PDR_EINVAL;
    pc->m = m;
    pc->left = m->nlive;
    pc->max = max;
    pc->count = (uint32_t)(((uint64_t)m->nlive + max - 1) / max);
    size_t cap = m->nlive < max ? m->nlive : max;
    pc->taken = pr_calloc((size_t)m->nslots / 64 + 1, sizeof *pc->taken);
    pc->list = pr_malloc((cap ? cap : 1) * sizeof *pc->list);
    if (!pc->taken || !pc->list) {
        par_merge_pieces_free(pc);
        return PDR_ENOMEM;
    }
    return 0;
}

static int piece_taken(const par_merge_pieces *pc, uint32_t t)
{
    return (pc->taken[t >> 6] >> (t & 63)) & 1;
}

static void piece_take(par_merge_pieces *pc, uint32_t t)
{
    pc->taken[t >> 6] |= UINT64_C(1) << (t & 63);
}

int par_merge_pieces_next(par_merge_pieces *pc, const uint32_t **tets, uint32_t *nt)
{
    const tm_mesh *m = pc->m;
    uint32_t want = pc->left < pc->max ? pc->left : pc->max, n = 0, head = 0;
    while (n < want) {
        if (head == n) { /* what the piece reaches is used up: a new seed */
            while (pc->scan < m->nslots &&
                   (tm_is_dead(m, pc->scan) || piece_taken(pc, pc->scan)))
                pc->scan++;
            if (pc->scan >= m->nslots)
                break; /* nlive was wrong; the piece ends here */
            piece_take(pc, pc->scan);
            pc->list[n++] = pc->scan;
        }
        uint32_t t = pc->list[head++];
        for (int i = 0; i < 4 && n < want; i++) {
            tm_link l = m->tets[t].n[i];
            if (tm_is_special(l))
                continue;
            uint32_t u = tm_ltet(l);
            if (u >= m->nslots || tm_is_dead(m, u) || piece_taken(pc, u))
                continue;
            piece_take(pc, u);
            pc->list[n++] = u;
        }
    }
    pc->left -= n;
    if (n == 0)
        return 0;
    /* ascending: the encoder then maps slots with a bit per slot */
    qsort(pc->list, n, sizeof *pc->list, pdr_cmp_u32);
    *tets = pc->list;
    *nt = n;
    return 1;
}

void par_merge_pieces_free(par_merge_pieces *pc)
{
    pr_free(pc->taken);
    pr_free(pc->list);
    memset(pc, 0, sizeof *pc);
}

#define NO_FACE UINT32_MAX

/* A hint to load a cache line now (a no-op where the compiler has none). */
#if defined(__GNUC__)
#define PREFETCH(p) __builtin_prefetch(p)
#else
#define PREFETCH(p) ((void)(p))
#endif
#define PREFETCH_AHEAD 16

/* A face not linked within its message (step 5): an interface face, or
 * one with nothing across. */
typedef struct loose {
    uint32_t f;      /* tm_mklink(merged slot, face) */
    uint32_t pe;     /* the PE its message names across it, or PAR_PE_NONE */
    uint32_t key[3]; /* its merged vertices, ascending */
    uint32_t next;   /* next face with the same key, or NO_FACE */
} loose;

/* What the checks of step 4 count, for one pass or one share of it. */
typedef struct link_tally {
    size_t up, down, bad_links, misoriented, marker_mismatch;
    int suspect;
    size_t unmarked; /* the first run: see par_merge_report.unmarked_bounds */
} link_tally;

/* State of one merge; every pointer owned, freed by st_free. */
typedef struct merge {
    const par_wire *w; /* [n] decoded messages (borrowed) */
    par_wire *own_w; /* w when the merge decoded them itself, else NULL */
    par_wire *spend; /* w when the merge frees each message's vertex and
                        tetrahedron tables once it has taken them (the
                        first run of par_merge_build_wires_spent), else NULL */
    const par_merge_ahead *ahead; /* [na]: messages 0..na-1's step 4 done */
    uint32_t na;
    uint32_t n;
    uint32_t **loc;  /* [n][vert.n]: merged vertex of each message vertex */
    uint32_t *base;  /* [n + 1]: slot of each message's first tetrahedron */
    uint8_t *drop;   /* per slot: 1 on a later copy of a tetrahedron (NULL: none) */
    loose *lf;       /* the faces of step 5 */
    size_t nlf, caplf;
    uint64_t *hash;  /* hashes of tetrahedra (step 3), then of faces (6) */
    size_t nhash, caphash;
    uint64_t *big;   /* hashes of step 5's groups of more than two faces */
    size_t nbig, capbig;
    hdup_buf scratch; /* of steps 3 and 6 */
    uint64_t *vk;    /* per merged vertex: its key for the hashes */
    int careful;     /* step 3 done (the second run, see par_merge_build) */
    int suspect;     /* two linked tetrahedra with the same vertices */
    link_tally pairs_k; /* step 4 done in step 2's tasks (the first run) */
} merge;

static void st_free(merge *g)
{
    if (g->own_w)
        for (uint32_t k = 0; k < g->n; k++)
            par_wire_clear(&g->own_w[k]);
    if (g->loc)
        for (uint32_t k = 0; k < g->n; k++)
            pr_free(g->loc[k]);
    pr_free(g->own_w);
    pr_free(g->loc);
    pr_free(g->base);
    pr_free(g->drop);
    pr_free(g->lf);
    pr_free(g->hash);
    pr_free(g->big);
    hdup_buf_free(&g->scratch);
    pr_free(g->vk);
}

/* ---------------------------------------------------------------- hashes */

/* A bijection of 64-bit words that spreads every input bit over the
 * output: multiplications by odd constants and folds of the high half. */
static uint64_t mix(uint64_t x)
{
    return par_wire_mix(x);
}

/* Hashes of vertex sets: the vertices' keys (g->vk, one mix of the gid
 * each, made once: so that a message's faces hash the same before its
 * vertices are merged, see par_merge_check_ahead) summed, so that the
 * order in which a tetrahedron or face lists them does not matter (no sort, and no unpredictable branch per face),
 * then mixed so that every bit of the result depends on all of them
 * (base/hdup partitions by the top bits). The offset keeps vertex 0 from
 * mixing to 0. */
static uint64_t vkey(uint64_t gid)
{
    return par_wire_vkey(gid);
}

static uint64_t tet_hash(const uint64_t *vk, const uint32_t v[4])
{
    return mix(vk[v[0]] + vk[v[1]] + vk[v[2]] + vk[v[3]]);
}

static uint64_t face_hash(const uint64_t *vk, uint32_t a, uint32_t b, uint32_t c)
{
    return par_wire_face_hash(vk[a], vk[b], vk[c]);
}

static int add_hash(uint64_t **a, size_t *n, size_t *cap, uint64_t h)
{
    if (pdr_grow((void **)a, cap, *n + 1, sizeof **a))
        return PDR_ENOMEM;
    (*a)[(*n)++] = h;
    return 0;
}

static void sort4(const uint32_t *v, uint32_t s[4])
{
    memcpy(s, v, 4 * sizeof *s);
    for (int i = 1; i < 4; i++)
        for (int j = i; j > 0 && s[j - 1] > s[j]; j--) {
            uint32_t x = s[j];
            s[j] = s[j - 1];
            s[j - 1] = x;
        }
}

static void face_of(const tm_mesh *m, uint32_t t, int i, uint32_t f[3])
{
    for (int c = 0; c < 3; c++)
        f[c] = m->tets[t].v[tm_face_vtx[i][c]];
}

static void face_key(const tm_mesh *m, uint32_t t, int i, uint32_t s[3])
{
    const uint32_t *v = m->tets[t].v;
    v3_sort3u(v[tm_face_vtx[i][0]], v[tm_face_vtx[i][1]], v[tm_face_vtx[i][2]], s);
}

/* 1 if the triangles x and y are the same face seen from its two sides: y
 * is an odd permutation of x. */
static int face_opposed(const uint32_t x[3], const uint32_t y[3])
{
    for (int k = 0; k < 3; k++)
        if (y[0] == x[k])
            return y[1] == x[(k + 2) % 3] && y[2] == x[(k + 1) % 3];
    return 0;
}

/* An entity whose hash repeats (the slow paths of steps 3 and 6): its
 * sorted vertices (the fourth 0 for a face) and its slot or face. */
typedef struct cand {
    uint32_t s[4];
    uint32_t id;
} cand;

static int cmp_cand(const void *a, const void *b)
{
    const cand *x = a, *y = b;
    for (int c = 0; c < 4; c++)
        if (x->s[c] != y->s[c])
            return x->s[c] < y->s[c] ? -1 : 1;
    return (x->id > y->id) - (x->id < y->id);
}

static int add_cand(cand **a, size_t *n, size_t *cap, const uint32_t s[4], uint32_t id)
{
    if (pdr_grow((void **)a, cap, *n + 1, sizeof **a))
        return PDR_ENOMEM;
    memcpy((*a)[*n].s, s, sizeof (*a)[*n].s);
    (*a)[(*n)++].id = id;
    return 0;
}

/* -------------------------------------------------------- 1. vertices */

/* The k-way merge's order: message a's next gid before message b's, the
 * lower message first on a tie (so that a gid's first copy is from the
 * first message holding it). */
static int before(const merge *g, const uint32_t *cur, uint32_t a, uint32_t b)
{
    uint64_t x = g->w[a].sm->vert.gid[cur[a]], y = g->w[b].sm->vert.gid[cur[b]];
    return x < y || (x == y && a < b);
}

static void sift_down(const merge *g, const uint32_t *cur, uint32_t *heap, size_t n, size_t i)
{
    for (;;) {
        size_t l = 2 * i + 1, r = l + 1, m = i;
        if (l < n && before(g, cur, heap[l], heap[m]))
            m = l;
        if (r < n && before(g, cur, heap[r], heap[m]))
            m = r;
        if (m == i)
            return;
        uint32_t x = heap[i];
        heap[i] = heap[m];
        heap[m] = x;
        i = m;
    }
}

/* The distinct gids in ascending order as vertices 1.., with coordinates
 * and bd data from the first message holding each (later copies are
 * compared), and each message's vertices in that numbering. */
static int add_vertices(merge *g, ref_mesher *r, par_merge_report *rep)
{
    tm_mesh *m = &r->m;
    size_t total = 1;
    for (uint32_t k = 0; k < g->n; k++)
        total += g->w[k].sm->vert.n;
    if (total > TM_MAX_VERTS)
        total = TM_MAX_VERTS; /* tm_add_vertex says whether they fit */
    int rc = tm_reserve(m, total, 0);
    if (!rc)
        rc = bd_vertex_room(&r->bd, total);
    g->loc = pr_calloc(g->n, sizeof *g->loc);
    uint32_t *cur = pr_calloc(g->n, sizeof *cur), *heap = pr_malloc(g->n * sizeof *heap);
    if (!rc && (!g->loc || !cur || !heap))
        rc = PDR_ENOMEM;
    size_t nh = 0;
    for (uint32_t k = 0; k < g->n && !rc; k++) {
        const pr_vtable *vt = &g->w[k].sm->vert;
        g->loc[k] = pr_malloc(((size_t)vt->n ? vt->n : 1) * sizeof *g->loc[k]);
        if (!g->loc[k]) {
            rc = PDR_ENOMEM;
            break;
        }
        /* The infinite vertex is the smallest gid: vertex 0 if sent. */
        if (vt->n && vt->gid[0] == PAR_GID_INF) {
            g->loc[k][0] = TM_VINF;
            cur[k] = 1;
        }
        if (cur[k] < vt->n)
            heap[nh++] = k;
    }
    for (size_t i = nh / 2; i-- > 0 && !rc;)
        sift_down(g, cur, heap, nh, i);
    uint64_t last = PAR_GID_INF;
    uint32_t v = TM_VINF;
    bd_set *bd = &r->bd;
    while (nh && !rc) {
        uint32_t k = heap[0], i = cur[k];
        const par_wire *w = &g->w[k];
        uint64_t gid = w->sm->vert.gid[i];
        const double *x = w->sm->vert.xyz + 3 * (size_t)i;
        if (gid != last) {
            if ((rc = tm_add_vertex(m, x, &v)))
                break;
            m->gid[v] = gid;
            bd->vkind[v] = w->vkind[i];
            bd->vfeat[v] = w->vfeat[i];
            bd->vrins[v] = w->vrins[i];
            last = gid;
        } else if (memcmp(m->xyz + 3 * (size_t)v, x, 3 * sizeof *x) ||
                   bd->vkind[v] != w->vkind[i] || bd->vfeat[v] != w->vfeat[i] ||
                   memcmp(&bd->vrins[v], &w->vrins[i], sizeof(float))) {
            rep->vertex_conflicts++;
        }
        g->loc[k][i] = v;
        if (++cur[k] == w->sm->vert.n)
            heap[0] = heap[--nh];
        sift_down(g, cur, heap, nh, 0);
    }
    pr_free(cur);
    pr_free(heap);
    if (!rc) {
        g->vk = pr_malloc((size_t)m->nv * sizeof *g->vk);
        if (!g->vk)
            return PDR_ENOMEM;
        for (uint32_t x = 0; x < m->nv; x++)
            g->vk[x] = vkey(m->gid[x]);
    }
    return rc;
}

/* ----------------------------------------------------- 2. tetrahedra */

static int add_loose(merge *g, uint32_t f, uint32_t pe)
{
    if (pdr_grow((void **)&g->lf, &g->caplf, g->nlf + 1, sizeof *g->lf))
        return PDR_ENOMEM;
    g->lf[g->nlf].f = f;
    g->lf[g->nlf++].pe = pe;
    return 0;
}

/* From this many tetrahedra in all, the messages are decoded and their
 * tetrahedra stored on the machine's cores, a message per task (below,
 * threads cost more than they save). */
#define MERGE_THREADS_FROM 200000

/* Threads for the per-message steps of a merge of total tetrahedra. */
static unsigned merge_threads(uint32_t n, size_t total)
{
    if (n < 2 || total < MERGE_THREADS_FROM)
        return 1;
    unsigned c = fj_cores();
    return c < n ? c : n;
}

/* A face's marker as sent, for the pass after step 2's tasks (the mesh's
 * marker map is one for all of them). */
typedef struct face_mark {
    uint32_t f; /* tm_mklink(merged slot, face) */
    int32_t marker;
} face_mark;

/* One message's tetrahedra (step 2), a task of base/fj: message k into
 * the slots from g->base[k], taken already; its loose faces into lf (in
 * the order of its faces), its ghosts counted. Writes only its own slots
 * and its own lf. */
typedef struct tet_task {
    merge *g;
    ref_mesher *r;
    uint32_t k;
    loose *lf;       /* its faces for g->lf, owned until handed over */
    size_t nlf, caplf;
    uint32_t nghost;
    int pairs;       /* step 4 of this message done here too (see below) */
    link_tally tally; /* its counts then */
    uint64_t *hash;  /* its pairs' face hashes then, owned until handed over */
    size_t nhash, caphash;
    face_mark *mk;   /* its marked faces, in face order, owned */
    size_t nmk, capmk;
} tet_task;

static int put_mark(tet_task *a, uint32_t f, int32_t marker)
{
    if (pdr_grow((void **)&a->mk, &a->capmk, a->nmk + 1, sizeof *a->mk))
        return PDR_ENOMEM;
    a->mk[a->nmk++] = (face_mark){f, marker};
    return 0;
}

static int put_loose(tet_task *a, uint32_t f, uint32_t pe)
{
    if (pdr_grow((void **)&a->lf, &a->caplf, a->nlf + 1, sizeof *a->lf))
        return PDR_ENOMEM;
    a->lf[a->nlf].f = f;
    a->lf[a->nlf++].pe = pe;
    return 0;
}

/* Step 4 for face i of t, whose link c (in the message, from base b)
 * names a face of a tetrahedron stored before it (c < 4j+i): the pair
 * seen from its higher side, with the other side's tm_tet written a while
 * ago and so nearer in the caches than the higher side is to the lower in
 * step 4's pass. That the links come back follows as in check_links, the
 * links down (checked) and up (counted) swapping roles; the other checks
 * are symmetric. mk is t's marker on face i and fl its flags as sent. */
static int pair_down(tet_task *a, const tm_mesh *m, uint32_t t, int i, uint32_t b, uint32_t c,
                     int32_t mk, uint16_t fl)
{
    const tm_tet *T = &m->tets[t];
    uint32_t u = b + (c >> 2);
    int j = (int)(c & 3);
    const tm_tet *U = &m->tets[u];
    a->tally.down++;
    a->tally.bad_links += U->n[j] != tm_mklink(t, i);
    uint32_t x[3], y[3];
    face_of(m, t, i, x);
    face_of(m, u, j, y);
    int opposed = tm_faces_opposed(x, y);
    a->tally.misoriented += (size_t)!opposed;
    /* the merged marker is the sent one + 1, 0 for none: u's as sent
     * (add_tets stores the markers after the tasks) */
    a->tally.marker_mismatch += a->g->w[a->k].sm->tet.marker[c] != mk;
    a->tally.suspect |= U->v[j] == T->v[i];
    /* t's flags are not stored yet: its interior test from what was sent */
    int tin = !tm_is_ghost(m, t) && !(fl & REF_F_EXTERIOR), uin = ref_is_interior(m, u);
    if (tin != uin)
        a->tally.unmarked += tin ? mk == PR_MARKER_NONE : !(m->flags[u] & TM_F_FACEMARK(j));
    if (a->nhash == a->caphash &&
        pdr_grow((void **)&a->hash, &a->caphash, a->nhash + 1, sizeof *a->hash))
        return PDR_ENOMEM;
    a->hash[a->nhash++] = face_hash(a->g->vk, x[0], x[1], x[2]);
    return 0;
}

static int tet_task_run(void *arg)
{
    tet_task *a = arg;
    const merge *g = a->g;
    ref_mesher *r = a->r;
    tm_mesh *m = &r->m;
    const par_wire *w = &g->w[a->k];
    const pr_submesh *sm = w->sm;
    const uint32_t *loc = g->loc[a->k];
    uint32_t b = g->base[a->k], q = 0;
    if (a->pairs) {
        /* about two pairs per tetrahedron */
        a->caphash = 2 * (size_t)sm->tet.n + 1;
        a->hash = pr_malloc(a->caphash * sizeof *a->hash);
        if (!a->hash)
            return PDR_ENOMEM;
    }
    for (uint32_t j = 0; j < sm->tet.n; j++) {
        uint32_t t = b + j;
        tm_tet *T = &m->tets[t];
        uint16_t fl = par_wire_tflags(w, j);
        for (int i = 0; i < 4; i++)
            T->v[i] = loc[sm->tet.v[4 * (size_t)j + (size_t)i]];
        if (a->pairs && j + PREFETCH_AHEAD < sm->tet.n)
            for (int i = 0; i < 4; i++) {
                uint32_t c = par_wire_link(w, 4 * ((size_t)j + PREFETCH_AHEAD) + (size_t)i);
                if (c < 4 * (j + PREFETCH_AHEAD)) {
                    PREFETCH(&m->tets[b + (c >> 2)].v[0]);
                    PREFETCH(&m->tets[b + (c >> 2)].n[3]);
                    PREFETCH(&m->flags[b + (c >> 2)]);
                }
            }
        for (int i = 0; i < 4; i++) {
            size_t x = 4 * (size_t)j + (size_t)i;
            uint32_t c = par_wire_link(w, x);
            if (c < PAR_WIRE_LINK_IFACE) {
                T->n[i] = tm_mklink(b + (c >> 2), (int)(c & 3));
                if (a->pairs && c >> 2 == j) {
                    a->tally.bad_links++; /* to itself (not decoded: see
                                             par_wire_from_sub) */
                } else if (a->pairs && c < x) {
                    int rc = pair_down(a, m, t, i, b, c, sm->tet.marker[x],
                                       par_wire_tflags(w, j));
                    if (rc)
                        return rc;
                } else if (a->pairs) {
                    a->tally.up++;
                }
            } else {
                /* IFACE faces are the listed ones, in the same ascending
                 * order (the decoder checked it). */
                uint32_t pe = PAR_PE_NONE;
                if (c == PAR_WIRE_LINK_IFACE && q < sm->iface.n)
                    pe = sm->iface.remote[q++];
                T->n[i] = TM_LINK_UNSET;
                int rc = put_loose(a, tm_mklink(t, i), pe);
                if (rc)
                    return rc;
            }
            /* the marker itself: add_tets, after the tasks */
            int32_t mk = sm->tet.marker[x];
            if (mk != PR_MARKER_NONE) {
                fl |= TM_F_FACEMARK(i);
                int rc = put_mark(a, tm_mklink(t, i), mk);
                if (rc)
                    return rc;
            }
        }
        fl |= (uint16_t)((sm->tet.subseg[j] & PR_SUBSEG_MASK) * TM_F_SUBSEG0);
        m->flags[t] = fl;
        a->nghost += (uint32_t)tm_is_ghost(m, t);
        if (r->region)
            r->region[t] = par_wire_region(w, j);
        if (g->careful)
            g->hash[t] = tet_hash(g->vk, T->v);
    }
    if (g->spend)
        par_wire_drop_tets(&g->spend[a->k]);
    return 0;
}

/* Every message's tetrahedra with their links, flags, markers,
 * subsegment bits and regions; the faces not linked go to g->lf (message
 * by message, face by face), and when careful the tetrahedra's hashes to
 * g->hash. The slots are taken first, in order, then each message is
 * stored by a task of its own (on several threads for a large mesh, see
 * merge_threads): the same mesh and the same g->lf either way. */
static int add_tets(merge *g, ref_mesher *r)
{
    tm_mesh *m = &r->m;
    size_t total = 0;
    for (uint32_t k = 0; k < g->n; k++)
        total += g->w[k].sm->tet.n;
    if (total > TM_MAX_TETS)
        return PDR_ELIMIT;
    int rc = tm_reserve(m, 0, total);
    if (!rc)
        rc = ref_region_room(r);
    g->base = pr_malloc(((size_t)g->n + 1) * sizeof *g->base);
    if (!rc && g->careful)
        rc = pdr_grow((void **)&g->hash, &g->caphash, total ? total : 1, sizeof *g->hash);
    tet_task *a = pr_calloc(g->n ? g->n : 1, sizeof *a);
    fj_task *ft = pr_calloc(g->n ? g->n : 1, sizeof *ft);
    if (!rc && (!g->base || !a || !ft))
        rc = PDR_ENOMEM;
    for (uint32_t k = 0; k < g->n && !rc; k++) {
        uint32_t b = m->nslots;
        g->base[k] = b;
        for (uint32_t j = 0; j < g->w[k].sm->tet.n && !rc; j++)
            /* A fresh mesh hands out slots 0, 1, ... in order, which the
             * links' offsets assume. */
            if (tm_alloc_tet(m) != b + j)
                rc = PDR_EINVAL;
        /* step 4 here for the messages not checked ahead, but not in the
         * careful run (check_links, with the copies dropped) */
        a[k] = (tet_task){.g = g, .r = r, .k = k, .pairs = !g->careful && k >= g->na};
        ft[k] = (fj_task){.run = tet_task_run, .arg = &a[k]};
    }
    if (!rc) {
        g->base[g->n] = m->nslots;
        fj_run(ft, g->n, merge_threads(g->n, total));
    }
    /* The first failure in message order, as one pass would stop at. */
    for (uint32_t k = 0; k < g->n && !rc; k++)
        rc = ft[k].rc;
    /* The face markers, the sent ones + 1 (0 for none), in one pass: the
     * tasks above share the mesh's one marker map (tm.h). */
    for (uint32_t k = 0; k < g->n && !rc; k++)
        for (size_t x = 0; x < a[k].nmk && !rc; x++)
            rc = tm_set_marker(m, tm_ltet(a[k].mk[x].f), tm_lface(a[k].mk[x].f),
                               a[k].mk[x].marker + 1);
    size_t nlf = 0, nh = 0;
    for (uint32_t k = 0; k < g->n && !rc; k++) {
        nlf += a[k].nlf;
        nh += a[k].nhash;
    }
    /* the first run: step 4's hashes, those checked ahead then those of
     * the tasks, message by message (room for step 5's too), and the
     * tasks' counts */
    for (uint32_t k = 0; k < g->na && !rc && !g->careful; k++)
        nh += g->ahead[k].nhash;
    if (!rc && !g->careful) {
        g->nhash = 0;
        rc = pdr_grow((void **)&g->hash, &g->caphash, nh + nlf + 1, sizeof *g->hash);
        for (uint32_t k = 0; k < g->na && !rc; k++) {
            if (g->ahead[k].nhash)
                memcpy(g->hash + g->nhash, g->ahead[k].hash,
                       g->ahead[k].nhash * sizeof *g->hash);
            g->nhash += g->ahead[k].nhash;
        }
        for (uint32_t k = 0; k < g->n && !rc; k++) {
            if (a[k].nhash)
                memcpy(g->hash + g->nhash, a[k].hash, a[k].nhash * sizeof *g->hash);
            g->nhash += a[k].nhash;
            g->pairs_k.up += a[k].tally.up;
            g->pairs_k.down += a[k].tally.down;
            g->pairs_k.bad_links += a[k].tally.bad_links;
            g->pairs_k.misoriented += a[k].tally.misoriented;
            g->pairs_k.marker_mismatch += a[k].tally.marker_mismatch;
            g->pairs_k.suspect |= a[k].tally.suspect;
            g->pairs_k.unmarked += a[k].tally.unmarked;
        }
    }
    if (!rc && nlf && pdr_grow((void **)&g->lf, &g->caplf, g->nlf + nlf, sizeof *g->lf))
        rc = PDR_ENOMEM;
    for (uint32_t k = 0; k < g->n && a; k++) {
        if (!rc) {
            if (a[k].nlf)
                memcpy(g->lf + g->nlf, a[k].lf, a[k].nlf * sizeof *g->lf);
            g->nlf += a[k].nlf;
            m->nghost += a[k].nghost;
        }
        pr_free(a[k].lf);
        pr_free(a[k].hash);
        pr_free(a[k].mk);
    }
    pr_free(a);
    pr_free(ft);
    if (g->careful)
        g->nhash = m->nslots;
    return rc;
}

/* The message a slot came from. */
static uint32_t src_of(const merge *g, uint32_t t)
{
    uint32_t lo = 0, hi = g->n;
    while (hi - lo > 1) {
        uint32_t mid = lo + (hi - lo) / 2;
        if (g->base[mid] <= t)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

/* ------------------------------------------------ 3. tetrahedra twice */

static int find_dup_tets(merge *g, const tm_mesh *m, par_merge_report *rep)
{
    uint64_t *rh = NULL;
    size_t nr = 0;
    int rc = hdup_find(g->hash, g->nhash, &g->scratch, &rh, &nr);
    if (rc || !nr) {
        pr_free(rh);
        return rc;
    }
    /* Some hash repeats: a tetrahedron sent twice, or (rarely) two
     * tetrahedra with one hash. Compare those by their vertices. */
    cand *c = NULL;
    size_t nc = 0, cap = 0;
    for (uint32_t t = 0; t < m->nslots && !rc; t++)
        if (hdup_has(rh, nr, tet_hash(g->vk, m->tets[t].v))) {
            uint32_t s[4];
            sort4(m->tets[t].v, s);
            rc = add_cand(&c, &nc, &cap, s, t);
        }
    pr_free(rh);
    g->drop = rc ? NULL : pr_calloc(m->nslots ? m->nslots : 1, 1);
    if (!rc && !g->drop)
        rc = PDR_ENOMEM;
    if (!rc) {
        qsort(c, nc, sizeof *c, cmp_cand);
        for (size_t k = 1; k < nc; k++)
            if (!memcmp(c[k].s, c[k - 1].s, sizeof c[k].s)) {
                g->drop[c[k].id] = 1; /* the first (lowest slot) stays */
                rep->dup_tets++;
            }
    }
    pr_free(c);
    return rc;
}

static int dropped(const merge *g, uint32_t t)
{
    return g->drop && g->drop[t];
}

/* -------------------------------------------------- 4. linked faces */

/* Face i of t and face j of u, linked by step 5: one triangle seen from
 * its two sides, with one marker. */
static void check_pair(const tm_mesh *m, uint32_t t, int i, uint32_t u, int j,
                       par_merge_report *rep)
{
    uint32_t x[3], y[3];
    face_of(m, t, i, x);
    face_of(m, u, j, y);
    if (!face_opposed(x, y))
        rep->misoriented++;
    if (tm_marker(m, t, i) != tm_marker(m, u, j))
        rep->marker_mismatch++;
}


static void prefetch_ahead(const tm_mesh *m, uint32_t t)
{
    if (t + PREFETCH_AHEAD >= m->nslots)
        return;
    for (int i = 0; i < 4; i++) {
        tm_link l = m->tets[t + PREFETCH_AHEAD].n[i];
        if (!tm_is_special(l) && tm_ltet(l) > t + PREFETCH_AHEAD) {
            /* both ends: a tm_tet may straddle two lines */
            PREFETCH(&m->tets[tm_ltet(l)].v[0]);
            PREFETCH(&m->tets[tm_ltet(l)].n[3]);
            PREFETCH(&m->flags[tm_ltet(l)]);
        }
    }
}

/* The checks of link l of face i of t, towards u = tm_ltet(l) > t: it
 * comes back, the two sides are one triangle, with one marker. Returns
 * the face's hash for step 6. */
static uint64_t check_up(const merge *g, const tm_mesh *m, uint32_t t, int i, tm_link l,
                         link_tally *k)
{
    const tm_tet *T = &m->tets[t];
    uint32_t u = tm_ltet(l);
    int j = tm_lface(l);
    const tm_tet *U = &m->tets[u];
    k->up++;
    if (U->n[j] != tm_mklink(t, i))
        k->bad_links++;
    uint32_t x[3], y[3];
    face_of(m, t, i, x);
    face_of(m, u, j, y);
    int opposed = tm_faces_opposed(x, y);
    k->misoriented += (size_t)!opposed;
    /* the flags first: a small array, and markers are rare */
    k->marker_mismatch += tm_face_marker(m, t, i) != tm_face_marker(m, u, j);
    k->suspect |= U->v[j] == T->v[i];
    return face_hash(g->vk, x[0], x[1], x[2]);
}

static void tally_into(merge *g, par_merge_report *rep, const link_tally *k)
{
    rep->bad_links += k->bad_links;
    rep->misoriented += k->misoriented;
    rep->marker_mismatch += k->marker_mismatch;
    rep->unmarked_bounds += k->unmarked;
    g->suspect |= k->suspect;
}

/* One share of step 4 on the threads of base/fj: slots [lo, hi) of a
 * mesh without dropped copies (nothing written to it), its hashes into
 * out[] (room counted beforehand). */
typedef struct link_share {
    const merge *g;
    const tm_mesh *m;
    uint32_t lo, hi;
    uint64_t *out; /* NULL: only count the links up into k.up */
    link_tally k;
} link_share;

static int link_share_run(void *arg)
{
    link_share *sh = arg;
    const tm_mesh *m = sh->m;
    size_t n = 0;
    for (uint32_t t = sh->lo; t < sh->hi; t++) {
        if (sh->out)
            prefetch_ahead(m, t);
        const tm_tet *T = &m->tets[t];
        for (int i = 0; i < 4; i++) {
            tm_link l = T->n[i];
            if (l == TM_LINK_UNSET)
                continue; /* loose: step 5 */
            if (tm_ltet(l) < t) {
                sh->k.down += sh->out != NULL; /* checked from the other side */
                continue;
            }
            if (!sh->out)
                sh->k.up++;
            else
                sh->out[n++] = check_up(sh->g, m, t, i, l, &sh->k);
        }
    }
    return 0;
}

/* Below this many slots, or with copies dropped, step 4 runs on the
 * calling thread alone. */
#define LINK_SHARES_FROM 400000
#define LINK_MAX_SHARES 8

/* Step 4 in shares on the machine's cores: the links up counted per
 * share, then each share checks its slots and writes its hashes after
 * those of the shares before it. The same counts and hashes as one pass
 * (in the same order). */
static int check_links_shared(merge *g, tm_mesh *m, par_merge_report *rep, unsigned n)
{
    link_share sh[LINK_MAX_SHARES];
    fj_task ft[LINK_MAX_SHARES];
    for (unsigned i = 0; i < n; i++) {
        sh[i] = (link_share){.g = g,
                             .m = m,
                             .lo = (uint32_t)((uint64_t)m->nslots * i / n),
                             .hi = (uint32_t)((uint64_t)m->nslots * (i + 1) / n)};
        ft[i] = (fj_task){.run = link_share_run, .arg = &sh[i]};
    }
    fj_run(ft, n, n);
    size_t total = 0;
    for (unsigned i = 0; i < n; i++)
        total += sh[i].k.up;
    if (pdr_grow((void **)&g->hash, &g->caphash, total + g->nlf + 1, sizeof *g->hash))
        return PDR_ENOMEM;
    size_t at = 0;
    for (unsigned i = 0; i < n; i++) {
        sh[i].out = g->hash + at;
        at += sh[i].k.up;
        sh[i].k.up = 0;
    }
    fj_run(ft, n, n);
    link_tally sum = {0};
    for (unsigned i = 0; i < n; i++) {
        sum.up += sh[i].k.up;
        sum.down += sh[i].k.down;
        tally_into(g, rep, &sh[i].k);
    }
    g->nhash = total;
    rep->bad_links += sum.up > sum.down ? sum.up - sum.down : sum.down - sum.up;
    return 0;
}

/* Step 4 of the messages checked ahead (par_merge_check_ahead): their
 * counts into rep and sum (their hashes are in g->hash, see add_tets). */
static void take_ahead(merge *g, par_merge_report *rep, link_tally *sum)
{
    for (uint32_t k = 0; k < g->na; k++) {
        const par_merge_ahead *a = &g->ahead[k];
        link_tally t = {.bad_links = a->bad_links,
                        .misoriented = a->misoriented,
                        .marker_mismatch = a->marker_mismatch,
                        .suspect = a->suspect,
                        .unmarked = a->unmarked};
        tally_into(g, rep, &t);
        sum->up += a->up;
        sum->down += a->down;
    }
}

/* Every pair linked within a message, checked once from its lower side:
 * it comes back, joins one triangle seen from its two sides, with one
 * marker; and its face hashed for step 6. A link into a dropped copy
 * leaves its face loose. Two tetrahedra with one opposite vertex across
 * the face have the same vertices: g->suspect (see par_merge_build).
 *
 * That links come back is checked from the lower side only, where the
 * other side is read anyway: the links up (to a higher slot) that come
 * back are a one-to-one map into the links down, so when there are as
 * many links down as up, every link down is the partner of one up, which
 * it points back to.
 *
 * The other side is anywhere in a 10^6-slot mesh, a cache and TLB miss:
 * it is asked for a few tetrahedra ahead, so that the misses overlap
 * (without, this pass took twice as long). A pass that instead summed a
 * hash of each side, in slot order, took as long in hashing. */
static int check_links(merge *g, tm_mesh *m, par_merge_report *rep)
{
    link_tally k = {0};
    if (!g->careful) {
        /* the first run: every message checked ahead or in step 2, the
         * hashes in g->hash already */
        take_ahead(g, rep, &k);
        tally_into(g, rep, &g->pairs_k);
        k.up += g->pairs_k.up;
        k.down += g->pairs_k.down;
        rep->bad_links += k.up > k.down ? k.up - k.down : k.down - k.up;
        return 0;
    }
    g->nhash = 0;
    unsigned shares = !g->drop && m->nslots >= LINK_SHARES_FROM ? fj_cores() : 1;
    if (shares > 1)
        return check_links_shared(g, m, rep, shares < LINK_MAX_SHARES ? shares : LINK_MAX_SHARES);
    /* about two linked pairs per tetrahedron, plus the groups of step 5 */
    size_t want = 2 * (size_t)m->nslots + g->nlf + 1;
    if (pdr_grow((void **)&g->hash, &g->caphash, want, sizeof *g->hash))
        return PDR_ENOMEM;
    for (uint32_t t = 0; t < m->nslots; t++) {
        prefetch_ahead(m, t);
        if (dropped(g, t))
            continue;
        tm_tet *T = &m->tets[t];
        for (int i = 0; i < 4; i++) {
            tm_link l = T->n[i];
            if (l == TM_LINK_UNSET)
                continue; /* loose: step 5 */
            uint32_t u = tm_ltet(l);
            if (dropped(g, u)) {
                T->n[i] = TM_LINK_UNSET;
                int rc = add_loose(g, tm_mklink(t, i), PAR_PE_NONE);
                if (rc)
                    return rc;
                continue;
            }
            if (u < t) {
                k.down++; /* checked from u */
                continue;
            }
            int rc = add_hash(&g->hash, &g->nhash, &g->caphash, check_up(g, m, t, i, l, &k));
            if (rc)
                return rc;
        }
    }
    tally_into(g, rep, &k);
    rep->bad_links += k.up > k.down ? k.up - k.down : k.down - k.up;
    return 0;
}

/* --------------------------------------------------- 5. loose faces */

/* A face alone: an interface face with nothing on the other side, or an
 * open face. */
static void loose_alone(tm_mesh *m, const loose *a, par_merge_report *rep)
{
    m->tets[tm_ltet(a->f)].n[tm_lface(a->f)] = TM_LINK_NONE;
    if (a->pe != PAR_PE_NONE)
        rep->iface_unmatched++;
    else
        rep->open_faces++;
}

/* Two loose faces with the same vertices: linked, and each must name the
 * other's PE (or neither a PE, within one PE: in one message, or between
 * two pieces of its submesh); checked as in step 4, suspect included. */
static void loose_pair(merge *g, tm_mesh *m, const loose *a, const loose *b,
                       par_merge_report *rep)
{
    uint32_t t = tm_ltet(a->f), u = tm_ltet(b->f);
    int i = tm_lface(a->f), j = tm_lface(b->f);
    m->tets[t].n[i] = b->f;
    m->tets[u].n[j] = a->f;
    g->suspect |= m->tets[t].v[i] == m->tets[u].v[j];
    int tin = ref_is_interior(m, t), uin = ref_is_interior(m, u);
    if (tin != uin)
        rep->unmarked_bounds += !(m->flags[tin ? t : u] & TM_F_FACEMARK(tin ? i : j));
    /* the PEs the two faces came from (a PE's pieces are its messages) */
    uint32_t st = g->w[src_of(g, t)].sm->rank, su = g->w[src_of(g, u)].sm->rank;
    if (st == su) {
        if (a->pe != PAR_PE_NONE || b->pe != PAR_PE_NONE)
            rep->iface_mismatch++;
    } else if (a->pe != su || b->pe != st) {
        rep->iface_mismatch++;
    }
    check_pair(m, t, i, u, j, rep);
}

/* The loose faces grouped by their vertices (a hash table of the few
 * percent of faces that are loose), each group checked; a group's hash
 * goes to step 6, and also to g->big when it has more than two faces. */
static int match_loose(merge *g, tm_mesh *m, par_merge_report *rep)
{
    size_t n = 0;
    for (size_t e = 0; e < g->nlf; e++)
        if (!dropped(g, tm_ltet(g->lf[e].f))) {
            loose *a = &g->lf[n++];
            *a = g->lf[e];
            face_key(m, tm_ltet(a->f), tm_lface(a->f), a->key);
            a->next = NO_FACE;
        }
    g->nlf = n;
    size_t cap = 2;
    while (cap < 2 * n)
        cap *= 2;
    uint32_t *tab = pr_malloc(cap * sizeof *tab);
    if (!tab)
        return PDR_ENOMEM;
    memset(tab, 0xff, cap * sizeof *tab);
    size_t mask = cap - 1;
    for (size_t e = 0; e < n; e++) {
        loose *a = &g->lf[e];
        size_t s = (size_t)face_hash(g->vk, a->key[0], a->key[1], a->key[2]) & mask;
        while (tab[s] != NO_FACE && memcmp(g->lf[tab[s]].key, a->key, sizeof a->key))
            s = (s + 1) & mask;
        if (tab[s] == NO_FACE) {
            tab[s] = (uint32_t)e;
        } else {
            a->next = g->lf[tab[s]].next;
            g->lf[tab[s]].next = (uint32_t)e;
        }
    }
    int rc = 0;
    for (size_t s = 0; s < cap && !rc; s++) {
        if (tab[s] == NO_FACE)
            continue;
        const loose *a = &g->lf[tab[s]];
        size_t size = 1;
        for (uint32_t e = a->next; e != NO_FACE; e = g->lf[e].next)
            size++;
        if (size == 2) {
            loose_pair(g, m, a, &g->lf[a->next], rep);
        } else {
            /* alone, or one of more than two: left unlinked */
            for (uint32_t e = tab[s]; e != NO_FACE; e = g->lf[e].next)
                loose_alone(m, &g->lf[e], rep);
        }
        uint64_t h = face_hash(g->vk, a->key[0], a->key[1], a->key[2]);
        rc = add_hash(&g->hash, &g->nhash, &g->caphash, h);
        if (!rc && size > 2)
            rc = add_hash(&g->big, &g->nbig, &g->capbig, h);
    }
    pr_free(tab);
    return rc;
}

/* ------------------------------------------------- 6. faces of three */

/* Faces of more than two tetrahedra. Every face of a kept tetrahedron is
 * in one linked pair of step 4 or one group of step 5, each hashed once:
 * a face is in more than two tetrahedra exactly when it is a group of
 * more than two, or when its hash repeats; only then are faces counted
 * one by one. */
static int find_nonmanifold(merge *g, const tm_mesh *m, par_merge_report *rep)
{
    uint64_t *rh = NULL;
    size_t nr = 0;
    int rc = hdup_find(g->hash, g->nhash, &g->scratch, &rh, &nr);
    if (rc)
        return rc;
    for (size_t k = 0; k < g->nbig; k++)
        if (!hdup_has(rh, nr, g->big[k]))
            rep->nonmanifold++; /* otherwise counted below */
    cand *c = NULL;
    size_t nc = 0, cap = 0;
    for (uint32_t t = 0; t < m->nslots && nr && !rc; t++) {
        if (dropped(g, t))
            continue;
        for (int i = 0; i < 4 && !rc; i++) {
            uint32_t s[4] = {0, 0, 0, 0};
            face_key(m, t, i, s);
            if (hdup_has(rh, nr, face_hash(g->vk, s[0], s[1], s[2])))
                rc = add_cand(&c, &nc, &cap, s, tm_mklink(t, i));
        }
    }
    pr_free(rh);
    if (!rc && nc) {
        qsort(c, nc, sizeof *c, cmp_cand);
        for (size_t k = 0; k < nc;) {
            size_t e = k + 1;
            while (e < nc && !memcmp(c[e].s, c[k].s, sizeof c[k].s))
                e++;
            rep->nonmanifold += e - k > 2;
            k = e;
        }
    }
    pr_free(c);
    return rc;
}

/* --------------------------------------------------- 7. the boundary */

/* 1 if y is x rotated (the same oriented triangle). */
static int same_rotation(const uint32_t x[3], const uint32_t y[3])
{
    for (int k = 0; k < 3; k++)
        if (y[0] == x[k])
            return y[1] == x[(k + 1) % 3] && y[2] == x[(k + 2) % 3];
    return 0;
}

static int add_bd(const merge *g, ref_mesher *r, par_merge_report *rep)
{
    bd_set *bd = &r->bd;
    for (uint32_t k = 0; k < g->n; k++) {
        const par_wire *w = &g->w[k];
        for (uint32_t j = 0; j < w->nseg; j++) {
            uint32_t a = g->loc[k][w->seg_v[2 * (size_t)j]],
                     b = g->loc[k][w->seg_v[2 * (size_t)j + 1]];
            uint32_t id = bd_find_subseg(bd, a, b);
            if (id != BD_NONE) {
                if (bd->segs[id].seg != w->seg_id[j])
                    rep->bd_conflicts++;
                bd->segs[id].flags |= w->seg_flags[j];
                continue;
            }
            int rc = bd_add_subseg(bd, a, b, w->seg_id[j], &id);
            if (rc)
                return rc;
            bd->segs[id].flags = w->seg_flags[j];
        }
        for (uint32_t j = 0; j < w->nfac; j++) {
            const uint32_t *x = w->fac_v + 3 * (size_t)j;
            uint32_t f[3] = {g->loc[k][x[0]], g->loc[k][x[1]], g->loc[k][x[2]]};
            uint32_t id = bd_find_subfac(bd, f[0], f[1], f[2]);
            if (id != BD_NONE) {
                if (bd->facs[id].facet != w->fac_id[j] || !same_rotation(bd->facs[id].v, f))
                    rep->bd_conflicts++;
                bd->facs[id].flags |= w->fac_flags[j];
                continue;
            }
            int rc = bd_add_subfac(bd, f[0], f[1], f[2], w->fac_id[j], &id);
            if (rc)
                return rc;
            bd->facs[id].flags = w->fac_flags[j];
        }
    }
    return 0;
}

/* Steps 5 and 6, a task of base/fj: writes the loose faces' links, the
 * face counts of rep and g's lists of faces. */
typedef struct face_task {
    merge *g;
    tm_mesh *m;
    par_merge_report *rep;
} face_task;

static int face_task_run(void *arg)
{
    face_task *a = arg;
    int rc = match_loose(a->g, a->m, a->rep);
    return rc ? rc : find_nonmanifold(a->g, a->m, a->rep);
}

/* Step 7 and the acute-segment table, a task of base/fj: writes only
 * r's bd and seg_acute and rep->bd_conflicts. */
typedef struct bd_task {
    const merge *g;
    ref_mesher *r;
    par_merge_report *rep;
} bd_task;

static int bd_task_run(void *arg)
{
    bd_task *a = arg;
    int rc = add_bd(a->g, a->r, a->rep);
    return rc ? rc : par_wire_seg_acute(a->r);
}

/* Decoding one message, a task of base/fj. */
typedef struct dec_task {
    const void *msg;
    size_t len;
    const plc *p;
    par_wire *out;
} dec_task;

static int dec_task_run(void *arg)
{
    dec_task *d = arg;
    return par_wire_decode(d->msg, d->len, d->p, d->out);
}

/* Step 0: every message decoded, on several threads for a large mesh (a
 * message per task). The first failure in message order is returned, as
 * one pass would stop at. */
static int decode_all(merge *g, const void *const *msg, const size_t *len, const plc *p)
{
    g->w = g->own_w = pr_calloc(g->n ? g->n : 1, sizeof *g->own_w);
    dec_task *d = pr_calloc(g->n ? g->n : 1, sizeof *d);
    fj_task *ft = pr_calloc(g->n ? g->n : 1, sizeof *ft);
    int rc = g->w && d && ft ? 0 : PDR_ENOMEM;
    size_t total = 0;
    for (uint32_t k = 0; k < g->n && !rc; k++) {
        d[k] = (dec_task){msg[k], len[k], p, &g->own_w[k]};
        ft[k] = (fj_task){.run = dec_task_run, .arg = &d[k]};
        total += len[k] / 32; /* a tetrahedron takes more than 32 bytes */
    }
    if (!rc)
        fj_run(ft, g->n, merge_threads(g->n, total));
    for (uint32_t k = 0; k < g->n && !rc; k++)
        rc = ft[k].rc;
    pr_free(d);
    pr_free(ft);
    return rc;
}

/* The messages are of one job's PEs 0..size-1 in ascending order, every
 * PE's at least one (a PE's submesh may come in pieces, PAR_MERGE_PIECE). */
static int wires_ok(const merge *g)
{
    if (g->n == 0 || !g->w[0].sm || g->w[0].sm->rank != 0)
        return PDR_EPARSE;
    uint32_t size = g->w[0].sm->size;
    for (uint32_t k = 1; k < g->n; k++) {
        const pr_submesh *sm = g->w[k].sm, *prev = g->w[k - 1].sm;
        if (!sm || sm->size != size || (sm->rank != prev->rank && sm->rank != prev->rank + 1))
            return PDR_EPARSE;
    }
    if (g->w[g->n - 1].sm->rank + 1 != size)
        return PDR_EPARSE;
    for (uint32_t k = 0; k < g->na; k++)
        if (g->ahead[k].tets != g->w[k].sm->tet.n)
            return PDR_EINVAL; /* not this message's */
    return 0;
}

/* Steps 5-6 (the faces) and 7 (the boundary tables): they share nothing
 * they write, so a large mesh has them side by side. */
static int faces_and_bd(merge *g, ref_mesher *r, par_merge_report *rep)
{
    face_task fa = {g, &r->m, rep};
    bd_task ba = {g, r, rep};
    fj_task ft[2] = {{.run = face_task_run, .arg = &fa}, {.run = bd_task_run, .arg = &ba}};
    fj_run(ft, 2, merge_threads(2, r->m.nslots));
    return ft[0].rc ? ft[0].rc : ft[1].rc;
}

static int merge_all(merge *g, ref_mesher *out, par_merge_report *rep)
{
    int rc = wires_ok(g);
    if (rc)
        return rc;
    tm_mesh *m = &out->m;
    rc = tm_enable(m, TM_FEAT_GIDS);
    if (!rc) {
        m->gid[0] = PAR_GID_INF;
        rc = add_vertices(g, out, rep);
    }
    /* the messages' vertices are in the mesh now (g->loc maps them) */
    for (uint32_t k = 0; k < g->n && g->spend && !rc; k++)
        par_wire_drop_vertices(&g->spend[k]);
    if (!rc)
        rc = add_tets(g, out);
#ifdef HAVE_MALLOC_TRIM
    /* the messages' tables that add_tets freed, back to the system
     * before steps 5-6 take their own */
    if (g->spend)
        malloc_trim(0);
#endif
    if (!rc && g->careful)
        rc = find_dup_tets(g, m, rep);
    if (!rc)
        rc = check_links(g, m, rep);
    if (!rc)
        rc = faces_and_bd(g, out, rep);
    if (rc)
        return rc;
    tm_rebuild_hints(m);
    out->classified = 1;
    rep->unmarked_known = !g->careful;
    if (g->careful)
        rep->unmarked_bounds = 0;
    rep->vertices = m->nv;
    rep->tets = m->nlive;
    return par_merge_problems(rep) ? PDR_ETOPOLOGY : 0;
}

/* A first run leaves step 3 out: it cannot change a mesh that fits (one
 * without problems), and a tetrahedron sent twice always shows in that
 * run, as problems or as a suspect pair. Its two copies have the same
 * faces: where a copy's face is linked to the other copy's, both sides
 * have the same vertex opposite (the suspect); where not, the face is in
 * two linked pairs or groups (a face of more than two tetrahedra), or in
 * a group of loose faces with it (linked as a suspect, or more than two),
 * or alone (open or unmatched). Only then does a second, careful run drop
 * the later copies first and count what is left, as the report says. */
/* The two runs (see par_merge_build) on the messages w[0..n), decoded
 * into own (freed here) when the caller gave the bytes. */
static int build_runs(const par_wire *w, par_wire *own, par_wire *spend, uint32_t n,
                      const par_merge_ahead *ahead, uint32_t na, const plc *p,
                      const ref_opts *o, ref_mesher *out, par_merge_report *rep)
{
    int rc = 0;
    for (int careful = 0; careful < 2; careful++) {
        memset(rep, 0, sizeof *rep);
        rc = ref_init(out, p, o);
        if (rc)
            break;
        merge g;
        memset(&g, 0, sizeof g);
        g.n = n;
        g.w = w;
        g.ahead = ahead;
        g.na = na < n ? na : n;
        g.careful = careful;
        g.spend = spend;
        rc = n ? merge_all(&g, out, rep) : PDR_EINVAL;
        int again = !careful && (rc == PDR_ETOPOLOGY || (!rc && g.suspect));
        if (again && spend) {
            /* no careful run without the tables: the first run's counts,
             * a pair of linked tetrahedra with one vertex set being a
             * tetrahedron sent twice */
            again = 0;
            if (!rc) {
                rep->dup_tets++;
                rc = PDR_ETOPOLOGY;
            }
        }
        st_free(&g);
        if (rc || again)
            ref_free(out);
        if (!again)
            break;
    }
    if (own)
        for (uint32_t k = 0; k < n; k++)
            par_wire_clear(&own[k]);
    pr_free(own);
    return rc;
}

int par_merge_build(const void *const *msg, const size_t *len, uint32_t n, const plc *p,
                    const ref_opts *o, ref_mesher *out, par_merge_report *rep)
{
    memset(rep, 0, sizeof *rep);
    merge g;
    memset(&g, 0, sizeof g);
    g.n = n;
    int rc = n ? decode_all(&g, msg, len, p) : PDR_EINVAL;
    par_wire *own = g.own_w;
    g.own_w = NULL;
    st_free(&g);
    if (rc) {
        if (own)
            for (uint32_t k = 0; k < n; k++)
                par_wire_clear(&own[k]);
        pr_free(own);
        /* *out freed (empty), as after a failed run */
        int irc = ref_init(out, p, o);
        if (!irc)
            ref_free(out);
        return irc ? irc : rc;
    }
    return build_runs(own, own, NULL, n, NULL, 0, p, o, out, rep);
}

int par_merge_build_wires(const par_wire *w, uint32_t n, const par_merge_ahead *ahead,
                          uint32_t na, const plc *p, const ref_opts *o, ref_mesher *out,
                          par_merge_report *rep)
{
    memset(rep, 0, sizeof *rep);
    return build_runs(w, NULL, NULL, n, ahead, na, p, o, out, rep);
}

int par_merge_build_wires_spent(par_wire *w, uint32_t n, const par_merge_ahead *ahead,
                                uint32_t na, const plc *p, const ref_opts *o, ref_mesher *out,
                                par_merge_report *rep)
{
    memset(rep, 0, sizeof *rep);
    return build_runs(w, NULL, w, n, ahead, na, p, o, out, rep);
}

/* The other side of face x's link, asked for a few faces ahead (as
 * prefetch_ahead does in the mesh). */
static void ahead_prefetch(const par_wire *w, size_t x, size_t nf)
{
    if (x >= nf)
        return;
    uint32_t c = par_wire_link(w, x);
    if (c < PAR_WIRE_LINK_IFACE && c > x) {
        PREFETCH(w->link_le + 4 * (size_t)c);
        PREFETCH(w->sm->tet.v + (size_t)(c & ~UINT32_C(3)));
        PREFETCH(w->sm->tet.marker + (size_t)c);
    }
}

int par_merge_check_ahead(const par_wire *w, par_merge_ahead *a)
{
    memset(a, 0, sizeof *a);
    const pr_submesh *sm = w->sm;
    uint32_t nv = sm->vert.n, nt = sm->tet.n;
    uint64_t *vk = pr_malloc((nv ? nv : 1) * sizeof *vk);
    /* about two linked pairs per tetrahedron */
    size_t cap = 2 * (size_t)nt + 1;
    a->hash = pr_malloc(cap * sizeof *a->hash);
    if (!vk || !a->hash) {
        pr_free(vk);
        par_merge_ahead_free(a);
        return PDR_ENOMEM;
    }
    for (uint32_t i = 0; i < nv; i++)
        vk[i] = vkey(sm->vert.gid[i]);
    a->tets = nt;
    /* the infinite vertex is vertex 0 when sent */
    uint32_t vinf = nv && sm->vert.gid[0] == PAR_GID_INF ? 0 : UINT32_MAX;
    const uint32_t *tv = sm->tet.v;
    const int32_t *mk = sm->tet.marker;
    size_t nf = 4 * (size_t)nt;
    int rc = 0;
    for (size_t x = 0; x < nf && !rc; x++) {
        ahead_prefetch(w, x + 4 * PREFETCH_AHEAD, nf);
        uint32_t c = par_wire_link(w, x);
        if (c >= PAR_WIRE_LINK_IFACE)
            continue; /* loose: step 5 */
        if (c < x) {
            a->down++; /* checked from the other side */
            continue;
        }
        /* as check_up, on the message's own vertex numbers: the merged
         * ones are one-to-one with them within a message */
        a->up++;
        size_t t = x >> 2, u = c >> 2;
        int i = (int)(x & 3), j = (int)(c & 3);
        a->bad_links += par_wire_link(w, c) != x;
        uint32_t f[3], y[3];
        for (int q = 0; q < 3; q++) {
            f[q] = tv[4 * t + (size_t)tm_face_vtx[i][q]];
            y[q] = tv[4 * u + (size_t)tm_face_vtx[j][q]];
        }
        int opposed = tm_faces_opposed(f, y);
        a->misoriented += (size_t)!opposed;
        a->marker_mismatch += mk[x] != mk[c];
        a->suspect |= tv[4 * u + (size_t)j] == tv[4 * t + (size_t)i];
        int tin = !(par_wire_tflags(w, t) & REF_F_EXTERIOR), uin = !(par_wire_tflags(w, u) &
                                                                     REF_F_EXTERIOR);
        for (int q = 0; q < 4; q++) {
            tin &= tv[4 * t + (size_t)q] != vinf;
            uin &= tv[4 * u + (size_t)q] != vinf;
        }
        if (tin != uin)
            a->unmarked += mk[tin ? x : c] == PR_MARKER_NONE;
        if (a->nhash == cap)
            rc = pdr_grow((void **)&a->hash, &cap, a->nhash + 1, sizeof *a->hash);
        if (!rc)
            a->hash[a->nhash++] = par_wire_face_hash(vk[f[0]], vk[f[1]], vk[f[2]]);
    }
    pr_free(vk);
    if (rc)
        par_merge_ahead_free(a);
    return rc ? PDR_ENOMEM : 0;
}


int par_merge_reclassify(ref_mesher *r, int missing, int refine, size_t *moved, size_t *added)
{
    *moved = *added = 0;
    size_t before = r->st.reclassified;
    int rc = 0;
    /* The marks of what the PEs left (ref_refine_marked) would hide those
     * tetrahedra from ref_refine's scan of them all. */
    for (uint32_t t = 0; t < r->m.nslots; t++)
        r->m.flags[t] &= (uint16_t)~TM_F_QUEUED;
    if (!missing) {
        /* Classified while nothing is missing: the flood fill is right. */
        rc = ref_classify(r, NULL, moved, NULL);
        if (rc || (!*moved && !refine))
            return rc;
        r->st.reclassified += *moved;
    }
    uint32_t nv0 = r->m.nv;
    r->region_doubts = 1; /* ref_refine classifies again after its run */
    rc = ref_refine(r);
    *added = (size_t)(r->m.nv - nv0);
    *moved = r->st.reclassified - before;
    return rc;
}

int par_merge_finish_left(ref_mesher *r, size_t *moved, size_t *added)
{
    size_t before = r->st.reclassified;
    uint32_t nv0 = r->m.nv;
    int rc = ref_refine_marked(r);
    *added = (size_t)(r->m.nv - nv0);
    *moved = r->st.reclassified - before;
    return rc;
}

int par_merge_put_missing(pr_buf *b, const par_sub *s, size_t *n)
{
    const bd_set *bd = &s->r.bd;
    const uint64_t *gid = s->r.m.gid;
    size_t segs, facs;
    bd_count_missing(bd, &segs, &facs);
    *n = segs + facs;
    pr_put_u32(b, (uint32_t)*n);
    for (size_t i = 0; i < bd->nsegs; i++) {
        const bd_subseg *g = &bd->segs[i];
        if ((g->flags & (BD_F_DEAD | BD_F_MISSING)) != BD_F_MISSING)
            continue;
        uint64_t k[3] = {gid[g->v[0]], gid[g->v[1]], 0};
        pr_put_u8(b, 2);
        pr_put_u64_array(b, k, 3);
        pr_put_u32(b, g->seg);
        pr_put_u16(b, g->flags);
    }
    for (size_t i = 0; i < bd->nfacs; i++) {
        const bd_subfac *g = &bd->facs[i];
        if ((g->flags & (BD_F_DEAD | BD_F_MISSING)) != BD_F_MISSING)
            continue;
        uint64_t k[3] = {gid[g->v[0]], gid[g->v[1]], gid[g->v[2]]};
        pr_put_u8(b, 3);
        pr_put_u64_array(b, k, 3);
        pr_put_u32(b, g->facet);
        pr_put_u16(b, g->flags);
    }
    return b->err ? PDR_ENOMEM : 0;
}

uint32_t par_merge_vertices_below(const tm_mesh *m, uint64_t g)
{
    uint32_t lo = 1, hi = m->nv;
    while (lo < hi) {
        uint32_t mid = lo + (hi - lo) / 2;
        if (m->gid[mid] < g)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo - 1;
}

/* The merged mesh's vertex with this gid, or TM_NONE. */
static uint32_t merged_vertex(const tm_mesh *m, uint64_t g)
{
    uint32_t v = par_merge_vertices_below(m, g) + 1;
    return g != 0 && v < m->nv && m->gid[v] == g ? v : TM_NONE;
}

int par_merge_add_missing(ref_mesher *r, const void *data, size_t len, size_t *added)
{
    *added = 0;
    pr_reader rd;
    pr_reader_init(&rd, data, len);
    uint32_t n;
    if (pr_get_count(&rd, UINT32_C(1) << 24, 31, &n))
        return PDR_EPARSE;
    for (uint32_t i = 0; i < n; i++) {
        uint8_t nv;
        uint64_t g[3];
        uint32_t feat;
        uint16_t flags;
        pr_get_u8(&rd, &nv);
        pr_get_u64_array(&rd, g, 3);
        pr_get_u32(&rd, &feat);
        pr_get_u16(&rd, &flags);
        if (rd.err || (nv != 2 && nv != 3))
            return PDR_EPARSE;
        uint32_t v[3] = {merged_vertex(&r->m, g[0]), merged_vertex(&r->m, g[1]),
                         nv == 3 ? merged_vertex(&r->m, g[2]) : TM_NONE};
        if (v[0] == TM_NONE || v[1] == TM_NONE || v[0] == v[1] ||
            (nv == 3 && (v[2] == TM_NONE || v[2] == v[0] || v[2] == v[1])))
            return PDR_EPARSE;
        uint32_t id;
        int rc;
        if (nv == 2) {
            if (feat >= r->p->nseg)
                return PDR_EPARSE;
            if (bd_find_subseg(&r->bd, v[0], v[1]) != BD_NONE)
                continue;
            rc = bd_add_subseg(&r->bd, v[0], v[1], feat, &id);
            if (!rc) {
                r->bd.segs[id].flags |= BD_F_MISSING;
                rc = ref_requeue(r, REF_SUBSEG, id, 0.0f);
            }
        } else {
            if (feat >= r->p->nfacet)
                return PDR_EPARSE;
            if (bd_find_subfac(&r->bd, v[0], v[1], v[2]) != BD_NONE)
                continue;
            rc = bd_add_subfac(&r->bd, v[0], v[1], v[2], feat, &id);
            if (!rc) {
                r->bd.facs[id].flags |= BD_F_MISSING;
                rc = ref_requeue(r, REF_SUBFACET, id, 0.0f);
            }
        }
        if (rc)
            return rc;
        (*added)++;
    }
    return pr_reader_finish(&rd) ? PDR_EPARSE : 0;
}
