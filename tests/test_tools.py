#!/usr/bin/python3
"""Tests of the command-line tools: the README's demo (tools/demo, its
bus-message printer tools/print-messages.py, which runs the pipeline and reads
the messages from the bus), sonar-waveforms, the ambiguity function
(tools/ambiguity.py, tools/plot-ambiguity.py), the energyscape reader and
plotter (tools/energyscape.py, tools/plot-energyscape.py), the tracks
plotter (tools/plot-tracks.py) and the benchmark (sonar-bench,
tools/plot-bench.py).

Run as SONAR_BUILD_DIR=build SONAR_SOURCE_DIR=. /usr/bin/python3
tests/test_tools.py; prints TAP and exits non-zero when a test fails.
"""

import csv
import importlib.util
import json
import math
import os
import pathlib
import re
import subprocess
import sys

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from taptest import (BUILD_DIR, SANITIZED, SECOND_COMPILER,  # noqa: E402
                     SOURCE_DIR, Skip, run_all, scratch, test)
TOOLS = SOURCE_DIR / "tools"
PROGRAM = BUILD_DIR / "tools" / "sonar-waveforms"
BENCH = BUILD_DIR / "tools" / "sonar-bench"
PYTHON = "/usr/bin/python3"
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"

sys.path.insert(0, str(TOOLS))
import ambiguity  # noqa: E402
import energyscape  # noqa: E402


