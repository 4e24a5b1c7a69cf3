/* scene.c — reads a scene file into a scene_t (DESIGN section 4).
 *
 * Pipeline, one pass each:
 *   1. libyaml parses the file into a node tree; a syntax error is reported
 *      with line and column. A table of dotted key -> line is taken from the
 *      tree before anything changes it, so later messages can cite lines of
 *      the file the user wrote.
 *   2. Each "dotted.key=value" override is checked against the libcyaml
 *      schema (an unknown key is an error naming the override), its value is
 *      parsed as YAML and grafted into the tree, creating missing mappings.
 *   3. The tree is emitted to text (kept as scene->text, the scene as run).
 *   4. libcyaml loads that text against the schema below into raw_* structs
 *      (optional keys are pointers, NULL when absent). Its messages come in
 *      through the log callback and leave as one message naming the dotted
 *      key, with the allowed keys / values / type taken from the schema.
 *   5. raw -> scene_t: defaults filled in, derived values (dx from
 *      cells_per_radius, tau <-> dt) computed, ranges and consistency checked.
 *      Every violation is reported (not only the first) before failing.
 *
 * Invariants: no state outside the call (the context lives on the stack);
 * nothing is printed, every message goes through the caller's log_t as
 * "FILE[:LINE]: KEY = VALUE: problem; allowed: RANGE", and a key set by an
 * override is located as "FILE (--set KEY=VALUE)". scene_load returns
 * STATUS_OK with *out set (warnings, if any, are only logged), STATUS_ERROR for
 * bad input or STATUS_FATAL when memory runs out; on failure *out is NULL and
 * everything allocated is freed on the single cleanup path. */
#include "scene.h"

#include <assert.h>
#include <cyaml/cyaml.h>
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <yaml.h>

enum {
    SCENE_KEY_MAX = 256,    /* longest dotted key we track */
    SCENE_MSG_MAX = 1024,   /* one message body */
    SCENE_FRAMES_MAX = 32,  /* libcyaml backtrace depth we keep */
};

static const double SCENE_DX_TOLERANCE = 1e-9; /* relative, for "size is a multiple of dx" */
static const double SCENE_MIN_RADIUS_CELLS = 1.5;

static const char *const FACE_KEYS[6] = {"x_min", "x_max", "y_min", "y_max", "z_min", "z_max"};
static const char AXIS_NAMES[3] = {'x', 'y', 'z'};

/* ------------------------------------------------------------------------ */
/* Enumerations: the one list of names for each enum in scene.h.             */

static const cyaml_strval_t FACE_TYPE_NAMES[] = {
    {"periodic", FACE_PERIODIC},
    {"no_slip", FACE_NO_SLIP},
    {"free_slip", FACE_FREE_SLIP},
    {"moving_wall", FACE_MOVING_WALL},
    {"velocity_inlet", FACE_VELOCITY_INLET},
    {"pressure_outlet", FACE_PRESSURE_OUTLET},
};
static const cyaml_strval_t PROFILE_NAMES[] = {{"uniform", PROFILE_UNIFORM}, {"parabolic", PROFILE_PARABOLIC}};
static const cyaml_strval_t COLLISION_NAMES[] = {{"bgk", COLLISION_BGK}, {"trt", COLLISION_TRT}};
static const cyaml_strval_t BOUNDARY_NAMES[] = {
    {"bounce_back", BOUNDARY_BOUNCE_BACK},
    {"yu", BOUNDARY_YU},
    {"cli", BOUNDARY_CLI},
    {"quadratic", BOUNDARY_QUADRATIC},
    {"multireflection", BOUNDARY_MULTIREFLECTION},
};
static const cyaml_strval_t REFILL_NAMES[] = {{"equilibrium", REFILL_EQUILIBRIUM},
                                              {"extrapolation", REFILL_EXTRAPOLATION}};
static const cyaml_strval_t FORCE_NAMES[] = {{"momentum_exchange", FORCE_MOMENTUM_EXCHANGE},
                                             {"galilean", FORCE_GALILEAN}};
static const cyaml_strval_t INITIAL_NAMES[] = {{"uniform", INITIAL_UNIFORM},
                                                {"plane_channel", INITIAL_PLANE_CHANNEL}};
static const cyaml_strval_t COUPLING_NAMES[] = {{"explicit", COUPLING_EXPLICIT}, {"implicit", COUPLING_IMPLICIT}};
static const cyaml_strval_t MOTION_NAMES[] = {
    {"free", MOTION_FREE}, {"fixed", MOTION_FIXED}, {"prescribed", MOTION_PRESCRIBED}};
static const cyaml_strval_t CONTACT_NAMES[] = {
    {"none", CONTACT_NONE}, {"spring_dashpot", CONTACT_SPRING_DASHPOT}, {"hertz", CONTACT_HERTZ}};
static const cyaml_strval_t INTEGRATOR_NAMES[] = {{"verlet", INTEGRATOR_VERLET}, {"cvode", INTEGRATOR_CVODE}};
static const cyaml_strval_t CVODE_METHOD_NAMES[] = {{"adams", CVODE_ADAMS}, {"bdf", CVODE_BDF}};
static const cyaml_strval_t LINSOL_NAMES[] = {{"dense", LINSOL_DENSE}, {"spgmr", LINSOL_SPGMR}};
/* Booleans are read as a strict enum: libcyaml 1.3's own bool takes any
 * unknown word ("maybe") as true. These are YAML 1.1's plain spellings. */
static const cyaml_strval_t BOOL_NAMES[] = {{"true", 1}, {"false", 0}, {"yes", 1}, {"no", 0}, {"on", 1}, {"off", 0}};

const char *face_type_name(face_type_t t)
{
    for (size_t i = 0; i < CYAML_ARRAY_LEN(FACE_TYPE_NAMES); i++) {
        if (FACE_TYPE_NAMES[i].val == (int64_t)t) {
            return FACE_TYPE_NAMES[i].str;
        }
    }
    return "unknown";
}

/* ------------------------------------------------------------------------ */
/* Raw structs as libcyaml fills them. Optional keys are pointers (NULL when
 * absent) so that presence is known: "exactly one of dx / cells_per_radius"
 * needs it, and defaults are applied in one place (raw_to_scene). Integers
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
    int *force_averaging;
} raw_fluid_t;

typedef struct {
    char *name;
    double density;
    motion_t *motion;
    double *velocity;
    double *angular_velocity;
    scene_sphere_t *spheres;
    unsigned spheres_count;
} raw_body_t;

typedef struct {
    double spheres[2];
    double *max_normal, *max_shear, *max_torque;
} raw_connection_t;

typedef struct {
    contact_model_t *model;
    double *restitution, *contact_time, *friction, *young_modulus, *poisson_ratio, *stick_speed;
} raw_contacts_t;

typedef struct {
    integrator_t *integrator;
    coupling_t *coupling;
    cvode_method_t *cvode_method;
    linsol_t *linear_solver;
    double *rtol, *atol, *substeps;
    double *gravity;
} raw_rigid_t;

typedef struct {
    double end_time;
    double *output_interval;
    int *fields;
    double *field_interval;
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
/* The libcyaml schema: the single table of keys and their types.           */

#define OPT CYAML_FLAG_OPTIONAL
#define OPT_PTR (CYAML_FLAG_OPTIONAL | CYAML_FLAG_POINTER)
#define ENUM_FIELD(key, st, member, names) \
    CYAML_FIELD_ENUM_PTR(key, OPT | CYAML_FLAG_STRICT, st, member, names, CYAML_ARRAY_LEN(names))

static const cyaml_schema_value_t SCHEMA_DOUBLE = {CYAML_VALUE_FLOAT(CYAML_FLAG_DEFAULT, double)};

static const cyaml_schema_field_t FACE_FIELDS[] = {
    CYAML_FIELD_ENUM("type", CYAML_FLAG_STRICT, raw_face_t, type, FACE_TYPE_NAMES,
                     CYAML_ARRAY_LEN(FACE_TYPE_NAMES)),
    CYAML_FIELD_SEQUENCE_FIXED("velocity", OPT_PTR, raw_face_t, velocity, &SCHEMA_DOUBLE, 3),
    ENUM_FIELD("profile", raw_face_t, profile, PROFILE_NAMES),
    CYAML_FIELD_FLOAT_PTR("pressure", OPT, raw_face_t, pressure),
    CYAML_FIELD_END,
};

