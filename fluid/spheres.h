/* spheres.h — moving spheres as curved moving boundaries (the paper's
 * Section 4, Eq. 5-7, and DESIGN section 6).
 *
 * Every step, in this order (spheres_map, then spheres_fill after the
 * domain walls):
 *   map     cells whose centre lies inside or on a sphere are solid; cells that
 *           become solid give their momentum to the sphere that covers them,
 *           cells that become fluid are refilled (refill.c) and take their
 *           momentum from the sphere that left them (Aidun, Lu & Ding 1998);
 *   links   one link per fluid cell x_f and direction q with x_f + c_q solid:
 *           delta in (0, 1] from a ray-sphere intersection (Eq. 5), the
 *           nearest hit over all spheres wins;
 *   fill    the population that x_f pulls from the solid side is computed
 *           from post-collision values at x_f, x_f - c_q, x_f - 2 c_q by the
 *           scene's scheme (boundary.c) with the moving-wall term, and the
 *           momentum exchanged on the link is added to the sphere (Eq. 7).
 * Lattice coordinates: the centre of allocated cell i is at X = i, so a
 * point x (m) is at X = x/dx + 1/2. Everything here is in lattice units. */
#ifndef FLUID_SPHERES_H
#define FLUID_SPHERES_H

#include "../common/exact_sum.h"
#include "../common/scene.h"
#include "boundary.h"
#include "cellflags.h"
#include "decomp.h"
#include "grid.h"
#include "layout.h"
#include "units.h"

#include <stddef.h>
#include <stdint.h>

/* the sums of a sphere's fill: force (3), torque (3), the drag coefficients
 * zt, zr, the density and the number of its links outside the film zone, and
 * the mass its links gave the fluid beyond bounce-back's and the weight the
 * next fill shares the debt out by (sphere_fill.c "mass balance") */
#define SPHERE_NACC 12

typedef struct {
    double c[3], v[3], w[3]; /* centre (lattice coordinates), velocity, angular velocity (lattice units) */
    double r;                /* radius, cells */
    int body;
    int motion;              /* MOTION_FREE, MOTION_FIXED, MOTION_PRESCRIBED */
    double cb0[3], rel0[3];  /* prescribed: body centroid at t0, centre minus centroid at t0 */
    double vbody[3];         /* prescribed: velocity of the body centroid */
    double f[3], t[3];       /* load of the last step: force, torque about c */
    xsum_t acc[SPHERE_NACC]; /* the load while it is summed: f, t, zt, zr, and the density outside the film
                                zone (exact: any threads and ranks) */
    double fprev[3], tprev[3];
    double zt, zr;           /* drag coefficients of the last step: -dF/dv and -dT/dw (isotropic parts) */
    double rho_film;         /* mean density at the fluid cells of its links outside the film zone, last step:
                                the ambient density the momentum exchange is centred on (sphere_fill.c) */
    double mass_debt;        /* mass its links gave the fluid beyond bounce-back's flux and not yet taken back,
                                after the last fill and the one before, and the weight sum_links w_q (1 -
                                3 c_q.u_w) of the last fill (sphere_fill.c "mass balance") */
    double mass_debt_prev;
    double mass_weight;
    double density_ratio;    /* particle / fluid density */
    double cmap[3];          /* centre at the last map stage: a sphere that has not moved keeps its links */
    int averaging;           /* deliver the load averaged over two steps (common/coupling.h) */
    double kappa_risky;      /* free and not implicit with averaging: the feedback number h zeta / m; else 0 */
    /* period-2 watch (fluid.c): the last three motions (velocity, surface
     * speed), steps in a row that alternate and that grow, warned once */
    double hist[3][6], hist_d[6]; /* motion (v, w r) at steps n, n-1, n-2; the last second difference */
    double amp0;                  /* amplitude at the start of the current alternating run */
    double amp_prev, amp_grow0;   /* last amplitude; amplitude where the current growing run began */
    int nhist, nalt, ngrow, warned;
} sphere_t;

/* Cell flags of the sphere stage (CELL_FLUID 0, CELL_SOLID 1, CELL_GHOST 2
 * of fluid_internal.h, and two bits of its own): four bits, packed two cells
 * to a byte in the grid's flags (cellflags.h). */
enum { FLAG_SOLID = 1, FLAG_GHOST = 2, FLAG_MARK = 4, FLAG_FRESH = 8 };

/* A cell the sphere stage reads: an index of the block's grid, or on
 * several ranks SPHERE_EXT + k, cell k of the sphere halo (sphere_halo.c):
 * a cell of another rank within two cells of the block, near a sphere. */
