#!/usr/bin/env python3
"""Strong scaling of the fluid on this machine, and a model of the halo share on a cluster.

Measures the time per fluid step of fully periodic cubes without bodies (in_place streaming,
double precision; 96^3 and 128^3 cells by default) for 1 rank x 1 thread, 1 rank x 2 threads
(OpenMP) and 2 ranks x 1 thread (`mpirun -np 2`, Open MPI's default binding of a rank to a
core; cut along z as MPI_Dims_create's choice goes to the axes, and along x with run.ranks for
comparison; the z cut also with AGGLO_OVERLAP=0, the exchange before the update instead of during
it), each the best of 3 runs of `coupler run SCENE --steps K --quiet`. The time is the fluid's
own wall time (attribute `wall_time_fluid` of the result file's root, coupler/run.c: the seconds
rank 0 spent in the fluid FMU's doStep, halo exchange and waits for the other rank included,
output rows not), divided by K. Prints `uptime` before and after (the machine may be shared), a
table (time per step, MLUPS, parallel efficiency T(1x1) / (cores x T), the halo bytes each rank
sends per step from `coupler check --ranks 2`), and writes it as CSV.

Then the model figures (halo_model below, its assumptions in its docstring): with the kernel
rate per core measured here at 1 x 1, the halo volume per rank of cubic blocks of 64^3, 128^3
and 256^3 cells and the share of a step the exchange would take on a 100 Gbit/s network.

    tools/mpi_scaling.py [--coupler build/coupler] [--out DIR] [--sizes 96 128] [--reps 3]
"""
import argparse
import csv
import math
import os
import pathlib
import re
import shutil
import subprocess
import sys
import tempfile

import h5py

ROOT = pathlib.Path(__file__).resolve().parents[1]
LB_Q = 19
HALO_Q = 5  # populations crossing a face (fluid/decomp.h)

SCENE = """# fully periodic cube, no bodies: the fluid step alone (tools/mpi_scaling.py)
domain:
  size: [{l}, {l}, {l}]
fluid:
  density: 1000.0
  viscosity: 1.0e-6
  dx: 1.0e-4
  tau: 0.8
  streaming: in_place
  precision: double
  initial_velocity: [1.0e-3, 5.0e-4, 0.0]
run:
  end_time: 1000.0
  output_interval: 1000.0
"""

# (label, ranks, threads, --set options). MPI_Dims_create cuts 2 ranks along x; the same with the
# cut along z is measured too: the exchange of an x face packs one value per row of every
# population (strided), of a z face whole contiguous rows.
# The exchange overlaps the update of the inner rows (fluid.c step_overlapped; not with a cut across
# x); AGGLO_OVERLAP=0 runs the same step in sequence, for the comparison in one run.
CONFIGS = [("1 rank x 1 thread", 1, 1, [], {}), ("1 rank x 2 threads", 1, 2, [], {}),
           ("2 ranks x 1 thread, x cut", 2, 1, ["run.ranks=[2, 1, 1]"], {}),
           ("2 ranks x 1 thread, z cut", 2, 1, [], {}),
           ("2 ranks, z cut, no overlap", 2, 1, [], {"AGGLO_OVERLAP": "0"})]


def uptime():
    return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()


def load1(text):
    m = re.search(r"load average:\s*([\d.]+)", text)
    return float(m.group(1)) if m else float("nan")


def set_args(sets):
    return [a for s in sets for a in ("--set", s)]


def run_once(coupler, scene, out, steps, ranks, threads, sets, extra_env):
    """One `coupler run`; returns (wall_time_fluid, mlups, ranks) from the result file."""
    env = dict(os.environ, OMP_NUM_THREADS=str(threads), **extra_env)
    cmd = [str(coupler), "run", str(scene), "--steps", str(steps), "--quiet", "-o", str(out)] + set_args(sets)
    if ranks > 1:
        mpirun = shutil.which("mpirun")
        if mpirun is None:
            sys.exit("mpi_scaling: mpirun is not installed (openmpi-bin)")
        exports = [a for k in ["OMP_NUM_THREADS", *extra_env] for a in ("-x", k)]
        cmd = [mpirun, "--allow-run-as-root", "--oversubscribe", "-np", str(ranks), *exports] + cmd
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600)
    if r.returncode != 0:
        sys.exit(f"mpi_scaling: {' '.join(cmd)} failed:\n{r.stderr[-3000:]}")
    with h5py.File(out, "r") as f:
        return float(f.attrs["wall_time_fluid"]), float(f.attrs["mlups"]), int(f.attrs.get("ranks", 1))


