/* test_body.c — mass properties of sphere unions against analytic values.
 *
 * References: solid sphere I = 2/5 m r^2 and the parallel-axis theorem
 * (any mechanics text, e.g. Goldstein, Classical Mechanics, ch. 5); the two-
 * and three-sphere unions are axisymmetric, so their exact mass, centre and
 * inertia follow from integrating disks along the axis: the disk radius is
 * piecewise sqrt(r^2 - (x - c)^2), split at the radical planes of the
 * spheres (the plane of the intersection circle: x = (d^2 + r1^2 - r2^2)/2d
 * from the first centre). The integrands are polynomials of degree <= 4 in x,
 * so 3-point Gauss-Legendre on each piece is exact (independent of the cap
 * formulas used by rigid/body.c). */
#include "test_rigid_util.h"

typedef struct {
    double V, xc, Ixx, Iyy; /* per unit density; Iyy about the centroid */
} axi_t;

/* Exact union of axisymmetric spheres (centres on x) given the pieces:
 * breakpoints x[0..np] and for each piece the sphere (centre, radius). */
static axi_t axi_union(int np, const double *x, const double *cen, const double *rad)
{
    static const double gx[3] = {-0.774596669241483377035853079956, 0.0, 0.774596669241483377035853079956};
    static const double gw[3] = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};
    double V = 0, M1 = 0, Ixx = 0, S2 = 0, D4 = 0;
    for (int p = 0; p < np; p++) {
        double a = x[p], b = x[p + 1], h = 0.5 * (b - a), m = 0.5 * (a + b);
        for (int k = 0; k < 3; k++) {
            double xx = m + h * gx[k], w = h * gw[k];
            double rho2 = rad[p] * rad[p] - (xx - cen[p]) * (xx - cen[p]);
            double A = M_PI * rho2;
            V += w * A;
            M1 += w * A * xx;
            Ixx += w * 0.5 * M_PI * rho2 * rho2;
            S2 += w * A * xx * xx;
            D4 += w * 0.25 * M_PI * rho2 * rho2;
        }
    }
    axi_t o;
    o.V = V;
    o.xc = M1 / V;
    o.Ixx = Ixx;
    o.Iyy = D4 + S2 - V * o.xc * o.xc;
    return o;
}

static void check_axi(const rigid_sphere_cfg_t *s, int n, axi_t ref, double rho, double tol)
{
    rigid_body_cfg_t b = {rho, {0, 0, 0}, {0, 0, 0}, 0};
    rigid_config_t cfg = test_cfg(n, s, 1, &b, 0, NULL);
    rigid_t *r = NULL;
    CU_ASSERT_EQUAL_FATAL(rigid_create(&cfg, NULL, &r), STATUS_OK);
    double com[3], m, I[9];
    rigid_get_body(r, 0, com, NULL, NULL, NULL, &m, I);
    CU_ASSERT(rel_err(m, rho * ref.V) < tol);
    CU_ASSERT(fabs(com[0] - ref.xc) < tol * 1.0);
    CU_ASSERT(fabs(com[1]) < 1e-14 && fabs(com[2]) < 1e-14);
    CU_ASSERT(rel_err(I[0], rho * ref.Ixx) < tol);
    CU_ASSERT(rel_err(I[4], rho * ref.Iyy) < tol);
    CU_ASSERT(rel_err(I[8], rho * ref.Iyy) < tol);
    CU_ASSERT(fabs(I[1]) + fabs(I[2]) + fabs(I[5]) < 1e-12 * I[0]);
    rigid_free(r);
}

