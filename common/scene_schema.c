/* scene_schema.c — the libcyaml schema of a scene file.
 *
 * The one list of names for each enum of scene.h, and the one table of keys
 * with their types, which libcyaml fills into the raw_* structs of
 * scene_internal.h (optional keys as pointers, NULL when absent). Besides the
 * tables, the questions asked of them by the override checks and by the
 * messages that translate libcyaml's errors: which schema a dotted key names
 * (scene_schema_at) and one line on what a value of it looks like
 * (scene_schema_describe). Everything here is constant. */
#include "scene_internal.h"

#include <assert.h>
#include <stdint.h>
#include <string.h>

/* ------------------------------------------------------------------------ */
/* Enumerations: the one list of names for each enum in scene.h.             */

const cyaml_strval_t SCENE_FACE_TYPE_NAMES[] = {
    {"periodic", FACE_PERIODIC},
    {"no_slip", FACE_NO_SLIP},
    {"free_slip", FACE_FREE_SLIP},
    {"moving_wall", FACE_MOVING_WALL},
    {"velocity_inlet", FACE_VELOCITY_INLET},
    {"pressure_outlet", FACE_PRESSURE_OUTLET},
};
static const cyaml_strval_t PROFILE_NAMES[] = {{"uniform", PROFILE_UNIFORM}, {"parabolic", PROFILE_PARABOLIC}};
static const cyaml_strval_t COLLISION_NAMES[] = {{"bgk", COLLISION_BGK}, {"trt", COLLISION_TRT}, {"regularized", COLLISION_REGULARIZED}};
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
static const cyaml_strval_t STREAMING_NAMES[] = {{"in_place", STREAMING_IN_PLACE},
                                                  {"two_array", STREAMING_TWO_ARRAY},
                                                  {"moments", STREAMING_MOMENTS}};
static const cyaml_strval_t PRECISION_NAMES[] = {{"double", PRECISION_DOUBLE}, {"single", PRECISION_SINGLE}};
static const cyaml_strval_t INITIAL_NAMES[] = {{"uniform", INITIAL_UNIFORM},
                                                {"plane_channel", INITIAL_PLANE_CHANNEL}};
static const cyaml_strval_t COUPLING_NAMES[] = {
    {"auto", COUPLING_AUTO}, {"explicit", COUPLING_EXPLICIT}, {"implicit", COUPLING_IMPLICIT}};
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

/* ------------------------------------------------------------------------ */
/* The libcyaml schema: the single table of keys and their types.           */

#define OPT CYAML_FLAG_OPTIONAL
#define OPT_PTR (CYAML_FLAG_OPTIONAL | CYAML_FLAG_POINTER)
#define ENUM_FIELD(key, st, member, names) \
    CYAML_FIELD_ENUM_PTR(key, OPT | CYAML_FLAG_STRICT, st, member, names, CYAML_ARRAY_LEN(names))

static const cyaml_schema_value_t SCHEMA_DOUBLE = {CYAML_VALUE_FLOAT(CYAML_FLAG_DEFAULT, double)};

