/* test-imaging.c: the Doppler bank and the MIMO imager against the
 * simulator's ground truth, without a pipeline. */
#include <fftw3.h>
#include <math.h>
#include <string.h>

#include "sonar-doppler-bank.h"
#include "sonar-imager.h"
#include "sonar-simulator.h"
#include "sonar-test-util.h"
#include "sonar-waveform.h"

typedef SonarTestChain Chain;

/* Images at the bank velocities @indices (maximum over them). */
static float *
chain_image (Chain * c, SonarDopplerBank * bank, const guint * indices,
    guint n, int emitter, const SonarImagerParams * params,
    const SonarImageGrid ** grid_out, SonarImager ** imager_out)
{
  GError *error = NULL;
  SonarImager *imager = sonar_imager_new (c->setup, &c->band, params, &error);
  SonarHypothesis *hypotheses = g_new (SonarHypothesis, n);
  float *image;

  g_assert_no_error (error);
  if (!sonar_doppler_bank_band (bank))
    sonar_doppler_bank_prepare_band (bank, &c->band);
  for (guint h = 0; h < n; h++)
    hypotheses[h] = sonar_doppler_bank_hypothesis (bank, indices[h]);
  image = g_new (float, sonar_image_grid_size (sonar_imager_grid (imager)));
  sonar_imager_process (imager, c->mic_spectra, n, hypotheses, emitter,
      image);
  *grid_out = sonar_imager_grid (imager);
  *imager_out = imager;
  g_free (hypotheses);
  return image;
}

static float
image_peak (const float *image, const SonarImageGrid * grid, double *azimuth,
    double *elevation, double *range)
{
  gsize best = 0;
  const gsize size = sonar_image_grid_size (grid);
  for (gsize i = 1; i < size; i++)
    if (image[i] > image[best])
      best = i;
  *range = grid->range_first + (best % grid->n_range) * grid->range_step;
  *azimuth = grid->azimuth_first + (best / grid->n_range % grid->n_azimuth)
      * grid->azimuth_step;
  *elevation = grid->elevation_first + (best / grid->n_range /
      grid->n_azimuth) * grid->elevation_step;
  return image[best];
}

/* Templates are the exact band-limited time-scaled emission: compared with
 * a double-precision evaluation of the emission's Fourier series. */
static void
test_bank_templates_exact (void)
{
  g_autoptr (SonarSetup) setup = sonar_test_default_setup (17500);
  g_autoptr (SonarDopplerBank) bank = NULL;
  const guint L = setup->waveform_length, N = 8192;
  const float *w = sonar_setup_waveform (setup, 3);
  double *x = fftw_alloc_real (N);
  fftw_complex *X = fftw_alloc_complex (N / 2 + 1);
  fftw_plan plan = fftw_plan_dft_r2c_1d (N, x, X, FFTW_ESTIMATE);
  const double velocities[] = { -7.0, -0.02, 0.0, 0.02, 7.0 };
  GError *error = NULL;

  bank = sonar_doppler_bank_new (setup, -7.0, 7.0, 0.01, &error);
  g_assert_no_error (error);
  g_assert_cmpuint (sonar_doppler_bank_n_velocities (bank), ==, 1401);
  memset (x, 0, sizeof (double) * N);
  for (guint i = 0; i < L; i++)
    x[i] = w[i];
  fftw_execute (plan);

  for (guint t = 0; t < G_N_ELEMENTS (velocities); t++) {
    const guint i = sonar_doppler_bank_nearest (bank, velocities[t]);
    const double v = sonar_doppler_bank_velocity (bank, i);
    const double alpha = (343.0 - v) / (343.0 + v);
    guint length;
    const float *tpl = sonar_doppler_bank_template (bank, 3, i, &length);
    double err2 = 0, sig2 = 0;

    g_assert_cmpfloat (fabs (v - velocities[t]), <, 1e-9);
    g_assert_cmpuint (length, ==, (guint) ceil ((L - 1) / alpha) + 1);
    /* Every 7th sample: the exact value is an O(N) sum. */
    for (guint k = 0; k < length; k += 7) {
      const double tau = alpha * k;
      double exact = X[0][0];
      for (guint b = 1; b < N / 2; b++) {
        const double ph = 2.0 * M_PI * b * tau / N;
        exact += 2.0 * (X[b][0] * cos (ph) - X[b][1] * sin (ph));
      }
      exact *= sqrt (alpha) / N;
      err2 += (tpl[k] - exact) * (tpl[k] - exact);
      sig2 += exact * exact;
    }
    g_test_message ("v = %+.2f m/s: template error %.1f dB", v,
        10 * log10 (err2 / sig2));
    g_assert_cmpfloat (10 * log10 (err2 / sig2), <, -80.0);
  }
  fftw_destroy_plan (plan);
  fftw_free (x);
  fftw_free (X);
}

