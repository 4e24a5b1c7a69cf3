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

#include <CUnit/CUnit.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

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

/* The film zone leaves out the lattice's normal force where a surface is
 * within the cut-off of a wall or of another body, but not the ambient
 * pressure there: fixed spheres half a cell from a no-slip wall and from
 * each other, in fluid at rest at density 1 + d, feel no load (a uniform
 * pressure on a closed surface). When the zone's normal part was left out
 * whole, a uniform raised pressure pushed the sphere into the wall by about
 * d/3 times the zone's area: at d = 0.01 a load of 0.101 (wall), 0.034 and
 * 0.068 (pair; now below 5e-15); an outlet pressure of 0.05 Pa made a
 * wall-ward force of 57% of a fixed sphere's drag in an inlet-outlet
 * channel (-3.5e-9 N at 0, -1.9e-8 N at 0.05 Pa; now +4.9e-10 N at both). */
static void test_film_zone_keeps_ambient_pressure(void)
{
    const int L = 16, Lz = 24;
    for (int pair = 0; pair < 2; pair++) {
        for (int k = 0; k < 2; k++) {
            const double d = k == 0 ? 0.01 : -0.01;
            scene_t s = test_box(L, L, Lz, 0.8, COLLISION_TRT);
            s.domain.faces[4].type = FACE_NO_SLIP;
            s.domain.faces[5].type = FACE_NO_SLIP;
            s.contacts.lubrication.enabled = 1;
            s.contacts.lubrication.cutoff = 2.0;
            /* half a cell from the floor, and the second sphere half a cell above it */
            scene_sphere_t sph[2] = {{{8.2, 7.9, 4.5}, 4.0}, {{8.2, 7.9, 13.0}, 4.0}};
            scene_body_t body[2] = {{.nspheres = 1, .spheres = &sph[0], .density = 2.0, .motion = MOTION_FIXED},
                                    {.nspheres = 1, .spheres = &sph[1], .density = 2.0, .motion = MOTION_FIXED}};
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
                printf("\n    %s, density %.2f, sphere %d: load %.3g (z %.3g)", pair ? "pair" : "wall", 1.0 + d, b, fn,
                       f[2]);
                CU_ASSERT(fn < 1e-9);
            }
            fluid_free(fl);
        }
    }
}

void approach_register_tests(int validate)
{
    CU_pSuite s = CU_add_suite("close approaches", NULL, NULL);
    CU_add_test(s, "Brenner's series reproduces his table and limits", test_brenner_series);
    CU_add_test(s, "sphere to wall r=8: Brenner within 5% at gap/a 1..0.05", test_wall_approach_quick);
    CU_add_test(s, "two spheres r=8, two placements: Brenner (free surface) within 5% at gap/a 0.2, 0.1, 0.05",
                test_two_spheres_quick);
    CU_add_test(s, "film zone at rest in fluid of density 1 +- 0.01: no load (wall and pair half a cell apart)",
                test_film_zone_keeps_ambient_pressure);
    if (validate) {
        CU_pSuite v = CU_add_suite("close approaches-validate", NULL, NULL);
        CU_add_test(v, "sphere to wall r=8, 96^3: Brenner within 5% at gap/a 2..0.05", test_wall_approach_full);
        CU_add_test(v, "two spheres r=8, 96^2 x 128, three placements: within 5% at gap/a 2..0.05",
                    test_two_spheres_full);
    }
}
