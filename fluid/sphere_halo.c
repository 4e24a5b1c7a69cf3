/* sphere_halo.c — the cells of other ranks that the sphere stage reads
 * (spheres.h sphere_halo_t; issue 13).
 *
 * The boundary schemes read a link's cells x_f - c_q and x_f - 2 c_q, and
 * the refill of an uncovered cell reads its neighbours and the next cell
 * along one direction: up to two cells beyond the block, every population,
 * where the lattice halo (decomp.c) brings five per face cell into one ghost
 * layer. So every step each rank also receives the 19 post-collision values
 * of the cells within two cells of its block and within SPHERE_HALO_REACH
 * of a sphere centre. Both sides find the same cells from the same centres
 * (they are equal on every rank), so no list travels: the receiver takes the
 * cells of its halo region, the sender the cells of its block in each
 * neighbour's halo region, both sorted by (owner direction, z, y, x). The
 * flags of the received cells (solid; fresh: solid at the last map, not now)
 * follow from the centres with the very arithmetic of spheres.c mark_sphere,
 * so that both sides agree to the bit. */
#include "spheres.h"

#include "lattice.h"

#include <math.h>
#include <mpi.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

/* Farther than any cell the stage reads: links start within r + sqrt 2,
 * their cells reach 2 sqrt 2 beyond; an uncovered cell lies within r + 1/2
 * and its refill reads up to 2 sqrt 2 beyond. */
#define SPHERE_HALO_REACH 4.5

static int dir_index(const int d[3]) { return (d[0] + 1) * 9 + (d[1] + 1) * 3 + (d[2] + 1); }

static uint64_t pack(const int Y[3])
{
    return ((uint64_t)(uint32_t)(Y[0] + 8) << 42) | ((uint64_t)(uint32_t)(Y[1] + 8) << 21) | (uint64_t)(Y[2] + 8);
}

static uint64_t mix(uint64_t k)
{
    k ^= k >> 33;
    k *= 0xff51afd7ed558ccdULL;
    k ^= k >> 33;
    return k;
}

long sphere_halo_find(const sphere_halo_t *h, const int Y[3])
{
    if (h->hcap == 0) {
        return -1;
    }
    const uint64_t key = pack(Y) + 1;
    for (size_t i = mix(key) & (h->hcap - 1);; i = (i + 1) & (h->hcap - 1)) {
        if (h->hkey[i] == 0) {
            return -1;
        }
        if (h->hkey[i] == key) {
            return (long)h->hval[i];
        }
    }
}

static int hash_build(sphere_halo_t *h)
{
    size_t cap = 64;
    while (cap < 2 * h->n + 2) {
        cap *= 2;
    }
    if (cap > h->hcap) {
        uint64_t *k = realloc(h->hkey, cap * sizeof *k);
        int64_t *v = k != NULL ? realloc(h->hval, cap * sizeof *v) : NULL;
        if (k != NULL) {
            h->hkey = k;
        }
        if (v == NULL) {
            return 0;
        }
        h->hval = v;
        h->hcap = cap;
    }
    memset(h->hkey, 0, h->hcap * sizeof *h->hkey);
    for (size_t j = 0; j < h->n; j++) {
        const uint64_t key = pack(h->Y[j]) + 1;
        size_t i = mix(key) & (h->hcap - 1);
        while (h->hkey[i] != 0 && h->hkey[i] != key) {
            i = (i + 1) & (h->hcap - 1);
        }
        h->hkey[i] = key;
        h->hval[i] = (int64_t)j;
    }
    return 1;
}

static int cmp_key(const void *a, const void *b)
{
    const long *x = a, *y = b;
    for (int k = 0; k < 4; k++) {
        if (x[k] != y[k]) {
            return x[k] < y[k] ? -1 : 1;
        }
    }
    return 0;
}

/* Global cell (0-based, wrapped) of unwrapped allocated coordinates X. */
static void wrapped(const spheres_t *sp, const int X[3], long G[3])
{
    for (int a = 0; a < 3; a++) {
        long g = X[a] - 1;
        if (sp->periodic[a]) {
            g = ((g % sp->N[a]) + sp->N[a]) % sp->N[a];
        }
        G[a] = g;
    }
}

/* Cells of a list: (key, value) pairs sorted by key and without repeats. */
typedef struct {
    long (*key)[5]; /* owner direction, z, y, x, position in Y (for the sort) */
    int (*Y)[3];
    size_t n, cap;
} cells_t;

