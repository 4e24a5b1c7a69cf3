/* decomp.c — the block decomposition and the halo exchange (decomp.h). */
#include "decomp.h"

#include "lattice.h"

#include <mpi.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

static MPI_Comm comm_of(const decomp_t *d) { return *(const MPI_Comm *)d->comm; }

/* Cells of block c of p along an axis of n cells, and its first cell. */
static void split(int n, int p, int c, int *lo, int *len)
{
    const int base = n / p, extra = n % p;
    *len = base + (c < extra ? 1 : 0);
    *lo = c * base + (c < extra ? c : extra);
}

void decomp_exchange_range(const decomp_t *d, const int n[3], int a, int lo[3], int hi[3])
{
    for (int b = 0; b < 3; b++) {
        /* the axes before a (x before y before z) with their ghost cells:
         * done before a (pull), or still to come after a (push) */
        const int with_ghosts = b < a;
        lo[b] = with_ghosts ? 0 : 1;
        hi[b] = with_ghosts ? n[b] + 1 : n[b];
        if (!(d->periodic[a] && d->dims[a] == 1)) {
            /* an exchange with another rank (not the local periodic copy):
             * the ghost rows of the domain walls along the face too: after
             * the push kernel, a free-slip link beside the cut reads what the
             * neighbour's cell pushed into its wall ghost (on one rank the
             * same slot is in this grid) */
            const int local_periodic = d->periodic[b] && d->dims[b] == 1;
            if (b != a && !local_periodic) {
                lo[b] = d->nbr[b][0] >= 0 ? lo[b] : 0;
                hi[b] = d->nbr[b][1] >= 0 ? hi[b] : n[b] + 1;
            }
        }
    }
}

void decomp_block(const decomp_t *d, const int coords[3], int lo[3], int n[3])
{
    for (int a = 0; a < 3; a++) {
        split(d->N[a], d->dims[a], coords[a], &lo[a], &n[a]);
    }
}

/* The rank of the block at coords (wrapped on periodic axes), or -1 beyond a
 * face of the domain: row-major, z fastest, as MPI_Cart_create numbers the
 * ranks without reordering. */
int decomp_rank_at(const decomp_t *d, const int coords[3])
{
    int r = 0;
    for (int a = 0; a < 3; a++) {
        int c = coords[a];
        if (c < 0 || c >= d->dims[a]) {
            if (!d->periodic[a]) {
                return -1;
            }
            c = (c % d->dims[a] + d->dims[a]) % d->dims[a];
        }
        r = r * d->dims[a] + c;
    }
    return r;
}

/* MPI_Dims_create's balanced split of world ranks over the axes not kept
 * whole. It returns its sizes largest first: given as (z, y, x), the most
 * ranks go along z and the fewest along x, whose rows the kernel streams (a
 * cut along x shortens every row and its exchange copies strided values: 2
 * ranks ran at 0.68-0.72 of ideal cut along x, 0.87-0.91 along z; README
 * "Several MPI ranks"). */
static int balanced_dims(int world, const int keep[3], int dims[3])
{
    int rev[3] = {keep[2] ? 1 : 0, keep[1] ? 1 : 0, keep[0] ? 1 : 0};
    const int rc = MPI_Dims_create(world, 3, rev);
    dims[0] = rev[2];
    dims[1] = rev[1];
    dims[2] = rev[0];
    return rc;
}

/* The first axis that dims cuts into blocks thinner than DECOMP_MIN_CELLS, or -1. */
static int thin_axis(const int N[3], const int dims[3])
{
    for (int a = 0; a < 3; a++) {
        if (dims[a] > 1 && N[a] / dims[a] < DECOMP_MIN_CELLS) {
            return a;
        }
    }
    return -1;
}

