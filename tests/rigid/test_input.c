/* test_input.c — bad input is refused with a message naming the body,
 * sphere or connection; numerical trouble is reported; the state round-trips
 * bit-identically; two instances coexist (FMI requires it). */
#include "test_rigid_util.h"

#include "../common/corrupt_state.h"
#include "../../rigid/rigid_internal.h"

#include <stddef.h>
#include <stdio.h>
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

static status_t restore_rigid(void *r, const void *buf, size_t n) { return rigid_state_restore(r, buf, n); }

/* buf with len bytes at off replaced by v: refused with expect in the message. */
static void rigid_refused(rigid_t *r, const test_log_t *tl, const unsigned char *buf, size_t n, size_t off,
                          const void *v, size_t len, const char *expect)
{
    expect_corrupt_refused(restore_rigid, r, tl->last, buf, n, off, v, len, expect);
}

/* Every part of a rigid state the restore checks, corrupted one at a time,
 * is refused with a message naming it, and the instance refusing it is left
 * as it was; the state itself restores. */
static void test_state_corruption_refused(void)
{
    double rr = 1e-3;
    rigid_sphere_cfg_t s[3] = {{{0, 0, 0.01}, rr, 0}, {{2 * rr, 0, 0.01}, rr, 0}, {{0, 0, 0.005}, rr, 1}};
    rigid_body_cfg_t b[2] = {{2500.0, {0, 0, -0.1}, {1, 2, 3}, 0}, {2500.0, {0, 0, 0.1}, {0, 0, 0}, 0}};
    rigid_connection_cfg_t c = {0, 1, 1e-2, 0, 0};
    rigid_config_t cfg = test_cfg(3, s, 2, b, 1, &c);
    cfg.gravity[2] = -9.81;
    test_log_t tl = {"", 0};
    log_t lg = {test_log_fn, &tl};
    rigid_t *a = NULL, *r = NULL;
    CU_ASSERT_EQUAL_FATAL(rigid_create(&cfg, NULL, &a), STATUS_OK);
    CU_ASSERT_EQUAL_FATAL(rigid_create(&cfg, &lg, &r), STATUS_OK);
    const double f[3] = {1e-5, 0, 0}, t[3] = {0, 1e-9, 0};
    for (int k = 0; k < 10; k++) {
        rigid_set_sphere_load(a, k % 3, f, t);
        CU_ASSERT_EQUAL_FATAL(rigid_step(a, 1e-4), STATUS_OK);
    }
    const size_t n = rigid_state_size(a), n0 = rigid_state_size(r);
    unsigned char *buf = malloc(n), *fresh = malloc(n0), *after = malloc(n0);
    CU_ASSERT_FATAL(buf != NULL && fresh != NULL && after != NULL);
    CU_ASSERT_EQUAL_FATAL(rigid_state_save(a, buf, n), STATUS_OK);
    CU_ASSERT_EQUAL_FATAL(rigid_state_save(r, fresh, n0), STATUS_OK);
    const size_t hs = sizeof(rigid_state_header_t), sph = hs, bod = sph + 3 * sizeof(rigid_sphere_t);
    const size_t con = bod + 2 * sizeof(rigid_body_t), touch = con + sizeof(rigid_conn_t);
    CU_ASSERT_FATAL(touch + 9 == n);
    /* the header */
    const int32_t zero = 0, many = 1000, four = 4;
    const double nan = NAN, inf = INFINITY, neg = -1.0, twice = 2e-3;
    rigid_refused(r, &tl, buf, n, offsetof(rigid_state_header_t, nbodies), &zero, 4, "does not fit");
    rigid_refused(r, &tl, buf, n, offsetof(rigid_state_header_t, nconn), &many, 4, "truncated");
    rigid_refused(r, &tl, buf, n, offsetof(rigid_state_header_t, t), &nan, 8, "time nan");
    rigid_refused(r, &tl, buf, n, offsetof(rigid_state_header_t, h_prev), &neg, 8, "previous step -1");
    rigid_refused(r, &tl, buf, n, offsetof(rigid_state_header_t, have_prev), &four, 4, "have_prev 4");
    /* the spheres: what the scene fixes, their body, finite values */
    const int body7 = 7, scene_body = 1;
    rigid_refused(r, &tl, buf, n, sph + offsetof(rigid_sphere_t, radius), &twice, 8, "sphere 0: radius 0.002");
    rigid_refused(r, &tl, buf, n, sph + offsetof(rigid_sphere_t, orig_body), &scene_body, 4, "scene body 1");
    rigid_refused(r, &tl, buf, n, sph + sizeof(rigid_sphere_t) + offsetof(rigid_sphere_t, mass), &twice, 8,
                  "sphere 1: radius");
    rigid_refused(r, &tl, buf, n, sph + sizeof(rigid_sphere_t) + offsetof(rigid_sphere_t, body), &body7, 4,
                  "belongs to body 7");
    rigid_refused(r, &tl, buf, n, sph + 2 * sizeof(rigid_sphere_t) + offsetof(rigid_sphere_t, p), &nan, 8,
                  "sphere 2: centre in its body's frame not finite");
    rigid_refused(r, &tl, buf, n, sph + 2 * sizeof(rigid_sphere_t) + offsetof(rigid_sphere_t, held_t) + 8, &inf, 8,
                  "sphere 2: loads not finite");
    /* the bodies */
    const int fixed5 = 5;
    rigid_refused(r, &tl, buf, n, bod + offsetof(rigid_body_t, com) + 8, &inf, 8, "body 0: centre of mass not finite");
    rigid_refused(r, &tl, buf, n, bod + offsetof(rigid_body_t, q), &twice, 8, "quaternion has norm");
    rigid_refused(r, &tl, buf, n, bod + offsetof(rigid_body_t, mass), &twice, 8, "shares add up");
    rigid_refused(r, &tl, buf, n, bod + sizeof(rigid_body_t) + offsetof(rigid_body_t, inertia) + 16, &neg, 8,
                  "body 1: principal moment of inertia 2");
    rigid_refused(r, &tl, buf, n, bod + offsetof(rigid_body_t, fixed), &fixed5, 4, "fixed = 5");
    /* the connection */
    const int sphere99 = 99, sphere0 = 0, intact3 = 3;
    rigid_refused(r, &tl, buf, n, con + offsetof(rigid_conn_t, a), &sphere99, 4, "joins spheres 99 and 1");
    rigid_refused(r, &tl, buf, n, con + offsetof(rigid_conn_t, b), &sphere0, 4, "joins spheres 0 and 0");
    rigid_refused(r, &tl, buf, n, con + offsetof(rigid_conn_t, max_normal), &neg, 8, "limits -1 N");
    rigid_refused(r, &tl, buf, n, con + offsetof(rigid_conn_t, max_shear), &nan, 8, "limits");
    rigid_refused(r, &tl, buf, n, con + offsetof(rigid_conn_t, intact), &intact3, 4, "intact 3");
    rigid_refused(r, &tl, buf, n, con + offsetof(rigid_conn_t, force), &nan, 8, "connection 0: its force");
    /* the touch flags, and bytes beyond the contents */
    const unsigned char flag7 = 7;
    rigid_refused(r, &tl, buf, n, touch + 5, &flag7, 1, "touch flag of spheres 1 and 2 is 7");
    unsigned char *longer = calloc(1, n + 1);
    CU_ASSERT_FATAL(longer != NULL);
    memcpy(longer, buf, n);
    CU_ASSERT_EQUAL(rigid_state_restore(r, longer, n + 1), STATUS_ERROR);
    CU_ASSERT_PTR_NOT_NULL(strstr(tl.last, "bytes for the"));
    free(longer);
    /* none of them changed the instance; the state itself restores */
    CU_ASSERT_EQUAL(rigid_state_save(r, after, n0), STATUS_OK);
    CU_ASSERT(memcmp(fresh, after, n0) == 0);
    CU_ASSERT_EQUAL(rigid_state_restore(r, buf, n), STATUS_OK);
    free(buf);
    free(fresh);
    free(after);
    rigid_free(a);
    rigid_free(r);
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
    CU_add_test(s, "state restore: each corrupted part refused, the instance unchanged", test_state_corruption_refused);
}