static void
test_bank_errors (void)
{
  g_autoptr (SonarSetup) setup = sonar_test_default_setup (17500);
  GError *error = NULL;

  g_assert_null (sonar_doppler_bank_new (setup, 1, -1, 0.1, &error));
  g_assert_nonnull (strstr (error->message, "min <= max"));
  g_clear_error (&error);
  g_assert_null (sonar_doppler_bank_new (setup, -1, 1, 0, &error));
  g_assert_nonnull (strstr (error->message, "step 0 m/s must be positive"));
  g_clear_error (&error);
  g_assert_null (sonar_doppler_bank_new (setup, -100, 1, 0.1, &error));
  g_assert_nonnull (strstr (error->message, "|v| < c / 4"));
  g_clear_error (&error);
}

/* A point reflector appears at its azimuth (+-1 bin) and range (+-1 cm). */
static void
check_point (Chain * c, SonarDopplerBank * bank, const SonarImagerParams * p,
    double range, double azimuth, double elevation)
{
  g_autofree char *json = g_strdup_printf ("{\"reflectors\": [{\"range\": "
      "%g, \"azimuth\": %g, \"elevation\": %g}]}", range, azimuth, elevation);
  const SonarTruth truth = sonar_test_chain_simulate (c, json, 0.0);
  const guint zero = sonar_doppler_bank_nearest (bank, 0.0);
  const SonarImageGrid *grid;
  SonarImager *imager;
  float *image = chain_image (c, bank, &zero, 1, -1, p, &grid, &imager);
  double az, el, r;

  image_peak (image, grid, &az, &el, &r);
  g_test_message ("truth %.3f m %.1f/%.1f deg -> peak %.4f m %.1f/%.1f deg",
      truth.range, truth.azimuth, truth.elevation, r, az, el);
  g_assert_cmpfloat (fabs (az - truth.azimuth), <=, grid->azimuth_step + 1e-9);
  if (grid->n_elevation > 1)
    g_assert_cmpfloat (fabs (el - truth.elevation), <=,
        grid->elevation_step + 1e-9);
  g_assert_cmpfloat (fabs (r - truth.range), <=, 0.01);
  g_free (image);
  sonar_imager_free (imager);
}

static void
test_point_reflectors_2d (void)
{
  Chain c;
  g_autoptr (SonarDopplerBank) bank = NULL;
  SonarImagerParams p;
  const double cases[][2] = {
    {0.3, 0.0}, {0.3, 80.0}, {0.35, -45.0}, {1.0, 20.0}, {2.0, -80.0},
    {4.8, 80.0}, {4.8, -30.0}, {4.8, 0.0},
  };

  sonar_test_chain_init (&c, 4100);
  bank = sonar_doppler_bank_new (c.setup, 0.0, 0.0, 0.05, NULL);
  sonar_imager_params_init_default (&p);
  for (guint i = 0; i < G_N_ELEMENTS (cases); i++)
    check_point (&c, bank, &p, cases[i][0], cases[i][1], 0.0);
  sonar_test_chain_clear (&c);
}

static void
test_point_reflectors_3d (void)
{
  Chain c;
  g_autoptr (SonarDopplerBank) bank = NULL;
  SonarImagerParams p;
  const double cases[][3] = {
    {0.5, 20.0, 30.0}, {1.5, -60.0, -20.0}, {4.5, 10.0, 50.0},
  };

  sonar_test_chain_init (&c, 4100);
  bank = sonar_doppler_bank_new (c.setup, 0.0, 0.0, 0.05, NULL);
  sonar_imager_params_init_default (&p);
  p.n_azimuth = 61;
  p.azimuth_min = -90;
  p.azimuth_max = 90;
  p.n_elevation = 31;
  p.elevation_min = -60;
  p.elevation_max = 60;
  for (guint i = 0; i < G_N_ELEMENTS (cases); i++)
    check_point (&c, bank, &p, cases[i][0], cases[i][1], cases[i][2]);
  sonar_test_chain_clear (&c);
}

/* Compares the coarse-to-fine image (the default) with the dense one
 * (coarse_spacing 0) of the same ping: every pixel within -10 dB of the
 * maximum (r^2-weighted) is imaged in full, so bit-identical; the work (unit x hypothesis passes) is at most
 * @max_work_fraction of the dense image's (measured: 46 % for four
 * objects, 13 % for one, 22 % for three movers over 47 hypotheses (14 %
 * before refine_pfa's noise gate), 16 % in 3-D for two). */
