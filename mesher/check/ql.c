/* check/ql.c -- tetrahedron measures, mesh statistics, histograms, plots. */
#include "config.h"

#include <errno.h>
#include <math.h>
#include <spawn.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "pr_alloc.h"
#include "check/ql.h"
#include "base/v3.h"

extern char **environ;





/* The tetrahedron's edges, in the order of ql_tet.dihedral, and for each
 * the two vertices not on it. */
static const int edge_v[6][4] = {{0, 1, 2, 3}, {0, 2, 1, 3}, {0, 3, 1, 2},
                                 {1, 2, 0, 3}, {1, 3, 0, 2}, {2, 3, 0, 1}};

void ql_tet_measure(const double a[3], const double b[3], const double c[3],
                    const double d[3], ql_tet *m)
{
    const double *p[4] = {a, b, c, d};
    double u[3], v[3], w[3], vw[3], wu[3], uv[3];
    double det = v3_tet_frame(a, b, c, d, u, v, w, vw, wu, uv);
    m->volume = det / 6.0;
    if (det != 0.0) {
        double uu = v3_dot(u, u), vv = v3_dot(v, v), ww = v3_dot(w, w), o[3];
        for (int k = 0; k < 3; k++)
            o[k] = (uu * vw[k] + vv * wu[k] + ww * uv[k]) / (2.0 * det);
        m->circumradius = v3_norm(o);
    } else {
        m->circumradius = INFINITY;
    }
    m->shortest = INFINITY;
    m->longest = 0.0;
    m->min_dihedral = 180.0;
    m->max_dihedral = 0.0;
    for (int e = 0; e < 6; e++) {
        const double *pi = p[edge_v[e][0]], *pj = p[edge_v[e][1]];
        const double *pk = p[edge_v[e][2]], *pl = p[edge_v[e][3]];
        double ev[3], ek[3], el[3], n1[3], n2[3], n12[3];
        v3_sub(pj, pi, ev);
        double len = v3_norm(ev);
        if (len < m->shortest)
            m->shortest = len;
        if (len > m->longest)
            m->longest = len;
        /* The normals of the two faces at the edge, both perpendicular to
         * it: the angle between them is the dihedral angle. */
        v3_sub(pk, pi, ek);
        v3_sub(pl, pi, el);
        v3_cross(ev, ek, n1);
        v3_cross(ev, el, n2);
        v3_cross(n1, n2, n12);
        double ang = atan2(v3_norm(n12), v3_dot(n1, n2)) * (180.0 / 3.14159265358979323846);
        m->dihedral[e] = ang;
        if (ang < m->min_dihedral)
            m->min_dihedral = ang;
        if (ang > m->max_dihedral)
            m->max_dihedral = ang;
    }
    m->radius_edge = m->shortest > 0 ? m->circumradius / m->shortest : INFINITY;
}

/* ------------------------------------------------------------ boundary */

/* Open-addressing set of faces (sorted vertex triples). */
struct faceset {
    uint32_t (*key)[3];
    size_t cap; /* power of two; key[i][0] == UINT32_MAX marks empty */
};


static size_t face_hash(const uint32_t *k, size_t mask)
{
    uint64_t h = k[0] * 0x9e3779b97f4a7c15u;
    h ^= (k[1] + 0x632be59bd9b4e019u) * 0xc2b2ae3d27d4eb4fu;
    h ^= (k[2] + 0x85ebca77c2b2ae63u) * 0x165667b19e3779f9u;
    h ^= h >> 29;
    return (size_t)h & mask;
}

static int faceset_init(struct faceset *fs, size_t n)
{
    fs->cap = 16;
    while (fs->cap < 2 * n)
        fs->cap *= 2;
    fs->key = pr_malloc(fs->cap * sizeof *fs->key);
    if (!fs->key)
        return PDR_ENOMEM;
    memset(fs->key, 0xff, fs->cap * sizeof *fs->key);
    return 0;
}

static void faceset_add(struct faceset *fs, const uint32_t *f)
{
    uint32_t k[3];
    v3_sort3u(f[0], f[1], f[2], k);
    size_t i = face_hash(k, fs->cap - 1);
    while (fs->key[i][0] != UINT32_MAX) {
        if (!memcmp(fs->key[i], k, sizeof k))
            return;
        i = (i + 1) & (fs->cap - 1);
    }
    memcpy(fs->key[i], k, sizeof k);
}

