/* fluid.c — the fluid component: creation, the time step, fields, the
 * spheres' loads (the totals and the check for numerical trouble:
 * diagnostics.c and scan.c).
 *
 * A step is the algorithm in two named stages: the boundary stage writes the
 * populations that interior cells receive from ghost and solid neighbours
 * (walls.c, spheres.c), then the fused kernel streams and collides
 * (kernel.c): in place on one array, alternating the local and the push
 * kernel, or from one array into the other, which then swap (layout.h).
 * Populations are SoA with one ghost layer (grid.h). */
#include "fluid_internal.h"
#include "../common/big_alloc.h"
#include "../common/coupling.h"

#include "../common/initial_profile.h"
#include "lattice.h"

#include <math.h>
#include <stdlib.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

/* One population array of values of esize bytes, 64-byte aligned (on huge
 * pages with AGGLO_HUGE_PAGES=1: common/big_alloc.h); the cells
 * between ncells and the stride of each population are zeroed (they are
 * never read, but a saved state copies them). */
static void *alloc_populations(const grid_t *g, size_t esize)
{
    if (g->stride > (SIZE_MAX - 1024) / (LB_Q * esize)) {
        return NULL; /* more bytes than an address space holds */
    }
    const size_t body = (size_t)LB_Q * g->stride * esize;
    unsigned char *m = big_alloc(body);
    if (m != NULL) {
        for (int q = 0; q < LB_Q; q++) {
            memset(m + ((size_t)q * g->stride + g->ncells) * esize, 0, (g->stride - g->ncells) * esize);
        }
    }
    return m;
}

/* Equilibrium everywhere (ghosts too), written in the kernel's row order so
 * that first touch puts pages near the thread that streams them. */
static void init_uniform(fluid_t *fl, double rho, const double u[3])
{
    const grid_t *g = &fl->g;
    double feq[LB_Q];
    for (int q = 0; q < LB_Q; q++) {
        feq[q] = lb_feq(q, rho, u[0], u[1], u[2]);
    }
    if (fl->streaming == STREAMING_MOMENTS) {
        const pops_t p = fluid_pops(fl);
#pragma omp parallel for schedule(static)
        for (size_t i = 0; i < g->ncells; i++) {
            pops_set_post(&p, i, feq);
        }
        return;
    }
    const size_t N = g->stride;
    const size_t plane = (size_t)g->s[0] * (size_t)g->s[1];
    const int swapped = fl->layout == LAYOUT_SWAPPED; /* post_slot(q, x) is slot qbar of x */
    for (int k = 0; k < fluid_arrays(fl); k++) {
#pragma omp parallel for schedule(static)
        for (int z = 0; z < g->s[2]; z++) {
            for (int q = 0; q < LB_Q; q++) {
                const size_t o = (size_t)q * N + (size_t)z * plane;
                const double v = feq[swapped ? lb_opposite(q) : q];
                for (size_t i = 0; i < plane; i++) {
                    if (fl->single) {
                        ((float *)fl->f[k])[o + i] = (float)(v - lb_w[q]); /* layout.h */
                    } else {
                        ((double *)fl->f[k])[o + i] = v;
                    }
                }
            }
        }
    }
}

/* The scene's initial velocity profile, cell by cell (interior cell i of an
 * axis has its centre at (i - 1/2) dx): equilibrium at rho = 1 plus the
 * first-order non-equilibrium part of the Chapman-Enskog expansion,
 * f1_q = -3 tau w_q (c_qa c_qb - delta_ab / 3) d_a u_b (symmetric rate 1/tau
 * for BGK and TRT), after collision (the arrays hold post-collision
 * populations: f1 (1 - 1/tau), i.e. the factor -3 (tau - 1)), so that a steady profile starts with its viscous stress
 * and no start-up transient. Velocity gradients by central differences over
 * one cell, exact for the quadratic plane-channel profile. The momentum
 * is that after a collision with Guo's body force, rho u + F/2. */