def halo_per_rank(coupler, scene, ranks, sets):
    """Bytes one rank sends per step (the largest over ranks) from `coupler check --ranks N`."""
    r = subprocess.run([str(coupler), "check", str(scene), "--ranks", str(ranks)] + set_args(sets),
                       capture_output=True, text=True, timeout=120)
    m = re.search(r"at most (\d+) B by one", r.stdout)
    if r.returncode != 0 or m is None:
        sys.exit(f"mpi_scaling: coupler check --ranks {ranks} failed:\n{r.stdout[-2000:]}{r.stderr[-2000:]}")
    return int(m.group(1))


# Measured here (README "Several MPI ranks"): 2 ranks x 1 thread against 1 rank x 2 threads (the
# same two cores and memory bandwidth), z cut: 1.20 ms more per step at 128^3 for 1.352 MB sent
# per rank, 0.89 ms at 96^3 for 0.768 MB: about 1 ns per byte sent for packing, Open MPI's
# shared-memory copy, unpacking and the wait, on one core.
COPY_NS_PER_BYTE = 1.0


def halo_model(n, mlups_per_core, cores_per_rank=8, bandwidth_bits=100e9, latency=2e-6, value_bytes=8,
               copy_ns_per_byte=COPY_NS_PER_BYTE, copy_speedup=4.0, overlap=True):
    """Halo bytes per rank per step and the fraction of a step spent in the exchange, for a
    cubic block of n^3 cells per rank in the interior of a 3-D decomposition.

    Assumptions:
    - 6 exchanged faces (every neighbour on another rank), 5 populations of value_bytes each per
      face cell. The faces span the ranges of fluid/walls.c walls_halo_begin: the x faces n x n,
      the y faces (n + 2) x n, the z faces (n + 2) x (n + 2) (the ghost rows of the axes
      exchanged before). Halo bytes per rank per step = 2 * 5 * value_bytes * (sum of the 3).
    - The exchange runs axis after axis as fluid.c step_overlapped does: 3 rounds; in each, the
      two messages of the axis (one to each side) leave through one network port at the same
      time and the two from the neighbours arrive meanwhile (full duplex), so a round's wire
      time is latency + 2 * face_bytes / bandwidth.
    - The copies (packing, unpacking; on a cluster the network card moves the bytes) cost
      copy_ns_per_byte per byte sent, measured on one core here (COPY_NS_PER_BYTE), divided by
      copy_speedup = 4 for the 8 cores of a rank (the copies are OpenMP loops, memory-bound).
      They are work of the cores: they never overlap the kernel.
    - overlap (the code's default): while a round is on the wire the rank updates a third of its
      inner cells ((n - 2)^3 of n^3), so only the part of each round's wire time beyond that
      third shows; without overlap (AGGLO_OVERLAP=0) all of it does. MPI's software overhead
      is left out, and the network is taken to move the bytes without the CPU (RDMA).
    - One rank per share of 8 cores (e.g. an 8-core socket or a NUMA domain) whose OpenMP
      threads run the kernel at cores_per_rank times the rate measured here on one core
      (optimistic where the memory bandwidth of the socket saturates first), and the rank has
      the whole 100 Gbit/s, 2 us port to itself (one rank per node, or a port per rank).
    - t_kernel = n^3 / (mlups_per_core * 1e6 * cores_per_rank); fraction = t_halo /
      (t_kernel + t_halo), t_halo = the wire time that shows + copies.
    Returns (halo_bytes, halo / populations of the block (19 values per cell), t_kernel,
    t_halo, fraction).
    """
    faces = [n * n, (n + 2) * n, (n + 2) * (n + 2)]
    halo = sum(2 * HALO_Q * value_bytes * f for f in faces)
    bandwidth = bandwidth_bits / 8.0
    t_kernel = n ** 3 / (mlups_per_core * 1e6 * cores_per_rank)
    hidden = t_kernel * (n - 2) ** 3 / n ** 3 / 3.0 if overlap else 0.0
    t_halo = sum(max(0.0, latency + 2 * HALO_Q * value_bytes * f / bandwidth - hidden) for f in faces)
    t_halo += halo * copy_ns_per_byte * 1e-9 / copy_speedup
    share = halo / (LB_Q * value_bytes * n ** 3)
    return halo, share, t_kernel, t_halo, t_halo / (t_kernel + t_halo)


