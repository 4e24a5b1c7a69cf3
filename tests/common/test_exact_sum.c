/* test_exact_sum.c — common/exact_sum.h: sums that do not depend on the
 * order of their terms (the loads and totals on any threads and ranks).
 *
 * Terms are rounded once each to a multiple of 2^-88 (to nearest, ties to
 * even) and then added exactly, so: (1) any order gives the same bits;
 * (2) for terms that are multiples of 2^-88 the value is the exact sum
 * correctly rounded to a double, checked against a 128-bit integer sum;
 * (3) the rounding of a term is to nearest with ties to even. */
#include "scene_tests.h"

#include "../../common/exact_sum.h"

#include <CUnit/CUnit.h>
#include <stdint.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

__extension__ typedef __int128 i128_t;

static uint64_t rng = 88172645463325252ULL;
static uint64_t next(void)
{
    rng ^= rng << 13;
    rng ^= rng >> 7;
    rng ^= rng << 17;
    return rng;
}

/* a multiple of 2^-88 of up to 2^39 in magnitude: m 2^(e - 88), |m| < 2^40 */
static double term(int64_t *m_out, int *e_out)
{
    const int64_t m = (int64_t)(next() >> 24) - ((int64_t)1 << 39);
    const int e = (int)(next() % 88);
    *m_out = m;
    *e_out = e;
    return ldexp((double)m, e - 88);
}

static void test_order_and_exact_value(void)
{
    enum { N = 2000 };
    double v[N];
    i128_t exact = 0;
    for (int i = 0; i < N; i++) {
        int64_t m;
        int e;
        v[i] = term(&m, &e);
        exact += (i128_t)m << e; /* in units of 2^-88 */
    }
    xsum_t a, b;
    xsum_zero(&a);
    xsum_zero(&b);
    for (int i = 0; i < N; i++) {
        xsum_add(&a, v[i]);
        xsum_add(&b, v[N - 1 - i]);
    }
    /* and in a shuffled order, in two parts merged */
    xsum_t c, d;
    xsum_zero(&c);
    xsum_zero(&d);
    for (int i = 0; i < N; i++) {
        const int j = (int)((uint64_t)i * 7919u % N);
        xsum_add(j % 2 ? &c : &d, v[j]);
    }
    xsum_merge(&c, &d);
    const double va = xsum_value(&a), vb = xsum_value(&b), vc = xsum_value(&c);
    CU_ASSERT(memcmp(&va, &vb, sizeof va) == 0);
    CU_ASSERT(memcmp(&va, &vc, sizeof va) == 0);
    /* the 128-bit sum rounded once: the same double */
    CU_ASSERT_EQUAL(va, (double)exact * 0x1p-88);
    /* a naive sum in another order differs somewhere (the terms span 127
     * binades): the test would see an order-dependent sum */
    double s1 = 0.0, s2 = 0.0;
    for (int i = 0; i < N; i++) {
        s1 += v[i];
        s2 += v[N - 1 - i];
    }
    CU_ASSERT(s1 != va || s2 != va);
}

static void test_rounding_to_nearest_even(void)
{
    const double ulp = 0x1p-88;
    const double cases[][2] = {
        {0.5 * ulp, 0.0},       {1.5 * ulp, 2.0 * ulp},  {2.5 * ulp, 2.0 * ulp}, {0.75 * ulp, ulp},
        {-1.5 * ulp, -2.0 * ulp}, {-0.5 * ulp, 0.0},     {0.25 * ulp, 0.0},      {3.0 * ulp + 0.5 * ulp, 4.0 * ulp},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        xsum_t s;
        xsum_zero(&s);
        xsum_add(&s, cases[i][0]);
        CU_ASSERT_EQUAL(xsum_value(&s), cases[i][1]);
    }
    /* a term beyond the fixed-point range goes to the plain part */
    xsum_t s;
    xsum_zero(&s);
    xsum_add(&s, 0x1p45);
    xsum_add(&s, 1.0);
    CU_ASSERT_EQUAL(xsum_value(&s), 0x1p45 + 1.0);
}

void exact_sum_register_tests(void)
{
    CU_pSuite s = CU_add_suite("exact_sum", NULL, NULL);
    CU_add_test(s, "any order and any split give the same bits, the exact sum rounded once",
                test_order_and_exact_value);
    CU_add_test(s, "each term is rounded to a multiple of 2^-88, to nearest, ties to even",
                test_rounding_to_nearest_even);
}
