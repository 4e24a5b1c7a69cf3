/* checkpoint.c — writing and reading the restart file (checkpoint.h).
 *
 * Layout (HDF5):
 *   root attributes  format ("agglo checkpoint"), format_version, scene (the
 *                    scene text), origin_coupler, origin_fluid, origin_rigid,
 *                    step, nsteps, rows, next_out, exchange_every, end_row (int64;
 *                    end_row 1: the last row is the run's end row, off the
 *                    output grid; absent in older checkpoints: 0),
 *                    h (s), wall [3] (s), ranks (int64), decomposition
 *                    [3] (int64: blocks along x, y, z)
 *   /fluid_state/K   uint8 [size]   fmi2SerializeFMUstate of the fluid FMU of
 *                                   rank K = 0 .. ranks - 1 (its block); this,
 *                                   the rigid state and /settle in chunks with
 *                                   HDF5's Fletcher-32 checksum
 *   /rigid_state     uint8 [size]   the same of the rigid FMU (when there is one)
 *   /settle/{time,velocity}  double [n]  settling-summary history (when kept)
 *   /output/...      the output file's time series as far as written (the
 *                    master copies them in through the fill callback)
 * Every HDF5, stdio and POSIX call is checked; a failure names the file and
 * the object, and leaves the previous checkpoint in place. */
#define _XOPEN_SOURCE 700
#include "checkpoint.h"

#include "resources.h"

#include "../common/h5_cause.h"

#include <errno.h>
#include <fcntl.h>
#include <hdf5.h>
#include <inttypes.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define CAT "checkpoint"
#define FORMAT "agglo checkpoint"
#define FORMAT_VERSION 2 /* 2: ranks, decomposition, /fluid_state/K */

void checkpoint_path(const char *output, char *buf, size_t n)
{
    snprintf(buf, n, "%s", output);
    char *dot = strrchr(buf, '.'), *slash = strrchr(buf, '/');
    if (dot != NULL && (slash == NULL || dot > slash)) { /* any extension, as the field file OUT_fields.h5 */
        *dot = '\0';
    }
    strncat(buf, "_checkpoint.h5", n - strlen(buf) - 1);
}

status_t checkpoint_file_hash(const char *path, const log_t *log, char out[17])
{
    FILE *fp = fopen(path, "rb");
    if (fp == NULL) {
        return log_msg(log, STATUS_ERROR, CAT, "cannot read %s to identify the build: %s", path, strerror(errno));
    }
    uint64_t h = 1469598103934665603ull; /* FNV-1a, 64 bit */
    unsigned char buf[1 << 16];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, fp)) > 0) {
        for (size_t i = 0; i < n; i++) {
            h = (h ^ buf[i]) * 1099511628211ull;
        }
    }
    const int bad = ferror(fp);
    fclose(fp);
    if (bad) {
        return log_msg(log, STATUS_ERROR, CAT, "error while reading %s to identify the build", path);
    }
    snprintf(out, 17, "%016" PRIx64, h);
    return STATUS_OK;
}

/* ------------------------------------------------------------------------ */
/* HDF5 helpers: each returns 0 on failure                                   */

/* Why the last put_* failed (h5_cause), taken before its closes clear
 * HDF5's error stack; checkpoint_write's message names it. One writer at a
 * time: the checkpoint is written by the master's thread. */
static char put_cause[160];

static int put_failed(void)
{
    h5_cause(0, put_cause, sizeof put_cause);
    return 0;
}

static int put_string(hid_t obj, const char *name, const char *value)
{
    hid_t type = H5Tcopy(H5T_C_S1), space = H5Screate(H5S_SCALAR), a = -1;
    int ok = type >= 0 && space >= 0 && H5Tset_size(type, strlen(value) + 1) >= 0 &&
             (a = H5Acreate2(obj, name, type, space, H5P_DEFAULT, H5P_DEFAULT)) >= 0 && H5Awrite(a, type, value) >= 0;
    ok = ok || put_failed();
    ok = (a < 0 || H5Aclose(a) >= 0 || put_failed()) && ok;
    if (space >= 0) {
        H5Sclose(space);
    }
    if (type >= 0) {
        H5Tclose(type);
    }
    return ok;
}

