/* test-velocity.c: Doppler-ACF velocity estimates against ground truth,
 * evaluated at the true position (the clustering is tested on its own). */
#include <math.h>
#include <string.h>

#include "sonar-cluster.h"
#include "sonar-doppler-bank.h"
#include "sonar-imager.h"
#include "sonar-simulator.h"
#include "sonar-test-util.h"
#include "sonar-velocity.h"
#include "sonar-waveform.h"

typedef struct
{
  SonarSetup *setup;
  SonarDopplerBank *bank;
  SonarImageGrid grid;
  SonarSpectrum *analyzer;
  SonarComplex *spectra;
  float *ping;
  SonarVelocityEstimator *est;
} Fixture;

/* Takes @setup. */
static void
fixture_init_setup (Fixture * f, SonarSetup * setup, double v_min,
    double v_max, double v_step)
{
  SonarBand band;
  SonarImagerParams ip;
  SonarVelocityParams vp;
  SonarImager *imager;
  const guint n_mics = setup->geometry.n_microphones;

  f->setup = setup;
  f->bank = sonar_doppler_bank_new (f->setup, v_min, v_max, v_step, NULL);
  sonar_band_init (&band, f->setup->sample_rate, f->setup->ping_length +
      sonar_doppler_bank_max_length (f->bank), f->setup->band_low,
      f->setup->band_high);
  sonar_doppler_bank_prepare_band (f->bank, &band);
  f->analyzer = sonar_spectrum_new (&band);
  sonar_imager_params_init_default (&ip);
  /* Short pings (6000 samples) record 2 m. */
  if (setup->ping_length < 17500)
    ip.range_max = 2.0;
  imager = sonar_imager_new (f->setup, &band, &ip, NULL);
  g_assert_nonnull (imager);
  f->grid = *sonar_imager_grid (imager);
  sonar_imager_free (imager);
  f->spectra = g_new (SonarComplex, (gsize) band.n_bins * n_mics);
  f->ping = g_new (float, (gsize) f->setup->ping_length * n_mics);
  sonar_velocity_params_init_default (&vp);
  f->est = sonar_velocity_estimator_new (f->bank, &f->grid, &vp, NULL);
}

static void
fixture_init (Fixture * f, double v_min, double v_max, double v_step)
{
  fixture_init_setup (f, sonar_test_default_setup (17500), v_min, v_max,
      v_step);
}

static void
fixture_clear (Fixture * f)
{
  sonar_velocity_estimator_free (f->est);
  sonar_spectrum_free (f->analyzer);
  sonar_doppler_bank_unref (f->bank);
  sonar_setup_unref (f->setup);
  g_free (f->spectra);
  g_free (f->ping);
}

/* Simulates @json, estimates at reflector @k's true position; @curves, if
 * not NULL, receives the Doppler-ACF curves in dB. */
static SonarVelocityEstimate
estimate_at_truth_curves (Fixture * f, const char *json, double noise,
    guint k, SonarTruth * truth_out, float *curves)
{
  SonarScene scene;
  SonarSimulatorParams params;
  SonarSimulator *sim;
  SonarTruth truth[16];
  SonarVelocityEstimate est[2];
  SonarCentroid centroid;

  g_assert_true (sonar_scene_load_data (&scene, json, "test", NULL));
  sonar_simulator_params_init_default (&params);
  params.noise_amplitude = noise;
  params.seed = 7;
  sim = sonar_simulator_new (f->setup, &params, NULL);
  sonar_simulator_render (sim, &scene, 0, 0.0, f->ping, truth);
  for (guint j = 0; j < f->setup->geometry.n_microphones; j++)
    sonar_spectrum_process (f->analyzer, f->ping + (gsize) j *
        f->setup->ping_length, f->setup->ping_length, 1,
        f->spectra + (gsize) j * sonar_doppler_bank_band (f->bank)->n_bins,
        NULL);
  centroid = sonar_velocity_point (truth[k].range, truth[k].azimuth,
      truth[k].elevation);
  sonar_velocity_estimate (f->est, f->spectra, &centroid, est, curves);
  *truth_out = truth[k];
  sonar_simulator_free (sim);
  sonar_scene_clear (&scene);
  return est[0];
}

static SonarVelocityEstimate
estimate_at_truth (Fixture * f, const char *json, double noise, guint k,
    SonarTruth * truth_out)
{
  return estimate_at_truth_curves (f, json, noise, k, truth_out, NULL);
}

