/* forces.c — assembles every force on the spheres and bodies for one state.
 *
 * This is the single right-hand side shared by both integrators (Verlet calls
 * it at each sub-step, CVODE from its RHS callback), so that they integrate
 * the same equations. Per sphere i it sums into sf[i] (force) and st[i]
 * (torque about the sphere centre): the hydrodynamic load held over the step,
 * gravity and buoyancy (m_i - rho_f V_i) g acting at the share centroid, the
 * contacts (contact.c) and the lubrication correction (lubrication.c, whose
 * damping Verlet integrates exactly over each kick: h_kick). Per body it then forms the force and the torque
 * about the centre of mass, bt = sum st_i + (x_i - com) x sf_i. Fixed bodies
 * get zero. The body array may be a scratch copy (CVODE). */
#include "rigid_internal.h"

#include <math.h>
#include <string.h>

int rigid_body_turn(rigid_body_t *b, const double w[3], double h, double m[9])
{
    const double wn = rv_norm(w);
    if (!(wn > 0.0)) {
        return 0;
    }
    const double half = 0.5 * wn * h, sn = sin(half) / wn;
    const double dq[4] = {cos(half), sn * w[0], sn * w[1], sn * w[2]};
    double qn[4];
    rq_mul(dq, b->q, qn);
    const double n = sqrt(qn[0] * qn[0] + qn[1] * qn[1] + qn[2] * qn[2] + qn[3] * qn[3]);
    for (int k = 0; k < 4; k++) {
        b->q[k] = qn[k] / n;
    }
    rq_matrix(dq, m);
    return 1;
}

void rigid_kinematic_move(rigid_body_t *b, double h)
{
    double d[3], m[9];
    rv_sub(b->com, b->kp, d);
    if (rigid_body_turn(b, b->kw, h, m)) {
        double dn[3];
        rm_mul(m, d, dn);
        memcpy(d, dn, sizeof d);
    }
    for (int a = 0; a < 3; a++) {
        b->kp[a] += h * b->kv[a];
        b->com[a] = b->kp[a] + d[a];
    }
}

void rigid_kinematic_advance(rigid_t *r, double h)
{
    for (int bi = 0; bi < r->nbodies; bi++) {
        if (r->bodies[bi].kinematic) {
            rigid_kinematic_move(&r->bodies[bi], h);
        }
    }
}

void rigid_body_point_velocity(const rigid_body_t *b, const double a[3], double v[3])
{
    if (b->kinematic) {
        /* its pivot's velocity and the turn about the pivot: kv + kw x (x - kp) */
        double d[3], u[3];
        for (int k = 0; k < 3; k++) {
            d[k] = b->com[k] + a[k] - b->kp[k];
        }
        rv_cross(b->kw, d, u);
        for (int k = 0; k < 3; k++) {
            v[k] = b->kv[k] + u[k];
        }
        return;
    }
    if (b->fixed) {
        v[0] = v[1] = v[2] = 0.0;
        return;
    }
    double w[3], u[3];
    rigid_body_omega(b, w);
    rv_cross(w, a, u);
    for (int k = 0; k < 3; k++) {
        v[k] = b->v[k] + u[k];
    }
}

double rigid_body_compliance(const rigid_body_t *b, const double a[3], const double n[3])
{
    if (b->fixed) {
        return 0.0;
    }
    double an[3], m[9], u[3];
    rv_cross(a, n, an);
    rq_matrix(b->q, m);
    rm_tmul(m, an, u);
    return 1.0 / b->mass + u[0] * u[0] / b->inertia[0] + u[1] * u[1] / b->inertia[1] + u[2] * u[2] / b->inertia[2];
}

