/* scene_build.c — a scene_t from the raw structs libcyaml fills (step 5 of
 * scene_load).
 *
 * Defaults are filled in here and nowhere else, derived values computed (dx
 * from cells_per_radius, tau <-> dt) and each value range-checked where it is
 * read. The checks that relate values to each other (scene_check.c) run in
 * scene_build once their inputs are known to be usable. Every violation is
 * reported, not only the first; the caller frees a partly built scene. */
#include "initial_profile.h"
#include "scene_internal.h"

#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const FACE_KEYS[6] = {"x_min", "x_max", "y_min", "y_max", "z_min", "z_max"};

static double opt(const double *p, double dflt)
{
    return p != NULL ? *p : dflt;
}

static void opt_vec(double out[3], const double *p, double x, double y, double z)
{
    out[0] = p ? p[0] : x;
    out[1] = p ? p[1] : y;
    out[2] = p ? p[2] : z;
}

/* Returns false when the domain is unusable for the geometric checks that follow. */
static bool build_domain(ctx_t *c, const raw_domain_t *r, scene_domain_t *d)
{
    bool ok = true;
    for (int a = 0; a < 3; a++) {
        d->size[a] = r->size[a];
        if (!isfinite(r->size[a]) || r->size[a] <= 0) {
            scene_report_bad(c, "domain.size", "= %s: the %c extent is %s; allowed: each in (0, inf) m",
                             fmt_vec(r->size, 3).s, AXIS_NAMES[a], fmt_num(r->size[a]).s);
            ok = false;
        }
    }
    const raw_face_t *rf[6] = {NULL, NULL, NULL, NULL, NULL, NULL};
    if (r->faces != NULL) {
        rf[0] = r->faces->x_min;
        rf[1] = r->faces->x_max;
        rf[2] = r->faces->y_min;
        rf[3] = r->faces->y_max;
        rf[4] = r->faces->z_min;
        rf[5] = r->faces->z_max;
    }
    char key[SCENE_KEY_MAX];
    for (int f = 0; f < 6; f++) {
        face_t *face = &d->faces[f];
        const raw_face_t *raw = rf[f];
        int axis = f / 2;
        face->type = raw ? raw->type : FACE_PERIODIC;
        opt_vec(face->velocity, raw ? raw->velocity : NULL, 0, 0, 0);
        face->profile = (raw && raw->profile) ? *raw->profile : PROFILE_UNIFORM;
        face->pressure = opt(raw ? raw->pressure : NULL, 0.0);
        if (raw == NULL) {
            continue;
        }
        const char *tname = face_type_name(face->type);
        bool uses_velocity = face->type == FACE_MOVING_WALL || face->type == FACE_VELOCITY_INLET;
        if (uses_velocity && raw->velocity == NULL) {
            snprintf(key, sizeof key, "domain.faces.%s.velocity", FACE_KEYS[f]);
            scene_report_bad(c, key, "required for a %s face but missing; allowed: a list of 3 numbers in m/s", tname);
        }
        if (!uses_velocity && raw->velocity != NULL) {
            snprintf(key, sizeof key, "domain.faces.%s.velocity", FACE_KEYS[f]);
            scene_report_warn(c, key, "= %s: ignored for a %s face (used by moving_wall and velocity_inlet only)",
                              fmt_vec(raw->velocity, 3).s, tname);
        }
        if (face->type != FACE_VELOCITY_INLET && raw->profile != NULL) {
            snprintf(key, sizeof key, "domain.faces.%s.profile", FACE_KEYS[f]);
            scene_report_warn(c, key, "ignored for a %s face (used by velocity_inlet only)", tname);
        }
        if (face->type != FACE_PRESSURE_OUTLET && raw->pressure != NULL) {
            snprintf(key, sizeof key, "domain.faces.%s.pressure", FACE_KEYS[f]);
            scene_report_warn(c, key, "= %s: ignored for a %s face (used by pressure_outlet only)",
                              fmt_num(*raw->pressure).s, tname);
        }
        if (raw->velocity != NULL && uses_velocity) {
            snprintf(key, sizeof key, "domain.faces.%s.velocity", FACE_KEYS[f]);
            if (scene_check_vec(c, key, face->velocity, 3)) {
                double vn = face->velocity[axis];
                if (face->type == FACE_MOVING_WALL && vn != 0.0) {
                    scene_report_bad(c, key,
                                     "= %s: a moving wall moves in its own plane, but the normal (%c) component "
                                     "is %s; allowed: %c component = 0",
                                     fmt_vec(face->velocity, 3).s, AXIS_NAMES[axis], fmt_num(vn).s, AXIS_NAMES[axis]);
                }
                bool inward = (f % 2 == 0) ? vn > 0 : vn < 0;
                if (face->type == FACE_VELOCITY_INLET && !inward) {
                    scene_report_bad(c, key,
                                     "= %s: an inlet on %s must point into the domain; allowed: %c component %s 0",
                                     fmt_vec(face->velocity, 3).s, FACE_KEYS[f], AXIS_NAMES[axis],
                                     (f % 2 == 0) ? ">" : "<");
                }
            }
        }
        if (face->type == FACE_PRESSURE_OUTLET) {
            snprintf(key, sizeof key, "domain.faces.%s.pressure", FACE_KEYS[f]);
            scene_check_range(c, key, face->pressure, -INFINITY, INFINITY, 0);
        }
    }
    for (int a = 0; a < 3; a++) {
        bool lo = d->faces[2 * a].type == FACE_PERIODIC;
        bool hi = d->faces[2 * a + 1].type == FACE_PERIODIC;
        if (lo != hi) {
            int np = lo ? 2 * a + 1 : 2 * a; /* the face that is not periodic */
            snprintf(key, sizeof key, "domain.faces.%s.type", FACE_KEYS[np]);
            scene_report_bad(c, key, "= %s, but %s is periodic; allowed: periodic on both %s and %s, or on neither",
                             face_type_name(d->faces[np].type), FACE_KEYS[lo ? 2 * a : 2 * a + 1], FACE_KEYS[2 * a],
                             FACE_KEYS[2 * a + 1]);
        }
    }
    return ok;
}

