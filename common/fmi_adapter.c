/* fmi_adapter.c — the generic FMI 2.0 Co-Simulation layer (all fmi2* entry points).
 *
 * Compiled once per FMU with -DFMI_MODEL=fluid_fmi_model (or rigid_fmi_model):
 * the model table (common/fmi_adapter.h) supplies the variables and the
 * native calls, this file everything FMI asks of an FMU:
 *
 * - Call order: every function names the states it is legal in as a bit mask
 *   (FMI 2.0, section 4.2.4, state machine of a co-simulation slave). A call
 *   in another state, a bad instance pointer or a bad argument (unknown value
 *   reference, wrong type, NULL array with nvr > 0, non-finite Real, value out
 *   of range, setting an output or a fixed parameter after initialisation,
 *   step size <= 0, a communication point that is not the FMU's time) is
 *   answered with fmi2Error and a message through the logger and has no
 *   effect: the instance stays in its state. A failure during the work itself
 *   (a step, creating the component) moves the instance to the Error state
 *   (fmi2Fatal: Fatal state), from which fmi2SetFMUstate or fmi2Reset recover.
 * - Lifecycle: the scene (resources/scene.yaml) is read at fmi2Instantiate to
 *   know the variables; the native component is created from the scene with
 *   the parameters applied as "key=value" overrides when first needed: at
 *   fmi2ExitInitializationMode or when an output is read in Initialization
 *   Mode (setting a parameter afterwards, still in Initialization Mode,
 *   discards it so the next use re-creates it).
 * - Values: one double per value reference; outputs are refreshed after
 *   creation, each step and each state restore.
 * - FMU state: one self-contained byte blob (header, values, native state),
 *   so get/set and serialise/deserialise share one format.
 * - Logging: native log_t messages and our own go to the FMI logger with the
 *   matching status; never stderr. Errors are always sent, other messages
 *   according to fmi2SetDebugLogging and the categories (fmi_log_categories).
 *
 * No global mutable state: any number of instances may coexist. */
#include "fmi2.h"
#include "fmi_adapter.h"

#include <ctype.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef FMI_MODEL
#error "compile fmi_adapter.c with -DFMI_MODEL=fluid_fmi_model or -DFMI_MODEL=rigid_fmi_model"
#endif
#define MODEL (&FMI_MODEL)

