/* test_util.h — helpers shared by the fluid tests: scenes built in code in
 * lattice-like SI units (dx = 1 m, dt = 1 s, density 1 kg/m^3), so that SI
 * and lattice values coincide and the references read as in the papers. */
#ifndef TESTS_FLUID_TEST_UTIL_H
#define TESTS_FLUID_TEST_UTIL_H

#include "../../common/scene.h"
#include "../../fluid/fluid.h"

/* A periodic box of nx*ny*nz cells with relaxation time tau. */
/* The precision of the scenes test_box makes (the reports' precision= option). */
extern precision_t test_box_precision;
/* TRT magic parameter of test_box (sphere_report drag magic=...; 3/16 unless set) */
extern double test_box_magic;
/* The population layout of test_box (sphere_report drag streaming=...; in place unless set) */
extern streaming_t test_box_streaming;
scene_t test_box(int nx, int ny, int nz, double tau, collision_t collision);
/* Creates the fluid or fails the current test; NULL on failure. */
fluid_t *test_fluid(const scene_t *s);
/* Runs n steps. */
void test_run(fluid_t *fl, long n);
/* Log sink that keeps the last message (for tests of error paths). */
typedef struct {
    char last[2048];
    int count;
    status_t worst;
} test_log_t;
log_t test_log(test_log_t *t);

#endif
