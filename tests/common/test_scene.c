/* test_scene.c — tests of the scene reader (common/scene.c) on valid input:
 * every key, default, derived value and override as models/README.md gives
 * them; bad input is in test_scene_refused.c and test_scene_bad.c. Each
 * scene is loaded through scene_harness.h (a fresh directory, a captured
 * log, nothing written). */
#include "scene_harness.h"
#include "scene_tests.h"

#include <CUnit/CUnit.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The base scene: loads with STATUS_OK. Line numbers are used in
 * test_scene_refused.c and test_scene_bad.c. */
const char scene_test_base[] =
    "domain:\n"                                                           /* 1 */
    "  size: [1.0e-3, 1.0e-3, 2.0e-3]\n"                                  /* 2 */
    "  faces:\n"                                                          /* 3 */
    "    z_min: {type: no_slip}\n"                                        /* 4 */
    "    z_max: {type: moving_wall, velocity: [1.0e-3, 0, 0]}\n"          /* 5 */
    "fluid:\n"                                                            /* 6 */
    "  density: 1000.0\n"                                                 /* 7 */
    "  viscosity: 1.0e-6\n"                                               /* 8 */
    "  dx: 2.5e-5\n"                                                      /* 9 */
    "  tau: 0.8\n"                                                        /* 10 */
    "bodies:\n"                                                           /* 11 */
    "  - name: p1\n"                                                      /* 12 */
    "    density: 2000.0\n"                                               /* 13 */
    "    spheres:\n"                                                      /* 14 */
    "      - {center: [5.0e-4, 5.0e-4, 5.0e-4], radius: 1.0e-4}\n"        /* 15 */
    "      - {center: [6.5e-4, 5.0e-4, 5.0e-4], radius: 1.0e-4}\n"        /* 16 */
    "  - name: p2\n"                                                      /* 17 */
    "    density: 2500.0\n"                                               /* 18 */
    "    motion: fixed\n"                                                 /* 19 */
    "    spheres:\n"                                                      /* 20 */
    "      - {center: [2.0e-4, 2.0e-4, 1.5e-3], radius: 1.0e-4}\n"        /* 21 */
    "connections:\n"                                                      /* 22 */
    "  - {spheres: [0, 1], max_normal: 1.0e-6}\n"                         /* 23 */
    "contacts: {model: spring_dashpot, contact_time: 1.0e-3}\n"           /* 24 */
    "rigid: {integrator: cvode, gravity: [0, 0, -9.81]}\n"                /* 25 */
    "run: {end_time: 0.1}\n";                                             /* 26 */

static void test_base_scene(void)
{
    capture_t cap;
    scene_t *s = NULL;
    status_t st = scene_test_load(BASE, NULL, 0, &cap, &s);
    CU_ASSERT_EQUAL(st, STATUS_OK);
    CU_ASSERT_EQUAL(cap.len, 0);
    CU_ASSERT_PTR_NOT_NULL_FATAL(s);
    CU_ASSERT_PTR_NOT_NULL(strstr(s->path, "scene.yaml"));
    CU_ASSERT_PTR_NOT_NULL(strstr(s->text, "moving_wall"));
    CU_ASSERT_DOUBLE_EQUAL(s->domain.size[2], 2.0e-3, 0);
    CU_ASSERT_EQUAL(s->domain.faces[0].type, FACE_PERIODIC);
    CU_ASSERT_EQUAL(s->domain.faces[4].type, FACE_NO_SLIP);
    CU_ASSERT_EQUAL(s->domain.faces[5].type, FACE_MOVING_WALL);
    CU_ASSERT_DOUBLE_EQUAL(s->domain.faces[5].velocity[0], 1.0e-3, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->fluid.dx, 2.5e-5, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->fluid.cells_per_radius, 0, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->fluid.tau, 0.8, 0);
    /* dt = (tau - 1/2) dx^2 / (3 nu) = 0.3 * 6.25e-10 / 3e-6 = 6.25e-5 s */
    CU_ASSERT_DOUBLE_EQUAL(s->fluid.dt, 6.25e-5, 1e-18);
    CU_ASSERT_EQUAL(s->nbodies, 2);
    CU_ASSERT_EQUAL(scene_total_spheres(s), 3);
    CU_ASSERT_STRING_EQUAL(s->bodies[0].name, "p1");
    CU_ASSERT_EQUAL(s->bodies[0].nspheres, 2);
    CU_ASSERT_DOUBLE_EQUAL(s->bodies[0].spheres[1].center[0], 6.5e-4, 0);
    CU_ASSERT_EQUAL(s->bodies[0].motion, MOTION_FREE);
    CU_ASSERT_EQUAL(s->bodies[1].motion, MOTION_FIXED);
    CU_ASSERT_DOUBLE_EQUAL(s->bodies[1].density, 2500.0, 0);
    CU_ASSERT_EQUAL(s->nconnections, 1);
    CU_ASSERT_EQUAL(s->connections[0].a, 0);
    CU_ASSERT_EQUAL(s->connections[0].b, 1);
    CU_ASSERT_DOUBLE_EQUAL(s->connections[0].max_normal, 1.0e-6, 0);
    CU_ASSERT(isinf(s->connections[0].max_shear) && s->connections[0].max_shear > 0);
    CU_ASSERT(isinf(s->connections[0].max_torque));
    CU_ASSERT_EQUAL(s->contacts.model, CONTACT_SPRING_DASHPOT);
    CU_ASSERT_EQUAL(s->rigid.integrator, INTEGRATOR_CVODE);
    CU_ASSERT_DOUBLE_EQUAL(s->rigid.gravity[2], -9.81, 0);
    CU_ASSERT_STRING_EQUAL(face_type_name(FACE_PRESSURE_OUTLET), "pressure_outlet");
    scene_free(s);
}

