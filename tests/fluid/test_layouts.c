/* test_layouts.c — the two streaming layouts (fluid/layout.h) give the same
 * flow to round-off: every wall type, a moving and turning sphere that
 * covers and uncovers cells, every boundary scheme; a state saved in either
 * in-place state (after the push and after the local kernel) continues
 * bit-identically; multireflection in place where the collision forgets
 * what it needs (omega_minus = 1) takes it from the pairs its links keep. */
#include "fluid_tests.h"
#include "sphere_harness.h"
#include "test_util.h"

#include "../../fluid/fluid_internal.h"

#include <CUnit/CUnit.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

enum { NX = 16, NY = 14, NZ = 12, NCELLS = NX * NY * NZ };

/* Box with the faces of `walls` (0: inlet/outlet along x, no-slip and moving
 * wall in y, periodic z; 1: periodic x, free-slip y, no-slip and moving wall
 * in z) and one prescribed sphere that moves and turns. */
static scene_t layout_scene(int walls, boundary_scheme_t scheme, streaming_t streaming)
{
    scene_t s = test_box(NX, NY, NZ, 0.7, COLLISION_TRT);
    face_t *f = s.domain.faces;
    if (walls == 0) {
        f[0].type = FACE_VELOCITY_INLET;
        f[0].profile = PROFILE_PARABOLIC;
        f[0].velocity[0] = 0.02;
        f[1].type = FACE_PRESSURE_OUTLET;
        f[1].pressure = 0.0;
        f[2].type = FACE_NO_SLIP;
        f[3].type = FACE_MOVING_WALL;
        f[3].velocity[0] = 0.01;
        f[3].velocity[2] = -0.005;
    } else {
        f[2].type = f[3].type = FACE_FREE_SLIP;
        f[4].type = FACE_NO_SLIP;
        f[5].type = FACE_MOVING_WALL;
        f[5].velocity[1] = 0.015;
        s.fluid.body_force[0] = 2e-6;
    }
    const double c[3] = {7.3, 6.8, 5.9};
    scene_body_t *b = harness_one_sphere(&s, c, 3.2, MOTION_PRESCRIBED);
    b->velocity[0] = 0.04;
    b->velocity[1] = -0.02;
    b->angular_velocity[2] = 0.01;
    s.fluid.boundary_scheme = scheme;
    s.fluid.refill = REFILL_EXTRAPOLATION;
    s.fluid.streaming = streaming;
    return s;
}

static double max_rel(const double *a, const double *b, int n, double scale)
{
    double m = 0.0;
    for (int i = 0; i < n; i++) {
        m = fmax(m, fabs(a[i] - b[i]) / scale);
    }
    return m;
}

static void test_layouts_agree(void)
{
    static const boundary_scheme_t schemes[] = {BOUNDARY_BOUNCE_BACK, BOUNDARY_YU, BOUNDARY_CLI, BOUNDARY_QUADRATIC,
                                                BOUNDARY_MULTIREFLECTION};
    double *m[2];
    m[0] = malloc(sizeof(double) * 4 * NCELLS);
    m[1] = malloc(sizeof(double) * 4 * NCELLS);
    CU_ASSERT_FATAL(m[0] != NULL && m[1] != NULL);
    for (int walls = 0; walls < 2; walls++) {
        for (int k = 0; k < 5; k++) {
            double load[2][6];
            long covered[2];
            for (int l = 0; l < 2; l++) {
                scene_t s = layout_scene(walls, schemes[k], l == 0 ? STREAMING_TWO_ARRAY : STREAMING_IN_PLACE);
                fluid_t *fl = test_fluid(&s);
                test_run(fl, 41); /* odd: the in-place array ends after a push kernel */
                fluid_moments_lattice(fl, m[l], m[l] + NCELLS);
                fluid_sphere_load_lattice(fl, 0, load[l], load[l] + 3);
                covered[l] = fl->spheres.covered_total + fl->spheres.uncovered_total;
                fluid_free(fl);
            }
            const double drho = max_rel(m[0], m[1], NCELLS, 1.0);
            const double du = max_rel(m[0] + NCELLS, m[1] + NCELLS, 3 * NCELLS, 0.04);
            const double fscale = sqrt(load[0][0] * load[0][0] + load[0][1] * load[0][1] + load[0][2] * load[0][2]);
            const double dload = max_rel(load[0], load[1], 6, fscale * 3.2);
            CU_ASSERT(covered[0] > 10 && covered[0] == covered[1]); /* the sphere crossed cells */
            CU_ASSERT(fscale > 0.0);
            CU_ASSERT(drho < 1e-13);
            CU_ASSERT(du < 1e-11);
            CU_ASSERT(dload < 1e-11);
            if (!(drho < 1e-13 && du < 1e-11 && dload < 1e-11)) {
                printf("\n    walls %d scheme %d: density %.3g, velocity %.3g, load %.3g (relative)", walls, k, drho,
                       du, dload);
            }
        }
    }
    free(m[0]);
    free(m[1]);
}

