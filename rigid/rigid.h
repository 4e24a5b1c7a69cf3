/* rigid.h — the rigid agglomerate component: bodies made of sintered spheres.
 *
 * One opaque handle and a few verbs. The exchange with the fluid is per sphere
 * (shared/DESIGN.md section 2): the caller sets the hydrodynamic force and the
 * torque about the sphere centre of every sphere, calls rigid_step(), and reads
 * back each sphere's centre, centre velocity and angular velocity, and each
 * connection's force, torque and intact flag. Bodies are an internal notion:
 * they split (break-up) and merge (sticking) and their ids change; spheres
 * never change. All quantities are SI. Errors are returned as status_t with a
 * message through the log_t given at creation (category "rigid").
 *
 * Physics: Iglberger, Thuerey, Ruede (2008), Stoermer-Verlet bodies and the
 * free-body-diagram connection force and torque (Eq. 8 and 9). The component
 * is documented in README.md (section "Rigid component"): integrators,
 * contact models, the cut rule for connections on cycles, break-up and
 * sticking, and the configuration fields with units and ranges. */
#ifndef RIGID_RIGID_H
#define RIGID_RIGID_H

#include <stddef.h>

#include "../common/status.h"

typedef struct rigid rigid_t;

typedef enum { RIGID_VERLET, RIGID_CVODE } rigid_integrator_t;
typedef enum { RIGID_ADAMS, RIGID_BDF } rigid_cvode_method_t;
typedef enum { RIGID_LS_DENSE, RIGID_LS_SPGMR } rigid_linsol_t;
typedef enum { RIGID_CONTACT_NONE, RIGID_CONTACT_SPRING_DASHPOT, RIGID_CONTACT_HERTZ } rigid_contact_model_t;
/* What the fluid sees at a wall face of the box: a solid no-slip wall (also
 * a moving one, with its velocity), a free-slip wall, or an open face (inlet,
 * outlet: bodies meet it as a wall for contacts, but there is no fluid film
 * to squeeze, so no lubrication). */
typedef enum { RIGID_WALL_NO_SLIP, RIGID_WALL_FREE_SLIP, RIGID_WALL_OPEN } rigid_wall_kind_t;

/* A sphere: centre at t0 (m), radius (m) > 0, index of its body in cfg->bodies. */
typedef struct {
    double center[3];
    double radius;
    int body;
} rigid_sphere_cfg_t;

/* A body: density (kg/m^3) > 0, initial velocity of its centre of mass (m/s)
 * and angular velocity (rad/s). fixed != 0: the body is not moved by forces
 * (infinite mass for contacts); it never moves, unless fixed ==
 * RIGID_PRESCRIBED: then it moves as the fluid moves a prescribed body, its
 * spheres' r^3-weighted centroid with `velocity` and the body turning about
 * that centroid with `angular_velocity`, both constant, so that contacts and
 * films meet it where the fluid has it. */
#define RIGID_PRESCRIBED 2
typedef struct {
    double density;
    double velocity[3];
    double angular_velocity[3];
    int fixed;
} rigid_body_cfg_t;

/* A connection between spheres a and b of one body, which must touch or
 * overlap. Limits: tensile normal force (N), shear force (N), torque (N m);
 * each >= 0; 0 or +INFINITY means that criterion never breaks. */
typedef struct {
    int a, b;
    double max_normal, max_shear, max_torque;
} rigid_connection_cfg_t;

