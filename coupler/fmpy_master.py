#!/usr/bin/env python3
"""fmpy_master.py — the co-simulation master of `coupler run`, in Python with fmpy.

    coupler/fmpy_master.py SCENE.yaml -o OUT.h5 [--set KEY=VALUE]... [--steps N]
                           [--exchange-every K] [--fluid-fmu F] [--rigid-fmu F]
                           [--log-fmi-calls FILE] [--quiet]

Runs a scene through fmpy's FMI 2.0 API (FMU2Slave) with the algorithm of the
C master (coupler/run.c, DESIGN section 2) and writes the same HDF5 layout
(DESIGN section 5, coupler/output.h) with h5py:

  per communication step n, t = n h (h = K LBM steps, from the step counter):
    rigid kinematics -> fluid inputs; fluid doStep(t, h);
    fluid forces/torques -> rigid inputs; rigid doStep(t, h)
  output rows at t >= k * run.output_interval and at the end; the last step
  is shorter when K does not divide the LBM steps to run.end_time.

The FMUs are exported from the scene with `build/coupler export` (the same
--set options) unless given. Every input is connected to the output of the
other FMU with the same name (error if missing or if type or unit differ).
Since the same shared libraries receive the same calls with the same values,
the numbers equal those of the C master bit for bit. --log-fmi-calls writes
fmpy's log of every FMI call (label, function, arguments, status); progress
(step, simulated time, wall time, ETA, MLUPS) goes to a terminal unless --quiet.
"""
import argparse
import json
import math
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import time as wallclock

import h5py
import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

import scene_yaml

ROOT = pathlib.Path(__file__).resolve().parents[1]
COUPLER = ROOT / "build" / "coupler"
SPHERE_Q = ("position", "velocity", "angular_velocity", "force", "torque")
UNITS = {"position": "m", "velocity": "m/s", "angular_velocity": "rad/s", "force": "N", "torque": "N m"}
VERSION = "0.2.0"


class MasterError(Exception):
    pass


class Counted:
    """An FMU2Slave whose calls are counted per FMI function."""

    def __init__(self, label, path, tmp, call_log=None):
        self.label = label
        folder = path if os.path.isdir(path) else extract(path, unzipdir=os.path.join(tmp, label))
        self.md = read_model_description(folder)
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.slave = FMU2Slave(guid=self.md.guid, unzipDirectory=folder,
                               modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=label,
                               fmiCallLogger=(lambda msg: call_log.write(f"{label} {msg}\n")) if call_log else None)
        self.calls = {}
        self.step_seconds = 0.0
        self.instantiated = self.initialized = False  # what close() may undo

    def count(self, name):
        self.calls[name] = self.calls.get(name, 0) + 1

    def instantiate(self, t0, t_stop):
        self.count("fmi2Instantiate")
        self.slave.instantiate()
        self.instantiated = True
        self.count("fmi2SetupExperiment")
        self.slave.setupExperiment(startTime=t0, stopTime=t_stop)
        self.count("fmi2EnterInitializationMode")
        self.slave.enterInitializationMode()

    def set_string(self, name, value):
        self.count("fmi2SetString")
        self.slave.setString([self.vars[name].valueReference], [value])

    def exit_init(self):
        self.count("fmi2ExitInitializationMode")
        self.slave.exitInitializationMode()
        self.initialized = True

    def get_real(self, vrs):
        self.count("fmi2GetReal")
        return self.slave.getReal(vrs)

    def set_real(self, vrs, values):
        self.count("fmi2SetReal")
        self.slave.setReal(vrs, values)

    def get_integer(self, vrs):
        self.count("fmi2GetInteger")
        return self.slave.getInteger(vrs)

    def get_boolean(self, vrs):
        self.count("fmi2GetBoolean")
        return self.slave.getBoolean(vrs)

    def do_step(self, t, h):
        self.count("fmi2DoStep")
        w0 = wallclock.perf_counter()
        self.slave.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        self.step_seconds += wallclock.perf_counter() - w0

    def close(self):
        """Ends the instance as far as it got: fmi2Terminate of an FMU never initialised fails
        and its error replaced the exception that stopped the run."""
        try:
            if self.initialized:
                self.slave.terminate()
        finally:
            if self.instantiated:
                self.slave.freeInstance()