static bool build_bodies(ctx_t *c, const raw_scene_t *r, scene_t *s)
{
    if (r->bodies_count > (unsigned)INT_MAX) {
        scene_report_bad(c, "bodies", "%u bodies; allowed: at most %d", r->bodies_count, INT_MAX);
        return false;
    }
    s->nbodies = (int)r->bodies_count;
    if (s->nbodies == 0) {
        return true;
    }
    s->bodies = calloc((size_t)s->nbodies, sizeof *s->bodies);
    if (s->bodies == NULL) {
        scene_report_oom(c);
        return false;
    }
    long total = 0;
    char key[SCENE_KEY_MAX];
    for (int i = 0; i < s->nbodies; i++) {
        const raw_body_t *rb = &r->bodies[i];
        scene_body_t *b = &s->bodies[i];
        total += (long)rb->spheres_count;
        if (total > INT_MAX) {
            scene_report_bad(c, "bodies", "more than %d spheres in total", INT_MAX);
            return false;
        }
        if (rb->name != NULL) {
            b->name = strdup(rb->name);
            if (b->name == NULL) {
                scene_report_oom(c);
                return false;
            }
        }
        b->nspheres = (int)rb->spheres_count;
        b->spheres = malloc((size_t)b->nspheres * sizeof *b->spheres);
        if (b->spheres == NULL) {
            scene_report_oom(c);
            return false;
        }
        memcpy(b->spheres, rb->spheres, (size_t)b->nspheres * sizeof *b->spheres);
        b->density = rb->density;
        b->motion = rb->motion ? *rb->motion : MOTION_FREE;
        opt_vec(b->velocity, rb->velocity, 0, 0, 0);
        opt_vec(b->angular_velocity, rb->angular_velocity, 0, 0, 0);
        b->move_with_flow = rb->move_with_flow != NULL && *rb->move_with_flow;
        if (b->move_with_flow) {
            snprintf(key, sizeof key, "bodies.%d.move_with_flow", i);
            if (b->motion != MOTION_FREE) {
                scene_report_bad(c, key, "= true for a %s body; allowed: for free bodies only (a prescribed body "
                                 "moves as given, a fixed one not at all)",
                                 b->motion == MOTION_FIXED ? "fixed" : "prescribed");
            } else if (rb->velocity != NULL || rb->angular_velocity != NULL) {
                scene_report_warn(c, key, "= true: bodies.%d.%s given too is replaced by the flow's", i,
                                  rb->velocity != NULL && rb->angular_velocity != NULL ? "velocity and angular_velocity"
                                  : rb->velocity != NULL                                ? "velocity"
                                                                                        : "angular_velocity");
            }
        }

        if (b->motion == MOTION_FIXED && rb->velocity != NULL) {
            snprintf(key, sizeof key, "bodies.%d.velocity", i);
            scene_report_warn(c, key, "= %s: ignored for a fixed body (it never moves; motion: prescribed moves "
                              "a body with its velocity)", fmt_vec(rb->velocity, 3).s);
        }
        if (b->motion == MOTION_FIXED && rb->angular_velocity != NULL) {
            snprintf(key, sizeof key, "bodies.%d.angular_velocity", i);
            scene_report_warn(c, key, "= %s: ignored for a fixed body (it never moves; motion: prescribed turns "
                              "a body with its angular velocity)", fmt_vec(rb->angular_velocity, 3).s);
        }

        snprintf(key, sizeof key, "bodies.%d.density", i);
        scene_check_range(c, key, b->density, 0, INFINITY, LO_OPEN);
        snprintf(key, sizeof key, "bodies.%d.velocity", i);
        scene_check_vec(c, key, b->velocity, 3);
        snprintf(key, sizeof key, "bodies.%d.angular_velocity", i);
        scene_check_vec(c, key, b->angular_velocity, 3);
        for (int k = 0; k < b->nspheres; k++) {
            snprintf(key, sizeof key, "bodies.%d.spheres.%d.center", i, k);
            scene_check_vec(c, key, b->spheres[k].center, 3);
            snprintf(key, sizeof key, "bodies.%d.spheres.%d.radius", i, k);
            scene_check_range(c, key, b->spheres[k].radius, 0, INFINITY, LO_OPEN);
        }
    }
    return true;
}

