"""Field snapshots on a disk that fills up (common/h5fields.c, fluid/fluid_fmi.c):
the run stops with exit 1 and a message naming the cause, nothing crashes
(HDF5 1.10 segfaulted at exit on the field file whose close had failed), and
the field file stays readable with every complete snapshot, the incomplete
one taken out.

A small tmpfs stands for the full disk: mounting one needs root, so the tests
are skipped otherwise (or where mounting is not allowed)."""
import os
import re
import subprocess
import time

import h5py
import numpy as np
import pytest

from conftest import COUPLER, PY, run

SCENE = """\
domain:
  size: [1.6e-4, 1.6e-4, 1.6e-4]
fluid: {{density: 1000.0, viscosity: 1.0e-6, dx: 1.0e-5, tau: 0.8}}
bodies:
  - density: 2000.0{motion}
    spheres:
      - {{center: [8.0e-5, 8.0e-5, 8.0e-5], radius: 3.0e-5}}
rigid: {{gravity: [0, 0, -9.81]}}
run: {{end_time: {end}, output_interval: 1.0e-5, fields: true, field_interval: 1.0e-5}}
"""


@pytest.fixture
def small_disk(tmp_path):
    """A tmpfs of 16 MiB, unmounted afterwards."""
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    d = tmp_path / "small"
    d.mkdir()
    p = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=16m", "tmpfs", str(d)], capture_output=True, text=True)
    if p.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {p.stderr.strip()}")
    try:
        yield d
    finally:
        subprocess.run(["umount", "-l", str(d)], capture_output=True)


def fill(folder, leave=0):
    """Fills the file system of folder up to `leave` bytes (to the last byte
    with 0)."""
    v = os.statvfs(folder)
    left = v.f_bavail * v.f_frsize - leave
    fd = os.open(folder / "filler", os.O_WRONLY | os.O_CREAT | os.O_APPEND)
    try:
        for chunk in (1 << 20, 4096):  # to the last page
            try:
                while left > 0:
                    left -= os.write(fd, b"\0" * min(left, chunk))
            except OSError:
                pass
    finally:
        os.close(fd)


def run_short_of_space(scene_text, folder, tmp_path, spare):
    """`coupler run` of a scene into folder, left with what `coupler check`
    says the run needs plus `spare` bytes (it counts the field snapshots'
    values only: the field file's own metadata and its .xmf index fill the
    rest): it fails with exit 1 and the cause.
    Returns the CompletedProcess and the output's path."""
    scene = tmp_path / "s.yaml"
    scene.write_text(scene_text)
    p = run("check", scene)
    need = float(re.search(r"([0-9.e+-]+) MB on disk", p.stdout + p.stderr).group(1)) * 1e6
    fill(folder, leave=int(need) + spare)
    out = folder / "o.h5"
    p = run("run", scene, "-o", out, "--quiet")
    assert p.returncode == 1, p.stderr
    assert "No space left on device" in p.stderr, p.stderr
    return p, out


