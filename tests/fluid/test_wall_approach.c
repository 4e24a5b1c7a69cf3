/* test_wall_approach.c — close approaches: a sphere moving towards a no-slip
 * wall and two spheres moving towards each other at low Reynolds number,
 * the lattice force plus the lubrication correction (rigid/lubrication.c)
 * against the exact Stokes results (issue 10).
 *
 * References (shared/reference/validation-references.md):
 * - Brenner, Chem. Eng. Sci. 16 (1961) 242: F = 6 pi mu a U lambda for a
 *   sphere approaching a plane, exact series for a rigid wall and for a free
 *   surface; the latter is, by mirror symmetry, two equal spheres closing with
 *   equal and opposite velocities (their gap = 2 (h - a)).
 * - Cooley & O'Neill (1969), Jeffrey (1982): the lubrication limits
 *   lambda -> a/h (wall) and a/(4 (h - a)) (free surface).
 * - Jeffrey & Onishi (1984): the log term of the film below the cut-off.
 * The method (approach_harness.h): prescribed motion at U from the steady
 * flow at the first gap, the force averaged over half a cell of travel
 * around each gap (what a moving particle feels of the lattice's cell-by-cell
 * jumps). Radius 8 cells, TRT (magic 3/16), CLI, Re = U a / nu = 0.07, the
 * scene's default cut-off (2 cells) with the fluid's film zone. */
#include "approach_harness.h"
#include "fluid_tests.h"
#include "test_util.h"

#include "../../fluid/lattice.h"

#include <CUnit/CUnit.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void print_points(const char *what, const approach_point_t *p, int n)
{
    for (int k = 0; k < n; k++) {
        printf("\n    %s gap/a %.2f: Brenner %.4g, lattice + film %.4f of it (%.3f-%.3f in the window), lattice "
               "alone %.4f, film share %.3f",
               what, p[k].gap, p[k].reference, p[k].total, p[k].lo, p[k].hi, p[k].lattice, p[k].lub_share);
    }
}

/* Asserts the wall approach at gaps[0..n): within tol of Brenner with the
 * film; where the window stays above the cut-off the film adds nothing (no
 * double counting) and the lattice alone is within tol; at the smallest gap
 * the lattice alone is far short (what the correction is for). */
static void check_wall(const approach_setup_t *set, const double *gaps, int n, double tol)
{
    approach_point_t p[8];
    const long steps = harness_approach(set, gaps, n, p);
    CU_ASSERT_FATAL(steps > 0);
    print_points("wall", p, n);
    for (int k = 0; k < n; k++) {
        CU_ASSERT(fabs(p[k].total - 1.0) < tol);
        if (gaps[k] * set->a - 0.25 > set->cutoff) {
            CU_ASSERT(p[k].lub_share == 0.0);
            CU_ASSERT(fabs(p[k].lattice - 1.0) < tol);
        }
    }
    CU_ASSERT(p[n - 1].lattice < 0.8);
}

static void test_wall_approach_quick(void)
{
    const approach_setup_t set = {APPROACH_WALL, 8.0, 64, 64, 1.5, 0.003, 0.0, 2.0, 1.1, 0.015, NULL};
    const double gaps[] = {1.0, 0.5, 0.2, 0.1, 0.05};
    check_wall(&set, gaps, 5, 0.05);
}

static void test_wall_approach_full(void)
{
    const approach_setup_t set = APPROACH_WALL_FULL;
    const double gaps[] = {2.0, 1.0, 0.5, 0.2, 0.1, 0.05};
    check_wall(&set, gaps, 6, 0.05);
}

/* Two spheres: below a cell or two the lattice sees the gap only where a row
 * of nodes lies in it, so without the film zone the force of one placement
 * depends on where the midplane sits in the cell (0.76 to 1.18 of Brenner
 * at gap/a 0.1 and 0.05 with the cut-off at 0.67 cells and no zone). Each
 * placement (offsets in cells of the midplane above a cell face: 0, no node
 * in a gap below one cell; 0.5, a row of nodes in it) must be within tol on
 * its own, and the placements within spread of each other. */