/* The Fig. 10 setting: small speeds, fine bank, realistic noise. */
static void
test_slow_objects (void)
{
  Fixture f;
  const double cases[][3] = {   /* range, azimuth, radial velocity */
    {0.6, -70, -0.1}, {1.0, 40, -0.23}, {1.8, -25, -0.27}, {2.5, 75, -0.08},
    {3.3, 10, -0.295}, {4.5, -50, -0.19}, {2.0, 0, 0.013},
  };
  double sum = 0, worst = 0;

  fixture_init (&f, -0.4, 0.4, 0.02);
  for (guint i = 0; i < G_N_ELEMENTS (cases); i++) {
    g_autofree char *json = g_strdup_printf ("{\"reflectors\": [{\"kind\": "
        "\"cylinder\", \"radius\": 0.05, \"range\": %g, \"azimuth\": %g, "
        "\"radial-velocity\": %g}]}", cases[i][0], cases[i][1], cases[i][2]);
    SonarTruth truth;
    SonarVelocityEstimate e = estimate_at_truth (&f, json, 0.01, 0, &truth);
    const double err = fabs (e.radial_velocity - truth.radial_velocity);
    g_test_message ("%.1f m %+.0f deg: truth %+.4f, estimate %+.4f m/s "
        "(error %.4f), agree %u, peak %.1f dB, variance %.4f, coherence %.3f",
        truth.range, truth.azimuth, truth.radial_velocity, e.radial_velocity,
        err, e.agreeing_emitters, e.peak_db, e.variance, e.coherence);
    g_assert_true (e.valid);
    sum += err;
    worst = MAX (worst, err);
  }
  g_test_message ("mean error %.4f m/s, worst %.4f m/s",
      sum / G_N_ELEMENTS (cases), worst);
  g_assert_cmpfloat (sum / G_N_ELEMENTS (cases), <=, 0.005);
  g_assert_cmpfloat (worst, <=, 0.02);
  fixture_clear (&f);
}

/* The Fig. 9 setting: fast movers, the -7..7 m/s bank at 0.05 m/s. */
static void
test_fast_movers (void)
{
  Fixture f;
  const double cases[][4] = {   /* range, azimuth, radial, tangential */
    {2.0, -40, -3.0, 1.0}, {3.0, 35, 1.8, -0.8}, {1.5, 10, -6.5, 0.0},
    {2.5, -60, 5.0, 0.5}, {1.2, 65, 0.0, 0.0},
  };
  double worst = 0;

  fixture_init (&f, -7.0, 7.0, 0.05);
  for (guint i = 0; i < G_N_ELEMENTS (cases); i++) {
    g_autofree char *json = g_strdup_printf ("{\"reflectors\": [{\"kind\": "
        "\"cylinder\", \"radius\": 0.05, \"range\": %g, \"azimuth\": %g, "
        "\"radial-velocity\": %g, \"tangential-velocity\": %g}]}",
        cases[i][0], cases[i][1], cases[i][2], cases[i][3]);
    SonarTruth truth;
    SonarVelocityEstimate e = estimate_at_truth (&f, json, 0.01, 0, &truth);
    const double err = fabs (e.radial_velocity - truth.radial_velocity);
    g_test_message ("%.1f m %+.0f deg: truth %+.4f, estimate %+.4f m/s "
        "(error %.4f), agree %u, peak %.1f dB", truth.range, truth.azimuth,
        truth.radial_velocity, e.radial_velocity, err, e.agreeing_emitters,
        e.peak_db);
    g_assert_true (e.valid);
    worst = MAX (worst, err);
  }
  g_test_message ("worst error %.4f m/s", worst);
  g_assert_cmpfloat (worst, <=, 0.02);
  fixture_clear (&f);
}

/* Points of @curve (dB) within @db of its maximum. */
static guint
width_within (const float *curve, guint n, double db)
{
  float top = -INFINITY;
  guint count = 0;

  for (guint v = 0; v < n; v++)
    top = MAX (top, curve[v]);
  for (guint v = 0; v < n; v++)
    count += curve[v] >= top - db;
  return count;
}

/* params.emitters: only the first k emitters enter the product, which is
 * wider for fewer; more than the sensor has is refused. */
static void
test_emitters_subset (void)
{
  const char *json = "{\"reflectors\": [{\"kind\": \"cylinder\", "
      "\"radius\": 0.05, \"range\": 2.0, \"azimuth\": 20, "
      "\"radial-velocity\": -0.2}]}";
  const guint subsets[] = { 1, 4, 0 };
  guint widths[G_N_ELEMENTS (subsets)];
  SonarVelocityParams vp;
  g_autoptr (GError) error = NULL;
  Fixture f;
  guint nv;

  fixture_init (&f, -0.4, 0.4, 0.02);
  nv = sonar_doppler_bank_n_velocities (f.bank);
  sonar_velocity_params_init_default (&vp);
  vp.emitters = 9;
  g_assert_null (sonar_velocity_estimator_new (f.bank, &f.grid, &vp,
          &error));
  g_assert_cmpstr (error->message, ==,
      "velocity: emitters is 9, the set-up has only 8");

  for (guint i = 0; i < G_N_ELEMENTS (subsets); i++) {
    const guint k = subsets[i] ? subsets[i] : 8;
    g_autofree float *curves = g_new (float, (gsize) (k + 1) * nv);
    g_autofree float *product = g_new (float, nv);
    SonarVelocityEstimate e[2];
    SonarCentroid centroid;
    SonarTruth truth;

    vp.emitters = subsets[i];
    sonar_velocity_estimator_free (f.est);
    f.est = sonar_velocity_estimator_new (f.bank, &f.grid, &vp, NULL);
    g_assert_nonnull (f.est);
    e[0] = estimate_at_truth (&f, json, 0.01, 0, &truth);
    centroid = sonar_velocity_point (truth.range, truth.azimuth,
        truth.elevation);
    sonar_velocity_estimate (f.est, f.spectra, &centroid, e, curves);
    /* The last curve is the product per emitter: times k, the product. */
    for (guint v = 0; v < nv; v++)
      product[v] = k * curves[(gsize) k * nv + v];
    widths[i] = width_within (product, nv, 3.0);
    g_test_message ("emitters %u: estimate %+.4f m/s (truth %+.4f), agree "
        "%u, product 3 dB wide over %u of %u velocities", k,
        e[0].radial_velocity, truth.radial_velocity, e[0].agreeing_emitters,
        widths[i], nv);
    g_assert_true (e[0].valid);
    g_assert_cmpuint (e[0].agreeing_emitters, <=, k);
    g_assert_cmpfloat (fabs (e[0].radial_velocity - truth.radial_velocity),
        <=, 0.02);
    if (k == 1)
      for (guint v = 0; v < nv; v++)
        g_assert_cmpfloat (fabsf (product[v] - curves[v]), <, 1e-3f);
  }
  /* More emitters, a sharper product (paper Fig. 4g). */
  g_assert_cmpuint (widths[0], >, widths[1]);
  g_assert_cmpuint (widths[1], >, widths[2]);
  fixture_clear (&f);
}