def run_while_filling(scene_text, folder, tmp_path, args, ready, leave):
    """`coupler run` of a scene into folder (output o.h5, more args), the
    file system filled to `leave` bytes once ready() holds: another program
    takes the space while the run writes. Returns the run's stderr after it
    ended with exit 1 and the cause."""
    scene = tmp_path / "s.yaml"
    scene.write_text(scene_text)
    env = dict(os.environ, OMP_NUM_THREADS="2")
    proc = subprocess.Popen([str(COUPLER), "run", str(scene), "-o", str(folder / "o.h5"), "--quiet", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    t0 = time.monotonic()
    while not ready() and proc.poll() is None and time.monotonic() - t0 < 120:
        time.sleep(0.02)
    fill(folder, leave=leave)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 1, err
    assert "No space left on device" in err, err
    return err


def complete_snapshots(fields, xmf):
    """The snapshots of a field file, each read whole (fails on a broken
    one), and the ones its .xmf index lists."""
    with h5py.File(fields, "r") as f:
        names = sorted(f["fields"])
        for k in names:
            g = f["fields"][k]
            assert g.attrs["time"] >= 0.0
            for d in ("density", "velocity", "flags"):
                assert g[d][()].size > 0
    listed = sorted(set(re.findall(r":/fields/(\d+)/density", xmf.read_text())))
    return names, listed


def test_coupler_run_filling_the_disk_stops_cleanly(coupler, small_disk, tmp_path):
    """A run whose snapshots fill the file system: exit 1 (not 139), the cause
    named, the field file and the output readable up to the failure. The
    disk is left with what `coupler check` says the run needs, which counts
    the snapshots' values only: the field file's own metadata and the .xmf
    index fill it before the end."""
    p, out = run_short_of_space(SCENE.format(motion="\n    motion: fixed", end="1.0e-3"), small_disk, tmp_path, 16384)
    assert "the field file was closed and keeps the snapshots before it" in p.stderr
    names, listed = complete_snapshots(small_disk / "o_fields.h5", small_disk / "o_fields.xmf")
    assert 2 <= len(names) < 101
    assert listed == names or listed == names[:-1]  # a snapshot flushed whose index could not be rewritten
    with h5py.File(out, "r") as f:
        assert f["time"].shape[0] >= len(names) - 1


# An FMU whose file system is filled to the last byte between two snapshots
# (the case that crashed), in its own process: the crash came at exit.
FULL_FMU = r"""
import sys
import fmpy
from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
sys.path.insert(0, sys.argv[3])
from test_disk_full import fill
import pathlib

fmu, folder = sys.argv[1], pathlib.Path(sys.argv[2])
md = fmpy.read_model_description(fmu)
vr = {v.name: v.valueReference for v in md.modelVariables}
def log(env, name, status, category, message):
    print("LOG", status, message.decode(), flush=True)
cb = fmi2CallbackFunctions()
cb.logger = fmi2CallbackLoggerTYPE(log)
s = FMU2Slave(guid=md.guid, unzipDirectory=fmpy.extract(fmu), modelIdentifier="fluid", instanceName="f")
s.instantiate(callbacks=cb)
s.setupExperiment(startTime=0.0)
s.enterInitializationMode()
s.setString([vr["output.fields"]], [str(folder / "f.h5")])
s.exitInitializationMode()
dt = 1e-5
for n in range(2):
    s.doStep(n * dt, dt)
fill(folder)
try:
    s.doStep(2 * dt, dt)
    print("STEP OK", flush=True)
except Exception as e:
    print("STEP FAILED", flush=True)
s.freeInstance()
print("END", flush=True)
"""


def test_fmu_snapshot_on_a_full_disk(coupler, small_disk, tmp_path):
    """Nothing left at all when a snapshot begins: the step fails with the
    cause, the process ends normally (it segfaulted in HDF5's exit handler),
    and the file holds the three snapshots before (steps 0, 1, 2)."""
    scene = tmp_path / "f.yaml"
    scene.write_text(SCENE.format(motion="\n    motion: fixed", end="1.0e-3"))
    p = run("export", scene, "-d", tmp_path / "fmu")
    assert p.returncode == 0, p.stderr
    script = tmp_path / "full.py"
    script.write_text(FULL_FMU)
    p = subprocess.run([PY, script, tmp_path / "fmu" / "fluid.fmu", small_disk, os.path.dirname(__file__)],
                       capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert p.returncode == 0, f"exit {p.returncode}: {p.stdout[-3000:]}{p.stderr[-2000:]}"
    assert "STEP FAILED" in p.stdout and p.stdout.rstrip().endswith("END"), p.stdout
    assert re.search(r"while writing /fields/000003\S*: No space left on device", p.stdout), p.stdout
    names, listed = complete_snapshots(small_disk / "f.h5", small_disk / "f.xmf")
    assert names == ["000000", "000001", "000002"] and listed == names


# Rows only (no snapshots), one a step: the output's first flush allocates a
# chunk of 4096 rows for every series, later flushes write into them, and the
# chunks of rows 4096 on need new space.
ROWS = """\
domain:
  size: [8.0e-5, 8.0e-5, 8.0e-5]
fluid: {{density: 1000.0, viscosity: 1.0e-6, dx: 1.0e-5, tau: 0.8}}
run: {{end_time: {end}, output_interval: 1.0e-5}}
"""


def kept_rows(stderr, out):
    """The rows the run says its output keeps, checked against the file read
    back: every series as long as the time, the times those of the rows."""
    m = re.search(r"stopped; \S+ holds the (\d+) output rows written before \(to t = ([0-9.e+-]+) s\)", stderr)
    assert m, stderr
    with h5py.File(out, "r") as f:
        t = f["time"][()]
        lengths = set()
        f.visititems(lambda n, o: lengths.add(o.shape[0]) if isinstance(o, h5py.Dataset) and o.ndim > 0 else None)
    assert lengths == {len(t)} and int(m.group(1)) == len(t), (lengths, len(t), m.group(0))
    assert t == pytest.approx(1.0e-5 * np.arange(len(t)), abs=1e-12)
    assert float(m.group(2)) == pytest.approx(t[-1], abs=1e-12)
    return len(t)


def test_output_rows_on_a_disk_that_fills_during_the_run(small_disk, tmp_path):
    """Another program fills the disk while the run writes its rows: exit 1
    with the cause named (the output writer said "HDF5 error" only), and the
    output keeps the rows written before, readable, as the message says."""
    out = small_disk / "o.h5"
    # 30 000 rows, about 1.8 MB; filled once the first rows are in the file
    err = run_while_filling(ROWS.format(end="0.3"), small_disk, tmp_path, [],
                            lambda: out.exists() and out.stat().st_size >= 50000, 20000)
    assert 256 <= kept_rows(err, out) < 30001


def test_checkpoint_on_a_disk_that_fills_during_the_run(small_disk, tmp_path):
    """The disk fills after the first checkpoint: the next one fails with the
    cause named (it said "is the folder writable?"), leaves no half-written
    .tmp behind, and the message names the checkpoint a restart can take,
    which is still whole."""
    cp = small_disk / "o_checkpoint.h5"
    # room for the rows to the next checkpoint, not for it (0.34 MB)
    err = run_while_filling(ROWS.format(end="0.3"), small_disk, tmp_path, ["--checkpoint-every", "0.02"], cp.exists,
                            150000)
    assert re.search(r"checkpoint\S*: .*No space left on device.*; the previous checkpoint \S+o_checkpoint\.h5 is kept",
                     err), err
    assert not (small_disk / "o_checkpoint.h5.tmp").exists()
    with h5py.File(cp, "r") as f:
        assert f.attrs["step"] >= 2000 and f["fluid_state/0"].shape[0] > 0
    kept_rows(err, small_disk / "o.h5")


def test_a_sparse_file_the_run_replaces_frees_its_blocks_not_its_length(coupler, small_disk, tmp_path):
    """The space a run counts as freed by the files it replaces is what they
    take on disk: an old output that is a sparse file of 1 GB (no blocks)
    frees nothing, so a run needing more than the 16 MiB disk is refused
    before it writes, and the old file is left as it was. Its length was
    counted: the run started, truncated the file and filled the disk."""
    scene = tmp_path / "s.yaml"
    scene.write_text(SCENE.format(motion="\n    motion: fixed", end="1.5e-3"))
    p = run("check", scene)
    need = float(re.search(r"([0-9.e+-]+) MB on disk", p.stdout + p.stderr).group(1)) * 1e6
    v = os.statvfs(small_disk)
    assert v.f_bavail * v.f_frsize < need < 1e9
    out = small_disk / "o.h5"
    with open(out, "wb") as f:
        f.truncate(1 << 30)
    assert os.stat(out).st_blocks == 0
    p = run("run", scene, "-o", out, "--quiet")
    assert p.returncode == 1, p.stderr
    assert "not run, nothing written" in p.stderr, p.stderr
    assert "No space left on device" not in p.stderr
    assert os.stat(out).st_size == 1 << 30 and not (small_disk / "o_fields.h5").exists()