#define INSTANCE_MAGIC 0x53504649u /* "SPFI": tells an instance from a stray pointer */
#define STATE_MAGIC "SPHFMUS1"
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
static const char *const STATE_NAMES[NSTATES] = {
#define STATE_NAME(name, text) text,
    STATE_LIST(STATE_NAME)
#undef STATE_NAME
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

typedef struct {
    unsigned magic;
    char *name;
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
} inst_t;

typedef struct {
    size_t size;
    unsigned char bytes[];
} fmu_state_t;

/* ------------------------------------------------------------------------ */
/* Logging                                                                   */

static void emit(const inst_t *in, status_t level, int cat, const char *msg)
{
    if (in->logger == NULL) {
        return;
    }
    const int enabled = (in->cat_mask >> cat) & 1u;
    if (!(level >= STATUS_ERROR || (enabled && (in->logging_on || level >= STATUS_WARNING)))) {
        return;
    }
    /* the logger takes a printf format: double every '%' */
    char buf[4096];
    size_t k = 0;
    for (const char *p = msg; *p != '\0' && k + 2 < sizeof buf; p++) {
        buf[k++] = *p;
        if (*p == '%') {
            buf[k++] = '%';
        }
    }
    buf[k] = '\0';
    in->logger(in->env, in->name, (fmi2Status)level, fmi_log_categories[cat][0], buf);
}

static int level_category(status_t level)
{
    switch (level) {
    case STATUS_OK:
        return FMI_CAT_INFO;
    case STATUS_WARNING:
        return FMI_CAT_WARNING;
    case STATUS_DISCARD:
        return FMI_CAT_DISCARD;
    case STATUS_ERROR:
        return FMI_CAT_ERROR;
    case STATUS_FATAL:
        return FMI_CAT_FATAL;
    }
    return FMI_CAT_ERROR;
}

/* The log_t sink given to scene_load and the native components. */
static void native_log(void *ctx, status_t level, const char *category, const char *msg)
{
    char buf[3000];
    snprintf(buf, sizeof buf, "[%s] %s", category != NULL ? category : "-", msg);
    emit(ctx, level, level_category(level), buf);
}

static fmi2Status vreport(const inst_t *in, status_t level, const char *fn, const char *fmt, va_list ap)
{
    char msg[2500], buf[2700];
    vsnprintf(msg, sizeof msg, fmt, ap);
    snprintf(buf, sizeof buf, "%s: %s", fn, msg);
    emit(in, level, level_category(level), buf);
    return (fmi2Status)level;
}

__attribute__((format(printf, 3, 4))) static fmi2Status fail(const inst_t *in, const char *fn, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vreport(in, STATUS_ERROR, fn, fmt, ap);
    va_end(ap);
    return fmi2Error;
}

__attribute__((format(printf, 4, 5))) static fmi2Status report(const inst_t *in, status_t level, const char *fn,
                                                               const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vreport(in, level, fn, fmt, ap);
    va_end(ap);
    return (fmi2Status)level;
}

__attribute__((format(printf, 3, 4))) static void trace(const inst_t *in, const char *fn, const char *fmt, ...)
{
    if (!in->logging_on || !((in->cat_mask >> FMI_CAT_CALLS) & 1u) || in->logger == NULL) {
        return;
    }
    char msg[1024], buf[1200];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    snprintf(buf, sizeof buf, "%s(%s)", fn, msg);
    emit(in, STATUS_OK, FMI_CAT_CALLS, buf);
}

/* ------------------------------------------------------------------------ */
/* Instance and state checks                                                 */

static inst_t *instance(fmi2Component c)
{
    inst_t *in = c;
    return in != NULL && in->magic == INSTANCE_MAGIC ? in : NULL;
}

static void state_list(int mask, char *buf, size_t n)
{
    buf[0] = '\0';
    for (int s = 0; s < NSTATES; s++) {
        if (mask & (1 << s)) {
            size_t len = strlen(buf);
            snprintf(buf + len, n - len, "%s%s", len > 0 ? ", " : "", STATE_NAMES[s]);
        }
    }
}

static int state_index(int state)
{
    for (int s = 0; s < NSTATES; s++) {
        if (state == (1 << s)) {
            return s;
        }
    }
    return S_ERROR_BIT;
}

/* NULL when the call may go on; otherwise the error has been logged. */
static int illegal(const inst_t *in, const char *fn, int mask)
{
    if (in->state & mask) {
        return 0;
    }
    char allowed[400];
    state_list(mask, allowed, sizeof allowed);
    fail(in, fn, "illegal call sequence: the FMU is in state %s; allowed in: %s", STATE_NAMES[state_index(in->state)],
         allowed);
    return 1;
}

#define BEGIN(fn, mask)                      \
    inst_t *in = instance(c);                \
    if (in == NULL) {                        \
        return fmi2Error;                    \
    }                                        \
    if (illegal(in, fn, mask)) {             \
        return fmi2Error;                    \
    }

static const char *type_name(fmi_type_t t)
{
    return t == FMI_REAL ? "Real" : t == FMI_INTEGER ? "Integer" : t == FMI_BOOLEAN ? "Boolean" : "String";
}

/* Value references exist and have the type of the function. */
static int bad_refs(const inst_t *in, const char *fn, const fmi2ValueReference vr[], size_t nvr, const void *values,
                    fmi_type_t type)
{
    if (nvr > 0 && (vr == NULL || values == NULL)) {
        fail(in, fn, "nvr = %zu but the %s array is NULL", nvr, vr == NULL ? "value reference" : "value");
        return 1;
    }
    for (size_t i = 0; i < nvr; i++) {
        if (vr[i] >= (fmi2ValueReference)in->vars.n) {
            fail(in, fn, "value reference %u does not exist; allowed: 0 to %d", vr[i], in->vars.n - 1);
            return 1;
        }
        const fmi_var_t *v = &in->vars.v[vr[i]];
        if (v->type != type) {
            fail(in, fn, "value reference %u (%s) is of type %s, not %s", vr[i], v->name, type_name(v->type),
                 type_name(type));
            return 1;
        }
    }
    return 0;
}

/* ------------------------------------------------------------------------ */
/* The native component                                                      */

static void drop_component(inst_t *in)
{
    if (in->comp != NULL) {
        MODEL->free(in->comp);
        in->comp = NULL;
    }
    scene_free(in->scene);
    in->scene = NULL;
}

static int vector_first(const inst_t *in, int j)
{
    for (int i = 0; i < j; i++) {
        if (in->vars.v[i].causality == FMI_PARAMETER && strcmp(in->vars.v[i].key, in->vars.v[j].key) == 0) {
            return 0;
        }
    }
    return 1;
}

/* "key=value" for a parameter that differs from its start value; a vector
 * key is written whole, once, at its first variable. 0: nothing to write. */
static int parameter_override(const inst_t *in, int j, char *buf, size_t n)
{
    const fmi_var_t *v = &in->vars.v[j];
    if (v->component < 0) {
        if (in->values[j] == v->start) {
            return 0;
        }
        snprintf(buf, n, "%s=%.17g", v->key, in->values[j]);
        return 1;
    }
    if (!vector_first(in, j)) {
        return 0;
    }
    double vec[3] = {0.0, 0.0, 0.0};
    int changed = 0;
    for (int i = j; i < in->vars.n; i++) {
        const fmi_var_t *w = &in->vars.v[i];
        if (w->causality == FMI_PARAMETER && w->component >= 0 && w->component < 3 && strcmp(w->key, v->key) == 0) {
            vec[w->component] = in->values[i];
            changed |= in->values[i] != w->start;
        }
    }
    if (!changed) {
        return 0;
    }
    snprintf(buf, n, "%s=[%.17g, %.17g, %.17g]", v->key, vec[0], vec[1], vec[2]);
    return 1;
}

/* Creates the component from the scene with the parameters applied. */
static status_t ensure_component(inst_t *in, const char *fn)
{
    if (in->comp != NULL) {
        return STATUS_OK;
    }
    int nov = 0;
    char **ov = calloc((size_t)in->vars.n + 1, sizeof *ov);
    status_t st = STATUS_OK;
    if (ov == NULL) {
        report(in, STATUS_FATAL, fn, "out of memory for the parameter overrides (%zu bytes)", ((size_t)in->vars.n + 1) * sizeof *ov);
        st = STATUS_FATAL;
        goto done;
    }
    for (int j = 0; j < in->vars.n; j++) {
        char buf[FMI_KEY_MAX + 100];
        if (in->vars.v[j].causality == FMI_PARAMETER && parameter_override(in, j, buf, sizeof buf)) {
            if ((ov[nov] = strdup(buf)) == NULL) {
                report(in, STATUS_FATAL, fn, "out of memory for a parameter override (%zu bytes)", strlen(buf) + 1);
                st = STATUS_FATAL;
                goto done;
            }
            report(in, STATUS_OK, fn, "parameter applied to the scene: %s", ov[nov]);
            nov++;
        }
    }
    st = scene_load(in->scene_path, (const char *const *)ov, nov, &in->log, &in->scene);
    if (st >= STATUS_ERROR) {
        report(in, st, fn, "the scene %s with the parameters set cannot be used (see the messages above)",
               in->scene_path);
        goto done;
    }
    st = MODEL->create(in->scene, in->t_start, &in->log, &in->comp);
    if (st >= STATUS_ERROR) {
        in->comp = NULL;
        report(in, st, fn, "the %s component cannot be created (see the messages above)", MODEL->identifier);
        goto done;
    }
    for (int j = 0; j < in->vars.n && MODEL->set_string != NULL; j++) {
        if (in->strings[j] != NULL) {
            st = status_worst(st, MODEL->set_string(in->comp, &in->vars.v[j], in->strings[j], &in->log));
            if (st >= STATUS_ERROR) {
                report(in, st, fn, "%s = '%s' cannot be used (see the messages above)", in->vars.v[j].name,
                       in->strings[j]);
                goto done;
            }
        }
    }
    memcpy(in->made_with, in->values, (size_t)in->vars.n * sizeof(double));
    MODEL->outputs(in->comp, &in->vars, in->values);
    in->lazy_stale = 1;
done:
    if (st >= STATUS_ERROR) {
        drop_component(in);
    }
    for (int k = 0; ov != NULL && k < nov; k++) {
        free(ov[k]);
    }
    free(ov);
    return st;
}

/* ------------------------------------------------------------------------ */
/* Common functions                                                          */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    BEGIN("fmi2SetDebugLogging", M_SET_DEBUG_LOGGING);
    if (nCategories > 0 && categories == NULL) {
        return fail(in, "fmi2SetDebugLogging", "nCategories = %zu but categories is NULL", nCategories);
    }
    unsigned mask = nCategories == 0 ? (1u << FMI_NCATS) - 1u : 0u;
    for (size_t i = 0; i < nCategories; i++) {
        int found = -1;
        for (int k = 0; k < FMI_NCATS && categories[i] != NULL; k++) {
            if (strcmp(categories[i], fmi_log_categories[k][0]) == 0) {
                found = k;
            }
        }
        if (found < 0) {
            return fail(in, "fmi2SetDebugLogging",
                        "unknown log category '%s'; allowed: logStatusWarning, logStatusDiscard, logStatusError, "
                        "logStatusFatal, logInfo, logCalls",
                        categories[i] != NULL ? categories[i] : "(null)");
        }
        mask |= 1u << found;
    }
    in->logging_on = loggingOn != fmi2False;
    in->cat_mask = mask;
    trace(in, "fmi2SetDebugLogging", "loggingOn=%d, nCategories=%zu", loggingOn, nCategories);
    return fmi2OK;
}

