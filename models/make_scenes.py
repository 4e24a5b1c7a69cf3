"""Writes the paper's agglomerate scenes into models/ (deterministic).

    .venv/bin/python models/make_scenes.py            # rewrite the scenes
    .venv/bin/python models/make_scenes.py --check    # exit 1 if a file differs

Scenes (see models/README.md): dual_star_shear, agglomerate_16/32/64,
three_agglomerates, channel_collision, breakup_shear. The complex agglomerates
come from coupler/agglomerate.py (seeded random sequential attachment with
sintering); the same seeds always give the same files.
"""
import argparse
import math
import pathlib
import sys

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "coupler"))
import agglomerate  # noqa: E402

WATER = {"density": 1000.0, "viscosity": 1.0e-6}


def fmt(x):
    return f"{x:.9g}"


def vec(v):
    return "[" + ", ".join(fmt(float(a)) for a in v) + "]"


def body_yaml(name, centers, radius, density, velocity=(0, 0, 0), motion="free"):
    lines = [f"  - name: {name}", f"    density: {fmt(density)}", f"    motion: {motion}",
             f"    velocity: {vec(velocity)}", "    spheres:"]
    for c in centers:
        lines.append(f"      - {{center: {vec(c)}, radius: {fmt(radius)}}}")
    return "\n".join(lines)


def connections_yaml(pairs, limits=None):
    if not pairs:
        return ""
    out = ["connections:"]
    for a, b in pairs:
        extra = ""
        if limits:
            extra = "".join(f", {k}: {fmt(v)}" for k, v in limits.items())
        out.append(f"  - {{spheres: [{a}, {b}]{extra}}}")
    return "\n".join(out)


def shear_domain(size, dx, wall_speed, tau=0.8):
    """Simple shear between z walls moving in opposite directions, periodic in x and y."""
    return "\n".join([
        "domain:",
        f"  size: {vec(size)}",
        "  faces:",
        f"    z_min: {{type: moving_wall, velocity: [{fmt(-wall_speed)}, 0, 0]}}",
        f"    z_max: {{type: moving_wall, velocity: [{fmt(wall_speed)}, 0, 0]}}",
        "fluid:",
        f"  density: {fmt(WATER['density'])}",
        f"  viscosity: {fmt(WATER['viscosity'])}",
        f"  dx: {fmt(dx)}",
        f"  tau: {fmt(tau)}",
        "  collision: trt",
        "  boundary_scheme: cli",
        "  refill: extrapolation",
        "  force: galilean",
        "  initial_profile: plane_channel   # start in the steady shear flow",
    ])


def cells_for(extent_m, dx, factor, multiple=8):
    n = math.ceil(2.0 * extent_m * factor / dx / multiple) * multiple
    return n * dx


def dual_star(r):
    """13 spheres: a central sphere, on each side along x an arm sphere and a
    star (centre + 4 satellites at +-y and +-z); 12 connections, length 10 r."""
    c = [(0, 0, 0)]
    pairs = []
    for side in (-1, 1):
        arm = len(c)
        c.append((side * 2 * r, 0, 0))
        pairs.append((0, arm))
        hub = len(c)
        c.append((side * 4 * r, 0, 0))
        pairs.append((arm, hub))
        for d in ((0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)):
            k = len(c)
            c.append((side * 4 * r, 2 * r * d[1], 2 * r * d[2]))
            pairs.append((hub, k))
    return np.array(c, dtype=float), pairs


