"""shear.py — the checks and figures of the shear scenes (check.py picks the check).

check_dual_star(h5, outdir) -> (ok, lines)
    The paper's dual star (Iglberger, Thuerey & Ruede 2008, Fig. 7/8) in simple
    shear. The two connections of the central sphere c, (c, l) and (c, r) with l
    left and r right of c along the flow, carry the force on the section holding
    c (Eq. 8). The scene is symmetric under the half turn about the vorticity
    axis y through the domain centre, R = diag(-1, 1, -1), which maps one
    section onto the other, so F_r = R F_l: the x and z components are opposite,
    the y components equal, and y is zero by the mirror symmetry y -> -y. Checks:
      - |F_l + F_r| <= 1e-6 |F_l| in every row (the forces are each other's
        negative; with y ~ 0 this is the full vector);
      - |F_y| <= 1e-6 |F| in every row, both connections;
      - the angular velocity of the star is about y (|w_x|, |w_z| <= 1e-6 |w_y|)
        and the rotation angle of the arm grows monotonically (positive about
        +y for u_x increasing with z);
      - F_x and F_z fitted by least squares with c + A sin(2 pi t / P + phi)
        (P scanned, then refined): amplitude, period and the rms residual are
        reported; the fit passes when the rms residual is below 5% of A.
    It reports the maximum force norm next to the paper's 7.00557e-7 N.

check_sphere_in_shear(h5, outdir) -> (ok, lines)
    One free sphere in simple shear turns at half the shear rate (Stokes flow,
    Re = gamma a^2 / nu << 1): the steady angular velocity (mean of the last
    20% of the run) along the vorticity axis must be gamma/2 within 1%, the
    other components negligible, and the sphere must stay at its place.

Both also report the relative change of the fluid mass (/fluid/mass) and fail
on any non-finite value.
"""
import math
import os
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "coupler"))
import h5out  # noqa: E402

PAPER_MAX_FORCE = 7.00557e-7  # N, Iglberger, Thuerey & Ruede (2008), Section 5, Fig. 8
SYM_TOL = 1e-6        # relative: antisymmetry of the central connections, y components, off-axis rotation
FIT_RESIDUAL = 0.05   # rms residual of the sinusoid fit relative to its amplitude
ROT_TOL = 0.01        # sphere in shear: |w/(gamma/2) - 1|


# ---------------------------------------------------------------------------------------------
# reading


def _text(attr):
    return h5out.text(attr)


read = h5out.read


def scene_name(d):
    """`dual_star_shear`, `sphere_in_shear` or None, from the scene file name, else the scene."""
    base = os.path.splitext(os.path.basename(d.get("scene_file", "")))[0]
    for name in ("dual_star_shear", "sphere_in_shear"):
        if base.startswith(name):
            return name
    sc = d.get("scene") or {}
    bodies = sc.get("bodies") or []
    ns = sum(len(b.get("spheres", [])) for b in bodies)
    if shear_flow(sc) is None:
        return None
    if len(bodies) == 1 and ns == 13 and len(sc.get("connections") or []) == 12:
        return "dual_star_shear"
    if len(bodies) == 1 and ns == 1:
        return "sphere_in_shear"
    return None


def shear_flow(sc):
    """(gamma, n, e, w) of a simple shear between two walls: shear rate (1/s), wall normal axis
    n, flow direction e and the unit vorticity axis n x e (the fluid vorticity is gamma n x e,
    a free sphere turns at gamma/2 about it). None if the scene is not a shear between walls."""
    faces = (sc.get("domain") or {}).get("faces") or {}
    size = (sc.get("domain") or {}).get("size")
    for a, ax in enumerate("xyz"):
        lo, hi = faces.get(f"{ax}_min") or {}, faces.get(f"{ax}_max") or {}
        walls = ("moving_wall", "no_slip")
        if lo.get("type") in walls and hi.get("type") in walls:
            ulo = np.array(lo.get("velocity", [0, 0, 0]), float)
            uhi = np.array(hi.get("velocity", [0, 0, 0]), float)
            du = uhi - ulo
            if not np.any(du):
                return None
            gamma = np.linalg.norm(du) / float(size[a])
            n = np.zeros(3)
            n[a] = 1.0
            e = du / np.linalg.norm(du)
            return gamma, n, e, np.cross(n, e)
    return None


