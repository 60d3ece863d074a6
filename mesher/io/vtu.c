/* io/vtu.c -- VTK XML UnstructuredGrid writer (see io/vtu.h). */
#include "config.h"

#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

#include "io/vtu.h"
#include "base/outfile.h"
#include "check/ql.h"

/* Streaming base64: bytes in, 76-column lines out. */
struct b64 {
    FILE *f;
    unsigned char pend[3];
    int npend;
    int col;
};

static const char b64chars[] =
    "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

static void b64_emit(struct b64 *b, const unsigned char *in, int n)
{
    char out[4];
    uint32_t v = (uint32_t)in[0] << 16 | (uint32_t)(n > 1 ? in[1] : 0) << 8 |
                 (n > 2 ? in[2] : 0);
    out[0] = b64chars[v >> 18 & 63];
    out[1] = b64chars[v >> 12 & 63];
    out[2] = n > 1 ? b64chars[v >> 6 & 63] : '=';
    out[3] = n > 2 ? b64chars[v & 63] : '=';
    fwrite(out, 1, 4, b->f);
    b->col += 4;
    if (b->col >= 76) {
        fputc('\n', b->f);
        b->col = 0;
    }
}

static void b64_put(struct b64 *b, const unsigned char *p, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        b->pend[b->npend++] = p[i];
        if (b->npend == 3) {
            b64_emit(b, b->pend, 3);
            b->npend = 0;
        }
    }
}

static void b64_end(struct b64 *b)
{
    if (b->npend)
        b64_emit(b, b->pend, b->npend);
    b->npend = 0;
}

static void le64(uint64_t v, unsigned char *o)
{
    for (int i = 0; i < 8; i++)
        o[i] = (unsigned char)(v >> (8 * i));
}

/* A typed array being written: the values are produced one at a time by
 * the caller through put_*; in binary mode the size header comes first,
 * encoded on its own. */
struct arr {
    FILE *f;
    int ascii;
    struct b64 b;
    size_t n; /* values written on the current ascii line */
};

static void arr_begin(struct arr *a, FILE *f, int ascii, const char *type,
                      const char *name, int ncomp, uint64_t nbytes)
{
    a->f = f;
    a->ascii = ascii;
    a->n = 0;
    fprintf(f, "        <DataArray type=\"%s\"", type);
    if (name)
        fprintf(f, " Name=\"%s\"", name);
    if (ncomp > 1)
        fprintf(f, " NumberOfComponents=\"%d\"", ncomp);
    fprintf(f, " format=\"%s\">\n", ascii ? "ascii" : "binary");
    if (!ascii) {
        unsigned char h[8];
        le64(nbytes, h);
        memset(&a->b, 0, sizeof a->b);
        a->b.f = f;
        b64_put(&a->b, h, 8);
        b64_end(&a->b);
    }
}

static void arr_sep(struct arr *a)
{
    if (++a->n == 12) {
        fputc('\n', a->f);
        a->n = 0;
    } else {
        fputc(' ', a->f);
    }
}

static void put_f64(struct arr *a, double v)
{
    if (a->ascii) {
        fprintf(a->f, "%.17g", v);
        arr_sep(a);
        return;
    }
    uint64_t bits;
    unsigned char o[8];
    memcpy(&bits, &v, sizeof bits);
    le64(bits, o);
    b64_put(&a->b, o, 8);
}

static void put_i64(struct arr *a, int64_t v)
{
    if (a->ascii) {
        fprintf(a->f, "%" PRId64, v);
        arr_sep(a);
        return;
    }
    unsigned char o[8];
    le64((uint64_t)v, o);
    b64_put(&a->b, o, 8);
}

static void put_i32(struct arr *a, int32_t v)
{
    if (a->ascii) {
        fprintf(a->f, "%" PRId32, v);
        arr_sep(a);
        return;
    }
    uint32_t u = (uint32_t)v;
    unsigned char o[4] = {(unsigned char)u, (unsigned char)(u >> 8),
                          (unsigned char)(u >> 16), (unsigned char)(u >> 24)};
    b64_put(&a->b, o, 4);
}

