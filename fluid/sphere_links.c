/* sphere_links.c — the boundary links of the moving spheres (spheres.h,
 * "links"): for every fluid cell x_f near a sphere and direction q with
 * x_f + c_q solid, the wall distance delta of Eq. 5 (the nearest hit over
 * all spheres wins, so a link belongs to exactly one sphere), the cells the
 * boundary scheme reads (boundary.c), and the film partner of the wall point
 * (README "Lubrication"). Each sphere builds its own list from its bounding
 * box, in parallel over spheres and in a fixed order: the lists, and the
 * loads summed from them, do not depend on the threads. */
#include "sphere_others.h"

#include "boundary.h"
#include "lattice.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* 1 when the cell k steps back along c_q from cell i at local X is fluid
 * (its index in *out). deep: X is k or more cells inside the block on every
 * axis, so that the cell is in the block and its index is i - k off_q, what
 * spheres_cell would give. The scan asks this for nearly every link; the
 * deep case without a call, a bounds test or a multiplication took 5-10%
 * off the scan's samples (perf, dual star). */
static inline __attribute__((always_inline)) int fluid_at(spheres_t *sp, const grid_t *g, const uint8_t *flags,
                                                          const int X[3], int deep, size_t i, ptrdiff_t off_q, int q,
                                                          int k, size_t *out)
{
    uint8_t flag;
    if (deep) {
        *out = (size_t)((ptrdiff_t)i - k * off_q);
        flag = (uint8_t)cellflags_get(flags, *out);
    } else {
        const int Z[3] = {X[0] - k * lb_c[q][0], X[1] - k * lb_c[q][1], X[2] - k * lb_c[q][2]};
        if (!spheres_cell(sp, g, flags, Z, out, &flag)) {
            return 0;
        }
    }
    return (flag & ~FLAG_FRESH) == 0; /* fluid, uncovered this step or not */
}

/* Whether the fluid cell at X (global, unwrapped) lies between two walls
 * along c_q: x_f + c_q is a sphere's, and x_f - c_q is a solid cell (a
 * sphere's link sends it back: SPHERES_PINCHED | SPHERES_PINCHED_SPHERE,
 * and the sphere that covers it in *partner) or beyond a no-slip or moving
 * wall (a bounce-back of walls.c, whose face outranks every other kind a
 * corner cell may cross: SPHERES_PINCHED); 0 when not. Both walls then
 * send back the pair's mean (spheres_fill, walls.c fill_links): the same
 * test on either side. */
static unsigned pinched(const spheres_t *sp, const grid_t *g, const uint8_t *flags, const int X[3], int q,
                        const double dk[3], const others_t *o, size_t *partner)
{
    int B[3], W[3], beyond = 0, wall = 0;
    for (int a = 0; a < 3; a++) {
        B[a] = X[a] - lb_c[q][a];
        if (!sp->periodic[a] && (B[a] < 1 || B[a] > sp->N[a])) {
            beyond = 1;
            wall = wall || sp->pinch_face[2 * a + (B[a] > sp->N[a])];
        }
    }
    if (beyond) {
        return wall ? SPHERES_PINCHED : 0;
    }
    if (!(spheres_locate(sp->lo, sp->nb, sp->open, sp->periodic, sp->N, B, W) != 0 &&
          (cellflags_get(flags, grid_index(g, W[0], W[1], W[2])) & FLAG_SOLID) != 0)) {
        return 0;
    }
    /* the sphere that covers x_f - c_q (k itself only as a periodic image) */
    for (int c = 0; c < o->nc; c++) {
        const sphere_t *m = &sp->s[o->cand[c]];
        double d2 = 0.0;
        for (int a = 0; a < 3; a++) {
            const double d = dk[a] - lb_c[q][a] + o->rel[c][a]; /* rel: c_k - c_m */
            d2 += d * d;
        }
        if (d2 <= m->r * m->r) {
            *partner = (size_t)o->cand[c];
            return SPHERES_PINCHED | SPHERES_PINCHED_SPHERE;
        }
    }
    return SPHERES_PINCHED; /* not found (a halo's sphere): as against a wall */
}

/* The links of sphere k: every fluid cell x_f in its box (plus a cell) and
 * direction q with x_f + c_q solid whose ray hits k first (Eq. 5, nearest
 * intersection over the candidates). A link thus belongs to exactly one
 * sphere and the spheres build their lists independently. */
