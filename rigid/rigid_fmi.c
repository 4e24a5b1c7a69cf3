/* rigid_fmi.c — the rigid component as an FMI 2.0 Co-Simulation FMU: the
 * mapping between value references and the native API (rigid.h). The scene
 * -> rigid_config_t translation is rigid_config_from_scene (rigid_scene.c);
 * the FMI entry points, call-order checks and logging are the generic layer's
 * (common/fmi_adapter.c, common/fmi_internal.h).
 *
 * What the FMU covers: the rigid component is built from every body of the
 * scene; fixed and prescribed bodies enter as fixed bodies (obstacles for
 * contacts; a prescribed body moves there with its prescribed motion, as the
 * fluid moves it, rigid_scene.c). Only spheres of free bodies have
 * variables. Variables (SI, structured names, global sphere index i: bodies
 * in scene order, their spheres in order; k: index in the scene's
 * connections list):
 *   parameters  rigid.gravity.x|y|z, rigid.substeps, rigid.rtol, rigid.atol,
 *               fluid.density (buoyancy)
 *   inputs      sphere[i].force|torque.x|y|z (hydrodynamic; start 0)
 *               sphere[i].drag_coefficient (kg/s), .rotational_drag_coefficient
 *               (kg.m2/s), only when rigid.coupling = implicit (start 0)
 *   outputs     sphere[i].position|velocity|angular_velocity.x|y|z,
 *               sphere[i].applied_force|applied_torque.x|y|z (implicit
 *               coupling or a rigid.release_time only: the hydrodynamic load
 *               that acted over the last step, the input plus its drag
 *               response to the step's velocity change, zero while held;
 *               what the master records as the sphere's load)
 *               sphere[i].body (Integer: the current body id; ids start as
 *               the scene body index and change when bodies split or merge)
 *               connection[k].force|torque.x|y|z, connection[k].intact
 *               rigid.bodies (Integer: number of moving bodies),
 *               rigid.momentum.x|y|z, rigid.angular_momentum.x|y|z (totals
 *               over the moving bodies, the latter about the world origin:
 *               the balances of break-up and sticking)
 * Connections created when bodies stick (beyond the scene's list) are not
 * exposed. A scene without free bodies needs no rigid FMU (variables()
 * answers STATUS_DISCARD). fmi2DoStep(h) is rigid_step(h) with any h > 0. */
#include "../common/coupling.h"
#include "../common/fmi_adapter.h"
#include "rigid.h"

#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

enum {
    Q_FORCE,
    Q_TORQUE,
    Q_POSITION,
    Q_VELOCITY,
    Q_ANGULAR_VELOCITY,
    Q_CONN_FORCE,
    Q_CONN_TORQUE,
    Q_CONN_INTACT,
    Q_BODY,
    Q_NBODIES,
    Q_MOMENTUM,
    Q_ANGULAR_MOMENTUM,
    Q_DRAG,
    Q_ROTATIONAL_DRAG,
    Q_APPLIED_FORCE,
    Q_APPLIED_TORQUE
};

static const char *const AXIS = "xyz";

typedef struct {
    rigid_t *r;
    int ns;
    double *load; /* per sphere: force[3], torque[3] */
    double *drag; /* per sphere: zt, zr (implicit coupling) */
} rigid_fmi_t;

/* An allocation failed: what it was for and its size. */
static status_t oom(const log_t *log, const char *what, size_t bytes)
{
    return log_msg(log, STATUS_FATAL, "rigid", "out of memory for %s (%zu bytes)", what, bytes);
}

static status_t add_vector(fmi_vars_t *vs, fmi_causality_t causality, int what, const char *kind, int index,
                           const char *quantity, const char *unit, const char *desc, const log_t *log)
{
    for (int a = 0; a < 3; a++) {
        fmi_var_t *v = fmi_vars_add(vs, FMI_REAL, causality, unit, "%s[%d].%s.%c", kind, index, quantity, AXIS[a]);
        if (v == NULL) {
            return oom(log, "the variable list", ((size_t)vs->n + 1) * sizeof(fmi_var_t));
        }
        snprintf(v->description, sizeof v->description, "%s of %s %d, %c component", desc, kind, index, AXIS[a]);
        v->what = what;
        v->index = index;
        v->axis = a;
    }
    return STATUS_OK;
}