# Collective calls per fluid step (fluid/fluid.c, spheres.c): the status agreement after the
# boundary stage; with moving spheres also the broadcast of the kinematics, the agreements around
# the sphere halo's plan and its two exchanges, and the exact sum of the loads (2 allreduces).
COLLECTIVES = {"fluid only": 1, "moving spheres": 8}


def weak_scaling(n, ranks, mlups_per_core, collectives, cores_per_rank=8, latency=2e-6, **kw):
    """Parallel efficiency of `ranks` ranks with an n^3 block each (weak scaling), against one
    rank with no exchange: t_kernel / (t_kernel + t_halo + t_coll).

    Assumptions (beyond halo_model's): every rank has 6 neighbours on other ranks (a periodic
    domain, or the interior of a large one), so t_halo does not grow with the ranks; each
    collective is a small allreduce or broadcast taking ceil(log2 ranks) latencies (recursive
    doubling or a binomial tree; its bytes are negligible: the loads are 160 bytes per sphere);
    no load imbalance, no network contention, no OS noise. Returns (efficiency, t_coll)."""
    if ranks == 1:
        return 1.0, 0.0
    _, _, tk, th, _ = halo_model(n, mlups_per_core, cores_per_rank=cores_per_rank, latency=latency, **kw)
    t_coll = collectives * math.ceil(math.log2(ranks)) * latency
    return tk / (tk + th + t_coll), t_coll


