/* fmu.c — loading an FMI 2.0 Co-Simulation FMU and calling it (fmu.h).
 *
 * Owns: the unpacked folder (when it unpacked an archive itself, it is left
 * for the caller's work_dir cleanup), the parsed variable table, the dlopen
 * handle and the instance. Invariant: every fmi2* call goes through call_*
 * below, so that the call counters and the call log see all of them. */
#define _XOPEN_SOURCE 700 /* realpath */
#include "fmu.h"

#include "../common/fmi2.h"

#include <dlfcn.h>
#include <errno.h>
#include <libxml/parser.h>
#include <libxml/tree.h>
#include <math.h>
#include <omp.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <zip.h>

#define CAT "fmu"

const char *const fmu_call_names[FMU_NCALLS] = {
    "fmi2Instantiate", "fmi2SetupExperiment", "fmi2EnterInitializationMode", "fmi2ExitInitializationMode",
    "fmi2SetReal",     "fmi2SetString",       "fmi2GetReal",                 "fmi2GetInteger",
    "fmi2GetBoolean",  "fmi2DoStep",          "fmi2GetFMUstate",             "fmi2SetFMUstate",
    "fmi2FreeFMUstate", "fmi2SerializedFMUstateSize", "fmi2SerializeFMUstate", "fmi2DeSerializeFMUstate",
    "fmi2Terminate",      "fmi2FreeInstance",
};

/* Pointer types of the functions the master calls (FMI 2.0, 2.1 and 4.2). */
typedef fmi2Component (*instantiate_fn)(fmi2String, fmi2Type, fmi2String, fmi2String, const fmi2CallbackFunctions *,
                                        fmi2Boolean, fmi2Boolean);
typedef void (*free_instance_fn)(fmi2Component);
typedef fmi2Status (*setup_fn)(fmi2Component, fmi2Boolean, fmi2Real, fmi2Real, fmi2Boolean, fmi2Real);
typedef fmi2Status (*plain_fn)(fmi2Component);
typedef fmi2Status (*set_real_fn)(fmi2Component, const fmi2ValueReference *, size_t, const fmi2Real *);
typedef fmi2Status (*get_real_fn)(fmi2Component, const fmi2ValueReference *, size_t, fmi2Real *);
typedef fmi2Status (*get_int_fn)(fmi2Component, const fmi2ValueReference *, size_t, fmi2Integer *);
typedef fmi2Status (*set_string_fn)(fmi2Component, const fmi2ValueReference *, size_t, const fmi2String *);
typedef fmi2Status (*do_step_fn)(fmi2Component, fmi2Real, fmi2Real, fmi2Boolean);
typedef fmi2Status (*get_state_fn)(fmi2Component, fmi2FMUstate *);
typedef fmi2Status (*set_state_fn)(fmi2Component, fmi2FMUstate);
typedef fmi2Status (*state_size_fn)(fmi2Component, fmi2FMUstate, size_t *);
typedef fmi2Status (*serialize_fn)(fmi2Component, fmi2FMUstate, fmi2Byte[], size_t);
typedef fmi2Status (*deserialize_fn)(fmi2Component, const fmi2Byte[], size_t, fmi2FMUstate *);
typedef const char *(*version_fn)(void);

typedef struct {
    version_fn get_version;
    instantiate_fn instantiate;
    free_instance_fn free_instance;
    setup_fn setup_experiment;
    plain_fn enter_init, exit_init, terminate;
    set_real_fn set_real;
    get_real_fn get_real;
    get_int_fn get_integer, get_boolean;
    set_string_fn set_string;
    do_step_fn do_step;
    get_state_fn get_state;
    set_state_fn set_state;
    get_state_fn free_state;
    state_size_fn state_size;
    serialize_fn serialize;
    deserialize_fn deserialize;
} fmi_api_t;

struct fmu {
    char *label, *dir, *identifier, *guid;
    fmu_var_t *vars;
    int nvars;
    const fmu_var_t **by_name; /* the variables sorted by name, then order: fmu_find */
    void *lib;
    fmi_api_t api;
    fmi2CallbackFunctions *callbacks; /* alive as long as the instance */
    fmi2Component inst;
    int initialised;
    int failed; /* a call returned fmi2Error or fmi2Fatal: no fmi2Terminate */
    FILE *calls;
    log_t log;
    long count[FMU_NCALLS];
    double step_seconds;
};

