"""settling_cases.py — scenes and measurements for issue 10's two wall tests: a sphere settling
in a closed box onto its floor (ten Cate et al. 2002) and the wet restitution of a heavy sphere
hitting a wall (Gondret et al. 2002, Joseph et al. 2001, Legendre et al. 2005).

Used by tests/python/test_settling_box.py; also a script:

    .venv/bin/python tests/python/settling_cases.py scene E2 10 [-o FILE]   # write a scene
    .venv/bin/python tests/python/settling_cases.py report OUT.h5           # settling summary

The scenes carry no coupling and no contact keys: they test the defaults (rigid.coupling auto,
contacts spring-dashpot with lubrication). Extra keys for experiments go in with `--set`.

Settling in a box (ten Cate, Nieuwstad, Derksen & Van den Akker, Phys. Fluids 14 (2002) 4012,
"Particle imaging velocimetry experiments and lattice-Boltzmann simulations on a single sphere
settling under gravity"): a box of 100 x 100 x 160 mm with no-slip walls, a sphere of
D = 15 mm and 1120 kg/m^3 released at rest; fluids E1..E4. The box is rounded to whole cells
of dx = D / (cells per diameter). The sphere's lowest point starts 120 mm above the floor
(centre at 127.5 mm), the reading of the paper's release height in waLBerla's
SettlingSphereInBox benchmark (lssfau/walberla, apps/benchmarks/FluidParticleCoupling; it
shifts the start a further D/4 up to match the plotted curves; we do not). dt makes the
lattice settling velocity U_LAT (0.04) at the terminal velocity u_inf of ten Cate's Table 1.

Wet restitution: a sphere of density ratio 10 (or 8) starts at its terminal velocity towards
the floor of a small box with gravity chosen so that this velocity is its terminal velocity
(Schiller-Naumann drag), so that it hits the floor at a known speed after a short approach;
the Stokes number St = (rho_p / rho_f) Re / 9 is set by the viscosity.
"""
import argparse
import math
import sys

import numpy as np
import yaml

D_SPHERE = 15e-3            # m
RHO_SPHERE = 1120.0         # kg/m^3
BOX = (0.100, 0.100, 0.160)  # m
RELEASE_GAP = 0.120         # m, lowest point of the sphere above the floor at release
G = 9.81
U_LAT = 0.04                # lattice settling velocity at u_inf

# ten Cate et al. (2002): fluid density (kg/m^3), dynamic viscosity (Pa s), Re and u_inf from
# their Table 1 (terminal velocity in an unbounded fluid), and the largest velocity measured in
# the box, u_max (their Table 2, as quoted in waLBerla's SettlingSphereInBox.cpp).
FLUIDS = {
    "E1": dict(rho=970.0, mu=0.373, re=1.5, u_inf=0.038, u_max=0.035986),
    "E2": dict(rho=965.0, mu=0.212, re=4.1, u_inf=0.060, u_max=0.05718),
    "E3": dict(rho=962.0, mu=0.113, re=11.6, u_inf=0.091, u_max=0.087269),
    "E4": dict(rho=960.0, mu=0.058, re=31.9, u_inf=0.128, u_max=0.12224),
}


def _f(x):
    return float(f"{x:.12g}")


def _whole_ns(dt):
    """dt rounded to a whole number of nanoseconds, as every scene's step is (README "FMUs":
    masters that count time in integer ns, libcosim/OSP, can then step the FMUs)."""
    return round(dt * 1e9) / 1e9


def settling_geometry(cells_per_d, height=None):
    """dx and the box in whole cells (rounded), optionally with a lower box height (m)."""
    dx = D_SPHERE / cells_per_d
    n = [int(round(L / dx)) for L in (BOX[0], BOX[1], height if height else BOX[2])]
    return dx, n


def settling_end_time(case, release_gap=RELEASE_GAP):
    """Fall at about u_max, the acceleration (a few particle times), and the approach to rest:
    the lubrication-limited creep of the last ~D/2 takes about 6 pi mu a^2 / W per e-fold."""
    f = FLUIDS[case]
    a = D_SPHERE / 2
    vol = math.pi / 6 * D_SPHERE ** 3
    w = (RHO_SPHERE - f["rho"]) * G * vol
    t_creep = 6 * math.pi * f["mu"] * a * a / w
    # particle relaxation time with the added mass and the Schiller-Naumann drag at Re
    t_acc = (RHO_SPHERE + 0.5 * f["rho"]) * D_SPHERE ** 2 / (18 * f["mu"]) / (1 + 0.15 * f["re"] ** 0.687)
    return release_gap / f["u_max"] + 3 * t_acc + 8 * t_creep + 0.1