status_t decomp_layout(decomp_t *d, const scene_t *s, const int N[3], int world, int rank, const log_t *log)
{
    memset(d, 0, sizeof *d);
    d->size = 1;
    for (int a = 0; a < 3; a++) {
        d->N[a] = N[a];
        d->n[a] = N[a];
        d->dims[a] = 1;
        d->nbr[a][0] = d->nbr[a][1] = -1;
        d->periodic[a] = s->domain.faces[2 * a].type == FACE_PERIODIC;
    }
    const char *path = s->path ? s->path : "(scene)";
    const int set = s->run.ranks[0] > 0;
    if (world == 1) {
        if (set && s->run.ranks[0] * s->run.ranks[1] * s->run.ranks[2] != 1) {
            log_msg(log, STATUS_WARNING, "fluid",
                    "%s: run.ranks [%d, %d, %d] asks for %d MPI ranks but this process runs alone (start it with "
                    "mpirun -np %d); the whole grid runs here",
                    path, s->run.ranks[0], s->run.ranks[1], s->run.ranks[2],
                    s->run.ranks[0] * s->run.ranks[1] * s->run.ranks[2],
                    s->run.ranks[0] * s->run.ranks[1] * s->run.ranks[2]);
        }
        return STATUS_OK;
    }
    int dims[3] = {0, 0, 0};
    if (set) {
        memcpy(dims, s->run.ranks, sizeof dims);
        if (dims[0] * dims[1] * dims[2] != world) {
            return log_msg(log, STATUS_ERROR, "fluid",
                           "%s: run.ranks [%d, %d, %d] makes %d blocks, but there are %d MPI ranks (mpirun -np, or "
                           "coupler check --ranks): the product must equal the number of ranks (or leave run.ranks "
                           "out to let MPI_Dims_create choose)",
                           path, dims[0], dims[1], dims[2], dims[0] * dims[1] * dims[2], world);
        }
    } else {
        /* axes too short to cut stay whole (MPI_Dims_create keeps the
         * entries that are set); the others as balanced as it finds */
        int keep[3];
        for (int a = 0; a < 3; a++) {
            keep[a] = N[a] < 2 * DECOMP_MIN_CELLS;
        }
        if (keep[0] && keep[1] && keep[2]) {
            return log_msg(log, STATUS_ERROR, "fluid",
                           "%s: the grid of %d x %d x %d cells has no axis of %d cells or more to cut over %d "
                           "ranks: use one rank, or more cells (fluid.dx)",
                           path, N[0], N[1], N[2], 2 * DECOMP_MIN_CELLS, world);
        }
        if (balanced_dims(world, keep, dims) != MPI_SUCCESS) {
            return log_msg(log, STATUS_ERROR, "fluid", "%s: MPI_Dims_create cannot split %d ranks", path, world);
        }
        /* an axis that this split cuts into blocks too thin stays whole too,
         * and its ranks go to the other axes, if that split is thick enough
         * (3 ranks on 24 x 24 x 11 cells: [1, 3, 1], not [1, 1, 3] refused);
         * if none is, the first split stays and is refused below */
        int other[3] = {dims[0], dims[1], dims[2]};
        for (int thin = thin_axis(N, other); thin >= 0; thin = thin_axis(N, other)) {
            keep[thin] = 1;
            if ((keep[0] && keep[1] && keep[2]) || balanced_dims(world, keep, other) != MPI_SUCCESS) {
                break;
            }
            if (thin_axis(N, other) < 0) {
                memcpy(dims, other, sizeof other);
            }
        }
    }
    for (int a = 0; a < 3; a++) {
        if (dims[a] > 1 && N[a] / dims[a] < DECOMP_MIN_CELLS) {
            return log_msg(log, STATUS_ERROR, "fluid",
                           "%s: %d cells along %c over %d ranks leaves blocks of fewer than %d cells; use fewer "
                           "ranks along %c (run.ranks) or more cells (fluid.dx)",
                           path, N[a], "xyz"[a], dims[a], DECOMP_MIN_CELLS, "xyz"[a]);
        }
    }
    d->size = world;
    d->rank = rank;
    for (int a = 0; a < 3; a++) {
        d->dims[a] = dims[a];
    }
    /* row-major coordinates of the rank, z fastest */
    d->coords[2] = rank % dims[2];
    d->coords[1] = rank / dims[2] % dims[1];
    d->coords[0] = rank / (dims[1] * dims[2]);
    decomp_block(d, d->coords, d->lo, d->n);
    for (int a = 0; a < 3; a++) {
        /* a periodic axis with one rank is the local copy (walls.c) */
        for (int side = 0; side < 2; side++) {
            int c[3] = {d->coords[0], d->coords[1], d->coords[2]};
            c[a] += side == 0 ? -1 : 1;
            d->nbr[a][side] = dims[a] == 1 ? -1 : decomp_rank_at(d, c);
        }
    }
    /* bytes sent per step: 5 populations per face cell, over the ranges the
     * exchange copies (decomp_exchange_range) */
    const size_t es = s->fluid.precision == PRECISION_SINGLE ? 4 : 8;
    d->xbytes_max = 0;
    for (int a = 0; a < 3; a++) {
        int lo[3], hi[3];
        decomp_exchange_range(d, d->n, a, lo, hi);
        size_t cells = 1;
        for (int b = 0; b < 3; b++) {
            cells *= b == a ? 1 : (size_t)(hi[b] - lo[b] + 1);
        }
        for (int side = 0; side < 2; side++) {
            if (d->nbr[a][side] >= 0) {
                d->halo_bytes += 5.0 * (double)cells * (double)es;
                d->xbytes_max = d->xbytes_max > 5 * cells * es ? d->xbytes_max : 5 * cells * es;
            }
        }
    }
    return STATUS_OK;
}

