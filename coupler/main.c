/* main.c — the `coupler` command line (DESIGN section 3).
 *
 *   coupler run   SCENE.yaml [-o OUT.h5] [--set KEY=VALUE]... [--steps N] [--quiet]
 *                 [--exchange-every K] [--log-fmi-calls FILE] [--fluid-fmu F] [--rigid-fmu F]
 *                 [--checkpoint-every T] [--restart CHECKPOINT]
 *   coupler check SCENE.yaml [--set KEY=VALUE]... [--ranks N]
 *   coupler bench [--size N]... [--json]
 *   coupler bench --coupled SCENE.yaml [--steps N] [--json]
 *   coupler export SCENE.yaml -d DIR [--set KEY=VALUE]...
 *
 * Only this file decides exit codes: 0 success, 1 a failed run or invalid
 * scene, 2 a usage error, 130 / 143 a run stopped by SIGINT / SIGTERM after
 * writing its checkpoint. Messages go to stderr through the log sink. */
#include "../common/coupling.h"
#include "../common/scene.h"
#include "../fluid/units.h"
#include "bench.h"
#include "check_ranks.h"
#include "mpi_env.h"
#include "export.h"
#include "resources.h"
#include "run.h"

#include <errno.h>
#include <hdf5.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define MAX_SETS 256
#define MAX_SIZES 16

static int usage(const char *msg)
{
    if (msg != NULL) {
        fprintf(stderr, "coupler: %s\n", msg);
    }
    fprintf(stderr, "usage:\n"
                    "  coupler run   SCENE.yaml [-o OUT.h5] [--set KEY=VALUE]... [--steps N] [--quiet]\n"
                    "                [--exchange-every K] [--log-fmi-calls FILE] [--fluid-fmu F] [--rigid-fmu F]\n"
                    "                [--checkpoint-every T] [--restart CHECKPOINT]\n"
                    "  coupler check SCENE.yaml [--set KEY=VALUE]... [--ranks N]\n"
                    "  coupler bench [--size N]... [--json]\n"
                    "  coupler bench --coupled SCENE.yaml [--steps N] [--json]\n"
                    "  coupler export SCENE.yaml -d DIR [--set KEY=VALUE]...\n");
    return 2;
}

static int parse_seconds(const char *opt, const char *s, double *out)
{
    char *end;
    errno = 0;
    const double v = strtod(s, &end);
    if (errno != 0 || end == s || *end != '\0' || !(v > 0.0) || !isfinite(v)) {
        fprintf(stderr, "coupler: %s takes a simulated time > 0 in s, got '%s'\n", opt, s);
        return 0;
    }
    *out = v;
    return 1;
}

static int parse_long(const char *opt, const char *s, long lo, long hi, long *out)
{
    char *end;
    errno = 0;
    const long v = strtol(s, &end, 10);
    if (errno != 0 || end == s || *end != '\0' || v < lo || v > hi) {
        fprintf(stderr, "coupler: %s takes a whole number from %ld to %ld, got '%s'\n", opt, lo, hi, s);
        return 0;
    }
    *out = v;
    return 1;
}

/* An option given twice, such as -o A -o B: which one was meant? Refused
 * rather than the last one taken silently (--set and --size repeat). */
static int repeated(const char *cmd, const char *opt, const char **seen, int *nseen, int cap)
{
    for (int k = 0; k < *nseen; k++) {
        if (strcmp(seen[k], opt) == 0) {
            fprintf(stderr, "coupler %s: option '%s' given twice; give it once\n", cmd, opt);
            return 1;
        }
    }
    if (*nseen < cap) {
        seen[(*nseen)++] = opt;
    }
    return 0;
}

/* Default output: the scene's file name with .h5 in the current folder. */
static void default_output(const char *scene, char *buf, size_t n)
{
    const char *base = strrchr(scene, '/') ? strrchr(scene, '/') + 1 : scene;
    snprintf(buf, n, "%s", base);
    char *dot = strrchr(buf, '.');
    if (dot != NULL) {
        *dot = '\0';
    }
    strncat(buf, ".h5", n - strlen(buf) - 1);
}

/* The sink of the CLI: rank 0's or the others', counting the warnings
 * (`check` prints their number, the scene reader's included). */
typedef struct {
    log_fn_t fn;
    int warnings;
} counted_t;