def scene_dual_star():
    r, dx = 4.0e-4, 5.0e-5
    L = 120 * dx
    u = 0.01  # wall speed: shear rate 2u/L = 3.33 1/s, lattice wall speed 0.05
    centers, pairs = dual_star(r)
    centers = centers + L / 2
    period = 4 * math.pi / (2 * u / L)
    return "\n".join([
        "# The paper's dual star (Fig. 7, 8): 13 spheres of radius 4e-4 m (8 cells), 12 connections,",
        "# length 4e-3 m, centred in a 120^3 box (dx = 5e-5 m) of water in simple shear between",
        f"# walls moving at -+{u} m/s along x (shear rate {2 * u / L:.4g} 1/s, vorticity along y).",
        f"# The agglomerate turns about y at about half the shear rate: one turn takes {period:.3g} s.",
        shear_domain([L, L, L], dx, u),
        "bodies:",
        body_yaml("dual_star", centers, r, 2000.0),
        connections_yaml(pairs),
        "rigid: {integrator: verlet, gravity: [0, 0, 0]}",
        f"run: {{end_time: {fmt(period / 2)}, output_interval: {fmt(period / 400)}}}",
        "",
    ])


def scene_agglomerate(n, seed):
    r, dx = 2.5e-4, 5.0e-5  # 5 cells per radius
    centers, pairs = agglomerate.generate(n, r, overlap=0.1, seed=seed)
    half = agglomerate.extent(centers, r)
    size = [cells_for(max(half), dx, 1.6)] * 3
    centers = centers + np.array(size) / 2
    u = 0.005
    return "\n".join([
        f"# A complex asymmetric agglomerate of {n} sintered spheres (radius 2.5e-4 m = 5 cells,",
        f"# 10% overlap, seed {seed}: coupler/agglomerate.py) in simple shear between z walls moving",
        f"# at -+{u} m/s; connection forces and torques recorded (Eq. 8, 9).",
        shear_domain(size, dx, u),
        "bodies:",
        body_yaml(f"agglomerate_{n}", centers, r, 2000.0),
        connections_yaml(pairs),
        "rigid: {integrator: verlet, gravity: [0, 0, 0]}",
        "run: {end_time: 2.0, output_interval: 0.01}",
        "",
    ])


def scene_three():
    r, dx = 2.5e-4, 5.0e-5
    specs = [(16, 11), (32, 12), (24, 13)]
    parts = []
    offsets = []
    size = [0.0, 0.0, 0.0]
    x = 0.0
    for n, seed in specs:
        c, p = agglomerate.generate(n, r, overlap=0.1, seed=seed)
        h = agglomerate.extent(c, r)
        x += h[0] * 1.5
        offsets.append(x)
        x += h[0] * 1.5
        parts.append((n, seed, c, p, h))
    width = max(max(h[1], h[2]) for *_, h in parts) * 2 * 1.6
    size = [math.ceil(x / dx / 8) * 8 * dx, math.ceil(width / dx / 8) * 8 * dx,
            math.ceil(width / dx / 8) * 8 * dx]
    bodies, pairs, base = [], [], 0
    for (n, seed, c, p, h), ox in zip(parts, offsets):
        cc = c + np.array([ox, size[1] / 2, size[2] / 2])
        bodies.append(body_yaml(f"agglomerate_{n}_{seed}", cc, r, 2000.0))
        pairs += [(a + base, b + base) for a, b in p]
        base += n
    u = 0.005
    return "\n".join([
        "# Three complex agglomerates (16, 32 and 24 spheres of radius 5 cells) side by side in one",
        "# shear flow (the paper's Fig. 9, right; it needed 640 MB): memory is printed by `coupler check`.",
        shear_domain(size, dx, u),
        "bodies:",
        "\n".join(bodies),
        connections_yaml(pairs),
        "contacts: {model: spring_dashpot, restitution: 0.5, contact_time: 2.0e-3}",
        "rigid: {integrator: verlet, gravity: [0, 0, 0], substeps: 4}",
        "run: {end_time: 1.0, output_interval: 0.01}",
        "",
    ])