/* by name, then by place in the description */
static int by_name_order(const void *a, const void *b)
{
    const fmu_var_t *u = *(const fmu_var_t *const *)a, *v = *(const fmu_var_t *const *)b;
    const int c = strcmp(u->name, v->name);
    return c != 0 ? c : (u > v) - (u < v);
}

/* ------------------------------------------------------------------------ */
/* Unpacking                                                                 */

static int make_dirs(char *path)
{
    for (char *p = path + 1; *p != '\0'; p++) {
        if (*p == '/') {
            *p = '\0';
            const int bad = mkdir(path, 0777) != 0 && errno != EEXIST;
            *p = '/';
            if (bad) {
                return 0;
            }
        }
    }
    return 1;
}

static status_t unpack(const char *archive, const char *dest, const log_t *log)
{
    int err = 0;
    zip_t *z = zip_open(archive, ZIP_RDONLY, &err);
    if (z == NULL) {
        zip_error_t ze;
        zip_error_init_with_code(&ze, err);
        log_msg(log, STATUS_ERROR, CAT, "%s: cannot open the FMU archive: %s", archive, zip_error_strerror(&ze));
        zip_error_fini(&ze);
        return STATUS_ERROR;
    }
    status_t st = STATUS_OK;
    char *buf = malloc(1 << 16);
    const zip_int64_t n = zip_get_num_entries(z, 0);
    if (buf == NULL) {
        st = log_msg(log, STATUS_FATAL, CAT, "out of memory for the unpacking buffer (%d bytes)", 1 << 16);
    }
    for (zip_int64_t i = 0; i < n && st == STATUS_OK; i++) {
        const char *name = zip_get_name(z, (zip_uint64_t)i, 0);
        if (name == NULL || name[0] == '\0' || name[0] == '/' || strstr(name, "..") != NULL) {
            st = log_msg(log, STATUS_ERROR, CAT, "%s: entry %lld has an unsafe name", archive, (long long)i);
            break;
        }
        char path[4096];
        if (snprintf(path, sizeof path, "%s/%s", dest, name) >= (int)sizeof path || !make_dirs(path)) {
            st = log_msg(log, STATUS_ERROR, CAT, "%s: cannot create the folder for %s", archive, name);
            break;
        }
        if (name[strlen(name) - 1] == '/') {
            continue;
        }
        zip_file_t *zf = zip_fopen_index(z, (zip_uint64_t)i, 0);
        FILE *out = zf != NULL ? fopen(path, "wb") : NULL;
        zip_int64_t got = 0;
        int ok = zf != NULL && out != NULL;
        while (ok && (got = zip_fread(zf, buf, 1 << 16)) > 0) {
            ok = fwrite(buf, 1, (size_t)got, out) == (size_t)got;
        }
        ok = ok && got == 0;
        if (out != NULL && fclose(out) != 0) {
            ok = 0;
        }
        if (!ok) {
            st = log_msg(log, STATUS_ERROR, CAT, "%s: cannot unpack %s: %s", archive, name,
                         zf == NULL || got < 0 ? zip_strerror(z) : strerror(errno));
        }
        if (zf != NULL) {
            zip_fclose(zf);
        }
    }
    free(buf);
    zip_discard(z);
    return st;
}

/* ------------------------------------------------------------------------ */
/* modelDescription.xml                                                      */

static char *prop(xmlNodePtr node, const char *name)
{
    xmlChar *v = xmlGetProp(node, BAD_CAST name);
    char *s = v != NULL ? strdup((const char *)v) : NULL;
    xmlFree(v);
    return s;
}

static int is(xmlNodePtr node, const char *name)
{
    return node->type == XML_ELEMENT_NODE && xmlStrcmp(node->name, BAD_CAST name) == 0;
}