/* The key of a link: its cell (unwrapped global coordinates, as the box
 * about the centre gives them) and q, in the order of the scan below. */
static uint64_t link_key(const int X[3], int q)
{
    return ((uint64_t)(X[2] + 32768) << 37) | ((uint64_t)(X[1] + 32768) << 21) | ((uint64_t)(X[0] + 32768) << 5) |
           (uint64_t)q;
}

size_t spheres_list_pairs(const link_list_t *list, unsigned char *out)
{
    size_t m = 0;
    for (size_t n = 0; n < list->n; n++) {
        const sphere_link_t *l = &list->l[n];
        if (l->has_pre) {
            if (out != NULL) {
                const spheres_carry_t c = {l->key, {l->pre[0], l->pre[1]}};
                memcpy(out + m * sizeof c, &c, sizeof c);
            }
            m++;
        }
    }
    return m;
}

/* Keeps the pre-collision pairs of the list about to be rebuilt: one pass,
 * room for every link. Only multireflection keeps pairs (spheres_fill sets
 * has_pre for links with a correction): for the other schemes the pass,
 * a cache line per link, would find none. */
static int carry_out(const spheres_t *sp, link_list_t *list)
{
    list->ncarry = 0;
    if (sp->scheme != BOUNDARY_MULTIREFLECTION || list->n == 0) {
        return 1;
    }
    if (!spheres_grow((void **)&list->carry, &list->capcarry, list->n, sizeof *list->carry)) {
        return 0;
    }
    list->ncarry = spheres_list_pairs(list, (unsigned char *)list->carry);
    return 1;
}

/* Gives the rebuilt links the pairs of the same (cell, q) from before; both
 * lists are in key order. A link that was another sphere's, or whose box
 * moved across a periodic face, starts without (spheres_fill). */
static void carry_in(link_list_t *list)
{
    size_t j = 0;
    for (size_t n = 0; n < list->n && j < list->ncarry; n++) {
        sphere_link_t *l = &list->l[n];
        while (j < list->ncarry && list->carry[j].key < l->key) {
            j++;
        }
        if (j < list->ncarry && list->carry[j].key == l->key) {
            l->pre[0] = list->carry[j].pre[0];
            l->pre[1] = list->carry[j].pre[1];
            l->has_pre = 1;
            j++;
        }
    }
    list->ncarry = 0;
}

/* The first cell along axis a of the box a sphere's links are built in
 * (unwrapped global coordinates): it fixes the keys (link_key). */
static inline int box_first(const sphere_t *p, int a) { return (int)floor(p->c[a] - p->r) - 1; }

/* A cell whose links start at index first goes in the list's near cells
 * when another sphere is (nearly) within reach (near_candidates' within):
 * 0 when out of memory. */
static int note_near(link_list_t *list, size_t first, int within)
{
    if (!within) {
        return 1;
    }
    if (!spheres_grow((void **)&list->near, &list->capnear, list->nnear + 1, sizeof *list->near)) {
        return 0;
    }
    list->near[list->nnear++] = first;
    return 1;
}

/* The links of one cell of sphere k's list, from index n (*end: past its
 * last), checked for k's new place: 0 when one is no longer k's. full:
 * their fresh marks and film partners set, and the cell noted as near or
 * not (note_near; *checked 0 when out of memory). */
static int refresh_cell(spheres_t *sp, const uint8_t *flags, int k, others_t *o, link_list_t *list, size_t n,
                        int full, size_t *end, int *checked, int *fresh_set)
{
    const sphere_t *p = &sp->s[k];
    const double reach2 = (p->r + 1.4143) * (p->r + 1.4143), r2 = p->r * p->r;
    int X[3];
    spheres_key_cell(list->l[n].key, X);
    const double dk[3] = {X[0] - p->c[0], X[1] - p->c[1], X[2] - p->c[2]};
    const double dd = dk[0] * dk[0] + dk[1] * dk[1] + dk[2] * dk[2];
    if (dd > reach2 || dd <= r2) {
        return 0;
    }
    int within = 0;
    const int nn = near_candidates(sp, dk, o, full ? &within : NULL);
    size_t e = n;
    int qs[LB_Q], nq = 0;
    double dl[LB_Q];
    for (; e < list->n && spheres_same_cell(&list->l[e], &list->l[n]); e++) {
        qs[nq++] = list->l[e].q;
    }
    spheres_rays(dk, qs, nq, p->r, dl);
    int Y[3] = {0, 0, 0};
    for (int jq = 0; jq < nq; jq++) {
        sphere_link_t *l = &list->l[n + (size_t)jq];
        double xb[3] = {0.0, 0.0, 0.0};
        if (dl[jq] == 0.0) {
            spheres_locate(sp->lo, sp->nb, sp->open, sp->periodic, sp->N, X, Y);
            for (int a = 0; a < 3; a++) {
                xb[a] = Y[a] + sp->lo[a] + lb_c[l->q][a];
            }
        }
        const double delta = link_delta(sp, k, l->q, dl[jq], o, nn, xb, dk);
        if (delta <= 0.0) {
            return 0;
        }
        if (full) {
            l->fresh = (cellflags_get(flags, l->xf) & FLAG_FRESH) != 0;
            *fresh_set |= l->fresh;
            l->film = link_film(sp, k, l->q, dk, delta, o, &l->film_tie);
        }
    }
    if (full && !note_near(list, n, within)) {
        *checked = 0;
    }
    *end = e;
    return 1;
}

