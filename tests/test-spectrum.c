/* test-spectrum.c: the front end that takes recordings onto the band
 * (sonar-spectrum.h): the spectra of a ping's interleaved channels, shared
 * by workers, against each channel's own transform. */
#include <math.h>
#include <string.h>

#include "sonar-rng.h"
#include "sonar-spectrum.h"
#include "sonar-test-util.h"

/* A ping of 32 channels of Gaussian noise, 17262 frames at 450 kHz on the
 * 20-80 kHz band, with a NaN and an infinity in two channels: for 1, 2,
 * 3, 5 and 64 workers (more than channels: capped) each channel's
 * spectrum is bit for bit what sonar_spectrum_process () makes of it
 * alone, the non-finite samples are counted (2) and read as 0, and so is
 * a glitch of 10^6 in a third channel (counted apart). */
static void
test_channels (void)
{
  const guint n_channels = 32, length = 17262;
  const guint threads[] = { 1, 2, 3, 5, 64 };
  SonarBand band;
  SonarRng rng;
  g_autofree float *samples = g_new (float, (gsize) n_channels * length);
  g_autofree float *one = g_new (float, length);
  g_autofree SonarComplex *expected = NULL;
  g_autofree SonarComplex *out = NULL;
  g_autoptr (SonarSpectrum) alone = NULL;

  sonar_band_init (&band, 450000.0, length + 4000, 20000.0, 80000.0);
  sonar_rng_init (&rng, 7, 0);
  for (gsize k = 0; k < (gsize) n_channels * length; k++)
    samples[k] = (float) sonar_rng_gaussian (&rng);
  samples[(gsize) 100 * n_channels + 3] = NAN;
  samples[(gsize) 9000 * n_channels + 31] = INFINITY;
  samples[(gsize) 4000 * n_channels + 5] = 1e6f;
  expected = g_new (SonarComplex, (gsize) n_channels * band.n_bins);
  out = g_new (SonarComplex, (gsize) n_channels * band.n_bins);
  alone = sonar_spectrum_new (&band);
  for (guint j = 0; j < n_channels; j++) {
    guint bad = 0;
    /* The channel's samples, the non-finite ones as 0, contiguous. */
    for (guint i = 0; i < length; i++) {
      const float x = samples[(gsize) i * n_channels + j];
      one[i] = isfinite (x) && x != 1e6f ? x : 0.0f;
    }
    sonar_spectrum_process (alone, one, length, 1,
        expected + (gsize) j * band.n_bins, &bad);
    g_assert_cmpuint (bad, ==, 0);
  }
  for (guint t = 0; t < G_N_ELEMENTS (threads); t++) {
    g_autoptr (GError) error = NULL;
    g_autoptr (SonarChannelSpectra) s = sonar_channel_spectra_new (&band,
        n_channels, threads[t], &error);
    guint bad;
    float largest;

    g_assert_no_error (error);
    memset (out, 0xff, sizeof (SonarComplex) * n_channels * band.n_bins);
    bad = sonar_channel_spectra_process (s, samples, length, out);
    g_assert_cmpuint (bad, ==, 2);
    g_assert_cmpuint (sonar_channel_spectra_glitches (s, &largest), ==, 1);
    g_assert_cmpfloat (largest, ==, 1e6f);
    g_assert_cmpmem (out, sizeof (SonarComplex) * n_channels * band.n_bins,
        expected, sizeof (SonarComplex) * n_channels * band.n_bins);
  }
}

/* Pings of changing lengths through the same front end (the padding
 * is zeroed only where an earlier, longer ping left samples): longer
 * than the FFT (cut), shorter, longer again and very short, each
 * channel's spectrum bit for bit that of a front end made for it. */
static void
test_lengths (void)
{
  const guint n_channels = 20, max_length = 30000;
  const guint lengths[] = { 17262, max_length, 9000, 17262, 100, 21600 };
  SonarBand band;
  SonarRng rng;
  g_autofree float *samples = g_new (float,
      (gsize) n_channels * max_length);
  g_autoptr (GError) error = NULL;
  g_autoptr (SonarChannelSpectra) kept = NULL;
  g_autoptr (SonarSpectrum) kept_alone = NULL;
  g_autofree SonarComplex *out = NULL, *expected = NULL;

  sonar_band_init (&band, 450000.0, 17262 + 4000, 20000.0, 80000.0);
  g_assert_cmpuint (band.fft_size, <, max_length);
  sonar_rng_init (&rng, 8, 0);
  for (gsize k = 0; k < (gsize) n_channels * max_length; k++)
    samples[k] = (float) sonar_rng_gaussian (&rng);
  out = g_new (SonarComplex, (gsize) n_channels * band.n_bins);
  expected = g_new (SonarComplex, (gsize) n_channels * band.n_bins);
  kept = sonar_channel_spectra_new (&band, n_channels, 2, &error);
  g_assert_no_error (error);
  kept_alone = sonar_spectrum_new (&band);
  for (guint t = 0; t < G_N_ELEMENTS (lengths); t++) {
    g_autoptr (SonarChannelSpectra) fresh =
        sonar_channel_spectra_new (&band, n_channels, 1, &error);
    g_autoptr (SonarSpectrum) fresh_alone = sonar_spectrum_new (&band);

    g_assert_no_error (error);
    g_assert_cmpuint (sonar_channel_spectra_process (fresh, samples,
            lengths[t], expected), ==, 0);
    g_assert_cmpuint (sonar_channel_spectra_process (kept, samples,
            lengths[t], out), ==, 0);
    g_assert_cmpmem (out, sizeof (SonarComplex) * n_channels * band.n_bins,
        expected, sizeof (SonarComplex) * n_channels * band.n_bins);
    sonar_spectrum_process (fresh_alone, samples + 3, lengths[t],
        n_channels, expected, NULL);
    sonar_spectrum_process (kept_alone, samples + 3, lengths[t],
        n_channels, out, NULL);
    g_assert_cmpmem (out, sizeof (SonarComplex) * band.n_bins, expected,
        sizeof (SonarComplex) * band.n_bins);
  }
}

