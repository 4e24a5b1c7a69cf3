/* h5fields.c — field snapshots and their XDMF index (h5fields.h). Every
 * HDF5, MPI and stdio call is checked; a failure names the file, the object
 * and the cause the system gave (HDF5 keeps it on its error stack: "No space
 * left on device").
 *
 * A failed snapshot (a full disk, most often) is taken out again: its group
 * is closed and deleted before anything is flushed, so that the file holds
 * the complete snapshots before it and nothing that points past its end.
 * This also keeps the file closable: HDF5 1.10 cannot close a file whose
 * metadata it cannot write (H5Fclose fails and leaves a freed file behind
 * its ID, which its exit handler then closes again: a segfault at exit),
 * and the metadata of the new group is what it could not write. The index
 * (.xmf) is rewritten only after a snapshot has been flushed.
 *
 * One process (no part, or a part without a communicator) writes the whole
 * grid with HDF5's default drivers, exactly as before MPI came. Several
 * processes write through the MPI-IO driver: the datasets, groups and the
 * `time` attribute are created by all of them with the global dimensions
 * (HDF5 requires every call that changes the file's structure to be made by
 * every process with the same arguments); each process selects its block as
 * a hyperslab of the file and all write it in one collective transfer. The
 * .xmf index is written by rank 0 only.
 *
 * Invariant: every process returns the same status from every call. Each
 * stage that can fail on one process only (memory, a bad block, the index,
 * an HDF5 call) ends in agree(), an MPI_Allreduce of (status, rank) with
 * MPI_MAXLOC, before the next collective HDF5 call, so that no process
 * enters a collective call that another one has left. A failure inside an
 * HDF5 collective call that HDF5 itself reports on one process only can
 * still leave the others waiting in MPI; that is beyond this layer. */
#include "h5fields.h"

#include "h5_cause.h"

#include "file_held.h"

#include <errno.h>
#include <hdf5.h>
#include <math.h>
#include <mpi.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct h5fields {
    char *path, *xmf;
    log_t log;
    hid_t file;
    int n[3];         /* the grid */
    int lo[3], nb[3]; /* this process's block */
    double dx;
    MPI_Comm comm;    /* ours (a duplicate), or MPI_COMM_NULL: serial */
    int rank;         /* in comm; 0 when serial */
    hid_t dxpl, dcpl; /* collective transfer, no fill; H5P_DEFAULT when serial */
    long *steps;      /* sorted, unique; the same on every process */
    double *times;
    int nsnaps, cap;
    /* the snapshot being written (h5fields_begin .. h5fields_end): its
     * group and datasets (-1: none), step, time and status so far */
    hid_t snap, dset[3];
    long snap_step;
    double snap_time;
    status_t snap_st;
    char snap_name[64];
};

/* The datasets of a snapshot: name, values per cell, HDF5 type. */
static const char *const FIELD_NAMES[3] = {"density", "velocity", "flags"};
/* their `unit` attributes, as every dataset of the output has one */
static const char *const FIELD_UNITS[3] = {"kg/m^3", "m/s", "0 fluid, 1 solid"};
static const int FIELD_COMPS[3] = {1, 3, 1};
static hid_t field_type(int k) { return k == 2 ? H5T_NATIVE_UCHAR : H5T_NATIVE_DOUBLE; }

static status_t open_file(const char *path, const int n[3], double dx, const h5fields_part_t *part, int resume,
                          const log_t *log, h5fields_t **out);
static status_t remember(h5fields_t *w, long step, double time);
static status_t write_xmf(h5fields_t *w);

/* A failed HDF5 call, logged with its cause. err: errno after a call that
 * writes to the file, cleared before it (0 otherwise): the MPI-IO driver
 * records no system message, but its failed write leaves errno set. */
static status_t fail_io(const h5fields_t *w, const char *what, int err)
{
    char cause[160];
    h5_cause(err, cause, sizeof cause);
    return log_msg(&w->log, STATUS_ERROR, "fields", "%s: HDF5 error while writing %s%s%s", w->path, what,
                   cause[0] != '\0' ? ": " : "", cause);
}

static status_t fail(const h5fields_t *w, const char *what) { return fail_io(w, what, 0); }

/* The worst status of any process of comm (MPI_COMM_NULL: st itself). A
 * process that did not fail itself says which one did, so that each log
 * explains the status its process returns. */
static status_t agree_on(MPI_Comm comm, const log_t *log, const char *path, status_t st, const char *what)
{
    if (comm == MPI_COMM_NULL) {
        return st;
    }
    int rank = 0;
    int mine[2] = {(int)st, 0}, all[2];
    if (MPI_Comm_rank(comm, &rank) != MPI_SUCCESS) {
        return log_msg(log, STATUS_FATAL, "fields", "%s: MPI error (MPI_Comm_rank) at %s", path, what);
    }
    mine[1] = rank;
    if (MPI_Allreduce(mine, all, 1, MPI_2INT, MPI_MAXLOC, comm) != MPI_SUCCESS) {
        return log_msg(log, STATUS_FATAL, "fields", "%s: MPI error (MPI_Allreduce) at %s", path, what);
    }
    if (all[0] > (int)st) {
        log_msg(log, (status_t)all[0], "fields", "%s: %s failed on process %d", path, what, all[1]);
    }
    return (status_t)all[0];
}

