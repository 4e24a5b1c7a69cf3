/* h5fields.c — field snapshots and their XDMF index (h5fields.h). Every
 * HDF5 and stdio call is checked; a failure names the file and the object. */
#include "h5fields.h"

#include <hdf5.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct h5fields {
    char *path, *xmf;
    log_t log;
    hid_t file;
    int n[3];
    double dx;
    long *steps; /* sorted, unique */
    double *times;
    int nsnaps, cap;
};

static status_t open_file(const char *path, const int n[3], double dx, int resume, const log_t *log,
                          h5fields_t **out);
static status_t remember(h5fields_t *w, long step, double time);
static status_t write_xmf(h5fields_t *w);

static status_t fail(const h5fields_t *w, const char *what)
{
    return log_msg(&w->log, STATUS_ERROR, "fields", "%s: HDF5 error while writing %s", w->path, what);
}

status_t h5fields_close(h5fields_t *w)
{
    if (w == NULL) {
        return STATUS_OK;
    }
    status_t st = STATUS_OK;
    if (w->file >= 0 && H5Fclose(w->file) < 0) {
        st = fail(w, "the file (closing)");
    }
    free(w->steps);
    free(w->times);
    free(w->xmf);
    free(w->path);
    free(w);
    return st;
}

status_t h5fields_open(const char *path, const int n[3], double dx, const log_t *log, h5fields_t **out)
{
    return open_file(path, n, dx, 0, log, out);
}

