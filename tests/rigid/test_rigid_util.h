/* test_rigid_util.h — helpers shared by the rigid tests: a default
 * configuration, a log sink that keeps the last message, relative errors. */
#ifndef TESTS_RIGID_UTIL_H
#define TESTS_RIGID_UTIL_H

#include "../../rigid/rigid.h"

#include <CUnit/CUnit.h>
#include <math.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

typedef struct {
    char last[2048];
    int nerr;
} test_log_t;

static inline void test_log_fn(void *ctx, status_t level, const char *cat, const char *msg)
{
    test_log_t *t = ctx;
    (void)cat;
    if (level >= STATUS_ERROR) {
        t->nerr++;
        snprintf(t->last, sizeof t->last, "%s", msg);
    }
}

static inline rigid_config_t test_cfg(int ns, const rigid_sphere_cfg_t *s, int nb, const rigid_body_cfg_t *b, int nc,
                                      const rigid_connection_cfg_t *c)
{
    rigid_config_t cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.nspheres = ns;
    cfg.spheres = s;
    cfg.nbodies = nb;
    cfg.bodies = b;
    cfg.nconnections = nc;
    cfg.connections = c;
    cfg.contact_model = RIGID_CONTACT_NONE;
    cfg.restitution = 1.0;
    cfg.integrator = RIGID_VERLET;
    cfg.rtol = 1e-8;
    cfg.atol = 1e-12;
    cfg.substeps = 1;
    return cfg;
}

static inline double rel_err(double a, double b) { return fabs(a - b) / fmax(fabs(b), 1e-300); }

static inline double vec_norm(const double a[3]) { return sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]); }

static inline double vec_dist(const double a[3], const double b[3])
{
    double d[3] = {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
    return vec_norm(d);
}

#endif
