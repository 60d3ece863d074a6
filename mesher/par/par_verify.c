/* par/par_verify.c -- consistency checks of submeshes (see
 * par/par_verify.h). */
#include "config.h"

#include <string.h>

#include "par/par_verify.h"

size_t par_verify_total(const par_verify_report *r)
{
    return r->asym_links + r->misoriented + r->bad_remote + r->stale_ifaces + r->open_faces +
           r->bad_vertices + r->bad_counts + r->unmatched_ifaces + r->marker_mismatch;
}

/* 1 if y is x seen from the other side: an odd permutation of x. */
static int opposed(const uint64_t x[3], const uint64_t y[3])
{
    for (int k = 0; k < 3; k++)
        if (y[0] == x[k])
            return y[1] == x[(k + 2) % 3] && y[2] == x[(k + 1) % 3];
    return 0;
}

/* The gids of face i of t in the face's orientation. */
static void face_gids(const par_sub *s, uint32_t t, int i, uint64_t g[3])
{
    const tm_mesh *m = &s->r.m;
    for (int c = 0; c < 3; c++)
        g[c] = m->gid[m->tets[t].v[tm_face_vtx[i][c]]];
}

static void check_vertices(const par_sub *s, par_verify_report *rep)
{
    const tm_mesh *m = &s->r.m;
    if (!m->gid || m->gid[0] != PAR_GID_INF) {
        rep->bad_vertices++;
        return;
    }
    for (uint32_t v = 1; v < m->nv; v++)
        if (m->gid[v] == PAR_GID_INF || par_sub_find_vertex(s, m->gid[v]) != v)
            rep->bad_vertices++;
}

static void check_face(const par_sub *s, uint32_t t, int i, par_verify_report *rep)
{
    const tm_mesh *m = &s->r.m;
    tm_link l = m->tets[t].n[i];
    if (l == TM_LINK_NONE || l == TM_LINK_UNSET) {
        rep->open_faces++;
        return;
    }
    if (tm_is_special(l)) {
        uint32_t k = l - TM_LINK_SPECIAL;
        if (k >= s->nifc || s->ifc[k].pe == PAR_PE_NONE || s->ifc[k].local != tm_mklink(t, i))
            rep->bad_remote++;
        return;
    }
    uint32_t u = tm_ltet(l);
    int j = tm_lface(l);
    if (u >= m->nslots || tm_is_dead(m, u) || m->tets[u].n[j] != tm_mklink(t, i)) {
        rep->asym_links++;
        return;
    }
    uint64_t x[3], y[3];
    face_gids(s, t, i, x);
    face_gids(s, u, j, y);
    if (!opposed(x, y) || tm_face_marker(m, t, i) != tm_face_marker(m, u, j))
        rep->misoriented++;
}

static void check_ifaces(const par_sub *s, par_verify_report *rep)
{
    const tm_mesh *m = &s->r.m;
    size_t live = 0;
    for (size_t k = 0; k < s->nifc; k++) {
        const par_iface *f = &s->ifc[k];
        if (f->pe == PAR_PE_NONE)
            continue;
        live++;
        uint32_t t = tm_ltet(f->local);
        int i = tm_lface(f->local);
        if (t >= m->nslots || tm_is_dead(m, t) || m->tets[t].n[i] != TM_LINK_REMOTE(k) ||
            f->pe == s->rank || f->pe >= s->size) {
            rep->stale_ifaces++;
            continue;
        }
        uint64_t key[3];
        par_face_key(s, t, i, key);
        if (memcmp(key, f->key, sizeof key) || par_sub_find_iface(s, key) != k)
            rep->stale_ifaces++;
    }
    if (live != s->live_ifc)
        rep->bad_counts++;
}

