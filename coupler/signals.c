/* signals.c — the signals of `coupler run`'s master (master.h): every input
 * of one FMU connected to the output of the other with the same name (a
 * missing partner, a different type or unit is an error), the outputs an
 * output row observes (per sphere kinematics and loads, connection loads,
 * fluid totals) found by name in either FMU, and one communication step:
 *   rigid kinematics -> fluid inputs; fluid fmi2DoStep(t, h);
 *   fluid forces/torques -> rigid inputs; rigid fmi2DoStep(t, h). */
#include "master.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define CAT "run"

/* The names of the row's sphere quantities (master.h). */
static const char *const SPHERE_Q[NSPHERE_Q] = {"position", "velocity", "angular_velocity", "force", "torque"};
static const char *const AXIS = "xyz";

/* ------------------------------------------------------------------------ */
/* Signals: what goes from one FMU to the other, and what a row observes    */

static int same_unit(const char *a, const char *b)
{
    return (a == NULL && b == NULL) || (a != NULL && b != NULL && strcmp(a, b) == 0);
}

static const char *type_text(fmu_type_t t)
{
    return t == FMU_REAL ? "Real" : t == FMU_INTEGER ? "Integer" : t == FMU_BOOLEAN ? "Boolean" : "String";
}

/* Every input of `to` gets the output of `from` with the same name. */
status_t master_connect(master_t *m, fmu_t *from, fmu_t *to, unsigned **src, unsigned **dst, int *n)
{
    const int nv = fmu_nvars(to);
    *src = calloc((size_t)nv + 1, sizeof **src);
    *dst = calloc((size_t)nv + 1, sizeof **dst);
    if (*src == NULL || *dst == NULL) {
        return log_msg(&m->log, STATUS_FATAL, CAT, "out of memory for the signal map of %d variables (%zu bytes)", nv, 2 * ((size_t)nv + 1) * sizeof **src);
    }
    status_t st = STATUS_OK;
    for (int j = 0; j < nv; j++) {
        const fmu_var_t *in = fmu_var(to, j);
        if (in->causality != FMU_INPUT) {
            continue;
        }
        const fmu_var_t *out = from != NULL ? fmu_find(from, in->name) : NULL;
        if (out == NULL || out->causality != FMU_OUTPUT) {
            st = log_msg(&m->log, STATUS_ERROR, CAT, "signal mismatch: input %s of %s has no output of that name in %s",
                         in->name, fmu_label(to), from != NULL ? fmu_label(from) : "any FMU (the scene has no rigid.fmu)");
            continue;
        }
        if (out->type != in->type || in->type != FMU_REAL || !same_unit(in->unit, out->unit)) {
            st = log_msg(&m->log, STATUS_ERROR, CAT,
                         "signal mismatch: %s is %s [%s] in %s but %s [%s] in %s", in->name, type_text(in->type),
                         in->unit != NULL ? in->unit : "no unit", fmu_label(to), type_text(out->type),
                         out->unit != NULL ? out->unit : "no unit", fmu_label(from));
            continue;
        }
        (*src)[*n] = out->vr;
        (*dst)[*n] = in->vr;
        (*n)++;
    }
    return st;
}

static status_t gather_add(master_t *m, gather_t *g, unsigned vr, int dest)
{
    if (g->n % 64 == 0) {
        unsigned *v = realloc(g->vr, sizeof *v * (size_t)(g->n + 64));
        int *d = v != NULL ? realloc(g->dest, sizeof *d * (size_t)(g->n + 64)) : NULL;
        if (v != NULL) {
            g->vr = v;
        }
        if (d == NULL) {
            return log_msg(&m->log, STATUS_FATAL, CAT, "out of memory for the observed outputs (%zu bytes)", ((size_t)g->n + 1) * (sizeof(int) + sizeof(unsigned)));
        }
        g->dest = d;
    }
    g->vr[g->n] = vr;
    g->dest[g->n] = dest;
    g->n++;
    return STATUS_OK;
}

/* Finds an output by name in the fluid or the rigid FMU. */
static status_t observe(master_t *m, const char *name, fmu_type_t type, int dest, int required)
{
    fmu_t *owners[2] = {m->fluid, m->rigid};
    for (int k = 0; k < 2; k++) {
        const fmu_var_t *v = owners[k] != NULL ? fmu_find(owners[k], name) : NULL;
        if (v == NULL || v->causality != FMU_OUTPUT) {
            continue;
        }
        if (v->type != type) {
            return log_msg(&m->log, STATUS_ERROR, CAT, "%s of %s is %s; the master expects %s", name,
                           fmu_label(owners[k]), type_text(v->type), type_text(type));
        }
        gather_t *g = type == FMU_REAL      ? (k == 0 ? &m->real_fluid : &m->real_rigid)
                      : type == FMU_INTEGER ? &m->int_rigid
                                            : &m->bool_rigid;
        if (type != FMU_REAL && k == 0) {
            return log_msg(&m->log, STATUS_ERROR, CAT, "%s: the master reads it from rigid.fmu only", name);
        }
        return gather_add(m, g, v->vr, dest);
    }
    if (!required) {
        return STATUS_DISCARD;
    }
    return log_msg(&m->log, STATUS_ERROR, CAT, "no FMU publishes the output %s that the output file needs", name);
}