static void check_pair(approach_setup_t set, const double *offsets, int no, const double *gaps, int n, double tol,
                       double spread)
{
    approach_point_t p[3][8];
    for (int o = 0; o < no; o++) {
        set.offset = offsets[o];
        const long steps = harness_approach(&set, gaps, n, p[o]);
        CU_ASSERT_FATAL(steps > 0);
        printf("\n    midplane %.2f cell above a cell face:", set.offset);
        print_points("two spheres", p[o], n);
        for (int k = 0; k < n; k++) {
            CU_ASSERT(fabs(p[o][k].total - 1.0) < tol);
        }
    }
    for (int k = 0; k < n; k++) {
        double lo = INFINITY, hi = -INFINITY;
        for (int o = 0; o < no; o++) {
            lo = fmin(lo, p[o][k].total);
            hi = fmax(hi, p[o][k].total);
        }
        printf("\n    two spheres gap/a %.2f: placements from %.4f to %.4f", gaps[k], lo, hi);
        CU_ASSERT(hi - lo < spread);
    }
}

static void test_two_spheres_quick(void)
{
    const approach_setup_t set = {APPROACH_SPHERES, 8.0, 64, 80, 1.5, 0.003, 0.0, 2.0, 0.3, 0.015, NULL};
    /* in this box the pair's images add 2-3% at gap/a 0.2 (against the full one) */
    const double gaps[] = {0.2, 0.1, 0.05}, offsets[] = {0.0, 0.5};
    check_pair(set, offsets, 2, gaps, 3, 0.05, 0.03);
}

static void test_two_spheres_full(void)
{
    const approach_setup_t set = APPROACH_PAIR_FULL;
    const double gaps[] = {2.0, 1.0, 0.5, 0.2, 0.1, 0.05}, offsets[] = {0.0, 0.25, 0.5};
    check_pair(set, offsets, 3, gaps, 6, 0.05, 0.03);
}

static void test_brenner_series(void)
{
    /* Brenner's table (validation-references.md): alpha = 0.5 .. 3 */
    const double alpha[] = {0.5, 1.0, 1.5, 2.0, 2.5, 3.0}, table[] = {9.2518, 3.0361, 1.8375, 1.4129, 1.2220, 1.1252};
    for (int k = 0; k < 6; k++) {
        CU_ASSERT(fabs(brenner_lambda(cosh(alpha[k]) - 1.0, 0) / table[k] - 1.0) < 1e-4); /* the table has 5 digits */
    }
    /* the limits: a/h near the wall, a/(4h) near a free surface, 1 + 9/8 a/h far */
    CU_ASSERT(fabs(brenner_lambda(0.02, 0) / 51.761 - 1.0) < 1e-4);
    CU_ASSERT(fabs(brenner_lambda(0.02, 1) / 15.309 - 1.0) < 1e-4);
    CU_ASSERT(fabs(brenner_lambda(1e-3, 0) * 1e-3 - 1.0) < 0.01);
    CU_ASSERT(fabs(brenner_lambda(1e-3, 1) * 1e-3 * 4.0 - 1.0) < 0.04);
    CU_ASSERT(fabs((brenner_lambda(199.0, 0) - 1.0) / (9.0 / 8.0 / 200.0) - 1.0) < 0.01);
}

/* A uniform pressure loads no sphere. The film zone leaves out the
 * lattice's normal force where a surface is within the cut-off of a wall or
 * of another body, but not the ambient pressure there: fixed spheres half a
 * cell from a no-slip wall and from each other, in fluid at rest at density
 * 1 + d, feel no load (a uniform pressure on a closed surface). When the
 * zone's normal part was left out whole, a uniform raised pressure pushed the
 * sphere into the wall by about d/3 times the zone's area: at d = 0.01 a load
 * of 0.101 (wall), 0.034 and 0.068 (pair; now below 5e-15); an outlet
 * pressure of 0.05 Pa made a wall-ward force of 57% of a fixed sphere's drag
 * in an inlet-outlet channel (-3.5e-9 N at 0, -1.9e-8 N at 0.05 Pa; now
 * +4.9e-10 N at both). Touching (gap 0, no film zone), the surfaces are open
 * where cells face the wall or the other sphere without links: with the
 * exchange centred on density 1, d = +-0.01 loaded the sphere on the floor
 * with 0.043 and a torque of 0.0037, the pair (on the floor and on each
 * other) with 0.0089 and 0.034, torques 0.0013 and 0.0026 (now centred on
 * the ambient density, sphere_fill.c: below 5e-15). */
