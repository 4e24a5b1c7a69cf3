/* initial_profile.h — the initial fluid velocity of a scene
 * (fluid.initial_profile): uniform, or the steady laminar plane-channel
 * profile between the two walls of the one wall-bounded axis (Couette +
 * body-force Poiseuille), plus fluid.initial_velocity. SI units. */
#ifndef FLUID_INITIAL_PROFILE_H
#define FLUID_INITIAL_PROFILE_H

#include "../common/scene.h"

/* Initial fluid velocity (m/s) at the point x (m) (fluid.initial_profile). */
void scene_initial_velocity(const scene_t *s, const double x[3], double u[3]);

#endif
