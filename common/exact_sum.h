/* exact_sum.h — sums of doubles whose result does not depend on the order of
 * the terms: the same bits for any number of threads or MPI ranks.
 *
 * Each term is rounded once to a multiple of 2^-88 (an absolute error below
 * 1.7e-27, far below the rounding of a double sum of terms of 1e-10 or
 * more) and added exactly as a 128-bit fixed-point number held in four
 * signed 32-bit limbs, each accumulated in an int64_t: integer addition is
 * associative, so the order of the terms, the threads and the ranks (an
 * MPI_SUM over the limbs as MPI_INT64_T) cannot change the result. A limb
 * takes 2^31 terms before it could overflow; xsum_normalise carries the
 * limbs back into 32 bits. Terms of magnitude 2^40 or more, NaN and Inf go
 * to a plain double beside the exact part: a lattice quantity that large is
 * numerical trouble that the fluid's checks report, and the total then is
 * that trouble (Inf, NaN), not a number to trust. The idea of exact
 * fixed-point accumulation: Demmel & Nguyen, ARITH 21 (2013), "Fast
 * reproducible floating-point summation"; this is the plain version of it. */
#ifndef COMMON_EXACT_SUM_H
#define COMMON_EXACT_SUM_H

#include <math.h>
#include <stdint.h>

enum { XSUM_LIMBS = 4 };

typedef struct {
    int64_t l[XSUM_LIMBS]; /* value = sum_k l[k] 2^(32 k - 88) */
    double big;            /* terms beyond the fixed-point range */
} xsum_t;

static inline void xsum_zero(xsum_t *s)
{
    for (int k = 0; k < XSUM_LIMBS; k++) {
        s->l[k] = 0;
    }
    s->big = 0.0;
}

static inline void xsum_add(xsum_t *s, double v)
{
    if (!(fabs(v) < 0x1p40)) {
        s->big += v;
        return;
    }
    /* v 2^88 split from the top: each step removes whole multiples of the
     * limb's weight, which is exact (the difference keeps v's lower bits) */
    double u = v * 0x1p88;
    /* truncations by conversion (|u 2^-96| < 2^32: exact, and no libm call
     * on a baseline x86-64 build) */
    const int64_t i3 = (int64_t)(u * 0x1p-96);
    u -= (double)i3 * 0x1p96;
    const int64_t i2 = (int64_t)(u * 0x1p-64);
    u -= (double)i2 * 0x1p64;
    const int64_t i1 = (int64_t)(u * 0x1p-32);
    u -= (double)i1 * 0x1p32;
    s->l[3] += i3;
    s->l[2] += i2;
    s->l[1] += i1;
    /* the one rounding, to nearest even (|u| < 2^32: adding and removing
     * 1.5 2^52 rounds to an integer, as nearbyint does in the default mode) */
    s->l[0] += (int64_t)((u + 0x1.8p52) - 0x1.8p52);
}

static inline void xsum_merge(xsum_t *s, const xsum_t *o)
{
    for (int k = 0; k < XSUM_LIMBS; k++) {
        s->l[k] += o->l[k];
    }
    s->big += o->big;
}

/* Limbs 0..2 into [0, 2^32), the carry in the top limb: the same value. */
static inline void xsum_normalise(xsum_t *s)
{
    for (int k = 0; k < XSUM_LIMBS - 1; k++) {
        const int64_t carry = s->l[k] >> 32; /* floor division (arithmetic shift) */
        s->l[k] -= carry * ((int64_t)1 << 32);
        s->l[k + 1] += carry;
    }
}

/* xsum_add of the n terms v[0..n) (the same value: each term rounded once to
 * a multiple of 2^-88, to nearest, ties to even), a vector of terms at a
 * time without a conversion per term. The limbs are split by rounding to
 * nearest (x + 1.5 2^52 - 1.5 2^52, exact for |x| < 2^51) instead of
 * truncating: each split is still exact, and the pieces add up to the same
 * multiple of 2^-88 (what is left below 2^32 is rounded to an integer once,
 * and moving a value by a multiple of 2^32 does not change how it rounds).
 * The pieces, integers below 2^32 in magnitude, are summed in doubles,
 * exact while each lane holds fewer than 2^20 of them; then converted
 * once. A group with a term beyond 2^40 or NaN goes through xsum_add.
 * Integer sums: the value does not depend on the lanes. xsum_add_array2 and
 * xsum_add_array4 take two and four terms at a time; xsum_add_array four
 * where the build has 256-bit vectors (AVX), else two: a vector wider than
 * the registers went through memory at every operation (SSE2 with four
 * lanes: 38 instructions a term, callgrind). */
