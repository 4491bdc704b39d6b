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
 * alone, the non-finite samples are counted (2) and read as 0. */
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
  expected = g_new (SonarComplex, (gsize) n_channels * band.n_bins);
  out = g_new (SonarComplex, (gsize) n_channels * band.n_bins);
  alone = sonar_spectrum_new (&band);
  for (guint j = 0; j < n_channels; j++) {
    guint bad = 0;
    /* The channel's samples, the non-finite ones as 0, contiguous. */
    for (guint i = 0; i < length; i++) {
      const float x = samples[(gsize) i * n_channels + j];
      one[i] = isfinite (x) ? x : 0.0f;
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

    g_assert_no_error (error);
    memset (out, 0xff, sizeof (SonarComplex) * n_channels * band.n_bins);
    bad = sonar_channel_spectra_process (s, samples, length, out);
    g_assert_cmpuint (bad, ==, 2);
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

int
main (int argc, char **argv)
{
  g_test_init (&argc, &argv, NULL);
  g_test_add_func ("/spectrum/channels", test_channels);
  g_test_add_func ("/spectrum/lengths", test_lengths);
  return g_test_run ();
}
