/* walls.c — applies the ghost links of the domain faces every step (walls.h;
 * walls_build.c builds them): the periodic ghost layers, the halo exchange's
 * order, and the bounce, copy and anti links. Reads are from post-collision
 * values of interior cells only and every in_slot is written by at most one
 * link, so the fill is order-independent and runs in parallel. */
#include "walls.h"

#include "cellflags.h"
#include "lattice.h"
#include "spheres.h"

#include <string.h>

static inline void moments(const pops_t *p, size_t cell, double *rho, double u[3])
{
    double j[3];
    *rho = pops_moments(p, cell, j);
    for (int a = 0; a < 3; a++) {
        u[a] = j[a] / *rho;
    }
}

/* Periodic faces without a list: the classic ghost-layer copy, one axis after
 * the other, so that populations that cross an edge of two periodic faces
 * wrap on both axes. Only the directions that cross the face are copied.
 *   PULL, SWAPPED  the post-collision value of a cell sits at the cell (slot q,
 *                  or qbar): each ghost cell receives it from the interior cell
 *                  it wraps to; axes x, y, z in turn, the ghost cells of the
 *                  axes already done included.
 *   PUSHED         the push kernel left the values of the cells next to a face
 *                  in the ghost cells beyond it (slot q at y + c_q): each is
 *                  moved to the interior cell the ghost wraps to; axes z, y, x
 *                  in turn, the ghost cells of the axes still to come included
 *                  (in both orders: the axes before a in x, y, z).
 * Links across a periodic and a non-periodic face belong to the wall (walls
 * list, filled afterwards), which overwrites what this copy wrote there. */
enum { PERIODIC_AHEAD = 8 };

/* The ghost cell at coordinate `ghost` of axis a and the interior cell at
 * `wrapped` it wraps to, both at (i, j) on the axes a + 1 and a + 2. */
static inline void ghost_pair(const grid_t *g, int a, int ghost, int wrapped, int i, int j, size_t *gi, size_t *wi)
{
    int X[3];
    X[a] = ghost;
    X[(a + 1) % 3] = i;
    X[(a + 2) % 3] = j;
    *gi = grid_index(g, X[0], X[1], X[2]);
    X[a] = wrapped;
    *wi = grid_index(g, X[0], X[1], X[2]);
}

static void periodic_axis(const grid_t *g, const pops_t *p, int a, const int lo[3], const int hi[3])
{
    const int push = p->state == LAYOUT_PUSHED, n = g->n[a];
    int qs[5], nq = 0;
    if (p->state == LAYOUT_MOMENTS) {
        /* the ghost's side-store slot q receives f~_q of the cell it wraps
         * to (rebuilt from its moments, or a ghost of an axis done before) */
        for (int side = 0; side < 2; side++) {
            nq = lb_crossing(a, side == 0 ? 1 : -1, qs);
            const int ghost = side == 0 ? 0 : n + 1, wrapped = side == 0 ? n : 1;
            const int b = (a + 1) % 3, c = (a + 2) % 3;
#pragma omp parallel for collapse(2) schedule(static)
            for (int j = lo[c]; j <= hi[c]; j++) {
                for (int i = lo[b]; i <= hi[b]; i++) {
                    size_t gi, wi;
                    ghost_pair(g, a, ghost, wrapped, i, j, &gi, &wi);
                    for (int k = 0; k < nq; k++) {
                        pops_copy_post(p, pops_post_slot(p, qs[k], gi), qs[k], wi);
                    }
                }
            }
        }
        return;
    }
    for (int side = 0; side < 2; side++) {
        /* ghost at coordinate 0 (side 0) or n + 1 (side 1); its directions */
        nq = lb_crossing(a, push ? (side == 0 ? -1 : 1) : (side == 0 ? 1 : -1), qs);
        size_t slot[5]; /* where each direction's array starts */
        for (int k = 0; k < nq; k++) {
            slot[k] = (size_t)(p->state == LAYOUT_SWAPPED ? lb_opposite(qs[k]) : qs[k]) * p->n;
        }
        const int ghost = side == 0 ? 0 : n + 1, wrapped = side == 0 ? n : 1;
        const int b = (a + 1) % 3, c = (a + 2) % 3;
#pragma omp parallel for collapse(2) schedule(static)
        for (int j = lo[c]; j <= hi[c]; j++) {
            for (int i = lo[b]; i <= hi[b]; i++) {
                size_t gi, wi;
                ghost_pair(g, a, ghost, wrapped, i, j, &gi, &wi);
                if (a == 0 && i + PERIODIC_AHEAD <= hi[b]) {
                    /* along x the values are a row apart, a cache line each, on a
                     * new page every few rows where the hardware prefetcher stops:
                     * ask for the lines PERIODIC_AHEAD rows on */
                    const ptrdiff_t d = (ptrdiff_t)PERIODIC_AHEAD * (ptrdiff_t)g->s[0];
                    for (int k = 0; k < nq; k++) {
                        pops_prefetch(p, slot[k] + (size_t)((ptrdiff_t)gi + d), 1);
                        pops_prefetch(p, slot[k] + (size_t)((ptrdiff_t)wi + d), 1);
                    }
                }
                for (int k = 0; k < nq; k++) {
                    if (push) {
                        pops_copy(p, slot[k] + wi, slot[k] + gi);
                    } else {
                        pops_copy(p, slot[k] + gi, slot[k] + wi);
                    }
                }
            }
        }
    }
}

