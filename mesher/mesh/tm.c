/* mesh/tm.c -- storage, free list, face linking and ghosts of a tm_mesh. */
#include "config.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "mesh/tm.h"
#include "base/v3.h"

/* Growth of the arrays. Untouched capacity costs no resident memory, so
 * growing by half keeps the number of reallocations small without raising
 * the peak RSS much. */
static size_t grown(size_t cur, size_t need, size_t limit)
{
    size_t c = cur + cur / 2;
    if (c < need)
        c = need;
    if (c < 1024)
        c = 1024;
    if (c > limit)
        c = limit;
    return c;
}

static int resize(void **p, size_t n, size_t size)
{
    void *q = pr_realloc(*p, n * size);
    if (!q && n)
        return PDR_ENOMEM;
    *p = q;
    return 0;
}

static int set_vcap(tm_mesh *m, size_t cap)
{
    if (resize((void **)&m->xyz, cap, 3 * sizeof(double)) ||
        resize((void **)&m->vhint, cap, sizeof(uint32_t)) ||
        (m->gid && resize((void **)&m->gid, cap, sizeof(uint64_t))))
        return PDR_ENOMEM;
    m->vcap = (uint32_t)cap;
    return 0;
}

static int set_tcap(tm_mesh *m, size_t cap)
{
    if (resize((void **)&m->tets, cap, sizeof(tm_tet)) ||
        resize((void **)&m->flags, cap, sizeof(uint16_t)) ||
        (m->lock && resize((void **)&m->lock, cap, sizeof(uint32_t))))
        return PDR_ENOMEM;
    if (m->lock) {
        /* New slots are free (lock 0), so that a bit clear always means
         * lock[t] == 0 (tm__take_slot clears only what its bit says is
         * held); and the summary bits (tm.h, tm_set_lock): the new words
         * zeroed. */
        if (cap > m->tcap)
            memset(m->lock + m->tcap, 0, (cap - m->tcap) * sizeof(uint32_t));
        size_t had = ((size_t)m->tcap + 63) / 64, words = (cap + 63) / 64 + 1;
        if (resize((void **)&m->locked, words, sizeof(uint64_t)))
            return PDR_ENOMEM;
        if (words > had)
            memset(m->locked + had, 0, (words - had) * sizeof(uint64_t));
    }
    if (m->mk_has) {
        /* the marker map's summary bits: the new words zeroed */
        size_t had = ((size_t)m->tcap + 63) / 64, words = (cap + 63) / 64 + 1;
        if (resize((void **)&m->mk_has, words, sizeof(uint64_t)))
            return PDR_ENOMEM;
        if (words > had)
            memset(m->mk_has + had, 0, (words - had) * sizeof(uint64_t));
    }
    m->tcap = (uint32_t)cap;
    return 0;
}

int tm_init(tm_mesh *m, unsigned features)
{
    memset(m, 0, sizeof *m);
    m->free_head = TM_NONE;
    m->rng = 0x2545f4914f6cdd1dULL;
    int rc = set_vcap(m, 16);
    if (!rc)
        rc = set_tcap(m, 64);
    if (!rc)
        rc = tm_enable(m, features);
    if (rc) {
        tm_free(m);
        return rc;
    }
    m->xyz[0] = m->xyz[1] = m->xyz[2] = NAN;
    m->vhint[0] = TM_NONE;
    if (m->gid)
        m->gid[0] = 0;
    m->nv = 1;
    return 0;
}

void tm_free(tm_mesh *m)
{
    pr_free(m->xyz);
    pr_free(m->vhint);
    pr_free(m->gid);
    pr_free(m->tets);
    pr_free(m->flags);
    pr_free(m->mk_has);
    pr_free(m->mk_key);
    pr_free(m->mk_val);
    pr_free(m->lock);
    pr_free(m->locked);
    memset(m, 0, sizeof *m);
    m->free_head = TM_NONE;
}

/* ------------------------------------------------ the face marker map */

#define MK_MIN_CAP 64u

static inline size_t marks_home(uint32_t key, uint32_t cap)
{
    /* Fibonacci hashing: the top bits of the product, as many as cap
     * has; neighbouring faces land far apart. */
    unsigned bits = (unsigned)__builtin_ctz(cap);
    return (size_t)(((uint64_t)key * UINT64_C(0x9E3779B97F4A7C15)) >> (64 - bits));
}

/* The index of key, or of the empty key where it would go. */
static size_t marks_probe(const tm_mesh *m, uint32_t key)
{
    size_t mask = m->mk_cap - 1, i = marks_home(key, m->mk_cap);
    while (m->mk_key[i] != key && m->mk_key[i] != TM_NONE)
        i = (i + 1) & mask;
    return i;
}

