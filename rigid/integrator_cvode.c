/* integrator_cvode.c — the bodies' equations of motion integrated by SUNDIALS
 * CVODE (v6 API: SUNContext, serial N_Vector).
 *
 * State vector: 13 entries per body, [com(3), q(4), v(3), L(3)], L the world
 * angular momentum about the centre of mass. Right-hand side (rhs below):
 *   com' = v,  q' = 1/2 (0, omega) (x) q,  v' = F/M,  L' = T,
 *   omega = R I^-1 R^T L, R the rotation of q/|q|,
 * with F, T from rigid_forces(), the same function Verlet uses. The
 * quaternion is not constrained; the RHS uses q/|q| and q is renormalised at
 * the end of each communication step. Fixed bodies have zero derivatives.
 * The RHS returns 0 on success, 1 (recoverable: CVODE retries with a smaller
 * step) on a fault of contact.c (an overlap beyond a radius, a wall reached
 * without a contact model), -1 (fatal) on NaN. When CVODE cannot get past a
 * fault, the fault is the error message. The lubrication force enters plain
 * (h_kick = 0): its stiffness is BDF's business.
 *
 * Methods: Adams-Moulton with the fixed-point nonlinear solver (non-stiff),
 * or BDF with Newton and a dense direct (difference-quotient Jacobian) or
 * unpreconditioned SPGMR linear solver (stiff contacts). Tolerances: rtol
 * from the scene; atol on the state scaled per body by its radius of
 * gyration l = sqrt(I_max/M) and I_max: atol*l for position (m) and velocity
 * (m/s), atol for q, atol*I_max for L (kg m^2/s).
 *
 * The hydrodynamic load is piecewise constant in time (it jumps at every
 * communication point) and bodies split and merge between steps, so CVODE is
 * re-initialised at the start of every communication step; this also makes a
 * restored state continue bit-identically. Every SUNDIALS call is checked;
 * SUNDIALS error messages go to the log sink, not stderr. */
#include "rigid_internal.h"

#include <cvode/cvode.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunlinsol/sunlinsol_spgmr.h>
#include <sunmatrix/sunmatrix_dense.h>
#include <sunnonlinsol/sunnonlinsol_fixedpoint.h>

#include <stdlib.h>
#include <string.h>

#define NV 13
#define CVODE_MAX_STEPS 200000

typedef struct {
    SUNContext ctx;
    void *mem;
    N_Vector y, abstol;
    SUNMatrix A;
    SUNLinearSolver ls;
    SUNNonlinearSolver nls;
    int n; /* number of bodies the solver objects are sized for, 0 = none */
    rigid_t *r;
    char last_msg[512];
    rigid_fault_t fault; /* last fault the RHS met in this step (a recoverable failure) */
    double fault_t;
} cvode_data_t;

static void cv_release(cvode_data_t *d)
{
    if (d->mem != NULL) {
        CVodeFree(&d->mem);
    }
    if (d->nls != NULL) {
        SUNNonlinSolFree(d->nls);
        d->nls = NULL;
    }
    if (d->ls != NULL) {
        SUNLinSolFree(d->ls);
        d->ls = NULL;
    }
    if (d->A != NULL) {
        SUNMatDestroy(d->A);
        d->A = NULL;
    }
    if (d->abstol != NULL) {
        N_VDestroy(d->abstol);
        d->abstol = NULL;
    }
    if (d->y != NULL) {
        N_VDestroy(d->y);
        d->y = NULL;
    }
    d->n = 0;
}

static void cv_errhandler(int code, const char *module, const char *function, char *msg, void *user)
{
    cvode_data_t *d = user;
    snprintf(d->last_msg, sizeof d->last_msg, "%s %s (%d): %s", module, function, code, msg);
}

/* The bodies at time r->t + dt: the free ones from y, a prescribed one moved on
 * by dt from where it is at r->t, so that every evaluation sees it at its time. */
static void unpack(const rigid_t *r, const double *y, double dt, rigid_body_t *out)
{
    for (int b = 0; b < r->nbodies; b++) {
        out[b] = r->bodies[b];
        if (out[b].kinematic && dt != 0.0) {
            rigid_kinematic_move(&out[b], dt);
        }
        if (r->bodies[b].fixed) {
            continue;
        }
        const double *p = y + NV * b;
        memcpy(out[b].com, p, 3 * sizeof(double));
        memcpy(out[b].q, p + 3, 4 * sizeof(double));
        memcpy(out[b].v, p + 7, 3 * sizeof(double));
        memcpy(out[b].l, p + 10, 3 * sizeof(double));
    }
}