static const cyaml_schema_field_t FACES_FIELDS[] = {
    CYAML_FIELD_MAPPING_PTR("x_min", OPT, raw_faces_t, x_min, FACE_FIELDS),
    CYAML_FIELD_MAPPING_PTR("x_max", OPT, raw_faces_t, x_max, FACE_FIELDS),
    CYAML_FIELD_MAPPING_PTR("y_min", OPT, raw_faces_t, y_min, FACE_FIELDS),
    CYAML_FIELD_MAPPING_PTR("y_max", OPT, raw_faces_t, y_max, FACE_FIELDS),
    CYAML_FIELD_MAPPING_PTR("z_min", OPT, raw_faces_t, z_min, FACE_FIELDS),
    CYAML_FIELD_MAPPING_PTR("z_max", OPT, raw_faces_t, z_max, FACE_FIELDS),
    CYAML_FIELD_END,
};

static const cyaml_schema_field_t DOMAIN_FIELDS[] = {
    CYAML_FIELD_SEQUENCE_FIXED("size", CYAML_FLAG_DEFAULT, raw_domain_t, size, &SCHEMA_DOUBLE, 3),
    CYAML_FIELD_MAPPING_PTR("faces", OPT, raw_domain_t, faces, FACES_FIELDS),
    CYAML_FIELD_END,
};

static const cyaml_schema_field_t FLUID_FIELDS[] = {
    CYAML_FIELD_FLOAT("density", CYAML_FLAG_DEFAULT, raw_fluid_t, density),
    CYAML_FIELD_FLOAT("viscosity", CYAML_FLAG_DEFAULT, raw_fluid_t, viscosity),
    CYAML_FIELD_FLOAT_PTR("dx", OPT, raw_fluid_t, dx),
    CYAML_FIELD_FLOAT_PTR("cells_per_radius", OPT, raw_fluid_t, cells_per_radius),
    CYAML_FIELD_FLOAT_PTR("tau", OPT, raw_fluid_t, tau),
    CYAML_FIELD_FLOAT_PTR("dt", OPT, raw_fluid_t, dt),
    ENUM_FIELD("collision", raw_fluid_t, collision, COLLISION_NAMES),
    CYAML_FIELD_FLOAT_PTR("magic", OPT, raw_fluid_t, magic),
    CYAML_FIELD_SEQUENCE_FIXED("body_force", OPT_PTR, raw_fluid_t, body_force, &SCHEMA_DOUBLE, 3),
    CYAML_FIELD_SEQUENCE_FIXED("initial_velocity", OPT_PTR, raw_fluid_t, initial_velocity, &SCHEMA_DOUBLE, 3),
    ENUM_FIELD("initial_profile", raw_fluid_t, initial_profile, INITIAL_NAMES),
    ENUM_FIELD("boundary_scheme", raw_fluid_t, boundary_scheme, BOUNDARY_NAMES),
    ENUM_FIELD("refill", raw_fluid_t, refill, REFILL_NAMES),
    ENUM_FIELD("force", raw_fluid_t, force, FORCE_NAMES),
    ENUM_FIELD("force_averaging", raw_fluid_t, force_averaging, BOOL_NAMES),
    CYAML_FIELD_END,
};

static const cyaml_schema_field_t SPHERE_FIELDS[] = {
    CYAML_FIELD_SEQUENCE_FIXED("center", CYAML_FLAG_DEFAULT, scene_sphere_t, center, &SCHEMA_DOUBLE, 3),
    CYAML_FIELD_FLOAT("radius", CYAML_FLAG_DEFAULT, scene_sphere_t, radius),
    CYAML_FIELD_END,
};
static const cyaml_schema_value_t SPHERE_SCHEMA = {
    CYAML_VALUE_MAPPING(CYAML_FLAG_DEFAULT, scene_sphere_t, SPHERE_FIELDS),
};

static const cyaml_schema_field_t BODY_FIELDS[] = {
    CYAML_FIELD_STRING_PTR("name", OPT, raw_body_t, name, 0, CYAML_UNLIMITED),
    CYAML_FIELD_FLOAT("density", CYAML_FLAG_DEFAULT, raw_body_t, density),
    ENUM_FIELD("motion", raw_body_t, motion, MOTION_NAMES),
    CYAML_FIELD_SEQUENCE_FIXED("velocity", OPT_PTR, raw_body_t, velocity, &SCHEMA_DOUBLE, 3),
    CYAML_FIELD_SEQUENCE_FIXED("angular_velocity", OPT_PTR, raw_body_t, angular_velocity, &SCHEMA_DOUBLE, 3),
    CYAML_FIELD_SEQUENCE("spheres", CYAML_FLAG_POINTER, raw_body_t, spheres, &SPHERE_SCHEMA, 1, CYAML_UNLIMITED),
    CYAML_FIELD_END,
};
static const cyaml_schema_value_t BODY_SCHEMA = {
    CYAML_VALUE_MAPPING(CYAML_FLAG_DEFAULT, raw_body_t, BODY_FIELDS),
};

static const cyaml_schema_field_t CONNECTION_FIELDS[] = {
    CYAML_FIELD_SEQUENCE_FIXED("spheres", CYAML_FLAG_DEFAULT, raw_connection_t, spheres, &SCHEMA_DOUBLE, 2),
    CYAML_FIELD_FLOAT_PTR("max_normal", OPT, raw_connection_t, max_normal),
    CYAML_FIELD_FLOAT_PTR("max_shear", OPT, raw_connection_t, max_shear),
    CYAML_FIELD_FLOAT_PTR("max_torque", OPT, raw_connection_t, max_torque),
    CYAML_FIELD_END,
};
static const cyaml_schema_value_t CONNECTION_SCHEMA = {
    CYAML_VALUE_MAPPING(CYAML_FLAG_DEFAULT, raw_connection_t, CONNECTION_FIELDS),
};

static const cyaml_schema_field_t CONTACTS_FIELDS[] = {
    ENUM_FIELD("model", raw_contacts_t, model, CONTACT_NAMES),
    CYAML_FIELD_FLOAT_PTR("restitution", OPT, raw_contacts_t, restitution),
    CYAML_FIELD_FLOAT_PTR("contact_time", OPT, raw_contacts_t, contact_time),
    CYAML_FIELD_FLOAT_PTR("friction", OPT, raw_contacts_t, friction),
    CYAML_FIELD_FLOAT_PTR("young_modulus", OPT, raw_contacts_t, young_modulus),
    CYAML_FIELD_FLOAT_PTR("poisson_ratio", OPT, raw_contacts_t, poisson_ratio),
    CYAML_FIELD_FLOAT_PTR("stick_speed", OPT, raw_contacts_t, stick_speed),
    CYAML_FIELD_END,
};

static const cyaml_schema_field_t RIGID_FIELDS[] = {
    ENUM_FIELD("integrator", raw_rigid_t, integrator, INTEGRATOR_NAMES),
    ENUM_FIELD("coupling", raw_rigid_t, coupling, COUPLING_NAMES),
    ENUM_FIELD("cvode_method", raw_rigid_t, cvode_method, CVODE_METHOD_NAMES),
    ENUM_FIELD("linear_solver", raw_rigid_t, linear_solver, LINSOL_NAMES),
    CYAML_FIELD_FLOAT_PTR("rtol", OPT, raw_rigid_t, rtol),
    CYAML_FIELD_FLOAT_PTR("atol", OPT, raw_rigid_t, atol),
    CYAML_FIELD_FLOAT_PTR("substeps", OPT, raw_rigid_t, substeps),
    CYAML_FIELD_SEQUENCE_FIXED("gravity", OPT_PTR, raw_rigid_t, gravity, &SCHEMA_DOUBLE, 3),
    CYAML_FIELD_END,
};

static const cyaml_schema_field_t RUN_FIELDS[] = {
    CYAML_FIELD_FLOAT("end_time", CYAML_FLAG_DEFAULT, raw_run_t, end_time),
    CYAML_FIELD_FLOAT_PTR("output_interval", OPT, raw_run_t, output_interval),
    ENUM_FIELD("fields", raw_run_t, fields, BOOL_NAMES),
    CYAML_FIELD_FLOAT_PTR("field_interval", OPT, raw_run_t, field_interval),
    CYAML_FIELD_END,
};

static const cyaml_schema_field_t SCENE_FIELDS[] = {
    CYAML_FIELD_MAPPING("domain", CYAML_FLAG_DEFAULT, raw_scene_t, domain, DOMAIN_FIELDS),
    CYAML_FIELD_MAPPING("fluid", CYAML_FLAG_DEFAULT, raw_scene_t, fluid, FLUID_FIELDS),
    CYAML_FIELD_SEQUENCE("bodies", OPT_PTR, raw_scene_t, bodies, &BODY_SCHEMA, 0, CYAML_UNLIMITED),
    CYAML_FIELD_SEQUENCE("connections", OPT_PTR, raw_scene_t, connections, &CONNECTION_SCHEMA, 0,
                         CYAML_UNLIMITED),
    CYAML_FIELD_MAPPING_PTR("contacts", OPT, raw_scene_t, contacts, CONTACTS_FIELDS),
    CYAML_FIELD_MAPPING_PTR("rigid", OPT, raw_scene_t, rigid, RIGID_FIELDS),
    CYAML_FIELD_MAPPING("run", CYAML_FLAG_DEFAULT, raw_scene_t, run, RUN_FIELDS),
    CYAML_FIELD_END,
};

