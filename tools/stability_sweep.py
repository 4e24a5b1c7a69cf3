#!/usr/bin/env python3
"""Stability map of a free sphere in a periodic box: density ratio x tau x
settling velocity x radius, for the default coupling and any alternative.

Each case is one `coupler run` of a sphere settling (or rising) in a periodic
box of 8 radii with a counter body force on the fluid, so that the system as a
whole does not accelerate. Gravity is chosen so that the terminal velocity is
about the requested lattice velocity (Stokes drag times the Sangani-Acrivos
array factor for D/L = 1/4 and the Schiller-Naumann Reynolds correction).
Verdict: "stable" (the run ends, no period-2 warning), "oscillates" (the
fluid's period-2 watch warned), or "fails" (the run stopped; the cause from the
message). A case that is not stable is run again as a control: the same sphere
moving at the case's speed with its motion prescribed (no coupling at all), the
body force on the fluid balancing its drag. When the control fails too, the
limit is the fluid's (the lattice and the moving boundary at that tau and
speed), not the coupling's: the detail says "fluid limit". Usage:

    tools/stability_sweep.py [--quick] [--csv OUT.csv] [--set KEY=VALUE]... [--label NAME]

Every `--set` is passed to each run (e.g. `--set rigid.coupling=explicit
--set fluid.force_averaging=false` for the paper's scheme). Prints a table.
"""
import argparse
import concurrent.futures as cf
import csv
import math
import os
import re
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
COUPLER = os.path.join(ROOT, "build", "coupler")

SCENE = """domain:
  size: [{L}, {L}, {L}]
fluid:
  density: 1000.0
  viscosity: 1.0e-6
  dx: {dx}
  tau: {tau}
  body_force: [0, 0, {fb}]
bodies:
  - density: {rho_p}
    spheres:
      - {{center: [{c}, {c}, {c}], radius: {a}}}
rigid:
  gravity: [0, 0, {g}]
run:
  end_time: {t_end}
  output_interval: {t_out}
"""


def case_numbers(a_cells, tau, u_lat):
    """SI numbers of a case (dx = 1 mm, water-like fluid): the step, the box, the sphere, its
    speed and its expected drag (Stokes drag times the array factor K(D/L = 1/4) ~ 1.5 and the
    Schiller-Naumann Reynolds correction)."""
    dx, nu, rho_f = 1.0e-3, 1.0e-6, 1000.0
    dt = (tau - 0.5) * dx * dx / (3.0 * nu)
    L, a = 8 * a_cells * dx, a_cells * dx
    u = u_lat * dx / dt
    re = 2.0 * a * u / nu
    drag = 6.0 * math.pi * rho_f * nu * a * u * 1.5 * (1.0 + 0.15 * re ** 0.687)
    return dict(dx=dx, dt=dt, rho_f=rho_f, L=L, a=a, u=u, vol=4.0 / 3.0 * math.pi * a ** 3, drag=drag)


def case_scene(a_cells, ratio, tau, u_lat, steps):
    """Scene text for one case."""
    k = case_numbers(a_cells, tau, u_lat)
    rho_f, vol, L = k["rho_f"], k["vol"], k["L"]
    g = -k["drag"] / (abs(ratio - 1.0) * rho_f * vol)
    weight = (ratio - 1.0) * rho_f * vol * g  # net weight of the sphere (N, z)
    fb = -weight / (L ** 3 - vol)             # counter body force on the fluid (N/m^3)
    return SCENE.format(L=L, dx=k["dx"], tau=tau, fb=fb, rho_p=ratio * rho_f, c=L / 2, a=k["a"], g=g,
                        t_end=steps * k["dt"], t_out=steps * k["dt"] / 20)


def control_scene(a_cells, ratio, tau, u_lat, steps):
    """The control of a case: the sphere moves down at the case's speed with its motion
    prescribed (no coupling), through fluid at rest; a body force equal to its drag per fluid
    volume pushes the fluid down with it, so that the fluid as a whole does not accelerate."""
    k = case_numbers(a_cells, tau, u_lat)
    fb = -k["drag"] / (k["L"] ** 3 - k["vol"])
    text = case_scene(a_cells, ratio, tau, u_lat, steps)
    text = re.sub(r"body_force: \[0, 0, [^\]]*\]", f"body_force: [0, 0, {fb!r}]", text)
    text = text.replace("  - density:", f"  - motion: prescribed\n    velocity: [0, 0, {-k['u']!r}]\n    density:")
    return re.sub(r"gravity: \[0, 0, [^\]]*\]", "gravity: [0, 0, 0]", text)


def one_run(text, sets, coupler):
    """(returncode, stderr) of one run of the scene text."""
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "case.yaml")
        with open(path, "w") as f:
            f.write(text)
        cmd = [coupler, "run", path, "-o", os.path.join(tmp, "out.h5"), "--quiet"]
        for s in sets:
            cmd += ["--set", s]
        env = dict(os.environ, OMP_NUM_THREADS="1")
        p = subprocess.run(cmd, capture_output=True, text=True, env=env)
    return p.returncode, p.stderr


def run_case(args):
    verdict, why = run_free(args)
    if verdict != "stable":
        a, ratio, tau, u, steps, sets, coupler = args
        rc, err = one_run(control_scene(a, ratio, tau, u, steps), sets, coupler)
        if rc != 0:
            errors = [l for l in err.splitlines() if l.startswith("error:")]
            why += "; fluid limit: the same motion prescribed fails too (%s)" % (
                errors[0][:160] if errors else "exit %d" % rc)
        else:
            why += "; control: the same motion prescribed runs"
    return verdict, why


def run_free(args):
    a, ratio, tau, u, steps, sets, coupler = args
    returncode, err = one_run(case_scene(a, ratio, tau, u, steps), sets, coupler)
    if returncode != 0:
        errors = "\n".join(l for l in err.splitlines() if l.startswith("error:"))
        m = re.search(r"(moves [0-9.e+]+ cells in one step at step \d+|at step \d+|step \d+)", errors)
        cause = m.group(1) if m else "exit %d" % returncode
        for key in ("non-finite", "non-positive density", "Mach", "reached face", "overlap"):
            if key in errors:
                cause += " (" + key + ")"
                break
        if "period-2" in err:
            cause += ", after a period-2 warning"
        return "fails", cause
    if "period-2" in err:
        m = re.search(r"step (\d+) \(t =", err)
        return "oscillates", "warned at step " + (m.group(1) if m else "?")
    return "stable", ""


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
