#!/usr/bin/env python3
"""stability_map.py — where the coupled method breaks, what the program says when it does, and
whether the remedy it offers works: section 4 of `make report` (issue 14).

Every case is one `coupler run` that runs until it ends or a detector of a component stops it.
Its verdict comes from the coupler's messages only, never from the output file:

- **stable**: the run ended (exit 0) without a period-2 warning;
- **oscillates**: it ended, but the fluid's period-2 watch warned (README "Coupling");
- **detected**: a component stopped the run with an error; the reason is the message's cause
  text (whatever detector it was: non-finite or non-positive density, Mach limit, a sphere that
  moves too far in a step, an unstable or too soft contact, ...). The parsing is generic on
  purpose: a new detector shows up here with its own words and needs no change in this file;
- **crashed**: the run ended without exit 0 and without an error message (a signal, an abort);
- **timed out**: the run did not end within its wall-time limit.

A message that ends in a remedy ("...: reduce dt (fluid.tau) or the velocity", "Remedies: ...",
"; use more substeps or the cvode BDF integrator") is split into cause and remedy, the remedy is
translated into changes of the case (`REMEDIES`: a `--set` or a case parameter per option, in the
order the message gives them, skipping options that would not change the case) and the case is
run again with each in turn until one runs stably (at most three). A message without a remedy
gets the README's advice for the limits of the lattice (more cells per radius at the same
Reynolds number), marked as not offered by the program. Quick mode reruns one case per class of
failure (group, verdict, cause, remedy, control); the full map every unstable case, except that
lattice-limit cases (the control fails too) share one rerun per radius, tau and velocity.

The free sphere (the set-up of the README's stability table and of the periodic settling test
against Sangani & Acrivos 1982): one sphere of radius a cells
in a periodic box of 8 a, started at the requested lattice velocity u and driven by gravity that
makes u its terminal velocity (Stokes drag, Sangani-Acrivos factor for D/L = 1/4, Schiller &
Naumann 1933 Reynolds correction); a counter body force on the fluid keeps the system as a whole
from accelerating. Density ratio 1 has no net weight: the sphere coasts from u. Starting at u
instead of from rest puts the fluid's velocity limits in the first few hundred steps (from rest,
a sphere at tau 0.51 needs thousands of steps to reach u). A case that is not stable is run
again as a control with the same motion prescribed (no coupling at all): when the control
fails too, the limit is the lattice's at that tau and speed ("fluid limit"), not the coupling's.

Slices (not the full product, which is ~900 cases per coupling; a fourth, the flow's speed:
a free sphere in a plane Couette flow with walls at +-u, tau x u, control: the sphere fixed):
- density ratio x tau at radius 3 cells, u = 0.05: the coupling's limit (the added-mass
  instability of explicitly coupled light particles, which Ladd & Verberg, J. Stat. Phys. 104
  (2001) 1191, remove with an implicit particle update) against the lattice's (tau -> 1/2);
- lattice velocity x tau at density ratio 2, radius 3: the lattice's limit (cell Reynolds number
  u / nu, Mach number) for a particle that the coupling handles;
- radius x density ratio at tau 0.6, u = 0.05: how small and how light a sphere can be.
Contacts, on a coarse fluid (the rigid FMU always runs with the fluid: there is no rigid-only
run), for Verlet and CVODE BDF:
- a sphere (density ratio 1000: a dry impact, Stokes number ~200) moving at u = 0.05 towards a
  no-slip floor, contact time from soft (100 fluid steps) to a tenth of a step; Verlet's limit
  is h sqrt(k/m) <= 1, i.e. t_c >= ~3.2 h (rigid/integrator_verlet.c);
- a sphere (density ratio 2) resting on the floor under gravity, sliding at u = 0.05, friction
  0.3, contact time 10, 1 and 0.1 steps;
- two spheres (ratio 2, radius 3) approaching each other at 0.05 each from a gap of 2 cells to
  below one cell: contacts with lubrication (the default), without it, and no contact model.
Every case for the default coupling (`rigid.coupling: auto`) and the alternatives: implicit and
explicit, each with and without `fluid.force_averaging`; 600 steps (contacts 400). Quick mode:
auto and explicit only (auto only for velocity x tau and the flow slice; the full map runs the flow
slice for auto and explicit), six density ratios in the radius slice,
contact times 10, 1, 0.1 steps, 300 steps (contacts 200).

Usage: tools/stability_map.py OUTDIR [--quick] [--jobs N] [--coupler PATH]
writes OUTDIR/stability.csv, OUTDIR/stability_*.png and OUTDIR/stability.md; `run_map` is the
function `make report` calls.
"""
import argparse
import concurrent.futures as cf
import csv
import math
import os
import re
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
COUPLER = os.path.join(ROOT, "build", "coupler")

RHO_F, NU, DX = 1000.0, 1.0e-6, 1.0e-3   # the free sphere: water, 1 mm cells

# Coupling variants: label -> --set options. "auto" is the default (no key set).
COUPLINGS = {
    "auto": [],
    "implicit": ["rigid.coupling=implicit", "fluid.force_averaging=true"],
    "implicit, no averaging": ["rigid.coupling=implicit", "fluid.force_averaging=false"],
    "explicit": ["rigid.coupling=explicit", "fluid.force_averaging=false"],
    "explicit + averaging": ["rigid.coupling=explicit", "fluid.force_averaging=true"],
}

TAUS = [0.5001, 0.501, 0.51, 0.55, 1.0, 2.0, 3.0]
RATIOS = [0.1, 0.3, 0.5, 1.0, 1.2, 2.0, 10.0, 1000.0]
SPEEDS = [0.01, 0.05, 0.1, 0.2, 0.3]
RADII = [1.5, 2.0, 3.0, 5.0]
FLOW_SLICE = "flow velocity x tau"  # the free-sphere slice whose speed is the flow's (shear_scene)
VERDICTS = ["stable", "oscillates", "detected", "crashed", "timed out"]
COLOURS = {"stable": "#4daf4a", "oscillates": "#ff9f1c", "detected": "#e41a1c", "crashed": "#222222",
           "timed out": "#9e9e9e"}


# --- scenes ------------------------------------------------------------------------------------

FREE = """domain:
  size: [{L!r}, {L!r}, {L!r}]
fluid:
  density: {rho_f!r}
  viscosity: {nu!r}
  dx: {dx!r}
  tau: {tau!r}
  body_force: [0, 0, {fb!r}]
bodies:
  - density: {rho_p!r}{motion}
    velocity: [0, 0, {v0!r}]
    spheres:
      - {{center: [{c!r}, {c!r}, {c!r}], radius: {a!r}}}
rigid:
  gravity: [0, 0, {g!r}]
run:
  end_time: {t_end!r}
  output_interval: {t_out!r}
"""


