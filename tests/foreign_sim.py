#!/usr/bin/python3
"""Foreign recordings: an independent simulator of the paper's MIMO sonar.

Writes recordings the way another lab's tools would, to test that the
project's processing chain works on recordings it did not make. Nothing here
comes from the project's own simulator or waveform generator: the physics is
written from scratch with numpy and scipy.

The sonar: N emitters send simultaneous band-passed (20-80 kHz)
pseudo-random Gaussian noise waveforms; J microphones record the echoes of
point reflectors moving in straight lines at constant velocity. Sensor frame:
array in the x-y plane, boresight +z, x right, y up, origin at the array
centre; metres, seconds, m/s; azimuth from +z towards +x, elevation towards
+y, degrees; radial velocity = d(range)/dt, positive moving away.

Physics (exact two-leg propagation, still sensor, still air): emitter n emits
w_n(t - t_k - d_n) for ping k (trigger instant t_k, emitter delay d_n). The
sample of microphone j at instant t holds, for every reflector p(t) = p0 + v t
and emitter n, w_n evaluated at the emission instant t_e found from

    t - t_r = |p(t_r) - m_j| / c      (reflection instant t_r, fixed point)
    t_e = t_r - |p(t_r) - e_n| / c

times strength / (|p(t_r) - e_n| + |p(t_r) - m_j|)^2 (the paper's eq. 6).
This carries the exact wideband Doppler time-scaling. w_n is read between
its samples by 8x FFT upsampling and a cubic spline (error -120 dB for an
80 kHz tone, against -60 dB needed), zero outside the waveform.

Files written into a folder, for a name NAME (default "recording"):
  NAME.wav            the recording, one channel per microphone: plain IEEE
                      float (format tag 3) or 16-bit PCM (format tag 1)
  NAME.emissions.wav  the emissions, one float32 channel per emitter, sample 0
                      the waveform's start
  NAME.sensor.json    the sensor description (the project's contract)
  NAME.truth.json     range, direction, radial velocity and position of every
                      reflector at every ping, at the instant `t` a wave
                      leaving the array centre at the ping's trigger reaches it
  NAME.geometry.json  only on request: the older geometry format

Use: simulate(spec, folder) from Python, or the command line:
    /usr/bin/python3 tests/foreign_sim.py OUT_DIR --reflector 0.5,0,2,0,0,-1
    /usr/bin/python3 tests/foreign_sim.py --self-check
(--help lists the options; SPEC_KEYS below documents each.)
"""

import argparse
import json
import math
import pathlib
import sys
import tempfile
import time

import numpy as np
import scipy.interpolate
import scipy.io.wavfile

ERTIS_FILE = (pathlib.Path(__file__).resolve().parent.parent / "data" /
              "ertis-microphones.json")
UPSAMPLING = 8
INT16_SCALE = 32768.0

SPEC_KEYS = {
    "name": ("recording", "stem of the file names"),
    "description": (None, "text of the sensor description (default: a "
                    "summary of the set-up)"),
    "sample_rate": (450000, "Hz, an integer"),
    "speed_of_sound": (343.0, "m/s"),
    "microphones": ("ertis", "'ertis' (the 32-microphone eRTIS layout), "
                    "'random16' (16 at random, seeded, in a disc of 10 cm "
                    "diameter, at least 8 mm apart) or a list of [x, y, z]"),
    "emitters": (None, "None: 8 on an ellipse of semi-axes 55 mm (x) and "
                 "40 mm (y) at 15, 60, 110, 150, 200, 245, 290, 335 degrees; "
                 "a count: evenly on a circle of radius 6 cm from 15 degrees; "
                 "or a list of [x, y, z]"),
    "waveform_length": (4000, "samples per emission"),
    "band": ((20000.0, 80000.0), "Hz, the emissions' pass band"),
    "emitter_delays": (None, "s per emitter, emitter n starts at trigger + "
                       "delay (default zeros)"),
    "trigger_offset": (0.0, "s, ping 0's trigger from the first sample"),
    "ping_period": (1.0 / 12.0, "s between pings"),
    "n_pings": (1, "pings recorded"),
    "window": (None, "ping-length: samples of one ping's processing "
               "(default: the period, rounded)"),
    "tail": (0, "samples recorded after the last ping's window (a partial "
             "ping)"),
    "reflectors": ((), "list of {position, velocity (default 0), strength "
                   "(default 1)}, position at t = 0 s (the first sample)"),
    "noise_rms": (0.03, "rms of the white Gaussian noise per sample (the "
                  "emissions have unit rms)"),
    "air_absorption": (False, "ISO 9613-1 absorption of air (20 C, relative "
                       "humidity 50 percent) along each echo's two-way path "
                       "(its range at t = 0), applied to the echo's "
                       "spectrum"),
    "emitter_resonance": (None, "[f0_min, f0_max, q_min, q_max]: each "
                          "emitter radiates its waveform through a resonance "
                          "(2nd-order band-pass, centre and Q drawn per "
                          "emitter) that the emissions file does not hold; "
                          "None: as written"),
    "microphone_mismatch": (None, "[gain_db, phase_deg]: each microphone's "
                            "gain and phase off by up to that (drawn per "
                            "microphone), as an uncalibrated array; None: "
                            "none"),
    "direct_path": (0.0, "coupling of the emitters to the microphones "
                    "through the air: each microphone also hears each "
                    "emission straight, direct_path / d^2 times it, d the "
                    "emitter-microphone distance (eq. 6 with one leg): 0.1 "
                    "puts it 33-71 dB (median 44) over a unit reflector's "
                    "echo at 1 m on the default set-up; 0: none"),
    "seed": (1, "seeds the waveforms, the noise and the random16 layout"),
    "sample_format": ("float32", "'float32' or 'int16'"),
    "full_scale": (None, "int16: the value of sample -32768 (default: 1.25 x "
                   "the recording's peak, 2 significant digits)"),
    "field_of_view": (None, "'fan', 'hemisphere' or None (not written)"),
    "inline_waveforms": (False, "write the waveforms into the description "
                         "instead of naming the emissions WAV"),
    "geometry_file": (False, "also write NAME.geometry.json"),
}