static status_t rigid_variables(const scene_t *s, const log_t *log, fmi_vars_t *out)
{
    fmi_vars_t vs = {0};
    status_t st = STATUS_OK;
    const double inf = INFINITY;
    *out = vs;
    if (scene_free_bodies(s) == 0) {
        return STATUS_DISCARD; /* the caller says what it means for it */
    }
    for (int a = 0; a < 3; a++) {
        char name[40], desc[60];
        snprintf(name, sizeof name, "rigid.gravity.%c", AXIS[a]);
        snprintf(desc, sizeof desc, "gravitational acceleration, %c component", AXIS[a]);
        if (!fmi_vars_param(&vs, name, "rigid.gravity", a, "m/s2", s->rigid.gravity[a], -inf, inf, 0, desc)) {
            st = oom(log, "the variable list", ((size_t)vs.n + 1) * sizeof(fmi_var_t));
            goto done;
        }
    }
    /* up to INT_MAX, as the scene allows (1e6 refused a scene's 2e6 set back through the FMU) */
    fmi_var_t *sub = fmi_vars_param(&vs, "rigid.substeps", "rigid.substeps", -1, NULL, s->rigid.substeps, 1.0,
                                    INT_MAX, 0, "rigid sub-steps per communication step (hydrodynamic load held)");
    if (sub == NULL) {
        st = oom(log, "the variable list", ((size_t)vs.n + 1) * sizeof(fmi_var_t));
        goto done;
    }
    sub->type = FMI_INTEGER;
    if (!fmi_vars_param(&vs, "rigid.rtol", "rigid.rtol", -1, NULL, s->rigid.rtol, 0.0, 1.0, FMI_LO_OPEN | FMI_HI_OPEN,
                        "CVODE relative tolerance (integrator cvode)") ||
        !fmi_vars_param(&vs, "rigid.atol", "rigid.atol", -1, NULL, s->rigid.atol, 0.0, inf, FMI_LO_OPEN,
                        "CVODE absolute tolerance on the scaled state (integrator cvode)") ||
        !fmi_vars_param(&vs, "fluid.density", "fluid.density", -1, "kg/m3", s->fluid.density, 0.0, inf, FMI_LO_OPEN,
                        "fluid density, for buoyancy")) {
        st = oom(log, "the variable list", ((size_t)vs.n + 1) * sizeof(fmi_var_t));
        goto done;
    }
    for (int b = 0, i = 0; b < s->nbodies; b++) {
        for (int k = 0; k < s->bodies[b].nspheres; k++, i++) {
            if (s->bodies[b].motion != MOTION_FREE) {
                continue;
            }
            if ((st = add_vector(&vs, FMI_INPUT, Q_FORCE, "sphere", i, "force", "N", "hydrodynamic force", log)) ||
                (st = add_vector(&vs, FMI_INPUT, Q_TORQUE, "sphere", i, "torque", "N.m",
                                 "hydrodynamic torque about the centre", log))) {
                goto done;
            }
            if (coupling_of_body(s, b).coupling != COUPLING_IMPLICIT) {
                continue; /* the drag pair exists for implicitly coupled bodies only (common/coupling.h) */
            }
            if (!fmi_vars_add_drag(&vs, FMI_INPUT, i, Q_DRAG, Q_ROTATIONAL_DRAG)) {
                st = oom(log, "the variable list", ((size_t)vs.n + 1) * sizeof(fmi_var_t));
                goto done;
            }
        }
    }
    for (int b = 0, i = 0; b < s->nbodies; b++) {
        for (int k = 0; k < s->bodies[b].nspheres; k++, i++) {
            if (s->bodies[b].motion != MOTION_FREE) {
                continue;
            }
            if ((st = add_vector(&vs, FMI_OUTPUT, Q_POSITION, "sphere", i, "position", "m", "centre position", log)) ||
                (st = add_vector(&vs, FMI_OUTPUT, Q_VELOCITY, "sphere", i, "velocity", "m/s", "centre velocity",
                                 log)) ||
                (st = add_vector(&vs, FMI_OUTPUT, Q_ANGULAR_VELOCITY, "sphere", i, "angular_velocity", "rad/s",
                                 "angular velocity", log))) {
                goto done;
            }
            if ((coupling_of_body(s, b).coupling == COUPLING_IMPLICIT || s->rigid.release_time > 0.0) &&
                ((st = add_vector(&vs, FMI_OUTPUT, Q_APPLIED_FORCE, "sphere", i, "applied_force", "N",
                                  "hydrodynamic force over the last step, implicit correction included", log)) ||
                 (st = add_vector(&vs, FMI_OUTPUT, Q_APPLIED_TORQUE, "sphere", i, "applied_torque", "N.m",
                                  "hydrodynamic torque over the last step, implicit correction included", log)))) {
                goto done;
            }
            fmi_var_t *v = fmi_vars_add(&vs, FMI_INTEGER, FMI_OUTPUT, NULL, "sphere[%d].body", i);
            if (v == NULL) {
                st = oom(log, "the variable list", ((size_t)vs.n + 1) * sizeof(fmi_var_t));
                goto done;
            }
            snprintf(v->description, sizeof v->description, "body id of sphere %d (changes on break-up and sticking)",
                     i);
            v->what = Q_BODY;
            v->index = i;
        }
    }
    for (int k = 0; k < s->nconnections; k++) {
        if ((st = add_vector(&vs, FMI_OUTPUT, Q_CONN_FORCE, "connection", k, "force", "N",
                             "force on the section holding sphere a (Eq. 8)", log)) ||
            (st = add_vector(&vs, FMI_OUTPUT, Q_CONN_TORQUE, "connection", k, "torque", "N.m",
                             "torque on that section about the connection point (Eq. 9)", log))) {
            goto done;
        }
        fmi_var_t *v = fmi_vars_add(&vs, FMI_BOOLEAN, FMI_OUTPUT, NULL, "connection[%d].intact", k);
        if (v == NULL) {
            st = oom(log, "the variable list", ((size_t)vs.n + 1) * sizeof(fmi_var_t));
            goto done;
        }
        snprintf(v->description, sizeof v->description, "true until connection %d (spheres %d-%d) breaks", k,
                 s->connections[k].a, s->connections[k].b);
        v->what = Q_CONN_INTACT;
        v->index = k;
    }
    fmi_var_t *nb = fmi_vars_add(&vs, FMI_INTEGER, FMI_OUTPUT, NULL, "rigid.bodies");
    if (nb == NULL) {
        st = oom(log, "the variable list", ((size_t)vs.n + 1) * sizeof(fmi_var_t));
        goto done;
    }
    snprintf(nb->description, sizeof nb->description, "number of moving bodies (changes on break-up and sticking)");
    nb->what = Q_NBODIES;
    for (int a = 0; a < 3; a++) {
        /* each filled in before the next is added (an add may move the list) */
        fmi_var_t *p = fmi_vars_add(&vs, FMI_REAL, FMI_OUTPUT, "kg.m/s", "rigid.momentum.%c", AXIS[a]);
        if (p == NULL) {
            st = oom(log, "the variable list", ((size_t)vs.n + 1) * sizeof(fmi_var_t));
            goto done;
        }
        snprintf(p->description, sizeof p->description, "linear momentum of all moving bodies, %c component", AXIS[a]);
        p->what = Q_MOMENTUM;
        p->axis = a;
        fmi_var_t *l = fmi_vars_add(&vs, FMI_REAL, FMI_OUTPUT, "kg.m2/s", "rigid.angular_momentum.%c", AXIS[a]);
        if (l == NULL) {
            st = oom(log, "the variable list", ((size_t)vs.n + 1) * sizeof(fmi_var_t));
            goto done;
        }
        snprintf(l->description, sizeof l->description,
                 "angular momentum of all moving bodies about the origin, %c component", AXIS[a]);
        l->what = Q_ANGULAR_MOMENTUM;
        l->axis = a;
    }
done:
    if (st != STATUS_OK) {
        fmi_vars_free(&vs);
    }
    *out = vs;
    return st;
}

