"""Field snapshots written by several MPI processes (common/h5fields.c).

build/h5fields_mpi writes a known analytic field on a 13 x 10 x 7 grid
(snapshots at steps 0 and 5, then resumed, the steps after 0 dropped and
step 5 written again with other values; tests/mpi/h5fields_mpi.c). One
process without MPI writes the reference file, which is checked against the
formulas below; every split over 1, 2, 3 or 4 processes (uneven blocks) must
give the same file: the same groups, every dataset bit for bit, the same
`time` attributes, `h5diff` silent, and the same .xmf text. A failure on one
process only must reach every process (all return an error, none hangs)."""
import shutil
import subprocess

import h5py
import numpy as np
import pytest

from conftest import ROOT

PROG = ROOT / "build" / "h5fields_mpi"
GRID = (13, 10, 7)  # x, y, z
NAME = "fields.h5"  # the same name everywhere: the .xmf refers to it
SPLITS = [(1, 1, 1), (2, 1, 1), (3, 1, 1), (1, 2, 2), (2, 2, 1)]


def mpirun():
    path = shutil.which("mpirun")
    if path is None:
        pytest.skip("mpirun is missing (Open MPI's mpirun, Debian package openmpi-bin)")
    # a process stuck in a collective call: mpirun stops all of them
    return [path, "--allow-run-as-root", "--oversubscribe", "--timeout", "60"]


def write(folder, *args, np_=None, mode=None):
    """Runs the writer (under mpirun with np_ processes when given) and
    returns the path of its field file."""
    assert PROG.exists(), "build/h5fields_mpi is missing: run `make all` first"
    folder.mkdir(exist_ok=True)
    out = folder / NAME
    cmd = [str(PROG), str(out), *map(str, args), *([mode] if mode else [])]
    if np_ is not None:
        cmd = mpirun() + ["-np", str(np_)] + cmd
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=90)
    assert proc.returncode == 0, f"{' '.join(cmd)} exited with {proc.returncode}:\n{proc.stdout}{proc.stderr}"
    return out, proc


def expected(version):
    """The analytic fields of tests/mpi/h5fields_mpi.c, [nz, ny, nx(, 3)]."""
    z, y, x = np.meshgrid(*(np.arange(n) for n in reversed(GRID)), indexing="ij")
    base = 1.0 + x + 100.0 * y + 10000.0 * z
    if version == 0:
        rho = base
        u = np.stack([x + 0.25, -y - 0.5, z * z + 0.125], axis=-1)
        flags = (x + 3 * y + 5 * z) % 7
    else:
        rho = -base / 3.0
        u = np.stack([x / 3.0, y * y + 0.75, -z / 7.0], axis=-1)
        flags = (x * y + z) % 2
    return {"density": rho, "velocity": u, "flags": flags.astype(np.uint8)}


def contents(path):
    """Every object of the file: name -> (attributes, dtype, shape, bytes)."""
    out = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            attrs = {k: (np.asarray(v).dtype.str, np.asarray(v).tobytes()) for k, v in obj.attrs.items()}
            if isinstance(obj, h5py.Dataset):
                data = obj[()]
                out[name] = (attrs, data.dtype.str, data.shape, data.tobytes())
            else:
                out[name] = (attrs, None, None, None)
        f.visititems(visit)
    return out


@pytest.fixture(scope="module")
def serial(tmp_path_factory):
    out, _ = write(tmp_path_factory.mktemp("serial"))
    return out


def test_serial_file_holds_the_analytic_field(serial):
    with h5py.File(serial, "r") as f:
        assert sorted(f["fields"]) == ["000000", "000005"]
        for step, version, time in (("000000", 0, 0.0), ("000005", 1, 0.5)):
            g = f["fields"][step]
            assert g.attrs["time"] == time
            for name, want in expected(version).items():
                got = g[name][()]
                assert got.dtype == want.dtype and got.shape == want.shape, (step, name)
                assert np.array_equal(got, want), f"{step}/{name} differs from the analytic field"
    xmf = serial.with_suffix(".xmf").read_text()
    assert xmf.count("<Time Value=") == 2 and f"{NAME}:/fields/000005/velocity" in xmf
    assert 'Dimensions="8 11 14"' in xmf  # nodes: one more than cells per axis


@pytest.mark.parametrize("split", SPLITS, ids=lambda s: "x".join(map(str, s)))
def test_parallel_file_equals_serial(tmp_path, serial, split):
    nprocs = split[0] * split[1] * split[2]
    out, _ = write(tmp_path / "parallel", *split, np_=nprocs)
    want, got = contents(serial), contents(out)
    assert list(got) == list(want), "the groups and datasets differ"
    for name in want:
        assert got[name][0] == want[name][0], f"{name}: attributes differ"
        assert got[name][1:3] == want[name][1:3], f"{name}: type or shape differs"
        assert got[name][3] == want[name][3], f"{name}: data differ"
    h5diff = shutil.which("h5diff")
    assert h5diff is not None, "h5diff is missing (Debian package hdf5-tools)"
    diff = subprocess.run([h5diff, str(serial), str(out)], capture_output=True, text=True, timeout=60)
    assert diff.returncode == 0, f"h5diff finds differences:\n{diff.stdout}{diff.stderr}"
    assert out.with_suffix(".xmf").read_text() == serial.with_suffix(".xmf").read_text()


def test_bad_block_on_one_process_fails_on_all(tmp_path, serial):
    # the last process's block reaches past the grid: every process's open
    # returns an error; then the same processes write the file as usual
    out, proc = write(tmp_path / "bad", 3, 1, 1, np_=3, mode="bad-block")
    assert "process 2: error: [fields]" in proc.stderr and "is not inside the grid" in proc.stderr
    for rank in (0, 1):
        assert f"process {rank}: error: [fields] {out}: setting up the field writer failed on process 2" in proc.stderr
    diff = subprocess.run(["h5diff", str(serial), str(out)], capture_output=True, text=True, timeout=60)
    assert diff.returncode == 0, diff.stdout + diff.stderr


def test_index_failure_on_rank_0_fails_on_all(tmp_path):
    # rank 0 alone writes the .xmf; made a directory, it cannot: the other
    # process must return the error too (the program checks every status)
    (tmp_path / "xmf" / "fields.xmf").mkdir(parents=True)
    _, proc = write(tmp_path / "xmf", 2, 1, 1, np_=2, mode="write-error")
    assert "process 0: error: [fields]" in proc.stderr and "cannot write the XDMF index" in proc.stderr
    assert "process 1: error: [fields]" in proc.stderr and "writing the XDMF index failed on process 0" in proc.stderr