def load_script(name):
    """Import a tools/*.py script whose name is not a module name."""
    spec = importlib.util.spec_from_file_location(
        name.replace("-", "_"), TOOLS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


plot_energyscape = load_script("plot-energyscape")

TMP = scratch("sonar-test-tools-")



def run(*args, check=True):
    """Run a command, capturing text output."""
    result = subprocess.run([str(a) for a in args], capture_output=True,
                            text=True, timeout=60)
    if check and result.returncode != 0:
        raise AssertionError(f"{args} exited {result.returncode}: "
                             f"{result.stderr.strip()}")
    return result


def assert_png(path):
    """The file exists, is a PNG and is not empty."""
    data = pathlib.Path(path).read_bytes()
    assert data.startswith(PNG_SIGNATURE), f"{path} is not a PNG"
    assert len(data) > 10000, f"{path} is only {len(data)} bytes"


# sonar-waveforms ---------------------------------------------------------

DEFAULT_JSON = {}


def default_output():
    """Standard output of sonar-waveforms without options (run once)."""
    if not DEFAULT_JSON:
        DEFAULT_JSON["text"] = run(PROGRAM).stdout
    return DEFAULT_JSON["text"]


@test
def waveforms_default_file():
    """sonar-waveforms: default file is 8 x 4000 at 450 kHz, 20-80 kHz,
    finite, unit peak"""
    doc = json.loads(default_output())
    assert set(doc) == {"description", "sample-rate", "band", "waveforms"}, \
        doc.keys()
    assert doc["sample-rate"] == 450000, doc["sample-rate"]
    assert doc["band"] == [20000, 80000], doc["band"]
    rows = np.array(doc["waveforms"], dtype=np.float64)
    assert rows.shape == (8, 4000), rows.shape
    assert np.all(np.isfinite(rows))
    peaks = np.abs(rows).max(axis=1)
    assert np.allclose(peaks, 1.0, atol=1e-6), peaks


@test
def waveforms_reproducible():
    """sonar-waveforms: two runs are identical, -o writes the same bytes"""
    assert run(PROGRAM).stdout == default_output()
    out = TMP / "default.json"
    run(PROGRAM, "-o", out)
    assert out.read_text() == default_output()


@test
def waveforms_file_same_as_sonarsrc():
    """sonar-waveforms: sonarsrc with the default file records the same
    samples as sonarsrc with its built-in waveforms"""
    out = TMP / "default.json"
    run(PROGRAM, "-o", out)
    env = dict(os.environ, GST_PLUGIN_PATH_1_0=str(BUILD_DIR / "elements"),
               GST_REGISTRY_1_0=str(TMP / "registry.bin"))
    recordings = []
    for extra in ([], [f"waveforms-file={out}"]):
        raw = TMP / f"ping{len(recordings)}.raw"
        result = subprocess.run(
            ["gst-launch-1.0", "-q", "sonarsrc", "num-buffers=1", *extra,
             "!", "filesink", f"location={raw}"],
            env=env, capture_output=True, text=True, timeout=60)
        assert result.returncode == 0, result.stderr
        recordings.append(raw.read_bytes())
    assert len(recordings[0]) > 0
    # Bit for bit: 9 significant digits carry every float32 exactly.
    assert recordings[0] == recordings[1]


@test
def waveforms_seed_changes_output():
    """sonar-waveforms: --seed 2 (or -s 2) gives other waveforms"""
    a = np.array(json.loads(default_output())["waveforms"])
    seed2 = run(PROGRAM, "--seed", "2").stdout
    b = np.array(json.loads(seed2)["waveforms"])
    assert a.shape == b.shape
    assert np.abs(a - b).max() > 0.1
    assert run(PROGRAM, "-s", "2").stdout == seed2


@test
def waveforms_options_respected():
    """sonar-waveforms: --kind, --emitters, --length are applied"""
    doc = json.loads(run(PROGRAM, "--kind", "multisine", "--emitters", "3",
                         "--length", "2000").stdout)
    assert "multisine" in doc["description"]
    assert np.array(doc["waveforms"]).shape == (3, 2000)


@test
def waveforms_band_above_nyquist_refused():
    """sonar-waveforms: --band-high 300000 exits 1 naming band_high"""
    result = run(PROGRAM, "--band-high", "300000", check=False)
    assert result.returncode == 1, result.returncode
    assert "band_high" in result.stderr, result.stderr
    assert result.stdout == ""


@test
def waveforms_unknown_kind_refused():
    """sonar-waveforms: unknown --kind exits 1 naming the kind"""
    result = run(PROGRAM, "--kind", "sawtooth", check=False)
    assert result.returncode == 1, result.returncode
    assert "sawtooth" in result.stderr, result.stderr
    assert "noise, hyperbolic-chirp, multisine" in result.stderr, \
        result.stderr


@test
def waveforms_list_kinds():
    """sonar-waveforms: --list-kinds names every kind, each one generates"""
    kinds = ambiguity.kinds(PROGRAM)
    assert [k for k, _ in kinds] == ["noise", "hyperbolic-chirp",
                                     "multisine"], kinds
    for kind, description in kinds:
        assert description, kind
        doc = json.loads(run(PROGRAM, "--kind", kind, "--emitters", "2",
                             "--length", "500").stdout)
        assert doc["description"].startswith(kind), doc["description"]


@test
def waveforms_bad_number_refused():
    """sonar-waveforms: --emitters -1 exits 1 naming the option"""
    result = run(PROGRAM, "--emitters", "-1", check=False)
    assert result.returncode == 1, result.returncode
    assert "--emitters" in result.stderr, result.stderr


# Ambiguity function ------------------------------------------------------


def default_noise():
    """Emitter 0 of the default waveforms (what sonarsrc emits)."""
    return np.array(json.loads(default_output())["waveforms"][0])


@test
def time_scale_is_band_limited_interpolation():
    """ambiguity: time_scale reproduces x at alpha 1 and matches a direct
    DFT sum at alpha 0.99"""
    x = default_noise()
    assert np.abs(ambiguity.time_scale(x, 1.0) - x).max() < 1e-9
    alpha = 0.99
    y = ambiguity.time_scale(x, alpha)
    assert len(y) == math.ceil(len(x) / alpha)
    # Independent evaluation of the same band-limited signal.
    m = 2 * len(x)
    spectrum = np.fft.rfft(x, m)
    weights = np.full(len(spectrum), 2.0)
    weights[0] = 1.0
    weights[-1] = 0.0
    n = np.arange(0, len(y), 37)
    k = np.arange(len(spectrum))
    direct = (np.exp(2j * np.pi * np.outer(alpha * n, k) / m)
              @ (spectrum * weights)).real / m
    assert np.abs(direct - y[n]).max() < 1e-7


@test
def noise_doppler_width():
    """ambiguity: PR-AWGN -3 dB Doppler width is 0.2-0.5 m/s"""
    width = ambiguity.AmbiguityFunction(default_noise()).doppler_width()
    print(f"# PR-AWGN -3 dB Doppler width {width:.3f} m/s")
    assert 0.2 <= width <= 0.5, width


@test
def chirp_doppler_tolerant():
    """ambiguity: chirp -3 dB Doppler width is at least 5x the noise's"""
    noise = ambiguity.AmbiguityFunction(default_noise()).doppler_width()
    _, rows = ambiguity.generate_waveforms(PROGRAM, "hyperbolic-chirp")
    chirp = ambiguity.AmbiguityFunction(rows[0]).doppler_width()
    print(f"# chirp -3 dB Doppler width {chirp:.1f} m/s")
    assert chirp >= 5 * noise, (chirp, noise)


@test
def noise_doppler_sidelobes():
    """ambiguity: PR-AWGN Doppler cut has its main lobe at 0 and sidelobes
    below -10 dB"""
    velocities = np.linspace(-2.0, 2.0, 81)
    _, _, cut = ambiguity.AmbiguityFunction(default_noise()).image(
        velocities, 10)
    assert np.argmax(cut) == 40 and abs(cut[40] - 1.0) < 1e-9, cut[40]
    level, where = ambiguity.peak_sidelobe(velocities, cut)
    print(f"# PR-AWGN peak Doppler sidelobe {level:.1f} dB at {where} m/s")
    assert level < -10.0, level


@test
def plot_ambiguity_writes_png():
    """plot-ambiguity.py: writes a PNG and the table"""
    out = TMP / "ambiguity.png"
    result = run(PYTHON, TOOLS / "plot-ambiguity.py", "--program", PROGRAM,
                 "--rows", "15", "-o", out)
    assert_png(out)
    assert "PR-AWGN" in result.stdout and "chirp" in result.stdout


# Energyscapes ------------------------------------------------------------


def synthetic_records():
    """A 2-D image with a blob at azimuth 20 deg, 1.5 m and a 3-D one."""
    az = -90.0 + np.arange(181)
    rng = 0.2 + 0.01 * np.arange(500)
    a, r = np.meshgrid(az, rng, indexing="ij")
    blob = np.exp(-((a - 20.0) / 3.0) ** 2 - ((r - 1.5) / 0.05) ** 2)
    flat = energyscape.Energyscape(
        ping_index=7, azimuth_first=-90.0, azimuth_step=1.0,
        elevation_first=0.0, elevation_step=0.0, range_first=0.2,
        range_step=0.01, velocity=math.nan, emitter=-1,
        data=(blob + 0.001).astype(np.float32)[None])
    gen = np.random.default_rng(3)
    cube = energyscape.Energyscape(
        ping_index=8, azimuth_first=-30.0, azimuth_step=2.0,
        elevation_first=-15.0, elevation_step=2.0, range_first=0.3,
        range_step=0.02, velocity=-0.25, emitter=3,
        data=gen.random((16, 31, 200), dtype=np.float32))
    return flat, cube


def write_synthetic():
    """Write the synthetic records; return (path, records)."""
    records = synthetic_records()
    path = TMP / "two.es"
    energyscape.write(path, records)
    return path, records


@test
def energyscape_round_trip():
    """energyscape.py: two records read back with exact values and axes"""
    path, (flat, cube) = write_synthetic()
    assert path.stat().st_size == 2 * 96 + 4 * (181 * 500 + 31 * 16 * 200)
    got = energyscape.read(path)
    assert len(got) == 2
    for want, have in zip((flat, cube), got):
        assert np.array_equal(want.data, have.data)
        for field in ("ping_index", "azimuth_step", "elevation_first",
                      "elevation_step", "range_first", "range_step",
                      "emitter"):
            assert getattr(want, field) == getattr(have, field), field
    assert math.isnan(got[0].velocity) and got[1].velocity == -0.25
    assert not got[0].is_3d and got[1].is_3d
    assert got[1].data.shape == (16, 31, 200)
    assert got[0].azimuth[0] == -90.0 and got[0].azimuth[-1] == 90.0
    assert got[1].elevation[-1] == 15.0
    assert abs(got[1].range[-1] - (0.3 + 0.02 * 199)) < 1e-12
    az, el, rng = got[0].peak()
    assert az == 20.0 and el == 0.0 and abs(rng - 1.5) < 1e-9


def expect_error(data, words):
    """Parsing data fails with an EnergyscapeError mentioning words."""
    try:
        energyscape.parse(data, "test")
    except energyscape.EnergyscapeError as e:
        assert all(w in str(e) for w in words), str(e)
        return
    raise AssertionError(f"no error mentioning {words}")


@test
def energyscape_truncated():
    """energyscape.py: truncated files are refused as truncated"""
    path, _ = write_synthetic()
    data = path.read_bytes()
    expect_error(data[:-4], ["truncated", "record 1"])
    expect_error(data[:96 + 4 * 181 * 500 + 50], ["truncated", "header"])


@test
def energyscape_bad_magic():
    """energyscape.py: a bad magic is refused"""
    path, _ = write_synthetic()
    expect_error(b"SONARES2" + path.read_bytes()[8:], ["magic", "record 0"])


@test
def plot_energyscape_writes_pngs():
    """plot-energyscape.py: PNGs for the 2-D and 3-D records, with
    overlays"""
    path, _ = write_synthetic()
    truth = TMP / "truth.json"
    truth.write_text(json.dumps([{"range": 1.5, "azimuth": 20.0,
                                  "elevation": 0.0}]))
    detections = TMP / "detections.jsonl"
    detections.write_text("\n".join(json.dumps(line) for line in (
        {"ping": 7, "detections": [{"range": 1.5, "azimuth": 20.0,
                                    "elevation": 0.0,
                                    "radial_velocity": -0.8}]},
        {"ping": 8, "detections": [{"range": 1.0, "azimuth": -10.0,
                                    "elevation": 4.0,
                                    "radial_velocity": 0.3}]})) + "\n")
    out = TMP / "es.png"
    run(PYTHON, TOOLS / "plot-energyscape.py", path, "--all", "-o", out,
        "--truth", truth, "--detections", detections)
    assert_png(TMP / "es-0000.png")
    assert_png(TMP / "es-0001.png")
    assert [d["radial_velocity"] for d in
            plot_energyscape.load_detections(detections, 8)] == [0.3]


@test
def plot_energyscape_fan_orientation():
    """plot-energyscape.py: the 2-D image's maximum is drawn right of
    boresight at azimuth 20 deg, 1.5 m"""
    flat, _ = synthetic_records()
    x, y = plot_energyscape.fan_peak_xy(flat)
    assert x > 0, x
    assert abs(x - 1.5 * math.sin(math.radians(20))) < 1e-6, x
    assert abs(y - 1.5 * math.cos(math.radians(20))) < 1e-6, y


@test
def plot_energyscape_bad_record():
    """plot-energyscape.py: --record out of range exits non-zero"""
    path, _ = write_synthetic()
    result = run(PYTHON, TOOLS / "plot-energyscape.py", path, "--record",
                 "2", "-o", TMP / "none.png", check=False)
    assert result.returncode != 0 and "--record 2" in result.stderr, \
        result.stderr


# sonar-bench -------------------------------------------------------------

@test
def bench_emitters_sweep():
    """sonar-bench: --sweep emitters on one fig10 ping writes 5 scored rows
    with memory, and plot-bench.py draws them"""
    path = TMP / "bench.csv"
    result = run(BENCH, "--sweep", "emitters", "--fig10-pings", "1",
                 "--timed-pings", "3", "--csv", path)
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["sweep"] for r in rows] == ["emitters"] * 5, rows
    assert [r["value"] for r in rows] == ["8", "6", "4", "2", "1"], rows
    for r in rows:
        found, total, fp = (int(r[k]) for k in
                            ("found", "total", "false_positives"))
        assert total == 6 and 0 <= found <= total and fp >= 0, r
        bank, chain, rss = (float(r[k]) for k in
                            ("mb_bank", "mb_chain", "peak_rss_mb"))
        # Under AddressSanitizer (meson test --setup asan) the heap is its
        # allocator's, which glibc's mallinfo2 does not see: 0 MB.
        if not SANITIZED:
            assert 0 < bank < chain < rss, r
        assert float(r["template_error_db"]) < -100, r
        assert int(r["bank_velocities"]) == 41, r
        # One rendered ping timed three times, scored once.
        assert r["pings"] == "1" and r["timed_pings"] == "3", r
        assert (float(r["ms_total_p10"]) <= float(r["ms_total"])
                <= float(r["ms_total_p90"])), r
    # All eight emitters: every Fig. 10 object, no false positive.
    assert rows[0]["found"] == "6" and rows[0]["false_positives"] == "0", \
        rows[0]
    # The three tables (times, memory, arithmetic floors) print a row per
    # value.
    lines = result.stdout.splitlines()
    for value in ("8", "6", "4", "2", "1"):
        assert sum(line.split()[:2] == [value, "fig10"]
                   for line in lines) == 3, (value, result.stdout)
    for r in rows:
        # Every stage has a floor, of the stage's order of magnitude (the
        # flop counts are the method's, the peak this CPU's).
        for stage in ("spectra", "imaging", "clustering", "velocity"):
            floor = float(r["floor_ms_" + stage])
            assert 0 < floor < 1e3 * float(r["ms_" + stage]), (stage, r)
        # The tracking stage (sonartrack's core) is timed, part of the
        # chain, and has no floor.
        assert 0 < float(r["ms_tracking"]) < float(r["ms_total"]), r
        assert float(r["floor_ms_tracking"]) == 0, r
    png = TMP / "bench.png"
    run(PYTHON, TOOLS / "plot-bench.py", path, "-o", png)
    assert_png(png)