static status_t parse_variable(fmu_t *f, xmlNodePtr sv, fmu_var_t *v, const char *xml)
{
    char *vr = prop(sv, "valueReference"), *causality = prop(sv, "causality");
    status_t st = STATUS_OK;
    v->name = prop(sv, "name");
    v->causality = FMU_OTHER;
    if (causality != NULL) {
        v->causality = strcmp(causality, "parameter") == 0 ? FMU_PARAMETER
                       : strcmp(causality, "input") == 0   ? FMU_INPUT
                       : strcmp(causality, "output") == 0  ? FMU_OUTPUT
                                                           : FMU_OTHER;
    }
    char *end = NULL;
    const unsigned long r = vr != NULL ? strtoul(vr, &end, 10) : 0;
    if (v->name == NULL || vr == NULL || end == vr || *end != '\0' || r > 0xffffffffUL) {
        st = log_msg(&f->log, STATUS_ERROR, CAT, "%s: a ScalarVariable without a valid name or valueReference", xml);
        goto done;
    }
    v->vr = (unsigned)r;
    int typed = 0;
    for (xmlNodePtr t = sv->children; t != NULL; t = t->next) {
        if (is(t, "Real") || is(t, "Integer") || is(t, "Boolean") || is(t, "String")) {
            v->type = is(t, "Real") ? FMU_REAL : is(t, "Integer") ? FMU_INTEGER : is(t, "Boolean") ? FMU_BOOLEAN
                                                                                                   : FMU_STRING;
            v->unit = prop(t, "unit");
            typed = 1;
        }
    }
    if (!typed) {
        st = log_msg(&f->log, STATUS_ERROR, CAT, "%s: variable %s has no Real, Integer, Boolean or String element", xml,
                     v->name);
    }
done:
    free(vr);
    free(causality);
    return st;
}

static status_t parse_description(fmu_t *f)
{
    char xml[4200];
    snprintf(xml, sizeof xml, "%s/modelDescription.xml", f->dir);
    xmlDocPtr doc = xmlReadFile(xml, NULL, XML_PARSE_NONET | XML_PARSE_NOERROR | XML_PARSE_NOWARNING);
    status_t st = STATUS_OK;
    char *version = NULL;
    if (doc == NULL) {
        return log_msg(&f->log, STATUS_ERROR, CAT, "%s: %s is missing or not well-formed XML", f->label, xml);
    }
    xmlNodePtr root = xmlDocGetRootElement(doc);
    if (root == NULL || !is(root, "fmiModelDescription") || (version = prop(root, "fmiVersion")) == NULL ||
        strcmp(version, "2.0") != 0) {
        st = log_msg(&f->log, STATUS_ERROR, CAT, "%s: %s is not an FMI 2.0 model description", f->label, xml);
        goto done;
    }
    f->guid = prop(root, "guid");
    int nsv = 0;
    for (xmlNodePtr c = root->children; c != NULL; c = c->next) {
        if (is(c, "CoSimulation") && f->identifier == NULL) {
            f->identifier = prop(c, "modelIdentifier");
        }
        if (is(c, "ModelVariables")) {
            for (xmlNodePtr sv = c->children; sv != NULL; sv = sv->next) {
                nsv += is(sv, "ScalarVariable");
            }
        }
    }
    if (f->guid == NULL || f->identifier == NULL || strchr(f->identifier, '/') != NULL) {
        st = log_msg(&f->log, STATUS_ERROR, CAT, "%s: %s has no guid or no CoSimulation modelIdentifier", f->label,
                     xml);
        goto done;
    }
    f->vars = calloc((size_t)nsv + 1, sizeof *f->vars);
    if (f->vars == NULL) {
        st = log_msg(&f->log, STATUS_FATAL, CAT, "%s: out of memory for %d variables (%zu bytes)", f->label, nsv, ((size_t)nsv + 1) * sizeof *f->vars);
        goto done;
    }
    for (xmlNodePtr c = root->children; c != NULL && st == STATUS_OK; c = c->next) {
        for (xmlNodePtr sv = is(c, "ModelVariables") ? c->children : NULL; sv != NULL && st == STATUS_OK;
             sv = sv->next) {
            if (is(sv, "ScalarVariable")) {
                st = parse_variable(f, sv, &f->vars[f->nvars++], xml);
            }
        }
    }
    if (st == STATUS_OK) {
        /* a master looks up every connected and observed variable by name:
         * with thousands of them (a sphere's position, velocity and load each)
         * a linear search per name made start-up quadratic */
        f->by_name = malloc(((size_t)f->nvars + 1) * sizeof *f->by_name);
        if (f->by_name == NULL) {
            st = log_msg(&f->log, STATUS_FATAL, CAT, "%s: out of memory for the index of %d variables", f->label,
                         f->nvars);
            goto done;
        }
        for (int j = 0; j < f->nvars; j++) {
            f->by_name[j] = &f->vars[j];
        }
        qsort(f->by_name, (size_t)f->nvars, sizeof *f->by_name, by_name_order);
    }
done:
    free(version);
    xmlFreeDoc(doc);
    return st;
}

