/* body.c — mass, centre of mass and inertia of unions of overlapping spheres.
 *
 * The union of a body's spheres is partitioned into one "share" per sphere by
 * the power diagram (Laguerre cells): a point belongs to the sphere with the
 * smallest power |x - c|^2 - r^2. Where two spheres overlap, the boundary
 * between their shares is the radical plane, the plane of their intersection
 * circle, so the lens is split between the two and counted once. Summing the
 * shares gives the union's mass properties; the shares also give the section
 * masses and inertias of the free-body diagram (Eq. 8-9 of the paper) and
 * stay fixed when bodies split or stick, so mass is conserved exactly.
 *
 * What is exact: a share is the ball minus one spherical cap per overlapping
 * neighbour. When those caps are pairwise disjoint inside the ball (always
 * true for two spheres, chains, stars: any arrangement without three spheres
 * sharing a common region of caps) the closed-form cap moments below are
 * exact to round-off. Otherwise the share is integrated in spherical
 * coordinates about the sphere centre: the radial integrals are exact and the
 * two angular integrals use nested adaptive Gauss-Kronrod (7/15) quadrature
 * to a relative tolerance of 1e-11 of the ball's moments. Both need the
 * centre to lie inside its own power cell (radical plane distance t > 0);
 * a sphere buried deeper in a neighbour is rejected with an error.
 *
 * Also here: principal axes (cyclic Jacobi) and the body frame conversions. */
#include "rigid_internal.h"

#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

#define SHARE_MAXNB 64

typedef struct {
    int n;
    double R;
    double nrm[SHARE_MAXNB][3];
    double t[SHARE_MAXNB];
} share_geom_t;

/* Radial extent of the share along unit direction d. */
static double share_extent(const share_geom_t *g, const double d[3])
{
    double e = g->R;
    for (int k = 0; k < g->n; k++) {
        double c = rv_dot(d, g->nrm[k]);
        if (c > 0.0 && g->t[k] < e * c) {
            e = g->t[k] / c;
        }
    }
    return e;
}

#define NF 10 /* volume, 3 first moments, 6 second moments */

static void share_integrand(const share_geom_t *g, double u, double phi, double f[NF])
{
    double s = sqrt(fmax(0.0, 1.0 - u * u));
    double d[3] = {s * cos(phi), s * sin(phi), u};
    double e = share_extent(g, d);
    double e3 = e * e * e / 3.0, e4 = e * e * e * e / 4.0, e5 = e * e * e * e * e / 5.0;
    f[0] = e3;
    f[1] = d[0] * e4;
    f[2] = d[1] * e4;
    f[3] = d[2] * e4;
    f[4] = d[0] * d[0] * e5;
    f[5] = d[1] * d[1] * e5;
    f[6] = d[2] * d[2] * e5;
    f[7] = d[0] * d[1] * e5;
    f[8] = d[0] * d[2] * e5;
    f[9] = d[1] * d[2] * e5;
}

static const double gk_x[8] = {0.991455371120812639206854697526329, 0.949107912342758524526189684047851,
                               0.864864423359769072789712788640926, 0.741531185599394439863864773280788,
                               0.586087235467691130294144845693013, 0.405845151377397166906606412076961,
                               0.207784955007898467600689403773245, 0.000000000000000000000000000000000};
static const double gk_wk[8] = {0.022935322010529224963732008058970, 0.063092092629978553290700663189204,
                                0.104790010322250183839876322541518, 0.140653259715525918745189590510238,
                                0.169004726639267902826583426598550, 0.190350578064785409913256402421014,
                                0.204432940075298892414161999234649, 0.209482141084727828012999174891714};
static const double gk_wg[4] = {0.129484966168869693270611432679082, 0.279705391489276667901467771423780,
                                 0.381830050505118944950369775488975, 0.417959183673469387755102040816327};

typedef struct {
    const share_geom_t *g;
    int level; /* 0: outer over u, 1: inner over phi */
    double u;  /* fixed u for the inner integral */
    double tol;
} share_quad_t;

static void share_adapt(share_quad_t *qd, double a, double b, double out[NF], int depth);

