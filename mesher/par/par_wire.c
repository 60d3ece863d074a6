/* par/par_wire.c -- the wire form of a submesh and the submesh built from
 * it (see par/par_wire.h for the byte layout and its rules). */
#include "config.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "base/pdr_util.h"
#include "base/v3.h"
#include "par/par_wire.h"

/* A hint to load a cache line now (a no-op where the compiler has none). */
#if defined(__GNUC__)
#define WIRE_PREFETCH(p) __builtin_prefetch(p)
#else
#define WIRE_PREFETCH(p) ((void)(p))
#endif

/* Bytes per element of the extension's arrays. */
#define VEXT_ELEM (1 + 4 + 4)
#define TEXT_ELEM (2 + 2 + 16)
#define SEG_ELEM (4 + 4 + 4 + 2)
#define FAC_ELEM (12 + 4 + 2)
/* At most six subsegments and four subfacets per tetrahedron sent. */
#define MAX_SEGS (6 * PR_MAX_TETS)
#define MAX_FACS (4 * PR_MAX_TETS)

/* A proto error as the mesher's: memory stays memory, everything else
 * becomes 'other' (PDR_EPARSE for a decoder, PDR_EINVAL for an encoder). */
static int from_pr(int rc, int other)
{
    return rc == 0 ? 0 : rc == PR_ENOMEM ? PDR_ENOMEM : other;
}

static uint32_t f32_bits(float x)
{
    uint32_t u;
    memcpy(&u, &x, sizeof u);
    return u;
}

static float f32_of(uint32_t u)
{
    float x;
    memcpy(&x, &u, sizeof x);
    return x;
}

/* ---------------------------------------------------------------- encode */

typedef struct gid_vertex {
    uint64_t gid;
    uint32_t v;
} gid_vertex;

/* Bits per pass of sort_gids. */
#define RADIX_BITS 11
#define RADIX_BINS (1u << RADIX_BITS)

/* Sorts a[0..n) by gid, least significant digit first, with tmp[0..n) as
 * scratch. A gid is a rank and a counter (pr_gid_make): most of its 64
 * bits are the same in every vertex of a PE, and a digit that is the same
 * in all of them is skipped, so this is about three passes over a table
 * that qsort took ten times as long for. Returns 0 or PDR_ENOMEM. */
static int sort_gids(gid_vertex *a, uint32_t n)
{
    gid_vertex *tmp = pr_malloc((n ? n : 1) * sizeof *tmp);
    size_t *count = pr_malloc(RADIX_BINS * sizeof *count);
    if (!tmp || !count) {
        pr_free(tmp);
        pr_free(count);
        return PDR_ENOMEM;
    }
    gid_vertex *from = a, *to = tmp;
    for (unsigned shift = 0; shift < 64; shift += RADIX_BITS) {
        memset(count, 0, RADIX_BINS * sizeof *count);
        for (uint32_t i = 0; i < n; i++)
            count[(from[i].gid >> shift) & (RADIX_BINS - 1)]++;
        if (n == 0 || count[(from[0].gid >> shift) & (RADIX_BINS - 1)] == n)
            continue; /* one digit everywhere: the order stays */
        size_t sum = 0;
        for (unsigned d = 0; d < RADIX_BINS; d++) {
            size_t c = count[d];
            count[d] = sum;
            sum += c;
        }
        for (uint32_t i = 0; i < n; i++)
            to[count[(from[i].gid >> shift) & (RADIX_BINS - 1)]++] = from[i];
        gid_vertex *x = from;
        from = to;
        to = x;
    }
    if (from != a)
        memcpy(a, from, (size_t)n * sizeof *a);
    pr_free(tmp);
    pr_free(count);
    return 0;
}

/* Scratch of one encoding; every pointer owned, freed by enc_free. */
typedef struct enc {
    uint32_t *idx;      /* per vertex of the mesh: message index or UINT32_MAX */
    gid_vertex *verts;  /* the vertices sent, sorted by gid */
    uint32_t nv;
    uint64_t *sent;     /* bit per slot of the mesh: in src->tets (ascending) */
    uint32_t *below;    /* per 64 slots: how many of the slots before are sent */
    uint32_t *pos;      /* when src->tets is not ascending: per slot, its
                           index there or UINT32_MAX */
    pr_submesh sm;      /* arrays below are ours */
    uint8_t *seen_seg, *seen_fac; /* per bd slot: listed already */
    uint32_t *segs, *facs; /* bd indices to send */
    uint32_t nseg, nfac;
} enc;

static void enc_free(enc *e)
{
    pr_free(e->idx);
    pr_free(e->verts);
    pr_free(e->sent);
    pr_free(e->below);
    pr_free(e->pos);
    pr_free(e->sm.vert.gid); /* one block with xyz and flags (pr_vtable_clear) */
    pr_free(e->sm.tet.v);    /* one block with marker and subseg (pr_ttable_clear) */
    pr_free(e->sm.iface.face);
    pr_free(e->sm.iface.remote);
    pr_free(e->seen_seg);
    pr_free(e->seen_fac);
    pr_free(e->segs);
    pr_free(e->facs);
}

/* The vertex table: every vertex the tetrahedra use, by ascending gid. */
static int enc_vertices(enc *e, const par_wire_src *src)
{
    const tm_mesh *m = &src->r->m;
    e->idx = pr_malloc(((size_t)m->nv ? m->nv : 1) * sizeof *e->idx);
    /* at most 4 nt distinct vertices, and at most nv */
    size_t cap = 4 * (size_t)src->nt < m->nv ? 4 * (size_t)src->nt : m->nv;
    e->verts = pr_malloc((cap ? cap : 1) * sizeof *e->verts);
    if (!e->idx || !e->verts)
        return PDR_ENOMEM;
    memset(e->idx, 0xff, (size_t)m->nv * sizeof *e->idx);
    uint32_t n = 0;
    for (uint32_t k = 0; k < src->nt; k++) {
        const uint32_t *v = m->tets[src->tets[k]].v;
        for (int s = 0; s < 4; s++) {
            if (v[s] >= m->nv)
                return PDR_EINVAL;
            if (e->idx[v[s]] != UINT32_MAX)
                continue;
            uint64_t g = src->gid[v[s]];
            if ((v[s] == TM_VINF) != (g == PAR_GID_INF) || g == PR_GID_NONE ||
                pr_gid_rank(g) >= src->size)
                return PDR_EINVAL;
            e->idx[v[s]] = n;
            e->verts[n].gid = g;
            e->verts[n].v = v[s];
            n++;
        }
    }
    if (n > PR_MAX_VERTICES)
        return PDR_ELIMIT;
    if (sort_gids(e->verts, n))
        return PDR_ENOMEM;
    for (uint32_t i = 0; i < n; i++) {
        if (i > 0 && e->verts[i].gid == e->verts[i - 1].gid)
            return PDR_EINVAL; /* two vertices with one gid */
        e->idx[e->verts[i].v] = i;
    }
    e->nv = n;
    pr_vtable *vt = &e->sm.vert;
    vt->n = n;
    /* One block, as proto's decoder has it, so that par_wire_from_sub can
     * hand the table over to a pr_submesh. */
    vt->gid = pr_malloc((size_t)(n ? n : 1) * (8 + 24 + 4));
    if (!vt->gid)
        return PDR_ENOMEM;
    vt->xyz = (double *)(vt->gid + n);
    vt->flags = (uint32_t *)(vt->xyz + 3 * (size_t)n);
    memset(vt->flags, 0, (size_t)n * sizeof *vt->flags);
    for (uint32_t i = 0; i < n; i++) {
        uint32_t v = e->verts[i].v;
        vt->gid[i] = e->verts[i].gid;
        for (int c = 0; c < 3; c++) {
            double x = v == TM_VINF ? 0.0 : tm_xyz(m, v)[c];
            if (!isfinite(x))
                return PDR_EINVAL;
            vt->xyz[3 * (size_t)i + c] = x;
        }
    }
    return 0;
}

