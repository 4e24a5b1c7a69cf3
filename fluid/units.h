/* units.h — the one place where SI meets lattice units.
 *
 * Lattice units: dx = dt = rho0 = 1. From the scene: dx (m), tau, kinematic
 * viscosity nu (m^2/s) and density rho0 (kg/m^3) give
 *   nu_lat = (tau - 1/2)/3,  dt = nu_lat dx^2 / nu,
 * and every other quantity converts with the factors below. units_assess
 * estimates the largest velocity the scene will see (walls, inlets, body
 * force driven channel flow, Stokes settling, prescribed motion) and turns
 * it into Mach and Reynolds numbers with warnings for risky values. */
#ifndef FLUID_UNITS_H
#define FLUID_UNITS_H

#include "../common/scene.h"
#include "grid.h"

typedef struct {
    int n[3];        /* cells per axis */
    double dx, dt;   /* m, s */
    double rho0, nu; /* kg/m^3, m^2/s */
    double tau, nu_lat, omega_plus, omega_minus;
    double force_lat[3]; /* body force per volume in lattice units */
    collision_t collision; /* fluid.collision, for messages */
} units_t;

static inline double units_velocity(const units_t *u) { return u->dx / u->dt; }             /* m/s per lattice unit */
static inline double units_force(const units_t *u) { return u->rho0 * u->dx * u->dx * u->dx * u->dx / (u->dt * u->dt); } /* N */
static inline double units_torque(const units_t *u) { return units_force(u) * u->dx; }       /* N m */
static inline double units_pressure(const units_t *u) { return u->rho0 * u->dx * u->dx / (u->dt * u->dt); } /* Pa */

/* Lattice parameters from a validated scene; errors name the key. */
status_t units_derive(const scene_t *s, const log_t *log, units_t *out);

typedef struct {
    double u_max;    /* estimated largest fluid or body velocity, m/s */
    const char *u_source; /* what sets it */
    double mach;     /* u_max / c_s in lattice units */
    double length;   /* the Reynolds length, m */
    const char *length_source;
    double reynolds;
    double radius_cells; /* smallest sphere radius in cells, 0 without spheres */
    long steps;          /* time steps to end_time */
    double bytes;        /* memory estimate of the fluid component */
    int nwarnings;
} units_assessment_t;

/* Estimates and logs warnings (Mach > 0.1, tau < 0.55 or > 2.5, radius < 4 cells,
 * Re of spheres > 1 when Stokes-flow assumptions are implied, ...). */
void units_assess(const scene_t *s, const units_t *u, const log_t *log, units_assessment_t *a);

/* Bytes per cell of the fluid state (two population arrays and a flag). */
/* Bytes per allocated cell: the population arrays of the scene's streaming
 * layout (one in place, two otherwise) in its precision, and the cell flag. */
double units_bytes_per_cell(const scene_t *s);
/* The multiple of cells the grid's x extent is padded to (grid_init):
 * GRID_ALIGN with two arrays, 1 in place. */
int units_grid_align(const scene_t *s);
/* Bytes beyond those per cell: in the moments layout the side store of the
 * ghost cells and of the cells inside the spheres (at their volume), and
 * the kernel's plane copies for threads threads; 0 in the other layouts. */
double units_extra_bytes(const scene_t *s, const grid_t *g, int threads);

#endif
