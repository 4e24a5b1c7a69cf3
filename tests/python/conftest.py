"""Shared fixtures: paths to the built coupler and the models folder."""
import os
import pathlib
import subprocess

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
