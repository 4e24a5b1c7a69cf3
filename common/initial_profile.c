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

void scene_initial_rigid_motion(const scene_t *s, const double x[3], double u[3], double w[3])
{
    scene_initial_velocity(s, x, u);
    /* du_a/dx_b; the profile is quadratic in one coordinate, so a central
     * difference is exact but for round-off of a step a thousandth of the
     * domain */
    double g[3][3];
    for (int b = 0; b < 3; b++) {
        const double h = 1e-3 * s->domain.size[b];
        double xp[3] = {x[0], x[1], x[2]}, xm[3] = {x[0], x[1], x[2]}, up[3], um[3];
        xp[b] += h;
        xm[b] -= h;
        scene_initial_velocity(s, xp, up);
        scene_initial_velocity(s, xm, um);
        for (int a = 0; a < 3; a++) {
            g[a][b] = (up[a] - um[a]) / (2.0 * h);
        }
    }
    w[0] = 0.5 * (g[2][1] - g[1][2]);
    w[1] = 0.5 * (g[0][2] - g[2][0]);
    w[2] = 0.5 * (g[1][0] - g[0][1]);
}

void scene_start_with_flow(scene_t *s)
{
    for (int b = 0; b < s->nbodies; b++) {
        scene_body_t *body = &s->bodies[b];
        if (!body->move_with_flow || body->motion != MOTION_FREE || body->nspheres == 0) {
            continue;
        }
        double c[3];
        scene_body_pivot(body, c);
        scene_initial_rigid_motion(s, c, body->velocity, body->angular_velocity);
    }
}
