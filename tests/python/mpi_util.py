"""What the MPI tests share (test_mpi.py, test_mpi_restart.py, test_mpi_check.py):
mpirun, the environment of their runs, and the settling-sphere scene whose
surface lies across the cuts of 2 and 4 ranks."""
import os
import shutil
import subprocess

from conftest import COUPLER

MPIRUN = shutil.which("mpirun")


def env1(**extra):
    """One OpenMP thread per rank: 4 ranks on 2 cores with spinning barriers would crawl."""
    e = dict(os.environ, OMP_NUM_THREADS="1")
    e.update(extra)
    return e


def coupler_command(ranks, *args):
    """build/coupler with args, under mpirun on more than one rank (as root, more ranks than
    cores, OMP_NUM_THREADS passed on)."""
    if ranks == 1:
        return [str(COUPLER), *map(str, args)]
    return [MPIRUN, "--allow-run-as-root", "--oversubscribe", "-np", str(ranks), "-x", "OMP_NUM_THREADS",
            str(COUPLER), *map(str, args)]


def run_coupler(ranks, *args, timeout=600, env=None):
    """coupler_command run to its end with one thread per rank (and the variables of env, which
    mpirun passes on); the CompletedProcess (text)."""
    cmd = coupler_command(ranks, *args)
    if ranks > 1 and env:
        cmd[1:1] = [a for k in env for a in ("-x", k)]
    return subprocess.run(cmd, capture_output=True, text=True, env=env1(**(env or {})), timeout=timeout)


# A free sphere (radius 4.5 cells, density ratio 2) settling from rest in a
# 24 x 24 x 32 box, its surface across x = 12 and z = 16 and 24.
SETTLE = """
domain:
  size: [2.4e-4, 2.4e-4, 3.2e-4]
  faces:
    x_min: {type: no_slip}
    x_max: {type: no_slip}
    y_min: {type: free_slip}
    y_max: {type: free_slip}
    z_min: {type: no_slip}
    z_max: {type: no_slip}
fluid:
  density: 1000.0
  viscosity: 1.0e-6
  dx: 1.0e-5
  tau: 1.0
  streaming: in_place
bodies:
  - name: sphere
    density: 2000.0
    spheres:
      - {center: [1.23e-4, 1.17e-4, 2.0e-4], radius: 4.5e-5}
rigid:
  gravity: [0, 0, -9.81]
run:
  end_time: 0.004
  output_interval: 2.0e-4
  fields: true
  field_interval: 0.002
"""
