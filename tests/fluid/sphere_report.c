/* sphere_report.c — the figures of the curved-boundary study (`make report`).
 *
 * `sphere_report drag DIR [...]` (`make drag-report`) writes the position study
 * of the drag of a fixed sphere in a simple cubic array (drag_report.c) as
 * DIR/drag.csv and DIR/drag.txt; `sphere_report rotation DIR [...]` the torque
 * on a rotating sphere over the same plan as DIR/rotation.csv. For each boundary scheme x force variant x
 * refill scheme x {BGK, TRT} at sphere radius 5 and 8 cells the other modes print:
 *   fluctuation std/mean of the drag on a sphere moved through a periodic
 *               box at constant velocity against a body-force driven flow
 *               (second half of 3000 steps), and the momentum drift per step
 *               of fluid + booked impulse;
 *   seconds     wall time of each run;
 * and the cost of a step with a particle relative to a pure fluid step on
 * the same grid; `sphere_report approach [DIR]` (also in "all") runs the
 * close approaches of the validation (a sphere to a wall, two spheres at three
 * placements, radius 8) and writes their per-step curves as CSV into DIR
 * (default build/report) for tools/plot_approach.py. Output: plain columns,
 * one line per combination. */
#include "../../common/scene.h"
#include "../../fluid/boundary.h"
#include "../../fluid/fluid.h"

#include "approach_harness.h"
#include "drag_report.h"
#include "sphere_harness.h"
#include "test_util.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static double step_cost(int with_sphere)
{
    const int L = 64;
    const double c[3] = {L / 2.0, L / 2.0, L / 2.0};
    scene_t s = test_box(L, L, L, 0.8, COLLISION_TRT);
    harness_one_sphere(&s, c, 8.0, MOTION_PRESCRIBED)->velocity[0] = 0.01;
    if (!with_sphere) {
        s.nbodies = 0;
    }
    s.fluid.boundary_scheme = BOUNDARY_CLI;
    s.fluid.force_method = FORCE_GALILEAN;
    s.fluid.refill = REFILL_EXTRAPOLATION;
    log_t log = {log_stderr, NULL};
    fluid_t *fl = NULL;
    if (fluid_create(&s, &log, &fl) != STATUS_OK) {
        return NAN;
    }
    for (int i = 0; i < 5; i++) {
        fluid_step(fl);
    }
    const double t0 = omp_get_wtime();
    for (int i = 0; i < 200; i++) {
        fluid_step(fl);
    }
    const double dt = (omp_get_wtime() - t0) / 200;
    fluid_free(fl);
    return dt;
}

/* Usage: sphere_report [moving|cost|all] [radius...] (default: all, radii 5 and 8);
 * sphere_report approach [DIR]; sphere_report drag DIR [key=value...] (drag_report.h). */
/* The close approaches: per-step CSV curves and the window means. */
static int report_approach(const char *dir)
{
    const double gaps[] = {2.0, 1.0, 0.5, 0.2, 0.1, 0.05};
    approach_setup_t runs[4] = {APPROACH_WALL_FULL, APPROACH_PAIR_FULL, APPROACH_PAIR_FULL, APPROACH_PAIR_FULL};
    const char *names[4] = {"approach_wall", "approach_pair_face", "approach_pair_quarter", "approach_pair_node"};
    runs[2].offset = 0.25;
    runs[3].offset = 0.5;
    printf("# close approaches, radius 8, Re 0.07: (lattice + film) / Brenner, mean over half a cell of travel\n");
    printf("%-20s %6s %10s %10s %10s %10s\n", "run", "gap/a", "Brenner", "total", "lattice", "seconds");
    for (int r = 0; r < 4; r++) {
        char path[512];
        snprintf(path, sizeof path, "%s/%s.csv", dir, names[r]);
        runs[r].trace = fopen(path, "w");
        if (runs[r].trace == NULL) {
            fprintf(stderr, "sphere_report: cannot write %s (does the folder exist?)\n", path);
            return 1;
        }
        approach_point_t p[6];
        const double t0 = omp_get_wtime();
        const long steps = harness_approach(&runs[r], gaps, 6, p);
        fclose(runs[r].trace);
        if (steps == 0) {
            fprintf(stderr, "sphere_report: the run %s failed\n", names[r]);
            return 1;
        }
        for (int k = 0; k < 6; k++) {
            printf("%-20s %6.2f %10.4f %10.4f %10.4f %10.1f\n", names[r], p[k].gap, p[k].reference, p[k].total,
                   p[k].lattice, omp_get_wtime() - t0);
        }
        fflush(stdout);
    }
    return 0;
}

