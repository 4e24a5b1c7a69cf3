/* test_scene_refused.c — the scene reader (common/scene.c) on bad input:
 * files and YAML, values and their consistency. The reference for every
 * case is the scene format in models/README.md (and issues 2 and 3, "Bad
 * input"): each must fail with *out == NULL, write nothing, and give one
 * message naming the file, the key, the value and the allowed range
 * (scene_harness.h). The table of bad scenes is test_scene_bad.c. */
#include "scene_harness.h"
#include "scene_tests.h"

#include <CUnit/CUnit.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------ */
/* Bad input: files and YAML.                                               */

static void test_missing_file(void)
{
    EXPECT_ERROR(NULL, NULL, 0, "scene.yaml: cannot open the scene file: No such file or directory");
}

static void test_syntax_error(void)
{
    EXPECT_LINE_ERROR(10, "  tau: [0.8", "scene.yaml:", "YAML syntax error", "flow sequence at line 10, column 8");
    EXPECT_LINE_ERROR(10, "  tau: 0.8\n   dt: 1", "scene.yaml:11:6: YAML syntax error",
                      "mapping values are not allowed", "error");
}

static void test_empty_and_multi_document(void)
{
    EXPECT_ERROR("", NULL, 0, "scene.yaml: the scene is empty");
    EXPECT_ERROR("- 1\n- 2\n", NULL, 0, "scene.yaml: the top level is a list", "allowed: a mapping");
    char two[4096];
    CU_ASSERT_FATAL(snprintf(two, sizeof two, "%s---\na: 1\n", BASE) < (int)sizeof two);
    EXPECT_ERROR(two, NULL, 0, "scene.yaml: more than one YAML document");
}

/* libcyaml's schema checks, reported with the dotted key and line. */
static void test_unknown_key(void)
{
    EXPECT_LINE_ERROR(10, "  tau: 0.8\n  visc: 2", "scene.yaml:11: fluid.visc: unknown key",
                      "allowed in fluid: a mapping with the keys density (required), viscosity (required), dx",
                      "libcyaml: Unexpected key: visc");
    EXPECT_LINE_ERROR(16, "      - {center: [6.5e-4, 5.0e-4, 5.0e-4], radius: 1.0e-4, colour: red}",
                      "scene.yaml:16: bodies.0.spheres.1.colour: unknown key",
                      "allowed in bodies.0.spheres.1: a mapping with the keys center (required), radius (required)",
                      "error");
    EXPECT_LINE_ERROR(26, "run: {end_time: 0.1}\nextra: 1", "scene.yaml:27: extra: unknown key",
                      "allowed in the top level", "domain (required)");
}

static void test_missing_key(void)
{
    EXPECT_LINE_ERROR(8, "", "scene.yaml:6: fluid.viscosity: required key is missing", "allowed in fluid",
                      "viscosity (required)");
    EXPECT_LINE_ERROR(21, "      - {center: [2.0e-4, 2.0e-4, 1.5e-3]}",
                      "scene.yaml:21: bodies.1.spheres.0.radius: required key is missing", "radius (required)",
                      "error");
    EXPECT_LINE_ERROR(26, "", "scene.yaml: run: required key is missing", "run (required)", "error");
}

static void test_wrong_type(void)
{
    EXPECT_LINE_ERROR(13, "    density: [2000]", "scene.yaml:13: bodies.0.density: wrong type or value",
                      "got event: SEQUENCE_START", "allowed: a number");
    EXPECT_LINE_ERROR(7, "  density: heavy", "scene.yaml:7: fluid.density: wrong type or value",
                      "Invalid FLOAT value: heavy", "allowed: a number");
    EXPECT_LINE_ERROR(2, "  size: [1.0e-3, 1.0e-3]", "scene.yaml:2: domain.size: wrong type or value",
                      "allowed: a list of exactly 3 numbers", "error");
    EXPECT_LINE_ERROR(25, "rigid: {integrator: rk4}", "scene.yaml:25: rigid.integrator: wrong type or value",
                      "rk4", "allowed: one of verlet | cvode");
    EXPECT_LINE_ERROR(4, "    z_min: {type: wall}", "scene.yaml:4: domain.faces.z_min.type",
                      "allowed: one of periodic | no_slip | free_slip | moving_wall | velocity_inlet | pressure_outlet",
                      "wall");
    EXPECT_SET_ERROR("bodies.1.spheres=[]", "bodies.1.spheres: wrong type or value",
                     "allowed: a list of at least 1 entries");
    EXPECT_LINE_ERROR(10, "  tau: 0.8\n  density: 1.0", "scene.yaml:11: fluid.density: key given twice",
                      "allowed: each key once", "error");
    EXPECT_SET_ERROR("run.fields=maybe", "run.fields: wrong type or value", "allowed: one of true | false | yes | no | on | off");
    EXPECT_SET_ERROR("fluid=3", "fluid: wrong type or value", "allowed: a mapping with the keys density");
    {
        char *yaml = scene_test_base_with_line(4, "    z_min: {type: free_slip}");
        const char *const ov[] = {"fluid.initial_profile=plane_channel"};
        EXPECT_ERROR(yaml, ov, 1, "fluid.initial_profile", "= plane_channel needs exactly one axis bounded by two walls",
                     "allowed otherwise: uniform");
        free(yaml);
    }
}

