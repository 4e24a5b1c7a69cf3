"""The coupler command line on fluid-only scenes: check, run, output, bad input.

Bad input must end with a message that names the file, the key and the
allowed range, a non-zero exit, and nothing written (DESIGN section 3, 4)."""
import math
import re
import subprocess
import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest

from conftest import MODELS, PY, ROOT, run


def test_check_prints_lattice_parameters(coupler):
    p = run("check", MODELS / "channel_poiseuille.yaml")
    assert p.returncode == 0, p.stderr
    for word in ("tau", "lattice viscosity", "Mach", "Reynolds", "steps", "memory"):
        assert word in p.stdout
    # tau 0.8 -> nu_lat = 0.1; dt = nu_lat dx^2 / nu = 0.1 * (2.5e-5)^2 / 1e-6
    assert "6.25e-05" in p.stdout


def test_check_reports_the_step_in_whole_nanoseconds(coupler, tmp_path):
    """common/scene.h: tau 1 at dx 1e-5 m, nu 1e-6 m^2/s gives dt = 16666.67 ns, rounded to
    16667 ns with tau = 1/2 + 3 nu dt / dx^2 = 1.00001; check says so, without a warning. A given
    dt that is not whole ns, and a step too small to round, are warnings naming the remedy."""
    p = run("check", MODELS / "sinking_sphere.yaml")
    assert p.returncode == 0, p.stderr
    assert "16667 ns (a whole number of ns)" in p.stdout
    line = [l for l in p.stdout.splitlines() if "tau requested" in l][0]
    assert "used 1.00001" in line and "+1e-05" in line
    assert "step" not in p.stderr
    text = (MODELS / "sinking_sphere.yaml").read_text().replace("  tau: 1.0", "  dt: 1.66666e-5")
    (tmp_path / "s.yaml").write_text(text)
    p = run("check", tmp_path / "s.yaml")
    assert p.returncode == 0, p.stderr
    assert "not a whole number of nanoseconds" in p.stderr and "fluid.dt = 16667e-9" in p.stderr
    p = run("check", MODELS / "sinking_sphere.yaml", "--set", "fluid.dx=1e-7", "--set", "fluid.tau=0.6")
    assert p.returncode == 0, p.stderr
    assert "dt is kept exact" in p.stderr and "integer" in p.stderr


def test_check_warns_on_high_mach(coupler):
    p = run("check", MODELS / "channel_poiseuille.yaml", "--set", "fluid.body_force=[8000, 0, 0]")
    assert p.returncode == 0
    assert "Mach" in p.stderr and "warning" in p.stderr


def test_check_warns_of_a_speed_above_the_mach_limit(coupler, tmp_path):
    # an initial velocity of Mach 0.52 was only "exceeds 0.1" in check, while the run stopped at
    # step 0 ("velocity above the Mach limit fluid.mach_limit"); at Mach 0.17 nothing stops it
    fast = run("check", MODELS / "channel_poiseuille.yaml", "--set", "fluid.initial_velocity=[0.12, 0, 0]")
    assert fast.returncode == 0, fast.stderr
    assert "above fluid.mach_limit 0.3" in fast.stderr, fast.stderr
    out = tmp_path / "fast.h5"
    p = run("run", MODELS / "channel_poiseuille.yaml", "-o", out, "--quiet", "--set",
            "fluid.initial_velocity=[0.12, 0, 0]", "--set", "run.end_time=0.001")
    assert p.returncode == 1 and "Mach limit" in p.stderr, p.stderr
    slow = run("check", MODELS / "channel_poiseuille.yaml", "--set", "fluid.initial_velocity=[0.04, 0, 0]")
    assert slow.returncode == 0 and "Mach number" in slow.stderr, slow.stderr
    assert "mach_limit" not in slow.stderr, slow.stderr


@pytest.mark.parametrize("collision", ["trt", "bgk"])
def test_check_names_trt_as_a_remedy_only_for_bgk(coupler, collision):
    # TRT at a fixed magic parameter has a steady state (wall location included) independent of tau,
    # so a large tau warns of the wall drift only with BGK; near 1/2 TRT is offered only to BGK.
    # Before, a TRT scene at tau 3.5 was told "drifts with tau (BGK); use TRT or tau <= 2.5" and one
    # at tau 0.5001 "use tau >= 0.55 or TRT".
    sets = ["--set", f"fluid.collision={collision}"]
    large = run("check", MODELS / "channel_poiseuille.yaml", *sets, "--set", "fluid.tau=3.5")
    small = run("check", MODELS / "channel_poiseuille.yaml", *sets, "--set", "fluid.tau=0.5001")
    assert large.returncode == 0 and small.returncode == 0, (large.stderr, small.stderr)
    assert ("fluid.tau = 3.5 is large" in large.stderr) == (collision == "bgk"), large.stderr
    assert "is close to 0.5" in small.stderr, small.stderr
    assert ("TRT" in small.stderr) == (collision == "bgk"), small.stderr


@pytest.mark.parametrize("sets", [[], ["--set", "rigid.gravity=[-0.05, 0, 0]"],
                                  ["--set", "rigid.gravity=[-0.05, 0, 0]", "--set", "fluid.dx=1e-7"]])
def test_check_counts_every_warning_it_prints(coupler, sets):
    # the count left out the scene reader's own warnings (an unbalanced weight in a periodic box:
    # one warning printed, "warnings 0")
    p = run("check", MODELS / "sinking_sphere.yaml", "--set", "domain.faces={}", *sets)
    assert p.returncode == 0, p.stderr
    printed = sum(line.startswith("warning:") for line in p.stderr.splitlines())
    assert f"warnings           {printed}\n" in p.stdout, (p.stdout, p.stderr)
    assert printed >= len(sets) // 2