static char *get_string(hid_t obj, const char *name)
{
    char *text = NULL;
    hid_t a = H5Aexists(obj, name) > 0 ? H5Aopen(obj, name, H5P_DEFAULT) : -1;
    hid_t t = a >= 0 ? H5Aget_type(a) : -1;
    const size_t n = t >= 0 ? H5Tget_size(t) : 0;
    if (n > 0 && (text = calloc(n + 1, 1)) != NULL && H5Aread(a, t, text) < 0) {
        free(text);
        text = NULL;
    }
    if (t >= 0) {
        H5Tclose(t);
    }
    if (a >= 0) {
        H5Aclose(a);
    }
    return text;
}

static int put_numbers(hid_t obj, const char *name, hid_t type, const void *v, hsize_t n)
{
    hid_t space = n == 1 ? H5Screate(H5S_SCALAR) : H5Screate_simple(1, &n, NULL), a = -1;
    int ok = space >= 0 && (a = H5Acreate2(obj, name, type, space, H5P_DEFAULT, H5P_DEFAULT)) >= 0 &&
             H5Awrite(a, type, v) >= 0;
    ok = ok || put_failed();
    ok = (a < 0 || H5Aclose(a) >= 0 || put_failed()) && ok;
    if (space >= 0) {
        H5Sclose(space);
    }
    return ok;
}

static int get_numbers(hid_t obj, const char *name, hid_t type, void *v, hsize_t n)
{
    hid_t a = H5Aexists(obj, name) > 0 ? H5Aopen(obj, name, H5P_DEFAULT) : -1;
    hid_t space = a >= 0 ? H5Aget_space(a) : -1;
    const hssize_t count = space >= 0 ? H5Sget_simple_extent_npoints(space) : -1;
    const int ok = count == (hssize_t)n && H5Aread(a, type, v) >= 0;
    if (space >= 0) {
        H5Sclose(space);
    }
    if (a >= 0) {
        H5Aclose(a);
    }
    return ok;
}

static int put_long(hid_t obj, const char *name, long v)
{
    const int64_t x = v;
    return put_numbers(obj, name, H5T_NATIVE_INT64, &x, 1);
}

static int get_long(hid_t obj, const char *name, long *v)
{
    int64_t x = 0;
    const int ok = get_numbers(obj, name, H5T_NATIVE_INT64, &x, 1);
    *v = (long)x;
    return ok;
}

#define ARRAY_CHUNK ((hsize_t)CHECKPOINT_CHUNK)

/* A 1-D dataset of n values, in chunks that HDF5 checksums (Fletcher-32
 * filter): a read of a damaged chunk fails (get_array) instead of handing
 * a restart the changed bytes (a byte flipped in a fluid state's
 * populations was restored silently: the state's own header checks only
 * its header). */
static int put_array(hid_t file, const char *name, hid_t type, const void *v, hsize_t n)
{
    hid_t space = H5Screate_simple(1, &n, NULL), lcpl = H5Pcreate(H5P_LINK_CREATE), d = -1;
    hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    const hsize_t chunk = n < ARRAY_CHUNK ? n : ARRAY_CHUNK;
    int ok = space >= 0 && lcpl >= 0 && dcpl >= 0 && H5Pset_create_intermediate_group(lcpl, 1) >= 0 &&
             (n == 0 || (H5Pset_chunk(dcpl, 1, &chunk) >= 0 && H5Pset_fletcher32(dcpl) >= 0)) &&
             (d = H5Dcreate2(file, name, type, space, lcpl, dcpl, H5P_DEFAULT)) >= 0 &&
             (n == 0 || H5Dwrite(d, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, v) >= 0);
    ok = ok || put_failed();
    ok = (d < 0 || H5Dclose(d) >= 0 || put_failed()) && ok;
    if (dcpl >= 0) {
        H5Pclose(dcpl);
    }
    if (lcpl >= 0) {
        H5Pclose(lcpl);
    }
    if (space >= 0) {
        H5Sclose(space);
    }
    return ok;
}

/* Why the last get_array failed (h5_cause): a damaged chunk's checksum. */
static char get_cause[160];

/* Reads a 1-D dataset of elem-byte values into a malloc'ed array (*n values);
 * a chunk whose checksum does not match fails the read (put_array). */
