/* lubrication.c — the lubrication correction: the normal force of the thin
 * fluid film between two close surfaces, which the lattice cannot resolve.
 *
 * Physics. A sphere of radius a approaching a no-slip plane at speed U and
 * surface gap h feels, in Stokes flow, F = 6 pi mu a U lambda, with
 * lambda -> a/h as h -> 0 (Brenner 1961, Chem. Eng. Sci. 16, 242; the exact
 * series is in shared/reference/validation-references.md). Two spheres
 * closing at V across a gap h: F = 6 pi mu reff^2 V / h with
 * reff = r_i r_j / (r_i + r_j) (Cooley & O'Neill 1969, Mathematika 16, 37;
 * Jeffrey 1982, Mathematika 29, 58), for equal spheres F = (3/2) pi mu a^2 V/h.
 * A free-slip (free-surface) plane is the mirror plane of two equal spheres,
 * lambda -> a/(4h): reff = a/2. So one form serves every pair,
 *     F = 6 pi mu reff^2 vn / h,   reff = r_i r_j/(r_i + r_j) | r | r/2.
 * Inlet and outlet faces are no solid surface: contact only, no film.
 *
 * The film zone and the cut-off h_c (Nguyen & Ladd 2002, Phys. Rev. E 66,
 * 046708, for the cut-off). The lattice resolves the flow in a gap of a few
 * cells; below that its force depends on whether a row of nodes lies in the
 * gap. So the fluid leaves out its own normal force on the zone where the
 * surfaces are closer than h_c (fluid/sphere_links.c film_partner), and this file
 * gives the film force of that zone: in lubrication theory (Reynolds) the
 * pressure at distance rho from the line of centres is 3 mu reff vn / h(rho)^2,
 * h = h_0 + rho^2/(2 reff), whose integral over h < h_c is
 * 6 pi mu reff^2 vn (1/h_0 - 1/h_c); the next term of the exact near field,
 * 6 pi mu rlog vn ln(1/h) (Jeffrey & Onishi 1984, J. Fluid Mech. 139, 261:
 * their g2 = b (1 + 7b + b^2) / (5 (1 + b)^3), b = r_j/r_i, in units of r_i;
 * r/5 against a no-slip wall, Brenner's series; 9r/20 against a free
 * surface, its mirror pair), spreads evenly over ln h and so gives the zone
 * rlog ln(h_c/h_0). Together
 *     F = 6 pi mu vn [reff^2 (1/h - 1/h_c) + rlog ln(h_c/h)],  h = max(h_0, h_min),
 * for h_0 < h_c, else 0: the exact force at h_0 minus the exact force at h_c
 * to O(h ln h) (test_lubrication.c: 5e-4 of Brenner's table), zero and
 * continuous at the cut-off, nothing counted twice. h_min (surface
 * roughness) keeps it finite in contact and in overlap (h < 0), where the
 * contact law takes over.
 *
 * Only the normal part: the tangential (shear and rolling) singularities grow
 * only like ln(a/h) (Goldman, Cox & Brenner 1967; O'Neill & Stewartson 1967),
 * so the lattice resolves most of them down to a cell, and in contact the
 * friction of contact.c takes over.
 *
 * Stiffness. The film is a pure damper with coefficient
 * c = F/vn, which near contact exceeds m_eff/h_step by
 * orders of magnitude: an explicit kick would reverse the approach and blow
 * up. With h_kick > 0 (Verlet) each kick integrates the film exactly: over a
 * kick of length k the relative normal speed of the pair obeys
 * m_eff dv/dt = F_o - c v (F_o: the other forces along n, held over the
 * kick), whose solution v' = v e^-x + (F_o/c)(1 - e^-x), x = c k / m_eff, is
 * what the film force
 *     F = c (phi(x) v + k psi(x) a_o),  phi = (1 - e^-x)/x,  psi = (1 - phi)/x
 * gives in one kick (a_o = F_o/m_eff: the relative normal acceleration from
 * the other forces). For F_o = 0 this is F = m_eff v (1 - e^-x)/k: the
 * approach is slowed, never reversed; for x >> 1 the film carries F_o and the
 * speed is the quasi-steady F_o/c, however long the step. m_eff is the
 * effective mass along n at the contact point (rotation included:
 * 1/m = 1/M + (a x n).I^-1 (a x n) per body). When a body has several films
 * at once (an agglomerate settling on a floor on several spheres) each film
 * alone would take the whole speed and together they would overshoot, so x
 * of a film is k times the sum over both bodies of all their films' rates
 * c/m_b: for one body on n equal films the kick is again exact. CVODE gets
 * the plain force c v (h_kick = 0; BDF handles the stiffness). */
