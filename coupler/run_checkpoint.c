/* run_checkpoint.c — checkpoints of `coupler run` (master.h): what they
 * belong to (the coupler binary, each FMU's GUID and library), writing one
 * with every rank's block of the grid (rank 0 writes the file, all learn the
 * outcome), and the records a restart replays. The file format is
 * checkpoint.c's. */
#define _XOPEN_SOURCE 700 /* readlink */
#include "master.h"
#include "mpi_env.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define CAT "run"

/* ------------------------------------------------------------------------ */
/* Checkpoint and restart                                                    */

/* What this run's checkpoints belong to: the coupler binary, each FMU's GUID
 * and library. */
status_t master_find_origin(master_t *m)
{
    char exe[4096], lib[4400], hash[17];
    const ssize_t len = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (len <= 0) {
        return log_msg(&m->log, STATUS_ERROR, CAT, "cannot find the coupler executable (/proc/self/exe): %s",
                       strerror(errno));
    }
    exe[len] = '\0';
    if (checkpoint_file_hash(exe, &m->log, hash) != STATUS_OK) {
        return STATUS_ERROR;
    }
    snprintf(m->origin.coupler, sizeof m->origin.coupler, "build %s", hash);
    fmu_t *f[2] = {m->fluid, m->rigid};
    char *dst[2] = {m->origin.fluid, m->origin.rigid};
    for (int k = 0; k < 2; k++) {
        if (f[k] == NULL) {
            continue;
        }
        fmu_library_path(f[k], lib, sizeof lib);
        if (checkpoint_file_hash(lib, &m->log, hash) != STATUS_OK) {
            return STATUS_ERROR;
        }
        snprintf(dst[k], CHECKPOINT_ID_MAX, "GUID %s, library %s", fmu_guid(f[k]), hash);
    }
    return STATUS_OK;
}

/* The serialized state of one FMU. */
static status_t serialize(fmu_t *f, unsigned char **bytes, size_t *size)
{
    void *state = NULL;
    status_t st = fmu_get_state(f, &state);
    if (st < STATUS_ERROR) {
        st = status_worst(st, fmu_serialize_state(f, state, bytes, size));
    }
    if (state != NULL) {
        st = status_worst(st, fmu_free_state(f, &state));
    }
    return st;
}

status_t master_restore(fmu_t *f, void **state)
{
    status_t st = *state != NULL ? fmu_set_state(f, *state) : STATUS_ERROR;
    if (*state != NULL) {
        st = status_worst(st, fmu_free_state(f, state));
    }
    return st;
}

/* Copies the file src to dst (through dst.tmp, synced, renamed over dst):
 * dst is whole or absent, never a part. */
static status_t copy_file(const char *src, const char *dst, const log_t *log)
{
    char tmp[4200];
    snprintf(tmp, sizeof tmp, "%s.tmp", dst);
    FILE *in = fopen(src, "rb");
    if (in == NULL) {
        return log_msg(log, STATUS_ERROR, CAT, "cannot read %s: %s", src, strerror(errno));
    }
    FILE *out = fopen(tmp, "wb");
    if (out == NULL) {
        const int e = errno;
        fclose(in);
        return log_msg(log, STATUS_ERROR, CAT, "cannot write %s: %s", tmp, strerror(e));
    }
    enum { CHUNK = 1 << 20 };
    char *buf = malloc(CHUNK);
    int err = buf == NULL ? ENOMEM : 0;
    const char *what = buf == NULL ? "a buffer" : NULL;
    size_t n;
    while (err == 0 && (n = fread(buf, 1, CHUNK, in)) > 0) {
        if (fwrite(buf, 1, n, out) != n) {
            err = errno != 0 ? errno : EIO;
            what = tmp;
        }
    }
    if (err == 0 && ferror(in)) {
        err = errno != 0 ? errno : EIO;
        what = src;
    }
    free(buf);
    fclose(in);
    if (fflush(out) != 0 || fsync(fileno(out)) != 0) {
        err = err != 0 ? err : errno;
        what = what != NULL ? what : tmp;
    }
    if (fclose(out) != 0 && err == 0) {
        err = errno;
        what = tmp;
    }
    if (err == 0 && rename(tmp, dst) != 0) {
        err = errno;
        what = dst;
    }
    if (err != 0) {
        remove(tmp);
        return log_msg(log, STATUS_ERROR, CAT, "copying %s to %s failed (%s: %s); nothing of it was kept", src, dst,
                       what, strerror(err));
    }
    return STATUS_OK;
}

