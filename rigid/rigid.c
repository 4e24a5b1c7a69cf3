/* rigid.c — the public verbs: create (validating the configuration), step,
 * getters, free.
 *
 * A communication step (rigid_step) reads like the algorithm:
 *   1. trapezoidal correction of the hydrodynamic load: the previous step
 *      held the old load F_n; now that F_{n+1} is known, v and L receive
 *      h_prev/2 (F_{n+1} - F_n) (and the matching torque), which makes the
 *      coupling second order for both integrators (for one sub-step and
 *      Verlet this is exactly the closing half-kick of Stoermer-Verlet);
 *   2. integrate over h (Verlet sub-steps or CVODE) with the load held;
 *   3. forces at the new state; connection forces and torques (Eq. 8-9);
 *   4. break-up, then sticking; sections rebuilt if the topology changed.
 * The velocities reported after a step are therefore the predicted ones
 * (with the held load); step 1 of the next call corrects them. */
#include "rigid_internal.h"

#include <assert.h>
#include <stdlib.h>
#include <string.h>

static status_t bad(const log_t *log, const char *fmt, double a, double b)
{
    return log_msg(log, STATUS_ERROR, RIGID_CAT, fmt, a, b);
}

static int finite3(const double v[3]) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }

static status_t validate(const rigid_config_t *c, const log_t *log)
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
        if ((c->walls[a][0] || c->walls[a][1]) &&
            !(c->box_hi[a] > c->box_lo[a] && isfinite(c->box_lo[a]) && isfinite(c->box_hi[a]))) {
            return log_msg(log, STATUS_ERROR, RIGID_CAT, "box along axis %d: need box_lo %g < box_hi %g for walls", a,
                           c->box_lo[a], c->box_hi[a]);
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
    return STATUS_OK;
}

/* Every body must be one piece: its spheres joined by touching/overlap. */
static status_t check_connected(const rigid_config_t *c, const log_t *log, int *comp, int *stack)
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

void rigid_free(rigid_t *r)
{
    if (r == NULL) {
        return;
    }
    if (r->ops != NULL) {
        r->ops->free(r->integ);
    }
    free(r->scratch_bodies);
    free(r->sx);
    free(r->sv);
    free(r->bt);
    free(r->bf);
    free(r->st);
    free(r->sf);
    free(r->touch);
    free(r->section);
    free(r->conn);
    free(r->bodies);
    free(r->spheres);
    free(r);
}

