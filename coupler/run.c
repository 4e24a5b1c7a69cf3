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
 * step counter, never accumulated; the last step is shorter when K does not
 * divide the LBM steps to run.end_time):
 *   rigid kinematics -> fluid inputs; fluid fmi2DoStep(t, h);
 *   fluid forces/torques -> rigid inputs; rigid fmi2DoStep(t, h)
 * (the rigid sub-cycles internally, rigid.substeps). Output rows at t >=
 * k * run.output_interval and at the end. Every FMI status is checked; an
 * error stops the run with the output file holding every row written.
 * Under mpirun every rank runs this loop with its own FMUs (the fluid's
 * block of the grid, the same rigid): they take every decision alike, agree
 * once per communication step on a stop signal that some rank has seen, and
 * write each checkpoint together (run_checkpoint.c: rank 0 writes the file
 * with every rank's block, and all learn the outcome).
 *
 * This file: setup and the loop; the signals and the step are signals.c's,
 * checkpoints run_checkpoint.c's (master.h). */
#define _XOPEN_SOURCE 700 /* nftw, mkdtemp */
#include "run.h"
#include "mpi_env.h"

#include "../common/file_held.h"
#include "../common/fmi_adapter.h"
#include "../fluid/decomp.h"
#include "../fluid/units.h"
#include "checkpoint.h"
#include "export.h"
#include "fmu.h"
#include "master.h"
#include "output.h"
#include "resources.h"
#include "summary.h"

#include <errno.h>
#include <ftw.h>
#include <sys/stat.h>
#include <limits.h>
#include <math.h>
#include <omp.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>

#define CAT "run"

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

/* ------------------------------------------------------------------------ */
/* The run                                                                   */

static status_t check_writable(const char *path, const log_t *log)
{
    struct stat st;
    if (path[0] == '\0') {
        return log_msg(log, STATUS_ERROR, CAT, "the output file name is empty; allowed: a file name such as out.h5 (-o)");
    }
    if (stat(path, &st) == 0 && S_ISDIR(st.st_mode)) {
        /* HDF5 then said "cannot create the output file (does the folder exist and is it writable?)" */
        return log_msg(log, STATUS_ERROR, CAT,
                       "cannot write %s: it is a folder; nothing was written; allowed: a file (-o OUT.h5 writes "
                       "OUT.h5, OUT_fields.h5 and OUT_checkpoint.h5)",
                       path);
    }
    char dir[4096];
    resources_folder(path, dir, sizeof dir);
    if (access(dir, W_OK | X_OK) != 0) {
        return log_msg(log, STATUS_ERROR, CAT, "cannot write the output file %s: folder %s: %s", path, dir,
                       strerror(errno));
    }
    if (access(path, F_OK) == 0 && access(path, W_OK) != 0) {
        return log_msg(log, STATUS_ERROR, CAT, "cannot write the output file %s: %s", path, strerror(errno));
    }
    if (file_held(path)) { /* before any file is written (HDF5 would empty it, then fail) */
        return log_msg(log, STATUS_ERROR, CAT,
                       "%s: another process holds this file open (a viewer, or the ranks of a stopped run?); nothing "
                       "was written: close it there or choose another -o",
                       path);
    }
    return STATUS_OK;
}

/* a and b name the same file: the same inode where both exist, else the
 * same folder (resolved) and name. */
static int same_file(const char *a, const char *b)
{
    struct stat sa, sb;
    if (stat(a, &sa) == 0 && stat(b, &sb) == 0) {
        return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
    }
    char da[4096], db[4096], ra[PATH_MAX], rb[PATH_MAX];
    const char *na = strrchr(a, '/'), *nb = strrchr(b, '/');
    snprintf(da, sizeof da, "%.*s", na != NULL ? (int)(na - a) + 1 : 1, na != NULL ? a : ".");
    snprintf(db, sizeof db, "%.*s", nb != NULL ? (int)(nb - b) + 1 : 1, nb != NULL ? b : ".");
    return realpath(da, ra) != NULL && realpath(db, rb) != NULL && strcmp(ra, rb) == 0 &&
           strcmp(na != NULL ? na + 1 : a, nb != NULL ? nb + 1 : b) == 0;
}

/* No file the run writes is one it reads or another it writes (checked
 * before anything is written: `-o scene.yaml` overwrote the scene, `-o
 * cp.h5 --restart cp.h5` emptied the checkpoint it was to continue from).
 * The checkpoint beside the output may be the one a restart reads: that is
 * how a run continues. */
static status_t check_paths(const scene_t *scene, const run_options_t *opt, const master_t *m, const log_t *log)
{
    char xmf[sizeof m->fields + 4] = ""; /* OUT_fields.xmf, as h5fields names it */
    if (m->fields[0] != '\0') {
        snprintf(xmf, sizeof xmf, "%.*s.xmf", (int)(strrchr(m->fields, '.') - m->fields), m->fields);
    }
    const struct {
        const char *path, *what;
    } out[] = {{opt->output, "the output (-o)"},
               {m->cp_path, "the checkpoint beside the output"},
               {m->fields[0] != '\0' ? m->fields : NULL, "the field file beside the output"},
               {xmf[0] != '\0' ? xmf : NULL, "the field index (.xmf) beside the output"},
               {opt->log_calls, "the FMI call log (--log-fmi-calls)"}},
      in[] = {{scene->path, "the scene file"},
              {opt->restart, "the checkpoint to restart from (--restart)"},
              {opt->fluid_fmu, "the fluid FMU (--fluid-fmu)"},
              {opt->rigid_fmu, "the rigid FMU (--rigid-fmu)"}};
    const int nout = (int)(sizeof out / sizeof out[0]), nin = (int)(sizeof in / sizeof in[0]);
    for (int i = 0; i < nout; i++) {
        for (int j = 0; j < nin + i && out[i].path != NULL; j++) {
            const int earlier = j >= nin; /* another file this run writes */
            const char *path = earlier ? out[j - nin].path : in[j].path;
            const char *what = earlier ? out[j - nin].what : in[j].what;
            if (path == NULL || (i == 1 && j == 1) || !same_file(out[i].path, path)) {
                continue;
            }
            return log_msg(log, STATUS_ERROR, CAT,
                           "%s %s is also %s: the run would %s it; allowed: another -o (or file name)", out[i].what,
                           out[i].path, what, earlier ? "write two things into" : "overwrite");
        }
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

/* The serialized state of a checkpoint as an FMU state of f, before f
 * leaves initialization (its component, the grid, does not exist yet), and
 * the serialized bytes freed: a restart holds the bytes and their copy, then
 * the copy and the grid, never all three (a grid's size each). */
static status_t deserialize_early(fmu_t *f, unsigned char **bytes, size_t size, void **state)
{
    const status_t st = fmu_deserialize_state(f, *bytes, size, state);
    free(*bytes);
    *bytes = NULL;
    return st;
}

/* resume: the field file of an interrupted run is continued (output.fields_resume);
 * with a checkpoint (rs), its states are deserialized into states[0] (fluid)
 * and states[1] (rigid) for master_restore, and every rank learns whether
 * that worked on all of them before the fluid's collective initialisation
 * and at the end (a rank that failed alone would leave the others waiting). */
static status_t init_fmus(master_t *m, double t_stop, int resume, checkpoint_t *rs, void *states[2])
{
    status_t st = fmu_instantiate(m->fluid, 0.0, t_stop);
    const fmu_var_t *fields = fmu_find(m->fluid, resume ? "output.fields_resume" : "output.fields");
    if (st < STATUS_ERROR && fields != NULL && m->fields[0] != '\0') {
        st = status_worst(st, fmu_set_string(m->fluid, fields->vr, m->fields));
    }
    if (rs != NULL) {
        if (st < STATUS_ERROR) {
            st = status_worst(st, deserialize_early(m->fluid, &rs->fluid_state, rs->fluid_size, &states[0]));
        }
        st = master_agree(m, st);
    }
    if (st < STATUS_ERROR) {
        st = status_worst(st, fmu_exit_init(m->fluid));
    }
    if (st < STATUS_ERROR && m->rigid != NULL) {
        st = status_worst(st, fmu_instantiate(m->rigid, 0.0, t_stop));
        if (st < STATUS_ERROR && rs != NULL) {
            st = status_worst(st, deserialize_early(m->rigid, &rs->rigid_state, rs->rigid_size, &states[1]));
        }
        if (st < STATUS_ERROR) {
            st = status_worst(st, fmu_exit_init(m->rigid));
        }
    }
    return rs != NULL ? master_agree(m, st) : st;
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

/* The options of this run that its continuation must repeat: the FMUs and
 * --exchange-every (a restart without them is refused), --steps (without it
 * the continuation runs to run.end_time instead) and --checkpoint-every
 * (without it no further checkpoint); with_steps 0 leaves --steps out (the
 * end-of-run summary asks for a larger one). */
static void continue_options(const run_options_t *opt, int with_steps, char *buf, size_t n)
{
    size_t k = 0;
    buf[0] = '\0';
    if (opt->fluid_fmu != NULL) {
        k += (size_t)snprintf(buf + k, n - k, " --fluid-fmu %s", opt->fluid_fmu);
    }
    if (k < n && opt->rigid_fmu != NULL) {
        k += (size_t)snprintf(buf + k, n - k, " --rigid-fmu %s", opt->rigid_fmu);
    }
    if (k < n && opt->exchange_every > 1) {
        k += (size_t)snprintf(buf + k, n - k, " --exchange-every %d", opt->exchange_every);
    }
    if (k < n && with_steps && opt->steps > 0) {
        k += (size_t)snprintf(buf + k, n - k, " --steps %ld", opt->steps);
    }
    if (k < n && opt->checkpoint_every > 0.0) {
        /* the shortest text that reads back as the same double */
        char t[32];
        snprintf(t, sizeof t, "%.15g", opt->checkpoint_every);
        if (strtod(t, NULL) != opt->checkpoint_every) {
            snprintf(t, sizeof t, "%.17g", opt->checkpoint_every);
        }
        snprintf(buf + k, n - k, " --checkpoint-every %s", t);
    }
}

/* A run stopped on an error: what its output file holds, read back (rank 0
 * writes it; the others only say that the run stopped). */
static void report_kept(const char *path, const log_t *log)
{
    if (mpi_env_rank() > 0) {
        log_msg(log, STATUS_ERROR, CAT, "stopped");
        return;
    }
    double t = 0.0;
    const long rows = output_rows_readable(path, &t);
    if (rows < 0) {
        log_msg(log, STATUS_ERROR, CAT, "stopped; %s is not readable (its first rows could not be written)", path);
    } else {
        log_msg(log, STATUS_ERROR, CAT, "stopped; %s holds the %ld output rows written before (to t = %.9g s)", path,
                rows, t);
    }
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
    void *restored[2] = {NULL, NULL}; /* the checkpoint's FMU states, deserialized (init_fmus) */
    output_t *out = NULL;
    int rc = 1, failed = 0;
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
    m.nfree_bodies = scene_free_bodies(scene);
    m.nc = m.nfree_bodies > 0 ? scene->nconnections : 0;
    const int k_lbm = opt->exchange_every > 0 ? opt->exchange_every : 1;
    /* the LBM step as the FMUs' DefaultExperiment states it (scene fluid.dt),
     * so that any master (fmpy_master.py) computes the same h */
    const double dt = scene->fluid.dt, h = k_lbm * dt;
    /* the LBM steps of the run (--steps counts communication steps); when K
     * does not divide the steps to run.end_time, the last communication step
     * takes the rest (short_last LBM steps), so that the run ends at end_time */
    const long n_lbm = opt->steps > 0 ? opt->steps * (long)k_lbm : (long)ceil(scene->run.end_time / dt - 1e-9);
    const long nsteps = (n_lbm + k_lbm - 1) / k_lbm, short_last = n_lbm % k_lbm;
    const double t_end = short_last != 0 ? n_lbm * dt : nsteps * h;
    if (opt->checkpoint_every > 0.0 && opt->checkpoint_every < h * (1.0 - 1e-9)) {
        log_msg(log, STATUS_ERROR, CAT,
                "--checkpoint-every %g s is shorter than one communication step (%g s); allowed: at least %g s",
                opt->checkpoint_every, h, h);
        rc = 2; /* an option out of range: a usage error, as the other range checks of main.c */
        goto done;
    }
    checkpoint_path(opt->output, m.cp_path, sizeof m.cp_path);
    if (scene->run.fields) {
        /* OUT_fields.h5 beside OUT.h5; the output links to it by its name */
        snprintf(m.fields, sizeof m.fields, "%s", opt->output);
        char *dot = strrchr(m.fields, '.'), *slash = strrchr(m.fields, '/');
        if (dot != NULL && (slash == NULL || dot > slash)) {
            *dot = '\0';
        }
        strncat(m.fields, "_fields.h5", sizeof m.fields - strlen(m.fields) - 1);
    }
    if (check_paths(scene, opt, &m, log) != STATUS_OK) {
        goto done;
    }
    /* opened without emptying it: a run refused below leaves an old log as it was
     * (emptied before the FMUs' first call, init_fmus) */
    if (opt->log_calls != NULL && (m.calls = fopen(opt->log_calls, "a")) == NULL) {
        log_msg(log, STATUS_ERROR, CAT, "cannot write the FMI call log %s: %s", opt->log_calls, strerror(errno));
        goto done;
    }
    /* 0: memory and disk are there (nothing allocated or written yet) */
    {
        resources_need_t need;
        char folder[4096];
        resources_folder(opt->output, folder, sizeof folder);
        const status_t nst = resources_need(scene, t_end, opt->checkpoint_every > 0.0, log, &need);
        const char *replaced[3] = {opt->output, m.cp_path, m.fields};
        for (int k = 0; k < 3; k++) {
            struct stat sb;
            if (replaced[k][0] != '\0' && stat(replaced[k], &sb) == 0 && S_ISREG(sb.st_mode) &&
                (opt->restart == NULL || !same_file(replaced[k], opt->restart))) {
                /* what replacing it frees: its blocks, not its length (a
                 * sparse file of 1 GB in 16 MB of disk let a run start that
                 * then filled the disk) */
                need.replaced += (double)sb.st_blocks * 512.0;
            }
        }
        if (nst != STATUS_OK || resources_compare(&need, folder, STATUS_ERROR, log) > 0) {
            log_msg(log, STATUS_ERROR, CAT, "%s: not run, nothing written", scene->path);
            goto done;
        }
    }
    /* 1-3: FMUs, signals, scene, output folder; nothing written yet */
    if (load_fmus(&m) >= STATUS_ERROR) {
        goto done;
    }
    st = master_connect(&m, m.rigid, m.fluid, &m.to_fluid_src, &m.to_fluid_dst, &m.nto_fluid);
    if (m.rigid != NULL) {
        st = status_worst(st, master_connect(&m, m.fluid, m.rigid, &m.to_rigid_src, &m.to_rigid_dst, &m.nto_rigid));
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
        master_plan_observation(&m) >= STATUS_ERROR || (writer && check_writable(opt->output, log) >= STATUS_ERROR)) {
        goto done;
    }
    const char *fields_rel = NULL;
    if (scene->run.fields) {
        fields_rel = strrchr(m.fields, '/') != NULL ? strrchr(m.fields, '/') + 1 : m.fields;
        if (writer && check_writable(m.fields, log) >= STATUS_ERROR) {
            goto done;
        }
    }
    if (writer && opt->checkpoint_every > 0.0 && check_writable(m.cp_path, log) >= STATUS_ERROR) {
        goto done; /* found at the first checkpoint, after the output was written over */
    }
    if (master_find_origin(&m) != STATUS_OK) {
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
        if (master_agree(&m, rst) >= STATUS_ERROR) {
            goto done;
        }
        if (!writer) {
            rst = checkpoint_read(opt->restart, scene, &m.origin, &m.ranks, mpi_env_rank(), &restart, log);
        }
        if (master_agree(&m, rst) >= STATUS_ERROR) {
            goto done;
        }
    }
    /* a restart continues the field file, or a copy of the interrupted run's
     * when it writes to another output (master_restart_fields) */
    int resume_fields = 0;
    if (opt->restart != NULL && m.fields[0] != '\0') {
        status_t fst = STATUS_OK;
        if (writer) {
            fst = master_restart_fields(&m, opt->restart, &resume_fields);
        }
        if (master_agree(&m, fst) >= STATUS_ERROR) {
            goto done;
        }
        int v = resume_fields;
        if (mpi_env_max(&v, log) != STATUS_OK) {
            goto done;
        }
        resume_fields = v;
    }
    if (m.calls != NULL && ftruncate(fileno(m.calls), 0) != 0) {
        log_msg(log, STATUS_ERROR, CAT, "cannot write the FMI call log %s: %s", opt->log_calls, strerror(errno));
        goto done;
    }
    if (init_fmus(&m, t_end, resume_fields, opt->restart != NULL ? &restart : NULL, restored) >= STATUS_ERROR) {
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
    /* a run continued past the step where it ended leaves out the row it
     * wrote there only because it ended (off the output grid): its output is
     * then that of one longer run */
    const int drop_end = opt->restart != NULL && restart.end_row && nsteps > restart.step;
    if (st < STATUS_ERROR && opt->restart != NULL) {
        st = output_restore_rows(out, opt->restart, "/output", restart.rows - drop_end);
    }
    free(pairs);
    /* what the run is, from the start: a run that fails keeps it too */
    if (st < STATUS_ERROR) {
        st = status_worst(st, output_attr(out, "exchange_every", k_lbm));
        st = status_worst(st, output_attr(out, "communication_step", h));
    }
    /* rank 0 alone opens the output: the others learn whether it could (a
     * file held open by another process) instead of waiting for it in the
     * first step */
    if (master_agree(&m, st) >= STATUS_ERROR) {
        goto done;
    }
    if (opt->restart != NULL) {
        status_t rst = master_restore(m.fluid, &restored[0]);
        if (rst < STATUS_ERROR && m.rigid != NULL) {
            rst = status_worst(rst, master_restore(m.rigid, &restored[1]));
        }
        if (rst >= STATUS_ERROR) {
            log_msg(log, STATUS_ERROR, CAT, "the FMU states of %s could not be restored (see above)", opt->restart);
        }
        if (master_agree(&m, rst) >= STATUS_ERROR) {
            goto done;
        }
        m.settle_t = restart.settle_t;
        m.settle_v = restart.settle_v;
        m.nsettle = restart.nsettle;
        restart.settle_t = restart.settle_v = NULL;
        if (drop_end && m.nsettle > 0 && fabs(m.settle_t[m.nsettle - 1] - restart.step * h) < 0.5 * h) {
            m.nsettle--; /* its settling summary's entry too */
        }
        if (drop_end) {
            restart.row_at_step = 0;
        }
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
    /* an output interval shorter than a communication step: a row every
     * step (the scene check warns), counted in steps */
    const double oi = fmax(scene->run.output_interval, h), ncells = (double)m.un.n[0] * m.un.n[1] * m.un.n[2];
    const int tty = !opt->quiet && isatty(fileno(stderr));
    const long n0 = restart.step;
    long next_out = restart.next_out;
    const double every = opt->checkpoint_every;
    long next_cp = every > 0.0 ? (long)floor(n0 * h / every + 1e-9 * dt / every) + 1 : 0;
    run_point_t point = {0, nsteps, 0, k_lbm, h, wall0, {restart.wall[0], restart.wall[1], restart.wall[2]}, 0};
    double last_print = wall0;
    const double wstart = omp_get_wtime() - wall0; /* s: export, load, instantiate, initialise */
    double wout = 0.0; /* s: reading the outputs of a row (the fluid totals included) and writing rows */
    for (long n = n0;; n++) {
        const int last = n == nsteps;
        const double t = last ? t_end : n * h;
        /* the last step's row, unless a restart begins at it and its
         * checkpoint has that row already (a run cut short at a checkpoint
         * restarted with that --steps wrote the row twice) */
        const int end_row = last && !(n == n0 && restart.row_at_step);
        const int due = t >= next_out * oi - 1e-9 * dt;
        const int do_out = !cp.replay && (end_row || due);
        const double w_out0 = omp_get_wtime();
        if (do_out || (cp.n1 >= 0 && n >= cp.n1)) {
            if (master_read_row(&m) >= STATUS_ERROR) {
                goto stopped;
            }
        }
        if (do_out) {
            if (master_write_row(&m, out, t) != STATUS_OK) {
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
            next_out = scene_next_multiple(next_out, oi, t + 1e-9 * dt);
        }
        wout += omp_get_wtime() - w_out0;
        if (cp.n1 >= 0 && n >= cp.n1 && master_checkpoint_record(&m, &cp, n) != STATUS_OK) {
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
        /* and one at the last step, so that a run that ended can be
         * continued with a larger --steps (not in --checkpoint-test's runs,
         * and not when this run began at its last step: that checkpoint is
         * the one it read) */
        const int cp_end = last && every > 0.0 && n > n0 && cp.n1 < 0 && short_last == 0;
        if ((!last && (cp_due || stop != 0)) || cp_end) {
            point.n = n;
            point.next_out = next_out;
            point.end_row = last && end_row && !due;
            if (master_save_checkpoint(&m, out, &point) != STATUS_OK) {
                goto stopped;
            }
            if (every > 0.0) {
                next_cp = scene_next_multiple(next_cp, every, t + 1e-9 * dt);
            }
        }
        if (!last && stop != 0) {
            const int sig = stop;
            char launch[64] = "";
            if (mpi_env_size() > 1) {
                snprintf(launch, sizeof launch, "mpirun -np %d ", mpi_env_size());
            }
            char more[3 * 4096 + 128];
            continue_options(opt, 1, more, sizeof more);
            log_msg(log, STATUS_WARNING, CAT,
                    "stopped by %s at t = %.9g s (communication step %ld of %ld); %s holds the output rows to then; "
                    "checkpoint %s: continue with `%scoupler run %s [the same --set options]%s --restart %s -o %s`",
                    sig == SIGINT ? "SIGINT" : "SIGTERM", t, n, nsteps, opt->output, m.cp_path, launch, scene->path,
                    more, m.cp_path, opt->output);
            rc = 128 + sig;
            goto done;
        }
        if (last) {
            break;
        }
        if (master_step(&m, t, short_last != 0 && n + 1 == nsteps ? t_end - t : h) >= STATUS_ERROR) {
            log_msg(log, STATUS_ERROR, CAT, "communication step %ld from t = %.9g s failed", n, t);
            goto stopped;
        }
        const double w1 = omp_get_wtime();
        if (tty && (w1 - last_print > 0.5)) {
            const double el = w1 - wall0, eta = el / (n + 1 - n0) * (nsteps - n - 1);
            fprintf(stderr, "\rstep %ld/%ld  t = %.4g s  wall %.1f s  ETA %.1f s  %.1f MLUPS   ", n + 1, nsteps,
                    n + 1 == nsteps ? t_end : t + h, el, eta, ncells * k_lbm * (n + 1 - n0) / fmax(fmu_step_seconds(m.fluid), 1e-9) / 1e6);
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
    /* the peak resident set of the process (Linux: kilobytes), the largest over the ranks */
    struct rusage ru;
    long rss_kb = getrusage(RUSAGE_SELF, &ru) == 0 ? ru.ru_maxrss : 0;
    if (mpi_env_size() > 1) {
        int kb = rss_kb > INT_MAX ? INT_MAX : (int)rss_kb;
        if (mpi_env_max(&kb, log) != STATUS_OK) {
            goto stopped;
        }
        rss_kb = kb;
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
    const double mlups = ncells * (double)n_lbm / fmax(wf, 1e-9) / 1e6;
    if (opt->times != NULL) {
        *opt->times = (run_times_t){wf, wr, wall - wf - wr, wstart, wout, wall};
    }
    st = output_attr(out, "wall_time_fluid", wf);
    st = status_worst(st, output_attr(out, "wall_time_rigid", wr));
    st = status_worst(st, output_attr(out, "wall_time_master", wall - wf - wr));
    st = status_worst(st, output_attr(out, "wall_time_output", wout));
    st = status_worst(st, output_attr(out, "wall_time_startup", wstart));
    st = status_worst(st, output_attr(out, "wall_time_total", wall));
    st = status_worst(st, output_attr(out, "mlups", mlups));
    st = status_worst(st, output_attr(out, "peak_rss_bytes", 1024.0 * (double)rss_kb));
    st = status_worst(st, output_attr_string(out, "fmi_calls_fluid", jf));
    if (m.rigid != NULL) {
        st = status_worst(st, output_attr_string(out, "fmi_calls_rigid", jr));
    }
    if (st != STATUS_OK) {
        goto done;
    }
    char last_of[64] = "";
    if (short_last != 0) {
        snprintf(last_of, sizeof last_of, ", the last of %ld", short_last);
    }
    printf("%s: %ld communication steps of %d LBM step%s%s (h = %.6g s), t = %.6g s, %d x %d x %d cells, tau %.4g\n",
           scene->path, nsteps, k_lbm, k_lbm > 1 ? "s" : "", last_of, h, t_end, m.un.n[0], m.un.n[1], m.un.n[2],
           m.un.tau);
    printf("  wall time %.3f s: fluid %.3f s (%.1f MLUPS), rigid %.3f s, master and output %.3f s (of it rows %.3f s)\n",
           wall, wf, mlups, wr, wall - wf - wr, wout);
    printf("  FMI calls: fluid %ld %s", cf, jf);
    if (m.rigid != NULL) {
        printf(", rigid %ld %s", cr, jr);
    } else {
        printf(" (no rigid.fmu: no free bodies)");
    }
    printf("\n");
    printf("  memory: peak resident set %.1f MB%s\n", 1024.0 * (double)rss_kb / 1e6,
           mpi_env_size() > 1 ? " (the largest rank)" : "");
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
    if (opt->checkpoint_every > 0.0 && nsteps > restart.step && cp.n1 < 0 && short_last == 0) {
        char more[3 * 4096 + 128];
        continue_options(opt, 0, more, sizeof more);
        printf("  checkpoint %s at the last step (%ld): to go on, `coupler run %s [the same --set options]%s --restart "
               "%s -o %s --steps N` with N > %ld\n",
               m.cp_path, nsteps, scene->path, more, m.cp_path, opt->output, nsteps);
    }
    rc = 0;
    goto done;
stopped:
    failed = 1;
done:
    if (restored[0] != NULL) { /* a restart stopped before its states were restored */
        fmu_free_state(m.fluid, &restored[0]);
    }
    if (restored[1] != NULL) {
        fmu_free_state(m.rigid, &restored[1]);
    }
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
    if (failed) {
        report_kept(opt->output, log);
    }
    free_master(&m);
    sigaction(SIGINT, &old_int, NULL);
    sigaction(SIGTERM, &old_term, NULL);
    return rc;
}
