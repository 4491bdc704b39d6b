#!/usr/bin/python3
"""Reads `gst-launch-1.0 -m` output and prints the sonar plugin's element
messages (docs/CONTRACTS.md) as tables: each ping's ground truth
("sonar-truth") and detections ("sonar-detections"), every detection with
the true object nearest to it and the velocity error. Other lines pass
through, except gst-launch's per-message chatter. With --truth FILE the
ground truth is also written as JSON lines ({"ping": p, "reflectors":
[...]}) for tools/plot-energyscape.py --truth."""
import argparse
import json
import math
import re
import sys

FIELD = re.compile(r'([a-z_-]+)=\((?:double|uint|string|guint64|boolean)\)'
                   r'([^,;>"]+)')


def fields(text):
    return {k: v.strip() for k, v in FIELD.findall(text)}


def position(item):
    r = float(item["range"])
    az = math.radians(float(item["azimuth"]))
    el = math.radians(float(item["elevation"]))
    return (r * math.cos(el) * math.sin(az), r * math.sin(el),
            r * math.cos(el) * math.cos(az))


def moved(item, ping_time, instant, speed_of_sound):
    """A true object moved along its line of sight to a detection's
    instant: the truth is the state when the ping's start reaches the
    object, a detection's when the emissions' centre does (CONTRACTS)."""
    since = instant - (ping_time + float(item["range"]) / speed_of_sound)
    return dict(item, range=float(item["range"]) +
                float(item["radial_velocity"]) * since)


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--truth", help="write the ground truth as JSON lines")
    parser.add_argument("--speed-of-sound", type=float, default=343.0,
                        help="m/s, to place the truth at each detection's "
                        "instant (default 343)")
    args = parser.parse_args()
    ping_times = {}
    truth_file = open(args.truth, "w") if args.truth else None
    truth = {}

    for raw in sys.stdin:
        line = raw.replace("\\", "")
        if "sonar-truth" in line:
            header = fields(line.split("reflectors=")[0])
            ping = int(header["ping"])
            ping_times[ping] = int(header["timestamp"]) / 1e9
            items = [fields(i) for i in line.split("reflector, ")[1:]]
            truth[ping] = items
            if truth_file:
                truth_file.write(json.dumps({"ping": ping, "reflectors": [
                    {k.replace("-", "_"): float(f[k]) for k in
                     ("range", "azimuth", "elevation", "radial_velocity")}
                    for f in items]}) + "\n")
            print(f"ping {ping}: ground truth")
            print(f"  {'id':>3} {'kind':<9} {'range m':>8} {'azim deg':>9} "
                  f"{'elev deg':>9} {'v_r m/s':>8}")
            for f in items:
                print(f"  {f['id']:>3} {f['kind']:<9} {float(f['range']):8.3f} "
                      f"{float(f['azimuth']):9.2f} {float(f['elevation']):9.2f} "
                      f"{float(f['radial_velocity']):8.3f}")
        elif "sonar-detections" in line:
            ping = int(fields(line.split("detections=")[0])["ping"])
            items = [fields(i) for i in line.split("detection, ")[1:]]
            print(f"ping {ping}: {len(items)} detections")
            print(f"  {'range m':>8} {'azim deg':>9} {'elev deg':>9} "
                  f"{'v_r m/s':>8} {'conf':>5}   nearest true object, error")
            for f in items:
                then = [moved(t, ping_times[ping], float(f["instant"]),
                              args.speed_of_sound)
                        for t in truth.get(ping, [])]
                best = min(then, default=None,
                           key=lambda t: math.dist(position(t), position(f)))
                note = ""
                if best is not None:
                    err = float(f["radial_velocity"]) - \
                        float(best["radial_velocity"])
                    note = (f"id {best['id']} at "
                            f"{math.dist(position(best), position(f)):.3f} m, "
                            f"{err:+.4f} m/s")
                arrow = "approaching" if f["approaching"] == "true" else ""
                print(f"  {float(f['range']):8.3f} {float(f['azimuth']):9.2f} "
                      f"{float(f['elevation']):9.2f} "
                      f"{float(f['radial_velocity']):+8.3f} "
                      f"{float(f['confidence']):5.2f}   {note} {arrow}")
        elif line.startswith(("Got message", "Setting", "Redistribute",
                              "Pipeline", "New clock")):
            continue
        else:
            sys.stdout.write(raw)


if __name__ == "__main__":
    main()
