/* scene_override.c — the --set overrides, as surgery on the YAML node tree
 * (steps 2 and 3 of scene_load).
 *
 * Each "dotted.key=value", in the order given, is checked against the
 * libcyaml schema (an unknown key is an error naming the override); its value
 * is parsed as YAML and grafted into the tree, creating missing mappings on
 * the way (a list index must exist). The tree is then emitted to text: the
 * text libcyaml reads and the scene keeps as run (scene->text). */
#include "scene_internal.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static bool text_append(text_t *t, const char *s, size_t n)
{
    if (t->len + n + 1 > t->cap) {
        size_t cap = t->cap ? t->cap : 1024;
        while (cap < t->len + n + 1) {
            cap *= 2;
        }
        char *p = realloc(t->data, cap);
        if (p == NULL) {
            return false;
        }
        t->data = p;
        t->cap = cap;
    }
    memcpy(t->data + t->len, s, n);
    t->len += n;
    t->data[t->len] = '\0';
    return true;
}

/* ------------------------------------------------------------------------ */
/* Step 2: overrides.                                                       */

/* Counts one more reference to each of the nids nodes; returns the first
 * collection reached for the second time, or NULL. */
static const yaml_node_t *shared_child(yaml_document_t *doc, unsigned char *refs, size_t n, const int *ids, int nids)
{
    for (int j = 0; j < nids; j++) {
        if (ids[j] < 1 || (size_t)ids[j] > n) {
            continue;
        }
        const yaml_node_t *child = &doc->nodes.start[ids[j] - 1];
        if (child->type != YAML_SCALAR_NODE && refs[ids[j]]++ > 0) {
            return child;
        }
    }
    return NULL;
}

/* Deep copy of node `id` of `src` into `dst`; returns the new id, 0 when
 * memory runs out, or -1 when the value is nested deeper than
 * SCENE_VALUE_DEPTH_MAX (no scene value is nested more than 4 deep). */
static int node_copy(yaml_document_t *dst, yaml_document_t *src, int id, int depth)
{
    yaml_node_t *n = yaml_document_get_node(src, id);
    if (depth > SCENE_VALUE_DEPTH_MAX) {
        return -1;
    }
    if (n == NULL) {
        return 0;
    }
    switch (n->type) {
    case YAML_SCALAR_NODE:
        return yaml_document_add_scalar(dst, n->tag, n->data.scalar.value, (int)n->data.scalar.length,
                                        n->data.scalar.style);
    case YAML_SEQUENCE_NODE: {
        int out = yaml_document_add_sequence(dst, n->tag, n->data.sequence.style);
        /* n stays valid: it lives in src, and only dst grows. */
        for (yaml_node_item_t *it = n->data.sequence.items.start; out && it < n->data.sequence.items.top; it++) {
            int item = node_copy(dst, src, *it, depth + 1);
            if (item <= 0) {
                return item;
            }
            if (!yaml_document_append_sequence_item(dst, out, item)) {
                return 0;
            }
        }
        return out;
    }
    case YAML_MAPPING_NODE: {
        int out = yaml_document_add_mapping(dst, n->tag, n->data.mapping.style);
        for (yaml_node_pair_t *p = n->data.mapping.pairs.start; out && p < n->data.mapping.pairs.top; p++) {
            int k = node_copy(dst, src, p->key, depth + 1);
            int v = k > 0 ? node_copy(dst, src, p->value, depth + 1) : k;
            if (v <= 0) {
                return v;
            }
            if (!yaml_document_append_mapping_pair(dst, out, k, v)) {
                return 0;
            }
        }
        return out;
    }
    default:
        return 0;
    }
}