/* The links of sphere k for its new place when no flag changed since they
 * were built in the same box (find_dirty has a sphere whose box moved
 * built anew: its keys would differ): the same cells and directions (a link is a
 * fluid cell and a solid neighbour, and those did not change) unless one
 * changed hands between spheres, which this sphere or the other sees as a
 * link it no longer wins: 0 then (the list is to be rebuilt), 1 when every
 * link is still k's (their geometry follows from the new centre:
 * spheres_link_delta). Only the near cells are checked while
 * near_check_holds; else all, and the near cells noted anew. */
static int sphere_refresh(spheres_t *sp, const uint8_t *flags, int k, others_t *o, link_list_t *list)
{
    others_find(sp, k, o);
    int checked = 1, fresh_set = 0;
    size_t e;
    if (others_near_check_holds(sp, list, o)) {
        for (size_t j = 0; j < list->nnear; j++) {
            if (!refresh_cell(sp, flags, k, o, list, list->near[j], 0, &e, &checked, &fresh_set)) {
                return 0;
            }
        }
        spheres_clear_fresh(list);
        list->near_refreshes++;
        return 1;
    }
    list->nnear = 0;
    for (size_t n = 0; n < list->n; n = e) {
        if (!refresh_cell(sp, flags, k, o, list, n, 1, &e, &checked, &fresh_set)) {
            list->checked = 0;
            return 0;
        }
    }
    others_note_checked(sp, list, o, checked, fresh_set);
    return 1;
}

