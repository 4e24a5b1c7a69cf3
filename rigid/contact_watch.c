/* contact_watch.c — the energy watch of contacts: a contact force is passive
 * (a spring stores what the approach gives it and returns it, a dashpot and
 * friction only take), so no contact may leave its two partners with more
 * energy than they brought in. An explicit integrator whose sub-step does not
 * resolve the contact breaks this: Stoermer-Verlet on a linear spring with
 * h omega0 = 0.9 (a contact of 3.5 sub-steps, below the refusal at
 * h omega0 > 1 in integrator_verlet.c) returns up to 1.11 times the
 * approach speed with e = 1, depending on where in a sub-step the touch falls.
 *
 * What is watched, after every accepted integrator step (Verlet sub-step,
 * CVODE internal step; rigid_contact_watch), for every sphere-sphere pair of
 * two bodies and every sphere-wall pair (pairs.c; spheres of one body, e.g.
 * joined by a sintered connection, are no contact and never visited):
 *  - near a touch (gap below half the smallest radius, no overlap): the normal
 *    approach speed v_in of the contact point, kept from the last sample
 *    before the touch;
 *  - in contact: the pair's normal energy as a speed,
 *      v_E = sqrt(v_n^2 + 2 E_el(delta) / m_n)
 *    (kinetic energy of the normal relative motion of the contact point, of
 *    mass m_n along n, plus the elastic energy of the overlap, contact.c), and at the first sample after separation
 *    v_E = |v_n|, the rebound speed;
 *  - an allowance for what the other forces may add: the time integral, from
 *    the last sample before the touch, of the normal relative acceleration
 *    by all forces but this contact's (gravity, the held hydrodynamic load,
 *    lubrication, other contacts), plus bounds on what the bodies' rotation
 *    can add to the contact point's normal speed (|omega|^2 |arm| and
 *    |torque| / I_min times the arm's part normal to n, the torque without the
 *    one of this contact's normal force, which is its own answer; both zero for a
 *    single sphere, whose arm lies along n), plus the velocity jumps of the
 *    held-load correction at the start of a communication step and of the
 *    fusions of sticking (topology.c).
 * The watch stops the run when v_E > WATCH_TOL v_in + allowance, i.e. the
 * energy ratio (v_E / v_in)^2 exceeds WATCH_TOL^2 = 1.10 beyond what the other
 * forces explain. The restitution of the model (e <= 1) needs no part in the
 * test: a contact that returns more than it took is wrong whatever e is.
 *
 * Records live only between samples of one run: a contact already in
 * progress when the watch starts (at t0, after a state restore or a break-up
 * of a neck) is not judged, for want of its approach speed. The integrators
 * take the watch's first sample at the start of their step (watch_t NaN), so
 * that a contact that begins within the first sub-step is judged. A record is not
 * part of the saved state (state.c): a restore clears them
 * (rigid_contact_watch_reset), so the continuation is bit-identical and at
 * worst misses the contacts in progress at the restore. */
#include "rigid_internal.h"

#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* speed ratio above which a contact counts as gaining energy: 5% in speed,
 * 10% in energy; Verlet at h omega0 <= 0.6 stays below 1.03 (1D spring,
 * every phase of the touch), a resolved contact (>= 10 sub-steps) below 1.003 */
#define WATCH_TOL 1.05
/* speeds below this fraction of the pair's own speed scale (the bodies'
 * speeds and their rotation at the arms) are round-off, not energy: two
 * bodies that start touching at rest fall together, and their normal speed,
 * 1e-12 m/s against an approach speed of 0, was reported as infinite growth */
#define WATCH_FLOOR 1e-6
/* pairs closer than this fraction of the smallest radius are sampled */
#define WATCH_REACH 0.5

typedef struct {
    double t, dt;  /* time of this sample, and since the last one */
    int cursor;    /* where the last record was found */
    status_t st;
} watch_ctx_t;