static void pack(const rigid_t *r, double *y)
{
    for (int b = 0; b < r->nbodies; b++) {
        double *p = y + NV * b;
        const rigid_body_t *bd = &r->bodies[b];
        memcpy(p, bd->com, 3 * sizeof(double));
        memcpy(p + 3, bd->q, 4 * sizeof(double));
        memcpy(p + 7, bd->v, 3 * sizeof(double));
        memcpy(p + 10, bd->l, 3 * sizeof(double));
    }
}

static int rhs(sunrealtype t, N_Vector y, N_Vector ydot, void *user)
{
    cvode_data_t *d = user;
    rigid_t *r = d->r;
    const double *yy = N_VGetArrayPointer(y);
    double *yd = N_VGetArrayPointer(ydot);
    rigid_body_t *bs = r->scratch_bodies;
    unpack(r, yy, t - r->t, bs);
    int rc = rigid_forces(r, bs, 0.0, NULL);
    if (rc < 0) {
        return -1;
    }
    if (rc > 0) {
        d->fault = r->fault;
        d->fault_t = t;
        return 1;
    }
    for (int b = 0; b < r->nbodies; b++) {
        double *p = yd + NV * b;
        if (bs[b].fixed) {
            memset(p, 0, NV * sizeof(double));
            continue;
        }
        double w[3];
        rigid_body_omega(&bs[b], w);
        const double *q = bs[b].q;
        double wq[4] = {0.0, w[0], w[1], w[2]}, dq[4];
        rq_mul(wq, q, dq);
        for (int a = 0; a < 3; a++) {
            p[a] = bs[b].v[a];
            p[7 + a] = r->bf[3 * b + a] / bs[b].mass;
            p[10 + a] = r->bt[3 * b + a];
        }
        for (int a = 0; a < 4; a++) {
            p[3 + a] = 0.5 * dq[a];
        }
    }
    return 0;
}

/* CVodeGetReturnFlagName returns a malloc'ed string: copy it and free it. */
static void flag_name(int flag, char *buf, size_t n)
{
    char *s = CVodeGetReturnFlagName(flag);
    snprintf(buf, n, "%s", s != NULL ? s : "?");
    free(s);
}

static status_t cv_fail(rigid_t *r, cvode_data_t *d, const char *call, int flag)
{
    char name[64];
    flag_name(flag, name, sizeof name);
    return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "cvode: %s failed at t=%.9g s with %d (%s)%s%s", call, r->t, flag,
                   name, d->last_msg[0] ? ": " : "", d->last_msg);
}

/* (Re)creates the solver objects for the current number of bodies. */
static status_t cv_setup(rigid_t *r, cvode_data_t *d)
{
    const rigid_config_t *cfg = &r->cfg;
    int n = r->nbodies;
    sunindextype len = (sunindextype)NV * n;
    int flag;
    cv_release(d);
    d->y = N_VNew_Serial(len, d->ctx);
    d->abstol = N_VNew_Serial(len, d->ctx);
    if (d->y == NULL || d->abstol == NULL) {
        return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "cvode: N_VNew_Serial(%ld) failed", (long)len);
    }
    pack(r, N_VGetArrayPointer(d->y));
    d->mem = CVodeCreate(cfg->cvode_method == RIGID_BDF ? CV_BDF : CV_ADAMS, d->ctx);
    if (d->mem == NULL) {
        return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "cvode: CVodeCreate failed");
    }
    if ((flag = CVodeSetErrHandlerFn(d->mem, cv_errhandler, d)) != CV_SUCCESS) {
        return cv_fail(r, d, "CVodeSetErrHandlerFn", flag);
    }
    if ((flag = CVodeInit(d->mem, rhs, r->t, d->y)) != CV_SUCCESS) {
        return cv_fail(r, d, "CVodeInit", flag);
    }
    if ((flag = CVodeSetUserData(d->mem, d)) != CV_SUCCESS) {
        return cv_fail(r, d, "CVodeSetUserData", flag);
    }
    if ((flag = CVodeSetMaxNumSteps(d->mem, CVODE_MAX_STEPS)) != CV_SUCCESS) {
        return cv_fail(r, d, "CVodeSetMaxNumSteps", flag);
    }
    if (cfg->cvode_method == RIGID_BDF) {
        if (cfg->linsol == RIGID_LS_DENSE) {
            d->A = SUNDenseMatrix(len, len, d->ctx);
            if (d->A == NULL) {
                return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "cvode: SUNDenseMatrix(%ld) failed", (long)len);
            }
            d->ls = SUNLinSol_Dense(d->y, d->A, d->ctx);
        } else {
            d->ls = SUNLinSol_SPGMR(d->y, SUN_PREC_NONE, 0, d->ctx);
        }
        if (d->ls == NULL) {
            return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "cvode: creating the linear solver failed");
        }
        if ((flag = CVodeSetLinearSolver(d->mem, d->ls, d->A)) != CVLS_SUCCESS) {
            return cv_fail(r, d, "CVodeSetLinearSolver", flag);
        }
    } else {
        d->nls = SUNNonlinSol_FixedPoint(d->y, 0, d->ctx);
        if (d->nls == NULL) {
            return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "cvode: SUNNonlinSol_FixedPoint failed");
        }
        if ((flag = CVodeSetNonlinearSolver(d->mem, d->nls)) != CV_SUCCESS) {
            return cv_fail(r, d, "CVodeSetNonlinearSolver", flag);
        }
    }
    d->n = n;
    return STATUS_OK;
}