/* Every default of models/README.md. */
static void test_defaults(void)
{
    capture_t cap;
    scene_t *s = NULL;
    CU_ASSERT_EQUAL(scene_test_load(MINIMAL, NULL, 0, &cap, &s), STATUS_OK);
    CU_ASSERT_PTR_NOT_NULL_FATAL(s);
    for (int f = 0; f < 6; f++) {
        CU_ASSERT_EQUAL(s->domain.faces[f].type, FACE_PERIODIC);
        CU_ASSERT_EQUAL(s->domain.faces[f].profile, PROFILE_UNIFORM);
        CU_ASSERT_DOUBLE_EQUAL(s->domain.faces[f].pressure, 0, 0);
    }
    CU_ASSERT_EQUAL(s->fluid.collision, COLLISION_TRT);
    CU_ASSERT_DOUBLE_EQUAL(s->fluid.magic, 0.25, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->fluid.mach_limit, 0.3, 0);
    CU_ASSERT_EQUAL(s->fluid.boundary_scheme, BOUNDARY_MULTIREFLECTION);
    CU_ASSERT_EQUAL(s->fluid.refill, REFILL_EXTRAPOLATION);
    CU_ASSERT_EQUAL(s->fluid.force_method, FORCE_GALILEAN);
    CU_ASSERT_EQUAL(s->fluid.force_averaging, -1); /* not given: per body (common/coupling.h) */
    CU_ASSERT_EQUAL(s->rigid.coupling, COUPLING_AUTO);
    for (int a = 0; a < 3; a++) {
        CU_ASSERT_DOUBLE_EQUAL(s->fluid.body_force[a], 0, 0);
        CU_ASSERT_DOUBLE_EQUAL(s->fluid.initial_velocity[a], 0, 0);
        CU_ASSERT_DOUBLE_EQUAL(s->rigid.gravity[a], 0, 0);
    }
    CU_ASSERT_EQUAL(s->nbodies, 0);
    CU_ASSERT_PTR_NULL(s->bodies);
    CU_ASSERT_EQUAL(s->nconnections, 0);
    CU_ASSERT_PTR_NULL(s->connections);
    CU_ASSERT_EQUAL(s->contacts.model, CONTACT_SPRING_DASHPOT);
    CU_ASSERT_DOUBLE_EQUAL(s->contacts.restitution, 0.9, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->contacts.contact_time, 10 * s->fluid.dt, 0); /* ten fluid steps */
    CU_ASSERT_EQUAL(s->contacts.lubrication.enabled, 1);
    CU_ASSERT_DOUBLE_EQUAL(s->contacts.lubrication.cutoff, 2.0, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->contacts.lubrication.min_gap, 0, 0); /* no spheres */
    CU_ASSERT_DOUBLE_EQUAL(s->contacts.friction, 0, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->contacts.young_modulus, 1e9, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->contacts.poisson_ratio, 0.3, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->contacts.stick_speed, 0, 0);
    CU_ASSERT_EQUAL(s->rigid.integrator, INTEGRATOR_VERLET);
    CU_ASSERT_EQUAL(s->rigid.cvode_method, CVODE_BDF);
    CU_ASSERT_EQUAL(s->rigid.linear_solver, LINSOL_DENSE);
    CU_ASSERT_DOUBLE_EQUAL(s->rigid.rtol, 1e-8, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->rigid.atol, 1e-12, 0);
    CU_ASSERT_EQUAL(s->rigid.substeps, 1);
    CU_ASSERT_DOUBLE_EQUAL(s->run.end_time, 2.0, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->run.output_interval, 0.02, 0);
    CU_ASSERT_EQUAL(s->run.fields, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->run.field_interval, 0.02, 0);
    scene_free(s);

    /* Body defaults. */
    const char *const ov[] = {"bodies=[{density: 1500, spheres: [{center: [5e-4, 5e-4, 5e-4], radius: 2e-4}]}]"};
    CU_ASSERT_EQUAL(scene_test_load(MINIMAL, ov, 1, &cap, &s), STATUS_OK);
    CU_ASSERT_PTR_NOT_NULL_FATAL(s);
    CU_ASSERT_PTR_NULL(s->bodies[0].name);
    CU_ASSERT_EQUAL(s->bodies[0].motion, MOTION_FREE);
    CU_ASSERT_DOUBLE_EQUAL(s->contacts.lubrication.min_gap, 2e-7, 1e-20); /* 1e-3 of the smallest radius */
    for (int a = 0; a < 3; a++) {
        CU_ASSERT_DOUBLE_EQUAL(s->bodies[0].velocity[a], 0, 0);
        CU_ASSERT_DOUBLE_EQUAL(s->bodies[0].angular_velocity[a], 0, 0);
    }
    scene_free(s);
}

