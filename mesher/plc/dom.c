/* plc/dom.c -- cube-in-cube, tee and sphere domains (see plc/dom.h). */
#include "config.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "base/hmap.h"
#include "plc/dom.h"

void dom_cube_defaults(dom_cube_opts *o)
{
    o->outer = 1.0;
    o->inner = 0.5;
}

void dom_tee_defaults(dom_tee_opts *o)
{
    o->length = 4.0;
    o->width = 1.0;
    o->height = 1.5;
    o->flange = 0.25;
    o->web = 0.125;
    o->angle = 60.0;
}

void dom_sphere_defaults(dom_sphere_opts *o)
{
    o->radius = 1.0;
    o->level = 4;
}

const char *dom_name(int kind)
{
    static const char *const names[DOM_COUNT] = {"cube-in-cube", "tee", "sphere"};
    return kind >= 0 && kind < DOM_COUNT ? names[kind] : NULL;
}

int dom_lookup(const char *name)
{
    for (int k = 0; k < DOM_COUNT; k++)
        if (!strcmp(name, dom_name(k)))
            return k;
    return -1;
}

int dom_build_default(plc *p, int kind, pdr_diag *diag)
{
    switch (kind) {
    case DOM_TEE: {
        dom_tee_opts o;
        dom_tee_defaults(&o);
        return dom_tee(p, &o, diag);
    }
    case DOM_SPHERE: {
        dom_sphere_opts o;
        dom_sphere_defaults(&o);
        return dom_sphere(p, &o, diag);
    }
    case DOM_CUBE_IN_CUBE: {
        dom_cube_opts o;
        dom_cube_defaults(&o);
        return dom_cube_in_cube(p, &o, diag);
    }
    default:
        return PDR_EINVAL;
    }
}

static int bad(pdr_diag *diag, const char *msg)
{
    pdr_diag_add(diag, NULL, 0, "%s", msg);
    return PDR_EINVAL;
}

/* Corners of an axis-aligned cube numbered x + 2y + 4z; faces listed
 * counterclockwise seen from outside. */
static const uint32_t cube_faces[6][4] = {
    {0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6},
};

static int add_cube(plc *p, double lo, double hi, int marker)
{
    uint32_t base = (uint32_t)p->nv, v[4];
    int rc;
    for (int i = 0; i < 8; i++) {
        double x[3] = {i & 1 ? hi : lo, i & 2 ? hi : lo, i & 4 ? hi : lo};
        if ((rc = plc_add_vertex(p, x, 0, NULL)))
            return rc;
    }
    for (int f = 0; f < 6; f++) {
        for (int k = 0; k < 4; k++)
            v[k] = base + cube_faces[f][k];
        if ((rc = plc_begin_facet(p, marker, 0)) || (rc = plc_add_polygon(p, v, 4, 0)))
            return rc;
    }
    return 0;
}

int dom_cube_in_cube(plc *p, const dom_cube_opts *o, pdr_diag *diag)
{
    if (!(o->outer > 0) || !isfinite(o->outer))
        return bad(diag, "the outer cube's side must be positive");
    if (!(o->inner > 0) || !(o->inner < o->outer))
        return bad(diag, "the void's side must be positive and smaller than the "
                         "outer cube's");
    double a = o->outer, lo = 0.5 * (a - o->inner), hi = 0.5 * (a + o->inner);
    int rc;
    if ((rc = add_cube(p, 0.0, a, 1)) || (rc = add_cube(p, lo, hi, 2)))
        return rc;
    double centre[3] = {0.5 * a, 0.5 * a, 0.5 * a};
    double material[3] = {0.5 * lo, 0.5 * a, 0.5 * a};
    if ((rc = plc_add_hole(p, centre, 0)) ||
        (rc = plc_add_region(p, material, 1.0, -1.0, 0)))
        return rc;
    return 0;
}

int dom_tee(plc *p, const dom_tee_opts *o, pdr_diag *diag)
{
    const double pi = 3.14159265358979323846;
    if (!(o->length > 0 && o->width > 0 && o->height > 0 && o->flange > 0 &&
          o->web > 0) ||
        !isfinite(o->length + o->width + o->height + o->flange + o->web))
        return bad(diag, "every tee dimension must be positive");
    if (!(o->angle > 0 && o->angle <= 90))
        return bad(diag, "the tee's angle must be in (0, 90] degrees");
    double c = o->angle == 90 ? 0.0 : 1.0 / tan(o->angle * pi / 180.0);
    if (!(o->flange < o->height))
        return bad(diag, "the flange must be thinner than the tee is high");
    if (!(o->web < o->width - o->flange * c))
        return bad(diag, "the web is too thick: the flange's bevel would cut "
                         "into it (need web < width - flange * cot(angle))");
    if (!(o->height * c < o->length))
        return bad(diag, "the tee is too short for its mitred end (need "
                         "length > height * cot(angle))");

    const double ys[6] = {0, o->width, o->width - o->flange * c, o->web, o->web, 0};
    const double zs[6] = {0, 0, o->flange, o->flange, o->height, o->height};
    int rc;
    for (int end = 0; end < 2; end++)
        for (int i = 0; i < 6; i++) {
            double x[3] = {end ? o->length - zs[i] * c : 0.0, ys[i], zs[i]};
            if ((rc = plc_add_vertex(p, x, 0, NULL)))
                return rc;
        }
    /* The start face is seen from outside (-x) clockwise in (y, z), the
     * end face counterclockwise; side i joins section edge i -> i+1. */
    uint32_t start[6] = {5, 4, 3, 2, 1, 0}, end[6] = {6, 7, 8, 9, 10, 11};
    if ((rc = plc_begin_facet(p, 1, 0)) || (rc = plc_add_polygon(p, start, 6, 0)) ||
        (rc = plc_begin_facet(p, 2, 0)) || (rc = plc_add_polygon(p, end, 6, 0)))
        return rc;
    for (uint32_t i = 0; i < 6; i++) {
        uint32_t j = (i + 1) % 6;
        uint32_t q[4] = {i, j, 6 + j, 6 + i};
        if ((rc = plc_begin_facet(p, 3 + (int)i, 0)) || (rc = plc_add_polygon(p, q, 4, 0)))
            return rc;
    }
    double inside[3] = {0.5 * o->length - 0.5 * o->height * c, 0.5 * o->web,
                        0.5 * (o->flange + o->height)};
    return plc_add_region(p, inside, 1.0, -1.0, 0);
}

