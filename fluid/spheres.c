/* spheres.c — map and refill of moving spheres (spheres.h; the links are
 * built in sphere_links.c, the fill and the loads are sphere_fill.c's). The
 * map stage (covering, uncovering, refill) touches only the cells inside the
 * spheres; links and fill run in parallel over spheres, each sphere with
 * its own list of links, so that every per-sphere sum is taken in a fixed
 * order (bit-identical results for any thread count) and the work is
 * O(surface), found from each sphere's bounding box. When no sphere moved,
 * flags and links are kept. */
#include "spheres_internal.h"

#include "../common/coupling.h"

#include "boundary.h"
#include "lattice.h"
#include "refill.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

int spheres_locate(const int lo[3], const int n[3], const int open[6], const int periodic[3], const int N[3],
                   const int X[3], int Y[3])
{
    int owned = 1;
    for (int a = 0; a < 3; a++) {
        int g = X[a] - 1; /* global cell, 0-based */
        if (periodic[a] && (g < 0 || g >= N[a])) {
            g = g < 0 && g >= -N[a] ? g + N[a] : g >= N[a] && g < 2 * N[a] ? g - N[a] : (g % N[a] + N[a]) % N[a];
        }
        int y = g - lo[a] + 1;
        if (periodic[a] && (open[2 * a] || open[2 * a + 1])) {
            /* a cut periodic axis: the image nearest to the block */
            if (y < -1) {
                y += N[a];
            } else if (y > n[a] + 2) {
                y -= N[a];
            }
        }
        if (y < 1 || y > n[a]) {
            owned = 0;
            if (!open[2 * a + (y < 1 ? 0 : 1)] || y < -1 || y > n[a] + 2) {
                return 0;
            }
        }
        Y[a] = y;
    }
    return owned ? 1 : 2;
}

int spheres_near_block(const spheres_t *sp, const double c[3], double r, const int lo[3], const int n[3])
{
    for (int a = 0; a < 3; a++) {
        /* allocated coordinates of the widened block: lo - 1 .. lo + n + 2 */
        const double b0 = lo[a] - 1 - 1.0, b1 = lo[a] + n[a] + 2 + 1.0;
        int meets = 0;
        for (int k = sp->periodic[a] ? -1 : 0; k <= (sp->periodic[a] ? 1 : 0) && !meets; k++) {
            const double x = c[a] + k * sp->N[a];
            meets = x + r >= b0 && x - r <= b1;
        }
        if (!meets) {
            return 0;
        }
    }
    return 1;
}

/* Global unwrapped allocated coordinates of local Y. */
static void global_of(const spheres_t *sp, const int Y[3], int X[3])
{
    for (int a = 0; a < 3; a++) {
        X[a] = Y[a] + sp->lo[a];
    }
}

int spheres_cell_beyond(spheres_t *sp, const grid_t *g, const uint8_t *flags, const int Y[3], size_t *ref,
                        uint8_t *flag)
{
    int X[3], Z[3];
    global_of(sp, Y, X);
    const int where = spheres_locate(sp->lo, sp->nb, sp->open, sp->periodic, sp->N, X, Z);
    if (where == 1) {
        *ref = grid_index(g, Z[0], Z[1], Z[2]);
        *flag = (uint8_t)cellflags_get(flags, *ref);
        return 1;
    }
    if (where == 2) {
        const long k = sphere_halo_find(&sp->halo, Z);
        if (k >= 0) {
            *ref = SPHERE_EXT + (size_t)k;
            *flag = sp->halo.flag[k];
            return 1;
        }
#pragma omp atomic
        sp->halo.misses++;
    }
    return 0;
}

static void rotate(const double w[3], double t, const double v[3], double out[3])
{
    /* Rodrigues: rotation by angle |w| t about w */
    const double n = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    if (n * t == 0.0) {
        memcpy(out, v, 3 * sizeof(double));
        return;
    }
    const double k[3] = {w[0] / n, w[1] / n, w[2] / n}, th = n * t;
    double kxv[3];
    spheres_cross(k, v, kxv);
    const double kv = k[0] * v[0] + k[1] * v[1] + k[2] * v[2];
    for (int a = 0; a < 3; a++) {
        out[a] = v[a] * cos(th) + kxv[a] * sin(th) + k[a] * kv * (1.0 - cos(th));
    }
}