/* dx from cells_per_radius (dx = smallest radius / value), tau from dt. */
static void test_derived(void)
{
    capture_t cap;
    scene_t *s = NULL;
    const char *const ov[] = {
        "fluid={density: 1000.0, viscosity: 1.0e-6, cells_per_radius: 4, dt: 5.0e-5}",
        "bodies.1.spheres.0.radius=5.0e-5",
        "domain.size=[1.0e-3, 1.0e-3, 2.0e-3]",
    };
    CU_ASSERT_EQUAL(scene_test_load(BASE, ov, 3, &cap, &s), STATUS_OK);
    CU_ASSERT_PTR_NOT_NULL_FATAL(s);
    CU_ASSERT_DOUBLE_EQUAL(s->fluid.cells_per_radius, 4, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->fluid.dx, 1.25e-5, 1e-20);
    /* tau = 1/2 + 3 nu dt / dx^2 = 0.5 + 1.5e-10 / 1.5625e-10 = 1.46 */
    CU_ASSERT_DOUBLE_EQUAL(s->fluid.tau, 1.46, 1e-12);
    CU_ASSERT_DOUBLE_EQUAL(s->fluid.dt, 5.0e-5, 0);
    scene_free(s);
}

/* The step is a whole number of nanoseconds (common/scene.h, README "FMUs"):
 * libcosim counts time in integer ns, so 1.6666...e-5 s would become 16667 ns,
 * a step the fluid refuses. dt = (tau - 1/2) dx^2 / (3 nu) is rounded and tau
 * set back from it, nu and dx exact; a dt below ~50 ns is kept exact; a
 * given dt is used as given. */
