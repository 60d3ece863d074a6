/*
 * plc/plc_ply.c -- the PLY reader (Stanford polygon files, as scanners,
 * MeshLab, Blender and most point-cloud tools write them): ASCII, binary
 * little-endian and binary big-endian, format version 1.0.
 *
 * What is read:
 *  - the element "vertex": its properties x, y and z, of any of PLY's
 *    numeric types (char/int8 ... double/float64); other scalar or list
 *    properties (normals, colours, confidence) are skipped;
 *  - the element "face": its list property "vertex_indices" (or
 *    "vertex_index", as some writers name it), 0-based; other properties
 *    are skipped. Each face is a facet with marker 0, mended as the other
 *    surface files (plc/plc_surf.c: repeated corners, non-planar
 *    polygons cut into triangles); vertices with equal coordinates are
 *    welded, and messages keep the file's vertex numbers;
 *  - every other element (edge, material, ...) is skipped whole.
 * Header lines that start with no keyword of the format are taken as
 * comments, as some writers put free text there. The faces must follow
 * the vertices in the file. A file without faces (a
 * point cloud) is refused with a message that says so: it has no surface
 * to mesh. ASCII data is read as whitespace-separated values, an element
 * per line by convention but not required; messages say "file:line". In
 * binary files messages say which element and item ("face 12").
 */
#include "config.h"

#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "pr_alloc.h"
#include "plc/plc.h"
#include "plc/plc_int.h"

enum ply_type { PLY_NONE, PLY_I8, PLY_U8, PLY_I16, PLY_U16, PLY_I32, PLY_U32, PLY_F32, PLY_F64 };
enum ply_format { PLY_ASCII, PLY_LE, PLY_BE };

#define PLY_MAX_ELEMS 32
#define PLY_MAX_PROPS 64
#define PLY_NAME 48

typedef struct ply_prop {
    char name[PLY_NAME];
    int type;       /* of the value, or of the list's items */
    int count_type; /* of a list's count; PLY_NONE for a scalar */
    int role;       /* what the reader does with it: enum below */
} ply_prop;
enum { ROLE_SKIP, ROLE_X, ROLE_Y, ROLE_Z, ROLE_CORNERS };

typedef struct ply_elem {
    char name[PLY_NAME];
    long count;
    int nprop;
    ply_prop prop[PLY_MAX_PROPS];
} ply_elem;

typedef struct ply_in {
    plc *p;
    FILE *f;
    const char *path;
    pdr_diag *diag;
    textin t; /* the header, and ASCII data */
    int format;
    int nelem;
    ply_elem elem[PLY_MAX_ELEMS];
    /* where binary data is: element name and item, for messages */
    const char *where;
    long item;
} ply_in;

static const struct {
    const char *name;
    int type;
} ply_types[] = {
    {"char", PLY_I8},    {"int8", PLY_I8},     {"uchar", PLY_U8},  {"uint8", PLY_U8},
    {"short", PLY_I16},  {"int16", PLY_I16},   {"ushort", PLY_U16}, {"uint16", PLY_U16},
    {"int", PLY_I32},    {"int32", PLY_I32},   {"uint", PLY_U32},  {"uint32", PLY_U32},
    {"float", PLY_F32},  {"float32", PLY_F32}, {"double", PLY_F64}, {"float64", PLY_F64},
};

static int type_of(const char *w)
{
    for (size_t i = 0; w && i < sizeof ply_types / sizeof ply_types[0]; i++)
        if (!strcmp(w, ply_types[i].name))
            return ply_types[i].type;
    return PLY_NONE;
}

static int is_integer_type(int type)
{
    return type != PLY_F32 && type != PLY_F64;
}

static int copy_name(ply_in *in, char dst[PLY_NAME], const char *w, const char *what)
{
    if (!w)
        return textin_error(&in->t, "%s: a name is missing", what);
    if (strlen(w) >= PLY_NAME)
        return textin_error(&in->t, "%s name '%.20s...' is too long", what, w);
    strcpy(dst, w);
    return 0;
}

/* ------------------------------------------------------------------ header */

