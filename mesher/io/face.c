/* io/face.c -- TetGen .face writer and reader (see io/face.h). */
#include "config.h"

#include <stdio.h>
#include <stdlib.h>

#include "pr_alloc.h"
#include "io/face.h"
#include "base/outfile.h"
#include "base/textin.h"

int face_write(const mesh_export *m, const char *path, int base, outset *set,
               pdr_diag *diag)
{
    outfile of;
    int rc = outfile_open_in(&of, set, path, diag);
    if (rc)
        return rc;
    FILE *f = of.f;
    int markers = m->tri_marker != NULL;
    fprintf(f, "%zu %d\n", m->nf, markers);
    for (size_t i = 0; i < m->nf; i++) {
        const uint32_t *t = m->tri[i];
        fprintf(f, "%zu %lu %lu %lu", i + (size_t)base, (unsigned long)t[0] + (unsigned long)base,
                (unsigned long)t[1] + (unsigned long)base,
                (unsigned long)t[2] + (unsigned long)base);
        if (markers)
            fprintf(f, " %d", m->tri_marker[i]);
        fputc('\n', f);
    }
    fprintf(f, "# written by pdr %s\n", PACKAGE_VERSION);
    return outfile_commit(&of, diag);
}

int face_read(const char *path, size_t nnodes, long first, uint32_t **tri, int **marker,
              size_t *nface, pdr_diag *diag)
{
    *tri = NULL;
    *marker = NULL;
    *nface = 0;
    textin t;
    int rc = textin_open(&t, path, diag);
    if (rc)
        return rc;
    long n = 0, nm = 0;
    uint32_t *out = NULL;
    int *mk = NULL;
    if ((rc = textin_header(&t, "<#faces> <markers 0|1>")))
        goto done;
    if ((rc = textin_long(&t, "face count", 0, 1L << 40, &n)) ||
        (rc = textin_opt_long(&t, "marker flag", 0, 1, &nm)) < 0)
        goto done;
    if (!textin_at_eol(&t)) {
        rc = textin_error(&t, "unexpected values after the header");
        goto done;
    }
    /* The arrays grow with the faces read (one spare entry, so that they
     * exist for n = 0): the header's count alone is not trusted with an
     * allocation. */
    size_t cap = 0;
    long lo = first, hi = first + (long)nnodes - 1, ffirst = 0;
    for (long i = 0; i <= n; i++) {
        if ((size_t)i == cap) {
            size_t ncap = cap ? 2 * cap : 1024;
            if (ncap > (size_t)n + 1)
                ncap = (size_t)n + 1;
            uint32_t *q = pr_realloc(out, ncap * 3 * sizeof *out);
            if (q)
                out = q;
            int *qm = q && nm ? pr_realloc(mk, ncap * sizeof *mk) : NULL;
            if (qm)
                mk = qm;
            if (!q || (nm && !qm)) {
                pdr_diag_add(diag, path, t.line, "out of memory for %ld faces", n);
                rc = PDR_ENOMEM;
                goto done;
            }
            cap = ncap;
        }
        if (i == n)
            break;
        rc = textin_next(&t);
        if (rc == 0) {
            pdr_diag_add(diag, path, t.line, "file ends after %ld of %ld faces", i, n);
            rc = PDR_EPARSE;
            goto done;
        }
        if (rc < 0)
            goto done;
        long idx;
        if ((rc = textin_long(&t, "face index", -(1L << 40), 1L << 40, &idx)))
            goto done;
        if (i == 0)
            ffirst = idx;
        if (idx != ffirst + i) {
            rc = textin_error(&t, "face index %ld out of sequence (expected %ld)", idx,
                              ffirst + i);
            goto done;
        }
        for (int k = 0; k < 3; k++) {
            long v;
            if (hi < lo) {
                rc = textin_error(&t, "face refers to a point, but there are none");
                goto done;
            }
            if ((rc = textin_long(&t, "node number", lo, hi, &v)))
                goto done;
            out[3 * i + k] = (uint32_t)(v - first);
        }
        if (nm) {
            long x;
            if ((rc = textin_long(&t, "face marker", -(1L << 31), (1L << 31) - 1, &x)))
                goto done;
            mk[i] = (int)x;
        }
        if (!textin_at_eol(&t)) {
            rc = textin_error(&t, "unexpected values after the face's values");
            goto done;
        }
    }
    rc = 0;
    *tri = out;
    *marker = mk;
    *nface = (size_t)n;
    out = NULL;
    mk = NULL;
done:
    pr_free(out);
    pr_free(mk);
    textin_close(&t);
    return rc;
}
