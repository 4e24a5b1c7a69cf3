/* export.c — `coupler export SCENE.yaml -d DIR`: the scene's FMUs.
 *
 * For each model (fluid, rigid) the variable list comes from the same
 * fmi_model_t table the shared library uses (common/fmi_adapter.h), so the
 * modelDescription.xml written here (libxml2) and the library agree by
 * construction. An FMU is a zip archive (libzip) with
 *   modelDescription.xml          FMI 2.0 Co-Simulation, generated per scene
 *   binaries/linux64/<id>.so      build/fmu/<id>.so
 *   resources/scene.yaml          the scene text after --set overrides
 *   documentation/index.html      what the FMU is, its step, its variables
 *                                 (FMI 2.0 section 2.3), generated per scene
 * The GUID is a hash of that scene text (fmi_guid), checked by
 * fmi2Instantiate. A scene without free bodies gets no rigid.fmu, and one
 * left in DIR by an earlier export is removed.
 *
 * ModelStructure (FMI 2.0.x section 2.2.8) says what each output depends on.
 * Outputs: the dependencies hold at communication points, where the knowns
 * are the inputs; the components apply their inputs only inside fmi2DoStep
 * and refresh their outputs only after it (common/fmi_adapter.c), so no
 * output depends directly on an input: dependencies="" (no direct
 * feedthrough; a master that connects fluid and rigid both ways sees no
 * algebraic loop). InitialUnknowns: every output (all are
 * initial="calculated"); in Initialization Mode the knowns are the inputs and
 * the parameters (initial="exact"). The component is created from the scene
 * with the parameters that override scene keys applied, before any input is
 * used, so the dependencies are those parameters and never an input.
 *
 * Order: build every description and check DIR and the libraries first;
 * only then write, so a failure leaves nothing behind (libzip writes to a
 * temporary file and renames it on zip_close). */
#include "export.h"

#include "../common/fmi_adapter.h"
#include "version.h"

#include <errno.h>
#include <libxml/tree.h>
#include <libxml/xmlstring.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zip.h>

#define CAT "export"

typedef struct {
    const fmi_model_t *model;
    fmi_vars_t vars;
    xmlChar *xml; /* modelDescription.xml */
    char *doc;    /* documentation/index.html */
    size_t doc_len;
    int xml_len;
    char lib[4096]; /* path of the shared library */
    char out[4096]; /* path of the .fmu */
    int store;           /* library stored uncompressed (an FMU for one run: zlib cost about 0.3 s) */
} fmu_job_t;

/* The shortest %g text that reads back as x (1.6667e-05, not 1.6667000000000002e-05). */
static const char *fmt_num(double x, char *buf, size_t n)
{
    for (int digits = 15; digits <= 17; digits++) {
        snprintf(buf, n, "%.*g", digits, x);
        if (strtod(buf, NULL) == x) {
            break;
        }
    }
    return buf;
}

/* Adds an attribute; 0 when libxml2 runs out of memory. */
static int attr(xmlNodePtr node, const char *name, const char *value)
{
    return xmlNewProp(node, BAD_CAST name, BAD_CAST value) != NULL;
}

static int attr_num(xmlNodePtr node, const char *name, double x)
{
    char buf[40];
    return attr(node, name, fmt_num(x, buf, sizeof buf));
}

/* The DefaultExperiment's stop: run.end_time rounded up to whole LBM steps
 * (coupler/run.c's count of steps with one LBM step per communication step). */
static double default_stop(const scene_t *s)
{
    return ceil(s->run.end_time / s->fluid.dt - 1e-9) * s->fluid.dt;
}

static xmlNodePtr child(xmlNodePtr parent, const char *name)
{
    return xmlNewChild(parent, NULL, BAD_CAST name, NULL);
}

static const char *scene_name(const scene_t *s, char *buf, size_t n)
{
    const char *base = strrchr(s->path, '/') != NULL ? strrchr(s->path, '/') + 1 : s->path;
    snprintf(buf, n, "%s", base);
    char *dot = strrchr(buf, '.');
    if (dot != NULL && dot != buf) {
        *dot = '\0';
    }
    return buf;
}