/* Moves the map into arrays of cap keys (a power of two, more than twice
 * the keys held). The old arrays stay if the new ones cannot be had. */
static int marks_rehash(tm_mesh *m, uint32_t cap)
{
    uint32_t *key = pr_malloc((size_t)cap * sizeof *key);
    int32_t *val = pr_malloc((size_t)cap * sizeof *val);
    if (!key || !val) {
        pr_free(key);
        pr_free(val);
        return PDR_ENOMEM;
    }
    memset(key, 0xff, (size_t)cap * sizeof *key); /* TM_NONE */
    tm_mesh nm = *m;
    nm.mk_key = key;
    nm.mk_val = val;
    nm.mk_cap = cap;
    for (uint32_t j = 0; j < m->mk_cap; j++) {
        uint32_t k = m->mk_key[j];
        if (k == TM_NONE)
            continue;
        size_t i = marks_probe(&nm, k);
        key[i] = k;
        val[i] = m->mk_val[j];
    }
    pr_free(m->mk_key);
    pr_free(m->mk_val);
    m->mk_key = key;
    m->mk_val = val;
    m->mk_cap = cap;
    return 0;
}

/* Room in the map for `more` keys beyond those held, at most half full. */
static int marks_room(tm_mesh *m, size_t more)
{
    size_t need = 2 * ((size_t)m->mk_n + more), cap = m->mk_cap;
    if (need <= cap)
        return 0;
    while (cap < need) {
        if (cap > UINT32_MAX / 2)
            return PDR_ELIMIT;
        cap *= 2;
    }
    return marks_rehash(m, (uint32_t)cap);
}

/* Removes the key at index i (backward-shift deletion: every later key
 * of the run that may live at i, its home not cyclically in (i, j], is
 * moved up). */
static void marks_remove_at(tm_mesh *m, size_t i)
{
    size_t mask = m->mk_cap - 1;
    m->mk_n--;
    for (size_t j = i;;) {
        m->mk_key[i] = TM_NONE;
        for (;;) {
            j = (j + 1) & mask;
            if (m->mk_key[j] == TM_NONE)
                return;
            size_t h = marks_home(m->mk_key[j], m->mk_cap);
            if (i <= j ? (i < h && h <= j) : (i < h || h <= j))
                continue;
            break;
        }
        m->mk_key[i] = m->mk_key[j];
        m->mk_val[i] = m->mk_val[j];
        i = j;
    }
}

int tm_marker_room(tm_mesh *m, size_t count)
{
    return m->mk_has ? marks_room(m, count) : 0;
}

int32_t tm__marker(const tm_mesh *m, uint32_t t, int i)
{
    size_t k = marks_probe(m, 4 * t + (uint32_t)i);
    return m->mk_key[k] == TM_NONE ? 0 : m->mk_val[k];
}

void tm__clear_marks(tm_mesh *m, uint32_t t)
{
    m->mk_has[t >> 6] &= ~((uint64_t)1 << (t & 63u));
    for (uint32_t i = 0; i < 4; i++) {
        size_t k = marks_probe(m, 4 * t + i);
        if (m->mk_key[k] != TM_NONE)
            marks_remove_at(m, k);
    }
}

int tm_set_marker(tm_mesh *m, uint32_t t, int i, int32_t marker)
{
    uint32_t key = 4 * t + (uint32_t)i;
    if (!marker) {
        if (!tm__has_marks(m, t))
            return 0;
        size_t k = marks_probe(m, key);
        if (m->mk_key[k] == TM_NONE)
            return 0;
        marks_remove_at(m, k);
        /* the slot's bit goes with its last marker */
        int left = 0;
        for (uint32_t f = 0; f < 4; f++)
            left |= m->mk_key[marks_probe(m, 4 * t + f)] != TM_NONE;
        if (!left)
            m->mk_has[t >> 6] &= ~((uint64_t)1 << (t & 63u));
        return 0;
    }
    size_t k = marks_probe(m, key);
    if (m->mk_key[k] == TM_NONE) {
        int rc = marks_room(m, 1);
        if (rc)
            return rc;
        k = marks_probe(m, key); /* the map may have moved */
        m->mk_key[k] = key;
        m->mk_n++;
        m->mk_has[t >> 6] |= (uint64_t)1 << (t & 63u);
    }
    m->mk_val[k] = marker;
    return 0;
}