/* ------------------------------------------------------------- sphere */

/* The icosphere under construction: unit-length vertices and triangles
 * (counterclockwise from outside), plus the midpoints of one level's
 * edges (edge key -> vertex). */
struct ico {
    double (*x)[3];
    size_t nv;
    uint32_t (*tri)[3];
    size_t ntri;
    hmap mid;
};

static uint32_t ico_vertex(struct ico *s, double x, double y, double z)
{
    double n = sqrt(x * x + y * y + z * z);
    s->x[s->nv][0] = x / n;
    s->x[s->nv][1] = y / n;
    s->x[s->nv][2] = z / n;
    return (uint32_t)s->nv++;
}

/* The vertex halfway along edge ab (made on first use), or HMAP_NONE when
 * out of memory. */
static uint32_t ico_midpoint(struct ico *s, uint32_t a, uint32_t b)
{
    uint64_t k = a < b ? ((uint64_t)a << 32 | b) + 1 : ((uint64_t)b << 32 | a) + 1;
    uint32_t v = hmap_get(&s->mid, k);
    if (v == HMAP_NONE) {
        const double *p = s->x[a], *q = s->x[b];
        v = ico_vertex(s, p[0] + q[0], p[1] + q[1], p[2] + q[2]);
        if (hmap_put(&s->mid, k, v))
            return HMAP_NONE;
    }
    return v;
}

int dom_sphere(plc *p, const dom_sphere_opts *o, pdr_diag *diag)
{
    if (!(o->radius > 0) || !isfinite(o->radius))
        return bad(diag, "the sphere's radius must be positive");
    if (o->level < 0 || o->level > 7)
        return bad(diag, "the sphere's level must be 0 to 7");
    /* V - E + F = 2 with E = 3F/2, F = 20 * 4^level */
    size_t nf = (size_t)20 << (2 * o->level), nv = nf / 2 + 2;
    struct ico s = {0};
    s.x = pr_malloc(nv * sizeof *s.x);
    s.tri = pr_malloc(nf * sizeof *s.tri);
    uint32_t(*next)[3] = pr_malloc(nf * sizeof *next);
    int rc = PDR_ENOMEM;
    if (!s.x || !s.tri || !next)
        goto done;
    const double t = (1.0 + sqrt(5.0)) / 2.0;
    const double ico_x[12][3] = {{-1, t, 0}, {1, t, 0},  {-1, -t, 0}, {1, -t, 0},
                                 {0, -1, t}, {0, 1, t},  {0, -1, -t}, {0, 1, -t},
                                 {t, 0, -1}, {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
    static const uint32_t ico_f[20][3] = {
        {0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
        {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
        {3, 8, 9},  {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
    for (int i = 0; i < 12; i++)
        ico_vertex(&s, ico_x[i][0], ico_x[i][1], ico_x[i][2]);
    memcpy(s.tri, ico_f, sizeof ico_f);
    s.ntri = 20;
    for (int l = 0; l < o->level; l++) {
        hmap_free(&s.mid); /* each level's edges are new */
        size_t n = 0;
        for (size_t f = 0; f < s.ntri; f++) {
            uint32_t a = s.tri[f][0], b = s.tri[f][1], c = s.tri[f][2];
            uint32_t ab = ico_midpoint(&s, a, b), bc = ico_midpoint(&s, b, c),
                     ca = ico_midpoint(&s, c, a);
            if (ab == HMAP_NONE || bc == HMAP_NONE || ca == HMAP_NONE)
                goto done;
            const uint32_t four[4][3] = {{a, ab, ca}, {b, bc, ab}, {c, ca, bc}, {ab, bc, ca}};
            memcpy(next[n], four, sizeof four);
            n += 4;
        }
        memcpy(s.tri, next, n * sizeof *next);
        s.ntri = n;
    }
    rc = 0;
    for (size_t v = 0; v < s.nv && !rc; v++) {
        double x[3] = {o->radius * s.x[v][0], o->radius * s.x[v][1], o->radius * s.x[v][2]};
        rc = plc_add_vertex(p, x, 0, NULL);
    }
    for (size_t f = 0; f < s.ntri && !rc; f++)
        if (!(rc = plc_begin_facet(p, 1, 0)))
            rc = plc_add_polygon(p, s.tri[f], 3, 0);
    if (!rc) {
        double centre[3] = {0, 0, 0};
        rc = plc_add_region(p, centre, 1.0, -1.0, 0);
    }
done:
    pr_free(s.x);
    pr_free(s.tri);
    pr_free(next);
    hmap_free(&s.mid);
    return rc;
}
