/* h5fields.h — field snapshots in an HDF5 file with an XDMF index beside it.
 *
 * /fields/NNNNNN/{density,velocity,flags} at LBM step NNNNNN: density
 * (kg/m^3) [nz, ny, nx], velocity (m/s) [nz, ny, nx, 3], flags (0 fluid,
 * 1 solid) [nz, ny, nx], x fastest; each group has a `time` attribute (s).
 * The .xmf (same path, extension .xmf) lists every snapshot as cell data of
 * a co-rectilinear grid (XDMF 2, as ParaView reads it) and is rewritten
 * after every snapshot, so a killed run leaves both files readable. Writing
 * a step again (after an FMU state restore) replaces that snapshot. Used by
 * the fluid FMU (fluid/fluid_fmi.c); hdf5.h and mpi.h appear only in the
 * writers.
 *
 * Several MPI processes may write one file together (parallel HDF5), each
 * its block of the grid; the file is the same as one process writes. Then
 * every function below is collective over the communicator: every process
 * calls it with the same arguments (but its own block and data) and every
 * process gets the same status back (a failure on one process is a failure
 * on all, and each says which process failed). h5fields_close must come
 * before MPI_Finalize. */
#ifndef COMMON_H5FIELDS_H
#define COMMON_H5FIELDS_H

#include "status.h"

typedef struct h5fields h5fields_t;

/* The block of the grid this process writes: cells lo .. lo + n - 1 (0-based,
 * global); comm: a pointer to the MPI_Comm of the processes that write the
 * file together (each its block, the blocks tiling the grid), or NULL: one
 * process writes the whole grid (lo 0, n the grid). */
typedef struct {
    int lo[3], n[3];
    const void *comm; /* const MPI_Comm *, or NULL */
} h5fields_part_t;

/* Creates (truncates) path for a grid of n cells of size dx; part NULL: the
 * whole grid from this process, without any MPI call (MPI need not be
 * initialised). Errors name the file. */
status_t h5fields_open(const char *path, const int n[3], double dx, const h5fields_part_t *part, const log_t *log,
                       h5fields_t **out);
/* Opens the field file of an interrupted run to continue it: the snapshots
 * already in it stay and are listed in the index. */
status_t h5fields_resume(const char *path, const int n[3], double dx, const h5fields_part_t *part, const log_t *log,
                         h5fields_t **out);
/* Drops the snapshots after `step` (a restored state continues from there). */
status_t h5fields_drop_after(h5fields_t *w, long step);
/* density [nb], velocity [nb][3], flags [nb]: this process's block of part.n
 * cells (the whole grid without a part), x fastest. */
status_t h5fields_write(h5fields_t *w, long step, double time, const double *density, const double *velocity,
                        const unsigned char *flags);

/* The same snapshot a few z planes at a time, so that the writer's buffers
 * hold those planes only, not the grid (the fluid FMU: fluid_fmi.c):
 * h5fields_begin creates the snapshot's group and datasets; each
 * h5fields_planes writes planes z0 .. z0 + nz - 1 of this process's block
 * (local z; the arrays as for h5fields_write, for n[0] n[1] nz cells);
 * h5fields_end adds the time, closes the snapshot and rewrites the index.
 * With several processes each h5fields_planes is collective: every process
 * makes the number of calls h5fields_slabs gives, those past the end of its
 * block with nz 0. After a failed call the next ones return its status, and
 * h5fields_end still closes the snapshot and takes it out of the file: a
 * failed snapshot is never left in the file (nor in the index), so the file
 * holds the complete snapshots before it and can still be closed. The
 * messages name the cause the system gave ("No space left on device"). */
status_t h5fields_begin(h5fields_t *w, long step, double time);
status_t h5fields_planes(h5fields_t *w, int z0, int nz, const double *density, const double *velocity,
                         const unsigned char *flags);
status_t h5fields_end(h5fields_t *w);
/* The calls of h5fields_planes each process makes when it writes `planes`
 * planes at a time (its own number; they may differ from process to
 * process): enough for the process that needs the most. Collective. */
status_t h5fields_slabs(h5fields_t *w, int planes, int *calls);

/* Cells of the buffers a writer of planes holds at most (33 bytes each: 8.7
 * MB), unless one plane alone has more; h5fields_slab_planes: planes of nx
 * x ny cells per slab for a block of nz planes (at least 1, at most nz).
 * No HDF5 call: the run's resource check uses it too. */
#define H5FIELDS_SLAB_CELLS 262144
int h5fields_slab_planes(int nx, int ny, int nz);
/* Closes the file and frees w (NULL is fine). */
status_t h5fields_close(h5fields_t *w);

#endif
