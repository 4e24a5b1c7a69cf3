/* kernel_dispatch.c — the FMU build's kernel: kernel.c is compiled for the
 * x86-64 baseline (SSE2) and for x86-64-v3 (AVX2 + FMA) (Makefile,
 * KERNEL_VARIANT); the CPU decides at the first call. An FMU thus runs on any
 * x86-64 machine and at full speed on a recent one (measured here, 64^3:
 * 50 MLUPS baseline, 82 MLUPS with AVX2). The environment variable
 * AGGLO_KERNEL=base selects the baseline kernel on any CPU. The grid scan of
 * the totals and checks (scan.c) is compiled and picked the same way. */
#include "kernel.h"
#include "moments.h"
#include "scan.h"

#include <stdlib.h>
#include <string.h>

void kernel_stream_collide_base(const grid_t *g, const kernel_params_t *p, const double *restrict src,
                                double *restrict dst, const kernel_box_t *box);
void kernel_stream_collide_v3(const grid_t *g, const kernel_params_t *p, const double *restrict src,
                              double *restrict dst, const kernel_box_t *box);

void kernel_in_place_base(const grid_t *g, const kernel_params_t *p, double *f, int push, const kernel_box_t *box);
void kernel_in_place_v3(const grid_t *g, const kernel_params_t *p, double *f, int push, const kernel_box_t *box);
void kernel_stream_collide_f32_base(const grid_t *g, const kernel_params_t *p, const float *restrict src,
                                    float *restrict dst, const kernel_box_t *box);
void kernel_stream_collide_f32_v3(const grid_t *g, const kernel_params_t *p, const float *restrict src,
                                  float *restrict dst, const kernel_box_t *box);
void kernel_in_place_f32_base(const grid_t *g, const kernel_params_t *p, float *f, int push, const kernel_box_t *box);
void kernel_in_place_f32_v3(const grid_t *g, const kernel_params_t *p, float *f, int push, const kernel_box_t *box);

static int use_v3(void)
{
#if defined(__x86_64__) && defined(__GNUC__)
    static int v3 = -1;
    if (v3 < 0) {
        __builtin_cpu_init();
        const char *force = getenv("AGGLO_KERNEL"); /* "base": the baseline kernel (tests, comparisons) */
        v3 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") && !(force && strcmp(force, "base") == 0);
    }
    return v3;
#else
    return 0;
#endif
}

void kernel_stream_collide(const grid_t *g, const kernel_params_t *p, const double *restrict src,
                           double *restrict dst, const kernel_box_t *box)
{
    if (use_v3()) {
        kernel_stream_collide_v3(g, p, src, dst, box);
    } else {
        kernel_stream_collide_base(g, p, src, dst, box);
    }
}

void kernel_in_place(const grid_t *g, const kernel_params_t *p, double *f, int push, const kernel_box_t *box)
{
    if (use_v3()) {
        kernel_in_place_v3(g, p, f, push, box);
    } else {
        kernel_in_place_base(g, p, f, push, box);
    }
}

void kernel_stream_collide_f32(const grid_t *g, const kernel_params_t *p, const float *restrict src,
                               float *restrict dst, const kernel_box_t *box)
{
    if (use_v3()) {
        kernel_stream_collide_f32_v3(g, p, src, dst, box);
    } else {
        kernel_stream_collide_f32_base(g, p, src, dst, box);
    }
}

void kernel_in_place_f32(const grid_t *g, const kernel_params_t *p, float *f, int push, const kernel_box_t *box)
{
    if (use_v3()) {
        kernel_in_place_f32_v3(g, p, f, push, box);
    } else {
        kernel_in_place_f32_base(g, p, f, push, box);
    }
}

int kernel_moments_base(const grid_t *g, const kernel_params_t *p, moments_t *ms);
int kernel_moments_v3(const grid_t *g, const kernel_params_t *p, moments_t *ms);

int kernel_moments(const grid_t *g, const kernel_params_t *p, moments_t *ms)
{
    return use_v3() ? kernel_moments_v3(g, p, ms) : kernel_moments_base(g, p, ms);
}

int fluid_scan_base(const fluid_t *fl, double umax2, double *plane, xsum_t *sums, int totals);
int fluid_scan_v3(const fluid_t *fl, double umax2, double *plane, xsum_t *sums, int totals);

int fluid_scan(const fluid_t *fl, double umax2, double *plane, xsum_t *sums, int totals)
{
    return use_v3() ? fluid_scan_v3(fl, umax2, plane, sums, totals) : fluid_scan_base(fl, umax2, plane, sums, totals);
}