static void test_film_zone_keeps_ambient_pressure(void)
{
    const int L = 16, Lz = 24;
    for (int touch = 0; touch < 2; touch++) {
        for (int pair = 0; pair < 2; pair++) {
            for (int k = 0; k < 2; k++) {
                const double d = k == 0 ? 0.01 : -0.01, gap = touch ? 0.0 : 0.5;
                scene_t s = test_box(L, L, Lz, 0.8, COLLISION_TRT);
                s.domain.faces[4].type = FACE_NO_SLIP;
                s.domain.faces[5].type = FACE_NO_SLIP;
                s.contacts.lubrication.enabled = !touch;
                s.contacts.lubrication.cutoff = 2.0;
                /* the gap from the floor, and the second sphere the gap above
                 * it; free (held where they are: nothing moves them), as only
                 * free spheres have a film zone */
                scene_sphere_t sph[2] = {{{8.2, 7.9, 4.0 + gap}, 4.0}, {{8.2, 7.9, 12.0 + 2.0 * gap}, 4.0}};
                scene_body_t body[2] = {{.nspheres = 1, .spheres = &sph[0], .density = 2.0, .motion = MOTION_FREE},
                                        {.nspheres = 1, .spheres = &sph[1], .density = 2.0, .motion = MOTION_FREE}};
                s.bodies = body;
                s.nbodies = pair ? 2 : 1;
                fluid_t *fl = test_fluid(&s);
                CU_ASSERT_FATAL(fl != NULL);
                double *rho = malloc(sizeof(double) * L * L * Lz);
                CU_ASSERT_FATAL(rho != NULL);
                for (int i = 0; i < L * L * Lz; i++) {
                    rho[i] = 1.0 + d;
                }
                fluid_set_equilibrium_lattice(fl, rho, NULL);
                free(rho);
                test_run(fl, 20);
                for (int b = 0; b < s.nbodies; b++) {
                    double f[3], t[3];
                    fluid_sphere_load_lattice(fl, b, f, t);
                    const double fn = sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
                    const double tn = sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
                    printf("\n    %s, gap %.1f, density %.2f, sphere %d: load %.3g (z %.3g), torque %.3g",
                           pair ? "pair" : "wall", gap, 1.0 + d, b, fn, f[2], tn);
                    CU_ASSERT(fn < 1e-9 && tn < 1e-9);
                }
                fluid_free(fl);
            }
        }
    }
}

/* Pinched cells: a fluid cell between two walls along c_q (a sphere on
 * each side, or a sphere and a no-slip floor, less than a cell apart) has
 * no fluid neighbour along that line, so plain bounce-back on both sides
 * swaps the pair each step and the collision, which keeps the cell's
 * momentum, never damps their difference: a fixed sphere touching a floor,
 * started in a uniform flow, kept the initial velocity (-3e-4) in the cell
 * next to the contact, its sign flipping each step (|u| 3.0e-4 after 1500
 * steps, of 2e-7 elsewhere); a free sphere that settled onto a floor kept
 * what its approach left there, and it moved the sphere. Both walls now
 * send back the pair's mean (sphere_fill.c, walls.c): the pair keeps its
 * mass and takes the walls' velocity. Checked here: the flow decays in
 * those cells as elsewhere, and with bounce-back at rest the fluid's mass
 * stays to round-off (the two sides agree; one alone loses mass). */
/* 1 when interior cell (x, y, z) of an nx x ny x nz grid, periodic in x
 * and y, walls below and above, is fluid and lies between non-fluid cells
 * (solid, or beyond a wall) along some c_q: a pinched cell. */
