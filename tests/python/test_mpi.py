"""The fluid on several MPI ranks gives the same answer as on one (issue 13).

Each case runs `coupler run` on 1 rank and under `mpirun -np 2` and `-np 4`
(`--oversubscribe`: more ranks than this machine's cores) and asserts that
the result files are identical, bit for bit: the time series of mass,
momentum and kinetic energy (sums over all cells, exact sums: common/
exact_sum.h) and, where the scene writes them, the field snapshots (each
rank writes its block with parallel HDF5). A wrong halo exchange (a missing
edge, a direction on the wrong side, a face of the domain treated as a rank
face or the reverse) changes the flow within a few steps and fails these.
"""
import shutil
import subprocess

import h5py
import numpy as np
import pytest

from conftest import ROOT, datasets
from mpi_util import MPIRUN, SETTLE, run_coupler

pytestmark = pytest.mark.skipif(MPIRUN is None, reason="mpirun (openmpi-bin) is not installed")


def run_ranks(tmp_path, scene_text, name, ranks=(1, 2, 4), sets=(), env=None):
    scene = tmp_path / f"{name}.yaml"
    scene.write_text(scene_text)
    outs = []
    for np_ in ranks:
        out = tmp_path / f"{name}_{np_}.h5"
        args = ["run", str(scene), "-o", str(out), "--quiet"]
        for s in sets:
            args += ["--set", s]
        r = run_coupler(np_, *args, env=env)
        assert r.returncode == 0, f"{np_} ranks: {r.stderr[-3000:]}"
        with h5py.File(out, "r") as f:
            assert f.attrs["ranks"] == np_
        outs.append(out)
    return outs


def fields_of(out):
    return out.with_name(out.stem + "_fields.h5")


def assert_identical(outs):
    """Time series and field snapshots (parallel HDF5 on several ranks) bit
    for bit; the fields also by h5diff with zero tolerance."""
    for path_of in (lambda o: o, fields_of):
        ref = datasets(path_of(outs[0]))
        assert len(ref) > 3, sorted(ref)
        for out in outs[1:]:
            other = datasets(path_of(out))
            assert sorted(other) == sorted(ref), out
            for k, v in ref.items():
                assert np.array_equal(v, other[k]), f"{out}: {k} differs (max {np.max(np.abs(v - other[k]))})"
    h5diff = shutil.which("h5diff")
    if h5diff is not None:
        for out in outs[1:]:
            r = subprocess.run([h5diff, str(fields_of(outs[0])), str(fields_of(out))], capture_output=True, text=True)
            assert r.returncode == 0, r.stdout[-2000:]


BOX = """
domain:
  size: [{lx}, {ly}, {lz}]
  faces:
{faces}
fluid:
  density: 1000.0
  viscosity: 1.0e-6
  dx: 1.0e-4
  tau: 0.8
  collision: {collision}
  streaming: {streaming}
  precision: {precision}
  body_force: [3.0, 1.0, 0.0]
  initial_velocity: [1.0e-4, -2.0e-4, 5.0e-5]
run:
  end_time: {end}
  output_interval: {out}
  fields: true
  field_interval: {fout}
"""

ALL_FACES = """    x_min: {type: velocity_inlet, velocity: [3.0e-3, 0.0, 1.0e-3], profile: parabolic}
    x_max: {type: pressure_outlet, pressure: 0.0}
    y_min: {type: free_slip}
    y_max: {type: no_slip}
    z_min: {type: no_slip}
    z_max: {type: moving_wall, velocity: [4.0e-3, 2.0e-3, 0.0]}"""

PERIODIC_X = """    y_min: {type: free_slip}
    y_max: {type: free_slip}
    z_min: {type: no_slip}
    z_max: {type: moving_wall, velocity: [4.0e-3, 2.0e-3, 0.0]}"""


def box(faces, streaming="in_place", precision="double", collision="trt", cells=(16, 12, 10), end=0.5):
    dt = (0.8 - 0.5) / 3 * 1.0e-4 ** 2 / 1.0e-6  # tau, dx, nu: 1 ms
    return BOX.format(lx=cells[0] * 1e-4, ly=cells[1] * 1e-4, lz=cells[2] * 1e-4, faces=faces,
                      streaming=streaming, precision=precision, collision=collision, end=end, out=20 * dt,
                      fout=100 * dt)