status_t rigid_create(const rigid_config_t *cfg, const log_t *log, rigid_t **out)
{
    assert(cfg != NULL && out != NULL);
    *out = NULL;
    status_t st = validate(cfg, log);
    if (st != STATUS_OK) {
        return st;
    }
    rigid_t *r = calloc(1, sizeof *r);
    if (r == NULL) {
        return log_msg(log, STATUS_ERROR, RIGID_CAT, "out of memory");
    }
    if (log != NULL) {
        r->log = *log;
    }
    r->cfg = *cfg;
    r->cfg.spheres = NULL;
    r->cfg.bodies = NULL;
    r->cfg.connections = NULL;
    r->t = cfg->t0;
    size_t ns = (size_t)cfg->nspheres;
    r->nspheres = cfg->nspheres;
    r->nbodies = cfg->nbodies;
    r->nconn = cfg->nconnections;
    r->conn_cap = cfg->nconnections > 0 ? cfg->nconnections : 1;
    r->spheres = calloc(ns, sizeof *r->spheres);
    r->bodies = calloc(ns, sizeof *r->bodies);
    r->scratch_bodies = calloc(ns, sizeof *r->scratch_bodies);
    r->conn = calloc((size_t)r->conn_cap, sizeof *r->conn);
    r->section = calloc((size_t)r->conn_cap * ns, 1);
    r->touch = calloc(ns * ns, 1); /* nothing touches "before" t0: initial contacts may stick */
    r->sf = calloc(3 * ns, sizeof(double));
    r->st = calloc(3 * ns, sizeof(double));
    r->bf = calloc(3 * ns, sizeof(double));
    r->bt = calloc(3 * ns, sizeof(double));
    r->sx = calloc(ns, sizeof *r->sx);
    r->sv = calloc(ns, sizeof *r->sv);
    int *members = malloc(ns * sizeof(int)), *ids = malloc(ns * sizeof(int));
    double (*c)[3] = malloc(ns * sizeof *c), (*s)[3] = malloc(ns * sizeof *s), (*j)[9] = malloc(ns * sizeof *j);
    double *rad = malloc(ns * sizeof(double));
    if (!r->spheres || !r->bodies || !r->scratch_bodies || !r->conn || !r->section || !r->touch || !r->sf || !r->st || !r->bf ||
        !r->bt || !r->sx || !r->sv || !members || !ids || !c || !s || !j || !rad) {
        st = log_msg(log, STATUS_ERROR, RIGID_CAT, "out of memory");
        goto cleanup;
    }
    if ((st = check_connected(cfg, log, members, ids)) != STATUS_OK) {
        goto cleanup;
    }
    for (int b = 0; b < cfg->nbodies; b++) {
        const rigid_body_cfg_t *bc = &cfg->bodies[b];
        int nm = 0;
        for (int i = 0; i < cfg->nspheres; i++) {
            if (cfg->spheres[i].body == b) {
                ids[nm] = i;
                members[nm] = i;
                memcpy(c[nm], cfg->spheres[i].center, sizeof c[nm]);
                rad[nm] = cfg->spheres[i].radius;
                nm++;
            }
        }
        for (int k = 0; k < nm; k++) {
            double vol;
            st = rigid_share_props(log, nm, (const double (*)[3])c, rad, ids, k, &vol, s[k], j[k]);
            if (st != STATUS_OK) {
                goto cleanup;
            }
            rigid_sphere_t *sp = &r->spheres[ids[k]];
            sp->radius = rad[k];
            sp->orig_body = b;
            sp->density = bc->density;
            sp->volume = vol;
            sp->mass = bc->density * vol;
            for (int m = 0; m < 9; m++) {
                j[k][m] *= bc->density;
            }
        }
        rigid_body_build(r, b, members, nm, c, s, j);
        rigid_body_t *bd = &r->bodies[b];
        bd->fixed = bc->fixed != 0;
        if (!bd->fixed) {
            double iw[9];
            memcpy(bd->v, bc->velocity, sizeof bd->v);
            rigid_body_inertia_world(bd, iw);
            rm_mul(iw, bc->angular_velocity, bd->l);
        }
    }
    for (int k = 0; k < cfg->nconnections; k++) {
        rigid_conn_t *cn = &r->conn[k];
        const rigid_connection_cfg_t *cc = &cfg->connections[k];
        cn->a = cc->a;
        cn->b = cc->b;
        cn->max_normal = cc->max_normal;
        cn->max_shear = cc->max_shear;
        cn->max_torque = cc->max_torque;
        cn->intact = 1;
        cn->gap0 = 0.0;
    }
    if ((st = rigid_sections_update(r)) != STATUS_OK) {
        goto cleanup;
    }
    r->ops = cfg->integrator == RIGID_CVODE ? &rigid_cvode_ops : &rigid_verlet_ops;
    if ((st = r->ops->create(r, &r->integ)) != STATUS_OK) {
        r->ops = NULL;
        goto cleanup;
    }
    /* connection loads at t0 (with zero hydrodynamic load) */
    if (rigid_forces(r, r->bodies, NULL) >= 0) {
        rigid_connections_eval(r);
    }
cleanup:
    free(members);
    free(ids);
    free(c);
    free(s);
    free(j);
    free(rad);
    if (st != STATUS_OK) {
        rigid_free(r);
        return st;
    }
    *out = r;
    return STATUS_OK;
}

void rigid_set_sphere_load(rigid_t *r, int sphere, const double force[3], const double torque[3])
{
    assert(r != NULL && sphere >= 0 && sphere < r->nspheres);
    rigid_sphere_t *s = &r->spheres[sphere];
    for (int a = 0; a < 3; a++) {
        s->load_f[a] = force != NULL ? force[a] : 0.0;
        s->load_t[a] = torque != NULL ? torque[a] : 0.0;
    }
}