def mass_change(d):
    m = d.get("mass")
    if m is None or len(m) < 2:
        return float("nan")
    return float(np.max(np.abs(m - m[0])) / m[0])


# ---------------------------------------------------------------------------------------------
# sinusoid fit


def _lsq_fixed_period(t, y, period):
    w = 2 * math.pi / period
    A = np.column_stack([np.ones_like(t), np.sin(w * t), np.cos(w * t)])
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    r = y - A @ coef
    return float(r @ r), coef


def fit_sinusoid(t, y, pmin, pmax):
    """Least-squares fit y ~ c + A sin(2 pi t / P + phi) with P in [pmin, pmax]: a log scan of P
    (linear least squares for c, A, phi at each P), then golden-section refinement around the best.
    Returns dict(amplitude, period, phase, offset, rms, rel_rms, at_bound, model)."""
    t = np.asarray(t, float)
    y = np.asarray(y, float)
    grid = np.geomspace(pmin, pmax, 400)
    ssr = np.array([_lsq_fixed_period(t, y, p)[0] for p in grid])
    k = int(np.argmin(ssr))
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
    g = (math.sqrt(5) - 1) / 2
    a, b = math.log(lo), math.log(hi)
    c1, c2 = b - g * (b - a), a + g * (b - a)
    f1, f2 = _lsq_fixed_period(t, y, math.exp(c1))[0], _lsq_fixed_period(t, y, math.exp(c2))[0]
    for _ in range(80):
        if f1 < f2:
            b, c2, f2 = c2, c1, f1
            c1 = b - g * (b - a)
            f1 = _lsq_fixed_period(t, y, math.exp(c1))[0]
        else:
            a, c1, f1 = c1, c2, f2
            c2 = a + g * (b - a)
            f2 = _lsq_fixed_period(t, y, math.exp(c2))[0]
    period = math.exp((a + b) / 2)
    s, coef = _lsq_fixed_period(t, y, period)
    off, cs, cc = coef
    amp = math.hypot(cs, cc)
    phase = math.atan2(cc, cs)
    rms = math.sqrt(s / len(t))
    w = 2 * math.pi / period
    return {"amplitude": amp, "period": period, "phase": phase, "offset": float(off), "rms": rms,
            "rel_rms": rms / amp if amp > 0 else float("inf"),
            "at_bound": k in (0, len(grid) - 1),
            "model": lambda tt: off + amp * np.sin(w * np.asarray(tt) + phase)}


# ---------------------------------------------------------------------------------------------
# dual star


def central_connections(d):
    """(c, kl, kr): the central sphere (nearest the agglomerate centroid at t0) and the indices of
    its connections to the left and right neighbour along the flow direction."""
    pos0 = d["position"][0]
    sc = d["scene"]
    _, _, e, _ = shear_flow(sc)
    c = int(np.argmin(np.linalg.norm(pos0 - pos0.mean(axis=0), axis=1)))
    ks = [k for k, (a, b) in enumerate(d["pair"]) if c in (a, b)]
    if len(ks) != 2:
        raise ValueError(f"central sphere {c} has {len(ks)} connections, expected 2")
    other = [int(d["pair"][k][1] if d["pair"][k][0] == c else d["pair"][k][0]) for k in ks]
    side = [float((pos0[o] - pos0[c]) @ e) for o in other]
    kl, kr = (ks[0], ks[1]) if side[0] < side[1] else (ks[1], ks[0])
    for k in (kl, kr):
        if d["pair"][k][0] != c:
            raise ValueError(f"connection {k} {tuple(d['pair'][k])}: the central sphere {c} must be "
                             "its first sphere (the force is on the section holding the first)")
    return c, kl, kr


