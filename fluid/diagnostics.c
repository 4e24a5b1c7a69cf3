/* diagnostics.c — the fluid's totals and its check for numerical trouble:
 * one pass over the grid (scan.c) gives, per z plane, exact sums of the
 * fluid cells' mass, momentum and kinetic energy, the largest speed and the
 * worst cell in trouble; here they are summed over planes and ranks, and a
 * cell in trouble is reported with step, place, cause and remedy. */
#include "fluid_internal.h"
#include "../common/coupling.h"

#include "lattice.h"
#include "scan.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

static int any_risky_coupling(const fluid_t *fl)
{
    for (int i = 0; i < fl->spheres.n; i++) {
        if (fl->spheres.s[i].kappa_risky >= COUPLING_AUTO_KAPPA) {
            return 1;
        }
    }
    return 0;
}

/* Whether any sphere moves (prescribed or free, not at rest). */
static int any_moving_sphere(const fluid_t *fl)
{
    for (int i = 0; i < fl->spheres.n; i++) {
        const sphere_t *p = &fl->spheres.s[i];
        for (int a = 0; a < 3; a++) {
            if (p->v[a] != 0.0 || p->w[a] != 0.0) {
                return 1;
            }
        }
    }
    return 0;
}

/* With a moving sphere at tau this close to 1/2 multireflection is the
 * first scheme to fail (its n^- correction hardly relaxes there): a sphere
 * of radius 5 driven down a closed box at tau 0.51 ran to 0.075 cells a step
 * with it, to 0.12 with cli (README "Stability map"). Where the lattice
 * fails the trouble spreads within a few steps, so the cell named need not
 * be next to the sphere: any moving sphere adds the hint. */
#define MR_NEAR_HALF_TAU 0.52
#define MR_NEAR_HALF_REMEDY                                                                                       \
    "with moving spheres at fluid.tau this close to 0.5, fluid.boundary_scheme: cli (or yu) stays stable at " \
    "higher sphere speeds than multireflection; "

static const char *const TROUBLE_CAUSES[] = {
    "", "velocity above the Mach limit fluid.mach_limit", "non-finite velocity (NaN or Inf)",
    "non-positive density", "non-finite density (NaN or Inf)"};

/* The error message of the cell a trouble key names: step, time, cell,
 * position in m, cause with the numbers, and what to change. Written by
 * the rank that holds the cell and logged by every rank. */
static status_t trouble_report(const fluid_t *fl, double key, double mach_limit)
{
    const grid_t *g = &fl->g;
    const decomp_t *d = &fl->d;
    const double total = (double)d->N[0] * (double)d->N[1] * (double)d->N[2];
    const int cause = (int)floor(key / total);
    const double gi = total - 1.0 - (key - (double)cause * total);
    const int G[3] = {(int)fmod(gi, d->N[0]), (int)fmod(floor(gi / d->N[0]), d->N[1]),
                      (int)floor(gi / ((double)d->N[0] * d->N[1]))};
    int mine = 1;
    for (int a = 0; a < 3; a++) {
        mine = mine && G[a] >= d->lo[a] && G[a] < d->lo[a] + d->n[a];
    }
    double owner = mine ? (double)d->rank : -1.0;
    decomp_max(d, &owner, 1);
    char text[2048] = "";
    if (mine) {
        const size_t i = grid_index(g, G[0] - d->lo[0] + 1, G[1] - d->lo[1] + 1, G[2] - d->lo[2] + 1);
        const pops_t pf = fluid_pops(fl);
        double r, u[3];
        fluid_local_moments(fl, &pf, i, &r, u);
        const double umag = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]), dx = fl->units.dx;
        /* the lattice velocity of a given flow is U dt / dx = U (tau - 1/2) dx / (3 nu): a smaller tau
         * or a smaller dx lowers it, but near tau = 1/2 a smaller tau makes the lattice less stable */
        /* faster than the lattice's speed of sound c_s no flow is meant
         * (fluid.mach_limit is at most 1): the lattice has become unstable
         * (a lid-driven cavity at tau 0.5001 runs away in a corner cell's
         * velocity before any density goes negative) */
        const int supersonic = cause == TROUBLE_MACH && umag > sqrt(LB_CS2);
        const char *remedy = cause == TROUBLE_MACH && !supersonic
                                 ? (fl->units.tau >= 0.55
                                        ? "lower the flow speed in lattice units: a smaller time step (fluid.tau "
                                          "closer to 0.5, or fluid.dt), more cells (fluid.dx), or slower walls, "
                                          "inlets, body force or bodies; raise fluid.mach_limit (at most 1) only if "
                                          "this speed is meant"
                                        : "lower the flow speed in lattice units: more cells (a smaller fluid.dx; "
                                          "fluid.tau is already close to 0.5, where a smaller tau makes the lattice "
                                          "less stable), or slower walls, inlets, body force or bodies; raise "
                                          "fluid.mach_limit (at most 1) only if this speed is meant")
                                 : fl->units.collision == COLLISION_BGK
                                       ? "the lattice became unstable: raise fluid.tau (or fluid.dt) away from 0.5, use "
                                         "TRT (fluid.collision: trt), more cells (fluid.dx), or lower the flow speed"
                                       : "the lattice became unstable: raise fluid.tau (or fluid.dt) away from 0.5, "
                                         "more cells (fluid.dx), or lower the flow speed";
        snprintf(text, sizeof text,
                 "%s: numerical trouble at step %ld (t = %.6g s), cell (%d, %d, %d) at (%.4g, %.4g, %.4g) m: "
                 "%s (density %.6g, |u| = %.4g lattice = Mach %.4g, fluid.mach_limit %.4g); %s%s%s",
                 fl->path, fl->step, fluid_time(fl), G[0], G[1], G[2], (G[0] + 0.5) * dx, (G[1] + 0.5) * dx,
                 (G[2] + 0.5) * dx, TROUBLE_CAUSES[cause], r, umag, umag / sqrt(LB_CS2), mach_limit,
                 any_risky_coupling(fl) ? RISKY_COUPLING_REMEDY "; otherwise " : "",
                 fl->spheres.scheme == BOUNDARY_MULTIREFLECTION && fl->units.tau < MR_NEAR_HALF_TAU &&
                         any_moving_sphere(fl)
                     ? MR_NEAR_HALF_REMEDY
                     : "",
                 remedy);
    }
    decomp_bcast_text(d, text, sizeof text, (int)owner);
    return log_msg(&fl->log, STATUS_ERROR, "fluid", "%s", text);
}