static int pinched_cell(const unsigned char *flags, int nx, int ny, int nz, int x, int y, int z)
{
    if (flags[x + nx * (y + ny * z)] != 0) {
        return 0;
    }
    for (int q = 1; q < LB_Q; q++) {
        int closed = 1;
        for (int sgn = -1; sgn <= 1; sgn += 2) {
            const int X = ((x + sgn * lb_c[q][0]) % nx + nx) % nx, Y = ((y + sgn * lb_c[q][1]) % ny + ny) % ny,
                      Z = z + sgn * lb_c[q][2];
            closed = closed && (Z < 0 || Z >= nz || flags[X + nx * (Y + ny * Z)] != 0);
        }
        if (closed) {
            return 1;
        }
    }
    return 0;
}

static void test_pinched_cells_damped(void)
{
    const int L = 16, Lz = 12;
    for (int pair = 0; pair < 2; pair++) {
        for (int bb = 0; bb < 2; bb++) {
            scene_t s = test_box(L, L, Lz, 0.7, COLLISION_TRT);
            s.domain.faces[4].type = FACE_NO_SLIP;
            s.domain.faces[5].type = FACE_NO_SLIP;
            s.fluid.boundary_scheme = bb ? BOUNDARY_BOUNCE_BACK : BOUNDARY_MULTIREFLECTION;
            s.fluid.initial_velocity[0] = 1e-4;
            s.fluid.initial_velocity[1] = 2e-4;
            s.fluid.initial_velocity[2] = -3e-4;
            /* touching the floor (gap 0); the pair: a second body's sphere
             * 0.02 cells from the first, above it along a slant */
            scene_sphere_t sph[2] = {{{8.29, 7.81, 3.3}, 3.3}, {{0.0, 0.0, 0.0}, 3.3}};
            const double d[3] = {2.3, 2.7, 4.5}, len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            for (int a = 0; a < 3; a++) {
                sph[1].center[a] = sph[0].center[a] + d[a] * (6.62 / len);
            }
            scene_body_t body[2] = {{.nspheres = 1, .spheres = &sph[0], .density = 2.0, .motion = MOTION_FIXED},
                                    {.nspheres = 1, .spheres = &sph[1], .density = 2.0, .motion = MOTION_FIXED}};
            s.bodies = body;
            s.nbodies = pair ? 2 : 1;
            fluid_t *fl = test_fluid(&s);
            CU_ASSERT_FATAL(fl != NULL);
            const int n = L * L * Lz;
            double *u = malloc(sizeof(double) * 3 * n), *rho = malloc(sizeof(double) * n);
            unsigned char *flags = malloc(n);
            CU_ASSERT_FATAL(u != NULL && rho != NULL && flags != NULL);
            test_run(fl, 1);
            fluid_moments_lattice(fl, rho, u);
            fluid_flags(fl, flags);
            double m0 = 0.0, m1 = 0.0, upinched = 0.0, urest = 0.0;
            for (int i = 0; i < n; i++) {
                m0 += flags[i] == 0 ? rho[i] : 0.0;
            }
            test_run(fl, 800);
            fluid_moments_lattice(fl, rho, u);
            long npinched = 0;
            for (int z = 0; z < Lz; z++) {
                for (int y = 0; y < L; y++) {
                    for (int x = 0; x < L; x++) {
                        const int i = x + L * (y + L * z);
                        if (flags[i] == 0) {
                            const double um = sqrt(u[3 * i] * u[3 * i] + u[3 * i + 1] * u[3 * i + 1] +
                                                   u[3 * i + 2] * u[3 * i + 2]);
                            m1 += rho[i];
                            if (pinched_cell(flags, L, L, Lz, x, y, z)) {
                                npinched++;
                                upinched = fmax(upinched, um);
                            } else {
                                urest = fmax(urest, um);
                            }
                        }
                    }
                }
            }
            printf("\n    %s, %s: %ld pinched cells, largest |u| after 800 steps there %.3g, elsewhere %.3g (3.7e-4 "
                   "at the start), mass change %.3g",
                   pair ? "sphere on a floor and a sphere 0.02 cells from it" : "sphere on a floor",
                   bb ? "bounce-back" : "multireflection", npinched, upinched, urest, m1 / m0 - 1.0);
            CU_ASSERT(npinched >= 4);
            /* the flow decays there as it does elsewhere (before: 3.0e-4 there) */
            CU_ASSERT(upinched < 1e-2 * 3.7e-4 && upinched < 2.0 * urest);
            if (bb) {
                CU_ASSERT(fabs(m1 / m0 - 1.0) < 1e-12);
            }
            free(u);
            free(rho);
            free(flags);
            fluid_free(fl);
        }
    }
}