static int cells_add(cells_t *c, long dir, const long G[3], const int Y[3])
{
    if (c->n == c->cap) {
        const size_t nc = c->cap ? 2 * c->cap : 256;
        long(*k)[5] = realloc(c->key, nc * sizeof *k);
        if (k == NULL) {
            return 0;
        }
        c->key = k;
        int(*y)[3] = realloc(c->Y, nc * sizeof *y);
        if (y == NULL) {
            return 0;
        }
        c->Y = y;
        c->cap = nc;
    }
    c->key[c->n][0] = dir;
    c->key[c->n][1] = G[2];
    c->key[c->n][2] = G[1];
    c->key[c->n][3] = G[0];
    c->key[c->n][4] = (long)c->n; /* position, to carry Y through the sort */
    memcpy(c->Y[c->n], Y, sizeof c->Y[0]);
    c->n++;
    return 1;
}

/* Sorts by (direction, z, y, x) and drops repeats; Y follows. */
static int cells_sort(cells_t *c)
{
    qsort(c->key, c->n, sizeof *c->key, cmp_key);
    int(*y)[3] = malloc((c->n + 1) * sizeof *y);
    if (y == NULL) {
        return 0;
    }
    size_t m = 0;
    for (size_t j = 0; j < c->n; j++) {
        if (m > 0 && cmp_key(c->key[j], c->key[m - 1]) == 0) {
            continue;
        }
        memcpy(y[m], c->Y[c->key[j][4]], sizeof y[0]);
        memmove(c->key[m], c->key[j], sizeof c->key[0]);
        m++;
    }
    free(c->Y);
    c->Y = y;
    c->n = m;
    return 1;
}

/* Every unwrapped cell within `reach` of a sphere centre, in a box about
 * it: fn(sp, k, X, ctx) for each (the same box loops as spheres.c). */
static int for_near_cells(const spheres_t *sp, double reach, const int blo[3], const int bn[3],
                          int (*fn)(void *, const int X[3]), void *ctx)
{
    for (int k = 0; k < sp->n; k++) {
        const sphere_t *p = &sp->s[k];
        if (!spheres_near_block(sp, p->c, p->r + reach + 1.0, blo, bn)) {
            continue;
        }
        int lo[3], hi[3], X[3];
        for (int a = 0; a < 3; a++) {
            lo[a] = (int)floor(p->c[a] - p->r - reach);
            hi[a] = (int)ceil(p->c[a] + p->r + reach);
        }
        for (X[2] = lo[2]; X[2] <= hi[2]; X[2]++) {
            for (X[1] = lo[1]; X[1] <= hi[1]; X[1]++) {
                for (X[0] = lo[0]; X[0] <= hi[0]; X[0]++) {
                    if (!fn(ctx, X)) {
                        return 0;
                    }
                }
            }
        }
    }
    return 1;
}

typedef struct {
    const spheres_t *sp;
    cells_t *cells;
    /* send lists: the receiving block */
    int rlo[3], rn[3], ropen[6], want; /* want: the owner direction (seen from the receiver) of my cells */
    const grid_t *g;
} plan_ctx_t;

static int add_recv(void *v, const int X[3])
{
    plan_ctx_t *c = v;
    const spheres_t *sp = c->sp;
    int Y[3];
    if (spheres_locate(sp->lo, sp->nb, sp->open, sp->periodic, sp->N, X, Y) != 2) {
        return 1;
    }
    const int d[3] = {Y[0] < 1 ? -1 : Y[0] > sp->nb[0], Y[1] < 1 ? -1 : Y[1] > sp->nb[1],
                      Y[2] < 1 ? -1 : Y[2] > sp->nb[2]};
    long G[3];
    wrapped(sp, X, G);
    return cells_add(c->cells, dir_index(d), G, Y);
}

static int add_send(void *v, const int X[3])
{
    plan_ctx_t *c = v;
    const spheres_t *sp = c->sp;
    int Y[3], R[3];
    if (spheres_locate(c->rlo, c->rn, c->ropen, sp->periodic, sp->N, X, R) != 2) {
        return 1;
    }
    const int d[3] = {R[0] < 1 ? -1 : R[0] > c->rn[0], R[1] < 1 ? -1 : R[1] > c->rn[1],
                      R[2] < 1 ? -1 : R[2] > c->rn[2]};
    if (dir_index(d) != c->want || spheres_locate(sp->lo, sp->nb, sp->open, sp->periodic, sp->N, X, Y) != 1) {
        return 1;
    }
    long G[3];
    wrapped(sp, X, G);
    return cells_add(c->cells, 0, G, Y);
}

