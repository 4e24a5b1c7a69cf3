/* resources.c — memory and disk a run needs against what is there
 * (resources.h). The estimates count the large items only: the fluid
 * grid, the field buffers and snapshots, the time series, the checkpoint;
 * the rigid component and the master are small beside them. */
#include "resources.h"

#include "../common/h5fields.h"
#include "checkpoint.h"
#include "output.h"

#include "../fluid/grid.h"
#include "../fluid/lattice.h"
#include "../fluid/units.h"

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <omp.h>
#include <sys/statvfs.h>

#define CAT "resources"

/* density (8), velocity (24) and flag (1) of an interior cell: one
 * snapshot's datasets, and the fluid FMU's field buffers for the cells of a
 * slab of planes (h5fields_slab_planes) */
#define FIELD_BYTES_PER_CELL 33.0

status_t resources_need(const scene_t *s, double t_end, int checkpoints, const log_t *log, resources_need_t *need)
{
    memset(need, 0, sizeof *need);
    units_t u;
    if (units_derive(s, log, &u) != STATUS_OK) {
        return STATUS_ERROR;
    }
    grid_t g;
    grid_init(&g, u.n, units_grid_align(s));
    const double interior = (double)u.n[0] * u.n[1] * u.n[2];
    need->grid_cells = (double)g.ncells;
    need->cell_bytes = units_bytes_per_cell(s);
    const double grid = need->grid_cells * need->cell_bytes + units_extra_bytes(s, &g, omp_get_max_threads());
    /* what a state holds of it (the moments layout's side store, not its
     * kernel's plane copies per thread) */
    const double state = need->grid_cells * need->cell_bytes + units_extra_bytes(s, &g, 0);
    const double slab = (double)u.n[0] * u.n[1] * h5fields_slab_planes(u.n[0], u.n[1], u.n[2]);
    need->memory = grid + (s->run.fields ? slab * FIELD_BYTES_PER_CELL : 0.0); /* buffers only with fields */
    /* the time series as the run lays them out (run.c): connections and
     * /bodies only with a rigid component; at most one row and one snapshot
     * per fluid step (shorter intervals write every step) */
    const int nfree = scene_free_bodies(s);
    const output_layout_t layout = {.ns = scene_total_spheres(s), .nc = nfree > 0 ? s->nconnections : 0,
                                    .bodies = nfree > 0};
    const double rows = floor(t_end / fmax(s->run.output_interval, s->fluid.dt)) + 2.0;
    need->output = output_file_bytes(&layout, rows, s->text != NULL ? strlen(s->text) : 0);
    if (s->run.fields) {
        const double snaps = floor(t_end / fmax(s->run.field_interval, s->fluid.dt)) + 2.0;
        need->fields = snaps * interior * FIELD_BYTES_PER_CELL;
    }
    if (checkpoints) {
        /* the serialized fluid state: the population array(s) and the flags,
         * plus a copy of the output rows */
        need->checkpoint = ceil(state / CHECKPOINT_CHUNK) * CHECKPOINT_CHUNK + need->output;
        /* while a checkpoint is written its serialized bytes are held beside
         * the grid (the FMU state itself copies no populations: it stays the
         * component until the component changes, common/fmi_state.c) */
        need->memory += state;
    }
    need->disk = need->output + need->fields + 2.0 * need->checkpoint;
    return STATUS_OK;
}

/* MemAvailable of /proc/meminfo in bytes, or -1 when it cannot be read. */
static double memory_available(void)
{
    FILE *fp = fopen("/proc/meminfo", "r");
    if (fp == NULL) {
        return -1.0;
    }
    char line[256];
    double kb = -1.0;
    while (fgets(line, sizeof line, fp) != NULL) {
        if (sscanf(line, "MemAvailable: %lf kB", &kb) == 1) {
            break;
        }
    }
    fclose(fp);
    return kb >= 0.0 ? kb * 1024.0 : -1.0;
}

int resources_compare(const resources_need_t *need, const char *folder, status_t severity, const log_t *log)
{
    int short_of = 0;
    const double mem = memory_available();
    if (mem >= 0.0 && need->memory > mem) {
        log_msg(log, severity, CAT,
                "the run needs %.4g MB of memory (fluid grid of %.4g M cells at %.0f bytes per cell, field buffers%s), "
                "this machine has %.4g MB available (MemAvailable in /proc/meminfo): use fewer cells (a larger dx, "
                "a smaller domain)",
                need->memory / 1e6, need->grid_cells / 1e6, need->cell_bytes,
                need->checkpoint > 0.0 ? ", the serialized state of a checkpoint" : "", mem / 1e6);
        short_of++;
    }
    struct statvfs v;
    if (statvfs(folder, &v) == 0) {
        const double free_bytes = (double)v.f_bavail * (double)v.f_frsize + need->replaced;
        if (need->disk > free_bytes) {
            log_msg(log, severity, CAT,
                    "the run writes up to %.4g MB into %s (output %.4g MB, field snapshots %.4g MB, checkpoints "
                    "%.4g MB), the file system has %.4g MB free (with the files the run replaces): write fewer snapshots (run.field_interval, "
                    "run.fields), fewer rows (run.output_interval) or to another folder",
                    need->disk / 1e6, folder, need->output / 1e6, need->fields / 1e6, 2.0 * need->checkpoint / 1e6,
                    free_bytes / 1e6);
            short_of++;
        }
    }
    return short_of;
}

void resources_folder(const char *path, char *buf, size_t n)
{
    snprintf(buf, n, "%s", path);
    char *slash = strrchr(buf, '/');
    if (slash == NULL) {
        snprintf(buf, n, ".");
    } else if (slash == buf) {
        buf[1] = '\0';
    } else {
        *slash = '\0';
    }
}
