/* h5fields_mpi.c — writes the field snapshots of a known analytic field with
 * common/h5fields.c, each MPI process its block, for
 * tests/python/test_h5fields_mpi.py, which compares every file with the one
 * a single process writes (datasets, attributes, groups, the .xmf index).
 *
 *   h5fields_mpi OUT.h5                  one process, part NULL, no MPI call
 *   h5fields_mpi OUT.h5 px py pz [MODE]  px*py*pz processes of MPI_COMM_WORLD
 *
 * The grid has 13 x 10 x 7 cells; axis a is split into p[a] blocks of
 * n/p cells, the first n%p of them one cell larger, and rank r writes block
 * (r % px, r / px % py, r / (px py)). The sequence: open, steps 0 and 5
 * (times 0 and 0.5), close; resume, drop the steps after 0, step 5 again
 * with other values (version 1), close. Step 0 goes in one h5fields_write,
 * step 5 in slabs of 2 planes on the even ranks and 3 on the odd ones (so
 * that the processes need different numbers of calls, as blocks of
 * different sizes do in the fluid FMU) and step 5 again in slabs of 3
 * (h5fields_begin, h5fields_slabs, h5fields_planes, h5fields_end: calls
 * with no planes left on some processes). MODE:
 *   bad-block    first an open where the last process's block lies outside
 *                the grid: every process must get STATUS_ERROR; after the
 *                good open, a step 0 whose last process asks for planes past
 *                its block: every h5fields_planes and h5fields_end must
 *                return STATUS_ERROR (then the sequence as above, whose step
 *                0 replaces that one);
 *   write-error  the caller made OUT.xmf a directory: the first snapshot
 *                must fail on every process (rank 0 alone writes the index),
 *                then the writer is closed.
 * After every call the processes compare their statuses; the exit status
 * is 0 when every call returned, on every process, what it should. */
#include "../../common/h5fields.h"

#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const int GRID[3] = {13, 10, 7};
static const double DX = 0.001;

typedef struct {
    int mpi, rank, size;
    log_t log;
} run_t;

static void log_process(void *ctx, status_t level, const char *category, const char *msg)
{
    const run_t *r = ctx;
    fprintf(stderr, "process %d: %s: [%s] %s\n", r->rank, status_name(level), category, msg);
}

/* Block c of p along an axis of n cells: n/p cells, the first n%p one more. */
static void split(int n, int p, int c, int *lo, int *nb)
{
    const int base = n / p, extra = n % p;
    *nb = base + (c < extra);
    *lo = c * base + (c < extra ? c : extra);
}

/* The analytic fields at global cell (x, y, z); test_h5fields_mpi.py has
 * the same formulas. */
static void fill(const int lo[3], const int nb[3], int version, double *rho, double *u, unsigned char *flags)
{
    size_t c = 0;
    for (int k = 0; k < nb[2]; k++) {
        for (int j = 0; j < nb[1]; j++) {
            for (int i = 0; i < nb[0]; i++, c++) {
                const int x = lo[0] + i, y = lo[1] + j, z = lo[2] + k;
                const double base = 1.0 + x + 100.0 * y + 10000.0 * z;
                if (version == 0) {
                    rho[c] = base;
                    u[3 * c] = x + 0.25;
                    u[3 * c + 1] = -y - 0.5;
                    u[3 * c + 2] = z * z + 0.125;
                    flags[c] = (unsigned char)((x + 3 * y + 5 * z) % 7);
                } else {
                    rho[c] = -base / 3.0;
                    u[3 * c] = x / 3.0;
                    u[3 * c + 1] = y * y + 0.75;
                    u[3 * c + 2] = -z / 7.0;
                    flags[c] = (unsigned char)((x * y + z) % 2);
                }
            }
        }
    }
}

/* 1 when st is `want` on every process; every process learns the same. */
static int check(const run_t *r, status_t st, status_t want, const char *what)
{
    int bad = st != want, any = bad;
    if (r->mpi && MPI_Allreduce(&bad, &any, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD) != MPI_SUCCESS) {
        fprintf(stderr, "process %d: MPI_Allreduce failed after %s\n", r->rank, what);
        return 0;
    }
    if (bad) {
        fprintf(stderr, "process %d: %s returned %s, expected %s\n", r->rank, what, status_name(st), status_name(want));
    }
    return !any;
}

/* Snapshot `step` of field `version` in slabs of `planes` planes, each
 * filled for its planes only, as the fluid FMU writes them. */
static int write_slabs(const run_t *r, h5fields_t *w, long step, double time, const int lo[3], const int nb[3],
                       int version, int planes, double *rho, double *u, unsigned char *flags)
{
    int calls = 0;
    int ok = check(r, h5fields_begin(w, step, time), STATUS_OK, "begin a snapshot") &&
             check(r, h5fields_slabs(w, planes, &calls), STATUS_OK, "count the slabs");
    for (int c = 0; c < calls && ok; c++) {
        const int z0 = c * planes, left = nb[2] - z0, nz = left <= 0 ? 0 : left < planes ? left : planes;
        const int slo[3] = {lo[0], lo[1], lo[2] + z0}, snb[3] = {nb[0], nb[1], nz};
        fill(slo, snb, version, rho, u, flags);
        ok = check(r, h5fields_planes(w, z0, nz, rho, u, flags), STATUS_OK, "a slab of planes");
    }
    return check(r, h5fields_end(w), ok ? STATUS_OK : STATUS_ERROR, "end a snapshot") && ok;
}

