/* test_scene_bad.c — a table of bad scenes, each with the exact message the
 * reader must give (common/scene*.c).
 *
 * Each row is one scene file (the base scene of test_scene.c with one line
 * replaced, a whole file of its own, or one built by a function for the
 * large cases) and up to three --set overrides. The row passes when the load
 * fails with *out == NULL, exactly `nerrors` error messages are logged, and
 * the first is exactly `msg` ("FILE[:LINE]: KEY = VALUE: problem; allowed:
 * RANGE", models/README.md "Error messages"), the file written as
 * "scene.yaml" without its temporary folder. The rows complement the cases of
 * test_scene.c: every top-level group, wrong types, NaN and infinity,
 * numbers followed by text or written with a leading zero, negative sizes,
 * unknown enum values, overlaps, spheres outside the domain, connections
 * naming missing spheres, bad --set paths, files that are empty, not YAML,
 * deeply nested or very large, and YAML aliases. Rows that were bugs of the
 * reader say so. */
#include "scene_harness.h"
#include "scene_tests.h"

#include "../../common/scene.h"

#include <CUnit/CUnit.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

typedef struct {
    int line;          /* > 0: this line of the base scene replaced by `text` */
    const char *text;  /* line == 0: the whole file (NULL: the base scene) */
    char *(*gen)(void); /* when not NULL: builds the whole file instead */
    const char *set[3];
    int nerrors;       /* exactly this many errors */
    const char *msg;   /* the first error, exactly */
} bad_scene_t;

/* ------------------------------------------------------------------------ */
/* Files too large to write out in the table.                               */

static char *repeat(const char *head, const char *unit, int n, const char *mid, const char *unit2, int n2,
                    const char *tail)
{
    size_t len = strlen(head) + strlen(unit) * (size_t)n + strlen(mid) + strlen(unit2) * (size_t)n2 + strlen(tail) + 1;
    char *out = malloc(len);
    CU_ASSERT_PTR_NOT_NULL_FATAL(out);
    char *p = out;
    p += sprintf(p, "%s", head);
    for (int i = 0; i < n; i++) {
        p += sprintf(p, "%s", unit);
    }
    p += sprintf(p, "%s", mid);
    for (int i = 0; i < n2; i++) {
        p += sprintf(p, "%s", unit2);
    }
    sprintf(p, "%s", tail);
    return out;
}

/* domain.size nested 5000 lists deep (at most 64 are read: SCENE_DEPTH_MAX). */
static char *deep_lists(void)
{
    return repeat("fluid: {density: 1000.0, viscosity: 1.0e-6, dx: 1.0e-4, tau: 1.0}\nrun: {end_time: 2.0}\n"
                  "domain: {size: ",
                  "[", 5000, "", "]", 5000, "}\n");
}

/* domain.size nested 100 000 lists deep and the contacts 100 000 mappings
 * deep (200 kB each): libyaml took 27 s to parse such a file (its scanner
 * costs the depth per token), then its emitter, which re-emits the tree,
 * overflowed the stack: a segmentation fault of `coupler check`. */
static char *deeper_lists(void)
{
    return repeat("fluid: {density: 1000.0, viscosity: 1.0e-6, dx: 1.0e-4, tau: 1.0}\nrun: {end_time: 2.0}\n"
                  "domain: {size: ",
                  "[", 100000, "", "]", 100000, "}\n");
}

static char *deeper_mappings(void)
{
    return repeat(MINIMAL "contacts: ", "{a: ", 100000, "1", "}", 100000, "\n");
}

/* 3000 mappings opened and never closed. */
static char *deep_unclosed(void)
{
    return repeat(MINIMAL "contacts: ", "{a: ", 3000, "", "", 0, "\n");
}

/* Two bodies of 400 spheres each, in the same place: 160 000 overlapping
 * pairs of spheres of different bodies. Spheres of one body may overlap, but
 * not coincide (scene_check_buried): a body's spheres are 1e-7 m apart in x. */
static char *many_overlapping_spheres(void)
{
    static const char head[] = MINIMAL "bodies:\n";
    static const char body[] = "  - {density: 2000.0, spheres: [";
    const size_t sphere_max = 64; /* one sphere's text */
    char *out = malloc(sizeof head + 2 * (sizeof body + 400 * sphere_max + 4));
    CU_ASSERT_PTR_NOT_NULL_FATAL(out);
    char *p = out + sprintf(out, "%s", head);
    for (int b = 0; b < 2; b++) {
        p += sprintf(p, "%s", body);
        for (int k = 0; k < 400; k++) {
            p += sprintf(p, "%s{center: [%.7e, 5.0e-4, 5.0e-4], radius: 2.0e-4}", k ? ", " : "", 5.0e-4 + 1e-7 * k);
        }
        p += sprintf(p, "]}\n");
    }
    return out;
}

/* ------------------------------------------------------------------------ */

