/* kernel.c — fused pull stream–collide, TRT/BGK with Guo forcing, D3Q19.
 *
 * Data: structure-of-arrays populations (grid.h, layout.h), collided in a
 * branch-free loop the compiler vectorises. Two arrays in double: every
 * interior row is cut into blocks of KERNEL_BLOCK cells, a block is pulled
 * and collided into a small buffer that stays in L1, then the buffer goes to
 * dst with non-temporal stores, so that dst costs no read-for-ownership. In
 * place (and two arrays in single precision): the results go straight to the
 * array. Either way 19 loads and 19 stores of a value per cell update, the
 * minimum.
 *
 * Collision (TRT, Ginzburg 2005; BGK when omega_minus == omega_plus), for each
 * pair (q, qbar) with f± = (f_q ± f_qbar)/2:
 *   f±' = f± - w±(f± - feq±) + (1 - w±/2) S±
 * Guo, Zheng & Shi, Phys. Rev. E 65 (2002) 046308, forcing:
 *   S_q = w_q [3 (c_q - u).F + 9 (c_q.u)(c_q.F)],  u = (sum c f + F/2)/rho;
 * its antisymmetric part 3 w c.F is constant for a uniform force.
 * The direction numbering is the one of lattice.h (q and q+9 opposite).
 *
 * The arithmetic is laid out for a core that waits on dependencies, not on
 * memory (one thread ran as fast with the grid in L3 as in memory): the
 * density is a pairwise sum of f_0 and the nine sums s_k = f_k + f_kbar (a
 * tree four additions deep, where the sum left to right was a chain of 18
 * that the division waited on), and each pair relaxes as
 *   n+ = (1 - w+)/2 s_k + w+ e+,  n- = (1 - w-)/2 d_k + w- e-
 * with d_k = f_k - f_kbar and w+ e+ = w+ W rho (1 - 1.5 u^2) + 4.5 w+ W rho
 * (c.u)^2, w- e- = 3 w- W rho c.u, whose factors are computed once per cell
 * for each of the two weights W: 11 operations per pair instead of 17. The
 * same relaxation as f± - w±(f± - feq±), rounded differently (results move
 * by round-off only: README "Speed and memory"). No multiply-add is fused
 * (-ffp-contract=off under -std=c11): the baseline and the AVX2 variants of
 * the FMU give the same bits. */
#include "kernel.h"

#include "lattice.h"

#include <stdint.h>
#if defined(__SSE2__)
#include <immintrin.h>
#endif

#define KERNEL_BLOCK 64
#define KERNEL_ROW 1024 /* in place: cells per call of collide_block (no buffer) */

/* KERNEL_VARIANT (the FMU build, Makefile): this file is compiled once for
 * the x86-64 baseline and once for x86-64-v3 (AVX2, FMA) under the names
 * kernel_stream_collide_base / _v3, and kernel_dispatch.c picks one at run
 * time (the baseline compile, KERNEL_PRIMARY, also defines
 * kernel_omega_minus); without it (build/coupler, tests: -march=native) it
 * defines kernel_stream_collide and kernel_omega_minus itself. */
/* KERNEL_SINGLE (kernel_single.c includes this file): populations stored
 * as float, shifted by their weight (f_q - w_q, Lehmann et al., Phys. Rev. E
 * 106 (2022) 015308: the stored numbers are the small deviations from rest,
 * so float keeps ~7 digits of them instead of ~7 of f); the arithmetic stays
 * in double. Names get _f32. */
