"""Shear scenes of issue 6: the paper's dual star (Fig. 7/8) and a free sphere in simple shear.

Short versions (run by `make test`) assert what holds from the first steps: finite loads, the
fluid mass bound stated in models/README.md, the exact half-turn symmetry of the dual star
(right central connection force = - left, no force along the vorticity axis, rotation only
about y) and, for the sphere, its spin-up towards gamma/2 at a coarse resolution. The full
runs (`make validate`) assert the checks of models/checks/shear.py: the sinusoid fit residual
of the connection forces and the sphere's steady rotation at gamma/2 within 1%."""
import math
import os
import subprocess
import sys

import h5py
import numpy as np
import pytest

from conftest import COUPLER, MODELS, PY, run

sys.path.insert(0, str(MODELS / "checks"))
import shear as check_shear  # noqa: E402

# bounds of max |m(t) - m(0)| / m(0) (/fluid/mass), measured and stated in models/README.md. The dual
# star's /fluid/mass follows the number of fluid cells as its spheres cover and uncover cells (measured
# 2.2e-4 in 200 steps, the fluid cell count changing by +1.7e-4 while the mean fluid density changed
# by -2e-7); the sphere turning in place changes no cell (measured 1.2e-9).
DUAL_STAR_MASS_SHORT = 4e-4
SPHERE_MASS_SHORT = 1e-8


def _run(scene, out, *extra):
    # the short runs skip the scene's field snapshots (tested elsewhere): only the series are checked
    p = run("run", MODELS / f"{scene}.yaml", "-o", out, "--quiet", "--set", "run.fields=false", *extra)
    assert p.returncode == 0, p.stderr
    # issue 10: the paper's scenes run with the defaults without the period-2 warning (the dual star
    # warned at step 64 with the old explicit default, a start-up transient taken for an instability)
    assert "period-2" not in p.stderr, p.stderr[-3000:]
    return check_shear.read(out)


def test_dual_star_short_symmetry(coupler, tmp_path):
    """200 steps at full resolution (120^3, r = 8 cells): the scene is invariant under the half
    turn about y through the domain centre, so F(0,7) = diag(-1, 1, -1) F(0,1) exactly; with the
    mirror y -> -y, F_y = 0. A lattice-asymmetric placement or an asymmetric force/boundary
    routine breaks this at once (the loads are ~1e-9 N after a few steps)."""
    out = tmp_path / "dual_star_shear.h5"
    d = _run("dual_star_shear", out, "--steps", "200", "--set", "run.output_interval=0.005")
    for k in ("cforce", "ctorque", "force", "torque", "position", "angular_velocity", "mass"):
        assert np.all(np.isfinite(d[k])), k
    c, kl, kr = check_shear.central_connections(d)
    assert (c, tuple(d["pair"][kl]), tuple(d["pair"][kr])) == (0, (0, 1), (0, 7))
    Fl, Fr = d["cforce"][1:, kl], d["cforce"][1:, kr]
    nl = np.linalg.norm(Fl, axis=1)
    assert np.all(nl > 0)
    assert np.max(np.linalg.norm(Fl + Fr, axis=1) / nl) < 1e-6
    assert np.max(np.abs(Fl[:, 1]) / nl) < 1e-6 and np.max(np.abs(Fr[:, 1]) / nl) < 1e-6
    # not trivially symmetric: x and z are both loaded and opposite
    assert np.all(np.abs(Fl[:, 0]) > 1e-3 * nl) or np.all(np.abs(Fl[:, 2]) > 1e-3 * nl)
    w = d["angular_velocity"][1:, 0]
    assert np.all(w[:, 1] > 0), "the star must turn with the vorticity (+y for u_x increasing with z)"
    assert np.max(np.abs(w[:, [0, 2]])) <= 1e-6 * np.max(np.abs(w[:, 1]))
    drift = np.linalg.norm(d["position"][:, 0] - d["position"][0, 0], axis=1).max()
    assert drift < 1e-9 * 5e-5  # the centre sphere does not move (symmetry), dx = 5e-5 m
    m = d["mass"]
    assert np.max(np.abs(m - m[0])) / m[0] < DUAL_STAR_MASS_SHORT


