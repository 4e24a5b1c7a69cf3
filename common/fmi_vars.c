/* fmi_vars.c — helpers shared by the FMI models, the generic FMI layer and the
 * exporter: the growable variable list, the unit table, the scene GUID and a
 * key probe on the scene text. No state outside the arguments. */
#include "fmi_adapter.h"

#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <yaml.h>

const fmi_unit_t fmi_units[] = {
    {"m", 0, 1, 0, 0},        {"m/s", 0, 1, -1, 0},    {"rad/s", 0, 0, -1, 1},   {"N", 1, 1, -2, 0},
    {"N.m", 1, 2, -2, 0},     {"kg/m3", 1, -3, 0, 0},  {"m2/s", 0, 2, -1, 0},    {"s", 0, 0, 1, 0},
    {"m/s2", 0, 1, -2, 0},    {"N/m3", 1, -2, -2, 0},  {"kg", 1, 0, 0, 0},      {"J", 1, 2, -2, 0},
    {"kg.m/s", 1, 1, -1, 0},  {"kg.m2/s", 1, 2, -1, 0},  {"kg/s", 1, 0, -1, 0},
};
const char *const fmi_log_categories[FMI_NCATS][2] = {
    {"logStatusWarning", "messages with status fmi2Warning"},
    {"logStatusDiscard", "messages with status fmi2Discard"},
    {"logStatusError", "messages with status fmi2Error (always sent)"},
    {"logStatusFatal", "messages with status fmi2Fatal (always sent)"},
    {"logInfo", "informational messages of the component (with debug logging on)"},
    {"logCalls", "one line per FMI function call with its arguments (with debug logging on)"},
};

const int fmi_nunits = (int)(sizeof fmi_units / sizeof fmi_units[0]);

fmi_var_t *fmi_vars_add(fmi_vars_t *vs, fmi_type_t type, fmi_causality_t causality, const char *unit,
                        const char *name_fmt, ...)
{
    if (vs->n == vs->cap) {
        int cap = vs->cap > 0 ? 2 * vs->cap : 64;
        fmi_var_t *v = realloc(vs->v, (size_t)cap * sizeof *v);
        if (v == NULL) {
            return NULL;
        }
        vs->v = v;
        vs->cap = cap;
    }
    fmi_var_t *v = &vs->v[vs->n++];
    memset(v, 0, sizeof *v);
    v->type = type;
    v->causality = causality;
    v->unit = unit;
    v->component = -1;
    v->min = -INFINITY;
    v->max = INFINITY;
    va_list ap;
    va_start(ap, name_fmt);
    vsnprintf(v->name, sizeof v->name, name_fmt, ap);
    va_end(ap);
    return v;
}

void fmi_vars_free(fmi_vars_t *vs)
{
    free(vs->v);
    vs->v = NULL;
    vs->n = vs->cap = 0;
}

fmi_var_t *fmi_vars_param(fmi_vars_t *vs, const char *name, const char *key, int component, const char *unit,
                          double start, double min, double max, int range_flags, const char *description)
{
    fmi_var_t *v = fmi_vars_add(vs, FMI_REAL, FMI_PARAMETER, unit, "%s", name);
    if (v == NULL) {
        return NULL;
    }
    snprintf(v->key, sizeof v->key, "%s", key);
    snprintf(v->description, sizeof v->description, "%s", description);
    v->component = component;
    v->start = start;
    v->min = min;
    v->max = max;
    v->range_flags = range_flags;
    return v;
}

/* Two independent 64-bit FNV-1a hashes (different offset bases) give the 128
 * bits of the GUID; the model name is hashed first so that fluid.fmu and
 * rigid.fmu of one scene differ. */
void fmi_guid(const char *model, const char *text, size_t len, char out[39])
{
    uint64_t h[2] = {0xcbf29ce484222325ULL, 0x84222325cbf29ce4ULL};
    const uint64_t prime = 0x100000001b3ULL;
    for (int k = 0; k < 2; k++) {
        for (const char *p = model; *p != '\0'; p++) {
            h[k] = (h[k] ^ (unsigned char)*p) * prime;
        }
        h[k] = (h[k] ^ 0xffu) * prime;
        for (size_t i = 0; i < len; i++) {
            h[k] = (h[k] ^ (unsigned char)text[i]) * prime;
            if (k == 1) {
                h[k] ^= h[k] >> 29;
            }
        }
    }
    snprintf(out, 39, "{%08x-%04x-%04x-%04x-%04x%08x}", (unsigned)(h[0] >> 32), (unsigned)(h[0] >> 16) & 0xffffu,
             (unsigned)h[0] & 0xffffu, (unsigned)(h[1] >> 48), (unsigned)(h[1] >> 32) & 0xffffu, (unsigned)h[1]);
}

static int scalar_is(const yaml_node_t *n, const char *s)
{
    return n != NULL && n->type == YAML_SCALAR_NODE && n->data.scalar.length == strlen(s) &&
           memcmp(n->data.scalar.value, s, n->data.scalar.length) == 0;
}

int fmi_scene_has_key(const char *text, const char *group, const char *key)
{
    yaml_parser_t parser;
    yaml_document_t doc;
    int found = -1;
    if (!yaml_parser_initialize(&parser)) {
        return -1;
    }
    yaml_parser_set_input_string(&parser, (const unsigned char *)text, strlen(text));
    if (!yaml_parser_load(&parser, &doc)) {
        yaml_parser_delete(&parser);
        return -1;
    }
    yaml_node_t *root = yaml_document_get_root_node(&doc);
    if (root != NULL && root->type == YAML_MAPPING_NODE) {
        found = 0;
        for (yaml_node_pair_t *p = root->data.mapping.pairs.start; p < root->data.mapping.pairs.top; p++) {
            yaml_node_t *g = yaml_document_get_node(&doc, p->value);
            if (!scalar_is(yaml_document_get_node(&doc, p->key), group) || g == NULL ||
                g->type != YAML_MAPPING_NODE) {
                continue;
            }
            for (yaml_node_pair_t *q = g->data.mapping.pairs.start; q < g->data.mapping.pairs.top; q++) {
                if (scalar_is(yaml_document_get_node(&doc, q->key), key)) {
                    found = 1;
                }
            }
        }
    }
    yaml_document_delete(&doc);
    yaml_parser_delete(&parser);
    return found;
}

int fmi_vars_add_drag(fmi_vars_t *vs, fmi_causality_t causality, int i, int what_t, int what_r)
{
    /* each filled in before the next is added: an add may move the list
     * (realloc), and a pointer kept across it would write freed memory */
    fmi_var_t *zt = fmi_vars_add(vs, FMI_REAL, causality, "kg/s", "sphere[%d].drag_coefficient", i);
    if (zt == NULL) {
        return 0;
    }
    snprintf(zt->description, sizeof zt->description, "-dF/dv of sphere %d's load (implicit coupling)", i);
    zt->what = what_t;
    zt->index = i;
    /* an input below 0 is refused by fmi2SetReal, naming this range; the
     * rigid component took it as 0 (explicit coupling) without a word */
    zt->min = causality == FMI_INPUT ? 0.0 : -INFINITY;
    fmi_var_t *zr = fmi_vars_add(vs, FMI_REAL, causality, "kg.m2/s", "sphere[%d].rotational_drag_coefficient", i);
    if (zr == NULL) {
        return 0;
    }
    snprintf(zr->description, sizeof zr->description, "-dT/dw of sphere %d's load (implicit coupling)", i);
    zr->what = what_r;
    zr->index = i;
    zr->min = causality == FMI_INPUT ? 0.0 : -INFINITY;
    return 1;
}
