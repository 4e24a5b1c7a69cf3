/* lattice.h — the D3Q19 velocity set.
 *
 * Direction 0 is at rest; directions 1..9 are the positive half of the set
 * (first non-zero component positive) and 10..18 their opposites, so that
 * the opposite of q is q+9 for 1 <= q <= 9 and q-9 for q >= 10 (a rule, not a
 * table lookup). Weights: 1/3 (rest), 1/18 (axis), 1/36 (face diagonals);
 * lattice speed of sound c_s^2 = 1/3. Reference: Qian, d'Humieres & Lallemand,
 * Europhys. Lett. 17 (1992) 479. The identities sum w = 1, sum w c = 0,
 * sum w c_a c_b = c_s^2 delta_ab are asserted in tests/fluid/test_lattice.c. */
#ifndef FLUID_LATTICE_H
#define FLUID_LATTICE_H

#include <stddef.h>

#define LB_Q 19
#define LB_HALF 9
#define LB_CS2 (1.0 / 3.0)

/* The tables themselves, not only their declarations: with the values known
 * at compile time a loop over q unrolled by the compiler has c_q as
 * literals (scan.c sums without products by 0). Each file that uses them
 * has its own copy of 19 x 3 ints and 19 doubles. */
static const int lb_c[LB_Q][3] = {
    {0, 0, 0},
    {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 0}, {1, -1, 0}, {1, 0, 1}, {1, 0, -1}, {0, 1, 1}, {0, 1, -1},
    {-1, 0, 0}, {0, -1, 0}, {0, 0, -1}, {-1, -1, 0}, {-1, 1, 0}, {-1, 0, -1}, {-1, 0, 1}, {0, -1, -1}, {0, -1, 1},
};

/* c_q as doubles: the same values, without a conversion per use where a
 * loop reads them by a q known only at run time (sphere_fill.c) */
static const double lb_cd[LB_Q][3] = {
    {0, 0, 0},
    {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 0}, {1, -1, 0}, {1, 0, 1}, {1, 0, -1}, {0, 1, 1}, {0, 1, -1},
    {-1, 0, 0}, {0, -1, 0}, {0, 0, -1}, {-1, -1, 0}, {-1, 1, 0}, {-1, 0, -1}, {-1, 0, 1}, {0, -1, -1}, {0, -1, 1},
};
/* |c_q|^2 */
static const double lb_cc[LB_Q] = {0, 1, 1, 1, 2, 2, 2, 2, 2, 2, 1, 1, 1, 2, 2, 2, 2, 2, 2};

static const double lb_w[LB_Q] = {
    1.0 / 3.0,
    1.0 / 18.0, 1.0 / 18.0, 1.0 / 18.0, 1.0 / 36.0, 1.0 / 36.0, 1.0 / 36.0, 1.0 / 36.0, 1.0 / 36.0, 1.0 / 36.0,
    1.0 / 18.0, 1.0 / 18.0, 1.0 / 18.0, 1.0 / 36.0, 1.0 / 36.0, 1.0 / 36.0, 1.0 / 36.0, 1.0 / 36.0, 1.0 / 36.0,
};

/* The opposite direction, from a table rather than two comparisons (the
 * fill asks it for a q that varies from one link to the next: 4% fewer
 * instructions there, callgrind); a q known at compile time folds to a
 * constant. */
static const unsigned char lb_opp[LB_Q] = {0, 10, 11, 12, 13, 14, 15, 16, 17, 18, 1, 2, 3, 4, 5, 6, 7, 8, 9};

static inline int lb_opposite(int q) { return lb_opp[q]; }

/* The direction whose velocity is c (0, the rest direction, for none). */
static inline int lb_direction(const int c[3])
{
    for (int q = 1; q < LB_Q; q++) {
        if (lb_c[q][0] == c[0] && lb_c[q][1] == c[1] && lb_c[q][2] == c[2]) {
            return q;
        }
    }
    return 0;
}

/* The directions with component dir (+1 or -1) along axis a, in q order:
 * the 5 that cross a face of a cell. Returns how many. */
static inline int lb_crossing(int a, int dir, int qs[5])
{
    int nq = 0;
    for (int q = 1; q < LB_Q; q++) {
        if (lb_c[q][a] == dir) {
            qs[nq++] = q;
        }
    }
    return nq;
}

/* s += k v for a velocity component k of the table (-1, 0 or 1): a
 * subtraction, nothing or an addition once a loop over q is unrolled (k a
 * literal then). The same value as s += k v for every s but -0: a product by
 * 0 stays in the code without -ffast-math (0 v may be -0 or NaN), and adding
 * it changes no sum that starts at +0 (such a sum is never -0). */
#define LB_ADD(s, k, v) ((k) > 0 ? (void)((s) += (v)) : (k) < 0 ? (void)((s) -= (v)) : (void)0)

/* Second-order equilibrium (the paper's Eq. 4 with c = 1). */
static inline double lb_feq(int q, double rho, double ux, double uy, double uz)
{
    const double cu = lb_c[q][0] * ux + lb_c[q][1] * uy + lb_c[q][2] * uz;
    const double uu = ux * ux + uy * uy + uz * uz;
    return lb_w[q] * rho * (1.0 + 3.0 * cu + 4.5 * cu * cu - 1.5 * uu);
}

#endif