# Emitter layout of the default set-up: angles from +x towards +y.
ELLIPSE_ANGLES = (15, 60, 110, 150, 200, 245, 290, 335)
ELLIPSE_AXES = (0.055, 0.040)
CIRCLE_RADIUS = 0.06
RANDOM16_RADIUS = 0.05
RANDOM16_SPACING = 0.008


# Geometry ----------------------------------------------------------------

def ertis_microphones():
    """The 32 eRTIS microphone positions (m, sensor frame), channel order."""
    with open(ERTIS_FILE) as f:
        return np.array(json.load(f)["microphones"], dtype=np.float64)


def random_disc_microphones(rng, count=16, radius=RANDOM16_RADIUS,
                            spacing=RANDOM16_SPACING):
    """`count` points drawn uniformly in a disc of the x-y plane, rejecting
    any closer than `spacing` to one already drawn (dart throwing)."""
    points = []
    for _ in range(100000):
        r = radius * math.sqrt(rng.random())
        a = 2 * math.pi * rng.random()
        p = np.array([r * math.cos(a), r * math.sin(a), 0.0])
        if all(np.linalg.norm(p - q) >= spacing for q in points):
            points.append(p)
            if len(points) == count:
                return np.array(points)
    raise RuntimeError("random microphone layout: no room for "
                       f"{count} microphones")


def ellipse_emitters():
    """The default 8 emitters on an ellipse just outside the eRTIS array."""
    a = np.radians(ELLIPSE_ANGLES)
    return np.stack([ELLIPSE_AXES[0] * np.cos(a), ELLIPSE_AXES[1] * np.sin(a),
                     np.zeros_like(a)], axis=1)


def circle_emitters(count):
    """`count` emitters evenly on a circle of radius 6 cm from 15 degrees."""
    a = np.radians(15.0 + 360.0 * np.arange(count) / count)
    return np.stack([CIRCLE_RADIUS * np.cos(a), CIRCLE_RADIUS * np.sin(a),
                     np.zeros_like(a)], axis=1)


# Waveforms ---------------------------------------------------------------

def noise_waveforms(rng, count, length, sample_rate, band,
                    taper_seconds=100e-6):
    """Band-passed pseudo-random Gaussian noise, one row per emitter.

    White Gaussian noise with every DFT bin outside `band` zeroed, its ends
    tapered by half-Hann ramps of `taper_seconds` (so it starts and stops at
    zero), scaled to unit rms. Rounded to float32: those are the samples the
    emissions file carries and the simulation emits.
    """
    freqs = np.fft.rfftfreq(length, 1.0 / sample_rate)
    stop = (freqs < band[0]) | (freqs > band[1])
    ramp_len = max(2, round(taper_seconds * sample_rate))
    ramp = 0.5 - 0.5 * np.cos(np.pi * np.arange(ramp_len) / ramp_len)
    taper = np.ones(length)
    taper[:ramp_len] = ramp
    taper[-ramp_len:] = ramp[::-1]
    rows = []
    for _ in range(count):
        spectrum = np.fft.rfft(rng.standard_normal(length))
        spectrum[stop] = 0.0
        row = np.fft.irfft(spectrum, length) * taper
        rows.append(row / np.sqrt(np.mean(row ** 2)))
    return np.array(rows, dtype=np.float32)


class BandLimited:
    """A sampled signal read at any real sample position.

    The band-limited (sinc) reconstruction of the samples, zero-padded so the
    FFT's periodicity does not wrap the ends onto each other, is tabulated 8x
    finer by zero-padding its spectrum, and a cubic spline reads between the
    table's points. Zero before sample 0 and after the last sample.
    """

    PAD = 64

    def __init__(self, samples):
        samples = np.asarray(samples, dtype=np.float64)
        self.length = len(samples)
        padded = np.concatenate([np.zeros(self.PAD), samples,
                                 np.zeros(self.PAD)])
        n = len(padded)
        spectrum = np.fft.rfft(padded)
        if n % 2 == 0:
            spectrum[-1] *= 0.5  # the Nyquist bin splits into +-fs/2
        fine = np.fft.irfft(spectrum, n * UPSAMPLING) * UPSAMPLING
        grid = np.arange(n * UPSAMPLING) / UPSAMPLING - self.PAD
        # The polynomial coefficients, read directly: on a uniform grid the
        # interval is an index, no search needed.
        self.coef = scipy.interpolate.CubicSpline(grid, fine).c

    def __call__(self, position):
        """Values at sample positions `position` (any shape)."""
        u = (position + self.PAD) * UPSAMPLING
        i = np.clip(np.floor(u).astype(np.intp), 0, self.coef.shape[1] - 1)
        dx = (u - i) / UPSAMPLING
        c = self.coef
        value = ((c[0, i] * dx + c[1, i]) * dx + c[2, i]) * dx + c[3, i]
        inside = (position >= 0) & (position <= self.length - 1)
        return np.where(inside, value, 0.0)


# Propagation -------------------------------------------------------------