/* Set bits in x (no builtin: C11 has none, and x86-64's baseline lacks
 * the instruction anyway). */
static unsigned popcount64(uint64_t x)
{
    x -= (x >> 1) & UINT64_C(0x5555555555555555);
    x = (x & UINT64_C(0x3333333333333333)) + ((x >> 2) & UINT64_C(0x3333333333333333));
    x = (x + (x >> 4)) & UINT64_C(0x0F0F0F0F0F0F0F0F);
    return (unsigned)((x * UINT64_C(0x0101010101010101)) >> 56);
}

/* Where slot u of the mesh is in the message, or UINT32_MAX. When the
 * tetrahedra sent are slots 0..nt-1 (a PE's whole mesh without a free
 * slot), u itself. When they are in ascending slot order (a PE's mesh
 * with free slots, a part of Mo), the number of slots sent below u: a bit
 * per slot and a count per 64 slots, 1/29 of a map of every slot, which
 * the links of 10^6 tetrahedra read at random. */
static uint32_t pos_of(const enc *e, const par_wire_src *src, uint32_t u)
{
    if (u >= src->r->m.nslots)
        return UINT32_MAX;
    if (e->pos)
        return e->pos[u];
    if (!e->sent)
        return u < src->nt ? u : UINT32_MAX;
    uint64_t w = e->sent[u >> 6], bit = UINT64_C(1) << (u & 63);
    return w & bit ? e->below[u >> 6] + popcount64(w & (bit - 1)) : UINT32_MAX;
}

/* The map pos_of reads (see there). Returns 0, PDR_ENOMEM or PDR_EINVAL
 * (a slot twice). */
static int enc_positions(enc *e, const par_wire_src *src)
{
    size_t ns = src->r->m.nslots, nt = src->nt, ascending = 1, ident = 0;
    while (ident < nt && src->tets[ident] == ident)
        ident++;
    if (ident == nt)
        return 0;
    for (size_t k = 1; k < nt && ascending; k++)
        ascending = src->tets[k] > src->tets[k - 1];
    if (ascending) {
        size_t nw = ns / 64 + 1;
        e->sent = pr_calloc(nw, sizeof *e->sent);
        e->below = pr_malloc(nw * sizeof *e->below);
        if (!e->sent || !e->below)
            return PDR_ENOMEM;
        for (size_t k = 0; k < nt; k++)
            e->sent[src->tets[k] >> 6] |= UINT64_C(1) << (src->tets[k] & 63);
        uint32_t c = 0;
        for (size_t w = 0; w < nw; w++) {
            e->below[w] = c;
            c += popcount64(e->sent[w]);
        }
        return 0;
    }
    e->pos = pr_malloc((ns ? ns : 1) * sizeof *e->pos);
    if (!e->pos)
        return PDR_ENOMEM;
    memset(e->pos, 0xff, ns * sizeof *e->pos);
    for (size_t k = 0; k < nt; k++) {
        if (e->pos[src->tets[k]] != UINT32_MAX)
            return PDR_EINVAL; /* a slot twice: its links would not come back */
        e->pos[src->tets[k]] = (uint32_t)k;
    }
    return 0;
}

/* The PE across face i of tets[k], whose link is l (PAR_PE_NONE for
 * none): from face_pe, or from the interface table the link names.
 * Returns 0 or PDR_EINVAL (a link to no interface entry, a bad PE). */
static int face_pe(const par_wire_src *src, size_t k, int i, tm_link l, uint32_t *pe)
{
    *pe = PAR_PE_NONE;
    if (src->face_pe) {
        *pe = src->face_pe[4 * k + (size_t)i];
    } else if (l >= TM_LINK_SPECIAL && l < TM_LINK_UNSET) {
        uint32_t j = l - TM_LINK_SPECIAL;
        if (!src->ifc || j >= src->nifc)
            return PDR_EINVAL;
        *pe = src->ifc[j].pe;
        if (*pe == PAR_PE_NONE)
            return PDR_EINVAL; /* a free entry */
    }
    return *pe != PAR_PE_NONE && (*pe >= src->size || *pe == src->rank) ? PDR_EINVAL : 0;
}

/* The link sent for face i of tets[k] (see the header), once enc_tets
 * checked the PEs: refuses a face both linked to a tetrahedron sent and
 * named remote. That the link comes back is the receiver's check: here
 * it would cost a cache miss per face of a large mesh. */
static int enc_link(const enc *e, const par_wire_src *src, size_t k, int i, uint32_t *out)
{
    tm_link l = src->r->m.tets[src->tets[k]].n[i];
    int remote = src->face_pe ? src->face_pe[4 * k + (size_t)i] != PAR_PE_NONE
                              : l >= TM_LINK_SPECIAL && l < TM_LINK_UNSET;
    uint32_t u = tm_is_special(l) ? UINT32_MAX : pos_of(e, src, tm_ltet(l));
    if (u != UINT32_MAX && remote)
        return PDR_EINVAL;
    *out = remote            ? PAR_WIRE_LINK_IFACE
           : u != UINT32_MAX ? tm_mklink(u, tm_lface(l))
                             : PAR_WIRE_LINK_NONE;
    return 0;
}

/* The tetrahedron table and the interface faces (the links are written
 * straight into the message by put_ext). */
