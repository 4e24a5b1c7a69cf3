"""agglomerates_in_shear.py — the check and figures of agglomerate_16/32/64 and three_agglomerates (Fig. 9).

check_agglomerate(h5, outdir): the scene's bodies stay whole (no limits) and keep
  their count; each turns about the vorticity axis y in the sense of the shear, with
  a mean angular velocity (second half of the run) in (0.3, 2) gamma/2 (a sphere
  turns at gamma/2; an elongated body between gamma/(p^2+1) and gamma p^2/(p^2+1)
  over its Jeffery orbit, aspect ratio p); the
  centre of mass stays within 2 sphere radii of its start across the flow.
  Figures like the paper's Fig. 9: 3D views at the start and the end, x-z
  projections over time, connection force magnitudes over time.
"""
import os

import matplotlib.pyplot as plt
import numpy as np

from agglo import agglomerate_3d, begin, connection_figure, group_centroids, save, shear_rate, snapshot_xz

# Mean angular velocity about the vorticity axis / (gamma/2): a rigid body in simple shear turns
# with the shear at a rate between gamma/(p^2+1) and gamma p^2/(p^2+1) (Jeffery 1922, aspect ratio
# p), i.e. in (0, 2) gamma/2; a sphere at 1. The lower end 0.3 allows p up to 2.4.
OMEGA_RANGE = (0.3, 2.0)
DRIFT_RADII = 2.0         # centre-of-mass drift across the flow, in sphere radii
# A developed start (initial_profile: plane_channel) puts the resting agglomerate at once into
# the moving fluid (an impulsive start: a load spike in the first steps); connection loads are
# also reported after this time.
STARTUP = 0.05


def check_agglomerate(h5, outdir):
    d, name, ok, lines = begin(h5)
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
    save(fig, f"{stem}_3d.png", written)
    ks = np.linspace(0, len(t) - 1, 4).astype(int)
    L = d["scene"]["domain"]["size"]
    fig, axes = plt.subplots(1, 4, figsize=(16, 4.2 * L[2] / L[0] + 1))
    for ax, k in zip(axes, ks):
        snapshot_xz(ax, d, k, xlim=(0, L[0] * 1e3))
    fig.suptitle(f"{name}: x-z projection (walls at z = 0 and z = {L[2] * 1e3:.3g} mm move along -+x)")
    save(fig, f"{stem}_snapshots.png", written)
    connection_figure(d, f"{stem}_connections.png", written)
    fig, ax = plt.subplots(figsize=(8, 3.8))
    for g, idx in enumerate(groups):
        ax.plot(t, d["angular_velocity"][:, idx[0], 1], label=f"body {g}")
    if gamma > 0:
        ax.axhline(gamma / 2, color="k", ls="--", label="gamma/2 (free sphere)")
    ax.set(xlabel="t (s)", ylabel="w_y (rad/s)", title="angular velocity about the vorticity axis")
    ax.legend(fontsize=8)
    save(fig, f"{stem}_rotation.png", written)
    lines += [f"  figure {w}" for w in written]
    lines.append(f"{name}: {'PASS' if ok else 'FAIL'}")
    return ok, lines