def fixed_point(update, start, tolerance=1e-14, max_iterations=100):
    """Iterate x = update(x) from `start` until no element moves more than
    `tolerance` (s). Contracts by |v|/c per step: a few steps suffice."""
    x = start
    for _ in range(max_iterations):
        new = update(x)
        if np.max(np.abs(new - x), initial=0.0) <= tolerance:
            return new
        x = new
    raise RuntimeError("propagation did not converge (reflector too fast?)")


def arrival_times(emit_times, emitters, mics, p0, v, c):
    """Instants (n, j) at which the sound emitter n sends at emit_times[n]
    reaches microphone j via the reflector p0 + v t."""
    def reflect(tr):
        return emit_times + np.linalg.norm(
            p0 + v * tr[:, None] - emitters, axis=1) / c
    tr = fixed_point(reflect, emit_times)
    pr = p0 + v * tr[:, None]
    return tr[:, None] + np.linalg.norm(
        pr[:, None, :] - mics[None, :, :], axis=2) / c


def add_echo(recording, setup, waves, trigger, reflector):
    """Add one reflector's echo of the ping triggered at `trigger` (s) to
    `recording` (samples x microphones), on the samples it reaches only."""
    fs, c = setup["sample_rate"], setup["speed_of_sound"]
    mics, emitters, delays = (setup["microphones"], setup["emitters"],
                              setup["emitter_delays"])
    p0, v, strength = reflector
    length = setup["waveform_length"]
    # The echo's span: arrivals of every emitter's first and last sample.
    first = arrival_times(trigger + delays, emitters, mics, p0, v, c)
    last = arrival_times(trigger + delays + (length - 1) / fs,
                         emitters, mics, p0, v, c)
    start = max(0, math.floor(first.min() * fs))
    stop = min(len(recording), math.ceil(last.max() * fs) + 1)
    if stop <= start:
        return
    t = np.arange(start, stop) / fs

    def reflect(tr):
        return t - np.linalg.norm(p0 + v * tr[..., None] - mics[:, None, :],
                                  axis=2) / c
    tr = fixed_point(reflect, np.broadcast_to(t, (len(mics), len(t))))
    pr = p0 + v * tr[..., None]                       # (J, S, 3)
    to_mic = np.linalg.norm(pr - mics[:, None, :], axis=2)
    echo = np.zeros_like(tr)
    for n, wave in enumerate(waves):
        to_emitter = np.linalg.norm(pr - emitters[n], axis=2)
        position = (tr - to_emitter / c - trigger - delays[n]) * fs
        echo += strength / (to_emitter + to_mic) ** 2 * wave(position)
    recording[start:stop] += echo.T


def add_direct_path(recording, setup, waves, trigger):
    """Add every emission heard straight from its emitter by every
    microphone: emitter n's waveform |m_j - e_n| / c after it starts,
    times direct_path / |m_j - e_n|^2."""
    fs, c = setup["sample_rate"], setup["speed_of_sound"]
    length = setup["waveform_length"]
    for n, (e, wave) in enumerate(zip(setup["emitters"], waves)):
        start_n = trigger + setup["emitter_delays"][n]
        for j, m in enumerate(setup["microphones"]):
            d = float(np.linalg.norm(m - e))
            first = max(0, math.floor((start_n + d / c) * fs))
            stop = min(len(recording),
                       math.ceil((start_n + d / c) * fs + length) + 1)
            if stop <= first:
                continue
            t = np.arange(first, stop) / fs
            recording[first:stop, j] += setup["direct_path"] / d ** 2 * wave(
                (t - start_n - d / c) * fs)


def truth_at(trigger, p0, v, c):
    """The reflector as a wave leaving the origin at `trigger` meets it:
    instant t = trigger + |p(t)| / c, and range, direction, radial speed."""
    t = fixed_point(lambda t: trigger + np.linalg.norm(p0 + v * t) / c,
                    np.float64(trigger))
    p = p0 + v * t
    r = float(np.linalg.norm(p))
    return {"t": float(t), "range": r,
            "azimuth": math.degrees(math.atan2(p[0], p[2])),
            "elevation": math.degrees(math.asin(p[1] / r)),
            "radial_velocity": float(np.dot(p, v) / r),
            "position": [float(x) for x in p]}


# The set-up --------------------------------------------------------------