static void share_eval(share_quad_t *qd, double x, double f[NF])
{
    if (qd->level == 1) {
        share_integrand(qd->g, qd->u, x, f);
        return;
    }
    share_quad_t inner = *qd;
    inner.level = 1;
    inner.u = x;
    share_adapt(&inner, 0.0, 2.0 * M_PI, f, 0);
}

/* One G7K15 panel: Kronrod estimate k and error estimate |k - g|. */
static double share_gk(share_quad_t *qd, double a, double b, double k[NF])
{
    double c = 0.5 * (a + b), h = 0.5 * (b - a);
    double g[NF] = {0}, f1[NF], f2[NF];
    share_eval(qd, c, f1);
    for (int m = 0; m < NF; m++) {
        k[m] = gk_wk[7] * f1[m];
        g[m] = gk_wg[3] * f1[m];
    }
    for (int j = 0; j < 7; j++) {
        share_eval(qd, c - h * gk_x[j], f1);
        share_eval(qd, c + h * gk_x[j], f2);
        for (int m = 0; m < NF; m++) {
            k[m] += gk_wk[j] * (f1[m] + f2[m]);
            if (j % 2 == 1) {
                g[m] += gk_wg[j / 2] * (f1[m] + f2[m]);
            }
        }
    }
    double err = 0.0;
    for (int m = 0; m < NF; m++) {
        k[m] *= h;
        g[m] *= h;
        err = fmax(err, fabs(k[m] - g[m]));
    }
    return err;
}

static void share_adapt(share_quad_t *qd, double a, double b, double out[NF], int depth)
{
    double k[NF];
    double err = share_gk(qd, a, b, k);
    /* tolerance by the square root of the panel's share of the interval:
     * where the integrand has a kink (a ray leaving through another cap) the
     * panel error falls as its length squared, so the kink is resolved after
     * half as many halvings as with a tolerance per unit length (which needed
     * the panel as short as tol), and the accepted panels' errors, falling
     * geometrically level by level, still add up to a few tol. The triangle
     * of tests/rigid/test_body.c: the same mass, centre and inertia to 2e-12,
     * rigid_body_inertia 2.7 s instead of 11.6 s. */
    double lim = qd->tol * sqrt((b - a) / (qd->level == 0 ? 2.0 : 2.0 * M_PI));
    if (err <= lim || depth >= 40) {
        memcpy(out, k, sizeof k);
        return;
    }
    double l[NF], rr[NF], c = 0.5 * (a + b);
    share_adapt(qd, a, c, l, depth + 1);
    share_adapt(qd, c, b, rr, depth + 1);
    for (int m = 0; m < NF; m++) {
        out[m] = l[m] + rr[m];
    }
}

/* Do the caps beyond planes (x.n1 > t1) and (x.n2 > t2) meet inside |x| < R?
 * The minimum-norm point of the intersection of the two half-spaces decides. */
static int caps_meet(const double n1[3], double t1, const double n2[3], double t2, double R)
{
    double c = rv_dot(n1, n2);
    double best;
    if (t2 * 1.0 <= t1 * c) { /* t1 n1 already lies in the second half-space */
        best = t1;
    } else if (t1 <= t2 * c) {
        best = t2;
    } else {
        double den = 1.0 - c * c;
        if (den <= 1e-300) {
            return 0; /* parallel planes facing opposite ways with t1, t2 > 0 */
        }
        double al = (t1 - c * t2) / den, be = (t2 - c * t1) / den;
        best = sqrt(fmax(0.0, al * t1 + be * t2));
    }
    return best < R;
}

