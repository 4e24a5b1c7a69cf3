"""A prescribed body meets free bodies where the fluid has it.

The rigid component takes fixed and prescribed bodies as obstacles of infinite mass. It kept a
prescribed body where it started, while the fluid moved it on: a prescribed sphere driven at a
free one passed through it (overlap 1.17 radii, no contact, no error), and a free sphere
settling through the place the prescribed sphere had left met a lubrication film there, from
nothing (up to 0.38 of its net weight). Now the rigid component moves a prescribed body with its
prescribed motion (rigid_kinematic_advance).
"""
import math

import h5py
import numpy as np

from conftest import run

DX = 1e-4
TAU = 0.8
DT = (TAU - 0.5) * DX * DX / 3e-6   # 1e-3 s, nu = 1e-6 m^2/s
A = 4                               # sphere radius, cells


def _scene(path, size, faces, bodies, steps, gravity=0.0, every=1):
    body_text = ""
    for name, motion, rho, vel, centre in bodies:
        body_text += f"""
  - name: {name}
    motion: {motion}
    density: {rho}
    velocity: [{vel[0] * DX / DT!r}, {vel[1] * DX / DT!r}, {vel[2] * DX / DT!r}]
    spheres:
      - {{center: [{centre[0] * DX!r}, {centre[1] * DX!r}, {centre[2] * DX!r}], radius: {A * DX!r}}}"""
    face_text = "".join(f"\n    {f}: {{type: no_slip}}" for f in faces)
    path.write_text(f"""domain:
  size: [{size[0] * DX!r}, {size[1] * DX!r}, {size[2] * DX!r}]
  faces:{face_text}
fluid: {{density: 1000.0, viscosity: 1.0e-6, dx: {DX!r}, tau: {TAU}}}
bodies:{body_text}
rigid: {{gravity: [0, 0, {-gravity!r}]}}
run: {{end_time: {steps * DT!r}, output_interval: {every * DT!r}}}
""")


def test_prescribed_sphere_pushes_a_free_sphere_instead_of_passing_through(coupler, tmp_path):
    """A prescribed sphere driven at 0.01 cells a step straight at a free sphere at rest, 6 cells
    of gap ahead (24 x 24 x 48, periodic x and y): it touches and pushes it. Before, it passed
    through it (the overlap reached 1.17 radii at step 1540, with no contact and no error)."""
    scene = tmp_path / "push.yaml"
    _scene(scene, (24, 24, 48), ("z_min", "z_max"),
           [("pusher", "prescribed", 2000.0, (0, 0, 0.01), (12, 12, 8)),
            ("free", "free", 2000.0, (0, 0, 0), (12, 12, 22))], 1800)
    out = tmp_path / "push.h5"
    p = run("run", scene, "-o", out, "--quiet")
    assert p.returncode == 0, p.stderr
    with h5py.File(out, "r") as f:
        x = f["/spheres/position"][()] / DX
        v = f["/spheres/velocity"][()] * DT / DX
    gap = (np.linalg.norm(x[:, 1] - x[:, 0], axis=1) - 2 * A) / A
    assert gap.min() > -0.02, f"overlap {-gap.min():.3f} radii at row {gap.argmin()}"
    # pushed along: at the end it moves with the pusher (0.01), in contact or in its film
    assert abs(v[-1, 1, 2] - 0.01) < 1e-3, v[-1, 1]
    assert gap[-1] < 0.1


