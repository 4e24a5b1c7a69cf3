"""A sphere in a periodic domain shorter than the reach of its links on both
sides (N < 2 (r + sqrt 2) cells along a periodic axis: a thin periodic slab)
sees a cell as two images of itself. The flow must be the one of a domain
twice as long holding the image as a second sphere: every link once, with
the geometry of the image its ray hits (fluid/sphere_links.c others_find).
Found by a sweep of unseen scenes: radius 1.6 cells in a 4-cell slab had
links counted twice (drag +22%), radius 4.1 in a 10-cell slab +1.4%; a
free sphere there moved differently on 1 rank and on 2 (the kept link
lists of one rank against the lists built anew of several).
"""
import h5py
import numpy as np
import pytest

from conftest import datasets, run
from mpi_util import MPIRUN, run_coupler

SCENE = """
domain:
  size: [{lx}, {ly}, {lz}]
fluid:
  density: 1000.0
  viscosity: 1.0e-6
  dx: 1.0e-5
  tau: 0.8
  body_force: [200.0, 50.0, 100.0]
bodies:
  - name: s
    density: 3000.0
    motion: fixed
    spheres:
{spheres}
contacts: {{model: none}}
run:
  end_time: 3.0e-4
  output_interval: 1.0e-4
"""


def sphere(c, r):
    return f"      - {{center: [{c[0]!r}, {c[1]!r}, {c[2]!r}], radius: {r!r}}}"


@pytest.mark.parametrize("axis,n,r", [(0, 4, 1.6e-5), (2, 10, 4.1e-5)])
def test_thin_periodic_slab_equals_its_double_with_the_image(coupler, tmp_path, axis, n, r):
    """A fixed sphere in a slab n cells thick against the slab 2 n thick with
    a second sphere one period on (one body, so no film between them): the
    same load on every sphere (the sums differ in order only)."""
    size = [2.4e-4, 2.4e-4, 2.4e-4]
    c = [1.23e-4, 1.11e-4, 1.17e-4]
    size[axis] = n * 1e-5
    c[axis] = 0.43 * n * 1e-5
    loads = []
    for copies in (1, 2):
        lx, ly, lz = size[0], size[1], size[2]
        big = list(size)
        big[axis] = copies * size[axis]
        centres = []
        for j in range(copies):
            cj = list(c)
            cj[axis] += j * size[axis]
            centres.append(sphere(cj, r))
        scene = tmp_path / f"slab{copies}.yaml"
        scene.write_text(SCENE.format(lx=big[0], ly=big[1], lz=big[2], spheres="\n".join(centres)))
        out = tmp_path / f"slab{copies}.h5"
        p = run("run", scene, "-o", out, "--quiet")
        assert p.returncode == 0, p.stderr[-2000:]
        with h5py.File(out, "r") as f:
            loads.append(f["spheres/force"][-1])
    one, two = loads
    assert np.abs(one[0]).max() > 0.0
    for j in range(2):
        rel = np.abs(one[0] - two[j]) / np.abs(two[j])
        assert rel.max() < 1e-9, f"the slab's load {one[0]} differs from its double's {two[j]} by {rel}"


MOVING = """
domain:
  size: [4.0e-5, 1.6e-4, 2.4e-4]
  faces:
    z_min: {type: no_slip}
    z_max: {type: no_slip}
fluid:
  density: 1000.0
  viscosity: 1.0e-6
  dx: 1.0e-5
  tau: 0.8
bodies:
  - name: small
    density: 3000.0
    velocity: [0.01, 0.0, 0.0]
    spheres:
      - {center: [0.2e-4, 0.8e-4, 0.6e-4], radius: 1.5e-5}
rigid: {gravity: [0, 0, -9.81]}
run:
  end_time: 6.0e-4
  output_interval: 1.0e-5
"""


@pytest.mark.skipif(MPIRUN is None, reason="mpirun (openmpi-bin) is not installed")
def test_free_sphere_in_thin_slab_same_on_1_and_2_ranks(tmp_path):
    """A free sphere (radius 1.5 cells) settling and drifting in a 4-cell
    periodic slab: one rank keeps and refreshes its links, two ranks build
    them anew every step; both must give the same run to the bit (it
    differed from step 17 on: links a refresh never had)."""
    scene = tmp_path / "thin.yaml"
    scene.write_text(MOVING)
    outs = []
    for ranks in (1, 2):
        out = tmp_path / f"thin_{ranks}.h5"
        cut = ["--set", "run.ranks=[1, 1, 2]"] if ranks == 2 else []
        r = run_coupler(ranks, "run", scene, "-o", out, "--quiet", *cut)
        assert r.returncode == 0, r.stderr[-2000:]
        outs.append(datasets(out))
    a, b = outs
    assert sorted(a) == sorted(b)
    for k in a:
        assert np.array_equal(a[k], b[k]), k