def case_numbers(a_cells, tau, u_lat):
    """SI numbers of a free-sphere case (dx = 1 mm, water): the step, the box (8 radii), the
    sphere, its speed and its expected drag (Stokes drag times the Sangani & Acrivos (1982)
    array factor K(D/L = 1/4) ~ 1.5 and the Schiller & Naumann Reynolds correction)."""
    dt = (tau - 0.5) * DX * DX / (3.0 * NU)
    L, a = 8 * a_cells * DX, a_cells * DX
    u = u_lat * DX / dt
    re = 2.0 * a * u / NU
    drag = 6.0 * math.pi * RHO_F * NU * a * u * 1.5 * (1.0 + 0.15 * re ** 0.687)
    return dict(dx=DX, dt=dt, rho_f=RHO_F, L=L, a=a, u=u, vol=4.0 / 3.0 * math.pi * a ** 3, drag=drag)


def case_scene(a_cells, ratio, tau, u_lat, steps, start="rest", prescribed=False):
    """Scene text of a free sphere settling (ratio > 1) or rising (ratio < 1) in a periodic box
    at terminal lattice velocity u_lat, from rest or (start="terminal") from u_lat. Ratio 1:
    no net weight, the sphere coasts from u_lat. prescribed: the control, the same sphere moving
    at u_lat with its motion prescribed through fluid pushed by a body force equal to its drag
    per fluid volume, so that the fluid as a whole does not accelerate."""
    k = case_numbers(a_cells, tau, u_lat)
    vol, L = k["vol"], k["L"]
    sign = -1.0 if ratio >= 1.0 else 1.0     # down when heavy (and for ratio 1), up when light
    if abs(ratio - 1.0) < 1e-9:
        g, fb = 0.0, 0.0
    else:
        g = -k["drag"] / (abs(ratio - 1.0) * RHO_F * vol)
        weight = (ratio - 1.0) * RHO_F * vol * g   # net weight of the sphere (N, z)
        fb = -weight / (L ** 3 - vol)               # counter body force on the fluid (N/m^3)
    v0 = sign * k["u"] if (start == "terminal" or prescribed) else 0.0
    motion = ""
    if prescribed:
        motion, g = "\n    motion: prescribed", 0.0
        fb = sign * k["drag"] / (L ** 3 - vol)
    return FREE.format(L=L, rho_f=RHO_F, nu=NU, dx=k["dx"], tau=tau, fb=fb, rho_p=ratio * RHO_F, motion=motion,
                       v0=v0, c=L / 2, a=k["a"], g=g, t_end=1.001 * steps * k["dt"],
                       t_out=steps * k["dt"] / 10)


SHEAR = """domain:
  size: [{L!r}, {L!r}, {L!r}]
  faces: {{z_min: {{type: moving_wall, velocity: [{mu!r}, 0, 0]}}, z_max: {{type: moving_wall, velocity: [{u!r}, 0, 0]}}}}
fluid: {{density: {rho_f!r}, viscosity: {nu!r}, dx: {dx!r}, tau: {tau!r}, initial_profile: plane_channel}}
bodies:
  - density: {rho_p!r}
    motion: {motion}
    spheres:
      - {{center: [{c!r}, {c!r}, {cz!r}], radius: {a!r}}}
rigid: {{gravity: [0, 0, 0]}}
run: {{end_time: {t_end!r}, output_interval: {t_out!r}}}
"""


def shear_scene(a_cells, ratio, tau, u_lat, steps, fixed=False):
    """Scene text of the flow slice: a sphere (free, or fixed for the control) a quarter radius
    off the centre of a plane Couette flow between no-slip walls moving at +-u_lat (lattice), x
    and y periodic, a box of 8 radii started in the steady shear profile: the speed of the flow
    relative to the grid is u_lat at the walls, whatever the particle does."""
    dt = (tau - 0.5) * DX * DX / (3.0 * NU)
    L, a, u = 8 * a_cells * DX, a_cells * DX, u_lat * DX / dt
    return SHEAR.format(L=L, mu=-u, u=u, rho_f=RHO_F, nu=NU, dx=DX, tau=tau, rho_p=ratio * RHO_F,
                        motion="fixed" if fixed else "free", c=L / 2, cz=L / 2 + 0.25 * a, a=a,
                        t_end=1.001 * steps * dt, t_out=steps * dt / 10)


def control_scene(a_cells, ratio, tau, u_lat, steps, start="rest"):
    """The control of a case: its motion prescribed (see case_scene)."""
    return case_scene(a_cells, ratio, tau, u_lat, steps, start, prescribed=True)


WALLS = """domain:
  size: [{Lx!r}, {Ly!r}, {Lz!r}]
  faces: {{z_min: {{type: no_slip}}, z_max: {{type: no_slip}}}}
fluid: {{density: {rho_f!r}, viscosity: {nu!r}, dx: {dx!r}, tau: {tau!r}}}
bodies:
{bodies}contacts: {contacts}
rigid: {{gravity: [0, 0, {g!r}], integrator: {integrator}}}
run: {{end_time: {t_end!r}, output_interval: {t_out!r}}}
"""

WALL_DX, WALL_TAU = 1.0e-4, 0.8     # 100 um cells, dt = 1 ms


