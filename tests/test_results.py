#!/usr/bin/python3
"""Robot-ready results (issue 14): every JSON line of real pipelines'
output against the JSON Schemas in docs/ (detections, tracks), each
detection's frame id and position with two sensors in one process
(pipelines/two-sensors.sh), and the 1-sigma uncertainties each detection
reports against the scatter of its estimates over noisy pings.

Run as SONAR_BUILD_DIR=build SONAR_SOURCE_DIR=. /usr/bin/python3
tests/test_results.py; prints TAP and exits non-zero when a test fails.
"""

import json
import math
import os
import pathlib
import re
import statistics
import subprocess
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from taptest import BUILD_DIR, SOURCE_DIR, Skip, run_all, scratch, test  # noqa

TMP = scratch("sonar-results-")
GST_ENV = dict(os.environ, GST_PLUGIN_PATH_1_0=str(BUILD_DIR / "elements"),
               GST_REGISTRY_1_0=str(TMP / "registry.bin"))
BANK = ["velocity-min=-1.5", "velocity-max=1.5", "velocity-step=0.05"]
CHAIN = ["!", "dopplerbank", *BANK, "!", "mimobeamform", "!", "wardcluster",
         "!", "velocityest"]
# m: a detection this close to an object's surface is that object (as
# test-pipeline.c scores).
MATCH_DISTANCE = 0.05


def launch(*elements, timeout=300):
    """stdout of gst-launch-1.0 -q with @elements (a list of words)."""
    run = subprocess.run(["gst-launch-1.0", "-q", *elements],
                         capture_output=True, text=True, timeout=timeout,
                         env=GST_ENV)
    assert run.returncode == 0, run.stderr
    return run.stdout


def validator(name):
    try:
        import jsonschema
    except ImportError:
        raise Skip("python3-jsonschema is not installed (tools/setup)")
    schema = json.loads((SOURCE_DIR / "docs" / name).read_text())
    jsonschema.Draft7Validator.check_schema(schema)
    return jsonschema.Draft7Validator(schema)


def validate_lines(text, name, pings):
    """Every line of @text valid against docs/@name; returns them parsed."""
    check = validator(name)
    lines = text.splitlines()
    assert len(lines) == pings, text
    rows = []
    for number, line in enumerate(lines):
        row = json.loads(line)
        errors = sorted(check.iter_errors(row), key=str)
        assert not errors, f"line {number}: {errors[0]}"
        rows.append(row)
    return rows


@test
def detections_match_schema():
    """velocityest's JSON lines (the Fig. 9 world, rejected centroids kept)
    are valid against docs/detections.schema.json, each line and every
    valid detection carries the frame id, an amplitude, an SNR and finite
    positive uncertainties (elevation's null on the 2-D image; range's and
    velocity's null at the bank's edge, where Fig. 9's 3 m/s mover is)"""
    out = launch("sonarsrc", "scene=fig9", "num-buffers=3",
                 "frame-id=sonar_front", *CHAIN, "keep-rejected=true", "!",
                 "fdsink")
    rows = validate_lines(out, "detections.schema.json", 3)
    valid = [d for row in rows for d in row["detections"] if d["valid"]]
    assert len(valid) >= 3 * 4, out
    assert all(row["frame_id"] == "sonar_front" for row in rows), out
    assert any(d["out_of_range"] for d in valid), out
    for d in valid:
        assert d["frame_id"] == "sonar_front", d
        assert d["snr"] > 10.0 and math.isfinite(d["amplitude"]), d
        assert d["azimuth_sigma"] is not None and d["azimuth_sigma"] > 0.0, d
        assert d["elevation_sigma"] is None, d
        assert d["azimuth_sigma"] < 2.0, d
        # A velocity at the bank's edge is a bound: no sigma for it, nor
        # for the range moved on at it.
        for field in ("range_sigma", "radial_velocity_sigma"):
            if d["out_of_range"]:
                assert d[field] is None, (field, d)
            else:
                assert d[field] is not None and d[field] > 0.0, (field, d)
        # Sane sizes: well below the image's resolution cells.
        assert d["out_of_range"] or d["range_sigma"] < 0.01, d