void spheres_wrap_centre(const spheres_t *sp, double c[3])
{
    for (int a = 0; a < 3; a++) {
        if (sp->periodic[a]) {
            c[a] = 0.5 + fmod(fmod(c[a] - 0.5, sp->N[a]) + sp->N[a], sp->N[a]);
        }
    }
}

status_t spheres_init(spheres_t *sp, const scene_t *s, const units_t *u, const grid_t *g, decomp_t *dc,
                      const log_t *log)
{
    memset(sp, 0, sizeof *sp);
    sp->dc = dc;
    sp->grid = *g;
    for (int a = 0; a < 3; a++) {
        sp->N[a] = dc->N[a];
        sp->lo[a] = dc->lo[a];
        sp->nb[a] = dc->n[a];
        sp->open[2 * a] = dc->nbr[a][0] >= 0;
        sp->open[2 * a + 1] = dc->nbr[a][1] >= 0;
    }
    sp->n = scene_total_spheres(s);
    sp->scheme = s->fluid.boundary_scheme;
    sp->refill = s->fluid.refill;
    sp->force = s->fluid.force_method;
    sp->first = 1;
    sp->omega_minus = u->omega_minus;
    for (int a = 0; a < 3; a++) {
        sp->body_force[a] = u->force_lat[a];
    }
    for (int a = 0; a < 3; a++) {
        sp->periodic[a] = s->domain.faces[2 * a].type == FACE_PERIODIC;
    }
    /* the film zone (spheres_fill): where the rigid component adds the film
     * force, every face but inlets, outlets and periodic ones */
    const scene_lubrication_t *lub = &s->contacts.lubrication;
    sp->film_cutoff = lub->enabled ? lub->cutoff : 0.0;
    for (int f = 0; f < 6; f++) {
        const face_type_t t = s->domain.faces[f].type;
        sp->film_face[f] = t == FACE_NO_SLIP || t == FACE_MOVING_WALL || t == FACE_FREE_SLIP;
        sp->pinch_face[f] = t == FACE_NO_SLIP || t == FACE_MOVING_WALL;
    }
    if (sp->n == 0) {
        return STATUS_OK;
    }
    sp->s = calloc((size_t)sp->n, sizeof *sp->s);
    sp->lists = calloc((size_t)sp->n, sizeof *sp->lists);
    sp->accbuf = calloc((size_t)sp->n * SPHERE_NACC, sizeof *sp->accbuf);
    sp->kin = calloc((size_t)sp->n * 9, sizeof *sp->kin);
    sp->dirty = calloc((size_t)sp->n + 1, 1);
    if (sp->s == NULL || sp->lists == NULL || sp->accbuf == NULL || sp->kin == NULL || sp->dirty == NULL) {
        return log_msg(log, STATUS_ERROR, "fluid", "out of memory for %d spheres", sp->n);
    }
    int k = 0;
    for (int b = 0; b < s->nbodies; b++) {
        const scene_body_t *body = &s->bodies[b];
        double cb[3];
        scene_body_pivot(body, cb);
        const body_coupling_t bc = coupling_of_body(s, b);
        const int averaging = bc.averaging;
        const double kappa_risky =
            body->motion == MOTION_FREE && (bc.coupling == COUPLING_EXPLICIT || !bc.averaging) ? bc.kappa : 0.0;
        for (int i = 0; i < body->nspheres; i++, k++) {
            sphere_t *p = &sp->s[k];
            p->body = b;
            p->motion = body->motion;
            p->density_ratio = body->density / s->fluid.density;
            p->rho_film = 1.0;
            p->averaging = averaging;
            p->kappa_risky = kappa_risky;
            p->r = body->spheres[i].radius / u->dx;
            double rel[3];
            for (int a = 0; a < 3; a++) {
                p->c[a] = body->spheres[i].center[a] / u->dx + 0.5;
                p->cb0[a] = cb[a] / u->dx + 0.5;
                rel[a] = p->c[a] - p->cb0[a];
                p->rel0[a] = rel[a];
            }
            if (body->motion != MOTION_FIXED) {
                double wr[3];
                const double w[3] = {body->angular_velocity[0] * u->dt, body->angular_velocity[1] * u->dt,
                                     body->angular_velocity[2] * u->dt};
                spheres_cross(w, rel, wr);
                for (int a = 0; a < 3; a++) {
                    p->w[a] = w[a];
                    p->vbody[a] = body->velocity[a] * u->dt / u->dx;
                    p->v[a] = p->vbody[a] + wr[a];
                }
            }
            spheres_wrap_centre(sp, p->c);
        }
    }
    return STATUS_OK;
}

