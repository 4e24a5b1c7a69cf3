/* scan.c — one pass over the block's grid (scan.h): the totals of an output
 * row and the trouble check.
 *
 * A z plane is taken SCAN_CHUNK rows at a time. The moments of a chunk come
 * from one pass over its whole span of slots (the ghost cells between its
 * rows included, their terms set to zero), four cells at a time with their
 * sums in vector registers: 19 streams of a few hundred cache lines each,
 * which the hardware prefetcher follows. (Row by row, one pass per direction
 * that loaded and stored the four sums of each cell 19 times, the scan took
 * 2.6 fluid steps' time on the dual star's 120^3 grid.) Then each row's
 * cells in a loop without branches: velocity, terms, and whether any cell
 * is in trouble; only a row with a cell in trouble, or with a speed above
 * the plane's largest so far, is gone through again cell by cell, in the
 * order of the old scan, so that the trouble key and the signed peak are
 * those of a scan cell by cell. The sums are exact (common/exact_sum.h),
 * so their order does not matter: the same bits on any threads and ranks.
 *
 * KERNEL_VARIANT (the FMU build, as kernel.c): compiled for the baseline and
 * for x86-64-v3 as fluid_scan_base / fluid_scan_v3 (kernel_dispatch.c). */
#include "scan.h"

#include "lattice.h"
#include "layout.h"

#include <stdlib.h>

#define SCAN_CAT2(a, b) a##_##b
#define SCAN_CAT(a, b) SCAN_CAT2(a, b)
#if defined(KERNEL_VARIANT)
#define SCAN_ENTRY SCAN_CAT(fluid_scan, KERNEL_VARIANT)
#define SCAN_XSUM SCAN_CAT(fluid_scan_xsum, KERNEL_VARIANT)
#else
#define SCAN_ENTRY fluid_scan
#define SCAN_XSUM fluid_scan_xsum
#endif
int SCAN_ENTRY(const fluid_t *fl, double umax2, double *plane, xsum_t *sums, int totals);

typedef double v4_t __attribute__((vector_size(32)));

/* The exact sum of a span's terms (exact_sum.h) as a function of this
 * file's own, under the variant's name, with everything in it inlined:
 * called from the six copies of scan_plane, xsum_add_array was left out of
 * line under its own name, so that the x86-64-v3 compile put AVX code where
 * a CPU without AVX could reach it (test_fmu checks). */
static __attribute__((noinline, flatten)) void SCAN_XSUM(xsum_t *s, const double *v, int n)
{
    xsum_add_array(s, v, n);
}

/* four consecutive values of a population (a pointer, not a return value:
 * a 32-byte vector returned without AVX would change the ABI) */
static inline __attribute__((always_inline)) void load4(const pops_t *pl, size_t slot, double w, v4_t *v)
{
    if (pl->h != NULL) {
        float h[4];
        __builtin_memcpy(h, pl->h + slot, sizeof h);
        const v4_t d = {h[0], h[1], h[2], h[3]};
        *v = d + w;
    } else {
        __builtin_memcpy(v, pl->f + slot, sizeof *v);
    }
}

/* Density and momentum of the post-collision populations of the n slots
 * from `first` on, with the layout state and precision known at compile
 * time. Each lane is one cell's sums in q order, as pops_moments. */
static inline __attribute__((always_inline)) void span_moments(const pops_t *pl, size_t first, int n, double *rho,
                                                               double *jx, double *jy, double *jz)
{
    if (pl->state == LAYOUT_MOMENTS) {
        /* the moments themselves (ghost and solid cells' terms are
         * masked by their flags: scan_plane) */
        const size_t st = pl->n;
        for (int x = 0; x < n; x++) {
            const size_t i = first + (size_t)x;
            rho[x] = pl->m[MOM_RHO * st + i];
            jx[x] = pl->m[MOM_JX * st + i];
            jy[x] = pl->m[MOM_JY * st + i];
            jz[x] = pl->m[MOM_JZ * st + i];
        }
        return;
    }
    size_t s0[LB_Q];
    for (int q = 0; q < LB_Q; q++) {
        s0[q] = pops_post_slot(pl, q, first);
    }
    int x = 0;
    for (; x + 4 <= n; x += 4) {
        v4_t r = {0.0, 0.0, 0.0, 0.0}, a = r, b = r, c = r;
        /* the sums of pops_moments, in q order, four cells at a time */
#pragma GCC unroll 19
        for (int q = 0; q < LB_Q; q++) {
            v4_t v;
            load4(pl, s0[q] + (size_t)x, lb_w[q], &v);
            r += v;
            LB_ADD(a, lb_c[q][0], v);
            LB_ADD(b, lb_c[q][1], v);
            LB_ADD(c, lb_c[q][2], v);
        }
        __builtin_memcpy(rho + x, &r, sizeof r);
        __builtin_memcpy(jx + x, &a, sizeof a);
        __builtin_memcpy(jy + x, &b, sizeof b);
        __builtin_memcpy(jz + x, &c, sizeof c);
    }
    for (; x < n; x++) {
        double j[3];
        rho[x] = pops_moments(pl, first + (size_t)x, j);
        jx[x] = j[0];
        jy[x] = j[1];
        jz[x] = j[2];
    }
}

