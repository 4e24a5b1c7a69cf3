/* topology.c — break-up and sticking: the events that change which spheres
 * form a body.
 *
 * Break-up (after each communication step): a connection breaks when its
 * tensile normal force F_c.n (n from sphere a to b, positive = pulling the
 * spheres apart) exceeds max_normal, its shear force |F_c - (F_c.n) n| exceeds
 * max_shear, or |T_c| exceeds max_torque (a limit of 0 or +inf disables that
 * criterion; compression never breaks). A body whose structure graph
 * (connection.c) then falls apart becomes one body per connected component,
 * each moving with the rigid motion of the old body at its new centre of mass:
 *   v_k = v + omega x (com_k - com),  L_k = I_k omega.
 * Sum M_k v_k = M v because the masses' first moments about com cancel, and
 * the angular momenta add up to the old one for the same reason, so momentum
 * and angular momentum are conserved to round-off.
 *
 * Sticking (paper Fig. 10): two spheres of different bodies that come into
 * contact (touch or overlap now, did not at the end of the previous step, so
 * the speed is the impact speed, not the speed at maximum compression of a
 * bounce) with a relative normal speed |(v_i - v_j).n| < stick_speed at the
 * contact point fuse their bodies into one (perfectly inelastic):
 *   v = (M_A v_A + M_B v_B)/M,
 *   L = sum_k [L_k + M_k (com_k - com) x (v_k - v)],
 * which conserves momentum and angular momentum exactly; a connection
 * joins the two spheres (limits cfg.fuse_max_*), so the fused body can break
 * there again. It is the pair's own broken connection from an earlier
 * sticking if there is one, else a broken sticking connection whose spheres
 * have parted, else a new one (stick_slot): a pair that sticks and breaks
 * again and again keeps one connection, and the connections stay bounded by
 * the scene's plus the pairs that touch at once. Mass properties are the sum
 * of the spheres' fixed shares (the contact overlap is not re-sintered), so
 * mass is conserved exactly. A body
 * that sticks to a fixed body becomes part of the fixed body.
 *
 * New bodies are appended; when two bodies fuse the last body moves into the
 * freed slot. Body ids are therefore not stable; sphere ids are. */
#include "rigid_internal.h"

#include <stdlib.h>
#include <string.h>

typedef struct {
    int *members;
    double (*p)[3], (*s)[3], (*j)[9];
} world_buf_t;

static status_t buf_alloc(rigid_t *r, world_buf_t *w)
{
    size_t n = (size_t)r->nspheres;
    w->members = malloc(n * sizeof(int));
    w->p = malloc(n * sizeof *w->p);
    w->s = malloc(n * sizeof *w->s);
    w->j = malloc(n * sizeof *w->j);
    if (!w->members || !w->p || !w->s || !w->j) {
        return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "out of memory for the break-up/sticking buffers of %zu spheres (%zu bytes)", n, n * (sizeof(int) + sizeof *w->p + sizeof *w->s + sizeof *w->j));
    }
    return STATUS_OK;
}

static void buf_free(world_buf_t *w)
{
    free(w->members);
    free(w->p);
    free(w->s);
    free(w->j);
}

/* World-frame share data of sphere i into slot k. */
static void world_of(const rigid_t *r, int i, world_buf_t *w, int k)
{
    const rigid_sphere_t *s = &r->spheres[i];
    const rigid_body_t *b = &r->bodies[s->body];
    double R[9], d[3];
    rq_matrix(b->q, R);
    rm_mul(R, s->p, d);
    for (int a = 0; a < 3; a++) {
        w->p[k][a] = b->com[a] + d[a];
    }
    rm_mul(R, s->s, d);
    for (int a = 0; a < 3; a++) {
        w->s[k][a] = b->com[a] + d[a];
    }
    for (int x = 0; x < 3; x++) {
        for (int y = 0; y < 3; y++) {
            double acc = 0.0;
            for (int u = 0; u < 3; u++) {
                for (int v = 0; v < 3; v++) {
                    acc += R[3 * x + u] * s->j[3 * u + v] * R[3 * y + v];
                }
            }
            w->j[k][3 * x + y] = acc;
        }
    }
    w->members[k] = i;
}

