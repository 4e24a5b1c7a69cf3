/* run.c — the co-simulation master of `coupler run` (DESIGN section 2).
 *
 * Setup, in an order that leaves existing files untouched on any error:
 *   1. FMUs: exported from the scene into a temporary folder (export.c), or
 *      the .fmu files / unpacked folders given with --fluid-fmu/--rigid-fmu;
 *      each is unpacked, described (modelDescription.xml) and dlopen'ed
 *      (fmu.c). The rigid FMU exists only when the scene has free bodies.
 *   2. Signals: every input of one FMU is connected to the output of the
 *      other with the same name; a missing partner or a different type or
 *      unit is an error. Observed outputs (per sphere kinematics and loads,
 *      connection loads, fluid totals) are found by name in either FMU.
 *   3. The FMUs must have been exported from this scene (GUID check), the
 *      output folder must be writable; then the FMUs are initialised and the
 *      output file is created.
 * Loop, per communication step n (h = K LBM steps, t = t0 + n h from the
 * step counter, never accumulated):
 *   rigid kinematics -> fluid inputs; fluid fmi2DoStep(t, h);
 *   fluid forces/torques -> rigid inputs; rigid fmi2DoStep(t, h)
 * (the rigid sub-cycles internally, rigid.substeps). Output rows at t >=
 * k * run.output_interval and at the end. Every FMI status is checked; an
 * error stops the run with the output file holding every row written.
 * Under mpirun every rank runs this loop with its own FMUs (the fluid's
 * block of the grid, the same rigid): they take every decision alike, agree
 * once per communication step on a stop signal that some rank has seen, and
 * write each checkpoint together (save_checkpoint: rank 0 writes the file
 * with every rank's block, and all learn the outcome). */
#define _XOPEN_SOURCE 700 /* nftw, mkdtemp */
#include "run.h"
#include "mpi_env.h"

#include "../common/fmi_adapter.h"
#include "../fluid/decomp.h"
#include "../fluid/units.h"
#include "checkpoint.h"
#include "export.h"
#include "fmu.h"
#include "output.h"
#include "resources.h"
#include "summary.h"

#include <errno.h>
#include <ftw.h>
#include <limits.h>
#include <math.h>
#include <omp.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define CAT "run"
#define PI 3.14159265358979323846

/* Quantities of one output row, in the order of the row buffer. */
enum { R_POS, R_VEL, R_OMEGA, R_FORCE, R_TORQUE, NSPHERE_Q };
static const char *const SPHERE_Q[NSPHERE_Q] = {"position", "velocity", "angular_velocity", "force", "torque"};
static const char *const AXIS = "xyz";

/* Values read from one FMU in one call: vr[k] goes to row[dest[k]]. */
typedef struct {
    unsigned *vr;
    int *dest;
    int n;
    double *tmp;
    int *itmp;
} gather_t;

typedef struct {
    const scene_t *scene;
    const run_options_t *opt;
    log_t log;
    units_t un;
    int ns, nc, nfree_bodies;
    fmu_t *fluid, *rigid;
    FILE *calls;
    char tmp[4096];   /* temporary folder, "" when none */
    char fields[4096]; /* field file, "" when none */
    /* exchange: rigid outputs -> fluid inputs, fluid outputs -> rigid inputs */
    unsigned *to_fluid_src, *to_fluid_dst, *to_rigid_src, *to_rigid_dst;
    int nto_fluid, nto_rigid;
    double *xbuf;
    /* observation: the row buffer and what fills it */
    double *row;  /* 5 * ns * 3 + 2 * nc * 3 + 8 doubles */
    int *ibody, *iintact;
    int o_cforce, o_ctorque, o_mass, o_mom, o_ke, o_vmax, o_peak, o_bmom, o_bang, nrow;
    gather_t real_fluid, real_rigid, int_rigid, bool_rigid;
    /* settling summary: the velocity along gravity of the one free sphere */
    double *settle_t, *settle_v;
    long nsettle;
    /* checkpoints: what they belong to, where they go */
    checkpoint_origin_t origin;
    checkpoint_ranks_t ranks; /* the MPI ranks and their blocks (fluid/decomp.h) */
    char cp_path[4200];
} master_t;

/* The signal that asked the run to stop (SIGINT, SIGTERM), 0 for none. The
 * one process-wide variable of the master: a signal handler can reach no
 * other. A second signal while the first is handled ends the process at once. */
static volatile sig_atomic_t stop_signal = 0;

static void on_signal(int sig)
{
    if (stop_signal != 0) {
        signal(sig, SIG_DFL);
        raise(sig);
        return;
    }
    stop_signal = sig;
}

/* ------------------------------------------------------------------------ */
/* Setup helpers                                                             */

static int rm_entry(const char *path, const struct stat *sb, int flag, struct FTW *ftw)
{
    (void)sb, (void)flag, (void)ftw;
    return remove(path) != 0 ? -1 : 0;
}

static int nfree_bodies(const scene_t *s)
{
    int n = 0;
    for (int b = 0; b < s->nbodies; b++) {
        n += s->bodies[b].motion == MOTION_FREE;
    }
    return n;
}

static int same_unit(const char *a, const char *b)
{
    return (a == NULL && b == NULL) || (a != NULL && b != NULL && strcmp(a, b) == 0);
}

static const char *type_text(fmu_type_t t)
{
    return t == FMU_REAL ? "Real" : t == FMU_INTEGER ? "Integer" : t == FMU_BOOLEAN ? "Boolean" : "String";
}

/* Every input of `to` gets the output of `from` with the same name. */
static status_t connect(master_t *m, fmu_t *from, fmu_t *to, unsigned **src, unsigned **dst, int *n)
{
    const int nv = fmu_nvars(to);
    *src = calloc((size_t)nv + 1, sizeof **src);
    *dst = calloc((size_t)nv + 1, sizeof **dst);
    if (*src == NULL || *dst == NULL) {
        return log_msg(&m->log, STATUS_FATAL, CAT, "out of memory for the signal map of %d variables (%zu bytes)", nv, 2 * ((size_t)nv + 1) * sizeof **src);
    }
    status_t st = STATUS_OK;
    for (int j = 0; j < nv; j++) {
        const fmu_var_t *in = fmu_var(to, j);
        if (in->causality != FMU_INPUT) {
            continue;
        }
        const fmu_var_t *out = from != NULL ? fmu_find(from, in->name) : NULL;
        if (out == NULL || out->causality != FMU_OUTPUT) {
            st = log_msg(&m->log, STATUS_ERROR, CAT, "signal mismatch: input %s of %s has no output of that name in %s",
                         in->name, fmu_label(to), from != NULL ? fmu_label(from) : "any FMU (the scene has no rigid.fmu)");
            continue;
        }
        if (out->type != in->type || in->type != FMU_REAL || !same_unit(in->unit, out->unit)) {
            st = log_msg(&m->log, STATUS_ERROR, CAT,
                         "signal mismatch: %s is %s [%s] in %s but %s [%s] in %s", in->name, type_text(in->type),
                         in->unit != NULL ? in->unit : "no unit", fmu_label(to), type_text(out->type),
                         out->unit != NULL ? out->unit : "no unit", fmu_label(from));
            continue;
        }
        (*src)[*n] = out->vr;
        (*dst)[*n] = in->vr;
        (*n)++;
    }
    return st;
}

