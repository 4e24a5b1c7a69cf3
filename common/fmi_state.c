/* fmi_state.c — FMU state of the generic FMI layer (fmi_internal.h): one
 * self-contained byte blob (header, values, native state), so that
 * get/set and serialise/deserialise share one format. The native part of a
 * state taken from the instance is copied only when the component is about
 * to change (fmi_states_keep): until then the component is that part.
 *
 * Every state is in a registry of the library's live states (under a mutex,
 * as the instances are in fmi_instance.c) with the instance that made it:
 * fmi2FreeInstance frees the states the master left (before, they stayed
 * allocated: about the grid's size each), and a handle freed already or
 * never returned is refused before anything behind it is read (before, a
 * second fmi2FreeFMUstate of a copied handle aborted in free()). */
#include "fmi_internal.h"

#include <math.h>
#include <pthread.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------ */
/* FMU state: header | values (nvars doubles) | native state.               */

typedef struct {
    char magic[8];
    char model[16];
    char guid[40];
    uint64_t nvars, comp_size;
    int32_t state, has_comp, has_stop, pad;
    double t, t_start, t_stop;
    /* of a serialized state: state_sum of its bytes (0 in memory) */
    uint64_t sum;
} state_header_t;

/* A 64-bit checksum of a serialized state: its bytes with the header's sum
 * taken as 0, eight at a time in four lanes (FNV-1a's multiplier on words),
 * so that fmi2DeSerializeFMUstate refuses a blob damaged on its way (a byte
 * of the populations changed was restored silently: the header checks saw
 * nothing wrong). Not a defence against a forged blob: a check against
 * damage, at about a memory pass. */
static uint64_t state_sum(const unsigned char *bytes, size_t size)
{
    const uint64_t prime = 1099511628211ull;
    uint64_t lane[4] = {1469598103934665603ull, 0x9e3779b97f4a7c15ull, 0xc2b2ae3d27d4eb4full, 0x165667b19e3779f9ull};
    const size_t at = offsetof(state_header_t, sum);
    size_t k = 0;
    for (; k + 8 <= size; k += 8) {
        uint64_t w = 0;
        if (k != at) {
            memcpy(&w, bytes + k, sizeof w);
        }
        lane[(k >> 3) & 3] = (lane[(k >> 3) & 3] ^ w) * prime;
    }
    uint64_t h = (lane[0] ^ (lane[1] * 31u) ^ (lane[2] * 961u) ^ (lane[3] * 29791u)) ^ (uint64_t)size;
    for (; k < size; k++) {
        h = (h ^ bytes[k]) * prime;
    }
    return h;
}

static pthread_mutex_t states_lock = PTHREAD_MUTEX_INITIALIZER;
static fmu_state_t *states_head; /* guarded by states_lock */

static void state_register(fmu_state_t *s, inst_t *owner)
{
    s->owner = owner;
    pthread_mutex_lock(&states_lock);
    s->live_next = states_head;
    states_head = s;
    pthread_mutex_unlock(&states_lock);
}

/* The live state behind a handle, or NULL (also for NULL); with take, it is
 * removed from the registry (to be freed), so a second take finds nothing. */
static fmu_state_t *state_find(const void *handle, int take)
{
    if (handle == NULL) {
        return NULL;
    }
    pthread_mutex_lock(&states_lock);
    fmu_state_t **p = &states_head;
    while (*p != NULL && (const void *)*p != handle) {
        p = &(*p)->live_next;
    }
    fmu_state_t *s = *p;
    if (s != NULL && take) {
        *p = s->live_next;
        s->live_next = NULL;
    }
    pthread_mutex_unlock(&states_lock);
    return s;
}

/* A lazy state out of its instance's list of lazy states: no longer lazy. */
static void state_unlink(fmu_state_t *s)
{
    fmu_state_t **p = &s->lazy->lazy_states;
    while (*p != NULL && *p != s) {
        p = &(*p)->next;
    }
    if (*p == s) {
        *p = s->next;
    }
    s->lazy = NULL;
    s->next = NULL;
}

/* Frees a state already taken out of the registry (state_find with take). */
static void state_free(fmu_state_t *s)
{
    if (s == NULL) {
        return;
    }
    if (s->lazy != NULL) {
        state_unlink(s);
    }
    free(s->bytes);
    free(s);
}

