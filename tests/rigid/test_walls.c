/* test_walls.c — bodies against the faces of the box (rigid/pairs.c,
 * contact.c, rigid_scene.c).
 *
 * Every non-periodic face kind of a scene (no_slip, free_slip, moving_wall,
 * velocity_inlet, pressure_outlet) is a wall for the bodies, on each axis and
 * side: a sphere thrown at it with the linear spring-dashpot rebounds with
 * exactly the restitution e (the damped oscillator of Schwager & Poeschel,
 * Computational Granular Dynamics, 2005, section 3.1; Verlet at t_c/200 is
 * within 1%, as in test_contact.c). Across a periodic face two spheres meet
 * at the nearest image: the same collision as in the interior (momentum
 * conserved, rebound with e; with friction the same spins), to round-off.
 * Without a contact model a sphere that reaches a wall stops the run with a
 * message naming body, sphere, face and time; with one, an overlap deeper
 * than the radius does. A moving wall drags a resting sphere along through
 * friction until it rolls on the wall: a sphere sliding on a plane reaches
 * rolling at 5/7 of its initial speed relative to the plane (solid sphere,
 * I = 2/5 m r^2; e.g. Marion & Thornton, Classical Dynamics, rolling
 * motion), so on a belt at U it ends at 2U/7 with omega = -5U/(7r). */
#include "../../common/scene.h"
#include "test_rigid_util.h"

#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

/* ---- every face kind, through a scene ---- */

static const char *const FACE_KEYS[6] = {"x_min", "x_max", "y_min", "y_max", "z_min", "z_max"};
static const char *const KINDS[5] = {"no_slip", "free_slip", "moving_wall", "velocity_inlet", "pressure_outlet"};

/* Writes the scene of a sphere thrown at face f of kind k (the opposite face
 * no-slip, the other axes periodic) and loads it. */
static scene_t *wall_scene(int f, int k, double speed)
{
    int ax = f / 2, side = f % 2;
    double sign = side == 0 ? -1.0 : 1.0, vel[3] = {0, 0, 0}, wall[3] = {0, 0, 0};
    vel[ax] = sign * speed;
    char face[160] = "";
    if (k == 2) { /* a moving wall moves in its plane */
        wall[(ax + 1) % 3] = 1e-3;
        snprintf(face, sizeof face, ", velocity: [%g, %g, %g]", wall[0], wall[1], wall[2]);
    } else if (k == 3) { /* an inlet points into the domain */
        wall[ax] = -sign * 1e-3;
        snprintf(face, sizeof face, ", velocity: [%g, %g, %g]", wall[0], wall[1], wall[2]);
    }
    char text[2048];
    snprintf(text, sizeof text,
             "domain:\n"
             "  size: [1.0e-3, 1.0e-3, 1.0e-3]\n"
             "  faces:\n"
             "    %s: {type: %s%s}\n"
             "    %s: {type: no_slip}\n"
             "fluid: {density: 1000.0, viscosity: 1.0e-6, dx: 1.0e-4, tau: 1.0}\n"
             "bodies:\n"
             "  - density: 2500.0\n"
             "    velocity: [%g, %g, %g]\n"
             "    spheres:\n"
             "      - {center: [5.0e-4, 5.0e-4, 5.0e-4], radius: 2.0e-4}\n"
             "contacts: {model: spring_dashpot, restitution: 0.5, lubrication: {enabled: false}}\n"
             "rigid: {substeps: 20}\n"
             "run: {end_time: 1.0}\n",
             FACE_KEYS[f], KINDS[k], face, FACE_KEYS[f ^ 1], vel[0], vel[1], vel[2]);
    char path[] = "/tmp/rigid_walls_XXXXXX";
    int fd = mkstemp(path);
    CU_ASSERT_FATAL(fd >= 0);
    FILE *fp = fdopen(fd, "w");
    CU_ASSERT_PTR_NOT_NULL_FATAL(fp);
    fputs(text, fp);
    fclose(fp);
    scene_t *s = NULL;
    test_log_t tl = {"", 0};
    log_t lg = {test_log_fn, &tl};
    status_t st = scene_load(path, NULL, 0, &lg, &s);
    unlink(path);
    if (st != STATUS_OK) {
        printf("\n    scene for %s %s refused: %s\n", FACE_KEYS[f], KINDS[k], tl.last);
    }
    return s;
}