/* A row with a cell in trouble, cell by cell: the trouble keys of its fluid
 * cells, and with totals their terms, peaks and largest speed (the row's
 * moments anew: the pass without branches has overwritten them). */
static inline __attribute__((always_inline)) void row_in_trouble(const fluid_t *fl, const pops_t *pl, size_t first,
                                                                 double *buf, size_t cap, double *v, double umax2,
                                                                 double *uumax, int totals)
{
    const int nx = fl->g.n[0];
    double *rho = buf, *jx = buf + cap, *jy = buf + 2 * cap, *jz = buf + 3 * cap, *en = buf + 4 * cap;
    span_moments(pl, first, nx, rho, jx, jy, jz);
    for (int x = 0; x < nx; x++) {
        const size_t i = first + (size_t)x;
        if (cellflags_get(fl->flags, i) != CELL_FLUID) {
            rho[x] = jx[x] = jy[x] = jz[x] = en[x] = 0.0;
            continue;
        }
        const double r = rho[x];
        double u[3];
        const double j[3] = {jx[x], jy[x], jz[x]};
        fluid_post_velocity(fl, r, j, u);
        if (totals) {
            const double uu = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
            jx[x] = r * u[0];
            jy[x] = r * u[1];
            jz[x] = r * u[2];
            en[x] = 0.5 * r * uu;
            for (int a = 0; a < 3; a++) {
                if (fabs(u[a]) > fabs(v[6 + a])) {
                    v[6 + a] = u[a];
                }
            }
            *uumax = uu > *uumax ? uu : *uumax;
        }
        const int cause = cell_trouble(r, u, umax2);
        if (cause != TROUBLE_NONE) {
            v[9] = fmax(v[9], trouble_key(fl, cause, i));
        }
    }
}

/* One z plane, with the layout state and precision known at compile time
 * (one copy per combination below); buf: scan_buffer_bytes (scan.h). */
