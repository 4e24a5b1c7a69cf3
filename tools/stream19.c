/* stream19.c — what the in-place kernel's memory pattern alone gets on this
 * machine: 19 arrays of (N+2)^3 doubles (N = 128 unless given), each cell's
 * 19 values read and written back row by row as the local AA step does, but
 * without the collision's arithmetic; against a copy with non-temporal
 * stores when the compiler has them (the limit `coupler bench` uses). Prints
 * M cells/s and the ratio to the copy (cells x 304 bytes against the copy's
 * bytes), best of 8 rounds.
 *   gcc -O3 -march=native -fopenmp tools/stream19.c -o build/stream19
 *   OMP_NUM_THREADS=1 build/stream19 [N]; OMP_NUM_THREADS=2 build/stream19 [N]
 * Not part of the build or the tests: a diagnostic (README "Speed and memory"). */
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#if defined(__AVX__)
#include <immintrin.h>
#endif

enum { Q = 19 };

int main(int argc, char **argv)
{
    const int n = argc > 1 ? atoi(argv[1]) : 128;
    if (n < 8 || n > 1024) {
        fprintf(stderr, "stream19: N = %s; allowed: 8 to 1024\n", argc > 1 ? argv[1] : "");
        return 1;
    }
    const size_t s = (size_t)n + 2, cells = s * s * s;
    const size_t stride = cells + (512 + 24 - cells % 512) % 512; /* as fluid/grid.h */
    const size_t m = (size_t)1 << 26;                               /* copy: 512 MiB per array */
    double *f = aligned_alloc(64, (Q * stride * sizeof(double) + 63) / 64 * 64);
    double *a = aligned_alloc(64, m * sizeof(double)), *b = aligned_alloc(64, m * sizeof(double));
    if (f == NULL || a == NULL || b == NULL) {
        fprintf(stderr, "stream19: out of memory\n");
        return 1;
    }
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < Q * stride; i++) {
        f[i] = 1.0 / Q;
    }
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < m; i++) {
        a[i] = (double)i;
        b[i] = 0.0;
    }
    double best_copy = 0.0, best_cells = 0.0;
    for (int round = 0; round < 8; round++) {
        double t0 = omp_get_wtime();
#pragma omp parallel for schedule(static)
        for (size_t i = 0; i < m; i += 4) {
#if defined(__AVX__)
            _mm256_stream_pd(b + i, _mm256_load_pd(a + i));
#else
            for (int k = 0; k < 4; k++) {
                b[i + k] = a[i + k];
            }
#endif
        }
        const double copy = 2.0 * (double)m * sizeof(double) / (omp_get_wtime() - t0) / 1e9;
        t0 = omp_get_wtime();
#pragma omp parallel for collapse(2) schedule(static)
        for (int z = 1; z <= n; z++) {
            for (int y = 1; y <= n; y++) {
                double *row = f + ((size_t)z * s + (size_t)y) * s + 1;
                for (int x0 = 0; x0 < n; x0 += 4) {
                    const int w = n - x0 < 4 ? n - x0 : 4;
                    for (int q = 0; q < Q; q++) {
                        double *p = row + (size_t)q * stride + x0;
                        for (int x = 0; x < w; x++) {
                            p[x] = 0.999 * p[x] + 1e-3 / Q;
                        }
                    }
                }
            }
        }
        const double mc = (double)n * n * n / (omp_get_wtime() - t0) / 1e6;
        best_copy = copy > best_copy ? copy : best_copy;
        best_cells = mc > best_cells ? mc : best_cells;
    }
    printf("%d^3, %d thread(s): copy %.2f GB/s; 19 arrays read and written back %.2f M cells/s, %.3f of the "
           "copy's limit (304 bytes per cell)\n",
           n, omp_get_max_threads(), best_copy, best_cells, best_cells * 304e6 / (best_copy * 1e9));
    volatile double sink = f[stride / 2] + b[m / 2];
    (void)sink;
    free(f);
    free(a);
    free(b);
    return 0;
}
