/* resources.h — what a run needs (memory, disk) against what the machine has.
 *
 * Memory: the fluid grid (bytes per cell x allocated cells, units.h) plus the
 * field buffers of the fluid FMU and, with checkpoints, the serialized state
 * held while one is written. Disk: the output rows, the field snapshots and
 * the checkpoint (twice while the next one replaces the previous).
 * Available: MemAvailable of /proc/meminfo (what the kernel can give without
 * swapping) and the free space of the output's folder (statvfs). `coupler
 * check` warns when a need exceeds what is available; `coupler run` refuses
 * before anything is allocated or written. */
#ifndef COUPLER_RESOURCES_H
#define COUPLER_RESOURCES_H

#include "../common/scene.h"
#include "../common/status.h"

#include <stddef.h>

typedef struct {
    double memory;      /* bytes */
    double grid_cells;  /* allocated cells of the fluid grid */
    double cell_bytes;  /* bytes per allocated cell (units_bytes_per_cell) */
    double output;      /* bytes of the time series */
    double fields;      /* bytes of the field snapshots (0: none) */
    double checkpoint;  /* bytes of one checkpoint (0: none asked for) */
    double disk;        /* output + fields + 2 checkpoints */
    double replaced;    /* bytes of files there now that the run replaces (its output, field file and
                         * checkpoint: a restart into the folder of a run stopped by a full disk) */
} resources_need_t;

/* What the scene needs for a run to t_end; checkpoints: whether the run
 * writes them (--checkpoint-every). */
status_t resources_need(const scene_t *s, double t_end, int checkpoints, const log_t *log, resources_need_t *need);

/* Compares need with the machine (folder: where the output goes). Returns
 * the number of shortfalls, each logged with `severity` (STATUS_WARNING in
 * check, STATUS_ERROR in run) naming what is needed and what is available. */
int resources_compare(const resources_need_t *need, const char *folder, status_t severity, const log_t *log);

/* The folder of a file path: "." for a bare name, "/" for a file in the root. */
void resources_folder(const char *path, char *buf, size_t n);

#endif