static void test_every_face_kind(void)
{
    const rigid_wall_kind_t expect[5] = {RIGID_WALL_NO_SLIP, RIGID_WALL_FREE_SLIP, RIGID_WALL_NO_SLIP, RIGID_WALL_OPEN,
                                         RIGID_WALL_OPEN};
    double speed = 0.01, worst = 0.0;
    for (int f = 0; f < 6; f++) {
        for (int k = 0; k < 5; k++) {
            int ax = f / 2, side = f % 2;
            scene_t *s = wall_scene(f, k, speed);
            CU_ASSERT_PTR_NOT_NULL_FATAL(s);
            rigid_config_t cfg;
            CU_ASSERT_EQUAL_FATAL(rigid_config_from_scene(s, 0.0, NULL, &cfg), STATUS_OK);
            CU_ASSERT(cfg.walls[ax][side] && cfg.walls[ax][side ^ 1]);
            CU_ASSERT_EQUAL(cfg.wall_kind[ax][side], expect[k]);
            CU_ASSERT_EQUAL(cfg.wall_velocity[ax][side][(ax + 1) % 3], k == 2 ? 1e-3 : 0.0);
            CU_ASSERT(!cfg.periodic[ax] && cfg.periodic[(ax + 1) % 3] && cfg.periodic[(ax + 2) % 3]);
            CU_ASSERT_EQUAL(cfg.contact_model, RIGID_CONTACT_SPRING_DASHPOT);
            CU_ASSERT_EQUAL(cfg.lubrication, 0);
            double h = s->fluid.dt;
            rigid_t *r = NULL;
            CU_ASSERT_EQUAL_FATAL(rigid_create(&cfg, NULL, &r), STATUS_OK);
            rigid_scene_config_free(&cfg);
            scene_free(s);
            double sign = side == 0 ? -1.0 : 1.0, vn = speed, x[3], v[3];
            int touched = 0, n;
            for (n = 0; n < 200; n++) {
                CU_ASSERT_EQUAL_FATAL(rigid_step(r, h), STATUS_OK);
                rigid_get_sphere(r, 0, x, v, NULL);
                double gap = side == 0 ? x[ax] - 2e-4 : 1e-3 - 2e-4 - x[ax];
                vn = sign * v[ax]; /* > 0 towards the face */
                touched |= gap < 0;
                if (touched && gap > 0) {
                    break;
                }
            }
            CU_ASSERT(touched && n < 200);
            double e = -vn / speed;
            worst = fmax(worst, rel_err(e, 0.5));
            CU_ASSERT(rel_err(e, 0.5) < 0.01);
            rigid_free(r);
        }
    }
    printf("\n    30 faces x kinds: worst restitution error %.4f (e = 0.5)\n", worst);
}

/* ---- across a periodic face ---- */

typedef struct {
    double v[2][3], w[2][3], p0[3], p1[3];
    int ok;
} pair_run_t;

/* Two spheres of radius 1e-4 m, centres 2.1e-4 m apart along x (offset dy
 * along y), closing at 0.15 m/s (and 1.5 vy along y), centred on x = xc
 * (xc = 0: across the periodic face x = 0 = 1e-3 m). */
static pair_run_t pair_collision(double xc, double dy, double friction, double vy)
{
    pair_run_t out = {0};
    double L = 1e-3, rr = 1e-4, half = 1.05e-4;
    double xa = xc - half < 0 ? xc - half + L : xc - half;
    rigid_sphere_cfg_t s[2] = {{{xa, 5e-4 - 0.5 * dy, 5e-4}, rr, 0}, {{xc + half, 5e-4 + 0.5 * dy, 5e-4}, rr, 1}};
    rigid_body_cfg_t b[2] = {{2500.0, {0.1, vy, 0}, {0, 0, 0}, 0}, {2500.0, {-0.05, -0.5 * vy, 0}, {0, 0, 0}, 0}};
    rigid_config_t cfg = test_cfg(2, s, 2, b, 0, NULL);
    cfg.contact_model = RIGID_CONTACT_SPRING_DASHPOT;
    cfg.restitution = 0.7;
    cfg.contact_time = 1e-4;
    cfg.friction = friction;
    for (int a = 0; a < 3; a++) {
        cfg.periodic[a] = 1;
        cfg.box_lo[a] = 0.0;
        cfg.box_hi[a] = L;
    }
    rigid_t *r = NULL;
    if (rigid_create(&cfg, NULL, &r) != STATUS_OK) {
        return out;
    }
    double l[3];
    rigid_momentum(r, out.p0, l);
    for (int n = 0; n < 500; n++) { /* t_c / 200, as in test_contact.c */
        if (rigid_step(r, 5e-7) != STATUS_OK) {
            rigid_free(r);
            return out;
        }
    }
    for (int i = 0; i < 2; i++) {
        rigid_get_sphere(r, i, NULL, out.v[i], out.w[i]);
    }
    rigid_momentum(r, out.p1, l);
    out.ok = 1;
    rigid_free(r);
    return out;
}