static void rigid_fmi_free(void *comp)
{
    rigid_fmi_t *m = comp;
    if (m == NULL) {
        return;
    }
    rigid_free(m->r);
    free(m->load);
    free(m->drag);
    free(m);
}

static status_t rigid_fmi_create(const scene_t *s, double t0, const log_t *log, void **comp)
{
    *comp = NULL;
    const int ns = scene_total_spheres(s);
    rigid_config_t cfg;
    rigid_fmi_t *m = calloc(1, sizeof *m);
    status_t st = rigid_config_from_scene(s, t0, log, &cfg);
    if (st >= STATUS_ERROR) {
        free(m);
        return st;
    }
    if (m == NULL || (m->load = calloc(6 * (size_t)ns + 1, sizeof(double))) == NULL ||
        (m->drag = calloc(2 * (size_t)ns + 1, sizeof(double))) == NULL) {
        st = oom(log, "the component and its sphere loads", sizeof *m + (8 * (size_t)ns + 2) * sizeof(double));
        goto done;
    }
    m->ns = ns;
    st = rigid_create(&cfg, log, &m->r);
    if (st >= STATUS_ERROR) {
        m->r = NULL;
    }
done:
    rigid_scene_config_free(&cfg);
    if (st >= STATUS_ERROR) {
        rigid_fmi_free(m);
        return st;
    }
    *comp = m;
    return st;
}