static int edge_between(const rigid_t *r, int i, int j)
{
    for (int k = 0; k < r->nconn; k++) {
        const rigid_conn_t *c = &r->conn[k];
        if (c->intact && ((c->a == i && c->b == j) || (c->a == j && c->b == i))) {
            return 1;
        }
    }
    return rigid_bonded(r, i, j);
}

/* Splits body bi into its connected components (if more than one). */
status_t rigid_regroup(rigid_t *r, int bi)
{
    int ns = r->nspheres;
    int *comp = malloc((size_t)ns * sizeof(int)), *stack = malloc((size_t)ns * sizeof(int));
    world_buf_t w = {0};
    status_t st = buf_alloc(r, &w);
    if (comp == NULL || stack == NULL) {
        st = log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "out of memory for the break-up component lists of %d spheres (%zu bytes)", ns, 2 * (size_t)ns * sizeof(int));
    }
    if (st != STATUS_OK) {
        goto cleanup;
    }
    int ncomp = 0;
    for (int i = 0; i < ns; i++) {
        comp[i] = -1;
    }
    for (int i = 0; i < ns; i++) {
        if (r->spheres[i].body != bi || comp[i] >= 0) {
            continue;
        }
        int top = 0;
        stack[top++] = i;
        comp[i] = ncomp;
        while (top > 0) {
            int u = stack[--top];
            for (int v = 0; v < ns; v++) {
                if (comp[v] < 0 && r->spheres[v].body == bi && edge_between(r, u, v)) {
                    comp[v] = ncomp;
                    stack[top++] = v;
                }
            }
        }
        ncomp++;
    }
    if (ncomp <= 1) {
        goto cleanup;
    }
    rigid_body_t old = r->bodies[bi];
    double w0[3] = {0, 0, 0};
    if (!old.fixed) {
        rigid_body_omega(&old, w0);
    }
    /* world data of all members first: rebuilding a body changes the frame */
    int nm = 0;
    for (int i = 0; i < ns; i++) {
        if (r->spheres[i].body == bi) {
            world_of(r, i, &w, nm++);
        }
    }
    world_buf_t sub = {0};
    if (buf_alloc(r, &sub) != STATUS_OK) {
        buf_free(&sub);
        st = log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "out of memory for the break-up buffers of %d spheres", r->nspheres);
        goto cleanup;
    }
    for (int c = 0; c < ncomp; c++) {
        int id = c == 0 ? bi : r->nbodies++;
        int k = 0;
        for (int m = 0; m < nm; m++) {
            if (comp[w.members[m]] == c) {
                sub.members[k] = w.members[m];
                memcpy(sub.p[k], w.p[m], sizeof w.p[m]);
                memcpy(sub.s[k], w.s[m], sizeof w.s[m]);
                memcpy(sub.j[k], w.j[m], sizeof w.j[m]);
                k++;
            }
        }
        rigid_body_build(r, id, sub.members, k, sub.p, sub.s, sub.j);
        rigid_body_t *nb = &r->bodies[id];
        nb->fixed = old.fixed;
        nb->kinematic = old.kinematic; /* a prescribed body's pieces keep its motion */
        memcpy(nb->kv, old.kv, sizeof nb->kv);
        memcpy(nb->kw, old.kw, sizeof nb->kw);
        memcpy(nb->kp, old.kp, sizeof nb->kp);
        double rr[3], u[3], iw[9];
        rv_sub(nb->com, old.com, rr);
        rv_cross(w0, rr, u);
        rigid_body_inertia_world(nb, iw);
        rm_mul(iw, w0, nb->l);
        for (int a = 0; a < 3; a++) {
            nb->v[a] = old.fixed ? 0.0 : old.v[a] + u[a];
        }
    }
    buf_free(&sub);
cleanup:
    free(comp);
    free(stack);
    buf_free(&w);
    return st;
}

