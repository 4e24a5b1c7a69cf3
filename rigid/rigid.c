/* rigid.c — the public verbs: create (after rigid_config.c has validated the
 * configuration), step, getters, free.
 *
 * A communication step (rigid_step) reads like the algorithm:
 *   1. trapezoidal correction of the hydrodynamic load: the previous step
 *      held the old load F_n; now that F_{n+1} is known, v and L receive
 *      h_prev/2 (F_{n+1} - F_n) (and the matching torque), which makes the
 *      coupling second order for both integrators (for one sub-step and
 *      Verlet this is exactly the closing half-kick of Stoermer-Verlet);
 *   2. integrate over h (Verlet sub-steps or CVODE) with the load held
 *      (corrected first by the implicit coupling, implicit.c);
 *   3. forces at the new state; connection forces and torques (Eq. 8-9);
 *   4. break-up, then sticking; sections rebuilt if the topology changed.
 * Before cfg.release_time the step is hold_step's instead: free bodies move
 * on with their velocity and angular velocity, and no load acts; the first
 * step after the hold begins by judging the contacts made meanwhile for
 * sticking, as new contacts (rigid_stick_at_release).
 * The velocities reported after a step are therefore the predicted ones
 * (with the held load); step 1 of the next call corrects them. */
#include "rigid_internal.h"

#include <assert.h>
#include <stdlib.h>
#include <string.h>