static status_t agree(const h5fields_t *w, status_t st, const char *what)
{
    return agree_on(w->comm, &w->log, w->path != NULL ? w->path : "the field file", st, what);
}

static void close_plist(hid_t p)
{
    if (p >= 0 && p != H5P_DEFAULT) {
        H5Pclose(p);
    }
}

/* Closes the snapshot's datasets and group (those open), each even when
 * one before failed; the first failure is logged when `report` (not after
 * the failure that ends a snapshot: one message for it is enough).
 * Collective with several processes. */
static status_t close_snapshot(h5fields_t *w, int report)
{
    int failed = 0;
    char what[160];
    for (int k = 0; k < 3; k++) {
        if (w->dset[k] >= 0 && H5Dclose(w->dset[k]) < 0 && !failed++ && report) {
            snprintf(what, sizeof what, "%s/%s (closing)", w->snap_name, FIELD_NAMES[k]);
            fail(w, what);
        }
        w->dset[k] = -1;
    }
    if (w->snap >= 0 && H5Gclose(w->snap) < 0 && !failed++ && report) {
        snprintf(what, sizeof what, "%s (closing)", w->snap_name);
        fail(w, what);
    }
    w->snap = -1;
    return failed ? STATUS_ERROR : STATUS_OK;
}

/* A snapshot that failed on the way: closed and its group deleted (by every
 * process), so that neither a flush nor the close of the file has to write
 * its metadata, and the file holds the snapshots before it only. Nothing is
 * flushed here: HDF5 writes the deletion with the next flush or the close. */
static status_t drop_failed_snapshot(h5fields_t *w, int report)
{
    status_t st = close_snapshot(w, report);
    const htri_t there = H5Lexists(w->file, "/fields", H5P_DEFAULT) > 0 ? H5Lexists(w->file, w->snap_name, H5P_DEFAULT)
                                                                        : 0;
    if (there > 0 && H5Ldelete(w->file, w->snap_name, H5P_DEFAULT) < 0) {
        char what[160];
        snprintf(what, sizeof what, "%s (removing the incomplete snapshot)", w->snap_name);
        st = status_worst(st, fail(w, what));
    }
    return st;
}

/* Closes whatever of the file is still open (a snapshot cut short), then the
 * file: a file ID left open after a failed close crashes HDF5's exit
 * handler. */
static status_t close_file(h5fields_t *w)
{
    status_t st = STATUS_OK;
    const unsigned types = H5F_OBJ_DATASET | H5F_OBJ_GROUP | H5F_OBJ_DATATYPE | H5F_OBJ_ATTR | H5F_OBJ_LOCAL;
    const ssize_t n = H5Fget_obj_count(w->file, types);
    hid_t ids[16];
    if (n > 0) {
        const ssize_t got = H5Fget_obj_ids(w->file, types, sizeof ids / sizeof ids[0], ids);
        for (ssize_t k = 0; k < got; k++) {
            const herr_t r = H5Iget_type(ids[k]) == H5I_ATTR ? H5Aclose(ids[k]) : H5Oclose(ids[k]);
            if (r < 0 && st == STATUS_OK) {
                st = fail(w, "an object of the file (closing)");
            }
        }
    }
    errno = 0;
    if (H5Fclose(w->file) < 0) {
        st = fail_io(w, "the file (closing)", errno);
    }
    w->file = -1;
    return st;
}

static status_t fields_close(h5fields_t *w)
{
    if (w == NULL) {
        return STATUS_OK;
    }
    status_t st = STATUS_OK;
    if (w->snap >= 0) {
        st = drop_failed_snapshot(w, 1); /* a snapshot begun and never ended */
    }
    if (w->file >= 0) {
        st = status_worst(st, close_file(w));
    }
    close_plist(w->dxpl);
    close_plist(w->dcpl);
    if (w->comm != MPI_COMM_NULL) {
        st = agree(w, st, "closing the field file");
        MPI_Comm_free(&w->comm);
    }
    free(w->steps);
    free(w->times);
    free(w->xmf);
    free(w->path);
    free(w);
    return st;
}

static status_t fields_open(const char *path, const int n[3], double dx, const h5fields_part_t *part, const log_t *log,
                           h5fields_t **out)
{
    return open_file(path, n, dx, part, 0, log, out);
}

/* A duplicate of the caller's communicator for this writer's agreements, so
 * that its reductions never meet the caller's messages (HDF5 duplicates it
 * once more for the file). The caller's error handler comes with it. */