/* file:///abs/path, file://localhost/abs/path or file:/abs/path, with
 * %XX escapes; returns a malloc'd "path/scene.yaml" or NULL. */
static char *resource_scene_path(const char *uri)
{
    const char *p;
    if (strncmp(uri, "file://localhost/", 17) == 0) {
        p = uri + 16;
    } else if (strncmp(uri, "file:///", 8) == 0) {
        p = uri + 7;
    } else if (strncmp(uri, "file:/", 6) == 0 && uri[6] != '/') {
        p = uri + 5;
    } else {
        return NULL;
    }
    size_t n = strlen(p);
    char *out = malloc(n + sizeof "/scene.yaml");
    if (out == NULL) {
        return NULL;
    }
    size_t k = 0;
    for (size_t i = 0; i < n; i++) {
        unsigned hex;
        if (p[i] == '%' && i + 2 < n && isxdigit((unsigned char)p[i + 1]) && isxdigit((unsigned char)p[i + 2]) &&
            sscanf(p + i + 1, "%2x", &hex) == 1) {
            out[k++] = (char)hex;
            i += 2;
        } else {
            out[k++] = p[i];
        }
    }
    while (k > 1 && out[k - 1] == '/') {
        k--;
    }
    memcpy(out + k, "/scene.yaml", sizeof "/scene.yaml");
    return out;
}

/* Reads a whole file; NULL with errno-style message in msg on failure. */
static char *read_text(const char *path, size_t *len, char *msg, size_t n)
{
    char *text = NULL;
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        snprintf(msg, n, "cannot open %s", path);
        return NULL;
    }
    size_t cap = 0, used = 0;
    for (;;) {
        if (used + 4096 + 1 > cap) {
            cap = cap > 0 ? 2 * cap : 16384;
            char *t = realloc(text, cap);
            if (t == NULL) {
                snprintf(msg, n, "out of memory reading %s", path);
                goto fail;
            }
            text = t;
        }
        size_t got = fread(text + used, 1, cap - used - 1, f);
        used += got;
        if (got == 0) {
            break;
        }
    }
    if (ferror(f)) {
        snprintf(msg, n, "cannot read %s", path);
        goto fail;
    }
    fclose(f);
    text[used] = '\0';
    *len = used;
    return text;
fail:
    fclose(f);
    free(text);
    return NULL;
}

