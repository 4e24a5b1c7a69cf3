/* output.c — HDF5 writer of the result file (output.h). Every HDF5 call is
 * checked; a failure is reported with the file and the object. */
#include "output.h"

#include "version.h"

#include "../common/h5_cause.h"

#include <hdf5.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* Rows are kept in memory and written together, OUTPUT_BUFFER_ROWS at a
 * time or after OUTPUT_FLUSH_SECONDS of wall time, whichever comes first
 * (and at every checkpoint and at the end): a row costs a memcpy, not an
 * HDF5 write and a flush, and a killed run loses at most the rows of the
 * last second. */
enum { OUTPUT_BUFFER_ROWS = 256 };
/* HDF5's own bytes for the file (superblock, groups, root attributes less
 * the scene text) and for each dataset (object header, chunk index, unit),
 * from files written (output_file_bytes) */
enum { OUTPUT_FILE_BYTES = 4096, OUTPUT_DATASET_BYTES = 3328 };
static const double OUTPUT_FLUSH_SECONDS = 1.0;

typedef struct {
    hid_t id, type;
    int rank;        /* 1: [n], 2: [n, a], 3: [n, a, b] */
    hsize_t dims[3]; /* dims[0] = rows written */
    size_t row_bytes;
    unsigned char *buf; /* OUTPUT_BUFFER_ROWS rows not yet written */
} series_t;

enum {
    S_TIME,
    S_POSITION,
    S_VELOCITY,
    S_OMEGA,
    S_FORCE,
    S_TORQUE,
    S_BODY,
    S_CONN_FORCE,
    S_CONN_TORQUE,
    S_CONN_INTACT,
    S_MASS,
    S_MOMENTUM,
    S_ENERGY,
    S_NBODIES,
    S_BODY_MOMENTUM,
    S_BODY_ANGMOM,
    NSERIES
};

struct output {
    int off; /* a rank other than 0 under MPI: writes nothing (output_open with path NULL) */
    char *path;
    log_t log;
    hid_t file;
    series_t s[NSERIES];
    int ns, nc, bodies;
    hsize_t rows;    /* rows in the file */
    hsize_t pending; /* rows in the buffers */
    double last_write; /* monotonic clock, s */
};

