/* mesh/vf.c -- exact mesh checks, counted by kind. */
#include "config.h"

#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "geom/pred.h"
#include "mesh/vf.h"
#include "base/v3.h"

#define X(m, v) ((m)->xyz + 3 * (size_t)(v))


static void face_of(const tm_tet *T, int i, uint32_t f[3])
{
    v3_sort3u(T->v[tm_face_vtx[i][0]], T->v[tm_face_vtx[i][1]], T->v[tm_face_vtx[i][2]], f);
}

/* A link is usable if it leads to a live tet that links back. */
static int link_ok(const tm_mesh *m, uint32_t t, int i)
{
    tm_link l = m->tets[t].n[i];
    if (tm_is_special(l))
        return 0;
    uint32_t u = tm_ltet(l);
    return u < m->nslots && !tm_is_dead(m, u) && m->tets[u].n[tm_lface(l)] == tm_mklink(t, i);
}

static int tet_vertices_ok(const tm_mesh *m, uint32_t t)
{
    const uint32_t *v = m->tets[t].v;
    int inf = 0;
    for (int s = 0; s < 4; s++) {
        if (v[s] >= m->nv)
            return 0;
        inf += v[s] == TM_VINF;
        for (int r = 0; r < s; r++)
            if (v[r] == v[s])
                return 0;
    }
    return inf <= 1;
}

static void check_topology(const tm_mesh *m, vf_report *r)
{
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t))
            continue;
        int ghost = tm_is_ghost(m, t);
        if (ghost)
            r->ghosts++;
        else
            r->tets++;
        if (!tet_vertices_ok(m, t)) {
            r->bad_vertex++;
            continue;
        }
        for (int i = 0; i < 4; i++) {
            tm_link l = m->tets[t].n[i];
            if (tm_is_special(l)) {
                if (l == TM_LINK_NONE) {
                    if (ghost)
                        r->open_hull++; /* counted per ghost face */
                    else
                        r->domain_faces++;
                } else if (l == TM_LINK_UNSET) {
                    r->bad_link++;
                } else {
                    r->remote_faces++;
                }
                continue;
            }
            if (!link_ok(m, t, i)) {
                r->bad_link++;
                continue;
            }
            uint32_t u = tm_ltet(l);
            uint32_t f[3], g[3];
            face_of(&m->tets[t], i, f);
            face_of(&m->tets[u], tm_lface(l), g);
            if (memcmp(f, g, sizeof f)) {
                r->face_mismatch++;
                continue;
            }
            int ughost = tm_is_ghost(m, u);
            if (!ghost && !ughost && t < u)
                r->interior_faces++;
            else if (!ghost && ughost)
                r->hull_faces++;
        }
    }
}

static void check_orientation(const tm_mesh *m, vf_report *r)
{
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t) || tm_is_ghost(m, t) || !tet_vertices_ok(m, t))
            continue;
        const uint32_t *v = m->tets[t].v;
        int o = pred_orient3d(X(m, v[0]), X(m, v[1]), X(m, v[2]), X(m, v[3]));
        if (o < 0)
            r->inverted++;
        else if (o == 0)
            r->flat++;
        for (int i = 0; i < 4; i++) {
            if (!link_ok(m, t, i))
                continue;
            tm_link l = m->tets[t].n[i];
            uint32_t u = tm_ltet(l);
            if (!tet_vertices_ok(m, u))
                continue;
            /* The vertex across face i must lie strictly on the other side;
             * for a ghost neighbour, the real side of the hull face is ours. */
            const uint8_t *f = tm_face_vtx[i];
            uint32_t w = m->tets[u].v[tm_lface(l)];
            if (w == TM_VINF)
                continue;
            if (t > u && !tm_is_ghost(m, u))
                continue; /* each interior face once */
            if (pred_orient3d(X(m, v[f[0]]), X(m, v[f[1]]), X(m, v[f[2]]), X(m, w)) >= 0)
                r->folded++;
        }
    }
    /* Ghosts: the real tet behind a hull face is on its inner side. */
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t) || !tet_vertices_ok(m, t))
            continue;
        int k = tm_ghost_slot(m, t);
        if (k < 0 || !link_ok(m, t, k))
            continue;
        tm_link l = m->tets[t].n[k];
        uint32_t u = tm_ltet(l);
        if (tm_is_ghost(m, u) || !tet_vertices_ok(m, u))
            continue;
        const uint32_t *v = m->tets[t].v;
        const uint8_t *f = tm_face_vtx[k];
        uint32_t w = m->tets[u].v[tm_lface(l)];
        if (pred_orient3d(X(m, v[f[0]]), X(m, v[f[1]]), X(m, v[f[2]]), X(m, w)) >= 0)
            r->folded++;
    }
}