static void put_u8(struct arr *a, unsigned v)
{
    if (a->ascii) {
        fprintf(a->f, "%u", v);
        arr_sep(a);
        return;
    }
    unsigned char o = (unsigned char)v;
    b64_put(&a->b, &o, 1);
}

static void arr_end(struct arr *a)
{
    if (!a->ascii) {
        b64_end(&a->b);
        if (a->b.col)
            fputc('\n', a->f);
    } else if (a->n) {
        fputc('\n', a->f);
    }
    fprintf(a->f, "        </DataArray>\n");
}

int vtu_write(const mesh_export *m, const char *path, const vtu_opts *o, outset *set,
              pdr_diag *diag)
{
    vtu_opts def = {0, 0};
    if (!o)
        o = &def;
    outfile of;
    int rc = outfile_open_in(&of, set, path, diag);
    if (rc)
        return rc;
    FILE *f = of.f;
    int asc = o->ascii;
    struct arr a;
    fprintf(f, "<?xml version=\"1.0\"?>\n"
               "<!-- written by pdr %s -->\n"
               "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" "
               "byte_order=\"LittleEndian\" header_type=\"UInt64\">\n"
               "  <UnstructuredGrid>\n"
               "    <Piece NumberOfPoints=\"%zu\" NumberOfCells=\"%zu\">\n"
               "      <Points>\n",
            PACKAGE_VERSION, m->nv, m->nt);
    arr_begin(&a, f, asc, "Float64", "Points", 3, (uint64_t)m->nv * 24);
    for (size_t v = 0; v < m->nv; v++)
        for (int k = 0; k < 3; k++)
            put_f64(&a, m->xyz[v][k]);
    arr_end(&a);
    fprintf(f, "      </Points>\n      <Cells>\n");
    arr_begin(&a, f, asc, "Int64", "connectivity", 1, (uint64_t)m->nt * 32);
    for (size_t t = 0; t < m->nt; t++) {
        uint32_t v[4];
        mesh_export_tet(m, t, v);
        for (int k = 0; k < 4; k++)
            put_i64(&a, v[k]);
    }
    arr_end(&a);
    arr_begin(&a, f, asc, "Int64", "offsets", 1, (uint64_t)m->nt * 8);
    for (size_t t = 0; t < m->nt; t++)
        put_i64(&a, (int64_t)(4 * (t + 1)));
    arr_end(&a);
    arr_begin(&a, f, asc, "UInt8", "types", 1, (uint64_t)m->nt);
    for (size_t t = 0; t < m->nt; t++)
        put_u8(&a, 10); /* VTK_TETRA */
    arr_end(&a);
    fprintf(f, "      </Cells>\n");
    if (m->tet_region || o->radius_edge) {
        fprintf(f, "      <CellData>\n");
        if (m->tet_region) {
            arr_begin(&a, f, asc, "Int32", "region", 1, (uint64_t)m->nt * 4);
            for (size_t t = 0; t < m->nt; t++)
                put_i32(&a, m->tet_region[t]);
            arr_end(&a);
        }
        if (o->radius_edge) {
            arr_begin(&a, f, asc, "Float64", "radius_edge", 1, (uint64_t)m->nt * 8);
            for (size_t t = 0; t < m->nt; t++) {
                const uint32_t *v = m->tet[t];
                ql_tet q;
                ql_tet_measure(m->xyz[v[0]], m->xyz[v[1]], m->xyz[v[2]], m->xyz[v[3]],
                               &q);
                /* VTK readers choke on inf; a degenerate element gets a
                 * huge finite value instead. */
                put_f64(&a, q.radius_edge < 1e300 ? q.radius_edge : 1e300);
            }
            arr_end(&a);
        }
        fprintf(f, "      </CellData>\n");
    }
    fprintf(f, "    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n");
    return outfile_commit(&of, diag);
}
