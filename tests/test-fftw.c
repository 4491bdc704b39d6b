/* test-fftw.c: the FFTW wisdom shipped in the core (sonar-fftw.h): FFTW
 * takes it, it plans every transform of the default set-up, plans made
 * from it are bit for bit the same, and wisdom FFTW cannot take leaves
 * planning as it was. */
#include <fftw3.h>
#include <stdlib.h>
#include <string.h>

#include "sonar-doppler-bank.h"
#include "sonar-fftw.h"
#include "sonar-imager.h"
#include "sonar-rng.h"
#include "sonar-spectrum.h"
#include "sonar-test-util.h"
#include "sonar-velocity.h"
#include "sonar-waveform.h"

/* The default set-up's transforms (sonarsrc at 5 m, the fan): the ping's
 * spectrum, the imager's and the velocity gate's inverse transforms. */
#define SPECTRUM_SIZE 21600
#define IMAGING_SIZE 3072

/* FFTW's wisdom now: its first line is this FFTW's configuration
 * signature (version and SIMD codelets), its other lines the entries. */
static char *
export_wisdom (void)
{
  char *fftw_text, *text;

  sonar_fftw_lock ();
  fftw_text = fftwf_export_wisdom_to_string ();
  sonar_fftw_unlock ();
  text = g_strdup (fftw_text);
  free (fftw_text);
  return text;
}

static gboolean
same_configuration (void)
{
  g_autofree char *now = export_wisdom ();
  const char *end = strchr (sonar_fftw_wisdom, '\n');

  /* No signature at all: not FFTW's wisdom, which the tests must see. */
  if (!end)
    return TRUE;
  return strncmp (now, sonar_fftw_wisdom, end - sonar_fftw_wisdom + 1) == 0;
}

/* Wisdom made by another FFTW (a CPU without the generator's SIMD) is
 * refused as a whole, and planning goes on by estimates: only there may
 * the wisdom be missing. */
static gboolean
skip_foreign_wisdom (void)
{
  if (same_configuration ())
    return FALSE;
  g_test_skip ("the shipped wisdom is for another FFTW configuration "
      "(regenerate it: README, \"FFTW wisdom\")");
  return TRUE;
}

static void
test_imported (void)
{
  sonar_fftw_lock ();
  sonar_fftw_unlock ();
  if (skip_foreign_wisdom ())
    return;
  g_assert_true (sonar_fftw_wisdom_imported ());
  g_assert_cmpuint (sonar_fftw_planning (), ==, FFTW_ESTIMATE);
}

/* The core's hot transforms have patient wisdom, for their very shapes
 * (out of place, FFTW's alignment, r2c and backward c2c): FFTW plans
 * them with FFTW_WISDOM_ONLY at FFTW_PATIENT's rigour. */
static void
test_patient_shapes (void)
{
  const unsigned patient_only = FFTW_PATIENT | FFTW_WISDOM_ONLY;
  float *real = fftwf_alloc_real (SPECTRUM_SIZE);
  fftwf_complex *in = fftwf_alloc_complex (SPECTRUM_SIZE);
  fftwf_complex *out = fftwf_alloc_complex (SPECTRUM_SIZE);
  fftwf_plan spectrum, imaging, unaligned;

  sonar_fftw_lock ();
  sonar_fftw_unlock ();
  if (skip_foreign_wisdom ())
    goto done;
  sonar_fftw_lock ();
  spectrum = fftwf_plan_dft_r2c_1d (SPECTRUM_SIZE, real, out, patient_only);
  imaging = fftwf_plan_dft_1d (IMAGING_SIZE, in, out, FFTW_BACKWARD,
      patient_only);
  /* Another shape has none: the check can fail. */
  unaligned = fftwf_plan_dft_1d (IMAGING_SIZE, in + 1, out, FFTW_BACKWARD,
      patient_only);
  sonar_fftw_unlock ();
  g_assert_nonnull (spectrum);
  g_assert_nonnull (imaging);
  g_assert_null (unaligned);
  sonar_fftw_lock ();
  fftwf_destroy_plan (spectrum);
  fftwf_destroy_plan (imaging);
  sonar_fftw_unlock ();
done:
  fftwf_free (real);
  fftwf_free (in);
  fftwf_free (out);
}

/* The core's objects for the default set-up plan every transform from the
 * wisdom: FFTW records a problem it estimates, so its wisdom would grow. */