/* A sphere moving along the bisector of an edge of two no-slip walls
 * (x_min and z_min), its film zones with both: mirrored in the bisector,
 * the load along x and along z must agree. The wall points on the bisector
 * are as near one wall as the other, and the first in axis order took them:
 * the x component of their normal part was left out, the z one kept, and
 * once they entered the zone (radius 5, gap 0.44 cells to each wall) the
 * load along z was 1.4% above the load along x. They are shared now. The
 * same edge mirrored (x_min, z_max), where the two gaps are rounded
 * differently, as well. */
static void test_edge_bisector_symmetric(void)
{
    for (int m = 0; m < 2; m++) {
        const int L = 20, zface = m == 0 ? 4 : 5;
        scene_t s = test_box(L, L, L, 1.0, COLLISION_TRT);
        s.fluid.magic = 0.25;
        s.domain.faces[0].type = s.domain.faces[1].type = FACE_NO_SLIP;
        s.domain.faces[4].type = s.domain.faces[5].type = FACE_NO_SLIP;
        s.contacts.lubrication.enabled = 1;
        s.contacts.lubrication.cutoff = 2.0;
        const double a = 5.0, g = 0.5, U = 0.003 / sqrt(2.0), sz = zface == 4 ? 1.0 : -1.0;
        scene_sphere_t sph = {{a + g, L / 2.0, zface == 4 ? a + g : L - a - g}, a};
        scene_body_t body = {.nspheres = 1, .spheres = &sph, .density = 2.0, .motion = MOTION_FREE};
        s.bodies = &body;
        s.nbodies = 1;
        fluid_t *fl = test_fluid(&s);
        CU_ASSERT_FATAL(fl != NULL);
        const double v[3] = {-U, 0.0, -sz * U}, w[3] = {0.0, 0.0, 0.0};
        double worst = 0.0, f[3], t[3];
        for (int k = 0; k < 60; k++) {
            sph.center[0] += v[0];
            sph.center[2] += v[2];
            fluid_set_sphere(fl, 0, sph.center, v, w);
            test_run(fl, 1);
            fluid_sphere_load_lattice(fl, 0, f, t);
            worst = fmax(worst, fabs(f[0] - sz * f[2]) / fabs(f[0]));
        }
        printf("\n    edge x_min, %s: load along x and z %.1e apart (load %.4f)", zface == 4 ? "z_min" : "z_max", worst,
               f[0]);
        CU_ASSERT(worst < 1e-12);
        fluid_free(fl);
    }
}

/* Three spheres of three bodies closing in a triangle: B at rest, A and C
 * moving at it along -(1,1,0) and -(1,0,1), each pair at the same gap. The
 * scene is its own mirror image in y <-> z (A <-> C), so B's load along y
 * and z must agree. B's wall points on that mirror plane are as near A as
 * C, and A (the lower index) took them: their normal part went along B-A
 * only, and B's y and z loads were up to 13% apart (radius 5, gaps 0.8 to
 * 0.1 cells, tau 1). */
