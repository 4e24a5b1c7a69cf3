/* fmi_instance.c — the generic FMI layer's logging, call-order and
 * argument checks, the registry of live instances, and the native component
 * (fmi_internal.h).
 *
 * The registry is the one piece of global state of an FMU library: a list of
 * the live instances under a mutex (masters may call different instances
 * from different threads). A handle is compared with the registered
 * addresses and only then dereferenced: a magic number inside the instance
 * cannot tell a freed one, since reading freed memory is undefined, and the
 * store that cleared it before free() was removed by the optimiser. */
#include "fmi_internal.h"

#include <math.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const STATE_NAMES[NSTATES] = {
#define STATE_NAME(name, text) text,
    STATE_LIST(STATE_NAME)
#undef STATE_NAME
};

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
void fmi_native_log(void *ctx, status_t level, const char *category, const char *msg)
{
    char buf[3000];
    snprintf(buf, sizeof buf, "[%s] %s", category != NULL ? category : "-", msg);
    emit(ctx, level, level_category(level), buf);
}

/* The same for the scene's first reading at instantiation: its errors only.
 * Its warnings come once, from the reading with the parameters applied in
 * fmi2ExitInitializationMode (they would otherwise be logged twice). */
void fmi_native_log_errors(void *ctx, status_t level, const char *category, const char *msg)
{
    if (level >= STATUS_ERROR) {
        fmi_native_log(ctx, level, category, msg);
    }
}

static fmi2Status vreport(const inst_t *in, status_t level, const char *fn, const char *fmt, va_list ap)
{
    char msg[2500], buf[2700];
    vsnprintf(msg, sizeof msg, fmt, ap);
    snprintf(buf, sizeof buf, "%s: %s", fn, msg);
    emit(in, level, level_category(level), buf);
    return (fmi2Status)level;
}

__attribute__((format(printf, 3, 4))) fmi2Status fmi_fail(const inst_t *in, const char *fn, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vreport(in, STATUS_ERROR, fn, fmt, ap);
    va_end(ap);
    return fmi2Error;
}

__attribute__((format(printf, 4, 5))) fmi2Status fmi_report(const inst_t *in, status_t level, const char *fn,
                                                            const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vreport(in, level, fn, fmt, ap);
    va_end(ap);
    return (fmi2Status)level;
}

__attribute__((format(printf, 3, 4))) void fmi_trace(const inst_t *in, const char *fn, const char *fmt, ...)
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

static pthread_mutex_t live_lock = PTHREAD_MUTEX_INITIALIZER;
static inst_t *live_head; /* guarded by live_lock */

void fmi_instance_add(inst_t *in)
{
    pthread_mutex_lock(&live_lock);
    in->live_next = live_head;
    live_head = in;
    pthread_mutex_unlock(&live_lock);
}

/* The registry's link to c (NULL when c is not live); live_lock held. */
static inst_t **live_link(fmi2Component c)
{
    for (inst_t **p = &live_head; *p != NULL; p = &(*p)->live_next) {
        if ((void *)*p == c) {
            return p;
        }
    }
    return NULL;
}

inst_t *fmi_instance(fmi2Component c)
{
    if (c == NULL) {
        return NULL;
    }
    pthread_mutex_lock(&live_lock);
    inst_t **p = live_link(c);
    inst_t *in = p != NULL ? *p : NULL;
    pthread_mutex_unlock(&live_lock);
    return in;
}