static status_t init_profile(fluid_t *fl, const scene_t *scene, const log_t *log)
{
    const grid_t *g = &fl->g;
    const double dx = scene->fluid.dx, uv = units_velocity(&fl->units), tau = scene->fluid.tau;
    pops_t arrays[2]; /* every array, in the (local: PULL or SWAPPED) layout state */
    for (int k = 0; k < fluid_arrays(fl); k++) {
        pops_init(&arrays[k], g, fl->f[k], fl->single, fl->layout);
    }
    /* the profile varies along the channel axis n only (initial_profile.h):
     * the values of each plane across it are computed once (the other
     * coordinates of pos change nothing, the differences along them are 0) */
    const int n = scene->fluid.channel_axis, len = n >= 0 ? g->s[n] : 1;
    double *vals = malloc((size_t)len * LB_Q * sizeof *vals);
    if (vals == NULL) {
        return log_msg(log, STATUS_ERROR, "fluid", "out of memory for the initial profile's planes (%zu bytes)",
                       (size_t)len * LB_Q * sizeof *vals);
    }
#pragma omp parallel for schedule(static)
    for (int t = 0; t < len; t++) {
        const int *o = fl->d.lo; /* global position of the block's cells */
        int X[3] = {0, 0, 0};
        if (n >= 0) {
            X[n] = t;
        }
        const double pos[3] = {(X[0] + o[0] - 0.5) * dx, (X[1] + o[1] - 0.5) * dx, (X[2] + o[2] - 0.5) * dx};
        double u[3], grad[3][3];
        scene_initial_velocity(scene, pos, u);
        for (int a = 0; a < 3; a++) {
            double p1[3] = {pos[0], pos[1], pos[2]}, p0[3] = {pos[0], pos[1], pos[2]}, u1[3], u0[3];
            p1[a] += 0.5 * dx;
            p0[a] -= 0.5 * dx;
            scene_initial_velocity(scene, p1, u1);
            scene_initial_velocity(scene, p0, u0);
            for (int b = 0; b < 3; b++) {
                grad[a][b] = (u1[b] - u0[b]) / uv; /* lattice units per cell */
            }
        }
        /* post-collision momentum with Guo forcing: rho u + F/2 */
        const double *F = fl->units.force_lat;
        const double ul[3] = {u[0] / uv + 0.5 * F[0], u[1] / uv + 0.5 * F[1], u[2] / uv + 0.5 * F[2]};
        for (int q = 0; q < LB_Q; q++) {
            double qs = 0.0;
            for (int a = 0; a < 3; a++) {
                for (int b = 0; b < 3; b++) {
                    qs += (lb_c[q][a] * lb_c[q][b] - (a == b ? 1.0 / 3.0 : 0.0)) * grad[a][b];
                }
            }
            vals[(size_t)t * LB_Q + (size_t)q] = lb_feq(q, 1.0, ul[0], ul[1], ul[2]) - 3.0 * (tau - 1.0) * lb_w[q] * qs;
        }
    }
#pragma omp parallel for schedule(static)
    for (int z = 0; z < g->s[2]; z++) {
        for (int y = 0; y < g->s[1]; y++) {
            for (int x = 0; x < g->s[0]; x++) {
                const int X[3] = {x, y, z};
                const double *v = vals + (size_t)(n >= 0 ? X[n] : 0) * LB_Q;
                const size_t i = grid_index(g, x, y, z);
                for (int k = 0; k < fluid_arrays(fl); k++) {
                    pops_set_post(&arrays[k], i, v);
                }
                if (fl->streaming == STREAMING_MOMENTS) {
                    const pops_t pm = fluid_pops(fl);
                    pops_set_post(&pm, i, v);
                }
            }
        }
    }
    free(vals);
    return STATUS_OK;
}

