/* scan.h — one pass over the block's grid (scan.c): the fluid totals of an
 * output row and the check for numerical trouble (diagnostics.c).
 *
 * The pass is compute-bound (exact sums, a division per component, the
 * checks of every cell), so in the FMU build scan.c is compiled for the
 * x86-64 baseline and for x86-64-v3 like the kernel, and kernel_dispatch.c
 * picks one by the CPU; both give the same bits (IEEE operations lane by
 * lane, no contraction into FMAs under C11). */
#ifndef FLUID_SCAN_H
#define FLUID_SCAN_H

#include "../common/exact_sum.h"
#include "fluid_internal.h"

#include <math.h>

/* Per z plane: [5] the largest speed, [6..8] the velocity component of
 * largest magnitude (signed), [9] the worst trouble key; [0..4] unused (the
 * sums go to the plane's exact sums: mass, momentum 3, kinetic energy). */
enum { SCAN_NV = 10, SCAN_NS = 5 };

/* Rows whose moments the scan takes in one pass, and doubles per slot of its
 * buffer: density, momentum 3, kinetic energy, velocity 3. */
enum { SCAN_CHUNK = 32, SCAN_ROW = 8 };

/* Slots of a chunk of rows: SCAN_CHUNK rows and the ghost cells between them. */
static inline size_t scan_span(const grid_t *g)
{
    return (size_t)(SCAN_CHUNK - 1) * (size_t)g->s[0] + (size_t)g->n[0];
}

/* The buffer of each thread of a scan: SCAN_ROW arrays of a span's doubles,
 * and the span's flags unpacked to a byte each. */
static inline size_t scan_buffer_bytes(const grid_t *g) { return SCAN_ROW * scan_span(g) * sizeof(double) + scan_span(g); }

/* Numerical trouble in one fluid cell, worst first (the order in which a
 * scan reports them): a density that is not a finite number (the lattice has
 * blown up: NaN or Inf spread from here), a density <= 0 (populations gone
 * negative: an unstable collision or a boundary that removes more mass than
 * the cell holds), a non-finite velocity, and a velocity above the Mach
 * limit (the lattice has one speed of sound c_s = 1/sqrt(3); near c_s the
 * compressibility error grows as Ma^2 and BGK/TRT lose stability). */
enum { TROUBLE_NONE, TROUBLE_MACH, TROUBLE_VELOCITY, TROUBLE_DENSITY, TROUBLE_DENSITY_NAN };

static inline int cell_trouble(double r, const double u[3], double umax2)
{
    const double uu = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
    if (!isfinite(r)) {
        return TROUBLE_DENSITY_NAN;
    }
    if (!(r > 0.0)) {
        return TROUBLE_DENSITY;
    }
    if (!isfinite(uu)) {
        return TROUBLE_VELOCITY;
    }
    return uu > umax2 ? TROUBLE_MACH : TROUBLE_NONE;
}

/* One number per cell in trouble that orders cells as a scan of the whole
 * grid reports them: the worse cause first, then the first cell in global
 * order (x fastest); 0 for none. The same on any number of ranks; exact in a
 * double (cells * 5 < 2^53). */
static inline double trouble_key(const fluid_t *fl, int cause, size_t i)
{
    if (cause == TROUBLE_NONE) {
        return 0.0;
    }
    const grid_t *g = &fl->g;
    const decomp_t *d = &fl->d;
    const double total = (double)d->N[0] * (double)d->N[1] * (double)d->N[2];
    const double gx = (double)(i % (size_t)g->s[0]) - 1 + d->lo[0];
    const double gy = (double)(i / (size_t)g->s[0] % (size_t)g->s[1]) - 1 + d->lo[1];
    const double gz = (double)(i / ((size_t)g->s[0] * (size_t)g->s[1])) - 1 + d->lo[2];
    return (double)cause * total + (total - 1.0 - (gx + d->N[0] * (gy + d->N[1] * gz)));
}

/* Every z plane of the block in parallel: into plane (n[2] x SCAN_NV,
 * zeroed) and, with totals, into sums (n[2] x SCAN_NS, zeroed), the terms of
 * the fluid cells (density, momentum rho u, kinetic energy rho u^2 / 2, with
 * u = (j - F/2) / rho, the velocity of Guo's forcing); without totals only
 * the trouble keys (umax2: the square of the largest allowed speed). 0 when
 * out of memory for a thread's buffer (scan_buffer_bytes). */
int fluid_scan(const fluid_t *fl, double umax2, double *plane, xsum_t *sums, int totals);

#endif