/* ------------------------------------------------------------------------ */
/* Loading                                                                   */

static void fmi_logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status, fmi2String category,
                       fmi2String message, ...)
{
    const fmu_t *f = env;
    char buf[4096];
    va_list ap;
    va_start(ap, message);
    vsnprintf(buf, sizeof buf, message != NULL ? message : "", ap);
    va_end(ap);
    const status_t level = status == fmi2OK        ? STATUS_OK
                           : status == fmi2Warning ? STATUS_WARNING
                           : status == fmi2Discard ? STATUS_DISCARD
                           : status == fmi2Error   ? STATUS_ERROR
                                                   : STATUS_FATAL;
    /* the scene's warnings: the master has read the same scene with the
     * same overrides and reported them already (an FMU of another scene is
     * refused) */
    if (level == STATUS_WARNING && strncmp(buf, "[scene] ", 8) == 0) {
        return;
    }
    log_msg(&f->log, level, f->label, "%s [%s] %s", instance != NULL ? instance : "-",
            category != NULL ? category : "-", buf);
}

static int resolve(fmu_t *f, const char *name, void *fp, size_t size)
{
    dlerror();
    void *sym = dlsym(f->lib, name);
    if (sym == NULL) {
        log_msg(&f->log, STATUS_ERROR, CAT, "%s: the library does not export %s", f->label, name);
        return 0;
    }
    memcpy(fp, &sym, size); /* POSIX: a data pointer from dlsym holds a function address */
    return 1;
}

status_t fmu_load(const char *path, const char *work_dir, const char *label, FILE *calls, const log_t *log,
                  fmu_t **out)
{
    *out = NULL;
    fmu_t *f = calloc(1, sizeof *f);
    if (f == NULL) {
        return log_msg(log, STATUS_FATAL, CAT, "out of memory for an FMU (%zu bytes)", sizeof *f);
    }
    f->log = *log;
    f->calls = calls;
    status_t st = STATUS_OK;
    struct stat sb;
    char dir[4096];
    if ((f->label = strdup(label)) == NULL) {
        st = log_msg(log, STATUS_FATAL, CAT, "out of memory for the FMU label (%zu bytes)", strlen(label) + 1);
        goto done;
    }
    if (stat(path, &sb) != 0) {
        st = log_msg(log, STATUS_ERROR, CAT, "%s: cannot read the FMU %s: %s", label, path, strerror(errno));
        goto done;
    }
    if (S_ISDIR(sb.st_mode)) {
        snprintf(dir, sizeof dir, "%s", path);
    } else {
        if (snprintf(dir, sizeof dir, "%s/%s", work_dir, label) >= (int)sizeof dir) {
            st = log_msg(log, STATUS_ERROR, CAT, "%s: path too long", label);
            goto done;
        }
        if ((st = unpack(path, dir, log)) != STATUS_OK) {
            goto done;
        }
    }
    if ((f->dir = realpath(dir, NULL)) == NULL) {
        st = log_msg(log, STATUS_ERROR, CAT, "%s: cannot resolve the folder %s: %s", label, dir, strerror(errno));
        goto done;
    }
    if ((st = parse_description(f)) != STATUS_OK) {
        goto done;
    }
    char lib[4400];
    fmu_library_path(f, lib, sizeof lib);
    f->lib = dlopen(lib, RTLD_NOW | RTLD_LOCAL);
    if (f->lib == NULL) {
        st = log_msg(log, STATUS_ERROR, CAT, "%s: cannot load the FMU library: %s", label, dlerror());
        goto done;
    }
    fmi_api_t *a = &f->api;
    if (!resolve(f, "fmi2GetVersion", &a->get_version, sizeof a->get_version) ||
        !resolve(f, "fmi2Instantiate", &a->instantiate, sizeof a->instantiate) ||
        !resolve(f, "fmi2FreeInstance", &a->free_instance, sizeof a->free_instance) ||
        !resolve(f, "fmi2SetupExperiment", &a->setup_experiment, sizeof a->setup_experiment) ||
        !resolve(f, "fmi2EnterInitializationMode", &a->enter_init, sizeof a->enter_init) ||
        !resolve(f, "fmi2ExitInitializationMode", &a->exit_init, sizeof a->exit_init) ||
        !resolve(f, "fmi2Terminate", &a->terminate, sizeof a->terminate) ||
        !resolve(f, "fmi2SetReal", &a->set_real, sizeof a->set_real) ||
        !resolve(f, "fmi2GetReal", &a->get_real, sizeof a->get_real) ||
        !resolve(f, "fmi2GetInteger", &a->get_integer, sizeof a->get_integer) ||
        !resolve(f, "fmi2GetBoolean", &a->get_boolean, sizeof a->get_boolean) ||
        !resolve(f, "fmi2SetString", &a->set_string, sizeof a->set_string) ||
        !resolve(f, "fmi2DoStep", &a->do_step, sizeof a->do_step) ||
        !resolve(f, "fmi2GetFMUstate", &a->get_state, sizeof a->get_state) ||
        !resolve(f, "fmi2SetFMUstate", &a->set_state, sizeof a->set_state) ||
        !resolve(f, "fmi2FreeFMUstate", &a->free_state, sizeof a->free_state) ||
        !resolve(f, "fmi2SerializedFMUstateSize", &a->state_size, sizeof a->state_size) ||
        !resolve(f, "fmi2SerializeFMUstate", &a->serialize, sizeof a->serialize) ||
        !resolve(f, "fmi2DeSerializeFMUstate", &a->deserialize, sizeof a->deserialize)) {
        st = STATUS_ERROR;
        goto done;
    }
    const char *version = a->get_version();
    if (version == NULL || strcmp(version, "2.0") != 0) {
        st = log_msg(log, STATUS_ERROR, CAT, "%s: fmi2GetVersion returns '%s', not 2.0", label,
                     version != NULL ? version : "(null)");
        goto done;
    }
done:
    if (st != STATUS_OK) {
        fmu_free(f);
        return st;
    }
    *out = f;
    return STATUS_OK;
}