static status_t join(const char *path, const void *comm, const log_t *log, MPI_Comm *out)
{
    *out = MPI_COMM_NULL;
    int up = 0;
    if (MPI_Initialized(&up) != MPI_SUCCESS || !up) {
        return log_msg(log, STATUS_ERROR, "fields",
                       "%s: the field file is to be written by several processes, but MPI is not initialised", path);
    }
    const MPI_Comm parent = *(const MPI_Comm *)comm;
    status_t st = STATUS_OK;
    if (MPI_Comm_dup(parent, out) != MPI_SUCCESS) {
        *out = MPI_COMM_NULL;
        st = log_msg(log, STATUS_ERROR, "fields", "%s: MPI error (MPI_Comm_dup) for the field file", path);
    }
    st = agree_on(parent, log, path, st, "duplicating the communicator");
    if (st != STATUS_OK && *out != MPI_COMM_NULL) {
        MPI_Comm_free(out);
    }
    return st;
}

/* The block must lie in the grid; one process alone must have all of it. */
static status_t check_block(const h5fields_t *w)
{
    int inside = 1, whole = 1;
    for (int a = 0; a < 3; a++) {
        inside = inside && w->lo[a] >= 0 && w->nb[a] >= 0 && w->nb[a] <= w->n[a] - w->lo[a];
        whole = whole && w->lo[a] == 0 && w->nb[a] == w->n[a];
    }
    if (!inside || (w->comm == MPI_COMM_NULL && !whole)) {
        return log_msg(&w->log, STATUS_ERROR, "fields",
                       "%s: the block of cells %d..%d x %d..%d x %d..%d (0-based, first..last) is not %s the grid of "
                       "%d x %d x %d cells",
                       w->path, w->lo[0], w->lo[0] + w->nb[0] - 1, w->lo[1], w->lo[1] + w->nb[1] - 1, w->lo[2],
                       w->lo[2] + w->nb[2] - 1, w->comm == MPI_COMM_NULL ? "all of" : "inside", w->n[0], w->n[1],
                       w->n[2]);
    }
    return STATUS_OK;
}

/* The blocks tile the grid: at least their cells add up to it (collective). */
static status_t check_tiling(const h5fields_t *w)
{
    const int64_t grid = (int64_t)w->n[0] * w->n[1] * w->n[2];
    int64_t mine = (int64_t)w->nb[0] * w->nb[1] * w->nb[2], all = 0;
    if (MPI_Allreduce(&mine, &all, 1, MPI_INT64_T, MPI_SUM, w->comm) != MPI_SUCCESS) {
        return log_msg(&w->log, STATUS_FATAL, "fields", "%s: MPI error (MPI_Allreduce) adding up the blocks",
                       w->path);
    }
    if (all != grid) {
        return log_msg(&w->log, STATUS_ERROR, "fields",
                       "%s: the blocks of the processes have %lld cells together, the grid of %d x %d x %d has %lld "
                       "(the blocks must tile the grid)",
                       w->path, (long long)all, w->n[0], w->n[1], w->n[2], (long long)grid);
    }
    return STATUS_OK;
}

/* The property lists of parallel writing: the MPI-IO driver for the file,
 * collective transfers, and no fill values (parallel HDF5 allocates a
 * dataset when it is created and would write the fill value over all of it
 * before the blocks overwrite it all again). */
static status_t parallel_lists(h5fields_t *w, hid_t *fapl)
{
    *fapl = H5Pcreate(H5P_FILE_ACCESS);
    w->dxpl = H5Pcreate(H5P_DATASET_XFER);
    w->dcpl = H5Pcreate(H5P_DATASET_CREATE);
    if (*fapl < 0 || w->dxpl < 0 || w->dcpl < 0 || H5Pset_fapl_mpio(*fapl, w->comm, MPI_INFO_NULL) < 0 ||
        H5Pset_dxpl_mpio(w->dxpl, H5FD_MPIO_COLLECTIVE) < 0 || H5Pset_fill_time(w->dcpl, H5D_FILL_TIME_NEVER) < 0) {
        return log_msg(&w->log, STATUS_ERROR, "fields", "%s: HDF5 error setting up parallel writing", w->path);
    }
    return STATUS_OK;
}

/* What needs no other process: the paths, the block, this process's rank
 * and the property lists of parallel writing. */
static status_t set_up(h5fields_t *w, const char *path, const int n[3], double dx, const h5fields_part_t *part,
                       hid_t *fapl)
{
    const size_t len = strlen(path);
    w->path = strdup(path);
    w->xmf = malloc(len + 5);
    if (w->path == NULL || w->xmf == NULL) {
        return log_msg(&w->log, STATUS_FATAL, "fields", "out of memory for the field file paths (%zu bytes)",
                       2 * len + 6);
    }
    memcpy(w->xmf, path, len + 1);
    char *dot = strrchr(w->xmf, '.'), *slash = strrchr(w->xmf, '/');
    if (dot != NULL && (slash == NULL || dot > slash)) {
        *dot = '\0';
    }
    strcat(w->xmf, ".xmf");
    memcpy(w->n, n, sizeof w->n);
    for (int a = 0; a < 3; a++) {
        w->lo[a] = part != NULL ? part->lo[a] : 0;
        w->nb[a] = part != NULL ? part->n[a] : n[a];
    }
    w->dx = dx;
    status_t st = check_block(w);
    if (w->comm != MPI_COMM_NULL) {
        if (MPI_Comm_rank(w->comm, &w->rank) != MPI_SUCCESS) {
            st = status_worst(st, log_msg(&w->log, STATUS_FATAL, "fields", "%s: MPI error (MPI_Comm_rank)", path));
        }
        st = status_worst(st, parallel_lists(w, fapl));
    }
    return st;
}