/* The default sensor with @n_emitters emitters (noise waveforms) on the
 * default emitters' ellipse (55 x 40 mm), at unevenly spaced angles. */
static SonarSetup *
setup_with_emitters (guint n_emitters, guint ping_length)
{
  SonarGeometry g;

  sonar_geometry_init_default (&g);
  g.n_emitters = n_emitters;
  g.emitters = g_renew (SonarVec3, g.emitters, n_emitters);
  for (guint n = 0; n < n_emitters; n++) {
    const double a = 2.0 * G_PI * (n + 0.3 * sin (1.7 * n)) / n_emitters;
    g.emitters[n] = sonar_vec3 (0.055 * cos (a), 0.040 * sin (a), 0.0);
  }
  return sonar_test_setup_new (&g, ping_length);
}

/* The Doppler-ACF product does not underflow: an echo at 1e-30 of full
 * scale (emitter outputs about 1e-31) with 32 emitters, whose product
 * taken linearly would be some 1e-990, far below double's range, and with
 * the default 8 emitters on the long bank -7..7 m/s in steps of 0.01
 * (1401 velocities). Every curve that sonar_velocity_estimate returns is
 * finite, the product peaks at the true speed, and the estimate is the
 * full-scale echo's. */
static void
test_acf_no_underflow (void)
{
  const struct
  {
    guint n_emitters;
    double v_min, v_max, v_step, velocity;
  } cases[] = {
    {32, -0.5, 0.5, 0.05, -0.23},
    {8, -7.0, 7.0, 0.01, 3.21},
  };

  for (guint c = 0; c < G_N_ELEMENTS (cases); c++) {
    Fixture f;
    guint nv, n_curves, peak = 0;
    float *curves;
    SonarVelocityEstimate e[2];
    SonarTruth truth;

    fixture_init_setup (&f, setup_with_emitters (cases[c].n_emitters, 6000),
        cases[c].v_min, cases[c].v_max, cases[c].v_step);
    nv = sonar_doppler_bank_n_velocities (f.bank);
    n_curves = (cases[c].n_emitters + 1) * nv;
    curves = g_new (float, n_curves);
    for (guint s = 0; s < 2; s++) {
      const double strength = s == 0 ? 1.0 : 1e-30;
      g_autofree char *json = g_strdup_printf ("{\"reflectors\": [{"
          "\"range\": 1.0, \"azimuth\": 20, \"radial-velocity\": %g, "
          "\"strength\": %g}]}", cases[c].velocity, strength);
      e[s] = estimate_at_truth_curves (&f, json, 0.01 * strength, 0, &truth,
          curves);
      for (guint i = 0; i < n_curves; i++)
        g_assert_true (isfinite (curves[i]));
      for (guint v = 0; v < nv; v++)
        if (curves[cases[c].n_emitters * nv + v] >
            curves[cases[c].n_emitters * nv + peak])
          peak = v;
      g_test_message ("%u emitters, %u velocities, strength %g: product "
          "peak %.1f dB at %+.2f m/s; estimate %+.4f m/s (truth %+.4f), "
          "peak %.1f dB over the median, valid %d", cases[c].n_emitters, nv,
          strength, curves[cases[c].n_emitters * nv + peak],
          sonar_doppler_bank_velocity (f.bank, peak), e[s].radial_velocity,
          truth.radial_velocity, e[s].peak_db, e[s].valid);
      g_assert_cmpfloat (fabs (sonar_doppler_bank_velocity (f.bank, peak) -
              truth.radial_velocity), <=, 0.05);
      g_assert_true (e[s].valid);
      g_assert_cmpfloat (fabs (e[s].radial_velocity - truth.radial_velocity),
          <=, 0.02);
      g_assert_cmpfloat (e[s].peak_db, >, 3.0);
      if (s == 1) {
        /* Truly faint: a linear product would have underflowed. */
        g_assert_cmpfloat (curves[cases[c].n_emitters * nv + peak], <,
            -500.0);
        g_assert_cmpfloat (fabs (e[1].radial_velocity -
                e[0].radial_velocity), <, 1e-3);
      }
    }
    g_free (curves);
    fixture_clear (&f);
  }
}