/* Adds to @x[@n] a tone of @amplitude at @frequency (of the sample rate)
 * from sample @start for @length samples, gated hard or (@hann) by a Hann
 * window. */
static void
add_tone (float *x, gsize n, gsize start, gsize length, double frequency,
    double amplitude, double phase, gboolean hann)
{
  for (gsize i = start; i < MIN (n, start + length); i++) {
    const double gate = hann ? 0.5 - 0.5 * cos (2.0 * G_PI * (i - start) /
        (length - 1)) : 1.0;
    x[i] += (float) (amplitude * gate * cos (2.0 * G_PI * frequency *
            (i - start) + phase));
  }
}

/* Glitches (sonar_remove_glitches ()): what no band-limited signal does,
 * however loud, and only that, is zeroed.
 * - Kept, bit for bit: unit noise with, 10^4 to 10^6 times louder, the
 *   band's tones from 20 to 80 kHz at 450 kHz, each hard-gated (its
 *   onset a step) or Hann-gated, alone or together (a direct path), a
 *   Hann-gated burst of 8 periods at 50 kHz, a tone clipped at half its
 *   amplitude, and a run of SONAR_GLITCH_MAX_RUN + 1 loud samples
 *   (longer than a glitch).
 * - Zeroed: one sample of 10^5 in the noise, a run of 3, one of 9 (a
 *   review's false objects) and one of SONAR_GLITCH_MAX_RUN, and a sample
 *   of 10^8 on the band's 13 tones of 10^5 together (its own sample of
 *   the tone goes with it); the count and the largest. */
static void
test_glitches (void)
{
  const gsize n = 17262;
  const double rate = 450000.0;
  SonarRng rng;
  g_autofree float *noise = g_new (float, n);
  g_autofree float *x = g_new (float, n);
  g_autofree float *expected = g_new (float, n);
  float largest = 0.0f;

  sonar_rng_init (&rng, 9, 0);
  for (gsize i = 0; i < n; i++)
    noise[i] = (float) sonar_rng_gaussian (&rng);

  for (double f = 20000.0; f <= 80000.0; f += 5000.0) {
    for (int hann = 0; hann < 2; hann++) {
      for (double amplitude = 1e4; amplitude <= 1e6; amplitude *= 10.0) {
        memcpy (x, noise, sizeof (float) * n);
        add_tone (x, n, 3000, 2000, f / rate, amplitude, f / 7e3, hann);
        memcpy (expected, x, sizeof (float) * n);
        g_assert_cmpuint (sonar_remove_glitches (x, n, &largest, NULL), ==, 0);
        g_assert_cmpmem (x, sizeof (float) * n, expected,
            sizeof (float) * n);
      }
    }
  }
  /* All the band's tones at once, as emitters heard straight. */
  memcpy (x, noise, sizeof (float) * n);
  for (double f = 20000.0; f <= 80000.0; f += 5000.0)
    add_tone (x, n, 200, 4000, f / rate, 1e5, f / 3e3, FALSE);
  /* A short burst well in the band: 8 periods at 50 kHz (72 samples),
   * Hann-gated. */
  add_tone (x, n, 8000, 72, 50000.0 / rate, 1e6, 0.0, TRUE);
  /* A tone clipped at half its amplitude. */
  add_tone (x, n, 10000, 500, 30000.0 / rate, 1e6, 0.0, FALSE);
  for (gsize i = 10000; i < 10500; i++)
    x[i] = CLAMP (x[i], -5e5f, 5e5f);
  /* Longer than a glitch. */
  for (gsize i = 14000; i < 14000 + SONAR_GLITCH_MAX_RUN + 1; i++)
    x[i] = 1e5f;
  memcpy (expected, x, sizeof (float) * n);
  g_assert_cmpuint (sonar_remove_glitches (x, n, &largest, NULL), ==, 0);
  g_assert_cmpmem (x, sizeof (float) * n, expected, sizeof (float) * n);
  g_assert_cmpfloat (largest, ==, 0.0f);

  /* Glitches, among all that. */
  x[5000] = 1e5f;
  x[12000] = -2e4f;
  x[12001] = 3e4f;
  x[12002] = 1e4f;
  for (gsize i = 16000; i < 16000 + SONAR_GLITCH_MAX_RUN; i++)
    x[i] = -4e4f;
  for (gsize i = 6000; i < 6009; i++)
    x[i] = 1e4f;
  x[1500] = 1e8f;
  memcpy (expected, x, sizeof (float) * n);
  expected[5000] = expected[12000] = expected[12001] = expected[12002] = 0;
  for (gsize i = 16000; i < 16000 + SONAR_GLITCH_MAX_RUN; i++)
    expected[i] = 0.0f;
  for (gsize i = 6000; i < 6009; i++)
    expected[i] = 0.0f;
  expected[1500] = 0.0f;
  g_assert_cmpuint (sonar_remove_glitches (x, n, &largest, NULL), ==,
      1 + 3 + 9 + SONAR_GLITCH_MAX_RUN + 1);
  g_assert_cmpmem (x, sizeof (float) * n, expected, sizeof (float) * n);
  g_assert_cmpfloat (largest, ==, 1e8f);
  g_assert_cmpuint (sonar_remove_glitches (x, 0, NULL, NULL), ==, 0);
}

