/* fmi_adapter.h — the contract between the generic FMI 2.0 layer and a model.
 *
 * One generic layer (fmi_adapter.c and the files fmi_internal.h lists)
 * implements every fmi2* entry point: call order (a legal-state bit mask per
 * function), argument checks, logging through the FMI logger, the value
 * store, FMU state and its serialisation.
 * A model (fluid/fluid_fmi.c, rigid/rigid_fmi.c) only describes its variables
 * for a scene and maps them to its native API through the fmi_model_t table
 * below. The same description generates modelDescription.xml (coupler/export.c),
 * so the XML and the library can never disagree.
 *
 * Value references are indices into the variable list (0, 1, ..., n-1). All
 * values are stored as doubles (Integer and Boolean values are exact in a
 * double); the generic layer owns them: inputs and parameters are written by
 * the master, outputs by the model after creation, each step and each restore.
 * Exceptions: String variables (parameters only, start "") are kept as text
 * and handed to the model by set_string after creation; outputs marked lazy
 * (costly, e.g. a pass over the whole grid) are computed by lazy_outputs only
 * when a master reads one after a step, not after every step. */
#ifndef COMMON_FMI_ADAPTER_H
#define COMMON_FMI_ADAPTER_H

#include "scene.h"
#include "status.h"

#include <stddef.h>

typedef enum { FMI_REAL, FMI_INTEGER, FMI_BOOLEAN, FMI_STRING } fmi_type_t;
typedef enum { FMI_PARAMETER, FMI_INPUT, FMI_OUTPUT } fmi_causality_t;

/* Range flags of a parameter: the modelDescription min/max are inclusive,
 * an open end is checked by the adapter and stated in the message. */
enum { FMI_LO_OPEN = 1, FMI_HI_OPEN = 2 };

#define FMI_NAME_MAX 80
#define FMI_DESC_MAX 120
#define FMI_KEY_MAX 48

typedef struct {
    char name[FMI_NAME_MAX];        /* structured name, e.g. sphere[3].force.x */
    char description[FMI_DESC_MAX];
    fmi_type_t type;
    fmi_causality_t causality;
    const char *unit;               /* one of the units in fmi_units, or NULL */
    double start;                   /* inputs and parameters */
    double min, max;                /* parameters: allowed range (may be +-INFINITY) */
    int range_flags;                /* FMI_LO_OPEN | FMI_HI_OPEN */
    int lazy;                       /* outputs: computed by lazy_outputs when read */
    /* Parameters: the scene key the value overrides; component >= 0 for one
     * element of a 3-vector key (the override then writes the whole vector). */
    char key[FMI_KEY_MAX];
    int component;
    /* Model-specific mapping: quantity code, sphere or connection index, axis. */
    int what, index, axis;
} fmi_var_t;

typedef struct {
    fmi_var_t *v;
    int n, cap;
} fmi_vars_t;

/* The per-model table. Every function reports through log (category = the
 * model name) and returns a status_t in FMI severity order. */
