"""Issue 10: spheres meeting the walls of a closed box, with the scene defaults (no coupling and
no contact keys in the scenes: rigid.coupling auto, contacts spring-dashpot with the lubrication
correction).

1. Settling in a closed box (ten Cate, Nieuwstad, Derksen & Van den Akker 2002, Phys. Fluids
   14, 4012): a sphere of D = 15 mm, 1120 kg/m^3, released at rest in a 100 x 100 x 160 mm box
   of no-slip walls filled with the fluids E1..E4 (Re 1.5 to 31.9), lattice settling velocity
   0.04 (tau 1.3-2.2 at Re 1.5, 0.54-0.58 at Re 32). The run must end with status 0 and no
   period-2 warning; the sphere comes to rest on the floor (speed over the last 5% of the run
   below 2% of u_max; lowest point within 1% of D of the floor and no deeper into it than twice
   the overlap a spring-dashpot contact allows, v sqrt(m/k) + W/k with v = u_max); the fluid
   mass changes by less than MASS_BOUND; u_max is within U_TOL[D] of the experiment's u_max.
   Short version (`make test`): E4 and E1 at D = 10 cells in a box 100 mm high, released 60 mm
   above the floor (the lower release costs E4 ~8% of its u_max: U_TOL_SHORT). Full version
   (`make validate`): the 4 fluids at D = 10, 15, 20 cells in the full box; u_max converges with
   D; the table and the velocity curves go to build/settling_box/.

2. Wet restitution (Gondret, Lance & Petit 2002, Phys. Fluids 14, 643; Joseph, Zenit, Hunt &
   Rosenwinkel 2001, J. Fluid Mech. 433, 329; fit of Legendre, Daniel & Guiraud 2005,
   e_wet/e_dry = exp(-35/St)): a sphere of density ratio 10 (and 8) hits the floor at its
   terminal velocity (settling_cases.restitution_scene); e = rebound speed / impact speed with
   the impact speed taken at a gap of one diameter (before the wall slows it) and the rebound
   speed the largest upward speed after the turn; St from the impact speed. Dry restitution 0.9
   (the default of contacts.restitution). Below St ~ 5 no rebound (e < 0.05), above St ~ 100
   e/e_dry > 0.5. Short version: one point of each regime; full version: the curve with its
   table and figure in build/settling_box/.
"""
import math
import os
import pathlib
import subprocess
import sys
import time

import numpy as np
import pytest

from conftest import COUPLER, ROOT

sys.path.insert(0, str(ROOT / "coupler"))
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import h5out  # noqa: E402
import settling_cases as sc  # noqa: E402

FIG_DIR = ROOT / "build" / "settling_box"
E_DRY = 0.9                   # contacts.restitution default
REST_SPEED = 0.02             # final speed / u_max
ON_FLOOR = 0.01               # final gap / D: resting on the floor, not hovering above it
MASS_BOUND = 3e-4             # largest relative change of the fluid mass
U_TOL = {10: 0.06, 15: 0.05, 20: 0.05}   # |u_max / u_max(experiment) - 1|
U_TOL_SHORT = {"E4": (0.85, 1.02), "E1": (0.92, 1.04)}   # u_max / u_max(experiment), short box
NO_REBOUND = 0.05             # e below this: no rebound
REBOUND = 0.5                 # e / e_dry above this at St >= 100
NEAR_FIT = 0.1                # and this near exp(-35/St) (Legendre et al. 2005)


def _run(scene, path, timeout=7200):
    """Writes the scene, runs it with 2 threads, returns (CompletedProcess, output, wall time)."""
    yml = path.with_suffix(".yaml")
    yml.write_text(sc.dump(scene))
    out = path.with_suffix(".h5")
    env = dict(os.environ, OMP_NUM_THREADS="2")
    t0 = time.time()
    p = subprocess.run([str(COUPLER), "run", str(yml), "-o", str(out), "--quiet"], capture_output=True, text=True,
                       env=env, timeout=timeout)
    return p, out, time.time() - t0


def _ok(p):
    """Exit status 0 and no period-2 warning: the defaults are stable."""
    problems = []
    if p.returncode != 0:
        problems.append(f"exit status {p.returncode}: {p.stderr[-2000:]}")
    if "period-2" in p.stderr:
        problems.append("period-2 warning: " + p.stderr[-2000:])
    return problems


