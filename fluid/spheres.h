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

#include "../common/scene.h"
#include "grid.h"
#include "layout.h"
#include "units.h"

#include <stddef.h>
#include <stdint.h>

typedef struct {
    double c[3], v[3], w[3]; /* centre (lattice coordinates), velocity, angular velocity (lattice units) */
    double r;                /* radius, cells */
    int body;
    int motion;              /* MOTION_FREE, MOTION_FIXED, MOTION_PRESCRIBED */
    double cb0[3], rel0[3];  /* prescribed: body centroid at t0, centre minus centroid at t0 */
    double vbody[3];         /* prescribed: velocity of the body centroid */
    double f[3], t[3];       /* load of the last step: force, torque about c */
    double fprev[3], tprev[3];
    double zt, zr;           /* drag coefficients of the last step: -dF/dv and -dT/dw (isotropic parts) */
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

/* Link from fluid cell x_f along c_q into a solid cell: it writes
 * in_slot(qbar, x_f) (layout.h), the population x_f receives from the solid. */
typedef struct {
    size_t xf, xff, xfff; /* interior cells along -c_q (periodic wrap applied) */
    double a[3], b[2];    /* f_new = sum a_k f~_q(x_f - k c_q) + sum b_k f~_qbar(x_f - k c_q) + moving term */
    double corr;          /* + corr n_q^-(x_f), pre-collision (multireflection) */
    double rw[3];         /* wall point minus sphere centre */
    int q, sphere;
    int fresh;            /* x_f was uncovered this step: no multireflection correction */
    double delta;
} sphere_link_t;

/* |1 - omega_minus| below which multireflection cannot recover the
 * pre-collision populations from the post-collision ones (spheres_fill); in
 * place, fluid_create refuses such a scene. */
#define SPHERES_MR_DECAY_MIN 0.05

typedef struct {
    sphere_link_t *l;
    size_t n, cap;
} link_list_t;

typedef struct {
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
    int periodic[3];
    boundary_scheme_t scheme;
    refill_t refill;
    force_method_t force;
    int first;
    int stale;            /* the links do not match the flags (a restored state): map anew */
    double omega_minus;
    double body_force[3]; /* lattice: the equilibrium velocity is (j~ - F/2)/rho */
} spheres_t;

status_t spheres_init(spheres_t *sp, const scene_t *s, const units_t *u, const grid_t *g, uint8_t *flags,
                      const log_t *log);
void spheres_free(spheres_t *sp);

/* Map stage on post-collision populations p: flags, covering, refill, links. */
status_t spheres_map(spheres_t *sp, const grid_t *g, uint8_t *flags, const pops_t *p, const log_t *log);
/* Fill stage: boundary populations and the momentum exchanged per sphere.
 * Multireflection needs the pre-collision populations of x_f: with two
 * arrays, prev is the other array (PULL state: the previous step's values
 * that x_f pulled); in place (prev NULL) they follow from the post-collision
 * ones (spheres.c). */
void spheres_fill(spheres_t *sp, const grid_t *g, const pops_t *p, const pops_t *prev);
/* Moves prescribed and fixed spheres by one step (dt = 1). */
void spheres_advance_prescribed(spheres_t *sp, const grid_t *g, long step);

#endif
