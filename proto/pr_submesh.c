/* pr_submesh.c -- the submesh message: one PE's part of the mesh as rank 0
 * scatters it after partitioning (PROTOCOL.md, "Submesh"). */
#include "config.h"

#include <stdlib.h>

#include "pr.h"
#include "pr_alloc.h"
#include "pr_int.h"

/* Bytes per interface face on the wire: face name and remote rank. */
#define IFTABLE_ELEM 8

/* Checks of the submesh's own fields and of its interface table; the
 * vertex and tetrahedron tables check themselves. Returns 0, PR_ERANGE or
 * PR_EDATA. */
static int head_error(const pr_submesh *sm)
{
    if (sm->size == 0 || sm->rank >= sm->size)
        return PR_ERANGE;
    /* Gids are ascending, so the last has the largest rank. */
    if (sm->vert.n && pr_gid_rank(sm->vert.gid[sm->vert.n - 1]) >= sm->size)
        return PR_ERANGE;
    return 0;
}

static int iftable_error(const pr_iftable *f, const pr_submesh *sm)
{
    if (f->n > PR_MAX_IFACES)
        return PR_ERANGE;
    /* tet.n <= 2^25, so 4 * tet.n fits in 32 bits. */
    uint32_t n_faces = 4 * sm->tet.n;
    int bad_ref = 0, bad_range = 0;
    for (uint32_t i = 0; i < f->n; i++) {
        bad_ref |= f->face[i] >= n_faces;
        bad_ref |= i > 0 && f->face[i] <= f->face[i - 1];
        bad_range |= f->remote[i] >= sm->size || f->remote[i] == sm->rank;
    }
    return bad_range ? PR_ERANGE : bad_ref ? PR_EDATA : 0;
}

int pr_submesh_put(pr_buf *b, const pr_submesh *sm)
{
    if (b->err)
        return b->err;
    if (head_error(sm) || iftable_error(&sm->iface, sm))
        return pr__buf_fail(b, PR_EINVAL);
    /* The tables check their own invariants before writing anything; if
     * one refuses, the partial message is cut off again. */
    size_t start = b->len;
    pr_msg_begin(b, PR_MSG_SUBMESH);
    pr_put_u32(b, sm->part);
    pr_put_u32(b, sm->rank);
    pr_put_u32(b, sm->size);
    pr_put_u32(b, sm->n_facets);
    pr_vtable_put(b, &sm->vert);
    pr_ttable_put(b, &sm->tet, sm->vert.n, sm->n_facets);
    pr_put_u32(b, sm->iface.n);
    pr_put_u32_array(b, sm->iface.face, sm->iface.n);
    pr_put_u32_array(b, sm->iface.remote, sm->iface.n);
    if (b->err && b->len >= start)
        b->len = start;
    return b->err;
}

static int iftable_get(pr_reader *r, pr_iftable *f)
{
    *f = (pr_iftable){0};
    uint32_t n;
    if (pr_get_count(r, PR_MAX_IFACES, IFTABLE_ELEM, &n))
        return r->err;
    if (n == 0)
        return 0;
    uint32_t *mem = pr_malloc((size_t)n * IFTABLE_ELEM);
    if (!mem)
        return pr_reader_fail(r, PR_ENOMEM);
    f->n = n;
    f->face = mem;
    f->remote = mem + n;
    pr_get_u32_array(r, f->face, n);
    return pr_get_u32_array(r, f->remote, n);
}

void pr_submesh_free(pr_submesh **sm)
{
    if (!*sm)
        return;
    pr_vtable_clear(&(*sm)->vert);
    pr_ttable_clear(&(*sm)->tet);
    pr_free((*sm)->iface.face); /* one allocation with remote */
    pr_free(*sm);
    *sm = NULL;
}

int pr_submesh_decode(const void *payload, size_t len, pr_submesh **out)
{
    *out = NULL;
    pr_submesh *sm = pr_calloc(1, sizeof *sm);
    if (!sm)
        return PR_ENOMEM;
    pr_reader r;
    if (pr_msg_open(&r, payload, len, PR_MSG_SUBMESH))
        goto fail;
    pr_get_u32(&r, &sm->part);
    pr_get_u32(&r, &sm->rank);
    pr_get_u32(&r, &sm->size);
    pr_get_u32(&r, &sm->n_facets);
    if (r.err || pr_vtable_get(&r, &sm->vert))
        goto fail;
    int rc = head_error(sm);
    if (rc) {
        pr_reader_fail(&r, rc);
        goto fail;
    }
    if (pr_ttable_get(&r, &sm->tet, sm->vert.n, sm->n_facets))
        goto fail;
    if (iftable_get(&r, &sm->iface))
        goto fail;
    rc = iftable_error(&sm->iface, sm);
    if (rc) {
        pr_reader_fail(&r, rc);
        goto fail;
    }
    rc = pr_reader_finish(&r);
    if (rc) {
        pr_reader_fail(&r, rc);
        goto fail;
    }
    *out = sm;
    return 0;
fail:
    rc = r.err ? r.err : PR_EINVAL;
    pr_submesh_free(&sm);
    return rc;
}

void pr_submesh_vertex(const pr_submesh *sm, uint32_t i, pr_vertex *v)
{
    v->gid = sm->vert.gid[i];
    for (int k = 0; k < 3; k++)
        v->xyz[k] = sm->vert.xyz[3 * (size_t)i + k];
    v->flags = sm->vert.flags[i];
}

void pr_submesh_tet(const pr_submesh *sm, uint32_t i, pr_tet *t)
{
    for (int k = 0; k < 4; k++) {
        t->v[k] = sm->vert.gid[sm->tet.v[4 * (size_t)i + k]];
        t->face_marker[k] = sm->tet.marker[4 * (size_t)i + k];
    }
    t->subseg = sm->tet.subseg[i];
    t->owner = sm->rank;
}

void pr_submesh_iface_key(const pr_submesh *sm, uint32_t j, pr_face_key *k)
{
    uint32_t name = sm->iface.face[j];
    const uint32_t *v = sm->tet.v + 4 * (size_t)(name / 4);
    uint64_t g[3];
    int n = 0;
    for (uint32_t c = 0; c < 4; c++)
        if (c != name % 4)
            g[n++] = sm->vert.gid[v[c]];
    /* The tetrahedron's vertices are distinct, so this cannot fail. */
    pr_face_key_make(k, g[0], g[1], g[2]);
}