static int faceset_has(const struct faceset *fs, const uint32_t *k)
{
    size_t i = face_hash(k, fs->cap - 1);
    while (fs->key[i][0] != UINT32_MAX) {
        if (!memcmp(fs->key[i], k, 3 * sizeof *k))
            return 1;
        i = (i + 1) & (fs->cap - 1);
    }
    return 0;
}

struct facerec {
    uint32_t k[3];
    uint32_t tet;
};

static int cmp_facerec(const void *x, const void *y)
{
    const struct facerec *a = x, *b = y;
    for (int i = 0; i < 3; i++)
        if (a->k[i] != b->k[i])
            return a->k[i] < b->k[i] ? -1 : 1;
    return 0;
}

static const int tet_face[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};

/* Marks the boundary tetrahedra: flag[t] = 1 when a face of t is a
 * boundary triangle (or, without triangles, a face of t alone). */
static int mark_boundary(const mesh_export *m, unsigned char *flag)
{
    if (m->nf > 0) {
        struct faceset fs;
        if (faceset_init(&fs, m->nf))
            return PDR_ENOMEM;
        for (size_t f = 0; f < m->nf; f++)
            faceset_add(&fs, m->tri[f]);
        for (size_t t = 0; t < m->nt; t++)
            for (int i = 0; i < 4 && !flag[t]; i++) {
                uint32_t f[3] = {m->tet[t][tet_face[i][0]], m->tet[t][tet_face[i][1]],
                                 m->tet[t][tet_face[i][2]]},
                         k[3];
                v3_sort3u(f[0], f[1], f[2], k);
                flag[t] = (unsigned char)faceset_has(&fs, k);
            }
        pr_free(fs.key);
        return 0;
    }
    struct facerec *r = pr_malloc((4 * m->nt + 1) * sizeof *r);
    if (!r)
        return PDR_ENOMEM;
    for (size_t t = 0; t < m->nt; t++)
        for (int i = 0; i < 4; i++) {
            uint32_t f[3] = {m->tet[t][tet_face[i][0]], m->tet[t][tet_face[i][1]],
                             m->tet[t][tet_face[i][2]]};
            v3_sort3u(f[0], f[1], f[2], r[4 * t + i].k);
            r[4 * t + i].tet = (uint32_t)t;
        }
    qsort(r, 4 * m->nt, sizeof *r, cmp_facerec);
    for (size_t i = 0; i < 4 * m->nt;) {
        size_t j = i + 1;
        while (j < 4 * m->nt && !cmp_facerec(&r[i], &r[j]))
            j++;
        if (j - i == 1)
            flag[r[i].tet] = 1;
        i = j;
    }
    pr_free(r);
    return 0;
}

int ql_mesh_stats(const mesh_export *m, double re_bound, ql_stats *s)
{
    memset(s, 0, sizeof *s);
    s->re_bound = re_bound;
    s->re_min = s->dih_min = s->min_volume = s->shortest_edge = INFINITY;
    s->re_max = s->dih_max = 0.0;
    unsigned char *flag = pr_calloc(m->nt ? m->nt : 1, 1);
    if (!flag)
        return PDR_ENOMEM;
    if (mark_boundary(m, flag)) {
        pr_free(flag);
        return PDR_ENOMEM;
    }
    for (size_t t = 0; t < m->nt; t++) {
        const uint32_t *v = m->tet[t];
        ql_tet q;
        ql_tet_measure(m->xyz[v[0]], m->xyz[v[1]], m->xyz[v[2]], m->xyz[v[3]], &q);
        s->ntet++;
        s->nboundary += flag[t];
        if (q.volume > 0)
            s->npositive++;
        else if (q.volume < 0)
            s->nnegative++;
        else
            s->ndegenerate++;
        double av = fabs(q.volume);
        s->volume += av;
        s->min_volume = fmin(s->min_volume, av);
        s->shortest_edge = fmin(s->shortest_edge, q.shortest);
        s->re_min = fmin(s->re_min, q.radius_edge);
        s->re_max = fmax(s->re_max, q.radius_edge);
        if (q.radius_edge >= re_bound)
            s->re_above++;
        double bin = floor((q.radius_edge - QL_RE_LO) / QL_RE_STEP);
        s->re_hist[bin < 0 ? 0 : bin >= QL_RE_NBINS - 1 ? QL_RE_NBINS - 1 : (size_t)bin]++;
        s->dih_min = fmin(s->dih_min, q.min_dihedral);
        s->dih_max = fmax(s->dih_max, q.max_dihedral);
        for (int e = 0; e < 6; e++) {
            int b = (int)floor(q.dihedral[e]);
            b = b < 0 ? 0 : b >= QL_DIH_NBINS ? QL_DIH_NBINS - 1 : b;
            s->dih_hist[flag[t] ? 0 : 1][b]++;
        }
    }
    if (m->nt == 0)
        s->re_min = s->dih_min = s->min_volume = s->shortest_edge = 0.0;
    pr_free(flag);
    return 0;
}

