/* test_util.c — see test_util.h. */
#include "test_util.h"

#include <CUnit/CUnit.h>
#include <stdio.h>
#include <string.h>

precision_t test_box_precision = PRECISION_DOUBLE;
double test_box_magic = 3.0 / 16.0;
streaming_t test_box_streaming = STREAMING_IN_PLACE;

scene_t test_box(int nx, int ny, int nz, double tau, collision_t collision)
{
    scene_t s;
    memset(&s, 0, sizeof s);
    s.path = "test-scene";
    s.domain.size[0] = nx;
    s.domain.size[1] = ny;
    s.domain.size[2] = nz;
    for (int f = 0; f < 6; f++) {
        s.domain.faces[f].type = FACE_PERIODIC;
    }
    s.fluid.density = 1.0;
    s.fluid.dx = 1.0;
    s.fluid.tau = tau;
    s.fluid.viscosity = (tau - 0.5) / 3.0;
    s.fluid.dt = 1.0;
    s.fluid.collision = collision;
    s.fluid.magic = test_box_magic;
    s.fluid.precision = test_box_precision;
    s.fluid.streaming = test_box_streaming;
    s.run.end_time = 1.0;
    s.run.output_interval = 1.0;
    return s;
}

static void keep_last(void *ctx, status_t level, const char *category, const char *msg)
{
    test_log_t *t = ctx;
    snprintf(t->last, sizeof t->last, "[%s] %s", category, msg);
    t->count++;
    if (level > t->worst) {
        t->worst = level;
    }
}

log_t test_log(test_log_t *t)
{
    memset(t, 0, sizeof *t);
    log_t l = {keep_last, t};
    return l;
}

fluid_t *test_fluid(const scene_t *s)
{
    fluid_t *fl = NULL;
    log_t l = {log_stderr, NULL};
    status_t st = fluid_create(s, &l, &fl);
    CU_ASSERT_EQUAL_FATAL(st, STATUS_OK);
    return fl;
}

void test_run(fluid_t *fl, long n)
{
    for (long i = 0; i < n; i++) {
        fluid_step(fl);
    }
}
