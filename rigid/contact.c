/* contact.c — the contact force laws between spheres of different bodies and
 * between a sphere and a solid wall of the box.
 *
 * Normal force along n (from sphere i to the other partner) for an overlap
 * delta > 0 and an approach speed ddelta = (v_i - v_j).n at the contact point:
 *  - linear spring-dashpot: F = k delta + c ddelta with
 *      k = m_eff (pi^2 + ln^2 e) / t_c^2,  c = -2 m_eff ln e / t_c,
 *    the damped oscillator whose half period is exactly t_c and whose
 *    rebound/approach speed ratio is exactly e (e.g. Schwager & Poeschel,
 *    "Computational Granular Dynamics", 2005, ch. 3). The force is not clipped
 *    at zero, so that these two identities hold (a small tensile force near
 *    the end of the contact is the price).
 *  - Hertz: F = 4/3 E* sqrt(R*) delta^(3/2) + c ddelta, with the damping of
 *    Tsuji, Tanaka, Ishida (1992) in the form c = 2 sqrt(5/6) beta sqrt(k_t m_eff),
 *    beta = -ln e / sqrt(ln^2 e + pi^2), k_t = 2 E* sqrt(R* delta) the
 *    tangent stiffness. 1/E* = 2 (1 - nu^2)/E (both partners of the one
 *    material; a wall is taken as the same material), R* = r_i r_j/(r_i+r_j),
 *    R* = r_i against a wall.
 * Tangential (optional, friction mu > 0): regularised Coulomb
 *   F_t = -min(mu |F_n|, c_t |v_t|) v_t/|v_t|, c_t = 2 m_eff / t_c (linear) or
 *   the normal damping scale sqrt(k_t m_eff) (Hertz): below the sliding
 *   threshold the tangential slip is damped on the contact time scale, which
 *   keeps the law continuous for CVODE.
 * m_eff = m_i m_j / (m_i + m_j); a fixed body has infinite mass.
 * omega0 = sqrt(k/m_eff) is returned for the Verlet stability check. */
#include "rigid_internal.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

typedef struct {
    double fn;     /* normal force magnitude, positive = repulsive */
    double ct;     /* tangential damping scale */
    double omega0; /* natural frequency of the contact */
} contact_law_t;

static contact_law_t contact_law(const rigid_config_t *cfg, double delta, double ddelta, double meff, double rstar)
{
    contact_law_t out = {0.0, 0.0, 0.0};
    double le = log(cfg->restitution);
    if (cfg->contact_model == RIGID_CONTACT_SPRING_DASHPOT) {
        double tc = cfg->contact_time;
        double k = meff * (M_PI * M_PI + le * le) / (tc * tc);
        double c = -2.0 * meff * le / tc;
        out.fn = k * delta + c * ddelta;
        out.ct = 2.0 * meff / tc;
        out.omega0 = sqrt(k / meff);
    } else if (cfg->contact_model == RIGID_CONTACT_HERTZ) {
        double nu = cfg->poisson_ratio;
        double estar = cfg->young_modulus / (2.0 * (1.0 - nu * nu));
        double sq = sqrt(rstar * delta);
        double kt = 2.0 * estar * sq;
        double beta = -le / sqrt(le * le + M_PI * M_PI);
        double c = 2.0 * sqrt(5.0 / 6.0) * beta * sqrt(kt * meff);
        out.fn = 4.0 / 3.0 * estar * sq * delta + c * ddelta;
        out.ct = sqrt(kt * meff);
        out.omega0 = sqrt(kt / meff);
    }
    return out;
}

static double body_mass_or_inf(const rigid_body_t *b) { return b->fixed ? INFINITY : b->mass; }

static double eff_mass(double m1, double m2)
{
    if (isinf(m1)) {
        return m2;
    }
    if (isinf(m2)) {
        return m1;
    }
    return m1 * m2 / (m1 + m2);
}

/* Applies one contact: sphere i against partner j (j < 0: wall), n unit from
 * i towards the partner, pc contact point, vrel velocity of i relative to the
 * partner at pc. Adds to r->sf/st. Returns omega0. */
static double contact_apply(rigid_t *r, int i, int j, const double n[3], double delta, const double pc[3],
                            const double vrel[3], double meff, double rstar, const double xi[3], const double xj[3])
{
    const rigid_config_t *cfg = &r->cfg;
    double vn = rv_dot(vrel, n);
    contact_law_t law = contact_law(cfg, delta, vn, meff, rstar);
    double f[3]; /* force on i */
    for (int a = 0; a < 3; a++) {
        f[a] = -law.fn * n[a];
    }
    if (cfg->friction > 0.0) {
        double vt[3];
        for (int a = 0; a < 3; a++) {
            vt[a] = vrel[a] - vn * n[a];
        }
        double s = rv_norm(vt);
        if (s > 0.0) {
            double ft = fmin(cfg->friction * fabs(law.fn), law.ct * s);
            for (int a = 0; a < 3; a++) {
                f[a] -= ft * vt[a] / s;
            }
        }
    }
    double arm[3], tq[3];
    rv_sub(pc, xi, arm);
    rv_cross(arm, f, tq);
    for (int a = 0; a < 3; a++) {
        r->sf[3 * i + a] += f[a];
        r->st[3 * i + a] += tq[a];
    }
    if (j >= 0) {
        rv_sub(pc, xj, arm);
        double g[3] = {-f[0], -f[1], -f[2]};
        rv_cross(arm, g, tq);
        for (int a = 0; a < 3; a++) {
            r->sf[3 * j + a] += g[a];
            r->st[3 * j + a] += tq[a];
        }
    }
    return law.omega0;
}