def lattice(scene, dt):
    """dx, tau and the grid from the scene (the rules of fluid/units.c)."""
    f = scene["fluid"]
    size = scene["domain"]["size"]
    if "dx" in f:
        dx = float(f["dx"])
    else:
        radii = [s["radius"] for b in scene.get("bodies", []) for s in b["spheres"]]
        dx = min(radii) / float(f["cells_per_radius"])
    tau = float(f["tau"]) if "tau" in f else 0.5 + 3.0 * float(f["viscosity"]) * dt / dx ** 2
    grid = [int(round(L / dx)) for L in size]
    return dx, tau, grid


def connect(frm, to):
    """(src vrs of frm, dst vrs of to) for every input of `to`."""
    src, dst, errors = [], [], []
    for v in to.md.modelVariables:
        if v.causality != "input":
            continue
        o = frm.vars.get(v.name) if frm is not None else None
        if o is None or o.causality != "output":
            errors.append(f"signal mismatch: input {v.name} of {to.label} has no output of that name in "
                          f"{frm.label if frm else 'any FMU (the scene has no rigid.fmu)'}")
        elif o.type != v.type or o.unit != v.unit:
            errors.append(f"signal mismatch: {v.name} is {v.type} [{v.unit}] in {to.label} "
                          f"but {o.type} [{o.unit}] in {frm.label}")
        else:
            src.append(o.valueReference)
            dst.append(v.valueReference)
    return src, dst, errors


def find(fmus, name, type_):
    for f in fmus:
        if f is None:
            continue
        v = f.vars.get(name)
        if v is not None and v.causality == "output":
            if v.type != type_:
                raise MasterError(f"{name} of {f.label} is {v.type}; the master expects {type_}")
            return f, v.valueReference
    return None, None


class Reader:
    """Reads the observed outputs of one row, as coupler/run.c does."""

    def __init__(self, fluid, rigid, ns, nc, bodies):
        self.fluid, self.rigid, self.ns, self.nc = fluid, rigid, ns, nc
        self.real = {id(fluid): ([], []), id(rigid): ([], [])}
        self.body_default = np.array(bodies, dtype=np.int32)
        self.body_vr, self.body_dest, self.intact_vr = [], [], []
        for i in range(ns):
            for q in SPHERE_Q:
                for a in "xyz":
                    # the load that acted over the step: rigid.fmu's applied load under the
                    # implicit coupling, else the fluid's (as coupler/run.c)
                    applied = f"sphere[{i}].applied_{q}.{a}"
                    if q in ("force", "torque") and find([rigid], applied, "Real")[0] is not None:
                        self._real(applied, ("sphere", q, i, "xyz".index(a)))
                    else:
                        self._real(f"sphere[{i}].{q}.{a}", ("sphere", q, i, "xyz".index(a)))
            f, vr = find([rigid], f"sphere[{i}].body", "Integer")
            if f is not None:
                self.body_vr.append(vr)
                self.body_dest.append(i)
        for k in range(nc):
            for q in ("force", "torque"):
                for a in "xyz":
                    self._real(f"connection[{k}].{q}.{a}", ("conn", q, k, "xyz".index(a)))
            f, vr = find([rigid], f"connection[{k}].intact", "Boolean")
            if f is None:
                raise MasterError(f"no FMU publishes the output connection[{k}].intact that the output file needs")
            self.intact_vr.append(vr)
        for name in ("fluid.mass", "fluid.kinetic_energy", "fluid.max_speed"):
            self._real(name, ("diag", name, 0, 0))
        for name in ("fluid.momentum", "fluid.peak_velocity"):
            for a in "xyz":
                self._real(f"{name}.{a}", ("diag", name, 0, "xyz".index(a)))
        self.nbodies_vr = []
        if rigid is not None:
            for name in ("rigid.momentum", "rigid.angular_momentum"):
                for a in "xyz":
                    self._real(f"{name}.{a}", ("diag", name, 0, "xyz".index(a)))
            f, vr = find([rigid], "rigid.bodies", "Integer")
            if f is None:
                raise MasterError("no FMU publishes the output rigid.bodies that the output file needs")
            self.nbodies_vr = [vr]

    def _real(self, name, dest):
        f, vr = find([self.fluid, self.rigid], name, "Real")
        if f is None:
            raise MasterError(f"no FMU publishes the output {name} that the output file needs")
        self.real[id(f)][0].append(vr)
        self.real[id(f)][1].append(dest)

    def read(self):
        row = {q: np.zeros((self.ns, 3)) for q in SPHERE_Q}
        row.update({"conn_force": np.zeros((self.nc, 3)), "conn_torque": np.zeros((self.nc, 3)),
                    "fluid.mass": 0.0, "fluid.kinetic_energy": 0.0, "fluid.max_speed": 0.0,
                    "fluid.momentum": np.zeros(3), "fluid.peak_velocity": np.zeros(3),
                    "rigid.momentum": np.zeros(3), "rigid.angular_momentum": np.zeros(3)})
        for f in (self.fluid, self.rigid):
            if f is None or not self.real[id(f)][0]:
                continue
            vrs, dests = self.real[id(f)]
            for x, (kind, q, i, a) in zip(f.get_real(vrs), dests):
                if kind == "sphere":
                    row[q][i, a] = x
                elif kind == "conn":
                    row["conn_" + q][i, a] = x
                elif q in ("fluid.momentum", "fluid.peak_velocity", "rigid.momentum", "rigid.angular_momentum"):
                    row[q][a] = x
                else:
                    row[q] = x
        body = self.body_default.copy()
        if self.body_vr:
            for i, b in zip(self.body_dest, self.rigid.get_integer(self.body_vr)):
                body[i] = b
        row["body"] = body
        row["rigid.bodies"] = self.rigid.get_integer(self.nbodies_vr)[0] if self.nbodies_vr else 0
        row["intact"] = np.array(self.rigid.get_boolean(self.intact_vr) if self.intact_vr else [], dtype=np.int32)
        return row


