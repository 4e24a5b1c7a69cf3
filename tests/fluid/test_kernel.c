/* test_kernel.c — the fused kernel against a plain reference kernel.
 *
 * The reference is written the textbook way, direction by direction with
 * the equilibrium of Eq. 4 and Guo's forcing term (Guo, Zheng & Shi, Phys.
 * Rev. E 65 (2002) 046308) split into symmetric and antisymmetric parts for
 * TRT (Ginzburg 2005), and it streams by wrapping periodic coordinates
 * itself instead of using ghost cells. The fused kernel plus the boundary
 * stage must give the same populations to round-off. */
#include "fluid_tests.h"
#include "test_util.h"

#include "../../fluid/fluid_internal.h"
#include "../../fluid/lattice.h"

#include <CUnit/CUnit.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static int wrap(int i, int n) { return ((i - 1) % n + n) % n + 1; }

static void reference_step(const grid_t *g, const kernel_params_t *p, const double *src, double *dst)
{
    const size_t N = g->ncells;
    for (int z = 1; z <= g->n[2]; z++) {
        for (int y = 1; y <= g->n[1]; y++) {
            for (int x = 1; x <= g->n[0]; x++) {
                double f[LB_Q], rho = 0.0, j[3] = {0, 0, 0};
                for (int q = 0; q < LB_Q; q++) {
                    const int xs = wrap(x - lb_c[q][0], g->n[0]), ys = wrap(y - lb_c[q][1], g->n[1]),
                              zs = wrap(z - lb_c[q][2], g->n[2]);
                    f[q] = src[(size_t)q * N + grid_index(g, xs, ys, zs)];
                    rho += f[q];
                    for (int a = 0; a < 3; a++) {
                        j[a] += lb_c[q][a] * f[q];
                    }
                }
                double u[3];
                for (int a = 0; a < 3; a++) {
                    u[a] = (j[a] + 0.5 * p->force[a]) / rho;
                }
                double feq[LB_Q], s[LB_Q];
                for (int q = 0; q < LB_Q; q++) {
                    feq[q] = lb_feq(q, rho, u[0], u[1], u[2]);
                    double cu = 0.0, cf = 0.0, uf = 0.0;
                    for (int a = 0; a < 3; a++) {
                        cu += lb_c[q][a] * u[a];
                        cf += lb_c[q][a] * p->force[a];
                        uf += u[a] * p->force[a];
                    }
                    s[q] = lb_w[q] * (3.0 * (cf - uf) + 9.0 * cu * cf);
                }
                const size_t i = grid_index(g, x, y, z);
                for (int q = 0; q < LB_Q; q++) {
                    const int o = lb_opposite(q);
                    const double fp = 0.5 * (f[q] + f[o]), fm = 0.5 * (f[q] - f[o]);
                    const double ep = 0.5 * (feq[q] + feq[o]), em = 0.5 * (feq[q] - feq[o]);
                    const double sp = 0.5 * (s[q] + s[o]), sm = 0.5 * (s[q] - s[o]);
                    dst[(size_t)q * N + i] = f[q] - p->omega_plus * (fp - ep) - p->omega_minus * (fm - em) +
                                             (1.0 - 0.5 * p->omega_plus) * sp + (1.0 - 0.5 * p->omega_minus) * sm;
                }
            }
        }
    }
}

/* Random populations, nsteps steps of the component (boundary stage and
 * kernel, in the scene's streaming layout) against nsteps reference steps. */
