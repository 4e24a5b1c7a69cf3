#!/usr/bin/env python3
"""Figure of the close approaches (build/sphere_report approach DIR writes the CSVs): the force
on a sphere of radius 8 cells approaching a no-slip wall, and on two spheres approaching each
other (three placements of their midplane in the cell), lattice alone and with the lubrication
film, against Brenner's (1961) exact Stokes result; below, (lattice + film) / Brenner with the
5% band of the tests. Usage: tools/plot_approach.py [DIR]
(default build/report); writes DIR/approach.png."""
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def load(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return {k: [float(r[k]) for r in rows] for k in rows[0]}


def main():
    d = sys.argv[1] if len(sys.argv) > 1 else os.path.join("build", "report")
    fig, axs = plt.subplots(2, 2, figsize=(12, 9), sharex="col")
    panels = [(0, "sphere approaching a no-slip wall", [("approach_wall", "")]),
              (1, "two spheres approaching each other",
               [("approach_pair_face", "midplane on a cell face"), ("approach_pair_quarter", "a quarter cell above"),
                ("approach_pair_node", "midplane on a node")])]
    for col, title, runs in panels:
        ax, rx = axs[0][col], axs[1][col]
        ref_drawn = False
        for name, label in runs:
            path = os.path.join(d, name + ".csv")
            if not os.path.exists(path):
                print(f"plot_approach: {path} is missing (run build/sphere_report approach {d})", file=sys.stderr)
                return 1
            c = load(path)
            g = c["gap_over_a"]
            tot = [a + b for a, b in zip(c["lambda_lattice"], c["lambda_film"])]
            suffix = f" ({label})" if label else ""
            ax.loglog(g, c["lambda_lattice"], lw=0.8, label="lattice alone" + suffix)
            ax.loglog(g, tot, lw=1.2, label="lattice + lubrication film" + suffix)
            rx.semilogx(g, [t / b for t, b in zip(tot, c["lambda_brenner"])], lw=1.0, label="lattice + film" + suffix)
            if not ref_drawn:
                ax.loglog(g, c["lambda_brenner"], "k--", lw=1.2, label="Brenner (1961), exact Stokes")
                ref_drawn = True
        ax.set_ylabel("F / (6 pi mu a U)")
        ax.set_title(title + ", radius 8 cells")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
        rx.axhspan(0.95, 1.05, color="0.9", label="within 5% (the tests)")
        rx.axhline(1.0, color="k", lw=0.8, ls="--")
        rx.set_ylim(0.85, 1.15)
        rx.set_xlabel("surface gap / radius")
        rx.set_ylabel("(lattice + film) / Brenner")
        rx.grid(alpha=0.3, which="both")
        rx.legend(fontsize=8)
        rx.invert_xaxis()
    fig.tight_layout()
    out = os.path.join(d, "approach.png")
    fig.savefig(out, dpi=120)
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