static status_t gather_add(master_t *m, gather_t *g, unsigned vr, int dest)
{
    if (g->n % 64 == 0) {
        unsigned *v = realloc(g->vr, sizeof *v * (size_t)(g->n + 64));
        int *d = v != NULL ? realloc(g->dest, sizeof *d * (size_t)(g->n + 64)) : NULL;
        if (v != NULL) {
            g->vr = v;
        }
        if (d == NULL) {
            return log_msg(&m->log, STATUS_FATAL, CAT, "out of memory for the observed outputs (%zu bytes)", ((size_t)g->n + 1) * (sizeof(int) + sizeof(unsigned)));
        }
        g->dest = d;
    }
    g->vr[g->n] = vr;
    g->dest[g->n] = dest;
    g->n++;
    return STATUS_OK;
}

/* Finds an output by name in the fluid or the rigid FMU. */
static status_t observe(master_t *m, const char *name, fmu_type_t type, int dest, int required)
{
    fmu_t *owners[2] = {m->fluid, m->rigid};
    for (int k = 0; k < 2; k++) {
        const fmu_var_t *v = owners[k] != NULL ? fmu_find(owners[k], name) : NULL;
        if (v == NULL || v->causality != FMU_OUTPUT) {
            continue;
        }
        if (v->type != type) {
            return log_msg(&m->log, STATUS_ERROR, CAT, "%s of %s is %s; the master expects %s", name,
                           fmu_label(owners[k]), type_text(v->type), type_text(type));
        }
        gather_t *g = type == FMU_REAL      ? (k == 0 ? &m->real_fluid : &m->real_rigid)
                      : type == FMU_INTEGER ? &m->int_rigid
                                            : &m->bool_rigid;
        if (type != FMU_REAL && k == 0) {
            return log_msg(&m->log, STATUS_ERROR, CAT, "%s: the master reads it from rigid.fmu only", name);
        }
        return gather_add(m, g, v->vr, dest);
    }
    if (!required) {
        return STATUS_DISCARD;
    }
    return log_msg(&m->log, STATUS_ERROR, CAT, "no FMU publishes the output %s that the output file needs", name);
}

static status_t plan_observation(master_t *m)
{
    const int ns = m->ns, nc = m->nc;
    m->o_cforce = NSPHERE_Q * 3 * ns;
    m->o_ctorque = m->o_cforce + 3 * nc;
    m->o_mass = m->o_ctorque + 3 * nc;
    m->o_mom = m->o_mass + 1;
    m->o_ke = m->o_mom + 3;
    m->o_vmax = m->o_ke + 1;
    m->o_peak = m->o_vmax + 1;
    m->o_bmom = m->o_peak + 3;
    m->o_bang = m->o_bmom + 3;
    m->nrow = m->o_bang + 3;
    m->row = calloc((size_t)m->nrow, sizeof(double));
    m->ibody = calloc((size_t)ns + 1, sizeof(int)); /* [ns]: the number of moving bodies */
    m->iintact = calloc((size_t)nc + 1, sizeof(int));
    if (m->row == NULL || m->ibody == NULL || m->iintact == NULL) {
        return log_msg(&m->log, STATUS_FATAL, CAT, "out of memory for the output row (%zu bytes)", (size_t)m->nrow * sizeof(double) + ((size_t)ns + (size_t)nc + 2) * sizeof(int));
    }
    status_t st = STATUS_OK;
    char name[128];
    for (int i = 0; i < ns && st == STATUS_OK; i++) {
        for (int q = 0; q < NSPHERE_Q && st == STATUS_OK; q++) {
            for (int a = 0; a < 3 && st == STATUS_OK; a++) {
                /* the load: what acted over the step (rigid.fmu's applied
                 * load under the implicit coupling), else the fluid's */
                if (q == R_FORCE || q == R_TORQUE) {
                    snprintf(name, sizeof name, "sphere[%d].applied_%s.%c", i, SPHERE_Q[q], AXIS[a]);
                    st = observe(m, name, FMU_REAL, q * 3 * ns + 3 * i + a, 0);
                    if (st != STATUS_DISCARD) {
                        continue;
                    }
                }
                snprintf(name, sizeof name, "sphere[%d].%s.%c", i, SPHERE_Q[q], AXIS[a]);
                st = observe(m, name, FMU_REAL, q * 3 * ns + 3 * i + a, 1);
            }
        }
    }
    /* body ids: the rigid publishes them for its spheres; the others keep
     * their scene body index */
    for (int b = 0, i = 0; b < m->scene->nbodies && st == STATUS_OK; b++) {
        for (int k = 0; k < m->scene->bodies[b].nspheres && st == STATUS_OK; k++, i++) {
            m->ibody[i] = b;
            snprintf(name, sizeof name, "sphere[%d].body", i);
            st = observe(m, name, FMU_INTEGER, i, 0);
            st = st == STATUS_DISCARD ? STATUS_OK : st;
        }
    }
    for (int k = 0; k < nc && st == STATUS_OK; k++) {
        for (int a = 0; a < 3 && st == STATUS_OK; a++) {
            snprintf(name, sizeof name, "connection[%d].force.%c", k, AXIS[a]);
            st = observe(m, name, FMU_REAL, m->o_cforce + 3 * k + a, 1);
            snprintf(name, sizeof name, "connection[%d].torque.%c", k, AXIS[a]);
            st = status_worst(st, observe(m, name, FMU_REAL, m->o_ctorque + 3 * k + a, 1));
        }
        snprintf(name, sizeof name, "connection[%d].intact", k);
        st = status_worst(st, observe(m, name, FMU_BOOLEAN, k, 1));
    }
    static const struct {
        const char *name;
        int vector;
    } diag[] = {{"fluid.mass", 0}, {"fluid.momentum", 1}, {"fluid.kinetic_energy", 0}, {"fluid.max_speed", 0},
                {"fluid.peak_velocity", 1}};
    const int offs[] = {m->o_mass, m->o_mom, m->o_ke, m->o_vmax, m->o_peak};
    for (int d = 0; d < 5 && st == STATUS_OK; d++) {
        for (int a = 0; a < (diag[d].vector ? 3 : 1) && st == STATUS_OK; a++) {
            if (diag[d].vector) {
                snprintf(name, sizeof name, "%s.%c", diag[d].name, AXIS[a]);
            } else {
                snprintf(name, sizeof name, "%s", diag[d].name);
            }
            st = observe(m, name, FMU_REAL, offs[d] + a, 1);
        }
    }
    /* the rigid component's totals over its moving bodies (balances of
     * break-up and sticking) */
    for (int a = 0; a < 3 && st == STATUS_OK && m->rigid != NULL; a++) {
        snprintf(name, sizeof name, "rigid.momentum.%c", AXIS[a]);
        st = observe(m, name, FMU_REAL, m->o_bmom + a, 1);
        snprintf(name, sizeof name, "rigid.angular_momentum.%c", AXIS[a]);
        st = status_worst(st, observe(m, name, FMU_REAL, m->o_bang + a, 1));
    }
    if (st == STATUS_OK && m->rigid != NULL) {
        st = observe(m, "rigid.bodies", FMU_INTEGER, ns, 1);
    }
    gather_t *gs[4] = {&m->real_fluid, &m->real_rigid, &m->int_rigid, &m->bool_rigid};
    for (int k = 0; k < 4 && st == STATUS_OK; k++) {
        gs[k]->tmp = calloc((size_t)gs[k]->n + 1, sizeof(double));
        gs[k]->itmp = calloc((size_t)gs[k]->n + 1, sizeof(int));
        if (gs[k]->tmp == NULL || gs[k]->itmp == NULL) {
            st = log_msg(&m->log, STATUS_FATAL, CAT, "out of memory for the read buffers (%zu bytes)", ((size_t)gs[k]->n + 1) * (sizeof(double) + sizeof(int)));
        }
    }
    return st;
}

