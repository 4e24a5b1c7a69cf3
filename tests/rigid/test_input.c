/* test_input.c — bad input is refused with a message naming the body,
 * sphere or connection; numerical trouble is reported; the state round-trips
 * bit-identically; two instances coexist (FMI requires it). */
#include "test_rigid_util.h"

#include <stdlib.h>

static status_t try_create(const rigid_config_t *cfg, test_log_t *tl)
{
    log_t lg = {test_log_fn, tl};
    rigid_t *r = NULL;
    status_t st = rigid_create(cfg, &lg, &r);
    rigid_free(r);
    return st;
}

static void test_bad_input(void)
{
    double rr = 0.01;
    rigid_sphere_cfg_t s[3] = {{{0, 0, 0}, rr, 0}, {{2 * rr, 0, 0}, rr, 0}, {{5 * rr, 0, 0}, rr, 1}};
    rigid_body_cfg_t b[2] = {{1000.0, {0, 0, 0}, {0, 0, 0}, 0}, {1000.0, {0, 0, 0}, {0, 0, 0}, 0}};
    rigid_connection_cfg_t c = {0, 1, 1.0, 1.0, 1.0};
    test_log_t tl = {"", 0};
    rigid_config_t cfg = test_cfg(3, s, 2, b, 1, &c);
    CU_ASSERT_EQUAL(try_create(&cfg, &tl), STATUS_OK);

    /* a connection between spheres that do not touch */
    rigid_sphere_cfg_t s2[3];
    memcpy(s2, s, sizeof s);
    s2[1].center[0] = 2.5 * rr;
    s2[2].body = 0;
    s2[2].center[0] = 4.5 * rr; /* keeps body 0 one piece through sphere 2 */
    rigid_sphere_cfg_t s3[3];
    memcpy(s3, s2, sizeof s3);
    rigid_body_cfg_t b1 = b[0];
    cfg = test_cfg(3, s2, 1, &b1, 1, &c);
    CU_ASSERT_EQUAL(try_create(&cfg, &tl), STATUS_ERROR);
    CU_ASSERT_PTR_NOT_NULL(strstr(tl.last, "connection 0: spheres 0 and 1 of body 0 do not touch"));

    /* a body whose spheres are not connected */
    rigid_sphere_cfg_t s4[2] = {{{0, 0, 0}, rr, 0}, {{3 * rr, 0, 0}, rr, 0}};
    cfg = test_cfg(2, s4, 1, &b1, 0, NULL);
    CU_ASSERT_EQUAL(try_create(&cfg, &tl), STATUS_ERROR);
    CU_ASSERT_PTR_NOT_NULL(strstr(tl.last, "body 0 is not one piece: sphere 1"));

    /* non-positive density and radius */
    rigid_body_cfg_t b2[2] = {b[0], b[1]};
    b2[1].density = 0.0;
    cfg = test_cfg(3, s, 2, b2, 1, &c);
    CU_ASSERT_EQUAL(try_create(&cfg, &tl), STATUS_ERROR);
    CU_ASSERT_PTR_NOT_NULL(strstr(tl.last, "body 1: density 0"));
    memcpy(s3, s, sizeof s3);
    s3[2].radius = -1e-3;
    cfg = test_cfg(3, s3, 2, b, 1, &c);
    CU_ASSERT_EQUAL(try_create(&cfg, &tl), STATUS_ERROR);
    CU_ASSERT_PTR_NOT_NULL(strstr(tl.last, "sphere 2: radius -0.001"));

    /* negative limit */
    rigid_connection_cfg_t c2 = {0, 1, 1.0, -2.0, 1.0};
    cfg = test_cfg(3, s, 2, b, 1, &c2);
    CU_ASSERT_EQUAL(try_create(&cfg, &tl), STATUS_ERROR);
    CU_ASSERT_PTR_NOT_NULL(strstr(tl.last, "connection 0 (spheres 0-1): max_shear (N) is -2"));

    /* connection across bodies, contact parameters */
    rigid_connection_cfg_t c3 = {1, 2, 0, 0, 0};
    cfg = test_cfg(3, s, 2, b, 1, &c3);
    CU_ASSERT_EQUAL(try_create(&cfg, &tl), STATUS_ERROR);
    CU_ASSERT_PTR_NOT_NULL(strstr(tl.last, "connection 0: sphere 1 (body 0) and sphere 2 (body 1)"));
    cfg = test_cfg(3, s, 2, b, 1, &c);
    cfg.contact_model = RIGID_CONTACT_SPRING_DASHPOT;
    cfg.restitution = 0.5;
    cfg.contact_time = 0.0;
    CU_ASSERT_EQUAL(try_create(&cfg, &tl), STATUS_ERROR);
    CU_ASSERT_PTR_NOT_NULL(strstr(tl.last, "contact_time 0"));
    CU_ASSERT(tl.nerr == 7);
}