status_t rigid_share_props(const log_t *log, int n, const double (*c)[3], const double *rad, const int *ids, int i,
                           double *vol, double cen[3], double j[9])
{
    share_geom_t g;
    g.n = 0;
    g.R = rad[i];
    double R = rad[i];
    for (int k = 0; k < n; k++) {
        if (k == i) {
            continue;
        }
        double dv[3];
        rv_sub(c[k], c[i], dv);
        double d = rv_norm(dv);
        if (d >= R + rad[k]) {
            continue; /* no overlap: touching spheres share a point only */
        }
        double t = (d * d + R * R - rad[k] * rad[k]) / (2.0 * d);
        if (!(d > 0.0) || t <= 0.0) {
            return log_msg(log, STATUS_ERROR, RIGID_CAT,
                           "sphere %d (radius %g m) is buried in sphere %d (radius %g m, centre distance %g m): "
                           "its centre lies beyond their radical plane (distance %g m, must be > 0)",
                           ids[i], R, ids[k], rad[k], d, t);
        }
        if (t >= R) {
            continue; /* the small neighbour lies inside this sphere's power cell: no cap */
        }
        if (g.n >= SHARE_MAXNB) {
            return log_msg(log, STATUS_ERROR, RIGID_CAT, "sphere %d overlaps more than %d spheres (limit %d)", ids[i],
                           SHARE_MAXNB, SHARE_MAXNB);
        }
        for (int a = 0; a < 3; a++) {
            g.nrm[g.n][a] = dv[a] / d;
        }
        g.t[g.n] = t;
        g.n++;
    }
    int disjoint = 1;
    for (int a = 0; a < g.n && disjoint; a++) {
        for (int b = a + 1; b < g.n; b++) {
            if (caps_meet(g.nrm[a], g.t[a], g.nrm[b], g.t[b], R)) {
                disjoint = 0;
                break;
            }
        }
    }
    /* moments about the sphere centre: V, first moment m1, S_ab = int x_a x_b dV */
    double V, m1[3] = {0, 0, 0}, S[9] = {0};
    if (disjoint) {
        double R2 = R * R, R5 = R2 * R2 * R;
        V = 4.0 / 3.0 * M_PI * R2 * R;
        S[0] = S[4] = S[8] = 4.0 * M_PI * R5 / 15.0;
        for (int k = 0; k < g.n; k++) {
            double t = g.t[k], h = R - t, t2 = t * t, t3 = t2 * t, t5 = t3 * t2;
            /* spherical cap z in [t, R] of a ball of radius R about the origin */
            double vc = M_PI * h * h * (3.0 * R - h) / 3.0;
            double zc = M_PI * (R2 - t2) * (R2 - t2) / 4.0;
            double zz = M_PI * (2.0 * R5 / 15.0 - R2 * t3 / 3.0 + t5 / 5.0);
            double xx = 0.25 * M_PI * (8.0 * R5 / 15.0 - R2 * R2 * t + 2.0 * R2 * t3 / 3.0 - t5 / 5.0);
            const double *nk = g.nrm[k];
            V -= vc;
            for (int a = 0; a < 3; a++) {
                m1[a] -= zc * nk[a];
                for (int b = 0; b < 3; b++) {
                    double nn = nk[a] * nk[b];
                    S[3 * a + b] -= xx * ((a == b ? 1.0 : 0.0) - nn) + zz * nn;
                }
            }
        }
    } else {
        /* in units of R: the one tolerance then suits the volume and the
         * first and second moments alike (in metres, R^5 scaled it far below
         * the volume's round-off for R << 1 m, and the panels halved to the
         * depth limit everywhere: three overlapping spheres of 3.3 mm never
         * finished) */
        share_geom_t gu = g;
        gu.R = 1.0;
        for (int k = 0; k < g.n; k++) {
            gu.t[k] = g.t[k] / R;
        }
        share_quad_t qd = {&gu, 0, 0.0, 1e-11 * 4.0 * M_PI / 15.0};
        double f[NF];
        share_adapt(&qd, -1.0, 1.0, f, 0);
        const double R3 = R * R * R, R4 = R3 * R, R5 = R4 * R;
        V = f[0] * R3;
        m1[0] = f[1] * R4;
        m1[1] = f[2] * R4;
        m1[2] = f[3] * R4;
        S[0] = f[4] * R5;
        S[4] = f[5] * R5;
        S[8] = f[6] * R5;
        S[1] = S[3] = f[7] * R5;
        S[2] = S[6] = f[8] * R5;
        S[5] = S[7] = f[9] * R5;
    }
    if (!(V > 0.0)) {
        return log_msg(log, STATUS_ERROR, RIGID_CAT, "sphere %d: its share of the union has volume %g m^3 (must be > 0)",
                       ids[i], V);
    }
    double d[3] = {m1[0] / V, m1[1] / V, m1[2] / V};
    /* shift the second moment to the centroid, then inertia = tr(S) 1 - S */
    for (int a = 0; a < 3; a++) {
        for (int b = 0; b < 3; b++) {
            S[3 * a + b] -= V * d[a] * d[b];
        }
    }
    double tr = S[0] + S[4] + S[8];
    for (int a = 0; a < 9; a++) {
        j[a] = -S[a];
    }
    j[0] += tr;
    j[4] += tr;
    j[8] += tr;
    *vol = V;
    for (int a = 0; a < 3; a++) {
        cen[a] = c[i][a] + d[a];
    }
    return STATUS_OK;
}