static status_t rigid_fmi_step(void *comp, const fmi_vars_t *vars, const double *values, double t, double h,
                               const log_t *log)
{
    (void)t;
    (void)log;
    rigid_fmi_t *m = comp;
    for (int j = 0; j < vars->n; j++) {
        const fmi_var_t *v = &vars->v[j];
        if (v->causality != FMI_INPUT) {
            continue;
        }
        if (v->what == Q_DRAG || v->what == Q_ROTATIONAL_DRAG) {
            m->drag[2 * v->index + (v->what - Q_DRAG)] = values[j];
        } else {
            m->load[6 * v->index + 3 * v->what + v->axis] = values[j];
        }
    }
    for (int i = 0; i < m->ns; i++) {
        rigid_set_sphere_load(m->r, i, &m->load[6 * i], &m->load[6 * i + 3]);
        rigid_set_sphere_drag(m->r, i, m->drag[2 * i], m->drag[2 * i + 1]);
    }
    return rigid_step(m->r, h);
}

static void rigid_fmi_outputs(void *comp, const fmi_vars_t *vars, double *values)
{
    const rigid_fmi_t *m = comp;
    for (int j = 0; j < vars->n; j++) {
        const fmi_var_t *v = &vars->v[j];
        if (v->causality != FMI_OUTPUT) {
            continue;
        }
        double q[3][3];
        int intact = 0;
        if (v->what == Q_BODY) {
            values[j] = rigid_sphere_body(m->r, v->index);
        } else if (v->what == Q_NBODIES) {
            values[j] = rigid_nfree_bodies(m->r);
        } else if (v->what == Q_MOMENTUM || v->what == Q_ANGULAR_MOMENTUM) {
            rigid_momentum(m->r, q[0], q[1]);
            values[j] = q[v->what == Q_MOMENTUM ? 0 : 1][v->axis];
        } else if (v->what == Q_APPLIED_FORCE || v->what == Q_APPLIED_TORQUE) {
            rigid_get_sphere_applied_load(m->r, v->index, q[0], q[1]);
            values[j] = q[v->what - Q_APPLIED_FORCE][v->axis];
        } else if (v->what <= Q_ANGULAR_VELOCITY) {
            rigid_get_sphere(m->r, v->index, q[0], q[1], q[2]);
            values[j] = q[v->what - Q_POSITION][v->axis];
        } else {
            rigid_get_connection(m->r, v->index, q[0], q[1], &intact);
            values[j] = v->what == Q_CONN_INTACT ? (intact ? 1.0 : 0.0) : q[v->what - Q_CONN_FORCE][v->axis];
        }
    }
}

static size_t rigid_fmi_state_size(void *comp)
{
    return rigid_state_size(((rigid_fmi_t *)comp)->r);
}

static status_t rigid_fmi_state_save(void *comp, void *buf, size_t size)
{
    return rigid_state_save(((rigid_fmi_t *)comp)->r, buf, size);
}

static status_t rigid_fmi_state_restore(void *comp, const void *buf, size_t size)
{
    return rigid_state_restore(((rigid_fmi_t *)comp)->r, buf, size);
}

const fmi_model_t rigid_fmi_model = {
    .identifier = "rigid",
    .description = "Rigid agglomerates of sintered spheres: per-sphere hydrodynamic load in, "
                   "kinematics and connection loads out",
    .can_variable_step = 1,
    .variables = rigid_variables,
    .create = rigid_fmi_create,
    .free = rigid_fmi_free,
    .check_step = NULL,
    .step = rigid_fmi_step,
    .outputs = rigid_fmi_outputs,
    .state_size = rigid_fmi_state_size,
    .state_save = rigid_fmi_state_save,
    .state_restore = rigid_fmi_state_restore,
};
