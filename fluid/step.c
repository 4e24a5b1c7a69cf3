/* step.c — one step of the fluid component (fluid_step): the sphere
 * stages (map, fill), the boundary fill of the walls and the update of every
 * cell, in one of three schedules that give the same values to the bit:
 *  - in sequence: map, walls, fill, then the update of all cells, each
 *    stage parallel over its own items;
 *  - spheres beside the update (one rank; step_spheres_beside): one thread
 *    runs the sphere stages (near a face: the fill alone, the map first)
 *    while the others update the z planes far from every sphere, then all
 *    update the planes near them. The update is bound by memory bandwidth,
 *    which one thread of two nearly fills (the in-place kernel ran at 0.65
 *    of its two-thread rate on one thread here), and the sphere stages by
 *    their own instructions and misses: side by side they share the step
 *    better than one after the other;
 *  - the exchange in flight (several ranks; step_overlapped).
 * Which of the first two runs is measured as the run goes (sov_choose):
 * what pays depends on the machine, the threads and the scene. */
#include "fluid_internal.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

/* The collision and streaming of the cells of box b (NULL: all); in place,
 * with skip, but those inside the spheres (fl->skip). */
static void update(fluid_t *fl, const kernel_box_t *b, int skip)
{
    kernel_params_t kp = fl->kp;
    kp.skip = skip && fl->skip_on && fl->skip.map == fl->spheres.maps ? &fl->skip : NULL;
    /* (never with the moments layout: its own update over whole planes, fluid_step) */
    if (fl->streaming == STREAMING_TWO_ARRAY) {
        if (fl->single) {
            kernel_stream_collide_f32(&fl->g, &kp, fl->f[fl->cur], fl->f[1 - fl->cur], b);
        } else {
            kernel_stream_collide(&fl->g, &kp, fl->f[fl->cur], fl->f[1 - fl->cur], b);
        }
    } else {
        const int push = fl->layout == LAYOUT_SWAPPED;
        if (fl->single) {
            kernel_in_place_f32(&fl->g, &kp, fl->f[0], push, b);
        } else {
            kernel_in_place(&fl->g, &kp, fl->f[0], push, b);
        }
    }
}

/* After a map: the runs of the cells inside the spheres, anew when the map
 * made a new list of them. Out of memory the update goes over every cell
 * (fl->skip.map stays behind: update). */
static void skip_refresh(fluid_t *fl)
{
    const spheres_t *sp = &fl->spheres;
    if (!fl->skip_on || fl->skip.map == sp->maps) {
        return;
    }
    const int32_t(**runs)[3] = malloc((size_t)sp->n * sizeof *runs);
    size_t *nruns = malloc((size_t)sp->n * sizeof *nruns);
    if (runs != NULL && nruns != NULL) {
        for (int k = 0; k < sp->n; k++) {
            runs[k] = (const int32_t(*)[3])sp->lists[k].runs;
            nruns[k] = sp->lists[k].nruns;
        }
        if (kernel_skip_build(&fl->skip, &fl->g, sp->n, runs, nruns)) {
            fl->skip.map = sp->maps;
        }
    }
    free(runs);
    free(nruns);
}

/* Slices of the inner cells per exchanged axis, with MPI progress between. */
enum { OVERLAP_SLICES = 4 };