@test
def bench_hemisphere_grid():
    """sonar-bench --sweep hemisphere-grid: the 3-D hemisphere at 2, 3 and
    4 degrees on one fig10 ping finds its 6 objects with every grid, the
    velocities within 1 cm/s, and the coarser grids make fewer passes (the
    share of the dense image's passes times the directions); plot-bench.py
    draws them as 3-D rows"""
    path = TMP / "hemisphere-grid.csv"
    run(BENCH, "--sweep", "hemisphere-grid", "--timed-pings", "1",
        "--csv", path)
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["value"] for r in rows] == ["2", "3", "4"], rows
    passes = []
    for r in rows:
        assert r["found"] == r["total"] == "6", r
        assert r["false_positives"] == "0", r
        assert float(r["max_error"]) < 0.01, r
        side = 180 // int(r["value"]) + 1
        passes.append(float(r["imaging_work"]) * side * side)
    assert passes[0] > passes[1] > passes[2], passes
    # plot-bench.py sets them beside the other 3-D rows, not the 2-D fig10.
    rows, _ = load_script("plot-bench").load_rows(path)
    assert [r["scene"] for r in rows] == ["fig10 3-D"] * 3, rows


@test
def bench_near_far():
    """sonar-bench --sweep near-far: a point 10-60 dB above a normal one,
    beyond and within the near echo's pulse, one ping per level: the
    normal one found beyond the pulse up to 50 dB; within it up to 40 dB
    (under the near echo's cross-talk: velocityest's residual search
    finds it on the ping less the near echo, cancelled deep enough since
    its model's own direction and microphone gains: 20 dB before) and
    lost at 60 dB; no false object; CSV rows a table plot-bench.py reads
    beside the others"""
    path = TMP / "near-far.csv"
    result = run(BENCH, "--sweep", "near-far", "--near-far-pings", "1",
                 "--csv", path)
    with open(path, newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["sweep"] == "near-far"]
    levels = ("10", "15", "20", "30", "40", "50", "60")
    assert [r["value"] for r in rows] == \
        [f"{where} {d} dB" for where in ("beyond", "within")
         for d in levels], rows
    for r in rows:
        assert r["pings"] == "1" and r["total"] == "1", r
        assert r["false_positives"] == "0", r
    found = {r["value"]: r["found"] for r in rows}
    for d in ("10", "20", "30", "40", "50"):
        assert found[f"beyond {d} dB"] == "1", rows
    for d in ("10", "15", "20", "30", "40"):
        assert found[f"within {d} dB"] == "1", rows
    assert found["within 60 dB"] == "0", rows
    assert "dynamic range beyond the pulse: " in result.stdout, \
        result.stdout
    plot_bench = load_script("plot-bench")
    _, sensitivity = plot_bench.load_rows(path)
    assert len(sensitivity["near-far"]) == 14, sensitivity


