/* sonar-interp.c: see sonar-interp.h. */
#include "sonar-interp.h"
#include "sonar-fftw.h"
#include "sonar-spectrum.h"

#include <fftw3.h>
#include <string.h>

SonarInterp *
sonar_interp_new (const float *signal, guint length)
{
  SonarInterp *in = g_new0 (SonarInterp, 1);
  const guint n = sonar_fft_good_size (length + 2 * SONAR_INTERP_PAD);
  const guint up_n = n * SONAR_INTERP_OVERSAMPLE;
  float *padded = fftwf_alloc_real (n);
  fftwf_plan forward;

  in->length = length;
  in->fft_size = n;
  in->table_points = SONAR_INTERP_OVERSAMPLE * (length - 1 +
      2 * SONAR_INTERP_PAD) + 1;
  /* One entry before and two after the points, for the 4-point stencil. */
  in->table = g_new (float, in->table_points + 3);
  in->spectrum = fftwf_alloc_complex (n / 2 + 1);
  in->up_spectrum = fftwf_alloc_complex (up_n / 2 + 1);
  in->up_signal = fftwf_alloc_real (up_n);

  sonar_fftw_lock ();
  forward = fftwf_plan_dft_r2c_1d (n, padded, in->spectrum, FFTW_ESTIMATE);
  in->up_plan = fftwf_plan_dft_c2r_1d (up_n, in->up_spectrum, in->up_signal,
      FFTW_ESTIMATE);
  sonar_fftw_unlock ();

  memset (padded, 0, sizeof (float) * n);
  memcpy (padded + SONAR_INTERP_PAD, signal, sizeof (float) * length);
  fftwf_execute (forward);
  sonar_fftw_lock ();
  fftwf_destroy_plan (forward);
  sonar_fftw_unlock ();
  fftwf_free (padded);

  sonar_interp_filter (in, NULL);
  return in;
}

void
sonar_interp_free (SonarInterp * in)
{
  if (!in)
    return;
  sonar_fftw_lock ();
  fftwf_destroy_plan (in->up_plan);
  sonar_fftw_unlock ();
  fftwf_free (in->spectrum);
  fftwf_free (in->up_spectrum);
  fftwf_free (in->up_signal);
  g_free (in->table);
  g_free (in);
}

guint
sonar_interp_n_bins (const SonarInterp * in)
{
  return in->fft_size / 2 + 1;
}

double
sonar_interp_bin_frequency (const SonarInterp * in, guint bin)
{
  return (double) bin / in->fft_size;
}

void
sonar_interp_filter (SonarInterp * in, const float *gains)
{
  const guint n = in->fft_size, up_n = n * SONAR_INTERP_OVERSAMPLE;
  const fftwf_complex *spectrum = in->spectrum;
  fftwf_complex *up = in->up_spectrum;
  const float scale = 1.0f / n;

  memset (up, 0, sizeof (fftwf_complex) * (up_n / 2 + 1));
  for (guint k = 0; k <= n / 2; k++) {
    /* The Nyquist bin of an even size is shared by +-fs/2. */
    const float g = scale * (gains ? gains[k] : 1.0f)
        * (2 * k == n ? 0.5f : 1.0f);
    up[k] = spectrum[k] * g;
  }
  fftwf_execute (in->up_plan);
  /* Entry 0 is one step before -PAD: the end of the periodic signal. */
  in->table[0] = in->up_signal[up_n - 1];
  memcpy (in->table + 1, in->up_signal, sizeof (float) *
      MIN (in->table_points + 2, up_n));
}