static int enc_tets(enc *e, const par_wire_src *src)
{
    const tm_mesh *m = &src->r->m;
    const plc *p = src->r->p;
    pr_ttable *tt = &e->sm.tet;
    size_t nt = src->nt;
    tt->n = src->nt;
    /* one block, as for the vertices */
    tt->v = pr_malloc((nt ? nt : 1) * (16 + 16 + 1));
    if (!tt->v)
        return PDR_ENOMEM;
    tt->marker = (int32_t *)(tt->v + 4 * nt);
    tt->subseg = (uint8_t *)(tt->marker + 4 * nt);
    int rc = enc_positions(e, src);
    if (rc)
        return rc;
    pr_iftable *f = &e->sm.iface;
    size_t capf = 0, capr = 0;
    for (size_t k = 0; k < nt; k++) {
        uint32_t t = src->tets[k];
        const tm_tet *T = &m->tets[t];
        for (int i = 0; i < 4; i++) {
            tt->v[4 * k + (size_t)i] = e->idx[T->v[i]];
            int32_t mk = tm_has_markers(m) ? tm_face_marker(m, t, i) : 0;
            if (mk < 0 || (size_t)mk > p->nfacet)
                return PDR_EINVAL;
            tt->marker[4 * k + (size_t)i] = mk ? mk - 1 : PR_MARKER_NONE;
            uint32_t pe;
            if (face_pe(src, k, i, T->n[i], &pe))
                return PDR_EINVAL;
            if (pe == PAR_PE_NONE)
                continue;
            if (pdr_grow((void **)&f->face, &capf, (size_t)f->n + 1, sizeof *f->face) ||
                pdr_grow((void **)&f->remote, &capr, (size_t)f->n + 1, sizeof *f->remote))
                return PDR_ENOMEM;
            f->face[f->n] = (uint32_t)(4 * k + (size_t)i);
            f->remote[f->n++] = pe;
        }
        tt->subseg[k] = (uint8_t)((m->flags[t] & TM_F_SUBSEGS) / TM_F_SUBSEG0);
    }
    return 0;
}

/* The subsegments on marked edges and subfacets on marked faces of the
 * tetrahedra, each once. */
static int enc_bd(enc *e, const par_wire_src *src)
{
    const tm_mesh *m = &src->r->m;
    const bd_set *bd = &src->r->bd;
    e->seen_seg = pr_calloc(bd->nsegs ? bd->nsegs : 1, 1);
    e->seen_fac = pr_calloc(bd->nfacs ? bd->nfacs : 1, 1);
    size_t cs = bd->live_segs, cf = bd->live_facs;
    e->segs = pr_malloc((cs ? cs : 1) * sizeof *e->segs);
    e->facs = pr_malloc((cf ? cf : 1) * sizeof *e->facs);
    if (!e->seen_seg || !e->seen_fac || !e->segs || !e->facs)
        return PDR_ENOMEM;
    for (uint32_t k = 0; k < src->nt; k++) {
        uint32_t t = src->tets[k];
        uint16_t fl = m->flags[t];
        const uint32_t *v = m->tets[t].v;
        for (int ed = 0; ed < 6 && (fl & TM_F_SUBSEGS); ed++) {
            if (!(fl & TM_F_SUBSEG(ed)))
                continue;
            uint32_t id = bd_find_subseg(bd, v[tm_edge_vtx[ed][0]], v[tm_edge_vtx[ed][1]]);
            if (id == BD_NONE)
                return PDR_ETOPOLOGY;
            if (e->seen_seg[id])
                continue;
            if (e->nseg >= cs)
                return PDR_ETOPOLOGY; /* the table's counts disagree */
            e->seen_seg[id] = 1;
            e->segs[e->nseg++] = id;
        }
        for (int i = 0; i < 4 && (fl & TM_F_FACEMARKS); i++) {
            if (!(fl & TM_F_FACEMARK(i)))
                continue;
            uint32_t id = bd_find_subfac(bd, v[tm_face_vtx[i][0]], v[tm_face_vtx[i][1]],
                                         v[tm_face_vtx[i][2]]);
            if (id == BD_NONE)
                return PDR_ETOPOLOGY;
            if (e->seen_fac[id])
                continue;
            if (e->nfac >= cf)
                return PDR_ETOPOLOGY;
            e->seen_fac[id] = 1;
            e->facs[e->nfac++] = id;
        }
    }
    return 0;
}

/* The extension's arrays per tetrahedron (TEXT_ELEM bytes each: flags,
 * regions, links) from q on. Returns 0 or PDR_EINVAL (a link enc_link
 * refuses). */
static int put_tet_ext(uint8_t *q, const enc *e, const par_wire_src *src)
{
    const ref_mesher *r = src->r;
    size_t nt = src->nt;
    for (size_t k = 0; k < nt; k++, q += 2)
        pr_store_u16(q, r->m.flags[src->tets[k]] & PAR_WIRE_TFLAGS);
    for (size_t k = 0; k < nt; k++, q += 2)
        pr_store_u16(q, r->region ? r->region[src->tets[k]] : 0);
    for (size_t k = 0; k < nt; k++)
        for (int i = 0; i < 4; i++, q += 4) {
            uint32_t c;
            if (enc_link(e, src, k, i, &c))
                return PDR_EINVAL;
            pr_store_u32(q, c);
        }
    return 0;
}

/* The extension, stored straight into b (one reservation, no call per
 * value: a merge message has millions of them). Returns 0, PDR_EINVAL (a
 * link enc_link refuses) or PDR_ENOMEM; b->len is then where it was. */
static int put_ext(pr_buf *b, const enc *e, const par_wire_src *src)
{
    const ref_mesher *r = src->r;
    const bd_set *bd = &r->bd;
    size_t nv = e->nv, nt = src->nt;
    size_t n = 4 + nv * VEXT_ELEM + 4 + nt * TEXT_ELEM + 4 + (size_t)e->nseg * SEG_ELEM + 4 +
               (size_t)e->nfac * FAC_ELEM;
    if (pr_buf_reserve(b, n))
        return PDR_ENOMEM;
    uint8_t *q = b->data + b->len;
    pr_store_u32(q, e->nv);
    q += 4;
    for (size_t i = 0; i < nv; i++)
        *q++ = bd->vkind[e->verts[i].v];
    for (size_t i = 0; i < nv; i++, q += 4)
        pr_store_u32(q, bd->vfeat[e->verts[i].v]);
    for (size_t i = 0; i < nv; i++, q += 4)
        pr_store_u32(q, f32_bits(bd->vrins[e->verts[i].v]));
    pr_store_u32(q, src->nt);
    q += 4;
    if (put_tet_ext(q, e, src))
        return PDR_EINVAL;
    q += nt * TEXT_ELEM;
    pr_store_u32(q, e->nseg);
    q += 4;
    for (int c = 0; c < 2; c++)
        for (uint32_t j = 0; j < e->nseg; j++, q += 4)
            pr_store_u32(q, e->idx[bd->segs[e->segs[j]].v[c]]);
    for (uint32_t j = 0; j < e->nseg; j++, q += 4)
        pr_store_u32(q, bd->segs[e->segs[j]].seg);
    for (uint32_t j = 0; j < e->nseg; j++, q += 2)
        pr_store_u16(q, bd->segs[e->segs[j]].flags & PAR_WIRE_BDFLAGS);
    pr_store_u32(q, e->nfac);
    q += 4;
    for (uint32_t j = 0; j < e->nfac; j++)
        for (int c = 0; c < 3; c++, q += 4)
            pr_store_u32(q, e->idx[bd->facs[e->facs[j]].v[c]]);
    for (uint32_t j = 0; j < e->nfac; j++, q += 4)
        pr_store_u32(q, bd->facs[e->facs[j]].facet);
    for (uint32_t j = 0; j < e->nfac; j++, q += 2)
        pr_store_u16(q, bd->facs[e->facs[j]].flags & PAR_WIRE_BDFLAGS);
    b->len += n;
    return 0;
}

