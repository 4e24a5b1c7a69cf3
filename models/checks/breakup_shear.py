"""breakup_shear.py — the check and figures of the breakup_shear scene.

check_breakup_shear(h5, outdir): one body at t0, at least two at the end; the time
  of the first break and the number of fragments; the body ids are the connected
  components of the intact connections (plus the unlisted touching pairs) in every
  row; no intact connection ever reports a load above its limit; the balance at
  every break row (and at every row).
"""
import math
import os

import matplotlib.pyplot as plt
import numpy as np

from agglo import (begin, body_events, connection_figure, event_balance, every_row_balance, momentum,
                   one_step_apart, save, snapshot_xz)


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
    d, name, ok, lines = begin(h5, "breakup_shear")
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
    save(fig, f"{stem}_snapshots.png", written)
    connection_figure(d, f"{stem}_connections.png", written, [t[k] for k, *_ in ev])
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.2))
    ax[0].step(t, nb, where="post")
    ax[0].set(xlabel="t (s)", ylabel="number of bodies", title="fragments")
    ax[1].plot(t, np.linalg.norm(P, axis=1))
    ax[1].set(xlabel="t (s)", ylabel="|P| (kg m/s)", title="total momentum of the bodies")
    save(fig, f"{stem}_fragments.png", written)
    lines += [f"  figure {w}" for w in written]
    lines.append(f"breakup_shear: {'PASS' if ok else 'FAIL'}")
    return ok, lines
