/* sonar-interp.h: a sampled, band-limited signal read at any instant.
 *
 * The signal is turned once into a table oversampled SONAR_INTERP_OVERSAMPLE
 * times by FFT zero-padding (the exact band-limited interpolation of the
 * zero-extended signal), then read with 4-point Lagrange interpolation:
 * the error is about -100 dB of the peak for content up to 80 kHz at
 * 450 kHz. The band-limited signal reaches SONAR_INTERP_PAD samples beyond
 * each end (its interpolation tails) and is zero further out.
 *
 * Both the simulator (echo synthesis) and the Doppler bank (time-scaled
 * templates) read waveforms through this one interpolator.
 */
#ifndef SONAR_INTERP_H
#define SONAR_INTERP_H

#include <glib.h>

G_BEGIN_DECLS

#define SONAR_INTERP_OVERSAMPLE 8
#define SONAR_INTERP_PAD 32

typedef struct
{
  /*< private >*/
  guint length;                 /* samples of the signal */
  guint table_points;
  float *table;                 /* entry m + 1: the signal at m / OVERSAMPLE - PAD */
  guint fft_size;
  void *spectrum;               /* fftwf_complex[fft_size / 2 + 1], unfiltered */
  void *up_spectrum;
  float *up_signal;
  void *up_plan;
} SonarInterp;

SonarInterp *sonar_interp_new (const float *signal, guint length);
void sonar_interp_free (SonarInterp * interp);

/* Bins of the signal's spectrum (for sonar_interp_filter) and their
 * frequency in cycles per sample. */
guint sonar_interp_n_bins (const SonarInterp * interp);
double sonar_interp_bin_frequency (const SonarInterp * interp, guint bin);

/* Rebuilds the table from the signal filtered by real @gains per bin (NULL:
 * the signal itself). */
void sonar_interp_filter (SonarInterp * interp, const float *gains);

/* The signal at @position samples (any real number). */
static inline float
sonar_interp_at (const SonarInterp * interp, double position)
{
  const double x = (position + SONAR_INTERP_PAD) * SONAR_INTERP_OVERSAMPLE;
  int k;
  float f, fp1, fm1, fm2;
  const float *p;

  if (!(x >= 0.0 && x <= interp->table_points - 1))
    return 0.0f;
  k = (int) x;
  f = (float) (x - k);
  p = interp->table + k;
  fp1 = f + 1.0f;
  fm1 = f - 1.0f;
  fm2 = f - 2.0f;
  return (p[3] * fp1 * f * fm1 - p[0] * f * fm1 * fm2) * (1.0f / 6.0f)
      + (p[1] * fp1 * fm1 * fm2 - p[2] * fp1 * f * fm2) * 0.5f;
}

G_DEFINE_AUTOPTR_CLEANUP_FUNC (SonarInterp, sonar_interp_free)

G_END_DECLS

#endif