static status_t open_file(const char *path, const int n[3], double dx, const h5fields_part_t *part, int resume,
                          const log_t *log, h5fields_t **out)
{
    *out = NULL;
    MPI_Comm comm = MPI_COMM_NULL;
    if (part != NULL && part->comm != NULL) {
        const status_t st = join(path, part->comm, log, &comm);
        if (st != STATUS_OK) {
            return st;
        }
    }
    h5fields_t *w = calloc(1, sizeof *w);
    status_t st = STATUS_OK;
    if (w == NULL) {
        st = log_msg(log, STATUS_FATAL, "fields", "out of memory for the field writer (%zu bytes)", sizeof *w);
    }
    if ((st = agree_on(comm, log, path, st, "allocating the field writer")) != STATUS_OK) {
        free(w);
        if (comm != MPI_COMM_NULL) {
            MPI_Comm_free(&comm);
        }
        return st;
    }
    w->file = w->snap = -1;
    w->dset[0] = w->dset[1] = w->dset[2] = -1;
    w->dxpl = w->dcpl = H5P_DEFAULT;
    w->comm = comm;
    if (log != NULL) {
        w->log = *log;
    }
    hid_t fapl = H5P_DEFAULT;
    st = agree_on(comm, log, path, set_up(w, path, n, dx, part, &fapl), "setting up the field writer");
    if (st == STATUS_OK && comm != MPI_COMM_NULL) {
        st = check_tiling(w); /* the same sum on every process */
    }
    if (st == STATUS_OK) {
        /* asked first, by one process: HDF5's create would empty a file that
         * another process holds open before finding its lock, and its open
         * (resume) shares a file this process has open already: another FMU
         * instance's, which both would then write */
        int rank = 0;
        if (comm != MPI_COMM_NULL) {
            MPI_Comm_rank(comm, &rank);
        }
        if (rank == 0 && file_held(path)) {
            st = log_msg(log, STATUS_ERROR, "fields",
                         "%s: another process holds the field file open (a viewer, or the ranks of a stopped run?), "
                         "or another FMU instance in this one writes it; it was left as it is",
                         path);
        }
        st = agree(w, st, "checking the field file");
    }
    if (st == STATUS_OK) {
        w->file = resume ? H5Fopen(path, H5F_ACC_RDWR, fapl) : H5Fcreate(path, H5F_ACC_TRUNC, H5P_DEFAULT, fapl);
        if (w->file < 0) {
            st = log_msg(log, STATUS_ERROR, "fields", "%s: cannot %s the field file (%s)", path,
                         resume ? "open" : "create",
                         resume ? "is it there, an HDF5 file, writable?" : "does the folder exist and is it writable?");
        }
        st = agree(w, st, resume ? "opening the field file" : "creating the field file");
    }
    close_plist(fapl);
    if (st != STATUS_OK) {
        fields_close(w);
        return st;
    }
    *out = w;
    return STATUS_OK;
}

/* Planes z0 .. z0 + nz - 1 of this process's block (local z) as a
 * hyperslab of the file's dataspace, and the dataspace of their buffer
 * (nb[0] nb[1] nz cells, x fastest, comps values per cell). */
static status_t select_planes(const h5fields_t *w, hid_t fspace, int comps, int z0, int nz, hid_t *mspace)
{
    const hsize_t start[4] = {(hsize_t)(w->lo[2] + z0), (hsize_t)w->lo[1], (hsize_t)w->lo[0], 0};
    const hsize_t count[4] = {(hsize_t)nz, (hsize_t)w->nb[1], (hsize_t)w->nb[0], (hsize_t)comps};
    const int empty = w->nb[0] == 0 || w->nb[1] == 0 || nz == 0;
    const hsize_t one[4] = {1, 1, 1, 1};
    *mspace = H5Screate_simple(comps > 1 ? 4 : 3, empty ? one : count, NULL);
    if (*mspace < 0) {
        return STATUS_ERROR;
    }
    /* nothing to write here (an empty block, or no planes left in it): the
     * process still takes part in the collective write, with nothing */
    if (empty) {
        return H5Sselect_none(fspace) < 0 || H5Sselect_none(*mspace) < 0 ? STATUS_ERROR : STATUS_OK;
    }
    /* a selection outside the dataset would fail in H5Dwrite on this process
     * alone, and leave the others waiting in the collective transfer */
    if (H5Sselect_hyperslab(fspace, H5S_SELECT_SET, start, NULL, count, NULL) < 0 || H5Sselect_valid(fspace) <= 0) {
        return STATUS_ERROR;
    }
    return STATUS_OK;
}