/* The native part of a lazy state into its own bytes. */
static fmi2Status state_keep(fmu_state_t *s, const char *fn)
{
    inst_t *in = s->lazy;
    unsigned char *b = realloc(s->bytes, s->size);
    if (b == NULL) {
        return fmi_fail(in, fn, "out of memory for a copy of a saved FMU state (%zu bytes), made before the "
                        "component changes: free the states no longer needed (fmi2FreeFMUstate)", s->size);
    }
    s->bytes = b;
    const status_t st = in->model->state_save(in->comp, s->bytes + s->head, s->size - s->head);
    if (st >= STATUS_ERROR) {
        return fmi_report(in, st, fn, "the %s component could not save its state", in->model->identifier);
    }
    state_unlink(s);
    return fmi2OK;
}

fmi2Status fmi_states_keep(inst_t *in, const char *fn)
{
    while (in->lazy_states != NULL) {
        const fmi2Status st = state_keep(in->lazy_states, fn);
        if (st >= fmi2Error) {
            return st;
        }
    }
    return fmi2OK;
}

void fmi_states_free(inst_t *in)
{
    fmu_state_t *mine = NULL;
    pthread_mutex_lock(&states_lock);
    for (fmu_state_t **p = &states_head; *p != NULL;) {
        fmu_state_t *s = *p;
        if (s->owner == in) {
            *p = s->live_next;
            s->live_next = mine;
            mine = s;
        } else {
            p = &s->live_next;
        }
    }
    pthread_mutex_unlock(&states_lock);
    while (mine != NULL) {
        fmu_state_t *next = mine->live_next;
        state_free(mine);
        mine = next;
    }
    in->lazy_states = NULL;
}

/* A state of the instance now: the header and values copied, the native
 * part left in the component (lazy). */
static fmi2Status save_state(inst_t *in, const char *fn, fmu_state_t **out)
{
    state_header_t h;
    memset(&h, 0, sizeof h);
    memcpy(h.magic, STATE_MAGIC, sizeof h.magic);
    snprintf(h.model, sizeof h.model, "%s", in->model->identifier);
    memcpy(h.guid, in->guid, sizeof in->guid);
    h.nvars = (uint64_t)in->vars.n;
    h.comp_size = in->comp != NULL ? (uint64_t)in->model->state_size(in->comp) : 0u;
    h.state = in->state;
    h.has_comp = in->comp != NULL;
    h.has_stop = in->has_stop;
    h.t = in->t;
    h.t_start = in->t_start;
    h.t_stop = in->t_stop;
    const size_t nval = (size_t)in->vars.n * sizeof(double);
    fmu_state_t *s = calloc(1, sizeof *s);
    if (s != NULL) {
        s->head = sizeof h + 2 * nval;
        s->size = s->head + (size_t)h.comp_size;
        s->bytes = malloc(s->head);
    }
    if (s == NULL || s->bytes == NULL) {
        free(s);
        return fmi_fail(in, fn, "out of memory for an FMU state (%zu bytes)", sizeof h + 2 * nval);
    }
    memcpy(s->bytes, &h, sizeof h);
    memcpy(s->bytes + sizeof h, in->values, nval);
    memcpy(s->bytes + sizeof h + nval, in->made_with, nval);
    if (in->comp != NULL) {
        s->lazy = in;
        s->next = in->lazy_states;
        in->lazy_states = s;
    }
    *out = s;
    return fmi2OK;
}

/* The live state behind a handle given to fn, or NULL (logged). */
static fmu_state_t *live_state(const inst_t *in, const char *fn, const void *handle)
{
    fmu_state_t *s = state_find(handle, 0);
    if (s == NULL) {
        fmi_fail(in, fn, "FMUstate %p is not a live FMU state of this FMU: freed already (fmi2FreeFMUstate, or "
                 "fmi2FreeInstance of the instance that made it) or never returned by fmi2GetFMUstate or "
                 "fmi2DeSerializeFMUstate", handle);
    }
    return s;
}