int tm_enable(tm_mesh *m, unsigned features)
{
    if ((features & TM_FEAT_MARKERS) && !m->mk_has) {
        uint64_t *has = pr_calloc(((size_t)m->tcap + 63) / 64 + 1, sizeof(uint64_t));
        if (!has || marks_rehash(m, MK_MIN_CAP)) {
            pr_free(has);
            return PDR_ENOMEM;
        }
        m->mk_has = has;
    }
    if ((features & TM_FEAT_LOCKS) && !m->lock) {
        m->lock = pr_calloc(m->tcap ? m->tcap : 1, sizeof(uint32_t));
        m->locked = pr_calloc(((size_t)m->tcap + 63) / 64 + 1, sizeof(uint64_t));
        if (!m->lock || !m->locked) {
            pr_free(m->lock);
            pr_free(m->locked);
            m->lock = NULL;
            m->locked = NULL;
            return PDR_ENOMEM;
        }
    }
    if ((features & TM_FEAT_GIDS) && !m->gid) {
        m->gid = pr_calloc(m->vcap ? m->vcap : 1, sizeof(uint64_t));
        if (!m->gid)
            return PDR_ENOMEM;
        for (uint32_t v = 0; v < m->nv; v++)
            m->gid[v] = v;
    }
    m->features |= features;
    return 0;
}

void tm_drop_locks(tm_mesh *m)
{
    pr_free(m->lock);
    pr_free(m->locked);
    m->lock = NULL;
    m->locked = NULL;
}

void tm__unlock_slot(tm_mesh *m, uint32_t t)
{
    tm_set_lock(m, t, 0);
}

int tm_reserve(tm_mesh *m, size_t nverts, size_t ntets)
{
    if (nverts > TM_MAX_VERTS || ntets > TM_MAX_TETS)
        return PDR_ELIMIT;
    if (nverts > m->vcap && set_vcap(m, nverts))
        return PDR_ENOMEM;
    if (ntets > m->tcap && set_tcap(m, ntets))
        return PDR_ENOMEM;
    return 0;
}

int tm_add_vertex(tm_mesh *m, const double p[3], uint32_t *out)
{
    if (m->nv == m->vcap) {
        if (m->nv >= TM_MAX_VERTS)
            return PDR_ELIMIT;
        if (set_vcap(m, grown(m->vcap, (size_t)m->nv + 1, TM_MAX_VERTS)))
            return PDR_ENOMEM;
    }
    uint32_t v = m->nv++;
    memcpy(m->xyz + 3 * (size_t)v, p, 3 * sizeof(double));
    m->vhint[v] = TM_NONE;
    if (m->gid)
        m->gid[v] = v;
    *out = v;
    return 0;
}

int tm_room(tm_mesh *m, size_t count)
{
    if (count <= m->nfree)
        return 0;
    size_t need = (size_t)m->nslots + (count - m->nfree);
    if (need <= m->tcap)
        return 0;
    if (need > TM_MAX_TETS)
        return PDR_ELIMIT;
    return set_tcap(m, grown(m->tcap, need, TM_MAX_TETS)) ? PDR_ENOMEM : 0;
}

void tm_delete_tet(tm_mesh *m, uint32_t t)
{
    tm_tet *T = &m->tets[t];
    for (int i = 0; i < 4; i++) {
        tm_link l = T->n[i];
        if (!tm_is_special(l) && !tm_is_dead(m, tm_ltet(l)))
            m->tets[tm_ltet(l)].n[tm_lface(l)] = TM_LINK_NONE;
    }
    /* Keep the vertex hints pointing at live tetrahedra where we can: a
     * neighbour across a face containing v also contains v. */
    for (int s = 0; s < 4; s++) {
        uint32_t v = T->v[s];
        if (m->vhint[v] != t)
            continue;
        m->vhint[v] = TM_NONE;
        for (int i = 0; i < 4; i++) {
            tm_link l = T->n[i];
            if (i != s && !tm_is_special(l) && !tm_is_dead(m, tm_ltet(l))) {
                m->vhint[v] = tm_ltet(l);
                break;
            }
        }
    }
    tm_free_tet(m, t);
}

int tm_mark_face(tm_mesh *m, uint32_t t, int i, int32_t marker)
{
    uint32_t ts[2] = {t, TM_NONE};
    int fs[2] = {i, 0};
    tm_link l = m->tets[t].n[i];
    if (!tm_is_special(l)) {
        ts[1] = tm_ltet(l);
        fs[1] = tm_lface(l);
    }
    for (int k = 0; k < 2 && ts[k] != TM_NONE; k++) {
        int rc = tm_set_marker(m, ts[k], fs[k], marker);
        if (rc)
            return rc;
        if (marker)
            m->flags[ts[k]] |= TM_F_FACEMARK(fs[k]);
        else
            m->flags[ts[k]] &= (uint16_t)~TM_F_FACEMARK(fs[k]);
    }
    return 0;
}