static int limit_exceeded(double value, double limit) { return limit > 0.0 && isfinite(limit) && value > limit; }

status_t rigid_breakup(rigid_t *r, int *changed)
{
    *changed = 0;
    int nb0 = r->nbodies;
    unsigned char *hit = calloc((size_t)r->nspheres, 1);
    if (hit == NULL) {
        return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "out of memory for the break-up flags of %d spheres (%d bytes)", r->nspheres, r->nspheres);
    }
    for (int k = 0; k < r->nconn; k++) {
        rigid_conn_t *c = &r->conn[k];
        if (!c->intact) {
            continue;
        }
        double pc[3], n[3];
        rigid_connection_point(r, c->a, c->b, r->sx[c->a], r->sx[c->b], pc, n);
        double fn = rv_dot(c->force, n), sh[3];
        for (int a = 0; a < 3; a++) {
            sh[a] = c->force[a] - fn * n[a];
        }
        double fs = rv_norm(sh), tq = rv_norm(c->torque);
        const char *why = NULL;
        double val = 0.0, lim = 0.0;
        if (limit_exceeded(fn, c->max_normal)) {
            why = "tensile force", val = fn, lim = c->max_normal;
        } else if (limit_exceeded(fs, c->max_shear)) {
            why = "shear force", val = fs, lim = c->max_shear;
        } else if (limit_exceeded(tq, c->max_torque)) {
            why = "torque", val = tq, lim = c->max_torque;
        }
        if (why != NULL) {
            c->intact = 0;
            /* the sintering overlap of the neck is no contact penetration */
            double dd[3];
            rv_sub(r->sx[c->b], r->sx[c->a], dd);
            const double dist = rv_norm(dd);
            c->gap0 = dist < r->spheres[c->a].radius + r->spheres[c->b].radius ? dist : 0.0;
            hit[r->spheres[c->a].body] = 1;
            *changed = 1;
            log_msg(&r->log, STATUS_OK, RIGID_CAT,
                    "connection %d (spheres %d-%d, body %d) broke at t=%.9g s: %s %g exceeds the limit %g", k, c->a,
                    c->b, r->spheres[c->a].body, r->t, why, val, lim);
        }
    }
    status_t st = STATUS_OK;
    for (int b = 0; b < nb0 && st == STATUS_OK; b++) {
        if (hit[b]) {
            st = rigid_regroup(r, b);
        }
    }
    free(hit);
    return st;
}

/* Whether spheres i and j (at xi, xj) touch or overlap; spheres of
 * different bodies at the nearest periodic image (a body's own spheres are
 * one piece, unwrapped). */
static int touching(const rigid_t *r, int i, int j, const double xi[3], const double xj[3])
{
    double d[3];
    rv_sub(xj, xi, d);
    if (r->spheres[i].body != r->spheres[j].body) {
        rigid_nearest_image(&r->cfg, d, NULL);
    }
    return rv_norm(d) <= (r->spheres[i].radius + r->spheres[j].radius) * (1.0 + RIGID_TOUCH_TOL);
}

/* Whether spheres i and j touch or overlap where their bodies are now. */
static int touching_now(const rigid_t *r, int i, int j)
{
    double xi[3], xj[3];
    rigid_sphere_world(r, r->bodies, i, xi, NULL, NULL);
    rigid_sphere_world(r, r->bodies, j, xj, NULL, NULL);
    return touching(r, i, j, xi, xj);
}

/* The slot of the connection made when spheres a and b stick: the pair's own
 * broken sticking connection if it has one, else the first broken sticking
 * connection that is dead (its spheres neither touch nor hold a broken neck's
 * overlap, and are of different scene bodies: for a pair of one scene body the
 * entry is what keeps rigid_bonded from taking it for an implicit bond), else
 * a new one (-1). Scene connections (k < cfg.nconnections) are never reused:
 * they keep their index, pair and outputs. So the sticking connections are
 * bounded by the pairs that touch at once, instead of growing by one with
 * every fusion of a pair that sticks and breaks again. */