static void log_counted(void *ctx, status_t level, const char *category, const char *msg)
{
    counted_t *c = ctx;
    c->warnings += level == STATUS_WARNING;
    c->fn(NULL, level, category, msg);
}

/* The dt and tau lines of `check`: dt in whole nanoseconds (what masters that
 * count time in integer ns, libcosim/OSP, need; common/scene.h) and the tau
 * used against the one requested; a warning when dt is not whole ns. */
static void check_step_ns(const scene_t *s, const units_t *u, const log_t *log)
{
    const scene_fluid_t *f = &s->fluid;
    long long ns;
    const int whole = scene_whole_ns(f->dt, &ns);
    if (whole) {
        printf("  dt                 %.6g s = %lld ns (a whole number of ns)\n", u->dt, ns);
    } else {
        printf("  dt                 %.6g s = %.12g ns (not a whole number of ns)\n", u->dt, f->dt * 1e9);
    }
    printf("  tau                %.6g (%s)\n", u->tau,
           f->collision == COLLISION_TRT ? "TRT" : f->collision == COLLISION_REGULARIZED ? "regularized BGK" : "BGK");
    if (f->tau_requested > 0.0 && f->tau != f->tau_requested) {
        printf("  tau requested      %.9g (used %.9g, relative change %+.3g: dt rounded to whole ns)\n",
               f->tau_requested, f->tau, (f->tau - f->tau_requested) / f->tau_requested);
    } else if (f->tau_requested > 0.0) {
        printf("  tau requested      %.9g (used as given)\n", f->tau_requested);
    }
    if (whole) {
        return;
    }
    if (f->tau_requested > 0.0) {
        log_msg(log, STATUS_WARNING, "step",
                "%s: fluid.tau = %g gives dt = %.6g s = %.4g ns; rounding it to a whole number of ns would move "
                "tau - 1/2 by more than %g, so dt is kept exact: masters that count time in integer "
                "nanoseconds (libcosim/OSP) cannot step these FMUs. To run them there, give fluid.dt as a "
                "whole number of ns instead of fluid.tau (e.g. fluid.dt = %.0fe-9), or a coarser fluid.dx or a "
                "larger fluid.tau (dt >= 50 ns is always rounded)",
                s->path, f->tau_requested, f->dt, f->dt * 1e9, SCENE_DT_ROUND_MAX, fmax(1.0, nearbyint(f->dt * 1e9)));
    } else {
        log_msg(log, STATUS_WARNING, "step",
                "%s: fluid.dt = %.12g s is not a whole number of nanoseconds (%.12g ns): masters that count time in "
                "integer ns (libcosim/OSP) cannot step these FMUs; allowed there: a whole number, e.g. fluid.dt = "
                "%.0fe-9",
                s->path, f->dt, f->dt * 1e9, fmax(1.0, nearbyint(f->dt * 1e9)));
    }
}

/* `world` > 0: the blocks of that many MPI ranks too (check_ranks.h); MPI
 * is started for it here when mpirun did not start it. */