void rigid_set_sphere_drag(rigid_t *r, int sphere, double zt, double zr)
{
    assert(r != NULL && sphere >= 0 && sphere < r->nspheres);
    r->spheres[sphere].drag_t = zt > 0.0 && isfinite(zt) ? zt : 0.0;
    r->spheres[sphere].drag_r = zr > 0.0 && isfinite(zr) ? zr : 0.0;
}

/* Solves the n x n system a x = b in place (Gaussian elimination with
 * partial pivoting; a is row-major and destroyed). Returns 0 when singular. */
static int solve_small(int n, double *a, double *b)
{
    for (int k = 0; k < n; k++) {
        int p = k;
        for (int i = k + 1; i < n; i++) {
            if (fabs(a[i * n + k]) > fabs(a[p * n + k])) {
                p = i;
            }
        }
        if (!(fabs(a[p * n + k]) > 0.0)) {
            return 0;
        }
        if (p != k) {
            for (int j = 0; j < n; j++) {
                const double t = a[k * n + j];
                a[k * n + j] = a[p * n + j];
                a[p * n + j] = t;
            }
            const double t = b[k];
            b[k] = b[p];
            b[p] = t;
        }
        for (int i = k + 1; i < n; i++) {
            const double f = a[i * n + k] / a[k * n + k];
            for (int j = k; j < n; j++) {
                a[i * n + j] -= f * a[k * n + j];
            }
            b[i] -= f * b[k];
        }
    }
    for (int k = n - 1; k >= 0; k--) {
        for (int j = k + 1; j < n; j++) {
            b[k] -= a[k * n + j] * b[j];
        }
        b[k] /= a[k * n + k];
    }
    return 1;
}

/* The change of the held load of sphere i when its body's velocity changes
 * by dv and its angular velocity by dw (d: sphere centre minus body centre
 * of mass): df = -zt (dv + dw x d), dt = -zr dw about the sphere centre. */
static void drag_response(const rigid_sphere_t *s, const double d[3], const double dv[3], const double dw[3],
                          double df[3], double dt[3])
{
    double wxd[3];
    rv_cross(dw, d, wxd);
    for (int a = 0; a < 3; a++) {
        df[a] = -s->drag_t * (dv[a] + wxd[a]);
        dt[a] = -s->drag_r * dw[a];
    }
}

/* Implicit coupling, before the integration of a step of length h: per body,
 * (M + h Z) x = h (F, T) with the mass matrix M = diag(m, m, m, I_world),
 * the body's total force and torque about its centre of mass at the start of
 * the step (load, gravity, contacts) and Z the response of the loads to
 * (dV, dW); x = (dV, dW) is the predicted change over the step and the held
 * load of every sphere becomes F_i - zt_i (dV + dW x d_i), T_i - zr_i dW. The
 * gyroscopic term is left out of the prediction (it only sets the size of a
 * correction that vanishes in steady motion). */