/* The step on several ranks: the exchange of each axis is in flight while
 * a slice of the inner rows is updated (y and z two or more cells from the
 * block's faces); then the links of the outer rows and their update. The
 * values are those of walls_fill, spheres_fill and one update in sequence,
 * to the bit:
 *  - the inner rows receive nothing that the exchange, a copy or a link
 *    writes after their update: the local periodic copy of x and the links
 *    of the inner rows' cells come first (walls.h), and no other copy,
 *    exchange or link writes what they receive;
 *  - the exchange reads and writes only what the cells of outer rows and the
 *    ghost cells send and receive, which the inner update does not touch;
 *  - every link reads before the inner update (in place, that update
 *    overwrites post-collision values of the cells it pulls from): the wall
 *    links' moments and all sphere links' values are taken first; the
 *    values of outer rows' links are written after the exchange (it writes
 *    the same slots, and the links win, as in sequence);
 *  - every cell is updated once (in place it would take its own output).
 * With x cut between ranks the inner rows would have to stop short of
 * columns 1 and n, and those columns updated apart fetch a cache line per
 * cell and population: measured here, 2 ranks cut along x at 128^3, 37.4
 * against 25.5 ms per step in sequence; so fluid_step does not overlap then
 * (the kernel's boxes allow it: kernel.h). */
static void step_overlapped(fluid_t *fl, const pops_t *p)
{
    const grid_t *g = &fl->g;
    const int n0 = g->n[0], n1 = g->n[1], n2 = g->n[2];
    const kernel_box_t in = {{1, 2, 2}, {n0, n1 - 1, n2 - 1}};
    walls_links_prepare(&fl->walls, p);
    walls_halo_early(&fl->walls, g, p);
    walls_links(&fl->walls, p, WALLS_EARLY);
    if (fl->spheres.n > 0) {
        spheres_fill(&fl->spheres, p, SPHERES_HOLD_OUTER);
    }
    /* the inner rows in slices while the exchanges with other ranks are in
     * flight (a local periodic copy has nothing in flight) */
    int axes[3], remote = 0;
    const int m = walls_halo_axes(&fl->walls, p, axes);
    for (int k = 0; k < m; k++) {
        remote += !fl->walls.periodic[axes[k]];
    }
    const int nslice = remote * OVERLAP_SLICES, zlen = n2 - 2;
    for (int k = 0, j = 0; k < m; k++) {
        walls_halo_begin(&fl->walls, g, p, axes[k], 1);
        for (int s = 0; s < OVERLAP_SLICES && !fl->walls.periodic[axes[k]]; s++, j++) {
            kernel_box_t b = in;
            b.lo[2] = in.lo[2] + zlen * j / nslice;
            b.hi[2] = in.lo[2] + zlen * (j + 1) / nslice - 1;
            update(fl, &b, 1);
            decomp_exchange_progress(&fl->d);
        }
        walls_halo_end(&fl->walls, g, p, axes[k]);
    }
    walls_links(&fl->walls, p, WALLS_LATE);
    if (fl->spheres.n > 0) {
        spheres_write_outer(&fl->spheres, p);
    }
    /* the outer rows: two z slabs, two y slabs between them */
    const kernel_box_t outer[4] = {
        {{1, 1, 1}, {n0, n1, 1}},
        {{1, 1, n2}, {n0, n1, n2}},
        {{1, 1, 2}, {n0, 1, n2 - 1}},
        {{1, n1, 2}, {n0, n1, n2 - 1}},
    };
    for (int i = 0; i < 4; i++) {
        update(fl, &outer[i], 1);
    }
}


/* Spheres beside the update. SOV_REACH: cells beyond a sphere's box (its
 * links' cells, sphere_links.c: floor(c - r) - 1 .. ceil(c + r) + 1) that
 * its stages may read or write: the cells two back along a link (x_f - 2
 * c_q), the refill's neighbours of an uncovered cell (two along the normal),
 * a slot of a cell kept at its neighbour (in place, layout.h), and the
 * neighbours an update of a far cell touches: 2 + 1 + 1 = 4, and two more
 * to spare. SOV_FACE: cells from a face within which walls_fill reads or
 * writes (ghost layers, wall links, the slip correction); with a sphere's
 * reach within it the map (its refill) and the walls' fill must keep their
 * order, so the map runs first, on all threads, and only the fill beside
 * the update (SOV_FILL). */
