/* moments.c — the store of the moments layout (moments.h): the 10 moments
 * of every fluid cell, the side store of 19 values per ghost or solid cell
 * and the index between them, kept in step with the spheres' maps. The
 * update of the cells is kernel_moments.c. */
#include "moments.h"

#include "../common/big_alloc.h"
#include "lattice.h"
#include "spheres.h"

#include <stdlib.h>
#include <string.h>

int moments_create(moments_t *ms, const grid_t *g)
{
    memset(ms, 0, sizeof *ms);
    ms->map = -1;
    if (g->stride > SIZE_MAX / (MOM_N * sizeof(double))) {
        return 0;
    }
    ms->m = big_alloc((size_t)MOM_N * g->stride * sizeof(double));
    ms->idx = malloc(g->ncells * sizeof *ms->idx);
    ms->row_fluid = malloc((size_t)g->s[1] * (size_t)g->s[2]);
    if (ms->m == NULL || ms->idx == NULL || ms->row_fluid == NULL) {
        return 0;
    }
    memset(ms->m, 0, (size_t)MOM_N * g->stride * sizeof(double));
    size_t n = 0, i = 0;
    for (int z = 0; z < g->s[2]; z++) {
        for (int y = 0; y < g->s[1]; y++) {
            for (int x = 0; x < g->s[0]; x++, i++) {
                const int ghost = !grid_is_interior(g, x, y, z);
                ms->idx[i] = ghost ? (int32_t)n : -1;
                n += (size_t)ghost;
            }
        }
    }
    if (n > INT32_MAX / 2) {
        return 0;
    }
    ms->nghost = ms->nside = ms->cap = n;
    ms->side = calloc(n > 0 ? n * LB_Q : 1, sizeof *ms->side);
    moments_rows(ms, g);
    return ms->side != NULL;
}

void moments_rows(moments_t *ms, const grid_t *g)
{
#pragma omp parallel for schedule(static)
    for (int z = 0; z < g->s[2]; z++) {
        for (int y = 0; y < g->s[1]; y++) {
            const size_t i0 = grid_index(g, 1, y, z);
            int all = grid_is_interior(g, 1, y, z);
            for (int x = 0; x < g->n[0] && all; x++) {
                all = ms->idx[i0 + (size_t)x] < 0;
            }
            ms->row_fluid[(size_t)z * (size_t)g->s[1] + (size_t)y] = (uint8_t)all;
        }
    }
}

void moments_free(moments_t *ms)
{
    free(ms->planes);
    free(ms->row_fluid);
    free(ms->side);
    free(ms->idx);
    free(ms->m);
    memset(ms, 0, sizeof *ms);
}

pops_t moments_pops(const moments_t *ms, const grid_t *g)
{
    pops_t p;
    pops_init(&p, g, ms->side, 0, LAYOUT_MOMENTS);
    p.m = ms->m;
    p.idx = ms->idx;
    return p;
}

int moments_sync(moments_t *ms, const grid_t *g, const spheres_t *sp)
{
    if (ms->map == sp->maps) {
        return 1;
    }
    const size_t need = ms->nghost + sp->nsolid;
    if (need > (size_t)INT32_MAX) {
        return 0;
    }
    if (need > ms->cap || need + need / 2 + 1024 < ms->cap) {
        /* room for some growth, and given back when the spheres shrank */
        const size_t cap = need + need / 8 + 64;
        double *s = realloc(ms->side, cap * LB_Q * sizeof *s);
        if (s == NULL && need > ms->cap) {
            return 0;
        }
        if (s != NULL) {
            ms->side = s;
            ms->cap = cap;
        }
    }
    const pops_t p = moments_pops(ms, g);
    /* uncovered: their entry holds the refill's values (spheres_map) */
    for (size_t j = 0; j < sp->nfresh; j++) {
        const size_t i = sp->fresh[j];
        if (ms->idx[i] < 0) {
            continue;
        }
        double v[LB_Q];
        for (int q = 0; q < LB_Q; q++) {
            v[q] = ms->side[(size_t)ms->idx[i] * LB_Q + (size_t)q];
        }
        ms->idx[i] = -1;
        pops_set_post(&p, i, v);
    }
    /* the solid cells, in the list's order; those just covered hold their
     * last values, rebuilt */
    for (size_t j = 0; j < sp->nsolid; j++) {
        const size_t i = sp->solid[j];
        const int32_t e = (int32_t)(ms->nghost + j);
        if (ms->idx[i] >= 0 && (size_t)ms->idx[i] < ms->nghost) {
            continue; /* a ghost cell keeps its own entry (on several ranks a sphere may cover one) */
        }
        if (ms->idx[i] < 0) {
            for (int q = 0; q < LB_Q; q++) {
                ms->side[(size_t)e * LB_Q + (size_t)q] = pops_rebuild(ms->m, g->stride, q, i);
            }
        }
        ms->idx[i] = e;
    }
    ms->nside = need;
    ms->map = sp->maps;
    moments_rows(ms, g);
    return 1;
}

size_t moments_bytes(const moments_t *ms, const grid_t *g)
{
    return (size_t)MOM_N * g->stride * sizeof(double) + g->ncells * sizeof(int32_t) + (size_t)g->s[1] * (size_t)g->s[2] +
           ms->cap * LB_Q * sizeof(double) + (size_t)ms->nplanes * MOMENTS_PLANE_DOUBLES * (size_t)g->s[0] * (size_t)g->s[1] *
                                                   sizeof(double);
}
