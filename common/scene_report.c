/* scene_report.c — where a problem of a scene is, and how it is said.
 *
 * Every message leaves through the caller's log_t as
 * "FILE[:LINE]: KEY = VALUE: problem; allowed: RANGE"; a key set by an
 * override is located as "FILE (--set KEY=VALUE)". Lines come from a table
 * of dotted key -> line taken from the file's node tree before any override
 * changes it (scene_report_where_walk). YAML syntax errors keep libyaml's line
 * and column; libcyaml's messages come in through its log callback and leave
 * as one message naming the dotted key, with the allowed keys, values or
 * type taken from the schema. Errors are counted in the load context (ctx_t,
 * on the stack of scene_load); nothing is printed, nothing else is kept. */
#include "scene_internal.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* snprintf that appends at *pos and never overruns; truncates silently. */
void scene_report_addf(char *buf, size_t size, size_t *pos, const char *fmt, ...)
{
    if (*pos >= size) {
        return;
    }
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(buf + *pos, size - *pos, fmt, ap);
    va_end(ap);
    if (n > 0) {
        *pos += (size_t)n;
        if (*pos >= size) {
            *pos = size - 1;
        }
    }
}

/* Does dotted key `key` lie at or below dotted key `prefix`? */
static bool key_under(const char *key, const char *prefix, size_t plen)
{
    return strncmp(key, prefix, plen) == 0 && (key[plen] == '\0' || key[plen] == '.');
}

/* "FILE:LINE", "FILE (--set K=V)" or "FILE": where the user can find `key`.
 * An override of a part of the key's value (--set bodies.0.spheres.0.center.1=...
 * for bodies.0.spheres.0.center) is named too: the file's line does not
 * show the value that is wrong. */
static void ctx_locate(const ctx_t *c, const char *key, char *buf, size_t size)
{
    for (int i = c->noverrides - 1; i >= 0 && key[0] != '\0'; i--) {
        const char *ov = c->overrides[i];
        const char *eq = strchr(ov, '=');
        if (eq != NULL && eq > ov &&
            (key_under(key, ov, (size_t)(eq - ov)) ||
             ((size_t)(eq - ov) > strlen(key) && key_under(ov, key, strlen(key))))) {
            snprintf(buf, size, "%s (--set %s)", c->file, ov);
            return;
        }
    }
    char k[SCENE_KEY_MAX];
    snprintf(k, sizeof k, "%s", key);
    for (;;) {
        /* the last match: for a key given twice, that is the one at fault */
        for (size_t i = c->nwhere; i-- > 0;) {
            if (strcmp(c->where[i].key, k) == 0) {
                snprintf(buf, size, "%s:%d", c->file, c->where[i].line);
                return;
            }
        }
        char *dot = strrchr(k, '.');
        if (dot == NULL) {
            break;
        }
        *dot = '\0';
    }
    snprintf(buf, size, "%s", c->file);
}

bool scene_report_shown(const ctx_t *c)
{
    return c->nlogged < SCENE_MESSAGES_MAX;
}

void scene_report_count(ctx_t *c, status_t level)
{
    if (level >= STATUS_ERROR) {
        c->nerrors++;
    }
    c->nhidden++;
    c->nhidden_errors += level >= STATUS_ERROR;
}

static void ctx_vreport(ctx_t *c, status_t level, const char *key, const char *fmt, va_list ap)
{
    /* A scene with thousands of spheres can break a check thousands of times
     * (or, for overlaps, n^2 times): the first messages say what is wrong,
     * the rest are only counted (scene_report_hidden). */
    if (!scene_report_shown(c)) {
        scene_report_count(c, level);
        return;
    }
    if (level >= STATUS_ERROR) {
        c->nerrors++;
    }
    c->nlogged++;
    char body[SCENE_MSG_MAX];
    vsnprintf(body, sizeof body, fmt, ap);
    char loc[SCENE_KEY_MAX + 64];
    ctx_locate(c, key, loc, sizeof loc);
    if (key[0] != '\0') {
        /* "KEY = VALUE: ..." when the body starts with the value, else "KEY: ..." */
        log_msg(c->log, level, "scene", "%s: %s%s%s", loc, key, body[0] == '=' ? " " : ": ", body);
    } else {
        log_msg(c->log, level, "scene", "%s: %s", loc, body);
    }
}

void scene_report_hidden(ctx_t *c)
{
    if (c->nhidden > 0) {
        log_msg(c->log, c->nhidden_errors > 0 ? STATUS_ERROR : STATUS_WARNING, "scene",
                "%s: %ld more messages not shown (%ld errors, %ld warnings); only the first %d are", c->file,
                c->nhidden, c->nhidden_errors, c->nhidden - c->nhidden_errors, SCENE_MESSAGES_MAX);
    }
}

void scene_report(ctx_t *c, status_t level, const char *key, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    ctx_vreport(c, level, key, fmt, ap);
    va_end(ap);
}

/* An error about `key`; the message should name the value and the allowed range. */
void scene_report_bad(ctx_t *c, const char *key, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    ctx_vreport(c, STATUS_ERROR, key, fmt, ap);
    va_end(ap);
}