void rigid_contact_watch_reset(rigid_t *r)
{
    r->nwatch = 0;
    r->watch_t = NAN;
    if (r->watch_kick != NULL) {
        memset(r->watch_kick, 0, 2 * sizeof(double) * (size_t)r->nspheres);
    }
}

void rigid_contact_watch_free(rigid_t *r)
{
    free(r->watch);
    free(r->watch_kick);
    r->watch = NULL;
    r->watch_kick = NULL;
    r->nwatch = r->watch_cap = 0;
}

void rigid_contact_watch_kick(rigid_t *r, int body, double dv, double dw)
{
    if (r->watch_kick != NULL) {
        r->watch_kick[2 * body] += dv;
        r->watch_kick[2 * body + 1] += dw;
    }
}

void rigid_contact_watch_fuse(rigid_t *r, int A, int B, int last, double dv, double dw)
{
    double *k = r->watch_kick;
    if (k == NULL) {
        return;
    }
    /* a point of either part has had its part's jumps, and now the fusion's */
    k[2 * A] = fmax(k[2 * A], k[2 * B]) + dv;
    k[2 * A + 1] = fmax(k[2 * A + 1], k[2 * B + 1]) + dw;
    if (last != B) {
        k[2 * B] = k[2 * last];
        k[2 * B + 1] = k[2 * last + 1];
    }
    k[2 * last] = k[2 * last + 1] = 0.0; /* a slot no body holds now */
}

/* The record of pair (i, j): searched from where the last one was found,
 * since the visitor meets the pairs in the same order every pass. */
static rigid_watch_t *find_record(rigid_t *r, watch_ctx_t *c, int i, int j)
{
    for (int k = 0; k < r->nwatch; k++) {
        int m = (c->cursor + k) % r->nwatch;
        if (r->watch[m].i == i && r->watch[m].j == j) {
            c->cursor = m + 1;
            return &r->watch[m];
        }
    }
    if (r->nwatch == r->watch_cap) {
        int cap = r->watch_cap > 0 ? 2 * r->watch_cap : 16;
        rigid_watch_t *w = realloc(r->watch, (size_t)cap * sizeof *w);
        if (w == NULL) {
            return NULL;
        }
        r->watch = w;
        r->watch_cap = cap;
    }
    rigid_watch_t *w = &r->watch[r->nwatch++];
    memset(w, 0, sizeof *w);
    w->i = i;
    w->j = j;
    w->phase = WATCH_NEW;
    return w;
}

/* What the motion of body b (not this contact's normal force) can add per
 * second to the normal speed of its material point at arm a: the centre's
 * acceleration along n by all forces (the caller removes the contact's own
 * part) is handled by the caller; here the rotation's share, bounded, by the
 * torque without the one of this contact's normal force fn_b on b (along n,
 * at the arm): that torque turns the body against the contact, it is the
 * contact's own answer, not another force (counted, it let an elastic
 * contact at the end of a rod return 2.25 times the energy unseen). */
static double rotation_rate(const rigid_t *r, const rigid_body_t *bodies, int b, const double a[3], const double n[3],
                            double fn_b)
{
    const rigid_body_t *bd = &bodies[b];
    if (bd->fixed) {
        return 0.0;
    }
    double w[3], axn[3], tq[3];
    rigid_body_omega(bd, w);
    rv_cross(a, n, axn);
    for (int k = 0; k < 3; k++) {
        tq[k] = r->bt[3 * b + k] - fn_b * axn[k];
    }
    const double imin = fmin(bd->inertia[0], fmin(bd->inertia[1], bd->inertia[2]));
    return rv_dot(w, w) * rv_norm(a) + (imin > 0.0 ? rv_norm(tq) / imin : 0.0) * rv_norm(axn);
}

static double body_inv_mass(const rigid_body_t *b) { return b->fixed ? 0.0 : 1.0 / b->mass; }