/* Single precision (f - w_q stored as float) against double, in place: the
 * flow differs by the float round-off of the stored deviations from rest. A
 * rounding of 2^-24 of a deviation of about |u| w_q ~ 1e-3 is ~1e-10 per value
 * and step; the bounds allow 100 times that after 41 steps. */
static void test_single_precision_close_to_double(void)
{
    double *m[2];
    m[0] = malloc(sizeof(double) * 4 * NCELLS);
    m[1] = malloc(sizeof(double) * 4 * NCELLS);
    CU_ASSERT_FATAL(m[0] != NULL && m[1] != NULL);
    for (int walls = 0; walls < 2; walls++) {
        double load[2][6];
        for (int l = 0; l < 2; l++) {
            scene_t s = layout_scene(walls, BOUNDARY_CLI, STREAMING_IN_PLACE);
            s.fluid.precision = l == 0 ? PRECISION_DOUBLE : PRECISION_SINGLE;
            fluid_t *fl = test_fluid(&s);
            test_run(fl, 41);
            fluid_moments_lattice(fl, m[l], m[l] + NCELLS);
            fluid_sphere_load_lattice(fl, 0, load[l], load[l] + 3);
            fluid_free(fl);
        }
        const double drho = max_rel(m[0], m[1], NCELLS, 1.0);
        const double du = max_rel(m[0] + NCELLS, m[1] + NCELLS, 3 * NCELLS, 1.0);
        const double fscale = sqrt(load[0][0] * load[0][0] + load[0][1] * load[0][1] + load[0][2] * load[0][2]);
        const double dload = max_rel(load[0], load[1], 6, fscale);
        printf("\n    walls %d: single - double: density %.2g, velocity %.2g (lattice), load %.2g (relative)", walls,
               drho, du, dload);
        CU_ASSERT(drho > 0.0 && drho < 1e-7);
        CU_ASSERT(du > 0.0 && du < 1e-7);
        CU_ASSERT(dload < 1e-4);
    }
    free(m[0]);
    free(m[1]);
}

/* A state saved after an odd and after an even number of steps (the two
 * in-place states) continues bit-identically in a fresh component; the same
 * state one byte short is refused. */
