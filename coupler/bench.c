/* bench.c — measures, in one run, the machine's memory bandwidth and the
 * fluid step's speed, and relates them.
 *
 * Bandwidth: a copy b[i] = a[i] over arrays far larger than the caches, with
 * non-temporal stores (no read-for-ownership), so each element costs one
 * 8-byte read and one 8-byte write of DRAM traffic; one copy before each
 * repeat of the fluid, and each row relates the best rate to the best copy
 * of its own repeats.
 * Fluid: a periodic cube, the whole step (boundary stage + fused kernel),
 * for both streaming layouts (fluid/layout.h). A D3Q19 step must move at
 * least 19 loads + 19 stores of a double per cell, 304 bytes, in either
 * layout (two arrays: the stores are non-temporal, no read-for-ownership;
 * in place: the stores go to lines just read), so the bandwidth limit is
 * B / 304 cell updates per second (B / 152 in single precision); the ratio
 * printed is MLUPS / that limit. The moments layout (double only, with its
 * regularized collision) moves 10 doubles each way and a 4-byte index:
 * B / 164.
 * Memory: bytes of the fluid component per interior cell, everything
 * included (fluid_memory_bytes). */
#include "bench.h"

#include "../common/big_alloc.h"
#include "../common/scene.h"
#include "../fluid/fluid.h"
#include "../fluid/lattice.h"
#include "../fluid/layout.h"
#include "run.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#if defined(__SSE2__)
#include <immintrin.h>
#endif


/* The copy arrays: far larger than the caches (512 MiB each). */
typedef struct {
    double *a, *b;
    size_t n;
} copy_arrays_t;

static int copy_alloc(copy_arrays_t *c)
{
    c->n = (size_t)1 << 26;
    /* on the same pages as the fluid's populations (common/big_alloc.h), so
     * that the limit and the kernel are measured alike */
    c->a = big_alloc(c->n * sizeof(double));
    c->b = big_alloc(c->n * sizeof(double));
    if (c->a == NULL || c->b == NULL) {
        free(c->a);
        free(c->b);
        return 0;
    }
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < c->n; i++) {
        c->a[i] = (double)i;
        c->b[i] = 0.0;
    }
    return 1;
}

/* One copy with the current number of threads: its bandwidth in GB/s. */
static double copy_once(const copy_arrays_t *c)
{
    double *restrict b = c->b;
    const double *restrict a = c->a;
    const size_t n = c->n;
    const double t0 = omp_get_wtime();
#pragma omp parallel
    {
#pragma omp for schedule(static) nowait
        for (size_t i = 0; i < n; i += 8) {
#if defined(__AVX__)
            _mm256_stream_pd(b + i, _mm256_load_pd(a + i));
            _mm256_stream_pd(b + i + 4, _mm256_load_pd(a + i + 4));
#elif defined(__SSE2__)
            for (int k = 0; k < 8; k += 2) {
                _mm_stream_pd(b + i + k, _mm_load_pd(a + i + k));
            }
#else
            for (int k = 0; k < 8; k++) {
                b[i + k] = a[i + k];
            }
#endif
        }
#if defined(__SSE2__)
        _mm_sfence();
#endif
    }
    const double dt = omp_get_wtime() - t0;
    volatile double sink = b[n / 2];
    (void)sink;
    return 2.0 * (double)n * sizeof(double) / dt / 1e9;
}

/* Best of several copies with this many threads (the first one warms up). */
static double stream_bandwidth(const copy_arrays_t *c, int threads)
{
    omp_set_num_threads(threads);
    double best = 0.0;
    for (int rep = 0; rep < 6; rep++) {
        const double gbs = copy_once(c);
        if (rep > 0 && gbs > best) {
            best = gbs;
        }
    }
    return best;
}

/* The fluid's best rate, with a copy before each repeat: *bw the best copy
 * among them, so that the limit comes from the same minutes as the rate
 * (this VM's bandwidth moves by 20% from one minute to the next). */