void spheres_free(spheres_t *sp)
{
    free(sp->s);
    for (int k = 0; k < sp->n && sp->lists != NULL; k++) {
        free(sp->lists[k].l);
        free(sp->lists[k].carry);
        free(sp->lists[k].inside);
        free(sp->lists[k].runs);
        free(sp->lists[k].oldkey);
        free(sp->lists[k].near);
        free(sp->lists[k].cand);
        free(sp->lists[k].cand_c);
    }
    free(sp->lists);
    free(sp->dirty);
    free(sp->parts);
    free(sp->changed);
    free(sp->solid);
    free(sp->fresh);
    free(sp->fresh_sphere);
    sphere_halo_free(&sp->halo);
    free(sp->accbuf);
    free(sp->kin);
    memset(sp, 0, sizeof *sp);
}

int spheres_advance_prescribed(spheres_t *sp, long step, int *face)
{
    int beyond = -1;
    for (int i = 0; i < sp->n; i++) {
        sphere_t *p = &sp->s[i];
        if (p->motion != MOTION_PRESCRIBED) {
            continue;
        }
        /* the centroid moves with the body velocity, the centre turns about it */
        double rel[3], wrel[3];
        rotate(p->w, (double)step, p->rel0, rel);
        spheres_cross(p->w, rel, wrel);
        for (int a = 0; a < 3; a++) {
            p->c[a] = p->cb0[a] + p->vbody[a] * (double)step + rel[a];
            p->v[a] = p->vbody[a] + wrel[a];
        }
        spheres_wrap_centre(sp, p->c);
        /* a prescribed body moves as given, through a wall too: the faces lie
         * half a cell beyond the first and last cells, X = 0.5 and N + 0.5; a
         * sphere may touch one (the scene allows r <= c <= L - r) */
        for (int a = 0; a < 3 && beyond < 0; a++) {
            const double tol = 1e-9;
            if (!sp->periodic[a] && (p->c[a] - p->r < 0.5 - tol || p->c[a] + p->r > sp->N[a] + 0.5 + tol)) {
                beyond = i;
                *face = 2 * a + (p->c[a] + p->r > sp->N[a] + 0.5 + tol);
            }
        }
    }
    return beyond;
}

/* Marks the cells inside sphere k with FLAG_MARK and lists them in the
 * sphere's inside list; the spheres in parallel (overlapping ones set the
 * same bit of a cell: an atomic or). */
