/* spheres_internal.h — what the sphere stages share inside the fluid
 * component: spheres.c (map, refill, fill, loads) and sphere_links.c (the
 * links and their film zone). Not part of the component's interface. */
#ifndef FLUID_SPHERES_INTERNAL_H
#define FLUID_SPHERES_INTERNAL_H

#include "spheres.h"

#include <math.h>
#include <stdlib.h>

/* Grows *p (capacity *cap elements of elem bytes) to hold need: 0 when out
 * of memory (*p is kept). */
static inline int spheres_grow(void **p, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap) {
        return 1;
    }
    size_t nc = *cap ? *cap : 256;
    while (nc < need) {
        nc *= 2;
    }
    void *np = realloc(*p, nc * elem);
    if (np == NULL) {
        return 0;
    }
    *p = np;
    *cap = nc;
    return 1;
}

/* The cells x of a row within w of c along it, and a cell more on each
 * side (for the rounding; the caller's own test decides), clamped to
 * [lo, hi]: the part of a sphere's box a row scan need visit. */
static inline void spheres_row_span(double c, double w, int lo, int hi, int *x0, int *x1)
{
    *x0 = (int)fmax(floor(c - w) - 1.0, lo);
    *x1 = (int)fmin(ceil(c + w) + 1.0, hi);
}

/* Minimum-image difference a - b (global lattice coordinates) on the
 * periodic axes of the whole grid. */
static inline void spheres_min_image(const spheres_t *sp, const double a[3], const double b[3], double d[3])
{
    for (int k = 0; k < 3; k++) {
        d[k] = a[k] - b[k];
        if (sp->periodic[k]) {
            d[k] -= sp->N[k] * floor(d[k] / sp->N[k] + 0.5);
        }
    }
}

static inline void spheres_cross(const double a[3], const double b[3], double c[3])
{
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

/* The sphere whose surface is nearest to point x (global coordinates), and x
 * minus its centre (minimum image). */
int spheres_nearest(const spheres_t *sp, const double x[3], double d_out[3]);

/* The links of a list that keep a pre-collision pair: their count, and
 * their records (key order) copied to out unless NULL (sphere_links.c). */
size_t spheres_list_pairs(const link_list_t *list, unsigned char *out);

/* Every sphere's links for the current flags (sphere_links.c), in parallel
 * over spheres. keep: the lists were built for the flags before this map's
 * changes, which sp->changed lists (one rank): the lists of the spheres
 * within reach of a changed cell, or whose box moved, are built anew and
 * the others refreshed in place (their links' geometry for the spheres' new
 * places); all are built anew if a link changed hands where that cannot be
 * followed. */
status_t spheres_build_links(spheres_t *sp, const grid_t *g, uint8_t *flags, int keep, const log_t *log);

#endif