/* Dataset k of the open snapshot, with the dimensions of the whole grid. */
static status_t create_one(h5fields_t *w, int k)
{
    char what[96];
    snprintf(what, sizeof what, "%s/%s", w->snap_name, FIELD_NAMES[k]);
    const int comps = FIELD_COMPS[k];
    const hsize_t dims[4] = {(hsize_t)w->n[2], (hsize_t)w->n[1], (hsize_t)w->n[0], (hsize_t)comps};
    hid_t space = H5Screate_simple(comps > 1 ? 4 : 3, dims, NULL);
    status_t st = agree(w, space < 0 ? fail(w, what) : STATUS_OK, what);
    if (st == STATUS_OK) {
        w->dset[k] = H5Dcreate2(w->snap, FIELD_NAMES[k], field_type(k), space, H5P_DEFAULT, w->dcpl, H5P_DEFAULT);
        st = agree(w, w->dset[k] < 0 ? fail(w, what) : STATUS_OK, what);
    }
    if (space >= 0) {
        H5Sclose(space);
    }
    if (st == STATUS_OK) {
        /* the unit (every process writes the same value: HDF5 requires it) */
        hid_t type = H5Tcopy(H5T_C_S1), scalar = H5Screate(H5S_SCALAR), a = -1;
        int ok = type >= 0 && scalar >= 0 && H5Tset_size(type, strlen(FIELD_UNITS[k]) + 1) >= 0;
        if (ok) {
            a = H5Acreate2(w->dset[k], "unit", type, scalar, H5P_DEFAULT, H5P_DEFAULT);
            ok = a >= 0 && H5Awrite(a, type, FIELD_UNITS[k]) >= 0;
        }
        st = ok ? STATUS_OK : fail(w, what); /* now: the closes below clear HDF5's error stack */
        if (a >= 0) {
            H5Aclose(a);
        }
        if (scalar >= 0) {
            H5Sclose(scalar);
        }
        if (type >= 0) {
            H5Tclose(type);
        }
        st = agree(w, st, what);
    }
    return st;
}

/* Planes z0 .. z0 + nz - 1 of this process's block into dataset k. */
static status_t write_planes_one(h5fields_t *w, int k, int z0, int nz, const void *data)
{
    char what[96];
    snprintf(what, sizeof what, "%s/%s", w->snap_name, FIELD_NAMES[k]);
    hid_t fspace = H5Dget_space(w->dset[k]), mspace = -1;
    status_t st = fspace < 0 || select_planes(w, fspace, FIELD_COMPS[k], z0, nz, &mspace) != STATUS_OK
                      ? fail(w, what)
                      : STATUS_OK;
    st = agree(w, st, what);
    errno = 0;
    if (st == STATUS_OK && H5Dwrite(w->dset[k], field_type(k), mspace, fspace, w->dxpl, data) < 0) {
        st = fail_io(w, what, errno);
    }
    st = agree(w, st, what);
    if (mspace >= 0) {
        H5Sclose(mspace);
    }
    if (fspace >= 0) {
        H5Sclose(fspace);
    }
    return st;
}

static status_t write_time(h5fields_t *w, hid_t group, const char *group_name, double time)
{
    char what[96];
    snprintf(what, sizeof what, "the time attribute of %s", group_name);
    hid_t space = H5Screate(H5S_SCALAR);
    status_t st = agree(w, space < 0 ? fail(w, what) : STATUS_OK, what);
    if (st != STATUS_OK) {
        if (space >= 0) {
            H5Sclose(space);
        }
        return st;
    }
    /* with several processes, each writes the same value (HDF5 requires it) */
    hid_t a = H5Acreate2(group, "time", H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, H5P_DEFAULT);
    st = agree(w, a < 0 ? fail(w, what) : STATUS_OK, what);
    if (st == STATUS_OK && H5Awrite(a, H5T_NATIVE_DOUBLE, &time) < 0) {
        st = fail(w, what);
    }
    if (a >= 0) {
        H5Aclose(a);
    }
    H5Sclose(space);
    return agree(w, st, what);
}

/* The XDMF index: a temporal collection of co-rectilinear grids whose
 * attributes point into the .h5 file (XDMF 2, as ParaView reads it). Rank 0
 * writes it; the others learn its status. */
static status_t write_xmf_once(h5fields_t *w)
{
    return agree(w, w->rank == 0 ? write_xmf(w) : STATUS_OK, "writing the XDMF index");
}

