"""The FMUs (DESIGN section 2, issue 5): `coupler export`, fmpy's validator and
simulator on each FMU, illegal call sequences, and FMU state save/restore.

Scenes are tiny (16^3 periodic box, dx = 10 um, one sphere of radius 3 cells)
so the whole file runs in seconds."""
import ctypes
import math
import pathlib
import platform
import shutil
import struct
import subprocess
import time
import xml.etree.ElementTree as ET
import zipfile

import fmpy
import numpy as np
import pytest
import yaml
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
from fmpy.validation import validate_fmu

from conftest import MODELS, PY, run

SCENE = """\
domain:
  size: [1.6e-4, 1.6e-4, 1.6e-4]
fluid:
  density: 1000.0
  viscosity: 1.0e-6
  dx: 1.0e-5
  tau: 0.8
bodies:
  - name: p
    density: 2000.0{motion}
    spheres:
      - {{center: [8.0e-5, 8.0e-5, 8.0e-5], radius: 3.0e-5}}
rigid: {{gravity: [0, 0, -9.81]}}
run: {{end_time: 1.0e-3, output_interval: 1.0e-4}}
"""

PAIR = """\
domain:
  size: [1.6e-4, 1.6e-4, 1.6e-4]
fluid: {density: 1000.0, viscosity: 1.0e-6, dx: 1.0e-5, tau: 0.8}
bodies:
  - density: 2000.0
    spheres:
      - {center: [6.0e-5, 8.0e-5, 8.0e-5], radius: 2.0e-5}
      - {center: [1.0e-4, 8.0e-5, 8.0e-5], radius: 2.0e-5}
connections:
  - {spheres: [0, 1]}
rigid: {gravity: [0, 0, -9.81]}
run: {end_time: 1.0e-3, output_interval: 1.0e-4}
"""

DT = 1e-5  # tau 0.8, dx 1e-5, nu 1e-6: dt = (tau - 1/2) dx^2 / (3 nu)
G, RHO_F, RHO_P = 9.81, 1000.0, 2000.0
Z0 = 8.0e-5


def export(tmp, name, text, *sets):
    scene = tmp / f"{name}.yaml"
    scene.write_text(text)
    out = tmp / name
    args = ["export", scene, "-d", out]
    for s in sets:
        args += ["--set", s]
    p = run(*args)
    assert p.returncode == 0, p.stderr
    return out, p


