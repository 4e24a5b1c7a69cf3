/* sphere_report.c — the figures of the curved-boundary study (`make report`).
 *
 * For each boundary scheme x force variant x refill scheme x {BGK, TRT} at
 * sphere radius 5 and 8 cells it prints:
 *   drag error  K / K_SA - 1 of a fixed sphere in a simple cubic array
 *               (D/L = 1/2, Stokes flow, Sangani & Acrivos 1982), at a cell
 *               corner and averaged over 4 positions relative to the grid
 *               (the force variant and the refill do not act on a fixed
 *               sphere, so it is computed once per scheme and collision);
 *   fluctuation std/mean of the drag on a sphere moved through a periodic
 *               box at constant velocity against a body-force driven flow
 *               (second half of 3000 steps), and the momentum drift per step
 *               of fluid + booked impulse;
 *   seconds     wall time of each run;
 * and the cost of a step with a particle relative to a pure fluid step on
 * the same grid. Output: plain columns, one line per combination. */
#include "../../common/scene.h"
#include "../../fluid/fluid.h"

#include "sangani_acrivos.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846


static scene_sphere_t g_sphere;
static scene_body_t g_body;

static scene_t box(int L, double tau, collision_t op, const double c[3], double a, motion_t motion)
{
    scene_t s;
    memset(&s, 0, sizeof s);
    s.path = "report";
    for (int k = 0; k < 3; k++) {
        s.domain.size[k] = L;
        s.domain.faces[2 * k].type = s.domain.faces[2 * k + 1].type = FACE_PERIODIC;
    }
    s.fluid.density = 1.0;
    s.fluid.dx = 1.0;
    s.fluid.tau = tau;
    s.fluid.viscosity = (tau - 0.5) / 3.0;
    s.fluid.collision = op;
    s.fluid.magic = 3.0 / 16.0;
    memset(&g_body, 0, sizeof g_body);
    g_sphere.radius = a;
    memcpy(g_sphere.center, c, sizeof g_sphere.center);
    g_body.nspheres = 1;
    g_body.spheres = &g_sphere;
    g_body.density = 2.0;
    g_body.motion = motion;
    s.nbodies = 1;
    s.bodies = &g_body;
    return s;
}

static double array_error(int L, double a, double tau, collision_t op, boundary_scheme_t scheme, double off)
{
    const double c[3] = {L / 2.0 - 0.5 + off, L / 2.0 - 0.5 + off, L / 2.0 - 0.5 + off};
    scene_t s = box(L, tau, op, c, a, MOTION_FIXED);
    s.fluid.boundary_scheme = scheme;
    const double nu = (tau - 0.5) / 3.0, fb = 1e-6 * nu;
    s.fluid.body_force[0] = fb;
    log_t log = {log_stderr, NULL};
    fluid_t *fl = NULL;
    if (fluid_create(&s, &log, &fl) != STATUS_OK) {
        return NAN;
    }
    double fold = 0.0, f[3], t[3];
    for (long n = 0; n < 200000; n += 100) {
        for (int k = 0; k < 100; k++) {
            fluid_step(fl);
        }
        fluid_sphere_load_lattice(fl, 0, f, t);
        if (fabs(f[0] - fold) < 1e-10 * fabs(f[0])) {
            break;
        }
        fold = f[0];
    }
    const int n = L * L * L;
    double *u = malloc(sizeof(double) * 3 * n);
    unsigned char *flags = malloc(n);
    fluid_moments_lattice(fl, NULL, u);
    fluid_flags(fl, flags);
    double usum = 0.0;
    for (int i = 0; i < n; i++) {
        if (flags[i] == 0) {
            usum += u[3 * i];
        }
    }
    free(u);
    free(flags);
    fluid_free(fl);
    const double U = usum / n;
    return (f[0] + fb * 4.0 / 3.0 * PI * a * a * a) / (6.0 * PI * nu * a * U) / sangani_acrivos(2.0 * a / L) - 1.0;
}

typedef struct {
    double fluct, drift;
} moving_t;

/* driven: body force against the motion (for the fluctuation); undriven:
 * no body force, so that fluid momentum + booked impulse must stay constant. */
static moving_t moving(double a, collision_t op, boundary_scheme_t scheme, force_method_t force, refill_t refill,
                       long steps, int driven)
{
    const int L = (int)(4 * a);
    const double tau = 0.8, nu = (tau - 0.5) / 3.0, urel = 0.02;
    const double c[3] = {L / 2.0, L / 2.0 + 0.13, L / 2.0 - 0.21};
    scene_t s = box(L, tau, op, c, a, MOTION_PRESCRIBED);
    g_body.velocity[0] = 0.5 * urel;
    g_body.velocity[1] = 0.05 * urel;
    s.fluid.boundary_scheme = scheme;
    s.fluid.force_method = force;
    s.fluid.refill = refill;
    if (driven) {
        s.fluid.body_force[0] = -6.0 * PI * nu * a * urel * sangani_acrivos(0.5) / ((double)L * L * L);
        s.fluid.initial_velocity[0] = -0.5 * urel;
    }
    log_t log = {log_stderr, NULL};
    fluid_t *fl = NULL;
    moving_t r = {NAN, NAN};
    if (fluid_create(&s, &log, &fl) != STATUS_OK) {
        return r;
    }
    double m0, p0[3], m, p[3], imp[3] = {0, 0, 0}, f[3], t[3], sum = 0.0, sum2 = 0.0;
    long cnt = 0;
    fluid_totals_lattice(fl, &m0, p0);
    for (long n = 0; n < steps; n++) {
        fluid_step(fl);
        fluid_sphere_load_lattice(fl, 0, f, t);
        for (int k = 0; k < 3; k++) {
            imp[k] += f[k];
        }
        if (n >= steps / 2) {
            sum += f[0];
            sum2 += f[0] * f[0];
            cnt++;
        }
    }
    fluid_totals_lattice(fl, &m, p);
    double d2 = 0.0;
    for (int k = 0; k < 3; k++) {
        d2 += pow(p[k] + imp[k] - p0[k], 2.0);
    }
    const double mean = sum / cnt;
    r.fluct = sqrt(fmax(sum2 / cnt - mean * mean, 0.0)) / fabs(mean);
    r.drift = sqrt(d2) / steps;
    fluid_free(fl);
    return r;
}

