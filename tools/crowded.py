#!/usr/bin/python3
"""Crowded scenes: n x n still point reflectors on a grid (8 degrees apart
in azimuth, 22 cm apart in range from 0.6 m), one ping through the chain
at the elements' defaults (bank -0.4..0.4 m/s / 0.02), scored against the
grid: an object is found when a valid detection lies within 5 cm of it.
Prints, per grid: objects, centroids, valid detections, objects found,
objects with a centroid within 5 cm (found or rejected), valid detections
near no object.

    /usr/bin/python3 tools/crowded.py 5 10 14 20
    /usr/bin/python3 tools/crowded.py 10 --velocityest "coherence-pfa=1"

(coherence-pfa=1: no coherence test). sonar-bench --sweep crowded
measures the same grids at the elements' defaults beside an oracle bound.
"""

import argparse
import json
import math
import os
import pathlib
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent
BANK = "velocity-min=-0.4 velocity-max=0.4 velocity-step=0.02"


def grid(n):
    """The grid's reflectors, as scene-file members."""
    return [{"kind": "point", "range": 0.6 + 0.22 * i,
             "azimuth": -(n - 1) * 4 + 8 * j}
            for i in range(n) for j in range(n)]


def run(n, wardcluster, velocityest, folder):
    scene = folder / f"grid{n}.json"
    scene.write_text(json.dumps({"dimensions": 2, "reflectors": grid(n)}))
    launch = (f"sonarsrc scene-file={scene} num-buffers=1 ! dopplerbank "
              f"{BANK} ! mimobeamform ! wardcluster {wardcluster} ! "
              f"velocityest keep-rejected=true {velocityest} ! fdsink")
    env = dict(os.environ)
    build = os.environ.get("SONAR_BUILD_DIR", str(ROOT / "build"))
    env["GST_PLUGIN_PATH_1_0"] = str(pathlib.Path(build) / "elements")
    out = subprocess.run(["gst-launch-1.0", "-q", *launch.split()],
                         capture_output=True, text=True, check=True, env=env)
    detections = json.loads(out.stdout.splitlines()[0])["detections"]
    truth = [(r["range"] * math.sin(math.radians(r["azimuth"])),
              r["range"] * math.cos(math.radians(r["azimuth"])))
             for r in grid(n)]

    def near(d, x, z):
        return math.hypot(d["x"] - x, d["z"] - z) < 0.05
    valid = [d for d in detections if d["valid"]]
    found = sum(any(near(d, x, z) for d in valid) for x, z in truth)
    reached = sum(any(near(d, x, z) for d in detections) for x, z in truth)
    stray = sum(not any(near(d, x, z) for x, z in truth) for d in valid)
    return n * n, len(detections), len(valid), found, reached, stray


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("sizes", type=int, nargs="+", help="grid sides n")
    parser.add_argument("--wardcluster", default="",
                        help="wardcluster properties")
    parser.add_argument("--velocityest", default="",
                        help="velocityest properties")
    args = parser.parse_args()
    print(f"{'objects':>8} {'centroids':>9} {'valid':>6} {'found':>6} "
          f"{'reached':>8} {'stray':>6}")
    with tempfile.TemporaryDirectory() as folder:
        for n in args.sizes:
            row = run(n, args.wardcluster, args.velocityest,
                      pathlib.Path(folder))
            print(" ".join(f"{v:>{w}}" for v, w in
                           zip(row, (8, 9, 6, 6, 8, 6))))
    return 0


if __name__ == "__main__":
    sys.exit(main())
