/* connection.c — the force and torque in each connection by the free-body
 * diagram (Iglberger, Thuerey, Ruede 2008, Eq. 8 and 9).
 *
 * Structure graph of a body: its spheres are the vertices; the edges are the
 * intact connections plus the implicit bonds, i.e. pairs of spheres of one
 * scene body that touch or overlap (sintered) but are not listed as a
 * connection; implicit bonds never break and are not reported.
 *
 * Section of connection k = (a, b): the body is cut into the part holding
 * sphere a and the rest. If removing the edge a-b alone separates the body
 * (a tree-like structure) the cut is that edge, as in the paper. If a-b lies
 * on a cycle, one edge does not cut the body; we then use the smallest cut
 * that contains it: a minimum a-b edge cut (every a-b cut contains the edge
 * a-b), found by unit-capacity max-flow (Edmonds-Karp, ties broken by sphere
 * order, hence deterministic). The section is the set reachable from a in the
 * residual graph, and the reported force and torque are the resultant carried
 * by all edges of that cut. section[k*nspheres + i] = 1 marks sphere i.
 *
 * Eq. 8: F_c = M_s a_s - F_s, with a_s the acceleration of the section's
 * centre of mass as a part of the rigid body, a_s = a + alpha x r + omega x
 * (omega x r), r = com_s - com. Eq. 9, written about the section's centre of
 * mass with the force acting at the connection point p_c (the centre of the
 * contact circle, on the radical plane; for touching spheres the touching
 * point): T_c = I_s alpha + omega x I_s omega - (p_c - com_s) x F_c - T_s.
 * (The paper's d_c is our lever p_c - com_s.) Both are the load exerted on
 * the section of sphere a by the rest of the body. */
#include "rigid_internal.h"

#include <stdlib.h>
#include <string.h>

int rigid_bonded(const rigid_t *r, int i, int j)
{
    const rigid_sphere_t *a = &r->spheres[i], *b = &r->spheres[j];
    if (a->orig_body != b->orig_body || a->body != b->body) {
        return 0;
    }
    for (int k = 0; k < r->nconn; k++) {
        const rigid_conn_t *c = &r->conn[k];
        if ((c->a == i && c->b == j) || (c->a == j && c->b == i)) {
            return 0; /* represented by the connection (intact or broken) */
        }
    }
    /* touching in the scene: such a pair is never parted (nothing can break
     * it), so it touches now as it did then; a pair of one scene body that
     * touches only since its fragments fused again is no bond (its body-frame
     * distance made it one, unbreakable, and kept the fused body from
     * breaking at its sticking connection) */
    double d[3];
    rv_sub(a->c0, b->c0, d);
    return rv_norm(d) <= (a->radius + b->radius) * (1.0 + RIGID_TOUCH_TOL);
}

typedef struct {
    int n;
    int *eu, *ev, ne; /* undirected edges */
    int *flow;        /* flow on edge e from eu to ev: -1, 0, 1 */
    int *prev_edge, *queue, *seen;
} graph_t;

/* BFS in the residual graph from s; returns 1 if t is reached. */
static int residual_bfs(graph_t *g, int s, int t)
{
    for (int i = 0; i < g->n; i++) {
        g->seen[i] = 0;
        g->prev_edge[i] = -1;
    }
    int head = 0, tail = 0;
    g->queue[tail++] = s;
    g->seen[s] = 1;
    while (head < tail) {
        int u = g->queue[head++];
        for (int e = 0; e < g->ne; e++) {
            int w = -1;
            if (g->eu[e] == u && g->flow[e] < 1) {
                w = g->ev[e];
            } else if (g->ev[e] == u && g->flow[e] > -1) {
                w = g->eu[e];
            }
            if (w >= 0 && !g->seen[w]) {
                g->seen[w] = 1;
                g->prev_edge[w] = e;
                g->queue[tail++] = w;
            }
        }
    }
    return g->seen[t];
}

