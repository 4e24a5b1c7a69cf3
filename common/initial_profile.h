/* initial_profile.h — the initial fluid velocity of a scene
 * (fluid.initial_profile): uniform, or the steady laminar plane-channel
 * profile between the two walls of the one wall-bounded axis (Couette +
 * body-force Poiseuille), plus fluid.initial_velocity. SI units. */
#ifndef COMMON_INITIAL_PROFILE_H
#define COMMON_INITIAL_PROFILE_H

#include "scene.h"

/* Initial fluid velocity (m/s) at the point x (m) (fluid.initial_profile). */
void scene_initial_velocity(const scene_t *s, const double x[3], double u[3]);
/* The rigid motion of that flow at x: its velocity u and half its vorticity
 * w = curl(u) / 2 (rad/s; central differences, exact for the profile's
 * polynomials up to round-off), what a free sphere there moves with. */
void scene_initial_rigid_motion(const scene_t *s, const double x[3], double u[3], double w[3]);
/* Every free body with move_with_flow: its velocity and angular velocity set
 * to the initial flow's rigid motion at the centroid of its sphere centres
 * weighted by r^3 (the scene reader, after fluid.channel_axis is known). */
void scene_start_with_flow(scene_t *s);

#endif