static int add_units(xmlNodePtr root, const fmi_vars_t *vs)
{
    xmlNodePtr defs = child(root, "UnitDefinitions");
    if (defs == NULL) {
        return 0;
    }
    for (int u = 0; u < fmi_nunits; u++) {
        int used = 0;
        for (int j = 0; j < vs->n && !used; j++) {
            used = vs->v[j].unit != NULL && strcmp(vs->v[j].unit, fmi_units[u].name) == 0;
        }
        if (!used) {
            continue;
        }
        xmlNodePtr unit = child(defs, "Unit"), base = unit != NULL ? child(unit, "BaseUnit") : NULL;
        if (base == NULL || !attr(unit, "name", fmi_units[u].name)) {
            return 0;
        }
        const struct {
            const char *name;
            int e;
        } ex[] = {{"kg", fmi_units[u].kg}, {"m", fmi_units[u].m}, {"s", fmi_units[u].s}, {"rad", fmi_units[u].rad}};
        for (size_t k = 0; k < sizeof ex / sizeof ex[0]; k++) {
            if (ex[k].e != 0 && !attr_num(base, ex[k].name, ex[k].e)) {
                return 0;
            }
        }
    }
    return 1;
}

static int add_variable(xmlNodePtr list, const fmi_var_t *v, int vr)
{
    xmlNodePtr sv = child(list, "ScalarVariable");
    if (sv == NULL || !attr(sv, "name", v->name) || !attr_num(sv, "valueReference", vr) ||
        (v->description[0] != '\0' && !attr(sv, "description", v->description))) {
        return 0;
    }
    const char *causality = v->causality == FMI_PARAMETER ? "parameter"
                            : v->causality == FMI_INPUT   ? "input"
                                                          : "output";
    const char *variability = v->causality == FMI_PARAMETER ? "fixed"
                              : v->type == FMI_REAL         ? "continuous"
                                                            : "discrete";
    if (!attr(sv, "causality", causality) || !attr(sv, "variability", variability)) {
        return 0;
    }
    if ((v->causality == FMI_PARAMETER && !attr(sv, "initial", "exact")) ||
        (v->causality == FMI_OUTPUT && !attr(sv, "initial", "calculated"))) {
        return 0;
    }
    xmlNodePtr t = child(sv, v->type == FMI_REAL      ? "Real"
                             : v->type == FMI_INTEGER ? "Integer"
                             : v->type == FMI_BOOLEAN ? "Boolean"
                                                      : "String");
    if (t == NULL) {
        return 0;
    }
    if (v->causality != FMI_OUTPUT) {
        if (v->type == FMI_STRING    ? !attr(t, "start", "")
            : v->type == FMI_BOOLEAN ? !attr(t, "start", v->start != 0.0 ? "true" : "false")
                                     : !attr_num(t, "start", v->start)) {
            return 0;
        }
    }
    if (v->type == FMI_REAL && v->unit != NULL && !attr(t, "unit", v->unit)) {
        return 0;
    }
    /* parameters, and the inputs with a range (the drag coefficients: min 0) */
    if (v->causality != FMI_OUTPUT && v->type != FMI_BOOLEAN && v->type != FMI_STRING) {
        if ((isfinite(v->min) && !attr_num(t, "min", v->min)) || (isfinite(v->max) && !attr_num(t, "max", v->max))) {
            return 0;
        }
    }
    return 1;
}

/* "i j k": the 1-based indices of the parameters that override scene keys
 * (String parameters such as output.fields only name files); NULL when
 * memory runs out. The caller frees it. */
static char *initial_dependencies(const fmi_vars_t *vs)
{
    size_t cap = (size_t)vs->n * 12 + 1, len = 0;
    char *deps = malloc(cap);
    if (deps == NULL) {
        return NULL;
    }
    deps[0] = '\0';
    for (int j = 0; j < vs->n; j++) {
        if (vs->v[j].causality == FMI_PARAMETER && vs->v[j].key[0] != '\0') {
            len += (size_t)snprintf(deps + len, cap - len, "%s%d", len > 0 ? " " : "", j + 1);
        }
    }
    return deps;
}