static double now_seconds(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* A failed HDF5 call, logged with its cause (a full disk names itself) */
static status_t fail(const output_t *o, const char *what)
{
    char cause[160];
    h5_cause(0, cause, sizeof cause);
    return log_msg(&o->log, STATUS_ERROR, "output", "%s: HDF5 error while writing %s%s%s", o->path, what,
                   cause[0] != '\0' ? ": " : "", cause);
}

static status_t attr_string(output_t *o, hid_t obj, const char *name, const char *value)
{
    hid_t type = H5Tcopy(H5T_C_S1);
    hid_t space = H5Screate(H5S_SCALAR);
    status_t st = STATUS_OK;
    if (type < 0 || space < 0 || H5Tset_size(type, strlen(value) + 1) < 0 ||
        (H5Aexists(obj, name) > 0 && H5Adelete(obj, name) < 0)) {
        st = fail(o, name);
    } else {
        hid_t a = H5Acreate2(obj, name, type, space, H5P_DEFAULT, H5P_DEFAULT);
        if (a < 0 || H5Awrite(a, type, value) < 0) {
            st = fail(o, name);
        }
        if (a >= 0 && H5Aclose(a) < 0) {
            st = fail(o, name);
        }
    }
    if (space >= 0) {
        H5Sclose(space);
    }
    if (type >= 0) {
        H5Tclose(type);
    }
    return st;
}

static status_t attr_doubles(output_t *o, hid_t obj, const char *name, const double *v, hsize_t n)
{
    hid_t space = n == 1 ? H5Screate(H5S_SCALAR) : H5Screate_simple(1, &n, NULL);
    status_t st = STATUS_OK;
    if (space < 0 || (H5Aexists(obj, name) > 0 && H5Adelete(obj, name) < 0)) {
        if (space >= 0) {
            H5Sclose(space);
        }
        return fail(o, name);
    }
    hid_t a = H5Acreate2(obj, name, H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, H5P_DEFAULT);
    if (a < 0 || H5Awrite(a, H5T_NATIVE_DOUBLE, v) < 0) {
        st = fail(o, name);
    }
    if (a >= 0 && H5Aclose(a) < 0) {
        st = fail(o, name);
    }
    H5Sclose(space);
    return st;
}

/* Rows of a chunk of a series whose rows hold per_row values: 4096 values
 * at least, or one row. */
static hsize_t chunk_rows(hsize_t per_row) { return per_row >= 4096 ? 1 : 4096 / per_row; }

/* An extendible dataset of rows of a x b values (a = 0: scalars; b = 0: vectors). */
static status_t series_create(output_t *o, series_t *s, const char *name, hid_t type, hsize_t a, hsize_t b,
                              const char *unit)
{
    s->rank = a == 0 ? 1 : b == 0 ? 2 : 3;
    s->type = type;
    s->dims[0] = 0;
    s->dims[1] = a;
    s->dims[2] = b;
    const hsize_t per_row = (a > 0 ? a : 1) * (b > 0 ? b : 1);
    s->row_bytes = (size_t)per_row * H5Tget_size(type);
    s->buf = malloc(OUTPUT_BUFFER_ROWS * s->row_bytes);
    if (s->buf == NULL) {
        s->id = -1;
        return log_msg(&o->log, STATUS_FATAL, "output", "out of memory for the row buffer of %s (%zu bytes)", name,
                       OUTPUT_BUFFER_ROWS * s->row_bytes);
    }
    hsize_t maxd[3] = {H5S_UNLIMITED, a, b}, chunk[3] = {chunk_rows(per_row), a, b};
    hid_t space = H5Screate_simple(s->rank, s->dims, maxd);
    hid_t plist = H5Pcreate(H5P_DATASET_CREATE);
    hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
    status_t st = STATUS_OK;
    s->id = -1;
    if (space < 0 || plist < 0 || lcpl < 0 || H5Pset_chunk(plist, s->rank, chunk) < 0 ||
        H5Pset_create_intermediate_group(lcpl, 1) < 0) {
        st = fail(o, name);
    } else {
        s->id = H5Dcreate2(o->file, name, type, space, lcpl, plist, H5P_DEFAULT);
        if (s->id < 0 || attr_string(o, s->id, "unit", unit) != STATUS_OK) {
            st = fail(o, name);
        }
    }
    if (lcpl >= 0) {
        H5Pclose(lcpl);
    }
    if (plist >= 0) {
        H5Pclose(plist);
    }
    if (space >= 0) {
        H5Sclose(space);
    }
    return st;
}

static void series_append(output_t *o, series_t *s, const void *v)
{
    if (s->id >= 0) { /* else not part of this scene's layout */
        memcpy(s->buf + o->pending * s->row_bytes, v, s->row_bytes);
    }
}

/* Writes rows [first, first + n) of a series from buf, extending it to them. */
static status_t series_put(output_t *o, series_t *s, hsize_t first, hsize_t n, const void *buf)
{
    hsize_t dims[3] = {first + n, s->dims[1], s->dims[2]}, start[3] = {first, 0, 0};
    hsize_t count[3] = {n, s->dims[1], s->dims[2]};
    status_t st = STATUS_OK;
    if (H5Dset_extent(s->id, dims) < 0) {
        return fail(o, "a time series (extending)");
    }
    hid_t fs = H5Dget_space(s->id);
    hid_t ms = H5Screate_simple(s->rank, count, NULL);
    if (fs < 0 || ms < 0 || H5Sselect_hyperslab(fs, H5S_SELECT_SET, start, NULL, count, NULL) < 0 ||
        H5Dwrite(s->id, s->type, ms, fs, H5P_DEFAULT, buf) < 0) {
        st = fail(o, "a time series row");
    }
    if (ms >= 0) {
        H5Sclose(ms);
    }
    if (fs >= 0) {
        H5Sclose(fs);
    }
    return st;
}

/* Writes the buffered rows of one series after the o->rows in the file. */
static status_t series_write(output_t *o, series_t *s)
{
    return s->id < 0 ? STATUS_OK : series_put(o, s, o->rows, o->pending, s->buf);
}

/* Writes every buffered row and flushes the file. */
static status_t write_pending(output_t *o)
{
    status_t st = STATUS_OK;
    if (o->pending > 0) {
        for (int k = 0; k < NSERIES; k++) {
            st = status_worst(st, series_write(o, &o->s[k]));
        }
        o->rows += o->pending;
        o->pending = 0;
    }
    if (H5Fflush(o->file, H5F_SCOPE_GLOBAL) < 0) {
        st = status_worst(st, fail(o, "the file (flushing)"));
    }
    o->last_write = now_seconds();
    return st;
}

static status_t write_pairs(output_t *o, const int *pairs, int nc)
{
    hsize_t dims[2] = {(hsize_t)nc, 2};
    hid_t space = H5Screate_simple(2, dims, NULL);
    hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
    status_t st = STATUS_OK;
    if (space < 0 || lcpl < 0 || H5Pset_create_intermediate_group(lcpl, 1) < 0) {
        if (space >= 0) {
            H5Sclose(space);
        }
        if (lcpl >= 0) {
            H5Pclose(lcpl);
        }
        return fail(o, "/connections/pair");
    }
    hid_t d = H5Dcreate2(o->file, "/connections/pair", H5T_NATIVE_INT, space, lcpl, H5P_DEFAULT, H5P_DEFAULT);
    H5Pclose(lcpl);
    if (d < 0 || H5Dwrite(d, H5T_NATIVE_INT, H5S_ALL, H5S_ALL, H5P_DEFAULT, pairs) < 0 ||
        attr_string(o, d, "unit", "sphere index") != STATUS_OK) {
        st = fail(o, "/connections/pair");
    }
    if (d >= 0 && H5Dclose(d) < 0) {
        st = fail(o, "/connections/pair");
    }
    H5Sclose(space);
    return st;
}

/* The time series of the layout: which group needs it and the row shape. */
enum { G_ALL, G_SPHERES, G_CONNECTIONS, G_BODIES };
enum { D_NONE, D_3, D_NS, D_NC };
static const struct {
    const char *name, *unit;
    int group, is_int, a, b;
} SERIES[NSERIES] = {
    [S_TIME] = {"/time", "s", G_ALL, 0, D_NONE, D_NONE},
    [S_MASS] = {"/fluid/mass", "kg", G_ALL, 0, D_NONE, D_NONE},
    [S_MOMENTUM] = {"/fluid/momentum", "kg m/s", G_ALL, 0, D_3, D_NONE},
    [S_ENERGY] = {"/fluid/kinetic_energy", "J", G_ALL, 0, D_NONE, D_NONE},
    [S_POSITION] = {"/spheres/position", "m", G_SPHERES, 0, D_NS, D_3},
    [S_VELOCITY] = {"/spheres/velocity", "m/s", G_SPHERES, 0, D_NS, D_3},
    [S_OMEGA] = {"/spheres/angular_velocity", "rad/s", G_SPHERES, 0, D_NS, D_3},
    [S_FORCE] = {"/spheres/force", "N", G_SPHERES, 0, D_NS, D_3},
    [S_TORQUE] = {"/spheres/torque", "N m", G_SPHERES, 0, D_NS, D_3},
    [S_BODY] = {"/spheres/body", "body id", G_SPHERES, 1, D_NS, D_NONE},
    [S_CONN_FORCE] = {"/connections/force", "N", G_CONNECTIONS, 0, D_NC, D_3},
    [S_CONN_TORQUE] = {"/connections/torque", "N m", G_CONNECTIONS, 0, D_NC, D_3},
    [S_CONN_INTACT] = {"/connections/intact", "1 intact, 0 broken", G_CONNECTIONS, 1, D_NC, D_NONE},
    [S_NBODIES] = {"/bodies/count", "bodies", G_BODIES, 1, D_NONE, D_NONE},
    [S_BODY_MOMENTUM] = {"/bodies/momentum", "kg m/s", G_BODIES, 0, D_3, D_NONE},
    [S_BODY_ANGMOM] = {"/bodies/angular_momentum", "kg m^2/s", G_BODIES, 0, D_3, D_NONE},
};

static int series_present(const output_t *o, int k)
{
    const int g = SERIES[k].group;
    return g == G_ALL || (g == G_SPHERES && o->ns > 0) || (g == G_CONNECTIONS && o->nc > 0) ||
           (g == G_BODIES && o->bodies);
}

static hsize_t series_dim(const output_t *o, int d)
{
    return d == D_3 ? 3 : d == D_NS ? (hsize_t)o->ns : d == D_NC ? (hsize_t)o->nc : 0;
}

double output_file_bytes(const output_layout_t *layout, double rows, size_t scene_text)
{
    const output_t o = {.ns = layout->ns, .nc = layout->nc, .bodies = layout->bodies};
    double bytes = OUTPUT_FILE_BYTES + (double)scene_text + 2.0 * sizeof(int) * layout->nc;
    for (int k = 0; k < NSERIES; k++) {
        if (!series_present(&o, k)) {
            continue;
        }
        const hsize_t a = series_dim(&o, SERIES[k].a), b = series_dim(&o, SERIES[k].b);
        const double per_row = (double)(a > 0 ? a : 1) * (double)(b > 0 ? b : 1);
        const double crows = (double)chunk_rows((hsize_t)per_row);
        /* HDF5 allocates whole chunks: a short run's file is its chunks */
        const double chunks = fmax(1.0, ceil(rows / crows));
        bytes += OUTPUT_DATASET_BYTES + chunks * crows * per_row * (SERIES[k].is_int ? sizeof(int) : sizeof(double));
    }
    return bytes;
}

/* The output_t without a file yet. */
static status_t output_new(const char *path, const output_layout_t *layout, const log_t *log, output_t **out)
{
    *out = NULL;
    output_t *o = calloc(1, sizeof *o);
    if (o == NULL) {
        return log_msg(log, STATUS_FATAL, "output", "out of memory for the output writer (%zu bytes)", sizeof *o);
    }
    if (log != NULL) {
        o->log = *log;
    }
    o->file = -1;
    for (int k = 0; k < NSERIES; k++) {
        o->s[k].id = -1;
    }
    o->ns = layout->ns;
    o->nc = layout->nc;
    o->bodies = layout->bodies;
    if ((o->path = strdup(path)) == NULL) {
        output_close(o);
        return log_msg(log, STATUS_FATAL, "output", "out of memory for the output path (%zu bytes)", strlen(path) + 1);
    }
    H5Eset_auto2(H5E_DEFAULT, NULL, NULL); /* errors are reported by us */
    *out = o;
    return STATUS_OK;
}

status_t output_open(const char *path, const scene_t *scene, const units_t *u, const output_layout_t *layout,
                     const log_t *log, output_t **out)
{
    output_t *o;
    status_t st = output_new(path != NULL ? path : "", layout, log, &o);
    if (st != STATUS_OK || path == NULL) {
        if (o != NULL) {
            o->off = 1;
        }
        *out = o;
        return st;
    }
    o->file = H5Fcreate(path, H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    if (o->file < 0) {
        log_msg(log, STATUS_ERROR, "output", "%s: cannot create the output file (does the folder exist and is it writable?)",
                path);
        output_close(o);
        return STATUS_ERROR;
    }
    const double grid[3] = {u->n[0], u->n[1], u->n[2]}, ranks = layout->ranks;
    st = attr_string(o, o->file, "scene", scene->text ? scene->text : "");
    st = status_worst(st, attr_string(o, o->file, "scene_file", scene->path ? scene->path : ""));
    st = status_worst(st, attr_string(o, o->file, "version", AGGLO_VERSION));
    st = status_worst(st, attr_string(o, o->file, "integrator",
                                      scene->rigid.integrator == INTEGRATOR_CVODE ? "cvode" : "verlet"));
    st = status_worst(st, attr_doubles(o, o->file, "dx", &u->dx, 1));
    st = status_worst(st, attr_doubles(o, o->file, "dt", &u->dt, 1));
    st = status_worst(st, attr_doubles(o, o->file, "tau", &u->tau, 1));
    st = status_worst(st, attr_doubles(o, o->file, "grid", grid, 3));
    st = status_worst(st, attr_doubles(o, o->file, "ranks", &ranks, 1));
    if (o->nc > 0) {
        st = status_worst(st, write_pairs(o, layout->pairs, o->nc));
    }
    for (int k = 0; k < NSERIES; k++) {
        if (series_present(o, k)) {
            st = status_worst(st, series_create(o, &o->s[k], SERIES[k].name,
                                                SERIES[k].is_int ? H5T_NATIVE_INT : H5T_NATIVE_DOUBLE,
                                                series_dim(o, SERIES[k].a), series_dim(o, SERIES[k].b),
                                                SERIES[k].unit));
        }
    }
    if (layout->fields_file != NULL &&
        H5Lcreate_external(layout->fields_file, "/fields", o->file, "/fields", H5P_DEFAULT, H5P_DEFAULT) < 0) {
        st = status_worst(st, fail(o, "the /fields link"));
    }
    if (st == STATUS_OK && H5Fflush(o->file, H5F_SCOPE_GLOBAL) < 0) {
        st = fail(o, "the file (flushing)");
    }
    if (st != STATUS_OK) {
        output_close(o);
        return st;
    }
    *out = o;
    return STATUS_OK;
}

status_t output_save_rows(output_t *o, const char *path, const char *prefix)
{
    if (o->off) {
        return STATUS_OK;
    }
    const status_t wst = write_pending(o);
    if (wst != STATUS_OK) {
        return wst;
    }
    hid_t dst = H5Fopen(path, H5F_ACC_RDWR, H5P_DEFAULT);
    hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
    status_t st = STATUS_OK;
    if (dst < 0 || lcpl < 0 || H5Pset_create_intermediate_group(lcpl, 1) < 0) {
        st = log_msg(&o->log, STATUS_ERROR, "output", "%s: cannot open it to copy the output rows into it", path);
    }
    for (int k = 0; k < NSERIES && st == STATUS_OK; k++) {
        char name[256];
        snprintf(name, sizeof name, "%s%s", prefix, SERIES[k].name);
        if (o->s[k].id >= 0 && H5Ocopy(o->file, SERIES[k].name, dst, name, H5P_DEFAULT, lcpl) < 0) {
            st = log_msg(&o->log, STATUS_ERROR, "output", "%s: HDF5 error while copying %s of %s into it", path,
                         SERIES[k].name, o->path);
        }
    }
    if (lcpl >= 0) {
        H5Pclose(lcpl);
    }
    if (dst >= 0 && H5Fclose(dst) < 0 && st == STATUS_OK) {
        st = log_msg(&o->log, STATUS_ERROR, "output", "%s: HDF5 error while closing it", path);
    }
    return st;
}

status_t output_restore_rows(output_t *o, const char *path, const char *prefix, long rows)
{
    if (o->off) {
        return STATUS_OK;
    }
    hid_t src = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    if (src < 0) {
        return log_msg(&o->log, STATUS_ERROR, "output", "%s: cannot open it to read the output rows", path);
    }
    status_t st = STATUS_OK;
    for (int k = 0; k < NSERIES && st == STATUS_OK; k++) {
        series_t *s = &o->s[k];
        if (s->id < 0) {
            continue;
        }
        char name[256];
        snprintf(name, sizeof name, "%s%s", prefix, SERIES[k].name);
        hid_t d = H5Lexists(src, prefix, H5P_DEFAULT) > 0 && H5Lexists(src, name, H5P_DEFAULT) > 0
                      ? H5Dopen2(src, name, H5P_DEFAULT)
                      : -1;
        hid_t space = d >= 0 ? H5Dget_space(d) : -1;
        hsize_t dims[3] = {0, 0, 0};
        const int rank = space >= 0 ? H5Sget_simple_extent_ndims(space) : -1;
        if (rank == s->rank) {
            H5Sget_simple_extent_dims(space, dims, NULL);
        }
        const hsize_t per_row = (s->dims[1] > 0 ? s->dims[1] : 1) * (s->dims[2] > 0 ? s->dims[2] : 1);
        const size_t elem = SERIES[k].is_int ? sizeof(int) : sizeof(double);
        void *buf = NULL;
        if (rank != s->rank || dims[0] < (hsize_t)rows || (rank > 1 && dims[1] != s->dims[1]) ||
            (rank > 2 && dims[2] != s->dims[2])) {
            st = log_msg(&o->log, STATUS_ERROR, "output",
                         "%s: %s is missing, of another shape or shorter than the %ld rows it counts", path, name, rows);
        } else if (rows > 0 && (buf = malloc((size_t)rows * per_row * elem)) == NULL) {
            st = log_msg(&o->log, STATUS_FATAL, "output", "out of memory for %ld rows of %s (%zu bytes)", rows,
                         SERIES[k].name, (size_t)rows * (size_t)per_row * elem);
        } else if (rows > 0) {
            hsize_t ext[3] = {(hsize_t)rows, s->dims[1], s->dims[2]}, start[3] = {0, 0, 0};
            hid_t fs = H5Dget_space(d), ms = H5Screate_simple(s->rank, ext, NULL);
            if (fs < 0 || ms < 0 || H5Sselect_hyperslab(fs, H5S_SELECT_SET, start, NULL, ext, NULL) < 0 ||
                H5Dread(d, s->type, ms, fs, H5P_DEFAULT, buf) < 0) {
                st = fail(o, SERIES[k].name);
            } else {
                st = series_put(o, s, 0, (hsize_t)rows, buf);
            }
            if (ms >= 0) {
                H5Sclose(ms);
            }
            if (fs >= 0) {
                H5Sclose(fs);
            }
        }
        free(buf);
        if (space >= 0) {
            H5Sclose(space);
        }
        if (d >= 0) {
            H5Dclose(d);
        }
    }
    H5Fclose(src);
    if (st == STATUS_OK) {
        o->rows = (hsize_t)rows;
        o->pending = 0;
        if (H5Fflush(o->file, H5F_SCOPE_GLOBAL) < 0) {
            st = fail(o, "the file (flushing)");
        }
    }
    return st;
}

long output_rows(const output_t *o) { return (long)(o->rows + o->pending); }

status_t output_flush(output_t *o) { return o->off ? STATUS_OK : write_pending(o); }

status_t output_row(output_t *o, const output_row_t *r)
{
    if (o->off) {
        return STATUS_OK;
    }
    series_t *s = o->s;
    series_append(o, &s[S_TIME], &r->time);
    series_append(o, &s[S_MASS], &r->mass);
    series_append(o, &s[S_MOMENTUM], r->momentum);
    series_append(o, &s[S_ENERGY], &r->kinetic_energy);
    if (o->ns > 0) {
        series_append(o, &s[S_POSITION], r->position);
        series_append(o, &s[S_VELOCITY], r->velocity);
        series_append(o, &s[S_OMEGA], r->angular_velocity);
        series_append(o, &s[S_FORCE], r->force);
        series_append(o, &s[S_TORQUE], r->torque);
        series_append(o, &s[S_BODY], r->body);
    }
    if (o->nc > 0) {
        series_append(o, &s[S_CONN_FORCE], r->conn_force);
        series_append(o, &s[S_CONN_TORQUE], r->conn_torque);
        series_append(o, &s[S_CONN_INTACT], r->intact);
    }
    if (o->bodies) {
        series_append(o, &s[S_NBODIES], &r->nbodies);
        series_append(o, &s[S_BODY_MOMENTUM], r->body_momentum);
        series_append(o, &s[S_BODY_ANGMOM], r->body_angular_momentum);
    }
    o->pending++;
    if (o->pending == OUTPUT_BUFFER_ROWS || now_seconds() - o->last_write >= OUTPUT_FLUSH_SECONDS) {
        return write_pending(o);
    }
    return STATUS_OK;
}

status_t output_attr(output_t *o, const char *name, double value)
{
    if (o->off) {
        return STATUS_OK;
    }
    return attr_doubles(o, o->file, name, &value, 1);
}

status_t output_attr_string(output_t *o, const char *name, const char *value)
{
    if (o->off) {
        return STATUS_OK;
    }
    return attr_string(o, o->file, name, value);
}

status_t output_close(output_t *o)
{
    if (o == NULL) {
        return STATUS_OK;
    }
    status_t st = o->file >= 0 && !o->off ? write_pending(o) : STATUS_OK;
    for (int k = 0; k < NSERIES; k++) {
        if (o->s[k].id >= 0 && H5Dclose(o->s[k].id) < 0) {
            st = fail(o, "a dataset (closing)");
        }
        free(o->s[k].buf);
    }
    if (o->file >= 0 && H5Fclose(o->file) < 0) {
        st = fail(o, "the file (closing)");
    }
    free(o->path);
    free(o);
    return st;
}

long output_rows_readable(const char *path, double *t_last)
{
    long rows = -1;
    *t_last = 0.0;
    const hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    const hid_t d = f >= 0 ? H5Dopen2(f, SERIES[S_TIME].name, H5P_DEFAULT) : -1;
    const hid_t space = d >= 0 ? H5Dget_space(d) : -1;
    hsize_t n = 0;
    if (space >= 0 && H5Sget_simple_extent_ndims(space) == 1 && H5Sget_simple_extent_dims(space, &n, NULL) == 1) {
        rows = (long)n;
        if (n > 0) {
            hsize_t start = n - 1, one = 1;
            const hid_t ms = H5Screate_simple(1, &one, NULL);
            if (ms < 0 || H5Sselect_hyperslab(space, H5S_SELECT_SET, &start, NULL, &one, NULL) < 0 ||
                H5Dread(d, H5T_NATIVE_DOUBLE, ms, space, H5P_DEFAULT, t_last) < 0) {
                rows = -1; /* the rows' chunks are not there */
            }
            if (ms >= 0) {
                H5Sclose(ms);
            }
        }
    }
    if (space >= 0) {
        H5Sclose(space);
    }
    if (d >= 0) {
        H5Dclose(d);
    }
    if (f >= 0) {
        H5Fclose(f);
    }
    return rows;
}