@pytest.mark.parametrize("streaming", ["in_place", "two_array"])
def test_every_face_type_same_on_1_2_4_ranks(tmp_path, streaming):
    """Inlet with a parabolic profile, pressure outlet, free slip, no slip and a
    moving wall, cut along z, then y and z (MPI_Dims_create): the exchange
    overlaps the update of the inner rows, the x faces' links come before it."""
    assert_identical(run_ranks(tmp_path, box(ALL_FACES, streaming), "faces_" + streaming))


@pytest.mark.parametrize("ranks", ["[2, 1, 1]", "[4, 1, 1]"])
def test_every_face_type_cut_along_the_channel(tmp_path, ranks):
    """The same faces cut along x, the inlet-outlet axis: with 4 ranks the
    outlet's block is 4 cells long; its links read their own rank's cells
    (x_f and the cell across the face from the ghost, walls.h), the ones cut
    along z and y (test above) the other rank's value in the exchanged
    ghost layer."""
    n = eval(ranks)[0]
    assert_identical(run_ranks(tmp_path, box(ALL_FACES), "faces_x", ranks=(1, n), sets=[f"run.ranks={ranks}"]))


@pytest.mark.parametrize("ranks", ["[2, 1, 1]", "[4, 1, 1]", "[2, 2, 1]", "[1, 2, 2]"])
def test_periodic_face_across_ranks(tmp_path, ranks):
    """x periodic and cut: the periodic face is an exchange between the first
    and the last rank along x (with 2 ranks, both neighbours are the same
    rank); an edge of periodic and wall faces on the cut."""
    n = eval(ranks)[0] * eval(ranks)[1] * eval(ranks)[2]
    outs = run_ranks(tmp_path, box(PERIODIC_X), "per", ranks=(1, n), sets=[f"run.ranks={ranks}"])
    assert_identical(outs)


FREE_SLIP_X = """    x_min: {type: free_slip}
    x_max: {type: free_slip}
    y_min: {type: periodic}
    y_max: {type: periodic}
    z_min: {type: no_slip}
    z_max: {type: moving_wall, velocity: [4.0e-3, 2.0e-3, 0.0]}"""


@pytest.mark.parametrize("streaming", ["in_place", "two_array"])
def test_free_slip_x_faces_and_periodic_cut(tmp_path, streaming):
    """Free-slip x faces (copies of the inner rows, before the overlapped
    exchange; their edges with the moving wall after it) and a periodic y
    axis cut between ranks."""
    ref = run_ranks(tmp_path, box(FREE_SLIP_X, streaming), "fsx1_" + streaming, ranks=(1,))
    two = run_ranks(tmp_path, box(FREE_SLIP_X, streaming), "fsx2_" + streaming, ranks=(2,), sets=["run.ranks=[1, 2, 1]"])
    four = run_ranks(tmp_path, box(FREE_SLIP_X, streaming), "fsx4_" + streaming, ranks=(4,), sets=["run.ranks=[1, 2, 2]"])
    assert_identical(ref + two + four)


@pytest.mark.parametrize("streaming", ["in_place", "two_array"])
def test_blocks_without_inner_cells(tmp_path, streaming):
    """Blocks 2 cells thick along y (a quasi-2D scene) cut along z have no
    inner rows (y and z two cells from every face): fluid_step runs them in
    sequence, not overlapped; the moving wall and the inlet make the flow
    three-dimensional within the block."""
    outs = run_ranks(tmp_path, box(ALL_FACES, streaming, cells=(16, 2, 12)), "thin_" + streaming, ranks=(1, 2),
                     sets=["run.ranks=[1, 1, 2]"])
    assert_identical(outs)


