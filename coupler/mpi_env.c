/* mpi_env.c — MPI start and end for the coupler CLI, and the master's few
 * collectives and messages (mpi_env.h). */
#define _GNU_SOURCE /* sched_getaffinity, CPU_COUNT */
#include "mpi_env.h"

#include <mpi.h>
#include <omp.h>
#include <sched.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#define CAT "mpi"
/* Bytes per message: counts are int */
#define PIECE ((size_t)1 << 30)
#define TAG_BYTES 7

static int started, rank, size = 1;

static int launched_by_mpirun(void)
{
    return getenv("OMPI_COMM_WORLD_SIZE") != NULL || getenv("PMIX_RANK") != NULL || getenv("PMI_RANK") != NULL;
}

static int start(int *argc, char ***argv, const char *why)
{
    /* Open MPI 4.1's own MPI-IO (OMPIO) wrote parts of the parallel field
     * snapshots wrong here (blocks of zeros and garbage, different from run
     * to run; tests/python/test_mpi.py); ROMIO writes them right. A user's
     * choice (OMPI_MCA_io set, or --mca io) is kept. */
    setenv("OMPI_MCA_io", "romio321", 0);
    int provided = 0;
    /* OpenMP threads inside a rank; only the main thread calls MPI */
    if (MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) {
        fprintf(stderr, "error: [mpi] MPI_Init_thread failed: %s\n", why);
        return 1;
    }
    started = 1;
    if (MPI_Comm_rank(MPI_COMM_WORLD, &rank) != MPI_SUCCESS || MPI_Comm_size(MPI_COMM_WORLD, &size) != MPI_SUCCESS) {
        fprintf(stderr, "error: [mpi] MPI_Comm_rank or MPI_Comm_size failed after MPI_Init_thread\n");
        return 1;
    }
    /* OpenMP threads: as many as this rank's cores (mpirun binds a rank
     * to a core by default for up to 2 ranks, to a socket beyond; two
     * threads spinning on one core run ten times slower), unless the user
     * set OMP_NUM_THREADS */
    cpu_set_t set;
    if (getenv("OMP_NUM_THREADS") == NULL && sched_getaffinity(0, sizeof set, &set) == 0) {
        const int cores = CPU_COUNT(&set);
        omp_set_num_threads(cores > 0 ? cores : 1);
    }
    return 0;
}

int mpi_env_init(int *argc, char ***argv)
{
    if (!launched_by_mpirun()) {
        return 0;
    }
    return start(argc, argv, "this process cannot join the other ranks");
}

int mpi_env_init_alone(void)
{
    if (started) {
        return 0;
    }
    /* a singleton: MPI_COMM_WORLD holds this process alone (size stays 1) */
    return start(NULL, NULL, "MPI cannot start in this process alone (a singleton, without mpirun)");
}

int mpi_env_rank(void) { return rank; }
int mpi_env_size(void) { return size; }

int mpi_env_finish(int rc)
{
    if (!started) {
        return rc;
    }
    /* 130, 143: the master agreed on the stop over all ranks (run.c) */
    if (rc != 0 && rc != 128 + 2 && rc != 128 + 15 && size > 1) {
        fflush(stdout);
        fflush(stderr);
        MPI_Abort(MPI_COMM_WORLD, rc);
    }
    MPI_Finalize();
    return rc;
}

static status_t failed(const log_t *log, const char *call)
{
    return log_msg(log, STATUS_FATAL, CAT, "rank %d of %d: %s failed", rank, size, call);
}

status_t mpi_env_max(int *v, const log_t *log)
{
    if (size == 1) {
        return STATUS_OK;
    }
    return MPI_Allreduce(MPI_IN_PLACE, v, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD) == MPI_SUCCESS
               ? STATUS_OK
               : failed(log, "MPI_Allreduce");
}

/* sizes travel as MPI_UINT64_T straight into the caller's array */
_Static_assert(sizeof(size_t) == sizeof(uint64_t), "size_t is not 64 bits");

status_t mpi_env_gather_size(size_t n, size_t *all, const log_t *log)
{
    if (size == 1) {
        all[0] = n;
        return STATUS_OK;
    }
    const uint64_t mine = n;
    return MPI_Gather(&mine, 1, MPI_UINT64_T, all, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD) == MPI_SUCCESS
               ? STATUS_OK
               : failed(log, "MPI_Gather");
}

status_t mpi_env_send(const void *buf, size_t n, int to, const log_t *log)
{
    const char *p = buf;
    for (size_t done = 0; done < n; done += PIECE) {
        const int count = (int)(n - done < PIECE ? n - done : PIECE);
        if (MPI_Send(p + done, count, MPI_BYTE, to, TAG_BYTES, MPI_COMM_WORLD) != MPI_SUCCESS) {
            return failed(log, "MPI_Send");
        }
    }
    return STATUS_OK;
}

status_t mpi_env_recv(void *buf, size_t n, int from, const log_t *log)
{
    char *p = buf;
    for (size_t done = 0; done < n; done += PIECE) {
        const int count = (int)(n - done < PIECE ? n - done : PIECE);
        if (MPI_Recv(p + done, count, MPI_BYTE, from, TAG_BYTES, MPI_COMM_WORLD, MPI_STATUS_IGNORE) != MPI_SUCCESS) {
            return failed(log, "MPI_Recv");
        }
    }
    return STATUS_OK;
}