def wall_scene(kind, p, steps):
    """Scene text of a contact case (x, y periodic, no-slip floor and ceiling; 100 um cells,
    water, tau 0.8): kind "drop" (a sphere of radius 2 cells and density ratio 1000 moving at
    p["u"] towards the floor from a gap of 2 cells, gravity 1e-3 lattice), "slide" (radius 2,
    ratio 2, resting on the floor, sliding along x at p["u"], friction 0.3) or "approach" (two
    spheres of radius 3, ratio 2, moving towards each other at p["u"] each from a gap of 2
    cells). p["tc"]: contact time in fluid steps; p["contacts"]: "lubrication" (the default),
    "no lubrication" or "none" (no contact model)."""
    dx, tau = WALL_DX, WALL_TAU
    dt = (tau - 0.5) * dx * dx / (3.0 * NU)
    u = p["u"] * dx / dt
    g = -1e-3 * dx / dt ** 2
    if kind == "drop":
        n, r, ratio = (8, 8, 16), 2.0, 1000.0
        bodies = [(ratio, [0, 0, -u], [(4.0, 4.0, r + 2.0)])]
    elif kind == "slide":
        n, r, ratio = (16, 8, 8), 2.0, 2.0
        bodies = [(ratio, [u, 0, 0], [(4.0, 4.0, r)])]
    else:
        n, r, ratio = (24, 12, 14), 3.0, 2.0
        bodies = [(ratio, [u, 0, 0], [(12.0 - r - 1.0, 6.0, 7.0)]), (ratio, [-u, 0, 0], [(12.0 + r + 1.0, 6.0, 7.0)])]
        g = 0.0
    text = ""
    for rho, v, centres in bodies:
        text += "  - density: %r\n    velocity: [%r, %r, %r]\n    spheres:\n" % (rho * RHO_F, v[0], v[1], v[2])
        for c in centres:
            text += "      - {center: [%r, %r, %r], radius: %r}\n" % (c[0] * dx, c[1] * dx, c[2] * dx, r * dx)
    contacts = p.get("contacts", "lubrication")
    if contacts == "none":
        cont = "{model: none}"
    else:
        cont = "{model: spring_dashpot, contact_time: %r%s%s}" % (
            p["tc"] * dt, ", friction: 0.3" if kind == "slide" else "",
            ", lubrication: {enabled: false}" if contacts == "no lubrication" else "")
    return WALLS.format(Lx=n[0] * dx, Ly=n[1] * dx, Lz=n[2] * dx, rho_f=RHO_F, nu=NU, dx=dx, tau=tau, bodies=text,
                        contacts=cont, g=g, integrator=p.get("integrator", "verlet"),
                        t_end=1.001 * steps * dt, t_out=steps * dt / 10)


# --- one case ----------------------------------------------------------------------------------

class Case:
    """One run: its group and parameters, how to write its scene, and the --set options (the
    coupling and the remedy's). scene(p) -> text; p holds the parameters a remedy may change."""

    def __init__(self, group, params, sets, steps):
        self.group, self.p, self.sets, self.steps = group, dict(params), list(sets), steps

    def scene(self):
        p = self.p
        if self.group == "free:" + FLOW_SLICE:
            return shear_scene(p["radius"], p["ratio"], p["tau"], p["u"], self.steps)
        if self.group.startswith("free"):
            return case_scene(p["radius"], p["ratio"], p["tau"], p["u"], self.steps, start="terminal")
        return wall_scene(self.group, p, self.steps)

    def cells(self):
        """Cell updates of the run: the estimate of its cost."""
        if self.group.startswith("free"):
            n = 8 * self.p["radius"] * DX / self.p.get("dx", DX)
            return n ** 3 * self.steps
        return 2000 * self.steps


def first_error(stderr):
    """The first error line of a component that names a cause (the FMI and master lines that only
    say that a step failed are skipped), without its prefixes."""
    generic = ("fmi2DoStep", "returned fmi2", "[run]", "in this communication step failed", "[fmu]")
    for line in stderr.splitlines():
        if line.startswith("error:") and not any(g in line for g in generic):
            return strip_prefix(line)
    for line in stderr.splitlines():
        if line.startswith("error:"):
            return strip_prefix(line)
    return ""


def strip_prefix(line):
    """'error: [fluid.fmu] fluid.fmu [logStatusError] [fluid] /tmp/.../scene.yaml: text' -> 'text'."""
    s = re.sub(r"^(error|warning):\s*", "", line)
    s = re.sub(r"^(\[[^\]]*\]\s*|\S+\.fmu\s+)*", "", s)
    return re.sub(r"^\S*\.yaml:\s*", "", s).strip()


REMEDY_START = re.compile(r"(\bRemed(?:y|ies)\s*:\s*|[:;]\s+(?=(?:use|set|reduce|shorten|raise|lower|increase|"
                          r"decrease|try|give|choose|refine|make)\b))")


def split_remedy(message):
    """(cause, remedy) of a message: the remedy is what follows 'Remedies:' or the first ': verb'
    / '; verb' (use, set, reduce, shorten, raise, lower, ...); '' when the message offers none."""
    m = REMEDY_START.search(message)
    if not m:
        return message.strip(), ""
    return message[:m.start()].strip().rstrip(".,;:"), message[m.end():].strip().rstrip(".")


def parse_outcome(returncode, stderr, timed_out=False):
    """(verdict, cause, remedy) of a run from its exit status and messages (module docstring)."""
    warned = [strip_prefix(l) for l in stderr.splitlines() if l.startswith("warning:") and "period-2" in l]
    if timed_out:
        return "timed out", "no end within the wall-time limit", ""
    if returncode == 0:
        if warned:
            cause, remedy = split_remedy(warned[0])
            return "oscillates", cause, remedy
        return "stable", "", ""
    msg = first_error(stderr)
    if not msg or returncode < 0:
        return "crashed", ("signal %d" % -returncode) if returncode < 0 else "exit %d, no message" % returncode, ""
    cause, remedy = split_remedy(msg)
    if warned:
        cause += " (after a period-2 warning)"
        if not remedy:
            remedy = split_remedy(warned[0])[1]
    return "detected", cause, remedy


def run_text(text, sets, steps, coupler, timeout):
    """(verdict, cause, remedy, seconds, warnings) of one run of the scene text."""
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "case.yaml")
        with open(path, "w") as f:
            f.write(text)
        cmd = [coupler, "run", path, "-o", os.path.join(tmp, "out.h5"), "--quiet", "--steps", str(steps)]
        for s in sets:
            cmd += ["--set", s]
        env = dict(os.environ, OMP_NUM_THREADS="1")
        t0 = time.time()
        try:
            p = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=timeout)
            rc, err, late = p.returncode, p.stderr, False
        except subprocess.TimeoutExpired as e:
            rc, err, late = -9, (e.stderr or b"").decode() if isinstance(e.stderr, bytes) else (e.stderr or ""), True
        seconds = time.time() - t0
    verdict, cause, remedy = parse_outcome(rc, err, late)
    others = sorted({re.sub(r"[0-9][0-9.e+-]*", "#", strip_prefix(l))[:80] for l in err.splitlines()
                     if l.startswith("warning:") and "period-2" not in l})
    return verdict, cause, remedy, seconds, "; ".join(others)


def label(cause):
    """A short label of a cause for a table cell: the known detectors by a keyword, anything else
    by its first words (so that a new detector still gets a readable label)."""
    known = [("period-2", "period-2"), ("non-finite", "NaN"), ("non-positive density", "rho<=0"),
             ("Mach", "Mach"), ("cells in one step", "moves"), ("half a cell", "moves"),
             ("unstable contact", "h*omega"), ("overlap", "overlap"), ("reached face", "wall"),
             ("energy", "energy"), ("cvode", "cvode"), ("leav", "leaves")]
    cause = cause.split(" (after a period-2")[0]
    for key, short in known:
        if key.lower() in cause.lower():
            return short
    words = re.sub(r"[^A-Za-z ]", " ", cause).split()
    return " ".join(words[:2])[:14] if words else "?"


