/* state.c — serialisation of the complete state for bit-identical restart.
 *
 * Layout (native byte order and struct layout: a state is read back by the
 * same build, as FMI 2.0 serialised FMU states are): a header with a magic
 * number, a layout version and the counts, then the sphere array (shares,
 * body ids, current and held loads), the body array (com, q, v, L, mass,
 * principal inertia, fixed) and the connection array (pair, limits, intact,
 * last force and torque), then the nspheres^2 touch flags of the sticking
 * rule. Derived data (sections, scratch) is rebuilt on
 * restore, and the contact watch starts afresh (contact_watch.c); CVODE is re-initialised at the start of every step anyway, so the
 * continuation after a restore is bit-identical to the uninterrupted run.
 *
 * A restore checks everything it reads before it uses any of it: the counts
 * against the instance and the buffer (exactly the bytes they need), each
 * sphere (what the scene fixes: radius, scene body, density, mass and volume
 * shares, as in this instance; its body one of the state's; the rest
 * finite), each body (finite, a unit quaternion, mass the sum of its
 * spheres' shares, positive inertia, at least one sphere), each connection
 * (two different spheres, limits >= 0, intact 0 or 1, finite loads) and the
 * touch flags (0 or 1). A refused state names the part that is wrong and
 * leaves the instance as it was. */
#include "rigid_internal.h"

#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define RIGID_STATE_MAGIC 0x52494744u /* "RIGD" */
#define RIGID_STATE_VERSION 3u /* 2: the implicit coupling's debt_f, debt_t; 3: prescribed bodies' motion */

static size_t state_bytes(int ns, int nb, int nc)
{
    return sizeof(rigid_state_header_t) + (size_t)ns * sizeof(rigid_sphere_t) + (size_t)nb * sizeof(rigid_body_t) +
           (size_t)nc * sizeof(rigid_conn_t) + (size_t)ns * (size_t)ns;
}

size_t rigid_state_size(const rigid_t *r) { return state_bytes(r->nspheres, r->nbodies, r->nconn); }

status_t rigid_state_save(const rigid_t *r, void *buf, size_t size)
{
    size_t need = rigid_state_size(r);
    if (buf == NULL || size < need) {
        return log_msg((log_t *)&r->log, STATUS_ERROR, RIGID_CAT, "state buffer of %zu bytes too small (need %zu)",
                       size, need);
    }
    rigid_state_header_t h;
    memset(&h, 0, sizeof h);
    h.magic = RIGID_STATE_MAGIC;
    h.version = RIGID_STATE_VERSION;
    h.nspheres = r->nspheres;
    h.nbodies = r->nbodies;
    h.nconn = r->nconn;
    h.integrator = (int32_t)r->cfg.integrator;
    h.have_prev = r->have_prev;
    h.t = r->t;
    h.h_prev = r->h_prev;
    unsigned char *p = buf;
    memcpy(p, &h, sizeof h);
    p += sizeof h;
    memcpy(p, r->spheres, (size_t)r->nspheres * sizeof(rigid_sphere_t));
    p += (size_t)r->nspheres * sizeof(rigid_sphere_t);
    memcpy(p, r->bodies, (size_t)r->nbodies * sizeof(rigid_body_t));
    p += (size_t)r->nbodies * sizeof(rigid_body_t);
    memcpy(p, r->conn, (size_t)r->nconn * sizeof(rigid_conn_t));
    p += (size_t)r->nconn * sizeof(rigid_conn_t);
    memcpy(p, r->touch, (size_t)r->nspheres * (size_t)r->nspheres);
    return STATUS_OK;
}

/* ------------------------------------------------------------------------ */
/* Checks of a state's contents (rigid_state_restore)                         */

/* A refused state, with what is wrong in it (common/status.h). */
#define corrupt(r, ...) log_state_corrupt(&(r)->log, RIGID_CAT, __VA_ARGS__)

