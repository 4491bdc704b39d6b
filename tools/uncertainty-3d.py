#!/usr/bin/python3
"""The 1-sigma each detection reports on a 3-D image against the scatter
of its estimates: four still points in front of a 3-D sensor (directions
off the 2-degree grid), N noisy pings through the chain at the elements'
defaults (the hemisphere at 2 degrees, the -7..7 m/s bank), per
noise-amplitude. Prints, per coordinate, the median reported sigma and
the ratio reported / measured (1: calibrated), the measured scatter being
the rms deviation from each point's mean over the pings (a fixed bias per
point is left out, as the sigmas leave it out), pooled over the points.

    /usr/bin/python3 tools/uncertainty-3d.py --pings 24 0.12 0.5 1.2
"""

import argparse
import json
import math
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent
# range m, azimuth and elevation degrees, strength
POINTS = [(1.53, -41.6, 12.3, 0.45), (2.07, 23.2, -17.7, 0.8),
          (2.71, -8.4, 31.1, 1.0), (3.32, 37.7, 5.6, 1.5)]
FIELDS = ("range", "azimuth", "elevation", "radial_velocity")
# A detection belongs to a point within this many degrees of its direction.
MATCH_DEGREES = 3.0


def run(noise, pings, folder):
    """Per point, the valid detections of @pings pings at @noise."""
    scene = folder / "points-3d.json"
    scene.write_text(json.dumps({
        "dimensions": 3,
        "reflectors": [{"kind": "point", "range": r, "azimuth": a,
                        "elevation": e, "strength": s}
                       for r, a, e, s in POINTS]}))
    launch = (f"sonarsrc scene-file={scene} num-buffers={pings} "
              f"noise-amplitude={noise} ! dopplerbank ! mimobeamform ! "
              f"wardcluster ! velocityest ! fdsink")
    env = dict(os.environ)
    build = os.environ.get("SONAR_BUILD_DIR", str(ROOT / "build"))
    env["GST_PLUGIN_PATH_1_0"] = str(pathlib.Path(build) / "elements")
    out = subprocess.run(["gst-launch-1.0", "-q", *launch.split()],
                         capture_output=True, text=True, check=True, env=env)
    per_point = [[] for _ in POINTS]
    for line in out.stdout.splitlines():
        for d in json.loads(line)["detections"]:
            for k, (_, a, e, _) in enumerate(POINTS):
                if (abs(d["azimuth"] - a) < MATCH_DEGREES
                        and abs(d["elevation"] - e) < MATCH_DEGREES):
                    per_point[k].append(d)
                    break
    return per_point


def ratio(per_point, field):
    """Reported sigma over the measured scatter, pooled over the points."""
    sum_z2, dof = 0.0, 0
    for p in per_point:
        if len(p) < 2:
            continue
        mean = statistics.fmean(d[field] for d in p)
        sum_z2 += sum(((d[field] - mean) / d[field + "_sigma"]) ** 2
                      for d in p)
        dof += len(p) - 1
    return 1.0 / math.sqrt(sum_z2 / dof) if sum_z2 > 0 else math.nan, dof


def print_points(per_point):
    """Per point and coordinate: mean - truth, scatter, median sigma."""
    for k, p in enumerate(per_point):
        if len(p) < 2:
            continue
        truth = dict(zip(("range", "azimuth", "elevation"), POINTS[k][:3]))
        cells = []
        for f in FIELDS[:3]:
            values = [d[f] for d in p]
            sigma = statistics.median(d[f + "_sigma"] for d in p)
            cells.append(f"{f} {statistics.fmean(values) - truth[f]:+.4f} "
                         f"sd {statistics.stdev(values):.4f} "
                         f"sigma {sigma:.4f}")
        print(f"    point {k}: " + "; ".join(cells))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("noise", type=float, nargs="+",
                        help="sonarsrc noise-amplitude values")
    parser.add_argument("--pings", type=int, default=24)
    parser.add_argument("--per-point", action="store_true",
                        help="also print each point's mean, scatter and "
                        "median sigma per coordinate")
    args = parser.parse_args()
    print(f"{'noise':>6} {'found':>11} {'image SNR':>9} " + " ".join(
        f"{f + ' sigma':>22} {'ratio':>5}" for f in FIELDS) + f" {'dof':>4}")
    with tempfile.TemporaryDirectory() as folder:
        for noise in args.noise:
            per_point = run(noise, args.pings, pathlib.Path(folder))
            found = "/".join(str(len(p)) for p in per_point)
            detections = [d for p in per_point for d in p]
            if not detections:
                print(f"{noise:>6} {found:>11} (nothing found)")
                continue
            snr = statistics.median(d["snr"] for d in detections)
            cells = []
            for f in FIELDS:
                sigma = statistics.median(d[f + "_sigma"] for d in detections)
                r, dof = ratio(per_point, f)
                cells.append(f"{sigma:>22.3g} {r:>5.2f}")
            print(f"{noise:>6} {found:>11} {snr:>9.1f} " + " ".join(cells)
                  + f" {dof:>4}")
            if args.per_point:
                print_points(per_point)
    return 0


if __name__ == "__main__":
    sys.exit(main())
