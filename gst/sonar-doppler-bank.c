/* sonar-doppler-bank.c: see sonar-doppler-bank.h. */
#include "sonar-doppler-bank.h"
#include "sonar-error.h"
#include "sonar-memory.h"
#include "sonar-kernels.h"
#include "sonar-interp.h"

#include <gio/gio.h>
#include <math.h>
#include <string.h>

struct _SonarDopplerBank
{
  gint ref_count;
  SonarSetup *setup;
  double v_min, v_step;
  guint n_velocities;
  guint max_length;
  guint *lengths;               /* [i] */
  float *templates;             /* [n][i][max_length] */
  gboolean has_band;
  SonarBand band;
  /* [i][n][n_bins], real and imaginary parts apart: the steering kernels
   * read them so, and splitting them per ping would redo set-up work. */
  float *spectra_re, *spectra_im;
};

double
sonar_doppler_scale (double speed_of_sound, double v)
{
  return (speed_of_sound - v) / (speed_of_sound + v);
}

/* Emission @s (@length samples) at @position samples, read as @interp
 * says (@band_limited for SONAR_TEMPLATE_BAND_LIMITED). */
static float
emission_at (const float *s, guint length, const SonarInterp * band_limited,
    SonarTemplateInterp interp, double position)
{
  const double i = floor (position);
  const guint k = (guint) i;
  const float f = (float) (position - i);

  switch (interp) {
    case SONAR_TEMPLATE_LINEAR:
      return (k < length ? (1.0f - f) * s[k] : 0.0f) +
          (k + 1 < length ? f * s[k + 1] : 0.0f);
    case SONAR_TEMPLATE_NEAREST:
      return f < 0.5f ? (k < length ? s[k] : 0.0f) :
          (k + 1 < length ? s[k + 1] : 0.0f);
    case SONAR_TEMPLATE_BAND_LIMITED:
    default:
      return sonar_interp_at (band_limited, position);
  }
}

SonarDopplerBank *
sonar_doppler_bank_new (SonarSetup * setup, double v_min, double v_max,
    double v_step, GError ** error)
{
  return sonar_doppler_bank_new_with_interp (setup, v_min, v_max, v_step,
      SONAR_TEMPLATE_BAND_LIMITED, error);
}

/* Velocities of the bank from v_min to v_max in steps of v_step; 0 with
 * @error set when they are not allowed. */
static guint
bank_size (double c, double v_min, double v_max, double v_step,
    GError ** error)
{
  double count;

  if (!(isfinite (v_min) && isfinite (v_max) && v_min <= v_max
          && fabs (v_min) < c / 4.0 && fabs (v_max) < c / 4.0)) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS,
        "Doppler bank: velocities %g to %g m/s must satisfy min <= max and "
        "|v| < c / 4 (%.1f m/s)", v_min, v_max, c / 4.0);
    return 0;
  }
  count = v_max > v_min ? floor ((v_max - v_min) / v_step + 1e-9) + 1.0 : 1.0;
  if (!(v_step > 0.0) || count > SONAR_MAX_BANK_VELOCITIES) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS,
        "Doppler bank: step %g m/s must be positive and give at most %u "
        "velocities between %g and %g m/s", v_step, SONAR_MAX_BANK_VELOCITIES,
        v_min, v_max);
    return 0;
  }
  return (guint) count;
}

/* Samples of the template of an emission of @length samples at velocity
 * @v: the stretched emission ends where alpha t reaches its last sample. */
static guint
template_length (double c, guint length, double v)
{
  return (guint) ceil ((length - 1) / sonar_doppler_scale (c, v)) + 1;
}

/* The FFT of a whole ping plus the longest template (linear, not circular,
 * correlations) on the set-up's band. */
static void
ping_band_init (SonarBand * band, const SonarSetup * setup, guint max_length)
{
  sonar_band_init (band, setup->sample_rate, setup->ping_length + max_length,
      setup->band_low, setup->band_high);
}