static status_t open_file(const char *path, const int n[3], double dx, int resume, const log_t *log,
                          h5fields_t **out)
{
    *out = NULL;
    h5fields_t *w = calloc(1, sizeof *w);
    if (w == NULL) {
        return log_msg(log, STATUS_FATAL, "fields", "out of memory for the field writer (%zu bytes)", sizeof *w);
    }
    w->file = -1;
    if (log != NULL) {
        w->log = *log;
    }
    const size_t len = strlen(path);
    w->path = strdup(path);
    w->xmf = malloc(len + 5);
    if (w->path == NULL || w->xmf == NULL) {
        h5fields_close(w);
        return log_msg(log, STATUS_FATAL, "fields", "out of memory for the field file paths (%zu bytes)", 2 * len + 6);
    }
    memcpy(w->xmf, path, len + 1);
    char *dot = strrchr(w->xmf, '.'), *slash = strrchr(w->xmf, '/');
    if (dot != NULL && (slash == NULL || dot > slash)) {
        *dot = '\0';
    }
    strcat(w->xmf, ".xmf");
    memcpy(w->n, n, sizeof w->n);
    w->dx = dx;
    H5Eset_auto2(H5E_DEFAULT, NULL, NULL); /* errors are reported by us */
    w->file = resume ? H5Fopen(path, H5F_ACC_RDWR, H5P_DEFAULT) : H5Fcreate(path, H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    if (w->file < 0) {
        log_msg(log, STATUS_ERROR, "fields", "%s: cannot %s the field file (%s)", path, resume ? "open" : "create",
                resume ? "is it there, an HDF5 file, writable?" : "does the folder exist and is it writable?");
        h5fields_close(w);
        return STATUS_ERROR;
    }
    *out = w;
    return STATUS_OK;
}

static status_t write_one(h5fields_t *w, hid_t group, const char *name, hid_t type, const void *data, int comps)
{
    hsize_t dims[4] = {(hsize_t)w->n[2], (hsize_t)w->n[1], (hsize_t)w->n[0], (hsize_t)comps};
    hid_t space = H5Screate_simple(comps > 1 ? 4 : 3, dims, NULL);
    status_t st = STATUS_OK;
    if (space < 0) {
        return fail(w, name);
    }
    hid_t d = H5Dcreate2(group, name, type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    if (d < 0 || H5Dwrite(d, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) {
        st = fail(w, name);
    }
    if (d >= 0 && H5Dclose(d) < 0) {
        st = fail(w, name);
    }
    H5Sclose(space);
    return st;
}

static status_t write_time(h5fields_t *w, hid_t group, double time)
{
    hid_t space = H5Screate(H5S_SCALAR);
    status_t st = STATUS_OK;
    if (space < 0) {
        return fail(w, "the time attribute");
    }
    hid_t a = H5Acreate2(group, "time", H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, H5P_DEFAULT);
    if (a < 0 || H5Awrite(a, H5T_NATIVE_DOUBLE, &time) < 0) {
        st = fail(w, "the time attribute");
    }
    if (a >= 0) {
        H5Aclose(a);
    }
    H5Sclose(space);
    return st;
}

/* The XDMF index: a temporal collection of co-rectilinear grids whose
 * attributes point into the .h5 file (XDMF 2, as ParaView reads it). */
static status_t write_xmf(h5fields_t *w)
{
    char tmp[4200];
    if (snprintf(tmp, sizeof tmp, "%s.tmp", w->xmf) >= (int)sizeof tmp) {
        return log_msg(&w->log, STATUS_ERROR, "fields", "%s: path too long", w->xmf);
    }
    FILE *fp = fopen(tmp, "w");
    if (fp == NULL) {
        return log_msg(&w->log, STATUS_ERROR, "fields", "%s: cannot write the XDMF index", w->xmf);
    }
    const char *h5 = strrchr(w->path, '/') ? strrchr(w->path, '/') + 1 : w->path;
    const int nx = w->n[0], ny = w->n[1], nz = w->n[2];
    fprintf(fp, "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"2.0\">\n <Domain>\n"
                "  <Grid Name=\"fields\" GridType=\"Collection\" CollectionType=\"Temporal\">\n");
    for (int k = 0; k < w->nsnaps; k++) {
        fprintf(fp, "   <Grid Name=\"step %ld\" GridType=\"Uniform\">\n    <Time Value=\"%.10g\"/>\n", w->steps[k],
                w->times[k]);
        /* cell data: the mesh has one node more than cells per axis */
        fprintf(fp, "    <Topology TopologyType=\"3DCoRectMesh\" Dimensions=\"%d %d %d\"/>\n", nz + 1, ny + 1,
                nx + 1);
        fprintf(fp,
                "    <Geometry GeometryType=\"ORIGIN_DXDYDZ\">\n"
                "     <DataItem Dimensions=\"3\" Format=\"XML\">0 0 0</DataItem>\n"
                "     <DataItem Dimensions=\"3\" Format=\"XML\">%.10g %.10g %.10g</DataItem>\n"
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
    const int bad = ferror(fp);
    if (fclose(fp) != 0 || bad || rename(tmp, w->xmf) != 0) {
        return log_msg(&w->log, STATUS_ERROR, "fields", "%s: cannot write the XDMF index", w->xmf);
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

status_t h5fields_write(h5fields_t *w, long step, double time, const double *density, const double *velocity,
                        const unsigned char *flags)
{
    char name[64];
    snprintf(name, sizeof name, "/fields/%06ld", step);
    if (H5Lexists(w->file, "/fields", H5P_DEFAULT) > 0 && H5Lexists(w->file, name, H5P_DEFAULT) > 0 &&
        H5Ldelete(w->file, name, H5P_DEFAULT) < 0) {
        return fail(w, name);
    }
    hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
    if (lcpl < 0 || H5Pset_create_intermediate_group(lcpl, 1) < 0) {
        if (lcpl >= 0) {
            H5Pclose(lcpl);
        }
        return fail(w, name);
    }
    hid_t g = H5Gcreate2(w->file, name, lcpl, H5P_DEFAULT, H5P_DEFAULT);
    H5Pclose(lcpl);
    if (g < 0) {
        return fail(w, name);
    }
    status_t st = write_one(w, g, "density", H5T_NATIVE_DOUBLE, density, 1);
    st = status_worst(st, write_one(w, g, "velocity", H5T_NATIVE_DOUBLE, velocity, 3));
    st = status_worst(st, write_one(w, g, "flags", H5T_NATIVE_UCHAR, flags, 1));
    st = status_worst(st, write_time(w, g, time));
    if (H5Gclose(g) < 0 || H5Fflush(w->file, H5F_SCOPE_GLOBAL) < 0) {
        st = status_worst(st, fail(w, name));
    }
    if (st != STATUS_OK) {
        return st;
    }
    st = remember(w, step, time);
    return st != STATUS_OK ? st : write_xmf(w);
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

status_t h5fields_resume(const char *path, const int n[3], double dx, const log_t *log, h5fields_t **out)
{
    h5fields_t *w;
    status_t st = open_file(path, n, dx, 1, log, &w);
    if (st != STATUS_OK) {
        return st;
    }
    if (H5Lexists(w->file, "/fields", H5P_DEFAULT) > 0) {
        hid_t g = H5Gopen2(w->file, "/fields", H5P_DEFAULT);
        if (g < 0 || H5Literate(g, H5_INDEX_NAME, H5_ITER_INC, NULL, found_snapshot, w) < 0) {
            st = log_msg(log, STATUS_ERROR, "fields", "%s: cannot read the snapshots already written", path);
        }
        if (g >= 0) {
            H5Gclose(g);
        }
    }
    if (st != STATUS_OK) {
        h5fields_close(w);
        return st;
    }
    *out = w;
    return STATUS_OK;
}

status_t h5fields_drop_after(h5fields_t *w, long step)
{
    if (w->nsnaps == 0 || w->steps[w->nsnaps - 1] <= step) {
        return STATUS_OK;
    }
    while (w->nsnaps > 0 && w->steps[w->nsnaps - 1] > step) {
        char name[64];
        snprintf(name, sizeof name, "/fields/%06ld", w->steps[w->nsnaps - 1]);
        if (H5Lexists(w->file, name, H5P_DEFAULT) > 0 && H5Ldelete(w->file, name, H5P_DEFAULT) < 0) {
            return fail(w, name);
        }
        w->nsnaps--;
    }
    if (H5Fflush(w->file, H5F_SCOPE_GLOBAL) < 0) {
        return fail(w, "the file (flushing)");
    }
    return write_xmf(w);
}