static void check_delaunay(const tm_mesh *m, vf_report *r, int constrained)
{
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t) || tm_is_ghost(m, t) || !tet_vertices_ok(m, t))
            continue;
        const uint32_t *v = m->tets[t].v;
        const double *a = X(m, v[0]), *b = X(m, v[1]), *c = X(m, v[2]), *d = X(m, v[3]);
        if (pred_orient3d(a, b, c, d) <= 0)
            continue; /* counted as inverted/flat: no sphere to test */
        for (int i = 0; i < 4; i++) {
            if (!link_ok(m, t, i) || (constrained && (m->flags[t] & TM_F_FACEMARK(i))))
                continue;
            tm_link l = m->tets[t].n[i];
            uint32_t u = tm_ltet(l);
            if (tm_is_ghost(m, u) || !tet_vertices_ok(m, u))
                continue;
            uint32_t w = m->tets[u].v[tm_lface(l)];
            if (pred_insphere(a, b, c, d, X(m, w)) > 0)
                r->not_delaunay++;
        }
    }
    /* Each violated face is seen from both sides at most; a face is
     * locally Delaunay iff neither opposite vertex is strictly inside the
     * other tet's sphere, and the two tests agree, so halve rounding up. */
    r->not_delaunay = (r->not_delaunay + 1) / 2;
}

static void check_hull(const tm_mesh *m, vf_report *r)
{
    for (uint32_t g = 0; g < m->nslots; g++) {
        if (tm_is_dead(m, g) || !tet_vertices_ok(m, g))
            continue;
        int k = tm_ghost_slot(m, g);
        if (k < 0)
            continue;
        const uint32_t *v = m->tets[g].v;
        const uint8_t *f = tm_face_vtx[k];
        for (int j = 0; j < 4; j++) {
            if (j == k || !link_ok(m, g, j))
                continue;
            uint32_t h = tm_ltet(m->tets[g].n[j]);
            if (h < g || !tet_vertices_ok(m, h) || tm_ghost_slot(m, h) < 0)
                continue;
            /* The vertex of h's hull face that is not on the shared edge. */
            uint32_t w = m->tets[h].v[tm_lface(m->tets[g].n[j])];
            if (w == TM_VINF)
                continue;
            if (pred_orient3d(X(m, v[f[0]]), X(m, v[f[1]]), X(m, v[f[2]]), X(m, w)) > 0)
                r->nonconvex_hull++;
        }
    }
}

static int lex_cmp_ctx_sort(const void *a, const void *b, void *ctx)
{
    const tm_mesh *m = ctx;
    return pred_lexcmp3(X(m, *(const uint32_t *)a), X(m, *(const uint32_t *)b));
}

static int check_vertices(const tm_mesh *m, vf_report *r)
{
    unsigned char *used = pr_calloc(m->nv, 1);
    if (!used)
        return PDR_ENOMEM;
    for (uint32_t t = 0; t < m->nslots; t++)
        if (!tm_is_dead(m, t) && tet_vertices_ok(m, t))
            for (int s = 0; s < 4; s++)
                used[m->tets[t].v[s]] = 1;
    size_t unused = 0;
    for (uint32_t v = 1; v < m->nv; v++) {
        r->used_vertices += used[v];
        unused += !used[v];
    }
    if (unused) {
        /* Sort all vertices by coordinates; an unused vertex is a duplicate
         * if a used one has the same coordinates. */
        uint32_t *idx = pr_malloc((size_t)(m->nv - 1) * sizeof *idx);
        if (!idx) {
            pr_free(used);
            return PDR_ENOMEM;
        }
        for (uint32_t v = 1; v < m->nv; v++)
            idx[v - 1] = v;
        qsort_r(idx, m->nv - 1, sizeof *idx, lex_cmp_ctx_sort, (void *)m);
        for (size_t i = 0; i < (size_t)m->nv - 1;) {
            size_t j = i + 1;
            while (j < (size_t)m->nv - 1 && !pred_lexcmp3(X(m, idx[i]), X(m, idx[j])))
                j++;
            int any_used = 0;
            for (size_t q = i; q < j; q++)
                any_used |= used[idx[q]];
            for (size_t q = i; q < j; q++)
                if (!used[idx[q]]) {
                    if (any_used)
                        r->duplicates++;
                    else
                        r->isolated++;
                }
            i = j;
        }
        pr_free(idx);
    }
    pr_free(used);
    return 0;
}

#define NPROBES 8

