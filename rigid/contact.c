/* contact.c — the contact force laws between spheres of different bodies and
 * between a sphere and a wall face of the box (every non-periodic face: no-slip,
 * free-slip, moving, inlet, outlet; a wall has infinite mass and the
 * same material). The pairs, their nearest periodic image and the relative
 * velocity at the contact point (against a moving wall's velocity) come from
 * pairs.c.
 *
 * The mass of a contact (rigid_contact_pair_mass) is that of its point along
 * the normal n, rotation included:
 *     1/m_n = sum over the two partners of 1/M + (a x n).I^-1 (a x n),
 * a the arm from the partner's centre of mass to the contact point, I its
 * inertia (world frame); a fixed body or a wall adds 0. A normal impulse J at
 * the point changes the relative normal velocity there by J/m_n (e.g. Brach,
 * "Mechanical Impact Dynamics", 1991, ch. 5), so the overlap of a single
 * frictionless contact obeys m_n delta'' = -F_n while the arms do not turn
 * much during it. For spheres struck through their centre (a along n)
 * m_n = m_eff = m_i m_j/(m_i + m_j); at a rod's end it is smaller (seven
 * spheres: M/3.19).
 *
 * Normal force along n (from sphere i to the other partner) for an overlap
 * delta > 0 and an approach speed ddelta = (v_i - v_j).n at the contact point:
 *  - linear spring-dashpot: F = k delta + c ddelta with
 *      k = m_n (pi^2 + ln^2 e) / t_c^2,  c = -2 m_n ln e / t_c,
 *    the damped oscillator whose half period is exactly t_c and whose
 *    rebound/approach speed ratio is exactly e (e.g. Schwager & Poeschel,
 *    "Computational Granular Dynamics", 2005, ch. 3), for the contact point's
 *    normal motion whatever the geometry: so a single frictionless impact
 *    lasts t_c and the contact point's normal velocity rebounds with e (with
 *    the translational m_eff a rod of two spheres struck at its end at 30
 *    degrees got 0.81 t_c and e 0.64 for 0.7). The force is not clipped at
 *    zero, so that these two identities hold (a small tensile force near the
 *    end of the contact is the price).
 *  - Hertz: F = 4/3 E* sqrt(R*) delta^(3/2) + c ddelta, with the damping of
 *    Tsuji, Tanaka, Ishida (1992) in the form c = 2 sqrt(5/6) beta sqrt(k_t m_n),
 *    beta = -ln e / sqrt(ln^2 e + pi^2), k_t = 2 E* sqrt(R* delta) the
 *    tangent stiffness. 1/E* = 2 (1 - nu^2)/E (both partners of the one
 *    material; a wall is taken as the same material), R* = r_i r_j/(r_i+r_j),
 *    R* = r_i against a wall. The restitution this gives depends on beta
 *    alone (not on speed or mass) but is not e; on m_n it is the same for
 *    every geometry.
 * Tangential (optional, friction mu > 0): regularised Coulomb
 *   F_t = -min(mu |F_n|, c_t |v_t|) v_t/|v_t|, c_t = 2 m_eff / t_c (linear) or
 *   sqrt(k_t m_eff) (Hertz), m_eff the translational reduced mass (a fixed
 *   body has infinite mass): below the sliding threshold the tangential slip
 *   is damped on the contact time scale, which keeps the law continuous for
 *   CVODE.
 * omega0 = sqrt(k/m_n) (sqrt(k_t/m_n), Hertz) is returned: the frequency at
 * which the contact answers, for Verlet's stability check.
 *
 * Faults (r->fault, rigid_fault_report): an overlap deeper than a radius (the
 * contact is too soft for the impact or the step too long), and, without a
 * contact model, a sphere of a free body that reaches a wall (gap <= 0): a
 * body must never leave the domain silently. Spheres of different bodies
 * without a contact model pass through each other, as in the paper. */
#include "rigid_internal.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

typedef struct {
    double fn;     /* normal force magnitude, positive = repulsive */
    double ct;     /* tangential damping scale */
    double omega0; /* natural frequency of the contact */
} contact_law_t;