static void test_periodic_contact(void)
{
    /* head-on, no friction: momentum, restitution */
    pair_run_t c = pair_collision(0.0, 0.0, 0.0, 0.0);
    CU_ASSERT_FATAL(c.ok);
    for (int a = 0; a < 3; a++) {
        CU_ASSERT(fabs(c.p1[a] - c.p0[a]) < 1e-12 * vec_norm(c.p0) + 1e-20);
    }
    double e = (c.v[1][0] - c.v[0][0]) / 0.15; /* separating / closing speed along x */
    CU_ASSERT(rel_err(e, 0.7) < 0.01);
    /* oblique with friction: the contact point and lever arms of the image
     * give the same velocities and spins as the same collision inside */
    pair_run_t p = pair_collision(0.0, 5e-5, 0.3, 0.02), q = pair_collision(5e-4, 5e-5, 0.3, 0.02);
    CU_ASSERT_FATAL(p.ok && q.ok);
    double dmax = 0.0, wmax = 0.0;
    for (int i = 0; i < 2; i++) {
        for (int a = 0; a < 3; a++) {
            dmax = fmax(dmax, fabs(p.v[i][a] - q.v[i][a]));
            dmax = fmax(dmax, 1e-4 * fabs(p.w[i][a] - q.w[i][a])); /* r omega */
            wmax = fmax(wmax, fabs(q.w[i][a]));
        }
    }
    CU_ASSERT(wmax > 10.0); /* friction did spin them */
    CU_ASSERT(dmax < 1e-9);
    for (int a = 0; a < 3; a++) {
        CU_ASSERT(fabs(p.p1[a] - p.p0[a]) < 1e-12 * vec_norm(p.p0) + 1e-20);
    }
    printf("\n    periodic: e = %.4f (0.7); oblique vs interior: max difference %.2e m/s (spin %.1f rad/s)\n", e, dmax,
           wmax);
}

/* ---- faults: no contact model, overlap beyond a radius ---- */

static status_t throw_at(int face, rigid_contact_model_t model, rigid_integrator_t integ, double speed, double h,
                         test_log_t *tl, double *t_end)
{
    int ax = face / 2, side = face % 2;
    double rr = 1e-4, c[3] = {5e-4, 5e-4, 5e-4}, v[3] = {0, 0, 0};
    v[ax] = side == 0 ? -speed : speed;
    rigid_sphere_cfg_t s = {{c[0], c[1], c[2]}, rr, 0};
    rigid_body_cfg_t b = {2500.0, {v[0], v[1], v[2]}, {0, 0, 0}, 0};
    rigid_config_t cfg = test_cfg(1, &s, 1, &b, 0, NULL);
    cfg.contact_model = model;
    cfg.restitution = 0.5;
    cfg.contact_time = 1e-3;
    cfg.integrator = integ;
    cfg.cvode_method = RIGID_BDF;
    for (int a = 0; a < 3; a++) {
        cfg.walls[a][0] = cfg.walls[a][1] = 1;
        cfg.box_lo[a] = 0.0;
        cfg.box_hi[a] = 1e-3;
    }
    log_t lg = {test_log_fn, tl};
    rigid_t *r = NULL;
    status_t st = rigid_create(&cfg, &lg, &r);
    if (st != STATUS_OK) {
        return st;
    }
    for (int n = 0; n < 1000 && st == STATUS_OK; n++) {
        st = rigid_step(r, h);
    }
    *t_end = rigid_time(r);
    rigid_free(r);
    return st;
}

static double message_time(const char *msg)
{
    const char *p = strstr(msg, "at t = ");
    double t = NAN;
    if (p == NULL || sscanf(p, "at t = %lf", &t) != 1) {
        return NAN;
    }
    return t;
}

