"""Shared fixtures: paths to the built coupler and the models folder, and the
helpers several test files use."""
import os
import pathlib
import subprocess
import time

import h5py
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
COUPLER = ROOT / "build" / "coupler"
MODELS = ROOT / "models"
PY = ROOT / ".venv" / "bin" / "python"


def pytest_configure(config):
    config.addinivalue_line("markers", "validate: long physics validation, run by `make validate`")


@pytest.fixture(scope="session")
def coupler():
    assert COUPLER.exists(), "build/coupler is missing: run `make all` first"
    return COUPLER


def run(*args, cwd=None):
    """Runs the coupler and returns the CompletedProcess (text mode)."""
    env = dict(os.environ, OMP_NUM_THREADS="2")
    return subprocess.run([str(COUPLER), *map(str, args)], capture_output=True, text=True, cwd=cwd, env=env,
                          timeout=600)


def datasets(path):
    """Every dataset of an HDF5 file by its path, read whole."""
    out = {}
    with h5py.File(path, "r") as f:
        f.visititems(lambda n, o: out.__setitem__(n, o[()]) if isinstance(o, h5py.Dataset) else None)
    return out


def wait_for(path, proc, timeout=300):
    """Waits until a running process (Popen) has written path (a checkpoint)."""
    t0 = time.time()
    while not path.exists():
        assert proc.poll() is None, "the run ended before writing a checkpoint: " + proc.stderr.read()
        assert time.time() - t0 < timeout, f"no {path} after {timeout} s"
        time.sleep(0.02)
