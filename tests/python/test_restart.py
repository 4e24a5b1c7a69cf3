"""Checkpoint and restart of `coupler run` (README "When a run fails").

A run killed after a checkpoint (SIGKILL: nothing of the run's own clean-up
happens) and continued with --restart in a new process must give the same
output as the run that was never interrupted, bit for bit: every dataset of
the output file and of the field file compared with zero tolerance. SIGINT
and SIGTERM finish the step, write a checkpoint and exit with 130 / 143. A
restart with another scene, other options or another build is refused with
a message that says what differs."""
import os
import re
import shlex
import signal
import subprocess
import time

import h5py
import numpy as np
import pytest

from conftest import COUPLER, MODELS, datasets, run, wait_for

SCENE = MODELS / "sinking_sphere.yaml"
STEPS = "700"
EVERY = "0.002"  # 120 communication steps of 1/60000 s


def start(*args):
    env = dict(os.environ, OMP_NUM_THREADS="2")
    return subprocess.Popen([str(COUPLER), *map(str, args)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env=env)


def assert_identical(a, b):
    da, db = datasets(a), datasets(b)
    assert sorted(da) == sorted(db)
    assert len(da) > 0
    for name in da:
        assert da[name].shape == db[name].shape, name
        assert np.array_equal(da[name], db[name]), f"{name} differs after the restart"


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The uninterrupted runs, Verlet and CVODE, fields every 0.003 s."""
    d = tmp_path_factory.mktemp("reference")
    outs = {}
    for integrator in ("verlet", "cvode"):
        out = d / f"{integrator}.h5"
        p = run("run", SCENE, "-o", out, "--steps", STEPS, "--quiet", "--set", f"rigid.integrator={integrator}",
                "--set", "run.field_interval=0.003")
        assert p.returncode == 0, p.stderr
        outs[integrator] = out
    return outs


@pytest.mark.parametrize("integrator", ["verlet", "cvode"])
def test_sigkill_after_checkpoint_then_restart_is_bit_identical(coupler, reference, tmp_path, integrator):
    out = tmp_path / "run.h5"
    ckpt = tmp_path / "run_checkpoint.h5"
    sets = ["--set", f"rigid.integrator={integrator}", "--set", "run.field_interval=0.003"]
    proc = start("run", SCENE, "-o", out, "--steps", STEPS, "--quiet", "--checkpoint-every", EVERY, *sets)
    wait_for(ckpt, proc)
    time.sleep(0.3)  # somewhere after it: in a step, an output row or the next checkpoint
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert proc.returncode == -signal.SIGKILL, "the run finished before it was killed: make it longer"
    assert not (tmp_path / "run_checkpoint.h5.tmp").exists() or ckpt.exists()
    with h5py.File(ckpt, "r") as f:
        step = int(f.attrs["step"])
        assert step > 0 and step % 120 == 0  # a checkpoint every 0.002 s
    p = run("run", SCENE, "-o", out, "--steps", STEPS, "--quiet", "--restart", ckpt, *sets)
    assert p.returncode == 0, p.stderr
    assert_identical(reference[integrator], out)
    ref_fields = reference[integrator].with_name(reference[integrator].stem + "_fields.h5")
    assert_identical(ref_fields, tmp_path / "run_fields.h5")


@pytest.mark.parametrize("sig,code", [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_signal_writes_checkpoint_and_exits(coupler, reference, tmp_path, sig, code):
    out = tmp_path / "run.h5"
    ckpt = tmp_path / "run_checkpoint.h5"
    proc = start("run", SCENE, "-o", out, "--steps", STEPS, "--quiet", "--checkpoint-every", EVERY, "--set",
                 "run.field_interval=0.003")
    wait_for(ckpt, proc)
    first = os.stat(ckpt).st_mtime_ns
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == code, err
    assert "stopped by " + ("SIGTERM" if sig == signal.SIGTERM else "SIGINT") in err
    assert str(ckpt) in err and "--restart" in err
    assert os.stat(ckpt).st_mtime_ns >= first  # written again at the stop
    with h5py.File(out, "r") as f:  # the output is readable as it was left
        rows = len(f["/time"])
    with h5py.File(ckpt, "r") as f:
        assert int(f.attrs["rows"]) == rows
    p = run("run", SCENE, "-o", out, "--steps", STEPS, "--quiet", "--restart", ckpt, "--set",
            "run.field_interval=0.003")
    assert p.returncode == 0, p.stderr
    assert_identical(reference["verlet"], out)


def test_restart_into_another_output_continues_a_copy_of_the_fields(coupler, reference, tmp_path):
    # a run of 400 steps (checkpoints every 120 steps and at its end, fields every 180) continued to
    # 700 in another folder under another name: its output and field file equal the uninterrupted
    # run's, and the first run's field file is left as it was (the snapshots after a checkpoint are
    # dropped by the same resume of the field file as in the SIGKILL tests above)
    sets = ["--set", "run.field_interval=0.003"]
    first = tmp_path / "first" / "run.h5"
    first.parent.mkdir()
    p = run("run", SCENE, "-o", first, "--steps", "400", "--quiet", "--checkpoint-every", EVERY, *sets)
    assert p.returncode == 0, p.stderr
    ckpt, old_fields = first.with_name("run_checkpoint.h5"), first.with_name("run_fields.h5")
    with h5py.File(ckpt, "r") as f:
        step = int(f.attrs["step"])
    assert step == 400  # the one at its last step (360 before it wrote one there)
    before = old_fields.read_bytes()
    moved = tmp_path / "second" / "continued.h5"
    moved.parent.mkdir()
    p = run("run", SCENE, "-o", moved, "--steps", STEPS, "--quiet", "--restart", ckpt, *sets)
    assert p.returncode == 0, p.stderr
    assert_identical(reference["verlet"], moved)
    ref_fields = reference["verlet"].with_name("verlet_fields.h5")
    assert_identical(ref_fields, moved.with_name("continued_fields.h5"))
    assert old_fields.read_bytes() == before
    with h5py.File(moved, "r") as f:  # the output links to its own field file
        assert f.get("fields", getlink=True).filename == "continued_fields.h5"
    # the interrupted run's field file gone: a warning names it, and the new field file holds the
    # snapshots from the checkpoint on, each equal to the uninterrupted run's
    old_fields.unlink()
    again = tmp_path / "third" / "again.h5"
    again.parent.mkdir()
    p = run("run", SCENE, "-o", again, "--steps", STEPS, "--quiet", "--restart", ckpt, *sets)
    assert p.returncode == 0, p.stderr
    assert str(old_fields) in p.stderr and "starts anew" in p.stderr
    assert_identical(reference["verlet"], again)
    ref, new = datasets(ref_fields), datasets(again.with_name("again_fields.h5"))
    later = sorted(n for n in new if int(n.split("/")[1]) > step)
    assert later == sorted(n for n in ref if n.startswith("fields/") and int(n.split("/")[1]) > step)
    assert len(later) > 0
    for name in new:
        assert np.array_equal(new[name], ref[name]), name


@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory):
    """A finished short run with checkpoints, to try bad restarts on."""
    d = tmp_path_factory.mktemp("bad")
    out = d / "run.h5"
    p = run("run", SCENE, "-o", out, "--steps", "130", "--quiet", "--checkpoint-every", EVERY, "--set",
            "run.fields=false")
    assert p.returncode == 0, p.stderr
    return d / "run_checkpoint.h5"


def test_restart_with_another_scene_is_refused(coupler, checkpoint, tmp_path):
    out = tmp_path / "x.h5"
    p = run("run", SCENE, "-o", out, "--steps", "130", "--restart", checkpoint, "--set", "run.fields=false", "--set",
            "fluid.tau=0.9")
    assert p.returncode == 1
    assert "belongs to another scene" in p.stderr
    assert "tau" in p.stderr  # the line that differs
    assert not out.exists()  # nothing written


def restart_with(checkpoint, tmp_path, attr, value):
    """Restarts from a copy of the checkpoint with one origin attribute changed."""
    bad = tmp_path / "tampered.h5"
    bad.write_bytes(checkpoint.read_bytes())
    with h5py.File(bad, "r+") as f:
        f.attrs[attr] = np.bytes_(value)
    return run("run", SCENE, "-o", tmp_path / "x.h5", "--steps", "130", "--restart", bad, "--set", "run.fields=false")


def test_restart_with_another_build_is_refused(coupler, checkpoint, tmp_path):
    p = restart_with(checkpoint, tmp_path, "origin_coupler", "build 0123456789abcdef")
    assert p.returncode == 1
    assert "coupler build 0123456789abcdef" in p.stderr and "this run has coupler build" in p.stderr


def test_restart_with_other_fmus_is_refused(coupler, checkpoint, tmp_path):
    p = restart_with(checkpoint, tmp_path, "origin_fluid", "GUID {00000000-0000-0000-0000-000000000000}, library 0")
    assert p.returncode == 1
    assert "fluid FMU GUID {00000000" in p.stderr


def test_restart_with_other_exchange_is_refused(coupler, checkpoint, tmp_path):
    p = run("run", SCENE, "-o", tmp_path / "x.h5", "--steps", "130", "--restart", checkpoint, "--set",
            "run.fields=false", "--exchange-every", "2")
    assert p.returncode == 1
    assert "--exchange-every 1" in p.stderr and "--exchange-every 2" in p.stderr


def test_restart_from_a_damaged_checkpoint_is_refused(coupler, checkpoint, tmp_path):
    """One byte changed in the fluid state's populations: the state's own header checks only the
    header, and the restart took the changed population silently; the state datasets are stored
    with HDF5's Fletcher-32 checksum per chunk, so the read fails and the restart is refused,
    naming the dataset, before anything is written."""
    bad = tmp_path / "damaged.h5"
    bad.write_bytes(checkpoint.read_bytes())
    with h5py.File(bad, "r") as f:
        d = f["/fluid_state/0"]
        assert d.fletcher32 and d.chunks is not None
        info = d.id.get_chunk_info(d.id.get_num_chunks() // 2)
    data = bytearray(bad.read_bytes())
    data[info.byte_offset + info.size // 2] ^= 0x10
    bad.write_bytes(bytes(data))
    out = tmp_path / "x.h5"
    p = run("run", SCENE, "-o", out, "--steps", "140", "--restart", bad, "--set", "run.fields=false")
    assert p.returncode == 1, p.stderr
    assert "/fluid_state/0 is missing or unreadable" in p.stderr and "damaged" in p.stderr, p.stderr
    assert not out.exists()


def test_restart_from_a_file_that_is_no_checkpoint(coupler, tmp_path):
    junk = tmp_path / "junk.h5"
    junk.write_text("not hdf5")
    p = run("run", SCENE, "-o", tmp_path / "x.h5", "--restart", junk)
    assert p.returncode == 1
    assert str(junk) in p.stderr and "cannot open the checkpoint" in p.stderr


def test_checkpoint_every_must_be_positive(coupler, tmp_path):
    p = run("run", SCENE, "-o", tmp_path / "x.h5", "--checkpoint-every", "-1")
    assert p.returncode == 2
    assert "--checkpoint-every takes a simulated time > 0" in p.stderr


def test_sigkill_without_checkpoint_keeps_the_rows_written(coupler, reference, tmp_path):
    # rows are buffered and written at least once a second (coupler/output.h): a run killed
    # by SIGKILL, with no checkpoint and no clean-up, leaves a readable file whose rows are
    # the uninterrupted run's first rows, bit for bit, and which lacks at most the rows of
    # the last second before the kill
    # the run is far longer than the wait (100 000 steps; 700 took 5.5 s here and under 4 s on
    # CI's machine, which made the test fail), so it is alive when the kill comes on any machine
    out = tmp_path / "killed.h5"
    proc = start("run", SCENE, "-o", out, "--steps", "100000", "--quiet", "--set", "run.fields=false",
                 "--set", "run.output_interval=1.6667e-5")  # a row every step
    try:
        time.sleep(4.0)
        assert proc.poll() is None, "the run ended before it was killed: " + proc.stderr.read()
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    assert proc.returncode == -signal.SIGKILL
    ref = datasets(reference["verlet"])
    with h5py.File(out, "r") as f:
        t = f["/time"][()]
        v = f["/spheres/velocity"][()]
    assert len(t) > 10, "fewer than 10 rows after 4 s"
    assert np.all(np.diff(t) > 0)
    # the first rows agree with the reference run at the times both have
    common = np.isin(t, ref["time"])
    assert common.sum() >= 1
    idx = np.searchsorted(ref["time"], t[common])
    assert np.array_equal(ref["spheres/velocity"][idx], v[common])


@pytest.mark.parametrize("output_interval", ["1e-9", "5e-5"])
@pytest.mark.parametrize("steps", [20, 40])
def test_a_run_that_ended_continues_as_one_longer_run(coupler, tmp_path, output_interval, steps):
    """A run of 20 steps with --checkpoint-every writes its last checkpoint at
    its last step (before, the last was the periodic one before the end: a run
    that had ended could not be continued). Restarted from it with --steps 20
    it begins at its last step and must write the 20-step run's output (with a
    row every step the checkpoint holds the row of step 20 already, and a
    restart there once wrote it again: 22 rows, the time 0.00033 s twice);
    with --steps 40 the output and fields of the uninterrupted 40-step run.
    With a row every 3 steps (5e-5 s) the row of step 20 is there only because
    the first run ended there: the continued run leaves it out (it kept it
    before: 16 rows against 15)."""
    sets = ["--set", f"run.output_interval={output_interval}", "--set", "run.field_interval=1e-4"]
    ref = tmp_path / "ref.h5"
    p = run("run", SCENE, "-o", ref, "--steps", steps, "--quiet", *sets)
    assert p.returncode == 0, p.stderr
    out = tmp_path / "run.h5"
    p = run("run", SCENE, "-o", out, "--steps", "20", "--quiet", "--checkpoint-every", "1", *sets)
    assert p.returncode == 0, p.stderr
    assert f"checkpoint {tmp_path / 'run_checkpoint.h5'} at the last step (20): to go on" in p.stdout
    with h5py.File(tmp_path / "run_checkpoint.h5", "r") as f:
        assert f.attrs["step"] == 20
        assert f.attrs["end_row"] == (1 if output_interval == "5e-5" else 0)
    p = run("run", SCENE, "-o", out, "--steps", steps, "--quiet", "--restart", tmp_path / "run_checkpoint.h5", *sets)
    assert p.returncode == 0, p.stderr
    assert_identical(ref, out)
    assert_identical(tmp_path / "ref_fields.h5", tmp_path / "run_fields.h5")
    t = datasets(out)["time"]
    assert np.all(np.diff(t) > 0), t


def test_stop_message_gives_the_command_that_continues(coupler, tmp_path):
    """The command that a stop by SIGTERM prints ("continue with `...`") repeats
    the options the continuation needs: --exchange-every (without it the restart
    is refused), --steps (without it the run went on to run.end_time) and
    --checkpoint-every (without it the continued run wrote no checkpoint). Run
    as printed, it gives the output of the uninterrupted run."""
    sets = ["--set", "run.fields=false"]
    opts = ["--exchange-every", "2", "--steps", "350"]
    ref = tmp_path / "ref.h5"
    p = run("run", SCENE, "-o", ref, "--quiet", *opts, *sets)
    assert p.returncode == 0, p.stderr
    out = tmp_path / "run.h5"
    proc = start("run", SCENE, "-o", out, "--quiet", *opts, "--checkpoint-every", EVERY, *sets)
    wait_for(tmp_path / "run_checkpoint.h5", proc)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 143, err
    printed = re.search(r"continue with `([^`]*)`", err).group(1)
    for option in ("--exchange-every 2", "--steps 350", f"--checkpoint-every {EVERY}"):
        assert option in printed, printed
    words = shlex.split(printed.replace("[the same --set options]", shlex.join(sets)))
    assert words[:2] == ["coupler", "run"], printed
    p = run(*words[1:])
    assert p.returncode == 0, p.stderr
    assert_identical(ref, out)


def test_restart_of_an_output_not_named_h5_finds_its_field_file(coupler, reference, tmp_path):
    """-o run.hdf5: the field file is run_fields.h5 (the output's name without its
    extension) and so is the checkpoint's name, run_checkpoint.h5, so that a restart
    into another output finds the field file beside the checkpoint. The checkpoint
    was run.hdf5_checkpoint.h5 (only .h5 was taken off), the restart looked for
    run.hdf5_fields.h5, warned that it was not there and the new field file lacked
    every snapshot before the checkpoint."""
    sets = ["--set", "run.field_interval=0.003"]
    first = tmp_path / "first" / "run.hdf5"
    first.parent.mkdir()
    p = run("run", SCENE, "-o", first, "--steps", "400", "--quiet", "--checkpoint-every", EVERY, *sets)
    assert p.returncode == 0, p.stderr
    ckpt = first.with_name("run_checkpoint.h5")
    assert ckpt.exists() and first.with_name("run_fields.h5").exists()
    moved = tmp_path / "second" / "continued.hdf5"
    moved.parent.mkdir()
    p = run("run", SCENE, "-o", moved, "--steps", STEPS, "--quiet", "--restart", ckpt, *sets)
    assert p.returncode == 0, p.stderr
    assert "not there" not in p.stderr, p.stderr
    assert_identical(reference["verlet"], moved)
    assert_identical(reference["verlet"].with_name("verlet_fields.h5"), moved.with_name("continued_fields.h5"))


def test_restart_into_an_output_whose_field_file_is_another_runs(coupler, reference, tmp_path):
    """A restart into another output copies the interrupted run's field file also
    over a field file of that name already there from another run: it continued
    that file instead, keeping the other run's snapshots before the checkpoint
    (here those of 50 steps with a snapshot every 30: fields/000030 was in the
    result, and 000000 was the other run's)."""
    sets = ["--set", "run.field_interval=0.003"]
    first = tmp_path / "first" / "run.h5"
    first.parent.mkdir()
    p = run("run", SCENE, "-o", first, "--steps", "400", "--quiet", "--checkpoint-every", EVERY, *sets)
    assert p.returncode == 0, p.stderr
    moved = tmp_path / "second" / "continued.h5"
    moved.parent.mkdir()
    p = run("run", SCENE, "-o", moved, "--steps", "50", "--quiet", "--set", "run.field_interval=0.0005",
            "--set", "fluid.initial_velocity=[0, 0, 1e-4]")
    assert p.returncode == 0, p.stderr
    p = run("run", SCENE, "-o", moved, "--steps", STEPS, "--quiet", "--restart", first.with_name("run_checkpoint.h5"),
            *sets)
    assert p.returncode == 0, p.stderr
    assert_identical(reference["verlet"], moved)
    assert_identical(reference["verlet"].with_name("verlet_fields.h5"), moved.with_name("continued_fields.h5"))


def test_moments_layout_restart_is_bit_identical(coupler, tmp_path):
    """fluid.streaming: moments (the moments, the side-store index and its entries
    in the fluid's state, fluid/state.c): a run of 20 steps with a checkpoint at its
    end, continued to 40, gives the output and fields of the uninterrupted 40-step run
    (a settling sphere: cells covered and uncovered, their entries come and go)."""
    sets = ["--set", "fluid.streaming=moments", "--set", "fluid.collision=regularized", "--set",
            "run.output_interval=5e-5", "--set", "run.field_interval=1e-4"]
    ref = tmp_path / "ref.h5"
    p = run("run", SCENE, "-o", ref, "--steps", "40", "--quiet", *sets)
    assert p.returncode == 0, p.stderr
    out = tmp_path / "run.h5"
    p = run("run", SCENE, "-o", out, "--steps", "20", "--quiet", "--checkpoint-every", "1", *sets)
    assert p.returncode == 0, p.stderr
    p = run("run", SCENE, "-o", out, "--steps", "40", "--quiet", "--restart", tmp_path / "run_checkpoint.h5", *sets)
    assert p.returncode == 0, p.stderr
    assert_identical(ref, out)
    assert_identical(tmp_path / "ref_fields.h5", tmp_path / "run_fields.h5")
    # a checkpoint of the moments layout restarted in place is refused
    p = run("run", SCENE, "-o", tmp_path / "x.h5", "--steps", "40", "--quiet", "--restart",
            tmp_path / "run_checkpoint.h5", "--set", "run.output_interval=5e-5", "--set", "run.field_interval=1e-4")
    assert p.returncode != 0
