/* scene_internal.h — what the files of the scene reader share; nothing
 * outside common/scene*.c includes it.
 *
 * The reader is one pipeline (scene.c) over one load context (ctx_t, on the
 * stack of scene_load): scene_schema.c holds the libcyaml tables the file is
 * read against, scene_report.c turns every problem into one message naming
 * file, line, key, value and allowed range, scene_override.c grafts the --set
 * overrides into the YAML tree, scene_build.c fills the scene_t from the raw
 * structs libcyaml returns, and scene_check.c holds the checks that refuse a
 * scene. What a file exports carries its stem as prefix. */
#ifndef COMMON_SCENE_INTERNAL_H
#define COMMON_SCENE_INTERNAL_H

#include "scene.h"

#include <cyaml/cyaml.h>
#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>
#include <yaml.h>

enum {
    SCENE_KEY_MAX = 256,    /* longest dotted key we track */
    SCENE_MSG_MAX = 1024,   /* one message body */
    SCENE_FRAMES_MAX = 32,  /* libcyaml backtrace depth we keep */
    SCENE_VALUE_DEPTH_MAX = 32, /* nesting of an override value */
    SCENE_DEPTH_MAX = 64, /* nesting of the scene file (a scene needs 6: bodies.0.spheres.0.center.0) */
    SCENE_MESSAGES_MAX = 50, /* messages logged by one load; the rest are counted in one last message */
};

static const double SCENE_MIN_RADIUS_CELLS = 1.5; /* smallest sphere radius, in cells of fluid.dx */
static const char AXIS_NAMES[3] = {'x', 'y', 'z'};  /* in messages */

/* ------------------------------------------------------------------------ */
/* Raw structs as libcyaml fills them. Optional keys are pointers (NULL when
 * absent) so that presence is known: "exactly one of dx / cells_per_radius"
 * needs it, and defaults are applied in one place (scene_build.c). Integers
 * that libcyaml 1.3 would silently truncate (it accepts 1.5 for an int) are
 * read as doubles and checked to be whole. */

typedef struct {
    face_type_t type;
    double *velocity;
    inlet_profile_t *profile;
    double *pressure;
} raw_face_t;

typedef struct {
    raw_face_t *x_min, *x_max, *y_min, *y_max, *z_min, *z_max;
} raw_faces_t;

typedef struct {
    double size[3];
    raw_faces_t *faces;
} raw_domain_t;

typedef struct {
    double density;
    double viscosity;
    double *dx, *cells_per_radius, *tau, *dt;
    collision_t *collision;
    double *magic;
    double *body_force;
    double *initial_velocity;
    initial_profile_t *initial_profile;
    boundary_scheme_t *boundary_scheme;
    refill_t *refill;
    force_method_t *force;
    streaming_t *streaming;
    precision_t *precision;
    int *force_averaging;
    double *mach_limit;
} raw_fluid_t;

typedef struct {
    char *name;
    double density;
    motion_t *motion;
    double *velocity;
    double *angular_velocity;
    int *move_with_flow;
    scene_sphere_t *spheres;
    unsigned spheres_count;
} raw_body_t;

typedef struct {
    double spheres[2];
    double *max_normal, *max_shear, *max_torque;
} raw_connection_t;

typedef struct {
    int *enabled;
    double *cutoff, *min_gap;
} raw_lubrication_t;

typedef struct {
    contact_model_t *model;
    double *restitution, *contact_time, *friction, *young_modulus, *poisson_ratio, *stick_speed;
    raw_lubrication_t *lubrication;
} raw_contacts_t;

typedef struct {
    integrator_t *integrator;
    coupling_t *coupling;
    cvode_method_t *cvode_method;
    linsol_t *linear_solver;
    double *rtol, *atol, *substeps, *release_time;
    double *gravity;
} raw_rigid_t;

typedef struct {
    double end_time;
    double *output_interval;
    int *fields;
    double *field_interval;
    double *ranks;
} raw_run_t;

typedef struct {
    raw_domain_t domain;
    raw_fluid_t fluid;
    raw_body_t *bodies;
    unsigned bodies_count;
    raw_connection_t *connections;
    unsigned connections_count;
    raw_contacts_t *contacts;
    raw_rigid_t *rigid;
    raw_run_t run;
} raw_scene_t;

/* ------------------------------------------------------------------------ */
/* Load context: where messages go, where keys are in the file, and what
 * libcyaml said. Lives on the stack of scene_load. */

typedef struct {
    char *key;
    int line; /* 1-based */
} where_t;

typedef struct {
    char child[SCENE_KEY_MAX / 4]; /* key or index inside this container; "" if none */
} cy_frame_t;

