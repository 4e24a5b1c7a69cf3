/* approach_harness.h — close approaches at low Reynolds number, shared by the
 * CUnit test (test_wall_approach.c) and the accuracy report (sphere_report.c),
 * in the lattice-like SI units of test_util.h (dx = 1, dt = 1, density 1).
 *
 * A sphere of radius a moves at constant speed U towards a no-slip floor
 * (prescribed motion: the test sets its centre every step), or two equal
 * spheres move towards each other at U each, through Stokes flow (Re = U a /
 * nu <= 0.1). The run starts from the steady flow of the approach at the
 * first gap (the geometry held while the surfaces move, which is the same
 * Stokes problem at that instant), so that no start-up transient remains.
 * The force is compared with Brenner's (1961) exact result for the gap of
 * each step (quasi-steady Stokes flow): lambda = F / (6 pi mu a U); for two
 * spheres, by mirror symmetry, the free-surface result at half their gap.
 * The fluid leaves out the lattice's normal force on the film zone, where
 * the surfaces are closer than the cut-off, and the film force of
 * rigid/lubrication.c stands for it (README "Lubrication").
 * The lattice force jumps as cells are covered and uncovered; what a moving
 * particle feels is its mean over that lattice period, so each target gap is
 * evaluated as the mean of F / F_Brenner over half a cell of travel of each
 * surface around it (the extremes are reported too). Fails softly (NaN). */
#ifndef TESTS_FLUID_APPROACH_HARNESS_H
#define TESTS_FLUID_APPROACH_HARNESS_H

#include <stdio.h>

typedef enum { APPROACH_WALL, APPROACH_SPHERES } approach_t;

typedef struct {
    approach_t kind;
    double a;         /* sphere radius, cells */
    int L, Lz;        /* lateral period; height (wall: no-slip floor and lid) or periodic length (two spheres) */
    double tau;       /* TRT, magic 3/16 */
    double U;         /* speed of each sphere, cells per step */
    double offset;    /* two spheres: their midplane sits this fraction of a cell above a cell face */
    double cutoff;    /* lubrication cut-off, cells (scene default 2): the film zone of the fluid and the film's */
    double start_gap; /* gap / a where the motion starts (steady flow there first) */
    double end_gap;   /* gap / a where it stops */
    FILE *trace;      /* NULL, or per step of the approach: gap/a, lattice, film and Brenner lambda (CSV) */
} approach_setup_t;

typedef struct {
    double gap;           /* target gap / a (between the two spheres: their gap / a) */
    double reference;     /* Brenner's lambda there */
    double total;         /* mean of (lattice + lubrication) / reference over the window */
    double lattice;       /* mean of lattice / reference: the lattice alone */
    double lo, hi;        /* extremes of (lattice + lubrication) / reference in the window */
    double lub_share;     /* mean share of the lubrication correction in the total */
} approach_point_t;

/* The validation runs (make validate, the report): radius 8, 96^3 against
 * the wall from gap/a 2.1, 96^2 x 128 for the pair. */
#define APPROACH_WALL_FULL {APPROACH_WALL, 8.0, 96, 96, 1.5, 0.003, 0.0, 2.0, 2.1, 0.015, NULL}
#define APPROACH_PAIR_FULL {APPROACH_SPHERES, 8.0, 96, 128, 1.5, 0.003, 0.0, 2.0, 2.1, 0.015, NULL}

/* Brenner's lambda for a sphere whose centre is at h/a = 1 + gap_a from a
 * no-slip plane (free_surface 0) or a free surface (1); the series of
 * shared/reference/validation-references.md summed to convergence. */
double brenner_lambda(double gap_a, int free_surface);

/* Runs one approach and evaluates it at the n target gaps (gap / a; each at
 * least half a cell inside [end_gap, start_gap] or it gets NaN). Returns the
 * number of steps run, 0 on failure. */
long harness_approach(const approach_setup_t *set, const double *gaps, int n, approach_point_t *out);

#endif
