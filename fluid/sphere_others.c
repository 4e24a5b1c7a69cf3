/* sphere_others.c — the other spheres near one sphere (sphere_others.h):
 * which they are, their film partners, and what a refresh keeps of them. */
#include "sphere_others.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Spheres whose rays from cells near sphere k can hit first: a link of k
 * starts within r_k + sqrt(2) of c_k and one of m within r_m + sqrt(2) of
 * c_m (|c_q| <= sqrt 2), so |c_k - c_m| < r_k + r_m + 3 takes in all; and
 * the film partners of k's wall points, within r_k + r_m + the cut-off. */
static int candidates(const spheres_t *sp, int k, int *out)
{
    int n = 0;
    for (int m = 0; m < sp->n; m++) {
        double d[3];
        spheres_min_image(sp, sp->s[k].c, sp->s[m].c, d);
        const double reach = sp->s[k].r + sp->s[m].r + fmax(3.0, sp->film_cutoff + 1.5);
        if (d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < reach * reach) {
            out[n++] = m;
        }
    }
    return n;
}

/* The gap between sphere k's wall point rw (relative to c_k) and face f:
 * the faces lie half a cell beyond the first and last cells, X = 0.5 and
 * N + 0.5. */
static double face_gap(const spheres_t *sp, int k, const double rw[3], int f)
{
    const int a = f / 2;
    const double x = sp->s[k].c[a] + rw[a];
    return f % 2 == 0 ? x - 0.5 : sp->N[a] + 0.5 - x;
}

/* The gap between sphere k's wall point rw and sphere m whose centre lies
 * at rel from c_k. */
static double sphere_gap(const sphere_t *m, const double rw[3], const double rel[3])
{
    const double d[3] = {rw[0] + rel[0], rw[1] + rel[1], rw[2] + rel[2]};
    return sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) - m->r;
}

/* The film zone (README "Lubrication"). Below the cut-off h_c the rigid
 * component adds the film force of the whole region where the surfaces are
 * closer than h_c: in lubrication theory (Reynolds) the pressure under
 * sphere k at distance rho from the line of centres is 3 mu reff V / h(rho)^2
 * with h = h_0 + rho^2 / (2 reff), and its integral over h < h_c is exactly
 * 6 pi mu reff^2 V (1/h_0 - 1/h_c), the correction of rigid/lubrication.c.
 * The lattice's own normal force on that region is what a row of nodes in
 * the gap, or none, makes of a film it cannot resolve: it is left out (the
 * normal part of the links whose wall point lies within h_c of the partner's
 * surface), so that the force does not depend on where the gap sits in the
 * cell and nothing is counted twice. The partner of a wall point: the
 * nearest surface within h_c of another body's sphere or of a face with a
 * film; -1 none, m a sphere, -2 - f face f. Only the links of free
 * spheres have a zone: the rigid component moves fixed and prescribed
 * bodies with no film of their own against a wall or each other, and
 * their load is the output's, so that a prescribed sphere driven at a
 * no-slip wall lost the zone's normal force with nothing in its place
 * (radius 5: 0.28 of Brenner's force at gap/a 0.1, 0.84 without a zone). */
int others_film_partner(const spheres_t *sp, int k, const double rw[3], const int *cand, double (*rel)[3],
                        int nc, uint8_t *tie)
{
    const sphere_t *p = &sp->s[k];
    double best = sp->film_cutoff;
    int partner = -1;
    *tie = 0;
    if (!(best > 0.0) || p->motion != MOTION_FREE) {
        return -1;
    }
    for (int c = 0; c < nc; c++) {
        const sphere_t *m = &sp->s[cand[c]];
        if (m->body == p->body) {
            continue; /* one rigid body: no film between its spheres */
        }
        const double gap = sphere_gap(m, rw, rel[c]);
        if (gap < best) {
            best = gap;
            partner = cand[c];
        }
    }
    for (int f = 0; f < 6; f++) {
        const double gap = face_gap(sp, k, rw, f);
        if (sp->film_face[f] && gap < best) {
            best = gap;
            partner = -2 - f;
        }
    }
    if (partner == -1) {
        return -1;
    }
    /* another partner as near: the point is shared (others_film_normals) */
    int near = 0;
    for (int c = 0; c < nc; c++) {
        near += sp->s[cand[c]].body != p->body && fabs(sphere_gap(&sp->s[cand[c]], rw, rel[c]) - best) <= FILM_TIE;
    }
    for (int f = 0; f < 6; f++) {
        near += sp->film_face[f] && fabs(face_gap(sp, k, rw, f) - best) <= FILM_TIE;
    }
    *tie = near > 1;
    return partner;
}

