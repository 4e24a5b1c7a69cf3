/* output.h — the HDF5 result file of `coupler run` (DESIGN section 5).
 *
 *   /time                                             [n]        s
 *   /spheres/{position,velocity,angular_velocity}     [n, ns, 3] m, m/s, rad/s
 *   /spheres/{force,torque}                           [n, ns, 3] N, N m (hydrodynamic)
 *   /spheres/body                                     [n, ns]    body id (int32)
 *   /connections/pair                                 [nc, 2]    sphere indices (int32)
 *   /connections/{force,torque}                       [n, nc, 3] N, N m (Eq. 8, 9)
 *   /connections/intact                               [n, nc]    1 until broken (int32)
 *   /fluid/{mass,kinetic_energy} [n], /fluid/momentum [n, 3]     kg, J, kg m/s
 *   /bodies/count [n] (int32), /bodies/{momentum,angular_momentum} [n, 3]
 *            number of moving bodies and their total linear momentum
 *            (kg m/s) and angular momentum about the origin (kg m^2/s)
 *   /fields  an HDF5 external link to /fields of the field file written
 *            by the fluid FMU (only when the scene asks for fields)
 * Only what the scene needs: no /spheres without spheres, no /connections
 * without connections, no /bodies without moving bodies, no /fields link without field output. Every dataset
 * has a `unit` attribute. Time series are extendible chunked datasets, one
 * row per output step; rows are buffered and written at least every second
 * (and every 256 rows, at every checkpoint and at the end), so that a
 * killed run leaves a readable file that lacks at most its last second of
 * rows. hdf5.h appears only in output.c. */
#ifndef COUPLER_OUTPUT_H
#define COUPLER_OUTPUT_H

#include "../common/scene.h"
#include "../common/status.h"
#include "../fluid/units.h"

typedef struct output output_t;

typedef struct {
    int ns;                  /* spheres (0: no /spheres) */
    int nc;                  /* connections (0: no /connections) */
    const int *pairs;        /* [nc][2] */
    const char *fields_file; /* NULL: no /fields; else the field file (its name relative to the output's folder) */
    int bodies;              /* 1: /bodies (a rigid component runs) */
    int ranks;               /* MPI ranks of the run (the root attribute "ranks") */
} output_layout_t;

/* One output row, SI; arrays of ns*3, ns, nc*3 and nc values (NULL when the
 * count is 0). */
typedef struct {
    double time;
    const double *position, *velocity, *angular_velocity, *force, *torque;
    const int *body;
    const double *conn_force, *conn_torque;
    const int *intact;
    double mass, momentum[3], kinetic_energy;
    int nbodies;                                         /* layout.bodies only */
    const double *body_momentum, *body_angular_momentum; /* [3] each, layout.bodies only */
} output_row_t;

/* Creates the file (truncating) with the root attributes: scene text and
 * file, lattice parameters dx, dt, tau, grid, integrator, ranks, version. */
status_t output_open(const char *path, const scene_t *scene, const units_t *units, const output_layout_t *layout,
                     const log_t *log, output_t **out);
status_t output_row(output_t *o, const output_row_t *row);
/* Bytes of an output file of the layout with `rows` rows and a scene text
 * of scene_text bytes, HDF5's whole chunks included (resources_need). */
double output_file_bytes(const output_layout_t *layout, double rows, size_t scene_text);
long output_rows(const output_t *o);
/* Copies every time series as written so far into the HDF5 file at path
 * (closed; opened and closed here), under prefix ("/output"): a checkpoint
 * keeps its own copy of the rows, so that a run killed while writing its
 * output loses nothing. */
status_t output_save_rows(output_t *o, const char *path, const char *prefix);
/* Fills a new output (output_open) with the first `rows` rows of the series
 * saved under prefix in the file at path. */
status_t output_restore_rows(output_t *o, const char *path, const char *prefix, long rows);
status_t output_flush(output_t *o);
/* Root attributes (wall times, results, FMI call counts). */
status_t output_attr(output_t *o, const char *name, double value);
status_t output_attr_string(output_t *o, const char *name, const char *value);
/* Flushes and closes; o is freed even on error. */
status_t output_close(output_t *o);
/* What the closed output file at path holds after a run that stopped on an
 * error: the rows of its time series (and the last time in *t_last), or -1
 * when HDF5 cannot read it (a disk that filled before its first rows were
 * written leaves a file whose metadata points past its end). */
long output_rows_readable(const char *path, double *t_last);

#endif