/* A run of doubles of a record, by name, for the messages. */
typedef struct {
    const char *name;
    size_t offset, n;
} state_run_t;

static const char *first_not_finite(const void *rec, const state_run_t *runs, size_t nruns)
{
    for (size_t m = 0; m < nruns; m++) {
        if (!all_finite((const double *)(const void *)((const char *)rec + runs[m].offset), runs[m].n)) {
            return runs[m].name;
        }
    }
    return NULL;
}

_Static_assert(offsetof(rigid_sphere_t, debt_t) == offsetof(rigid_sphere_t, load_f) + 23 * sizeof(double),
               "check_sphere reads load_f .. debt_t as one run of doubles");

static status_t check_sphere(const rigid_t *r, int i, const rigid_sphere_t *sp, int nbodies)
{
    const rigid_sphere_t *mine = &r->spheres[i];
    if (memcmp(&sp->radius, &mine->radius, sizeof sp->radius) != 0 || sp->orig_body != mine->orig_body ||
        memcmp(&sp->density, &mine->density, sizeof sp->density) != 0 ||
        memcmp(&sp->mass, &mine->mass, sizeof sp->mass) != 0 ||
        memcmp(&sp->volume, &mine->volume, sizeof sp->volume) != 0 || memcmp(sp->c0, mine->c0, sizeof sp->c0) != 0) {
        return corrupt(r, "sphere %d: radius %.17g m, scene body %d, density %.17g kg/m^3, mass %.17g kg, volume "
                       "%.17g m^3 (or its scene centre); this scene: %.17g, %d, %.17g, %.17g, %.17g", i, sp->radius, sp->orig_body,
                       sp->density, sp->mass, sp->volume, mine->radius, mine->orig_body, mine->density, mine->mass,
                       mine->volume);
    }
    if (sp->body < 0 || sp->body >= nbodies) {
        return corrupt(r, "sphere %d belongs to body %d; allowed: 0 to %d, the state's bodies", i, sp->body,
                       nbodies - 1);
    }
    static const state_run_t runs[] = {
        {"centre in its body's frame", offsetof(rigid_sphere_t, p), 3},
        {"share centroid", offsetof(rigid_sphere_t, s), 3},
        {"share inertia", offsetof(rigid_sphere_t, j), 9},
        {"loads", offsetof(rigid_sphere_t, load_f), 26},
    };
    const char *bad = first_not_finite(sp, runs, sizeof runs / sizeof runs[0]);
    if (bad != NULL) {
        return corrupt(r, "sphere %d: %s not finite", i, bad);
    }
    return STATUS_OK;
}

/* A body, given the sum of its spheres' mass shares and their number. */
static status_t check_body(const rigid_t *r, int b, const rigid_body_t *bd, double share_mass, int members)
{
    static const state_run_t runs[] = {
        {"centre of mass", offsetof(rigid_body_t, com), 3},
        {"orientation", offsetof(rigid_body_t, q), 4},
        {"velocity", offsetof(rigid_body_t, v), 3},
        {"angular momentum", offsetof(rigid_body_t, l), 3},
    };
    const char *bad = first_not_finite(bd, runs, sizeof runs / sizeof runs[0]);
    if (bad != NULL) {
        return corrupt(r, "body %d: %s not finite", b, bad);
    }
    const double qn = sqrt(bd->q[0] * bd->q[0] + bd->q[1] * bd->q[1] + bd->q[2] * bd->q[2] + bd->q[3] * bd->q[3]);
    if (!(fabs(qn - 1.0) <= 1e-6)) {
        return corrupt(r, "body %d: its orientation quaternion has norm %.17g, not 1", b, qn);
    }
    if (members == 0) {
        return corrupt(r, "body %d has no sphere", b);
    }
    if (!(fabs(bd->mass - share_mass) <= 1e-9 * share_mass)) {
        return corrupt(r, "body %d: mass %.17g kg; its %d spheres' shares add up to %.17g kg", b, bd->mass, members,
                       share_mass);
    }
    for (int a = 0; a < 3; a++) {
        if (!(isfinite(bd->inertia[a]) && bd->inertia[a] > 0.0)) {
            return corrupt(r, "body %d: principal moment of inertia %d is %.17g; allowed: finite and > 0", b, a,
                           bd->inertia[a]);
        }
    }
    if (bd->fixed != 0 && bd->fixed != 1) {
        return corrupt(r, "body %d: fixed = %d; allowed: 0 or 1", b, bd->fixed);
    }
    if (bd->kinematic != 0 && bd->kinematic != bd->fixed) {
        return corrupt(r, "body %d: kinematic = %d; allowed: 0, or 1 for a fixed body", b, bd->kinematic);
    }
    for (int a = 0; a < 3; a++) {
        if (!isfinite(bd->kv[a]) || !isfinite(bd->kw[a]) || !isfinite(bd->kp[a])) {
            return corrupt(r, "body %d: prescribed motion not finite", b);
        }
    }
    return STATUS_OK;
}

