/* fmi_adapter.c — the generic FMI 2.0 Co-Simulation layer (all fmi2* entry points).
 *
 * Compiled once per FMU with -DFMI_MODEL=fluid_fmi_model (or rigid_fmi_model):
 * the model table (common/fmi_adapter.h) supplies the variables and the
 * native calls, this layer everything FMI asks of an FMU. This file: the
 * instance's lifecycle, stepping and status; the rest in the files
 * fmi_internal.h lists (logging and checks, values, FMU state).
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
 * - Instances: fmi2Instantiate registers the instance it returns, and every
 *   entry point looks its handle up in that registry (fmi_instance.c) before
 *   reading anything behind it: a handle freed already (a second
 *   fmi2FreeInstance, a call after it) or never returned is answered with
 *   fmi2Error, and fmi2FreeInstance ignores it.
 *
 * No global mutable state but that registry: any number of instances may
 * coexist. */
#include "fmi_internal.h"

#include <ctype.h>
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef FMI_MODEL
#error "compile fmi_adapter.c with -DFMI_MODEL=fluid_fmi_model or -DFMI_MODEL=rigid_fmi_model"
#endif

/* ------------------------------------------------------------------------ */
/* Common functions                                                          */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    BEGIN("fmi2SetDebugLogging", M_SET_DEBUG_LOGGING);
    if (nCategories > 0 && categories == NULL) {
        return fmi_fail(in, "fmi2SetDebugLogging", "nCategories = %zu but categories is NULL", nCategories);
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
            return fmi_fail(in, "fmi2SetDebugLogging",
                            "unknown log category '%s'; allowed: logStatusWarning, logStatusDiscard, logStatusError, "
                            "logStatusFatal, logInfo, logCalls",
                            categories[i] != NULL ? categories[i] : "(null)");
        }
        mask |= 1u << found;
    }
    in->logging_on = loggingOn != fmi2False;
    in->cat_mask = mask;
    fmi_trace(in, "fmi2SetDebugLogging", "loggingOn=%d, nCategories=%zu", loggingOn, nCategories);
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
    fmi_states_free(in);
    fmi_drop_component(in);
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
                              fmi_log_categories[FMI_CAT_FATAL][0],
                                      "fmi2Instantiate: out of memory for the instance (%zu bytes)", sizeof *in);
        }
        return NULL;
    }
    in->model = &FMI_MODEL;
    in->logger = functions->logger;
    in->env = functions->componentEnvironment;
    in->logging_on = loggingOn != fmi2False;
    in->cat_mask = (1u << FMI_NCATS) - 1u;
    in->state = S_INSTANTIATED;
    in->log = (log_t){fmi_native_log, in};
    in->name = strdup(instanceName != NULL ? instanceName : "");
    if (in->name == NULL) {
        fmi_report(in, STATUS_FATAL, fn, "out of memory for the instance name (%zu bytes)", strlen(instanceName) + 1);
        goto fail;
    }
    if (instanceName == NULL || instanceName[0] == '\0') {
        fmi_fail(in, fn, "instanceName is %s; allowed: a non-empty string", instanceName == NULL ? "NULL" : "empty");
        goto fail;
    }
    if (fmuType != fmi2CoSimulation) {
        fmi_fail(in, fn, "fmuType = %d: the %s FMU supports Co-Simulation only (fmi2CoSimulation = %d)", (int)fmuType,
                 in->model->identifier, (int)fmi2CoSimulation);
        goto fail;
    }
    if (fmuResourceLocation == NULL || (in->scene_path = resource_scene_path(fmuResourceLocation)) == NULL) {
        fmi_fail(in, fn, "fmuResourceLocation '%s' is not a file URI (file:///...) of the FMU's resources folder",
                 fmuResourceLocation != NULL ? fmuResourceLocation : "(null)");
        goto fail;
    }
    char msg[600];
    size_t len = 0;
    char *text = read_text(in->scene_path, &len, msg, sizeof msg);
    if (text == NULL) {
        fmi_fail(in, fn, "%s (the FMU carries its scene as resources/scene.yaml)", msg);
        goto fail;
    }
    fmi_guid(in->model->identifier, text, len, in->guid);
    free(text);
    if (fmuGUID == NULL || strcmp(fmuGUID, in->guid) != 0) {
        fmi_fail(in, fn,
                 "fmuGUID %s does not match the GUID %s of this FMU's scene; was the FMU unpacked over another?",
                 fmuGUID != NULL ? fmuGUID : "(null)", in->guid);
        goto fail;
    }
    const log_t errors_only = {fmi_native_log_errors, in};
    if (scene_load(in->scene_path, NULL, 0, &errors_only, &in->base) >= STATUS_ERROR) {
        fmi_fail(in, fn, "the scene %s cannot be read (see the messages above)", in->scene_path);
        goto fail;
    }
    status_t st = in->model->variables(in->base, &in->log, &in->vars);
    if (st == STATUS_DISCARD) {
        fmi_fail(in, fn, "the scene %s needs no %s FMU (it has no free bodies)", in->scene_path, in->model->identifier);
        goto fail;
    }
    if (st != STATUS_OK) {
        fmi_fail(in, fn, "no %s variables for the scene %s (see the messages above)", in->model->identifier,
                 in->scene_path);
        goto fail;
    }
    in->values = calloc((size_t)in->vars.n + 1, sizeof(double));
    in->made_with = calloc((size_t)in->vars.n + 1, sizeof(double));
    in->strings = calloc((size_t)in->vars.n + 1, sizeof(char *));
    if (in->values == NULL || in->made_with == NULL || in->strings == NULL) {
        fmi_report(in, STATUS_FATAL, fn, "out of memory for the values of %d variables (%zu bytes)", in->vars.n,
                   ((size_t)in->vars.n + 1) * (2 * sizeof(double) + sizeof(char *)));
        goto fail;
    }
    for (int j = 0; j < in->vars.n; j++) {
        if (in->vars.v[j].type == FMI_STRING && (in->strings[j] = strdup("")) == NULL) {
            fmi_report(in, STATUS_FATAL, fn, "out of memory for an empty String value (1 byte)");
            goto fail;
        }
    }
    for (int j = 0; j < in->vars.n; j++) {
        in->values[j] = in->vars.v[j].start;
    }
    fmi_trace(in, fn, "instanceName=%s, fmuGUID=%s, fmuResourceLocation=%s, loggingOn=%d", instanceName, fmuGUID,
              fmuResourceLocation, loggingOn);
    fmi_instance_add(in);
    return in;