/* modelDescription.xml for one model; 0 when libxml2 runs out of memory. */
static int build_description(const scene_t *s, fmu_job_t *job)
{
    const fmi_model_t *m = job->model;
    const fmi_vars_t *vs = &job->vars;
    char guid[39], name[300], buf[600];
    fmi_guid(m->identifier, s->text, strlen(s->text), guid);
    scene_name(s, name, sizeof name);
    int ok = 0;
    xmlDocPtr doc = xmlNewDoc(BAD_CAST "1.0");
    xmlNodePtr root = doc != NULL ? xmlNewNode(NULL, BAD_CAST "fmiModelDescription") : NULL;
    if (root == NULL) {
        goto done;
    }
    xmlDocSetRootElement(doc, root);
    snprintf(buf, sizeof buf, "%s_%s", name, m->identifier);
    if (!attr(root, "fmiVersion", "2.0") || !attr(root, "modelName", buf) || !attr(root, "guid", guid) ||
        !attr(root, "description", m->description) || !attr(root, "version", AGGLO_VERSION) ||
        !attr(root, "generationTool", "agglo coupler export " AGGLO_VERSION) ||
        !attr(root, "variableNamingConvention", "structured") || !attr(root, "numberOfEventIndicators", "0")) {
        goto done;
    }
    xmlNodePtr cs = child(root, "CoSimulation");
    if (cs == NULL || !attr(cs, "modelIdentifier", m->identifier) ||
        !attr(cs, "canHandleVariableCommunicationStepSize", m->can_variable_step ? "true" : "false") ||
        !attr(cs, "canInterpolateInputs", "false") || !attr(cs, "maxOutputDerivativeOrder", "0") ||
        !attr(cs, "canRunAsynchronuously", "false") || !attr(cs, "canBeInstantiatedOnlyOncePerProcess", "false") ||
        !attr(cs, "canNotUseMemoryManagementFunctions", "true") || !attr(cs, "canGetAndSetFMUstate", "true") ||
        !attr(cs, "canSerializeFMUstate", "true") || !attr(cs, "providesDirectionalDerivative", "false")) {
        goto done;
    }
    if (!add_units(root, vs)) {
        goto done;
    }
    xmlNodePtr cats = child(root, "LogCategories");
    if (cats == NULL) {
        goto done;
    }
    for (int k = 0; k < FMI_NCATS; k++) {
        xmlNodePtr c = child(cats, "Category");
        if (c == NULL || !attr(c, "name", fmi_log_categories[k][0]) ||
            !attr(c, "description", fmi_log_categories[k][1])) {
            goto done;
        }
    }
    /* one LBM time step is the natural communication step of both FMUs; a
     * whole number of ns for every scene that gives tau (common/scene.h). The
     * stop is run.end_time rounded up to whole steps, as `coupler run` runs
     * it: a master that steps from start to stop by the step size (fmpy's
     * simulate_fmu) then never asks the fluid for a fraction of an LBM step */
    xmlNodePtr ex = child(root, "DefaultExperiment");
    if (ex == NULL || !attr(ex, "startTime", "0") || !attr_num(ex, "stopTime", default_stop(s)) ||
        !attr_num(ex, "stepSize", s->fluid.dt)) {
        goto done;
    }
    xmlNodePtr list = child(root, "ModelVariables");
    if (list == NULL) {
        goto done;
    }
    for (int j = 0; j < vs->n; j++) {
        if (!add_variable(list, &vs->v[j], j)) {
            goto done;
        }
    }
    xmlNodePtr ms = child(root, "ModelStructure");
    xmlNodePtr outs = ms != NULL ? child(ms, "Outputs") : NULL;
    xmlNodePtr init = ms != NULL ? child(ms, "InitialUnknowns") : NULL;
    if (outs == NULL || init == NULL) {
        goto done;
    }
    /* the knowns the initial outputs depend on: the parameters that override
     * scene keys (ScalarVariable indices, ascending); never an input */
    char *init_deps = initial_dependencies(vs);
    if (init_deps == NULL) {
        goto done;
    }
    int nout = 0;
    for (int j = 0; j < vs->n; j++) {
        if (vs->v[j].causality != FMI_OUTPUT) {
            continue;
        }
        nout++;
        xmlNodePtr u = child(outs, "Unknown"), w = child(init, "Unknown");
        if (u == NULL || w == NULL || !attr_num(u, "index", j + 1) || !attr(u, "dependencies", "") ||
            !attr_num(w, "index", j + 1) || !attr(w, "dependencies", init_deps)) {
            free(init_deps);
            goto done;
        }
    }
    free(init_deps);
    if (nout == 0) {
        /* the schema wants at least one Unknown in a present element */
        xmlUnlinkNode(outs);
        xmlFreeNode(outs);
        xmlUnlinkNode(init);
        xmlFreeNode(init);
    }
    xmlDocDumpFormatMemoryEnc(doc, &job->xml, &job->xml_len, "UTF-8", 1);
    ok = job->xml != NULL && job->xml_len > 0;
done:
    xmlFreeDoc(doc);
    return ok;
}

