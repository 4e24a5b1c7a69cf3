/* h5fields.h — field snapshots in an HDF5 file with an XDMF index beside it.
 *
 * /fields/NNNNNN/{density,velocity,flags} at LBM step NNNNNN: density
 * (kg/m^3) [nz, ny, nx], velocity (m/s) [nz, ny, nx, 3], flags (0 fluid,
 * 1 solid) [nz, ny, nx], x fastest; each group has a `time` attribute (s).
 * The .xmf (same path, extension .xmf) lists every snapshot as cell data of
 * a co-rectilinear grid (XDMF 2, as ParaView reads it) and is rewritten
 * after every snapshot, so a killed run leaves both files readable. Writing
 * a step again (after an FMU state restore) replaces that snapshot. Used by
 * the fluid FMU (fluid/fluid_fmi.c); hdf5.h appears only in the writers. */
#ifndef COMMON_H5FIELDS_H
#define COMMON_H5FIELDS_H

#include "status.h"

typedef struct h5fields h5fields_t;

/* Creates (truncates) path; errors name the file. */
status_t h5fields_open(const char *path, const int n[3], double dx, const log_t *log, h5fields_t **out);
/* Opens the field file of an interrupted run to continue it: the snapshots
 * already in it stay and are listed in the index. */
status_t h5fields_resume(const char *path, const int n[3], double dx, const log_t *log, h5fields_t **out);
/* Drops the snapshots after `step` (a restored state continues from there). */
status_t h5fields_drop_after(h5fields_t *w, long step);
status_t h5fields_write(h5fields_t *w, long step, double time, const double *density, const double *velocity,
                        const unsigned char *flags);
/* Closes the file and frees w (NULL is fine). */
status_t h5fields_close(h5fields_t *w);

#endif