#if defined(KERNEL_SINGLE)
typedef float real_t;
#define KERNEL_BASE_NAME(n) n##_f32
#else
typedef double real_t;
#define KERNEL_BASE_NAME(n) n
#endif
#define KERNEL_CAT2(a, b) a##_##b
#define KERNEL_CAT(a, b) KERNEL_CAT2(a, b)
#if defined(KERNEL_VARIANT)
#define KERNEL_ENTRY KERNEL_CAT(KERNEL_BASE_NAME(kernel_stream_collide), KERNEL_VARIANT)
#define KERNEL_IN_PLACE KERNEL_CAT(KERNEL_BASE_NAME(kernel_in_place), KERNEL_VARIANT)
#else
#define KERNEL_ENTRY KERNEL_BASE_NAME(kernel_stream_collide)
#define KERNEL_IN_PLACE KERNEL_BASE_NAME(kernel_in_place)
#endif
void KERNEL_ENTRY(const grid_t *g, const kernel_params_t *p, const real_t *restrict src, real_t *restrict dst,
                  const kernel_box_t *box);
void KERNEL_IN_PLACE(const grid_t *g, const kernel_params_t *p, real_t *f, int push, const kernel_box_t *box);

#if (!defined(KERNEL_VARIANT) || defined(KERNEL_PRIMARY)) && !defined(KERNEL_SINGLE)
double kernel_omega_minus(double omega_plus, double magic)
{
    const double a = 1.0 / omega_plus - 0.5;
    return 1.0 / (magic / a + 0.5);
}
#endif

typedef struct {
    double wp, wm, gp;  /* omega_plus, omega_minus, 1 - omega_plus/2 */
    double fx, fy, fz;  /* body force */
    double sm[10];      /* (1 - omega_minus/2) 3 w_q c_q.F for q = 1..9 */
} consts_t;

/* One pair of opposite directions k (positive) and k+9, velocity (A,B,C),
 * weight W, PA = w+ W rho (1 - 1.5 u^2) (shifted: SHIFT), PB = 4.5 w+ W rho,
 * PC = 3 w- W rho: collide, write both to the block buffer. CU is c.u
 * written out for that velocity (ux - uy for (1,-1,0)): the same value as
 * A ux + B uy + C uz, without the products by 0 that the compiler must
 * keep (0 x may be -0 or NaN). Without a body force the forcing terms are
 * left out altogether, not added as zeros: the same values (x + 0 = x) in
 * some 100 fewer instructions per four cells. */