@test
def bench_scalloping():
    """sonar-bench --sweep scalloping: a noise-free point halfway between
    coarse directions loses more the farther apart they are, more in 3-D
    (a cell's centre) than in 2-D, less off to the side (a degree is a
    smaller step there); about 5 dB at the 2-D default's 3 degrees, under
    1 dB at 1 degree, over 15 dB at the 3-D default's 6 degrees"""
    result = run(BENCH, "--sweep", "scalloping")
    lines = result.stdout.splitlines()
    start = next(i for i, line in enumerate(lines)
                 if line.split()[:2] == ["S", "deg"])
    table = {}
    for line in lines[start + 1:]:
        fields = line.split()
        if len(fields) != 5:
            break
        table[float(fields[0])] = [float(x) for x in fields[1:]]
    assert sorted(table) == [1, 2, 3, 4, 6, 8], result.stdout
    spacings = sorted(table)
    for column in range(4):
        losses = [table[s][column] for s in spacings]
        assert all(a > b for a, b in zip(losses, losses[1:])), losses
    for s in spacings:
        flat_on, flat_off, cell_on, cell_off = table[s]
        assert cell_on < flat_on <= 0 and flat_on < flat_off, table[s]
        assert cell_on < cell_off, table[s]
    assert table[1][0] > -1.0 and table[1][2] > -1.5, table[1]
    assert -7.0 < table[3][0] < -3.5, table[3]
    assert table[6][2] < -15.0, table[6]


