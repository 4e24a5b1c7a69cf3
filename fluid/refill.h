/* refill.h — populations for cells that a moving sphere uncovers.
 *
 * equilibrium    the paper's scheme: f = feq(rho, u_s), rho the mean density
 *                of the fluid neighbours, u_s the velocity of the sphere
 *                surface point nearest to the cell.
 * extrapolation  equilibrium plus the non-equilibrium part of the fluid
 *                neighbour along the lattice direction closest to the surface
 *                normal (Caiazzo, Prog. Comput. Fluid Dyn. 8 (2008) 3, his
 *                equilibrium + non-equilibrium refill; the non-equilibrium
 *                extrapolation of Guo, Zheng & Shi, Chin. Phys. 11 (2002)
 *                366): f_neq is O(dx) and changes by O(dx^2) over a cell, so
 *                the copy is second order. Equilibrium where no fluid
 *                neighbour exists.
 * A neighbour counts when its flag is plain fluid (not solid, ghost, or
 * itself uncovered in this step). Periodic axes wrap. */
#ifndef FLUID_REFILL_H
#define FLUID_REFILL_H

#include "../common/scene.h"
#include "grid.h"
#include "layout.h"

struct spheres_s;

#include <stdint.h>

/* cell: allocated coordinates X of the block; normal: unit outward normal of
 * the sphere at the cell; us: surface velocity (lattice). Its neighbours may
 * be cells of other ranks (spheres_cell: the sphere halo). Writes the 19
 * populations of the cell (its post-collision slots in p) and returns their
 * momentum in mom[3]. */
void refill_cell(refill_t kind, struct spheres_s *sp, const grid_t *g, const uint8_t *flags, const pops_t *p,
                 const int X[3], const double normal[3], const double us[3], double mom[3]);

#endif
