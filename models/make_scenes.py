"""Writes the paper's agglomerate scenes into models/ (deterministic).

    .venv/bin/python models/make_scenes.py            # rewrite the scenes
    .venv/bin/python models/make_scenes.py --check    # exit 1 if a file differs

Scenes (see models/README.md): dual_star_shear, agglomerate_16/32/64,
three_agglomerates, channel_collision, breakup_shear. The complex agglomerates
come from models/agglomerate.py (seeded random sequential attachment with
sintering); the same seeds always give the same files.
"""
import argparse
import math
import pathlib
import sys

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
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
        f"run: {{end_time: {fmt(period / 2)}, output_interval: {fmt(period / 400)}, fields: true, "
        f"field_interval: {fmt(period / 8)}}}",
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
        f"# 10% overlap, seed {seed}: models/agglomerate.py) in simple shear between z walls moving",
        f"# at -+{u} m/s; connection forces and torques recorded (Eq. 8, 9).",
        shear_domain(size, dx, u),
        "bodies:",
        body_yaml(f"agglomerate_{n}", centers, r, 2000.0),
        connections_yaml(pairs),
        "rigid: {integrator: verlet, gravity: [0, 0, 0]}",
        "run: {end_time: 2.0, output_interval: 0.01, fields: true, field_interval: 0.5}",
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
        "run: {end_time: 1.0, output_interval: 0.01, fields: true, field_interval: 0.25}",
        "",
    ])


def scene_channel_collision():
    """Two small agglomerates in a body-force driven channel: the one near the
    centre plane moves faster, catches up with the one nearer the wall and
    sticks to it (the paper's Fig. 10). Placement: the upstream agglomerate 2 r
    below the centre plane, the downstream one 2.5 r lower and 8 r ahead, so
    that their z ranges overlap by about 2.5 r (a head-on collision: with 3.5 r
    and 9.6 r the two passed each other at 0.1 r). The relative speed of the
    undisturbed profile, u(-2 r) - u(-4.5 r) = 0.113 umax, closes the gap in
    about 1 s. Density ratio 1 (neutrally buoyant, no gravity): the force is
    averaged over two steps (fluid.force_averaging), without which the coupled
    force alternates sign every step."""
    r, dx = 2.0e-4, 5.0e-5  # 4 cells per radius
    H = 96 * dx
    Lx, Ly = 192 * dx, 48 * dx
    a, pa = agglomerate.generate(6, r, overlap=0.1, seed=21)
    b, pb = agglomerate.generate(6, r, overlap=0.1, seed=22)
    ca = a + np.array([0.25 * Lx, Ly / 2, 0.5 * H - 2.0 * r])
    cb = b + np.array([0.25 * Lx + 8.0 * r, Ly / 2, 0.5 * H - 4.5 * r])
    umax = 0.01
    fb = 8 * WATER["density"] * WATER["viscosity"] * umax / H**2
    pairs = pa + [(x + 6, y + 6) for x, y in pb]
    return "\n".join([
        "# Two agglomerates of 6 spheres (radius 4 cells) in a periodic plane channel driven by a body",
        f"# force (peak velocity {umax} m/s): the one nearer the centre plane is faster, reaches the one",
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
        "  force_averaging: true            # density ratio 1: damps the period-2 coupling oscillation",
        "bodies:",
        body_yaml("upstream", ca, r, 1000.0),
        body_yaml("downstream", cb, r, 1000.0),
        connections_yaml(pairs),
        "# the paper's contact model has no lubrication film: the bodies touch and stick as in Fig. 10",
        "# (with the film on, the default, the last 0.1 r of the gap closes only like exp(-t / 0.04 s))",
        "contacts: {model: spring_dashpot, restitution: 0.5, contact_time: 1.0e-3, stick_speed: 1.0,",
        "           lubrication: {enabled: false}}",
        "rigid: {integrator: verlet, gravity: [0, 0, 0], substeps: 4}",
        "run: {end_time: 2.0, output_interval: 0.005, fields: true, field_interval: 0.5}",
        "",
    ])


