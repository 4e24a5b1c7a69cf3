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
__extension__ typedef unsigned __int128 u128_t;

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
    /* in units of 2^-88, modulo 2^128 (unsigned: wrapping is defined; a
     * term can reach 2^127, the sum fits): the signed value at the end */
    u128_t wrapped = 0;
    for (int i = 0; i < N; i++) {
        int64_t m;
        int e;
        v[i] = term(&m, &e);
        wrapped += (u128_t)(i128_t)m << e;
    }
    const i128_t exact = (i128_t)wrapped;
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

/* any double of up to 2^45 in magnitude, most within the fixed-point range,
 * some below 2^-88 (rounded away or to 2^-88), some beyond 2^40 */
static double any_term(void)
{
    const double m = (double)(int64_t)(next() >> 11) * 0x1p-53; /* in [0, 1) */
    const int e = (int)(next() % 140) - 95;
    return ldexp(2.0 * m - 1.0, e);
}

static int same_sum(const xsum_t *a0, const xsum_t *b0)
{
    xsum_t a = *a0, b = *b0;
    xsum_normalise(&a);
    xsum_normalise(&b);
    return memcmp(a.l, b.l, sizeof a.l) == 0 && (a.big == b.big || (isnan(a.big) && isnan(b.big)));
}

/* xsum_add of v[0..n) one term at a time and xsum_add_array2,
 * xsum_add_array4 and xsum_add_array of the same: 1 when all their limbs
 * (normalised) and plain parts agree */
static int array_matches(const double *v, int n)
{
    void (*const arrays[3])(xsum_t *, const double *, int) = {xsum_add_array2, xsum_add_array4, xsum_add_array};
    xsum_t a;
    xsum_zero(&a);
    for (int i = 0; i < n; i++) {
        xsum_add(&a, v[i]);
    }
    int same = 1;
    for (int k = 0; k < 3; k++) {
        xsum_t b;
        xsum_zero(&b);
        arrays[k](&b, v, n);
        same = same && same_sum(&a, &b);
    }
    return same;
}

/* xsum_add_array (two and four lanes) is xsum_add term by term: the same
 * limbs, also for ties at 2^-89 (rounded to even), terms beyond 2^40 and
 * NaN, and lengths that are no multiple of the lanes; and over more terms
 * than its lanes hold before a flush */
static void test_array_equals_term_by_term(void)
{
    enum { N = 1100000 };
    static double v[N];
    const int lengths[] = {0, 1, 3, 4, 7, 64, 1001, N};
    for (size_t k = 0; k < sizeof lengths / sizeof lengths[0]; k++) {
        const int n = lengths[k];
        for (int i = 0; i < n; i++) {
            v[i] = any_term();
        }
        if (n >= 64) {
            v[5] = 0x1p-89;       /* a tie: to 0 */
            v[6] = 3.0 * 0x1p-89; /* a tie: to 2^-87 */
            v[9] = 0x1p41;        /* beyond the fixed-point range */
            v[n - 2] = -0x1.fffffffffffffp39;
        }
        CU_ASSERT(array_matches(v, n));
    }
    /* large terms all of one sign: the most a lane's limbs reach */
    for (int i = 0; i < N; i++) {
        v[i] = 0x1.fffffffffffffp39;
    }
    CU_ASSERT(array_matches(v, N));
    /* NaN in a group: the sum is NaN both ways */
    v[2] = NAN;
    CU_ASSERT(array_matches(v, 8));
    xsum_t b;
    xsum_zero(&b);
    xsum_add_array(&b, v, 8);
    CU_ASSERT(isnan(xsum_value(&b)));
}

void exact_sum_register_tests(void)
{
    CU_pSuite s = CU_add_suite("exact_sum", NULL, NULL);
    CU_add_test(s, "any order and any split give the same bits, the exact sum rounded once",
                test_order_and_exact_value);
    CU_add_test(s, "each term is rounded to a multiple of 2^-88, to nearest, ties to even",
                test_rounding_to_nearest_even);
    CU_add_test(s, "two or four terms at a time (xsum_add_array) give the limbs of one at a time",
                test_array_equals_term_by_term);
}