def resolve(spec):
    """The spec with defaults filled in and geometry, delays and reflectors
    as arrays; refuses unknown keys and impossible values, naming them."""
    unknown = set(spec) - set(SPEC_KEYS)
    if unknown:
        raise ValueError(f"unknown spec keys: {sorted(unknown)}")
    s = {key: spec.get(key, default) for key, (default, _) in
         SPEC_KEYS.items()}
    rng_layout, rng_waves, rng_noise, rng_hardware = (
        np.random.default_rng(child) for child in
        np.random.SeedSequence(s["seed"]).spawn(4))
    s["rng_noise"] = rng_noise
    s["rng_hardware"] = rng_hardware
    fs = s["sample_rate"]
    if fs != int(fs) or fs <= 0:
        raise ValueError(f"sample_rate must be a positive integer: {fs}")
    s["sample_rate"] = fs = int(fs)

    mics = s["microphones"]
    if isinstance(mics, str):
        layouts = {"ertis": ertis_microphones,
                   "random16": lambda: random_disc_microphones(rng_layout)}
        if mics not in layouts:
            raise ValueError(f"microphones: unknown layout {mics!r}")
        mics = layouts[mics]()
    s["microphones"] = np.array(mics, dtype=np.float64).reshape(-1, 3)

    emitters = s["emitters"]
    if emitters is None:
        emitters = ellipse_emitters()
    elif isinstance(emitters, int):
        emitters = circle_emitters(emitters)
    s["emitters"] = np.array(emitters, dtype=np.float64).reshape(-1, 3)
    n = len(s["emitters"])

    delays = s["emitter_delays"]
    s["emitter_delays"] = (np.zeros(n) if delays is None else
                           np.array(delays, dtype=np.float64))
    if s["emitter_delays"].shape != (n,):
        raise ValueError(f"emitter_delays: {n} values needed")
    if s["ping_period"] <= 0 or s["n_pings"] < 1:
        raise ValueError("ping_period and n_pings must be positive")
    if s["window"] is None:
        s["window"] = round(s["ping_period"] * fs)
    if s["sample_format"] not in ("float32", "int16"):
        raise ValueError(f"sample_format: {s['sample_format']!r}")
    if not s["direct_path"] >= 0:
        raise ValueError(f"direct_path must be >= 0: {s['direct_path']}")
    for key, size in (("emitter_resonance", 4), ("microphone_mismatch", 2)):
        if s[key] is not None and (len(s[key]) != size or not all(
                x >= 0 for x in s[key])):
            raise ValueError(f"{key}: {size} values >= 0 or None")
    if s["field_of_view"] not in (None, "fan", "hemisphere"):
        raise ValueError(f"field_of_view: {s['field_of_view']!r}")

    reflectors = []
    for k, r in enumerate(s["reflectors"]):
        extra = set(r) - {"position", "velocity", "strength"}
        if extra:
            raise ValueError(f"reflector {k}: unknown keys {sorted(extra)}")
        p0 = np.array(r["position"], dtype=np.float64)
        v = np.array(r.get("velocity", (0, 0, 0)), dtype=np.float64)
        if np.linalg.norm(v) >= 0.1 * s["speed_of_sound"]:
            raise ValueError(f"reflector {k}: faster than c / 10")
        reflectors.append((p0, v, float(r.get("strength", 1.0))))
    s["reflectors"] = reflectors
    s["waveforms"] = noise_waveforms(rng_waves, n, s["waveform_length"], fs,
                                     s["band"])
    return s


def triggers(s):
    """Trigger instants of the pings, s from the first sample."""
    return s["trigger_offset"] + np.arange(s["n_pings"]) * s["ping_period"]


def recording_length(s):
    """Samples recorded: up to the last ping's window or period, whichever
    ends later, plus the tail. (The 1e-6 absorbs rounding of fs * t.)"""
    fs = s["sample_rate"]
    last = triggers(s)[-1] * fs + max(s["window"], s["ping_period"] * fs)
    return math.ceil(last - 1e-6) + s["tail"]


def filtered(signal, response, fs, pad=2048):
    """@signal through the filter whose frequency response (of Hz) is
    @response, by FFT over the signal and @pad zeros (its tail kept)."""
    n = len(signal) + pad
    spectrum = np.fft.rfft(signal, n) * response(np.fft.rfftfreq(n, 1 / fs))
    return np.fft.irfft(spectrum, n)


def air_absorption_db_per_m(f, kelvin=293.15, humidity=50.0):
    """ISO 9613-1:1993 pure-tone absorption of air at standard pressure,
    dB/m (eq. 3-5, B.1-B.3)."""
    t = kelvin / 293.15
    h = humidity * 10 ** (-6.8346 * (273.16 / kelvin) ** 1.261 + 4.6151)
    fr_o = 24 + 4.04e4 * h * (0.02 + h) / (0.391 + h)
    fr_n = t ** -0.5 * (9 + 280 * h * np.exp(-4.170 * (t ** (-1 / 3) - 1)))
    return 8.686 * f ** 2 * (1.84e-11 * t ** 0.5 + t ** -2.5 * (
        0.01275 * np.exp(-2239.1 / kelvin) / (fr_o + f ** 2 / fr_o) +
        0.1068 * np.exp(-3352.0 / kelvin) / (fr_n + f ** 2 / fr_n)))


def resonance(f0, q):
    """A 2nd-order band-pass's response (1 at @f0) as a function of Hz."""
    def response(f):
        s = 1j * f / f0
        return (s / q) / (s * s + s / q + 1)
    return response


def radiated(s):
    """What each emitter radiates: its waveform, through its resonance
    when emitter_resonance asks for one (the emissions file keeps the
    waveform as written)."""
    waves = s["waveforms"].astype(np.float64)
    if s["emitter_resonance"] is None:
        return waves
    f_lo, f_hi, q_lo, q_hi = s["emitter_resonance"]
    rng = s["rng_hardware"]
    return np.array([filtered(w, resonance(rng.uniform(f_lo, f_hi),
                                           rng.uniform(q_lo, q_hi)),
                              s["sample_rate"])[:len(w) + 1024]
                     for w in waves])


def mismatch_microphones(recording, s):
    """Each microphone's gain and phase off by up to microphone_mismatch's
    [dB, degrees]: a constant phase is a rotation of the analytic signal,
    x cos p - H{x} sin p."""
    gain_db, phase_deg = s["microphone_mismatch"]
    rng = s["rng_hardware"]
    for j in range(recording.shape[1]):
        gain = 10 ** (rng.uniform(-gain_db, gain_db) / 20)
        phase = math.radians(rng.uniform(-phase_deg, phase_deg))
        spectrum = np.fft.rfft(recording[:, j])
        spectrum[1:] *= np.exp(-1j * phase)
        recording[:, j] = gain * np.fft.irfft(spectrum, recording.shape[0])


