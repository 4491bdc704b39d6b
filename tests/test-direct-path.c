/* test-direct-path.c: the emissions heard straight from the emitters,
 * fitted and subtracted before the spectra (sonar-direct-path.h).
 *
 * Each ping here is built by the test itself: every emitter's waveform
 * delayed by its path to the microphone through a long windowed-sinc
 * interpolator (sonar_test_add_delayed (), independent of the fit's
 * whole-sample taps), at a gain of its own, plus white noise and
 * echoes. */
#include <math.h>
#include <string.h>

#include "sonar-direct-path.h"
#include "sonar-error.h"
#include "sonar-rng.h"
#include "sonar-spectrum.h"
#include "sonar-test-util.h"

/* Samples a transducer's ringing may run on after the waveform. */
#define RING_TAIL 256

/* @x through a resonance (the band-pass biquad of unit peak gain at
 * @f0 cycles per sample, quality @q; R. Bristow-Johnson's cookbook), in
 * place: what an emitter radiates when it rings. */
static void
resonate (float *x, guint n, double f0, double q)
{
  const double w0 = 2.0 * G_PI * f0, alpha = sin (w0) / (2.0 * q);
  const double a0 = 1.0 + alpha;
  const double b0 = alpha / a0, b2 = -alpha / a0;
  const double a1 = -2.0 * cos (w0) / a0, a2 = (1.0 - alpha) / a0;
  double x1 = 0.0, x2 = 0.0, y1 = 0.0, y2 = 0.0;

  for (guint i = 0; i < n; i++) {
    const double y = b0 * x[i] + b2 * x2 - a1 * y1 - a2 * y2;
    x2 = x1;
    x1 = x[i];
    y2 = y1;
    y1 = y;
    x[i] = (float) y;
  }
}

typedef struct
{
  SonarSetup *setup;
  guint n_mics, n_emitters, length;
  float *clean;                 /* [mic][sample]: noise and echoes */
  float *ping;                  /* clean plus the direct path */
  double direct_energy;         /* of the direct path alone, all mics */
} Fixture;

/* Noise of rms @noise, an echo of amplitude @echo from (0.3, 0, 1) m, and,
 * with @direct > 0, every emitter heard straight at a gain of @direct
 * times 0.5-2 (random per pair), its delay the path from the emitter to
 * the microphone moved by up to @geometry_error m. */
static void
fixture_init (Fixture * f, double noise, double direct, double echo,
    double geometry_error, double ringing)
{
  g_autoptr (GError) error = NULL;
  SonarRng rng;
  const SonarVec3 point = sonar_vec3 (0.3, 0.0, 1.0);

  f->setup = sonar_setup_new_default (5.0, &error);
  g_assert_no_error (error);
  f->n_mics = f->setup->geometry.n_microphones;
  f->n_emitters = f->setup->geometry.n_emitters;
  f->length = f->setup->ping_length;
  f->clean = g_new0 (float, (gsize) f->n_mics * f->length);
  f->ping = g_new0 (float, (gsize) f->n_mics * f->length);
  f->direct_energy = 0.0;
  sonar_rng_init (&rng, 31, 0);
  for (guint j = 0; j < f->n_mics; j++) {
    float *clean = f->clean + (gsize) j * f->length;
    float *ping = f->ping + (gsize) j * f->length;
    const SonarVec3 m = f->setup->geometry.microphones[j];
    for (guint t = 0; t < f->length; t++)
      clean[t] = (float) (noise * sonar_rng_gaussian (&rng));
    for (guint n = 0; n < f->n_emitters; n++) {
      const SonarVec3 e = f->setup->geometry.emitters[n];
      const double c = f->setup->speed_of_sound, fs = f->setup->sample_rate;
      const double there = sonar_vec3_norm (sonar_vec3_sub (point, e)) +
          sonar_vec3_norm (sonar_vec3_sub (point, m));
      sonar_test_add_delayed (clean, f->length, sonar_setup_waveform (f->setup, n),
          f->setup->waveform_length, there / c * fs, echo);
    }
    memcpy (ping, clean, sizeof (float) * f->length);
    if (direct > 0.0) {
      g_autofree float *alone = g_new0 (float, f->length);
      for (guint n = 0; n < f->n_emitters; n++) {
        const SonarVec3 e = f->setup->geometry.emitters[n];
        const double c = f->setup->speed_of_sound;
        const double fs = f->setup->sample_rate;
        const double path = sonar_vec3_norm (sonar_vec3_sub (m, e)) +
            geometry_error * (2.0 * sonar_rng_uniform (&rng) - 1.0);
        const guint w_length = f->setup->waveform_length + RING_TAIL;
        g_autofree float *sent = g_new0 (float, w_length);

        memcpy (sent, sonar_setup_waveform (f->setup, n), sizeof (float) *
            f->setup->waveform_length);
        if (ringing > 0.0)
          resonate (sent, w_length, 45000.0 / fs, ringing);
        sonar_test_add_delayed (alone, f->length, sent, w_length,
            path / c * fs, direct * (0.5 + 1.5 * sonar_rng_uniform (&rng)));
      }
      for (guint t = 0; t < f->length; t++) {
        ping[t] += alone[t];
        f->direct_energy += (double) alone[t] * alone[t];
      }
    }
  }
}

