#!/usr/bin/python3
"""Draw energyscapes (sonar images written by mimobeamform) as PNG.

Usage: tools/plot-energyscape.py FILE [--record K | --all] [-o out.png]
           [--dynamic-range 40] [--truth TRUTH.json] [--detections DET.json]

A 2-D image (one elevation) is drawn as a polar fan like the paper's Fig. 5
and 9: x = r sin(azimuth), y = r cos(azimuth), boresight up. A 3-D image is
drawn as the azimuth x elevation map of the maximum over range beside the
azimuth x range fan of the maximum over elevation. Colour is dB relative to
the image's maximum, clipped at -dynamic-range.

--truth: a JSON list of {"range", "azimuth", "elevation"} objects, or JSON
(lines) objects holding such a "reflectors" list (with "ping", only the
record's ping is used). --detections: JSON lines
{"ping": N, "detections": [{"range", "azimuth", "elevation",
"radial_velocity"}, ...]}, drawn labelled with the radial velocity: red when
approaching (negative), green otherwise.
"""

import argparse
import json
import math
import pathlib
import sys

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402 (after choosing the backend)

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import energyscape  # noqa: E402


def parse_args(argv):
    """Command-line options."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("file", help="energyscape file (records back to back)")
    which = p.add_mutually_exclusive_group()
    which.add_argument("--record", type=int, default=0,
                       help="record to draw, negative counts from the end "
                       "(default 0)")
    which.add_argument("--all", action="store_true",
                       help="draw every record: OUT-0000.png, OUT-0001.png..")
    p.add_argument("-o", "--output", default="out/energyscape.png",
                   help="PNG to write (default %(default)s)")
    p.add_argument("--dynamic-range", type=float, default=40.0,
                   help="dB below the image maximum shown (default 40)")
    p.add_argument("--truth", help="ground truth JSON to overlay")
    p.add_argument("--detections", help="detections JSON lines to overlay")
    args = p.parse_args(argv)
    if not args.dynamic_range > 0:
        p.error("--dynamic-range must be positive")
    return args


def _json_documents(path):
    """The JSON values of a file: one document, or one per line."""
    text = pathlib.Path(path).read_text(encoding="utf-8")
    try:
        return [json.loads(text)]
    except json.JSONDecodeError:
        pass
    docs = []
    for number, line in enumerate(text.splitlines(), 1):
        if line.strip():
            try:
                docs.append(json.loads(line))
            except json.JSONDecodeError as e:
                raise ValueError(f"{path}:{number}: not JSON: {e}") from e
    return docs


def _objects_for_ping(path, key, ping_index):
    """Objects of the `key` lists of the documents for this ping.

    A top-level list is taken as the objects themselves. Documents with a
    "ping" member only count for that ping.
    """
    objects = []
    for doc in _json_documents(path):
        if isinstance(doc, list):
            objects.extend(doc)
        elif isinstance(doc, dict) and isinstance(doc.get(key), list):
            if doc.get("ping", ping_index) == ping_index:
                objects.extend(doc[key])
        else:
            raise ValueError(f"{path}: expected a list, or objects with a "
                             f"\"{key}\" list")
    for obj in objects:
        if not (isinstance(obj, dict) and "range" in obj
                and "azimuth" in obj):
            raise ValueError(f"{path}: every {key} entry needs \"range\" and "
                             f"\"azimuth\" (got {obj!r})")
    return objects


def load_truth(path, ping_index):
    """Reflectors to mark: dicts with range, azimuth and elevation."""
    return _objects_for_ping(path, "reflectors", ping_index)


def load_detections(path, ping_index):
    """Detections of one ping: dicts with range, azimuth, elevation and
    radial_velocity."""
    detections = _objects_for_ping(path, "detections", ping_index)
    for det in detections:
        velocity = det.get("radial_velocity", det.get("radial-velocity"))
        if not isinstance(velocity, (int, float)):
            raise ValueError(f"{path}: detection without a numeric "
                             f"\"radial_velocity\": {det!r}")
        det["radial_velocity"] = float(velocity)
    return detections


def to_db(image, dynamic_range):
    """Linear amplitude to dB re the image's maximum, clipped."""
    peak = float(np.max(image))
    if not peak > 0:
        return np.full(image.shape, -dynamic_range)
    return np.maximum(20.0 * np.log10(np.maximum(image / peak, 1e-30)),
                      -dynamic_range)


def _edges(first, step, count, fallback):
    """Cell edges of a regular axis; fallback step for a single cell."""
    step = step if step != 0 else fallback
    return first + step * (np.arange(count + 1) - 0.5)


def fan_image(record):
    """The azimuth x range image shown in the fan (maximum over
    elevation), shape (n_azimuth, n_range)."""
    return record.data.max(axis=0)


def fan_peak_xy(record):
    """(x, y) in metres of the fan image's brightest cell, as drawn."""
    image = fan_image(record)
    a, r = np.unravel_index(int(np.argmax(image)), image.shape)
    x, y = energyscape.fan_xy(record.azimuth[a], record.range[r])
    return float(x), float(y)


