/* walls.h — the domain faces as a list of ghost links.
 *
 * Every population that an interior cell pulls from a ghost cell is one link:
 * the slot to write (ghost cell, direction q) and how to get its value from
 * post-collision populations of interior cells:
 *   copy        free-slip faces (specular reflection: the mirrored direction
 *               from the cell beside the ghost; where a sphere covers that
 *               cell, bounce-back of the fluid cell's own population: walls.c
 *               fill_links);
 *   bounce      half-way bounce-back, with the moving-wall term
 *               6 w_q rho c_q.u_w (Ladd, J. Fluid Mech. 271 (1994) 285)
 *               for moving walls and velocity inlets (a link through the
 *               edge of an inlet and a wall is the wall's with the inlet's
 *               velocity: every cell next to an inlet receives rho U);
 *               with TRT at a magic
 *               parameter Lambda other than 3/16, no-slip and moving walls
 *               add the velocity kappa P_t (u(x_f) - 2 u(x_f + n) + u(x_f + 2n))
 *               to the wall's, kappa = (16 Lambda - 3)/24, n the inward
 *               normal, P_t the tangential part: half-way bounce-back puts
 *               a parabolic flow's wall where it belongs only at Lambda = 3/16
 *               and otherwise slips by u_s = (16 Lambda - 3)/24 g/nu (measured
 *               exactly so for tau 0.6-2, Lambda 1/8-1/3: issue 11), and
 *               -kappa u'' with u'' = -g/nu cancels that for any tangential
 *               parabolic flow, the second difference being exact there
 *               (not on a link through an edge of two walls of one kind,
 *               which has no one normal: plain bounce-back);
 *   anti        pressure outlet: the non-equilibrium extrapolation of
 *               Guo, Zheng & Shi, Chinese Phys. 11 (2002) 366, from the
 *               ghost's own upstream cell: the ghost x_g = x_f - c_q lies
 *               across the face from x_s = x_f - c_t (c_t the part of c_q
 *               along the face), and
 *                 f_q(x_f) = f~_q(x_s) + f_q^eq(2 rho_w - rho_f, u_f)
 *                                      - f_q^eq(rho_f, u_f),
 *               a zero normal gradient of the post-collision populations
 *               with the density extrapolated through the face to rho_w.
 *               A developed flow continues unchanged to the face. (Anti-
 *               bounce-back, Ginzburg, Verhaeghe & d'Humieres 2008, -f~_qbar
 *               + 2 w_q rho_w [1 + 4.5 (c.u_w)^2 - 1.5 u_w^2], sent back the
 *               opposite diagonal, whose shear part has the other sign: a
 *               transverse velocity of 0.11 U in a channel's last cells.)
 *               x_s across a tangential face: periodic, its image; free-
 *               slip, x_f with the tangential component mirrored; another
 *               rank's cell, the value the exchange leaves in the in-slot
 *               of q of x_f + c_n (read after it); inside a sphere, x_f's.
 * Where a link crosses two non-periodic faces (an edge), the stronger
 * condition wins: no-slip, moving wall, inlet, outlet, free-slip; any of
 * them wins over a periodic face. Its velocity: across an inlet, the
 * inlet's; across two (three) moving walls, the mean of theirs, so that it
 * does not depend on the order of the axes. Periodic faces need no list: their ghost
 * layers are copied (walls.c periodic_axis) before the links are filled. */
#ifndef FLUID_WALLS_H
#define FLUID_WALLS_H

#include "../common/scene.h"
#include "decomp.h"
#include "grid.h"
#include "layout.h"
#include "units.h"

#include <stddef.h>
#include <stdint.h>

typedef enum { LINK_COPY, LINK_BOUNCE, LINK_ANTI } link_kind_t;

/* A link writes in_slot(q, cell) (layout.h): the population that the fluid
 * cell receives from its ghost neighbour cell - c_q. */