/* The worst trouble key of all ranks, and its report. */
static status_t trouble_finish(const fluid_t *fl, double key, double mach_limit)
{
    decomp_max(&fl->d, &key, 1);
    return key > 0.0 ? trouble_report(fl, key, mach_limit) : STATUS_OK;
}

status_t fluid_diagnostics_lattice(fluid_t *fl, double mach_limit, double *mass, double momentum[3], double *kinetic,
                                   double *umax, double peak[3])
{
    const grid_t *g = &fl->g;
    const int nz = g->n[2];
    const double umax2 = mach_limit * mach_limit * LB_CS2;
    enum { NV = SCAN_NV, NS = SCAN_NS };
    double *plane = calloc((size_t)nz * NV, sizeof(double));
    xsum_t *sums = calloc((size_t)nz * NS, sizeof(xsum_t));
    if (plane == NULL || sums == NULL || !fluid_scan(fl, umax2, plane, sums, 1)) {
        free(plane);
        free(sums);
        *mass = *kinetic = *umax = NAN;
        momentum[0] = momentum[1] = momentum[2] = peak[0] = peak[1] = peak[2] = NAN;
        return decomp_agree(&fl->d, log_msg(&fl->log, STATUS_ERROR, "fluid",
                                            "out of memory for the plane sums of the totals (%zu bytes)",
                                            (size_t)nz * (NV * sizeof(double) + NS * sizeof(xsum_t)) +
                                                scan_buffer_bytes(g)));
    }
    /* exact sums (common/exact_sum.h): the same bits for any number of
     * threads and ranks; maxima are exact anyway */
    xsum_t t[NS];
    double m[1 + 3 + 3 + 1] = {0.0}; /* umax, |peak|, peak (where |peak| is largest), trouble key */
    for (int k = 0; k < NS; k++) {
        xsum_zero(&t[k]);
    }
    for (int z = 0; z < nz; z++) {
        const double *v = plane + (size_t)z * NV;
        for (int k = 0; k < NS; k++) {
            xsum_merge(&t[k], &sums[(size_t)z * NS + k]);
        }
        m[0] = fmax(m[0], v[5]);
        for (int a = 0; a < 3; a++) {
            if (fabs(v[6 + a]) > m[1 + a]) {
                m[1 + a] = fabs(v[6 + a]);
                m[4 + a] = v[6 + a];
            }
        }
        m[7] = fmax(m[7], v[9]);
    }
    free(plane);
    free(sums);
    decomp_sum(&fl->d, t, NS);
    double largest[3] = {m[1], m[2], m[3]};
    decomp_max(&fl->d, m, 4);
    for (int a = 0; a < 3; a++) {
        /* the signed peak of a rank that holds the largest magnitude (of
         * two such ranks, the positive one) */
        m[4 + a] = largest[a] == m[1 + a] && m[1 + a] > 0.0 ? m[4 + a] : -INFINITY;
    }
    decomp_max(&fl->d, m + 4, 3);
    *mass = xsum_value(&t[0]);
    for (int a = 0; a < 3; a++) {
        momentum[a] = xsum_value(&t[1 + a]);
        peak[a] = m[1 + a] > 0.0 ? m[4 + a] : 0.0;
    }
    *kinetic = xsum_value(&t[4]);
    *umax = m[0];
    return trouble_finish(fl, m[7], mach_limit);
}

status_t fluid_check(fluid_t *fl, double mach_limit)
{
    const int nz = fl->g.n[2];
    double *plane = calloc((size_t)nz * SCAN_NV, sizeof(double));
    if (plane == NULL || !fluid_scan(fl, mach_limit * mach_limit * LB_CS2, plane, NULL, 0)) {
        free(plane);
        return decomp_agree(&fl->d, log_msg(&fl->log, STATUS_ERROR, "fluid",
                                            "out of memory for the check of the grid (%zu bytes)",
                                            (size_t)nz * SCAN_NV * sizeof(double) +
                                                scan_buffer_bytes(&fl->g)));
    }
    double worst = 0.0;
    for (int z = 0; z < nz; z++) {
        worst = fmax(worst, plane[(size_t)z * SCAN_NV + 9]);
    }
    free(plane);
    return trouble_finish(fl, worst, mach_limit);
}