# --- remedies ----------------------------------------------------------------------------------

def _set(case, key, value):
    case.sets = [s for s in case.sets if not s.startswith(key + "=")] + ["%s=%s" % (key, value)]


def _get(case, key, default):
    for s in reversed(case.sets):
        if s.startswith(key + "="):
            return s.split("=", 1)[1]
    return default


def _coupling(case, remedy, msg):
    if _get(case, "rigid.coupling", "auto") == "implicit" and _get(case, "fluid.force_averaging", "true") == "true":
        return None
    if _get(case, "rigid.coupling", "auto") == "auto" and _get(case, "fluid.force_averaging", "") == "":
        if case.group.startswith("free") and kappa(case.p["radius"], case.p["ratio"]) >= 0.025:
            return None   # auto already chose implicit with averaging
    _set(case, "rigid.coupling", "implicit")
    _set(case, "fluid.force_averaging", "true")
    return "rigid.coupling=implicit, fluid.force_averaging=true"


def _substeps(case, remedy, msg):
    m = re.search(r"is ([0-9.e+-]+), limit ([0-9.e+-]+)", msg)
    n = int(_get(case, "rigid.substeps", "1"))
    new = max(2 * n, int(math.ceil(1.25 * n * float(m.group(1)) / float(m.group(2))))) if m else 4 * n
    _set(case, "rigid.substeps", new)
    return "rigid.substeps=%d" % new


def _cvode(case, remedy, msg):
    if case.p.get("integrator", "verlet") == "cvode" or _get(case, "rigid.integrator", "") == "cvode":
        return None
    _set(case, "rigid.integrator", "cvode")
    _set(case, "rigid.cvode_method", "bdf")
    return "rigid.integrator=cvode (BDF)"


def _contact_time(case, remedy, msg):
    if "tc" not in case.p:
        return None
    case.p["tc"] /= 4.0
    return "contacts.contact_time / 4"


def _contact_model(case, remedy, msg):
    if case.p.get("contacts") != "none":
        return None
    case.p["contacts"] = "lubrication"
    case.p.setdefault("tc", 10.0)
    return "contacts.model=spring_dashpot"


