/* test_sphere_motion.c — spheres that move through the fluid: momentum
 * book-keeping, drag fluctuations, mirror symmetry and the stability of the
 * cells they uncover, the speed limit and numerical trouble next to a sphere
 * (split from test_spheres.c, which keeps geometry, drag, rotation and state). */
#include "fluid_tests.h"
#include "sphere_harness.h"
#include "test_util.h"

#include "../../common/coupling.h"
#include "../../fluid/boundary.h"
#include "../../fluid/fluid_internal.h"

#include <CUnit/CUnit.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- moving sphere: momentum book-keeping and fluctuations --------------- */

typedef struct {
    double drift_per_step; /* |P_fluid + impulse - P0| / steps, lattice */
    double fluct;          /* std/mean of the drag after the transient */
    double mean;
} moving_t;

static moving_t moving_sphere(boundary_scheme_t scheme, force_method_t force, refill_t refill, collision_t op,
                              double a, long steps, int driven)
{
    const harness_moving_t h = harness_moving_sphere(scheme, force, refill, op, a, steps, driven);
    moving_t r = {h.drift_per_step, h.fluct, h.mean};
    return r;
}

static void test_moving_sphere_momentum_bounce_back(void)
{
    const moving_t m = moving_sphere(BOUNDARY_BOUNCE_BACK, FORCE_MOMENTUM_EXCHANGE, REFILL_EQUILIBRIUM,
                                     COLLISION_TRT, 4.0, 400, 0);
    printf("\n    bounce-back: momentum drift %.2e per step (drag %.3e)", m.drift_per_step, m.mean);
    CU_ASSERT(m.drift_per_step < 1e-14 * 1e3 * fabs(m.mean) + 1e-15);
}

static void test_moving_sphere_fluctuation(void)
{
    const moving_t paper = moving_sphere(BOUNDARY_YU, FORCE_MOMENTUM_EXCHANGE, REFILL_EQUILIBRIUM, COLLISION_TRT,
                                         5.0, 3000, 1);
    const moving_t best = moving_sphere(BOUNDARY_CLI, FORCE_GALILEAN, REFILL_EXTRAPOLATION, COLLISION_TRT, 5.0,
                                        3000, 1);
    /* issue 11: multireflection at Lambda 1/4, the default, must not fluctuate more than cli (the
     * default before it, at 3/16) */
    const double magic = test_box_magic;
    test_box_magic = 0.25;
    const moving_t mr = moving_sphere(BOUNDARY_MULTIREFLECTION, FORCE_GALILEAN, REFILL_EXTRAPOLATION, COLLISION_TRT,
                                      5.0, 3000, 1);
    test_box_magic = magic;
    printf("\n    drag fluctuation: paper (yu, mem, equilibrium) %.4f, cli + galilean + extrapolation %.4f, "
           "multireflection %.4f",
           paper.fluct, best.fluct, mr.fluct);
    CU_ASSERT(best.fluct <= paper.fluct / 3.0);
    CU_ASSERT(mr.fluct <= best.fluct);
}


/* ---- symmetry ------------------------------------------------------------ */

/* A sphere moving along z on the axis of a periodic box, its centre on the
 * mirror planes x = 8, y = 8 and x = y of the lattice: no force across the
 * axis and no torque, to round-off, while it uncovers cells behind it that
 * are mirror images of each other (refill by extrapolation, whose ties
 * between directions equally near a cell's normal must not pick one of
 * them: before, 1e-4 of the drag sideways). */