/* Reads every observed output into the row buffer. */
static status_t read_row(master_t *m)
{
    status_t st = STATUS_OK;
    gather_t *g = &m->real_fluid;
    if (g->n > 0 && (st = fmu_get_real(m->fluid, g->vr, (size_t)g->n, g->tmp)) >= STATUS_ERROR) {
        return st;
    }
    for (int k = 0; k < g->n; k++) {
        m->row[g->dest[k]] = g->tmp[k];
    }
    if (m->rigid == NULL) {
        return st;
    }
    g = &m->real_rigid;
    if (g->n > 0 && (st = fmu_get_real(m->rigid, g->vr, (size_t)g->n, g->tmp)) >= STATUS_ERROR) {
        return st;
    }
    for (int k = 0; k < g->n; k++) {
        m->row[g->dest[k]] = g->tmp[k];
    }
    g = &m->int_rigid;
    if (g->n > 0 && (st = fmu_get_integer(m->rigid, g->vr, (size_t)g->n, g->itmp)) >= STATUS_ERROR) {
        return st;
    }
    for (int k = 0; k < g->n; k++) {
        m->ibody[g->dest[k]] = g->itmp[k];
    }
    g = &m->bool_rigid;
    if (g->n > 0 && (st = fmu_get_boolean(m->rigid, g->vr, (size_t)g->n, g->itmp)) >= STATUS_ERROR) {
        return st;
    }
    for (int k = 0; k < g->n; k++) {
        m->iintact[g->dest[k]] = g->itmp[k] != 0;
    }
    return st;
}

static status_t write_row(master_t *m, output_t *out, double t)
{
    const int ns = m->ns;
    const double *r = m->row;
    output_row_t row = {
        .time = t,
        .position = r + R_POS * 3 * ns,
        .velocity = r + R_VEL * 3 * ns,
        .angular_velocity = r + R_OMEGA * 3 * ns,
        .force = r + R_FORCE * 3 * ns,
        .torque = r + R_TORQUE * 3 * ns,
        .body = m->ibody,
        .conn_force = r + m->o_cforce,
        .conn_torque = r + m->o_ctorque,
        .intact = m->iintact,
        .mass = r[m->o_mass],
        .momentum = {r[m->o_mom], r[m->o_mom + 1], r[m->o_mom + 2]},
        .kinetic_energy = r[m->o_ke],
        .nbodies = m->ibody[m->ns],
        .body_momentum = r + m->o_bmom,
        .body_angular_momentum = r + m->o_bang,
    };
    return output_row(out, &row);
}

/* ------------------------------------------------------------------------ */
/* Stepping                                                                  */

static status_t exchange(master_t *m, fmu_t *from, fmu_t *to, const unsigned *src, const unsigned *dst, int n)
{
    if (n == 0) {
        return STATUS_OK;
    }
    status_t st = fmu_get_real(from, src, (size_t)n, m->xbuf);
    return st >= STATUS_ERROR ? st : status_worst(st, fmu_set_real(to, dst, (size_t)n, m->xbuf));
}

/* One communication step from t: the sequential scheme. */
static status_t cosim_step(master_t *m, double t, double h)
{
    status_t st = STATUS_OK;
    if (m->rigid != NULL && (st = exchange(m, m->rigid, m->fluid, m->to_fluid_src, m->to_fluid_dst,
                                           m->nto_fluid)) >= STATUS_ERROR) {
        return st;
    }
    if ((st = status_worst(st, fmu_do_step(m->fluid, t, h))) >= STATUS_ERROR) {
        return st;
    }
    if (m->rigid == NULL) {
        return st;
    }
    if ((st = status_worst(st, exchange(m, m->fluid, m->rigid, m->to_rigid_src, m->to_rigid_dst, m->nto_rigid))) >=
        STATUS_ERROR) {
        return st;
    }
    return status_worst(st, fmu_do_step(m->rigid, t, h));
}

/* ------------------------------------------------------------------------ */
/* Summary                                                                   */

/* ------------------------------------------------------------------------ */
/* The run                                                                   */

static status_t check_writable(const char *path, const log_t *log)
{
    char dir[4096];
    resources_folder(path, dir, sizeof dir);
    if (access(dir, W_OK | X_OK) != 0) {
        return log_msg(log, STATUS_ERROR, CAT, "cannot write the output file %s: folder %s: %s", path, dir,
                       strerror(errno));
    }
    if (access(path, F_OK) == 0 && access(path, W_OK) != 0) {
        return log_msg(log, STATUS_ERROR, CAT, "cannot write the output file %s: %s", path, strerror(errno));
    }
    return STATUS_OK;
}

