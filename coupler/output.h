/* output.h — the HDF5 result file (DESIGN section 5) and its XDMF companion.
 *
 * Time series are extendible chunked datasets, one row per output step,
 * flushed at every output step so that a killed run leaves a readable file
 * up to its last output. Field snapshots go to /fields/NNNNNN/ and are
 * listed in an .xmf file beside the .h5, rewritten after every snapshot, so
 * ParaView opens the fields at any time. hdf5.h appears only in output.c. */
#ifndef COUPLER_OUTPUT_H
#define COUPLER_OUTPUT_H

#include "../common/scene.h"
#include "../common/status.h"
#include "../fluid/units.h"

typedef struct output output_t;

/* Checks that path can be written and creates the file with the root
 * attributes (scene text, lattice parameters, version). */
status_t output_open(const char *path, const scene_t *scene, const units_t *units, const log_t *log,
                     output_t **out);
/* One row of the fluid time series (SI). */
status_t output_fluid_row(output_t *o, double time, double mass, const double momentum[3], double kinetic_energy);
/* A field snapshot: density (kg/m^3), velocity (m/s, 3 per cell), flags; x fastest. */
status_t output_fields(output_t *o, long step, double time, const double *density, const double *velocity,
                       const unsigned char *flags);
/* A named double attribute on the root (wall times, results). */
status_t output_attr(output_t *o, const char *name, double value);
/* Flushes and closes; o is freed even on error. */
status_t output_close(output_t *o);

#endif