status_t decomp_init(decomp_t *d, const scene_t *s, const int N[3], const log_t *log)
{
    int inited = 0, fin = 0, world = 1, rank = 0;
    MPI_Initialized(&inited);
    MPI_Finalized(&fin);
    if (inited && !fin) {
        MPI_Comm_size(MPI_COMM_WORLD, &world);
        MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    }
    status_t st = decomp_layout(d, s, N, world, rank, log);
    if (st >= STATUS_ERROR || world == 1) {
        return st;
    }
    MPI_Comm *cart = malloc(sizeof *cart);
    /* the buffers of the largest axis now: an exchange that failed for
     * memory on one rank would leave its neighbours waiting */
    d->cap = 4 * d->xbytes_max;
    d->buf = malloc(d->cap > 0 ? d->cap : 1);
    d->req = malloc(4 * sizeof(MPI_Request));
    if (cart == NULL || d->buf == NULL || d->req == NULL) {
        free(cart);
        return log_msg(log, STATUS_ERROR, "fluid", "out of memory for the communicator and the halo buffers (%zu bytes)",
                       d->cap);
    }
    /* no reordering: world rank 0 (which writes the outputs) keeps block 0,
     * and the ranks are row-major as decomp_layout numbers them */
    MPI_Cart_create(MPI_COMM_WORLD, 3, d->dims, d->periodic, 0, cart);
    d->comm = cart;
    int coords[3];
    MPI_Comm_rank(*cart, &rank);
    MPI_Cart_coords(*cart, rank, 3, coords);
    if (rank != d->rank || coords[0] != d->coords[0] || coords[1] != d->coords[1] || coords[2] != d->coords[2]) {
        return log_msg(log, STATUS_ERROR, "fluid",
                       "MPI_Cart_create placed rank %d at (%d, %d, %d), not at (%d, %d, %d) as the decomposition "
                       "assumes (row-major): this MPI library numbers Cartesian ranks otherwise",
                       rank, coords[0], coords[1], coords[2], d->coords[0], d->coords[1], d->coords[2]);
    }
    return STATUS_OK;
}

void decomp_free(decomp_t *d)
{
    if (d->comm != NULL) {
        int fin = 0;
        MPI_Finalized(&fin);
        if (!fin) {
            MPI_Comm_free((MPI_Comm *)d->comm);
        }
        free(d->comm);
    }
    free(d->buf);
    free(d->req);
    d->comm = NULL;
    d->buf = NULL;
    d->req = NULL;
}

/* Copies layer `layer` of axis a (cells lo..hi on the other axes), the
 * directions qs, between the populations and buf (out: to buf). Direction
 * by direction, rows along the faster axis: contiguous runs for x and y
 * faces; typed copies (a memcpy of a run-time size per value cost a call). */
#define LAYER_COPY(T, base)                                                                  \
    do {                                                                                     \
        T *restrict pf = (T *)(base);                                                        \
        T *restrict bf = (T *)buf;                                                           \
        _Pragma("omp parallel for collapse(2) schedule(static)")                             \
        for (int m = 0; m < nq; m++) {                                                       \
            for (int jj = lo[c]; jj <= hi[c]; jj++) {                                        \
                int X[3];                                                                    \
                X[a] = layer;                                                                \
                X[c] = jj;                                                                   \
                X[b] = lo[b];                                                                \
                const size_t q = (size_t)(p->state == LAYOUT_SWAPPED ? lb_opposite(qs[m]) : qs[m]); \
                const size_t s0 = q * p->n + grid_index(g, X[0], X[1], X[2]);                \
                size_t k = ((size_t)m * (size_t)nc + (size_t)(jj - lo[c])) * (size_t)nb;    \
                for (int ii = 0; ii < nb; ii++, k++) {                                       \
                    const size_t slot = s0 + (size_t)ii * stride_b;                          \
                    if (out) {                                                               \
                        bf[k] = pf[slot];                                                    \
                    } else {                                                                 \
                        pf[slot] = bf[k];                                                    \
                    }                                                                        \
                }                                                                            \
            }                                                                                \
        }                                                                                    \
    } while (0)

