/* io/tg.c -- reading and writing TetGen .node/.ele/.face files. */
#include "config.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "io/tg.h"
#include "base/nf.h"
#include "base/outfile.h"
#include "base/textin.h"

/* ------------------------------------------------------------- reading */

void tg_nodes_free(tg_nodes *nodes)
{
    pr_free(nodes->xyz);
    pr_free(nodes->attr);
    pr_free(nodes->marker);
    memset(nodes, 0, sizeof *nodes);
}

static int no_more_values(textin *t, const char *what)
{
    char *w = textin_word(t);
    if (w)
        return textin_error(t, "unexpected '%s' after the %s", w, what);
    return 0;
}

/* Makes room for point i (0-based) of n in out, growing the arrays
 * geometrically: a header's count is not trusted with an allocation before
 * the points are there, so a tiny file that promises billions of points
 * fails at its end ("file ends after ...") instead of in malloc. */
static int node_room(tg_nodes *out, size_t i, size_t n, size_t *cap)
{
    if (i < *cap)
        return 0;
    size_t ncap = *cap ? *cap * 2 : 1024;
    if (ncap > n)
        ncap = n;
    double *xyz = pr_realloc(out->xyz, ncap * 3 * sizeof *xyz);
    if (!xyz)
        return PDR_ENOMEM;
    out->xyz = xyz;
    if (out->nattr) {
        double *a = pr_realloc(out->attr, ncap * (size_t)out->nattr * sizeof *a);
        if (!a)
            return PDR_ENOMEM;
        out->attr = a;
    }
    if (out->markers) {
        long *m = pr_realloc(out->marker, ncap * sizeof *m);
        if (!m)
            return PDR_ENOMEM;
        out->marker = m;
    }
    *cap = ncap;
    return 0;
}

int tg_read_node(const char *path, tg_nodes *out, pdr_diag *diag)
{
    memset(out, 0, sizeof *out);
    FILE *f = fopen(path, "r");
    if (!f) {
        pdr_diag_add(diag, path, 0, "cannot open: %s", strerror(errno));
        return PDR_EIO;
    }
    int rc = tg_read_node_stream(f, path, out, diag);
    fclose(f);
    return rc;
}

int tg_read_node_stream(FILE *f, const char *path, tg_nodes *out, pdr_diag *diag)
{
    memset(out, 0, sizeof *out);
    textin t;
    textin_attach(&t, f, path, diag);
    int rc;
    size_t cap = 0;
    long n = 0, dim = 0, nattr = 0, markers = 0;
    if ((rc = textin_header(&t, "<#points> 3 <#attributes> <markers 0|1>")))
        goto done;
    if ((rc = textin_long(&t, "point count", 0, (long)TM_MAX_VERTS - 2, &n)) ||
        (rc = textin_long(&t, "dimension", 0, 100, &dim)))
        goto done;
    if (dim != 3) {
        rc = textin_error(&t, "dimension must be 3, not %ld", dim);
        goto done;
    }
    if ((rc = textin_opt_long(&t, "attribute count", 0, 1000, &nattr)) < 0 ||
        (rc = textin_opt_long(&t, "boundary marker flag", 0, 1, &markers)) < 0 ||
        (rc = no_more_values(&t, "header")))
        goto done;
    out->nattr = (int)nattr;
    out->markers = (int)markers;
    for (long i = 0; i < n; i++) {
        rc = textin_next(&t);
        if (rc == 0) {
            pdr_diag_add(diag, path, t.line, "file ends after %ld of %ld points", i, n);
            rc = PDR_EPARSE;
            goto done;
        }
        if (rc < 0)
            goto done;
        if (node_room(out, (size_t)i, (size_t)n, &cap)) {
            pdr_diag_add(diag, path, t.line, "out of memory for %ld points", n);
            rc = PDR_ENOMEM;
            goto done;
        }
        out->n = (size_t)i + 1;
        long idx;
        if ((rc = textin_long(&t, "point index", -(1L << 40), 1L << 40, &idx)))
            goto done;
        if (i == 0) {
            if (idx != 0 && idx != 1) {
                rc = textin_error(&t, "the first point index must be 0 or 1, not %ld", idx);
                goto done;
            }
            out->first = idx;
        } else if (idx != out->first + i) {
            rc = textin_error(&t, "point index %ld out of sequence (expected %ld)", idx,
                              out->first + i);
            goto done;
        }
        double *p = out->xyz + 3 * i;
        if ((rc = textin_double(&t, "x coordinate", &p[0])) ||
            (rc = textin_double(&t, "y coordinate", &p[1])) ||
            (rc = textin_double(&t, "z coordinate", &p[2])))
            goto done;
        for (long a = 0; a < nattr; a++)
            if ((rc = textin_double(&t, "attribute", &out->attr[i * nattr + a])))
                goto done;
        if (markers && (rc = textin_long(&t, "boundary marker", -(1L << 40), 1L << 40,
                                         &out->marker[i])))
            goto done;
        if ((rc = no_more_values(&t, "point's values")))
            goto done;
    }
    rc = 0;
    if (!out->xyz) {
        /* No points: still a valid (empty) array for the callers. */
        out->xyz = pr_malloc(sizeof *out->xyz);
        if (!out->xyz) {
            pdr_diag_add(diag, path, 0, "out of memory");
            rc = PDR_ENOMEM;
        }
    }
done:
    textin_close(&t);
    if (rc)
        tg_nodes_free(out);
    return rc;
}