static void free_instance(inst_t *in)
{
    drop_component(in);
    scene_free(in->base);
    fmi_vars_free(&in->vars);
    for (int j = 0; in->strings != NULL && j < in->vars.n; j++) {
        free(in->strings[j]);
    }
    free(in->strings);
    free(in->values);
    free(in->made_with);
    free(in->scene_path);
    free(in->name);
    in->magic = 0;
    free(in);
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn)
{
    (void)visible;
    const char *fn = "fmi2Instantiate";
    if (functions == NULL) {
        return NULL;
    }
    inst_t *in = calloc(1, sizeof *in);
    if (in == NULL) {
        if (functions->logger != NULL) {
            functions->logger(functions->componentEnvironment, instanceName, fmi2Fatal,
                              fmi_log_categories[FMI_CAT_FATAL][0], "fmi2Instantiate: out of memory for the instance (%zu bytes)", sizeof *in);
        }
        return NULL;
    }
    in->magic = INSTANCE_MAGIC;
    in->logger = functions->logger;
    in->env = functions->componentEnvironment;
    in->logging_on = loggingOn != fmi2False;
    in->cat_mask = (1u << FMI_NCATS) - 1u;
    in->state = S_INSTANTIATED;
    in->log = (log_t){native_log, in};
    in->name = strdup(instanceName != NULL ? instanceName : "");
    if (in->name == NULL) {
        report(in, STATUS_FATAL, fn, "out of memory for the instance name (%zu bytes)", strlen(instanceName) + 1);
        goto fail;
    }
    if (instanceName == NULL || instanceName[0] == '\0') {
        fail(in, fn, "instanceName is %s; allowed: a non-empty string", instanceName == NULL ? "NULL" : "empty");
        goto fail;
    }
    if (fmuType != fmi2CoSimulation) {
        fail(in, fn, "fmuType = %d: the %s FMU supports Co-Simulation only (fmi2CoSimulation = %d)", (int)fmuType,
             MODEL->identifier, (int)fmi2CoSimulation);
        goto fail;
    }
    if (fmuResourceLocation == NULL || (in->scene_path = resource_scene_path(fmuResourceLocation)) == NULL) {
        fail(in, fn, "fmuResourceLocation '%s' is not a file URI (file:///...) of the FMU's resources folder",
             fmuResourceLocation != NULL ? fmuResourceLocation : "(null)");
        goto fail;
    }
    char msg[600];
    size_t len = 0;
    char *text = read_text(in->scene_path, &len, msg, sizeof msg);
    if (text == NULL) {
        fail(in, fn, "%s (the FMU carries its scene as resources/scene.yaml)", msg);
        goto fail;
    }
    fmi_guid(MODEL->identifier, text, len, in->guid);
    free(text);
    if (fmuGUID == NULL || strcmp(fmuGUID, in->guid) != 0) {
        fail(in, fn, "fmuGUID %s does not match the GUID %s of this FMU's scene; was the FMU unpacked over another?",
             fmuGUID != NULL ? fmuGUID : "(null)", in->guid);
        goto fail;
    }
    if (scene_load(in->scene_path, NULL, 0, &in->log, &in->base) >= STATUS_ERROR) {
        fail(in, fn, "the scene %s cannot be read (see the messages above)", in->scene_path);
        goto fail;
    }
    status_t st = MODEL->variables(in->base, &in->log, &in->vars);
    if (st == STATUS_DISCARD) {
        fail(in, fn, "the scene %s needs no %s FMU (it has no free bodies)", in->scene_path, MODEL->identifier);
        goto fail;
    }
    if (st != STATUS_OK) {
        fail(in, fn, "no %s variables for the scene %s (see the messages above)", MODEL->identifier, in->scene_path);
        goto fail;
    }
    in->values = calloc((size_t)in->vars.n + 1, sizeof(double));
    in->made_with = calloc((size_t)in->vars.n + 1, sizeof(double));
    in->strings = calloc((size_t)in->vars.n + 1, sizeof(char *));
    if (in->values == NULL || in->made_with == NULL || in->strings == NULL) {
        report(in, STATUS_FATAL, fn, "out of memory for the values of %d variables (%zu bytes)", in->vars.n, ((size_t)in->vars.n + 1) * (2 * sizeof(double) + sizeof(char *)));
        goto fail;
    }
    for (int j = 0; j < in->vars.n; j++) {
        if (in->vars.v[j].type == FMI_STRING && (in->strings[j] = strdup("")) == NULL) {
            report(in, STATUS_FATAL, fn, "out of memory for an empty String value (1 byte)");
            goto fail;
        }
    }
    for (int j = 0; j < in->vars.n; j++) {
        in->values[j] = in->vars.v[j].start;
    }
    trace(in, fn, "instanceName=%s, fmuGUID=%s, fmuResourceLocation=%s, loggingOn=%d", instanceName, fmuGUID,
          fmuResourceLocation, loggingOn);
    return in;
fail:
    free_instance(in);
    return NULL;
}

void fmi2FreeInstance(fmi2Component c)
{
    /* legal in every state: a master must be able to release an FMU it gave up on */
    inst_t *in = instance(c);
    if (in == NULL) {
        return;
    }
    trace(in, "fmi2FreeInstance", "%s", "");
    free_instance(in);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    const char *fn = "fmi2SetupExperiment";
    BEGIN(fn, M_SETUP_EXPERIMENT);
    trace(in, fn, "toleranceDefined=%d, tolerance=%.17g, startTime=%.17g, stopTimeDefined=%d, stopTime=%.17g",
          toleranceDefined, tolerance, startTime, stopTimeDefined, stopTime);
    if (!isfinite(startTime)) {
        return fail(in, fn, "startTime = %g; allowed: a finite time", startTime);
    }
    if (stopTimeDefined && !(isfinite(stopTime) && stopTime >= startTime)) {
        return fail(in, fn, "stopTime = %g; allowed: a finite time >= startTime = %g", stopTime, startTime);
    }
    if (toleranceDefined) {
        report(in, STATUS_OK, fn, "tolerance %g ignored: the tolerances come from the scene (rigid.rtol, rigid.atol)",
               tolerance);
    }
    in->t_start = startTime;
    in->t = startTime;
    in->has_stop = stopTimeDefined != fmi2False;
    in->t_stop = stopTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    BEGIN("fmi2EnterInitializationMode", M_ENTER_INIT);
    trace(in, "fmi2EnterInitializationMode", "%s", "");
    in->state = S_INIT;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    const char *fn = "fmi2ExitInitializationMode";
    BEGIN(fn, M_EXIT_INIT);
    trace(in, fn, "%s", "");
    status_t st = ensure_component(in, fn);
    if (st >= STATUS_ERROR) {
        in->state = st == STATUS_FATAL ? S_FATAL : S_ERROR;
        return (fmi2Status)st;
    }
    in->t = in->t_start;
    in->state = S_STEP_COMPLETE;
    return (fmi2Status)st;
}

