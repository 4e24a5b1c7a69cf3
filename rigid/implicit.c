/* implicit.c — the implicit hydrodynamic coupling (rigid.coupling =
 * implicit; README "Implicit coupling").
 *
 * The fluid publishes each sphere's drag coefficients, the instantaneous
 * response of its load to its velocity (rigid_set_sphere_drag). Before the
 * integration of a step, the change of each body's velocity over the step is
 * predicted from a small linear system that treats that response implicitly,
 * and every sphere's held load is corrected by the drag response to that
 * change (rigid_sphere_t.imp_f, imp_t). Without drag coefficients nothing
 * changes: the coupling is then explicit.
 *
 * The fluid delivers that response itself in the following steps (its loads
 * are computed with the new velocity), so the corrections are paid back: each
 * step adds its correction to a debt (debt_f, debt_t) and pays back half of
 * the debt, and the corrections of a run sum to the debt left, which
 * halves every step once the motion is steady: fluid and bodies exchange the
 * same momentum. (Without the pay-back the body took each correction on
 * top, an added mass of h zeta that the fluid never felt: a sphere launched
 * in a periodic box at rest left the total momentum 20% above its start, 9%
 * with force averaging; README "Implicit coupling".) Paying all of it back
 * in the next step is the virtual-mass form of Schwarz, Kempe & Froehlich,
 * J. Comput. Phys. 281 (2015) 591, (m + h zeta)(v' - v) = h F + h zeta dV_prev;
 * in the model m v' = -zeta v (k = h zeta / m) its extra root has |L|^2 =
 * k / (1 + k), close to 1 for a light sphere, whose velocity then jittered
 * more than twice as much as without the pay-back (radius 1.5 cells, density ratio
 * 0.1: 3.3% against 1.2% rms about a smooth fit). Half a debt a step gives
 * |L|^2 = (1 - a + a k) / (1 + k) = 1/2 for any k (a = 1/2).
 *
 * The torque's debt is paid back more slowly, a fifth a step. The fluid's
 * torque on a sphere whose rotation changes overshoots the instantaneous
 * response the prediction uses: radius 3 cells, one step after a step in
 * w, 1.42 times zr at tau 2 (1.16 for the force), 0.66 at tau 1, and -0.9
 * at tau 0.51 (the period-2 part that force averaging takes out). With half
 * the debt a step a light sphere's rotation then grew at tau 2 (density
 * ratio 0.1, radius 3, rising at 0.01 lattice in a periodic box: w from
 * 1e-12 to 0.05 rad per step between steps 260 and 400, the run stopped at
 * Mach 0.34; a simulation of this scheme with the measured response of the
 * lattice gave the same, and that a fifth a step is stable there for
 * density ratios 0.01-3, and at tau 0.51-1 as before). The force keeps half:
 * a fifth let three light spheres at tau 0.51 grow unstable after 2100
 * steps (tools/stability_sweep.py). */
#include "rigid_internal.h"

#include <string.h>

/* the fractions of the outstanding corrections paid back each step */
#define IMPLICIT_PAYBACK_FORCE 0.5
#define IMPLICIT_PAYBACK_TORQUE 0.2

/* Solves the n x n system a x = b in place (Gaussian elimination with
 * partial pivoting; a is row-major and destroyed). Returns 0 when singular. */
static int solve_small(int n, double *a, double *b)
{
    for (int k = 0; k < n; k++) {
        int p = k;
        for (int i = k + 1; i < n; i++) {
            if (fabs(a[i * n + k]) > fabs(a[p * n + k])) {
                p = i;
            }
        }
        if (!(fabs(a[p * n + k]) > 0.0)) {
            return 0;
        }
        if (p != k) {
            for (int j = 0; j < n; j++) {
                const double t = a[k * n + j];
                a[k * n + j] = a[p * n + j];
                a[p * n + j] = t;
            }
            const double t = b[k];
            b[k] = b[p];
            b[p] = t;
        }
        for (int i = k + 1; i < n; i++) {
            const double f = a[i * n + k] / a[k * n + k];
            for (int j = k; j < n; j++) {
                a[i * n + j] -= f * a[k * n + j];
            }
            b[i] -= f * b[k];
        }
    }
    for (int k = n - 1; k >= 0; k--) {
        for (int j = k + 1; j < n; j++) {
            b[k] -= a[k * n + j] * b[j];
        }
        b[k] /= a[k * n + k];
    }
    return 1;
}

/* The change of the held load of sphere i when its body's velocity changes
 * by dv and its angular velocity by dw (d: sphere centre minus body centre
 * of mass): df = -zt (dv + dw x d), dt = -zr dw about the sphere centre. */