static const bad_scene_t CASES[] = {
    /* --- files that are not a scene --- */
    {0, "# only a comment\n\n", NULL, {NULL}, 1,
     "scene.yaml: the scene is empty; allowed: a mapping with the keys domain, fluid, run (required) and bodies, "
     "connections, contacts, rigid"},
    {0, "42\n", NULL, {NULL}, 1,
     "scene.yaml: the top level is a scalar; allowed: a mapping with the keys domain, fluid, run (required) and "
     "bodies, connections, contacts, rigid"},
    {0, "domain:\n\tsize: [1, 1, 1]\n", NULL, {NULL}, 1,
     "scene.yaml:2:1: YAML syntax error: found character that cannot start any token (while scanning for the next "
     "token at line 2, column 1)"},
    {0, "\x01\x02\x03 binary\n", NULL, {NULL}, 1,
     "scene.yaml: cannot read at byte 0: control characters are not allowed"},
    {0, "domain: {size: [1, 1, 1]}\nfluid: \xff\xfe\n", NULL, {NULL}, 1,
     "scene.yaml: cannot read at byte 33: invalid leading UTF-8 octet"},
    {0, NULL, deep_lists, {NULL}, 1,
     "scene.yaml:3:78: YAML nested too deep: this list or mapping lies inside 64 others; allowed: at most 64 "
     "levels (a scene needs 6: bodies.0.spheres.0.center)"},
    {0, NULL, deeper_lists, {NULL}, 1,
     "scene.yaml:3:78: YAML nested too deep: this list or mapping lies inside 64 others; allowed: at most 64 "
     "levels (a scene needs 6: bodies.0.spheres.0.center)"},
    {0, NULL, deeper_mappings, {NULL}, 1,
     "scene.yaml:4:263: YAML nested too deep: this list or mapping lies inside 64 others; allowed: at most 64 "
     "levels (a scene needs 6: bodies.0.spheres.0.center)"},
    {0, NULL, deep_unclosed, {NULL}, 1,
     "scene.yaml:4:263: YAML nested too deep: this list or mapping lies inside 64 others; allowed: at most 64 "
     "levels (a scene needs 6: bodies.0.spheres.0.center)"},
    {0, MINIMAL "contacts: {a: {a: {a: {a: {a: \n", NULL, {NULL}, 1,
     "scene.yaml:5:1: YAML syntax error: did not find expected node content (while parsing a flow node at "
     "line 5, column 1)"},
    /* YAML aliases of lists and mappings expanded every walk over the tree
     * ("billion laughs": this file hung the reader; found while writing the
     * fuzz target, which did not reach it by itself in 10 minutes) */
    {0,
     "a0: &a0 [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n"
     "a1: &a1 [*a0, *a0, *a0, *a0, *a0, *a0, *a0, *a0, *a0, *a0]\n"
     "a2: [*a1, *a1, *a1, *a1, *a1, *a1, *a1, *a1, *a1, *a1]\n" MINIMAL,
     NULL, {NULL}, 1,
     "scene.yaml:1:5: YAML alias of a list: the list anchored here is used again through an alias (or inside "
     "itself); allowed: aliases of single values only (write the list out)"},
    {0, MINIMAL "bodies: &b [{density: 1.0, spheres: *b}]\n", NULL, {NULL}, 1,
     "scene.yaml:4:9: YAML alias of a list: the list anchored here is used again through an alias (or inside "
     "itself); allowed: aliases of single values only (write the list out)"},

    /* --- domain --- */
    {2, "  size: [-1.0e-3, 1.0e-3, 2.0e-3]", NULL, {NULL}, 1,
     "scene.yaml:2: domain.size = [-0.001, 0.001, 0.002]: the x extent is -0.001; allowed: each in (0, inf) m"},
    {2, "  size: [1.0e-3, .inf, 2.0e-3]", NULL, {NULL}, 1,
     "scene.yaml:2: domain.size.1: wrong type or value (libcyaml: Invalid FLOAT value: .inf); allowed: a "
     "number"},
    {2, "  size: {x: 1}", NULL, {NULL}, 1,
     "scene.yaml:2: domain.size: wrong type or value (libcyaml: Expecting SEQUENCE_FIXED, got event: "
     "MAPPING_START); allowed: a list of exactly 3 numbers"},
    {0, "domain: [1.0e-3, 1.0e-3, 1.0e-3]\nfluid: {density: 1000.0, viscosity: 1.0e-6, dx: 1.0e-4, tau: 1.0}\n"
        "run: {end_time: 2.0}\n",
     NULL, {NULL}, 1,
     "scene.yaml:1: domain: wrong type or value (libcyaml: Expecting MAPPING, got event: SEQUENCE_START); "
     "allowed: a mapping with the keys size (required), faces"},
    {4, "    w_min: {type: no_slip}", NULL, {NULL}, 1,
     "scene.yaml:4: domain.faces.w_min: unknown key (libcyaml: Unexpected key: w_min); allowed in "
     "domain.faces: a mapping with the keys x_min, x_max, y_min, y_max, z_min, z_max"},
    {0, NULL, NULL, {"domain.faces.x_min.type=Periodic"}, 1,
     "scene.yaml (--set domain.faces.x_min.type=Periodic): domain.faces.x_min.type: wrong type or value "
     "(libcyaml: Invalid ENUM value: Periodic); allowed: one of periodic | no_slip | free_slip | "
     "moving_wall | velocity_inlet | pressure_outlet"},
    {5, "    z_max: {type: moving_wall, velocity: fast}", NULL, {NULL}, 1,
     "scene.yaml:5: domain.faces.z_max.velocity: wrong type or value (libcyaml: Expecting SEQUENCE_FIXED, "
     "got event: SCALAR); allowed: a list of exactly 3 numbers"},
    {0, NULL, NULL, {"domain.faces.z_max={type: pressure_outlet, pressure: .nan}"}, 1,
     "scene.yaml (--set domain.faces.z_max={type: pressure_outlet, pressure: .nan}): domain.faces.z_max.pressure: "
     "wrong type or value (libcyaml: Invalid FLOAT value: .nan); allowed: a number"},
    /* said "allowed: [-inf, inf)" */
    {0, NULL, NULL, {"domain.faces.z_max={type: pressure_outlet, pressure: nan}"}, 1,
     "scene.yaml (--set domain.faces.z_max={type: pressure_outlet, pressure: nan}): domain.faces.z_max.pressure = "
     "nan: out of range; allowed: (-inf, inf)"},

    /* --- fluid --- */
    {0, NULL, NULL, {"fluid.viscosity=.inf"}, 1,
     "scene.yaml (--set fluid.viscosity=.inf): fluid.viscosity: wrong type or value (libcyaml: Invalid "
     "FLOAT value: .inf); allowed: a number"},
    {0, NULL, NULL, {"fluid.density=NaN"}, 1,
     "scene.yaml (--set fluid.density=NaN): fluid.density = nan: out of range; allowed: (0, inf)"},
    {10, "  dt: -1.0e-5", NULL, {NULL}, 1, "scene.yaml:10: fluid.dt = -1e-05: out of range; allowed: (0, inf)"},
    {10, "  dt: 1.0e-300", NULL, {NULL}, 1,
     "scene.yaml:10: fluid.dt = 1e-300 gives tau = 0.5 + 3 nu dt / dx^2 = 0.5; allowed: a dt for which tau is in "
     "(0.5, inf)"},
    /* dt = (tau - 1/2) dx^2 / (3 nu) underflowed to 0: the scene was refused for
     * "contacts.contact_time = 0" (its default, 10 dt), without a line or fluid.dx */
    {9, "  dx: 1.0e-300", NULL, {NULL}, 1,
     "scene.yaml:9: fluid.dx = 1e-300 m gives the step dt = (tau - 1/2) dx^2 / (3 nu) = 0 s with fluid.tau = 0.8 and "
     "fluid.viscosity = 1e-06 m^2/s, outside the steps a run can take, [2.22507385851e-308, 1.79769313486e+307] s; "
     "allowed: fluid.dx in [4.71706885524e-157, 1.34078079299e+151] m for this tau and viscosity"},
    {0, NULL, NULL, {"fluid={density: 1000.0, viscosity: 1.0e-6, dx: 1.0e-300, dt: 1.0e-5}"}, 1,
     "scene.yaml (--set fluid={density: 1000.0, viscosity: 1.0e-6, dx: 1.0e-300, dt: 1.0e-5}): fluid.dx = 1e-300 m "
     "gives dx^2 = 0 m^2, from which tau = 1/2 + 3 nu dt / dx^2 cannot be computed; allowed: fluid.dx in "
     "[1.49166814624e-154, 1.34078079299e+154] m"},
    {9, "  cells_per_radius: -2", NULL, {NULL}, 1,
     "scene.yaml:9: fluid.cells_per_radius = -2: out of range; allowed: [1.5, inf)"},
    /* the Mach limit of the fluid's check: (0, 1] (the lattice cannot carry Mach 1) */
    {0, NULL, NULL, {"fluid.mach_limit=0"}, 1,
     "scene.yaml (--set fluid.mach_limit=0): fluid.mach_limit = 0: out of range; allowed: (0, 1]"},
    {0, NULL, NULL, {"fluid.mach_limit=1.5"}, 1,
     "scene.yaml (--set fluid.mach_limit=1.5): fluid.mach_limit = 1.5: out of range; allowed: (0, 1]"},
    {0, NULL, NULL, {"fluid.collision=lbgk"}, 1,
     "scene.yaml (--set fluid.collision=lbgk): fluid.collision: wrong type or value (libcyaml: Invalid "
     "ENUM value: lbgk); allowed: one of bgk | trt | regularized"},
    {0, NULL, NULL, {"fluid.body_force=[0, 0, -.inf]"}, 1,
     "scene.yaml (--set fluid.body_force=[0, 0, -.inf]): fluid.body_force.2: wrong type or value (libcyaml: "
     "Invalid FLOAT value: -.inf); allowed: a number"},
    {0, NULL, NULL, {"fluid.body_force=[0, 0, -1e999]"}, 1,
     "scene.yaml (--set fluid.body_force=[0, 0, -1e999]): fluid.body_force = [0, 0, -inf]: component 2 is not a "
     "finite number; allowed: finite numbers"},
    /* numbers followed by more text were read in part: libcyaml 1.3 takes a
     * float with strtod and let the rest go ("1,000" loaded as 1, where
     * PyYAML reads a string) */
    {7, "  density: 1,000", NULL, {NULL}, 1,
     "scene.yaml:7: fluid.density: wrong type or value ('1,000' is not a number: ',000' follows '1'); allowed: a "
     "number such as 1000, -2.5 or 1.0e-3 (no units, digit separators or leading zeros)"},
    {0, NULL, NULL, {"fluid.tau=0.7 m"}, 1,
     "scene.yaml (--set fluid.tau=0.7 m): fluid.tau: wrong type or value ('0.7 m' is not a number: ' m' follows "
     "'0.7'); allowed: a number such as 1000, -2.5 or 1.0e-3 (no units, digit separators or leading zeros)"},
    {0, NULL, NULL, {"fluid.body_force=[0, 0, -9.81e3 N/m^3]"}, 1,
     "scene.yaml (--set fluid.body_force=[0, 0, -9.81e3 N/m^3]): fluid.body_force.2: wrong type or value ('-9.81e3 "
     "N/m^3' is not a number: ' N/m^3' follows '-9.81e3'); allowed: a number such as 1000, -2.5 or 1.0e-3 (no units, "
     "digit separators or leading zeros)"},
    {0, NULL, NULL, {"fluid.initial_velocity=[0, 0]"}, 1,
     "scene.yaml (--set fluid.initial_velocity=[0, 0]): fluid.initial_velocity: wrong type or value "
     "(libcyaml: Insufficient entries (2 of 3 min) in sequence.); allowed: a list of exactly 3 numbers"},

    /* --- bodies --- */
    {0, MINIMAL "bodies: {name: p1}\n", NULL, {NULL}, 1, 
     "scene.yaml:4: bodies: wrong type or value (libcyaml: Expecting SEQUENCE, got event: MAPPING_START); allowed: a "
     "list"},
    {0, NULL, NULL, {"bodies.0.spheres.0.radius=-1.0e-4"}, 1,
     "scene.yaml (--set bodies.0.spheres.0.radius=-1.0e-4): bodies.0.spheres.0.radius = -0.0001: out of range; "
     "allowed: (0, inf)"},
    {19, "    motion: frozen", NULL, {NULL}, 1,
     "scene.yaml:19: bodies.1.motion: wrong type or value (libcyaml: Invalid ENUM value: frozen); "
     "allowed: one of free | fixed | prescribed"},
    {12, "  - name: [p, 1]", NULL, {NULL}, 1,
     "scene.yaml:12: bodies.0.name: wrong type or value (libcyaml: Expecting STRING, got event: "
     "SEQUENCE_START); allowed: a string"},
    {13, "    colour: red", NULL, {NULL}, 1,
     "scene.yaml:13: bodies.0.colour: unknown key (libcyaml: Unexpected key: colour); allowed in "
     "bodies.0: a mapping with the keys name, density (required), motion, velocity, angular_velocity, "
     "move_with_flow, spheres (required)"},
    {18, "    mass: 1.0", NULL, {NULL}, 1,
     "scene.yaml:18: bodies.1.mass: unknown key (libcyaml: Unexpected key: mass); allowed in bodies.1: a "
     "mapping with the keys name, density (required), motion, velocity, angular_velocity, move_with_flow, "
     "spheres (required)"},
    {0, NULL, NULL, {"bodies.0.velocity=[nan, 0, 0]"}, 1,
     "scene.yaml (--set bodies.0.velocity=[nan, 0, 0]): bodies.0.velocity = [nan, 0, 0]: component 0 is not a "
     "finite number; allowed: finite numbers"},
    {21, "      - {center: [-1.0e-4, 2.0e-4, 1.5e-3], radius: 1.0e-4}", NULL, {NULL}, 1,
     "scene.yaml:21: bodies.1.spheres.0.center = [-0.0001, 0.0002, 0.0015] (sphere 2): the x coordinate -0.0001 is "
     "outside the periodic domain; allowed: x in [0, 0.001)"},
    {21, "      - {center: [2.0e-4, 2.0e-4, 2.5e-3], radius: 1.0e-4}", NULL, {NULL}, 1,
     "scene.yaml:21: bodies.1.spheres.0.center = [0.0002, 0.0002, 0.0025] with radius 0.0001 (sphere 2) reaches "
     "outside the walls along z: [0.0024, 0.0026]; allowed: z in [0.0001, 0.0019]"},
    {21, "      - {center: [8.4e-4, 5.0e-4, 5.0e-4], radius: 1.0e-4}", NULL, {NULL}, 1,
     "scene.yaml:21: bodies.1.spheres.0.center = [0.00084, 0.0005, 0.0005] (sphere 2, body 1) overlaps sphere 1 of "
     "body 0 at [0.00065, 0.0005, 0.0005]: centre distance 0.00019 m < sum of radii 0.0002 m; allowed: distance >= "
     "sum of radii for spheres of different bodies"},
    {2, "  size: [1.0e-3, 1.0e-3, 2.0e-3m]", NULL, {NULL}, 1,
     "scene.yaml:2: domain.size.2: wrong type or value ('2.0e-3m' is not a number: 'm' follows '2.0e-3'); allowed: "
     "a number such as 1000, -2.5 or 1.0e-3 (no units, digit separators or leading zeros)"},
    /* every bad number is reported, each on its line */
    {15, "      - {center: [5.0e-4, 5.0e-4, 5.0e-4], radius: 1.0e-4 m}\n      - {center: [6.5e-4, 5.0e-4 m, 5.0e-4], "
         "radius: 1.0e-4}",
     NULL, {NULL}, 2,
     "scene.yaml:15: bodies.0.spheres.0.radius: wrong type or value ('1.0e-4 m' is not a number: ' m' follows "
     "'1.0e-4'); allowed: a number such as 1000, -2.5 or 1.0e-3 (no units, digit separators or leading zeros)"},
    /* spheres buried in another of their body passed `coupler check`; the
     * rigid component refused them at start-up ("distance inf m", "-nan m") */
    {16, "      - {center: [5.2e-4, 5.0e-4, 5.0e-4], radius: 5.0e-5}", NULL, {NULL}, 1,
     "scene.yaml:16: bodies.0.spheres.1.center = [0.00052, 0.0005, 0.0005] (sphere 1, radius 5e-05 m, body 0) is "
     "buried in sphere 0 of the same body at [0.0005, 0.0005, 0.0005] (radius 0.0001 m): it lies entirely inside "
     "(centre distance 2e-05 m + radius 5e-05 m <= 0.0001 m), so it adds nothing to the body: remove it; allowed: "
     "centre distance > sqrt(R^2 - r^2) = 8.66025403784e-05 m, the plane where the surfaces meet between the centres "
     "(the rigid component splits the body's volume between its spheres there)"},
    {16, "      - {center: [5.0e-4, 5.0e-4, 5.0e-4], radius: 1.0e-4}", NULL, {NULL}, 1,
     "scene.yaml:16: bodies.0.spheres.1.center = [0.0005, 0.0005, 0.0005] (sphere 1, radius 0.0001 m, body 0) is "
     "buried in sphere 0 of the same body at [0.0005, 0.0005, 0.0005] (radius 0.0001 m): the two centres coincide, so "
     "it adds nothing to the body: remove it; allowed: centre distance > sqrt(R^2 - r^2) = 0 m, the plane where the "
     "surfaces meet between the centres (the rigid component splits the body's volume between its spheres there)"},
    /* logged n^2 messages: now the first 50 and one that counts the rest */
    {0, NULL, many_overlapping_spheres, {NULL}, 51,
     "scene.yaml:6: bodies.1.spheres.0.center = [0.0005, 0.0005, 0.0005] (sphere 400, body 1) overlaps sphere 0 of "
     "body 0 at [0.0005, 0.0005, 0.0005]: centre distance 0 m < sum of radii 0.0004 m; allowed: distance >= sum of "
     "radii for spheres of different bodies"},

    /* --- connections --- */
    {23, "  - {spheres: [0]}", NULL, {NULL}, 1,
     "scene.yaml:23: connections.0.spheres: wrong type or value (libcyaml: Insufficient entries (1 of 2 "
     "min) in sequence.); allowed: a list of exactly 2 numbers"},
    /* said "allowed: integers in [0, -1]" */
    {0, MINIMAL "connections: [{spheres: [0, 1]}]\n", NULL, {NULL}, 1,
     "scene.yaml:4: connections.0.spheres = [0, 1]: sphere index 0 does not exist; allowed: none, the scene has no "
     "spheres (connections join spheres of bodies)"},
    {0, NULL, NULL, {"connections.0.max_shear=.nan"}, 1,
     "scene.yaml (--set connections.0.max_shear=.nan): connections.0.max_shear: wrong type or value (libcyaml: "
     "Invalid FLOAT value: .nan); allowed: a number"},
    {0, NULL, NULL, {"connections.0.max_shear=-nan"}, 1,
     "scene.yaml (--set connections.0.max_shear=-nan): connections.0.max_shear = nan: out of range; allowed: [0, "
     "inf]"},
    /* 01 is octal in YAML 1.1 (PyYAML) and decimal in YAML 1.2; "1_000" was read as 1 */
    {23, "  - {spheres: [0, 01], max_normal: 1.0e-6}", NULL, {NULL}, 1,
     "scene.yaml:23: connections.0.spheres.1: wrong type or value ('01' has a leading zero: octal in YAML 1.1 and "
     "PyYAML, decimal in YAML 1.2); allowed: a number such as 1000, -2.5 or 1.0e-3 (no units, digit separators or "
     "leading zeros)"},
    {0, NULL, NULL, {"rigid.substeps=1_000"}, 1,
     "scene.yaml (--set rigid.substeps=1_000): rigid.substeps: wrong type or value ('1_000' is not a number: '_000' "
     "follows '1'); allowed: a number such as 1000, -2.5 or 1.0e-3 (no units, digit separators or leading zeros)"},
    {0, MINIMAL "connections: {spheres: [0, 1]}\n", NULL, {NULL}, 1, 
     "scene.yaml:4: connections: wrong type or value (libcyaml: Expecting SEQUENCE, got event: MAPPING_START); "
     "allowed: a "
     "list"},

    /* --- contacts --- */
    {24, "contacts: {model: linear}", NULL, {NULL}, 1,
     "scene.yaml:24: contacts.model: wrong type or value (libcyaml: Invalid ENUM value: linear); allowed: "
     "one of none | spring_dashpot | hertz"},
    {24, "contacts: {lubrication: {enabled: 2}}", NULL, {NULL}, 1,
     "scene.yaml:24: contacts.lubrication.enabled: wrong type or value (libcyaml: Invalid ENUM value: 2); "
     "allowed: one of true | false | yes | no | on | off"},
    {24, "contacts: [spring_dashpot]", NULL, {NULL}, 1,
     "scene.yaml:24: contacts: wrong type or value (libcyaml: Expecting MAPPING, got event: "
     "SEQUENCE_START); allowed: a mapping with the keys model, lubrication, restitution, contact_time, "
     "friction, young_modulus, poisson_ratio, stick_speed"},
    {0, NULL, NULL, {"contacts.young_modulus=-1e9"}, 1,
     "scene.yaml (--set contacts.young_modulus=-1e9): contacts.young_modulus = -1000000000: out of range; allowed: "
     "(0, inf)"},

    /* --- rigid --- */
    {25, "rigid: {integrator: CVODE}", NULL, {NULL}, 1,
     "scene.yaml:25: rigid.integrator: wrong type or value (libcyaml: Invalid ENUM value: CVODE); "
     "allowed: one of verlet | cvode"},
    {0, NULL, NULL, {"rigid.substeps=1e10"}, 1,
     "scene.yaml (--set rigid.substeps=1e10): rigid.substeps = 10000000000: not a whole number in range; allowed: "
     "an integer in [1, 2147483647]"},
    {25, "rigid: {gravity: [0, -9.81]}", NULL, {NULL}, 1,
     "scene.yaml:25: rigid.gravity: wrong type or value (libcyaml: Insufficient entries (2 of 3 min) in "
     "sequence.); allowed: a list of exactly 3 numbers"},
    {0, NULL, NULL, {"rigid.cvode_method=gear"}, 1,
     "scene.yaml (--set rigid.cvode_method=gear): rigid.cvode_method: wrong type or value (libcyaml: "
     "Invalid ENUM value: gear); allowed: one of adams | bdf"},
    {0, NULL, NULL, {"rigid.coupling=semi"}, 1,
     "scene.yaml (--set rigid.coupling=semi): rigid.coupling: wrong type or value (libcyaml: Invalid ENUM "
     "value: semi); allowed: one of auto | explicit | implicit"},

    /* --- run --- */
    {26, "run: {end_time: -1}", NULL, {NULL}, 1, "scene.yaml:26: run.end_time = -1: out of range; allowed: (0, inf)"},
    {26, "run: {end_time: .nan}", NULL, {NULL}, 1,
     "scene.yaml:26: run.end_time: wrong type or value (libcyaml: Invalid FLOAT value: .nan); allowed: a "
     "number"},
    {26, "run: {output_interval: 1.0}", NULL, {NULL}, 1,
     "scene.yaml:26: run.end_time: required key is missing (libcyaml: Missing required mapping field: "
     "end_time); allowed in run: a mapping with the keys end_time (required), output_interval, fields, "
     "field_interval, ranks"},
    {26, "run: 0.1", NULL, {NULL}, 1,
     "scene.yaml:26: run: wrong type or value (libcyaml: Expecting MAPPING, got event: SCALAR); allowed: "
     "a mapping with the keys end_time (required), output_interval, fields, field_interval, ranks"},

    /* steps beyond a long: `coupler check` printed "steps -9223372036854775808" and exited 0 */
    {26, "run: {end_time: 1.0e+15}", NULL, {NULL}, 1,
     "scene.yaml:26: run.end_time = 1e+15 s is 1.6e+19 steps of fluid.dt = 6.25e-05 s, more than a run can count; "
     "allowed: at most 9007199254740992 (2^53) steps, i.e. run.end_time <= 562949953421 s"},

    /* densities in (0, inf) whose body mass or moment of inertia is not a normal, finite number: they passed
       `coupler check`, and the run stopped at its first step with "fmi2SetReal: sphere[0].velocity.x (value
       reference 9) = -nan" from the fluid */
    {0, NULL, NULL, {"bodies.0.density=1e-308"}, 1,
     "scene.yaml (--set bodies.0.density=1e-308): bodies.0.density = 1e-308 kg/m^3 gives the body a mass of "
     "8.37737709088e-320 kg (volume 8.37758040957e-12 m^3) and moments of inertia between 0 and 0 kg m^2, below the "
     "smallest numbers the rigid component can divide by; allowed: a mass and moments of inertia in "
     "[2.22507385851e-308, 1.79769313486e+308], here a density in [1.32799313747e-288, 1.79769313486e+308] kg/m^3"},
    {0,
     "domain: {size: [10.0, 10.0, 10.0]}\nfluid: {density: 1000.0, viscosity: 1.0e-6, dx: 0.5, tau: 0.8}\n"
     "bodies:\n  - {density: 1.0e308, spheres: [{center: [5.0, 5.0, 5.0], radius: 2.0}]}\nrun: {end_time: 1.0e6}\n",
     NULL, {NULL}, 1,
     "scene.yaml:4: bodies.0.density = 1e+308 kg/m^3 gives the body a mass of inf kg (volume 33.5103216383 m^3) and "
     "moments of inertia between inf and inf kg m^2, beyond the numbers the rigid component can divide by; allowed: a "
     "mass and moments of inertia in [2.22507385851e-308, 1.79769313486e+308], here a density in "
     "[6.63996568736e-310, 1.11762401787e+305] kg/m^3"},

    /* run.ranks: a bad entry was named "run.ranks[0]", a key no other message or --set uses, so it was
       located at the file's run line even when the value came from --set */
    {0, NULL, NULL, {"run.ranks=[2, 0, 1]"}, 1,
     "scene.yaml (--set run.ranks=[2, 0, 1]): run.ranks.1 = 0: not a whole number in range; allowed: an integer in "
     "[1, 65536]"},
    {26, "run: {end_time: 2.0,\n      ranks: [1, 1, 1.5]}", NULL, {NULL}, 1,
     "scene.yaml:27: run.ranks.2 = 1.5: not a whole number in range; allowed: an integer in [1, 65536]"},

    /* an entry of a list the file does not have: "run.ranks has 0 entries (allowed: 0 to -1)" */
    {0, NULL, NULL, {"run.ranks.0=2"}, 1,
     "scene.yaml: override 'run.ranks.0=2': index 0 is out of range; run.ranks has no entries (entries are not "
     "created: set the whole list, run.ranks=[...])"},
    /* one coordinate from --set: the message named the file's line, which shows another value */
    {0, NULL, NULL, {"bodies.1.spheres.0.center.0=2.0e-3"}, 1,
     "scene.yaml (--set bodies.1.spheres.0.center.0=2.0e-3): bodies.1.spheres.0.center = [0.002, 0.0002, 0.0015] "
     "(sphere 2): the x coordinate 0.002 is outside the periodic domain; allowed: x in [0, 0.001)"},

    /* --- --set paths --- */
    {0, NULL, NULL, {"run.end_time.0=1"}, 1,
     "scene.yaml: override 'run.end_time.0=1': run.end_time is a number and has no key '0'"},
    {0, NULL, NULL, {"bodies.0.spheres.x=1"}, 1,
     "scene.yaml: override 'bodies.0.spheres.x=1': bodies.0.spheres is a list, so 'x' must be an index 0, 1, ..."},
    {0, NULL, NULL, {"connections.5.max_normal=1"}, 1,
     "scene.yaml: override 'connections.5.max_normal=1': index 5 is out of range; connections has 1 entries "
     "(allowed: 0 to 0)"},
    {0, NULL, NULL, {"domain.faces.q_min.type=no_slip"}, 1,
     "scene.yaml: override 'domain.faces.q_min.type=no_slip': unknown key 'q_min' in domain.faces; allowed: a "
     "mapping with the keys x_min, x_max, y_min, y_max, z_min, z_max"},
    {0, NULL, NULL, {".fluid.tau=1"}, 1,
     "scene.yaml: override '.fluid.tau=1': empty key component; allowed: keys joined by single dots"},
    {0, NULL, NULL, {"fluid.tau=1", "rigid.gravity.3=1"}, 1,
     "scene.yaml: override 'rigid.gravity.3=1': index 3 is out of range; rigid.gravity has 3 entries (allowed: 0 to "
     "2)"},
    {0, NULL, NULL, {"fluid.tau=[&a [1], *a]"}, 1,
     "scene.yaml: override 'fluid.tau=[&a [1], *a]': the value at 1:2: YAML alias of a list: the list anchored here "
     "is used again through an alias (or inside itself); allowed: aliases of single values only (write the list "
     "out)"},
    /* was reported as "out of memory" */
    {0, NULL, NULL, {"fluid.tau=[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[1]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]"}, 1,
     "scene.yaml: override 'fluid.tau=[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[1]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]': the "
     "value is "
     "nested more than 32 levels deep; allowed: a YAML value such as 1.5, cvode or [1, 2, 3]"},
};

