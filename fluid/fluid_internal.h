/* fluid_internal.h — the fluid component's state, shared by its own files.
 *
 * Invariant between steps: f[cur] holds the post-collision populations of
 * the last step for every interior cell. Ghost (and later solid) slots of
 * f[cur] are stale until the boundary stage fills exactly the slots that
 * interior cells pull from. Everything the component owns is reachable from
 * here, so that a state can be serialised without hidden parts. */
#ifndef FLUID_INTERNAL_H
#define FLUID_INTERNAL_H

#include "fluid.h"
#include "grid.h"
#include "kernel.h"
#include "spheres.h"
#include "walls.h"

#include <stdint.h>

enum { CELL_FLUID = 0, CELL_SOLID = 1, CELL_GHOST = 2 };

struct fluid {
    grid_t g;
    units_t units;
    kernel_params_t kp;
    double *f[2];
    int cur;
    uint8_t *flags;
    walls_t walls;
    spheres_t spheres;
    long step;
    double t0;
    log_t log;
    char *path; /* scene file, for messages */
};

#endif