static void
check_coarse_to_fine (Chain * c, SonarDopplerBank * bank,
    const guint * hypotheses, guint n_hypotheses,
    const SonarImagerParams * dense_params, const char *json,
    double max_work_fraction)
{
  SonarImagerParams p = *dense_params;
  const SonarImageGrid *grid;
  SonarImager *dense_imager, *imager;
  float *dense, *image;
  double top = 0.0;
  guint units, dense_units, passes, dense_passes, kept = 0;
  gsize size;

  sonar_test_chain_simulate (c, json, 0.01);
  p.coarse_spacing = 0.0;
  dense = chain_image (c, bank, hypotheses, n_hypotheses, -1, &p, &grid,
      &dense_imager);
  p.coarse_spacing = dense_params->coarse_spacing;
  image = chain_image (c, bank, hypotheses, n_hypotheses, -1, &p, &grid,
      &imager);
  size = sonar_image_grid_size (grid);
  for (gsize i = 0; i < size; i++) {
    const double r = grid->range_first + (i % grid->n_range) *
        grid->range_step;
    top = MAX (top, dense[i] * r * r);
  }
  for (gsize i = 0; i < size; i++) {
    const double r = grid->range_first + (i % grid->n_range) *
        grid->range_step;
    if (dense[i] * r * r >= top * pow (10.0, -10.0 / 20.0)) {
      g_assert_cmpfloat (image[i], ==, dense[i]);
      kept++;
    }
  }
  sonar_imager_last_work (imager, &units, &dense_units, &passes,
      &dense_passes);
  g_test_message ("%u of %u direction x zone units imaged in full, %u of %u "
      "unit x hypothesis passes; %u pixels within -10 dB, all exact", units,
      dense_units, passes, dense_passes, kept);
  g_assert_cmpuint (kept, >, 0);
  g_assert_cmpfloat (passes, <, max_work_fraction * dense_passes);
  sonar_imager_last_work (dense_imager, &units, &dense_units, &passes,
      &dense_passes);
  g_assert_cmpuint (units, ==, dense_units);
  g_assert_cmpuint (passes, ==, dense_passes);
  g_free (dense);
  g_free (image);
  sonar_imager_free (dense_imager);
  sonar_imager_free (imager);
}

/* 3-D at 2 degrees, 31 x 21 directions from (@azimuth_min,
 * @elevation_min) (@p's other settings kept). */
static void
set_3d_grid (SonarImagerParams * p, double azimuth_min, double elevation_min)
{
  p->n_azimuth = 31;
  p->azimuth_min = azimuth_min;
  p->azimuth_max = azimuth_min + 60;
  p->n_elevation = 21;
  p->elevation_min = elevation_min;
  p->elevation_max = elevation_min + 40;
}

static void
test_coarse_to_fine (void)
{
  Chain c;
  g_autoptr (SonarDopplerBank) bank = NULL;
  SonarImagerParams p;
  /* Near and far, strong and 6 dB weaker, at broadside and 61 degrees. */
  const char *scene = "{\"reflectors\": [{\"range\": 0.4, \"azimuth\": -61}, "
      "{\"range\": 1.2, \"azimuth\": 10.5}, {\"range\": 2.5, \"azimuth\": "
      "44, \"strength\": 0.5}, {\"range\": 4.6, \"azimuth\": -1}]}";
  const char *sparse = "{\"reflectors\": [{\"range\": 2.0, \"azimuth\": 20}]}";
  const char *scene_3d = "{\"reflectors\": [{\"range\": 1.5, \"azimuth\": "
      "-20, \"elevation\": 15}, {\"range\": 3.0, \"azimuth\": 13, "
      "\"elevation\": -8}]}";

  /* Movers on the Fig. 9 bank, imaged over its 47 detection hypotheses:
   * the fine units image only the hypotheses their coarse corners found
   * near the maximum, and the pixels near the maximum still come out
   * exact. */
  const char *movers = "{\"reflectors\": [{\"range\": 0.8, \"azimuth\": -40, "
      "\"radial-velocity\": -6.2}, {\"range\": 2.2, \"azimuth\": 12, "
      "\"radial-velocity\": 1.45}, {\"range\": 3.9, \"azimuth\": 55}]}";
  g_autoptr (SonarDopplerBank) fast_bank = NULL;
  guint hypotheses[64], n_hypotheses, zero;

  sonar_test_chain_init (&c, 4200);
  bank = sonar_doppler_bank_new (c.setup, 0.0, 0.0, 0.05, NULL);
  zero = sonar_doppler_bank_nearest (bank, 0.0);
  sonar_imager_params_init_default (&p);
  check_coarse_to_fine (&c, bank, &zero, 1, &p, scene, 0.6);
  check_coarse_to_fine (&c, bank, &zero, 1, &p, sparse, 0.2);
  fast_bank = sonar_doppler_bank_new (c.setup, -7.0, 7.0, 0.05, NULL);
  n_hypotheses = sonar_doppler_bank_hypotheses (fast_bank, 0.3, hypotheses);
  g_assert_cmpuint (n_hypotheses, >=, 47);
  check_coarse_to_fine (&c, fast_bank, hypotheses, n_hypotheses, &p, movers,
      0.3);
  /* 3-D at 2 degrees over +-30 x +-20 degrees: a coarse grid of 4. */
  set_3d_grid (&p, -30, -20);
  check_coarse_to_fine (&c, bank, &zero, 1, &p, scene_3d, 0.25);
  sonar_test_chain_clear (&c);
}

/* Cheaper template readings (the benchmark's template-interpolation
 * sweep): linear and nearest-sample templates stay near the band-limited
 * ones, nearest further off; the default is the band-limited reading. */