static void
fixture_clear (Fixture * f)
{
  sonar_setup_unref (f->setup);
  g_free (f->clean);
  g_free (f->ping);
}

/* sum over every microphone of |ping - clean|^2. */
static double
error_energy (const Fixture * f)
{
  double sum = 0.0;

  for (gsize i = 0; i < (gsize) f->n_mics * f->length; i++) {
    const double d = (double) f->ping[i] - f->clean[i];
    sum += d * d;
  }
  return sum;
}

/* Subtracts with @mode and @n_taps a path from every microphone; returns
 * how many it was subtracted from, and in *@rang (may be NULL) whether a
 * path rang past the taps (sonar_direct_path_rang ()). */
static guint
remove_all (Fixture * f, SonarDirectPathMode mode, guint n_taps,
    gboolean * rang)
{
  g_autoptr (GError) error = NULL;
  g_autoptr (SonarDirectPath) dp = sonar_direct_path_new (f->setup, n_taps,
      &error);
  g_autofree double *scratch = NULL;
  guint count = 0;

  g_assert_no_error (error);
  scratch = g_new (double, sonar_direct_path_scratch_size (dp));
  for (guint j = 0; j < f->n_mics; j++) {
    gboolean removed;
    sonar_direct_path_remove (dp, j, f->ping + (gsize) j * f->length,
        f->length, mode, scratch, &removed);
    count += removed;
  }
  if (rang)
    *rang = sonar_direct_path_rang (dp);
  return count;
}

/* A direct path alone (the delays fractional, each pair's gain its own)
 * with the geometry's paths exact, or up to @data metres off (1 mm: 1.3
 * samples at 450 kHz, within the taps' reach of 3): subtracted from every
 * microphone, what is left of it is more than 70 dB below it (measured
 * -82.2 and -80.2 dB). */
static void
test_cancels (gconstpointer data)
{
  const double geometry_error = *(const double *) data;
  Fixture f;
  double left;
  gboolean rang;

  fixture_init (&f, 0.0, 100.0, 0.0, geometry_error, 0.0);
  g_assert_cmpuint (remove_all (&f, SONAR_DIRECT_PATH_AUTO,
          SONAR_DIRECT_PATH_TAPS, &rang), ==, f.n_mics);
  g_assert_false (rang);
  left = error_energy (&f);
  g_test_message ("left %.1f dB of the direct path",
      10.0 * log10 (left / f.direct_energy));
  g_assert_cmpfloat (left, <, 1e-7 * f.direct_energy);
  fixture_clear (&f);
}

/* An emitter that rings (a resonance of Q 3 at 45 kHz the waveforms
 * lack): 7 taps alone left -8.3 dB of it (before the ringing fit), 41
 * taps (2 before the path's delay, the rest after: the ringing follows
 * the sound) more than 30 dB less, and so do the default 7 now, which
 * tell the ringing and fit what they left again with 41
 * (sonar-direct-path.h); a path that does not ring is not fitted again
 * (test_cancels ()); a tap count out of range is an error that says
 * so. */
