/* sangani_acrivos.h — drag of a simple cubic array of spheres in Stokes flow.
 *
 * Sangani & Acrivos, Int. J. Multiphase Flow 8 (1982) 343, Eq. 60 and
 * Table 1: K(chi) = sum_{s=0}^{30} a_s chi^s with chi = D/L, K = F/(6 pi mu a U)
 * (coefficients as in shared/reference/validation-references.md; K(0.5) = 2.84202). */
#ifndef TESTS_FLUID_SANGANI_ACRIVOS_H
#define TESTS_FLUID_SANGANI_ACRIVOS_H

static inline double sangani_acrivos(double chi)
{
    static const double a[31] = {1.000000,   1.418649,   2.012564,   2.331523,   2.564809,   2.584787,  2.873609,
                                 3.340163,   3.536763,   3.504092,   3.253622,   2.689757,   2.037769,  1.809341,
                                 1.877347,   1.534685,   0.9034708,  0.2857896,  -0.5512626, -1.278724, 1.013350,
                                 5.492491,   4.615388,   -0.5736023, -2.865924,  -4.709215,  -6.870076, 0.1455304,
                                 12.51891,   9.742811,   -5.566269};
    double k = 0.0, p = 1.0;
    for (int s = 0; s < 31; s++) {
        k += a[s] * p;
        p *= chi;
    }
    return k;
}

#endif