/* a and b are one file (both exist, same inode) */
static int same_inode(const char *a, const char *b)
{
    struct stat sa, sb;
    return stat(a, &sa) == 0 && stat(b, &sb) == 0 && sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}

/* A restart's field file (rank 0): the run continues m->fields if it is the
 * interrupted run's own (restarted with the same -o), or if that one is not
 * known. A restart into another output starts it as a copy of the
 * interrupted run's field file, which lies beside its checkpoint
 * (P_checkpoint.h5: P_fields.h5) and is left as it is, also over a field
 * file of that name already there (another run's: it was continued, its
 * snapshots before the checkpoint kept); without that file the new one
 * starts empty, with a warning. *resume: 1 when m->fields is then there to
 * continue. */
status_t master_restart_fields(master_t *m, const char *checkpoint, int *resume)
{
    *resume = 1;
    static const char suffix[] = "_checkpoint.h5";
    const size_t len = strlen(checkpoint), ls = sizeof suffix - 1;
    char orig[4200] = "";
    if (len > ls && strcmp(checkpoint + len - ls, suffix) == 0) {
        snprintf(orig, sizeof orig, "%.*s_fields.h5", (int)(len - ls), checkpoint);
    }
    const int orig_there = orig[0] != '\0' && access(orig, R_OK) == 0;
    if (access(m->fields, F_OK) == 0 && (!orig_there || same_inode(orig, m->fields))) {
        return STATUS_OK;
    }
    if (orig_there) {
        const status_t st = copy_file(orig, m->fields, &m->log);
        if (st == STATUS_OK && !m->opt->quiet) {
            printf("restart: the field file %s continues a copy of the interrupted run's %s\n", m->fields, orig);
        }
        return st;
    }
    *resume = 0;
    if (orig[0] == '\0') {
        return log_msg(&m->log, STATUS_WARNING, CAT,
                       "%s is not named P_checkpoint.h5, so the interrupted run's field file (P_fields.h5) is not "
                       "known; %s starts anew with the snapshots from the checkpoint on",
                       checkpoint, m->fields);
    }
    return log_msg(&m->log, STATUS_WARNING, CAT,
                   "the interrupted run's field file %s is not there; %s starts anew with the snapshots from the "
                   "checkpoint on",
                   orig, m->fields);
}

/* The worst status of all ranks: every rank takes the same branch after it. */
status_t master_agree(master_t *m, status_t st)
{
    int v = (int)st;
    const status_t mst = mpi_env_max(&v, &m->log);
    return status_worst((status_t)v, mst);
}

/* Rank 0's side of a checkpoint on several ranks (checkpoint_hooks_t): the
 * other ranks' fluid blocks, received one after another into one buffer. */
typedef struct {
    master_t *m;
    output_t *out;
    const size_t *sizes; /* every rank's block, bytes */
    unsigned char *buf;  /* as large as the largest of the other ranks */
} blocks_t;

static status_t receive_block(void *ctx, int rank, const unsigned char **bytes, size_t *size)
{
    blocks_t *b = ctx;
    *bytes = b->buf;
    *size = b->sizes[rank];
    return mpi_env_recv(b->buf, b->sizes[rank], rank, &b->m->log);
}

static status_t copy_rows(void *ctx, const char *tmp_path)
{
    return output_save_rows(((blocks_t *)ctx)->out, tmp_path, "/output");
}

/* Every rank calls it at the same communication step (the steps are due
 * alike and a stop is agreed, run_scene): each serializes its fluid block,
 * rank 0 writes them all with the rest into the one file, and every rank
 * returns the outcome of the whole. */