static status_t write_xmf(h5fields_t *w)
{
    char tmp[4200];
    if (snprintf(tmp, sizeof tmp, "%s.tmp", w->xmf) >= (int)sizeof tmp) {
        return log_msg(&w->log, STATUS_ERROR, "fields", "%s: path too long", w->xmf);
    }
    FILE *fp = fopen(tmp, "w");
    if (fp == NULL) {
        return log_msg(&w->log, STATUS_ERROR, "fields", "%s: cannot write the XDMF index: %s", w->xmf,
                       strerror(errno));
    }
    const char *h5 = strrchr(w->path, '/') ? strrchr(w->path, '/') + 1 : w->path;
    const int nx = w->n[0], ny = w->n[1], nz = w->n[2];
    fprintf(fp, "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"2.0\">\n <Domain>\n"
                "  <Grid Name=\"fields\" GridType=\"Collection\" CollectionType=\"Temporal\">\n");
    for (int k = 0; k < w->nsnaps; k++) {
        fprintf(fp, "   <Grid Name=\"step %ld\" GridType=\"Uniform\">\n    <Time Value=\"%.10g\"/>\n", w->steps[k],
                w->times[k]);
        /* cell data: the mesh has one node more than cells per axis; the
         * origin and spacing as doubles (an XML DataItem without a
         * Precision is a 4-byte float: ParaView read dx 1e-4 m as
         * 9.99999975e-05 m), written to the last bit */
        fprintf(fp, "    <Topology TopologyType=\"3DCoRectMesh\" Dimensions=\"%d %d %d\"/>\n", nz + 1, ny + 1,
                nx + 1);
        fprintf(fp,
                "    <Geometry GeometryType=\"ORIGIN_DXDYDZ\">\n"
                "     <DataItem Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">0 0 0</DataItem>\n"
                "     <DataItem Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">%.17g %.17g "
                "%.17g</DataItem>\n"
                "    </Geometry>\n",
                w->dx, w->dx, w->dx);
        static const char *names[3] = {"density", "velocity", "flags"};
        for (int a = 0; a < 3; a++) {
            fprintf(fp,
                    "    <Attribute Name=\"%s\" AttributeType=\"%s\" Center=\"Cell\">\n"
                    "     <DataItem Dimensions=\"%d %d %d%s\" NumberType=\"%s\" Precision=\"%d\" "
                    "Format=\"HDF\">%s:/fields/%06ld/%s</DataItem>\n    </Attribute>\n",
                    names[a], a == 1 ? "Vector" : "Scalar", nz, ny, nx, a == 1 ? " 3" : "",
                    a == 2 ? "UChar" : "Float", a == 2 ? 1 : 8, h5, w->steps[k], names[a]);
        }
        fprintf(fp, "   </Grid>\n");
    }
    fprintf(fp, "  </Grid>\n </Domain>\n</Xdmf>\n");
    /* the first failure and its errno: a full disk shows at the flush, or at the close */
    int bad = ferror(fp) || fflush(fp) != 0, err = bad ? errno : 0;
    if (fclose(fp) != 0 && !bad) {
        bad = 1;
        err = errno;
    }
    if (!bad && rename(tmp, w->xmf) != 0) {
        bad = 1;
        err = errno;
    }
    if (bad) {
        remove(tmp); /* the index before stays as it was */
        return log_msg(&w->log, STATUS_ERROR, "fields", "%s: cannot write the XDMF index: %s", w->xmf,
                       err != 0 ? strerror(err) : "a write error");
    }
    return STATUS_OK;
}

/* Records a snapshot in the sorted list (replacing one of the same step). */
static status_t remember(h5fields_t *w, long step, double time)
{
    int k = 0;
    while (k < w->nsnaps && w->steps[k] < step) {
        k++;
    }
    if (k < w->nsnaps && w->steps[k] == step) {
        w->times[k] = time;
        return STATUS_OK;
    }
    if (w->nsnaps == w->cap) {
        const int cap = w->cap > 0 ? 2 * w->cap : 16;
        long *ns = realloc(w->steps, sizeof(long) * (size_t)cap);
        if (ns == NULL) {
            return log_msg(&w->log, STATUS_FATAL, "fields", "out of memory for the list of %d snapshots (%zu bytes)", cap, sizeof(long) * (size_t)cap);
        }
        w->steps = ns;
        double *nt = realloc(w->times, sizeof(double) * (size_t)cap);
        if (nt == NULL) {
            return log_msg(&w->log, STATUS_FATAL, "fields", "out of memory for the list of %d snapshots (%zu bytes)", cap, sizeof(double) * (size_t)cap);
        }
        w->times = nt;
        w->cap = cap;
    }
    memmove(&w->steps[k + 1], &w->steps[k], sizeof(long) * (size_t)(w->nsnaps - k));
    memmove(&w->times[k + 1], &w->times[k], sizeof(double) * (size_t)(w->nsnaps - k));
    w->steps[k] = step;
    w->times[k] = time;
    w->nsnaps++;
    return STATUS_OK;
}

int h5fields_slab_planes(int nx, int ny, int nz)
{
    const double plane = (double)nx * (double)ny;
    const double fit = plane > 0.0 ? floor((double)H5FIELDS_SLAB_CELLS / plane) : (double)nz;
    const int planes = fit < 1.0 ? 1 : fit > (double)nz ? nz : (int)fit;
    return planes > 0 ? planes : 1;
}