class Output:
    """The HDF5 layout of coupler/output.h, written with h5py."""

    def __init__(self, path, scene_text, scene_file, scene, dx, dt, tau, grid, ns, nc, pairs, fields_rel, bodies):
        self.f = h5py.File(path, "w")
        a = self.f.attrs
        a["scene"] = np.bytes_(scene_text)
        a["scene_file"] = np.bytes_(scene_file)
        a["version"] = np.bytes_(VERSION)
        a["integrator"] = np.bytes_(scene.get("rigid", {}).get("integrator", "verlet"))
        a["dx"], a["dt"], a["tau"] = dx, dt, tau
        a["grid"] = np.array(grid, dtype=float)
        a["ranks"] = 1.0
        self.ns, self.nc, self.bodies = ns, nc, bodies
        self.sets = {}
        self._series("/time", (), "s")
        self._series("/fluid/mass", (), "kg")
        self._series("/fluid/momentum", (3,), "kg m/s")
        self._series("/fluid/kinetic_energy", (), "J")
        if ns > 0:
            for q in SPHERE_Q:
                self._series(f"/spheres/{q}", (ns, 3), UNITS[q])
            self._series("/spheres/body", (ns,), "body id", np.int32)
        if nc > 0:
            d = self.f.create_dataset("/connections/pair", data=np.array(pairs, dtype=np.int32).reshape(nc, 2))
            d.attrs["unit"] = np.bytes_("sphere index")
            self._series("/connections/force", (nc, 3), "N")
            self._series("/connections/torque", (nc, 3), "N m")
            self._series("/connections/intact", (nc,), "1 intact, 0 broken", np.int32)
        if bodies:
            self._series("/bodies/count", (), "bodies", np.int32)
            self._series("/bodies/momentum", (3,), "kg m/s")
            self._series("/bodies/angular_momentum", (3,), "kg m^2/s")
        if fields_rel is not None:
            self.f["/fields"] = h5py.ExternalLink(fields_rel, "/fields")
        self.f.flush()

    def _series(self, name, shape, unit, dtype=np.float64):
        per_row = int(np.prod(shape)) if shape else 1
        chunk = (1 if per_row >= 4096 else 4096 // per_row,) + shape
        d = self.f.create_dataset(name, shape=(0,) + shape, maxshape=(None,) + shape, chunks=chunk, dtype=dtype)
        d.attrs["unit"] = np.bytes_(unit)
        self.sets[name] = d

    def _append(self, name, value):
        d = self.sets[name]
        d.resize(d.shape[0] + 1, axis=0)
        d[-1] = value

    def row(self, t, r):
        self._append("/time", t)
        self._append("/fluid/mass", r["fluid.mass"])
        self._append("/fluid/momentum", r["fluid.momentum"])
        self._append("/fluid/kinetic_energy", r["fluid.kinetic_energy"])
        if self.ns > 0:
            for q in SPHERE_Q:
                self._append(f"/spheres/{q}", r[q])
            self._append("/spheres/body", r["body"])
        if self.nc > 0:
            self._append("/connections/force", r["conn_force"])
            self._append("/connections/torque", r["conn_torque"])
            self._append("/connections/intact", r["intact"])
        if self.bodies:
            self._append("/bodies/count", r["rigid.bodies"])
            self._append("/bodies/momentum", r["rigid.momentum"])
            self._append("/bodies/angular_momentum", r["rigid.angular_momentum"])
        self.f.flush()


def export(scene_path, sets, folder):
    args = [str(COUPLER), "export", str(scene_path), "-d", str(folder)]
    for s in sets:
        args += ["--set", s]
    p = subprocess.run(args, capture_output=True, text=True)
    if p.returncode != 0:
        raise MasterError(f"`coupler export` failed:\n{p.stderr}")


class Progress:
    """One status line on a terminal: step, simulated time, wall time, ETA, MLUPS."""

    def __init__(self, enabled, nsteps, cells_per_step):
        self.on = enabled
        self.n, self.cells = nsteps, cells_per_step
        self.t0 = self.last = wallclock.perf_counter()

    def show(self, step, t, fluid_seconds, final=False):
        now = wallclock.perf_counter()
        if not self.on or (not final and now - self.last < 0.5):
            return
        self.last = now
        wall = now - self.t0
        eta = wall / step * (self.n - step) if step > 0 else 0.0
        mlups = self.cells * step / max(fluid_seconds, 1e-9) / 1e6
        sys.stderr.write(f"\r  step {step}/{self.n}  t = {t:.6g} s  wall {wall:.1f} s  ETA {eta:.1f} s  "
                         f"{mlups:.1f} MLUPS ")
        if final:
            sys.stderr.write("\n")
        sys.stderr.flush()


def run(args):
    tmp = tempfile.mkdtemp(prefix="fmpy-master-")
    fluid = rigid = out = call_log = None
    try:
        if args.log_fmi_calls:
            try:
                call_log = open(args.log_fmi_calls, "w")
            except OSError as e:
                raise MasterError(f"{args.log_fmi_calls}: cannot write the FMI call log: {e.strerror}")
        export_dir = pathlib.Path(tmp) / "export"
        if args.fluid_fmu is None or args.rigid_fmu is None:
            export(args.scene, args.set, export_dir)
        fluid = Counted("fluid.fmu", args.fluid_fmu or str(export_dir / "fluid.fmu"), tmp, call_log)
        scene_text = (pathlib.Path(fluid.slave.unzipDirectory) / "resources" / "scene.yaml").read_text()
        scene = scene_yaml.load(scene_text)
        bodies = scene.get("bodies") or []
        free = [b for b in bodies if b.get("motion", "free") == "free"]
        if free:
            rigid = Counted("rigid.fmu", args.rigid_fmu or str(export_dir / "rigid.fmu"), tmp, call_log)
        src_f, dst_f, errors = connect(rigid, fluid)
        src_r, dst_r, errors_r = connect(fluid, rigid) if rigid else ([], [], [])
        if errors or errors_r:
            raise MasterError("\n".join(errors + errors_r))
        ns = sum(len(b["spheres"]) for b in bodies)
        conns = scene.get("connections") or [] if rigid else []
        nc = len(conns)
        scene_body = [b for b, body in enumerate(bodies) for _ in body["spheres"]]
        reader = Reader(fluid, rigid, ns, nc, scene_body)
        dt = float(fluid.md.defaultExperiment.stepSize)
        k = args.exchange_every
        h = k * dt
        run_cfg = scene["run"]
        t_end_scene = float(run_cfg["end_time"])
        # the LBM steps of the run; the last communication step takes the rest
        # when K does not divide them (coupler/run.c)
        n_lbm = args.steps * k if args.steps else math.ceil(t_end_scene / dt - 1e-9)
        nsteps, short_last = -(-n_lbm // k), n_lbm % k
        oi = float(run_cfg.get("output_interval", t_end_scene / 100.0))
        dx, tau, grid = lattice(scene, dt)
        fields_rel = None
        fields_path = None
        if run_cfg.get("fields", False) and "output.fields" in fluid.vars:
            stem = os.path.splitext(args.output)[0]
            fields_path = stem + "_fields.h5"
            fields_rel = os.path.basename(fields_path)
        t_end = n_lbm * dt if short_last else nsteps * h
        wall0 = wallclock.perf_counter()
        fluid.instantiate(0.0, t_end)
        if fields_path is not None:
            fluid.set_string("output.fields", fields_path)
        fluid.exit_init()
        if rigid:
            rigid.instantiate(0.0, t_end)
            rigid.exit_init()
        pairs = [c["spheres"] for c in conns]
        out = Output(args.output, scene_text, str(args.scene), scene, dx, dt, tau, grid, ns, nc, pairs, fields_rel,
                     rigid is not None)
        progress = Progress(sys.stderr.isatty() and not args.quiet, nsteps, float(np.prod(grid)) * k)
        next_out = 0
        row = None
        for n in range(nsteps + 1):
            last = n == nsteps
            t = t_end if last else n * h
            if last or t >= next_out * oi - 1e-9 * dt:
                row = reader.read()
                out.row(t, row)
                while next_out * oi <= t + 1e-9 * dt:
                    next_out += 1
            if last:
                progress.show(n, t, fluid.step_seconds, final=True)
                break
            progress.show(n, t, fluid.step_seconds)
            if rigid and src_f:
                fluid.set_real(dst_f, rigid.get_real(src_f))
            hn = t_end - t if short_last and n + 1 == nsteps else h
            fluid.do_step(t, hn)
            if rigid:
                if src_r:
                    rigid.set_real(dst_r, fluid.get_real(src_r))
                rigid.do_step(t, hn)
        wall = wallclock.perf_counter() - wall0
        a = out.f.attrs
        wf = fluid.step_seconds
        wr = rigid.step_seconds if rigid else 0.0
        a["wall_time_fluid"], a["wall_time_rigid"] = wf, wr
        a["wall_time_master"], a["wall_time_total"] = wall - wf - wr, wall
        a["exchange_every"], a["communication_step"] = float(k), h
        a["mlups"] = float(np.prod(grid)) * n_lbm / max(wf, 1e-9) / 1e6
        a["fmi_calls_fluid"] = np.bytes_(json.dumps(fluid.calls))
        if rigid:
            a["fmi_calls_rigid"] = np.bytes_(json.dumps(rigid.calls))
        last_of = f", the last of {short_last}" if short_last else ""
        print(f"{args.scene}: {nsteps} communication steps of {k} LBM step(s){last_of} (h = {h:.6g} s), "
              f"t = {t_end:.6g} s")
        print(f"  wall time {wall:.3f} s: fluid {wf:.3f} s, rigid {wr:.3f} s")
        print(f"  FMI calls: fluid {sum(fluid.calls.values())} {json.dumps(fluid.calls)}"
              + (f", rigid {sum(rigid.calls.values())} {json.dumps(rigid.calls)}" if rigid else ""))
        print(f"  output {args.output}")
        return 0
    finally:
        if out is not None:
            out.f.close()
        for f in (rigid, fluid):
            if f is not None:
                f.close()
        if call_log is not None:
            call_log.close()
        shutil.rmtree(tmp, ignore_errors=True)


class Once(argparse.Action):
    """An option given twice (-o a.h5 -o b.h5) is a usage error, as in the C coupler,
    not the last one taken."""

    def __call__(self, parser, namespace, values, option_string=None):
        if getattr(namespace, "_given_" + self.dest, False):
            parser.error(f"option '{option_string}' given twice; give it once")
        setattr(namespace, "_given_" + self.dest, True)
        setattr(namespace, self.dest, True if self.nargs == 0 else values)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scene")
    p.add_argument("-o", "--output", required=True, action=Once)
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--steps", type=int, default=0, action=Once, help="communication steps instead of run.end_time")
    p.add_argument("--exchange-every", type=int, default=1, metavar="K", action=Once,
                   help="LBM steps per communication step")
    p.add_argument("--fluid-fmu", action=Once)
    p.add_argument("--rigid-fmu", action=Once)
    p.add_argument("--log-fmi-calls", metavar="FILE", action=Once,
                   help="log every FMI call with its arguments and status")
    p.add_argument("--quiet", action=Once, nargs=0, default=False, help="no progress line")
    args = p.parse_args(argv)
    if args.exchange_every < 1:
        p.error("--exchange-every takes a whole number >= 1")
    try:
        return run(args)
    except MasterError as e:
        print(f"fmpy_master: {e}", file=sys.stderr)
        return 1
    except Exception as e:  # an FMI call that failed (fmpy raises FMICallException)
        print(f"fmpy_master: {type(e).__name__}: {e}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