#define SPHERE_EXT ((size_t)1 << 62)

typedef struct {
    size_t n, cap;     /* cells held */
    double *val;       /* n x LB_Q post-collision populations */
    uint8_t *flag;     /* FLAG_SOLID / FLAG_FRESH (spheres.c) of each, from the geometry */
    int (*Y)[3];       /* local allocated coordinates (-1 .. n + 2) */
    uint64_t *hkey;    /* hash of Y -> k (open addressing) */
    int64_t *hval;
    size_t hcap;
    size_t nrecv[27], recv0[27]; /* per direction of the owner (dx+1)*9 + (dy+1)*3 + dz+1 */
    size_t *send[27], nsend[27], capsend[27]; /* grid indices of this block's cells each neighbour holds */
    double *sbuf;
    size_t scap;
    long misses;       /* cells the stage looked for and the halo did not hold (must stay 0) */
} sphere_halo_t;

/* Link from fluid cell x_f along c_q into a solid cell: it writes
 * in_slot(qbar, x_f) (layout.h), the population x_f receives from the solid.
 * 72 bytes. Its geometry is derived where it is used, not kept: delta
 * (Eq. 5) and the wall point from the cell (key), q and the sphere's centre
 * (spheres_link_cell, spheres_link_delta, spheres_wall_point), and from delta and have the scheme's
 * coefficients (boundary_coefficients): f_new = sum a_k f~_q(x_f - k c_q) +
 * sum b_k f~_qbar(x_f - k c_q) + moving term + corr n_q^-(x_f),
 * pre-collision (boundary.h). (Kept, they made a record of 168 bytes, then
 * 104, that the links' stage wrote and the fill read every step for a
 * moving sphere.) */
typedef struct {
    size_t xf, xff, xfff; /* interior cells along -c_q (periodic wrap applied) */
    double fnew;          /* outer: the value to write, held back (SPHERES_HOLD_OUTER) */
    /* multireflection: the pre-collision pair (f_q, f_qbar) of x_f for the
     * next fill, which the fill keeps as it goes: f_q is the post-collision
     * f~_q(x_f - c_q) it reads (it streams to x_f), f_qbar the value it
     * writes. In place the collision may have forgotten them (omega_minus
     * near 1). Carried over a rebuild of the links by key (spheres_carry_t). */
    double pre[2];
    uint64_t key;         /* (unwrapped cell, q), increasing along a sphere's list (sphere_links.c) */
    int sphere;
    int film;             /* the film partner whose surface lies within the lubrication cut-off of the
                           * wall point: a sphere m >= 0, a domain face -2 - face; -1 none (spheres_fill) */
    uint8_t q;
    uint8_t fresh;        /* x_f was uncovered this step: no multireflection correction */
    uint8_t outer;        /* x_f lies in an outer row of the block: y or z at its faces (spheres_fill) */
    uint8_t have;         /* x_f - c_q fluid: bit 0; x_f - 2 c_q too: bit 1 (boundary_coefficients);
                           * bit 2 (SPHERES_PINCHED): x_f - c_q a sphere's or a no-slip/moving wall's, a
                           * pinched pair (spheres_fill); bit 3 (SPHERES_PINCHED_SPHERE): a sphere's */
    uint8_t has_pre;
    uint8_t film_tie;     /* another film partner is as near: the wall point is shared (sphere_others.c) */
} sphere_link_t;

/* A link's pre-collision pair while the links are rebuilt, or saved in a
 * state (fluid/state.c). */
typedef struct {
    uint64_t key;
    double pre[2];
} spheres_carry_t;

/* |1 - omega_minus| below which multireflection cannot recover the
 * pre-collision populations from the post-collision ones (spheres_fill): a
 * link without its kept pair (new this step) and without the other array
 * then goes without the correction for that step. */
#define SPHERES_MR_DECAY_MIN 0.05

/* The part of a sphere's mass debt (the mean of the last two) that a fill
 * returns to the fluid (sphere_fill.c "mass balance") */
#define SPHERES_MASS_GAIN 0.5

/* sphere_link_t.have: x_f lies between two walls along c_q, and the other
 * one is a sphere's, whose index xfff then holds (sphere_links.c pinched) */
#define SPHERES_PINCHED 4
#define SPHERES_PINCHED_SPHERE 8