fmi2Status fmi2Terminate(fmi2Component c)
{
    BEGIN("fmi2Terminate", M_TERMINATE);
    trace(in, "fmi2Terminate", "%s", "");
    in->state = S_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c)
{
    BEGIN("fmi2Reset", M_RESET);
    trace(in, "fmi2Reset", "%s", "");
    drop_component(in);
    for (int j = 0; j < in->vars.n; j++) {
        in->values[j] = in->vars.v[j].start;
    }
    in->t = in->t_start = 0.0;
    in->has_stop = 0;
    in->state = S_INSTANTIATED;
    return fmi2OK;
}

/* ------------------------------------------------------------------------ */
/* Getters and setters                                                       */

/* Reading an output in Initialization Mode creates the component. */
static fmi2Status prepare_get(inst_t *in, const char *fn, const fmi2ValueReference vr[], size_t nvr)
{
    if (in->comp != NULL || in->state != S_INIT) {
        return fmi2OK;
    }
    for (size_t i = 0; i < nvr; i++) {
        if (in->vars.v[vr[i]].causality == FMI_OUTPUT) {
            status_t st = ensure_component(in, fn);
            if (st >= STATUS_ERROR) {
                in->state = st == STATUS_FATAL ? S_FATAL : S_ERROR;
            }
            return (fmi2Status)st;
        }
    }
    return fmi2OK;
}

static fmi2Status get_values(fmi2Component c, const char *fn, fmi_type_t type, const fmi2ValueReference vr[],
                             size_t nvr, void *value)
{
    BEGIN(fn, M_GET);
    if (bad_refs(in, fn, vr, nvr, value, type)) {
        return fmi2Error;
    }
    fmi2Status st = prepare_get(in, fn, vr, nvr);
    if (st >= fmi2Error) {
        return st;
    }
    for (size_t i = 0; i < nvr && in->lazy_stale && in->comp != NULL; i++) {
        if (in->vars.v[vr[i]].lazy) {
            const status_t lst = MODEL->lazy_outputs(in->comp, &in->vars, in->values);
            if (lst >= STATUS_ERROR) {
                /* the component found its state broken (e.g. NaN in the
                 * fluid): no value is handed out, the instance stops */
                in->state = lst == STATUS_FATAL ? S_FATAL : S_ERROR;
                return report(in, lst, fn, "the %s outputs at t = %.17g s cannot be computed (see the message "
                              "above); restore a saved FMU state or reset", MODEL->identifier, in->t);
            }
            in->lazy_stale = 0;
        }
    }
    for (size_t i = 0; i < nvr; i++) {
        const double x = in->values[vr[i]];
        if (type == FMI_REAL) {
            ((fmi2Real *)value)[i] = x;
        } else if (type == FMI_INTEGER) {
            ((fmi2Integer *)value)[i] = (fmi2Integer)x;
        } else {
            ((fmi2Boolean *)value)[i] = x != 0.0 ? fmi2True : fmi2False;
        }
    }
    return st;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[])
{
    return get_values(c, "fmi2GetReal", FMI_REAL, vr, nvr, value);
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[])
{
    return get_values(c, "fmi2GetInteger", FMI_INTEGER, vr, nvr, value);
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[])
{
    return get_values(c, "fmi2GetBoolean", FMI_BOOLEAN, vr, nvr, value);
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[])
{
    BEGIN("fmi2GetString", M_GET);
    if (bad_refs(in, "fmi2GetString", vr, nvr, value, FMI_STRING)) {
        return fmi2Error;
    }
    for (size_t i = 0; i < nvr; i++) {
        value[i] = in->strings[vr[i]];
    }
    return fmi2OK;
}

static void format_range(const fmi_var_t *v, char *buf, size_t n)
{
    snprintf(buf, n, "%c%.17g, %.17g%c", (v->range_flags & FMI_LO_OPEN) ? '(' : '[', v->min, v->max,
             (v->range_flags & FMI_HI_OPEN) ? ')' : ']');
}

static int in_range(const fmi_var_t *v, double x)
{
    const int lo = (v->range_flags & FMI_LO_OPEN) ? x > v->min : x >= v->min;
    const int hi = (v->range_flags & FMI_HI_OPEN) ? x < v->max : x <= v->max;
    return lo && hi;
}