typedef struct {
    const char *identifier;  /* modelIdentifier and library name: "fluid" */
    const char *description; /* one line for modelDescription.xml */
    int can_variable_step;   /* canHandleVariableCommunicationStepSize */
    /* The variable list of this FMU for a scene; STATUS_DISCARD (nothing
     * logged) when the scene needs no such FMU: the rigid without free bodies. */
    status_t (*variables)(const scene_t *s, const log_t *log, fmi_vars_t *out);
    /* Creates the native component from the scene with parameters applied. */
    status_t (*create)(const scene_t *s, double t0, const log_t *log, void **comp);
    void (*free)(void *comp);
    /* Optional: rejects a step size before anything changes (NULL: any h > 0);
     * t is the communication point (a master's h = t_next - t carries the
     * round-off of both times, which grows with |t|). */
    status_t (*check_step)(void *comp, double t, double h, const log_t *log);
    /* Applies the inputs in values[] and advances from t by h > 0. */
    status_t (*step)(void *comp, const fmi_vars_t *vars, const double *values, double t, double h, const log_t *log);
    /* Writes every output into values[]. */
    void (*outputs)(void *comp, const fmi_vars_t *vars, double *values);
    /* Optional: computes the outputs marked lazy (NULL: the model has none),
     * reading the component without changing it (a saved FMU state may still
     * be the component itself: fmi_state.c). STATUS_ERROR (logged) when they
     * cannot be trusted (numerical trouble): the get fails and the instance
     * goes to the Error state. */
    status_t (*lazy_outputs)(void *comp, const fmi_vars_t *vars, double *values);
    /* Optional: a String parameter's value, called right after create (NULL:
     * the model has no String variables). */
    status_t (*set_string)(void *comp, const fmi_var_t *var, const char *value, const log_t *log);
    /* Optional: at fmi2Terminate, closes the files the component writes
     * (the fluid's field file), so that the master can read them before
     * fmi2FreeInstance; a state restored after it writes none. */
    status_t (*terminate)(void *comp, const log_t *log);
    size_t (*state_size)(void *comp);
    status_t (*state_save)(void *comp, void *buf, size_t size);
    status_t (*state_restore)(void *comp, const void *buf, size_t size);
} fmi_model_t;

extern const fmi_model_t fluid_fmi_model;
extern const fmi_model_t rigid_fmi_model;

/* Units used by the models: name and SI base-unit exponents kg, m, s, rad. */
typedef struct {
    const char *name;
    int kg, m, s, rad;
} fmi_unit_t;
extern const fmi_unit_t fmi_units[];
extern const int fmi_nunits;

/* Log categories of every FMU, in this order (modelDescription LogCategories):
 * messages of status warning, discard, error, fatal, informational messages
 * of the components, and a trace of every FMI call. */
enum { FMI_CAT_WARNING, FMI_CAT_DISCARD, FMI_CAT_ERROR, FMI_CAT_FATAL, FMI_CAT_INFO, FMI_CAT_CALLS, FMI_NCATS };
extern const char *const fmi_log_categories[FMI_NCATS][2]; /* name, description */

/* Variable list helpers (common/fmi_vars.c). fmi_vars_add returns the new
 * variable (zeroed, component -1) or NULL when memory runs out. The pointer
 * holds until the next add, which may move the list: fill each variable in
 * before adding another. */
fmi_var_t *fmi_vars_add(fmi_vars_t *vs, fmi_type_t type, fmi_causality_t causality, const char *unit,
                        const char *name_fmt, ...) __attribute__((format(printf, 5, 6)));
void fmi_vars_free(fmi_vars_t *vs);
/* Adds a Real parameter overriding scene key (component >= 0: element of a vector key). */
fmi_var_t *fmi_vars_param(fmi_vars_t *vs, const char *name, const char *key, int component, const char *unit,
                          double start, double min, double max, int range_flags, const char *description);

/* The drag-coefficient pair of sphere i for the implicit coupling (README
 * "Implicit coupling"): sphere[i].drag_coefficient (kg/s, what = what_t) and
 * sphere[i].rotational_drag_coefficient (kg.m2/s, what = what_r), outputs of
 * the fluid and inputs of the rigid FMU. Returns 0 when memory runs out. */
int fmi_vars_add_drag(fmi_vars_t *vs, fmi_causality_t causality, int i, int what_t, int what_r);

/* The GUID of an FMU: a 128-bit hash of the scene text it carries, written
 * as {8-4-4-4-12} hex digits (39 characters with the NUL). */
void fmi_guid(const char *model, const char *text, size_t len, char out[39]);

/* Whether the scene text gives key in the top-level mapping group (e.g.
 * "fluid", "tau"); -1 when the text cannot be parsed. */
int fmi_scene_has_key(const char *text, const char *group, const char *key);

#endif