/* The solid cells of one sphere as mark_sphere finds them. */
static void mark_halo(spheres_t *sp, const double c[3], double r, uint8_t bit)
{
    sphere_halo_t *h = &sp->halo;
    if (!spheres_near_block(sp, c, r, sp->lo, sp->nb)) {
        return;
    }
    int lo[3], hi[3], X[3], Y[3];
    for (int a = 0; a < 3; a++) {
        lo[a] = (int)ceil(c[a] - r);
        hi[a] = (int)floor(c[a] + r);
    }
    const double r2 = r * r;
    for (X[2] = lo[2]; X[2] <= hi[2]; X[2]++) {
        for (X[1] = lo[1]; X[1] <= hi[1]; X[1]++) {
            for (X[0] = lo[0]; X[0] <= hi[0]; X[0]++) {
                const double dx = X[0] - c[0], dy = X[1] - c[1], dz = X[2] - c[2];
                if (dx * dx + dy * dy + dz * dz > r2 ||
                    spheres_locate(sp->lo, sp->nb, sp->open, sp->periodic, sp->N, X, Y) != 2) {
                    continue;
                }
                const long k = sphere_halo_find(h, Y);
                if (k >= 0) {
                    h->flag[k] |= bit;
                }
            }
        }
    }
}

static status_t oom(const log_t *log, size_t cells)
{
    return log_msg(log, STATUS_ERROR, "fluid", "out of memory for the sphere halo (%zu cells of other ranks)", cells);
}

status_t sphere_halo_plan(spheres_t *sp, const log_t *log)
{
    sphere_halo_t *h = &sp->halo;
    h->n = 0;
    for (int i = 0; i < 27; i++) {
        h->nrecv[i] = h->recv0[i] = h->nsend[i] = 0;
    }
    if (sp->dc == NULL || !decomp_parallel(sp->dc) || sp->n == 0) {
        return STATUS_OK;
    }
    status_t st = STATUS_OK;
    cells_t cells = {0};
    plan_ctx_t ctx = {.sp = sp, .cells = &cells};
    if (!for_near_cells(sp, SPHERE_HALO_REACH, sp->lo, sp->nb, add_recv, &ctx) || !cells_sort(&cells)) {
        st = oom(log, cells.n);
        goto out;
    }
    if (cells.n > h->cap) {
        double *val = realloc(h->val, cells.n * LB_Q * sizeof *val);
        uint8_t *flag = val != NULL ? realloc(h->flag, cells.n) : NULL;
        int(*Y)[3] = flag != NULL ? realloc(h->Y, cells.n * sizeof *Y) : NULL;
        if (val != NULL) {
            h->val = val;
        }
        if (flag != NULL) {
            h->flag = flag;
        }
        if (Y == NULL) {
            st = oom(log, cells.n);
            goto out;
        }
        h->Y = Y;
        h->cap = cells.n;
    }
    h->n = cells.n;
    for (size_t j = 0; j < cells.n; j++) {
        memcpy(h->Y[j], cells.Y[j], sizeof h->Y[0]);
        h->flag[j] = 0;
        const int dir = (int)cells.key[j][0];
        if (h->nrecv[dir] == 0) {
            h->recv0[dir] = j;
        }
        h->nrecv[dir]++;
    }
    if (!hash_build(h)) {
        st = oom(log, cells.n);
        goto out;
    }
    /* flags: solid now; fresh: solid at the last map (cmap), not now */
    for (int k = 0; k < sp->n; k++) {
        mark_halo(sp, sp->s[k].c, sp->s[k].r, FLAG_SOLID);
        if (!sp->first) {
            mark_halo(sp, sp->s[k].cmap, sp->s[k].r, FLAG_MARK);
        }
    }
    for (size_t j = 0; j < h->n; j++) {
        const uint8_t f = h->flag[j];
        h->flag[j] = (f & FLAG_SOLID) ? FLAG_SOLID : (f & FLAG_MARK) ? FLAG_FRESH : 0;
    }
    /* what each neighbour holds of this block: its halo region, my cells */
    const decomp_t *d = sp->dc;
    for (int e0 = -1; e0 <= 1; e0++) {
        for (int e1 = -1; e1 <= 1; e1++) {
            for (int e2 = -1; e2 <= 1; e2++) {
                const int e[3] = {e0, e1, e2};
                int rc[3], skip = e0 == 0 && e1 == 0 && e2 == 0;
                for (int a = 0; a < 3; a++) {
                    skip = skip || (e[a] != 0 && d->dims[a] == 1);
                    rc[a] = d->coords[a] + e[a];
                }
                if (skip || decomp_rank_at(d, rc) < 0) {
                    continue;
                }
                for (int a = 0; a < 3; a++) {
                    rc[a] = (rc[a] % d->dims[a] + d->dims[a]) % d->dims[a];
                }
                decomp_block(d, rc, ctx.rlo, ctx.rn);
                for (int a = 0; a < 3; a++) {
                    for (int side = 0; side < 2; side++) {
                        int nc[3] = {rc[0], rc[1], rc[2]};
                        nc[a] += side == 0 ? -1 : 1;
                        ctx.ropen[2 * a + side] = d->dims[a] > 1 && decomp_rank_at(d, nc) >= 0;
                    }
                }
                const int back[3] = {-e0, -e1, -e2};
                ctx.want = dir_index(back);
                cells_t mine = {0};
                ctx.cells = &mine;
                const int ei = dir_index(e);
                if (!for_near_cells(sp, SPHERE_HALO_REACH, ctx.rlo, ctx.rn, add_send, &ctx) || !cells_sort(&mine)) {
                    free(mine.key);
                    free(mine.Y);
                    st = oom(log, mine.n);
                    goto out;
                }
                if (mine.n > h->capsend[ei]) {
                    size_t *sl = realloc(h->send[ei], mine.n * sizeof *sl);
                    if (sl == NULL) {
                        free(mine.key);
                        free(mine.Y);
                        st = oom(log, mine.n);
                        goto out;
                    }
                    h->send[ei] = sl;
                    h->capsend[ei] = mine.n;
                }
                for (size_t j = 0; j < mine.n; j++) {
                    h->send[ei][j] = grid_index(&sp->grid, mine.Y[j][0], mine.Y[j][1], mine.Y[j][2]);
                }
                h->nsend[ei] = mine.n;
                free(mine.key);
                free(mine.Y);
            }
        }
    }
out:
    free(cells.key);
    free(cells.Y);
    return st;
}

