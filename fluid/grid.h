/* grid.h — the one place that maps cell coordinates to memory.
 *
 * The grid holds n[0] x n[1] x n[2] interior cells and one ghost layer on
 * every side. Coordinates here are allocated coordinates: 0 and n[a]+1 are
 * ghosts, 1..n[a] interior. x is fastest; with two arrays the x extent s[0]
 * is padded to a multiple of GRID_ALIGN cells so that every row of every
 * population array starts on a 64-byte boundary (the fused kernel streams
 * whole rows with non-temporal stores); in place it is not (grid_init).
 * Populations are structure-of-arrays: population q of cell i is
 * f[q * stride + i], stride >= ncells (below). Ghost layers make room for
 * domain boundaries and for the MPI halo exchange. */
#ifndef FLUID_GRID_H
#define FLUID_GRID_H

#include <stddef.h>

#define GRID_ALIGN 8

typedef struct {
    int n[3];      /* interior cells */
    int s[3];      /* allocated extent: s[1] = n[1]+2, s[2] = n[2]+2, s[0] = n[0]+2 (padded with two arrays) */
    size_t ncells; /* s[0]*s[1]*s[2] */
    size_t stride; /* cells from one population to the next: ncells + a few (below) */
} grid_t;

/* The population stride is ncells rounded up to 24 mod 512 cells: 8-byte
 * values of population q then start 192 q bytes (3 q cache lines) apart modulo
 * 4 KiB. With a stride that is a multiple of 4 KiB (120^3 gives one) the 19
 * streams of a kernel all fall into the same L1 cache set and alias on
 * 4 KiB address bits: measured here, 43 MLUPS at 120^3 against 95 at 128^3. */
enum { GRID_STRIDE_MOD = 512, GRID_STRIDE_REM = 24 };

/* align: the multiple of cells the x extent is padded to, GRID_ALIGN for
 * two arrays (whole rows with non-temporal stores), 1 in place (no padding:
 * its kernel writes interior cells with ordinary stores, and 202 allocated
 * columns instead of 208 are 3 % of the memory of a 200-cell grid). */
static inline void grid_init(grid_t *g, const int n[3], int align)
{
    for (int a = 0; a < 3; a++) {
        g->n[a] = n[a];
        g->s[a] = n[a] + 2;
    }
    g->s[0] = (g->s[0] + align - 1) / align * align;
    g->ncells = (size_t)g->s[0] * (size_t)g->s[1] * (size_t)g->s[2];
    g->stride = g->ncells + (GRID_STRIDE_MOD + GRID_STRIDE_REM - g->ncells % GRID_STRIDE_MOD) % GRID_STRIDE_MOD;
}

static inline size_t grid_index(const grid_t *g, int x, int y, int z)
{
    return ((size_t)z * (size_t)g->s[1] + (size_t)y) * (size_t)g->s[0] + (size_t)x;
}

/* Offset of the neighbour at (+cx, +cy, +cz). */
static inline ptrdiff_t grid_offset(const grid_t *g, int cx, int cy, int cz)
{
    return (ptrdiff_t)cx + (ptrdiff_t)g->s[0] * ((ptrdiff_t)cy + (ptrdiff_t)g->s[1] * (ptrdiff_t)cz);
}

static inline int grid_is_interior(const grid_t *g, int x, int y, int z)
{
    return x >= 1 && x <= g->n[0] && y >= 1 && y <= g->n[1] && z >= 1 && z <= g->n[2];
}

#endif
