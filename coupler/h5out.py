"""h5out.py — reading a `coupler run` output file (DESIGN section 5) for
coupler/plot.py and the scene checks in models/checks/, and the one way they
save a figure."""
import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import scene_yaml  # noqa: E402


def text(attr):
    """An HDF5 string attribute as str."""
    return attr.decode() if isinstance(attr, bytes) else str(attr)


def read(h5):
    """Every time series of the file as numpy arrays, with the scene (dict) and
    the root attributes the scripts use. Keys: path, scene, scene_file, h, dx,
    wall_time, t; position, velocity, angular_velocity, force, torque, body
    (/spheres); pair, cforce, ctorque, intact (/connections); nbodies, P, L
    (/bodies); fluid_mass (also as mass), fluid_momentum, fluid_kinetic_energy;
    fields (snapshot names). Absent datasets give absent keys."""
    d = {"path": str(h5)}
    with h5py.File(h5, "r") as f:
        a = f.attrs
        d["scene"] = scene_yaml.load(text(a["scene"])) if "scene" in a else {}
        d["scene_file"] = text(a["scene_file"]) if "scene_file" in a else ""
        d["h"] = float(a["communication_step"]) if "communication_step" in a else float("nan")
        d["dx"] = float(a["dx"]) if "dx" in a else float("nan")
        d["wall_time"] = float(a["wall_time_total"]) if "wall_time_total" in a else float("nan")
        d["t"] = f["/time"][:]
        for k in ("position", "velocity", "angular_velocity", "force", "torque", "body"):
            if f"/spheres/{k}" in f:
                d[k] = f[f"/spheres/{k}"][:]
        if "/connections/pair" in f:
            d["pair"] = f["/connections/pair"][:]
            d["cforce"] = f["/connections/force"][:]
            d["ctorque"] = f["/connections/torque"][:]
            d["intact"] = f["/connections/intact"][:]
        if "/bodies/count" in f:
            d["nbodies"] = f["/bodies/count"][:]
            d["P"] = f["/bodies/momentum"][:]
            d["L"] = f["/bodies/angular_momentum"][:]
        for k in ("mass", "momentum", "kinetic_energy"):
            if f"/fluid/{k}" in f:
                d["fluid_" + k] = f[f"/fluid/{k}"][:]
        if "fluid_mass" in d:
            d["mass"] = d["fluid_mass"]
        d["fields"] = sorted(f["/fields"].keys()) if "/fields" in f else []
    return d


def save(fig, path, written):
    """Saves a figure as PNG, closes it and appends the path to written."""
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    written.append(path)