static double step_cost(int with_sphere)
{
    const int L = 64;
    const double c[3] = {L / 2.0, L / 2.0, L / 2.0};
    scene_t s = box(L, 0.8, COLLISION_TRT, c, 8.0, MOTION_PRESCRIBED);
    g_body.velocity[0] = 0.01;
    if (!with_sphere) {
        s.nbodies = 0;
    }
    s.fluid.boundary_scheme = BOUNDARY_CLI;
    s.fluid.force_method = FORCE_GALILEAN;
    s.fluid.refill = REFILL_EXTRAPOLATION;
    log_t log = {log_stderr, NULL};
    fluid_t *fl = NULL;
    if (fluid_create(&s, &log, &fl) != STATUS_OK) {
        return NAN;
    }
    for (int i = 0; i < 5; i++) {
        fluid_step(fl);
    }
    const double t0 = omp_get_wtime();
    for (int i = 0; i < 200; i++) {
        fluid_step(fl);
    }
    const double dt = (omp_get_wtime() - t0) / 200;
    fluid_free(fl);
    return dt;
}

/* Usage: sphere_report [drag|moving|cost|all] [radius...]; default: all, radii 5 and 8.
 * The drag position average is done for radius 5 only (it costs 4 runs). */
int main(int argc, char **argv)
{
    const char *what = argc > 1 ? argv[1] : "all";
    double rad[8] = {5.0, 8.0};
    int nr = 2;
    if (argc > 2) {
        nr = 0;
        for (int i = 2; i < argc && nr < 8; i++) {
            rad[nr++] = atof(argv[i]);
        }
    }
    const int do_drag = !strcmp(what, "all") || !strcmp(what, "drag");
    const int do_moving = !strcmp(what, "all") || !strcmp(what, "moving");
    const int do_cost = !strcmp(what, "all") || !strcmp(what, "cost");
    static const char *sname[] = {"bounce_back", "yu", "cli", "quadratic", "multireflection"};
    static const char *cname[] = {"bgk", "trt"};
    const double *radii = rad;
    if (do_drag) {
    printf("# drag error of a fixed sphere, simple cubic array D/L = 1/2 (Sangani & Acrivos 1982), tau 0.8\n");
    printf("%-6s %-16s %-5s %12s %14s %9s\n", "radius", "scheme", "coll", "err_corner%", "err_mean4pos%", "seconds");
    for (int ri = 0; ri < nr; ri++) {
        for (int sc = 0; sc < 5; sc++) {
            for (int op = 0; op < 2; op++) {
                const double t0 = omp_get_wtime();
                const int L = (int)(4 * radii[ri]);
                const double e0 = array_error(L, radii[ri], 0.8, op, sc, 0.5);
                double em = NAN;
                if (radii[ri] <= 5.0) {
                    const double offs[4] = {0.0, 0.15, 0.3, 0.5};
                    em = 0.0;
                    for (int k = 0; k < 4; k++) {
                        em += (k == 3 ? e0 : array_error(L, radii[ri], 0.8, op, sc, offs[k])) / 4.0;
                    }
                }
                printf("%-6.0f %-16s %-5s %12.3f %14.3f %9.1f\n", radii[ri], sname[sc], cname[op], 100 * e0, 100 * em,
                       omp_get_wtime() - t0);
                fflush(stdout);
            }
        }
    }
    }
    if (do_moving) {
    printf("\n# drag fluctuation (std/mean) of a sphere moving through a periodic box, 3000 steps, tau 0.8\n");
    printf("%-6s %-16s %-9s %-13s %-5s %10s %14s %9s\n", "radius", "scheme", "force", "refill", "coll", "fluct",
           "drift/step", "seconds");
    for (int ri = 0; ri < nr; ri++) {
        for (int sc = 0; sc < 5; sc++) {
            for (int fm = 0; fm < 2; fm++) {
                for (int rf = 0; rf < 2; rf++) {
                    for (int op = 0; op < 2; op++) {
                        const double t0 = omp_get_wtime();
                        const moving_t m = moving(radii[ri], op, sc, fm, rf, 3000, 1);
                        const moving_t d = moving(radii[ri], op, sc, fm, rf, 400, 0);
                        printf("%-6.0f %-16s %-9s %-13s %-5s %10.5f %14.3e %9.1f\n", radii[ri], sname[sc],
                               fm ? "galilean" : "mem", rf ? "extrapolation" : "equilibrium", cname[op], m.fluct,
                               d.drift, omp_get_wtime() - t0);
                        fflush(stdout);
                    }
                }
            }
        }
    }
    }
    if (!do_cost) {
        return 0;
    }
    const double tf = step_cost(0), tp = step_cost(1);
    printf("\n# step cost on 64^3 with one moving sphere of radius 8 (cli, galilean, extrapolation): %.3f ms vs "
           "%.3f ms pure fluid, ratio %.3f\n",
           1e3 * tp, 1e3 * tf, tp / tf);
    return 0;
}