int tg_read_ele(const char *path, size_t nnodes, long first, uint32_t **tets, size_t *ntets,
                pdr_diag *diag)
{
    *tets = NULL;
    *ntets = 0;
    textin t;
    int rc = textin_open(&t, path, diag);
    if (rc)
        return rc;
    long n = 0, per = 0, nattr = 0;
    uint32_t *out = NULL;
    if ((rc = textin_header(&t, "<#tetrahedra> <nodes per tet 4|10> <#attributes>")))
        goto done;
    if ((rc = textin_long(&t, "tetrahedron count", 0, (long)TM_MAX_TETS - 1, &n)) ||
        (rc = textin_long(&t, "nodes per tetrahedron", 0, 100, &per)))
        goto done;
    if (per != 4 && per != 10) {
        rc = textin_error(&t, "nodes per tetrahedron must be 4 or 10, not %ld", per);
        goto done;
    }
    if ((rc = textin_opt_long(&t, "attribute count", 0, 1000, &nattr)) < 0 ||
        (rc = no_more_values(&t, "header")))
        goto done;
    /* The array grows with the tetrahedra read, as in tg_read_node: the
     * header's count alone is not trusted with an allocation. */
    size_t cap = 0;
    long lo = first, hi = first + (long)nnodes - 1;
    long efirst = 0;
    for (long i = 0; i <= n; i++) {
        if ((size_t)i == cap) {
            size_t ncap = cap ? 2 * cap : 1024;
            if (ncap > (size_t)n + 1)
                ncap = (size_t)n + 1;
            uint32_t *q = pr_realloc(out, ncap * 4 * sizeof *out);
            if (!q) {
                pdr_diag_add(diag, path, t.line, "out of memory for %ld tetrahedra", n);
                rc = PDR_ENOMEM;
                goto done;
            }
            out = q;
            cap = ncap;
        }
        if (i == n)
            break;
        rc = textin_next(&t);
        if (rc == 0) {
            pdr_diag_add(diag, path, t.line, "file ends after %ld of %ld tetrahedra", i, n);
            rc = PDR_EPARSE;
            goto done;
        }
        if (rc < 0)
            goto done;
        long idx;
        if ((rc = textin_long(&t, "tetrahedron index", -(1L << 40), 1L << 40, &idx)))
            goto done;
        if (i == 0)
            efirst = idx;
        if (i == 0 && idx != 0 && idx != 1) {
            rc = textin_error(&t, "the first tetrahedron index must be 0 or 1, not %ld", idx);
            goto done;
        }
        if (idx != efirst + i) {
            rc = textin_error(&t, "tetrahedron index %ld out of sequence (expected %ld)", idx,
                              efirst + i);
            goto done;
        }
        for (long k = 0; k < per; k++) {
            long v;
            if (hi < lo) {
                rc = textin_error(&t, "tetrahedron refers to a point, but there are none");
                goto done;
            }
            if ((rc = textin_long(&t, "node number", lo, hi, &v)))
                goto done;
            if (k < 4)
                out[4 * i + k] = (uint32_t)(v - first);
        }
        for (long a = 0; a < nattr; a++) {
            double x;
            if ((rc = textin_double(&t, "attribute", &x)))
                goto done;
        }
        if ((rc = no_more_values(&t, "tetrahedron's values")))
            goto done;
    }
    rc = 0;
    *tets = out;
    *ntets = (size_t)n;
    out = NULL;
done:
    pr_free(out);
    textin_close(&t);
    return rc;
}