static status_t load_fmus(master_t *m)
{
    const run_options_t *opt = m->opt;
    char export_dir[4200], fluid_path[4300], rigid_path[4300];
    const char *tmpdir = getenv("TMPDIR") != NULL && getenv("TMPDIR")[0] != '\0' ? getenv("TMPDIR") : "/tmp";
    snprintf(m->tmp, sizeof m->tmp, "%s/coupler-XXXXXX", tmpdir);
    if (mkdtemp(m->tmp) == NULL) {
        const status_t st = log_msg(&m->log, STATUS_ERROR, CAT, "cannot create a temporary folder in %s: %s", tmpdir,
                                    strerror(errno));
        m->tmp[0] = '\0';
        return st;
    }
    snprintf(export_dir, sizeof export_dir, "%s/export", m->tmp);
    const int need_rigid = m->nfree_bodies > 0;
    if ((opt->fluid_fmu == NULL || (need_rigid && opt->rigid_fmu == NULL)) &&
        export_fmus(m->scene, export_dir, opt->lib_dir, 0, &m->log) != 0) {
        return log_msg(&m->log, STATUS_ERROR, CAT, "cannot export the FMUs of %s (see above)", m->scene->path);
    }
    snprintf(fluid_path, sizeof fluid_path, "%s", opt->fluid_fmu != NULL ? opt->fluid_fmu : export_dir);
    if (opt->fluid_fmu == NULL) {
        strcat(fluid_path, "/fluid.fmu");
    }
    status_t st = fmu_load(fluid_path, m->tmp, "fluid.fmu", m->calls, &m->log, &m->fluid);
    if (st >= STATUS_ERROR) {
        return st;
    }
    if (!need_rigid) {
        if (opt->rigid_fmu != NULL) {
            log_msg(&m->log, STATUS_WARNING, CAT, "%s has no free bodies: the fluid runs alone, --rigid-fmu %s is not used",
                    m->scene->path, opt->rigid_fmu);
        }
        return STATUS_OK;
    }
    snprintf(rigid_path, sizeof rigid_path, "%s", opt->rigid_fmu != NULL ? opt->rigid_fmu : export_dir);
    if (opt->rigid_fmu == NULL) {
        strcat(rigid_path, "/rigid.fmu");
    }
    return fmu_load(rigid_path, m->tmp, "rigid.fmu", m->calls, &m->log, &m->rigid);
}

/* The FMUs must carry this scene: their GUID is a hash of its text. */
static status_t check_guid(master_t *m, fmu_t *f)
{
    char guid[39];
    fmi_guid(fmu_identifier(f), m->scene->text, strlen(m->scene->text), guid);
    if (strcmp(guid, fmu_guid(f)) != 0) {
        return log_msg(&m->log, STATUS_ERROR, CAT,
                       "%s was exported from another scene (GUID %s; %s with these --set options gives %s): export it "
                       "again with `coupler export`",
                       fmu_label(f), fmu_guid(f), m->scene->path, guid);
    }
    return STATUS_OK;
}

/* resume: the field file of an interrupted run is continued (output.fields_resume). */
static status_t init_fmus(master_t *m, double t_stop, int resume)
{
    status_t st = fmu_instantiate(m->fluid, 0.0, t_stop);
    const fmu_var_t *fields = fmu_find(m->fluid, resume ? "output.fields_resume" : "output.fields");
    if (st < STATUS_ERROR && fields != NULL && m->fields[0] != '\0') {
        st = status_worst(st, fmu_set_string(m->fluid, fields->vr, m->fields));
    }
    if (st < STATUS_ERROR) {
        st = status_worst(st, fmu_exit_init(m->fluid));
    }
    if (st < STATUS_ERROR && m->rigid != NULL) {
        st = status_worst(st, fmu_instantiate(m->rigid, 0.0, t_stop));
        if (st < STATUS_ERROR) {
            st = status_worst(st, fmu_exit_init(m->rigid));
        }
    }
    return st;
}

static void free_master(master_t *m)
{
    fmu_free(m->rigid);
    fmu_free(m->fluid);
    if (m->calls != NULL && fclose(m->calls) != 0) {
        log_msg(&m->log, STATUS_WARNING, CAT, "%s: error while closing the FMI call log", m->opt->log_calls);
    }
    if (m->tmp[0] != '\0') {
        nftw(m->tmp, rm_entry, 16, FTW_DEPTH | FTW_PHYS);
    }
    gather_t *gs[4] = {&m->real_fluid, &m->real_rigid, &m->int_rigid, &m->bool_rigid};
    for (int k = 0; k < 4; k++) {
        free(gs[k]->vr);
        free(gs[k]->dest);
        free(gs[k]->tmp);
        free(gs[k]->itmp);
    }
    free(m->to_fluid_src);
    free(m->to_fluid_dst);
    free(m->to_rigid_src);
    free(m->to_rigid_dst);
    free(m->xbuf);
    free(m->row);
    free(m->ibody);
    free(m->iintact);
    free(m->settle_t);
    free(m->settle_v);
}

/* ------------------------------------------------------------------------ */
/* Checkpoint and restart                                                    */

/* What this run's checkpoints belong to: the coupler binary, each FMU's GUID
 * and library. */
static status_t find_origin(master_t *m)
{
    char exe[4096], lib[4400], hash[17];
    const ssize_t len = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (len <= 0) {
        return log_msg(&m->log, STATUS_ERROR, CAT, "cannot find the coupler executable (/proc/self/exe): %s",
                       strerror(errno));
    }
    exe[len] = '\0';
    if (checkpoint_file_hash(exe, &m->log, hash) != STATUS_OK) {
        return STATUS_ERROR;
    }
    snprintf(m->origin.coupler, sizeof m->origin.coupler, "build %s", hash);
    fmu_t *f[2] = {m->fluid, m->rigid};
    char *dst[2] = {m->origin.fluid, m->origin.rigid};
    for (int k = 0; k < 2; k++) {
        if (f[k] == NULL) {
            continue;
        }
        fmu_library_path(f[k], lib, sizeof lib);
        if (checkpoint_file_hash(lib, &m->log, hash) != STATUS_OK) {
            return STATUS_ERROR;
        }
        snprintf(dst[k], CHECKPOINT_ID_MAX, "GUID %s, library %s", fmu_guid(f[k]), hash);
    }
    return STATUS_OK;
}

/* The serialized state of one FMU. */
static status_t serialize(fmu_t *f, unsigned char **bytes, size_t *size)
{
    void *state = NULL;
    status_t st = fmu_get_state(f, &state);
    if (st < STATUS_ERROR) {
        st = status_worst(st, fmu_serialize_state(f, state, bytes, size));
    }
    if (state != NULL) {
        st = status_worst(st, fmu_free_state(f, &state));
    }
    return st;
}

static status_t deserialize(fmu_t *f, const unsigned char *bytes, size_t size)
{
    void *state = NULL;
    status_t st = fmu_deserialize_state(f, bytes, size, &state);
    if (st < STATUS_ERROR) {
        st = status_worst(st, fmu_set_state(f, state));
    }
    if (state != NULL) {
        st = status_worst(st, fmu_free_state(f, &state));
    }
    return st;
}