int scene_yaml_depth_within(yaml_parser_t *p, int max, yaml_mark_t *where)
{
    int depth = 0;
    for (;;) {
        yaml_event_t ev;
        if (!yaml_parser_parse(p, &ev)) {
            return -1;
        }
        const yaml_event_type_t type = ev.type;
        if (type == YAML_SEQUENCE_START_EVENT || type == YAML_MAPPING_START_EVENT) {
            if (++depth > max) {
                *where = ev.start_mark;
                yaml_event_delete(&ev);
                return 0;
            }
        } else if (type == YAML_SEQUENCE_END_EVENT || type == YAML_MAPPING_END_EVENT) {
            depth--;
        }
        yaml_event_delete(&ev);
        if (type == YAML_STREAM_END_EVENT) {
            return 1;
        }
    }
}

/* Parses the text after '=' as a YAML document and copies its root into doc. */
static int override_value(ctx_t *c, yaml_document_t *doc, const char *ov, const char *value)
{
    yaml_parser_t parser;
    yaml_document_t vdoc;
    bool parser_ok = false, vdoc_ok = false;
    int id = 0;

    if (!yaml_parser_initialize(&parser)) {
        scene_report_oom(c);
        goto done;
    }
    parser_ok = true;
    yaml_parser_set_input_string(&parser, (const unsigned char *)value, strlen(value));
    {
        yaml_mark_t deep;
        if (scene_yaml_depth_within(&parser, SCENE_DEPTH_MAX, &deep) == 0) {
            char what[SCENE_KEY_MAX + 32];
            snprintf(what, sizeof what, "override '%s': the value at ", ov);
            scene_report_too_deep(c, deep, SCENE_DEPTH_MAX, what);
            goto done;
        }
        /* again from the start, for the document */
        yaml_parser_delete(&parser);
        parser_ok = false;
        if (!yaml_parser_initialize(&parser)) {
            scene_report_oom(c);
            goto done;
        }
        parser_ok = true;
        yaml_parser_set_input_string(&parser, (const unsigned char *)value, strlen(value));
    }
    if (!yaml_parser_load(&parser, &vdoc)) {
        char what[SCENE_KEY_MAX + 32];
        snprintf(what, sizeof what, "override '%s': the value is not YAML", ov);
        scene_report_yaml_error(c, &parser, what);
        goto done;
    }
    vdoc_ok = true;
    if (yaml_document_get_root_node(&vdoc) == NULL) {
        scene_report_bad(c, "",
                         "override '%s': the value is empty; allowed: a YAML value such as 1.5, cvode or [1, 2, 3]",
                         ov);
        goto done;
    }
    {
        bool oom = false;
        const yaml_node_t *shared = scene_override_shared_collection(&vdoc, &oom);
        if (oom) {
            scene_report_oom(c);
            goto done;
        }
        if (shared != NULL) {
            char what[SCENE_KEY_MAX + 32];
            snprintf(what, sizeof what, "override '%s': the value at ", ov);
            scene_report_alias(c, shared, what);
            goto done;
        }
    }
    id = node_copy(doc, &vdoc, 1, 0);
    if (id < 0) {
        scene_report_bad(c, "", "override '%s': the value is nested more than %d levels deep; allowed: a YAML value "
                         "such as 1.5, cvode or [1, 2, 3]", ov, SCENE_VALUE_DEPTH_MAX);
        id = 0;
    } else if (id == 0) {
        scene_report_oom(c);
    }
done:
    if (vdoc_ok) {
        yaml_document_delete(&vdoc);
    }
    if (parser_ok) {
        yaml_parser_delete(&parser);
    }
    return id;
}

/* A mapping or list that the tree reaches more than once: through a YAML
 * alias, or from inside itself (libyaml lets an alias name the collection it
 * is in). Walks over such a tree, and libcyaml's load that replays every
 * alias, expand it, exponentially when aliases nest ("billion laughs"), so
 * the reader refuses them. Aliases of scalars expand to one node each and
 * are allowed. One pass over the node array, no recursion. */
