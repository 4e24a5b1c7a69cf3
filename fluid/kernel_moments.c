/* kernel_moments.c — the update of the moments layout (moments.h): fused
 * pull streaming and regularized BGK collision with Guo forcing, in place on
 * the 10 moments of each fluid cell.
 *
 * Streaming. Cell x pulls f_q = f~_q(x - c_q) of the last step: from the
 * side store when x - c_q is a ghost or solid cell (the boundary stage wrote
 * it: walls.c, sphere_fill.c), else rebuilt from that cell's moments,
 *   f~_q = w_q [rho + 3 c_q.j + 9/2 Q_q : A],  Q_q = c_q c_q - I/3
 * (layout.h pops_rebuild), the moment representation of Vardhan, Gounley,
 * Chen, Dolan & Randles, SC'19 (Moment representation in the lattice
 * Boltzmann method on massively parallel hardware), Eq. 6-8, with the
 * second moment stored less rho/3 I.
 *
 * Collision (regularized BGK: Latt & Chopard, Math. Comput. Simul. 72 (2006)
 * 165, Eq. 13-16; with Guo, Zheng & Shi, Phys. Rev. E 65 (2002) 046308). Of
 * the pulled f: rho = sum f, j = sum c f, P = sum c c f; u = (j + F/2)/rho;
 * Pi_eq = rho/3 I + rho u u. BGK with Guo's source
 * S_q = w_q [3 (c_q - u).F + 9 (c_q.u)(c_q.F)] = w_q [3 c_q.F + 9/2 Q_q:(uF + Fu)]
 * gives post-collision moments up to the second
 *   rho~ = rho,   j~ = j + F,
 *   Pi~ = Pi_eq + (1 - omega)(P - Pi_eq) + (1 - omega/2)(u F + F u),
 * and the regularized collision keeps exactly these and drops every higher
 * (non-hydrodynamic) moment: its f~ is the Hermite expansion to second
 * order of them, so the stored moments are
 *   A~ = Pi~ - rho/3 I = rho u u + (1 - omega)(P - rho/3 I - rho u u)
 *        + (1 - omega/2)(u F + F u).
 * Density and momentum are those of the other kernels (kernel.c, BGK); the
 * viscosity is nu = (1/omega - 1/2)/3 as with BGK.
 *
 * In place. A cell's neighbours must read its old moments after it has
 * written its new ones: the planes are updated in z order, each thread over
 * its own slab of planes, keeping aside the old populations its cells pull:
 * the 5 with c_z = +1 of the plane below (z - 1), the 9 with c_z = 0 of the
 * plane itself and the 5 with c_z = -1 of the plane above (still old in
 * m), each rebuilt once per cell from its moments before the plane is
 * updated (rebuilding a neighbour's value for
 * each pull, 18 rebuilds of 10 loads per cell, ran at 14 MLUPS on one
 * thread at 128^3 where this runs at 43; README "Moments layout"). The
 * last plane of a slab has the next slab's first plane above it: its
 * moments, and the populations of the plane below the slab, are taken
 * before any thread starts (a barrier). Extra memory: 5 + 5 + 9 + 5 + 5
 * doubles per plane cell and thread (MOMENTS_PLANE_DOUBLES). Cells inside
 * the spheres (solid) are left alone. */
#include "moments.h"

#include "lattice.h"

#include <omp.h>
#include <stdlib.h>

/* KERNEL_VARIANT (the FMU build, as kernel.c): compiled for the x86-64
 * baseline and for x86-64-v3 under kernel_moments_base / _v3, picked by
 * kernel_dispatch.c; without it (build/coupler, tests: -march=native) it
 * defines kernel_moments itself. */
#define KM_CAT2(a, b) a##_##b
#define KM_CAT(a, b) KM_CAT2(a, b)
#if defined(KERNEL_VARIANT)
#define KM_ENTRY KM_CAT(kernel_moments, KERNEL_VARIANT)
int KM_ENTRY(const grid_t *g, const kernel_params_t *p, moments_t *ms);
#else
#define KM_ENTRY kernel_moments
#endif

typedef struct {
    const int32_t *idx;
    const double *side;
    ptrdiff_t off[LB_Q];  /* the neighbour at +c_q in the grid */
    ptrdiff_t poff[LB_Q]; /* and within its plane */
    size_t np;            /* cells per plane */
    double om, fx, fy, fz;
} kctx_t;