/* Sphere-sphere and sphere-wall contacts. Returns >0 if an overlap exceeds a
 * radius (recoverable: the step was too long). */
int rigid_contacts(rigid_t *r, const rigid_body_t *bodies, const double (*x)[3], rigid_contact_info_t *worst)
{
    const rigid_config_t *cfg = &r->cfg;
    int bad = 0;
    if (cfg->contact_model == RIGID_CONTACT_NONE) {
        return 0;
    }
    for (int i = 0; i < r->nspheres; i++) {
        const rigid_sphere_t *si = &r->spheres[i];
        const rigid_body_t *bi = &bodies[si->body];
        for (int j = i + 1; j < r->nspheres; j++) {
            const rigid_sphere_t *sj = &r->spheres[j];
            if (sj->body == si->body) {
                continue;
            }
            const rigid_body_t *bj = &bodies[sj->body];
            if (bi->fixed && bj->fixed) {
                continue;
            }
            double dv[3];
            rv_sub(x[j], x[i], dv);
            double d = rv_norm(dv);
            double delta = si->radius + sj->radius - d;
            if (!(delta > 0.0)) {
                continue;
            }
            /* the spheres of a broken sintered neck overlap by the neck: only
             * an approach closer than at the break is a contact */
            delta = rigid_contact_reference(r, i, j) - d;
            if (!(delta > 0.0)) {
                continue;
            }
            if (delta > fmin(si->radius, sj->radius) || d == 0.0) {
                bad = 1;
                continue;
            }
            double n[3] = {dv[0] / d, dv[1] / d, dv[2] / d}, pc[3], vrel[3];
            for (int a = 0; a < 3; a++) {
                pc[a] = x[i][a] + (si->radius - 0.5 * delta) * n[a];
            }
            double wi[3], wj[3], ai[3], aj[3], ui[3], uj[3];
            rigid_body_omega(bi, wi);
            rigid_body_omega(bj, wj);
            rv_sub(pc, bi->com, ai);
            rv_sub(pc, bj->com, aj);
            rv_cross(wi, ai, ui);
            rv_cross(wj, aj, uj);
            for (int a = 0; a < 3; a++) {
                double vi = bi->fixed ? 0.0 : bi->v[a] + ui[a];
                double vj = bj->fixed ? 0.0 : bj->v[a] + uj[a];
                vrel[a] = vi - vj;
            }
            double meff = eff_mass(body_mass_or_inf(bi), body_mass_or_inf(bj));
            double rstar = si->radius * sj->radius / (si->radius + sj->radius);
            double w0 = contact_apply(r, i, j, n, delta, pc, vrel, meff, rstar, x[i], x[j]);
            if (worst != NULL && w0 > worst->omega0) {
                worst->omega0 = w0;
                worst->sphere_i = i;
                worst->sphere_j = j;
            }
        }
        if (bi->fixed) {
            continue;
        }
        for (int ax = 0; ax < 3; ax++) {
            for (int side = 0; side < 2; side++) {
                if (!cfg->walls[ax][side]) {
                    continue;
                }
                double gap = side == 0 ? x[i][ax] - cfg->box_lo[ax] : cfg->box_hi[ax] - x[i][ax];
                double delta = si->radius - gap;
                if (!(delta > 0.0)) {
                    continue;
                }
                if (delta > si->radius) {
                    bad = 1;
                    continue;
                }
                double n[3] = {0, 0, 0}, pc[3];
                n[ax] = side == 0 ? -1.0 : 1.0;
                for (int a = 0; a < 3; a++) {
                    pc[a] = x[i][a] + (si->radius - delta) * n[a];
                }
                double wi[3], ai[3], ui[3], vrel[3];
                rigid_body_omega(bi, wi);
                rv_sub(pc, bi->com, ai);
                rv_cross(wi, ai, ui);
                for (int a = 0; a < 3; a++) {
                    vrel[a] = bi->v[a] + ui[a];
                }
                double w0 = contact_apply(r, i, -1, n, delta, pc, vrel, bi->mass, si->radius, x[i], NULL);
                if (worst != NULL && w0 > worst->omega0) {
                    worst->omega0 = w0;
                    worst->sphere_i = i;
                    worst->sphere_j = -1 - 2 * ax - side;
                }
            }
        }
    }
    return bad;
}