/* mn: the contact point's mass along n (normal law), mt: the translational
 * reduced mass (friction's damping scale). */
static contact_law_t contact_law(const rigid_config_t *cfg, double delta, double ddelta, double mn, double mt,
                                 double rstar)
{
    contact_law_t out = {0.0, 0.0, 0.0};
    double le = log(cfg->restitution);
    if (cfg->contact_model == RIGID_CONTACT_SPRING_DASHPOT) {
        double tc = cfg->contact_time;
        double k = mn * (M_PI * M_PI + le * le) / (tc * tc);
        double c = -2.0 * mn * le / tc;
        out.fn = k * delta + c * ddelta;
        out.ct = 2.0 * mt / tc;
        out.omega0 = sqrt(k / mn);
    } else if (cfg->contact_model == RIGID_CONTACT_HERTZ) {
        double nu = cfg->poisson_ratio;
        double estar = cfg->young_modulus / (2.0 * (1.0 - nu * nu));
        double sq = sqrt(rstar * delta);
        double kt = 2.0 * estar * sq;
        double beta = -le / sqrt(le * le + M_PI * M_PI);
        double c = 2.0 * sqrt(5.0 / 6.0) * beta * sqrt(kt * mn);
        out.fn = 4.0 / 3.0 * estar * sq * delta + c * ddelta;
        out.ct = sqrt(kt * mt);
        out.omega0 = sqrt(kt / mn);
    }
    return out;
}

double rigid_contact_normal_force(const rigid_config_t *cfg, double delta, double ddelta, double mn, double rstar,
                                  double *omega0)
{
    const contact_law_t law = contact_law(cfg, delta, ddelta, mn, mn, rstar);
    *omega0 = law.omega0;
    return law.fn;
}

/* The spring part of each law integrated over the overlap: k delta^2 / 2
 * (linear), 8/15 E* sqrt(R*) delta^(5/2) (Hertz). */