static void
test_bank_template_interp (void)
{
  g_autoptr (SonarSetup) setup = sonar_test_default_setup (17500);
  const SonarTemplateInterp interps[] = { SONAR_TEMPLATE_BAND_LIMITED,
    SONAR_TEMPLATE_LINEAR, SONAR_TEMPLATE_NEAREST,
  };
  g_autoptr (SonarDopplerBank) plain = sonar_doppler_bank_new (setup, 0.3,
      0.3, 0.1, NULL);
  const float *exact = sonar_doppler_bank_template (plain, 2, 0, NULL);
  double error_db[G_N_ELEMENTS (interps)];

  for (guint i = 0; i < G_N_ELEMENTS (interps); i++) {
    g_autoptr (SonarDopplerBank) bank = sonar_doppler_bank_new_with_interp
        (setup, 0.3, 0.3, 0.1, interps[i], NULL);
    guint length;
    const float *t = sonar_doppler_bank_template (bank, 2, 0, &length);
    double err2 = 0, sig2 = 0;

    for (guint k = 0; k < length; k++) {
      err2 += (t[k] - exact[k]) * (t[k] - exact[k]);
      sig2 += exact[k] * exact[k];
    }
    error_db[i] = err2 > 0 ? 10 * log10 (err2 / sig2) : -INFINITY;
    g_test_message ("%u: %.1f dB from the band-limited template", i,
        error_db[i]);
  }
  g_assert_cmpfloat (error_db[0], ==, -INFINITY);
  g_assert_cmpfloat (error_db[1], <, -20.0);
  g_assert_cmpfloat (error_db[1], >, -40.0);
  g_assert_cmpfloat (error_db[2], >, error_db[1] + 6.0);
  g_assert_cmpfloat (error_db[2], <, -6.0);
}

/* The defaults on a small 3-D grid: 2 degrees over -42..18 x -18..22,
 * coarse directions every 6 degrees from -42 and -18. */
static void
small_3d_grid (SonarImagerParams * p)
{
  sonar_imager_params_init_default (p);
  set_3d_grid (p, -42, -18);
}

/* The strongest pixel of @image within 2 directions and 20 range bins of
 * the faint echo at (-21, 9) degrees, 2.5 m. */
static guint
faint_echo_peak (const float *image, const SonarImageGrid * grid)
{
  const guint a0 = (guint) lround ((-21 - grid->azimuth_first) /
      grid->azimuth_step);
  const guint e0 = (guint) lround ((9 - grid->elevation_first) /
      grid->elevation_step);
  const guint i0 = (guint) lround ((2.5 - grid->range_first) /
      grid->range_step);
  guint best = 0;

  for (guint e = e0 - 2; e <= e0 + 2; e++)
    for (guint a = a0 - 2; a <= a0 + 2; a++)
      for (guint i = i0 - 20; i <= i0 + 20; i++) {
        const guint px = (e * grid->n_azimuth + a) * grid->n_range + i;
        if (best == 0 || image[px] > image[best])
          best = px;
      }
  return best;
}

/* The noise gate of the coarse to fine pass (refine_pfa): an echo 30 dB
 * below a near one in the range-compensated image (far below refine_db),
 * between the coarse directions of a 3-D grid (2 degrees, coarse 6), is
 * imaged in full: its peak pixel is the dense image's. Without the gate
 * it is interpolated from coarse directions 3 degrees off its beam, more
 * than 6 dB under its peak, and its strongest pixel is elsewhere. Still
 * and imaged at one velocity; and moving at 0.9 m/s, imaged over the 11
 * hypotheses of a -1.5..1.5 m/s bank, where the units refined for the
 * gate alone image 3 of them (the gate's and its neighbours) and keep
 * the interpolation where it is higher: the peak is still the dense
 * image's, at a fraction of the passes. */
static void
check_coarse_to_fine_faint (double speed, double bank_max)
{
  Chain c;
  g_autoptr (SonarDopplerBank) bank = NULL;
  SonarImagerParams p;
  const SonarImageGrid *grid;
  SonarImager *imagers[3];
  float *images[3];
  g_autofree char *scene = g_strdup_printf ("{\"reflectors\": [{\"range\": "
      "0.6, \"azimuth\": 0, \"elevation\": 0, \"strength\": 30}, "
      "{\"range\": 2.5, \"azimuth\": -21, \"elevation\": 9, "
      "\"radial-velocity\": %g}]}", speed);
  const double spacing[3] = { 0.0, 6.0, 6.0 }, pfa[3] = { 1e-5, 1e-5, 0.0 };
  guint indices[64], n_hyp, best;
  guint units, dense_units, passes[3], dense_passes;

  sonar_test_chain_init (&c, 4200);
  bank = sonar_doppler_bank_new (c.setup, -bank_max, bank_max, 0.05, NULL);
  n_hyp = sonar_doppler_bank_hypotheses (bank, 0.3, indices);
  g_assert_cmpuint (n_hyp, ==, bank_max > 0.0 ? 11 : 1);
  sonar_test_chain_simulate (&c, scene, 0.01);
  /* Coarse directions -24 and -18, 6 and 12 bracket the echo. */
  small_3d_grid (&p);
  for (guint k = 0; k < 3; k++) {
    p.coarse_spacing = spacing[k];
    p.refine_pfa = pfa[k];
    images[k] = chain_image (&c, bank, indices, n_hyp, -1, &p, &grid,
        &imagers[k]);
    sonar_imager_last_work (imagers[k], &units, &dense_units, &passes[k],
        &dense_passes);
  }
  /* The dense image's peak within 4 degrees and 5 cm of the faint echo. */
  best = faint_echo_peak (images[0], grid);
  g_test_message ("%+.1f m/s, %u hypotheses: faint echo's peak %.3g at az "
      "%g el %g r %g: gated %.3g, ungated %.3g; passes %u, %u ungated, "
      "dense %u", speed, n_hyp, images[0][best], grid->azimuth_first +
      best / grid->n_range % grid->n_azimuth * grid->azimuth_step,
      grid->elevation_first + best / grid->n_range / grid->n_azimuth *
      grid->elevation_step, grid->range_first + best % grid->n_range *
      grid->range_step, images[1][best], images[2][best], passes[1],
      passes[2], passes[0]);
  g_assert_cmpfloat (images[1][best], ==, images[0][best]);
  g_assert_cmpfloat (images[2][best], <, 0.5 * images[0][best]);
  /* The gate's units image a few of the hypotheses: it costs a fraction
   * of the dense image's passes. */
  g_assert_cmpuint (passes[1], <, passes[0] / 4);
  for (guint k = 0; k < 3; k++) {
    g_free (images[k]);
    sonar_imager_free (imagers[k]);
  }
  sonar_test_chain_clear (&c);
}