def rotation_angle(d, c, other, n, e, w):
    """Angle (rad) of the arm c -> other in the plane (e, n), positive about +w (the sense of the
    vorticity), unwrapped, from its direction at t0."""
    rel = d["position"][:, other] - d["position"][:, c]
    # rotation about +w turns e towards -n (for w = n x e)
    ang = np.unwrap(np.arctan2(-(rel @ n), rel @ e))
    return ang - ang[0]


class _Report:
    """The lines of a check report; check() adds a pass/fail line, and ok stays
    False once anything failed."""

    def __init__(self):
        self.lines, self.ok = [], True

    def check(self, cond, text):
        self.ok = self.ok and bool(cond)
        self.lines.append(f"  [{'ok' if cond else 'FAIL'}] {text}")


def check_dual_star(h5, outdir):
    d = read(h5)
    rep = _Report()
    lines, check = rep.lines, rep.check

    sc = d["scene"]
    sf = shear_flow(sc)
    if sf is None or "cforce" not in d:
        return False, ["dual star: the file holds no shear flow between walls or no connections"]
    gamma, n, e, w = sf
    t = d["t"]
    c, kl, kr = central_connections(d)
    Fl, Fr = d["cforce"][:, kl], d["cforce"][:, kr]
    Tl, Tr = d["ctorque"][:, kl], d["ctorque"][:, kr]
    lines.append(f"dual star in shear: {h5}")
    lines.append(f"  {len(t)} rows to t = {t[-1]:.6g} s; shear rate {gamma:.6g} 1/s; central sphere {c}, "
                 f"left connection {kl} {tuple(int(x) for x in d['pair'][kl])}, "
                 f"right connection {kr} {tuple(int(x) for x in d['pair'][kr])}")
    finite = all(np.all(np.isfinite(x)) for x in (Fl, Fr, Tl, Tr, d["position"], d["angular_velocity"]))
    check(finite, "all connection loads, positions and angular velocities finite")
    if not finite:
        return False, lines
    check(np.all(d["intact"][:, [kl, kr]] == 1), "both central connections intact")

    rows = np.linalg.norm(Fl, axis=1) > 0  # the first row holds no force yet
    nl, nr = np.linalg.norm(Fl, axis=1), np.linalg.norm(Fr, axis=1)
    fmax = float(max(nl.max(), nr.max()))
    anti = np.linalg.norm(Fl + Fr, axis=1)[rows] / nl[rows]
    i_anti = int(np.argmax(anti))
    check(anti.max() <= SYM_TOL,
          f"right force = -left force: max_t |F_l + F_r| / |F_l| = {anti.max():.3g} "
          f"(at t = {t[rows][i_anti]:.5g} s; limit {SYM_TOL:g}); relative to max |F|: "
          f"{np.linalg.norm(Fl + Fr, axis=1).max() / fmax:.3g}")
    a = np.array([-1.0, 1.0, -1.0])  # R = diag(-1, 1, -1) in the (e, w, n) frame for e = x, w = y, n = z
    frame = np.array([e, w, n])      # rows: flow, vorticity, normal
    Tl_f, Tr_f = Tl @ frame.T, Tr @ frame.T
    tmax = float(max(np.linalg.norm(Tl, axis=1).max(), np.linalg.norm(Tr, axis=1).max()))
    tsym = np.linalg.norm(Tr_f - a * Tl_f, axis=1).max() / tmax if tmax > 0 else 0.0
    lines.append(f"  torque: T_r = R T_l (flow and normal components opposite, vorticity component "
                 f"equal): max |T_r - R T_l| / max |T| = {tsym:.3g}; max |T| = {tmax:.4g} N m")
    fyl = np.abs(Fl @ w)[rows] / nl[rows]
    fyr = np.abs(Fr @ w)[rows] / nr[rows]
    check(max(fyl.max(), fyr.max()) <= SYM_TOL,
          f"vorticity (y) components: max |F_y| / |F| = {fyl.max():.3g} (left), {fyr.max():.3g} (right) "
          f"(limit {SYM_TOL:g})")

    om = d["angular_velocity"][:, c]
    wy = om @ w
    off = np.linalg.norm(om - np.outer(wy, w), axis=1)
    check(off.max() <= SYM_TOL * max(np.abs(wy).max(), 1e-300),
          f"rotation about y: max |w_x, w_z| = {off.max():.3g} rad/s vs max |w_y| = {np.abs(wy).max():.4g} rad/s")
    other_r = int(d["pair"][kr][1])
    ang = rotation_angle(d, c, other_r, n, e, w)
    dang = np.diff(ang)
    check(np.all(dang >= -1e-12) and ang[-1] > 0,
          f"rotation angle grows monotonically: {ang[-1]:.4f} rad at t = {t[-1]:.4g} s "
          f"(uniform rotation at gamma/2 would give {gamma / 2 * t[-1]:.4f} rad)")
    drift = np.linalg.norm(d["position"][:, c] - d["position"][0, c], axis=1).max()
    dx = float(sc["fluid"]["dx"]) if "dx" in sc.get("fluid", {}) else float("nan")
    lines.append(f"  centre sphere displacement: max {drift:.3g} m ({drift / dx:.3g} cells)")
    half = max(1, len(t) // 2)
    lines.append(f"  mean w_y: {wy[1:half].mean():.5g} rad/s in the first half, {wy[half:].mean():.5g} rad/s in "
                 f"the second (gamma/2 = {gamma / 2:.5g}); mean angular rate from the angle "
                 f"{ang[-1] / (t[-1] - t[0]):.5g} rad/s")

    # sinusoid fits of the left connection (the right one is its mirror image)
    span = t[-1] - t[0]
    fits = {}
    fit_rows = rows & (t >= t[0] + 0.05 * span)  # skip the start-up (the star starts at rest)
    tf = t[fit_rows]
    for comp, vec in (("x", e), ("z", n)):
        y = Fl[fit_rows] @ vec
        fits[comp] = fit_sinusoid(tf, y, 0.1 * span, 20 * span)
        f = fits[comp]
        lines.append(f"  [info] F_{comp} (left) vs time, c + A sin(2 pi t/P + phi): A = {f['amplitude']:.4g} N, "
                     f"P = {f['period']:.4g} s, c = {f['offset']:.3g} N, rms residual {f['rms']:.3g} N = "
                     f"{f['rel_rms'] * 100:.1f}% of A{' (period at the scan bound)' if f['at_bound'] else ''}")
    lines.append(f"  expected: uniform rotation at gamma/2 would turn once in 4 pi/gamma = {4 * math.pi / gamma:.4g} s "
                 f"and a load that follows the strain (sin 2 theta) would repeat every {2 * math.pi / gamma:.4g} s; "
                 f"the star turns non-uniformly (Jeffery-like, and spinning up from rest), so F_x, F_z are no single "
                 f"sinusoids of t; in the frame of the arm the load is a sinusoid of 2 theta")
    # the load in the frame of the arm, against the rotation angle: axial (along the arm c -> right
    # neighbour, > 0 = compression of the section) and transverse (in the shear plane)
    u = d["position"][:, int(d["pair"][kr][1])] - d["position"][:, c]
    u /= np.linalg.norm(u, axis=1)[:, None]
    perp = np.cross(w, u)
    axial, trans = np.einsum("ij,ij->i", Fl, u), np.einsum("ij,ij->i", Fl, perp)
    afit = {}
    covered = ang[fit_rows][-1] - ang[fit_rows][0] if fit_rows.any() else 0.0
    for name, y in (("axial", axial), ("transverse", trans)):
        afit[name] = fit_sinusoid(ang[fit_rows], y[fit_rows], 0.3, 40.0) if covered > 0 else None
    fa = afit["axial"]
    if fa is None or covered < math.pi / 2:
        check(False, f"rotation angle covered by the fit {covered:.3g} rad: too short for a fit against the "
                     f"angle (needs pi/2)")
    else:
        check(fa["rel_rms"] <= FIT_RESIDUAL and abs(fa["period"] / math.pi - 1) <= 0.1,
              f"axial load (left) vs rotation angle, c + A sin(2 pi theta/P + phi): A = {fa['amplitude']:.4g} N, "
              f"P = {fa['period']:.4g} rad ({fa['period'] / math.pi:.3f} pi; expected pi: the strain load "
              f"~ sin 2 theta; limit +-10%), c = {fa['offset']:.3g} N, rms residual {fa['rms']:.3g} N = "
              f"{fa['rel_rms'] * 100:.2f}% of A (limit {FIT_RESIDUAL * 100:g}%); fitted over {covered:.3g} rad")
        ft = afit["transverse"]
        lines.append(f"  [info] transverse load (left) vs rotation angle: A = {ft['amplitude']:.4g} N, "
                     f"P = {ft['period']:.4g} rad ({ft['period'] / math.pi:.3f} pi), c = {ft['offset']:.3g} N, "
                     f"rms residual {ft['rel_rms'] * 100:.2f}% of A")
    imax = int(np.argmax(nl))
    lines.append(f"  max |F| = {fmax:.5g} N (left {nl.max():.5g} N at t = {t[imax]:.4g} s, right {nr.max():.5g} N); "
                 f"paper: {PAPER_MAX_FORCE:.6g} N, ratio {fmax / PAPER_MAX_FORCE:.3g}, shear rate {gamma:.4g} 1/s")
    dm = mass_change(d)
    lines.append(f"  fluid mass: max |m(t) - m(0)| / m(0) = {dm:.3g}")

    if outdir:
        lines += plot_dual_star(h5, outdir, d, t, Fl, Fr, Tl, Tr, fits, fit_rows, e, w, n, ang, gamma, wy,
                                axial, trans, afit)
    lines.insert(0, f"check_dual_star: {'PASS' if rep.ok else 'FAIL'}")
    return rep.ok, lines


def _stem(h5, outdir):
    return os.path.join(outdir, os.path.splitext(os.path.basename(h5))[0])


def plot_dual_star(h5, outdir, d, t, Fl, Fr, Tl, Tr, fits, fit_rows, e, w, n, ang, gamma, wy,
                   axial, trans, afit):
    os.makedirs(outdir, exist_ok=True)
    stem = _stem(h5, outdir)
    out = []
    fig, ax = plt.subplots(2, 2, figsize=(11, 7.5), sharex=True)
    comps = (("x", e), ("y", w), ("z", n))
    for j, (comp, vec) in enumerate(comps):
        a = ax.flat[j]
        a.plot(t, Fl @ vec, label="left connection", lw=1.2)
        a.plot(t, Fr @ vec, label="right connection", lw=1.2, ls="--")
        if comp in fits:
            f = fits[comp]
            tt = t[fit_rows]
            a.plot(tt, f["model"](tt), "k:", lw=1.5,
                   label=f"fit (left): A={f['amplitude']:.3g} N, P={f['period']:.3g} s")
        a.set(ylabel=f"force {comp} (N)", title=f"force {comp}")
        a.legend(fontsize=7)
    a = ax.flat[3]
    for comp, vec in comps:
        a.plot(t, Tl @ vec, label=f"left, {comp}")
        a.plot(t, Tr @ vec, ls="--", label=f"right, {comp}")
    a.set(ylabel="torque (N m)", title="torque (Eq. 9)")
    a.legend(fontsize=7, ncol=2)
    for a in ax[1]:
        a.set_xlabel("t (s)")
    fig.suptitle("central connections of the dual star (cf. Iglberger, Thuerey & Ruede 2008, Fig. 8)")
    fig.tight_layout()
    fig.savefig(f"{stem}_connections_fig8.png", dpi=110)
    plt.close(fig)
    out.append(f"{stem}_connections_fig8.png")

    pos = d["position"]
    sc = d["scene"]
    rad = [s["radius"] for b in sc["bodies"] for s in b["spheres"]]
    k = np.unique(np.linspace(0, len(t) - 1, 5).round().astype(int))
    fig, ax = plt.subplots(1, len(k), figsize=(3.2 * len(k), 3.4))
    ctr = pos[0].mean(axis=0)
    rel = pos - ctr
    lim = 1.05 * (np.sqrt((rel @ e) ** 2 + (rel @ n) ** 2).max() + max(rad))
    for a, i in zip(np.atleast_1d(ax), k):
        for s in range(pos.shape[1]):
            p = pos[i, s] - ctr
            a.add_patch(plt.Circle((p @ e * 1e3, p @ n * 1e3), rad[s] * 1e3, fill=False,
                                   color="C1" if s == 0 else "C0"))
        a.set(xlim=(-lim * 1e3, lim * 1e3), ylim=(-lim * 1e3, lim * 1e3), aspect="equal",
              title=f"t = {t[i]:.3g} s", xlabel="x (mm)")
    np.atleast_1d(ax)[0].set_ylabel("z (mm)")
    fig.suptitle("dual star, x-z projection of the sphere centres (domain centre at 0)")
    fig.tight_layout()
    fig.savefig(f"{stem}_snapshots.png", dpi=110)
    plt.close(fig)
    out.append(f"{stem}_snapshots.png")

    fig, ax = plt.subplots(1, 3, figsize=(15, 4))
    for name, y in (("axial", axial), ("transverse", trans)):
        ax[2].plot(ang, y, label=f"{name} (left)")
        f = afit.get(name)
        if f is not None:
            ax[2].plot(ang[fit_rows], f["model"](ang[fit_rows]), "k:",
                       label=f"fit: A={f['amplitude']:.3g} N, P={f['period'] / math.pi:.3f} pi")
    ax[2].set(xlabel="rotation angle theta (rad)", ylabel="force (N)",
              title="central connection load in the arm frame")
    ax[2].legend(fontsize=7)
    ax[0].plot(t, ang, label="simulation")
    ax[0].plot(t, gamma / 2 * (t - t[0]), "k--", label="uniform rotation at gamma/2")
    ax[0].set(xlabel="t (s)", ylabel="rotation angle about y (rad)")
    ax[0].legend()
    ax[1].plot(t, wy, label="w_y")
    ax[1].axhline(gamma / 2, color="k", ls="--", label=f"gamma/2 = {gamma / 2:.4g} rad/s")
    ax[1].set(xlabel="t (s)", ylabel="angular velocity (rad/s)")
    ax[1].legend()
    fig.suptitle("dual star rotation")
    fig.tight_layout()
    fig.savefig(f"{stem}_rotation.png", dpi=110)
    plt.close(fig)
    out.append(f"{stem}_rotation.png")
    return [f"  figure: {p}" for p in out]


# ---------------------------------------------------------------------------------------------
# single sphere


def check_sphere_in_shear(h5, outdir):
    d = read(h5)
    rep = _Report()
    lines, check = rep.lines, rep.check

    sc = d["scene"]
    sf = shear_flow(sc)
    if sf is None or "angular_velocity" not in d or d["angular_velocity"].shape[1] != 1:
        return False, ["sphere in shear: the file holds no shear flow between walls or not one sphere"]
    gamma, n, e, w = sf
    t = d["t"]
    om = d["angular_velocity"][:, 0]
    pos = d["position"][:, 0]
    a = float(sc["bodies"][0]["spheres"][0]["radius"])
    nu = float(sc["fluid"]["viscosity"])
    lines.append(f"sphere in shear: {h5}")
    lines.append(f"  {len(t)} rows to t = {t[-1]:.6g} s; shear rate {gamma:.6g} 1/s, radius {a:.4g} m, "
                 f"Re = gamma a^2 / nu = {gamma * a * a / nu:.3g}; t nu / a^2 = {t[-1] * nu / a ** 2:.3g}")
    finite = all(np.all(np.isfinite(x)) for x in (om, pos, d["force"], d["torque"]))
    check(finite, "positions, angular velocities, forces and torques finite")
    if not finite:
        return False, lines
    tail = t >= t[0] + 0.8 * (t[-1] - t[0])
    wy = om @ w
    steady = float(wy[tail].mean())
    ratio = steady / (gamma / 2)
    check(abs(ratio - 1) <= ROT_TOL,
          f"steady w_y (mean of the last 20%) = {steady:.6g} rad/s, gamma/2 = {gamma / 2:.6g} rad/s, "
          f"ratio {ratio:.5f} (error {(ratio - 1) * 100:+.3f}%, limit {ROT_TOL * 100:g}%)")
    spread = float(np.ptp(wy[tail]) / (gamma / 2))
    lines.append(f"  spread of w_y over the last 20%: {spread * 100:.3f}% of gamma/2; last row {wy[-1]:.6g} rad/s "
                 f"(ratio {wy[-1] / (gamma / 2):.5f})")
    half = (t >= t[0] + 0.5 * (t[-1] - t[0])) & (t > t[0])
    if half.sum() >= 3:
        # the spin-up approaches its steady value with the viscous long-time tail ~ t^(-3/2)
        A = np.column_stack([np.ones(half.sum()), (t[half] - t[0]) ** -1.5])
        (winf, _), *_ = np.linalg.lstsq(A, wy[half], rcond=None)
        lines.append(f"  [info] w_y(t) = w_inf - C t^(-3/2) fitted over the second half: w_inf = {winf:.6g} rad/s, "
                     f"ratio {winf / (gamma / 2):.5f} (error {(winf / (gamma / 2) - 1) * 100:+.3f}%)")
    offax = float(np.linalg.norm(om - np.outer(wy, w), axis=1).max())
    check(offax <= 1e-3 * gamma / 2, f"off-axis angular velocity max {offax:.3g} rad/s (limit 1e-3 gamma/2)")
    dx = float(sc["fluid"]["dx"])
    drift = float(np.linalg.norm(pos - pos[0], axis=1).max())
    check(drift <= 0.01 * dx, f"sphere stays at the centre: max displacement {drift:.3g} m = {drift / dx:.3g} cells")
    dm = mass_change(d)
    lines.append(f"  fluid mass: max |m(t) - m(0)| / m(0) = {dm:.3g}")
    if outdir:
        os.makedirs(outdir, exist_ok=True)
        stem = _stem(h5, outdir)
        fig, ax = plt.subplots(1, 2, figsize=(11, 4))
        ax[0].plot(t, wy / (gamma / 2), label="w_y / (gamma/2)")
        ax[0].axhline(1.0, color="k", ls="--", label="Stokes: gamma/2")
        ax[0].axhspan(1 - ROT_TOL, 1 + ROT_TOL, color="0.85", label="+-1%")
        ax[0].set(xlabel="t (s)", ylabel="w_y / (gamma/2)", title="angular velocity of the sphere")
        ax[0].legend()
        ax[1].plot(t[tail], wy[tail] / (gamma / 2))
        ax[1].axhline(1.0, color="k", ls="--")
        ax[1].set(xlabel="t (s)", ylabel="w_y / (gamma/2)", title="last 20% (steady value)")
        fig.suptitle(f"free sphere in simple shear, gamma = {gamma:.4g} 1/s, Re = {gamma * a * a / nu:.3g}")
        fig.tight_layout()
        fig.savefig(f"{stem}_rotation.png", dpi=110)
        plt.close(fig)
        lines.append(f"  figure: {stem}_rotation.png")
    lines.insert(0, f"check_sphere_in_shear: {'PASS' if rep.ok else 'FAIL'}")
    return rep.ok, lines
