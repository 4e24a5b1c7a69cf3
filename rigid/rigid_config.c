/* rigid_config.c — validation of a rigid_config_t, before rigid_create
 * builds anything.
 *
 * Counts and array pointers; finite, positive physical values; connections
 * that join two different, touching spheres of one body, each pair once;
 * contact, wall, lubrication and integrator settings; and every body one
 * piece. The first
 * violation is logged (category "rigid") and returned as STATUS_ERROR.
 * Nothing is allocated here: the connectivity check works in scratch arrays
 * of the caller. */
#include "rigid_internal.h"

static status_t bad(const log_t *log, const char *fmt, double a, double b)
{
    return log_msg(log, STATUS_ERROR, RIGID_CAT, fmt, a, b);
}

static int finite3(const double v[3]) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }

status_t rigid_config_validate(const rigid_config_t *c, const log_t *log)
{
    if (c->nspheres < 1 || c->nbodies < 1 || c->nconnections < 0) {
        return log_msg(log, STATUS_ERROR, RIGID_CAT,
                       "need at least one sphere and one body (nspheres=%d, nbodies=%d, nconnections=%d)",
                       c->nspheres, c->nbodies, c->nconnections);
    }
    if (c->spheres == NULL || c->bodies == NULL || (c->nconnections > 0 && c->connections == NULL)) {
        return log_msg(log, STATUS_ERROR, RIGID_CAT, "configuration arrays missing");
    }
    for (int b = 0; b < c->nbodies; b++) {
        const rigid_body_cfg_t *bd = &c->bodies[b];
        if (!(bd->density > 0.0) || !isfinite(bd->density)) {
            return log_msg(log, STATUS_ERROR, RIGID_CAT, "body %d: density %g kg/m^3 must be > 0 and finite", b,
                           bd->density);
        }
        if (!finite3(bd->velocity) || !finite3(bd->angular_velocity)) {
            return log_msg(log, STATUS_ERROR, RIGID_CAT, "body %d: initial velocity must be finite", b);
        }
    }
    for (int i = 0; i < c->nspheres; i++) {
        const rigid_sphere_cfg_t *s = &c->spheres[i];
        if (!(s->radius > 0.0) || !isfinite(s->radius)) {
            return log_msg(log, STATUS_ERROR, RIGID_CAT, "sphere %d: radius %g m must be > 0 and finite", i,
                           s->radius);
        }
        if (!finite3(s->center)) {
            return log_msg(log, STATUS_ERROR, RIGID_CAT, "sphere %d: centre must be finite", i);
        }
        if (s->body < 0 || s->body >= c->nbodies) {
            return log_msg(log, STATUS_ERROR, RIGID_CAT, "sphere %d: body %d out of range [0, %d)", i, s->body,
                           c->nbodies);
        }
    }
    for (int k = 0; k < c->nconnections; k++) {
        const rigid_connection_cfg_t *cn = &c->connections[k];
        if (cn->a < 0 || cn->a >= c->nspheres || cn->b < 0 || cn->b >= c->nspheres || cn->a == cn->b) {
            return log_msg(log, STATUS_ERROR, RIGID_CAT,
                           "connection %d: spheres %d and %d must be two different spheres in [0, %d)", k, cn->a,
                           cn->b, c->nspheres);
        }
        const rigid_sphere_cfg_t *sa = &c->spheres[cn->a], *sb = &c->spheres[cn->b];
        if (sa->body != sb->body) {
            return log_msg(log, STATUS_ERROR, RIGID_CAT,
                           "connection %d: sphere %d (body %d) and sphere %d (body %d) belong to different bodies", k,
                           cn->a, sa->body, cn->b, sb->body);
        }
        double d[3];
        rv_sub(sa->center, sb->center, d);
        double dist = rv_norm(d), lim = (sa->radius + sb->radius) * (1.0 + RIGID_TOUCH_TOL);
        if (dist > lim) {
            return log_msg(log, STATUS_ERROR, RIGID_CAT,
                           "connection %d: spheres %d and %d of body %d do not touch or overlap: centre distance %.9g m "
                           "exceeds the sum of radii %.9g m",
                           k, cn->a, cn->b, sa->body, dist, sa->radius + sb->radius);
        }
        const double lims[3] = {cn->max_normal, cn->max_shear, cn->max_torque};
        const char *names[3] = {"max_normal (N)", "max_shear (N)", "max_torque (N m)"};
        for (int m = 0; m < 3; m++) {
            if (!(lims[m] >= 0.0)) {
                return log_msg(log, STATUS_ERROR, RIGID_CAT,
                               "connection %d (spheres %d-%d): %s is %g, must be >= 0 (0 or inf = unbreakable)", k,
                               cn->a, cn->b, names[m], lims[m]);
            }
        }
        for (int m = 0; m < k; m++) {
            const rigid_connection_cfg_t *o = &c->connections[m];
            if ((o->a == cn->a && o->b == cn->b) || (o->a == cn->b && o->b == cn->a)) {
                return log_msg(log, STATUS_ERROR, RIGID_CAT, "connection %d duplicates connection %d (spheres %d-%d)",
                               k, m, cn->a, cn->b);
            }
        }
    }
    if (!finite3(c->gravity)) {
        return log_msg(log, STATUS_ERROR, RIGID_CAT, "gravity must be finite");
    }
    if (!(c->fluid_density >= 0.0) || !isfinite(c->fluid_density)) {
        return bad(log, "fluid_density %g kg/m^3 must be >= 0 (limit %g)", c->fluid_density, 0.0);
    }
    if (c->contact_model != RIGID_CONTACT_NONE && c->contact_model != RIGID_CONTACT_SPRING_DASHPOT &&
        c->contact_model != RIGID_CONTACT_HERTZ) {
        return log_msg(log, STATUS_ERROR, RIGID_CAT, "contact_model %d unknown", (int)c->contact_model);
    }
    if (c->contact_model != RIGID_CONTACT_NONE) {
        if (!(c->restitution > 0.0 && c->restitution <= 1.0)) {
            return bad(log, "restitution %g must be in (0, %g]", c->restitution, 1.0);
        }
        if (!(c->friction >= 0.0) || !isfinite(c->friction)) {
            return bad(log, "friction %g must be >= %g and finite", c->friction, 0.0);
        }
    }
    if (c->contact_model == RIGID_CONTACT_SPRING_DASHPOT && !(c->contact_time > 0.0 && isfinite(c->contact_time))) {
        return bad(log, "contact_time %g s must be > %g and finite", c->contact_time, 0.0);
    }
    if (c->contact_model == RIGID_CONTACT_HERTZ) {
        if (!(c->young_modulus > 0.0) || !isfinite(c->young_modulus)) {
            return bad(log, "young_modulus %g Pa must be > %g", c->young_modulus, 0.0);
        }
        if (!(c->poisson_ratio >= 0.0 && c->poisson_ratio < 0.5)) {
            return bad(log, "poisson_ratio %g must be in [0, %g)", c->poisson_ratio, 0.5);
        }
    }
    if (!(c->stick_speed >= 0.0) || !isfinite(c->stick_speed)) {
        return bad(log, "stick_speed %g m/s must be >= %g and finite", c->stick_speed, 0.0);
    }
    const double fl[3] = {c->fuse_max_normal, c->fuse_max_shear, c->fuse_max_torque};
    for (int m = 0; m < 3; m++) {
        if (!(fl[m] >= 0.0)) {
            return bad(log, "fuse limit %g must be >= %g (0 or inf = unbreakable)", fl[m], 0.0);
        }
    }
    for (int a = 0; a < 3; a++) {
        if ((c->walls[a][0] || c->walls[a][1] || c->periodic[a]) &&
            !(c->box_hi[a] > c->box_lo[a] && isfinite(c->box_lo[a]) && isfinite(c->box_hi[a]))) {
            return log_msg(log, STATUS_ERROR, RIGID_CAT,
                           "box along axis %d: need box_lo %g < box_hi %g for walls or a period", a, c->box_lo[a],
                           c->box_hi[a]);
        }
        if (c->periodic[a] && (c->walls[a][0] || c->walls[a][1])) {
            return log_msg(log, STATUS_ERROR, RIGID_CAT, "axis %d is periodic and has a wall; allowed: one of the two",
                           a);
        }
        for (int side = 0; side < 2; side++) {
            rigid_wall_kind_t k = c->wall_kind[a][side];
            if (k != RIGID_WALL_NO_SLIP && k != RIGID_WALL_FREE_SLIP && k != RIGID_WALL_OPEN) {
                return log_msg(log, STATUS_ERROR, RIGID_CAT, "wall_kind[%d][%d] = %d unknown", a, side, (int)k);
            }
            if (!finite3(c->wall_velocity[a][side])) {
                return log_msg(log, STATUS_ERROR, RIGID_CAT, "wall_velocity[%d][%d] must be finite", a, side);
            }
        }
    }
    if (!(c->fluid_viscosity >= 0.0) || !isfinite(c->fluid_viscosity)) {
        return bad(log, "fluid_viscosity %g m^2/s must be >= %g and finite", c->fluid_viscosity, 0.0);
    }
    if (c->lubrication) {
        if (!(c->lub_cutoff > 0.0) || !isfinite(c->lub_cutoff)) {
            return bad(log, "lub_cutoff %g m must be > %g and finite", c->lub_cutoff, 0.0);
        }
        if (!(c->lub_min_gap > 0.0 && c->lub_min_gap < c->lub_cutoff)) {
            return bad(log, "lub_min_gap %g m must be in (0, lub_cutoff = %g m)", c->lub_min_gap, c->lub_cutoff);
        }
    }
    if (c->integrator != RIGID_VERLET && c->integrator != RIGID_CVODE) {
        return log_msg(log, STATUS_ERROR, RIGID_CAT, "integrator %d unknown", (int)c->integrator);
    }
    if (c->integrator == RIGID_CVODE) {
        if (c->cvode_method != RIGID_ADAMS && c->cvode_method != RIGID_BDF) {
            return log_msg(log, STATUS_ERROR, RIGID_CAT, "cvode_method %d unknown", (int)c->cvode_method);
        }
        if (c->linsol != RIGID_LS_DENSE && c->linsol != RIGID_LS_SPGMR) {
            return log_msg(log, STATUS_ERROR, RIGID_CAT, "linsol %d unknown", (int)c->linsol);
        }
        if (!(c->rtol > 0.0 && c->rtol < 1.0)) {
            return bad(log, "rtol %g must be in (0, %g)", c->rtol, 1.0);
        }
        if (!(c->atol > 0.0) || !isfinite(c->atol)) {
            return bad(log, "atol %g must be > %g", c->atol, 0.0);
        }
    }
    if (c->substeps < 1) {
        return log_msg(log, STATUS_ERROR, RIGID_CAT, "substeps %d must be >= 1", c->substeps);
    }
    if (!isfinite(c->t0)) {
        return log_msg(log, STATUS_ERROR, RIGID_CAT, "t0 must be finite");
    }
    if (!(c->release_time >= 0.0) || !isfinite(c->release_time)) {
        return bad(log, "release_time %g must be >= %g and finite", c->release_time, 0.0);
    }
    return STATUS_OK;
}