def scene_breakup():
    """A 10-sphere agglomerate with weak necks in strong shear. The fluid starts at
    rest and the walls start moving at t = 0, so the shear builds up from the walls
    (time scale H^2/(pi^2 nu) = 1.3 s) and the connection loads grow with it until the
    weakest necks break. A developed start (initial_profile: plane_channel) is not used:
    the agglomerate at rest is put at once into the moving fluid, and the sudden no-slip
    condition loads each sphere with up to ~3e-7 N in the first step, ten times the steady shear loads
    (1-2e-8 N at this shear rate, measured with unbreakable necks); with the former
    limits of 2e-7 N every neck was broken within 0.005 s. The limit 1e-8 N lies below
    the steady loads of the most
    loaded necks and above those of the least loaded ones. Contacts are on, so fragments
    do not pass through each other; the sintering overlap of a just-broken neck is not a
    contact penetration (the rigid component takes the centre distance at the break as the
    contact-free distance of that pair until the two spheres part)."""
    r, dx = 2.5e-4, 5.0e-5
    c, p = agglomerate.generate(10, r, overlap=0.1, seed=31)
    half = agglomerate.extent(c, r)
    size = [cells_for(max(half), dx, 1.8)] * 3
    c = c + np.array(size) / 2
    u = 0.01
    limit = 1.0e-8
    domain = shear_domain(size, dx, u).replace(
        "  initial_profile: plane_channel   # start in the steady shear flow",
        "  initial_profile: uniform   # fluid at rest at t = 0: the shear builds up from the walls")
    return "\n".join([
        f"# A 10-sphere agglomerate whose necks hold at most {limit:g} N in tension or shear, in strong shear",
        f"# (walls at -+{u} m/s, started at t = 0): as the shear builds up, connections break and the",
        "# fragments move on as separate bodies.",
        domain,
        "bodies:",
        body_yaml("fragile", c, r, 2000.0),
        connections_yaml(p, {"max_normal": limit, "max_shear": limit}),
        "contacts: {model: spring_dashpot, restitution: 0.5, contact_time: 1.0e-3}   # fragments do not pass through each other",
        "rigid: {integrator: verlet, gravity: [0, 0, 0], substeps: 4}",
        "run: {end_time: 3.0, output_interval: 0.01, fields: true, field_interval: 0.75}",
        "",
    ])


def scene_sphere_in_shear():
    """One free, neutrally buoyant sphere at the centre of a simple shear flow between z walls
    (periodic in x and y): in Stokes flow it turns at half the shear rate about y. Box and
    Reynolds number are chosen so that the expected deviations are small (models/README.md):
    walls -5 (a/H)^3 (Goldman, Cox & Brenner 1967, two walls), periodic images in x and y
    (stresslet far field, unscreened estimate) and inertia -0.0385 Re^1.5 (Lin, Peery &
    Schowalter 1970)."""
    dx = 1.0e-5
    a = 8 * dx                        # 8 cells per radius
    nx, ny, nz = 224, 96, 160          # box in cells: Lx = 28 a, Ly = 12 a, H = 20 a
    size = [nx * dx, ny * dx, nz * dx]
    nu = WATER["viscosity"]
    re = 0.05                         # gamma a^2 / nu
    gamma = re * nu / a ** 2
    u = gamma * size[2] / 2
    return "\n".join([
        "# One free, neutrally buoyant sphere (radius 8e-5 m = 8 cells) at the centre of a simple shear",
        f"# flow between z walls moving at -+{fmt(u)} m/s along x (shear rate {fmt(gamma)} 1/s,",
        f"# Re = gamma a^2/nu = {re:g}); periodic in x and y. Stokes flow: it turns at gamma/2 about +y.",
        shear_domain(size, dx, u, tau=1.5),
        "bodies:",
        body_yaml("sphere", [np.array(size) / 2], a, WATER["density"]),
        "rigid: {integrator: verlet, gravity: [0, 0, 0]}",
        f"run: {{end_time: {fmt(5 * a * a / nu)}, output_interval: {fmt(0.05 * a * a / nu)}, fields: true, "
        f"field_interval: {fmt(1.25 * a * a / nu)}}}   # 5 a^2/nu",
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
    "sphere_in_shear.yaml": scene_sphere_in_shear,
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