/* The tables of src's message into e (which the caller frees with
 * enc_free, also on error). Returns as par_wire_encode. */
static int enc_build(enc *e, const par_wire_src *src)
{
    memset(e, 0, sizeof *e);
    const ref_mesher *r = src->r;
    const tm_mesh *m = &r->m;
    if (src->nt > PR_MAX_TETS)
        return PDR_ELIMIT;
    if (src->size == 0 || src->rank >= src->size || !src->gid)
        return PDR_EINVAL;
    for (uint32_t k = 0; k < src->nt; k++)
        if (src->tets[k] >= m->nslots || tm_is_dead(m, src->tets[k]))
            return PDR_EINVAL;
    e->sm.part = src->part;
    e->sm.rank = src->rank;
    e->sm.size = src->size;
    e->sm.n_facets = (uint32_t)r->p->nfacet;
    int rc = enc_vertices(e, src);
    if (!rc)
        rc = enc_tets(e, src);
    if (!rc)
        rc = enc_bd(e, src);
    return rc;
}

int par_wire_encode(pr_buf *b, const par_wire_src *src)
{
    if (b->err)
        return from_pr(b->err, PDR_EINVAL);
    enc e;
    int rc = enc_build(&e, src);
    if (rc) {
        enc_free(&e);
        return rc;
    }
    /* One allocation for the whole message instead of a doubling series
     * of copies (a merge message is tens of megabytes): the submesh and
     * the extension's bytes per vertex, tetrahedron, interface face and
     * boundary piece, and room for the headers and counts (about 70
     * bytes). */
    size_t nv = e.nv, nt = src->nt, nif = e.sm.iface.n;
    pr_buf_reserve(b, 256 + nv * (8 + 24 + 4 + VEXT_ELEM) + nt * (16 + 16 + 1 + TEXT_ELEM) +
                          nif * 8 + (size_t)e.nseg * SEG_ELEM + (size_t)e.nfac * FAC_ELEM);
    size_t start = b->len;
    pr_put_u32(b, PAR_WIRE_MAGIC);
    pr_put_u32(b, PAR_WIRE_VERSION);
    pr_put_u64(b, src->next_seq);
    size_t at = b->len;
    pr_put_u32(b, 0); /* sublen, filled in below */
    pr_submesh_put(b, &e.sm);
    if (!b->err) {
        size_t sub = b->len - at - 4;
        if (sub > UINT32_MAX)
            rc = PDR_ELIMIT;
        else
            pr_store_u32(b->data + at, (uint32_t)sub);
    }
    if (!rc && !b->err)
        rc = put_ext(b, &e, src);
    if (!rc && b->err)
        rc = from_pr(b->err, PDR_EINVAL);
    if (rc && b->len >= start)
        b->len = start;
    enc_free(&e);
    return rc;
}

/* The message source of every live tetrahedron of s (see
 * par_wire_encode_sub); *tets gets the list of slots, which the caller
 * frees. Returns 0, PDR_ENOMEM or PDR_EINVAL. */
static int sub_src(const par_sub *s, par_wire_src *src, uint32_t **tets)
{
    const tm_mesh *m = &s->r.m;
    size_t n = m->nlive;
    *tets = pr_malloc((n ? n : 1) * sizeof **tets);
    if (!*tets)
        return PDR_ENOMEM;
    uint32_t k = 0;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t))
            continue;
        if (k >= n)
            return PDR_EINVAL; /* nlive is wrong */
        (*tets)[k++] = t;
    }
    /* the PEs across faces from s's interface table, not a copy of them
     * per face: a merge message has millions of faces */
    *src = (par_wire_src){&s->r,   m->gid,       *tets,  k, NULL, s->rank, s->rank,
                          s->size, s->next_seq, s->ifc, s->nifc};
    return 0;
}

int par_wire_encode_tets(pr_buf *b, const par_sub *s, const uint32_t *tets, uint32_t nt)
{
    const tm_mesh *m = &s->r.m;
    par_wire_src src = {&s->r,   m->gid,      tets,   nt,     NULL, s->rank, s->rank,
                        s->size, s->next_seq, s->ifc, s->nifc};
    return par_wire_encode(b, &src);
}

int par_wire_encode_sub(pr_buf *b, const par_sub *s)
{
    par_wire_src src;
    uint32_t *tets = NULL;
    int rc = sub_src(s, &src, &tets);
    if (!rc)
        rc = par_wire_encode(b, &src);
    pr_free(tets);
    return rc;
}

/* par_wire_from_sub's part after the tables: e's submesh handed over to
 * w, and the extension's arrays made. */