static void
test_coarse_to_fine_faint (void)
{
  check_coarse_to_fine_faint (0.0, 0.0);
}

static void
test_coarse_to_fine_faint_mover (void)
{
  check_coarse_to_fine_faint (0.9, 1.5);
}

/* The coarse pass on a third of the band (coarse_band): a sub-band pass
 * over every other hypothesis, what it finds imaged again over the whole
 * band. (1) The pixels within -10 dB of the maximum are the dense image's
 * bit for bit, as with the whole band's coarse pass (check_coarse_to_fine
 * (): still and moving reflectors, 2-D and 3-D). (2) An echo 30 dB below a
 * near one in the range-compensated image, between the coarse directions
 * of a 3-D grid and moving (11 hypotheses), is found by the sub-band's
 * noise gate and imaged in full: its peak pixel is the dense image's. (3)
 * Noise alone: nothing stands over wardcluster's threshold, no level
 * refines the noise under it, and the few pixels over the sub-band's gate
 * leave nearly every unit interpolated (the whole band's coarse pass
 * refines every unit within refine_db of the noise's maximum: measured,
 * 242 units and 11,374 passes against 68 and 1,487). */
static void
test_coarse_band (void)
{
  Chain c;
  g_autoptr (SonarDopplerBank) bank = NULL;
  g_autoptr (SonarDopplerBank) fast_bank = NULL;
  g_autoptr (SonarDopplerBank) mover_bank = NULL;
  SonarImagerParams p;
  const SonarImageGrid *grid;
  SonarImager *imagers[2];
  float *images[2];
  const char *scene = "{\"reflectors\": [{\"range\": 0.4, \"azimuth\": -61}, "
      "{\"range\": 1.2, \"azimuth\": 10.5}, {\"range\": 2.5, \"azimuth\": "
      "44, \"strength\": 0.5}, {\"range\": 4.6, \"azimuth\": -1}]}";
  const char *movers = "{\"reflectors\": [{\"range\": 0.8, \"azimuth\": -40, "
      "\"radial-velocity\": -6.2}, {\"range\": 2.2, \"azimuth\": 12, "
      "\"radial-velocity\": 1.45}, {\"range\": 3.9, \"azimuth\": 55}]}";
  const char *scene_3d = "{\"reflectors\": [{\"range\": 1.5, \"azimuth\": "
      "-20, \"elevation\": 15}, {\"range\": 3.0, \"azimuth\": 13, "
      "\"elevation\": -8}]}";
  const char *faint = "{\"reflectors\": [{\"range\": 0.6, \"azimuth\": 0, "
      "\"elevation\": 0, \"strength\": 30}, {\"range\": 2.5, \"azimuth\": "
      "-21, \"elevation\": 9, \"radial-velocity\": 0.9}]}";
  guint hypotheses[64], n_hypotheses, zero, best;
  guint units[2], dense_units, passes[2], dense_passes;

  sonar_test_chain_init (&c, 4200);
  bank = sonar_doppler_bank_new (c.setup, 0.0, 0.0, 0.05, NULL);
  zero = sonar_doppler_bank_nearest (bank, 0.0);
  fast_bank = sonar_doppler_bank_new (c.setup, -7.0, 7.0, 0.05, NULL);
  n_hypotheses = sonar_doppler_bank_hypotheses (fast_bank, 0.3, hypotheses);
  g_assert_cmpuint (n_hypotheses, >=, 47);

  /* (1) */
  sonar_imager_params_init_default (&p);
  p.coarse_band = 1.0 / 3.0;
  check_coarse_to_fine (&c, bank, &zero, 1, &p, scene, 0.6);
  check_coarse_to_fine (&c, fast_bank, hypotheses, n_hypotheses, &p, movers,
      0.35);
  set_3d_grid (&p, -30, -20);
  check_coarse_to_fine (&c, bank, &zero, 1, &p, scene_3d, 0.25);

  /* (2) */
  mover_bank = sonar_doppler_bank_new (c.setup, -1.5, 1.5, 0.05, NULL);
  n_hypotheses = sonar_doppler_bank_hypotheses (mover_bank, 0.3, hypotheses);
  g_assert_cmpuint (n_hypotheses, ==, 11);
  sonar_test_chain_simulate (&c, faint, 0.01);
  small_3d_grid (&p);
  for (guint k = 0; k < 2; k++) {
    p.coarse_spacing = k == 0 ? 0.0 : 6.0;
    p.coarse_band = k == 0 ? 1.0 : 1.0 / 3.0;
    images[k] = chain_image (&c, mover_bank, hypotheses, n_hypotheses, -1,
        &p, &grid, &imagers[k]);
    sonar_imager_last_work (imagers[k], &units[k], &dense_units, &passes[k],
        &dense_passes);
  }
  best = faint_echo_peak (images[0], grid);
  g_test_message ("faint mover: peak %.3g dense, %.3g on the sub-band; "
      "passes %u of %u", images[0][best], images[1][best], passes[1],
      passes[0]);
  g_assert_cmpfloat (images[1][best], ==, images[0][best]);
  g_assert_cmpuint (passes[1], <, passes[0] / 4);
  for (guint k = 0; k < 2; k++) {
    g_free (images[k]);
    sonar_imager_free (imagers[k]);
  }

  /* (3) */
  n_hypotheses = sonar_doppler_bank_hypotheses (fast_bank, 0.3, hypotheses);
  sonar_test_chain_simulate (&c, "{\"reflectors\": []}", 0.01);
  sonar_imager_params_init_default (&p);
  for (guint k = 0; k < 2; k++) {
    p.coarse_band = k == 0 ? 1.0 : 1.0 / 3.0;
    images[k] = chain_image (&c, fast_bank, hypotheses, n_hypotheses, -1,
        &p, &grid, &imagers[k]);
    sonar_imager_last_work (imagers[k], &units[k], &dense_units, &passes[k],
        &dense_passes);
  }
  g_test_message ("noise alone: %u and %u units of %u (the coarse ones "
      "included), %u and %u passes of %u, whole band and sub-band",
      units[0], units[1], dense_units, passes[0], passes[1], dense_passes);
  /* Beyond the 61 coarse directions, at most 2 % of the units imaged
   * (coarse ones confirmed over the whole band, fine ones refined), and a
   * quarter of the whole band's passes (the sub-band's counted whole). */
  g_assert_cmpuint (units[1], <=, 61 + dense_units / 50);
  g_assert_cmpuint (passes[1], <, passes[0] / 4);
  for (guint k = 0; k < 2; k++) {
    g_free (images[k]);
    sonar_imager_free (imagers[k]);
  }
  sonar_test_chain_clear (&c);
}