size_t par_verify_sub(const par_sub *s, par_verify_report *rep)
{
    size_t before = par_verify_total(rep);
    const tm_mesh *m = &s->r.m;
    check_vertices(s, rep);
    size_t live = 0, ghosts = 0;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t))
            continue;
        live++;
        ghosts += (size_t)tm_is_ghost(m, t);
        if (m->lock && tm_is_locked(m, t) != (m->lock[t] != 0))
            rep->bad_counts++; /* a lock written past tm_set_lock */
        int ok = 1;
        for (int c = 0; c < 4; c++)
            ok &= m->tets[t].v[c] < m->nv;
        if (!ok) {
            rep->bad_vertices++;
            continue;
        }
        for (int i = 0; i < 4; i++)
            check_face(s, t, i, rep);
    }
    if (live != m->nlive || ghosts != m->nghost)
        rep->bad_counts++;
    check_ifaces(s, rep);
    return par_verify_total(rep) - before;
}

size_t par_verify_all(const par_sub *subs, uint32_t n, par_verify_report *rep)
{
    size_t before = par_verify_total(rep);
    for (uint32_t a = 0; a < n; a++)
        par_verify_sub(&subs[a], rep);
    for (uint32_t a = 0; a < n; a++) {
        const par_sub *s = &subs[a];
        for (size_t k = 0; k < s->nifc; k++) {
            const par_iface *f = &s->ifc[k];
            if (f->pe == PAR_PE_NONE)
                continue;
            uint32_t k2 = f->pe < n ? par_sub_find_iface(&subs[f->pe], f->key) : PAR_PE_NONE;
            if (k2 == PAR_PE_NONE || subs[f->pe].ifc[k2].pe != a || s->rank != a) {
                rep->unmatched_ifaces++;
                continue;
            }
            const par_sub *o = &subs[f->pe];
            uint32_t t = tm_ltet(f->local), u = tm_ltet(o->ifc[k2].local);
            int i = tm_lface(f->local), j = tm_lface(o->ifc[k2].local);
            if (t >= s->r.m.nslots || u >= o->r.m.nslots)
                continue; /* counted as stale above */
            uint64_t x[3], y[3];
            face_gids(s, t, i, x);
            face_gids(o, u, j, y);
            if (!opposed(x, y) || tm_face_marker(&s->r.m, t, i) != tm_face_marker(&o->r.m, u, j))
                rep->marker_mismatch++;
        }
    }
    return par_verify_total(rep) - before;
}

/* ------------------------------------------------ facet triangulations */

static int visit_none(const tm_mesh *m, uint32_t t, void *arg)
{
    (void)m;
    (void)t;
    (void)arg;
    return 0;
}

size_t par_verify_facets(const par_sub *s, FILE *log)
{
    const tm_mesh *m = &s->r.m;
    const bd_set *bd = &s->r.bd;
    size_t bad = 0;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t))
            continue;
        const tm_tet *T = &m->tets[t];
        for (int k = 0; k < 4; k++) {
            if (!(m->flags[t] & TM_F_FACEMARK(k)))
                continue;
            uint32_t f[3];
            for (int c = 0; c < 3; c++)
                f[c] = T->v[tm_face_vtx[k][c]];
            uint32_t id = bd_find_subfac(bd, f[0], f[1], f[2]);
            if (id == BD_NONE)
                continue; /* ref_consistency's business */
            for (int e = 0; e < 3; e++) {
                if (bd_subfac_across(bd, id, e) != BD_NONE)
                    continue;
                uint32_t a = bd->facs[id].v[(e + 1) % 3], b = bd->facs[id].v[(e + 2) % 3];
                /* no gap where the neighbour may be on another PE */
                if (bd_find_subseg(bd, a, b) != BD_NONE ||
                    ref_around_edge(m, t, a, b, visit_none, NULL) != 0)
                    continue;
                if (log)
                    fprintf(log,
                            "PE %u: subfacet %u (gids %llu %llu %llu) of facet %u has no "
                            "neighbour across edge %llu-%llu, which is no subsegment\n",
                            s->rank, id, (unsigned long long)m->gid[bd->facs[id].v[0]],
                            (unsigned long long)m->gid[bd->facs[id].v[1]],
                            (unsigned long long)m->gid[bd->facs[id].v[2]], bd->facs[id].facet,
                            (unsigned long long)m->gid[a], (unsigned long long)m->gid[b]);
                bad++;
            }
        }
    }
    return bad;
}
