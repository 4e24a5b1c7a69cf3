/* test_connection.c — connection force and torque by the free-body diagram
 * (Iglberger, Thuerey, Ruede 2008, Eq. 8 and 9).
 *
 * References: a dumbbell of two equal touching spheres spinning at constant
 * omega about an axis through its centre of mass, perpendicular to its axis:
 * each sphere moves on a circle of radius d (centre to centre of mass), so the
 * connection must carry the centripetal force m omega^2 d (tensile) and no
 * torque. A symmetric star spinning about its symmetry axis: opposite
 * connections carry opposite forces (the paper's Fig. 8 observation, here
 * exact by symmetry). A triangle of three touching spheres: the connection
 * 0-1 lies on a cycle; the smallest cut containing it is {0-1, 0-2}, which
 * isolates sphere 0, whose centripetal force is m omega^2 (2r/sqrt 3). */
#include "test_rigid_util.h"

static void test_dumbbell(rigid_integrator_t integ)
{
    double rr = 0.01, rho = 2000.0, w = 5.0;
    rigid_sphere_cfg_t s[2] = {{{-rr, 0, 0}, rr, 0}, {{rr, 0, 0}, rr, 0}};
    rigid_body_cfg_t b = {rho, {0.1, -0.2, 0.05}, {0, 0, w}, 0};
    rigid_connection_cfg_t c = {0, 1, 0, 0, 0};
    rigid_config_t cfg = test_cfg(2, s, 1, &b, 1, &c);
    cfg.integrator = integ;
    cfg.rtol = 1e-10;
    rigid_t *r = NULL;
    CU_ASSERT_EQUAL_FATAL(rigid_create(&cfg, NULL, &r), STATUS_OK);
    double m = rho * 4.0 / 3.0 * M_PI * rr * rr * rr, fref = m * w * w * rr;
    for (int n = 0; n <= 20; n++) {
        double f[3], t[3], xa[3], xb[3];
        int intact;
        rigid_get_connection(r, 0, f, t, &intact);
        rigid_get_sphere(r, 0, xa, NULL, NULL);
        rigid_get_sphere(r, 1, xb, NULL, NULL);
        double nrm[3] = {(xb[0] - xa[0]) / (2 * rr), (xb[1] - xa[1]) / (2 * rr), (xb[2] - xa[2]) / (2 * rr)};
        CU_ASSERT(intact == 1);
        CU_ASSERT(rel_err(vec_norm(f), fref) < 1e-10);
        CU_ASSERT(rel_err(f[0] * nrm[0] + f[1] * nrm[1] + f[2] * nrm[2], fref) < 1e-10); /* tensile */
        CU_ASSERT(vec_norm(t) < 1e-10 * fref * rr);
        CU_ASSERT_EQUAL_FATAL(rigid_step(r, 0.01), STATUS_OK);
    }
    rigid_free(r);
}

static void test_dumbbell_verlet(void) { test_dumbbell(RIGID_VERLET); }
static void test_dumbbell_cvode(void) { test_dumbbell(RIGID_CVODE); }

static void test_star_opposite(void)
{
    /* central sphere and four arms in the x-y plane; spin about z plus gravity
     * along z and a hydrodynamic torque about z on the centre: the agglomerate
     * spins up (angular acceleration) and falls */
    double R = 4e-4, rr = 4e-4, D = R + rr;
    rigid_sphere_cfg_t s[5] = {
        {{0, 0, 0}, R, 0}, {{D, 0, 0}, rr, 0}, {{-D, 0, 0}, rr, 0}, {{0, D, 0}, rr, 0}, {{0, -D, 0}, rr, 0}};
    rigid_body_cfg_t b = {2000.0, {0, 0, 0}, {0, 0, 30.0}, 0};
    rigid_connection_cfg_t c[4] = {{0, 1, 0, 0, 0}, {0, 2, 0, 0, 0}, {0, 3, 0, 0, 0}, {0, 4, 0, 0, 0}};
    rigid_config_t cfg = test_cfg(5, s, 1, &b, 4, c);
    cfg.gravity[2] = -9.81;
    cfg.fluid_density = 1000.0;
    rigid_t *r = NULL;
    CU_ASSERT_EQUAL_FATAL(rigid_create(&cfg, NULL, &r), STATUS_OK);
    const double tz[3] = {0, 0, 1e-9}, zero[3] = {0, 0, 0};
    for (int n = 0; n < 50; n++) {
        rigid_set_sphere_load(r, 0, zero, tz);
        CU_ASSERT_EQUAL_FATAL(rigid_step(r, 1e-3), STATUS_OK);
        double f1[3], f2[3], f3[3], f4[3], t1[3], t2[3];
        rigid_get_connection(r, 0, f1, t1, NULL);
        rigid_get_connection(r, 1, f2, t2, NULL);
        rigid_get_connection(r, 2, f3, NULL, NULL);
        rigid_get_connection(r, 3, f4, NULL, NULL);
        double scale = vec_norm(f1);
        CU_ASSERT(scale > 0.0);
        /* in-plane components opposite, z components (gravity - buoyancy
         * carried by each arm) equal */
        for (int a = 0; a < 2; a++) {
            CU_ASSERT(fabs(f1[a] + f2[a]) < 1e-12 * scale);
            CU_ASSERT(fabs(f3[a] + f4[a]) < 1e-12 * scale);
        }
        CU_ASSERT(fabs(f1[2] - f2[2]) < 1e-12 * scale);
        CU_ASSERT(rel_err(vec_norm(f1), vec_norm(f2)) < 1e-12);
        CU_ASSERT(rel_err(vec_norm(f3), vec_norm(f1)) < 1e-12);
    }
    rigid_free(r);
}

