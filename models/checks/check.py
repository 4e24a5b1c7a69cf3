#!/usr/bin/env python3
"""check.py — the checks and figures of the paper's scenes, for any output file.

    .venv/bin/python models/checks/check.py OUT.h5 [-o DIR]

Reads the scene file name from the output's root attributes and runs that
scene's check (models/README.md, "Scenes"): it prints the report, writes the
scene's figures (PNG) into DIR (default: beside OUT.h5) and exits with 1 when
a check fails, 0 when all pass or when the scene has no check of its own
(coupler/plot.py draws the generic plots of every file), 2 when the file
cannot be read. A scene file whose name starts with a scene's name (a copy
such as dual_star_shear_long.yaml) gets that scene's check; an output without
the scene file's name, a shear scene recognised by its shape (shear.py).

  dual_star_shear          shear.py                  check_dual_star
  sphere_in_shear          shear.py                  check_sphere_in_shear
  channel_collision        channel_collision.py      check_channel_collision
  breakup_shear            breakup_shear.py          check_breakup_shear
  agglomerate_16/32/64,
  three_agglomerates       agglomerates_in_shear.py  check_agglomerate

The shared parts of the last three are in agglo.py. `make run SCENE=models/X.yaml`
runs the scene, coupler/plot.py and this script.
"""
import argparse
import importlib
import os
import pathlib
import sys

import h5py

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

# (prefix of the scene file's stem, module, check), the first match wins
CHECKS = (
    ("dual_star_shear", "shear", "check_dual_star"),
    ("sphere_in_shear", "shear", "check_sphere_in_shear"),
    ("channel_collision", "channel_collision", "check_channel_collision"),
    ("breakup_shear", "breakup_shear", "check_breakup_shear"),
    ("agglomerate_", "agglomerates_in_shear", "check_agglomerate"),
    ("three_agglomerates", "agglomerates_in_shear", "check_agglomerate"),
)


def check_for(name, path):
    """(module, function) of the check for scene `name` of output `path`, or None."""
    for prefix, module, func in CHECKS:
        if name.startswith(prefix):
            return module, func
    if not name:
        shear = importlib.import_module("shear")
        by_shape = shear.scene_name(shear.read(path))
        if by_shape is not None:
            return "shear", "check_" + ("dual_star" if by_shape == "dual_star_shear" else by_shape)
    return None


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
    try:
        found = check_for(name, args.output)
        if found is None:
            print(f"{args.output}: scene '{name}' has no scene check (see coupler/plot.py for its plots)")
            return 0
        module, func = found
        ok, lines = getattr(importlib.import_module(module), func)(args.output, outdir)
    except (OSError, KeyError, ValueError) as e:
        # a file cut short or written by something else: a dataset or attribute the check needs is missing
        print(f"check.py: {args.output}: cannot be checked as scene '{name}' ({type(e).__name__}: {e})",
              file=sys.stderr)
        return 2
    print(f"{args.output}: scene '{name}'")
    for line in lines:
        print("  " + line)
    print("  checks: " + ("all passed" if ok else "FAILED"))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