status_t fluid_create(const scene_t *scene, const log_t *log, fluid_t **out)
{
    *out = NULL;
    fluid_t *fl = calloc(1, sizeof *fl);
    if (fl == NULL) {
        return log_msg(log, STATUS_ERROR, "fluid", "out of memory for the fluid component (%zu bytes)", sizeof *fl);
    }
    if (log != NULL) {
        fl->log = *log;
    }
    status_t st = units_derive(scene, log, &fl->units);
    if (st != STATUS_OK) {
        free(fl);
        return st;
    }
    st = decomp_init(&fl->d, scene, fl->units.n, log);
    if (st >= STATUS_ERROR) {
        free(fl);
        return st;
    }
    grid_init(&fl->g, fl->d.n, units_grid_align(scene));
    fl->kp.omega_plus = fl->units.omega_plus;
    fl->kp.omega_minus = fl->units.omega_minus;
    memcpy(fl->kp.force, fl->units.force_lat, sizeof fl->kp.force);
    fl->path = strdup(scene->path ? scene->path : "(scene)");
    fl->streaming = scene->fluid.streaming;
    fl->single = scene->fluid.precision == PRECISION_SINGLE;
    const char *ov = getenv("AGGLO_OVERLAP");
    fl->overlap = !(ov != NULL && strcmp(ov, "0") == 0);
    const char *sov = getenv("AGGLO_SPHERE_OVERLAP");
    fl->sov.mode = sov == NULL ? SOV_AUTO : strcmp(sov, "0") == 0 ? SOV_OFF : strcmp(sov, "1") == 0 ? SOV_ON : SOV_AUTO;
    const char *skip = getenv("AGGLO_SKIP_SOLID");
    fl->skip_on = fl->streaming == STREAMING_IN_PLACE && !(skip != NULL && strcmp(skip, "0") == 0);
    fl->skip.map = -1;
    fl->layout = fl->streaming == STREAMING_TWO_ARRAY ? LAYOUT_PULL
                 : fl->streaming == STREAMING_MOMENTS ? LAYOUT_MOMENTS
                                                      : LAYOUT_SWAPPED;
    if (fl->streaming == STREAMING_MOMENTS) {
        /* its kernel goes over whole planes in z order (kernel_moments.c):
         * no chunks of planes beside the spheres' stages, and on several
         * ranks the exchange before the update (no inner rows in flight) */
        fl->sov.mode = SOV_OFF;
        fl->overlap = 0;
    }
    int have = 1;
    for (int k = 0; k < fluid_arrays(fl); k++) {
        fl->f[k] = alloc_populations(&fl->g, fluid_value_bytes(fl));
        have = have && fl->f[k] != NULL;
    }
    fl->flags = calloc(cellflags_bytes(fl->g.ncells), 1);
    if (fl->path == NULL || !have || fl->flags == NULL) {
        have = 0;
    }
    for (int z = 0; z < fl->g.s[2] && have; z++) {
        for (int y = 0; y < fl->g.s[1]; y++) {
            for (int x = 0; x < fl->g.s[0]; x++) {
                /* a ghost cell beyond faces to other ranks only is their fluid */
                const int X[3] = {x, y, z};
                int ghost = 0;
                for (int a = 0; a < 3; a++) {
                    if (X[a] < 1 || X[a] > fl->g.n[a]) {
                        ghost = ghost || !decomp_exchanged(&fl->d, a, X[a] < 1 ? 0 : 1);
                    }
                }
                cellflags_set(fl->flags, grid_index(&fl->g, x, y, z), ghost ? CELL_GHOST : CELL_FLUID);
            }
        }
    }
    if (have && fl->streaming == STREAMING_MOMENTS) {
        have = moments_create(&fl->mom, &fl->g);
    }
    if (!have && fl->streaming == STREAMING_MOMENTS) {
        log_msg(log, STATUS_ERROR, "fluid",
                "%s: out of memory for the moments, side store and flags of %d x %d x %d cells (%.4g GB: %d moments "
                "of %.4g GB, the side store of the ghost layers and the flags)",
                fl->path, fl->g.n[0], fl->g.n[1], fl->g.n[2],
                ((double)fl->g.ncells * units_bytes_per_cell(scene) + units_extra_bytes(scene, &fl->g, 0)) / 1e9,
                MOM_N, (double)fl->g.ncells * MOM_N * sizeof(double) / 1e9);
        fluid_free(fl);
        return STATUS_ERROR;
    }
    if (!have) {
        log_msg(log, STATUS_ERROR, "fluid",
                "%s: out of memory for the populations and flags of %d x %d x %d cells (%.4g GB: %d array(s) of "
                "%.4g GB and the flags)",
                fl->path, fl->g.n[0], fl->g.n[1], fl->g.n[2], (double)fl->g.ncells * units_bytes_per_cell(scene) / 1e9,
                fluid_arrays(fl), (double)fl->g.ncells * LB_Q * fluid_value_bytes(fl) / 1e9);
        fluid_free(fl);
        return STATUS_ERROR;
    }
    const double uv = units_velocity(&fl->units);
    const double u0[3] = {scene->fluid.initial_velocity[0] / uv, scene->fluid.initial_velocity[1] / uv,
                          scene->fluid.initial_velocity[2] / uv};
    if (scene->fluid.initial_profile == INITIAL_UNIFORM) {
        init_uniform(fl, 1.0, u0);
    } else if (init_profile(fl, scene, log) != STATUS_OK) {
        fluid_free(fl);
        return STATUS_ERROR;
    }
    st = walls_build(&fl->walls, &fl->g, scene, &fl->units, &fl->d, log);
    fl->walls.flags = fl->flags;
    if (st == STATUS_OK) {
        st = spheres_init(&fl->spheres, scene, &fl->units, &fl->g, &fl->d, log);
    }
    if (st == STATUS_OK) {
        const pops_t p = fluid_pops(fl);
        st = spheres_map(&fl->spheres, &fl->g, fl->flags, &p, log);
    }
    if (st == STATUS_OK && fl->streaming == STREAMING_MOMENTS && !moments_sync(&fl->mom, &fl->g, &fl->spheres)) {
        st = log_msg(log, STATUS_ERROR, "fluid", "%s: out of memory for the side store of the cells inside the spheres",
                     fl->path);
    }
    if (st != STATUS_OK) {
        fluid_free(fl);
        return st;
    }
    fl->t0 = 0.0;
    *out = fl;
    return STATUS_OK;
}