typedef struct {
    const char *file;
    const log_t *log;
    const char *const *overrides;
    int noverrides;
    where_t *where;
    size_t nwhere, capwhere;
    int nerrors;
    long nhidden, nhidden_errors; /* messages past SCENE_MESSAGES_MAX, not logged */
    int nlogged;
    bool oom;
    /* What libcyaml reported while loading: the first error message and the
     * backtrace frames, innermost first (the order libcyaml prints them). */
    char cy_msg[SCENE_MSG_MAX / 2];
    int cy_nframes;
    cy_frame_t cy_frames[SCENE_FRAMES_MAX];
} ctx_t;

/* A growable text buffer, NUL-terminated. */
typedef struct {
    char *data;
    size_t len, cap;
} text_t;

/* ---- scene_schema.c: the libcyaml schema and what it says about a key ---- */
extern const cyaml_schema_value_t SCENE_SCHEMA; /* the whole file, into raw_scene_t */
extern const cyaml_strval_t SCENE_FACE_TYPE_NAMES[FACE_PRESSURE_OUTLET + 1];
/* The field `key` (len characters, not NUL-terminated) of mapping schema v, or NULL. */
const cyaml_schema_field_t *scene_schema_field(const cyaml_schema_value_t *v, const char *key, size_t len);
/* A list index of at most 9 digits. */
bool scene_schema_parse_index(const char *s, size_t len, long *out);
bool scene_schema_is_sequence(const cyaml_schema_value_t *v);
/* The schema of dotted key `key` (numbers index lists), or NULL. */
const cyaml_schema_value_t *scene_schema_at(const char *key);
/* One line on what a value of this schema looks like. */
void scene_schema_describe(const cyaml_schema_value_t *v, char *buf, size_t size);

/* ---- scene_report.c: locating and saying problems ---- */
/* snprintf that appends at *pos and never overruns; truncates silently. */
void scene_report_addf(char *buf, size_t size, size_t *pos, const char *fmt, ...) __attribute__((format(printf, 4, 5)));

/* Values in messages, 12 significant digits: enough for any value a user
 * types, and derived values print without round-off noise. Returned by
 * value, so that fmt_num(v).s can stand in an argument list. */
typedef struct {
    char s[40];
} num_t;

static inline num_t fmt_num(double v)
{
    num_t n;
    if (isnan(v)) {
        snprintf(n.s, sizeof n.s, "nan");
    } else if (isinf(v)) {
        snprintf(n.s, sizeof n.s, v > 0 ? "inf" : "-inf");
    } else {
        snprintf(n.s, sizeof n.s, "%.12g", v);
    }
    return n;
}

typedef struct {
    char s[130];
} vec_t;

static inline vec_t fmt_vec(const double *v, int n)
{
    vec_t out;
    size_t pos = 0;
    scene_report_addf(out.s, sizeof out.s, &pos, "[");
    for (int i = 0; i < n; i++) {
        scene_report_addf(out.s, sizeof out.s, &pos, "%s%s", i ? ", " : "", fmt_num(v[i]).s);
    }
    scene_report_addf(out.s, sizeof out.s, &pos, "]");
    return out;
}