def scene_channel_collision():
    """Two small agglomerates in a body-force driven channel: the one near the
    centre plane moves faster, catches up with the one nearer the wall and
    sticks to it (the paper's Fig. 10)."""
    r, dx = 2.0e-4, 5.0e-5  # 4 cells per radius
    H = 96 * dx
    Lx, Ly = 192 * dx, 48 * dx
    a, pa = agglomerate.generate(6, r, overlap=0.1, seed=21)
    b, pb = agglomerate.generate(6, r, overlap=0.1, seed=22)
    ca = a + np.array([0.25 * Lx, Ly / 2, 0.5 * H])
    cb = b + np.array([0.45 * Lx, Ly / 2, 0.5 * H - 5.0 * r])
    umax = 0.01
    fb = 8 * WATER["density"] * WATER["viscosity"] * umax / H**2
    pairs = pa + [(x + 6, y + 6) for x, y in pb]
    return "\n".join([
        "# Two agglomerates of 6 spheres (radius 4 cells) in a periodic plane channel driven by a body",
        f"# force (peak velocity {umax} m/s): the one on the centre plane is faster, reaches the one",
        "# below it and sticks (contacts.stick_speed), forming one new agglomerate (Fig. 10).",
        "domain:",
        f"  size: {vec([Lx, Ly, H])}",
        "  faces:",
        "    z_min: {type: no_slip}",
        "    z_max: {type: no_slip}",
        "fluid:",
        "  density: 1000.0",
        "  viscosity: 1.0e-6",
        f"  dx: {fmt(dx)}",
        "  tau: 0.8",
        f"  body_force: [{fmt(fb)}, 0, 0]",
        "  initial_profile: plane_channel   # start in the developed channel flow",
        "bodies:",
        body_yaml("upstream", ca, r, 1000.0),
        body_yaml("downstream", cb, r, 1000.0),
        connections_yaml(pairs),
        "contacts: {model: spring_dashpot, restitution: 0.5, contact_time: 1.0e-3, stick_speed: 1.0}",
        "rigid: {integrator: verlet, gravity: [0, 0, 0], substeps: 4}",
        "run: {end_time: 4.0, output_interval: 0.01}",
        "",
    ])


def scene_breakup():
    """A 10-sphere agglomerate with weak necks in strong shear."""
    r, dx = 2.5e-4, 5.0e-5
    c, p = agglomerate.generate(10, r, overlap=0.1, seed=31)
    half = agglomerate.extent(c, r)
    size = [cells_for(max(half), dx, 1.8)] * 3
    c = c + np.array(size) / 2
    u = 0.01
    return "\n".join([
        "# A 10-sphere agglomerate whose necks hold at most 2e-7 N in tension or shear, in strong shear",
        f"# (walls at -+{u} m/s): connections break and the fragments move on as separate bodies.",
        shear_domain(size, dx, u),
        "bodies:",
        body_yaml("fragile", c, r, 2000.0),
        connections_yaml(p, {"max_normal": 2.0e-7, "max_shear": 2.0e-7}),
        "contacts: {model: spring_dashpot, restitution: 0.5, contact_time: 1.0e-3}",
        "rigid: {integrator: verlet, gravity: [0, 0, 0], substeps: 4}",
        "run: {end_time: 1.0, output_interval: 0.005}",
        "",
    ])


SCENES = {
    "dual_star_shear.yaml": scene_dual_star,
    "agglomerate_16.yaml": lambda: scene_agglomerate(16, 16),
    "agglomerate_32.yaml": lambda: scene_agglomerate(32, 32),
    "agglomerate_64.yaml": lambda: scene_agglomerate(64, 64),
    "three_agglomerates.yaml": scene_three,
    "channel_collision.yaml": scene_channel_collision,
    "breakup_shear.yaml": scene_breakup,
}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--check", action="store_true", help="compare with the files instead of writing them")
    a = ap.parse_args()
    bad = 0
    for name, make in SCENES.items():
        text = make()
        path = HERE / name
        if a.check:
            if not path.exists() or path.read_text() != text:
                print(f"{path} differs from what make_scenes.py generates")
                bad = 1
        else:
            path.write_text(text)
            print(f"wrote {path}")
    return bad


if __name__ == "__main__":
    sys.exit(main())