void fluid_free(fluid_t *fl)
{
    if (fl == NULL) {
        return;
    }
    walls_free(&fl->walls);
    spheres_free(&fl->spheres);
    kernel_skip_free(&fl->skip);
    free(fl->sov.plane);
    free(fl->sov.far);
    free(fl->sov.near);
    decomp_free(&fl->d);
    free(fl->flags);
    free(fl->f[1]);
    free(fl->f[0]);
    moments_free(&fl->mom);
    free(fl->path);
    free(fl);
}

/* The load a sphere delivers (lattice units): that of the last step, or the
 * mean of the last two when fluid.force_averaging is set, the one before the
 * first step zero: so the loads delivered over a run add up to those the
 * fluid exchanged, less half the last. (The first load whole, then averaged
 * with the second, counted it one and a half times: a sphere launched in a
 * periodic box at rest left the total momentum 11% below its start.) */
static void delivered_load(const sphere_t *p, double force[3], double torque[3])
{
    const int avg = p->averaging;
    for (int a = 0; a < 3; a++) {
        force[a] = avg ? 0.5 * (p->f[a] + p->fprev[a]) : p->f[a];
        torque[a] = avg ? 0.5 * (p->t[a] + p->tprev[a]) : p->t[a];
    }
}

/* The period-2 watch. Explicit coupling feeds the particle velocity of one
 * step into the boundary force of the next; for a light or small particle
 * this force reacts so strongly that the velocity overshoots and flips every
 * step (an added-mass type instability). For each free sphere its motion,
 * the velocity v and the surface speed w r that the master sets every step,
 * is watched: the second difference d_n = m_n - 2 m_(n-1) + m_(n-2) of a
 * period-2 signal of amplitude A is +-4A with alternating sign, of a smooth
 * signal about 0. The motion, not the load: close to tau = 1/2 the lattice's
 * own non-equilibrium parts flip sign every step (relaxation factor
 * 1 - 1/tau = -0.96 at tau 0.51), and the load on a moving sphere alternates
 * by twice its mean even with the motion prescribed, while a stable free
 * sphere under that load moves smoothly (0.2% period-2 in its velocity). So
 * WATCH_STEPS steps in a row with d_n . d_(n-1) < 0 and |d_n|/4 above
 * WATCH_AMPLITUDE of the mean speed |m_n + m_(n-1)|/2 (velocity, or surface
 * speed; at least WATCH_SPEED_FLOOR in lattice units, so that the round-off
 * of a sphere at rest is no oscillation) raise one warning per sphere, with
 * the remedies, unless the oscillation decays: the start-up transient of a
 * particle released from rest or set in motion at once (the dual star's
 * first steps in shear) flips too, but its amplitude falls. So after
 * WATCH_STEPS alternating steps the absolute amplitude is compared with the
 * one at the start of the window: below WATCH_DECAY of it the window starts
 * again (a transient), otherwise (persistent) it warns. A growing
 * oscillation may wreck the run sooner (an unstable light sphere moves more
 * than a cell per step within 15-25 steps): when the amplitude has grown in
 * each of WATCH_GROW_STEPS alternating steps in a row, to WATCH_GROW times
 * its value where that growth began or more, it warns at once, before the
 * failure it explains (steady growth, not merely a larger amplitude, which
 * noise that alternates by chance for a few steps can show). */
enum { WATCH_STEPS = 30, WATCH_GROW_STEPS = 6 };
static const double WATCH_AMPLITUDE = 0.02;
static const double WATCH_SPEED_FLOOR = 1e-3;
static const double WATCH_DECAY = 0.9;
static const double WATCH_GROW = 4.0;