/* to the nearest integer, ties to even (|x| < 2^51); a macro: a function
 * returning the vector would change the ABI on a build without AVX */
#define XSUM_RN(x) (((x) + xsum_m52) - xsum_m52)
#define XSUM_FLUSH(acc, LANES)                                                                                  \
    for (int k = 0; k < XSUM_LIMBS; k++) {                                                                      \
        for (int lane = 0; lane < (LANES); lane++) {                                                            \
            s->l[k] += (int64_t)(acc)[k][lane];                                                                 \
        }                                                                                                       \
        (acc)[k] = zero;                                                                                        \
    }
#define XSUM_ADD_ARRAY(NAME, LANES)                                                                             \
    static inline void NAME(xsum_t *s, const double *v, int n)                                                  \
    {                                                                                                           \
        typedef double vec_t __attribute__((vector_size((LANES) * sizeof(double))));                            \
        const vec_t zero = {0.0};                                                                               \
        const vec_t lim = zero + 0x1p40, w96 = zero + 0x1p96, w64 = zero + 0x1p64, w32 = zero + 0x1p32,         \
                    w88 = zero + 0x1p88, xsum_m52 = zero + 0x1.8p52;                                            \
        vec_t acc[XSUM_LIMBS] = {zero, zero, zero, zero};                                                       \
        int i = 0, held = 0;                                                                                    \
        for (; i + (LANES) <= n; i += (LANES)) {                                                                \
            vec_t x;                                                                                            \
            __builtin_memcpy(&x, v + i, sizeof x);                                                              \
            const __typeof__(x < lim) in = (x < lim) & (x > -lim); /* NaN: false */                             \
            int all = 1;                                                                                        \
            for (int lane = 0; lane < (LANES); lane++) {                                                        \
                all = all && in[lane];                                                                          \
            }                                                                                                   \
            if (!all) {                                                                                         \
                for (int lane = 0; lane < (LANES); lane++) {                                                    \
                    xsum_add(s, v[i + lane]);                                                                   \
                }                                                                                               \
                continue;                                                                                       \
            }                                                                                                   \
            vec_t u = x * w88;                                                                                  \
            const vec_t i3 = XSUM_RN(u / w96);                                                                  \
            u -= i3 * w96;                                                                                      \
            const vec_t i2 = XSUM_RN(u / w64);                                                                  \
            u -= i2 * w64;                                                                                      \
            const vec_t i1 = XSUM_RN(u / w32);                                                                  \
            u -= i1 * w32;                                                                                      \
            acc[3] += i3;                                                                                       \
            acc[2] += i2;                                                                                       \
            acc[1] += i1;                                                                                       \
            acc[0] += XSUM_RN(u);                                                                               \
            if (++held == 1 << 19) {                                                                            \
                XSUM_FLUSH(acc, LANES)                                                                          \
                held = 0;                                                                                       \
            }                                                                                                   \
        }                                                                                                       \
        XSUM_FLUSH(acc, LANES)                                                                                  \
        for (; i < n; i++) {                                                                                    \
            xsum_add(s, v[i]);                                                                                  \
        }                                                                                                       \
    }
XSUM_ADD_ARRAY(xsum_add_array2, 2)
XSUM_ADD_ARRAY(xsum_add_array4, 4)
#undef XSUM_ADD_ARRAY
#undef XSUM_FLUSH

static inline void xsum_add_array(xsum_t *s, const double *v, int n)
{
#if defined(__AVX__)
    xsum_add_array4(s, v, n);
#else
    xsum_add_array2(s, v, n);
#endif
}

/* The sum rounded to a double (correctly, by the conversion of one 128-bit
 * integer): a function of the limbs only. The integer counts units of
 * 2^-88, so sums of magnitude 2^39 (5.5e11) and more wrap (far beyond the
 * totals and loads of a lattice); it is put together unsigned, where
 * wrapping is defined, and read as signed. */
__extension__ typedef __int128 xsum_i128_t;
__extension__ typedef unsigned __int128 xsum_u128_t;
static inline double xsum_value(const xsum_t *s0)
{
    xsum_t s = *s0;
    xsum_normalise(&s);
    xsum_u128_t t = (xsum_u128_t)(xsum_i128_t)s.l[3];
    for (int k = XSUM_LIMBS - 2; k >= 0; k--) {
        t = (t << 32) + (xsum_u128_t)(xsum_i128_t)s.l[k];
    }
    return (double)(xsum_i128_t)t * 0x1p-88 + s.big;
}

#endif