static void layer_copy(const grid_t *g, const pops_t *p, int a, int layer, const int lo[3], const int hi[3],
                       const int *qs, int nq, unsigned char *buf, int out)
{
    /* b the faster of the other two axes (x for y and z faces) */
    const int b = a == 0 ? 1 : 0, c = a == 2 ? 1 : 2, nb = hi[b] - lo[b] + 1, nc = hi[c] - lo[c] + 1;
    const int e[3] = {b == 0, b == 1, b == 2};
    const size_t stride_b = (size_t)grid_offset(g, e[0], e[1], e[2]);
    if (p->state == LAYOUT_MOMENTS) {
        /* out: f~_q of my outer layer (rebuilt from a fluid cell's moments);
         * in: into the side-store slots of my ghost layer (layout.h) */
        double *restrict bf = (double *)(void *)buf;
#pragma omp parallel for collapse(2) schedule(static)
        for (int m = 0; m < nq; m++) {
            for (int jj = lo[c]; jj <= hi[c]; jj++) {
                int X[3];
                X[a] = layer;
                X[c] = jj;
                X[b] = lo[b];
                const size_t i0 = grid_index(g, X[0], X[1], X[2]);
                size_t k = ((size_t)m * (size_t)nc + (size_t)(jj - lo[c])) * (size_t)nb;
                for (int ii = 0; ii < nb; ii++, k++) {
                    const size_t i = i0 + (size_t)ii * stride_b;
                    if (out) {
                        bf[k] = pops_post(p, qs[m], i);
                    } else {
                        pops_write(p, qs[m], pops_post_slot(p, qs[m], i), bf[k]);
                    }
                }
            }
        }
        return;
    }
    if (p->h != NULL) {
        LAYER_COPY(float, p->h);
    } else {
        LAYER_COPY(double, p->f);
    }
}
#undef LAYER_COPY

/* PULL, SWAPPED: the post-collision values of my outer interior layers go to
 * the neighbours' ghost layers. PUSHED: the push kernel left the values
 * leaving my block in my ghost layers; they go to the neighbours' outer
 * interior layers. The message to the upper neighbour carries the 5
 * directions with c_a = +1, to the lower one those with c_a = -1. */
void decomp_exchange_begin(decomp_t *d, const grid_t *g, const pops_t *p, int a, const int lo[3], const int hi[3])
{
    d->xnreq = 0;
    d->xa = a;
    if (d->nbr[a][0] < 0 && d->nbr[a][1] < 0) {
        return;
    }
    const double t0 = omp_get_wtime();
    const int push = p->state == LAYOUT_PUSHED, n = g->n[a];
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    const size_t es = p->h != NULL ? sizeof(float) : sizeof(double);
    const size_t bytes = (size_t)(hi[b] - lo[b] + 1) * (size_t)(hi[c] - lo[c] + 1) * 5 * es;
    memcpy(d->xlo, lo, sizeof d->xlo);
    memcpy(d->xhi, hi, sizeof d->xhi);
    d->xbytes = bytes;
    MPI_Request *req = d->req;
    for (int side = 0; side < 2; side++) { /* receive from the neighbour on `side` */
        if (d->nbr[a][side] >= 0) {
            MPI_Irecv(d->buf + (size_t)(2 + side) * bytes, (int)bytes, MPI_BYTE, d->nbr[a][side], 1 - side,
                      comm_of(d), &req[d->xnreq++]);
        }
    }
    for (int side = 0; side < 2; side++) { /* send to the neighbour on `side` */
        if (d->nbr[a][side] < 0) {
            continue;
        }
        int qs[5];
        const int nq = lb_crossing(a, side == 0 ? -1 : 1, qs);
        const int layer = push ? (side == 0 ? 0 : n + 1) : (side == 0 ? 1 : n);
        layer_copy(g, p, a, layer, lo, hi, qs, nq, d->buf + (size_t)side * bytes, 1);
        MPI_Isend(d->buf + (size_t)side * bytes, (int)bytes, MPI_BYTE, d->nbr[a][side], side, comm_of(d),
                  &req[d->xnreq++]);
    }
    d->halo_seconds += omp_get_wtime() - t0;
}