static int cmd_check(const scene_t *s, int world, const log_t *log)
{
    units_t u;
    if (units_derive(s, log, &u) != STATUS_OK) {
        return 1;
    }
    units_assessment_t a;
    units_assess(s, &u, log, &a);
    printf("%s\n", s->path);
    printf("  grid               %d x %d x %d cells (%.4g M)\n", u.n[0], u.n[1], u.n[2],
           (double)u.n[0] * u.n[1] * u.n[2] / 1e6);
    printf("  dx                 %.6g m\n", u.dx);
    check_step_ns(s, &u, log);
    if (s->fluid.collision == COLLISION_TRT) {
        printf("  magic parameter    %.6g (omega- = %.6g)\n", s->fluid.magic, u.omega_minus);
    }
    printf("  lattice viscosity  %.6g\n", u.nu_lat);
    printf("  body force         %.6g %.6g %.6g (lattice)\n", u.force_lat[0], u.force_lat[1], u.force_lat[2]);
    printf("  largest velocity   %.6g m/s (%s)\n", a.u_max, a.u_source);
    printf("  Mach               %.4g\n", a.mach);
    printf("  Reynolds           %.4g (length %.4g m: %s)\n", a.reynolds, a.length, a.length_source);
    if (a.radius_cells > 0.0) {
        printf("  sphere radius      %.4g cells (smallest)\n", a.radius_cells);
    }
    for (int b = 0; b < s->nbodies; b++) {
        char line[512];
        coupling_describe(s, b, line, sizeof line);
        printf("  %-18s %s\n", b == 0 ? "coupling" : "", line);
        const body_coupling_t c = coupling_of_body(s, b);
        if (c.coupling == COUPLING_EXPLICIT && c.kappa >= COUPLING_AUTO_KAPPA) {
            log_msg(log, STATUS_WARNING, "coupling",
                    "%s: body %d: explicit coupling (rigid.coupling: explicit) with kappa = %.3g >= %g risks the "
                    "period-2 (added-mass) instability, seen from kappa ~ 0.3; rigid.coupling: auto (the default) "
                    "would couple it implicitly with force averaging",
                    s->path, b, c.kappa, COUPLING_AUTO_KAPPA);
        }
    }
    for (int b = 0; b < s->nbodies; b++) {
        const scene_body_t *body = &s->bodies[b];
        if (body->move_with_flow) {
            printf("  %-18s body %d: velocity (%.6g, %.6g, %.6g) m/s, angular velocity (%.6g, %.6g, %.6g) rad/s "
                   "(move_with_flow)\n",
                   "starts with flow", b, body->velocity[0], body->velocity[1], body->velocity[2],
                   body->angular_velocity[0], body->angular_velocity[1], body->angular_velocity[2]);
        }
    }
    if (s->rigid.release_time > 0) {
        printf("  release time       %.6g s: free bodies held until then (%.4g steps)\n", s->rigid.release_time,
               s->rigid.release_time / u.dt);
    }
    printf("  steps              %ld to t = %.6g s\n", a.steps, s->run.end_time);
    const double interior = (double)u.n[0] * u.n[1] * u.n[2];
    const char *layout = s->fluid.streaming == STREAMING_TWO_ARRAY ? "two_array"
                         : s->fluid.streaming == STREAMING_MOMENTS ? "moments"
                                                                   : "in_place";
    printf("  memory             %.4g MB (fluid.streaming %s: %.1f bytes per allocated cell, %.1f per interior cell "
           "with the ghost layers%s)\n",
           a.bytes / 1e6, layout, units_bytes_per_cell(s), a.bytes / interior,
           s->fluid.streaming == STREAMING_MOMENTS ? ", the side store of 19 doubles per ghost cell and per cell "
                                                     "inside a sphere, and the kernel's plane copies"
                                                   : "");
    resources_need_t need, with_cp;
    if (resources_need(s, (double)a.steps * u.dt, 0, log, &need) == STATUS_OK &&
        resources_need(s, (double)a.steps * u.dt, 1, log, &with_cp) == STATUS_OK) {
        /* a checkpoint as a run with --checkpoint-every counts it (the
         * moments layout's side store included) */
        printf("  run needs          %.4g MB of memory; %.4g MB on disk (output %.4g MB, field snapshots %.4g MB), "
               "a checkpoint %.4g MB more\n",
               need.memory / 1e6, need.disk / 1e6, need.output / 1e6, need.fields / 1e6, with_cp.checkpoint / 1e6);
        /* the default output goes to the current folder */
        resources_compare(&need, ".", STATUS_WARNING, log);
    }
    if (world > 0) {
        /* MPI_Dims_create needs MPI, without other ranks */
        if (world > 1 && mpi_env_init_alone() != 0) {
            return 1;
        }
        if (check_ranks(s, u.n, world, log) >= STATUS_ERROR) {
            return 1;
        }
    }
    /* every warning, the scene reader's and those above (each one logged) */
    printf("  warnings           %d\n", ((const counted_t *)log->ctx)->warnings);
    return 0;
}

/* The FMU libraries live in build/fmu beside the coupler executable. */
static void fmu_lib_dir(char *buf, size_t n)
{
    ssize_t len = readlink("/proc/self/exe", buf, n - 1);
    if (len <= 0 || (size_t)len >= n - 1) {
        snprintf(buf, n, "build");
    } else {
        buf[len] = '\0';
        char *slash = strrchr(buf, '/');
        if (slash != NULL) {
            *slash = '\0';
        }
    }
    strncat(buf, "/fmu", n - strlen(buf) - 1);
}

/* On ranks other than 0 only errors are printed, with their rank: rank 0
 * prints everything that all ranks say alike. */