/* ------------------------------------------------------------------------ */

typedef struct {
    char dir[32];
    char first[2048]; /* the first error, the temporary folder cut off */
    char last[2048];  /* the last error, the same way */
    int nerrors;
} bad_log_t;

static void bad_log(void *ctx, status_t level, const char *category, const char *msg)
{
    (void)category;
    bad_log_t *k = ctx;
    if (level < STATUS_ERROR) {
        return;
    }
    size_t n = strlen(k->dir);
    const char *shown = strncmp(msg, k->dir, n) == 0 && msg[n] == '/' ? msg + n + 1 : msg;
    if (k->nerrors++ == 0) {
        snprintf(k->first, sizeof k->first, "%s", shown);
    }
    snprintf(k->last, sizeof k->last, "%s", shown);
}

/* Loads row i, checks it, and leaves what was logged in *k. */
static void run_case(size_t i, bad_log_t *k)
{
    const bad_scene_t *b = &CASES[i];
    char *yaml = b->gen ? b->gen()
                 : b->line > 0 ? scene_test_base_with_line(b->line, b->text)
                               : strdup(b->text ? b->text : scene_test_base);
    CU_ASSERT_PTR_NOT_NULL_FATAL(yaml);
    *k = (bad_log_t){.dir = "/tmp/scene_bad_XXXXXX"};
    CU_ASSERT_PTR_NOT_NULL_FATAL(mkdtemp(k->dir));
    char path[64];
    snprintf(path, sizeof path, "%s/scene.yaml", k->dir);
    FILE *f = fopen(path, "w");
    CU_ASSERT_PTR_NOT_NULL_FATAL(f);
    CU_ASSERT_EQUAL(fputs(yaml, f) >= 0, 1);
    CU_ASSERT_EQUAL(fclose(f), 0);
    int nov = 0;
    while (nov < 3 && b->set[nov] != NULL) {
        nov++;
    }
    const log_t log = {bad_log, k};
    scene_t *s = (scene_t *)k; /* must be overwritten with NULL */
    status_t st = scene_load(path, b->set, nov, &log, &s);
    CU_ASSERT_EQUAL(unlink(path), 0);
    CU_ASSERT_EQUAL(rmdir(k->dir), 0);

    char what[4096];
    snprintf(what, sizeof what, "case %zu (%.60s%s): status %s, %d errors, first: \"%s\"; expected %d errors, first: "
             "\"%s\"", i, b->set[0] ? b->set[0] : b->text ? b->text : "generated", b->gen ? " generated" : "",
             status_name(st), k->nerrors, k->first, b->nerrors, b->msg);
    bool ok = st == STATUS_ERROR && s == NULL && k->nerrors == b->nerrors && strcmp(k->first, b->msg) == 0;
    CU_assertImplementation(ok ? CU_TRUE : CU_FALSE, __LINE__, what, __FILE__, "", CU_FALSE);
    if (st == STATUS_OK) {
        scene_free(s);
    }
    free(yaml);
}