def settling_scene(case, cells_per_d, height=None, release_gap=RELEASE_GAP, end_time=None, rows=400):
    """The scene (dict) of ten Cate's case E1..E4 at cells_per_d cells across the sphere."""
    f = FLUIDS[case]
    dx, n = settling_geometry(cells_per_d, height)
    size = [_f(k * dx) for k in n]
    a = D_SPHERE / 2
    center = [_f(size[0] / 2), _f(size[1] / 2), _f(release_gap + a)]
    if center[2] + a > size[2]:
        raise ValueError(f"the box of height {size[2]} m does not hold the sphere released at {release_gap} m")
    dt = _whole_ns(U_LAT * dx / f["u_inf"])
    end = end_time if end_time else settling_end_time(case, release_gap)
    faces = {k: {"type": "no_slip"} for k in ("x_min", "x_max", "y_min", "y_max", "z_min", "z_max")}
    return {
        "domain": {"size": size, "faces": faces},
        "fluid": {"density": f["rho"], "viscosity": _f(f["mu"] / f["rho"]), "dx": _f(dx), "dt": _f(dt)},
        "bodies": [{"name": "sphere", "density": RHO_SPHERE,
                    "spheres": [{"center": center, "radius": _f(a)}]}],
        "rigid": {"gravity": [0.0, 0.0, -G]},
        "run": {"end_time": _f(end), "output_interval": _f(max(end / rows, dt))},
    }


def dump(scene, header=""):
    text = yaml.safe_dump(scene, default_flow_style=None, sort_keys=False, width=110)
    return header + text


def tau_of(scene):
    fl = scene["fluid"]
    return 0.5 + 3 * fl["viscosity"] * fl["dt"] / fl["dx"] ** 2


# --- the measurements -------------------------------------------------------------------------


def contact_overlap_estimate(scene, v_impact, contact_time=None, restitution=0.9):
    """Largest overlap of a linear spring-dashpot contact with the floor: the undamped bound
    delta = v sqrt(m/k) of an impact at v (from m v^2 / 2 = k delta^2 / 2), plus the static
    overlap W/k under the net weight. k = m (pi^2 + ln^2 e) / t_c^2 (rigid/contact.c); t_c is 10
    fluid steps unless given (the default of contacts.contact_time)."""
    fl, b = scene["fluid"], scene["bodies"][0]
    a = b["spheres"][0]["radius"]
    m = b["density"] * 4 / 3 * math.pi * a ** 3
    tc = contact_time if contact_time else 10 * fl["dt"]
    k = m * (math.pi ** 2 + math.log(restitution) ** 2) / tc ** 2
    g = abs(scene["rigid"]["gravity"][2])
    w = (b["density"] - fl["density"]) * 4 / 3 * math.pi * a ** 3 * g
    return v_impact * math.sqrt(m / k) + w / k


def settling_measure(d, scene):
    """Reads an output (coupler/h5out.read dict) of a settling scene: u_max and when, the
    final gap (lowest point above the floor, m and in D), the final speed, where it landed,
    and the largest relative fluid mass change."""
    a = scene["bodies"][0]["spheres"][0]["radius"]
    t = d["t"]
    z = d["position"][:, 0, 2]
    v = d["velocity"][:, 0, :]
    vz = v[:, 2]
    k = int(np.argmax(-vz))
    gap = z - a
    m = d["fluid_mass"]
    speed = np.linalg.norm(v, axis=1)
    # the first row with the sphere within 0.1 D of the floor: "landed"
    near = np.nonzero(gap < 0.1 * 2 * a)[0]
    return {
        "u_max": float(-vz[k]), "t_u_max": float(t[k]), "gap_end": float(gap[-1]),
        "gap_end_D": float(gap[-1] / (2 * a)), "gap_min_D": float(gap.min() / (2 * a)),
        "v_end": float(speed[-1]), "vz_end": float(vz[-1]),
        "speed_last": float(np.max(speed[int(0.95 * len(t)):])),
        "t_land": float(t[near[0]]) if len(near) else float("nan"),
        "mass_change": float(np.max(np.abs(m - m[0])) / m[0]),
        "lateral_drift": float(np.max(np.hypot(d["position"][:, 0, 0] - d["position"][0, 0, 0],
                                               d["position"][:, 0, 1] - d["position"][0, 0, 1]))),
        "t": t, "vz": vz, "gap": gap,
    }