@test
def plot_bench_sensitivity():
    """plot-bench.py: the detection and split sweeps' rows (as sonar-bench
    writes them, timing columns empty) give a Pd-against-SNR figure and a
    split-rate map beside the output, read back from the values"""
    path = TMP / "sensitivity.csv"
    listed = run(BENCH, "--help").stdout
    assert "  split  " in listed, listed
    columns = ("sweep,value,scene,pings,found,total,false_positives,"
               "mean_error,max_error").split(",")
    rows = [["detection", f"{snr} dB {r} m", "point", 10,
             min(10, max(0, snr + 35 + r)), 10, 0, 0.01, 0.02]
            for snr in (-35, -30, -25) for r in (2, 5, 8)]
    rows += [["split", f"{sep} cm {dv} m/s", "pair", 4, 4 if dv > 0.5 else
              2, 4, 0, 0.005, 0.01] for sep in (0.5, 1.5) for dv in
             (0.4, 1.5, 5)]
    rows += [["split", "single", "point", 35, 35, 35, 0, 0.001, 0.003],
             ["noise", "false-objects", "empty", 1000, 0, 0, 0, "nan",
              "nan"]]
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(columns + ["ms_spectra"])
        for row in rows:
            writer.writerow(row + [""])
    plot_bench = load_script("plot-bench")
    _, sensitivity = plot_bench.load_rows(path)
    curves = plot_bench.detection_curves(sensitivity["detection"])
    assert sorted(curves) == [2.0, 5.0, 8.0], curves
    assert curves[2.0] == [(-35.0, 0.2, 10), (-30.0, 0.7, 10),
                           (-25.0, 1.0, 10)], curves[2.0]
    separations, differences, shares = plot_bench.split_grid(
        sensitivity["split"])
    assert separations == [0.5, 1.5] and differences == [0.4, 1.5, 5.0]
    assert shares == [[0.5, 1.0, 1.0], [0.5, 1.0, 1.0]], shares
    out = TMP / "sensitivity.png"
    result = run(PYTHON, TOOLS / "plot-bench.py", path, "-o", out)
    assert_png(TMP / "sensitivity-detection.png")
    assert_png(TMP / "sensitivity-split.png")
    assert not out.exists(), "no configuration rows: no Pareto figure"
    assert "sensitivity-split.png" in result.stdout, result.stdout


@test
def bench_refuses_other_csv():
    """sonar-bench: a CSV of other columns is refused, not appended to"""
    path = TMP / "old-bench.csv"
    path.write_text("sweep,value,scene\nlinkage,ward,fig10\n")
    result = run(BENCH, "--sweep", "emitters", "--csv", path, check=False)
    assert result.returncode == 1, result
    assert "not this sonar-bench's" in result.stderr, result.stderr
    assert path.read_text() == "sweep,value,scene\nlinkage,ward,fig10\n"


# Tracks ---------------------------------------------------------------------


