/* moments.h — the moments layout (fluid.streaming: moments): 10 doubles per
 * fluid cell instead of 19 populations.
 *
 * Storage (layout.h LAYOUT_MOMENTS):
 *   m      MOM_N arrays of stride cells (structure of arrays, moment k of
 *          cell x at m[k * stride + x]): for a fluid cell the moments of its
 *          post-collision populations of the last step: rho, j = sum c f~
 *          and A = sum c c f~ - rho/3 I (6), which fix them entirely,
 *          f~_q = w_q [rho + 3 c_q.j + 9/2 (c_q.A.c_q - tr A/3)]
 *          (the collision is regularized: kernel_moments.c);
 *   side   19 doubles per ghost or solid cell, f[e * 19 + q] for entry e;
 *   idx    per cell its entry (int32), -1 for a fluid cell. Ghost cells
 *          (every cell of the ghost layer: beyond a wall, a periodic face or
 *          another rank's face, whose fluid the halo exchange brings) have
 *          the entries 0 .. nghost - 1 for ever (in cell order); the
 *          cells inside the spheres nghost + j for the j-th of the spheres'
 *          solid list (spheres_t.solid), reassigned after every map that
 *          moved (moments_sync): a cell a sphere uncovers was refilled into
 *          its entry by the map (refill.c writes post slots) and takes its
 *          moments from there; a cell it covers gets the values rebuilt from
 *          its last moments. What a solid entry holds otherwise is never
 *          read before a link writes it in the step (layout.h).
 * The side store grows and shrinks with the spheres' volume.
 * Invariant between steps: m holds the post-collision moments of every
 * fluid cell; idx and flags agree (idx < 0 exactly for fluid cells). */
#ifndef FLUID_MOMENTS_H
#define FLUID_MOMENTS_H

#include "grid.h"
#include "kernel.h"
#include "layout.h"

#include <stddef.h>
#include <stdint.h>

struct spheres_s;

/* The kernel's copies per thread, doubles per cell of a plane: the 5
 * populations with c_z = +1 of two planes, the 9 with c_z = 0 of one and
 * the 5 with c_z = -1 of two (kernel_moments.c). */
enum { MOMENTS_PLANE_DOUBLES = 5 + 5 + 9 + 5 + 5 };

typedef struct {
    double *m;       /* MOM_N * stride */
    double *side;    /* LB_Q per entry, cap entries */
    int32_t *idx;    /* ncells */
    size_t nghost;   /* entries of the ghost cells (the first ones) */
    size_t nside;    /* entries in use: nghost + the solid cells */
    size_t cap;      /* entries allocated */
    long map;        /* the sphere map the solid entries belong to (spheres_t.maps) */
    uint8_t *row_fluid; /* per row (y, z) of the allocated grid: 1 when its interior cells are all fluid */
    double *planes;  /* the kernel's copies of old planes: MOMENTS_PLANE_DOUBLES per plane cell and thread */
    int nplanes;     /* threads the planes are allocated for */
} moments_t;

/* Allocates the store for grid g; every interior cell's moments are zero
 * and every entry zero until the caller writes them (pops_set_post). 0
 * when out of memory (then moments_free). */
int moments_create(moments_t *ms, const grid_t *g);
void moments_free(moments_t *ms);

/* The populations of the store (LAYOUT_MOMENTS). */
pops_t moments_pops(const moments_t *ms, const grid_t *g);

/* After a map of the spheres: the cells they uncovered take their moments
 * from their entries (where the refill wrote them), those they cover get
 * entries, holding the values rebuilt from their last moments. 0 when out
 * of memory for the side store (the store is then as before). */
int moments_sync(moments_t *ms, const grid_t *g, const struct spheres_s *sp);

/* row_fluid anew from idx (after moments_create, moments_sync and a
 * restored state). */
void moments_rows(moments_t *ms, const grid_t *g);

/* Bytes held now (the memory report of a live component). */
size_t moments_bytes(const moments_t *ms, const grid_t *g);

/* The fused pull stream and regularized collision with Guo forcing of every
 * fluid cell, in place (kernel_moments.c). 0 when out of memory for its
 * plane copies (nothing updated). */
int kernel_moments(const grid_t *g, const kernel_params_t *p, moments_t *ms);

#endif