status_t master_save_checkpoint(master_t *m, output_t *out, const run_point_t *p)
{
    const int rank = mpi_env_rank(), size = mpi_env_size();
    checkpoint_t c;
    memset(&c, 0, sizeof c);
    size_t *sizes = NULL;
    blocks_t b = {m, out, NULL, NULL};
    status_t st = output_flush(out);
    if (st < STATUS_ERROR) {
        st = status_worst(st, serialize(m->fluid, &c.fluid_state, &c.fluid_size));
    }
    /* the rigid state is the same on every rank: rank 0 writes its own */
    if (st < STATUS_ERROR && m->rigid != NULL && rank == 0) {
        st = status_worst(st, serialize(m->rigid, &c.rigid_state, &c.rigid_size));
    }
    if (size > 1) {
        if (rank == 0 && (sizes = calloc((size_t)size, sizeof *sizes)) == NULL) {
            /* the others wait for rank 0 until its MPI_Abort (mpi_env_finish) */
            st = log_msg(&m->log, STATUS_FATAL, CAT, "out of memory for the block sizes of %d ranks", size);
            goto cleanup;
        }
        st = status_worst(st, mpi_env_gather_size(c.fluid_size, sizes, &m->log));
        size_t largest = 0;
        for (int k = 1; rank == 0 && k < size; k++) {
            largest = sizes[k] > largest ? sizes[k] : largest;
        }
        if (rank == 0 && st < STATUS_ERROR && (b.buf = malloc(largest > 0 ? largest : 1)) == NULL) {
            st = log_msg(&m->log, STATUS_FATAL, CAT, "out of memory for a fluid block of another rank (%zu bytes)",
                         largest);
        }
        b.sizes = sizes;
        /* all ranks send and receive, or none */
        st = master_agree(m, st);
    }
    if (st < STATUS_ERROR && rank > 0) {
        st = status_worst(st, mpi_env_send(c.fluid_state, c.fluid_size, 0, &m->log));
    } else if (st < STATUS_ERROR) {
        c.step = p->n;
        c.nsteps = p->nsteps;
        c.rows = output_rows(out);
        c.next_out = p->next_out;
        c.exchange_every = p->k_lbm;
        c.end_row = p->end_row;
        c.h = p->h;
        c.ranks = m->ranks;
        c.settle_t = m->settle_t;
        c.settle_v = m->settle_v;
        c.nsettle = m->nsettle;
        c.wall[0] = p->wall_before[0] + fmu_step_seconds(m->fluid);
        c.wall[1] = p->wall_before[1] + (m->rigid != NULL ? fmu_step_seconds(m->rigid) : 0.0);
        c.wall[2] = p->wall_before[2] + omp_get_wtime() - p->wall0;
        const checkpoint_hooks_t hooks = {receive_block, copy_rows, &b};
        st = status_worst(st, checkpoint_write(m->cp_path, m->scene, &m->origin, &c, &hooks, &m->log));
    }
    if (size > 1) {
        st = master_agree(m, st); /* every rank knows whether the checkpoint is there */
    }
cleanup:
    free(b.buf);
    free(sizes);
    free(c.fluid_state);
    free(c.rigid_state);
    return st;
}

status_t master_checkpoint_record(master_t *m, replay_t *c, long n)
{
    const int width = m->nrow + m->ns + m->nc;
    const long k = n - c->n1;
    double *r;
    if (!c->replay) {
        if (k >= c->cap) {
            c->cap = c->cap > 0 ? 2 * c->cap : 256;
            double *p = realloc(c->rows, sizeof(double) * (size_t)width * (size_t)c->cap);
            if (p == NULL) {
                return log_msg(&m->log, STATUS_FATAL, CAT, "out of memory for %ld recorded rows (%zu bytes)", c->cap, sizeof(double) * (size_t)width * (size_t)c->cap);
            }
            c->rows = p;
        }
        c->nrows = k + 1;
    }
    r = c->replay ? malloc(sizeof(double) * (size_t)width) : c->rows + (size_t)k * (size_t)width;
    if (r == NULL) {
        return log_msg(&m->log, STATUS_FATAL, CAT, "out of memory for a recorded row (%zu bytes)", sizeof(double) * (size_t)width);
    }
    memcpy(r, m->row, sizeof(double) * (size_t)m->nrow);
    for (int i = 0; i < m->ns; i++) {
        r[m->nrow + i] = m->ibody[i]; /* (the body count is a function of these) */
    }
    for (int i = 0; i < m->nc; i++) {
        r[m->nrow + m->ns + i] = m->iintact[i];
    }
    if (c->replay) {
        if (k >= c->nrows || memcmp(r, c->rows + (size_t)k * (size_t)width, sizeof(double) * (size_t)width) != 0) {
            c->mismatches++;
        }
        free(r);
    }
    return STATUS_OK;
}
