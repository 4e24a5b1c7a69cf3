/* kernel_skip.c — the runs of cells the in-place update leaves alone
 * (kernel.h kernel_skip_t), built from a list of cells: a counting sort by
 * row, each row's x sorted, consecutive x joined into runs. O(cells + rows),
 * after every map that moved a sphere (fluid_step). */
#include "kernel.h"

#include <stdlib.h>
#include <string.h>

void kernel_skip_free(kernel_skip_t *k)
{
    free(k->start);
    free(k->run);
    free(k->xs);
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
    int32_t *xs = realloc(k->xs, cap * sizeof *xs);
    if (xs != NULL) {
        k->xs = xs;
    }
    if (run == NULL || xs == NULL) {
        return 0;
    }
    k->cap_run = cap;
    return 1;
}

/* The interior row of cell i (kernel_skip_t), and its x; the number of rows
 * for a cell outside the interior. */
static size_t cell_row(const grid_t *g, size_t i, int *x)
{
    const size_t sx = (size_t)g->s[0], sy = (size_t)g->s[1];
    const int y = (int)(i / sx % sy), z = (int)(i / (sx * sy));
    *x = (int)(i % sx);
    if (*x < 1 || *x > g->n[0] || y < 1 || y > g->n[1] || z < 1 || z > g->n[2]) {
        return (size_t)g->n[1] * (size_t)g->n[2];
    }
    return (size_t)(y - 1) + (size_t)g->n[1] * (size_t)(z - 1);
}

int kernel_skip_build(kernel_skip_t *k, const grid_t *g, const size_t *cells, size_t n)
{
    const int ny = g->n[1], nz = g->n[2];
    const size_t rows = (size_t)ny * (size_t)nz;
    if (k->start == NULL || k->ny != ny || k->nz != nz) {
        free(k->start);
        k->start = malloc((rows + 1) * sizeof *k->start);
        k->ny = k->start != NULL ? ny : 0;
        k->nz = k->start != NULL ? nz : 0;
    }
    if (k->start == NULL || !grow(k, n + 1)) {
        if (k->start != NULL) {
            memset(k->start, 0, (rows + 1) * sizeof *k->start); /* no runs: every cell updated */
        }
        return 0;
    }
    uint32_t *start = k->start;
    memset(start, 0, (rows + 1) * sizeof *start);
    /* the interior cells' rows: counts, then where each row begins */
    int x;
    for (size_t j = 0; j < n; j++) {
        const size_t r = cell_row(g, cells[j], &x);
        if (r < rows) {
            start[r + 1]++;
        }
    }
    for (size_t r = 0; r < rows; r++) {
        start[r + 1] += start[r];
    }
    /* each x at its row's next place (start[r] moves to the row's end) */
    for (size_t j = 0; j < n; j++) {
        const size_t r = cell_row(g, cells[j], &x);
        if (r < rows) {
            k->xs[start[r]++] = x;
        }
    }
    for (size_t r = rows; r > 0; r--) {
        start[r] = start[r - 1];
    }
    start[0] = 0;
    /* each row's x in order (a few dozen at most: insertion), then joined */
    uint32_t w = 0;
    for (size_t r = 0; r < rows; r++) {
        const uint32_t b = start[r], e = start[r + 1];
        for (uint32_t i = b + 1; i < e; i++) {
            const int32_t v = k->xs[i];
            uint32_t j = i;
            for (; j > b && k->xs[j - 1] > v; j--) {
                k->xs[j] = k->xs[j - 1];
            }
            k->xs[j] = v;
        }
        start[r] = w;
        for (uint32_t i = b; i < e; i++) {
            const int32_t v = k->xs[i];
            if (w > start[r] && v <= k->run[w - 1][1] + 1) {
                k->run[w - 1][1] = v > k->run[w - 1][1] ? v : k->run[w - 1][1];
            } else {
                k->run[w][0] = k->run[w][1] = v;
                w++;
            }
        }
    }
    start[rows] = w;
    return 1;
}
