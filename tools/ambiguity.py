"""Wideband ambiguity function of the sonar's emission waveforms.

The numeric core of tools/plot-ambiguity.py (the paper's Fig. 2), importable
by tests. An echo from a reflector moving at radial velocity v (m/s, positive
away) is the emission time-scaled by alpha = (c - v) / (c + v):
y[n] = x(alpha n). The ambiguity function is the envelope of the output of
the matched filter tuned to v = 0 (cross-correlation with the unscaled
waveform) against lag and v.

Over 4000 samples, 0.02 m/s stretches the echo by about half a sample, so the
time-scaling must be exact between samples. scipy.signal.resample cannot do
it: it only resamples to an integer number of samples, which quantises alpha
in steps of 1/N (about 0.04 m/s here). Instead the waveform is treated as
the band-limited periodic signal of its zero-padded DFT,
x(t) = (1/M) sum_k X[k] exp(2 pi i k t / M), and evaluated at t = alpha n.
For a fixed alpha the frequencies alpha k / M are equally spaced, so the sum
is a chirp z-transform (scipy.signal.czt): the exact band-limited
interpolation at FFT cost, accurate to about 1e-11.
"""

import json
import math
import subprocess

import numpy as np
from scipy import fft, optimize, signal

SPEED_OF_SOUND = 343.0


def load_waveforms(path):
    """Read a waveforms file (docs/FORMATS.md).

    Returns (sample_rate, waveforms) with waveforms an
    (n_emitters, length) float64 array.
    """
    with open(path, encoding="utf-8") as f:
        doc = json.load(f)
    try:
        sample_rate = float(doc["sample-rate"])
        waveforms = np.array(doc["waveforms"], dtype=np.float64)
    except (KeyError, TypeError, ValueError) as e:
        raise ValueError(f"{path}: not a waveforms file ({e})") from e
    if waveforms.ndim != 2 or waveforms.shape[1] < 16:
        raise ValueError(f"{path}: \"waveforms\" must be rows of equal "
                         "length (at least 16 samples)")
    return sample_rate, waveforms


def kinds(program):
    """The waveform kinds the sonar-waveforms program makes.

    Returns [(name, description)] in the core's order (its table of kinds,
    gst/sonar-waveform.c).
    """
    out = subprocess.run([program, "--list-kinds"], check=True,
                         capture_output=True, text=True).stdout
    return [tuple(line.split("\t", 1)) for line in out.splitlines()]


def generate_waveforms(program, kind, *args):
    """Run the sonar-waveforms program for one kind.

    Returns (sample_rate, waveforms) like load_waveforms.
    """
    out = subprocess.run([program, "--kind", kind, *args], check=True,
                         capture_output=True, text=True).stdout
    doc = json.loads(out)
    return float(doc["sample-rate"]), np.array(doc["waveforms"],
                                               dtype=np.float64)


def time_scale_factor(velocity, speed_of_sound=SPEED_OF_SOUND):
    """Doppler time-scale alpha = (c - v) / (c + v) of an echo."""
    return (speed_of_sound - velocity) / (speed_of_sound + velocity)


def time_scale(x, alpha, length=None):
    """Evaluate the band-limited waveform x at t = alpha n, n < length.

    length defaults to the duration of the scaled waveform, ceil(N / alpha).
    Exact for the band-limited interpolation of x (see the module doc).
    """
    if not alpha > 0:
        raise ValueError(f"time scale {alpha} must be positive")
    n = len(x)
    if length is None:
        length = math.ceil(n / alpha)
    # A period M beyond both the waveform and the evaluated span keeps the
    # periodic interpolation from wrapping the waveform onto itself.
    m = fft.next_fast_len(2 * max(n, math.ceil(alpha * length)))
    spectrum = fft.rfft(x, m)
    half = m // 2
    # Positive frequencies 1 .. M/2 - 1; DC added apart; the Nyquist bin of
    # a band-passed waveform is nil and has no unambiguous scaling anyway.
    w = np.exp(2j * np.pi * alpha / m)
    sums = signal.czt(spectrum[1:half], length, w=w, a=1.0)
    t = alpha * np.arange(length)
    return (2.0 * np.real(np.exp(2j * np.pi * t / m) * sums)
            + spectrum[0].real) / m


