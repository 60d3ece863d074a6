/*
 * plc/plc_obj.c -- the Wavefront OBJ reader (the polygon part of the
 * format, as Blender, FreeCAD, MeshLab and most CAD and scan tools export
 * it).
 *
 * What is read:
 *  - "v x y z [w | r g b]": a vertex; what follows x y z (a weight, or a
 *    colour as some scan tools write) is ignored;
 *  - "f c1 c2 c3 ...": a face; each corner is "v", "v/vt", "v//vn" or
 *    "v/vt/vn", v numbered from 1, or negative: relative to the vertices
 *    read so far (-1 is the last one). Only v is used. A face may name a
 *    vertex defined after it. Each face is a facet with marker 0, mended
 *    as the other surface files (plc/plc_surf.c); vertices with equal
 *    coordinates are welded, and messages keep the file's numbers;
 *  - a line ending in '\' continues on the next one.
 * Ignored: texture coordinates and normals (vt, vn), points and lines (p,
 * l), groups, objects, smoothing groups and materials (g, o, s, mg,
 * usemtl, mtllib), display attributes, and any statement this reader does
 * not know. Refused with a message: free-form geometry (curves and
 * surfaces: cstype, curv, surf, ...), whose shape would be lost.
 */
#include "config.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "plc/plc.h"
#include "plc/plc_int.h"

/* Statements of free-form geometry: refused. */
static const char *const freeform[] = {"cstype", "deg",  "bmat", "step", "curv", "curv2",
                                       "surf",   "parm", "trim", "hole", "scrv", "sp",
                                       "con",    NULL};

static int is_freeform(const char *w)
{
    for (int i = 0; freeform[i]; i++)
        if (!strcmp(w, freeform[i]))
            return 1;
    return 0;
}

/* The next word of a statement, following a '\' at the end of a line onto
 * the next one; NULL at the statement's end. */
static char *statement_word(textin *t, int *rc)
{
    for (;;) {
        char *w = textin_word(t);
        if (!w || strcmp(w, "\\") != 0 || !textin_at_eol(t))
            return w;
        if ((*rc = plc__need_line(t, "the line continued by '\\'")))
            return NULL;
    }
}

/* The vertex number of corner word w ("v", "v/vt", "v//vn", "v/vt/vn"),
 * 0-based, with a negative one taken relative to the nv vertices read so
 * far. Returns 0, or PDR_EPARSE with a message. */
static int corner_of(textin *t, const char *w, long nv, uint32_t *out)
{
    char *end;
    long k = strtol(w, &end, 10);
    if (end == w || (*end && *end != '/'))
        return textin_error(t, "face corner '%s' is not a vertex number", w);
    if (k > 0 && k <= PLC_MAX_COUNT) {
        *out = (uint32_t)(k - 1);
        return 0;
    }
    if (k < 0 && k >= -nv) {
        *out = (uint32_t)(nv + k);
        return 0;
    }
    if (k < 0)
        return textin_error(t, "relative vertex number %ld reaches before the first "
                               "vertex (%ld read so far)", k, nv);
    return textin_error(t, "vertex number %ld is out of range", k);
}

int plc__read_obj(plc *p, FILE *f, const char *path, pdr_diag *diag)
{
    textin t;
    textin_attach(&t, f, path, diag);
    p->base = 1;
    struct plc__welder w;
    struct plc__faces fs;
    memset(&w, 0, sizeof w);
    memset(&fs, 0, sizeof fs);
    uint32_t *c = NULL;
    size_t cap_c = 0;
    long nv = 0;
    int rc;
    while ((rc = textin_next(&t)) == 1) {
        char *kw = textin_word(&t);
        if (!strcmp(kw, "v")) {
            double x[3];
            if ((rc = textin_double(&t, "x coordinate", &x[0])) ||
                (rc = textin_double(&t, "y coordinate", &x[1])) ||
                (rc = textin_double(&t, "z coordinate", &x[2])))
                break;
            if (nv >= PLC_MAX_COUNT) {
                rc = textin_error(&t, "too many vertices");
                break;
            }
            if (plc__weld_vertex(p, &w, nv, x, t.line)) {
                rc = plc__oom(&t);
                break;
            }
            nv++;
        } else if (!strcmp(kw, "f") || !strcmp(kw, "fo")) {
            long line = t.line;
            uint32_t n = 0;
            char *cw;
            rc = 0;
            while ((cw = statement_word(&t, &rc)) != NULL) {
                if (plc__grow((void **)&c, &cap_c, (size_t)n + 1, sizeof *c)) {
                    rc = plc__oom(&t);
                    break;
                }
                if ((rc = corner_of(&t, cw, nv, &c[n])))
                    break;
                n++;
            }
            if (rc)
                break;
            if (n < 3) {
                rc = textin_error(&t, "a face needs at least 3 corners, not %u", n);
                break;
            }
            if (plc__faces_add(&fs, c, n, 0, line)) {
                rc = plc__oom(&t);
                break;
            }
        } else if (is_freeform(kw)) {
            rc = textin_error(&t, "free-form geometry ('%s') is not supported: export the "
                                  "surface as polygons", kw);
            break;
        } else {
            /* anything else: attributes, grouping, display; a statement
             * continued over lines is skipped whole */
            int rc2 = 0;
            while (statement_word(&t, &rc2))
                ;
            if ((rc = rc2))
                break;
        }
    }
    if (rc == 0 && fs.nface == 0) {
        pdr_diag_add(diag, path, 0, "the file has no faces ('f'): there is no surface to "
                                    "mesh");
        rc = PDR_EPARSE;
    }
    if (rc == 0)
        rc = plc__faces_commit(p, &fs, w.map, (size_t)nv, 1, path, diag);
    plc__faces_free(&fs);
    plc__welder_free(&w);
    pr_free(c);
    textin_close(&t);
    return rc;
}