/* ------------------------------------------------------------------------ */
/* Calls                                                                     */

static const char *status_text(fmi2Status s)
{
    static const char *const names[] = {"fmi2OK", "fmi2Warning", "fmi2Discard", "fmi2Error", "fmi2Fatal",
                                        "fmi2Pending"};
    return (unsigned)s < 6u ? names[s] : "(unknown status)";
}

/* Counts the call, writes the call log line and turns the status into a
 * status_t (an error names the FMU and the call). args: the argument text. */
static status_t finish(fmu_t *f, int which, const char *args, fmi2Status s)
{
    f->count[which]++;
    if (f->calls != NULL) {
        fprintf(f->calls, "%s %s(%s) -> %s\n", f->label, fmu_call_names[which], args, status_text(s));
    }
    if (s == fmi2OK || s == fmi2Warning) {
        return s == fmi2OK ? STATUS_OK : STATUS_WARNING;
    }
    f->failed = 1;
    return log_msg(&f->log, STATUS_ERROR, CAT, "%s: %s(%.300s%s) returned %s", f->label, fmu_call_names[which], args,
                   strlen(args) > 300 ? "..." : "", status_text(s));
}

/* "vr=[..], value=[..]" for the call log; only built when it is written. */
static char *list_args(const fmu_t *f, const unsigned *vr, size_t n, const double *dv, const int *iv)
{
    if (f->calls == NULL) {
        return NULL;
    }
    size_t cap = 32 + n * 40;
    char *s = malloc(cap);
    if (s == NULL) {
        return NULL;
    }
    size_t k = (size_t)snprintf(s, cap, "vr=[");
    for (size_t i = 0; i < n; i++) {
        k += (size_t)snprintf(s + k, cap - k, "%s%u", i ? "," : "", vr[i]);
    }
    k += (size_t)snprintf(s + k, cap - k, "], nvr=%zu, value=[", n);
    for (size_t i = 0; i < n && (dv != NULL || iv != NULL); i++) {
        if (dv != NULL) {
            k += (size_t)snprintf(s + k, cap - k, "%s%.17g", i ? "," : "", dv[i]);
        } else {
            k += (size_t)snprintf(s + k, cap - k, "%s%d", i ? "," : "", iv[i]);
        }
    }
    snprintf(s + k, cap - k, "]");
    return s;
}