/* The core chain as the elements run it at their defaults: the detection
 * image over the hypotheses 0.3 m/s apart, the centroids (@cluster), the
 * velocity pool (of chain_init ()'s @n_threads). */
typedef struct
{
  SonarImager *imager;
  SonarClusterer *clusterer;
  SonarVelocityPool *pool;
  guint n_hypotheses;
  SonarHypothesis *hypotheses;
  float *image;
  SonarCentroid centroids[64];
  SonarVelocityEstimate results[128];
  guint counts[64];
} Chain;

static void
chain_init (Chain * c, Fixture * f, const SonarClusterParams * cluster,
    guint n_threads)
{
  SonarImagerParams ip;
  SonarClusterParams cp = *cluster;
  SonarVelocityParams vp;
  guint *indices = g_new (guint, sonar_doppler_bank_n_velocities (f->bank)
      + 2);

  sonar_imager_params_init_default (&ip);
  c->imager = sonar_imager_new (f->setup, sonar_doppler_bank_band (f->bank),
      &ip, NULL);
  g_assert_nonnull (c->imager);
  c->n_hypotheses = sonar_doppler_bank_hypotheses (f->bank, 0.3, indices);
  c->hypotheses = g_new (SonarHypothesis, c->n_hypotheses);
  for (guint h = 0; h < c->n_hypotheses; h++)
    c->hypotheses[h] = sonar_doppler_bank_hypothesis (f->bank, indices[h]);
  cp.hypotheses = c->n_hypotheses;
  c->clusterer = sonar_clusterer_new (sonar_imager_grid (c->imager), &cp,
      NULL);
  g_assert_nonnull (c->clusterer);
  sonar_velocity_params_init_default (&vp);
  c->pool = sonar_velocity_pool_new (f->bank, sonar_imager_grid (c->imager),
      &vp, n_threads, NULL);
  g_assert_nonnull (c->pool);
  c->image = g_new (float, sonar_image_grid_size (sonar_imager_grid
          (c->imager)));
  g_free (indices);
}

static void
chain_clear (Chain * c)
{
  sonar_imager_free (c->imager);
  sonar_clusterer_free (c->clusterer);
  sonar_velocity_pool_free (c->pool);
  g_free (c->hypotheses);
  g_free (c->image);
}

/* Simulates @json (noise 0.01) and runs it through @c; @truths receives
 * its reflectors' truth, @found the valid estimates. Returns their number
 * and sets *@n_centroids. */
static guint
chain_run (Chain * c, Fixture * f, const char *json, SonarTruth * truths,
    SonarVelocityEstimate * found, guint * n_centroids)
{
  SonarScene scene;
  SonarSimulatorParams params;
  SonarSimulator *sim;
  guint n = 0;

  g_assert_true (sonar_scene_load_data (&scene, json, "test", NULL));
  sonar_simulator_params_init_default (&params);
  params.noise_amplitude = 0.01;
  params.seed = 7;
  sim = sonar_simulator_new (f->setup, &params, NULL);
  sonar_simulator_render (sim, &scene, 0, 0.0, f->ping, truths);
  for (guint j = 0; j < f->setup->geometry.n_microphones; j++)
    sonar_spectrum_process (f->analyzer, f->ping + (gsize) j *
        f->setup->ping_length, f->setup->ping_length, 1,
        f->spectra + (gsize) j * sonar_doppler_bank_band (f->bank)->n_bins,
        NULL);
  sonar_imager_process (c->imager, f->spectra, c->n_hypotheses,
      c->hypotheses, -1, c->image);
  *n_centroids = sonar_clusterer_process (c->clusterer, c->image,
      c->centroids, G_N_ELEMENTS (c->centroids));
  sonar_velocity_pool_estimate (c->pool, f->spectra, c->centroids,
      *n_centroids, c->results, c->counts);
  for (guint k = 0; k < *n_centroids; k++)
    for (guint i = 0; i < c->counts[k]; i++)
      if (c->results[2 * k + i].valid)
        found[n++] = c->results[2 * k + i];
  sonar_simulator_free (sim);
  sonar_scene_clear (&scene);
  return n;
}

/* The estimate of @found nearest @truth in velocity, or NULL. */
static const SonarVelocityEstimate *
nearest_estimate (const SonarVelocityEstimate * found, guint n,
    const SonarTruth * truth)
{
  const SonarVelocityEstimate *best = NULL;

  for (guint i = 0; i < n; i++)
    if (!best || fabs (found[i].radial_velocity - truth->radial_velocity) <
        fabs (best->radial_velocity - truth->radial_velocity))
      best = &found[i];
  return best;
}

/* On the fan's 1-degree grid a detection's direction was its centroid's
 * (its members' weighted mean): 0.100, 0.035, 0.018 and 0.054 degree off
 * these four lone echoes. The pool now reports the vertex of the power
 * each echo's model explains: 0.005, 0.033, 0.002 and 0.001 off, and that
 * parabola's curvature for its sigma. */