/* The speed of body b at the arm a: |v| + |omega| |a|. */
static double speed_scale(const rigid_body_t *bodies, int b, const double a[3])
{
    double w[3];
    rigid_body_omega(&bodies[b], w);
    return rv_norm(bodies[b].v) + rv_norm(w) * rv_norm(a);
}

static status_t watch_report(rigid_t *r, const rigid_watch_t *w, double vnow, double t, double dt)
{
    const int i = w->i, j = w->j, bi = r->spheres[i].body;
    char other[96];
    if (j >= 0) {
        snprintf(other, sizeof other, "body %d sphere %d", r->spheres[j].body, j);
    } else {
        snprintf(other, sizeof other, "the wall face %s", rigid_face_name(-1 - j));
    }
    const double tc = w->omega0 > 0.0 ? M_PI / w->omega0 : 0.0;
    const char *soft = r->cfg.contact_model == RIGID_CONTACT_HERTZ ? "a lower contacts.young_modulus"
                                                                     : "a longer contacts.contact_time";
    return log_msg(&r->log, STATUS_ERROR, RIGID_CAT,
                   "energy growth in the contact of body %d sphere %d and %s at t = %.9g s (touch at t = %.9g s): "
                   "the normal kinetic + elastic energy of the pair is %.3g times its value at the touch (speed "
                   "%.4g m/s against the approach speed %.4g m/s; allowed: %.2f times, plus %.3g m/s the other "
                   "forces can add); the contact time, about %.3g s, spans %.3g steps of %.3g s of the %s "
                   "integrator, which does not resolve it. Remedies: more rigid.substeps (or a shorter "
                   "communication step), a softer contact (%s), or rigid.integrator: cvode with "
                   "rigid.cvode_method: bdf",
                   bi, i, other, t, w->t_in, (vnow / w->v_in) * (vnow / w->v_in), vnow, w->v_in, WATCH_TOL * WATCH_TOL,
                   w->allow, tc, dt > 0.0 ? tc / dt : 0.0, dt, r->ops->name, soft);
}