static double smallest_radius(const scene_t *s)
{
    double rmin = INFINITY;
    for (int i = 0; i < s->nbodies; i++) {
        for (int k = 0; k < s->bodies[i].nspheres; k++) {
            rmin = fmin(rmin, s->bodies[i].spheres[k].radius);
        }
    }
    return rmin;
}

/* The step of a scene that gives tau: dt = (tau - 1/2) dx^2 / (3 nu) rounded
 * to a whole number of nanoseconds, tau then set from it (tau = 1/2 + 3 nu
 * dt / dx^2), so that masters counting time in integer ns (libcosim/OSP) can
 * step the FMUs (scene.h). nu and dx stay exact: the physics is unchanged,
 * only the numerical parameter tau moves, by at most 0.5 ns / dt of tau - 1/2
 * (1e-5 for the default scene). When that exceeds SCENE_DT_ROUND_MAX (dt
 * below ~50 ns) dt stays exact and `coupler check` warns. A dt that is whole
 * already (within round-off) leaves tau bit-identical. */
static double whole_ns_step(scene_fluid_t *f)
{
    const double dt = (f->tau - 0.5) * f->dx * f->dx / (3.0 * f->viscosity);
    const double ns = dt * 1e9, n = nearbyint(ns);
    if (!(n >= 1.0) || fabs(ns - n) > SCENE_DT_ROUND_MAX * ns) {
        return dt;
    }
    if (fabs(ns - n) > 1e-12 * n) {
        f->tau = 0.5 + 3.0 * f->viscosity * (n / 1e9) / (f->dx * f->dx);
    }
    return n / 1e9;
}