status_t fluid_watch_period_two(fluid_t *fl)
{
    status_t st = STATUS_OK;
    for (int i = 0; i < fl->spheres.n; i++) {
        sphere_t *p = &fl->spheres.s[i];
        if (p->motion != MOTION_FREE || p->warned) {
            continue;
        }
        double motion[6];
        for (int a = 0; a < 3; a++) {
            motion[a] = p->v[a];
            motion[3 + a] = p->w[a] * p->r;
        }
        memmove(p->hist[1], p->hist[0], 2 * sizeof p->hist[0]);
        memcpy(p->hist[0], motion, sizeof motion);
        if (p->nhist < 3) {
            p->nhist++;
            continue;
        }
        /* velocity and surface speed, both against one scale: the mean
         * speed S = max(|v|, |w| r, floor), so that a rotation that is about
         * zero (a settling sphere) or a velocity that is about zero (a sphere
         * turning in shear) does not count its round-off as an oscillation */
        double d[6], mv = 0.0, mw = 0.0;
        for (int a = 0; a < 6; a++) {
            const double m = 0.5 * (p->hist[0][a] + p->hist[1][a]);
            d[a] = p->hist[0][a] - 2.0 * p->hist[1][a] + p->hist[2][a];
            *(a < 3 ? &mv : &mw) += m * m;
        }
        const double scale = fmax(sqrt(fmax(mv, mw)), WATCH_SPEED_FLOOR);
        int alternating = 0;
        double amp = 0.0, amp_abs = 0.0;
        for (int o = 0; o < 6; o += 3) {
            double d2 = 0.0, dot = 0.0;
            for (int a = o; a < o + 3; a++) {
                d2 += d[a] * d[a];
                dot += d[a] * p->hist_d[a];
                p->hist_d[a] = d[a];
            }
            const double rel = 0.25 * sqrt(d2) / scale;
            if (dot < 0.0 && rel > WATCH_AMPLITUDE) {
                alternating = 1;
                amp = fmax(amp, rel);
                amp_abs = fmax(amp_abs, 0.25 * sqrt(d2));
            }
        }
        p->nalt = alternating ? p->nalt + 1 : 0;
        if (p->nalt == 1) {
            p->amp0 = amp_abs;
        }
        if (alternating && p->nalt > 1 && amp_abs > p->amp_prev) {
            p->ngrow++;
        } else {
            p->ngrow = 0;
            p->amp_grow0 = amp_abs;
        }
        p->amp_prev = amp_abs;
        if (p->nalt >= WATCH_STEPS && amp_abs < WATCH_DECAY * p->amp0) {
            p->nalt = 1; /* decaying (a start-up transient): a new window from here */
            p->amp0 = amp_abs;
        }
        const int growing = p->ngrow >= WATCH_GROW_STEPS && amp_abs >= WATCH_GROW * p->amp_grow0;
        if (p->nalt >= WATCH_STEPS || growing) {
            p->warned = 1;
            const double dx = fl->units.dx;
            st = status_worst(st, log_msg(&fl->log, STATUS_WARNING, "fluid",
                "%s: sphere %d (radius %.3g cells, density ratio %.3g) at (%.4g, %.4g, %.4g) m, step %ld (t = %.6g s): "
                "its velocity has alternated every step for %d steps (period-2 oscillation, amplitude %.3g%% "
                "of its speed%s): explicit coupling of a light or small particle, whose boundary force reacts at once "
                "to its velocity (an added-mass type instability). Remedies: rigid.coupling: auto or implicit "
                "(the default auto picks implicit for this body unless set otherwise) with fluid.force_averaging "
                "true or not set (stable down to density ratio 0.03 at radius 3 cells), more cells per radius "
                "(fluid.dx), a smaller time step (fluid.tau)",
                fl->path, i, p->r, p->density_ratio, (p->c[0] - 0.5) * dx, (p->c[1] - 0.5) * dx,
                (p->c[2] - 0.5) * dx, fl->step, fluid_time(fl), p->nalt, 100.0 * amp, growing ? ", growing" : ""));
        }
    }
    return st;
}

/* On several ranks every rank takes rank 0's sphere kinematics: the master
 * of each rank sets them from its own copy of the rigid component, and
 * ranks that disagreed in a last bit (another CPU's libm) would disagree on
 * which cells are solid. */
void fluid_share_kinematics(fluid_t *fl)
{
    if (!decomp_parallel(&fl->d)) {
        return;
    }
    const int n = fl->spheres.n;
    double *buf = fl->spheres.kin;
    for (int i = 0; i < n; i++) {
        memcpy(buf + 9 * i, fl->spheres.s[i].c, 3 * sizeof(double));
        memcpy(buf + 9 * i + 3, fl->spheres.s[i].v, 3 * sizeof(double));
        memcpy(buf + 9 * i + 6, fl->spheres.s[i].w, 3 * sizeof(double));
    }
    decomp_bcast(&fl->d, buf, 9 * (size_t)n * sizeof(double));
    for (int i = 0; i < n; i++) {
        memcpy(fl->spheres.s[i].c, buf + 9 * i, 3 * sizeof(double));
        memcpy(fl->spheres.s[i].v, buf + 9 * i + 3, 3 * sizeof(double));
        memcpy(fl->spheres.s[i].w, buf + 9 * i + 6, 3 * sizeof(double));
    }
}

long fluid_step_count(const fluid_t *fl) { return fl->step; }

void fluid_set_exchange_steps(fluid_t *fl, long k) { fl->exchange_steps = k; }
double fluid_time(const fluid_t *fl) { return fl->t0 + (double)fl->step * fl->units.dt; }
const units_t *fluid_units(const fluid_t *fl) { return &fl->units; }

void fluid_cells(const fluid_t *fl, int n[3])
{
    for (int a = 0; a < 3; a++) {
        n[a] = fl->d.N[a];
    }
}