static void test_whole_ns_step(void)
{
    capture_t cap;
    scene_t *s = NULL;
    CU_ASSERT_EQUAL_FATAL(scene_test_load(BASE, NULL, 0, &cap, &s), STATUS_OK);
    CU_ASSERT_DOUBLE_EQUAL(s->fluid.dt, 6.25e-5, 0); /* whole already (62500 ns): tau untouched */
    CU_ASSERT_DOUBLE_EQUAL(s->fluid.tau, 0.8, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->fluid.tau_requested, 0.8, 0);
    scene_free(s);
    s = NULL;
    const char *const ov1[] = {"fluid.dx=2.0e-5", "fluid.tau=1.0"};
    CU_ASSERT_EQUAL_FATAL(scene_test_load(BASE, ov1, 2, &cap, &s), STATUS_OK);
    /* exact dt = 0.5 * 4e-10 / 3e-6 = 66666.67 ns -> 66667 ns */
    long long ns = 0;
    CU_ASSERT_TRUE(scene_whole_ns(s->fluid.dt, &ns));
    CU_ASSERT_EQUAL(ns, 66667);
    CU_ASSERT_DOUBLE_EQUAL(s->fluid.dt, 66667e-9, 1e-20);
    CU_ASSERT_DOUBLE_EQUAL(s->fluid.tau_requested, 1.0, 0);
    /* tau = 1/2 + 3 nu dt / dx^2 = 0.5 + 3e-6 * 66667e-9 / 4e-10 = 1.0000025 */
    CU_ASSERT_DOUBLE_EQUAL(s->fluid.tau, 1.0000025, 1e-12);
    CU_ASSERT_TRUE(s->fluid.tau != 1.0);
    scene_free(s);
    s = NULL;
    /* dx 2e-7 at tau 0.55: 0.667 ns; rounding would move tau - 1/2 by 50%: dt stays exact (check warns) */
    const char *const ov2[] = {"fluid.dx=2.0e-7", "fluid.tau=0.55"};
    CU_ASSERT_EQUAL_FATAL(scene_test_load(MINIMAL, ov2, 2, &cap, &s), STATUS_OK);
    CU_ASSERT_DOUBLE_EQUAL(s->fluid.tau, 0.55, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->fluid.dt, 0.05 * 4e-14 / 3e-6, 1e-24);
    CU_ASSERT_FALSE(scene_whole_ns(s->fluid.dt, NULL));
    scene_free(s);
    s = NULL;
    /* a given dt is never changed, whole or not */
    const char *const ov3[] = {"fluid={density: 1000.0, viscosity: 1.0e-6, dx: 2.5e-5, dt: 1.23456789e-5}"};
    CU_ASSERT_EQUAL_FATAL(scene_test_load(BASE, ov3, 1, &cap, &s), STATUS_OK);
    CU_ASSERT_DOUBLE_EQUAL(s->fluid.dt, 1.23456789e-5, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->fluid.tau_requested, 0.0, 0);
    CU_ASSERT_FALSE(scene_whole_ns(s->fluid.dt, NULL));
    CU_ASSERT_TRUE(scene_whole_ns(1e-5, NULL));
    CU_ASSERT_TRUE(scene_whole_ns(3 * 16667e-9, NULL));
    CU_ASSERT_FALSE(scene_whole_ns(1.0 / 60000.0, NULL));
    CU_ASSERT_FALSE(scene_whole_ns(0.4e-9, NULL));
    scene_free(s);
}

/* --set: dotted keys, list indices, lists as values, created keys. */
static void test_overrides(void)
{
    capture_t cap;
    scene_t *s = NULL;
    const char *const ov[] = {
        "fluid.tau=1.0",
        "rigid.integrator=verlet",
        "bodies.0.density=3000",
        "domain.size=[1e-3,1e-3,1e-3]",
        "domain.faces.x_min.type=no_slip",
        "domain.faces.x_max={type: pressure_outlet, pressure: 12.5}",
        "contacts.model=hertz",
        "run.fields=true",
        "bodies.1.spheres.0.center.2=5e-4",
        "connections.0.max_shear=2e-6",
        "fluid.tau=1.5", /* later overrides win */
    };
    CU_ASSERT_EQUAL(scene_test_load(BASE, ov, 11, &cap, &s), STATUS_OK);
    CU_ASSERT_PTR_NOT_NULL_FATAL(s);
    CU_ASSERT_DOUBLE_EQUAL(s->fluid.tau_requested, 1.5, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->fluid.tau, 1.5, 1e-5); /* dt 208333.3 ns rounded to whole ns */
    CU_ASSERT_EQUAL(s->rigid.integrator, INTEGRATOR_VERLET);
    CU_ASSERT_DOUBLE_EQUAL(s->bodies[0].density, 3000, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->domain.size[2], 1e-3, 0);
    CU_ASSERT_EQUAL(s->domain.faces[0].type, FACE_NO_SLIP);
    CU_ASSERT_EQUAL(s->domain.faces[1].type, FACE_PRESSURE_OUTLET);
    CU_ASSERT_DOUBLE_EQUAL(s->domain.faces[1].pressure, 12.5, 0);
    CU_ASSERT_EQUAL(s->contacts.model, CONTACT_HERTZ);
    CU_ASSERT_DOUBLE_EQUAL(s->contacts.contact_time, 1.0e-3, 0); /* untouched sibling key */
    CU_ASSERT_EQUAL(s->run.fields, 1);
    CU_ASSERT_DOUBLE_EQUAL(s->bodies[1].spheres[0].center[2], 5e-4, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->connections[0].max_shear, 2e-6, 0);
    /* scene->text is the scene as run, after the overrides */
    CU_ASSERT_PTR_NOT_NULL(strstr(s->text, "pressure_outlet"));
    CU_ASSERT_PTR_NOT_NULL(strstr(s->text, "tau: 1.5"));
    CU_ASSERT_PTR_NULL(strstr(s->text, "tau: 0.8"));
    scene_free(s);

    /* A group absent from the file is created by the override. */
    const char *const ov2[] = {"rigid.substeps=4", "domain.faces.z_min.type=free_slip",
                               "domain.faces.z_max.type=free_slip"};
    CU_ASSERT_EQUAL(scene_test_load(MINIMAL, ov2, 3, &cap, &s), STATUS_OK);
    CU_ASSERT_PTR_NOT_NULL_FATAL(s);
    CU_ASSERT_EQUAL(s->rigid.substeps, 4);
    CU_ASSERT_EQUAL(s->domain.faces[5].type, FACE_FREE_SLIP);
    scene_free(s);
}

