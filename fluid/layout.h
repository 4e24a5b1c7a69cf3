/* layout.h — where a population lives in memory, for the streaming layouts.
 *
 * Three layouts (scene key fluid.streaming; the third, moments, below the
 * table: LAYOUT_MOMENTS):
 *   two_array  pull from one array, write the other (kernel.c); the arrays swap.
 *   in_place   one array, the AA pattern (Bailey, Myre, Walsh, Lilja & Bader,
 *              ICPP 2009): steps alternate between a local kernel, which reads
 *              the 19 slots of a cell and writes them back with the directions
 *              swapped, and a push kernel, which reads a cell's populations
 *              from its neighbours (swapped) and writes its results to them.
 *              Each cell reads and writes the same 19 slots, so the update is
 *              in place and thread-safe; half the memory, the same traffic.
 *
 * Between two steps the array is in one of three states. Everything outside
 * the kernels (walls, spheres, refill, fields, state) reads and writes through
 * two maps, and so works unchanged in every state:
 *   post_slot(q, x)  where the post-collision f~_q(x) of the last step is;
 *   in_slot(q, x)    where the next kernel reads the f_q that enters x,
 *                    i.e. f~_q(x - c_q) after streaming. A boundary writes it
 *                    when x - c_q is a ghost or solid cell.
 *
 *   state     next kernel     post_slot(q, x)          in_slot(q, x)
 *   PULL      two_array       q,    x                  q,    x - c_q
 *   SWAPPED   push            qbar, x                  qbar, x - c_q
 *   PUSHED    local           q,    x + c_q            q,    x
 *
 * (slot "q, x" is f[q * ncells + x]). The local kernel leaves the SWAPPED
 * state, the push kernel the PUSHED one. In every state in_slot(q, x) is the
 * slot of post_slot(q, x - c_q): a boundary that writes in_slot(q, x) for a
 * fluid x overwrites only the (meaningless) post-collision value of the ghost
 * or solid cell x - c_q, never a value of a fluid cell. An MPI halo exchange
 * is the same copy, in_slot(q, x) <- post_slot(q, remote cell), as a
 * periodic face. */
#ifndef FLUID_LAYOUT_H
#define FLUID_LAYOUT_H

#include "grid.h"
#include "lattice.h"

#include <stddef.h>
#include <stdint.h>

typedef enum { LAYOUT_PULL, LAYOUT_SWAPPED, LAYOUT_PUSHED, LAYOUT_MOMENTS } layout_state_t;

/* The moments layout (fluid.streaming: moments; moments.h): a fluid cell
 * keeps the 10 moments of its post-collision populations, m[k * n + x]
 * (MOM_* below), and post(q, x) is their reconstruction; a ghost or solid
 * cell keeps 19 values in a side store, f[idx[x] * 19 + q], and for it
 * post_slot(q, x) is that slot, as in_slot(q, x) is the slot q of
 * x - c_q (never a fluid cell there: the boundary writes it). A fluid cell
 * has no slot: everything that reads a post-collision value goes through
 * pops_post (or pops_moments), everything that writes a whole cell through
 * pops_set_post. */
enum { MOM_RHO, MOM_JX, MOM_JY, MOM_JZ, MOM_AXX, MOM_AYY, MOM_AZZ, MOM_AXY, MOM_AXZ, MOM_AYZ, MOM_N };

/* Storage: double, or (fluid.precision: single) float holding f_q - w_q
 * (kernel.c); pops_read/pops_write convert, so that everything outside the
 * kernels computes in double either way. */
typedef struct {
    double *f;            /* double storage, or NULL */
    float *h;             /* single storage (f - w_q), or NULL */
    size_t n;             /* cells from one population to the next (grid.h stride) */
    ptrdiff_t off[LB_Q];  /* offset of the neighbour at +c_q */
    layout_state_t state;
    double *m;            /* LAYOUT_MOMENTS: the 10 moments per cell (f is then the side store) */
    const int32_t *idx;   /* LAYOUT_MOMENTS: a ghost or solid cell's entry in the side store, -1 for fluid */
} pops_t;

static inline void pops_init(pops_t *p, const grid_t *g, void *data, int single, layout_state_t state)
{
    p->f = single ? NULL : (double *)data;
    p->h = single ? (float *)data : NULL;
    p->n = g->stride;
    p->state = state;
    p->m = NULL;
    p->idx = NULL;
    for (int q = 0; q < LB_Q; q++) {
        p->off[q] = grid_offset(g, lb_c[q][0], lb_c[q][1], lb_c[q][2]);
    }
}