/* Every body must be one piece: its spheres joined by touching/overlap. */
status_t rigid_config_check_connected(const rigid_config_t *c, const log_t *log, int *comp, int *stack)
{
    for (int i = 0; i < c->nspheres; i++) {
        comp[i] = -1;
    }
    for (int b = 0; b < c->nbodies; b++) {
        int first = -1;
        for (int i = 0; i < c->nspheres; i++) {
            if (c->spheres[i].body == b) {
                first = i;
                break;
            }
        }
        if (first < 0) {
            return log_msg(log, STATUS_ERROR, RIGID_CAT, "body %d has no spheres", b);
        }
        int top = 0;
        stack[top++] = first;
        comp[first] = b;
        while (top > 0) {
            int u = stack[--top];
            for (int v = 0; v < c->nspheres; v++) {
                if (comp[v] >= 0 || c->spheres[v].body != b) {
                    continue;
                }
                double d[3];
                rv_sub(c->spheres[u].center, c->spheres[v].center, d);
                if (rv_norm(d) <= (c->spheres[u].radius + c->spheres[v].radius) * (1.0 + RIGID_TOUCH_TOL)) {
                    comp[v] = b;
                    stack[top++] = v;
                }
            }
        }
        for (int i = 0; i < c->nspheres; i++) {
            if (c->spheres[i].body == b && comp[i] < 0) {
                return log_msg(log, STATUS_ERROR, RIGID_CAT,
                               "body %d is not one piece: sphere %d is not joined to sphere %d by a chain of touching "
                               "or overlapping spheres of the body",
                               b, i, first);
            }
        }
    }
    return STATUS_OK;
}