static double fluid_mlups(int size, int threads, streaming_t streaming, precision_t precision,
                          const copy_arrays_t *copy, double *bw, double *bytes_per_cell)
{
    omp_set_num_threads(threads);
    scene_t s;
    memset(&s, 0, sizeof s);
    s.path = "bench";
    for (int a = 0; a < 3; a++) {
        s.domain.size[a] = size;
        s.domain.faces[2 * a].type = s.domain.faces[2 * a + 1].type = FACE_PERIODIC;
    }
    s.fluid.density = 1.0;
    s.fluid.dx = 1.0;
    s.fluid.tau = 0.8;
    s.fluid.viscosity = 0.1;
    s.fluid.collision = streaming == STREAMING_MOMENTS ? COLLISION_REGULARIZED : COLLISION_TRT;
    s.fluid.magic = 3.0 / 16.0;
    s.fluid.initial_velocity[0] = 0.01;
    s.fluid.body_force[2] = 1e-7;
    s.fluid.streaming = streaming;
    s.fluid.precision = precision;
    log_t log = {log_stderr, NULL};
    fluid_t *fl = NULL;
    if (fluid_create(&s, &log, &fl) != STATUS_OK) {
        return 0.0;
    }
    for (int i = 0; i < 3; i++) {
        fluid_step(fl);
    }
    const double cells = (double)size * size * size;
    *bytes_per_cell = (double)fluid_memory_bytes(fl) / cells;
    double best = 0.0, total = 0.0;
    (void)copy_once(copy); /* a warm-up, as stream_bandwidth's first */
    *bw = 0.0;
    for (int rep = 0; rep < 5 || total < 2.0; rep++) {
        *bw = fmax(*bw, copy_once(copy));
        const int steps = (int)fmax(1.0, 2e7 / cells);
        const double t0 = omp_get_wtime();
        for (int i = 0; i < steps; i++) {
            fluid_step(fl);
        }
        const double dt = omp_get_wtime() - t0;
        total += dt;
        best = fmax(best, cells * steps / dt / 1e6);
        if (rep > 20) {
            break;
        }
    }
    fluid_free(fl);
    return best;
}

int bench_main(const int *sizes, int nsizes, int json)
{
    static const int default_size = 128;
    if (nsizes == 0) {
        sizes = &default_size;
        nsizes = 1;
    }
    const int maxthreads = omp_get_max_threads();
    int tcounts[2] = {1, maxthreads};
    const int ntc = maxthreads > 1 ? 2 : 1;
    copy_arrays_t copy;
    if (!copy_alloc(&copy)) {
        fprintf(stderr, "coupler bench: out of memory for the copy arrays (1 GiB)\n");
        return 1;
    }
    for (int t = 0; t < ntc; t++) {
        const double bw = stream_bandwidth(&copy, tcounts[t]);
        if (!json) {
            printf("memory bandwidth, %d thread%s (copy, non-temporal stores): %.2f GB/s at the start; each row's "
                   "limit comes from copies between its repeats\n",
                   tcounts[t], tcounts[t] > 1 ? "s" : "", bw);
        }
    }
    if (!json) {
        printf("%6s %7s %9s %9s %8s %10s %12s %7s %10s\n", "size", "threads", "precision", "streaming", "MLUPS",
               "BW GB/s", "limit MLUPS", "ratio", "bytes/cell");
    }
    static const streaming_t layouts[] = {STREAMING_IN_PLACE, STREAMING_TWO_ARRAY, STREAMING_MOMENTS};
    static const char *const names[] = {"in_place", "two_array", "moments"};
    static const precision_t precisions[] = {PRECISION_DOUBLE, PRECISION_SINGLE};
    static const char *const pnames[] = {"double", "single"};
    for (int k = 0; k < nsizes; k++) {
        for (int pr = 0; pr < 2; pr++) {
            for (int l = 0; l < 3; l++) {
                if (layouts[l] == STREAMING_MOMENTS && precisions[pr] != PRECISION_DOUBLE) {
                    continue; /* double only */
                }
                for (int t = 0; t < ntc; t++) {
                    double bpc = 0.0, bwr = 0.0;
                    const double m =
                        fluid_mlups(sizes[k], tcounts[t], layouts[l], precisions[pr], &copy, &bwr, &bpc);
                    /* 19 loads + 19 stores of a value per cell update; the
                     * moments layout: 10 of each and its 4-byte index
                     * (fluid/kernel_moments.c; its plane copies stay in cache) */
                    const double update = layouts[l] == STREAMING_MOMENTS
                                              ? 2.0 * MOM_N * sizeof(double) + sizeof(int32_t)
                                              : 2.0 * LB_Q * (pr == 0 ? sizeof(double) : sizeof(float));
                    const double limit = bwr * 1e9 / update / 1e6;
                    const double ratio = limit > 0.0 ? m / limit : 0.0;
                    if (json) {
                        printf("{\"size\": %d, \"threads\": %d, \"precision\": \"%s\", \"streaming\": \"%s\", "
                               "\"mlups\": %.3f, \"bandwidth_gbs\": %.3f, \"limit_mlups\": %.3f, \"ratio\": %.4f, "
                               "\"bytes_per_cell\": %.2f}\n",
                               sizes[k], tcounts[t], pnames[pr], names[l], m, bwr, limit, ratio, bpc);
                    } else {
                        printf("%6d %7d %9s %9s %8.2f %10.2f %12.2f %7.3f %10.1f\n", sizes[k], tcounts[t],
                               pnames[pr], names[l], m, bwr, limit, ratio, bpc);
                    }
                    fflush(stdout);
                }
            }
        }
    }
    omp_set_num_threads(maxthreads);
    free(copy.a);
    free(copy.b);
    return 0;
}