void fluid_block(const fluid_t *fl, int lo[3], int n[3], const void **comm)
{
    for (int a = 0; a < 3; a++) {
        lo[a] = fl->d.lo[a];
        n[a] = fl->d.n[a];
    }
    *comm = fl->d.comm;
}

void fluid_decomposition(const fluid_t *fl, fluid_decomposition_t *out)
{
    out->ranks = fl->d.size;
    out->rank = fl->d.rank;
    for (int a = 0; a < 3; a++) {
        out->dims[a] = fl->d.dims[a];
        out->lo[a] = fl->d.lo[a];
        out->n[a] = fl->d.n[a];
    }
    out->halo_bytes = fl->d.halo_bytes;
    out->halo_seconds = fl->d.halo_seconds;
}

size_t fluid_memory_bytes(const fluid_t *fl)
{
    return (size_t)fluid_arrays(fl) * (size_t)LB_Q * fl->g.stride * fluid_value_bytes(fl) +
           (fl->streaming == STREAMING_MOMENTS ? moments_bytes(&fl->mom, &fl->g) : 0) +
           cellflags_bytes(fl->g.ncells) + fl->walls.nlinks * sizeof(ghost_link_t) + fl->walls.ncopies * sizeof(copy_link_t) +
           sizeof *fl;
}

void fluid_moments_lattice(fluid_t *fl, double *rho, double *u)
{
    fluid_moments_lattice_planes(fl, 0, fl->g.n[2], rho, u);
}

void fluid_moments_lattice_planes(fluid_t *fl, int z0, int nz, double *rho, double *u)
{
    const grid_t *g = &fl->g;
    const pops_t pf = fluid_pops(fl), *f = &pf;
    const int nx = g->n[0], ny = g->n[1];
    /* over rows, not planes: a slab may be a plane or two */
#pragma omp parallel for collapse(2) schedule(static)
    for (int z = 0; z < nz; z++) {
        for (int y = 0; y < ny; y++) {
            for (int x = 0; x < nx; x++) {
                const size_t o = (size_t)x + (size_t)nx * ((size_t)y + (size_t)ny * (size_t)z);
                const size_t i = grid_index(g, x + 1, y + 1, z0 + z + 1);
                double r = 0.0, v[3] = {0.0, 0.0, 0.0};
                if (cellflags_get(fl->flags, i) == CELL_FLUID) {
                    fluid_local_moments(fl, f, i, &r, v);
                }
                if (rho != NULL) {
                    rho[o] = r;
                }
                if (u != NULL) {
                    u[3 * o] = v[0];
                    u[3 * o + 1] = v[1];
                    u[3 * o + 2] = v[2];
                }
            }
        }
    }
}

void fluid_set_equilibrium_lattice(fluid_t *fl, const double *rho, const double *u)
{
    const grid_t *g = &fl->g;
    const pops_t pf = fluid_pops(fl);
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    for (int z = 0; z < nz; z++) {
        for (int y = 0; y < ny; y++) {
            for (int x = 0; x < nx; x++) {
                const size_t o = (size_t)x + (size_t)nx * ((size_t)y + (size_t)ny * (size_t)z);
                const size_t i = grid_index(g, x + 1, y + 1, z + 1);
                const double r = rho != NULL ? rho[o] : 1.0;
                const double ux = u != NULL ? u[3 * o] : 0.0, uy = u != NULL ? u[3 * o + 1] : 0.0,
                             uz = u != NULL ? u[3 * o + 2] : 0.0;
                double v[LB_Q];
                for (int q = 0; q < LB_Q; q++) {
                    v[q] = lb_feq(q, r, ux, uy, uz);
                }
                pops_set_post(&pf, i, v);
            }
        }
    }
}

void fluid_flags(const fluid_t *fl, unsigned char *flags)
{
    fluid_flags_planes(fl, 0, fl->g.n[2], flags);
}

void fluid_flags_planes(const fluid_t *fl, int z0, int nz, unsigned char *flags)
{
    const grid_t *g = &fl->g;
    const int nx = g->n[0], ny = g->n[1];
    for (int z = 0; z < nz; z++) {
        for (int y = 0; y < ny; y++) {
            for (int x = 0; x < nx; x++) {
                flags[(size_t)x + (size_t)nx * ((size_t)y + (size_t)ny * (size_t)z)] =
                    (unsigned char)cellflags_get(fl->flags, grid_index(g, x + 1, y + 1, z0 + z + 1));
            }
        }
    }
}