static void html_text(FILE *f, const char *text)
{
    for (const char *c = text; *c != '\0'; c++) {
        switch (*c) {
        case '<': fputs("&lt;", f); break;
        case '>': fputs("&gt;", f); break;
        case '&': fputs("&amp;", f); break;
        case '"': fputs("&quot;", f); break;
        default: fputc(*c, f);
        }
    }
}

/* documentation/index.html (FMI 2.0 section 2.3, the FMU's documentation):
 * what the FMU is and for which scene, the step and how to use it, the
 * dependencies, every variable, the scene it carries. Deterministic (no
 * date), like the rest of the FMU. 0 when memory runs out. */
static int build_documentation(const scene_t *s, fmu_job_t *job)
{
    const fmi_model_t *m = job->model;
    const fmi_vars_t *vs = &job->vars;
    char name[300], num[40], num2[40];
    scene_name(s, name, sizeof name);
    FILE *f = open_memstream(&job->doc, &job->doc_len);
    if (f == NULL) {
        return 0;
    }
    fprintf(f, "<!DOCTYPE html>\n<html lang=\"en\">\n<head><meta charset=\"utf-8\"><title>");
    html_text(f, name);
    fprintf(f, "_%s</title></head>\n<body>\n<h1>", m->identifier);
    html_text(f, name);
    fprintf(f, "_%s</h1>\n<p>", m->identifier);
    html_text(f, m->description);
    fprintf(f, ".</p>\n<p>An FMI 2.0 Co-Simulation FMU for linux64, generated by agglo coupler export %s from "
               "the scene <code>", AGGLO_VERSION);
    html_text(f, s->path);
    fprintf(f, "</code> (carried as <code>resources/scene.yaml</code>, below; the GUID is a hash of it). The "
               "fluid and the rigid FMU of one scene are coupled by connecting every input to the output of "
               "the other FMU with the same name; all values are SI.</p>\n<h2>Step</h2>\n<p>DefaultExperiment: "
               "start 0, stop %s s, step size %s s",
            fmt_num(default_stop(s), num, sizeof num), fmt_num(s->fluid.dt, num2, sizeof num2));
    long long ns;
    if (scene_whole_ns(s->fluid.dt, &ns)) {
        fprintf(f, " = %lld ns, one LBM time step: a whole number of nanoseconds, so masters that count time "
                   "in integer ns (libcosim/OSP) can use it.",
                ns);
    } else {
        fprintf(f, ", one LBM time step; not a whole number of nanoseconds: masters that count time in integer "
                   "ns (libcosim/OSP) cannot step this FMU.");
    }
    fprintf(f, " %s</p>\n", m->check_step != NULL
                                ? "A communication step must be a whole number of LBM steps; the inputs are held "
                                  "over it."
                                : "Any communication step h &gt; 0 is accepted.");
    fprintf(f, "<h2>Dependencies</h2>\n<p>No output depends directly on an input: inputs act only through "
               "fmi2DoStep, outputs are those of the last communication point (ModelStructure Outputs: "
               "dependencies=\"\"). The initial outputs depend on the parameters only.</p>\n");
    fprintf(f, "<h2>Variables</h2>\n<table border=\"1\">\n<tr><th>name</th><th>causality</th><th>type</th>"
               "<th>unit</th><th>start</th><th>description</th></tr>\n");
    static const char *const causality[] = {"parameter", "input", "output"};
    static const char *const type[] = {"Real", "Integer", "Boolean", "String"};
    for (int j = 0; j < vs->n; j++) {
        const fmi_var_t *v = &vs->v[j];
        fprintf(f, "<tr><td><code>");
        html_text(f, v->name);
        fprintf(f, "</code></td><td>%s</td><td>%s</td><td>%s</td><td>", causality[v->causality], type[v->type],
                v->unit != NULL ? v->unit : "");
        if (v->causality != FMI_OUTPUT) {
            fputs(v->type == FMI_STRING ? "\"\"" : fmt_num(v->start, num, sizeof num), f);
        }
        fprintf(f, "</td><td>");
        html_text(f, v->description);
        fprintf(f, "</td></tr>\n");
    }
    fprintf(f, "</table>\n<h2>Scene (resources/scene.yaml)</h2>\n<pre>");
    html_text(f, s->text);
    fprintf(f, "</pre>\n<p>More: the FMUs section of the agglo README and models/README.md (the scene keys).</p>\n"
               "</body>\n</html>\n");
    int ok = !ferror(f);
    if (fclose(f) != 0) {
        ok = 0;
    }
    return ok && job->doc != NULL;
}

