/* state.c — serialisation of the fluid component's state (fluid.h).
 *
 * Layout: a header (magic, version, grid, sphere count, streaming layout and
 * its state), the step counter, the population arrays of every allocated
 * cell (in place: the one array; two arrays: the current post-collision
 * values, and the previous ones that multireflection reads), the cell flags,
 * the sphere records, the list of solid cells (the map stage needs the
 * previous solid set to find uncovered cells) and the pre-collision pairs
 * the links keep for multireflection (spheres.h). Links are rebuilt by the
 * next step, which gives them their pairs back. Same build, same scene. */
#include "fluid_internal.h"

#include "lattice.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define STATE_MAGIC 0x464c5549444c4234ull /* "FLUIDLB4": the cell flags two to a byte (cellflags.h) */

typedef struct {
    uint64_t magic;
    int32_t n[3];
    int32_t nspheres;
    int64_t step;
    uint64_t ncells;
    uint64_t nsolid;
    int64_t covered, uncovered;
    int32_t first;
    int16_t streaming, layout;
    int32_t single, pad;
} state_header_t;

size_t fluid_state_size(const fluid_t *fl)
{
    return sizeof(state_header_t) + (size_t)fluid_arrays(fl) * LB_Q * fl->g.stride * fluid_value_bytes(fl) + cellflags_bytes(fl->g.ncells) +
           (size_t)fl->spheres.n * sizeof(sphere_t) + fl->spheres.nsolid * sizeof(size_t) +
           spheres_pairs_bytes(&fl->spheres);
}

status_t fluid_state_save(const fluid_t *fl, void *buf, size_t size)
{
    if (size < fluid_state_size(fl)) {
        return log_msg(&fl->log, STATUS_ERROR, "fluid", "state buffer of %zu bytes is smaller than the %zu needed",
                       size, fluid_state_size(fl));
    }
    state_header_t h;
    memset(&h, 0, sizeof h);
    h.magic = STATE_MAGIC;
    for (int a = 0; a < 3; a++) {
        h.n[a] = fl->g.n[a];
    }
    h.nspheres = fl->spheres.n;
    h.step = fl->step;
    h.ncells = fl->g.ncells;
    h.nsolid = fl->spheres.nsolid;
    h.covered = fl->spheres.covered_total;
    h.uncovered = fl->spheres.uncovered_total;
    h.first = fl->spheres.first;
    h.streaming = (int16_t)fl->streaming;
    h.layout = (int16_t)fl->layout;
    h.single = fl->single;
    unsigned char *p = buf;
    memcpy(p, &h, sizeof h);
    p += sizeof h;
    const size_t fbytes = (size_t)LB_Q * fl->g.stride * fluid_value_bytes(fl);
    for (int k = 0; k < fluid_arrays(fl); k++) {
        memcpy(p, fl->f[k == 0 ? fl->cur : 1 - fl->cur], fbytes);
        p += fbytes;
    }
    memcpy(p, fl->flags, cellflags_bytes(fl->g.ncells));
    p += cellflags_bytes(fl->g.ncells);
    if (fl->spheres.n > 0) {
        memcpy(p, fl->spheres.s, (size_t)fl->spheres.n * sizeof(sphere_t));
        p += (size_t)fl->spheres.n * sizeof(sphere_t);
    }
    if (fl->spheres.nsolid > 0) {
        memcpy(p, fl->spheres.solid, fl->spheres.nsolid * sizeof(size_t));
        p += fl->spheres.nsolid * sizeof(size_t);
    }
    spheres_pairs_out(&fl->spheres, p);
    return STATUS_OK;
}

