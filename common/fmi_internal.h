/* fmi_internal.h — what the parts of the generic FMI 2.0 layer share: the
 * instance, its states and the legal-state masks of each function, the
 * logging and checks every entry point uses, and the native component.
 *
 *   fmi_adapter.c   instantiation, lifecycle, stepping and status (the one
 *                   file compiled per model: -DFMI_MODEL names its table)
 *   fmi_instance.c  logging, call-order and argument checks, the native
 *                   component created from the scene and parameters
 *   fmi_values.c    fmi2Get* and fmi2Set*
 *   fmi_state.c     FMU state: get, set, free, serialise
 *
 * Every function here logs its own error through the FMI logger. */
#ifndef COMMON_FMI_INTERNAL_H
#define COMMON_FMI_INTERNAL_H

#include "fmi2.h"
#include "fmi_adapter.h"

#include <stddef.h>

#define STATE_MAGIC "SPHFMUS2" /* 2: the serialized state's checksum (fmi_state.c) */
#define TIME_TOL 1e-9 /* relative round-off allowed on communication points */

/* States of the co-simulation state machine. */
#define STATE_LIST(X)                            \
    X(S_INSTANTIATED, "Instantiated")            \
    X(S_INIT, "InitializationMode")              \
    X(S_STEP_COMPLETE, "StepComplete")           \
    X(S_STEP_IN_PROGRESS, "StepInProgress")      \
    X(S_STEP_FAILED, "StepFailed")               \
    X(S_STEP_CANCELED, "StepCanceled")           \
    X(S_TERMINATED, "Terminated")                \
    X(S_ERROR, "Error")                          \
    X(S_FATAL, "Fatal")

enum {
#define STATE_BIT(name, text) name##_BIT,
    STATE_LIST(STATE_BIT)
#undef STATE_BIT
        NSTATES
};
enum {
#define STATE_MASK(name, text) name = 1 << name##_BIT,
    STATE_LIST(STATE_MASK)
#undef STATE_MASK
};

/* Legal states per function (FMI 2.0, table in 4.2.4). */
#define M_ANY_BUT_FATAL (S_INSTANTIATED | S_INIT | S_STEP_COMPLETE | S_STEP_IN_PROGRESS | S_STEP_FAILED | \
                         S_STEP_CANCELED | S_TERMINATED | S_ERROR)
#define M_SET_DEBUG_LOGGING M_ANY_BUT_FATAL
#define M_SETUP_EXPERIMENT S_INSTANTIATED
#define M_ENTER_INIT S_INSTANTIATED
#define M_EXIT_INIT S_INIT
#define M_TERMINATE (S_STEP_COMPLETE | S_STEP_FAILED | S_STEP_CANCELED)
#define M_RESET (M_ANY_BUT_FATAL & ~S_STEP_IN_PROGRESS)
#define M_GET (S_INIT | S_STEP_COMPLETE | S_STEP_FAILED | S_STEP_CANCELED | S_TERMINATED | S_ERROR)
#define M_SET (S_INSTANTIATED | S_INIT | S_STEP_COMPLETE)
#define M_SET_PARAMETER (S_INSTANTIATED | S_INIT)
#define M_FMU_STATE (M_ANY_BUT_FATAL & ~S_STEP_IN_PROGRESS)
#define M_DIRECTIONAL (S_INIT | S_STEP_COMPLETE | S_STEP_FAILED | S_STEP_CANCELED | S_TERMINATED | S_ERROR)
#define M_SET_INPUT_DER (S_INSTANTIATED | S_INIT | S_STEP_COMPLETE)
#define M_GET_OUTPUT_DER (S_STEP_COMPLETE | S_STEP_FAILED | S_STEP_CANCELED | S_TERMINATED | S_ERROR)
#define M_DO_STEP S_STEP_COMPLETE
#define M_CANCEL_STEP S_STEP_IN_PROGRESS
#define M_GET_STATUS (S_STEP_COMPLETE | S_STEP_IN_PROGRESS | S_STEP_FAILED | S_STEP_CANCELED | S_TERMINATED)

typedef struct fmu_state fmu_state_t;

typedef struct inst inst_t;
struct inst {
    inst_t *live_next; /* the registry of live instances (fmi_instance.c) */
    char *name;
    const fmi_model_t *model; /* the model this FMU was built with (fmi_adapter.c) */
    fmi2CallbackLogger logger;
    fmi2ComponentEnvironment env;
    int logging_on;
    unsigned cat_mask; /* bit per fmi_log_categories entry */
    int state;
    log_t log;         /* native components log here */
    char *scene_path;  /* resources/scene.yaml */
    char guid[39];
    scene_t *base;     /* the scene as shipped: variables and start values */
    fmi_vars_t vars;
    double *values;    /* one per value reference */
    double *made_with; /* values when comp was created (parameters compared on restore) */
    char **strings;    /* per value reference: the text of a String variable, else NULL */
    int lazy_stale;    /* the lazy outputs in values[] are out of date */
    scene_t *scene;    /* the scene with parameters applied, alive while comp is */
    void *comp;
    double t, t_start, t_stop;
    int has_stop;
    fmu_state_t *lazy_states; /* the states whose native part is still comp itself */
};