typedef struct {
    sphere_link_t *l;
    size_t n, cap;
    spheres_carry_t *carry; /* the pairs of the last links while they are rebuilt, in key order */
    size_t ncarry, capcarry;
    size_t *inside;         /* the cells inside the sphere at the last map (spheres_map) */
    int32_t (*runs)[3];     /* the same cells of the block's interior as runs along x: interior row
                             * (y - 1) + ny (z - 1), first and last x (the update skips them) */
    size_t nruns, capruns;
    uint64_t *oldkey;       /* the keys of the links before a rebuild of this list alone (sphere_links.c) */
    size_t nold, capold;
    size_t ninside, capinside;
    int box_lo[3];          /* the first cell of the box the links were built in (sphere_links.c) */
    /* what a refresh needs to check (sphere_links.c sphere_refresh): the
     * links of the cells that another sphere's ray could reach once it has
     * moved by less than SPHERES_NEAR_MARGIN (their first links' indices),
     * the other spheres near this one and their centres when that was
     * found, and whether it holds: no link has a film partner or is fresh */
    size_t *near;
    size_t nnear, capnear;
    int *cand;
    double (*cand_c)[3];
    int ncand;
    size_t capcand;
    int checked;            /* near, cand, cand_c hold for the links as they are */
    int film_set;           /* some link may have a film partner */
    int fresh_set;          /* some link may be marked fresh */
    long near_refreshes;    /* refreshes that checked the near cells alone (a count for the tests) */
} link_list_t;

/* A part of a sphere's list that one thread fills, and its load
 * (spheres_fill). */
typedef struct {
    xsum_t acc[SPHERE_NACC];
    size_t begin, end;
    int sphere;
} spheres_fill_part_t;

typedef struct spheres_s {
    int n;
    sphere_t *s;
    /* per-step lists */
    link_list_t *lists;   /* the links of each sphere (spheres.c build_links) */
    size_t nlinks;        /* all spheres */
    size_t *solid;
    size_t nsolid, cap_solid;
    size_t *fresh; /* cells uncovered this step */
    size_t nfresh, cap_fresh;
    int *fresh_sphere;
    long covered_total, uncovered_total;
    long maps;                      /* maps that made a new list of solid cells (solid, nsolid) */
    long refreshed, refresh_failed; /* maps whose links were refreshed in place, or tried and rebuilt */
    long partial, partial_failed;   /* maps that rebuilt the dirty spheres' lists and refreshed the others, or
                                     * tried and rebuilt all (sphere_links.c) */
    uint8_t *dirty;                 /* per sphere: a cell within reach of it changed, or its box moved */
    spheres_fill_part_t *parts;     /* the parts of the lists the fill's threads take (spheres_fill) */
    size_t cap_parts;
    int (*changed)[3];              /* cells covered or uncovered by this map (global coordinates) */
    size_t nchanged, capchanged;
    int periodic[3];      /* periodic axes of the domain (period N) */
    int N[3], lo[3], nb[3]; /* the whole grid, this block's first cell and cells */
    grid_t grid;          /* this block's grid */
    int open[6];          /* block faces (2 axis + side) towards another rank (decomp.h) */
    decomp_t *dc;         /* the block (not owned) */
    sphere_halo_t halo;
    xsum_t *accbuf;       /* the loads of all spheres for their sum over ranks */
    double *kin;          /* 9 per sphere: the kinematics rank 0 sends (fluid.c) */
    boundary_scheme_t scheme;
    refill_t refill;
    force_method_t force;
    int first;
    int stale;            /* the links do not match the flags (a restored state): map anew */
    int carried;          /* the lists' carry holds the pairs of a restored state (state.c) */
    double omega_minus;
    double film_cutoff;   /* cells: the lubrication cut-off of the film zone, 0 without a film (spheres_fill) */
    int film_face[6];     /* 1: a face that carries a film (no-slip, moving, free-slip walls) */
    int pinch_face[6];    /* 1: a face that closes a pinched pair (no-slip, moving walls: sphere_links.c) */
    double body_force[3]; /* lattice: the equilibrium velocity is (j~ - F/2)/rho */
} spheres_t;

status_t spheres_init(spheres_t *sp, const scene_t *s, const units_t *u, const grid_t *g, decomp_t *dc,
                      const log_t *log);
void spheres_free(spheres_t *sp);

/* Map stage on post-collision populations p: flags, covering, refill, links. */
status_t spheres_map(spheres_t *sp, const grid_t *g, uint8_t *flags, const pops_t *p, const log_t *log);
/* Fill stage: boundary populations and the momentum exchanged per sphere.
 * Multireflection needs the pre-collision populations of x_f: each link
 * keeps them from its last fill (sphere_link_t.pre); a link new this step
 * recovers them from the post-collision ones away from omega_minus = 1
 * (spheres.c), and goes without the correction that step near it: the same
 * in either layout. A link writes what its x_f receives. With
 * SPHERES_HOLD_OUTER the links of cells in outer rows (y or z at a face of
 * the block) keep their values until spheres_write_outer: their slots are written by the
 * halo exchange too, which must come first, while every link must read
 * before the update of the inner rows (in place it overwrites values the
 * links read): fluid.c step_overlapped. */