void scene_report_warn(ctx_t *c, const char *key, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    ctx_vreport(c, STATUS_WARNING, key, fmt, ap);
    va_end(ap);
}

void scene_report_oom(ctx_t *c)
{
    if (!c->oom) {
        log_msg(c->log, STATUS_FATAL, "scene", "%s: out of memory while reading the scene", c->file);
        c->nerrors++;
        c->oom = true;
    }
}

/* ------------------------------------------------------------------------ */
/* Step 1: key -> line table from the file's node tree.                     */

static void where_add(ctx_t *c, const char *key, int line)
{
    if (c->nwhere == c->capwhere) {
        size_t cap = c->capwhere ? 2 * c->capwhere : 64;
        where_t *w = realloc(c->where, cap * sizeof *w);
        if (w == NULL) {
            scene_report_oom(c);
            return;
        }
        c->where = w;
        c->capwhere = cap;
    }
    char *k = strdup(key);
    if (k == NULL) {
        scene_report_oom(c);
        return;
    }
    c->where[c->nwhere].key = k;
    c->where[c->nwhere].line = line;
    c->nwhere++;
}

void scene_report_where_walk(ctx_t *c, yaml_document_t *doc, int id, const char *prefix, int depth)
{
    yaml_node_t *n = yaml_document_get_node(doc, id);
    if (n == NULL || depth > 16 || c->oom) {
        return;
    }
    char key[SCENE_KEY_MAX];
    if (n->type == YAML_MAPPING_NODE) {
        for (yaml_node_pair_t *p = n->data.mapping.pairs.start; p < n->data.mapping.pairs.top; p++) {
            yaml_node_t *k = yaml_document_get_node(doc, p->key);
            if (k == NULL || k->type != YAML_SCALAR_NODE) {
                continue;
            }
            int len = snprintf(key, sizeof key, "%s%s%s", prefix, prefix[0] ? "." : "",
                               (const char *)k->data.scalar.value);
            if (len < 0 || (size_t)len >= sizeof key) {
                continue;
            }
            where_add(c, key, (int)k->start_mark.line + 1);
            scene_report_where_walk(c, doc, p->value, key, depth + 1);
        }
    } else if (n->type == YAML_SEQUENCE_NODE) {
        long i = 0;
        for (yaml_node_item_t *it = n->data.sequence.items.start; it < n->data.sequence.items.top; it++, i++) {
            yaml_node_t *item = yaml_document_get_node(doc, *it);
            int len = snprintf(key, sizeof key, "%s%s%ld", prefix, prefix[0] ? "." : "", i);
            if (item == NULL || len < 0 || (size_t)len >= sizeof key) {
                continue;
            }
            where_add(c, key, (int)item->start_mark.line + 1);
            scene_report_where_walk(c, doc, *it, key, depth + 1);
        }
    }
}

void scene_report_where_free(ctx_t *c)
{
    for (size_t i = 0; i < c->nwhere; i++) {
        free(c->where[i].key);
    }
    free(c->where);
    c->where = NULL;
    c->nwhere = c->capwhere = 0;
}

/* `what` is NULL for the scene file itself ("FILE:LINE:COLUMN: ..."), else
 * names the override whose value failed to parse. */
void scene_report_yaml_error(ctx_t *c, const yaml_parser_t *p, const char *what)
{
    if (p->error == YAML_MEMORY_ERROR) {
        scene_report_oom(c);
        return;
    }
    const char *problem = p->problem ? p->problem : "unknown problem";
    char loc[SCENE_KEY_MAX + 64];
    if (what == NULL) {
        snprintf(loc, sizeof loc, "%s", c->file);
    } else {
        snprintf(loc, sizeof loc, "%s: %s", c->file, what);
    }
    if (p->error == YAML_READER_ERROR) {
        log_msg(c->log, STATUS_ERROR, "scene", "%s: cannot read at byte %zu: %s", loc, p->problem_offset, problem);
    } else {
        char context[128] = "";
        if (p->context != NULL) {
            snprintf(context, sizeof context, " (%s at line %zu, column %zu)", p->context, p->context_mark.line + 1,
                     p->context_mark.column + 1);
        }
        log_msg(c->log, STATUS_ERROR, "scene", "%s%s%zu:%zu: YAML syntax error: %s%s", loc,
                what == NULL ? ":" : " at ", p->problem_mark.line + 1, p->problem_mark.column + 1, problem, context);
    }
    c->nerrors++;
}

void scene_report_too_deep(ctx_t *c, yaml_mark_t where, int max, const char *what)
{
    log_msg(c->log, STATUS_ERROR, "scene",
            "%s%s%s%zu:%zu: YAML nested too deep: this list or mapping lies inside %d others; allowed: at most %d "
            "levels (a scene needs 6: bodies.0.spheres.0.center)",
            c->file, what == NULL ? "" : ": ", what == NULL ? ":" : what, where.line + 1, where.column + 1, max, max);
    c->nerrors++;
}

