"""Checkpoint and restart of `coupler run` on several MPI ranks (README "When
a run fails"; coupler/checkpoint.h).

Rank 0 writes one checkpoint file with every rank's fluid block (received
from the other ranks), the rigid state and the master's counters; a restart
on the same ranks and blocks continues the run bit for bit: every dataset of
the output and of the field file is compared with zero tolerance with the
run that was never interrupted. A stop signal seen by one rank stops all of
them at the same communication step. A restart on another number of ranks
is refused with both numbers.

The scene is the settling sphere of mpi_util.py, whose surface lies across the
cut between the two ranks' blocks (x = 12 cells), so that both blocks hold
sphere cells and their states differ.
"""
import os
import signal
import subprocess

import h5py
import numpy as np
import pytest

from conftest import datasets, wait_for
from mpi_util import MPIRUN, SETTLE, coupler_command, env1, run_coupler

pytestmark = pytest.mark.skipif(MPIRUN is None, reason="mpirun (openmpi-bin) is not installed")

# 240 communication steps of 1/60000 s; a checkpoint every 60
EVERY = "0.001"
# 3600 steps (a few seconds on 2 ranks): long enough to be stopped by a signal
LONG = SETTLE.replace("end_time: 0.004", "end_time: 0.06").replace("field_interval: 0.002", "field_interval: 0.01")


run = run_coupler


def start(ranks, *args, env=None):
    return subprocess.Popen(coupler_command(ranks, *args), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=env if env is not None else env1())


def fields_of(out):
    return out.with_name(out.stem + "_fields.h5")


def assert_identical(ref, out):
    """The output and the field file, every dataset bit for bit."""
    for a, b in ((ref, out), (fields_of(ref), fields_of(out))):
        da, db = datasets(a), datasets(b)
        assert sorted(da) == sorted(db), b
        assert len(da) > 3
        for name in da:
            assert np.array_equal(da[name], db[name]), f"{b}: {name} differs after the restart"


@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    d = tmp_path_factory.mktemp("scenes")
    (d / "settle.yaml").write_text(SETTLE)
    (d / "long.yaml").write_text(LONG)
    return d


@pytest.fixture(scope="module")
def reference(scenes, tmp_path_factory):
    """The uninterrupted runs on 2 ranks (test_mpi: the same on 1 rank)."""
    d = tmp_path_factory.mktemp("reference")
    outs = {}
    for name in ("settle", "long"):
        out = d / f"{name}.h5"
        p = run(2, "run", scenes / f"{name}.yaml", "-o", out, "--quiet")
        assert p.returncode == 0, p.stderr[-3000:]
        outs[name] = out
    return outs


@pytest.fixture(scope="module")
def cut_short(scenes, tmp_path_factory):
    """Runs of 130 of the 240 steps with a checkpoint every 60, on 1 and 2
    ranks: each leaves the checkpoint of its last step, 130 (before one was
    written at a run's end, that of step 120)."""
    runs = {}
    for ranks in (1, 2):
        d = tmp_path_factory.mktemp(f"short{ranks}")
        out = d / "run.h5"
        p = run(ranks, "run", scenes / "settle.yaml", "-o", out, "--quiet", "--steps", "130", "--checkpoint-every",
                EVERY)
        assert p.returncode == 0, p.stderr[-3000:]
        runs[ranks] = out
    return runs


@pytest.mark.parametrize("ranks", [1, 2])
def test_run_cut_short_then_restarted_is_bit_identical(scenes, reference, cut_short, ranks):
    """A restart runs longer than the run that wrote the checkpoint (--steps
    130, then the scene's 240): the fluid FMU keeps the stop time of its own
    experiment (common/fmi_adapter.c)."""
    out = cut_short[ranks]
    ckpt = out.with_name("run_checkpoint.h5")
    with h5py.File(ckpt, "r") as f:
        assert int(f.attrs["step"]) == 130
        assert int(f.attrs["ranks"]) == ranks
        assert list(f.attrs["decomposition"]) == ([1, 1, 2] if ranks == 2 else [1, 1, 1])
        blocks = [f[f"fluid_state/{k}"][()] for k in range(ranks)]
    if ranks == 2:
        assert not np.array_equal(blocks[0], blocks[1]), "the two blocks should differ (the sphere spans both)"
    p = run(ranks, "run", scenes / "settle.yaml", "-o", out, "--quiet", "--restart", ckpt)
    assert p.returncode == 0, p.stderr[-3000:]
    assert_identical(reference["settle"], out)


