/* fmu.h — an FMI 2.0 Co-Simulation FMU seen from the master.
 *
 * fmu_load unpacks a .fmu archive (libzip) or takes an unpacked folder,
 * reads modelDescription.xml (libxml2) into a variable table, and loads
 * binaries/linux64/<modelIdentifier>.so with dlopen, resolving every fmi2*
 * function the master calls with dlsym: the master never calls fluid or
 * rigid code directly. Every later call goes through the wrappers below,
 * which check the status (an fmi2Error or fmi2Fatal becomes STATUS_ERROR
 * with a message naming the FMU, the function and its arguments), count the
 * calls per function, time fmi2DoStep, and, when a call log is given, write
 * one line per call with its arguments and status. FMU log messages arrive
 * through the FMI logger callback and go to the master's log sink. */
#ifndef COUPLER_FMU_H
#define COUPLER_FMU_H

#include "../common/status.h"

#include <stdio.h>

typedef enum { FMU_REAL, FMU_INTEGER, FMU_BOOLEAN, FMU_STRING } fmu_type_t;
typedef enum { FMU_PARAMETER, FMU_INPUT, FMU_OUTPUT, FMU_OTHER } fmu_causality_t;

typedef struct {
    char *name;
    char *unit; /* NULL when none */
    unsigned vr;
    fmu_type_t type;
    fmu_causality_t causality;
} fmu_var_t;

typedef struct fmu fmu_t;

/* Names of the wrapped functions, in the order of the call counters. */
enum {
    FMU_CALL_INSTANTIATE,
    FMU_CALL_SETUP_EXPERIMENT,
    FMU_CALL_ENTER_INIT,
    FMU_CALL_EXIT_INIT,
    FMU_CALL_SET_REAL,
    FMU_CALL_SET_STRING,
    FMU_CALL_GET_REAL,
    FMU_CALL_GET_INTEGER,
    FMU_CALL_GET_BOOLEAN,
    FMU_CALL_DO_STEP,
    FMU_CALL_GET_STATE,
    FMU_CALL_SET_STATE,
    FMU_CALL_FREE_STATE,
    FMU_CALL_STATE_SIZE,
    FMU_CALL_SERIALIZE,
    FMU_CALL_DESERIALIZE,
    FMU_CALL_TERMINATE,
    FMU_CALL_FREE_INSTANCE,
    FMU_NCALLS
};
extern const char *const fmu_call_names[FMU_NCALLS];

/* path: a .fmu file (unpacked into work_dir/<label>) or an unpacked folder.
 * label names the FMU in messages ("fluid.fmu"). calls: NULL or a stream
 * for the call log. Nothing is instantiated yet. */
status_t fmu_load(const char *path, const char *work_dir, const char *label, FILE *calls, const log_t *log,
                  fmu_t **out);
/* Terminates (when initialised), frees the instance and unloads. */
void fmu_free(fmu_t *f);

const char *fmu_label(const fmu_t *f);
const char *fmu_identifier(const fmu_t *f);
const char *fmu_guid(const fmu_t *f);
int fmu_nvars(const fmu_t *f);
const fmu_var_t *fmu_var(const fmu_t *f, int j);
/* The variable of that name, or NULL. */
const fmu_var_t *fmu_find(const fmu_t *f, const char *name);

/* Instantiate, SetupExperiment(t0, stop), EnterInitializationMode. */
status_t fmu_instantiate(fmu_t *f, double t0, double t_stop);
status_t fmu_set_string(fmu_t *f, unsigned vr, const char *value);
status_t fmu_exit_init(fmu_t *f);
status_t fmu_set_real(fmu_t *f, const unsigned *vr, size_t n, const double *v);
status_t fmu_get_real(fmu_t *f, const unsigned *vr, size_t n, double *v);
status_t fmu_get_integer(fmu_t *f, const unsigned *vr, size_t n, int *v);
status_t fmu_get_boolean(fmu_t *f, const unsigned *vr, size_t n, int *v);
status_t fmu_do_step(fmu_t *f, double t, double h);
/* FMU state (for the checkpoint test): *state is owned by the FMU. */
status_t fmu_get_state(fmu_t *f, void **state);
status_t fmu_set_state(fmu_t *f, void *state);
status_t fmu_free_state(fmu_t *f, void **state);
/* A state as bytes (fmi2SerializedFMUstateSize + fmi2SerializeFMUstate;
 * *bytes is malloc'ed, the caller frees it), and back into a new state
 * (fmi2DeSerializeFMUstate) for fmu_set_state, freed by fmu_free_state. */
status_t fmu_serialize_state(fmu_t *f, void *state, unsigned char **bytes, size_t *size);
status_t fmu_deserialize_state(fmu_t *f, const unsigned char *bytes, size_t size, void **state);
/* The path of the FMU's shared library (binaries/linux64/ID.so). */
void fmu_library_path(const fmu_t *f, char *buf, size_t n);

long fmu_calls(const fmu_t *f, int which);
long fmu_calls_total(const fmu_t *f);
double fmu_step_seconds(const fmu_t *f); /* wall time inside fmi2DoStep */

#endif
