/* sphere_fill.c — the fill and the momentum exchange of the moving spheres
 * (spheres.h "fill"): for every link, the population the wall sends into
 * the fluid (boundary.c's scheme, the moving-wall term of Eq. 6 and the
 * multireflection correction), and the load it exchanges with the sphere
 * (Eq. 7), summed per cell in link order and then exactly per sphere; in
 * parallel over parts of the spheres' lists of links (sphere_links.c).
 *
 * Mass balance. A link takes f~_q(x_f) from the fluid and gives back f_new;
 * bounce-back gives f~_q(x_f) - 6 w_q rho c_q.u_w, the fluid the moving
 * surface displaces through the link's share of it. The continuum flux
 * through a rigidly moving surface is zero: the rotation's surface velocity
 * is tangential, and the translation's displaced fluid is what the cells it
 * covers and uncovers take back (bounce-back's term with v alone sums to
 * that, but for the density's variation, over a closed surface). The
 * interpolated schemes are not conservative (Kao & Yang, J. Comput. Phys.
 * 227 (2008) 5671; Bao, Yuan & Schaefer, J. Comput. Phys. 227 (2008) 8472,
 * who restore the balance by a correction of the boundary populations;
 * Sanjeevi, Zarghami & Padding, Phys. Rev. E 97 (2018) 043305, compare the
 * schemes' leaks): near tau = 1/2 the interpolation (a rotating sphere) and
 * multireflection's n^- correction (a translating one: with TRT, n^- holds
 * (1/omega^- - 1/2) times the inertial and unsteady terms, which its
 * closure does not expect) give a net that grew the fluid's mass without
 * bound (README "Known problems"). So each sphere keeps the mass its links
 * gave beyond -6 w_q rho c_q.v (v the sphere's velocity; a pinched pair's
 * own term, whose mass is bounce-back's by design) as a debt (the sum over
 * steps, over its links and ranks summed exactly with its load:
 * spheres_loads), and each fill takes part of it back through every link
 * in proportion to w_q (1 - 3 c_q.u_w): the population along -c_q of mass
 * that moves with the wall, so that on a closed surface it carries that
 * mass's momentum and nothing else (sum_links w_q c_q = 0) and leaves the
 * Galilean-invariant load unchanged. It is an integral controller on the
 * fluid's mass: the fill returns SPHERES_MASS_GAIN times the mean of the
 * last two debts. The links answer mass put into them with a weakly damped
 * echo that alternates every step (a fixed sphere at tau 1, cli: 12% taken
 * back in the next step, then given and taken in turn, 5% less each step);
 * returning each whole debt at once fed that echo back until it grew (one
 * of the six places of the drag test went to NaN), and the mean of two
 * steps does not see it. Gain 1 with the mean made a sphere rotating at
 * tau 0.51 oscillate; 1/2 leaves margin both ways. What a link gives within
 * a step stays, so the forces keep the scheme's accuracy; only the net is
 * returned. Bounce-back is left as it was (its net, the lattice's sum of
 * the rotation's term, is 2e-6 of the fluid's mass in 800 steps). */
#include "spheres_internal.h"

#include "boundary.h"
#include "sphere_others.h"
#include "lattice.h"

#include <math.h>
#include <omp.h>
#include <string.h>


/* links ahead at which spheres_fill prefetches a cell's populations */
#define FILL_AHEAD 12
/* links ahead at which it prefetches a link's own scattered values */
#define LINK_AHEAD 8
/* links ahead at which it prefetches the link records themselves */
#define RECORD_AHEAD 16
/* parts of the lists per thread (spheres_fill), and the fewest links in
 * a part: a part's first links go without their prefetches */
#define FILL_PARTS_PER_THREAD 4
#define FILL_PART_MIN 256
/* cells whose loads spheres_fill sums at once (12 x 8 x 256 bytes of stack) */
#define FILL_CHUNK 256

/* The links [n_begin, n_end) of a list (whole cells), their load added
 * to acc. */
