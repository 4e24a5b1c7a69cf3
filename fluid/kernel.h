/* kernel.h — the fused pull stream–collide step (the hot loop).
 *
 * One call advances the cells of a box (kernel_box_t below; all interior
 * cells without one) by one time step: each cell pulls
 * f_q from its neighbour at x - c_q in src (post-collision values of the
 * previous step, with ghost and solid neighbours already filled by the
 * boundary stage), collides with TRT (BGK when omega_minus == omega_plus)
 * including Guo forcing, and writes post-collision values to dst.
 * For whole rows the ghost columns are computed too (their values are never
 * read before the boundary stage overwrites them); this keeps every row
 * aligned for non-temporal stores. */
#ifndef FLUID_KERNEL_H
#define FLUID_KERNEL_H

#include "grid.h"

/* The cells one call updates: interior cells lo..hi (allocated coordinates,
 * inclusive). fluid.c updates a block's inner cells while its halo is in
 * flight and its outer layer afterwards (README "Several MPI ranks"). With
 * two arrays in double, rows that start and end on cache lines (lo[0] 1 or
 * a multiple of GRID_ALIGN, hi[0] n[0] or one less than a multiple) go
 * through the block path above; other parts of rows get ordinary stores.
 * NULL: every interior cell. */
typedef struct {
    int lo[3], hi[3];
} kernel_box_t;

typedef struct {
    double omega_plus;  /* 1/tau: sets the viscosity nu = (1/omega_plus - 1/2)/3 */
    double omega_minus; /* TRT: from the magic parameter; BGK: = omega_plus */
    double force[3];    /* body force per volume, lattice units (Guo et al. 2002) */
} kernel_params_t;

/* omega_minus for the magic parameter Lambda = (1/w+ - 1/2)(1/w- - 1/2)
 * (Ginzburg, Verhaeghe & d'Humieres, Commun. Comput. Phys. 3 (2008) 427). */
double kernel_omega_minus(double omega_plus, double magic);

void kernel_stream_collide(const grid_t *g, const kernel_params_t *p, const double *restrict src,
                           double *restrict dst, const kernel_box_t *box);
/* The in-place (AA) step on one array (layout.h): push = 0 the local kernel
 * (from the PUSHED state to SWAPPED), push = 1 the push kernel (SWAPPED to
 * PUSHED). */
void kernel_in_place(const grid_t *g, const kernel_params_t *p, double *f, int push, const kernel_box_t *box);
/* The same with single-precision storage (fluid.precision: single): every
 * value is f_q - w_q as a float, the arithmetic is in double (kernel.c). */
void kernel_stream_collide_f32(const grid_t *g, const kernel_params_t *p, const float *restrict src,
                               float *restrict dst, const kernel_box_t *box);
void kernel_in_place_f32(const grid_t *g, const kernel_params_t *p, float *f, int push, const kernel_box_t *box);

#endif
