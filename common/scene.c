/* scene.c — reads a scene file into a scene_t (DESIGN section 4): the verbs
 * of scene.h.
 *
 * Pipeline, one pass each:
 *   1. libyaml parses the file into a node tree; a syntax error is reported
 *      with line and column. A table of dotted key -> line is taken from the
 *      tree before anything changes it, so later messages can cite lines of
 *      the file the user wrote (scene_report.c).
 *   2. Each "dotted.key=value" override is checked against the libcyaml
 *      schema (an unknown key is an error naming the override), its value is
 *      parsed as YAML and grafted into the tree, creating missing mappings
 *      (scene_override.c). Every scalar that the schema reads as a number
 *      must then be one as a whole: libcyaml would read "1,000" as 1
 *      (scene_check_numbers).
 *   3. The tree is emitted to text (kept as scene->text, the scene as run).
 *   4. libcyaml loads that text against the schema (scene_schema.c) into raw_*
 *      structs (optional keys are pointers, NULL when absent). Its messages
 *      come in through the log callback and leave as one message naming the
 *      dotted key, with the allowed keys / values / type taken from the schema.
 *   5. raw -> scene_t: defaults filled in, derived values (dx from
 *      cells_per_radius, tau <-> dt) computed (scene_build.c), ranges and
 *      consistency checked (scene_check.c). Every violation is reported (not
 *      only the first) before failing.
 *
 * Invariants: no state outside the call (the context lives on the stack);
 * nothing is printed, every message goes through the caller's log_t as
 * "FILE[:LINE]: KEY = VALUE: problem; allowed: RANGE", and a key set by an
 * override is located as "FILE (--set KEY=VALUE)". scene_load returns
 * STATUS_OK with *out set (warnings, if any, are only logged), STATUS_ERROR for
 * bad input or STATUS_FATAL when memory runs out; on failure *out is NULL and
 * everything allocated is freed on the single cleanup path. */
#include "scene_internal.h"

#include <assert.h>
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

const char *face_type_name(face_type_t t)
{
    for (size_t i = 0; i < CYAML_ARRAY_LEN(SCENE_FACE_TYPE_NAMES); i++) {
        if (SCENE_FACE_TYPE_NAMES[i].val == (int64_t)t) {
            return SCENE_FACE_TYPE_NAMES[i].str;
        }
    }
    return "unknown";
}

void scene_body_pivot(const scene_body_t *b, double c[3])
{
    double vol = 0.0;
    c[0] = c[1] = c[2] = 0.0;
    for (int i = 0; i < b->nspheres; i++) {
        const double r3 = pow(b->spheres[i].radius, 3.0);
        for (int a = 0; a < 3; a++) {
            c[a] += r3 * b->spheres[i].center[a];
        }
        vol += r3;
    }
    for (int a = 0; a < 3; a++) {
        c[a] /= vol;
    }
}

int scene_whole_ns(double t, long long *ns)
{
    const double n = nearbyint(t * 1e9);
    if (ns != NULL) {
        *ns = isfinite(n) && fabs(n) < 9e18 ? (long long)n : 0;
    }
    return isfinite(n) && n >= 1.0 && fabs(t * 1e9 - n) <= 1e-9 * n;
}

long scene_next_multiple(long k, double interval, double x)
{
    const double guess = floor(x / interval) + 1.0;
    if (!(guess < 0x1p62)) {
        return LONG_MAX;
    }
    long m = guess > (double)k ? (long)guess : k;
    /* the division may round either way: a step or two to the exact answer */
    while (m > k && (double)(m - 1) * interval > x) {
        m--;
    }
    while ((double)m * interval <= x) {
        m++;
    }
    return m;
}

int scene_total_spheres(const scene_t *s)
{
    int n = 0;
    for (int i = 0; i < s->nbodies; i++) {
        n += s->bodies[i].nspheres;
    }
    return n;
}

int scene_free_bodies(const scene_t *s)
{
    int n = 0;
    for (int b = 0; b < s->nbodies; b++) {
        n += s->bodies[b].motion == MOTION_FREE;
    }
    return n;
}

void scene_free(scene_t *s)
{
    if (s == NULL) {
        return;
    }
    for (int i = 0; s->bodies != NULL && i < s->nbodies; i++) {
        free(s->bodies[i].name);
        free(s->bodies[i].spheres);
    }
    free(s->bodies);
    free(s->connections);
    free(s->path);
    free(s->text);
    free(s);
}