#include "rigid_internal.h"

#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

double rigid_lubrication_normal(double mu, double reff, double rlog, double gap, double vn, double cutoff,
                                double min_gap)
{
    if (!(gap < cutoff)) {
        return 0.0;
    }
    double h = fmax(gap, min_gap);
    const double lead = reff * reff * (1.0 / h - 1.0 / cutoff);
    return 6.0 * M_PI * mu * vn * (rlog != 0.0 ? lead + rlog * log(cutoff / h) : lead);
}

void rigid_film_of_spheres(double ri, double rj, double *reff, double *rlog)
{
    const double b = rj / ri;
    *reff = ri * rj / (ri + rj);
    *rlog = ri * b * (1.0 + 7.0 * b + b * b) / (5.0 * (1.0 + b) * (1.0 + b) * (1.0 + b));
}

void rigid_film_of_wall(double r, int free_slip, double *reff, double *rlog)
{
    *reff = free_slip ? 0.5 * r : r;
    *rlog = free_slip ? 0.45 * r : 0.2 * r;
}

typedef struct {
    double mu, h_kick;
    int apply; /* 0: sum the rates per body, 1: apply the forces */
    const double (*x)[3];
} lub_ctx_t;

/* The film lengths of a pair (rigid_film_of_spheres, rigid_film_of_wall);
 * 0 where there is no film to squeeze */
static double pair_film(const rigid_t *r, const rigid_pair_t *p, double *rlog)
{
    double ri = r->spheres[p->i].radius, reff = 0.0;
    *rlog = 0.0;
    if (p->j >= 0) {
        /* fragments of one scene body (and the broken sintered necks among
         * them, solid rather than a film): the fluid keeps the lattice's own
         * force between spheres of one scene body (fluid/sphere_links.c
         * film_partner), so a film here would count it twice */
        if (r->spheres[p->i].orig_body == r->spheres[p->j].orig_body) {
            return 0.0;
        }
        rigid_film_of_spheres(ri, r->spheres[p->j].radius, &reff, rlog);
        return reff;
    }
    switch (r->cfg.wall_kind[p->face / 2][p->face % 2]) {
    case RIGID_WALL_NO_SLIP:
        rigid_film_of_wall(ri, 0, &reff, rlog);
        return reff;
    case RIGID_WALL_FREE_SLIP:
        rigid_film_of_wall(ri, 1, &reff, rlog);
        return reff;
    default:
        return 0.0;
    }
}

/* Acceleration of the material of body bi at arm a from its centre of mass
 * under the body force and torque r->bf, r->bt (centripetal part left out). */
static void point_accel(const rigid_t *r, const rigid_body_t *bodies, int bi, const double a[3], double acc[3])
{
    const rigid_body_t *b = &bodies[bi];
    if (b->fixed) {
        acc[0] = acc[1] = acc[2] = 0.0;
        return;
    }
    double m[9], tb[3], alpha[3], u[3];
    rq_matrix(b->q, m);
    rm_tmul(m, &r->bt[3 * bi], tb);
    for (int k = 0; k < 3; k++) {
        tb[k] /= b->inertia[k];
    }
    rm_mul(m, tb, alpha);
    rv_cross(alpha, a, u);
    for (int k = 0; k < 3; k++) {
        acc[k] = r->bf[3 * bi + k] / b->mass + u[k];
    }
}