static void test_bad_override(void)
{
    EXPECT_SET_ERROR("fluid.visc=1", "override 'fluid.visc=1': unknown key 'visc' in fluid",
                     "allowed: a mapping with the keys density");
    EXPECT_SET_ERROR("flud.tau=1", "override 'flud.tau=1': unknown key 'flud'", "allowed");
    EXPECT_SET_ERROR("fluid.tau", "override 'fluid.tau': expected KEY=VALUE");
    EXPECT_SET_ERROR("=1", "override '=1': expected KEY=VALUE");
    EXPECT_SET_ERROR("fluid..tau=1", "override 'fluid..tau=1': empty key component");
    EXPECT_SET_ERROR("fluid.tau=", "override 'fluid.tau=': the value is empty");
    EXPECT_SET_ERROR("fluid.tau=[1", "override 'fluid.tau=[1': the value is not YAML", "YAML syntax error");
    EXPECT_SET_ERROR("bodies.2.density=1", "override 'bodies.2.density=1': index 2 is out of range",
                     "bodies has 2 entries (allowed: 0 to 1)");
    EXPECT_SET_ERROR("bodies.first.density=1", "bodies is a list, so 'first' must be an index");
    EXPECT_SET_ERROR("fluid.tau.x=1", "fluid.tau is a number and has no key 'x'");
    const char *const ov[] = {"fluid.tau=3"};
    EXPECT_ERROR("fluid: 3\ndomain: {size: [1, 1, 1]}\nrun: {end_time: 1}\n", ov, 1,
                 "override 'fluid.tau=3': fluid is a scalar in the file, not a mapping");
}

/* Numbers must be numbers as a whole (common/scene_check.c, "Numbers as
 * written"): libcyaml reads a float with strtod and used to take the number
 * at the start of "1,000" (1), "0.7 m", "1_000" or "0o17" (0) and drop the
 * rest. Every number-valued key of models/README.md, scalars and items of
 * vectors and lists, from --set and from the file. */
