/* fluid.h — the lattice Boltzmann fluid component (native API).
 *
 * An opaque handle and a few verbs: create from a validated scene, step,
 * read fields and diagnostics, free. No global state: any number of
 * instances may coexist (FMI requires it). Inputs and outputs are SI unless
 * a name says _lattice; the conversion lives in units.h. The FMI adapter and
 * the tests use exactly this API. */
#ifndef FLUID_FLUID_H
#define FLUID_FLUID_H

#include "../common/scene.h"
#include "../common/status.h"
#include "units.h"

#include <stddef.h>

typedef struct fluid fluid_t;

status_t fluid_create(const scene_t *scene, const log_t *log, fluid_t **out);
void fluid_free(fluid_t *fl);

/* One lattice Boltzmann time step: boundary stage, fused stream-collide. */
status_t fluid_step(fluid_t *fl);

long fluid_step_count(const fluid_t *fl);
double fluid_time(const fluid_t *fl); /* s */
const units_t *fluid_units(const fluid_t *fl);
void fluid_cells(const fluid_t *fl, int n[3]); /* the whole grid */
/* This rank's block of the grid (fluid/decomp.h): global cells lo .. lo + n
 * - 1, and the communicator of the ranks (const MPI_Comm *, NULL on one
 * rank). The field functions below read and write the block's cells; on
 * one rank it is the whole grid. */
void fluid_block(const fluid_t *fl, int lo[3], int n[3], const void **comm);
typedef struct {
    int ranks, rank, dims[3]; /* ranks along x, y, z */
    int lo[3], n[3];          /* this rank's block */
    double halo_bytes;        /* sent by this rank per step (the lattice halo; the sphere halo comes on top) */
    double halo_seconds;      /* wall time in exchanges so far, this rank */
} fluid_decomposition_t;
void fluid_decomposition(const fluid_t *fl, fluid_decomposition_t *out);
size_t fluid_memory_bytes(const fluid_t *fl);

/* Density and velocity of every interior cell of the block, lattice units, x fastest:
 * rho[i], u[3*i+a] with i = x + nx*(y + ny*z) (0-based interior coordinates):
 * the values the last collision used (with Guo's half-force shift). Solid
 * cells read 0. */
void fluid_moments_lattice(fluid_t *fl, double *rho, double *u);
/* The same for the interior planes z0 .. z0 + nz - 1 only (0-based), into
 * arrays of nx ny nz cells (i = x + nx*(y + ny*(z - z0))). */
void fluid_moments_lattice_planes(fluid_t *fl, int z0, int nz, double *rho, double *u);
/* Sets every interior cell to the equilibrium of the given fields (same
 * layout), e.g. an initial condition; NULL u means at rest. */
void fluid_set_equilibrium_lattice(fluid_t *fl, const double *rho, const double *u);
/* Cell type of every interior cell (0 fluid, 1 solid), same layout. */
void fluid_flags(const fluid_t *fl, unsigned char *flags);
void fluid_flags_planes(const fluid_t *fl, int z0, int nz, unsigned char *flags);

/* Total mass and momentum of the interior (lattice units), for diagnostics. */
void fluid_totals_lattice(fluid_t *fl, double *mass, double momentum[3]);
/* Totals over the fluid cells in one pass, lattice units: mass sum rho,
 * momentum sum rho u, kinetic energy sum rho u^2 / 2, the largest |u| and,
 * per axis, the velocity component of largest magnitude (u from the
 * post-collision moments, fluid_moments_lattice). Summed plane by plane and
 * the planes in order: the same result for any number of threads. The same
 * pass does what fluid_check does: STATUS_ERROR (totals computed anyway)
 * when a cell is in numerical trouble, so that totals are never NaN
 * silently. */
status_t fluid_diagnostics_lattice(fluid_t *fl, double mach_limit, double *mass, double momentum[3],
                                   double *kinetic, double *umax, double peak[3]);

/* Scans for numerical trouble: a non-finite or non-positive density, or a
 * velocity above mach_limit times the lattice speed of sound (the scene's
 * fluid.mach_limit). Returns STATUS_ERROR with step, cell, position in m and
 * cause in the message (the worst cause, at its first cell). */
status_t fluid_check(fluid_t *fl, double mach_limit);
/* The cheap check before the outputs are read: the load of every sphere
 * (force, torque, drag coefficients) is finite. When not, the full scan
 * (fluid_check) names the cell in trouble, and the error names the sphere. */
status_t fluid_check_loads(fluid_t *fl, double mach_limit);
/* A finite load can still come from a fluid in numerical trouble, and a
 * body moved by it then fails in the rigid component on that component's
 * terms (a free sphere started at 0.45 cells a step at tau 0.505: Mach 0.35
 * at its surface in the first step, a load of 1420 times its drag
 * coefficient at step 4, thrown 77 cells through a wall: "the contact is
 * too soft for this impact ... shorten contacts.contact_time"). A load
 * F ~ zeta (v_s - u) of a sane fluid is below LOAD_SLIP_MAX times the drag
 * coefficient (a slip of half a cell per step, the most a sphere may move;
 * measured up to 0.23 at that impulsive start, 0.025 in close approaches at
 * tau 0.505), and likewise the torque over zeta_r / r: a larger one, on a
 * sphere with only[k] != 0 (NULL: every sphere), has the whole grid checked
 * (fluid_check), which names the cell in trouble. */
#define LOAD_SLIP_MAX 0.5
status_t fluid_check_load_sizes(fluid_t *fl, double mach_limit, const unsigned char *only);

/* Spheres (global index: bodies in scene order, their spheres in order). */
int fluid_nspheres(const fluid_t *fl);
/* Kinematics for the next step, SI: centre, centre velocity, angular velocity
 * of its body. A move (or a velocity) of more than half a cell in one step is
 * refused with STATUS_ERROR and the remedies; the sphere then stays where it
 * was. Prescribed and fixed spheres move by themselves. */
status_t fluid_set_sphere(fluid_t *fl, int i, const double c[3], const double v[3], const double w[3]);
/* The LBM steps the spheres set next are held for (a master's communication
 * step): named by fluid_set_sphere when a sphere moves too far in one. */
void fluid_set_exchange_steps(fluid_t *fl, long k);
void fluid_get_sphere(const fluid_t *fl, int i, double c[3], double v[3], double w[3]);
/* Hydrodynamic force (N) and torque about the centre (N m) of the last step,
 * averaged over the last two steps when fluid.force_averaging is set. */
void fluid_sphere_load(const fluid_t *fl, int i, double force[3], double torque[3]);
/* Drag coefficients of sphere i in the last step (SI): the isotropic part of
 * the load's instantaneous response to the sphere's motion through the
 * moving-wall term of its boundary links, zt = -dF/dv (kg/s) and
 * zr = -dT/dw (kg m^2/s); for rigid.coupling = implicit. */
void fluid_sphere_drag(const fluid_t *fl, int i, double *zt, double *zr);
/* The same, lattice units, never averaged (momentum per step). */
void fluid_sphere_load_lattice(const fluid_t *fl, int i, double force[3], double torque[3]);

/* Serialisation of the complete state (populations, flags, spheres, step)
 * for FMI get/set/serialize FMU state: restoring a saved state into an
 * instance created from the same scene continues bit-identically. */
size_t fluid_state_size(const fluid_t *fl);
status_t fluid_state_save(const fluid_t *fl, void *buf, size_t size);
status_t fluid_state_restore(fluid_t *fl, const void *buf, size_t size);

/* Low-level access for tests and benchmarks. */

#endif