static void
test_direction_of_lone_echoes (void)
{
  static const double places[][3] = {
    {1.0, 20.0, -0.5}, {1.6, -37.5, 0.8}, {2.4, 52.3, -1.1}, {3.1, 4.6, 0.2}
  };
  Fixture f;
  Chain c;
  SonarClusterParams cp;
  double off = 0.0;

  fixture_init (&f, -1.5, 1.5, 0.05);
  sonar_cluster_params_init_default (&cp);
  chain_init (&c, &f, &cp, 0);
  for (guint p = 0; p < G_N_ELEMENTS (places); p++) {
    g_autofree char *json = g_strdup_printf ("{\"dimensions\": 2, "
        "\"reflectors\": [{\"range\": %g, \"azimuth\": %g, "
        "\"strength\": 1, \"radial-velocity\": %g}]}", places[p][0],
        places[p][1], places[p][2]);
    SonarTruth truth[1];
    SonarVelocityEstimate found[8];
    guint n_centroids, n;

    n = chain_run (&c, &f, json, truth, found, &n_centroids);
    g_assert_cmpuint (n, ==, 1);
    g_test_message ("%.1f m, %.1f deg (truth %.4f): centroid %.4f deg, "
        "reported %.4f deg, curvature %.3g per deg^2", places[p][0],
        places[p][1], truth[0].azimuth, found[0].azimuth,
        found[0].echo_azimuth, found[0].direction_curvature[0]);
    g_assert_cmpfloat (fabs (found[0].echo_azimuth - truth[0].azimuth), <,
        0.04);
    off += fabs (found[0].echo_azimuth - truth[0].azimuth);
    g_assert_cmpfloat (found[0].direction_curvature[0], <, 0.0);
  }
  g_assert_cmpfloat (off, <, 0.06);
  chain_clear (&c);
  fixture_clear (&f);
}

/* A centroid that holds two reflectors (paper: "a single seemingly-large
 * object might be identified as two close lying objects with different
 * speeds"): two points at one azimuth 0.5-3 cm apart in range, whose
 * radial velocities differ by 0.4-5 m/s (more than a Doppler main lobe),
 * merge into one centroid between them (wardcluster joins peaks within
 * 0.1 m). At the defaults (bank -7..7 / 0.05) both are reported, each
 * with its own velocity (within 0.02 m/s) and range (within 3 mm). With
 * the second echo 6 dB weaker too, from 1.5 m/s apart (a main lobe
 * apart, a weaker echo may hide in the stronger's lobe: sonar-bench
 * --sweep split measures how often), within 0.05 m/s: the stronger echo,
 * smeared through the weaker one's templates, biases it (0.034 m/s at 5
 * m/s apart). */
static void
test_split_pairs (void)
{
  const double separations[] = { 0.005, 0.015, 0.03 };
  const double differences[] = { 0.4, 1.5, 5.0 };
  const double weaker[] = { 1.0, 0.5 };
  SonarClusterParams cp;
  Fixture f;
  Chain c;

  fixture_init (&f, -7.0, 7.0, 0.05);
  sonar_cluster_params_init_default (&cp);
  chain_init (&c, &f, &cp, 1);
  for (guint w = 0; w < G_N_ELEMENTS (weaker); w++) {
    for (guint i = 0; i < G_N_ELEMENTS (separations); i++) {
      for (guint j = w; j < G_N_ELEMENTS (differences); j++) {
        /* The faster one nearer or farther, approaching or receding. */
        const double sign = (i + j) % 2 ? -1.0 : 1.0;
        g_autofree char *json = g_strdup_printf ("{\"dimensions\": 2, "
            "\"reflectors\": [{\"range\": 2.5, \"azimuth\": -25, "
            "\"radial-velocity\": 0.3}, {\"range\": %g, \"azimuth\": -25, "
            "\"radial-velocity\": %g, \"strength\": %g}]}", 2.5 + sign *
            separations[i], 0.3 + sign * differences[j], weaker[w]);
        SonarTruth truths[2];
        SonarVelocityEstimate found[128];
        guint n_centroids, n;

        n = chain_run (&c, &f, json, truths, found, &n_centroids);
        g_test_message ("%.1f cm, %+.1f m/s, second %.0f dB weaker: %u "
            "centroid(s), %u objects", 100 * separations[i], sign *
            differences[j], -20.0 * log10 (weaker[w]), n_centroids, n);
        g_assert_cmpuint (n, ==, 2);
        for (guint k = 0; k < 2; k++) {
          const SonarVelocityEstimate *e = nearest_estimate (found, n,
              &truths[k]);
          g_test_message ("  truth %.4f m %+.4f m/s: estimate %.4f m "
              "%+.4f m/s (error %.4f m/s, %.1f mm)", truths[k].range,
              truths[k].radial_velocity, e->range, e->radial_velocity,
              fabs (e->radial_velocity - truths[k].radial_velocity),
              1e3 * fabs (e->range - truths[k].range));
          g_assert_cmpfloat (fabs (e->radial_velocity -
                  truths[k].radial_velocity), <=, weaker[w] < 1.0 ? 0.05 :
              0.02);
          g_assert_cmpfloat (fabs (e->range - truths[k].range), <=, 0.003);
          g_assert_cmpfloat (fabs (e->azimuth - truths[k].azimuth), <=, 1.0);
        }
        g_assert_true (nearest_estimate (found, n, &truths[0]) !=
            nearest_estimate (found, n, &truths[1]));
      }
    }
  }
  chain_clear (&c);
  fixture_clear (&f);
}