static void test_one_sphere(void)
{
    rigid_sphere_cfg_t s = {{0.1, -0.2, 0.3}, 0.5, 0};
    double rho = 2500.0, m = rho * 4.0 / 3.0 * M_PI * 0.125;
    rigid_body_cfg_t b = {rho, {0, 0, 0}, {0, 0, 0}, 0};
    rigid_config_t cfg = test_cfg(1, &s, 1, &b, 0, NULL);
    rigid_t *r = NULL;
    CU_ASSERT_EQUAL_FATAL(rigid_create(&cfg, NULL, &r), STATUS_OK);
    double com[3], mass, I[9];
    rigid_get_body(r, 0, com, NULL, NULL, NULL, &mass, I);
    CU_ASSERT(rel_err(mass, m) < 1e-14);
    CU_ASSERT(vec_dist(com, s.center) < 1e-15);
    for (int a = 0; a < 3; a++) {
        CU_ASSERT(rel_err(I[4 * a], 0.4 * m * 0.25) < 1e-14);
    }
    rigid_free(r);
}

static void test_two_touching(void)
{
    double rr = 0.3, rho = 1000.0, m = rho * 4.0 / 3.0 * M_PI * rr * rr * rr;
    rigid_sphere_cfg_t s[2] = {{{-rr, 0, 0}, rr, 0}, {{rr, 0, 0}, rr, 0}};
    axi_t ref = {2 * m / rho, 0.0, 2 * 0.4 * m * rr * rr / rho, 2 * (0.4 * m * rr * rr + m * rr * rr) / rho};
    check_axi(s, 2, ref, rho, 1e-13);
}

static void test_two_overlapping_lens(void)
{
    /* unequal spheres r1 = 1, r2 = 0.7 at distance 1.2 (overlap 0.5) */
    double r1 = 1.0, r2 = 0.7, d = 1.2, xp = (d * d + r1 * r1 - r2 * r2) / (2 * d);
    rigid_sphere_cfg_t s[2] = {{{0, 0, 0}, r1, 0}, {{d, 0, 0}, r2, 0}};
    double x[3] = {-r1, xp, d + r2}, cen[2] = {0, d}, rad[2] = {r1, r2};
    axi_t ref = axi_union(2, x, cen, rad);
    /* cross-check the lens volume formula pi (r1+r2-d)^2 (d^2 + 2d(r1+r2) - 3(r1-r2)^2) / (12 d) */
    double lens = M_PI * pow(r1 + r2 - d, 2) * (d * d + 2 * d * (r1 + r2) - 3 * pow(r1 - r2, 2)) / (12 * d);
    CU_ASSERT(rel_err(ref.V, 4.0 / 3.0 * M_PI * (r1 * r1 * r1 + r2 * r2 * r2) - lens) < 1e-13);
    check_axi(s, 2, ref, 3.0, 1e-12);
}

static void test_three_in_line_quadrature(void)
{
    /* three unit spheres spaced 0.8: the outer two overlap each other too, so
     * the caps inside them intersect and body.c must use its quadrature */
    double sp = 0.8;
    rigid_sphere_cfg_t s[3] = {{{-sp, 0, 0}, 1, 0}, {{0, 0, 0}, 1, 0}, {{sp, 0, 0}, 1, 0}};
    double x[4] = {-sp - 1, -sp / 2, sp / 2, sp + 1}, cen[3] = {-sp, 0, sp}, rad[3] = {1, 1, 1};
    axi_t ref = axi_union(3, x, cen, rad);
    check_axi(s, 3, ref, 1.0, 1e-8);
}

