/* checkpoint.h — the restart file of `coupler run` (OUT_checkpoint.h5).
 *
 * A checkpoint holds the complete coupled state at a communication point:
 * both FMUs' serialized states (fmi2SerializeFMUstate), the master's step
 * counter and output position, a copy of every output row written so far
 * (under /output: a run killed while writing its output file loses
 * nothing), the settling-summary history, the wall time
 * spent so far, and what it belongs to: the scene text (with its --set
 * overrides applied), the FMUs' GUIDs and a hash of each binary (the
 * coupler and both FMU libraries), so that a restart with another scene,
 * other FMUs or another build is refused with what differs.
 *
 * It is written to PATH.tmp, flushed, fsync'ed and renamed over PATH (then
 * the folder is fsync'ed): a valid checkpoint exists at every moment, even
 * when the run is killed while writing the next one. hdf5.h appears only
 * in the .c file.
 *
 * On several MPI ranks there is still one file, written by rank 0: the
 * master's counters, the rows and the rigid state (the same on every
 * rank), the number of ranks and their blocks along x, y, z, and the fluid
 * state of every rank (fmi2SerializeFMUstate of its block), which rank 0
 * receives from the others one after another (the master's `block` hook),
 * so that it holds its own block and one other at a time. The one rename
 * makes the checkpoint of all ranks valid as a whole or not at all. A
 * restart needs the same ranks and blocks; each rank reads its own block. */
#ifndef COUPLER_CHECKPOINT_H
#define COUPLER_CHECKPOINT_H

#include "../common/scene.h"
#include "../common/status.h"

#include <stddef.h>

#define CHECKPOINT_ID_MAX 160
/* values per chunk of an array in a checkpoint: a chunk's checksum covers at
 * most this many, and a state's last chunk is allocated whole (the disk
 * estimate, resources.c) */
#define CHECKPOINT_CHUNK (1 << 22)

/* What a checkpoint belongs to; every field must match on restart. */
typedef struct {
    char coupler[CHECKPOINT_ID_MAX];    /* hash of the coupler executable */
    char fluid[CHECKPOINT_ID_MAX];      /* fluid FMU: GUID and library hash */
    char rigid[CHECKPOINT_ID_MAX];      /* rigid FMU: GUID and library hash, "" without one */
} checkpoint_origin_t;

/* The ranks a checkpoint belongs to: their blocks must match on restart. */
typedef struct {
    int ranks;   /* MPI ranks (1 without MPI) */
    int dims[3]; /* blocks along x, y, z (fluid/decomp.h) */
} checkpoint_ranks_t;

typedef struct {
    long step;            /* communication steps done */
    long nsteps;          /* the run's length in communication steps */
    long rows;            /* output rows written */
    long next_out;        /* the next output row is due at next_out * run.output_interval */
    int row_at_step;      /* 1: the last of those rows is that of communication step `step` (read from the
                             copy of /output/time: a restart at its run's last step writes no second one) */
    int end_row;          /* 1: that last row is the run's end row, off the output grid (a run continued past
                             its end drops it, so that its output is that of one longer run) */
    int exchange_every;   /* LBM steps per communication step */
    double h;             /* communication step, s */
    checkpoint_ranks_t ranks;
    unsigned char *fluid_state, *rigid_state; /* serialized FMU states: this rank's fluid block, the rigid
                                                 (NULL without one) */
    size_t fluid_size, rigid_size;
    double *settle_t, *settle_v; /* settling-summary history (may be NULL) */
    long nsettle;
    double wall[3];       /* wall time so far: fluid, rigid, whole run */
} checkpoint_t;

/* "OUT_checkpoint.h5" for the output "OUT.h5" (OUT: the output's name
 * without its extension, whatever it is, as for the field file
 * OUT_fields.h5, so that a restart finds that file beside the checkpoint). */
void checkpoint_path(const char *output, char *buf, size_t n);

/* A 64-bit FNV-1a hash of a file's bytes, as 16 hex digits. */
status_t checkpoint_file_hash(const char *path, const log_t *log, char out[17]);

/* What the master adds while rank 0 writes: block gives the fluid state of
 * rank k = 1 .. ranks - 1 (c->fluid_state is rank 0's) and is called for
 * every k in order, even after an error, because those ranks wait to send
 * theirs; the bytes stay the master's. fill (may be NULL) adds to the closed
 * temporary file before it is synced and renamed (the output rows). */
typedef struct {
    status_t (*block)(void *ctx, int rank, const unsigned char **bytes, size_t *size);
    status_t (*fill)(void *ctx, const char *tmp_path);
    void *ctx;
} checkpoint_hooks_t;

status_t checkpoint_write(const char *path, const scene_t *scene, const checkpoint_origin_t *origin,
                          const checkpoint_t *c, const checkpoint_hooks_t *hooks, const log_t *log);

/* Reads path into *c (arrays malloc'ed: checkpoint_free), the fluid state
 * of `rank`, after checking that it belongs to these ranks and blocks, this
 * scene and this origin; a mismatch is an error saying what differs. */
status_t checkpoint_read(const char *path, const scene_t *scene, const checkpoint_origin_t *origin,
                         const checkpoint_ranks_t *ranks, int rank, checkpoint_t *c, const log_t *log);
void checkpoint_free(checkpoint_t *c);

#endif