static void compare_forced(collision_t collision, double tau, int nx, int ny, int nz, streaming_t streaming,
                           int nsteps, precision_t precision, double force)
{
    scene_t s = test_box(nx, ny, nz, tau, collision);
    s.fluid.body_force[0] = 1.3 * force;
    s.fluid.body_force[1] = -0.7 * force;
    s.fluid.body_force[2] = 2.1 * force;
    s.fluid.streaming = streaming;
    s.fluid.precision = precision;
    fluid_t *fl = test_fluid(&s);
    const grid_t *g = &fl->g;
    const size_t bytes = (size_t)LB_Q * g->ncells * sizeof(double);
    double *src = malloc(bytes), *ref = malloc(bytes);
    CU_ASSERT_FATAL(src != NULL && ref != NULL);
    memset(src, 0, bytes);
    memset(ref, 0, bytes);
    const pops_t p0 = fluid_pops(fl);
    srand(12345);
    for (int z = 1; z <= g->n[2]; z++) {
        for (int y = 1; y <= g->n[1]; y++) {
            for (int x = 1; x <= g->n[0]; x++) {
                for (int q = 0; q < LB_Q; q++) {
                    const size_t i = grid_index(g, x, y, z);
                    const double v = lb_w[q] * (1.0 + 0.1 * ((double)rand() / RAND_MAX - 0.5));
                    pops_write(&p0, q, pops_post_slot(&p0, q, i), v);
                    src[(size_t)q * g->ncells + i] = pops_post(&p0, q, i); /* as stored */
                }
            }
        }
    }
    for (int n = 0; n < nsteps; n++) {
        reference_step(g, &fl->kp, src, ref);
        memcpy(src, ref, bytes);
        fluid_step(fl);
    }
    const pops_t p = fluid_pops(fl);
    double maxdiff = 0.0;
    for (int z = 1; z <= g->n[2]; z++) {
        for (int y = 1; y <= g->n[1]; y++) {
            for (int x = 1; x <= g->n[0]; x++) {
                for (int q = 0; q < LB_Q; q++) {
                    const size_t i = grid_index(g, x, y, z);
                    maxdiff = fmax(maxdiff, fabs(pops_post(&p, q, i) - ref[(size_t)q * g->ncells + i]));
                }
            }
        }
    }
    /* double: populations are O(0.1), round-off of a few ulp per step.
     * single: each stored value is f - w_q, about 0.05 w_q here, rounded to
     * float (2^-24 relative): ~1e-10 absolute per step; unshifted it would be
     * ~1e-8 (the test of the shift) */
    if (precision == PRECISION_SINGLE) {
        CU_ASSERT(maxdiff < 1e-9 * nsteps);
        CU_ASSERT(maxdiff > 1e-13); /* it is float storage */
    } else {
        CU_ASSERT(maxdiff < 1e-15 * nsteps);
    }
    CU_ASSERT(maxdiff >= 0.0);
    free(src);
    free(ref);
    fluid_free(fl);
}

static void compare(collision_t collision, double tau, int nx, int ny, int nz, streaming_t streaming, int nsteps,
                    precision_t precision)
{
    compare_forced(collision, tau, nx, ny, nz, streaming, nsteps, precision, 1e-5);
}

/* without a body force the kernels compile the forcing terms away */
static void test_unforced_equals_reference(void)
{
    compare_forced(COLLISION_TRT, 0.73, 70, 5, 4, STREAMING_TWO_ARRAY, 1, PRECISION_DOUBLE, 0.0);
    compare_forced(COLLISION_TRT, 0.73, 70, 5, 4, STREAMING_IN_PLACE, 3, PRECISION_DOUBLE, 0.0);
    compare_forced(COLLISION_BGK, 1.7, 13, 6, 7, STREAMING_IN_PLACE, 3, PRECISION_SINGLE, 0.0);
}

static void test_fused_equals_reference_trt(void)
{
    compare(COLLISION_TRT, 0.73, 70, 5, 4, STREAMING_TWO_ARRAY, 1, PRECISION_DOUBLE);
}
static void test_fused_equals_reference_bgk(void)
{
    compare(COLLISION_BGK, 1.7, 13, 6, 7, STREAMING_TWO_ARRAY, 1, PRECISION_DOUBLE);
}
/* in place: three steps, so that both kernels (push, local, push) and both
 * boundary states (SWAPPED, PUSHED) are exercised */