static void test_mirror_symmetric_motion(void)
{
    static const refill_t refills[2] = {REFILL_EXTRAPOLATION, REFILL_EQUILIBRIUM};
    for (int k = 0; k < 2; k++) {
        scene_t s = test_box(16, 16, 24, 0.8, COLLISION_TRT);
        const double c[3] = {7.5, 7.5, 10.3}; /* lattice: 8, 8, 10.8 */
        scene_body_t *b = harness_one_sphere(&s, c, 4.6, MOTION_PRESCRIBED);
        b->velocity[2] = -0.02;
        s.fluid.boundary_scheme = BOUNDARY_CLI;
        s.fluid.refill = refills[k];
        fluid_t *fl = test_fluid(&s);
        double f[3], t[3], worst = 0.0;
        for (int n = 0; n < 120; n++) {
            CU_ASSERT_EQUAL(fluid_step(fl), STATUS_OK);
            fluid_sphere_load_lattice(fl, 0, f, t);
            const double side = fmax(fabs(f[0]), fabs(f[1])), turn = fmax(fabs(t[0]), fmax(fabs(t[1]), fabs(t[2])));
            worst = fmax(worst, fmax(side, turn / 4.6) / fabs(f[2]));
        }
        printf("\n    refill %d: %ld cells uncovered, largest force across the axis or torque / r: %.2g of the drag", k,
               fl->spheres.uncovered_total, worst);
        CU_ASSERT(fl->spheres.uncovered_total > 100);
        CU_ASSERT(worst < 1e-11);
        fluid_free(fl);
    }
}


/* ---- the fluid's mass around a moving sphere near tau = 1/2 -------------- */

/* A prescribed sphere of radius 5 in a closed 32^3 box (no-slip faces) at
 * tau 0.51, TRT at the scheme's default Lambda (1/4 multireflection, 3/16
 * otherwise, where the faces' bounce-back keeps mass exactly): rotating
 * about z at a surface speed of 0.05 in the middle (rotate), or moving
 * down at 0.03 cells a step from 2.5 radii below the lid (translate).
 * Returns the largest |M(n) - M(0)| / M(0) over the steps, the fluid's mass
 * M checked every 50 steps; NaN if the run failed. */
static double mass_drift(boundary_scheme_t scheme, int rotate, long steps, precision_t precision, streaming_t layout)
{
    const double a = 5.0;
    const int L = 32;
    const double magic = test_box_magic;
    const precision_t prec = test_box_precision;
    const streaming_t str = test_box_streaming;
    test_box_magic = scheme == BOUNDARY_MULTIREFLECTION ? 0.25 : 0.1875;
    test_box_precision = precision;
    test_box_streaming = layout;
    scene_t s = test_box(L, L, L, 0.51, COLLISION_TRT);
    test_box_magic = magic;
    test_box_precision = prec;
    test_box_streaming = str;
    for (int f = 0; f < 6; f++) {
        s.domain.faces[f].type = FACE_NO_SLIP;
    }
    const double c[3] = {L / 2.0 + 0.13, L / 2.0 - 0.21, rotate ? L / 2.0 + 0.31 : L - 2.5 * a + 0.07};
    scene_body_t *b = harness_one_sphere(&s, c, a, MOTION_PRESCRIBED);
    if (rotate) {
        b->angular_velocity[2] = 0.05 / a;
    } else {
        b->velocity[2] = -0.03;
    }
    s.fluid.boundary_scheme = scheme;
    s.fluid.refill = REFILL_EXTRAPOLATION;
    s.fluid.force_method = FORCE_GALILEAN;
    fluid_t *fl = test_fluid(&s);
    if (fl == NULL) {
        return NAN;
    }
    double m0, m, mom[3], kin, umax, peak[3], worst = 0.0;
    if (fluid_diagnostics_lattice(fl, 1.0, &m0, mom, &kin, &umax, peak) != STATUS_OK) {
        worst = NAN;
    }
    for (long n = 1; n <= steps && isfinite(worst); n++) {
        if (fluid_step(fl) != STATUS_OK) {
            worst = NAN;
        } else if (n % 50 == 0) {
            if (fluid_diagnostics_lattice(fl, 1.0, &m, mom, &kin, &umax, peak) != STATUS_OK) {
                worst = NAN;
            } else {
                worst = fmax(worst, fabs(m - m0) / m0);
            }
        }
    }
    fluid_free(fl);
    return worst;
}

/* The interpolated schemes give the fluid mass through their links beyond
 * bounce-back's moving-wall flux (sphere_fill.c "mass balance"). Measured
 * before each sphere took that net back (the helper's sweep, 2026-11-27, and
 * this test's scenes): a sphere that only rotates raised the fluid's mass by
 * 3.6e-3 (yu) and 4.7e-3 (quadratic) in 800 steps, without bound (bounce-
 * back 1.7e-6); now 8e-6 and 1.3e-5. cli and multireflection are left out here:
 * at tau 0.51 this rotating sphere goes unstable with them, with or without
 * the balance (README "Known problems"); cli at tau 0.8 gained 1.2e-4. */
