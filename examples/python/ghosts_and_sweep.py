#!/usr/bin/env python3
"""Two studies from Python, plotted with matplotlib (no notebook needed).

1. The ghost table of the double Gauss (veil ghosts): every two-reflection ghost ranked by
   its peak irradiance on the sensor, the top 12 as a bar chart.
2. A mount-reflectance sweep of the seed's 6-lens lens with the Sun 7 degrees off axis
   (veil sweep): the stray light that scatters off the mounts against their reflectance,
   every variant traced with the same rays, with its 1-sigma error and a straight line
   through the origin: a Lambertian mount's single scatter goes with its reflectance; light
   scattered by two mounts goes with its square and bends the curve up at 9 %.

Run from the repository root after building:

    PYTHONPATH=build/python python3 examples/python/ghosts_and_sweep.py -o out/python

(--quick: smaller budgets, for the test suite). Writes ghosts.png, sweep.png and prints
both tables.
"""

import argparse
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import veil  # noqa: E402

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
MOUNTS = "scatter(spacer4a|spacer4b|stop|barrel|retainer*|spacer1|spacer2|spacer3|spacer5)"
KEY = "properties.black_anodized.scatter.reflectance"


def ghost_table(out):
    lens = veil.Scene(os.path.join(ROOT, "examples", "lenses", "double_gauss_50mm.toml"))
    report = lens.ghosts(rays=0, top=0).report  # the sequential estimate of every pair
    ghosts = report["ghosts"][:12]
    print("%-4s %-24s %14s %14s" % ("rank", "ghost", "peak W/mm^2", "flux W"))
    for g in ghosts:
        print("%-4d %-24s %14.4g %14.4g" % (g["rank"], g["ghost"], g["peak_irradiance"],
                                             g["flux"]))
    fig, ax = plt.subplots(figsize=(8, 4.5))
    ax.barh([g["ghost"] for g in ghosts][::-1], [g["peak_irradiance"] for g in ghosts][::-1],
            color="#4c72b0")
    ax.set_xscale("log")
    ax.set_xlabel("peak ghost irradiance on the sensor (W/mm², 1 W per field)")
    ax.set_title("%s: the 12 brightest of %d two-reflection ghosts" % (
        report["lens"], report["ghost_count"]), fontsize=10)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "ghosts.png"), dpi=120)
    plt.close(fig)


def mount_sweep(out, rays, batches):
    scene = veil.Scene(os.path.join(ROOT, "examples", "scenes", "longfocus_360mm_sun.toml"))
    values = [0.01, 0.03, 0.05, 0.07, 0.09]
    report = scene.sweep(KEY + "=" + ",".join(map(str, values)), rays=rays, batches=batches,
                         where=[MOUNTS], seed=1).report
    # The quantity of the criterion's layer on the sensor: mount scatter only.
    x, y, e = [], [], []
    for v in report["variants"]:
        m = next(q for q in v["measured"] if q["quantity"].endswith("where1"))
        x.append(float(v["values"][KEY]))
        y.append(m["value"])
        e.append(m["error"])
    x, y, e = map(np.array, (x, y, e))
    slope = np.sum(x * y / e**2) / np.sum(x * x / e**2)  # least squares through the origin
    print("\n%-12s %14s %12s" % ("reflectance", "mount W", "1 sigma"))
    for xi, yi, ei in zip(x, y, e):
        print("%-12.2f %14.4g %12.2g" % (xi, yi, ei))
    fig, ax = plt.subplots(figsize=(6, 4.5))
    ax.errorbar(x, y, yerr=e, fmt="o", color="#c44e52", capsize=3,
                label="veil sweep (%d rays, %d batches)" % (rays, batches))
    grid = np.linspace(0, x.max() * 1.05, 50)
    ax.plot(grid, slope * grid, "-", color="#555555", lw=1, label="proportional (weighted fit)")
    ax.set_xlabel("mount reflectance (Lambertian)")
    ax.set_ylabel("mount scatter on the sensor (W)")
    ax.set_title("Sun 7° off axis: stray light from the mounts", fontsize=10)
    ax.set_xlim(0, None)
    ax.set_ylim(0, None)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "sweep.png"), dpi=120)
    plt.close(fig)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("-o", "--output", default="out/python")
    parser.add_argument("--quick", action="store_true", help="small budgets (tests)")
    args = parser.parse_args()
    os.makedirs(args.output, exist_ok=True)
    ghost_table(args.output)
    mount_sweep(args.output, rays=2000 if args.quick else 40000, batches=8 if args.quick else 16)
    print("\nwrote %s and %s" % (os.path.join(args.output, "ghosts.png"),
                                 os.path.join(args.output, "sweep.png")))


if __name__ == "__main__":
    main()
