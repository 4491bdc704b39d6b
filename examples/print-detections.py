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
sink = pipeline.get_by_name("sink")
pipeline.set_state(Gst.State.PLAYING)
while (sample := sink.emit("pull-sample")) is not None:
    buffer = sample.get_buffer()
    ping = json.loads(buffer.extract_dup(0, buffer.get_size()))
    print(f"ping {ping['ping']}: {len(ping['detections'])} detections")
    for d in ping["detections"]:
        print(f"  {d['range']:.3f} m  azimuth {d['azimuth']:+.1f}  elevation "
              f"{d['elevation']:+.1f} deg  {d['radial_velocity']:+.3f} m/s")
error = pipeline.get_bus().pop_filtered(Gst.MessageType.ERROR)
pipeline.set_state(Gst.State.NULL)
sys.exit(f"print-detections: {error.parse_error()[0].message}" if error else 0)