int main(int argc, char **argv)
{
    const char *what = argc > 1 ? argv[1] : "all";
    double rad[8] = {5.0, 8.0};
    int nr = 2;
    if (argc > 2 && strcmp(what, "drag") && strcmp(what, "rotation")) {
        nr = 0;
        for (int i = 2; i < argc && nr < 8; i++) {
            rad[nr++] = atof(argv[i]);
        }
    }
    const int do_drag = !strcmp(what, "drag"), do_rotation = !strcmp(what, "rotation");
    const int do_moving = !strcmp(what, "all") || !strcmp(what, "moving");
    const int do_cost = !strcmp(what, "all") || !strcmp(what, "cost");
    if (!strcmp(what, "all") || !strcmp(what, "approach")) {
        const char *dir = !strcmp(what, "approach") && argc > 2 ? argv[2] : "build/report";
        if (report_approach(dir) != 0) {
            return 1;
        }
        if (strcmp(what, "all")) {
            return 0;
        }
    }
    const char *const *sname = boundary_scheme_names;
    static const char *cname[] = {"bgk", "trt"};
    const double *radii = rad;
    if (do_drag || do_rotation) {
        /* sphere_report drag|rotation DIR [schemes=.. collisions=bgk,trt radii=.. taus=.. positions=..
         * precision=single|double] (drag_report.h) */
        drag_plan_t plan;
        const int bad = drag_plan_parse(&plan, argc > 3 ? argc - 3 : 0, argv + 3);
        if (bad != 0) {
            fprintf(stderr, "sphere_report: bad %s option '%s' (schemes=cli,multireflection,... collisions=bgk,trt "
                            "radii=4,8 taus=0.6,1,1.5 positions=N, N from 2 to 256 magic=L precision=single|double "
                            "streaming=two_array|in_place)\n", what, argv[3 + bad - 1]);
            return 2;
        }
        const char *dir = argc > 2 ? argv[2] : "build/report";
        if ((do_drag ? drag_report(dir, &plan) : rotation_report(dir, &plan)) != 0) {
            return 1;
        }
        return 0;
    }
    if (do_moving) {
    printf("\n# drag fluctuation (std/mean) of a sphere moving through a periodic box, 3000 steps, tau 0.8\n");
    printf("%-6s %-16s %-9s %-13s %-5s %10s %14s %9s\n", "radius", "scheme", "force", "refill", "coll", "fluct",
           "drift/step", "seconds");
    for (int ri = 0; ri < nr; ri++) {
        for (int sc = 0; sc < BOUNDARY_NSCHEMES; sc++) {
            for (int fm = 0; fm < 2; fm++) {
                for (int rf = 0; rf < 2; rf++) {
                    for (int op = 0; op < 2; op++) {
                        const double t0 = omp_get_wtime();
                        const harness_moving_t m = harness_moving_sphere(sc, fm, rf, op, radii[ri], 3000, 1);
                        const harness_moving_t d = harness_moving_sphere(sc, fm, rf, op, radii[ri], 400, 0);
                        printf("%-6.0f %-16s %-9s %-13s %-5s %10.5f %14.3e %9.1f\n", radii[ri], sname[sc],
                               fm ? "galilean" : "mem", rf ? "extrapolation" : "equilibrium", cname[op], m.fluct,
                               d.drift_per_step, omp_get_wtime() - t0);
                        fflush(stdout);
                    }
                }
            }
        }
    }
    }
    if (!do_cost) {
        return 0;
    }
    const double tf = step_cost(0), tp = step_cost(1);
    printf("\n# step cost on 64^3 with one moving sphere of radius 8 (cli, galilean, extrapolation): %.3f ms vs "
           "%.3f ms pure fluid, ratio %.3f\n",
           1e3 * tp, 1e3 * tf, tp / tf);
    return 0;
}