@test
def printed_finer_than_sigma():
    """on the default scene's 65-75 dB echoes (the smallest uncertainties
    the presets give), the JSON prints each valid detection's range, x, z,
    azimuth and radial velocity in a unit no larger than the smallest
    sigma of that coordinate: rounding does not add to the error the sigma
    states (docs/CONTRACTS.md section 9)"""
    out = launch("sonarsrc", "num-buffers=2", *CHAIN, "!", "fdsink")
    # The unit: the most decimals any value of the field shows (numbers are
    # printed at their shortest, so one value may show fewer).
    decimals = {}
    for number in re.finditer(r'"(range|x|z|azimuth|radial_velocity)": '
                              r'-?\d+\.(\d+)', out):
        field, digits = number.group(1), len(number.group(2))
        decimals[field] = max(decimals.get(field, 0), digits)
    valid = [d for line in out.splitlines()
             for d in json.loads(line)["detections"] if d["valid"]]
    assert len(valid) >= 4, out
    # y is 0 on this 2-D image.
    sigma = {"range": "range_sigma", "x": "range_sigma", "z": "range_sigma",
             "azimuth": "azimuth_sigma",
             "radial_velocity": "radial_velocity_sigma"}
    for field, sigma_field in sigma.items():
        smallest = min(d[sigma_field] for d in valid)
        unit = 10.0 ** -decimals[field]
        print(f"# {field}: unit {unit:g}, smallest sigma {smallest:.3g}")
        assert unit <= smallest, (field, unit, smallest)


@test
def tracks_match_schema():
    """sonartrack's JSON lines (the Fig. 10 drive) are valid against
    docs/tracks.schema.json and carry the sensor's frame id"""
    out = launch("sonarsrc", "scene=fig10", "num-buffers=6",
                 "frame-id=sonar_front", "!", "dopplerbank",
                 "velocity-min=-0.4", "velocity-max=0.4",
                 "velocity-step=0.02", "!", "mimobeamform", "!",
                 "wardcluster", "!", "velocityest", "!", "sonartrack", "!",
                 "fdsink")
    rows = validate_lines(out, "tracks.schema.json", 6)
    assert all(row["frame_id"] == "sonar_front" for row in rows), out
    assert rows[-1]["tracks"] and rows[-1]["ego_status"] == "observed", out


def scene_truth(path, instant):
    """The reflectors of the scene file at @path as the sensor sees them
    at @instant: (position in the sensor frame, radius) each."""
    scene = json.loads(pathlib.Path(path).read_text())
    sensor = scene.get("sensor", {})
    s0 = sensor.get("position", [0, 0, 0])
    sv = sensor.get("velocity", [0, 0, 0])
    truths = []
    for r in scene["reflectors"]:
        p = r["position"]
        v = r.get("velocity", [0, 0, 0])
        truths.append(([p[i] + v[i] * instant - s0[i] - sv[i] * instant
                        for i in range(3)],
                       r.get("radius", 0.05) if r.get("kind") == "cylinder"
                       else 0.0))
    return truths


def surface_distance(detection, truth):
    """m from @detection's position to the near surface of @truth."""
    (centre, radius) = truth
    d = [detection["x"], detection["y"], detection["z"]]
    # A cylinder's echo comes from its surface facing the sensor.
    return abs(math.dist(d, centre) - radius) if radius else \
        math.dist(d, centre)


@test
def empty_ping_names_its_sensor():
    """A ping without detections names its sensor all the same (the line's
    frame_id): two sensors' lines through a funnel can be told apart"""
    out = launch("sonarsrc", "scene=empty", "num-buffers=1", "frame-id=left",
                 *CHAIN, "!", "fdsink")
    rows = validate_lines(out, "detections.schema.json", 1)
    assert rows[0]["detections"] == [] and rows[0]["frame_id"] == "left", out


@test
def two_sensors_tag_their_detections():
    """pipelines/two-sensors.sh: two sources in one process, 0.8 m apart
    in one world; each detection carries its sensor's frame id, and its
    position is an object of that sensor's view (not the other's), every
    object seen by both"""
    scenes = SOURCE_DIR / "pipelines" / "scenes"
    left, right = (scenes / "two-sensors-left.json",
                   scenes / "two-sensors-right.json")
    run = subprocess.run(
        [str(SOURCE_DIR / "pipelines" / "two-sensors.sh"), str(left),
         str(right), "3"], capture_output=True, text=True, timeout=300,
        env=dict(GST_ENV, SONAR_FRAME_IDS="left right"))
    assert run.returncode == 0, run.stderr
    seen = {"left": set(), "right": set()}
    lines = run.stdout.splitlines()
    assert len(lines) == 6, run.stdout
    for line in lines:
        row = json.loads(line)
        ids = {d["frame_id"] for d in row["detections"]}
        # One line is one sensor's ping: all its detections share its id.
        assert ids == {row["frame_id"]}, row
        for d in row["detections"]:
            own = left if d["frame_id"] == "left" else right
            other = right if own is left else left
            # Ping p happens at p / ping-rate, the timestamps' clock.
            truths = scene_truth(own, d["instant"])
            distances = [surface_distance(d, t) for t in truths]
            best = min(range(len(distances)), key=distances.__getitem__)
            assert distances[best] < MATCH_DISTANCE, (d, distances)
            elsewhere = min(surface_distance(d, t) for t in scene_truth(
                other, d["instant"]))
            assert elsewhere > 0.2, (d, elsewhere)
            seen[d["frame_id"]].add(best)
    assert seen == {"left": {0, 1, 2}, "right": {0, 1, 2}}, seen


