/* pairs.c — the close pairs that contacts (contact.c) and lubrication
 * (lubrication.c) act on: two spheres of different bodies, and a sphere
 * against a wall face of the box.
 *
 * One place computes the geometry both force laws need, so that they see the
 * same partner, normal and relative velocity:
 *  - two spheres meet at the image of j nearest to i along periodic axes
 *    (minimum image, shift a whole number of periods box_hi - box_lo), and the
 *    contact point, the lever arms and j's velocity there use that image. The
 *    gap is the centre distance minus rigid_contact_reference (the sum of the
 *    radii, or the contact-free distance of a broken sintered neck). Pairs of
 *    one body and pairs of two fixed bodies are never visited. Only the
 *    nearest image counts: a periodic length of at least twice the reach of a
 *    pair (r_i + r_j + cut-off) is assumed.
 *  - a sphere of a free body against each wall face (every non-periodic face:
 *    no-slip, free-slip, moving, inlet, outlet); the gap is the distance of
 *    the sphere surface from the face, the contact point lies on the face and
 *    the relative velocity is taken against the wall's own velocity (moving
 *    walls).
 * Pairs of two bodies whose spheres are all farther apart than the reach
 * (body_bounds) are passed over without a distance each: agglomerates far
 * from each other cost a test per body pair, and the visit O(N^2) trivial
 * iterations rather than O(N^2) distances (when the bodies have two or more
 * spheres on average; single spheres are tested pair by pair). */
#include "rigid_internal.h"

#include <string.h>

static const char *const FACE_NAMES[6] = {"x_min", "x_max", "y_min", "y_max", "z_min", "z_max"};

const char *rigid_face_name(int face)
{
    return face >= 0 && face < 6 ? FACE_NAMES[face] : "?";
}

void rigid_nearest_image(const rigid_config_t *cfg, double dv[3], double shift[3])
{
    for (int a = 0; a < 3; a++) {
        double s = 0.0;
        if (cfg->periodic[a]) {
            const double len = cfg->box_hi[a] - cfg->box_lo[a];
            s = -len * round(dv[a] / len);
            dv[a] += s;
        }
        if (shift != NULL) {
            shift[a] = s;
        }
    }
}

static int visit_spheres(rigid_t *r, const rigid_body_t *bodies, const double (*x)[3], int i, int j, double reach,
                         rigid_pair_fn fn, void *ctx)
{
    const rigid_config_t *cfg = &r->cfg;
    const rigid_sphere_t *si = &r->spheres[i], *sj = &r->spheres[j];
    rigid_pair_t p = {.i = i, .j = j, .face = -1};
    double dv[3], shift[3];
    rv_sub(x[j], x[i], dv);
    rigid_nearest_image(cfg, dv, shift);
    double rsum = si->radius + sj->radius, lim = rsum + reach;
    if (!(rv_dot(dv, dv) <= lim * lim)) {
        return 0;
    }
    double d = rv_norm(dv);
    p.gap = d - rigid_contact_reference(r, i, j);
    if (!(p.gap <= reach)) {
        return 0;
    }
    if (d == 0.0) {
        p.gap = -rsum; /* coincident centres: no normal; a full overlap */
    } else {
        for (int a = 0; a < 3; a++) {
            p.n[a] = dv[a] / d;
        }
    }
    const rigid_body_t *bi = &bodies[si->body], *bj = &bodies[sj->body];
    double ui[3], uj[3];
    for (int a = 0; a < 3; a++) {
        p.xj[a] = x[j][a] + shift[a];
        p.pc[a] = x[i][a] + (si->radius + 0.5 * p.gap) * p.n[a];
        p.ai[a] = p.pc[a] - bi->com[a];
        p.aj[a] = p.pc[a] - (bj->com[a] + shift[a]);
    }
    rigid_body_point_velocity(bi, p.ai, ui);
    rigid_body_point_velocity(bj, p.aj, uj);
    rv_sub(ui, uj, p.vrel);
    return fn(r, bodies, &p, ctx);
}

