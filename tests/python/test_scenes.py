"""The paper's agglomerate scenes (issue 6): reproducible generation and a smoke run.

The generator reproduces the committed files bit for bit, the agglomerates are
sintered trees, and every scene runs a few coupled steps with finite forces. The
scene checks (dual-star symmetry, rotation at half the shear rate, fusion and
break-up balances) are in test_shear_scenes.py and test_agglomerate_scenes.py."""
import re
import subprocess
import sys

import h5py
import numpy as np
import pytest
import yaml

from conftest import MODELS, PY, run

sys.path.insert(0, str(MODELS))
import agglomerate  # noqa: E402

SCENES = ["dual_star_shear", "sphere_in_shear", "agglomerate_16", "agglomerate_32", "agglomerate_64",
          "three_agglomerates", "channel_collision", "breakup_shear"]


def test_generator_reproduces_committed_scenes():
    p = subprocess.run([str(PY), str(MODELS / "make_scenes.py"), "--check"], capture_output=True, text=True)
    assert p.returncode == 0, p.stdout + p.stderr


@pytest.mark.parametrize("n,seed", [(16, 16), (64, 64), (10, 31)])
def test_agglomerate_is_a_sintered_tree(n, seed):
    r, overlap = 1.0, 0.1
    c, conn = agglomerate.generate(n, r, overlap, seed)
    assert len(c) == n and len(conn) == n - 1
    d = 2 * r * (1 - overlap)
    for a, b in conn:
        assert abs(np.linalg.norm(c[a] - c[b]) - d) < 1e-12  # each connection is a sintered neck
    # no other pair overlaps more than touching at the neck distance
    for i in range(n):
        for j in range(i + 1, n):
            if (i, j) not in conn and (j, i) not in conn:
                assert np.linalg.norm(c[i] - c[j]) >= d * (1 - 1e-12)
    # connected: every sphere reaches sphere 0
    parent = {k: p for p, k in conn}
    for k in range(1, n):
        seen = 0
        while k != 0:
            k = parent[k]
            seen += 1
            assert seen <= n
    assert np.allclose(c.mean(axis=0), 0.0, atol=1e-12)
    # the same seed gives the same agglomerate, another seed another one
    c2, _ = agglomerate.generate(n, r, overlap, seed)
    c3, _ = agglomerate.generate(n, r, overlap, seed + 1)
    assert np.array_equal(c, c2) and not np.allclose(c, c3)


@pytest.mark.parametrize("scene", SCENES)
def test_scene_runs_a_few_steps(coupler, tmp_path, scene):
    out = tmp_path / f"{scene}.h5"
    p = run("run", MODELS / f"{scene}.yaml", "-o", out, "--steps", "4", "--quiet", "--set", "run.fields=false",
            "--set", "run.output_interval=1e-9")
    assert p.returncode == 0, p.stderr
    with h5py.File(out, "r") as f:
        force = f["/spheres/force"][:]
        assert force.shape[0] >= 2 and np.all(np.isfinite(force))
        assert np.all(np.isfinite(f["/spheres/position"][:]))
        if "/connections/force" in f:
            assert np.all(np.isfinite(f["/connections/force"][:]))


@pytest.mark.parametrize("scene", ["sinking_sphere"] + SCENES)
def test_every_paper_scene_writes_fields_for_paraview(scene):
    """Each scene of the paper asks for field snapshots (run.fields) at 5 times, so that
    `make run SCENE=...` leaves an .xmf for ParaView beside the output (the writer itself is
    tested in test_master.py)."""
    s = yaml.safe_load((MODELS / f"{scene}.yaml").read_text())
    assert s["run"]["fields"] is True
    n = s["run"]["end_time"] / s["run"]["field_interval"]
    assert abs(n - round(n)) < 1e-6 and 4 <= round(n) <= 8


def test_scene_table_gives_what_check_prints():
    """models/README.md's table of the agglomerate scenes gives each one's memory as `coupler
    check` prints it (it gave the two-array figures, 581 MB for the dual star where check says
    277 MB), and sphere_in_shear's step count (960; the whole-ns dt makes it 961)."""
    text = (MODELS / "README.md").read_text()
    rows = [l for l in text.splitlines() if l.startswith("| `") and l.endswith(" MB |") and ".yaml`" in l]
    assert len(rows) == 5
    for row in rows:
        names = re.findall(r"`(\w+)\.yaml`|`_(\d+)`", row.split("|")[1])
        stems = [a or f"agglomerate_{b}" for a, b in names]
        table = [int(x) for x in re.findall(r"\d+", row.split("|")[-2])]
        for stem, mb in zip(stems, table, strict=True):
            p = run("check", MODELS / f"{stem}.yaml")
            got = float(re.search(r"memory +([\d.]+) MB", p.stdout).group(1))
            assert round(got) == mb, (stem, got, mb)
    p = run("check", MODELS / "sphere_in_shear.yaml")
    steps = re.search(r"steps +(\d+) to", p.stdout).group(1)
    assert f"runs {steps} steps" in text
    # README "Speed and memory": three_agglomerates in each layout (it gave 401.7, 202.1, 824.5 MB)
    readme = (MODELS.parent / "README.md").read_text()
    for sets, row in ((), "in_place, double (default)"), (("--set", "fluid.precision=single"), "in_place, single"), \
            (("--set", "fluid.streaming=two_array"), "two_array, double"):
        p = run("check", MODELS / "three_agglomerates.yaml", *sets)
        m = re.search(r"memory +([\d.]+) MB .*?([\d.]+) per interior cell", p.stdout)
        assert f"| {row} | {m.group(1)} MB ({m.group(2)} B per interior cell) |" in readme, (row, m.groups())