static status_t check_conn(const rigid_t *r, int k, const rigid_conn_t *c)
{
    if (c->a < 0 || c->a >= r->nspheres || c->b < 0 || c->b >= r->nspheres || c->a == c->b) {
        return corrupt(r, "connection %d joins spheres %d and %d; allowed: two different spheres of 0 to %d", k, c->a,
                       c->b, r->nspheres - 1);
    }
    if (!(c->max_normal >= 0.0 && c->max_shear >= 0.0 && c->max_torque >= 0.0) || (c->intact != 0 && c->intact != 1)) {
        return corrupt(r, "connection %d: limits %g N, %g N, %g N m (allowed: >= 0, inf for none), intact %d (0 or 1)",
                       k, c->max_normal, c->max_shear, c->max_torque, c->intact);
    }
    if (!all_finite(c->force, 3) || !all_finite(c->torque, 3) || !(isfinite(c->gap0) && c->gap0 >= 0.0)) {
        return corrupt(r, "connection %d: its force, torque or contact-free distance (%g m) is not finite or "
                       "negative", k, c->gap0);
    }
    return STATUS_OK;
}

/* Everything after the header: the records from the buffer one at a time
 * (the buffer need not be aligned). */
static status_t check_records(const rigid_t *r, const rigid_state_header_t *h, const unsigned char *p)
{
    const int ns = h->nspheres, nb = h->nbodies;
    double *mass = calloc((size_t)nb, sizeof *mass);
    int *members = calloc((size_t)nb, sizeof *members);
    status_t st = STATUS_OK;
    if (mass == NULL || members == NULL) {
        st = log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "out of memory checking a state of %d bodies (%zu bytes)", nb,
                     (size_t)nb * (sizeof *mass + sizeof *members));
        goto done;
    }
    for (int i = 0; i < ns && st == STATUS_OK; i++, p += sizeof(rigid_sphere_t)) {
        rigid_sphere_t sp;
        memcpy(&sp, p, sizeof sp);
        st = check_sphere(r, i, &sp, nb);
        if (st == STATUS_OK) {
            mass[sp.body] += sp.mass;
            members[sp.body]++;
        }
    }
    for (int b = 0; b < nb && st == STATUS_OK; b++, p += sizeof(rigid_body_t)) {
        rigid_body_t bd;
        memcpy(&bd, p, sizeof bd);
        st = check_body(r, b, &bd, mass[b], members[b]);
    }
    for (int k = 0; k < h->nconn && st == STATUS_OK; k++, p += sizeof(rigid_conn_t)) {
        rigid_conn_t c;
        memcpy(&c, p, sizeof c);
        st = check_conn(r, k, &c);
    }
    for (size_t k = 0; k < (size_t)ns * (size_t)ns && st == STATUS_OK; k++) {
        if (p[k] > 1) {
            st = corrupt(r, "the touch flag of spheres %zu and %zu is %u; allowed: 0 or 1", k / (size_t)ns,
                         k % (size_t)ns, p[k]);
        }
    }