status_t rigid_sections_update(rigid_t *r)
{
    int ns = r->nspheres;
    size_t maxe = (size_t)r->nconn + (size_t)ns * (size_t)ns;
    graph_t g = {ns, NULL, NULL, 0, NULL, NULL, NULL, NULL};
    g.eu = malloc(maxe * sizeof(int));
    g.ev = malloc(maxe * sizeof(int));
    g.flow = malloc(maxe * sizeof(int));
    g.prev_edge = malloc((size_t)ns * sizeof(int));
    g.queue = malloc((size_t)ns * sizeof(int));
    g.seen = malloc((size_t)ns * sizeof(int));
    status_t st = STATUS_OK;
    if (!g.eu || !g.ev || !g.flow || !g.prev_edge || !g.queue || !g.seen) {
        st = log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "out of memory for the connection-section graph of %d spheres (%zu bytes)", ns, 3 * maxe * sizeof(int) + 3 * (size_t)ns * sizeof(int));
        goto cleanup;
    }
    for (int k = 0; k < r->nconn; k++) {
        if (r->conn[k].intact) {
            g.eu[g.ne] = r->conn[k].a;
            g.ev[g.ne] = r->conn[k].b;
            g.ne++;
        }
    }
    for (int i = 0; i < ns; i++) {
        for (int j = i + 1; j < ns; j++) {
            if (rigid_bonded(r, i, j)) {
                g.eu[g.ne] = i;
                g.ev[g.ne] = j;
                g.ne++;
            }
        }
    }
    memset(r->section, 0, (size_t)r->conn_cap * (size_t)ns);
    for (int k = 0; k < r->nconn; k++) {
        const rigid_conn_t *c = &r->conn[k];
        if (!c->intact) {
            continue;
        }
        memset(g.flow, 0, (size_t)g.ne * sizeof(int));
        while (residual_bfs(&g, c->a, c->b)) {
            for (int w = c->b; w != c->a;) {
                int e = g.prev_edge[w];
                if (g.ev[e] == w) {
                    g.flow[e] += 1;
                    w = g.eu[e];
                } else {
                    g.flow[e] -= 1;
                    w = g.ev[e];
                }
            }
        }
        /* after the last failed BFS, seen[] is the source side of a minimum cut */
        for (int i = 0; i < ns; i++) {
            r->section[(size_t)k * ns + i] = (unsigned char)g.seen[i];
        }
    }
cleanup:
    free(g.eu);
    free(g.ev);
    free(g.flow);
    free(g.prev_edge);
    free(g.queue);
    free(g.seen);
    return st;
}

void rigid_connection_point(const rigid_t *r, int a, int b, const double xa[3], const double xb[3], double pc[3],
                            double n[3])
{
    double d[3];
    rv_sub(xb, xa, d);
    double dist = rv_norm(d);
    double ra = r->spheres[a].radius, rb = r->spheres[b].radius;
    double t = dist < ra + rb ? (dist * dist + ra * ra - rb * rb) / (2.0 * dist) : ra;
    for (int k = 0; k < 3; k++) {
        n[k] = d[k] / dist;
        pc[k] = xa[k] + t * n[k];
    }
}