/* All values are checked before any is stored: a rejected call has no effect. */
static fmi2Status set_values(fmi2Component c, const char *fn, fmi_type_t type, const fmi2ValueReference vr[],
                             size_t nvr, const void *value)
{
    BEGIN(fn, M_SET);
    if (bad_refs(in, fn, vr, nvr, value, type)) {
        return fmi2Error;
    }
    int parameters = 0;
    for (size_t i = 0; i < nvr; i++) {
        const fmi_var_t *v = &in->vars.v[vr[i]];
        const double x = type == FMI_REAL      ? ((const fmi2Real *)value)[i]
                         : type == FMI_INTEGER ? (double)((const fmi2Integer *)value)[i]
                                               : (double)((const fmi2Boolean *)value)[i];
        if (v->causality == FMI_OUTPUT) {
            return fail(in, fn, "%s (value reference %u) is an output and cannot be set", v->name, vr[i]);
        }
        if (v->causality == FMI_PARAMETER && !(in->state & M_SET_PARAMETER)) {
            return fail(in, fn,
                        "%s (value reference %u) is a fixed parameter: set it before fmi2ExitInitializationMode "
                        "(state now %s)",
                        v->name, vr[i], STATE_NAMES[state_index(in->state)]);
        }
        if (!isfinite(x)) {
            return fail(in, fn, "%s (value reference %u) = %g; allowed: a finite value", v->name, vr[i], x);
        }
        if (v->causality == FMI_PARAMETER && !in_range(v, x)) {
            char range[120];
            format_range(v, range, sizeof range);
            return fail(in, fn, "%s (value reference %u) = %.17g is out of range; allowed: %s%s%s", v->name, vr[i], x,
                        range, v->unit != NULL ? " " : "", v->unit != NULL ? v->unit : "");
        }
        parameters |= v->causality == FMI_PARAMETER;
    }
    for (size_t i = 0; i < nvr; i++) {
        const double x = type == FMI_REAL      ? ((const fmi2Real *)value)[i]
                         : type == FMI_INTEGER ? (double)((const fmi2Integer *)value)[i]
                                               : (((const fmi2Boolean *)value)[i] != fmi2False ? 1.0 : 0.0);
        trace(in, fn, "%s = %.17g", in->vars.v[vr[i]].name, x);
        in->values[vr[i]] = x;
    }
    if (parameters && in->comp != NULL) {
        /* only in Initialization Mode: the next use re-creates it */
        report(in, STATUS_OK, fn, "parameter changed: the component will be re-created");
        drop_component(in);
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[])
{
    return set_values(c, "fmi2SetReal", FMI_REAL, vr, nvr, value);
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[])
{
    return set_values(c, "fmi2SetInteger", FMI_INTEGER, vr, nvr, value);
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[])
{
    return set_values(c, "fmi2SetBoolean", FMI_BOOLEAN, vr, nvr, value);
}

/* String variables are parameters: set before fmi2ExitInitializationMode. */
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[])
{
    const char *fn = "fmi2SetString";
    BEGIN(fn, M_SET);
    if (bad_refs(in, fn, vr, nvr, value, FMI_STRING)) {
        return fmi2Error;
    }
    for (size_t i = 0; i < nvr; i++) {
        const fmi_var_t *v = &in->vars.v[vr[i]];
        if (v->causality != FMI_PARAMETER || !(in->state & M_SET_PARAMETER)) {
            return fail(in, fn, "%s (value reference %u) is a fixed parameter: set it before "
                        "fmi2ExitInitializationMode (state now %s)", v->name, vr[i],
                        STATE_NAMES[state_index(in->state)]);
        }
        if (value[i] == NULL) {
            return fail(in, fn, "%s (value reference %u) = NULL; allowed: a string (\"\" for none)", v->name, vr[i]);
        }
    }
    for (size_t i = 0; i < nvr; i++) {
        char *copy = strdup(value[i]);
        if (copy == NULL) {
            return fail(in, fn, "out of memory for a String value (%zu bytes)", strlen(value[i]) + 1);
        }
        trace(in, fn, "%s = '%s'", in->vars.v[vr[i]].name, copy);
        free(in->strings[vr[i]]);
        in->strings[vr[i]] = copy;
    }
    if (nvr > 0 && in->comp != NULL) {
        report(in, STATUS_OK, fn, "parameter changed: the component will be re-created");
        drop_component(in);
    }
    return fmi2OK;
}

/* ------------------------------------------------------------------------ */
/* FMU state: header | values (nvars doubles) | native state.               */

typedef struct {
    char magic[8];
    char model[16];
    char guid[40];
    uint64_t nvars, comp_size;
    int32_t state, has_comp, has_stop, pad;
    double t, t_start, t_stop;
} state_header_t;

static fmi2Status save_state(inst_t *in, const char *fn, fmu_state_t **out)
{
    state_header_t h;
    memset(&h, 0, sizeof h);
    memcpy(h.magic, STATE_MAGIC, sizeof h.magic);
    snprintf(h.model, sizeof h.model, "%s", MODEL->identifier);
    memcpy(h.guid, in->guid, sizeof in->guid);
    h.nvars = (uint64_t)in->vars.n;
    h.comp_size = in->comp != NULL ? (uint64_t)MODEL->state_size(in->comp) : 0u;
    h.state = in->state;
    h.has_comp = in->comp != NULL;
    h.has_stop = in->has_stop;
    h.t = in->t;
    h.t_start = in->t_start;
    h.t_stop = in->t_stop;
    const size_t nval = (size_t)in->vars.n * sizeof(double);
    const size_t size = sizeof h + 2 * nval + (size_t)h.comp_size;
    fmu_state_t *s = malloc(sizeof *s + size);
    if (s == NULL) {
        return fail(in, fn, "out of memory for an FMU state of %zu bytes", size);
    }
    s->size = size;
    memcpy(s->bytes, &h, sizeof h);
    memcpy(s->bytes + sizeof h, in->values, nval);
    memcpy(s->bytes + sizeof h + nval, in->made_with, nval);
    if (in->comp != NULL) {
        status_t st = MODEL->state_save(in->comp, s->bytes + sizeof h + 2 * nval, (size_t)h.comp_size);
        if (st >= STATUS_ERROR) {
            free(s);
            return report(in, st, fn, "the %s component could not save its state", MODEL->identifier);
        }
    }
    *out = s;
    return fmi2OK;
}

