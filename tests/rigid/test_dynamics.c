/* test_dynamics.c — free rigid-body motion and coupling order.
 *
 * Torque-free asymmetric top: energy and |L| are invariants (Euler's
 * equations; Landau & Lifshitz, Mechanics, section 37). The intermediate-axis
 * rotation is periodic with period T = 4 K(k) / nu (Landau & Lifshitz eq.
 * 37.10-37.12): for I1 < I2 < I3 and L^2 > 2 E I2,
 *   nu = sqrt((I3 - I2)(L^2 - 2 E I1) / (I1 I2 I3)),
 *   k^2 = (I2 - I1)(2 E I3 - L^2) / ((I3 - I2)(L^2 - 2 E I1)),
 * and with 1 <-> 3 exchanged for L^2 < 2 E I2; K is the complete elliptic
 * integral of the first kind (computed by the arithmetic-geometric mean,
 * Abramowitz & Stegun 17.6). The body-frame component omega_2 changes sign
 * twice per period.
 *
 * Linear drag: m v' = -c v has v = v0 exp(-c t / m). The drag is applied as
 * the hydrodynamic load computed from the velocity reported after each step,
 * as the fluid would; the coupling is second order (trapezoidal correction),
 * so the error must fall by ~4 when the step halves.
 *
 * Release (rigid_config_t.release_time): before it a body moves with its
 * initial velocity and angular velocity, both constant, whatever acts on it:
 * the sphere centres follow x0 + v t and the exact rotation exp(w t) about
 * the centre of mass (Rodrigues' formula), which torque-free motion of the
 * asymmetric top would not (its w turns); connections carry nothing and do
 * not break. The first step after it is an ordinary step with the load. */
#include "test_rigid_util.h"

/* The top: a central sphere with two pairs of touching arms of different size. */
static const rigid_sphere_cfg_t top_spheres[5] = {{{0, 0, 0}, 1.0, 0},
                                                  {{1.6, 0, 0}, 0.6, 0},
                                                  {{-1.6, 0, 0}, 0.6, 0},
                                                  {{0, 1.4, 0}, 0.4, 0},
                                                  {{0, -1.4, 0}, 0.4, 0}};

static rigid_t *make_top(const double w[3], rigid_integrator_t integ, rigid_cvode_method_t meth, double rtol)
{
    rigid_body_cfg_t b = {1.0, {0, 0, 0}, {w[0], w[1], w[2]}, 0};
    rigid_config_t cfg = test_cfg(5, top_spheres, 1, &b, 0, NULL);
    cfg.integrator = integ;
    cfg.cvode_method = meth;
    cfg.rtol = rtol;
    cfg.atol = rtol * 1e-2;
    rigid_t *r = NULL;
    if (rigid_create(&cfg, NULL, &r) != STATUS_OK) {
        return NULL;
    }
    return r;
}

static double l_norm(const rigid_t *r)
{
    double p[3], l[3];
    rigid_momentum(r, p, l);
    return vec_norm(l);
}

static void run_top_invariants(rigid_integrator_t integ, rigid_cvode_method_t meth, int nsteps, double h,
                               double tol_e, double tol_l)
{
    const double w[3] = {0.4, 1.0, 0.3};
    rigid_t *r = make_top(w, integ, meth, 1e-9);
    CU_ASSERT_PTR_NOT_NULL_FATAL(r);
    double e0 = rigid_kinetic_energy(r), l0 = l_norm(r), de = 0, dl = 0;
    int ok = 1;
    for (int n = 0; n < nsteps && ok; n++) {
        ok = rigid_step(r, h) == STATUS_OK;
        de = fmax(de, rel_err(rigid_kinetic_energy(r), e0));
        dl = fmax(dl, rel_err(l_norm(r), l0));
    }
    CU_ASSERT(ok);
    CU_ASSERT(de < tol_e);
    CU_ASSERT(dl < tol_l);
    rigid_free(r);
}