static int visit_walls(rigid_t *r, const rigid_body_t *bodies, const double (*x)[3], int i, double reach,
                       rigid_pair_fn fn, void *ctx)
{
    const rigid_config_t *cfg = &r->cfg;
    const rigid_sphere_t *si = &r->spheres[i];
    const rigid_body_t *bi = &bodies[si->body];
    int bad = 0;
    for (int face = 0; face < 6; face++) {
        int ax = face / 2, side = face % 2;
        if (!cfg->walls[ax][side]) {
            continue;
        }
        double centre_gap = side == 0 ? x[i][ax] - cfg->box_lo[ax] : cfg->box_hi[ax] - x[i][ax];
        rigid_pair_t p = {.i = i, .j = -1 - face, .face = face, .gap = centre_gap - si->radius};
        if (!(p.gap <= reach)) {
            continue;
        }
        p.n[ax] = side == 0 ? -1.0 : 1.0;
        double ui[3];
        for (int a = 0; a < 3; a++) {
            p.pc[a] = x[i][a] + (si->radius + p.gap) * p.n[a];
            p.ai[a] = p.pc[a] - bi->com[a];
        }
        rigid_body_point_velocity(bi, p.ai, ui);
        rv_sub(ui, cfg->wall_velocity[ax][side], p.vrel);
        bad |= fn(r, bodies, &p, ctx);
    }
    return bad;
}

/* Marks r->pair_far[A nb + B] for the body pairs none of whose sphere pairs
 * visit_spheres would take. About a centre c_A (the mean of A's sphere
 * centres; any point would do) every sphere i of A has |x_i - c_A| <= e_A
 * and r_i <= m_A; for any periodic shift s, |x_j + s - x_i| >= |c_B + s -
 * c_A| - e_A - e_B, and the smallest |c_B + s - c_A| is the nearest image
 * per axis (the axes are independent). So when that distance exceeds e_A +
 * e_B + m_A + m_B + reach, every pair fails visit_spheres' first test,
 * |dv| <= r_i + r_j + reach; a margin of 1e-9 of the terms and of the
 * centroids' own size covers the rounding of either side. */
static void body_bounds(rigid_t *r, const double (*x)[3], double reach)
{
    const int nb = r->nbodies;
    double (*bd)[6] = r->pair_bound;
    memset(bd, 0, (size_t)nb * sizeof *bd);
    for (int i = 0; i < r->nspheres; i++) {
        double *c = bd[r->spheres[i].body];
        for (int a = 0; a < 3; a++) {
            c[a] += x[i][a];
        }
        c[3] += 1.0; /* the count, for now */
    }
    for (int b = 0; b < nb; b++) {
        for (int a = 0; a < 3 && bd[b][3] > 0.0; a++) {
            bd[b][a] /= bd[b][3];
        }
        bd[b][3] = 0.0;
        bd[b][5] = rv_norm(bd[b]);
    }
    for (int i = 0; i < r->nspheres; i++) {
        double *c = bd[r->spheres[i].body], d[3];
        rv_sub(x[i], c, d);
        c[3] = fmax(c[3], rv_norm(d));
        c[4] = fmax(c[4], r->spheres[i].radius);
    }
    const rigid_config_t *cfg = &r->cfg;
    for (int a = 0; a < nb; a++) {
        r->pair_far[(size_t)a * nb + a] = 0;
        for (int b = a + 1; b < nb; b++) {
            double dv[3];
            rv_sub(bd[b], bd[a], dv);
            rigid_nearest_image(cfg, dv, NULL);
            const double dist = rv_norm(dv);
            const double need = bd[a][3] + bd[b][3] + bd[a][4] + bd[b][4] + reach;
            const int far = dist - need > 1e-9 * (dist + fabs(need) + fabs(reach) + bd[a][5] + bd[b][5]);
            r->pair_far[(size_t)a * nb + b] = r->pair_far[(size_t)b * nb + a] = (unsigned char)far;
        }
    }
}

int rigid_pairs_visit(rigid_t *r, const rigid_body_t *bodies, const double (*x)[3], double reach, rigid_pair_fn fn,
                      void *ctx)
{
    int bad = 0;
    const int nb = r->nbodies;
    /* bodies of two or more spheres on average: a body pair's test replaces
     * several sphere pairs' (with single spheres it would only add to them) */
    const int bounds = 2 * nb <= r->nspheres;
    if (bounds) {
        body_bounds(r, x, reach);
    }
    for (int i = 0; i < r->nspheres; i++) {
        const rigid_sphere_t *si = &r->spheres[i];
        const rigid_body_t *bi = &bodies[si->body];
        const unsigned char *far = r->pair_far + (size_t)si->body * nb;
        for (int j = i + 1; j < r->nspheres; j++) {
            const rigid_sphere_t *sj = &r->spheres[j];
            if (sj->body == si->body || (bi->fixed && bodies[sj->body].fixed) || (bounds && far[sj->body])) {
                continue;
            }
            bad |= visit_spheres(r, bodies, x, i, j, reach, fn, ctx);
        }
        if (!bi->fixed) {
            bad |= visit_walls(r, bodies, x, i, reach, fn, ctx);
        }
    }
    return bad;
}