def _time_step(case, remedy, msg):
    """Half the step at the same physics (tau - 1/2 halves; twice the steps), or twice the step
    when the words before the option ask for more (raise, increase, larger, higher tau)."""
    tau = float(_get(case, "fluid.tau", case.p.get("tau", WALL_TAU)))
    up = re.search(r"\b(raise|increase|larger|higher|bigger)\b", remedy) is not None
    new = 0.5 + (2.0 if up else 0.5) * (tau - 0.5)
    _set(case, "fluid.tau", repr(new))
    case.steps = max(1, case.steps // 2) if up else case.steps * 2
    return "fluid.tau=%.6g (%s the step)" % (new, "twice" if up else "half")


def _velocity(case, remedy, msg):
    case.p["u"] /= 2.0
    return "velocity / 2"


def _refine(case, remedy, msg):
    """Twice the cells per radius at the same physics and tau: dt / 4, the lattice velocity / 2;
    the rerun covers the first half of the case's time (2x its steps) to bound its cost (x16)."""
    dx = float(_get(case, "fluid.dx", DX if case.group.startswith("free") else WALL_DX))
    _set(case, "fluid.dx", repr(dx / 2))
    case.p["dx"] = dx / 2
    case.steps *= 2
    return "fluid.dx / 2 (first half of the time)"


# Remedy phrases of the messages -> the change they ask for (tried in the order of the message).
REMEDIES = [
    (r"rigid\.coupling|force_averaging", _coupling),
    (r"substeps", _substeps),
    (r"cvode", _cvode),
    (r"contact_time", _contact_time),
    (r"contacts\.model", _contact_model),
    (r"fluid\.dx|cells per radius|resolution", _refine),
    (r"\bdt\b|time step|fluid\.tau", _time_step),
    (r"velocity", _velocity),
]
README_REMEDY = "more cells per radius at the same Reynolds number (README, stability map)"


def remedy_options(case, remedy, message):
    """[(description of the change, the changed case)] for the options of the remedy text that
    change this case, in the order the message gives them; with no remedy text, README_REMEDY
    (marked as not the program's)."""
    if not remedy:
        new = Case(case.group, case.p, case.sets, case.steps)
        return [("(none offered; README:) " + _refine(new, "", message), new)]
    found = sorted((m.start(), i) for i, (pat, fn) in enumerate(REMEDIES) for m in [re.search(pat, remedy)] if m)
    out = []
    for pos, i in found:
        trial = Case(case.group, case.p, case.sets, case.steps)
        # the option's own words: from the last separator before it (its verb) to its end
        start = max(remedy.rfind(sep, 0, pos) for sep in (",", ";", " or ", "Remedies:"))
        change = REMEDIES[i][1](trial, remedy[max(0, start):pos + 40], message)
        if change:
            out.append((change, trial))
    return out


def kappa(a_cells, ratio):
    """The explicit feedback number of a sphere (models/README.md, rigid.coupling)."""
    return 4 * math.pi * a_cells ** 2 * (1 + 2 * math.sqrt(2)) / 6 / (ratio * 4 / 3 * math.pi * a_cells ** 3)


# --- the map -----------------------------------------------------------------------------------

def plan(quick):
    """The cases of the map: (slice name, Case)."""
    steps = 300 if quick else 600
    couplings_all = list(COUPLINGS)
    few = ["auto", "explicit"]
    cases = []

    def free(slice_name, a, ratio, tau, u, coupling):
        p = dict(radius=a, ratio=ratio, tau=tau, u=u, coupling=coupling)
        cases.append(Case("free:" + slice_name, p, COUPLINGS[coupling], steps))

    for c in (few if quick else couplings_all):
        for r in RATIOS:
            for t in TAUS:
                free("ratio x tau", 3.0, r, t, 0.05, c)
    for c in (["auto"] if quick else couplings_all):
        for u in SPEEDS:
            for t in TAUS:
                free("velocity x tau", 3.0, 2.0, t, u, c)
    for c in (["auto"] if quick else few):
        for u in SPEEDS:
            for t in TAUS:
                free(FLOW_SLICE, 3.0, 1.2, t, u, c)
    for c in (few if quick else couplings_all):
        for a in RADII:
            for r in ([0.1, 0.3, 0.5, 1.2, 2.0, 10.0] if quick else RATIOS):
                free("radius x ratio", a, r, 0.6, 0.05, c)
    wall_steps = 200 if quick else 400
    tcs = [10.0, 1.0, 0.1] if quick else [100.0, 10.0, 3.0, 1.0, 0.3, 0.1]
    for c in (few if quick else couplings_all):
        for integ in ("verlet", "cvode"):
            for tc in tcs:
                p = dict(u=0.05, tc=tc, integrator=integ, coupling=c, variant="t_c = %g steps" % tc)
                cases.append(Case("drop", p, COUPLINGS[c] + ["rigid.cvode_method=bdf"], wall_steps))
            for tc in ([10.0, 0.1] if quick else [10.0, 1.0, 0.1]):
                p = dict(u=0.05, tc=tc, integrator=integ, coupling=c, variant="t_c = %g steps" % tc)
                cases.append(Case("slide", p, COUPLINGS[c] + ["rigid.cvode_method=bdf"], wall_steps))
            for cont in ("lubrication", "no lubrication", "none"):
                p = dict(u=0.05, tc=10.0, integrator=integ, coupling=c, contacts=cont, variant=cont)
                cases.append(Case("approach", p, COUPLINGS[c] + ["rigid.cvode_method=bdf"], wall_steps))
    return cases


def _run_case(args):
    case, coupler, timeout = args
    return run_text(case.scene(), case.sets, case.steps, coupler, timeout)


def _pmap(fn, items, jobs):
    with cf.ThreadPoolExecutor(max(1, jobs)) as ex:
        return list(ex.map(fn, items))


def run_cases(cases, coupler, jobs, timeout):
    """Runs the cases (most expensive first, to keep both workers busy to the end) and stores each
    outcome on its case."""
    order = sorted(range(len(cases)), key=lambda i: -cases[i].cells())
    res = _pmap(_run_case, [(cases[i], coupler, timeout) for i in order], jobs)
    for i, r in zip(order, res):
        cases[i].verdict, cases[i].cause, cases[i].remedy, cases[i].seconds, cases[i].warnings = r


def run_controls(cases, coupler, jobs, timeout):
    """The prescribed-motion control of every free-sphere case that is not stable, once per
    (radius, tau, u): it does not depend on the density ratio or the coupling. For the flow
    slice the control holds the sphere fixed in the same flow."""
    def key(c):
        return (c.group == "free:" + FLOW_SLICE, c.p["radius"], c.p["tau"], c.p["u"], c.steps)

    def control_text(k):
        if k[0]:   # the flow slice: the same flow past the sphere held fixed
            return shear_scene(k[1], 1.0, k[2], k[3], k[4], fixed=True)
        return control_scene(k[1], 2.0, k[2], k[3], k[4], start="terminal")
    keys = sorted({key(c) for c in cases if c.group.startswith("free") and c.verdict != "stable"})
    res = _pmap(lambda k: run_text(control_text(k), [], k[4], coupler, timeout), keys, jobs)
    control = dict(zip(keys, res))
    for c in cases:
        c.control = ""
        if c.group.startswith("free") and c.verdict != "stable":
            v = control[key(c)]
            c.control = "fluid limit" if v[0] in ("detected", "crashed") else "coupling"


def case_class(c):
    """The class of an unstable case: group kind, verdict, cause label, the remedy's words and,
    for the free sphere, whether the control failed too."""
    return (c.group.split(":")[0], c.verdict, label(c.cause), re.sub(r"[0-9][0-9.e+-]*", "#", c.remedy),
            getattr(c, "control", ""))


def _rerun_key(c, quick):
    """Cases that share a key share their reruns. Quick: the class. Full: the class and the case,
    except that cases whose control failed too (a fluid limit: the coupling plays no part) share
    per (radius, tau, u)."""
    key = case_class(c)
    if quick:
        return key
    if c.control == "fluid limit":
        return key + (c.p["radius"], c.p["tau"], c.p["u"])
    return key + tuple(sorted((k, str(v)) for k, v in c.p.items()))


def _try_remedies(args):
    """Runs the case with the options of its remedy in turn until one is stable (at most
    MAX_OPTIONS): [(change, (verdict, cause, ...))]."""
    c, coupler, timeout = args
    chain = []
    options = remedy_options(c, c.remedy, c.cause + ": " + c.remedy)
    for change, new in options[:MAX_OPTIONS]:
        r = _run_case((new, coupler, timeout))
        chain.append((change, r))
        if r[0] == "stable":
            break
    return chain


MAX_OPTIONS = 3


def run_remedies(cases, coupler, jobs, timeout, quick):
    """Reruns the unstable cases with the remedy their message offers (the options in turn until
    one works): once per rerun key (_rerun_key), on the key's cheapest case."""
    todo = {}
    for c in cases:
        c.chain, c.rerun_of = [], None
        if c.verdict != "stable":
            k = _rerun_key(c, quick)
            if k not in todo or c.cells() < todo[k].cells():
                todo[k] = c
    keys = sorted(todo, key=lambda k: -todo[k].cells())
    chains = dict(zip(keys, _pmap(_try_remedies, [(todo[k], coupler, timeout) for k in keys], jobs)))
    for c in cases:
        if c.verdict != "stable":
            k = _rerun_key(c, quick)
            c.chain, c.rerun_of = chains[k], todo[k]


def chain_text(chain):
    if not chain:
        return "no option of the remedy applies"
    return "; ".join("%s: %s%s" % (ch, r[0], "" if r[0] == "stable" else " (%s)" % label(r[1])) for ch, r in chain)


# --- output ------------------------------------------------------------------------------------

CSV_FIELDS = ["group", "radius_cells", "density_ratio", "tau", "u_lattice", "coupling", "integrator", "variant",
              "steps", "verdict", "cause", "remedy", "control", "remedy_applied", "rerun_verdict", "rerun_cause",
              "seconds", "other_warnings"]


def write_csv(path, cases):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(CSV_FIELDS)
        for c in cases:
            p = c.p
            last = c.chain[-1][1] if c.chain else None
            w.writerow([c.group, p.get("radius", ""), p.get("ratio", ""), p.get("tau", WALL_TAU), p["u"],
                        p.get("coupling", ""), p.get("integrator", "verlet"), p.get("variant", ""), c.steps,
                        c.verdict, c.cause, c.remedy, c.control,
                        chain_text(c.chain) if c.verdict != "stable" else "",
                        last[0] if last else "", last[1] if last else "", "%.2f" % c.seconds, c.warnings])


def _legend(fig):
    import matplotlib.patches as mpatches
    handles = [mpatches.Patch(facecolor=COLOURS[v], edgecolor="k", label=v) for v in VERDICTS]
    handles.append(mpatches.Patch(facecolor="white", edgecolor="k", hatch="///",
                                  label="fluid limit (the prescribed motion fails too)"))
    fig.legend(handles=handles, loc="lower center", ncol=3, fontsize=8, frameon=False)


def _grid(ax, cells, xs, ys, xlabel, ylabel, title):
    """One coloured table: cells[(x, y)] = case; a cell shows the verdict colour and the cause
    label ("after p2": the period-2 watch warned before), hatched where the control (prescribed
    motion) failed too."""
    import matplotlib.patches as mpatches
    for i, x in enumerate(xs):
        for j, y in enumerate(ys):
            c = cells.get((x, y))
            if c is None:
                continue
            hatch = "///" if getattr(c, "control", "") == "fluid limit" else None
            ax.add_patch(mpatches.Rectangle((i, j), 1, 1, facecolor=COLOURS[c.verdict], edgecolor="white",
                                            hatch=hatch, linewidth=1))
            if c.verdict != "stable":
                text = label(c.cause)
                if "after a period-2" in c.cause:
                    text += "\nafter p2"
                ax.text(i + 0.5, j + 0.5, text, ha="center", va="center", fontsize=6,
                        color="white" if c.verdict in ("detected", "crashed") else "black")
    ax.set_xlim(0, len(xs))
    ax.set_ylim(0, len(ys))
    ax.set_xticks([i + 0.5 for i in range(len(xs))])
    ax.set_xticklabels([("%g" % x) if isinstance(x, float) else str(x) for x in xs], fontsize=7,
                       rotation=30 if max(len(str(x)) for x in xs) > 6 else 0)
    ax.set_yticks([j + 0.5 for j in range(len(ys))])
    ax.set_yticklabels([("%g" % y) if isinstance(y, float) else str(y) for y in ys], fontsize=7)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=9)