status_t master_plan_observation(master_t *m)
{
    const int ns = m->ns, nc = m->nc;
    m->o_cforce = NSPHERE_Q * 3 * ns;
    m->o_ctorque = m->o_cforce + 3 * nc;
    m->o_mass = m->o_ctorque + 3 * nc;
    m->o_mom = m->o_mass + 1;
    m->o_ke = m->o_mom + 3;
    m->o_vmax = m->o_ke + 1;
    m->o_peak = m->o_vmax + 1;
    m->o_bmom = m->o_peak + 3;
    m->o_bang = m->o_bmom + 3;
    m->nrow = m->o_bang + 3;
    m->row = calloc((size_t)m->nrow, sizeof(double));
    m->ibody = calloc((size_t)ns + 1, sizeof(int)); /* [ns]: the number of moving bodies */
    m->iintact = calloc((size_t)nc + 1, sizeof(int));
    if (m->row == NULL || m->ibody == NULL || m->iintact == NULL) {
        return log_msg(&m->log, STATUS_FATAL, CAT, "out of memory for the output row (%zu bytes)", (size_t)m->nrow * sizeof(double) + ((size_t)ns + (size_t)nc + 2) * sizeof(int));
    }
    status_t st = STATUS_OK;
    char name[128];
    for (int i = 0; i < ns && st == STATUS_OK; i++) {
        for (int q = 0; q < NSPHERE_Q && st == STATUS_OK; q++) {
            for (int a = 0; a < 3 && st == STATUS_OK; a++) {
                /* the load: what acted over the step (rigid.fmu's applied
                 * load under the implicit coupling), else the fluid's */
                if (q == R_FORCE || q == R_TORQUE) {
                    snprintf(name, sizeof name, "sphere[%d].applied_%s.%c", i, SPHERE_Q[q], AXIS[a]);
                    st = observe(m, name, FMU_REAL, q * 3 * ns + 3 * i + a, 0);
                    if (st != STATUS_DISCARD) {
                        continue;
                    }
                }
                snprintf(name, sizeof name, "sphere[%d].%s.%c", i, SPHERE_Q[q], AXIS[a]);
                st = observe(m, name, FMU_REAL, q * 3 * ns + 3 * i + a, 1);
            }
        }
    }
    /* body ids: the rigid publishes them for its spheres; the others keep
     * their scene body index */
    for (int b = 0, i = 0; b < m->scene->nbodies && st == STATUS_OK; b++) {
        for (int k = 0; k < m->scene->bodies[b].nspheres && st == STATUS_OK; k++, i++) {
            m->ibody[i] = b;
            snprintf(name, sizeof name, "sphere[%d].body", i);
            st = observe(m, name, FMU_INTEGER, i, 0);
            st = st == STATUS_DISCARD ? STATUS_OK : st;
        }
    }
    for (int k = 0; k < nc && st == STATUS_OK; k++) {
        for (int a = 0; a < 3 && st == STATUS_OK; a++) {
            snprintf(name, sizeof name, "connection[%d].force.%c", k, AXIS[a]);
            st = observe(m, name, FMU_REAL, m->o_cforce + 3 * k + a, 1);
            snprintf(name, sizeof name, "connection[%d].torque.%c", k, AXIS[a]);
            st = status_worst(st, observe(m, name, FMU_REAL, m->o_ctorque + 3 * k + a, 1));
        }
        snprintf(name, sizeof name, "connection[%d].intact", k);
        st = status_worst(st, observe(m, name, FMU_BOOLEAN, k, 1));
    }
    static const struct {
        const char *name;
        int vector;
    } diag[] = {{"fluid.mass", 0}, {"fluid.momentum", 1}, {"fluid.kinetic_energy", 0}, {"fluid.max_speed", 0},
                {"fluid.peak_velocity", 1}};
    const int offs[] = {m->o_mass, m->o_mom, m->o_ke, m->o_vmax, m->o_peak};
    for (int d = 0; d < 5 && st == STATUS_OK; d++) {
        for (int a = 0; a < (diag[d].vector ? 3 : 1) && st == STATUS_OK; a++) {
            if (diag[d].vector) {
                snprintf(name, sizeof name, "%s.%c", diag[d].name, AXIS[a]);
            } else {
                snprintf(name, sizeof name, "%s", diag[d].name);
            }
            st = observe(m, name, FMU_REAL, offs[d] + a, 1);
        }
    }
    /* the rigid component's totals over its moving bodies (balances of
     * break-up and sticking) */
    for (int a = 0; a < 3 && st == STATUS_OK && m->rigid != NULL; a++) {
        snprintf(name, sizeof name, "rigid.momentum.%c", AXIS[a]);
        st = observe(m, name, FMU_REAL, m->o_bmom + a, 1);
        snprintf(name, sizeof name, "rigid.angular_momentum.%c", AXIS[a]);
        st = status_worst(st, observe(m, name, FMU_REAL, m->o_bang + a, 1));
    }
    if (st == STATUS_OK && m->rigid != NULL) {
        st = observe(m, "rigid.bodies", FMU_INTEGER, ns, 1);
    }
    gather_t *gs[4] = {&m->real_fluid, &m->real_rigid, &m->int_rigid, &m->bool_rigid};
    for (int k = 0; k < 4 && st == STATUS_OK; k++) {
        gs[k]->tmp = calloc((size_t)gs[k]->n + 1, sizeof(double));
        gs[k]->itmp = calloc((size_t)gs[k]->n + 1, sizeof(int));
        if (gs[k]->tmp == NULL || gs[k]->itmp == NULL) {
            st = log_msg(&m->log, STATUS_FATAL, CAT, "out of memory for the read buffers (%zu bytes)", ((size_t)gs[k]->n + 1) * (sizeof(double) + sizeof(int)));
        }
    }
    return st;
}