/* phi(x) = (1 - e^-x)/x and psi(x) = (1 - phi)/x, by series near 0 */
static void decay_factors(double x, double *phi, double *psi)
{
    if (x < 1e-4) {
        *phi = 1.0 - x / 2.0 + x * x / 6.0;
        *psi = 0.5 - x / 6.0 + x * x / 24.0;
        return;
    }
    *phi = -expm1(-x) / x;
    *psi = (1.0 - *phi) / x;
}

static int lub_pair(rigid_t *r, const rigid_body_t *bodies, const rigid_pair_t *p, void *ctx)
{
    const lub_ctx_t *c = ctx;
    const rigid_config_t *cfg = &r->cfg;
    double rlog, reff = pair_film(r, p, &rlog);
    if (reff == 0.0) {
        return 0;
    }
    double coef = rigid_lubrication_normal(c->mu, reff, rlog, p->gap, 1.0, cfg->lub_cutoff, cfg->lub_min_gap);
    if (!(coef > 0.0)) {
        return 0;
    }
    int bi = r->spheres[p->i].body, bj = p->j >= 0 ? r->spheres[p->j].body : -1;
    if (!c->apply) {
        r->lub_rate[bi] += coef * rigid_body_compliance(&bodies[bi], p->ai, p->n);
        if (bj >= 0) {
            r->lub_rate[bj] += coef * rigid_body_compliance(&bodies[bj], p->aj, p->n);
        }
        return 0;
    }
    double vn = rv_dot(p->vrel, p->n), fn = coef * vn;
    if (c->h_kick > 0.0) {
        double rate = r->lub_rate[bi] + (bj >= 0 ? r->lub_rate[bj] : 0.0), phi, psi, acc_i[3], acc_j[3] = {0, 0, 0};
        decay_factors(c->h_kick * rate, &phi, &psi);
        point_accel(r, bodies, bi, p->ai, acc_i);
        if (bj >= 0) {
            point_accel(r, bodies, bj, p->aj, acc_j);
        }
        double a_o = rv_dot(acc_i, p->n) - rv_dot(acc_j, p->n);
        fn = coef * (phi * vn + c->h_kick * psi * a_o);
    }
    double f[3], arm[3], tq[3];
    for (int a = 0; a < 3; a++) {
        f[a] = -fn * p->n[a];
    }
    rv_sub(p->pc, c->x[p->i], arm);
    rv_cross(arm, f, tq);
    for (int a = 0; a < 3; a++) {
        r->sf[3 * p->i + a] += f[a];
        r->st[3 * p->i + a] += tq[a];
    }
    if (p->j >= 0) {
        double g[3] = {-f[0], -f[1], -f[2]};
        rv_sub(p->pc, p->xj, arm);
        rv_cross(arm, g, tq);
        for (int a = 0; a < 3; a++) {
            r->sf[3 * p->j + a] += g[a];
            r->st[3 * p->j + a] += tq[a];
        }
    }
    return 1;
}

int rigid_lubrication(rigid_t *r, const rigid_body_t *bodies, const double (*x)[3], double h_kick)
{
    const rigid_config_t *cfg = &r->cfg;
    lub_ctx_t c = {cfg->fluid_density * cfg->fluid_viscosity, h_kick, 0, x};
    if (!cfg->lubrication || !(c.mu > 0.0)) {
        return 0;
    }
    if (h_kick > 0.0) {
        memset(r->lub_rate, 0, sizeof(double) * (size_t)r->nbodies);
        rigid_pairs_visit(r, bodies, x, cfg->lub_cutoff, lub_pair, &c);
    }
    c.apply = 1;
    return rigid_pairs_visit(r, bodies, x, cfg->lub_cutoff, lub_pair, &c);
}