static void test_number_as_written(void)
{
    static const char *const keys[] = {
        "domain.size.0", "domain.faces.z_max.velocity.0", "fluid.density", "fluid.viscosity", "fluid.dx",
        "fluid.tau", "fluid.magic", "fluid.mach_limit", "bodies.0.density", "bodies.0.spheres.1.center.2",
        "bodies.0.spheres.0.radius", "connections.0.spheres.1", "connections.0.max_normal", "contacts.contact_time",
        "rigid.gravity.2",
    };
    static const char *const bad[][2] = {
        /* value, then what the message says of it */
        {"1,000", "('1,000' is not a number: ',000' follows '1')"},
        {"0.7 m", "('0.7 m' is not a number: ' m' follows '0.7')"},
        {"0.7abc", "('0.7abc' is not a number: 'abc' follows '0.7')"},
        {"1_000", "('1_000' is not a number: '_000' follows '1')"},
        {"0o17", "('0o17' is not a number: 'o17' follows '0')"},
        {"017", "('017' has a leading zero: octal in YAML 1.1 and PyYAML, decimal in YAML 1.2)"},
        {"1:30", "('1:30' is not a number: ':30' follows '1')"},
        {"0x1p3", "('0x1p3' is not a number: 'p3' follows '0x1')"},
        {"'1.5 '", "('1.5 ' is not a number: ' ' follows '1.5')"},
    };
    const char *allowed =
        "allowed: a number such as 1000, -2.5 or 1.0e-3 (no units, digit separators or leading zeros)";
    char set[128], want[256];
    for (size_t k = 0; k < sizeof keys / sizeof keys[0]; k++) {
        for (size_t v = 0; v < sizeof bad / sizeof bad[0]; v++) {
            snprintf(set, sizeof set, "%s=%s", keys[k], bad[v][0]);
            snprintf(want, sizeof want, "scene.yaml (--set %s): %s: wrong type or value %s", set, keys[k], bad[v][1]);
            EXPECT_SET_ERROR(set, want, allowed);
        }
    }
    /* keys the base scene does not have, created by the override */
    static const char *const created[][2] = {
        {"domain.faces.x_min.pressure=2 Pa", "domain.faces.x_min.pressure"},
        {"fluid.cells_per_radius=4x", "fluid.cells_per_radius"},
        {"fluid.dt=1e-5s", "fluid.dt"},
        {"fluid.body_force=[0, 0, 1e3N]", "fluid.body_force.2"},
        {"fluid.initial_velocity=[0, 1.5.0, 0]", "fluid.initial_velocity.1"},
        {"bodies.1.velocity=[0, 0, 1m]", "bodies.1.velocity.2"},
        {"bodies.1.angular_velocity=[0x, 0, 0]", "bodies.1.angular_velocity.0"},
        {"connections.0.max_shear=1e-6N", "connections.0.max_shear"},
        {"connections.0.max_torque=2%", "connections.0.max_torque"},
        {"contacts.restitution=0.9.1", "contacts.restitution"},
        {"contacts.friction=0,3", "contacts.friction"},
        {"contacts.young_modulus=1e9Pa", "contacts.young_modulus"},
        {"contacts.poisson_ratio=.3.", "contacts.poisson_ratio"},
        {"contacts.stick_speed=1e-3/s", "contacts.stick_speed"},
        {"contacts.lubrication.cutoff=2cells", "contacts.lubrication.cutoff"},
        {"contacts.lubrication.min_gap=1e-7 m", "contacts.lubrication.min_gap"},
        {"rigid.rtol=1e-8!", "rigid.rtol"},
        {"rigid.atol=1e-12?", "rigid.atol"},
        {"rigid.substeps=1_0", "rigid.substeps"},
        {"run.end_time=0.1s", "run.end_time"},
        {"run.output_interval=1e-3 s", "run.output_interval"},
        {"run.field_interval=5e-3 s", "run.field_interval"},
        {"run.ranks=[1, 1, 2x]", "run.ranks.2"},
    };
    for (size_t i = 0; i < sizeof created / sizeof created[0]; i++) {
        snprintf(want, sizeof want, "scene.yaml (--set %s): %s: wrong type or value", created[i][0], created[i][1]);
        EXPECT_SET_ERROR(created[i][0], want, "is not a number", allowed);
    }
    /* from the file: located by line; every bad number is reported */
    static const char yaml[] = "domain: {size: [1.0e-3, 1.0e-3, 1.0e-3]}\n"
                               "fluid:\n"
                               "  density: 1,000\n"
                               "  viscosity: 1.0e-6 m^2/s\n"
                               "  dx: 1.0e-4\n"
                               "  tau: 1.0\n"
                               "run: {end_time: 2.0}\n";
    EXPECT_N_ERRORS(2, yaml, NULL, 0, "scene.yaml:3: fluid.density: wrong type or value ('1,000' is not a number",
                    "scene.yaml:4: fluid.viscosity: wrong type or value ('1.0e-6 m^2/s' is not a number: "
                    "' m^2/s' follows '1.0e-6')");
}

/* ------------------------------------------------------------------------ */
/* Bad input: values and consistency.                                       */