static void test_top_verlet_invariants(void)
{
    /* 1e5 steps, |omega| h = 5.5e-4: no drift beyond 1e-6 (issue 4) */
    run_top_invariants(RIGID_VERLET, RIGID_ADAMS, 100000, 5e-4, 1e-6, 1e-12);
}

static double top_cvode_energy_error(rigid_cvode_method_t meth, double rtol, int nsteps, double h)
{
    const double w[3] = {0.4, 1.0, 0.3};
    rigid_t *r = make_top(w, RIGID_CVODE, meth, rtol);
    if (r == NULL) {
        return INFINITY;
    }
    double e0 = rigid_kinetic_energy(r), l0 = l_norm(r), de = 0;
    for (int n = 0; n < nsteps; n++) {
        if (rigid_step(r, h) != STATUS_OK) {
            de = INFINITY;
            break;
        }
        de = fmax(de, rel_err(rigid_kinetic_energy(r), e0));
        de = fmax(de, rel_err(l_norm(r), l0));
    }
    rigid_free(r);
    return de;
}

static void test_top_cvode_invariants(void)
{
    /* CVODE restarts at every communication step (the load may jump there),
     * so its local error, bounded by rtol, adds up over the steps: over 1000
     * steps the drift must stay below 1000 rtol and fall with rtol. */
    double e9 = top_cvode_energy_error(RIGID_ADAMS, 1e-9, 1000, 0.05);
    double e11 = top_cvode_energy_error(RIGID_ADAMS, 1e-11, 1000, 0.05);
    double b9 = top_cvode_energy_error(RIGID_BDF, 1e-9, 1000, 0.05);
    CU_ASSERT(e9 < 1000 * 1e-9);
    CU_ASSERT(b9 < 1000 * 1e-9);
    CU_ASSERT(e11 < 1000 * 1e-11);
    CU_ASSERT(e11 < 0.1 * e9);
}

static double ellip_k(double k)
{
    double a = 1.0, b = sqrt(1.0 - k * k);
    for (int i = 0; i < 60 && fabs(a - b) > 1e-16 * a; i++) {
        double an = 0.5 * (a + b);
        b = sqrt(a * b);
        a = an;
    }
    return M_PI / (2.0 * a);
}

/* body-frame angular velocity component along the principal axis with the
 * middle moment of inertia */