static void test_rotating_sphere_keeps_mass(void)
{
    static const boundary_scheme_t schemes[2] = {BOUNDARY_YU, BOUNDARY_QUADRATIC};
    for (int k = 0; k < 2; k++) {
        const double d = mass_drift(schemes[k], 1, 800, PRECISION_DOUBLE, STREAMING_IN_PLACE);
        printf("\n    %s, rotating, tau 0.51, 800 steps: fluid mass within %.2e", boundary_scheme_names[schemes[k]], d);
        CU_ASSERT(d < 2e-5);
    }
    /* single precision and two arrays keep it too */
    const double s1 = mass_drift(BOUNDARY_YU, 1, 800, PRECISION_SINGLE, STREAMING_IN_PLACE);
    const double s2 = mass_drift(BOUNDARY_YU, 1, 800, PRECISION_DOUBLE, STREAMING_TWO_ARRAY);
    printf("; single %.2e, two arrays %.2e", s1, s2);
    CU_ASSERT(s1 < 2e-5);
    CU_ASSERT(s2 < 2e-5);
}

/* Multireflection's n^- correction with TRT near tau = 1/2 gave a sphere
 * moving down a closed box a net mass: 1.6e-3 of the fluid's after 400
 * steps, growing linearly (the other schemes, whose covered and uncovered
 * cells take back bounce-back's flux, about 1e-4 and bounded). Now within
 * bounce-back's figure. */
static void test_translating_sphere_keeps_mass(void)
{
    const double mr = mass_drift(BOUNDARY_MULTIREFLECTION, 0, 400, PRECISION_DOUBLE, STREAMING_IN_PLACE);
    const double bb = mass_drift(BOUNDARY_BOUNCE_BACK, 0, 400, PRECISION_DOUBLE, STREAMING_IN_PLACE);
    const double two = mass_drift(BOUNDARY_MULTIREFLECTION, 0, 400, PRECISION_DOUBLE, STREAMING_TWO_ARRAY);
    printf("\n    moving at 0.03, tau 0.51, 400 steps: fluid mass within %.2e (multireflection), %.2e (two "
           "arrays), %.2e (bounce-back)",
           mr, two, bb);
    CU_ASSERT(mr < 2e-4);
    CU_ASSERT(two < 2e-4);
    CU_ASSERT(bb < 2e-4);
}


/* ---- bad input: a sphere that moves too far in one step ----------------- */

/* A sphere of radius 3 at the centre of a periodic 16^3 box at tau 0.8, its
 * messages in tl. */
static fluid_t *centred_sphere(motion_t motion, test_log_t *tl)
{
    scene_t s = test_box(16, 16, 16, 0.8, COLLISION_TRT);
    const double c[3] = {8.0, 8.0, 8.0};
    harness_one_sphere(&s, c, 3.0, motion);
    log_t l = test_log(tl);
    fluid_t *fl = NULL;
    CU_ASSERT_EQUAL_FATAL(fluid_create(&s, &l, &fl), STATUS_OK);
    return fl;
}

