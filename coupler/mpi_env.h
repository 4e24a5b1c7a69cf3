/* mpi_env.h — the coupler's MPI: initialised when mpirun started the
 * process (README "MPI"); the fluid FMU then decomposes its grid over the
 * ranks (fluid/decomp.c). Every rank runs the same master; rank 0 alone
 * writes the result file and prints progress. `coupler check --ranks N`
 * starts MPI in a process of its own too (mpi_env_init_alone), to lay out
 * the blocks of N ranks. */
#ifndef COUPLER_MPI_ENV_H
#define COUPLER_MPI_ENV_H

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
 * others down (MPI_Abort), which may wait in a collective call for it. */
int mpi_env_finish(int rc);

#endif
