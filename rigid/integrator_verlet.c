/* integrator_verlet.c — Stoermer-Verlet (kick-drift-kick) with a symplectic
 * splitting of the free rotation.
 *
 * Translation is the paper's second-order Stoermer-Verlet (velocity form):
 *   v += h/2 F/M;  x += h v;  F = F(x, v);  v += h/2 F/M.
 * Rotation uses the same kick-drift-kick with the world angular momentum L as
 * momentum: L += h/2 T; free-rotor drift; L += h/2 T. The free-rotor drift is
 * the symmetric splitting of the kinetic energy sum_k pi_k^2 / (2 I_k) into
 * exact rotations about the principal axes, R1(h/2) R2(h/2) R3(h) R2(h/2)
 * R1(h/2) (Dullweber, Leimkuhler, McLachlan, J. Chem. Phys. 107 (1997) 5840;
 * equivalent to NO_SQUISH, Miller et al., J. Chem. Phys. 116 (2002) 8649).
 * Each factor is an exact flow, so |L| is conserved to round-off, the map is
 * symplectic and time-reversible, and the energy error stays bounded (no
 * drift) over long runs — the property the torque-free top test checks.
 * Velocity-dependent forces (dashpots, friction) in the second kick use the
 * half-step velocity.
 *
 * Stability: with a contact of natural frequency omega0 = sqrt(k/m) (m: the
 * mass of the contact point along the normal, rotation included) the
 * scheme is unstable for h omega0 > 2 (less with damping). A sub-step with
 * h omega0 > 1 is refused with STATUS_ERROR naming the contact, bodies and
 * time, instead of producing garbage; non-finite forces and the faults of
 * contact.c (an overlap beyond a radius, a wall reached without a contact
 * model) likewise. Below that limit an unresolved contact can still return
 * more energy than it took (up to 1.11 times the approach speed at
 * h omega0 = 0.9, e = 1): the contact watch (contact_watch.c) checks every
 * sub-step. The lubrication damping needs no such limit: each kick
 * integrates it exactly (lubrication.c, h_kick = half a sub-step). */
#include "rigid_internal.h"

#include <string.h>

#define VERLET_MAX_H_OMEGA 1.0

static status_t verlet_create(rigid_t *r, void **data)
{
    (void)r;
    *data = NULL;
    return STATUS_OK;
}

static void verlet_free(void *data) { (void)data; }

/* Exact free rotation about principal axis k by tau pi_k / I_k. */
static void rotate_axis(rigid_body_t *b, double pi[3], int k, double tau)
{
    double th = tau * pi[k] / b->inertia[k];
    double c = cos(th), s = sin(th);
    int a = (k + 1) % 3, bb = (k + 2) % 3;
    double pa = pi[a], pb = pi[bb];
    pi[a] = c * pa + s * pb;
    pi[bb] = -s * pa + c * pb;
    double dq[4] = {cos(0.5 * th), 0, 0, 0}, qn[4];
    dq[1 + k] = sin(0.5 * th);
    rq_mul(b->q, dq, qn);
    double n = sqrt(qn[0] * qn[0] + qn[1] * qn[1] + qn[2] * qn[2] + qn[3] * qn[3]);
    for (int m = 0; m < 4; m++) {
        b->q[m] = qn[m] / n;
    }
}

static void free_rotor(rigid_body_t *b, double h)
{
    double m[9], pi[3];
    rq_matrix(b->q, m);
    rm_tmul(m, b->l, pi);
    rotate_axis(b, pi, 0, 0.5 * h);
    rotate_axis(b, pi, 1, 0.5 * h);
    rotate_axis(b, pi, 2, h);
    rotate_axis(b, pi, 1, 0.5 * h);
    rotate_axis(b, pi, 0, 0.5 * h);
}