static status_t mark_sphere(spheres_t *sp, const grid_t *g, uint8_t *flags, int k)
{
    const sphere_t *p = &sp->s[k];
    link_list_t *list = &sp->lists[k];
    list->ninside = 0;
    list->nruns = 0;
    if (!spheres_near_block(sp, p->c, p->r, sp->lo, sp->nb)) {
        return STATUS_OK; /* another rank's sphere */
    }
    int lo[3], hi[3];
    for (int a = 0; a < 3; a++) {
        lo[a] = (int)ceil(p->c[a] - p->r);
        hi[a] = (int)floor(p->c[a] + p->r);
    }
    const double r2 = p->r * p->r;
    /* the box inside the block, away from its faces: a cell's local
     * coordinates are its global ones less the block's first cell, without
     * spheres_locate (most spheres, most maps) */
    int inner = 1;
    for (int a = 0; a < 3; a++) {
        inner = inner && lo[a] - sp->lo[a] >= 1 && hi[a] - sp->lo[a] <= sp->nb[a];
    }
    int X[3], Y[3];
    for (X[2] = lo[2]; X[2] <= hi[2]; X[2]++) {
        for (X[1] = lo[1]; X[1] <= hi[1]; X[1]++) {
            /* the row's cells inside lie within w of c_k: those and a cell
             * more each side (the test below decides) */
            const double e = (X[1] - p->c[1]) * (X[1] - p->c[1]) + (X[2] - p->c[2]) * (X[2] - p->c[2]);
            if (e > r2) {
                continue;
            }
            int x0, x1;
            spheres_row_span(p->c[0], sqrt(r2 - e), lo[0], hi[0], &x0, &x1);
            const size_t row = x1 >= x0 ? (size_t)(x1 - x0 + 1) : 0;
            if (!spheres_grow((void **)&list->inside, &list->capinside, list->ninside + row, sizeof *list->inside)) {
                return STATUS_ERROR;
            }
            /* the row's cells inside as runs: one for the row of an inner box
             * (a sphere meets a row in one piece), else a run per cell */
            const size_t nrun = list->nruns + (inner ? 1 : row);
            if (!spheres_grow((void **)&list->runs, &list->capruns, nrun, sizeof *list->runs)) {
                return STATUS_ERROR;
            }
            int32_t *run = NULL;
            const double dy = X[1] - p->c[1], dz = X[2] - p->c[2];
            for (X[0] = x0; X[0] <= x1; X[0]++) {
                const double dx = X[0] - p->c[0];
                if (dx * dx + dy * dy + dz * dz > r2) {
                    continue;
                }
                if (inner) {
                    for (int a = 0; a < 3; a++) {
                        Y[a] = X[a] - sp->lo[a];
                    }
                } else if (!spheres_locate(sp->lo, sp->nb, sp->open, sp->periodic, sp->N, X, Y) ||
                           !(Y[0] >= 0 && Y[0] <= g->n[0] + 1 && Y[1] >= 0 && Y[1] <= g->n[1] + 1 && Y[2] >= 0 &&
                             Y[2] <= g->n[2] + 1)) {
                    continue; /* beyond a wall, or a halo cell outside the grid's ghost layer */
                }
                const size_t i = grid_index(g, Y[0], Y[1], Y[2]);
                list->inside[list->ninside++] = i;
                cellflags_or_atomic(flags, i, FLAG_MARK);
                if (grid_is_interior(g, Y[0], Y[1], Y[2])) {
                    if (run == NULL || !inner) {
                        run = list->runs[list->nruns++];
                        run[0] = (Y[1] - 1) + g->n[1] * (Y[2] - 1);
                        run[1] = Y[0];
                    }
                    run[2] = Y[0];
                }
            }
        }
    }
    return STATUS_OK;
}

static void cell_coords(const grid_t *g, size_t i, int X[3])
{
    X[0] = (int)(i % (size_t)g->s[0]);
    X[1] = (int)(i / (size_t)g->s[0] % (size_t)g->s[1]);
    X[2] = (int)(i / ((size_t)g->s[0] * (size_t)g->s[1]));
}

/* Books momentum dp (lattice) taken by sphere k at (local) cell X. */
static void book(spheres_t *sp, int k, const int X[3], const double dp[3])
{
    sphere_t *p = &sp->s[k];
    const double x[3] = {X[0] + sp->lo[0], X[1] + sp->lo[1], X[2] + sp->lo[2]};
    double d[3], t[3];
    spheres_min_image(sp, x, p->c, d);
    spheres_cross(d, dp, t);
    for (int a = 0; a < 3; a++) {
        xsum_add(&p->acc[a], dp[a]);
        xsum_add(&p->acc[3 + a], t[a]);
    }
}

/* With the Galilean-invariant force (Wen et al. 2014) a covered or uncovered
 * cell books its momentum relative to the solid at the cell, rho (u - u_s):
 * the part rho u_s only moves mass between fluid and solid and, booked as an
 * impulse, is the dominant source of force fluctuations (+rho v on every
 * covered cell, -rho v on every uncovered one). With plain momentum exchange
 * the full momentum is booked (Aidun, Lu & Ding 1998), which conserves the
 * momentum of fluid plus spheres exactly. */