static int read_property(ply_in *in)
{
    ply_elem *e = &in->elem[in->nelem - 1];
    if (e->nprop == PLY_MAX_PROPS)
        return textin_error(&in->t, "element '%s' has more than %d properties", e->name,
                            PLY_MAX_PROPS);
    ply_prop *q = &e->prop[e->nprop];
    memset(q, 0, sizeof *q);
    char *w = textin_word(&in->t);
    if (w && !strcmp(w, "list")) {
        char *ct = textin_word(&in->t), *it = textin_word(&in->t);
        q->count_type = type_of(ct);
        q->type = type_of(it);
        if (q->count_type == PLY_NONE || !is_integer_type(q->count_type))
            return textin_error(&in->t, "a list's count type must be an integer type, "
                                        "not '%s'", ct ? ct : "(none)");
        if (q->type == PLY_NONE)
            return textin_error(&in->t, "unknown property type '%s'", it ? it : "(none)");
    } else {
        q->type = type_of(w);
        if (q->type == PLY_NONE)
            return textin_error(&in->t, "unknown property type '%s'", w ? w : "(none)");
    }
    int rc = copy_name(in, q->name, textin_word(&in->t), "property");
    if (rc || (rc = plc__expect_eol(&in->t, "the property")))
        return rc;
    e->nprop++;
    return 0;
}

static int read_header(ply_in *in)
{
    textin *t = &in->t;
    int rc = textin_next_raw(t, 1);
    if (rc < 0)
        return rc;
    char *first = rc == 1 ? textin_word(t) : NULL;
    if (!first || strcmp(first, "ply") != 0 || !textin_at_eol(t))
        return textin_error(t, "not a PLY file: it must start with the line 'ply'");
    int have_format = 0;
    for (;;) {
        if ((rc = textin_next_raw(t, 1)) != 1)
            return rc < 0 ? rc : textin_error(t, "unexpected end of file in the header "
                                                 "(no 'end_header')");
        char *w = textin_word(t);
        if (!strcmp(w, "comment") || !strcmp(w, "obj_info"))
            continue;
        if (!strcmp(w, "end_header"))
            break;
        if (!strcmp(w, "format")) {
            char *f = textin_word(t), *v = textin_word(t);
            if (f && !strcmp(f, "ascii"))
                in->format = PLY_ASCII;
            else if (f && !strcmp(f, "binary_little_endian"))
                in->format = PLY_LE;
            else if (f && !strcmp(f, "binary_big_endian"))
                in->format = PLY_BE;
            else
                return textin_error(t, "unknown PLY format '%s' (ascii, "
                                       "binary_little_endian or binary_big_endian)",
                                    f ? f : "(none)");
            if (!v || strcmp(v, "1.0") != 0)
                return textin_error(t, "PLY version '%s' is not supported (1.0)",
                                    v ? v : "(none)");
            if ((rc = plc__expect_eol(t, "the format")))
                return rc;
            have_format = 1;
        } else if (!strcmp(w, "element")) {
            if (in->nelem == PLY_MAX_ELEMS)
                return textin_error(t, "more than %d elements", PLY_MAX_ELEMS);
            ply_elem *e = &in->elem[in->nelem];
            memset(e, 0, sizeof *e);
            if ((rc = copy_name(in, e->name, textin_word(t), "element")) ||
                (rc = textin_long(t, "element count", 0, PLC_MAX_COUNT, &e->count)) ||
                (rc = plc__expect_eol(t, "the element")))
                return rc;
            in->nelem++;
        } else if (!strcmp(w, "property")) {
            if (!in->nelem)
                return textin_error(t, "a property before any element");
            if ((rc = read_property(in)))
                return rc;
        }
        /* Anything else is taken as a comment: old writers (Blender 2.4)
         * put free text in the header without the keyword. */
    }
    if (!have_format)
        return textin_error(t, "the header has no 'format' line");
    return 0;
}