static inline __attribute__((always_inline)) void fill_links(spheres_t *sp, const pops_t *f0,
                                                            const link_list_t *list, size_t n_begin, size_t n_end,
                                                            xsum_t acc[SPHERE_NACC], int galilean, double inv_decay,
                                                            spheres_part_t part, layout_state_t state, int single)
{
    const pops_t fl = pops_fixed(f0, state, single);
    const pops_t *f = &fl;
    /* where each q's post-collision value of cell 0 is (bytes): a cell's
     * value of q is then one add away (the cell prefetch and the density) */
    const size_t esz = single ? sizeof(float) : sizeof(double);
    const char *base = single ? (const char *)f->h : (const char *)f->f;
    const char *pb[LB_Q];
    for (int q = 0; q < LB_Q; q++) {
        /* (the moments layout has no slots of fluid cells: pb unused) */
        pb[q] = state == LAYOUT_MOMENTS ? base : base + esz * pops_post_slot(f, q, 0);
    }
    size_t cell = (size_t)-1;
    double rho = 0.0, j[3] = {0.0, 0.0, 0.0};
    /* the cell minus the centre (spheres_link_cell); the rays of the cell's
     * links from link n0 on */
    double dk[3] = {0.0, 0.0, 0.0}, ray[LB_Q];
    size_t n0 = 0;
    /* the load of a cell's links, summed in q order, then added exactly to
     * the sphere's (common/exact_sum.h): the same bits on any ranks. The
     * cells' loads wait in cb and go in FILL_CHUNK at a time, four terms at
     * a time (xsum_add_array: the same value as one xsum_add per term) */
    double cl[SPHERE_NACC] = {0.0};
    double cb[SPHERE_NACC][FILL_CHUNK];
    int ncb = 0;
    const sphere_t *p = n_end > n_begin ? &sp->s[list->l[n_begin].sphere] : NULL;
    /* the recovery of n^- from the post-collision populations (below) holds
     * away from omega_minus = 1 */
    const int use_decay = fabs(1.0 - sp->omega_minus) >= SPHERES_MR_DECAY_MIN;
    /* the momentum of x_f serves multireflection's correction only */
    const int need_j = sp->scheme == BOUNDARY_MULTIREFLECTION;
    /* the mass balance (top of file): the share of the debt per unit of
     * w_q (1 - 3 c_q.u_w) this fill returns */
    const int balance = sp->scheme != BOUNDARY_BOUNCE_BACK;
    const double give = p != NULL && balance && p->mass_weight > 0.0
                            ? -SPHERES_MASS_GAIN * 0.5 * (p->mass_debt + p->mass_debt_prev) / p->mass_weight
                            : 0.0;
    /* the schemes that may read x_f - 2 c_q */
    const int wide = sp->scheme == BOUNDARY_MULTIREFLECTION || sp->scheme == BOUNDARY_QUADRATIC;
    for (size_t n = n_begin; n < n_end; n++) {
        sphere_link_t *l = &list->l[n];
        const int q = l->q, o = lb_opposite(q);
        if (n == n_begin || !spheres_same_cell(l, l - 1)) { /* the links of a cell are consecutive (sphere_links) */
            if (n > n_begin) {
                for (int a = 0; a < SPHERE_NACC; a++) {
                    cb[a][ncb] = cl[a];
                    cl[a] = 0.0;
                }
                if (++ncb == FILL_CHUNK) {
                    for (int a = 0; a < SPHERE_NACC; a++) {
                        xsum_add_array(&acc[a], cb[a], ncb);
                    }
                    ncb = 0;
                }
            }
            cell = l->xf;
            spheres_link_cell(p, l->key, dk);
            /* side by side: independent square roots and divisions (one
             * link at a time, each waited on the one before) */
            int qs[LB_Q], nq = 0;
            for (size_t e = n; e < n_end && spheres_same_cell(&list->l[e], l) && nq < LB_Q; e++) {
                qs[nq++] = list->l[e].q;
            }
            spheres_rays(dk, qs, nq, p->r, ray);
            n0 = n;
            if (need_j || state == LAYOUT_MOMENTS) {
                rho = pops_moments(f, cell, j);
            } else {
                /* pops_moments' density: the same sum, in its order */
                rho = 0.0;
                const size_t cb0 = cell * esz;
#pragma GCC unroll 19
                for (int q = 0; q < LB_Q; q++) {
                    rho += single ? (double)*(const float *)(pb[q] + cb0) + lb_w[q] : *(const double *)(pb[q] + cb0);
                }
            }
        }
        /* the fill waits on memory (the 19 scattered values of a cell's
         * moments): fetch those of the cell FILL_AHEAD links on in advance */
        if (state != LAYOUT_MOMENTS && n + FILL_AHEAD < n_end &&
            list->l[n + FILL_AHEAD].xf != list->l[n + FILL_AHEAD - 1].xf) {
            const size_t ahead = list->l[n + FILL_AHEAD].xf * esz;
#pragma GCC unroll 19
            for (int qq = 0; qq < LB_Q; qq++) {
                __builtin_prefetch(pb[qq] + ahead, 0);
            }
        }
        /* the records stream in (72 bytes a link, one or two cache
         * lines), and the look-ahead below reads record n + LINK_AHEAD: with
         * its lines asked for before, the fill took 0.43-0.48 s where it took
         * 0.50-0.59 s (dual star, 200 steps, 168-byte records then; README
         * "Speed and memory") */
        if (n + RECORD_AHEAD < n_end) {
            const char *r = (const char *)&list->l[n + RECORD_AHEAD];
            __builtin_prefetch(r, 1);
            __builtin_prefetch(r + 64, 1);
            __builtin_prefetch(r + sizeof(sphere_link_t) - 1, 1);
        }
        /* and the link's own scattered values (x_f - c_q, x_f - 2 c_q and the
         * slot it writes) LINK_AHEAD links on: the fill is bound by their
         * latency, one miss after another without it */
        if (n + LINK_AHEAD < n_end) {
            const sphere_link_t *m = &list->l[n + LINK_AHEAD];
            const int mo = lb_opposite(m->q);
            pops_prefetch(f, pops_in_slot(f, mo, m->xf), 1);
            /* (a hint: where the coefficients may read x_f - 2 c_q, and
             * f~_qbar(x_f - c_q) with it, as boundary_coefficients gives them) */
            const int far = (m->have & 2) && wide;
            if (m->xff != m->xf && m->xff < SPHERE_EXT) {
                pops_prefetch(f, pops_post_slot(f, m->q, m->xff), 0);
                if (far) {
                    pops_prefetch(f, pops_post_slot(f, mo, m->xff), 0);
                }
            }
            if (far && m->xfff < SPHERE_EXT) {
                pops_prefetch(f, pops_post_slot(f, m->q, m->xfff), 0);
            }
        }
        /* the wall point and delta for the sphere's place now */
        double rw[3], wr[3], uw[3];
        const double delta = spheres_link_delta(ray[n - n0]);
        spheres_wall_point(dk, delta, q, rw);
        spheres_cross(p->w, rw, wr);
        for (int a = 0; a < 3; a++) {
            uw[a] = p->v[a] + wr[a];
        }
        const double cuw = lb_cd[q][0] * uw[0] + lb_cd[q][1] * uw[1] + lb_cd[q][2] * uw[2];
        double cu = cuw;
        if (l->have & SPHERES_PINCHED_SPHERE) {
            /* a pair pinched between this sphere's wall (velocity u_A) and
             * sphere m's (u_B, at the point half a link back): each side
             * sends back the pair's mean less 6 w rho c.(3/4 u_A - 1/4 u_B),
             * so that the pair moves at (u_A + u_B)/2 and its mass changes by
             * 6 w rho c.(u_B - u_A), bounce-back's (below) */
            const sphere_t *m = &sp->s[l->xfff];
            double rel[3], rb[3], wb[3];
            spheres_min_image(sp, p->c, m->c, rel); /* c_k - c_m */
            for (int a = 0; a < 3; a++) {
                rb[a] = dk[a] - 0.5 * lb_cd[q][a] + rel[a];
            }
            spheres_cross(m->w, rb, wb);
            double cub = 0.0;
            for (int a = 0; a < 3; a++) {
                cub += lb_cd[q][a] * (m->v[a] + wb[a]);
            }
            cu = 0.75 * cu - 0.25 * cub;
        }
        boundary_coef_t co;
        boundary_coefficients(sp->scheme, delta, l->have & 1, l->have >> 1 & 1, sp->omega_minus, &co);
        const double A = co.a[0] + co.a[1] + co.a[2];
        const double f_old = pops_post(f, q, l->xf);
        /* a pinched pair (x_f between two walls along c_q, sphere_links.c):
         * bounce-back of the pair's mean, as the other wall does (walls.c).
         * Bounce-back's moving-wall terms reach the mean of the two walls'
         * velocities as the steady state of the pair's swap, each side
         * undoing the other's reflection; with the swap gone, whole terms
         * give the pair their sum (the cells in the neck of a translating
         * dumbbell moved at twice its speed). Between two spheres each side
         * knows both velocities (cu above): the pair moves at their mean and
         * keeps bounce-back's mass (half terms lost mass wherever the two
         * moved apart: breakup_shear's fragments 4.6e-4 of the fluid's).
         * Against a domain wall each side keeps its whole term, the pair's
         * mass as with bounce-back (a sphere settling onto a floor lost 8e-4
         * of the fluid's mass with half terms), its velocity the sphere's
         * plus the wall's. */
        const int pinched = (l->have & SPHERES_PINCHED) != 0;
        const double f_back = pinched ? 0.5 * (f_old + pops_post(f, o, l->xf)) : f_old;
        /* the term's response to this sphere's own velocity (the drag coefficients below) */
        const double A_wall = (l->have & SPHERES_PINCHED_SPHERE) ? 0.75 * A : A;
        double f_new = co.a[0] * f_back - A * 6.0 * lb_w[q] * rho * cu;
        const int linear = co.a[1] != 0.0 || co.b[0] != 0.0 || co.b[1] != 0.0;
        const double f_ff = (linear || co.corr != 0.0) && l->xff != l->xf ? spheres_post(sp, f, q, l->xff) : 0.0;
        if (linear) {
            f_new += co.a[1] * f_ff + co.b[0] * pops_post(f, o, l->xf);
        }
        if (co.a[2] != 0.0) {
            f_new += co.a[2] * spheres_post(sp, f, q, l->xfff);
        }
        if (co.b[1] != 0.0) {
            f_new += co.b[1] * spheres_post(sp, f, o, l->xff);
        }
        if (co.corr != 0.0 && !l->fresh && (l->has_pre || use_decay)) {
            /* antisymmetric non-equilibrium of the pre-collision populations at x_f:
             * f_q came from x_f - c_q, f_qbar from the solid side, the very slot of this link.
             * It is taken against the pre-collision momentum j - F (Guo's collision adds
             * F to it), i.e. n^- + S^-/2 with S^- = 3 w c.F: the part that carries the
             * velocity's second derivatives. Against rho u = j - F/2 a forced Poiseuille
             * flow comes out 0.3% low in 12 cells (tau 1); against j - F it is exact to
             * round-off for every delta, tau and Lambda (checked with a 1D channel). */
            double nm;
            if (l->has_pre) {
                /* the pair the last fill kept */
                double cu0 = 0.0;
                for (int a = 0; a < 3; a++) {
                    cu0 += lb_cd[q][a] * (j[a] - sp->body_force[a]);
                }
                nm = 0.5 * (l->pre[0] - l->pre[1]) - 3.0 * lb_w[q] * cu0;
            } else {
                const double cj = lb_cd[q][0] * j[0] + lb_cd[q][1] * j[1] + lb_cd[q][2] * j[2];
                nm = (0.5 * (f_old - pops_post(f, o, l->xf)) - 3.0 * lb_w[q] * cj) * inv_decay;
            }
            f_new += co.corr * nm;
        }
        if (balance) {
            /* the debt's share, mass moving with the wall (w_q (1 - 3 c_q.u_w)
             * of an equilibrium at u_w along -c_q), and the mass the link
             * gives beyond bounce-back's flux of the translation (a pinched
             * pair: beyond its own term) */
            const double share = lb_w[q] * (1.0 - 3.0 * cuw);
            f_new += give * share;
            const double cv = pinched ? cu : lb_cd[q][0] * p->v[0] + lb_cd[q][1] * p->v[1] + lb_cd[q][2] * p->v[2];
            cl[10] += f_new - f_back + 6.0 * lb_w[q] * rho * cv;
            cl[11] += share;
        }
        if (co.corr != 0.0) {
            /* the pre-collision pair of x_f at the next fill: f~_q(x_f - c_q)
             * streams to x_f, f_new is what x_f receives from the wall */
            l->pre[0] = f_ff;
            l->pre[1] = f_new;
            l->has_pre = l->xff != l->xf;
        }
        if (part == SPHERES_HOLD_OUTER && l->outer) {
            l->fnew = f_new;
        } else {
            pops_write(f, o, pops_in_slot(f, o, l->xf), f_new);
        }
        /* Eq. 7 (Ladd), populations centred on the equilibrium of the
         * ambient density rho_a (the mean at the sphere's links outside the
         * film zone in the last step), so that a uniform pressure loads no
         * surface, closed or not: hidden faces of touching spheres, and the
         * faces of the cells a sphere touching a wall turns to the wall, have
         * no links. (Centred on the rest weight, rho_a 1, a fluid whose mean
         * density had drifted by -4.2e-5 while a sphere settled turned the
         * sphere resting on the floor at 1.4e-3 rad/s for good, through the
         * open face under it; its lateral place in the cell decided the
         * sense.) On a closed surface the sum of w_q c_q over the links
         * vanishes, so there the load is the same. Wen et al., Phys. Rev. E
         * 89 (2014) 023305, add -(f_old - f_new) u_w. */
        const double mem = f_old + f_new - 2.0 * lb_w[q] * p->rho_film;
        double df[3];
        for (int a = 0; a < 3; a++) {
            df[a] = lb_cd[q][a] * mem - (galilean ? (f_old - f_new) * uw[a] : 0.0);
        }
        if (l->film == -1) {
            cl[8] += rho;
            cl[9] += 1.0;
        } else {
            /* in the film zone: the normal part is the film's (sphere_links.c
             * film_partner), the film force (rigid/lubrication.c) being the
             * excess over the ambient pressure, which mem above leaves out
             * (left out whole with an ambient part, a raised pressure, an
             * outlet's, pushed a sphere into the wall by (rho_a - 1)/3 times
             * the area of the zone, and a lowered one off it) */
            double de[3]; /* the part to share out (df changes as it goes) */
            for (int a = 0; a < 3; a++) {
                de[a] = df[a];
            }
            double nt[FILM_TIES_MAX][3];
            const int nties = l->film_tie ? others_film_normals(sp, l->sphere, rw, nt, FILM_TIES_MAX) : 0;
            if (nties > 0) {
                /* a point as near several partners (a mirror plane between
                 * them) gives each an equal share of its normal part */
                for (int e = 0; e < nties; e++) {
                    const double dn = de[0] * nt[e][0] + de[1] * nt[e][1] + de[2] * nt[e][2];
                    for (int a = 0; a < 3; a++) {
                        df[a] -= dn * nt[e][a] / nties;
                    }
                }
            } else if (l->film >= 0) {
                double n[3];
                spheres_min_image(sp, p->c, sp->s[l->film].c, n);
                const double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
                for (int a = 0; a < 3; a++) {
                    n[a] /= len;
                }
                const double dn = de[0] * n[0] + de[1] * n[1] + de[2] * n[2];
                for (int a = 0; a < 3; a++) {
                    df[a] -= dn * n[a];
                }
            } else {
                const int a = (-2 - l->film) / 2;
                df[a] -= de[a];
            }
        }
        double t[3];
        spheres_cross(rw, df, t);
        for (int a = 0; a < 3; a++) {
            cl[a] += df[a];
            cl[3 + a] += t[a];
        }
        /* the moving-wall term makes df react at once to the wall velocity:
         * d(df)/d(u_w) = -A 6 w rho c c^T (3/4 A between two spheres'
         * pinched walls, as above); its isotropic parts for v and for
         * w (u_w = v + w x r_w, so c . u_w = c . v + w . (r_w x c)) */
        const double cq[3] = {lb_cd[q][0], lb_cd[q][1], lb_cd[q][2]};
        double rc[3];
        spheres_cross(rw, cq, rc);
        const double k = A_wall * 6.0 * lb_w[q] * rho / 3.0;
        cl[6] += k * lb_cc[q];
        cl[7] += k * (rc[0] * rc[0] + rc[1] * rc[1] + rc[2] * rc[2]);
    }
    if (p != NULL) {
        for (int a = 0; a < SPHERE_NACC; a++) {
            cb[a][ncb] = cl[a];
            xsum_add_array(&acc[a], cb[a], ncb + 1);
        }
    }
}