static void galilean_shift(const spheres_t *sp, int k, const int X[3], double rho, double dp[3])
{
    if (sp->force != FORCE_GALILEAN) {
        return;
    }
    const sphere_t *p = &sp->s[k];
    const double x[3] = {X[0] + sp->lo[0], X[1] + sp->lo[1], X[2] + sp->lo[2]};
    double d[3], wr[3];
    spheres_min_image(sp, x, p->c, d);
    spheres_cross(p->w, d, wr);
    for (int a = 0; a < 3; a++) {
        dp[a] -= rho * (p->v[a] + wr[a]);
    }
}

int spheres_nearest(const spheres_t *sp, const double x[3], double d_out[3])
{
    int best = 0;
    double bd = INFINITY;
    for (int k = 0; k < sp->n; k++) {
        double d[3];
        spheres_min_image(sp, x, sp->s[k].c, d);
        const double dist = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) - sp->s[k].r;
        if (dist < bd) {
            bd = dist;
            best = k;
            memcpy(d_out, d, sizeof d);
        }
    }
    return best;
}


/* Notes a cell (local coordinates X) that this map covers or uncovers, in
 * global coordinates: 0 when out of memory. */
static int note_changed(spheres_t *sp, const int X[3])
{
    if (!spheres_grow((void **)&sp->changed, &sp->capchanged, sp->nchanged + 1, sizeof *sp->changed)) {
        return 0;
    }
    for (int a = 0; a < 3; a++) {
        sp->changed[sp->nchanged][a] = X[a] + sp->lo[a];
    }
    sp->nchanged++;
    return 1;
}

