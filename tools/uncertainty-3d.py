#!/usr/bin/python3
"""The 1-sigma each detection reports on a 3-D image against the scatter
of its estimates: still points in front of a 3-D sensor (directions off
the 2-degree grid), N noisy pings through the chain at the elements'
defaults (the hemisphere at 2 degrees, the -7..7 m/s bank), per
noise-amplitude. Prints, per coordinate, the median reported sigma and
the ratio reported / measured (1: calibrated), the measured scatter being
the rms deviation from each point's mean over the pings (a fixed bias per
point is left out, as the sigmas leave it out), pooled over the points.
The points: four fixed ones, or with --seeds the 12 random ones per seed
of tools/direction-errors-3d.py (one every 35 cm of range from 0.8 m,
azimuth +-60, elevation +-45 degrees, each scene run on its own).

    /usr/bin/python3 tools/uncertainty-3d.py --pings 24 0.12 0.5 1.2
    /usr/bin/python3 tools/uncertainty-3d.py --pings 24 0.5 --seeds 1 2 3

--samples also reads what sonar_uncertainty_measure () saw
(SONAR_UNCERTAINTY_SAMPLES, gst/sonar-uncertainty.c): per coordinate,
pooled over the points (each one's most frequent peak pixel), the log
samples y-, y0, y+ of wardcluster's parabola: their noise variances over
the one the noise meter predicts, E|n|^2 / (2 A_k^2) ("gamma"), their
correlations between neighbours (rho1) and between the outer two (rho2)
beside those of noise shaped like the peak itself (exp (kappa / 2),
exp (2 kappa), kappa the mean log curvature), and the scatter of the
parabola's offset (the centroid's coordinate, before velocityest) against
the Cramér-Rao sigma and against the propagation through the parabola
with that peak-shaped noise (ratio = sigma / scatter); and how often
velocityest's direction search moved the centroid.
"""

import argparse
import importlib.util
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
# A detection belongs to a point within this many degrees of its direction
# (and, for the random points, within this many metres of its range).
MATCH_DEGREES = 3.0
MATCH_RANGE = 0.05


