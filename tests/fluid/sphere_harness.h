/* sphere_harness.h — the sphere experiments shared by the CUnit tests
 * (test_spheres.c) and the accuracy report (sphere_report.c), in the
 * lattice-like SI units of test_util.h (dx = 1, dt = 1, density 1). They fail
 * softly (NaN results) so that either caller decides what a failure means. */
#ifndef TESTS_FLUID_SPHERE_HARNESS_H
#define TESTS_FLUID_SPHERE_HARNESS_H

#include "../../common/scene.h"

/* One body of one sphere in s (storage shared by the last four calls). */
scene_body_t *harness_one_sphere(scene_t *s, const double c[3], double r, motion_t motion);

/* A fixed sphere of radius a at (L/2 - 1/2 + off) on each axis (off = 1/2: a
 * cell corner) in a periodic L^3 box driven by a body force, run to steady
 * state: the drag coefficient against Sangani & Acrivos (1982), with F =
 * momentum-exchange force + body force on 4/3 pi a^3 and U the superficial
 * velocity (k_rel = K / K_SA - 1); balance = F_h / (F_b N_fluid) - 1; the mean
 * density of the fluid cells. */
typedef struct {
    double k_rel, balance, mean_density;
    double k_flux; /* K / K_SA - 1 with F = f L^3, f the body force per volume: needs no volume */
    long nsolid;   /* solid cells */
} harness_drag_t;
harness_drag_t harness_array_drag(int L, double a, double tau, collision_t op, boundary_scheme_t scheme, double off);
/* The same with the centre at a cell corner + p (cells, per axis): p = 0 a
 * corner, p = (1/2, 1/2, 1/2) a cell centre; steps = steps run to steady state. */
harness_drag_t harness_array_drag_at(int L, double a, double tau, collision_t op, boundary_scheme_t scheme,
                                     const double p[3], long *steps);

/* A sphere of radius a centred at a cell corner + p (cells) in a periodic L^3
 * box, rotating about z at a fixed rate in fluid at rest, run until the torque
 * changes by less than 1e-7 per 100 steps: its torque / Hofmann et al. (1999)
 * (simple cubic array) - 1; steps = steps run. */
double harness_rotating_torque(int L, double a, double tau, collision_t op, boundary_scheme_t scheme,
                               const double p[3], long *steps);

/* n positions of a sphere centre within a cell, as offsets from a cell corner
 * in [0, 1)^3: the corner, the cell centre, then n - 2 drawn uniformly with a
 * fixed generator (splitmix64 from seed), so that every run sees the same set. */
void harness_cell_positions(int n, unsigned long long seed, double (*p)[3]);

/* A sphere of radius a moved at constant velocity through a periodic (4a)^3
 * box. driven: a body force pushes the fluid the other way (starting at its
 * expected mean velocity), so that the drag has a steady mean about which it
 * fluctuates as cells are covered and uncovered; fluct = std/mean of the
 * delivered load over the second half. Undriven: drift_per_step = |P_fluid +
 * booked impulse - P0| / steps. */
typedef struct {
    double drift_per_step, fluct, mean;
} harness_moving_t;
harness_moving_t harness_moving_sphere(boundary_scheme_t scheme, force_method_t force, refill_t refill,
                                       collision_t op, double a, long steps, int driven);

#endif
