/* drag_report.h — the position study of issue 11: drag of a fixed sphere in a
 * simple cubic array (D/L = 1/2, Sangani & Acrivos 1982) at many positions of
 * its centre within a cell, per boundary scheme, radius and tau. */
#ifndef TESTS_FLUID_DRAG_REPORT_H
#define TESTS_FLUID_DRAG_REPORT_H

#include "../../common/scene.h"

#define DRAG_MAX 8

typedef struct {
    int nschemes, nradii, ntaus, npositions, ncollisions;
    collision_t collisions[2];
    boundary_scheme_t schemes[DRAG_MAX];
    double radii[DRAG_MAX], taus[DRAG_MAX];
} drag_plan_t;

/* Over one set of positions: mean of K/K_SA - 1, the largest |K/K_SA - 1|
 * (worst) and max - min (spread), by the flux definition (k) and by the
 * momentum-exchange one (m, force + body force on 4/3 pi a^3). */
typedef struct {
    double mean, worst, spread;
    double mean_m, worst_m, spread_m;
    int n;
} drag_stats_t;

/* Runs one scheme / radius / tau over npositions of harness_cell_positions
 * (seed fixed); err_flux / err_mem (may be NULL) receive the per-position errors. */
drag_stats_t drag_positions(boundary_scheme_t scheme, double radius, double tau, int npositions, double *err_flux,
                            double *err_mem);

/* The full plan: dir/drag.csv (one row per run) and dir/drag.txt (the table of
 * mean/worst/spread); progress and the table on stdout. 0 on success. */
int drag_report(const char *dir, const drag_plan_t *plan);

/* Fills a plan from "key=value" words: schemes=cli,multireflection radii=4,8
 * taus=0.6,1,1.5 positions=22; defaults: every scheme, radii 3 4 5 6 8, taus 0.6 1 1.5,
 * 22 positions (corner, centre, 20 random). 0 on success, else the bad word's index + 1. */
/* The rotating sphere (harness_rotating_torque, L = 4a) over the same plan:
 * DIR/rotation.csv, one row per run (torque error, steps, seconds). */
int rotation_report(const char *dir, const drag_plan_t *plan);

int drag_plan_parse(drag_plan_t *plan, int argc, char **argv);

#endif