/* The forms of a number that YAML 1.1 and 1.2 agree on and strtod reads
 * the same way load as those numbers (common/scene_check.c, "Numbers as
 * written"); inf and nan are read and left to the range checks. */
static void test_number_forms(void)
{
    capture_t cap;
    scene_t *s = NULL;
    const char *const ov[] = {
        "bodies.0.density=0x7D0",           /* hexadecimal: 2000 */
        "bodies.1.density=+2.5E+3",
        "fluid.density=1.0E+3",
        "fluid.viscosity=1e-6",
        "contacts.friction=-0",
        "contacts.restitution=.5",
        "contacts.poisson_ratio='0.25'",    /* quoted: the same text */
        "rigid.substeps=2.",
        "connections.0.max_shear=inf",
        "connections.0.max_torque=Infinity",
        "bodies.0.spheres.0.center=[5.0e-4, 05.0e-4, 0.0005]",
    };
    CU_ASSERT_EQUAL_FATAL(scene_test_load(BASE, ov, sizeof ov / sizeof ov[0], &cap, &s), STATUS_OK);
    CU_ASSERT_EQUAL(cap.nerrors, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->bodies[0].density, 2000, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->bodies[1].density, 2500, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->fluid.density, 1000, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->fluid.viscosity, 1e-6, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->contacts.friction, 0, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->contacts.restitution, 0.5, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->contacts.poisson_ratio, 0.25, 0);
    CU_ASSERT_EQUAL(s->rigid.substeps, 2);
    CU_ASSERT(isinf(s->connections[0].max_shear) && isinf(s->connections[0].max_torque));
    CU_ASSERT_DOUBLE_EQUAL(s->bodies[0].spheres[0].center[1], 5e-4, 0);
    scene_free(s);
}

static void test_warnings(void)
{
    capture_t cap;
    scene_t *s = NULL;
    /* A key that the face type does not use is ignored with a warning. */
    const char *const ov[] = {"domain.faces.z_min.pressure=3", "fluid.collision=bgk", "fluid.magic=0.25"};
    CU_ASSERT_EQUAL(scene_test_load(BASE, ov, 3, &cap, &s), STATUS_OK); /* usable: warnings are only logged */
    CU_ASSERT_PTR_NOT_NULL(s);
    CU_ASSERT_EQUAL(cap.nerrors, 0);
    CU_ASSERT_EQUAL(cap.nwarnings, 2);
    scene_test_contains(&cap, "domain.faces.z_min.pressure = 3: ignored for a no_slip face", __FILE__, __LINE__);
    scene_test_contains(&cap, "fluid.magic = 0.25: ignored", __FILE__, __LINE__);
    scene_free(s);

    /* A free body faster than half a cell per step: refused (the fluid would
     * refuse its first step), with the remedies; at the limit it loads. */
    const char *const ov2[] = {"bodies.0.velocity=[1, 0, 0]"};
    CU_ASSERT_EQUAL(scene_test_load(BASE, ov2, 1, &cap, &s), STATUS_ERROR);
    CU_ASSERT_EQUAL(cap.nerrors, 1);
    CU_ASSERT_PTR_NULL(s);
    scene_test_contains(&cap, "bodies.0.velocity = [1, 0, 0]", __FILE__, __LINE__);
    scene_test_contains(&cap, "allowed: at most 0.5 cells per step = 0.2 m/s", __FILE__, __LINE__);
    scene_test_contains(&cap, "fluid.tau closer to 0.5", __FILE__, __LINE__);
    const char *const ov3[] = {"bodies.0.velocity=[0.19, 0, 0]"};
    CU_ASSERT_EQUAL(scene_test_load(BASE, ov3, 1, &cap, &s), STATUS_OK);
    CU_ASSERT_EQUAL(cap.nerrors, 0);
    scene_free(s);
}

/* A body given across a periodic face is made one piece: each centre moves
 * to the image nearest a sphere it touches, from the first sphere on; a
 * chain longer than half the period (here 0.6 mm of 1 mm) too, where the
 * image nearest the first sphere would tear it. */
