/*
 * plc/plc_medit.c -- the reader of Medit's ASCII .mesh files (INRIA's
 * format, written by Gmsh, MMG, TetGen, CGAL and many FEM tools).
 *
 * The file is a sequence of keywords, each followed by its count and its
 * records; values are separated by any white space, lines included, and
 * '#' starts a comment. What is read:
 *  - "MeshVersionFormatted 1|2" (first) and "Dimension 3";
 *  - "Vertices": "x y z ref" (the reference is ignored);
 *  - "Triangles": "a b c ref" and "Quadrilaterals": "a b c d ref", with
 *    vertex numbers from 1: each a facet whose marker is its reference, so
 *    that a surface's boundary parts keep their numbers in the output's
 *    .face markers (the coplanar merge joins only faces with equal
 *    markers). Faces are mended as the other surface files
 *    (plc/plc_surf.c); vertices with equal coordinates are welded;
 *  - "End" (optional) ends the file.
 * Skipped with their records: Edges, Corners, Ridges, RequiredVertices,
 * RequiredEdges, RequiredTriangles, Tetrahedra, Hexahedra, Prisms,
 * Pyramids, Normals, NormalAtVertices, Tangents, TangentAtVertices. A volume mesh is read as its surface: its Triangles, not
 * its Tetrahedra. Refused with a message: any other keyword (how many
 * values would have to be skipped is unknown), "Dimension 2", and the
 * binary form .meshb (a different extension, not dispatched here).
 */
#include "config.h"

#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "pr_alloc.h"
#include "plc/plc.h"
#include "plc/plc_int.h"

/* Keywords whose records are skipped: values per record (-1: a string). */
static const struct {
    const char *name;
    int values;
} skipped[] = {
    {"Edges", 3},           {"Corners", 1},           {"Ridges", 1},
    {"RequiredVertices", 1}, {"RequiredEdges", 1},     {"RequiredTriangles", 1},
    {"Tetrahedra", 5},      {"Hexahedra", 9},         {"Prisms", 7},
    {"Pyramids", 6},        {"Normals", 3},           {"NormalAtVertices", 2},
    {"Tangents", 3},        {"TangentAtVertices", 2},
};

/* The next word, on this line or a following one; NULL at the end of the
 * file (*rc 0) or on a read error (*rc set). */
static char *next_word(textin *t, int *rc)
{
    *rc = 0;
    while (textin_at_eol(t)) {
        int r = textin_next(t);
        if (r != 1) {
            *rc = r < 0 ? r : 0;
            return NULL;
        }
    }
    return textin_word(t);
}

int plc__read_medit(plc *p, FILE *f, const char *path, pdr_diag *diag)
{
    textin t;
    textin_attach(&t, f, path, diag);
    p->base = 1;
    struct plc__welder wv;
    struct plc__faces fs;
    memset(&wv, 0, sizeof wv);
    memset(&fs, 0, sizeof fs);
    long nv = 0, version = 0, dim = 0;
    int rc = 0, first = 1, have_vertices = 0;
    char *w;
    while ((w = next_word(&t, &rc)) != NULL) {
        if (first && strcmp(w, "MeshVersionFormatted") != 0) {
            rc = textin_error(&t, "not a Medit mesh: it must start with "
                                  "'MeshVersionFormatted'");
            break;
        }
        first = 0;
        if (!strcmp(w, "End"))
            break;
        if (!strcmp(w, "MeshVersionFormatted")) {
            if ((rc = plc__record_long(&t, "the format version", 0, 4, &version)))
                break;
            if (version != 1 && version != 2) {
                rc = textin_error(&t, "MeshVersionFormatted %ld is not supported (1 or 2)",
                                  version);
                break;
            }
        } else if (!strcmp(w, "Dimension")) {
            if ((rc = plc__record_long(&t, "the dimension", 0, 1000, &dim)))
                break;
            if (dim != 3) {
                rc = textin_error(&t, "Dimension %ld: only 3D meshes can be read", dim);
                break;
            }
        } else if (!strcmp(w, "Vertices")) {
            long n;
            if (have_vertices) {
                rc = textin_error(&t, "a second 'Vertices' section");
                break;
            }
            have_vertices = 1;
            if ((rc = plc__record_long(&t, "the vertex count", 0, PLC_MAX_COUNT, &n)))
                break;
            for (long i = 0; i < n && !rc; i++) {
                double x[3], ref;
                if ((rc = plc__record_double(&t, "x coordinate", &x[0])) ||
                    (rc = plc__record_double(&t, "y coordinate", &x[1])) ||
                    (rc = plc__record_double(&t, "z coordinate", &x[2])) ||
                    (rc = plc__record_double(&t, "vertex reference", &ref)))
                    break;
                if (plc__weld_vertex(p, &wv, i, x, t.line))
                    rc = plc__oom(&t);
                nv = i + 1;
            }
        } else if (!strcmp(w, "Triangles") || !strcmp(w, "Quadrilaterals")) {
            uint32_t k = w[0] == 'T' ? 3 : 4;
            long n;
            if ((rc = plc__record_long(&t, "the face count", 0, PLC_MAX_COUNT, &n)))
                break;
            for (long i = 0; i < n && !rc; i++) {
                uint32_t c[4];
                long v, ref = 0, line = 0;
                for (uint32_t j = 0; j < k && !rc; j++) {
                    if (!(rc = plc__record_long(&t, "vertex number", 1, PLC_MAX_COUNT, &v)))
                        c[j] = (uint32_t)(v - 1);
                    line = t.line;
                }
                if (rc || (rc = plc__record_long(&t, "face reference", -2147483647L, 2147483647L,
                                          &ref)))
                    break;
                if (plc__faces_add(&fs, c, k, (int)ref, line))
                    rc = plc__oom(&t);
            }
        } else {
            size_t s = 0, ns = sizeof skipped / sizeof skipped[0];
            while (s < ns && strcmp(w, skipped[s].name) != 0)
                s++;
            if (s == ns) {
                rc = textin_error(&t, "unknown keyword '%s'", w);
                break;
            }
            long n;
            if ((rc = plc__record_long(&t, "the record count", 0, PLC_MAX_COUNT, &n)))
                break;
            for (long i = 0; i < n * skipped[s].values && !rc; i++) {
                double x;
                rc = plc__record_double(&t, skipped[s].name, &x);
            }
        }
        if (rc)
            break;
    }
    if (!rc && first) {
        pdr_diag_add(diag, path, 0, "empty file: expected 'MeshVersionFormatted'");
        rc = PDR_EPARSE;
    }
    if (!rc && fs.nface == 0) {
        pdr_diag_add(diag, path, 0, "no 'Triangles' or 'Quadrilaterals': there is no "
                                    "surface to mesh");
        rc = PDR_EPARSE;
    }
    if (!rc)
        rc = plc__faces_commit(p, &fs, wv.map, (size_t)nv, 1, path, diag);
    plc__faces_free(&fs);
    plc__welder_free(&wv);
    textin_close(&t);
    return rc;
}