/* Loud channels: in a ping of unit noise on 32 channels, channel 7 with a
 * 40 kHz hum of 100 (37 dB over the noise) is read as 0 and reported (the
 * first, 29-30 dB over the median channel's quiet peak), channel 12 at
 * three times the gain (9.5 dB) is kept; every other channel's spectrum is
 * its own, bit for bit. */
static void
test_loud_channels (void)
{
  const guint n_channels = 32, length = 17262;
  SonarBand band;
  SonarRng rng;
  g_autofree float *samples = g_new (float, (gsize) n_channels * length);
  g_autofree float *one = g_new (float, length);
  g_autofree SonarComplex *expected = NULL, *out = NULL;
  g_autoptr (SonarSpectrum) alone = NULL;
  g_autoptr (SonarChannelSpectra) s = NULL;
  g_autoptr (GError) error = NULL;
  guint first;
  double db;

  sonar_band_init (&band, 450000.0, length + 4000, 20000.0, 80000.0);
  sonar_rng_init (&rng, 11, 0);
  for (gsize i = 0; i < (gsize) n_channels * length; i++)
    samples[i] = (float) sonar_rng_gaussian (&rng);
  for (guint i = 0; i < length; i++) {
    samples[(gsize) i * n_channels + 7] += (float) (100.0 * sin (2.0 * G_PI *
            40000.0 / 450000.0 * i));
    samples[(gsize) i * n_channels + 12] *= 3.0f;
  }
  expected = g_new0 (SonarComplex, (gsize) n_channels * band.n_bins);
  out = g_new (SonarComplex, (gsize) n_channels * band.n_bins);
  alone = sonar_spectrum_new (&band);
  for (guint j = 0; j < n_channels; j++) {
    if (j == 7)
      continue;
    for (guint i = 0; i < length; i++)
      one[i] = samples[(gsize) i * n_channels + j];
    sonar_spectrum_process (alone, one, length, 1,
        expected + (gsize) j * band.n_bins, NULL);
  }
  s = sonar_channel_spectra_new (&band, n_channels, 2, &error);
  g_assert_no_error (error);
  sonar_channel_spectra_process (s, samples, length, out);
  g_assert_cmpuint (sonar_channel_spectra_loud (s, &first, &db), ==, 1);
  g_assert_cmpuint (first, ==, 7);
  g_test_message ("channel 7: %.1f dB over the median", db);
  g_assert_cmpfloat (db, >, 28.0);
  g_assert_cmpfloat (db, <, 32.0);
  g_assert_cmpmem (out, sizeof (SonarComplex) * n_channels * band.n_bins,
      expected, sizeof (SonarComplex) * n_channels * band.n_bins);
  /* The next ping without it: nothing loud. */
  for (guint i = 0; i < length; i++)
    samples[(gsize) i * n_channels + 7] = samples[(gsize) i * n_channels + 6];
  sonar_channel_spectra_process (s, samples, length, out);
  g_assert_cmpuint (sonar_channel_spectra_loud (s, NULL, NULL), ==, 0);
}

int
main (int argc, char **argv)
{
  g_test_init (&argc, &argv, NULL);
  g_test_add_func ("/spectrum/channels", test_channels);
  g_test_add_func ("/spectrum/lengths", test_lengths);
  g_test_add_func ("/spectrum/glitches", test_glitches);
  g_test_add_func ("/spectrum/loud-channels", test_loud_channels);
  return g_test_run ();
}