/* ------------------------------------------------------------- writing */

/* Buffered formatting: fprintf is the bottleneck when writing millions of
 * lines, so integers are formatted by hand. */
typedef struct wbuf {
    FILE *f;
    size_t pos;
    char b[1 << 16];
} wbuf;

static void wflush(wbuf *w)
{
    if (w->pos)
        fwrite(w->b, 1, w->pos, w->f);
    w->pos = 0;
}

static void wroom(wbuf *w, size_t n)
{
    if (w->pos + n > sizeof w->b)
        wflush(w);
}

static void wstr(wbuf *w, const char *s)
{
    size_t n = strlen(s);
    wroom(w, n);
    memcpy(w->b + w->pos, s, n);
    w->pos += n;
}

static void wlong(wbuf *w, long v)
{
    char tmp[24];
    int n = 0;
    unsigned long u = v < 0 ? 0UL - (unsigned long)v : (unsigned long)v;
    do {
        tmp[n++] = (char)('0' + u % 10);
        u /= 10;
    } while (u);
    if (v < 0)
        tmp[n++] = '-';
    wroom(w, (size_t)n + 2);
    w->b[w->pos++] = ' ';
    w->b[w->pos++] = ' ';
    while (n)
        w->b[w->pos++] = tmp[--n];
}

static void wdouble(wbuf *w, double x)
{
    wroom(w, NF_DOUBLE17_MAX + 2);
    w->b[w->pos++] = ' ';
    w->b[w->pos++] = ' ';
    w->pos += nf_double17(x, w->b + w->pos); /* printf's %.17g, faster */
}

static void wnl(wbuf *w)
{
    wroom(w, 1);
    w->b[w->pos++] = '\n';
}

static int open_w(const char *path, outset *set, outfile *of, wbuf **w, pdr_diag *diag)
{
    *w = pr_malloc(sizeof **w);
    if (!*w) {
        pdr_diag_add(diag, path, 0, "out of memory");
        return PDR_ENOMEM;
    }
    int rc = outfile_open_in(of, set, path, diag);
    if (rc) {
        pr_free(*w);
        *w = NULL;
        return rc;
    }
    (*w)->f = of->f;
    (*w)->pos = 0;
    return 0;
}

static int close_w(outfile *of, wbuf *w, pdr_diag *diag)
{
    wflush(w);
    pr_free(w);
    return outfile_commit(of, diag);
}

int tg_write_node(const char *path, const tg_nodes *nodes, outset *set, pdr_diag *diag)
{
    outfile of;
    wbuf *w;
    int rc = open_w(path, set, &of, &w, diag);
    if (rc)
        return rc;
    wstr(w, "# written by pdr\n");
    wlong(w, (long)nodes->n);
    wlong(w, 3);
    wlong(w, nodes->nattr);
    wlong(w, nodes->markers);
    wnl(w);
    for (size_t i = 0; i < nodes->n; i++) {
        wlong(w, (long)i + nodes->first);
        for (int k = 0; k < 3; k++)
            wdouble(w, nodes->xyz[3 * i + (size_t)k]);
        for (int a = 0; a < nodes->nattr; a++)
            wdouble(w, nodes->attr[i * (size_t)nodes->nattr + (size_t)a]);
        if (nodes->markers)
            wlong(w, nodes->marker[i]);
        wnl(w);
    }
    return close_w(&of, w, diag);
}