static void test_out_of_range(void)
{
    /* key=value, then the expected "KEY = VALUE: out of range; allowed: RANGE" */
    static const char *const cases[][2] = {
        {"fluid.density=0", "fluid.density = 0: out of range; allowed: (0, inf)"},
        {"fluid.viscosity=-1e-6", "fluid.viscosity = -1e-06: out of range; allowed: (0, inf)"},
        {"fluid.dx=0", "fluid.dx = 0: out of range; allowed: (0, inf)"},
        {"fluid.tau=0.5", "fluid.tau = 0.5: out of range; allowed: (0.5, inf)"},
        {"fluid.tau=0.3", "fluid.tau = 0.3: out of range; allowed: (0.5, inf)"},
        {"fluid.magic=0", "fluid.magic = 0: out of range; allowed: (0, inf)"},
        {"fluid.density=nan", "fluid.density = nan: out of range"},
        {"fluid.density=1e400", "fluid.density = inf: out of range; allowed: (0, inf)"},
        {"domain.size=[1e-3, 0, 2e-3]", "domain.size = [0.001, 0, 0.002]: the y extent is 0; allowed: each in (0, inf)"},
        {"bodies.0.density=-1", "bodies.0.density = -1: out of range; allowed: (0, inf)"},
        {"bodies.0.spheres.1.radius=0", "bodies.0.spheres.1.radius = 0: out of range; allowed: (0, inf)"},
        {"connections.0.max_normal=-1", "connections.0.max_normal = -1: out of range; allowed: [0, inf]"},
        {"connections.0.max_torque=-1e-12", "connections.0.max_torque = -1e-12: out of range; allowed: [0, inf]"},
        {"contacts.restitution=0", "contacts.restitution = 0: out of range; allowed: (0, 1]"},
        {"contacts.restitution=1.01", "contacts.restitution = 1.01: out of range; allowed: (0, 1]"},
        {"contacts.contact_time=0", "contacts.contact_time = 0: out of range; allowed: (0, inf)"},
        {"contacts.friction=-0.1", "contacts.friction = -0.1: out of range; allowed: [0, inf)"},
        {"contacts.young_modulus=0", "contacts.young_modulus = 0: out of range; allowed: (0, inf)"},
        {"contacts.poisson_ratio=0.5", "contacts.poisson_ratio = 0.5: out of range; allowed: [0, 0.5)"},
        {"contacts.poisson_ratio=-0.1", "contacts.poisson_ratio = -0.1: out of range; allowed: [0, 0.5)"},
        {"contacts.stick_speed=-1", "contacts.stick_speed = -1: out of range; allowed: [0, inf)"},
        {"rigid.rtol=0", "rigid.rtol = 0: out of range; allowed: (0, 1)"},
        {"rigid.rtol=1", "rigid.rtol = 1: out of range; allowed: (0, 1)"},
        {"rigid.atol=-1e-12", "rigid.atol = -1e-12: out of range; allowed: (0, inf)"},
        {"rigid.substeps=0", "rigid.substeps = 0: not a whole number in range; allowed: an integer in [1, 2147483647]"},
        {"rigid.substeps=2.5", "rigid.substeps = 2.5: not a whole number in range; allowed: an integer in [1,"},
        {"run.end_time=0", "run.end_time = 0: out of range; allowed: (0, inf)"},
        {"run.output_interval=-1", "run.output_interval = -1: out of range; allowed: (0, inf)"},
        {"run.field_interval=0", "run.field_interval = 0: out of range; allowed: (0, inf)"},
        {"rigid.gravity=[0, 0, nan]", "rigid.gravity = [0, 0, nan]: component 2 is not a finite number"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char where[128];
        snprintf(where, sizeof where, "scene.yaml (--set %s): ", cases[i][0]);
        EXPECT_SET_ERROR(cases[i][0], where, cases[i][1]);
    }
    /* Located by line when the value comes from the file. */
    EXPECT_LINE_ERROR(10, "  tau: 0.4", "scene.yaml:10: fluid.tau = 0.4: out of range; allowed: (0.5, inf)",
                      "error", "error");
    EXPECT_LINE_ERROR(24, "contacts: {model: hertz, poisson_ratio: 0.7}",
                      "scene.yaml:24: contacts.poisson_ratio = 0.7: out of range; allowed: [0, 0.5)", "error",
                      "error");
}

static void test_resolution_exclusive(void)
{
    EXPECT_SET_ERROR("fluid.cells_per_radius=4", "fluid.dx: both fluid.dx and fluid.cells_per_radius are given",
                     "allowed: exactly one of fluid.dx (m) and fluid.cells_per_radius");
    EXPECT_LINE_ERROR(9, "", "scene.yaml:6: fluid: neither fluid.dx nor fluid.cells_per_radius is given",
                      "allowed: exactly one of fluid.dx", "error");
    EXPECT_SET_ERROR("fluid.dt=1e-5", "fluid.tau: both fluid.tau and fluid.dt are given",
                     "allowed: exactly one of fluid.tau and fluid.dt");
    EXPECT_LINE_ERROR(10, "", "scene.yaml:6: fluid: neither fluid.tau nor fluid.dt is given",
                      "allowed: exactly one of fluid.tau and fluid.dt", "error");
    const char *const ov[] = {"fluid={density: 1000.0, viscosity: 1.0e-6, cells_per_radius: 4, tau: 1}"};
    EXPECT_ERROR(MINIMAL, ov, 1, "fluid.cells_per_radius = 4: needs at least one sphere in bodies",
                 "allowed: give fluid.dx instead");
    const char *const ov2[] = {"fluid={density: 1000.0, viscosity: 1.0e-6, cells_per_radius: 1.2, tau: 1}"};
    EXPECT_ERROR(BASE, ov2, 1, "fluid.cells_per_radius = 1.2: out of range; allowed: [1.5, inf)");
}

/* dt = (tau - 1/2) dx^2 / (3 nu) underflowed to 0 for fluid.dx = 1e-300 m and
 * the scene was refused for "contacts.contact_time = 0: out of range", the
 * default 10 dt, a key the file did not have; now the key that set dx is
 * named with the range that keeps dx^2 and dt usable (DBL_MIN to DBL_MAX / 10
 * for dt: sqrt(DBL_MIN / k) to sqrt(DBL_MAX / 10 / k) for dx, k = (tau - 1/2)
 * / (3 nu) = 1e5 s/m^2 in the base scene). */
static void test_step_underflow(void)
{
    EXPECT_SET_ERROR("fluid.dx=1e-300",
                     "scene.yaml (--set fluid.dx=1e-300): fluid.dx = 1e-300 m gives the step dt = (tau - 1/2) dx^2 "
                     "/ (3 nu) = 0 s with fluid.tau = 0.8",
                     "allowed: fluid.dx in [4.71706885524e-157, 1.34078079299e+151] m for this tau and viscosity");
    EXPECT_SET_ERROR("fluid.dx=1e200", "fluid.dx = 1e+200 m gives the step dt = (tau - 1/2) dx^2 / (3 nu) = inf s");
    const char *const cpr[] = {"fluid={density: 1000.0, viscosity: 1.0e-6, cells_per_radius: 1e300, tau: 0.8}"};
    EXPECT_ERROR(BASE, cpr, 1, "fluid.cells_per_radius = 1e+300 gives fluid.dx = 1e-304 m and the step dt",
                 "allowed: fluid.cells_per_radius in [1.5, 2.11996057443e+152] for this tau and viscosity");
    capture_t *cap = malloc(sizeof *cap);
    CU_ASSERT_PTR_NOT_NULL_FATAL(cap);
    scene_t *s = NULL;
    const char *const dx[] = {"fluid.dx=1e-300"};
    CU_ASSERT_EQUAL(scene_test_load(BASE, dx, 1, cap, &s), STATUS_ERROR);
    CU_ASSERT_EQUAL(cap->nerrors, 1);
    CU_ASSERT_PTR_NULL(strstr(cap->text, "contact_time"));
    free(cap);
}

static void test_not_divisible(void)
{
    EXPECT_SET_ERROR("domain.size=[1e-3, 1e-3, 2.01e-3]",
                     "domain.size = [0.001, 0.001, 0.00201]: the z extent 0.00201 m is 80.4 cells of fluid.dx = "
                     "2.5e-05 m; allowed: a whole number (>= 1) of cells (relative tolerance 1e-09)");
    EXPECT_SET_ERROR("fluid.dx=3e-5", "domain.size = [0.001, 0.001, 0.002]: the x extent 0.001 m is 33.3333333333 cells");
    /* within the relative tolerance 1e-9: accepted */
    capture_t cap;
    scene_t *s = NULL;
    const char *const ov[] = {"domain.size=[1.0000000000001e-3, 1e-3, 2e-3]"};
    CU_ASSERT_EQUAL(scene_test_load(BASE, ov, 1, &cap, &s), STATUS_OK);
    CU_ASSERT_PTR_NOT_NULL(s);
    scene_free(s);
}

static void test_faces(void)
{
    EXPECT_SET_ERROR("domain.faces.x_min.type=no_slip",
                     "domain.faces.x_min.type = no_slip, but x_max is periodic; allowed: periodic on both x_min and "
                     "x_max, or on neither");
    EXPECT_SET_ERROR("domain.faces.z_max.type=periodic", "domain.faces.z_min.type = no_slip, but z_max is periodic");
    EXPECT_SET_ERROR("domain.faces.z_max.velocity=[1e-3, 0, 1e-4]",
                     "domain.faces.z_max.velocity = [0.001, 0, 0.0001]: a moving wall moves in its own plane, but "
                     "the normal (z) component is 0.0001; allowed: z component = 0");
    EXPECT_SET_ERROR("domain.faces.z_min={type: velocity_inlet, velocity: [0, 0, -1e-3], profile: parabolic}",
                     "domain.faces.z_min.velocity = [0, 0, -0.001]: an inlet on z_min must point into the domain; "
                     "allowed: z component > 0");
    EXPECT_SET_ERROR("domain.faces.z_max={type: velocity_inlet, velocity: [0, 0, 1e-3]}",
                     "domain.faces.z_max.velocity = [0, 0, 0.001]: an inlet on z_max must point into the domain; "
                     "allowed: z component < 0");
    EXPECT_SET_ERROR("domain.faces.z_max={type: moving_wall}",
                     "domain.faces.z_max.velocity: required for a moving_wall face but missing");
    EXPECT_LINE_ERROR(5, "    z_max: {type: moving_wall, velocity: [1.0e-3, 0, 2]}", "scene.yaml:5: ",
                      "domain.faces.z_max.velocity = [0.001, 0, 2]", "allowed: z component = 0");
}

static void test_connections(void)
{
    EXPECT_SET_ERROR("connections.0.spheres=[0, 3]",
                     "connections.0.spheres = [0, 3]: sphere index 3 does not exist; allowed: integers in [0, 2]");
    EXPECT_SET_ERROR("connections.0.spheres=[-1, 1]", "sphere index -1 does not exist");
    EXPECT_SET_ERROR("connections.0.spheres=[0.5, 1]", "sphere index 0.5 does not exist");
    EXPECT_SET_ERROR("connections.0.spheres=[1, 1]",
                     "connections.0.spheres = [1, 1]: a sphere cannot be connected to itself; allowed: two different");
    /* a neck joins spheres of one body; the rigid FMU refused this at
     * initialisation, after `coupler check` had passed it */
    EXPECT_SET_ERROR("connections.0.spheres=[1, 2]",
                     "connections.0.spheres = [1, 2]: sphere 1 (body 0) and sphere 2 (body 1) belong to different "
                     "bodies; allowed: two spheres of one body (bodies.0 has spheres 0 to 1)");
    EXPECT_SET_ERROR("connections=[{spheres: [0, 1]}, {spheres: [1, 0]}]",
                     "connections.1.spheres = [1, 0]: the pair is already connected by connections.0");
    EXPECT_LINE_ERROR(23, "  - {spheres: [0, 9], max_normal: 1.0e-6}", "scene.yaml:23: connections.0.spheres = [0, 9]",
                      "allowed: integers in [0, 2]", "the scene has 3 spheres");
}

static void test_spheres_in_domain(void)
{
    /* z has walls: the sphere must be fully inside */
    EXPECT_SET_ERROR("bodies.1.spheres.0.center=[2e-4, 2e-4, 1.95e-3]",
                     "bodies.1.spheres.0.center = [0.0002, 0.0002, 0.00195] with radius 0.0001 (sphere 2) reaches "
                     "outside the walls along z: [0.00185, 0.00205]; allowed: z in [0.0001, 0.0019]");
    EXPECT_SET_ERROR("bodies.0.spheres.0.center=[5e-4, 5e-4, 5e-5]", "reaches outside the walls along z",
                     "allowed: z in [0.0001, 0.0019]");
    /* wider than the walls are apart: no centre fits (the message gave the empty range [r, L - r]) */
    EXPECT_SET_ERROR("bodies.1.spheres.0.radius=1.1e-3",
                     "diameter 0.0022 m exceeds the distance 0.002 m between the walls along z; allowed: radius <= "
                     "0.001 m");
    /* x is periodic: only the centre must be inside */
    EXPECT_SET_ERROR("bodies.1.spheres.0.center=[1.2e-3, 2e-4, 1.5e-3]",
                     "bodies.1.spheres.0.center = [0.0012, 0.0002, 0.0015] (sphere 2): the x coordinate 0.0012 is "
                     "outside the periodic domain; allowed: x in [0, 0.001)");
    EXPECT_SET_ERROR("bodies.1.spheres.0.radius=6e-4", "diameter 0.0012 m exceeds the periodic length 0.001 m");
    capture_t cap;
    scene_t *s = NULL;
    const char *const ov[] = {"bodies.1.spheres.0.center=[0, 0, 1.5e-3]"}; /* cut by two periodic faces: fine */
    CU_ASSERT_EQUAL(scene_test_load(BASE, ov, 1, &cap, &s), STATUS_OK);
    CU_ASSERT_PTR_NOT_NULL(s);
    scene_free(s);
    EXPECT_LINE_ERROR(21, "      - {center: [2.0e-4, 2.0e-4, 1.95e-3], radius: 1.0e-4}",
                      "scene.yaml:21: bodies.1.spheres.0.center", "reaches outside the walls", "error");
}

static void test_overlap(void)
{
    EXPECT_SET_ERROR("bodies.1.spheres.0.center=[6e-4, 6e-4, 6e-4]",
                     "bodies.1.spheres.0.center = [0.0006, 0.0006, 0.0006] (sphere 2, body 1) overlaps sphere 0 of "
                     "body 0",
                     "allowed: distance >= sum of radii for spheres of different bodies");
    /* nearest periodic image: x = 0.95e-3 is 0.1e-3 from x = 0.05e-3 */
    const char *const ov[] = {"bodies.0.spheres=[{center: [0.5e-4, 5e-4, 5e-4], radius: 1e-4}]",
                              "bodies.1.spheres.0.center=[9.5e-4, 5e-4, 5e-4]", "connections=[]"};
    EXPECT_ERROR(BASE, ov, 3, "overlaps sphere 0 of body 0", "centre distance 0.0001 m < sum of radii 0.0002 m");
    /* spheres of one body may overlap (sintered): the base scene has that */
}

/* A sphere buried in another sphere of its own body (entirely inside, its
 * centre beyond the plane where their surfaces meet, or coinciding) passed
 * `coupler check` and was refused by the rigid component at start-up
 * ("distance inf m", "-nan m"): the rigid component splits a body's volume at
 * that plane and needs it between the centres, d > sqrt(R^2 - r^2)
 * (rigid/body.c). Body 0 of the base scene: sphere 0 at x = 5e-4 m, radius
 * 1e-4 m; sphere 1 replaced. */
static void test_buried_spheres(void)
{
    EXPECT_SET_ERROR("bodies.0.spheres.1={center: [5.2e-4, 5e-4, 5e-4], radius: 5e-5}",
                     "bodies.0.spheres.1.center = [0.00052, 0.0005, 0.0005] (sphere 1, radius 5e-05 m, body 0) is "
                     "buried in sphere 0 of the same body at [0.0005, 0.0005, 0.0005] (radius 0.0001 m): it lies "
                     "entirely inside (centre distance 2e-05 m + radius 5e-05 m <= 0.0001 m), so it adds nothing to "
                     "the body: remove it; allowed: centre distance > sqrt(R^2 - r^2) = 8.66025403784e-05 m");
    EXPECT_SET_ERROR("bodies.0.spheres.1.center=[5e-4, 5e-4, 5e-4]",
                     "bodies.0.spheres.1.center = [0.0005, 0.0005, 0.0005] (sphere 1, radius 0.0001 m, body 0) is "
                     "buried in sphere 0 of the same body at [0.0005, 0.0005, 0.0005] (radius 0.0001 m): the two "
                     "centres coincide", "allowed: centre distance > sqrt(R^2 - r^2) = 0 m");
    /* sticking out, but the centre beyond the plane; the smaller sphere is named, here the first */
    EXPECT_SET_ERROR("bodies.0.spheres.0={center: [5.7e-4, 5e-4, 5e-4], radius: 5e-5}",
                     "bodies.0.spheres.0.center = [0.00057, 0.0005, 0.0005] (sphere 0, radius 5e-05 m, body 0) is "
                     "buried in sphere 1 of the same body at [0.00065, 0.0005, 0.0005] (radius 0.0001 m): its centre "
                     "lies beyond the plane where the two surfaces meet (centre distance 8e-05 m); allowed: centre "
                     "distance > sqrt(R^2 - r^2) = 8.66025403784e-05 m");
    /* across the periodic x face: the nearest image, 3e-5 m away */
    const char *const across[] = {"bodies.0.spheres=[{center: [0.2e-4, 5e-4, 5e-4], radius: 1e-4}, "
                                  "{center: [9.9e-4, 5e-4, 5e-4], radius: 5e-5}]"};
    EXPECT_ERROR(BASE, across, 1, "bodies.0.spheres.1.center = [0.00099, 0.0005, 0.0005] (sphere 1, radius 5e-05 m, "
                 "body 0) is buried in sphere 0", "centre distance 3e-05 m + radius 5e-05 m <= 0.0001 m");
    /* just beyond the limit: sintered, loads (as the rigid component takes it) */
    capture_t cap;
    scene_t *s = NULL;
    const char *const ok[] = {"bodies.0.spheres.1={center: [5.87e-4, 5e-4, 5e-4], radius: 5e-5}"};
    CU_ASSERT_EQUAL(scene_test_load(BASE, ok, 1, &cap, &s), STATUS_OK);
    CU_ASSERT_EQUAL(cap.nerrors, 0);
    scene_free(s);
}

static void test_radius_cells(void)
{
    EXPECT_SET_ERROR("bodies.0.spheres.1.radius=3e-5",
                     "bodies.0.spheres.1.radius = 3e-05 m is 1.2 cells of fluid.dx = 2.5e-05 m (sphere 1); allowed: "
                     "at least 1.5 cells = 3.75e-05 m");
    capture_t cap;
    scene_t *s = NULL;
    const char *const ov[] = {"bodies.0.spheres.1.radius=3.75e-5"}; /* exactly 1.5 cells: accepted */
    CU_ASSERT_EQUAL(scene_test_load(BASE, ov, 1, &cap, &s), STATUS_OK);
    CU_ASSERT_PTR_NOT_NULL(s);
    scene_free(s);
}

static void test_prescribed_speed(void)
{
    const char *const ov[] = {"bodies.0.motion=prescribed", "bodies.0.angular_velocity=[0, 0, 2000]"};
    EXPECT_ERROR(BASE, ov, 2, "bodies.0.velocity = [0, 0, 0] with angular velocity [0, 0, 2000]",
                 "cells per step; allowed: at most 0.5 cells per step = 0.2 m/s");
}

/* A run's steps ceil(run.end_time / fluid.dt) are counted in longs and
 * multiplied back by dt in double: at most SCENE_STEPS_MAX = 2^53 (scene.h).
 * run.end_time = 1e15 s gave a step count beyond a long (`coupler check`
 * printed -9223372036854775808 steps and exited 0). The base scene's dt is
 * 62500 ns: 2^53 steps are 5.63e11 s. */
static void test_run_length(void)
{
    EXPECT_SET_ERROR("run.end_time=1e15",
                     "scene.yaml (--set run.end_time=1e15): run.end_time = 1e+15 s is 1.6e+19 steps of fluid.dt = "
                     "6.25e-05 s, more than a run can count; allowed: at most 9007199254740992 (2^53) steps, i.e. "
                     "run.end_time <= 562949953421 s");
    EXPECT_SET_ERROR("run.end_time=5.7e11", "run.end_time = 570000000000 s is 9.12e+15 steps");
    /* within the limit: loads, and the count fits */
    capture_t cap;
    scene_t *s = NULL;
    const char *const ok[] = {"run.end_time=5.6e11", "run.output_interval=1e-4"};
    CU_ASSERT_EQUAL_FATAL(scene_test_load(BASE, ok, 2, &cap, &s), STATUS_OK);
    CU_ASSERT(ceil(s->run.end_time / s->fluid.dt - 1e-9) <= (double)SCENE_STEPS_MAX);
    CU_ASSERT_EQUAL((long)ceil(s->run.end_time / s->fluid.dt - 1e-9), 8960000000000000L);
    scene_free(s);
}

/* All violations are reported, not only the first. */
static void test_many_errors(void)
{
    const char *const ov[] = {"fluid.tau=0.4", "bodies.0.density=0", "contacts.friction=-1"};
    EXPECT_N_ERRORS(3, BASE, ov, 3, "fluid.tau = 0.4", "bodies.0.density = 0", "contacts.friction = -1");
}

void scene_refused_register_tests(void)
{
    static const struct {
        const char *name;
        CU_TestFunc fn;
    } bad[] = {
        {"missing file", test_missing_file},
        {"YAML syntax error", test_syntax_error},
        {"empty and multi-document", test_empty_and_multi_document},
        {"unknown key", test_unknown_key},
        {"missing key", test_missing_key},
        {"wrong type", test_wrong_type},
        {"bad override", test_bad_override},
        {"numbers as a whole", test_number_as_written},
        {"out of range", test_out_of_range},
        {"dx/cells_per_radius, tau/dt", test_resolution_exclusive},
        {"step underflow names fluid.dx", test_step_underflow},
        {"domain not divisible by dx", test_not_divisible},
        {"faces", test_faces},
        {"connections", test_connections},
        {"spheres in domain", test_spheres_in_domain},
        {"overlapping bodies", test_overlap},
        {"sphere buried in its own body", test_buried_spheres},
        {"radius in cells", test_radius_cells},
        {"prescribed speed", test_prescribed_speed},
        {"run length countable", test_run_length},
        {"many errors", test_many_errors},
    };
    CU_pSuite s = CU_add_suite("scene: bad input", NULL, NULL);
    if (s == NULL) {
        return;
    }
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        if (CU_add_test(s, bad[i].name, bad[i].fn) == NULL) {
            return;
        }
    }
}