static status_t cv_create(rigid_t *r, void **data)
{
    cvode_data_t *d = calloc(1, sizeof *d);
    if (d == NULL) {
        return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "cvode: out of memory for its data (%zu bytes)", sizeof *d);
    }
    d->r = r;
    int flag = SUNContext_Create(NULL, &d->ctx);
    if (flag != 0) {
        free(d);
        return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "cvode: SUNContext_Create failed with %d", flag);
    }
    *data = d;
    return STATUS_OK;
}

static void cv_free(void *data)
{
    cvode_data_t *d = data;
    if (d == NULL) {
        return;
    }
    cv_release(d);
    SUNContext_Free(&d->ctx);
    free(d);
}

/* Names the body and contact that most likely caused a failure. */
static status_t cv_report(rigid_t *r, cvode_data_t *d, int flag, double tret)
{
    int rhs_flag = flag == CV_RHSFUNC_FAIL || flag == CV_FIRST_RHSFUNC_ERR || flag == CV_REPTD_RHSFUNC_ERR ||
                   flag == CV_UNREC_RHSFUNC_ERR;
    if (rhs_flag && d->fault.kind != RIGID_FAULT_NONE) {
        /* CVODE could not get past a state where a sphere reaches a wall
         * without a contact model, or overlaps beyond a radius */
        return rigid_fault_report(r, &d->fault, d->fault_t);
    }
    rigid_contact_info_t worst;
    unpack(r, N_VGetArrayPointer(d->y), tret - r->t, r->scratch_bodies);
    int rc = rigid_forces(r, r->scratch_bodies, 0.0, &worst);
    char where[512] = "";
    if (rc < 0) {
        int bad = -1;
        for (int b = 0; b < r->nbodies && bad < 0; b++) {
            for (int a = 0; a < 3; a++) {
                if (!isfinite(r->bf[3 * b + a]) || !isfinite(r->bt[3 * b + a])) {
                    bad = b;
                }
            }
        }
        snprintf(where, sizeof where, "; non-finite force or torque on body %d", bad);
    } else if (worst.sphere_i >= 0) {
        snprintf(where, sizeof where, "; stiffest contact: sphere %d of body %d, contact frequency %g 1/s",
                 worst.sphere_i, r->spheres[worst.sphere_i].body, worst.omega0);
    } else if (flag == CV_TOO_MUCH_WORK) {
        /* no contact to blame: the fastest turning body sets the steps */
        int fast = -1;
        double wmax = -1.0, vfast = 0.0;
        for (int b = 0; b < r->nbodies; b++) {
            if (r->scratch_bodies[b].fixed) {
                continue;
            }
            double w[3];
            rigid_body_omega(&r->scratch_bodies[b], w);
            const double wn = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
            if (wn > wmax) {
                const double *v = r->scratch_bodies[b].v;
                wmax = wn;
                fast = b;
                vfast = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
            }
        }
        if (fast >= 0) {
            snprintf(where, sizeof where,
                     "; fastest turning body %d: |w| = %.3g rad/s, |v| = %.3g m/s (too fast for the tolerances: check "
                     "its loads, or take a shorter step)",
                     fast, wmax, vfast);
        }
    }
    if (where[0] == '\0' && (flag == CV_LSETUP_FAIL || flag == CV_LSOLVE_FAIL || flag == CV_CONV_FAILURE ||
                              flag == CV_ERR_FAILURE)) {
        /* no contact, no non-finite force: the tolerances or the loads (an
         * atol of 1e-300 or 1e300, or a load of 1e200 N, ended here without
         * a word on either) */
        double fmax_b = 0.0;
        for (int i = 0; i < r->nspheres; i++) {
            const double *f = r->spheres[i].load_f;
            fmax_b = fmax(fmax_b, hypot(hypot(f[0], f[1]), f[2]));
        }
        snprintf(where, sizeof where,
                 "; rigid.rtol = %g, rigid.atol = %g (on the scaled state: README \"Configuration\"), largest hydrodynamic load on a sphere %g N: "
                 "tolerances far from the motion's scale or loads this large make CVODE's linear solve or error "
                 "test fail; check them, or use rigid.integrator: verlet",
                 r->cfg.rtol, r->cfg.atol, fmax_b);
    }
    char name[64];
    flag_name(flag, name, sizeof name);
    return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "cvode: CVode failed at t=%.9g s with %s%s%s%s", tret, name, where,
                   d->last_msg[0] ? "; " : "", d->last_msg);
}