/* The image does not depend on the workers sharing it (the coarse pass,
 * the noise gate's floors, the fine pass): bit for bit with 1 to 7
 * threads, on a 3-D grid over 47 hypotheses where the gate and the
 * refined units' subsets of hypotheses both act. */
static void
test_threads (void)
{
  Chain c;
  g_autoptr (SonarDopplerBank) bank = NULL;
  SonarImagerParams p;
  const SonarImageGrid *grid;
  const char *scene = "{\"reflectors\": [{\"range\": 0.6, \"azimuth\": 0, "
      "\"elevation\": 0, \"strength\": 30, \"radial-velocity\": -1.2}, "
      "{\"range\": 2.5, \"azimuth\": -21, \"elevation\": 9, "
      "\"radial-velocity\": 2.1}]}";
  const guint threads[] = { 1, 2, 3, 7, 1, 2, 3, 7 };
  guint hypotheses[64], n_hypotheses, units = 0, dense_units, passes,
      dense_passes;
  float *first = NULL;

  sonar_test_chain_init (&c, 4200);
  bank = sonar_doppler_bank_new (c.setup, -7.0, 7.0, 0.05, NULL);
  n_hypotheses = sonar_doppler_bank_hypotheses (bank, 0.3, hypotheses);
  sonar_test_chain_simulate (&c, scene, 0.01);
  small_3d_grid (&p);
  p.coarse_spacing = 6.0;
  for (guint k = 0; k < G_N_ELEMENTS (threads); k++) {
    SonarImager *imager;
    float *image;

    p.threads = threads[k];
    /* The second four on a third of the band (coarse_band). */
    if (k == 4) {
      g_free (first);
      first = NULL;
      p.coarse_band = 1.0 / 3.0;
    }
    image = chain_image (&c, bank, hypotheses, n_hypotheses, -1, &p, &grid,
        &imager);
    sonar_imager_last_work (imager, &units, &dense_units, &passes,
        &dense_passes);
    if (!first) {
      g_test_message ("%u of %u units, %u of %u passes", units, dense_units,
          passes, dense_passes);
      /* Some units refined, over some of the hypotheses only. */
      g_assert_cmpuint (units, <, dense_units);
      g_assert_cmpuint (passes, <, (guint64) units * n_hypotheses);
      first = image;
    } else {
      g_assert_cmpmem (image, sonar_image_grid_size (grid) * sizeof (float),
          first, sonar_image_grid_size (grid) * sizeof (float));
      g_free (image);
    }
    sonar_imager_free (imager);
  }
  g_free (first);
  sonar_test_chain_clear (&c);
}