static inline __attribute__((always_inline)) size_t pops_post_slot(const pops_t *p, int q, size_t x)
{
    switch (p->state) {
    case LAYOUT_SWAPPED:
        return (size_t)lb_opposite(q) * p->n + x;
    case LAYOUT_PUSHED:
        return (size_t)q * p->n + (size_t)((ptrdiff_t)x + p->off[q]);
    case LAYOUT_MOMENTS: /* a ghost or solid x only */
        return (size_t)p->idx[x] * LB_Q + (size_t)q;
    case LAYOUT_PULL:
    default:
        return (size_t)q * p->n + x;
    }
}

static inline size_t pops_in_slot(const pops_t *p, int q, size_t x)
{
    switch (p->state) {
    case LAYOUT_SWAPPED:
        return (size_t)lb_opposite(q) * p->n + (size_t)((ptrdiff_t)x - p->off[q]);
    case LAYOUT_PUSHED:
        return (size_t)q * p->n + x;
    case LAYOUT_MOMENTS:
        return (size_t)p->idx[(ptrdiff_t)x - p->off[q]] * LB_Q + (size_t)q;
    case LAYOUT_PULL:
    default:
        return (size_t)q * p->n + (size_t)((ptrdiff_t)x - p->off[q]);
    }
}

/* The value of a slot of direction q (or of its opposite: same weight). */
static inline __attribute__((always_inline)) double pops_read(const pops_t *p, int q, size_t slot)
{
    return p->h != NULL ? (double)p->h[slot] + lb_w[q] : p->f[slot];
}

static inline void pops_write(const pops_t *p, int q, size_t slot, double v)
{
    if (p->h != NULL) {
        p->h[slot] = (float)(v - lb_w[q]);
    } else {
        p->f[slot] = v;
    }
}

/* Copies a slot to another of the same weight, exactly. */
static inline void pops_copy(const pops_t *p, size_t dst, size_t src)
{
    if (p->h != NULL) {
        p->h[dst] = p->h[src];
    } else {
        p->f[dst] = p->f[src];
    }
}

/* f~_q of a fluid cell from its moments: the regularized populations
 * w_q [rho + 3 c_q.j + 9/2 (c_q.A.c_q - tr A / 3)], A the second moment
 * less rho/3 I (moments.h). */
static inline __attribute__((always_inline)) double pops_rebuild(const double *m, size_t n, int q, size_t x)
{
    const double cx = lb_c[q][0], cy = lb_c[q][1], cz = lb_c[q][2];
    const double axx = m[MOM_AXX * n + x], ayy = m[MOM_AYY * n + x], azz = m[MOM_AZZ * n + x];
    const double cac = cx * cx * axx + cy * cy * ayy + cz * cz * azz +
                       2.0 * (cx * cy * m[MOM_AXY * n + x] + cx * cz * m[MOM_AXZ * n + x] + cy * cz * m[MOM_AYZ * n + x]);
    return lb_w[q] * (m[MOM_RHO * n + x] + 3.0 * (cx * m[MOM_JX * n + x] + cy * m[MOM_JY * n + x] + cz * m[MOM_JZ * n + x]) +
                      4.5 * (cac - (axx + ayy + azz) / 3.0));
}

/* The 10 moments of 19 post-collision values (their projection on the
 * regularized populations: pops_rebuild gives back the same density,
 * momentum and second moment). */
