"""The fluid's numerical-trouble detectors through the coupler (issue 14, "Detection inside
the components"): a scene that blows up, or that runs faster than the lattice or the moving
boundary allows, stops with a non-zero exit and a message that names the step, the place and the
cause, and the output file opens with every row written before the failure, all finite: no
silent NaN. The component-level tests are in tests/fluid (flows "numerical trouble", spheres)
and tests/rigid (rigid_contact "energy growth", rigid_walls)."""
import re

import h5py
import numpy as np
import pytest

from conftest import run

# a closed 16^3 cavity of 0.4 mm, the lid (z_max) moving along x
CAVITY = """domain:
  size: [4.0e-4, 4.0e-4, 4.0e-4]
  faces:
    x_min: {{type: no_slip}}
    x_max: {{type: no_slip}}
    y_min: {{type: no_slip}}
    y_max: {{type: no_slip}}
    z_min: {{type: no_slip}}
    z_max: {{type: moving_wall, velocity: [{lid}, 0.0, 0.0]}}
fluid:
  density: 1000.0
  viscosity: 1.0e-6
  dx: 2.5e-5
  tau: {tau}
  collision: {collision}
run:
  end_time: {end}
  output_interval: {out}
"""

# a heavy sphere (radius 3 cells) falling in a periodic 16^3 box: it accelerates until it moves
# more than half a cell per LBM step (dt = 1/600 s, half a cell per step = 0.03 m/s)
FALLING = """domain:
  size: [1.6e-3, 1.6e-3, 1.6e-3]
fluid:
  density: 1000.0
  viscosity: 1.0e-6
  dx: 1.0e-4
  tau: 1.0
  boundary_scheme: cli
bodies:
  - density: 100000.0
    spheres:
      - {center: [8.0e-4, 8.0e-4, 8.0e-4], radius: 3.0e-4}
rigid:
  gravity: [0, 0, -0.5]
run:
  end_time: 1.0
  output_interval: 0.00334
"""


def assert_rows_finite(path, min_rows):
    """The output opens and holds at least min_rows rows, every value finite."""
    with h5py.File(path, "r") as f:
        n = len(f["/time"])
        assert n >= min_rows
        bad = []

        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and obj.dtype.kind == "f" and not np.all(np.isfinite(obj[()])):
                bad.append(name)
        f.visititems(visit)
        assert bad == [], "non-finite values in " + ", ".join(bad)
    return n


def trouble_line(stderr):
    lines = [l for l in stderr.splitlines() if "numerical trouble at step" in l]
    assert lines, stderr
    return lines[0]


def test_blow_up_stops_at_nan_or_negative_density(coupler, tmp_path):
    """tau 0.5001 (BGK) under a lid at 300 m/s (0.3 cells per step): the lattice blows up within
    100 steps. The Mach limit is raised to 1 so that what is found is the blow-up, not the
    flow's speed: a density gone negative or non-finite, or a corner cell running away faster
    than the lattice's speed of sound (what it does since the edges of the lid keep the mass,
    walls_build.c balance_cell), each reported as an unstable lattice with fluid.tau as the remedy;
    the totals read at every output row (every 10 steps) check every cell, so the run stops at
    the first row after the blow-up, before a NaN is written."""
    scene = tmp_path / "blowup.yaml"
    scene.write_text(CAVITY.format(lid=300.0, tau=0.5001, collision="bgk", end=1e-5, out=2.1e-7))
    out = tmp_path / "blowup.h5"
    p = run("run", scene, "-o", out, "--quiet", "--set", "fluid.mach_limit=1")
    assert p.returncode == 1, p.stderr
    line = trouble_line(p.stderr)
    assert re.search(r"numerical trouble at step \d+ \(t = [0-9.e+-]+ s\), cell \(\d+, \d+, \d+\) at \([^)]*\) m: "
                     r"(non-finite density|non-positive density|velocity above the Mach limit)", line), line
    mach = re.search(r"Mach ([0-9.e+-]+),", line)
    assert "velocity above the Mach limit" not in line or float(mach.group(1)) > 1.0, line
    assert "lattice became unstable" in line and "fluid.tau" in line, line  # the remedy
    kept = re.search(r"stopped; \S+ holds the (\d+) output rows written before \(to t = ([0-9.e+-]+) s\)", p.stderr)
    assert kept, p.stderr
    n = assert_rows_finite(out, 3)
    with h5py.File(out, "r") as f:  # read back from the file after its close
        assert int(kept.group(1)) == f["/time"].shape[0]
        assert float(kept.group(2)) == pytest.approx(f["/time"][-1], rel=1e-9)
    # the failing step lies after the last row written
    step = int(re.search(r"at step (\d+)", line).group(1))
    with h5py.File(out, "r") as f:
        assert f["/time"][-1] < step * 2.1e-8