typedef enum { SPHERES_ALL, SPHERES_HOLD_OUTER } spheres_part_t;
void spheres_fill(spheres_t *sp, const pops_t *p, spheres_part_t part);
void spheres_write_outer(spheres_t *sp, const pops_t *p);
/* After the fill of every link: each sphere's load of this step (summed
 * over ranks; collective). */
void spheres_loads(spheres_t *sp);
/* The pre-collision pairs the links hold (or, after a restore, carry) for
 * the next fill, for a state: the bytes they take, and copied out (in
 * sphere and key order, each sphere's count first). spheres_pairs_size: the
 * bytes of such a section of nspheres spheres at buf, (size_t)-1 if it does
 * not fit in size; spheres_pairs_in reads a section so checked, 0 when out
 * of memory. */
size_t spheres_pairs_bytes(const spheres_t *sp);
void spheres_pairs_out(const spheres_t *sp, unsigned char *buf);
size_t spheres_pairs_size(const unsigned char *buf, size_t size, int nspheres);
int spheres_pairs_in(spheres_t *sp, const unsigned char *buf);
/* Moves prescribed and fixed spheres by one step (dt = 1). Returns the first
 * prescribed sphere that now reaches beyond a face that is not periodic, its
 * face (2 axis + side) in *face, or -1. */
int spheres_advance_prescribed(spheres_t *sp, long step, int *face);
/* Wraps a centre (global lattice coordinates) onto the periodic axes. */
void spheres_wrap_centre(const spheres_t *sp, double c[3]);

/* Where the global allocated cell X (unwrapped) is for the block lo, n with
 * open faces `open`: 1 a cell of the block (Y its allocated coordinates),
 * 2 a cell of another rank within two cells of the block, 0 neither (beyond
 * a wall, or farther). */
int spheres_locate(const int lo[3], const int n[3], const int open[6], const int periodic[3], const int N[3],
                   const int X[3], int Y[3]);
/* 1 when the cells within r + reach of centre c (global lattice
 * coordinates, periodic images included) can meet the block lo, n widened
 * by two cells: a sphere far from a block costs it nothing. */
int spheres_near_block(const spheres_t *sp, const double c[3], double r, const int lo[3], const int n[3]);
/* spheres_cell for a cell beyond the block (a periodic image, or another
 * rank's cell in the sphere halo). */
int spheres_cell_beyond(spheres_t *sp, const grid_t *g, const uint8_t *flags, const int Y[3], size_t *ref,
                        uint8_t *flag);
/* The cell at local allocated coordinates Y as the stage reads it: 1 and
 * ref, flag (grid flags, or the halo's) when available, else 0. Inline for
 * a cell of the block, what the link scan reads for nearly every link. */
static inline int spheres_cell(spheres_t *sp, const grid_t *g, const uint8_t *flags, const int Y[3], size_t *ref,
                               uint8_t *flag)
{
    if (Y[0] >= 1 && Y[0] <= sp->nb[0] && Y[1] >= 1 && Y[1] <= sp->nb[1] && Y[2] >= 1 && Y[2] <= sp->nb[2]) {
        *ref = grid_index(g, Y[0], Y[1], Y[2]); /* a cell of the block: what spheres_locate gives */
        *flag = (uint8_t)cellflags_get(flags, *ref);
        return 1;
    }
    return spheres_cell_beyond(sp, g, flags, Y, ref, flag);
}
/* Post-collision population q of a cell reference. */
static inline double spheres_post(const spheres_t *sp, const pops_t *p, int q, size_t ref)
{
    return ref >= SPHERE_EXT ? sp->halo.val[(ref - SPHERE_EXT) * LB_Q + (size_t)q] : pops_post(p, q, ref);
}

/* sphere_halo.c: the halo's cells for the current centres (and their flags,
 * fresh from the centres at the last map), and the exchange of their
 * values. Collective: every rank calls them alike. */
status_t sphere_halo_plan(spheres_t *sp, const log_t *log);
status_t sphere_halo_exchange(spheres_t *sp, const pops_t *p, const log_t *log);
long sphere_halo_find(const sphere_halo_t *h, const int Y[3]);
void sphere_halo_free(sphere_halo_t *h);

#endif
