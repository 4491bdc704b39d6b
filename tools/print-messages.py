#!/usr/bin/env python3
"""Reads `gst-launch-1.0 -m` output and prints the sonar plugin's element
messages (docs/CONTRACTS.md) as tables; everything else passes through
unless it is per-message chatter."""
import re
import sys

FIELD = re.compile(r'([a-z-]+)=\((?:double|uint|string|guint64)\)([^,;>"]+)')


def fields(text):
    return {k: v.strip() for k, v in FIELD.findall(text)}


for raw in sys.stdin:
    line = raw.replace("\\", "")
    if "sonar-truth" in line:
        head = fields(line.split("reflectors=")[0])
        print(f"ping {head.get('ping')}: ground truth")
        print(f"  {'id':>3} {'kind':<9} {'range m':>8} {'azim deg':>9} "
              f"{'elev deg':>9} {'v_r m/s':>8}")
        for item in line.split("reflector, ")[1:]:
            f = fields(item)
            print(f"  {f['id']:>3} {f['kind']:<9} {float(f['range']):8.3f} "
                  f"{float(f['azimuth']):9.2f} {float(f['elevation']):9.2f} "
                  f"{float(f['radial-velocity']):8.3f}")
    elif line.startswith("Got message") or line.startswith("Setting") \
            or line.startswith("Redistribute") or line.startswith("Pipeline"):
        continue
    else:
        sys.stdout.write(raw)