# --- wet restitution ----------------------------------------------------------------------------

def schiller_naumann_cd(re):
    return 24.0 / re * (1 + 0.15 * re ** 0.687)


def restitution_numerics(st, ratio, cells_per_d=None, u_lat=None):
    """Cells across the sphere and lattice velocity for a Stokes number (tau = 1/2 + 3 u D / Re):
    12 cells and u = 0.05 where that keeps tau in [0.51, 1.5]; a lower u at low Re (tau = 1.5);
    at high Re as many cells as tau >= 0.51 needs at u = 0.05 (30 at Re 450). The lattice
    velocity stays at 0.05: at 0.1 with tau 0.51 the free sphere blew up (models/README.md,
    "Wet restitution")."""
    re = 9.0 * st / ratio
    n = cells_per_d or 12
    u = u_lat or 0.05
    if u_lat is None and 0.5 + 3 * u * n / re > 1.5:
        u = re / (3 * n)
    if cells_per_d is None and 0.5 + 3 * u * n / re < 0.51 - 1e-12:
        n = max(n, int(math.ceil(0.01 * re / (3 * u) - 1e-9)))
    return n, u


def restitution_scene(st, ratio=10.0, cells_per_d=None, u_lat=None, lateral_d=4.0, start_gap_d=1.5):
    """A sphere (ratio = rho_p / rho_f) moving at u towards the no-slip floor of a box
    lateral_d D wide and start_gap_d + 2.5 D high, its lowest point start_gap_d D above the
    floor, at the Stokes number St (Re = 9 St / ratio sets the viscosity); gravity such that u
    is the sphere's terminal velocity in an unbounded fluid (Schiller-Naumann). SI units from
    D = 1 mm, water density and u = 0.05 m/s; cells and lattice velocity from
    restitution_numerics. Output every step (the contact lasts 10 steps)."""
    D = 1e-3
    rho_f = 1000.0
    u = 0.05
    re = 9.0 * st / ratio
    nu = u * D / re
    n, ul = restitution_numerics(st, ratio, cells_per_d, u_lat)
    dx = D / n
    dt = _whole_ns(ul * dx / u)
    nl = int(round(lateral_d * n))
    nz = int(round((start_gap_d + 2.5) * n))
    a = D / 2
    vol = math.pi / 6 * D ** 3
    # gravity: (rho_p - rho_f) V g = C_D (1/2) rho_f u^2 pi a^2
    g = schiller_naumann_cd(re) * 0.5 * rho_f * u * u * math.pi * a * a / ((ratio - 1) * rho_f * vol)
    # the fall, and the creep through the film at low St (e-folding 6 pi mu a^2 / W)
    t_creep = 6 * math.pi * nu * rho_f * a * a / ((ratio - 1) * rho_f * vol * g)
    end = 1.3 * start_gap_d * D / u + 8 * t_creep
    faces = {k: {"type": "no_slip"} for k in ("x_min", "x_max", "y_min", "y_max", "z_min", "z_max")}
    return {
        "domain": {"size": [_f(nl * dx), _f(nl * dx), _f(nz * dx)], "faces": faces},
        "fluid": {"density": rho_f, "viscosity": _f(nu), "dx": _f(dx), "dt": _f(dt)},
        "bodies": [{"name": "sphere", "density": _f(ratio * rho_f), "velocity": [0.0, 0.0, -u],
                    "spheres": [{"center": [_f(nl * dx / 2), _f(nl * dx / 2), _f(a + start_gap_d * D)],
                                 "radius": _f(a)}]}],
        "rigid": {"gravity": [0.0, 0.0, -_f(g)]},
        "run": {"end_time": _f(end), "output_interval": _f(dt)},
    }


