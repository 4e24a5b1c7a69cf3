/* run.c — the coupling loop of `coupler run`.
 *
 * For a fluid-only scene the loop is: fluid step, and at each output time a
 * row of fluid diagnostics (mass, momentum, kinetic energy) and, when asked
 * for, a field snapshot; a numerical-trouble check runs every CHECK_EVERY
 * steps and at every output. Output times are t0 + k * output_interval,
 * reached when the step counter passes them (no accumulated round-off). */
#include "run.h"

#include "../fluid/fluid.h"
#include "../fluid/lattice.h"
#include "output.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#define CHECK_EVERY 200
#define MACH_LIMIT 0.5

typedef struct {
    double *rho, *u;
    unsigned char *flags;
    size_t n;
} fields_t;

/* Totals over the fluid cells of fields already in SI units. */
static void summarize_fields(const fields_t *f, const units_t *un, double *mass, double mom[3], double *ke,
                             double *umax)
{
    const double cell = un->dx * un->dx * un->dx;
    double m = 0.0, jx = 0.0, jy = 0.0, jz = 0.0, e = 0.0, vmax = 0.0;
    for (size_t i = 0; i < f->n; i++) {
        if (f->flags[i] != 0) {
            continue;
        }
        const double r = f->rho[i];
        const double ux = f->u[3 * i], uy = f->u[3 * i + 1], uz = f->u[3 * i + 2];
        const double uu = ux * ux + uy * uy + uz * uz;
        m += r * cell;
        jx += r * ux * cell;
        jy += r * uy * cell;
        jz += r * uz * cell;
        e += 0.5 * r * uu * cell;
        vmax = fmax(vmax, sqrt(uu));
    }
    *mass = m;
    mom[0] = jx;
    mom[1] = jy;
    mom[2] = jz;
    *ke = e;
    *umax = vmax;
}

static void to_si(fields_t *f, const units_t *un)
{
    const double uv = units_velocity(un);
    for (size_t i = 0; i < f->n; i++) {
        f->rho[i] *= un->rho0;
        for (int a = 0; a < 3; a++) {
            f->u[3 * i + a] *= uv;
        }
    }
}

/* Plane Poiseuille check for a body-force channel: walls on exactly one axis,
 * force along another. Prints the analytic peak next to the measured one. */
static void poiseuille_summary(const scene_t *s, const units_t *un, const fields_t *f)
{
    int wall = -1, nwalls = 0, along = -1;
    for (int a = 0; a < 3; a++) {
        if (s->domain.faces[2 * a].type == FACE_NO_SLIP && s->domain.faces[2 * a + 1].type == FACE_NO_SLIP) {
            wall = a;
            nwalls++;
        } else if (s->domain.faces[2 * a].type != FACE_PERIODIC) {
            return;
        }
        if (s->fluid.body_force[a] != 0.0) {
            along = along < 0 ? a : 3;
        }
    }
    if (nwalls != 1 || along < 0 || along == 3 || along == wall) {
        return;
    }
    const double h = s->domain.size[wall], mu = s->fluid.viscosity * s->fluid.density, dx = un->dx;
    const int nh = un->n[wall];
    /* the analytic profile F/(2 mu) y (h - y) at the cell centre nearest the middle */
    const double y = (nh / 2 + 0.5) * dx;
    const double peak = s->fluid.body_force[along] / (2.0 * mu) * y * (h - y);
    double best = 0.0;
    for (size_t i = 0; i < f->n; i++) {
        if (fabs(f->u[3 * i + along]) > fabs(best)) {
            best = f->u[3 * i + along];
        }
    }
    printf("  plane Poiseuille check: peak velocity %.6g m/s, analytic %.6g m/s at the same cell centre "
           "(relative difference %.2e)\n",
           best, peak, best / peak - 1.0);
}