static status_t implicit_load(rigid_t *r, double h)
{
    int any = 0;
    for (int i = 0; i < r->nspheres; i++) {
        memset(r->spheres[i].imp_f, 0, sizeof r->spheres[i].imp_f);
        memset(r->spheres[i].imp_t, 0, sizeof r->spheres[i].imp_t);
        any |= r->spheres[i].drag_t > 0.0 || r->spheres[i].drag_r > 0.0;
    }
    if (!any) {
        return STATUS_OK;
    }
    if (rigid_forces(r, r->bodies, NULL) < 0) {
        return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "non-finite force at t=%.9g s before the step", r->t);
    }
    for (int b = 0; b < r->nbodies; b++) {
        const rigid_body_t *bd = &r->bodies[b];
        if (bd->fixed) {
            continue;
        }
        double a[36] = {0}, x[6], iw[9];
        rigid_body_inertia_world(bd, iw);
        for (int k = 0; k < 3; k++) {
            a[k * 6 + k] = bd->mass;
            for (int j = 0; j < 3; j++) {
                a[(3 + k) * 6 + 3 + j] = iw[3 * k + j];
            }
            x[k] = h * r->bf[3 * b + k];
            x[3 + k] = h * r->bt[3 * b + k];
        }
        /* + h Z, column by column: Z e_k = -(dF, dT) for a unit change e_k */
        int some = 0;
        for (int i = 0; i < r->nspheres; i++) {
            const rigid_sphere_t *s = &r->spheres[i];
            if (s->body != b || (s->drag_t == 0.0 && s->drag_r == 0.0)) {
                continue;
            }
            some = 1;
            double c[3], d[3];
            rigid_sphere_world(r, r->bodies, i, c, NULL, NULL);
            rv_sub(c, bd->com, d);
            for (int k = 0; k < 6; k++) {
                double dv[3] = {0, 0, 0}, dw[3] = {0, 0, 0}, df[3], dt[3], tf[3];
                (k < 3 ? dv : dw)[k % 3] = 1.0;
                drag_response(s, d, dv, dw, df, dt);
                rv_cross(d, df, tf);
                for (int j = 0; j < 3; j++) {
                    a[j * 6 + k] -= h * df[j];
                    a[(3 + j) * 6 + k] -= h * (dt[j] + tf[j]);
                }
            }
        }
        if (!some) {
            continue;
        }
        if (!solve_small(6, a, x)) {
            return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "implicit coupling: singular system for body %d at t=%.9g s",
                           b, r->t);
        }
        for (int i = 0; i < r->nspheres; i++) {
            rigid_sphere_t *s = &r->spheres[i];
            if (s->body != b || (s->drag_t == 0.0 && s->drag_r == 0.0)) {
                continue;
            }
            double c[3], d[3];
            rigid_sphere_world(r, r->bodies, i, c, NULL, NULL);
            rv_sub(c, bd->com, d);
            drag_response(s, d, x, x + 3, s->imp_f, s->imp_t);
        }
    }
    return STATUS_OK;
}

/* Step 1 of rigid_step: trapezoidal correction of the held load. */
static void load_correction(rigid_t *r)
{
    double half = 0.5 * r->h_prev;
    for (int i = 0; i < r->nspheres; i++) {
        rigid_sphere_t *s = &r->spheres[i];
        rigid_body_t *b = &r->bodies[s->body];
        if (b->fixed) {
            continue;
        }
        double df[3], dt[3], x[3], d[3], m[3];
        for (int a = 0; a < 3; a++) {
            df[a] = s->load_f[a] - s->held_f[a];
            dt[a] = s->load_t[a] - s->held_t[a];
        }
        if (df[0] == 0.0 && df[1] == 0.0 && df[2] == 0.0 && dt[0] == 0.0 && dt[1] == 0.0 && dt[2] == 0.0) {
            continue;
        }
        rigid_sphere_world(r, r->bodies, i, x, NULL, NULL);
        rv_sub(x, b->com, d);
        rv_cross(d, df, m);
        for (int a = 0; a < 3; a++) {
            b->v[a] += half * df[a] / b->mass;
            b->l[a] += half * (m[a] + dt[a]);
        }
    }
}

status_t rigid_step(rigid_t *r, double h)
{
    assert(r != NULL);
    if (!(h > 0.0) || !isfinite(h)) {
        return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "step length %g s must be > 0 and finite (t=%.9g s)", h,
                       r->t);
    }
    if (r->have_prev && r->cfg.load_correction) {
        load_correction(r);
    }
    status_t st = implicit_load(r, h);
    if (st != STATUS_OK) {
        return st;
    }
    st = r->ops->advance(r, r->integ, h);
    if (st != STATUS_OK) {
        return st;
    }
    for (int i = 0; i < r->nspheres; i++) {
        memcpy(r->spheres[i].held_f, r->spheres[i].load_f, sizeof r->spheres[i].held_f);
        memcpy(r->spheres[i].held_t, r->spheres[i].load_t, sizeof r->spheres[i].held_t);
    }
    r->have_prev = 1;
    r->h_prev = h;
    r->t += h;
    int rc = rigid_forces(r, r->bodies, NULL);
    if (rc < 0) {
        return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "non-finite force at t=%.9g s after the step", r->t);
    }
    rigid_connections_eval(r);
    int broke = 0, stuck = 0;
    if ((st = rigid_breakup(r, &broke)) != STATUS_OK) {
        return st;
    }
    if ((st = rigid_stick(r, &stuck)) != STATUS_OK) {
        return st;
    }
    rigid_touch_update(r);
    if (broke || stuck) {
        st = rigid_sections_update(r);
    }
    return st;
}

