/* boundary.c — coefficients of the curved-wall schemes (boundary.h). */
#include "boundary.h"

const char *const boundary_scheme_names[BOUNDARY_NSCHEMES] = {"bounce_back", "yu", "cli", "quadratic",
                                                               "multireflection"};

boundary_scheme_t boundary_coefficients(boundary_scheme_t scheme, double d, int have_ff, int have_fff,
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