static void
test_ringing (void)
{
  Fixture f;
  const guint taps[2] = { SONAR_DIRECT_PATH_TAPS, 41 };
  g_autoptr (GError) error = NULL;

  for (guint k = 0; k < 2; k++) {
    gboolean rang;
    double left;
    fixture_init (&f, 0.0, 100.0, 0.0, 0.0, 3.0);
    g_assert_cmpuint (remove_all (&f, SONAR_DIRECT_PATH_ALWAYS, taps[k],
            &rang), ==, f.n_mics);
    left = 10.0 * log10 (error_energy (&f) / f.direct_energy);
    g_test_message ("%u taps: left %.1f dB of the ringing direct path%s",
        taps[k], left, rang ? ", fitted again with 41" : "");
    g_assert_cmpfloat (left, <, -8.3 - 30.0);
    g_assert_true (rang == (taps[k] < SONAR_DIRECT_PATH_RINGING_TAPS));
    fixture_clear (&f);
  }

  fixture_init (&f, 0.0, 100.0, 0.0, 0.0, 0.0);
  g_assert_null (sonar_direct_path_new (f.setup, 2, &error));
  g_assert_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS);
  g_assert_cmpstr (error->message, ==, "direct path: 2 taps: between 3 and "
      "64");
  fixture_clear (&f);
}

/* No direct path, a strong echo (30 dB over the noise) inside its
 * samples: auto leaves every microphone bit for bit as it was; always
 * subtracts a fit of what is there: the share of the echo's power in the
 * direct path's samples that its waveforms at those lags take (about
 * P / (b L) = 5 %; 2 % of the ping's), and each emitter's matched
 * filter at the echo's own lag moves by less than 0.5 dB (measured
 * 0.35 at most). */
static void
test_auto_leaves_echoes (void)
{
  Fixture f;
  double left, power = 0.0, moved = 0.0;

  fixture_init (&f, 1.0, 0.0, 30.0, 0.0, 0.0);
  g_assert_cmpuint (remove_all (&f, SONAR_DIRECT_PATH_AUTO,
          SONAR_DIRECT_PATH_TAPS, NULL), ==, 0);
  g_assert_cmpmem (f.ping, sizeof (float) * f.n_mics * f.length, f.clean,
      sizeof (float) * f.n_mics * f.length);
  g_assert_cmpuint (remove_all (&f, SONAR_DIRECT_PATH_ALWAYS,
          SONAR_DIRECT_PATH_TAPS, NULL), ==, f.n_mics);
  left = error_energy (&f);
  for (gsize i = 0; i < (gsize) f.n_mics * f.length; i++)
    power += (double) f.clean[i] * f.clean[i];
  g_test_message ("always took %.2f %% of the ping's power",
      100.0 * left / power);
  g_assert_cmpfloat (left, >, 0.0);
  g_assert_cmpfloat (left, <, 0.05 * power);
  for (guint j = 0; j < f.n_mics; j += 7)
    for (guint n = 0; n < f.n_emitters; n++) {
      const SonarVec3 e = f.setup->geometry.emitters[n];
      const SonarVec3 m = f.setup->geometry.microphones[j];
      const SonarVec3 point = sonar_vec3 (0.3, 0.0, 1.0);
      const gsize lag = (gsize) lround ((sonar_vec3_norm (sonar_vec3_sub
                  (point, e)) + sonar_vec3_norm (sonar_vec3_sub (point,
                      m))) / f.setup->speed_of_sound * f.setup->sample_rate);
      const float *w = sonar_setup_waveform (f.setup, n);
      double before = 0.0, after = 0.0;
      for (guint i = 0; i < f.setup->waveform_length; i++) {
        before += (double) f.clean[(gsize) j * f.length + lag + i] * w[i];
        after += (double) f.ping[(gsize) j * f.length + lag + i] * w[i];
      }
      moved = MAX (moved, fabs (20.0 * log10 (fabs (after / before))));
    }
  g_test_message ("the echo's matched filters moved %.2f dB at most", moved);
  g_assert_cmpfloat (moved, <, 0.5);
  fixture_clear (&f);
}

