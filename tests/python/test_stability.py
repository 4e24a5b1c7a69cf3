"""Issue 14, stability: short cases of the report's stability map (tools/stability_map.py) whose
verdicts are known, asserted from the coupler's messages exactly as the map reads them.

- A case that must be stable is stable: a free sphere of radius 3 cells, density ratio 0.5, tau
  0.6, lattice velocity 0.05 with the defaults (rigid.coupling auto: implicit with force
  averaging for this body; models/README.md "How auto chooses").
- A case that must be detected is detected: tau 0.5001 at lattice velocity 0.1 (cell Reynolds
  number u/nu = 3000), and its prescribed-motion control fails too (a limit of the lattice, not
  of the coupling); a contact of a tenth of a fluid step with Verlet (h sqrt(k/m) = 31 against
  the limit 1, rigid/integrator_verlet.c) is refused, and the remedy the message offers (more
  sub-steps) or CVODE BDF runs it.
- The paper's explicit coupling of a light sphere (radius 3, density ratio 0.3) is not stable
  (the added-mass instability of explicitly coupled light particles; Ladd & Verberg, J. Stat.
  Phys. 104 (2001) 1191) where the default is.
- The verdict parsing itself on messages of each kind, including a crash without a message.

About 10 s on 2 cores (each run a few hundred steps on at most 24^3 cells; the last test draws
the map's figures from made-up outcomes).
"""
import re
import sys

import pytest

from conftest import ROOT

sys.path.insert(0, str(ROOT / "tools"))
import stability_map as sm  # noqa: E402

TIMEOUT = 120


def free(coupler, ratio, tau, u, coupling="auto", steps=300, a=3.0):
    c = sm.Case("free:test", dict(radius=a, ratio=ratio, tau=tau, u=u, coupling=coupling), sm.COUPLINGS[coupling],
                steps)
    return sm.run_text(c.scene(), c.sets, c.steps, str(coupler), TIMEOUT)


def test_light_sphere_defaults_stable(coupler):
    verdict, cause, _, _, _ = free(coupler, 0.5, 0.6, 0.05)
    assert verdict == "stable", cause


def test_light_sphere_at_large_tau_does_not_start_turning(coupler):
    """Radius 3 cells, density ratio 0.1, tau 2, rising from rest toward 0.01 lattice in a periodic
    box (a case of tools/stability_sweep.py): with the torque's correction paid back half a step
    its rotation grew from 1e-12 at step 260 until Mach 0.34 stopped the run at step 404
    (rigid/implicit.c, IMPLICIT_PAYBACK_TORQUE)."""
    steps = 700
    verdict, cause, _, _, _ = sm.run_text(sm.case_scene(3, 0.1, 2.0, 0.01, steps), [], steps, str(coupler),
                                          TIMEOUT)
    assert verdict == "stable", cause


def test_tau_near_half_fast_detected_as_fluid_limit(coupler):
    verdict, cause, _, _, _ = free(coupler, 2.0, 0.5001, 0.1)
    assert verdict == "detected" and cause, cause
    control = sm.run_text(sm.control_scene(3.0, 2.0, 0.5001, 0.1, 300, start="terminal"), [], 300, str(coupler),
                          TIMEOUT)
    assert control[0] == "detected", control  # the lattice's limit: no coupling in the control


@pytest.mark.parametrize("integrator, expected", [("verlet", "detected"), ("cvode", "stable")])
def test_stiff_contact(coupler, integrator, expected):
    """A sphere of density ratio 1000 hits a no-slip floor at lattice speed 0.05 with a contact time
    of 0.1 fluid steps: Verlet refuses it and names the remedy, which works; CVODE BDF runs it."""
    c = sm.Case("drop", dict(u=0.05, tc=0.1, integrator=integrator, coupling="auto", variant=""),
                ["rigid.cvode_method=bdf"], 150)
    verdict, cause, remedy, _, _ = sm.run_text(c.scene(), c.sets, c.steps, str(coupler), TIMEOUT)
    assert verdict == expected, cause
    if expected == "detected":
        assert "substeps" in remedy, remedy
        # how many, and that --exchange-every K needs K times as many (h sqrt(k/m) = 31.4)
        assert "rigid.substeps: at least 32 for this step" in remedy and "--exchange-every K" in remedy, remedy
        change, fixed = sm.remedy_options(c, remedy, cause + ": " + remedy)[0]
        assert "rigid.substeps" in change
        again = sm.run_text(fixed.scene(), fixed.sets, fixed.steps, str(coupler), TIMEOUT)
        assert again[0] == "stable", again


