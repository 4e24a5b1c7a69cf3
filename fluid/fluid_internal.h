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
#include "decomp.h"
#include "kernel.h"
#include "layout.h"
#include "spheres.h"
#include "walls.h"

#include <stdint.h>

enum { CELL_FLUID = 0, CELL_SOLID = 1, CELL_GHOST = 2 };

struct fluid {
    grid_t g;             /* this rank's block (the whole grid on one rank) */
    decomp_t d;
    units_t units;
    kernel_params_t kp;
    void *f[2];           /* two_array: both; in_place: f[0] only (f[1] NULL); double or float */
    int single;           /* fluid.precision single: float storage of f - w_q (layout.h) */
    int overlap;          /* several ranks: the inner update while the halo is in flight (fluid.c;
                           * AGGLO_OVERLAP=0 turns it off, for comparisons) */
    int cur;
    streaming_t streaming;
    layout_state_t layout; /* of f[cur] (layout.h) */
    uint8_t *flags;
    walls_t walls;
    spheres_t spheres;
    long step;
    double t0;
    log_t log;
    char *path; /* scene file, for messages */
};

/* The populations of f[cur] with the maps of its layout state. */
static inline pops_t fluid_pops(const fluid_t *fl)
{
    pops_t p;
    pops_init(&p, &fl->g, fl->f[fl->cur], fl->single, fl->layout);
    return p;
}

static inline int fluid_arrays(const fluid_t *fl) { return fl->streaming == STREAMING_TWO_ARRAY ? 2 : 1; }
static inline size_t fluid_value_bytes(const fluid_t *fl) { return fl->single ? sizeof(float) : sizeof(double); }

#endif
