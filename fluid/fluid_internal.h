/* fluid_internal.h — the fluid component's state, shared by its own files.
 *
 * Invariant between steps: f[cur] holds the post-collision populations of
 * the last step for every interior cell (the moments layout: mom holds
 * their moments, moments.h). Ghost (and later solid) slots of
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
#include "moments.h"
#include "spheres.h"
#include "walls.h"

#include <stdint.h>

enum { CELL_FLUID = 0, CELL_SOLID = 1, CELL_GHOST = 2 };

/* The spheres' stages beside the update (step.c): AGGLO_SPHERE_OVERLAP=0
 * never, =1 wherever it applies, otherwise (auto) where it is measured to
 * be faster. */
enum { SOV_OFF, SOV_ON, SOV_AUTO };
typedef struct {
    int mode;
    uint8_t *plane;           /* per z plane (1..n): within reach of a sphere this step */
    kernel_box_t *far, *near; /* the far planes in chunks, the near ones in runs */
    int nfar, nnear;
    long cycle;               /* auto: timed steps into the cycle of probes and runs (step.c) */
    double probe[2];          /* auto: time of the probe's steps in sequence, beside (s) */
    int pick;                 /* auto: 1 when the last probe found beside faster */
    long steps_beside;        /* steps run with the spheres beside the update */
} sphere_overlap_t;

struct fluid {
    grid_t g;             /* this rank's block (the whole grid on one rank) */
    decomp_t d;
    units_t units;
    kernel_params_t kp;
    void *f[2];           /* two_array: both; in_place: f[0] only (f[1] NULL); double or float; moments: none */
    moments_t mom;        /* moments: the store (moments.h) */
    int single;           /* fluid.precision single: float storage of f - w_q (layout.h) */
    int overlap;          /* several ranks: the inner update while the halo is in flight (fluid.c;
                           * AGGLO_OVERLAP=0 turns it off, for comparisons) */
    int cur;
    streaming_t streaming;
    layout_state_t layout; /* of f[cur] (layout.h) */
    uint8_t *flags; /* two cells to a byte: cellflags_get / cellflags_set (cellflags.h) */
    walls_t walls;
    spheres_t spheres;
    sphere_overlap_t sov;
    /* in place: the update leaves the cells inside the spheres alone
     * (kernel.h kernel_skip_t; AGGLO_SKIP_SOLID=0 turns it off, for
     * comparisons); skip holds their runs, rebuilt after a map that moved */
    int skip_on;
    kernel_skip_t skip;
    long step;
    long exchange_steps; /* LBM steps per communication step (fluid_set_exchange_steps; 0 or 1: one) */
    double t0;
    log_t log;
    char *path; /* scene file, for messages */
};

/* The head of a saved state (state.c; tests corrupt its fields one at a
 * time). */
typedef struct {
    uint64_t magic;
    int32_t n[3];
    int32_t nspheres;
    int64_t step;
    uint64_t ncells;
    uint64_t nsolid;
    int64_t covered, uncovered;
    int32_t first;
    int16_t streaming, layout;
    int32_t single, pad;
    uint64_t nside; /* moments layout: side-store entries in use (moments.h); else 0 */
} fluid_state_header_t;

/* The populations of f[cur] with the maps of its layout state. */
static inline pops_t fluid_pops(const fluid_t *fl)
{
    if (fl->streaming == STREAMING_MOMENTS) {
        return moments_pops(&fl->mom, &fl->g);
    }
    pops_t p;
    pops_init(&p, &fl->g, fl->f[fl->cur], fl->single, fl->layout);
    return p;
}

/* Density and velocity of cell i from its post-collision populations: the
 * collision keeps the density and adds the force F to the momentum, so the
 * velocity it used is u = (sum c f~ - F/2) / rho (Guo et al. 2002). Needs no
 * boundary values, and so is exact next to walls and spheres. */
static inline __attribute__((always_inline)) void fluid_post_velocity(const fluid_t *fl, double rho, const double j[3],
                                                                     double u[3])
{
    for (int a = 0; a < 3; a++) {
        u[a] = (j[a] - 0.5 * fl->kp.force[a]) / rho;
    }
}

static inline __attribute__((always_inline)) void fluid_local_moments(const fluid_t *fl, const pops_t *f,
                                                                     size_t i, double *rho, double u[3])
{
    double j[3];
    *rho = pops_moments(f, i, j);
    fluid_post_velocity(fl, *rho, j, u);
}

/* The first remedy when a light body is coupled explicitly or without force
 * averaging (kappa_risky): its speed, and the flow it drives, grow by the
 * added-mass instability (README "Coupling"), whatever the step. */
#define RISKY_COUPLING_REMEDY                                                                                         \
    "set rigid.coupling: auto (the default) or implicit with fluid.force_averaging: true first: a light body "   \
    "(feedback number h zeta / m large) is coupled explicitly or without force averaging, and a speed that grows " \
    "by itself is that coupling's instability, not the step's"

/* fluid.c, for the step (step.c): rank 0's sphere kinematics to all
 * ranks; the period-2 watch of the spheres' motion after a step */
void fluid_share_kinematics(fluid_t *fl);
status_t fluid_watch_period_two(fluid_t *fl);

/* population arrays of 19 values per cell (none in the moments layout) */
static inline int fluid_arrays(const fluid_t *fl)
{
    return fl->streaming == STREAMING_TWO_ARRAY ? 2 : fl->streaming == STREAMING_MOMENTS ? 0 : 1;
}
static inline size_t fluid_value_bytes(const fluid_t *fl) { return fl->single ? sizeof(float) : sizeof(double); }

#endif
