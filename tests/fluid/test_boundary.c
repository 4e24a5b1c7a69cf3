/* test_boundary.c — the curved-wall closures of fluid/boundary.h on the
 * exact steady TRT solution along one link.
 *
 * Along a link (s in units of the link, x_f at s = 0, the wall at s = delta)
 * a plane channel flow at steady state has populations polynomial in s:
 * e^+ = P0 + P1 s, e^- = G0 + G1 s + G2 s^2, the forcing S^- = Fq, and the
 * steady TRT equations (streaming along the link, collision with Guo's
 * source) give n^+ = -e^-'/omega+ and n^- = -Fq/2 + (Fq - P1 - G2 +
 * 2 G2/omega+)/omega- (solved by hand from the streaming of the pair and
 * checked against the numbers below). No-slip (or the wall moving):
 * e^-(delta) = E_w. The momentum balance of a plane channel adds
 * G2 = 3 (P1 - Fq)/(2 Lambda+). A closure is exact if it returns the
 * population the bulk solution streams in from s = 1, f~_qbar(1), from the
 * post-collision populations at s = 0, -1, -2, x_f's pre-collision
 * non-equilibrium and the wall term. MR1 must be exact for any P1, G2, Fq
 * (Ginzburg, Verhaeghe & d'Humieres 2008), with or without the balance and
 * the wall moving; CLI, Yu and Bouzidi's quadratic scheme are not exact even
 * with the balance (away from delta = 1/2, where CLI is bounce-back). */
#include "fluid_tests.h"

#include "../../fluid/boundary.h"
#include "../../fluid/kernel.h"

#include <CUnit/CUnit.h>
#include <math.h>
#include <stdio.h>

typedef struct {
    double P0, P1, G0, G1, G2, Fq, wp, wm;
} link_flow_t;

static double n_plus(const link_flow_t *f, double s) { return -(f->G1 + 2.0 * f->G2 * s) / f->wp; }

static double n_minus(const link_flow_t *f)
{
    return -0.5 * f->Fq + (f->Fq - f->P1 - f->G2 + 2.0 * f->G2 / f->wp) / f->wm;
}

/* post-collision f~_q (sign +1) or f~_qbar (sign -1) at s */
static double post(const link_flow_t *f, int sign, double s)
{
    const double ep = f->P0 + f->P1 * s, em = f->G0 + f->G1 * s + f->G2 * s * s;
    return ep + (1.0 - f->wp) * n_plus(f, s) + sign * (em + (1.0 - f->wm) * n_minus(f) + (1.0 - 0.5 * f->wm) * f->Fq);
}

/* |closure - exact| for a scheme on the flow, the wall moving with E_w */
static double closure_error(boundary_scheme_t scheme, const link_flow_t *f, double delta, double Ew)
{
    boundary_coef_t c;
    boundary_coefficients(scheme, delta, 1, 1, f->wm, &c);
    const double A = c.a[0] + c.a[1] + c.a[2];
    double v = -2.0 * A * Ew;
    for (int k = 0; k < 3; k++) {
        v += c.a[k] * post(f, 1, -k);
    }
    for (int k = 0; k < 2; k++) {
        v += c.b[k] * post(f, -1, -k);
    }
    /* x_f's pre-collision n^- against j - F (spheres.c) is n^- + Fq/2 */
    v += c.corr * (n_minus(f) + 0.5 * f->Fq);
    return fabs(v - post(f, -1, 1.0));
}

/* a flow on the link: balanced (plane channel) or with G2 free; k varies
 * the other coefficients */
static link_flow_t link_flow(double tau, double magic, double delta, double Ew, int balanced, unsigned k)
{
    link_flow_t f;
    f.wp = 1.0 / tau;
    f.wm = kernel_omega_minus(f.wp, magic);
    f.P0 = 0.05 + 0.01 * (k % 3);
    f.P1 = 1e-4 * (1.0 + (k % 5));
    f.Fq = -2e-4 * (1.0 + (k % 7)) / 7.0;
    f.G1 = 3e-3 * (1.0 - 0.3 * (k % 4));
    const double Lp = tau - 0.5;
    f.G2 = balanced ? 3.0 * (f.P1 - f.Fq) / (2.0 * Lp) : 7e-4 * (1.0 + (k % 3));
    f.G0 = Ew - f.G1 * delta - f.G2 * delta * delta;
    return f;
}

static void test_exact_on_links(void)
{
    const double taus[] = {0.52, 0.6, 0.8, 1.0, 1.5, 3.0};
    const double magics[] = {1.0 / 12.0, 3.0 / 16.0, 0.25, 1.0};
    const boundary_scheme_t others[] = {BOUNDARY_CLI, BOUNDARY_YU, BOUNDARY_QUADRATIC};
    double worst_mr = 0.0, least[3] = {1.0, 1.0, 1.0};
    unsigned k = 0;
    for (int t = 0; t < 6; t++) {
        for (int m = 0; m < 4; m++) {
            for (int i = 0; i <= 20; i++, k++) {
                const double delta = i == 0 ? 1e-6 : i / 20.0, Ew = (k % 2) ? 2e-3 : 0.0;
                for (int bal = 0; bal < 2; bal++) {
                    const link_flow_t f = link_flow(taus[t], magics[m], delta, Ew, bal, k);
                    worst_mr = fmax(worst_mr, closure_error(BOUNDARY_MULTIREFLECTION, &f, delta, Ew));
                    for (int s = 0; s < 3; s++) {
                        if (bal && fabs(delta - 0.5) > 0.2) {
                            least[s] = fmin(least[s], closure_error(others[s], &f, delta, Ew));
                        }
                    }
                }
            }
        }
    }
    printf("\n    closure error on exact links (populations ~0.05): MR1 %.1e; on plane channels at least: "
           "cli %.1e, yu %.1e, quadratic %.1e ",
           worst_mr, least[0], least[1], least[2]);
    CU_ASSERT(worst_mr < 1e-15);
    for (int s = 0; s < 3; s++) {
        CU_ASSERT(least[s] > 1e-7);
    }
}

void boundary_register_tests(void)
{
    CU_pSuite s = CU_add_suite("boundary", NULL, NULL);
    CU_add_test(s, "closures on the exact steady TRT link: MR1 exact for any flow, cli, yu, quadratic not",
                test_exact_on_links);
}
