/* walls_build.c — builds the ghost links of the domain faces (walls.h),
 * once: for every interior cell next to a face and every direction q whose
 * upwind neighbour x - c_q is a ghost cell beyond a non-periodic face
 * (periodic faces need no list: walls.c periodic_axis). walls.c fills them
 * every step. */
#include "walls.h"

#include "cellflags.h"
#include "lattice.h"
#include "spheres.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static int face_rank(face_type_t t)
{
    switch (t) {
    case FACE_NO_SLIP:
        return 5;
    case FACE_MOVING_WALL:
        return 4;
    case FACE_VELOCITY_INLET:
        return 3;
    case FACE_PRESSURE_OUTLET:
        return 2;
    case FACE_FREE_SLIP:
        return 1;
    case FACE_PERIODIC:
        return 0;
    }
    return 0;
}

/* Inlet velocity (lattice units) where link (cell xf, direction q) crosses
 * face f: uniform, or a parabola across every non-periodic tangential axis
 * with the given peak, evaluated at the crossing point x_f - c_q/2. */
static void inlet_velocity(const scene_t *s, const decomp_t *d, const units_t *u, int f, const int xf[3], int q,
                           double uw[3])
{
    const face_t *face = &s->domain.faces[f];
    double shape = 1.0;
    if (face->profile == PROFILE_PARABOLIC) {
        for (int a = 0; a < 3; a++) {
            if (a == f / 2 || s->domain.faces[2 * a].type == FACE_PERIODIC) {
                continue;
            }
            const double xi = ((double)(xf[a] + d->lo[a]) - 0.5 - 0.5 * lb_c[q][a]) / d->N[a];
            shape *= 4.0 * xi * (1.0 - xi);
        }
    }
    for (int a = 0; a < 3; a++) {
        uw[a] = face->velocity[a] * shape / units_velocity(u);
    }
}

/* Walls that move along themselves let no mass through, but where one
 * slides into another (a driven lid meeting a side wall) the links of the
 * cell at their edge come from walls of different velocities, and their
 * terms 6 w_q rho c_q.u_w no longer cancel: bounce-back with Ladd's term then
 * puts mass in at the downstream edge and takes it out at the upstream one,
 * each times its own density, so a lid-driven cavity gained mass without end
 * (1.2e-4 of it in 20 000 steps at 32^3, U 0.005, the higher pressure of the
 * downstream corner winning). Such a cell's sum s of the coefficients of its
 * wall links (not an inlet's, whose flux is meant) is taken off them in
 * proportion to their weights, coef_q -= s w_q / sum w: its links put no mass
 * in, whatever its density. Cells of one wall (every link's velocity the
 * same tangential one) have s = 0 and are left as they are. */
static void balance_cell(ghost_link_t *l, size_t n, const int flux[LB_Q])
{
    /* The slip correction's terms 6 w_q rho c_q.u_k (u_k tangential to the
     * link's wall) cancel in pairs of links mirrored along the wall; where
     * the mirror of a link went to the other wall of an edge, or to no
     * correction, the term stands alone and moves mass (a driven lid at
     * Lambda 1/4: 2e-7 of the cavity's mass in 5000 steps): it is left out. */
    int unpaired[LB_Q] = {0};
    for (size_t i = 0; i < n; i++) {
        if (l[i].kind != LINK_BOUNCE || l[i].cell2 == l[i].cell) {
            continue;
        }
        int cm[3];
        for (int a = 0; a < 3; a++) {
            cm[a] = a == l[i].axis ? lb_c[l[i].q][a] : -lb_c[l[i].q][a];
        }
        const int mq = lb_direction(cm);
        int found = mq == l[i].q;
        for (size_t j = 0; j < n && !found; j++) {
            found = l[j].q == mq && l[j].kind == LINK_BOUNCE && l[j].axis == l[i].axis && l[j].cell2 != l[j].cell;
        }
        unpaired[l[i].q] = !found;
    }
    for (size_t i = 0; i < n; i++) {
        if (unpaired[l[i].q]) {
            l[i].cell2 = l[i].cell;
        }
    }
    double s = 0.0, wsum = 0.0, scale = 0.0;
    for (size_t i = 0; i < n; i++) {
        if (l[i].kind == LINK_BOUNCE && !flux[l[i].q]) {
            s += l[i].coef;
            wsum += lb_w[l[i].q];
            scale += fabs(l[i].coef);
        }
    }
    if (wsum == 0.0 || fabs(s) <= 1e-14 * scale) {
        return;
    }
    for (size_t i = 0; i < n; i++) {
        if (l[i].kind == LINK_BOUNCE && !flux[l[i].q]) {
            l[i].coef -= s * lb_w[l[i].q] / wsum;
        }
    }
}