void rigid_sphere_world(const rigid_t *r, const rigid_body_t *bodies, int i, double x[3], double v[3], double w[3])
{
    const rigid_sphere_t *s = &r->spheres[i];
    const rigid_body_t *b = &bodies[s->body];
    double m[9], d[3], om[3];
    rq_matrix(b->q, m);
    rm_mul(m, s->p, d);
    if (b->kinematic) {
        memcpy(om, b->kw, sizeof om);
    } else if (b->fixed) {
        om[0] = om[1] = om[2] = 0.0;
    } else {
        rigid_body_omega(b, om);
    }
    if (x != NULL) {
        for (int a = 0; a < 3; a++) {
            x[a] = b->com[a] + d[a];
        }
    }
    if (v != NULL && b->kinematic) {
        rigid_body_point_velocity(b, d, v);
    } else if (v != NULL) {
        double u[3];
        rv_cross(om, d, u);
        for (int a = 0; a < 3; a++) {
            v[a] = (b->fixed ? 0.0 : b->v[a]) + u[a];
        }
    }
    if (w != NULL) {
        memcpy(w, om, sizeof om);
    }
}

/* Body force and torque about the centre of mass from the sphere loads. */
static void body_loads(rigid_t *r, const rigid_body_t *bodies)
{
    memset(r->bf, 0, sizeof(double) * 3 * (size_t)r->nbodies);
    memset(r->bt, 0, sizeof(double) * 3 * (size_t)r->nbodies);
    for (int i = 0; i < r->nspheres; i++) {
        int bi = r->spheres[i].body;
        if (bodies[bi].fixed) {
            continue;
        }
        double d[3], t[3];
        rv_sub(r->sx[i], bodies[bi].com, d);
        rv_cross(d, &r->sf[3 * i], t);
        for (int a = 0; a < 3; a++) {
            r->bf[3 * bi + a] += r->sf[3 * i + a];
            r->bt[3 * bi + a] += r->st[3 * i + a] + t[a];
        }
    }
}

double rigid_lub_kick(const rigid_t *r, double h)
{
    /* kick-drift-kick: each kick spans half a sub-step */
    return r->cfg.integrator == RIGID_VERLET ? 0.5 * h / r->cfg.substeps : 0.0;
}

int rigid_forces(rigid_t *r, const rigid_body_t *bodies, double h_kick, rigid_contact_info_t *worst)
{
    const rigid_config_t *cfg = &r->cfg;
    int ns = r->nspheres;
    r->nforces++;
    r->fault = (rigid_fault_t){RIGID_FAULT_NONE, -1, 0, 0.0};
    if (worst != NULL) {
        worst->omega0 = 0.0;
        worst->sphere_i = worst->sphere_j = -1;
    }
    for (int i = 0; i < ns; i++) {
        const rigid_sphere_t *s = &r->spheres[i];
        const rigid_body_t *b = &bodies[s->body];
        rigid_sphere_world(r, bodies, i, r->sx[i], r->sv[i], NULL);
        double m[9], arm[3], fg[3], tg[3];
        rq_matrix(b->q, m);
        double ds[3] = {s->s[0] - s->p[0], s->s[1] - s->p[1], s->s[2] - s->p[2]};
        rm_mul(m, ds, arm);
        double wgt = s->mass - cfg->fluid_density * s->volume;
        for (int a = 0; a < 3; a++) {
            fg[a] = wgt * cfg->gravity[a];
        }
        rv_cross(arm, fg, tg);
        for (int a = 0; a < 3; a++) {
            r->sf[3 * i + a] = s->load_f[a] + s->imp_f[a] + fg[a];
            r->st[3 * i + a] = s->load_t[a] + s->imp_t[a] + tg[a];
        }
    }
    int bad = rigid_contacts(r, bodies, (const double (*)[3])r->sx, worst);
    body_loads(r, bodies);
    if (rigid_lubrication(r, bodies, (const double (*)[3])r->sx, h_kick)) {
        body_loads(r, bodies);
    }
    for (int k = 0; k < 3 * r->nbodies; k++) {
        if (!isfinite(r->bf[k]) || !isfinite(r->bt[k])) {
            return -1;
        }
    }
    return bad;
}