/* Requires r->sf, r->st, r->bf, r->bt, r->sx evaluated at r->bodies. */
void rigid_connections_eval(rigid_t *r)
{
    int ns = r->nspheres;
    for (int k = 0; k < r->nconn; k++) {
        rigid_conn_t *c = &r->conn[k];
        int bi = r->spheres[c->a].body;
        const rigid_body_t *b = &r->bodies[bi];
        /* a fixed or prescribed body is held at every sphere by supports we do
         * not know: its sections carry nothing (with a_s = 0 the load of a's
         * section would depend on which sphere is listed first) */
        if (!c->intact || b->fixed) {
            memset(c->force, 0, sizeof c->force);
            memset(c->torque, 0, sizeof c->torque);
            continue;
        }
        const unsigned char *sec = &r->section[(size_t)k * ns];
        double R[9], w[3] = {0, 0, 0}, acc[3] = {0, 0, 0}, alpha[3] = {0, 0, 0};
        rq_matrix(b->q, R);
        if (!b->fixed) {
            double lw[3], g[3];
            rigid_body_omega(b, w);
            rv_cross(w, b->l, lw);
            for (int a = 0; a < 3; a++) {
                acc[a] = r->bf[3 * bi + a] / b->mass;
                g[a] = r->bt[3 * bi + a] - lw[a];
            }
            /* alpha = R I^-1 R^T (T - omega x L) */
            double gb[3];
            rm_tmul(R, g, gb);
            for (int a = 0; a < 3; a++) {
                gb[a] /= b->inertia[a];
            }
            rm_mul(R, gb, alpha);
        }
        double ms = 0.0, coms[3] = {0, 0, 0}, fs[3] = {0, 0, 0};
        double sw[3];
        for (int i = 0; i < ns; i++) {
            if (!sec[i]) {
                continue;
            }
            const rigid_sphere_t *s = &r->spheres[i];
            rm_mul(R, s->s, sw);
            ms += s->mass;
            for (int a = 0; a < 3; a++) {
                coms[a] += s->mass * sw[a]; /* relative to the body com for now */
                fs[a] += r->sf[3 * i + a];
            }
        }
        for (int a = 0; a < 3; a++) {
            coms[a] /= ms;
        }
        /* a_s = a + alpha x r + omega x (omega x r), r = com_s - com */
        double t1[3], t2[3], t3[3], as[3], fc[3];
        rv_cross(alpha, coms, t1);
        rv_cross(w, coms, t2);
        rv_cross(w, t2, t3);
        for (int a = 0; a < 3; a++) {
            as[a] = acc[a] + t1[a] + t3[a];
            fc[a] = ms * as[a] - fs[a]; /* Eq. 8 */
        }
        double is[9] = {0}, ts[3] = {0, 0, 0}, comw[3];
        for (int a = 0; a < 3; a++) {
            comw[a] = b->com[a] + coms[a];
        }
        for (int i = 0; i < ns; i++) {
            if (!sec[i]) {
                continue;
            }
            const rigid_sphere_t *s = &r->spheres[i];
            double d[3], jw[9], tmp[9], arm[3], tq[3];
            rm_mul(R, s->s, sw);
            rv_sub(sw, coms, d);
            for (int x = 0; x < 3; x++) {
                for (int y = 0; y < 3; y++) {
                    double acc2 = 0.0;
                    for (int z = 0; z < 3; z++) {
                        acc2 += s->j[3 * x + z] * R[3 * y + z];
                    }
                    tmp[3 * x + y] = acc2; /* J R^T */
                }
            }
            for (int x = 0; x < 3; x++) {
                for (int y = 0; y < 3; y++) {
                    double acc2 = 0.0;
                    for (int z = 0; z < 3; z++) {
                        acc2 += R[3 * x + z] * tmp[3 * z + y];
                    }
                    jw[3 * x + y] = acc2; /* R J R^T */
                }
            }
            double d2 = rv_dot(d, d);
            for (int x = 0; x < 3; x++) {
                for (int y = 0; y < 3; y++) {
                    is[3 * x + y] += jw[3 * x + y] + s->mass * ((x == y ? d2 : 0.0) - d[x] * d[y]);
                }
            }
            rv_sub(r->sx[i], comw, arm);
            rv_cross(arm, &r->sf[3 * i], tq);
            for (int a = 0; a < 3; a++) {
                ts[a] += r->st[3 * i + a] + tq[a];
            }
        }
        double pc[3], n[3], lever[3], ia[3], iw2[3], wiw[3], lf[3];
        rigid_connection_point(r, c->a, c->b, r->sx[c->a], r->sx[c->b], pc, n);
        rv_sub(pc, comw, lever);
        rm_mul(is, alpha, ia);
        rm_mul(is, w, iw2);
        rv_cross(w, iw2, wiw);
        rv_cross(lever, fc, lf);
        for (int a = 0; a < 3; a++) {
            c->force[a] = fc[a];
            c->torque[a] = ia[a] + wiw[a] - lf[a] - ts[a]; /* Eq. 9 */
        }
    }
}