#define PAIR(k, A, B, C, CU, W, PA, PB, PC)                                        \
    do {                                                                           \
        const double cu = (CU);                                                    \
        double np = hp * s##k + (PA + PB * (cu * cu)), nm = hm * d##k + PC * cu;   \
        if (forced) { /* the same additions, left to right, as one expression */   \
            const double cf = (A) * fx + (B) * fy + (C) * fz;                      \
            np += gp * (W) * (9.0 * cu * cf - uf3);                                \
            nm += k_->sm[k];                                                       \
        }                                                                          \
        if (direct == 2) {                                                         \
            OWN(fb##k, W, np + nm);                                                \
            OWN(f##k, W, np - nm);                                                 \
        } else {                                                                   \
            PUT(k, W, np + nm);                                                    \
            PUT(k + 9, W, np - nm);                                                \
        }                                                                          \
    } while (0)

/* V(name): the population of the block row name at x, as a double. With
 * single-precision storage a row holds f_q - w_q (README "Speed and memory"),
 * and the collision works on those deviations throughout: the density is
 * 1 + their sum, the equilibria enter shifted by their weight (SHIFT), and
 * the results are stored as they come out. The coefficients of n+ sum to 1,
 * so the same shift on both sides leaves it unchanged: n+ - w = (1 - w+)/2
 * (s_k - 2w) + w+ (e+ - w); n- and the forcing terms carry no shift. The
 * weight is thus added and subtracted once per pair instead of
 * once per population on the way in and again on the way out. In double the
 * macros leave every expression as it was. */
#if defined(KERNEL_SINGLE)
#define V(name) ((double)(name)[x])
#define SHIFT(e, w) ((e) - (w))
#define RHO(sum) (1.0 + (sum))
#else
#define V(name) ((name)[x])
#define SHIFT(e, w) (e)
#define RHO(sum) (sum)
#endif

/* always inlined: its vector code must stay inside the entry points of this
 * variant (kernel_dispatch.c; tests/python/test_fmu.py checks the FMU) */
/* direct = 0: results to the block buffer buf (as double); direct = 1:
 * straight to the rows out[q]; direct = 2 (in place, out unused): each
 * result to the row its opposite direction came from, out[q] = in[qbar]
 * in either in-place step (layout.h), through the same 19 pointers (with
 * 38 the loop kept reloading them from the stack). forced = 0:
 * no body force (the forcing terms vanish at compile time). Both are
 * constants at every call, so each call compiles to its own loop. */
static inline __attribute__((always_inline)) void collide_block(const consts_t *restrict k_, const real_t *const in[LB_Q], int nb,
                          double (*restrict buf)[KERNEL_BLOCK], real_t *const out[LB_Q], int direct,
                          int forced)
{
#if defined(KERNEL_SINGLE)
/* val is already the deviation f - w (SHIFT above); the block buffer, which
 * the single-precision kernels do not use, would hold whole values */
#define OWN(row, w, val) ((row)[x] = (float)(val))
#define PUT(q, w, val)                                    \
    do {                                                  \
        if (direct) {                                     \
            out[q][x] = (float)(val);                     \
        } else {                                          \
            buf[q][x] = (val) + (w);                      \
        }                                                 \
    } while (0)
#else
#define OWN(row, w, val) ((row)[x] = (val))
#define PUT(q, w, val)                                    \
    do {                                                  \
        if (direct) {                                     \
            out[q][x] = (val);                            \
        } else {                                          \
            buf[q][x] = (val);                            \
        }                                                 \
    } while (0)
#endif
    const double fx = forced ? k_->fx : 0.0, fy = forced ? k_->fy : 0.0, fz = forced ? k_->fz : 0.0;
#define PTR(name, q) real_t *restrict name = (real_t *)in[q]
    PTR(f0, 0);
    PTR(f1, 1);
    PTR(f2, 2);
    PTR(f3, 3);
    PTR(f4, 4);
    PTR(f5, 5);
    PTR(f6, 6);
    PTR(f7, 7);
    PTR(f8, 8);
    PTR(f9, 9);
    PTR(fb1, 10);
    PTR(fb2, 11);
    PTR(fb3, 12);
    PTR(fb4, 13);
    PTR(fb5, 14);
    PTR(fb6, 15);
    PTR(fb7, 16);
    PTR(fb8, 17);
    PTR(fb9, 18);
#undef PTR
    const double wp = k_->wp, wm = k_->wm, gp = k_->gp;
    const double hp = 0.5 * (1.0 - wp), hm = 0.5 * (1.0 - wm), wp45 = 4.5 * wp, wm3 = 3.0 * wm;
#pragma omp simd
    for (int x = 0; x < nb; x++) {
        /* differences of opposite pairs need no shift (equal weights) */
        const double d1 = (double)f1[x] - fb1[x], d2 = (double)f2[x] - fb2[x], d3 = (double)f3[x] - fb3[x];
        const double d4 = (double)f4[x] - fb4[x], d5 = (double)f5[x] - fb5[x], d6 = (double)f6[x] - fb6[x];
        const double d7 = (double)f7[x] - fb7[x], d8 = (double)f8[x] - fb8[x], d9 = (double)f9[x] - fb9[x];
        const double s1 = V(f1) + V(fb1), s2 = V(f2) + V(fb2), s3 = V(f3) + V(fb3);
        const double s4 = V(f4) + V(fb4), s5 = V(f5) + V(fb5), s6 = V(f6) + V(fb6);
        const double s7 = V(f7) + V(fb7), s8 = V(f8) + V(fb8), s9 = V(f9) + V(fb9);
        const double rho = RHO(((V(f0) + s1) + (s2 + s3)) + (((s4 + s5) + (s6 + s7)) + (s8 + s9)));
        const double jx = (d1 + d4) + (d5 + (d6 + d7));
        const double jy = (d2 + d4) + ((d8 + d9) - d5);
        const double jz = (d3 + d6) + ((d8 - d9) - d7);
        const double inv = 1.0 / rho;
        const double ux = forced ? (jx + 0.5 * fx) * inv : jx * inv;
        const double uy = forced ? (jy + 0.5 * fy) * inv : jy * inv;
        const double uz = forced ? (jz + 0.5 * fz) * inv : jz * inv;
        const double usq15 = 1.5 * (ux * ux + uy * uy + uz * uz);
        const double uf3 = forced ? 3.0 * (ux * fx + uy * fy + uz * fz) : 0.0;
        const double a = 1.0 - usq15, r18 = (1.0 / 18.0) * rho, r36 = (1.0 / 36.0) * rho;
        const double pa18 = wp * SHIFT(r18 * a, 1.0 / 18.0), pb18 = wp45 * r18, pc18 = wm3 * r18;
        const double pa36 = wp * SHIFT(r36 * a, 1.0 / 36.0), pb36 = wp45 * r36, pc36 = wm3 * r36;
        const double eq0 = SHIFT((1.0 / 3.0) * rho * a, 1.0 / 3.0);
        double n0 = V(f0) - wp * (V(f0) - eq0);
        if (forced) {
            n0 -= gp * (1.0 / 3.0) * uf3;
        }
        if (direct == 2) {
            OWN(f0, 1.0 / 3.0, n0);
        } else {
            PUT(0, 1.0 / 3.0, n0);
        }
        PAIR(1, 1, 0, 0, ux, 1.0 / 18.0, pa18, pb18, pc18);
        PAIR(2, 0, 1, 0, uy, 1.0 / 18.0, pa18, pb18, pc18);
        PAIR(3, 0, 0, 1, uz, 1.0 / 18.0, pa18, pb18, pc18);
        PAIR(4, 1, 1, 0, ux + uy, 1.0 / 36.0, pa36, pb36, pc36);
        PAIR(5, 1, -1, 0, ux - uy, 1.0 / 36.0, pa36, pb36, pc36);
        PAIR(6, 1, 0, 1, ux + uz, 1.0 / 36.0, pa36, pb36, pc36);
        PAIR(7, 1, 0, -1, ux - uz, 1.0 / 36.0, pa36, pb36, pc36);
        PAIR(8, 0, 1, 1, uy + uz, 1.0 / 36.0, pa36, pb36, pc36);
        PAIR(9, 0, 1, -1, uy - uz, 1.0 / 36.0, pa36, pb36, pc36);
    }
}
#undef PAIR
#undef PUT
#undef OWN
#undef V
#undef SHIFT
#undef RHO

#if !defined(KERNEL_SINGLE)
/* Copies the block buffer to dst. With SSE2/AVX the stores are non-temporal:
 * dst rows are 64-byte aligned and nb is a multiple of GRID_ALIGN (grid.h). */
static inline __attribute__((always_inline)) void store_block_nt(double *restrict dst, size_t ncells, size_t base, int nb,
                           double (*restrict buf)[KERNEL_BLOCK])
{
    for (int q = 0; q < LB_Q; q++) {
        double *restrict d = dst + (size_t)q * ncells + base;
#if defined(__AVX__)
        for (int x = 0; x < nb; x += 4) {
            _mm256_stream_pd(d + x, _mm256_load_pd(&buf[q][x]));
        }
#elif defined(__SSE2__)
        for (int x = 0; x < nb; x += 2) {
            _mm_stream_pd(d + x, _mm_load_pd(&buf[q][x]));
        }
#else
        for (int x = 0; x < nb; x++) {
            d[x] = buf[q][x];
        }
#endif
    }
}

#endif

static inline __attribute__((always_inline)) void kernel_consts(const kernel_params_t *p, consts_t *k)
{
    k->wp = p->omega_plus;
    k->wm = p->omega_minus;
    k->gp = 1.0 - 0.5 * p->omega_plus;
    k->fx = p->force[0];
    k->fy = p->force[1];
    k->fz = p->force[2];
    k->sm[0] = 0.0;
    for (int q = 1; q <= LB_HALF; q++) {
        const double cf = lb_c[q][0] * k->fx + lb_c[q][1] * k->fy + lb_c[q][2] * k->fz;
        k->sm[q] = (1.0 - 0.5 * p->omega_minus) * 3.0 * lb_w[q] * cf;
    }
}

/* The box to update: all interior cells without one; false when it is empty. */
static inline int kernel_range(const grid_t *g, const kernel_box_t *box, int lo[3], int hi[3])
{
    for (int a = 0; a < 3; a++) {
        lo[a] = box != NULL ? box->lo[a] : 1;
        hi[a] = box != NULL ? box->hi[a] : g->n[a];
        if (lo[a] > hi[a]) {
            return 0;
        }
    }
    return 1;
}

void KERNEL_ENTRY(const grid_t *g, const kernel_params_t *p, const real_t *restrict src, real_t *restrict dst,
                  const kernel_box_t *box)
{
    int lo[3], hi[3];
    if (!kernel_range(g, box, lo, hi)) {
        return;
    }
    consts_t k;
    kernel_consts(p, &k);
    const int forced = k.fx != 0.0 || k.fy != 0.0 || k.fz != 0.0;
    ptrdiff_t off[LB_Q];
    for (int q = 0; q < LB_Q; q++) {
        off[q] = grid_offset(g, lb_c[q][0], lb_c[q][1], lb_c[q][2]);
    }
    /* a box that starts and ends on cache lines (row ends widened to the
     * ghost and padding columns, computed and never read) goes in aligned
     * blocks with non-temporal stores; any other part of rows, cell by cell
     * with ordinary stores */
    const int x_first = lo[0] == 1 ? 0 : lo[0], x_end = hi[0] == g->n[0] ? g->s[0] : hi[0] + 1;
#if !defined(KERNEL_SINGLE)
    const int rows = x_first % GRID_ALIGN == 0 && x_end % GRID_ALIGN == 0;
#endif
    const size_t ncells = g->stride;
#pragma omp parallel
    {
#if !defined(KERNEL_SINGLE)
        double buf[LB_Q][KERNEL_BLOCK] __attribute__((aligned(64)));
#endif
#pragma omp for collapse(2) schedule(static) nowait
        for (int z = lo[2]; z <= hi[2]; z++) {
            for (int y = lo[1]; y <= hi[1]; y++) {
                const size_t row = grid_index(g, 0, y, z);
                for (int x0 = x_first; x0 < x_end; x0 += KERNEL_BLOCK) {
                    const int nb = x_end - x0 < KERNEL_BLOCK ? x_end - x0 : KERNEL_BLOCK;
                    const size_t base = row + (size_t)x0;
                    const real_t *in[LB_Q];
                    for (int q = 0; q < LB_Q; q++) {
                        in[q] = src + (size_t)q * ncells + base - off[q];
                    }
#if !defined(KERNEL_SINGLE)
                    if (rows) {
                        if (forced) {
                            collide_block(&k, in, nb, buf, NULL, 0, 1);
                        } else {
                            collide_block(&k, in, nb, buf, NULL, 0, 0);
                        }
                        store_block_nt(dst, ncells, base, nb, buf);
                        continue;
                    }
#endif
                    real_t *out[LB_Q];
                    for (int q = 0; q < LB_Q; q++) {
                        out[q] = dst + (size_t)q * ncells + base;
                    }
                    if (forced) {
                        collide_block(&k, in, nb, NULL, out, 1, 1);
                    } else {
                        collide_block(&k, in, nb, NULL, out, 1, 0);
                    }
                }
            }
        }
#if defined(__SSE2__) && !defined(KERNEL_SINGLE)
        _mm_sfence(); /* non-temporal stores are weakly ordered */
#endif
    }
}

/* The cells x0 .. x1 of the row that starts at cell row, in place. */
static inline __attribute__((always_inline)) void in_place_span(const consts_t *k, real_t *f, size_t ncells,
                                                                const ptrdiff_t off[LB_Q], int push, int forced,
                                                                size_t row, int x0, int x1)
{
    for (int x = x0; x <= x1; x += KERNEL_ROW) {
        const int nb = x1 + 1 - x < KERNEL_ROW ? x1 + 1 - x : KERNEL_ROW;
        const size_t base = row + (size_t)x;
        /* the results go where out[q] = in[qbar] points (direct = 2) */
        const real_t *in[LB_Q];
        for (int q = 0; q < LB_Q; q++) {
            in[q] = f + (size_t)(push ? lb_opposite(q) : q) * ncells + base - off[q];
        }
        if (forced) {
            collide_block(k, in, nb, NULL, NULL, 2, 1);
        } else {
            collide_block(k, in, nb, NULL, NULL, 2, 0);
        }
    }
}

/* The in-place (AA) step, layout.h: push = 0 the local kernel (slot q of x
 * in, slot qbar of x out), push = 1 the push kernel (slot qbar of x - c_q in,
 * slot q of x + c_q out). Interior cells only, but those of p->skip's runs;
 * results go straight to the array (no block buffer: in place the lines
 * were just read). */
void KERNEL_IN_PLACE(const grid_t *g, const kernel_params_t *p, real_t *f, int push, const kernel_box_t *box)
{
    int lo[3], hi[3];
    if (!kernel_range(g, box, lo, hi)) {
        return;
    }
    consts_t k;
    kernel_consts(p, &k);
    const int forced = k.fx != 0.0 || k.fy != 0.0 || k.fz != 0.0;
    ptrdiff_t off[LB_Q];
    for (int q = 0; q < LB_Q; q++) {
        off[q] = push ? grid_offset(g, lb_c[q][0], lb_c[q][1], lb_c[q][2]) : 0;
    }
    const size_t ncells = g->stride;
    const kernel_skip_t *skip = p->skip != NULL && p->skip->start != NULL && p->skip->ny == g->n[1] &&
                                        p->skip->nz == g->n[2]
                                    ? p->skip
                                    : NULL;
#pragma omp parallel
    {
#pragma omp for collapse(2) schedule(static)
        for (int z = lo[2]; z <= hi[2]; z++) {
            for (int y = lo[1]; y <= hi[1]; y++) {
                const size_t row = grid_index(g, 0, y, z);
                /* the interior cells only: no alignment to keep (ordinary stores);
                 * the spans between the row's runs left alone, through one call
                 * (each call inlines the collision: two would double the code
                 * the core fetches, 30 KB instead of 15) */
                uint32_t j = 0, je = 0;
                if (skip != NULL) {
                    const size_t r = (size_t)(y - 1) + (size_t)skip->ny * (size_t)(z - 1);
                    j = skip->start[r];
                    je = skip->start[r + 1];
                }
                for (int x = lo[0]; x <= hi[0];) {
                    while (j < je && skip->run[j][1] < x) {
                        j++;
                    }
                    if (j < je && skip->run[j][0] <= x) {
                        x = skip->run[j][1] + 1; /* a run left alone */
                        continue;
                    }
                    const int end = j < je && skip->run[j][0] - 1 < hi[0] ? skip->run[j][0] - 1 : hi[0];
                    in_place_span(&k, f, ncells, off, push, forced, row, x, end);
                    x = end + 1;
                }
            }
        }
    }
}