/* A wall point as near several film partners (to FILM_TIE cells, for the
 * rounding of mirrored points) lies on a mirror plane between them: the
 * bisector of an edge of two walls (three at a corner), or between two
 * spheres placed alike about sphere k. The first partner in index and axis
 * order took it whole, so its normal part went along one normal and the
 * mirror image of the scene gave another load (a sphere moving along the
 * bisector of an edge, radius 5: 1.4% more along the later axis; the middle
 * sphere of three approaching each other in a triangle: 13% between the two
 * mirrored components, README "Lubrication"). Each of them now takes an
 * equal share. The unit normals of those partners (the line of centres, a
 * face's axis), at most max: how many. */
int others_film_normals(const spheres_t *sp, int k, const double rw[3], double (*n)[3], int max)
{
    const sphere_t *p = &sp->s[k];
    double best = sp->film_cutoff;
    for (int pass = 0, cnt = 0; pass < 2; pass++) {
        for (int m = 0; m < sp->n; m++) {
            if (sp->s[m].body == p->body) {
                continue;
            }
            double rel[3];
            spheres_min_image(sp, p->c, sp->s[m].c, rel);
            const double gap = sphere_gap(&sp->s[m], rw, rel);
            if (pass == 0) {
                best = fmin(best, gap);
            } else if (fabs(gap - best) <= FILM_TIE && cnt < max) {
                const double len = sqrt(rel[0] * rel[0] + rel[1] * rel[1] + rel[2] * rel[2]);
                for (int a = 0; a < 3; a++) {
                    n[cnt][a] = rel[a] / len;
                }
                cnt++;
            }
        }
        for (int f = 0; f < 6; f++) {
            if (!sp->film_face[f]) {
                continue;
            }
            const double gap = face_gap(sp, k, rw, f);
            if (pass == 0) {
                best = fmin(best, gap);
            } else if (fabs(gap - best) <= FILM_TIE && cnt < max) {
                n[cnt][0] = n[cnt][1] = n[cnt][2] = 0.0;
                n[cnt][f / 2] = 1.0;
                cnt++;
            }
        }
        if (pass == 1) {
            return cnt;
        }
    }
    return 0;
}

/* 0 when no wall point of sphere k (at r_k from c_k) can have a film
 * partner: every other body's sphere and every face with a film farther
 * than the cut-off (and 1e-6 cells, for the rounding of the wall points);
 * film_partner would give -1 for each of its links. */
static int film_possible(const spheres_t *sp, int k, const int *cand, double (*rel)[3], int nc)
{
    const sphere_t *p = &sp->s[k];
    const double reach = sp->film_cutoff + 1e-6;
    if (!(sp->film_cutoff > 0.0) || p->motion != MOTION_FREE) {
        return 0;
    }
    for (int c = 0; c < nc; c++) {
        const sphere_t *m = &sp->s[cand[c]];
        const double d = sqrt(rel[c][0] * rel[c][0] + rel[c][1] * rel[c][1] + rel[c][2] * rel[c][2]);
        if (m->body != p->body && d - p->r - m->r < reach) {
            return 1;
        }
    }
    for (int a = 0; a < 3; a++) {
        if ((sp->film_face[2 * a] && p->c[a] - p->r - 0.5 < reach) ||
            (sp->film_face[2 * a + 1] && sp->N[a] + 0.5 - (p->c[a] + p->r) < reach)) {
            return 1;
        }
    }
    return 0;
}


int others_alloc(others_t *o, int n)
{
    const size_t m = (n > 0 ? (size_t)n : 1) + SELF_IMAGES_MAX;
    o->cand = malloc(m * sizeof *o->cand);
    o->rel = malloc(m * sizeof *o->rel);
    o->near = malloc(m * sizeof *o->near);
    o->dnear = malloc(m * sizeof *o->dnear);
    return o->cand != NULL && o->rel != NULL && o->near != NULL && o->dnear != NULL;
}

void others_free(others_t *o)
{
    free(o->cand);
    free(o->rel);
    free(o->near);
    free(o->dnear);
}