/* A single object is never split: point reflectors across the bank, the
 * fan and the range give one object each, with its velocity. */
static void
test_single_not_split (void)
{
  const double cases[][3] = {   /* range, azimuth, radial velocity */
    {0.8, 30, -6.5}, {1.4, -60, -2.0}, {2.0, 0, -0.3}, {2.7, 45, 0.0},
    {3.3, -10, 0.7}, {3.9, 70, 3.3}, {4.5, -35, 6.0},
  };
  SonarClusterParams cp;
  Fixture f;
  Chain c;

  fixture_init (&f, -7.0, 7.0, 0.05);
  sonar_cluster_params_init_default (&cp);
  chain_init (&c, &f, &cp, 1);
  for (guint i = 0; i < G_N_ELEMENTS (cases); i++) {
    g_autofree char *json = g_strdup_printf ("{\"dimensions\": 2, "
        "\"reflectors\": [{\"range\": %g, \"azimuth\": %g, "
        "\"radial-velocity\": %g}]}", cases[i][0], cases[i][1],
        cases[i][2]);
    SonarTruth truth;
    SonarVelocityEstimate found[128];
    guint n_centroids, n;

    n = chain_run (&c, &f, json, &truth, found, &n_centroids);
    g_test_message ("%.1f m %+.0f deg %+.1f m/s: %u centroid(s), %u "
        "objects, first %+.4f m/s", cases[i][0], cases[i][1], cases[i][2],
        n_centroids, n, n ? found[0].radial_velocity : NAN);
    g_assert_cmpuint (n, ==, 1);
    g_assert_cmpfloat (fabs (found[0].radial_velocity -
            truth.radial_velocity), <=, 0.02);
  }
  chain_clear (&c);
  fixture_clear (&f);
}

/* wardcluster's distance set to a millimetre leaves two centroids a few
 * millimetres apart that each see both echoes: each object is reported
 * once. */
static void
test_split_not_duplicated (void)
{
  const double separations[] = { 0.0135, 0.0145 };
  SonarClusterParams cp;
  Fixture f;
  Chain c;

  fixture_init (&f, -7.0, 7.0, 0.05);
  sonar_cluster_params_init_default (&cp);
  cp.stop = SONAR_STOP_DISTANCE;
  cp.distance = 0.001;
  chain_init (&c, &f, &cp, 1);
  for (guint i = 0; i < G_N_ELEMENTS (separations); i++) {
    /* The mover, imaged 8.7 mm nearer than it is, 5-6 mm from the still
     * one. */
    g_autofree char *json = g_strdup_printf ("{\"dimensions\": 2, "
        "\"reflectors\": [{\"range\": 2.0, \"azimuth\": 20}, "
        "{\"range\": %g, \"azimuth\": 20, \"radial-velocity\": -1.5}]}",
        2.0 + separations[i]);
    SonarTruth truths[2];
    SonarVelocityEstimate found[128];
    guint n_centroids, n;

    n = chain_run (&c, &f, json, truths, found, &n_centroids);
    g_test_message ("%.2f cm: %u centroids, %u objects", 100 *
        separations[i], n_centroids, n);
    g_assert_cmpuint (n_centroids, >=, 2);
    g_assert_cmpuint (n, ==, 2);
    for (guint k = 0; k < 2; k++)
      g_assert_cmpfloat (fabs (nearest_estimate (found, n,
                  &truths[k])->radial_velocity - truths[k].radial_velocity),
          <=, 0.03);
  }
  chain_clear (&c);
  fixture_clear (&f);
}

/* @a and @b field by field, bit for bit (not their padding). */
static void
assert_same_estimate (const SonarVelocityEstimate * a,
    const SonarVelocityEstimate * b)
{
  const double da[] = { a->range, a->azimuth, a->elevation,
    a->radial_velocity, a->peak_db, a->velocity_curvature, a->variance,
    a->coherence
  };
  const double db[] = { b->range, b->azimuth, b->elevation,
    b->radial_velocity, b->peak_db, b->velocity_curvature, b->variance,
    b->coherence
  };

  g_assert_cmpmem (da, sizeof da, db, sizeof db);
  g_assert_cmpuint (a->bank_index, ==, b->bank_index);
  g_assert_cmpuint (a->agreeing_emitters, ==, b->agreeing_emitters);
  g_assert_cmpint (a->at_bank_edge, ==, b->at_bank_edge);
  g_assert_cmpint (a->valid, ==, b->valid);
  g_assert_cmpint (a->second, ==, b->second);
  g_assert_cmpuint (a->evaluated_velocities, ==, b->evaluated_velocities);
}

