/* kernel_skip.c — the runs of cells the in-place update leaves alone
 * (kernel.h kernel_skip_t), from the runs the spheres' map records row by
 * row (spheres.c mark_sphere: a sphere meets a row in one run): a counting
 * sort by row, each row's runs sorted, overlapping and adjacent ones joined
 * (sintered spheres). O(runs + rows), a few thousand for the dual star,
 * where a list of the solid cells cost O(cells) with divisions to find
 * their rows: that made the dual star's step slower than updating them. */
#include "kernel.h"

#include <stdlib.h>
#include <string.h>

void kernel_skip_free(kernel_skip_t *k)
{
    free(k->start);
    free(k->run);
    free(k->tmp);
    memset(k, 0, sizeof *k);
}

static int grow(kernel_skip_t *k, size_t n)
{
    if (n <= k->cap_run) {
        return 1;
    }
    size_t cap = k->cap_run > 0 ? k->cap_run : 1024;
    while (cap < n) {
        cap *= 2;
    }
    int32_t(*run)[2] = realloc(k->run, cap * sizeof *run);
    if (run != NULL) {
        k->run = run;
    }
    int32_t(*tmp)[2] = realloc(k->tmp, cap * sizeof *tmp);
    if (tmp != NULL) {
        k->tmp = tmp;
    }
    if (run == NULL || tmp == NULL) {
        return 0;
    }
    k->cap_run = cap;
    return 1;
}

int kernel_skip_build(kernel_skip_t *k, const grid_t *g, int nparts, const int32_t (*const *runs)[3],
                      const size_t *nruns)
{
    const int ny = g->n[1], nz = g->n[2];
    const size_t rows = (size_t)ny * (size_t)nz;
    if (k->start == NULL || k->ny != ny || k->nz != nz) {
        free(k->start);
        k->start = malloc((rows + 1) * sizeof *k->start);
        k->ny = k->start != NULL ? ny : 0;
        k->nz = k->start != NULL ? nz : 0;
    }
    size_t n = 0;
    for (int p = 0; p < nparts; p++) {
        n += nruns[p];
    }
    if (k->start == NULL || !grow(k, n + 1)) {
        if (k->start != NULL) {
            memset(k->start, 0, (rows + 1) * sizeof *k->start); /* no runs: every cell updated */
        }
        return 0;
    }
    uint32_t *start = k->start;
    memset(start, 0, (rows + 1) * sizeof *start);
    /* counts per row, then where each row begins, then each run at its
     * row's next place (start[r] moves to the row's end) */
    for (int p = 0; p < nparts; p++) {
        for (size_t j = 0; j < nruns[p]; j++) {
            const size_t r = (size_t)runs[p][j][0];
            if (r < rows) {
                start[r + 1]++;
            }
        }
    }
    for (size_t r = 0; r < rows; r++) {
        start[r + 1] += start[r];
    }
    for (int p = 0; p < nparts; p++) {
        for (size_t j = 0; j < nruns[p]; j++) {
            const size_t r = (size_t)runs[p][j][0];
            if (r < rows) {
                k->tmp[start[r]][0] = runs[p][j][1];
                k->tmp[start[r]++][1] = runs[p][j][2];
            }
        }
    }
    for (size_t r = rows; r > 0; r--) {
        start[r] = start[r - 1];
    }
    start[0] = 0;
    /* each row's runs by their first x (a few: insertion), then joined */
    uint32_t w = 0;
    for (size_t r = 0; r < rows; r++) {
        const uint32_t b = start[r], e = start[r + 1];
        for (uint32_t i = b + 1; i < e; i++) {
            const int32_t a0 = k->tmp[i][0], a1 = k->tmp[i][1];
            uint32_t j = i;
            for (; j > b && k->tmp[j - 1][0] > a0; j--) {
                k->tmp[j][0] = k->tmp[j - 1][0];
                k->tmp[j][1] = k->tmp[j - 1][1];
            }
            k->tmp[j][0] = a0;
            k->tmp[j][1] = a1;
        }
        start[r] = w;
        for (uint32_t i = b; i < e; i++) {
            if (w > start[r] && k->tmp[i][0] <= k->run[w - 1][1] + 1) {
                k->run[w - 1][1] = k->tmp[i][1] > k->run[w - 1][1] ? k->tmp[i][1] : k->run[w - 1][1];
            } else {
                k->run[w][0] = k->tmp[i][0];
                k->run[w][1] = k->tmp[i][1];
                w++;
            }
        }
    }
    start[rows] = w;
    return 1;
}