class AmbiguityFunction:
    """Matched-filter envelopes of one waveform against Doppler velocity.

    Envelopes are normalised by the peak of the autocorrelation envelope,
    so 1 (0 dB) is the matched filter's output for a still reflector.
    """

    def __init__(self, waveform, speed_of_sound=SPEED_OF_SOUND):
        self.waveform = np.asarray(waveform, dtype=np.float64)
        self.speed_of_sound = speed_of_sound
        self._reference = self._matched_filter(1.0).max()

    def _matched_filter(self, alpha):
        """Envelope of the v = 0 matched filter's output for an echo
        time-scaled by alpha, lags -(N - 1) .. len(echo) - 1."""
        echo = time_scale(self.waveform, alpha)
        corr = signal.correlate(echo, self.waveform, mode="full",
                                method="fft")
        # Zero-padded so the FFT-based Hilbert transform does not wrap.
        analytic = signal.hilbert(corr, fft.next_fast_len(2 * len(corr)))
        return np.abs(analytic[:len(corr)])

    def envelope(self, velocity):
        """Matched filter envelope for an echo at radial velocity v.

        Returns (lags, envelope): lag 0 is the echo's start, the filter's
        peak for a still reflector.
        """
        env = self._matched_filter(
            time_scale_factor(velocity, self.speed_of_sound))
        lags = np.arange(len(env)) - (len(self.waveform) - 1)
        return lags, env / self._reference

    def image(self, velocities, lag_span):
        """Ambiguity image over velocities and lags -lag_span .. lag_span.

        Returns (lags, image, cut): image[i, j] is the envelope at
        velocities[i] and lags[j]; cut[i] is the envelope's peak over all
        lags (the Doppler cut, or velocity sensitivity).
        """
        window = np.arange(-lag_span, lag_span + 1)
        image = np.zeros((len(velocities), len(window)))
        cut = np.zeros(len(velocities))
        for i, v in enumerate(velocities):
            lags, env = self.envelope(v)
            cut[i] = env.max()
            inside = (window >= lags[0]) & (window <= lags[-1])
            image[i, inside] = env[window[inside] - lags[0]]
        return window, image, cut

    def cut_db(self, velocity):
        """Doppler cut in dB at one velocity: peak envelope over lags."""
        return 20.0 * math.log10(self.envelope(velocity)[1].max())

    def doppler_width(self, threshold_db=-3.0, first_step=0.02,
                      growth=1.5, v_max=100.0, tolerance=1e-4):
        """Width (m/s) of the Doppler cut's main lobe at threshold_db.

        Walks outward from v = 0 on each side with geometrically growing
        steps until the cut falls below the threshold, then refines the
        crossing with Brent's method. Returns math.inf when the cut stays
        above the threshold up to v_max on either side (a Doppler tolerant
        waveform). Sidelobes must stay below the threshold, as they do
        (-14 dB or lower) for every kind here.
        """
        edges = []
        for side in (1.0, -1.0):
            inner, outer = 0.0, first_step
            while self.cut_db(side * outer) >= threshold_db:
                if outer >= v_max:
                    return math.inf
                inner, outer = outer, min(outer * growth, v_max)
            edges.append(optimize.brentq(
                lambda v, s=side: self.cut_db(s * v) - threshold_db,
                inner, outer, xtol=tolerance))
        return edges[0] + edges[1]


def peak_sidelobe(velocities, cut, floor_db=-3.0):
    """Peak sidelobe of a Doppler cut: (level in dB re the peak, velocity).

    The main lobe runs from the peak out to the first local minimum on each
    side that lies below floor_db, so ripple near the top is not a
    sidelobe. Returns (NaN, NaN) when the main lobe fills the grid (a
    Doppler tolerant waveform): there is no sidelobe to measure.
    """
    velocities = np.asarray(velocities)
    cut_db = 20.0 * np.log10(np.maximum(np.asarray(cut) / np.max(cut),
                                        1e-12))
    peak = int(np.argmax(cut_db))
    right = peak
    while right + 1 < len(cut_db) and not (
            cut_db[right] < floor_db and cut_db[right + 1] > cut_db[right]):
        right += 1
    left = peak
    while left > 0 and not (
            cut_db[left] < floor_db and cut_db[left - 1] > cut_db[left]):
        left -= 1
    outside = np.ones(len(cut_db), dtype=bool)
    outside[left:right + 1] = False
    if not outside.any():
        return math.nan, math.nan
    best = np.flatnonzero(outside)[np.argmax(cut_db[outside])]
    return float(cut_db[best]), float(velocities[best])