static inline __attribute__((always_inline)) void scan_plane(const fluid_t *fl, const pops_t *p0, int z, xsum_t *xs,
                                                             double *v, double umax2, double *buf, int totals,
                                                             layout_state_t state, int single)
{
    const grid_t *g = &fl->g;
    const pops_t pl = pops_fixed(p0, state, single);
    const int nx = g->n[0], sx = g->s[0];
    const size_t cap = scan_span(g);
    double *rho = buf, *jx = buf + cap, *jy = buf + 2 * cap, *jz = buf + 3 * cap, *en = buf + 4 * cap;
    double *ux = buf + 5 * cap, *uy = buf + 6 * cap, *uz = buf + 7 * cap;
    const double hf[3] = {0.5 * fl->kp.force[0], 0.5 * fl->kp.force[1], 0.5 * fl->kp.force[2]};
    double uumax = 0.0;
    for (int y0 = 1; y0 <= g->n[1]; y0 += SCAN_CHUNK) {
        const int nr = g->n[1] - y0 + 1 < SCAN_CHUNK ? g->n[1] - y0 + 1 : SCAN_CHUNK;
        const size_t first = grid_index(g, 1, y0, z);
        const int span = (nr - 1) * sx + nx;
        span_moments(&pl, first, span, rho, jx, jy, jz);
        /* the span's flags, a byte each (cellflags.h packs two to a byte) */
        uint8_t *const flags = (uint8_t *)(buf + SCAN_ROW * cap);
        for (int b = 0; b < span; b++) {
            flags[b] = (uint8_t)cellflags_get(fl->flags, first + (size_t)b);
        }
        for (int r = 0; r < nr; r++) {
            const int b0 = r * sx;
            const uint8_t *flag = flags + b0;
            /* the row without branches: u = (j - F/2) / rho as the collision
             * used it (Guo), the terms of the fluid cells (zero elsewhere),
             * and whether a fluid cell is in trouble (a non-finite or
             * non-positive density, a non-finite speed or one above the limit) */
            int bad = 0;
            double rowmax = 0.0, m0 = 0.0, m1 = 0.0, m2 = 0.0;
#pragma omp simd reduction(| : bad) reduction(max : rowmax, m0, m1, m2)
            for (int x = 0; x < nx; x++) {
                const int b = b0 + x;
                const double rr = rho[b];
                const double u0 = (jx[b] - hf[0]) / rr, u1 = (jy[b] - hf[1]) / rr, u2 = (jz[b] - hf[2]) / rr;
                const double uu = u0 * u0 + u1 * u1 + u2 * u2;
                const int fluid = flag[x] == CELL_FLUID;
                bad |= fluid & !(rr > 0.0 && rr < INFINITY && uu <= umax2);
                ux[b] = u0;
                uy[b] = u1;
                uz[b] = u2;
                rho[b] = fluid ? rr : 0.0;
                jx[b] = fluid ? rr * u0 : 0.0;
                jy[b] = fluid ? rr * u1 : 0.0;
                jz[b] = fluid ? rr * u2 : 0.0;
                en[b] = fluid ? 0.5 * rr * uu : 0.0;
                const double su = fluid ? uu : 0.0, a0 = fluid ? fabs(u0) : 0.0, a1 = fluid ? fabs(u1) : 0.0,
                             a2 = fluid ? fabs(u2) : 0.0;
                rowmax = rowmax > su ? rowmax : su;
                m0 = m0 > a0 ? m0 : a0;
                m1 = m1 > a1 ? m1 : a1;
                m2 = m2 > a2 ? m2 : a2;
            }
            if (bad) {
                /* rare (the run stops with the report): the row cell by cell,
                 * its terms at the row's place in the buffer */
                row_in_trouble(fl, &pl, first + (size_t)b0, buf + b0, cap, v, umax2, &uumax, totals);
            } else if (totals) {
                uumax = rowmax > uumax ? rowmax : uumax;
                /* the peaks: the first fluid cell in order whose magnitude
                 * exceeds the plane's so far, as a scan cell by cell finds it */
                const double m[3] = {m0, m1, m2};
                const double *u[3] = {ux, uy, uz};
                for (int a = 0; a < 3; a++) {
                    if (!(m[a] > fabs(v[6 + a]))) {
                        continue;
                    }
                    for (int x = 0; x < nx; x++) {
                        if (flag[x] == CELL_FLUID && fabs(u[a][b0 + x]) > fabs(v[6 + a])) {
                            v[6 + a] = u[a][b0 + x];
                        }
                    }
                }
            }
            /* the ghost cells between this row and the next: no term */
            for (int b = b0 + nx; b < b0 + sx && b < span; b++) {
                rho[b] = jx[b] = jy[b] = jz[b] = en[b] = 0.0;
            }
        }
        if (totals) {
            SCAN_XSUM(&xs[0], rho, span);
            SCAN_XSUM(&xs[1], jx, span);
            SCAN_XSUM(&xs[2], jy, span);
            SCAN_XSUM(&xs[3], jz, span);
            SCAN_XSUM(&xs[4], en, span);
        }
    }
    /* the largest speed (NaN ignored, as fmax does): sqrt is monotonic, so the
     * root of the largest square */
    v[5] = fmax(v[5], sqrt(uumax));
}

int SCAN_ENTRY(const fluid_t *fl, double umax2, double *plane, xsum_t *sums, int totals)
{
    const grid_t *g = &fl->g;
    const pops_t pf = fluid_pops(fl);
    const int nz = g->n[2];
    int fail = 0;
#pragma omp parallel reduction(| : fail)
    {
        double *buf = malloc(scan_buffer_bytes(g));
        fail = buf == NULL;
#pragma omp for schedule(static)
        for (int z = 1; z <= nz; z++) {
            if (buf == NULL) {
                continue;
            }
            double *v = plane + (size_t)(z - 1) * SCAN_NV;
            xsum_t *xs = totals ? sums + (size_t)(z - 1) * SCAN_NS : NULL;
            /* totals a compile-time constant in each copy */
#define PLANE(state, single)                                              \
    do {                                                                  \
        if (totals) {                                                     \
            scan_plane(fl, &pf, z, xs, v, umax2, buf, 1, state, single); \
        } else {                                                          \
            scan_plane(fl, &pf, z, xs, v, umax2, buf, 0, state, single); \
        }                                                                 \
    } while (0)
            POPS_SPECIALISE(&pf, PLANE);
#undef PLANE
        }
        free(buf);
    }
    return !fail;
}