static void test_triangle_mirror_symmetric(void)
{
    const int L = 28;
    scene_t s = test_box(L, L, L, 1.0, COLLISION_TRT);
    s.fluid.magic = 0.25;
    s.contacts.lubrication.enabled = 1;
    s.contacts.lubrication.cutoff = 2.0;
    const double a = 5.0, g0 = 0.7, c = L / 2.0 + 0.25, D = (2.0 * a + g0) / sqrt(2.0), u = 0.003 / sqrt(2.0);
    scene_sphere_t sph[3] = {{{c, c, c}, a}, {{c - D, c - D, c}, a}, {{c - D, c, c - D}, a}};
    scene_body_t body[3];
    for (int b = 0; b < 3; b++) {
        body[b] = (scene_body_t){.nspheres = 1, .spheres = &sph[b], .density = 2.0, .motion = MOTION_FREE};
    }
    s.bodies = body;
    s.nbodies = 3;
    fluid_t *fl = test_fluid(&s);
    CU_ASSERT_FATAL(fl != NULL);
    const double v[3][3] = {{0.0, 0.0, 0.0}, {u, u, 0.0}, {u, 0.0, u}}, w[3] = {0.0, 0.0, 0.0};
    double worst = 0.0, f[3], t[3];
    for (int k = 0; k < 100; k++) {
        for (int b = 0; b < 3; b++) {
            for (int x = 0; x < 3; x++) {
                sph[b].center[x] += v[b][x];
            }
            fluid_set_sphere(fl, b, sph[b].center, v[b], w);
        }
        test_run(fl, 1);
        fluid_sphere_load_lattice(fl, 0, f, t);
        worst = fmax(worst, fabs(f[1] - f[2]) / sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]));
    }
    printf("\n    triangle: the middle sphere's y and z loads %.1e apart (of its load)", worst);
    CU_ASSERT(worst < 1e-12);
    fluid_free(fl);
}

/* The film zone leaves out a free sphere's lattice normal force for the
 * rigid component's film; fixed and prescribed spheres get no film there
 * (it moves them with no film of their own against a wall), and their load
 * is what the output reports. A prescribed sphere driven at a no-slip wall
 * lost the zone's normal force with nothing in its place: radius 5, tau 1,
 * 0.28 of Brenner's force at gap/a 0.1 where the lattice alone gives 0.84
 * (`coupler run`, 32^3). Now its load is the lattice's, the same with and
 * without lubrication; a free sphere's still has the zone. */
static void test_prescribed_sphere_keeps_lattice_force(void)
{
    double fz[2][2];
    for (int free = 0; free < 2; free++) {
        for (int lub = 0; lub < 2; lub++) {
            scene_t s = test_box(16, 16, 20, 1.0, COLLISION_TRT);
            s.fluid.magic = 0.25;
            s.domain.faces[4].type = s.domain.faces[5].type = FACE_NO_SLIP;
            s.contacts.lubrication.enabled = lub;
            s.contacts.lubrication.cutoff = 2.0;
            scene_sphere_t sph = {{8.2, 7.9, 5.2}, 4.0};
            scene_body_t body = {.nspheres = 1,
                                 .spheres = &sph,
                                 .density = 2.0,
                                 .velocity = {0.0, 0.0, -0.005},
                                 .motion = free ? MOTION_FREE : MOTION_PRESCRIBED};
            s.bodies = &body;
            s.nbodies = 1;
            fluid_t *fl = test_fluid(&s);
            CU_ASSERT_FATAL(fl != NULL);
            const double w[3] = {0.0, 0.0, 0.0};
            double f[3], t[3];
            for (int k = 0; k < 60; k++) {
                if (free) { /* the same motion, set as a master would */
                    sph.center[2] += body.velocity[2];
                    fluid_set_sphere(fl, 0, sph.center, body.velocity, w);
                }
                test_run(fl, 1);
            }
            fluid_sphere_load_lattice(fl, 0, f, t);
            fz[free][lub] = f[2];
            fluid_free(fl);
        }
        printf("\n    %s sphere 0.4 cells from the floor: load %.6f with lubrication, %.6f without", free ? "free" : "prescribed",
               fz[free][1], fz[free][0]);
    }
    CU_ASSERT(fz[0][1] == fz[0][0]);
    CU_ASSERT(fabs(fz[1][1] - fz[1][0]) > 0.1 * fabs(fz[1][0]));
}

/* The pinched cells in the neck of a rigid dumbbell (two touching spheres of
 * one body) and between a sphere and a floor it slides on take the mean of
 * their walls' velocities: the neck cells of a translating dumbbell move with
 * it, and the cells under a sliding sphere at most at its speed. With each
 * side's whole moving-wall term (the first version of the pinched pairs)
 * the neck cells moved at 2.0 times the dumbbell's speed. */