static int get_array(hid_t file, const char *name, hid_t type, size_t elem, void **v, size_t *n)
{
    get_cause[0] = '\0';
    *v = NULL;
    *n = 0;
    hid_t d = H5Lexists(file, name, H5P_DEFAULT) > 0 ? H5Dopen2(file, name, H5P_DEFAULT) : -1;
    hid_t space = d >= 0 ? H5Dget_space(d) : -1;
    const hssize_t count = space >= 0 ? H5Sget_simple_extent_npoints(space) : -1;
    int ok = count >= 0;
    if (ok) {
        *v = malloc(count > 0 ? (size_t)count * elem : 1);
        ok = *v != NULL && (count == 0 || H5Dread(d, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, *v) >= 0);
        if (!ok && *v != NULL) {
            h5_cause(0, get_cause, sizeof get_cause);
        }
        *n = ok ? (size_t)count : 0;
        if (!ok) {
            free(*v);
            *v = NULL;
        }
    }
    if (space >= 0) {
        H5Sclose(space);
    }
    if (d >= 0) {
        H5Dclose(d);
    }
    return ok;
}

/* What a failed get_array's message adds: the cause, when HDF5 gave one. */
static const char *damaged(void)
{
    static char text[sizeof get_cause + 160];
    if (get_cause[0] == '\0') {
        return "";
    }
    snprintf(text, sizeof text, " (%s: the file was damaged or changed after it was written)", get_cause);
    return text;
}

/* ------------------------------------------------------------------------ */
/* Writing                                                                   */

static status_t sync_path(const char *path, int directory, const log_t *log)
{
    int fd = open(path, directory ? O_RDONLY | O_DIRECTORY : O_RDONLY);
    if (fd < 0 || fsync(fd) != 0) {
        const int e = errno;
        if (fd >= 0) {
            close(fd);
        }
        return log_msg(log, STATUS_ERROR, CAT, "cannot sync %s to disk: %s", path, strerror(e));
    }
    close(fd);
    return STATUS_OK;
}

/* The end of a failed write's message: which checkpoint a restart can take. */
static const char *kept(const char *path, char *buf, size_t n)
{
    if (access(path, F_OK) == 0) {
        snprintf(buf, n, "the previous checkpoint %s is kept", path);
    } else {
        snprintf(buf, n, "no checkpoint was written before");
    }
    return buf;
}