static const cyaml_schema_value_t SCENE_SCHEMA = {
    CYAML_VALUE_MAPPING(CYAML_FLAG_POINTER, raw_scene_t, SCENE_FIELDS),
};

#undef ENUM_FIELD
#undef OPT_PTR
#undef OPT

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

/* snprintf that appends at *pos and never overruns; truncates silently. */
static void str_addf(char *buf, size_t size, size_t *pos, const char *fmt, ...) __attribute__((format(printf, 4, 5)));
static void str_addf(char *buf, size_t size, size_t *pos, const char *fmt, ...)
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

/* 12 significant digits: enough for any value a user types, and derived
 * values print without round-off noise. */
typedef struct {
    char s[40];
} num_t;

static num_t fmt_num(double v)
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

static vec_t fmt_vec(const double *v, int n)
{
    vec_t out;
    size_t pos = 0;
    str_addf(out.s, sizeof out.s, &pos, "[");
    for (int i = 0; i < n; i++) {
        str_addf(out.s, sizeof out.s, &pos, "%s%s", i ? ", " : "", fmt_num(v[i]).s);
    }
    str_addf(out.s, sizeof out.s, &pos, "]");
    return out;
}

/* Does dotted key `key` lie at or below dotted key `prefix`? */
static bool key_under(const char *key, const char *prefix, size_t plen)
{
    return strncmp(key, prefix, plen) == 0 && (key[plen] == '\0' || key[plen] == '.');
}

