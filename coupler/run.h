/* run.h — `coupler run`: the FMI 2.0 co-simulation master.
 *
 * Loads the scene's FMUs (exported into a temporary folder, or given with
 * --fluid-fmu/--rigid-fmu), connects every input to the output of the
 * other FMU with the same name, steps them with the fixed-step sequential
 * scheme of DESIGN section 2 and writes the output file (output.h). With
 * --checkpoint-every T it writes the coupled state every T simulated
 * seconds, and on SIGINT/SIGTERM, to a checkpoint from which --restart
 * continues the run bit-identically (checkpoint.h). */
#ifndef COUPLER_RUN_H
#define COUPLER_RUN_H

#include "../common/scene.h"

/* The wall times of a run in seconds, as its output's wall_time_* attributes
 * (DESIGN section 5): the fluid and rigid FMUs' steps, the master's share
 * (start-up and output included), of it start-up and output, and the whole. */
typedef struct {
    double fluid, rigid, master, startup, output, total;
} run_times_t;

typedef struct {
    const char *output;        /* .h5 path */
    long steps;                /* > 0: this many communication steps instead of run.end_time */
    int quiet;                 /* no progress line */
    int exchange_every;        /* LBM steps per communication step, >= 1 */
    const char *log_calls;     /* NULL or a file for the FMI call log */
    const char *fluid_fmu;     /* NULL: export from the scene */
    const char *rigid_fmu;     /* NULL: export from the scene */
    const char *lib_dir;       /* build/fmu: the libraries export packs */
    double checkpoint_t1;      /* > 0: checkpoint test (save at t1, run, restore, run, compare) */
    double checkpoint_every;   /* > 0: a checkpoint every this many simulated seconds */
    const char *restart;       /* NULL, or the checkpoint to continue from (appending to output) */
    run_times_t *times;        /* NULL, or set to the run's wall times when it ends (coupler bench) */
} run_options_t;

/* Returns 0 on success, 1 on failure (messages already logged), 128 + the
 * signal number when SIGINT or SIGTERM stopped the run after writing a
 * checkpoint (OUT_checkpoint.h5 beside the output, checkpoint.h). */
int run_scene(const scene_t *scene, const run_options_t *opt, const log_t *log);

#endif
