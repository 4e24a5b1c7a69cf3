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

#include <stddef.h>
#include <stdint.h>

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

/* Cells the in-place update leaves alone, row by row: the cells inside the
 * spheres, whose values never reach a fluid cell (every population a fluid
 * cell takes from a solid one is written by a link first, and in place the
 * update of a cell reads and writes only the slots it owns in that step:
 * layout.h). Row r = (y - 1) + ny (z - 1) of the block's interior has the
 * runs run[start[r] .. start[r + 1]), each the first and the last x of a run
 * of such cells, increasing and apart (kernel_skip_build). */
typedef struct {
    int ny, nz;
    uint32_t *start;  /* ny nz + 1 */
    int32_t (*run)[2];
    int32_t (*tmp)[2]; /* kernel_skip_build's scratch: the runs given, row by row */
    size_t cap_run;
    long map;         /* the sphere map it was built for (spheres_t.maps) */
} kernel_skip_t;

typedef struct {
    double omega_plus;  /* 1/tau: sets the viscosity nu = (1/omega_plus - 1/2)/3 */
    double omega_minus; /* TRT: from the magic parameter; BGK: = omega_plus */
    double force[3];    /* body force per volume, lattice units (Guo et al. 2002) */
    const kernel_skip_t *skip; /* in place: the cells left alone (NULL: none; two arrays: ignored) */
} kernel_params_t;

/* The runs of k from nparts lists of runs (part p: nruns[p] runs of
 * interior row, first x, last x), which may overlap and come in any order:
 * 0 when out of memory (k is then empty, and a kernel given it updates
 * every cell). O(runs + rows): after every map that moved a sphere. */
int kernel_skip_build(kernel_skip_t *k, const grid_t *g, int nparts, const int32_t (*const *runs)[3],
                      const size_t *nruns);
void kernel_skip_free(kernel_skip_t *k);

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