/* Finds the vertex and face elements and gives their properties roles. */
static int assign_roles(ply_in *in, int *ev, int *ef)
{
    *ev = *ef = -1;
    for (int i = 0; i < in->nelem; i++) {
        if (!strcmp(in->elem[i].name, "vertex") && *ev < 0)
            *ev = i;
        else if (!strcmp(in->elem[i].name, "face") && *ef < 0)
            *ef = i;
    }
    if (*ev < 0)
        return textin_error(&in->t, "the header declares no 'vertex' element");
    if (*ef < 0 || in->elem[*ef].count == 0)
        return textin_error(&in->t, "the file has no faces (a point cloud?): there is no "
                                    "surface to mesh");
    if (*ef < *ev)
        return textin_error(&in->t, "the 'face' element comes before the 'vertex' "
                                    "element; this reader needs the vertices first");
    ply_elem *v = &in->elem[*ev], *f = &in->elem[*ef];
    int seen[3] = {0, 0, 0};
    for (int k = 0; k < v->nprop; k++) {
        ply_prop *q = &v->prop[k];
        int axis = !strcmp(q->name, "x") ? 0 : !strcmp(q->name, "y") ? 1
                                           : !strcmp(q->name, "z") ? 2 : -1;
        if (axis < 0 || q->count_type != PLY_NONE || seen[axis])
            continue;
        seen[axis] = 1;
        q->role = ROLE_X + axis;
    }
    if (!seen[0] || !seen[1] || !seen[2])
        return textin_error(&in->t, "the 'vertex' element lacks a property x, y or z");
    int corners = 0;
    for (int k = 0; k < f->nprop; k++) {
        ply_prop *q = &f->prop[k];
        if (corners || q->count_type == PLY_NONE || !is_integer_type(q->type) ||
            (strcmp(q->name, "vertex_indices") && strcmp(q->name, "vertex_index")))
            continue;
        q->role = ROLE_CORNERS;
        corners = 1;
    }
    if (!corners)
        return textin_error(&in->t, "the 'face' element has no integer list property "
                                    "'vertex_indices'");
    return 0;
}

/* -------------------------------------------------------------------- data */

/* An error in the data: "file:line: ..." in ASCII files, "file: face 12:
 * ..." in binary ones. Returns PDR_EPARSE. */
