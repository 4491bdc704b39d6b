/* sonar-test-util.c: see sonar-test-util.h. Uses double-precision FFTW so
 * that the measurement is far more accurate than what it measures. */
#include "sonar-test-util.h"
#include "sonar-waveform.h"

#include <fftw3.h>
#include <glib/gstdio.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static gsize
next_fast_size (gsize n)
{
  gsize size = 1;
  while (size < n)
    size <<= 1;
  return size;
}

double *
sonar_test_xcorr (const float *x, gsize nx, const float *y, gsize ny)
{
  const gsize n_out = nx + ny - 1;
  const gsize size = next_fast_size (n_out);
  double *a = fftw_alloc_real (size), *b = fftw_alloc_real (size);
  fftw_complex *fa = fftw_alloc_complex (size / 2 + 1);
  fftw_complex *fb = fftw_alloc_complex (size / 2 + 1);
  fftw_plan pa = fftw_plan_dft_r2c_1d (size, a, fa, FFTW_ESTIMATE);
  fftw_plan pb = fftw_plan_dft_r2c_1d (size, b, fb, FFTW_ESTIMATE);
  fftw_plan pinv = fftw_plan_dft_c2r_1d (size, fa, a, FFTW_ESTIMATE);
  double *r = g_new (double, n_out);

  memset (a, 0, size * sizeof (double));
  memset (b, 0, size * sizeof (double));
  for (gsize i = 0; i < nx; i++)
    a[i] = x[i];
  for (gsize i = 0; i < ny; i++)
    b[i] = y[i];
  fftw_execute (pa);
  fftw_execute (pb);
  for (gsize k = 0; k < size / 2 + 1; k++) {
    /* complex.h comes first (sonar-spectrum.h): fftw_complex is C99's. */
    fa[k] = fa[k] * conj (fb[k]) / size;
  }
  fftw_execute (pinv);
  /* a[lag mod size] holds lag; negative lags wrap to the end. */
  for (gsize k = 0; k < n_out; k++) {
    const gssize lag = (gssize) k - (gssize) (ny - 1);
    r[k] = a[(lag + (gssize) size) % (gssize) size];
  }
  fftw_destroy_plan (pa);
  fftw_destroy_plan (pb);
  fftw_destroy_plan (pinv);
  fftw_free (a);
  fftw_free (b);
  fftw_free (fa);
  fftw_free (fb);
  return r;
}

double
sonar_test_delay (const float *x, gsize nx, const float *y, gsize ny,
    double min_lag, double max_lag, double *peak)
{
  enum { UP = 32 };
  const gsize size = next_fast_size (nx + ny);
  const gsize up_size = size * UP;
  double *a = fftw_alloc_real (size), *b = fftw_alloc_real (size);
  double *r = fftw_alloc_real (up_size);
  fftw_complex *fa = fftw_alloc_complex (size / 2 + 1);
  fftw_complex *fb = fftw_alloc_complex (size / 2 + 1);
  fftw_complex *fr = fftw_alloc_complex (up_size / 2 + 1);
  fftw_plan pa = fftw_plan_dft_r2c_1d (size, a, fa, FFTW_ESTIMATE);
  fftw_plan pb = fftw_plan_dft_r2c_1d (size, b, fb, FFTW_ESTIMATE);
  fftw_plan pinv = fftw_plan_dft_c2r_1d (up_size, fr, r, FFTW_ESTIMATE);
  double best = -INFINITY, best_lag = 0.0;
  gssize best_k = 0;

  memset (a, 0, size * sizeof (double));
  memset (b, 0, size * sizeof (double));
  for (gsize i = 0; i < nx; i++)
    a[i] = x[i];
  for (gsize i = 0; i < ny; i++)
    b[i] = y[i];
  fftw_execute (pa);
  fftw_execute (pb);
  memset (fr, 0, (up_size / 2 + 1) * sizeof (fftw_complex));
  /* Zero-padding the cross spectrum upsamples the correlation by UP.
   * The Nyquist bin is dropped: the sonar band is far below it. */
  for (gsize k = 0; k < size / 2; k++) {
    fr[k] = fa[k] * conj (fb[k]) / size;
  }
  fftw_execute (pinv);

  for (gssize k = (gssize) floor (min_lag * UP);
      k <= (gssize) ceil (max_lag * UP); k++) {
    const double v = r[(k + (gssize) up_size) % (gssize) up_size];
    if (v > best) {
      best = v;
      best_k = k;
    }
  }
  {
    const double ym = r[(best_k - 1 + (gssize) up_size) % (gssize) up_size];
    const double y0 = best;
    const double yp = r[(best_k + 1 + (gssize) up_size) % (gssize) up_size];
    const double denom = ym - 2.0 * y0 + yp;
    const double offset = denom < 0.0 ? 0.5 * (ym - yp) / denom : 0.0;
    best_lag = (best_k + offset) / UP;
    if (peak)
      *peak = y0 - 0.25 * (ym - yp) * offset;
  }
  fftw_destroy_plan (pa);
  fftw_destroy_plan (pb);
  fftw_destroy_plan (pinv);
  fftw_free (a);
  fftw_free (b);
  fftw_free (r);
  fftw_free (fa);
  fftw_free (fb);
  fftw_free (fr);
  return best_lag;
}

