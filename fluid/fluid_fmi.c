/* fluid_fmi.c — the fluid component as an FMI 2.0 Co-Simulation FMU: the
 * mapping between value references and the native API (fluid.h). The FMI
 * entry points, call-order checks and logging are common/fmi_adapter.c.
 *
 * Variables (SI, structured names, global sphere index i: bodies in scene
 * order, their spheres in order):
 *   parameters  fluid.density, fluid.viscosity, fluid.tau (or fluid.dt when
 *               the scene gives dt), fluid.body_force.x|y|z
 *   inputs      sphere[i].position|velocity|angular_velocity.x|y|z, only for
 *               spheres of free bodies (the fluid moves fixed and prescribed
 *               spheres itself); start values are the scene's initial state
 *   outputs     sphere[i].force|torque.x|y|z for every sphere: the
 *               hydrodynamic force and the torque about the sphere centre of
 *               the last LBM step (averaged when fluid.force_averaging is set)
 * A communication step h must be a whole number k of LBM steps dt (within
 * 1e-9 relative). The inputs are held over the step (zero-order hold): a
 * free sphere stays where its position input puts it for all k LBM steps,
 * with the surface velocity of its velocity inputs. */
#include "../common/fmi_adapter.h"
#include "fluid.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

enum { Q_POSITION, Q_VELOCITY, Q_ANGULAR_VELOCITY, Q_FORCE, Q_TORQUE, Q_PARAMETER };

static const char *const AXIS = "xyz";

typedef struct {
    fluid_t *fl;
    int ns;
    double *kin;            /* per sphere: c[3], v[3], w[3] */
    unsigned char *is_free; /* per sphere: set from inputs */
} fluid_fmi_t;

static status_t oom(const log_t *log)
{
    return log_msg(log, STATUS_FATAL, "fluid", "out of memory");
}

static status_t add_vector(fmi_vars_t *vs, fmi_causality_t causality, int what, int sphere, const char *quantity,
                           const char *unit, const double start[3], const char *desc, const log_t *log)
{
    for (int a = 0; a < 3; a++) {
        fmi_var_t *v = fmi_vars_add(vs, FMI_REAL, causality, unit, "sphere[%d].%s.%c", sphere, quantity, AXIS[a]);
        if (v == NULL) {
            return oom(log);
        }
        snprintf(v->description, sizeof v->description, "%s of sphere %d, %c component", desc, sphere, AXIS[a]);
        v->what = what;
        v->index = sphere;
        v->axis = a;
        v->start = start != NULL ? start[a] : 0.0;
    }
    return STATUS_OK;
}

static status_t fluid_variables(const scene_t *s, const log_t *log, fmi_vars_t *out)
{
    fmi_vars_t vs = {0};
    status_t st = STATUS_OK;
    const double inf = INFINITY;
    const int has_dt = fmi_scene_has_key(s->text, "fluid", "dt") == 1;
    const scene_fluid_t *f = &s->fluid;
    if (!fmi_vars_param(&vs, "fluid.density", "fluid.density", -1, "kg/m3", f->density, 0.0, inf, FMI_LO_OPEN,
                        "fluid density") ||
        !fmi_vars_param(&vs, "fluid.viscosity", "fluid.viscosity", -1, "m2/s", f->viscosity, 0.0, inf, FMI_LO_OPEN,
                        "kinematic viscosity") ||
        !(has_dt ? fmi_vars_param(&vs, "fluid.dt", "fluid.dt", -1, "s", f->dt, 0.0, inf, FMI_LO_OPEN,
                                  "LBM time step (sets tau)")
                 : fmi_vars_param(&vs, "fluid.tau", "fluid.tau", -1, NULL, f->tau, 0.5, inf, FMI_LO_OPEN,
                                  "BGK/TRT relaxation time (sets the LBM time step)"))) {
        st = oom(log);
        goto done;
    }
    for (int a = 0; a < 3; a++) {
        char name[40], desc[60];
        snprintf(name, sizeof name, "fluid.body_force.%c", AXIS[a]);
        snprintf(desc, sizeof desc, "body force per volume driving the fluid, %c component", AXIS[a]);
        if (!fmi_vars_param(&vs, name, "fluid.body_force", a, "N/m3", f->body_force[a], -inf, inf, 0, desc)) {
            st = oom(log);
            goto done;
        }
    }
    /* inputs: spheres of free bodies, initial kinematics of the scene; the
     * centre of mass is the r^3-weighted mean of the centres (one density
     * per body, as fluid and rigid compute it) */
    for (int b = 0, i = 0; b < s->nbodies; b++) {
        const scene_body_t *body = &s->bodies[b];
        double com[3] = {0, 0, 0}, vol = 0.0;
        for (int k = 0; k < body->nspheres; k++) {
            const double r3 = pow(body->spheres[k].radius, 3.0);
            for (int a = 0; a < 3; a++) {
                com[a] += r3 * body->spheres[k].center[a];
            }
            vol += r3;
        }
        for (int k = 0; k < body->nspheres; k++, i++) {
            if (body->motion != MOTION_FREE) {
                continue;
            }
            const double *c = body->spheres[k].center, *v = body->velocity, *w = body->angular_velocity;
            double rel[3], vs_[3];
            for (int a = 0; a < 3; a++) {
                rel[a] = c[a] - com[a] / vol;
            }
            vs_[0] = v[0] + w[1] * rel[2] - w[2] * rel[1];
            vs_[1] = v[1] + w[2] * rel[0] - w[0] * rel[2];
            vs_[2] = v[2] + w[0] * rel[1] - w[1] * rel[0];
            if ((st = add_vector(&vs, FMI_INPUT, Q_POSITION, i, "position", "m", c, "centre position", log)) ||
                (st = add_vector(&vs, FMI_INPUT, Q_VELOCITY, i, "velocity", "m/s", vs_, "centre velocity", log)) ||
                (st = add_vector(&vs, FMI_INPUT, Q_ANGULAR_VELOCITY, i, "angular_velocity", "rad/s", w,
                                 "angular velocity", log))) {
                goto done;
            }
        }
    }
    const int ns = scene_total_spheres(s);
    for (int i = 0; i < ns; i++) {
        if ((st = add_vector(&vs, FMI_OUTPUT, Q_FORCE, i, "force", "N", NULL, "hydrodynamic force", log)) ||
            (st = add_vector(&vs, FMI_OUTPUT, Q_TORQUE, i, "torque", "N.m", NULL,
                             "hydrodynamic torque about the centre", log))) {
            goto done;
        }
    }
done:
    if (st != STATUS_OK) {
        fmi_vars_free(&vs);
    }
    *out = vs;
    return st;
}