def test_set_override_changes_tau(coupler):
    p = run("check", MODELS / "channel_poiseuille.yaml", "--set", "fluid.tau=1.1")
    assert p.returncode == 0, p.stderr
    assert "1.1" in p.stdout.split("tau", 1)[1].splitlines()[0]


def test_run_poiseuille_matches_analytic(coupler, tmp_path):
    out = tmp_path / "p.h5"
    p = run("run", MODELS / "channel_poiseuille.yaml", "-o", out, "--quiet")
    assert p.returncode == 0, p.stderr
    with h5py.File(out, "r") as f:
        t = f["/time"][:]
        assert t[0] == 0.0 and abs(t[-1] - 3.0) < 1e-9
        assert np.all(np.diff(t) > 0)
        mass = f["/fluid/mass"][:]
        assert abs(mass[-1] / mass[0] - 1) < 1e-10  # round-off over 48000 steps
        assert f.attrs["tau"] == pytest.approx(0.8)
        assert "fluid:" in f.attrs["scene"].decode() if isinstance(f.attrs["scene"], bytes) else f.attrs["scene"]
        assert "fields" not in f  # not asked for
    line = [l for l in p.stdout.splitlines() if "Poiseuille" in l][0]
    rel = float(line.split("relative difference")[1].strip(" ()"))
    assert abs(rel) < 1e-8  # TRT + magic 3/16: exact parabola


def test_fields_and_xdmf(coupler, tmp_path):
    out = tmp_path / "cavity.h5"
    p = run("run", MODELS / "lid_driven_cavity.yaml", "-o", out, "--quiet", "--set", "run.end_time=0.02",
            "--set", "run.field_interval=0.01", "--set", "domain.size=[5e-4,5e-4,5e-4]")
    assert p.returncode == 0, p.stderr
    # the fluid FMU writes the fields into cavity_fields.h5 with its index
    # cavity_fields.xmf; cavity.h5 links /fields to it
    xmf = tmp_path / "cavity_fields.xmf"
    root = ET.parse(xmf).getroot()
    files = {d.text.split(":")[0] for d in root.iter("DataItem") if d.get("Format") == "HDF"}
    assert files == {"cavity_fields.h5"}
    items = [d.text.split(":")[1] for d in root.iter("DataItem") if d.get("Format") == "HDF"]
    assert len(items) == 3 * 3  # t = 0, 0.01, 0.02: density, velocity, flags
    units = {"density": b"kg/m^3", "velocity": b"m/s", "flags": b"0 fluid, 1 solid"}
    with h5py.File(out, "r") as f:
        for path in items:
            assert path in f
            assert f[path].attrs["unit"] == units[path.rsplit("/", 1)[1]], path  # as every dataset
        v = f[items[-2]][:]
        assert v.shape == (20, 20, 20, 3)
        # the lid drives +x flow in the top layer, return flow below
        assert v[-1, :, :, 0].mean() > 0 and v[5, :, :, 0].mean() < 0


def test_fields_written_in_slabs_hold_every_plane(coupler, tmp_path):
    # 96 x 96 x 40 cells: the fluid FMU writes a snapshot 28 planes at a time
    # (H5FIELDS_SLAB_CELLS = 262144 cells of 33 bytes in its buffers, common/h5fields.h),
    # so in two slabs; the plane channel starts in its exact steady profile, which
    # differs from plane to plane: a slab out of place or left out shows
    size = ["--set", "domain.size=[2.4e-3,2.4e-3,1.0e-3]", "--set", "fluid.initial_profile=plane_channel",
            "--set", "run.fields=true", "--set", "run.field_interval=6.25e-5"]
    p = run("check", MODELS / "channel_poiseuille.yaml", *size)
    assert p.returncode == 0, p.stderr
    grid = float(re.search(r"memory +([0-9.]+) MB", p.stdout).group(1))
    need = float(re.search(r"run needs +([0-9.]+) MB of memory", p.stdout).group(1))
    assert need - grid == pytest.approx(28 * 96 * 96 * 33 / 1e6, abs=0.02)  # a slab, not the grid's 12.2 MB
    out = tmp_path / "slabs.h5"
    p = run("run", MODELS / "channel_poiseuille.yaml", "-o", out, "--quiet", "--steps", "1", *size)
    assert p.returncode == 0, p.stderr
    with h5py.File(out, "r") as f:
        u = f["/fields/000000/velocity"][()]  # [z, y, x, 3]
        rho = f["/fields/000000/density"][()]
        flags = f["/fields/000000/flags"][()]
    z = (np.arange(40) + 0.5) * 2.5e-5
    want = 8.0 / (2 * 1e-3) * z * (1e-3 - z)  # F z (h - z) / (2 mu), 1 mm/s at the centre
    assert np.max(np.abs(u[..., 0] - want[:, None, None])) < 1e-12
    assert np.max(np.abs(u[..., 1:])) < 1e-12
    assert np.max(np.abs(rho - 1000.0)) < 1e-9 and not flags.any()


