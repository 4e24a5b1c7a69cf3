/* fluid_fmi.c — the fluid component as an FMI 2.0 Co-Simulation FMU: the
 * mapping between value references and the native API (fluid.h). The FMI
 * entry points, call-order checks and logging are the generic layer's
 * (common/fmi_adapter.c, common/fmi_internal.h).
 *
 * Variables (SI, structured names, global sphere index i: bodies in scene
 * order, their spheres in order):
 *   parameters  fluid.density, fluid.viscosity, fluid.tau (or fluid.dt when
 *               the scene gives dt), fluid.body_force.x|y|z; fluid.tau is
 *               the requested value (the scene key it overrides): the scene
 *               reader rounds dt to whole ns and adjusts tau (common/scene.h)
 *   inputs      sphere[i].position|velocity|angular_velocity.x|y|z, only for
 *               spheres of free bodies (the fluid moves fixed and prescribed
 *               spheres itself); start values are the scene's initial state
 *               output.fields (String, only when the scene sets run.fields):
 *               the HDF5 file for field snapshots, "" for none;
 *               output.fields_resume (String, likewise): the field file of an
 *               interrupted run to continue (coupler run --restart): opened,
 *               not truncated, its snapshots after the restored step dropped
 *   outputs     sphere[i].force|torque.x|y|z for every sphere: the
 *               hydrodynamic force and the torque about the sphere centre of
 *               the last LBM step (averaged when fluid.force_averaging is set)
 *               sphere[i].drag_coefficient (kg/s), .rotational_drag_coefficient
 *               (kg.m2/s) for spheres of free bodies when rigid.coupling =
 *               implicit: the load's instantaneous response -dF/dv, -dT/dw
 *               sphere[i].position|velocity|angular_velocity.x|y|z for the
 *               spheres that are not inputs (fixed and prescribed bodies: the
 *               fluid moves them, so it publishes where they are at the FMU's
 *               time t, the scene's motion: the r^3-weighted centroid moves
 *               with the body velocity, the centre turns about it with the
 *               angular velocity; wrapped on periodic axes)
 *               fluid.mass (kg), fluid.momentum.x|y|z (kg m/s),
 *               fluid.kinetic_energy (J), fluid.max_speed (m/s),
 *               fluid.peak_velocity.x|y|z (m/s, the signed component of
 *               largest magnitude per axis): totals over the fluid cells,
 *               lazy (one pass over the grid, only when a master reads them)
 * Field snapshots (common/h5fields.h) are written by the FMU itself into
 * output.fields: at creation, at every LBM step that reaches a multiple of
 * run.field_interval and at run.end_time; a master cannot reach the grid
 * through FMI. Numerical trouble (a non-finite or non-positive density, a
 * velocity above fluid.mach_limit) fails the step, or the read of the
 * totals, with the step, the cell, its position and the cause, so that no NaN
 * reaches a master's output: the whole grid is scanned every CHECK_EVERY LBM
 * steps, at the last step of the run and before every field snapshot; the
 * sphere loads are checked at the end of every communication step (a NaN
 * near a sphere shows in its load at once); and the totals' own pass over
 * the grid checks every cell it reads (fluid_diagnostics_lattice).
 * A communication step h must be a whole number k of LBM steps dt (within
 * 1e-9 relative). The inputs are held over the step (zero-order hold): a
 * free sphere stays where its position input puts it for all k LBM steps,
 * with the surface velocity of its velocity inputs. */
#include "../common/coupling.h"
#include "../common/fmi_adapter.h"
#include "../common/h5fields.h"
#include "fluid.h"

#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum {
    Q_POSITION,
    Q_VELOCITY,
    Q_ANGULAR_VELOCITY,
    Q_FORCE,
    Q_TORQUE,
    Q_DRAG,
    Q_ROTATIONAL_DRAG,
    Q_PARAMETER,
    Q_FIELDS_FILE,
    Q_FIELDS_RESUME,
    Q_MASS,
    Q_MOMENTUM,
    Q_KINETIC_ENERGY,
    Q_MAX_SPEED,
    Q_PEAK_VELOCITY,
};

/* Every CHECK_EVERY LBM steps the whole grid is scanned (~1/3 of a step's
 * memory traffic, so 0.2% of the run): a blow-up inside a long communication
 * step stops within 200 steps of its start. */
#define CHECK_EVERY 200