static int wire_of_enc(enc *e, const par_wire_src *src, par_wire *w)
{
    const bd_set *bd = &src->r->bd;
    size_t nv = e->nv, nt = src->nt;
    w->next_seq = src->next_seq;
    w->sm = pr_calloc(1, sizeof *w->sm);
    if (!w->sm)
        return PDR_ENOMEM;
    *w->sm = e->sm;
    /* the tables are w's now (one block each, as pr_submesh_free wants);
     * the interface table becomes one block too */
    memset(&e->sm.vert, 0, sizeof e->sm.vert);
    memset(&e->sm.tet, 0, sizeof e->sm.tet);
    pr_iftable *f = &w->sm->iface;
    f->face = f->remote = NULL;
    if (f->n) {
        f->face = pr_malloc(2 * (size_t)f->n * sizeof *f->face);
        if (!f->face) {
            f->n = 0;
            return PDR_ENOMEM;
        }
        f->remote = f->face + f->n;
        memcpy(f->face, e->sm.iface.face, (size_t)f->n * sizeof *f->face);
        memcpy(f->remote, e->sm.iface.remote, (size_t)f->n * sizeof *f->remote);
    }
    w->vkind = pr_malloc(nv ? nv : 1);
    w->vfeat = pr_malloc((nv ? nv : 1) * sizeof *w->vfeat);
    w->vrins = pr_malloc((nv ? nv : 1) * sizeof *w->vrins);
    w->own = pr_malloc(nt ? nt * TEXT_ELEM : 1);
    w->nseg = e->nseg;
    w->seg_v = pr_malloc((e->nseg ? 2 * (size_t)e->nseg : 1) * sizeof *w->seg_v);
    w->seg_id = pr_malloc((e->nseg ? e->nseg : 1) * sizeof *w->seg_id);
    w->seg_flags = pr_malloc((e->nseg ? e->nseg : 1) * sizeof *w->seg_flags);
    w->nfac = e->nfac;
    w->fac_v = pr_malloc((e->nfac ? 3 * (size_t)e->nfac : 1) * sizeof *w->fac_v);
    w->fac_id = pr_malloc((e->nfac ? e->nfac : 1) * sizeof *w->fac_id);
    w->fac_flags = pr_malloc((e->nfac ? e->nfac : 1) * sizeof *w->fac_flags);
    if (!w->vkind || !w->vfeat || !w->vrins || !w->own || !w->seg_v || !w->seg_id ||
        !w->seg_flags || !w->fac_v || !w->fac_id || !w->fac_flags)
        return PDR_ENOMEM;
    for (size_t i = 0; i < nv; i++) {
        uint32_t v = e->verts[i].v;
        w->vkind[i] = bd->vkind[v];
        w->vfeat[i] = bd->vfeat[v];
        w->vrins[i] = bd->vrins[v];
    }
    if (put_tet_ext(w->own, e, src))
        return PDR_EINVAL;
    w->tflags_le = w->own;
    w->region_le = w->own + 2 * nt;
    w->link_le = w->own + 4 * nt;
    for (uint32_t j = 0; j < e->nseg; j++) {
        const bd_subseg *g = &bd->segs[e->segs[j]];
        w->seg_v[2 * (size_t)j] = e->idx[g->v[0]];
        w->seg_v[2 * (size_t)j + 1] = e->idx[g->v[1]];
        w->seg_id[j] = g->seg;
        w->seg_flags[j] = g->flags & PAR_WIRE_BDFLAGS;
    }
    for (uint32_t j = 0; j < e->nfac; j++) {
        const bd_subfac *g = &bd->facs[e->facs[j]];
        for (int c = 0; c < 3; c++)
            w->fac_v[3 * (size_t)j + (size_t)c] = e->idx[g->v[c]];
        w->fac_id[j] = g->facet;
        w->fac_flags[j] = g->flags & PAR_WIRE_BDFLAGS;
    }
    return 0;
}

void par_wire_pairs_free(par_wire_pairs *a)
{
    pr_free(a->hash);
    memset(a, 0, sizeof *a);
}

/* The pairs of w, the message wire_of_enc made of src (see
 * par_wire_from_sub_pairs): face x = 4k+i of the message is face i of
 * slot t = src->tets[k]; its link c = 4u+j (from w, as sent) is face j of
 * the slot its mesh link names, whose own link is sent as enc_link makes
 * it, its vertices as e->idx numbers them and its marker as enc_tets
 * writes it: the same values as the message's tables hold, read from one
 * tm_tet of the mesh instead of three tables. */
static int enc_pairs(const enc *e, const par_wire_src *src, const par_wire *w,
                     par_wire_pairs *a)
{
    const tm_mesh *m = &src->r->m;
    size_t nt = src->nt, cap = 2 * nt + 1;
    a->tets = src->nt;
    a->hash = pr_malloc(cap * sizeof *a->hash);
    uint64_t *vk = pr_malloc((m->nv ? m->nv : 1) * sizeof *vk);
    if (!a->hash || !vk) {
        pr_free(vk);
        return PDR_ENOMEM;
    }
    /* keys of the vertices sent (the others are not read) */
    for (uint32_t i = 0; i < e->nv; i++)
        vk[e->verts[i].v] = par_wire_vkey(e->verts[i].gid);
    for (size_t k = 0; k < nt; k++) {
        if (k + 16 < nt) {
            const tm_tet *P = &m->tets[src->tets[k + 16]];
            for (int i = 0; i < 4; i++)
                if (!tm_is_special(P->n[i]) && tm_ltet(P->n[i]) < m->nslots) {
                    WIRE_PREFETCH(&m->tets[tm_ltet(P->n[i])].v[0]);
                    WIRE_PREFETCH(&m->tets[tm_ltet(P->n[i])].n[3]);
                }
        }
        uint32_t t = src->tets[k];
        const tm_tet *T = &m->tets[t];
        for (int i = 0; i < 4; i++) {
            size_t x = 4 * k + (size_t)i;
            uint32_t c = par_wire_link(w, x);
            if (c >= PAR_WIRE_LINK_IFACE)
                continue; /* loose */
            if (c < x) {
                a->down++;
                continue;
            }
            a->up++;
            /* c names a sent slot, so T's link is that slot's face */
            uint32_t su = tm_ltet(T->n[i]);
            int j = (int)(c & 3);
            const tm_tet *U = &m->tets[su];
            /* enc_link(u, j) is x exactly when U's link j is face i of
             * t: a remote link is sent as IFACE, and pos_of is
             * one-to-one on the slots sent (t's is k) */
            a->bad_links += U->n[j] != tm_mklink(t, i);
            uint32_t f[3], y[3];
            for (int q = 0; q < 3; q++) {
                f[q] = T->v[tm_face_vtx[i][q]];
                y[q] = U->v[tm_face_vtx[j][q]];
            }
            /* mesh vertices for the message's numbers: one-to-one */
            int opposed = tm_faces_opposed(f, y);
            a->misoriented += (size_t)!opposed;
            if (tm_has_markers(m))
                a->marker_mismatch += tm_face_marker(m, t, i) != tm_face_marker(m, su, j);
            a->suspect |= U->v[j] == T->v[i];
            int tin = ref_is_interior(m, t), uin = ref_is_interior(m, su);
            if (tin != uin)
                a->unmarked += !(m->flags[tin ? t : su] & TM_F_FACEMARK(tin ? i : j));
            if (a->nhash == cap &&
                pdr_grow((void **)&a->hash, &cap, a->nhash + 1, sizeof *a->hash)) {
                pr_free(vk);
                return PDR_ENOMEM;
            }
            a->hash[a->nhash++] = par_wire_face_hash(vk[f[0]], vk[f[1]], vk[f[2]]);
        }
    }
    pr_free(vk);
    return 0;
}

int par_wire_from_sub(const par_sub *s, par_wire *out)
{
    return par_wire_from_sub_pairs(s, out, NULL);
}