static void
test_default_setup_planned (void)
{
  SonarGeometry geometry;
  SonarWaveformParams wp;
  g_autoptr (SonarSetup) setup = NULL;
  g_autoptr (GError) error = NULL;
  g_autofree char *before = NULL, *after = NULL;
  SonarDopplerBank *bank;
  SonarChannelSpectra *spectra;
  SonarImager *imager;
  SonarVelocityEstimator *est;
  SonarImagerParams ip;
  SonarVelocityParams vp;
  const SonarBand *band;
  guint ping_length;

  sonar_fftw_lock ();
  sonar_fftw_unlock ();
  if (skip_foreign_wisdom ())
    return;
  sonar_geometry_init_default (&geometry);
  sonar_waveform_params_init_default (&wp);
  ping_length = sonar_ping_length_for_range (&geometry,
      SONAR_DEFAULT_SPEED_OF_SOUND, wp.sample_rate, wp.length, 5.0);
  sonar_geometry_clear (&geometry);
  before = export_wisdom ();

  setup = sonar_test_default_setup (ping_length);
  bank = sonar_doppler_bank_new (setup, -7.0, 7.0, 0.05, &error);
  g_assert_no_error (error);
  sonar_doppler_bank_prepare_ping_band (bank);
  band = sonar_doppler_bank_band (bank);
  g_assert_cmpuint (band->fft_size, ==, SPECTRUM_SIZE);
  spectra = sonar_channel_spectra_new (band, setup->geometry.n_microphones,
      0, &error);
  g_assert_no_error (error);
  sonar_imager_params_init_default (&ip);
  imager = sonar_imager_new (setup, band, &ip, &error);
  g_assert_no_error (error);
  sonar_velocity_params_init_default (&vp);
  est = sonar_velocity_estimator_new (bank, sonar_imager_grid (imager), &vp,
      &error);
  g_assert_no_error (error);

  after = export_wisdom ();
  g_assert_cmpstr (after, ==, before);
  sonar_velocity_estimator_free (est);
  sonar_imager_free (imager);
  sonar_channel_spectra_free (spectra);
  sonar_doppler_bank_unref (bank);
}

/* Two plans of the ping's spectrum give the same bits. */
static void
test_same_bits (void)
{
  const guint n_bins = SPECTRUM_SIZE / 2 + 1;
  SonarBand band;
  SonarRng rng;
  g_autofree float *signal = g_new (float, SPECTRUM_SIZE);
  g_autofree SonarComplex *first = NULL, *second = NULL;
  SonarSpectrum *a, *b;

  sonar_band_init (&band, 450000.0, SPECTRUM_SIZE, 0.0, 225000.0);
  g_assert_cmpuint (band.fft_size, ==, SPECTRUM_SIZE);
  g_assert_cmpuint (band.n_bins, ==, n_bins);
  sonar_rng_init (&rng, 11, 0);
  for (guint i = 0; i < SPECTRUM_SIZE; i++)
    signal[i] = (float) sonar_rng_gaussian (&rng);
  first = g_new (SonarComplex, n_bins);
  second = g_new (SonarComplex, n_bins);
  a = sonar_spectrum_new (&band);
  sonar_spectrum_process (a, signal, SPECTRUM_SIZE, 1, first, NULL);
  sonar_spectrum_free (a);
  b = sonar_spectrum_new (&band);
  sonar_spectrum_process (b, signal, SPECTRUM_SIZE, 1, second, NULL);
  sonar_spectrum_free (b);
  g_assert_cmpmem (first, sizeof (SonarComplex) * n_bins, second,
      sizeof (SonarComplex) * n_bins);
}

/* Wisdom FFTW cannot take (another configuration's signature; a codelet
 * this FFTW lacks, as a SIMD one on a CPU without it) is refused whole,
 * the wisdom held is kept, and planning works on. */
static void
test_foreign_refused (void)
{
  g_autofree char *before = NULL, *after = NULL;
  g_autofree char *other_signature = NULL, *unknown_codelet = NULL;
  const char *end = strchr (sonar_fftw_wisdom, '\n');
  float *real = fftwf_alloc_real (SPECTRUM_SIZE);
  fftwf_complex *out = fftwf_alloc_complex (SPECTRUM_SIZE);
  fftwf_plan plan;

  g_assert_nonnull (end);
  sonar_fftw_lock ();
  sonar_fftw_unlock ();
  before = export_wisdom ();
  /* The signature's last word, changed. */
  other_signature = g_strdup (sonar_fftw_wisdom);
  other_signature[end - sonar_fftw_wisdom - 1] ^= 1;
  /* This FFTW's own signature, an entry with a solver it does not have. */
  unknown_codelet = g_strdup_printf ("%.*s  (fftwf_codelet_n1fv_32_nosuchisa"
      " 0 #x11048 #x11048 #x0 #x1 #x2 #x3 #x4)\n)\n",
      (int) (strchr (before, '\n') - before + 1), before);

  sonar_fftw_lock ();
  g_assert_cmpint (fftwf_import_wisdom_from_string (other_signature), ==, 0);
  g_assert_cmpint (fftwf_import_wisdom_from_string (unknown_codelet), ==, 0);
  plan = fftwf_plan_dft_r2c_1d (SPECTRUM_SIZE, real, out,
      SONAR_FFTW_PLANNING);
  sonar_fftw_unlock ();
  g_assert_nonnull (plan);
  after = export_wisdom ();
  g_assert_cmpstr (after, ==, before);
  sonar_fftw_lock ();
  fftwf_destroy_plan (plan);
  sonar_fftw_unlock ();
  fftwf_free (real);
  fftwf_free (out);
}

int
main (int argc, char **argv)
{
  g_test_init (&argc, &argv, NULL);
  g_test_add_func ("/fftw/imported", test_imported);
  g_test_add_func ("/fftw/patient-shapes", test_patient_shapes);
  g_test_add_func ("/fftw/default-setup-planned", test_default_setup_planned);
  g_test_add_func ("/fftw/same-bits", test_same_bits);
  g_test_add_func ("/fftw/foreign-refused", test_foreign_refused);
  return g_test_run ();
}