void tm_rebuild_hints(tm_mesh *m)
{
    for (uint32_t v = 0; v < m->nv; v++)
        m->vhint[v] = TM_NONE;
    for (uint32_t t = 0; t < m->nslots; t++)
        if (!tm_is_dead(m, t))
            for (int s = 0; s < 4; s++)
                m->vhint[m->tets[t].v[s]] = t;
}

/* ------------------------------------------------------- face matching */

typedef struct keyed {
    uint64_t key;
    tm_link link;
} keyed;

static int keyed_cmp(const void *pa, const void *pb)
{
    const keyed *a = pa, *b = pb;
    return (a->key > b->key) - (a->key < b->key);
}

static void sort_keyed(keyed *k, size_t n)
{
    if (n < 24) {
        for (size_t i = 1; i < n; i++) {
            keyed x = k[i];
            size_t j = i;
            while (j > 0 && k[j - 1].key > x.key) {
                k[j] = k[j - 1];
                j--;
            }
            k[j] = x;
        }
    } else {
        qsort(k, n, sizeof *k, keyed_cmp);
    }
}

/* Links runs of equal keys: pairs become neighbours, singles get
 * TM_LINK_NONE, longer runs are left unlinked. Returns the number of runs
 * longer than two, plus the singles when singles_bad. */
static size_t link_runs(tm_mesh *m, keyed *k, size_t n, int singles_bad)
{
    size_t bad = 0;
    for (size_t i = 0; i < n;) {
        size_t j = i + 1;
        while (j < n && k[j].key == k[i].key)
            j++;
        if (j - i == 2) {
            tm_link a = k[i].link, b = k[i + 1].link;
            m->tets[tm_ltet(a)].n[tm_lface(a)] = b;
            m->tets[tm_ltet(b)].n[tm_lface(b)] = a;
        } else {
            if (j - i > 2 || singles_bad)
                bad++;
            for (size_t q = i; q < j; q++)
                m->tets[tm_ltet(k[q].link)].n[tm_lface(k[q].link)] = TM_LINK_NONE;
        }
        i = j;
    }
    return bad;
}

static void face_sorted(const tm_tet *T, int i, uint32_t f[3])
{
    v3_sort3u(T->v[tm_face_vtx[i][0]], T->v[tm_face_vtx[i][1]], T->v[tm_face_vtx[i][2]], f);
}

int tm_link_faces(tm_mesh *m, size_t *nonmanifold)
{
    /* Faces are bucketed by their smallest vertex (counting sort), then
     * each bucket, about 27 faces for a Delaunay mesh, is sorted by the
     * other two vertices. Memory: one link per face plus one offset per
     * vertex, instead of a sort of every face with its full key. */
    size_t *start = pr_calloc((size_t)m->nv + 1, sizeof *start);
    if (!start)
        return PDR_ENOMEM;
    size_t nfaces = 0;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t))
            continue;
        for (int i = 0; i < 4; i++) {
            uint32_t f[3];
            face_sorted(&m->tets[t], i, f);
            start[f[0] + 1]++;
            nfaces++;
        }
    }
    for (uint32_t v = 0; v < m->nv; v++)
        start[v + 1] += start[v];
    tm_link *bucket = pr_malloc((nfaces ? nfaces : 1) * sizeof *bucket);
    size_t *fill = pr_malloc(((size_t)m->nv + 1) * sizeof *fill);
    if (!bucket || !fill) {
        pr_free(start);
        pr_free(bucket);
        pr_free(fill);
        return PDR_ENOMEM;
    }
    memcpy(fill, start, ((size_t)m->nv + 1) * sizeof *fill);
    size_t maxrun = 0;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t))
            continue;
        for (int i = 0; i < 4; i++) {
            uint32_t f[3];
            face_sorted(&m->tets[t], i, f);
            bucket[fill[f[0]]++] = tm_mklink(t, i);
        }
    }
    pr_free(fill);
    for (uint32_t v = 0; v < m->nv; v++)
        if (start[v + 1] - start[v] > maxrun)
            maxrun = start[v + 1] - start[v];
    keyed *k = pr_malloc((maxrun ? maxrun : 1) * sizeof *k);
    if (!k) {
        pr_free(start);
        pr_free(bucket);
        return PDR_ENOMEM;
    }
    size_t bad = 0;
    for (uint32_t v = 0; v < m->nv; v++) {
        size_t n = start[v + 1] - start[v];
        for (size_t q = 0; q < n; q++) {
            tm_link l = bucket[start[v] + q];
            uint32_t f[3];
            face_sorted(&m->tets[tm_ltet(l)], tm_lface(l), f);
            k[q].key = ((uint64_t)f[1] << 32) | f[2];
            k[q].link = l;
        }
        sort_keyed(k, n);
        bad += link_runs(m, k, n, 0);
    }
    pr_free(k);
    pr_free(bucket);
    pr_free(start);
    if (nonmanifold)
        *nonmanifold = bad;
    return 0;
}

