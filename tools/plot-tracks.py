#!/usr/bin/python3
"""Draw sonartrack's tracks (its JSON lines) as PNG.

Usage: tools/plot-tracks.py TRACKS.jsonl [-o tracks.png] [--frame sensor|world]
           [--truth TRUTH.jsonl] [--arrow-seconds 0.5] [--last-ping N]

Top view (x right, z forward, metres, equal scales). Each confirmed track
is drawn as the path of its positions over the pings, its last position
ringed and labelled with its id and speed in the world, and an arrow of
its velocity in the world (how far it goes in --arrow-seconds): red for
moving, blue for still. Tentative tracks are small grey dots.

--frame sensor (default): positions as the sensor saw them on the last
ping: earlier pings' positions are moved by how far the sensor went since
(the sum of the ego velocities times the time between pings; a ping whose
ego-motion was unobservable keeps the last one). --frame world: the sensor
starts at the origin and moves; its path is drawn too. With a still sensor
both are the same.

--truth: JSON lines {"ping": N, "reflectors": [{"range", "azimuth",
"elevation"}, ...]} (tools/print-messages.py --truth) drawn as small black
crosses in the same frame.

A panel below shows the ego velocity's components per ping with their
1-sigma bands; gaps are pings where it was unobservable.
"""

import argparse
import json
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402 (after choosing the backend)


def parse_args(argv):
    """Command-line options."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("tracks", help="sonartrack's JSON lines")
    p.add_argument("-o", "--output", default="tracks.png", help="PNG file")
    p.add_argument("--frame", choices=("sensor", "world"), default="sensor")
    p.add_argument("--truth", help="JSON lines of the true reflectors")
    p.add_argument("--arrow-seconds", type=float, default=0.5,
                   help="velocity arrows show this many seconds of motion")
    p.add_argument("--last-ping", type=int,
                   help="draw the pings up to this one (default: all)")
    return p.parse_args(argv)


def read_lines(path):
    """JSON objects, one per non-empty line; errors name the line."""
    out = []
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            if not line.strip():
                continue
            try:
                out.append(json.loads(line))
            except json.JSONDecodeError as e:
                sys.exit(f"{path}:{number}: not JSON: {e}")
    return out


def sensor_path(pings):
    """The sensor's displacement (x, z) at each ping from the first,
    integrating the ego velocity (the last observed one through pings
    where it was unobservable)."""
    path, position, velocity, last_time = [], (0.0, 0.0), (0.0, 0.0), None
    for p in pings:
        time = p.get("time")
        if p.get("ego_velocity") is not None:
            velocity = (p["ego_velocity"][0], p["ego_velocity"][2])
        if last_time is not None and time is not None:
            dt = time - last_time
            position = (position[0] + velocity[0] * dt,
                        position[1] + velocity[1] * dt)
        if time is not None:
            last_time = time
        path.append(position)
    return path


def to_frame(point, sensor, last_sensor, frame):
    """A point seen from the sensor at @sensor, in the drawing's frame."""
    if frame == "world":
        return (point[0] + sensor[0], point[1] + sensor[1])
    return (point[0] + sensor[0] - last_sensor[0],
            point[1] + sensor[1] - last_sensor[1])


