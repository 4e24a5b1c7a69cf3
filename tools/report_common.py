"""report_common.py — what the sections of `make report` (tools/report.py) share: running
the programs, CSV, figures, and the free sphere settling in a periodic box that sections 1, 2
and 6 use.
"""
import concurrent.futures as cf
import csv
import math
import os
import subprocess
import time

import h5py
import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BUILD = os.path.join(ROOT, "build")
COUPLER = os.path.join(BUILD, "coupler")
SCHEMES = ["bounce_back", "yu", "cli", "quadratic", "multireflection"]
ONE_THREAD = dict(os.environ, OMP_NUM_THREADS="1")


# ---- small helpers -----------------------------------------------------------

def sh(cmd, env=None, check=True):
    """Runs cmd (a list); returns (CompletedProcess, seconds)."""
    t0 = time.monotonic()
    p = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, env=env)
    if check and p.returncode != 0:
        raise RuntimeError("%s failed (%d):\n%s" % (" ".join(map(str, cmd)), p.returncode, p.stderr[-2000:]))
    return p, time.monotonic() - t0


def read_csv(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def write_csv(path, rows, fields):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow(r)


def slope(x, y):
    """Least-squares slope of log y against log x (the fitted order), or nan."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = (x > 0) & (y > 0) & np.isfinite(x) & np.isfinite(y)
    if ok.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)[0])


def loglog(ax, xlabel, ylabel, title):
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", alpha=0.3)


def save(fig, out, name):
    fig.tight_layout()
    fig.savefig(os.path.join(out, name), dpi=110)
    plt.close(fig)
    return name


def pool_map(fn, items, jobs):
    with cf.ThreadPoolExecutor(max_workers=jobs) as ex:
        return list(ex.map(fn, items))


def settling_scene(a, tau, ratio=2.0, u_lat=0.004, t_diff=5.0, offset=0.3):
    """A free sphere settling at low Re in a periodic box of side L = 4a (D/L = 1/2), a counter
    body force on the fluid so that the whole does not accelerate, gravity set so that the
    settling velocity is about u_lat (lattice units). dx = 1 mm, water. Returns (text, numbers)."""
    dx, nu, rho = 1e-3, 1e-6, 1000.0
    L = 4 * a
    dt = (tau - 0.5) * dx * dx / (3 * nu)
    V, Lm = 4.0 / 3.0 * math.pi * (a * dx) ** 3, L * dx
    phi = V / Lm ** 3
    K = SA_K_HALF
    U = u_lat * dx / dt
    F_sa = 6 * math.pi * rho * nu * a * dx * U * K     # the array's drag per sphere (pressure part included)
    # the rigid component's gravity includes buoyancy: the net weight (ratio - 1) rho V g is carried
    # by the drag, W = F_sa (1 - phi) (the fluid's body force carries the rest of F_sa)
    g = F_sa * (1 - phi) / ((ratio - 1) * rho * V)
    fb = (ratio - 1) * rho * V * g / (Lm ** 3 - V)    # counter body force, N/m^3
    t_end = t_diff * Lm ** 2 / nu
    c = Lm / 2 + offset * dx
    text = """domain:
  size: [{L}, {L}, {L}]
fluid:
  density: {rho}
  viscosity: {nu}
  dx: {dx}
  tau: {tau}
  body_force: [0, 0, {fb}]
bodies:
  - density: {rho_p}
    spheres:
      - {{center: [{c}, {c2}, {c3}], radius: {a}}}
rigid:
  gravity: [0, 0, {g}]
run:
  end_time: {t_end}
  output_interval: {t_out}
""".format(L=Lm, rho=rho, nu=nu, dx=dx, tau=tau, fb=fb, rho_p=ratio * rho, c=c, c2=c + 0.17 * dx,
           c3=c - 0.11 * dx, a=a * dx, g=-g, t_end=t_end, t_out=t_end / 200)
    return text, dict(L=Lm, V=V, rho=rho, nu=nu, a=a * dx, fb=fb, dt=dt, dx=dx, U=U)


# Sangani & Acrivos (1982), simple cubic array, drag factor at D/L = 1/2 (chi = 0.5 in their
# series; the value tests/fluid/sangani_acrivos.h evaluates)
SA_K_HALF = 2.84202


def settling_k(h5, k, tail=0.2):
    """K/K_SA - 1 of a periodic settling run: K = |fb| L^3 / (6 pi mu a U), U the superficial
    velocity of the fluid relative to the sphere (flux definition of issue 11), averaged over the
    last `tail` of the rows."""
    with h5py.File(h5, "r") as f:
        t = f["time"][:]
        P = f["fluid/momentum"][:, 2]
        vp = f["spheres/velocity"][:, 0, 2]
    n0 = int(len(t) * (1 - tail))
    urel = (P[n0:] / k["rho"] - vp[n0:] * (k["L"] ** 3 - k["V"])) / k["L"] ** 3
    Kv = abs(k["fb"]) * k["L"] ** 3 / (6 * math.pi * k["rho"] * k["nu"] * k["a"] * abs(np.mean(urel)))
    return Kv / SA_K_HALF - 1.0


def run_sphere_report(item, tmp, tau, precision="double"):
    """`sphere_report KIND` (the drag of a fixed sphere or the torque of a rotating one, tests/fluid/
    drag_report.h) for item = (kind, scheme, collision, radii, positions) at one tau and storage
    precision, on one thread, in a folder of its own under tmp: the rows of its CSV."""
    kind, scheme, coll, radii, npos = item
    d = os.path.join(tmp, "%s_%s_%s_%s_tau%g_%s" % (kind, scheme, coll, "-".join(map(str, radii)), tau, precision))
    os.makedirs(d, exist_ok=True)
    sh([os.path.join(BUILD, "sphere_report"), kind, d, "schemes=" + scheme, "collisions=" + coll,
        "radii=" + ",".join(map(str, radii)), "taus=%g" % tau, "positions=%d" % npos, "precision=" + precision],
       env=ONE_THREAD)
    return read_csv(os.path.join(d, kind + ".csv"))


def run_scene(text, name, sets, tmp):
    """Writes the scene text to TMP/NAME.yaml and runs it on one thread with the --set options:
    (CompletedProcess, seconds, path of its output)."""
    base = os.path.join(tmp, name)
    with open(base + ".yaml", "w") as f:
        f.write(text)
    args = [COUPLER, "run", base + ".yaml", "-o", base + ".h5", "--quiet"] + [x for s in sets for x in ("--set", s)]
    p, secs = sh(args, env=ONE_THREAD, check=False)
    return p, secs, base + ".h5"