static void test_in_place_state_restore(void)
{
    for (int run = 0; run < 3; run++) {
        const int steps = run == 1 ? 18 : 17;
        scene_t s = layout_scene(0, BOUNDARY_MULTIREFLECTION, STREAMING_IN_PLACE);
        s.fluid.precision = run == 2 ? PRECISION_SINGLE : PRECISION_DOUBLE;
        fluid_t *a = test_fluid(&s), *r = test_fluid(&s);
        test_run(a, steps);
        const size_t n = fluid_state_size(a);
        void *buf = malloc(n);
        CU_ASSERT_FATAL(buf != NULL);
        CU_ASSERT_EQUAL(fluid_state_save(a, buf, n), STATUS_OK);
        test_run(a, 9);
        /* cut short inside its last section (the links' pre-collision pairs): refused */
        CU_ASSERT_EQUAL(fluid_state_restore(r, buf, n - 1), STATUS_ERROR);
        CU_ASSERT_EQUAL(fluid_state_restore(r, buf, n), STATUS_OK);
        test_run(r, 9);
        double *ma = malloc(sizeof(double) * 4 * NCELLS), *mr = malloc(sizeof(double) * 4 * NCELLS);
        CU_ASSERT_FATAL(ma != NULL && mr != NULL);
        fluid_moments_lattice(a, ma, ma + NCELLS);
        fluid_moments_lattice(r, mr, mr + NCELLS);
        CU_ASSERT(memcmp(ma, mr, sizeof(double) * 4 * NCELLS) == 0);
        double la[6], lr[6];
        fluid_sphere_load_lattice(a, 0, la, la + 3);
        fluid_sphere_load_lattice(r, 0, lr, lr + 3);
        CU_ASSERT(memcmp(la, lr, sizeof la) == 0);
        /* a two-array state (a double one, for the single run) is refused */
        scene_t t = layout_scene(0, BOUNDARY_MULTIREFLECTION, run == 2 ? STREAMING_IN_PLACE : STREAMING_TWO_ARRAY);
        fluid_t *o = test_fluid(&t);
        const size_t no = fluid_state_size(o);
        void *bo = malloc(no);
        CU_ASSERT_FATAL(bo != NULL);
        CU_ASSERT_EQUAL(fluid_state_save(o, bo, no), STATUS_OK);
        CU_ASSERT_EQUAL(fluid_state_restore(r, bo, no), STATUS_ERROR);
        free(bo);
        fluid_free(o);
        free(ma);
        free(mr);
        free(buf);
        fluid_free(a);
        fluid_free(r);
    }
}

/* Lambda = (tau - 1/2)/2 makes omega_minus = 1: the collision leaves no
 * trace of the pre-collision n^- that multireflection's correction needs,
 * and only the pair each link keeps (spheres.h) has it. Both layouts then
 * agree to round-off (a link new in a step goes without the correction in
 * both), and the steady drag of a fixed sphere lies between its values at
 * Lambda 0.2 and 0.3 (where n^- could also be recovered from the
 * post-collision values) as a smooth function of Lambda: measured 1.5e-7 from
 * their mean, where without the pairs (no correction) it is 1.1e-5 off. */
static void test_in_place_multireflection_at_omega_minus_one(void)
{
    static const double magic[4] = {0.25, 0.25, 0.2, 0.3};
    double fx[4];
    for (int l = 0; l < 4; l++) {
        /* a fixed sphere in a periodic box, pushed by a body force, to steady state */
        scene_t s = test_box(12, 12, 12, 1.0, COLLISION_TRT);
        const double c[3] = {6.31, 6.27, 6.64};
        harness_one_sphere(&s, c, 3.0, MOTION_FIXED);
        s.fluid.boundary_scheme = BOUNDARY_MULTIREFLECTION;
        s.fluid.magic = magic[l];
        s.fluid.body_force[0] = 1e-6;
        s.fluid.streaming = l == 0 ? STREAMING_TWO_ARRAY : STREAMING_IN_PLACE;
        fluid_t *fl = test_fluid(&s);
        CU_ASSERT_FATAL(fl != NULL);
        CU_ASSERT(l >= 2 || fabs(fl->units.omega_minus - 1.0) < 1e-12);
        test_run(fl, 1500);
        double f[3], t[3];
        fluid_sphere_load_lattice(fl, 0, f, t);
        fx[l] = f[0];
        fluid_free(fl);
    }
    const double mid = 0.5 * (fx[2] + fx[3]);
    printf("\n    fixed sphere, steady drag: two arrays %.12g, in place %.12g, mean of Lambda 0.2 and 0.3 %.12g "
           "(%.2g)", fx[0], fx[1], mid, fx[1] / mid - 1.0);
    CU_ASSERT(fx[0] > 0.0 && fabs(fx[1] - fx[0]) < 1e-12 * fx[0]);
    CU_ASSERT(fabs(fx[1] - mid) < 3e-6 * mid);
    double load[2][6];
    for (int l = 0; l < 2; l++) {
        scene_t s = layout_scene(1, BOUNDARY_MULTIREFLECTION, l == 0 ? STREAMING_TWO_ARRAY : STREAMING_IN_PLACE);
        s.fluid.magic = (s.fluid.tau - 0.5) / 2.0;
        fluid_t *fl = test_fluid(&s);
        CU_ASSERT_FATAL(fl != NULL);
        test_run(fl, 41);
        fluid_sphere_load_lattice(fl, 0, load[l], load[l] + 3);
        fluid_free(fl);
    }
    const double fscale = sqrt(load[0][0] * load[0][0] + load[0][1] * load[0][1] + load[0][2] * load[0][2]);
    const double dload = max_rel(load[0], load[1], 6, fscale * 3.2);
    printf("; moving sphere, load: %.3g (relative)", dload);
    CU_ASSERT(fscale > 0.0 && dload < 1e-11);
}

