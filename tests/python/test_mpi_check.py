"""`coupler check --ranks N` (and `check` under mpirun): the blocks of N ranks.

The report comes from the fluid's own layout (fluid/decomp.c decomp_layout);
these tests check it against an independent computation here, from the
rules the C code documents:
- blocks (decomp.c split): n // p cells per block, the first n % p blocks one
  larger; ranks row-major, z fastest (as MPI_Cart_create numbers them);
- memory (fluid/grid.h grid_init, fluid/fluid.c alloc_populations): the x
  extent n0 + 2 (two_array: padded to a multiple of 8 cells; in place not
  padded), y and z with their ghosts,
  ncells their product; each population `stride` values, stride = ncells
  rounded up to 24 mod 512; 19 populations per array (1 array in place, 2
  for two_array), 8 or 4 bytes per value, and 1 byte of flags per cell;
- halo (fluid/walls.c walls_halo_begin): for every axis a cut over more than one
  rank, 5 populations per face cell of each exchanged face, the face spanning
  the other two axes with the ghost rows of the axes before a (x before y
  before z) and of the faces that are domain walls (not exchanged, not a
  periodic axis held by one rank).
MPI_Dims_create's choice for 4 ranks is (2, 2, 1) (the MPI standard: as
balanced as possible, non-increasing), given to the axes z, y, x in that
order (fluid/decomp.c: the fewest ranks along x): [1, 2, 2].
"""
import re

import pytest

from conftest import run
from mpi_util import MPIRUN, run_coupler

SCENE = """
domain:
  size: [{lx}, {ly}, {lz}]
  faces:
{faces}
fluid:
  density: 1000.0
  viscosity: 1.0e-6
  dx: 1.0e-4
  tau: 0.8
  streaming: {streaming}
  precision: {precision}
run:
  end_time: 0.01
  output_interval: 0.005
"""

# x periodic (faces left out), walls across y and z
PERIODIC_X = {"y_min": "free_slip", "y_max": "no_slip", "z_min": "no_slip", "z_max": "no_slip"}


def write_scene(tmp_path, cells=(64, 32, 16), faces=None, streaming="in_place", precision="double", name="s"):
    faces = PERIODIC_X if faces is None else faces
    text = SCENE.format(lx=round(cells[0] * 1e-4, 10), ly=round(cells[1] * 1e-4, 10), lz=round(cells[2] * 1e-4, 10),
                        faces="\n".join(f"    {k}: {{type: {v}}}" for k, v in faces.items()) or "    {}",
                        streaming=streaming, precision=precision)
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    return path


# --- the independent computation ---------------------------------------

def split(n, p):
    """(first cell, cells) of each of p blocks along an axis of n cells."""
    base, extra = divmod(n, p)
    out, lo = [], 0
    for c in range(p):
        length = base + (1 if c < extra else 0)
        out.append((lo, length))
        lo += length
    return out