def test_no_film_where_a_prescribed_sphere_started(coupler, tmp_path):
    """A prescribed sphere leaves along x at 0.01 cells a step; a free sphere settles through the
    place where it started, once the mover is more than 2 cells (the film's cut-off) away from it.
    The free sphere's momentum balance, m dv/dt = F_hydro + net weight, then holds: no force acts
    but the fluid's and gravity. Before, a film against the empty start place pushed it (0.3 of
    its net weight while its gap to that place was below the cut-off; 0.43 here)."""
    g = 9 * 0.1 * 0.005 / (2 * A * A) * DX / DT ** 2  # lattice Stokes velocity 0.005 at ratio 2
    scene = tmp_path / "phantom.yaml"
    every = 10
    _scene(scene, (48, 24, 40), ("z_min", "z_max"),
           [("mover", "prescribed", 2000.0, (0.01, 0, 0), (16, 12, 12)),
            ("free", "free", 2000.0, (0, 0, 0), (16.3, 12, 26))], 3000, gravity=g, every=every)
    out = tmp_path / "phantom.h5"
    p = run("run", scene, "-o", out, "--quiet")
    assert p.returncode == 0, p.stderr
    with h5py.File(out, "r") as f:
        t = f["/time"][()]
        x = f["/spheres/position"][()]
        v = f["/spheres/velocity"][()]
        force = f["/spheres/force"][()]
    vol = 4 / 3 * math.pi * (A * DX) ** 3
    m = 2000.0 * vol
    weight = np.array([0.0, 0.0, -(m - 1000.0 * vol) * g])
    start = np.array([16, 12, 12]) * DX
    gap = (np.linalg.norm(x[:, 1] - start, axis=1) - 2 * A * DX) / DX
    sep = x[:, 1] - x[:, 0]
    sep[:, 0] -= 48 * DX * np.round(sep[:, 0] / (48 * DX))
    gap_mover = (np.linalg.norm(sep, axis=1) - 2 * A * DX) / DX
    assert gap.min() < 0.5, "the free sphere must pass close to the start place"
    assert gap_mover.min() > 2.5, "the mover must stay beyond the film's cut-off"
    # rows `every` steps apart: the force of the row's last step stands for the interval
    resid = m * np.diff(v[:, 1], axis=0) / np.diff(t)[:, None] - force[1:, 1] - weight
    near = (gap[1:] < 2.0) & (t[1:] > 300 * DT)
    assert near.sum() > 20
    worst = np.abs(resid[near]).max() / abs(weight[2])
    assert worst < 0.02, f"a force of {worst:.3g} of the net weight near the start place"


def _push_run(tmp_path, name, sets):
    """A prescribed sphere at 0.04 cells a step, 1 cell from a free sphere at rest of the
    same size (24 x 16 x 16, periodic x and y): 120 steps, the last 90 of them pushing."""
    scene = tmp_path / f"{name}.yaml"
    _scene(scene, (24, 16, 16), ("z_min", "z_max"),
           [("pusher", "prescribed", 2000.0, (0.04, 0, 0), (5, 8, 8)),
            ("free", "free", 2000.0, (0, 0, 0), (14, 8, 8))], 120)
    out = tmp_path / f"{name}.h5"
    p = run("run", scene, "-o", out, "--quiet", *[a for s in sets for a in ("--set", s)])
    assert p.returncode == 0, f"{sets}: {p.stderr[-1500:]}"
    with h5py.File(out, "r") as f:
        return f["/spheres/velocity"][()] * DT / DX


def test_prescribed_push_resolved_in_time_by_substeps_and_cvode(coupler, tmp_path):
    """The integrators move a prescribed body with the free ones (a Verlet drift, each CVODE
    evaluation at its own time). Before, it sat at the step's midpoint during the rigid step
    while the contact's dashpot used its velocity: an integrator that resolves the contact
    within the step (rigid.substeps 20, cvode) saw it jump half its step's travel (0.02 cells,
    more than the contact's overlap) at each step's end and the pair gained energy: 'energy
    growth in the contact', 2.2 and 1.8 times, exit 1, at the first touch. Now the three
    integrations agree: pushed along at the pusher's speed."""
    ends = {}
    for name, sets in (("verlet", ()), ("substeps", ("rigid.substeps=20",)), ("cvode", ("rigid.integrator=cvode",))):
        v = _push_run(tmp_path, name, sets)
        assert v[:, 1, 0].max() < 0.04 * 1.02, f"{name}: the free sphere overtakes the pusher: {v[:, 1, 0].max()}"
        ends[name] = v[-1, 1, 0]
    assert abs(ends["verlet"] - 0.04) < 0.002, ends
    for name in ("substeps", "cvode"):
        assert abs(ends[name] - ends["verlet"]) < 2e-4, ends