static void test_in_place_equals_reference_trt(void)
{
    compare(COLLISION_TRT, 0.73, 70, 5, 4, STREAMING_IN_PLACE, 3, PRECISION_DOUBLE);
}
static void test_in_place_equals_reference_bgk(void)
{
    compare(COLLISION_BGK, 1.7, 13, 6, 7, STREAMING_IN_PLACE, 3, PRECISION_DOUBLE);
}
static void test_single_equals_reference(void)
{
    compare(COLLISION_TRT, 0.73, 70, 5, 4, STREAMING_IN_PLACE, 3, PRECISION_SINGLE);
    compare(COLLISION_BGK, 1.7, 13, 6, 7, STREAMING_TWO_ARRAY, 2, PRECISION_SINGLE);
}

/* Lambda = (1/w+ - 1/2)(1/w- - 1/2) must come out as the requested magic
 * parameter (Ginzburg, Verhaeghe & d'Humieres 2008). */
static void test_magic_parameter(void)
{
    const double taus[] = {0.51, 0.6, 1.0, 2.0, 5.0};
    for (int i = 0; i < 5; i++) {
        const double wp = 1.0 / taus[i];
        const double wm = kernel_omega_minus(wp, 3.0 / 16.0);
        CU_ASSERT_DOUBLE_EQUAL((1.0 / wp - 0.5) * (1.0 / wm - 0.5), 3.0 / 16.0, 1e-14);
        CU_ASSERT(wm > 0.0 && wm < 2.0);
    }
}

/* The kernel on boxes that tile the block (fluid.c step_overlapped: inner
 * cells in slices, then the outer layer) gives the very bits of one call
 * over every cell: with the inner columns on whole cache lines (the block
 * path of the two-array kernel, ghost and padding columns included) and
 * with columns 1 and n alone (cell by cell). The tiles are a partition: in
 * place a cell updated twice would take its own output. Both in-place
 * kernels (push, local) are run. */
static void update(const grid_t *g, const kernel_params_t *kp, int two, int single, void *a, void *b, int push,
                   const kernel_box_t *box)
{
    if (two) {
        if (single) {
            kernel_stream_collide_f32(g, kp, a, b, box);
        } else {
            kernel_stream_collide(g, kp, a, b, box);
        }
    } else if (single) {
        kernel_in_place_f32(g, kp, a, push, box);
    } else {
        kernel_in_place(g, kp, a, push, box);
    }
}