static int compare_doubles(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* One whole `coupler run` of the scene (export, master, output), in seconds;
 * its parts in *tm. */
static double timed_run(const char *path, const char *const *overrides, int nover, long steps, const char *lib_dir,
                        const char *out, run_times_t *tm)
{
    log_t log = {log_stderr, NULL};
    scene_t *s = NULL;
    if (scene_load(path, overrides, nover, &log, &s) != STATUS_OK) {
        return -1.0;
    }
    const run_options_t opt = {out, steps, 1, 1, NULL, NULL, NULL, lib_dir, 0.0, 0.0, NULL, tm};
    const double t0 = omp_get_wtime();
    const int rc = run_scene(s, &opt, &log);
    const double t = omp_get_wtime() - t0;
    scene_free(s);
    return rc == 0 ? t : -1.0;
}

int bench_coupled(const char *scene, long steps, const char *lib_dir, int json)
{
    char dir[] = "/tmp/agglo-bench-XXXXXX";
    if (mkdtemp(dir) == NULL) {
        fprintf(stderr, "coupler bench: cannot create a temporary folder in /tmp\n");
        return 1;
    }
    char out[sizeof dir + 32];
    snprintf(out, sizeof out, "%s/out.h5", dir);
    static const char *const no_bodies[] = {"bodies=[]", "connections=[]", "run.fields=false"};
    static const char *const as_given[] = {"run.fields=false"};
    /* pairs of runs, the order alternating so that neither run always comes
     * first: the best of each, and the median of the pairs' ratios (each
     * pair from the same minute: this VM's speed drifts by 20%) */
    enum { PAIRS = 5 };
    double with = 1e300, without = 1e300, ratios[PAIRS];
    run_times_t best[2] = {{0}}; /* the parts of the fastest run without [0] and with [1] bodies */
    for (int rep = 0; rep < PAIRS; rep++) {
        double t2[2];
        for (int k = 0; k < 2; k++) {
            const int bodies = (k + rep) % 2 == 0;
            run_times_t tm;
            const double t = timed_run(scene, bodies ? as_given : no_bodies, bodies ? 1 : 3, steps, lib_dir, out, &tm);
            if (t < 0.0) {
                fprintf(stderr, "coupler bench: the run of %s%s failed (see above)\n", scene,
                        bodies ? "" : " without bodies");
                remove(out);
                rmdir(dir);
                return 1;
            }
            t2[bodies] = t;
            if (t < (bodies ? with : without)) {
                best[bodies] = tm;
            }
        }
        with = fmin(with, t2[1]);
        without = fmin(without, t2[0]);
        ratios[rep] = t2[1] / t2[0];
    }
    remove(out);
    rmdir(dir);
    qsort(ratios, PAIRS, sizeof ratios[0], compare_doubles);
    const double median = ratios[PAIRS / 2];
    const run_times_t *b = &best[1], *f = &best[0];
    if (json) {
        printf("{\"scene\": \"%s\", \"steps\": %ld, \"coupled_s\": %.6f, \"fluid_only_s\": %.6f, \"ratio\": %.4f, "
               "\"ratio_median\": %.4f, \"coupled_parts_s\": {\"fluid\": %.6f, \"rigid\": %.6f, \"master\": %.6f, "
               "\"startup\": %.6f, \"output\": %.6f}, \"fluid_only_parts_s\": {\"fluid\": %.6f, \"rigid\": %.6f, "
               "\"master\": %.6f, \"startup\": %.6f, \"output\": %.6f}}\n",
               scene, steps, with, without, with / without, median, b->fluid, b->rigid, b->master, b->startup,
               b->output, f->fluid, f->rigid, f->master, f->startup, f->output);
    } else {
        printf("coupled run of %s, %ld steps, whole wall time (export, master, output; no field snapshots), %d "
               "pairs:\n"
               "  best: with its bodies %.3f s, without bodies (same grid and walls) %.3f s, ratio %.3f\n"
               "  ratio within each pair: median %.3f (from %.3f to %.3f)\n"
               "  parts of the two best runs, with / without bodies (s): fluid component %.3f / %.3f (%+.3f, x %.3f: "
               "the sphere stages), rigid component %.3f / %.3f, master %.3f / %.3f (of it start-up %.3f / "
               "%.3f, output %.3f / %.3f)\n",
               scene, steps, PAIRS, with, without, with / without, median, ratios[0], ratios[PAIRS - 1], b->fluid,
               f->fluid, b->fluid - f->fluid, b->fluid / fmax(f->fluid, 1e-9), b->rigid, f->rigid, b->master,
               f->master, b->startup, f->startup, b->output, f->output);
    }
    return 0;
}