/* Resolution and time step. Returns true when dx (and, via *dt_ok, dt) are usable. */
static bool build_fluid(ctx_t *c, const raw_fluid_t *r, scene_t *s, bool *dt_ok)
{
    scene_fluid_t *f = &s->fluid;
    *dt_ok = false;
    f->density = r->density;
    f->viscosity = r->viscosity;
    /* (the moments layout's only collision is its default there) */
    f->collision = r->collision                                             ? *r->collision
                   : r->streaming != NULL && *r->streaming == STREAMING_MOMENTS ? COLLISION_REGULARIZED
                                                                             : COLLISION_TRT;
    opt_vec(f->body_force, r->body_force, 0, 0, 0);
    opt_vec(f->initial_velocity, r->initial_velocity, 0, 0, 0);
    f->initial_profile = r->initial_profile ? *r->initial_profile : INITIAL_UNIFORM;
    f->channel_axis = -1;
    f->boundary_scheme = r->boundary_scheme ? *r->boundary_scheme : BOUNDARY_MULTIREFLECTION;
    /* Lambda 1/4 makes multireflection's drag position independent (README issue 11); 3/16 suits the others */
    f->magic = opt(r->magic, f->boundary_scheme == BOUNDARY_MULTIREFLECTION ? 0.25 : 3.0 / 16.0);
    f->refill = r->refill ? *r->refill : REFILL_EXTRAPOLATION;
    f->force_method = r->force ? *r->force : FORCE_GALILEAN;
    f->streaming = r->streaming ? *r->streaming : STREAMING_IN_PLACE;
    f->precision = r->precision ? *r->precision : PRECISION_DOUBLE;
    f->force_averaging = r->force_averaging ? (*r->force_averaging ? 1 : 0) : -1; /* -1: per body (coupling.h) */
    f->mach_limit = opt(r->mach_limit, SCENE_MACH_LIMIT_DEFAULT);

    bool nu_ok = scene_check_range(c, "fluid.viscosity", f->viscosity, 0, INFINITY, LO_OPEN);
    scene_check_range(c, "fluid.density", f->density, 0, INFINITY, LO_OPEN);
    scene_check_range(c, "fluid.magic", f->magic, 0, INFINITY, LO_OPEN);
    /* above Mach 1 the lattice (c = 1 cell per step, c_s = 1/sqrt(3)) cannot carry the flow at all */
    scene_check_range(c, "fluid.mach_limit", f->mach_limit, 0, 1, LO_OPEN);
    /* the moments layout keeps what a regularized collision leaves, and
     * only the moments layout has that collision (fluid/kernel_moments.c) */
    if (f->streaming == STREAMING_MOMENTS && f->collision != COLLISION_REGULARIZED) {
        scene_report_bad(c, "fluid.collision",
                         "= %s with fluid.streaming = moments, which stores 10 moments per cell and so only a "
                         "regularized collision; allowed with it: regularized",
                         f->collision == COLLISION_BGK ? "bgk" : "trt");
    } else if (f->collision == COLLISION_REGULARIZED && f->streaming != STREAMING_MOMENTS) {
        scene_report_bad(c, "fluid.collision",
                         "= regularized with fluid.streaming = %s; the regularized collision is implemented in the "
                         "moments layout only: allowed with %s: bgk, trt (or fluid.streaming: moments)",
                         f->streaming == STREAMING_TWO_ARRAY ? "two_array" : "in_place",
                         f->streaming == STREAMING_TWO_ARRAY ? "two_array" : "in_place");
    }
    if (f->streaming == STREAMING_MOMENTS && f->precision != PRECISION_DOUBLE) {
        scene_report_bad(c, "fluid.precision",
                         "= single with fluid.streaming = moments; allowed with it: double (the moments layout "
                         "stores doubles)");
    }
    if (r->magic != NULL && f->collision == COLLISION_BGK) {
        scene_report_warn(c, "fluid.magic", "= %s: ignored with fluid.collision = bgk (used by trt only)",
                          fmt_num(f->magic).s);
    }
    scene_check_vec(c, "fluid.body_force", f->body_force, 3);
    scene_check_vec(c, "fluid.initial_velocity", f->initial_velocity, 3);

    bool dx_ok = false;
    const char *dx_key = r->dx != NULL ? "fluid.dx" : "fluid.cells_per_radius";
    const double rmin = smallest_radius(s);
    if ((r->dx != NULL) == (r->cells_per_radius != NULL)) {
        scene_report_bad(c, r->dx ? "fluid.dx" : "fluid",
                         "%s; allowed: exactly one of fluid.dx (m) and fluid.cells_per_radius",
                         r->dx ? "both fluid.dx and fluid.cells_per_radius are given"
                               : "neither fluid.dx nor fluid.cells_per_radius is given");
    } else if (r->dx != NULL) {
        f->dx = *r->dx;
        f->cells_per_radius = 0.0;
        dx_ok = scene_check_range(c, "fluid.dx", f->dx, 0, INFINITY, LO_OPEN);
    } else {
        f->cells_per_radius = *r->cells_per_radius;
        if (scene_check_range(c, "fluid.cells_per_radius", f->cells_per_radius, SCENE_MIN_RADIUS_CELLS, INFINITY, 0)) {
            if (!isfinite(rmin)) {
                scene_report_bad(c, "fluid.cells_per_radius",
                                 "= %s: needs at least one sphere in bodies to set the cell size; allowed: give "
                                 "fluid.dx instead",
                                 fmt_num(f->cells_per_radius).s);
            } else if (rmin > 0) {
                f->dx = rmin / f->cells_per_radius;
                dx_ok = true;
            }
        }
    }

    if ((r->tau != NULL) == (r->dt != NULL)) {
        scene_report_bad(c, r->tau ? "fluid.tau" : "fluid", "%s; allowed: exactly one of fluid.tau and fluid.dt (s)",
                         r->tau ? "both fluid.tau and fluid.dt are given" : "neither fluid.tau nor fluid.dt is given");
    } else if (r->tau != NULL) {
        f->tau = f->tau_requested = *r->tau;
        /* tau = 1/2 + 3 nu dt / dx^2 (lattice viscosity nu_lb = (tau - 1/2)/3) */
        if (scene_check_range(c, "fluid.tau", f->tau, 0.5, INFINITY, LO_OPEN) && dx_ok && nu_ok) {
            f->dt = whole_ns_step(f);
            *dt_ok = scene_check_step(c, dx_key, s, rmin, false);
        }
    } else {
        f->tau_requested = 0.0;
        f->dt = *r->dt;
        if (scene_check_range(c, "fluid.dt", f->dt, 0, INFINITY, LO_OPEN) && dx_ok && nu_ok &&
            scene_check_step(c, dx_key, s, rmin, true)) {
            f->tau = 0.5 + 3.0 * f->viscosity * f->dt / (f->dx * f->dx);
            if (!(f->tau > 0.5) || !isfinite(f->tau)) {
                scene_report_bad(c, "fluid.dt",
                                 "= %s gives tau = 0.5 + 3 nu dt / dx^2 = %s; allowed: a dt for which tau is "
                                 "in (0.5, inf)",
                                 fmt_num(f->dt).s, fmt_num(f->tau).s);
            } else {
                *dt_ok = true;
            }
        }
    }
    return dx_ok;
}