double
sonar_test_max_abs (const double *v, gsize n, gsize * index)
{
  double best = -1.0;
  gsize best_i = 0;
  for (gsize i = 0; i < n; i++) {
    if (fabs (v[i]) > best) {
      best = fabs (v[i]);
      best_i = i;
    }
  }
  if (index)
    *index = best_i;
  return best;
}

gboolean
sonar_test_sanitized (void)
{
  return g_getenv ("SONAR_SANITIZED") != NULL;
}

char *
sonar_test_source_path (const char *relative)
{
  const char *root = g_getenv ("SONAR_SOURCE_DIR");
  return g_build_filename (root ? root : ".", relative, NULL);
}

static GPtrArray *temp_files;

static void
remove_temp_files (void)
{
  for (guint i = 0; temp_files && i < temp_files->len; i++) {
    const char *path = g_ptr_array_index (temp_files, i);
    g_autofree char *dir = g_path_get_dirname (path);
    g_unlink (path);
    g_rmdir (dir);
  }
}

char *
sonar_test_write_temp (const char *basename, const char *text)
{
  char *dir = g_dir_make_tmp ("sonar-test-XXXXXX", NULL);
  char *path = g_build_filename (dir, basename, NULL);
  g_assert_true (g_file_set_contents (path, text, -1, NULL));
  if (!temp_files) {
    temp_files = g_ptr_array_new_with_free_func (g_free);
    atexit (remove_temp_files);
  }
  g_ptr_array_add (temp_files, g_strdup (path));
  g_free (dir);
  return path;
}

SonarSetup *
sonar_test_setup_new (SonarGeometry * geometry, guint ping_length)
{
  SonarWaveformParams wp;
  float *w;
  SonarSetup *setup;

  sonar_waveform_params_init_default (&wp);
  wp.n_emitters = geometry->n_emitters;
  w = g_new (float, wp.n_emitters * wp.length);
  g_assert_true (sonar_waveform_generate (&wp, w, NULL));
  setup = sonar_setup_new (&(SonarSetupParams) {
        .sample_rate = wp.sample_rate,
        .speed_of_sound = SONAR_DEFAULT_SPEED_OF_SOUND,
        .band_low = wp.band_low, .band_high = wp.band_high,
        .geometry = geometry, .waveform_length = wp.length, .waveforms = w,
        .ping_length = ping_length}, NULL);
  g_assert_nonnull (setup);
  g_free (w);
  sonar_geometry_clear (geometry);
  return setup;
}

SonarSetup *
sonar_test_default_setup (guint ping_length)
{
  SonarGeometry g;

  sonar_geometry_init_default (&g);
  return sonar_test_setup_new (&g, ping_length);
}

static void
chain_buffers (SonarTestChain * c, guint max_template)
{
  const guint n_mics = c->setup->geometry.n_microphones;

  sonar_band_init (&c->band, c->setup->sample_rate, c->setup->ping_length +
      max_template, c->setup->band_low, c->setup->band_high);
  c->analyzer = sonar_spectrum_new (&c->band);
  c->mic_spectra = g_new0 (SonarComplex, (gsize) c->band.n_bins * n_mics);
  c->ping = g_new0 (float, (gsize) c->setup->ping_length * n_mics);
}