/* "FILE:LINE", "FILE (--set K=V)" or "FILE": where the user can find `key`. */
static void ctx_locate(const ctx_t *c, const char *key, char *buf, size_t size)
{
    for (int i = c->noverrides - 1; i >= 0 && key[0] != '\0'; i--) {
        const char *ov = c->overrides[i];
        const char *eq = strchr(ov, '=');
        if (eq != NULL && eq > ov && key_under(key, ov, (size_t)(eq - ov))) {
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

static void ctx_vreport(ctx_t *c, status_t level, const char *key, const char *fmt, va_list ap)
{
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
    if (level >= STATUS_ERROR) {
        c->nerrors++;
    }
}

static void report(ctx_t *c, status_t level, const char *key, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
static void report(ctx_t *c, status_t level, const char *key, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    ctx_vreport(c, level, key, fmt, ap);
    va_end(ap);
}

/* An error about `key`; the message should name the value and the allowed range. */
static void bad(ctx_t *c, const char *key, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static void bad(ctx_t *c, const char *key, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    ctx_vreport(c, STATUS_ERROR, key, fmt, ap);
    va_end(ap);
}

static void warn(ctx_t *c, const char *key, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static void warn(ctx_t *c, const char *key, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    ctx_vreport(c, STATUS_WARNING, key, fmt, ap);
    va_end(ap);
}

static void out_of_memory(ctx_t *c)
{
    if (!c->oom) {
        log_msg(c->log, STATUS_FATAL, "scene", "%s: out of memory while reading the scene", c->file);
        c->nerrors++;
        c->oom = true;
    }
}

/* ------------------------------------------------------------------------ */
/* Range checks. Every failing check names key, value and allowed range.    */

enum { LO_OPEN = 1, HI_OPEN = 2, ALLOW_INF = 4 };

static bool check_range(ctx_t *c, const char *key, double v, double lo, double hi, int flags)
{
    bool ok = !isnan(v) && (isfinite(v) || (flags & ALLOW_INF)) && ((flags & LO_OPEN) ? v > lo : v >= lo) &&
              ((flags & HI_OPEN) ? v < hi : v <= hi);
    if (!ok) {
        bad(c, key, "= %s: out of range; allowed: %s%s, %s%s", fmt_num(v).s, (flags & LO_OPEN) ? "(" : "[",
            fmt_num(lo).s, fmt_num(hi).s, ((flags & HI_OPEN) || (isinf(hi) && !(flags & ALLOW_INF))) ? ")" : "]");
    }
    return ok;
}

static bool check_vec(ctx_t *c, const char *key, const double *v, int n)
{
    for (int i = 0; i < n; i++) {
        if (!isfinite(v[i])) {
            bad(c, key, "= %s: component %d is not a finite number; allowed: finite numbers", fmt_vec(v, n).s, i);
            return false;
        }
    }
    return true;
}

/* A whole number in [lo, hi] read as a double (see raw structs). */
static bool check_int(ctx_t *c, const char *key, double v, double lo, double hi)
{
    bool ok = isfinite(v) && v == floor(v) && v >= lo && v <= hi;
    if (!ok) {
        bad(c, key, "= %s: not a whole number in range; allowed: an integer in [%s, %s]", fmt_num(v).s, fmt_num(lo).s, fmt_num(hi).s);
    }
    return ok;
}

/* ------------------------------------------------------------------------ */
/* Schema helpers shared by override checks and libcyaml messages.          */

static const cyaml_schema_field_t *schema_field(const cyaml_schema_value_t *v, const char *key, size_t len)
{
    assert(v->type == CYAML_MAPPING);
    for (const cyaml_schema_field_t *f = v->mapping.fields; f->key != NULL; f++) {
        if (strlen(f->key) == len && strncmp(f->key, key, len) == 0) {
            return f;
        }
    }
    return NULL;
}

static bool parse_index(const char *s, size_t len, long *out)
{
    if (len == 0 || len > 9) {
        return false;
    }
    long v = 0;
    for (size_t i = 0; i < len; i++) {
        if (s[i] < '0' || s[i] > '9') {
            return false;
        }
        v = 10 * v + (s[i] - '0');
    }
    *out = v;
    return true;
}

static bool schema_is_sequence(const cyaml_schema_value_t *v)
{
    return v->type == CYAML_SEQUENCE || v->type == CYAML_SEQUENCE_FIXED;
}

/* The schema of dotted key `key` (numbers index lists), or NULL. */
static const cyaml_schema_value_t *schema_at(const char *key)
{
    const cyaml_schema_value_t *v = &SCENE_SCHEMA;
    const char *p = key;
    while (*p != '\0') {
        size_t len = strcspn(p, ".");
        long idx;
        if (v->type == CYAML_MAPPING) {
            const cyaml_schema_field_t *f = schema_field(v, p, len);
            if (f == NULL) {
                return NULL;
            }
            v = &f->value;
        } else if (schema_is_sequence(v) && parse_index(p, len, &idx)) {
            v = v->sequence.entry;
        } else {
            return NULL;
        }
        p += len;
        if (*p == '.') {
            p++;
        }
    }
    return v;
}

/* One line on what a value of this schema looks like. */
static void schema_describe(const cyaml_schema_value_t *v, char *buf, size_t size)
{
    size_t pos = 0;
    switch (v->type) {
    case CYAML_MAPPING:
        str_addf(buf, size, &pos, "a mapping with the keys ");
        for (const cyaml_schema_field_t *f = v->mapping.fields; f->key != NULL; f++) {
            str_addf(buf, size, &pos, "%s%s%s", f == v->mapping.fields ? "" : ", ", f->key,
                     (f->value.flags & CYAML_FLAG_OPTIONAL) ? "" : " (required)");
        }
        break;
    case CYAML_ENUM:
        str_addf(buf, size, &pos, "one of ");
        for (uint32_t i = 0; i < v->enumeration.count; i++) {
            str_addf(buf, size, &pos, "%s%s", i ? " | " : "", v->enumeration.strings[i].str);
        }
        break;
    case CYAML_FLOAT:
        str_addf(buf, size, &pos, "a number");
        break;
    case CYAML_INT:
    case CYAML_UINT:
        str_addf(buf, size, &pos, "an integer");
        break;
    case CYAML_BOOL:
        str_addf(buf, size, &pos, "true | false");
        break;
    case CYAML_STRING:
        str_addf(buf, size, &pos, "a string");
        break;
    case CYAML_SEQUENCE_FIXED:
        str_addf(buf, size, &pos, "a list of exactly %u %s", (unsigned)v->sequence.min,
                 v->sequence.entry->type == CYAML_FLOAT ? "numbers" : "entries");
        break;
    case CYAML_SEQUENCE:
        if (v->sequence.min > 0) {
            str_addf(buf, size, &pos, "a list of at least %u entries", (unsigned)v->sequence.min);
        } else {
            str_addf(buf, size, &pos, "a list");
        }
        break;
    default:
        str_addf(buf, size, &pos, "a value of another type");
        break;
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
            out_of_memory(c);
            return;
        }
        c->where = w;
        c->capwhere = cap;
    }
    char *k = strdup(key);
    if (k == NULL) {
        out_of_memory(c);
        return;
    }
    c->where[c->nwhere].key = k;
    c->where[c->nwhere].line = line;
    c->nwhere++;
}

static void where_walk(ctx_t *c, yaml_document_t *doc, int id, const char *prefix, int depth)
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
            where_walk(c, doc, p->value, key, depth + 1);
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
            where_walk(c, doc, *it, key, depth + 1);
        }
    }
}

static void where_free(ctx_t *c)
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
static void report_yaml_error(ctx_t *c, const yaml_parser_t *p, const char *what)
{
    if (p->error == YAML_MEMORY_ERROR) {
        out_of_memory(c);
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

/* ------------------------------------------------------------------------ */
/* Step 2: overrides.                                                       */

/* Deep copy of node `id` of `src` into `dst`; returns the new id or 0. */
static int node_copy(yaml_document_t *dst, yaml_document_t *src, int id, int depth)
{
    yaml_node_t *n = yaml_document_get_node(src, id);
    if (n == NULL || depth > 32) {
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
            if (item == 0 || !yaml_document_append_sequence_item(dst, out, item)) {
                return 0;
            }
        }
        return out;
    }
    case YAML_MAPPING_NODE: {
        int out = yaml_document_add_mapping(dst, n->tag, n->data.mapping.style);
        for (yaml_node_pair_t *p = n->data.mapping.pairs.start; out && p < n->data.mapping.pairs.top; p++) {
            int k = node_copy(dst, src, p->key, depth + 1);
            int v = k ? node_copy(dst, src, p->value, depth + 1) : 0;
            if (v == 0 || !yaml_document_append_mapping_pair(dst, out, k, v)) {
                return 0;
            }
        }
        return out;
    }
    default:
        return 0;
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
        out_of_memory(c);
        goto done;
    }
    parser_ok = true;
    yaml_parser_set_input_string(&parser, (const unsigned char *)value, strlen(value));
    if (!yaml_parser_load(&parser, &vdoc)) {
        char what[SCENE_KEY_MAX + 32];
        snprintf(what, sizeof what, "override '%s': the value is not YAML", ov);
        report_yaml_error(c, &parser, what);
        goto done;
    }
    vdoc_ok = true;
    if (yaml_document_get_root_node(&vdoc) == NULL) {
        bad(c, "", "override '%s': the value is empty; allowed: a YAML value such as 1.5, cvode or [1, 2, 3]", ov);
        goto done;
    }
    id = node_copy(doc, &vdoc, 1, 0);
    if (id == 0) {
        out_of_memory(c);
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

static const char *node_kind(const yaml_node_t *n)
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
static bool override_apply(ctx_t *c, yaml_document_t *doc, const char *ov)
{
    const char *eq = strchr(ov, '=');
    if (eq == NULL || eq == ov) {
        bad(c, "", "override '%s': expected KEY=VALUE with a dotted KEY such as fluid.tau=0.8", ov);
        return false;
    }
    size_t klen = (size_t)(eq - ov);
    if (klen >= SCENE_KEY_MAX) {
        bad(c, "", "override '%s': the key is longer than %d characters", ov, SCENE_KEY_MAX - 1);
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
            bad(c, "", "override '%s': empty key component; allowed: keys joined by single dots", ov);
            return false;
        }
        if (sv->type == CYAML_MAPPING) {
            const cyaml_schema_field_t *f = schema_field(sv, p, len);
            if (f == NULL) {
                schema_describe(sv, desc, sizeof desc);
                bad(c, "", "override '%s': unknown key '%.*s' in %s; allowed: %s", ov, (int)len, p, parent, desc);
                return false;
            }
            if (node->type != YAML_MAPPING_NODE) {
                bad(c, "", "override '%s': %s is %s in the file, not a mapping with key '%.*s'", ov, parent,
                    node_kind(node), (int)len, p);
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
                    child_id = schema_is_sequence(&f->value)
                                   ? yaml_document_add_sequence(doc, NULL, YAML_ANY_SEQUENCE_STYLE)
                                   : yaml_document_add_mapping(doc, NULL, YAML_ANY_MAPPING_STYLE);
                }
                if (key_id == 0 || child_id == 0 || !yaml_document_append_mapping_pair(doc, node_id, key_id, child_id)) {
                    out_of_memory(c);
                    return false;
                }
                node_id = child_id;
            }
            sv = &f->value;
        } else if (schema_is_sequence(sv)) {
            long idx;
            if (!parse_index(p, len, &idx)) {
                bad(c, "", "override '%s': %s is a list, so '%.*s' must be an index 0, 1, ...", ov, parent,
                    (int)len, p);
                return false;
            }
            if (node->type != YAML_SEQUENCE_NODE) {
                bad(c, "", "override '%s': %s is %s in the file, not a list", ov, parent, node_kind(node));
                return false;
            }
            long n = (long)(node->data.sequence.items.top - node->data.sequence.items.start);
            if (idx >= n) {
                bad(c, "", "override '%s': index %ld is out of range; %s has %ld entries (allowed: 0 to %ld)", ov,
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
            schema_describe(sv, desc, sizeof desc);
            bad(c, "", "override '%s': %s is %s and has no key '%.*s'", ov, parent, desc, (int)len, p);
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
static bool emit_document(ctx_t *c, yaml_document_t *doc, text_t *out)
{
    yaml_emitter_t em;
    if (!yaml_emitter_initialize(&em)) {
        yaml_document_delete(doc);
        out_of_memory(c);
        return false;
    }
    yaml_emitter_set_output(&em, emit_write, out);
    yaml_emitter_set_unicode(&em, 1);
    yaml_emitter_set_width(&em, -1);
    bool ok = yaml_emitter_open(&em) && yaml_emitter_dump(&em, doc) && yaml_emitter_close(&em) &&
              yaml_emitter_flush(&em);
    if (!ok) {
        if (em.error == YAML_MEMORY_ERROR || em.error == YAML_WRITER_ERROR) {
            out_of_memory(c);
        } else {
            bad(c, "", "cannot write the scene after overrides: %s", em.problem ? em.problem : "unknown problem");
        }
    }
    yaml_emitter_delete(&em);
    return ok;
}

/* ------------------------------------------------------------------------ */
/* Step 4: libcyaml messages -> one message naming the key.                 */

static void cy_log(cyaml_log_t level, void *vctx, const char *fmt, va_list ap)
{
    ctx_t *c = vctx;
    char line[SCENE_MSG_MAX / 2];
    vsnprintf(line, sizeof line, fmt, ap);
    line[strcspn(line, "\n")] = '\0';
    if (level < CYAML_LOG_ERROR) {
        warn(c, "", "libcyaml: %s", line);
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

static void report_cyaml_error(ctx_t *c, cyaml_err_t err)
{
    if (err == CYAML_ERR_OOM) {
        out_of_memory(c);
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
        str_addf(key, sizeof key, &pos, "%s%s", pos ? "." : "", c->cy_frames[i].child);
    }
    char parent[SCENE_KEY_MAX];
    snprintf(parent, sizeof parent, "%s", key);
    if (extra != NULL) {
        str_addf(key, sizeof key, &pos, "%s%s", pos ? "." : "", extra);
    }

    char desc[SCENE_MSG_MAX / 2] = "";
    const cyaml_schema_value_t *sv = extra != NULL ? schema_at(parent) : schema_at(key);
    if (sv != NULL) {
        schema_describe(sv, desc, sizeof desc);
    }
    if (strncmp(msg, "Missing required", 16) == 0) {
        bad(c, key, "required key is missing (libcyaml: %s); allowed in %s: %s", msg,
            parent[0] ? parent : "the top level", desc);
    } else if (strncmp(msg, "Unexpected key", 14) == 0) {
        bad(c, key, "unknown key (libcyaml: %s); allowed in %s: %s", msg, parent[0] ? parent : "the top level",
            desc);
    } else if (strncmp(msg, "Mapping field already seen", 26) == 0) {
        bad(c, key, "key given twice (libcyaml: %s); allowed: each key once", msg);
    } else {
        bad(c, key, "wrong type or value (libcyaml: %s); allowed: %s", msg, desc[0] ? desc : "see models/README.md");
    }
}

/* ------------------------------------------------------------------------ */
/* Step 5: raw -> scene, with defaults, derived values and validation.      */

static double opt(const double *p, double dflt)
{
    return p != NULL ? *p : dflt;
}

static void opt_vec(double out[3], const double *p, double x, double y, double z)
{
    out[0] = p ? p[0] : x;
    out[1] = p ? p[1] : y;
    out[2] = p ? p[2] : z;
}

/* Returns false when the domain is unusable for the geometric checks that follow. */
static bool build_domain(ctx_t *c, const raw_domain_t *r, scene_domain_t *d)
{
    bool ok = true;
    for (int a = 0; a < 3; a++) {
        d->size[a] = r->size[a];
        if (!isfinite(r->size[a]) || r->size[a] <= 0) {
            bad(c, "domain.size", "= %s: the %c extent is %s; allowed: each in (0, inf) m", fmt_vec(r->size, 3).s,
                AXIS_NAMES[a], fmt_num(r->size[a]).s);
            ok = false;
        }
    }
    const raw_face_t *rf[6] = {NULL, NULL, NULL, NULL, NULL, NULL};
    if (r->faces != NULL) {
        rf[0] = r->faces->x_min;
        rf[1] = r->faces->x_max;
        rf[2] = r->faces->y_min;
        rf[3] = r->faces->y_max;
        rf[4] = r->faces->z_min;
        rf[5] = r->faces->z_max;
    }
    char key[SCENE_KEY_MAX];
    for (int f = 0; f < 6; f++) {
        face_t *face = &d->faces[f];
        const raw_face_t *raw = rf[f];
        int axis = f / 2;
        face->type = raw ? raw->type : FACE_PERIODIC;
        opt_vec(face->velocity, raw ? raw->velocity : NULL, 0, 0, 0);
        face->profile = (raw && raw->profile) ? *raw->profile : PROFILE_UNIFORM;
        face->pressure = opt(raw ? raw->pressure : NULL, 0.0);
        if (raw == NULL) {
            continue;
        }
        const char *tname = face_type_name(face->type);
        bool uses_velocity = face->type == FACE_MOVING_WALL || face->type == FACE_VELOCITY_INLET;
        if (uses_velocity && raw->velocity == NULL) {
            snprintf(key, sizeof key, "domain.faces.%s.velocity", FACE_KEYS[f]);
            bad(c, key, "required for a %s face but missing; allowed: a list of 3 numbers in m/s", tname);
        }
        if (!uses_velocity && raw->velocity != NULL) {
            snprintf(key, sizeof key, "domain.faces.%s.velocity", FACE_KEYS[f]);
            warn(c, key, "= %s: ignored for a %s face (used by moving_wall and velocity_inlet only)",
                 fmt_vec(raw->velocity, 3).s, tname);
        }
        if (face->type != FACE_VELOCITY_INLET && raw->profile != NULL) {
            snprintf(key, sizeof key, "domain.faces.%s.profile", FACE_KEYS[f]);
            warn(c, key, "ignored for a %s face (used by velocity_inlet only)", tname);
        }
        if (face->type != FACE_PRESSURE_OUTLET && raw->pressure != NULL) {
            snprintf(key, sizeof key, "domain.faces.%s.pressure", FACE_KEYS[f]);
            warn(c, key, "= %s: ignored for a %s face (used by pressure_outlet only)", fmt_num(*raw->pressure).s,
                 tname);
        }
        if (raw->velocity != NULL && uses_velocity) {
            snprintf(key, sizeof key, "domain.faces.%s.velocity", FACE_KEYS[f]);
            if (check_vec(c, key, face->velocity, 3)) {
                double vn = face->velocity[axis];
                if (face->type == FACE_MOVING_WALL && vn != 0.0) {
                    bad(c, key,
                        "= %s: a moving wall moves in its own plane, but the normal (%c) component is %s; allowed: "
                        "%c component = 0",
                        fmt_vec(face->velocity, 3).s, AXIS_NAMES[axis], fmt_num(vn).s, AXIS_NAMES[axis]);
                }
                bool inward = (f % 2 == 0) ? vn > 0 : vn < 0;
                if (face->type == FACE_VELOCITY_INLET && !inward) {
                    bad(c, key, "= %s: an inlet on %s must point into the domain; allowed: %c component %s 0",
                        fmt_vec(face->velocity, 3).s, FACE_KEYS[f], AXIS_NAMES[axis], (f % 2 == 0) ? ">" : "<");
                }
            }
        }
        if (face->type == FACE_PRESSURE_OUTLET) {
            snprintf(key, sizeof key, "domain.faces.%s.pressure", FACE_KEYS[f]);
            check_range(c, key, face->pressure, -INFINITY, INFINITY, 0);
        }
    }
    for (int a = 0; a < 3; a++) {
        bool lo = d->faces[2 * a].type == FACE_PERIODIC;
        bool hi = d->faces[2 * a + 1].type == FACE_PERIODIC;
        if (lo != hi) {
            int np = lo ? 2 * a + 1 : 2 * a; /* the face that is not periodic */
            snprintf(key, sizeof key, "domain.faces.%s.type", FACE_KEYS[np]);
            bad(c, key, "= %s, but %s is periodic; allowed: periodic on both %s and %s, or on neither",
                face_type_name(d->faces[np].type), FACE_KEYS[lo ? 2 * a : 2 * a + 1], FACE_KEYS[2 * a],
                FACE_KEYS[2 * a + 1]);
        }
    }
    return ok;
}

static bool build_bodies(ctx_t *c, const raw_scene_t *r, scene_t *s)
{
    if (r->bodies_count > (unsigned)INT_MAX) {
        bad(c, "bodies", "%u bodies; allowed: at most %d", r->bodies_count, INT_MAX);
        return false;
    }
    s->nbodies = (int)r->bodies_count;
    if (s->nbodies == 0) {
        return true;
    }
    s->bodies = calloc((size_t)s->nbodies, sizeof *s->bodies);
    if (s->bodies == NULL) {
        out_of_memory(c);
        return false;
    }
    long total = 0;
    char key[SCENE_KEY_MAX];
    for (int i = 0; i < s->nbodies; i++) {
        const raw_body_t *rb = &r->bodies[i];
        scene_body_t *b = &s->bodies[i];
        total += (long)rb->spheres_count;
        if (total > INT_MAX) {
            bad(c, "bodies", "more than %d spheres in total", INT_MAX);
            return false;
        }
        if (rb->name != NULL) {
            b->name = strdup(rb->name);
            if (b->name == NULL) {
                out_of_memory(c);
                return false;
            }
        }
        b->nspheres = (int)rb->spheres_count;
        b->spheres = malloc((size_t)b->nspheres * sizeof *b->spheres);
        if (b->spheres == NULL) {
            out_of_memory(c);
            return false;
        }
        memcpy(b->spheres, rb->spheres, (size_t)b->nspheres * sizeof *b->spheres);
        b->density = rb->density;
        b->motion = rb->motion ? *rb->motion : MOTION_FREE;
        opt_vec(b->velocity, rb->velocity, 0, 0, 0);
        opt_vec(b->angular_velocity, rb->angular_velocity, 0, 0, 0);

        snprintf(key, sizeof key, "bodies.%d.density", i);
        check_range(c, key, b->density, 0, INFINITY, LO_OPEN);
        snprintf(key, sizeof key, "bodies.%d.velocity", i);
        check_vec(c, key, b->velocity, 3);
        snprintf(key, sizeof key, "bodies.%d.angular_velocity", i);
        check_vec(c, key, b->angular_velocity, 3);
        for (int k = 0; k < b->nspheres; k++) {
            snprintf(key, sizeof key, "bodies.%d.spheres.%d.center", i, k);
            check_vec(c, key, b->spheres[k].center, 3);
            snprintf(key, sizeof key, "bodies.%d.spheres.%d.radius", i, k);
            check_range(c, key, b->spheres[k].radius, 0, INFINITY, LO_OPEN);
        }
    }
    return true;
}

static double smallest_radius(const scene_t *s)
{
    double rmin = INFINITY;
    for (int i = 0; i < s->nbodies; i++) {
        for (int k = 0; k < s->bodies[i].nspheres; k++) {
            rmin = fmin(rmin, s->bodies[i].spheres[k].radius);
        }
    }
    return rmin;
}

/* Resolution and time step. Returns true when dx (and, via *dt_ok, dt) are usable. */
static bool build_fluid(ctx_t *c, const raw_fluid_t *r, scene_t *s, bool *dt_ok)
{
    scene_fluid_t *f = &s->fluid;
    *dt_ok = false;
    f->density = r->density;
    f->viscosity = r->viscosity;
    f->collision = r->collision ? *r->collision : COLLISION_TRT;
    f->magic = opt(r->magic, 3.0 / 16.0);
    opt_vec(f->body_force, r->body_force, 0, 0, 0);
    opt_vec(f->initial_velocity, r->initial_velocity, 0, 0, 0);
    f->initial_profile = r->initial_profile ? *r->initial_profile : INITIAL_UNIFORM;
    f->channel_axis = -1;
    f->boundary_scheme = r->boundary_scheme ? *r->boundary_scheme : BOUNDARY_CLI;
    f->refill = r->refill ? *r->refill : REFILL_EXTRAPOLATION;
    f->force_method = r->force ? *r->force : FORCE_GALILEAN;
    f->force_averaging = (r->force_averaging && *r->force_averaging) ? 1 : 0;

    bool nu_ok = check_range(c, "fluid.viscosity", f->viscosity, 0, INFINITY, LO_OPEN);
    check_range(c, "fluid.density", f->density, 0, INFINITY, LO_OPEN);
    check_range(c, "fluid.magic", f->magic, 0, INFINITY, LO_OPEN);
    if (r->magic != NULL && f->collision == COLLISION_BGK) {
        warn(c, "fluid.magic", "= %s: ignored with fluid.collision = bgk (used by trt only)", fmt_num(f->magic).s);
    }
    check_vec(c, "fluid.body_force", f->body_force, 3);
    check_vec(c, "fluid.initial_velocity", f->initial_velocity, 3);

    bool dx_ok = false;
    if ((r->dx != NULL) == (r->cells_per_radius != NULL)) {
        bad(c, r->dx ? "fluid.dx" : "fluid",
            "%s; allowed: exactly one of fluid.dx (m) and fluid.cells_per_radius",
            r->dx ? "both fluid.dx and fluid.cells_per_radius are given" : "neither fluid.dx nor fluid.cells_per_radius is given");
    } else if (r->dx != NULL) {
        f->dx = *r->dx;
        f->cells_per_radius = 0.0;
        dx_ok = check_range(c, "fluid.dx", f->dx, 0, INFINITY, LO_OPEN);
    } else {
        f->cells_per_radius = *r->cells_per_radius;
        double rmin = smallest_radius(s);
        if (check_range(c, "fluid.cells_per_radius", f->cells_per_radius, SCENE_MIN_RADIUS_CELLS, INFINITY, 0)) {
            if (!isfinite(rmin)) {
                bad(c, "fluid.cells_per_radius",
                    "= %s: needs at least one sphere in bodies to set the cell size; allowed: give fluid.dx instead",
                    fmt_num(f->cells_per_radius).s);
            } else if (rmin > 0) {
                f->dx = rmin / f->cells_per_radius;
                dx_ok = true;
            }
        }
    }

    if ((r->tau != NULL) == (r->dt != NULL)) {
        bad(c, r->tau ? "fluid.tau" : "fluid", "%s; allowed: exactly one of fluid.tau and fluid.dt (s)",
            r->tau ? "both fluid.tau and fluid.dt are given" : "neither fluid.tau nor fluid.dt is given");
    } else if (r->tau != NULL) {
        f->tau = *r->tau;
        /* tau = 1/2 + 3 nu dt / dx^2 (lattice viscosity nu_lb = (tau - 1/2)/3) */
        if (check_range(c, "fluid.tau", f->tau, 0.5, INFINITY, LO_OPEN) && dx_ok && nu_ok) {
            f->dt = (f->tau - 0.5) * f->dx * f->dx / (3.0 * f->viscosity);
            *dt_ok = true;
        }
    } else {
        f->dt = *r->dt;
        if (check_range(c, "fluid.dt", f->dt, 0, INFINITY, LO_OPEN) && dx_ok && nu_ok) {
            f->tau = 0.5 + 3.0 * f->viscosity * f->dt / (f->dx * f->dx);
            if (!(f->tau > 0.5) || !isfinite(f->tau)) {
                bad(c, "fluid.dt",
                    "= %s gives tau = 0.5 + 3 nu dt / dx^2 = %s; allowed: a dt for which tau is in (0.5, inf)",
                    fmt_num(f->dt).s, fmt_num(f->tau).s);
            } else {
                *dt_ok = true;
            }
        }
    }
    return dx_ok;
}

static void check_divisible(ctx_t *c, const scene_t *s)
{
    double dx = s->fluid.dx;
    for (int a = 0; a < 3; a++) {
        double n = s->domain.size[a] / dx;
        double nr = round(n);
        if (nr < 1 || fabs(n - nr) > SCENE_DX_TOLERANCE * n) {
            bad(c, "domain.size",
                "= %s: the %c extent %s m is %s cells of fluid.dx = %s m; allowed: a whole number (>= 1) of cells "
                "(relative tolerance %s)",
                fmt_vec(s->domain.size, 3).s, AXIS_NAMES[a], fmt_num(s->domain.size[a]).s, fmt_num(n).s,
                fmt_num(dx).s, fmt_num(SCENE_DX_TOLERANCE).s);
        }
    }
}

static bool axis_periodic(const scene_t *s, int a)
{
    return s->domain.faces[2 * a].type == FACE_PERIODIC;
}

static void check_spheres(ctx_t *c, const scene_t *s, bool domain_ok, bool dx_ok)
{
    char key[SCENE_KEY_MAX];
    int g = 0;
    for (int i = 0; i < s->nbodies; i++) {
        const scene_body_t *b = &s->bodies[i];
        for (int k = 0; k < b->nspheres; k++, g++) {
            const scene_sphere_t *sp = &b->spheres[k];
            if (!(sp->radius > 0) || !isfinite(sp->radius)) {
                continue; /* already reported */
            }
            snprintf(key, sizeof key, "bodies.%d.spheres.%d.radius", i, k);
            if (dx_ok && sp->radius < SCENE_MIN_RADIUS_CELLS * s->fluid.dx * (1 - 1e-12)) {
                bad(c, key, "= %s m is %s cells of fluid.dx = %s m (sphere %d); allowed: at least %s cells = %s m",
                    fmt_num(sp->radius).s, fmt_num(sp->radius / s->fluid.dx).s, fmt_num(s->fluid.dx).s, g,
                    fmt_num(SCENE_MIN_RADIUS_CELLS).s, fmt_num(SCENE_MIN_RADIUS_CELLS * s->fluid.dx).s);
            }
            if (!domain_ok) {
                continue;
            }
            snprintf(key, sizeof key, "bodies.%d.spheres.%d.center", i, k);
            for (int a = 0; a < 3; a++) {
                double x = sp->center[a], r = sp->radius, L = s->domain.size[a];
                if (!isfinite(x)) {
                    break;
                }
                if (axis_periodic(s, a)) {
                    if (!(x >= 0 && x < L)) {
                        bad(c, key,
                            "= %s (sphere %d): the %c coordinate %s is outside the periodic domain; allowed: %c in "
                            "[0, %s)",
                            fmt_vec(sp->center, 3).s, g, AXIS_NAMES[a], fmt_num(x).s, AXIS_NAMES[a], fmt_num(L).s);
                    } else if (2 * r > L) {
                        bad(c, key,
                            "= %s (sphere %d): diameter %s m exceeds the periodic length %s m along %c, so the sphere "
                            "overlaps its own image; allowed: radius <= %s m",
                            fmt_vec(sp->center, 3).s, g, fmt_num(2 * r).s, fmt_num(L).s, AXIS_NAMES[a],
                            fmt_num(L / 2).s);
                    }
                } else if (!(x - r >= 0 && x + r <= L)) {
                    bad(c, key,
                        "= %s with radius %s (sphere %d) reaches outside the walls along %c: [%s, %s]; allowed: %c in "
                        "[%s, %s]",
                        fmt_vec(sp->center, 3).s, fmt_num(r).s, g, AXIS_NAMES[a], fmt_num(x - r).s,
                        fmt_num(x + r).s, AXIS_NAMES[a], fmt_num(r).s, fmt_num(L - r).s);
                }
            }
        }
    }
}

/* Spheres of different bodies must not overlap at start; on periodic axes
 * the nearest image counts. O(n^2), fine for the few thousand spheres of a
 * scene. Spheres of one body may overlap (sintered). */
static void check_overlaps(ctx_t *c, const scene_t *s, bool domain_ok)
{
    char key[SCENE_KEY_MAX];
    int gi = 0;
    for (int i = 0; i < s->nbodies; i++) {
        for (int k = 0; k < s->bodies[i].nspheres; k++, gi++) {
            const scene_sphere_t *p = &s->bodies[i].spheres[k];
            int gj = gi - k + s->bodies[i].nspheres;
            for (int j = i + 1; j < s->nbodies; j++) {
                for (int l = 0; l < s->bodies[j].nspheres; l++, gj++) {
                    const scene_sphere_t *q = &s->bodies[j].spheres[l];
                    double d2 = 0;
                    for (int a = 0; a < 3; a++) {
                        double d = p->center[a] - q->center[a];
                        if (domain_ok && axis_periodic(s, a)) {
                            d -= s->domain.size[a] * round(d / s->domain.size[a]);
                        }
                        d2 += d * d;
                    }
                    double dist = sqrt(d2), rsum = p->radius + q->radius;
                    if (dist < rsum) {
                        snprintf(key, sizeof key, "bodies.%d.spheres.%d.center", j, l);
                        bad(c, key,
                            "= %s (sphere %d, body %d) overlaps sphere %d of body %d at %s: centre distance %s m < "
                            "sum of radii %s m; allowed: distance >= sum of radii for spheres of different bodies",
                            fmt_vec(q->center, 3).s, gj, j, gi, i, fmt_vec(p->center, 3).s, fmt_num(dist).s,
                            fmt_num(rsum).s);
                    }
                }
            }
        }
    }
}

/* A sphere surface point must not move more than half a cell per LBM step
 * (the link lists and refill assume it). The body's reference point is the
 * volume-weighted centroid of its spheres (overlaps ignored): an estimate,
 * good enough for a start-up check. Prescribed motion is known to keep that
 * speed, so it is an error; free motion is only a warning. */
static void check_speeds(ctx_t *c, const scene_t *s)
{
    char key[SCENE_KEY_MAX];
    double limit = 0.5 * s->fluid.dx / s->fluid.dt;
    for (int i = 0; i < s->nbodies; i++) {
        const scene_body_t *b = &s->bodies[i];
        if (b->motion == MOTION_FIXED) {
            continue;
        }
        double cen[3] = {0, 0, 0}, vol = 0;
        for (int k = 0; k < b->nspheres; k++) {
            double w = pow(b->spheres[k].radius, 3);
            vol += w;
            for (int a = 0; a < 3; a++) {
                cen[a] += w * b->spheres[k].center[a];
            }
        }
        double reach = 0;
        for (int k = 0; k < b->nspheres; k++) {
            double d2 = 0;
            for (int a = 0; a < 3; a++) {
                double d = b->spheres[k].center[a] - cen[a] / vol;
                d2 += d * d;
            }
            reach = fmax(reach, sqrt(d2) + b->spheres[k].radius);
        }
        const double *v = b->velocity, *w = b->angular_velocity;
        double speed = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) + sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]) * reach;
        if (!(speed <= limit)) {
            snprintf(key, sizeof key, "bodies.%d.velocity", i);
            report(c, b->motion == MOTION_PRESCRIBED ? STATUS_ERROR : STATUS_WARNING, key,
                "= %s with angular velocity %s moves a surface point up to %s m/s = %s cells per step; allowed: at "
                "most 0.5 cells per step = %s m/s (fluid.dx / (2 fluid.dt))",
                fmt_vec(v, 3).s, fmt_vec(w, 3).s, fmt_num(speed).s, fmt_num(speed * s->fluid.dt / s->fluid.dx).s,
                fmt_num(limit).s);
        }
    }
}

/* fluid.initial_profile = plane_channel needs exactly one axis with walls
 * (no_slip or moving_wall on both faces); the others periodic or free-slip. */
static void check_initial_profile(ctx_t *c, scene_t *s)
{
    scene_fluid_t *f = &s->fluid;
    if (f->initial_profile != INITIAL_PLANE_CHANNEL) {
        return;
    }
    int axis = -1, nwalled = 0;
    for (int a = 0; a < 3; a++) {
        face_type_t t0 = s->domain.faces[2 * a].type, t1 = s->domain.faces[2 * a + 1].type;
        bool wall0 = t0 == FACE_NO_SLIP || t0 == FACE_MOVING_WALL, wall1 = t1 == FACE_NO_SLIP || t1 == FACE_MOVING_WALL;
        bool open0 = t0 == FACE_PERIODIC || t0 == FACE_FREE_SLIP, open1 = t1 == FACE_PERIODIC || t1 == FACE_FREE_SLIP;
        if (wall0 && wall1) {
            axis = a;
            nwalled++;
        } else if (!(open0 && open1)) {
            nwalled = 99; /* an inlet, an outlet or one wall only */
        }
    }
    if (nwalled != 1) {
        bad(c, "fluid.initial_profile",
            "= plane_channel needs exactly one axis bounded by two walls (no_slip or moving_wall) and the other "
            "faces periodic or free_slip; allowed otherwise: uniform");
        return;
    }
    f->channel_axis = axis;
}

void scene_initial_velocity(const scene_t *s, const double x[3], double u[3])
{
    const scene_fluid_t *f = &s->fluid;
    for (int a = 0; a < 3; a++) {
        u[a] = f->initial_velocity[a];
    }
    const int n = f->channel_axis;
    if (f->initial_profile != INITIAL_PLANE_CHANNEL || n < 0) {
        return;
    }
    const double h = s->domain.size[n], xi = fmin(fmax(x[n] / h, 0.0), 1.0);
    const face_t *lo = &s->domain.faces[2 * n], *hi = &s->domain.faces[2 * n + 1];
    for (int a = 0; a < 3; a++) {
        if (a == n) {
            continue;
        }
        double v0 = lo->type == FACE_MOVING_WALL ? lo->velocity[a] : 0.0;
        double v1 = hi->type == FACE_MOVING_WALL ? hi->velocity[a] : 0.0;
        /* Couette part + Poiseuille part of the body force: g/(2 nu) x (h - x). */
        u[a] += v0 + (v1 - v0) * xi + f->body_force[a] / (2.0 * f->density * f->viscosity) * xi * (1.0 - xi) * h * h;
    }
}

static bool build_connections(ctx_t *c, const raw_scene_t *r, scene_t *s)
{
    if (r->connections_count > (unsigned)INT_MAX) {
        bad(c, "connections", "%u connections; allowed: at most %d", r->connections_count, INT_MAX);
        return false;
    }
    s->nconnections = (int)r->connections_count;
    if (s->nconnections == 0) {
        return true;
    }
    s->connections = calloc((size_t)s->nconnections, sizeof *s->connections);
    if (s->connections == NULL) {
        out_of_memory(c);
        return false;
    }
    int ns = scene_total_spheres(s);
    char key[SCENE_KEY_MAX];
    for (int i = 0; i < s->nconnections; i++) {
        const raw_connection_t *rc = &r->connections[i];
        scene_connection_t *cn = &s->connections[i];
        snprintf(key, sizeof key, "connections.%d.spheres", i);
        bool ok = true;
        for (int e = 0; e < 2; e++) {
            if (!isfinite(rc->spheres[e]) || rc->spheres[e] != floor(rc->spheres[e]) || rc->spheres[e] < 0 ||
                rc->spheres[e] >= ns) {
                bad(c, key, "= %s: sphere index %s does not exist; allowed: integers in [0, %d] (global sphere "
                    "indices: bodies in order, their spheres in order; the scene has %d spheres)",
                    fmt_vec(rc->spheres, 2).s, fmt_num(rc->spheres[e]).s, ns - 1, ns);
                ok = false;
                break;
            }
        }
        if (ok && rc->spheres[0] == rc->spheres[1]) {
            bad(c, key, "= %s: a sphere cannot be connected to itself; allowed: two different sphere indices",
                fmt_vec(rc->spheres, 2).s);
            ok = false;
        }
        cn->a = ok ? (int)rc->spheres[0] : -1;
        cn->b = ok ? (int)rc->spheres[1] : -1;
        for (int j = 0; ok && j < i; j++) {
            const scene_connection_t *o = &s->connections[j];
            if ((o->a == cn->a && o->b == cn->b) || (o->a == cn->b && o->b == cn->a)) {
                bad(c, key, "= %s: the pair is already connected by connections.%d; allowed: each pair once",
                    fmt_vec(rc->spheres, 2).s, j);
                break;
            }
        }
        cn->max_normal = opt(rc->max_normal, INFINITY);
        cn->max_shear = opt(rc->max_shear, INFINITY);
        cn->max_torque = opt(rc->max_torque, INFINITY);
        snprintf(key, sizeof key, "connections.%d.max_normal", i);
        check_range(c, key, cn->max_normal, 0, INFINITY, ALLOW_INF);
        snprintf(key, sizeof key, "connections.%d.max_shear", i);
        check_range(c, key, cn->max_shear, 0, INFINITY, ALLOW_INF);
        snprintf(key, sizeof key, "connections.%d.max_torque", i);
        check_range(c, key, cn->max_torque, 0, INFINITY, ALLOW_INF);
    }
    return true;
}

static void build_contacts(ctx_t *c, const raw_contacts_t *r, scene_contacts_t *k)
{
    static const raw_contacts_t none = {0};
    if (r == NULL) {
        r = &none;
    }
    k->model = r->model ? *r->model : CONTACT_NONE;
    k->restitution = opt(r->restitution, 0.9);
    k->contact_time = opt(r->contact_time, 1e-4);
    k->friction = opt(r->friction, 0.0);
    k->young_modulus = opt(r->young_modulus, 1e9);
    k->poisson_ratio = opt(r->poisson_ratio, 0.3);
    k->stick_speed = opt(r->stick_speed, 0.0);
    check_range(c, "contacts.restitution", k->restitution, 0, 1, LO_OPEN);
    check_range(c, "contacts.contact_time", k->contact_time, 0, INFINITY, LO_OPEN);
    check_range(c, "contacts.friction", k->friction, 0, INFINITY, 0);
    check_range(c, "contacts.young_modulus", k->young_modulus, 0, INFINITY, LO_OPEN);
    check_range(c, "contacts.poisson_ratio", k->poisson_ratio, 0, 0.5, HI_OPEN);
    check_range(c, "contacts.stick_speed", k->stick_speed, 0, INFINITY, 0);
}

static void build_rigid(ctx_t *c, const raw_rigid_t *r, scene_rigid_t *g)
{
    static const raw_rigid_t none = {0};
    if (r == NULL) {
        r = &none;
    }
    g->integrator = r->integrator ? *r->integrator : INTEGRATOR_VERLET;
    g->coupling = r->coupling ? *r->coupling : COUPLING_EXPLICIT;
    g->cvode_method = r->cvode_method ? *r->cvode_method : CVODE_BDF;
    g->linear_solver = r->linear_solver ? *r->linear_solver : LINSOL_DENSE;
    g->rtol = opt(r->rtol, 1e-8);
    g->atol = opt(r->atol, 1e-12);
    double substeps = opt(r->substeps, 1.0);
    g->substeps = check_int(c, "rigid.substeps", substeps, 1, INT_MAX) ? (int)substeps : 1;
    opt_vec(g->gravity, r->gravity, 0, 0, 0);
    check_range(c, "rigid.rtol", g->rtol, 0, INFINITY, LO_OPEN);
    check_range(c, "rigid.atol", g->atol, 0, INFINITY, LO_OPEN);
    check_vec(c, "rigid.gravity", g->gravity, 3);
}

static void build_run(ctx_t *c, const raw_run_t *r, scene_run_t *u)
{
    u->end_time = r->end_time;
    u->output_interval = opt(r->output_interval, r->end_time / 100.0);
    u->fields = (r->fields && *r->fields) ? 1 : 0;
    u->field_interval = opt(r->field_interval, u->output_interval);
    if (check_range(c, "run.end_time", u->end_time, 0, INFINITY, LO_OPEN) || r->output_interval != NULL) {
        check_range(c, "run.output_interval", u->output_interval, 0, INFINITY, LO_OPEN);
    }
    if (r->field_interval != NULL) {
        check_range(c, "run.field_interval", u->field_interval, 0, INFINITY, LO_OPEN);
    }
}

static void check_time_scales(ctx_t *c, const scene_t *s)
{
    /* dt derived from tau carries round-off: one step is "at least dt within 1e-9" */
    double dt = s->fluid.dt * (1.0 - 1e-9);
    if (s->run.output_interval > 0 && s->run.output_interval < dt) {
        warn(c, "run.output_interval", "= %s s is shorter than one fluid step fluid.dt = %s s; output every step",
             fmt_num(s->run.output_interval).s, fmt_num(s->fluid.dt).s);
    }
    if (s->run.end_time > 0 && s->run.end_time < dt) {
        warn(c, "run.end_time", "= %s s is shorter than one fluid step fluid.dt = %s s", fmt_num(s->run.end_time).s,
             fmt_num(s->fluid.dt).s);
    }
    double rigid_dt = s->fluid.dt / s->rigid.substeps;
    if (s->contacts.model == CONTACT_SPRING_DASHPOT && s->contacts.contact_time > 0 &&
        s->contacts.contact_time < 10 * rigid_dt) {
        warn(c, "contacts.contact_time",
             "= %s s spans only %s rigid steps of fluid.dt / rigid.substeps = %s s; at least 10 are advised "
             "(raise rigid.substeps)",
             fmt_num(s->contacts.contact_time).s, fmt_num(s->contacts.contact_time / rigid_dt).s,
             fmt_num(rigid_dt).s);
    }
}

static void raw_to_scene(ctx_t *c, const raw_scene_t *r, scene_t *s)
{
    bool domain_ok = build_domain(c, &r->domain, &s->domain);
    if (!build_bodies(c, r, s)) {
        return;
    }
    bool dt_ok;
    bool dx_ok = build_fluid(c, &r->fluid, s, &dt_ok);
    if (dx_ok && domain_ok) {
        check_divisible(c, s);
    }
    check_spheres(c, s, domain_ok, dx_ok);
    check_overlaps(c, s, domain_ok);
    if (domain_ok) {
        check_initial_profile(c, s);
    }
    if (!build_connections(c, r, s)) {
        return;
    }
    build_contacts(c, r->contacts, &s->contacts);
    build_rigid(c, r->rigid, &s->rigid);
    build_run(c, &r->run, &s->run);
    if (dt_ok && c->nerrors == 0) {
        check_speeds(c, s);
        check_time_scales(c, s);
    }
}

/* ------------------------------------------------------------------------ */

int scene_total_spheres(const scene_t *s)
{
    int n = 0;
    for (int i = 0; i < s->nbodies; i++) {
        n += s->bodies[i].nspheres;
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
        .log_fn = cy_log,
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
        bad(&c, "", "cannot open the scene file: %s", strerror(errno));
        goto done;
    }
    if (!yaml_parser_initialize(&parser)) {
        out_of_memory(&c);
        goto done;
    }
    parser_ok = true;
    yaml_parser_set_input_file(&parser, fp);
    if (!yaml_parser_load(&parser, &doc)) {
        report_yaml_error(&c, &parser, NULL);
        goto done;
    }
    doc_ok = true;
    if (yaml_document_get_root_node(&doc) == NULL) {
        bad(&c, "", "the scene is empty; allowed: a mapping with the keys domain, fluid, run (required) and "
                    "bodies, connections, contacts, rigid");
        goto done;
    }
    {
        yaml_document_t extra;
        if (!yaml_parser_load(&parser, &extra)) {
            report_yaml_error(&c, &parser, NULL);
            goto done;
        }
        bool more = yaml_document_get_root_node(&extra) != NULL;
        yaml_document_delete(&extra);
        if (more) {
            bad(&c, "", "more than one YAML document ('---'); allowed: exactly one");
            goto done;
        }
    }
    yaml_parser_delete(&parser);
    parser_ok = false;
    if (fclose(fp) != 0) {
        fp = NULL;
        bad(&c, "", "cannot close the scene file: %s", strerror(errno));
        goto done;
    }
    fp = NULL;

    if (yaml_document_get_root_node(&doc)->type != YAML_MAPPING_NODE) {
        bad(&c, "", "the top level is %s; allowed: a mapping with the keys domain, fluid, run (required) and "
                    "bodies, connections, contacts, rigid",
            node_kind(yaml_document_get_root_node(&doc)));
        goto done;
    }
    where_walk(&c, &doc, 1, "", 0);
    if (c.oom) {
        goto done;
    }
    for (int i = 0; i < noverrides; i++) {
        assert(overrides[i] != NULL);
        if (!override_apply(&c, &doc, overrides[i])) {
            goto done;
        }
    }
    doc_ok = false; /* emit_document consumes it */
    if (!emit_document(&c, &doc, &text)) {
        goto done;
    }

    cyaml_err_t err = cyaml_load_data((const uint8_t *)text.data, text.len, &cfg, &SCENE_SCHEMA,
                                      (cyaml_data_t **)&raw, NULL);
    if (err != CYAML_OK) {
        raw = NULL;
        report_cyaml_error(&c, err);
        goto done;
    }
    if (raw == NULL) {
        bad(&c, "", "the scene is empty");
        goto done;
    }

    s = calloc(1, sizeof *s);
    if (s == NULL) {
        out_of_memory(&c);
        goto done;
    }
    raw_to_scene(&c, raw, s);
    if (c.nerrors > 0) {
        goto done;
    }
    s->path = strdup(path);
    if (s->path == NULL) {
        out_of_memory(&c);
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
    where_free(&c);
    return st;
}