static const char *const AXIS = "xyz";

typedef struct {
    fluid_t *fl;
    const scene_t *scene;   /* alive while the component is (adapter) */
    int ns;
    double *kin;            /* per sphere: c[3], v[3], w[3] */
    unsigned char *is_free; /* per sphere: set from inputs */
    int block[3];           /* this rank's interior cells (the whole grid on one rank) */
    int slab;               /* z planes per field slab (h5fields_slab_planes) */
    double *rho, *u;        /* SI moments of a slab of planes, for the field snapshots */
    unsigned char *flags;
    h5fields_t *fields;     /* NULL: no snapshots */
    long fields_failed;     /* the step whose snapshot failed (the file was closed then), or -1 */
    long next_field;        /* snapshots at next_field * run.field_interval */
    long end_step;          /* the LBM step of run.end_time */
    log_t log;
} fluid_fmi_t;

/* An allocation failed: what it was for and its size. */
static status_t oom(const log_t *log, const char *what, size_t bytes)
{
    return log_msg(log, STATUS_FATAL, "fluid", "out of memory for %s (%zu bytes)", what, bytes);
}

static status_t add_vector(fmi_vars_t *vs, fmi_causality_t causality, int what, int sphere, const char *quantity,
                           const char *unit, const double start[3], const char *desc, const log_t *log)
{
    for (int a = 0; a < 3; a++) {
        fmi_var_t *v = fmi_vars_add(vs, FMI_REAL, causality, unit, "sphere[%d].%s.%c", sphere, quantity, AXIS[a]);
        if (v == NULL) {
            return oom(log, "the variable list", ((size_t)vs->n + 1) * sizeof(fmi_var_t));
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
                 : fmi_vars_param(&vs, "fluid.tau", "fluid.tau", -1, NULL, f->tau_requested, 0.5, inf, FMI_LO_OPEN,
                                  "BGK/TRT relaxation time as requested (dt rounded to whole ns, tau adjusted)"))) {
        st = oom(log, "the variable list", ((size_t)vs.n + 1) * sizeof(fmi_var_t));
        goto done;
    }
    for (int a = 0; a < 3; a++) {
        char name[40], desc[60];
        snprintf(name, sizeof name, "fluid.body_force.%c", AXIS[a]);
        snprintf(desc, sizeof desc, "body force per volume driving the fluid, %c component", AXIS[a]);
        if (!fmi_vars_param(&vs, name, "fluid.body_force", a, "N/m3", f->body_force[a], -inf, inf, 0, desc)) {
            st = oom(log, "the variable list", ((size_t)vs.n + 1) * sizeof(fmi_var_t));
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
    if (s->run.fields) {
        fmi_var_t *v = fmi_vars_add(&vs, FMI_STRING, FMI_PARAMETER, NULL, "output.fields");
        if (v == NULL) {
            st = oom(log, "the variable list", ((size_t)vs.n + 1) * sizeof(fmi_var_t));
            goto done;
        }
        v->what = Q_FIELDS_FILE;
        snprintf(v->description, sizeof v->description,
                 "HDF5 file for field snapshots every run.field_interval (\"\": none), .xmf beside it");
        if ((v = fmi_vars_add(&vs, FMI_STRING, FMI_PARAMETER, NULL, "output.fields_resume")) == NULL) {
            st = oom(log, "the variable list", ((size_t)vs.n + 1) * sizeof(fmi_var_t));
            goto done;
        }
        v->what = Q_FIELDS_RESUME;
        snprintf(v->description, sizeof v->description,
                 "field file of an interrupted run to continue after a state restore (\"\": none)");
    }
    const int ns = scene_total_spheres(s);
    for (int i = 0; i < ns; i++) {
        if ((st = add_vector(&vs, FMI_OUTPUT, Q_FORCE, i, "force", "N", NULL, "hydrodynamic force", log)) ||
            (st = add_vector(&vs, FMI_OUTPUT, Q_TORQUE, i, "torque", "N.m", NULL,
                             "hydrodynamic torque about the centre", log))) {
            goto done;
        }
    }
    for (int b = 0, i = 0; b < s->nbodies; b++) {
        const int implicit = coupling_of_body(s, b).coupling == COUPLING_IMPLICIT; /* free bodies only */
        for (int k = 0; k < s->bodies[b].nspheres; k++, i++) {
            if (!implicit) {
                continue;
            }
            if (!fmi_vars_add_drag(&vs, FMI_OUTPUT, i, Q_DRAG, Q_ROTATIONAL_DRAG)) {
                st = oom(log, "the variable list", ((size_t)vs.n + 1) * sizeof(fmi_var_t));
                goto done;
            }
        }
    }
    for (int b = 0, i = 0; b < s->nbodies; b++) {
        for (int k = 0; k < s->bodies[b].nspheres; k++, i++) {
            if (s->bodies[b].motion == MOTION_FREE) {
                continue;
            }
            if ((st = add_vector(&vs, FMI_OUTPUT, Q_POSITION, i, "position", "m", NULL, "centre position", log)) ||
                (st = add_vector(&vs, FMI_OUTPUT, Q_VELOCITY, i, "velocity", "m/s", NULL, "centre velocity", log)) ||
                (st = add_vector(&vs, FMI_OUTPUT, Q_ANGULAR_VELOCITY, i, "angular_velocity", "rad/s", NULL,
                                 "angular velocity", log))) {
                goto done;
            }
        }
    }
    static const struct {
        const char *name, *unit, *desc;
        int what, vector;
    } diag[] = {
        {"fluid.mass", "kg", "mass of the fluid cells", Q_MASS, 0},
        {"fluid.momentum", "kg.m/s", "momentum of the fluid cells", Q_MOMENTUM, 1},
        {"fluid.kinetic_energy", "J", "kinetic energy of the fluid cells", Q_KINETIC_ENERGY, 0},
        {"fluid.max_speed", "m/s", "largest fluid speed", Q_MAX_SPEED, 0},
        {"fluid.peak_velocity", "m/s", "velocity component of largest magnitude (signed)", Q_PEAK_VELOCITY, 1},
    };
    for (size_t d = 0; d < sizeof diag / sizeof diag[0]; d++) {
        for (int a = 0; a < (diag[d].vector ? 3 : 1); a++) {
            fmi_var_t *v = diag[d].vector
                               ? fmi_vars_add(&vs, FMI_REAL, FMI_OUTPUT, diag[d].unit, "%s.%c", diag[d].name, AXIS[a])
                               : fmi_vars_add(&vs, FMI_REAL, FMI_OUTPUT, diag[d].unit, "%s", diag[d].name);
            if (v == NULL) {
                st = oom(log, "the variable list", ((size_t)vs.n + 1) * sizeof(fmi_var_t));
                goto done;
            }
            if (diag[d].vector) {
                snprintf(v->description, sizeof v->description, "%s, %c component (computed when read)",
                         diag[d].desc, AXIS[a]);
            } else {
                snprintf(v->description, sizeof v->description, "%s (computed when read)", diag[d].desc);
            }
            v->what = diag[d].what;
            v->axis = a;
            v->lazy = 1;
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
    h5fields_close(m->fields); /* errors were reported at each snapshot */
    if (m->fl != NULL) {
        fluid_decomposition_t d;
        fluid_decomposition(m->fl, &d);
        const long steps = fluid_step_count(m->fl);
        if (d.ranks > 1 && d.rank == 0 && steps > 0) {
            log_msg(&m->log, STATUS_OK, "fluid",
                    "%d MPI ranks as [%d, %d, %d]; rank 0: block %d x %d x %d, halo %.4g MB per step, exchanges "
                    "%.4g s in %ld steps (%.4g ms per step)",
                    d.ranks, d.dims[0], d.dims[1], d.dims[2], d.n[0], d.n[1], d.n[2], d.halo_bytes / 1e6,
                    d.halo_seconds, steps, 1e3 * d.halo_seconds / (double)steps);
        }
    }
    fluid_free(m->fl);
    free(m->kin);
    free(m->is_free);
    free(m->rho);
    free(m->u);
    free(m->flags);
    free(m);
}

static status_t fluid_fmi_create(const scene_t *s, double t0, const log_t *log, void **comp)
{
    (void)t0; /* the fluid counts steps from 0; the adapter keeps FMU time */
    *comp = NULL;
    fluid_fmi_t *m = calloc(1, sizeof *m);
    if (m == NULL) {
        return oom(log, "the component", sizeof *m);
    }
    m->fields_failed = -1;
    m->ns = scene_total_spheres(s);
    m->kin = calloc(9 * (size_t)m->ns + 1, sizeof(double));
    m->is_free = calloc((size_t)m->ns + 1, 1);
    if (m->kin == NULL || m->is_free == NULL) {
        const size_t bytes = (9 * (size_t)m->ns + 1) * sizeof(double) + (size_t)m->ns + 1;
        fluid_fmi_free(m);
        return oom(log, "the sphere kinematics", bytes);
    }
    status_t st = fluid_create(s, log, &m->fl);
    if (st >= STATUS_ERROR) {
        m->fl = NULL;
        fluid_fmi_free(m);
        return st;
    }
    /* the fields of this rank's block (the whole grid on one rank) */
    int lo[3];
    const void *comm;
    fluid_block(m->fl, lo, m->block, &comm);
    m->slab = h5fields_slab_planes(m->block[0], m->block[1], m->block[2]);
    m->scene = s;
    m->log = *log;
    m->end_step = (long)ceil(s->run.end_time / fluid_units(m->fl)->dt - 1e-9);
    *comp = m;
    return st;
}

/* Moments and flags of the interior planes z0 .. z0 + nz - 1 in SI units. */
static void load_fields(fluid_fmi_t *m, int z0, int nz)
{
    const units_t *un = fluid_units(m->fl);
    const double uv = units_velocity(un);
    fluid_moments_lattice_planes(m->fl, z0, nz, m->rho, m->u);
    fluid_flags_planes(m->fl, z0, nz, m->flags);
    const size_t cells = (size_t)m->block[0] * (size_t)m->block[1] * (size_t)nz;
    for (size_t i = 0; i < cells; i++) {
        m->rho[i] *= un->rho0;
        for (int a = 0; a < 3; a++) {
            m->u[3 * i + a] *= uv;
        }
    }
}

/* A snapshot when the current step reaches the next multiple of the field
 * interval (or run.end_time); output times are k * interval from the step
 * counter, never accumulated. */
static status_t maybe_snapshot(fluid_fmi_t *m)
{
    if (m->fields == NULL) {
        return m->fields_failed < 0 ? STATUS_OK
                                    : log_msg(&m->log, STATUS_ERROR, "fluid", "no field snapshots after the one of "
                                              "step %ld failed (the field file was closed then)", m->fields_failed);
    }
    /* an interval shorter than a step: a snapshot every step */
    const double dt = fluid_units(m->fl)->dt, fi = fmax(m->scene->run.field_interval, dt), t = fluid_time(m->fl);
    const long step = fluid_step_count(m->fl);
    if (t < m->next_field * fi - 1e-9 * dt && step != m->end_step) {
        return STATUS_OK;
    }
    /* a snapshot holds every cell: none may be NaN (the scan costs less
     * than the moments and the write) */
    status_t st = fluid_check(m->fl, m->scene->fluid.mach_limit);
    if (st >= STATUS_ERROR) {
        return st;
    }
    /* a slab of planes at a time: the buffers hold a slab, not the grid (on
     * several ranks each makes as many calls as the rank that needs the most:
     * their blocks, and so their slabs, may differ) */
    st = h5fields_begin(m->fields, step, t);
    if (st == STATUS_OK) {
        int calls = 0;
        st = h5fields_slabs(m->fields, m->slab, &calls);
        for (int c = 0; c < calls && st == STATUS_OK; c++) {
            const int z0 = c * m->slab, left = m->block[2] - z0;
            const int nz = left <= 0 ? 0 : left < m->slab ? left : m->slab;
            load_fields(m, z0, nz);
            st = h5fields_planes(m->fields, z0, nz, m->rho, m->u, m->flags);
        }
        st = status_worst(st, h5fields_end(m->fields));
    }
    if (st >= STATUS_ERROR) {
        /* the writer took the failed snapshot out again: closed now, the
         * file holds the snapshots before it, whatever the master does next
         * (h5fields.c; collective, as every rank has this status) */
        h5fields_close(m->fields);
        m->fields = NULL;
        m->fields_failed = step;
        return log_msg(&m->log, STATUS_ERROR, "fluid", "the field snapshot of step %ld failed (see above): the field "
                       "file was closed and keeps the snapshots before it", step);
    }
    m->next_field = scene_next_multiple(m->next_field, fi, t + 1e-9 * dt);
    return st;
}

static status_t fluid_fmi_terminate(void *comp, const log_t *log)
{
    (void)log; /* the writer names its failures through its own log */
    fluid_fmi_t *m = comp;
    const status_t st = h5fields_close(m->fields);
    m->fields = NULL;
    m->fields_failed = -1;
    return st;
}

static status_t fluid_fmi_set_string(void *comp, const fmi_var_t *var, const char *value, const log_t *log)
{
    fluid_fmi_t *m = comp;
    if ((var->what != Q_FIELDS_FILE && var->what != Q_FIELDS_RESUME) || value[0] == '\0') {
        return STATUS_OK;
    }
    h5fields_close(m->fields);
    m->fields = NULL;
    m->fields_failed = -1;
    /* the field buffers exist only where fields are written: a slab's */
    const size_t cells = (size_t)m->block[0] * (size_t)m->block[1] * (size_t)m->slab;
    if (m->rho == NULL) {
        m->rho = malloc(sizeof(double) * cells);
        m->u = malloc(sizeof(double) * 3 * cells);
        m->flags = malloc(cells);
        if (m->rho == NULL || m->u == NULL || m->flags == NULL) {
            free(m->rho);
            free(m->u);
            free(m->flags);
            m->rho = m->u = NULL;
            m->flags = NULL;
            return log_msg(log, STATUS_ERROR, "fluid", "out of memory for the field buffers of %zu cells (%.4g MB)",
                           cells, 33.0 * (double)cells / 1e6);
        }
    }
    int n[3];
    fluid_cells(m->fl, n);
    const double dx = fluid_units(m->fl)->dx;
    /* on several MPI ranks each writes its block of the same file (parallel
     * HDF5); on one, part NULL: this process writes the whole grid */
    h5fields_part_t part;
    fluid_block(m->fl, part.lo, part.n, &part.comm);
    const h5fields_part_t *part_ptr = part.comm != NULL ? &part : NULL;
    if (var->what == Q_FIELDS_RESUME) {
        /* the snapshots continue after the state restore (fluid_fmi_state_restore) */
        return h5fields_resume(value, n, dx, part_ptr, log, &m->fields);
    }
    status_t st = h5fields_open(value, n, dx, part_ptr, log, &m->fields);
    if (st >= STATUS_ERROR) {
        return st;
    }
    m->next_field = 0;
    return maybe_snapshot(m);
}

/* A step h of k LBM steps within 1e-9 h, or within the round-off of a step
 * a master computes as the difference of two communication points, h =
 * t_next - t: each time is rounded to 1/2 ulp, so h is off by up to an ulp
 * of |t| + h (at t = 1000 s, 1.1e-13 s: 1.1e-8 of a step of 1e-5 s, which
 * the relative 1e-9 alone refused; at 1e5 s, 3.4e-7 of it). */
static status_t fluid_fmi_check_step(void *comp, double t, double h, const log_t *log)
{
    const fluid_fmi_t *m = comp;
    const double dt = fluid_units(m->fl)->dt;
    const double k = nearbyint(h / dt);
    const double roundoff = 4.0 * DBL_EPSILON * (fabs(t) + h), tol = fmax(1e-9 * h, roundoff);
    if (roundoff >= 0.25 * dt) {
        /* also every step of more LBM steps than a long counts (h/dt above
         * 2.8e14 here): it was counted as LONG_MIN, and the step of 1e20 s
         * returned fmi2OK having taken none */
        if (h > fabs(t)) {
            return log_msg(log, STATUS_ERROR, "fluid",
                           "communication step %.17g s (%.3g LBM steps of dt = %.17g s) is too long: a double "
                           "resolves t + h only to %.3g s; allowed: steps below %.3g s",
                           h, h / dt, dt, roundoff, dt / (16.0 * DBL_EPSILON));
        }
        return log_msg(log, STATUS_ERROR, "fluid",
                       "at t = %.17g s a double resolves times only to %.3g s, too coarse for the LBM step dt = "
                       "%.17g s; start the experiment at a smaller time (fmi2SetupExperiment startTime)",
                       t, roundoff, dt);
    }
    if (k < 1.0 || fabs(h - k * dt) > tol) {
        return log_msg(log, STATUS_ERROR, "fluid",
                       "communication step %.17g s is not a whole number of LBM steps dt = %.17g s (h/dt = %.9g, "
                       "tolerance %.3g s at t = %.17g s); allowed: k * dt with k = 1, 2, ...",
                       h, dt, h / dt, tol, t);
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
    const long steps = (long)nearbyint(h / fluid_units(m->fl)->dt);
    fluid_set_exchange_steps(m->fl, steps);
    for (int i = 0; i < m->ns; i++) {
        if (m->is_free[i]) {
            const double *k = &m->kin[9 * i];
            st = status_worst(st, fluid_set_sphere(m->fl, i, k, k + 3, k + 6));
            if (st >= STATUS_ERROR) {
                return st;
            }
        }
    }
    const double mach = m->scene->fluid.mach_limit;
    for (long n = 0; n < steps; n++) {
        st = status_worst(st, fluid_step(m->fl));
        const long step = fluid_step_count(m->fl);
        if (st < STATUS_ERROR && (step % CHECK_EVERY == 0 || step == m->end_step)) {
            st = status_worst(st, fluid_check(m->fl, mach));
        }
        if (st < STATUS_ERROR) {
            st = status_worst(st, maybe_snapshot(m));
        }
        if (st >= STATUS_ERROR) {
            return log_msg(log, st, "fluid", "LBM step %ld of %ld in this communication step failed", n + 1, steps);
        }
    }
    /* the outputs a master reads next: the sphere loads (the totals check
     * themselves when read) */
    st = status_worst(st, fluid_check_loads(m->fl, mach));
    if (st >= STATUS_ERROR) {
        return log_msg(log, st, "fluid", "the communication step of %ld LBM steps ends with a non-finite sphere load",
                       steps);
    }
    /* loads a sane fluid cannot give, before a free body takes them (fluid.h) */
    st = status_worst(st, fluid_check_load_sizes(m->fl, mach, m->is_free));
    if (st >= STATUS_ERROR) {
        return log_msg(log, st, "fluid",
                       "the communication step of %ld LBM steps ends with a sphere load larger than a sane fluid "
                       "gives, from the cells in trouble named above",
                       steps);
    }
    return st;
}

/* Kinematics of a fixed or prescribed sphere at time t (s): Rodrigues'
 * rotation of the centre about the body's pivot (scene_body_pivot, as
 * spheres.c and the initial profile take it). */
static void moved_sphere(const scene_t *s, int sphere, double t, double c[3], double v[3], double w[3])
{
    int b = 0, k = sphere;
    while (k >= s->bodies[b].nspheres) {
        k -= s->bodies[b].nspheres;
        b++;
    }
    const scene_body_t *body = &s->bodies[b];
    const int moving = body->motion == MOTION_PRESCRIBED;
    double com[3], rel[3], rot[3], wv[3] = {0, 0, 0}, vb[3] = {0, 0, 0};
    scene_body_pivot(body, com);
    for (int a = 0; a < 3; a++) {
        rel[a] = body->spheres[k].center[a] - com[a];
        wv[a] = moving ? body->angular_velocity[a] : 0.0;
        vb[a] = moving ? body->velocity[a] : 0.0;
    }
    const double wn = sqrt(wv[0] * wv[0] + wv[1] * wv[1] + wv[2] * wv[2]);
    memcpy(rot, rel, sizeof rot);
    if (wn > 0.0) {
        const double e[3] = {wv[0] / wn, wv[1] / wn, wv[2] / wn}, ang = wn * t;
        const double cs = cos(ang), sn = sin(ang), dot = e[0] * rel[0] + e[1] * rel[1] + e[2] * rel[2];
        const double ex[3] = {e[1] * rel[2] - e[2] * rel[1], e[2] * rel[0] - e[0] * rel[2],
                              e[0] * rel[1] - e[1] * rel[0]};
        for (int a = 0; a < 3; a++) {
            rot[a] = rel[a] * cs + ex[a] * sn + e[a] * dot * (1.0 - cs);
        }
    }
    const double wr[3] = {wv[1] * rot[2] - wv[2] * rot[1], wv[2] * rot[0] - wv[0] * rot[2],
                          wv[0] * rot[1] - wv[1] * rot[0]};
    for (int a = 0; a < 3; a++) {
        c[a] = com[a] + vb[a] * t + rot[a];
        if (s->domain.faces[2 * a].type == FACE_PERIODIC) {
            const double L = s->domain.size[a];
            c[a] -= L * floor(c[a] / L);
        }
        v[a] = vb[a] + wr[a];
        w[a] = wv[a];
    }
}

static void fluid_fmi_outputs(void *comp, const fmi_vars_t *vars, double *values)
{
    const fluid_fmi_t *m = comp;
    for (int j = 0; j < vars->n; j++) {
        const fmi_var_t *v = &vars->v[j];
        if (v->causality != FMI_OUTPUT || v->lazy) {
            continue;
        }
        double q[3][3];
        if (v->what == Q_FORCE || v->what == Q_TORQUE) {
            fluid_sphere_load(m->fl, v->index, q[0], q[1]);
            values[j] = q[v->what - Q_FORCE][v->axis];
        } else if (v->what == Q_DRAG || v->what == Q_ROTATIONAL_DRAG) {
            fluid_sphere_drag(m->fl, v->index, &q[0][0], &q[0][1]);
            values[j] = q[0][v->what - Q_DRAG];
        } else {
            moved_sphere(m->scene, v->index, fluid_time(m->fl), q[0], q[1], q[2]);
            values[j] = q[v->what - Q_POSITION][v->axis];
        }
    }
}

/* Totals over the fluid cells (one pass over the grid, no field buffers),
 * which also checks every cell: numerical trouble fails the read. */
static status_t fluid_fmi_lazy_outputs(void *comp, const fmi_vars_t *vars, double *values)
{
    fluid_fmi_t *m = comp;
    const units_t *un = fluid_units(m->fl);
    const double uv = units_velocity(un), cell = un->dx * un->dx * un->dx;
    double mass, mom[3], ke, vmax, peak[3];
    const status_t st = fluid_diagnostics_lattice(m->fl, m->scene->fluid.mach_limit, &mass, mom, &ke, &vmax, peak);
    mass *= un->rho0 * cell;
    ke *= un->rho0 * uv * uv * cell;
    vmax *= uv;
    for (int a = 0; a < 3; a++) {
        mom[a] *= un->rho0 * uv * cell;
        peak[a] *= uv;
    }
    for (int j = 0; j < vars->n; j++) {
        const fmi_var_t *v = &vars->v[j];
        if (!v->lazy) {
            continue;
        }
        values[j] = v->what == Q_MASS             ? mass
                    : v->what == Q_MOMENTUM       ? mom[v->axis]
                    : v->what == Q_KINETIC_ENERGY ? ke
                    : v->what == Q_MAX_SPEED      ? vmax
                                                  : peak[v->axis];
    }
    return st;
}

static size_t fluid_fmi_state_size(void *comp)
{
    return fluid_state_size(((fluid_fmi_t *)comp)->fl);
}

static status_t fluid_fmi_state_save(void *comp, void *buf, size_t size)
{
    return fluid_state_save(((fluid_fmi_t *)comp)->fl, buf, size);
}

/* After a restore, snapshots continue from the restored step: those of later
 * steps (from the run that went on, or was killed, after the state was taken)
 * are dropped. */
static status_t fluid_fmi_state_restore(void *comp, const void *buf, size_t size)
{
    fluid_fmi_t *m = comp;
    status_t st = fluid_state_restore(m->fl, buf, size);
    if (st >= STATUS_ERROR) {
        return st; /* refused: the component is as it was */
    }
    if (m->fields == NULL) {
        m->next_field = 0;
        return st;
    }
    const double dt = fluid_units(m->fl)->dt;
    m->next_field = scene_next_multiple(0, fmax(m->scene->run.field_interval, dt), fluid_time(m->fl) + 1e-9 * dt);
    return status_worst(st, h5fields_drop_after(m->fields, fluid_step_count(m->fl)));
}

const fmi_model_t fluid_fmi_model = {
    .identifier = "fluid",
    .description = "Lattice Boltzmann (D3Q19) fluid with moving spheres: per-sphere kinematics in, "
                   "hydrodynamic force and torque out",
    .can_variable_step = 1,
    .variables = fluid_variables,
    .create = fluid_fmi_create,
    .free = fluid_fmi_free,
    .terminate = fluid_fmi_terminate,
    .check_step = fluid_fmi_check_step,
    .step = fluid_fmi_step,
    .outputs = fluid_fmi_outputs,
    .lazy_outputs = fluid_fmi_lazy_outputs,
    .set_string = fluid_fmi_set_string,
    .state_size = fluid_fmi_state_size,
    .state_save = fluid_fmi_state_save,
    .state_restore = fluid_fmi_state_restore,
};
