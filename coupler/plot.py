#!/usr/bin/env python3
"""plot.py — plots of a `coupler run` (or fmpy_master.py) output file.

    coupler/plot.py OUT.h5 [-o DIR]

Writes PNG files (matplotlib, Agg backend) into DIR (default: beside OUT.h5),
named OUT_<what>.png, for what the file holds (DESIGN section 5):
  trajectories   sphere centres, x-z and y-z projections, per sphere
  velocity       sphere velocity components over time
  force          hydrodynamic force components over time
  connections    connection force and torque magnitudes over time, with the
                 moment each connection broke
  settling       for one free sphere under gravity: the settling speed and the
                 total force over time, like Fig. 6 of Iglberger, Thuerey &
                 Ruede (2008), with the Stokes value (Eq. 10)
  fluid          fluid kinetic energy and momentum over time
Prints the names of the files written.
"""
import argparse
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import h5py  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import h5out  # noqa: E402
import scene_yaml  # noqa: E402


text = h5out.text
save = h5out.save


def settling_sphere(scene):
    """Index of the one free single-sphere body under gravity, or None."""
    bodies = scene.get("bodies") or []
    free = [(k, b) for k, b in enumerate(bodies) if b.get("motion", "free") == "free"]
    g = (scene.get("rigid") or {}).get("gravity", [0, 0, 0])
    if len(free) != 1 or len(free[0][1]["spheres"]) != 1 or not any(g):
        return None
    k = free[0][0]
    return sum(len(b["spheres"]) for b in bodies[:k]), free[0][1], np.array(g, dtype=float)


def plot(path, outdir):
    written = []
    stem = os.path.join(outdir, os.path.splitext(os.path.basename(path))[0])
    with h5py.File(path, "r") as f:
        t = f["/time"][:]
        scene = scene_yaml.load(text(f.attrs["scene"])) if "scene" in f.attrs else {}
        if "spheres" in f:
            pos, vel, force = f["/spheres/position"][:], f["/spheres/velocity"][:], f["/spheres/force"][:]
            ns = pos.shape[1]
            fig, ax = plt.subplots(1, 2, figsize=(10, 4.5))
            for i in range(ns):
                ax[0].plot(pos[:, i, 0] * 1e6, pos[:, i, 2] * 1e6, label=f"sphere {i}")
                ax[1].plot(pos[:, i, 1] * 1e6, pos[:, i, 2] * 1e6)
            ax[0].set(xlabel="x (um)", ylabel="z (um)", title="trajectories (x-z)")
            ax[1].set(xlabel="y (um)", ylabel="z (um)", title="trajectories (y-z)")
            if ns <= 10:
                ax[0].legend(fontsize=7)
            save(fig, f"{stem}_trajectories.png", written)
            for name, data, unit in (("velocity", vel, "m/s"), ("force", force, "N")):
                fig, ax = plt.subplots(1, 3, figsize=(13, 4), sharex=True)
                for a, axis in enumerate("xyz"):
                    for i in range(ns):
                        ax[a].plot(t, data[:, i, a], label=f"sphere {i}")
                    ax[a].set(xlabel="t (s)", ylabel=f"{name} {axis} ({unit})")
                if ns <= 10:
                    ax[0].legend(fontsize=7)
                fig.suptitle(f"sphere {name}")
                save(fig, f"{stem}_{name}.png", written)
            s = settling_sphere(scene)
            if s is not None:
                i, body, g = s
                gdir = g / np.linalg.norm(g)
                a = body["spheres"][0]["radius"]
                rho_f, nu = scene["fluid"]["density"], scene["fluid"]["viscosity"]
                stokes = 2 * np.linalg.norm(g) * a * a * (body["density"] - rho_f) / (9 * rho_f * nu)
                fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
                ax[0].plot(t, vel[:, i] @ gdir, label="simulation")
                ax[0].axhline(stokes, color="k", ls="--", label=f"Stokes, Eq. 10 ({stokes:.3g} m/s)")
                ax[0].set(xlabel="t (s)", ylabel="settling velocity (m/s)", title="sinking velocity")
                ax[0].legend()
                ax[1].plot(t, -(force[:, i] @ gdir), label="hydrodynamic force against gravity")
                weight = (body["density"] - rho_f) * 4 / 3 * math.pi * a ** 3 * np.linalg.norm(g)
                ax[1].axhline(weight, color="k", ls="--", label=f"weight - buoyancy ({weight:.3g} N)")
                ax[1].set(xlabel="t (s)", ylabel="force (N)", title="total force on the particle")
                ax[1].legend()
                fig.suptitle("sinking sphere (cf. Iglberger, Thuerey & Ruede 2008, Fig. 6)")
                save(fig, f"{stem}_settling.png", written)
        if "connections" in f:
            cf, ct = f["/connections/force"][:], f["/connections/torque"][:]
            intact, pair = f["/connections/intact"][:], f["/connections/pair"][:]
            fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
            for k in range(cf.shape[1]):
                lab = f"{k}: spheres {pair[k][0]}-{pair[k][1]}"
                ax[0].plot(t, np.linalg.norm(cf[:, k], axis=1), label=lab)
                ax[1].plot(t, np.linalg.norm(ct[:, k], axis=1), label=lab)
                broke = np.nonzero(intact[:, k] == 0)[0]
                if broke.size:
                    ax[0].axvline(t[broke[0]], color="r", ls=":", lw=0.8)
            ax[0].set(xlabel="t (s)", ylabel="|force| (N)", title="connection force (Eq. 8)")
            ax[1].set(xlabel="t (s)", ylabel="|torque| (N m)", title="connection torque (Eq. 9)")
            if cf.shape[1] <= 12:
                ax[0].legend(fontsize=7)
            save(fig, f"{stem}_connections.png", written)
        if "fluid" in f:
            fig, ax = plt.subplots(1, 2, figsize=(11, 4))
            ax[0].plot(t, f["/fluid/kinetic_energy"][:])
            ax[0].set(xlabel="t (s)", ylabel="kinetic energy (J)")
            mom = f["/fluid/momentum"][:]
            for a, axis in enumerate("xyz"):
                ax[1].plot(t, mom[:, a], label=axis)
            ax[1].set(xlabel="t (s)", ylabel="momentum (kg m/s)")
            ax[1].legend()
            fig.suptitle("fluid")
            save(fig, f"{stem}_fluid.png", written)
    return written


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("output", help="an OUT.h5 of coupler run or fmpy_master.py")
    p.add_argument("-o", "--dir", help="folder for the PNG files (default: beside the file)")
    args = p.parse_args(argv)
    outdir = args.dir or os.path.dirname(os.path.abspath(args.output))
    try:
        os.makedirs(outdir, exist_ok=True)
        written = plot(args.output, outdir)
    except (OSError, KeyError) as e:
        print(f"plot.py: {args.output}: {e}", file=sys.stderr)
        return 1
    for w in written:
        print(w)
    return 0


if __name__ == "__main__":
    sys.exit(main())