static double omega_mid(const rigid_t *r, double *imid)
{
    double q[4], w[3], I[9];
    rigid_get_body(r, 0, NULL, q, NULL, w, NULL, I);
    double s = 2.0 / (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    double R[9] = {1 - s * (q[2] * q[2] + q[3] * q[3]), s * (q[1] * q[2] - q[0] * q[3]), s * (q[1] * q[3] + q[0] * q[2]),
                   s * (q[1] * q[2] + q[0] * q[3]), 1 - s * (q[1] * q[1] + q[3] * q[3]), s * (q[2] * q[3] - q[0] * q[1]),
                   s * (q[1] * q[3] - q[0] * q[2]), s * (q[2] * q[3] + q[0] * q[1]), 1 - s * (q[1] * q[1] + q[2] * q[2])};
    /* principal moments: e_k^T I e_k with e_k the body axes (columns of R) */
    double mom[3], wb[3];
    for (int k = 0; k < 3; k++) {
        double e[3] = {R[k], R[3 + k], R[6 + k]}, Ie[3];
        for (int a = 0; a < 3; a++) {
            Ie[a] = I[3 * a] * e[0] + I[3 * a + 1] * e[1] + I[3 * a + 2] * e[2];
        }
        mom[k] = e[0] * Ie[0] + e[1] * Ie[1] + e[2] * Ie[2];
        wb[k] = e[0] * w[0] + e[1] * w[1] + e[2] * w[2];
    }
    int mid = 0;
    for (int k = 0; k < 3; k++) {
        int lo = 0, hi = 0;
        for (int j = 0; j < 3; j++) {
            lo += mom[j] < mom[k];
            hi += mom[j] > mom[k];
        }
        if (lo == 1 && hi == 1) {
            mid = k;
        }
    }
    if (imid != NULL) {
        double I1 = fmin(mom[0], fmin(mom[1], mom[2])), I3 = fmax(mom[0], fmax(mom[1], mom[2]));
        imid[0] = I1;
        imid[1] = mom[mid];
        imid[2] = I3;
    }
    return wb[mid];
}

static void flip_period(rigid_integrator_t integ, double h, int nsteps)
{
    /* spin mostly about the intermediate (y) axis with a small perturbation */
    const double w[3] = {0.02, 1.0, 0.03};
    rigid_t *r = make_top(w, integ, RIGID_ADAMS, 1e-10);
    CU_ASSERT_PTR_NOT_NULL_FATAL(r);
    double I[3];
    double prev = omega_mid(r, I), tprev = rigid_time(r);
    double E = rigid_kinetic_energy(r) , L2 = l_norm(r) * l_norm(r);
    double I1 = I[0], I2 = I[1], I3 = I[2], nu, k2;
    if (L2 > 2 * E * I2) {
        nu = sqrt((I3 - I2) * (L2 - 2 * E * I1) / (I1 * I2 * I3));
        k2 = (I2 - I1) * (2 * E * I3 - L2) / ((I3 - I2) * (L2 - 2 * E * I1));
    } else {
        nu = sqrt((I2 - I1) * (2 * E * I3 - L2) / (I1 * I2 * I3));
        k2 = (I3 - I2) * (L2 - 2 * E * I1) / ((I2 - I1) * (2 * E * I3 - L2));
    }
    double T = 4.0 * ellip_k(sqrt(k2)) / nu;
    double cross[8];
    int nc = 0;
    for (int n = 0; n < nsteps && nc < 8; n++) {
        CU_ASSERT_EQUAL_FATAL(rigid_step(r, h), STATUS_OK);
        double cur = omega_mid(r, NULL), t = rigid_time(r);
        if ((prev < 0) != (cur < 0)) {
            cross[nc++] = tprev + (t - tprev) * prev / (prev - cur);
        }
        prev = cur;
        tprev = t;
    }
    CU_ASSERT_FATAL(nc >= 5);
    double Tm = (cross[4] - cross[0]) / 2.0; /* two sign changes per period */
    CU_ASSERT(rel_err(Tm, T) < 0.01);
    rigid_free(r);
}

static void test_top_flip_verlet(void) { flip_period(RIGID_VERLET, 2e-3, 200000); }
static void test_top_flip_cvode(void) { flip_period(RIGID_CVODE, 0.05, 10000); }

/* v(T) for the linear drag problem; returns the error against v0 exp(-T c/m) */
static double drag_error(rigid_integrator_t integ, rigid_cvode_method_t meth, double h, double *vout)
{
    rigid_sphere_cfg_t s = {{0, 0, 0}, 0.5, 0};
    rigid_body_cfg_t b = {1000.0, {1.0, 0.5, 0}, {0, 0, 0}, 0};
    rigid_config_t cfg = test_cfg(1, &s, 1, &b, 0, NULL);
    cfg.integrator = integ;
    cfg.cvode_method = meth;
    cfg.rtol = 1e-11;
    cfg.atol = 1e-13;
    cfg.load_correction = 1; /* a given drag law: second-order coupling */
    rigid_t *r = NULL;
    if (rigid_create(&cfg, NULL, &r) != STATUS_OK) {
        return INFINITY;
    }
    double m;
    rigid_get_body(r, 0, NULL, NULL, NULL, NULL, &m, NULL);
    double c = 2.0 * m; /* decay rate c/m = 2 1/s */
    int n = (int)lround(1.0 / h);
    for (int k = 0; k < n; k++) {
        double x[3], v[3], w[3], f[3], t[3] = {0, 0, 0};
        rigid_get_sphere(r, 0, x, v, w);
        for (int a = 0; a < 3; a++) {
            f[a] = -c * v[a];
        }
        rigid_set_sphere_load(r, 0, f, t);
        if (rigid_step(r, h) != STATUS_OK) {
            rigid_free(r);
            return INFINITY;
        }
    }
    double x[3], v[3];
    rigid_get_sphere(r, 0, x, v, NULL);
    double ex = exp(-2.0 * rigid_time(r));
    if (vout != NULL) {
        *vout = v[0];
    }
    rigid_free(r);
    return fabs(v[0] - ex) + fabs(v[1] - 0.5 * ex);
}

static void test_drag_verlet_order(void)
{
    double e1 = drag_error(RIGID_VERLET, RIGID_ADAMS, 0.02, NULL);
    double e2 = drag_error(RIGID_VERLET, RIGID_ADAMS, 0.01, NULL);
    double e3 = drag_error(RIGID_VERLET, RIGID_ADAMS, 0.005, NULL);
    CU_ASSERT(e1 / e2 > 3.6 && e1 / e2 < 4.4);
    CU_ASSERT(e2 / e3 > 3.6 && e2 / e3 < 4.4);
    CU_ASSERT(e3 < 1e-4);
}

static void test_drag_cvode(void)
{
    /* With the load held within a step, the exact solution of each step's ODE
     * is what Verlet computes (constant force); CVODE must agree with it to
     * its tolerance, and show the same second-order coupling error. */
    double vv, vc, va;
    double ev = drag_error(RIGID_VERLET, RIGID_ADAMS, 0.01, &vv);
    double ec = drag_error(RIGID_CVODE, RIGID_BDF, 0.01, &vc);
    double ea = drag_error(RIGID_CVODE, RIGID_ADAMS, 0.01, &va);
    CU_ASSERT(fabs(vc - vv) < 1e-8);
    CU_ASSERT(fabs(va - vv) < 1e-8);
    CU_ASSERT(rel_err(ec, ev) < 1e-3);
    double ec2 = drag_error(RIGID_CVODE, RIGID_ADAMS, 0.005, NULL);
    CU_ASSERT(ea / ec2 > 3.6 && ea / ec2 < 4.4);
}

/* d rotated by the angle |w| t about w (Rodrigues). */
static void rodrigues(const double w[3], double t, const double d[3], double out[3])
{
    const double wn = vec_norm(w), th = wn * t, k[3] = {w[0] / wn, w[1] / wn, w[2] / wn};
    const double kd = k[0] * d[0] + k[1] * d[1] + k[2] * d[2];
    const double kx[3] = {k[1] * d[2] - k[2] * d[1], k[2] * d[0] - k[0] * d[2], k[0] * d[1] - k[1] * d[0]};
    for (int a = 0; a < 3; a++) {
        out[a] = d[a] * cos(th) + kx[a] * sin(th) + k[a] * kd * (1.0 - cos(th));
    }
}

static void run_release(rigid_integrator_t integ)
{
    const double w0[3] = {0.4, 1.0, 0.3}, v0[3] = {0.1, -0.2, 0.05}, h = 0.01;
    rigid_body_cfg_t b = {1.0, {v0[0], v0[1], v0[2]}, {w0[0], w0[1], w0[2]}, 0};
    /* every arm joined to the centre by a neck far weaker than the loads */
    const rigid_connection_cfg_t c[4] = {
        {0, 1, 1e-9, 1e-9, 0}, {0, 2, 1e-9, 1e-9, 0}, {0, 3, 1e-9, 1e-9, 0}, {0, 4, 1e-9, 1e-9, 0}};
    rigid_config_t cfg = test_cfg(5, top_spheres, 1, &b, 4, c);
    cfg.integrator = integ;
    cfg.gravity[2] = -9.81;
    cfg.release_time = 10 * h; /* ten steps held; the clock reaches it with round-off */
    rigid_t *r = NULL;
    CU_ASSERT_FATAL(rigid_create(&cfg, NULL, &r) == STATUS_OK);
    double x0[5][3], com0[3], q[4], v[3], w[3], mass, iw[9];
    rigid_get_body(r, 0, com0, q, v, w, &mass, iw);
    for (int i = 0; i < 5; i++) {
        rigid_get_sphere(r, i, x0[i], NULL, NULL);
    }
    const double f[3] = {3.0, -1.0, 2.0}, tq[3] = {0.5, 0.2, -0.7};
    double err_x = 0.0, err_w = 0.0, err_v = 0.0, fc = 0.0, fa = 0.0;
    int intact_all = 1;
    for (int n = 1; n <= 10; n++) {
        for (int i = 0; i < 5; i++) {
            rigid_set_sphere_load(r, i, f, tq);
        }
        CU_ASSERT_FATAL(rigid_step(r, h) == STATUS_OK);
        const double t = rigid_time(r);
        double com[3];
        rigid_get_body(r, 0, com, q, v, w, &mass, iw);
        for (int a = 0; a < 3; a++) {
            err_v = fmax(err_v, fabs(v[a] - v0[a]));
            err_w = fmax(err_w, fabs(w[a] - w0[a]));
        }
        for (int i = 0; i < 5; i++) {
            double x[3], d0[3], d[3], ft[3], tt[3];
            rigid_get_sphere(r, i, x, NULL, NULL);
            for (int a = 0; a < 3; a++) {
                d0[a] = x0[i][a] - com0[a];
            }
            rodrigues(w0, t, d0, d);
            for (int a = 0; a < 3; a++) {
                err_x = fmax(err_x, fabs(x[a] - (com0[a] + v0[a] * t + d[a])));
            }
            rigid_get_sphere_applied_load(r, i, ft, tt);
            fa = fmax(fa, fmax(vec_norm(ft), vec_norm(tt)));
        }
        for (int k = 0; k < 4; k++) {
            double cf[3], ct[3];
            int intact;
            rigid_get_connection(r, k, cf, ct, &intact);
            fc = fmax(fc, fmax(vec_norm(cf), vec_norm(ct)));
            intact_all &= intact;
        }
    }
    CU_ASSERT(err_x < 1e-12);
    CU_ASSERT(err_v == 0.0);
    CU_ASSERT(err_w < 1e-12);
    CU_ASSERT(fc == 0.0 && fa == 0.0);
    CU_ASSERT(intact_all && rigid_nbodies(r) == 1);
    /* the step after the release: the load and gravity act, the necks break */
    for (int i = 0; i < 5; i++) {
        rigid_set_sphere_load(r, i, f, tq);
    }
    CU_ASSERT_FATAL(rigid_step(r, h) == STATUS_OK);
    double pm[3], lm[3];
    rigid_momentum(r, pm, lm);
    const double pz = mass * (v0[2] - 9.81 * h) + 5 * h * f[2];
    CU_ASSERT(fabs(pm[0] - (mass * v0[0] + 5 * h * f[0])) < 1e-9 * mass);
    CU_ASSERT(fabs(pm[2] - pz) < 1e-9 * mass);
    CU_ASSERT(rigid_nbodies(r) == 5);
    rigid_free(r);
}

static void test_release_verlet(void) { run_release(RIGID_VERLET); }
static void test_release_cvode(void) { run_release(RIGID_CVODE); }

void test_dynamics_register(void)
{
    CU_pSuite s = CU_add_suite("rigid_dynamics", NULL, NULL);
    CU_add_test(s, "torque-free top, Verlet: E and |L| bounded over 1e5 steps", test_top_verlet_invariants);
    CU_add_test(s, "torque-free top, CVODE: E and |L| within tolerance", test_top_cvode_invariants);
    CU_add_test(s, "intermediate-axis flip period (Verlet) vs 4K(k)/nu", test_top_flip_verlet);
    CU_add_test(s, "intermediate-axis flip period (CVODE) vs 4K(k)/nu", test_top_flip_cvode);
    CU_add_test(s, "linear drag: Verlet second order", test_drag_verlet_order);
    CU_add_test(s, "linear drag: CVODE within tolerance", test_drag_cvode);
    CU_add_test(s, "release time: held motion exact, no load, no break; then the load (Verlet)", test_release_verlet);
    CU_add_test(s, "release time: the same with CVODE", test_release_cvode);
}