static void check_cover(const tm_mesh *m, vf_report *r)
{
    double probe[NPROBES][3];
    int np = 0;
    if (r->tets == 0 && !(r->checked & VF_TOPOLOGY))
        return;
    /* Centroids of tets spread over the slot range, kept if strictly
     * inside their tet (always, unless the tet is nearly flat). */
    for (int k = 0; k < NPROBES; k++) {
        uint32_t t = (uint32_t)(((uint64_t)m->nslots * (uint64_t)(2 * k + 1)) / (2 * NPROBES));
        for (; t < m->nslots; t++)
            if (!tm_is_dead(m, t) && !tm_is_ghost(m, t) && tet_vertices_ok(m, t))
                break;
        if (t >= m->nslots)
            continue;
        const uint32_t *v = m->tets[t].v;
        double c[3];
        for (int q = 0; q < 3; q++)
            c[q] = (X(m, v[0])[q] + X(m, v[1])[q] + X(m, v[2])[q] + X(m, v[3])[q]) * 0.25;
        int inside = 1;
        for (int i = 0; i < 4 && inside; i++) {
            const uint8_t *f = tm_face_vtx[i];
            inside = pred_orient3d(X(m, v[f[0]]), X(m, v[f[1]]), X(m, v[f[2]]), c) > 0;
        }
        if (inside)
            memcpy(probe[np++], c, sizeof c);
    }
    int count[NPROBES] = {0};
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t) || tm_is_ghost(m, t) || !tet_vertices_ok(m, t))
            continue;
        const uint32_t *v = m->tets[t].v;
        double lo[3], hi[3];
        for (int q = 0; q < 3; q++) {
            lo[q] = hi[q] = X(m, v[0])[q];
            for (int s = 1; s < 4; s++) {
                double x = X(m, v[s])[q];
                lo[q] = x < lo[q] ? x : lo[q];
                hi[q] = x > hi[q] ? x : hi[q];
            }
        }
        for (int k = 0; k < np; k++) {
            const double *c = probe[k];
            if (c[0] < lo[0] || c[0] > hi[0] || c[1] < lo[1] || c[1] > hi[1] || c[2] < lo[2] ||
                c[2] > hi[2])
                continue;
            int inside = 1;
            for (int i = 0; i < 4 && inside; i++) {
                const uint8_t *f = tm_face_vtx[i];
                inside = pred_orient3d(X(m, v[f[0]]), X(m, v[f[1]]), X(m, v[f[2]]), c) >= 0;
            }
            count[k] += inside;
        }
    }
    r->probes += (size_t)np;
    for (int k = 0; k < np; k++)
        r->overlaps += count[k] != 1;
}

int vf_check(const tm_mesh *m, unsigned what, vf_report *r)
{
    r->checked |= what;
    r->vertices = m->nv ? m->nv - 1 : 0;
    if (what & VF_TOPOLOGY)
        check_topology(m, r);
    if (what & VF_ORIENTATION)
        check_orientation(m, r);
    if (what & VF_DELAUNAY)
        check_delaunay(m, r, (what & VF_CONSTRAINED) != 0);
    if (what & VF_HULL)
        check_hull(m, r);
    if ((what & VF_VERTICES) && check_vertices(m, r))
        return PDR_ENOMEM;
    if (what & VF_COVER)
        check_cover(m, r);
    return 0;
}

size_t vf_defects(const vf_report *r)
{
    return r->bad_vertex + r->bad_link + r->face_mismatch + r->nonmanifold + r->inverted +
           r->flat + r->folded + r->not_delaunay + r->open_hull + r->nonconvex_hull +
           r->isolated + r->overlaps;
}

static void line(FILE *f, const char *what, size_t n, int defect)
{
    fprintf(f, "  %-34s %12zu%s\n", what, n, defect && n ? "   <-- DEFECT" : "");
}

void vf_print(const vf_report *r, FILE *f)
{
    fprintf(f, "mesh\n");
    line(f, "vertices", r->vertices, 0);
    if (r->checked & VF_VERTICES) {
        line(f, "vertices in tetrahedra", r->used_vertices, 0);
        line(f, "duplicate points (not inserted)", r->duplicates, 0);
    }
    if (r->checked & VF_TOPOLOGY) {
        line(f, "tetrahedra", r->tets, 0);
        line(f, "interior faces", r->interior_faces, 0);
        line(f, "convex hull faces", r->hull_faces, 0);
        if (r->domain_faces)
            line(f, "domain boundary faces", r->domain_faces, 0);
        if (r->remote_faces)
            line(f, "remote faces", r->remote_faces, 0);
    }
    fprintf(f, "checks\n");
    if (r->checked & VF_TOPOLOGY) {
        line(f, "bad vertex numbers", r->bad_vertex, 1);
        line(f, "bad or asymmetric neighbour links", r->bad_link, 1);
        line(f, "neighbours disagreeing on a face", r->face_mismatch, 1);
        line(f, "faces in more than two tetrahedra", r->nonmanifold, 1);
    }
    if (r->checked & VF_ORIENTATION) {
        line(f, "inverted tetrahedra", r->inverted, 1);
        line(f, "flat tetrahedra", r->flat, 1);
        line(f, "folded faces", r->folded, 1);
    }
    if (r->checked & VF_DELAUNAY)
        line(f, "faces not locally Delaunay", r->not_delaunay, 1);
    if (r->checked & (VF_HULL | VF_TOPOLOGY)) {
        line(f, "open convex hull edges", r->open_hull, 1);
        line(f, "non-convex hull edges", r->nonconvex_hull, 1);
    }
    if (r->checked & VF_VERTICES)
        line(f, "points missing from the mesh", r->isolated, 1);
    if (r->checked & VF_COVER) {
        line(f, "probe points", r->probes, 0);
        line(f, "probe points not covered once", r->overlaps, 1);
    }
    size_t d = vf_defects(r);
    fprintf(f, "%s: %zu defect%s\n", d ? "FAILED" : "ok", d, d == 1 ? "" : "s");
}