@pytest.mark.parametrize("streaming", ["in_place", "two_array"])
def test_exchange_in_sequence_same_as_overlapped(tmp_path, streaming):
    """AGGLO_OVERLAP=0 (the comparison in make bench-mpi) runs the exchange
    before the update of any cell: the same bits as the overlapped step, with
    a moving sphere across the cuts."""
    scene = SETTLE.replace("streaming: in_place", f"streaming: {streaming}")
    outs = run_ranks(tmp_path, scene, "seq_" + streaming, ranks=(1, 2), sets=["run.ranks=[1, 1, 2]"],
                     env={"AGGLO_OVERLAP": "0"})
    assert_identical(outs)


def test_single_precision_and_bgk(tmp_path):
    assert_identical(run_ranks(tmp_path, box(ALL_FACES, "in_place", "single", "bgk"), "single", ranks=(1, 2)))


def test_field_slabs_of_uneven_blocks(tmp_path):
    # 96 x 96 x 40 cells on 3 ranks along z: blocks of 14, 13 and 13 planes, each written
    # a slab at a time (fluid FMU, common/h5fields.h): the ranks' slabs differ, and every
    # rank must still make as many collective writes as the others (a mismatch hangs)
    text = (ROOT / "models" / "channel_poiseuille.yaml").read_text()
    sets = ["domain.size=[2.4e-3,2.4e-3,1.0e-3]", "fluid.initial_profile=plane_channel", "run.fields=true",
            "run.field_interval=6.25e-5", "run.end_time=1.875e-4", "run.output_interval=6.25e-5"]
    outs = run_ranks(tmp_path, text, "slabs", ranks=(1, 3), sets=sets)
    with h5py.File(outs[1], "r") as f:
        assert f.attrs["ranks"] == 3
    assert_identical(outs)


def test_bad_rank_counts_are_refused(tmp_path):
    """run.ranks that does not match the ranks mpirun started, and blocks
    thinner than 4 cells, stop with the key and the numbers."""
    scene = tmp_path / "bad.yaml"
    scene.write_text(box(PERIODIC_X, end=0.01))
    r = run_coupler(2, "run", str(scene), "-o", str(tmp_path / "bad.h5"), "--quiet", "--set", "run.ranks=[1, 1, 4]")
    assert r.returncode != 0
    assert "run.ranks [1, 1, 4] makes 4 blocks, but there are 2 MPI ranks" in r.stderr
    r = run_coupler(2, "run", str(scene), "-o", str(tmp_path / "bad.h5"), "--quiet", "--set", "run.ranks=[1, 1, 2]",
                    "--set", "domain.size=[1.6e-3, 1.2e-3, 5.0e-4]")
    assert r.returncode != 0
    assert "5 cells along z over 2 ranks leaves blocks of fewer than 4 cells" in r.stderr




def test_output_held_by_another_process_stops_all_ranks(tmp_path):
    """Rank 0 alone creates the output: when it cannot (the file is held open by
    another process, e.g. ranks of a killed mpirun still running), every rank
    stops with exit 1 and the file is left as it was. (The other ranks waited
    forever in the first step before, and HDF5's create had emptied the file.)"""
    scene = tmp_path / "box.yaml"
    scene.write_text(box(PERIODIC_X, end=0.01))
    out = tmp_path / "held.h5"
    with h5py.File(out, "w") as f:
        f["x"] = np.arange(3.0)
    before = out.read_bytes()
    with h5py.File(out, "r"):  # held open: HDF5's file lock refuses rank 0's create
        r = run_coupler(2, "run", str(scene), "-o", str(out), "--quiet", timeout=120)
    assert r.returncode == 1, r.stderr[-2000:]
    assert "another process holds this file open" in r.stderr
    assert out.read_bytes() == before


