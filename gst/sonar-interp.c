/* sonar-interp.c: see sonar-interp.h. */
#include "sonar-interp.h"
#include "sonar-fftw.h"
#include "sonar-spectrum.h"

#include <complex.h>          /* before fftw3.h: fftwf_complex is C99 */
#include <fftw3.h>
#include <math.h>
#include <string.h>

struct _SonarInterpRebuild
{
  gint ref_count;
  guint fft_size;
  /* Zero-padded spectra, transformed in place into the oversampled signal
   * and its derivative: fftwf_complex[fft_size * OVERSAMPLE / 2 + 1]. */
  fftwf_complex *up[2];
  fftwf_plan plan;
};

static SonarInterpRebuild *
rebuild_new (guint n)
{
  SonarInterpRebuild *r = g_new0 (SonarInterpRebuild, 1);
  const guint up_n = n * SONAR_INTERP_OVERSAMPLE;

  r->ref_count = 1;
  r->fft_size = n;
  r->up[0] = fftwf_alloc_complex (up_n / 2 + 1);
  r->up[1] = fftwf_alloc_complex (up_n / 2 + 1);
  sonar_fftw_lock ();
  r->plan = fftwf_plan_dft_c2r_1d (up_n, r->up[0], (float *) r->up[0],
      FFTW_ESTIMATE);
  sonar_fftw_unlock ();
  return r;
}

static void
rebuild_unref (SonarInterpRebuild * r)
{
  if (!r || !g_atomic_int_dec_and_test (&r->ref_count))
    return;
  sonar_fftw_lock ();
  fftwf_destroy_plan (r->plan);
  sonar_fftw_unlock ();
  fftwf_free (r->up[0]);
  fftwf_free (r->up[1]);
  g_free (r);
}

/* The transform reaches one point further: the end of the last step. */
static guint
table_points (guint length)
{
  return SONAR_INTERP_OVERSAMPLE * (length - 1 + 2 * SONAR_INTERP_PAD) + 1;
}

guint64
sonar_interp_memory (guint length)
{
  const guint64 n = sonar_fft_good_size (length + 2 * SONAR_INTERP_PAD);

  /* The table (4 floats a point), then, while it is made or to filter it,
   * the padded signal, its spectrum and the oversampled rebuild buffers. */
  return 4 * sizeof (float) * (guint64) table_points (length)
      + sizeof (float) * n + sizeof (fftwf_complex) * (n / 2 + 1)
      + 2 * sizeof (fftwf_complex) * (n * SONAR_INTERP_OVERSAMPLE / 2 + 1);
}

static SonarInterp *
interp_new (const float *signal, guint length, gboolean filterable,
    SonarInterp * share)
{
  SonarInterp *in = g_new0 (SonarInterp, 1);
  const guint n = sonar_fft_good_size (length + 2 * SONAR_INTERP_PAD);
  float *padded = fftwf_alloc_real (n);
  fftwf_plan forward;

  in->fft_size = n;
  in->table_points = table_points (length);
  in->table = g_new (float, 4 * (gsize) in->table_points);
  in->spectrum = fftwf_alloc_complex (n / 2 + 1);
  if (share) {
    in->rebuild = share->rebuild;
    g_atomic_int_inc (&in->rebuild->ref_count);
  } else {
    in->rebuild = rebuild_new (n);
  }

  sonar_fftw_lock ();
  forward = fftwf_plan_dft_r2c_1d (n, padded, in->spectrum, FFTW_ESTIMATE);
  sonar_fftw_unlock ();
  memset (padded, 0, sizeof (float) * n);
  memcpy (padded + SONAR_INTERP_PAD, signal, sizeof (float) * length);
  fftwf_execute (forward);
  sonar_fftw_lock ();
  fftwf_destroy_plan (forward);
  sonar_fftw_unlock ();
  fftwf_free (padded);

  sonar_interp_filter (in, NULL);
  if (!filterable) {
    g_clear_pointer (&in->spectrum, fftwf_free);
    g_clear_pointer (&in->rebuild, rebuild_unref);
  }
  return in;
}

SonarInterp *
sonar_interp_new (const float *signal, guint length)
{
  return interp_new (signal, length, FALSE, NULL);
}

SonarInterp *
sonar_interp_new_filterable (const float *signal, guint length,
    SonarInterp * share)
{
  g_return_val_if_fail (!share || (share->rebuild && share->fft_size ==
          sonar_fft_good_size (length + 2 * SONAR_INTERP_PAD)), NULL);
  return interp_new (signal, length, TRUE, share);
}

void
sonar_interp_free (SonarInterp * in)
{
  if (!in)
    return;
  rebuild_unref (in->rebuild);
  fftwf_free (in->spectrum);
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
  /* The derivative per table step, not per sample. */
  const double omega = 2.0 * M_PI / up_n;
  const fftwf_complex *spectrum = in->spectrum;
  SonarInterpRebuild *r = in->rebuild;
  const float *y, *d;

  g_return_if_fail (r != NULL);

  for (int pass = 0; pass < 2; pass++) {
    fftwf_complex *up = r->up[pass];

    memset (up, 0, sizeof (fftwf_complex) * (up_n / 2 + 1));
    for (guint k = 0; k <= n / 2; k++) {
      /* The Nyquist bin of an even size is shared by +-fs/2; its
       * derivative is zero. */
      const double g = (gains ? gains[k] : 1.0) / n
          * (2 * k == n ? (pass ? 0.0 : 0.5) : 1.0);
      const double re = crealf (spectrum[k]) * g;
      const double im = cimagf (spectrum[k]) * g;
      up[k] = pass ? CMPLXF (-im * omega * k, re * omega * k) :
          CMPLXF (re, im);
    }
    fftwf_execute_dft_c2r (r->plan, up, (float *) up);
  }
  y = (const float *) r->up[0];
  d = (const float *) r->up[1];
  for (guint m = 0; m < in->table_points; m++) {
    float *c = in->table + 4 * (gsize) m;
    c[0] = y[m];
    c[1] = d[m];
    c[2] = 3.0f * (y[m + 1] - y[m]) - 2.0f * d[m] - d[m + 1];
    c[3] = 2.0f * (y[m] - y[m + 1]) + d[m] + d[m + 1];
  }
}
