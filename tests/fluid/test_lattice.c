/* test_lattice.c — identities of the D3Q19 velocity set (lattice.h).
 * Reference: Qian, d'Humieres & Lallemand, Europhys. Lett. 17 (1992) 479:
 * sum w = 1, sum w c_a = 0, sum w c_a c_b = c_s^2 delta_ab with c_s^2 = 1/3,
 * sum w c_a c_b c_c = 0 and the isotropic fourth moment
 * sum w c_a c_b c_c c_d = c_s^4 (d_ab d_cd + d_ac d_bd + d_ad d_bc). */
#include "fluid_tests.h"

#include "../../fluid/lattice.h"

#include <CUnit/CUnit.h>
#include <math.h>

static int delta(int a, int b) { return a == b; }

static void test_weights_and_moments(void)
{
    double s0 = 0.0, s1[3] = {0}, s2[3][3] = {{0}}, s3[3][3][3] = {{{0}}};
    for (int q = 0; q < LB_Q; q++) {
        s0 += lb_w[q];
        for (int a = 0; a < 3; a++) {
            s1[a] += lb_w[q] * lb_c[q][a];
            for (int b = 0; b < 3; b++) {
                s2[a][b] += lb_w[q] * lb_c[q][a] * lb_c[q][b];
                for (int c = 0; c < 3; c++) {
                    s3[a][b][c] += lb_w[q] * lb_c[q][a] * lb_c[q][b] * lb_c[q][c];
                }
            }
        }
    }
    CU_ASSERT_DOUBLE_EQUAL(s0, 1.0, 1e-15);
    for (int a = 0; a < 3; a++) {
        CU_ASSERT_DOUBLE_EQUAL(s1[a], 0.0, 1e-15);
        for (int b = 0; b < 3; b++) {
            CU_ASSERT_DOUBLE_EQUAL(s2[a][b], LB_CS2 * delta(a, b), 1e-15);
            for (int c = 0; c < 3; c++) {
                CU_ASSERT_DOUBLE_EQUAL(s3[a][b][c], 0.0, 1e-15);
            }
        }
    }
}

static void test_fourth_moment(void)
{
    for (int a = 0; a < 3; a++) {
        for (int b = 0; b < 3; b++) {
            for (int c = 0; c < 3; c++) {
                for (int d = 0; d < 3; d++) {
                    double s = 0.0;
                    for (int q = 0; q < LB_Q; q++) {
                        s += lb_w[q] * lb_c[q][a] * lb_c[q][b] * lb_c[q][c] * lb_c[q][d];
                    }
                    const double ref = LB_CS2 * LB_CS2 *
                                       (delta(a, b) * delta(c, d) + delta(a, c) * delta(b, d) +
                                        delta(a, d) * delta(b, c));
                    CU_ASSERT_DOUBLE_EQUAL(s, ref, 1e-15);
                }
            }
        }
    }
}

static void test_opposites_and_set(void)
{
    int seen[3][3][3] = {{{0}}};
    for (int q = 0; q < LB_Q; q++) {
        const int o = lb_opposite(q);
        CU_ASSERT_EQUAL(lb_opposite(o), q);
        CU_ASSERT_EQUAL(lb_w[o], lb_w[q]);
        for (int a = 0; a < 3; a++) {
            CU_ASSERT_EQUAL(lb_c[o][a], -lb_c[q][a]);
        }
        const int n2 = lb_c[q][0] * lb_c[q][0] + lb_c[q][1] * lb_c[q][1] + lb_c[q][2] * lb_c[q][2];
        CU_ASSERT(n2 <= 2);
        CU_ASSERT_DOUBLE_EQUAL(lb_w[q], n2 == 0 ? 1.0 / 3.0 : (n2 == 1 ? 1.0 / 18.0 : 1.0 / 36.0), 0.0);
        seen[lb_c[q][0] + 1][lb_c[q][1] + 1][lb_c[q][2] + 1]++;
        if (q >= 1 && q <= LB_HALF) {
            /* positive half: the first non-zero component is positive */
            const int first = lb_c[q][0] != 0 ? lb_c[q][0] : (lb_c[q][1] != 0 ? lb_c[q][1] : lb_c[q][2]);
            CU_ASSERT(first > 0);
        }
    }
    for (int i = 0; i < 27; i++) {
        const int x = i % 3 - 1, y = i / 3 % 3 - 1, z = i / 9 - 1;
        const int n2 = x * x + y * y + z * z;
        CU_ASSERT_EQUAL(seen[x + 1][y + 1][z + 1], n2 <= 2 ? 1 : 0);
    }
}

static void test_equilibrium_moments(void)
{
    const double rho = 1.07, u[3] = {0.03, -0.02, 0.045};
    double m0 = 0.0, m1[3] = {0}, m2[3][3] = {{0}};
    for (int q = 0; q < LB_Q; q++) {
        const double f = lb_feq(q, rho, u[0], u[1], u[2]);
        m0 += f;
        for (int a = 0; a < 3; a++) {
            m1[a] += f * lb_c[q][a];
            for (int b = 0; b < 3; b++) {
                m2[a][b] += f * lb_c[q][a] * lb_c[q][b];
            }
        }
    }
    CU_ASSERT_DOUBLE_EQUAL(m0, rho, 1e-15);
    for (int a = 0; a < 3; a++) {
        CU_ASSERT_DOUBLE_EQUAL(m1[a], rho * u[a], 1e-15);
        for (int b = 0; b < 3; b++) {
            /* Pi_eq = rho c_s^2 delta + rho u u */
            CU_ASSERT_DOUBLE_EQUAL(m2[a][b], rho * LB_CS2 * delta(a, b) + rho * u[a] * u[b], 1e-15);
        }
    }
}

void lattice_register_tests(void)
{
    CU_pSuite s = CU_add_suite("lattice", NULL, NULL);
    CU_add_test(s, "weights, first, second and third moments", test_weights_and_moments);
    CU_add_test(s, "isotropic fourth moment", test_fourth_moment);
    CU_add_test(s, "opposites, weights by speed, the full set", test_opposites_and_set);
    CU_add_test(s, "equilibrium moments (Eq. 4)", test_equilibrium_moments);
}