def random_points(seed):
    """tools/direction-errors-3d.py's points of @seed, as POINTS gives
    them."""
    spec = importlib.util.spec_from_file_location(
        "direction_errors_3d", ROOT / "tools" / "direction-errors-3d.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return [(r, a, e, 1.0) for r, a, e in module.points(seed, 12)]


def matches(d, point, by_range):
    """Whether detection @d is @point's: within MATCH_DEGREES of its
    direction (and with @by_range, MATCH_RANGE of its range)."""
    r, a, e, _ = point
    return (abs(d["azimuth"] - a) < MATCH_DEGREES
            and abs(d["elevation"] - e) < MATCH_DEGREES
            and (not by_range or abs(d["range"] - r) < MATCH_RANGE))


def run(noise, pings, folder, samples=False, imager="", points=POINTS,
        by_range=False):
    """Per point of @points, the valid detections of @pings pings at
    @noise (with @samples, also each one's samples line, as a list of
    numbers, under "samples")."""
    scene = folder / "points-3d.json"
    scene.write_text(json.dumps({
        "dimensions": 3,
        "reflectors": [{"kind": "point", "range": r, "azimuth": a,
                        "elevation": e, "strength": s}
                       for r, a, e, s in points]}))
    launch = (f"sonarsrc scene-file={scene} num-buffers={pings} "
              f"noise-amplitude={noise} ! dopplerbank ! mimobeamform "
              f"{imager} ! "
              f"wardcluster ! velocityest ! fdsink")
    env = dict(os.environ)
    build = os.environ.get("SONAR_BUILD_DIR", str(ROOT / "build"))
    env["GST_PLUGIN_PATH_1_0"] = str(pathlib.Path(build) / "elements")
    if samples:
        env["SONAR_UNCERTAINTY_SAMPLES"] = "1"
    out = subprocess.run(["gst-launch-1.0", "-q", *launch.split()],
                         capture_output=True, text=True, check=True, env=env)
    # velocityest measures every detection it reports, in order.
    lines = iter([[float(v) for v in line.split()[1:]]
                  for line in out.stderr.splitlines()
                  if line.startswith("sonar-uncertainty-samples:")])
    per_point = [[] for _ in points]
    for line in out.stdout.splitlines():
        for d in json.loads(line)["detections"]:
            if samples:
                d["samples"] = next(lines)
            for k, point in enumerate(points):
                if matches(d, point, by_range):
                    per_point[k].append(d)
                    break
    return per_point


def ratio(per_point, field):
    """Reported sigma over the measured scatter, pooled over the points
    (each one's detections with a sigma, at least two)."""
    sum_z2, dof = 0.0, 0
    for p in per_point:
        p = [d for d in p if d[field + "_sigma"] is not None]
        if len(p) < 2:
            continue
        mean = statistics.fmean(d[field] for d in p)
        sum_z2 += sum(((d[field] - mean) / d[field + "_sigma"]) ** 2
                      for d in p)
        dof += len(p) - 1
    return 1.0 / math.sqrt(sum_z2 / dof) if sum_z2 > 0 else math.nan, dof


def print_points(per_point, points):
    """Per point and coordinate: mean - truth, scatter, median sigma."""
    for k, p in enumerate(per_point):
        if len(p) < 2:
            continue
        truth = dict(zip(("range", "azimuth", "elevation"), points[k][:3]))
        cells = []
        for f in FIELDS[:3]:
            values = [d[f] for d in p]
            sigma = statistics.median(d[f + "_sigma"] for d in p)
            cells.append(f"{f} {statistics.fmean(values) - truth[f]:+.4f} "
                         f"sd {statistics.stdev(values):.4f} "
                         f"sigma {sigma:.4f}")
        print(f"    point {k}: " + "; ".join(cells))


def pooled_covariance(rows):
    """3 x 3 covariance of rows of three values each, about their mean."""
    n = len(rows)
    mean = [statistics.fmean(r[k] for r in rows) for k in range(3)]
    return [[sum((r[j] - mean[j]) * (r[k] - mean[k]) for r in rows) / (n - 1)
             for k in range(3)] for j in range(3)], mean


def parabola_sigma(y, var, rho1, rho2):
    """sonar_uncertainty_parabola_sigma (), in steps."""
    c = y[0] - 2 * y[1] + y[2]
    if not c < 0:
        return math.nan
    u = 0.5 * (y[0] - y[2]) / c
    w = [(1 - 2 * u) / (2 * c), 4 * u / (2 * c), -(1 + 2 * u) / (2 * c)]
    rho = [[1, rho1, rho2], [rho1, 1, rho1], [rho2, rho1, 1]]
    v = sum(w[j] * w[k] * rho[j][k] * math.sqrt(var[j] * var[k])
            for j in range(3) for k in range(3))
    return math.sqrt(v) if v > 0 else math.nan


def print_samples(per_point):
    """--samples: the parabola's inputs against the noise models."""
    for axis, name in enumerate(("range", "azimuth", "elevation")):
        cov = [[0.0] * 3 for _ in range(3)]
        kappas, moved, total = [], 0, 0
        z2 = {"CRB": 0.0, "peak-shaped": 0.0}
        dof = 0
        for p in per_point:
            s = [d["samples"] for d in p]
            if len(s) < 3:
                continue
            total += len(s)
            if axis:
                # Its search moves by multiples of a quarter step.
                moved += sum(abs(v[7 + axis] - v[4 + axis]) > 0.25
                             for v in s)
            pixel = statistics.mode(int(v[1 + axis]) for v in s)
            s = [v for v in s if int(v[1 + axis]) == pixel
                 and all(x > 0 for x in v[10 + 5 * axis + 1:
                                          10 + 5 * axis + 4])]
            if len(s) < 3:
                continue
            logs = [[math.log(x) for x in v[10 + 5 * axis + 1:
                                             10 + 5 * axis + 4]] for v in s]
            c, mean = pooled_covariance(logs)
            noise = statistics.median(v[0] for v in s)
            predicted = [noise / (2 * math.exp(2 * m)) for m in mean]
            for j in range(3):
                for k in range(3):
                    cov[j][k] += (len(s) - 1) * c[j][k] / math.sqrt(
                        predicted[j] * predicted[k])
            kappa = mean[0] - 2 * mean[1] + mean[2]
            kappas.append(kappa)
            offsets = []
            sigmas = {"CRB": [], "peak-shaped": []}
            for v, y in zip(s, logs):
                k = y[0] - 2 * y[1] + y[2]
                offsets.append(0.5 * (y[0] - y[2]) / k)
                snr = math.exp(2 * y[1]) / v[0]
                sigmas["CRB"].append(math.sqrt(1 / (2 * snr * -k)))
                var = [v[0] / (2 * math.exp(2 * x)) for x in y]
                sigmas["peak-shaped"].append(parabola_sigma(
                    y, var, math.exp(k / 2), math.exp(2 * k)))
            m = statistics.fmean(offsets)
            for key, values in sigmas.items():
                z2[key] += sum(((o - m) / sg) ** 2
                               for o, sg in zip(offsets, values))
            dof += len(s) - 1
        if not dof:
            continue
        cov = [[x / dof for x in row] for row in cov]
        d = [math.sqrt(cov[k][k]) for k in range(3)]
        kappa = statistics.fmean(kappas)
        print(f"    {name}: gamma {cov[0][0]:.2f} {cov[1][1]:.2f} "
              f"{cov[2][2]:.2f}, rho1 {cov[0][1] / d[0] / d[1]:.2f} "
              f"{cov[1][2] / d[1] / d[2]:.2f} (peak-shaped "
              f"{math.exp(kappa / 2):.2f}), rho2 "
              f"{cov[0][2] / d[0] / d[2]:.2f} ({math.exp(2 * kappa):.2f}); "
              f"parabola's ratio: CRB {1 / math.sqrt(z2['CRB'] / dof):.2f}, "
              f"peak-shaped propagation "
              f"{1 / math.sqrt(z2['peak-shaped'] / dof):.2f} ({dof} dof)"
              + (f"; moved by velocityest {moved}/{total}" if axis else ""))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("noise", type=float, nargs="+",
                        help="sonarsrc noise-amplitude values")
    parser.add_argument("--pings", type=int, default=24)
    parser.add_argument("--samples", action="store_true",
                        help="also print the parabola's samples against "
                        "the noise models (see above)")
    parser.add_argument("--mimobeamform", default="",
                        help="its properties, e.g. \"mode=fixed "
                        "velocity=0\" (one hypothesis)")
    parser.add_argument("--seeds", type=int, nargs="+",
                        help="the random points of these seeds instead of "
                        "the four fixed ones")
    parser.add_argument("--per-point", action="store_true",
                        help="also print each point's mean, scatter and "
                        "median sigma per coordinate")
    args = parser.parse_args()
    print(f"{'noise':>6} {'found':>11} {'image SNR':>9} " + " ".join(
        f"{f + ' sigma':>22} {'ratio':>5}" for f in FIELDS) + f" {'dof':>4}")
    scenes = ([random_points(seed) for seed in args.seeds] if args.seeds
              else [POINTS])
    points = [p for scene in scenes for p in scene]
    with tempfile.TemporaryDirectory() as folder:
        for noise in args.noise:
            per_point = [p for scene in scenes for p in run(
                noise, args.pings, pathlib.Path(folder), args.samples,
                args.mimobeamform, scene, by_range=bool(args.seeds))]
            detections = [d for p in per_point for d in p]
            found = (f"{len(detections)}/{len(points) * args.pings}"
                     if args.seeds else
                     "/".join(str(len(p)) for p in per_point))
            if not detections:
                print(f"{noise:>6} {found:>11} (nothing found)")
                continue
            snr = statistics.median(d["snr"] for d in detections)
            cells = []
            for f in FIELDS:
                sigma = statistics.median(d[f + "_sigma"] for d in detections
                                          if d[f + "_sigma"] is not None)
                r, dof = ratio(per_point, f)
                cells.append(f"{sigma:>22.3g} {r:>5.2f}")
            print(f"{noise:>6} {found:>11} {snr:>9.1f} " + " ".join(cells)
                  + f" {dof:>4}")
            if args.per_point:
                print_points(per_point, points)
            if args.samples:
                print_samples(per_point)
    return 0


if __name__ == "__main__":
    sys.exit(main())