def restitution_measure(d, scene):
    """Impact and rebound of the sphere of a restitution scene. Impact speed u_in: the approach
    speed at a gap of one diameter, before the wall slows it (the sphere started at its terminal
    velocity in an unbounded fluid; the box walls slow it somewhat on the way, so St is computed
    from u_in, not taken from the scene). The approach ends at the first row where the sphere
    moves up; the rebound speed u_out is the largest upward speed after that (0 when it never
    moves up). e = u_out / u_in. Also Re and St of u_in, the smallest gap and when, and the
    speed at a gap of 0.1 D on the way in."""
    fl, b = scene["fluid"], scene["bodies"][0]
    a = b["spheres"][0]["radius"]
    ratio = b["density"] / fl["density"]
    z = d["position"][:, 0, 2]
    vz = d["velocity"][:, 0, 2]
    gap = z - a
    kmin = int(np.argmin(gap))
    up = np.nonzero(vz > 0)[0]
    k_turn = int(up[0]) if len(up) else len(vz) - 1

    def speed_at(g):
        idx = np.nonzero(gap[:k_turn + 1] <= g)[0]
        return float(-vz[idx[0]]) if len(idx) else float("nan")

    u_in = speed_at(2 * a)
    u_out = float(vz[k_turn:].max()) if len(up) else 0.0
    re = u_in * 2 * a / fl["viscosity"]
    return {"u_in": u_in, "u_out": u_out, "e": u_out / u_in, "st": ratio * re / 9.0, "re": re, "ratio": ratio,
            "gap_min_D": float(gap.min() / (2 * a)), "t_contact": float(d["t"][kmin]),
            "u_at_01D": speed_at(0.2 * a), "t": d["t"], "vz": vz, "gap": gap}


def legendre(st):
    """e_wet / e_dry = exp(-35 / St) (Legendre, Daniel & Guiraud 2005, fit to Gondret et al. 2002
    and Joseph et al. 2001)."""
    return math.exp(-35.0 / st)


# --- command line -----------------------------------------------------------------------------


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("scene", help="write a settling scene")
    s.add_argument("case", choices=sorted(FLUIDS))
    s.add_argument("cells_per_d", type=int)
    s.add_argument("--height", type=float, help="box height (m), default 0.16")
    s.add_argument("--release-gap", type=float, default=RELEASE_GAP)
    s.add_argument("-o", "--output")
    r = sub.add_parser("report", help="summary of a settling output")
    r.add_argument("output")
    args = p.parse_args(argv)
    if args.cmd == "scene":
        sc = settling_scene(args.case, args.cells_per_d, args.height, args.release_gap)
        text = dump(sc, f"# ten Cate et al. (2002) case {args.case}, D = {args.cells_per_d} cells, "
                        f"tau = {tau_of(sc):.4f} (tests/python/settling_cases.py)\n")
        if args.output:
            with open(args.output, "w") as fh:
                fh.write(text)
        else:
            sys.stdout.write(text)
        return 0
    sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[2] / "coupler"))
    import h5out
    d = h5out.read(args.output)
    sc = d["scene"]
    m = settling_measure(d, sc)
    rho = sc["fluid"]["density"]
    case = min(FLUIDS, key=lambda c: abs(FLUIDS[c]["rho"] - rho))
    f = FLUIDS[case]
    print(f"{args.output}: settling, nearest ten Cate case {case}")
    print(f"  u_max {m['u_max']:.5f} m/s at t = {m['t_u_max']:.3f} s (experiment {f['u_max']:.5f}, "
          f"ratio {m['u_max'] / f['u_max']:.3f}; u_inf {f['u_inf']})")
    print(f"  landed (gap < 0.1 D) at t = {m['t_land']:.3f} s; final gap {m['gap_end_D']:+.4f} D "
          f"(smallest {m['gap_min_D']:+.4f} D), final speed {m['v_end']:.2e} m/s = "
          f"{m['v_end'] / m['u_max']:.2%} of u_max")
    print(f"  fluid mass change (largest) {m['mass_change']:.2e}; lateral drift {m['lateral_drift']:.2e} m")
    return 0


if __name__ == "__main__":
    sys.exit(main())