static void test_body_across_periodic_face(void)
{
    const char *const ov[] = {"bodies.0.spheres=[{center: [7.5e-4, 5e-4, 5e-4], radius: 1e-4}, "
                              "{center: [9.0e-4, 5e-4, 5e-4], radius: 1e-4}, {center: [0.5e-4, 5e-4, 5e-4], radius: 1e-4}, "
                              "{center: [2.0e-4, 5e-4, 5e-4], radius: 1e-4}, {center: [3.5e-4, 5e-4, 5e-4], radius: 1e-4}]",
                              "bodies.1.spheres.0.center=[5e-4, 8e-4, 1.5e-3]"};
    capture_t cap;
    scene_t *s = NULL;
    CU_ASSERT_EQUAL_FATAL(scene_test_load(BASE, ov, 2, &cap, &s), STATUS_OK);
    const double want[5] = {7.5e-4, 9.0e-4, 1.05e-3, 1.2e-3, 1.35e-3};
    for (int k = 0; k < 5; k++) {
        CU_ASSERT_DOUBLE_EQUAL(s->bodies[0].spheres[k].center[0], want[k], 1e-15);
        CU_ASSERT_EQUAL(s->bodies[0].spheres[k].center[1], 5e-4);
    }
    CU_ASSERT_EQUAL(s->bodies[1].spheres[0].center[0], 5e-4); /* a body inside the box: as given */
    scene_free(s);
}

/* Two loads of the same file give the same struct: no hidden state. */
static void test_repeatable(void)
{
    capture_t cap;
    scene_t *a = NULL, *b = NULL;
    CU_ASSERT_EQUAL(scene_test_load(BASE, NULL, 0, &cap, &a), STATUS_OK);
    CU_ASSERT_EQUAL(scene_test_load(BASE, NULL, 0, &cap, &b), STATUS_OK);
    CU_ASSERT_PTR_NOT_NULL_FATAL(a);
    CU_ASSERT_PTR_NOT_NULL_FATAL(b);
    CU_ASSERT_STRING_EQUAL(a->text, b->text);
    CU_ASSERT_DOUBLE_EQUAL(a->fluid.dt, b->fluid.dt, 0);
    CU_ASSERT_EQUAL(memcmp(&a->domain, &b->domain, sizeof a->domain), 0);
    scene_free(a);
    scene_free(b);
    scene_free(NULL);
}

/* contacts.lubrication (models/README.md): the mapping and its defaults, off
 * with contacts.model: none unless enabled, and the ranges of cutoff (cells)
 * and min_gap (m, below cutoff x fluid.dx). */
static void test_lubrication_keys(void)
{
    capture_t cap;
    scene_t *s = NULL;
    const char *const on[] = {"contacts.lubrication={cutoff: 1.5, min_gap: 1.0e-6}"};
    CU_ASSERT_EQUAL(scene_test_load(BASE, on, 1, &cap, &s), STATUS_OK);
    CU_ASSERT_PTR_NOT_NULL_FATAL(s);
    CU_ASSERT_EQUAL(s->contacts.lubrication.enabled, 1);
    CU_ASSERT_DOUBLE_EQUAL(s->contacts.lubrication.cutoff, 1.5, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->contacts.lubrication.min_gap, 1.0e-6, 0);
    scene_free(s);
    const char *const none[] = {"contacts.model=none"};
    CU_ASSERT_EQUAL(scene_test_load(BASE, none, 1, &cap, &s), STATUS_OK);
    CU_ASSERT_PTR_NOT_NULL_FATAL(s);
    CU_ASSERT_EQUAL(s->contacts.lubrication.enabled, 0);
    CU_ASSERT_DOUBLE_EQUAL(s->contacts.lubrication.min_gap, 1.0e-7, 1e-20); /* 1e-3 of radius 1e-4 */
    scene_free(s);
    const char *const forced[] = {"contacts.model=none", "contacts.lubrication.enabled=true"};
    CU_ASSERT_EQUAL(scene_test_load(BASE, forced, 2, &cap, &s), STATUS_OK);
    CU_ASSERT_PTR_NOT_NULL_FATAL(s);
    CU_ASSERT_EQUAL(s->contacts.lubrication.enabled, 1);
    scene_free(s);
    EXPECT_SET_ERROR("contacts.lubrication.cutoff=0", "contacts.lubrication.cutoff = 0: out of range; allowed: (0, 10]");
    EXPECT_SET_ERROR("contacts.lubrication.cutoff=10.5", "contacts.lubrication.cutoff = 10.5: out of range");
    EXPECT_SET_ERROR("contacts.lubrication.min_gap=0", "contacts.lubrication.min_gap = 0: out of range; allowed: (0, inf)");
    /* dx = 2.5e-5 m: the default cut-off 2 cells is 5e-5 m */
    EXPECT_SET_ERROR("contacts.lubrication.min_gap=6e-5",
                     "contacts.lubrication.min_gap = 6e-05 m is not below the cut-off contacts.lubrication.cutoff x "
                     "fluid.dx = 2 x 2.5e-05 m = 5e-05 m");
    EXPECT_SET_ERROR("contacts.lubrication.width=1", "contacts.lubrication.width");
}