/* Whether grid cell i is an interior cell. */
static int interior(const fluid_t *fl, size_t i)
{
    const size_t sx = (size_t)fl->g.s[0], sy = (size_t)fl->g.s[1];
    return grid_is_interior(&fl->g, (int)(i % sx), (int)(i / sx % sy), (int)(i / (sx * sy)));
}

/* The value of every population of the interior solid cells set to v
 * (all: every slot each sends; else the rest population alone, the one slot
 * a cell owns in both in-place states). */
static void set_solid(fluid_t *fl, double v, int all)
{
    const pops_t p = fluid_pops(fl);
    for (size_t j = 0; j < fl->spheres.nsolid; j++) {
        const size_t i = fl->spheres.solid[j];
        if (!interior(fl, i)) {
            continue;
        }
        for (int q = 0; q < (all ? LB_Q : 1); q++) {
            pops_write(&p, q, pops_post_slot(&p, q, i), v);
        }
    }
}

/* In place the update leaves the cells inside the spheres alone (kernel.h
 * kernel_skip_t), which is right because what they hold never reaches the
 * fluid: with every value of every solid cell made NaN after each step, a
 * moving and turning sphere (away from the walls) gives the same flow and
 * load to the bit as without, whether the update skips them or not; and the
 * rest population of a cell solid before and after a step keeps a value
 * put there when the update skips it, and not when it does not. */
static void test_in_place_leaves_solid_cells_alone(void)
{
    double *m[2];
    m[0] = malloc(sizeof(double) * 4 * NCELLS);
    m[1] = malloc(sizeof(double) * 4 * NCELLS);
    CU_ASSERT_FATAL(m[0] != NULL && m[1] != NULL);
    for (int walls = 0; walls < 2; walls++) {
        for (int skip = 0; skip < 2; skip++) {
            double load[2][6];
            for (int poison = 0; poison < 2; poison++) {
                scene_t s = layout_scene(walls, walls ? BOUNDARY_MULTIREFLECTION : BOUNDARY_CLI, STREAMING_IN_PLACE);
                fluid_t *fl = test_fluid(&s);
                fl->skip_on = skip;
                for (int n = 0; n < 41; n++) {
                    CU_ASSERT_EQUAL(fluid_step(fl), STATUS_OK);
                    if (poison) {
                        set_solid(fl, NAN, 1);
                    }
                }
                fluid_moments_lattice(fl, m[poison], m[poison] + NCELLS);
                fluid_sphere_load_lattice(fl, 0, load[poison], load[poison] + 3);
                CU_ASSERT(fl->spheres.covered_total > 5 && fl->spheres.uncovered_total > 5);
                fluid_free(fl);
            }
            CU_ASSERT(memcmp(m[0], m[1], sizeof(double) * 4 * NCELLS) == 0);
            CU_ASSERT(memcmp(load[0], load[1], sizeof load[0]) == 0);
            CU_ASSERT(isfinite(load[1][0]) && load[1][0] != 0.0);
        }
    }
    for (int skip = 0; skip < 2; skip++) {
        scene_t s = layout_scene(1, BOUNDARY_CLI, STREAMING_IN_PLACE);
        fluid_t *fl = test_fluid(&s);
        fl->skip_on = skip;
        test_run(fl, 6);
        set_solid(fl, 7.0, 0);
        const size_t ncells = fl->g.ncells;
        unsigned char *was = calloc(ncells, 1);
        CU_ASSERT_FATAL(was != NULL);
        for (size_t j = 0; j < fl->spheres.nsolid; j++) {
            was[fl->spheres.solid[j]] = 1;
        }
        CU_ASSERT_EQUAL(fluid_step(fl), STATUS_OK);
        const pops_t p = fluid_pops(fl);
        long kept = 0, both = 0;
        for (size_t j = 0; j < fl->spheres.nsolid; j++) {
            const size_t i = fl->spheres.solid[j];
            if (was[i] && interior(fl, i)) {
                both++;
                kept += pops_post(&p, 0, i) == 7.0;
            }
        }
        CU_ASSERT(both > 50);
        CU_ASSERT_EQUAL(kept, skip ? both : 0);
        free(was);
        fluid_free(fl);
    }
    free(m[0]);
    free(m[1]);
}

