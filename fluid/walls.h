/* walls.h — the domain faces as a list of ghost links.
 *
 * Every population that an interior cell pulls from a ghost cell is one link:
 * the slot to write (ghost cell, direction q) and how to get its value from
 * post-collision populations of interior cells:
 *   copy        periodic faces, and free-slip faces (specular reflection:
 *               the mirrored direction from the cell beside the ghost);
 *   bounce      half-way bounce-back, with the moving-wall term
 *               6 w_q rho c_q.u_w (Ladd, J. Fluid Mech. 271 (1994) 285)
 *               for moving walls and velocity inlets;
 *   anti        anti-bounce-back pressure outlet (Ginzburg, Verhaeghe &
 *               d'Humieres 2008; Izquierdo & Fueyo 2008):
 *               f_q = -f~_qbar + 2 w_q rho_w [1 + 4.5 (c.u_w)^2 - 1.5 u_w^2],
 *               u_w extrapolated from the two cells next to the face.
 * Where a link crosses two non-periodic faces (an edge), the stronger
 * condition wins: no-slip, moving wall, inlet, outlet, free-slip. */
#ifndef FLUID_WALLS_H
#define FLUID_WALLS_H

#include "../common/scene.h"
#include "grid.h"
#include "units.h"

#include <stddef.h>

typedef enum { LINK_COPY, LINK_BOUNCE, LINK_ANTI } link_kind_t;

typedef struct {
    size_t dst;   /* q * ncells + ghost cell */
    size_t src;   /* slot read: copy from it, or the bounced population at the fluid cell */
    size_t cell;  /* the fluid cell the link ends in */
    size_t cell2; /* anti: the next cell inwards, for the extrapolation of u_w */
    double coef;  /* bounce: 6 w_q c_q.u_w (times rho); anti: rho_w */
    int q;
    int kind;
} ghost_link_t;

typedef struct {
    ghost_link_t *links; /* bounce and anti links */
    size_t nlinks;
    size_t *copies;      /* copy links as (dst, src) pairs, sorted by dst: a tight, cache-friendly loop */
    size_t ncopies;
} walls_t;

status_t walls_build(walls_t *w, const grid_t *g, const scene_t *s, const units_t *u, const log_t *log);
void walls_free(walls_t *w);
/* Fills the ghost slots of f (post-collision populations of one step). */
void walls_fill(const walls_t *w, const grid_t *g, double *f);

#endif