/* The global index of body b's first sphere (bodies in order). */
static int first_sphere(const scene_t *s, int b)
{
    int k = 0;
    for (int i = 0; i < b; i++) {
        k += s->bodies[i].nspheres;
    }
    return k;
}

/* The body of global sphere k (0 <= k < scene_total_spheres). */
static int body_of_sphere(const scene_t *s, int k)
{
    int b = 0;
    while (b < s->nbodies - 1 && k >= s->bodies[b].nspheres) {
        k -= s->bodies[b].nspheres;
        b++;
    }
    return b;
}

static bool build_connections(ctx_t *c, const raw_scene_t *r, scene_t *s)
{
    if (r->connections_count > (unsigned)INT_MAX) {
        scene_report_bad(c, "connections", "%u connections; allowed: at most %d", r->connections_count, INT_MAX);
        return false;
    }
    s->nconnections = (int)r->connections_count;
    if (s->nconnections == 0) {
        return true;
    }
    s->connections = calloc((size_t)s->nconnections, sizeof *s->connections);
    if (s->connections == NULL) {
        scene_report_oom(c);
        return false;
    }
    int ns = scene_total_spheres(s);
    char key[SCENE_KEY_MAX];
    for (int i = 0; i < s->nconnections; i++) {
        const raw_connection_t *rc = &r->connections[i];
        scene_connection_t *cn = &s->connections[i];
        snprintf(key, sizeof key, "connections.%d.spheres", i);
        bool ok = true;
        for (int e = 0; e < 2; e++) {
            if (!isfinite(rc->spheres[e]) || rc->spheres[e] != floor(rc->spheres[e]) || rc->spheres[e] < 0 ||
                rc->spheres[e] >= ns) {
                if (ns == 0) {
                    scene_report_bad(c, key,
                                     "= %s: sphere index %s does not exist; allowed: none, the scene has no spheres "
                                     "(connections join spheres of bodies)",
                                     fmt_vec(rc->spheres, 2).s, fmt_num(rc->spheres[e]).s);
                    ok = false;
                    break;
                }
                scene_report_bad(c, key,
                                 "= %s: sphere index %s does not exist; allowed: integers in [0, %d] (global sphere "
                                 "indices: bodies in order, their spheres in order; the scene has %d spheres)",
                                 fmt_vec(rc->spheres, 2).s, fmt_num(rc->spheres[e]).s, ns - 1, ns);
                ok = false;
                break;
            }
        }
        if (ok && rc->spheres[0] == rc->spheres[1]) {
            scene_report_bad(c, key,
                             "= %s: a sphere cannot be connected to itself; allowed: two different sphere indices",
                             fmt_vec(rc->spheres, 2).s);
            ok = false;
        }
        /* a connection is a sintered neck inside one agglomerate: the rigid
         * component refuses one between bodies (each body is one rigid
         * piece until its connections break); said here, with the key, so
         * that `coupler check` refuses what `coupler run` would, not the
         * rigid FMU at initialisation without file or line */
        if (ok) {
            const int ba = body_of_sphere(s, (int)rc->spheres[0]), bb = body_of_sphere(s, (int)rc->spheres[1]);
            if (ba != bb) {
                scene_report_bad(c, key,
                                 "= %s: sphere %d (body %d) and sphere %d (body %d) belong to different bodies; "
                                 "allowed: two spheres of one body (bodies.%d has spheres %d to %d)",
                                 fmt_vec(rc->spheres, 2).s, (int)rc->spheres[0], ba, (int)rc->spheres[1], bb, ba,
                                 first_sphere(s, ba), first_sphere(s, ba) + s->bodies[ba].nspheres - 1);
                ok = false;
            }
        }
        cn->a = ok ? (int)rc->spheres[0] : -1;
        cn->b = ok ? (int)rc->spheres[1] : -1;
        for (int j = 0; ok && j < i; j++) {
            const scene_connection_t *o = &s->connections[j];
            if ((o->a == cn->a && o->b == cn->b) || (o->a == cn->b && o->b == cn->a)) {
                scene_report_bad(c, key,
                                 "= %s: the pair is already connected by connections.%d; allowed: each pair once",
                                 fmt_vec(rc->spheres, 2).s, j);
                break;
            }
        }
        cn->max_normal = opt(rc->max_normal, INFINITY);
        cn->max_shear = opt(rc->max_shear, INFINITY);
        cn->max_torque = opt(rc->max_torque, INFINITY);
        snprintf(key, sizeof key, "connections.%d.max_normal", i);
        scene_check_range(c, key, cn->max_normal, 0, INFINITY, ALLOW_INF);
        snprintf(key, sizeof key, "connections.%d.max_shear", i);
        scene_check_range(c, key, cn->max_shear, 0, INFINITY, ALLOW_INF);
        snprintf(key, sizeof key, "connections.%d.max_torque", i);
        scene_check_range(c, key, cn->max_torque, 0, INFINITY, ALLOW_INF);
    }
    return true;
}

