"""report_precision.py — section 6 of `make report`: single against double precision storage
(`fluid.precision`, issue 12): what the halved memory costs in drag and settling accuracy.

Single precision stores f_q - w_q as a float (the arithmetic stays in double, README "Speed and
memory"). Its error is round-off of the stored deviations, so it is measured as the difference
to the same run in double, next to the discretisation error of that run (the drag against
Sangani & Acrivos), which is what a user compares it with.
"""
import os
import re

import h5py
import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from report_common import (COUPLER, ONE_THREAD, ROOT, SA_K_HALF, pool_map, run_scene, run_sphere_report, save,
                           settling_k, settling_scene, sh, write_csv)

PRECISIONS = ("double", "single")


def drag_runs(tmp, npos, jobs):
    """The steady drag of a fixed sphere (radius 4, tau 1, cli, TRT) at npos places in the cell,
    in both precisions: {precision: rows of sphere_report's drag.csv}."""
    def one(prec):
        return run_sphere_report(("drag", "cli", "trt", [4], npos), tmp, 1.0, prec)
    return dict(zip(PRECISIONS, pool_map(one, PRECISIONS, jobs)))


def settling_runs(tmp, radii, jobs):
    """A free sphere settling in a periodic box (section 1's scene, tau 1, cli) in both precisions."""
    def one(item):
        a, prec = item
        text, k = settling_scene(a, 1.0)
        p, secs, h5 = run_scene(text, "precision_settle_%g_%s" % (a, prec),
                                ["fluid.boundary_scheme=cli", "fluid.precision=" + prec], tmp)
        if p.returncode != 0:
            return dict(radius=a, precision=prec, err=float("nan"), seconds=secs, w=float("nan"))
        with h5py.File(h5, "r") as f:
            w = f["spheres/velocity"][:, 0, 2]
        n0 = int(len(w) * 0.8)
        return dict(radius=a, precision=prec, err=settling_k(h5, k), seconds=secs, w=float(np.mean(w[n0:])))
    items = [(a, p) for a in radii for p in PRECISIONS]
    return pool_map(one, items, jobs)


def sinking_runs(tmp, end_time, jobs):
    """The paper's sinking sphere (models/sinking_sphere.yaml) in both precisions: its velocity
    history, terminal velocity (mean over the last 20 % of the rows) and run time."""
    def one(prec):
        base = os.path.join(tmp, "precision_sink_" + prec)
        p, secs = sh([COUPLER, "run", os.path.join(ROOT, "models", "sinking_sphere.yaml"), "-o", base + ".h5",
                      "--set", "run.fields=false", "--set", "run.end_time=%g" % end_time, "--set",
                      "fluid.precision=" + prec], env=ONE_THREAD, check=False)
        if p.returncode != 0:
            raise RuntimeError("sinking sphere in %s precision failed: %s" % (prec, p.stderr.strip()[-500:]))
        with h5py.File(base + ".h5", "r") as f:
            t, w = f["time"][:], f["spheres/velocity"][:, 0, 2]
        # the summary's terminal velocity, to all digits: the mean over the last 20 % of the rows
        terminal = float(-np.mean(w[int(0.8 * len(w)):]))
        return dict(precision=prec, t=t, w=w, terminal=terminal, seconds=secs)
    return dict(zip(PRECISIONS, pool_map(one, PRECISIONS, jobs)))


def memory_rows():
    """Bytes of the three_agglomerates scene per precision, from `coupler check`."""
    rows = []
    for prec in PRECISIONS:
        p, _ = sh([COUPLER, "check", os.path.join(ROOT, "models", "three_agglomerates.yaml"), "--set",
                   "fluid.precision=" + prec], check=False)
        m = re.search(r"memory\s+([0-9.]+) MB .*?([0-9.]+) per interior cell", p.stdout)
        rows.append(dict(precision=prec, mb=float(m.group(1)) if m else float("nan"),
                         bytes_per_cell=float(m.group(2)) if m else float("nan")))
    return rows


