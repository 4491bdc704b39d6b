#!/usr/bin/python3
"""A robot's live sonar: the chain on a live source, results to an appsink.

    pipelines/live-robot.py                      # until Ctrl-C, one line per ping
    pipelines/live-robot.py --pings 1000 --quiet # 1000 of the source's pings, then a summary

The pipeline (docs/CONTRACTS.md, "Live pipelines"):

    sonarsrc is-live=true ! queue leaky=downstream max-size-buffers=1
      ! dopplerbank ! mimobeamform ! wardcluster ! velocityest
      ! appsink name=detections sync=false max-buffers=4 drop=true

The source pings at its rate in its own thread, as the sensor does; the
leaky queue holds only the newest ping, so when the chain is slower than
the source whole pings are dropped there (dopplerbank reports them: a
"sonar-dropped" warning and its dropped count) and the delay stays bounded.
The appsink hands each ping's detections to the application as soon as
they are ready (sync=false); with sync=true it would hold each ping until
its instant plus the pipeline's latency (a constant delay). Every result
carries the source's ping index: a dropped ping leaves a gap.

What an application must do, shown below: pull the samples, read the JSON
(or the SonarDetectionsMeta, in C), and on a LATENCY message call
gst_bin_recalculate_latency () (the elements measure their processing time
as they run). Replace sonarsrc with the sensor's own source (caps and the
sonar-setup event, or dopplerbank sensor-file=) for a real robot.
"""
import argparse
import json
import os
import statistics
import sys

import gi

gi.require_version("Gst", "1.0")
from gi.repository import Gst  # noqa: E402

ROBOT = ("sonarsrc is-live=true {source} ! queue leaky=downstream "
         "max-size-buffers=1 ! dopplerbank {bank} ! mimobeamform ! wardcluster "
         "! velocityest ! appsink name=detections sync={sync} max-buffers=4 "
         "drop=true")
STAGES = ["sonarsrc", "dopplerbank", "mimobeamform", "wardcluster",
          "velocityest"]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--pings", type=int, default=0,
                        help="stop after this many of the source's pings (0: never)")
    parser.add_argument("--source", default="",
                        help="sonarsrc properties, e.g. 'scene=fig9 ping-rate=12'")
    parser.add_argument("--bank", default="",
                        help="dopplerbank properties, e.g. 'velocity-min=-1 velocity-max=1'")
    parser.add_argument("--sync", action="store_true",
                        help="appsink sync=true: each ping held to its instant plus the latency")
    parser.add_argument("--pipeline",
                        help="a whole pipeline instead, ending in 'appsink name=detections'")
    parser.add_argument("--quiet", action="store_true",
                        help="no line per ping, the summary only")
    args = parser.parse_args()

    build = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..",
                         "build", "elements")
    if "GST_PLUGIN_PATH_1_0" not in os.environ and os.path.isdir(build):
        os.environ["GST_PLUGIN_PATH_1_0"] = build
    Gst.init(None)
    description = args.pipeline or ROBOT.format(
        source=args.source, bank=args.bank, sync="true" if args.sync else "false")
    pipeline = Gst.parse_launch(description)
    sink = pipeline.get_by_name("detections")
    bus = pipeline.get_bus()
    pipeline.set_state(Gst.State.PLAYING)

    delays, pings = [], []
    reported_dropped = 0
    last_ping = -1
    stopping = False
    try:
        while True:
            message = bus.pop()
            while message:
                kind = message.type
                if kind == Gst.MessageType.LATENCY:
                    pipeline.recalculate_latency()
                elif kind == Gst.MessageType.WARNING:
                    error, _ = message.parse_warning()
                    details = message.parse_warning_details()
                    if details and details.has_field("sonar-dropped"):
                        reported_dropped += details.get_uint64("pings")[1]
                    if not args.quiet:
                        print("# %s: %s" % (message.src.get_name(), error.message),
                              file=sys.stderr)
                elif kind == Gst.MessageType.ERROR:
                    error, debug = message.parse_error()
                    sys.exit("%s: %s" % (message.src.get_name(), error.message))
                elif kind == Gst.MessageType.EOS:
                    raise StopIteration
                message = bus.pop()
            sample = sink.emit("try-pull-sample", 100 * Gst.MSECOND)
            if sample is None:
                continue
            buffer = sample.get_buffer()
            now = pipeline.get_clock().get_time() - pipeline.get_base_time()
            result = json.loads(buffer.extract_dup(0, buffer.get_size()))
            delay = (now - buffer.pts) / Gst.SECOND
            delays.append(delay)
            pings.append(result["ping"])
            if not args.quiet:
                found = ", ".join(
                    "%.2f m %+.1f deg %+.3f m/s" % (d["range"], d["azimuth"],
                                                     d["radial_velocity"])
                    for d in result["detections"] if d["valid"])
                print("ping %d  t %.3f s  delay %.3f s  %s"
                      % (result["ping"], result["time"], delay, found), flush=True)
            last_ping = result["ping"]
            if args.pings and last_ping + 1 >= args.pings and not stopping:
                pipeline.send_event(Gst.Event.new_eos())
                stopping = True
    except (StopIteration, KeyboardInterrupt):
        pass

    # Each element's answer to the LATENCY query adds its own part.
    own, latency = [], None
    for stage in STAGES:
        element = next((e for e in pipeline.iterate_elements()
                        if e.get_factory().get_name() == stage), None)
        query = Gst.Query.new_latency()
        if element and element.get_static_pad("src").query(query):
            _, low, high = query.parse_latency()
            own.append("%s %.0f" % (stage, (low - (latency or (0, 0))[0]) / 1e6))
            latency = (low, high)
    pipeline.set_state(Gst.State.NULL)
    if not pings:
        sys.exit("no ping came out")
    gaps = last_ping + 1 - len(pings)
    after_first = max(delays[1:] or delays)
    delays.sort()
    print("%d of the source's first %d pings out (%d missing: the gaps in the "
          "ping numbers; %d reported in sonar-dropped warnings)"
          % (len(pings), last_ping + 1, gaps, reported_dropped))
    print("delay from a ping's instant to its result: median %.3f s, 95 %% %.3f s, "
          "max %.3f s (after the first ping: %.3f s)"
          % (statistics.median(delays), delays[int(0.95 * (len(delays) - 1))],
             delays[-1], after_first))
    if latency:
        print("latency reported: min %.3f s, max %.3f s; each element's own (ms): %s"
              % (latency[0] / 1e9, latency[1] / 1e9, ", ".join(own)))


if __name__ == "__main__":
    main()
