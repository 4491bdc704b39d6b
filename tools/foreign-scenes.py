#!/usr/bin/python3
"""Objects found on recordings the project did not make: seeded random
scenes written by tests/foreign_sim.py (its own physics, the eRTIS array,
8 emitters of band-passed noise), each replayed through the chain at the
elements' defaults (`filesrc ! wavparse ! dopplerbank sensor-file=... !
mimobeamform ! wardcluster ! velocityest`) and, for comparison, with
other mimobeamform properties. An object is found when a valid
detection lies within 5 cm of it where it is at the detection's instant
(moved along its straight line: the chain reports each object when the
emissions' energy centre reaches it, the simulator's truth is when their
start does); every other valid detection is false.

Scenes: OBJECTS point reflectors at 0.8-6 m, azimuth +-60 degrees (and
elevation +-40 on a 3-D sensor), radial velocities +-3 m/s, strengths
spread evenly in dB over SPREAD below the strongest (the r^2-weighted
image spans that range), one ping each.

    /usr/bin/python3 tools/foreign-scenes.py --view fan --scenes 20 \\
        --compare "refine-pfa=0"

A word ELEMENT.PROP=VALUE of --compare sets another element's property
(dopplerbank, mimobeamform, wardcluster or velocityest); a bare one is
mimobeamform's. --set KEY=VALUE sets a spec key of foreign_sim.py (VALUE
in JSON) for every scene: what a real sensor's recordings hold and the
simulator leaves out by default (direct_path, air_absorption,
emitter_resonance, microphone_mismatch):

    /usr/bin/python3 tools/foreign-scenes.py --view fan --scenes 12 \\
        --seed 3 --set direct_path=0.1 --compare dopplerbank.direct-path=off

--array-scale MICS,EMITTERS scales the eRTIS microphones and the default
emitters' ellipse (2.5,2: an array 2.5 times as wide, whose main lobe is
1.4 degrees against eRTIS's 3.0).

--explain lists, under each scene, every object missed (its place,
radial velocity, dB below the strongest and the nearest detection) and
every false detection. --time measures each run of the chain (one
gst-launch-1.0 at a time: the ping and the elements' set-up, wall and
CPU time) and the share of the dense image's passes mimobeamform imaged
(its GST_DEBUG line), per scene and as ranges over the scenes. --keep DIR
keeps each scene's files (sceneK.wav, .sensor.json, .truth.json) to
replay. The summary gives, beside the objects found, the radial velocity
errors of those found against the truth.
"""

import argparse
import contextlib
import json
import math
import os
import pathlib
import random
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
MATCH = 0.05


def scene(rng, view, n_objects, spread_db):
    reflectors = []
    for _ in range(n_objects):
        r = rng.uniform(0.8, 6.0)
        az = math.radians(rng.uniform(-60, 60))
        el = math.radians(rng.uniform(-40, 40)) if view == "hemisphere" \
            else 0.0
        u = [math.sin(az) * math.cos(el), math.sin(el),
             math.cos(az) * math.cos(el)]
        v = rng.uniform(-3, 3)
        reflectors.append({
            "position": [r * x for x in u],
            "velocity": [v * x for x in u],
            "strength": 2 * 10 ** (-rng.uniform(0, spread_db) / 20)})
    return reflectors


# mimobeamform's DEBUG line per ping: "... (12.3 %)".
PASSES = re.compile(r"of the dense image's .* passes \(([0-9.]+) %\)")


ELEMENTS = ("dopplerbank", "mimobeamform", "wardcluster", "velocityest")


def run_chain(folder, name, props, env, timing=None):
    """The detections of the scene's ping, @props the words of --compare;
    with @timing (a list), appends (wall s, CPU s, share of the dense
    image's passes in %) of the run."""
    settings = {e: [] for e in ELEMENTS}
    for word in props.split():
        element, dot, rest = word.partition(".")
        if dot and element in ELEMENTS and "=" in rest:
            settings[element].append(rest)
        else:
            settings["mimobeamform"].append(word)
    settings["dopplerbank"].insert(0, "sensor-file=%s/%s.sensor.json" % (
        folder, name))
    launch = ["gst-launch-1.0", "-q", "filesrc",
              "location=%s/%s.wav" % (folder, name), "!", "wavparse"]
    for element in ELEMENTS:
        launch += ["!", element] + settings[element]
    launch += ["!", "fdsink"]
    if timing is not None:
        env = dict(env, GST_DEBUG="mimobeamform:5", GST_DEBUG_NO_COLOR="1")
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    began = time.monotonic()
    out = subprocess.run(launch, env=env, capture_output=True, text=True)
    wall = time.monotonic() - began
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if out.returncode != 0:
        sys.exit("the chain failed: %s" % out.stderr.strip())
    if timing is not None:
        shares = [float(m.group(1)) for m in PASSES.finditer(out.stderr)]
        timing.append((wall, after.ru_utime + after.ru_stime -
                       before.ru_utime - before.ru_stime,
                       statistics.mean(shares) if shares else math.nan))
    return json.loads(out.stdout.splitlines()[0])["detections"]