status_t fluid_state_restore(fluid_t *fl, const void *buf, size_t size)
{
    state_header_t h;
    if (size < sizeof h) {
        return log_msg(&fl->log, STATUS_ERROR, "fluid", "state of %zu bytes is too short", size);
    }
    memcpy(&h, buf, sizeof h);
    if (h.magic != STATE_MAGIC || h.n[0] != fl->g.n[0] || h.n[1] != fl->g.n[1] || h.n[2] != fl->g.n[2] ||
        h.nspheres != fl->spheres.n || h.ncells != fl->g.ncells || h.streaming != (int16_t)fl->streaming ||
        h.single != fl->single) {
        return log_msg(&fl->log, STATUS_ERROR, "fluid",
                       "the state does not belong to this scene (grid %d x %d x %d with %d spheres, fluid.streaming "
                       "%s and fluid.precision %s expected)",
                       fl->g.n[0], fl->g.n[1], fl->g.n[2], fl->spheres.n,
                       fl->streaming == STREAMING_TWO_ARRAY ? "two_array" : "in_place", fl->single ? "single" : "double");
    }
    if (h.layout != LAYOUT_PULL && h.layout != LAYOUT_SWAPPED && h.layout != LAYOUT_PUSHED) {
        return log_msg(&fl->log, STATUS_ERROR, "fluid", "the state names layout state %d (0 to 2 expected)", h.layout);
    }
    const size_t fbytes = (size_t)LB_Q * fl->g.stride * fluid_value_bytes(fl);
    const size_t need = sizeof h + (size_t)fluid_arrays(fl) * fbytes + cellflags_bytes(fl->g.ncells) + (size_t)h.nspheres * sizeof(sphere_t) +
                        (size_t)h.nsolid * sizeof(size_t);
    if (size < need) {
        return log_msg(&fl->log, STATUS_ERROR, "fluid", "state of %zu bytes is shorter than its %zu bytes", size,
                       need);
    }
    /* the pairs: a count per sphere, then that many records, within the buffer */
    if (spheres_pairs_size((const unsigned char *)buf + need, size - need, h.nspheres) == (size_t)-1) {
        return log_msg(&fl->log, STATUS_ERROR, "fluid",
                       "state of %zu bytes ends inside the pre-collision pairs of its boundary links", size);
    }
    if (h.nsolid > fl->spheres.cap_solid) {
        size_t *ns = realloc(fl->spheres.solid, h.nsolid * sizeof(size_t));
        if (ns == NULL) {
            return log_msg(&fl->log, STATUS_ERROR, "fluid", "out of memory restoring the list of %zu solid cells (%zu bytes)",
                           (size_t)h.nsolid, (size_t)h.nsolid * sizeof(size_t));
        }
        fl->spheres.solid = ns;
        fl->spheres.cap_solid = h.nsolid;
    }
    const unsigned char *p = buf;
    p += sizeof h;
    for (int k = 0; k < fluid_arrays(fl); k++) {
        memcpy(fl->f[k == 0 ? fl->cur : 1 - fl->cur], p, fbytes);
        p += fbytes;
    }
    fl->layout = (layout_state_t)h.layout;
    memcpy(fl->flags, p, cellflags_bytes(fl->g.ncells));
    p += cellflags_bytes(fl->g.ncells);
    if (h.nspheres > 0) {
        memcpy(fl->spheres.s, p, (size_t)h.nspheres * sizeof(sphere_t));
        p += (size_t)h.nspheres * sizeof(sphere_t);
    }
    if (h.nsolid > 0) {
        memcpy(fl->spheres.solid, p, h.nsolid * sizeof(size_t));
        p += h.nsolid * sizeof(size_t);
    }
    if (!spheres_pairs_in(&fl->spheres, p)) {
        return log_msg(&fl->log, STATUS_ERROR, "fluid", "out of memory restoring the pre-collision pairs of the links");
    }
    fl->spheres.nsolid = h.nsolid;
    fl->spheres.covered_total = h.covered;
    fl->spheres.uncovered_total = h.uncovered;
    fl->spheres.first = h.first;
    fl->spheres.stale = 1; /* links are not saved: the next map stage builds them */
    fl->step = h.step;
    return STATUS_OK;
}
