"""channel_collision.py — the check and figures of the channel_collision scene (Fig. 10).

check_channel_collision(h5, outdir): two bodies at t0; exactly one fusion (body count
  2 -> 1); before it, the upstream body (behind in x) moves faster along the flow;
  after it, every sphere has the same body id and the two groups keep their relative
  position (rigid); the balance at the fusion row (and at every row).
"""
import os

import matplotlib.pyplot as plt
import numpy as np

from agglo import (L_TOL, P_TOL, begin, body_events, connection_figure, event_balance, every_row_balance,
                   fields_slice, group_centroids, momentum, save, shares, snapshot_xz)


def check_channel_collision(h5, outdir):
    d, name, ok, lines = begin(h5, "channel_collision")
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
    save(fig, f"{stem}_snapshots.png", written)
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
    save(fig, f"{stem}_velocity.png", written)
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
        save(fig, f"{stem}_balance.png", written)
    fields_slice(d, f"{stem}_slice.png", written, t[kf])
    lines += [f"  figure {w}" for w in written]
    lines.append(f"channel_collision: {'PASS' if ok else 'FAIL'}")
    return ok, lines
