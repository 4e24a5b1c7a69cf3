/* sphere_others.h — the other spheres near one sphere (sphere_links.c): the
 * ones whose rays from its cells can hit first (the nearest hit of Eq. 5
 * takes a link), the images of the sphere itself on a short periodic axis,
 * the film partners of its wall points (README "Lubrication"), and whether a
 * refresh may check only the cells near them. The tests of single links are
 * inline here: the links' build and refresh ask them for every link. */
#ifndef FLUID_SPHERE_OTHERS_H
#define FLUID_SPHERE_OTHERS_H

#include "spheres_internal.h"

#include "lattice.h"

#include <string.h>

/* The other spheres near sphere k, which its links' rays and wall points
 * are tested against; per thread, room for every sphere (others_alloc). */
typedef struct {
    int *cand;          /* the other spheres within reach of k (candidates), increasing */
    double (*rel)[3];   /* their centres relative to c_k (minimum image) */
    int *near;          /* of one cell: those a ray of length sqrt 2 can reach (indices into cand) */
    double (*dnear)[3]; /* and their centres relative to that cell */
    int nc, film;       /* how many; 1 when a wall point of k can have a film partner */
} others_t;

/* At most 26 images of sphere k itself besides k (others_find). */
enum { SELF_IMAGES_MAX = 26 };

/* Room in o for n spheres and the images of one (0 when out of memory);
 * others_free releases it. */
int others_alloc(others_t *o, int n);
void others_free(others_t *o);
/* The other spheres near sphere k into o (others_find, sphere_others.c). */
void others_find(const spheres_t *sp, int k, others_t *o);
/* The film partner of sphere k's wall point rw (relative to c_k) among the
 * nc candidates cand at rel: -1 none, m a sphere, -2 - f face f; *tie: 1
 * when another partner is as near (to FILM_TIE cells). */
int others_film_partner(const spheres_t *sp, int k, const double rw[3], const int *cand, double (*rel)[3], int nc,
                        uint8_t *tie);
/* Partners whose gaps differ by at most this (cells) are as near. */
#define FILM_TIE 1e-12
/* The most partners a wall point shares (others_film_normals). */
enum { FILM_TIES_MAX = 8 };
/* Of a wall point with a tie, the unit normals of all its nearest
 * partners, at most max: how many; they share its normal part (sphere_fill.c). */
int others_film_normals(const spheres_t *sp, int k, const double rw[3], double (*n)[3], int max);
/* After every link of a list was checked: what a later refresh needs to
 * check only the near cells (others_near_check_holds). */
void others_note_checked(const spheres_t *sp, link_list_t *list, const others_t *o, int checked, int fresh_set);
int others_near_check_holds(const spheres_t *sp, const link_list_t *list, const others_t *o);

/* The film partner of a link's wall point (dk: x_f - c_k; delta, its own
 * ray's: link_delta), the wall point as the fill derives it. */
static inline int link_film(const spheres_t *sp, int k, int q, const double dk[3], double delta, const others_t *o,
                            uint8_t *tie)
{
    *tie = 0;
    if (!o->film) {
        return -1;
    }
    double rw[3];
    spheres_wall_point(dk, delta, q, rw);
    return others_film_partner(sp, k, rw, o->cand, o->rel, o->nc, tie);
}


/* Of two rays that hit at the same distance, the one of candidate c wins
 * over sphere k's own: a lower sphere index, or for an image of k itself
 * the visit of the same cell with the lower key (link_key: z, then y, then
 * x), which is this one shifted by -rel: so c wins when rel's first
 * non-zero component in that order is positive. Both visits thus agree. */
static inline int wins_tie(const others_t *o, int c, int k)
{
    if (o->cand[c] != k) {
        return o->cand[c] < k;
    }
    for (int a = 2; a >= 0; a--) {
        if (o->rel[c][a] != 0.0) {
            return o->rel[c][a] > 0.0;
        }
    }
    return 0;
}


/* How far (cells) the other spheres may move before a refresh checks all
 * the links of a sphere again (sphere_refresh): the cells within this of
 * a ray's reach of another sphere are checked at every refresh. */
#define SPHERES_NEAR_MARGIN 0.5

/* The others a ray of length sqrt 2 from a cell at dk from c_k can reach
 * (the same for every q), in increasing index: their count. *within (unless
 * NULL): 1 when one is within SPHERES_NEAR_MARGIN of that reach too. */
static inline int near_candidates(const spheres_t *sp, const double dk[3], others_t *o, int *within)
{
    int nn = 0, w = 0;
    for (int c = 0; c < o->nc; c++) {
        const double dm[3] = {dk[0] + o->rel[c][0], dk[1] + o->rel[c][1], dk[2] + o->rel[c][2]};
        const double rm = sp->s[o->cand[c]].r + 1.4143, rw = rm + SPHERES_NEAR_MARGIN;
        const double d2 = dm[0] * dm[0] + dm[1] * dm[1] + dm[2] * dm[2];
        if (d2 <= rm * rm) {
            memcpy(o->dnear[nn], dm, sizeof dm);
            o->near[nn++] = c;
        }
        w = w || d2 <= rw * rw;
    }
    if (within != NULL) {
        *within = w;
    }
    return nn;
}

/* Eq. 5 for a link of sphere k along c_q whose own ray gave dq, from a
 * cell with nn near others (near_candidates): its delta, 0 when another
 * near sphere's ray hits first (ties to the lower
 * index), or -1 when no ray hits and x_b (global coordinates xb) is nearest
 * to another sphere's surface. */
static inline double link_delta(const spheres_t *sp, int k, int q, double dq, const others_t *o, int nn,
                         const double xb[3], const double dk[3])
{
    double delta = dq;
    for (int j = 0; j < nn; j++) {
        const int c = o->near[j];
        double t;
        spheres_rays(o->dnear[j], &q, 1, sp->s[o->cand[c]].r, &t);
        if (t > 0.0 && (delta == 0.0 || t < delta || (t == delta && wins_tie(o, c, k)))) {
            return 0.0; /* another sphere's link, or another image's of k */
        }
    }
    if (delta == 0.0) {
        /* no ray hits: x_b sits on a surface the ray only touches at t = 1;
         * the link of the visit whose image of k is nearest to x_b (dk +
         * c_q its minimum image), so that a cell seen twice has it once */
        for (int a = 0; a < 3; a++) {
            const double b = dk[a] + lb_c[q][a];
            if (sp->periodic[a] && !(b > -0.5 * sp->N[a] && b <= 0.5 * sp->N[a])) {
                return -1.0;
            }
        }
        double d[3];
        return spheres_nearest(sp, xb, d) == k ? 1.0 : -1.0;
    }
    return delta;
}


#endif