def settling_checks(case, n, scene, m, u_tol):
    """The assertions on one settling run (a list of failures, empty when it passes)."""
    f = sc.FLUIDS[case]
    fail = []
    a = scene["bodies"][0]["spheres"][0]["radius"]
    bound = 2 * sc.contact_overlap_estimate(scene, m["u_max"])
    if not m["speed_last"] < REST_SPEED * m["u_max"]:
        fail.append(f"{case} D={n}: not at rest: speed {m['speed_last']:.3e} m/s over the last 5% of the run "
                    f"(bound {REST_SPEED} u_max = {REST_SPEED * m['u_max']:.3e})")
    if not m["gap_end"] < ON_FLOOR * 2 * a:
        fail.append(f"{case} D={n}: not on the floor: final gap {m['gap_end_D']:.4f} D")
    if not m["gap_min_D"] * 2 * a > -bound:
        fail.append(f"{case} D={n}: into the floor by {-m['gap_min_D']:.4f} D, more than the contact allows "
                    f"({bound / (2 * a):.4f} D)")
    if not m["mass_change"] < MASS_BOUND:
        fail.append(f"{case} D={n}: fluid mass change {m['mass_change']:.2e} (bound {MASS_BOUND})")
    r = m["u_max"] / f["u_max"]
    lo, hi = u_tol
    if not lo <= r <= hi:
        fail.append(f"{case} D={n}: u_max {m['u_max']:.5f} m/s = {r:.3f} of the experiment ({f['u_max']}), "
                    f"allowed [{lo}, {hi}]")
    if not m["lateral_drift"] < 0.05 * 2 * a:
        fail.append(f"{case} D={n}: lateral drift {m['lateral_drift']:.2e} m")
    return fail


def settling_line(case, n, scene, m, wall):
    f = sc.FLUIDS[case]
    a = scene["bodies"][0]["spheres"][0]["radius"]
    return (f"{case} | {n} | {sc.tau_of(scene):.3f} | {m['u_max']:.5f} | {f['u_max']:.5f} | "
            f"{m['u_max'] / f['u_max']:.3f} | {m['t_land']:.3f} | {m['gap_end_D']:+.5f} | {m['gap_min_D']:+.5f} | "
            f"{2 * sc.contact_overlap_estimate(scene, m['u_max']) / (2 * a):.5f} | "
            f"{m['speed_last'] / m['u_max']:.2e} | {m['mass_change']:.2e} | {wall:.0f}")


SETTLING_HEAD = ("case | D (cells) | tau | u_max (m/s) | experiment | ratio | t landed (s) | final gap / D | "
                 "smallest gap / D | overlap bound / D | speed (last 5%) / u_max | mass change | wall (s)")


# ---------------------------------------------------------------------------------------------
# settling in a box


