#!/usr/bin/python3
"""Runs a pipeline and prints the sonar plugin's bus messages
(docs/CONTRACTS.md section 10) as tables: each ping's ground truth
("sonar-truth", from sonarsrc) and detections ("sonar-detections", from
velocityest), every detection with the true object nearest to it and the
velocity error. The messages are read from the bus as structures (PyGObject
with python3-gst-1.0, which reads their lists), not from gst-launch's text.
Errors and warnings are printed as gst-launch prints them; an error ends
the run with status 1. With --truth FILE the ground truth is also written as
JSON lines ({"ping": p, "reflectors": [...]}) for tools/plot-energyscape.py
and tools/plot-tracks.py --truth.

    tools/print-messages.py 'sonarsrc num-buffers=2 ! dopplerbank \\
        velocity-min=-1.5 velocity-max=1.5 ! mimobeamform ! wardcluster \\
        ! velocityest ! fakesink'
"""
import argparse
import json
import math
import sys

import gi
gi.require_version("Gst", "1.0")
from gi.repository import GLib, Gst  # noqa: E402

COORDINATES = ("range", "azimuth", "elevation", "radial_velocity")


def items(structure, field):
    """The list of structures in @field as dicts of their fields."""
    out = []
    for item in structure.get_value(field):
        out.append({item.nth_field_name(i): item.get_value(
            item.nth_field_name(i)) for i in range(item.n_fields())})
    return out


def position(item):
    r = item["range"]
    az, el = math.radians(item["azimuth"]), math.radians(item["elevation"])
    return (r * math.cos(el) * math.sin(az), r * math.sin(el),
            r * math.cos(el) * math.cos(az))


def moved(item, ping_time, instant, speed_of_sound):
    """A true object moved along its line of sight to a detection's
    instant: the truth is the state when the ping's start reaches the
    object, a detection's when the emissions' centre does (CONTRACTS)."""
    since = instant - (ping_time + item["range"] / speed_of_sound)
    return dict(item, range=item["range"] + item["radial_velocity"] * since)


class Printer:
    def __init__(self, truth_file, speed_of_sound):
        self.truth_file = truth_file
        self.speed_of_sound = speed_of_sound
        self.truth = {}
        self.ping_times = {}

    def ground_truth(self, s):
        ping = s.get_value("ping")
        reflectors = items(s, "reflectors")
        self.ping_times[ping] = s.get_value("timestamp") / 1e9
        self.truth[ping] = reflectors
        if self.truth_file:
            self.truth_file.write(json.dumps({"ping": ping, "reflectors": [
                {k: r[k] for k in COORDINATES} for r in reflectors]}) + "\n")
        print(f"ping {ping}: ground truth")
        print(f"  {'id':>3} {'kind':<9} {'range m':>8} {'azim deg':>9} "
              f"{'elev deg':>9} {'v_r m/s':>8}")
        for r in reflectors:
            print(f"  {r['id']:>3} {r['kind']:<9} {r['range']:8.3f} "
                  f"{r['azimuth']:9.2f} {r['elevation']:9.2f} "
                  f"{r['radial_velocity']:8.3f}")

    def detections(self, s):
        ping = s.get_value("ping")
        found = items(s, "detections")
        print(f"ping {ping}: {len(found)} detections")
        print(f"  {'range m':>8} {'azim deg':>9} {'elev deg':>9} "
              f"{'v_r m/s':>8} {'conf':>5}   nearest true object, error")
        for d in found:
            then = [moved(t, self.ping_times[ping], d["instant"],
                          self.speed_of_sound)
                    for t in self.truth.get(ping, [])]
            best = min(then, default=None,
                       key=lambda t: math.dist(position(t), position(d)))
            note = ""
            if best is not None:
                error = d["radial_velocity"] - best["radial_velocity"]
                note = (f"id {best['id']} at "
                        f"{math.dist(position(best), position(d)):.3f} m, "
                        f"{error:+.4f} m/s")
            arrow = "approaching" if d["approaching"] else ""
            print(f"  {d['range']:8.3f} {d['azimuth']:9.2f} "
                  f"{d['elevation']:9.2f} {d['radial_velocity']:+8.3f} "
                  f"{d['confidence']:5.2f}   {note} {arrow}")


def main():
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    parser.add_argument("pipeline", nargs="+",
                        help="a gst-launch-1.0 pipeline description")
    parser.add_argument("--truth", help="write the ground truth as JSON lines")
    parser.add_argument("--speed-of-sound", type=float, default=343.0,
                        help="m/s, to place the truth at each detection's "
                        "instant (default 343)")
    args = parser.parse_args()
    Gst.init(None)
    try:
        pipeline = Gst.parse_launch(" ".join(args.pipeline))
    except GLib.Error as e:
        sys.exit(f"print-messages: the pipeline: {e.message}")
    truth_file = open(args.truth, "w") if args.truth else None
    printer = Printer(truth_file, args.speed_of_sound)
    handlers = {"sonar-truth": printer.ground_truth,
                "sonar-detections": printer.detections}
    bus = pipeline.get_bus()
    status = 0
    pipeline.set_state(Gst.State.PLAYING)
    try:
        while True:
            message = bus.timed_pop_filtered(
                Gst.CLOCK_TIME_NONE, Gst.MessageType.ELEMENT
                | Gst.MessageType.ERROR | Gst.MessageType.WARNING
                | Gst.MessageType.EOS)
            if message.type == Gst.MessageType.ELEMENT:
                s = message.get_structure()
                if s.get_name() in handlers:
                    handlers[s.get_name()](s)
                    sys.stdout.flush()
            elif message.type in (Gst.MessageType.ERROR,
                                  Gst.MessageType.WARNING):
                error, debug = (message.parse_error()
                                if message.type == Gst.MessageType.ERROR
                                else message.parse_warning())
                kind = ("ERROR" if message.type == Gst.MessageType.ERROR
                        else "WARNING")
                print(f"{kind}: from element {message.src.get_path_string()}"
                      f": {error.message}", file=sys.stderr)
                if debug:
                    print(f"Additional debug info:\n{debug}", file=sys.stderr)
                if message.type == Gst.MessageType.ERROR:
                    status = 1
                    break
            else:
                break
    except KeyboardInterrupt:
        status = 130
    pipeline.set_state(Gst.State.NULL)
    if truth_file:
        truth_file.close()
    return status


if __name__ == "__main__":
    sys.exit(main())