static int stick_slot(const rigid_t *r, int a, int b)
{
    int dead = -1;
    for (int k = r->cfg.nconnections; k < r->nconn; k++) {
        const rigid_conn_t *c = &r->conn[k];
        if (c->intact) {
            continue;
        }
        if ((c->a == a && c->b == b) || (c->a == b && c->b == a)) {
            return k;
        }
        if (dead < 0 && !(c->gap0 > 0.0) && r->spheres[c->a].orig_body != r->spheres[c->b].orig_body &&
            !touching_now(r, c->a, c->b)) {
            dead = k;
        }
    }
    return dead;
}

/* The connection of spheres a and b that stick, with the fuse limits: in the
 * slot stick_slot finds, else appended. */
static status_t add_connection(rigid_t *r, int a, int b)
{
    int k = stick_slot(r, a, b);
    if (k < 0 && r->nconn == r->conn_cap) {
        int cap = r->conn_cap < 8 ? 16 : 2 * r->conn_cap;
        rigid_conn_t *nc = realloc(r->conn, (size_t)cap * sizeof *nc);
        if (nc == NULL) {
            return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "out of memory for %d connections (%zu bytes)", cap, (size_t)cap * sizeof *nc);
        }
        r->conn = nc;
        unsigned char *sec = realloc(r->section, (size_t)cap * (size_t)r->nspheres);
        if (sec == NULL) {
            return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "out of memory for the sections of %d connections (%zu bytes)", cap, (size_t)cap * (size_t)r->nspheres);
        }
        r->section = sec;
        r->conn_cap = cap;
    }
    if (k < 0) {
        k = r->nconn++;
    }
    rigid_conn_t *c = &r->conn[k];
    memset(c, 0, sizeof *c);
    c->a = a;
    c->b = b;
    c->max_normal = r->cfg.fuse_max_normal;
    c->max_shear = r->cfg.fuse_max_shear;
    c->max_torque = r->cfg.fuse_max_torque;
    c->intact = 1;
    return STATUS_OK;
}

/* The angular velocity of body b: none for a fixed body, the prescribed one
 * for a kinematic body. */
static void body_spin(const rigid_body_t *b, double w[3])
{
    if (b->kinematic) {
        memcpy(w, b->kw, 3 * sizeof(double));
    } else if (b->fixed) {
        w[0] = w[1] = w[2] = 0.0;
    } else {
        rigid_body_omega(b, w);
    }
}