void fluid_totals_lattice(fluid_t *fl, double *mass, double momentum[3])
{
    const grid_t *g = &fl->g;
    const pops_t pf = fluid_pops(fl), *f = &pf;
    xsum_t t[4];
    for (int k = 0; k < 4; k++) {
        xsum_zero(&t[k]);
    }
    /* exact sums (common/exact_sum.h): any order of threads and ranks */
#pragma omp parallel
    {
        xsum_t mine[4];
        for (int k = 0; k < 4; k++) {
            xsum_zero(&mine[k]);
        }
#pragma omp for collapse(2) schedule(static)
        for (int z = 1; z <= g->n[2]; z++) {
            for (int y = 1; y <= g->n[1]; y++) {
                for (int x = 1; x <= g->n[0]; x++) {
                    const size_t i = grid_index(g, x, y, z);
                    if (cellflags_get(fl->flags, i) != CELL_FLUID) {
                        continue;
                    }
                    for (int q = 0; q < LB_Q; q++) {
                        const double v = pops_post(f, q, i);
                        xsum_add(&mine[0], v);
                        for (int a = 0; a < 3; a++) {
                            if (lb_c[q][a] != 0) {
                                xsum_add(&mine[1 + a], lb_c[q][a] * v);
                            }
                        }
                    }
                }
            }
        }
#pragma omp critical(fluid_totals)
        for (int k = 0; k < 4; k++) {
            xsum_merge(&t[k], &mine[k]);
        }
    }
    decomp_sum(&fl->d, t, 4);
    *mass = xsum_value(&t[0]);
    for (int a = 0; a < 3; a++) {
        momentum[a] = xsum_value(&t[1 + a]);
    }
}

status_t fluid_check_loads(fluid_t *fl, double mach_limit)
{
    for (int i = 0; i < fl->spheres.n; i++) {
        const sphere_t *p = &fl->spheres.s[i];
        double f[3], t[3];
        delivered_load(p, f, t);
        if (isfinite(f[0] + f[1] + f[2] + t[0] + t[1] + t[2] + p->zt + p->zr)) {
            continue;
        }
        /* the load sums the links of the sphere's surface cells: the fluid
         * there is in trouble; the scan names the cell (and the worst one) */
        const status_t st = fluid_check(fl, mach_limit);
        const double dx = fl->units.dx;
        return log_msg(&fl->log, STATUS_ERROR, "fluid",
                       "%s: numerical trouble at step %ld (t = %.6g s): non-finite hydrodynamic load on sphere %d at "
                       "(%.4g, %.4g, %.4g) m (force (%.4g, %.4g, %.4g), torque (%.4g, %.4g, %.4g) lattice)%s",
                       fl->path, fl->step, fluid_time(fl), i, (p->c[0] - 0.5) * dx, (p->c[1] - 0.5) * dx,
                       (p->c[2] - 0.5) * dx, f[0], f[1], f[2], t[0], t[1], t[2],
                       st >= STATUS_ERROR ? " (the cell is named above)" : "");
    }
    return STATUS_OK;
}

status_t fluid_check_load_sizes(fluid_t *fl, double mach_limit, const unsigned char *only)
{
    for (int i = 0; i < fl->spheres.n; i++) {
        const sphere_t *p = &fl->spheres.s[i];
        if (only != NULL && !only[i]) {
            continue;
        }
        double f[3], t[3];
        delivered_load(p, f, t);
        const double fn = sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
        const double tn = sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
        if (fn > LOAD_SLIP_MAX * p->zt || tn * p->r > LOAD_SLIP_MAX * p->zr) {
            /* the same load on every rank: every rank scans */
            return fluid_check(fl, mach_limit);
        }
    }
    return STATUS_OK;
}

int fluid_nspheres(const fluid_t *fl) { return fl->spheres.n; }