/* ------------------------------------------------------------ output */

static void bar(FILE *out, size_t n, size_t max, int width)
{
    int len = max ? (int)((double)n * width / (double)max + 0.5) : 0;
    if (n > 0 && len == 0)
        len = 1; /* a nonzero count never looks empty */
    for (int i = 0; i < len; i++)
        fputc('#', out);
    fputc('\n', out);
}

static int valid_bin(int b)
{
    return b >= 1 && b <= 90 && QL_DIH_NBINS % b == 0 ? b : 5;
}

void ql_print(const ql_stats *s, FILE *out, int dih_bin)
{
    dih_bin = valid_bin(dih_bin);
    fprintf(out, "tetrahedra %zu (%zu boundary, %zu interior), volume %.10g\n", s->ntet,
            s->nboundary, s->ntet - s->nboundary, s->volume);
    fprintf(out, "radius-edge ratio min %.4f max %.4f; %zu at or above %g\n",
            s->re_min, s->re_max, s->re_above, s->re_bound);
    fprintf(out, "dihedral angle min %.3f max %.3f degrees\n", s->dih_min, s->dih_max);
    fprintf(out, "shortest edge %.6g\n", s->shortest_edge);

    size_t max = 0;
    for (int i = 0; i < QL_RE_NBINS; i++)
        max = s->re_hist[i] > max ? s->re_hist[i] : max;
    fprintf(out, "\nradius-edge ratio histogram\n");
    for (int i = 0; i < QL_RE_NBINS; i++) {
        double lo = QL_RE_LO + i * QL_RE_STEP;
        if (i < QL_RE_NBINS - 1)
            fprintf(out, "  [%.1f, %.1f) %10zu ", lo, lo + QL_RE_STEP, s->re_hist[i]);
        else
            fprintf(out, "  [%.1f, inf) %10zu ", lo, s->re_hist[i]);
        bar(out, s->re_hist[i], max, 40);
    }

    static const char *const label[2] = {"boundary", "interior"};
    for (int k = 0; k < 2; k++) {
        size_t agg[QL_DIH_NBINS] = {0}, amax = 0;
        int nb = QL_DIH_NBINS / dih_bin;
        for (int i = 0; i < QL_DIH_NBINS; i++)
            agg[i / dih_bin] += s->dih_hist[k][i];
        for (int i = 0; i < nb; i++)
            amax = agg[i] > amax ? agg[i] : amax;
        fprintf(out, "\ndihedral angles of %s elements (degrees)\n", label[k]);
        for (int i = 0; i < nb; i++) {
            fprintf(out, "  [%3d, %3d) %10zu ", i * dih_bin, (i + 1) * dih_bin, agg[i]);
            bar(out, agg[i], amax, 40);
        }
    }
}

static void gnuplot_string(FILE *out, const char *s)
{
    /* Single-quoted gnuplot strings take '' for a quote. */
    fputc('\'', out);
    for (; *s; s++) {
        if (*s == '\'')
            fputc('\'', out);
        fputc(*s, out);
    }
    fputc('\'', out);
}

