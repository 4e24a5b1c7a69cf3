/* approach_harness.c — see approach_harness.h. */
#include "approach_harness.h"

#include "../../fluid/fluid.h"
#include "../../rigid/rigid.h"
#include "test_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846

double brenner_lambda(double gap_a, int free_surface)
{
    const double al = acosh(1.0 + gap_a), s1 = sinh(al), s2 = sinh(2.0 * al);
    double sum = 0.0;
    for (int n = 1; n < 1000000; n++) {
        const double k = 2.0 * n + 1.0, x = (n + 0.5) * al;
        if (k * al > 700.0) {
            break; /* sinh overflows; the terms fell like exp(-(2n+1) alpha) long before */
        }
        double num, den;
        if (free_surface) {
            num = 4.0 * cosh(x) * cosh(x) + k * k * s1 * s1;
            den = 2.0 * sinh(k * al) - k * s2;
        } else {
            num = 2.0 * sinh(k * al) + k * s2;
            den = 4.0 * sinh(x) * sinh(x) - k * k * s1 * s1;
        }
        const double term = n * (n + 1.0) / ((2.0 * n - 1.0) * (2.0 * n + 3.0)) * (num / den - 1.0);
        sum += term;
        if (fabs(term) < 1e-15 * fabs(sum)) {
            break;
        }
    }
    return 4.0 / 3.0 * s1 * sum;
}

/* The film correction's lambda at surface gap g (cells): against the floor
 * reff = a, closing speed U; between the spheres reff = a/2 at 2U. */
static double lub_lambda(const approach_setup_t *set, double g)
{
    const double mu = (set->tau - 0.5) / 3.0, F0 = 6.0 * PI * mu * set->a * set->U;
    const int pair = set->kind == APPROACH_SPHERES;
    double reff, rlog;
    if (pair) {
        rigid_film_of_spheres(set->a, set->a, &reff, &rlog);
    } else {
        rigid_film_of_wall(set->a, 0, &reff, &rlog);
    }
    return rigid_lubrication_normal(mu, reff, rlog, g, pair ? 2.0 * set->U : set->U, set->cutoff, 1e-3 * set->a) / F0;
}