enum { SOV_REACH = 6, SOV_FACE = 3, SOV_CHUNK_CELLS = 16384 };
/* auto: SOV_PROBE steps of each schedule alternately (so that both meet
 * the same machine and the same mix of steps: a map that rebuilds the
 * links costs more than one that refreshes them), then the faster one for
 * SOV_RUN steps, and again (the spheres move, the machine's load changes) */
enum { SOV_PROBE = 8, SOV_RUN = 200 };

/* What runs beside the update of the far planes: the map and the fill, or
 * the fill alone. */
enum { SOV_NONE, SOV_MAP_FILL, SOV_FILL };

/* The planes near and far from every sphere for this step, and what runs
 * beside: SOV_NONE when nothing does (no far plane, a sphere's reach across
 * a periodic z face, or a centre not finite: the sequence reports it). */
static int sov_plan(fluid_t *fl)
{
    sphere_overlap_t *ov = &fl->sov;
    const grid_t *g = &fl->g;
    const int nz = g->n[2];
    if (ov->plane == NULL || ov->far == NULL || ov->near == NULL) {
        ov->plane = ov->plane != NULL ? ov->plane : malloc((size_t)nz + 2);
        ov->far = ov->far != NULL ? ov->far : malloc((size_t)nz * sizeof *ov->far);
        ov->near = ov->near != NULL ? ov->near : malloc((size_t)nz * sizeof *ov->near);
        if (ov->plane == NULL || ov->far == NULL || ov->near == NULL) {
            return SOV_NONE; /* in sequence then: nothing is lost but the overlap */
        }
    }
    memset(ov->plane, 0, (size_t)nz + 2);
    int inside = 1;
    for (int k = 0; k < fl->spheres.n; k++) {
        const sphere_t *s = &fl->spheres.s[k];
        int lo[3], hi[3];
        for (int a = 0; a < 3; a++) {
            if (!(fabs(s->c[a]) < 1e9 && fabs(s->cmap[a]) < 1e9 && s->r < 1e9)) {
                return SOV_NONE;
            }
            /* this map's place and the last one's (its uncovered cells) */
            lo[a] = (int)floor(fmin(s->c[a], s->cmap[a]) - s->r) - 1 - SOV_REACH;
            hi[a] = (int)ceil(fmax(s->c[a], s->cmap[a]) + s->r) + 1 + SOV_REACH;
            inside = inside && lo[a] >= 1 + SOV_FACE && hi[a] <= g->n[a] - SOV_FACE;
        }
        if (fl->spheres.periodic[2] && (lo[2] < 1 || hi[2] > nz)) {
            return SOV_NONE; /* its reach wraps to the other end's planes */
        }
        lo[2] = lo[2] < 1 ? 1 : lo[2];
        hi[2] = hi[2] > nz ? nz : hi[2];
        if (lo[2] <= hi[2]) {
            memset(ov->plane + lo[2], 1, (size_t)(hi[2] - lo[2] + 1));
        }
    }
    const int chunk = (int)fmax(1.0, (double)SOV_CHUNK_CELLS / ((double)g->n[0] * g->n[1]));
    ov->nfar = ov->nnear = 0;
    for (int z = 1; z <= nz;) {
        int e = z;
        while (e < nz && ov->plane[e + 1] == ov->plane[z]) {
            e++;
        }
        for (int c = z; c <= e; c += ov->plane[z] ? e - z + 1 : chunk) {
            const kernel_box_t b = {{1, 1, c}, {g->n[0], g->n[1], ov->plane[z] ? e : (int)fmin(c + chunk - 1, e)}};
            if (ov->plane[z]) {
                ov->near[ov->nnear++] = b;
            } else {
                ov->far[ov->nfar++] = b;
            }
        }
        z = e + 1;
    }
    return ov->nfar == 0 ? SOV_NONE : inside ? SOV_MAP_FILL : SOV_FILL;
}

/* 1: spheres beside the update this step. first: the step builds the
 * sphere stages' lists anew (not timed). */
