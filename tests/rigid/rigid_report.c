/* rigid_report.c — error against run time of the rigid integrators (the
 * figures of issue 4, and section 2 of `make report`): Verlet over a step
 * sweep, CVODE Adams and BDF over a tolerance sweep, on four cases:
 *   top       torque-free asymmetric top over 20 s; error = |omega(T) -
 *             omega_ref| / |omega_ref|, reference: CVODE Adams at rtol 1e-13;
 *   collision head-on spring-dashpot collision of two spheres (e = 0.7,
 *             t_c = 1e-4 s); error = |e_measured - e| / e (e is exact for the
 *             linear spring-dashpot, Schwager & Poeschel 2005);
 *   stiff     sphere dropped 1 um onto a wall, e = 0.3, t_c = 1e-5 s,
 *             communication step 1e-4 s, at 0.6 ms (in flight after the first bounce); error =
 *             |v_z(T) - v_ref| / v_impact, reference CVODE BDF at rtol 1e-10.
 *             Verlet sweeps its sub-steps; a run refused as unstable (or a
 *             CVODE failure) is printed as "failed";
 *   drag      a sphere falling under gravity against Stokes drag -6 pi mu a v,
 *             the load set by the caller at each communication step h as a
 *             fluid coupling does it (with the implicit drag coefficient):
 *             error = |v(T) - v_exact(T)| / v_terminal at T = 2 m/zeta, exact
 *             v = v_t (1 - exp(-zeta t / m)). Every integrator sweeps h
 *             (CVODE at rtol 1e-10): the held load, not the integrator,
 *             sets the error of a coupled run.
 * Output: plain columns "case integrator parameter error seconds evaluations"
 * (evaluations: force evaluations, rigid_force_evaluations), and with a
 * folder argument the same rows as DIR/rigid.csv. */
#define _POSIX_C_SOURCE 200809L
#include "../../rigid/rigid.h"

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static const char *iname(rigid_integrator_t i, rigid_cvode_method_t m)
{
    return i == RIGID_VERLET ? "verlet" : (m == RIGID_ADAMS ? "cvode_adams" : "cvode_bdf");
}

static FILE *csv_out; /* DIR/rigid.csv, or NULL */
static long evaluations; /* force evaluations of the last run */

static void row(const char *cs, rigid_integrator_t i, rigid_cvode_method_t m, const char *param, double value,
                status_t st, double err, double secs)
{
    if (st == STATUS_OK) {
        printf("%-10s %-12s %s=%-9g %-10.3e %.4f %ld\n", cs, iname(i, m), param, value, err, secs, evaluations);
    } else {
        printf("%-10s %-12s %s=%-9g %-10s %.4f %ld\n", cs, iname(i, m), param, value, "failed", secs, evaluations);
    }
    if (csv_out != NULL) {
        fprintf(csv_out, "%s,%s,%s,%g,%s,%.6e,%.6f,%ld\n", cs, iname(i, m), param, value, st == STATUS_OK ? "ok" : "failed",
                st == STATUS_OK ? err : NAN, secs, evaluations);
    }
}

/* Frees r after recording its force evaluations for the next row. */
static void finish(rigid_t *r)
{
    evaluations = r != NULL ? rigid_force_evaluations(r) : 0;
    rigid_free(r);
}

typedef struct {
    rigid_integrator_t integ;
    rigid_cvode_method_t meth;
    double h, rtol;
    int substeps;
} run_t;

static rigid_config_t base_cfg(const run_t *run)
{
    rigid_config_t c;
    memset(&c, 0, sizeof c);
    c.restitution = 1.0;
    c.substeps = run->substeps > 0 ? run->substeps : 1;
    c.integrator = run->integ;
    c.cvode_method = run->meth;
    c.linsol = RIGID_LS_DENSE;
    c.rtol = run->rtol;
    c.atol = run->rtol * 1e-2;
    return c;
}

/* ---- torque-free top ---- */
static status_t top_run(const run_t *run, double w_out[3])
{
    const rigid_sphere_cfg_t s[5] = {{{0, 0, 0}, 1.0, 0},
                                     {{1.6, 0, 0}, 0.6, 0},
                                     {{-1.6, 0, 0}, 0.6, 0},
                                     {{0, 1.4, 0}, 0.4, 0},
                                     {{0, -1.4, 0}, 0.4, 0}};
    rigid_body_cfg_t b = {1.0, {0, 0, 0}, {0.4, 1.0, 0.3}, 0};
    rigid_config_t c = base_cfg(run);
    c.nspheres = 5;
    c.spheres = s;
    c.nbodies = 1;
    c.bodies = &b;
    rigid_t *r = NULL;
    status_t st = rigid_create(&c, NULL, &r);
    int n = (int)lround(20.0 / run->h);
    for (int k = 0; k < n && st == STATUS_OK; k++) {
        st = rigid_step(r, run->h);
    }
    if (r != NULL) {
        rigid_get_body(r, 0, NULL, NULL, NULL, w_out, NULL, NULL);
    }
    finish(r);
    return st;
}

