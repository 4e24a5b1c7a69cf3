/* units.c — SI to lattice conversion and the pre-run assessment (units.h). */
#include "units.h"

#include "grid.h"
#include "kernel.h"
#include "lattice.h"
#include "layout.h"
#include "moments.h"

#include <math.h>
#include <omp.h>

status_t units_derive(const scene_t *s, const log_t *log, units_t *u)
{
    const char *file = s->path ? s->path : "(scene)";
    u->dx = s->fluid.dx;
    u->tau = s->fluid.tau;
    u->rho0 = s->fluid.density;
    u->nu = s->fluid.viscosity;
    if (!(u->dx > 0.0) || !(u->tau > 0.5) || !(u->rho0 > 0.0) || !(u->nu > 0.0)) {
        return log_msg(log, STATUS_ERROR, "units",
                       "%s: fluid: need dx > 0, tau > 0.5, density > 0, viscosity > 0 (got dx=%g, tau=%g, "
                       "density=%g, viscosity=%g)",
                       file, u->dx, u->tau, u->rho0, u->nu);
    }
    static const char *axis = "xyz";
    for (int a = 0; a < 3; a++) {
        const double n = s->domain.size[a] / u->dx;
        const double r = floor(n + 0.5);
        if (r < 1.0 || fabs(n - r) > 1e-9 * n || r > 1e7) {
            return log_msg(log, STATUS_ERROR, "units",
                           "%s: domain.size[%d] (%c) = %g m is not a whole number of cells of dx = %g m "
                           "(%.12g cells); allowed: an integer from 1 to 1e7",
                           file, a, axis[a], s->domain.size[a], u->dx, n);
        }
        u->n[a] = (int)r;
    }
    u->nu_lat = (u->tau - 0.5) / 3.0;
    /* the scene's step itself (a whole number of ns, tau derived from it):
     * recomputed from tau it came out an ulp off, and the snapshot times
     * (step x dt) an ulp off the master's rows */
    u->dt = s->fluid.dt > 0.0 ? s->fluid.dt : u->nu_lat * u->dx * u->dx / u->nu;
    u->omega_plus = 1.0 / u->tau;
    u->collision = s->fluid.collision;
    u->omega_minus = s->fluid.collision == COLLISION_TRT ? kernel_omega_minus(u->omega_plus, s->fluid.magic)
                                                         : u->omega_plus;
    const double ff = 1.0 / (units_force(u) / (u->dx * u->dx * u->dx)); /* (N/m^3)^-1 */
    for (int a = 0; a < 3; a++) {
        u->force_lat[a] = s->fluid.body_force[a] * ff;
    }
    return STATUS_OK;
}

double units_bytes_per_cell(const scene_t *s)
{
    if (s->fluid.streaming == STREAMING_MOMENTS) {
        /* 10 moments, the side-store index and the flags (moments.h); the
         * side store itself: units_extra_bytes */
        return MOM_N * sizeof(double) + sizeof(int32_t) + 0.5;
    }
    const double arrays = s->fluid.streaming == STREAMING_TWO_ARRAY ? 2.0 : 1.0;
    const double bytes = s->fluid.precision == PRECISION_SINGLE ? sizeof(float) : sizeof(double);
    return arrays * LB_Q * bytes + 0.5; /* and the flags, two cells to a byte (cellflags.h) */
}

double units_extra_bytes(const scene_t *s, const grid_t *g, int threads)
{
    if (s->fluid.streaming != STREAMING_MOMENTS) {
        return 0.0;
    }
    /* every ghost cell and every cell inside a sphere (its volume in cells,
     * the spheres apart), 19 doubles each, with the store's slack (an
     * eighth: moments_sync); the kernel's plane copies per thread */
    const double ghosts = (double)g->ncells - (double)g->n[0] * g->n[1] * g->n[2];
    double solid = 0.0;
    for (int i = 0; i < s->nbodies; i++) {
        for (int k = 0; k < s->bodies[i].nspheres; k++) {
            const double r = s->bodies[i].spheres[k].radius / s->fluid.dx;
            solid += 4.0 / 3.0 * 3.14159265358979323846 * r * r * r;
        }
    }
    return ghosts * LB_Q * sizeof(double) + 1.125 * solid * LB_Q * sizeof(double) +
           (double)threads * MOMENTS_PLANE_DOUBLES * sizeof(double) * g->s[0] * g->s[1];
}

int units_grid_align(const scene_t *s) { return s->fluid.streaming == STREAMING_TWO_ARRAY ? GRID_ALIGN : 1; }

/* Smallest extent between two non-periodic faces across an axis other than
 * `along`, the width that bounds a channel flow; 0 when there is none. */
static double channel_width(const scene_t *s, int along)
{
    double h = 0.0;
    for (int a = 0; a < 3; a++) {
        if (a == along || s->domain.faces[2 * a].type == FACE_PERIODIC) {
            continue;
        }
        if (h == 0.0 || s->domain.size[a] < h) {
            h = s->domain.size[a];
        }
    }
    return h;
}