/* The vertex's number in the input (dt_build may have renumbered). */
static uint64_t orig(const tm_mesh *m, uint32_t v)
{
    return m->gid ? m->gid[v] : v;
}

int tg_write_ele(const char *path, const tm_mesh *m, long first, outset *set,
                 pdr_diag *diag)
{
    outfile of;
    wbuf *w;
    int rc = open_w(path, set, &of, &w, diag);
    if (rc)
        return rc;
    size_t n = 0;
    for (uint32_t t = 0; t < m->nslots; t++)
        n += !tm_is_dead(m, t) && !tm_is_ghost(m, t);
    wstr(w, "# written by pdr\n");
    wlong(w, (long)n);
    wlong(w, 4);
    wlong(w, 0);
    wnl(w);
    long idx = first;
    for (uint32_t t = 0; t < m->nslots; t++) {
        if (tm_is_dead(m, t) || tm_is_ghost(m, t))
            continue;
        wlong(w, idx++);
        for (int s = 0; s < 4; s++)
            wlong(w, (long)orig(m, m->tets[t].v[s]) - 1 + first);
        wnl(w);
    }
    return close_w(&of, w, diag);
}

int tg_write_ele_view(const char *path, const mesh_export *m, const double *attr, long first,
                      outset *set, pdr_diag *diag)
{
    outfile of;
    wbuf *w;
    int rc = open_w(path, set, &of, &w, diag);
    if (rc)
        return rc;
    wstr(w, "# written by pdr\n");
    wlong(w, (long)m->nt);
    wlong(w, 4);
    wlong(w, attr ? 1 : 0);
    wnl(w);
    for (size_t t = 0; t < m->nt; t++) {
        wlong(w, (long)t + first);
        for (int s = 0; s < 4; s++)
            wlong(w, (long)m->tet[t][s] + first);
        if (attr)
            wdouble(w, attr[t]);
        wnl(w);
    }
    return close_w(&of, w, diag);
}

int tg_write_face(const char *path, const tm_mesh *m, long first, outset *set,
                  pdr_diag *diag)
{
    outfile of;
    wbuf *w;
    int rc = open_w(path, set, &of, &w, diag);
    if (rc)
        return rc;
    size_t n = 0;
    for (int pass = 0; pass < 2; pass++) {
        if (pass == 1) {
            wstr(w, "# written by pdr\n");
            wlong(w, (long)n);
            wlong(w, 0);
            wnl(w);
        }
        long idx = first;
        for (uint32_t t = 0; t < m->nslots; t++) {
            if (tm_is_dead(m, t))
                continue;
            const tm_tet *T = &m->tets[t];
            int k = tm_ghost_slot(m, t);
            for (int i = 0; i < 4; i++) {
                uint32_t f[3];
                const uint8_t *fv = tm_face_vtx[i];
                if (k >= 0 && i == k) { /* hull face, outside positive */
                    f[0] = T->v[fv[0]];
                    f[1] = T->v[fv[1]];
                    f[2] = T->v[fv[2]];
                } else if (k < 0 && T->n[i] == TM_LINK_NONE) { /* reversed */
                    f[0] = T->v[fv[0]];
                    f[1] = T->v[fv[2]];
                    f[2] = T->v[fv[1]];
                } else {
                    continue;
                }
                if (pass == 0) {
                    n++;
                    continue;
                }
                wlong(w, idx++);
                for (int s = 0; s < 3; s++)
                    wlong(w, (long)orig(m, f[s]) - 1 + first);
                wnl(w);
            }
        }
    }
    return close_w(&of, w, diag);
}
