/* refill.c — refilling uncovered cells (refill.h). */
#include "refill.h"

#include "spheres.h"

#include "lattice.h"

#include <math.h>

/* The cell X + c_q (the block's, or another rank's in the sphere halo);
 * 0 beyond a wall. */
static int neighbour(spheres_t *sp, const grid_t *g, const uint8_t *flags, const int X[3], int q, size_t *out,
                     uint8_t *flag)
{
    int Y[3];
    for (int a = 0; a < 3; a++) {
        Y[a] = X[a] + lb_c[q][a];
    }
    return spheres_cell(sp, g, flags, Y, out, flag);
}

static void moments(const spheres_t *sp, const pops_t *p, size_t i, double *rho, double u[3])
{
    double r = 0.0, j[3] = {0.0, 0.0, 0.0};
#pragma GCC unroll 19
    for (int q = 0; q < LB_Q; q++) { /* the sums of pops_moments */
        const double v = spheres_post(sp, p, q, i);
        r += v;
        LB_ADD(j[0], lb_c[q][0], v);
        LB_ADD(j[1], lb_c[q][1], v);
        LB_ADD(j[2], lb_c[q][2], v);
    }
    *rho = r;
    for (int a = 0; a < 3; a++) {
        u[a] = j[a] / r;
    }
}

/* Directions whose cosine to the normal is within this of the best one
 * count as tied: mirror images of a cell (the same normal, mirrored) then
 * extrapolate along mirrored directions, and a cell on a mirror plane along
 * a symmetric set (before, the first in index order won a tie: a sphere
 * settling on the axis of a symmetric box began to turn, 3e-4 rad/s after
 * four mirror-image cells were refilled, found by a sweep of unseen scenes). */
#define REFILL_TIE 1e-12

void refill_cell(refill_t kind, spheres_t *sp, const grid_t *g, const uint8_t *flags, const pops_t *p,
                 const int X[3], const double normal[3], const double us[3], double mom[3])
{
    const size_t self = grid_index(g, X[0], X[1], X[2]);
    double rho = 0.0;
    int nrho = 0;
    double best_cos = -2.0, cs[LB_Q];
    size_t nb[LB_Q];
    for (int q = 1; q < LB_Q; q++) {
        uint8_t fl;
        cs[q] = -2.0; /* not a fluid neighbour */
        if (!neighbour(sp, g, flags, X, q, &nb[q], &fl) || fl != 0) {
            continue;
        }
        double r, u[3];
        moments(sp, p, nb[q], &r, u);
        rho += r;
        nrho++;
        const double len = sqrt((double)(lb_c[q][0] * lb_c[q][0] + lb_c[q][1] * lb_c[q][1] + lb_c[q][2] * lb_c[q][2]));
        cs[q] = (lb_c[q][0] * normal[0] + lb_c[q][1] * normal[1] + lb_c[q][2] * normal[2]) / len;
        best_cos = fmax(best_cos, cs[q]);
    }
    rho = nrho > 0 ? rho / nrho : 1.0;
    /* the non-equilibrium part of the fluid neighbour along the direction
     * nearest the normal, the mean over the tied ones. Not the linear
     * extrapolation 2 n(x + c) - n(x + 2c) (used before 2026-11-27): behind a
     * moving sphere x + c and x + 2c are cells refilled the same way a few
     * steps earlier, and the recursion amplifies grid-scale noise up to
     * threefold per refill; near tau = 1/2, where that noise is hardly damped,
     * it grew until the run stopped (multireflection, tau 0.51, a sphere of
     * radius 5 moving 0.045 cells a step: negative density at step 550;
     * CUnit sphere_motion). */
    double neq[LB_Q] = {0.0};
    int ntied = 0;
    for (int d = 1; d < LB_Q && kind == REFILL_EXTRAPOLATION && nrho > 0; d++) {
        if (!(cs[d] >= best_cos - REFILL_TIE)) {
            continue;
        }
        const size_t i1 = nb[d];
        double r1, u1[3];
        moments(sp, p, i1, &r1, u1);
        for (int q = 0; q < LB_Q; q++) {
            neq[q] += spheres_post(sp, p, q, i1) - lb_feq(q, r1, u1[0], u1[1], u1[2]);
        }
        ntied++;
    }
    for (int q = 0; q < LB_Q && ntied > 1; q++) {
        neq[q] /= ntied;
    }
    mom[0] = mom[1] = mom[2] = 0.0;
    double v[LB_Q];
    for (int q = 0; q < LB_Q; q++) {
        v[q] = lb_feq(q, rho, us[0], us[1], us[2]) + neq[q];
        for (int a = 0; a < 3; a++) {
            mom[a] += lb_c[q][a] * v[q];
        }
    }
    /* (moments layout: the cell's side-store entry, which moments_sync
     * turns into its moments after the map) */
    pops_set_post(p, self, v);
}
