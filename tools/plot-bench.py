#!/usr/bin/python3
"""Draw sonar-bench results: time per ping against mean velocity error.

Usage: tools/plot-bench.py BENCH.csv [-o out.png] [--scene fig10]

Reads the CSV that `sonar-bench --csv` appends to and draws one marker per
configuration, labelled sweep=value, at its median time per ping (log x)
and its mean radial velocity error (log y). Rows of one run shared by two
sweeps (linkage=ward is refine=on) are one marker with both labels.

The Pareto front, per scene, joins the configurations that no other one
beats in both time and error; it is drawn as a line and printed as a table.
Only its points are labelled (the elements' defaults, shared by most sweeps,
as "defaults"). The hemisphere sweep (3-D image) and the datacube sweep (a
wider bank, one ping) are scenes of their own: "fig10 3-D", "fig10 +-1".
Only configurations that found every object without a false positive are
candidates: the mean error of one that misses objects is over fewer, easier
ones. The others are drawn hollow and listed below the table.
"""

import argparse
import csv
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402 (after choosing the backend)
from matplotlib.ticker import FuncFormatter  # noqa: E402

NUMERIC = ("pings", "found", "total", "false_positives", "mean_error",
           "max_error", "ms_spectra", "ms_imaging", "ms_clustering",
           "ms_velocity", "ms_total", "pings_per_second")
MARKERS = {"fig10": "o", "fig9": "s", "fig10 3-D": "D", "fig10 +-1": "v"}
COLOURS = {"fig10": "tab:blue", "fig9": "tab:orange", "fig10 3-D": "tab:green",
           "fig10 +-1": "tab:purple"}
# Sweeps whose rows are not comparable with their scene's others.
OWN_SCENE = {"hemisphere": "fig10 3-D", "datacube": "fig10 +-1"}


def parse_args(argv):
    """Command-line options."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("csv", help="CSV written by sonar-bench --csv")
    p.add_argument("-o", "--output", default="out/bench.png",
                   help="PNG to write (default %(default)s)")
    p.add_argument("--scene", help="only this scene's rows (fig10, fig9)")
    return p.parse_args(argv)


def load_rows(path, scene=None):
    """The CSV's configurations, rows of one run merged under both labels."""
    merged = {}
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            if scene and row["scene"] != scene:
                continue
            try:
                values = {k: float(row[k]) for k in NUMERIC}
            except (KeyError, ValueError) as e:
                raise SystemExit(f"{path}: not a sonar-bench CSV ({e})")
            group = OWN_SCENE.get(row["sweep"], row["scene"])
            key = (group,) + tuple(values[k] for k in NUMERIC)
            label = f"{row['sweep']}={row['value']}"
            if key in merged:
                if label not in merged[key]["labels"]:
                    merged[key]["labels"].append(label)
            else:
                merged[key] = dict(values, scene=group, labels=[label])
    return list(merged.values())


def complete(row):
    """Found every object, no false positive, a finite positive error."""
    return (row["found"] == row["total"] and row["false_positives"] == 0
            and math.isfinite(row["mean_error"]) and row["mean_error"] > 0
            and row["ms_total"] > 0)


def pareto_front(rows):
    """Rows not dominated in (time, error), by increasing time."""
    front = []
    for r in rows:
        dominated = any(
            o["ms_total"] <= r["ms_total"]
            and o["mean_error"] <= r["mean_error"]
            and (o["ms_total"] < r["ms_total"]
                 or o["mean_error"] < r["mean_error"])
            for o in rows)
        if not dominated:
            front.append(r)
    return sorted(front, key=lambda r: (r["ms_total"], r["mean_error"]))


def name(row):
    """A row's label: its sweep=value, or "defaults" for the run most
    sweeps share."""
    return "defaults" if len(row["labels"]) > 2 else ", ".join(row["labels"])


def format_table(rows):
    """Rows as an aligned text table."""
    lines = [f"  {'configuration':<30} {'scene':<9} {'ms/ping':>9} "
             f"{'pings/s':>8} {'mean m/s':>9} {'max m/s':>8} {'found':>7} "
             f"{'FP':>3}"]
    for r in rows:
        found = f"{r['found']:.0f}/{r['total']:.0f}"
        lines.append(f"  {name(r):<30} {r['scene']:<9} "
                     f"{r['ms_total']:9.1f} {r['pings_per_second']:8.3f} "
                     f"{r['mean_error']:9.4f} {r['max_error']:8.4f} "
                     f"{found:>7} {r['false_positives']:3.0f}")
    return "\n".join(lines)


def minor_labels(axis):
    """A formatter for @axis's minor ticks: every one within a decade, only
    2 and 5 times a power of ten over more, so that labels never crowd."""
    def label(value, _position):
        low, high = sorted(axis.get_view_interval())
        if low > 0 and high / low < 10 or f"{value:e}"[0] in "25":
            return f"{value:g}"
        return ""
    return FuncFormatter(label)


def plot(rows, fronts, output):
    """Draws the markers, the fronts and their points' labels."""
    fig, ax = plt.subplots(figsize=(12, 7))
    on_front = {id(r) for front in fronts.values() for r in front}
    for r in rows:
        if not (r["ms_total"] > 0 and r["mean_error"] > 0):
            continue
        colour = COLOURS.get(r["scene"], "tab:gray")
        ax.scatter(r["ms_total"], r["mean_error"],
                   marker=MARKERS.get(r["scene"], "^"),
                   facecolors=colour if complete(r) else "none",
                   edgecolors=colour, zorder=3)
        if id(r) in on_front or name(r) == "defaults":
            ax.annotate(name(r), (r["ms_total"], r["mean_error"]),
                        textcoords="offset points", xytext=(4, 6),
                        rotation=30, ha="left", va="bottom", fontsize=8)
    for scene, front in fronts.items():
        ax.plot([r["ms_total"] for r in front],
                [r["mean_error"] for r in front], "-o",
                color=COLOURS.get(scene, "tab:gray"), alpha=0.6,
                markersize=12, markerfacecolor="none",
                label=f"{scene}: Pareto front")
    ax.set_xscale("log")
    ax.set_yscale("log")
    low, high = ax.get_ylim()
    ax.set_ylim(low, high * 1.8)  # room for the labels
    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        axis.set_minor_formatter(minor_labels(axis))
    ax.set_xlabel("time per ping, ms (median)")
    ax.set_ylabel("mean |radial velocity error|, m/s")
    ax.set_title("sonar-bench: cost against accuracy (hollow: missed objects "
                 "or false positives)")
    ax.grid(True, which="both", alpha=0.3)
    if fronts:
        ax.legend()
    fig.tight_layout()
    fig.savefig(output, dpi=120)
    plt.close(fig)


def main(argv=None):
    """Reads the CSV, prints each scene's front, writes the PNG."""
    args = parse_args(argv)
    try:
        rows = load_rows(args.csv, args.scene)
    except OSError as e:
        raise SystemExit(f"{args.csv}: {e.strerror}")
    if not rows:
        raise SystemExit(f"{args.csv}: no configurations")
    fronts = {}
    for scene in sorted({r["scene"] for r in rows}):
        candidates = [r for r in rows if r["scene"] == scene and complete(r)]
        if candidates:
            fronts[scene] = pareto_front(candidates)
    print("Pareto front (time per ping against mean velocity error)")
    print(format_table([r for f in fronts.values() for r in f]))
    others = [r for r in rows if not complete(r)]
    if others:
        print("\nNot candidates (missed objects or false positives)")
        print(format_table(others))
    plot(rows, fronts, args.output)
    print(f"\nwrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