/* The built-in array and emitters at twice their size (17,500-sample
 * pings). */
static SonarSetup *
wide_setup (void)
{
  SonarGeometry g;
  SonarSetup *wide;

  sonar_geometry_init_default (&g);
  for (guint j = 0; j < g.n_microphones; j++)
    g.microphones[j] = sonar_vec3_scale (g.microphones[j], 2.0);
  for (guint n = 0; n < g.n_emitters; n++)
    g.emitters[n] = sonar_vec3_scale (g.emitters[n], 2.0);
  wide = sonar_test_setup_new (&g, 17500);
  sonar_geometry_clear (&g);
  return wide;
}

/* The coarse spacing in main lobes of the array's beam
 * (sonar_imager_params_fit_beam ()): on the eRTIS array the views'
 * degrees, 3 for the fan and 6 for a 3-D grid, the same image bit for
 * bit; on an array twice as large (a 1.5 degree lobe) every other
 * direction of the fan is coarse, not every third: 91 coarse units on
 * noise, not 61. */
static void
test_coarse_lobes (void)
{
  const char *scene = "{\"reflectors\": [{\"range\": 1.8, \"azimuth\": "
      "-30, \"elevation\": -30, \"radial-velocity\": 0.4}]}";
  guint hypotheses[64], n_hypotheses, units[2], dense_units, passes,
      dense_passes;

  for (guint view = 0; view < 2; view++) {
    Chain c;
    g_autoptr (SonarDopplerBank) bank = NULL;
    const SonarImageGrid *grid;
    SonarImagerParams p;
    float *image[2];
    SonarImager *imager[2];

    sonar_test_chain_init (&c, 4200);
    bank = sonar_doppler_bank_new (c.setup, -1.0, 1.0, 0.05, NULL);
    n_hypotheses = sonar_doppler_bank_hypotheses (bank, 0.3, hypotheses);
    sonar_test_chain_simulate (&c, scene, 0.01);
    if (view) {
      small_3d_grid (&p);
      p.coarse_spacing = 6.0;
    } else
      sonar_imager_params_init_default (&p);
    for (guint k = 0; k < 2; k++) {
      if (k)
        sonar_imager_params_fit_beam (&p);
      image[k] = chain_image (&c, bank, hypotheses, n_hypotheses, -1, &p,
          &grid, &imager[k]);
      sonar_imager_last_work (imager[k], &units[k], &dense_units, &passes,
          &dense_passes);
    }
    g_test_message ("%s: %u and %u units, degrees and lobes", view ? "3-D" :
        "fan", units[0], units[1]);
    /* The set-up (the test chain's: a fan) does not decide: a grid of
     * rows and columns is coarse by two lobes, a row by one. */
    for (guint k = 0; k < 2; k++) {
      double azimuth, elevation;
      sonar_imager_coarse_spacing (imager[k], &azimuth, &elevation);
      g_assert_cmpfloat (azimuth, ==, view ? 6.0 : 3.0);
      g_assert_cmpfloat (elevation, ==, view ? 6.0 : 0.0);
    }
    g_assert_cmpuint (units[0], <, dense_units);
    g_assert_cmpuint (units[1], ==, units[0]);
    g_assert_cmpmem (image[1], sonar_image_grid_size (grid) * sizeof (float),
        image[0], sonar_image_grid_size (grid) * sizeof (float));
    for (guint k = 0; k < 2; k++) {
      g_free (image[k]);
      sonar_imager_free (imager[k]);
    }
    sonar_test_chain_clear (&c);
  }

  {
    g_autoptr (SonarSetup) wide = NULL;
    SonarBand band;
    SonarImagerParams p;
    SonarImager *imager;
    g_autoptr (SonarDopplerBank) bank = NULL;
    SonarHypothesis still;
    SonarComplex *noise;
    float *image;

    wide = wide_setup ();
    bank = sonar_doppler_bank_new (wide, 0.0, 0.0, 0.05, NULL);
    sonar_band_init (&band, wide->sample_rate, wide->ping_length +
        sonar_doppler_bank_max_length (bank), wide->band_low,
        wide->band_high);
    sonar_doppler_bank_prepare_band (bank, &band);
    still = sonar_doppler_bank_hypothesis (bank, 0);
    noise = g_new (SonarComplex, (gsize) wide->geometry.n_microphones *
        band.n_bins);
    {
      g_autoptr (GRand) rand = g_rand_new_with_seed (7);
      for (gsize i = 0; i < (gsize) wide->geometry.n_microphones *
          band.n_bins; i++)
        noise[i] = CMPLXF (g_rand_double (rand) - 0.5,
            g_rand_double (rand) - 0.5);
    }
    /* Refined around the maximum alone: the coarse units and a few. */
    sonar_imager_params_init_default (&p);
    p.refine_db = 0.1;
    p.refine_pfa = 0.0;
    for (guint k = 0; k < 2; k++) {
      if (k)
        sonar_imager_params_fit_beam (&p);
      imager = sonar_imager_new (wide, &band, &p, NULL);
      g_assert_nonnull (imager);
      image = g_new (float, sonar_image_grid_size (sonar_imager_grid
              (imager)));
      sonar_imager_process (imager, noise, 1, &still, -1, image);
      sonar_imager_last_work (imager, &units[k], &dense_units, &passes,
          &dense_passes);
      g_free (image);
      sonar_imager_free (imager);
    }
    g_test_message ("twice as large, noise: %u and %u units, degrees and "
        "lobes", units[0], units[1]);
    g_assert_cmpuint (units[0], >=, 61);
    g_assert_cmpuint (units[0], <, 61 + 12);
    g_assert_cmpuint (units[1], >=, 91);
    g_assert_cmpuint (units[1], <, 91 + 12);
    g_free (noise);
  }
}