/* Silence and off: nothing subtracted, -inf, the ping untouched. */
static void
test_silence_and_off (void)
{
  Fixture f;
  g_autoptr (GError) error = NULL;
  g_autoptr (SonarDirectPath) dp = NULL;
  g_autofree double *scratch = NULL;
  g_autofree float *zeros = NULL;
  gboolean removed = TRUE;

  fixture_init (&f, 1.0, 100.0, 0.0, 0.0, 0.0);
  dp = sonar_direct_path_new (f.setup, SONAR_DIRECT_PATH_TAPS, &error);
  g_assert_no_error (error);
  scratch = g_new (double, sonar_direct_path_scratch_size (dp));
  zeros = g_new0 (float, f.length);
  g_assert_cmpfloat (sonar_direct_path_remove (dp, 0, zeros, f.length,
          SONAR_DIRECT_PATH_ALWAYS, scratch, &removed), ==, -INFINITY);
  g_assert_false (removed);
  for (guint t = 0; t < f.length; t++)
    g_assert_cmpfloat (zeros[t], ==, 0.0f);
  memcpy (f.clean, f.ping, sizeof (float) * f.length);
  removed = TRUE;
  g_assert_cmpfloat (sonar_direct_path_remove (dp, 0, f.ping, f.length,
          SONAR_DIRECT_PATH_OFF, scratch, &removed), ==, -INFINITY);
  g_assert_false (removed);
  g_assert_cmpmem (f.ping, sizeof (float) * f.length, f.clean,
      sizeof (float) * f.length);
  fixture_clear (&f);
}

/* A ping too short to hold the direct path after the waveform's length:
 * an error that says so (dopplerbank's auto then leaves it be). */
static void
test_short_ping (void)
{
  g_autoptr (GError) error = NULL;
  g_autoptr (SonarSetup) setup = sonar_setup_new_default (5.0, &error);
  g_autoptr (SonarSetup) shorter = NULL;
  g_autoptr (SonarDirectPath) dp = NULL;
  SonarSetupParams p;

  g_assert_no_error (error);
  sonar_test_setup_params (&p, setup);
  p.ping_length = setup->waveform_length + 10;
  shorter = sonar_setup_new (&p, &error);
  g_assert_no_error (error);
  dp = sonar_direct_path_new (shorter, SONAR_DIRECT_PATH_TAPS, &error);
  g_assert_null (dp);
  g_assert_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS);
  g_assert_nonnull (strstr (error->message, "direct path: a ping of 4010 "
          "samples cannot hold the emissions' direct path to the "
          "microphones"));
}

/* Through the front end (sonar_channel_spectra_set_direct_path ()), on
 * the interleaved ping, 1 and 2 workers: every channel's spectrum bit for
 * bit that of its samples with the direct path subtracted alone
 * (sonar_direct_path_remove () on the contiguous channel), 32 channels
 * counted, the largest fit over 30 dB (37); with OFF, none counted and
 * the spectra those of the ping as it came. */