const yaml_node_t *scene_override_shared_collection(yaml_document_t *doc, bool *oom)
{
    size_t n = (size_t)(doc->nodes.top - doc->nodes.start);
    unsigned char *refs = calloc(n + 1, 1); /* by node id; 2 means "more than once" */
    if (refs == NULL) {
        *oom = true;
        return NULL;
    }
    const yaml_node_t *shared = NULL;
    refs[1] = n > 0; /* the root is reached once, as the root */
    for (size_t i = 0; i < n && shared == NULL; i++) {
        const yaml_node_t *node = &doc->nodes.start[i];
        int ids[2];
        if (node->type == YAML_SEQUENCE_NODE) {
            for (const yaml_node_item_t *it = node->data.sequence.items.start;
                 shared == NULL && it < node->data.sequence.items.top; it++) {
                ids[0] = *it;
                shared = shared_child(doc, refs, n, ids, 1);
            }
        } else if (node->type == YAML_MAPPING_NODE) {
            for (const yaml_node_pair_t *p = node->data.mapping.pairs.start;
                 shared == NULL && p < node->data.mapping.pairs.top; p++) {
                ids[0] = p->key;
                ids[1] = p->value;
                shared = shared_child(doc, refs, n, ids, 2);
            }
        }
    }
    free(refs);
    return shared;
}

const char *scene_override_node_kind(const yaml_node_t *n)
{
    switch (n->type) {
    case YAML_MAPPING_NODE:
        return "a mapping";
    case YAML_SEQUENCE_NODE:
        return "a list";
    default:
        return "a scalar";
    }
}

/* Applies one "dotted.key=value": the key is checked against the schema,
 * missing mappings on the way are created, the value replaces or adds. */
