#!/usr/bin/env python3
"""report.py — `make report`: what each choice of resolution, boundary scheme,
coupling and integrator costs and buys, and where the method breaks, as one
document a user reads top to bottom.

    tools/report.py [OUTDIR] [--quick] [--jobs N]

writes OUTDIR/report.md (default build/report) with its PNG figures and the
CSV data of every figure beside it. Sections:

1. Fluid accuracy against run time: the drag of a fixed sphere in a simple
   cubic array (Sangani & Acrivos 1982) over many places of the centre in the
   cell, the torque on a rotating sphere (Hofmann et al. 1999), and a free
   sphere settling at low Reynolds number in a periodic box (the same
   Sangani & Acrivos drag, now with the particle moving through the lattice).
2. Integrators against run time: Verlet against CVODE (Adams, BDF) on the
   rigid problems with exact solutions, and on the coupled settling sphere.
3. Coupled accuracy: the paper's sinking sphere at three resolutions and the
   dual star's connection force at two.
4. Stability map (tools/stability_map.py).
5. Cost of a step of every scene in models/, split into fluid, spheres,
   rigid, master and output.
6. Single against double precision storage: drag, settling and memory.

Each section is a module beside this file (report_fluid.py, report_integrators.py,
report_coupled.py, stability_map.py, report_cost.py, report_precision.py; what they
share in report_common.py); this file runs them and writes the document.

Small runs use one OpenMP thread each and run `--jobs` at a time (default 2):
two threads on a loaded 2-core machine spin in OpenMP barriers and run ten
times slower, which would turn the wall-time axis into a measure of the load.
The cost section runs one scene at a time with all threads. `--quick` makes
the same document from shorter sweeps (under 10 minutes on 2 cores).
"""
import argparse
import os
import re
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from report_common import BUILD, COUPLER  # noqa: E402
from report_cost import section_cost  # noqa: E402
from report_coupled import section_coupled  # noqa: E402
from report_fluid import section_fluid  # noqa: E402
from report_integrators import section_integrators  # noqa: E402
from report_precision import section_precision  # noqa: E402


# ---- the document -------------------------------------------------------------------

def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out", nargs="?", default=os.path.join(BUILD, "report"))
    ap.add_argument("--quick", action="store_true", help="shorter sweeps (under 10 minutes on 2 cores)")
    ap.add_argument("--jobs", type=int, default=2, help="small runs at a time (default 2)")
    ap.add_argument("--only", default="1,2,3,4,5,6", help="sections to make (comma list, for development)")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    only = {int(s) for s in args.only.split(",")}
    t_start = time.monotonic()
    parts, figs, times = [], [], {}
    with tempfile.TemporaryDirectory(prefix="report-") as tmp:
        for num, fn in ((1, section_fluid), (2, section_integrators), (3, section_coupled), (4, None),
                        (5, section_cost), (6, section_precision)):
            if num not in only:
                continue
            t0 = time.monotonic()
            print("report: section %d ..." % num, flush=True)
            if num == 4:
                import stability_map
                res = stability_map.run_map(args.out, args.quick, COUPLER, args.jobs)
                md, f = res["markdown"], res["figures"]
            else:
                md, f = fn(args.out, tmp, args.quick, args.jobs)
            times[num] = time.monotonic() - t0
            parts.append((num, md))
            figs += f
            print("report: section %d done in %.0f s" % (num, times[num]), flush=True)
    parts.sort()
    total = time.monotonic() - t_start
    head = """# Report: accuracy against run time, and stability

Made by `make report{q}` on {date} in {total:.0f} s ({secs}); machine: {cpus} cores, load
average at the end {load:.2f}. Wall times are of this machine and this load: compare them within
this report, not with another machine. Every figure has its data beside it as CSV.

Contents: {toc}.
""".format(q=" QUICK=1" if args.quick else "", date=time.strftime("%Y-%m-%d %H:%M"), total=total,
           secs=", ".join("section %d %.0f s" % (k, v) for k, v in sorted(times.items())),
           cpus=os.cpu_count(), load=os.getloadavg()[0],
           toc=", ".join(re.match(r"## (.*)", md).group(1) for _, md in parts))
    with open(os.path.join(args.out, "report.md"), "w") as f:
        f.write(head + "\n" + "\n".join(md for _, md in parts))
    missing = [x for x in figs if not os.path.exists(os.path.join(args.out, x))]
    print("report: %s (%d figures%s) in %.0f s" % (os.path.join(args.out, "report.md"), len(figs),
                                                  ", missing: " + " ".join(missing) if missing else "", total))
    return 1 if missing else 0


if __name__ == "__main__":
    sys.exit(main())