int tm_add_ghosts(tm_mesh *m, size_t *open_edges)
{
    size_t nhull = 0;
    uint32_t nslots0 = m->nslots;
    for (uint32_t t = 0; t < nslots0; t++)
        if (!tm_is_dead(m, t) && !tm_is_ghost(m, t))
            for (int i = 0; i < 4; i++)
                nhull += m->tets[t].n[i] == TM_LINK_NONE;
    int rc = tm_room(m, nhull);
    if (rc)
        return rc;
    keyed *k = pr_malloc((3 * nhull + 1) * sizeof *k);
    if (!k)
        return PDR_ENOMEM;
    size_t nk = 0;
    for (uint32_t t = 0; t < nslots0; t++) {
        if (tm_is_dead(m, t) || tm_is_ghost(m, t))
            continue;
        for (int i = 0; i < 4; i++) {
            if (m->tets[t].n[i] != TM_LINK_NONE)
                continue;
            const tm_tet *T = &m->tets[t];
            uint32_t g = tm_alloc_tet(m);
            tm_tet *G = &m->tets[g];
            /* Reversed face: the hull's outside on the positive side. */
            G->v[0] = T->v[tm_face_vtx[i][0]];
            G->v[1] = T->v[tm_face_vtx[i][2]];
            G->v[2] = T->v[tm_face_vtx[i][1]];
            G->v[3] = TM_VINF;
            G->n[3] = tm_mklink(t, i);
            m->tets[t].n[i] = tm_mklink(g, 3);
            m->nghost++;
            m->vhint[TM_VINF] = g;
            for (int j = 0; j < 3; j++) {
                /* face j of G holds vertex 0 and the two others */
                uint32_t a = G->v[(j + 1) % 3], b = G->v[(j + 2) % 3];
                if (a > b) {
                    uint32_t x = a;
                    a = b;
                    b = x;
                }
                k[nk].key = ((uint64_t)a << 32) | b;
                k[nk].link = tm_mklink(g, j);
                nk++;
            }
        }
    }
    qsort(k, nk, sizeof *k, keyed_cmp);
    size_t bad = link_runs(m, k, nk, 1);
    pr_free(k);
    if (open_edges)
        *open_edges = bad;
    return 0;
}

void tm_remove_ghosts(tm_mesh *m)
{
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t))
            continue;
        int k = tm_ghost_slot(m, t);
        if (k < 0)
            continue;
        tm_link l = m->tets[t].n[k];
        if (!tm_is_special(l))
            m->tets[tm_ltet(l)].n[tm_lface(l)] = TM_LINK_NONE;
        tm_free_tet(m, t);
    }
    m->vhint[TM_VINF] = TM_NONE;
}

/* The whole bytes of a slot: everything but its lock summary bit. */
static size_t slot_bytes(const tm_mesh *m)
{
    return sizeof(tm_tet) + sizeof(uint16_t) + (m->lock ? sizeof(uint32_t) : 0);
}

double tm_bytes_per_tet(const tm_mesh *m)
{
    return (double)slot_bytes(m) + (m->locked ? 1.0 / 8.0 : 0.0) +
           (m->mk_has ? 1.0 / 8.0 : 0.0);
}

size_t tm_bytes_per_vertex(const tm_mesh *m)
{
    return 3 * sizeof(double) + sizeof(uint32_t) + (m->gid ? sizeof(uint64_t) : 0);
}

size_t tm_bytes_used(const tm_mesh *m)
{
    size_t words = ((size_t)m->nslots + 63) / 64 * sizeof(uint64_t);
    size_t bits = (m->locked ? words : 0) + (m->mk_has ? words : 0);
    size_t map = (size_t)m->mk_cap * (sizeof(uint32_t) + sizeof(int32_t));
    return (size_t)m->nslots * slot_bytes(m) + bits + map +
           (size_t)m->nv * tm_bytes_per_vertex(m);
}