double rigid_time(const rigid_t *r) { return r->t; }
int rigid_nbodies(const rigid_t *r) { return r->nbodies; }
int rigid_nspheres(const rigid_t *r) { return r->nspheres; }

int rigid_nfree_bodies(const rigid_t *r)
{
    int n = 0;
    for (int k = 0; k < r->nbodies; k++) {
        n += !r->bodies[k].fixed;
    }
    return n;
}
int rigid_nconnections(const rigid_t *r) { return r->nconn; }

int rigid_sphere_body(const rigid_t *r, int sphere)
{
    assert(sphere >= 0 && sphere < r->nspheres);
    return r->spheres[sphere].body;
}

void rigid_get_sphere(const rigid_t *r, int sphere, double pos[3], double vel[3], double omega[3])
{
    assert(sphere >= 0 && sphere < r->nspheres);
    rigid_sphere_world(r, r->bodies, sphere, pos, vel, omega);
}

void rigid_get_connection(const rigid_t *r, int k, double force[3], double torque[3], int *intact)
{
    assert(k >= 0 && k < r->nconn);
    const rigid_conn_t *c = &r->conn[k];
    if (force != NULL) {
        memcpy(force, c->force, sizeof c->force);
    }
    if (torque != NULL) {
        memcpy(torque, c->torque, sizeof c->torque);
    }
    if (intact != NULL) {
        *intact = c->intact;
    }
}

void rigid_get_connection_pair(const rigid_t *r, int k, int *a, int *b)
{
    assert(k >= 0 && k < r->nconn);
    *a = r->conn[k].a;
    *b = r->conn[k].b;
}

void rigid_get_body(const rigid_t *r, int body, double com[3], double q[4], double v[3], double omega[3],
                    double *mass, double inertia_world[9])
{
    assert(body >= 0 && body < r->nbodies);
    const rigid_body_t *b = &r->bodies[body];
    if (com != NULL) {
        memcpy(com, b->com, sizeof b->com);
    }
    if (q != NULL) {
        memcpy(q, b->q, sizeof b->q);
    }
    if (v != NULL) {
        memcpy(v, b->v, sizeof b->v);
    }
    if (omega != NULL) {
        rigid_body_omega(b, omega);
    }
    if (mass != NULL) {
        *mass = b->mass;
    }
    if (inertia_world != NULL) {
        rigid_body_inertia_world(b, inertia_world);
    }
}

void rigid_momentum(const rigid_t *r, double p[3], double l[3])
{
    for (int a = 0; a < 3; a++) {
        p[a] = l[a] = 0.0;
    }
    for (int k = 0; k < r->nbodies; k++) {
        const rigid_body_t *b = &r->bodies[k];
        if (b->fixed) {
            continue;
        }
        double mv[3] = {b->mass * b->v[0], b->mass * b->v[1], b->mass * b->v[2]}, x[3];
        rv_cross(b->com, mv, x);
        for (int a = 0; a < 3; a++) {
            p[a] += mv[a];
            l[a] += x[a] + b->l[a];
        }
    }
}

double rigid_kinetic_energy(const rigid_t *r)
{
    double e = 0.0;
    for (int k = 0; k < r->nbodies; k++) {
        const rigid_body_t *b = &r->bodies[k];
        if (b->fixed) {
            continue;
        }
        double w[3];
        rigid_body_omega(b, w);
        e += 0.5 * b->mass * rv_dot(b->v, b->v) + 0.5 * rv_dot(w, b->l);
    }
    return e;
}
