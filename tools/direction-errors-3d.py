#!/usr/bin/python3
"""Direction errors on a 3-D image: still point reflectors at seeded
random directions (azimuth +-60, elevation +-45 degrees, off the 2-degree
grid), one every 35 cm of range from 0.8 m so that each detection is
matched to its point by range, run through the chain at the elements'
defaults (the hemisphere at 2 degrees, the -7..7 m/s bank). Prints, per
seed and over all, the points' detections found and the rms and worst
error of their azimuth and elevation against the truth (bias and noise
together).

    /usr/bin/python3 tools/direction-errors-3d.py --seeds 1 2 3

--off-boresight MIN MAX places them MIN..MAX degrees off boresight, all
the way round it (the hemisphere's rim: 80 88), and the errors in the
array's plane (the direction cosines along x and y) are printed too.

SONAR_BUILD_DIR names the build whose plugin runs (default: build).
"""

import argparse
import json
import math
import os
import pathlib
import random
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent
SPACING = 0.35     # m of range between the points
MATCH = 0.05       # m: a detection is its point's within this range


def points(seed, n, off_boresight=None):
    """(range m, azimuth, elevation degrees) of @n points; with
    @off_boresight (lo, hi), at angles lo..hi degrees off boresight, all
    the way round it."""
    rng = random.Random(seed)
    if off_boresight is None:
        return [(0.8 + SPACING * k, rng.uniform(-60, 60),
                 rng.uniform(-45, 45)) for k in range(n)]
    scene = []
    for k in range(n):
        off = math.radians(rng.uniform(*off_boresight))
        around = rng.uniform(0, 2 * math.pi)
        x, y = math.sin(off) * math.cos(around), math.sin(off) * math.sin(
            around)
        z = math.cos(off)
        scene.append((0.8 + SPACING * k, math.degrees(math.atan2(x, z)),
                      math.degrees(math.asin(y))))
    return scene


def cosines(azimuth, elevation):
    """The direction's cosines along x and y, the array's plane."""
    a, e = math.radians(azimuth), math.radians(elevation)
    return math.sin(a) * math.cos(e), math.sin(e)


def errors(scene, pings, noise, folder, env):
    """(azimuth errors, elevation errors, extra detections) over @pings
    pings of @scene: the errors of each point's valid detection nearest
    it in range (within MATCH), per ping; extra: the other valid
    detections."""
    path = folder / "points.json"
    path.write_text(json.dumps({"dimensions": 3, "reflectors": [
        {"kind": "point", "range": r, "azimuth": a, "elevation": e,
         "strength": 1.0} for r, a, e in scene]}))
    out = subprocess.run(
        ["gst-launch-1.0", "-q", "sonarsrc", f"scene-file={path}",
         f"num-buffers={pings}", f"noise-amplitude={noise}", "!",
         "dopplerbank", "!", "mimobeamform", "!", "wardcluster", "!",
         "velocityest", "!", "fdsink"],
        env=env, capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit("the chain failed: %s" % out.stderr.strip())
    azimuth, elevation, plane, extra = [], [], [], 0
    for line in out.stdout.splitlines():
        left = [d for d in json.loads(line)["detections"] if d["valid"]]
        for r, a, e in scene:
            near = min(left, default=None,
                       key=lambda d: abs(d["range"] - r))
            if near is not None and abs(near["range"] - r) < MATCH:
                left.remove(near)
                azimuth.append(near["azimuth"] - a)
                elevation.append(near["elevation"] - e)
                ux, uy = cosines(a, e)
                dx, dy = cosines(near["azimuth"], near["elevation"])
                plane.append(math.hypot(dx - ux, dy - uy))
        extra += len(left)
    return azimuth, elevation, plane, extra


def summary(found, expected, extra, azimuth, elevation, plane):
    rms = lambda v: math.sqrt(sum(x * x for x in v) / len(v)) if v else \
        math.nan
    worst = lambda v: max(map(abs, v), default=math.nan)
    return ("%d of %d found, %d other detections; azimuth rms %.3f, worst "
            "%.3f deg; elevation rms %.3f, worst %.3f deg; in the array's "
            "plane rms %.5f, worst %.5f" % (
                found, expected, extra, rms(azimuth), worst(azimuth),
                rms(elevation), worst(elevation), rms(plane), worst(plane)))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--points", type=int, default=12)
    parser.add_argument("--pings", type=int, default=2)
    parser.add_argument("--noise", type=float, default=0.05,
                        help="sonarsrc noise-amplitude")
    parser.add_argument("--off-boresight", type=float, nargs=2,
                        metavar=("MIN", "MAX"),
                        help="degrees off boresight, all the way round "
                        "it, instead of the default box")
    args = parser.parse_args()
    env = dict(os.environ)
    build = os.environ.get("SONAR_BUILD_DIR", str(ROOT / "build"))
    env["GST_PLUGIN_PATH_1_0"] = str(pathlib.Path(build) / "elements")
    all_azimuth, all_elevation, all_plane, all_extra = [], [], [], 0
    with tempfile.TemporaryDirectory() as folder:
        for seed in args.seeds:
            azimuth, elevation, plane, extra = errors(
                points(seed, args.points, args.off_boresight), args.pings,
                args.noise, pathlib.Path(folder), env)
            print("seed %d: %s" % (seed, summary(
                len(azimuth), args.points * args.pings, extra, azimuth,
                elevation, plane)))
            all_azimuth += azimuth
            all_elevation += elevation
            all_plane += plane
            all_extra += extra
    print("all: %s" % summary(len(all_azimuth), args.points * args.pings *
                              len(args.seeds), all_extra, all_azimuth,
                              all_elevation, all_plane))


if __name__ == "__main__":
    main()
