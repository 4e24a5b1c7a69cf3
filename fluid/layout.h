/* layout.h — where a population lives in memory, for both streaming layouts.
 *
 * Two layouts (scene key fluid.streaming):
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

typedef enum { LAYOUT_PULL, LAYOUT_SWAPPED, LAYOUT_PUSHED } layout_state_t;

/* Storage: double, or (fluid.precision: single) float holding f_q - w_q
 * (kernel.c); pops_read/pops_write convert, so that everything outside the
 * kernels computes in double either way. */
typedef struct {
    double *f;            /* double storage, or NULL */
    float *h;             /* single storage (f - w_q), or NULL */
    size_t n;             /* cells from one population to the next (grid.h stride) */
    ptrdiff_t off[LB_Q];  /* offset of the neighbour at +c_q */
    layout_state_t state;
} pops_t;

static inline void pops_init(pops_t *p, const grid_t *g, void *data, int single, layout_state_t state)
{
    p->f = single ? NULL : (double *)data;
    p->h = single ? (float *)data : NULL;
    p->n = g->stride;
    p->state = state;
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

static inline __attribute__((always_inline)) double pops_post(const pops_t *p, int q, size_t x)
{
    return pops_read(p, q, pops_post_slot(p, q, x));
}

/* Asks for the cache line of a slot ahead of its use (write: to store to
 * it), where the hardware prefetcher cannot guess the address. */
static inline void pops_prefetch(const pops_t *p, size_t slot, int write)
{
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
