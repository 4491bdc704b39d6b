#!/usr/bin/python3
"""Prints each ping's detections: velocityest's JSON lines from an appsink.
Usage: print-detections.py ["sonarsrc scene=fig9 num-buffers=2 ! ... ! velocityest"]
"""
import json
import sys

import gi
gi.require_version("Gst", "1.0")
from gi.repository import Gst  # noqa: E402

Gst.init(None)
chain = sys.argv[1] if len(sys.argv) > 1 else (
    "sonarsrc num-buffers=3 ! dopplerbank velocity-min=-1.5 velocity-max=1.5"
    " ! mimobeamform ! wardcluster ! velocityest")
pipeline = Gst.parse_launch(chain + " ! appsink name=sink sync=false")
sink, bus, error = pipeline.get_by_name("sink"), pipeline.get_bus(), None
pipeline.set_state(Gst.State.PLAYING)
while (sample := sink.emit("pull-sample")) is not None:
    ping = json.loads(sample.get_buffer().extract_dup(0, 1 << 62))  # all of it
    print(f"ping {ping['ping']}: {len(ping['detections'])} detections")
    for d in ping["detections"]:  # velocity null: none measured (rejected)
        v = "none" if d["radial_velocity"] is None else f"{d['radial_velocity']:+.3f}"
        print(f"  {d['range']:.3f} m  azimuth {d['azimuth']:+.1f}  elevation "
              f"{d['elevation']:+.1f} deg  {v} m/s")
    while (msg := bus.pop()) is not None:  # a few every ping: they pile up
        error = error or (msg.type == Gst.MessageType.ERROR and msg)
pipeline.set_state(Gst.State.NULL)
sys.exit(f"print-detections: {error.parse_error()[0].message}" if error else 0)
