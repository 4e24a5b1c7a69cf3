"""agglo.py — what the checks of the agglomerate scenes share (check.py picks the check):
reading an output, the sanity part, the momentum balance of the free bodies, and the
figures (x-z snapshots, 3D views, connection loads, a field slice).

Every check returns (ok, lines) and starts with the sanity part:
  - every stored value finite (sphere kinematics and loads, connection loads, body
    totals, fluid totals);
  - the largest relative change of the fluid mass, max |m(t) - m(0)| / m(0) over the
    rows of /fluid/mass, at most MASS_BOUND[scene] (measured, see models/README.md).

The momentum balance of the free bodies (balance_at):
  The rows k-1, k one communication step h apart: the rigid step from t_{k-1} to t_k
  used the hydrodynamic loads stored in row k (load correction off in coupled runs;
  contacts between bodies and the connection loads are internal and cancel; not the
  torques about the origin of a contact across a periodic face, whose two points lie a
  period L e apart: L then changes by L e x J with J the contact's impulse, physics of
  the periodic box, not an error, and this balance does not hold for such a step), so
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
"""
import math
import os
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import h5py  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Circle  # noqa: E402

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "coupler"))
import h5out  # noqa: E402

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


def begin(h5, name=None):
    """What every check starts with: the data of output h5, its scene name (name, else the
    scene's own), and the sanity part: (d, name, ok, report lines)."""
    d = read(h5)
    name = name or scene_name(d) or "agglomerate"
    ok, lines = sanity(d, name)
    return d, name, ok, [f"{name}: {h5}"] + lines


# ---------------------------------------------------------------------------------------------
# figures


save = h5out.save


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
    save(fig, path, written)


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
    save(fig, path, written)


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