@pytest.mark.parametrize("collision", ["bgk", "trt"])
def test_blow_up_names_trt_as_a_remedy_only_for_bgk(coupler, tmp_path, collision):
    """The blow-up's remedy offers TRT only to a BGK scene. Before, a TRT cavity at tau 0.501
    (lid 24 m/s = 0.2 cells per step) whose density went negative was told "use TRT
    (fluid.collision: trt)"."""
    scene = tmp_path / "blowup.yaml"
    scene.write_text(CAVITY.format(lid=24.0, tau=0.501, collision=collision, end=1e-3, out=2.1e-5))
    p = run("run", scene, "-o", tmp_path / "blowup.h5", "--quiet", "--set", "fluid.mach_limit=1")
    assert p.returncode == 1, p.stderr
    line = trouble_line(p.stderr)
    assert "lattice became unstable" in line and "fluid.tau" in line, line
    assert ("TRT" in line) == (collision == "bgk"), line


def test_mach_limit_stops_a_fast_lid(coupler, tmp_path):
    """A lid at 0.09 m/s = 0.225 cells per step (Mach 0.39) drags the fluid under it above
    fluid.mach_limit = 0.3 (|u| 0.173 lattice) within 50 steps; with the limit at 0.5 the same
    run finishes."""
    scene = tmp_path / "lid.yaml"
    scene.write_text(CAVITY.format(lid=0.09, tau=0.8, collision="trt", end=0.01, out=6.25e-4))
    out = tmp_path / "lid.h5"
    p = run("run", scene, "-o", out, "--quiet")
    assert p.returncode == 1, p.stderr
    line = trouble_line(p.stderr)
    assert re.search(r"cell \(\d+, \d+, 15\) at \([0-9.e+-]+, [0-9.e+-]+, 0.0003875\) m: velocity above the Mach "
                     r"limit", line), line  # the top layer of cells, under the lid
    mach = float(re.search(r"= Mach ([0-9.]+)", line).group(1))
    assert 0.3 <= mach < 0.5 and "fluid.mach_limit 0.3" in line  # printed to 4 digits
    assert_rows_finite(out, 2)
    p = run("run", scene, "-o", out, "--quiet", "--set", "fluid.mach_limit=0.5")
    assert p.returncode == 0, p.stderr
    assert_rows_finite(out, 17)


def test_sphere_faster_than_half_a_cell_per_step_stops(coupler, tmp_path):
    """The falling sphere passes half a cell per step after ~40 steps: the fluid refuses the move
    with the sphere, the distance, the step and the remedies (the Mach limit is raised to 1 and the
    boundaries are cli, so that the wake does not stop the run first: with multireflection it
    passes Mach 1 at step 39, just before the sphere passes half a cell)."""
    scene = tmp_path / "falling.yaml"
    scene.write_text(FALLING)
    out = tmp_path / "falling.h5"
    p = run("run", scene, "-o", out, "--quiet", "--set", "fluid.mach_limit=1")
    assert p.returncode == 1, p.stderr
    m = re.search(r"sphere 0 moves ([0-9.]+) cells in one step at step (\d+) \(t = [0-9.e+-]+ s\), from "
                  r"\([^)]*\) m", p.stderr)
    assert m, p.stderr
    assert 0.5 < float(m.group(1)) < 0.6
    assert "limit half a cell per step" in p.stderr and "fluid.tau" in p.stderr and "fluid.dx" in p.stderr
    n = assert_rows_finite(out, 10)
    with h5py.File(out, "r") as f:
        v = f["/spheres/velocity"][:, 0, 2]
        assert v[-1] < -0.02  # it was falling fast, below the limit, at the last row