typedef struct {
    int nspheres, nbodies, nconnections;
    const rigid_sphere_cfg_t *spheres;
    const rigid_body_cfg_t *bodies;
    const rigid_connection_cfg_t *connections;
    double gravity[3];      /* m/s^2 */
    double fluid_density;   /* kg/m^3 >= 0; buoyancy = -fluid_density * V * g per sphere share */
    rigid_contact_model_t contact_model;
    double restitution;     /* (0, 1], spring-dashpot and Hertz damping */
    double contact_time;    /* s > 0, spring-dashpot only */
    double friction;        /* Coulomb coefficient >= 0; 0 = off */
    double young_modulus;   /* Pa > 0, Hertz only */
    double poisson_ratio;   /* [0, 0.5), Hertz only */
    double stick_speed;     /* m/s >= 0: fuse when relative normal speed < this at contact; 0 = never */
    int walls[3][2];        /* walls[axis][side]=1: face box_lo/box_hi[axis] is a wall for the bodies */
    rigid_wall_kind_t wall_kind[3][2]; /* of each wall (0 = no-slip) */
    double wall_velocity[3][2][3];     /* m/s, of a moving no-slip wall (tangential); 0 otherwise */
    int periodic[3];        /* periodic[axis]=1: period box_hi - box_lo; sphere pairs meet at the nearest image */
    double box_lo[3], box_hi[3];
    /* Lubrication (lubrication.c): the normal force of the thin film between
     * two spheres or a sphere and a no-slip/free-slip wall, for surface gaps
     * below lub_cutoff, saturated at lub_min_gap. */
    double fluid_viscosity; /* kinematic, m^2/s >= 0; dynamic viscosity mu = fluid_density * fluid_viscosity */
    int lubrication;        /* 1: on */
    double lub_cutoff;      /* m > 0 */
    double lub_min_gap;     /* m, in (0, lub_cutoff) */
    rigid_integrator_t integrator;
    rigid_cvode_method_t cvode_method;
    rigid_linsol_t linsol;
    double rtol, atol;      /* CVODE; atol on the scaled state (see README) */
    int substeps;           /* >= 1 sub-steps per communication step, hydrodynamic load held */
    double t0;              /* s */
    /* Limits of connections created when bodies stick (same meaning as in
     * rigid_connection_cfg_t; all 0 = unbreakable). Optional, may stay 0. */
    double fuse_max_normal, fuse_max_shear, fuse_max_torque;
    /* 1: trapezoidal correction of the held hydrodynamic load at the next
     * step (second-order coupling for loads that do not respond to the
     * velocity within a step, e.g. a given drag law). Combined with a fluid
     * whose force reacts at once to the sphere velocity (moving-wall term)
     * it acts like Adams-Bashforth 2, whose smaller stability region lets the
     * coupled rotation of a sphere of a few cells blow up; 0 (the default and
     * what scenes use): the load of a step is held over that step only. */
    int load_correction;
    /* s, on the run's clock (not relative to t0): a step whose middle is
     * before it (0: none, also before t = 0) moves every free body with its current velocity and angular
     * velocity (kept constant) and applies no load to it (fluid, gravity,
     * contacts, lubrication); its connections carry nothing and cannot break,
     * nothing sticks (a pair of bodies in contact at the release is judged for
     * sticking then, as a new contact, by its normal speed then). The fluid meanwhile develops around the bodies, so that
     * a body put into a developed flow starts from the flow's steady load
     * instead of the impulsive start's (README "Release"). 0: no hold. */
    double release_time;
} rigid_config_t;

status_t rigid_create(const rigid_config_t *cfg, const log_t *log, rigid_t **out);

/* Lubrication correction (lubrication.c), a pure function: the normal force
 * (N) of the fluid film between two surfaces at gap (m) approaching at vn
 * (m/s; > 0 approach gives a repulsive force > 0, separation an attractive
 * one < 0): the film of the region where the surfaces are closer than the
 * cut-off,
 *     F = 6 pi mu vn [reff^2 (1/h - 1/cutoff) + rlog ln(cutoff/h)],
 * h = max(gap, min_gap), for gap < cutoff and 0 otherwise. mu: dynamic
 * viscosity (Pa s); reff and rlog (m) from rigid_film_of_spheres and
 * rigid_film_of_wall. */
double rigid_lubrication_normal(double mu, double reff, double rlog, double gap, double vn, double cutoff,
                                double min_gap);
/* The film's lengths for two spheres of radii ri, rj (Jeffrey & Onishi 1984):
 * reff = ri rj / (ri + rj), rlog = ri b (1 + 7b + b^2) / (5 (1 + b)^3),
 * b = rj / ri; for a sphere against a no-slip wall (free_slip 0: Brenner
 * 1961, reff = r, rlog = r/5) or a free-slip one (1: the mirror pair,
 * reff = r/2, rlog = 9r/20). */
void rigid_film_of_spheres(double ri, double rj, double *reff, double *rlog);
void rigid_film_of_wall(double r, int free_slip, double *reff, double *rlog);