/* A periodic box takes no net force: free bodies settling in it with
 * nothing to balance their net weight accelerate the whole suspension
 * without bound (a sphere of density ratio 2 in a periodic 24^3 box, gravity
 * along x: 0.0035 m/s after 3000 steps and still rising, against 0.00049
 * m/s with the balancing body force; no warning before). A warning names the
 * axis and the fluid body force that balances it; a balanced box, a wall
 * (even a free-slip face across the gravity), or a held body: none. */
static void test_unbalanced_periodic_weight(void)
{
    static const char yaml[] = "domain:\n"
                               "  size: [2.4e-3, 2.4e-3, 2.4e-3]\n"
                               "fluid: {density: 1000.0, viscosity: 1.0e-6, dx: 1.0e-4, tau: 0.8}\n"
                               "bodies:\n"
                               "  - density: 2000.0\n"
                               "    spheres:\n"
                               "      - {center: [1.2e-3, 1.2e-3, 1.2e-3], radius: 4.0e-4}\n"
                               "rigid: {gravity: [-0.05, 0, 0]}\n"
                               "run: {end_time: 3.0}\n";
    capture_t cap;
    scene_t *s = NULL;
    CU_ASSERT_EQUAL(scene_test_load(yaml, NULL, 0, &cap, &s), STATUS_OK);
    CU_ASSERT_EQUAL(cap.nwarnings, 1);
    scene_test_contains(&cap, "scene.yaml:8: rigid.gravity = [-0.05, 0, 0]: the free bodies' net weight", __FILE__,
                        __LINE__);
    scene_test_contains(&cap, "along the periodic x axis", __FILE__, __LINE__);
    scene_test_contains(&cap, "set fluid.body_force = [0.98880", __FILE__, __LINE__);
    scene_free(s);
    const char *const quiet[][2] = {
        {"fluid.body_force=[0.988802766585, 0, 0]", NULL},
        {"domain.faces={x_min: {type: free_slip}, x_max: {type: free_slip}}", NULL},
        {"domain.faces={y_min: {type: no_slip}, y_max: {type: no_slip}}", NULL},
        {"bodies.0.density=1000", NULL},
        {"rigid.gravity=[0, 0, 0]", "bodies.0.motion=fixed"},
    };
    for (size_t k = 0; k < sizeof quiet / sizeof quiet[0]; k++) {
        const int n = quiet[k][1] != NULL ? 2 : 1;
        CU_ASSERT_EQUAL(scene_test_load(yaml, quiet[k], n, &cap, &s), STATUS_OK);
        CU_ASSERT_EQUAL(cap.nwarnings, 0);
        scene_free(s);
    }
    /* two sintered spheres (centres 0.75 radii apart): balanced by their union,
     * as the rigid component weighs them; counted twice, the overlap left
     * 2.3% of the weight unbalanced and warned */
    const char *const sintered[] = {"bodies.0.spheres=[{center: [0.9e-3, 1.2e-3, 1.2e-3], radius: 4.0e-4}, "
                                    "{center: [1.5e-3, 1.2e-3, 1.2e-3], radius: 4.0e-4}]",
                                    "fluid.body_force=[1.92747234678, 0, 0]"};
    CU_ASSERT_EQUAL(scene_test_load(yaml, sintered, 2, &cap, &s), STATUS_OK);
    CU_ASSERT_EQUAL(cap.nwarnings, 0);
    scene_free(s);
    /* a fixed body holds the fluid: a body force drives a flow through it */
    const char *const held[] = {"rigid.gravity=[0, 0, 0]", "bodies.0.motion=fixed", "fluid.body_force=[1, 0, 0]"};
    CU_ASSERT_EQUAL(scene_test_load(yaml, held, 3, &cap, &s), STATUS_OK);
    CU_ASSERT_EQUAL(cap.nwarnings, 0);
    scene_free(s);
    /* a free body does not: the body force alone accelerates the box */
    const char *const pushed[] = {"rigid.gravity=[0, 0, 0]", "fluid.body_force=[1, 0, 0]"};
    CU_ASSERT_EQUAL(scene_test_load(yaml, pushed, 2, &cap, &s), STATUS_OK);
    CU_ASSERT_EQUAL(cap.nwarnings, 1);
    scene_test_contains(&cap, "fluid.body_force = [1, 0, 0]", __FILE__, __LINE__);
    scene_free(s);
}