static double top_err(const double w[3], const double wref[3])
{
    double d = sqrt(pow(w[0] - wref[0], 2) + pow(w[1] - wref[1], 2) + pow(w[2] - wref[2], 2));
    return d / sqrt(wref[0] * wref[0] + wref[1] * wref[1] + wref[2] * wref[2]);
}

/* ---- head-on collision ---- */
static status_t collision_run(const run_t *run, double *e_out)
{
    double rr = 1e-3, v0 = 0.1;
    rigid_sphere_cfg_t s[2] = {{{-rr - 1e-6, 0, 0}, rr, 0}, {{rr + 1e-6, 0, 0}, rr, 1}};
    rigid_body_cfg_t b[2] = {{2500.0, {v0, 0, 0}, {0, 0, 0}, 0}, {2500.0, {-v0, 0, 0}, {0, 0, 0}, 0}};
    rigid_config_t c = base_cfg(run);
    c.nspheres = 2;
    c.spheres = s;
    c.nbodies = 2;
    c.bodies = b;
    c.contact_model = RIGID_CONTACT_SPRING_DASHPOT;
    c.restitution = 0.7;
    c.contact_time = 1e-4;
    rigid_t *r = NULL;
    status_t st = rigid_create(&c, NULL, &r);
    int n = (int)lround(3e-4 / run->h);
    for (int k = 0; k < n && st == STATUS_OK; k++) {
        st = rigid_step(r, run->h);
    }
    if (st == STATUS_OK) {
        double va[3], vb[3];
        rigid_get_sphere(r, 0, NULL, va, NULL);
        rigid_get_sphere(r, 1, NULL, vb, NULL);
        *e_out = (vb[0] - va[0]) / (2 * v0);
    }
    finish(r);
    return st;
}

/* ---- stiff contact ---- */
#define STIFF_T 6e-4  /* s: in flight after the first bounce (impact at 0.45 ms) */
#define STIFF_H 1e-4  /* s: communication step = 10 contact times */
static status_t stiff_run(const run_t *run, double *vz)
{
    double rr = 1e-3, tc = 1e-5, e = 0.3, g = 9.81;
    rigid_sphere_cfg_t s = {{0, 0, rr + 1e-6}, rr, 0};
    rigid_body_cfg_t b = {2500.0, {0, 0, 0}, {0, 0, 0}, 0};
    rigid_config_t c = base_cfg(run);
    c.nspheres = 1;
    c.spheres = &s;
    c.nbodies = 1;
    c.bodies = &b;
    c.gravity[2] = -g;
    c.contact_model = RIGID_CONTACT_SPRING_DASHPOT;
    c.restitution = e;
    c.contact_time = tc;
    c.walls[2][0] = 1;
    c.box_hi[2] = 1.0;
    rigid_t *r = NULL;
    status_t st = rigid_create(&c, NULL, &r);
    int n = (int)lround(STIFF_T / run->h);
    for (int k = 0; k < n && st == STATUS_OK; k++) {
        st = rigid_step(r, run->h);
    }
    if (st == STATUS_OK) {
        double v[3];
        rigid_get_sphere(r, 0, NULL, v, NULL);
        *vz = v[2];
    }
    finish(r);
    return st;
}

/* ---- linear drag, load held over each communication step ---- */
#define DRAG_A 1e-3   /* m */
#define DRAG_MU 1e-3  /* Pa s */
#define DRAG_RHO 2500.0
static double drag_zeta(void) { return 6.0 * M_PI * DRAG_MU * DRAG_A; }
static double drag_mass(void) { return DRAG_RHO * 4.0 / 3.0 * M_PI * pow(DRAG_A, 3); }

static status_t drag_run(const run_t *run, double *err)
{
    const double zeta = drag_zeta(), m = drag_mass(), g = 9.81, T = 2.0 * m / zeta, vt = m * g / zeta;
    rigid_sphere_cfg_t s = {{0, 0, 0}, DRAG_A, 0};
    rigid_body_cfg_t b = {DRAG_RHO, {0, 0, 0}, {0, 0, 0}, 0};
    rigid_config_t c = base_cfg(run);
    c.nspheres = 1;
    c.spheres = &s;
    c.nbodies = 1;
    c.bodies = &b;
    c.gravity[2] = -g;
    rigid_t *r = NULL;
    status_t st = rigid_create(&c, NULL, &r);
    const int n = (int)lround(T / run->h);
    for (int k = 0; k < n && st == STATUS_OK; k++) {
        double v[3], f[3], zero[3] = {0, 0, 0};
        rigid_get_sphere(r, 0, NULL, v, NULL);
        for (int a = 0; a < 3; a++) {
            f[a] = -zeta * v[a];
        }
        rigid_set_sphere_load(r, 0, f, zero);
        rigid_set_sphere_drag(r, 0, zeta, 0.0);
        st = rigid_step(r, run->h);
    }
    if (st == STATUS_OK) {
        double v[3];
        rigid_get_sphere(r, 0, NULL, v, NULL);
        *err = fabs(v[2] + vt * (1.0 - exp(-zeta * n * run->h / m))) / vt;
    }
    finish(r);
    return st;
}

