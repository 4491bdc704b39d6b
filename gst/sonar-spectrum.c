/* sonar-spectrum.c: see sonar-spectrum.h. */
#include "sonar-spectrum.h"
#include "sonar-fftw.h"

#include <fftw3.h>
#include <math.h>
#include <string.h>

static GMutex fftw_planner_lock;

void
sonar_fftw_lock (void)
{
  g_mutex_lock (&fftw_planner_lock);
}

void
sonar_fftw_unlock (void)
{
  g_mutex_unlock (&fftw_planner_lock);
}

guint
sonar_fft_good_size (guint n)
{
  for (n = MAX (n, 1);; n++) {
    guint m = n;
    while (m % 2 == 0)
      m /= 2;
    while (m % 3 == 0)
      m /= 3;
    while (m % 5 == 0)
      m /= 5;
    if (m == 1)
      return n;
  }
}

guint
sonar_fft_fast_size (guint n)
{
  guint power = 1;

  while (power < n && 3 * power < n)
    power *= 2;
  return power >= n ? power : 3 * power;
}

void
sonar_band_init (SonarBand * band, double sample_rate, guint min_fft_size,
    double low, double high)
{
  const guint n = sonar_fft_good_size (min_fft_size);
  const double bin_width = sample_rate / n;
  const guint first = (guint) MAX (floor (low / bin_width) - 1.0, 0.0);
  const guint last = (guint) MIN (ceil (high / bin_width) + 1.0, n / 2.0);

  band->sample_rate = sample_rate;
  band->fft_size = n;
  band->first_bin = first;
  band->n_bins = last - first + 1;
}

struct _SonarSpectrum
{
  SonarBand band;
  float *input;
  fftwf_complex *output;
  fftwf_plan plan;
};

SonarSpectrum *
sonar_spectrum_new (const SonarBand * band)
{
  SonarSpectrum *s = g_new0 (SonarSpectrum, 1);

  s->band = *band;
  s->input = fftwf_alloc_real (band->fft_size);
  s->output = fftwf_alloc_complex (band->fft_size / 2 + 1);
  sonar_fftw_lock ();
  s->plan = fftwf_plan_dft_r2c_1d (band->fft_size, s->input, s->output,
      SONAR_FFTW_PLANNING);
  sonar_fftw_unlock ();
  return s;
}

void
sonar_spectrum_free (SonarSpectrum * s)
{
  if (!s)
    return;
  sonar_fftw_lock ();
  fftwf_destroy_plan (s->plan);
  sonar_fftw_unlock ();
  fftwf_free (s->input);
  fftwf_free (s->output);
  g_free (s);
}

void
sonar_spectrum_process (SonarSpectrum * s, const float *signal, gsize length,
    gsize stride, SonarComplex * out, guint * n_bad)
{
  const guint n = s->band.fft_size;
  const gsize used = MIN (length, (gsize) n);
  guint bad = 0;

  for (gsize i = 0; i < used; i++) {
    const float x = signal[i * stride];
    /* One NaN would spread over every bin of the spectrum. */
    if (G_LIKELY (isfinite (x)))
      s->input[i] = x;
    else {
      s->input[i] = 0.0f;
      bad++;
    }
  }
  memset (s->input + used, 0, sizeof (float) * (n - used));
  fftwf_execute (s->plan);
  memcpy (out, s->output + s->band.first_bin,
      sizeof (SonarComplex) * s->band.n_bins);
  if (n_bad)
    *n_bad += bad;
}