status_t scene_load(const char *path, const char *const *overrides, int noverrides, const log_t *log,
                    scene_t **out)
{
    assert(path != NULL && out != NULL);
    assert(noverrides >= 0 && (noverrides == 0 || overrides != NULL));
    *out = NULL;

    ctx_t c = {.file = path, .log = log, .overrides = overrides, .noverrides = noverrides};
    const cyaml_config_t cfg = {
        .log_fn = scene_report_cyaml_log,
        .log_ctx = &c,
        .mem_fn = cyaml_mem,
        .log_level = CYAML_LOG_WARNING,
        .flags = CYAML_CFG_DEFAULT,
    };
    FILE *fp = NULL;
    yaml_parser_t parser;
    yaml_document_t doc;
    bool parser_ok = false, doc_ok = false;
    text_t text = {0};
    raw_scene_t *raw = NULL;
    scene_t *s = NULL;
    status_t st = STATUS_ERROR;

    fp = fopen(path, "rb");
    if (fp == NULL) {
        scene_report_bad(&c, "", "cannot open the scene file: %s", strerror(errno));
        goto done;
    }
    {
        struct stat sb;
        if (fstat(fileno(fp), &sb) == 0 && S_ISDIR(sb.st_mode)) {
            /* libyaml's read of it said "cannot read at byte 0: input error" */
            scene_report_bad(&c, "", "is a folder, not a scene file; allowed: a YAML scene file (models/README.md)");
            goto done;
        }
    }
    {
        /* the nesting first, from the events (scene_yaml_depth_within) */
        yaml_parser_t pre;
        if (!yaml_parser_initialize(&pre)) {
            scene_report_oom(&c);
            goto done;
        }
        yaml_parser_set_input_file(&pre, fp);
        yaml_mark_t deep;
        const int within = scene_yaml_depth_within(&pre, SCENE_DEPTH_MAX, &deep);
        if (within == -1 && pre.error == YAML_MEMORY_ERROR) {
            yaml_parser_delete(&pre);
            scene_report_oom(&c);
            goto done;
        }
        yaml_parser_delete(&pre);
        if (within == 0) {
            scene_report_too_deep(&c, deep, SCENE_DEPTH_MAX, NULL);
            goto done;
        }
        if (fseek(fp, 0, SEEK_SET) != 0) {
            scene_report_bad(&c, "", "cannot read the scene file again from its start: %s", strerror(errno));
            goto done;
        }
        clearerr(fp);
    }
    if (!yaml_parser_initialize(&parser)) {
        scene_report_oom(&c);
        goto done;
    }
    parser_ok = true;
    yaml_parser_set_input_file(&parser, fp);
    if (!yaml_parser_load(&parser, &doc)) {
        scene_report_yaml_error(&c, &parser, NULL);
        goto done;
    }
    doc_ok = true;
    if (yaml_document_get_root_node(&doc) == NULL) {
        scene_report_bad(&c, "",
                         "the scene is empty; allowed: a mapping with the keys domain, fluid, run (required) and "
                         "bodies, connections, contacts, rigid");
        goto done;
    }
    {
        yaml_document_t extra;
        if (!yaml_parser_load(&parser, &extra)) {
            scene_report_yaml_error(&c, &parser, NULL);
            goto done;
        }
        bool more = yaml_document_get_root_node(&extra) != NULL;
        yaml_document_delete(&extra);
        if (more) {
            scene_report_bad(&c, "", "more than one YAML document ('---'); allowed: exactly one");
            goto done;
        }
    }
    yaml_parser_delete(&parser);
    parser_ok = false;
    if (fclose(fp) != 0) {
        fp = NULL;
        scene_report_bad(&c, "", "cannot close the scene file: %s", strerror(errno));
        goto done;
    }
    fp = NULL;

    if (yaml_document_get_root_node(&doc)->type != YAML_MAPPING_NODE) {
        scene_report_bad(&c, "",
                         "the top level is %s; allowed: a mapping with the keys domain, fluid, run (required) and "
                         "bodies, connections, contacts, rigid",
                         scene_override_node_kind(yaml_document_get_root_node(&doc)));
        goto done;
    }
    {
        bool oom = false;
        const yaml_node_t *shared = scene_override_shared_collection(&doc, &oom);
        if (oom) {
            scene_report_oom(&c);
            goto done;
        }
        if (shared != NULL) {
            scene_report_alias(&c, shared, NULL);
            goto done;
        }
    }
    scene_report_where_walk(&c, &doc, 1, "", 0);
    if (c.oom) {
        goto done;
    }
    for (int i = 0; i < noverrides; i++) {
        assert(overrides[i] != NULL);
        if (!scene_override_apply(&c, &doc, overrides[i])) {
            goto done;
        }
    }
    scene_check_numbers(&c, &doc);
    if (c.nerrors > 0) {
        goto done;
    }
    doc_ok = false; /* emit_document consumes it */
    if (!scene_override_emit(&c, &doc, &text)) {
        goto done;
    }

    cyaml_err_t err = cyaml_load_data((const uint8_t *)text.data, text.len, &cfg, &SCENE_SCHEMA,
                                      (cyaml_data_t **)&raw, NULL);
    if (err != CYAML_OK) {
        raw = NULL;
        scene_report_cyaml_error(&c, err);
        goto done;
    }
    if (raw == NULL) {
        scene_report_bad(&c, "", "the scene is empty");
        goto done;
    }

    s = calloc(1, sizeof *s);
    if (s == NULL) {
        scene_report_oom(&c);
        goto done;
    }
    scene_build(&c, raw, s);
    if (c.nerrors > 0) {
        goto done;
    }
    s->path = strdup(path);
    if (s->path == NULL) {
        scene_report_oom(&c);
        goto done;
    }
    s->text = text.data;
    text.data = NULL;
    *out = s;
    s = NULL;
    /* Warnings have been logged; the scene is usable, so the result is ok
     * (callers test != STATUS_OK for failure). */
    st = STATUS_OK;

done:
    scene_report_hidden(&c);
    if (c.oom) {
        st = STATUS_FATAL;
    }
    scene_free(s);
    if (raw != NULL) {
        cyaml_free(&cfg, &SCENE_SCHEMA, raw, 0);
    }
    free(text.data);
    if (doc_ok) {
        yaml_document_delete(&doc);
    }
    if (parser_ok) {
        yaml_parser_delete(&parser);
    }
    if (fp != NULL) {
        fclose(fp); /* already failing; a close error adds nothing */
    }
    scene_report_where_free(&c);
    return st;
}
