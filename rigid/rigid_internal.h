/* rigid_internal.h — the data layout of the rigid component, shared by its files.
 *
 * Layout. Spheres never change; each carries its fixed "mass share" (the part
 * of its body's union that belongs to it, see body.c) expressed in the frame
 * of the body it currently belongs to. Bodies are an array rebuilt on
 * break-up and sticking (topology.c). A body's frame is its principal-axes
 * frame with origin at its centre of mass, so its inertia is diag(inertia).
 * Connections are an array: the scene's, then those of sticking, which
 * grows only when no broken sticking connection can be reused (topology.c).
 *
 * Invariants: for every body b, mass = sum of its spheres' share masses and
 * the shares' first moments sum to zero in the body frame; q is a unit
 * quaternion; L is the angular momentum about the centre of mass in the world
 * frame (the state variable of both integrators, so that free rotation keeps
 * it exactly); every connection joins two spheres of one body while intact.
 * Everything that a continuation depends on lives in these arrays, so that
 * state.c can serialise it (DESIGN.md section 8). */
#ifndef RIGID_INTERNAL_H
#define RIGID_INTERNAL_H

#include "rigid.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>

#define RIGID_CAT "rigid"

typedef struct {
    double radius;
    int body;
    int orig_body;    /* body index in the scene: implicit bonds join touching spheres of one scene body */
    double density;   /* of its original body's material */
    double c0[3];     /* centre in the scene, at t0: implicit bonds are the pairs of one scene body touching
                       * there (rigid_bonded) */
    double p[3];      /* centre, body frame relative to the body's centre of mass */
    double mass;      /* share mass (kg) */
    double volume;    /* share volume (m^3) */
    double s[3];      /* share centroid, body frame relative to the body's centre of mass */
    double j[9];      /* share inertia about its own centroid, body frame */
    double load_f[3], load_t[3]; /* hydrodynamic load set for the next step */
    double held_f[3], held_t[3]; /* load used in the previous step */
    double drag_t, drag_r;       /* implicit coupling: -dF/dv (kg/s), -dT/dw (kg m^2/s) of the load */
    double imp_f[3], imp_t[3];   /* implicit coupling: load correction of the current step */
    double debt_f[3], debt_t[3]; /* implicit coupling: the corrections not yet paid back (implicit.c) */
} rigid_sphere_t;

typedef struct {
    double com[3];
    double q[4];       /* w, x, y, z: body -> world */
    double v[3];
    double l[3];       /* angular momentum about com, world frame */
    double mass;
    double inertia[3]; /* principal moments */
    int fixed;
    int kinematic;     /* a fixed body with prescribed motion (rigid_kinematic_advance) */
    double kv[3], kw[3], kp[3]; /* its pivot's velocity, its angular velocity, its pivot (world) */
} rigid_body_t;

typedef struct {
    int a, b;
    double max_normal, max_shear, max_torque;
    int intact;
    double force[3], torque[3];
    /* a broken sintered neck whose spheres still overlap: the centre distance
     * that counts as contact-free (the distance at the break, growing as the
     * spheres move apart), 0 once they no longer overlap or while intact */
    double gap0;
} rigid_conn_t;

struct rigid_integrator_ops;

/* A fault found by a force evaluation (contact.c): the first one is kept. */
typedef enum { RIGID_FAULT_NONE, RIGID_FAULT_NO_MODEL, RIGID_FAULT_DEEP } rigid_fault_kind_t;
typedef struct {
    rigid_fault_kind_t kind; /* NO_MODEL: a wall reached without a contact model; DEEP: overlap beyond a radius */
    int sphere_i, sphere_j;  /* j < 0: the wall face -1 - j (2*axis + side) */
    double gap;              /* surface gap, m (< 0: overlap) */
} rigid_fault_t;