status_t sphere_halo_exchange(spheres_t *sp, const pops_t *p, const log_t *log)
{
    sphere_halo_t *h = &sp->halo;
    const decomp_t *d = sp->dc;
    if (d == NULL || !decomp_parallel(d) || sp->n == 0) {
        return STATUS_OK;
    }
    const double t0 = omp_get_wtime();
    size_t total = 0;
    for (int i = 0; i < 27; i++) {
        total += h->nsend[i];
    }
    if (total * LB_Q > h->scap) {
        double *b = realloc(h->sbuf, total * LB_Q * sizeof *b);
        if (b == NULL) {
            return oom(log, total);
        }
        h->sbuf = b;
        h->scap = total * LB_Q;
    }
    const MPI_Comm comm = *(const MPI_Comm *)d->comm;
    MPI_Request req[54];
    int nreq = 0, rdir[27], nr = 0;
    for (int i = 0; i < 27; i++) {
        if (h->nrecv[i] == 0) {
            continue;
        }
        const int dd[3] = {i / 9 - 1, i / 3 % 3 - 1, i % 3 - 1};
        int rc[3];
        for (int a = 0; a < 3; a++) {
            rc[a] = d->coords[a] + dd[a];
        }
        MPI_Irecv(h->val + h->recv0[i] * LB_Q, (int)(h->nrecv[i] * LB_Q), MPI_DOUBLE, decomp_rank_at(d, rc), 100 + i,
                  comm, &req[nreq++]);
        rdir[nr++] = i;
    }
    size_t off = 0;
    for (int i = 0; i < 27; i++) {
        if (h->nsend[i] == 0) {
            continue;
        }
        double *b = h->sbuf + off;
#pragma omp parallel for schedule(static)
        for (size_t j = 0; j < h->nsend[i]; j++) {
            for (int q = 0; q < LB_Q; q++) {
                b[j * LB_Q + (size_t)q] = pops_post(p, q, h->send[i][j]);
            }
        }
        const int e[3] = {i / 9 - 1, i / 3 % 3 - 1, i % 3 - 1}, back[3] = {-e[0], -e[1], -e[2]};
        int rc[3];
        for (int a = 0; a < 3; a++) {
            rc[a] = d->coords[a] + e[a];
        }
        /* the receiver sees this block in direction -e */
        MPI_Isend(b, (int)(h->nsend[i] * LB_Q), MPI_DOUBLE, decomp_rank_at(d, rc), 100 + dir_index(back), comm,
                  &req[nreq++]);
        off += h->nsend[i] * LB_Q;
    }
    MPI_Status stat[54];
    MPI_Waitall(nreq, req, stat);
    status_t st = STATUS_OK;
    for (int k = 0; k < nr; k++) {
        int got = 0;
        MPI_Get_count(&stat[k], MPI_DOUBLE, &got);
        if ((size_t)got != h->nrecv[rdir[k]] * LB_Q) {
            st = log_msg(log, STATUS_ERROR, "fluid",
                         "sphere halo: %d values arrived from direction %d where %zu were expected: the ranks "
                         "disagree on the cells near the spheres (a bug: please report it with the scene)",
                         got, rdir[k], h->nrecv[rdir[k]] * LB_Q);
        }
    }
    sp->dc->halo_seconds += omp_get_wtime() - t0;
    return st;
}

void sphere_halo_free(sphere_halo_t *h)
{
    free(h->val);
    free(h->flag);
    free(h->Y);
    free(h->hkey);
    free(h->hval);
    free(h->sbuf);
    for (int i = 0; i < 27; i++) {
        free(h->send[i]);
    }
    memset(h, 0, sizeof *h);
}