/* The collision of cell i from the moments of its pulled f (rho, j, the
 * second moment P), its new moments into m. */
static inline __attribute__((always_inline)) void collide_moments(double om, double fx, double fy, double fz, size_t i,
                                                                 double *restrict m, size_t stride, double rho,
                                                                 double jx, double jy, double jz, double pxx,
                                                                 double pyy, double pzz, double pxy, double pxz,
                                                                 double pyz)
{
    const double inv = 1.0 / rho;
    const double ux = (jx + 0.5 * fx) * inv, uy = (jy + 0.5 * fy) * inv, uz = (jz + 0.5 * fz) * inv;
    const double r3 = rho / 3.0, keep = 1.0 - om, src = 1.0 - 0.5 * om;
    const double exx = rho * ux * ux, eyy = rho * uy * uy, ezz = rho * uz * uz;
    const double exy = rho * ux * uy, exz = rho * ux * uz, eyz = rho * uy * uz;
    m[MOM_RHO * stride + i] = rho;
    m[MOM_JX * stride + i] = jx + fx;
    m[MOM_JY * stride + i] = jy + fy;
    m[MOM_JZ * stride + i] = jz + fz;
    m[MOM_AXX * stride + i] = exx + keep * (pxx - r3 - exx) + src * 2.0 * ux * fx;
    m[MOM_AYY * stride + i] = eyy + keep * (pyy - r3 - eyy) + src * 2.0 * uy * fy;
    m[MOM_AZZ * stride + i] = ezz + keep * (pzz - r3 - ezz) + src * 2.0 * uz * fz;
    m[MOM_AXY * stride + i] = exy + keep * (pxy - exy) + src * (ux * fy + uy * fx);
    m[MOM_AXZ * stride + i] = exz + keep * (pxz - exz) + src * (ux * fz + uz * fx);
    m[MOM_AYZ * stride + i] = eyz + keep * (pyz - eyz) + src * (uy * fz + uz * fy);
}

/* The sums of the moments of f over q, in q order (both paths alike). */
#define MOMENT_SUMS(F)                                                                                         \
    double rho = 0.0, jx = 0.0, jy = 0.0, jz = 0.0, pxx = 0.0, pyy = 0.0, pzz = 0.0, pxy = 0.0, pxz = 0.0,     \
           pyz = 0.0;                                                                                          \
    _Pragma("GCC unroll 19") for (int q = 0; q < LB_Q; q++)                                                    \
    {                                                                                                          \
        const int cx = lb_c[q][0], cy = lb_c[q][1], cz = lb_c[q][2];                                          \
        const double v = (F);                                                                                  \
        rho += v;                                                                                              \
        LB_ADD(jx, cx, v);                                                                                     \
        LB_ADD(jy, cy, v);                                                                                     \
        LB_ADD(jz, cz, v);                                                                                     \
        LB_ADD(pxx, cx * cx, v);                                                                               \
        LB_ADD(pyy, cy * cy, v);                                                                               \
        LB_ADD(pzz, cz * cz, v);                                                                               \
        LB_ADD(pxy, cx * cy, v);                                                                               \
        LB_ADD(pxz, cx * cz, v);                                                                               \
        LB_ADD(pyz, cy * cz, v);                                                                               \
    }

/* The populations kept per plane, by the sign of c_z, each set in q order:
 * MID_SLOT[q] for c_z = 0 (9), UP_SLOT for c_z = +1 (5, pulled by the
 * plane above), DOWN_SLOT for c_z = -1 (5, pulled by the plane below); -1
 * outside the set. */
static const signed char MID_SLOT[LB_Q] = {0, 1, 2, -1, 3, 4, -1, -1, -1, -1, 5, 6, -1, 7, 8, -1, -1, -1, -1};
static const signed char UP_SLOT[LB_Q] = {-1, -1, -1, 0, -1, -1, 1, -1, 2, -1, -1, -1, -1, -1, -1, -1, 3, -1, 4};
static const signed char DOWN_SLOT[LB_Q] = {-1, -1, -1, -1, -1, -1, -1, 0, -1, 1, -1, -1, 2, -1, -1, 3, -1, 4, -1};

/* (Everything here inlined into the kernel's entry: the FMU's baseline
 * build must hold AVX code only under the _v3 names, test_fmu.) */