static int sphere_links(spheres_t *sp, const grid_t *g, const uint8_t *flags, int k, others_t *o,
                        link_list_t *list)
{
    const sphere_t *p = &sp->s[k];
    if (!sp->carried && !carry_out(sp, list)) {
        return 0;
    }
    list->checked = 0;
    list->nnear = 0;
    if (!spheres_near_block(sp, p->c, p->r + 2.0, sp->lo, sp->nb)) {
        list->n = 0;
        list->ncarry = 0;
        return 1; /* no cell of this block links to it */
    }
    others_find(sp, k, o);
    int checked = 1, fresh_set = 0;
    const double reach2 = (p->r + 1.4143) * (p->r + 1.4143), r2 = p->r * p->r;
    ptrdiff_t off[LB_Q];
    for (int q = 0; q < LB_Q; q++) {
        off[q] = grid_offset(g, lb_c[q][0], lb_c[q][1], lb_c[q][2]);
    }
    /* the list in locals while it grows: the lists of all spheres sit side by
     * side, and threads writing their counts would share cache lines */
    sphere_link_t *links = list->l;
    size_t nl = 0, cap = list->cap;
    int lo[3], hi[3];
    for (int a = 0; a < 3; a++) {
        lo[a] = box_first(p, a);
        hi[a] = (int)ceil(p->c[a] + p->r) + 1;
    }
    memcpy(list->box_lo, lo, sizeof lo);
    int X[3], Y[3];
    for (X[2] = lo[2]; X[2] <= hi[2]; X[2]++) {
        for (X[1] = lo[1]; X[1] <= hi[1]; X[1]++) {
            /* the row's cells within reach but not inside k lie in two
             * intervals about c_k: visit those and a cell more on each side
             * (the test below decides, so the links are the same) */
            const double e = (X[1] - p->c[1]) * (X[1] - p->c[1]) + (X[2] - p->c[2]) * (X[2] - p->c[2]);
            if (e > reach2 + 1.0) {
                continue;
            }
            const double wi = e < r2 ? sqrt(r2 - e) : -2.0;
            int x0, x1;
            spheres_row_span(p->c[0], sqrt(fmax(reach2 - e, 0.0)), lo[0], hi[0], &x0, &x1);
            const int skip0 = (int)ceil(p->c[0] - wi) + 1, skip1 = (int)floor(p->c[0] + wi) - 1;
            for (X[0] = x0; X[0] <= x1; X[0]++) {
                if (X[0] == skip0 && skip0 <= skip1) {
                    X[0] = skip1; /* the cells in between are inside k by a cell or more */
                    continue;
                }
                /* the box is about c_k, so X - c_k is the minimum image */
                const double dk[3] = {X[0] - p->c[0], X[1] - p->c[1], X[2] - p->c[2]};
                const double dd = dk[0] * dk[0] + dk[1] * dk[1] + dk[2] * dk[2];
                if (dd > reach2 || dd <= r2) {
                    continue; /* no ray of length <= sqrt 2 from here reaches k; or inside k (solid) */
                }
                if (spheres_locate(sp->lo, sp->nb, sp->open, sp->periodic, sp->N, X, Y) != 1) {
                    continue; /* beyond a wall, or another rank's cell: its links are built there */
                }
                const size_t i = grid_index(g, Y[0], Y[1], Y[2]);
                if ((cellflags_get(flags, i) & ~(unsigned)FLAG_FRESH) != 0) {
                    continue; /* solid or ghost */
                }
                int inner = 1, deep = 1; /* all neighbours (and theirs) inside the grid: no wrap needed */
                for (int a = 0; a < 3; a++) {
                    inner = inner && Y[a] > 1 && Y[a] < g->n[a];
                    deep = deep && Y[a] > 2 && Y[a] < g->n[a] - 1;
                }
                /* bit q: x_f + c_q is solid; gathered without a branch per
                 * direction (solid or not is what a predictor cannot guess) */
                uint32_t solid = 0;
                if (inner) {
                    for (int q = 1; q < LB_Q; q++) {
                        solid |= (uint32_t)((cellflags_get(flags, (size_t)((ptrdiff_t)i + off[q])) & FLAG_SOLID) != 0)
                                 << q;
                    }
                } else {
                    for (int q = 1; q < LB_Q; q++) {
                        int B[3], W[3];
                        for (int a = 0; a < 3; a++) {
                            B[a] = Y[a] + lb_c[q][a] + sp->lo[a];
                        }
                        /* a neighbour: in the block or its ghost layer, whose
                         * flags mark_sphere set as the owner's */
                        if (spheres_locate(sp->lo, sp->nb, sp->open, sp->periodic, sp->N, B, W)) {
                            solid |= (uint32_t)((cellflags_get(flags, grid_index(g, W[0], W[1], W[2])) & FLAG_SOLID) != 0)
                                     << q;
                        }
                    }
                }
                /* the candidates a ray of length <= sqrt 2 from this cell can
                 * reach (the same for every q), in increasing index */
                int within = 0;
                const int nn = solid != 0 ? near_candidates(sp, dk, o, &within) : 0;
                /* the rays to k of all the cell's links first (in increasing
                 * q, as the keys want): independent of each other, where one
                 * link at a time waited on each square root and division */
                int qs[LB_Q], nq = 0;
                double dl[LB_Q];
                for (; solid != 0; solid &= solid - 1) {
                    qs[nq++] = __builtin_ctz(solid);
                }
                spheres_rays(dk, qs, nq, p->r, dl);
                const size_t nl_first = nl;
                int linked = 0;
                for (int jq = 0; jq < nq; jq++) {
                    const int q = qs[jq];
                    /* Eq. 5: the nearest intersection over the candidates wins
                     * (ties to the lower index); a link of k must hit k first */
                    const double xb[3] = {Y[0] + sp->lo[0] + lb_c[q][0], Y[1] + sp->lo[1] + lb_c[q][1],
                                          Y[2] + sp->lo[2] + lb_c[q][2]};
                    const double delta = link_delta(sp, k, q, dl[jq], o, nn, xb, dk);
                    if (delta <= 0.0) {
                        continue; /* another sphere's link */
                    }
                    if (!spheres_grow((void **)&links, &cap, nl + 1, sizeof *links)) {
                        list->l = links;
                        list->cap = cap;
                        list->n = nl;
                        return 0;
                    }
                    sphere_link_t *l = &links[nl++];
                    l->key = link_key(X, q);
                    l->has_pre = 0;
                    l->q = (uint8_t)q;
                    l->sphere = k;
                    l->xf = l->xff = l->xfff = i; /* xff, xfff: replaced where they exist */
                    /* uncovered this step: refill.c replaced its populations, it has no
                     * pre-collision ones, and its links go without the multireflection
                     * correction for this one step (with it, a moving sphere's drag
                     * fluctuated 16 times more) */
                    l->fresh = (cellflags_get(flags, i) & FLAG_FRESH) != 0;
                    /* written after the exchange: a cell of an outer row (fluid.c step_overlapped) */
                    l->outer = Y[1] < 2 || Y[1] > g->n[1] - 1 || Y[2] < 2 || Y[2] > g->n[2] - 1;
                    const int have_ff = fluid_at(sp, g, flags, Y, deep, i, off[q], q, 1, &l->xff);
                    const int have_fff = have_ff && fluid_at(sp, g, flags, Y, deep, i, off[q], q, 2, &l->xfff);
                    l->have = (uint8_t)(have_ff | have_fff << 1);
                    if (!have_ff) {
                        /* x_f - 2 c_q is not read: its slot holds a pinched pair's partner */
                        l->have |= (uint8_t)pinched(sp, g, flags, X, q, dk, o, &l->xfff);
                    }
                    l->film = link_film(sp, k, q, dk, delta, o, &l->film_tie);
                    fresh_set |= l->fresh;
                    linked = 1;
                }
                if (linked && !note_near(list, nl_first, within)) {
                    checked = 0;
                }
            }
        }
    }
    list->l = links;
    list->cap = cap;
    list->n = nl;
    carry_in(list);
    others_note_checked(sp, list, o, checked, fresh_set);
    return 1;
}