static status_t push(walls_t *w, size_t *cap, const ghost_link_t *l, const log_t *log)
{
    if (w->nlinks == *cap) {
        size_t nc = *cap ? 2 * *cap : 1024;
        ghost_link_t *p = realloc(w->links, nc * sizeof *p);
        if (p == NULL) {
            return log_msg(log, STATUS_ERROR, "fluid", "out of memory for %zu wall links", nc);
        }
        w->links = p;
        *cap = nc;
    }
    w->links[w->nlinks++] = *l;
    return STATUS_OK;
}

static status_t push_copy(walls_t *w, size_t *cap, size_t cell, int q, size_t src, int sq, const log_t *log)
{
    if (w->ncopies == *cap) {
        size_t nc = *cap ? 2 * *cap : 1024;
        copy_link_t *p = realloc(w->copies, nc * sizeof *p);
        if (p == NULL) {
            return log_msg(log, STATUS_ERROR, "fluid", "out of memory for %zu periodic and free-slip links (%zu bytes)",
                           nc, nc * sizeof *p);
        }
        w->copies = p;
        *cap = nc;
    }
    w->copies[w->ncopies++] = (copy_link_t){(uint32_t)cell, (uint32_t)src, (uint8_t)q, (uint8_t)sq};
    return STATUS_OK;
}

/* 1 when cell i lies in an inner row: y and z two or more cells from the
 * block's faces (walls.h). */
static int inner_row(const grid_t *g, size_t i)
{
    const int y = (int)(i / (size_t)g->s[0] % (size_t)g->s[1]), z = (int)(i / ((size_t)g->s[0] * (size_t)g->s[1]));
    return y >= 2 && y <= g->n[1] - 1 && z >= 2 && z <= g->n[2] - 1;
}

/* The links and copies of cells in inner rows first, each part in the
 * order it was built (cell order): the two runs of walls_links. */
#define PARTITION(T, arr, n, nearly)                                 \
    do {                                                             \
        T *tmp = malloc(((n) > 0 ? (n) : 1) * sizeof(T));            \
        if (tmp == NULL) {                                           \
            return 0;                                                \
        }                                                            \
        size_t k = 0;                                                \
        for (int early = 1; early >= 0; early--) {                   \
            for (size_t i = 0; i < (n); i++) {                       \
                if (inner_row(g, (arr)[i].cell) == early) {          \
                    tmp[k++] = (arr)[i];                             \
                }                                                    \
            }                                                        \
            if (early) {                                             \
                (nearly) = k;                                        \
            }                                                        \
        }                                                            \
        if ((n) > 0) { /* arr is NULL without links */               \
            memcpy((arr), tmp, (n) * sizeof(T));                     \
        }                                                            \
        free(tmp);                                                   \
    } while (0)

static int partition(walls_t *w, const grid_t *g)
{
    PARTITION(ghost_link_t, w->links, w->nlinks, w->nlinks_early);
    PARTITION(copy_link_t, w->copies, w->ncopies, w->ncopies_early);
    return 1;
}
#undef PARTITION