/* Reads every observed output into the row buffer. */
status_t master_read_row(master_t *m)
{
    status_t st = STATUS_OK;
    gather_t *g = &m->real_fluid;
    if (g->n > 0 && (st = fmu_get_real(m->fluid, g->vr, (size_t)g->n, g->tmp)) >= STATUS_ERROR) {
        return st;
    }
    for (int k = 0; k < g->n; k++) {
        m->row[g->dest[k]] = g->tmp[k];
    }
    if (m->rigid == NULL) {
        return st;
    }
    g = &m->real_rigid;
    if (g->n > 0 && (st = fmu_get_real(m->rigid, g->vr, (size_t)g->n, g->tmp)) >= STATUS_ERROR) {
        return st;
    }
    for (int k = 0; k < g->n; k++) {
        m->row[g->dest[k]] = g->tmp[k];
    }
    g = &m->int_rigid;
    if (g->n > 0 && (st = fmu_get_integer(m->rigid, g->vr, (size_t)g->n, g->itmp)) >= STATUS_ERROR) {
        return st;
    }
    for (int k = 0; k < g->n; k++) {
        m->ibody[g->dest[k]] = g->itmp[k];
    }
    g = &m->bool_rigid;
    if (g->n > 0 && (st = fmu_get_boolean(m->rigid, g->vr, (size_t)g->n, g->itmp)) >= STATUS_ERROR) {
        return st;
    }
    for (int k = 0; k < g->n; k++) {
        m->iintact[g->dest[k]] = g->itmp[k] != 0;
    }
    return st;
}

status_t master_write_row(master_t *m, output_t *out, double t)
{
    const int ns = m->ns;
    const double *r = m->row;
    output_row_t row = {
        .time = t,
        .position = r + R_POS * 3 * ns,
        .velocity = r + R_VEL * 3 * ns,
        .angular_velocity = r + R_OMEGA * 3 * ns,
        .force = r + R_FORCE * 3 * ns,
        .torque = r + R_TORQUE * 3 * ns,
        .body = m->ibody,
        .conn_force = r + m->o_cforce,
        .conn_torque = r + m->o_ctorque,
        .intact = m->iintact,
        .mass = r[m->o_mass],
        .momentum = {r[m->o_mom], r[m->o_mom + 1], r[m->o_mom + 2]},
        .kinetic_energy = r[m->o_ke],
        .nbodies = m->ibody[m->ns],
        .body_momentum = r + m->o_bmom,
        .body_angular_momentum = r + m->o_bang,
    };
    return output_row(out, &row);
}
/* ------------------------------------------------------------------------ */
/* Stepping                                                                  */

static status_t exchange(master_t *m, fmu_t *from, fmu_t *to, const unsigned *src, const unsigned *dst, int n)
{
    if (n == 0) {
        return STATUS_OK;
    }
    status_t st = fmu_get_real(from, src, (size_t)n, m->xbuf);
    return st >= STATUS_ERROR ? st : status_worst(st, fmu_set_real(to, dst, (size_t)n, m->xbuf));
}

/* One communication step from t: the sequential scheme. */
status_t master_step(master_t *m, double t, double h)
{
    status_t st = STATUS_OK;
    if (m->rigid != NULL && (st = exchange(m, m->rigid, m->fluid, m->to_fluid_src, m->to_fluid_dst,
                                           m->nto_fluid)) >= STATUS_ERROR) {
        return st;
    }
    if ((st = status_worst(st, fmu_do_step(m->fluid, t, h))) >= STATUS_ERROR) {
        return st;
    }
    if (m->rigid == NULL) {
        return st;
    }
    if ((st = status_worst(st, exchange(m, m->fluid, m->rigid, m->to_rigid_src, m->to_rigid_dst, m->nto_rigid))) >=
        STATUS_ERROR) {
        return st;
    }
    return status_worst(st, fmu_do_step(m->rigid, t, h));
}