static void test_bad_scene_table(void)
{
    CU_ASSERT(sizeof CASES / sizeof CASES[0] >= 30);
    for (size_t i = 0; i < sizeof CASES / sizeof CASES[0]; i++) {
        bad_log_t k;
        run_case(i, &k);
        if (CASES[i].gen == many_overlapping_spheres) {
            /* 2 x 400 spheres: 160 000 overlaps, the first 50 logged */
            CU_ASSERT_STRING_EQUAL(k.last, "scene.yaml: 159950 more messages not shown (159950 errors, 0 warnings); "
                                           "only the first 50 are");
        }
    }
}

/* Spheres that break a pairwise check n^2 times: only the first 50 messages
 * are logged, but every hidden one was still formatted (a dozen numbers
 * printed with %.12g each), so a body of 5000 coincident spheres took 35 s
 * to be refused and one of 20 000 more than a minute. Now the hidden ones are
 * only counted: 4000 coincident spheres of one body (8 M buried pairs) and
 * two bodies of 2000 spheres in one place (4 M overlapping pairs) are
 * refused in well under a second each (22 s and 10 s before). */
static char *spheres_in_one_place(int nbodies, int per_body, double step)
{
    static const char head[] = MINIMAL "bodies:\n";
    static const char body[] = "  - {density: 2000.0, spheres: [";
    const size_t sphere_max = 64;
    char *out = malloc(sizeof head + (size_t)nbodies * (sizeof body + (size_t)per_body * sphere_max + 4));
    CU_ASSERT_PTR_NOT_NULL_FATAL(out);
    char *p = out + sprintf(out, "%s", head);
    for (int b = 0; b < nbodies; b++) {
        p += sprintf(p, "%s", body);
        for (int k = 0; k < per_body; k++) {
            p += sprintf(p, "%s{center: [%.7e, 5.0e-4, 5.0e-4], radius: 2.0e-4}", k ? ", " : "", 5.0e-4 + step * k);
        }
        p += sprintf(p, "]}\n");
    }
    return out;
}