status_t spheres_map(spheres_t *sp, const grid_t *g, uint8_t *flags, const pops_t *f, const log_t *log)
{
    if (sp->n == 0) {
        return STATUS_OK;
    }
    for (int k = 0; k < sp->n; k++) {
        memcpy(sp->s[k].fprev, sp->s[k].f, sizeof sp->s[k].f);
        memcpy(sp->s[k].tprev, sp->s[k].t, sizeof sp->s[k].t);
        memset(sp->s[k].f, 0, sizeof sp->s[k].f);
        memset(sp->s[k].t, 0, sizeof sp->s[k].t);
        sp->s[k].zt = sp->s[k].zr = 0.0;
        for (int a = 0; a < SPHERE_NACC; a++) {
            xsum_zero(&sp->s[k].acc[a]);
        }
    }
    /* no sphere moved: flags, solid cells and links stay. (Solid cells are
     * never reset: the kernel runs over them, but every population a fluid
     * cell receives from a solid one is written by a link, so what the solid
     * cells hold never reaches the fluid.) */
    int moved = sp->first || sp->stale;
    for (int k = 0; k < sp->n && !moved; k++) {
        moved = memcmp(sp->s[k].c, sp->s[k].cmap, sizeof sp->s[k].c) != 0;
    }
    if (!moved) {
        /* links marked fresh belong to the last map stage only */
        for (int k = 0; k < sp->n; k++) {
            spheres_clear_fresh(&sp->lists[k]);
        }
        sp->nfresh = 0;
        /* the cells of other ranks the links read, this step's values */
        return sphere_halo_exchange(sp, f, log);
    }
    /* on several ranks: the cells of other ranks near the spheres (with the
     * centres of the last map in cmap, for their fresh flags), and their
     * values for the refill */
    status_t hst = decomp_agree(sp->dc, sphere_halo_plan(sp, log));
    if (hst == STATUS_OK) {
        hst = decomp_agree(sp->dc, sphere_halo_exchange(sp, f, log));
    }
    if (hst != STATUS_OK) {
        return hst;
    }
    for (int k = 0; k < sp->n; k++) {
        memcpy(sp->s[k].cmap, sp->s[k].c, sizeof sp->s[k].c);
    }
    /* the lists may be kept (refreshed, or rebuilt near the cells this map
     * changes: sp->changed) on one rank */
    int keep = !sp->first && !sp->stale && !sp->carried && !decomp_parallel(sp->dc);
    sp->nchanged = 0;
    sp->stale = 0;
    int failed = -1;
#pragma omp parallel for schedule(dynamic, 1)
    for (int k = 0; k < sp->n; k++) {
        if (mark_sphere(sp, g, flags, k) != STATUS_OK) {
#pragma omp critical(spheres_mark_failed)
            failed = k;
        }
    }
    if (failed >= 0) {
        return log_msg(log, STATUS_ERROR, "fluid", "out of memory while mapping sphere %d (a list of %zu cells)",
                       failed, sp->lists[failed].ninside + 1);
    }
    /* uncovered: solid before, not marked now */
    sp->nfresh = 0;
    for (size_t j = 0; j < sp->nsolid; j++) {
        const size_t i = sp->solid[j];
        if (cellflags_get(flags, i) & FLAG_MARK) {
            continue;
        }
        int Xu[3];
        cell_coords(g, i, Xu);
        if (keep && !note_changed(sp, Xu)) {
            keep = 0; /* out of memory for the list: all lists built anew */
        }
        if (!grid_is_interior(g, Xu[0], Xu[1], Xu[2])) {
            cellflags_set(flags, i, 0); /* a ghost cell of another rank's fluid: its owner refills it */
            continue;
        }
        if (!spheres_grow((void **)&sp->fresh, &sp->cap_fresh, sp->nfresh + 1, sizeof *sp->fresh)) {
            return log_msg(log, STATUS_ERROR, "fluid", "out of memory while mapping spheres (lists of %zu cells)",
                           sp->nsolid + sp->nfresh + 1);
        }
        sp->fresh[sp->nfresh++] = i;
        cellflags_set(flags, i, FLAG_FRESH);
    }
    /* covered: marked now, fluid before; the new solid list, sphere by
     * sphere (a cell inside two goes with the first) */
    size_t ninside = 0;
    for (int k = 0; k < sp->n; k++) {
        ninside += sp->lists[k].ninside;
    }
    if (!spheres_grow((void **)&sp->solid, &sp->cap_solid, ninside + 1, sizeof *sp->solid)) {
        return log_msg(log, STATUS_ERROR, "fluid", "out of memory while mapping spheres (lists of %zu cells)",
                       ninside + sp->nfresh + 1);
    }
    sp->nsolid = 0;
    for (int k = 0; k < sp->n; k++) {
        const link_list_t *list = &sp->lists[k];
        for (size_t j = 0; j < list->ninside; j++) {
            const size_t i = list->inside[j];
            const unsigned fi = cellflags_get(flags, i);
            if (!(fi & FLAG_MARK)) {
                continue; /* already handled through another sphere */
            }
            const int was_solid = fi & FLAG_SOLID;
            cellflags_set(flags, i, FLAG_SOLID);
            sp->solid[sp->nsolid++] = i;
            if (was_solid || sp->first) {
                continue; /* most cells: solid before (and cell_coords divides) */
            }
            int Xc[3];
            cell_coords(g, i, Xc);
            if (keep && !note_changed(sp, Xc)) {
                keep = 0;
            }
            if (grid_is_interior(g, Xc[0], Xc[1], Xc[2])) {
                double dp[3] = {0.0, 0.0, 0.0}, rho = 0.0;
                for (int q = 0; q < LB_Q; q++) {
                    const double v = pops_post(f, q, i);
                    rho += v;
                    for (int a = 0; a < 3; a++) {
                        dp[a] += lb_c[q][a] * v;
                    }
                }
                galilean_shift(sp, k, Xc, rho, dp);
                book(sp, k, Xc, dp);
                sp->covered_total++;
            }
        }
    }
    sp->maps++; /* a new list of solid cells */
    /* refill, after all flags are final; fresh cells do not feed each other */
    for (size_t j = 0; j < sp->nfresh; j++) {
        const size_t i = sp->fresh[j];
        int X[3];
        cell_coords(g, i, X);
        const double x[3] = {X[0] + sp->lo[0], X[1] + sp->lo[1], X[2] + sp->lo[2]};
        double d[3] = {0.0, 0.0, 0.0};
        const int k = spheres_nearest(sp, x, d);
        const sphere_t *p = &sp->s[k];
        const double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        double nrm[3], rs[3], wr[3], us[3], mom[3];
        for (int a = 0; a < 3; a++) {
            nrm[a] = len > 0.0 ? d[a] / len : 0.0;
            rs[a] = nrm[a] * p->r; /* nearest surface point, relative to the centre */
        }
        spheres_cross(p->w, rs, wr);
        for (int a = 0; a < 3; a++) {
            us[a] = p->v[a] + wr[a];
        }
        refill_cell(sp->refill, sp, g, flags, f, X, nrm, us, mom);
        double rho = 0.0;
        for (int q = 0; q < LB_Q; q++) {
            rho += pops_post(f, q, i);
        }
        galilean_shift(sp, k, X, rho, mom);
        for (int a = 0; a < 3; a++) {
            mom[a] = -mom[a];
        }
        book(sp, k, X, mom);
        sp->uncovered_total++;
    }
    sp->first = 0;
    /* the uncovered cells keep FLAG_FRESH through the links (fluid cells for
     * them, marked as fresh on their links: sphere_links) */
    status_t st = spheres_build_links(sp, g, flags, keep, log);
    for (size_t j = 0; j < sp->nfresh; j++) {
        cellflags_set(flags, sp->fresh[j], 0);
    }
    if (sp->halo.misses > 0) {
        st = log_msg(log, STATUS_ERROR, "fluid",
                     "sphere halo: %ld cells of other ranks near the spheres were read but not held (a bug: please "
                     "report it with the scene and run.ranks)",
                     sp->halo.misses);
        sp->halo.misses = 0;
    }
    /* the links read the refilled cells of other ranks too */
    st = decomp_agree(sp->dc, st);
    if (st == STATUS_OK) {
        st = decomp_agree(sp->dc, sphere_halo_exchange(sp, f, log));
    }
    return st;
}