void decomp_exchange_progress(decomp_t *d)
{
    if (d->xnreq > 0) {
        const double t0 = omp_get_wtime();
        int done = 0;
        MPI_Testall(d->xnreq, d->req, &done, MPI_STATUSES_IGNORE);
        d->halo_seconds += omp_get_wtime() - t0;
    }
}

void decomp_exchange_end(decomp_t *d, const grid_t *g, const pops_t *p)
{
    const int a = d->xa;
    if (d->nbr[a][0] < 0 && d->nbr[a][1] < 0) {
        return;
    }
    const double t0 = omp_get_wtime();
    MPI_Waitall(d->xnreq, d->req, MPI_STATUSES_IGNORE);
    d->xnreq = 0;
    const int push = p->state == LAYOUT_PUSHED, n = g->n[a];
    for (int side = 0; side < 2; side++) {
        if (d->nbr[a][side] < 0) {
            continue;
        }
        /* from the lower neighbour: directions c_a = +1, into ghost 0
         * (pull) or layer 1 (push); from the upper one c_a = -1 */
        int qs[5];
        const int nq = lb_crossing(a, side == 0 ? 1 : -1, qs);
        const int layer = push ? (side == 0 ? 1 : n) : (side == 0 ? 0 : n + 1);
        layer_copy(g, p, a, layer, d->xlo, d->xhi, qs, nq, d->buf + (size_t)(2 + side) * d->xbytes, 0);
    }
    d->halo_seconds += omp_get_wtime() - t0;
}

status_t decomp_agree(const decomp_t *d, status_t st)
{
    if (d->comm == NULL) {
        return st;
    }
    int v = (int)st, w = 0;
    MPI_Allreduce(&v, &w, 1, MPI_INT, MPI_MAX, comm_of(d));
    return (status_t)w;
}

void decomp_sum(const decomp_t *d, xsum_t *s, int count)
{
    if (d->comm == NULL || count == 0) {
        return;
    }
    /* in chunks through buffers on the stack: no allocation that could fail
     * on one rank alone and leave the ranks in different collectives */
    enum { CHUNK = 256 };
    int64_t l[CHUNK * XSUM_LIMBS];
    double big[CHUNK];
    for (int c0 = 0; c0 < count; c0 += CHUNK) {
        const int m = count - c0 < CHUNK ? count - c0 : CHUNK;
        for (int i = 0; i < m; i++) {
            xsum_normalise(&s[c0 + i]);
            memcpy(l + (size_t)i * XSUM_LIMBS, s[c0 + i].l, sizeof s[0].l);
            big[i] = s[c0 + i].big;
        }
        MPI_Allreduce(MPI_IN_PLACE, l, m * XSUM_LIMBS, MPI_INT64_T, MPI_SUM, comm_of(d));
        MPI_Allreduce(MPI_IN_PLACE, big, m, MPI_DOUBLE, MPI_SUM, comm_of(d));
        for (int i = 0; i < m; i++) {
            memcpy(s[c0 + i].l, l + (size_t)i * XSUM_LIMBS, sizeof s[0].l);
            s[c0 + i].big = big[i];
        }
    }
}

void decomp_max(const decomp_t *d, double *v, int count)
{
    if (d->comm != NULL && count > 0) {
        MPI_Allreduce(MPI_IN_PLACE, v, count, MPI_DOUBLE, MPI_MAX, comm_of(d));
    }
}

void decomp_bcast(const decomp_t *d, void *buf, size_t bytes)
{
    if (d->comm != NULL && bytes > 0) {
        MPI_Bcast(buf, (int)bytes, MPI_BYTE, 0, comm_of(d));
    }
}

void decomp_bcast_text(const decomp_t *d, char *buf, size_t cap, int root)
{
    if (d->comm != NULL && cap > 0) {
        MPI_Bcast(buf, (int)cap, MPI_CHAR, root, comm_of(d));
        buf[cap - 1] = '\0';
    }
}
