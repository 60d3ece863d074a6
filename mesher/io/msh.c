/* io/msh.c -- Gmsh .msh 4.1 ASCII writer (see io/msh.h). */
#include "config.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "io/msh.h"
#include "base/outfile.h"

static int cmp_int(const void *x, const void *y)
{
    int a = *(const int *)x, b = *(const int *)y;
    return a < b ? -1 : a > b;
}

/* The distinct values of vals[0..n) (or {0} when vals is NULL or n is 0),
 * sorted; *nd receives their number. Caller frees. */
static int *distinct(const int *vals, size_t n, size_t *nd)
{
    size_t cnt = vals && n ? n : 1;
    int *d = pr_malloc(cnt * sizeof *d);
    if (!d)
        return NULL;
    if (vals && n)
        memcpy(d, vals, n * sizeof *d);
    else
        d[0] = 0;
    qsort(d, cnt, sizeof *d, cmp_int);
    size_t u = 0;
    for (size_t i = 0; i < cnt; i++)
        if (i == 0 || d[i] != d[u - 1])
            d[u++] = d[i];
    *nd = u;
    return d;
}

static size_t entity_of(const int *vals, size_t i, const int *d, size_t nd)
{
    int key = vals ? vals[i] : 0;
    const int *hit = bsearch(&key, d, nd, sizeof *d, cmp_int);
    return (size_t)(hit - d);
}

struct group {
    size_t *start; /* nd + 1 */
    uint32_t *elem;
    double (*box)[6];
};

/* Groups n elements (each of k corners in conn) by entity. */
static int group(struct group *g, const uint32_t *conn, int k, size_t n,
                 const int *vals, const int *d, size_t nd, const double (*xyz)[3])
{
    g->start = pr_calloc(nd + 1, sizeof *g->start);
    g->elem = pr_malloc((n ? n : 1) * sizeof *g->elem);
    g->box = pr_malloc(nd * sizeof *g->box);
    if (!g->start || !g->elem || !g->box)
        return PDR_ENOMEM;
    for (size_t e = 0; e < nd; e++)
        for (int j = 0; j < 3; j++) {
            g->box[e][j] = INFINITY;
            g->box[e][3 + j] = -INFINITY;
        }
    for (size_t i = 0; i < n; i++)
        g->start[entity_of(vals, i, d, nd) + 1]++;
    for (size_t e = 0; e < nd; e++)
        g->start[e + 1] += g->start[e];
    size_t *fill = pr_malloc((nd ? nd : 1) * sizeof *fill);
    if (!fill)
        return PDR_ENOMEM;
    memcpy(fill, g->start, nd * sizeof *fill);
    for (size_t i = 0; i < n; i++) {
        size_t e = entity_of(vals, i, d, nd);
        g->elem[fill[e]++] = (uint32_t)i;
        for (int c = 0; c < k; c++) {
            const double *x = xyz[conn[i * (size_t)k + (size_t)c]];
            for (int j = 0; j < 3; j++) {
                g->box[e][j] = fmin(g->box[e][j], x[j]);
                g->box[e][3 + j] = fmax(g->box[e][3 + j], x[j]);
            }
        }
    }
    pr_free(fill);
    return 0;
}

static void group_free(struct group *g)
{
    pr_free(g->start);
    pr_free(g->elem);
    pr_free(g->box);
}

static void put_box(FILE *f, const double *b)
{
    /* An entity without elements gets an empty box at the origin. */
    for (int j = 0; j < 6; j++)
        fprintf(f, "%.17g ", isfinite(b[j]) ? b[j] : 0.0);
}

int msh_write(const mesh_export *m, const char *path, outset *set, pdr_diag *diag)
{
    size_t ns = 0, nvol = 0;
    int *smark = distinct(m->tri_marker, m->nf, &ns);
    int *vreg = distinct(m->tet_region, m->nt, &nvol);
    struct group gs = {0}, gv = {0};
    int rc = PDR_ENOMEM;
    if (!smark || !vreg)
        goto fail;
    if (m->nf == 0)
        ns = 0; /* no triangles, no surface entities */
    if (group(&gs, m->nf ? &m->tri[0][0] : NULL, 3, m->nf, m->tri_marker, smark,
              ns ? ns : 1, m->xyz) ||
        group(&gv, m->nt ? &m->tet[0][0] : NULL, 4, m->nt, m->tet_region, vreg, nvol,
              m->xyz))
        goto fail;

    outfile of;
    if ((rc = outfile_open_in(&of, set, path, diag)))
        goto out;
    FILE *f = of.f;
    fprintf(f, "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n");
    fprintf(f, "$Entities\n0 0 %zu %zu\n", ns, nvol);
    for (size_t e = 0; e < ns; e++) {
        fprintf(f, "%zu ", e + 1);
        put_box(f, gs.box[e]);
        if (smark[e] > 0)
            fprintf(f, "1 %d 0\n", smark[e]);
        else
            fprintf(f, "0 0\n");
    }
    for (size_t e = 0; e < nvol; e++) {
        fprintf(f, "%zu ", e + 1);
        put_box(f, gv.box[e]);
        if (vreg[e] > 0)
            fprintf(f, "1 %d 0\n", vreg[e]);
        else
            fprintf(f, "0 0\n");
    }
    fprintf(f, "$EndEntities\n");

    fprintf(f, "$Nodes\n1 %zu 1 %zu\n3 1 0 %zu\n", m->nv, m->nv, m->nv);
    for (size_t v = 0; v < m->nv; v++)
        fprintf(f, "%zu\n", v + 1);
    for (size_t v = 0; v < m->nv; v++)
        fprintf(f, "%.17g %.17g %.17g\n", m->xyz[v][0], m->xyz[v][1], m->xyz[v][2]);
    fprintf(f, "$EndNodes\n");

    size_t nblocks = 0, nelem = m->nf + m->nt;
    for (size_t e = 0; e < ns; e++)
        nblocks += gs.start[e + 1] > gs.start[e];
    for (size_t e = 0; e < nvol; e++)
        nblocks += gv.start[e + 1] > gv.start[e];
    fprintf(f, "$Elements\n%zu %zu %d %zu\n", nblocks, nelem, nelem ? 1 : 0, nelem);
    size_t tag = 1;
    for (size_t e = 0; e < ns; e++) {
        size_t cnt = gs.start[e + 1] - gs.start[e];
        if (!cnt)
            continue;
        fprintf(f, "2 %zu 2 %zu\n", e + 1, cnt);
        for (size_t i = gs.start[e]; i < gs.start[e + 1]; i++) {
            const uint32_t *t = m->tri[gs.elem[i]];
            fprintf(f, "%zu %u %u %u\n", tag++, t[0] + 1, t[1] + 1, t[2] + 1);
        }
    }
    for (size_t e = 0; e < nvol; e++) {
        size_t cnt = gv.start[e + 1] - gv.start[e];
        if (!cnt)
            continue;
        fprintf(f, "3 %zu 4 %zu\n", e + 1, cnt);
        for (size_t i = gv.start[e]; i < gv.start[e + 1]; i++) {
            uint32_t v[4];
            mesh_export_tet(m, gv.elem[i], v);
            fprintf(f, "%zu %u %u %u %u\n", tag++, v[0] + 1, v[1] + 1, v[2] + 1,
                    v[3] + 1);
        }
    }
    fprintf(f, "$EndElements\n");
    rc = outfile_commit(&of, diag);
    goto out;
fail:
    pdr_diag_add(diag, path, 0, "out of memory");
out:
    group_free(&gs);
    group_free(&gv);
    pr_free(smark);
    pr_free(vreg);
    return rc;
}