static const cyaml_schema_field_t FACE_FIELDS[] = {
    CYAML_FIELD_ENUM("type", CYAML_FLAG_STRICT, raw_face_t, type, SCENE_FACE_TYPE_NAMES,
                     CYAML_ARRAY_LEN(SCENE_FACE_TYPE_NAMES)),
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
    ENUM_FIELD("streaming", raw_fluid_t, streaming, STREAMING_NAMES),
    ENUM_FIELD("precision", raw_fluid_t, precision, PRECISION_NAMES),
    CYAML_FIELD_FLOAT_PTR("mach_limit", OPT, raw_fluid_t, mach_limit),
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
    ENUM_FIELD("move_with_flow", raw_body_t, move_with_flow, BOOL_NAMES),
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

static const cyaml_schema_field_t LUBRICATION_FIELDS[] = {
    ENUM_FIELD("enabled", raw_lubrication_t, enabled, BOOL_NAMES),
    CYAML_FIELD_FLOAT_PTR("cutoff", OPT, raw_lubrication_t, cutoff),
    CYAML_FIELD_FLOAT_PTR("min_gap", OPT, raw_lubrication_t, min_gap),
    CYAML_FIELD_END,
};

static const cyaml_schema_field_t CONTACTS_FIELDS[] = {
    ENUM_FIELD("model", raw_contacts_t, model, CONTACT_NAMES),
    CYAML_FIELD_MAPPING_PTR("lubrication", OPT, raw_contacts_t, lubrication, LUBRICATION_FIELDS),
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
    CYAML_FIELD_FLOAT_PTR("release_time", OPT, raw_rigid_t, release_time),
    CYAML_FIELD_SEQUENCE_FIXED("gravity", OPT_PTR, raw_rigid_t, gravity, &SCHEMA_DOUBLE, 3),
    CYAML_FIELD_END,
};

static const cyaml_schema_field_t RUN_FIELDS[] = {
    CYAML_FIELD_FLOAT("end_time", CYAML_FLAG_DEFAULT, raw_run_t, end_time),
    CYAML_FIELD_FLOAT_PTR("output_interval", OPT, raw_run_t, output_interval),
    ENUM_FIELD("fields", raw_run_t, fields, BOOL_NAMES),
    CYAML_FIELD_FLOAT_PTR("field_interval", OPT, raw_run_t, field_interval),
    CYAML_FIELD_SEQUENCE_FIXED("ranks", OPT_PTR, raw_run_t, ranks, &SCHEMA_DOUBLE, 3),
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

const cyaml_schema_value_t SCENE_SCHEMA = {
    CYAML_VALUE_MAPPING(CYAML_FLAG_POINTER, raw_scene_t, SCENE_FIELDS),
};

#undef ENUM_FIELD
#undef OPT_PTR
#undef OPT

/* ------------------------------------------------------------------------ */
/* Schema helpers shared by override checks and libcyaml messages.          */

const cyaml_schema_field_t *scene_schema_field(const cyaml_schema_value_t *v, const char *key, size_t len)
{
    assert(v->type == CYAML_MAPPING);
    for (const cyaml_schema_field_t *f = v->mapping.fields; f->key != NULL; f++) {
        if (strlen(f->key) == len && strncmp(f->key, key, len) == 0) {
            return f;
        }
    }
    return NULL;
}

bool scene_schema_parse_index(const char *s, size_t len, long *out)
{
    if (len == 0 || len > 9 || (len > 1 && s[0] == '0')) {
        return false; /* "01" would name entry 1 as well as "1" */
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

bool scene_schema_is_sequence(const cyaml_schema_value_t *v)
{
    return v->type == CYAML_SEQUENCE || v->type == CYAML_SEQUENCE_FIXED;
}

/* The schema of dotted key `key` (numbers index lists), or NULL. */
const cyaml_schema_value_t *scene_schema_at(const char *key)
{
    const cyaml_schema_value_t *v = &SCENE_SCHEMA;
    const char *p = key;
    while (*p != '\0') {
        size_t len = strcspn(p, ".");
        long idx;
        if (v->type == CYAML_MAPPING) {
            const cyaml_schema_field_t *f = scene_schema_field(v, p, len);
            if (f == NULL) {
                return NULL;
            }
            v = &f->value;
        } else if (scene_schema_is_sequence(v) && scene_schema_parse_index(p, len, &idx)) {
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
void scene_schema_describe(const cyaml_schema_value_t *v, char *buf, size_t size)
{
    size_t pos = 0;
    switch (v->type) {
    case CYAML_MAPPING:
        scene_report_addf(buf, size, &pos, "a mapping with the keys ");
        for (const cyaml_schema_field_t *f = v->mapping.fields; f->key != NULL; f++) {
            scene_report_addf(buf, size, &pos, "%s%s%s", f == v->mapping.fields ? "" : ", ", f->key,
                              (f->value.flags & CYAML_FLAG_OPTIONAL) ? "" : " (required)");
        }
        break;
    case CYAML_ENUM:
        scene_report_addf(buf, size, &pos, "one of ");
        for (uint32_t i = 0; i < v->enumeration.count; i++) {
            scene_report_addf(buf, size, &pos, "%s%s", i ? " | " : "", v->enumeration.strings[i].str);
        }
        break;
    case CYAML_FLOAT:
        scene_report_addf(buf, size, &pos, "a number");
        break;
    case CYAML_INT:
    case CYAML_UINT:
        scene_report_addf(buf, size, &pos, "an integer");
        break;
    case CYAML_BOOL:
        scene_report_addf(buf, size, &pos, "true | false");
        break;
    case CYAML_STRING:
        scene_report_addf(buf, size, &pos, "a string");
        break;
    case CYAML_SEQUENCE_FIXED:
        scene_report_addf(buf, size, &pos, "a list of exactly %u %s", (unsigned)v->sequence.min,
                          v->sequence.entry->type == CYAML_FLOAT ? "numbers" : "entries");
        break;
    case CYAML_SEQUENCE:
        if (v->sequence.min > 0) {
            scene_report_addf(buf, size, &pos, "a list of at least %u entries", (unsigned)v->sequence.min);
        } else {
            scene_report_addf(buf, size, &pos, "a list");
        }
        break;
    default:
        scene_report_addf(buf, size, &pos, "a value of another type");
        break;
    }
}