def ranks_of(mpirun_pid):
    """The rank processes that mpirun started: {rank: pid}."""
    ranks = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as f:
                ppid = int(f.read().rsplit(")", 1)[1].split()[1])
            if ppid != mpirun_pid:
                continue
            with open(f"/proc/{entry}/environ", "rb") as f:
                env = dict(v.split(b"=", 1) for v in f.read().split(b"\0") if b"=" in v)
        except (OSError, ValueError, IndexError):
            continue
        if b"OMPI_COMM_WORLD_RANK" in env:
            ranks[int(env[b"OMPI_COMM_WORLD_RANK"])] = int(entry)
    return ranks


def stop_then_restart(scenes, reference, tmp_path, send, env=None):
    """Starts the long run on 2 ranks, calls send(proc) once the first
    checkpoint is there, and restarts from the checkpoint of the stop."""
    out = tmp_path / "long.h5"
    ckpt = tmp_path / "long_checkpoint.h5"
    proc = start(2, "run", scenes / "long.yaml", "-o", out, "--quiet", "--checkpoint-every", "0.002", env=env)
    wait_for(ckpt, proc)
    send(proc)
    _, err = proc.communicate(timeout=300)
    assert "stopped by SIGTERM" in err, err[-3000:]
    assert "mpirun -np 2 coupler run" in err and "--restart" in err
    assert "MPI_ABORT" not in err, "the ranks must end with MPI_Finalize after a stop, not MPI_Abort"
    with h5py.File(ckpt, "r") as f:
        step, rows = int(f.attrs["step"]), int(f.attrs["rows"])
    assert 120 < step < 3600, "the checkpoint of the stop (after the first, before the end)"
    with h5py.File(out, "r") as f:
        assert len(f["/time"]) == rows  # the output as it was left
    p = run(2, "run", scenes / "long.yaml", "-o", out, "--quiet", "--restart", ckpt)
    assert p.returncode == 0, p.stderr[-3000:]
    assert_identical(reference["long"], out)
    return proc.returncode


def test_sigterm_to_mpirun_writes_checkpoint_and_restarts(scenes, reference, tmp_path):
    """Open MPI 4.1's mpirun passes SIGTERM (and SIGINT) on to the ranks as
    SIGTERM, odls_base_sigkill_timeout seconds later (SIGCONT first), and
    SIGKILLs them as long again after that; it exits with 1 whatever the
    ranks return. 2 s is ample for this checkpoint (the default 1 s is
    enough here too, but not on a loaded machine)."""
    rc = stop_then_restart(scenes, reference, tmp_path, lambda proc: proc.send_signal(signal.SIGTERM),
                           env=env1(OMPI_MCA_odls_base_sigkill_timeout="2"))
    assert rc != 0


def test_sigterm_to_one_rank_stops_both_at_one_step(scenes, reference, tmp_path):
    """A signal that reaches only rank 1 (as a batch system's signal may
    reach the ranks at different steps): both ranks stop at the same
    communication step (the flag is agreed once per step), rank 0 writes
    the checkpoint with both blocks, and every rank exits with 143, which
    mpirun passes on."""
    def send(proc):
        ranks = ranks_of(proc.pid)
        assert sorted(ranks) == [0, 1], ranks
        os.kill(ranks[1], signal.SIGTERM)

    assert stop_then_restart(scenes, reference, tmp_path, send) == 143


@pytest.mark.parametrize("written,now", [(2, 1), (2, 4), (1, 2)])
def test_restart_on_other_ranks_is_refused(scenes, cut_short, tmp_path, written, now):
    ckpt = cut_short[written].with_name("run_checkpoint.h5")
    out = tmp_path / "x.h5"
    p = run(now, "run", scenes / "settle.yaml", "-o", out, "--quiet", "--restart", ckpt)
    assert p.returncode != 0
    dims = "[1, 1, 2]" if written == 2 else "[1, 1, 1]"
    what = f"{ckpt} was written by {written} rank{'s' if written > 1 else ''} as {dims}; this run has {now} rank"
    assert what in p.stderr, p.stderr[-3000:]
    assert ("restart with mpirun -np 2" if written == 2 else "restart on one rank (without mpirun)") in p.stderr
    assert not out.exists()  # nothing written


def test_checkpoint_test_on_two_ranks(scenes, tmp_path):
    """--checkpoint-test: every rank saves its states at t1, runs to the end,
    restores them and runs again; the rows must be bit-identical."""
    p = run(2, "run", scenes / "settle.yaml", "-o", tmp_path / "ct.h5", "--checkpoint-test", "0.002")
    assert p.returncode == 0, p.stderr[-3000:]
    assert "run again: bit-identical (0 of 121 communication points differ)" in p.stdout