static void test_triangle_in_metres(void)
{
    /* three spheres of 3.3 mm in an equilateral triangle, centres 1.5 radii
     * apart: each pair overlaps and all three share the region about the
     * centroid, so the quadrature path. Its tolerance was scaled by R^5 in
     * metres, far below the round-off of the volume (R^3): the panels halved
     * to the depth limit and rigid_create never returned. By symmetry the
     * centre of mass is the centroid and the in-plane inertia is isotropic;
     * by inclusion-exclusion 3 V1 - 3 L < V <= 3 V1 - 2 L (L the lens of a
     * pair, pi (4R + d)(2R - d)^2 / 12; the triple region is in (0, L]). */
    const double R = 3.3e-3, d = 1.5 * R, h = d * sqrt(3.0) / 2.0, rho = 1000.0;
    rigid_sphere_cfg_t s[3] = {{{0, 0, 0}, R, 0}, {{d, 0, 0}, R, 0}, {{d / 2.0, h, 0}, R, 0}};
    rigid_body_cfg_t b = {rho, {0, 0, 0}, {0, 0, 0}, 0};
    rigid_config_t cfg = test_cfg(3, s, 1, &b, 0, NULL);
    rigid_t *r = NULL;
    CU_ASSERT_EQUAL_FATAL(rigid_create(&cfg, NULL, &r), STATUS_OK);
    double com[3], m, I[9];
    rigid_get_body(r, 0, com, NULL, NULL, NULL, &m, I);
    const double v1 = 4.0 / 3.0 * M_PI * R * R * R, lens = M_PI * (4.0 * R + d) * pow(2.0 * R - d, 2) / 12.0;
    CU_ASSERT(m > rho * (3.0 * v1 - 3.0 * lens) && m <= rho * (3.0 * v1 - 2.0 * lens));
    CU_ASSERT(fabs(com[0] - d / 2.0) < 1e-7 * R && fabs(com[1] - h / 3.0) < 1e-7 * R && fabs(com[2]) < 1e-7 * R);
    CU_ASSERT(rel_err(I[0], I[4]) < 1e-7);
    CU_ASSERT(fabs(I[1]) < 1e-8 * I[0]);
    rigid_free(r);
}

static void test_symmetric_star(void)
{
    /* central sphere R with six touching arms r on +-x, +-y, +-z:
     * I = 2/5 Mc R^2 + 6 * 2/5 m r^2 + 4 m (R + r)^2 about every axis */
    double R = 4e-4, rr = 3e-4, rho = 2000.0, D = R + rr;
    rigid_sphere_cfg_t s[7] = {{{0, 0, 0}, R, 0},  {{D, 0, 0}, rr, 0},  {{-D, 0, 0}, rr, 0}, {{0, D, 0}, rr, 0},
                               {{0, -D, 0}, rr, 0}, {{0, 0, D}, rr, 0}, {{0, 0, -D}, rr, 0}};
    rigid_body_cfg_t b = {rho, {0, 0, 0}, {0, 0, 0}, 0};
    rigid_config_t cfg = test_cfg(7, s, 1, &b, 0, NULL);
    rigid_t *r = NULL;
    CU_ASSERT_EQUAL_FATAL(rigid_create(&cfg, NULL, &r), STATUS_OK);
    double mc = rho * 4.0 / 3.0 * M_PI * R * R * R, m = rho * 4.0 / 3.0 * M_PI * rr * rr * rr;
    double Iref = 0.4 * mc * R * R + 6 * 0.4 * m * rr * rr + 4 * m * D * D;
    double com[3], mass, I[9];
    rigid_get_body(r, 0, com, NULL, NULL, NULL, &mass, I);
    CU_ASSERT(rel_err(mass, mc + 6 * m) < 1e-14);
    CU_ASSERT(vec_norm(com) < 1e-18);
    for (int a = 0; a < 3; a++) {
        CU_ASSERT(rel_err(I[4 * a], Iref) < 1e-13);
    }
    rigid_free(r);
}

void test_body_register(void)
{
    CU_pSuite s = CU_add_suite("rigid_body_inertia", NULL, NULL);
    CU_add_test(s, "one sphere: 2/5 m r^2", test_one_sphere);
    CU_add_test(s, "two touching spheres: parallel axes", test_two_touching);
    CU_add_test(s, "two overlapping spheres: lens counted once", test_two_overlapping_lens);
    CU_add_test(s, "three overlapping in line: quadrature path", test_three_in_line_quadrature);
    CU_add_test(s, "three overlapping in a triangle, in metres: quadrature path", test_triangle_in_metres);
    CU_add_test(s, "symmetric star: isotropic inertia", test_symmetric_star);
}