status_t fmu_instantiate(fmu_t *f, double t0, double t_stop)
{
    char uri[4200], args[4600];
    snprintf(uri, sizeof uri, "file://%s/resources", f->dir);
    const fmi2CallbackFunctions cb = {fmi_logger, calloc, free, NULL, f};
    if (f->callbacks == NULL && (f->callbacks = malloc(sizeof *f->callbacks)) == NULL) {
        return log_msg(&f->log, STATUS_FATAL, CAT, "%s: out of memory for the FMI callbacks (%zu bytes)", f->label, sizeof *f->callbacks);
    }
    memcpy(f->callbacks, &cb, sizeof cb); /* the members are const: copy, not assign */
    f->inst = f->api.instantiate(f->label, fmi2CoSimulation, f->guid, uri, f->callbacks, fmi2False, fmi2False);
    snprintf(args, sizeof args, "instanceName=%s, fmuType=fmi2CoSimulation, fmuGUID=%s, fmuResourceLocation=%s, "
             "visible=0, loggingOn=0", f->label, f->guid, uri);
    status_t st = finish(f, FMU_CALL_INSTANTIATE, args, f->inst != NULL ? fmi2OK : fmi2Error);
    if (st >= STATUS_ERROR) {
        return st;
    }
    snprintf(args, sizeof args, "toleranceDefined=0, tolerance=0, startTime=%.17g, stopTimeDefined=1, stopTime=%.17g",
             t0, t_stop);
    st = finish(f, FMU_CALL_SETUP_EXPERIMENT, args, f->api.setup_experiment(f->inst, fmi2False, 0.0, t0, fmi2True,
                                                                          t_stop));
    if (st >= STATUS_ERROR) {
        return st;
    }
    return finish(f, FMU_CALL_ENTER_INIT, "", f->api.enter_init(f->inst));
}

status_t fmu_set_string(fmu_t *f, unsigned vr, const char *value)
{
    char args[4400];
    snprintf(args, sizeof args, "vr=[%u], nvr=1, value=[\"%s\"]", vr, value);
    fmi2String v[1] = {value};
    return finish(f, FMU_CALL_SET_STRING, args, f->api.set_string(f->inst, &vr, 1, v));
}

status_t fmu_exit_init(fmu_t *f)
{
    status_t st = finish(f, FMU_CALL_EXIT_INIT, "", f->api.exit_init(f->inst));
    f->initialised = st < STATUS_ERROR;
    return st;
}

status_t fmu_set_real(fmu_t *f, const unsigned *vr, size_t n, const double *v)
{
    const fmi2Status s = f->api.set_real(f->inst, vr, n, v);
    char *args = list_args(f, vr, n, v, NULL);
    status_t st = finish(f, FMU_CALL_SET_REAL, args != NULL ? args : "", s);
    free(args);
    return st;
}

status_t fmu_get_real(fmu_t *f, const unsigned *vr, size_t n, double *v)
{
    const fmi2Status s = f->api.get_real(f->inst, vr, n, v);
    char *args = list_args(f, vr, n, s <= fmi2Warning ? v : NULL, NULL);
    status_t st = finish(f, FMU_CALL_GET_REAL, args != NULL ? args : "", s);
    free(args);
    return st;
}

static status_t get_ints(fmu_t *f, int which, get_int_fn fn, const unsigned *vr, size_t n, int *v)
{
    const fmi2Status s = fn(f->inst, vr, n, v);
    char *args = list_args(f, vr, n, NULL, s <= fmi2Warning ? v : NULL);
    status_t st = finish(f, which, args != NULL ? args : "", s);
    free(args);
    return st;
}

status_t fmu_get_integer(fmu_t *f, const unsigned *vr, size_t n, int *v)
{
    return get_ints(f, FMU_CALL_GET_INTEGER, f->api.get_integer, vr, n, v);
}

status_t fmu_get_boolean(fmu_t *f, const unsigned *vr, size_t n, int *v)
{
    return get_ints(f, FMU_CALL_GET_BOOLEAN, f->api.get_boolean, vr, n, v);
}

status_t fmu_do_step(fmu_t *f, double t, double h)
{
    char args[200];
    const double w0 = omp_get_wtime();
    const fmi2Status s = f->api.do_step(f->inst, t, h, fmi2True);
    f->step_seconds += omp_get_wtime() - w0;
    snprintf(args, sizeof args, "currentCommunicationPoint=%.17g, communicationStepSize=%.17g, "
             "noSetFMUStatePriorToCurrentPoint=1", t, h);
    return finish(f, FMU_CALL_DO_STEP, args, s);
}

status_t fmu_get_state(fmu_t *f, void **state)
{
    fmi2FMUstate s = *state;
    status_t st = finish(f, FMU_CALL_GET_STATE, "", f->api.get_state(f->inst, &s));
    *state = s;
    return st;
}