/* Checks that a blob was made by an FMU of this model and scene. */
static fmi2Status check_blob(const inst_t *in, const char *fn, const unsigned char *bytes, size_t size,
                             state_header_t *h)
{
    if (size < sizeof *h) {
        return fail(in, fn, "the FMU state has %zu bytes, fewer than its header (%zu)", size, sizeof *h);
    }
    memcpy(h, bytes, sizeof *h);
    if (memcmp(h->magic, STATE_MAGIC, sizeof h->magic) != 0) {
        return fail(in, fn, "not an FMU state of this project (bad magic)");
    }
    h->model[sizeof h->model - 1] = '\0';
    h->guid[sizeof h->guid - 1] = '\0';
    if (strcmp(h->model, MODEL->identifier) != 0 || strcmp(h->guid, in->guid) != 0) {
        return fail(in, fn, "the FMU state belongs to model %s with GUID %s; this is %s with GUID %s", h->model,
                    h->guid, MODEL->identifier, in->guid);
    }
    const size_t nval = (size_t)in->vars.n * sizeof(double);
    if (h->nvars != (uint64_t)in->vars.n || size != sizeof *h + 2 * nval + h->comp_size ||
        (h->has_comp == 0) != (h->comp_size == 0) || h->state <= 0 || h->state >= (1 << NSTATES) ||
        (h->state & (h->state - 1)) != 0) {
        return fail(in, fn, "the FMU state is inconsistent (%zu bytes, %llu variables, component %llu bytes)", size,
                    (unsigned long long)h->nvars, (unsigned long long)h->comp_size);
    }
    return fmi2OK;
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    const char *fn = "fmi2GetFMUstate";
    BEGIN(fn, M_FMU_STATE);
    if (FMUstate == NULL) {
        return fail(in, fn, "FMUstate is NULL");
    }
    trace(in, fn, "t=%.17g", in->t);
    fmu_state_t *s = NULL;
    fmi2Status st = save_state(in, fn, &s);
    if (st >= fmi2Error) {
        return st;
    }
    free(*FMUstate); /* a previous state handed in for reuse */
    *FMUstate = s;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate)
{
    const char *fn = "fmi2SetFMUstate";
    BEGIN(fn, M_FMU_STATE);
    const fmu_state_t *s = FMUstate;
    state_header_t h;
    if (s == NULL) {
        return fail(in, fn, "FMUstate is NULL");
    }
    if (check_blob(in, fn, s->bytes, s->size, &h) != fmi2OK) {
        return fmi2Error;
    }
    trace(in, fn, "t=%.17g", h.t);
    const size_t nval = (size_t)in->vars.n * sizeof(double);
    const double *made_with = (const double *)(const void *)(s->bytes + sizeof h + nval);
    /* a component made with other parameters cannot take the native state */
    int same = in->comp != NULL && h.has_comp;
    for (int j = 0; same && j < in->vars.n; j++) {
        if (in->vars.v[j].causality == FMI_PARAMETER && memcmp(&in->made_with[j], &made_with[j], sizeof(double))) {
            same = 0;
        }
    }
    if (!same) {
        drop_component(in);
    }
    memcpy(in->values, s->bytes + sizeof h, nval);
    in->t = h.t;
    in->t_start = h.t_start;
    /* the stop time stays this instance's own (fmi2SetupExperiment): a
     * restart may run longer than the run that saved the state */
    if (h.has_comp) {
        if (in->comp == NULL) {
            /* re-create with the parameters the state was made with */
            double *keep = malloc(nval + sizeof(double));
            if (keep == NULL) {
                in->state = S_ERROR;
                return fail(in, fn, "out of memory for a copy of the values (%zu bytes)", nval + sizeof(double));
            }
            memcpy(keep, in->values, nval);
            memcpy(in->values, made_with, nval);
            status_t st = ensure_component(in, fn);
            memcpy(in->values, keep, nval);
            free(keep);
            if (st >= STATUS_ERROR) {
                in->state = st == STATUS_FATAL ? S_FATAL : S_ERROR;
                return (fmi2Status)st;
            }
        }
        status_t st = MODEL->state_restore(in->comp, s->bytes + sizeof h + 2 * nval, (size_t)h.comp_size);
        if (st >= STATUS_ERROR) {
            in->state = st == STATUS_FATAL ? S_FATAL : S_ERROR;
            return report(in, st, fn, "the %s component could not restore the state", MODEL->identifier);
        }
        memcpy(in->made_with, made_with, nval);
        MODEL->outputs(in->comp, &in->vars, in->values);
        in->lazy_stale = 1;
    }
    in->state = h.state;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    BEGIN("fmi2FreeFMUstate", M_FMU_STATE);
    trace(in, "fmi2FreeFMUstate", "%s", "");
    if (FMUstate == NULL) {
        return fail(in, "fmi2FreeFMUstate", "FMUstate is NULL");
    }
    free(*FMUstate);
    *FMUstate = NULL;
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size)
{
    BEGIN("fmi2SerializedFMUstateSize", M_FMU_STATE);
    if (FMUstate == NULL || size == NULL) {
        return fail(in, "fmi2SerializedFMUstateSize", "%s is NULL", FMUstate == NULL ? "FMUstate" : "size");
    }
    *size = ((const fmu_state_t *)FMUstate)->size;
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size)
{
    const char *fn = "fmi2SerializeFMUstate";
    BEGIN(fn, M_FMU_STATE);
    const fmu_state_t *s = FMUstate;
    if (s == NULL || serializedState == NULL) {
        return fail(in, fn, "%s is NULL", s == NULL ? "FMUstate" : "serializedState");
    }
    if (size != s->size) {
        return fail(in, fn, "size = %zu; allowed: %zu, as fmi2SerializedFMUstateSize gives", size, s->size);
    }
    memcpy(serializedState, s->bytes, s->size);
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate)
{
    const char *fn = "fmi2DeSerializeFMUstate";
    BEGIN(fn, M_FMU_STATE);
    state_header_t h;
    if (serializedState == NULL || FMUstate == NULL) {
        return fail(in, fn, "%s is NULL", serializedState == NULL ? "serializedState" : "FMUstate");
    }
    if (check_blob(in, fn, (const unsigned char *)serializedState, size, &h) != fmi2OK) {
        return fmi2Error;
    }
    fmu_state_t *s = malloc(sizeof *s + size);
    if (s == NULL) {
        return fail(in, fn, "out of memory for an FMU state of %zu bytes", size);
    }
    s->size = size;
    memcpy(s->bytes, serializedState, size);
    free(*FMUstate);
    *FMUstate = s;
    return fmi2OK;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[])
{
    BEGIN("fmi2GetDirectionalDerivative", M_DIRECTIONAL);
    (void)vUnknown_ref, (void)nUnknown, (void)vKnown_ref, (void)nKnown, (void)dvKnown, (void)dvUnknown;
    return fail(in, "fmi2GetDirectionalDerivative",
                "not supported (providesDirectionalDerivative=\"false\" in modelDescription.xml)");
}