def render(s):
    """The recording (samples x microphones, float64): every echo of every
    ping that falls inside it, the direct path, the microphones'
    mismatch, plus the noise."""
    n_samples = recording_length(s)
    recording = np.zeros((n_samples, len(s["microphones"])))
    sent = radiated(s)
    waves = [BandLimited(w) for w in sent]
    for trigger in triggers(s):
        for reflector in s["reflectors"]:
            echo_waves = waves
            if s["air_absorption"]:
                path = 2 * float(np.linalg.norm(reflector[0]))
                echo_waves = [BandLimited(filtered(w, lambda f: 10 ** (
                    -air_absorption_db_per_m(f) * path / 20),
                    s["sample_rate"])) for w in sent]
            add_echo(recording, s, echo_waves, trigger, reflector)
        if s["direct_path"]:
            add_direct_path(recording, s, waves, trigger)
    if s["microphone_mismatch"] is not None:
        mismatch_microphones(recording, s)
    recording += s["noise_rms"] * s["rng_noise"].standard_normal(
        recording.shape)
    return recording


def echo_inside_window(s, trigger, reflector):
    """Whether every pair's echo of this ping ends inside its window."""
    p0, v, _ = reflector
    fs = s["sample_rate"]
    last = arrival_times(trigger + s["emitter_delays"] +
                         (s["waveform_length"] - 1) / fs, s["emitters"],
                         s["microphones"], p0, v, s["speed_of_sound"])
    return bool(last.max() < trigger + s["window"] / fs)


def rows(array):
    """A 2-D array as nested lists of Python floats (for JSON)."""
    return [[float(x) for x in row] for row in array]


def to_json(doc):
    """A JSON object as text, one member a line, and one line per row of a
    list of lists or objects (positions, waveforms, pings)."""
    members = []
    for key, value in doc.items():
        if isinstance(value, list) and value and isinstance(
                value[0], (list, dict)):
            text = "[\n  " + ",\n  ".join(json.dumps(v) for v in value) + \
                "\n ]"
        else:
            text = json.dumps(value)
        members.append(f" {json.dumps(key)}: {text}")
    return "{\n" + ",\n".join(members) + "\n}\n"


def describe(s):
    """Default description text."""
    return (f"Foreign recording (tests/foreign_sim.py): "
            f"{len(s['microphones'])} microphones, {len(s['emitters'])} "
            f"emitters of band-passed noise, {s['n_pings']} pings, "
            f"{len(s['reflectors'])} point reflectors, seed {s['seed']}")


def simulate(spec, folder):
    """Simulate the recording `spec` asks for (keys: SPEC_KEYS) into
    `folder`; returns the paths written, by kind: recording, emissions,
    sensor, truth and, when asked, geometry."""
    s = resolve(spec)
    folder = pathlib.Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    name, fs = s["name"], s["sample_rate"]
    paths = {kind: folder / f"{name}{suffix}" for kind, suffix in
             (("recording", ".wav"), ("emissions", ".emissions.wav"),
              ("sensor", ".sensor.json"), ("truth", ".truth.json"))}

    recording = render(s)
    full_scale = None
    clipped = 0
    if s["sample_format"] == "int16":
        full_scale = s["full_scale"]
        if full_scale is None:
            full_scale = float(f"{1.25 * np.abs(recording).max():.2g}")
        counts = np.round(recording / full_scale * INT16_SCALE)
        clipped = int(np.count_nonzero((counts < -32768) | (counts > 32767)))
        data = np.clip(counts, -32768, 32767).astype(np.int16)
    else:
        data = recording.astype(np.float32)
    scipy.io.wavfile.write(paths["recording"], fs, data)
    scipy.io.wavfile.write(paths["emissions"], fs,
                           np.ascontiguousarray(s["waveforms"].T))

    sensor = {
        "description": s["description"] or describe(s),
        "sample-rate": fs,
        "speed-of-sound": s["speed_of_sound"],
        "microphones": rows(s["microphones"]),
        "emitters": rows(s["emitters"]),
        # 9 significant digits carry a float32 exactly.
        "waveforms": ([[float(f"{x:.9g}") for x in w] for w in s["waveforms"]]
                      if s["inline_waveforms"] else paths["emissions"].name),
        "emitter-delays": [float(d) for d in s["emitter_delays"]],
        "trigger-offset": s["trigger_offset"],
        "ping-period": s["ping_period"],
        "ping-length": int(s["window"]),
    }
    if s["field_of_view"] is not None:
        sensor["field-of-view"] = s["field_of_view"]
    paths["sensor"].write_text(to_json(sensor))

    pings = []
    for k, trigger in enumerate(triggers(s)):
        found = []
        for i, reflector in enumerate(s["reflectors"]):
            p0, v, strength = reflector
            entry = {"id": i, **truth_at(trigger, p0, v, s["speed_of_sound"]),
                     "velocity": [float(x) for x in v], "strength": strength,
                     "in_window": echo_inside_window(s, trigger, reflector)}
            found.append(entry)
        pings.append({"ping": k, "time": float(trigger), "reflectors": found})
    truth = {
        "description": "Ground truth of " + paths["recording"].name + ": "
        "each reflector at the instant t (s from the first sample) a wave "
        "leaving the array centre at the ping's trigger reaches it; "
        "in_window: its whole echo lies inside the ping's window",
        "sample-rate": fs, "speed-of-sound": s["speed_of_sound"],
        "n-samples": len(data), "sample-format": s["sample_format"],
        "full-scale": full_scale, "clipped-samples": clipped,
        "noise-rms": s["noise_rms"], "direct-path": s["direct_path"],
        "air-absorption": s["air_absorption"],
        "emitter-resonance": s["emitter_resonance"],
        "microphone-mismatch": s["microphone_mismatch"],
        "seed": s["seed"], "pings": pings,
    }
    paths["truth"].write_text(to_json(truth))

    if s["geometry_file"]:
        paths["geometry"] = folder / f"{name}.geometry.json"
        paths["geometry"].write_text(to_json(
            {"microphones": rows(s["microphones"]),
             "emitters": rows(s["emitters"])}))
    return paths