int par_wire_from_sub_pairs(const par_sub *s, par_wire *out, par_wire_pairs *pairs)
{
    memset(out, 0, sizeof *out);
    if (pairs)
        memset(pairs, 0, sizeof *pairs);
    par_wire_src src;
    uint32_t *tets = NULL;
    enc e;
    memset(&e, 0, sizeof e);
    int rc = sub_src(s, &src, &tets);
    if (!rc)
        rc = enc_build(&e, &src);
    if (!rc)
        rc = wire_of_enc(&e, &src, out);
    if (!rc && pairs)
        rc = enc_pairs(&e, &src, out, pairs);
    enc_free(&e);
    pr_free(tets);
    if (rc) {
        par_wire_clear(out);
        if (pairs)
            par_wire_pairs_free(pairs);
    }
    return rc;
}

/* ---------------------------------------------------------------- decode */

void par_wire_clear(par_wire *w)
{
    pr_submesh_free(&w->sm);
    pr_free(w->own);
    pr_free(w->vkind);
    pr_free(w->vfeat);
    pr_free(w->vrins);
    pr_free(w->seg_v);
    pr_free(w->seg_id);
    pr_free(w->seg_flags);
    pr_free(w->fac_v);
    pr_free(w->fac_id);
    pr_free(w->fac_flags);
    memset(w, 0, sizeof *w);
}

void par_wire_drop_vertices(par_wire *w)
{
    uint32_t n = w->sm ? w->sm->vert.n : 0;
    if (w->sm) {
        pr_vtable_clear(&w->sm->vert);
        w->sm->vert.n = n;
    }
    pr_free(w->vkind);
    pr_free(w->vfeat);
    pr_free(w->vrins);
    w->vkind = NULL;
    w->vfeat = NULL;
    w->vrins = NULL;
}

void par_wire_drop_tets(par_wire *w)
{
    uint32_t n = w->sm ? w->sm->tet.n : 0;
    if (w->sm) {
        pr_ttable_clear(&w->sm->tet);
        w->sm->tet.n = n;
    }
    if (w->own) {
        pr_free(w->own);
        w->own = NULL;
        w->tflags_le = NULL;
        w->region_le = NULL;
        w->link_le = NULL;
    }
}

/* The feature index a vertex of this kind may have. */
static int vfeat_ok(const plc *p, uint8_t kind, uint32_t feat)
{
    switch (kind) {
    case BD_V_VOLUME:
        return 1;
    case BD_V_INPUT:
        return feat < p->nv;
    case BD_V_SEGMENT:
        return feat < p->nseg;
    case BD_V_FACET:
        return feat < p->nfacet;
    default:
        return 0;
    }
}

static int dec_vertices(pr_reader *rd, const plc *p, par_wire *w)
{
    uint32_t n = w->sm->vert.n, c;
    const uint8_t *kind, *feat, *rins;
    if (pr_get_u32(rd, &c) || c != n)
        return PDR_EPARSE;
    if (pr_get_view(rd, &kind, n) || pr_get_view(rd, &feat, 4 * (size_t)n) ||
        pr_get_view(rd, &rins, 4 * (size_t)n))
        return PDR_EPARSE;
    w->vkind = pr_malloc(n ? n : 1);
    w->vfeat = pr_malloc((n ? n : 1) * sizeof *w->vfeat);
    w->vrins = pr_malloc((n ? n : 1) * sizeof *w->vrins);
    if (!w->vkind || !w->vfeat || !w->vrins)
        return PDR_ENOMEM;
    uint32_t rank = w->sm->rank;
    for (uint32_t i = 0; i < n; i++) {
        w->vkind[i] = kind[i];
        w->vfeat[i] = pr_load_u32(feat + 4 * (size_t)i);
        w->vrins[i] = f32_of(pr_load_u32(rins + 4 * (size_t)i));
        if (!vfeat_ok(p, w->vkind[i], w->vfeat[i]) || !(w->vrins[i] >= 0))
            return PDR_EPARSE;
        /* The infinite vertex is the smallest gid, so vertex 0 if sent. */
        uint64_t g = w->sm->vert.gid[i];
        if (g == PAR_GID_INF && i != 0)
            return PDR_EPARSE;
        /* A vertex this PE made must be below its counter, or the PE
         * would make that gid again. */
        if (g != PAR_GID_INF && pr_gid_rank(g) == rank && pr_gid_seq(g) >= w->next_seq)
            return PDR_EPARSE;
    }
    return 0;
}

/* The links against the decoder's rules (see the header): in range, not
 * to the same tetrahedron, IFACE exactly on the listed faces. One pass in
 * order: whether a link comes back would cost a cache miss per face of a
 * large message, and the receivers read the other side anyway. */
static int links_ok(const par_wire *w)
{
    const pr_iftable *f = &w->sm->iface;
    size_t nf = 4 * (size_t)w->sm->tet.n;
    uint32_t q = 0;
    for (size_t x = 0; x < nf; x++) {
        uint32_t c = par_wire_link(w, x);
        /* the interface faces are strictly ascending (proto checked) */
        int listed = q < f->n && f->face[q] == x;
        q += (uint32_t)listed;
        if (c == PAR_WIRE_LINK_IFACE) {
            if (!listed)
                return 0;
        } else if (listed) {
            return 0;
        } else if (c != PAR_WIRE_LINK_NONE) {
            if (c >= nf || c >> 2 == x >> 2)
                return 0;
        }
    }
    return 1;
}

static int dec_tets(pr_reader *rd, const plc *p, par_wire *w)
{
    uint32_t n = w->sm->tet.n, c;
    if (pr_get_u32(rd, &c) || c != n)
        return PDR_EPARSE;
    if (pr_get_view(rd, &w->tflags_le, 2 * (size_t)n) ||
        pr_get_view(rd, &w->region_le, 2 * (size_t)n) ||
        pr_get_view(rd, &w->link_le, 16 * (size_t)n))
        return PDR_EPARSE;
    for (uint32_t k = 0; k < n; k++)
        if ((par_wire_tflags(w, k) & ~PAR_WIRE_TFLAGS) || par_wire_region(w, k) > p->nregion)
            return PDR_EPARSE;
    return links_ok(w) ? 0 : PDR_EPARSE;
}

/* True if vertex index i of the table is a real vertex. */
static int real_index(const par_wire *w, uint32_t i)
{
    return i < w->sm->vert.n && w->sm->vert.gid[i] != PAR_GID_INF;
}