typedef struct {
    size_t cell;  /* the fluid cell the link ends in */
    size_t cell2; /* anti: x_s (walls.h above; on another rank its ghost); bounce: the next cell inwards, for
                   * the slip correction (cell + 2 (cell2 - cell) the one after), cell if none */
    double coef;  /* bounce: 6 w_q c_q.u_w (times rho); anti: rho_w */
    int16_t q;
    int16_t kind;
    int16_t axis;  /* bounce: the axis normal to the face (slip correction); anti: the direction read at x_s */
    int16_t pinch; /* bounce of a no-slip or moving wall: a pinched pair is closed (walls.c fill_links);
                    * anti: x_s is another rank's */
    size_t cell3;  /* bounce with pinch: the cell x_f + c_q, across a periodic face its image in the block
                    * (whose flags the sphere stage sets; the ghost's it leaves): solid, the pair is pinched;
                    * anti with x_s on another rank: x_f + c_n, whose in-slot of q holds f~_q(x_s) */
} ghost_link_t;

/* Copy link: in_slot(q, cell) <- post_slot(sq, src); 12 bytes, for the many
 * links of periodic faces (a grid of at most 2^32 cells per process). */
typedef struct {
    uint32_t cell, src;
    uint8_t q, sq;
} copy_link_t;

/* What a link reads of the cells' moments, taken before the step changes
 * them (walls_links_prepare): bounce, rho of its cell and the slip
 * correction's term 6 w_q rho c_q.u_k, and a pinched pair's f~_q(x_f); anti,
 * f~_q(x_s) (x_f's where x_s is on another rank or a sphere's) and the
 * equilibrium's shift. */
typedef struct {
    double v[3];
} link_moments_t;

typedef struct {
    ghost_link_t *links; /* bounce and anti links */
    link_moments_t *pre; /* per link */
    size_t nlinks;
    copy_link_t *copies; /* free-slip copy links in cell order: a tight, cache-friendly loop */
    size_t ncopies;
    size_t nlinks_early, ncopies_early; /* the first ones: cells in inner rows (walls_links) */
    int periodic[3];     /* periodic axes with one rank: filled by a copy of the ghost layers, no list (walls.c) */
    double kappa;        /* the slip correction of no-slip and moving walls (above); 0 without */
    const uint8_t *flags; /* the cell flags (fluid.c, cellflags.h): the correction reads fluid cells only */
    decomp_t *d;         /* the block (not owned): faces to other ranks are filled by its exchange */
} walls_t;

/* The links of the block's faces that are faces of the domain (d: the
 * block; global coordinates for inlet profiles). */
status_t walls_build(walls_t *w, const grid_t *g, const scene_t *s, const units_t *u, decomp_t *d, const log_t *log);
void walls_free(walls_t *w);
/* Writes the populations that interior cells receive from ghost cells: the
 * periodic copy and the exchange with other ranks first, then the links. */
void walls_fill(const walls_t *w, const grid_t *g, const pops_t *p);
/* walls_fill in its steps, for the update of the inner rows while the
 * exchange is in flight (fluid.c step_overlapped; an inner row: y and z
 * two or more cells from the block's faces):
 *   walls_links_prepare  the moments the links read, before any cell is
 *                        updated (in place, that update overwrites the
 *                        post-collision values of the cells it pulls from);
 *   walls_halo_early     the local periodic copy of x where the inner rows
 *                        read it: all of it in the PULL and SWAPPED states
 *                        (x comes first, nothing it copies depends on
 *                        another axis); in the PUSHED state (axes z, y, x)
 *                        the inner rows only;
 *   walls_links EARLY    the links of cells in inner rows (x faces);
 *   walls_halo_axes      the axes whose ghost layers are copied or
 *                        exchanged, in the order the layout state needs
 *                        (returns how many); each is begun (the local copy,
 *                        or the exchange posted; rest = 1: without what
 *                        walls_halo_early did) and ended in that order;
 *   walls_links LATE     the other links.
 * walls_halo_early and the early links write only what cells of inner rows
 * receive, the rest only what cells of other rows receive. */
typedef enum { WALLS_ALL, WALLS_EARLY, WALLS_LATE } walls_part_t;
void walls_links_prepare(const walls_t *w, const pops_t *p);
void walls_halo_early(const walls_t *w, const grid_t *g, const pops_t *p);
int walls_halo_axes(const walls_t *w, const pops_t *p, int axes[3]);
void walls_halo_begin(const walls_t *w, const grid_t *g, const pops_t *p, int a, int rest);
void walls_halo_end(const walls_t *w, const grid_t *g, const pops_t *p, int a);
void walls_links(const walls_t *w, const pops_t *p, walls_part_t part);

#endif