static void tiles_equal_one_call(int two, int single, int xa)
{
    const int n[3] = {19, 7, 9};
    grid_t g;
    grid_init(&g, n, two ? GRID_ALIGN : 1);
    const kernel_params_t kp = {1.0 / 0.8, kernel_omega_minus(1.0 / 0.8, 0.25), {1e-5, -2e-5, 3e-5}, NULL};
    const size_t es = single ? sizeof(float) : sizeof(double), bytes = ((size_t)LB_Q * g.stride * es + 63) / 64 * 64;
    unsigned char *a = aligned_alloc(64, bytes), *b = aligned_alloc(64, bytes); /* C11: a multiple of 64 */
    unsigned char *a2 = aligned_alloc(64, bytes), *b2 = aligned_alloc(64, bytes);
    CU_ASSERT_FATAL(a != NULL && b != NULL && a2 != NULL && b2 != NULL);
    srand(777);
    for (size_t i = 0; i < (size_t)LB_Q * g.stride; i++) {
        const double v = 0.01 * ((double)rand() / RAND_MAX - 0.5); /* single: f - w; double: any values */
        if (single) {
            ((float *)a)[i] = (float)v;
        } else {
            ((double *)a)[i] = 0.05 + v;
        }
    }
    memcpy(a2, a, bytes);
    unsigned char *orig = malloc(bytes);
    CU_ASSERT_FATAL(orig != NULL);
    memcpy(orig, a, bytes);
    memset(b, 0, bytes);
    memset(b2, 0, bytes);
    /* inner cells in slices, then the six pieces of the outer layer */
    const int n0 = n[0], n1 = n[1], n2 = n[2], xb = xa == 2 ? n0 - 1 : n0 / 8 * 8 - 1;
    kernel_box_t tiles[16];
    int nt = 0;
    for (int z = 2; z <= n2 - 1; z += 3) {
        tiles[nt++] = (kernel_box_t){{xa, 2, z}, {xb, n1 - 1, z + 2 < n2 - 1 ? z + 2 : n2 - 1}};
    }
    const kernel_box_t outer[6] = {
        {{1, 1, 1}, {n0, n1, 1}},           {{1, 1, n2}, {n0, n1, n2}},              {{1, 1, 2}, {n0, 1, n2 - 1}},
        {{1, n1, 2}, {n0, n1, n2 - 1}},     {{1, 2, 2}, {xa - 1, n1 - 1, n2 - 1}},   {{xb + 1, 2, 2}, {n0, n1 - 1, n2 - 1}},
    };
    for (int i = 0; i < 6; i++) {
        tiles[nt++] = outer[i];
    }
    for (int step = 0; step < (two ? 1 : 2); step++) {
        const int push = step == 0;
        update(&g, &kp, two, single, a, b, push, NULL);
        for (int i = 0; i < nt; i++) {
            update(&g, &kp, two, single, a2, b2, push, &tiles[i]);
        }
    }
    /* interior cells with two arrays (the whole-row pass fills ghost columns
     * too); in place every slot, ghosts included (the push kernel writes them) */
    const unsigned char *r = two ? b : a, *t = two ? b2 : a2;
    long differ = 0;
    for (int q = 0; q < LB_Q; q++) {
        for (int z = two ? 1 : 0; z <= (two ? n2 : n2 + 1); z++) {
            for (int y = two ? 1 : 0; y <= (two ? n1 : n1 + 1); y++) {
                const size_t row = (size_t)q * g.stride + grid_index(&g, two ? 1 : 0, y, z);
                const int len = two ? n0 : n0 + 2;
                differ += memcmp(r + row * es, t + row * es, (size_t)len * es) != 0;
            }
        }
    }
    CU_ASSERT_EQUAL(differ, 0);
    /* and the tiles did update every cell: no value of an interior row is still the input's */
    long same = 0;
    for (int z = 1; z <= n2; z++) {
        for (int y = 1; y <= n1; y++) {
            for (int x = 1; x <= n0; x++) {
                const size_t i = (size_t)3 * g.stride + grid_index(&g, x, y, z); /* population 3, any */
                same += memcmp(t + i * es, orig + i * es, es) == 0;
            }
        }
    }
    CU_ASSERT_EQUAL(same, 0);
    free(orig);
    free(a);
    free(b);
    free(a2);
    free(b2);
}

static void test_tiles_equal_one_call(void)
{
    for (int two = 0; two < 2; two++) {
        for (int single = 0; single < 2; single++) {
            tiles_equal_one_call(two, single, 8); /* inner columns 8 .. 15 of 19 */
            tiles_equal_one_call(two, single, 2); /* inner columns 2 .. 18 */
        }
    }
}

void kernel_register_tests(void)
{
    CU_pSuite s = CU_add_suite("kernel", NULL, NULL);
    CU_add_test(s, "fused TRT kernel equals the reference kernel", test_fused_equals_reference_trt);
    CU_add_test(s, "fused BGK kernel equals the reference kernel", test_fused_equals_reference_bgk);
    CU_add_test(s, "in-place (AA) TRT kernel equals the reference kernel", test_in_place_equals_reference_trt);
    CU_add_test(s, "in-place (AA) BGK kernel equals the reference kernel", test_in_place_equals_reference_bgk);
    CU_add_test(s, "single precision (f - w stored as float) equals the reference kernel to 1e-9",
                test_single_equals_reference);
    CU_add_test(s, "kernels without a body force equal the reference kernel", test_unforced_equals_reference);
    CU_add_test(s, "TRT magic parameter", test_magic_parameter);
    CU_add_test(s, "the kernels on tiles of the block (inner, outer layer) equal one call, bit for bit",
                test_tiles_equal_one_call);
}