/* sonar_imager_focus_turns (): the phase, in turns at the band's top,
 * by which one focus zone leaves the array's outermost microphone and
 * emitter at its ends, worked out by hand for the built-in array
 * (rho 41.3 and 54.1 mm: (rho_m^2 + rho_e^2) / 4 (1 / 0.3 - 1 / 4.7)
 * 80 kHz / 343 m/s = 0.84); it grows as 1 / range_min and as the
 * array's size squared. */
static void
test_focus_turns (void)
{
  g_autoptr (SonarSetup) setup = sonar_test_default_setup (17500);
  g_autoptr (SonarSetup) wide = NULL;
  const SonarGeometry *d = &setup->geometry;
  double rho_m = 0.0, rho_e = 0.0, expected, turns;

  for (guint j = 0; j < d->n_microphones; j++)
    rho_m = MAX (rho_m, hypot (d->microphones[j].x, d->microphones[j].y));
  for (guint n = 0; n < d->n_emitters; n++)
    rho_e = MAX (rho_e, hypot (d->emitters[n].x, d->emitters[n].y));
  g_assert_cmpfloat (fabs (rho_m - 0.0413), <, 0.0005);
  g_assert_cmpfloat (fabs (rho_e - 0.0541), <, 0.0005);
  expected = (rho_m * rho_m + rho_e * rho_e) / 4.0 * (1.0 / 0.3 - 1.0 /
      4.7) * setup->band_high / setup->speed_of_sound;
  turns = sonar_imager_focus_turns (setup, 0.3, 4.7);
  g_test_message ("0.3 to 4.7 m: %.4f turns", turns);
  g_assert_cmpfloat (fabs (turns - expected), <, 1e-12);
  g_assert_cmpfloat (fabs (turns - 0.84), <, 0.01);
  g_assert_cmpfloat (fabs (sonar_imager_focus_turns (setup, 0.01, 4.7) -
          turns * (100.0 - 1.0 / 4.7) / (1.0 / 0.3 - 1.0 / 4.7)), <, 1e-9);

  wide = wide_setup ();
  g_assert_cmpfloat (fabs (sonar_imager_focus_turns (wide, 0.3, 4.7) -
          4.0 * turns), <, 1e-9);
}

/* A ping no longer than its waveform holds no echo to image: the error
 * names the ping and the waveform (it named range-min and an image ending
 * at 0.000 m). */
static void
test_empty_window (void)
{
  g_autoptr (SonarSetup) setup = sonar_test_default_setup (4000);
  g_autoptr (GError) error = NULL;
  SonarImagerParams p;
  SonarBand band;

  sonar_imager_params_init_default (&p);
  sonar_band_init (&band, setup->sample_rate, 8000, setup->band_low,
      setup->band_high);
  g_assert_null (sonar_imager_new (setup, &band, &p, &error));
  g_assert_cmpstr (error->message, ==, "imager: a ping of 4000 samples "
      "holds no whole echo of a 4000-sample waveform beyond the array's own "
      "size: the image would be empty (a longer ping-length or a shorter "
      "waveform)");
}

int
main (int argc, char **argv)
{
  g_test_init (&argc, &argv, NULL);
  g_test_add_func ("/imaging/bank-templates-exact", test_bank_templates_exact);
  g_test_add_func ("/imaging/focus-turns", test_focus_turns);
  g_test_add_func ("/imaging/empty-window", test_empty_window);
  g_test_add_func ("/imaging/bank-template-interp",
      test_bank_template_interp);
  g_test_add_func ("/imaging/bank-errors", test_bank_errors);
  g_test_add_func ("/imaging/point-reflectors-2d", test_point_reflectors_2d);
  g_test_add_func ("/imaging/point-reflectors-3d", test_point_reflectors_3d);
  g_test_add_func ("/imaging/coarse-to-fine", test_coarse_to_fine);
  g_test_add_func ("/imaging/coarse-to-fine-faint", test_coarse_to_fine_faint);
  g_test_add_func ("/imaging/coarse-to-fine-faint-mover",
      test_coarse_to_fine_faint_mover);
  g_test_add_func ("/imaging/coarse-band", test_coarse_band);
  g_test_add_func ("/imaging/threads", test_threads);
  g_test_add_func ("/imaging/coarse-lobes", test_coarse_lobes);
  return g_test_run ();
}