/* The configuration of a scene (rigid_scene.c): every body of the scene,
 * fixed and prescribed ones as fixed bodies; sphere i = the scene's global
 * sphere index, its body the scene body index; walls from the domain faces.
 * Free the arrays with rigid_scene_config_free (also after a failure). */
struct scene; /* scene_t, common/scene.h */
status_t rigid_config_from_scene(const struct scene *s, double t0, const log_t *log, rigid_config_t *cfg);
void rigid_scene_config_free(rigid_config_t *cfg);
void rigid_free(rigid_t *r);

/* Hydrodynamic force (N) and torque about the sphere centre (N m) of one
 * sphere, held over the next rigid_step (see README: trapezoidal correction). */
void rigid_set_sphere_load(rigid_t *r, int sphere, const double force[3], const double torque[3]);

/* Implicit coupling (optional): the load's instantaneous response to the
 * sphere's motion, zt = -dF/dv (kg/s) and zr = -dT/dw (kg m^2/s), both >= 0
 * (0: explicit, the default). rigid_step then predicts each body's change of
 * velocity and angular velocity over the step from the linearised load
 * F_i - zt (dV + dW x d_i), T_i - zr dW with the other forces at the start
 * (one 6x6 solve per body) and holds the load corrected by that change: a
 * light particle no longer overshoots (README "Implicit coupling"). */
void rigid_set_sphere_drag(rigid_t *r, int sphere, double zt, double zr);

/* Advances one communication step of length h > 0 in cfg->substeps sub-steps. */
status_t rigid_step(rigid_t *r, double h);
double rigid_time(const rigid_t *r);

void rigid_get_sphere(const rigid_t *r, int sphere, double pos[3], double vel[3], double omega[3]);
/* The hydrodynamic load that acted on the sphere over the last rigid_step:
 * the load set by rigid_set_sphere_load plus, under the implicit coupling,
 * its drag response to the step's predicted velocity change (what the
 * momentum balance of the step sees; without drag coefficients: the load;
 * zero for a step before rigid_config_t.release_time, which applies none). */
void rigid_get_sphere_applied_load(const rigid_t *r, int sphere, double force[3], double torque[3]);
int rigid_sphere_body(const rigid_t *r, int sphere);
int rigid_nbodies(const rigid_t *r);
int rigid_nfree_bodies(const rigid_t *r); /* bodies that move (not fixed) */
int rigid_nspheres(const rigid_t *r);

/* Connections: the first cfg->nconnections keep their cfg index; connections
 * created by sticking follow them (a pair that sticks again takes back its
 * broken connection, a new pair the slot of a broken one whose spheres have
 * parted, else one is appended). force is the force on the section that
 * contains sphere a exerted by the rest (Eq. 8), torque the torque on that
 * section about the connection point (Eq. 9). */
int rigid_nconnections(const rigid_t *r);
void rigid_get_connection(const rigid_t *r, int k, double force[3], double torque[3], int *intact);
void rigid_get_connection_pair(const rigid_t *r, int k, int *a, int *b);

/* Body state: centre of mass, orientation (unit quaternion w,x,y,z rotating
 * body principal axes to world), velocity, angular velocity, mass and the
 * world inertia tensor about the centre of mass (row-major 3x3). Any output
 * pointer may be NULL. */
void rigid_get_body(const rigid_t *r, int body, double com[3], double q[4], double v[3], double omega[3],
                    double *mass, double inertia_world[9]);

/* Diagnostics over all movable bodies: linear momentum, angular momentum
 * about the world origin, kinetic energy. */
void rigid_momentum(const rigid_t *r, double p[3], double l[3]);
double rigid_kinetic_energy(const rigid_t *r);
/* Evaluations of all forces since rigid_create: Verlet makes one per sub-step,
 * CVODE one per right-hand-side call (and the Jacobian's finite differences). */
long rigid_force_evaluations(const rigid_t *r);

size_t rigid_state_size(const rigid_t *r);
status_t rigid_state_save(const rigid_t *r, void *buf, size_t size);
status_t rigid_state_restore(rigid_t *r, const void *buf, size_t size);

#endif
