/* boundary.h — interpolated bounce-back schemes for curved walls as
 * coefficient sets.
 *
 * Every scheme here is linear in post-collision populations along the link
 * direction q (pointing from the fluid cell x_f into the solid):
 *   f_qbar(x_f, t+1) = sum_k a_k f~_q(x_f - k c_q) + sum_k b_k f~_qbar(x_f - k c_q)
 *                      - A 6 w_q rho_w c_q.u_w,      A = a_0 + a_1 + a_2,
 * and the moving-wall term follows from requiring that a uniform flow moving
 * with the wall is reproduced exactly (it gives Ladd's term for bounce-back,
 * Eq. 6's term for Yu, 4/(1+2 delta) for CLI, and Lallemand & Luo's for
 * Bouzidi). Schemes:
 *   bounce_back  a0 = 1 (Ladd 1994)
 *   yu           Yu, Mei & Shyy (2003), the paper's Eq. 6:
 *                a0 = b0 = delta/(1+delta), a1 = (1-delta)/(1+delta)
 *   cli          central linear interpolation, Ginzburg, Verhaeghe &
 *                d'Humieres, Commun. Comput. Phys. 3 (2008) 427, Eq. 4.1,
 *                Table 3: a0 = 1, a1 = k0, b0 = -k0, k0 = (1-2 delta)/(1+2 delta)
 *   quadratic    Bouzidi, Firdaouss & Lallemand, Phys. Fluids 13 (2001) 3452:
 *                delta < 1/2: a0 = delta(1+2 delta), a1 = 1-4 delta^2,
 *                             a2 = -delta(1-2 delta)
 *                delta >= 1/2: a0 = 1/(delta(2 delta+1)), b0 = (2 delta-1)/delta,
 *                             b1 = -(2 delta-1)/(2 delta+1)
 *   multireflection  MR1 of Ginzburg, Verhaeghe & d'Humieres (2008), Table 3
 *                with c = (1+delta)^2: a0 = 1, a1 = k0, a2 = k_1, b0 = -k0, b1 = -k_1,
 *                k0 = (1 - 2 delta - 2 delta^2)/c, k_1 = delta^2/c, plus the
 *                post-collision correction of their Eq. 5.7,
 *                -alpha (1 - w-/2) n_q^-, alpha = 4/c, n_q^- the antisymmetric
 *                non-equilibrium part of the pre-collision populations at x_f,
 *                taken against their own momentum (with Guo forcing: j - F,
 *                spheres.c); it makes the scheme exact for parabolic profiles
 *                with TRT at any delta and Lambda (1D channel, issue 11).
 *                The MYLI fall-back below is not exact (its factor would
 *                depend on delta); it is used only next to other solids.
 *                With only x_f - c_q fluid: MYLI (Yu's coefficients plus the
 *                correction -alpha w-/2 n_q^-, alpha = 2/(1+delta), Eq. 5.5).
 * MR1 is the only closure of this five-population form with an n^- correction
 * that is exact for every parabolic flow (with Guo forcing; tests/fluid/
 * test_boundary.c checks it on the exact steady TRT solution along a link).
 * Closures exact only for plane channel flows (closed with the channel's
 * momentum balance, a 1/Lambda+ term) were derived and measured for issue 11
 * and not kept: unstable at tau 0.6, and 2% low on a radius-4 sphere
 * (README "Drag at any position in the cell").
 * Where a scheme needs a fluid node that is missing (x_f - c_q or
 * x_f - 2 c_q solid or outside), the next simpler scheme is used:
 * quadratic -> cli -> bounce_back, multireflection -> MYLI -> bounce_back,
 * yu -> bounce_back. */
#ifndef FLUID_BOUNDARY_H
#define FLUID_BOUNDARY_H

#include "../common/scene.h"

/* The schemes, in the order of boundary_scheme_t, by their scene names. */
#define BOUNDARY_NSCHEMES 5
extern const char *const boundary_scheme_names[BOUNDARY_NSCHEMES];

/* The coefficients of one link. */
typedef struct {
    double a[3], b[2];
    double corr; /* factor of n_q^- of x_f's pre-collision populations (against j - F) */
} boundary_coef_t;

/* The coefficients of a link at distance delta (in units of the link) from
 * the wall; have_ff / have_fff: x_f - c_q / x_f - 2 c_q are fluid;
 * omega_minus the odd relaxation rate. Returns the scheme actually used.
 * Inline: the fill derives each link's coefficients as it goes (spheres.h
 * sphere_link_t), with the scheme the same for every link. */
static inline boundary_scheme_t boundary_coefficients(boundary_scheme_t scheme, double d, int have_ff, int have_fff,
                                                       double omega_minus, boundary_coef_t *c)
{
    double *a = c->a, *b = c->b;
    a[0] = a[1] = a[2] = b[0] = b[1] = 0.0;
    c->corr = 0.0;
    if (scheme == BOUNDARY_MULTIREFLECTION) {
        if (have_ff && have_fff) {
            const double cc = (1.0 + d) * (1.0 + d);
            const double k0 = (1.0 - 2.0 * d - 2.0 * d * d) / cc, km1 = d * d / cc;
            a[0] = 1.0;
            a[1] = k0;
            a[2] = km1;
            b[0] = -k0;
            b[1] = -km1;
            c->corr = -(4.0 / cc) * (1.0 - 0.5 * omega_minus);
            return BOUNDARY_MULTIREFLECTION;
        }
        if (have_ff) {
            a[0] = b[0] = d / (1.0 + d);
            a[1] = (1.0 - d) / (1.0 + d);
            c->corr = -(2.0 / (1.0 + d)) * 0.5 * omega_minus;
            return BOUNDARY_MULTIREFLECTION;
        }
        scheme = BOUNDARY_BOUNCE_BACK;
    }
    if (scheme == BOUNDARY_QUADRATIC) {
        if (d < 0.5 && have_ff && have_fff) {
            a[0] = d * (1.0 + 2.0 * d);
            a[1] = 1.0 - 4.0 * d * d;
            a[2] = -d * (1.0 - 2.0 * d);
            return BOUNDARY_QUADRATIC;
        }
        if (d >= 0.5 && have_ff) {
            a[0] = 1.0 / (d * (2.0 * d + 1.0));
            b[0] = (2.0 * d - 1.0) / d;
            b[1] = -(2.0 * d - 1.0) / (2.0 * d + 1.0);
            return BOUNDARY_QUADRATIC;
        }
        scheme = BOUNDARY_CLI;
    }
    if (scheme == BOUNDARY_CLI && have_ff) {
        const double k0 = (1.0 - 2.0 * d) / (1.0 + 2.0 * d);
        a[0] = 1.0;
        a[1] = k0;
        b[0] = -k0;
        return BOUNDARY_CLI;
    }
    if (scheme == BOUNDARY_YU && have_ff) {
        a[0] = b[0] = d / (1.0 + d);
        a[1] = (1.0 - d) / (1.0 + d);
        return BOUNDARY_YU;
    }
    a[0] = 1.0;
    return BOUNDARY_BOUNCE_BACK;
}

#endif