@pytest.fixture(scope="session")
def fmus(coupler, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("fmus")
    free, _ = export(tmp, "free", SCENE.format(motion=""))
    fixed, p_fixed = export(tmp, "fixed", SCENE.format(motion="\n    motion: fixed"))
    pair, _ = export(tmp, "pair", PAIR)
    cvode, _ = export(tmp, "cvode", SCENE.format(motion=""), "rigid.integrator=cvode")
    return {"free": free, "fixed": fixed, "pair": pair, "cvode": cvode, "fixed_stdout": p_fixed.stdout}


def variables(fmu):
    md = fmpy.read_model_description(str(fmu))
    return md, {v.name: v for v in md.modelVariables}


# --- export -------------------------------------------------------------------


def test_export_writes_both_fmus_with_scene_and_library(fmus):
    for name in ("fluid", "rigid"):
        path = fmus["free"] / f"{name}.fmu"
        with zipfile.ZipFile(path) as z:
            names = z.namelist()
            assert "modelDescription.xml" in names
            assert f"binaries/linux64/{name}.so" in names
            assert "resources/scene.yaml" in names
            assert "bodies:" in z.read("resources/scene.yaml").decode()


@pytest.mark.skipif(platform.machine() != "x86_64" or shutil.which("objdump") is None,
                    reason="the portability check reads x86-64 machine code with objdump")
def test_fmu_binaries_run_on_any_x86_64(fmus, tmp_path):
    # built for the x86-64 baseline, not -march=native: AVX (ymm/zmm) instructions, which a CPU
    # without AVX would trap on, appear only in the AVX2 variants of the fluid kernel and of the
    # grid scan (fluid/scan.c), which kernel_dispatch.c calls only on a CPU that has AVX2 and FMA
    for name in ("fluid", "rigid"):
        with zipfile.ZipFile(fmus["free"] / f"{name}.fmu") as z:
            so = tmp_path / f"{name}.so"
            so.write_bytes(z.read(f"binaries/linux64/{name}.so"))
        asm = subprocess.run(["objdump", "-d", str(so)], capture_output=True, text=True, check=True).stdout
        assert "fmi2DoStep" in asm
        fn, with_avx = None, set()
        for line in asm.splitlines():
            if line.endswith(">:") and "<" in line:
                fn = line[line.index("<") + 1:-2]
            elif "%ymm" in line or "%zmm" in line:
                with_avx.add(fn)
        if name == "fluid":
            # the AVX2 variants of the kernels (two layouts, two precisions) and of the scan
            assert with_avx and all(f.startswith(("kernel_", "fluid_scan_")) and "_v3" in f for f in with_avx), with_avx
            for k in ("kernel_stream_collide", "kernel_in_place", "kernel_stream_collide_f32", "kernel_in_place_f32",
                      "fluid_scan"):
                assert f"<{k}_base" in asm and f"<{k}_v3" in asm, k
        else:
            assert not with_avx, with_avx


def test_scene_without_free_bodies_has_no_rigid_fmu(fmus):
    assert (fmus["fixed"] / "fluid.fmu").exists()
    assert not (fmus["fixed"] / "rigid.fmu").exists()
    assert "no rigid.fmu" in fmus["fixed_stdout"]
    _, v = variables(fmus["fixed"] / "fluid.fmu")
    # the fluid moves a fixed sphere itself: its kinematics are outputs, not inputs
    assert all(x.causality == "output" for n, x in v.items() if n.startswith("sphere[0]."))
    assert v["sphere[0].position.z"].causality == "output"
    assert v["sphere[0].force.x"].causality == "output"


def test_set_is_written_into_the_resources(fmus):
    with zipfile.ZipFile(fmus["cvode"] / "rigid.fmu") as z:
        assert "cvode" in z.read("resources/scene.yaml").decode()


def test_export_errors_write_nothing(coupler, tmp_path):
    scene = tmp_path / "s.yaml"
    scene.write_text(SCENE.format(motion=""))
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    p = run("export", scene, "-d", blocker)
    assert p.returncode == 1 and "not a folder" in p.stderr
    p = run("export", scene, "-d", tmp_path / "out", "--set", "fluid.tau=0.4")
    assert p.returncode == 1 and "fluid.tau" in p.stderr
    assert not (tmp_path / "out").exists()
    p = run("export", scene)
    assert p.returncode == 2


# --- model description ----------------------------------------------------------


def test_fmpy_validates_every_fmu(fmus):
    for fmu in [fmus["free"] / "fluid.fmu", fmus["free"] / "rigid.fmu", fmus["fixed"] / "fluid.fmu",
                fmus["pair"] / "fluid.fmu", fmus["pair"] / "rigid.fmu"]:
        assert validate_fmu(str(fmu)) == [], fmu


def test_variable_naming_contract(fmus):
    md, v = variables(fmus["free"] / "fluid.fmu")
    assert md.coSimulation.modelIdentifier == "fluid" and md.variableNamingConvention == "structured"
    assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate
    assert not md.coSimulation.providesDirectionalDerivative
    for q, unit in (("position", "m"), ("velocity", "m/s"), ("angular_velocity", "rad/s")):
        for a in "xyz":
            assert v[f"sphere[0].{q}.{a}"].causality == "input" and v[f"sphere[0].{q}.{a}"].unit == unit
    for q, unit in (("force", "N"), ("torque", "N.m")):
        for a in "xyz":
            assert v[f"sphere[0].{q}.{a}"].causality == "output" and v[f"sphere[0].{q}.{a}"].unit == unit
    assert float(v["sphere[0].position.z"].start) == Z0
    tau = v["fluid.tau"]
    assert tau.causality == "parameter" and tau.variability == "fixed" and float(tau.min) == 0.5
    outputs = [u.variable.name for u in md.outputs]
    assert outputs == [n for n, x in v.items() if x.causality == "output"]

    md, v = variables(fmus["pair"] / "rigid.fmu")
    assert md.coSimulation.modelIdentifier == "rigid"
    for k in ("sphere[0].force.x", "sphere[1].torque.z"):
        assert v[k].causality == "input"
    for k in ("sphere[1].position.x", "sphere[0].angular_velocity.y", "connection[0].force.z",
              "connection[0].torque.x"):
        assert v[k].causality == "output"
    assert v["connection[0].intact"].type == "Boolean"
    assert v["rigid.substeps"].type == "Integer"
    _, fv = variables(fmus["free"] / "rigid.fmu")
    assert not any(n.startswith("connection") for n in fv)  # only what the scene needs
    assert md.guid != fmpy.read_model_description(str(fmus["pair"] / "fluid.fmu")).guid


def test_parameter_start_values_lie_in_their_ranges(coupler, tmp_path):
    """Every parameter's start value (the scene's) lies within the min and max it declares, and the
    FMU takes that value back through fmi2SetInteger: rigid.substeps 2e6, which the scene allows
    (up to 2147483647), was declared max 1e6 and refused when set."""
    out, _ = export(tmp_path, "many", SCENE.format(motion=""), "rigid.substeps=2000000")
    for which in ("rigid", "fluid"):
        _, v = variables(out / f"{which}.fmu")
        for name, x in v.items():
            if x.causality == "parameter" and x.start is not None:
                start = float(x.start)
                assert x.min is None or float(x.min) <= start, (which, name, x.min, start)
                assert x.max is None or start <= float(x.max), (which, name, start, x.max)
    md, v = variables(out / "rigid.fmu")
    folder = fmpy.extract(str(out / "rigid.fmu"), unzipdir=str(tmp_path / "rigid_x"))
    slave = FMU2Slave(guid=md.guid, unzipDirectory=folder, modelIdentifier="rigid", instanceName="r")
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.setInteger([v["rigid.substeps"].valueReference], [2000000])
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    slave.terminate()
    slave.freeInstance()


def model_structure(fmu):
    """Outputs and InitialUnknowns as {index: dependencies attribute or None}, and the
    ScalarVariables in index order (1-based), read from the XML itself: fmpy's reader does not
    keep an absent attribute apart from every detail a master relies on."""
    with zipfile.ZipFile(fmu) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    svs = root.find("ModelVariables").findall("ScalarVariable")
    ms = root.find("ModelStructure")
    lists = {}
    for name in ("Outputs", "InitialUnknowns"):
        lists[name] = {int(u.get("index")): u.get("dependencies") for u in ms.find(name).findall("Unknown")}
    return root, svs, lists


@pytest.mark.parametrize("scene,fmu", [("free", "fluid"), ("free", "rigid"), ("fixed", "fluid"),
                                       ("pair", "fluid"), ("pair", "rigid")])
def test_model_structure_declares_no_direct_feedthrough(fmus, scene, fmu):
    """FMI 2.0.x section 2.2.8 (ModelStructure): for Co-Simulation the dependencies of <Outputs>
    hold at communication points, where the knowns are the inputs; an absent attribute means
    "depends on every known", dependencies="" on none. Our inputs act only through fmi2DoStep, so
    every output declares dependencies="" (a master connecting fluid and rigid both ways must see
    no algebraic loop). <InitialUnknowns> lists exactly the outputs (all initial="calculated");
    in Initialization Mode the knowns are the inputs and the parameters (initial="exact"): the
    component is created from the scene with its parameters, so the list is those parameters
    (every one that overrides a scene key, ascending) and never an input."""
    root, svs, lists = model_structure(fmus[scene] / f"{fmu}.fmu")
    causality = {k + 1: sv.get("causality") for k, sv in enumerate(svs)}
    outputs = sorted(i for i, c in causality.items() if c == "output")
    inputs = {i for i, c in causality.items() if c == "input"}
    params = [i for i, c in causality.items() if c == "parameter" and svs[i - 1].find("String") is None]
    assert outputs and list(lists["Outputs"]) == outputs
    assert all(d == "" for d in lists["Outputs"].values()), lists["Outputs"]
    assert list(lists["InitialUnknowns"]) == outputs
    for index, deps in lists["InitialUnknowns"].items():
        assert deps is not None, index
        known = [int(x) for x in deps.split()]
        assert known == params and not inputs & set(known), (index, deps)
        assert all(svs[k - 1].get("initial") == "exact" for k in known)
    # and so does fmpy's reader
    md = fmpy.read_model_description(str(fmus[scene] / f"{fmu}.fmu"))
    assert all(u.dependencies == [] for u in md.outputs)


@pytest.mark.parametrize("fmu,inputs", [
    ("fluid", {"sphere[0].position.x": 8.4e-5, "sphere[0].velocity.x": -2e-3, "sphere[0].angular_velocity.z": 5.0}),
    ("rigid", {"sphere[0].force.x": 1e-9, "sphere[0].force.z": -3e-9, "sphere[0].torque.z": 1e-15}),
])
def test_outputs_do_not_change_with_inputs_between_steps(fmus, tmp_path, fmu, inputs):
    """What dependencies="" promises: between two communication points, setting inputs leaves
    every output as it was (an FMU with direct feedthrough would change them); the inputs act in
    the next fmi2DoStep."""
    s = Slave(fmus["free"] / f"{fmu}.fmu", tmp_path)
    s.init()
    s.fmu.doStep(0.0, DT)
    before = s.outputs()
    s.fmu.setReal([s.vr[n] for n in inputs], list(inputs.values()))
    np.testing.assert_array_equal(s.outputs(), before)
    s.fmu.doStep(DT, DT)
    assert not np.array_equal(s.outputs(), before)
    s.close()


def test_fmu_carries_documentation_and_a_whole_ns_default_step(coupler, tmp_path):
    """FMI 2.0 section 2.3: documentation/index.html is the entry point of an FMU's documentation;
    the cross-check rules want a DefaultExperiment with the step size and the tool named. The
    default scene's step, (tau - 1/2) dx^2 / (3 nu) = 16666.67 ns at tau 1, is rounded to 16667 ns
    so that masters counting time in integer ns (libcosim) can take it (common/scene.h)."""
    d = tmp_path / "fmus"
    p = run("export", MODELS / "sinking_sphere.yaml", "-d", d)
    assert p.returncode == 0, p.stderr
    scene = yaml.safe_load((MODELS / "sinking_sphere.yaml").read_text())["fluid"]
    for name in ("fluid", "rigid"):
        # cross-check rules (README "FMUs"): valid (fmpy's validator in place of the FMU
        # Compliance Checker), at most 10 MB
        assert validate_fmu(str(d / f"{name}.fmu")) == []
        assert (d / f"{name}.fmu").stat().st_size < 10e6
        root, _, _ = model_structure(d / f"{name}.fmu")
        ex = root.find("DefaultExperiment")
        h = float(ex.get("stepSize"))
        assert h * 1e9 == pytest.approx(round(h * 1e9), abs=1e-6) and round(h * 1e9) == 16667
        exact = (scene["tau"] - 0.5) * scene["dx"] ** 2 / (3 * scene["viscosity"])
        assert abs(h - exact) <= 0.5e-9
        # run.end_time 0.06 s is 3599.93 steps: the stop is 3600 whole steps, as coupler run runs it
        assert float(ex.get("stopTime")) == pytest.approx(3600 * h, rel=1e-15) and float(ex.get("startTime")) == 0.0
        assert root.get("version") and "coupler export" in root.get("generationTool")
        with zipfile.ZipFile(d / f"{name}.fmu") as z:
            html = z.read("documentation/index.html").decode()
        assert "16667 ns" in html and "sphere[0].position.x" in html and "dependencies" in html
        assert html.lstrip().startswith("<!DOCTYPE html>") and html.rstrip().endswith("</html>")
    md = fmpy.read_model_description(str(d / "fluid.fmu"))
    tau = [v for v in md.modelVariables if v.name == "fluid.tau"][0]
    assert float(tau.start) == scene["tau"]  # the requested value: setting it again changes nothing


# --- simulation, each FMU alone --------------------------------------------------


@pytest.mark.parametrize("which", ["free", "cvode"])
def test_rigid_alone_falls_freely(fmus, which):
    """Zero hydrodynamic force: z(t) = z0 - g (1 - rho_f/rho_p) t^2 / 2 (gravity and buoyancy).
    Verlet is exact for a constant acceleration; CVODE gets rigid.rtol = 1e-12 as an FMU parameter
    (its error control sees z ~ 8e-5 m, so the default 1e-8 leaves ~1e-10 m on a fall of 2.5e-9 m)."""
    tight = {"rigid.rtol": 1e-12} if which == "cvode" else {}
    r = fmpy.simulate_fmu(str(fmus[which] / "rigid.fmu"), stop_time=1e-3, step_size=DT, output_interval=DT,
                          start_values=tight)
    t, z = r["time"], r["sphere[0].position.z"]
    a = G * (1 - RHO_F / RHO_P)
    np.testing.assert_allclose(Z0 - z, 0.5 * a * t ** 2, rtol=1e-6, atol=1e-15)
    np.testing.assert_allclose(r["sphere[0].velocity.z"], -a * t, rtol=1e-9, atol=1e-15)
    # parameters are applied as scene overrides when the component is created
    r = fmpy.simulate_fmu(str(fmus[which] / "rigid.fmu"), stop_time=1e-3, step_size=DT, output_interval=DT,
                          start_values={**tight, "rigid.gravity.z": -2.0, "fluid.density": 500.0})
    np.testing.assert_allclose(Z0 - r["sphere[0].position.z"], 0.5 * 2.0 * (1 - 500 / RHO_P) * r["time"] ** 2,
                               rtol=1e-6, atol=1e-15)


@pytest.mark.parametrize("which", ["free", "cvode"])
def test_rigid_with_a_negative_start_time_falls_from_its_first_step(fmus, tmp_path, which):
    """FMI lets a master start at any time. A rigid.release_time of 0 (the default) holds nothing,
    but the hold was `t < release_time - h/2` on the FMU's clock: from startTime -5e-5 s the body
    hung for 5 steps without gravity or load (z and v unchanged, and the fluid's load dropped
    without a word). Now it falls from the first step as from 0. With a release time the hold
    still lasts until that time of the run's clock (README "Release")."""
    t0, n = -5 * DT, 10
    r = fmpy.simulate_fmu(str(fmus[which] / "rigid.fmu"), start_time=t0, stop_time=t0 + n * DT, step_size=DT,
                          output_interval=DT, start_values={"rigid.rtol": 1e-12} if which == "cvode" else {})
    a = G * (1 - RHO_F / RHO_P)
    np.testing.assert_allclose(r["sphere[0].velocity.z"], -a * (r["time"] - t0), rtol=1e-9, atol=1e-15)
    d, _ = export(tmp_path, "held", SCENE.format(motion=""), "rigid.release_time=2e-5", "rigid.coupling=explicit",
                  f"rigid.integrator={'cvode' if which == 'cvode' else 'verlet'}")
    s = Slave(d / "rigid.fmu", tmp_path)
    s.fmu.setupExperiment(startTime=t0)
    s.fmu.enterInitializationMode()
    s.fmu.exitInitializationMode()
    v, held = [], []
    for k in range(n):
        s.fmu.setReal([s.vr["sphere[0].force.z"]], [1e-9])
        s.fmu.doStep(t0 + k * DT, DT)
        v.append(s.fmu.getReal([s.vr["sphere[0].velocity.z"]])[0])
        held.append(s.fmu.getReal([s.vr["sphere[0].applied_force.z"]])[0] == 0.0)
    # the steps from -5e-5 to 2e-5 s are held: 7 of them, zero load, at rest; the 8th moves
    assert held == [True] * 7 + [False] * 3 and v[:7] == [0.0] * 7 and v[7] != 0.0
    s.close()


def test_fluid_fmu_runs_its_own_default_experiment(tmp_path):
    """fmpy.simulate_fmu with nothing but the FMU: its DefaultExperiment's stop is run.end_time
    rounded up to whole LBM steps (2.05e-4 s is 20.5 steps: 21), so the last step is a whole
    LBM step too (with stop = end_time the fluid refused a last step of h/dt = 0.5)."""
    d, _ = export(tmp_path, "own", SCENE.format(motion="\n    motion: fixed"), "run.end_time=2.05e-4")
    r = fmpy.simulate_fmu(str(d / "fluid.fmu"))
    assert r["time"][-1] == pytest.approx(21 * DT, rel=1e-12)
    assert np.all(np.diff(r["time"]) == pytest.approx(DT, rel=1e-9))
    assert np.all(np.isfinite(r["sphere[0].force.z"]))


def test_fluid_alone_sphere_held_by_inputs(fmus):
    fmu = str(fmus["free"] / "fluid.fmu")
    # a body force drives the fluid past the held sphere: drag along +x only
    r = fmpy.simulate_fmu(fmu, stop_time=40 * DT, step_size=DT, output_interval=DT,
                          start_values={"fluid.body_force.x": 1.0e4})
    fx = r["sphere[0].force.x"]
    assert fx[-1] > 0 and np.all(np.diff(fx[5:]) > 0)
    assert abs(r["sphere[0].force.y"][-1]) < 1e-9 * fx[-1] and abs(r["sphere[0].force.z"][-1]) < 1e-9 * fx[-1]
    # a sphere held in place with a surface velocity -x drags the fluid: force along +x again (two steps at once)
    r = fmpy.simulate_fmu(fmu, stop_time=40 * DT, step_size=2 * DT, output_interval=2 * DT,
                          start_values={"sphere[0].velocity.x": -1.0e-3})
    assert r["sphere[0].force.x"][-1] > 0
    # a fixed sphere needs no inputs at all
    r = fmpy.simulate_fmu(str(fmus["fixed"] / "fluid.fmu"), stop_time=10 * DT, step_size=DT,
                          start_values={"fluid.body_force.x": 1.0e4})
    assert r["sphere[0].force.x"][-1] > 0


# --- the low-level API: illegal calls and FMU state ---------------------------------


class Slave:
    """An unpacked FMU instance with a logger that keeps every message."""

    def __init__(self, fmu, tmp, name="a"):
        self.dir = fmpy.extract(str(fmu), unzipdir=str(tmp / f"{pathlib.Path(fmu).stem}_{name}"))
        self.md = fmpy.read_model_description(self.dir)
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.messages = []

        def log(env, instance, status, category, message):
            self.messages.append((status, category.decode(), message.decode()))

        self.callbacks = fmi2CallbackFunctions()
        self.callbacks.logger = fmi2CallbackLoggerTYPE(log)
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self.dir,
                             modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        self.fmu.instantiate(callbacks=self.callbacks)

    def init(self):
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    def outputs(self):
        return np.array(self.fmu.getReal([v.valueReference for v in self.md.modelVariables
                                          if v.causality == "output" and v.type == "Real"]))

    def fails(self, call, *args, expect="error"):
        before = len(self.messages)
        with pytest.raises(FMICallException):
            call(*args)
        text = " ".join(m[2] for m in self.messages[before:])
        assert expect in text, text
        assert any(m[0] == 3 and m[1] == "logStatusError" for m in self.messages[before:])

    def close(self):
        self.fmu.freeInstance()


def test_illegal_calls_are_errors_not_crashes(fmus, tmp_path):
    s = Slave(fmus["free"] / "fluid.fmu", tmp_path)
    f = s.fmu
    s.fails(f.doStep, 0.0, DT, expect="illegal call sequence")
    s.fails(f.exitInitializationMode, expect="illegal call sequence")
    s.fails(f.getReal, [s.vr["sphere[0].force.x"]], expect="illegal call sequence")
    s.fails(f.setReal, [s.vr["fluid.tau"]], [0.5], expect="fluid.tau")  # open range (0.5, inf)
    s.fails(f.setReal, [s.vr["fluid.viscosity"]], [-1.0], expect="out of range")
    s.init()
    s.fails(f.setReal, [s.vr["sphere[0].force.x"]], [1.0], expect="is an output")
    s.fails(f.setReal, [s.vr["sphere[0].velocity.x"]], [math.nan], expect="finite")
    s.fails(f.setReal, [s.vr["fluid.tau"]], [0.9], expect="fixed parameter")
    s.fails(f.getReal, [10_000], expect="does not exist")
    s.fails(f.getInteger, [s.vr["fluid.tau"]], expect="not Integer")
    s.fails(f.doStep, 0.0, -DT, expect="communicationStepSize")
    s.fails(f.doStep, 0.0, 0.0, expect="communicationStepSize")
    s.fails(f.doStep, 0.5, DT, expect="not where the FMU is")
    s.fails(f.doStep, 0.0, 1.5 * DT, expect="dt =")
    s.fails(f.getDirectionalDerivative, [0], [1], [1.0], expect="not supported")
    with pytest.raises(FMICallException):  # NULL arrays with nvr > 0
        f.fmi2GetReal(f.component, None, 3, None)
    # none of those changed anything: the instance steps on normally
    f.doStep(0.0, DT)
    f.doStep(DT, 2 * DT)
    assert f.getRealStatus(2) == pytest.approx(3 * DT)  # fmi2LastSuccessfulTime
    f.terminate()
    s.fails(f.doStep, 3 * DT, DT, expect="illegal call sequence")
    f.reset()  # back to Instantiated: a new run is possible
    s.init()
    f.doStep(0.0, DT)
    s.close()


def test_negative_drag_coefficient_input_is_refused(fmus, tmp_path):
    """The rigid FMU's drag coefficients (implicit coupling) are -dF/dv and -dT/dw, >= 0 (rigid.h).
    A master that sent a negative one got it taken as 0, the explicit coupling, without a word
    (a load of 1e-9 N: the same velocity after two steps for 0, -1e-6 and -1e3 kg/s). Now fmi2SetReal
    refuses it with the variable and its range, as for a parameter, and modelDescription.xml
    declares min="0"; the fluid never publishes one below 0 (A > 0 in every boundary scheme)."""
    md, v = variables(fmus["free"] / "rigid.fmu")
    for name in ("sphere[0].drag_coefficient", "sphere[0].rotational_drag_coefficient"):
        assert v[name].causality == "input" and float(v[name].min) == 0.0
    s = Slave(fmus["free"] / "rigid.fmu", tmp_path)
    s.init()
    f = s.fmu
    zt, zr, fz = s.vr["sphere[0].drag_coefficient"], s.vr["sphere[0].rotational_drag_coefficient"], \
        s.vr["sphere[0].force.z"]
    s.fails(f.setReal, [fz, zt], [1e-9, -1e-6], expect="sphere[0].drag_coefficient (value reference")
    assert "allowed: [0, inf] kg/s" in s.messages[-1][2]
    s.fails(f.setReal, [zr], [-1e-20], expect="sphere[0].rotational_drag_coefficient")
    assert f.getReal([fz, zt, zr]) == [0.0, 0.0, 0.0]  # a refused call sets nothing
    f.setReal([fz, zt, zr], [1e-9, 1e-7, 0.0])
    f.doStep(0.0, DT)
    s.close()


def test_scene_warnings_are_logged_once(fmus, tmp_path):
    # the scene (3 cells per radius) draws warnings. The FMU reads it at instantiation and again
    # with the parameters applied in fmi2ExitInitializationMode: each warning was logged twice.
    # Now the first reading logs only errors.
    for name in ("fluid", "rigid"):
        s = Slave(fmus["free"] / f"{name}.fmu", tmp_path, name=f"w_{name}")
        assert not [m for m in s.messages if m[0] == 1], s.messages
        s.init()
        warnings = [m[2] for m in s.messages if m[0] == 1]
        assert warnings and any("[scene]" in w for w in warnings), s.messages
        assert len(set(warnings)) == len(warnings), warnings
        s.close()


# Run in its own process: on a handle that is not a live instance the old
# layer read and freed freed memory, which may crash the interpreter.
STALE_HANDLES = r"""
import ctypes, sys
import fmpy
from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE

# fmpy's default logger prints the FMU's messages (the scene's warnings) into the stdout compared below
callbacks = fmi2CallbackFunctions()
callbacks.logger = fmi2CallbackLoggerTYPE(lambda *args: None)

def slave(fmu, name):
    md = fmpy.read_model_description(fmu)
    s = FMU2Slave(guid=md.guid, unzipDirectory=fmpy.extract(fmu), modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName=name)
    s.instantiate(callbacks=callbacks)
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    s.doStep(0.0, float(sys.argv[3]))
    lib = ctypes.CDLL(s.dll._name)  # the raw entry points: fmpy raises on fmi2Error
    lib.fmi2DoStep.argtypes = [ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.c_int]
    lib.fmi2GetReal.argtypes = [ctypes.c_void_p, ctypes.POINTER(ctypes.c_uint), ctypes.c_size_t,
                                ctypes.POINTER(ctypes.c_double)]
    lib.fmi2FreeInstance.argtypes = [ctypes.c_void_p]
    lib.fmi2FreeInstance.restype = None
    return s, lib

def refused(lib, c, h):
    vr, x = (ctypes.c_uint * 1)(0), (ctypes.c_double * 1)()
    return lib.fmi2DoStep(c, h, h, 1) == 3 and lib.fmi2GetReal(c, vr, 1, x) == 3  # fmi2Error

h = float(sys.argv[3])
fluid, flib = slave(sys.argv[1], "f")
rigid, rlib = slave(sys.argv[2], "r")
keep, _ = slave(sys.argv[2], "k")
c = rigid.component
# freed memory that still holds the instance's bytes, as an allocator may leave it
stale = ctypes.create_string_buffer(ctypes.string_at(c, 256), 256)
rlib.fmi2FreeInstance(c)
rlib.fmi2FreeInstance(c)  # a second free: ignored
print("freed handle refused:", refused(rlib, c, h), flush=True)
print("stale bytes refused:", refused(rlib, ctypes.addressof(stale), h), flush=True)
rlib.fmi2FreeInstance(ctypes.addressof(stale))  # ignored, not freed
print("other FMU's instance refused:", refused(flib, keep.component, h), flush=True)
keep.doStep(h, h)  # the other rigid instance lives on
keep.freeInstance()
fluid.doStep(h, h)
fluid.freeInstance()
print("end", flush=True)
"""


def test_freed_or_stray_instance_is_refused(fmus, tmp_path):
    """A second fmi2FreeInstance, and any call on a freed handle or on a
    pointer that was never an instance of this FMU, is refused with fmi2Error
    (fmi2FreeInstance: ignored) without reading what is behind it
    (common/fmi_instance.c, the registry of live instances). Before, a magic
    number inside the freed block was checked, and its clearing store was
    removed by -O3: valgrind saw 12 invalid free() of a second
    fmi2FreeInstance; here the bytes of a freed instance kept in a buffer
    stand for that freed block."""
    script = tmp_path / "stale.py"
    script.write_text(STALE_HANDLES)
    p = subprocess.run([PY, script, fmus["free"] / "fluid.fmu", fmus["free"] / "rigid.fmu", repr(DT)],
                       capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert p.returncode == 0, f"exit {p.returncode}: {p.stdout}{p.stderr[-2000:]}"
    assert p.stdout.splitlines() == ["freed handle refused: True", "stale bytes refused: True",
                                     "other FMU's instance refused: True", "end"], p.stdout


# Run in its own process: the old layer freed a state handle twice (abort in free()).
STALE_STATES = r"""
import ctypes, sys
import fmpy
from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE

fmu, h = sys.argv[1], float(sys.argv[2])
unzipped = fmpy.extract(fmu)  # one folder: every instance below shares one library
md = fmpy.read_model_description(unzipped)
callbacks = fmi2CallbackFunctions()
callbacks.logger = fmi2CallbackLoggerTYPE(lambda *args: None)

def slave(name):
    s = FMU2Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier="fluid", instanceName=name)
    s.instantiate(callbacks=callbacks)
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    s.doStep(0.0, h)
    return s

def rss_mb():
    return int(next(l for l in open("/proc/self/status") if l.startswith("VmRSS")).split()[1]) / 1024

a = slave("a")
lib = ctypes.CDLL(a.dll._name)  # the raw entry points: fmpy raises on fmi2Error
lib.fmi2FreeFMUstate.argtypes = [ctypes.c_void_p, ctypes.c_void_p]
lib.fmi2SetFMUstate.argtypes = [ctypes.c_void_p, ctypes.c_void_p]
lib.fmi2SerializedFMUstateSize.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.POINTER(ctypes.c_size_t)]
state = a.getFMUstate()
a.doStep(h, h)  # copies the state's native part: a block of its own
copy = ctypes.c_void_p(state.value)
a.freeFMUstate(state)
size = ctypes.c_size_t(0)
print("freed state refused:", lib.fmi2SetFMUstate(a.component, copy) == 3 and
      lib.fmi2SerializedFMUstateSize(a.component, copy, ctypes.byref(size)) == 3, flush=True)
print("second free:", lib.fmi2FreeFMUstate(a.component, ctypes.byref(copy)), copy.value, flush=True)
# a state the master did not free goes with its instance
b = slave("b")
left = b.getFMUstate()
b.doStep(h, h)
b.freeInstance()
print("state of a freed instance refused:", lib.fmi2SetFMUstate(a.component, left) == 3, flush=True)
for k in range(25):
    if k == 5:
        before = rss_mb()
    c = slave("c")
    c.getFMUstate()
    c.doStep(h, h)
    c.freeInstance()
print("grew MB:", round(rss_mb() - before), flush=True)
a.doStep(2 * h, h)
a.freeInstance()
print("end", flush=True)
"""


def test_stale_fmu_states_are_refused_and_freed_with_their_instance(fmus, tmp_path):
    """FMI 2.0: fmi2FreeInstance frees all the memory the FMU allocated, the states the master
    left too. Before, a state made by an instance outlived it (the free scene's state is 0.96 MB:
    40 instances, each freed with one state left, grew the process by 53 MB; now 15 MB, all of it
    the first instance's), and a second fmi2FreeFMUstate of a copied handle aborted the process in
    free() ("double free detected"); a freed handle's size read as 23 GB. The library now keeps
    a registry of its live states, as of its instances (common/fmi_state.c): a freed or unknown
    handle is refused (fmi2Error) or, given to fmi2FreeFMUstate, ignored with a warning."""
    script = tmp_path / "stale_states.py"
    script.write_text(STALE_STATES)
    p = subprocess.run([PY, script, fmus["free"] / "fluid.fmu", repr(DT)], capture_output=True, text=True,
                       timeout=300, cwd=tmp_path)
    assert p.returncode == 0, f"exit {p.returncode}: {p.stdout}{p.stderr[-2000:]}"
    lines = p.stdout.splitlines()
    grew = float(lines[3].split(":")[1])
    assert lines[:3] + lines[4:] == ["freed state refused: True", "second free: 1 None",
                                     "state of a freed instance refused: True", "end"], p.stdout
    assert grew < 8, p.stdout  # 20 instances, a 0.96 MB state left by each


# Run in its own process: the old layer stepped a NULL component (segmentation fault).
FORGED_STATES = r"""
import ctypes, struct, sys
import fmpy
from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE

fmu, h = sys.argv[1], float(sys.argv[2])
md = fmpy.read_model_description(fmu)
messages = []
callbacks = fmi2CallbackFunctions()
callbacks.logger = fmi2CallbackLoggerTYPE(lambda env, name, status, cat, msg: messages.append(msg.decode()))
s = FMU2Slave(guid=md.guid, unzipDirectory=fmpy.extract(fmu), modelIdentifier=md.coSimulation.modelIdentifier,
              instanceName="a")
s.instantiate(callbacks=callbacks)
s.setupExperiment(startTime=0.0)
s.enterInitializationMode()
init = bytearray(s.serializeFMUstate(s.getFMUstate()))  # no component yet
s.exitInitializationMode()
s.doStep(0.0, h)
stepped = bytearray(s.serializeFMUstate(s.getFMUstate()))
lib = ctypes.CDLL(s.dll._name)  # the raw entry points: fmpy raises on fmi2Error
lib.fmi2DeSerializeFMUstate.argtypes = [ctypes.c_void_p, ctypes.c_char_p, ctypes.c_size_t, ctypes.POINTER(ctypes.c_void_p)]
for name, blob, state in [("StepComplete without a component", init, 4), ("Terminated without a component", init, 64),
                          ("Instantiated with a component", stepped, 1), ("StepInProgress", stepped, 8),
                          ("Fatal", stepped, 256)]:
    bad = bytearray(blob)
    struct.pack_into("<i", bad, 80, state)  # the header's state (common/fmi_state.c state_header_t)
    handle = ctypes.c_void_p()
    rc = lib.fmi2DeSerializeFMUstate(s.component, bytes(bad), len(bad), ctypes.byref(handle))
    print(name, "refused:", rc == 3 and "inconsistent" in messages[-1], flush=True)
s.doStep(h, h)  # the instance steps on
s.freeInstance()
print("end", flush=True)
"""


@pytest.mark.parametrize("fmu", ["fluid", "rigid"])
def test_forged_state_header_is_refused(fmus, tmp_path, fmu):
    """A state blob whose header puts the instance in a state that has a component (StepComplete,
    Terminated) but carries none was taken, and the next fmi2DoStep stepped a NULL component:
    segmentation fault, with both FMUs (the blob of a state taken in Initialization Mode, its state
    field 2 set to 4). Now the header's state must be one a state can be taken in, with a component
    exactly where that state has one."""
    script = tmp_path / "forged.py"
    script.write_text(FORGED_STATES)
    p = subprocess.run([PY, script, fmus["free"] / f"{fmu}.fmu", repr(DT)], capture_output=True, text=True,
                       timeout=300, cwd=tmp_path)
    assert p.returncode == 0, f"exit {p.returncode}: {p.stdout}{p.stderr[-2000:]}"
    assert p.stdout.splitlines() == [f"{n} refused: True" for n in (
        "StepComplete without a component", "Terminated without a component", "Instantiated with a component",
        "StepInProgress", "Fatal")] + ["end"], p.stdout


def test_guid_and_resources_are_checked(fmus, tmp_path):
    s = Slave(fmus["free"] / "fluid.fmu", tmp_path)
    s.close()
    md = s.md
    bad = FMU2Slave(guid="{00000000-0000-0000-0000-000000000000}", unzipDirectory=s.dir,
                    modelIdentifier="fluid", instanceName="x")
    with pytest.raises(Exception, match="instantiate"):
        bad.instantiate(callbacks=s.callbacks)
    assert any("does not match" in m[2] for m in s.messages)
    bad.freeLibrary()
    (pathlib.Path(s.dir) / "resources" / "scene.yaml").unlink()
    bad = FMU2Slave(guid=md.guid, unzipDirectory=s.dir, modelIdentifier="fluid", instanceName="y")
    with pytest.raises(Exception, match="instantiate"):
        bad.instantiate(callbacks=s.callbacks)
    assert any("cannot open" in m[2] for m in s.messages)
    bad.freeLibrary()


def drive(s, inputs, t0, n, h=DT):
    """n steps from t0 with fixed inputs; returns the outputs after each step."""
    rows = []
    for k in range(n):
        s.fmu.setReal([s.vr[name] for name in inputs], list(inputs.values()))
        s.fmu.doStep(t0 + k * h, h)
        rows.append(s.outputs())
    return np.array(rows)


@pytest.mark.parametrize("fmu,inputs", [
    ("free/fluid.fmu", {"sphere[0].velocity.x": -2e-3, "sphere[0].angular_velocity.z": 5.0}),
    ("free/rigid.fmu", {"sphere[0].force.x": 1e-9, "sphere[0].torque.z": 1e-15}),
    ("cvode/rigid.fmu", {"sphere[0].force.x": 1e-9, "sphere[0].torque.z": 1e-15}),
])
def test_fmu_state_restore_is_bit_identical(fmus, tmp_path, fmu, inputs):
    path = fmus[fmu.split("/")[0]] / fmu.split("/")[1]
    s = Slave(path, tmp_path)
    s.init()
    n1, n2 = 5, 8
    drive(s, inputs, 0.0, n1)
    state = s.fmu.getFMUstate()
    first = drive(s, inputs, n1 * DT, n2)
    assert np.any(first[-1] != 0)
    s.fmu.setFMUstate(state)
    again = drive(s, inputs, n1 * DT, n2)
    assert np.array_equal(first, again)
    # serialised, deserialised, restored into a second instance of the same FMU
    blob = s.fmu.serializeFMUstate(state)
    s.fmu.freeFMUstate(state)
    other = Slave(path, tmp_path, name="b")
    other.init()
    restored = other.fmu.deSerializeFMUstate(blob)
    other.fmu.setFMUstate(restored)
    assert np.array_equal(drive(other, inputs, n1 * DT, n2), first)
    other.fmu.freeFMUstate(restored)
    # a damaged blob is refused with a message
    other.fails(other.fmu.deSerializeFMUstate, b"garbage" * 20, expect="bad magic")
    # and so is one whose time is not finite (the header's t, common/fmi_state.c)
    bad = bytearray(blob)
    struct.pack_into("<d", bad, 96, math.nan)
    other.fails(other.fmu.deSerializeFMUstate, bytes(bad), expect="allowed: finite times")
    # one byte of the state's last part (the component's) changed on its way: its header's checks
    # passed and the damage was restored; the checksum of fmi2SerializeFMUstate refuses it
    bad = bytearray(blob)
    bad[len(bad) - 9] ^= 0x04
    other.fails(other.fmu.deSerializeFMUstate, bytes(bad), expect="the serialized FMU state is damaged")
    # a forged model name is quoted printable (it was quoted raw, not UTF-8: the logger failed)
    bad = bytearray(blob)
    bad[8:12] = b"\xff\xfe\x80\x01"
    other.fails(other.fmu.deSerializeFMUstate, bytes(bad), expect="the FMU state belongs to model ????")
    other.close()
    # a state keeps the component's native part uncopied until the component
    # changes (common/fmi_state.c): serialised at once it is written from the
    # component, and a state copied by the step that follows it gives the same
    # bytes; both restore the run
    lazy = s.fmu.getFMUstate()
    kept = s.fmu.getFMUstate()
    blob_lazy = s.fmu.serializeFMUstate(lazy)
    s.fmu.freeFMUstate(lazy)
    later = drive(s, inputs, (n1 + n2) * DT, 3)  # its first step copies `kept` first
    assert s.fmu.serializeFMUstate(kept) == blob_lazy
    s.fmu.setFMUstate(kept)
    assert np.array_equal(drive(s, inputs, (n1 + n2) * DT, 3), later)
    # restoring the state the component is still in changes nothing
    same = s.fmu.getFMUstate()
    s.fmu.setFMUstate(same)
    assert np.array_equal(drive(s, inputs, (n1 + n2 + 3) * DT, 2), drive_again(s, same, inputs, (n1 + n2 + 3) * DT, 2))
    s.fmu.freeFMUstate(same)
    s.fmu.freeFMUstate(kept)
    s.close()


def drive_again(s, state, inputs, t0, n):
    """Back to state, then n steps from t0 as drive."""
    s.fmu.setFMUstate(state)
    return drive(s, inputs, t0, n)


def test_fluid_takes_steps_that_are_differences_of_late_times(fmus, tmp_path):
    """A master that starts late and passes h = t[n+1] - t[n], with t[n] = start + n dt, hands
    the fluid a step off by the round-off of t (start 1000 s: h/dt = 0.999999997; 1e5 s:
    1.00000034): it was refused as 'not a whole number of LBM steps' (tolerance 1e-9 h). Now an
    ulp-sized error of |t| + h is taken as round-off, the step is one LBM step and the run equals
    the one started at 0; a start so late that a double cannot resolve dt is refused, saying so."""
    inputs = {"sphere[0].velocity.x": -2e-3}

    def run(start, n=4):
        s = Slave(fmus["free"] / "fluid.fmu", tmp_path, name=f"s{start:g}")
        s.fmu.setupExperiment(startTime=start)
        s.fmu.enterInitializationMode()
        s.fmu.exitInitializationMode()
        t = [start + k * DT for k in range(n + 1)]
        for k in range(n):
            s.fmu.setReal([s.vr["sphere[0].velocity.x"]], list(inputs.values()))
            s.fmu.doStep(t[k], t[k + 1] - t[k])
        out = s.outputs()
        assert s.fmu.getRealStatus(2) == pytest.approx(t[n], rel=1e-15)  # fmi2LastSuccessfulTime
        s.close()
        return out

    first = run(0.0)
    for start in (1e3, 1e5):
        assert ((start + DT) - start) / DT - 1 != 0
        np.testing.assert_array_equal(run(start), first)
    s = Slave(fmus["free"] / "fluid.fmu", tmp_path, name="late")
    s.fmu.setupExperiment(startTime=1e12)
    s.fmu.enterInitializationMode()
    s.fmu.exitInitializationMode()
    s.fails(s.fmu.doStep, 1e12, DT, expect="a double resolves times only to")
    s.close()
    # a communication point 5 LBM steps off where the FMU is, at t = 1e5 s: refused (the tolerance
    # was 1e-9 |t|, 1e-4 s there; now a part of the step and a few ulps of t)
    s = Slave(fmus["free"] / "fluid.fmu", tmp_path, name="off")
    s.fmu.setupExperiment(startTime=1e5)
    s.fmu.enterInitializationMode()
    s.fmu.exitInitializationMode()
    s.fails(s.fmu.doStep, 1e5 + 5 * DT, DT, expect="is not where the FMU is")
    s.close()


def test_fluid_refuses_a_step_of_more_lbm_steps_than_it_can_count(fmus, tmp_path):
    """A communication step of 1e20 s (1e25 LBM steps: more than a long holds) was counted as
    LONG_MIN LBM steps: fmi2DoStep returned fmi2OK having taken none, and the FMU's time was
    1e20 s. Now it is refused, naming the longest step."""
    s = Slave(fmus["free"] / "fluid.fmu", tmp_path)
    s.init()
    for h in (1e20, 9.3e18 * DT):
        s.fails(s.fmu.doStep, 0.0, h, expect="is too long: a double resolves t + h only to")
    assert s.fmu.getRealStatus(2) == 0.0  # fmi2LastSuccessfulTime
    s.fmu.doStep(0.0, DT)
    s.close()


def test_cvode_step_limit_holds_with_contacts(fmus, tmp_path):
    """CVODE's limit of 200000 internal steps per communication step (README "Integrators") holds
    with a contact model too (the scene's default spring_dashpot), where the step is taken one
    internal step at a time for the contact watch and CVodeSetMaxNumSteps never applies. A torque
    of 1e-3 N.m on the sphere (I = 8.1e-20 kg.m2) spins it past 1e10 rad/s within the step: before,
    that step of 1e-5 s ran for 21 s (0.01 N.m: 188 s, and longer without bound for more) and
    succeeded; now it fails after 200000 steps (0.6 s), as it did without a contact model."""
    s = Slave(fmus["cvode"] / "rigid.fmu", tmp_path)
    s.init()
    s.fmu.setReal([s.vr["sphere[0].torque.z"]], [1e-3])
    t0 = time.perf_counter()
    s.fails(s.fmu.doStep, 0.0, DT, expect="200000 internal steps (the limit per communication step)")
    assert time.perf_counter() - t0 < 10
    assert any("CV_TOO_MUCH_WORK; fastest turning body 0" in m[2] for m in s.messages)
    s.close()


def test_cvode_failure_without_a_contact_names_tolerances_and_loads(fmus, tmp_path):
    """A load of 1e200 N on the sphere makes CVODE fail in its linear setup (CV_LSETUP_FAIL): the
    message named neither the tolerances nor the load (found by a helper's FMI sweep); now it
    gives rigid.rtol, rigid.atol and the largest load on a sphere."""
    s = Slave(fmus["cvode"] / "rigid.fmu", tmp_path)
    s.init()
    s.fmu.setReal([s.vr["sphere[0].force.x"]], [1e200])
    s.fails(s.fmu.doStep, 0.0, DT, expect="cvode: CVode failed")
    said = [m[2] for m in s.messages if "CVode failed" in m[2]]
    assert said and "rigid.rtol = " in said[0] and "rigid.atol = " in said[0], said
    assert "largest hydrodynamic load on a sphere 1e+200 N" in said[0], said
    s.close()


def test_fields_string_parameter_and_lazy_totals(coupler, tmp_path):
    """output.fields (String, only with run.fields) makes the fluid FMU write
    its own field snapshots; the fluid totals are outputs computed when read."""
    text = SCENE.format(motion="\n    motion: fixed").replace(
        "output_interval: 1.0e-4}", "output_interval: 1.0e-4, fields: true, field_interval: 2.0e-5}")
    d, _ = export(tmp_path, "fields", text)
    assert validate_fmu(str(d / "fluid.fmu")) == []
    s = Slave(d / "fluid.fmu", tmp_path)
    f = s.fmu
    var = {v.name: v for v in s.md.modelVariables}["output.fields"]
    assert var.type == "String" and var.causality == "parameter" and var.variability == "fixed"
    h5 = tmp_path / "f.h5"
    f.setupExperiment(startTime=0.0)
    f.enterInitializationMode()
    f.setString([var.valueReference], [str(h5)])
    assert f.getString([var.valueReference])[0].decode() == str(h5)
    f.exitInitializationMode()
    s.fails(f.setString, [var.valueReference], ["other.h5"], expect="fixed parameter")
    for n in range(5):
        f.doStep(n * DT, DT)
    mass, ke = f.getReal([s.vr["fluid.mass"], s.vr["fluid.kinetic_energy"]])
    f.terminate()
    import h5py
    # fmi2Terminate closes the field file: the master reads it before fmi2FreeInstance
    # (it stayed open and locked until then: "unable to lock file")
    with h5py.File(h5, "r") as h:
        assert sorted(h["/fields"].keys()) == ["000000", "000002", "000004"]
    s.close()
    fluid_volume = (1.6e-4) ** 3 - 4 / 3 * math.pi * (3e-5) ** 3  # the sphere, 3 cells: about +-5% in cells
    assert mass == pytest.approx(RHO_F * fluid_volume, rel=0.05) and ke < 1e-30  # fixed sphere, fluid at rest
    with h5py.File(h5, "r") as h:
        assert sorted(h["/fields"].keys()) == ["000000", "000002", "000004"]
        assert h["/fields/000004"].attrs["time"] == pytest.approx(4 * DT)
    assert "f.h5:/fields/000004/velocity" in (tmp_path / "f.xmf").read_text()
    # without run.fields the FMU has no String variable at all
    _, v = variables(d.parent / "fields" / "fluid.fmu")
    assert "output.fields" in v
    _, v = variables(export(tmp_path, "nofields", SCENE.format(motion=""))[0] / "fluid.fmu")
    assert "output.fields" not in v


def test_reset_gives_string_parameters_their_start_value(coupler, tmp_path):
    """fmi2Reset puts every variable back to its start value (FMI 2.0: as after fmi2Instantiate),
    the String parameters too. output.fields kept the file of the run before the reset, so the next
    run, which did not set it, wrote its snapshots over that run's file (its mtime changed, its
    snapshots replaced) and fmi2GetString still gave the old path."""
    text = SCENE.format(motion="\n    motion: fixed").replace(
        "output_interval: 1.0e-4}", "output_interval: 1.0e-4, fields: true, field_interval: 2.0e-5}")
    d, _ = export(tmp_path, "fields_reset", text)
    s = Slave(d / "fluid.fmu", tmp_path)
    f = s.fmu
    vr = s.vr["output.fields"]
    h5 = tmp_path / "first.h5"
    f.setupExperiment(startTime=0.0)
    f.enterInitializationMode()
    f.setString([vr], [str(h5)])
    f.exitInitializationMode()
    for n in range(5):
        f.doStep(n * DT, DT)
    f.terminate()
    f.reset()
    f.setupExperiment(startTime=0.0)
    f.enterInitializationMode()
    assert f.getString([vr])[0].decode() == ""
    written = h5.stat().st_mtime_ns, h5.read_bytes()
    f.exitInitializationMode()
    f.doStep(0.0, DT)
    s.close()
    assert (h5.stat().st_mtime_ns, h5.read_bytes()) == written
    import h5py
    with h5py.File(h5, "r") as h:
        assert sorted(h["/fields"].keys()) == ["000000", "000002", "000004"]


def test_field_file_of_another_instance_is_refused_also_to_resume(coupler, tmp_path):
    """Two fluid instances in one process (FMI: independent) given the same field file. A second
    output.fields was refused (the file is held open), but output.fields_resume was taken: HDF5 hands
    a process the file it has open already, so the second instance wrote into the first one's file
    (a snapshot of its step 1 among the first's 0, 2, 4). Now the resume is refused too, before the
    file is opened, and the first instance's file holds its own snapshots only."""
    text = SCENE.format(motion="\n    motion: fixed").replace(
        "output_interval: 1.0e-4}", "output_interval: 1.0e-4, fields: true, field_interval: 2.0e-5}")
    d, _ = export(tmp_path, "fields_shared", text)
    h5 = tmp_path / "shared.h5"
    a = Slave(d / "fluid.fmu", tmp_path, name="a")
    a.fmu.setString([a.vr["output.fields"]], [str(h5)])
    a.init()
    for k, key in enumerate(("output.fields", "output.fields_resume")):
        b = Slave(d / "fluid.fmu", tmp_path, name=f"b{k}")
        b.fmu.setString([b.vr[key]], [str(h5)])
        b.fmu.setupExperiment(startTime=0.0)
        b.fmu.enterInitializationMode()
        b.fails(b.fmu.exitInitializationMode, expect="holds the field file open")
        b.close()
    for n in range(5):
        a.fmu.doStep(n * DT, DT)
    a.fmu.terminate()
    a.close()
    import h5py
    with h5py.File(h5, "r") as h:
        assert sorted(h["/fields"].keys()) == ["000000", "000002", "000004"]