def test_inlet_outlet_pressure_drop(coupler, tmp_path):
    out = tmp_path / "ch.h5"
    p = run("run", MODELS / "channel_inlet_outlet.yaml", "-o", out, "--quiet")
    assert p.returncode == 0, p.stderr
    with h5py.File(out, "r") as f:
        last = sorted(f["/fields"].keys())[-1]
        rho = f[f"/fields/{last}/density"][:]  # [z, y, x]
        u = f[f"/fields/{last}/velocity"][:]
        dx = f.attrs["dx"]
        dt = f.attrs["dt"]
    cs2 = (dx / dt) ** 2 / 3.0
    nx = rho.shape[2]
    i1, i2 = nx // 4, 3 * nx // 4
    dp = cs2 * (rho[:, 0, i1].mean() - rho[:, 0, i2].mean())
    mu = 1e-3
    ref = 8 * mu * 2.0e-3 / (8.0e-4) ** 2 * (i2 - i1) * dx
    assert dp == pytest.approx(ref, rel=0.01)
    h = rho.shape[0]
    z = (np.arange(h) + 0.5) / h
    assert np.max(np.abs(u[:, 0, nx // 2, 0] - 2.0e-3 * 4 * z * (1 - z))) < 0.01 * 2.0e-3


BAD = [
    # (override, words the message must contain)
    ("fluid.tau=0.5", ["fluid.tau", "0.5"]),
    ("fluid.tau=abc", ["fluid.tau"]),
    ("fluid.viscosity=-1", ["fluid.viscosity", "-1"]),
    ("fluid.unknown_key=1", ["unknown_key"]),
    ("domain.size=[1.0e-4, 1.0e-4, 1.01e-3]", ["domain.size", "dx"]),
    ("domain.faces.x_min.type=no_slip", ["x_min", "periodic"]),
    ("fluid.collision=lbgk", ["fluid.collision", "lbgk"]),
    ("fluid.tau=0.7 m", ["fluid.tau", "'0.7 m' is not a number: ' m' follows '0.7'"]),  # was read as 0.7
]


@pytest.mark.parametrize("override,words", BAD)
def test_bad_scene_values(coupler, tmp_path, override, words):
    out = tmp_path / "keep.h5"
    out.write_bytes(b"precious")
    p = run("run", MODELS / "channel_poiseuille.yaml", "-o", out, "--set", override)
    assert p.returncode != 0
    assert "channel_poiseuille.yaml" in p.stderr
    for w in words:
        assert w in p.stderr, p.stderr
    assert out.read_bytes() == b"precious"  # nothing written


def test_velocity_of_a_fixed_body_is_ignored_with_a_warning(coupler):
    """A fixed body never moves: its velocity was ignored without a word, yet check's Mach
    estimate took it ("Mach number 4.33e+09 (from a body's velocity)")."""
    p = run("check", MODELS / "sinking_sphere.yaml", "--set", "bodies.0.motion=fixed",
            "--set", "bodies.0.velocity=[1e3, 0, 0]", "--set", "bodies.0.angular_velocity=[0, 0, 1e6]")
    assert p.returncode == 0, p.stderr
    assert "bodies.0.velocity = [1000, 0, 0]: ignored for a fixed body" in p.stderr, p.stderr
    assert "bodies.0.angular_velocity = [0, 0, 1000000]: ignored for a fixed body" in p.stderr
    assert "a body's" not in p.stdout + p.stderr
    assert re.search(r"Mach +0\n", p.stdout) and "nothing moves" in p.stdout, p.stdout


def test_tau_close_to_a_half_is_named_as_used(coupler):
    """tau 0.5000001 was reported as "fluid.tau = 0.5 is close to 0.5" (%g) and the remedy
    "or TRT" was offered to a scene that uses TRT."""
    p = run("check", MODELS / "channel_poiseuille.yaml", "--set", "fluid.tau=0.5000001")
    assert p.returncode == 0, p.stderr
    assert "fluid.tau = 0.5000001 is close to 0.5: the scheme loses stability; use tau >= 0.55\n" in p.stderr
    p = run("check", MODELS / "channel_poiseuille.yaml", "--set", "fluid.tau=0.52", "--set", "fluid.collision=bgk")
    assert "is close to 0.5: the scheme loses stability; use tau >= 0.55 or TRT" in p.stderr


def test_check_refuses_a_run_too_long_to_count(coupler):
    """ceil(run.end_time / dt) beyond a long: check printed "steps -9223372036854775808" and
    exited 0; now the scene is refused with the count and the maximum, 2^53 (common/scene.h)."""
    p = run("check", MODELS / "sinking_sphere.yaml", "--set", "run.end_time=1e15")
    assert p.returncode == 1
    assert "run.end_time = 1e+15 s is 5.9998800024e+19 steps of fluid.dt" in p.stderr, p.stderr
    assert "allowed: at most 9007199254740992 (2^53) steps" in p.stderr
    assert "-9223372036854775808" not in p.stdout
    p = run("check", MODELS / "sinking_sphere.yaml", "--set", "run.end_time=1.5e11")
    assert p.returncode == 0, p.stderr
    # ceil(1.5e11 s / 16667 ns) = 8999820003599929 exactly; counted in doubles near 2^53,
    # whose spacing there is 1 (2 from 2^53 on): within a few steps
    ns = int(re.search(r"dt +\S+ s = (\d+) ns", p.stdout).group(1))
    exact = -(-150_000_000_000 * 10**9 // ns)
    m = re.search(r"steps +(\d+) to t = 1.5e\+11 s", p.stdout)
    assert m and abs(int(m.group(1)) - exact) <= 4, (m and m.group(1), exact)


def test_missing_key_and_syntax_error(coupler, tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("domain:\n  size: [1e-3, 1e-3, 1e-3]\nfluid:\n  density: 1000\n  dx: 1e-4\n  tau: 0.8\n"
                   "run:\n  end_time: 1\n")
    p = run("check", bad)
    assert p.returncode != 0 and "viscosity" in p.stderr and "bad.yaml" in p.stderr
    bad.write_text("domain: [\n")
    p = run("check", bad)
    assert p.returncode != 0 and "bad.yaml" in p.stderr and "line" in p.stderr


def test_cli_usage_errors(coupler, tmp_path):
    assert run().returncode == 2
    assert run("frobnicate").returncode == 2
    p = run("run", MODELS / "channel_poiseuille.yaml", "--steps", "-3")
    assert p.returncode == 2 and "--steps" in p.stderr
    p = run("check", tmp_path / "missing.yaml")
    assert p.returncode == 1 and "missing.yaml" in p.stderr


@pytest.mark.parametrize("args", [
    ("run", "-o", "a.h5", "-o", "b.h5"),
    ("run", "--steps", "2", "--steps", "3"),
    ("check", "--ranks", "2", "--ranks", "4"),
    ("export", "-d", "one", "-d", "two"),
])
def test_an_option_given_twice_is_refused(coupler, tmp_path, args):
    """`-o a.h5 -o b.h5` wrote b.h5 without a word: which one was meant? Now a usage error
    naming the option, before anything is read or written."""
    cmd, *opts = args
    p = run(cmd, MODELS / "channel_poiseuille.yaml", *opts, cwd=tmp_path)
    assert p.returncode == 2, p.stderr
    assert f"coupler {cmd}: option '{opts[2]}' given twice; give it once" in p.stderr
    assert list(tmp_path.iterdir()) == []
    p = run("bench", "--coupled", "x.yaml", "--coupled", "y.yaml")
    assert p.returncode == 2 and "option '--coupled' given twice" in p.stderr


def test_the_fmpy_master_refuses_an_option_given_twice(tmp_path):
    """coupler/fmpy_master.py takes the coupler's options and refuses a repeated one alike."""
    for opts in (["-o", "a.h5", "--output", "b.h5"], ["-o", "a.h5", "--steps", "1", "--steps", "2"]):
        p = subprocess.run([str(PY), str(ROOT / "coupler" / "fmpy_master.py"), str(MODELS / "sinking_sphere.yaml"),
                            *opts], capture_output=True, text=True, cwd=tmp_path, timeout=120)
        assert p.returncode == 2, p.stderr
        assert f"option '{opts[-2]}' given twice; give it once" in p.stderr, p.stderr
        assert list(tmp_path.iterdir()) == []


def test_a_list_index_with_a_leading_zero_is_refused(coupler):
    """`bodies.01.density` named body 1, as `bodies.1` does: the message says indices are
    0, 1, ..., so "01" is refused with it."""
    p = run("check", MODELS / "sinking_sphere.yaml", "--set", "bodies.00.density=3000")
    assert p.returncode == 1
    assert "bodies is a list, so '00' must be an index 0, 1, ..." in p.stderr, p.stderr
    assert run("check", MODELS / "sinking_sphere.yaml", "--set", "bodies.0.density=3000").returncode == 0


def test_export_removes_an_earlier_exports_rigid_fmu(coupler, tmp_path):
    """A scene without free bodies gets no rigid.fmu; one left in the folder by an earlier
    export stayed there beside the new fluid.fmu, a pair from two scenes for any master that
    takes the folder's FMUs."""
    scene = MODELS / "sinking_sphere.yaml"
    assert run("export", scene, "-d", tmp_path).returncode == 0
    assert sorted(f.name for f in tmp_path.iterdir()) == ["fluid.fmu", "rigid.fmu"]
    p = run("export", scene, "-d", tmp_path, "--set", "bodies.0.motion=fixed")
    assert p.returncode == 0, p.stderr
    assert f"removed {tmp_path}/rigid.fmu of an earlier export" in p.stdout, p.stdout
    assert sorted(f.name for f in tmp_path.iterdir()) == ["fluid.fmu"]


def test_readme_command_line_lists_every_command_of_help(coupler):
    """README "Command line" left out `coupler bench --coupled SCENE.yaml [--steps N] [--json]`,
    which `coupler --help` prints."""
    p = run("--help")
    block = (MODELS.parent / "README.md").read_text().split("## Command line", 1)[1].split("```")[1]
    readme = " ".join(block.replace("build/coupler", "coupler").split())
    for line in p.stderr.splitlines()[1:]:
        assert " ".join(line.split()) in readme, line


def test_scene_that_is_a_folder(coupler, tmp_path):
    # was "error: [scene] DIR: cannot read at byte 0: input error"
    for cmd in ("check", "run", "export"):
        args = ["-d", tmp_path / "fmus"] if cmd == "export" else []
        p = run(cmd, tmp_path, *args)
        assert p.returncode == 1
        assert f"error: [scene] {tmp_path}: is a folder, not a scene file; allowed: a YAML scene file" in p.stderr, p.stderr
    assert not (tmp_path / "fmus").exists()


def test_unwritable_output(coupler, tmp_path):
    p = run("run", MODELS / "channel_poiseuille.yaml", "-o", tmp_path / "no" / "such" / "dir.h5", "--steps", "1")
    assert p.returncode == 1 and "dir.h5" in p.stderr


def test_output_that_is_a_folder_is_refused_before_anything_is_written(coupler, tmp_path):
    # `-o DIR` said "DIR: cannot create the output file (does the folder exist and is it writable?)"
    # about a folder that exists and is writable; `-o ''` named no file at all; and a folder in the
    # checkpoint's place (OUT_checkpoint.h5) was found only at the first checkpoint, after OUT.h5
    # had been written over ("cannot rename OUT_checkpoint.h5.tmp to OUT_checkpoint.h5: Is a
    # directory", exit 1, the old OUT.h5 gone). Now each is refused before anything is written.
    scene = MODELS / "channel_poiseuille.yaml"
    folder = tmp_path / "outdir"
    folder.mkdir()
    p = run("run", scene, "-o", folder, "--steps", "2", "--quiet")
    assert p.returncode == 1
    assert f"cannot write {folder}: it is a folder; nothing was written; allowed: a file" in p.stderr, p.stderr
    assert list(folder.iterdir()) == []
    p = run("run", scene, "-o", "", "--steps", "2", "--quiet")
    assert p.returncode == 1 and "the output file name is empty" in p.stderr, p.stderr
    out = tmp_path / "keep.h5"
    out.write_bytes(b"precious")
    (tmp_path / "keep_checkpoint.h5").mkdir()
    p = run("run", scene, "-o", out, "--steps", "2", "--quiet", "--checkpoint-every", "1e-4")
    assert p.returncode == 1
    assert f"cannot write {tmp_path / 'keep_checkpoint.h5'}: it is a folder" in p.stderr, p.stderr
    assert out.read_bytes() == b"precious"
    assert not (tmp_path / "keep_checkpoint.h5.tmp").exists()


def test_run_never_writes_over_what_it_reads(coupler, tmp_path):
    # `-o scene.yaml` turned the scene into an HDF5 file; `-o cp.h5 --restart cp.h5` emptied the
    # checkpoint to continue from (5.6 MB to 13 kB); `--log-fmi-calls` equal to `-o` left an output
    # h5py could not open, with exit 0. Now each is refused before anything is written.
    scene = tmp_path / "scene.yaml"
    scene.write_text((MODELS / "channel_poiseuille.yaml").read_text())
    text = scene.read_bytes()
    p = run("run", scene, "-o", scene, "--steps", "2")
    assert p.returncode == 1 and "is also the scene file" in p.stderr
    assert scene.read_bytes() == text
    out = tmp_path / "a.h5"
    p = run("run", scene, "-o", out, "--steps", "4", "--checkpoint-every", "1e-4", "--quiet")
    cp = tmp_path / "a_checkpoint.h5"
    assert p.returncode == 0 and cp.exists(), p.stderr
    kept = cp.read_bytes()
    p = run("run", scene, "-o", cp, "--restart", cp)
    assert p.returncode == 1 and "is also the checkpoint to restart from" in p.stderr
    assert cp.read_bytes() == kept
    p = run("run", scene, "-o", tmp_path / "b.h5", "--log-fmi-calls", tmp_path / "b.h5", "--steps", "2")
    assert p.returncode == 1 and "is also the output" in p.stderr
    assert not (tmp_path / "b.h5").exists()
    # the fluid's index of the field file, OUT_fields.xmf, was left out: a scene of that name was
    # overwritten by it, exit 0
    xmf = tmp_path / "c_fields.xmf"
    xmf.write_bytes(text)
    p = run("run", xmf, "-o", tmp_path / "c.h5", "--steps", "2", "--set", "run.fields=true")
    assert p.returncode == 1 and "the field index (.xmf) beside the output" in p.stderr, p.stderr
    assert "is also the scene file" in p.stderr and xmf.read_bytes() == text
    # the usual restart, from the checkpoint beside the output, is not such a clash
    p = run("run", scene, "-o", out, "--restart", cp, "--steps", "6", "--quiet")
    assert p.returncode == 0, p.stderr


def test_a_refused_run_leaves_an_old_fmi_call_log_as_it_was(coupler, tmp_path):
    """--log-fmi-calls emptied its file before the checks, so a run refused for a broken FMU or
    for the disk it needs ("not run, nothing written") had emptied last run's log."""
    log = tmp_path / "calls.log"
    log.write_text("last run\n")
    (tmp_path / "broken").mkdir()
    p = run("run", MODELS / "channel_poiseuille.yaml", "-o", tmp_path / "o.h5", "--log-fmi-calls", log,
            "--fluid-fmu", tmp_path / "broken")
    assert p.returncode == 1 and "modelDescription.xml" in p.stderr, p.stderr
    p = run("run", MODELS / "channel_poiseuille.yaml", "-o", tmp_path / "o.h5", "--log-fmi-calls", log,
            "--steps", "100000000000", "--set", "run.output_interval=1e-9")  # 1e11 rows: no disk holds them
    assert p.returncode == 1 and "not run, nothing written" in p.stderr, p.stderr
    assert log.read_text() == "last run\n"
    p = run("run", MODELS / "channel_poiseuille.yaml", "-o", tmp_path / "o.h5", "--log-fmi-calls", log,
            "--steps", "2", "--quiet")
    assert p.returncode == 0, p.stderr
    assert log.read_text().startswith("fluid.fmu fmi2Instantiate(")


def test_prescribed_sphere_through_a_wall_stops_the_run(coupler, tmp_path):
    """A prescribed body moves as given: driven at a no-slip floor it went through it and out of
    the box (centre z = -5e-5 m after 200 steps), exit 0, without a word."""
    out = tmp_path / "o.h5"
    p = run("run", MODELS / "sinking_sphere.yaml", "-o", out, "--steps", "40", "--quiet", "--set", "run.fields=false",
            "--set", "run.output_interval=1e-9",
            "--set", "bodies.0={density: 2000, motion: prescribed, velocity: [0, 0, -0.02],"
            " spheres: [{center: [3.0e-4, 3.0e-4, 6.0e-5], radius: 5.0e-5}]}")
    assert p.returncode == 1
    # z = 6e-5 m - 0.02 m/s x 30 x 16667 ns = 4.99998e-5 m < r at step 30: the step from there is refused
    assert "prescribed sphere 0 (body 0) reaches beyond the face z_min at step 30 (t = 0.00050001 s)" in p.stderr, \
        p.stderr
    with h5py.File(out, "r") as f:
        assert f["/time"].shape == (31,)
    p = run("run", MODELS / "sinking_sphere.yaml", "-o", out, "--steps", "40", "--quiet", "--set", "run.fields=false",
            "--set", "bodies.0={density: 2000, motion: prescribed, velocity: [0.02, 0, 0],"
            " spheres: [{center: [3.0e-4, 3.0e-4, 5.0e-5], radius: 5.0e-5}]}")
    assert p.returncode == 0, p.stderr  # touching the floor and sliding along it is allowed


def test_tiny_intervals_do_not_hang(coupler, tmp_path):
    # run.output_interval / run.field_interval of 1e-30 s: the next row's index was counted up to
    # t one interval at a time (1e26 turns of a loop that a signal could not stop). Now a row and
    # a snapshot every step; a checkpoint interval below the communication step is refused.
    out = tmp_path / "t.h5"
    p = run("run", MODELS / "channel_poiseuille.yaml", "-o", out, "--steps", "5", "--quiet",
            "--set", "run.output_interval=1e-30", "--set", "run.fields=true", "--set", "run.field_interval=1e-30")
    assert p.returncode == 0, p.stderr
    with h5py.File(out, "r") as f:
        assert len(f["/time"]) == 6
    with h5py.File(tmp_path / "t_fields.h5", "r") as f:
        assert len(f["/fields"]) == 6  # the start and every step
    p = run("run", MODELS / "channel_poiseuille.yaml", "-o", tmp_path / "c.h5", "--steps", "5",
            "--checkpoint-every", "1e-30")
    assert p.returncode == 2 and "--checkpoint-every 1e-30 s is shorter than one communication step" in p.stderr


def test_check_prints_the_start_with_the_flow_and_the_release(coupler):
    # breakup_shear: walls at -+0.01 m/s, 3.6 mm apart: the flow turns at gamma/2 = 2.778 rad/s
    p = run("check", MODELS / "breakup_shear.yaml", "--set", "fluid.initial_profile=plane_channel",
            "--set", "bodies.0.move_with_flow=true", "--set", "rigid.release_time=0.025")
    assert p.returncode == 0, p.stderr
    m = re.search(r"starts with flow +body 0: velocity \(.*\) m/s, angular velocity \(\S+, (\S+), \S+\) rad/s",
                  p.stdout)
    assert m and float(m.group(1)) == pytest.approx(0.01 / 0.0036, rel=1e-5), p.stdout
    assert re.search(r"release time +0.025 s: free bodies held until then \(100 steps\)", p.stdout), p.stdout


def test_a_scene_warning_is_printed_once(coupler, tmp_path):
    # the master reads the scene, and each FMU read it at instantiation and again with its
    # parameters: the same warning came five times (twice from each FMU). Now the master's, once.
    p = run("run", MODELS / "sinking_sphere.yaml", "-o", tmp_path / "w.h5", "--steps", "2", "--quiet",
            "--set", "run.output_interval=1e-30")
    assert p.returncode == 0, p.stderr
    assert p.stderr.count("is shorter than one fluid step") == 1, p.stderr


@pytest.mark.parametrize("held", ["output", "fields"])
def test_output_held_open_elsewhere_is_left_as_it_is(coupler, tmp_path, held):
    # HDF5's create (H5F_ACC_TRUNC) empties a file before it finds that another process holds
    # it open: a run into an output or field file open in a viewer lost that file's content.
    # Now the run stops before it writes anything, with exit 1 and the file named, and both
    # files keep every byte.
    out = tmp_path / "run.h5"
    fields = tmp_path / "run_fields.h5"
    for path in (out, fields):
        with h5py.File(path, "w") as f:
            f["kept"] = np.arange(5.0)
    before = {p: p.read_bytes() for p in (out, fields)}
    target = out if held == "output" else fields
    with h5py.File(target, "r"):
        p = run("run", MODELS / "channel_poiseuille.yaml", "-o", out, "--steps", "2", "--set", "run.fields=true")
    assert p.returncode == 1, p.stderr
    assert str(target) in p.stderr and "another process holds" in p.stderr
    assert all(path.read_bytes() == b for path, b in before.items())  # nothing written to either


def test_bench_json(coupler):
    import json
    p = run("bench", "--size", "24", "--json")
    assert p.returncode == 0, p.stderr
    rows = [json.loads(l) for l in p.stdout.splitlines() if l.strip()]
    assert rows
    for r in rows:
        assert set(r) == {"size", "threads", "precision", "streaming", "mlups", "bandwidth_gbs", "limit_mlups",
                          "ratio", "bytes_per_cell"}
        assert r["size"] == 24 and r["mlups"] > 0
        value = 8 if r["precision"] == "double" else 4
        # the moments layout (double only): 10 doubles each way and a 4-byte index, 164 bytes
        update = 164 if r["streaming"] == "moments" else 38 * value
        assert r["limit_mlups"] == pytest.approx(r["bandwidth_gbs"] * 1e9 / update / 1e6, rel=1e-3)
    # both layouts and precisions; in place one population array of 19 values per allocated
    # cell (24^3 allocates 26 x 26 x 26), two arrays twice that (32 x 26 x 26: x padded);
    # each population `stride` values, the cells rounded up to 24 mod 512 (fluid/grid.h)
    by = {(r["streaming"], r["precision"]): r["bytes_per_cell"] for r in rows if r["streaming"] != "moments"}
    assert set(by) == {(s, p) for s in ("in_place", "two_array") for p in ("double", "single")}
    # the moments layout: 10 doubles per allocated cell (stride as above), a 4-byte index, 19
    # doubles per ghost cell (26^3 - 24^3 of them) and 29 doubles per plane cell and thread (the
    # kernel's copies: fluid/moments.h MOMENTS_PLANE_DOUBLES)
    mom = [r for r in rows if r["streaming"] == "moments"]
    assert mom and all(r["precision"] == "double" for r in mom)
    for r in mom:
        ncells = 26 * 26 * 26
        stride = ncells + (512 + 24 - ncells % 512) % 512
        want = (10 * 8 * stride + 4 * ncells + 152 * (ncells - 24**3) + 29 * 8 * 26 * 26 * r["threads"]
                + 26 * 26 + ncells / 2) / 24**3
        assert r["bytes_per_cell"] == pytest.approx(want, rel=0.005), r
    for (s, p), b in by.items():
        ncells = (32 if s == "two_array" else 26) * 26 * 26
        stride = ncells + (512 + 24 - ncells % 512) % 512
        want = ((2 if s == "two_array" else 1) * 19 * stride * (8 if p == "double" else 4) + ncells) / 24**3
        assert b == pytest.approx(want, rel=0.005), (s, p)  # and the small lists of the walls


def test_peak_resident_set_is_reported(coupler, tmp_path):
    """`coupler run` reports the process's peak resident set (summary line, root attribute
    peak_rss_bytes). three_agglomerates' populations (401.7 MB by `coupler check`) are written
    at the start, so they are resident: the peak holds them plus what the process itself needs
    (libraries, HDF5, the FMUs: some 60 MB measured), not much more."""
    import re
    scene = MODELS / "three_agglomerates.yaml"
    c = run("check", scene)
    assert c.returncode == 0, c.stderr
    fluid_mb = float(re.search(r"memory\s+([0-9.]+) MB", c.stdout).group(1))
    out = tmp_path / "ta.h5"
    p = run("run", scene, "-o", out, "--steps", "2", "--set", "run.fields=false")
    assert p.returncode == 0, p.stderr
    line = re.search(r"memory: peak resident set ([0-9.]+) MB", p.stdout)
    assert line, p.stdout
    with h5py.File(out, "r") as f:
        rss = float(f.attrs["peak_rss_bytes"])
    assert float(line.group(1)) == pytest.approx(rss / 1e6, abs=0.051)
    assert fluid_mb * 1e6 <= rss <= fluid_mb * 1e6 + 300e6, (rss, fluid_mb)


def test_bench_coupled_json(coupler):
    """`bench --coupled`: the best of each kind of run, their ratio, and the median of the
    ratios within the pairs of runs."""
    import json
    p = run("bench", "--coupled", MODELS / "sinking_sphere.yaml", "--steps", "3", "--json")
    assert p.returncode == 0, p.stderr
    r = json.loads(p.stdout.strip().splitlines()[-1])
    assert set(r) == {"scene", "steps", "coupled_s", "fluid_only_s", "ratio", "ratio_median", "coupled_parts_s",
                      "fluid_only_parts_s"}
    assert r["steps"] == 3 and r["coupled_s"] > 0 and r["fluid_only_s"] > 0
    # times printed to 1e-6 s, the ratio to 1e-4
    assert r["ratio"] == pytest.approx(r["coupled_s"] / r["fluid_only_s"], abs=1e-4 + 1e-5 / r["fluid_only_s"])
    assert math.isfinite(r["ratio_median"]) and r["ratio_median"] > 0
    # the parts of the best run of each kind (the output's wall_time_* attributes): the fluid, rigid and
    # master parts make up the run the master timed, inside the bench's own timing of it (which adds
    # reading the scene); start-up and output are parts of the master's share; no rigid FMU without bodies
    for kind in ("coupled", "fluid_only"):
        parts, whole = r[kind + "_parts_s"], r[kind + "_s"]
        assert set(parts) == {"fluid", "rigid", "master", "startup", "output"}
        assert all(v >= 0 for v in parts.values()), parts
        assert parts["fluid"] > 0 and parts["startup"] > 0
        assert 0.5 * whole < parts["fluid"] + parts["rigid"] + parts["master"] <= whole + 2e-6, (parts, whole)
        assert parts["startup"] + parts["output"] <= parts["master"] + 2e-6, parts
    assert r["fluid_only_parts_s"]["rigid"] == 0 and r["coupled_parts_s"]["rigid"] > 0


STRADDLE = """\
domain: {size: [3.2e-4, 2.4e-4, 2.4e-4]}
fluid: {density: 1000.0, viscosity: 1.0e-6, dx: 1.0e-5, tau: 0.8}
bodies:
  - name: dumbbell
    density: 1500.0
    motion: %s
    velocity: [0.004, 0.001, 0]
    angular_velocity: [0, 0, 200.0]
    spheres:
      - {center: [%s, 1.17e-4, 1.21e-4], radius: 4.0e-5}
      - {center: [%s, 1.17e-4, 1.21e-4], radius: 4.0e-5}
rigid: {gravity: [0, 0, 0]}
run: {end_time: 2.0e-4, output_interval: 1.0e-5}
"""


@pytest.mark.parametrize("motion", ["prescribed", "free"])
def test_body_across_a_periodic_face_moves_as_one_piece(coupler, tmp_path, motion):
    """A body of two touching spheres given across the periodic x face (centres
    2.93e-4 and 0.33e-4 in a box 3.2e-4 long) is the same body as its copy
    16 cells over, inside the box (1.33e-4, 1.93e-4): it turns about its own
    centroid (prescribed) and is one piece with its own mass properties (free),
    so both give the same sphere velocities and the same positions, 16 cells
    apart (modulo the period), to round-off. (Before, the centroid was the mean of the wrapped
    centres: the prescribed body turned about a point 15 cells off, its
    spheres at 0.026 instead of 0.006 m/s; the free one was refused as not
    one piece.)"""
    res = {}
    for name, xs in (("inside", ("1.33e-4", "1.93e-4")), ("across", ("2.93e-4", "0.33e-4"))):
        scene = tmp_path / f"{name}.yaml"
        scene.write_text(STRADDLE % (motion, *xs))
        out = tmp_path / f"{name}.h5"
        p = run("run", scene, "-o", out, "--quiet")
        assert p.returncode == 0, p.stderr
        with h5py.File(out, "r") as f:
            res[name] = f["/spheres/position"][()], f["/spheres/velocity"][()]
    (pa, va), (pb, vb) = res["inside"], res["across"]
    L = 3.2e-4
    assert len(pa) == len(pb) == 21
    speed = np.abs(va).max()
    assert speed > 3e-3  # 200 rad/s at 3 cells from the centroid, plus the drift of the free body
    assert np.abs(va - vb).max() < 1e-9 * speed
    # the same places, 1.6e-4 apart along x (wrapped or continuous)
    dx = (pb[..., 0] - pa[..., 0] - 1.6e-4) / L
    assert np.abs(dx - np.round(dx)).max() < 1e-9
    assert np.abs(pb[..., 1:] - pa[..., 1:]).max() < 1e-12


def test_settling_summary_of_a_rising_sphere(coupler, tmp_path):
    # a light sphere rises: its velocity along gravity and Stokes' are negative, its Reynolds
    # number is that of its speed (it was printed negative, "Re = -0.883", found by a sweep)
    p = run("run", MODELS / "sinking_sphere.yaml", "-o", tmp_path / "r.h5", "--steps", "60", "--quiet",
            "--set", "bodies.0.density=500", "--set", "run.fields=false")
    assert p.returncode == 0, p.stderr
    m = re.search(r"terminal velocity (\S+) m/s along gravity .*Stokes \(Eq. 10\) (\S+) m/s, Re = (\S+)", p.stdout)
    assert m, p.stdout
    v, stokes, re_ = map(float, m.groups())
    assert v < 0 and stokes < 0 and re_ > 0
    assert abs(re_ - abs(v) * 2 * 5e-5 / 1e-6) < 1e-2 * re_  # radius 5e-5 m, water (printed to 3 digits)


@pytest.mark.parametrize("cells,spheres,warned", [(18, 2, True), (20, 2, False), (18, 1, False)])
def test_check_warns_of_a_thin_periodic_slab(coupler, tmp_path, cells, spheres, warned):
    """README "Known problems": on a periodic axis shorter than 2 (r + sqrt(2)) cells another
    sphere's far image could be missed. check accepted radius 7.8 cells on 18-cell periodic axes
    without a word; now it warns once per axis (the length 2 (r + sqrt(2)) = 18.43 cells named),
    and not for 20 cells or for a sphere alone (whose own images are handled)."""
    L = cells * 1e-5
    body = "  - {{density: 2000, motion: fixed, spheres: [{{center: [{x}, {h}, {h}], radius: 7.8e-5}}]}}\n"
    text = (f"domain: {{size: [4.0e-4, {L}, {L}]}}\n"
            "fluid: {density: 1000, viscosity: 1.0e-6, dx: 1.0e-5, tau: 0.8}\n"
            "bodies:\n" + "".join(body.format(x=(1 + 2 * k) * 1e-4, h=L / 2) for k in range(spheres)) +
            "run: {end_time: 1.0e-4, output_interval: 1.0e-5}\n")
    (tmp_path / "s.yaml").write_text(text)
    p = run("check", tmp_path / "s.yaml")
    assert p.returncode == 0, p.stderr
    hits = p.stderr.count("a thin periodic slab")
    if warned:
        # y and z are thin; x (40 cells) holds the two spheres side by side
        assert hits == 2 and "2 (r + sqrt(2) dx) = 0.000184284" in p.stderr, p.stderr
    else:
        assert hits == 0, p.stderr


@pytest.mark.parametrize("sets,ignored", [
    (["contacts.model=spring_dashpot", "contacts.young_modulus=2e9", "contacts.poisson_ratio=0.25"],
     ["contacts.young_modulus = 2000000000: ignored with contacts.model = spring_dashpot (used by hertz only)",
      "contacts.poisson_ratio = 0.25: ignored with contacts.model = spring_dashpot (used by hertz only)"]),
    (["contacts.model=hertz", "contacts.contact_time=1e-4"],
     ["contacts.contact_time = 0.0001: ignored with contacts.model = hertz (used by spring_dashpot only)"]),
    (["contacts.model=none", "contacts.restitution=0.5", "contacts.friction=0.3"],
     ["contacts.restitution = 0.5: ignored with contacts.model = none (used by spring_dashpot and hertz)",
      "contacts.friction = 0.3: ignored with contacts.model = none (used by spring_dashpot and hertz)"]),
    (["rigid.integrator=verlet", "rigid.rtol=1e-6", "rigid.cvode_method=adams"],
     ["rigid.rtol: ignored with rigid.integrator = verlet (used by cvode only)",
      "rigid.cvode_method: ignored with rigid.integrator = verlet (used by cvode only)"]),
    (["run.fields=false", "run.field_interval=0.01"],
     ["run.field_interval = 0.01 s: ignored, as run.fields is false"]),
    (["contacts.model=hertz", "contacts.young_modulus=2e9", "rigid.integrator=cvode", "rigid.rtol=1e-6",
      "run.fields=true", "run.field_interval=0.01"], []),
])
def test_keys_the_scene_does_not_use_are_named_as_ignored(coupler, sets, ignored):
    """A key the chosen model, integrator or output does not read was taken in silence (a helper's
    audit: contacts.young_modulus with spring_dashpot, rigid.rtol with Verlet, run.field_interval
    without fields); now each is a warning, as fluid.magic with BGK, and the same keys where they
    are used are not."""
    args = [a for kv in sets for a in ("--set", kv)]
    p = run("check", MODELS / "sinking_sphere.yaml", *args)
    assert p.returncode == 0, p.stderr
    for text in ignored:
        assert text in p.stderr, p.stderr
    assert p.stderr.count("ignored") == len(ignored), p.stderr
