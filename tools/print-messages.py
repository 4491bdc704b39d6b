#!/usr/bin/env python3
"""Reads `gst-launch-1.0 -m` output and prints the sonar plugin's element
messages (docs/CONTRACTS.md) as tables; everything else passes through
unless it is per-message chatter. With --truth FILE it also writes the
ground truth as JSON lines ({"ping": p, "reflectors": [...]}) for
tools/plot-energyscape.py --truth."""
import argparse
import json
import re
import sys

FIELD = re.compile(r'([a-z-]+)=\((?:double|uint|string|guint64)\)([^,;>"]+)')


def fields(text):
    return {k: v.strip() for k, v in FIELD.findall(text)}


parser = argparse.ArgumentParser(description=__doc__)
parser.add_argument("--truth", help="write the ground truth as JSON lines")
args = parser.parse_args()
truth_file = open(args.truth, "w") if args.truth else None

for raw in sys.stdin:
    line = raw.replace("\\", "")
    if "sonar-truth" in line:
        head = fields(line.split("reflectors=")[0])
        items = [fields(item) for item in line.split("reflector, ")[1:]]
        if truth_file:
            truth_file.write(json.dumps({"ping": int(head["ping"]), "reflectors": [
                {k.replace("-", "_"): float(f[k]) for k in
                 ("range", "azimuth", "elevation", "radial-velocity")}
                for f in items]}) + "\n")
        print(f"ping {head.get('ping')}: ground truth")
        print(f"  {'id':>3} {'kind':<9} {'range m':>8} {'azim deg':>9} "
              f"{'elev deg':>9} {'v_r m/s':>8}")
        for f in items:
            print(f"  {f['id']:>3} {f['kind']:<9} {float(f['range']):8.3f} "
                  f"{float(f['azimuth']):9.2f} {float(f['elevation']):9.2f} "
                  f"{float(f['radial-velocity']):8.3f}")
    elif line.startswith("Got message") or line.startswith("Setting") \
            or line.startswith("Redistribute") or line.startswith("Pipeline"):
        continue
    else:
        sys.stdout.write(raw)