/* Box with both faces of one axis (z, or x) of type t, the others
 * periodic, a body force along the faces, and one sphere of radius 3.2 at
 * `gap` cells from the low z face (axis 2) or the high x face (axis 0):
 * fixed, or prescribed to slide along the face and turn. */
static scene_t wall_gap_scene(face_type_t t, int axis, double gap, int moving)
{
    scene_t s = test_box(NX, NY, NZ, 0.8, COLLISION_TRT);
    face_t *f = s.domain.faces;
    const int tan = axis == 2 ? 0 : 1, other = 3 - axis - tan; /* the axes along the faces */
    f[2 * axis].type = f[2 * axis + 1].type = t;
    if (t == FACE_MOVING_WALL) {
        f[2 * axis].velocity[tan] = 0.02;
        f[2 * axis].velocity[other] = 0.007;
        f[2 * axis + 1].velocity[tan] = -0.01;
    }
    s.fluid.body_force[tan] = 3e-6;
    s.fluid.body_force[other] = 1e-6;
    const double r = 3.2;
    double c[3] = {7.3, 6.8, 5.9};
    c[axis] = axis == 2 ? r + gap : s.domain.size[axis] - r - gap;
    scene_body_t *b = harness_one_sphere(&s, c, r, moving ? MOTION_PRESCRIBED : MOTION_FIXED);
    if (moving) {
        b->velocity[tan] = 0.03;
        b->velocity[other] = -0.01;
        b->angular_velocity[axis] = 0.01;
        b->angular_velocity[tan] = 0.005;
    }
    s.fluid.refill = REFILL_EXTRAPOLATION;
    return s;
}

/* The same premise next to the walls, where the walls' fill reads cells
 * near the sphere (the free-slip copy from the cell beside the ghost, the
 * moving wall's density, the slip correction two cells inwards): a sphere
 * at a gap of 0, 0.3, 1 and 1.5 cells from a free-slip, moving or no-slip
 * face on z and on x, fixed and sliding, with NaN in every value of every
 * solid cell after each step, gives the flow and the load of the run
 * without to the bit, and in place with the update of the solid cells
 * skipped or not. Collision, scheme and layout take turns over the cases
 * (TRT at 1/4 with multireflection in place, BGK with bounce-back on two
 * arrays, TRT at 3/16 with cli in place, TRT at 1/4 with yu on two
 * arrays). Before walls.c checked the free-slip copy's source, a sphere
 * within half a cell of a free-slip face (its first layer of cells partly
 * solid) passed the solid cells' values on: NaN everywhere, and without
 * NaN a fixed sphere's force that depended on AGGLO_SKIP_SOLID. */