/* Fuses body B into body A (A < B); the last body moves into slot B. */
static status_t fuse(rigid_t *r, int A, int B)
{
    world_buf_t w = {0};
    status_t st = buf_alloc(r, &w);
    if (st != STATUS_OK) {
        buf_free(&w);
        return st;
    }
    rigid_body_t ba = r->bodies[A], bb = r->bodies[B];
    int fixed = ba.fixed || bb.fixed;
    int nm = 0;
    for (int i = 0; i < r->nspheres; i++) {
        if (r->spheres[i].body == A || r->spheres[i].body == B) {
            world_of(r, i, &w, nm++);
        }
    }
    rigid_body_build(r, A, w.members, nm, w.p, w.s, w.j);
    rigid_body_t *nb = &r->bodies[A];
    nb->fixed = fixed;
    /* stuck to a prescribed body: the fused body moves as it does */
    const rigid_body_t *kin = ba.kinematic ? &ba : bb.kinematic ? &bb : NULL;
    nb->kinematic = kin != NULL;
    memcpy(nb->kv, kin ? kin->kv : (const double[3]){0, 0, 0}, sizeof nb->kv);
    memcpy(nb->kw, kin ? kin->kw : (const double[3]){0, 0, 0}, sizeof nb->kw);
    memcpy(nb->kp, kin ? kin->kp : (const double[3]){0, 0, 0}, sizeof nb->kp);
    if (fixed) {
        memset(nb->v, 0, sizeof nb->v);
        memset(nb->l, 0, sizeof nb->l);
    } else {
        double m = ba.mass + bb.mass;
        for (int a = 0; a < 3; a++) {
            nb->v[a] = (ba.mass * ba.v[a] + bb.mass * bb.v[a]) / m;
        }
        const rigid_body_t *parts[2] = {&ba, &bb};
        for (int a = 0; a < 3; a++) {
            nb->l[a] = 0.0;
        }
        for (int k = 0; k < 2; k++) {
            double d[3], dv[3], x[3];
            rv_sub(parts[k]->com, nb->com, d);
            rv_sub(parts[k]->v, nb->v, dv);
            rv_cross(d, dv, x);
            for (int a = 0; a < 3; a++) {
                nb->l[a] += parts[k]->l[a] + parts[k]->mass * x[a];
            }
        }
    }
    /* the jump of each part's material to the fused motion, for the
     * contact watch: its velocity at the new centre of mass and its spin */
    double dv = 0.0, dw = 0.0, un[3], wn[3];
    const double zero[3] = {0, 0, 0};
    rigid_body_point_velocity(nb, zero, un);
    body_spin(nb, wn);
    for (int k = 0; k < 2; k++) {
        const rigid_body_t *part = k == 0 ? &ba : &bb;
        double arm[3], u[3], w[3], d[3];
        rv_sub(nb->com, part->com, arm);
        rigid_body_point_velocity(part, arm, u);
        body_spin(part, w);
        rv_sub(un, u, d);
        dv = fmax(dv, rv_norm(d));
        rv_sub(wn, w, d);
        dw = fmax(dw, rv_norm(d));
    }
    int last = r->nbodies - 1;
    rigid_contact_watch_fuse(r, A, B, last, dv, dw);
    if (B != last) {
        r->bodies[B] = r->bodies[last];
        for (int i = 0; i < r->nspheres; i++) {
            if (r->spheres[i].body == last) {
                r->spheres[i].body = B;
            }
        }
    }
    r->nbodies--;
    buf_free(&w);
    return STATUS_OK;
}

status_t rigid_stick(rigid_t *r, int *changed)
{
    *changed = 0;
    if (!(r->cfg.stick_speed > 0.0)) {
        return STATUS_OK;
    }
    for (;;) {
        int found = 0;
        for (int i = 0; i < r->nspheres && !found; i++) {
            for (int j = i + 1; j < r->nspheres && !found; j++) {
                const rigid_sphere_t *si = &r->spheres[i], *sj = &r->spheres[j];
                if (si->body == sj->body) {
                    continue;
                }
                const rigid_body_t *bi = &r->bodies[si->body], *bj = &r->bodies[sj->body];
                if (bi->fixed && bj->fixed) {
                    continue;
                }
                double xi[3], xj[3], vi[3], vj[3], d[3], shift[3];
                rigid_sphere_world(r, r->bodies, i, xi, vi, NULL);
                rigid_sphere_world(r, r->bodies, j, xj, vj, NULL);
                rv_sub(xj, xi, d);
                rigid_nearest_image(&r->cfg, d, shift); /* they may meet across a periodic face */
                double dist = rv_norm(d);
                if (dist > (si->radius + sj->radius) * (1.0 + RIGID_TOUCH_TOL) || dist == 0.0 ||
                    r->touch[(size_t)i * r->nspheres + j]) {
                    continue;
                }
                for (int a = 0; a < 3; a++) {
                    xj[a] += shift[a];
                }
                double pc[3], n[3], ai[3], aj[3], ui[3], uj[3], vr[3];
                rigid_connection_point(r, i, j, xi, xj, pc, n);
                rv_sub(pc, bi->com, ai);
                rv_sub(pc, bj->com, aj);
                rv_sub(aj, shift, aj); /* the arm from j's body at its image */
                rigid_body_point_velocity(bi, ai, ui);
                rigid_body_point_velocity(bj, aj, uj);
                rv_sub(ui, uj, vr);
                double vn = fabs(rv_dot(vr, n));
                if (vn >= r->cfg.stick_speed) {
                    continue;
                }
                int A = si->body < sj->body ? si->body : sj->body;
                int B = si->body < sj->body ? sj->body : si->body;
                if (shift[0] != 0.0 || shift[1] != 0.0 || shift[2] != 0.0) {
                    /* across a periodic face: j's body moves to the image
                     * that touches i (a free body, whose whole state is its
                     * centre of mass, moved by whole periods), so that the
                     * fused body is one piece, as a body that straddles a
                     * face is (its centres unwrapped, some beyond the face) */
                    rigid_body_t *bm = bj->fixed ? &r->bodies[si->body] : &r->bodies[sj->body];
                    const double sign = bj->fixed ? -1.0 : 1.0;
                    for (int a = 0; a < 3; a++) {
                        bm->com[a] += sign * shift[a];
                    }
                }
                log_msg(&r->log, STATUS_OK, RIGID_CAT,
                        "bodies %d and %d stick at t=%.9g s (spheres %d-%d, normal speed %g m/s below %g m/s)", A, B,
                        r->t, i, j, vn, r->cfg.stick_speed);
                status_t st = add_connection(r, i, j);
                if (st == STATUS_OK) {
                    st = fuse(r, A, B);
                }
                if (st != STATUS_OK) {
                    return st;
                }
                found = 1;
                *changed = 1;
            }
        }
        if (!found) {
            break;
        }
    }
    return STATUS_OK;
}