static int sequence(const run_t *r, const char *out, const h5fields_part_t *part, const char *mode)
{
    const int *lo = part != NULL ? part->lo : (const int[3]){0, 0, 0}, *nb = part != NULL ? part->n : GRID;
    const size_t cells = (size_t)nb[0] * (size_t)nb[1] * (size_t)nb[2];
    double *rho = malloc(sizeof(double) * (cells + 1)), *u = malloc(sizeof(double) * 3 * (cells + 1));
    unsigned char *flags = malloc(cells + 1);
    h5fields_t *w = NULL;
    int ok = rho != NULL && u != NULL && flags != NULL;
    if (!ok) {
        fprintf(stderr, "process %d: out of memory\n", r->rank);
    }
    ok = check(r, ok ? STATUS_OK : STATUS_FATAL, STATUS_OK, "allocating the fields");
    if (ok && strcmp(mode, "bad-block") == 0) {
        h5fields_part_t bad = *part;
        if (r->rank == r->size - 1) {
            bad.lo[0] = GRID[0] - bad.n[0] + 1; /* one cell past the grid */
        }
        ok = check(r, h5fields_open(out, GRID, DX, &bad, &r->log, &w), STATUS_ERROR, "open with a bad block") &&
             w == NULL;
    }
    if (ok) {
        ok = check(r, h5fields_open(out, GRID, DX, part, &r->log, &w), STATUS_OK, "open");
    }
    if (ok && strcmp(mode, "bad-block") == 0) {
        /* planes past the last process's block: an error on every process */
        const int z0 = r->rank == r->size - 1 ? nb[2] : 0;
        ok = check(r, h5fields_begin(w, 0, 0.0), STATUS_OK, "begin step 0") &&
             check(r, h5fields_planes(w, z0, 1, rho, u, flags), STATUS_ERROR, "planes past the block") &&
             check(r, h5fields_planes(w, 0, 1, rho, u, flags), STATUS_ERROR, "planes after a failed call") &&
             check(r, h5fields_end(w), STATUS_ERROR, "end after a failed call");
    }
    if (ok) {
        fill(lo, nb, 0, rho, u, flags);
    }
    if (ok && strcmp(mode, "write-error") == 0) {
        ok = check(r, h5fields_write(w, 0, 0.0, rho, u, flags), STATUS_ERROR, "step 0 with the index a directory") &&
             check(r, h5fields_close(w), STATUS_OK, "close");
    } else if (ok) {
        ok = check(r, h5fields_write(w, 0, 0.0, rho, u, flags), STATUS_OK, "step 0") &&
             write_slabs(r, w, 5, 0.5, lo, nb, 0, 2 + r->rank % 2, rho, u, flags) &&
             check(r, h5fields_close(w), STATUS_OK, "close");
        w = NULL;
        ok = ok && check(r, h5fields_resume(out, GRID, DX, part, &r->log, &w), STATUS_OK, "resume") &&
             check(r, h5fields_drop_after(w, 0), STATUS_OK, "drop after step 0");
        if (ok) {
            ok = write_slabs(r, w, 5, 0.5, lo, nb, 1, 3, rho, u, flags) &&
                 check(r, h5fields_close(w), STATUS_OK, "close after resume");
        }
    }
    free(rho);
    free(u);
    free(flags);
    return ok;
}

int main(int argc, char **argv)
{
    if (argc != 2 && argc != 5 && argc != 6) {
        fprintf(stderr, "usage: %s OUT.h5 [px py pz [bad-block|write-error]]\n", argv[0]);
        return 2;
    }
    run_t r = {.size = 1};
    r.log = (log_t){log_process, &r};
    if (argc == 2) {
        return sequence(&r, argv[1], NULL, "") ? 0 : 1;
    }
    int p[3];
    for (int a = 0; a < 3; a++) {
        p[a] = atoi(argv[2 + a]);
        if (p[a] < 1 || p[a] > GRID[a]) {
            fprintf(stderr, "%s: the split of axis %d must be 1..%d, not %s\n", argv[0], a, GRID[a], argv[2 + a]);
            return 2;
        }
    }
    const char *mode = argc == 6 ? argv[5] : "";
    if (strcmp(mode, "") != 0 && strcmp(mode, "bad-block") != 0 && strcmp(mode, "write-error") != 0) {
        fprintf(stderr, "%s: unknown mode %s\n", argv[0], mode);
        return 2;
    }
    setenv("OMPI_MCA_io", "romio321", 0); /* as the coupler does (coupler/mpi_env.c) */
    if (MPI_Init(&argc, &argv) != MPI_SUCCESS) {
        fprintf(stderr, "%s: MPI_Init failed\n", argv[0]);
        return 2;
    }
    r.mpi = 1;
    MPI_Comm_rank(MPI_COMM_WORLD, &r.rank);
    MPI_Comm_size(MPI_COMM_WORLD, &r.size);
    int status = 2;
    if (r.size != p[0] * p[1] * p[2]) {
        fprintf(stderr, "%s: %d processes for a split into %d x %d x %d\n", argv[0], r.size, p[0], p[1], p[2]);
    } else {
        const MPI_Comm world = MPI_COMM_WORLD;
        const int c[3] = {r.rank % p[0], r.rank / p[0] % p[1], r.rank / (p[0] * p[1])};
        h5fields_part_t part = {.comm = &world};
        for (int a = 0; a < 3; a++) {
            split(GRID[a], p[a], c[a], &part.lo[a], &part.n[a]);
        }
        status = sequence(&r, argv[1], &part, mode) ? 0 : 1;
    }
    MPI_Finalize();
    return status;
}