int walls_halo_axes(const walls_t *w, const pops_t *p, int axes[3])
{
    const int push = p->state == LAYOUT_PUSHED;
    int m = 0;
    for (int k = 0; k < 3; k++) {
        const int a = push ? 2 - k : k;
        if (w->periodic[a] || decomp_exchanged(w->d, a, 0) || decomp_exchanged(w->d, a, 1)) {
            axes[m++] = a;
        }
    }
    return m;
}

/* The rows (b, c) of the x axis's copy that are not inner rows, as four
 * boxes of lo..hi: y outside 2 .. n - 1 at any z, then z outside at inner y. */
static void x_outer_rows(const grid_t *g, const int lo[3], const int hi[3], int blo[4][3], int bhi[4][3])
{
    for (int k = 0; k < 4; k++) {
        memcpy(blo[k], lo, 3 * sizeof(int));
        memcpy(bhi[k], hi, 3 * sizeof(int));
    }
    bhi[0][1] = 1;
    blo[1][1] = g->n[1];
    for (int k = 2; k < 4; k++) {
        blo[k][1] = 2;
        bhi[k][1] = g->n[1] - 1;
    }
    bhi[2][2] = 1;
    blo[3][2] = g->n[2];
}

void walls_halo_early(const walls_t *w, const grid_t *g, const pops_t *p)
{
    if (!w->periodic[0]) {
        return;
    }
    int lo[3], hi[3];
    decomp_exchange_range(w->d, g->n, 0, lo, hi);
    if (p->state == LAYOUT_PUSHED) {
        lo[1] = lo[2] = 2;
        hi[1] = g->n[1] - 1;
        hi[2] = g->n[2] - 1;
    }
    periodic_axis(g, p, 0, lo, hi);
}

void walls_halo_begin(const walls_t *w, const grid_t *g, const pops_t *p, int a, int rest)
{
    int lo[3], hi[3];
    decomp_exchange_range(w->d, g->n, a, lo, hi);
    if (w->periodic[a] && rest && a == 0) {
        if (p->state == LAYOUT_PUSHED) {
            int blo[4][3], bhi[4][3];
            x_outer_rows(g, lo, hi, blo, bhi);
            for (int k = 0; k < 4; k++) {
                periodic_axis(g, p, 0, blo[k], bhi[k]);
            }
        }
    } else if (w->periodic[a]) {
        periodic_axis(g, p, a, lo, hi);
    } else {
        /* the same copy with the other side on another rank */
        decomp_exchange_begin(w->d, g, p, a, lo, hi);
    }
}

void walls_halo_end(const walls_t *w, const grid_t *g, const pops_t *p, int a)
{
    if (!w->periodic[a]) {
        decomp_exchange_end(w->d, g, p);
    }
}

/* 1 for a cell a sphere covers now (no flags: no spheres) */
static inline int solid_cell(const walls_t *w, size_t cell)
{
    return w->flags != NULL && (cellflags_get(w->flags, cell) & FLAG_SOLID) != 0;
}

/* 1 for a bounce link whose pair is pinched: the cell's neighbour away from
 * the wall along c_q is a sphere's (walls.h ghost_link_t.pinch) */
static inline int pinched(const walls_t *w, const ghost_link_t *l) { return l->pinch && solid_cell(w, l->cell3); }

void walls_fill(const walls_t *w, const grid_t *g, const pops_t *p)
{
    walls_links_prepare(w, p);
    int axes[3];
    const int m = walls_halo_axes(w, p, axes);
    for (int k = 0; k < m; k++) {
        walls_halo_begin(w, g, p, axes[k], 0);
        walls_halo_end(w, g, p, axes[k]);
    }
    walls_links(w, p, WALLS_ALL);
}

enum { WALLS_AHEAD = 16 };