/* The populations of the set slot[] (MID_SLOT, UP_SLOT or DOWN_SLOT) of
 * every cell of a plane whose moments are at src (moment k at k n), into
 * buf (slot s of plane cell pi at s np + pi); with mid != NULL also those
 * of MID_SLOT into mid. Each cell's values from its 10 moments at once,
 * where pulling them from the moments rebuilt a neighbour's for each value. */
static inline __attribute__((always_inline)) void rebuild_set(double *restrict buf, const signed char *slot,
                                                             double *restrict mid, const double *restrict src,
                                                             size_t n, size_t np)
{
#pragma omp simd
    for (size_t pi = 0; pi < np; pi++) {
#pragma GCC unroll 19
        for (int q = 0; q < LB_Q; q++) {
            if (slot[q] >= 0) {
                buf[(size_t)slot[q] * np + pi] = pops_rebuild(src, n, q, pi);
            } else if (mid != NULL && MID_SLOT[q] >= 0) {
                mid[(size_t)MID_SLOT[q] * np + pi] = pops_rebuild(src, n, q, pi);
            }
        }
    }
}

static inline __attribute__((always_inline)) void rebuild_up(double *up, const double *src, size_t n, size_t np)
{
    rebuild_set(up, UP_SLOT, NULL, src, n, np);
}

static inline __attribute__((always_inline)) void rebuild_down(double *down, const double *src, size_t n, size_t np)
{
    rebuild_set(down, DOWN_SLOT, NULL, src, n, np);
}

/* a plane's own (c_z = 0) and upward (c_z = +1) populations */
static inline __attribute__((always_inline)) void rebuild_mid_up(double *mid, double *up, const double *src, size_t n, size_t np)
{
    rebuild_set(up, UP_SLOT, mid, src, n, np);
}

/* f~_q of the fluid neighbour x - c_q of the cell at plane index pi (at =
 * pi - the in-plane part of c_q): from the populations of the plane below
 * (lo), of its own plane (mid) or of the plane above (hi). */
static inline __attribute__((always_inline)) double pulled(const double *lo, const double *mid, const double *hi,
                                                          size_t np, int q, size_t at)
{
    return lb_c[q][2] > 0   ? lo[(size_t)UP_SLOT[q] * np + at]
           : lb_c[q][2] < 0 ? hi[(size_t)DOWN_SLOT[q] * np + at]
                            : mid[(size_t)MID_SLOT[q] * np + at];
}

/* One cell: i its grid index, pi its index in the plane. */
static inline __attribute__((always_inline)) void update_cell(const kctx_t *k, const double *lo, const double *mid,
                                                             const double *hi, size_t i, size_t pi, double *restrict m,
                                                             size_t stride)
{
    double f[LB_Q];
#pragma GCC unroll 19
    for (int q = 0; q < LB_Q; q++) {
        const int32_t e = k->idx[(ptrdiff_t)i - k->off[q]];
        f[q] = e >= 0 ? k->side[(size_t)e * LB_Q + (size_t)q]
                      : pulled(lo, mid, hi, k->np, q, (size_t)((ptrdiff_t)pi - k->poff[q]));
    }
    MOMENT_SUMS(f[q])
    collide_moments(k->om, k->fx, k->fy, k->fz, i, m, stride, rho, jx, jy, jz, pxx, pyy, pzz, pxy, pxz, pyz);
}

/* n cells of a row from plane index pi0 on whose neighbours are all fluid:
 * no index to look at, and the cells side by side in vector lanes (what
 * the loop reads held in locals: stores to m could alias a field of k).
 * The same arithmetic, in the same order, as update_cell: the same bits. */
static inline __attribute__((always_inline)) void update_run(const kctx_t *k, const double *restrict lo,
                                                            const double *restrict mid, const double *restrict hi,
                                                            size_t i0, size_t pi0, int n, ptrdiff_t sx,
                                                            double *restrict m, size_t stride)
{
    const size_t np = k->np;
    const double om = k->om, fx = k->fx, fy = k->fy, fz = k->fz;
#pragma omp simd
    for (int x = 0; x < n; x++) {
        const size_t pi = pi0 + (size_t)x;
        MOMENT_SUMS(pulled(lo, mid, hi, np, q, (size_t)((ptrdiff_t)pi - cx - sx * cy)))
        collide_moments(om, fx, fy, fz, i0 + (size_t)x, m, stride, rho, jx, jy, jz, pxx, pyy, pzz, pxy, pxz, pyz);
    }
}