def tracks_line(ping, time, ego, z):
    """A sonartrack line with one still track at (0.5, 0, z)."""
    return {"ping": ping, "time": time,
            "ego_status": "observed" if ego else "unobservable",
            "ego_velocity": ego, "ego_covariance":
            [[1e-6, 0, 0], [0, 0, 0], [0, 0, 1e-6]] if ego else None,
            "tracks": [{"id": 1, "state": "confirmed", "moving": False,
                        "x": 0.5, "y": 0.0, "z": z,
                        "velocity": [0.0, 0.0, 0.0]}]}


@test
def plot_tracks_writes_png():
    """plot-tracks.py: the sensor's path from the ego velocities (kept
    through an unobservable ping), a PNG in either frame; other JSON
    refused"""
    plot_tracks = load_script("plot-tracks")
    lines = [tracks_line(0, 0.0, [0.0, 0.0, 0.5], 3.0),
             tracks_line(1, 1.0, None, 2.5),
             tracks_line(2, 2.0, [0.0, 0.0, 0.5], 2.0)]
    assert plot_tracks.sensor_path(lines) == [(0.0, 0.0), (0.0, 0.5),
                                              (0.0, 1.0)]
    path = TMP / "tracks.jsonl"
    path.write_text("".join(json.dumps(line) + "\n" for line in lines))
    for frame in ("sensor", "world"):
        out = TMP / f"tracks-{frame}.png"
        result = run(PYTHON, TOOLS / "plot-tracks.py", path, "--frame",
                     frame, "-o", out)
        assert_png(out)
        assert "1 tracks over 3 pings" in result.stdout, result.stdout
    other = TMP / "detections-only.jsonl"
    other.write_text(json.dumps({"ping": 0, "detections": []}) + "\n")
    result = run(PYTHON, TOOLS / "plot-tracks.py", other, "-o",
                 TMP / "x.png", check=False)
    assert result.returncode != 0
    assert "sonartrack's output" in result.stderr, result.stderr


@test
def demo_prints_truth_and_errors():
    """tools/demo, the README's first command, on the default scene: every
    ping's ground truth and each detection matched to its true object
    (tools/print-messages.py reads them from the bus), within 5 mm
    and 0.01 m/s, and the picture drawn"""
    env = dict(os.environ, SONAR_BUILD_DIR=str(BUILD_DIR))
    result = subprocess.run([str(TOOLS / "demo")], capture_output=True,
                            text=True, timeout=120, env=env)
    assert result.returncode == 0, result.stderr
    out = result.stdout
    assert "ping 0: ground truth" in out and "ping 1: ground truth" in out
    matches = re.findall(r"id (\d+) at ([0-9.]+) m, ([+-][0-9.]+) m/s", out)
    # Two pings of the three objects, each found once.
    assert sorted(int(m[0]) for m in matches) == [0, 0, 1, 1, 2, 2], out
    for _, distance, error in matches:
        assert float(distance) <= 0.005 and abs(float(error)) <= 0.01, out
    assert_png(SOURCE_DIR / "out" / "default.png")


@test
def print_messages_reads_the_bus():
    """tools/print-messages.py runs a pipeline and reads sonarsrc's truth
    from the bus as structures: the --truth file holds each ping's
    reflectors (the default scene's three, the first still at 1.5 m,
    -30 degrees); an element's error is printed with its element and
    ends the run with status 1"""
    env = dict(os.environ, GST_PLUGIN_PATH_1_0=str(BUILD_DIR / "elements"))
    truth = TMP / "truth.jsonl"
    result = subprocess.run(
        [PYTHON, str(TOOLS / "print-messages.py"), "--truth", str(truth),
         "sonarsrc", "num-buffers=2", "!", "fakesink"],
        capture_output=True, text=True, timeout=60, env=env)
    assert result.returncode == 0, result.stderr
    pings = [json.loads(line) for line in truth.read_text().splitlines()]
    assert [p["ping"] for p in pings] == [0, 1], pings
    first = pings[0]["reflectors"][0]
    assert len(pings[0]["reflectors"]) == 3, pings
    assert abs(first["range"] - 1.5) < 1e-9, first
    assert abs(first["azimuth"] + 30.0) < 1e-9, first
    result = subprocess.run(
        [PYTHON, str(TOOLS / "print-messages.py"), "filesrc",
         f"location={TMP / 'missing.wav'}", "!", "fakesink"],
        capture_output=True, text=True, timeout=60, env=env)
    assert result.returncode == 1, result
    assert ("ERROR: from element /GstPipeline:pipeline0/GstFileSrc:filesrc0"
            ": Resource not found." in result.stderr), result.stderr