def section_precision(out, tmp, quick, jobs):
    npos = 3 if quick else 8
    drag = drag_runs(tmp, npos, jobs)
    settle = settling_runs(tmp, [4] if quick else [4, 6], jobs)
    sink = sinking_runs(tmp, 0.02 if quick else 0.06, jobs)
    mem = memory_rows()

    # drag: per place, each precision against Sangani & Acrivos and single against double
    rows = []
    for rd, rs in zip(drag["double"], drag["single"]):
        ed, es = float(rd["err_flux"]), float(rs["err_flux"])
        rows.append(dict(position=int(rd["position"]), err_double=ed, err_single=es,
                         single_vs_double=(1 + es) / (1 + ed) - 1, steps_double=int(rd["steps"]),
                         steps_single=int(rs["steps"]), seconds_double=float(rd["seconds"]),
                         seconds_single=float(rs["seconds"])))
    write_csv(os.path.join(out, "precision_drag.csv"), rows, list(rows[0].keys()))
    write_csv(os.path.join(out, "precision_settling.csv"), settle, ["radius", "precision", "err", "w", "seconds"])
    write_csv(os.path.join(out, "precision_memory.csv"), mem, ["precision", "mb", "bytes_per_cell"])
    d, s = sink["double"], sink["single"]
    n = min(len(d["w"]), len(s["w"]))
    rel = np.abs(s["w"][:n] - d["w"][:n]) / np.max(np.abs(d["w"][:n]))
    write_csv(os.path.join(out, "precision_sinking.csv"),
              [dict(t=float(t), w_double=float(a), w_single=float(b)) for t, a, b in zip(d["t"][:n], d["w"][:n],
                                                                                      s["w"][:n])],
              ["t", "w_double", "w_single"])

    fig, axs = plt.subplots(1, 2, figsize=(12, 4.4))
    x = [r["position"] for r in rows]
    axs[0].plot(x, [100 * r["err_double"] for r in rows], "o-", label="double against Sangani & Acrivos")
    axs[0].plot(x, [100 * r["err_single"] for r in rows], "x--", label="single against Sangani & Acrivos")
    axs[0].set(xlabel="place of the centre in the cell (index)", ylabel="drag error (%)",
               title="fixed sphere, radius 4, τ 1, cli")
    ax2 = axs[0].twinx()
    # equal values (the CSV keeps 17 digits) sit on the axis floor, 1e-16
    ax2.semilogy(x, [max(abs(r["single_vs_double"]), 1e-16) for r in rows], "s:", color="gray")
    ax2.set_ylim(1e-16 / 2, None)
    ax2.set_ylabel("|K_single / K_double − 1| (gray squares; 1e-16: equal)")
    axs[0].legend(fontsize=8, loc="lower left")
    axs[1].plot(d["t"][:n], -d["w"][:n] * 1e3, label="double")
    axs[1].plot(s["t"][:n], -s["w"][:n] * 1e3, "--", label="single")
    axs[1].set(xlabel="t (s)", ylabel="settling velocity (mm/s)", title="the paper's sinking sphere (Fig. 6)")
    ax3 = axs[1].twinx()
    ax3.semilogy(d["t"][:n], np.maximum(rel, 1e-16), ":", color="gray")
    ax3.set_ylabel("|w_single − w_double| / max |w_double| (gray)")
    axs[1].legend(fontsize=8, loc="center right")
    fig.tight_layout()
    figs = [save(fig, out, "precision.png")]

    worst_sd = max(abs(r["single_vs_double"]) for r in rows)
    worst_disc = max(abs(r["err_double"]) for r in rows)
    steps_ratio = [r["steps_single"] / r["steps_double"] for r in rows]
    drag_lines = ["| place | double vs S&A | single vs S&A | single / double − 1 | steps double / single | "
                  "s double / single |", "|---|---|---|---|---|---|"]
    drag_lines += ["| %d | %+.4f %% | %+.4f %% | %.1e | %d / %d | %.1f / %.1f |" % (
        r["position"], 100 * r["err_double"], 100 * r["err_single"], r["single_vs_double"], r["steps_double"],
        r["steps_single"], r["seconds_double"], r["seconds_single"]) for r in rows]
    set_lines = ["| radius | precision | K/K_SA − 1 | mean settling velocity (m/s) | s/run |", "|---|---|---|---|---|"]
    set_lines += ["| %g | %s | %+.4f %% | %.6e | %.1f |" % (r["radius"], r["precision"], 100 * r["err"], r["w"],
                                                             r["seconds"]) for r in settle]
    settle_diff = []
    for a in sorted({r["radius"] for r in settle}):
        pr = {r["precision"]: r for r in settle if r["radius"] == a}
        settle_diff.append((a, abs((1 + pr["single"]["err"]) / (1 + pr["double"]["err"]) - 1),
                            abs(pr["single"]["w"] / pr["double"]["w"] - 1)))
    mem_lines = ["| precision | memory | bytes per interior cell |", "|---|---|---|"]
    mem_lines += ["| %s | %.1f MB | %.1f |" % (r["precision"], r["mb"], r["bytes_per_cell"]) for r in mem]
    term = abs(s["terminal"] / d["terminal"] - 1)
    conclude = (
        "Single precision halves the populations' memory (three_agglomerates %.1f → %.1f MB). Its drag "
        "differs from double's by at most %.1e (relative) over %d places, %s the discretisation error of the "
        "same runs (up to %.2f %% against Sangani & Acrivos); the settling box's K by at most %.1e and its "
        "settling velocity by %.1e; the sinking sphere's terminal velocity by %.1e (largest difference over "
        "the run %.1e of the peak). The cost: the steady state, detected by the drag's change per step, "
        "took %.2f to %.2f times the steps in single (float round-off is the floor of that change); the "
        "sinking sphere's wall time in single was %.2f times double's (one thread; the arithmetic is in "
        "double either way, single moves half the bytes)."
        % (mem[0]["mb"], mem[1]["mb"], worst_sd, len(rows),
           "orders of magnitude below" if worst_sd < 0.01 * worst_disc else "not far below", 100 * worst_disc,
           max(x[1] for x in settle_diff), max(x[2] for x in settle_diff), term, float(np.max(rel)),
           min(steps_ratio), max(steps_ratio), s["seconds"] / d["seconds"]))
    md = """## 6. Single against double precision storage

![precision](precision.png)

`fluid.precision: single` stores each population as f_q − w_q in a float (issue 12). *Left:* the
steady drag of a fixed sphere (radius 4, τ 1, cli, TRT, a simple cubic array at D/L = 1/2) at
{npos} places in the cell, each precision against Sangani & Acrivos (K = {ksa}), and single against
double (gray, right axis). *Right:* the paper's sinking sphere (`models/sinking_sphere.yaml`,
{tend:g} s) in both precisions and their difference. One thread each. Data:
`precision_drag.csv`, `precision_settling.csv`, `precision_sinking.csv`, `precision_memory.csv`.

### Drag of a fixed sphere
{drag}

### Free sphere settling in a periodic box (section 1's scene, cli, τ 1)
{settle}

### The sinking sphere
Terminal velocity (mean over the last 20 % of the run): double {td:.9e} m/s, single {ts:.9e} m/s
(relative difference {term:.1e}); run time {sd:.1f} s in double, {ss:.1f} s in single.

### Memory (`coupler check models/three_agglomerates.yaml`)
{mem}

**What to conclude.** {conclude}
""".format(npos=npos, ksa=SA_K_HALF, tend=0.02 if quick else 0.06, drag="\n".join(drag_lines),
           settle="\n".join(set_lines), td=d["terminal"], ts=s["terminal"], term=term, sd=d["seconds"],
           ss=s["seconds"], mem="\n".join(mem_lines), conclude=conclude)
    return md, figs