/* 1 when a link with this key is in the list (its keys increase). */
static int list_has_key(const link_list_t *list, uint64_t key)
{
    size_t lo = 0, hi = list->n;
    while (lo < hi) {
        const size_t mid = lo + (hi - lo) / 2;
        if (list->l[mid].key < key) {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    return lo < list->n && list->l[lo].key == key;
}

/* After the rebuilt spheres' lists (dirty) and the others refreshed: 1 when
 * every link a rebuilt sphere had and no longer has is gone for good (its
 * fluid cell now solid, or its solid cell fluid) or is now another sphere's
 * (found in that sphere's list). A link that went to a refreshed sphere
 * without being found there would be lost (a refresh adds no link), so 0
 * then: all lists are to be built anew. */
static int handovers_found(spheres_t *sp, const grid_t *g, const uint8_t *flags, const uint8_t *dirty)
{
    for (int m = 0; m < sp->n; m++) {
        const link_list_t *list = &sp->lists[m];
        if (!dirty[m]) {
            continue;
        }
        size_t j = 0;
        for (size_t o = 0; o < list->nold; o++) {
            const uint64_t key = list->oldkey[o];
            while (j < list->n && list->l[j].key < key) {
                j++;
            }
            if (j < list->n && list->l[j].key == key) {
                continue; /* still m's */
            }
            int X[3], Y[3], B[3], W[3];
            spheres_key_cell(key, X);
            const int q = (int)(key & 31);
            for (int a = 0; a < 3; a++) {
                B[a] = X[a] + lb_c[q][a];
            }
            if (spheres_locate(sp->lo, sp->nb, sp->open, sp->periodic, sp->N, X, Y) != 1 ||
                !spheres_locate(sp->lo, sp->nb, sp->open, sp->periodic, sp->N, B, W)) {
                return 0;
            }
            if ((cellflags_get(flags, grid_index(g, Y[0], Y[1], Y[2])) & ~(unsigned)FLAG_FRESH) != 0 ||
                (cellflags_get(flags, grid_index(g, W[0], W[1], W[2])) & FLAG_SOLID) == 0) {
                continue; /* no link there any more */
            }
            int found = 0;
            for (int k = 0; k < sp->n && !found; k++) {
                found = k != m && list_has_key(&sp->lists[k], key);
            }
            if (!found) {
                return 0;
            }
        }
    }
    return 1;
}

/* Keeps the keys of a list about to be rebuilt (handovers_found). */
static int keep_old_keys(link_list_t *list)
{
    if (!spheres_grow((void **)&list->oldkey, &list->capold, list->n + 1, sizeof *list->oldkey)) {
        return 0;
    }
    for (size_t n = 0; n < list->n; n++) {
        list->oldkey[n] = list->l[n].key;
    }
    list->nold = list->n;
    return 1;
}

/* Work (changed cells x spheres) beyond which every list is built anew
 * rather than the spheres near a changed cell sought. */
#define DIRTY_WORK 4000000.0

/* The spheres whose lists are to be built anew (sp->dirty): a changed cell
 * within reach of the sphere's links (x_f within r + sqrt 2 of its centre,
 * x_f + c_q, x_f - c_q and x_f - 2 c_q within r + 3 sqrt 2 = r + 4.25;
 * r + 4.5 taken), or its box moved. Their count. */
static int find_dirty(spheres_t *sp)
{
    int ndirty = 0;
    const int all = (double)sp->nchanged * sp->n > DIRTY_WORK;
    for (int k = 0; k < sp->n; k++) {
        const sphere_t *p = &sp->s[k];
        int d = all;
        for (int a = 0; a < 3 && !d; a++) {
            d = box_first(p, a) != sp->lists[k].box_lo[a];
        }
        const double reach2 = (p->r + 4.5) * (p->r + 4.5);
        for (size_t j = 0; j < sp->nchanged && !d; j++) {
            const double x[3] = {sp->changed[j][0], sp->changed[j][1], sp->changed[j][2]};
            double e[3];
            spheres_min_image(sp, x, p->c, e);
            d = e[0] * e[0] + e[1] * e[1] + e[2] * e[2] <= reach2;
        }
        sp->dirty[k] = (uint8_t)d;
        ndirty += d;
    }
    return ndirty;
}

/* Every sphere's links, in parallel over spheres: each list is its own, so
 * the lists (and the loads summed from them) do not depend on the threads. */
status_t spheres_build_links(spheres_t *sp, const grid_t *g, uint8_t *flags, int keep, const log_t *log)
{
    int failed = -1;
    const int ndirty = keep ? find_dirty(sp) : sp->n;
    if (ndirty < sp->n) {
        const int unchanged = ndirty == 0;
        const uint8_t *dirty = sp->dirty;
        /* no flag changed (or only near the dirty spheres): each list refreshed
         * in place, the dirty ones built anew; one link that changed hands
         * (any sphere's) and all are built anew */
        int kept = 1;
#pragma omp parallel
        {
            others_t o;
            const int have = others_alloc(&o, sp->n);
#pragma omp for schedule(dynamic, 1) reduction(&& : kept)
            for (int k = 0; k < sp->n; k++) {
                if (!have) {
                    kept = 0;
                } else if (dirty[k]) {
                    /* out of memory: the rebuild of all below reports it */
                    kept = kept && keep_old_keys(&sp->lists[k]) && sphere_links(sp, g, flags, k, &o, &sp->lists[k]);
                } else {
                    kept = kept && sphere_refresh(sp, flags, k, &o, &sp->lists[k]);
                }
            }
            others_free(&o);
        }
        if (kept && !unchanged) {
            kept = handovers_found(sp, g, flags, dirty);
        }
        if (kept) {
            if (unchanged) {
                sp->refreshed++;
            } else {
                sp->partial++;
                sp->nlinks = 0;
                for (int k = 0; k < sp->n; k++) {
                    sp->nlinks += sp->lists[k].n;
                }
            }
            return STATUS_OK;
        }
        if (unchanged) {
            sp->refresh_failed++;
        } else {
            sp->partial_failed++;
        }
    }
#pragma omp parallel
    {
        others_t o;
        const int have = others_alloc(&o, sp->n);
#pragma omp for schedule(dynamic, 1)
        for (int k = 0; k < sp->n; k++) {
            if (!have || !sphere_links(sp, g, flags, k, &o, &sp->lists[k])) {
#pragma omp critical(spheres_links_failed)
                failed = k;
            }
        }
        others_free(&o);
    }
    sp->carried = 0;
    sp->nlinks = 0;
    for (int k = 0; k < sp->n; k++) {
        sp->nlinks += sp->lists[k].n;
    }
    if (failed >= 0) {
        return log_msg(log, STATUS_ERROR, "fluid",
                       "out of memory for the boundary links of sphere %d (%zu links of %zu bytes so far)", failed,
                       sp->lists[failed].n + 1, sizeof(sphere_link_t));
    }
    return STATUS_OK;
}
