/* check_ranks.c — `coupler check --ranks N` (or under mpirun): what each of
 * N ranks would hold and send (check_ranks.h).
 *
 * The layout is fluid/decomp.c's own (decomp_layout for every rank), so the
 * report cannot drift from what a run does. Memory per rank is what the
 * fluid allocates for its block (fluid/fluid.c alloc_populations, grid.h):
 * LB_Q populations of `stride` values each, for every array of the streaming
 * layout (1 in place, 2 for two arrays), and 1 byte of flags per allocated
 * cell (ghost layer and x padding included); the wall and sphere link lists,
 * which depend on the flow, are left out. Halo bytes per step are
 * decomp_layout's: 5 populations per face cell of every exchanged face. */
#include "check_ranks.h"

#include "../fluid/decomp.h"
#include "../fluid/grid.h"
#include "../fluid/lattice.h"
#include "../fluid/units.h"

#include <stdio.h>

/* Above this many ranks the table shows the first CHECK_RANKS_HEAD, the last
 * one, and the extremes over all. */
enum { CHECK_RANKS_ROWS = 16, CHECK_RANKS_HEAD = 8 };

static double value_bytes(const scene_t *s) { return s->fluid.precision == PRECISION_SINGLE ? 4.0 : 8.0; }

/* Bytes of the fluid's populations and flags for a block of n cells. */
static double block_bytes(const scene_t *s, const int n[3])
{
    grid_t g;
    grid_init(&g, n, units_grid_align(s));
    const double arrays = s->fluid.streaming == STREAMING_TWO_ARRAY ? 2.0 : 1.0;
    return arrays * LB_Q * (double)g.stride * value_bytes(s) + (double)g.ncells;
}

/* One rank's figures. */
typedef struct {
    double cells, bytes, halo, share; /* share: halo / populations of the interior cells */
} rank_row_t;

static rank_row_t row_of(const scene_t *s, const decomp_t *d)
{
    rank_row_t r;
    r.cells = (double)d->n[0] * d->n[1] * d->n[2];
    r.bytes = block_bytes(s, d->n);
    r.halo = d->halo_bytes;
    r.share = r.halo / (LB_Q * value_bytes(s) * r.cells);
    return r;
}

static void print_figures(const rank_row_t *r)
{
    printf("%12.0f %11.3f %13.0f %8.3f\n", r->cells, r->bytes / 1e6, r->halo, 100.0 * r->share);
}

static void print_rank(const scene_t *s, const decomp_t *d)
{
    char coords[48], lo[48], n[48];
    snprintf(coords, sizeof coords, "(%d, %d, %d)", d->coords[0], d->coords[1], d->coords[2]);
    snprintf(lo, sizeof lo, "(%d, %d, %d)", d->lo[0], d->lo[1], d->lo[2]);
    snprintf(n, sizeof n, "%d x %d x %d", d->n[0], d->n[1], d->n[2]);
    printf("    %6d  %-16s %-20s %-18s", d->rank, coords, lo, n);
    const rank_row_t r = row_of(s, d);
    print_figures(&r);
}

status_t check_ranks(const scene_t *s, const int N[3], int world, const log_t *log)
{
    decomp_t d;
    status_t st = decomp_layout(&d, s, N, world, 0, log);
    if (st >= STATUS_ERROR) {
        return st;
    }
    const int set = s->run.ranks[0] > 0;
    printf("  MPI ranks          %d = %d x %d x %d along x, y, z (%s)\n", world, d.dims[0], d.dims[1], d.dims[2],
           world == 1 ? "one block: the whole grid" : set ? "run.ranks" : "MPI_Dims_create");
    printf("    %6s  %-16s %-20s %-18s%12s %11s %13s %8s\n", "rank", "coords", "first cell", "block cells", "interior",
           "memory MB", "halo B/step", "halo %");
    rank_row_t lo = {0}, hi = {0}, sum = {0};
    for (int r = 0; r < world; r++) {
        if (r > 0) {
            st = decomp_layout(&d, s, N, world, r, log);
            if (st >= STATUS_ERROR) {
                return st; /* cannot happen: the layout's checks do not depend on the rank */
            }
        }
        const rank_row_t row = row_of(s, &d);
        if (r == 0) {
            lo = hi = row;
        }
        lo.cells = row.cells < lo.cells ? row.cells : lo.cells;
        lo.bytes = row.bytes < lo.bytes ? row.bytes : lo.bytes;
        lo.halo = row.halo < lo.halo ? row.halo : lo.halo;
        lo.share = row.share < lo.share ? row.share : lo.share;
        hi.cells = row.cells > hi.cells ? row.cells : hi.cells;
        hi.bytes = row.bytes > hi.bytes ? row.bytes : hi.bytes;
        hi.halo = row.halo > hi.halo ? row.halo : hi.halo;
        hi.share = row.share > hi.share ? row.share : hi.share;
        sum.cells += row.cells;
        sum.bytes += row.bytes;
        sum.halo += row.halo;
        if (world <= CHECK_RANKS_ROWS || r < CHECK_RANKS_HEAD || r == world - 1) {
            if (world > CHECK_RANKS_ROWS && r == world - 1) {
                printf("    %6s\n", "...");
            }
            print_rank(s, &d);
        }
    }
    decomp_free(&d);
    if (world > CHECK_RANKS_ROWS) {
        printf("    %6s  %-56s", "min", "(over all ranks)");
        print_figures(&lo);
        printf("    %6s  %-56s", "max", "(over all ranks)");
        print_figures(&hi);
    }
    printf("  memory per rank    max %.4g MB, mean %.4g MB (fluid.streaming %s, precision %s: the populations of "
           "the block with its ghost layer as grid.h allocates them, and 1 byte of flags per cell; no link lists)\n",
           hi.bytes / 1e6, sum.bytes / world / 1e6,
           s->fluid.streaming == STREAMING_TWO_ARRAY ? "two_array"
           : s->fluid.streaming == STREAMING_MOMENTS ? "moments"
                                                     : "in_place",
           s->fluid.precision == PRECISION_SINGLE ? "single" : "double");
    printf("  halo per step      %.0f B sent by all ranks, at most %.0f B by one; %.3g %% of the populations of the "
           "interior cells (%d x %.0f B per cell)\n",
           sum.halo, hi.halo, 100.0 * sum.halo / (LB_Q * value_bytes(s) * sum.cells), LB_Q, value_bytes(s));
    return STATUS_OK;
}