/* ------------------------------------------------------------------------ */
/* Co-simulation                                                             */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[])
{
    BEGIN("fmi2SetRealInputDerivatives", M_SET_INPUT_DER);
    (void)vr, (void)nvr, (void)order, (void)value;
    return fail(in, "fmi2SetRealInputDerivatives",
                "not supported (canInterpolateInputs=\"false\" in modelDescription.xml): inputs are held constant "
                "over a communication step");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[])
{
    BEGIN("fmi2GetRealOutputDerivatives", M_GET_OUTPUT_DER);
    (void)vr, (void)nvr, (void)order, (void)value;
    return fail(in, "fmi2GetRealOutputDerivatives",
                "not supported (maxOutputDerivativeOrder=\"0\" in modelDescription.xml)");
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    const char *fn = "fmi2DoStep";
    BEGIN(fn, M_DO_STEP);
    (void)noSetFMUStatePriorToCurrentPoint;
    const double t = currentCommunicationPoint, h = communicationStepSize;
    trace(in, fn, "currentCommunicationPoint=%.17g, communicationStepSize=%.17g", t, h);
    if (!(isfinite(h) && h > 0.0)) {
        return fail(in, fn, "communicationStepSize = %g; allowed: a finite value > 0", h);
    }
    if (!isfinite(t) || fabs(t - in->t) > TIME_TOL * fmax(fabs(in->t), h)) {
        return fail(in, fn,
                    "currentCommunicationPoint = %.17g s is not where the FMU is (t = %.17g s, tolerance %.3g s)", t,
                    in->t, TIME_TOL * fmax(fabs(in->t), h));
    }
    if (in->has_stop && t + h > in->t_stop + TIME_TOL * fmax(fabs(in->t_stop), h)) {
        return fail(in, fn, "the step to t = %.17g s would pass stopTime = %.17g s of fmi2SetupExperiment", t + h,
                    in->t_stop);
    }
    if (MODEL->check_step != NULL && MODEL->check_step(in->comp, h, &in->log) >= STATUS_ERROR) {
        return fail(in, fn, "communicationStepSize = %.17g s rejected (see the message above); the step was not taken",
                    h);
    }
    status_t st = MODEL->step(in->comp, &in->vars, in->values, t, h, &in->log);
    if (st >= STATUS_ERROR) {
        in->state = st == STATUS_FATAL ? S_FATAL : S_ERROR;
        return report(in, st, fn, "the %s step from t = %.17g s failed; restore a saved FMU state or reset",
                      MODEL->identifier, t);
    }
    if (st == STATUS_DISCARD) {
        in->state = S_STEP_FAILED;
        return report(in, st, fn, "the %s step from t = %.17g s was discarded", MODEL->identifier, t);
    }
    MODEL->outputs(in->comp, &in->vars, in->values);
    in->lazy_stale = 1;
    in->t = t + h;
    return (fmi2Status)st;
}

fmi2Status fmi2CancelStep(fmi2Component c)
{
    /* fmi2DoStep never returns fmi2Pending, so there is never a step to cancel */
    BEGIN("fmi2CancelStep", M_CANCEL_STEP);
    return fmi2OK;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value)
{
    const char *fn = "fmi2GetStatus";
    BEGIN(fn, M_GET_STATUS);
    if (value == NULL) {
        return fail(in, fn, "value is NULL");
    }
    (void)s;
    return report(in, STATUS_DISCARD, fn,
                  "no asynchronous step: fmi2DoStep never returns fmi2Pending, so there is no status to report");
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value)
{
    const char *fn = "fmi2GetRealStatus";
    BEGIN(fn, M_GET_STATUS);
    if (value == NULL) {
        return fail(in, fn, "value is NULL");
    }
    if (s == fmi2LastSuccessfulTime) {
        *value = in->t;
        return fmi2OK;
    }
    return report(in, STATUS_DISCARD, fn, "status kind %d not available; allowed: fmi2LastSuccessfulTime", (int)s);
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value)
{
    const char *fn = "fmi2GetIntegerStatus";
    BEGIN(fn, M_GET_STATUS);
    (void)s, (void)value;
    return report(in, STATUS_DISCARD, fn, "no Integer status is defined by FMI 2.0");
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value)
{
    const char *fn = "fmi2GetBooleanStatus";
    BEGIN(fn, M_GET_STATUS);
    if (value == NULL) {
        return fail(in, fn, "value is NULL");
    }
    if (s == fmi2Terminated) {
        *value = fmi2False; /* the slave never asks to end the simulation */
        return fmi2OK;
    }
    return report(in, STATUS_DISCARD, fn, "status kind %d not available; allowed: fmi2Terminated", (int)s);
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value)
{
    const char *fn = "fmi2GetStringStatus";
    BEGIN(fn, M_GET_STATUS);
    (void)s, (void)value;
    return report(in, STATUS_DISCARD, fn, "no asynchronous step, so no pending status text");
}
