#!/usr/bin/python3
"""Draw the paper's Fig. 2: the wideband ambiguity function of each waveform.

Usage: tools/plot-ambiguity.py [WAVEFORMS.json ...] [-o out/ambiguity.png]

With no files it runs build/tools/sonar-waveforms for the three kinds
(PR-AWGN noise, multisine, hyperbolic chirp). For one emitter of each it
draws the matched filter envelope (dB, lag horizontal, radial velocity
vertical) over -5..5 m/s and zoomed over -1..1 m/s, plus the Doppler cut
(peak over lag against velocity, the "velocity sensitivity", panel d), and
prints each waveform's -3 dB Doppler width and peak sidelobe level.
The numbers come from tools/ambiguity.py.
"""

import argparse
import os
import pathlib
import sys

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402 (after choosing the backend)

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import ambiguity  # noqa: E402

# Short panel titles; a kind without one is titled by its description.
TITLES = {"noise": "PR-AWGN", "multisine": "multisine",
          "hyperbolic-chirp": "hyperbolic FM chirp"}


def default_program():
    """The sonar-waveforms executable of the build tree."""
    build = os.environ.get("SONAR_BUILD_DIR") or str(
        pathlib.Path(__file__).resolve().parent.parent / "build")
    return os.path.join(build, "tools", "sonar-waveforms")


def parse_args(argv):
    """Command-line options."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("files", nargs="*", metavar="WAVEFORMS.json",
                   help="waveforms files (default: generate the 3 kinds)")
    p.add_argument("-o", "--output", default="out/ambiguity.png",
                   help="PNG to write (default %(default)s)")
    p.add_argument("--program", default=default_program(),
                   help="sonar-waveforms executable (default %(default)s)")
    p.add_argument("--emitter", type=int, default=0,
                   help="which row of each file to analyse (default 0)")
    p.add_argument("--v-max", type=float, default=5.0,
                   help="velocity span of the wide panels, m/s")
    p.add_argument("--v-zoom", type=float, default=1.0,
                   help="velocity span of the zoomed panels, m/s")
    p.add_argument("--rows", type=int, default=201,
                   help="velocities per panel (default %(default)s)")
    p.add_argument("--lag-span", type=int, default=400,
                   help="lags shown in the wide panels, samples")
    p.add_argument("--zoom-lag-span", type=int, default=60,
                   help="lags shown in the zoomed panels, samples")
    p.add_argument("--dynamic-range", type=float, default=40.0,
                   help="dB below the peak where the colour scale ends")
    p.add_argument("--speed-of-sound", type=float,
                   default=ambiguity.SPEED_OF_SOUND, help="m/s")
    args = p.parse_args(argv)
    if args.rows < 3:
        p.error("--rows must be at least 3")
    if not 0 < args.v_zoom <= args.v_max < args.speed_of_sound:
        p.error("need 0 < --v-zoom <= --v-max < --speed-of-sound")
    return args


def load_inputs(args):
    """Return [(title, sample_rate, waveform)] for the emitter to analyse."""
    inputs = []
    if args.files:
        for path in args.files:
            rate, rows = ambiguity.load_waveforms(path)
            inputs.append((pathlib.Path(path).stem, rate, rows))
    else:
        for kind, description in ambiguity.kinds(args.program):
            rate, rows = ambiguity.generate_waveforms(args.program, kind)
            inputs.append((TITLES.get(kind, description), rate, rows))
    result = []
    for title, rate, rows in inputs:
        if not 0 <= args.emitter < len(rows):
            sys.exit(f"plot-ambiguity: --emitter {args.emitter} is out of "
                     f"range: {title} has {len(rows)} waveforms")
        result.append((title, rate, rows[args.emitter]))
    return result


def to_db(values, dynamic_range):
    """Linear amplitude (1 = peak) to dB, clipped at -dynamic_range."""
    return np.maximum(20.0 * np.log10(np.maximum(values, 1e-12)),
                      -dynamic_range)


def main(argv=None):
    """Compute, print the table, draw the figure."""
    args = parse_args(argv)
    inputs = load_inputs(args)
    wide = np.linspace(-args.v_max, args.v_max, args.rows)
    zoom = np.linspace(-args.v_zoom, args.v_zoom, args.rows)

    n = len(inputs)
    fig = plt.figure(figsize=(4.2 * n, 11), constrained_layout=True)
    grid = fig.add_gridspec(3, n)
    cut_axes = (fig.add_subplot(grid[2, :max(n - 1, 1)]),
                fig.add_subplot(grid[2, n - 1]) if n > 1 else None)

    image_axes = ([], [])
    print(f"{'waveform':<22} {'-3 dB width':>12} {'peak sidelobe':>14} "
          f"{'at v':>7} {'cut @1 m/s':>11} {'cut @v-max':>11}")
    for col, (title, rate, x) in enumerate(inputs):
        af = ambiguity.AmbiguityFunction(x, args.speed_of_sound)
        cuts = {}
        for row, (velocities, span, label) in enumerate(
                ((wide, args.lag_span, ""), (zoom, args.zoom_lag_span,
                                             ", zoom"))):
            lags, image, cut = af.image(velocities, span)
            cuts[label] = cut
            ax = fig.add_subplot(grid[row, col])
            mesh = ax.pcolormesh(lags, velocities,
                                 to_db(image, args.dynamic_range),
                                 shading="nearest", cmap="viridis",
                                 vmin=-args.dynamic_range, vmax=0.0,
                                 rasterized=True)
            ax.set_title(f"({chr(ord('a') + col)}) {title}{label}")
            ax.set_xlabel(f"lag (samples at {rate / 1000:g} kHz)")
            ax.set_ylabel("radial velocity (m/s)")
            image_axes[row].append(ax)

        # The sidelobe level on the fine grid near 0 and the wide one away.
        merged_v = np.concatenate((wide, zoom))
        order = np.argsort(merged_v, kind="stable")
        merged_cut = np.concatenate((cuts[""], cuts[", zoom"]))[order]
        psl, psl_v = ambiguity.peak_sidelobe(merged_v[order], merged_cut)
        width = af.doppler_width()
        sidelobe = ("{:11.1f} dB {:7.2f}".format(psl, psl_v)
                    if np.isfinite(psl) else f"{'none':>14} {'':>7}")
        print(f"{title:<22} {width:9.3f} m/s {sidelobe} "
              f"{af.cut_db(1.0):8.1f} dB {af.cut_db(args.v_max):8.1f} dB")

        line = cut_axes[0].plot(wide, to_db(cuts[""], args.dynamic_range),
                                label=f"{title} (-3 dB: {width:.2f} m/s)")
        if cut_axes[1] is not None:
            cut_axes[1].plot(zoom, to_db(cuts[", zoom"], args.dynamic_range),
                             color=line[0].get_color())

    for axes in image_axes:
        fig.colorbar(mesh, ax=axes, label="dB re matched peak", shrink=0.9)
    cut_axes[0].set_title("(d) velocity sensitivity: peak over lag")
    cut_axes[0].legend(loc="lower right", fontsize="small")
    for ax in cut_axes:
        if ax is None:
            continue
        ax.axhline(-3.0, color="grey", linewidth=0.8, linestyle=":")
        ax.set_xlabel("radial velocity (m/s)")
        ax.set_ylabel("dB re matched peak")
        ax.set_ylim(-args.dynamic_range, 2.0)
        ax.grid(alpha=0.3)
    if cut_axes[1] is not None:
        cut_axes[1].set_title("(d) zoom")

    out = pathlib.Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
