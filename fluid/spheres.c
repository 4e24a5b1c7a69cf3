/* spheres.c — map, refill and momentum exchange of moving spheres
 * (spheres.h; the links are built in sphere_links.c). The map stage
 * (covering, uncovering, refill) is serial and touches only the cells
 * inside the spheres; links and fill run in parallel
 * over spheres, each sphere with its own list of links, so that every
 * per-sphere sum is taken in a fixed order (bit-identical results for any
 * thread count) and the work is O(surface), found from each sphere's
 * bounding box. When no sphere moved, flags and links are kept. */
#include "spheres_internal.h"

#include "../common/coupling.h"

#include "boundary.h"
#include "lattice.h"
#include "refill.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* links ahead at which spheres_fill prefetches a cell's populations */
#define FILL_AHEAD 12
/* links ahead at which it prefetches a link's own scattered values */
#define LINK_AHEAD 8
/* cells whose loads spheres_fill sums at once (8 x 8 x 256 bytes of stack) */
#define FILL_CHUNK 256

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
        *flag = flags[*ref];
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
    }
    if (sp->n == 0) {
        return STATUS_OK;
    }
    sp->s = calloc((size_t)sp->n, sizeof *sp->s);
    sp->lists = calloc((size_t)sp->n, sizeof *sp->lists);
    sp->accbuf = calloc((size_t)sp->n * 8, sizeof *sp->accbuf);
    sp->kin = calloc((size_t)sp->n * 9, sizeof *sp->kin);
    if (sp->s == NULL || sp->lists == NULL || sp->accbuf == NULL || sp->kin == NULL) {
        return log_msg(log, STATUS_ERROR, "fluid", "out of memory for %d spheres", sp->n);
    }
    int k = 0;
    for (int b = 0; b < s->nbodies; b++) {
        const scene_body_t *body = &s->bodies[b];
        double cb[3] = {0.0, 0.0, 0.0}, vol = 0.0;
        for (int i = 0; i < body->nspheres; i++) {
            const double r3 = pow(body->spheres[i].radius, 3.0);
            for (int a = 0; a < 3; a++) {
                cb[a] += r3 * body->spheres[i].center[a];
            }
            vol += r3;
        }
        for (int a = 0; a < 3; a++) {
            cb[a] /= vol;
        }
        const body_coupling_t bc = coupling_of_body(s, b);
        const int averaging = bc.averaging;
        const double kappa_risky =
            body->motion == MOTION_FREE && (bc.coupling == COUPLING_EXPLICIT || !bc.averaging) ? bc.kappa : 0.0;
        for (int i = 0; i < body->nspheres; i++, k++) {
            sphere_t *p = &sp->s[k];
            p->body = b;
            p->motion = body->motion;
            p->density_ratio = body->density / s->fluid.density;
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
    }
    free(sp->lists);
    free(sp->solid);
    free(sp->fresh);
    free(sp->fresh_sphere);
    sphere_halo_free(&sp->halo);
    free(sp->accbuf);
    free(sp->kin);
    memset(sp, 0, sizeof *sp);
}

void spheres_advance_prescribed(spheres_t *sp, long step)
{
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
    }
}

/* Marks the cells inside sphere k with FLAG_MARK and lists them in the
 * sphere's inside list; the spheres in parallel (overlapping ones set the
 * same bit of a cell: an atomic or). */
