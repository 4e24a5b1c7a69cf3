/* mpi_env.h — the coupler's MPI: initialised only when mpirun started the
 * process (README "MPI"); the fluid FMU then decomposes its grid over the
 * ranks (fluid/decomp.c). Every rank runs the same master; rank 0 alone
 * writes the result file and prints progress. */
#ifndef COUPLER_MPI_ENV_H
#define COUPLER_MPI_ENV_H

/* Initialises MPI when the process was started by mpirun (Open MPI, PMI or
 * PMIx environment); returns 0, or 1 when MPI could not be initialised. */
int mpi_env_init(int *argc, char ***argv);
int mpi_env_rank(void); /* 0 without MPI */
int mpi_env_size(void); /* 1 without MPI */
/* Ends MPI with the exit code of this rank: a failing rank takes the
 * others down (MPI_Abort), which may wait in a collective call for it. */
int mpi_env_finish(int rc);

#endif
