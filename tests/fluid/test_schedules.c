/* test_schedules.c — the step's schedules (fluid/step.c) give the same
 * values to the bit: the spheres' stages beside the update of the far planes
 * against the stages in sequence, in both layouts and precisions and with
 * the boundary scheme that keeps pairs on its links; the fill alone beside
 * where a sphere's reach comes near a face (a wall, a periodic face); the
 * sequence where it wraps across a periodic z face; auto times both and
 * keeps to its cycle. */
#include "fluid_tests.h"
#include "test_util.h"

#include "../../fluid/fluid_internal.h"

#include <CUnit/CUnit.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* long in z, so that planes lie beyond the spheres' reach on both sides */
enum { NX = 32, NY = 30, NZ = 44, NCELLS = NX * NY * NZ, STEPS = 25 };

/* Periodic x, free-slip y, a no-slip and a moving wall in z (walls_fill has
 * work on every axis); a prescribed dimer along z that moves and turns,
 * crossing cells, centred at (xc, 15.x, zc); at xc = 16, zc = 22 its reach
 * (box, SOV_REACH and the faces' margin) leaves 8 planes below it and 9
 * above, and keeps off every face. */
static scene_t dimer_scene(double xc, double zc, streaming_t streaming, precision_t precision,
                           boundary_scheme_t scheme)
{
    static scene_sphere_t sph[2];
    static scene_body_t body;
    scene_t s = test_box(NX, NY, NZ, 0.7, COLLISION_TRT);
    face_t *f = s.domain.faces;
    f[2].type = f[3].type = FACE_FREE_SLIP;
    f[4].type = FACE_NO_SLIP;
    f[5].type = FACE_MOVING_WALL;
    f[5].velocity[0] = 0.02;
    memset(sph, 0, sizeof sph);
    memset(&body, 0, sizeof body);
    const double c[2][3] = {{xc, 15.0, zc - 3.1}, {xc + 0.4, 15.5, zc + 3.1}};
    for (int k = 0; k < 2; k++) {
        sph[k].radius = 2.6;
        memcpy(sph[k].center, c[k], sizeof c[k]);
    }
    body.nspheres = 2;
    body.spheres = sph;
    body.density = 2.0;
    body.motion = MOTION_PRESCRIBED;
    body.velocity[0] = 0.05;
    body.velocity[2] = -0.03;
    body.angular_velocity[1] = 0.012;
    s.nbodies = 1;
    s.bodies = &body;
    s.fluid.boundary_scheme = scheme;
    s.fluid.refill = REFILL_EXTRAPOLATION;
    s.fluid.streaming = streaming;
    s.fluid.precision = precision;
    return s;
}

typedef struct {
    double m[4 * NCELLS]; /* density and velocity */
    unsigned char flags[NCELLS];
    double load[2][6];
    long covered, beside;
} outcome_t;

static void run(const scene_t *s, int mode, long steps, outcome_t *o)
{
    fluid_t *fl = test_fluid(s);
    fl->sov.mode = mode;
    test_run(fl, steps);
    fluid_moments_lattice(fl, o->m, o->m + NCELLS);
    fluid_flags(fl, o->flags);
    for (int k = 0; k < 2; k++) {
        fluid_sphere_load_lattice(fl, k, o->load[k], o->load[k] + 3);
    }
    o->covered = fl->spheres.covered_total + fl->spheres.uncovered_total;
    o->beside = fl->sov.steps_beside;
    fluid_free(fl);
}

static int same(const outcome_t *a, const outcome_t *b)
{
    return memcmp(a->m, b->m, sizeof a->m) == 0 && memcmp(a->flags, b->flags, sizeof a->flags) == 0 &&
           memcmp(a->load, b->load, sizeof a->load) == 0 && a->covered == b->covered;
}

