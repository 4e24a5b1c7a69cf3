/* refill.c — refilling uncovered cells (refill.h). */
#include "refill.h"

#include "lattice.h"

#include <math.h>

/* Interior index of X + k c_q, wrapped on periodic axes; 0 when outside. */
static int neighbour(const grid_t *g, const int periodic[3], const int X[3], int q, int k, size_t *out)
{
    int Y[3];
    for (int a = 0; a < 3; a++) {
        Y[a] = X[a] + k * lb_c[q][a];
        if (Y[a] < 1 || Y[a] > g->n[a]) {
            if (!periodic[a]) {
                return 0;
            }
            Y[a] = (Y[a] - 1 + 2 * g->n[a]) % g->n[a] + 1;
        }
    }
    *out = grid_index(g, Y[0], Y[1], Y[2]);
    return 1;
}

static void moments(const pops_t *p, size_t i, double *rho, double u[3])
{
    double j[3];
    *rho = pops_moments(p, i, j);
    for (int a = 0; a < 3; a++) {
        u[a] = j[a] / *rho;
    }
}

void refill_cell(refill_t kind, const grid_t *g, const uint8_t *flags, const int periodic[3], const pops_t *p,
                 const int X[3], const double normal[3], const double us[3], double mom[3])
{
    const size_t self = grid_index(g, X[0], X[1], X[2]);
    double rho = 0.0;
    int nrho = 0, best = -1;
    double best_cos = -2.0;
    for (int q = 1; q < LB_Q; q++) {
        size_t i;
        if (!neighbour(g, periodic, X, q, 1, &i) || flags[i] != 0) {
            continue;
        }
        double r, u[3];
        moments(p, i, &r, u);
        rho += r;
        nrho++;
        const double len = sqrt((double)(lb_c[q][0] * lb_c[q][0] + lb_c[q][1] * lb_c[q][1] + lb_c[q][2] * lb_c[q][2]));
        const double cs = (lb_c[q][0] * normal[0] + lb_c[q][1] * normal[1] + lb_c[q][2] * normal[2]) / len;
        if (cs > best_cos) {
            best_cos = cs;
            best = q;
        }
    }
    rho = nrho > 0 ? rho / nrho : 1.0;
    double neq[LB_Q] = {0.0};
    if (kind == REFILL_EXTRAPOLATION && best > 0) {
        size_t i1, i2;
        neighbour(g, periodic, X, best, 1, &i1);
        const int two = neighbour(g, periodic, X, best, 2, &i2) && flags[i2] == 0;
        double r1, u1[3], r2 = 0.0, u2[3] = {0.0, 0.0, 0.0};
        moments(p, i1, &r1, u1);
        if (two) {
            moments(p, i2, &r2, u2);
        }
        for (int q = 0; q < LB_Q; q++) {
            const double n1 = pops_post(p, q, i1) - lb_feq(q, r1, u1[0], u1[1], u1[2]);
            if (two) {
                const double n2 = pops_post(p, q, i2) - lb_feq(q, r2, u2[0], u2[1], u2[2]);
                neq[q] = 2.0 * n1 - n2;
            } else {
                neq[q] = n1;
            }
        }
    }
    mom[0] = mom[1] = mom[2] = 0.0;
    for (int q = 0; q < LB_Q; q++) {
        const double v = lb_feq(q, rho, us[0], us[1], us[2]) + neq[q];
        pops_write(p, q, pops_post_slot(p, q, self), v);
        for (int a = 0; a < 3; a++) {
            mom[a] += lb_c[q][a] * v;
        }
    }
}
