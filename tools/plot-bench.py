#!/usr/bin/python3
"""Draw sonar-bench results: time per ping against mean velocity error,
and the sensitivity sweeps (probability of detection, split rate).

Usage: tools/plot-bench.py BENCH.csv [-o out.png] [--scene fig10]

Reads the CSV that `sonar-bench --csv` appends to and draws one marker per
configuration, labelled sweep=value, at its median time per ping (log x)
and its mean radial velocity error (log y). Rows of one run shared by two
sweeps (linkage=ward is refine=on) are one marker with both labels.

The Pareto front, per scene, joins the configurations that no other one
beats in both time and error; it is drawn as a line and printed as a table.
Only its points are labelled (the elements' defaults, shared by most sweeps,
as "defaults"). The hemisphere sweeps (3-D images) and the datacube sweep
(a wider bank, one ping) are scenes of their own: "fig10 3-D", "fig9 3-D",
"fig10 +-1".
Only configurations that found every object without a false positive are
candidates: the mean error of one that misses objects is over fewer, easier
ones. The others are drawn hollow and listed below the table.

Rows of the sensitivity sweeps are drawn beside, each figure named after
the output: the detection sweep's probability of detection against
per-channel SNR, a curve per range (OUT-detection.png), and the split
sweep's share of pairs split into two objects, separation against
velocity difference (OUT-split.png).
"""

import argparse
import csv
import math
import pathlib
import re
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402 (after choosing the backend)
from matplotlib.ticker import FuncFormatter  # noqa: E402

NUMERIC = ("pings", "found", "total", "false_positives", "mean_error",
           "max_error", "ms_spectra", "ms_imaging", "ms_clustering",
           "ms_velocity", "ms_total", "pings_per_second")
MARKERS = {"fig10": "o", "fig9": "s", "fig10 3-D": "D", "fig9 3-D": "P",
           "fig10 +-1": "v"}
COLOURS = {"fig10": "tab:blue", "fig9": "tab:orange", "fig10 3-D": "tab:green",
           "fig9 3-D": "tab:red", "fig10 +-1": "tab:purple"}
# Sweeps whose rows are not comparable with their scene's others.
OWN_SCENE = {"hemisphere": "fig10 3-D", "hemisphere-grid": "fig10 3-D",
             "hemisphere-fig9": "fig9 3-D", "hemisphere-fig9-band": "fig9 3-D",
             "hemisphere-fig9-grid": "fig9 3-D", "datacube": "fig10 +-1"}
# Sweeps that render their own pings: no timing, their own figures.
SENSITIVITY = ("noise", "detection", "split", "crowded", "near-far")


def parse_args(argv):
    """Command-line options."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("csv", help="CSV written by sonar-bench --csv")
    p.add_argument("-o", "--output", default="out/bench.png",
                   help="PNG to write (default %(default)s)")
    p.add_argument("--scene", help="only this scene's rows (fig10, fig9)")
    return p.parse_args(argv)


def load_rows(path, scene=None):
    """The CSV's configurations, rows of one run merged under both labels;
    and the sensitivity sweeps' rows, by sweep."""
    merged = {}
    sensitivity = {name: [] for name in SENSITIVITY}
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            if row.get("sweep") in SENSITIVITY:
                sensitivity[row["sweep"]].append(row)
                continue
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
    return list(merged.values()), sensitivity


def detection_curves(rows):
    """{range m: [(SNR dB, Pd, pings)]} of the detection sweep's rows
    ("-28 dB 5 m"), by increasing SNR."""
    curves = {}
    for row in rows:
        match = re.fullmatch(r"(-?[\d.]+) dB ([\d.]+) m", row["value"])
        if not match:
            continue
        snr, distance = float(match[1]), float(match[2])
        pings = int(row["total"])
        curves.setdefault(distance, []).append(
            (snr, int(row["found"]) / pings if pings else math.nan, pings))
    return {d: sorted(points) for d, points in sorted(curves.items())}


def split_grid(rows):
    """The split sweep's pair cells ("1.5 cm 0.4 m/s"): separations (cm),
    velocity differences (m/s) and the share split, rows by separation."""
    cells = {}
    for row in rows:
        match = re.fullmatch(r"([\d.]+) cm ([\d.]+) m/s", row["value"])
        if match and int(row["total"]):
            cells[(float(match[1]), float(match[2]))] = \
                int(row["found"]) / int(row["total"])
    separations = sorted({s for s, _ in cells})
    differences = sorted({d for _, d in cells})
    return separations, differences, [
        [cells.get((s, d), math.nan) for d in differences]
        for s in separations]


def plot_detection(curves, output):
    """Probability of detection against per-channel SNR, one curve per
    range."""
    fig, ax = plt.subplots(figsize=(8, 5))
    for distance, points in curves.items():
        ax.plot([p[0] for p in points], [p[1] for p in points], "-o",
                label=f"{distance:g} m")
    pings = sorted({p[2] for points in curves.values() for p in points})
    ax.set_xlabel("per-channel SNR, dB")
    ax.set_ylabel("probability of detection")
    ax.set_ylim(-0.02, 1.02)
    ax.set_title("sonar-bench --sweep detection: one point reflector, "
                 f"{'/'.join(str(p) for p in pings)} pings per point")
    ax.grid(True, alpha=0.3)
    ax.legend(title="range")
    fig.tight_layout()
    fig.savefig(output, dpi=120)
    plt.close(fig)


def plot_split(separations, differences, shares, output):
    """The share of pairs split, separation against velocity difference,
    each cell labelled."""
    fig, ax = plt.subplots(figsize=(8, 4.5))
    image = ax.imshow(shares, vmin=0.0, vmax=1.0, cmap="viridis",
                      origin="lower", aspect="auto")
    for i, row in enumerate(shares):
        for j, share in enumerate(row):
            if math.isfinite(share):
                ax.text(j, i, f"{share:.2f}", ha="center", va="center",
                        color="black" if share > 0.5 else "white")
    ax.set_xticks(range(len(differences)), [f"{d:g}" for d in differences])
    ax.set_yticks(range(len(separations)), [f"{s:g}" for s in separations])
    ax.set_xlabel("radial velocity difference, m/s")
    ax.set_ylabel("separation in range, cm")
    ax.set_title("sonar-bench --sweep split: share of the pairs reported "
                 "as two objects")
    fig.colorbar(image, ax=ax, label="split rate")
    fig.tight_layout()
    fig.savefig(output, dpi=120)
    plt.close(fig)


def beside(output, suffix):
    """@output's path with -@suffix before its extension."""
    path = pathlib.Path(output)
    return str(path.with_name(f"{path.stem}-{suffix}{path.suffix or '.png'}"))


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
        rows, sensitivity = load_rows(args.csv, args.scene)
    except OSError as e:
        raise SystemExit(f"{args.csv}: {e.strerror}")
    curves = detection_curves(sensitivity["detection"])
    separations, differences, shares = split_grid(sensitivity["split"])
    if not rows and not curves and not separations:
        raise SystemExit(f"{args.csv}: no configurations")
    if curves:
        plot_detection(curves, beside(args.output, "detection"))
        print(f"wrote {beside(args.output, 'detection')}")
    if separations:
        plot_split(separations, differences, shares,
                   beside(args.output, "split"))
        print(f"wrote {beside(args.output, 'split')}")
    if not rows:
        return 0
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