static inline void pops_project(const double v[LB_Q], double mo[MOM_N])
{
    double r = 0.0, j[3] = {0.0, 0.0, 0.0}, P[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    for (int q = 0; q < LB_Q; q++) {
        const double cx = lb_c[q][0], cy = lb_c[q][1], cz = lb_c[q][2];
        r += v[q];
        j[0] += cx * v[q];
        j[1] += cy * v[q];
        j[2] += cz * v[q];
        P[0] += cx * cx * v[q];
        P[1] += cy * cy * v[q];
        P[2] += cz * cz * v[q];
        P[3] += cx * cy * v[q];
        P[4] += cx * cz * v[q];
        P[5] += cy * cz * v[q];
    }
    mo[MOM_RHO] = r;
    mo[MOM_JX] = j[0];
    mo[MOM_JY] = j[1];
    mo[MOM_JZ] = j[2];
    mo[MOM_AXX] = P[0] - r / 3.0;
    mo[MOM_AYY] = P[1] - r / 3.0;
    mo[MOM_AZZ] = P[2] - r / 3.0;
    mo[MOM_AXY] = P[3];
    mo[MOM_AXZ] = P[4];
    mo[MOM_AYZ] = P[5];
}

static inline __attribute__((always_inline)) int pops_is_moments_cell(const pops_t *p, size_t x)
{
    return p->state == LAYOUT_MOMENTS && p->idx[x] < 0;
}

static inline __attribute__((always_inline)) double pops_post(const pops_t *p, int q, size_t x)
{
    if (pops_is_moments_cell(p, x)) {
        return pops_rebuild(p->m, p->n, q, x);
    }
    return pops_read(p, q, pops_post_slot(p, q, x));
}

/* Writes the 19 post-collision values of cell x (initialisation, refill,
 * a state given from outside): in the moments layout a fluid cell keeps
 * their 10 moments (the values are regularized on the way). */
static inline void pops_set_post(const pops_t *p, size_t x, const double v[LB_Q])
{
    if (pops_is_moments_cell(p, x)) {
        double mo[MOM_N];
        pops_project(v, mo);
        for (int k = 0; k < MOM_N; k++) {
            p->m[(size_t)k * p->n + x] = mo[k];
        }
        return;
    }
    for (int q = 0; q < LB_Q; q++) {
        pops_write(p, q, pops_post_slot(p, q, x), v[q]);
    }
}

/* dst <- f~_q(x): an exact copy of a slot, or in the moments layout the
 * value rebuilt for a fluid x. */
static inline __attribute__((always_inline)) void pops_copy_post(const pops_t *p, size_t dst, int q, size_t x)
{
    if (pops_is_moments_cell(p, x)) {
        pops_write(p, q, dst, pops_rebuild(p->m, p->n, q, x));
    } else {
        pops_copy(p, dst, pops_post_slot(p, q, x));
    }
}

/* Asks for the cache line of a slot ahead of its use (write: to store to
 * it), where the hardware prefetcher cannot guess the address. (The
 * moments layout: a hint it does without.) */
static inline void pops_prefetch(const pops_t *p, size_t slot, int write)
{
    if (p->state == LAYOUT_MOMENTS) {
        return;
    }
    const void *a = p->h != NULL ? (const void *)(p->h + slot) : (const void *)(p->f + slot);
    if (write) {
        __builtin_prefetch(a, 1);
    } else {
        __builtin_prefetch(a, 0);
    }
}

/* Runs BODY(state, single) with the layout state and the precision of p as
 * compile-time constants: one copy of BODY per combination, so that the
 * maps above compile to straight arithmetic in a hot loop. */
#define POPS_SPECIALISE(p, BODY)                         \
    do {                                                 \
        switch (2 * (int)(p)->state + ((p)->h != NULL)) { \
        case 2 * LAYOUT_PULL:                            \
            BODY(LAYOUT_PULL, 0);                        \
            break;                                       \
        case 2 * LAYOUT_PULL + 1:                        \
            BODY(LAYOUT_PULL, 1);                        \
            break;                                       \
        case 2 * LAYOUT_SWAPPED:                         \
            BODY(LAYOUT_SWAPPED, 0);                     \
            break;                                       \
        case 2 * LAYOUT_SWAPPED + 1:                     \
            BODY(LAYOUT_SWAPPED, 1);                     \
            break;                                       \
        case 2 * LAYOUT_PUSHED:                          \
            BODY(LAYOUT_PUSHED, 0);                      \
            break;                                       \
        case 2 * LAYOUT_MOMENTS:                         \
            BODY(LAYOUT_MOMENTS, 0);                     \
            break;                                       \
        default:                                         \
            BODY(LAYOUT_PUSHED, 1);                      \
            break;                                       \
        }                                                \
    } while (0)

/* A copy of p whose state and precision are the constants state and
 * single (inside a POPS_SPECIALISE body). */
static inline __attribute__((always_inline)) pops_t pops_fixed(const pops_t *p, layout_state_t state, int single)
{
    pops_t c = *p;
    c.state = state;
    if (!single) {
        c.h = NULL;
    } else if (c.h == NULL) {
        __builtin_unreachable(); /* single: the float storage is there */
    }
    return c;
}

/* Density and momentum of the post-collision populations of cell x. */
static inline __attribute__((always_inline)) double pops_moments(const pops_t *p, size_t x, double j[3])
{
    if (pops_is_moments_cell(p, x)) {
        j[0] = p->m[MOM_JX * p->n + x];
        j[1] = p->m[MOM_JY * p->n + x];
        j[2] = p->m[MOM_JZ * p->n + x];
        return p->m[MOM_RHO * p->n + x];
    }
    double rho = 0.0;
    j[0] = j[1] = j[2] = 0.0;
#pragma GCC unroll 19
    for (int q = 0; q < LB_Q; q++) {
        const double v = pops_post(p, q, x);
        rho += v;
        LB_ADD(j[0], lb_c[q][0], v);
        LB_ADD(j[1], lb_c[q][1], v);
        LB_ADD(j[2], lb_c[q][2], v);
    }
    return rho;
}

#endif
