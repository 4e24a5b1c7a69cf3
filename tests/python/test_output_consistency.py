"""What the output says against what the README says it holds (README "Output",
"Release"): small scenes of a few seconds each, checked the way a user reads
the file with h5py."""
import xml.etree.ElementTree as ET

import h5py
import numpy as np

from conftest import run

# A dimer turning at 3 rad/s about y in a periodic box, its neck unbreakable: the neck
# carries the centripetal load m w^2 r of the section (a sphere of radius 3e-4 m, density
# 1200 kg/m^3, 3e-4 m from the centre of mass: 3.66e-10 N) whenever the body is free.
DIMER = """\
domain:
  size: [1.6e-3, 1.6e-3, 1.6e-3]
fluid: {density: 1000.0, viscosity: 1.0e-6, dx: 1.0e-4, tau: 0.8}
bodies:
  - name: dimer
    density: 1200.0
    angular_velocity: [0, 3.0, 0]
    spheres:
      - {center: [5.0e-4, 8.0e-4, 8.0e-4], radius: 3.0e-4}
      - {center: [1.1e-3, 8.0e-4, 8.0e-4], radius: 3.0e-4}
connections:
  - {spheres: [0, 1]}
run: {end_time: 0.005, output_interval: 0.001}
"""


def test_held_connections_carry_nothing_from_the_first_row(coupler, tmp_path):
    # rigid.release_time: "its connections carry nothing" while held. The rows after each
    # held step were zero, but the first row (t = 0, also before the release) held the
    # centripetal load evaluated at creation: 3.66e-10 N, then 0, 0, 0, then the load again.
    scene = tmp_path / "dimer.yaml"
    scene.write_text(DIMER)
    m = 1200.0 * 4.0 / 3.0 * np.pi * 3e-4 ** 3
    centripetal = m * 3.0 ** 2 * 3e-4
    for release, held_rows in ((0.003, 4), (0.0, 0)):
        out = tmp_path / f"r{release}.h5"
        p = run("run", scene, "-o", out, "--quiet", "--set", f"rigid.release_time={release}")
        assert p.returncode == 0, p.stderr
        with h5py.File(out, "r") as f:
            fc = np.linalg.norm(f["/connections/force"][:, 0], axis=1)
            t = f["/time"][:]
        assert np.all(t[:held_rows] < release + 1e-9)  # the rows after held steps and t = 0
        assert np.all(fc[:held_rows] == 0.0), fc           # t = 0 .. 0.003: held
        assert np.all(fc[held_rows:] > 0.0), fc            # free: loaded
        if release == 0.0:
            assert abs(fc[0] - centripetal) < 1e-6 * centripetal, (fc[0], centripetal)


XDMF_PRECISION = {"Float": {None: 4, "4": 4, "8": 8}}


def test_xdmf_geometry_is_the_grid_in_double(coupler, tmp_path):
    # OUT_fields.xmf gave the origin and spacing as XML DataItems without NumberType and
    # Precision, which XDMF reads as 4-byte floats, printed with 10 digits: VTK's XDMF reader
    # (ParaView's) made dx = 1e-4 m a spacing of 9.99999975e-05 m and the box 3.1999999e-3 m
    # long. Now Float of Precision 8, to the last bit: as read, equal to the file's dx.
    scene = tmp_path / "dimer.yaml"
    dx = 1.0e-4 / 3.0  # not a short decimal either
    scene.write_text(DIMER.replace("dx: 1.0e-4", f"dx: {dx!r}").replace("1.6e-3, 1.6e-3, 1.6e-3",
                                                                        f"{48 * dx!r}, {48 * dx!r}, {48 * dx!r}"))
    out = tmp_path / "g.h5"
    p = run("run", scene, "-o", out, "--quiet", "--steps", "1", "--set", "run.fields=true")
    assert p.returncode == 0, p.stderr
    with h5py.File(out, "r") as f:
        fdx = float(f.attrs["dx"])
    root = ET.parse(tmp_path / "g_fields.xmf").getroot()
    grids = root.findall(".//Grid[@GridType='Uniform']")
    assert len(grids) == 1  # step 0
    for g in grids:
        origin, spacing = g.find("Geometry").findall("DataItem")
        for item, want in ((origin, [0.0] * 3), (spacing, [fdx] * 3)):
            assert item.get("NumberType", "Float") == "Float"
            assert XDMF_PRECISION["Float"][item.get("Precision")] == 8, ET.tostring(item)
            assert [float(v) for v in item.text.split()] == want


def test_snapshot_times_are_the_rows_times(coupler, tmp_path):
    # A snapshot's `time` was step x dt with dt recomputed from tau, an ulp off the scene's
    # whole-ns step: 0.020000000000000004 against the row's 0.02, so a user matching a
    # snapshot to its output row by time found none. Now the fluid steps with the scene's dt.
    scene = tmp_path / "dimer.yaml"
    scene.write_text(DIMER)
    out = tmp_path / "t.h5"
    p = run("run", scene, "-o", out, "--quiet", "--set", "run.fields=true", "--set", "run.field_interval=1e-9",
            "--set", "run.output_interval=1e-9")
    assert p.returncode == 0, p.stderr
    with h5py.File(out, "r") as f, h5py.File(tmp_path / "t_fields.h5", "r") as g:
        rows = f["/time"][()].tolist()
        snaps = [g["/fields"][k].attrs["time"] for k in g["/fields"]]
    assert len(snaps) == len(rows) > 3
    assert snaps == rows