void scene_report(ctx_t *c, status_t level, const char *key, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
/* An error about `key`; the message should name the value and the allowed range. */
void scene_report_bad(ctx_t *c, const char *key, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
void scene_report_warn(ctx_t *c, const char *key, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
void scene_report_oom(ctx_t *c);
/* Past SCENE_MESSAGES_MAX a message is only counted: a check that would
 * break thousands of times (n^2 pairs of spheres) asks first and counts the
 * rest without formatting them (scene_report_count). */
bool scene_report_shown(const ctx_t *c);
void scene_report_count(ctx_t *c, status_t level);
/* Step 1: the key -> line table of the node tree below node `id`; freed by scene_report_where_free. */
void scene_report_where_walk(ctx_t *c, yaml_document_t *doc, int id, const char *prefix, int depth);
void scene_report_where_free(ctx_t *c);
/* `what` is NULL for the scene file itself ("FILE:LINE:COLUMN: ..."), else
 * names the override whose value failed to parse. */
void scene_report_yaml_error(ctx_t *c, const yaml_parser_t *p, const char *what);
/* A collection repeated through an alias (scene_override_shared_collection);
 * `what` as for scene_report_yaml_error. */
void scene_report_alias(ctx_t *c, const yaml_node_t *n, const char *what);
/* The one message counting what SCENE_MESSAGES_MAX held back, if anything. */
void scene_report_hidden(ctx_t *c);
/* Step 4: libcyaml's log callback (log_ctx is the ctx_t), and the one message
 * for a failed load, naming the key. */
void scene_report_cyaml_log(cyaml_log_t level, void *vctx, const char *fmt, va_list ap);
void scene_report_cyaml_error(ctx_t *c, cyaml_err_t err);

/* ---- scene_override.c: steps 2 and 3 ---- */
/* Step 1, before the node tree is built: the lists and mappings of the YAML
 * text that `p` reads, nested more than `max` deep? From the parser's events,
 * so that the cost is bounded by `max` per token (libyaml's scanner costs the
 * depth per token: 100 000 nested lists, 200 kB, took 27 s to parse) and no
 * deep tree reaches the recursive walkers (libyaml's emitter overflowed the
 * stack at that depth, a segmentation fault). Returns 1 when within `max`, 0
 * when deeper (*where: the collection one level too deep), -1 when the
 * parser fails first (the loader reports that error itself). */
int scene_yaml_depth_within(yaml_parser_t *p, int max, yaml_mark_t *where);
/* The message for a file or override value nested too deep: `what` NULL for
 * the file, else names the override. */
void scene_report_too_deep(ctx_t *c, yaml_mark_t where, int max, const char *what);
const char *scene_override_node_kind(const yaml_node_t *n); /* "a mapping", "a list" or "a scalar" */
/* A mapping or list reached twice (a YAML alias of it), or NULL; *oom on failure to count. */
const yaml_node_t *scene_override_shared_collection(yaml_document_t *doc, bool *oom);
/* Applies one "dotted.key=value" to the tree; false (reported) when it cannot. */
bool scene_override_apply(ctx_t *c, yaml_document_t *doc, const char *ov);
/* Emits the tree as text into out; consumes doc, whether it succeeds or not. */
bool scene_override_emit(ctx_t *c, yaml_document_t *doc, text_t *out);

/* ---- scene_build.c: step 5 ---- */
/* Fills s from r, reporting every violation (c->nerrors counts the errors). */
void scene_build(ctx_t *c, const raw_scene_t *r, scene_t *s);

/* ---- scene_check.c: the checks that refuse a scene ---- */
/* Between steps 2 and 3: every scalar of the tree that the schema reads as a
 * number is one as a whole ("1,000" and "0.7 m" are not); reports each one
 * that is not. */
void scene_check_numbers(ctx_t *c, yaml_document_t *doc);
/* Range checks. Every failing check names key, value and allowed range. */
enum { LO_OPEN = 1, HI_OPEN = 2, ALLOW_INF = 4 };
bool scene_check_range(ctx_t *c, const char *key, double v, double lo, double hi, int flags);
bool scene_check_vec(ctx_t *c, const char *key, const double *v, int n);
/* A whole number in [lo, hi] read as a double (see raw structs). */
bool scene_check_int(ctx_t *c, const char *key, double v, double lo, double hi);
/* Consistency, in the order scene_build runs them. */
/* dx^2, and the dt derived from fluid.tau (dt_given false), usable numbers;
 * else reported on `key`, the key that set dx (rmin: the smallest sphere
 * radius, for fluid.cells_per_radius). */
bool scene_check_step(ctx_t *c, const char *key, const scene_t *s, double rmin, bool dt_given);
void scene_check_divisible(ctx_t *c, const scene_t *s);
void scene_check_spheres(ctx_t *c, const scene_t *s, bool domain_ok, bool dx_ok);
void scene_check_overlaps(ctx_t *c, const scene_t *s, bool domain_ok);
/* No sphere buried in another of its own body (beyond their radical plane). */
void scene_check_buried(ctx_t *c, const scene_t *s, bool domain_ok);
/* relative: spheres of a body touch when d <= (r_a + r_b)(1 + tol), as the
 * rigid component counts them (RIGID_TOUCH_TOL) */
#define SCENE_TOUCH_TOL 1e-9
void scene_unwrap_bodies(scene_t *s);
void scene_check_initial_profile(ctx_t *c, scene_t *s); /* sets fluid.channel_axis */
void scene_check_masses(ctx_t *c, const scene_t *s);
void scene_check_speeds(ctx_t *c, const scene_t *s);
void scene_check_time_scales(ctx_t *c, const scene_t *s);
void scene_check_net_force(ctx_t *c, const scene_t *s);
/* The steps of the run countable: at most SCENE_STEPS_MAX (scene.h). */
void scene_check_run_length(ctx_t *c, const scene_t *s);
void scene_check_lubrication(ctx_t *c, const scene_t *s);

#endif