void scene_report_alias(ctx_t *c, const yaml_node_t *n, const char *what)
{
    const char *kind = n->type == YAML_MAPPING_NODE ? "mapping" : "list";
    log_msg(c->log, STATUS_ERROR, "scene",
            "%s%s%s%zu:%zu: YAML alias of a %s: the %s anchored here is used again through an alias (or inside "
            "itself); allowed: aliases of single values only (write the %s out)",
            c->file, what == NULL ? "" : ": ", what == NULL ? ":" : what, n->start_mark.line + 1,
            n->start_mark.column + 1, kind, kind, kind);
    c->nerrors++;
}

/* ------------------------------------------------------------------------ */
/* Step 4: libcyaml messages -> one message naming the key.                 */

void scene_report_cyaml_log(cyaml_log_t level, void *vctx, const char *fmt, va_list ap)
{
    ctx_t *c = vctx;
    char line[SCENE_MSG_MAX / 2];
    vsnprintf(line, sizeof line, fmt, ap);
    line[strcspn(line, "\n")] = '\0';
    if (level < CYAML_LOG_ERROR) {
        scene_report_warn(c, "", "libcyaml: %s", line);
        return;
    }
    if (strncmp(line, "  in ", 5) == 0) {
        if (c->cy_nframes >= SCENE_FRAMES_MAX) {
            return;
        }
        cy_frame_t *f = &c->cy_frames[c->cy_nframes++];
        f->child[0] = '\0';
        const char *q = strchr(line, '\'');
        const char *q2 = q ? strchr(q + 1, '\'') : NULL;
        if (q2 == NULL) {
            return;
        }
        if (strncmp(line, "  in sequence entry", 19) == 0) {
            /* libcyaml numbers the entry being read from 1 */
            long n = strtol(q + 1, NULL, 10);
            snprintf(f->child, sizeof f->child, "%ld", n > 0 ? n - 1 : 0);
        } else {
            snprintf(f->child, sizeof f->child, "%.*s", (int)(q2 - q - 1), q + 1);
        }
        return;
    }
    if (strncmp(line, "Load: Backtrace", 15) == 0 || c->cy_msg[0] != '\0') {
        return;
    }
    const char *msg = strncmp(line, "Load: ", 6) == 0 ? line + 6 : line;
    snprintf(c->cy_msg, sizeof c->cy_msg, "%s", msg);
}

void scene_report_cyaml_error(ctx_t *c, cyaml_err_t err)
{
    if (err == CYAML_ERR_OOM) {
        scene_report_oom(c);
        return;
    }
    const char *msg = c->cy_msg[0] ? c->cy_msg : cyaml_strerror(err);
    /* The innermost frame is the container being read. For errors about the
     * container itself (a missing key, a wrong entry count) its "current
     * child" is stale, so it is left out of the key. */
    bool about_container = strncmp(msg, "Missing required mapping field", 30) == 0 ||
                           strncmp(msg, "Insufficient entries", 20) == 0 ||
                           strncmp(msg, "Excessive entries", 17) == 0;
    const char *extra = NULL;
    if (strncmp(msg, "Missing required mapping field: ", 32) == 0) {
        extra = msg + 32;
    } else if (strncmp(msg, "Unexpected key: ", 16) == 0) {
        extra = msg + 16;
    }
    char key[SCENE_KEY_MAX] = "";
    size_t pos = 0;
    for (int i = c->cy_nframes - 1; i >= 0; i--) {
        if ((i == 0 && about_container) || c->cy_frames[i].child[0] == '\0') {
            continue;
        }
        scene_report_addf(key, sizeof key, &pos, "%s%s", pos ? "." : "", c->cy_frames[i].child);
    }
    char parent[SCENE_KEY_MAX];
    snprintf(parent, sizeof parent, "%s", key);
    if (extra != NULL) {
        scene_report_addf(key, sizeof key, &pos, "%s%s", pos ? "." : "", extra);
    }

    char desc[SCENE_MSG_MAX / 2] = "";
    const cyaml_schema_value_t *sv = extra != NULL ? scene_schema_at(parent) : scene_schema_at(key);
    if (sv != NULL) {
        scene_schema_describe(sv, desc, sizeof desc);
    }
    if (strncmp(msg, "Missing required", 16) == 0) {
        scene_report_bad(c, key, "required key is missing (libcyaml: %s); allowed in %s: %s", msg,
                         parent[0] ? parent : "the top level", desc);
    } else if (strncmp(msg, "Unexpected key", 14) == 0) {
        scene_report_bad(c, key, "unknown key (libcyaml: %s); allowed in %s: %s", msg,
                         parent[0] ? parent : "the top level", desc);
    } else if (strncmp(msg, "Mapping field already seen", 26) == 0) {
        scene_report_bad(c, key, "key given twice (libcyaml: %s); allowed: each key once", msg);
    } else {
        scene_report_bad(c, key, "wrong type or value (libcyaml: %s); allowed: %s", msg,
                         desc[0] ? desc : "see models/README.md");
    }
}