static void test_sphere_speed_limits(void)
{
    test_log_t tl;
    fluid_t *fl = centred_sphere(MOTION_FREE, &tl);
    const double v0[3] = {0.1, 0, 0}, w0[3] = {0, 0, 0};
    double p[3] = {8.1, 8.0, 8.0};
    CU_ASSERT_EQUAL(fluid_set_sphere(fl, 0, p, v0, w0), STATUS_OK);
    /* 0.45 cells in one step: accepted */
    tl.worst = STATUS_OK;
    p[0] = 8.55;
    CU_ASSERT_EQUAL(fluid_set_sphere(fl, 0, p, v0, w0), STATUS_OK);
    CU_ASSERT(tl.worst < STATUS_ERROR);
    /* 0.7 cells: an error naming the sphere, the distance, the step and the
     * remedies, and the sphere stays where it was */
    p[0] = 9.25;
    CU_ASSERT_EQUAL(fluid_set_sphere(fl, 0, p, v0, w0), STATUS_ERROR);
    CU_ASSERT(strstr(tl.last, "sphere 0 moves 0.7 cells in one step at step 0") != NULL);
    CU_ASSERT(strstr(tl.last, "limit half a cell per step") != NULL);
    CU_ASSERT(strstr(tl.last, "fluid.tau") != NULL && strstr(tl.last, "fluid.dx") != NULL);
    /* the velocity input (0.1 cells a step) does not explain the move: said */
    CU_ASSERT(strstr(tl.last, "its velocity input accounts for 0.1 of the 0.7 cells") != NULL);
    double c1[3], v1[3], w1[3];
    fluid_get_sphere(fl, 0, c1, v1, w1);
    CU_ASSERT_DOUBLE_EQUAL(c1[0], 8.55, 1e-12);
    /* far out on the periodic x axis: 1e20 cells is a multiple of 16 in a
     * double, so the sphere would wrap to x = 0, 7.45 cells away (it was
     * taken: the move was measured before the wrap, to round-off of 1e20) */
    const double far[3] = {1e20, 8.0, 8.0};
    CU_ASSERT_EQUAL(fluid_set_sphere(fl, 0, far, v0, w0), STATUS_ERROR);
    CU_ASSERT(strstr(tl.last, "sphere 0 moves 7.45 cells") != NULL);
    fluid_get_sphere(fl, 0, c1, v1, w1);
    CU_ASSERT_DOUBLE_EQUAL(c1[0], 8.55, 1e-12);
    /* a velocity above half a cell per step is refused too (0.6 cells) */
    const double vfast[3] = {0.6, 0, 0};
    CU_ASSERT_EQUAL(fluid_set_sphere(fl, 0, c1, vfast, w0), STATUS_ERROR);
    CU_ASSERT(strstr(tl.last, "moves 0.6 cells") != NULL);
    CU_ASSERT(strstr(tl.last, "accounts for") == NULL); /* a fast velocity, not a jump */
    fluid_free(fl);
}

/* The remedy of a too-fast sphere names the coupling first when the body is
 * light and not coupled implicitly with averaging (its speed most likely grew
 * by the added-mass instability), and does not advise a smaller tau when tau
 * is already close to 1/2. */
static const char *too_fast_message(coupling_t coupling, int averaging, double tau, test_log_t *tl)
{
    scene_t s = test_box(16, 16, 16, tau, COLLISION_TRT);
    const double c[3] = {8.0, 8.0, 8.0};
    harness_one_sphere(&s, c, 3.0, MOTION_FREE)->density = 0.5 * s.fluid.density; /* light: kappa ~ 1.3 */
    s.rigid.coupling = coupling;
    s.fluid.force_averaging = averaging;
    log_t l = test_log(tl);
    fluid_t *fl = NULL;
    if (fluid_create(&s, &l, &fl) != STATUS_OK) {
        return "";
    }
    const double p[3] = {8.8, 8.0, 8.0}, v[3] = {0, 0, 0};
    fluid_set_sphere(fl, 0, p, v, v);
    fluid_free(fl);
    return tl->last;
}

static void test_sphere_speed_remedies(void)
{
    test_log_t tl;
    CU_ASSERT(strstr(too_fast_message(COUPLING_EXPLICIT, 0, 0.8, &tl), "set rigid.coupling: auto (the default) or implicit with fluid.force_averaging: true first") != NULL);
    CU_ASSERT(strstr(too_fast_message(COUPLING_IMPLICIT, 0, 0.8, &tl), "set rigid.coupling: auto (the default) or implicit with fluid.force_averaging: true first") != NULL);
    CU_ASSERT(strstr(too_fast_message(COUPLING_AUTO, -1, 0.8, &tl), "rigid.coupling") == NULL);
    CU_ASSERT(strstr(tl.last, "fluid.tau closer to 0.5") != NULL);
    CU_ASSERT(strstr(too_fast_message(COUPLING_AUTO, -1, 0.52, &tl), "fluid.tau closer to 0.5") == NULL);
    CU_ASSERT(strstr(tl.last, "fluid.tau is already close to 0.5") != NULL && strstr(tl.last, "fluid.dx") != NULL);
}

