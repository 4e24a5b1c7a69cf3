/* coupling.c — the per-body choice of the hydrodynamic coupling.
 *
 * Explicit coupling holds the fluid's load of step n over the rigid step
 * n -> n+1. The load reacts at once to the particle velocity through the
 * moving-wall term of the boundary links (-dF/dv = zeta), so the velocity
 * error is fed back with the factor 1 - h zeta / m per step, plus a delayed
 * response of the fluid next to the wall that alternates sign every step:
 * a light or small particle oscillates with period 2 and blows up (the
 * added-mass instability of partitioned schemes). The implicit coupling
 * (rigid/implicit.c) takes zeta into the rigid step, force averaging over two
 * steps (fluid) removes the period-2 part of the delayed response; together
 * they are stable down to density ratio 0.03 (README, stability table).
 *
 * kappa = h zeta / m is estimated from the geometry alone, before any step.
 * A bounce-back link in direction q at a wall moving with u returns
 * -6 w_q rho (c_q . u) more than at rest, so its force changes by
 * 6 w_q rho (c_q . u) c_q; along u, averaged over the directions of u, that
 * is 2 w_q rho |c_q|^2 |u|. A sphere of radius a is cut by
 * int_{c_q . n < 0} |c_q . n| dA = pi a^2 |c_q| links in direction q, so
 *   zeta = 2 pi a^2 rho sum_q w_q |c_q|^3 = 4 pi a^2 rho (1 + 2 sqrt 2) / 6
 * (D3Q19: sum_q w_q |c_q|^3 = (1 + 2 sqrt 2) / 3; lattice units, h = 1;
 * 289 for a = 6, where tests/fluid/test_spheres.c measures 288-290), and
 * kappa ~ 1.9 / (a rho_p / rho_f) for one sphere. For a body, zeta and m are
 * summed over its spheres (overlaps counted twice in both: an estimate).
 * Under rigid.coupling: auto a body with kappa >= COUPLING_AUTO_KAPPA gets
 * the implicit coupling with averaging; only heavy, large particles (kappa
 * below 0.025, e.g. density ratio 10 at radius 8 cells), whose coupling
 * error is negligible either way, keep the paper's explicit scheme. Explicit
 * coupling became unstable at kappa ~ 0.3 (radius 3 at density ratio 2,
 * radius 5 at 1.17 with tau 0.54), so the threshold keeps a margin of ten. */
#include "coupling.h"

#include <math.h>
#include <stdio.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

double coupling_drag_estimate(double r_cells)
{
    return 4.0 * M_PI * r_cells * r_cells * (1.0 + 2.0 * sqrt(2.0)) / 6.0;
}

static double body_kappa(const scene_t *s, int b)
{
    const scene_body_t *body = &s->bodies[b];
    double zeta = 0.0, vol = 0.0;
    for (int k = 0; k < body->nspheres; k++) {
        const double a = body->spheres[k].radius / s->fluid.dx;
        zeta += coupling_drag_estimate(a);
        vol += 4.0 / 3.0 * M_PI * a * a * a;
    }
    const double ratio = body->density / s->fluid.density;
    return zeta / (ratio * vol);
}

body_coupling_t coupling_of_body(const scene_t *s, int b)
{
    body_coupling_t c = {COUPLING_EXPLICIT, 0, 0.0};
    if (s->bodies[b].motion != MOTION_FREE) {
        return c;
    }
    c.kappa = body_kappa(s, b);
    c.coupling = s->rigid.coupling != COUPLING_AUTO ? s->rigid.coupling
                 : c.kappa >= COUPLING_AUTO_KAPPA  ? COUPLING_IMPLICIT
                                                   : COUPLING_EXPLICIT;
    /* fluid.force_averaging given: as given; not given (-1): with the implicit coupling */
    c.averaging = s->fluid.force_averaging >= 0 ? s->fluid.force_averaging : c.coupling == COUPLING_IMPLICIT;
    return c;
}

void coupling_describe(const scene_t *s, int b, char *buf, size_t size)
{
    const body_coupling_t c = coupling_of_body(s, b);
    const char *name = s->bodies[b].name != NULL ? s->bodies[b].name : "";
    if (s->bodies[b].motion != MOTION_FREE) {
        snprintf(buf, size, "body %d %s: %s, no coupling", b, name,
                 s->bodies[b].motion == MOTION_FIXED ? "fixed" : "prescribed");
        return;
    }
    char why[160] = "as set by rigid.coupling";
    if (s->rigid.coupling == COUPLING_AUTO) {
        snprintf(why, sizeof why, c.coupling == COUPLING_IMPLICIT
                                      ? "auto: kappa >= %g, explicit coupling would risk the period-2 (added-mass) "
                                        "instability"
                                      : "auto: kappa < %g, a heavy body: the paper's scheme",
                 COUPLING_AUTO_KAPPA);
    }
    snprintf(buf, size, "body %d %s: %s%s (kappa = h zeta/m = %.3g, density ratio %.3g; %s)", b, name,
             c.coupling == COUPLING_IMPLICIT ? "implicit" : "explicit",
             c.averaging ? " + force averaging" : "", c.kappa, s->bodies[b].density / s->fluid.density, why);
}