/* walls_links_prepare's share of the links from each thread, with the
 * layout state and precision known at compile time (POPS_SPECIALISE): the
 * slots of a cell's 19 values are then straight arithmetic, not a switch
 * per value. */
static inline __attribute__((always_inline)) void prepare_links(const walls_t *w, const pops_t *p0,
                                                                layout_state_t state, int single)
{
    const pops_t pf = pops_fixed(p0, state, single);
    const pops_t *p = &pf;
    const ptrdiff_t n = (ptrdiff_t)w->nlinks;
    /* the links of a cell are consecutive (walls_build): its moments once,
     * the slip term once per normal (a cell at an edge has links of two faces) */
    size_t last = (size_t)-1;
    int last_axis = -1;
    double rho_last = 0.0, u_last[3] = {0.0, 0.0, 0.0}, uk_last[3] = {0.0, 0.0, 0.0};
#pragma omp for schedule(static)
    for (ptrdiff_t i = 0; i < n; i++) {
        const ghost_link_t *l = &w->links[i];
        const int slip = w->kappa != 0.0 && l->kind == LINK_BOUNCE && l->cell2 != l->cell;
        if (l->kind == LINK_BOUNCE && (l->coef != 0.0 || slip)) {
            if (l->cell != last) {
                last = l->cell;
                last_axis = -1;
                if (w->kappa != 0.0) {
                    moments(p, last, &rho_last, u_last);
                } else {
                    double j[3]; /* no slip term: the density only */
                    rho_last = pops_moments(p, last, j);
                }
            }
            /* the cells' populations are a cache line each and cold (the
             * kernel's pass evicted them): ask for those of the cell
             * WALLS_AHEAD links on */
            if (i + WALLS_AHEAD < n && w->links[i + WALLS_AHEAD].cell != w->links[i + WALLS_AHEAD - 1].cell) {
                const size_t ahead = w->links[i + WALLS_AHEAD].cell;
                for (int q = 0; q < LB_Q; q++) {
                    pops_prefetch(p, pops_post_slot(p, q, ahead), 0);
                }
            }
            if (slip && l->axis != last_axis) {
                /* kappa P_t u'' along the inward normal, from fluid cells only (a sphere may cover them) */
                last_axis = l->axis;
                const size_t c2 = l->cell2, c3 = 2 * l->cell2 - l->cell;
                uk_last[0] = uk_last[1] = uk_last[2] = 0.0;
                if (w->flags == NULL || (cellflags_get(w->flags, c2) == 0 && cellflags_get(w->flags, c3) == 0)) {
                    double r2, r3, u2[3], u3[3];
                    moments(p, c2, &r2, u2);
                    moments(p, c3, &r3, u3);
                    for (int a = 0; a < 3; a++) {
                        uk_last[a] = a == l->axis ? 0.0 : w->kappa * (u_last[a] - 2.0 * u2[a] + u3[a]);
                    }
                }
            }
            w->pre[i].v[0] = rho_last;
            w->pre[i].v[1] = slip ? 6.0 * lb_w[l->q] * rho_last *
                                        (lb_c[l->q][0] * uk_last[0] + lb_c[l->q][1] * uk_last[1] +
                                         lb_c[l->q][2] * uk_last[2])
                                  : 0.0;
        } else if (l->kind == LINK_BOUNCE) {
            /* a resting wall where the domain is too thin for the slip term
             * (cell2 == cell): plain bounce-back; walls_links still adds both */
            w->pre[i].v[0] = w->pre[i].v[1] = 0.0;
        }
        if (l->kind == LINK_BOUNCE) {
            /* a pinched pair's other value, f~_q(x_f), read here, before any
             * update: in place it may sit in x_f + c_q's slots, which an
             * update of that cell (solid ones too with AGGLO_SKIP_SOLID=0)
             * overwrites before the late links of step_overlapped run */
            w->pre[i].v[2] = pinched(w, l) ? pops_post(p, l->q, l->cell) : 0.0;
        } else if (l->kind == LINK_ANTI) {
            /* the non-equilibrium extrapolation (walls.h): x_s's f~_q (where
             * a sphere covers x_s, or until the exchange brings it, x_f's) and
             * the ghost's equilibrium shifted to the density 2 rho_w - rho_f */
            double r1, u1[3];
            moments(p, l->cell, &r1, u1);
            w->pre[i].v[0] =
                l->pinch || solid_cell(w, l->cell2) ? pops_post(p, l->q, l->cell) : pops_post(p, l->axis, l->cell2);
            w->pre[i].v[1] =
                lb_feq(l->q, 2.0 * l->coef - r1, u1[0], u1[1], u1[2]) - lb_feq(l->q, r1, u1[0], u1[1], u1[2]);
        }
    }
}