static int readable_file(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        return 0;
    }
    fclose(f);
    return 1;
}

/* Adds one file to the archive from memory (copied by libzip on close). */
static int zip_add_buffer(zip_t *z, const char *name, const void *data, size_t len)
{
    zip_source_t *src = zip_source_buffer(z, data, len, 0);
    if (src == NULL) {
        return 0;
    }
    if (zip_file_add(z, name, src, ZIP_FL_OVERWRITE | ZIP_FL_ENC_UTF_8) < 0) {
        zip_source_free(src);
        return 0;
    }
    return 1;
}

static int write_fmu(const scene_t *s, const fmu_job_t *job, const log_t *log)
{
    int err = 0;
    zip_t *z = zip_open(job->out, ZIP_CREATE | ZIP_TRUNCATE, &err);
    if (z == NULL) {
        zip_error_t ze;
        zip_error_init_with_code(&ze, err);
        log_msg(log, STATUS_ERROR, CAT, "cannot create %s: %s", job->out, zip_error_strerror(&ze));
        zip_error_fini(&ze);
        return 0;
    }
    char lib_name[64];
    snprintf(lib_name, sizeof lib_name, "binaries/linux64/%s.so", job->model->identifier);
    zip_source_t *lib = NULL;
    int ok = zip_dir_add(z, "binaries/", ZIP_FL_ENC_UTF_8) >= 0 &&
             zip_dir_add(z, "binaries/linux64/", ZIP_FL_ENC_UTF_8) >= 0 &&
             zip_dir_add(z, "resources/", ZIP_FL_ENC_UTF_8) >= 0 &&
             zip_dir_add(z, "documentation/", ZIP_FL_ENC_UTF_8) >= 0 &&
             zip_add_buffer(z, "documentation/index.html", job->doc, job->doc_len) &&
             zip_add_buffer(z, "modelDescription.xml", job->xml, (size_t)job->xml_len) &&
             zip_add_buffer(z, "resources/scene.yaml", s->text, strlen(s->text)) &&
             (lib = zip_source_file(z, job->lib, 0, -1)) != NULL;
    zip_int64_t lib_index = ok ? zip_file_add(z, lib_name, lib, ZIP_FL_OVERWRITE | ZIP_FL_ENC_UTF_8) : -1;
    if (ok && lib_index < 0) {
        zip_source_free(lib);
        ok = 0;
    }
    if (ok && job->store && zip_set_file_compression(z, (zip_uint64_t)lib_index, ZIP_CM_STORE, 0) != 0) {
        ok = 0;
    }
    if (!ok) {
        log_msg(log, STATUS_ERROR, CAT, "cannot assemble %s: %s", job->out, zip_strerror(z));
        zip_discard(z);
        return 0;
    }
    if (zip_close(z) != 0) {
        log_msg(log, STATUS_ERROR, CAT, "cannot write %s: %s", job->out, zip_strerror(z));
        zip_discard(z);
        return 0;
    }
    return 1;
}