@pytest.mark.parametrize("ranks", ["[2, 1, 1]", "[2, 2, 1]", "[1, 1, 4]", "[4, 1, 1]"])
def test_sphere_settles_across_rank_boundaries(tmp_path, ranks):
    """A free sphere (radius 4.5 cells, density ratio 2) settles from rest
    with its surface across the cuts (x = 12 for 2 ranks along x; z = 16 and
    24 for 4 along z, where it covers and uncovers cells of two ranks; 6-cell
    blocks along x, where it spans three): the loads are summed over the
    ranks, its links read cells of other ranks two deep (the sphere halo), and
    the rigid component runs on every rank. Time series and fields must equal
    the single-rank run bit for bit."""
    n = eval(ranks)[0] * eval(ranks)[1] * eval(ranks)[2]
    outs = run_ranks(tmp_path, SETTLE, "settle", ranks=(1, n),
                     sets=[f"run.ranks={ranks}"])
    assert_identical(outs)
    vel = datasets(outs[0])["spheres/velocity"]
    assert vel[-1, 0, 2] < -1e-3, "the sphere settles (so the test covers a moving sphere)"


def pinched_scene(cells, x_faces, center, end, every, extra_fluid=""):
    """A fixed sphere of radius 3.3 cells touching the floor of a box of
    no-slip walls (x faces: x_faces), started in a uniform flow, with field
    snapshots: the cells between sphere and floor are pinched."""
    L = cells * 1e-4
    return f"""
domain:
  size: [{L!r}, {L!r}, {L!r}]
  faces:
    x_min: {{type: {x_faces}}}
    x_max: {{type: {x_faces}}}
    y_min: {{type: no_slip}}
    y_max: {{type: no_slip}}
    z_min: {{type: no_slip}}
    z_max: {{type: no_slip}}
fluid:
  density: 1000
  viscosity: 1e-06
  dx: 1e-4
  tau: 0.7{extra_fluid}
  initial_velocity: [0.0001, 0.0002, -0.0003]
bodies:
  - name: s
    density: 1500
    motion: fixed
    spheres:
      - {{center: [{center[0]!r}, {center[1]!r}, 0.00033], radius: 0.00033}}
run:
  end_time: {end!r}
  output_interval: {every!r}
  fields: true
  field_interval: {end / 2!r}
"""


PINCHED = pinched_scene(16, "no_slip", (0.000829, 0.000781), 0.06, 0.01)


@pytest.mark.parametrize("skip", ["1", "0"])
def test_pinched_cells_at_a_cut_wall(tmp_path, skip):
    """A sphere touching the floor: the cells between them are pinched, and
    the floor's links there, in the first z row (an outer row, filled late
    when the exchange overlaps the update), take the mean of their pair
    (README "Touching surfaces"). That mean reads f_q(x_f), which in place
    sits in x_f + c_q's slots: read late, after the inner rows' update had
    overwritten the solid cell above (AGGLO_SKIP_SOLID=0), 2 ranks along z
    differed from 1 by 1.5e-4 in density. Read before the update (walls.c
    walls_links_prepare), equal bit for bit, solid cells skipped or not."""
    outs = run_ranks(tmp_path, PINCHED, "pinched", ranks=(1, 2), sets=["run.ranks=[1, 1, 2]"],
                     env={"AGGLO_SKIP_SOLID": skip})
    assert_identical(outs)


PINCHED_PERIODIC = pinched_scene(14, "periodic", (0.00004, 0.00071), 0.1, 0.025, "\n  boundary_scheme: bounce_back")


def test_pinched_cells_across_a_periodic_face(tmp_path):
    """A sphere on the floor across the periodic x face: the floor's links
    at x = 1 whose pair's sphere cell x_f + c_q lies beyond the face read
    the flag of its ghost, which the sphere stage leaves unset on one rank
    along x (it flags the image in the block), so the floor sent back its
    own population while the sphere's link sent back the pair's mean: mass
    drifted by 2.1e-7 in 150 steps of bounce-back at rest (1.2e-14 with 2
    ranks along x, whose ghosts are flagged). The link now reads the image
    (walls_build.c walls_build, ghost_link_t.cell3): mass kept, 1 rank equal to 2
    bit for bit."""
    outs = run_ranks(tmp_path, PINCHED_PERIODIC, "pinched_periodic", ranks=(1, 2), sets=["run.ranks=[2, 1, 1]"])
    for out in outs:
        with h5py.File(out, "r") as f:
            m = f["/fluid/mass"][...]
        assert np.max(np.abs(m / m[0] - 1.0)) < 1e-12, f"{out}: mass {m}"
    assert_identical(outs)