static void drag_response(const rigid_sphere_t *s, const double d[3], const double dv[3], const double dw[3],
                          double df[3], double dt[3])
{
    double wxd[3];
    rv_cross(dw, d, wxd);
    for (int a = 0; a < 3; a++) {
        df[a] = -s->drag_t * (dv[a] + wxd[a]);
        dt[a] = -s->drag_r * dw[a];
    }
}

/* Implicit coupling, before the integration of a step of length h: per body,
 * (M + h Z) x = h (F, T) with the mass matrix M = diag(m, m, m, I_world),
 * the body's total force and torque about its centre of mass at the start of
 * the step (load, gravity, contacts) and Z the response of the loads to
 * (dV, dW); x = (dV, dW) is the predicted change over the step and the held
 * load of every sphere becomes F_i - zt_i (dV + dW x d_i), T_i - zr_i dW. The
 * gyroscopic term is left out of the prediction (it only sets the size of a
 * correction that vanishes in steady motion). */
status_t rigid_implicit_load(rigid_t *r, double h)
{
    int any = 0;
    for (int i = 0; i < r->nspheres; i++) {
        rigid_sphere_t *s = &r->spheres[i];
        /* half the force's debt paid back, a fifth of the torque's (a known
         * load: in the prediction's right-hand side too) */
        for (int a = 0; a < 3; a++) {
            s->imp_f[a] = -IMPLICIT_PAYBACK_FORCE * s->debt_f[a];
            s->imp_t[a] = -IMPLICIT_PAYBACK_TORQUE * s->debt_t[a];
            s->debt_f[a] += s->imp_f[a];
            s->debt_t[a] += s->imp_t[a];
        }
        any |= s->drag_t > 0.0 || s->drag_r > 0.0;
    }
    if (!any) {
        return STATUS_OK;
    }
    /* the lubrication damping integrated exactly over the whole step, so that
     * a stiff film cannot throw the prediction past a reversal */
    if (rigid_forces(r, r->bodies, h, NULL) < 0) {
        return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "non-finite force at t=%.9g s before the step", r->t);
    }
    for (int b = 0; b < r->nbodies; b++) {
        const rigid_body_t *bd = &r->bodies[b];
        if (bd->fixed) {
            continue;
        }
        double a[36] = {0}, x[6], iw[9];
        rigid_body_inertia_world(bd, iw);
        for (int k = 0; k < 3; k++) {
            a[k * 6 + k] = bd->mass;
            for (int j = 0; j < 3; j++) {
                a[(3 + k) * 6 + 3 + j] = iw[3 * k + j];
            }
            x[k] = h * r->bf[3 * b + k];
            x[3 + k] = h * r->bt[3 * b + k];
        }
        /* + h Z, column by column: Z e_k = -(dF, dT) for a unit change e_k */
        int some = 0;
        for (int i = 0; i < r->nspheres; i++) {
            const rigid_sphere_t *s = &r->spheres[i];
            if (s->body != b || (s->drag_t == 0.0 && s->drag_r == 0.0)) {
                continue;
            }
            some = 1;
            double c[3], d[3];
            rigid_sphere_world(r, r->bodies, i, c, NULL, NULL);
            rv_sub(c, bd->com, d);
            for (int k = 0; k < 6; k++) {
                double dv[3] = {0, 0, 0}, dw[3] = {0, 0, 0}, df[3], dt[3], tf[3];
                (k < 3 ? dv : dw)[k % 3] = 1.0;
                drag_response(s, d, dv, dw, df, dt);
                rv_cross(d, df, tf);
                for (int j = 0; j < 3; j++) {
                    a[j * 6 + k] -= h * df[j];
                    a[(3 + j) * 6 + k] -= h * (dt[j] + tf[j]);
                }
            }
        }
        if (!some) {
            continue;
        }
        if (!solve_small(6, a, x)) {
            return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "implicit coupling: singular system for body %d at t=%.9g s",
                           b, r->t);
        }
        for (int i = 0; i < r->nspheres; i++) {
            rigid_sphere_t *s = &r->spheres[i];
            if (s->body != b || (s->drag_t == 0.0 && s->drag_r == 0.0)) {
                continue;
            }
            double c[3], d[3];
            rigid_sphere_world(r, r->bodies, i, c, NULL, NULL);
            rv_sub(c, bd->com, d);
            double pf[3], pt[3];
            drag_response(s, d, x, x + 3, pf, pt);
            for (int a = 0; a < 3; a++) {
                s->imp_f[a] += pf[a];
                s->imp_t[a] += pt[a];
                s->debt_f[a] += pf[a];
                s->debt_t[a] += pt[a];
            }
        }
    }
    return STATUS_OK;
}