@test
def foreign_scenes_finds_faint_objects():
    """tools/foreign-scenes.py on two seeded 2-D scenes of
    tests/foreign_sim.py (6 objects over 30 dB each): the defaults find
    all 12 with no false object; without mimobeamform's noise gate
    (refine-pfa=0) and velocityest's residual search (which images the
    ping again with its own gate) two objects 20.6 and 21.6 dB below the
    strongest, between coarse directions, are lost, and --explain names
    them; the summary gives the velocity errors of the objects found"""
    env = dict(os.environ, SONAR_BUILD_DIR=str(BUILD_DIR))
    result = subprocess.run(
        [PYTHON, str(TOOLS / "foreign-scenes.py"), "--view", "fan",
         "--scenes", "2", "--seed", "3", "--compare",
         "refine-pfa=0 velocityest.residual-search=false", "--explain"],
        capture_output=True, text=True, timeout=120, env=env)
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert "  defaults                 found 12 of 12, 0 false" in lines, \
        result.stdout
    assert "  refine-pfa=0 velocityest.residual-search=false found 10 of 12, " \
        "0 false" in lines, result.stdout
    missed = [line.split(";")[0] for line in lines if " missed: " in line]
    assert missed == [
        "  refine-pfa=0 velocityest.residual-search=false missed: 4.020 m, "
        "az -52.1, el 0.0, -2.92 m/s, 20.6 dB below the strongest",
        "  refine-pfa=0 velocityest.residual-search=false missed: 2.851 m, "
        "az 36.1, el 0.0, -0.33 m/s, 21.6 dB below the strongest"], \
        result.stdout
    errors = [line for line in lines if "radial velocity error: mean" in line]
    assert len(errors) == 2, result.stdout
    worst = [float(line.split("worst ")[1].split()[0]) for line in errors]
    assert all(0.0 < w < 0.03 for w in worst), errors


@test
def foreign_scenes_times_the_chain():
    """tools/foreign-scenes.py --time: each run's wall and CPU time and
    the share of the dense image's passes mimobeamform imaged (read off
    its DEBUG line), per scene and as median (range) over the scenes"""
    env = dict(os.environ, SONAR_BUILD_DIR=str(BUILD_DIR))
    result = subprocess.run(
        [PYTHON, str(TOOLS / "foreign-scenes.py"), "--view", "fan",
         "--scenes", "1", "--seed", "3", "--time"],
        capture_output=True, text=True, timeout=120, env=env)
    assert result.returncode == 0, result.stderr
    row = re.search(r"^scene0: 6/6, 0 false, ([0-9.]+) s wall, ([0-9.]+) s "
                    r"CPU, ([0-9.]+) %$", result.stdout, re.MULTILINE)
    assert row, result.stdout
    wall, cpu, share = (float(x) for x in row.groups())
    assert wall > 0 and cpu > 0, result.stdout
    # A 2-D scene of 6 objects: the coarse pass and the units around the
    # echoes, a tenth of the dense image (10.1 % when written).
    assert 3 < share < 30, result.stdout
    assert re.search(r"a run: [0-9.]+ s \([0-9.]+-[0-9.]+\) wall, "
                     r"[0-9.]+ s \([0-9.]+-[0-9.]+\) CPU, %.1f %% "
                     r"\(%.1f-%.1f\) of the dense image's passes" % (
                         share, share, share), result.stdout), result.stdout


@test
def foreign_scenes_wide_array():
    """tools/foreign-scenes.py --array-scale 2.5,2: the eRTIS layout 2.5
    times as wide, whose main lobe (1.4 degrees) is under two of the
    fan's 1 degree steps: mimobeamform's coarse pass is its beam's, so
    the fan is imaged in full; a malformed scale is refused"""
    env = dict(os.environ, SONAR_BUILD_DIR=str(BUILD_DIR))
    result = subprocess.run(
        [PYTHON, str(TOOLS / "foreign-scenes.py"), "--view", "fan",
         "--scenes", "1", "--seed", "3", "--array-scale", "2.5,2",
         "--time"],
        capture_output=True, text=True, timeout=120, env=env)
    assert result.returncode == 0, result.stderr
    assert "seed 3, array scaled 2.5,2:" in result.stdout, result.stdout
    assert re.search(r"^scene0: 6/6, 0 false, [0-9.]+ s wall, [0-9.]+ s "
                     r"CPU, 100.0 %$", result.stdout, re.MULTILINE), \
        result.stdout
    result = subprocess.run(
        [PYTHON, str(TOOLS / "foreign-scenes.py"), "--array-scale", "2.5"],
        capture_output=True, text=True, timeout=120, env=env)
    assert result.returncode == 2 and "--array-scale 2.5: two factors, " \
        "MICS,EMITTERS" in result.stderr, result.stderr


@test
def direction_errors_3d():
    """tools/direction-errors-3d.py on 12 still points at random 3-D
    directions (seed 2, one ping): every one found, nothing else,
    azimuth and elevation within 0.1 degree rms and 0.3 at worst
    (velocityest's fit over 3 x 3 directions half a step apart: 0.07 and
    0.21 over 2 pings; the search's quarter steps reported before, 0.155
    and 0.47; parabolas along the image peak's row and column alone, 0.26
    and 0.61: the beam is tilted in azimuth and elevation)"""
    stdout, (rms_a, worst_a, rms_e, worst_e, _, _) = direction_errors(
        ["--seeds", "2", "--pings", "1"], 12, 0)
    assert rms_a < 0.1 and rms_e < 0.1, stdout
    assert worst_a < 0.3 and worst_e < 0.3, stdout