static status_t fields_slabs(h5fields_t *w, int planes, int *calls)
{
    planes = planes > 0 ? planes : 1;
    int mine = (w->nb[2] + planes - 1) / planes;
    *calls = mine;
    /* the processes' slabs may differ (their blocks do): the most calls of any */
    if (w->comm != MPI_COMM_NULL && MPI_Allreduce(&mine, calls, 1, MPI_INT, MPI_MAX, w->comm) != MPI_SUCCESS) {
        *calls = 0;
        return log_msg(&w->log, STATUS_FATAL, "fields", "%s: MPI error (MPI_Allreduce) counting the slabs of planes",
                       w->path);
    }
    return STATUS_OK;
}

static status_t fields_begin(h5fields_t *w, long step, double time)
{
    if (w->snap >= 0) {
        drop_failed_snapshot(w, 1); /* one begun and never ended */
    }
    snprintf(w->snap_name, sizeof w->snap_name, "/fields/%06ld", step);
    const char *name = w->snap_name;
    w->snap_step = step;
    w->snap_time = time;
    status_t st = STATUS_OK;
    if (H5Lexists(w->file, "/fields", H5P_DEFAULT) > 0 && H5Lexists(w->file, name, H5P_DEFAULT) > 0 &&
        H5Ldelete(w->file, name, H5P_DEFAULT) < 0) {
        st = fail(w, name);
    }
    hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
    if (st == STATUS_OK && (lcpl < 0 || H5Pset_create_intermediate_group(lcpl, 1) < 0)) {
        st = fail(w, name);
    }
    if ((st = agree(w, st, name)) == STATUS_OK) {
        w->snap = H5Gcreate2(w->file, name, lcpl, H5P_DEFAULT, H5P_DEFAULT);
        st = agree(w, w->snap < 0 ? fail(w, name) : STATUS_OK, name);
    }
    if (lcpl >= 0) {
        H5Pclose(lcpl);
    }
    for (int k = 0; k < 3 && st == STATUS_OK; k++) {
        st = create_one(w, k);
    }
    if (st != STATUS_OK) {
        drop_failed_snapshot(w, 0);
    }
    w->snap_st = st;
    return st;
}

static status_t fields_planes(h5fields_t *w, int z0, int nz, const double *density, const double *velocity,
                         const unsigned char *flags)
{
    if (w->snap < 0) {
        return log_msg(&w->log, STATUS_ERROR, "fields", "%s: planes written outside a snapshot (h5fields_begin)",
                       w->path);
    }
    if (w->snap_st != STATUS_OK) {
        return w->snap_st; /* every process knows it (agreed): none writes on */
    }
    status_t st = STATUS_OK;
    if (z0 < 0 || nz < 0 || (nz > 0 && z0 + nz > w->nb[2])) {
        st = log_msg(&w->log, STATUS_ERROR, "fields", "%s: planes %d..%d are not in this process's block of %d planes",
                     w->path, z0, z0 + nz - 1, w->nb[2]);
    }
    st = agree(w, st, w->snap_name);
    const void *data[3] = {density, velocity, flags};
    for (int k = 0; k < 3 && st == STATUS_OK; k++) {
        st = write_planes_one(w, k, z0, nz, data[k]);
    }
    w->snap_st = st;
    return st;
}

static status_t fields_end(h5fields_t *w)
{
    if (w->snap < 0) {
        return log_msg(&w->log, STATUS_ERROR, "fields", "%s: no snapshot to finish (h5fields_begin)", w->path);
    }
    status_t st = w->snap_st;
    if (st == STATUS_OK) {
        st = write_time(w, w->snap, w->snap_name, w->snap_time);
    }
    /* on every process, whatever the other did: closing is collective */
    st = agree(w, status_worst(st, close_snapshot(w, st == STATUS_OK)), w->snap_name);
    errno = 0;
    if (st == STATUS_OK && H5Fflush(w->file, H5F_SCOPE_GLOBAL) < 0) {
        st = fail_io(w, w->snap_name, errno);
    }
    if ((st = agree(w, st, w->snap_name)) != STATUS_OK) {
        /* incomplete, or not on disk: out again (the flush after a failed
         * write is never tried, it could not write the new metadata) */
        drop_failed_snapshot(w, 0);
        return st;
    }
    st = agree(w, remember(w, w->snap_step, w->snap_time), "the list of snapshots");
    return st != STATUS_OK ? st : write_xmf_once(w);
}

static status_t fields_write(h5fields_t *w, long step, double time, const double *density, const double *velocity,
                        const unsigned char *flags)
{
    status_t st = fields_begin(w, step, time);
    if (st != STATUS_OK) {
        return st;
    }
    fields_planes(w, 0, w->nb[2], density, velocity, flags); /* its status: h5fields_end's */
    return fields_end(w);
}

/* Every snapshot group already in the file, into the sorted list. */
static herr_t found_snapshot(hid_t group, const char *name, const H5L_info_t *info, void *data)
{
    (void)info;
    h5fields_t *w = data;
    char *end;
    const long step = strtol(name, &end, 10);
    double time = 0.0;
    if (*end != '\0' || step < 0) {
        return 0; /* not a snapshot of ours: left alone */
    }
    hid_t a = H5Aopen_by_name(group, name, "time", H5P_DEFAULT, H5P_DEFAULT);
    if (a < 0 || H5Aread(a, H5T_NATIVE_DOUBLE, &time) < 0) {
        if (a >= 0) {
            H5Aclose(a);
        }
        return -1;
    }
    H5Aclose(a);
    return remember(w, step, time) == STATUS_OK ? 0 : -1;
}