status_t rigid_stick_at_release(rigid_t *r, int *changed)
{
    const int ns = r->nspheres;
    for (int i = 0; i < ns; i++) {
        for (int j = i + 1; j < ns; j++) {
            if (r->spheres[i].body != r->spheres[j].body) {
                r->touch[(size_t)i * ns + j] = 0;
            }
        }
    }
    /* a broken neck's spheres overlap since the break, not since a touch */
    for (int k = 0; k < r->nconn; k++) {
        const rigid_conn_t *c = &r->conn[k];
        if (c->gap0 > 0.0) {
            r->touch[(size_t)(c->a < c->b ? c->a : c->b) * ns + (c->a < c->b ? c->b : c->a)] = 1;
        }
    }
    const status_t st = rigid_stick(r, changed);
    rigid_touch_update(r);
    return st;
}

double rigid_contact_reference(const rigid_t *r, int i, int j)
{
    for (int k = 0; k < r->nconn; k++) {
        const rigid_conn_t *c = &r->conn[k];
        if (c->gap0 > 0.0 && ((c->a == i && c->b == j) || (c->a == j && c->b == i))) {
            return c->gap0;
        }
    }
    return r->spheres[i].radius + r->spheres[j].radius;
}

/* The touch flags of every sphere pair as they are now; own_body: only the
 * pairs of one body count (the others start untouched). */
static void touch_scan(rigid_t *r, int own_body)
{
    const int ns = r->nspheres;
    for (int i = 0; i < ns; i++) {
        double xi[3];
        rigid_sphere_world(r, r->bodies, i, xi, NULL, NULL);
        for (int j = i + 1; j < ns; j++) {
            double xj[3];
            rigid_sphere_world(r, r->bodies, j, xj, NULL, NULL);
            r->touch[(size_t)i * ns + j] = (unsigned char)((!own_body || r->spheres[i].body == r->spheres[j].body) &&
                                                           touching(r, i, j, xi, xj));
        }
    }
}

void rigid_touch_init(rigid_t *r) { touch_scan(r, 1); }

void rigid_touch_update(rigid_t *r)
{
    /* broken necks: the contact-free distance follows the spheres apart and
     * is forgotten once they no longer overlap */
    for (int k = 0; k < r->nconn; k++) {
        rigid_conn_t *c = &r->conn[k];
        if (c->gap0 > 0.0) {
            double xa[3], xb[3], d[3];
            rigid_sphere_world(r, r->bodies, c->a, xa, NULL, NULL);
            rigid_sphere_world(r, r->bodies, c->b, xb, NULL, NULL);
            rv_sub(xb, xa, d);
            const double dist = rv_norm(d);
            c->gap0 = dist >= r->spheres[c->a].radius + r->spheres[c->b].radius ? 0.0 : fmax(c->gap0, dist);
        }
    }
    touch_scan(r, 0);
}