void
sonar_test_chain_init (SonarTestChain * c, guint max_template)
{
  c->setup = sonar_test_default_setup (17500);
  c->bank = NULL;
  chain_buffers (c, max_template);
}

void
sonar_test_chain_init_with_bank (SonarTestChain * c, double v_min,
    double v_max, double v_step)
{
  GError *error = NULL;

  c->setup = sonar_test_default_setup (17500);
  c->bank = sonar_doppler_bank_new (c->setup, v_min, v_max, v_step, &error);
  g_assert_no_error (error);
  chain_buffers (c, sonar_doppler_bank_max_length (c->bank));
  sonar_doppler_bank_prepare_band (c->bank, &c->band);
}

void
sonar_test_chain_clear (SonarTestChain * c)
{
  sonar_spectrum_free (c->analyzer);
  if (c->bank)
    sonar_doppler_bank_unref (c->bank);
  g_free (c->mic_spectra);
  g_free (c->ping);
  sonar_setup_unref (c->setup);
}

void
sonar_test_chain_spectra (SonarTestChain * c)
{
  for (guint j = 0; j < c->setup->geometry.n_microphones; j++)
    sonar_spectrum_process (c->analyzer, c->ping + (gsize) j *
        c->setup->ping_length, c->setup->ping_length, 1,
        c->mic_spectra + (gsize) j * c->band.n_bins, NULL);
}

SonarTruth
sonar_test_chain_simulate (SonarTestChain * c, const char *json,
    double noise)
{
  SonarScene scene;
  SonarSimulatorParams params;
  SonarSimulator *sim;
  SonarTruth truth[16];
  GError *error = NULL;

  g_assert_true (sonar_scene_load_data (&scene, json, "test", &error));
  g_assert_no_error (error);
  g_assert_cmpuint (scene.n_reflectors, <=, G_N_ELEMENTS (truth));
  sonar_simulator_params_init_default (&params);
  params.noise_amplitude = noise;
  sim = sonar_simulator_new (c->setup, &params, &error);
  g_assert_no_error (error);
  sonar_simulator_render (sim, &scene, 0, 0.0, c->ping, truth);
  sonar_test_chain_spectra (c);
  sonar_simulator_free (sim);
  sonar_scene_clear (&scene);
  return truth[0];
}

/* Taps either side of sonar_test_add_delayed ()'s interpolator. */
#define SINC_HALF 48

void
sonar_test_add_delayed (float *signal, gsize length, const float *w, guint n,
    double delay, double gain)
{
  const gint whole = (gint) floor (delay);
  const double frac = delay - whole;
  double taps[2 * SINC_HALF + 1];

  for (gint k = -SINC_HALF; k <= SINC_HALF; k++) {
    const double x = k - frac;
    const double window = 0.42 + 0.5 * cos (G_PI * x / (SINC_HALF + 1)) +
        0.08 * cos (2.0 * G_PI * x / (SINC_HALF + 1));
    taps[k + SINC_HALF] = (fabs (x) < 1e-12 ? 1.0 : sin (G_PI * x) /
        (G_PI * x)) * window;
  }
  /* signal[t] = sum_k w[t - whole - k] taps[k]: w shifted by delay. */
  for (gint t = whole - SINC_HALF; t < (gint) n + whole + SINC_HALF; t++) {
    double sum = 0.0;
    if (t < 0 || t >= (gint) length)
      continue;
    for (gint k = -SINC_HALF; k <= SINC_HALF; k++) {
      const gint i = t - whole - k;
      if (i >= 0 && i < (gint) n)
        sum += w[i] * taps[k + SINC_HALF];
    }
    signal[t] += (float) (gain * sum);
  }
}

void
sonar_test_setup_params (SonarSetupParams * p, const SonarSetup * setup)
{
  sonar_setup_params_init (p);
  p->sample_rate = setup->sample_rate;
  p->speed_of_sound = setup->speed_of_sound;
  p->band_low = setup->band_low;
  p->band_high = setup->band_high;
  p->geometry = &setup->geometry;
  p->waveform_length = setup->waveform_length;
  p->waveforms = setup->waveforms;
  p->ping_length = setup->ping_length;
  p->ping_period = setup->ping_period;
  p->ping_stride = setup->ping_stride;
  p->trigger_offset = setup->trigger_offset;
  p->field_of_view = setup->field_of_view;
  p->frame_id = setup->frame_id;
}