static status_t verlet_forces(rigid_t *r, double t)
{
    rigid_contact_info_t worst;
    double hs = r->h_sub_current;
    int rc = rigid_forces(r, r->bodies, 0.5 * hs, &worst);
    if (rc < 0) {
        for (int b = 0; b < r->nbodies; b++) {
            if (!isfinite(r->bf[3 * b] + r->bf[3 * b + 1] + r->bf[3 * b + 2] + r->bt[3 * b] + r->bt[3 * b + 1] +
                          r->bt[3 * b + 2])) {
                return log_msg(&r->log, STATUS_ERROR, RIGID_CAT,
                               "verlet: non-finite force or torque on body %d at t=%.9g s", b, t);
            }
        }
        return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "verlet: non-finite force at t=%.9g s", t);
    }
    if (worst.sphere_i >= 0 && worst.omega0 * hs > VERLET_MAX_H_OMEGA) {
        int i = worst.sphere_i, j = worst.sphere_j;
        char other[96];
        if (j >= 0) {
            snprintf(other, sizeof other, "sphere %d (body %d)", j, r->spheres[j].body);
        } else {
            snprintf(other, sizeof other, "the wall face %s", rigid_face_name(-1 - j));
        }
        return log_msg(&r->log, STATUS_ERROR, RIGID_CAT,
                       "verlet: unstable contact between sphere %d (body %d) and %s at t=%.9g s: sub-step %g s "
                       "times contact frequency sqrt(k/m)=%g 1/s (m: the contact point's mass, rotation included) is %g, limit %g (contact time about %g s); "
                       "use more substeps (rigid.substeps: at least %.0f for this step of %g s, the master's "
                       "communication step: a master that exchanges every K fluid steps, coupler run "
                       "--exchange-every K, needs K times as many) or the cvode BDF integrator",
                       i, r->spheres[i].body, other, t, hs, worst.omega0, worst.omega0 * hs, VERLET_MAX_H_OMEGA,
                       3.14159265358979 / worst.omega0, ceil(worst.omega0 * hs * r->cfg.substeps / VERLET_MAX_H_OMEGA),
                       hs * r->cfg.substeps);
    }
    if (rc > 0) {
        return rigid_fault_report(r, &r->fault, t);
    }
    return STATUS_OK;
}

static void kick(rigid_t *r, double h)
{
    for (int b = 0; b < r->nbodies; b++) {
        rigid_body_t *bd = &r->bodies[b];
        if (bd->fixed) {
            continue;
        }
        for (int a = 0; a < 3; a++) {
            bd->v[a] += h * r->bf[3 * b + a] / bd->mass;
            bd->l[a] += h * r->bt[3 * b + a];
        }
    }
}

static status_t verlet_advance(rigid_t *r, void *data, double h)
{
    (void)data;
    int n = r->cfg.substeps;
    double hs = h / n;
    r->h_sub_current = hs;
    for (int k = 0; k < n; k++) {
        double t = r->t + h * k / n;
        status_t st = verlet_forces(r, t);
        if (st == STATUS_OK && isnan(r->watch_t)) {
            /* the watch's first sample (at t0, after a restore): the state at
             * the start, so that a contact that begins in this sub-step is
             * judged against its approach speed */
            st = rigid_contact_watch(r, r->bodies, t);
        }
        if (st != STATUS_OK) {
            return st;
        }
        kick(r, 0.5 * hs);
        for (int b = 0; b < r->nbodies; b++) {
            rigid_body_t *bd = &r->bodies[b];
            if (bd->kinematic) {
                rigid_kinematic_move(bd, hs); /* prescribed: drifts with the free bodies */
            }
            if (bd->fixed) {
                continue;
            }
            for (int a = 0; a < 3; a++) {
                bd->com[a] += hs * bd->v[a];
            }
            free_rotor(bd, hs);
        }
        st = verlet_forces(r, t + hs);
        if (st != STATUS_OK) {
            return st;
        }
        kick(r, 0.5 * hs);
        /* positions and forces of t + hs (verlet_forces), velocities now too */
        st = rigid_contact_watch(r, r->bodies, t + hs);
        if (st != STATUS_OK) {
            return st;
        }
    }
    return STATUS_OK;
}

const rigid_integrator_ops_t rigid_verlet_ops = {"verlet", verlet_create, verlet_free, verlet_advance};