int ql_write_gnuplot(const ql_stats *s, FILE *out, const char *png_path,
                     const char *title, int dih_bin)
{
    dih_bin = valid_bin(dih_bin);
    fprintf(out, "# Dihedral angle distribution written by pdr %s\n", PACKAGE_VERSION);
    fprintf(out, "set terminal png size 900,600\nset output ");
    gnuplot_string(out, png_path);
    fprintf(out, "\nset title ");
    gnuplot_string(out, title ? title : "Dihedral angle distribution");
    fprintf(out, "\nset xlabel 'angle (degrees)'\n"
                 "set ylabel '# elements x 1000'\n"
                 "set xrange [0:180]\nset xtics 30\nset grid\nset key top right\n"
                 "$dihedral << EOD\n");
    int nb = QL_DIH_NBINS / dih_bin;
    for (int i = 0; i < nb; i++) {
        size_t b = 0, n = 0;
        for (int j = i * dih_bin; j < (i + 1) * dih_bin; j++) {
            b += s->dih_hist[0][j];
            n += s->dih_hist[1][j];
        }
        fprintf(out, "%g %.3f %.3f\n", (i + 0.5) * dih_bin, b / 1000.0, n / 1000.0);
    }
    fprintf(out, "EOD\n"
                 "plot $dihedral using 1:2 with linespoints title 'Boundary Elements', \\\n"
                 "     $dihedral using 1:3 with linespoints title 'Interior Elements'\n");
    return ferror(out) ? PDR_EIO : 0;
}

int ql_plot_png(const ql_stats *s, const char *png_path, const char *title,
                int dih_bin, pdr_diag *diag)
{
    size_t n = strlen(png_path);
    char *tmp_png = pr_malloc(n + 16);
    char script[] = "/tmp/pdr-plot-XXXXXX";
    if (!tmp_png) {
        pdr_diag_add(diag, png_path, 0, "out of memory");
        return PDR_ENOMEM;
    }
    snprintf(tmp_png, n + 16, "%s.tmp.XXXXXX", png_path);
    int pfd = mkstemp(tmp_png);
    if (pfd < 0) {
        pdr_diag_add(diag, png_path, 0, "cannot create: %s", strerror(errno));
        pr_free(tmp_png);
        return PDR_EIO;
    }
    /* mkstemp made it 0600; give the plot the usual umask-based mode. */
    mode_t mask = umask(0);
    umask(mask);
    fchmod(pfd, 0666 & ~mask);
    close(pfd);
    int rc = PDR_EIO;
    int sfd = mkstemp(script);
    FILE *f = sfd >= 0 ? fdopen(sfd, "w") : NULL;
    if (!f) {
        pdr_diag_add(diag, script, 0, "cannot create a temporary gnuplot script: %s",
                     strerror(errno));
        if (sfd >= 0) {
            close(sfd);
            unlink(script);
        }
        unlink(tmp_png);
        pr_free(tmp_png);
        return PDR_EIO;
    }
    int wr = ql_write_gnuplot(s, f, tmp_png, title, dih_bin);
    if (fclose(f) != 0 || wr) {
        pdr_diag_add(diag, script, 0, "cannot write the gnuplot script");
        goto out;
    }
    const char *prog = getenv("PDR_GNUPLOT");
    if (!prog || !*prog)
        prog = "gnuplot";
    char *argv[] = {(char *)prog, script, NULL};
    pid_t pid;
    int err = posix_spawnp(&pid, prog, NULL, NULL, argv, environ);
    if (err) {
        pdr_diag_add(diag, png_path, 0, "cannot run %s: %s", prog, strerror(err));
        goto out;
    }
    int status;
    while (waitpid(pid, &status, 0) < 0)
        if (errno != EINTR) {
            status = -1;
            break;
        }
    if (status != 0) {
        pdr_diag_add(diag, png_path, 0, "%s failed (status %d); no plot written",
                     prog, status);
        goto out;
    }
    if (rename(tmp_png, png_path) != 0) {
        pdr_diag_add(diag, png_path, 0, "cannot write: %s", strerror(errno));
        goto out;
    }
    rc = 0;
out:
    unlink(script);
    if (rc)
        unlink(tmp_png);
    pr_free(tmp_png);
    return rc;
}