/* bodies.N.move_with_flow: the free body starts with the initial flow's
 * rigid motion at the r^3-weighted centroid of its centres. The base scene's
 * plane channel along z (no-slip floor, lid at U = 1e-3 m/s in x, H = 2e-3 m):
 * u_x = U z/H, w_y = (1/2) du_x/dz = U/(2H) = 0.25 rad/s at the centroid
 * (5.75e-4, 5e-4, 5e-4) m: u_x = 2.5e-4 m/s. With a body force g = 1 N/m^3
 * along x the Poiseuille part g/(2 rho nu) z (H - z) adds 3.75e-4 m/s and
 * g/(2 rho nu)(H - 2z)/2 = 0.25 rad/s. */
static void test_move_with_flow(void)
{
    const char *const ov[] = {"fluid.initial_profile=plane_channel", "bodies.0.move_with_flow=true"};
    capture_t cap;
    scene_t *s = NULL;
    CU_ASSERT_EQUAL_FATAL(scene_test_load(BASE, ov, 2, &cap, &s), STATUS_OK);
    const double *v = s->bodies[0].velocity, *w = s->bodies[0].angular_velocity;
    CU_ASSERT_DOUBLE_EQUAL(v[0], 2.5e-4, 1e-15);
    CU_ASSERT(v[1] == 0.0 && v[2] == 0.0);
    CU_ASSERT_DOUBLE_EQUAL(w[1], 0.25, 1e-9);
    CU_ASSERT(fabs(w[0]) < 1e-12 && fabs(w[2]) < 1e-12);
    scene_free(s);
    const char *const ovg[] = {"fluid.initial_profile=plane_channel", "bodies.0.move_with_flow=true",
                               "fluid.body_force=[1, 0, 0]"};
    CU_ASSERT_EQUAL_FATAL(scene_test_load(BASE, ovg, 3, &cap, &s), STATUS_OK);
    CU_ASSERT_DOUBLE_EQUAL(s->bodies[0].velocity[0], 6.25e-4, 1e-15);
    CU_ASSERT_DOUBLE_EQUAL(s->bodies[0].angular_velocity[1], 0.5, 1e-9);
    scene_free(s);
    /* given velocities are replaced, with a warning; a fixed body cannot */
    const char *const ovw[] = {"fluid.initial_profile=plane_channel", "bodies.0.move_with_flow=true",
                               "bodies.0.angular_velocity=[0, 7, 0]"};
    CU_ASSERT_EQUAL_FATAL(scene_test_load(BASE, ovw, 3, &cap, &s), STATUS_OK);
    CU_ASSERT_DOUBLE_EQUAL(s->bodies[0].angular_velocity[1], 0.25, 1e-9);
    scene_test_contains(&cap, "bodies.0.angular_velocity given too is replaced by the flow's", __FILE__, __LINE__);
    scene_free(s);
    const char *const ovf[] = {"bodies.1.move_with_flow=true"};
    EXPECT_ERROR(BASE, ovf, 1, "bodies.1.move_with_flow = true for a fixed body; allowed: for free bodies only");
}

void scene_register_tests(void)
{
    static const struct {
        const char *name;
        CU_TestFunc fn;
    } valid[] = {
        {"base scene", test_base_scene},
        {"defaults", test_defaults},
        {"derived dx and tau", test_derived},
        {"step in whole nanoseconds", test_whole_ns_step},
        {"overrides", test_overrides},
        {"warnings", test_warnings},
        {"numbers in their YAML forms", test_number_forms},
        {"repeatable", test_repeatable},
        {"contacts.lubrication", test_lubrication_keys},
        {"body across a periodic face", test_body_across_periodic_face},
        {"unbalanced weight in a periodic box warns", test_unbalanced_periodic_weight},
        {"move_with_flow: the initial flow's rigid motion", test_move_with_flow},
    };
    CU_pSuite s = CU_add_suite("scene: valid input", NULL, NULL);
    if (s == NULL) {
        return;
    }
    for (size_t i = 0; i < sizeof valid / sizeof valid[0]; i++) {
        if (CU_add_test(s, valid[i].name, valid[i].fn) == NULL) {
            return;
        }
    }
}