/* Contacts and lubrication. Two defaults follow the scene: contact_time is
 * ten fluid steps (Costa et al. 2015, Phys. Rev. E 92, 053012, resolve a
 * collision in about ten), lubrication.min_gap 1e-3 of the smallest sphere
 * radius; the lubrication cut-off is 2 cells, where the film zone makes the
 * force of a close pair independent of where its gap sits in the cell (README
 * "Lubrication"). */
static void build_contacts(ctx_t *c, const raw_contacts_t *r, scene_t *s, bool dt_ok)
{
    static const raw_contacts_t none = {0};
    static const raw_lubrication_t no_lub = {0};
    scene_contacts_t *k = &s->contacts;
    if (r == NULL) {
        r = &none;
    }
    const raw_lubrication_t *rl = r->lubrication != NULL ? r->lubrication : &no_lub;
    k->model = r->model ? *r->model : CONTACT_SPRING_DASHPOT;
    k->restitution = opt(r->restitution, 0.9);
    k->contact_time = opt(r->contact_time, dt_ok ? 10.0 * s->fluid.dt : 1e-4);
    k->friction = opt(r->friction, 0.0);
    k->young_modulus = opt(r->young_modulus, 1e9);
    k->poisson_ratio = opt(r->poisson_ratio, 0.3);
    k->stick_speed = opt(r->stick_speed, 0.0);
    scene_lubrication_t *l = &k->lubrication;
    double rmin = smallest_radius(s);
    l->enabled = rl->enabled ? (*rl->enabled ? 1 : 0) : k->model != CONTACT_NONE;
    l->cutoff = opt(rl->cutoff, 2.0);
    l->min_gap = opt(rl->min_gap, isfinite(rmin) ? 1e-3 * rmin : 0.0);
    scene_check_range(c, "contacts.restitution", k->restitution, 0, 1, LO_OPEN);
    scene_check_range(c, "contacts.contact_time", k->contact_time, 0, INFINITY, LO_OPEN);
    scene_check_range(c, "contacts.friction", k->friction, 0, INFINITY, 0);
    scene_check_range(c, "contacts.young_modulus", k->young_modulus, 0, INFINITY, LO_OPEN);
    scene_check_range(c, "contacts.poisson_ratio", k->poisson_ratio, 0, 0.5, HI_OPEN);
    scene_check_range(c, "contacts.stick_speed", k->stick_speed, 0, INFINITY, 0);
    scene_check_range(c, "contacts.lubrication.cutoff", l->cutoff, 0, 10, LO_OPEN);
    if (rl->min_gap != NULL) {
        scene_check_range(c, "contacts.lubrication.min_gap", l->min_gap, 0, INFINITY, LO_OPEN);
    }
    /* keys the chosen model does not read (rigid/contact.c), as fluid.magic
     * with BGK: said, so that a value meant to act is not taken in silence */
    static const char *const model_name[] = {[CONTACT_NONE] = "none", [CONTACT_SPRING_DASHPOT] = "spring_dashpot",
                                             [CONTACT_HERTZ] = "hertz"};
    const struct {
        const char *key;
        const double *given;
        int used; /* by the chosen model */
        const char *by;
    } keys[] = {
        {"contacts.restitution", r->restitution, k->model != CONTACT_NONE, "spring_dashpot and hertz"},
        {"contacts.friction", r->friction, k->model != CONTACT_NONE, "spring_dashpot and hertz"},
        {"contacts.contact_time", r->contact_time, k->model == CONTACT_SPRING_DASHPOT, "spring_dashpot only"},
        {"contacts.young_modulus", r->young_modulus, k->model == CONTACT_HERTZ, "hertz only"},
        {"contacts.poisson_ratio", r->poisson_ratio, k->model == CONTACT_HERTZ, "hertz only"},
    };
    for (size_t i = 0; i < sizeof keys / sizeof keys[0]; i++) {
        if (keys[i].given != NULL && !keys[i].used) {
            scene_report_warn(c, keys[i].key, "= %s: ignored with contacts.model = %s (used by %s)",
                              fmt_num(*keys[i].given).s, model_name[k->model], keys[i].by);
        }
    }
}