/* An FMU state (fmi_state.c): header and values, then the component's
 * native state. fmi2GetFMUstate copies the header and values at once but
 * not the native part (the population arrays: as large as the grid): the
 * state stays lazy, the live component itself, until a call would change
 * the component (fmi_states_keep copies the native part first) or the
 * state is freed; serialised meanwhile, it is written straight from the
 * component. So a checkpoint (get, serialise, free) holds the serialised
 * bytes beside the component, not a copy as well. */
struct fmu_state {
    size_t size;          /* serialised bytes: header, values, native state */
    size_t head;          /* header and values, at the start of bytes */
    inst_t *owner;        /* the instance that made it (fmi2GetFMUstate, fmi2DeSerializeFMUstate): freed with it */
    fmu_state_t *live_next; /* the registry of live states (fmi_state.c) */
    inst_t *lazy;         /* the instance whose component holds the native part (the owner), or NULL: in bytes */
    fmu_state_t *next;    /* the instance's other lazy states */
    unsigned char *bytes; /* size bytes; head while lazy */
};

/* Copies the native part of every lazy state of the instance, before a call
 * changes its component (a step, a parameter set, a reset, another state
 * restored); fmi2Error (logged, nothing changed) when memory is short.
 * fmi_states_free: the instance is being freed, and with it every state it
 * made that the master has not freed (FMI 2.0, fmi2FreeInstance frees all
 * the memory the FMU allocated). Each FMU library keeps a registry of its
 * live states, as of its instances: a handle that is not one (freed already,
 * by fmi2FreeFMUstate or with its instance, or never returned) is refused,
 * never read or freed again. */
fmi2Status fmi_states_keep(inst_t *in, const char *fn);
void fmi_states_free(inst_t *in);

/* Logging (fmi_instance.c): through the FMI logger with the status as
 * category; errors always, other messages as fmi2SetDebugLogging asks.
 * The native components' log_t sink: ctx is the instance. */
void fmi_native_log(void *ctx, status_t level, const char *category, const char *msg);
void fmi_native_log_errors(void *ctx, status_t level, const char *category, const char *msg);
/* "fn: message" as an error; returns fmi2Error. */
__attribute__((format(printf, 3, 4))) fmi2Status fmi_fail(const inst_t *in, const char *fn, const char *fmt, ...);
/* "fn: message" at level; returns it as an fmi2Status. */
__attribute__((format(printf, 4, 5))) fmi2Status fmi_report(const inst_t *in, status_t level, const char *fn,
                                                            const char *fmt, ...);
/* "fn(arguments)" in the logFmiCalls category, when it is on. */
__attribute__((format(printf, 3, 4))) void fmi_trace(const inst_t *in, const char *fn, const char *fmt, ...);

/* The registry of live instances (fmi_instance.c), one per FMU library and
 * guarded by a mutex: an instance is added when fmi2Instantiate succeeds and
 * taken out by fmi2FreeInstance. A handle is looked up by its address before
 * anything behind it is read, so a freed or stray pointer is never touched.
 * fmi_instance: the live instance behind c, or NULL (also for NULL).
 * fmi_instance_take: the same, and removed from the registry (to be freed);
 * a second take of one instance gives NULL. */
void fmi_instance_add(inst_t *in);
inst_t *fmi_instance(fmi2Component c);
inst_t *fmi_instance_take(fmi2Component c);
/* 1 (logged) when the instance's state is not in mask. */
int fmi_illegal(const inst_t *in, const char *fn, int mask);
/* The name of a state (one bit of the masks), as the messages give it. */
const char *fmi_state_name(int state);
/* 1 (logged) when a value reference does not exist or is not of type. */
int fmi_bad_refs(const inst_t *in, const char *fn, const fmi2ValueReference vr[], size_t nvr, const void *values,
                 fmi_type_t type);

/* The start of every entry point on an instance: a handle that is not a live
 * instance (never one, or freed) returns fmi2Error, with nothing logged (its
 * logger is unknown); a call in a state the function is not legal in returns
 * fmi2Error (logged). */
#define BEGIN(fn, mask)                      \
    inst_t *in = fmi_instance(c);                \
    if (in == NULL) {                        \
        return fmi2Error;                    \
    }                                        \
    if (fmi_illegal(in, fn, mask)) {             \
        return fmi2Error;                    \
    }

/* The native component (fmi_instance.c): freed, or created from the scene
 * with the parameters applied when it does not exist yet. */
void fmi_drop_component(inst_t *in);
status_t fmi_ensure_component(inst_t *in, const char *fn);

#endif