void spheres_fill(spheres_t *sp, const pops_t *f, spheres_part_t part)
{
    const int galilean = sp->force == FORCE_GALILEAN;
    /* n^- of the pre-collision populations from the post-collision ones. TRT
     * with Guo forcing gives f~^- = (1 - w-) f^- + w- e^- + (1 - w-/2) 3 w c.F,
     * e^- = 3 w c.(j + F/2), j the pre-collision momentum, and j~ = j + F, so
     * f~^- - 3 w c.j~ = (1 - w-)(f^- - 3 w c.j): exact, so that both layouts
     * give the same result, and it treats the initial state (an equilibrium)
     * as what it is, a state after a collision. Near w- = 1 the collision
     * forgets n^-. So each link keeps the pre-collision pair of its cell for
     * the next fill (sphere_link_t.pre), which is exact in either layout and
     * for any w-; the recovery serves a link new this step, and near w- = 1
     * such a link goes without the correction for that step. (Reading the
     * pair of a new link from the other array, which two arrays could, made
     * a fixed sphere's steady drag at w- = 1 depend on its first step and
     * creep, 2e-4 after 1500 steps: tests/fluid/test_layouts.c.) */
    const double inv_decay = 1.0 / (1.0 - sp->omega_minus);
    /* the lists in parts of about psize links (whole cells), in parallel
     * over the parts: a few spheres, or one, keep every thread busy. Each
     * part's load is summed apart and added to its sphere's after: exact
     * sums, so the same bits as a sphere at a time. (Parts of 1024 links:
     * the sinking sphere's fill 0.11 -> 0.07 ms a step on two threads, the
     * dual star's 1.74-1.83 -> 1.83-1.91 ms: a part's first links go
     * without their prefetches; so FILL_PARTS_PER_THREAD parts a thread.) */
    size_t nlinks = 0, nparts = 0;
    for (int k = 0; k < sp->n; k++) {
        nlinks += sp->lists[k].n;
    }
    const size_t want = (size_t)omp_get_max_threads() * FILL_PARTS_PER_THREAD;
    const size_t psize = nlinks / want > FILL_PART_MIN ? nlinks / want : FILL_PART_MIN;
    for (int k = 0; k < sp->n; k++) {
        nparts += sp->lists[k].n / psize + 1;
    }
    if (!spheres_grow((void **)&sp->parts, &sp->cap_parts, nparts, sizeof *sp->parts)) {
        nparts = 0; /* out of memory: a sphere at a time */
    } else {
        nparts = 0;
        for (int k = 0; k < sp->n; k++) {
            const link_list_t *list = &sp->lists[k];
            for (size_t b = 0; b < list->n;) {
                size_t e = b + psize < list->n ? b + psize : list->n;
                while (e < list->n && list->l[e].xf == list->l[e - 1].xf) {
                    e++;
                }
                spheres_fill_part_t *pt = &sp->parts[nparts++];
                pt->sphere = k;
                pt->begin = b;
                pt->end = e;
                b = e;
            }
        }
    }
    const int whole = nparts == 0;
    const int nwork = whole ? sp->n : (int)nparts;
#pragma omp parallel for schedule(dynamic, 1)
    for (int w = 0; w < nwork; w++) {
        const int k = whole ? w : sp->parts[w].sphere;
        const link_list_t *l = &sp->lists[k];
        const size_t b = whole ? 0 : sp->parts[w].begin, e = whole ? l->n : sp->parts[w].end;
        xsum_t *acc = whole ? sp->s[k].acc : sp->parts[w].acc;
        if (!whole) {
            for (int a = 0; a < SPHERE_NACC; a++) {
                xsum_zero(&acc[a]);
            }
        }
#define FILL(state, single) fill_links(sp, f, l, b, e, acc, galilean, inv_decay, part, state, single)
        POPS_SPECIALISE(f, FILL);
#undef FILL
    }
    for (size_t w = 0; w < (whole ? 0 : nparts); w++) {
        for (int a = 0; a < SPHERE_NACC; a++) {
            xsum_merge(&sp->s[sp->parts[w].sphere].acc[a], &sp->parts[w].acc[a]);
        }
    }
}

