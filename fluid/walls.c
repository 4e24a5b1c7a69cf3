/* walls.c — builds and applies the ghost links of the domain faces (walls.h).
 *
 * The list is built once: for every interior cell next to a face and every
 * direction q whose upwind neighbour x - c_q is a ghost cell. Reads are from
 * interior slots only and every ghost slot is written by at most one link,
 * so the fill is order-independent and runs in parallel. */
#include "walls.h"

#include "lattice.h"

#include <math.h>
#include <stdlib.h>

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
static void inlet_velocity(const scene_t *s, const grid_t *g, const units_t *u, int f, const int xf[3], int q,
                           double uw[3])
{
    const face_t *face = &s->domain.faces[f];
    double shape = 1.0;
    if (face->profile == PROFILE_PARABOLIC) {
        for (int a = 0; a < 3; a++) {
            if (a == f / 2 || s->domain.faces[2 * a].type == FACE_PERIODIC) {
                continue;
            }
            const double xi = ((double)xf[a] - 0.5 - 0.5 * lb_c[q][a]) / g->n[a];
            shape *= 4.0 * xi * (1.0 - xi);
        }
    }
    for (int a = 0; a < 3; a++) {
        uw[a] = face->velocity[a] * shape / units_velocity(u);
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

static int by_dst(const void *a, const void *b)
{
    const size_t x = *(const size_t *)a, y = *(const size_t *)b;
    return x < y ? -1 : (x > y ? 1 : 0);
}

/* Moves the copy links out of the general list into (dst, src) pairs. */
static status_t split_copies(walls_t *w, const log_t *log)
{
    size_t nc = 0;
    for (size_t i = 0; i < w->nlinks; i++) {
        nc += w->links[i].kind == LINK_COPY;
    }
    w->copies = malloc(2 * (nc ? nc : 1) * sizeof(size_t));
    if (w->copies == NULL) {
        return log_msg(log, STATUS_ERROR, "fluid", "out of memory for %zu periodic links", nc);
    }
    size_t k = 0, m = 0;
    for (size_t i = 0; i < w->nlinks; i++) {
        if (w->links[i].kind == LINK_COPY) {
            w->copies[2 * k] = w->links[i].dst;
            w->copies[2 * k + 1] = w->links[i].src;
            k++;
        } else {
            w->links[m++] = w->links[i];
        }
    }
    qsort(w->copies, nc, 2 * sizeof(size_t), by_dst);
    w->ncopies = nc;
    w->nlinks = m;
    return STATUS_OK;
}

status_t walls_build(walls_t *w, const grid_t *g, const scene_t *s, const units_t *u, const log_t *log)
{
    w->links = NULL;
    w->nlinks = 0;
    w->copies = NULL;
    w->ncopies = 0;
    size_t cap = 0;
    const size_t N = g->ncells;
    for (int z = 1; z <= g->n[2]; z++) {
        for (int y = 1; y <= g->n[1]; y++) {
            for (int x = 1; x <= g->n[0]; x++) {
                if (x > 1 && x < g->n[0] && y > 1 && y < g->n[1] && z > 1 && z < g->n[2]) {
                    continue;
                }
                const int xf[3] = {x, y, z};
                for (int q = 1; q < LB_Q; q++) {
                    int sp[3], gh[3], crossed[3] = {-1, -1, -1};
                    int best = -1, any = 0;
                    for (int a = 0; a < 3; a++) {
                        sp[a] = gh[a] = xf[a] - lb_c[q][a];
                        if (sp[a] >= 1 && sp[a] <= g->n[a]) {
                            continue;
                        }
                        any = 1;
                        const int side = sp[a] < 1 ? 0 : 1;
                        const int f = 2 * a + side;
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
                    if (!any) {
                        continue;
                    }
                    ghost_link_t l = {0};
                    l.q = q;
                    l.dst = (size_t)q * N + grid_index(g, gh[0], gh[1], gh[2]);
                    l.cell = grid_index(g, x, y, z);
                    const size_t bounced = (size_t)lb_opposite(q) * N + l.cell;
                    if (best < 0) {
                        l.kind = LINK_COPY;
                        l.src = (size_t)q * N + grid_index(g, sp[0], sp[1], sp[2]);
                    } else {
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
                            int qm = 0;
                            for (int r = 1; r < LB_Q; r++) {
                                if (lb_c[r][0] == cm[0] && lb_c[r][1] == cm[1] && lb_c[r][2] == cm[2]) {
                                    qm = r;
                                }
                            }
                            l.kind = LINK_COPY;
                            l.src = (size_t)qm * N + grid_index(g, sp[0], sp[1], sp[2]);
                            break;
                        }
                        case FACE_NO_SLIP:
                        case FACE_MOVING_WALL:
                        case FACE_VELOCITY_INLET: {
                            double uw[3] = {0.0, 0.0, 0.0};
                            if (face->type == FACE_MOVING_WALL) {
                                for (int a = 0; a < 3; a++) {
                                    uw[a] = face->velocity[a] / units_velocity(u);
                                }
                            } else if (face->type == FACE_VELOCITY_INLET) {
                                inlet_velocity(s, g, u, best, xf, q, uw);
                            }
                            l.kind = LINK_BOUNCE;
                            l.src = bounced;
                            l.coef = 6.0 * lb_w[q] * (lb_c[q][0] * uw[0] + lb_c[q][1] * uw[1] + lb_c[q][2] * uw[2]);
                            break;
                        }
                        case FACE_PRESSURE_OUTLET: {
                            const int a = best / 2;
                            int x2[3] = {x, y, z};
                            x2[a] += best % 2 == 0 ? 1 : -1;
                            if (x2[a] < 1 || x2[a] > g->n[a]) {
                                x2[a] = xf[a];
                            }
                            l.kind = LINK_ANTI;
                            l.src = bounced;
                            l.cell2 = grid_index(g, x2[0], x2[1], x2[2]);
                            l.coef = 1.0 + face->pressure / units_pressure(u) / LB_CS2;
                            break;
                        }
                        case FACE_PERIODIC:
                            break;
                        }
                    }
                    if (push(w, &cap, &l, log) != STATUS_OK) {
                        walls_free(w);
                        return STATUS_ERROR;
                    }
                }
            }
        }
    }
    if (split_copies(w, log) != STATUS_OK) {
        walls_free(w);
        return STATUS_ERROR;
    }
    return STATUS_OK;
}

void walls_free(walls_t *w)
{
    free(w->links);
    free(w->copies);
    w->links = NULL;
    w->copies = NULL;
    w->nlinks = 0;
    w->ncopies = 0;
}

static void moments(const double *f, size_t N, size_t cell, double *rho, double u[3])
{
    double j[3];
    *rho = lb_moments(f, N, cell, j);
    for (int a = 0; a < 3; a++) {
        u[a] = j[a] / *rho;
    }
}

void walls_fill(const walls_t *w, const grid_t *g, double *f)
{
    const size_t N = g->ncells;
    const ptrdiff_t nc = (ptrdiff_t)w->ncopies, n = (ptrdiff_t)w->nlinks;
    const size_t *restrict cp = w->copies;
#pragma omp parallel
    {
#pragma omp for schedule(static) nowait
    for (ptrdiff_t i = 0; i < nc; i++) {
        f[cp[2 * i]] = f[cp[2 * i + 1]];
    }
#pragma omp for schedule(static)
    for (ptrdiff_t i = 0; i < n; i++) {
        const ghost_link_t *l = &w->links[i];
        switch (l->kind) {
        case LINK_COPY:
            f[l->dst] = f[l->src];
            break;
        case LINK_BOUNCE: {
            double v = f[l->src];
            if (l->coef != 0.0) {
                double rho, u[3];
                moments(f, N, l->cell, &rho, u);
                v += l->coef * rho;
            }
            f[l->dst] = v;
            break;
        }
        case LINK_ANTI: {
            double r1, r2, u1[3], u2[3], uw[3];
            moments(f, N, l->cell, &r1, u1);
            moments(f, N, l->cell2, &r2, u2);
            for (int a = 0; a < 3; a++) {
                uw[a] = 1.5 * u1[a] - 0.5 * u2[a];
            }
            const double cu = lb_c[l->q][0] * uw[0] + lb_c[l->q][1] * uw[1] + lb_c[l->q][2] * uw[2];
            const double uu = uw[0] * uw[0] + uw[1] * uw[1] + uw[2] * uw[2];
            f[l->dst] = -f[l->src] + 2.0 * lb_w[l->q] * l->coef * (1.0 + 4.5 * cu * cu - 1.5 * uu);
            break;
        }
        }
    }
    }
}