static int data_error(ply_in *in, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static int data_error(ply_in *in, const char *fmt, ...)
{
    char msg[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (in->format == PLY_ASCII)
        return textin_error(&in->t, "%s", msg);
    pdr_diag_add(in->diag, in->path, 0, "%s %ld: %s", in->where, in->item, msg);
    return PDR_EPARSE;
}

static int binary_value(ply_in *in, int type, double *out)
{
    static const int size[] = {0, 1, 1, 2, 2, 4, 4, 4, 8};
    unsigned char b[8];
    int n = size[type];
    if (fread(b, 1, (size_t)n, in->f) != (size_t)n)
        return data_error(in, "unexpected end of file");
    uint64_t u = 0;
    for (int i = 0; i < n; i++)
        u |= (uint64_t)b[in->format == PLY_LE ? i : n - 1 - i] << (8 * i);
    switch (type) {
    case PLY_I8: *out = (int8_t)u; break;
    case PLY_U8: *out = (uint8_t)u; break;
    case PLY_I16: *out = (int16_t)u; break;
    case PLY_U16: *out = (uint16_t)u; break;
    case PLY_I32: *out = (int32_t)u; break;
    case PLY_U32: *out = (uint32_t)u; break;
    case PLY_F32: {
        uint32_t w = (uint32_t)u;
        float x;
        memcpy(&x, &w, sizeof x);
        *out = x;
        break;
    }
    default: {
        double x;
        memcpy(&x, &u, sizeof x);
        *out = x;
    }
    }
    return 0;
}

/* The next value of an item: ASCII values may continue on the next line. */
static int next_value(ply_in *in, int type, const char *what, double *out)
{
    if (in->format != PLY_ASCII)
        return binary_value(in, type, out);
    if (is_integer_type(type)) {
        long v;
        int rc = plc__record_long(&in->t, what, -2147483648L, 4294967295L, &v);
        if (!rc)
            *out = (double)v;
        return rc;
    }
    return plc__record_double(&in->t, what, out);
}

/* The count of a list: an integer in [0, max]. */
static int list_count(ply_in *in, const ply_prop *q, long max, long *n)
{
    double c;
    int rc = next_value(in, q->count_type, "list count", &c);
    if (rc)
        return rc;
    if (!(c >= 0 && c <= (double)max))
        return data_error(in, "list count %.0f is out of range", c);
    *n = (long)c;
    return 0;
}

/* Skips property q of the current item. */
static int skip_property(ply_in *in, const ply_prop *q)
{
    double x;
    long n = 1;
    int rc = 0;
    if (q->count_type != PLY_NONE)
        rc = list_count(in, q, PLC_MAX_COUNT, &n);
    for (long i = 0; i < n && !rc; i++)
        rc = next_value(in, q->type, "property value", &x);
    return rc;
}

/* Skips a whole element (one that is neither vertex nor face). */
static int skip_element(ply_in *in, const ply_elem *e)
{
    if (e->nprop == 0)
        return 0; /* items without properties take no room */
    in->where = e->name;
    for (long i = 0; i < e->count; i++) {
        in->item = i;
        for (int k = 0; k < e->nprop; k++) {
            int rc = skip_property(in, &e->prop[k]);
            if (rc)
                return rc;
        }
    }
    return 0;
}

typedef struct ply_read {
    struct plc__welder w; /* file vertex -> plc vertex */
    uint32_t *c; /* a face's corners */
    size_t cap_c;
    long nv; /* vertices in the file */
} ply_read;

static int read_vertices(ply_in *in, const ply_elem *e, ply_read *r)
{
    plc *p = in->p;
    in->where = "vertex";
    r->nv = e->count;
    for (long i = 0; i < e->count; i++) {
        in->item = i;
        double x[3] = {0, 0, 0};
        for (int k = 0; k < e->nprop; k++) {
            const ply_prop *q = &e->prop[k];
            int rc = q->role == ROLE_SKIP ? skip_property(in, q)
                                          : next_value(in, q->type, "coordinate",
                                                       &x[q->role - ROLE_X]);
            if (rc)
                return rc;
        }
        if (!isfinite(x[0]) || !isfinite(x[1]) || !isfinite(x[2]))
            return data_error(in, "a coordinate is not finite");
        if (plc__weld_vertex(p, &r->w, i, x, in->format == PLY_ASCII ? in->t.line : 0))
            return PDR_ENOMEM;
    }
    return 0;
}

static int read_faces(ply_in *in, const ply_elem *e, ply_read *r)
{
    plc *p = in->p;
    double tol = plc__surface_tol(p);
    in->where = "face";
    for (long i = 0; i < e->count; i++) {
        in->item = i;
        long line = 0, n = -1;
        for (int k = 0; k < e->nprop; k++) {
            const ply_prop *q = &e->prop[k];
            int rc;
            if (q->role != ROLE_CORNERS) {
                if ((rc = skip_property(in, q)))
                    return rc;
                continue;
            }
            if ((rc = list_count(in, q, PLC_MAX_COUNT, &n)))
                return rc;
            if (in->format == PLY_ASCII)
                line = in->t.line;
            for (long j = 0; j < n; j++) {
                double v;
                if ((rc = next_value(in, q->type, "vertex index", &v)))
                    return rc;
                if (!(v >= 0 && v < (double)r->nv))
                    return data_error(in, "vertex index %.0f is out of range [0, %ld]", v,
                                      r->nv - 1);
                if (plc__grow((void **)&r->c, &r->cap_c, (size_t)j + 1, sizeof *r->c))
                    return PDR_ENOMEM;
                r->c[j] = r->w.map[(long)v];
            }
        }
        if (n < 3)
            return data_error(in, "a face needs at least 3 corners, not %ld", n);
        if (plc__add_surface_face(p, r->c, (uint32_t)n, line, tol))
            return PDR_ENOMEM;
    }
    return 0;
}

int plc__read_ply(plc *p, FILE *f, const char *path, pdr_diag *diag)
{
    ply_in *in = pr_calloc(1, sizeof *in);
    if (!in) {
        pdr_diag_add(diag, path, 0, "out of memory");
        return PDR_ENOMEM;
    }
    in->p = p;
    in->f = f;
    in->path = path;
    in->diag = diag;
    textin_attach(&in->t, f, path, diag);
    p->base = 0;
    ply_read r;
    memset(&r, 0, sizeof r);
    int ev, ef, rc = read_header(in);
    if (!rc)
        rc = assign_roles(in, &ev, &ef);
    for (int i = 0; i < in->nelem && !rc; i++) {
        if (i == ev)
            rc = read_vertices(in, &in->elem[i], &r);
        else if (i == ef)
            rc = read_faces(in, &in->elem[i], &r);
        else
            rc = skip_element(in, &in->elem[i]);
    }
    if (!rc && in->format == PLY_ASCII) {
        if (!textin_at_eol(&in->t) || textin_next(&in->t) == 1)
            rc = textin_error(&in->t, "unexpected data after the last element");
    } else if (!rc && getc(f) != EOF) {
        pdr_diag_add(diag, path, 0, "unexpected data after the last element (do the "
                                    "header's types match the data?)");
        rc = PDR_EPARSE;
    }
    if (rc == PDR_ENOMEM)
        pdr_diag_add(diag, path, in->format == PLY_ASCII ? in->t.line : 0, "out of memory");
    plc__welder_free(&r.w);
    pr_free(r.c);
    textin_close(&in->t);
    pr_free(in);
    return rc;
}
