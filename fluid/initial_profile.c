/* initial_profile.c — the initial fluid velocity of a scene
 * (fluid.initial_profile; initial_profile.h).
 *
 * uniform: fluid.initial_velocity everywhere. plane_channel: the steady
 * laminar solution between the two walls of the one wall-bounded axis n (the
 * scene reader has checked that there is exactly one and set
 * fluid.channel_axis), plus fluid.initial_velocity. With xi = x_n / h across
 * the channel of width h: the Couette part v0 + (v1 - v0) xi of the wall
 * velocities and the Poiseuille part of the body force g (per volume),
 * g / (2 rho nu) xi (1 - xi) h^2. Nothing is added along n. */
#include "initial_profile.h"

#include <math.h>

void scene_initial_velocity(const scene_t *s, const double x[3], double u[3])
{
    const scene_fluid_t *f = &s->fluid;
    for (int a = 0; a < 3; a++) {
        u[a] = f->initial_velocity[a];
    }
    const int n = f->channel_axis;
    if (f->initial_profile != INITIAL_PLANE_CHANNEL || n < 0) {
        return;
    }
    const double h = s->domain.size[n], xi = fmin(fmax(x[n] / h, 0.0), 1.0);
    const face_t *lo = &s->domain.faces[2 * n], *hi = &s->domain.faces[2 * n + 1];
    for (int a = 0; a < 3; a++) {
        if (a == n) {
            continue;
        }
        double v0 = lo->type == FACE_MOVING_WALL ? lo->velocity[a] : 0.0;
        double v1 = hi->type == FACE_MOVING_WALL ? hi->velocity[a] : 0.0;
        /* Couette part + Poiseuille part of the body force: g/(2 nu) x (h - x). */
        u[a] += v0 + (v1 - v0) * xi + f->body_force[a] / (2.0 * f->density * f->viscosity) * xi * (1.0 - xi) * h * h;
    }
}
