/* fmi_values.c — fmi2Get* and fmi2Set* of the generic FMI layer
 * (fmi_internal.h): one double per value reference, String parameters as
 * text; each value checked against its variable's type, causality and range. */
#include "fmi_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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
            status_t st = fmi_ensure_component(in, fn);
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
    if (fmi_bad_refs(in, fn, vr, nvr, value, type)) {
        return fmi2Error;
    }
    fmi2Status st = prepare_get(in, fn, vr, nvr);
    if (st >= fmi2Error) {
        return st;
    }
    for (size_t i = 0; i < nvr && in->lazy_stale && in->comp != NULL; i++) {
        if (in->vars.v[vr[i]].lazy) {
            const status_t lst = in->model->lazy_outputs(in->comp, &in->vars, in->values);
            if (lst >= STATUS_ERROR) {
                /* the component found its state broken (e.g. NaN in the
                 * fluid): no value is handed out, the instance stops */
                in->state = lst == STATUS_FATAL ? S_FATAL : S_ERROR;
                return fmi_report(in, lst, fn, "the %s outputs at t = %.17g s cannot be computed (see the message "
                                  "above); restore a saved FMU state or reset", in->model->identifier, in->t);
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
    if (fmi_bad_refs(in, "fmi2GetString", vr, nvr, value, FMI_STRING)) {
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
    if (fmi_bad_refs(in, fn, vr, nvr, value, type)) {
        return fmi2Error;
    }
    int parameters = 0;
    for (size_t i = 0; i < nvr; i++) {
        const fmi_var_t *v = &in->vars.v[vr[i]];
        const double x = type == FMI_REAL      ? ((const fmi2Real *)value)[i]
                         : type == FMI_INTEGER ? (double)((const fmi2Integer *)value)[i]
                                               : (double)((const fmi2Boolean *)value)[i];
        if (v->causality == FMI_OUTPUT) {
            return fmi_fail(in, fn, "%s (value reference %u) is an output and cannot be set", v->name, vr[i]);
        }
        if (v->causality == FMI_PARAMETER && !(in->state & M_SET_PARAMETER)) {
            return fmi_fail(in, fn,
                            "%s (value reference %u) is a fixed parameter: set it before fmi2ExitInitializationMode "
                            "(state now %s)",
                            v->name, vr[i], fmi_state_name(in->state));
        }
        if (!isfinite(x)) {
            return fmi_fail(in, fn, "%s (value reference %u) = %g; allowed: a finite value", v->name, vr[i], x);
        }
        /* parameters, and the inputs that declare a range (min/max in modelDescription.xml) */
        if (!in_range(v, x)) {
            char range[120];
            format_range(v, range, sizeof range);
            return fmi_fail(in, fn, "%s (value reference %u) = %.17g is out of range; allowed: %s%s%s", v->name, vr[i],
                            x,
                            range, v->unit != NULL ? " " : "", v->unit != NULL ? v->unit : "");
        }
        parameters |= v->causality == FMI_PARAMETER;
    }
    /* a parameter replaces the component (below): the saved states that
     * are still the component are copied first (inputs only reach values[]) */
    if (parameters && in->comp != NULL && fmi_states_keep(in, fn) >= fmi2Error) {
        return fmi2Error;
    }
    for (size_t i = 0; i < nvr; i++) {
        const double x = type == FMI_REAL      ? ((const fmi2Real *)value)[i]
                         : type == FMI_INTEGER ? (double)((const fmi2Integer *)value)[i]
                                               : (((const fmi2Boolean *)value)[i] != fmi2False ? 1.0 : 0.0);
        fmi_trace(in, fn, "%s = %.17g", in->vars.v[vr[i]].name, x);
        in->values[vr[i]] = x;
    }
    if (parameters && in->comp != NULL) {
        /* only in Initialization Mode: the next use re-creates it */
        fmi_report(in, STATUS_OK, fn, "parameter changed: the component will be re-created");
        fmi_drop_component(in);
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
    if (fmi_bad_refs(in, fn, vr, nvr, value, FMI_STRING)) {
        return fmi2Error;
    }
    for (size_t i = 0; i < nvr; i++) {
        const fmi_var_t *v = &in->vars.v[vr[i]];
        if (v->causality != FMI_PARAMETER || !(in->state & M_SET_PARAMETER)) {
            return fmi_fail(in, fn, "%s (value reference %u) is a fixed parameter: set it before "
                            "fmi2ExitInitializationMode (state now %s)", v->name, vr[i],
                            fmi_state_name(in->state));
        }
        if (value[i] == NULL) {
            return fmi_fail(in, fn, "%s (value reference %u) = NULL; allowed: a string (\"\" for none)", v->name,
                            vr[i]);
        }
    }
    /* the component is replaced (below): the saved states that are still it are copied first */
    if (nvr > 0 && in->comp != NULL && fmi_states_keep(in, fn) >= fmi2Error) {
        return fmi2Error;
    }
    for (size_t i = 0; i < nvr; i++) {
        char *copy = strdup(value[i]);
        if (copy == NULL) {
            return fmi_fail(in, fn, "out of memory for a String value (%zu bytes)", strlen(value[i]) + 1);
        }
        fmi_trace(in, fn, "%s = '%s'", in->vars.v[vr[i]].name, copy);
        free(in->strings[vr[i]]);
        in->strings[vr[i]] = copy;
    }
    if (nvr > 0 && in->comp != NULL) {
        fmi_report(in, STATUS_OK, fn, "parameter changed: the component will be re-created");
        fmi_drop_component(in);
    }
    return fmi2OK;
}