# Self-check ----------------------------------------------------------------

def sinc_sum(samples, position):
    """Reference reading of `samples` between samples: the plain
    Whittaker-Shannon sum over all of them (slow, independent of
    BandLimited)."""
    m = np.arange(len(samples))
    return np.array([np.dot(samples, np.sinc(p - m)) for p in position])


def peak_lag(signal, template):
    """Fractional lag L maximising sum_i signal[i + L] template[i]: the
    cross-correlation computed by FFT, its largest sample refined to the
    maximum of its band-limited interpolation by Newton steps on the
    derivatives of its Fourier series."""
    size = 1 << (len(signal) + len(template)).bit_length()
    cross = np.fft.rfft(signal, size) * np.conj(np.fft.rfft(template, size))
    cross[1:-1] *= 2.0  # the other half of the spectrum: DC, Nyquist once
    omega = 2 * np.pi * np.arange(len(cross)) / size
    lag = float(np.argmax(np.fft.irfft(cross, size)))
    for _ in range(5):
        rotated = cross * np.exp(1j * omega * lag)
        slope = (1j * omega * rotated).real.sum()
        curvature = (-omega ** 2 * rotated).real.sum()
        lag -= slope / curvature
    return lag - size if lag > size / 2 else lag


def read_wav(path):
    """(format tag, sample rate, samples x channels float64) of a WAV whose
    fmt chunk comes first, as scipy writes them."""
    tag = int.from_bytes(pathlib.Path(path).read_bytes()[20:22], "little")
    rate, data = scipy.io.wavfile.read(path)
    return tag, rate, np.asarray(data, dtype=np.float64).reshape(len(data), -1)


def check_interpolator():
    """Error of BandLimited, in dB of the signal: a Hann-windowed 80 kHz tone
    at 450 kHz against the exact tone, and a noise waveform against the
    plain sinc sum."""
    rng = np.random.default_rng(7)
    fs, length = 450000, 4000

    def tone(s):
        return (0.5 - 0.5 * np.cos(2 * np.pi * s / (length - 1))) * np.sin(
            2 * np.pi * 80000 * s / fs)

    s = rng.uniform(0, length - 1, 20000)
    tone_db = 20 * np.log10(np.abs(
        BandLimited(tone(np.arange(length)))(s) - tone(s)).max())
    wave = noise_waveforms(rng, 1, length, fs, (20000, 80000))[0]
    s = rng.uniform(-2, length + 1, 300)
    reference = np.where((s >= 0) & (s <= length - 1),
                         sinc_sum(wave.astype(np.float64), s), 0.0)
    noise_db = 20 * np.log10(np.abs(BandLimited(wave)(s) - reference).max())
    return tone_db, noise_db


def check_still_delays(folder):
    """A still reflector seen through the written files: the matched-filter
    peak lag of emitter n in microphone j against the two-leg delay
    trigger + d_n + (|p - e_n| + |p - m_j|) / c, for every pair of the
    default set-up with delays of 0 to 70 us. One recording per emitter: in
    a recording of all eight, the other emitters' cross-talk shifts the peak
    by ~0.1 sample, a property of the waveforms, not of the physics. Returns
    the worst error in samples and the time to generate the eight."""
    delays = [0, 11.1e-6, 22.2e-6, 33.3e-6, 44.4e-6, 55.5e-6, 66.6e-6, 70e-6]
    p = np.array([0.6, 0.2, 1.8])
    worst, elapsed = 0.0, 0.0
    for n, e in enumerate(ellipse_emitters()):
        spec = {"name": f"still{n}", "trigger_offset": 1.3e-3,
                "ping_period": 0.03, "emitters": [e.tolist()],
                "emitter_delays": [delays[n]], "noise_rms": 0.0,
                "reflectors": [{"position": p.tolist()}]}
        began = time.monotonic()
        paths = simulate(spec, folder)
        elapsed += time.monotonic() - began
        sensor = json.loads(paths["sensor"].read_text())
        _, fs, recording = read_wav(paths["recording"])
        _, _, waves = read_wav(folder / sensor["waveforms"])
        c = sensor["speed-of-sound"]
        for j, m in enumerate(np.array(sensor["microphones"])):
            expected = (sensor["trigger-offset"] + sensor["emitter-delays"][0]
                        + (np.linalg.norm(p - e) + np.linalg.norm(p - m)) / c
                        ) * fs
            lag = peak_lag(recording[:, j], waves[:, 0])
            worst = max(worst, abs(lag - expected))
    return worst, elapsed


def check_air_absorption(folder):
    """A still reflector at 2 m, one emitter, no noise, with and without
    air_absorption: the ratio of the echoes' spectra at 25-75 kHz against
    ISO 9613-1 over the 4 m path. Returns the worst difference in dB."""
    spectra = []
    for absorb in (False, True):
        paths = simulate({"name": f"air{int(absorb)}", "ping_period": 0.03,
                          "emitters": [[0.05, 0.0, 0.0]], "noise_rms": 0.0,
                          "air_absorption": absorb,
                          "reflectors": [{"position": [0.0, 0.0, 2.0]}]},
                         folder)
        _, fs, recording = read_wav(paths["recording"])
        spectra.append(np.abs(np.fft.rfft(recording[:, 0])))
    freqs = np.fft.rfftfreq(recording.shape[0], 1.0 / fs)
    band = (freqs >= 25e3) & (freqs <= 75e3)
    measured = 20 * np.log10(spectra[1][band] / spectra[0][band])
    return float(np.max(np.abs(measured + air_absorption_db_per_m(
        freqs[band]) * 4.0)))


