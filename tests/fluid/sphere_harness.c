/* sphere_harness.c — see sphere_harness.h. */
#include "sphere_harness.h"

#include "../../fluid/fluid.h"
#include "sangani_acrivos.h"
#include "test_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846

scene_body_t *harness_one_sphere(scene_t *s, const double c[3], double r, motion_t motion)
{
    static scene_sphere_t sph[4];
    static scene_body_t body[4];
    static int next = 0;
    const int k = next++ % 4;
    memset(&body[k], 0, sizeof body[k]);
    sph[k].radius = r;
    memcpy(sph[k].center, c, sizeof sph[k].center);
    body[k].nspheres = 1;
    body[k].spheres = &sph[k];
    body[k].density = 2.0;
    body[k].motion = motion;
    s->nbodies = 1;
    s->bodies = &body[k];
    return &body[k];
}

static fluid_t *create(const scene_t *s)
{
    log_t log = {log_stderr, NULL};
    fluid_t *fl = NULL;
    return fluid_create(s, &log, &fl) == STATUS_OK ? fl : NULL;
}

harness_drag_t harness_array_drag(int L, double a, double tau, collision_t op, boundary_scheme_t scheme, double off)
{
    const double p[3] = {off - 0.5, off - 0.5, off - 0.5};
    return harness_array_drag_at(L, a, tau, op, scheme, p, NULL);
}

void harness_cell_positions(int n, unsigned long long seed, double (*p)[3])
{
    unsigned long long x = seed;
    for (int i = 0; i < n; i++) {
        for (int k = 0; k < 3; k++) {
            if (i < 2) {
                p[i][k] = 0.5 * i;
                continue;
            }
            /* splitmix64 (Steele, Lea & Flood, OOPSLA 2014), top 53 bits as a double in [0, 1) */
            x += 0x9E3779B97F4A7C15ULL;
            unsigned long long z = x;
            z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
            z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
            z ^= z >> 31;
            p[i][k] = (double)(z >> 11) * 0x1.0p-53;
        }
    }
}

double harness_rotating_torque(int L, double a, double tau, collision_t op, boundary_scheme_t scheme,
                               const double p[3], long *steps)
{
    const double nu = (tau - 0.5) / 3.0, omega = 2e-4;
    scene_t s = test_box(L, L, L, tau, op);
    const double c[3] = {L / 2.0 + p[0], L / 2.0 + p[1], L / 2.0 + p[2]};
    harness_one_sphere(&s, c, a, MOTION_PRESCRIBED)->angular_velocity[2] = omega;
    s.fluid.boundary_scheme = scheme;
    fluid_t *fl = create(&s);
    if (fl == NULL) {
        return NAN;
    }
    double f[3], t[3], told = 0.0;
    long n = 0;
    /* the moving boundary's links exchange a little mass with the sphere each
     * step (its rotation is tangential only in the continuum), so the torque
     * creeps on at about 1e-9 per 100 steps after the flow has settled: stop
     * at 1e-7 */
    while (n < 100000) {
        test_run(fl, 100);
        n += 100;
        fluid_sphere_load_lattice(fl, 0, f, t);
        if (fabs(t[2] - told) < 1e-7 * fabs(t[2])) {
            break;
        }
        told = t[2];
    }
    fluid_free(fl);
    if (steps != NULL) {
        *steps = n;
    }
    /* Hofmann et al. (1999): torque on a sphere of a simple cubic array rotating in a fluid at rest */
    const double phi = 4.0 / 3.0 * PI * a * a * a / ((double)L * L * L);
    const double ref = -8.0 * PI * nu * a * a * a * omega / (1.0 - phi - 1.95708 * pow(phi, 10.0 / 3.0));
    return t[2] / ref - 1.0;
}