def test_sphere_moved_too_far_by_a_long_communication_step_names_exchange_every(coupler, tmp_path):
    """With --exchange-every K the fluid holds a sphere in place for K LBM steps and moves it at
    the end of the communication step: a heavy sphere coasting at 0.05 cells per LBM step (0.049 when it is set) moves
    0.59 cells at once with K = 12. The fluid refuses the move, and the message names the communication
    step and the largest K for that speed (10), not a time step or cells (before: 'use a smaller
    time step (fluid.tau closer to 0.5, or fluid.dt), more cells ...', for a sphere ten times
    slower than the limit). K = 8 (0.4 cells) runs."""
    scene = tmp_path / "coasting.yaml"
    scene.write_text(FALLING.replace("gravity: [0, 0, -0.5]", "gravity: [0, 0, 0]")
                     .replace("  - density: 100000.0\n", "  - density: 100000.0\n    velocity: [0, 0, -0.003]\n")
                     .replace("end_time: 1.0", "end_time: 0.08"))
    out = tmp_path / "coasting.h5"
    p = run("run", scene, "-o", out, "--quiet", "--exchange-every", "12")
    assert p.returncode == 1, p.stderr
    m = re.search(r"sphere 0 moves ([0-9.]+) cells in one step at step 12 .* ([0-9.]+) cells per LBM step", p.stderr)
    assert m and 0.55 < float(m.group(1)) < 0.61 and 0.045 < float(m.group(2)) <= 0.05, p.stderr
    assert "a communication step of 12 LBM steps (coupler run --exchange-every 12)" in p.stderr, p.stderr
    assert "--exchange-every at most 10 at this speed" in p.stderr and "fluid.tau" not in p.stderr, p.stderr
    p = run("run", scene, "-o", out, "--quiet", "--exchange-every", "8")
    assert p.returncode == 0, p.stderr


# a heavy sphere (radius 4 cells) launched at 0.45 cells per step at tau 0.505 in a closed 24 x 16 x 16
# box: the lattice cannot follow (Mach 0.35 at its surface in the first step, a negative density at
# step 4), while the load stays finite
LAUNCHED = """domain:
  size: [2.4e-3, 1.6e-3, 1.6e-3]
  faces:
    x_min: {type: no_slip}
    x_max: {type: no_slip}
    y_min: {type: no_slip}
    y_max: {type: no_slip}
    z_min: {type: no_slip}
    z_max: {type: no_slip}
fluid: {density: 1000.0, viscosity: 1.0e-6, dx: 1.0e-4, tau: 0.505}
bodies:
  - density: 3000.0
    velocity: [2.7, 0, 0]
    spheres:
      - {center: [1.23e-3, 8.1e-4, 8.2e-4], radius: 4.0e-4}
contacts: {model: spring_dashpot}
run: {end_time: 5.0e-3, output_interval: 8.3335e-05}
"""


def test_finite_garbage_load_is_the_fluids_trouble(coupler, tmp_path):
    """A finite load from a fluid in numerical trouble stops the run in the fluid, naming the cell
    and the cause, before a free body takes it. Before, the load of step 4 (1420 times the sphere's
    drag coefficient) threw the sphere 77 cells through the x_min wall and the rigid component
    stopped the run blaming the contact: "overlaps face x_min by 0.00767 m ... shorten
    contacts.contact_time or raise rigid.substeps"."""
    scene = tmp_path / "launched.yaml"
    scene.write_text(LAUNCHED)
    out = tmp_path / "launched.h5"
    p = run("run", scene, "-o", out, "--quiet")
    assert p.returncode == 1, p.stderr
    line = trouble_line(p.stderr)
    assert re.search(r"numerical trouble at step [1-4] \(t = [0-9.e+-]+ s\), cell \(\d+, \d+, \d+\) at \([^)]*\) m: "
                     r"(non-positive density|velocity above the Mach limit)", line), line
    assert "sphere load larger than a sane fluid gives" in p.stderr
    assert "overlaps face" not in p.stderr and "contact_time" not in p.stderr, p.stderr
    assert_rows_finite(out, 1)