void rigid_free(rigid_t *r)
{
    if (r == NULL) {
        return;
    }
    if (r->ops != NULL) {
        r->ops->free(r->integ);
    }
    rigid_contact_watch_free(r);
    free(r->scratch_bodies);
    free(r->pair_bound);
    free(r->pair_far);
    free(r->sx);
    free(r->sv);
    free(r->lub_rate);
    free(r->open_noted);
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
    status_t st = rigid_config_validate(cfg, log);
    if (st != STATUS_OK) {
        return st;
    }
    rigid_t *r = calloc(1, sizeof *r);
    if (r == NULL) {
        return log_msg(log, STATUS_ERROR, RIGID_CAT, "out of memory for the rigid component (%zu bytes)", sizeof *r);
    }
    if (log != NULL) {
        r->log = *log;
    }
    r->cfg = *cfg;
    r->cfg.spheres = NULL;
    r->cfg.bodies = NULL;
    r->cfg.connections = NULL;
    r->t = cfg->t0;
    r->watch_t = NAN;
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
    r->touch = calloc(ns * ns, 1); /* set by rigid_touch_init once the bodies are built */
    r->pair_bound = calloc(ns, sizeof *r->pair_bound);
    r->pair_far = calloc(ns * ns, 1);
    r->sf = calloc(3 * ns, sizeof(double));
    r->st = calloc(3 * ns, sizeof(double));
    r->bf = calloc(3 * ns, sizeof(double));
    r->bt = calloc(3 * ns, sizeof(double));
    r->sx = calloc(ns, sizeof *r->sx);
    r->sv = calloc(ns, sizeof *r->sv);
    r->lub_rate = calloc(ns, sizeof(double));
    r->open_noted = calloc(ns, 1);
    int *members = malloc(ns * sizeof(int)), *ids = malloc(ns * sizeof(int));
    double (*c)[3] = malloc(ns * sizeof *c), (*s)[3] = malloc(ns * sizeof *s), (*j)[9] = malloc(ns * sizeof *j);
    double *rad = malloc(ns * sizeof(double));
    if (!r->spheres || !r->bodies || !r->scratch_bodies || !r->conn || !r->section || !r->touch || !r->pair_bound ||
        !r->pair_far || !r->sf || !r->st || !r->bf ||
        !r->bt || !r->sx || !r->sv || !r->lub_rate || !r->open_noted || !members || !ids || !c || !s || !j || !rad) {
        st = log_msg(log, STATUS_ERROR, RIGID_CAT,
                     "out of memory for the arrays of %zu spheres and %d connections (about %.4g MB: the touch "
                     "and body pair tables grow as spheres^2)",
                     ns, r->conn_cap,
                     ((double)ns * (sizeof *r->spheres + 2 * sizeof *r->bodies + 21 * sizeof(double) + 2 * ns) +
                      (double)r->conn_cap * (sizeof *r->conn + ns)) / 1e6);
        goto cleanup;
    }
    if ((st = rigid_config_check_connected(cfg, log, members, ids)) != STATUS_OK) {
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
            memcpy(sp->c0, c[k], sizeof sp->c0);
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
        bd->kinematic = bc->fixed == RIGID_PRESCRIBED;
        memset(bd->kv, 0, sizeof bd->kv);
        memset(bd->kw, 0, sizeof bd->kw);
        memset(bd->kp, 0, sizeof bd->kp);
        if (bd->kinematic) {
            /* the fluid's pivot: the r^3-weighted centroid of the sphere centres */
            double w = 0.0;
            for (int k = 0; k < nm; k++) {
                const double r3 = rad[k] * rad[k] * rad[k];
                for (int a = 0; a < 3; a++) {
                    bd->kp[a] += r3 * c[k][a];
                }
                w += r3;
            }
            for (int a = 0; a < 3; a++) {
                bd->kp[a] /= w;
            }
            memcpy(bd->kv, bc->velocity, sizeof bd->kv);
            memcpy(bd->kw, bc->angular_velocity, sizeof bd->kw);
        }
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
    rigid_touch_init(r);
    r->ops = cfg->integrator == RIGID_CVODE ? &rigid_cvode_ops : &rigid_verlet_ops;
    if ((st = r->ops->create(r, &r->integ)) != STATUS_OK) {
        r->ops = NULL;
        goto cleanup;
    }
    /* connection loads at t0 (with zero hydrodynamic load); none while the
     * bodies are held from t0 on (release_time, hold_step: the connections
     * carry nothing), so the first output row agrees with the held ones */
    if (rigid_forces(r, r->bodies, 0.0, NULL) >= 0 && !(cfg->release_time > 0.0 && cfg->release_time > cfg->t0)) {
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

/* Whether the step of length h from t is a hold (rigid_config_t.release_time):
 * one whose middle is before the release time. A release time of 0 (the
 * default) holds nothing, also on a clock that starts before 0 (an FMI master's
 * negative startTime: every step before t = 0 was held, without load or
 * gravity and without a word). */
static int held_step(const rigid_t *r, double t, double h)
{
    return r->cfg.release_time > 0.0 && t < r->cfg.release_time - 0.5 * h;
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

void rigid_get_sphere_applied_load(const rigid_t *r, int sphere, double force[3], double torque[3])
{
    assert(r != NULL && sphere >= 0 && sphere < r->nspheres);
    const rigid_sphere_t *s = &r->spheres[sphere];
    /* the last step was a hold (hold_step): nothing was applied */
    const int held = r->h_prev > 0.0 && held_step(r, r->t - r->h_prev, r->h_prev);
    for (int a = 0; a < 3; a++) {
        force[a] = held ? 0.0 : s->load_f[a] + s->imp_f[a];
        torque[a] = held ? 0.0 : s->load_t[a] + s->imp_t[a];
    }
}

void rigid_set_sphere_drag(rigid_t *r, int sphere, double zt, double zr)
{
    assert(r != NULL && sphere >= 0 && sphere < r->nspheres);
    r->spheres[sphere].drag_t = zt > 0.0 && isfinite(zt) ? zt : 0.0;
    r->spheres[sphere].drag_r = zr > 0.0 && isfinite(zr) ? zr : 0.0;
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
        /* a jump the contact watch must allow for (|dw| bounded by the
         * smallest principal moment) */
        const double imin = fmin(b->inertia[0], fmin(b->inertia[1], b->inertia[2]));
        double dl[3];
        for (int a = 0; a < 3; a++) {
            dl[a] = half * (m[a] + dt[a]);
        }
        rigid_contact_watch_kick(r, s->body, half * rv_norm(df) / b->mass, imin > 0.0 ? rv_norm(dl) / imin : 0.0);
    }
}

/* A free body that reaches an inlet or outlet face stays in the domain: the
 * face holds it as a wall would (contact, no lubrication film) and it
 * blocks part of the flow there. Said once per body (a user who expects it
 * to leave with the flow would otherwise see it stop without a word). */
static void note_open_faces(rigid_t *r)
{
    const rigid_config_t *cfg = &r->cfg;
    int open = 0;
    for (int face = 0; face < 6; face++) {
        open |= cfg->walls[face / 2][face % 2] && cfg->wall_kind[face / 2][face % 2] == RIGID_WALL_OPEN;
    }
    for (int i = 0; i < r->nspheres && open; i++) {
        const rigid_sphere_t *s = &r->spheres[i];
        if (r->open_noted[i] || r->bodies[s->body].fixed) {
            continue;
        }
        const double *c = r->sx[i]; /* the centres of the force evaluation at the step's end */
        for (int face = 0; face < 6; face++) {
            const int ax = face / 2, side = face % 2;
            if (!cfg->walls[ax][side] || cfg->wall_kind[ax][side] != RIGID_WALL_OPEN) {
                continue;
            }
            const double gap = (side == 0 ? c[ax] - cfg->box_lo[ax] : cfg->box_hi[ax] - c[ax]) - s->radius;
            if (!(gap <= 0.0)) {
                continue;
            }
            log_msg(&r->log, STATUS_WARNING, RIGID_CAT,
                    "body %d (sphere %d) reached the face %s at t=%.9g s, an inlet or outlet: bodies do not leave "
                    "the domain, the face holds it as a wall would (contact, no lubrication film) and it blocks part "
                    "of the flow there; to follow it further, make the domain longer",
                    s->body, i, rigid_face_name(face), r->t);
            for (int j = 0; j < r->nspheres; j++) {
                r->open_noted[j] |= r->spheres[j].body == s->body;
            }
            break;
        }
    }
}

/* The forces at the state a step ended in (r->t already advanced): a
 * non-finite force or a fault (a deep overlap, a wall without a contact
 * model) stops the run. */
static status_t forces_after_step(rigid_t *r, double h_kick)
{
    const int rc = rigid_forces(r, r->bodies, h_kick, NULL);
    if (rc < 0) {
        return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "non-finite force at t=%.9g s after the step", r->t);
    }
    return rc > 0 ? rigid_fault_report(r, &r->fault, r->t) : STATUS_OK;
}

/* A step before the release time (rigid_config_t.release_time): every free
 * body translates with v and turns with its angular velocity w about the
 * centre of mass, both kept constant (the rotation is exact: q turned by
 * |w| h about w, and L = I_world w at the new attitude). No load acts and no
 * load is held over for the step after, no implicit correction is made or
 * owed, connections carry nothing and do not break, nothing sticks (a pair
 * that comes into contact is judged at the release, rigid_step); the contact
 * state is followed, and a deep overlap is a fault as in any step. */
static status_t hold_step(rigid_t *r, double h)
{
    rigid_kinematic_advance(r, h);
    for (int b = 0; b < r->nbodies; b++) {
        rigid_body_t *bd = &r->bodies[b];
        if (bd->fixed) {
            continue;
        }
        double w[3], iw[9], m[9];
        rigid_body_omega(bd, w);
        if (rigid_body_turn(bd, w, h, m)) {
            rigid_body_inertia_world(bd, iw);
            rm_mul(iw, w, bd->l);
        }
        for (int a = 0; a < 3; a++) {
            bd->com[a] += h * bd->v[a];
        }
    }
    for (int i = 0; i < r->nspheres; i++) {
        rigid_sphere_t *s = &r->spheres[i];
        memset(s->imp_f, 0, sizeof s->imp_f);
        memset(s->imp_t, 0, sizeof s->imp_t);
        memset(s->debt_f, 0, sizeof s->debt_f);
        memset(s->debt_t, 0, sizeof s->debt_t);
    }
    r->have_prev = 0;
    r->h_prev = h;
    r->t += h;
    status_t st = forces_after_step(r, 0.0);
    if (st != STATUS_OK) {
        return st;
    }
    for (int k = 0; k < r->nconn; k++) {
        memset(r->conn[k].force, 0, sizeof r->conn[k].force);
        memset(r->conn[k].torque, 0, sizeof r->conn[k].torque);
    }
    rigid_touch_update(r);
    note_open_faces(r);
    return STATUS_OK;
}

status_t rigid_step(rigid_t *r, double h)
{
    assert(r != NULL);
    if (!(h > 0.0) || !isfinite(h)) {
        return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "step length %g s must be > 0 and finite (t=%.9g s)", h,
                       r->t);
    }
    if (held_step(r, r->t, h)) {
        return hold_step(r, h);
    }
    status_t st = STATUS_OK;
    if (r->h_prev > 0.0 && held_step(r, r->t - r->h_prev, r->h_prev)) {
        /* the release: contacts made while held are judged for sticking now */
        int stuck = 0;
        if ((st = rigid_stick_at_release(r, &stuck)) != STATUS_OK) {
            return st;
        }
        if (stuck && (st = rigid_sections_update(r)) != STATUS_OK) {
            return st;
        }
    }
    if (r->have_prev && r->cfg.load_correction) {
        load_correction(r);
    }
    st = rigid_implicit_load(r, h);
    if (st != STATUS_OK) {
        return st;
    }
    /* the integrator moves the prescribed bodies with the free ones, each force
     * evaluation seeing them where they are at its time (before, they sat at the
     * step's midpoint: a contact with one was off by half its step's travel) */
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
    if ((st = forces_after_step(r, rigid_lub_kick(r, h))) != STATUS_OK) {
        return st;
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
    note_open_faces(r);
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

long rigid_force_evaluations(const rigid_t *r) { return r->nforces; }

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