/* A pair the contact watch follows (contact_watch.c). */
typedef enum { WATCH_NEW, WATCH_NEAR, WATCH_TOUCHING, WATCH_UNKNOWN } rigid_watch_phase_t;
typedef struct {
    int i, j;      /* sphere i and its partner: sphere j > i of another body, or the wall j = -1 - face */
    int phase;     /* rigid_watch_phase_t: UNKNOWN = in contact since before the watch saw it */
    int seen;      /* met in the current pass */
    double v_in;   /* normal approach speed at the last sample before the touch, m/s */
    double t_in;   /* time of that sample */
    double allow;  /* speed the other forces may have added since, m/s */
    double rate;   /* their bound per second at the last sample, m/s^2 */
    double omega0; /* largest contact frequency met, 1/s */
} rigid_watch_t;

struct rigid {
    rigid_config_t cfg; /* copy; the array pointers of cfg are NOT kept (set to NULL) */
    log_t log;
    double t;
    int have_prev;      /* a previous step exists: apply the trapezoidal load correction */
    double h_prev;      /* length of the previous communication step */
    double h_sub_current; /* sub-step in progress (diagnostics only) */
    int nspheres, nbodies, nconn, conn_cap;
    rigid_sphere_t *spheres;
    rigid_body_t *bodies; /* capacity nspheres: there are never more bodies than spheres */
    rigid_conn_t *conn;
    /* derived, rebuilt after any topology change: sections of the free-body diagram */
    unsigned char *section; /* conn_cap * nspheres: 1 if sphere is in the section of sphere a */
    unsigned char *touch;   /* nspheres^2: pair touched at the end of the previous step (sticking is
                               decided at the first step of a contact); part of the state */
    /* scratch for force evaluation */
    double *sf, *st;        /* per sphere external force and torque about its centre */
    double *bf, *bt;        /* per body force and torque about com */
    double (*sx)[3], (*sv)[3]; /* per sphere centre and velocity (last force evaluation) */
    double *lub_rate;       /* per body: sum of its lubrication damping rates (lubrication.c) */
    rigid_fault_t fault;    /* of the last force evaluation */
    long nforces;           /* force evaluations so far (diagnostics; not part of the state) */
    rigid_body_t *scratch_bodies;
    /* the pair visit's body bounds (pairs.c): per body a centre, the extent of
     * its centres about it, its largest radius and the centre's norm; per
     * body pair 1 when none of their sphere pairs can come within reach */
    double (*pair_bound)[6];
    unsigned char *pair_far; /* nspheres^2 */
    /* the contact watch (contact_watch.c): not part of the saved state */
    rigid_watch_t *watch;
    int nwatch, watch_cap;
    double watch_t;         /* time of its last sample (NaN: none yet) */
    double *watch_kick;     /* per body: |dv|, |dw| of velocity jumps outside the integrator since then */
    unsigned char *open_noted; /* per sphere: its body's arrival at an inlet or outlet face was logged (not saved) */
    const struct rigid_integrator_ops *ops;
    void *integ;            /* integrator private data */
};

