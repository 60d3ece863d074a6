/* domain.c -- cube-in-cube and tee model problems (see domain.h). */
#include "config.h"

#include <math.h>

#include "domain.h"

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
