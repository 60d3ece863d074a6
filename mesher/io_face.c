/* io_face.c -- TetGen .face writer (see io_face.h). */
#include "config.h"

#include <stdio.h>

#include "io_face.h"
#include "outfile.h"

int face_write(const mesh_export *m, const char *path, int base, pdr_diag *diag)
{
    outfile of;
    int rc = outfile_open(&of, path, diag);
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