/* ---- numerical trouble next to a sphere --------------------------------- */

/* A NaN in a fluid cell next to the surface enters the sphere's load in the
 * next step: the cheap check at the end of a communication step
 * (fluid_check_loads) stops there, naming the sphere, and the scan the cell. */
static void test_nan_load_detected(void)
{
    test_log_t tl;
    fluid_t *fl = centred_sphere(MOTION_FIXED, &tl);
    test_run(fl, 2);
    CU_ASSERT_EQUAL(fluid_check_loads(fl, 0.3), STATUS_OK);
    const int nc = 16 * 16 * 16;
    double *rho = malloc(sizeof(double) * nc);
    CU_ASSERT_FATAL(rho != NULL);
    for (int i = 0; i < nc; i++) {
        rho[i] = 1.0;
    }
    rho[11 + 16 * (8 + 16 * 8)] = NAN; /* centre 11.5 m: 3.5 cells from the sphere's centre */
    fluid_set_equilibrium_lattice(fl, rho, NULL);
    free(rho);
    CU_ASSERT_EQUAL(fluid_step(fl), STATUS_OK);
    CU_ASSERT_EQUAL(fluid_check_loads(fl, 0.3), STATUS_ERROR);
    CU_ASSERT_PTR_NOT_NULL(strstr(tl.last, "non-finite hydrodynamic load on sphere 0 at (8, 8, 8) m"));
    CU_ASSERT_PTR_NOT_NULL(strstr(tl.last, "at step 3"));
    CU_ASSERT_PTR_NOT_NULL(strstr(tl.last, "the cell is named above"));
    fluid_free(fl);
}

/* ---- the cells a sphere uncovers, near tau = 1/2 -------------------------- */

/* A sphere of radius 5 driven at v cells a step down the middle of a closed
 * box (6a x 6a x 14a, no-slip faces) at tau 0.51 with the scene defaults for
 * its scheme (TRT; Lambda 1/4 with multireflection, 3/16 otherwise;
 * extrapolation refill), from 2.5 radii below the lid: returns the fastest
 * fluid cell over the sphere's speed, checked every 25 steps, and the steps
 * run before a check failed (its message in tl). */
static double fastest_during_descent(boundary_scheme_t scheme, double v, long steps, long *done, test_log_t *tl)
{
    const double a = 5.0;
    const int L = 30, H = 70;
    scene_t s = test_box(L, L, H, 0.51, COLLISION_TRT);
    for (int f = 0; f < 6; f++) {
        s.domain.faces[f].type = FACE_NO_SLIP;
    }
    s.fluid.magic = scheme == BOUNDARY_MULTIREFLECTION ? 0.25 : 0.1875;
    const double c[3] = {L / 2.0 + 0.13, L / 2.0 - 0.21, H - 2.5 * a};
    scene_body_t *b = harness_one_sphere(&s, c, a, MOTION_PRESCRIBED);
    b->velocity[2] = -v;
    s.fluid.boundary_scheme = scheme;
    s.fluid.refill = REFILL_EXTRAPOLATION;
    log_t l = test_log(tl);
    fluid_t *fl = NULL;
    CU_ASSERT_EQUAL_FATAL(fluid_create(&s, &l, &fl), STATUS_OK);
    double worst = 0.0, mass, mom[3], kin, umax, peak[3];
    *done = 0;
    for (long n = 1; n <= steps; n++) {
        if (fluid_step(fl) != STATUS_OK) {
            break;
        }
        if (n % 25 == 0) {
            if (fluid_diagnostics_lattice(fl, 1.0, &mass, mom, &kin, &umax, peak) != STATUS_OK) {
                worst = INFINITY;
                break;
            }
            worst = fmax(worst, umax);
        }
        *done = n;
    }
    fluid_free(fl);
    return worst / v;
}