def spread(values, unit, digits):
    """"median (min-max) unit" of @values."""
    return "%.*f%s (%.*f-%.*f)" % (
        digits, statistics.median(values), unit, digits, min(values),
        digits, max(values))


def offset(r, d):
    """How far detection @d lies from reflector @r where @r is at @d's
    instant (velocityest's: when the emissions' energy centre reaches the
    object; the truth's own instant, "t", is when their start does), along
    @r's straight line."""
    dt = d["instant"] - r["t"] if d.get("instant") is not None else 0.0
    return math.dist([p + v * dt for p, v in zip(r["position"],
                                                  r["velocity"])],
                     [d["x"], d["y"], d["z"]])


def score(detections, truth):
    """The radial velocity errors of the objects found (m/s), and the lists
    of those missed and of the false detections."""
    errors, used, missed = [], set(), []
    for r in truth:
        for j, d in enumerate(detections):
            if d["valid"] and j not in used and offset(r, d) < MATCH:
                errors.append(abs(d["radial_velocity"] -
                                  r["radial_velocity"]))
                used.add(j)
                break
        else:
            missed.append(r)
    false = [d for j, d in enumerate(detections)
             if d["valid"] and j not in used]
    return errors, missed, false


def explain(label, truth, detections, missed, false):
    """Lines on what a run missed and reported falsely: each missed
    object's place, its strength against the strongest's and the nearest
    detection (valid or rejected); each false detection's place."""
    top = max(r["strength"] for r in truth)
    for r in missed:
        near = min(detections, default=None, key=lambda d: offset(r, d))
        where = "no detection" if near is None else \
            "nearest detection %.3f m away (%s)" % (
                offset(r, near), "valid" if near["valid"] else "rejected")
        print("  %s missed: %.3f m, az %.1f, el %.1f, %+.2f m/s, %.1f dB "
              "below the strongest; %s" % (
                  label, r["range"], r["azimuth"], r["elevation"],
                  r["radial_velocity"], 20 * math.log10(top / r["strength"]),
                  where))
    for d in false:
        print("  %s false: %.3f m, az %.1f, el %.1f, %+.3f m/s, snr %.1f dB"
              % (label, d["range"], d["azimuth"], d["elevation"] or 0.0,
                 d["radial_velocity"], d["snr"]))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--view", choices=("fan", "hemisphere"),
                        default="fan")
    parser.add_argument("--scenes", type=int, default=10)
    parser.add_argument("--objects", type=int, default=6)
    parser.add_argument("--spread", type=float, default=30.0,
                        help="dB between the strongest and the weakest")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--ping-rate", type=float, default=None,
                        metavar="HZ", help="the sensor's pings per second "
                        "(its window: what a ping records); default the "
                        "simulator's")
    parser.add_argument("--compare", action="append", default=[],
                        metavar="PROPS", help="mimobeamform properties of "
                        "another run of every scene, or ELEMENT.PROP=VALUE "
                        "for another element's (repeatable)")
    parser.add_argument("--set", action="append", default=[],
                        metavar="KEY=VALUE", help="a spec key of "
                        "foreign_sim.py for every scene, VALUE in JSON "
                        "(direct_path=0.1, air_absorption=true, "
                        "emitter_resonance=[38e3,52e3,1.5,3], "
                        "microphone_mismatch=[1.5,10]; repeatable)")
    parser.add_argument("--array-scale", metavar="MICS,EMITTERS",
                        help="the eRTIS microphones and the default "
                        "emitters' ellipse scaled by these factors (2.5,2: "
                        "an array 2.5 times as wide)")
    parser.add_argument("--explain", action="store_true",
                        help="under each scene, the objects missed and "
                        "the false detections")
    parser.add_argument("--keep", metavar="DIR", help="write the scenes' "
                        "recordings, sensor files and truths into DIR (made "
                        "if need be) and keep them, to replay")
    parser.add_argument("--time", action="store_true",
                        help="each run's wall and CPU time (its ping and "
                        "the set-up) and share of the dense image's "
                        "passes")
    args = parser.parse_args()

    env = dict(os.environ)
    build = os.environ.get("SONAR_BUILD_DIR", str(ROOT / "build"))
    env["GST_PLUGIN_PATH_1_0"] = str(pathlib.Path(build) / "elements")
    sys.path.insert(0, str(ROOT / "tests"))
    import foreign_sim

    extra = {}
    for setting in args.set:
        key, equals, value = setting.partition("=")
        if not equals or key not in foreign_sim.SPEC_KEYS:
            parser.error("--set %s: KEY=VALUE with one of foreign_sim.py's "
                         "spec keys" % setting)
        extra[key] = json.loads(value)
    if args.array_scale:
        try:
            mics, emitters = (float(f) for f in args.array_scale.split(","))
        except ValueError:
            parser.error("--array-scale %s: two factors, MICS,EMITTERS" %
                         args.array_scale)
        extra["microphones"] = (mics *
                                foreign_sim.ertis_microphones()).tolist()
        extra["emitters"] = (emitters *
                             foreign_sim.ellipse_emitters()).tolist()
    rng = random.Random(args.seed)
    variants = [""] + args.compare
    totals = {v: [0, 0, 0] for v in variants}
    errors = {v: [] for v in variants}
    timings = {v: [] for v in variants}
    if args.keep:
        pathlib.Path(args.keep).mkdir(parents=True, exist_ok=True)
    with contextlib.nullcontext(args.keep) if args.keep else \
            tempfile.TemporaryDirectory() as folder:
        for k in range(args.scenes):
            name = "scene%d" % k
            spec = {"name": name, "n_pings": 1, "seed": args.seed * 1000 + k,
                    "field_of_view": args.view,
                    **({"ping_period": 1.0 / args.ping_rate}
                       if args.ping_rate else {}),
                    **extra,
                    "reflectors": scene(rng, args.view, args.objects,
                                        args.spread)}
            foreign_sim.simulate(spec, folder)
            truth = json.loads(pathlib.Path(
                folder, name + ".truth.json").read_text())
            truth = truth["pings"][0]["reflectors"]
            row, lines = [], []
            for v in variants:
                detections = run_chain(folder, name, v, env,
                                       timings[v] if args.time else None)
                found, missed, false = score(detections, truth)
                errors[v] += found
                t = totals[v]
                t[0] += len(found)
                t[1] += len(truth)
                t[2] += len(false)
                row.append("%d/%d, %d false" % (len(found), len(truth),
                                                len(false)))
                if args.time:
                    row[-1] += ", %.1f s wall, %.1f s CPU, %.1f %%" % \
                        timings[v][-1]
                lines.append((v or "defaults", detections, missed, false))
            print("%s: %s" % (name, " | ".join(row)), flush=True)
            for label, detections, missed, false in lines if args.explain \
                    else ():
                explain(label, truth, detections, missed, false)
    print("\n%s, %d scenes of %d objects over %g dB, seed %d%s:" % (
        args.view, args.scenes, args.objects, args.spread, args.seed,
        "".join(", %s" % setting for setting in args.set +
                ["array scaled %s" % args.array_scale] * bool(
                    args.array_scale))))
    for v in variants:
        t = totals[v]
        print("  %-24s found %d of %d, %d false" % (
            v or "defaults", t[0], t[1], t[2]))
        if errors[v]:
            e = sorted(errors[v])
            print("  %-24s radial velocity error: mean %.4f, median %.4f, "
                  "95 %% %.4f, worst %.4f m/s" % (
                      "", statistics.mean(e), statistics.median(e),
                      e[min(len(e) - 1, int(0.95 * len(e)))], e[-1]))
        if args.time:
            walls, cpus, shares = zip(*timings[v])
            print("  %-24s a run: %s wall, %s CPU, %s of the dense "
                  "image's passes" % ("", spread(walls, " s", 1),
                                      spread(cpus, " s", 1),
                                      spread(shares, " %", 1)))


if __name__ == "__main__":
    main()