def print_weak_scaling(per_core):
    print(f"\nweak scaling model (weak_scaling in {pathlib.Path(__file__).name}): efficiency against one rank")
    print(f"{'block':>7} {'ranks':>6} " + " ".join(f"{k:>15}" for k in COLLECTIVES))
    for n in (64, 128, 256):
        for ranks in (8, 64, 1000):
            effs = [weak_scaling(n, ranks, per_core, c)[0] for c in COLLECTIVES.values()]
            print(f"{n:>5}^3 {ranks:>6} " + " ".join(f"{e:>15.3f}" for e in effs))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--coupler", default=str(ROOT / "build" / "coupler"))
    ap.add_argument("--out", default=str(ROOT / "build" / "bench"), help="folder of the CSV files")
    ap.add_argument("--sizes", type=int, nargs="+", default=[96, 128])
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--model-only", type=float, metavar="MLUPS_PER_CORE",
                    help="print only the model figures for this kernel rate per core (no runs)")
    ap.add_argument("--updates", type=float, default=1e8,
                    help="cell updates per run (steps K = updates / cells, at least 10): about 2 s at 1 x 1")
    args = ap.parse_args()
    if args.model_only:
        print_model(args.model_only)
        print_weak_scaling(args.model_only)
        return
    coupler = pathlib.Path(args.coupler)
    if not coupler.exists():
        sys.exit(f"mpi_scaling: {coupler} is missing: run `make all` first")
    out_dir = pathlib.Path(args.out)
    out_dir.mkdir(parents=True, exist_ok=True)

    before = uptime()
    print("before:", before)
    if load1(before) > 1.5:
        print(f"note: load {load1(before):.2f} > 1.5 on {os.cpu_count()} cores: another job competes, the "
              "times are slower and noisier than on an idle machine")
    rows = []
    with tempfile.TemporaryDirectory(prefix="mpi-scaling-") as tmp:
        tmp = pathlib.Path(tmp)
        for n in args.sizes:
            scene = tmp / f"cube{n}.yaml"
            scene.write_text(SCENE.format(l=round(n * 1e-4, 10)))
            steps = max(10, int(args.updates / n ** 3))
            base = None
            for label, ranks, threads, sets, extra_env in CONFIGS:
                halo = halo_per_rank(coupler, scene, ranks, sets) if ranks > 1 else 0
                best, best_mlups = float("inf"), 0.0
                for rep in range(args.reps):
                    wf, mlups, got = run_once(coupler, scene, tmp / "out.h5", steps, ranks, threads, sets, extra_env)
                    if got != ranks:
                        sys.exit(f"mpi_scaling: the run of {label} ran on {got} ranks")
                    if wf / steps < best:
                        best, best_mlups = wf / steps, mlups
                if base is None:
                    base = best
                cores = ranks * threads
                rows.append({"cells": f"{n}^3", "config": label, "ranks": ranks, "threads": threads,
                             "steps": steps, "time_per_step_s": best, "mlups": best_mlups,
                             "efficiency": base / (cores * best),
                             "halo_bytes_per_rank": halo})
                r = rows[-1]
                print(f"  {r['cells']:>6} {label:<26} {best:.5f} s/step  {best_mlups:7.2f} MLUPS", flush=True)
    after = uptime()
    print("after: ", after)

    print()
    print(f"{'cells':>6}  {'configuration':<26} {'steps':>5} {'s/step':>9} {'MLUPS':>8} {'efficiency':>10} "
          f"{'halo B/step/rank':>16}")
    for r in rows:
        print(f"{r['cells']:>6}  {r['config']:<26} {r['steps']:>5} {r['time_per_step_s']:>9.5f} {r['mlups']:>8.2f} "
              f"{r['efficiency']:>10.3f} {r['halo_bytes_per_rank']:>16}")
    csv_path = out_dir / "mpi_scaling.csv"
    with open(csv_path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]) + ["load_before", "load_after"])
        w.writeheader()
        for r in rows:
            w.writerow(dict(r, load_before=load1(before), load_after=load1(after)))

    # the model: the kernel rate per core at 1 x 1 on the largest cube measured
    largest = f"{max(args.sizes)}^3"
    per_core = next(r["mlups"] for r in rows if r["cells"] == largest and r["ranks"] == 1 and r["threads"] == 1)
    model = print_model(per_core, largest)
    print_weak_scaling(per_core)
    model_path = out_dir / "mpi_scaling_model.csv"
    with open(model_path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(model[0]))
        w.writeheader()
        w.writerows(model)
    print(f"\nwrote {csv_path} and {model_path}")


def print_model(per_core, largest="the cube"):
    print()
    print(f"model (halo_model in {pathlib.Path(__file__).name}): kernel {per_core:.1f} MLUPS per core "
          f"(1 x 1, {largest}, double, in_place) x 8 cores per rank; 6 face messages per step in 3 rounds of 2 "
          "(one per axis), a round on the wire = 2 us + 2 x face bytes / 100 Gbit/s, copies 1 ns per byte sent / 4; "
          "with the overlap of the code (each round behind a third of the inner update) and without it")
    print(f"{'block':>7} {'halo MB/step/rank':>18} {'halo/pops':>10} {'t_kernel ms':>12} {'t_halo ms':>10} "
          f"{'halo share':>10} {'t_halo no overlap':>18} {'share':>7}")
    model = []
    for n in (64, 128, 256):
        halo, share, tk, th, frac = halo_model(n, per_core)
        _, _, _, th0, frac0 = halo_model(n, per_core, overlap=False)
        model.append({"block": f"{n}^3", "halo_bytes_per_rank": halo, "halo_over_populations": share,
                      "t_kernel_s": tk, "t_halo_s": th, "halo_fraction": frac, "t_halo_no_overlap_s": th0,
                      "halo_fraction_no_overlap": frac0, "mlups_per_core": per_core})
        print(f"{n:>5}^3 {halo / 1e6:>18.3f} {100 * share:>9.2f}% {1e3 * tk:>12.3f} {1e3 * th:>10.4f} "
              f"{100 * frac:>9.2f}% {1e3 * th0:>18.4f} {100 * frac0:>6.2f}%")
    return model


if __name__ == "__main__":
    main()
