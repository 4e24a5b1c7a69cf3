/* rigid_scene.c — the scene -> rigid_config_t translation (rigid.h).
 *
 * One place maps the scene struct (common/scene.h) to the rigid component's
 * configuration, so that the FMU (rigid_fmi.c) and any other user build the
 * same bodies. Every body of the scene enters: free bodies move, fixed and
 * prescribed bodies enter as fixed bodies (obstacles for contacts, infinite
 * mass), a prescribed one moving with its prescribed motion as the fluid moves
 * it (before, it stayed where it started: a free sphere met its film there,
 * and passed through the body itself). Sphere i is the scene's global sphere index
 * (bodies in order, their spheres in order), its body the scene body index.
 * Every non-periodic face is a wall for contacts (with its kind and, for a
 * moving wall, its velocity); periodic axes pair spheres at the nearest
 * image; the lubrication cut-off is converted from cells to metres.
 * The arrays are owned by the caller through rigid_scene_config_free. */
#include "rigid.h"

#include "../common/scene.h"

#include <stdlib.h>

/* Every face that is not periodic is a wall for the bodies (a body must never
 * leave the domain); what the fluid sees there decides the lubrication. */
static rigid_wall_kind_t wall_kind(face_type_t t)
{
    switch (t) {
    case FACE_NO_SLIP:
    case FACE_MOVING_WALL:
        return RIGID_WALL_NO_SLIP;
    case FACE_FREE_SLIP:
        return RIGID_WALL_FREE_SLIP;
    default:
        return RIGID_WALL_OPEN; /* inlet, outlet: no film to squeeze */
    }
}

status_t rigid_config_from_scene(const scene_t *s, double t0, const log_t *log, rigid_config_t *cfg)
{
    const int ns = scene_total_spheres(s);
    rigid_sphere_cfg_t *sp = calloc((size_t)ns + 1, sizeof *sp);
    rigid_body_cfg_t *bd = calloc((size_t)s->nbodies + 1, sizeof *bd);
    rigid_connection_cfg_t *cn = calloc((size_t)s->nconnections + 1, sizeof *cn);
    *cfg = (rigid_config_t){0};
    if (sp == NULL || bd == NULL || cn == NULL) {
        free(sp);
        free(bd);
        free(cn);
        return log_msg(log, STATUS_FATAL, "rigid", "out of memory for the configuration of %d spheres, %d bodies, %d connections (%zu bytes)", ns, s->nbodies, s->nconnections, ((size_t)ns + 1) * sizeof *sp + ((size_t)s->nbodies + 1) * sizeof *bd + ((size_t)s->nconnections + 1) * sizeof *cn);
    }
    for (int b = 0, i = 0; b < s->nbodies; b++) {
        const scene_body_t *body = &s->bodies[b];
        bd[b].density = body->density;
        /* a prescribed body moves as the fluid moves it */
        bd[b].fixed = body->motion == MOTION_FREE ? 0 : body->motion == MOTION_PRESCRIBED ? RIGID_PRESCRIBED : 1;
        for (int a = 0; a < 3; a++) {
            const int moves = body->motion != MOTION_FIXED;
            bd[b].velocity[a] = moves ? body->velocity[a] : 0.0;
            bd[b].angular_velocity[a] = moves ? body->angular_velocity[a] : 0.0;
        }
        for (int k = 0; k < body->nspheres; k++, i++) {
            for (int a = 0; a < 3; a++) {
                sp[i].center[a] = body->spheres[k].center[a];
            }
            sp[i].radius = body->spheres[k].radius;
            sp[i].body = b;
        }
    }
    for (int k = 0; k < s->nconnections; k++) {
        cn[k] = (rigid_connection_cfg_t){s->connections[k].a, s->connections[k].b, s->connections[k].max_normal,
                                         s->connections[k].max_shear, s->connections[k].max_torque};
    }
    *cfg = (rigid_config_t){
        .nspheres = ns,
        .nbodies = s->nbodies,
        .nconnections = s->nconnections,
        .spheres = sp,
        .bodies = bd,
        .connections = cn,
        .fluid_density = s->fluid.density,
        .fluid_viscosity = s->fluid.viscosity,
        .lubrication = s->contacts.lubrication.enabled,
        .lub_cutoff = s->contacts.lubrication.cutoff * s->fluid.dx,
        .lub_min_gap = s->contacts.lubrication.min_gap,
        .contact_model = s->contacts.model == CONTACT_HERTZ            ? RIGID_CONTACT_HERTZ
                         : s->contacts.model == CONTACT_SPRING_DASHPOT ? RIGID_CONTACT_SPRING_DASHPOT
                                                                       : RIGID_CONTACT_NONE,
        .restitution = s->contacts.restitution,
        .contact_time = s->contacts.contact_time,
        .friction = s->contacts.friction,
        .young_modulus = s->contacts.young_modulus,
        .poisson_ratio = s->contacts.poisson_ratio,
        .stick_speed = s->contacts.stick_speed,
        .integrator = s->rigid.integrator == INTEGRATOR_CVODE ? RIGID_CVODE : RIGID_VERLET,
        .cvode_method = s->rigid.cvode_method == CVODE_ADAMS ? RIGID_ADAMS : RIGID_BDF,
        .linsol = s->rigid.linear_solver == LINSOL_SPGMR ? RIGID_LS_SPGMR : RIGID_LS_DENSE,
        .rtol = s->rigid.rtol,
        .atol = s->rigid.atol,
        .substeps = s->rigid.substeps,
        .t0 = t0,
        .release_time = s->rigid.release_time,
    };
    for (int a = 0; a < 3; a++) {
        cfg->gravity[a] = s->rigid.gravity[a];
        for (int side = 0; side < 2; side++) {
            const face_t *f = &s->domain.faces[2 * a + side];
            cfg->walls[a][side] = f->type != FACE_PERIODIC;
            cfg->wall_kind[a][side] = wall_kind(f->type);
            for (int k = 0; k < 3; k++) {
                cfg->wall_velocity[a][side][k] = f->type == FACE_MOVING_WALL ? f->velocity[k] : 0.0;
            }
        }
        cfg->periodic[a] = !cfg->walls[a][0] && !cfg->walls[a][1];
        cfg->box_lo[a] = 0.0;
        cfg->box_hi[a] = s->domain.size[a];
    }
    return STATUS_OK;
}

void rigid_scene_config_free(rigid_config_t *cfg)
{
    /* the arrays were allocated non-const above */
    free((void *)cfg->spheres);
    free((void *)cfg->bodies);
    free((void *)cfg->connections);
    cfg->spheres = NULL;
    cfg->bodies = NULL;
    cfg->connections = NULL;
}