static void test_beside_equals_sequence(void)
{
    static const struct {
        streaming_t streaming;
        precision_t precision;
        boundary_scheme_t scheme;
    } cases[] = {{STREAMING_IN_PLACE, PRECISION_DOUBLE, BOUNDARY_CLI},
                 {STREAMING_TWO_ARRAY, PRECISION_DOUBLE, BOUNDARY_CLI},
                 {STREAMING_IN_PLACE, PRECISION_SINGLE, BOUNDARY_YU},
                 {STREAMING_IN_PLACE, PRECISION_DOUBLE, BOUNDARY_MULTIREFLECTION}};
    outcome_t *o = malloc(2 * sizeof *o);
    CU_ASSERT_FATAL(o != NULL);
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        const scene_t s = dimer_scene(16.0, 22.0, cases[c].streaming, cases[c].precision, cases[c].scheme);
        run(&s, SOV_OFF, STEPS, &o[0]);
        run(&s, SOV_ON, STEPS, &o[1]);
        CU_ASSERT(o[0].beside == 0);
        CU_ASSERT(o[1].beside == STEPS); /* every step beside: the test compares two schedules */
        CU_ASSERT(o[0].covered > 10);    /* the spheres crossed cells */
        CU_ASSERT(o[0].load[0][0] != 0.0 && o[0].load[1][0] != 0.0);
        CU_ASSERT(same(&o[0], &o[1]));
        if (!same(&o[0], &o[1])) {
            printf("\n    case %zu: the schedules differ", c);
        }
    }
    free(o);
}

/* Near a face the map keeps its order with the walls' fill and only the
 * fill runs beside: 4 cells from the no-slip face, and across the periodic
 * x face (centred at x = 1.5: its links reach the other end through the
 * ghost layer the fill writes). Across a periodic z face the reach would
 * wrap to far planes at the other end: the sequence then, even when asked. */
static void test_near_faces(void)
{
    outcome_t *o = malloc(2 * sizeof *o);
    CU_ASSERT_FATAL(o != NULL);
    static const double at[2][2] = {{16.0, 7.5}, {1.5, 22.0}};
    for (int c = 0; c < 2; c++) {
        const scene_t s = dimer_scene(at[c][0], at[c][1], STREAMING_IN_PLACE, PRECISION_DOUBLE, BOUNDARY_MULTIREFLECTION);
        run(&s, SOV_OFF, 15, &o[0]);
        run(&s, SOV_ON, 15, &o[1]);
        CU_ASSERT(o[1].beside == 15);
        CU_ASSERT(o[0].covered > 0);
        CU_ASSERT(same(&o[0], &o[1]));
        if (!same(&o[0], &o[1])) {
            printf("\n    near a face, case %d: the schedules differ", c);
        }
    }
    scene_t s = dimer_scene(16.0, 4.0, STREAMING_IN_PLACE, PRECISION_DOUBLE, BOUNDARY_CLI);
    s.domain.faces[4].type = s.domain.faces[5].type = FACE_PERIODIC;
    run(&s, SOV_OFF, 9, &o[0]);
    run(&s, SOV_ON, 9, &o[1]);
    CU_ASSERT(o[1].beside == 0);
    CU_ASSERT(same(&o[0], &o[1]));
    free(o);
}

/* auto: 8 steps of each alternately (the lists were built when the fluid
 * was created, so every step is timed), then the faster of the two for the
 * rest: beside in 8 or in 8 + the rest of the steps, and the same values as
 * the sequence. */
static void test_auto_probes_both(void)
{
    outcome_t *o = malloc(2 * sizeof *o);
    CU_ASSERT_FATAL(o != NULL);
    const long steps = 31, rest = steps - 16;
    const scene_t s = dimer_scene(16.0, 22.0, STREAMING_IN_PLACE, PRECISION_DOUBLE, BOUNDARY_CLI);
    run(&s, SOV_OFF, steps, &o[0]);
    run(&s, SOV_AUTO, steps, &o[1]);
    CU_ASSERT(o[1].beside == 8 || o[1].beside == 8 + rest);
    printf("\n    auto: beside in %ld of %ld steps", o[1].beside, steps);
    CU_ASSERT(same(&o[0], &o[1]));
    free(o);
}

void schedules_register_tests(void)
{
    CU_pSuite s = CU_add_suite("schedules", NULL, NULL);
    CU_add_test(s, "spheres beside the far planes' update: the sequence's values to the bit (layouts, precisions, "
                   "schemes)",
                test_beside_equals_sequence);
    CU_add_test(s, "near a wall or across a periodic x face: the fill beside, the same bits; across periodic z: "
                   "the sequence",
                test_near_faces);
    CU_add_test(s, "auto: both schedules timed alternately, then the faster", test_auto_probes_both);
}