done:
    free(mass);
    free(members);
    return st;
}

status_t rigid_state_restore(rigid_t *r, const void *buf, size_t size)
{
    rigid_state_header_t h;
    if (buf == NULL || size < sizeof h) {
        return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "state of %zu bytes is too short", size);
    }
    memcpy(&h, buf, sizeof h);
    if (h.magic != RIGID_STATE_MAGIC || h.version != RIGID_STATE_VERSION) {
        return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "not a rigid state (magic %#x version %u, expected %#x %u)",
                       h.magic, h.version, RIGID_STATE_MAGIC, RIGID_STATE_VERSION);
    }
    if (h.nspheres != r->nspheres || h.integrator != (int32_t)r->cfg.integrator || h.nbodies < 1 ||
        h.nbodies > r->nspheres || h.nconn < 0) {
        return log_msg(&r->log, STATUS_ERROR, RIGID_CAT,
                       "state does not fit this instance: %d spheres, integrator %d (instance: %d spheres, "
                       "integrator %d)",
                       h.nspheres, h.integrator, r->nspheres, (int)r->cfg.integrator);
    }
    size_t need = state_bytes(h.nspheres, h.nbodies, h.nconn);
    if (size < need) {
        return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "state of %zu bytes truncated (need %zu)", size, need);
    }
    if (size > need) {
        return corrupt(r, "%zu bytes for the %zu its counts take (%d bodies, %d connections)", size, need, h.nbodies,
                       h.nconn);
    }
    if (!isfinite(h.t) || !(isfinite(h.h_prev) && h.h_prev >= 0.0) || (h.have_prev != 0 && h.have_prev != 1)) {
        return corrupt(r, "time %g s, previous step %g s, have_prev %d (allowed: finite, >= 0, 0 or 1)", h.t,
                       h.h_prev, h.have_prev);
    }
    status_t st = check_records(r, &h, (const unsigned char *)buf + sizeof h);
    if (st != STATUS_OK) {
        return st;
    }
    if (h.nconn > r->conn_cap) {
        rigid_conn_t *nc = realloc(r->conn, (size_t)h.nconn * sizeof *nc);
        if (nc == NULL) {
            return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "out of memory restoring %d connections (%zu bytes)",
                           (int)h.nconn, (size_t)h.nconn * sizeof *nc);
        }
        r->conn = nc;
        unsigned char *sec = realloc(r->section, (size_t)h.nconn * (size_t)r->nspheres);
        if (sec == NULL) {
            return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "out of memory restoring the sections of %d connections (%zu bytes)",
                           (int)h.nconn, (size_t)h.nconn * (size_t)r->nspheres);
        }
        r->section = sec;
        r->conn_cap = h.nconn;
    }
    const unsigned char *p = (const unsigned char *)buf + sizeof h;
    memcpy(r->spheres, p, (size_t)h.nspheres * sizeof(rigid_sphere_t));
    p += (size_t)h.nspheres * sizeof(rigid_sphere_t);
    memcpy(r->bodies, p, (size_t)h.nbodies * sizeof(rigid_body_t));
    p += (size_t)h.nbodies * sizeof(rigid_body_t);
    memcpy(r->conn, p, (size_t)h.nconn * sizeof(rigid_conn_t));
    p += (size_t)h.nconn * sizeof(rigid_conn_t);
    memcpy(r->touch, p, (size_t)h.nspheres * (size_t)h.nspheres);
    rigid_contact_watch_reset(r); /* its records belong to the run that went on (contact_watch.c) */
    r->nbodies = h.nbodies;
    r->nconn = h.nconn;
    r->t = h.t;
    r->h_prev = h.h_prev;
    r->have_prev = h.have_prev;
    return rigid_sections_update(r);
}