status_t fmu_set_state(fmu_t *f, void *state)
{
    return finish(f, FMU_CALL_SET_STATE, "", f->api.set_state(f->inst, state));
}

status_t fmu_free_state(fmu_t *f, void **state)
{
    fmi2FMUstate s = *state;
    status_t st = finish(f, FMU_CALL_FREE_STATE, "", f->api.free_state(f->inst, &s));
    *state = s;
    return st;
}

status_t fmu_serialize_state(fmu_t *f, void *state, unsigned char **bytes, size_t *size)
{
    *bytes = NULL;
    *size = 0;
    size_t n = 0;
    status_t st = finish(f, FMU_CALL_STATE_SIZE, "", f->api.state_size(f->inst, state, &n));
    if (st >= STATUS_ERROR) {
        return st;
    }
    unsigned char *b = malloc(n > 0 ? n : 1);
    if (b == NULL) {
        return log_msg(&f->log, STATUS_FATAL, CAT, "%s: out of memory for the serialized state (%zu bytes)", f->label,
                       n);
    }
    char args[64];
    snprintf(args, sizeof args, "size=%zu", n);
    st = status_worst(st, finish(f, FMU_CALL_SERIALIZE, args, f->api.serialize(f->inst, state, (fmi2Byte *)b, n)));
    if (st >= STATUS_ERROR) {
        free(b);
        return st;
    }
    *bytes = b;
    *size = n;
    return st;
}

status_t fmu_deserialize_state(fmu_t *f, const unsigned char *bytes, size_t size, void **state)
{
    fmi2FMUstate s = NULL;
    char args[64];
    snprintf(args, sizeof args, "size=%zu", size);
    status_t st = finish(f, FMU_CALL_DESERIALIZE, args, f->api.deserialize(f->inst, (const fmi2Byte *)bytes, size, &s));
    *state = s;
    return st;
}

void fmu_library_path(const fmu_t *f, char *buf, size_t n)
{
    snprintf(buf, n, "%s/binaries/linux64/%s.so", f->dir, f->identifier);
}

void fmu_free(fmu_t *f)
{
    if (f == NULL) {
        return;
    }
    if (f->inst != NULL) {
        /* fmi2Terminate is illegal in the Error state (FMI 2.0, 4.2.4) */
        if (f->initialised && !f->failed) {
            finish(f, FMU_CALL_TERMINATE, "", f->api.terminate(f->inst));
        }
        f->api.free_instance(f->inst);
        finish(f, FMU_CALL_FREE_INSTANCE, "", fmi2OK);
    }
    if (f->lib != NULL) {
        dlclose(f->lib);
    }
    for (int j = 0; j < f->nvars; j++) {
        free(f->vars[j].name);
        free(f->vars[j].unit);
    }
    free(f->vars);
    free(f->by_name);
    free(f->callbacks);
    free(f->identifier);
    free(f->guid);
    free(f->dir);
    free(f->label);
    free(f);
}

const char *fmu_label(const fmu_t *f) { return f->label; }
const char *fmu_identifier(const fmu_t *f) { return f->identifier; }
const char *fmu_guid(const fmu_t *f) { return f->guid; }
int fmu_nvars(const fmu_t *f) { return f->nvars; }
const fmu_var_t *fmu_var(const fmu_t *f, int j) { return &f->vars[j]; }

/* The first variable of that name in the model description (names are
 * unique in a valid one): the lowest of the equal names in by_name. */
const fmu_var_t *fmu_find(const fmu_t *f, const char *name)
{
    if (f == NULL || f->by_name == NULL) {
        return NULL;
    }
    size_t lo = 0, hi = (size_t)f->nvars; /* the first name >= name lies in [lo, hi] */
    while (lo < hi) {
        const size_t mid = lo + (hi - lo) / 2;
        if (strcmp(f->by_name[mid]->name, name) < 0) {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    return lo < (size_t)f->nvars && strcmp(f->by_name[lo]->name, name) == 0 ? f->by_name[lo] : NULL;
}

long fmu_calls(const fmu_t *f, int which) { return f->count[which]; }

long fmu_calls_total(const fmu_t *f)
{
    long n = 0;
    for (int k = 0; k < FMU_NCALLS; k++) {
        n += f->count[k];
    }
    return n;
}

double fmu_step_seconds(const fmu_t *f) { return f->step_seconds; }