void spheres_write_outer(spheres_t *sp, const pops_t *f)
{
#pragma omp parallel for schedule(dynamic, 1)
    for (int k = 0; k < sp->n; k++) {
        const link_list_t *list = &sp->lists[k];
        for (size_t n = 0; n < list->n; n++) {
            const sphere_link_t *l = &list->l[n];
            if (l->outer) {
                const int o = lb_opposite(l->q);
                pops_write(f, o, pops_in_slot(f, o, l->xf), l->fnew);
            }
        }
    }
}

void spheres_loads(spheres_t *sp)
{
    /* every rank's part of each load (the links of its cells, the cells it
     * covered and uncovered), summed exactly: all ranks get the same load */
    const int parallel = decomp_parallel(sp->dc);
    if (parallel) {
        for (int k = 0; k < sp->n; k++) {
            memcpy(sp->accbuf + (size_t)k * SPHERE_NACC, sp->s[k].acc, sizeof sp->s[k].acc);
        }
        decomp_sum(sp->dc, sp->accbuf, SPHERE_NACC * sp->n);
    }
    for (int k = 0; k < sp->n; k++) {
        const xsum_t *a = parallel ? sp->accbuf + (size_t)k * SPHERE_NACC : sp->s[k].acc;
        sphere_t *p = &sp->s[k];
        for (int c = 0; c < 3; c++) {
            p->f[c] = xsum_value(&a[c]);
            p->t[c] = xsum_value(&a[3 + c]);
        }
        /* the mass balance (top of file): the net of this fill joins the debt */
        p->mass_debt_prev = p->mass_debt;
        p->mass_debt += xsum_value(&a[10]);
        p->mass_weight = xsum_value(&a[11]);
        p->zt = xsum_value(&a[6]);
        p->zr = xsum_value(&a[7]);
        /* the ambient density of the film zone for the next fill: the mean
         * over the links outside it (none: the last one stays) */
        const double nout = xsum_value(&a[9]);
        if (nout > 0.0) {
            p->rho_film = xsum_value(&a[8]) / nout;
        }
    }
}