def test_settling_box_scene_is_ten_cate_e3(coupler):
    """models/settling_box.yaml is the generator's E3 case at D = 15 cells (rounder output times,
    field snapshots) with no coupling or contact keys, and `coupler check` takes it."""
    import yaml
    path = ROOT / "models" / "settling_box.yaml"
    user = yaml.safe_load(path.read_text())
    gen = sc.settling_scene("E3", 15)
    assert user["domain"] == gen["domain"] and user["bodies"] == gen["bodies"]
    assert user["rigid"] == {"gravity": [0, 0, -9.81]} and "contacts" not in user
    for k in ("density", "viscosity", "dx", "dt"):
        assert user["fluid"][k] == pytest.approx(gen["fluid"][k], rel=1e-9), k
    assert set(user["fluid"]) == {"density", "viscosity", "dx", "dt"}
    assert user["run"]["end_time"] >= gen["run"]["end_time"]
    p = subprocess.run([str(COUPLER), "check", str(path)], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    assert "implicit" in p.stdout   # auto coupling picks implicit + averaging for this light sphere


@pytest.mark.parametrize("case", ["E4", "E1"])
def test_settling_short_box_lands_and_rests(coupler, tmp_path, case):
    scene = sc.settling_scene(case, 10, height=0.100, release_gap=0.060)
    p, out, wall = _run(scene, tmp_path / f"settle_{case}")
    assert not _ok(p), "\n".join(_ok(p))
    d = h5out.read(out)
    m = sc.settling_measure(d, scene)
    print("\n" + SETTLING_HEAD + "\n" + settling_line(case, 10, scene, m, wall))
    fail = settling_checks(case, 10, scene, m, U_TOL_SHORT[case])
    assert not fail, "\n".join(fail)


@pytest.mark.validate
def test_settling_box_matrix_converges(coupler, tmp_path):
    FIG_DIR.mkdir(parents=True, exist_ok=True)
    res, fail, lines = {}, [], []
    for case in ("E1", "E2", "E3", "E4"):
        for n in (10, 15, 20):
            scene = sc.settling_scene(case, n)
            p, out, wall = _run(scene, tmp_path / f"settle_{case}_{n}")
            fail += _ok(p)
            if p.returncode != 0:
                continue
            d = h5out.read(out)
            m = sc.settling_measure(d, scene)
            res[case, n] = m
            lines.append(settling_line(case, n, scene, m, wall))
            print(lines[-1], flush=True)
            tol = U_TOL[n]
            fail += settling_checks(case, n, scene, m, (1 - tol, 1 + tol))
    # convergence: the change from 15 to 20 cells is smaller than from 10 to 15 (or below 1%)
    for case in ("E1", "E2", "E3", "E4"):
        if all((case, n) in res for n in (10, 15, 20)):
            u = [res[case, n]["u_max"] for n in (10, 15, 20)]
            d1, d2 = abs(u[1] - u[0]), abs(u[2] - u[1])
            if not (d2 < d1 or d2 < 0.01 * u[2]):
                fail.append(f"{case}: u_max does not converge: {u}")
    _table_and_figure("settling", SETTLING_HEAD, lines, _settling_figure(res, FIG_DIR / "settling_box_velocity.png"))
    assert not fail, "\n".join(fail)


def _table_and_figure(what, head, lines, png):
    """Writes the table of a validation beside its figure and says where both are."""
    table = FIG_DIR / ("settling_box.txt" if what == "settling" else "wet_restitution.txt")
    table.write_text(head + "\n" + "\n".join(lines) + "\n")
    print(f"\n{what} table: {table}\n{what} figure: {png}")


def _settling_figure(res, path):
    import matplotlib.pyplot as plt
    fig, axs = plt.subplots(2, 2, figsize=(11, 8), sharex=False)
    styles = {10: ":", 15: "--", 20: "-"}
    for ax, case in zip(axs.flat, ("E1", "E2", "E3", "E4")):
        f = sc.FLUIDS[case]
        for n in (10, 15, 20):
            if (case, n) in res:
                m = res[case, n]
                ax.plot(m["t"], -m["vz"], styles[n], label=f"D = {n} cells (u_max {m['u_max']:.4f})")
        ax.axhline(f["u_max"], color="k", lw=0.8, label=f"experiment u_max {f['u_max']}")
        ax.axhline(f["u_inf"], color="grey", lw=0.8, ls="-.", label=f"u_inf {f['u_inf']} (Table 1)")
        ax.set_title(f"{case}: Re {f['re']}, rho_f {f['rho']:.0f}, mu {f['mu']}")
        ax.set_xlabel("t (s)")
        ax.set_ylabel("-u_z (m/s)")
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    fig.suptitle("Sphere settling in a closed box (ten Cate et al. 2002), scene defaults")
    saved = []
    h5out.save(fig, path, saved)
    return saved[0]


# ---------------------------------------------------------------------------------------------
# wet restitution


def _restitution(tmp_path, st, ratio):
    scene = sc.restitution_scene(st, ratio)
    p, out, wall = _run(scene, tmp_path / f"rest_{ratio:g}_{st:g}")
    prob = _ok(p)
    if p.returncode != 0:
        return scene, None, prob, wall
    m = sc.restitution_measure(h5out.read(out), scene)
    return scene, m, prob, wall


def restitution_line(st_nominal, scene, m, wall):
    n, _ = sc.restitution_numerics(st_nominal, m["ratio"])
    return (f"{m['ratio']:g} | {st_nominal:g} | {n} | {sc.tau_of(scene):.4f} | {m['st']:.2f} | {m['re']:.2f} | "
            f"{m['u_in']:.4f} | {m['u_out']:.4f} | {m['e']:.3f} | {m['e'] / E_DRY:.3f} | {sc.legendre(m['st']):.3f} | "
            f"{m['gap_min_D']:+.4f} | {wall:.0f}")


RESTITUTION_HEAD = ("rho_p/rho_f | St (nominal) | D (cells) | tau | St (impact) | Re | u_in (m/s) | u_out (m/s) | e | "
                    "e/e_dry | exp(-35/St) | smallest gap / D | wall (s)")


def restitution_checks(m, label):
    fail = []
    if m["st"] < 6:
        if not m["gap_min_D"] < 0.02:
            fail.append(f"{label}: St {m['st']:.2f}: never came near the floor (smallest gap {m['gap_min_D']:.4f} D)")
        if not m["e"] < NO_REBOUND:
            fail.append(f"{label}: St {m['st']:.2f}: rebound e = {m['e']:.3f} (no rebound expected, e < {NO_REBOUND})")
    if m["st"] >= 100 and not m["e"] / E_DRY > REBOUND:
        fail.append(f"{label}: St {m['st']:.1f}: e/e_dry = {m['e'] / E_DRY:.3f} (expected > {REBOUND})")
    if m["st"] >= 100 and not abs(m["e"] / E_DRY - sc.legendre(m["st"])) < NEAR_FIT:
        fail.append(f"{label}: St {m['st']:.1f}: e/e_dry = {m['e'] / E_DRY:.3f}, more than {NEAR_FIT} from "
                    f"exp(-35/St) = {sc.legendre(m['st']):.3f}")
    if not m["e"] <= E_DRY * 1.02:
        fail.append(f"{label}: St {m['st']:.1f}: e = {m['e']:.3f} above the dry restitution {E_DRY}")
    return fail


@pytest.mark.parametrize("st", [4, 200])
def test_wet_restitution_two_regimes(coupler, tmp_path, st):
    scene, m, prob, wall = _restitution(tmp_path, st, 10.0)
    assert not prob, "\n".join(prob)
    print("\n" + RESTITUTION_HEAD + "\n" + restitution_line(st, scene, m, wall))
    # the nominal Stokes numbers land in the two regimes
    assert (m["st"] < 6) if st < 10 else (m["st"] >= 100), m["st"]
    fail = restitution_checks(m, f"St {st}")
    assert not fail, "\n".join(fail)


# St 500 (Re 450, 30 cells at tau 0.51) and, at ratio 8, St 300 (23 cells) are left out: after the
# rebound (measured, e/e_dry 0.918 and 0.878 against 0.928 and 0.880 of the fit), the fluid rushing
# into the opening gap passes the Mach detector at the floor (Mach 0.367 at step 984, density 0.60;
# 0.301 at step 779): a lattice limit of tau 0.51 in a gap below a cell, reported with step and place
# (README "Known problems"). Ratio 8 at St 200 stopped behind the falling sphere before the refill
# took the neighbour's non-equilibrium part (2026-11-27, README "Refill").
RESTITUTION_CURVE = {10.0: (1, 2, 5, 10, 20, 50, 100, 200), 8.0: (2, 10, 50, 200)}


@pytest.mark.validate
def test_wet_restitution_curve(coupler, tmp_path):
    FIG_DIR.mkdir(parents=True, exist_ok=True)
    fail, lines, res = [], [], {}
    for ratio, sts in RESTITUTION_CURVE.items():
        for st in sts:
            scene, m, prob, wall = _restitution(tmp_path, st, ratio)
            fail += [f"ratio {ratio:g} St {st}: {x}" for x in prob]
            if m is None:
                continue
            res[ratio, st] = m
            lines.append(restitution_line(st, scene, m, wall))
            print(lines[-1], flush=True)
            fail += restitution_checks(m, f"ratio {ratio:g} St {st}")
    _table_and_figure("restitution", RESTITUTION_HEAD, lines, _restitution_figure(res, FIG_DIR / "wet_restitution.png"))
    assert not fail, "\n".join(fail)


def _restitution_figure(res, path):
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4.5))
    s = np.logspace(0, 3.2, 200)
    ax.plot(s, [sc.legendre(x) for x in s], "k-", lw=1, label="Legendre et al. (2005): exp(-35/St)")
    for ratio, mk in ((10.0, "o"), (8.0, "s")):
        pts = sorted((m["st"], m["e"] / E_DRY) for (r, _), m in res.items() if r == ratio)
        if pts:
            ax.plot(*zip(*pts), mk, label=f"simulation, rho_p/rho_f = {ratio:g}")
    ax.axvline(10, color="grey", lw=0.6, ls=":")
    ax.set_xscale("log")
    ax.set_xlabel("St = (rho_p / rho_f) Re / 9 (impact speed at a gap of 1 D)")
    ax.set_ylabel("e_wet / e_dry  (e_dry = 0.9)")
    ax.set_ylim(-0.05, 1.1)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    ax.set_title("Wet restitution of a sphere on a no-slip wall, scene defaults")
    saved = []
    h5out.save(fig, path, saved)
    return saved[0]