static void
test_front_end (void)
{
  Fixture f;
  SonarBand band;
  g_autoptr (GError) error = NULL;
  g_autoptr (SonarDirectPath) dp = NULL;
  g_autoptr (SonarSpectrum) alone = NULL;
  g_autofree double *scratch = NULL;
  g_autofree float *frames = NULL, *channel = NULL;
  g_autofree SonarComplex *subtracted = NULL, *kept = NULL, *got = NULL;
  const gsize size = sizeof (SonarComplex);

  fixture_init (&f, 1.0, 100.0, 3.0, 0.0, 0.0);
  sonar_band_init (&band, f.setup->sample_rate, f.length +
      f.setup->waveform_length, f.setup->band_low, f.setup->band_high);
  dp = sonar_direct_path_new (f.setup, SONAR_DIRECT_PATH_TAPS, &error);
  g_assert_no_error (error);
  scratch = g_new (double, sonar_direct_path_scratch_size (dp));
  alone = sonar_spectrum_new (&band);
  frames = g_new (float, (gsize) f.n_mics * f.length);
  channel = g_new (float, f.length);
  subtracted = g_new (SonarComplex, (gsize) f.n_mics * band.n_bins);
  kept = g_new (SonarComplex, (gsize) f.n_mics * band.n_bins);
  got = g_new (SonarComplex, (gsize) f.n_mics * band.n_bins);
  for (guint j = 0; j < f.n_mics; j++) {
    const float *ping = f.ping + (gsize) j * f.length;
    for (guint t = 0; t < f.length; t++)
      frames[(gsize) t * f.n_mics + j] = ping[t];
    sonar_spectrum_process (alone, ping, f.length, 1,
        kept + (gsize) j * band.n_bins, NULL);
    memcpy (channel, ping, sizeof (float) * f.length);
    sonar_direct_path_remove (dp, j, channel, f.length,
        SONAR_DIRECT_PATH_AUTO, scratch, NULL);
    sonar_spectrum_process (alone, channel, f.length, 1,
        subtracted + (gsize) j * band.n_bins, NULL);
  }
  for (guint threads = 1; threads <= 2; threads++) {
    g_autoptr (SonarChannelSpectra) s = sonar_channel_spectra_new (&band,
        f.n_mics, threads, &error);
    double largest;

    g_assert_no_error (error);
    sonar_channel_spectra_set_direct_path (s, dp, SONAR_DIRECT_PATH_AUTO);
    sonar_channel_spectra_process (s, frames, f.length, got);
    g_assert_cmpuint (sonar_channel_spectra_direct_path_removed (s,
            &largest), ==, f.n_mics);
    g_test_message ("largest fit %.1f dB over the rest", largest);
    g_assert_cmpfloat (largest, >, 30.0);
    g_assert_cmpmem (got, size * f.n_mics * band.n_bins, subtracted,
        size * f.n_mics * band.n_bins);

    sonar_channel_spectra_set_direct_path (s, dp, SONAR_DIRECT_PATH_OFF);
    sonar_channel_spectra_process (s, frames, f.length, got);
    g_assert_cmpuint (sonar_channel_spectra_direct_path_removed (s,
            &largest), ==, 0);
    g_assert_cmpfloat (largest, ==, -INFINITY);
    g_assert_cmpmem (got, size * f.n_mics * band.n_bins, kept,
        size * f.n_mics * band.n_bins);
  }
  fixture_clear (&f);
}

/* The taps a path needs grow as the band reaches towards Nyquist: 7 for
 * the built-in sensor (80 kHz at 450 kHz), 13 at 250 kHz, 28 at 192 kHz,
 * the most past it. */
static void
test_default_taps (void)
{
  g_autoptr (SonarSetup) setup = sonar_test_default_setup (17262);
  const double rates[] = { 450000.0, 250000.0, 192000.0, 162000.0 };
  const guint taps[] = { 7, 13, 28, SONAR_DIRECT_PATH_MAX_TAPS };

  for (guint k = 0; k < G_N_ELEMENTS (rates); k++) {
    SonarSetup at = *setup;
    at.sample_rate = rates[k];
    g_assert_cmpuint (sonar_direct_path_default_taps (&at), ==, taps[k]);
  }
}

int
main (int argc, char **argv)
{
  static const double exact = 0.0, millimetre_off = 0.001;

  g_test_init (&argc, &argv, NULL);
  g_test_add_data_func ("/direct-path/cancels", &exact, test_cancels);
  g_test_add_data_func ("/direct-path/geometry-off", &millimetre_off,
      test_cancels);
  g_test_add_func ("/direct-path/ringing", test_ringing);
  g_test_add_func ("/direct-path/default-taps", test_default_taps);
  g_test_add_func ("/direct-path/auto-leaves-echoes",
      test_auto_leaves_echoes);
  g_test_add_func ("/direct-path/silence-and-off", test_silence_and_off);
  g_test_add_func ("/direct-path/short-ping", test_short_ping);
  g_test_add_func ("/direct-path/front-end", test_front_end);
  return g_test_run ();
}
