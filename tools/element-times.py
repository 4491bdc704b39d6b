#!/usr/bin/python3
"""Time per ping of each element of a pipeline, from GStreamer's latency
tracer, and each element's share of the others' total.

Usage:
  GST_TRACERS="latency(flags=element)" GST_DEBUG="GST_TRACER:7" \\
    gst-launch-1.0 -q ... 2>&1 >/dev/null | tools/element-times.py

The tracer logs, for every buffer an element pushes, the time from the
buffer entering the element to the result leaving it (wall-clock: other
processes on the machine inflate it). Prints per element the pings seen,
the median and the 10-90 % range in ms, and its median's share of the sum
of the other elements' medians.
"""

import re
import statistics
import sys

RECORD = re.compile(r"element-latency, .*element=\(string\)([^,]+), "
                    r"src=\(string\)[^,]+, time=\(guint64\)(\d+)")


def percentile(values, fraction):
    """The value below which @fraction of @values lie (nearest rank)."""
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(fraction * len(ordered)))]


def main():
    """Read the log from stdin, print the table."""
    times = {}
    for line in sys.stdin:
        match = RECORD.search(line)
        if match:
            times.setdefault(match.group(1), []).append(
                int(match.group(2)) / 1e6)
    if not times:
        sys.exit("no element-latency records: run gst-launch-1.0 with "
                 "GST_TRACERS=\"latency(flags=element)\" and "
                 "GST_DEBUG=\"GST_TRACER:7\", its stderr to this tool")
    medians = {name: statistics.median(v) for name, v in times.items()}
    total = sum(medians.values())
    print(f"{'element':<16} {'pings':>5} {'median ms':>10} {'10-90 % ms':>15}"
          f" {'share of the rest':>18}")
    for name, values in times.items():
        rest = total - medians[name]
        share = 100.0 * medians[name] / rest if rest > 0 else float("nan")
        print(f"{name:<16} {len(values):>5} {medians[name]:>10.3f} "
              f"{percentile(values, 0.1):>7.3f}-{percentile(values, 0.9):<7.3f}"
              f" {share:>17.2f}%")


if __name__ == "__main__":
    main()