status_t walls_build(walls_t *w, const grid_t *g, const scene_t *s, const units_t *u, decomp_t *d, const log_t *log)
{
    w->links = NULL;
    w->pre = NULL;
    w->nlinks = 0;
    w->copies = NULL;
    w->ncopies = 0;
    w->d = d;
    for (int a = 0; a < 3; a++) {
        w->periodic[a] = s->domain.faces[2 * a].type == FACE_PERIODIC && d->dims[a] == 1;
    }
    /* the slip of half-way bounce-back under TRT (walls.h); BGK keeps the
     * paper's plain bounce-back and its slip (Lambda = (tau - 1/2)^2) */
    w->kappa = s->fluid.collision == COLLISION_TRT ? (16.0 * s->fluid.magic - 3.0) / 24.0 : 0.0;
    size_t cap = 0, capc = 0;
    if (g->ncells > UINT32_MAX) {
        return log_msg(log, STATUS_ERROR, "fluid",
                       "%zu cells (with ghost layers) in one process: at most %u (about 1600^3); split the domain "
                       "over MPI ranks",
                       g->ncells, UINT32_MAX);
    }
    for (int z = 1; z <= g->n[2]; z++) {
        for (int y = 1; y <= g->n[1]; y++) {
            for (int x = 1; x <= g->n[0]; x++) {
                if (x > 1 && x < g->n[0] && y > 1 && y < g->n[1] && z > 1 && z < g->n[2]) {
                    continue;
                }
                const int xf[3] = {x, y, z};
                const size_t first = w->nlinks;
                int flux[LB_Q] = {0}; /* a bounce link that carries an inlet's velocity */
                for (int q = 1; q < LB_Q; q++) {
                    int sp[3], crossed[3] = {-1, -1, -1};
                    int best = -1, any = 0;
                    for (int a = 0; a < 3; a++) {
                        sp[a] = xf[a] - lb_c[q][a];
                        if (sp[a] >= 1 && sp[a] <= g->n[a]) {
                            continue;
                        }
                        any = 1;
                        const int side = sp[a] < 1 ? 0 : 1;
                        const int f = 2 * a + side;
                        if (decomp_exchanged(d, a, side)) {
                            continue; /* another rank's cell: its value comes by the exchange */
                        }
                        if (s->domain.faces[f].type == FACE_PERIODIC) {
                            sp[a] += side == 0 ? g->n[a] : -g->n[a];
                        } else {
                            crossed[a] = side;
                            if (best < 0 || face_rank(s->domain.faces[f].type) >
                                                face_rank(s->domain.faces[best].type)) {
                                best = f;
                            }
                        }
                    }
                    if (!any || best < 0) {
                        continue; /* interior, or only periodic and exchange faces crossed: periodic_axis */
                    }
                    ghost_link_t l = {0};
                    l.q = (int16_t)q;
                    l.cell = grid_index(g, x, y, z);
                    int sq = q;
                    const face_t *face = &s->domain.faces[best];
                    switch (face->type) {
                    case FACE_FREE_SLIP: {
                        int cm[3];
                        for (int a = 0; a < 3; a++) {
                            cm[a] = lb_c[q][a];
                            if (crossed[a] >= 0) {
                                cm[a] = -cm[a];
                                sp[a] = crossed[a] == 0 ? 1 : g->n[a];
                            }
                        }
                        sq = lb_direction(cm);
                        l.kind = LINK_COPY;
                        break;
                    }
                    case FACE_NO_SLIP:
                    case FACE_MOVING_WALL:
                    case FACE_VELOCITY_INLET: {
                        double uw[3] = {0.0, 0.0, 0.0};
                        int ninlets = 0, nmoving = 0; /* the inlets and moving walls the link crosses */
                        double uin[3] = {0.0, 0.0, 0.0}, umov[3] = {0.0, 0.0, 0.0};
                        for (int a = 0; a < 3; a++) {
                            if (crossed[a] < 0) {
                                continue;
                            }
                            const face_t *fc = &s->domain.faces[2 * a + crossed[a]];
                            if (fc->type == FACE_VELOCITY_INLET) {
                                double v[3];
                                inlet_velocity(s, d, u, 2 * a + crossed[a], xf, q, v);
                                for (int b = 0; b < 3; b++) {
                                    uin[b] += v[b];
                                }
                                ninlets++;
                            } else if (fc->type == FACE_MOVING_WALL) {
                                for (int b = 0; b < 3; b++) {
                                    umov[b] += fc->velocity[b] / units_velocity(u);
                                }
                                nmoving++;
                            }
                        }
                        if (ninlets > 0) {
                            /* a link through the edge of an inlet and a wall
                             * crosses the inlet too and takes its velocity (the
                             * mean of two inlets' at their edge): an
                             * inlet gives every cell next to it rho U (the
                             * five links' 6 w_q c_q.u sum to u), also where
                             * it meets a wall; the link stays the wall's
                             * otherwise (slip correction, pinched pairs).
                             * Before, it went with the wall and carried no
                             * flux: a uniform inlet delivered 5/6 of rho U in
                             * the cells along its edges (0.979 of rho U H at
                             * 16 cells). A parabolic inlet is 0 there. */
                            for (int a = 0; a < 3; a++) {
                                uw[a] = uin[a] / ninlets;
                            }
                            flux[q] = 1;
                        } else if (face->type == FACE_MOVING_WALL) {
                            /* a link through an edge (or corner) of two (three)
                             * moving walls: the mean of their velocities. It
                             * took the first wall's in axis order, so a box of
                             * moving walls turned x <-> z gave another flow
                             * (5.2e-3 off after 30 steps, walls at 0.01-0.02) */
                            for (int a = 0; a < 3; a++) {
                                uw[a] = umov[a] / nmoving;
                            }
                        }
                        l.kind = LINK_BOUNCE;
                        l.pinch = face->type != FACE_VELOCITY_INLET;
                        /* x_f + c_q, wrapped across a periodic face as the
                         * sphere stage maps it (its ghost, flagged only when
                         * the face is cut between ranks: spheres_locate) */
                        int xp[3];
                        for (int a = 0; a < 3; a++) {
                            xp[a] = xf[a] + lb_c[q][a];
                            const int side = xp[a] < 1 ? 0 : 1;
                            if ((xp[a] < 1 || xp[a] > g->n[a]) && !decomp_exchanged(d, a, side) &&
                                s->domain.faces[2 * a + side].type == FACE_PERIODIC) {
                                xp[a] += side == 0 ? g->n[a] : -g->n[a];
                            }
                        }
                        l.cell3 = grid_index(g, xp[0], xp[1], xp[2]);
                        l.coef = 6.0 * lb_w[q] * (lb_c[q][0] * uw[0] + lb_c[q][1] * uw[1] + lb_c[q][2] * uw[2]);
                        l.axis = (int16_t)(best / 2);
                        l.cell2 = l.cell;
                        /* a link through an edge (or corner) of two walls of
                         * one kind has no one normal: which face it went
                         * with depended on the order of the axes, so a
                         * closed box turned gave another flow (3e-5 of a
                         * density pulse at its edges in two steps); it
                         * keeps plain bounce-back, as where the domain is
                         * too thin for the correction */
                        int ties = 0;
                        for (int a = 0; a < 3; a++) {
                            ties += crossed[a] >= 0 &&
                                    face_rank(s->domain.faces[2 * a + crossed[a]].type) == face_rank(face->type);
                        }
                        if (face->type != FACE_VELOCITY_INLET && ties == 1) {
                            /* the two cells inwards along the normal, for the slip correction */
                            int x3[3] = {x, y, z};
                            x3[best / 2] += best % 2 == 0 ? 2 : -2;
                            if (x3[best / 2] >= 1 && x3[best / 2] <= g->n[best / 2]) {
                                x3[best / 2] += best % 2 == 0 ? -1 : 1;
                                l.cell2 = grid_index(g, x3[0], x3[1], x3[2]);
                            }
                        }
                        break;
                    }
                    case FACE_PRESSURE_OUTLET: {
                        /* the ghost x_g = x_f - c_q lies across the outlet
                         * from x_s = x_f - c_t (c_t: c_q's tangential part),
                         * whose f~_q the link copies (walls.h): x_s itself, or
                         * across a tangential face its image in the block
                         * (periodic: wrapped; free-slip: mirrored, with the
                         * mirrored direction) or another rank's cell (read
                         * where the exchange leaves it, the in-slot of q of
                         * x_f + c_n, after the exchange) */
                        const int a = best / 2;
                        int xs[3] = {x, y, z}, sq2 = q, remote = 0;
                        for (int b = 0; b < 3; b++) {
                            if (b == a || lb_c[q][b] == 0 || g->n[a] < 2) {
                                continue; /* a domain one cell long: x_f's own (x_f + c_n is no cell) */
                            }
                            xs[b] -= lb_c[q][b];
                            if (xs[b] >= 1 && xs[b] <= g->n[b]) {
                                continue;
                            }
                            const int side = xs[b] < 1 ? 0 : 1;
                            if (decomp_exchanged(d, b, side)) {
                                remote = 1;
                            } else if (s->domain.faces[2 * b + side].type == FACE_PERIODIC) {
                                xs[b] += side == 0 ? g->n[b] : -g->n[b];
                            } else {
                                /* free-slip (a wall would have won the link): x_f, the
                                 * tangential component reflected */
                                xs[b] = xf[b];
                                int cm[3] = {lb_c[q][0], lb_c[q][1], lb_c[q][2]};
                                cm[b] = -cm[b];
                                sq2 = lb_direction(cm);
                            }
                        }
                        l.kind = LINK_ANTI;
                        l.coef = 1.0 + face->pressure / units_pressure(u) / LB_CS2;
                        l.pinch = (int16_t)remote;
                        l.axis = (int16_t)sq2;
                        int xn[3] = {x, y, z};
                        xn[a] += best % 2 == 0 ? 1 : -1;
                        l.cell2 = grid_index(g, xs[0], xs[1], xs[2]);
                        l.cell3 = remote ? grid_index(g, xn[0], xn[1], xn[2]) : l.cell2;
                        break;
                    }
                    case FACE_PERIODIC:
                        break;
                    }
                    const status_t st = l.kind == LINK_COPY
                                            ? push_copy(w, &capc, l.cell, q, grid_index(g, sp[0], sp[1], sp[2]), sq, log)
                                            : push(w, &cap, &l, log);
                    if (st != STATUS_OK) {
                        walls_free(w);
                        return STATUS_ERROR;
                    }
                }
                balance_cell(w->links + first, w->nlinks - first, flux);
            }
        }
    }
    w->pre = calloc(w->nlinks > 0 ? w->nlinks : 1, sizeof *w->pre);
    if (w->pre == NULL || !partition(w, g)) {
        walls_free(w);
        return log_msg(log, STATUS_ERROR, "fluid", "out of memory for the moments of %zu wall links", w->nlinks);
    }
    return STATUS_OK;
}

void walls_free(walls_t *w)
{
    free(w->links);
    free(w->pre);
    free(w->copies);
    w->pre = NULL;
    w->links = NULL;
    w->copies = NULL;
    w->nlinks = 0;
    w->ncopies = 0;
}