static status_t mark_sphere(spheres_t *sp, const grid_t *g, uint8_t *flags, int k)
{
    const sphere_t *p = &sp->s[k];
    link_list_t *list = &sp->lists[k];
    list->ninside = 0;
    if (!spheres_near_block(sp, p->c, p->r, sp->lo, sp->nb)) {
        return STATUS_OK; /* another rank's sphere */
    }
    int lo[3], hi[3];
    for (int a = 0; a < 3; a++) {
        lo[a] = (int)ceil(p->c[a] - p->r);
        hi[a] = (int)floor(p->c[a] + p->r);
    }
    const double r2 = p->r * p->r;
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
            for (X[0] = x0; X[0] <= x1; X[0]++) {
                const double dx = X[0] - p->c[0], dy = X[1] - p->c[1], dz = X[2] - p->c[2];
                if (dx * dx + dy * dy + dz * dz > r2 ||
                    !spheres_locate(sp->lo, sp->nb, sp->open, sp->periodic, sp->N, X, Y) ||
                    !(Y[0] >= 0 && Y[0] <= g->n[0] + 1 && Y[1] >= 0 && Y[1] <= g->n[1] + 1 && Y[2] >= 0 &&
                      Y[2] <= g->n[2] + 1)) {
                    continue; /* beyond a wall, or a halo cell outside the grid's ghost layer */
                }
                const size_t i = grid_index(g, Y[0], Y[1], Y[2]);
                if (!spheres_grow((void **)&list->inside, &list->capinside, list->ninside + 1,
                                  sizeof *list->inside)) {
                    return STATUS_ERROR;
                }
                list->inside[list->ninside++] = i;
#pragma omp atomic update
                flags[i] |= FLAG_MARK;
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
        for (int a = 0; a < 8; a++) {
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
        for (int k = 0; k < sp->n && sp->nfresh > 0; k++) {
            for (size_t j = 0; j < sp->lists[k].n; j++) {
                sp->lists[k].l[j].fresh = 0;
            }
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
        if (flags[i] & FLAG_MARK) {
            continue;
        }
        int Xu[3];
        cell_coords(g, i, Xu);
        if (!grid_is_interior(g, Xu[0], Xu[1], Xu[2])) {
            flags[i] = 0; /* a ghost cell of another rank's fluid: its owner refills it */
            continue;
        }
        if (!spheres_grow((void **)&sp->fresh, &sp->cap_fresh, sp->nfresh + 1, sizeof *sp->fresh)) {
            return log_msg(log, STATUS_ERROR, "fluid", "out of memory while mapping spheres (lists of %zu cells)",
                           sp->nsolid + sp->nfresh + 1);
        }
        sp->fresh[sp->nfresh++] = i;
        flags[i] = FLAG_FRESH;
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
            if (!(flags[i] & FLAG_MARK)) {
                continue; /* already handled through another sphere */
            }
            const int was_solid = flags[i] & FLAG_SOLID;
            flags[i] = FLAG_SOLID;
            sp->solid[sp->nsolid++] = i;
            if (was_solid || sp->first) {
                continue; /* most cells: solid before (and cell_coords divides) */
            }
            int Xc[3];
            cell_coords(g, i, Xc);
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
    status_t st = spheres_build_links(sp, g, flags, log);
    for (size_t j = 0; j < sp->nfresh; j++) {
        flags[sp->fresh[j]] = 0;
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

static inline __attribute__((always_inline)) void fill_sphere(spheres_t *sp, const pops_t *f0,
                                                             const link_list_t *list, int galilean, double inv_decay,
                                                             spheres_part_t part, layout_state_t state, int single);

void spheres_fill(spheres_t *sp, const pops_t *f, spheres_part_t part)
{
    const int galilean = sp->force == FORCE_GALILEAN;
    /* n^- of the pre-collision populations from the post-collision ones. TRT
     * with Guo forcing gives f~^- = (1 - w-) f^- + w- e^- + (1 - w-/2) 3 w c.F,
     * e^- = 3 w c.(j + F/2), j the pre-collision momentum, and j~ = j + F, so
     * f~^- - 3 w c.j~ = (1 - w-)(f^- - 3 w c.j): exact, so that both layouts
     * give the same result, and it treats the initial state (an equilibrium)
     * as what it is, a state after a collision. Near w- = 1 the collision
     * forgets n^-. So each link keeps the pre-collision pair of its cell for
     * the next fill (sphere_link_t.pre), which is exact in either layout and
     * for any w-; the recovery serves a link new this step, and near w- = 1
     * such a link goes without the correction for that step. (Reading the
     * pair of a new link from the other array, which two arrays could, made
     * a fixed sphere's steady drag at w- = 1 depend on its first step and
     * creep, 2e-4 after 1500 steps: tests/fluid/test_layouts.c.) */
    const double inv_decay = 1.0 / (1.0 - sp->omega_minus);
#pragma omp parallel for schedule(dynamic, 1)
    for (int k = 0; k < sp->n; k++) {
        const link_list_t *l = &sp->lists[k];
#define FILL(state, single) fill_sphere(sp, f, l, galilean, inv_decay, part, state, single)
        POPS_SPECIALISE(f, FILL);
#undef FILL
    }
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

void spheres_write_outer(spheres_t *sp, const pops_t *f)
{
#pragma omp parallel for schedule(dynamic, 1)
    for (int k = 0; k < sp->n; k++) {
        const link_list_t *list = &sp->lists[k];
        for (size_t n = 0; n < list->n; n++) {
            const sphere_link_t *l = &list->l[n];
            if (l->outer) {
                const int o = lb_opposite(l->q);
                pops_write(f, o, pops_in_slot(f, o, l->xf), l->fnew);
            }
        }
    }
}

void spheres_loads(spheres_t *sp)
{
    /* every rank's part of each load (the links of its cells, the cells it
     * covered and uncovered), summed exactly: all ranks get the same load */
    const int parallel = decomp_parallel(sp->dc);
    if (parallel) {
        for (int k = 0; k < sp->n; k++) {
            memcpy(sp->accbuf + (size_t)k * 8, sp->s[k].acc, sizeof sp->s[k].acc);
        }
        decomp_sum(sp->dc, sp->accbuf, 8 * sp->n);
    }
    for (int k = 0; k < sp->n; k++) {
        const xsum_t *a = parallel ? sp->accbuf + (size_t)k * 8 : sp->s[k].acc;
        sphere_t *p = &sp->s[k];
        for (int c = 0; c < 3; c++) {
            p->f[c] = xsum_value(&a[c]);
            p->t[c] = xsum_value(&a[3 + c]);
        }
        p->zt = xsum_value(&a[6]);
        p->zr = xsum_value(&a[7]);
    }
}

static inline __attribute__((always_inline)) void fill_sphere(spheres_t *sp, const pops_t *f0,
                                                             const link_list_t *list, int galilean, double inv_decay,
                                                             spheres_part_t part, layout_state_t state, int single)
{
    const pops_t fl = pops_fixed(f0, state, single);
    const pops_t *f = &fl;
    size_t cell = (size_t)-1;
    double rho = 0.0, j[3] = {0.0, 0.0, 0.0};
    /* the load of a cell's links, summed in q order, then added exactly to
     * the sphere's (common/exact_sum.h): the same bits on any ranks. The
     * cells' loads wait in cb and go in FILL_CHUNK at a time, four terms at
     * a time (xsum_add_array: the same value as one xsum_add per term) */
    double cl[8] = {0.0};
    double cb[8][FILL_CHUNK];
    int ncb = 0;
    sphere_t *p = list->n > 0 ? &sp->s[list->l[0].sphere] : NULL;
    /* the recovery of n^- from the post-collision populations (below) holds
     * away from omega_minus = 1 */
    const int use_decay = fabs(1.0 - sp->omega_minus) >= SPHERES_MR_DECAY_MIN;
    for (size_t n = 0; n < list->n; n++) {
        sphere_link_t *l = &list->l[n];
        const int q = l->q, o = lb_opposite(q);
        if (l->xf != cell) { /* the links of a cell are consecutive (sphere_links) */
            if (n > 0) {
                for (int a = 0; a < 8; a++) {
                    cb[a][ncb] = cl[a];
                    cl[a] = 0.0;
                }
                if (++ncb == FILL_CHUNK) {
                    for (int a = 0; a < 8; a++) {
                        xsum_add_array(&p->acc[a], cb[a], ncb);
                    }
                    ncb = 0;
                }
            }
            cell = l->xf;
            rho = pops_moments(f, cell, j);
        }
        /* the fill waits on memory (the 19 scattered values of a cell's
         * moments): fetch those of the cell FILL_AHEAD links on in advance */
        if (n + FILL_AHEAD < list->n && list->l[n + FILL_AHEAD].xf != list->l[n + FILL_AHEAD - 1].xf) {
            const size_t ahead = list->l[n + FILL_AHEAD].xf;
            for (int qq = 0; qq < LB_Q; qq++) {
                pops_prefetch(f, pops_post_slot(f, qq, ahead), 0);
            }
        }
        /* and the link's own scattered values (x_f - c_q, x_f - 2 c_q and the
         * slot it writes) LINK_AHEAD links on: the fill is bound by their
         * latency, one miss after another without it */
        if (n + LINK_AHEAD < list->n) {
            const sphere_link_t *m = &list->l[n + LINK_AHEAD];
            const int mo = lb_opposite(m->q);
            pops_prefetch(f, pops_in_slot(f, mo, m->xf), 1);
            if (m->xff != m->xf && m->xff < SPHERE_EXT) {
                pops_prefetch(f, pops_post_slot(f, m->q, m->xff), 0);
                if (m->co.b[1] != 0.0) {
                    pops_prefetch(f, pops_post_slot(f, mo, m->xff), 0);
                }
            }
            if (m->co.a[2] != 0.0 && m->xfff < SPHERE_EXT) {
                pops_prefetch(f, pops_post_slot(f, m->q, m->xfff), 0);
            }
        }
        double wr[3], uw[3];
        spheres_cross(p->w, l->rw, wr);
        for (int a = 0; a < 3; a++) {
            uw[a] = p->v[a] + wr[a];
        }
        const double cu = lb_c[q][0] * uw[0] + lb_c[q][1] * uw[1] + lb_c[q][2] * uw[2];
        const double A = l->co.a[0] + l->co.a[1] + l->co.a[2];
        const double f_old = pops_post(f, q, l->xf);
        double f_new = l->co.a[0] * f_old - A * 6.0 * lb_w[q] * rho * cu;
        const int linear = l->co.a[1] != 0.0 || l->co.b[0] != 0.0 || l->co.b[1] != 0.0;
        const double f_ff = (linear || l->co.corr != 0.0) && l->xff != l->xf ? spheres_post(sp, f, q, l->xff) : 0.0;
        if (linear) {
            f_new += l->co.a[1] * f_ff + l->co.b[0] * pops_post(f, o, l->xf);
        }
        if (l->co.a[2] != 0.0) {
            f_new += l->co.a[2] * spheres_post(sp, f, q, l->xfff);
        }
        if (l->co.b[1] != 0.0) {
            f_new += l->co.b[1] * spheres_post(sp, f, o, l->xff);
        }
        if (l->co.corr != 0.0 && !l->fresh && (l->has_pre || use_decay)) {
            /* antisymmetric non-equilibrium of the pre-collision populations at x_f:
             * f_q came from x_f - c_q, f_qbar from the solid side, the very slot of this link.
             * It is taken against the pre-collision momentum j - F (Guo's collision adds
             * F to it), i.e. n^- + S^-/2 with S^- = 3 w c.F: the part that carries the
             * velocity's second derivatives. Against rho u = j - F/2 a forced Poiseuille
             * flow comes out 0.3% low in 12 cells (tau 1); against j - F it is exact to
             * round-off for every delta, tau and Lambda (checked with a 1D channel). */
            double nm;
            if (l->has_pre) {
                /* the pair the last fill kept */
                double cu0 = 0.0;
                for (int a = 0; a < 3; a++) {
                    cu0 += lb_c[q][a] * (j[a] - sp->body_force[a]);
                }
                nm = 0.5 * (l->pre[0] - l->pre[1]) - 3.0 * lb_w[q] * cu0;
            } else {
                const double cj = lb_c[q][0] * j[0] + lb_c[q][1] * j[1] + lb_c[q][2] * j[2];
                nm = (0.5 * (f_old - pops_post(f, o, l->xf)) - 3.0 * lb_w[q] * cj) * inv_decay;
            }
            f_new += l->co.corr * nm;
        }
        if (l->co.corr != 0.0) {
            /* the pre-collision pair of x_f at the next fill: f~_q(x_f - c_q)
             * streams to x_f, f_new is what x_f receives from the wall */
            l->pre[0] = f_ff;
            l->pre[1] = f_new;
            l->has_pre = l->xff != l->xf;
        }
        if (part == SPHERES_HOLD_OUTER && l->outer) {
            l->fnew = f_new;
        } else {
            pops_write(f, o, pops_in_slot(f, o, l->xf), f_new);
        }
        /* Eq. 7 (Ladd), populations centred on the rest weight so that hidden
         * faces of touching spheres carry no spurious pressure; Wen et al.,
         * Phys. Rev. E 89 (2014) 023305, add -(f_old - f_new) u_w. */
        const double mem = f_old + f_new - 2.0 * lb_w[q];
        double df[3];
        for (int a = 0; a < 3; a++) {
            df[a] = lb_c[q][a] * mem - (galilean ? (f_old - f_new) * uw[a] : 0.0);
        }
        if (l->film != -1) {
            /* in the film zone: the normal part is the film's (sphere_links.c film_partner) */
            double n[3] = {0.0, 0.0, 0.0};
            if (l->film >= 0) {
                spheres_min_image(sp, p->c, sp->s[l->film].c, n);
                const double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
                for (int a = 0; a < 3; a++) {
                    n[a] /= len;
                }
            } else {
                n[(-2 - l->film) / 2] = 1.0;
            }
            const double dn = df[0] * n[0] + df[1] * n[1] + df[2] * n[2];
            for (int a = 0; a < 3; a++) {
                df[a] -= dn * n[a];
            }
        }
        double t[3];
        spheres_cross(l->rw, df, t);
        for (int a = 0; a < 3; a++) {
            cl[a] += df[a];
            cl[3 + a] += t[a];
        }
        /* the moving-wall term makes df react at once to the wall velocity:
         * d(df)/d(u_w) = -A 6 w rho c c^T; its isotropic parts for v and for
         * w (u_w = v + w x r_w, so c . u_w = c . v + w . (r_w x c)) */
        const double cq[3] = {lb_c[q][0], lb_c[q][1], lb_c[q][2]};
        double rc[3];
        spheres_cross(l->rw, cq, rc);
        const double k = A * 6.0 * lb_w[q] * rho / 3.0;
        cl[6] += k * (cq[0] * cq[0] + cq[1] * cq[1] + cq[2] * cq[2]);
        cl[7] += k * (rc[0] * rc[0] + rc[1] * rc[1] + rc[2] * rc[2]);
    }
    if (p != NULL) {
        for (int a = 0; a < 8; a++) {
            cb[a][ncb] = cl[a];
            xsum_add_array(&p->acc[a], cb[a], ncb + 1);
        }
    }
}
