/* state.c — serialisation of the fluid component's state (fluid.h).
 *
 * Layout: a header (magic, version, grid, sphere count, streaming layout and
 * its state), the step counter, the population arrays of every allocated
 * cell (in place: the one array; two arrays: the current post-collision
 * values, and the previous ones that multireflection reads), the cell flags,
 * the sphere records, the list of solid cells (the map stage needs the
 * previous solid set to find uncovered cells) and the pre-collision pairs
 * the links keep for multireflection (spheres.h). Links are rebuilt by the
 * next step, which gives them their pairs back. Same build, same scene.
 *
 * A restore checks everything it reads before it uses any of it (a flipped
 * bit, a damaged checkpoint file, bytes handed in through
 * fmi2DeSerializeFMUstate): the counts against the grid and the buffer, the
 * cell flags (fluid, solid or ghost, the ghost layer as this grid has it,
 * as many solid cells as listed), every solid cell's index (within the grid,
 * a solid cell), the sphere records (what the scene fixes equal to this
 * instance's, the rest finite and centres where a centre can be) and the
 * pairs section (as many bytes as are left, keys in order, finite values).
 * A refused state names the part that is wrong and leaves the component as
 * it was. The populations are not checked: a non-finite one is found by the
 * step's own detectors (fluid.c), with step, cell and position. */
#include "fluid_internal.h"

#include "lattice.h"

#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define STATE_MAGIC 0x464c5549444c4235ull /* "FLUIDLB5": the cell flags two to a byte (cellflags.h), the side store of the moments layout */

/* The moments layout's part instead of the population arrays: the
 * moments of every allocated cell, the side-store index and the entries in
 * use (moments.h). */
static size_t moments_part(const grid_t *g, size_t nside)
{
    return (size_t)MOM_N * g->stride * sizeof(double) + g->ncells * sizeof(int32_t) + nside * LB_Q * sizeof(double);
}

static const char *streaming_name(streaming_t s)
{
    return s == STREAMING_TWO_ARRAY ? "two_array" : s == STREAMING_MOMENTS ? "moments" : "in_place";
}

size_t fluid_state_size(const fluid_t *fl)
{
    return sizeof(fluid_state_header_t) + (size_t)fluid_arrays(fl) * LB_Q * fl->g.stride * fluid_value_bytes(fl) +
           (fl->streaming == STREAMING_MOMENTS ? moments_part(&fl->g, fl->mom.nside) : 0) +
           cellflags_bytes(fl->g.ncells) +
           (size_t)fl->spheres.n * sizeof(sphere_t) + fl->spheres.nsolid * sizeof(size_t) +
           spheres_pairs_bytes(&fl->spheres);
}