fail:
    free_instance(in);
    return NULL;
}

void fmi2FreeInstance(fmi2Component c)
{
    /* legal in every state: a master must be able to release an FMU it gave
     * up on. Taken out of the registry first, so a second call (or one from
     * another thread at the same time) finds nothing and does nothing. */
    inst_t *in = fmi_instance_take(c);
    if (in == NULL) {
        return;
    }
    fmi_trace(in, "fmi2FreeInstance", "%s", "");
    free_instance(in);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    const char *fn = "fmi2SetupExperiment";
    BEGIN(fn, M_SETUP_EXPERIMENT);
    fmi_trace(in, fn, "toleranceDefined=%d, tolerance=%.17g, startTime=%.17g, stopTimeDefined=%d, stopTime=%.17g",
              toleranceDefined, tolerance, startTime, stopTimeDefined, stopTime);
    if (!isfinite(startTime)) {
        return fmi_fail(in, fn, "startTime = %g; allowed: a finite time", startTime);
    }
    if (stopTimeDefined && !(isfinite(stopTime) && stopTime >= startTime)) {
        return fmi_fail(in, fn, "stopTime = %g; allowed: a finite time >= startTime = %g", stopTime, startTime);
    }
    if (toleranceDefined) {
        fmi_report(in, STATUS_OK, fn,
                   "tolerance %g ignored: the tolerances come from the scene (rigid.rtol, rigid.atol)",
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
    fmi_trace(in, "fmi2EnterInitializationMode", "%s", "");
    in->state = S_INIT;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    const char *fn = "fmi2ExitInitializationMode";
    BEGIN(fn, M_EXIT_INIT);
    fmi_trace(in, fn, "%s", "");
    status_t st = fmi_ensure_component(in, fn);
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
    fmi_trace(in, "fmi2Terminate", "%s", "");
    in->state = S_TERMINATED;
    if (in->comp != NULL && in->model->terminate != NULL) {
        const status_t st = in->model->terminate(in->comp, &in->log);
        if (st >= STATUS_ERROR) {
            in->state = st == STATUS_FATAL ? S_FATAL : S_ERROR;
        }
        if (st >= STATUS_WARNING) {
            return fmi_report(in, st, "fmi2Terminate", "closing the %s component's files (see the message above)",
                              in->model->identifier);
        }
    }
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c)
{
    BEGIN("fmi2Reset", M_RESET);
    fmi_trace(in, "fmi2Reset", "%s", "");
    if (fmi_states_keep(in, "fmi2Reset") >= fmi2Error) {
        return fmi2Error;
    }
    fmi_drop_component(in);
    for (int j = 0; j < in->vars.n; j++) {
        in->values[j] = in->vars.v[j].start;
        if (in->strings[j] != NULL) {
            in->strings[j][0] = '\0'; /* a String's start value "" (kept: output.fields went on being written) */
        }
    }
    in->t = in->t_start = 0.0;
    in->has_stop = 0;
    in->state = S_INSTANTIATED;
    return fmi2OK;
}
/* ------------------------------------------------------------------------ */
/* Co-simulation                                                             */

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[])
{
    BEGIN("fmi2GetDirectionalDerivative", M_DIRECTIONAL);
    (void)vUnknown_ref, (void)nUnknown, (void)vKnown_ref, (void)nKnown, (void)dvKnown, (void)dvUnknown;
    return fmi_fail(in, "fmi2GetDirectionalDerivative",
                    "not supported (providesDirectionalDerivative=\"false\" in modelDescription.xml)");
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[])
{
    BEGIN("fmi2SetRealInputDerivatives", M_SET_INPUT_DER);
    (void)vr, (void)nvr, (void)order, (void)value;
    return fmi_fail(in, "fmi2SetRealInputDerivatives",
                    "not supported (canInterpolateInputs=\"false\" in modelDescription.xml): inputs are held constant "
                    "over a communication step");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[])
{
    BEGIN("fmi2GetRealOutputDerivatives", M_GET_OUTPUT_DER);
    (void)vr, (void)nvr, (void)order, (void)value;
    return fmi_fail(in, "fmi2GetRealOutputDerivatives",
                    "not supported (maxOutputDerivativeOrder=\"0\" in modelDescription.xml)");
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    const char *fn = "fmi2DoStep";
    BEGIN(fn, M_DO_STEP);
    (void)noSetFMUStatePriorToCurrentPoint;
    const double t = currentCommunicationPoint, h = communicationStepSize;
    fmi_trace(in, fn, "currentCommunicationPoint=%.17g, communicationStepSize=%.17g", t, h);
    if (!(isfinite(h) && h > 0.0)) {
        return fmi_fail(in, fn, "communicationStepSize = %g; allowed: a finite value > 0", h);
    }
    /* the round-off of a master's times: a part of the step and a few ulps
     * of t (a tolerance relative to t alone took t off by 5 LBM steps at
     * t = 1e5 s for where the FMU was) */
    const double t_tol = TIME_TOL * h + 8.0 * DBL_EPSILON * (fabs(in->t) + h);
    if (!isfinite(t) || fabs(t - in->t) > t_tol) {
        return fmi_fail(in, fn,
                        "currentCommunicationPoint = %.17g s is not where the FMU is (t = %.17g s, tolerance %.3g s)",
                        t, in->t, t_tol);
    }
    if (in->has_stop && t + h > in->t_stop + TIME_TOL * fmax(fabs(in->t_stop), h)) {
        return fmi_fail(in, fn, "the step to t = %.17g s would pass stopTime = %.17g s of fmi2SetupExperiment", t + h,
                        in->t_stop);
    }
    /* the saved states that are still this component: copied before it moves on */
    if (fmi_states_keep(in, fn) >= fmi2Error) {
        return fmi2Error;
    }
    if (in->model->check_step != NULL && in->model->check_step(in->comp, t, h, &in->log) >= STATUS_ERROR) {
        return fmi_fail(in, fn,
                        "communicationStepSize = %.17g s rejected (see the message above); the step was not taken",
                        h);
    }
    status_t st = in->model->step(in->comp, &in->vars, in->values, t, h, &in->log);
    if (st >= STATUS_ERROR) {
        in->state = st == STATUS_FATAL ? S_FATAL : S_ERROR;
        return fmi_report(in, st, fn, "the %s step from t = %.17g s failed; restore a saved FMU state or reset",
                          in->model->identifier, t);
    }
    if (st == STATUS_DISCARD) {
        in->state = S_STEP_FAILED;
        return fmi_report(in, st, fn, "the %s step from t = %.17g s was discarded", in->model->identifier, t);
    }
    in->model->outputs(in->comp, &in->vars, in->values);
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
        return fmi_fail(in, fn, "value is NULL");
    }
    (void)s;
    return fmi_report(in, STATUS_DISCARD, fn,
                      "no asynchronous step: fmi2DoStep never returns fmi2Pending, so there is no status to report");
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value)
{
    const char *fn = "fmi2GetRealStatus";
    BEGIN(fn, M_GET_STATUS);
    if (value == NULL) {
        return fmi_fail(in, fn, "value is NULL");
    }
    if (s == fmi2LastSuccessfulTime) {
        *value = in->t;
        return fmi2OK;
    }
    return fmi_report(in, STATUS_DISCARD, fn, "status kind %d not available; allowed: fmi2LastSuccessfulTime", (int)s);
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value)
{
    const char *fn = "fmi2GetIntegerStatus";
    BEGIN(fn, M_GET_STATUS);
    (void)s, (void)value;
    return fmi_report(in, STATUS_DISCARD, fn, "no Integer status is defined by FMI 2.0");
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value)
{
    const char *fn = "fmi2GetBooleanStatus";
    BEGIN(fn, M_GET_STATUS);
    if (value == NULL) {
        return fmi_fail(in, fn, "value is NULL");
    }
    if (s == fmi2Terminated) {
        *value = fmi2False; /* the slave never asks to end the simulation */
        return fmi2OK;
    }
    return fmi_report(in, STATUS_DISCARD, fn, "status kind %d not available; allowed: fmi2Terminated", (int)s);
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value)
{
    const char *fn = "fmi2GetStringStatus";
    BEGIN(fn, M_GET_STATUS);
    (void)s, (void)value;
    return fmi_report(in, STATUS_DISCARD, fn, "no asynchronous step, so no pending status text");
}
