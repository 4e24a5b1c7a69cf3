/* test_fmi_vars.c — the FMUs' variable lists (fluid_fmi_model.variables,
 * rigid_fmi_model.variables) for scenes of 1 to 70 spheres and 0 to 69
 * connections, so that the list grows (and may move: realloc) between any
 * two variables that are added together: every variable must come out with
 * its description and with the sphere or connection index and the axis its
 * name says. A pointer kept across an add and written after the list moved
 * (sphere[i].drag_coefficient and its rotational twin, rigid.momentum and
 * rigid.angular_momentum did) leaves the moved copy blank: index 0, axis 0,
 * no description, and the coupled run read the wrong quantity. */
#include "scene_tests.h"

#include "../../common/fmi_adapter.h"
#include "../../common/scene.h"

#include <CUnit/CUnit.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static void quiet(void *ctx, status_t level, const char *category, const char *msg)
{
    (void)ctx;
    (void)level;
    (void)category;
    (void)msg;
}

/* A chain of n spheres of radius 2 cells, touching, in one free body, with
 * n - 1 connections (connections: 0 for none), in a periodic box. */
static scene_t *chain_scene(int n, int connections)
{
    char path[] = "/tmp/fmi_vars_XXXXXX";
    const int fd = mkstemp(path);
    CU_ASSERT_FATAL(fd >= 0);
    FILE *f = fdopen(fd, "w");
    CU_ASSERT_PTR_NOT_NULL_FATAL(f);
    fprintf(f, "domain: {size: [%.17g, 4.0e-4, 4.0e-4]}\n", 4.0e-5 * (n + 2));
    fprintf(f, "fluid: {density: 1000.0, viscosity: 1.0e-6, dx: 1.0e-5, tau: 0.8}\n");
    fprintf(f, "bodies:\n  - name: chain\n    density: 2000.0\n    spheres:\n");
    for (int i = 0; i < n; i++) {
        fprintf(f, "      - {center: [%.17g, 2.0e-4, 2.0e-4], radius: 2.0e-5}\n", 4.0e-5 * (i + 1));
    }
    if (connections && n > 1) {
        fprintf(f, "connections:\n");
        for (int i = 0; i + 1 < n; i++) {
            fprintf(f, "  - {spheres: [%d, %d]}\n", i, i + 1);
        }
    }
    fprintf(f, "run: {end_time: 1.0e-3}\n");
    CU_ASSERT_EQUAL_FATAL(fclose(f), 0);
    const log_t log = {quiet, NULL};
    scene_t *s = NULL;
    const status_t st = scene_load(path, NULL, 0, &log, &s);
    unlink(path);
    CU_ASSERT_FATAL(st < STATUS_ERROR && s != NULL);
    return s;
}

/* Every variable of the list: a description, and for names "kind[i]...c"
 * the index i and the axis (or component) of the last letter x, y, z. Returns the number
 * of variables that fail. */
static int blank_variables(const fmi_vars_t *vs)
{
    int bad = 0;
    for (int k = 0; k < vs->n; k++) {
        const fmi_var_t *v = &vs->v[k];
        int ok = v->description[0] != '\0';
        const char *br = strchr(v->name, '[');
        if (br != NULL) {
            ok = ok && atoi(br + 1) == v->index;
        }
        const size_t len = strlen(v->name);
        if (len > 2 && v->name[len - 2] == '.' && strchr("xyz", v->name[len - 1]) != NULL) {
            /* a vector parameter names its element of the scene key (component),
             * an input or output its axis */
            ok = ok && (v->component >= 0 ? v->component : v->axis) == v->name[len - 1] - 'x';
        }
        if (!ok) {
            fprintf(stderr, "variable %d %s: description \"%s\", index %d, axis %d\n", k, v->name, v->description,
                    v->index, v->axis);
            bad++;
        }
    }
    return bad;
}

static void test_every_variable_keeps_its_description_index_and_axis(void)
{
    const log_t log = {quiet, NULL};
    int lists = 0;
    for (int n = 1; n <= 70; n++) {
        for (int c = 0; c <= 1; c++) {
            scene_t *s = chain_scene(n, c);
            const fmi_model_t *models[2] = {&fluid_fmi_model, &rigid_fmi_model};
            for (int m = 0; m < 2; m++) {
                fmi_vars_t vs;
                memset(&vs, 0, sizeof vs);
                CU_ASSERT_EQUAL_FATAL(models[m]->variables(s, &log, &vs), STATUS_OK);
                CU_ASSERT(vs.n > 0);
                const int bad = blank_variables(&vs);
                if (bad != 0) {
                    fprintf(stderr, "%s FMU, %d spheres, %s connections: %d variables blank\n", models[m]->identifier,
                            n, c ? "with" : "without", bad);
                }
                CU_ASSERT_EQUAL(bad, 0);
                fmi_vars_free(&vs);
                lists++;
            }
            scene_free(s);
        }
    }
    CU_ASSERT_EQUAL(lists, 280);
}

void fmi_vars_register_tests(void)
{
    CU_pSuite s = CU_add_suite("fmi_vars", NULL, NULL);
    CU_add_test(s, "every variable keeps its description, index and axis",
                test_every_variable_keeps_its_description_index_and_axis);
}