guint64
sonar_doppler_bank_memory (const SonarSetup * setup, double v_min,
    double v_max, double v_step, guint * n_velocities, SonarBand * ping_band)
{
  const double c = setup->speed_of_sound;
  const guint n_emitters = setup->geometry.n_emitters;
  guint max_length;
  guint64 templates, spectra;

  *n_velocities = bank_size (c, v_min, v_max, v_step, NULL);
  if (!*n_velocities) {
    memset (ping_band, 0, sizeof (*ping_band));
    return 0;
  }
  /* alpha falls as v grows: the longest template is at an end. */
  max_length = MAX (template_length (c, setup->waveform_length, v_min),
      template_length (c, setup->waveform_length, v_max));
  ping_band_init (ping_band, setup, max_length);
  templates = sonar_memory_array (sonar_memory_array (n_emitters,
          *n_velocities), sizeof (float) * (guint64) max_length);
  /* Split spectra: real and imaginary parts, float each. */
  spectra = sonar_memory_array (sonar_memory_array (n_emitters,
          *n_velocities), 2 * sizeof (float) * (guint64) ping_band->n_bins);
  return sonar_memory_add (templates, spectra);
}

SonarDopplerBank *
sonar_doppler_bank_new_with_interp (SonarSetup * setup, double v_min,
    double v_max, double v_step, SonarTemplateInterp interp, GError ** error)
{
  const double c = setup->speed_of_sound;
  const guint n_emitters = setup->geometry.n_emitters;
  const guint length = setup->waveform_length;
  SonarDopplerBank *bank;
  guint count;

  count = bank_size (c, v_min, v_max, v_step, error);
  if (!count)
    return NULL;

  bank = g_new0 (SonarDopplerBank, 1);
  bank->ref_count = 1;
  bank->setup = sonar_setup_ref (setup);
  bank->v_min = v_min;
  bank->v_step = v_step;
  bank->n_velocities = count;
  bank->lengths = g_new (guint, bank->n_velocities);
  for (guint i = 0; i < bank->n_velocities; i++) {
    bank->lengths[i] = template_length (c, length,
        sonar_doppler_bank_velocity (bank, i));
    bank->max_length = MAX (bank->max_length, bank->lengths[i]);
  }
  bank->templates = g_new0 (float, (gsize) n_emitters * bank->n_velocities *
      bank->max_length);

  for (guint n = 0; n < n_emitters; n++) {
    const float *emission = sonar_setup_waveform (setup, n);
    g_autoptr (SonarInterp) band_limited = sonar_interp_new (emission,
        length);
    for (guint i = 0; i < bank->n_velocities; i++) {
      const double alpha = sonar_doppler_scale (c,
          sonar_doppler_bank_velocity (bank, i));
      const float gain = (float) sqrt (alpha);
      float *t = bank->templates + ((gsize) n * bank->n_velocities + i) *
          bank->max_length;
      for (guint k = 0; k < bank->lengths[i]; k++)
        t[k] = gain * emission_at (emission, length, band_limited, interp,
            alpha * k);
    }
  }
  return bank;
}

SonarDopplerBank *
sonar_doppler_bank_ref (SonarDopplerBank * bank)
{
  g_atomic_int_inc (&bank->ref_count);
  return bank;
}

void
sonar_doppler_bank_unref (SonarDopplerBank * bank)
{
  if (bank && g_atomic_int_dec_and_test (&bank->ref_count)) {
    sonar_setup_unref (bank->setup);
    g_free (bank->lengths);
    g_free (bank->templates);
    g_free (bank->spectra_re);
    g_free (bank->spectra_im);
    g_free (bank);
  }
}

SonarSetup *
sonar_doppler_bank_get_setup (const SonarDopplerBank * bank)
{
  return bank->setup;
}

guint
sonar_doppler_bank_n_velocities (const SonarDopplerBank * bank)
{
  return bank->n_velocities;
}

double
sonar_doppler_bank_velocity (const SonarDopplerBank * bank, guint i)
{
  return bank->v_min + i * bank->v_step;
}

double
sonar_doppler_bank_step (const SonarDopplerBank * bank)
{
  return bank->v_step;
}