def main(argv=None):
    """Read, draw, write."""
    args = parse_args(sys.argv[1:] if argv is None else argv)
    pings = read_lines(args.tracks)
    if args.last_ping is not None:
        pings = [p for p in pings if p["ping"] <= args.last_ping]
    if not pings:
        sys.exit(f"{args.tracks}: no pings to draw")
    for p in pings:
        for member in ("ping", "tracks", "ego_status"):
            if member not in p:
                sys.exit(f"{args.tracks}: ping line without \"{member}\": "
                         "is it sonartrack's output?")
    path = sensor_path(pings)
    last = path[-1]
    paths, final = {}, {}
    for p, sensor in zip(pings, path):
        for t in p["tracks"]:
            xy = to_frame((t["x"], t["z"]), sensor, last, args.frame)
            paths.setdefault(t["id"], []).append((xy, t["state"]))
            final[t["id"]] = (t, xy, p["ping"])
    last_ping = pings[-1]["ping"]

    fig, (ax, ego_ax) = plt.subplots(
        2, 1, figsize=(8, 10), gridspec_kw={"height_ratios": [3, 1]})
    if args.truth:
        by_ping = {t["ping"]: t["reflectors"] for t in read_lines(args.truth)}
        xs, zs = [], []
        for p, sensor in zip(pings, path):
            for r in by_ping.get(p["ping"], []):
                az = math.radians(r["azimuth"])
                el = math.radians(r.get("elevation", 0.0))
                xy = to_frame((r["range"] * math.cos(el) * math.sin(az),
                               r["range"] * math.cos(el) * math.cos(az)),
                              sensor, last, args.frame)
                xs.append(xy[0])
                zs.append(xy[1])
        ax.plot(xs, zs, "x", color="black", ms=3, alpha=0.4,
                label="truth")
    for track_id, points in paths.items():
        confirmed = [xy for xy, state in points if state == "confirmed"]
        tentative = [xy for xy, state in points if state != "confirmed"]
        if tentative:
            ax.plot([q[0] for q in tentative], [q[1] for q in tentative],
                    ".", color="0.6", ms=3)
        if not confirmed:
            continue
        t, xy, ping = final[track_id]
        colour = "tab:red" if t["moving"] else "tab:blue"
        ax.plot([q[0] for q in confirmed], [q[1] for q in confirmed], "-",
                color=colour, lw=1.2, alpha=0.8)
        if ping != last_ping:
            continue
        vx, vz = t["velocity"][0], t["velocity"][2]
        ax.plot(*xy, "o", mfc="none", color=colour, ms=9)
        ax.annotate("", xy=(xy[0] + vx * args.arrow_seconds,
                            xy[1] + vz * args.arrow_seconds),
                    xytext=xy, arrowprops=dict(arrowstyle="->",
                                               color=colour, lw=1.5))
        ax.annotate(f"{track_id}: {math.hypot(vx, vz):.2f} m/s", xy,
                    xytext=(6, 6), textcoords="offset points", fontsize=8,
                    color=colour)
    sensor_xy = [to_frame((0.0, 0.0), s, last, args.frame) for s in path]
    ax.plot([q[0] for q in sensor_xy], [q[1] for q in sensor_xy], "-",
            color="black", lw=2)
    ax.plot(*sensor_xy[-1], "s", color="black", ms=7, label="sensor")
    ax.plot([], [], "-", color="tab:red", label="moving")
    ax.plot([], [], "-", color="tab:blue", label="still")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m)")
    ax.grid(alpha=0.3)
    ax.legend(loc="lower left", fontsize=8)
    ax.set_title(f"sonartrack, pings {pings[0]['ping']}-{last_ping} "
                 f"({args.frame} frame at ping {last_ping}); arrows: "
                 f"{args.arrow_seconds:g} s of velocity in the world",
                 fontsize=9)

    for k, (axis, colour) in enumerate((("x", "tab:orange"),
                                        ("z", "tab:green"))):
        c = 0 if k == 0 else 2
        xs = [p["ping"] if p.get("ego_velocity") else math.nan
              for p in pings]
        vs = [p["ego_velocity"][c] if p.get("ego_velocity") else math.nan
              for p in pings]
        sd = [math.sqrt(p["ego_covariance"][c][c])
              if p.get("ego_covariance") else math.nan for p in pings]
        ego_ax.plot(xs, vs, ".-", color=colour, label=f"v{axis}")
        ego_ax.fill_between(xs, [v - s for v, s in zip(vs, sd)],
                            [v + s for v, s in zip(vs, sd)], color=colour,
                            alpha=0.25)
    unobservable = [p["ping"] for p in pings if not p.get("ego_velocity")]
    for ping in unobservable:
        ego_ax.axvspan(ping - 0.5, ping + 0.5, color="0.85")
    ego_ax.set_xlabel("ping")
    ego_ax.set_ylabel("ego velocity (m/s)")
    ego_ax.grid(alpha=0.3)
    ego_ax.legend(fontsize=8, title=f"{len(unobservable)} unobservable "
                  "(grey)" if unobservable else None, title_fontsize=8)
    fig.tight_layout()
    fig.savefig(args.output, dpi=110)
    print(f"{args.output}: {len(paths)} tracks over {len(pings)} pings")


if __name__ == "__main__":
    main()
