/*
 * refine/refine.c -- the mesher object of refine/refine.h: options, set-up
 * and release. The work itself is in the other refine_*.c files (the
 * decision, the boundary updates, the insertion loop, classification and
 * export; refine/refine_int.h lists what they share); this file is the one
 * place that knows every piece of memory a ref_mesher owns.
 */
#include "config.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pr_alloc.h"
#include "plc/fm.h"
#include "refine/refine_int.h"

/* ------------------------------------------------------------- set-up */

void ref_default_opts(ref_opts *o)
{
    memset(o, 0, sizeof *o);
    o->ratio = 2.0;
    o->min_dihedral = 10.0;
    o->rho = 1.0 / (2.0 * sqrt(2.0));
    o->use_region_maxvol = 1;
    o->order = REF_ORDER_LIFO;
}

size_t ref_point_limit(const plc *p, const ref_opts *o)
{
    double n = REF_LIMIT_BASE + REF_LIMIT_PER_INPUT * (double)(p->nv + p->nseg + p->nfacet);
    double box = 1;
    for (int k = 0; k < 3; k++)
        box *= p->bbox[1][k] - p->bbox[0][k];
    /* The largest tetrahedron volume the size bounds allow. */
    double v = o->maxvol > 0 ? o->maxvol : INFINITY;
    if (o->maxedge > 0)
        v = fmin(v, o->maxedge * o->maxedge * o->maxedge / (6.0 * M_SQRT2));
    if (o->use_region_maxvol)
        for (size_t i = 0; i < p->nregion; i++)
            if (p->regions[i].maxvol > 0)
                v = fmin(v, p->regions[i].maxvol);
    if (isfinite(v) && v > 0 && box > 0)
        n += REF_LIMIT_PER_SIZE * box / v;
    return n < 4e9 ? (size_t)n : (size_t)4e9;
}

int ref_init(ref_mesher *r, const plc *p, const ref_opts *o)
{
    memset(r, 0, sizeof *r);
    r->p = p;
    if (o)
        r->o = *o;
    else
        ref_default_opts(&r->o);
    r->keep_stuck = r->o.keep_stuck != 0;
    r->b2 = r->o.ratio > 0 ? r->o.ratio * r->o.ratio : 0.0;
    r->sin_min = r->o.min_dihedral > 0 ? sin(r->o.min_dihedral * M_PI / 180.0) : 0.0;
    double d2 = 0;
    for (int k = 0; k < 3; k++)
        d2 += (p->bbox[1][k] - p->bbox[0][k]) * (p->bbox[1][k] - p->bbox[0][k]);
    r->min_spacing = REF_MIN_SPACING * sqrt(d2);
    bd_init(&r->bd);
    dt_cavity_init(&r->cav);
    int rc = tm_init(&r->m, TM_FEAT_MARKERS);
    if (rc)
        return rc;
    if (p->nregion) {
        rc = ref_region_room(r);
        if (rc) {
            ref_free(r);
            return rc;
        }
    }
    if (r->o.constrained && p->v_minang) {
        r->fac_needle = pr_calloc(p->nfacet ? p->nfacet : 1, 1);
        if (!r->fac_needle) {
            ref_free(r);
            return PDR_ENOMEM;
        }
        for (size_t v = 0; v < p->nv; v++)
            if (p->v_minang[v] < FM_NEEDLE_ANG)
                for (size_t i = p->v_fstart[v]; i < p->v_fstart[v + 1]; i++)
                    r->fac_needle[p->v_facets[i]] = 1;
    }
    return 0;
}

void ref_free(ref_mesher *r)
{
    ref_release_work(r);
    tm_free(&r->m);
    bd_free(&r->bd);
    pr_free(r->region);
    pr_free(r->seg_acute);
    pr_free(r->corner_steps);
    hmap_free(&r->flat_made);
    hmap_free(&r->flat_tries);
    pr_free(r->leftover);
    pr_free(r->fac_needle);
    pr_free(r->bflag);
    pr_free(r->breg);
    pr_free(r->list);
    pr_free(r->bedge);
    pr_free(r->miss);
    memset(r, 0, sizeof *r);
}

void ref_release_work(ref_mesher *r)
{
    dt_cavity_free(&r->cav);
    ref_marks_free(&r->marks);
    ref__queue_free(&r->segq);
    ref__queue_free(&r->facq);
    ref__queue_free(&r->tetq);
    ref__queue_free(&r->tetq_local);
    pr_free(r->flipped.tets);
    pr_free(r->flipped.stuck_faces);
    memset(&r->flipped, 0, sizeof r->flipped);
}

int ref_region_room(ref_mesher *r)
{
    if (!r->p->nregion || r->region_cap >= r->m.tcap)
        return 0;
    size_t c = r->m.tcap;
    uint16_t *g = pr_realloc(r->region, c * sizeof *g);
    if (!g)
        return PDR_ENOMEM;
    memset(g + r->region_cap, 0, (c - r->region_cap) * sizeof *g);
    r->region = g;
    r->region_cap = c;
    return 0;
}
