/* scene.h — the scene as a plain struct (DESIGN section 4).
 *
 * A scene file is YAML in SI units. It is parsed once, schema-checked by
 * libcyaml, validated (ranges, consistency) and then handed to the components
 * as this struct: physics never sees text. Optional groups are flagged by
 * has_* members. Lattice units are derived elsewhere (common/units.h), in one
 * place. Every string the scene owns is freed by scene_free. */
#ifndef COMMON_SCENE_H
#define COMMON_SCENE_H

#include "status.h"

#include <stddef.h>

typedef enum {
    FACE_PERIODIC,
    FACE_NO_SLIP,
    FACE_FREE_SLIP,
    FACE_MOVING_WALL,
    FACE_VELOCITY_INLET,
    FACE_PRESSURE_OUTLET,
} face_type_t;

typedef enum { PROFILE_UNIFORM, PROFILE_PARABOLIC } inlet_profile_t;

/* Face order everywhere: x_min, x_max, y_min, y_max, z_min, z_max (= 2*axis + side). */
typedef struct {
    face_type_t type;
    double velocity[3];      /* moving_wall: wall velocity; velocity_inlet: mean (uniform) or peak (parabolic) velocity, m/s */
    inlet_profile_t profile; /* velocity_inlet only */
    double pressure;         /* pressure_outlet: pressure relative to the reference pressure, Pa */
} face_t;

/* regularized: BGK on the regularized non-equilibrium part (Latt & Chopard
 * 2006), with fluid.streaming moments only (fluid/kernel_moments.c) */
typedef enum { COLLISION_BGK, COLLISION_TRT, COLLISION_REGULARIZED } collision_t;
typedef enum {
    BOUNDARY_BOUNCE_BACK,
    BOUNDARY_YU,
    BOUNDARY_CLI,
    BOUNDARY_QUADRATIC,
    BOUNDARY_MULTIREFLECTION
} boundary_scheme_t;
typedef enum { REFILL_EQUILIBRIUM, REFILL_EXTRAPOLATION } refill_t;
typedef enum { FORCE_MOMENTUM_EXCHANGE, FORCE_GALILEAN } force_method_t;
/* Population layout (fluid/layout.h): one array updated in place (the AA
 * pattern), two arrays, pull from one and write the other, or the 10
 * moments of each fluid cell (fluid/moments.h). */
typedef enum { STREAMING_IN_PLACE, STREAMING_TWO_ARRAY, STREAMING_MOMENTS } streaming_t;
/* Storage of the populations: double, or float holding f - w_q. */
typedef enum { PRECISION_DOUBLE, PRECISION_SINGLE } precision_t;

typedef struct {
    double size[3]; /* m */
    face_t faces[6];
} scene_domain_t;

/* Initial fluid velocity: uniform (fluid.initial_velocity everywhere) or the
 * steady laminar plane-channel profile between the two walls of the one
 * wall-bounded axis (Couette + body-force Poiseuille), plus initial_velocity
 * (the profile itself: fluid/initial_profile.c). */
typedef enum { INITIAL_UNIFORM, INITIAL_PLANE_CHANNEL } initial_profile_t;

typedef struct {
    double density;             /* kg/m^3 */
    double viscosity;           /* kinematic, m^2/s */
    double dx;                  /* m; derived from cells_per_radius when that is given */
    double cells_per_radius;    /* 0 when dx is given */
    double tau;                 /* relaxation time used; derived from dt when that is given */
    double dt;                  /* s; derived from tau when tau is given (a whole number of ns, below) */
    double tau_requested;       /* fluid.tau as the scene gives it; 0 when the scene gives fluid.dt */
    collision_t collision;
    double magic;               /* TRT magic parameter Lambda */
    double body_force[3];       /* force per volume, N/m^3 */
    double initial_velocity[3]; /* m/s */
    initial_profile_t initial_profile;
    int channel_axis;           /* INITIAL_PLANE_CHANNEL: the wall-normal axis; -1 otherwise */
    boundary_scheme_t boundary_scheme;
    refill_t refill;
    force_method_t force_method;
    streaming_t streaming;
    precision_t precision;
    int force_averaging;        /* average force over two steps: 1, 0, or -1 = not given (per body, common/coupling.h) */
    double mach_limit;          /* a fluid cell faster than this Mach number stops the run (fluid_check) */
} scene_fluid_t;

typedef enum { MOTION_FREE, MOTION_FIXED, MOTION_PRESCRIBED } motion_t;

typedef struct {
    double center[3]; /* m */
    double radius;    /* m */
} scene_sphere_t;

typedef struct {
    char *name;
    int nspheres;
    scene_sphere_t *spheres;
    double density;             /* kg/m^3 */
    double velocity[3];         /* initial (free) or prescribed (prescribed), m/s */
    double angular_velocity[3]; /* rad/s, same meaning */
    motion_t motion;
    int move_with_flow;         /* velocity and angular_velocity taken from the initial flow (scene_build.c) */
} scene_body_t;

typedef struct {
    int a, b;                                   /* global sphere indices (bodies in order, spheres in order) */
    double max_normal, max_shear, max_torque;   /* N, N, N m; infinity when not given */
} scene_connection_t;

typedef enum { CONTACT_NONE, CONTACT_SPRING_DASHPOT, CONTACT_HERTZ } contact_model_t;