def check_direct_path(folder):
    """The direct path alone (no reflector, no noise), one emitter at a
    time: the matched-filter peak lag of each microphone against trigger +
    d_n + |m_j - e_n| / c. Returns the worst error in samples."""
    worst = 0.0
    for n, e in enumerate(ellipse_emitters()):
        spec = {"name": f"direct{n}", "trigger_offset": 1.3e-3,
                "ping_period": 0.02, "emitters": [e.tolist()],
                "emitter_delays": [7e-6 * n], "noise_rms": 0.0,
                "direct_path": 0.1}
        paths = simulate(spec, folder)
        sensor = json.loads(paths["sensor"].read_text())
        _, fs, recording = read_wav(paths["recording"])
        _, _, waves = read_wav(folder / sensor["waveforms"])
        for j, m in enumerate(np.array(sensor["microphones"])):
            expected = (sensor["trigger-offset"] + sensor["emitter-delays"][0]
                        + np.linalg.norm(m - e) / sensor["speed-of-sound"]
                        ) * fs
            worst = max(worst, abs(peak_lag(recording[:, j], waves[:, 0])
                                   - expected))
    return worst


def local_peak(wave, piece, guess, reach=12):
    """Where in `wave` `piece` fits best, within `reach` samples of `guess`:
    integer-lag correlation refined by a parabola; None at the search's
    edge."""
    lags = np.arange(max(0, guess - reach),
                     min(len(wave) - len(piece), guess + reach) + 1)
    r = np.array([np.dot(wave[lag:lag + len(piece)], piece) for lag in lags])
    k = int(np.argmax(r))
    if k in (0, len(r) - 1):
        return None
    a, b, c = r[k - 1:k + 2]
    return lags[k] + 0.5 * (a - c) / (a - 2 * b + c)