/* Checks that a blob was made by an FMU of this model and scene. */
static fmi2Status check_blob(const inst_t *in, const char *fn, const unsigned char *bytes, size_t size,
                             state_header_t *h)
{
    if (size < sizeof *h) {
        return fmi_fail(in, fn, "the FMU state has %zu bytes, fewer than its header (%zu)", size, sizeof *h);
    }
    memcpy(h, bytes, sizeof *h);
    if (memcmp(h->magic, STATE_MAGIC, sizeof h->magic) != 0) {
        return fmi_fail(in, fn, "not an FMU state of this project (bad magic)");
    }
    h->model[sizeof h->model - 1] = '\0';
    h->guid[sizeof h->guid - 1] = '\0';
    /* printable in the message below (a forged blob's bytes are not UTF-8,
     * and a master's logger may decode the message as such) */
    for (char *t = h->model; *t != '\0'; t++) {
        *t = (*t >= ' ' && *t <= '~') ? *t : '?';
    }
    for (char *t = h->guid; *t != '\0'; t++) {
        *t = (*t >= ' ' && *t <= '~') ? *t : '?';
    }
    if (strcmp(h->model, in->model->identifier) != 0 || strcmp(h->guid, in->guid) != 0) {
        return fmi_fail(in, fn, "the FMU state belongs to model %s with GUID %s; this is %s with GUID %s", h->model,
                        h->guid, in->model->identifier, in->guid);
    }
    const size_t nval = (size_t)in->vars.n * sizeof(double);
    if (h->nvars != (uint64_t)in->vars.n || size != sizeof *h + 2 * nval + h->comp_size ||
        (h->has_comp == 0) != (h->comp_size == 0) || h->state <= 0 || h->state >= (1 << NSTATES) ||
        (h->state & (h->state - 1)) != 0) {
        return fmi_fail(in, fn, "the FMU state is inconsistent (%zu bytes, %llu variables, component %llu bytes)", size,
                        (unsigned long long)h->nvars, (unsigned long long)h->comp_size);
    }
    /* the state the instance is put in must be one a state can be taken in,
     * with a component exactly where that state has one: a header that said
     * StepComplete without one was taken, and the next fmi2DoStep stepped a
     * NULL component (segmentation fault) */
    const int needs_comp = S_STEP_COMPLETE | S_STEP_FAILED | S_STEP_CANCELED | S_TERMINATED;
    if (!(h->state & M_FMU_STATE) || (h->has_comp != 0 && h->has_comp != 1) ||
        ((h->state & needs_comp) && !h->has_comp) || (h->state == S_INSTANTIATED && h->has_comp)) {
        return fmi_fail(in, fn, "the FMU state is inconsistent: state %s %s a component (has_comp %d); allowed: "
                        "a component in StepComplete, StepFailed, StepCanceled and Terminated, none in Instantiated, "
                        "no state in StepInProgress or Fatal", fmi_state_name(h->state),
                        h->has_comp ? "with" : "without", (int)h->has_comp);
    }
    if (!isfinite(h->t) || !isfinite(h->t_start) || (h->has_stop != 0 && h->has_stop != 1) ||
        (h->has_stop && !isfinite(h->t_stop))) {
        return fmi_fail(in, fn, "the FMU state is corrupt: time %g s, start time %g s, stop time %g s (has_stop %d); "
                        "allowed: finite times", h->t, h->t_start, h->t_stop, (int)h->has_stop);
    }
    return fmi2OK;
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    const char *fn = "fmi2GetFMUstate";
    BEGIN(fn, M_FMU_STATE);
    if (FMUstate == NULL) {
        return fmi_fail(in, fn, "FMUstate is NULL");
    }
    fmi_trace(in, fn, "t=%.17g", in->t);
    fmu_state_t *s = NULL;
    fmi2Status st = save_state(in, fn, &s);
    if (st >= fmi2Error) {
        return st;
    }
    state_register(s, in);
    /* a previous state handed in for reuse; anything else is not ours to free */
    state_free(state_find(*FMUstate, 1));
    *FMUstate = s;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate)
{
    const char *fn = "fmi2SetFMUstate";
    BEGIN(fn, M_FMU_STATE);
    state_header_t h;
    if (FMUstate == NULL) {
        return fmi_fail(in, fn, "FMUstate is NULL");
    }
    fmu_state_t *s = live_state(in, fn, FMUstate);
    if (s == NULL || check_blob(in, fn, s->bytes, s->size, &h) != fmi2OK) {
        return fmi2Error;
    }
    /* this instance's own state, its component unchanged since (a change
     * would have copied it): the component is in that state already */
    const int current = s->lazy == in;
    if (!current && s->lazy != NULL && state_keep(s, fn) >= fmi2Error) {
        return fmi2Error; /* another instance's state: its own copy first */
    }
    if (!current && fmi_states_keep(in, fn) >= fmi2Error) {
        return fmi2Error; /* the states taken here before, before the component changes */
    }
    fmi_trace(in, fn, "t=%.17g", h.t);
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
        fmi_drop_component(in);
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
                return fmi_fail(in, fn, "out of memory for a copy of the values (%zu bytes)", nval + sizeof(double));
            }
            memcpy(keep, in->values, nval);
            memcpy(in->values, made_with, nval);
            status_t st = fmi_ensure_component(in, fn);
            memcpy(in->values, keep, nval);
            free(keep);
            if (st >= STATUS_ERROR) {
                in->state = st == STATUS_FATAL ? S_FATAL : S_ERROR;
                return (fmi2Status)st;
            }
        }
        status_t st = current ? STATUS_OK
                              : in->model->state_restore(in->comp, s->bytes + sizeof h + 2 * nval, (size_t)h.comp_size);
        if (st >= STATUS_ERROR) {
            in->state = st == STATUS_FATAL ? S_FATAL : S_ERROR;
            return fmi_report(in, st, fn, "the %s component could not restore the state", in->model->identifier);
        }
        memcpy(in->made_with, made_with, nval);
        in->model->outputs(in->comp, &in->vars, in->values);
        in->lazy_stale = 1;
    }
    in->state = h.state;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    BEGIN("fmi2FreeFMUstate", M_FMU_STATE);
    fmi_trace(in, "fmi2FreeFMUstate", "%s", "");
    if (FMUstate == NULL) {
        return fmi_fail(in, "fmi2FreeFMUstate", "FMUstate is NULL");
    }
    fmu_state_t *s = state_find(*FMUstate, 1);
    if (s == NULL && *FMUstate != NULL) {
        /* freed already (a copy of the handle), with its instance, or never ours: not touched */
        fmi_report(in, STATUS_WARNING, "fmi2FreeFMUstate", "FMUstate %p is not a live FMU state of this FMU (freed "
                   "already, or with the instance that made it): ignored", *FMUstate);
        *FMUstate = NULL;
        return fmi2Warning;
    }
    state_free(s);
    *FMUstate = NULL;
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size)
{
    BEGIN("fmi2SerializedFMUstateSize", M_FMU_STATE);
    if (FMUstate == NULL || size == NULL) {
        return fmi_fail(in, "fmi2SerializedFMUstateSize", "%s is NULL", FMUstate == NULL ? "FMUstate" : "size");
    }
    const fmu_state_t *s = live_state(in, "fmi2SerializedFMUstateSize", FMUstate);
    if (s == NULL) {
        return fmi2Error;
    }
    *size = s->size;
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size)
{
    const char *fn = "fmi2SerializeFMUstate";
    BEGIN(fn, M_FMU_STATE);
    if (FMUstate == NULL || serializedState == NULL) {
        return fmi_fail(in, fn, "%s is NULL", FMUstate == NULL ? "FMUstate" : "serializedState");
    }
    const fmu_state_t *s = live_state(in, fn, FMUstate);
    if (s == NULL) {
        return fmi2Error;
    }
    if (size != s->size) {
        return fmi_fail(in, fn, "size = %zu; allowed: %zu, as fmi2SerializedFMUstateSize gives", size, s->size);
    }
    if (s->lazy == NULL) {
        memcpy(serializedState, s->bytes, s->size);
    } else {
        /* straight from the component, which is still in that state */
        const inst_t *owner = s->lazy;
        memcpy(serializedState, s->bytes, s->head);
        const status_t st = owner->model->state_save(owner->comp, (unsigned char *)serializedState + s->head,
                                                     s->size - s->head);
        if (st >= STATUS_ERROR) {
            return fmi_report(in, st, fn, "the %s component could not save its state", owner->model->identifier);
        }
    }
    const uint64_t sum = state_sum((const unsigned char *)serializedState, s->size);
    memcpy(serializedState + offsetof(state_header_t, sum), &sum, sizeof sum);
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate)
{
    const char *fn = "fmi2DeSerializeFMUstate";
    BEGIN(fn, M_FMU_STATE);
    state_header_t h;
    if (serializedState == NULL || FMUstate == NULL) {
        return fmi_fail(in, fn, "%s is NULL", serializedState == NULL ? "serializedState" : "FMUstate");
    }
    if (check_blob(in, fn, (const unsigned char *)serializedState, size, &h) != fmi2OK) {
        return fmi2Error;
    }
    const uint64_t sum = state_sum((const unsigned char *)serializedState, size);
    if (sum != h.sum) {
        return fmi_fail(in, fn, "the serialized FMU state is damaged: its checksum is %016llx, its bytes give %016llx "
                        "(changed after fmi2SerializeFMUstate wrote them); nothing is restored",
                        (unsigned long long)h.sum, (unsigned long long)sum);
    }
    fmu_state_t *s = calloc(1, sizeof *s);
    if (s != NULL && (s->bytes = malloc(size)) == NULL) {
        free(s);
        s = NULL;
    }
    if (s == NULL) {
        return fmi_fail(in, fn, "out of memory for an FMU state of %zu bytes", size);
    }
    s->size = size;
    s->head = size;
    memcpy(s->bytes, serializedState, size);
    state_register(s, in);
    state_free(state_find(*FMUstate, 1)); /* a previous state handed in for reuse, as fmi2GetFMUstate */
    *FMUstate = s;
    return fmi2OK;
}