guint
sonar_doppler_bank_nearest (const SonarDopplerBank * bank, double v)
{
  const double i = round ((v - bank->v_min) / bank->v_step);
  return (guint) CLAMP (i, 0.0, bank->n_velocities - 1.0);
}

guint
sonar_doppler_bank_hypotheses (const SonarDopplerBank * bank, double spacing,
    guint * out)
{
  const guint n_bank = bank->n_velocities;
  const double lo = sonar_doppler_bank_velocity (bank, 0);
  const double hi = sonar_doppler_bank_velocity (bank, n_bank - 1);
  guint n = 0;

  if (lo + 0.5 * spacing < ceil (lo / spacing) * spacing)
    out[n++] = 0;
  for (double k = ceil (lo / spacing); k * spacing <= hi + 1e-9; k++) {
    const guint i = sonar_doppler_bank_nearest (bank, k * spacing);
    if (n == 0 || out[n - 1] != i)
      out[n++] = i;
  }
  if (n == 0 || (out[n - 1] != n_bank - 1
          && sonar_doppler_bank_velocity (bank, out[n - 1]) + 0.5 * spacing
          < hi))
    out[n++] = n_bank - 1;
  return n;
}

guint
sonar_doppler_bank_max_length (const SonarDopplerBank * bank)
{
  return bank->max_length;
}

const float *
sonar_doppler_bank_template (const SonarDopplerBank * bank, guint n, guint i,
    guint * length)
{
  if (length)
    *length = bank->lengths[i];
  return bank->templates + ((gsize) n * bank->n_velocities + i) *
      bank->max_length;
}

void
sonar_doppler_bank_prepare_band (SonarDopplerBank * bank,
    const SonarBand * band)
{
  const guint n_emitters = bank->setup->geometry.n_emitters;
  const gsize per_velocity = (gsize) n_emitters * band->n_bins;
  g_autoptr (SonarSpectrum) analyzer = sonar_spectrum_new (band);
  g_autofree SonarComplex *spectrum = g_new (SonarComplex, band->n_bins);

  g_free (bank->spectra_re);
  g_free (bank->spectra_im);
  bank->spectra_re = g_new (float, per_velocity * bank->n_velocities);
  bank->spectra_im = g_new (float, per_velocity * bank->n_velocities);
  bank->band = *band;
  bank->has_band = TRUE;
  for (guint i = 0; i < bank->n_velocities; i++) {
    for (guint n = 0; n < n_emitters; n++) {
      const gsize at = i * per_velocity + (gsize) n * band->n_bins;
      guint length;
      const float *t = sonar_doppler_bank_template (bank, n, i, &length);
      sonar_spectrum_process (analyzer, t, length, 1, spectrum, NULL);
      sonar_kernel_split (bank->spectra_re + at, bank->spectra_im + at,
          spectrum, band->n_bins);
    }
  }
}

void
sonar_doppler_bank_prepare_ping_band (SonarDopplerBank * bank)
{
  SonarBand band;

  ping_band_init (&band, bank->setup, bank->max_length);
  sonar_doppler_bank_prepare_band (bank, &band);
}

const SonarBand *
sonar_doppler_bank_band (const SonarDopplerBank * bank)
{
  return bank->has_band ? &bank->band : NULL;
}

SonarSplitSpectra
sonar_doppler_bank_spectra (const SonarDopplerBank * bank, guint i)
{
  const gsize at = (gsize) i * bank->setup->geometry.n_emitters *
      bank->band.n_bins;
  SonarSplitSpectra spectra = { NULL, NULL };

  g_return_val_if_fail (bank->has_band, spectra);
  spectra.re = bank->spectra_re + at;
  spectra.im = bank->spectra_im + at;
  return spectra;
}

SonarHypothesis
sonar_doppler_bank_hypothesis (const SonarDopplerBank * bank, guint i)
{
  SonarHypothesis h;

  h.velocity = sonar_doppler_bank_velocity (bank, i);
  h.templates = sonar_doppler_bank_spectra (bank, i);
  return h;
}