bool scene_override_apply(ctx_t *c, yaml_document_t *doc, const char *ov)
{
    const char *eq = strchr(ov, '=');
    if (eq == NULL || eq == ov) {
        scene_report_bad(c, "", "override '%s': expected KEY=VALUE with a dotted KEY such as fluid.tau=0.8", ov);
        return false;
    }
    size_t klen = (size_t)(eq - ov);
    if (klen >= SCENE_KEY_MAX) {
        scene_report_bad(c, "", "override '%s': the key is longer than %d characters", ov, SCENE_KEY_MAX - 1);
        return false;
    }
    int value_id = override_value(c, doc, ov, eq + 1);
    if (value_id == 0) {
        return false;
    }

    const cyaml_schema_value_t *sv = &SCENE_SCHEMA;
    int node_id = 1; /* the root; scene_load has checked that it exists */
    const char *p = ov;
    char parent[SCENE_KEY_MAX] = "(top level)";
    char desc[SCENE_MSG_MAX / 2];
    for (;;) {
        size_t len = strcspn(p, ".=");
        bool last = p[len] == '=';
        yaml_node_t *node = yaml_document_get_node(doc, node_id);
        if (len == 0) {
            scene_report_bad(c, "", "override '%s': empty key component; allowed: keys joined by single dots", ov);
            return false;
        }
        if (sv->type == CYAML_MAPPING) {
            const cyaml_schema_field_t *f = scene_schema_field(sv, p, len);
            if (f == NULL) {
                scene_schema_describe(sv, desc, sizeof desc);
                scene_report_bad(c, "", "override '%s': unknown key '%.*s' in %s; allowed: %s", ov, (int)len, p, parent,
                                 desc);
                return false;
            }
            if (node->type != YAML_MAPPING_NODE) {
                scene_report_bad(c, "", "override '%s': %s is %s in the file, not a mapping with key '%.*s'", ov,
                                 parent, scene_override_node_kind(node), (int)len, p);
                return false;
            }
            yaml_node_pair_t *found = NULL;
            for (yaml_node_pair_t *q = node->data.mapping.pairs.start; q < node->data.mapping.pairs.top; q++) {
                yaml_node_t *k = yaml_document_get_node(doc, q->key);
                if (k != NULL && k->type == YAML_SCALAR_NODE && k->data.scalar.length == len &&
                    memcmp(k->data.scalar.value, p, len) == 0) {
                    found = q;
                }
            }
            if (found != NULL && last) {
                found->value = value_id;
            } else if (found != NULL) {
                node_id = found->value;
            } else {
                int key_id = yaml_document_add_scalar(doc, NULL, (yaml_char_t *)(uintptr_t)p, (int)len,
                                                      YAML_PLAIN_SCALAR_STYLE);
                int child_id = value_id;
                if (!last) {
                    child_id = scene_schema_is_sequence(&f->value)
                                   ? yaml_document_add_sequence(doc, NULL, YAML_ANY_SEQUENCE_STYLE)
                                   : yaml_document_add_mapping(doc, NULL, YAML_ANY_MAPPING_STYLE);
                }
                if (key_id == 0 || child_id == 0 || !yaml_document_append_mapping_pair(doc, node_id, key_id, child_id)) {
                    scene_report_oom(c);
                    return false;
                }
                node_id = child_id;
            }
            sv = &f->value;
        } else if (scene_schema_is_sequence(sv)) {
            long idx;
            if (!scene_schema_parse_index(p, len, &idx)) {
                scene_report_bad(c, "", "override '%s': %s is a list, so '%.*s' must be an index 0, 1, ...", ov, parent,
                                 (int)len, p);
                return false;
            }
            if (node->type != YAML_SEQUENCE_NODE) {
                scene_report_bad(c, "", "override '%s': %s is %s in the file, not a list", ov, parent,
                                 scene_override_node_kind(node));
                return false;
            }
            long n = (long)(node->data.sequence.items.top - node->data.sequence.items.start);
            if (n == 0) { /* "has 0 entries (allowed: 0 to -1)" */
                scene_report_bad(c, "",
                                 "override '%s': index %ld is out of range; %s has no entries (entries are not "
                                 "created: set the whole list, %s=[...])",
                                 ov, idx, parent, parent);
                return false;
            }
            if (idx >= n) {
                scene_report_bad(c, "",
                                 "override '%s': index %ld is out of range; %s has %ld entries (allowed: 0 to %ld)", ov,
                                 idx, parent, n, n - 1);
                return false;
            }
            if (last) {
                node->data.sequence.items.start[idx] = value_id;
            } else {
                node_id = node->data.sequence.items.start[idx];
            }
            sv = sv->sequence.entry;
        } else {
            scene_schema_describe(sv, desc, sizeof desc);
            scene_report_bad(c, "", "override '%s': %s is %s and has no key '%.*s'", ov, parent, desc, (int)len, p);
            return false;
        }
        snprintf(parent, sizeof parent, "%.*s", (int)(p + len - ov), ov);
        if (last) {
            return true;
        }
        p += len + 1;
    }
}

/* ------------------------------------------------------------------------ */
/* Step 3: emit the tree to text.                                            */

static int emit_write(void *data, unsigned char *buffer, size_t size)
{
    return text_append(data, (const char *)buffer, size) ? 1 : 0;
}

/* yaml_emitter_dump consumes the document, whether it succeeds or not. */
bool scene_override_emit(ctx_t *c, yaml_document_t *doc, text_t *out)
{
    yaml_emitter_t em;
    if (!yaml_emitter_initialize(&em)) {
        yaml_document_delete(doc);
        scene_report_oom(c);
        return false;
    }
    yaml_emitter_set_output(&em, emit_write, out);
    yaml_emitter_set_unicode(&em, 1);
    yaml_emitter_set_width(&em, -1);
    bool ok = yaml_emitter_open(&em) && yaml_emitter_dump(&em, doc) && yaml_emitter_close(&em) &&
              yaml_emitter_flush(&em);
    if (!ok) {
        if (em.error == YAML_MEMORY_ERROR || em.error == YAML_WRITER_ERROR) {
            scene_report_oom(c);
        } else {
            scene_report_bad(c, "", "cannot write the scene after overrides: %s",
                             em.problem ? em.problem : "unknown problem");
        }
    }
    yaml_emitter_delete(&em);
    return ok;
}