static double norm3(const double v[3]) { return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

static void consider(units_assessment_t *a, double v, const char *why)
{
    if (v > a->u_max) {
        a->u_max = v;
        a->u_source = why;
    }
}

void units_assess(const scene_t *s, const units_t *u, const log_t *log, units_assessment_t *a)
{
    const double mu = u->nu * u->rho0;
    a->u_max = 0.0;
    a->u_source = "nothing moves";
    a->length = fmin(s->domain.size[0], fmin(s->domain.size[1], s->domain.size[2]));
    a->length_source = "smallest domain extent";
    a->radius_cells = 0.0;
    a->nwarnings = 0;
    consider(a, norm3(s->fluid.initial_velocity), "fluid.initial_velocity");
    for (int f = 0; f < 6; f++) {
        if (s->domain.faces[f].type == FACE_MOVING_WALL || s->domain.faces[f].type == FACE_VELOCITY_INLET) {
            consider(a, norm3(s->domain.faces[f].velocity), "a moving wall or inlet velocity");
        }
    }
    const double fb = norm3(s->fluid.body_force);
    if (fb > 0.0) {
        int along = 0;
        for (int i = 1; i < 3; i++) {
            if (fabs(s->fluid.body_force[i]) > fabs(s->fluid.body_force[along])) {
                along = i;
            }
        }
        const double h = channel_width(s, along);
        if (h > 0.0) {
            /* plane Poiseuille peak velocity F h^2 / (8 mu) */
            consider(a, fb * h * h / (8.0 * mu), "body-force channel flow (plane Poiseuille peak)");
            a->length = h;
            a->length_source = "channel width";
        } else if (s->nbodies == 0) {
            log_msg(log, STATUS_WARNING, "units",
                    "%s: fluid.body_force drives a domain without walls or spheres: the flow accelerates "
                    "without bound",
                    s->path);
            a->nwarnings++;
        }
    }
    double g = norm3(s->rigid.gravity);
    for (int b = 0; b < s->nbodies; b++) {
        const scene_body_t *body = &s->bodies[b];
        const int moves = body->motion != MOTION_FIXED; /* a fixed body's velocities are ignored */
        if (moves) {
            consider(a, norm3(body->velocity), "a body's velocity");
        }
        double rmax = 0.0;
        for (int i = 0; i < body->nspheres; i++) {
            const double r = body->spheres[i].radius;
            rmax = fmax(rmax, r);
            if (a->radius_cells == 0.0 || r / u->dx < a->radius_cells) {
                a->radius_cells = r / u->dx;
            }
            if (moves) {
                consider(a, norm3(body->angular_velocity) * r, "a body's rotation");
            }
        }
        if (body->motion == MOTION_FREE && g > 0.0) {
            /* Stokes settling of the largest sphere, the paper's Eq. 10 */
            const double v = 2.0 * g * rmax * rmax * fabs(body->density - u->rho0) / (9.0 * mu);
            consider(a, v, "Stokes settling (Eq. 10)");
        }
        if (b == 0 || 2.0 * rmax < a->length) {
            a->length = 2.0 * rmax;
            a->length_source = "sphere diameter";
        }
    }
    a->mach = a->u_max / units_velocity(u) / sqrt(LB_CS2);
    a->reynolds = a->u_max * a->length / u->nu;
    a->steps = (long)ceil(s->run.end_time / u->dt - 1e-9);
    grid_t gr;
    grid_init(&gr, u->n, units_grid_align(s));
    a->bytes = (double)gr.ncells * units_bytes_per_cell(s) + units_extra_bytes(s, &gr, omp_get_max_threads());

    if (a->mach > 0.1) {
        log_msg(log, STATUS_WARNING, "units",
                "%s: Mach number %.3g (from %s) exceeds 0.1: compressibility errors grow as Ma^2; lower "
                "fluid.tau or dx",
                s->path, a->mach, a->u_source);
        a->nwarnings++;
    }
    if (a->mach > s->fluid.mach_limit) {
        /* the fluid's detector stops such a run (fluid_check) */
        log_msg(log, STATUS_WARNING, "units",
                "%s: Mach number %.3g (from %s) is above fluid.mach_limit %g: the run stops as soon as a fluid cell "
                "moves that fast (at its first step when it is the initial velocity); lower the speed in lattice "
                "units or raise fluid.mach_limit (at most 1) if this speed is meant",
                s->path, a->mach, a->u_source, s->fluid.mach_limit);
        a->nwarnings++;
    }
    if (u->tau < 0.55) {
        /* TRT as a remedy only where it is not already used */
        log_msg(log, STATUS_WARNING, "units",
                "%s: fluid.tau = %.9g is close to 0.5: the scheme loses stability; use tau >= 0.55%s", s->path,
                u->tau, s->fluid.collision == COLLISION_BGK ? " or TRT (fluid.collision: trt)" : "");
        a->nwarnings++;
    }
    /* TRT at a fixed magic parameter keeps its steady state, walls included, at any tau */
    if (u->tau > 2.5 && s->fluid.collision == COLLISION_BGK) {
        log_msg(log, STATUS_WARNING, "units",
                "%s: fluid.tau = %g is large: the wall location of interpolated boundaries drifts with tau "
                "(BGK); use TRT or tau <= 2.5",
                s->path, u->tau);
        a->nwarnings++;
    }
    if (a->radius_cells > 0.0 && a->radius_cells < 4.0) {
        log_msg(log, STATUS_WARNING, "units",
                "%s: the smallest sphere has %.3g cells per radius; forces are inaccurate below about 4",
                s->path, a->radius_cells);
        a->nwarnings++;
    }
}
