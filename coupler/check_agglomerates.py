#!/usr/bin/env python3
"""check_agglomerates.py — checks and figures for the agglomerate scenes of issue 6.

    .venv/bin/python coupler/check_agglomerates.py OUT.h5 [-o DIR]

Picks the check from the scene of OUT.h5 (root attribute `scene_file`):
`channel_collision` -> check_channel_collision, `breakup_shear` -> check_breakup_shear,
`agglomerate_*` and `three_agglomerates` -> check_agglomerate. Prints the report,
writes PNG figures into DIR (default: beside OUT.h5) and exits 1 if a check fails
(2 if the file fits no check).

Every check returns (ok, lines) and starts with the sanity part:
  - every stored value finite (sphere kinematics and loads, connection loads, body
    totals, fluid totals);
  - the largest relative change of the fluid mass, max |m(t) - m(0)| / m(0) over the
    rows of /fluid/mass, at most MASS_BOUND[scene] (measured, see models/README.md).

The momentum balance of the free bodies (balance_at):
  The rows k-1, k one communication step h apart: the rigid step from t_{k-1} to t_k
  used the hydrodynamic loads stored in row k (load correction off in coupled runs;
  contacts between bodies and the connection loads are internal and cancel), so
      P_k - P_{k-1} = h sum_i F_i[k]                                      (exact)
      L_k - L_{k-1} = h sum_i (x_i^mid x F_i[k] + T_i[k])                 (2nd order)
  with P, L the totals of /bodies/momentum, /bodies/angular_momentum (about the
  world origin; from the sphere shares when the file has no /bodies), x^mid the
  mean of the sphere centres in rows k-1 and k. Break-up and fusion conserve P and
  L exactly, so the balance holds across the event too. Tolerances:
    - P: |dP - h sum F| <= P_TOL max|P| with P_TOL = 1e-12. Only round-off remains
      (measured 7e-16 |P| in ordinary steps); one step's impulse is ~1e-4 |P| here,
      and a fusion or break that lost or created momentum (e.g. kept the velocity of
      one body, or gave the fragments the centre-of-mass velocity without the
      rotation part) misses by ~|P| dv/v >> 1e-12 |P|.
    - L: |dL - h sum(x^mid x F + T)| <= L_TOL max|L| with L_TOL = 1e-5: the midpoint
      rule for the moving centres is second order (measured <= 4.4e-7 max|L| per step,
      largest in the first steps of a run from rest, 4e-9 in the collision); an event
      that does not conserve L (e.g. fused without the orbital term
      M_k (com_k - com) x (v_k - v)) misses by ~1e-2 |L|.
  A step in which a sphere touches a domain wall (external contact force, not in the
  file) is left out of the every-row balance and reported.

check_channel_collision(h5, outdir): two bodies at t0; exactly one fusion (body count
  2 -> 1); before it, the upstream body (behind in x) moves faster along the flow;
  after it, every sphere has the same body id and the two groups keep their relative
  position (rigid); the balance at the fusion row (and at every row).
check_breakup_shear(h5, outdir): one body at t0, at least two at the end; the time
  of the first break and the number of fragments; the body ids are the connected
  components of the intact connections (plus the unlisted touching pairs) in every
  row; no intact connection ever reports a load above its limit; the balance at
  every break row (and at every row).
check_agglomerate(h5, outdir): the scene's bodies stay whole (no limits) and keep
  their count; each turns about the vorticity axis y in the sense of the shear, with
  a mean angular velocity (second half of the run) in (0.3, 2) gamma/2 (a sphere
  turns at gamma/2; an elongated body between gamma/(p^2+1) and gamma p^2/(p^2+1)
  over its Jeffery orbit, aspect ratio p); the
  centre of mass stays within 2 sphere radii of its start across the flow.
  Figures like the paper's Fig. 9: 3D views at the start and the end, x-z
  projections over time, connection force magnitudes over time.
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

import h5out  # noqa: E402
from matplotlib.patches import Circle  # noqa: E402

P_TOL = 1e-12   # momentum balance, relative to |P|
L_TOL = 1e-5    # angular momentum balance, relative to max |L| over the run
# Largest relative fluid mass change max|m - m0|/m0, per scene: measured on the full run
# and on the short test versions (models/README.md "Scenes"), with a margin.
# The change follows the number of fluid cells as spheres cover and uncover cells; it grows
# with the distance the spheres travel relative to the grid. Measured: channel_collision
# 5.8e-5 (2 s) / 3.6e-5 (short); breakup_shear 2.0e-4 (3 s) / 3.9e-5 (short); agglomerate_16
# 1.4e-4 (1 s); agglomerate_32 1.0e-4 (0.5 s); agglomerate_64 see README; three_agglomerates
# 3.7e-5 (0.2 s).
MASS_BOUND = {
    "channel_collision": 1.5e-4,
    "breakup_shear": 4e-4,
    "agglomerate_16": 3e-4,
    "agglomerate_32": 3e-4,
    "agglomerate_64": 3e-4,
    "three_agglomerates": 3e-4,
}
# Mean angular velocity about the vorticity axis / (gamma/2): a rigid body in simple shear turns
# with the shear at a rate between gamma/(p^2+1) and gamma p^2/(p^2+1) (Jeffery 1922, aspect ratio
# p), i.e. in (0, 2) gamma/2; a sphere at 1. The lower end 0.3 allows p up to 2.4.
OMEGA_RANGE = (0.3, 2.0)
DRIFT_RADII = 2.0         # centre-of-mass drift across the flow, in sphere radii
# A developed start (initial_profile: plane_channel) puts the resting agglomerate at once into
# the moving fluid (an impulsive start: a load spike in the first steps); connection loads are
# also reported after this time.
STARTUP = 0.05


# ---------------------------------------------------------------------------------------------
# reading


def _text(attr):
    return h5out.text(attr)


def read(h5):
    """h5out.read plus the per-sphere radius, scene body and free flag, and the
    number of moving bodies from the body ids when the file has no /bodies."""
    d = h5out.read(h5)
    sc = d["scene"]
    bodies = sc.get("bodies") or []
    d["radius"] = np.array([s["radius"] for b in bodies for s in b["spheres"]], float)
    d["scene_body"] = np.array([k for k, b in enumerate(bodies) for _ in b["spheres"]], int)
    d["free"] = np.array([b.get("motion", "free") == "free" for b in bodies for _ in b["spheres"]], bool)
    if "nbodies" not in d and "body" in d:
        d["nbodies"] = np.array([len(np.unique(row[d["free"]])) for row in d["body"]])
    return d


SCENES = ("channel_collision", "breakup_shear", "three_agglomerates", "agglomerate_")


def scene_name(d):
    """The scene name (stem of `scene_file`) when it is one of ours, else None."""
    base = os.path.splitext(os.path.basename(d.get("scene_file", "")))[0]
    for name in SCENES:
        if base.startswith(name):
            return base if name == "agglomerate_" else name
    return None


def shear_rate(sc):
    """(gamma, wall axis) of a shear between z walls, or (0, None)."""
    faces = (sc.get("domain") or {}).get("faces") or {}
    size = (sc.get("domain") or {}).get("size")
    for a, ax in enumerate("xyz"):
        lo, hi = faces.get(f"{ax}_min") or {}, faces.get(f"{ax}_max") or {}
        if lo.get("type") == "moving_wall" and hi.get("type") == "moving_wall":
            du = np.array(hi["velocity"], float) - np.array(lo["velocity"], float)
            return float(np.linalg.norm(du) / size[a]), a
    return 0.0, None


# ---------------------------------------------------------------------------------------------
# sphere shares (fallback for files without /bodies) and groups


def shares(d):
    """Mass and centroid offset (world frame at t0) of each sphere's share of its scene body:
    the ball minus the caps beyond the radical planes with the overlapping spheres of the same
    scene body (exact when the caps are disjoint, as for the generated agglomerates)."""
    sc = d["scene"]
    dens = np.array([b["density"] for b in sc["bodies"] for _ in b["spheres"]], float)
    x0, r, sb = d["position"][0], d["radius"], d["scene_body"]
    n = len(r)
    vol = 4.0 / 3.0 * math.pi * r ** 3
    moment = np.zeros((n, 3))
    for i in range(n):
        for j in range(n):
            if i == j or sb[i] != sb[j]:
                continue
            e = x0[j] - x0[i]
            dist = np.linalg.norm(e)
            if dist >= r[i] + r[j]:
                continue
            a = (dist * dist + r[i] ** 2 - r[j] ** 2) / (2 * dist)   # radical plane from centre i
            hcap = r[i] - a
            vcap = math.pi * hcap * hcap * (3 * r[i] - hcap) / 3
            zbar = 3 * (2 * r[i] - hcap) ** 2 / (4 * (3 * r[i] - hcap))
            vol[i] -= vcap
            moment[i] -= vcap * zbar * e / dist
    return dens * vol, moment / vol[:, None]


def momentum(d):
    """Total momentum [n, 3] of the free bodies and where it comes from."""
    if "P" in d:
        return d["P"], "/bodies/momentum"
    m, off = shares(d)
    v = d["velocity"] + np.cross(d["angular_velocity"], off[None])   # offsets at t0 (short runs)
    return np.einsum("i,nij->nj", m * d["free"], v), "sphere shares (no /bodies in the file)"


def group_centroids(d, groups):
    """Mass-weighted centre and velocity [n, ngroups, 3] of the given sphere groups (index arrays)."""
    m, _ = shares(d)
    x, v = d["position"], d["velocity"]
    cx = np.stack([np.einsum("i,nij->nj", m[g], x[:, g]) / m[g].sum() for g in groups], axis=1)
    cv = np.stack([np.einsum("i,nij->nj", m[g], v[:, g]) / m[g].sum() for g in groups], axis=1)
    return cx, cv


def body_events(d):
    """Rows k where the number of free bodies changes: list of (k, before, after)."""
    nb = d["nbodies"]
    return [(k, int(nb[k - 1]), int(nb[k])) for k in range(1, len(nb)) if nb[k] != nb[k - 1]]


def wall_touch(d):
    """[n] bool: some sphere touches a domain wall (an external contact force) in the row."""
    sc = d["scene"]
    size = np.array(sc["domain"]["size"], float)
    faces = sc["domain"].get("faces") or {}
    x, r = d["position"], d["radius"]
    touch = np.zeros(len(d["t"]), bool)
    for a, ax in enumerate("xyz"):
        for side in ("min", "max"):
            if (faces.get(f"{ax}_{side}") or {}).get("type", "periodic") in ("no_slip", "moving_wall", "free_slip"):
                gap = x[:, :, a] - r if side == "min" else size[a] - x[:, :, a] - r
                touch |= np.any(gap <= 0, axis=1)
    return touch


# ---------------------------------------------------------------------------------------------
# momentum balance


def one_step_apart(d, k):
    h = d["h"]
    return k >= 1 and abs((d["t"][k] - d["t"][k - 1]) - h) <= 1e-6 * h


def balance_at(d, k, P=None):
    """Momentum and angular momentum balance over rows k-1 -> k (one communication step)."""
    if P is None:
        P, _ = momentum(d)
    h, F, T, x = d["h"], d["force"], d["torque"], d["position"]
    fr = d["free"]
    imp = h * F[k, fr].sum(axis=0)
    dP = P[k] - P[k - 1]
    rP = float(np.linalg.norm(dP - imp))
    sP = float(np.max(np.linalg.norm(P, axis=1)))   # the run's largest |P| (P may pass near 0)
    out = {"k": k, "t": float(d["t"][k]), "dP": dP, "impulse": imp, "resP": rP, "scaleP": sP,
           "okP": rP <= P_TOL * sP}
    if "L" in d:
        L = d["L"]
        xm = 0.5 * (x[k, fr] + x[k - 1, fr])
        ang = h * (np.cross(xm, F[k, fr]).sum(axis=0) + T[k, fr].sum(axis=0))
        dL = L[k] - L[k - 1]
        rL = float(np.linalg.norm(dL - ang))
        sL = float(np.max(np.linalg.norm(L, axis=1)))
        out.update({"dL": dL, "angimp": ang, "resL": rL, "scaleL": sL, "okL": rL <= L_TOL * sL})
    return out


def coarse_residuals(d, P):
    """For output rows m > 1 steps apart: |dP - m h (sum F_{k-1} + sum F_k)/2| / |P| for every
    interval k (trapezoid estimate of the impulse from the two stored loads; an estimate, not
    a balance). Returns an array [n] (nan where not defined)."""
    h, F, fr = d["h"], d["force"], d["free"]
    res = np.full(len(d["t"]), np.nan)
    for k in range(2, len(d["t"])):
        m = (d["t"][k] - d["t"][k - 1]) / h
        imp = m * h * 0.5 * (F[k - 1, fr].sum(axis=0) + F[k, fr].sum(axis=0))
        res[k] = np.linalg.norm(P[k] - P[k - 1] - imp) / max(np.linalg.norm(P[k]), np.linalg.norm(P[k - 1]))
    return res


def event_balance(d, k, P, what):
    """(ok, lines): the exact balance at an event row k when the rows are one step apart; else
    the trapezoid estimate, which cannot be exact: reported with the spread of the same estimate
    over the event-free intervals, and not failed (rerun with output every step to check)."""
    if one_step_apart(d, k):
        b = balance_at(d, k, P)
        return b["okP"] and b.get("okL", True), balance_lines(b, what)
    res = coarse_residuals(d, P)
    ev = {e[0] for e in body_events(d)}
    other = np.array([res[j] for j in range(2, len(res)) if j not in ev and np.isfinite(res[j])])
    m = (d["t"][k] - d["t"][k - 1]) / d["h"]
    lines = [f"  {what}: rows {k - 1}->{k} are {m:.0f} steps apart, so the balance is only estimated with the "
             f"trapezoid rule: residual {res[k]:.3g} |P|; the same estimate over the {len(other)} event-free "
             f"intervals: median {np.median(other):.3g}, max {np.max(other):.3g} |P| (not a pass/fail check: "
             f"rerun the event with run.output_interval <= fluid.dt for the exact balance)"]
    return True, lines


def balance_lines(b, what):
    lines = [f"  {what}: rows {b['k'] - 1}->{b['k']} (t = {b['t']:.6g} s): |dP| = {np.linalg.norm(b['dP']):.4g}, "
             f"|h sum F| = {np.linalg.norm(b['impulse']):.4g}, residual {b['resP']:.3g} kg m/s = "
             f"{b['resP'] / b['scaleP']:.3g} max|P| (tol {P_TOL:g}) {'ok' if b['okP'] else 'FAIL'}"]
    if "resL" in b:
        lines.append(f"  {'':{len(what)}}  |dL| = {np.linalg.norm(b['dL']):.4g}, |h sum(x x F + T)| = "
                     f"{np.linalg.norm(b['angimp']):.4g}, residual {b['resL']:.3g} = {b['resL'] / b['scaleL']:.3g} "
                     f"max|L| (tol {L_TOL:g}) {'ok' if b['okL'] else 'FAIL'}")
    return lines


def every_row_balance(d, P):
    """Balance over every pair of rows one step apart without wall contact: (ok, lines, rows, residuals)."""
    touch = wall_touch(d)
    rows = [k for k in range(2, len(d["t"])) if one_step_apart(d, k) and not touch[k] and not touch[k - 1]]
    skipped = sum(1 for k in range(2, len(d["t"])) if one_step_apart(d, k) and (touch[k] or touch[k - 1]))
    if not rows:
        return True, ["  every-row balance: no rows one communication step apart (output interval > h)"], [], []
    bs = [balance_at(d, k, P) for k in rows]
    wp = max(bs, key=lambda b: b["resP"] / b["scaleP"])
    ok = all(b["okP"] for b in bs)
    line = (f"  every-row balance over {len(rows)} steps: worst P residual {wp['resP'] / wp['scaleP']:.3g} max|P| "
            f"(t = {wp['t']:.5g} s)")
    if "resL" in wp:
        wl = max(bs, key=lambda b: b["resL"])
        ok = ok and all(b["okL"] for b in bs)
        line += f", worst L residual {wl['resL'] / wl['scaleL']:.3g} max|L| (t = {wl['t']:.5g} s)"
    if skipped:
        line += f"; {skipped} steps with a sphere touching a wall left out"
    return ok, [line + (" ok" if ok else " FAIL")], rows, bs


# ---------------------------------------------------------------------------------------------
# sanity


def sanity(d, name):
    lines, ok = [], True
    bad = [k for k in ("position", "velocity", "angular_velocity", "force", "torque", "cforce", "ctorque",
                       "P", "L", "fluid_mass", "fluid_momentum", "fluid_kinetic_energy")
           if k in d and not np.all(np.isfinite(d[k]))]
    if bad:
        ok = False
        lines.append(f"  non-finite values in {', '.join(bad)}: FAIL")
    else:
        lines.append(f"  all values finite over {len(d['t'])} rows, t = 0 .. {d['t'][-1]:.6g} s: ok")
    m = d.get("fluid_mass")
    if m is not None and len(m) >= 2:
        dm = float(np.max(np.abs(m - m[0])) / m[0])
        bound = MASS_BOUND.get(name, 2e-4)
        okm = dm <= bound
        ok = ok and okm
        lines.append(f"  fluid mass: max |m - m0|/m0 = {dm:.3g} (bound {bound:g}): {'ok' if okm else 'FAIL'}")
    return ok, lines


# ---------------------------------------------------------------------------------------------
# figures


_save = h5out.save


def _colors(ids):
    cmap = plt.get_cmap("tab10")
    uniq = {b: k for k, b in enumerate(sorted(set(int(i) for i in ids)))}
    return [cmap(uniq[int(i)] % 10) for i in ids]


def snapshot_xz(ax, d, k, xlim=None, title=None, unit=1e-3):
    """Sphere positions of row k projected on x-z, circles of the sphere radius, coloured by body."""
    x, r, ids = d["position"][k], d["radius"], d["body"][k]
    cols = _colors(ids)
    for i in np.argsort(x[:, 1]):   # back to front along y
        ax.add_patch(Circle((x[i, 0] / unit, x[i, 2] / unit), r[i] / unit, fc=cols[i], ec="k", lw=0.5, alpha=0.85))
    H = d["scene"]["domain"]["size"][2]
    if xlim is None:
        pad = 2 * r.max()
        xlim = ((x[:, 0].min() - pad) / unit, (x[:, 0].max() + pad) / unit)
    ax.set_xlim(*xlim)
    ax.set_ylim(0, H / unit)
    ax.axhline(0, color="k", lw=2)
    ax.axhline(H / unit, color="k", lw=2)
    ax.set_aspect("equal")
    ax.set(xlabel="x (mm)", ylabel="z (mm)", title=title or f"t = {d['t'][k]:.3g} s")


def connection_figure(d, path, written, events=()):
    if "cforce" not in d:
        return
    t, cf, intact, pair = d["t"], d["cforce"], d["intact"], d["pair"]
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.4))
    mag = np.linalg.norm(cf, axis=2)
    tq = np.linalg.norm(d["ctorque"], axis=2)
    kmax = int(np.argmax(mag.max(axis=0)))
    for k in range(cf.shape[1]):
        lw, lab = (1.6, f"{k}: spheres {pair[k][0]}-{pair[k][1]} (largest)") if k == kmax else (0.6, None)
        ax[0].plot(t, mag[:, k], lw=lw, label=lab)
        ax[1].plot(t, tq[:, k], lw=lw)
        broke = np.nonzero(intact[:, k] == 0)[0]
        if broke.size:
            ax[0].plot(t[broke[0]], 0, "rx")
    for te in events:
        for a in ax:
            a.axvline(te, color="r", ls=":", lw=0.8)
    ax[0].set(xlabel="t (s)", ylabel="|F_c| (N)", title=f"connection forces (Eq. 8), {cf.shape[1]} connections")
    ax[1].set(xlabel="t (s)", ylabel="|T_c| (N m)", title="connection torques (Eq. 9)")
    ax[0].legend(fontsize=8)
    _save(fig, path, written)


def fields_slice(d, path, written, t_want):
    """x-velocity in the y mid-plane of the field snapshot nearest t_want (if the run wrote fields)."""
    if not d["fields"]:
        return
    with h5py.File(d["path"], "r") as f:
        keys = d["fields"]
        times = [float(f[f"/fields/{k}/velocity"].attrs.get("time", np.nan)) if "time" in
                 f[f"/fields/{k}/velocity"].attrs else float(f[f"/fields/{k}"].attrs.get("time", np.nan))
                 for k in keys]
        k = keys[int(np.nanargmin(np.abs(np.array(times) - t_want)))]
        vel = f[f"/fields/{k}/velocity"]
        ny = vel.shape[1]
        u = vel[:, ny // 2, :, 0]
        flags = f[f"/fields/{k}/flags"][:, ny // 2, :]
    dx = d["dx"]
    fig, ax = plt.subplots(figsize=(10, 4))
    um = np.ma.masked_where(flags != 0, u)
    im = ax.imshow(um, origin="lower", extent=(0, u.shape[1] * dx * 1e3, 0, u.shape[0] * dx * 1e3), cmap="viridis")
    fig.colorbar(im, ax=ax, label="u_x (m/s)")
    ax.set(xlabel="x (mm)", ylabel="z (mm)", title=f"x-velocity, y mid-plane, field {k}")
    _save(fig, path, written)


def agglomerate_3d(ax, d, k, res=10):
    """Spheres of row k as shaded surfaces, coloured by body."""
    x, r, ids = d["position"][k], d["radius"], d["body"][k]
    cols = _colors(ids)
    u, v = np.mgrid[0:2 * np.pi:complex(0, 2 * res), 0:np.pi:complex(0, res)]
    unit = 1e-3
    for i in range(len(r)):
        ax.plot_surface((x[i, 0] + r[i] * np.cos(u) * np.sin(v)) / unit, (x[i, 1] + r[i] * np.sin(u) * np.sin(v)) / unit,
                        (x[i, 2] + r[i] * np.cos(v)) / unit, color=cols[i], shade=True, linewidth=0)
    c = x.mean(axis=0) / unit
    half = (np.max(np.abs(x - x.mean(axis=0))) + r.max()) / unit
    ax.set_xlim(c[0] - half, c[0] + half)
    ax.set_ylim(c[1] - half, c[1] + half)
    ax.set_zlim(c[2] - half, c[2] + half)
    ax.set_box_aspect((1, 1, 1))
    ax.set(xlabel="x (mm)", ylabel="y (mm)", zlabel="z (mm)", title=f"t = {d['t'][k]:.3g} s")


# ---------------------------------------------------------------------------------------------
# channel collision


def check_channel_collision(h5, outdir):
    d = read(h5)
    name = "channel_collision"
    lines = [f"channel_collision: {h5}"]
    ok, sl = sanity(d, name)
    lines += sl
    t, nb = d["t"], d["nbodies"]
    P, src = momentum(d)
    groups = [np.nonzero(d["scene_body"] == b)[0] for b in range(len(d["scene"]["bodies"]))]
    names = [b.get("name", f"body {k}") for k, b in enumerate(d["scene"]["bodies"])]
    cx, cv = group_centroids(d, groups)
    ev = body_events(d)
    lines.append(f"  bodies: {int(nb[0])} at t = 0, {int(nb[-1])} at t = {t[-1]:.6g} s; events {ev}")
    written = []
    fused = len(groups) == 2 and nb[0] == 2 and nb[-1] == 1 and len(ev) == 1 and ev[0][1:] == (2, 1)
    if not fused:
        ok = False
        lines.append("  expected exactly one fusion 2 -> 1: FAIL")
    kf = ev[0][0] if ev else len(t) - 1
    # who catches whom: the one behind at t0 (lower x) must be faster before the fusion
    behind = int(np.argmin(cx[0, :, 0]))
    ahead = 1 - behind
    pre = slice(1, kf) if kf > 1 else slice(0, 1)
    vb, va = float(cv[pre, behind, 0].mean()), float(cv[pre, ahead, 0].mean())
    okc = vb > va
    ok = ok and okc
    lines.append(f"  before the fusion: {names[behind]} (behind) mean u_x = {vb:.5g} m/s, {names[ahead]} (ahead) "
                 f"{va:.5g} m/s: the one behind is faster: {'ok' if okc else 'FAIL'}")
    if fused:
        tf = float(t[kf])
        x = d["position"]
        gap = np.min(np.linalg.norm(x[kf - 1][groups[0]][:, None] - x[kf - 1][groups[1]][None], axis=2)
                     - (d["radius"][groups[0]][:, None] + d["radius"][groups[1]][None]))
        lines.append(f"  fusion between rows {kf - 1} and {kf}: t = {t[kf - 1]:.6g} .. {tf:.6g} s; smallest gap in row "
                     f"{kf - 1}: {gap:.3g} m = {gap / d['dx']:.3g} cells; relative speed "
                     f"{np.linalg.norm(cv[kf - 1, 0] - cv[kf - 1, 1]):.4g} m/s")
        same = bool(np.all(d["body"][kf:][:, d["free"]] == d["body"][kf:, :1]))
        ok = ok and same
        lines.append(f"  after the fusion all spheres carry one body id: {'ok' if same else 'FAIL'}")
        rel = np.linalg.norm(cx[kf:, 0] - cx[kf:, 1], axis=1)
        drift = float(np.max(np.abs(rel - rel[0])) / rel[0])
        okr = drift < 1e-6
        ok = ok and okr
        lines.append(f"  after the fusion the two groups keep their distance (rigid): max relative change "
                     f"{drift:.3g} (tol 1e-6): {'ok' if okr else 'FAIL'}")
        lines.append(f"  momentum from {src}")
        okb, bl = event_balance(d, kf, P, "balance across the fusion")
        ok = ok and okb
        lines += bl
    okr_, rl, rows, bs = every_row_balance(d, P)
    ok = ok and okr_
    lines += rl
    # figures
    stem = os.path.join(outdir, os.path.splitext(os.path.basename(h5))[0])
    if fused:
        ks = sorted(set([0, max(kf // 2, 0), kf - 1, kf, min(kf + (len(t) - kf) // 2, len(t) - 1), len(t) - 1]))
    else:
        ks = sorted(set(np.linspace(0, len(t) - 1, 5).astype(int)))
    H = d["scene"]["domain"]["size"][2]
    ncol = 2
    nrow = (len(ks) + ncol - 1) // ncol
    fig, axes = plt.subplots(nrow, ncol, figsize=(13, 3.3 * nrow))
    axes = np.atleast_1d(axes).ravel()
    for ax, k in zip(axes, ks):
        tag = ""
        if fused:
            tag = " (last row before the fusion)" if k == kf - 1 else " (fusion)" if k == kf else ""
        xc = float(d["position"][k, :, 0].mean())
        snapshot_xz(ax, d, k, xlim=((xc - H) * 1e3, (xc + H) * 1e3),
                    title=f"t = {t[k]:.4g} s{tag}, {int(nb[k])} bodies")
    for ax in axes[len(ks):]:
        ax.axis("off")
    fig.suptitle("channel collision, x-z projection, coloured by body (cf. Fig. 10)")
    _save(fig, f"{stem}_snapshots.png", written)
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.2))
    for g in range(len(groups)):
        ax[0].plot(t, cv[:, g, 0], label=f"{names[g]} (spheres {groups[g][0]}-{groups[g][-1]})")
        ax[1].plot(t, cx[:, g, 2] * 1e3, label=names[g])
    mtot = shares(d)[0][d["free"]].sum()
    ax[0].plot(t, P[:, 0] / mtot, "k--", lw=0.8, label="all bodies: P_x / M")
    if fused:
        for a in ax:
            a.axvline(t[kf], color="r", ls=":", label="fusion")
    ax[0].set(xlabel="t (s)", ylabel="u_x of the group's centre of mass (m/s)", title="velocity of each agglomerate")
    ax[1].set(xlabel="t (s)", ylabel="z of the centre of mass (mm)", title="height in the channel")
    ax[0].legend(fontsize=8)
    ax[1].legend(fontsize=8)
    _save(fig, f"{stem}_velocity.png", written)
    connection_figure(d, f"{stem}_connections.png", written, [t[kf]] if fused else [])
    if rows:
        fig, ax = plt.subplots(figsize=(8, 3.6))
        ax.semilogy([b["t"] for b in bs], [max(b["resP"] / b["scaleP"], 1e-18) for b in bs], ".", ms=2, label="P")
        if "resL" in bs[0]:
            ax.semilogy([b["t"] for b in bs], [max(b["resL"] / b["scaleL"], 1e-18) for b in bs], ".", ms=2, label="L")
        ax.axhline(P_TOL, color="C0", ls="--", lw=0.8)
        ax.axhline(L_TOL, color="C1", ls="--", lw=0.8)
        if fused:
            ax.axvline(t[kf], color="r", ls=":")
        ax.set(xlabel="t (s)", ylabel="relative residual", title="momentum balance per step")
        ax.legend()
        _save(fig, f"{stem}_balance.png", written)
    fields_slice(d, f"{stem}_slice.png", written, t[kf])
    lines += [f"  figure {w}" for w in written]
    lines.append(f"channel_collision: {'PASS' if ok else 'FAIL'}")
    return ok, lines


# ---------------------------------------------------------------------------------------------
# break-up


def components(n, edges):
    """Connected components (label per node) of a graph with n nodes."""
    parent = list(range(n))

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for a, b in edges:
        ra, rb = find(int(a)), find(int(b))
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    return np.array([find(a) for a in range(n)])


def same_partition(a, b):
    """True if the labelings a and b split the nodes into the same groups."""
    pairs = set(zip(a.tolist(), b.tolist()))
    return len(pairs) == len(set(a.tolist())) == len(set(b.tolist()))


def implicit_bonds(d):
    """Touching or overlapping pairs of one scene body that are not listed as connections."""
    x0, r, sb = d["position"][0], d["radius"], d["scene_body"]
    listed = {tuple(sorted(map(int, p))) for p in d.get("pair", [])}
    out = []
    for i in range(len(r)):
        for j in range(i + 1, len(r)):
            if sb[i] == sb[j] and (i, j) not in listed and \
                    np.linalg.norm(x0[i] - x0[j]) <= (r[i] + r[j]) * (1 + 1e-9):
                out.append((i, j))
    return out


def limit_violations(d):
    """Largest ratio load/limit over every intact connection and row (normal tension, shear)."""
    conns = d["scene"].get("connections") or []
    x, cf, intact, pair = d["position"], d["cforce"], d["intact"], d["pair"]
    worst = (0.0, None)
    for k, c in enumerate(conns):
        a, b = pair[k]
        nvec = x[:, b] - x[:, a]
        nvec /= np.linalg.norm(nvec, axis=1)[:, None]
        fn = np.einsum("ij,ij->i", cf[:, k], nvec)
        fs = np.linalg.norm(cf[:, k] - fn[:, None] * nvec, axis=1)
        tq = np.linalg.norm(d["ctorque"][:, k], axis=1)
        for val, key in ((fn, "max_normal"), (fs, "max_shear"), (tq, "max_torque")):
            lim = float(c.get(key, math.inf))
            if lim > 0 and math.isfinite(lim):
                ratio = np.where(intact[:, k] == 1, val / lim, 0.0)
                j = int(np.argmax(ratio))
                if ratio[j] > worst[0]:
                    worst = (float(ratio[j]), (k, key, float(d["t"][j])))
    return worst


def check_breakup_shear(h5, outdir):
    d = read(h5)
    name = "breakup_shear"
    lines = [f"breakup_shear: {h5}"]
    ok, sl = sanity(d, name)
    lines += sl
    t, nb = d["t"], d["nbodies"]
    P, src = momentum(d)
    ev = body_events(d)
    written = []
    broke = bool(nb[0] == 1 and nb[-1] >= 2)
    ok = ok and broke
    lines.append(f"  bodies: {int(nb[0])} at t = 0, {int(nb[-1])} fragments at t = {t[-1]:.6g} s "
                 f"(expected 1 -> >= 2): {'ok' if broke else 'FAIL'}")
    kb = None
    if "intact" in d:
        nbroken = (d["intact"] == 0).sum(axis=1)
        first = np.nonzero(nbroken > 0)[0]
        if first.size:
            kb = int(first[0])
            lines.append(f"  first break between rows {kb - 1} and {kb}: t = {t[kb - 1]:.6g} .. {t[kb]:.6g} s; "
                         f"{int(nbroken[kb])} connection(s) broken then, {int(nbroken[-1])} of {len(d['pair'])} at the end")
    for k, before, after in ev:
        lines.append(f"    t = {t[k]:.6g} s: {before} -> {after} bodies")
    frag_sizes = sorted(np.unique(d["body"][-1][d["free"]], return_counts=True)[1].tolist(), reverse=True)
    lines.append(f"  fragments at the end (spheres each): {frag_sizes}")
    # body ids = components of intact connections + implicit bonds, every row
    imp = implicit_bonds(d)
    mism = []
    for k in range(len(t)):
        edges = [tuple(p) for p, on in zip(d["pair"], d["intact"][k]) if on] + imp
        if not same_partition(components(len(d["radius"]), edges), d["body"][k]):
            mism.append(k)
    okp = not mism
    ok = ok and okp
    lines.append(f"  bodies = connected components of the intact connections (+{len(imp)} unlisted touching pairs) in "
                 f"every row: {'ok' if okp else 'FAIL in rows ' + str(mism[:10])}")
    ratio, where = limit_violations(d)
    okl = ratio <= 1 + 1e-9
    ok = ok and okl
    lines.append(f"  largest load/limit of an intact connection: {ratio:.4g}"
                 + (f" (connection {where[0]}, {where[1]}, t = {where[2]:.6g} s)" if where else "")
                 + f" (<= 1): {'ok' if okl else 'FAIL'}")
    # a connection breaks in the step whose load exceeds its limit (that row holds the breaking
    # load when the rows are one step apart) and carries nothing afterwards
    okz, notes = True, []
    for c_k, c in enumerate(d["scene"].get("connections") or []):
        rows = np.nonzero(d["intact"][:, c_k] == 0)[0]
        if rows.size == 0:
            continue
        kb_ = int(rows[0])
        okz = okz and bool(np.all(d["intact"][kb_:, c_k] == 0) and np.all(d["cforce"][kb_ + 1:, c_k] == 0))
        if one_step_apart(d, kb_):
            a, b = d["pair"][c_k]
            nv = d["position"][kb_, b] - d["position"][kb_, a]
            nv /= np.linalg.norm(nv)
            F = d["cforce"][kb_, c_k]
            fn = float(F @ nv)
            fs = float(np.linalg.norm(F - fn * nv))
            exceeded = fn > float(c.get("max_normal", math.inf)) or fs > float(c.get("max_shear", math.inf))
            okz = okz and exceeded
            notes.append(f"connection {c_k} at t = {t[kb_]:.6g} s: tension {fn:.3g} N, shear {fs:.3g} N")
    ok = ok and okz
    lines.append(f"  broken connections stay broken and carry no load afterwards"
                 + (f"; breaking loads above the limits ({'; '.join(notes)})" if notes else "")
                 + f": {'ok' if okz else 'FAIL'}")
    lines.append(f"  momentum from {src}")
    for k, before, after in ev:
        okb, bl = event_balance(d, k, P, f"balance across {before}->{after}")
        ok = ok and okb
        lines += bl
    okr, rl, rows, bs = every_row_balance(d, P)
    ok = ok and okr
    lines += rl
    # figures
    stem = os.path.join(outdir, os.path.splitext(os.path.basename(h5))[0])
    k0 = kb if kb is not None else len(t) // 2
    ks = sorted(set([0, max(k0 - 1, 0), min(k0 + (len(t) - k0) // 3, len(t) - 1), len(t) - 1]))
    fig, axes = plt.subplots(1, len(ks), figsize=(4 * len(ks), 4.2))
    L = d["scene"]["domain"]["size"]
    for ax, k in zip(np.atleast_1d(axes), ks):
        snapshot_xz(ax, d, k, xlim=(0, L[0] * 1e3), title=f"t = {t[k]:.4g} s, {int(nb[k])} bodies")
    fig.suptitle("break-up in shear, x-z projection, coloured by body")
    _save(fig, f"{stem}_snapshots.png", written)
    connection_figure(d, f"{stem}_connections.png", written, [t[k] for k, *_ in ev])
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.2))
    ax[0].step(t, nb, where="post")
    ax[0].set(xlabel="t (s)", ylabel="number of bodies", title="fragments")
    ax[1].plot(t, np.linalg.norm(P, axis=1))
    ax[1].set(xlabel="t (s)", ylabel="|P| (kg m/s)", title="total momentum of the bodies")
    _save(fig, f"{stem}_fragments.png", written)
    lines += [f"  figure {w}" for w in written]
    lines.append(f"breakup_shear: {'PASS' if ok else 'FAIL'}")
    return ok, lines


# ---------------------------------------------------------------------------------------------
# agglomerates in shear (Fig. 9)


def check_agglomerate(h5, outdir):
    d = read(h5)
    name = scene_name(d) or "agglomerate"
    lines = [f"{name}: {h5}"]
    ok, sl = sanity(d, name)
    lines += sl
    t, nb = d["t"], d["nbodies"]
    nsb = len(d["scene"]["bodies"])
    written = []
    okn = bool(np.all(nb == nsb))
    ok = ok and okn
    lines.append(f"  bodies: {nsb} in the scene, count {int(nb.min())}..{int(nb.max())} over the run: "
                 f"{'ok' if okn else 'FAIL'}")
    if "intact" in d:
        okc = bool(np.all(d["intact"] == 1))
        ok = ok and okc
        mag = np.linalg.norm(d["cforce"], axis=2)
        k, c = np.unravel_index(int(np.argmax(mag)), mag.shape)
        lines.append(f"  {len(d['pair'])} connections, all intact: {'ok' if okc else 'FAIL'}; largest |F_c| = "
                     f"{mag[k, c]:.4g} N (connection {c}, spheres {d['pair'][c][0]}-{d['pair'][c][1]}, t = {t[k]:.4g} s)")
        late = t >= STARTUP
        if np.any(late):
            k2, c2 = np.unravel_index(int(np.argmax(mag[late])), mag[late].shape)
            lines.append(f"  largest |F_c| after the start-up (t >= {STARTUP:g} s): {mag[late][k2, c2]:.4g} N (connection "
                         f"{c2}, t = {t[late][k2]:.4g} s)")
    gamma, _ = shear_rate(d["scene"])
    groups = [np.nonzero(d["scene_body"] == b)[0] for b in range(nsb)]
    cx, cv = group_centroids(d, groups)
    half = t >= t[-1] / 2
    r = float(d["radius"].max())
    for g, idx in enumerate(groups):
        wy = d["angular_velocity"][:, idx[0], 1]
        ratio = float(wy[half].mean() / (gamma / 2)) if gamma > 0 else float("nan")
        okw = OMEGA_RANGE[0] < ratio < OMEGA_RANGE[1]
        drift = float(np.max(np.abs(cx[:, g, 2] - cx[0, g, 2])) / r)
        okd = drift <= DRIFT_RADII
        ok = ok and okw and okd
        lines.append(f"  body {g} ({len(idx)} spheres): mean w_y over t >= {t[-1] / 2:.3g} s = {wy[half].mean():.4g} "
                     f"rad/s = {ratio:.3f} gamma/2 (gamma = {gamma:.4g} 1/s; range {OMEGA_RANGE}): "
                     f"{'ok' if okw else 'FAIL'}; z drift of the centre of mass {drift:.3g} r "
                     f"(<= {DRIFT_RADII}): {'ok' if okd else 'FAIL'}")
    # figures (Fig. 9 analogue)
    stem = os.path.join(outdir, os.path.splitext(os.path.basename(h5))[0])
    fig = plt.figure(figsize=(11, 5))
    for j, k in enumerate((0, len(t) - 1)):
        ax = fig.add_subplot(1, 2, j + 1, projection="3d")
        agglomerate_3d(ax, d, k, res=8 if len(d["radius"]) > 40 else 12)
    fig.suptitle(f"{name}: {len(d['radius'])} spheres (cf. Iglberger et al. 2008, Fig. 9)")
    _save(fig, f"{stem}_3d.png", written)
    ks = np.linspace(0, len(t) - 1, 4).astype(int)
    L = d["scene"]["domain"]["size"]
    fig, axes = plt.subplots(1, 4, figsize=(16, 4.2 * L[2] / L[0] + 1))
    for ax, k in zip(axes, ks):
        snapshot_xz(ax, d, k, xlim=(0, L[0] * 1e3))
    fig.suptitle(f"{name}: x-z projection (walls at z = 0 and z = {L[2] * 1e3:.3g} mm move along -+x)")
    _save(fig, f"{stem}_snapshots.png", written)
    connection_figure(d, f"{stem}_connections.png", written)
    fig, ax = plt.subplots(figsize=(8, 3.8))
    for g, idx in enumerate(groups):
        ax.plot(t, d["angular_velocity"][:, idx[0], 1], label=f"body {g}")
    if gamma > 0:
        ax.axhline(gamma / 2, color="k", ls="--", label="gamma/2 (free sphere)")
    ax.set(xlabel="t (s)", ylabel="w_y (rad/s)", title="angular velocity about the vorticity axis")
    ax.legend(fontsize=8)
    _save(fig, f"{stem}_rotation.png", written)
    lines += [f"  figure {w}" for w in written]
    lines.append(f"{name}: {'PASS' if ok else 'FAIL'}")
    return ok, lines


CHECKS = {
    "channel_collision": check_channel_collision,
    "breakup_shear": check_breakup_shear,
    "three_agglomerates": check_agglomerate,
}


def check_for(name):
    if name is None:
        return None
    if name.startswith("agglomerate_"):
        return check_agglomerate
    return CHECKS.get(name)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("output", help="an OUT.h5 of coupler run")
    p.add_argument("-o", "--dir", help="folder for the PNG files (default: beside the file)")
    a = p.parse_args(argv)
    outdir = a.dir or os.path.dirname(os.path.abspath(a.output))
    try:
        d = read(a.output)
    except (OSError, KeyError) as e:
        print(f"check_agglomerates.py: {a.output}: {e}", file=sys.stderr)
        return 2
    fn = check_for(scene_name(d))
    if fn is None:
        print(f"check_agglomerates.py: {a.output}: scene {d.get('scene_file')!r} is none of "
              "channel_collision, breakup_shear, agglomerate_*, three_agglomerates", file=sys.stderr)
        return 2
    os.makedirs(outdir, exist_ok=True)
    ok, lines = fn(a.output, outdir)
    print("\n".join(lines))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