static int dec_segs(pr_reader *rd, const plc *p, par_wire *w)
{
    uint32_t n;
    const uint8_t *a, *b, *id, *fl;
    if (pr_get_count(rd, MAX_SEGS, SEG_ELEM, &n))
        return PDR_EPARSE;
    if (pr_get_view(rd, &a, 4 * (size_t)n) || pr_get_view(rd, &b, 4 * (size_t)n) ||
        pr_get_view(rd, &id, 4 * (size_t)n) || pr_get_view(rd, &fl, 2 * (size_t)n))
        return PDR_EPARSE;
    w->nseg = n;
    w->seg_v = pr_malloc((n ? 2 * (size_t)n : 1) * sizeof *w->seg_v);
    w->seg_id = pr_malloc((n ? n : 1) * sizeof *w->seg_id);
    w->seg_flags = pr_malloc((n ? n : 1) * sizeof *w->seg_flags);
    if (!w->seg_v || !w->seg_id || !w->seg_flags)
        return PDR_ENOMEM;
    for (uint32_t j = 0; j < n; j++) {
        uint32_t x = pr_load_u32(a + 4 * (size_t)j), y = pr_load_u32(b + 4 * (size_t)j);
        w->seg_v[2 * (size_t)j] = x;
        w->seg_v[2 * (size_t)j + 1] = y;
        w->seg_id[j] = pr_load_u32(id + 4 * (size_t)j);
        w->seg_flags[j] = pr_load_u16(fl + 2 * (size_t)j);
        if (!real_index(w, x) || !real_index(w, y) || x == y || w->seg_id[j] >= p->nseg ||
            (w->seg_flags[j] & ~PAR_WIRE_BDFLAGS))
            return PDR_EPARSE;
    }
    return 0;
}

static int dec_facs(pr_reader *rd, const plc *p, par_wire *w)
{
    uint32_t n;
    const uint8_t *v, *id, *fl;
    if (pr_get_count(rd, MAX_FACS, FAC_ELEM, &n))
        return PDR_EPARSE;
    if (pr_get_view(rd, &v, 12 * (size_t)n) || pr_get_view(rd, &id, 4 * (size_t)n) ||
        pr_get_view(rd, &fl, 2 * (size_t)n))
        return PDR_EPARSE;
    w->nfac = n;
    w->fac_v = pr_malloc((n ? 3 * (size_t)n : 1) * sizeof *w->fac_v);
    w->fac_id = pr_malloc((n ? n : 1) * sizeof *w->fac_id);
    w->fac_flags = pr_malloc((n ? n : 1) * sizeof *w->fac_flags);
    if (!w->fac_v || !w->fac_id || !w->fac_flags)
        return PDR_ENOMEM;
    for (uint32_t j = 0; j < n; j++) {
        uint32_t *x = w->fac_v + 3 * (size_t)j;
        for (int c = 0; c < 3; c++) {
            x[c] = pr_load_u32(v + 12 * (size_t)j + 4 * (size_t)c);
            if (!real_index(w, x[c]))
                return PDR_EPARSE;
        }
        w->fac_id[j] = pr_load_u32(id + 4 * (size_t)j);
        w->fac_flags[j] = pr_load_u16(fl + 2 * (size_t)j);
        if (x[0] == x[1] || x[1] == x[2] || x[0] == x[2] || w->fac_id[j] >= p->nfacet ||
            (w->fac_flags[j] & ~PAR_WIRE_BDFLAGS))
            return PDR_EPARSE;
    }
    return 0;
}

int par_wire_decode(const void *msg, size_t len, const plc *p, par_wire *out)
{
    memset(out, 0, sizeof *out);
    pr_reader rd;
    pr_reader_init(&rd, msg, len);
    uint32_t magic = 0, version = 0, sublen = 0;
    const uint8_t *sub;
    pr_get_u32(&rd, &magic);
    pr_get_u32(&rd, &version);
    pr_get_u64(&rd, &out->next_seq);
    pr_get_u32(&rd, &sublen);
    if (rd.err || magic != PAR_WIRE_MAGIC || version != PAR_WIRE_VERSION ||
        out->next_seq == 0 || out->next_seq > PR_GID_SEQ_MAX + 1 ||
        pr_get_view(&rd, &sub, sublen))
        return PDR_EPARSE;
    int rc = from_pr(pr_submesh_decode(sub, sublen, &out->sm), PDR_EPARSE);
    if (!rc && out->sm->n_facets != p->nfacet)
        rc = PDR_EPARSE;
    if (!rc)
        rc = dec_vertices(&rd, p, out);
    if (!rc)
        rc = dec_tets(&rd, p, out);
    if (!rc)
        rc = dec_segs(&rd, p, out);
    if (!rc)
        rc = dec_facs(&rd, p, out);
    if (!rc && pr_reader_finish(&rd))
        rc = PDR_EPARSE;
    if (rc)
        par_wire_clear(out);
    return rc;
}

int par_wire_decode_own(const void *msg, size_t len, const plc *p, par_wire *out)
{
    int rc = par_wire_decode(msg, len, p, out);
    if (rc)
        return rc;
    /* The three arrays lie one after the other in the message. */
    size_t nt = out->sm->tet.n;
    out->own = pr_malloc(nt ? nt * TEXT_ELEM : 1);
    if (!out->own) {
        par_wire_clear(out);
        return PDR_ENOMEM;
    }
    memcpy(out->own, out->tflags_le, nt * TEXT_ELEM);
    out->tflags_le = out->own;
    out->region_le = out->own + 2 * nt;
    out->link_le = out->own + 4 * nt;
    return 0;
}

/* ----------------------------------------------------------------- build */

/* 1 if the triangles x and y (vertex triples) are the same face seen from
 * its two sides: y is an odd permutation of x. */
static int face_opposed(const uint32_t x[3], const uint32_t y[3])
{
    for (int k = 0; k < 3; k++)
        if (y[0] == x[k])
            return y[1] == x[(k + 2) % 3] && y[2] == x[(k + 1) % 3];
    return 0;
}

static void face_of(const tm_mesh *m, uint32_t t, int i, uint32_t f[3])
{
    for (int c = 0; c < 3; c++)
        f[c] = m->tets[t].v[tm_face_vtx[i][c]];
}

/* Every local link joins two opposed faces with the same marker. */
static int links_agree(const tm_mesh *m)
{
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t))
            continue;
        for (int i = 0; i < 4; i++) {
            tm_link l = m->tets[t].n[i];
            if (tm_is_special(l))
                continue;
            uint32_t u = tm_ltet(l), x[3], y[3];
            int j = tm_lface(l);
            face_of(m, t, i, x);
            face_of(m, u, j, y);
            if (!face_opposed(x, y) || tm_face_marker(m, t, i) != tm_face_marker(m, u, j))
                return 0;
        }
    }
    return 1;
}

/* The links the faces gave (slot k is tetrahedron k of the message) are
 * the ones the message sent; as tm_link_faces' links come back, so do the
 * message's then. */
static int links_sent(const par_wire *w, const tm_mesh *m)
{
    for (uint32_t t = 0; t < w->sm->tet.n; t++)
        for (int i = 0; i < 4; i++) {
            uint32_t c = par_wire_link(w, 4 * (size_t)t + (size_t)i);
            tm_link l = m->tets[t].n[i];
            if (c == PAR_WIRE_LINK_IFACE ? !tm_is_special(l) || l == TM_LINK_NONE
                : c == PAR_WIRE_LINK_NONE ? l != TM_LINK_NONE
                                          : l != c)
                return 0;
        }
    return 1;
}