static int sov_choose(const fluid_t *fl, int first)
{
    const sphere_overlap_t *ov = &fl->sov;
    if (ov->mode != SOV_AUTO || first) {
        return ov->mode == SOV_ON;
    }
    return ov->cycle < 2 * SOV_PROBE ? (int)(ov->cycle % 2) : ov->pick;
}

/* Books a step of schedule s that took seconds (auto, not the first). */
static void sov_record(fluid_t *fl, int s, double seconds)
{
    sphere_overlap_t *ov = &fl->sov;
    if (ov->cycle < 2 * SOV_PROBE) {
        ov->probe[s] += seconds;
        if (ov->cycle == 2 * SOV_PROBE - 1) {
            ov->pick = ov->probe[1] < ov->probe[0];
            ov->probe[0] = ov->probe[1] = 0.0;
        }
    }
    ov->cycle = (ov->cycle + 1) % (2 * SOV_PROBE + SOV_RUN);
}

/* One thread maps and fills the spheres (plan SOV_MAP_FILL; SOV_FILL: the
 * map first, on all threads, then the walls' fill, in the sequence's order,
 * and the fill alone beside) while the others update the far planes (each
 * taking the next chunk as it is done, and the sphere thread too once it
 * is), then all update the near planes. The same values as the sequence to
 * the bit: the sphere stages read and write only cells within SOV_REACH of
 * a sphere's box (across a periodic x or y face too: those are all in near
 * planes), and the update of a far cell only that cell and its neighbours'
 * slots, so neither sees the other's writes; each cell is updated once,
 * from the same inputs; with SOV_MAP_FILL walls_fill comes first, which no
 * sphere stage then depends on (SOV_FACE). The sphere stages' own parallel
 * loops run on their one thread (a nested region has one thread unless
 * nesting is on); so does the update of each far chunk. A failed map
 * returns after the far planes: the step is then lost, as in sequence. */
static status_t step_spheres_beside(fluid_t *fl, const pops_t *p, int plan)
{
    sphere_overlap_t *ov = &fl->sov;
    status_t st = STATUS_OK;
    if (plan == SOV_FILL) {
        st = spheres_map(&fl->spheres, &fl->g, fl->flags, p, &fl->log);
        if (st != STATUS_OK) {
            return st;
        }
        skip_refresh(fl);
    }
    walls_fill(&fl->walls, &fl->g, p);
#pragma omp parallel
    {
#pragma omp single nowait
        {
            if (plan == SOV_MAP_FILL) {
                st = spheres_map(&fl->spheres, &fl->g, fl->flags, p, &fl->log);
                if (st == STATUS_OK) {
                    skip_refresh(fl);
                }
            }
            if (st == STATUS_OK) {
                spheres_fill(&fl->spheres, p, SPHERES_ALL);
            }
        }
#pragma omp for schedule(dynamic, 1) nowait
        for (int c = 0; c < ov->nfar; c++) {
            update(fl, &ov->far[c], 0); /* no sphere near: nothing to skip (and the map may be rebuilding the runs) */
        }
    }
    if (st != STATUS_OK) {
        return st;
    }
    for (int c = 0; c < ov->nnear; c++) {
        update(fl, &ov->near[c], 1);
    }
    return STATUS_OK;
}