/* An estimator keeps state between estimates (the curves' logarithms,
 * refilled only where they changed): each estimate and its curves are
 * the same bit for bit whatever was estimated before, here a pair of
 * echoes of two speeds in one centroid (both found: their neighbourhoods
 * evaluated again apart) and a lone echo, against a fresh estimator. */
static void
test_independent_of_order (void)
{
  const char *json = "{\"dimensions\": 2, \"reflectors\": ["
      "{\"range\": 2.5, \"azimuth\": -25, \"radial-velocity\": 0.3}, "
      "{\"range\": 2.505, \"azimuth\": -25, \"radial-velocity\": 1.8}, "
      "{\"range\": 3.2, \"azimuth\": 30, \"radial-velocity\": -0.9}]}";
  SonarScene scene;
  SonarSimulatorParams params;
  SonarSimulator *sim;
  SonarVelocityParams vp;
  SonarVelocityEstimator *fresh;
  SonarTruth truth[3];
  SonarCentroid centroids[2];
  SonarVelocityEstimate first[2][2], again[2][2];
  guint counts[2], counts_again[2];
  g_autofree float *curves = NULL, *curves_again = NULL;
  Fixture f;
  gsize n_curves;

  fixture_init (&f, -7.0, 7.0, 0.05);
  n_curves = (gsize) (f.setup->geometry.n_emitters + 1) *
      sonar_doppler_bank_n_velocities (f.bank);
  curves = g_new (float, 2 * n_curves);
  curves_again = g_new (float, 2 * n_curves);
  g_assert_true (sonar_scene_load_data (&scene, json, "test", NULL));
  sonar_simulator_params_init_default (&params);
  params.seed = 7;
  sim = sonar_simulator_new (f.setup, &params, NULL);
  sonar_simulator_render (sim, &scene, 0, 0.0, f.ping, truth);
  for (guint j = 0; j < f.setup->geometry.n_microphones; j++)
    sonar_spectrum_process (f.analyzer, f.ping + (gsize) j *
        f.setup->ping_length, f.setup->ping_length, 1,
        f.spectra + (gsize) j * sonar_doppler_bank_band (f.bank)->n_bins,
        NULL);
  centroids[0] = sonar_velocity_point (truth[0].range, truth[0].azimuth,
      truth[0].elevation);
  centroids[0].range_max = truth[1].range;
  centroids[0].n_members = 2;
  centroids[1] = sonar_velocity_point (truth[2].range, truth[2].azimuth,
      truth[2].elevation);

  for (guint k = 0; k < 2; k++)
    counts[k] = sonar_velocity_estimate (f.est, f.spectra, &centroids[k],
        first[k], curves + k * n_curves);
  g_assert_cmpuint (counts[0], ==, 2);
  g_assert_true (first[0][0].valid && first[0][1].valid);
  /* The other way round on the same estimator. */
  for (guint k = 2; k-- > 0;)
    counts_again[k] = sonar_velocity_estimate (f.est, f.spectra,
        &centroids[k], again[k], curves_again + k * n_curves);
  sonar_velocity_params_init_default (&vp);
  fresh = sonar_velocity_estimator_new (f.bank, &f.grid, &vp, NULL);
  counts[1] = sonar_velocity_estimate (fresh, f.spectra, &centroids[1],
      first[1], curves + n_curves);
  for (guint k = 0; k < 2; k++) {
    g_assert_cmpuint (counts_again[k], ==, counts[k]);
    for (guint i = 0; i < counts[k]; i++)
      assert_same_estimate (&again[k][i], &first[k][i]);
  }
  g_assert_cmpmem (curves_again, 2 * n_curves * sizeof (float), curves,
      2 * n_curves * sizeof (float));
  sonar_velocity_estimator_free (fresh);
  sonar_simulator_free (sim);
  sonar_scene_clear (&scene);
  fixture_clear (&f);
}

/* 40 random still-ish objects at 1-4 m and +-60 degrees (seed 11): a
 * crowd in which several echoes are examined as possible blends. */
static GString *
crowd_of_40 (void)
{
  GString *json = g_string_new ("{\"dimensions\": 2, \"reflectors\": [");
  g_autoptr (GRand) rand = g_rand_new_with_seed (11);

  for (guint i = 0; i < 40; i++)
    g_string_append_printf (json, "%s{\"range\": %.3f, \"azimuth\": %.1f, "
        "\"radial-velocity\": %.2f}", i ? ", " : "", g_rand_double_range
        (rand, 1.0, 4.0), g_rand_double_range (rand, -60.0, 60.0),
        g_rand_double_range (rand, -0.8, 0.8));
  g_string_append (json, "]}");
  return json;
}

/* Two chains' estimates of the same ping, centroid by centroid, bit for
 * bit. */
static void
assert_same_chain_results (const Chain * got, const Chain * want,
    guint n_got, guint n_want)
{
  g_assert_cmpuint (n_got, ==, n_want);
  for (guint k = 0; k < n_want; k++) {
    g_assert_cmpuint (got->counts[k], ==, want->counts[k]);
    for (guint i = 0; i < want->counts[k]; i++)
      assert_same_estimate (&got->results[2 * k + i],
          &want->results[2 * k + i]);
  }
}