/* Position of the run at a communication point, for a checkpoint. */
typedef struct {
    long n, nsteps, next_out;
    int k_lbm;
    double h, wall0, wall_before[3];
} run_point_t;

/* The worst status of all ranks: every rank takes the same branch after it. */
static status_t agree(master_t *m, status_t st)
{
    int v = (int)st;
    const status_t mst = mpi_env_max(&v, &m->log);
    return status_worst((status_t)v, mst);
}

/* Rank 0's side of a checkpoint on several ranks (checkpoint_hooks_t): the
 * other ranks' fluid blocks, received one after another into one buffer. */
typedef struct {
    master_t *m;
    output_t *out;
    const size_t *sizes; /* every rank's block, bytes */
    unsigned char *buf;  /* as large as the largest of the other ranks */
} blocks_t;

static status_t receive_block(void *ctx, int rank, const unsigned char **bytes, size_t *size)
{
    blocks_t *b = ctx;
    *bytes = b->buf;
    *size = b->sizes[rank];
    return mpi_env_recv(b->buf, b->sizes[rank], rank, &b->m->log);
}

static status_t copy_rows(void *ctx, const char *tmp_path)
{
    return output_save_rows(((blocks_t *)ctx)->out, tmp_path, "/output");
}

/* Every rank calls it at the same communication step (the steps are due
 * alike and a stop is agreed, run_scene): each serializes its fluid block,
 * rank 0 writes them all with the rest into the one file, and every rank
 * returns the outcome of the whole. */
static status_t save_checkpoint(master_t *m, output_t *out, const run_point_t *p)
{
    const int rank = mpi_env_rank(), size = mpi_env_size();
    checkpoint_t c;
    memset(&c, 0, sizeof c);
    size_t *sizes = NULL;
    blocks_t b = {m, out, NULL, NULL};
    status_t st = output_flush(out);
    if (st < STATUS_ERROR) {
        st = status_worst(st, serialize(m->fluid, &c.fluid_state, &c.fluid_size));
    }
    /* the rigid state is the same on every rank: rank 0 writes its own */
    if (st < STATUS_ERROR && m->rigid != NULL && rank == 0) {
        st = status_worst(st, serialize(m->rigid, &c.rigid_state, &c.rigid_size));
    }
    if (size > 1) {
        if (rank == 0 && (sizes = calloc((size_t)size, sizeof *sizes)) == NULL) {
            /* the others wait for rank 0 until its MPI_Abort (mpi_env_finish) */
            st = log_msg(&m->log, STATUS_FATAL, CAT, "out of memory for the block sizes of %d ranks", size);
            goto cleanup;
        }
        st = status_worst(st, mpi_env_gather_size(c.fluid_size, sizes, &m->log));
        size_t largest = 0;
        for (int k = 1; rank == 0 && k < size; k++) {
            largest = sizes[k] > largest ? sizes[k] : largest;
        }
        if (rank == 0 && st < STATUS_ERROR && (b.buf = malloc(largest > 0 ? largest : 1)) == NULL) {
            st = log_msg(&m->log, STATUS_FATAL, CAT, "out of memory for a fluid block of another rank (%zu bytes)",
                         largest);
        }
        b.sizes = sizes;
        /* all ranks send and receive, or none */
        st = agree(m, st);
    }
    if (st < STATUS_ERROR && rank > 0) {
        st = status_worst(st, mpi_env_send(c.fluid_state, c.fluid_size, 0, &m->log));
    } else if (st < STATUS_ERROR) {
        c.step = p->n;
        c.nsteps = p->nsteps;
        c.rows = output_rows(out);
        c.next_out = p->next_out;
        c.exchange_every = p->k_lbm;
        c.h = p->h;
        c.ranks = m->ranks;
        c.settle_t = m->settle_t;
        c.settle_v = m->settle_v;
        c.nsettle = m->nsettle;
        c.wall[0] = p->wall_before[0] + fmu_step_seconds(m->fluid);
        c.wall[1] = p->wall_before[1] + (m->rigid != NULL ? fmu_step_seconds(m->rigid) : 0.0);
        c.wall[2] = p->wall_before[2] + omp_get_wtime() - p->wall0;
        const checkpoint_hooks_t hooks = {receive_block, copy_rows, &b};
        st = status_worst(st, checkpoint_write(m->cp_path, m->scene, &m->origin, &c, &hooks, &m->log));
    }
    if (size > 1) {
        st = agree(m, st); /* every rank knows whether the checkpoint is there */
    }
cleanup:
    free(b.buf);
    free(sizes);
    free(c.fluid_state);
    free(c.rigid_state);
    return st;
}

/* The checkpoint test (--checkpoint-test): the states saved at step n1, the
 * rows after it, compared with the rows of the run restored to n1. */
typedef struct {
    long n1;
    void *fluid_state, *rigid_state;
    double *rows; /* (n - n1 + 1) rows of nrow doubles + ns + nc ints as doubles */
    long nrows, cap;
    int replay;
    long mismatches;
} replay_t;

static status_t checkpoint_record(master_t *m, replay_t *c, long n)
{
    const int width = m->nrow + m->ns + m->nc;
    const long k = n - c->n1;
    double *r;
    if (!c->replay) {
        if (k >= c->cap) {
            c->cap = c->cap > 0 ? 2 * c->cap : 256;
            double *p = realloc(c->rows, sizeof(double) * (size_t)width * (size_t)c->cap);
            if (p == NULL) {
                return log_msg(&m->log, STATUS_FATAL, CAT, "out of memory for %ld recorded rows (%zu bytes)", c->cap, sizeof(double) * (size_t)width * (size_t)c->cap);
            }
            c->rows = p;
        }
        c->nrows = k + 1;
    }
    r = c->replay ? malloc(sizeof(double) * (size_t)width) : c->rows + (size_t)k * (size_t)width;
    if (r == NULL) {
        return log_msg(&m->log, STATUS_FATAL, CAT, "out of memory for a recorded row (%zu bytes)", sizeof(double) * (size_t)width);
    }
    memcpy(r, m->row, sizeof(double) * (size_t)m->nrow);
    for (int i = 0; i < m->ns; i++) {
        r[m->nrow + i] = m->ibody[i]; /* (the body count is a function of these) */
    }
    for (int i = 0; i < m->nc; i++) {
        r[m->nrow + m->ns + i] = m->iintact[i];
    }
    if (c->replay) {
        if (k >= c->nrows || memcmp(r, c->rows + (size_t)k * (size_t)width, sizeof(double) * (size_t)width) != 0) {
            c->mismatches++;
        }
        free(r);
    }
    return STATUS_OK;
}