harness_drag_t harness_array_drag_at(int L, double a, double tau, collision_t op, boundary_scheme_t scheme,
                                     const double p[3], long *steps)
{
    harness_drag_t d = {NAN, NAN, NAN, NAN, 0};
    scene_t s = test_box(L, L, L, tau, op);
    /* scene coordinate x is at lattice X = x + 1/2 (cell centres at integers): L/2 is a corner */
    const double c[3] = {L / 2.0 + p[0], L / 2.0 + p[1], L / 2.0 + p[2]};
    harness_one_sphere(&s, c, a, MOTION_FIXED);
    s.fluid.boundary_scheme = scheme;
    s.fluid.force_method = FORCE_GALILEAN;
    const double nu = (tau - 0.5) / 3.0, fb = 1e-6 * nu;
    s.fluid.body_force[0] = fb;
    fluid_t *fl = create(&s);
    if (fl == NULL) {
        return d;
    }
    double fold = 0.0, f[3], t[3];
    long nsteps = 0;
    while (nsteps < 200000) {
        test_run(fl, 100);
        nsteps += 100;
        fluid_sphere_load_lattice(fl, 0, f, t);
        if (fabs(f[0] - fold) < 1e-10 * fabs(f[0])) {
            break;
        }
        fold = f[0];
    }
    if (steps != NULL) {
        *steps = nsteps;
    }
    const int n = L * L * L;
    double *u = malloc(sizeof(double) * 3 * n), *rho = malloc(sizeof(double) * n);
    unsigned char *flags = malloc(n);
    if (u != NULL && rho != NULL && flags != NULL) {
        fluid_moments_lattice(fl, rho, u);
        fluid_flags(fl, flags);
        double usum = 0.0, rsum = 0.0;
        long nfluid = 0;
        for (int i = 0; i < n; i++) {
            if (flags[i] == 0) {
                usum += u[3 * i];
                rsum += rho[i];
                nfluid++;
            }
        }
        const double U = usum / n;
        d.k_rel = (f[0] + fb * 4.0 / 3.0 * PI * a * a * a) / (6.0 * PI * nu * a * U) / sangani_acrivos(2.0 * a / L) -
                  1.0;
        d.k_flux = fb * n / (6.0 * PI * nu * a * U) / sangani_acrivos(2.0 * a / L) - 1.0;
        d.nsolid = n - nfluid;
        d.balance = f[0] / (fb * nfluid) - 1.0;
        d.mean_density = rsum / nfluid;
    }
    free(u);
    free(rho);
    free(flags);
    fluid_free(fl);
    return d;
}

harness_moving_t harness_moving_sphere(boundary_scheme_t scheme, force_method_t force, refill_t refill,
                                       collision_t op, double a, long steps, int driven)
{
    harness_moving_t r = {NAN, NAN, NAN};
    const int L = (int)(4 * a);
    const double tau = 0.8, nu = (tau - 0.5) / 3.0, urel = 0.02;
    scene_t s = test_box(L, L, L, tau, op);
    const double c[3] = {L / 2.0, L / 2.0 + 0.13, L / 2.0 - 0.21};
    scene_body_t *b = harness_one_sphere(&s, c, a, MOTION_PRESCRIBED);
    b->velocity[0] = 0.5 * urel;
    b->velocity[1] = 0.05 * urel;
    s.fluid.boundary_scheme = scheme;
    s.fluid.force_method = force;
    s.fluid.refill = refill;
    if (driven) {
        /* Stokes drag of the array, K(0.5) = 2.842 (Sangani & Acrivos 1982) */
        const double drag = 6.0 * PI * nu * a * urel * sangani_acrivos(0.5);
        s.fluid.body_force[0] = -drag / ((double)L * L * L);
        s.fluid.initial_velocity[0] = -0.5 * urel;
    }
    fluid_t *fl = create(&s);
    if (fl == NULL) {
        return r;
    }
    double m0, p0[3], m, p[3], impulse[3] = {0, 0, 0}, f[3], t[3], sum = 0.0, sum2 = 0.0;
    long cnt = 0;
    fluid_totals_lattice(fl, &m0, p0);
    for (long n = 0; n < steps; n++) {
        fluid_step(fl);
        fluid_sphere_load_lattice(fl, 0, f, t);
        for (int k = 0; k < 3; k++) {
            impulse[k] += f[k];
        }
        if (n >= steps / 2) {
            fluid_sphere_load(fl, 0, f, t); /* with averaging when the scene asks for it */
            sum += f[0];
            sum2 += f[0] * f[0];
            cnt++;
        }
    }
    fluid_totals_lattice(fl, &m, p);
    double dr = 0.0;
    for (int k = 0; k < 3; k++) {
        dr += pow(p[k] + impulse[k] - p0[k], 2.0);
    }
    r.drift_per_step = sqrt(dr) / steps;
    r.mean = sum / cnt;
    r.fluct = sqrt(fmax(sum2 / cnt - r.mean * r.mean, 0.0)) / fabs(r.mean);
    fluid_free(fl);
    return r;
}