static void test_nan_load_reported(void)
{
    rigid_sphere_cfg_t s = {{0, 0, 0}, 0.01, 0};
    rigid_body_cfg_t b = {1000.0, {0, 0, 0}, {0, 0, 0}, 0};
    rigid_config_t cfg = test_cfg(1, &s, 1, &b, 0, NULL);
    for (int integ = 0; integ < 2; integ++) {
        cfg.integrator = integ ? RIGID_CVODE : RIGID_VERLET;
        test_log_t tl = {"", 0};
        log_t lg = {test_log_fn, &tl};
        rigid_t *r = NULL;
        CU_ASSERT_EQUAL_FATAL(rigid_create(&cfg, &lg, &r), STATUS_OK);
        const double f[3] = {NAN, 0, 0};
        rigid_set_sphere_load(r, 0, f, NULL);
        CU_ASSERT_EQUAL(rigid_step(r, 1e-3), STATUS_ERROR);
        CU_ASSERT(tl.nerr == 1);
        CU_ASSERT_PTR_NOT_NULL(strstr(tl.last, "t="));
        CU_ASSERT_PTR_NOT_NULL(strstr(tl.last, "body 0"));
        rigid_free(r);
    }
}

/* A scene with everything: contacts, a wall, gravity, connections, loads. */
static void restart_case(rigid_integrator_t integ)
{
    double rr = 1e-3;
    rigid_sphere_cfg_t s[4] = {
        {{0, 0, 0.01}, rr, 0}, {{2 * rr, 0, 0.01}, rr, 0}, {{0.5 * rr, 0.2 * rr, 0.01 - 2.2 * rr}, rr, 1}, {{0, 0, 0.0012}, rr, 2}};
    rigid_body_cfg_t b[3] = {{2500.0, {0, 0, -0.1}, {1, 2, 3}, 0}, {2500.0, {0, 0, 0.1}, {0, 0, 0}, 0},
                             {2500.0, {0, 0, 0}, {0, 0, 0}, 0}};
    rigid_connection_cfg_t c = {0, 1, 1e-2, 0, 0};
    rigid_config_t cfg = test_cfg(4, s, 3, b, 1, &c);
    cfg.gravity[2] = -9.81;
    cfg.contact_model = RIGID_CONTACT_SPRING_DASHPOT;
    cfg.restitution = 0.5;
    cfg.contact_time = 1e-3;
    cfg.friction = 0.3;
    cfg.stick_speed = 0.05;
    cfg.walls[2][0] = 1;
    cfg.box_hi[2] = 1;
    cfg.integrator = integ;
    cfg.cvode_method = RIGID_BDF;
    rigid_t *a = NULL, *bb = NULL;
    CU_ASSERT_EQUAL_FATAL(rigid_create(&cfg, NULL, &a), STATUS_OK);
    CU_ASSERT_EQUAL_FATAL(rigid_create(&cfg, NULL, &bb), STATUS_OK);
    const double f[3] = {1e-5, 0, 0}, t[3] = {0, 1e-9, 0};
    for (int n = 0; n < 30; n++) {
        rigid_set_sphere_load(a, n % 4, f, t);
        CU_ASSERT_EQUAL_FATAL(rigid_step(a, 1e-4), STATUS_OK);
    }
    size_t sz = rigid_state_size(a);
    void *buf = malloc(sz);
    CU_ASSERT_EQUAL_FATAL(rigid_state_save(a, buf, sz), STATUS_OK);
    CU_ASSERT_EQUAL(rigid_state_restore(bb, buf, sz), STATUS_OK);
    free(buf);
    for (int n = 30; n < 200; n++) {
        rigid_set_sphere_load(a, n % 4, f, t);
        rigid_set_sphere_load(bb, n % 4, f, t);
        CU_ASSERT_EQUAL_FATAL(rigid_step(a, 1e-4), STATUS_OK);
        CU_ASSERT_EQUAL_FATAL(rigid_step(bb, 1e-4), STATUS_OK);
    }
    int same = rigid_nbodies(a) == rigid_nbodies(bb) && rigid_nconnections(a) == rigid_nconnections(bb);
    for (int i = 0; i < 4 && same; i++) {
        double xa[3], va[3], wa[3], xb[3], vb[3], wb[3];
        rigid_get_sphere(a, i, xa, va, wa);
        rigid_get_sphere(bb, i, xb, vb, wb);
        same = memcmp(xa, xb, sizeof xa) == 0 && memcmp(va, vb, sizeof va) == 0 && memcmp(wa, wb, sizeof wa) == 0;
    }
    CU_ASSERT(same);
    CU_ASSERT(rigid_time(a) == rigid_time(bb));
    rigid_free(a);
    rigid_free(bb);
}

static void test_restart_verlet(void) { restart_case(RIGID_VERLET); }
static void test_restart_cvode(void) { restart_case(RIGID_CVODE); }

void test_input_register(void)
{
    CU_pSuite s = CU_add_suite("rigid_input_state", NULL, NULL);
    CU_add_test(s, "bad input: clear errors naming the item", test_bad_input);
    CU_add_test(s, "non-finite load: error with body and time", test_nan_load_reported);
    CU_add_test(s, "state save/restore: bit-identical continuation (Verlet)", test_restart_verlet);
    CU_add_test(s, "state save/restore: bit-identical continuation (CVODE)", test_restart_cvode);
}