static int watch_pair(rigid_t *r, const rigid_body_t *bodies, const rigid_pair_t *p, void *ctx)
{
    watch_ctx_t *c = ctx;
    if (c->st != STATUS_OK) {
        return 0;
    }
    const rigid_sphere_t *si = &r->spheres[p->i];
    rigid_watch_t *w = find_record(r, c, p->i, p->j);
    if (w == NULL) {
        c->st = log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "out of memory for %d contact watch records (%zu bytes)",
                        r->nwatch + 1, (size_t)(r->nwatch + 1) * sizeof(rigid_watch_t));
        return 0;
    }
    w->seen = 1;
    const int bi = si->body, bj = p->j >= 0 ? r->spheres[p->j].body : -1;
    const double vn = rv_dot(p->vrel, p->n); /* > 0: approaching */
    const double noise =
        WATCH_FLOOR * (speed_scale(bodies, bi, p->ai) + (bj >= 0 ? speed_scale(bodies, bj, p->aj) : 0.0));
    /* the other forces' share of the normal relative acceleration of the
     * centres, a_total + f_n (1/M_i + 1/M_j) (in contact the contact pushes i
     * back along n with f_n), and the rotation bounds; at every sample, near
     * or in contact, so that the interval up to the touch has the rate at
     * both its ends */
    const int touching = p->gap < 0.0;
    const double delta = -p->gap;
    double mn = 0.0, meff = 0.0, rstar = 0.0, omega0 = 0.0, fn = 0.0;
    if (touching) {
        rigid_contact_pair_mass(r, bodies, p, &mn, &meff, &rstar);
        fn = rigid_contact_normal_force(&r->cfg, delta, vn, mn, rstar, &omega0);
    }
    double atot = 0.0;
    for (int a = 0; a < 3; a++) {
        atot += (r->bf[3 * bi + a] * body_inv_mass(&bodies[bi]) -
                 (bj >= 0 ? r->bf[3 * bj + a] * body_inv_mass(&bodies[bj]) : 0.0)) *
                p->n[a];
    }
    const double rate = fabs(atot + (touching ? fn / meff : 0.0)) + rotation_rate(r, bodies, bi, p->ai, p->n, -fn) +
                        (bj >= 0 ? rotation_rate(r, bodies, bj, p->aj, p->n, fn) : 0.0);
    double kick = r->watch_kick[2 * bi] + r->watch_kick[2 * bi + 1] * rv_norm(p->ai);
    if (bj >= 0) {
        kick += r->watch_kick[2 * bj] + r->watch_kick[2 * bj + 1] * rv_norm(p->aj);
    }
    if (!touching) {
        if (w->phase == WATCH_TOUCHING) {
            /* the first sample after separation: the rebound speed */
            const double allow = w->allow + c->dt * fmax(rate, w->rate) + kick;
            if (-vn > WATCH_TOL * w->v_in + allow + noise) {
                w->allow = allow;
                c->st = watch_report(r, w, -vn, c->t, c->dt);
                return 0;
            }
        }
        w->phase = WATCH_NEAR;
        w->v_in = vn;
        w->t_in = c->t;
        w->allow = 0.0;
        w->omega0 = 0.0;
        w->rate = rate;
        return 0;
    }
    if (w->phase == WATCH_NEAR) {
        if (!(w->v_in > 0.0)) {
            w->v_in = 0.0; /* touched while not approaching: the other forces did it */
        }
        w->phase = WATCH_TOUCHING;
    } else if (w->phase == WATCH_NEW) {
        w->phase = WATCH_UNKNOWN; /* in contact when first seen: no approach speed to judge by */
    }
    if (w->phase != WATCH_TOUCHING) {
        return 0;
    }
    /* the rate of the last sample stands for the interval since (rectangles) */
    w->allow += c->dt * fmax(rate, w->rate) + kick;
    w->rate = rate;
    w->omega0 = fmax(w->omega0, omega0);
    const double e_el = rigid_contact_elastic_energy(&r->cfg, delta, mn, rstar);
    const double ve = sqrt(vn * vn + 2.0 * e_el / mn);
    if (ve > WATCH_TOL * w->v_in + w->allow + noise) {
        c->st = watch_report(r, w, ve, c->t, c->dt);
    }
    return 0;
}

status_t rigid_contact_watch(rigid_t *r, const rigid_body_t *bodies, double t)
{
    if (r->cfg.contact_model == RIGID_CONTACT_NONE) {
        return STATUS_OK;
    }
    if (r->watch_kick == NULL) {
        r->watch_kick = calloc(2 * (size_t)r->nspheres, sizeof(double));
        if (r->watch_kick == NULL) {
            return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "out of memory for the contact watch (%zu bytes)",
                           2 * sizeof(double) * (size_t)r->nspheres);
        }
    }
    watch_ctx_t c = {t, isnan(r->watch_t) ? 0.0 : t - r->watch_t, 0, STATUS_OK};
    for (int k = 0; k < r->nwatch; k++) {
        r->watch[k].seen = 0;
    }
    double rmin = INFINITY;
    for (int i = 0; i < r->nspheres; i++) {
        rmin = fmin(rmin, r->spheres[i].radius);
    }
    rigid_pairs_visit(r, bodies, (const double (*)[3])r->sx, WATCH_REACH * rmin, watch_pair, &c);
    /* pairs gone out of reach (or joined into one body) are forgotten */
    int n = 0;
    for (int k = 0; k < r->nwatch; k++) {
        if (r->watch[k].seen) {
            r->watch[n++] = r->watch[k];
        }
    }
    r->nwatch = n;
    memset(r->watch_kick, 0, 2 * sizeof(double) * (size_t)r->nspheres);
    r->watch_t = t;
    return c.st;
}