static void test_cycle_smallest_cut(void)
{
    double rr = 0.01, rho = 1000.0, w = 3.0;
    double h = sqrt(3.0) * rr;
    rigid_sphere_cfg_t s[3] = {{{0, 2.0 * h / 3.0, 0}, rr, 0}, {{-rr, -h / 3.0, 0}, rr, 0}, {{rr, -h / 3.0, 0}, rr, 0}};
    rigid_body_cfg_t b = {rho, {0, 0, 0}, {0, 0, w}, 0};
    rigid_connection_cfg_t c[3] = {{0, 1, 0, 0, 0}, {1, 2, 0, 0, 0}, {2, 0, 0, 0, 0}};
    rigid_config_t cfg = test_cfg(3, s, 1, &b, 3, c);
    rigid_t *r = NULL;
    CU_ASSERT_EQUAL_FATAL(rigid_create(&cfg, NULL, &r), STATUS_OK);
    double m = rho * 4.0 / 3.0 * M_PI * rr * rr * rr, fref = m * w * w * 2.0 * h / 3.0;
    double f[3];
    rigid_get_connection(r, 0, f, NULL, NULL);
    CU_ASSERT(rel_err(vec_norm(f), fref) < 1e-10);
    /* force on sphere 0 points to the centre of mass (-y) */
    CU_ASSERT(rel_err(-f[1], fref) < 1e-10);
    rigid_free(r);
}

/* A fixed chain of five touching spheres under gravity, its connections
 * listed a->b along the chain or reversed: the body is held at every sphere,
 * so no connection carries a load or breaks, in either order (the sections'
 * free-body diagram with a_s = 0 gave mg, 2mg, 3mg, 4mg along the chain in one
 * order and 4mg ... mg in the other, and broke the last two or the first two
 * connections under a shear limit of 2.5 mg). */
static void test_fixed_body_carries_nothing(void)
{
    double rr = 0.01, rho = 2000.0, g = 9.81;
    double m = rho * 4.0 / 3.0 * M_PI * rr * rr * rr;
    rigid_sphere_cfg_t s[5];
    for (int i = 0; i < 5; i++) {
        s[i] = (rigid_sphere_cfg_t){{2.0 * rr * i, 0, 0}, rr, 0};
    }
    rigid_body_cfg_t b = {rho, {0, 0, 0}, {0, 0, 0}, 1};
    for (int rev = 0; rev < 2; rev++) {
        rigid_connection_cfg_t c[4];
        for (int k = 0; k < 4; k++) {
            c[k] = (rigid_connection_cfg_t){rev ? k + 1 : k, rev ? k : k + 1, 0, 2.5 * m * g, 0};
        }
        rigid_config_t cfg = test_cfg(5, s, 1, &b, 4, c);
        cfg.gravity[2] = -g;
        rigid_t *r = NULL;
        CU_ASSERT_EQUAL_FATAL(rigid_create(&cfg, NULL, &r), STATUS_OK);
        for (int n = 0; n < 3; n++) {
            CU_ASSERT_EQUAL_FATAL(rigid_step(r, 1e-4), STATUS_OK);
        }
        for (int k = 0; k < 4; k++) {
            double f[3], t[3];
            int intact;
            rigid_get_connection(r, k, f, t, &intact);
            CU_ASSERT(intact == 1);
            CU_ASSERT(vec_norm(f) == 0.0 && vec_norm(t) == 0.0);
        }
        CU_ASSERT_EQUAL(rigid_nbodies(r), 1);
        rigid_free(r);
    }
}

void test_connection_register(void)
{
    CU_pSuite s = CU_add_suite("rigid_connection", NULL, NULL);
    CU_add_test(s, "spinning dumbbell (Verlet): m w^2 d to 1e-10", test_dumbbell_verlet);
    CU_add_test(s, "spinning dumbbell (CVODE): m w^2 d to 1e-10", test_dumbbell_cvode);
    CU_add_test(s, "symmetric star: opposite connections opposite", test_star_opposite);
    CU_add_test(s, "cycle: resultant over the smallest cut", test_cycle_smallest_cut);
    CU_add_test(s, "fixed body: connections carry nothing, break in neither order", test_fixed_body_carries_nothing);
}
