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

import h5py
import pytest

from conftest import PY, run

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
    the datasets only: the files' own metadata and the .xmf index fill it
    before the end."""
    scene = tmp_path / "s.yaml"
    scene.write_text(SCENE.format(motion="\n    motion: fixed", end="1.0e-3"))
    p = run("check", scene)
    need = float(re.search(r"([0-9.e+-]+) MB on disk", p.stdout + p.stderr).group(1)) * 1e6
    fill(small_disk, leave=int(need) + 16384)
    out = small_disk / "o.h5"
    p = run("run", scene, "-o", out, "--quiet")
    assert p.returncode == 1, p.stderr
    assert "No space left on device" in p.stderr, p.stderr
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