/* At 0.045 cells a step (1000 steps, 45 cells, ending 7.5 cells above the
 * floor) the fastest fluid cell stays near the sphere's own speed. Before
 * the refill took the neighbour's non-equilibrium part instead of
 * extrapolating it linearly from two cells, which behind the sphere are
 * cells refilled a few steps earlier, the noise of the uncovered cells grew
 * with multireflection (1.5 v at step 300, 4.4 v at 500) until the density
 * went negative at step 550. The restitution scenes of make validate (a free
 * sphere, tau 0.51, 15 cells across) stopped on the same growth at its rear
 * (Mach 0.37). */
static void test_uncovered_cells_stay_quiet(void)
{
    static const boundary_scheme_t schemes[2] = {BOUNDARY_MULTIREFLECTION, BOUNDARY_CLI};
    for (int k = 0; k < 2; k++) {
        long done;
        test_log_t tl;
        const double r = fastest_during_descent(schemes[k], 0.045, 1000, &done, &tl);
        printf("\n    %s, tau 0.51, 0.045 cells a step: %ld steps, fastest fluid cell %.3f of the sphere's speed",
               boundary_scheme_names[schemes[k]], done, r);
        CU_ASSERT_EQUAL(done, 1000);
        CU_ASSERT(r < 1.5);
    }
}

/* At 0.12 cells a step (cell Reynolds number 36) multireflection's n^-
 * correction fails first (measured: stopped at step 200; without the
 * correction, or with cli, it ran on): its message names cli as the
 * remedy, and cli runs the descent (375 steps, 45 cells; its fluid, under-
 * resolved at this Reynolds number, 2.5 times the sphere's speed at most). */
static void test_fast_sphere_near_half_tau(void)
{
    long done;
    test_log_t tl;
    double r = fastest_during_descent(BOUNDARY_MULTIREFLECTION, 0.12, 375, &done, &tl);
    printf("\n    multireflection, tau 0.51, 0.12 cells a step: stopped after %ld steps", done);
    CU_ASSERT(done < 375);
    CU_ASSERT(isinf(r));
    CU_ASSERT_PTR_NOT_NULL(strstr(tl.last, "numerical trouble at step"));
    CU_ASSERT_PTR_NOT_NULL(strstr(tl.last, "fluid.boundary_scheme: cli"));
    r = fastest_during_descent(BOUNDARY_CLI, 0.12, 375, &done, &tl);
    printf("; cli: %ld steps, fastest fluid cell %.3f of the sphere's speed", done, r);
    CU_ASSERT_EQUAL(done, 375);
    CU_ASSERT(isfinite(r));
}

void sphere_motion_register_tests(void)
{
    CU_pSuite s = CU_add_suite("sphere_motion", NULL, NULL);
    CU_add_test(s, "moving sphere, bounce-back: momentum conserved", test_moving_sphere_momentum_bounce_back);
    CU_add_test(s, "moving sphere: fluctuation a third of the paper's, multireflection <= cli",
                test_moving_sphere_fluctuation);
    CU_add_test(s, "a sphere moving on a mirror axis: no force across it, no torque (refill ties)",
                test_mirror_symmetric_motion);
    CU_add_test(s, "a sphere moving down a closed box at tau 0.51: the cells it uncovers stay quiet",
                test_uncovered_cells_stay_quiet);
    CU_add_test(s, "a fast sphere at tau 0.51: multireflection stops naming cli, cli runs",
                test_fast_sphere_near_half_tau);
    CU_add_test(s, "a sphere rotating at tau 0.51 keeps the fluid's mass (yu, quadratic)",
                test_rotating_sphere_keeps_mass);
    CU_add_test(s, "a sphere moving at tau 0.51 keeps the fluid's mass (multireflection, TRT)",
                test_translating_sphere_keeps_mass);
    CU_add_test(s, "a sphere moving more than half a cell per step is refused", test_sphere_speed_limits);
    CU_add_test(s, "a too-fast sphere's remedy: the coupling first for a light body, no smaller tau near 1/2",
                test_sphere_speed_remedies);
    CU_add_test(s, "numerical trouble: a NaN next to a sphere stops at its load", test_nan_load_detected);
}