def test_sphere_two_arrays_across_ranks(tmp_path):
    assert_identical(run_ranks(tmp_path, SETTLE.replace("streaming: in_place", "streaming: two_array"), "settle2", ranks=(1, 2)))


CROSS = """
domain:
  size: [3.2e-4, 1.6e-4, 1.6e-4]
  faces:
    x_min: {type: periodic}
    x_max: {type: periodic}
    y_min: {type: free_slip}
    y_max: {type: free_slip}
    z_min: {type: no_slip}
    z_max: {type: moving_wall, velocity: [2.0e-3, 0.0, 0.0]}
fluid:
  density: 1000.0
  viscosity: 1.0e-6
  dx: 1.0e-5
  tau: 0.8
  boundary_scheme: multireflection
  refill: extrapolation
bodies:
  - name: dimer
    density: 1500.0
    motion: prescribed
    velocity: [1.5e-2, 1.0e-3, 0.0]
    angular_velocity: [0.0, 0.0, 30.0]
    spheres:
      - {center: [2.7e-4, 8.0e-5, 8.0e-5], radius: 3.5e-5}
      - {center: [3.1e-4, 8.0e-5, 8.5e-5], radius: 2.5e-5}
run:
  end_time: 0.012
  output_interval: 4.0e-4
  fields: true
  field_interval: 0.004
"""


@pytest.mark.parametrize("ranks", ["[2, 1, 1]", "[4, 1, 1]", "[2, 2, 1]", "[1, 2, 2]"])
def test_body_crosses_periodic_face_across_ranks(tmp_path, ranks):
    """A turning dimer moves 18 cells along the periodic x axis, across the
    periodic face, which is cut between the first and the last rank along x
    (multireflection: links read two cells back; extrapolation refill: the
    refill reads two cells along the normal), through every block. With
    [1, 2, 2] x stays whole (the local periodic copy) and the exchange
    overlaps the update of the inner rows, with the dimer's links in outer
    rows and across the cuts."""
    n = eval(ranks)[0] * eval(ranks)[1] * eval(ranks)[2]
    assert_identical(run_ranks(tmp_path, CROSS, "cross", ranks=(1, n), sets=[f"run.ranks={ranks}"]))


def test_dual_star_short_same_loads(tmp_path):
    """The dual star in shear (13 spheres, 5 connections, a free body), 60
    steps on 1 and 2 ranks: the same loads, motion and connection forces."""
    scene = (ROOT / "models" / "dual_star_shear.yaml").read_text()
    outs = run_ranks(tmp_path, scene, "dual", ranks=(1, 2),
                     sets=["run.output_interval=0.0025", "run.fields=false", "run.end_time=0.015"])
    a, b = datasets(outs[0]), datasets(outs[1])
    assert sorted(a) == sorted(b)
    for k in a:
        assert np.array_equal(a[k], b[k]), k
    assert np.abs(a["spheres/force"]).max() > 0.0 and np.abs(a["connections/force"]).max() > 0.0


@pytest.mark.parametrize("case", ["faces", "periodic", "sphere"])
def test_moments_layout_same_on_1_2_4_ranks(tmp_path, case):
    """fluid.streaming: moments (fluid/moments.h) across ranks: the exchange
    sends f~_q of the outer layer, rebuilt from the cells' moments, into the
    neighbours' ghost entries of the side store. Every face type cut along z
    and y; a periodic x axis cut between ranks; a settling sphere crossing a
    cut (its solid cells in the exchanged ghost layers keep their ghost
    entries)."""
    if case == "faces":
        scene, sets = box(ALL_FACES, "moments", collision="regularized"), []
    elif case == "periodic":
        scene, sets = box(PERIODIC_X, "moments", collision="regularized"), ["run.ranks=[2, 1, 1]"]
    else:
        scene, sets = SETTLE.replace("streaming: in_place", "streaming: moments"), ["run.ranks=[1, 1, 2]"]
    ranks = (1, 2, 4) if case == "faces" else (1, 2)
    assert_identical(run_ranks(tmp_path, scene, "mom_" + case, ranks=ranks, sets=sets))