static void test_solid_cells_next_to_walls(void)
{
    const face_type_t types[3] = {FACE_FREE_SLIP, FACE_MOVING_WALL, FACE_NO_SLIP};
    const double gaps[4] = {0.0, 0.3, 1.0, 1.5};
    const struct {
        collision_t op;
        double magic;
        boundary_scheme_t scheme;
        streaming_t streaming;
    } mix[4] = {{COLLISION_TRT, 0.25, BOUNDARY_MULTIREFLECTION, STREAMING_IN_PLACE},
                {COLLISION_BGK, 3.0 / 16.0, BOUNDARY_BOUNCE_BACK, STREAMING_TWO_ARRAY},
                {COLLISION_TRT, 3.0 / 16.0, BOUNDARY_CLI, STREAMING_IN_PLACE},
                {COLLISION_TRT, 0.25, BOUNDARY_YU, STREAMING_TWO_ARRAY}};
    double *m[3];
    for (int k = 0; k < 3; k++) {
        m[k] = malloc(sizeof(double) * 4 * NCELLS);
        CU_ASSERT_FATAL(m[k] != NULL);
    }
    int cases = 0, same = 0, nsolid_layer = 0;
    for (int t = 0; t < 3; t++) {
        for (int axis = 0; axis <= 2; axis += 2) {
            for (int gi = 0; gi < 4; gi++) {
                for (int moving = 0; moving < 2; moving++) {
                    const int k = cases % 4;
                    const int runs = mix[k].streaming == STREAMING_IN_PLACE ? 3 : 2;
                    double load[3][6];
                    for (int run = 0; run < runs; run++) { /* 0 as is, 1 NaN in the solid cells, 2 no skip */
                        scene_t s = wall_gap_scene(types[t], axis, gaps[gi], moving);
                        s.fluid.collision = mix[k].op;
                        s.fluid.magic = mix[k].magic;
                        s.fluid.boundary_scheme = mix[k].scheme;
                        s.fluid.streaming = mix[k].streaming;
                        fluid_t *fl = test_fluid(&s);
                        fl->skip_on = run != 2;
                        for (int n = 0; n < 30; n++) {
                            CU_ASSERT_EQUAL(fluid_step(fl), STATUS_OK);
                            if (run == 1) {
                                set_solid(fl, NAN, 1);
                            }
                        }
                        fluid_moments_lattice(fl, m[run], m[run] + NCELLS);
                        fluid_sphere_load_lattice(fl, 0, load[run], load[run] + 3);
                        fluid_free(fl);
                    }
                    int ok = isfinite(load[0][0]) && load[0][0] != 0.0;
                    for (int run = 1; run < runs; run++) {
                        ok = ok && memcmp(m[0], m[run], sizeof(double) * 4 * NCELLS) == 0 &&
                             memcmp(load[0], load[run], sizeof load[0]) == 0;
                    }
                    same += ok;
                    nsolid_layer += gaps[gi] < 0.5;
                    cases++;
                }
            }
        }
    }
    printf("; %d of %d cases bit-identical (%d with solid cells next to the face)", same, cases, nsolid_layer);
    CU_ASSERT_EQUAL(same, cases);
    for (int k = 0; k < 3; k++) {
        free(m[k]);
    }
}

void layouts_register_tests(void)
{
    CU_pSuite s = CU_add_suite("layouts", NULL, NULL);
    CU_add_test(s, "two_array and in_place agree to round-off: every wall and scheme, a moving sphere",
                test_layouts_agree);
    CU_add_test(s, "in place: state saved after either kernel continues bit-identically", test_in_place_state_restore);
    CU_add_test(s, "single precision: flow and load within float round-off of double",
                test_single_precision_close_to_double);
    CU_add_test(s, "in place: multireflection at omega_minus = 1 from the links' kept pairs",
                test_in_place_multireflection_at_omega_minus_one);
    CU_add_test(s, "in place: the cells inside the spheres left alone, and nothing of them reaches the fluid",
                test_in_place_leaves_solid_cells_alone);
    CU_add_test(s, "NaN in the solid cells of a sphere at or near each wall type reaches nothing (gap 0-1.5 cells)",
                test_solid_cells_next_to_walls);
}