/* Lubrication correction for close approaches (rigid/lubrication.c). */
typedef struct {
    int enabled;    /* default: on where contacts are on (model != none) */
    double cutoff;  /* surface gap below which it acts, in cells of fluid.dx */
    double min_gap; /* m, where it saturates; 1e-3 of the smallest sphere radius by default (0 without spheres) */
} scene_lubrication_t;

typedef struct {
    contact_model_t model;
    scene_lubrication_t lubrication;
    double restitution;   /* (0, 1] */
    double contact_time;  /* s; 10 fluid steps by default */
    double friction;      /* Coulomb coefficient, 0 = off */
    double young_modulus; /* Pa, Hertz */
    double poisson_ratio; /* Hertz */
    double stick_speed;   /* m/s, 0 = never stick */
} scene_contacts_t;

typedef enum { INTEGRATOR_VERLET, INTEGRATOR_CVODE } integrator_t;
typedef enum { CVODE_ADAMS, CVODE_BDF } cvode_method_t;
typedef enum { LINSOL_DENSE, LINSOL_SPGMR } linsol_t;

/* Hydrodynamic coupling: explicit (the load of the last fluid step held over
 * the rigid step), implicit (the fluid also publishes each sphere's drag
 * coefficients, the load's instantaneous response to the sphere velocity,
 * and the rigid step treats that part implicitly; README "Implicit coupling")
 * or auto (the default: chosen per body, common/coupling.h). */
typedef enum { COUPLING_EXPLICIT, COUPLING_IMPLICIT, COUPLING_AUTO } coupling_t;

typedef struct {
    integrator_t integrator;
    coupling_t coupling;
    cvode_method_t cvode_method;
    linsol_t linear_solver;
    double rtol, atol;
    int substeps;
    double gravity[3]; /* m/s^2 */
    double release_time; /* s: free bodies keep their initial motion and take no load until then (0: none) */
} scene_rigid_t;

typedef struct {
    double end_time;        /* s */
    double output_interval; /* s */
    int fields;             /* write field snapshots */
    double field_interval;  /* s; output_interval when not given */
    int ranks[3];           /* MPI ranks along x, y, z (fluid/decomp.c); 0: chosen by MPI_Dims_create */
} scene_run_t;

typedef struct scene {
    char *path;  /* file the scene came from */
    char *text;  /* the scene text after --set overrides (stored in the output) */
    scene_domain_t domain;
    scene_fluid_t fluid;
    int nbodies;
    scene_body_t *bodies;
    int nconnections;
    scene_connection_t *connections;
    scene_contacts_t contacts;
    scene_rigid_t rigid;
    scene_run_t run;
} scene_t;

/* Loads, schema-checks, applies the "dotted.key=value" overrides in order,
 * and validates. On failure every message names the file, the key, the value
 * and the allowed range; *out is NULL and nothing else is touched. */
status_t scene_load(const char *path, const char *const *overrides, int noverrides, const log_t *log,
                    scene_t **out);
void scene_free(scene_t *s);
int scene_total_spheres(const scene_t *s);
/* Bodies with motion free: the ones a rigid component moves (none: no rigid FMU). */
int scene_free_bodies(const scene_t *s);
const char *face_type_name(face_type_t t);
/* A body's pivot (m): the centroid of its sphere centres weighted by r^3,
 * about which the fluid turns a prescribed body and at which a body that
 * moves with the flow takes the flow's motion. */
void scene_body_pivot(const scene_body_t *b, double c[3]);

/* Time steps in whole nanoseconds, for masters that count time in integer ns
 * (libcosim / OSP). When the scene gives fluid.tau, scene_load rounds
 * dt = (tau - 1/2) dx^2 / (3 nu) to a whole number of ns and sets
 * tau = 1/2 + 3 nu dt / dx^2 (nu exact, tau moved by ~1e-5), unless that
 * moves tau - 1/2 by more than SCENE_DT_ROUND_MAX (dt below ~50 ns): then dt
 * is kept exact and `coupler check` warns. A given fluid.dt is used as given
 * (check warns when it is not whole ns). README "FMUs", models/README.md. */
#define SCENE_DT_ROUND_MAX 1e-2
/* Default of fluid.mach_limit: Mach 0.3 = |u| 0.173 lattice units, where the
 * compressibility error of the lattice (O(Ma^2)) reaches ~10% and BGK/TRT
 * start to lose stability; well above the Mach ~0.1 a scene aims for. */
#define SCENE_MACH_LIMIT_DEFAULT 0.3
/* The most fluid steps a run may take, ceil(run.end_time / fluid.dt): 2^53.
 * Step counters are `long` (64 bits) and times are counted as step x dt in
 * double, which holds every whole number up to 2^53 exactly; scene_load
 * refuses a run.end_time beyond it. */
#define SCENE_STEPS_MAX 9007199254740992LL
/* Whether t (s) is a whole number of nanoseconds within 1e-9 relative (the
 * FMUs' tolerance on communication points); *ns the nearest count (may be NULL). */
int scene_whole_ns(double t, long long *ns);

/* The next of a schedule of events at whole multiples of interval (rows,
 * snapshots, checkpoints): the smallest k' >= k with k' interval > x, found
 * from a division and not by counting (an interval of 1e-30 s counted up
 * to t for ever). interval > 0; LONG_MAX when k' would not fit. */
long scene_next_multiple(long k, double interval, double x);

#endif