status_t checkpoint_write(const char *path, const scene_t *scene, const checkpoint_origin_t *origin,
                          const checkpoint_t *c, const checkpoint_hooks_t *hooks, const log_t *log)
{
    char tmp[4200], dir[4200], block[64], note[4300];
    status_t st = STATUS_OK;
    hid_t f = -1;
    H5Eset_auto2(H5E_DEFAULT, NULL, NULL); /* errors are reported by us */
    put_cause[0] = '\0';
    if (snprintf(tmp, sizeof tmp, "%s.tmp", path) >= (int)sizeof tmp) {
        st = log_msg(log, STATUS_ERROR, CAT, "%s: path too long", path);
    } else if ((f = H5Fcreate(tmp, H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT)) < 0) {
        char cause[160];
        h5_cause(0, cause, sizeof cause);
        st = log_msg(log, STATUS_ERROR, CAT, "%s: cannot create the checkpoint file: %s; %s", tmp,
                     cause[0] != '\0' ? cause : "is the folder writable?", kept(path, note, sizeof note));
        remove(tmp); /* a full disk leaves it empty behind */
    }
    const int64_t dims[3] = {c->ranks.dims[0], c->ranks.dims[1], c->ranks.dims[2]};
    const char *what = NULL;
    if (st != STATUS_OK) {
        /* the blocks of the other ranks are still taken below */
    } else if (!put_string(f, "format", FORMAT) || !put_long(f, "format_version", FORMAT_VERSION)) {
        what = "the format attributes";
    } else if (!put_string(f, "scene", scene->text != NULL ? scene->text : "") ||
               !put_string(f, "scene_file", scene->path != NULL ? scene->path : "")) {
        what = "the scene text";
    } else if (!put_string(f, "origin_coupler", origin->coupler) || !put_string(f, "origin_fluid", origin->fluid) ||
               !put_string(f, "origin_rigid", origin->rigid)) {
        what = "the origin attributes";
    } else if (!put_long(f, "step", c->step) || !put_long(f, "nsteps", c->nsteps) || !put_long(f, "rows", c->rows) ||
               !put_long(f, "next_out", c->next_out) || !put_long(f, "exchange_every", c->exchange_every) ||
               !put_long(f, "end_row", c->end_row) ||
               !put_numbers(f, "h", H5T_NATIVE_DOUBLE, &c->h, 1) ||
               !put_numbers(f, "wall", H5T_NATIVE_DOUBLE, c->wall, 3) || !put_long(f, "ranks", c->ranks.ranks) ||
               !put_numbers(f, "decomposition", H5T_NATIVE_INT64, dims, 3)) {
        what = "the master's counters";
    } else if (!put_array(f, "/fluid_state/0", H5T_NATIVE_UCHAR, c->fluid_state, c->fluid_size)) {
        what = "/fluid_state/0";
    }
    /* every other rank's block is taken, even after an error: the ranks wait to send it */
    for (int k = 1; k < c->ranks.ranks; k++) {
        const unsigned char *bytes = NULL;
        size_t size = 0;
        const status_t bst = hooks->block(hooks->ctx, k, &bytes, &size);
        if (st != STATUS_OK || what != NULL) {
            continue;
        }
        snprintf(block, sizeof block, "/fluid_state/%d", k);
        if (bst >= STATUS_ERROR) {
            st = bst;
        } else if (!put_array(f, block, H5T_NATIVE_UCHAR, bytes, size)) {
            what = block;
        }
    }
    if (st != STATUS_OK || what != NULL) {
        /* reported */
    } else if (c->rigid_state != NULL &&
               !put_array(f, "/rigid_state", H5T_NATIVE_UCHAR, c->rigid_state, c->rigid_size)) {
        what = "/rigid_state";
    } else if (c->settle_t != NULL &&
               (!put_array(f, "/settle/time", H5T_NATIVE_DOUBLE, c->settle_t, (hsize_t)c->nsettle) ||
                !put_array(f, "/settle/velocity", H5T_NATIVE_DOUBLE, c->settle_v, (hsize_t)c->nsettle))) {
        what = "/settle";
    }
    if (f >= 0 && H5Fclose(f) < 0 && st == STATUS_OK && what == NULL) {
        what = "the file (closing)";
        put_failed();
    }
    if (what != NULL) {
        st = log_msg(log, STATUS_ERROR, CAT, "%s: HDF5 error while writing %s%s%s; %s", tmp, what,
                     put_cause[0] != '\0' ? ": " : "", put_cause, kept(path, note, sizeof note));
    }
    if (st == STATUS_OK && hooks->fill != NULL && hooks->fill(hooks->ctx, tmp) != STATUS_OK) {
        st = log_msg(log, STATUS_ERROR, CAT, "%s could not be completed (see above); %s", tmp,
                     kept(path, note, sizeof note));
    }
    if (st == STATUS_OK) {
        st = sync_path(tmp, 0, log);
    }
    if (st == STATUS_OK && rename(tmp, path) != 0) {
        st = log_msg(log, STATUS_ERROR, CAT, "cannot rename %s to %s: %s", tmp, path, strerror(errno));
    }
    if (st != STATUS_OK) {
        if (f >= 0) {
            remove(tmp);
        }
        return st;
    }
    resources_folder(path, dir, sizeof dir);
    return sync_path(dir, 1, log);
}

/* ------------------------------------------------------------------------ */
/* Reading                                                                   */

/* The first line where two texts differ, for the message. */
static void first_difference(const char *a, const char *b, char *buf, size_t n)
{
    int line = 1;
    const char *la = a, *lb = b;
    while (*a != '\0' && *a == *b) {
        if (*a == '\n') {
            line++;
            la = a + 1;
            lb = b + 1;
        }
        a++;
        b++;
    }
    const int na = (int)strcspn(la, "\n"), nb = (int)strcspn(lb, "\n");
    snprintf(buf, n, "line %d: '%.*s' in the checkpoint, '%.*s' now", line, na > 80 ? 80 : na, la,
             nb > 80 ? 80 : nb, lb);
}