int main(int argc, char **argv)
{
    if (argc > 1) {
        char path[512];
        snprintf(path, sizeof path, "%s/rigid.csv", argv[1]);
        if ((csv_out = fopen(path, "w")) == NULL) {
            fprintf(stderr, "rigid_report: cannot write %s (does the folder exist?)\n", path);
            return 1;
        }
        fprintf(csv_out, "case,integrator,parameter,value,status,error,seconds,evaluations\n");
    }
    printf("# case      integrator   parameter    error      seconds evaluations\n");
    double wref[3], w[3], t0, e;
    run_t ref = {RIGID_CVODE, RIGID_ADAMS, 0.1, 1e-13, 1};
    if (top_run(&ref, wref) != STATUS_OK) {
        fprintf(stderr, "reference run of the top failed\n");
        return 1;
    }
    for (double h = 0.1; h > 0.002; h /= 2) {
        run_t run = {RIGID_VERLET, RIGID_ADAMS, h, 1e-8, 1};
        t0 = now();
        status_t st = top_run(&run, w);
        row("top", run.integ, run.meth, "h", h, st, top_err(w, wref), now() - t0);
    }
    for (int m = 0; m < 2; m++) {
        for (double tol = 1e-4; tol > 1e-11; tol /= 10) {
            run_t run = {RIGID_CVODE, m ? RIGID_BDF : RIGID_ADAMS, 0.1, tol, 1};
            t0 = now();
            status_t st = top_run(&run, w);
            row("top", run.integ, run.meth, "rtol", tol, st, top_err(w, wref), now() - t0);
        }
    }
    for (double h = 1e-5; h > 1e-7; h /= 2) {
        run_t run = {RIGID_VERLET, RIGID_ADAMS, h, 1e-8, 1};
        t0 = now();
        status_t st = collision_run(&run, &e);
        row("collision", run.integ, run.meth, "h", h, st, fabs(e - 0.7) / 0.7, now() - t0);
    }
    for (int m = 0; m < 2; m++) {
        for (double tol = 1e-4; tol > 1e-11; tol /= 10) {
            run_t run = {RIGID_CVODE, m ? RIGID_BDF : RIGID_ADAMS, 1e-5, tol, 1};
            t0 = now();
            status_t st = collision_run(&run, &e);
            row("collision", run.integ, run.meth, "rtol", tol, st, fabs(e - 0.7) / 0.7, now() - t0);
        }
    }
    /* stiff: error in the vertical velocity at STIFF_T relative to the impact
     * speed sqrt(2 g 1e-6 m), reference CVODE BDF at rtol 1e-10 */
    double vref, vz, vimp = sqrt(2 * 9.81 * 1e-6);
    run_t sref = {RIGID_CVODE, RIGID_BDF, STIFF_H, 1e-10, 1};
    if (stiff_run(&sref, &vref) != STATUS_OK) {
        fprintf(stderr, "reference run of the stiff contact failed\n");
        return 1;
    }
    for (int sub = 1; sub <= 512; sub *= 2) {
        run_t run = {RIGID_VERLET, RIGID_ADAMS, STIFF_H, 1e-8, sub};
        t0 = now();
        status_t st = stiff_run(&run, &vz);
        row("stiff", run.integ, run.meth, "substeps", sub, st, fabs(vz - vref) / vimp, now() - t0);
    }
    for (int m = 0; m < 2; m++) {
        for (double tol = 1e-4; tol > 1e-11; tol /= 10) {
            run_t run = {RIGID_CVODE, m ? RIGID_BDF : RIGID_ADAMS, STIFF_H, tol, 1};
            t0 = now();
            status_t st = stiff_run(&run, &vz);
            row("stiff", run.integ, run.meth, "rtol", tol, st, fabs(vz - vref) / vimp, now() - t0);
        }
    }
    const double tau_drag = drag_mass() / drag_zeta();
    for (double h = tau_drag / 4; h > tau_drag / 2000; h /= 2) {
        run_t run = {RIGID_VERLET, RIGID_ADAMS, h, 1e-8, 1};
        t0 = now();
        status_t st = drag_run(&run, &e);
        row("drag", run.integ, run.meth, "h", h, st, e, now() - t0);
    }
    for (int m = 0; m < 2; m++) {
        for (double h = tau_drag / 4; h > tau_drag / 2000; h /= 4) {
            run_t run = {RIGID_CVODE, m ? RIGID_BDF : RIGID_ADAMS, h, 1e-10, 1};
            t0 = now();
            status_t st = drag_run(&run, &e);
            row("drag", run.integ, run.meth, "h", h, st, e, now() - t0);
        }
    }
    return csv_out != NULL && fclose(csv_out) != 0;
}
