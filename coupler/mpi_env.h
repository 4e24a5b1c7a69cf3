/* mpi_env.h — the coupler's MPI: initialised when mpirun started the
 * process (README "MPI"); the fluid FMU then decomposes its grid over the
 * ranks (fluid/decomp.c). Every rank runs the same master; rank 0 alone
 * writes the result file and prints progress. `coupler check --ranks N`
 * starts MPI in a process of its own too (mpi_env_init_alone), to lay out
 * the blocks of N ranks.
 *
 * The few collectives and messages the master itself needs (agreeing on a
 * stop, on the outcome of a checkpoint, gathering the fluid blocks into
 * rank 0's checkpoint) are here, so that mpi.h stays out of the master.
 * They work on MPI_COMM_WORLD, whose ranks are the fluid's blocks in order;
 * without MPI they are the identity. Every rank calls a collective at the
 * same point; an MPI error is reported through log and returned. */
#ifndef COUPLER_MPI_ENV_H
#define COUPLER_MPI_ENV_H

#include "../common/status.h"

#include <stddef.h>

/* Initialises MPI when the process was started by mpirun (Open MPI, PMI or
 * PMIx environment); returns 0, or 1 when MPI could not be initialised. */
int mpi_env_init(int *argc, char ***argv);
/* Initialises MPI in a process that mpirun did not start (a singleton: a
 * world of this process alone, size 1), for the MPI calls that need no other
 * rank (MPI_Dims_create for `coupler check --ranks N`); nothing when MPI runs
 * already. mpi_env_finish ends it. Returns 0, or 1 when MPI could not start. */
int mpi_env_init_alone(void);
int mpi_env_rank(void); /* 0 without MPI */
int mpi_env_size(void); /* 1 without MPI */
/* Ends MPI with the exit code of this rank: a failing rank takes the
 * others down (MPI_Abort), which may wait in a collective call for it. The
 * deliberate stops 130 and 143 (SIGINT, SIGTERM: every rank stopped at the
 * same step with the same code) end with MPI_Finalize on every rank. */
int mpi_env_finish(int rc);

/* *v becomes the largest *v of all ranks. */
status_t mpi_env_max(int *v, const log_t *log);
/* On rank 0, all[k] becomes n of rank k (all: mpi_env_size() values);
 * all may be NULL on the other ranks. */
status_t mpi_env_gather_size(size_t n, size_t *all, const log_t *log);
/* n bytes from this rank to rank `to`, received there by mpi_env_recv with
 * the same n (in pieces below 2^31 bytes: any size). */
status_t mpi_env_send(const void *buf, size_t n, int to, const log_t *log);
status_t mpi_env_recv(void *buf, size_t n, int from, const log_t *log);

#endif