inst_t *fmi_instance_take(fmi2Component c)
{
    if (c == NULL) {
        return NULL;
    }
    pthread_mutex_lock(&live_lock);
    inst_t **p = live_link(c);
    inst_t *in = NULL;
    if (p != NULL) {
        in = *p;
        *p = in->live_next;
        in->live_next = NULL;
    }
    pthread_mutex_unlock(&live_lock);
    return in;
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

const char *fmi_state_name(int state) { return STATE_NAMES[state_index(state)]; }

/* NULL when the call may go on; otherwise the error has been logged. */
int fmi_illegal(const inst_t *in, const char *fn, int mask)
{
    if (in->state & mask) {
        return 0;
    }
    char allowed[400];
    state_list(mask, allowed, sizeof allowed);
    fmi_fail(in, fn, "illegal call sequence: the FMU is in state %s; allowed in: %s", fmi_state_name(in->state),
             allowed);
    return 1;
}


static const char *type_name(fmi_type_t t)
{
    return t == FMI_REAL ? "Real" : t == FMI_INTEGER ? "Integer" : t == FMI_BOOLEAN ? "Boolean" : "String";
}

/* Value references exist and have the type of the function. */
int fmi_bad_refs(const inst_t *in, const char *fn, const fmi2ValueReference vr[], size_t nvr, const void *values,
                 fmi_type_t type)
{
    if (nvr > 0 && (vr == NULL || values == NULL)) {
        fmi_fail(in, fn, "nvr = %zu but the %s array is NULL", nvr, vr == NULL ? "value reference" : "value");
        return 1;
    }
    for (size_t i = 0; i < nvr; i++) {
        if (vr[i] >= (fmi2ValueReference)in->vars.n) {
            fmi_fail(in, fn, "value reference %u does not exist; allowed: 0 to %d", vr[i], in->vars.n - 1);
            return 1;
        }
        const fmi_var_t *v = &in->vars.v[vr[i]];
        if (v->type != type) {
            fmi_fail(in, fn, "value reference %u (%s) is of type %s, not %s", vr[i], v->name, type_name(v->type),
                     type_name(type));
            return 1;
        }
    }
    return 0;
}
/* ------------------------------------------------------------------------ */
/* The native component                                                      */

void fmi_drop_component(inst_t *in)
{
    if (in->comp != NULL) {
        in->model->free(in->comp);
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
status_t fmi_ensure_component(inst_t *in, const char *fn)
{
    if (in->comp != NULL) {
        return STATUS_OK;
    }
    int nov = 0;
    char **ov = calloc((size_t)in->vars.n + 1, sizeof *ov);
    status_t st = STATUS_OK;
    if (ov == NULL) {
        fmi_report(in, STATUS_FATAL, fn, "out of memory for the parameter overrides (%zu bytes)",
                   ((size_t)in->vars.n + 1) * sizeof *ov);
        st = STATUS_FATAL;
        goto done;
    }
    for (int j = 0; j < in->vars.n; j++) {
        char buf[FMI_KEY_MAX + 100];
        if (in->vars.v[j].causality == FMI_PARAMETER && parameter_override(in, j, buf, sizeof buf)) {
            if ((ov[nov] = strdup(buf)) == NULL) {
                fmi_report(in, STATUS_FATAL, fn, "out of memory for a parameter override (%zu bytes)", strlen(buf) + 1);
                st = STATUS_FATAL;
                goto done;
            }
            fmi_report(in, STATUS_OK, fn, "parameter applied to the scene: %s", ov[nov]);
            nov++;
        }
    }
    st = scene_load(in->scene_path, (const char *const *)ov, nov, &in->log, &in->scene);
    if (st >= STATUS_ERROR) {
        fmi_report(in, st, fn, "the scene %s with the parameters set cannot be used (see the messages above)",
                   in->scene_path);
        goto done;
    }
    st = in->model->create(in->scene, in->t_start, &in->log, &in->comp);
    if (st >= STATUS_ERROR) {
        in->comp = NULL;
        fmi_report(in, st, fn, "the %s component cannot be created (see the messages above)", in->model->identifier);
        goto done;
    }
    for (int j = 0; j < in->vars.n && in->model->set_string != NULL; j++) {
        if (in->strings[j] != NULL) {
            st = status_worst(st, in->model->set_string(in->comp, &in->vars.v[j], in->strings[j], &in->log));
            if (st >= STATUS_ERROR) {
                fmi_report(in, st, fn, "%s = '%s' cannot be used (see the messages above)", in->vars.v[j].name,
                           in->strings[j]);
                goto done;
            }
        }
    }
    memcpy(in->made_with, in->values, (size_t)in->vars.n * sizeof(double));
    in->model->outputs(in->comp, &in->vars, in->values);
    in->lazy_stale = 1;
done:
    if (st >= STATUS_ERROR) {
        fmi_drop_component(in);
    }
    for (int k = 0; ov != NULL && k < nov; k++) {
        free(ov[k]);
    }
    free(ov);
    return st;
}
