/* output.c — HDF5 writer and XDMF index (output.h). Every HDF5 call is
 * checked; a failure is reported with the file and the object. */
#include "output.h"

#include <hdf5.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define VERSION "0.1.0"

typedef struct {
    hid_t id;
    int rank; /* 1 or 2 */
    hsize_t cols;
} series_t;

struct output {
    char *path;
    char *xmf;
    log_t log;
    hid_t file;
    series_t time, mass, momentum, energy;
    hsize_t rows;
    int n[3];
    double dx;
    long *snap_steps;
    double *snap_times;
    int nsnaps;
};

static status_t fail(const output_t *o, const char *what)
{
    return log_msg(&o->log, STATUS_ERROR, "output", "%s: HDF5 error while %s", o->path, what);
}

static status_t attr_string(output_t *o, hid_t obj, const char *name, const char *value)
{
    hid_t type = H5Tcopy(H5T_C_S1);
    hid_t space = H5Screate(H5S_SCALAR);
    status_t st = STATUS_OK;
    if (type < 0 || space < 0 || H5Tset_size(type, strlen(value) + 1) < 0) {
        st = fail(o, "creating a string attribute");
    } else {
        hid_t a = H5Acreate2(obj, name, type, space, H5P_DEFAULT, H5P_DEFAULT);
        if (a < 0 || H5Awrite(a, type, value) < 0) {
            st = fail(o, name);
        }
        if (a >= 0) {
            H5Aclose(a);
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
    if (space < 0) {
        return fail(o, name);
    }
    if (H5Aexists(obj, name) > 0) {
        H5Adelete(obj, name);
    }
    hid_t a = H5Acreate2(obj, name, H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, H5P_DEFAULT);
    if (a < 0 || H5Awrite(a, H5T_NATIVE_DOUBLE, v) < 0) {
        st = fail(o, name);
    }
    if (a >= 0) {
        H5Aclose(a);
    }
    H5Sclose(space);
    return st;
}

static status_t series_create(output_t *o, series_t *s, const char *name, hsize_t cols, const char *unit)
{
    const int rank = cols > 0 ? 2 : 1;
    hsize_t dims[2] = {0, cols}, maxd[2] = {H5S_UNLIMITED, cols}, chunk[2] = {256, cols};
    hid_t space = H5Screate_simple(rank, dims, maxd);
    hid_t plist = H5Pcreate(H5P_DATASET_CREATE);
    status_t st = STATUS_OK;
    s->id = -1;
    s->rank = rank;
    s->cols = cols;
    if (space < 0 || plist < 0 || H5Pset_chunk(plist, rank, chunk) < 0) {
        st = fail(o, name);
    } else {
        hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
        H5Pset_create_intermediate_group(lcpl, 1);
        s->id = H5Dcreate2(o->file, name, H5T_NATIVE_DOUBLE, space, lcpl, plist, H5P_DEFAULT);
        H5Pclose(lcpl);
        if (s->id < 0 || attr_string(o, s->id, "unit", unit) != STATUS_OK) {
            st = fail(o, name);
        }
    }
    if (plist >= 0) {
        H5Pclose(plist);
    }
    if (space >= 0) {
        H5Sclose(space);
    }
    return st;
}

static status_t series_append(output_t *o, series_t *s, hsize_t row, const double *v)
{
    hsize_t dims[2] = {row + 1, s->cols}, start[2] = {row, 0}, count[2] = {1, s->cols};
    status_t st = STATUS_OK;
    if (H5Dset_extent(s->id, dims) < 0) {
        return fail(o, "extending a time series");
    }
    hid_t fs = H5Dget_space(s->id);
    hid_t ms = H5Screate_simple(s->rank, count, NULL);
    if (fs < 0 || ms < 0 || H5Sselect_hyperslab(fs, H5S_SELECT_SET, start, NULL, count, NULL) < 0 ||
        H5Dwrite(s->id, H5T_NATIVE_DOUBLE, ms, fs, H5P_DEFAULT, v) < 0) {
        st = fail(o, "writing a time series row");
    }
    if (ms >= 0) {
        H5Sclose(ms);
    }
    if (fs >= 0) {
        H5Sclose(fs);
    }
    return st;
}

status_t output_open(const char *path, const scene_t *scene, const units_t *u, const log_t *log, output_t **out)
{
    *out = NULL;
    output_t *o = calloc(1, sizeof *o);
    if (o == NULL) {
        return log_msg(log, STATUS_ERROR, "output", "out of memory");
    }
    if (log != NULL) {
        o->log = *log;
    }
    o->file = -1;
    o->path = strdup(path);
    const size_t len = strlen(path);
    o->xmf = malloc(len + 5);
    if (o->path == NULL || o->xmf == NULL) {
        output_close(o);
        return log_msg(log, STATUS_ERROR, "output", "out of memory");
    }
    memcpy(o->xmf, path, len + 1);
    char *dot = strrchr(o->xmf, '.');
    char *slash = strrchr(o->xmf, '/');
    if (dot != NULL && (slash == NULL || dot > slash)) {
        *dot = '\0';
    }
    strcat(o->xmf, ".xmf");
    memcpy(o->n, u->n, sizeof o->n);
    o->dx = u->dx;
    /* Silence HDF5's own stack printing: errors are reported by us. */
    H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
    o->file = H5Fcreate(path, H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    if (o->file < 0) {
        log_msg(log, STATUS_ERROR, "output", "%s: cannot create the output file (does the folder exist and is it writable?)",
                path);
        output_close(o);
        return STATUS_ERROR;
    }
    const double grid[3] = {u->n[0], u->n[1], u->n[2]};
    status_t st = attr_string(o, o->file, "scene", scene->text ? scene->text : "");
    st = status_worst(st, attr_string(o, o->file, "scene_file", scene->path ? scene->path : ""));
    st = status_worst(st, attr_string(o, o->file, "version", VERSION));
    st = status_worst(st, attr_string(o, o->file, "integrator", scene->rigid.integrator == INTEGRATOR_CVODE ? "cvode" : "verlet"));
    st = status_worst(st, attr_doubles(o, o->file, "dx", &u->dx, 1));
    st = status_worst(st, attr_doubles(o, o->file, "dt", &u->dt, 1));
    st = status_worst(st, attr_doubles(o, o->file, "tau", &u->tau, 1));
    st = status_worst(st, attr_doubles(o, o->file, "grid", grid, 3));
    const double ranks = 1.0;
    st = status_worst(st, attr_doubles(o, o->file, "ranks", &ranks, 1));
    st = status_worst(st, series_create(o, &o->time, "/time", 0, "s"));
    st = status_worst(st, series_create(o, &o->mass, "/fluid/mass", 0, "kg"));
    st = status_worst(st, series_create(o, &o->momentum, "/fluid/momentum", 3, "kg m/s"));
    st = status_worst(st, series_create(o, &o->energy, "/fluid/kinetic_energy", 0, "J"));
    if (st != STATUS_OK) {
        output_close(o);
        return st;
    }
    H5Fflush(o->file, H5F_SCOPE_GLOBAL);
    *out = o;
    return STATUS_OK;
}

status_t output_fluid_row(output_t *o, double time, double mass, const double momentum[3], double kinetic_energy)
{
    status_t st = series_append(o, &o->time, o->rows, &time);
    st = status_worst(st, series_append(o, &o->mass, o->rows, &mass));
    st = status_worst(st, series_append(o, &o->momentum, o->rows, momentum));
    st = status_worst(st, series_append(o, &o->energy, o->rows, &kinetic_energy));
    o->rows++;
    if (H5Fflush(o->file, H5F_SCOPE_GLOBAL) < 0) {
        st = fail(o, "flushing");
    }
    return st;
}

static status_t write_field(output_t *o, hid_t group, const char *name, hid_t type, const void *data, int comps)
{
    hsize_t dims[4] = {(hsize_t)o->n[2], (hsize_t)o->n[1], (hsize_t)o->n[0], (hsize_t)comps};
    hid_t space = H5Screate_simple(comps > 1 ? 4 : 3, dims, NULL);
    status_t st = STATUS_OK;
    if (space < 0) {
        return fail(o, name);
    }
    hid_t d = H5Dcreate2(group, name, type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    if (d < 0 || H5Dwrite(d, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) {
        st = fail(o, name);
    }
    if (d >= 0) {
        H5Dclose(d);
    }
    H5Sclose(space);
    return st;
}

/* The XDMF index: a temporal collection of co-rectilinear grids whose
 * attributes point into the .h5 file (XDMF 2, as ParaView reads it). */
static status_t write_xmf(output_t *o)
{
    char tmp[4096];
    snprintf(tmp, sizeof tmp, "%s.tmp", o->xmf);
    FILE *fp = fopen(tmp, "w");
    if (fp == NULL) {
        return log_msg(&o->log, STATUS_ERROR, "output", "%s: cannot write the XDMF index", o->xmf);
    }
    const char *h5 = strrchr(o->path, '/') ? strrchr(o->path, '/') + 1 : o->path;
    const int nx = o->n[0], ny = o->n[1], nz = o->n[2];
    fprintf(fp, "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"2.0\">\n <Domain>\n"
                "  <Grid Name=\"fields\" GridType=\"Collection\" CollectionType=\"Temporal\">\n");
    for (int k = 0; k < o->nsnaps; k++) {
        fprintf(fp, "   <Grid Name=\"step %ld\" GridType=\"Uniform\">\n    <Time Value=\"%.10g\"/>\n",
                o->snap_steps[k], o->snap_times[k]);
        /* cell data: the mesh has one node more than cells per axis */
        fprintf(fp, "    <Topology TopologyType=\"3DCoRectMesh\" Dimensions=\"%d %d %d\"/>\n", nz + 1, ny + 1,
                nx + 1);
        fprintf(fp,
                "    <Geometry GeometryType=\"ORIGIN_DXDYDZ\">\n"
                "     <DataItem Dimensions=\"3\" Format=\"XML\">0 0 0</DataItem>\n"
                "     <DataItem Dimensions=\"3\" Format=\"XML\">%.10g %.10g %.10g</DataItem>\n"
                "    </Geometry>\n",
                o->dx, o->dx, o->dx);
        static const char *names[3] = {"density", "velocity", "flags"};
        for (int a = 0; a < 3; a++) {
            fprintf(fp,
                    "    <Attribute Name=\"%s\" AttributeType=\"%s\" Center=\"Cell\">\n"
                    "     <DataItem Dimensions=\"%d %d %d%s\" NumberType=\"%s\" Precision=\"%d\" "
                    "Format=\"HDF\">%s:/fields/%06ld/%s</DataItem>\n    </Attribute>\n",
                    names[a], a == 1 ? "Vector" : "Scalar", nz, ny, nx, a == 1 ? " 3" : "",
                    a == 2 ? "UChar" : "Float", a == 2 ? 1 : 8, h5, o->snap_steps[k], names[a]);
        }
        fprintf(fp, "   </Grid>\n");
    }
    fprintf(fp, "  </Grid>\n </Domain>\n</Xdmf>\n");
    if (fclose(fp) != 0 || rename(tmp, o->xmf) != 0) {
        return log_msg(&o->log, STATUS_ERROR, "output", "%s: cannot write the XDMF index", o->xmf);
    }
    return STATUS_OK;
}

status_t output_fields(output_t *o, long step, double time, const double *density, const double *velocity,
                       const unsigned char *flags)
{
    char name[64];
    snprintf(name, sizeof name, "/fields/%06ld", step);
    hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
    H5Pset_create_intermediate_group(lcpl, 1);
    hid_t g = H5Gcreate2(o->file, name, lcpl, H5P_DEFAULT, H5P_DEFAULT);
    H5Pclose(lcpl);
    if (g < 0) {
        return fail(o, name);
    }
    status_t st = write_field(o, g, "density", H5T_NATIVE_DOUBLE, density, 1);
    st = status_worst(st, write_field(o, g, "velocity", H5T_NATIVE_DOUBLE, velocity, 3));
    st = status_worst(st, write_field(o, g, "flags", H5T_NATIVE_UCHAR, flags, 1));
    st = status_worst(st, attr_doubles(o, g, "time", &time, 1));
    H5Gclose(g);
    if (H5Fflush(o->file, H5F_SCOPE_GLOBAL) < 0) {
        st = fail(o, "flushing");
    }
    if (st != STATUS_OK) {
        return st;
    }
    long *ns = realloc(o->snap_steps, sizeof(long) * (size_t)(o->nsnaps + 1));
    if (ns == NULL) {
        return log_msg(&o->log, STATUS_ERROR, "output", "out of memory");
    }
    o->snap_steps = ns;
    double *nt = realloc(o->snap_times, sizeof(double) * (size_t)(o->nsnaps + 1));
    if (nt == NULL) {
        return log_msg(&o->log, STATUS_ERROR, "output", "out of memory");
    }
    o->snap_times = nt;
    o->snap_steps[o->nsnaps] = step;
    o->snap_times[o->nsnaps] = time;
    o->nsnaps++;
    return write_xmf(o);
}

status_t output_attr(output_t *o, const char *name, double value)
{
    return attr_doubles(o, o->file, name, &value, 1);
}

status_t output_close(output_t *o)
{
    if (o == NULL) {
        return STATUS_OK;
    }
    status_t st = STATUS_OK;
    series_t *all[4] = {&o->time, &o->mass, &o->momentum, &o->energy};
    for (int i = 0; i < 4; i++) {
        if (all[i]->id > 0) {
            H5Dclose(all[i]->id);
        }
    }
    if (o->file >= 0 && H5Fclose(o->file) < 0) {
        st = fail(o, "closing");
    }
    free(o->snap_steps);
    free(o->snap_times);
    free(o->xmf);
    free(o->path);
    free(o);
    return st;
}