int KM_ENTRY(const grid_t *g, const kernel_params_t *p, moments_t *ms)
{
    const size_t np = (size_t)g->s[0] * (size_t)g->s[1];
    const int maxt = omp_get_max_threads();
    if (ms->planes == NULL || ms->nplanes < maxt) {
        free(ms->planes);
        ms->nplanes = 0;
        ms->planes = malloc((size_t)maxt * MOMENTS_PLANE_DOUBLES * np * sizeof(double));
        if (ms->planes == NULL) {
            return 0;
        }
        ms->nplanes = maxt;
    }
    kctx_t k;
    k.idx = ms->idx;
    k.side = ms->side;
    k.np = np;
    k.om = p->omega_plus;
    k.fx = p->force[0];
    k.fy = p->force[1];
    k.fz = p->force[2];
    for (int q = 0; q < LB_Q; q++) {
        k.poff[q] = grid_offset(g, lb_c[q][0], lb_c[q][1], 0);
        k.off[q] = grid_offset(g, lb_c[q][0], lb_c[q][1], lb_c[q][2]);
    }
    double *const m = ms->m;
    const size_t stride = g->stride;
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    double *const planes = ms->planes;
#pragma omp parallel num_threads(maxt)
    {
        const int nt = omp_get_num_threads(), t = omp_get_thread_num();
        const int z0 = 1 + nz * t / nt, z1 = nz * (t + 1) / nt;
        /* per plane cell: the upward populations of the plane below (lo) and
         * of this plane (lo_next, for the next), this plane's own (mid), the
         * downward ones of the plane above (down), and those of the plane
         * above the slab (top), taken before any thread starts */
        double *lo = planes + (size_t)t * MOMENTS_PLANE_DOUBLES * np, *lo_next = lo + 5 * np,
               *mid = lo_next + 5 * np, *down = mid + 9 * np, *top = down + 5 * np;
        if (z0 <= z1) {
            rebuild_up(lo, m + (size_t)(z0 - 1) * np, stride, np);
            rebuild_down(top, m + (size_t)(z1 + 1) * np, stride, np);
        }
#pragma omp barrier
        if (z0 <= z1) {
            rebuild_mid_up(mid, lo_next, m + (size_t)z0 * np, stride, np);
        }
        for (int z = z0; z <= z1; z++) {
            /* the plane above: still old in m, but for the slab's last */
            const double *up = top;
            if (z < z1) {
                rebuild_down(down, m + (size_t)(z + 1) * np, stride, np);
                up = down;
            }
            const size_t sy = (size_t)g->s[1];
            for (int y = 1; y <= ny; y++) {
                /* the row and its eight neighbour rows all fluid: cells 2 .. nx - 1
                 * without the index (1 and nx have ghost neighbours) */
                const uint8_t *rf = ms->row_fluid;
                const int clear = nx > 2 && rf[(size_t)z * sy + y] && rf[(size_t)z * sy + y - 1] &&
                                  rf[(size_t)z * sy + y + 1] && rf[(size_t)(z - 1) * sy + y] &&
                                  rf[(size_t)(z + 1) * sy + y] && rf[(size_t)(z - 1) * sy + y - 1] &&
                                  rf[(size_t)(z - 1) * sy + y + 1] && rf[(size_t)(z + 1) * sy + y - 1] &&
                                  rf[(size_t)(z + 1) * sy + y + 1];
                for (int x = 1; x <= nx; x++) {
                    const size_t pi = (size_t)y * (size_t)g->s[0] + (size_t)x, i = (size_t)z * np + pi;
                    if (clear && x == 2) {
                        update_run(&k, lo, mid, up, i, pi, nx - 2, (ptrdiff_t)g->s[0], m, stride);
                        x = nx - 1;
                        continue;
                    }
                    if (k.idx[i] < 0) {
                        update_cell(&k, lo, mid, up, i, pi, m, stride);
                    }
                }
            }
            double *t2 = lo;
            lo = lo_next;
            lo_next = t2;
            if (z < z1) {
                rebuild_mid_up(mid, lo_next, m + (size_t)(z + 1) * np, stride, np);
            }
        }
    }
    return 1;
}