static void test_pinched_cells_move_with_walls(void)
{
    for (int floor = 0; floor < 2; floor++) {
        const int L = 24;
        scene_t s = test_box(L, L, L, 0.8, COLLISION_TRT);
        if (floor) {
            s.domain.faces[4].type = FACE_NO_SLIP;
            s.domain.faces[5].type = FACE_NO_SLIP;
        }
        s.fluid.boundary_scheme = BOUNDARY_BOUNCE_BACK;
        const double U[3] = {0.004, 0.002, floor ? 0.0 : 0.001}, speed = sqrt(U[0] * U[0] + U[1] * U[1] + U[2] * U[2]);
        scene_sphere_t sph[2] = {{{8.3, 11.6, floor ? 4.0 : 11.8}, 4.0}, {{16.3, 11.6, 11.8}, 4.0}};
        scene_body_t body = {.nspheres = floor ? 1 : 2, .spheres = sph, .density = 2.0, .motion = MOTION_PRESCRIBED};
        memcpy(body.velocity, U, sizeof U);
        s.bodies = &body;
        s.nbodies = 1;
        fluid_t *fl = test_fluid(&s);
        CU_ASSERT_FATAL(fl != NULL);
        test_run(fl, 300);
        const int n = L * L * L;
        double *u = malloc(sizeof(double) * 3 * n);
        unsigned char *flags = malloc(n);
        CU_ASSERT_FATAL(u != NULL && flags != NULL);
        fluid_moments_lattice(fl, NULL, u);
        fluid_flags(fl, flags);
        double umax = 0.0;
        for (int i = 0; i < n; i++) {
            if (flags[i] == 0) {
                umax = fmax(umax, sqrt(u[3 * i] * u[3 * i] + u[3 * i + 1] * u[3 * i + 1] + u[3 * i + 2] * u[3 * i + 2]));
            }
        }
        printf("\n    %s: fastest fluid cell %.3f of the body's speed", floor ? "sphere sliding on a floor" : "dumbbell",
               umax / speed);
        CU_ASSERT(umax < 1.2 * speed);
        free(u);
        free(flags);
        fluid_free(fl);
    }
}

void approach_register_tests(int validate)
{
    CU_pSuite s = CU_add_suite("close approaches", NULL, NULL);
    CU_add_test(s, "Brenner's series reproduces his table and limits", test_brenner_series);
    CU_add_test(s, "sphere to wall r=8: Brenner within 5% at gap/a 1..0.05", test_wall_approach_quick);
    CU_add_test(s, "two spheres r=8, two placements: Brenner (free surface) within 5% at gap/a 0.2, 0.1, 0.05",
                test_two_spheres_quick);
    CU_add_test(s, "fluid at rest of density 1 +- 0.01: no load (wall and pair half a cell apart, and touching)",
                test_film_zone_keeps_ambient_pressure);
    CU_add_test(s, "pinched cells (a sphere on a floor, two spheres 0.02 apart): flow decays, mass kept",
                test_pinched_cells_damped);
    CU_add_test(s, "pinched cells move with their walls (a translating dumbbell's neck, a sphere sliding on a floor)",
                test_pinched_cells_move_with_walls);
    CU_add_test(s, "sphere along the bisector of an edge of two walls: the same load along both normals",
                test_edge_bisector_symmetric);
    CU_add_test(s, "three spheres closing in a triangle: the middle one's load mirrored", test_triangle_mirror_symmetric);
    CU_add_test(s, "prescribed sphere at a wall: its lattice load, no film zone", test_prescribed_sphere_keeps_lattice_force);
    if (validate) {
        CU_pSuite v = CU_add_suite("close approaches-validate", NULL, NULL);
        CU_add_test(v, "sphere to wall r=8, 96^3: Brenner within 5% at gap/a 2..0.05", test_wall_approach_full);
        CU_add_test(v, "two spheres r=8, 96^2 x 128, three placements: within 5% at gap/a 2..0.05",
                    test_two_spheres_full);
    }
}