long harness_approach(const approach_setup_t *set, const double *gaps, int n, approach_point_t *out)
{
    const double a = set->a, U = set->U, mu = (set->tau - 0.5) / 3.0, F0 = 6.0 * PI * mu * a * U;
    const int pair = set->kind == APPROACH_SPHERES, L = set->L, Lz = set->Lz;
    for (int k = 0; k < n; k++) {
        out[k] = (approach_point_t){gaps[k], brenner_lambda(pair ? gaps[k] / 2.0 : gaps[k], pair), NAN, NAN, NAN,
                                    NAN, NAN};
    }
    scene_t s = test_box(L, L, Lz, set->tau, COLLISION_TRT);
    s.fluid.boundary_scheme = BOUNDARY_CLI;
    s.fluid.force_method = FORCE_GALILEAN;
    s.fluid.refill = REFILL_EXTRAPOLATION;
    /* the film zone of the fluid (fluid/sphere_links.c film_partner) at the harness's cut-off */
    s.contacts.lubrication.enabled = set->cutoff > 0.0;
    s.contacts.lubrication.cutoff = set->cutoff;
    scene_sphere_t sph[2];
    scene_body_t body[2];
    memset(body, 0, sizeof body);
    double v[2][3] = {{0, 0, -U}, {0, 0, -U}};
    const double g0 = set->start_gap * a;
    if (pair) {
        const double mid = Lz / 2.0 + set->offset;
        s.nbodies = 2;
        sph[0] = (scene_sphere_t){{L / 2.0, L / 2.0, mid - a - g0 / 2.0}, a};
        sph[1] = (scene_sphere_t){{L / 2.0, L / 2.0, mid + a + g0 / 2.0}, a};
        v[0][2] = U;
    } else {
        s.domain.faces[4].type = FACE_NO_SLIP;
        s.domain.faces[5].type = FACE_NO_SLIP;
        s.nbodies = 1;
        sph[0] = (scene_sphere_t){{L / 2.0, L / 2.0, a + g0}, a};
    }
    for (int b = 0; b < s.nbodies; b++) {
        body[b] = (scene_body_t){.nspheres = 1, .spheres = &sph[b], .density = 2.0, .motion = MOTION_FREE};
    }
    s.bodies = body;
    /* the period-2 watch of free spheres may remark on the first sound
     * waves; only errors count here */
    test_log_t quiet;
    log_t log = test_log(&quiet);
    fluid_t *fl = NULL;
    if (fluid_create(&s, &log, &fl) != STATUS_OK) {
        return 0;
    }
    const double w[3] = {0, 0, 0};
    double f[3], t[3];
    for (int b = 0; b < s.nbodies; b++) {
        fluid_set_sphere(fl, b, sph[b].center, v[b], w);
    }
    /* steady flow at the first gap: the change per chunk of steps decays
     * geometrically (ratio q); stop when the rest of it, d q / (1 - q), is
     * below 1e-4 of the force */
    const long chunk = 200;
    long steps = 0;
    double prev = NAN, dprev = NAN;
    for (; steps < 200000; steps += chunk) {
        for (long k = 0; k < chunk; k++) {
            if (fluid_step(fl) >= STATUS_ERROR) {
                fluid_free(fl);
                return 0;
            }
        }
        fluid_sphere_load_lattice(fl, 0, f, t);
        const double F = pair ? -f[2] : f[2], d = F - prev, q = d / dprev;
        if (steps > 10 * chunk && q > 0.0 && q < 0.99 && fabs(d * q / (1.0 - q)) < 1e-4 * fabs(F)) {
            break;
        }
        prev = F;
        dprev = d;
    }
    /* the approach: per step the gap (cells) and the lattice lambda */
    const double rate = pair ? 2.0 * U : U, g1 = set->end_gap * a;
    const long nmove = (long)((g0 - g1) / rate);
    double *gap = malloc(sizeof(double) * (size_t)(nmove + 1)), *lam = malloc(sizeof(double) * (size_t)(nmove + 1));
    long m = 0;
    for (; gap != NULL && lam != NULL && m < nmove; m++) {
        for (int b = 0; b < s.nbodies; b++) {
            sph[b].center[2] += v[b][2];
            fluid_set_sphere(fl, b, sph[b].center, v[b], w);
        }
        if (fluid_step(fl) >= STATUS_ERROR) {
            break;
        }
        fluid_sphere_load_lattice(fl, 0, f, t);
        gap[m] = g0 - rate * (m + 1);
        lam[m] = (pair ? -f[2] : f[2]) / F0;
    }
    steps += m;
    fluid_free(fl);
    if (set->trace != NULL) {
        fprintf(set->trace, "gap_over_a,lambda_lattice,lambda_film,lambda_brenner\n");
        for (long j = 0; j < m; j++) {
            fprintf(set->trace, "%.6f,%.6f,%.6f,%.6f\n", gap[j] / a, lam[j], lub_lambda(set, gap[j]),
                    brenner_lambda(pair ? gap[j] / a / 2.0 : gap[j] / a, pair));
        }
    }
    const double win = 0.25; /* cells of gap on either side: half a cell of travel */
    for (int k = 0; k < n && m == nmove; k++) {
        const double gt = gaps[k] * a;
        if (gt - win < gap[nmove - 1] || gt + win > g0) {
            continue;
        }
        double sum_t = 0.0, sum_l = 0.0, sum_s = 0.0, lo = INFINITY, hi = -INFINITY;
        long cnt = 0;
        for (long j = 0; j < m; j++) {
            if (fabs(gap[j] - gt) > win) {
                continue;
            }
            const double ref = brenner_lambda(pair ? gap[j] / a / 2.0 : gap[j] / a, pair), lub = lub_lambda(set, gap[j]);
            const double r = (lam[j] + lub) / ref;
            sum_t += r;
            sum_l += lam[j] / ref;
            sum_s += lub / (lam[j] + lub);
            lo = fmin(lo, r);
            hi = fmax(hi, r);
            cnt++;
        }
        out[k].total = sum_t / cnt;
        out[k].lattice = sum_l / cnt;
        out[k].lub_share = sum_s / cnt;
        out[k].lo = lo;
        out[k].hi = hi;
    }
    free(gap);
    free(lam);
    return m == nmove ? steps : 0;
}