static status_t same_origin(const char *path, hid_t f, const char *name, const char *what, const char *now,
                            const log_t *log)
{
    char *then = get_string(f, name);
    status_t st = STATUS_OK;
    if (then == NULL || strcmp(then, now) != 0) {
        st = log_msg(log, STATUS_ERROR, CAT,
                     "%s was written by %s %s; this run has %s %s: restart with the build and FMUs that wrote it", path,
                     what, then != NULL && then[0] != '\0' ? then : "(none)", what, now[0] != '\0' ? now : "(none)");
    }
    free(then);
    return st;
}

void checkpoint_free(checkpoint_t *c)
{
    free(c->fluid_state);
    free(c->rigid_state);
    free(c->settle_t);
    free(c->settle_v);
    memset(c, 0, sizeof *c);
}

/* The ranks and blocks that wrote the checkpoint must be this run's: each
 * rank restores the block of its own number. */
static status_t same_ranks(const char *path, hid_t f, const checkpoint_ranks_t *now, checkpoint_ranks_t *then,
                           const log_t *log)
{
    long ranks = 0;
    int64_t dims[3] = {0, 0, 0};
    if (!get_long(f, "ranks", &ranks) || !get_numbers(f, "decomposition", H5T_NATIVE_INT64, dims, 3) || ranks < 1 ||
        dims[0] < 1 || dims[1] < 1 || dims[2] < 1 || dims[0] * dims[1] * dims[2] != ranks) {
        return log_msg(log, STATUS_ERROR, CAT, "%s: the ranks and their decomposition are missing or out of range",
                       path);
    }
    then->ranks = (int)ranks;
    for (int a = 0; a < 3; a++) {
        then->dims[a] = (int)dims[a];
    }
    char written[128], advice[128];
    snprintf(written, sizeof written, "%d rank%s as [%d, %d, %d]", then->ranks, then->ranks > 1 ? "s" : "",
             then->dims[0], then->dims[1], then->dims[2]);
    if (then->ranks != now->ranks) {
        if (then->ranks == 1) {
            snprintf(advice, sizeof advice, "restart on one rank (without mpirun)");
        } else {
            snprintf(advice, sizeof advice, "restart with mpirun -np %d", then->ranks);
        }
        return log_msg(log, STATUS_ERROR, CAT, "%s was written by %s; this run has %d rank%s: %s", path, written,
                       now->ranks, now->ranks > 1 ? "s" : "", advice);
    }
    if (then->dims[0] != now->dims[0] || then->dims[1] != now->dims[1] || then->dims[2] != now->dims[2]) {
        return log_msg(log, STATUS_ERROR, CAT,
                       "%s was written by %s; this run has %d ranks as [%d, %d, %d]: the blocks would not match; "
                       "restart with the run.ranks of the interrupted run",
                       path, written, now->ranks, now->dims[0], now->dims[1], now->dims[2]);
    }
    return STATUS_OK;
}