def free_figure(path, cases, slice_name, xkey, ykey, xlabel, ylabel, fixed):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    sel = [c for c in cases if c.group == "free:" + slice_name]
    couplings = [k for k in COUPLINGS if any(c.p["coupling"] == k for c in sel)]
    xs = sorted({c.p[xkey] for c in sel})
    ys = sorted({c.p[ykey] for c in sel})
    fig, axs = plt.subplots(1, len(couplings), figsize=(max(3.3 * len(couplings) + 0.8, 6.5), 0.35 * len(ys) + 2.2),
                            squeeze=False)
    for ax, k in zip(axs[0], couplings):
        cells = {(c.p[xkey], c.p[ykey]): c for c in sel if c.p["coupling"] == k}
        _grid(ax, cells, xs, ys, xlabel, ylabel, "coupling: %s%s" % (k, " (default)" if k == "auto" else ""))
    fig.suptitle("Free sphere in %s: %s (%s)" % ("a plane shear flow" if slice_name == FLOW_SLICE else
                                                   "a periodic box", slice_name, fixed), fontsize=10)
    _legend(fig)
    fig.tight_layout(rect=(0, 0.12, 1, 0.95))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def contact_figure(path, cases):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    sel = [c for c in cases if not c.group.startswith("free")]
    rows = []
    for c in sel:
        r = "%s: %s" % (c.group, c.p["variant"])
        if r not in rows:
            rows.append(r)
    cols = []
    for c in sel:
        k = "%s / %s" % (c.p["integrator"], c.p["coupling"])
        if k not in cols:
            cols.append(k)
    cells = {("%s / %s" % (c.p["integrator"], c.p["coupling"]), "%s: %s" % (c.group, c.p["variant"])): c for c in sel}
    fig, ax = plt.subplots(figsize=(1.0 * len(cols) + 3.2, 0.32 * len(rows) + 2.4))
    _grid(ax, cells, cols, rows[::-1], "integrator / coupling", "case (contact time t_c in fluid steps)",
          "Contacts: drop on a floor (density ratio 1000), slide along it (ratio 2,\nfriction 0.3), "
          "two spheres approaching to below one cell (ratio 2)")
    _legend(fig)
    fig.tight_layout(rect=(0, 0.1, 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _count(cases, pred=lambda c: True):
    sel = [c for c in cases if pred(c)]
    n = {v: sum(1 for c in sel if c.verdict == v) for v in VERDICTS}
    return len(sel), n


def _fmt_counts(total, n):
    return "%d of %d stable, %d oscillate, %d detected, %d crashed%s" % (
        n["stable"], total, n["oscillates"], n["detected"], n["crashed"],
        (", %d timed out" % n["timed out"]) if n["timed out"] else "")


def _where(c):
    p = c.p
    if c.group.startswith("free"):
        return "%sa %g, ratio %g, tau %g, u %g, %s" % ("shear flow, " if c.group == "free:" + FLOW_SLICE else "",
                                                      p["radius"], p["ratio"], p["tau"], p["u"], p["coupling"])
    return "%s %s, %s, %s" % (c.group, p["variant"], p["integrator"], p["coupling"])


def figure_name(slice_name):
    """The PNG of a free-sphere slice: "velocity x tau" -> stability_velocity_tau.png, no blanks
    (a Markdown image link ends at the first blank)."""
    return "stability_" + re.sub(r"\s+", "_", slice_name.replace(" x ", "_")) + ".png"


def markdown(cases, figures, quick, wall):
    free = [c for c in cases if c.group.startswith("free")]
    walls = [c for c in cases if not c.group.startswith("free")]
    L = ["## 4. Stability map", ""]
    L.append(
        "Each case runs until it ends or a detector of a component stops it; the verdict and its reason are taken "
        "from the coupler's messages: **stable** (ended, no warning), **oscillates** (ended, but the fluid's "
        "period-2 watch warned), **detected** (a component stopped the run and named the cause), **crashed** "
        "(stopped without a message), **timed out**. Every case that is not stable is run again with the remedy "
        "its message offers. `tools/stability_map.py` (its docstring gives the set-up and the sources); %s mode, "
        "%d runs, %.0f s wall time on 2 cores." % ("quick" if quick else "full", len(cases), wall))
    L.append("")
    L.append(
        "**The free sphere.** One sphere in a periodic box of 8 radii, started at lattice velocity u and driven by "
        "gravity that makes u its terminal velocity (a counter body force keeps the whole system from "
        "accelerating); %d steps. A case that is not stable is rerun with the same motion prescribed (no "
        "coupling): where that fails too (hatched) the limit is the lattice's at that tau and speed, not the "
        "coupling's. Not the full product of the parameters, but three slices that cross the boundaries: "
        "density ratio x tau at radius 3 cells and u = 0.05 (the coupling's limit for light particles against the "
        "lattice's as tau -> 1/2), lattice velocity x tau at density ratio 2, radius 3 (the lattice's limit: "
        "cell Reynolds number u/nu and Mach number, for a particle the coupling handles), radius x density ratio "
        "at tau 0.6, u = 0.05 (how small and how light a sphere may be). In these three the speed is the "
        "sphere's, relative to fluid at rest far from it. A fourth slice makes it the flow's: a free sphere "
        "(ratio 1.2, radius 3) in a plane Couette flow whose walls move at +-u, started in the steady "
        "profile, tau x u; its control holds the sphere fixed in the same flow." % (free[0].steps if free else 0))
    L.append("")
    for f in figures:
        L.append("![%s](%s)" % (f[:-4].replace("_", " "), f))
        L.append("")
    for name in ("ratio x tau", "velocity x tau", "radius x ratio", FLOW_SLICE):
        sub = [c for c in free if c.group == "free:" + name]
        if not sub:
            continue
        parts = []
        for k in COUPLINGS:
            t, n = _count(sub, lambda c, k=k: c.p["coupling"] == k)
            if t:
                parts.append("%s: %s" % (k, _fmt_counts(t, n)))
        L.append("- **%s**: %s." % (name, "; ".join(parts)))
    L.append("")
    L.append(
        "**Contacts** (coarse fluid, 100 um cells, tau 0.8): a sphere of density ratio 1000 moving at u = 0.05 "
        "towards a no-slip floor (contact time t_c from %s fluid steps), a sphere of ratio 2 sliding along the "
        "floor under gravity with friction 0.3, and two spheres of ratio 2 approaching each other from a gap of 2 "
        "cells to below one, for Verlet and CVODE BDF. Verlet's stability limit h sqrt(k/m) <= 1 means "
        "t_c >= ~3.2 sub-steps." % ("100 to 0.1" if not quick else "10 to 0.1"))
    L.append("")
    for integ in ("verlet", "cvode"):
        t, n = _count(walls, lambda c, i=integ: c.p["integrator"] == i)
        if t:
            L.append("- **%s**: %s." % (integ, _fmt_counts(t, n)))
    L.append("")
    # the table of unstable cases, by class
    groups = {}
    for c in cases:
        if c.verdict != "stable":
            groups.setdefault(case_class(c), []).append(c)
    L.append("**Unstable cases, the remedy the program offers, and runs with it.** One row per class of "
             "failure (group, verdict, cause, remedy offered and, for the free sphere, whether the prescribed "
             "motion fails too). *Rerun*: the options of the remedy in the order the message gives them, each "
             "applied to %s until one runs stably. A message without a remedy gets the README's advice, marked "
             "so." % ("the class's cheapest case (quick mode: one case per class)" if quick else
                      "every case of the class (fluid-limit cases once per radius, tau and velocity)"))
    L.append("")
    L.append("| group | verdict | cause (one case of the class) | cases | remedy offered | rerun with it | "
             "remedy worked |")
    L.append("|---|---|---|---|---|---|---|")
    for key, cs in sorted(groups.items(), key=lambda kv: (kv[0][0], -len(kv[1]))):
        rep = cs[0].rerun_of or cs[0]
        ctl = {"fluid limit": ", fluid limit", "coupling": ", control runs"}.get(key[4], "")
        reps = {id(x.rerun_of): x for x in cs if x.rerun_of is not None}
        worked = sum(1 for x in reps.values() if x.chain and x.chain[-1][1][0] == "stable")
        L.append("| %s | %s%s | %s (%s) | %d | %s | %s | %d of %d rerun%s |" % (
            key[0], key[1], ctl, _short(rep.cause, 120), _where(rep), len(cs), _short(rep.remedy, 120) or "none",
            chain_text(rep.chain), worked, len(reps), "s" if len(reps) != 1 else ""))
    L.append("")
    L.append("**What a user should conclude.** " + conclusion(cases))
    L.append("")
    return "\n".join(L)


def _short(s, n):
    s = s.replace("|", "/")
    return s if len(s) <= n else s[:n - 1] + "…"


def _limits(sel, xkey, ykey):
    """For each x, the largest y at which the cases of sel are stable up to it (from the smallest y),
    as 'x: y' items; '-' when even the smallest y is not stable."""
    out = []
    for x in sorted({c.p[xkey] for c in sel}):
        col = sorted((c for c in sel if c.p[xkey] == x), key=lambda c: c.p[ykey])
        best = None
        for c in col:
            if c.verdict != "stable":
                break
            best = c.p[ykey]
        out.append("%g: %s" % (x, "-" if best is None else "%g" % best))
    return ", ".join(out)


def conclusion(cases):
    """The closing paragraph, from the data: where the defaults hold, what breaks them, which
    remedies work."""
    free = [c for c in cases if c.group.startswith("free")]
    s = []
    auto = [c for c in free if c.p["coupling"] == "auto"]
    if auto:
        bad = [c for c in auto if c.verdict != "stable"]
        fl = [c for c in bad if c.control == "fluid limit"]
        s.append("With the defaults (no coupling key) %d of %d free-sphere cases run stably; of the %d that do not, "
                 "%d fail with the motion prescribed as well: those are limits of the lattice (tau too close to 1/2 "
                 "for the speed: the cell Reynolds number u/nu = 3u/(tau - 1/2) too large, or the Mach number), "
                 "not of the coupling." % (len(auto) - len(bad), len(auto), len(bad), len(fl)))
        vt = [c for c in auto if c.group == "free:velocity x tau"]
        if vt:
            s.append("The largest lattice velocity that runs stably for %d steps at each tau (density ratio 2, "
                     "radius 3, defaults; a longer run may find less): %s. Below that, refine the grid (more cells "
                     "per radius at the same Reynolds number) rather than lower tau." % (
                         vt[0].steps, _limits(vt, "tau", "u")))
        rt = [c for c in auto if c.group == "free:ratio x tau"]
        if rt:
            taus = sorted({c.p["tau"] for c in rt if all(x.verdict == "stable" for x in rt if x.p["tau"] == c.p["tau"])})
            if taus:
                s.append("At u = 0.05 and radius 3 every density ratio from %g to %g is stable for tau %s." % (
                    min(c.p["ratio"] for c in rt), max(c.p["ratio"] for c in rt), "/".join("%g" % t for t in taus)))
        coup = [c for c in bad if c.control == "coupling"]
        if coup:
            s.append("%d default case(s) fail where the motion prescribed at the intended speed runs (a limit of "
                     "the coupling, or a free sphere faster than intended): %s." % (
                         len(coup), "; ".join("%s (%s)" % (_where(c), label(c.cause)) for c in coup[:4])))
    for k in ("explicit", "explicit + averaging", "implicit, no averaging", "implicit"):
        sub = [c for c in free if c.p["coupling"] == k]
        cb = [c for c in sub if c.verdict != "stable" and c.control != "fluid limit"]
        if cb:
            ratios = sorted({c.p["ratio"] for c in cb})
            s.append("`%s` fails or oscillates where the lattice does not in %d of %d cases (density ratios %s)." % (
                k, len(cb), len(sub), "/".join("%g" % r for r in ratios)))
    if any(c.p["coupling"] != "auto" for c in free):
        s.append("So keep `rigid.coupling: auto` (it takes the implicit coupling with force averaging for every "
                 "body that needs it); `explicit` is the paper's scheme, for comparison only.")
    walls = [c for c in cases if not c.group.startswith("free")]
    for integ in ("verlet", "cvode"):
        sub = [c for c in walls if c.p["integrator"] == integ and c.p["coupling"] == "auto"]
        if not sub:
            continue
        badw = [c for c in sub if c.verdict != "stable"]
        tcs = sorted({c.p["tc"] for c in sub if c.group == "drop" and c.verdict == "stable"})
        s.append("Contacts with %s and the default coupling: %d of %d cases stable%s%s." % (
            "Verlet" if integ == "verlet" else "CVODE BDF", len(sub) - len(badw), len(sub),
            "; the drop runs down to a contact time of %g fluid steps" % min(tcs) if tcs else "",
            (" (not: " + ", ".join(sorted({"%s %s" % (c.group, c.p["variant"]) for c in badw})) + ")")
            if badw else ""))
    if any(c.p.get("integrator") == "verlet" and "h*omega" == label(c.cause) for c in walls):
        s.append("Here a contact stiffer than Verlet's limit was refused with a message as soon as it began, "
                 "instead of being integrated: take the sub-steps it names or CVODE BDF.")
    reps = {}
    for c in cases:
        if c.verdict != "stable" and c.rerun_of is not None:
            reps[id(c.rerun_of)] = c.rerun_of
    if reps:
        good = [c for c in reps.values() if c.chain and c.chain[-1][1][0] == "stable"]
        first = [c for c in reps.values() if c.chain and c.chain[0][1][0] == "stable"]
        s.append("The remedies the messages offer: the first option made %d of %d rerun cases run stably, one of "
                 "the options %d." % (len(first), len(reps), len(good)))
        bad = [c for c in reps.values() if c not in good]
        lattice = [c for c in bad if c.control == "fluid limit"]
        if lattice:
            s.append("They did not help %d lattice-limit case(s) (%s): there only a finer grid at the same "
                     "Reynolds number, by more than the factor 2 tried here, or a lower Reynolds number helps." % (
                         len(lattice), ", ".join(sorted({label(c.cause) for c in lattice}))))
        def same_but_auto(c):
            return [x for x in cases if x.group == c.group and x.p["coupling"] == "auto" and
                    all(x.p.get(k) == v for k, v in c.p.items() if k != "coupling")]
        coupled = [c for c in bad if c.p["coupling"] != "auto" and c.control != "fluid limit" and
                   any(x.verdict == "stable" for x in same_but_auto(c))]
        if coupled:
            s.append("Nor %d failure(s) of a non-default coupling whose message blames the step or the speed "
                     "(%s) while the same case runs stably with the default coupling: that is the remedy such a "
                     "message should name." % (len(coupled), ", ".join(sorted({label(c.cause) for c in coupled}))))
        other = [c for c in bad if c not in lattice and c not in coupled]
        if other:
            s.append("Not fixed either: %s." % "; ".join("%s (%s)" % (_where(c), label(c.cause)) for c in other[:4]))
    return " ".join(s)


def run_map(outdir, quick, coupler=COUPLER, jobs=2):
    """Runs the stability map and writes outdir/stability.csv and outdir/stability_*.png. Returns
    {"markdown": the report section, "figures": [png names], "csv": [csv names]}."""
    os.makedirs(outdir, exist_ok=True)
    t0 = time.time()
    timeout = 120 if quick else 600
    cases = plan(quick)
    timings = {}
    for name, phase in (("cases", run_cases), ("controls", run_controls)):
        t1 = time.time()
        phase(cases, coupler, jobs, timeout)
        timings[name] = time.time() - t1
    t1 = time.time()
    run_remedies(cases, coupler, jobs, timeout, quick)
    timings["remedies"] = time.time() - t1
    wall = time.time() - t0
    write_csv(os.path.join(outdir, "stability.csv"), cases)
    figures = []
    for slice_name, xkey, ykey, xl, yl, fixed in [
            ("ratio x tau", "tau", "ratio", "tau", "density ratio rho_p / rho_f", "radius 3 cells, u = 0.05"),
            ("velocity x tau", "tau", "u", "tau", "lattice velocity u (cells per step)", "density ratio 2, radius 3"),
            ("radius x ratio", "ratio", "radius", "density ratio rho_p / rho_f", "radius (cells)",
             "tau 0.6, u = 0.05"),
            (FLOW_SLICE, "tau", "u", "tau", "wall speed of the shear flow (cells per step)",
             "Couette flow, free sphere of ratio 1.2, radius 3")]:
        name = figure_name(slice_name)
        free_figure(os.path.join(outdir, name), cases, slice_name, xkey, ykey, xl, yl, fixed)
        figures.append(name)
    contact_figure(os.path.join(outdir, "stability_contacts.png"), cases)
    figures.append("stability_contacts.png")
    return {"markdown": markdown(cases, figures, quick, wall), "figures": figures, "csv": ["stability.csv"],
            "cases": cases, "timings": timings}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("outdir")
    ap.add_argument("--quick", action="store_true", help="fewer cases and steps (under ~4 minutes on 2 cores)")
    ap.add_argument("--jobs", type=int, default=2, help="coupler runs at a time (each with one thread)")
    ap.add_argument("--coupler", default=COUPLER, help="the coupler executable (default build/coupler)")
    o = ap.parse_args()
    r = run_map(o.outdir, o.quick, o.coupler, o.jobs)
    with open(os.path.join(o.outdir, "stability.md"), "w") as f:
        f.write(r["markdown"])
    n = {v: sum(1 for c in r["cases"] if c.verdict == v) for v in VERDICTS}
    print("%d cases: %s; wrote %s" % (len(r["cases"]), ", ".join("%d %s" % (k, v) for v, k in n.items()),
                                      os.path.join(o.outdir, "stability.md")))
    print("wall time per phase: " + ", ".join("%s %.0f s" % kv for kv in r["timings"].items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