def check_doppler(folder, speed):
    """A reflector 2 m ahead moving along the boresight at `speed`, emitter
    and microphone both at the origin, where the echo is exactly
    w(alpha (t - z0/c) - z0/c) / (2 z(t_r))^2 with alpha = (c-v)/(c+v).
    Returns the error of the recording against that (dB of the echo's rms,
    the waveform read by the sinc sum), the time scale measured without
    interpolation (matched-filtering pieces of the echo) and alpha."""
    c, z0 = 343.0, 2.0
    spec = {"name": f"doppler{speed:+g}", "microphones": [[0, 0, 0]],
            "emitters": [[0, 0, 0]], "ping_period": 0.03, "noise_rms": 0.0,
            "reflectors": [{"position": [0, 0, z0],
                            "velocity": [0, 0, speed]}]}
    paths = simulate(spec, folder)
    _, fs, recording = read_wav(paths["recording"])
    _, _, waves = read_wav(paths["emissions"])
    echo, wave = recording[:, 0], waves[:, 0]
    alpha = (c - speed) / (c + speed)
    support = np.flatnonzero(echo)
    rng = np.random.default_rng(3)
    i = rng.integers(support[0], support[-1], 400)
    t = i / fs
    t_r = (c * t - z0) / (c + speed)
    model = sinc_sum(wave, (alpha * (t - z0 / c) - z0 / c) * fs) / (
        2 * (z0 + speed * t_r)) ** 2
    error_db = 20 * np.log10(np.sqrt(np.mean((echo[i] - model) ** 2)) /
                             np.sqrt(np.mean(echo[support] ** 2)))
    # Where in the waveform each 64-sample piece of the echo sits: a
    # straight line of slope alpha. Pieces this short stay compressed at
    # 7 m/s; the echo's length guides the search.
    piece = 64
    rough = (len(wave) - 1) / (support[-1] - support[0])
    fits = []
    for start in range(support[0] + 100, support[-1] - 100 - piece,
                       piece // 2):
        where = local_peak(wave, echo[start:start + piece],
                           round(rough * (start - support[0])))
        if where is not None:
            fits.append((start, where))
    slope = np.polyfit(*np.array(fits).T, 1)[0]
    return error_db, slope, alpha


def check_speed(folder):
    """Generation time of a 3-ping eRTIS recording (32 x 8) of 4 reflectors,
    in seconds."""
    spec = {"name": "speed", "n_pings": 3, "reflectors": [
        {"position": [-0.75, 0, 1.3]},
        {"position": [0.4, 0, 2.2], "velocity": [0, 0, -1]},
        {"position": [1.9, 0.3, 2.3], "velocity": [3, 0, 5]},
        {"position": [0, -0.5, 3.5], "velocity": [0, 0, 0.5]}]}
    began = time.monotonic()
    simulate(spec, folder)
    return time.monotonic() - began


def self_check(folder):
    """Run the physics checks, print their figures; True when all pass."""
    folder = pathlib.Path(folder)
    ok = True

    def report(passed, text):
        nonlocal ok
        ok &= bool(passed)
        print(("ok   " if passed else "FAIL ") + text)

    tone_db, noise_db = check_interpolator()
    report(tone_db < -60, f"interpolator: 80 kHz tone error {tone_db:.1f} dB")
    report(noise_db < -60, f"interpolator: noise waveform against the sinc "
           f"sum {noise_db:.1f} dB")
    worst, elapsed = check_still_delays(folder)
    report(worst < 0.05, f"still reflector: worst matched-filter lag error "
           f"over 8 x 32 pairs {worst:.2g} samples (generated in "
           f"{elapsed:.2f} s)")
    for speed in (7.0, -7.0, 0.02):
        error_db, slope, alpha = check_doppler(folder, speed)
        implied = 343.0 * (1 - slope) / (1 + slope)
        report(error_db < -60 and abs(implied - speed) < 0.01,
               f"{speed:+g} m/s mover: echo against the exact model "
               f"{error_db:.1f} dB; time scale {slope:.6f} measured, "
               f"{alpha:.6f} expected (speed {implied:+.4f} m/s)")
    for name in ("still0.wav", "still0.emissions.wav"):
        tag = read_wav(folder / name)[0]
        report(tag == 3, f"{name}: format tag {tag}")
    simulate({"name": "pcm", "sample_format": "int16", "ping_period": 0.02,
              "reflectors": [{"position": [0, 0, 1]}]}, folder)
    tag = read_wav(folder / "pcm.wav")[0]
    report(tag == 1, f"pcm.wav: format tag {tag}")
    worst = check_direct_path(folder)
    report(worst < 0.05, f"direct path: worst lag error over 8 x 32 pairs "
           f"{worst:.2g} samples")
    worst = check_air_absorption(folder)
    report(worst < 0.1, f"air absorption: echo spectra against ISO 9613-1 "
           f"at 25-75 kHz, worst {worst:.3f} dB")
    elapsed = check_speed(folder)
    report(elapsed < 60, f"3 pings, 32 x 8, 4 reflectors: {elapsed:.1f} s")
    return ok


# Command line ---------------------------------------------------------------

def reflector_option(text):
    """x,y,z[,vx,vy,vz[,strength]] as a reflector dict."""
    values = [float(x) for x in text.split(",")]
    if len(values) not in (3, 6, 7):
        raise argparse.ArgumentTypeError(
            "a reflector is x,y,z[,vx,vy,vz[,strength]]")
    reflector = {"position": values[:3]}
    if len(values) > 3:
        reflector["velocity"] = values[3:6]
    if len(values) == 7:
        reflector["strength"] = values[6]
    return reflector


def parse_args(argv):
    """Command-line options; the spec keys not given stay unset."""
    parser = argparse.ArgumentParser(
        description="Write a foreign sonar recording (WAV), its emissions, "
        "sensor description and ground truth into OUT_DIR.")
    parser.add_argument("out_dir", nargs="?", help="folder to write into")
    parser.add_argument("--self-check", action="store_true",
                        help="run the physics checks (in a temporary folder "
                        "unless OUT_DIR is given) and exit")
    parser.add_argument("--spec", help="JSON file of spec keys (options "
                        "given here override it)")
    parser.add_argument("--reflector", action="append", type=reflector_option,
                        dest="reflectors", metavar="X,Y,Z[,VX,VY,VZ[,S]]",
                        help="a point reflector (repeatable)")
    parser.add_argument("--microphones",
                        help="ertis, random16 or a JSON file with "
                        "\"microphones\"")
    parser.add_argument("--emitters", help="a count (on a 6 cm circle) or a "
                        "JSON file with \"emitters\"")
    parser.add_argument("--emitter-delays", dest="emitter_delays",
                        type=lambda t: [float(x) for x in t.split(",")],
                        help="comma-separated seconds")
    numbers = {"sample_rate": int, "speed_of_sound": float,
               "waveform_length": int, "trigger_offset": float,
               "ping_period": float, "n_pings": int, "window": int,
               "tail": int, "noise_rms": float, "seed": int,
               "full_scale": float, "direct_path": float}
    for key, kind in numbers.items():
        parser.add_argument("--" + key.replace("_", "-"), dest=key,
                            type=kind, help=SPEC_KEYS[key][1])
    for key in ("name", "description", "sample_format", "field_of_view"):
        parser.add_argument("--" + key.replace("_", "-"), dest=key,
                            help=SPEC_KEYS[key][1])
    for key in ("emitter_resonance", "microphone_mismatch"):
        parser.add_argument("--" + key.replace("_", "-"), dest=key,
                            type=lambda t: [float(x) for x in t.split(",")],
                            help=SPEC_KEYS[key][1] + " (comma-separated)")
    for key in ("inline_waveforms", "geometry_file", "air_absorption"):
        parser.add_argument("--" + key.replace("_", "-"), dest=key,
                            action="store_const", const=True,
                            help=SPEC_KEYS[key][1])
    args = parser.parse_args(argv)
    if not args.self_check and not args.out_dir:
        parser.error("OUT_DIR is needed")
    return args


def spec_from_args(args):
    """The spec: the --spec file's keys, overridden by the options given."""
    spec = json.loads(pathlib.Path(args.spec).read_text()) if args.spec \
        else {}
    for key, value in vars(args).items():
        if key in SPEC_KEYS and value is not None:
            spec[key] = value
    for key in ("microphones", "emitters"):
        value = spec.get(key)
        if isinstance(value, str) and value.isdigit():
            spec[key] = int(value)
        elif isinstance(value, str) and value.endswith(".json"):
            spec[key] = json.loads(pathlib.Path(value).read_text())[key]
    return spec


def main(argv=None):
    """Write a recording (or run the self-check); print the files written."""
    args = parse_args(sys.argv[1:] if argv is None else argv)
    if args.self_check:
        if args.out_dir:
            return 0 if self_check(args.out_dir) else 1
        with tempfile.TemporaryDirectory(prefix="foreign-sim-") as folder:
            return 0 if self_check(folder) else 1
    try:
        paths = simulate(spec_from_args(args), args.out_dir)
    except (ValueError, KeyError, OSError) as error:
        print(f"foreign_sim.py: {error}", file=sys.stderr)
        return 1
    for kind, path in paths.items():
        print(f"{kind}: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