static void log_rank(void *ctx, status_t level, const char *category, const char *msg)
{
    if (level >= STATUS_ERROR) {
        fprintf(stderr, "[rank %d] ", mpi_env_rank());
        log_stderr(ctx, level, category, msg);
    }
}

static int run_main(int argc, char **argv);

int main(int argc, char **argv)
{
    /* Every file is closed by its writer before main returns. HDF5's own
     * handler at exit closes again what is left, and HDF5 1.10 segfaults
     * there on a file whose close failed (a disk full before the output's
     * first rows could be written: exit 139 instead of the run's 1). */
    H5dont_atexit();
    if (mpi_env_init(&argc, &argv) != 0) {
        return 1;
    }
    if (mpi_env_rank() > 0 && freopen("/dev/null", "w", stdout) == NULL) {
        fprintf(stderr, "[rank %d] cannot silence the summary of this rank\n", mpi_env_rank());
    }
    return mpi_env_finish(run_main(argc, argv));
}

static int run_main(int argc, char **argv)
{
    if (argc < 2) {
        return usage(NULL);
    }
    const char *cmd = argv[1];
    counted_t counted = {mpi_env_rank() == 0 ? log_stderr : log_rank, 0};
    log_t log = {log_counted, &counted};
    if (strcmp(cmd, "-h") == 0 || strcmp(cmd, "--help") == 0) {
        usage(NULL);
        return 0;
    }
    if (strcmp(cmd, "bench") == 0) {
        int sizes[MAX_SIZES], nsizes = 0, json = 0;
        const char *coupled = NULL;
        long csteps = 200;
        const char *seen[8];
        int nseen = 0;
        for (int i = 2; i < argc; i++) {
            long v;
            if (strcmp(argv[i], "--size") != 0 && repeated(cmd, argv[i], seen, &nseen, 8)) {
                return usage(NULL);
            }
            if (strcmp(argv[i], "--json") == 0) {
                json = 1;
            } else if (strcmp(argv[i], "--coupled") == 0 && i + 1 < argc) {
                coupled = argv[++i];
            } else if (strcmp(argv[i], "--steps") == 0 && i + 1 < argc) {
                if (!parse_long("--steps", argv[++i], 1, 100000000, &csteps)) {
                    return 2;
                }
            } else if (strcmp(argv[i], "--size") == 0 && i + 1 < argc) {
                if (!parse_long("--size", argv[++i], 8, 1024, &v)) {
                    return 2;
                }
                if (nsizes == MAX_SIZES) {
                    return usage("at most 16 --size options");
                }
                sizes[nsizes++] = (int)v;
            } else {
                fprintf(stderr, "coupler bench: unknown or incomplete option '%s'\n", argv[i]);
                return usage(NULL);
            }
        }
        if (coupled != NULL) {
            char lib_dir[4096];
            fmu_lib_dir(lib_dir, sizeof lib_dir);
            return bench_coupled(coupled, csteps, lib_dir, json);
        }
        return bench_main(sizes, nsizes, json);
    }
    if (strcmp(cmd, "run") != 0 && strcmp(cmd, "check") != 0 && strcmp(cmd, "export") != 0) {
        fprintf(stderr, "coupler: unknown command '%s'\n", cmd);
        return usage(NULL);
    }
    if (strcmp(cmd, "check") == 0 && mpi_env_rank() > 0) {
        /* every rank checks the same scene alike: rank 0 says it once */
        log.fn = NULL;
    }
    const char *scene_path = NULL, *output = NULL, *export_dir = NULL;
    const char *log_calls = NULL, *fluid_fmu = NULL, *rigid_fmu = NULL, *restart = NULL;
    const char *sets[MAX_SETS];
    int nsets = 0, quiet = 0;
    long steps = 0, every = 1, ranks = 0;
    double checkpoint = 0.0, checkpoint_every = 0.0;
    const char *seen[32];
    int nseen = 0;
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i];
        const int has_value = i + 1 < argc;
        if (a[0] == '-' && strcmp(a, "--set") != 0 && repeated(cmd, a, seen, &nseen, 32)) {
            return usage(NULL);
        }
        if (strcmp(a, "--set") == 0 && has_value) {
            if (nsets == MAX_SETS) {
                return usage("at most 256 --set options");
            }
            sets[nsets++] = argv[++i];
        } else if (strcmp(cmd, "run") == 0 && strcmp(a, "-o") == 0 && has_value) {
            output = argv[++i];
        } else if (strcmp(cmd, "run") == 0 && strcmp(a, "--steps") == 0 && has_value) {
            if (!parse_long("--steps", argv[++i], 0, LONG_MAX / 2, &steps)) {
                return 2;
            }
        } else if (strcmp(cmd, "run") == 0 && strcmp(a, "--exchange-every") == 0 && has_value) {
            if (!parse_long("--exchange-every", argv[++i], 1, 1000000, &every)) {
                return 2;
            }
        } else if (strcmp(cmd, "run") == 0 && strcmp(a, "--log-fmi-calls") == 0 && has_value) {
            log_calls = argv[++i];
        } else if (strcmp(cmd, "run") == 0 && strcmp(a, "--fluid-fmu") == 0 && has_value) {
            fluid_fmu = argv[++i];
        } else if (strcmp(cmd, "run") == 0 && strcmp(a, "--rigid-fmu") == 0 && has_value) {
            rigid_fmu = argv[++i];
        } else if (strcmp(cmd, "run") == 0 && strcmp(a, "--checkpoint-test") == 0 && has_value) {
            /* hidden: save the FMU states at T1, run, restore, run again, compare */
            if (!parse_seconds("--checkpoint-test", argv[++i], &checkpoint)) {
                return 2;
            }
        } else if (strcmp(cmd, "run") == 0 && strcmp(a, "--checkpoint-every") == 0 && has_value) {
            if (!parse_seconds("--checkpoint-every", argv[++i], &checkpoint_every)) {
                return 2;
            }
        } else if (strcmp(cmd, "run") == 0 && strcmp(a, "--restart") == 0 && has_value) {
            restart = argv[++i];
        } else if (strcmp(cmd, "check") == 0 && strcmp(a, "--ranks") == 0 && has_value) {
            if (!parse_long("--ranks", argv[++i], 1, 65536, &ranks)) {
                return 2;
            }
        } else if (strcmp(cmd, "export") == 0 && strcmp(a, "-d") == 0 && has_value) {
            export_dir = argv[++i];
        } else if (strcmp(cmd, "run") == 0 && strcmp(a, "--quiet") == 0) {
            quiet = 1;
        } else if (a[0] == '-' || scene_path != NULL) {
            fprintf(stderr, "coupler %s: unknown, incomplete or extra argument '%s'\n", cmd, a);
            return usage(NULL);
        } else {
            scene_path = a;
        }
    }
    if (scene_path == NULL) {
        return usage("a scene file is required");
    }
    if (restart != NULL && checkpoint > 0.0) {
        return usage("--restart and --checkpoint-test do not go together");
    }
    if (strcmp(cmd, "export") == 0 && export_dir == NULL) {
        return usage("export needs -d DIR, the folder for fluid.fmu and rigid.fmu");
    }
    for (int k = 0; k < nsets; k++) {
        if (strchr(sets[k], '=') == NULL) {
            fprintf(stderr, "coupler: --set takes KEY=VALUE, got '%s'\n", sets[k]);
            return 2;
        }
    }
    scene_t *scene = NULL;
    if (scene_load(scene_path, sets, nsets, &log, &scene) != STATUS_OK) {
        return 1;
    }
    int rc;
    if (strcmp(cmd, "check") == 0) {
        /* under mpirun without --ranks: the blocks of the ranks started */
        rc = cmd_check(scene, ranks > 0 ? (int)ranks : mpi_env_size() > 1 ? mpi_env_size() : 0, &log);
    } else if (strcmp(cmd, "export") == 0) {
        char lib_dir[4096];
        fmu_lib_dir(lib_dir, sizeof lib_dir);
        rc = export_fmus(scene, export_dir, lib_dir, 1, &log);
    } else {
        char buf[4096];
        if (output == NULL) {
            default_output(scene_path, buf, sizeof buf);
            output = buf;
        }
        char lib_dir[4096];
        fmu_lib_dir(lib_dir, sizeof lib_dir);
        run_options_t opt = {output,    steps,     quiet,   (int)every, log_calls,       fluid_fmu,
                             rigid_fmu, lib_dir,   checkpoint, checkpoint_every, restart, NULL};
        rc = run_scene(scene, &opt, &log);
    }
    scene_free(scene);
    return rc;
}