TOUCHING = """\
domain: {size: [1.0e-4, 1.0e-4, 1.0e-4]}
fluid: {density: 1000.0, viscosity: 1.0e-6, dx: 1.0e-5, tau: 1.0}
bodies:
  - {name: b, density: 2000.0, spheres: [{center: [5.0e-5, 5.0e-5, 5.0e-5], radius: 2.0e-5}]}
  - {name: c, density: 2000.0, spheres: [{center: [9.0e-5, 5.0e-5, 5.0e-5], radius: 2.0e-5}]}
rigid: {gravity: [0, 0, -9.81]}
run: {end_time: 3.3334e-4, output_interval: 8.3335e-5}
"""


def test_bodies_touching_at_rest_are_not_energy_growth(coupler, tmp_path):
    # Two bodies that start exactly touching (centre distance 2 r, which the scene check
    # allows) and settle side by side press on each other only by round-off: a normal speed
    # of 1.8e-12 m/s against an approach speed of 0 was reported as infinite energy growth and
    # stopped the run at step 2. Speeds below 1e-6 of the pair's own are round-off now; a real
    # growth is still stopped (CUnit rigid_contact).
    scene = tmp_path / "touching.yaml"
    scene.write_text(TOUCHING)
    out = tmp_path / "t.h5"
    p = run("run", scene, "-o", out, "--quiet")
    assert p.returncode == 0, p.stderr
    with h5py.File(out, "r") as f:
        v = f["/spheres/velocity"][-1]
    assert v[0, 2] < -1e-4 and abs(v[0, 2] - v[1, 2]) < 1e-9 * abs(v[0, 2])  # settling together


def test_body_reaching_an_outlet_is_named_once(coupler, tmp_path):
    """A neutrally buoyant sphere carried by a channel's flow to its pressure outlet stops there
    (bodies never leave the domain): the rigid component says so once, with the body, the face
    and the time, and the run goes on (it stopped there without a word, found by a sweep)."""
    scene = tmp_path / "outlet.yaml"
    scene.write_text("""domain:
  size: [6.4e-3, 2.4e-3, 2.4e-3]
  faces:
    x_min: {type: velocity_inlet, velocity: [2.0e-3, 0, 0]}
    x_max: {type: pressure_outlet, pressure: 0.0}
    z_min: {type: no_slip}
    z_max: {type: no_slip}
fluid: {density: 1000.0, viscosity: 1.0e-6, dx: 1.0e-4, tau: 0.8}
bodies:
  - density: 1000.0
    spheres:
      - {center: [4.8e-3, 1.2e-3, 1.2e-3], radius: 4.0e-4}
run: {end_time: 0.6, output_interval: 0.01, fields: false}
""")
    p = run("run", scene, "-o", tmp_path / "outlet.h5", "--quiet")
    assert p.returncode == 0, p.stderr
    said = [line for line in p.stderr.splitlines() if "reached the face" in line]
    assert len(said) == 1, p.stderr
    m = re.search(r"body 0 \(sphere 0\) reached the face x_max at t=([0-9.]+) s, an inlet or outlet", said[0])
    assert m and 0.2 < float(m.group(1)) < 0.6, said
    with h5py.File(tmp_path / "outlet.h5", "r") as f:
        x = f["spheres/position"][:, 0, 0]
    assert x.max() <= 6.4e-3 - 4.0e-4 + 1e-5  # held at the face (a contact's overlap at most)