double rigid_contact_elastic_energy(const rigid_config_t *cfg, double delta, double mn, double rstar)
{
    if (cfg->contact_model == RIGID_CONTACT_SPRING_DASHPOT) {
        const double le = log(cfg->restitution), tc = cfg->contact_time;
        return 0.5 * mn * (M_PI * M_PI + le * le) / (tc * tc) * delta * delta;
    }
    if (cfg->contact_model == RIGID_CONTACT_HERTZ) {
        const double nu = cfg->poisson_ratio, estar = cfg->young_modulus / (2.0 * (1.0 - nu * nu));
        return 8.0 / 15.0 * estar * sqrt(rstar) * pow(delta, 2.5);
    }
    return 0.0;
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
 * partner at pc; mn, mt: the point's mass along n and the translational
 * reduced mass. Adds to r->sf/st. Returns omega0. */
static double contact_apply(rigid_t *r, int i, int j, const double n[3], double delta, const double pc[3],
                            const double vrel[3], double mn, double mt, double rstar, const double xi[3],
                            const double xj[3])
{
    const rigid_config_t *cfg = &r->cfg;
    double vn = rv_dot(vrel, n);
    contact_law_t law = contact_law(cfg, delta, vn, mn, mt, rstar);
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

void rigid_contact_pair_mass(const rigid_t *r, const rigid_body_t *bodies, const rigid_pair_t *p, double *mn,
                             double *meff, double *rstar)
{
    const rigid_sphere_t *si = &r->spheres[p->i];
    const rigid_body_t *bi = &bodies[si->body];
    double inv = rigid_body_compliance(bi, p->ai, p->n);
    if (p->j >= 0) {
        const rigid_sphere_t *sj = &r->spheres[p->j];
        const rigid_body_t *bj = &bodies[sj->body];
        inv += rigid_body_compliance(bj, p->aj, p->n);
        *meff = eff_mass(body_mass_or_inf(bi), body_mass_or_inf(bj));
        *rstar = si->radius * sj->radius / (si->radius + sj->radius);
    } else {
        *meff = bi->mass;
        *rstar = si->radius;
    }
    /* the pair visit never gives two fixed partners, so inv > 0 */
    *mn = 1.0 / inv;
}

/* Records the first fault of a force evaluation. */
static int fault(rigid_t *r, rigid_fault_kind_t kind, const rigid_pair_t *p)
{
    if (r->fault.kind == RIGID_FAULT_NONE) {
        r->fault = (rigid_fault_t){kind, p->i, p->j, p->gap};
    }
    return 1;
}

typedef struct {
    const double (*x)[3];
    rigid_contact_info_t *worst;
} contact_ctx_t;

static int contact_pair(rigid_t *r, const rigid_body_t *bodies, const rigid_pair_t *p, void *ctx)
{
    const contact_ctx_t *c = ctx;
    const rigid_config_t *cfg = &r->cfg;
    const rigid_sphere_t *si = &r->spheres[p->i];
    if (cfg->contact_model == RIGID_CONTACT_NONE) {
        /* spheres of different bodies pass through each other (the paper's
         * setting); a wall stops the run instead of being crossed silently */
        return p->j < 0 ? fault(r, RIGID_FAULT_NO_MODEL, p) : 0;
    }
    if (!(p->gap < 0.0)) {
        return 0;
    }
    double delta = -p->gap, mn, meff, rstar;
    if (delta > (p->j >= 0 ? fmin(si->radius, r->spheres[p->j].radius) : si->radius)) {
        return fault(r, RIGID_FAULT_DEEP, p);
    }
    rigid_contact_pair_mass(r, bodies, p, &mn, &meff, &rstar);
    /* w0: the frequency at which the contact answers, its stiffness against
     * the contact point's mass m_n, so that Verlet's refusal sees the step it
     * needs */
    const double w0 = contact_apply(r, p->i, p->j, p->n, delta, p->pc, p->vrel, mn, meff, rstar, c->x[p->i], p->xj);
    if (c->worst != NULL && w0 > c->worst->omega0) {
        c->worst->omega0 = w0;
        c->worst->sphere_i = p->i;
        c->worst->sphere_j = p->j;
    }
    return 0;
}

/* Sphere-sphere and sphere-wall contacts. Returns >0 after a fault (an
 * overlap beyond a radius, or a wall reached without a contact model),
 * recorded in r->fault. */
int rigid_contacts(rigid_t *r, const rigid_body_t *bodies, const double (*x)[3], rigid_contact_info_t *worst)
{
    contact_ctx_t c = {x, worst};
    return rigid_pairs_visit(r, bodies, x, 0.0, contact_pair, &c);
}

status_t rigid_fault_report(const rigid_t *r, const rigid_fault_t *f, double t)
{
    const rigid_config_t *cfg = &r->cfg;
    int i = f->sphere_i, j = f->sphere_j, bi = r->spheres[i].body;
    if (f->kind == RIGID_FAULT_NO_MODEL) {
        return log_msg(&r->log, STATUS_ERROR, RIGID_CAT,
                       "body %d sphere %d reached face %s at t = %.9g s (gap %.3g m): no contact model is set "
                       "(contacts.model: none); set contacts.model: spring_dashpot or hertz to let bodies touch walls",
                       bi, i, rigid_face_name(-1 - j), t, f->gap);
    }
    const char *fix = cfg->contact_model == RIGID_CONTACT_HERTZ ? "raise contacts.young_modulus"
                                                                : "shorten contacts.contact_time";
    if (j < 0) {
        return log_msg(&r->log, STATUS_ERROR, RIGID_CAT,
                       "body %d sphere %d overlaps face %s by %.3g m, more than its radius %g m, at t = %.9g s: "
                       "the contact is too soft for this impact or the step too long; %s or raise rigid.substeps",
                       bi, i, rigid_face_name(-1 - j), -f->gap, r->spheres[i].radius, t, fix);
    }
    return log_msg(&r->log, STATUS_ERROR, RIGID_CAT,
                   "body %d sphere %d and body %d sphere %d overlap by %.3g m, more than the smaller radius %g m, at "
                   "t = %.9g s: the contact is too soft for this impact or the step too long; %s or raise "
                   "rigid.substeps",
                   bi, i, r->spheres[j].body, j, -f->gap, fmin(r->spheres[i].radius, r->spheres[j].radius), t, fix);
}