static void fluid_fmi_free(void *comp)
{
    fluid_fmi_t *m = comp;
    if (m == NULL) {
        return;
    }
    fluid_free(m->fl);
    free(m->kin);
    free(m->is_free);
    free(m);
}

static status_t fluid_fmi_create(const scene_t *s, double t0, const log_t *log, void **comp)
{
    (void)t0; /* the fluid counts steps from 0; the adapter keeps FMU time */
    *comp = NULL;
    fluid_fmi_t *m = calloc(1, sizeof *m);
    if (m == NULL) {
        return oom(log);
    }
    m->ns = scene_total_spheres(s);
    m->kin = calloc(9 * (size_t)m->ns + 1, sizeof(double));
    m->is_free = calloc((size_t)m->ns + 1, 1);
    if (m->kin == NULL || m->is_free == NULL) {
        fluid_fmi_free(m);
        return oom(log);
    }
    status_t st = fluid_create(s, log, &m->fl);
    if (st >= STATUS_ERROR) {
        m->fl = NULL;
        fluid_fmi_free(m);
        return st;
    }
    *comp = m;
    return st;
}

static status_t fluid_fmi_check_step(void *comp, double h, const log_t *log)
{
    const fluid_fmi_t *m = comp;
    const double dt = fluid_units(m->fl)->dt;
    const double k = nearbyint(h / dt);
    if (k < 1.0 || fabs(h - k * dt) > 1e-9 * h) {
        return log_msg(log, STATUS_ERROR, "fluid",
                       "communication step %.17g s is not a whole number of LBM steps dt = %.17g s (h/dt = %.9g); "
                       "allowed: k * dt with k = 1, 2, ...",
                       h, dt, h / dt);
    }
    return STATUS_OK;
}

static status_t fluid_fmi_step(void *comp, const fmi_vars_t *vars, const double *values, double t, double h,
                               const log_t *log)
{
    (void)t;
    fluid_fmi_t *m = comp;
    for (int j = 0; j < vars->n; j++) {
        const fmi_var_t *v = &vars->v[j];
        if (v->causality == FMI_INPUT) {
            m->kin[9 * v->index + 3 * v->what + v->axis] = values[j];
            m->is_free[v->index] = 1;
        }
    }
    status_t st = STATUS_OK;
    for (int i = 0; i < m->ns; i++) {
        if (m->is_free[i]) {
            const double *k = &m->kin[9 * i];
            st = status_worst(st, fluid_set_sphere(m->fl, i, k, k + 3, k + 6));
            if (st >= STATUS_ERROR) {
                return st;
            }
        }
    }
    const long steps = (long)nearbyint(h / fluid_units(m->fl)->dt);
    for (long n = 0; n < steps; n++) {
        st = status_worst(st, fluid_step(m->fl));
        if (st >= STATUS_ERROR) {
            return log_msg(log, st, "fluid", "LBM step %ld of %ld in this communication step failed", n + 1, steps);
        }
    }
    return st;
}

static void fluid_fmi_outputs(void *comp, const fmi_vars_t *vars, double *values)
{
    const fluid_fmi_t *m = comp;
    for (int j = 0; j < vars->n; j++) {
        const fmi_var_t *v = &vars->v[j];
        if (v->causality == FMI_OUTPUT) {
            double f[3], tq[3];
            fluid_sphere_load(m->fl, v->index, f, tq);
            values[j] = v->what == Q_FORCE ? f[v->axis] : tq[v->axis];
        }
    }
}

static size_t fluid_fmi_state_size(void *comp)
{
    return fluid_state_size(((fluid_fmi_t *)comp)->fl);
}

static status_t fluid_fmi_state_save(void *comp, void *buf, size_t size)
{
    return fluid_state_save(((fluid_fmi_t *)comp)->fl, buf, size);
}

static status_t fluid_fmi_state_restore(void *comp, const void *buf, size_t size)
{
    return fluid_state_restore(((fluid_fmi_t *)comp)->fl, buf, size);
}

const fmi_model_t fluid_fmi_model = {
    .identifier = "fluid",
    .description = "Lattice Boltzmann (D3Q19) fluid with moving spheres: per-sphere kinematics in, "
                   "hydrodynamic force and torque out",
    .can_variable_step = 1,
    .variables = fluid_variables,
    .create = fluid_fmi_create,
    .free = fluid_fmi_free,
    .check_step = fluid_fmi_check_step,
    .step = fluid_fmi_step,
    .outputs = fluid_fmi_outputs,
    .state_size = fluid_fmi_state_size,
    .state_save = fluid_fmi_state_save,
    .state_restore = fluid_fmi_state_restore,
};