int run_scene(const scene_t *scene, const run_options_t *opt, const log_t *log)
{
    master_t m;
    memset(&m, 0, sizeof m);
    m.scene = scene;
    m.opt = opt;
    m.log = *log;
    replay_t cp = {0};
    checkpoint_t restart = {0};
    output_t *out = NULL;
    int rc = 1;
    status_t st;
    const double wall0 = omp_get_wtime();
    /* SIGINT, SIGTERM: finish the step, write a checkpoint, stop (130, 143) */
    struct sigaction sa, old_int, old_term;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sa.sa_flags = SA_RESTART;
    sigemptyset(&sa.sa_mask);
    stop_signal = 0;
    sigaction(SIGINT, &sa, &old_int);
    sigaction(SIGTERM, &sa, &old_term);
    if (units_derive(scene, log, &m.un) != STATUS_OK) {
        goto done;
    }
    /* under mpirun (mpi_env.h) every rank runs this master; rank 0 writes */
    const int writer = mpi_env_rank() == 0;
    /* the blocks of the ranks, as the fluid FMU cuts the grid (its own
     * check of run.ranks says the same) */
    m.ranks = (checkpoint_ranks_t){1, {1, 1, 1}};
    if (mpi_env_size() > 1) {
        decomp_t d;
        if (decomp_layout(&d, scene, m.un.n, mpi_env_size(), mpi_env_rank(), log) != STATUS_OK) {
            goto done;
        }
        m.ranks = (checkpoint_ranks_t){d.size, {d.dims[0], d.dims[1], d.dims[2]}};
    }
    m.ns = scene_total_spheres(scene);
    m.nfree_bodies = nfree_bodies(scene);
    m.nc = m.nfree_bodies > 0 ? scene->nconnections : 0;
    const int k_lbm = opt->exchange_every > 0 ? opt->exchange_every : 1;
    /* the LBM step as the FMUs' DefaultExperiment states it (scene fluid.dt),
     * so that any master (fmpy_master.py) computes the same h */
    const double dt = scene->fluid.dt, h = k_lbm * dt;
    const long nsteps = opt->steps > 0 ? opt->steps : (long)ceil(scene->run.end_time / h - 1e-9);
    const double t_end = nsteps * h;
    checkpoint_path(opt->output, m.cp_path, sizeof m.cp_path);
    if (opt->log_calls != NULL && (m.calls = fopen(opt->log_calls, "w")) == NULL) {
        log_msg(log, STATUS_ERROR, CAT, "cannot write the FMI call log %s: %s", opt->log_calls, strerror(errno));
        goto done;
    }
    /* 0: memory and disk are there (nothing allocated or written yet) */
    {
        resources_need_t need;
        char folder[4096];
        resources_folder(opt->output, folder, sizeof folder);
        if (resources_need(scene, t_end, opt->checkpoint_every > 0.0, log, &need) != STATUS_OK ||
            resources_compare(&need, folder, STATUS_ERROR, log) > 0) {
            log_msg(log, STATUS_ERROR, CAT, "%s: not run, nothing written", scene->path);
            goto done;
        }
    }
    /* 1-3: FMUs, signals, scene, output folder; nothing written yet */
    if (load_fmus(&m) >= STATUS_ERROR) {
        goto done;
    }
    st = connect(&m, m.rigid, m.fluid, &m.to_fluid_src, &m.to_fluid_dst, &m.nto_fluid);
    if (m.rigid != NULL) {
        st = status_worst(st, connect(&m, m.fluid, m.rigid, &m.to_rigid_src, &m.to_rigid_dst, &m.nto_rigid));
    }
    if (st >= STATUS_ERROR) {
        log_msg(log, STATUS_ERROR, CAT, "the FMUs do not fit together (see above); nothing was run");
        goto done;
    }
    if ((m.xbuf = calloc((size_t)(m.nto_fluid + m.nto_rigid) + 1, sizeof(double))) == NULL) {
        log_msg(log, STATUS_FATAL, CAT, "out of memory for the exchange buffer (%zu bytes)", ((size_t)(m.nto_fluid + m.nto_rigid) + 1) * sizeof(double));
        goto done;
    }
    if (check_guid(&m, m.fluid) >= STATUS_ERROR || (m.rigid != NULL && check_guid(&m, m.rigid) >= STATUS_ERROR) ||
        plan_observation(&m) >= STATUS_ERROR || (writer && check_writable(opt->output, log) >= STATUS_ERROR)) {
        goto done;
    }
    const char *fields_rel = NULL;
    if (scene->run.fields) {
        /* OUT_fields.h5 beside OUT.h5; the output links to it by its name */
        snprintf(m.fields, sizeof m.fields, "%s", opt->output);
        char *dot = strrchr(m.fields, '.'), *slash = strrchr(m.fields, '/');
        if (dot != NULL && (slash == NULL || dot > slash)) {
            *dot = '\0';
        }
        strncat(m.fields, "_fields.h5", sizeof m.fields - strlen(m.fields) - 1);
        fields_rel = strrchr(m.fields, '/') != NULL ? strrchr(m.fields, '/') + 1 : m.fields;
        if (writer && check_writable(m.fields, log) >= STATUS_ERROR) {
            goto done;
        }
    }
    if (find_origin(&m) != STATUS_OK) {
        goto done;
    }
    if (opt->restart != NULL) {
        /* rank 0 checks that the checkpoint belongs to these ranks, this
         * scene, these FMUs and this build, and says what differs; then the
         * other ranks read their blocks */
        status_t rst = STATUS_OK;
        if (writer) {
            rst = checkpoint_read(opt->restart, scene, &m.origin, &m.ranks, 0, &restart, log);
            if (rst == STATUS_OK && (restart.exchange_every != k_lbm || restart.h != h)) {
                rst = log_msg(log, STATUS_ERROR, CAT,
                              "%s was written with --exchange-every %d (h = %.17g s); this run has --exchange-every "
                              "%d (h = %.17g s): restart with the options of the interrupted run",
                              opt->restart, restart.exchange_every, restart.h, k_lbm, h);
            } else if (rst == STATUS_OK && restart.step > nsteps) {
                rst = log_msg(log, STATUS_ERROR, CAT,
                              "%s is at communication step %ld, after the end of this run (%ld steps)", opt->restart,
                              restart.step, nsteps);
            }
        }
        if (agree(&m, rst) >= STATUS_ERROR) {
            goto done;
        }
        if (!writer) {
            rst = checkpoint_read(opt->restart, scene, &m.origin, &m.ranks, mpi_env_rank(), &restart, log);
        }
        if (agree(&m, rst) >= STATUS_ERROR) {
            goto done;
        }
    }
    if (init_fmus(&m, t_end, opt->restart != NULL) >= STATUS_ERROR) {
        log_msg(log, STATUS_ERROR, CAT, "the FMUs could not be initialised (see above); nothing was run");
        goto done;
    }
    int *pairs = calloc(2 * (size_t)m.nc + 1, sizeof(int));
    if (pairs == NULL) {
        log_msg(log, STATUS_FATAL, CAT, "out of memory for %d connection pairs (%zu bytes)", m.nc, (2 * (size_t)m.nc + 1) * sizeof(int));
        goto done;
    }
    for (int k = 0; k < m.nc; k++) {
        pairs[2 * k] = scene->connections[k].a;
        pairs[2 * k + 1] = scene->connections[k].b;
    }
    output_layout_t layout = {m.ns, m.nc, pairs, fields_rel, m.rigid != NULL, mpi_env_size()};
    units_t shown = m.un;
    shown.dt = dt; /* the time base of the run (may differ from units_derive's dt in the last bit) */
    /* a restart writes the output anew: the rows to the checkpoint from its copy */
    st = output_open(writer ? opt->output : NULL, scene, &shown, &layout, log, &out);
    if (st < STATUS_ERROR && opt->restart != NULL) {
        st = output_restore_rows(out, opt->restart, "/output", restart.rows);
    }
    free(pairs);
    if (st >= STATUS_ERROR) {
        goto done;
    }
    if (opt->restart != NULL) {
        status_t rst = deserialize(m.fluid, restart.fluid_state, restart.fluid_size);
        if (rst < STATUS_ERROR && m.rigid != NULL) {
            rst = status_worst(rst, deserialize(m.rigid, restart.rigid_state, restart.rigid_size));
        }
        if (rst >= STATUS_ERROR) {
            log_msg(log, STATUS_ERROR, CAT, "the FMU states of %s could not be restored (see above)", opt->restart);
        }
        if (agree(&m, rst) >= STATUS_ERROR) {
            goto done;
        }
        m.settle_t = restart.settle_t;
        m.settle_v = restart.settle_v;
        m.nsettle = restart.nsettle;
        restart.settle_t = restart.settle_v = NULL;
    }
    const int settle = summary_settling_sphere(scene);
    double gdir[3] = {0, 0, 0};
    if (settle >= 0) {
        const double g = hypot(hypot(scene->rigid.gravity[0], scene->rigid.gravity[1]), scene->rigid.gravity[2]);
        for (int a = 0; a < 3; a++) {
            gdir[a] = scene->rigid.gravity[a] / g;
        }
    }
    cp.n1 = opt->checkpoint_t1 > 0.0 ? (long)llround(opt->checkpoint_t1 / h) : -1;
    if (opt->checkpoint_t1 > 0.0 && (cp.n1 < 1 || cp.n1 >= nsteps)) {
        log_msg(log, STATUS_ERROR, CAT, "--checkpoint-test %g s is not inside the run (0, %g s)", opt->checkpoint_t1,
                t_end);
        goto done;
    }
    /* the loop */
    const double oi = scene->run.output_interval, ncells = (double)m.un.n[0] * m.un.n[1] * m.un.n[2];
    const int tty = !opt->quiet && isatty(fileno(stderr));
    const long n0 = restart.step;
    long next_out = restart.next_out;
    const double every = opt->checkpoint_every;
    long next_cp = every > 0.0 ? (long)floor(n0 * h / every + 1e-9 * dt / every) + 1 : 0;
    run_point_t point = {0, nsteps, 0, k_lbm, h, wall0, {restart.wall[0], restart.wall[1], restart.wall[2]}};
    double last_print = wall0;
    const double wstart = omp_get_wtime() - wall0; /* s: export, load, instantiate, initialise */
    double wout = 0.0; /* s: reading the outputs of a row (the fluid totals included) and writing rows */
    for (long n = n0;; n++) {
        const double t = n * h;
        const int last = n == nsteps;
        const int do_out = !cp.replay && (last || t >= next_out * oi - 1e-9 * dt);
        const double w_out0 = omp_get_wtime();
        if (do_out || (cp.n1 >= 0 && n >= cp.n1)) {
            if (read_row(&m) >= STATUS_ERROR) {
                goto stopped;
            }
        }
        if (do_out) {
            if (write_row(&m, out, t) != STATUS_OK) {
                goto stopped;
            }
            if (settle >= 0) {
                double *pt = realloc(m.settle_t, sizeof(double) * (size_t)(m.nsettle + 1));
                double *pv = pt != NULL ? realloc(m.settle_v, sizeof(double) * (size_t)(m.nsettle + 1)) : NULL;
                if (pt != NULL) {
                    m.settle_t = pt;
                }
                if (pv == NULL) {
                    log_msg(log, STATUS_FATAL, CAT, "out of memory for %ld rows of the settling summary (%zu bytes)", m.nsettle + 1, 2 * sizeof(double) * (size_t)(m.nsettle + 1));
                    goto stopped;
                }
                m.settle_v = pv;
                const double *v = &m.row[R_VEL * 3 * m.ns + 3 * settle];
                m.settle_t[m.nsettle] = t;
                m.settle_v[m.nsettle++] = v[0] * gdir[0] + v[1] * gdir[1] + v[2] * gdir[2];
            }
            while (next_out * oi <= t + 1e-9 * dt) {
                next_out++;
            }
        }
        wout += omp_get_wtime() - w_out0;
        if (cp.n1 >= 0 && n >= cp.n1 && checkpoint_record(&m, &cp, n) != STATUS_OK) {
            goto stopped;
        }
        if (cp.n1 >= 0 && n == cp.n1 && !cp.replay) {
            if (fmu_get_state(m.fluid, &cp.fluid_state) >= STATUS_ERROR ||
                (m.rigid != NULL && fmu_get_state(m.rigid, &cp.rigid_state) >= STATUS_ERROR)) {
                goto stopped;
            }
        }
        if (last && cp.n1 >= 0 && !cp.replay) {
            /* restore the states of t1 and run to the end again */
            if (fmu_set_state(m.fluid, cp.fluid_state) >= STATUS_ERROR ||
                (m.rigid != NULL && fmu_set_state(m.rigid, cp.rigid_state) >= STATUS_ERROR)) {
                goto stopped;
            }
            cp.replay = 1;
            n = cp.n1 - 1;
            continue;
        }
        const int cp_due = every > 0.0 && n > n0 && t >= next_cp * every - 1e-9 * dt;
        /* the signal reaches the ranks at different steps (mpirun forwards
         * it): they stop together at the first step where one has seen it */
        int stop = stop_signal;
        if (!last && mpi_env_size() > 1 && mpi_env_max(&stop, log) != STATUS_OK) {
            goto stopped;
        }
        if (!last && (cp_due || stop != 0)) {
            point.n = n;
            point.next_out = next_out;
            if (save_checkpoint(&m, out, &point) != STATUS_OK) {
                goto stopped;
            }
            while (every > 0.0 && next_cp * every <= t + 1e-9 * dt) {
                next_cp++;
            }
        }
        if (!last && stop != 0) {
            const int sig = stop;
            char launch[64] = "";
            if (mpi_env_size() > 1) {
                snprintf(launch, sizeof launch, "mpirun -np %d ", mpi_env_size());
            }
            log_msg(log, STATUS_WARNING, CAT,
                    "stopped by %s at t = %.9g s (communication step %ld of %ld); %s holds the output rows to then; "
                    "checkpoint %s: continue with `%scoupler run %s [the same --set options] --restart %s -o %s`",
                    sig == SIGINT ? "SIGINT" : "SIGTERM", t, n, nsteps, opt->output, m.cp_path, launch, scene->path,
                    m.cp_path, opt->output);
            rc = 128 + sig;
            goto done;
        }
        if (last) {
            break;
        }
        if (cosim_step(&m, t, h) >= STATUS_ERROR) {
            log_msg(log, STATUS_ERROR, CAT, "communication step %ld from t = %.9g s failed", n, t);
            goto stopped;
        }
        const double w1 = omp_get_wtime();
        if (tty && (w1 - last_print > 0.5)) {
            const double el = w1 - wall0, eta = el / (n + 1 - n0) * (nsteps - n - 1);
            fprintf(stderr, "\rstep %ld/%ld  t = %.4g s  wall %.1f s  ETA %.1f s  %.1f MLUPS   ", n + 1, nsteps,
                    t + h, el, eta, ncells * k_lbm * (n + 1 - n0) / fmax(fmu_step_seconds(m.fluid), 1e-9) / 1e6);
            last_print = w1;
        }
    }
    if (tty) {
        fprintf(stderr, "\n");
    }
    if (cp.n1 >= 0 && mpi_env_size() > 1) {
        /* the same verdict, and exit code, on every rank */
        int differ = cp.mismatches > INT_MAX ? INT_MAX : (int)cp.mismatches;
        if (mpi_env_max(&differ, log) != STATUS_OK) {
            goto stopped;
        }
        cp.mismatches = differ;
    }
    /* wall times of the whole run, the interrupted parts before a restart included */
    const double wall = restart.wall[2] + omp_get_wtime() - wall0, wf = restart.wall[0] + fmu_step_seconds(m.fluid);
    const double wr = restart.wall[1] + (m.rigid != NULL ? fmu_step_seconds(m.rigid) : 0.0);
    char jf[1024], jr[1024] = "{}";
    summary_calls_json(m.fluid, jf, sizeof jf);
    if (m.rigid != NULL) {
        summary_calls_json(m.rigid, jr, sizeof jr);
    }
    const long cf = fmu_calls_total(m.fluid), cr = m.rigid != NULL ? fmu_calls_total(m.rigid) : 0;
    const double mlups = ncells * k_lbm * (double)nsteps / fmax(wf, 1e-9) / 1e6;
    st = output_attr(out, "wall_time_fluid", wf);
    st = status_worst(st, output_attr(out, "wall_time_rigid", wr));
    st = status_worst(st, output_attr(out, "wall_time_master", wall - wf - wr));
    st = status_worst(st, output_attr(out, "wall_time_output", wout));
    st = status_worst(st, output_attr(out, "wall_time_startup", wstart));
    st = status_worst(st, output_attr(out, "wall_time_total", wall));
    st = status_worst(st, output_attr(out, "exchange_every", k_lbm));
    st = status_worst(st, output_attr(out, "communication_step", h));
    st = status_worst(st, output_attr(out, "mlups", mlups));
    st = status_worst(st, output_attr_string(out, "fmi_calls_fluid", jf));
    if (m.rigid != NULL) {
        st = status_worst(st, output_attr_string(out, "fmi_calls_rigid", jr));
    }
    if (st != STATUS_OK) {
        goto done;
    }
    printf("%s: %ld communication steps of %d LBM step%s (h = %.6g s), t = %.6g s, %d x %d x %d cells, tau %.4g\n",
           scene->path, nsteps, k_lbm, k_lbm > 1 ? "s" : "", h, t_end, m.un.n[0], m.un.n[1], m.un.n[2], m.un.tau);
    printf("  wall time %.3f s: fluid %.3f s (%.1f MLUPS), rigid %.3f s, master and output %.3f s (of it rows %.3f s)\n",
           wall, wf, mlups, wr, wall - wf - wr, wout);
    printf("  FMI calls: fluid %ld %s", cf, jf);
    if (m.rigid != NULL) {
        printf(", rigid %ld %s", cr, jr);
    } else {
        printf(" (no rigid.fmu: no free bodies)");
    }
    printf("\n");
    const double vmax = m.row[m.o_vmax];
    printf("  fluid: largest speed %.6g m/s (Mach %.3g)\n", vmax, vmax / units_velocity(&m.un) * sqrt(3.0));
    summary_bodies(scene, m.ns, m.ibody, &m.row[R_VEL * 3 * m.ns]);
    summary_settling(scene, m.settle_t, m.settle_v, m.nsettle, t_end);
    summary_poiseuille(scene, &m.un, &m.row[m.o_peak]);
    if (cp.n1 >= 0) {
        printf("  checkpoint test: state saved at t1 = %.6g s, run to %.6g s, restored, run again: %s (%ld of %ld "
               "communication points differ)\n",
               cp.n1 * h, t_end, cp.mismatches == 0 ? "bit-identical" : "DIFFERENT", cp.mismatches, cp.nrows);
        if (cp.mismatches != 0) {
            log_msg(log, STATUS_ERROR, CAT, "checkpoint test failed: the restored run differs");
            goto done;
        }
    }
    printf("  output %s%s%s\n", opt->output, m.fields[0] != '\0' ? ", fields " : "", m.fields);
    rc = 0;
    goto done;
stopped:
    log_msg(log, STATUS_ERROR, CAT, "stopped; %s holds the output rows written so far", opt->output);
done:
    if (cp.fluid_state != NULL) {
        fmu_free_state(m.fluid, &cp.fluid_state);
    }
    if (cp.rigid_state != NULL) {
        fmu_free_state(m.rigid, &cp.rigid_state);
    }
    free(cp.rows);
    checkpoint_free(&restart);
    if (output_close(out) != STATUS_OK) {
        rc = 1;
    }
    free_master(&m);
    sigaction(SIGINT, &old_int, NULL);
    sigaction(SIGTERM, &old_term, NULL);
    return rc;
}