def direction_errors(arguments, found, extra):
    """tools/direction-errors-3d.py run with @arguments (skipped under the
    sanitizers and in the second compiler's run: the accuracy, a property
    of the method, is the plain run's to check), whose
    closing line must report @found points found and @extra other
    detections: its output, and the azimuth's, elevation's and the array
    plane's rms and worst errors."""
    if SANITIZED or SECOND_COMPILER:
        raise Skip("the accuracy of a 3-D chain, the plain run's to check")
    env = dict(os.environ, SONAR_BUILD_DIR=str(BUILD_DIR))
    result = subprocess.run(
        [PYTHON, str(TOOLS / "direction-errors-3d.py"), *arguments],
        capture_output=True, text=True, timeout=300, env=env)
    assert result.returncode == 0, result.stderr
    stdout = result.stdout
    row = re.search(r"^all: %d of %d found, %d other detections; azimuth "
                    r"rms ([0-9.]+), worst ([0-9.]+) deg; elevation rms "
                    r"([0-9.]+), worst ([0-9.]+) deg; in the array's plane "
                    r"rms ([0-9.]+), worst ([0-9.]+)$" % (found, found, extra),
                    stdout, re.MULTILINE)
    assert row, stdout
    return stdout, [float(x) for x in row.groups()]


@test
def direction_errors_near_the_rim():
    """tools/direction-errors-3d.py --off-boresight 70 88 (seed 2, 10
    points, one ping): near the hemisphere's rim every point is found,
    once (two centroids on one point's beam ridge made two detections
    2.85 mm apart in range, a step and a little more: one echo's are now
    those within the band's range resolution c / 2B), and in the array's
    plane, which is what a planar array measures, the
    errors are as small as at boresight (0.0013 rms, 0.0023 at worst;
    0.0012 and 0.0024 in the default box). There a degree of azimuth
    moves the beam little and one of elevation sweeps it sideways:
    velocityest's direction fit in azimuth and elevation stayed on the
    grid row beside the peak, 0.0030 rms and 0.0081 at worst (azimuth
    12.6 degrees off); it fits the direction cosines now. Azimuth and
    elevation are not asserted: near the rim a small error in the plane is
    a large one in them (6 degrees of azimuth at worst)."""
    stdout, (*_, rms_plane, worst_plane) = direction_errors(
        ["--seeds", "2", "--points", "10", "--pings", "1",
         "--off-boresight", "70", "88"], 10, 0)
    assert rms_plane < 0.002 and worst_plane < 0.004, stdout


def sigma_ratios(noise, pings, points, fields, min_pings):
    """tools/uncertainty-3d.py's run of @points at @noise over @pings
    pings: per field of @fields, the ratio of reported sigma to measured
    scatter, pooled over the points found in at least @min_pings pings
    (each asserted within the issue's 30 %). Skipped under the
    sanitizers and in the second compiler's run: the calibration, a
    statistical property of the method, is the plain run's to check."""
    if SANITIZED or SECOND_COMPILER:
        raise Skip(f"a 3-D chain of {pings} pings, calibration checked by "
                   "the plain run")
    tool = load_script("uncertainty-3d")
    os.environ.setdefault("SONAR_BUILD_DIR", str(BUILD_DIR))
    per_point = tool.run(noise, pings, TMP, points=points(tool),
                         by_range=True)
    per_point = [p for p in per_point if len(p) >= min_pings]
    for field in fields:
        ratio, dof = tool.ratio(per_point, field)
        print(f"# {field}: reported / measured {ratio:.2f} ({dof} dof)")
        assert 0.7 <= ratio <= 1.3, (field, ratio, dof)
    return per_point


@test
def uncertainty_3d_matches_scatter():
    """tools/uncertainty-3d.py's random points (seed 1: 12 still points at
    0.8-4.7 m, 10 noisy pings, noise-amplitude 0.5): the range, azimuth,
    elevation and radial velocity sigmas each detection reports match the
    scatter of its estimates within 30 %, pooled over the points found
    in at least 8 pings (the issue's bound; seed 1 reads 0.82-1.06, three
    seeds over 24 pings 0.87-1.07)"""
    per_point = sigma_ratios(0.5, 10, lambda tool: tool.random_points(1),
                             ("range", "azimuth", "elevation",
                              "radial_velocity"), 8)
    assert len(per_point) >= 8, [len(p) for p in per_point]


@test
def uncertainty_3d_cluster_of_one_echo():
    """Strong 3-D echoes in loud noise (seed 1's three nearest points,
    0.8-1.5 m, at noise-amplitude 1.2: 25-31 dB): noise peaks on their
    range sidelobes and beam join their clusters (2-4 members a ping at
    0.8 m) and pull the cluster's weighted mean over, so the detection
    reports its strongest peak's own range and velocityest's fit of the
    direction, whose sigmas match their scatter within 30 % (the weighted
    mean range, and the window's whole-step lag where the members spread
    beyond it, scattered three times their sigma; the search's quarter
    steps in direction twice to three times)"""
    per_point = sigma_ratios(1.2, 12, lambda tool: tool.random_points(1)[:3],
                             ("range", "azimuth", "elevation"), 12)
    assert len(per_point) == 3, "found in fewer than their 12 pings"


if __name__ == "__main__":
    sys.exit(run_all())