static void test_no_contact_model(void)
{
    const int faces[2] = {4, 1}; /* z_min, x_max */
    const char *const expect[2] = {"body 0 sphere 0 reached face z_min at t = ", "body 0 sphere 0 reached face x_max at t = "};
    for (int k = 0; k < 2; k++) {
        for (int integ = 0; integ < 2; integ++) {
            test_log_t tl = {"", 0};
            double t_end;
            status_t st = throw_at(faces[k], RIGID_CONTACT_NONE, integ == 0 ? RIGID_VERLET : RIGID_CVODE, 0.01, 1e-3,
                                   &tl, &t_end);
            CU_ASSERT_EQUAL(st, STATUS_ERROR);
            CU_ASSERT_EQUAL(tl.nerr, 1);
            CU_ASSERT_PTR_NOT_NULL(strstr(tl.last, expect[k]));
            CU_ASSERT_PTR_NOT_NULL(strstr(tl.last, "no contact model is set (contacts.model: none)"));
            CU_ASSERT_PTR_NOT_NULL(strstr(tl.last, "set contacts.model: spring_dashpot or hertz"));
            /* the surface reaches the face after 4e-4 m / 0.01 m/s = 0.04 s */
            double t = message_time(tl.last);
            CU_ASSERT(t >= 0.04 - 1e-9 && t <= 0.041 + 1e-9);
            if (k == 0 && integ == 0) {
                printf("\n    %s\n", tl.last);
            }
        }
    }
}

static void test_deep_overlap(void)
{
    /* 1 m/s into a contact of t_c = 1 ms: the overlap would reach v t_c / pi ~ 3 radii */
    test_log_t tl = {"", 0};
    double t_end;
    status_t st = throw_at(4, RIGID_CONTACT_SPRING_DASHPOT, RIGID_VERLET, 1.0, 1e-5, &tl, &t_end);
    CU_ASSERT_EQUAL(st, STATUS_ERROR);
    CU_ASSERT_PTR_NOT_NULL(strstr(tl.last, "body 0 sphere 0 overlaps face z_min by"));
    CU_ASSERT_PTR_NOT_NULL(strstr(tl.last, "more than its radius"));
    CU_ASSERT(isfinite(message_time(tl.last)));
}

/* ---- a moving wall drags a resting sphere ---- */

static void test_moving_wall_drags(void)
{
    double rr = 1e-4, U = 0.01;
    rigid_sphere_cfg_t s = {{5e-4, 5e-4, rr}, rr, 0};
    rigid_body_cfg_t b = {2500.0, {0, 0, 0}, {0, 0, 0}, 0};
    rigid_config_t cfg = test_cfg(1, &s, 1, &b, 0, NULL);
    cfg.gravity[2] = -9.81;
    cfg.contact_model = RIGID_CONTACT_SPRING_DASHPOT;
    cfg.restitution = 0.5;
    cfg.contact_time = 1e-4; /* static overlap m g / k = 1e-4 r: rolling radius r */
    cfg.friction = 0.5;
    cfg.walls[2][0] = 1;
    cfg.wall_kind[2][0] = RIGID_WALL_NO_SLIP;
    cfg.wall_velocity[2][0][0] = U;
    cfg.box_lo[2] = 0.0;
    cfg.box_hi[2] = 1e-3;
    rigid_t *r = NULL;
    CU_ASSERT_EQUAL_FATAL(rigid_create(&cfg, NULL, &r), STATUS_OK);
    /* sliding ends after 2U/(7 mu g) = 0.6 ms; the regularised stick phase
     * damps the remaining slip at 7/t_c */
    for (int n = 0; n < 20000; n++) {
        CU_ASSERT_EQUAL_FATAL(rigid_step(r, 1e-6), STATUS_OK);
    }
    double x[3], v[3], w[3];
    rigid_get_sphere(r, 0, x, v, w);
    CU_ASSERT(x[0] > 5.4e-4); /* carried along: about 2U/7 x 0.02 s = 5.7e-5 m */
    CU_ASSERT(rel_err(v[0], 2 * U / 7) < 0.002);
    CU_ASSERT(rel_err(w[1], -5 * U / (7 * rr)) < 0.002);
    CU_ASSERT(fabs(v[2]) < 1e-6);
    printf("\n    moving wall U = %g m/s: v = %.6f (2U/7 = %.6f), omega_y = %.3f (%.3f)\n", U, v[0], 2 * U / 7, w[1],
           -5 * U / (7 * rr));
    rigid_free(r);
}

void test_walls_register(void)
{
    CU_pSuite s = CU_add_suite("rigid_walls", NULL, NULL);
    CU_add_test(s, "every face kind on each axis and side: rebound with e", test_every_face_kind);
    CU_add_test(s, "contact across a periodic face = the same contact inside", test_periodic_contact);
    CU_add_test(s, "no contact model: reaching a wall is an error naming body, sphere, face, time",
                test_no_contact_model);
    CU_add_test(s, "overlap beyond the radius is an error", test_deep_overlap);
    CU_add_test(s, "a moving wall drags a resting sphere (rolls at 2U/7)", test_moving_wall_drags);
}
