/* master.h — what the parts of `coupler run`'s master share (run.c): the
 * master's state and the functions of its parts.
 *
 *   run.c             setup (FMUs, output, checks) and the loop of run_scene
 *   signals.c         the signals between the FMUs, the observed outputs of
 *                     an output row, and one communication step
 *   run_checkpoint.c  checkpoints of a run and their replay on restart
 *
 * Each function logs its own errors through m->log. */
#ifndef COUPLER_MASTER_H
#define COUPLER_MASTER_H

#include "../fluid/units.h"
#include "checkpoint.h"
#include "fmu.h"
#include "output.h"
#include "run.h"

#include <stdio.h>

/* Quantities of one output row, in the order of the row buffer. */
enum { R_POS, R_VEL, R_OMEGA, R_FORCE, R_TORQUE, NSPHERE_Q };

/* Values read from one FMU in one call: vr[k] goes to row[dest[k]]. */
typedef struct {
    unsigned *vr;
    int *dest;
    int n;
    double *tmp;
    int *itmp;
} gather_t;

typedef struct {
    const scene_t *scene;
    const run_options_t *opt;
    log_t log;
    units_t un;
    int ns, nc, nfree_bodies;
    fmu_t *fluid, *rigid;
    FILE *calls;
    char tmp[4096];   /* temporary folder, "" when none */
    char fields[4096]; /* field file, "" when none */
    /* exchange: rigid outputs -> fluid inputs, fluid outputs -> rigid inputs */
    unsigned *to_fluid_src, *to_fluid_dst, *to_rigid_src, *to_rigid_dst;
    int nto_fluid, nto_rigid;
    double *xbuf;
    /* observation: the row buffer and what fills it */
    double *row;  /* 5 * ns * 3 + 2 * nc * 3 + 8 doubles */
    int *ibody, *iintact;
    int o_cforce, o_ctorque, o_mass, o_mom, o_ke, o_vmax, o_peak, o_bmom, o_bang, nrow;
    gather_t real_fluid, real_rigid, int_rigid, bool_rigid;
    /* settling summary: the velocity along gravity of the one free sphere */
    double *settle_t, *settle_v;
    long nsettle;
    /* checkpoints: what they belong to, where they go */
    checkpoint_origin_t origin;
    checkpoint_ranks_t ranks; /* the MPI ranks and their blocks (fluid/decomp.h) */
    char cp_path[4200];
} master_t;

/* Position of the run at a communication point, for a checkpoint. */
typedef struct {
    long n, nsteps, next_out;
    int k_lbm;
    double h, wall0, wall_before[3];
    int end_row; /* 1: the row of step n is there only because the run ends at n (off the output grid) */
} run_point_t;

/* The checkpoint test (--checkpoint-test): the states saved at step n1, the
 * rows after it, compared with the rows of the run restored to n1. */
typedef struct {
    long n1;
    void *fluid_state, *rigid_state;
    double *rows; /* (n - n1 + 1) rows of nrow doubles + ns + nc ints as doubles */
    long nrows, cap;
    int replay;
    long mismatches;
} replay_t;

/* Every input of `to` gets the output of `from` with the same name (signals.c). */
status_t master_connect(master_t *m, fmu_t *from, fmu_t *to, unsigned **src, unsigned **dst, int *n);
/* The outputs an output row observes, found by name in either FMU. */
status_t master_plan_observation(master_t *m);
/* Reads the observed outputs into m->row; writes it as the row at t. */
status_t master_read_row(master_t *m);
status_t master_write_row(master_t *m, output_t *out, double t);
/* One communication step from t: the sequential scheme. */
status_t master_step(master_t *m, double t, double h);

/* Checkpoints (run_checkpoint.c): what this run's checkpoints belong to;
 * the status every rank agrees on; a checkpoint at p written by all ranks
 * together; the replay record of step n on restart; an FMU set to a state
 * (deserialized from a checkpoint), the state freed. */
status_t master_find_origin(master_t *m);
status_t master_agree(master_t *m, status_t st);
status_t master_restart_fields(master_t *m, const char *checkpoint, int *resume);
status_t master_save_checkpoint(master_t *m, output_t *out, const run_point_t *p);
status_t master_checkpoint_record(master_t *m, replay_t *c, long n);
status_t master_restore(fmu_t *f, void **state);

#endif