void walls_links_prepare(const walls_t *w, const pops_t *p)
{
#pragma omp parallel
    {
#define PREPARE(state, single) prepare_links(w, p, state, single)
        POPS_SPECIALISE(p, PREPARE);
#undef PREPARE
    }
}

/* walls_links' share of the copies and links from each thread, with the
 * layout state and precision known at compile time (as prepare_links). */
static inline __attribute__((always_inline)) void fill_links(const walls_t *w, const pops_t *p0, walls_part_t part,
                                                             layout_state_t state, int single)
{
    const pops_t pf = pops_fixed(p0, state, single);
    const pops_t *p = &pf;
    const ptrdiff_t c0 = part == WALLS_LATE ? (ptrdiff_t)w->ncopies_early : 0;
    const ptrdiff_t nc = part == WALLS_EARLY ? (ptrdiff_t)w->ncopies_early : (ptrdiff_t)w->ncopies;
    const ptrdiff_t l0 = part == WALLS_LATE ? (ptrdiff_t)w->nlinks_early : 0;
    const ptrdiff_t n = part == WALLS_EARLY ? (ptrdiff_t)w->nlinks_early : (ptrdiff_t)w->nlinks;
    const copy_link_t *restrict cp = w->copies;
#pragma omp for schedule(static) nowait
    for (ptrdiff_t i = c0; i < nc; i++) {
        const size_t dst = pops_in_slot(p, cp[i].q, cp[i].cell);
        if (solid_cell(w, cp[i].src)) {
            /* The mirrored source lies inside a sphere that nearly touches
             * the face (a gap below half a cell): what it holds is no fluid
             * value (in place the update skips it, kernel_skip.c), and the
             * sphere's links do not cover this population (its upwind cell
             * is a ghost). The reflected path meets the sphere between the
             * face and that cell: the sphere's mirror image across the
             * face sends the population back, half-way bounce-back at rest,
             * f_q(x) = f~_qbar(x), what a sphere link of `bounce_back`
             * gives for a sphere at rest. Its momentum goes to the face,
             * not to the sphere (README "Known problems"). Before, the copy
             * took the solid cell's stale values: a fixed sphere 0.3 cells
             * from a free-slip floor had a drag that changed by 5% with
             * AGGLO_SKIP_SOLID, and NaN in the solid cells reached the
             * whole flow (CUnit layouts). */
            pops_copy_post(p, dst, lb_opposite(cp[i].q), cp[i].cell);
        } else {
            /* the mirrored direction has the same weight */
            pops_copy_post(p, dst, cp[i].sq, cp[i].src);
        }
    }
#pragma omp for schedule(static)
    for (ptrdiff_t i = l0; i < n; i++) {
        const ghost_link_t *l = &w->links[i];
        const size_t dst = pops_in_slot(p, l->q, l->cell);
        switch (l->kind) {
        case LINK_COPY:
            break; /* all in w->copies */
        case LINK_BOUNCE: {
            double bounced = pops_post(p, lb_opposite(l->q), l->cell);
            if (pinched(w, l)) {
                /* a pinched pair: the cell lies between this wall and a
                 * sphere along c_q, so both its populations along that line
                 * are sent back by walls. Each wall (here, and the sphere's
                 * link: sphere_fill.c) sends back the mean of the two instead
                 * of the one that reached it, with its whole moving-wall
                 * term: the pair keeps its mass as with bounce-back, which
                 * swaps the two each step and keeps their difference for
                 * ever (a momentum that no collision damps, as the cell has
                 * no fluid neighbour along c_q: README "Touching surfaces") */
                bounced = 0.5 * (bounced + w->pre[i].v[2]);
            }
            const double v = l->coef != 0.0 || w->kappa != 0.0
                                 ? bounced + l->coef * w->pre[i].v[0] + (w->kappa != 0.0 ? w->pre[i].v[1] : 0.0)
                                 : bounced;
            pops_write(p, l->q, dst, v);
            break;
        }
        case LINK_ANTI: {
            double src = w->pre[i].v[0];
            if (l->pinch && !solid_cell(w, l->cell2)) {
                src = pops_read(p, l->q, pops_in_slot(p, l->q, l->cell3)); /* x_s on another rank */
            }
            pops_write(p, l->q, dst, src + w->pre[i].v[1]);
            break;
        }
        }
    }
}

void walls_links(const walls_t *w, const pops_t *p, walls_part_t part)
{
#pragma omp parallel
    {
#define FILL(state, single) fill_links(w, p, part, state, single)
        POPS_SPECIALISE(p, FILL);
#undef FILL
    }
}