/* ---- small vector / quaternion helpers ---- */
static inline double rv_dot(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static inline void rv_cross(const double a[3], const double b[3], double c[3])
{
    double x = a[1] * b[2] - a[2] * b[1];
    double y = a[2] * b[0] - a[0] * b[2];
    double z = a[0] * b[1] - a[1] * b[0];
    c[0] = x;
    c[1] = y;
    c[2] = z;
}
static inline double rv_norm(const double a[3]) { return sqrt(rv_dot(a, a)); }
static inline void rv_sub(const double a[3], const double b[3], double c[3])
{
    c[0] = a[0] - b[0];
    c[1] = a[1] - b[1];
    c[2] = a[2] - b[2];
}
/* row-major 3x3 matrix times vector */
static inline void rm_mul(const double m[9], const double a[3], double c[3])
{
    double x = m[0] * a[0] + m[1] * a[1] + m[2] * a[2];
    double y = m[3] * a[0] + m[4] * a[1] + m[5] * a[2];
    double z = m[6] * a[0] + m[7] * a[1] + m[8] * a[2];
    c[0] = x;
    c[1] = y;
    c[2] = z;
}
static inline void rm_tmul(const double m[9], const double a[3], double c[3])
{
    double x = m[0] * a[0] + m[3] * a[1] + m[6] * a[2];
    double y = m[1] * a[0] + m[4] * a[1] + m[7] * a[2];
    double z = m[2] * a[0] + m[5] * a[1] + m[8] * a[2];
    c[0] = x;
    c[1] = y;
    c[2] = z;
}
/* rotation matrix of a quaternion, normalised on the fly (CVODE lets |q| drift) */
static inline void rq_matrix(const double q[4], double m[9])
{
    double n2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
    double s = 2.0 / n2;
    double w = q[0], x = q[1], y = q[2], z = q[3];
    m[0] = 1 - s * (y * y + z * z);
    m[1] = s * (x * y - w * z);
    m[2] = s * (x * z + w * y);
    m[3] = s * (x * y + w * z);
    m[4] = 1 - s * (x * x + z * z);
    m[5] = s * (y * z - w * x);
    m[6] = s * (x * z - w * y);
    m[7] = s * (y * z + w * x);
    m[8] = 1 - s * (x * x + y * y);
}
/* c = a (x) b */
static inline void rq_mul(const double a[4], const double b[4], double c[4])
{
    double w = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
    double x = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
    double y = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
    double z = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
    c[0] = w;
    c[1] = x;
    c[2] = y;
    c[3] = z;
}

/* ---- rigid_config.c: validation of the configuration ---- */
/* Counts, ranges, connections and settings of c; the first violation is
 * logged and returned (STATUS_ERROR). */
status_t rigid_config_validate(const rigid_config_t *c, const log_t *log);
/* Every body is one piece: its spheres joined by touching/overlap. comp and
 * stack are scratch of c->nspheres ints each. */
status_t rigid_config_check_connected(const rigid_config_t *c, const log_t *log, int *comp, int *stack);

/* ---- implicit.c: implicit coupling ---- */
/* Before the integration of a step of length h: each sphere's load
 * correction imp_f, imp_t from its drag coefficients (zero without them). */
status_t rigid_implicit_load(rigid_t *r, double h);

/* ---- body.c: mass properties of the sphere shares ---- */
/* Mass properties of the share of sphere i of a union (spheres given by
 * centres c and radii rad, n of them, all of one body): volume, centroid
 * (absolute) and second moment about the centroid per unit density. */
status_t rigid_share_props(const log_t *log, int n, const double (*c)[3], const double *rad, const int *ids, int i,
                           double *vol, double cen[3], double j[9]);
/* Builds one body from a set of spheres given with world-frame share data;
 * sets com, q (principal axes), mass, inertia, and each sphere's body-frame
 * data. world_s/world_j/world_p are per member sphere. */
void rigid_body_build(rigid_t *r, int body, const int *members, int nm, double (*world_p)[3], double (*world_s)[3],
                      double (*world_j)[9]);
void rigid_body_rotation(const rigid_body_t *b, double m[9]);
void rigid_body_omega(const rigid_body_t *b, double w[3]);
void rigid_body_inertia_world(const rigid_body_t *b, double iw[9]);
void rigid_sym_eigen(const double a[9], double eval[3], double evec[9]);

/* ---- forces.c: all external forces on spheres and bodies ---- */
typedef struct {
    int sphere_i, sphere_j; /* j < 0: wall face -1 - j (2*axis + side) */
    double omega0;          /* sqrt(k/m) of the contact, m its point's mass along n (rotation included),
                               for the Verlet stability check */
} rigid_contact_info_t;
/* Evaluates sphere forces (r->sf, r->st) and body forces (r->bf, r->bt) for
 * the body states in bodies (which may be a scratch copy). h_kick > 0: the
 * lubrication damping is integrated exactly over a kick of that length
 * (Verlet), 0: the plain force (CVODE). Returns 0, or >0 for a fault
 * (r->fault: overlap beyond a radius, a wall reached without a contact
 * model), <0 for NaN. If worst is not NULL it receives the contact with the
 * largest omega0. */
int rigid_forces(rigid_t *r, const rigid_body_t *bodies, double h_kick, rigid_contact_info_t *worst);
/* The h_kick of the integrator for a communication step of length h. */
double rigid_lub_kick(const rigid_t *r, double h);
void rigid_sphere_world(const rigid_t *r, const rigid_body_t *bodies, int i, double x[3], double v[3], double w[3]);
/* Velocity of the material of body b at arm a from its centre of mass (zero for a fixed body,
 * the prescribed motion's for a kinematic one). */
void rigid_body_point_velocity(const rigid_body_t *b, const double a[3], double v[3]);
/* dv (b - a) to the nearest periodic image of b along each periodic axis;
 * shift (may be NULL): what was added to dv, a whole number of periods
 * (pairs.c). */
void rigid_nearest_image(const rigid_config_t *cfg, double dv[3], double shift[3]);
/* 1/m of body b for a force along the unit n applied at arm a from its centre
 * of mass, rotation included: 1/M + (a x n).I^-1 (a x n); 0 for a fixed body. */
double rigid_body_compliance(const rigid_body_t *b, const double a[3], const double n[3]);
/* Moves the kinematic (prescribed) bodies on by h: the pivot with kv, the body turned
 * exactly by kw h about it. */
void rigid_kinematic_advance(rigid_t *r, double h);
/* Moves one kinematic body on by h (the integrators move them with the free bodies'
 * time: a Verlet drift, each CVODE evaluation at its own t). */
void rigid_kinematic_move(rigid_body_t *b, double h);
/* Turns body b exactly by the world angular velocity w over h (its attitude
 * q premultiplied by the rotation of |w| h about w); m: that rotation's
 * matrix. Returns 0 and does nothing when w is zero. */
int rigid_body_turn(rigid_body_t *b, const double w[3], double h, double m[9]);
/* contact.c: adds contact forces to r->sf/st; x: sphere centres */
int rigid_contacts(rigid_t *r, const rigid_body_t *bodies, const double (*x)[3], rigid_contact_info_t *worst);
/* The error message of a fault found at time t (names body, sphere, partner or face, gap). */
status_t rigid_fault_report(const rigid_t *r, const rigid_fault_t *f, double t);
/* lubrication.c: adds the lubrication forces to r->sf/st (see rigid_forces
 * for h_kick; r->bf/bt must hold the body loads without them). Returns 1 if
 * any film acts (the body loads are then to be summed again). */
int rigid_lubrication(rigid_t *r, const rigid_body_t *bodies, const double (*x)[3], double h_kick);

/* ---- pairs.c: the close pairs of contacts and lubrication ---- */
typedef struct {
    int i, j;       /* sphere i and its partner: sphere j >= 0 of another body, or the wall j = -1 - face */
    int face;       /* wall: 2*axis + side (x_min, x_max, ..., z_max); -1 for two spheres */
    double n[3];    /* unit normal from i towards the partner (0 for coincident centres) */
    double gap;     /* surface gap, m, < 0 in overlap; spheres: centre distance - rigid_contact_reference */
    double pc[3];   /* contact point: midway between the surfaces (spheres), on the face (wall) */
    double xj[3];   /* centre of the image of j nearest to i (spheres) */
    double ai[3], aj[3]; /* pc - centre of mass of i's body, of j's body (its image) */
    double vrel[3]; /* velocity of i's material at pc relative to the partner's (a moving wall's) */
} rigid_pair_t;
typedef int (*rigid_pair_fn)(rigid_t *r, const rigid_body_t *bodies, const rigid_pair_t *p, void *ctx);
/* Calls fn for every pair with gap <= reach: spheres of different bodies,
 * not both fixed, at the nearest periodic image; spheres of free bodies
 * against every wall face. Returns the OR of fn's results. */
int rigid_pairs_visit(rigid_t *r, const rigid_body_t *bodies, const double (*x)[3], double reach, rigid_pair_fn fn,
                      void *ctx);
const char *rigid_face_name(int face); /* "x_min" ... "z_max" */

/* ---- contact.c helpers and contact_watch.c (after the pair type) ---- */
/* The masses and radius R* of a pair: mn the contact point's mass along n,
 * rotation included (1/mn = sum of rigid_body_compliance over the partners;
 * what the normal law is built on), meff the translational reduced mass (a
 * fixed body or a wall: infinite mass; friction's scale). */
void rigid_contact_pair_mass(const rigid_t *r, const rigid_body_t *bodies, const rigid_pair_t *p, double *mn,
                             double *meff, double *rstar);
/* The normal force (repulsive > 0) at overlap delta and approach speed ddelta
 * of a contact whose point has the mass mn along n, and omega0. */
double rigid_contact_normal_force(const rigid_config_t *cfg, double delta, double ddelta, double mn, double rstar,
                                  double *omega0);
/* The elastic energy stored at overlap delta (the spring part of the law). */
double rigid_contact_elastic_energy(const rigid_config_t *cfg, double delta, double mn, double rstar);
/* contact_watch.c: after an accepted step to time t of the bodies (r->sx,
 * r->bf, r->bt from rigid_forces on them): STATUS_ERROR when a contact has
 * gained energy (the message names time, bodies, ratio, contact time, step
 * and remedies). */
status_t rigid_contact_watch(rigid_t *r, const rigid_body_t *bodies, double t);
void rigid_contact_watch_reset(rigid_t *r);
void rigid_contact_watch_free(rigid_t *r);
/* A velocity jump of body b outside the integrator (the held-load correction). */
void rigid_contact_watch_kick(rigid_t *r, int body, double dv, double dw);
/* Bodies A and B fused into A (topology.c), the last body moved into slot B:
 * their jumps so far go with them, and the fusion's own jump (dv, dw: the
 * larger of the two parts') is added to A's. */
void rigid_contact_watch_fuse(rigid_t *r, int A, int B, int last, double dv, double dw);

/* ---- integrators ---- */
typedef struct rigid_integrator_ops {
    const char *name;
    status_t (*create)(rigid_t *r, void **data);
    void (*free)(void *data);
    /* integrate the bodies over [t, t+h] in cfg.substeps sub-steps with the held load */
    status_t (*advance)(rigid_t *r, void *data, double h);
} rigid_integrator_ops_t;
extern const rigid_integrator_ops_t rigid_verlet_ops;
extern const rigid_integrator_ops_t rigid_cvode_ops;

/* ---- connection.c ---- */
#define RIGID_TOUCH_TOL 1e-9 /* relative: spheres touch when d <= (r_a + r_b)(1 + tol) */
int rigid_bonded(const rigid_t *r, int i, int j); /* implicit bond between i and j (same scene body and body, touching at t0) */
status_t rigid_sections_update(rigid_t *r);
void rigid_connections_eval(rigid_t *r);
/* connection point (centre of the contact circle) and unit normal from a to b */
void rigid_connection_point(const rigid_t *r, int a, int b, const double xa[3], const double xb[3], double pc[3],
                            double n[3]);

/* ---- topology.c: break-up and sticking ---- */
status_t rigid_breakup(rigid_t *r, int *changed);
status_t rigid_stick(rigid_t *r, int *changed);
/* At the release (rigid_config_t.release_time, before the first step that is
 * not held): nothing stuck while the bodies were held, so every pair of
 * different bodies in contact now is judged as a new contact, by its normal
 * speed now, the held motion's, i.e. the speed the pair met with (the contact
 * did not slow it); broken necks excepted. The touch flags are then those of
 * now, so a pair is judged once. */
status_t rigid_stick_at_release(rigid_t *r, int *changed);
status_t rigid_regroup(rigid_t *r, int body);
void rigid_touch_update(rigid_t *r); /* records which pairs touch now; follows broken necks */
/* The touch flags at t0: the spheres of one body that touch (its sintered
 * necks) touched before, so a neck that breaks in the first step is no new
 * contact that sticks again at once; spheres of different bodies touching
 * at t0 are new contacts (they may stick at the first step). */
void rigid_touch_init(rigid_t *r);
/* Reference distance of contact between spheres i and j: gap0 of a broken neck
 * joining them, else r_i + r_j. */
double rigid_contact_reference(const rigid_t *r, int i, int j);

/* ---- state.c: the head of a saved state (tests corrupt its fields one at a time) ---- */
typedef struct {
    uint32_t magic, version;
    int32_t nspheres, nbodies, nconn, integrator;
    int32_t have_prev, pad;
    double t, h_prev;
} rigid_state_header_t;

#endif
