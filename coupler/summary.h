/* summary.h — what `coupler run` prints at the end of a run. */
#ifndef COUPLER_SUMMARY_H
#define COUPLER_SUMMARY_H

#include "../common/scene.h"
#include "../fluid/units.h"
#include "fmu.h"

#include <stddef.h>

/* The one free body made of one sphere under gravity: index of the sphere, or -1. */
int summary_settling_sphere(const scene_t *s);
/* Terminal velocity (mean over the last 20 % of the run) against Stokes,
 * from the velocity along gravity of that sphere at the output rows. */
void summary_settling(const scene_t *s, const double *settle_t, const double *settle_v, long nsettle, double t_end);
/* A fluid-only channel with one pair of no-slip walls: peak against the analytic profile. */
void summary_poiseuille(const scene_t *s, const units_t *un, const double peak[3]);
/* Final velocity of every free body from its spheres' velocities [ns][3]. */
void summary_bodies(const scene_t *s, int ns, const int *ibody, const double *velocity);
/* The FMI call counts of an FMU as a JSON object. */
void summary_calls_json(const fmu_t *f, char *buf, size_t n);

#endif