int run_scene(const scene_t *scene, const run_options_t *opt, const log_t *log)
{
    fluid_t *fl = NULL;
    output_t *out = NULL;
    fields_t f = {0};
    int rc = 1;
    if (fluid_create(scene, log, &fl) != STATUS_OK) {
        goto done;
    }
    const units_t *un = fluid_units(fl);
    int n[3];
    fluid_cells(fl, n);
    f.n = (size_t)n[0] * n[1] * n[2];
    f.rho = malloc(sizeof(double) * f.n);
    f.u = malloc(sizeof(double) * 3 * f.n);
    f.flags = malloc(f.n);
    if (f.rho == NULL || f.u == NULL || f.flags == NULL) {
        log_msg(log, STATUS_ERROR, "run", "out of memory for the field buffers");
        goto done;
    }
    if (output_open(opt->output, scene, un, log, &out) != STATUS_OK) {
        goto done;
    }
    const long steps = opt->steps > 0 ? opt->steps : (long)ceil(scene->run.end_time / un->dt - 1e-9);
    const double oi = scene->run.output_interval, fi = scene->run.field_interval;
    long next_out = 0, next_field = 0; /* output counters k: times k * interval */
    const int tty = !opt->quiet && isatty(fileno(stderr));
    const double wall0 = omp_get_wtime();
    double last_print = wall0, fluid_wall = 0.0;
    double mass0 = 0.0, umax = 0.0;
    for (long step = 0;; step++) {
        const double t = fluid_time(fl);
        const int last = step == steps;
        const int do_out = last || t >= next_out * oi - 1e-9 * un->dt;
        const int do_field = scene->run.fields && (last || t >= next_field * fi - 1e-9 * un->dt);
        if (do_out || do_field || step % CHECK_EVERY == 0) {
            if (fluid_check(fl, MACH_LIMIT) != STATUS_OK) {
                log_msg(log, STATUS_ERROR, "run", "stopped; %s holds the output up to t = %.6g s", opt->output,
                        (next_out - 1) * oi);
                goto done;
            }
        }
        if (do_out || do_field) {
            fluid_moments_lattice(fl, f.rho, f.u);
            fluid_flags(fl, f.flags);
            to_si(&f, un);
            double mass, mom[3], ke;
            summarize_fields(&f, un, &mass, mom, &ke, &umax);
            if (step == 0) {
                mass0 = mass;
            }
            if (do_out && output_fluid_row(out, t, mass, mom, ke) != STATUS_OK) {
                goto done;
            }
            if (do_field && output_fields(out, step, t, f.rho, f.u, f.flags) != STATUS_OK) {
                goto done;
            }
            while (next_out * oi <= t + 1e-9 * un->dt) {
                next_out++;
            }
            while (scene->run.fields && next_field * fi <= t + 1e-9 * un->dt) {
                next_field++;
            }
            if (last) {
                printf("%s: %ld steps, t = %.6g s, %d x %d x %d cells, tau %.4g, dt %.4g s\n", scene->path, steps,
                       t, n[0], n[1], n[2], un->tau, un->dt);
                printf("  fluid: mass change %.3e (relative), largest speed %.6g m/s (Mach %.3g)\n",
                       mass0 > 0 ? mass / mass0 - 1.0 : 0.0, umax, umax / units_velocity(un) * sqrt(3.0));
                poiseuille_summary(scene, un, &f);
            }
        }
        if (last) {
            break;
        }
        const double w0 = omp_get_wtime();
        fluid_step(fl);
        const double w1 = omp_get_wtime();
        fluid_wall += w1 - w0;
        if (tty && (w1 - last_print > 0.5)) {
            const double el = w1 - wall0, eta = el / (step + 1) * (steps - step - 1);
            fprintf(stderr, "\rstep %ld/%ld  t = %.4g s  wall %.1f s  ETA %.1f s  %.1f MLUPS   ", step + 1, steps,
                    fluid_time(fl), el, eta, (double)f.n * (step + 1) / fluid_wall / 1e6);
            last_print = w1;
        }
    }
    if (tty) {
        fprintf(stderr, "\n");
    }
    const double wall = omp_get_wtime() - wall0;
    printf("  wall time %.3f s (fluid %.3f s, %.1f MLUPS), output %s\n", wall, fluid_wall,
           (double)f.n * steps / fmax(fluid_wall, 1e-9) / 1e6, opt->output);
    if (output_attr(out, "wall_time_fluid", fluid_wall) != STATUS_OK ||
        output_attr(out, "wall_time_total", wall) != STATUS_OK) {
        goto done;
    }
    rc = 0;
done:
    if (output_close(out) != STATUS_OK) {
        rc = 1;
    }
    free(f.rho);
    free(f.u);
    free(f.flags);
    fluid_free(fl);
    return rc;
}