static status_t fields_resume(const char *path, const int n[3], double dx, const h5fields_part_t *part, const log_t *log,
                         h5fields_t **out)
{
    h5fields_t *w;
    status_t st = open_file(path, n, dx, part, 1, log, &w);
    if (st != STATUS_OK) {
        return st;
    }
    /* reading only: each process reads the list for itself */
    if (H5Lexists(w->file, "/fields", H5P_DEFAULT) > 0) {
        hid_t g = H5Gopen2(w->file, "/fields", H5P_DEFAULT);
        if (g < 0 || H5Literate(g, H5_INDEX_NAME, H5_ITER_INC, NULL, found_snapshot, w) < 0) {
            st = log_msg(log, STATUS_ERROR, "fields", "%s: cannot read the snapshots already written", path);
        }
        if (g >= 0) {
            H5Gclose(g);
        }
    }
    if ((st = agree(w, st, "reading the snapshots already written")) != STATUS_OK) {
        fields_close(w);
        return st;
    }
    *out = w;
    return STATUS_OK;
}

static status_t fields_drop_after(h5fields_t *w, long step)
{
    if (w->nsnaps == 0 || w->steps[w->nsnaps - 1] <= step) {
        return STATUS_OK;
    }
    while (w->nsnaps > 0 && w->steps[w->nsnaps - 1] > step) {
        char name[64];
        snprintf(name, sizeof name, "/fields/%06ld", w->steps[w->nsnaps - 1]);
        status_t st = STATUS_OK;
        if (H5Lexists(w->file, name, H5P_DEFAULT) > 0 && H5Ldelete(w->file, name, H5P_DEFAULT) < 0) {
            st = fail(w, name);
        }
        if ((st = agree(w, st, name)) != STATUS_OK) {
            return st;
        }
        w->nsnaps--;
    }
    errno = 0;
    status_t st = H5Fflush(w->file, H5F_SCOPE_GLOBAL) < 0 ? fail_io(w, "the file (flushing)", errno) : STATUS_OK;
    if ((st = agree(w, st, "flushing the field file")) != STATUS_OK) {
        return st;
    }
    return write_xmf_once(w);
}

/* The public calls: HDF5 prints no error of its own while they run (this
 * file reports each failure with its cause, h5_cause), and the host
 * process's printing is put back after each, as it was: an FMU must not
 * change a setting of a library its host may use too (it was turned off
 * for the whole process at the first open). */
typedef struct {
    H5E_auto2_t fn;
    void *data;
} quiet_t;

static quiet_t quiet_begin(void)
{
    quiet_t q = {NULL, NULL};
    H5Eget_auto2(H5E_DEFAULT, &q.fn, &q.data);
    H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
    return q;
}

static status_t quiet_end(quiet_t q, status_t st)
{
    H5Eset_auto2(H5E_DEFAULT, q.fn, q.data);
    return st;
}

status_t h5fields_open(const char *path, const int n[3], double dx, const h5fields_part_t *part, const log_t *log,
                       h5fields_t **out)
{
    const quiet_t q = quiet_begin();
    return quiet_end(q, fields_open(path, n, dx, part, log, out));
}

status_t h5fields_resume(const char *path, const int n[3], double dx, const h5fields_part_t *part, const log_t *log,
                         h5fields_t **out)
{
    const quiet_t q = quiet_begin();
    return quiet_end(q, fields_resume(path, n, dx, part, log, out));
}

status_t h5fields_drop_after(h5fields_t *w, long step)
{
    const quiet_t q = quiet_begin();
    return quiet_end(q, fields_drop_after(w, step));
}

status_t h5fields_write(h5fields_t *w, long step, double time, const double *density, const double *velocity,
                        const unsigned char *flags)
{
    const quiet_t q = quiet_begin();
    return quiet_end(q, fields_write(w, step, time, density, velocity, flags));
}

status_t h5fields_begin(h5fields_t *w, long step, double time)
{
    const quiet_t q = quiet_begin();
    return quiet_end(q, fields_begin(w, step, time));
}

status_t h5fields_planes(h5fields_t *w, int z0, int nz, const double *density, const double *velocity,
                         const unsigned char *flags)
{
    const quiet_t q = quiet_begin();
    return quiet_end(q, fields_planes(w, z0, nz, density, velocity, flags));
}

status_t h5fields_end(h5fields_t *w)
{
    const quiet_t q = quiet_begin();
    return quiet_end(q, fields_end(w));
}

status_t h5fields_slabs(h5fields_t *w, int planes, int *calls)
{
    const quiet_t q = quiet_begin();
    return quiet_end(q, fields_slabs(w, planes, calls));
}

status_t h5fields_close(h5fields_t *w)
{
    const quiet_t q = quiet_begin();
    return quiet_end(q, fields_close(w));
}
