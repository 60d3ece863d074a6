/*
 * plc/dom.h -- the paper's two model problems, and a tessellated sphere, as
 * PLCs (prefix dom_).
 *
 * cube-in-cube: the cube [0, outer]^3 with a cubical void of side inner
 *   centred in it (Nave et al., fig. 8a). The void's six facets are part of
 *   the PLC and a hole point at the centre empties it. Facet markers: 1 on
 *   the outer cube, 2 on the void. One region point (attribute 1) lies in
 *   the material.
 *
 * tee: a half-tee brace (fig. 8b), a T-section beam of length 'length'
 *   along x, cut in half along the web's symmetry plane y = 0. Its cross
 *   section in the (y, z) plane is the hexagon
 *       (0, 0) (width, 0) (width - flange * cot(angle), flange)
 *       (web, flange) (web, height) (0, height):
 *   a flange plate of half-width 'width' and thickness 'flange' whose outer
 *   edge is bevelled at 'angle', and a web of half-thickness 'web' rising
 *   to 'height'. The start x = 0 is square, the far end is mitred: it lies
 *   in the plane x = length - z * cot(angle). Both the bevel and the mitre
 *   meet the underside z = 0 at a dihedral angle of 'angle' degrees inside
 *   the solid (default 60), so the boundary has angles below 90 degrees,
 *   which the paper's initial-mesh construction cannot take without
 *   recovery. Facet markers: 1 start, 2 mitred end, 3 underside, 4 bevel,
 *   5 flange top, 6 web side, 7 web top, 8 symmetry plane. One region
 *   point (attribute 1) lies in the web.
 *
 * sphere: a ball of radius 'radius' centred at the origin, its surface an
 *   icosahedron whose triangles are split in four 'level' times with the
 *   new vertices pushed out to the sphere: 20 * 4^level triangles, each
 *   its own facet (marker 1), every edge a segment. Not a model problem of
 *   the paper: a stand-in for the tessellated curved surfaces of real
 *   inputs (many small facets meeting at nearly flat angles). One region
 *   point (attribute 1) at the centre.
 */
#ifndef PDR_DOMAIN_H
#define PDR_DOMAIN_H

#include "base/pdr_error.h"
#include "plc/plc.h"

typedef struct dom_cube_opts {
    double outer; /* side of the outer cube (default 1) */
    double inner; /* side of the void (default 0.5) */
} dom_cube_opts;

typedef struct dom_tee_opts {
    double length; /* along x (default 4) */
    double width;  /* flange half-width along y (default 1) */
    double height; /* total height along z (default 1.5) */
    double flange; /* flange thickness (default 0.25) */
    double web;    /* web half-thickness (default 0.125) */
    double angle;  /* bevel and mitre angle in degrees, (0, 90] (default 60) */
} dom_tee_opts;

typedef struct dom_sphere_opts {
    double radius; /* default 1 */
    int level;     /* subdivisions of the icosahedron, 0..7 (default 4) */
} dom_sphere_opts;

/* The domains by name, for the commands that take one. */
enum dom_kind { DOM_CUBE_IN_CUBE = 0, DOM_TEE = 1, DOM_SPHERE = 2, DOM_COUNT = 3 };
/* "cube-in-cube", "tee", "sphere"; NULL outside 0..DOM_COUNT-1. */
const char *dom_name(int kind);
/* The dom_kind named 'name', or -1. */
int dom_lookup(const char *name);
/* Builds domain 'kind' with its defaults (as the dom_* functions). */
int dom_build_default(plc *p, int kind, pdr_diag *diag);

void dom_cube_defaults(dom_cube_opts *o);
void dom_tee_defaults(dom_tee_opts *o);
void dom_sphere_defaults(dom_sphere_opts *o);

/* Build the domain into p, which must be freshly initialised. Invalid
 * dimensions give PDR_EINVAL with the reason in diag. */
int dom_cube_in_cube(plc *p, const dom_cube_opts *o, pdr_diag *diag);
int dom_tee(plc *p, const dom_tee_opts *o, pdr_diag *diag);
int dom_sphere(plc *p, const dom_sphere_opts *o, pdr_diag *diag);

#endif /* PDR_DOMAIN_H */