status_t fluid_state_save(const fluid_t *fl, void *buf, size_t size)
{
    if (size < fluid_state_size(fl)) {
        return log_msg(&fl->log, STATUS_ERROR, "fluid", "state buffer of %zu bytes is smaller than the %zu needed",
                       size, fluid_state_size(fl));
    }
    fluid_state_header_t h;
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
    h.nside = fl->streaming == STREAMING_MOMENTS ? fl->mom.nside : 0;
    unsigned char *p = buf;
    memcpy(p, &h, sizeof h);
    p += sizeof h;
    const size_t fbytes = (size_t)LB_Q * fl->g.stride * fluid_value_bytes(fl);
    for (int k = 0; k < fluid_arrays(fl); k++) {
        memcpy(p, fl->f[k == 0 ? fl->cur : 1 - fl->cur], fbytes);
        p += fbytes;
    }
    if (fl->streaming == STREAMING_MOMENTS) {
        const size_t mb = (size_t)MOM_N * fl->g.stride * sizeof(double), ib = fl->g.ncells * sizeof(int32_t),
                     sb = fl->mom.nside * LB_Q * sizeof(double);
        memcpy(p, fl->mom.m, mb);
        memcpy(p + mb, fl->mom.idx, ib);
        if (sb > 0) {
            memcpy(p + mb + ib, fl->mom.side, sb);
        }
        p += mb + ib + sb;
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

/* ------------------------------------------------------------------------ */
/* Checks of a state's contents (fluid_state_restore)                         */

/* A refused state, with what is wrong in it (common/status.h). */
#define corrupt(fl, ...) log_state_corrupt(&(fl)->log, "fluid", __VA_ARGS__)

/* The step counter: from 0 to 2^53, beyond which step * dt is not exact. */
#define STATE_STEP_MAX ((int64_t)1 << 53)
/* Lattice coordinates of a centre off the periodic axes: within 2^30 cells
 * (the cells' coordinates near it are ints). */
#define STATE_CENTRE_MAX 1073741824.0

/* Cell flags: 0 fluid, 1 solid, 2 ghost; the ghost cells those of this
 * grid (set at creation, never changed); the solid ones counted. */
static status_t check_flags(const fluid_t *fl, const uint8_t *flags, size_t *nsolid)
{
    size_t n = 0;
    for (size_t i = 0; i < fl->g.ncells; i++) {
        const unsigned v = cellflags_get(flags, i), mine = cellflags_get(fl->flags, i);
        if (v > CELL_GHOST || (v == CELL_GHOST) != (mine == CELL_GHOST)) {
            const size_t sx = (size_t)fl->g.s[0], sy = (size_t)fl->g.s[1];
            return corrupt(fl, "cell flags: cell %zu (allocated x %zu, y %zu, z %zu) has flag %u; allowed: %s", i,
                           i % sx, i / sx % sy, i / (sx * sy), v,
                           mine == CELL_GHOST ? "2 (a ghost cell of this grid)" : "0 (fluid) or 1 (solid)");
        }
        n += v == CELL_SOLID;
    }
    *nsolid = n;
    return STATUS_OK;
}

/* The list of solid cells: each an index of this grid whose flag is solid.
 * (With as many listed as flagged, checked by the caller.) */
static status_t check_solid(const fluid_t *fl, const uint8_t *flags, const unsigned char *list, size_t nsolid)
{
    for (size_t j = 0; j < nsolid; j++) {
        size_t i;
        memcpy(&i, list + j * sizeof i, sizeof i);
        if (i >= fl->g.ncells) {
            return corrupt(fl, "solid cell %zu of %zu has index %zu; allowed: below %zu, the cells of this grid", j,
                           nsolid, i, fl->g.ncells);
        }
        if (cellflags_get(flags, i) != CELL_SOLID) {
            return corrupt(fl, "solid cell %zu of %zu (index %zu) has flag %u, not 1 (solid)", j, nsolid, i,
                           cellflags_get(flags, i));
        }
    }
    return STATUS_OK;
}

/* A sphere record: what the scene fixes (body, motion, radius, density
 * ratio, coupling, prescribed motion) as in this instance, made from the
 * same scene; the kinematics, loads and watch finite; the centre where the
 * component keeps it (wrapped into the box on periodic axes). */
_Static_assert(offsetof(sphere_t, amp_grow0) == offsetof(sphere_t, hist) + 26 * sizeof(double) &&
                   offsetof(sphere_t, zr) == offsetof(sphere_t, zt) + sizeof(double) &&
                   offsetof(sphere_t, mass_weight) == offsetof(sphere_t, mass_debt) + 2 * sizeof(double),
               "check_sphere reads hist .. amp_grow0, zt, zr and mass_debt .. mass_weight as runs of doubles");

static status_t check_sphere(const fluid_t *fl, int k, const sphere_t *p)
{
    const sphere_t *mine = &fl->spheres.s[k];
    if (p->body != mine->body || p->motion != mine->motion || p->averaging != mine->averaging) {
        return corrupt(fl, "sphere %d: body %d, motion %d, averaging %d; this scene: body %d, motion %d, averaging %d",
                       k, p->body, p->motion, p->averaging, mine->body, mine->motion, mine->averaging);
    }
    static const struct {
        const char *name;
        size_t offset, n;
    } fixed[] = {
        {"radius", offsetof(sphere_t, r), 1},
        {"density ratio", offsetof(sphere_t, density_ratio), 1},
        {"coupling number", offsetof(sphere_t, kappa_risky), 1},
        {"initial centroid", offsetof(sphere_t, cb0), 3},
        {"initial offset from the centroid", offsetof(sphere_t, rel0), 3},
        {"prescribed velocity", offsetof(sphere_t, vbody), 3},
    };
    for (size_t m = 0; m < sizeof fixed / sizeof fixed[0]; m++) {
        const double *a = (const double *)(const void *)((const char *)p + fixed[m].offset);
        const double *b = (const double *)(const void *)((const char *)mine + fixed[m].offset);
        for (size_t d = 0; d < fixed[m].n; d++) {
            if (memcmp(&a[d], &b[d], sizeof(double)) != 0) {
                return corrupt(fl, "sphere %d: its %s (lattice units, component %zu) is %.17g, this scene's %.17g", k,
                               fixed[m].name, d, a[d], b[d]);
            }
        }
    }
    static const struct {
        const char *name;
        size_t offset, n;
    } finite[] = {
        {"centre", offsetof(sphere_t, c), 3},
        {"velocity", offsetof(sphere_t, v), 3},
        {"angular velocity", offsetof(sphere_t, w), 3},
        {"force", offsetof(sphere_t, f), 3},
        {"torque", offsetof(sphere_t, t), 3},
        {"previous force", offsetof(sphere_t, fprev), 3},
        {"previous torque", offsetof(sphere_t, tprev), 3},
        {"drag coefficients", offsetof(sphere_t, zt), 2},
        {"ambient density of the film zone", offsetof(sphere_t, rho_film), 1},
        {"mass debt of the links", offsetof(sphere_t, mass_debt), 3},
        {"centre at the last map", offsetof(sphere_t, cmap), 3},
        {"period-2 watch", offsetof(sphere_t, hist), 18 + 6 + 3},
    };
    for (size_t m = 0; m < sizeof finite / sizeof finite[0]; m++) {
        const double *a = (const double *)(const void *)((const char *)p + finite[m].offset);
        if (!all_finite(a, finite[m].n)) {
            return corrupt(fl, "sphere %d: %s not finite", k, finite[m].name);
        }
    }
    for (int a = 0; a < 3; a++) {
        const double lo = fl->spheres.periodic[a] ? 0.5 : -STATE_CENTRE_MAX,
                     hi = fl->spheres.periodic[a] ? fl->spheres.N[a] + 0.5 : STATE_CENTRE_MAX;
        if (!(p->c[a] >= lo && p->c[a] <= hi) || !(fabs(p->cmap[a]) <= STATE_CENTRE_MAX)) {
            return corrupt(fl, "sphere %d: its centre %c = %.17g cells (at the last map %.17g); allowed: %.17g to %.17g",
                           k, "xyz"[a], p->c[a], p->cmap[a], lo, hi);
        }
    }
    if (p->nhist < 0 || p->nhist > 3 || p->nalt < 0 || p->ngrow < 0 || (p->warned != 0 && p->warned != 1)) {
        return corrupt(fl, "sphere %d: period-2 watch counts %d, %d, %d, %d out of range", k, p->nhist, p->nalt,
                       p->ngrow, p->warned);
    }
    return STATUS_OK;
}

/* The pairs section: a count per sphere (none unless the scheme keeps
 * pairs), then that many (key, pair) records in increasing key order, with
 * keys as link_key makes them (sphere_links.c: q below 19, 53 bits), and
 * exactly the bytes left. */
static status_t check_pairs(const fluid_t *fl, const unsigned char *buf, size_t size, int nspheres)
{
    const size_t used = spheres_pairs_size(buf, size, nspheres);
    if (used == (size_t)-1) {
        return corrupt(fl, "the pre-collision pairs of the boundary links do not fit in the %zu bytes left for them",
                       size);
    }
    if (used != size) {
        return corrupt(fl, "the pre-collision pairs of the boundary links take %zu of the %zu bytes left for them",
                       used, size);
    }
    for (int k = 0; k < nspheres; k++) {
        uint64_t m;
        memcpy(&m, buf, sizeof m);
        buf += sizeof m;
        if (m > 0 && fl->spheres.scheme != BOUNDARY_MULTIREFLECTION) {
            return corrupt(fl, "sphere %d has %llu pre-collision pairs; this scene's boundary scheme keeps none", k,
                           (unsigned long long)m);
        }
        uint64_t last = 0;
        for (uint64_t j = 0; j < m; j++, buf += sizeof(spheres_carry_t)) {
            spheres_carry_t c;
            memcpy(&c, buf, sizeof c);
            if ((c.key & 31u) >= LB_Q || (c.key >> 53) != 0 || (j > 0 && c.key <= last) || !all_finite(c.pre, 2)) {
                return corrupt(fl, "pre-collision pair %llu of sphere %d: key %#llx (after %#llx), values %g, %g",
                               (unsigned long long)j, k, (unsigned long long)c.key, (unsigned long long)last, c.pre[0],
                               c.pre[1]);
            }
            last = c.key;
        }
    }
    return STATUS_OK;
}

/* The moments layout's side-store index: a cell of the ghost layer has its
 * own entry (as this grid gives them), an interior solid cell one of the
 * others, below nside, an interior fluid cell none (-1). */
static status_t check_index(const fluid_t *fl, const uint8_t *flags, const unsigned char *ibuf, size_t nside)
{
    const grid_t *g = &fl->g;
    size_t i = 0;
    for (int z = 0; z < g->s[2]; z++) {
        for (int y = 0; y < g->s[1]; y++) {
            for (int x = 0; x < g->s[0]; x++, i++) {
                int32_t e;
                memcpy(&e, ibuf + i * sizeof e, sizeof e);
                const unsigned v = cellflags_get(flags, i);
                const int ghost = !grid_is_interior(g, x, y, z);
                const int ok = ghost              ? e == fl->mom.idx[i]
                               : v == CELL_SOLID ? e >= 0 && (size_t)e >= fl->mom.nghost && (size_t)e < nside
                                                 : e == -1;
                if (!ok) {
                    return corrupt(fl, "side-store index: cell %zu (flag %u) has entry %d; allowed: %s", i, v, (int)e,
                                   ghost ? "its ghost entry" : v == CELL_SOLID ? "a solid cell's entry" : "-1 (fluid)");
                }
            }
        }
    }
    return STATUS_OK;
}

status_t fluid_state_restore(fluid_t *fl, const void *buf, size_t size)
{
    fluid_state_header_t h;
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
                       fl->g.n[0], fl->g.n[1], fl->g.n[2], fl->spheres.n, streaming_name(fl->streaming),
                       fl->single ? "single" : "double");
    }
    if (fl->streaming == STREAMING_TWO_ARRAY    ? h.layout != LAYOUT_PULL
        : fl->streaming == STREAMING_MOMENTS ? h.layout != LAYOUT_MOMENTS
                                             : h.layout != LAYOUT_SWAPPED && h.layout != LAYOUT_PUSHED) {
        return corrupt(fl, "layout state %d; allowed with fluid.streaming %s: %s", h.layout,
                       streaming_name(fl->streaming),
                       fl->streaming == STREAMING_TWO_ARRAY ? "0 (pull)"
                       : fl->streaming == STREAMING_MOMENTS ? "3 (moments)"
                                                            : "1 or 2 (swapped, pushed)");
    }
    const int mom = fl->streaming == STREAMING_MOMENTS;
    if (mom ? h.nside != fl->mom.nghost + h.nsolid : h.nside != 0) {
        return corrupt(fl, "%llu side-store entries; allowed: %s", (unsigned long long)h.nside,
                       mom ? "the ghost cells' and one per solid cell" : "0 outside fluid.streaming moments");
    }
    if (h.step < 0 || h.step > STATE_STEP_MAX || h.covered < 0 || h.uncovered < 0 || (h.first != 0 && h.first != 1)) {
        return corrupt(fl, "step %lld (allowed: 0 to 2^53), cells covered %lld and uncovered %lld (>= 0), first map %d "
                       "(0 or 1)", (long long)h.step, (long long)h.covered, (long long)h.uncovered, (int)h.first);
    }
    if (h.nsolid > fl->g.ncells || (h.first && h.nsolid > 0)) {
        return corrupt(fl, "%llu solid cells; allowed: 0 to the %zu cells of the grid, none before the first step",
                       (unsigned long long)h.nsolid, fl->g.ncells);
    }
    const size_t fbytes = (size_t)LB_Q * fl->g.stride * fluid_value_bytes(fl);
    const size_t mbytes = mom ? moments_part(&fl->g, (size_t)h.nside) : 0;
    const size_t need = sizeof h + (size_t)fluid_arrays(fl) * fbytes + mbytes + cellflags_bytes(fl->g.ncells) +
                        (size_t)h.nspheres * sizeof(sphere_t) + (size_t)h.nsolid * sizeof(size_t);
    if (size < need) {
        return log_msg(&fl->log, STATUS_ERROR, "fluid", "state of %zu bytes is shorter than its %zu bytes", size,
                       need);
    }
    const unsigned char *pops = (const unsigned char *)buf + sizeof h;
    const unsigned char *mpart = pops + (size_t)fluid_arrays(fl) * fbytes;
    const uint8_t *flags = mpart + mbytes;
    const unsigned char *recs = flags + cellflags_bytes(fl->g.ncells);
    const unsigned char *solid = recs + (size_t)h.nspheres * sizeof(sphere_t);
    const unsigned char *pairs = solid + (size_t)h.nsolid * sizeof(size_t);
    size_t nflagged = 0;
    status_t st = check_flags(fl, flags, &nflagged);
    if (st == STATUS_OK && nflagged != h.nsolid) {
        st = corrupt(fl, "%zu cells are flagged solid and %llu are listed", nflagged, (unsigned long long)h.nsolid);
    }
    if (st == STATUS_OK) {
        st = check_solid(fl, flags, solid, (size_t)h.nsolid);
    }
    for (int k = 0; k < h.nspheres && st == STATUS_OK; k++) {
        sphere_t p;
        memcpy(&p, recs + (size_t)k * sizeof p, sizeof p);
        st = check_sphere(fl, k, &p);
    }
    if (st == STATUS_OK) {
        st = check_pairs(fl, pairs, size - need, h.nspheres);
    }
    if (st == STATUS_OK && mom) {
        st = check_index(fl, flags, mpart + (size_t)MOM_N * fl->g.stride * sizeof(double), (size_t)h.nside);
    }
    if (st == STATUS_OK && mom && h.nside > fl->mom.cap) {
        double *ns = realloc(fl->mom.side, (size_t)h.nside * LB_Q * sizeof(double));
        if (ns == NULL) {
            return log_msg(&fl->log, STATUS_ERROR, "fluid", "out of memory restoring the side store of %zu cells",
                           (size_t)h.nside);
        }
        fl->mom.side = ns;
        fl->mom.cap = (size_t)h.nside;
    }
    if (st != STATUS_OK) {
        return st;
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
    const unsigned char *p = pops;
    for (int k = 0; k < fluid_arrays(fl); k++) {
        memcpy(fl->f[k == 0 ? fl->cur : 1 - fl->cur], p, fbytes);
        p += fbytes;
    }
    if (mom) {
        const size_t mb = (size_t)MOM_N * fl->g.stride * sizeof(double), ib = fl->g.ncells * sizeof(int32_t);
        memcpy(fl->mom.m, mpart, mb);
        memcpy(fl->mom.idx, mpart + mb, ib);
        if (h.nside > 0) {
            memcpy(fl->mom.side, mpart + mb + ib, (size_t)h.nside * LB_Q * sizeof(double));
        }
        fl->mom.nside = (size_t)h.nside;
    }
    fl->layout = (layout_state_t)h.layout;
    memcpy(fl->flags, flags, cellflags_bytes(fl->g.ncells));
    if (h.nspheres > 0) {
        memcpy(fl->spheres.s, recs, (size_t)h.nspheres * sizeof(sphere_t));
    }
    if (h.nsolid > 0) {
        memcpy(fl->spheres.solid, solid, h.nsolid * sizeof(size_t));
    }
    if (!spheres_pairs_in(&fl->spheres, pairs)) {
        return log_msg(&fl->log, STATUS_ERROR, "fluid", "out of memory restoring the pre-collision pairs of the links");
    }
    fl->spheres.nsolid = h.nsolid;
    fl->spheres.covered_total = h.covered;
    fl->spheres.uncovered_total = h.uncovered;
    fl->spheres.first = h.first;
    fl->spheres.stale = 1; /* links are not saved: the next map stage builds them */
    fl->step = h.step;
    if (mom) {
        fl->mom.map = fl->spheres.maps; /* the entries are those of the restored solid list */
        moments_rows(&fl->mom, &fl->g);
    }
    return STATUS_OK;
}