/* The other spheres near sphere k (candidates without k itself), their
 * centres relative to c_k, and whether its wall points can have a film.
 * On a periodic axis shorter than the reach of k's links on both sides
 * (N < 2 (r + sqrt 2)) a cell can be within reach of two images of k:
 * its box then holds the cell twice (X and X -+ N), and each visit tests
 * its links against one image. Those other images of k follow the others
 * (candidate k, centre c_k + s N: rel = -s N), so that a link goes to the
 * image its ray hits first, from that image's visit alone. Without them a
 * sphere of radius 1.6 in a 4-cell periodic slab had links counted twice
 * (a ray that misses its own image took delta 1 beside the image's real
 * link): its drag came out 22% above that of the same flow on 8 cells
 * with the image as a second sphere. */
void others_find(const spheres_t *sp, int k, others_t *o)
{
    const int nc = candidates(sp, k, o->cand);
    o->nc = 0;
    for (int c = 0; c < nc; c++) {
        if (o->cand[c] != k) {
            spheres_min_image(sp, sp->s[k].c, sp->s[o->cand[c]].c, o->rel[o->nc]);
            o->cand[o->nc++] = o->cand[c];
        }
    }
    o->film = film_possible(sp, k, o->cand, o->rel, o->nc);
    int span[3];
    for (int a = 0; a < 3; a++) {
        span[a] = sp->periodic[a] && sp->N[a] < 2.0 * (sp->s[k].r + 1.4143);
    }
    for (int sz = -span[2]; sz <= span[2]; sz++) {
        for (int sy = -span[1]; sy <= span[1]; sy++) {
            for (int sx = -span[0]; sx <= span[0]; sx++) {
                if (sx != 0 || sy != 0 || sz != 0) {
                    o->rel[o->nc][0] = -(double)sx * sp->N[0];
                    o->rel[o->nc][1] = -(double)sy * sp->N[1];
                    o->rel[o->nc][2] = -(double)sz * sp->N[2];
                    o->cand[o->nc++] = k;
                }
            }
        }
    }
}


/* After every link of a list was checked (built or refreshed in full): the
 * others near it and their centres now, for the refreshes that check only
 * the near cells (sphere_refresh); room for those alone (a list with room
 * for every sphere would take memory growing with their number squared). */
void others_note_checked(const spheres_t *sp, link_list_t *list, const others_t *o, int checked, int fresh_set)
{
    const size_t need = ((size_t)o->nc + 8) / 8 * 8;
    if (need > list->capcand) {
        int *c = realloc(list->cand, need * sizeof *list->cand);
        list->cand = c != NULL ? c : list->cand;
        double(*cc)[3] = c != NULL ? realloc(list->cand_c, need * sizeof *list->cand_c) : NULL;
        list->cand_c = cc != NULL ? cc : list->cand_c;
        list->capcand = c != NULL && cc != NULL ? need : 0;
    }
    if (need > list->capcand) {
        checked = 0; /* out of memory: the next refresh checks every cell */
    }
    list->ncand = checked ? o->nc : 0;
    for (int c = 0; c < list->ncand; c++) {
        list->cand[c] = o->cand[c];
        memcpy(list->cand_c[c], sp->s[o->cand[c]].c, sizeof list->cand_c[c]);
    }
    list->checked = checked;
    list->film_set = o->film;
    list->fresh_set = fresh_set;
}

/* 1 when only the near cells of list need checking: the others near k
 * are the same as when all its links were, none has moved by
 * SPHERES_NEAR_MARGIN since, and no link has or can have a film partner.
 * Then a far cell has no other sphere within a ray's reach, so its links
 * are k's as they were (a link changes hands only to a sphere within
 * reach of its cell), its cell is still fluid and its solid neighbour
 * still inside k (else a flag changed near k, and find_dirty has it built
 * anew), and its wall distance is k's own ray (spheres_link_delta). */
int others_near_check_holds(const spheres_t *sp, const link_list_t *list, const others_t *o)
{
    if (!list->checked || list->film_set || o->film || o->nc != list->ncand) {
        return 0;
    }
    for (int c = 0; c < o->nc; c++) {
        double d[3];
        if (o->cand[c] != list->cand[c]) {
            return 0;
        }
        spheres_min_image(sp, sp->s[o->cand[c]].c, list->cand_c[c], d);
        if (!(d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < SPHERES_NEAR_MARGIN * SPHERES_NEAR_MARGIN)) {
            return 0;
        }
    }
    return 1;
}
