#!/usr/bin/env python3
"""Stability table of a free sphere settling from rest in a periodic box: density ratio x tau x
settling velocity x radius, for the default coupling and any alternative (the README's table).

The scenes, the prescribed-motion control and the verdict parsing are those of
tools/stability_map.py (the report's stability map, which starts the sphere at its terminal
velocity to keep runs short); here the sphere starts from rest and runs 1500-3000 steps, so it
reaches its terminal lattice velocity (0.01, 0.04 or 0.1) as a user's settling run would.
Verdict: "stable" (the run ends, no period-2 warning), "oscillates" (the fluid's period-2 watch
warned), or "fails" (a detector stopped the run or it crashed; the cause from the message). A
case that is not stable is run again with the same motion prescribed (no coupling at all): when
that fails too the limit is the fluid's ("fluid limit"). Usage:

    tools/stability_sweep.py [--quick] [--csv OUT.csv] [--set KEY=VALUE]... [--label NAME]

Every `--set` is passed to each run (e.g. `--set rigid.coupling=explicit
--set fluid.force_averaging=false` for the paper's scheme). Prints a table.
"""
import argparse
import concurrent.futures as cf
import csv
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from stability_map import COUPLER, case_scene, control_scene, run_text  # noqa: E402

TIMEOUT = 1800


def run_case(args):
    a, ratio, tau, u, steps, sets, coupler = args
    verdict, cause, _, _, _ = run_text(case_scene(a, ratio, tau, u, steps), sets, steps, coupler, TIMEOUT)
    if verdict == "stable":
        return verdict, ""
    if verdict != "oscillates":
        verdict = "fails"
    c = run_text(control_scene(a, ratio, tau, u, steps), sets, steps, coupler, TIMEOUT)
    if c[0] != "stable":
        cause += "; fluid limit: the same motion prescribed fails too (%s)" % c[1][:160]
    else:
        cause += "; control: the same motion prescribed runs"
    return verdict, cause


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer cases and steps")
    ap.add_argument("--csv", help="write the table as CSV")
    ap.add_argument("--set", action="append", default=[], dest="sets", metavar="KEY=VALUE")
    ap.add_argument("--label", default="", help="name of the configuration in the output")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--coupler", default=COUPLER, help="the coupler executable (default build/coupler)")
    o = ap.parse_args()
    radii = [3] if o.quick else [3, 5]
    ratios = [0.1, 0.5, 1.17, 10.0] if o.quick else [0.1, 0.3, 0.5, 1.17, 2.0, 10.0]
    taus = [0.51, 0.55, 1.0, 2.0]
    speeds = [0.04, 0.1] if o.quick else [0.01, 0.04, 0.1]
    cases = [(a, r, t, u, (1500 if o.quick else 3000) if a == 3 else 2000, o.sets, o.coupler)
             for a in radii for r in ratios for t in taus for u in speeds]
    with cf.ThreadPoolExecutor(o.jobs) as ex:
        results = list(ex.map(run_case, cases))
    rows = [(c[0], c[1], c[2], c[3], v, why) for c, (v, why) in zip(cases, results)]
    print("configuration: %s (%s)" % (o.label or "defaults", " ".join(o.sets) or "no --set"))
    print("| radius (cells) | density ratio | tau | lattice velocity | verdict | detail |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print("| %d | %g | %g | %g | %s | %s |" % r)
    n = {v: sum(1 for r in rows if r[4] == v) for v in ("stable", "oscillates", "fails")}
    print("%d stable, %d oscillate, %d fail of %d" % (n["stable"], n["oscillates"], n["fails"], len(rows)))
    if o.csv:
        with open(o.csv, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["radius_cells", "density_ratio", "tau", "u_lattice", "verdict", "detail", "label"])
            for r in rows:
                w.writerow(list(r) + [o.label])
    return 0


if __name__ == "__main__":
    sys.exit(main())
