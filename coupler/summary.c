/* summary.c — the summary `coupler run` prints at the end (summary.h): the
 * final velocity of every free body, the settling velocity against Stokes
 * (the paper's Eq. 10) with a wall-corrected estimate, the plane Poiseuille
 * peak against the analytic profile, the FMI call counts. */
#include "summary.h"

#include <math.h>
#include <stdio.h>

/* Hasimoto (1959) drag factor of a simple cubic array, a = radius, L = period. */
static double hasimoto(double a_over_l)
{
    const double x = a_over_l;
    return 1.0 / (1.0 - 2.837 * x + 4.19 * x * x * x - 27.4 * pow(x, 6.0));
}

/* The one free body made of one sphere under gravity: index of the sphere, or -1. */
int summary_settling_sphere(const scene_t *s)
{
    int found = -1, nfree = 0;
    for (int b = 0, i = 0; b < s->nbodies; b++) {
        if (s->bodies[b].motion == MOTION_FREE) {
            nfree++;
            found = s->bodies[b].nspheres == 1 ? i : -2;
        }
        i += s->bodies[b].nspheres;
    }
    const double g = hypot(hypot(s->rigid.gravity[0], s->rigid.gravity[1]), s->rigid.gravity[2]);
    return nfree == 1 && found >= 0 && g > 0.0 ? found : -1;
}

void summary_settling(const scene_t *s, const double *settle_t, const double *settle_v, long nsettle, double t_end)
{
    const int i = summary_settling_sphere(s);
    if (i < 0 || nsettle == 0) {
        return;
    }
    const scene_body_t *body = NULL;
    for (int b = 0, k = 0; b < s->nbodies && body == NULL; b++) {
        body = k == i ? &s->bodies[b] : NULL;
        k += s->bodies[b].nspheres;
    }
    const double a = body->spheres[0].radius, rho_f = s->fluid.density, mu = rho_f * s->fluid.viscosity;
    const double g = hypot(hypot(s->rigid.gravity[0], s->rigid.gravity[1]), s->rigid.gravity[2]);
    const double stokes = 2.0 * g * a * a * (body->density - rho_f) / (9.0 * mu); /* the paper's Eq. 10 */
    double sum = 0.0;
    long n = 0;
    for (long k = 0; k < nsettle; k++) {
        if (settle_t[k] >= 0.8 * t_end - 1e-12 * t_end) {
            sum += settle_v[k];
            n++;
        }
    }
    const double v = n > 0 ? sum / n : 0.0;
    /* along gravity: a light sphere's are negative (it rises); Re of the speed */
    printf("  settling: terminal velocity %.4g m/s along gravity (mean over the last 20%% of the run, %ld rows), "
           "Stokes (Eq. 10) %.4g m/s, Re = %.3g\n",
           v, n, stokes, fabs(v) * 2.0 * a / s->fluid.viscosity);
    int free_slip = 1;
    double lmin = INFINITY;
    for (int f = 0; f < 6; f++) {
        free_slip &= s->domain.faces[f].type == FACE_FREE_SLIP;
        lmin = fmin(lmin, s->domain.size[f / 2]);
    }
    if (free_slip) {
        /* A free-slip wall is a mirror: for a sphere in the middle of a box
         * of side L its images in the side walls form a square array of
         * period L. The wall-corrected estimate treats the whole image system
         * as a simple cubic array of period L: Hasimoto (1959), dilute
         * periodic array of spheres, v = v_Stokes / K(a/L). */
        const double k = hasimoto(a / lmin);
        printf("  wall-corrected estimate %.4g m/s (free-slip walls as mirror images, a periodic array of period "
               "L = %.4g m: Hasimoto 1959 K = %.4f for a/L = %.4g); measured / corrected = %.4f\n",
               stokes / k, lmin, k, a / lmin, v / (stokes / k));
    }
}

void summary_poiseuille(const scene_t *s, const units_t *un, const double peak[3])
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
    if (nwalls != 1 || along < 0 || along == 3 || along == wall || s->nbodies > 0) {
        return;
    }
    const double h = s->domain.size[wall], mu = s->fluid.viscosity * s->fluid.density, dx = un->dx;
    /* the analytic profile F/(2 mu) y (h - y) at the cell centre nearest the middle */
    const double y = (un->n[wall] / 2 + 0.5) * dx;
    const double ref = s->fluid.body_force[along] / (2.0 * mu) * y * (h - y);
    printf("  plane Poiseuille check: peak velocity %.6g m/s, analytic %.6g m/s at the same cell centre "
           "(relative difference %.2e)\n",
           peak[along], ref, peak[along] / ref - 1.0);
}

void summary_calls_json(const fmu_t *f, char *buf, size_t n)
{
    size_t k = (size_t)snprintf(buf, n, "{");
    for (int c = 0; c < FMU_NCALLS && k < n; c++) {
        if (fmu_calls(f, c) > 0) {
            k += (size_t)snprintf(buf + k, n - k, "%s\"%s\": %ld", k > 1 ? ", " : "", fmu_call_names[c],
                                  fmu_calls(f, c));
        }
    }
    if (k < n) {
        snprintf(buf + k, n - k, "}");
    }
}

/* Final velocity of every free body: the r^3-weighted mean of its spheres'
 * velocities (the centre-of-mass velocity of a rigid body of one density). */
void summary_bodies(const scene_t *s, int ns, const int *ibody, const double *velocity)
{
    for (int i = 0, b0 = 0, k0 = 0; i < ns; i++) {
        /* the scene sphere i: is its body free? */
        while (k0 + s->bodies[b0].nspheres <= i) {
            k0 += s->bodies[b0].nspheres;
            b0++;
        }
        int first = 1;
        for (int j = 0; j < i; j++) {
            first &= ibody[j] != ibody[i];
        }
        if (!first || s->bodies[b0].motion != MOTION_FREE) {
            continue;
        }
        double v[3] = {0, 0, 0}, w = 0.0;
        int count = 0;
        for (int j = i, b = b0, k = k0; j < ns; j++) {
            while (k + s->bodies[b].nspheres <= j) {
                k += s->bodies[b].nspheres;
                b++;
            }
            if (ibody[j] != ibody[i]) {
                continue;
            }
            const double r3 = pow(s->bodies[b].spheres[j - k].radius, 3.0);
            for (int a = 0; a < 3; a++) {
                v[a] += r3 * velocity[3 * j + a];
            }
            w += r3;
            count++;
        }
        printf("  body %d (%d sphere%s from sphere %d): final velocity (%.6g, %.6g, %.6g) m/s\n", ibody[i], count,
               count > 1 ? "s" : "", i, v[0] / w, v[1] / w, v[2] / w);
    }
}