def coords_of(rank, dims):
    return (rank // (dims[1] * dims[2]), rank // dims[2] % dims[1], rank % dims[2])


def block_bytes(n, streaming, precision):
    s0 = (n[0] + 2 + 7) // 8 * 8 if streaming == "two_array" else n[0] + 2
    ncells = s0 * (n[1] + 2) * (n[2] + 2)
    stride = ncells
    while stride % 512 != 24:
        stride += 1
    arrays = 2 if streaming == "two_array" else 1
    value = 4 if precision == "single" else 8
    return arrays * 19 * stride * value + ncells


def halo_bytes(n, coords, dims, periodic, value):
    def exchanged(b, side):
        if dims[b] == 1:
            return False  # a wall, or a periodic axis copied inside the block
        if periodic[b]:
            return True
        return coords[b] > 0 if side == 0 else coords[b] < dims[b] - 1

    total = 0
    for a in range(3):
        sides = exchanged(a, 0) + exchanged(a, 1)
        if sides == 0:
            continue
        face = 1
        for b in range(3):
            if b == a:
                continue
            lo, hi = (0, n[b] + 1) if b < a else (1, n[b])
            if not (periodic[b] and dims[b] == 1):
                lo = lo if exchanged(b, 0) else 0
                hi = hi if exchanged(b, 1) else n[b] + 1
            face *= hi - lo + 1
        total += sides * 5 * face * value
    return total


def expected(cells, dims, periodic, streaming="in_place", precision="double"):
    value = 4 if precision == "single" else 8
    rows = []
    for rank in range(dims[0] * dims[1] * dims[2]):
        c = coords_of(rank, dims)
        lo, n = zip(*(split(cells[a], dims[a])[c[a]] for a in range(3)))
        rows.append({"rank": rank, "coords": c, "lo": lo, "n": n, "cells": n[0] * n[1] * n[2],
                     "mb": block_bytes(n, streaming, precision) / 1e6, "halo": halo_bytes(n, c, dims, periodic, value)})
    return rows


# --- the report ---------------------------------------------------------

ROW = re.compile(r"^\s+(\d+)\s+\((\d+), (\d+), (\d+)\)\s+\((\d+), (\d+), (\d+)\)\s+(\d+) x (\d+) x (\d+)"
                 r"\s+(\d+)\s+([\d.]+)\s+(\d+)\s+([\d.]+)$")
DIMS = re.compile(r"MPI ranks\s+(\d+) = (\d+) x (\d+) x (\d+) along x, y, z \((.+)\)")


def report(stdout):
    m = DIMS.search(stdout)
    assert m, stdout
    rows = []
    for line in stdout.splitlines():
        r = ROW.match(line)
        if r:
            v = r.groups()
            rows.append({"rank": int(v[0]), "coords": tuple(map(int, v[1:4])), "lo": tuple(map(int, v[4:7])),
                         "n": tuple(map(int, v[7:10])), "cells": int(v[10]), "mb": float(v[11]),
                         "halo": int(v[12])})
    total = int(re.search(r"halo per step\s+(\d+) B sent by all ranks", stdout).group(1))
    return int(m.group(1)), [int(m.group(k)) for k in (2, 3, 4)], m.group(5), rows, total


def assert_rows(rows, want):
    assert len(rows) == len(want)
    for got, exp in zip(rows, want):
        for key in ("rank", "coords", "lo", "n", "cells", "halo"):
            assert got[key] == exp[key], (key, got, exp)
        assert got["mb"] == pytest.approx(exp["mb"], abs=0.0005), (got, exp)  # printed with 3 decimals


@pytest.mark.parametrize("streaming,precision", [("in_place", "double"), ("two_array", "single")])
def test_four_ranks_blocks_memory_and_halo(coupler, tmp_path, streaming, precision):
    scene = write_scene(tmp_path, streaming=streaming, precision=precision)
    p = run("check", scene, "--ranks", "4")
    assert p.returncode == 0, p.stderr
    world, dims, source, rows, total = report(p.stdout)
    assert (world, dims, source) == (4, [1, 2, 2], "MPI_Dims_create")
    want = expected((64, 32, 16), dims, (1, 0, 0), streaming, precision)
    assert_rows(rows, want)
    assert total == sum(r["halo"] for r in want)
    # by hand for rank 0 in double, block 64 x 16 x 8: the y cut (one face, to
    # rank 2) over 66 x 9 cells (x with its ghosts, done before y; z: the wall
    # row below), the z cut (one face, to rank 1) over 66 x 18 (x and y with
    # their ghosts); x periodic on one rank: the local copy, no message.
    # Memory in place: s = 66 (not padded) x 18 x 10 = 11880 cells, stride 12312
    if precision == "double":
        assert rows[0]["halo"] == 5 * 66 * 9 * 8 + 5 * 66 * 18 * 8
        assert rows[0]["mb"] == pytest.approx((19 * 12312 * 8 + 66 * 18 * 10) / 1e6, abs=5e-4)


def test_uneven_blocks_first_ones_larger(coupler, tmp_path):
    """65 x 33 x 16 cells over 6 ranks as [1, 2, 3]: z blocks 6, 5, 5; y 17, 16."""
    scene = write_scene(tmp_path, cells=(65, 33, 16))
    p = run("check", scene, "--ranks", "6")
    assert p.returncode == 0, p.stderr
    world, dims, source, rows, _ = report(p.stdout)
    assert (world, dims) == (6, [1, 2, 3])
    assert_rows(rows, expected((65, 33, 16), dims, (1, 0, 0)))
    assert [r["n"][2] for r in rows[:3]] == [6, 5, 5]
    assert [r["n"][1] for r in rows[::3]] == [17, 16]


@pytest.mark.parametrize("ranks", [[2, 2, 1], [1, 1, 4], [1, 2, 2], [4, 1, 1]])
def test_run_ranks_honoured(coupler, tmp_path, ranks):
    scene = write_scene(tmp_path)
    p = run("check", scene, "--ranks", "4", "--set", f"run.ranks={ranks}")
    assert p.returncode == 0, p.stderr
    world, dims, source, rows, total = report(p.stdout)
    assert (world, dims, source) == (4, ranks, "run.ranks")
    want = expected((64, 32, 16), ranks, (1, 0, 0))
    assert_rows(rows, want)
    assert total == sum(r["halo"] for r in want)


def test_all_periodic_cube(coupler, tmp_path):
    """Every face periodic and cut: each rank sends 2 faces per cut axis."""
    scene = write_scene(tmp_path, cells=(32, 32, 32), faces={})
    p = run("check", scene, "--ranks", "8")
    assert p.returncode == 0, p.stderr
    world, dims, _, rows, total = report(p.stdout)
    assert dims == [2, 2, 2]
    assert_rows(rows, expected((32, 32, 32), dims, (1, 1, 1)))
    # x over 16 x 16, y over 18 x 16, z over 18 x 18 (the ghosts of x, y)
    assert rows[0]["halo"] == 2 * 5 * 8 * (16 * 16 + 18 * 16 + 18 * 18)
    assert total == 8 * rows[0]["halo"]


def test_many_ranks_table_is_shortened(coupler, tmp_path):
    scene = write_scene(tmp_path)
    p = run("check", scene, "--ranks", "32")
    assert p.returncode == 0, p.stderr
    world, dims, _, rows, total = report(p.stdout)
    assert world == 32 and dims[0] * dims[1] * dims[2] == 32
    assert [r["rank"] for r in rows] == list(range(8)) + [31]
    want = expected((64, 32, 16), dims, (1, 0, 0))
    assert_rows(rows, want[:8] + want[31:])
    assert total == sum(r["halo"] for r in want)
    mn = re.search(r"^\s+min .*\s(\d+)\s+[\d.]+\s+(\d+)\s+[\d.]+$", p.stdout, re.M)
    mx = re.search(r"^\s+max .*\s(\d+)\s+[\d.]+\s+(\d+)\s+[\d.]+$", p.stdout, re.M)
    assert int(mn.group(2)) == min(r["halo"] for r in want)
    assert int(mx.group(2)) == max(r["halo"] for r in want)


def test_one_rank_and_no_option(coupler, tmp_path):
    scene = write_scene(tmp_path)
    p = run("check", scene, "--ranks", "1")
    assert p.returncode == 0, p.stderr
    world, dims, source, rows, total = report(p.stdout)
    assert (world, dims, total) == (1, [1, 1, 1], 0)
    assert rows[0]["n"] == (64, 32, 16)
    p = run("check", scene)
    assert p.returncode == 0 and "MPI ranks" not in p.stdout


@pytest.mark.parametrize("value", ["0", "-2", "65537", "four", "2.5"])
def test_bad_ranks_value_is_a_usage_error(coupler, tmp_path, value):
    p = run("check", write_scene(tmp_path), "--ranks", value)
    assert p.returncode == 2
    assert f"--ranks takes a whole number from 1 to 65536, got '{value}'" in p.stderr


def test_ranks_is_for_check_only(coupler, tmp_path):
    scene = write_scene(tmp_path)
    assert run("check", scene, "--ranks").returncode == 2
    p = run("run", scene, "--ranks", "2", "-o", tmp_path / "x.h5")
    assert p.returncode == 2 and "'--ranks'" in p.stderr


@pytest.mark.parametrize("args,message", [
    (["--ranks", "17"], "16 cells along z over 17 ranks leaves blocks of fewer than 4 cells"),
    (["--ranks", "8", "--set", "run.ranks=[1, 1, 8]"], "16 cells along z over 8 ranks leaves blocks of fewer than 4"),
    (["--ranks", "3", "--set", "run.ranks=[2, 2, 1]"], "run.ranks [2, 2, 1] makes 4 blocks, but there are 3 MPI ranks"),
])
def test_impossible_decomposition_is_an_error(coupler, tmp_path, args, message):
    p = run("check", write_scene(tmp_path), *args)
    assert p.returncode == 1
    assert message in p.stderr
    assert "MPI ranks" not in p.stdout


@pytest.mark.parametrize("cells,dims", [((24, 24, 11), [1, 3, 1]), ((12, 9, 9), [3, 1, 1])])
def test_an_axis_too_thin_for_its_ranks_is_left_whole(coupler, tmp_path, cells, dims):
    """MPI_Dims_create gives 3 ranks to z; 11 or 9 cells along z over 3 ranks make
    blocks thinner than 4 cells, so z stays whole and the ranks go along y, or x
    (before, `mpirun -np 3` on these grids stopped with '11 cells along z over 3
    ranks leaves blocks of fewer than 4 cells' although y or x could take them)."""
    p = run("check", write_scene(tmp_path, cells=cells), "--ranks", "3")
    assert p.returncode == 0, p.stderr
    world, got, source, rows, _ = report(p.stdout)
    assert (world, got, source) == (3, dims, "MPI_Dims_create")
    assert_rows(rows, expected(cells, dims, (1, 0, 0)))


def test_grid_too_small_to_cut(coupler, tmp_path):
    p = run("check", write_scene(tmp_path, cells=(6, 6, 6)), "--ranks", "2")
    assert p.returncode == 1
    assert "has no axis of 8 cells or more to cut over 2 ranks" in p.stderr


@pytest.mark.skipif(MPIRUN is None, reason="mpirun (openmpi-bin) is not installed")
def test_under_mpirun_the_world_is_reported_once(coupler, tmp_path):
    scene = write_scene(tmp_path)
    p = run_coupler(2, "check", scene, timeout=120)
    assert p.returncode == 0, p.stderr
    assert p.stdout.count("MPI ranks") == 1 and p.stdout.count(str(scene)) == 1, p.stdout
    world, dims, source, rows, total = report(p.stdout)
    assert (world, dims, source) == (2, [1, 1, 2], "MPI_Dims_create")
    want = expected((64, 32, 16), dims, (1, 0, 0))
    assert_rows(rows, want)
    # --ranks wins over the world size
    p = run_coupler(2, "check", scene, "--ranks", "4", timeout=120)
    assert p.returncode == 0, p.stderr
    assert p.stdout.count("MPI ranks") == 1
    assert report(p.stdout)[0] == 4