/* A crowd's echoes that may be blends of two (split_first ()) are
 * examined by the pool's workers side by side, each on its own buffers
 * and estimator: the same estimates, bit for bit, as one worker's, on a
 * ping of 40 objects where several are examined. */
static void
test_crowd_examined_by_workers (void)
{
  GString *json = crowd_of_40 ();
  SonarTruth truths[40];
  SonarVelocityEstimate found[2][128];
  guint n_centroids[2], n[2], examined;
  SonarClusterParams cp;
  Fixture f;
  Chain one, three;

  fixture_init (&f, -1.0, 1.0, 0.05);
  sonar_cluster_params_init_default (&cp);
  chain_init (&one, &f, &cp, 1);
  chain_init (&three, &f, &cp, 3);
  n[0] = chain_run (&one, &f, json->str, truths, found[0], &n_centroids[0]);
  examined = sonar_velocity_pool_last_examined (one.pool);
  n[1] = chain_run (&three, &f, json->str, truths, found[1], &n_centroids[1]);
  g_test_message ("%u centroids, %u objects, %u echoes examined",
      n_centroids[0], n[0], examined);
  g_assert_cmpuint (examined, >=, 3);
  g_assert_cmpuint (sonar_velocity_pool_last_examined (three.pool), ==,
      examined);
  g_assert_cmpuint (n[1], ==, n[0]);
  assert_same_chain_results (&three, &one, n_centroids[1], n_centroids[0]);
  chain_clear (&one);
  chain_clear (&three);
  fixture_clear (&f);
  g_string_free (json, TRUE);
}

/* The checks for blends keep a candidate's echo model for the next pass
 * instead of making it again: on a crowd where several models are
 * reused, each is the one made anew bit for bit, and the estimates are
 * the same as without checking. */
static void
test_blend_models_reused (void)
{
  GString *json = crowd_of_40 ();
  SonarTruth truths[40];
  SonarVelocityEstimate found[2][128];
  guint n_centroids[2], n[2], reused;
  SonarClusterParams cp;
  Fixture f;
  Chain reusing, checking;

  fixture_init (&f, -1.0, 1.0, 0.05);
  sonar_cluster_params_init_default (&cp);
  chain_init (&reusing, &f, &cp, 1);
  chain_init (&checking, &f, &cp, 1);
  sonar_velocity_pool_check_models (checking.pool, TRUE);
  n[0] = chain_run (&reusing, &f, json->str, truths, found[0],
      &n_centroids[0]);
  reused = sonar_velocity_pool_last_reused (reusing.pool);
  n[1] = chain_run (&checking, &f, json->str, truths, found[1],
      &n_centroids[1]);
  g_test_message ("%u centroids, %u echoes examined, %u models reused",
      n_centroids[0], sonar_velocity_pool_last_examined (reusing.pool),
      reused);
  g_assert_cmpuint (reused, >=, 2);
  g_assert_cmpuint (sonar_velocity_pool_last_reused (checking.pool), ==,
      reused);
  g_assert_cmpuint (n[1], ==, n[0]);
  assert_same_chain_results (&checking, &reusing, n_centroids[1],
      n_centroids[0]);
  chain_clear (&reusing);
  chain_clear (&checking);
  fixture_clear (&f);
  g_string_free (json, TRUE);
}

/* Approaching is moving towards the sensor by what reads -0.01 m/s or
 * less: a still object's estimate a few mm/s below 0 (two of the golden
 * Fig. 9's still objects read -0.001 and -0.0004) is not approaching. */
static void
test_approaching (void)
{
  g_assert_true (sonar_velocity_approaching (-1.0));
  g_assert_true (sonar_velocity_approaching (-0.0051));
  g_assert_false (sonar_velocity_approaching (-0.0049));
  g_assert_false (sonar_velocity_approaching (-0.001058));
  g_assert_false (sonar_velocity_approaching (0.0));
  g_assert_false (sonar_velocity_approaching (0.3));
  g_assert_false (sonar_velocity_approaching (NAN));
}

int
main (int argc, char **argv)
{
  g_test_init (&argc, &argv, NULL);
  g_test_add_func ("/velocity/slow-objects", test_slow_objects);
  g_test_add_func ("/velocity/fast-movers", test_fast_movers);
  g_test_add_func ("/velocity/emitters-subset", test_emitters_subset);
  g_test_add_func ("/velocity/acf-no-underflow", test_acf_no_underflow);
  g_test_add_func ("/velocity/direction-of-lone-echoes",
      test_direction_of_lone_echoes);
  g_test_add_func ("/velocity/split-pairs", test_split_pairs);
  g_test_add_func ("/velocity/single-not-split", test_single_not_split);
  g_test_add_func ("/velocity/split-not-duplicated",
      test_split_not_duplicated);
  g_test_add_func ("/velocity/independent-of-order",
      test_independent_of_order);
  g_test_add_func ("/velocity/blend-models-reused",
      test_blend_models_reused);
  g_test_add_func ("/velocity/crowd-examined-by-workers",
      test_crowd_examined_by_workers);
  g_test_add_func ("/velocity/approaching", test_approaching);
  return g_test_run ();
}