static void build_rigid(ctx_t *c, const raw_rigid_t *r, scene_rigid_t *g)
{
    static const raw_rigid_t none = {0};
    if (r == NULL) {
        r = &none;
    }
    g->integrator = r->integrator ? *r->integrator : INTEGRATOR_VERLET;
    g->coupling = r->coupling ? *r->coupling : COUPLING_AUTO;
    g->cvode_method = r->cvode_method ? *r->cvode_method : CVODE_BDF;
    g->linear_solver = r->linear_solver ? *r->linear_solver : LINSOL_DENSE;
    g->rtol = opt(r->rtol, 1e-8);
    g->atol = opt(r->atol, 1e-12);
    double substeps = opt(r->substeps, 1.0);
    g->substeps = scene_check_int(c, "rigid.substeps", substeps, 1, INT_MAX) ? (int)substeps : 1;
    opt_vec(g->gravity, r->gravity, 0, 0, 0);
    g->release_time = opt(r->release_time, 0.0);
    scene_check_range(c, "rigid.release_time", g->release_time, 0, INFINITY, 0);
    /* CVODE takes a relative tolerance below 1 only (rigid_config.c, and the
     * rigid FMU's parameter): rtol 2 passed check and stopped the run at start */
    scene_check_range(c, "rigid.rtol", g->rtol, 0, 1, LO_OPEN | HI_OPEN);
    scene_check_range(c, "rigid.atol", g->atol, 0, INFINITY, LO_OPEN);
    scene_check_vec(c, "rigid.gravity", g->gravity, 3);
    if (g->integrator == INTEGRATOR_VERLET) {
        /* CVODE's settings, unread by Verlet (rigid/integrator_cvode.c) */
        const char *given[4] = {r->cvode_method ? "rigid.cvode_method" : NULL,
                                r->linear_solver ? "rigid.linear_solver" : NULL, r->rtol ? "rigid.rtol" : NULL,
                                r->atol ? "rigid.atol" : NULL};
        for (int i = 0; i < 4; i++) {
            if (given[i] != NULL) {
                scene_report_warn(c, given[i], "ignored with rigid.integrator = verlet (used by cvode only)");
            }
        }
    }
}