status_t fluid_set_sphere(fluid_t *fl, int i, const double c[3], const double v[3], const double w[3])
{
    sphere_t *p = &fl->spheres.s[i];
    const units_t *u = &fl->units;
    double cn[3], moved = 0.0;
    for (int a = 0; a < 3; a++) {
        cn[a] = c[a] / u->dx + 0.5;
        double d = cn[a] - p->c[a];
        if (fl->spheres.periodic[a]) {
            /* the move to where the sphere is put, wrapped (exact): from the
             * unwrapped input the nearest image is lost to round-off once it
             * is far out (1e20 cells: a jump to x = 0 measured as none) */
            cn[a] = 0.5 + fmod(fmod(cn[a] - 0.5, fl->d.N[a]) + fl->d.N[a], fl->d.N[a]);
            d = cn[a] - p->c[a];
            d -= fl->d.N[a] * floor(d / fl->d.N[a] + 0.5);
        }
        moved += d * d;
    }
    moved = sqrt(moved);
    double speed = 0.0;
    for (int a = 0; a < 3; a++) {
        speed += v[a] * v[a];
    }
    speed = sqrt(speed) * u->dt / u->dx;
    const double worst = fmax(moved, speed);
    if (!(worst <= 0.5)) {
        /* the link lists are rebuilt from the new position, and a cell the
         * sphere uncovers is refilled from neighbours that were fluid in the
         * last step: both assume the surface moves less than half a cell (a
         * larger jump uncovers cells with no fluid neighbour to refill from
         * and makes the boundary force jump); the sphere stays where it was */
        const double dx = u->dx;
        char why[768];
        if (fl->exchange_steps > 1 && speed <= 0.5 && speed > 0.0) {
            /* slow enough for one LBM step, but moved further since its last
             * position: a communication step of several LBM steps holds the
             * sphere in place and moves it at its end by all of them */
            snprintf(why, sizeof why,
                     "%.3g cells per LBM step, but %.3g times as far since a communication step of %ld LBM steps "
                     "(coupler run --exchange-every %ld) holds it in place and moves it at its end; use fewer LBM "
                     "steps per communication step (--exchange-every at most %.0f at this speed)",
                     speed, moved / speed, fl->exchange_steps, fl->exchange_steps, fmax(1.0, floor(0.5 / speed)));
        } else {
            snprintf(why, sizeof why, "%s%s",
                     p->kappa_risky >= COUPLING_AUTO_KAPPA ? RISKY_COUPLING_REMEDY "; otherwise " : "",
                     u->tau >= 0.55 ? "use a smaller time step (fluid.tau closer to 0.5, or fluid.dt), more cells "
                                      "(a smaller fluid.dx at the same tau: dt shrinks as dx^2), or a lower velocity"
                                    : "use more cells (a smaller fluid.dx at the same tau: dt shrinks as dx^2) or a "
                                      "lower velocity; fluid.tau is already close to 0.5, where a smaller tau makes "
                                      "the lattice less stable");
        }
        /* cells the velocity input accounts for (exchange_steps 0: not set, one LBM step) */
        const double carried = speed * (double)(fl->exchange_steps > 1 ? fl->exchange_steps : 1);
        if (moved > 0.5 && carried < 0.5 * moved) {
            /* a position that its velocity does not explain: a master that
             * sets positions and velocities that disagree (or a jump) */
            const size_t len = strlen(why);
            snprintf(why + len, sizeof why - len,
                     "; but its velocity input accounts for %.3g of the %.3g cells since its last position: if the "
                     "master sets positions that do not follow from its velocities, that is the cause",
                     carried, moved);
        }
        return log_msg(&fl->log, STATUS_ERROR, "fluid",
                       "%s: sphere %d moves %.3g cells in one step at step %ld (t = %.6g s), from (%.4g, %.4g, "
                       "%.4g) m at %.4g m/s (limit half a cell per step: the boundary links and the refill of "
                       "uncovered cells cannot follow a larger move): %s",
                       fl->path, i, worst, fl->step, fluid_time(fl), (p->c[0] - 0.5) * dx, (p->c[1] - 0.5) * dx,
                       (p->c[2] - 0.5) * dx, speed * u->dx / u->dt, why);
    }
    for (int a = 0; a < 3; a++) {
        p->c[a] = cn[a]; /* wrapped on periodic axes */
        p->v[a] = v[a] * u->dt / u->dx;
        p->w[a] = w[a] * u->dt;
    }
    return STATUS_OK;
}

void fluid_get_sphere(const fluid_t *fl, int i, double c[3], double v[3], double w[3])
{
    const sphere_t *p = &fl->spheres.s[i];
    const units_t *u = &fl->units;
    for (int a = 0; a < 3; a++) {
        c[a] = (p->c[a] - 0.5) * u->dx;
        v[a] = p->v[a] * u->dx / u->dt;
        w[a] = p->w[a] / u->dt;
    }
}

void fluid_sphere_load(const fluid_t *fl, int i, double force[3], double torque[3])
{
    const double fs = units_force(&fl->units), ts = units_torque(&fl->units);
    delivered_load(&fl->spheres.s[i], force, torque);
    for (int a = 0; a < 3; a++) {
        force[a] *= fs;
        torque[a] *= ts;
    }
}

void fluid_sphere_drag(const fluid_t *fl, int i, double *zt, double *zr)
{
    const sphere_t *p = &fl->spheres.s[i];
    const units_t *u = &fl->units;
    /* sums of A 2 w rho |c|^2 >= 0 term by term; the rigid FMU refuses a
     * negative input (a round-off below 0 would stop a run) */
    *zt = fmax(0.0, p->zt * units_force(u) / units_velocity(u));
    *zr = fmax(0.0, p->zr * units_torque(u) * u->dt);
}

void fluid_sphere_load_lattice(const fluid_t *fl, int i, double force[3], double torque[3])
{
    const sphere_t *p = &fl->spheres.s[i];
    for (int a = 0; a < 3; a++) {
        force[a] = p->f[a];
        torque[a] = p->t[a];
    }
}
