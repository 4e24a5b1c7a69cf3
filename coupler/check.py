#!/usr/bin/env python3
"""check.py — the checks and figures of the paper's scenes, for any output file.

    coupler/check.py OUT.h5 [-o DIR]

Reads the scene file name from the output's root attributes and runs that
scene's check (models/README.md, "Scenes"): it prints the report, writes the
scene's figures (PNG) into DIR (default: beside OUT.h5) and exits with 1 when
a check fails, 0 when all pass or when the scene has no check of its own
(coupler/plot.py draws the generic plots of every file).

  dual_star_shear          coupler/check_shear.py        check_dual_star
  sphere_in_shear          coupler/check_shear.py        check_sphere_in_shear
  channel_collision        coupler/check_agglomerates.py check_channel_collision
  breakup_shear            coupler/check_agglomerates.py check_breakup_shear
  agglomerate_16/32/64,
  three_agglomerates       coupler/check_agglomerates.py check_agglomerate

`make run SCENE=models/X.yaml` runs the scene, plot.py and this script.
"""
import argparse
import importlib
import os
import pathlib
import sys

import h5py

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

CHECKS = {
    "dual_star_shear": ("check_shear", "check_dual_star"),
    "sphere_in_shear": ("check_shear", "check_sphere_in_shear"),
    "channel_collision": ("check_agglomerates", "check_channel_collision"),
    "breakup_shear": ("check_agglomerates", "check_breakup_shear"),
    "agglomerate_16": ("check_agglomerates", "check_agglomerate"),
    "agglomerate_32": ("check_agglomerates", "check_agglomerate"),
    "agglomerate_64": ("check_agglomerates", "check_agglomerate"),
    "three_agglomerates": ("check_agglomerates", "check_agglomerate"),
}


def scene_of(path):
    with h5py.File(path, "r") as f:
        a = f.attrs.get("scene_file", b"")
    a = a.decode() if isinstance(a, bytes) else str(a)
    return pathlib.Path(a).stem


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("output")
    p.add_argument("-o", "--outdir")
    args = p.parse_args(argv)
    if not os.path.isfile(args.output):
        print(f"check.py: {args.output}: no such file", file=sys.stderr)
        return 2
    try:
        name = scene_of(args.output)
    except OSError as e:
        print(f"check.py: {args.output}: not an HDF5 output file ({e})", file=sys.stderr)
        return 2
    outdir = args.outdir or os.path.dirname(os.path.abspath(args.output))
    try:
        os.makedirs(outdir, exist_ok=True)
    except OSError as e:
        print(f"check.py: {outdir}: cannot create the figure folder ({e.strerror})", file=sys.stderr)
        return 2
    if name not in CHECKS:
        print(f"{args.output}: scene '{name}' has no scene check (see coupler/plot.py for its plots)")
        return 0
    module, func = CHECKS[name]
    ok, lines = getattr(importlib.import_module(module), func)(args.output, outdir)
    print(f"{args.output}: scene '{name}'")
    for line in lines:
        print("  " + line)
    print("  checks: " + ("all passed" if ok else "FAILED"))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