/* Cyclic Jacobi for a symmetric 3x3 matrix: eigenvalues ascending, the
 * eigenvectors as columns of a proper rotation (det +1). */
void rigid_sym_eigen(const double a_in[9], double eval[3], double evec[9])
{
    double a[9], v[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    memcpy(a, a_in, sizeof a);
    for (int sweep = 0; sweep < 50; sweep++) {
        double off = fabs(a[1]) + fabs(a[2]) + fabs(a[5]);
        double scale = fabs(a[0]) + fabs(a[4]) + fabs(a[8]);
        if (off <= 1e-300 || off <= 1e-17 * scale) {
            break;
        }
        for (int p = 0; p < 2; p++) {
            for (int q = p + 1; q < 3; q++) {
                double apq = a[3 * p + q];
                if (apq == 0.0) {
                    continue;
                }
                double th = 0.5 * (a[3 * q + q] - a[3 * p + p]) / apq;
                double t = (th >= 0 ? 1.0 : -1.0) / (fabs(th) + sqrt(th * th + 1.0));
                double cs = 1.0 / sqrt(t * t + 1.0), sn = t * cs;
                for (int k = 0; k < 3; k++) { /* A <- A J */
                    double akp = a[3 * k + p], akq = a[3 * k + q];
                    a[3 * k + p] = cs * akp - sn * akq;
                    a[3 * k + q] = sn * akp + cs * akq;
                }
                for (int k = 0; k < 3; k++) { /* A <- J^T A */
                    double apk = a[3 * p + k], aqk = a[3 * q + k];
                    a[3 * p + k] = cs * apk - sn * aqk;
                    a[3 * q + k] = sn * apk + cs * aqk;
                }
                for (int k = 0; k < 3; k++) {
                    double vkp = v[3 * k + p], vkq = v[3 * k + q];
                    v[3 * k + p] = cs * vkp - sn * vkq;
                    v[3 * k + q] = sn * vkp + cs * vkq;
                }
            }
        }
    }
    int idx[3] = {0, 1, 2};
    double d[3] = {a[0], a[4], a[8]};
    for (int x = 0; x < 3; x++) {
        for (int y = x + 1; y < 3; y++) {
            if (d[idx[y]] < d[idx[x]]) {
                int tmp = idx[x];
                idx[x] = idx[y];
                idx[y] = tmp;
            }
        }
    }
    for (int col = 0; col < 3; col++) {
        eval[col] = d[idx[col]];
        for (int k = 0; k < 3; k++) {
            evec[3 * k + col] = v[3 * k + idx[col]];
        }
    }
    double c0[3] = {evec[0], evec[3], evec[6]}, c1[3] = {evec[1], evec[4], evec[7]}, c2[3];
    rv_cross(c0, c1, c2);
    for (int k = 0; k < 3; k++) {
        evec[3 * k + 2] = c2[k];
    }
}

static void quat_from_matrix(const double m[9], double q[4])
{
    double tr = m[0] + m[4] + m[8];
    if (tr > 0.0) {
        double s = 2.0 * sqrt(tr + 1.0);
        q[0] = 0.25 * s;
        q[1] = (m[7] - m[5]) / s;
        q[2] = (m[2] - m[6]) / s;
        q[3] = (m[3] - m[1]) / s;
    } else if (m[0] > m[4] && m[0] > m[8]) {
        double s = 2.0 * sqrt(1.0 + m[0] - m[4] - m[8]);
        q[0] = (m[7] - m[5]) / s;
        q[1] = 0.25 * s;
        q[2] = (m[1] + m[3]) / s;
        q[3] = (m[2] + m[6]) / s;
    } else if (m[4] > m[8]) {
        double s = 2.0 * sqrt(1.0 + m[4] - m[0] - m[8]);
        q[0] = (m[2] - m[6]) / s;
        q[1] = (m[1] + m[3]) / s;
        q[2] = 0.25 * s;
        q[3] = (m[5] + m[7]) / s;
    } else {
        double s = 2.0 * sqrt(1.0 + m[8] - m[0] - m[4]);
        q[0] = (m[3] - m[1]) / s;
        q[1] = (m[2] + m[6]) / s;
        q[2] = (m[5] + m[7]) / s;
        q[3] = 0.25 * s;
    }
    double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    for (int k = 0; k < 4; k++) {
        q[k] /= n;
    }
}

void rigid_body_rotation(const rigid_body_t *b, double m[9]) { rq_matrix(b->q, m); }

void rigid_body_inertia_world(const rigid_body_t *b, double iw[9])
{
    double m[9];
    rq_matrix(b->q, m);
    for (int x = 0; x < 3; x++) {
        for (int y = 0; y < 3; y++) {
            double s = 0.0;
            for (int k = 0; k < 3; k++) {
                s += m[3 * x + k] * b->inertia[k] * m[3 * y + k];
            }
            iw[3 * x + y] = s;
        }
    }
}

/* omega = R diag(1/I) R^T L */
void rigid_body_omega(const rigid_body_t *b, double w[3])
{
    double m[9], lb[3];
    rq_matrix(b->q, m);
    rm_tmul(m, b->l, lb);
    for (int k = 0; k < 3; k++) {
        lb[k] /= b->inertia[k];
    }
    rm_mul(m, lb, w);
}

void rigid_body_build(rigid_t *r, int body, const int *members, int nm, double (*world_p)[3], double (*world_s)[3],
                      double (*world_j)[9])
{
    rigid_body_t *b = &r->bodies[body];
    double mass = 0.0, com[3] = {0, 0, 0};
    for (int k = 0; k < nm; k++) {
        double m = r->spheres[members[k]].mass;
        mass += m;
        for (int a = 0; a < 3; a++) {
            com[a] += m * world_s[k][a];
        }
    }
    for (int a = 0; a < 3; a++) {
        com[a] /= mass;
    }
    double iw[9] = {0};
    for (int k = 0; k < nm; k++) {
        double m = r->spheres[members[k]].mass, d[3];
        rv_sub(world_s[k], com, d);
        double d2 = rv_dot(d, d);
        for (int x = 0; x < 3; x++) {
            for (int y = 0; y < 3; y++) {
                iw[3 * x + y] += world_j[k][3 * x + y] + m * ((x == y ? d2 : 0.0) - d[x] * d[y]);
            }
        }
    }
    double ev[3], R[9];
    rigid_sym_eigen(iw, ev, R);
    b->mass = mass;
    memcpy(b->com, com, sizeof com);
    memcpy(b->inertia, ev, sizeof ev);
    quat_from_matrix(R, b->q);
    rq_matrix(b->q, R); /* use exactly the rotation the quaternion represents */
    for (int k = 0; k < nm; k++) {
        rigid_sphere_t *s = &r->spheres[members[k]];
        double d[3];
        s->body = body;
        rv_sub(world_p[k], com, d);
        rm_tmul(R, d, s->p);
        rv_sub(world_s[k], com, d);
        rm_tmul(R, d, s->s);
        double tmp[9];
        for (int x = 0; x < 3; x++) { /* tmp = J R */
            for (int y = 0; y < 3; y++) {
                double acc = 0.0;
                for (int z = 0; z < 3; z++) {
                    acc += world_j[k][3 * x + z] * R[3 * z + y];
                }
                tmp[3 * x + y] = acc;
            }
        }
        for (int x = 0; x < 3; x++) { /* j = R^T tmp */
            for (int y = 0; y < 3; y++) {
                double acc = 0.0;
                for (int z = 0; z < 3; z++) {
                    acc += R[3 * z + x] * tmp[3 * z + y];
                }
                s->j[3 * x + y] = acc;
            }
        }
    }
}