def test_explicit_light_sphere_unstable_default_stable(coupler):
    explicit = free(coupler, 0.3, 1.0, 0.05, coupling="explicit")
    assert explicit[0] in ("oscillates", "detected"), explicit
    default = free(coupler, 0.3, 1.0, 0.05)
    assert default[0] == "stable", default


def test_verdict_parsing():
    pre = "error: [fluid.fmu] fluid.fmu [logStatusError] [fluid] /tmp/c-x/fluid.fmu/resources/scene.yaml: "
    p2 = ("warning: [fluid.fmu] fluid.fmu [logStatusWarning] [fluid] /tmp/s.yaml: sphere 0 (radius 3 cells) ... "
          "(period-2 oscillation, amplitude 74%): explicit coupling. Remedies: rigid.coupling: auto or implicit")
    tail = ("error: [fmu] fluid.fmu: fmi2DoStep(...) returned fmi2Error\n"
            "error: [run] communication step 26 from t = 1 s failed\n")
    moved = pre + "sphere 0 moves 1.06 cells in one step at step 26 (limit 1 cell): reduce dt (fluid.tau) or the velocity\n"
    assert sm.parse_outcome(0, "") == ("stable", "", "")
    v, cause, remedy = sm.parse_outcome(0, p2 + "\n")
    assert v == "oscillates" and "period-2" in cause and remedy.startswith("rigid.coupling")
    v, cause, remedy = sm.parse_outcome(1, moved + tail)
    assert v == "detected" and cause.startswith("sphere 0 moves 1.06 cells") and remedy.startswith("reduce dt")
    v, cause, remedy = sm.parse_outcome(1, p2 + "\n" + moved + tail)
    assert v == "detected" and "after a period-2 warning" in cause
    # a detector this file does not know: its own words are the cause, whatever follows '; use' the remedy
    new = pre + "body 0 gains energy in a contact at step 9 (x2.5); use a longer contact time\n"
    v, cause, remedy = sm.parse_outcome(1, new + tail)
    assert (v, cause, remedy) == ("detected", "body 0 gains energy in a contact at step 9 (x2.5)",
                                  "use a longer contact time")
    assert sm.parse_outcome(-11, "")[0] == "crashed"
    assert sm.parse_outcome(1, "")[0] == "crashed"


def test_map_writes_report_files(tmp_path, monkeypatch):
    """run_map's bookkeeping, figures and text on made-up outcomes (no coupler runs): every
    figure and the CSV it names exist, and the section has its table and its conclusion."""
    def fake(text, sets, steps, coupler, timeout):
        if "tau: 0.5001" in text:
            return "detected", "numerical trouble at step 200: non-positive density", "", 0.0, ""
        if "contact_time: 0.0001" in text and "integrator: verlet" in text and not sets[-1].startswith("rigid.sub"):
            return ("detected", "verlet: unstable contact ... is 31.4, limit 1",
                    "use more substeps or the cvode BDF integrator", 0.0, "")
        if "rigid.coupling=explicit" in sets and "density: 100.0" in text:
            return ("detected", "sphere 0 moves 2 cells in one step at step 5 (after a period-2 warning)",
                    "reduce dt (fluid.tau) or the velocity", 0.0, "")
        return "stable", "", "", 0.0, ""
    monkeypatch.setattr(sm, "run_text", fake)
    r = sm.run_map(str(tmp_path), quick=True, coupler="unused", jobs=2)
    for name in r["figures"] + r["csv"]:
        assert (tmp_path / name).stat().st_size > 0, name
    md = r["markdown"]
    assert md.startswith("## 4. Stability map") and "| group | verdict |" in md and "What a user should conclude" in md
    assert all("(%s)" % f in md for f in r["figures"])
    assert "rigid.substeps=40: stable" in md and "| drop | detected |" in md
    assert "(none offered; README:) fluid.dx / 2" in md and "velocity / 2: detected (moves)" in md


def test_report_figure_links_have_no_blanks():
    # the fourth slice, "flow velocity x tau", was drawn to "stability_flow velocity_tau.png" and
    # linked as ![...](stability_flow velocity_tau.png): a Markdown image link ends at the blank, so
    # report.md showed the text, not the figure. Now stability_flow_velocity_tau.png, the other
    # three names unchanged.
    names = [sm.figure_name(s) for s in ("ratio x tau", "velocity x tau", "radius x ratio", sm.FLOW_SLICE)]
    assert names == ["stability_ratio_tau.png", "stability_velocity_tau.png", "stability_radius_ratio.png",
                     "stability_flow_velocity_tau.png"]
    md = sm.markdown([], names + ["stability_contacts.png"], True, 0.0)
    links = re.findall(r"!\[[^\]]*\]\(([^)]*)\)", md)
    assert links == names + ["stability_contacts.png"]
    assert all(re.fullmatch(r"[\w.]+", link) for link in links), links
