/* spheres_internal.h — what the sphere stages share inside the fluid
 * component: spheres.c (map, refill, fill, loads) and sphere_links.c (the
 * links and their film zone). Not part of the component's interface. */
#ifndef FLUID_SPHERES_INTERNAL_H
#define FLUID_SPHERES_INTERNAL_H

#include "lattice.h"
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

/* The ray x + t c_q, t in (0, 1], against a sphere of radius r whose
 * centre is at x - d, c = |d|^2 - r^2: its delta, 0 where it starts inside
 * or misses. Without a branch (the comparisons as bits, the square root of
 * a non-negative number: -fno-math-errno), so that rays side by side are
 * independent chains of a square root and a division, which the compiler
 * puts in vector registers and the core overlaps; where a ray hits, t is
 * the value of the root itself, as a ray at a time gives it (the same bits
 * in the links' build and in the fill, which derives delta from it). */
static inline __attribute__((always_inline)) double spheres_ray(const double d[3], double c, int q)
{
    const double b = d[0] * lb_cd[q][0] + d[1] * lb_cd[q][1] + d[2] * lb_cd[q][2];
    const double disc = b * b - lb_cc[q] * c;
    /* smaller root, written to avoid cancellation */
    const double t = c / (-b + sqrt(disc >= 0.0 ? disc : 0.0));
    const int hit = (c > 0.0) & (disc >= 0.0) & (b < 0.0) & (t > 0.0) & (t <= 1.0 + 1e-12);
    return hit ? (t < 1.0 ? t : 1.0) : 0.0;
}

/* The cell (unwrapped global coordinates) of a link's key (sphere_links.c
 * link_key). */
static inline void spheres_key_cell(uint64_t key, int X[3])
{
    X[0] = (int)(key >> 5 & 0xffff) - 32768;
    X[1] = (int)(key >> 21 & 0xffff) - 32768;
    X[2] = (int)(key >> 37) - 32768;
}

/* 1 when two links start at the same cell of the sphere's box (their keys
 * but for q): the links of a cell are consecutive in a list, and share its
 * ray origin (spheres_link_cell). Not the same as the same x_f: on a
 * periodic axis shorter than the box a cell is in it twice, as two images
 * (sphere_links.c others_find), each with links of its own geometry. */
static inline int spheres_same_cell(const sphere_link_t *a, const sphere_link_t *b)
{
    return a->key >> 5 == b->key >> 5;
}

/* delta of the rays x + t c_q, t in (0, 1], for q = qs[0..n), against a
 * sphere of radius r whose centre is at x - d (spheres_ray), side by side:
 * the links' build and refresh, and the fill. */
static inline __attribute__((always_inline)) void spheres_rays(const double d[3], const int *qs, int n, double r,
                                                               double *out)
{
    const double c = d[0] * d[0] + d[1] * d[1] + d[2] * d[2] - r * r;
#pragma omp simd
    for (int j = 0; j < n; j++) {
        out[j] = spheres_ray(d, c, qs[j]);
    }
}

/* A link's wall distance and wall point for its sphere p's centre, derived
 * from the link's cell and q (not kept in it: sphere_link_t). The link is
 * p's (the links' stage checked that no other sphere's ray from its cell
 * hits first), so delta is p's own ray (Eq. 5), or 1 where that ray only
 * touches the surface at t = 1 (its solid cell sits on it): what
 * sphere_links.c link_delta gives it. spheres_link_cell: the cell (key)
 * minus c_p, the same for all the links of a cell; spheres_link_delta: delta
 * from the ray (spheres_rays); spheres_wall_point: rw = x_f + delta c_q -
 * c_p. */
static inline void spheres_link_cell(const sphere_t *p, uint64_t key, double dk[3])
{
    int X[3];
    spheres_key_cell(key, X);
    for (int a = 0; a < 3; a++) {
        dk[a] = X[a] - p->c[a]; /* the box is about c_p: X - c_p, the image of c_p the link's ray hits */
    }
}

static inline double spheres_link_delta(double ray) { return ray > 0.0 ? ray : 1.0; }

static inline void spheres_wall_point(const double dk[3], double delta, int q, double rw[3])
{
    for (int a = 0; a < 3; a++) {
        rw[a] = dk[a] + delta * lb_cd[q][a];
    }
}

/* Fresh marks belong to the map that uncovered the cells: a list's cleared
 * by the next map that uncovers none near it. */
static inline void spheres_clear_fresh(link_list_t *list)
{
    if (list->fresh_set) {
        for (size_t n = 0; n < list->n; n++) {
            list->l[n].fresh = 0;
        }
        list->fresh_set = 0;
    }
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