status_t fluid_step(fluid_t *fl)
{
    const double t0 = omp_get_wtime();
    const pops_t p = fluid_pops(fl);
    const int spheres = fl->spheres.n > 0;
    const int first = fl->spheres.first || fl->spheres.stale;
    if (spheres) {
        fluid_share_kinematics(fl);
        int face = 0;
        const int k = spheres_advance_prescribed(&fl->spheres, fl->step, &face);
        if (k >= 0) {
            static const char *const names[6] = {"x_min", "x_max", "y_min", "y_max", "z_min", "z_max"};
            const sphere_t *q = &fl->spheres.s[k];
            const double dx = fl->units.dx;
            return log_msg(&fl->log, STATUS_ERROR, "fluid",
                           "%s: prescribed sphere %d (body %d) reaches beyond the face %s at step %ld (t = %.6g s): "
                           "centre (%.4g, %.4g, %.4g) m, radius %.4g m; a prescribed body moves as given, through "
                           "a wall too: end the run before (run.end_time, --steps) or change bodies.%d.velocity "
                           "or angular_velocity",
                           fl->path, k, q->body, names[face], fl->step, fluid_time(fl), (q->c[0] - 0.5) * dx,
                           (q->c[1] - 0.5) * dx, (q->c[2] - 0.5) * dx, q->r * dx, q->body);
        }
    }
    const int plan = spheres && fl->sov.mode != SOV_OFF && !decomp_parallel(&fl->d) ? sov_plan(fl) : SOV_NONE;
    const int planned = plan != SOV_NONE;
    const int beside = planned && sov_choose(fl, first);
    if (beside) {
        const status_t st = step_spheres_beside(fl, &p, plan);
        if (st != STATUS_OK) {
            return st;
        }
    } else {
        if (spheres) {
            const status_t st = decomp_agree(&fl->d, spheres_map(&fl->spheres, &fl->g, fl->flags, &p, &fl->log));
            if (st != STATUS_OK) {
                return st;
            }
            skip_refresh(fl);
            if (fl->streaming == STREAMING_MOMENTS && !moments_sync(&fl->mom, &fl->g, &fl->spheres)) {
                return log_msg(&fl->log, STATUS_ERROR, "fluid",
                               "%s: out of memory for the side store of the %zu cells inside the spheres (%zu bytes)",
                               fl->path, fl->spheres.nsolid, fl->spheres.nsolid * LB_Q * sizeof(double));
            }
        }
        int exchanged = 0;
        for (int a = 1; a < 3; a++) {
            exchanged = exchanged || decomp_exchanged(&fl->d, a, 0) || decomp_exchanged(&fl->d, a, 1);
        }
        const int x_cut = decomp_exchanged(&fl->d, 0, 0) || decomp_exchanged(&fl->d, 0, 1);
        /* blocks of fewer than 3 cells along y or z have no inner rows; a cut
         * across x costs more than the overlap saves (step_overlapped) */
        if (exchanged && !x_cut && fl->overlap && fl->g.n[1] >= 3 && fl->g.n[2] >= 3) {
            step_overlapped(fl, &p);
        } else {
            walls_fill(&fl->walls, &fl->g, &p);
            if (spheres) {
                spheres_fill(&fl->spheres, &p, SPHERES_ALL);
            }
            if (fl->streaming == STREAMING_MOMENTS) {
                if (!kernel_moments(&fl->g, &fl->kp, &fl->mom)) {
                    return log_msg(&fl->log, STATUS_ERROR, "fluid",
                                   "%s: out of memory for the moments kernel's plane copies (%zu bytes per thread)",
                                   fl->path, (size_t)MOMENTS_PLANE_DOUBLES * (size_t)fl->g.s[0] * (size_t)fl->g.s[1] *
                                                 sizeof(double));
                }
            } else {
                update(fl, NULL, 1);
            }
        }
    }
    if (spheres) {
        spheres_loads(&fl->spheres);
    }
    if (fl->streaming == STREAMING_TWO_ARRAY) {
        fl->cur = 1 - fl->cur;
    } else if (fl->streaming == STREAMING_MOMENTS) {
        /* in place, and the same layout state every step */
    } else {
        fl->layout = fl->layout == LAYOUT_SWAPPED ? LAYOUT_PUSHED : LAYOUT_SWAPPED;
    }
    fl->step++;
    if (planned) {
        fl->sov.steps_beside += beside;
        if (fl->sov.mode == SOV_AUTO && !first) {
            sov_record(fl, beside, omp_get_wtime() - t0);
        }
    }
    return spheres ? fluid_watch_period_two(fl) : STATUS_OK;
}