static double seconds_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void test_hidden_messages_are_only_counted(void)
{
    const struct {
        int nbodies, per_body;
        double step;
        long npairs;
        const char *first;
    } cases[] = {{1, 4000, 0.0, 4000L * 3999 / 2, "is buried in sphere 0 of the same body"},
                 {2, 2000, 1e-7, 2000L * 2000, "overlaps sphere 0 of body 0"}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char *yaml = spheres_in_one_place(cases[i].nbodies, cases[i].per_body, cases[i].step);
        bad_log_t k = {.dir = "/tmp/scene_bad_XXXXXX"};
        CU_ASSERT_PTR_NOT_NULL_FATAL(mkdtemp(k.dir));
        char path[64];
        snprintf(path, sizeof path, "%s/scene.yaml", k.dir);
        FILE *f = fopen(path, "w");
        CU_ASSERT_PTR_NOT_NULL_FATAL(f);
        CU_ASSERT_EQUAL(fputs(yaml, f) >= 0, 1);
        CU_ASSERT_EQUAL(fclose(f), 0);
        const log_t log = {bad_log, &k};
        scene_t *s = NULL;
        const double t0 = seconds_now();
        const status_t st = scene_load(path, NULL, 0, &log, &s);
        const double took = seconds_now() - t0;
        CU_ASSERT_EQUAL(unlink(path), 0);
        CU_ASSERT_EQUAL(rmdir(k.dir), 0);
        CU_ASSERT_EQUAL(st, STATUS_ERROR);
        CU_ASSERT_PTR_NULL(s);
        CU_ASSERT_EQUAL(k.nerrors, 51); /* 50 shown, one counting the rest */
        CU_ASSERT_PTR_NOT_NULL(strstr(k.first, cases[i].first));
        char rest[160];
        snprintf(rest, sizeof rest,
                 "scene.yaml: %ld more messages not shown (%ld errors, 0 warnings); only the first 50 are",
                 cases[i].npairs - 50, cases[i].npairs - 50);
        CU_ASSERT_STRING_EQUAL(k.last, rest);
        CU_ASSERT(took < 3.0);
        if (!(took < 3.0)) {
            fprintf(stderr, "\n  %d bodies of %d spheres in one place took %.1f s to be refused\n", cases[i].nbodies,
                    cases[i].per_body, took);
        }
        free(yaml);
    }
}

void scene_bad_register_tests(void)
{
    CU_pSuite s = CU_add_suite("scene: bad scenes table", NULL, NULL);
    if (s != NULL) {
        CU_add_test(s, "every row fails with its exact message", test_bad_scene_table);
        CU_add_test(s, "n^2 hidden messages are counted, not formatted", test_hidden_messages_are_only_counted);
    }
}