def test_sphere_in_shear_short(coupler, tmp_path):
    """The scene at half the resolution (fluid.dx = 2e-5 m: r = 4 cells in a 112 x 48 x 80 box, the same
    shear rate, Re and end time 5 a^2/nu, 240 steps): the sphere spins up from rest with the vorticity
    (+y) and ends within 1% of gamma/2 (measured -0.04%), without turning about x or z or moving."""
    out = tmp_path / "sphere_in_shear.h5"
    d = _run("sphere_in_shear", out, "--set", "fluid.dx=2e-5")
    for k in ("force", "torque", "position", "angular_velocity", "mass"):
        assert np.all(np.isfinite(d[k])), k
    gamma, n, e, w = check_shear.shear_flow(d["scene"])
    assert np.allclose(w, [0, 1, 0])
    wy = d["angular_velocity"][:, 0, 1]
    assert wy[0] == 0 and np.all(wy[1:] > 0)
    assert abs(wy[-1] / (gamma / 2) - 1) < 0.01, wy[-1] / (gamma / 2)
    assert np.max(np.linalg.norm(d["position"][:, 0] - d["position"][0, 0], axis=1)) < 1e-3 * 2e-5
    assert np.max(np.abs(d["angular_velocity"][:, 0, [0, 2]])) < 1e-3 * gamma / 2
    m = d["mass"]
    assert np.max(np.abs(m - m[0])) / m[0] < SPHERE_MASS_SHORT


def test_fit_sinusoid_recovers_known_signal():
    t = np.linspace(0.1, 1.9, 200)
    y = 0.3 + 2.0 * np.sin(2 * math.pi * t / 1.7 + 0.4)
    f = check_shear.fit_sinusoid(t, y, 0.2, 20)
    assert abs(f["period"] - 1.7) < 1e-6 and abs(f["amplitude"] - 2.0) < 1e-6 and f["rel_rms"] < 1e-8


def _run_long(*args):
    """Like conftest.run, with room for a full run on a shared machine (12 min measured here)."""
    env = dict(os.environ, OMP_NUM_THREADS="2")
    return subprocess.run([str(COUPLER), *map(str, args)], capture_output=True, text=True, env=env, timeout=2400)


@pytest.mark.validate
def test_dual_star_full(coupler, tmp_path):
    """The full run (7540 steps; 12-20 min here with the machine shared, ~6 min alone): symmetry to
    1e-6, rotation about y, and the central connection load a sinusoid of 2 theta (residual <= 5%,
    period pi +- 10%) (check_shear.check_dual_star)."""
    out = tmp_path / "dual_star_shear.h5"
    p = _run_long("run", MODELS / "dual_star_shear.yaml", "-o", out, "--quiet")
    assert p.returncode == 0, p.stderr
    ok, lines = check_shear.check_dual_star(out, tmp_path)
    assert ok, "\n".join(lines)


@pytest.mark.validate
def test_sphere_in_shear_full(coupler, tmp_path):
    """The full scene (r = 8 cells, 224 x 96 x 160, 960 steps; 3.5 min here): steady w_y = gamma/2
    within 1% (check_shear.check_sphere_in_shear), and the CLI picks that check from the file."""
    out = tmp_path / "sphere_in_shear.h5"
    p = _run_long("run", MODELS / "sphere_in_shear.yaml", "-o", out, "--quiet")
    assert p.returncode == 0, p.stderr
    ok, lines = check_shear.check_sphere_in_shear(out, tmp_path)
    assert ok, "\n".join(lines)
    p = subprocess.run([str(PY), str(MODELS / "checks" / "check.py"), str(out), "-o", str(tmp_path)],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stdout + p.stderr