static int build_tets(const par_wire *w, const uint32_t *loc, par_sub *s)
{
    const pr_submesh *sm = w->sm;
    tm_mesh *m = &s->r.m;
    int rc = tm_room(m, sm->tet.n);
    if (!rc)
        rc = ref_region_room(&s->r);
    if (rc)
        return rc;
    for (uint32_t k = 0; k < sm->tet.n; k++) {
        /* A fresh mesh hands out slots 0, 1, ...: slot k is tetrahedron k
         * of the message, as the interface faces' names assume. */
        uint32_t t = tm_alloc_tet(m);
        if (t != k)
            return PDR_EINVAL;
        uint16_t fl = par_wire_tflags(w, k);
        for (int i = 0; i < 4; i++) {
            size_t j = 4 * (size_t)k + (size_t)i;
            m->tets[t].v[i] = loc[sm->tet.v[j]];
            m->tets[t].n[i] = TM_LINK_UNSET;
            int32_t mk = sm->tet.marker[j];
            rc = tm_set_marker(m, t, i, mk + 1);
            if (rc)
                return rc;
            if (mk != PR_MARKER_NONE)
                fl |= TM_F_FACEMARK(i);
        }
        fl |= (uint16_t)((sm->tet.subseg[k] & PR_SUBSEG_MASK) * TM_F_SUBSEG0);
        m->flags[t] = fl;
        m->nghost += (uint32_t)tm_is_ghost(m, t);
        if (s->r.region)
            s->r.region[t] = par_wire_region(w, k);
        else if (par_wire_region(w, k))
            return PDR_EPARSE; /* unreachable: the decoder checked nregion */
    }
    return 0;
}

static int build_bd(const par_wire *w, const uint32_t *loc, par_sub *s)
{
    bd_set *bd = &s->r.bd;
    for (uint32_t j = 0; j < w->nseg; j++) {
        uint32_t a = loc[w->seg_v[2 * (size_t)j]], b = loc[w->seg_v[2 * (size_t)j + 1]], id;
        if (bd_find_subseg(bd, a, b) != BD_NONE)
            return PDR_ETOPOLOGY;
        int rc = bd_add_subseg(bd, a, b, w->seg_id[j], &id);
        if (rc)
            return rc;
        bd->segs[id].flags = w->seg_flags[j];
    }
    for (uint32_t j = 0; j < w->nfac; j++) {
        const uint32_t *x = w->fac_v + 3 * (size_t)j;
        uint32_t a = loc[x[0]], b = loc[x[1]], c = loc[x[2]], id;
        if (bd_find_subfac(bd, a, b, c) != BD_NONE)
            return PDR_ETOPOLOGY;
        int rc = bd_add_subfac(bd, a, b, c, w->fac_id[j], &id);
        if (rc)
            return rc;
        bd->facs[id].flags = w->fac_flags[j];
    }
    return 0;
}

static int build(const par_wire *w, par_sub *s)
{
    const pr_submesh *sm = w->sm;
    tm_mesh *m = &s->r.m;
    s->next_seq = w->next_seq;
    s->own_base = w->next_seq;
    int rc = par_wire_seg_acute(&s->r);
    if (!rc)
        rc = tm_reserve(m, (size_t)sm->vert.n + 1, sm->tet.n);
    if (rc)
        return rc;
    uint32_t *loc = pr_malloc(((size_t)sm->vert.n ? sm->vert.n : 1) * sizeof *loc);
    if (!loc)
        return PDR_ENOMEM;
    for (uint32_t i = 0; i < sm->vert.n && !rc; i++) {
        if (sm->vert.gid[i] == PAR_GID_INF)
            loc[i] = TM_VINF;
        else
            rc = par_sub_vertex(s, sm->vert.gid[i], sm->vert.xyz + 3 * (size_t)i, w->vkind[i],
                                w->vfeat[i], w->vrins[i], &loc[i]);
    }
    if (!rc)
        rc = build_tets(w, loc, s);
    size_t nonmanifold = 0;
    if (!rc)
        rc = tm_link_faces(m, &nonmanifold);
    if (!rc && nonmanifold)
        rc = PDR_ETOPOLOGY;
    for (uint32_t j = 0; j < sm->iface.n && !rc; j++) {
        uint32_t t = sm->iface.face[j] >> 2;
        int i = (int)(sm->iface.face[j] & 3);
        if (m->tets[t].n[i] != TM_LINK_NONE)
            rc = PDR_ETOPOLOGY; /* the neighbour is here after all */
        else
            rc = par_sub_add_iface(s, t, i, sm->iface.remote[j]);
    }
    if (!rc && (!links_agree(m) || !links_sent(w, m)))
        rc = PDR_ETOPOLOGY;
    if (!rc)
        rc = build_bd(w, loc, s);
    pr_free(loc);
    if (rc)
        return rc;
    tm_rebuild_hints(m);
    s->r.classified = 1;
    /* A constrained Mo comes carved: its ghosts lie on the boundary. */
    s->r.carved = s->r.o.constrained != 0;
    return 0;
}

int par_wire_build(const par_wire *w, const plc *p, const ref_opts *o, par_sub *out)
{
    int rc = par_sub_init(out, p, o, w->sm->rank, w->sm->size);
    if (rc)
        return rc;
    rc = build(w, out);
    if (rc)
        par_sub_free(out);
    return rc;
}

int par_wire_load(const void *msg, size_t len, const plc *p, const ref_opts *o, par_sub *out)
{
    par_wire w;
    int rc = par_wire_decode(msg, len, p, &w);
    if (rc) {
        memset(out, 0, sizeof *out);
        return rc;
    }
    rc = par_wire_build(&w, p, o, out);
    par_wire_clear(&w);
    return rc;
}

int par_wire_seg_acute(ref_mesher *r)
{
    const plc *p = r->p;
    pr_free(r->seg_acute);
    r->seg_acute = pr_calloc(p->nv ? p->nv : 1, sizeof *r->seg_acute);
    if (!r->seg_acute)
        return PDR_ENOMEM;
    for (size_t v = 0; v < p->nv; v++) {
        size_t lo = p->v_sstart[v], hi = p->v_sstart[v + 1];
        for (size_t i = lo; i < hi && !r->seg_acute[v]; i++)
            for (size_t j = i + 1; j < hi; j++) {
                const uint32_t *a = p->segs[p->v_segs[i]].v, *b = p->segs[p->v_segs[j]].v;
                uint32_t oa = a[0] == v ? a[1] : a[0], ob = b[0] == v ? b[1] : b[0];
                double u[3], x[3];
                v3_sub(p->xyz[oa], p->xyz[v], u);
                v3_sub(p->xyz[ob], p->xyz[v], x);
                if (v3_dot(u, x) > 0) {
                    r->seg_acute[v] = 1;
                    break;
                }
            }
    }
    return 0;
}