# The uncertainty test's scene: still points at several ranges and
# directions (where a peak falls between the image's samples changes its
# estimators' errors), a weak echo each, far apart.
UNCERTAINTY_SCENE = {
    "dimensions": 2,
    "reflectors": [
        {"kind": "point", "range": 1.53, "azimuth": -41.6, "strength": 0.45},
        {"kind": "point", "range": 2.07, "azimuth": 23.2, "strength": 0.8},
        {"kind": "point", "range": 2.71, "azimuth": -8.4},
        {"kind": "point", "range": 3.32, "azimuth": 37.7, "strength": 1.5},
    ]}
UNCERTAINTY_PINGS = 40
# 30 % (the goal) on what N pings can tell: the scatter's own relative
# uncertainty is about 1 / sqrt (2 (N - 1) M) over M places.
UNCERTAINTY_TOLERANCE = 0.3


@test
def uncertainty_matches_scatter():
    """over 40 noisy pings of four still points (noise-amplitude 0.5, image
    SNR about 20 dB), the range, azimuth and radial velocity sigmas each
    detection reports match the scatter of its estimates within 30 %
    (pooled over the points: rms of deviation from the point's mean over
    the reported sigma)"""
    scene = TMP / "uncertainty.json"
    scene.write_text(json.dumps(UNCERTAINTY_SCENE))
    # The elements' defaults (the -7..7 m/s bank, 47 detection hypotheses).
    out = launch("sonarsrc", f"scene-file={scene}",
                 f"num-buffers={UNCERTAINTY_PINGS}", "noise-amplitude=0.5",
                 "!", "dopplerbank", "!", "mimobeamform", "!", "wardcluster",
                 "!", "velocityest", "!", "fdsink")
    truths = scene_truth(scene_file_positions(scene), 0.0)
    per_object = [[] for _ in truths]
    for line in out.splitlines():
        for d in json.loads(line)["detections"]:
            distances = [surface_distance(d, t) for t in truths]
            best = min(range(len(truths)), key=distances.__getitem__)
            if distances[best] < MATCH_DISTANCE:
                per_object[best].append(d)
    counts = [len(p) for p in per_object]
    assert min(counts) >= UNCERTAINTY_PINGS - 3, counts
    snrs = [d["snr"] for p in per_object for d in p]
    print(f"# image SNR median {statistics.median(snrs):.1f} dB, "
          f"{min(snrs):.1f}-{max(snrs):.1f}")
    assert 14.0 < statistics.median(snrs) < 26.0, snrs
    for field in ("range", "azimuth", "radial_velocity"):
        sum_z2, dof = 0.0, 0
        for p in per_object:
            mean = statistics.fmean(d[field] for d in p)
            sum_z2 += sum(((d[field] - mean) / d[field + "_sigma"]) ** 2
                          for d in p)
            dof += len(p) - 1
        ratio = 1.0 / math.sqrt(sum_z2 / dof)
        sigma = statistics.median(d[field + "_sigma"] for p in per_object
                                  for d in p)
        print(f"# {field}: reported sigma (median) {sigma:.3g}, reported / "
              f"measured {ratio:.2f}")
        assert abs(ratio - 1.0) <= UNCERTAINTY_TOLERANCE, (field, ratio)


def scene_file_positions(path):
    """A copy of the scene file at @path with each reflector given by its
    position (as scene_truth () reads them)."""
    scene = json.loads(pathlib.Path(path).read_text())
    for r in scene["reflectors"]:
        if "position" not in r:
            az = math.radians(r["azimuth"])
            el = math.radians(r.get("elevation", 0.0))
            r["position"] = [r["range"] * math.cos(el) * math.sin(az),
                             r["range"] * math.sin(el),
                             r["range"] * math.cos(el) * math.cos(az)]
    out = TMP / (pathlib.Path(path).stem + "-positions.json")
    out.write_text(json.dumps(scene))
    return out


if __name__ == "__main__":
    sys.exit(run_all())