static void build_run(ctx_t *c, const raw_run_t *r, scene_run_t *u)
{
    u->end_time = r->end_time;
    u->output_interval = opt(r->output_interval, r->end_time / 100.0);
    u->fields = (r->fields && *r->fields) ? 1 : 0;
    u->field_interval = opt(r->field_interval, u->output_interval);
    if (scene_check_range(c, "run.end_time", u->end_time, 0, INFINITY, LO_OPEN) || r->output_interval != NULL) {
        scene_check_range(c, "run.output_interval", u->output_interval, 0, INFINITY, LO_OPEN);
    }
    if (r->field_interval != NULL) {
        scene_check_range(c, "run.field_interval", u->field_interval, 0, INFINITY, LO_OPEN);
        if (!u->fields) {
            scene_report_warn(c, "run.field_interval", "= %s s: ignored, as run.fields is false (no field snapshots)",
                              fmt_num(u->field_interval).s);
        }
    }
    for (int a = 0; a < 3; a++) {
        u->ranks[a] = 0;
        if (r->ranks != NULL) {
            static const char *const keys[3] = {"run.ranks.0", "run.ranks.1", "run.ranks.2"};
            u->ranks[a] = scene_check_int(c, keys[a], r->ranks[a], 1, 65536) ? (int)r->ranks[a] : 1;
        }
    }
}

/* Each check of scene_check.c runs once the values it relates are usable (a
 * broken domain or resolution would only add follow-up errors); speeds and
 * time scales only on a scene without errors so far. */
void scene_build(ctx_t *c, const raw_scene_t *r, scene_t *s)
{
    bool domain_ok = build_domain(c, &r->domain, &s->domain);
    if (!build_bodies(c, r, s)) {
        return;
    }
    bool dt_ok;
    bool dx_ok = build_fluid(c, &r->fluid, s, &dt_ok);
    if (dx_ok && domain_ok) {
        scene_check_divisible(c, s);
    }
    scene_check_spheres(c, s, domain_ok, dx_ok);
    scene_check_overlaps(c, s, domain_ok);
    scene_check_buried(c, s, domain_ok);
    if (domain_ok && c->nerrors == 0) {
        scene_unwrap_bodies(s);
    }
    if (c->nerrors == 0) {
        scene_check_masses(c, s);
    }
    if (domain_ok) {
        scene_check_initial_profile(c, s);
        if (c->nerrors == 0) {
            scene_start_with_flow(s);
        }
    }
    if (!build_connections(c, r, s)) {
        return;
    }
    build_contacts(c, r->contacts, s, dt_ok);
    build_rigid(c, r->rigid, &s->rigid);
    build_run(c, &r->run, &s->run);
    if (dt_ok) {
        scene_check_run_length(c, s);
    }
    if (dx_ok && c->nerrors == 0) {
        scene_check_lubrication(c, s);
    }
    if (dt_ok && c->nerrors == 0) {
        scene_check_speeds(c, s);
        scene_check_time_scales(c, s);
    }
    if (domain_ok && c->nerrors == 0) {
        scene_check_net_force(c, s);
    }
}