def draw_fan(ax, record, dynamic_range):
    """Polar fan of the azimuth x range image; returns the mesh."""
    az = _edges(record.azimuth_first, record.azimuth_step,
                record.n_azimuth, 1.0)
    r = _edges(record.range_first, record.range_step, record.n_range,
               max(record.range_first, 1.0) * 0.01)
    x, y = energyscape.fan_xy(az[:, None], np.maximum(r, 0.0)[None, :])
    mesh = ax.pcolormesh(x, y, to_db(fan_image(record), dynamic_range),
                         shading="flat", cmap="viridis",
                         vmin=-dynamic_range, vmax=0.0, rasterized=True)
    ax.set_aspect("equal")
    ax.set_xlabel("x = r sin(azimuth) (m)")
    ax.set_ylabel("y = r cos(azimuth) (m)")
    return mesh


def draw_map(ax, record, dynamic_range):
    """Azimuth x elevation map of the maximum over range; returns it."""
    az = _edges(record.azimuth_first, record.azimuth_step,
                record.n_azimuth, 1.0)
    el = _edges(record.elevation_first, record.elevation_step,
                record.n_elevation, 1.0)
    image = to_db(record.data.max(axis=2), dynamic_range)
    mesh = ax.pcolormesh(az, el, image, shading="flat", cmap="viridis",
                         vmin=-dynamic_range, vmax=0.0, rasterized=True)
    ax.set_aspect("equal")
    ax.set_xlabel("azimuth (deg)")
    ax.set_ylabel("elevation (deg)")
    return mesh


def overlay(ax, points, in_fan, detections):
    """Mark truth (white circles) or detections (crosses with velocity)."""
    for p in points:
        if in_fan:
            px, py = energyscape.fan_xy(p["azimuth"], p["range"])
        else:
            px, py = p["azimuth"], p.get("elevation", 0.0)
        if not detections:
            ax.plot(px, py, "o", markersize=10, markerfacecolor="none",
                    markeredgecolor="white", markeredgewidth=1.2)
            continue
        v = p["radial_velocity"]
        colour = "red" if v < 0 else "limegreen"
        ax.plot(px, py, "x", color=colour, markersize=8, markeredgewidth=2)
        ax.annotate(f"{v:+.2f} m/s", (px, py), xytext=(6, 6),
                    textcoords="offset points", color=colour,
                    fontsize="small", fontweight="bold",
                    bbox={"boxstyle": "round,pad=0.15", "facecolor": "black",
                          "alpha": 0.5, "linewidth": 0})


def title_of(record):
    """A one-line description of a record."""
    source = "MIMO" if record.emitter < 0 else f"emitter {record.emitter}"
    if math.isnan(record.velocity):
        doppler = "max over Doppler hypotheses"
    else:
        doppler = f"v = {record.velocity:+.2f} m/s"
    return f"ping {record.ping_index}, {source}, {doppler}"


def plot_record(record, output, dynamic_range, truth=None, detections=None):
    """Draw one record into a PNG file."""
    if record.is_3d:
        fig, (ax_map, ax_fan) = plt.subplots(
            1, 2, figsize=(13, 6), constrained_layout=True,
            gridspec_kw={"width_ratios": [1, 1.2]})
        mesh = draw_map(ax_map, record, dynamic_range)
        ax_map.set_title("maximum over range")
        draw_fan(ax_fan, record, dynamic_range)
        ax_fan.set_title("maximum over elevation")
        axes = ((ax_map, False), (ax_fan, True))
    else:
        # Size the figure to the fan: a +-90 degree fan is twice as wide as
        # it is high, a narrow one much taller than wide.
        x, y = energyscape.fan_xy(record.azimuth[:, None],
                                  record.range[None, :])
        aspect = np.ptp(y) / max(np.ptp(x), 1e-9)
        fig, ax_fan = plt.subplots(
            figsize=(9, float(np.clip(7.5 * aspect + 1.0, 3.5, 9.0))),
            constrained_layout=True)
        mesh = draw_fan(ax_fan, record, dynamic_range)
        axes = ((ax_fan, True),)
    for ax, in_fan in axes:
        overlay(ax, truth or [], in_fan, detections=False)
        overlay(ax, detections or [], in_fan, detections=True)
    fig.suptitle(title_of(record))
    fig.colorbar(mesh, ax=[ax for ax, _ in axes],
                 label="dB re image maximum", shrink=0.8)
    output = pathlib.Path(output)
    output.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(output, dpi=100)
    plt.close(fig)


def main(argv=None):
    """Read, select, overlay and draw."""
    args = parse_args(argv)
    try:
        records = energyscape.read(args.file)
    except (OSError, energyscape.EnergyscapeError) as e:
        sys.exit(f"plot-energyscape: {e}")
    if args.all:
        out = pathlib.Path(args.output)
        jobs = [(rec, out.with_name(f"{out.stem}-{k:04d}{out.suffix}"))
                for k, rec in enumerate(records)]
    elif -len(records) <= args.record < len(records):
        jobs = [(records[args.record], args.output)]
    else:
        sys.exit(f"plot-energyscape: --record {args.record} is out of "
                 f"range: {args.file} holds {len(records)} records")
    for record, output in jobs:
        try:
            truth = (load_truth(args.truth, record.ping_index)
                     if args.truth else None)
            detections = (load_detections(args.detections,
                                          record.ping_index)
                          if args.detections else None)
        except (OSError, ValueError) as e:
            sys.exit(f"plot-energyscape: {e}")
        plot_record(record, output, args.dynamic_range, truth, detections)
        print(f"wrote {output}")


if __name__ == "__main__":
    main()