int export_fmus(const scene_t *scene, const char *dir, const char *lib_dir, int verbose, const log_t *log)
{
    fmu_job_t jobs[2];
    const fmi_model_t *models[2] = {&fluid_fmi_model, &rigid_fmi_model};
    int njobs = 0, rc = 1;
    memset(jobs, 0, sizeof jobs);
    for (int k = 0; k < 2; k++) {
        fmu_job_t *job = &jobs[njobs];
        job->model = models[k];
        job->store = !verbose; /* `coupler run` unpacks it at once; `coupler export` makes it small */
        status_t st = models[k]->variables(scene, log, &job->vars);
        if (st == STATUS_DISCARD) {
            continue; /* no free bodies: no rigid.fmu (said below) */
        }
        njobs++;
        if (st != STATUS_OK) {
            goto done;
        }
        if (snprintf(job->lib, sizeof job->lib, "%s/%s.so", lib_dir, models[k]->identifier) >= (int)sizeof job->lib ||
            snprintf(job->out, sizeof job->out, "%s/%s.fmu", dir, models[k]->identifier) >= (int)sizeof job->out) {
            log_msg(log, STATUS_ERROR, CAT, "path too long: %s", dir);
            goto done;
        }
        if (!readable_file(job->lib)) {
            log_msg(log, STATUS_ERROR, CAT, "cannot read the FMU library %s: %s (build it with `make fmus`)", job->lib,
                    strerror(errno));
            goto done;
        }
        if (!build_description(scene, job) || !build_documentation(scene, job)) {
            log_msg(log, STATUS_ERROR, CAT, "out of memory building modelDescription.xml or documentation of %s",
                    models[k]->identifier);
            goto done;
        }
    }
    struct stat sb;
    if (stat(dir, &sb) != 0) {
        if (errno != ENOENT || mkdir(dir, 0777) != 0) {
            log_msg(log, STATUS_ERROR, CAT, "cannot create the output folder %s: %s", dir, strerror(errno));
            goto done;
        }
    } else if (!S_ISDIR(sb.st_mode)) {
        log_msg(log, STATUS_ERROR, CAT, "%s exists and is not a folder; allowed: a writable folder for the FMUs", dir);
        goto done;
    } else if (access(dir, W_OK | X_OK) != 0) {
        log_msg(log, STATUS_ERROR, CAT, "cannot write to the folder %s: %s", dir, strerror(errno));
        goto done;
    }
    for (int k = 0; k < njobs; k++) {
        if (!write_fmu(scene, &jobs[k], log)) {
            for (int j = 0; j < k; j++) {
                remove(jobs[j].out); /* all or nothing */
            }
            goto done;
        }
        if (!verbose) {
            continue;
        }
        int nin = 0, nout = 0, npar = 0;
        for (int j = 0; j < jobs[k].vars.n; j++) {
            nin += jobs[k].vars.v[j].causality == FMI_INPUT;
            nout += jobs[k].vars.v[j].causality == FMI_OUTPUT;
            npar += jobs[k].vars.v[j].causality == FMI_PARAMETER;
        }
        printf("%s: %d parameters, %d inputs, %d outputs\n", jobs[k].out, npar, nin, nout);
    }
    if (njobs == 1) {
        /* a rigid.fmu left by an earlier export of another scene would pair
         * with this fluid.fmu in any master that takes the folder's FMUs */
        char stale[sizeof jobs[0].out];
        struct stat rs;
        const int n = snprintf(stale, sizeof stale, "%s/%s.fmu", dir, rigid_fmi_model.identifier);
        if (n > 0 && n < (int)sizeof stale && lstat(stale, &rs) == 0 && S_ISREG(rs.st_mode)) {
            if (remove(stale) != 0) {
                log_msg(log, STATUS_ERROR, CAT,
                        "cannot remove %s, left by an earlier export (this scene has no free bodies, so it does not "
                        "belong with the new fluid.fmu): %s",
                        stale, strerror(errno));
                goto done;
            }
            if (verbose) {
                printf("removed %s of an earlier export: it does not belong with this scene\n", stale);
            }
        }
        if (verbose) {
            printf("no rigid.fmu: the scene has no free bodies, so the fluid runs alone\n");
        }
    }
    rc = 0;
done:
    for (int k = 0; k < 2; k++) {
        fmi_vars_free(&jobs[k].vars);
        xmlFree(jobs[k].xml);
        free(jobs[k].doc);
    }
    return rc;
}