size_t spheres_pairs_bytes(const spheres_t *sp)
{
    size_t m = 0;
    for (int k = 0; k < sp->n; k++) {
        m += sp->carried ? sp->lists[k].ncarry : spheres_list_pairs(&sp->lists[k], NULL);
    }
    return (size_t)sp->n * sizeof(uint64_t) + m * sizeof(spheres_carry_t);
}

void spheres_pairs_out(const spheres_t *sp, unsigned char *buf)
{
    for (int k = 0; k < sp->n; k++) {
        const link_list_t *list = &sp->lists[k];
        uint64_t m;
        if (sp->carried) {
            m = list->ncarry;
            if (m > 0) {
                memcpy(buf + sizeof m, list->carry, list->ncarry * sizeof *list->carry);
            }
        } else {
            m = spheres_list_pairs(list, buf + sizeof m);
        }
        memcpy(buf, &m, sizeof m);
        buf += sizeof m + (size_t)m * sizeof(spheres_carry_t);
    }
}

size_t spheres_pairs_size(const unsigned char *buf, size_t size, int nspheres)
{
    size_t at = 0;
    for (int k = 0; k < nspheres; k++) {
        uint64_t m;
        if (size - at < sizeof m) {
            return (size_t)-1;
        }
        memcpy(&m, buf + at, sizeof m);
        at += sizeof m;
        if (m > (size - at) / sizeof(spheres_carry_t)) {
            return (size_t)-1;
        }
        at += (size_t)m * sizeof(spheres_carry_t);
    }
    return at;
}

int spheres_pairs_in(spheres_t *sp, const unsigned char *buf)
{
    for (int k = 0; k < sp->n; k++) {
        link_list_t *list = &sp->lists[k];
        uint64_t m;
        memcpy(&m, buf, sizeof m);
        buf += sizeof m;
        if (!spheres_grow((void **)&list->carry, &list->capcarry, (size_t)m, sizeof *list->carry)) {
            return 0;
        }
        if (m > 0) { /* carry is NULL before any pair */
            memcpy(list->carry, buf, (size_t)m * sizeof *list->carry);
        }
        list->ncarry = (size_t)m;
        buf += (size_t)m * sizeof *list->carry;
    }
    sp->carried = 1;
    return 1;
}
