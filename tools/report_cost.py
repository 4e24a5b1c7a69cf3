"""report_cost.py — section 5 of `make report`: the cost of a step of every scene in
models/, split into fluid, spheres, rigid, master and output.
"""
import os

import h5py
import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from report_common import COUPLER, ROOT, save, sh, write_csv  # noqa: E402


def section_cost(out, tmp, quick, jobs):
    scenes = sorted(f for f in os.listdir(os.path.join(ROOT, "models")) if f.endswith(".yaml"))
    steps = 20 if quick else 100
    rows = []
    for sc in scenes:
        path = os.path.join(ROOT, "models", sc)
        r = dict(scene=sc[:-5], steps=steps)
        for label, extra in (("coupled", []), ("fluid_only", ["--set", "bodies=[]", "--set", "connections=[]"])):
            base = os.path.join(tmp, "cost_%s_%s" % (sc[:-5], label))
            p, secs = sh([COUPLER, "run", path, "-o", base + ".h5", "--quiet", "--steps", steps, "--set",
                          "run.fields=false"] + extra, check=False)
            if p.returncode != 0:
                r[label] = "failed: " + (p.stderr.strip().splitlines() or ["?"])[-1][:120]
                continue
            with h5py.File(base + ".h5", "r") as f:
                a = {k: float(f.attrs[k]) for k in ("wall_time_fluid", "wall_time_rigid", "wall_time_master",
                                                     "wall_time_output", "wall_time_startup", "wall_time_total")}
                has_spheres = "spheres" in f
                grid = f.attrs["grid"]
                k_lbm = float(f.attrs["exchange_every"])
            r[label] = a
            r.setdefault("spheres", has_spheres)
            r["cells"] = int(np.prod(grid))
            r["lbm_steps"] = steps * k_lbm
        rows.append(r)
    table = []
    for r in rows:
        c, f = r.get("coupled"), r.get("fluid_only")
        if not isinstance(c, dict):
            table.append(dict(scene=r["scene"], status=c or "failed"))
            continue
        n = r["lbm_steps"]
        fl = f["wall_time_fluid"] / n if isinstance(f, dict) else float("nan")
        if not r["spheres"]:
            fl = c["wall_time_fluid"] / n
        table.append(dict(scene=r["scene"], status="ok", cells=r["cells"], lbm_steps=n,
                          fluid_ms=1e3 * fl, spheres_ms=1e3 * max(c["wall_time_fluid"] / n - fl, 0.0),
                          rigid_ms=1e3 * c["wall_time_rigid"] / n,
                          master_ms=1e3 * (c["wall_time_master"] - c["wall_time_output"] - c["wall_time_startup"]) / n,
                          output_ms=1e3 * c["wall_time_output"] / n,
                          total_ms=1e3 * (c["wall_time_total"] - c["wall_time_startup"]) / n,
                          startup_s=c["wall_time_startup"], mlups=r["cells"] * n / c["wall_time_fluid"] / 1e6))
    fields = ["scene", "status", "cells", "lbm_steps", "fluid_ms", "spheres_ms", "rigid_ms", "master_ms", "output_ms",
              "total_ms", "startup_s", "mlups"]
    write_csv(os.path.join(out, "cost.csv"), table, fields)
    ok = [t for t in table if t["status"] == "ok"]
    fig, ax = plt.subplots(figsize=(10, 4.8))
    bottom = np.zeros(len(ok))
    for key, lab in (("fluid_ms", "fluid"), ("spheres_ms", "spheres (links, fill, forces)"), ("rigid_ms", "rigid"),
                     ("master_ms", "master (exchange)"), ("output_ms", "output rows")):
        v = np.array([t[key] for t in ok])
        ax.bar(range(len(ok)), v, bottom=bottom, label=lab)
        bottom += v
    ax.set_xticks(range(len(ok)))
    ax.set_xticklabels([t["scene"] for t in ok], rotation=35, ha="right", fontsize=8)
    ax.set_yscale("log")
    ax.set_ylabel("wall time per LBM step (ms, log)")
    ax.set_title("cost of a step of each scene in models/ (%d steps, all threads)" % steps, fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(axis="y", alpha=0.3)
    fig_name = save(fig, out, "cost.png")
    lines = ["| scene | cells | fluid | spheres | rigid | master | output | total (ms/step) | start-up (s) | "
             "fluid MLUPS |", "|---|---|---|---|---|---|---|---|---|---|"]
    for t in table:
        if t["status"] != "ok":
            lines.append("| %s | %s | | | | | | | | |" % (t["scene"], t["status"]))
        else:
            lines.append("| %s | %d | %.2f | %.2f | %.3f | %.2f | %.2f | %.2f | %.2f | %.1f |" % (
                t["scene"], t["cells"], t["fluid_ms"], t["spheres_ms"], t["rigid_ms"], t["master_ms"], t["output_ms"],
                t["total_ms"], t["startup_s"], t["mlups"]))
    load = os.getloadavg()[0]
    md = """## 5. Cost of a step

![cost](cost.png)

Each scene of `models/` for {steps} communication steps (`coupler run SCENE --steps {steps} --set
run.fields=false`, all threads), once as it is and once with `bodies=[]` and `connections=[]`:
*fluid* is the fluid step without bodies, *spheres* the extra time of the fluid component with its
bodies (links, refill, forces), *rigid* the rigid component, *output* reading and writing the
output rows (the fluid totals included), *master* the rest of the stepping (the exchange of
inputs and outputs), per LBM step; the *start-up* (export, load, instantiate, initialise) once
per run, in seconds. *Spheres* is a difference of two runs and carries their noise.
Load average at the end: {load:.2f}. Data: `cost.csv`; `coupler bench` measures the pure fluid
against the machine's memory bandwidth.

{table}

**What to conclude.** A step costs what its cells cost: the fluid dominates every scene, the
sphere stages add a fraction that grows with the sphere surface, and the rigid component and
the output rows are small. Multiply the ms per step by the number of steps `coupler check`
prints to know what a run will cost before starting it.
""".format(steps=steps, load=load, table="\n".join(lines))
    return md, [fig_name]