status_t checkpoint_read(const char *path, const scene_t *scene, const checkpoint_origin_t *origin,
                         const checkpoint_ranks_t *ranks, int rank, checkpoint_t *c, const log_t *log)
{
    memset(c, 0, sizeof *c);
    H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
    hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f < 0) {
        return log_msg(log, STATUS_ERROR, CAT, "%s: cannot open the checkpoint (is it there, an HDF5 file, readable?)",
                       path);
    }
    status_t st = STATUS_OK;
    char *format = get_string(f, "format"), *text = NULL;
    long version = 0;
    if (format == NULL || strcmp(format, FORMAT) != 0 || !get_long(f, "format_version", &version)) {
        st = log_msg(log, STATUS_ERROR, CAT, "%s is not a checkpoint of `coupler run` (no format attribute '%s')", path,
                     FORMAT);
        goto done;
    }
    if (version != FORMAT_VERSION) {
        st = log_msg(log, STATUS_ERROR, CAT, "%s: checkpoint format version %ld; allowed: %d (this build)", path,
                     version, FORMAT_VERSION);
        goto done;
    }
    if ((st = same_ranks(path, f, ranks, &c->ranks, log)) != STATUS_OK) {
        goto done;
    }
    text = get_string(f, "scene");
    const char *now = scene->text != NULL ? scene->text : "";
    if (text == NULL || strcmp(text, now) != 0) {
        char diff[256] = "no scene text in it";
        if (text != NULL) {
            first_difference(text, now, diff, sizeof diff);
        }
        st = log_msg(log, STATUS_ERROR, CAT,
                     "%s belongs to another scene than %s with these --set options (%s): restart with the scene and "
                     "--set options of the interrupted run",
                     path, scene->path, diff);
        goto done;
    }
    if ((st = same_origin(path, f, "origin_coupler", "coupler", origin->coupler, log)) != STATUS_OK ||
        (st = same_origin(path, f, "origin_fluid", "fluid FMU", origin->fluid, log)) != STATUS_OK ||
        (st = same_origin(path, f, "origin_rigid", "rigid FMU", origin->rigid, log)) != STATUS_OK) {
        goto done;
    }
    long every = 0;
    void *settle_t = NULL, *settle_v = NULL, *fs = NULL, *rs = NULL;
    size_t nt = 0, nv = 0;
    const int counters = get_long(f, "step", &c->step) && get_long(f, "nsteps", &c->nsteps) &&
                         get_long(f, "rows", &c->rows) && get_long(f, "next_out", &c->next_out) &&
                         get_long(f, "exchange_every", &every) && get_numbers(f, "h", H5T_NATIVE_DOUBLE, &c->h, 1) &&
                         get_numbers(f, "wall", H5T_NATIVE_DOUBLE, c->wall, 3);
    c->exchange_every = (int)every;
    if (!counters || c->step < 0 || c->rows < 0 || c->next_out < 0 || every < 1) {
        st = log_msg(log, STATUS_ERROR, CAT, "%s: the master's counters are missing or out of range", path);
        goto done;
    }
    /* whether the row of this very step was written: a checkpoint is taken
     * after the step's row, when one was due */
    void *times = NULL;
    size_t ntimes = 0;
    if (c->rows > 0 && get_array(f, "/output/time", H5T_NATIVE_DOUBLE, sizeof(double), &times, &ntimes) &&
        ntimes >= (size_t)c->rows) {
        const double t_last = ((const double *)times)[c->rows - 1];
        c->row_at_step = fabs(t_last - (double)c->step * c->h) < 0.5 * c->h;
    }
    free(times);
    long end_row = 0;
    if (H5Aexists(f, "end_row") > 0 && !get_long(f, "end_row", &end_row)) {
        st = log_msg(log, STATUS_ERROR, CAT, "%s: the attribute end_row is unreadable", path);
        goto done;
    }
    c->end_row = c->row_at_step && end_row == 1;
    char block[64];
    snprintf(block, sizeof block, "/fluid_state/%d", rank);
    if (!get_array(f, block, H5T_NATIVE_UCHAR, 1, &fs, &c->fluid_size)) {
        st = log_msg(log, STATUS_ERROR, CAT, "%s: %s is missing or unreadable%s", path, block, damaged());
        goto done;
    }
    c->fluid_state = fs;
    if (origin->rigid[0] != '\0') {
        if (!get_array(f, "/rigid_state", H5T_NATIVE_UCHAR, 1, &rs, &c->rigid_size)) {
            st = log_msg(log, STATUS_ERROR, CAT, "%s: /rigid_state is missing or unreadable%s", path, damaged());
            goto done;
        }
        c->rigid_state = rs;
    }
    if (H5Lexists(f, "/settle", H5P_DEFAULT) > 0) {
        if (!get_array(f, "/settle/time", H5T_NATIVE_DOUBLE, sizeof(double), &settle_t, &nt) ||
            !get_array(f, "/settle/velocity", H5T_NATIVE_DOUBLE, sizeof(double), &settle_v, &nv) || nt != nv) {
            free(settle_t);
            free(settle_v);
            st = log_msg(log, STATUS_ERROR, CAT, "%s: /settle is unreadable%s", path, damaged());
            goto done;
        }
        c->settle_t = settle_t;
        c->settle_v = settle_v;
        c->nsettle = (long)nt;
    }
done:
    free(format);
    free(text);
    if (H5Fclose(f) < 0 && st == STATUS_OK) {
        st = log_msg(log, STATUS_ERROR, CAT, "%s: HDF5 error while closing the checkpoint", path);
    }
    if (st != STATUS_OK) {
        checkpoint_free(c);
    }
    return st;
}
