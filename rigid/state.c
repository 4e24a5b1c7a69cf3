/* state.c — serialisation of the complete state for bit-identical restart.
 *
 * Layout (native byte order and struct layout: a state is read back by the
 * same build, as FMI 2.0 serialised FMU states are): a header with a magic
 * number, a layout version and the counts, then the sphere array (shares,
 * body ids, current and held loads), the body array (com, q, v, L, mass,
 * principal inertia, fixed) and the connection array (pair, limits, intact,
 * last force and torque), then the nspheres^2 touch flags of the sticking
 * rule. Derived data (sections, scratch) is rebuilt on
 * restore, and the contact watch starts afresh (contact_watch.c); CVODE is re-initialised at the start of every step anyway, so the
 * continuation after a restore is bit-identical to the uninterrupted run. */
#include "rigid_internal.h"

#include <stdlib.h>
#include <string.h>

#define RIGID_STATE_MAGIC 0x52494744u /* "RIGD" */
#define RIGID_STATE_VERSION 2u /* 2: the implicit coupling's debt_f, debt_t */

typedef struct {
    uint32_t magic, version;
    int32_t nspheres, nbodies, nconn, integrator;
    int32_t have_prev, pad;
    double t, h_prev;
} state_header_t;

static size_t state_bytes(int ns, int nb, int nc)
{
    return sizeof(state_header_t) + (size_t)ns * sizeof(rigid_sphere_t) + (size_t)nb * sizeof(rigid_body_t) +
           (size_t)nc * sizeof(rigid_conn_t) + (size_t)ns * (size_t)ns;
}

size_t rigid_state_size(const rigid_t *r) { return state_bytes(r->nspheres, r->nbodies, r->nconn); }

status_t rigid_state_save(const rigid_t *r, void *buf, size_t size)
{
    size_t need = rigid_state_size(r);
    if (buf == NULL || size < need) {
        return log_msg((log_t *)&r->log, STATUS_ERROR, RIGID_CAT, "state buffer of %zu bytes too small (need %zu)",
                       size, need);
    }
    state_header_t h;
    memset(&h, 0, sizeof h);
    h.magic = RIGID_STATE_MAGIC;
    h.version = RIGID_STATE_VERSION;
    h.nspheres = r->nspheres;
    h.nbodies = r->nbodies;
    h.nconn = r->nconn;
    h.integrator = (int32_t)r->cfg.integrator;
    h.have_prev = r->have_prev;
    h.t = r->t;
    h.h_prev = r->h_prev;
    unsigned char *p = buf;
    memcpy(p, &h, sizeof h);
    p += sizeof h;
    memcpy(p, r->spheres, (size_t)r->nspheres * sizeof(rigid_sphere_t));
    p += (size_t)r->nspheres * sizeof(rigid_sphere_t);
    memcpy(p, r->bodies, (size_t)r->nbodies * sizeof(rigid_body_t));
    p += (size_t)r->nbodies * sizeof(rigid_body_t);
    memcpy(p, r->conn, (size_t)r->nconn * sizeof(rigid_conn_t));
    p += (size_t)r->nconn * sizeof(rigid_conn_t);
    memcpy(p, r->touch, (size_t)r->nspheres * (size_t)r->nspheres);
    return STATUS_OK;
}

status_t rigid_state_restore(rigid_t *r, const void *buf, size_t size)
{
    state_header_t h;
    if (buf == NULL || size < sizeof h) {
        return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "state of %zu bytes is too short", size);
    }
    memcpy(&h, buf, sizeof h);
    if (h.magic != RIGID_STATE_MAGIC || h.version != RIGID_STATE_VERSION) {
        return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "not a rigid state (magic %#x version %u, expected %#x %u)",
                       h.magic, h.version, RIGID_STATE_MAGIC, RIGID_STATE_VERSION);
    }
    if (h.nspheres != r->nspheres || h.integrator != (int32_t)r->cfg.integrator || h.nbodies < 1 ||
        h.nbodies > r->nspheres || h.nconn < 0) {
        return log_msg(&r->log, STATUS_ERROR, RIGID_CAT,
                       "state does not fit this instance: %d spheres, integrator %d (instance: %d spheres, "
                       "integrator %d)",
                       h.nspheres, h.integrator, r->nspheres, (int)r->cfg.integrator);
    }
    size_t need = state_bytes(h.nspheres, h.nbodies, h.nconn);
    if (size < need) {
        return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "state of %zu bytes truncated (need %zu)", size, need);
    }
    if (h.nconn > r->conn_cap) {
        rigid_conn_t *nc = realloc(r->conn, (size_t)h.nconn * sizeof *nc);
        if (nc == NULL) {
            return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "out of memory restoring %d connections (%zu bytes)",
                           (int)h.nconn, (size_t)h.nconn * sizeof *nc);
        }
        r->conn = nc;
        unsigned char *sec = realloc(r->section, (size_t)h.nconn * (size_t)r->nspheres);
        if (sec == NULL) {
            return log_msg(&r->log, STATUS_ERROR, RIGID_CAT, "out of memory restoring the sections of %d connections (%zu bytes)",
                           (int)h.nconn, (size_t)h.nconn * (size_t)r->nspheres);
        }
        r->section = sec;
        r->conn_cap = h.nconn;
    }
    const unsigned char *p = (const unsigned char *)buf + sizeof h;
    memcpy(r->spheres, p, (size_t)h.nspheres * sizeof(rigid_sphere_t));
    p += (size_t)h.nspheres * sizeof(rigid_sphere_t);
    memcpy(r->bodies, p, (size_t)h.nbodies * sizeof(rigid_body_t));
    p += (size_t)h.nbodies * sizeof(rigid_body_t);
    memcpy(r->conn, p, (size_t)h.nconn * sizeof(rigid_conn_t));
    p += (size_t)h.nconn * sizeof(rigid_conn_t);
    memcpy(r->touch, p, (size_t)h.nspheres * (size_t)h.nspheres);
    rigid_contact_watch_reset(r); /* its records belong to the run that went on (contact_watch.c) */
    r->nbodies = h.nbodies;
    r->nconn = h.nconn;
    r->t = h.t;
    r->h_prev = h.h_prev;
    r->have_prev = h.have_prev;
    return rigid_sections_update(r);
}