static status_t cv_advance(rigid_t *r, void *data, double h)
{
    cvode_data_t *d = data;
    const rigid_config_t *cfg = &r->cfg;
    int flag;
    status_t st;
    d->last_msg[0] = '\0';
    d->fault.kind = RIGID_FAULT_NONE;
    if (d->n != r->nbodies || d->mem == NULL) {
        if ((st = cv_setup(r, d)) != STATUS_OK) {
            return st;
        }
    }
    double *y = N_VGetArrayPointer(d->y), *at = N_VGetArrayPointer(d->abstol);
    pack(r, y);
    for (int b = 0; b < r->nbodies; b++) {
        const rigid_body_t *bd = &r->bodies[b];
        double imax = fmax(bd->inertia[0], fmax(bd->inertia[1], bd->inertia[2]));
        double l = sqrt(imax / bd->mass);
        for (int k = 0; k < NV; k++) {
            double s = k < 3 ? l : k < 7 ? 1.0 : k < 10 ? l : imax;
            at[NV * b + k] = cfg->atol * s;
        }
    }
    if ((flag = CVodeReInit(d->mem, r->t, d->y)) != CV_SUCCESS) {
        return cv_fail(r, d, "CVodeReInit", flag);
    }
    if ((flag = CVodeSVtolerances(d->mem, cfg->rtol, d->abstol)) != CV_SUCCESS) {
        return cv_fail(r, d, "CVodeSVtolerances", flag);
    }
    double tend = r->t + h;
    if ((flag = CVodeSetStopTime(d->mem, tend)) != CV_SUCCESS) {
        return cv_fail(r, d, "CVodeSetStopTime", flag);
    }
    double tret = r->t;
    if (cfg->contact_model == RIGID_CONTACT_NONE) {
        flag = CVode(d->mem, tend, d->y, &tret, CV_NORMAL);
        if (flag < 0) {
            return cv_report(r, d, flag, tret);
        }
    } else {
        /* step by step (the same internal steps as CV_NORMAL up to the stop
         * time), so that the contact watch sees every accepted state; each
         * CV_ONE_STEP call is one step, so CVodeSetMaxNumSteps never stops
         * this loop: the limit of CV_NORMAL is counted here */
        long taken = 0;
        if (isnan(r->watch_t) && rigid_forces(r, r->bodies, 0.0, NULL) >= 0 &&
            (st = rigid_contact_watch(r, r->bodies, r->t)) != STATUS_OK) {
            return st; /* the watch's first sample: the state at the start (as Verlet) */
        }
        do {
            if (taken++ >= CVODE_MAX_STEPS) {
                snprintf(d->last_msg, sizeof d->last_msg,
                         "%d internal steps (the limit per communication step) reached t = %.9g s of %.9g s",
                         CVODE_MAX_STEPS, tret, tend);
                return cv_report(r, d, CV_TOO_MUCH_WORK, tret);
            }
            flag = CVode(d->mem, tend, d->y, &tret, CV_ONE_STEP);
            if (flag < 0) {
                return cv_report(r, d, flag, tret);
            }
            unpack(r, y, tret - r->t, r->scratch_bodies);
            if (rigid_forces(r, r->scratch_bodies, 0.0, NULL) >= 0 &&
                (st = rigid_contact_watch(r, r->scratch_bodies, tret)) != STATUS_OK) {
                return st;
            }
        } while (flag != CV_TSTOP_RETURN && tret < tend);
    }
    unpack(r, y, 0.0, r->scratch_bodies);
    for (int b = 0; b < r->nbodies; b++) {
        rigid_body_t *bd = &r->bodies[b];
        if (bd->kinematic) {
            rigid_kinematic_move(bd, h);
        }
        if (bd->fixed) {
            continue;
        }
        *bd = r->scratch_bodies[b];
        double n = sqrt(bd->q[0] * bd->q[0] + bd->q[1] * bd->q[1] + bd->q[2] * bd->q[2] + bd->q[3] * bd->q[3]);
        for (int k = 0; k < 4; k++) {
            bd->q[k] /= n;
        }
        for (int k = 0; k < 3; k++) {
            if (!isfinite(bd->com[k] + bd->v[k] + bd->l[k])) {
                return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "cvode: non-finite state of body %d at t=%.9g s",
                               b, tend);
            }
        }
    }
    return STATUS_OK;
}

const rigid_integrator_ops_t rigid_cvode_ops = {"cvode", cv_create, cv_free, cv_advance};
