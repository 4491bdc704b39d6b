/* test-residual.c: the residual search (sonar-residual.h) through the
 * core: an echo hidden within a stronger one's pulse, found on the ping
 * less the accepted echoes; a ping with nothing accepted costs nothing;
 * the imager makes a grid again from the grid alone; a lone echo is
 * cancelled deep, calibrated or not, and one whose spectrum air has
 * tilted down to the noise. */
#include <math.h>

#include "sonar-cluster.h"
#include "sonar-imager.h"
#include "sonar-residual.h"
#include "sonar-test-util.h"
#include "sonar-velocity.h"

#define NOISE 0.01
#define MATCH_DISTANCE 0.05
#define MAX_CENTROIDS 1024

typedef struct
{
  SonarTestChain chain;
  SonarImager *imager;
  const SonarImageGrid *grid;
  guint n_hypotheses;
  SonarHypothesis *hypotheses;
  SonarClusterer *clusterer;
  SonarVelocityPool *pool;
  SonarResidualSearch *search;
  float *image;
  SonarCentroid centroids[MAX_CENTROIDS];
  SonarVelocityEstimate results[2 * MAX_CENTROIDS];
  guint counts[MAX_CENTROIDS];
  guint n_centroids;
} Fixture;

/* The elements' defaults on a -1.5..1.5 m/s bank. */
static void
fixture_init (Fixture * f)
{
  g_autoptr (GError) error = NULL;
  g_autofree guint *indices = NULL;
  SonarImagerParams ip;
  SonarClusterParams cp;
  SonarVelocityParams vp;

  sonar_test_chain_init_with_bank (&f->chain, -1.5, 1.5, 0.05);
  sonar_imager_params_init_default (&ip);
  f->imager = sonar_imager_new (f->chain.setup, &f->chain.band, &ip,
      &error);
  g_assert_no_error (error);
  f->grid = sonar_imager_grid (f->imager);
  indices = g_new (guint, sonar_doppler_bank_n_velocities (f->chain.bank) +
      2);
  f->n_hypotheses = sonar_doppler_bank_hypotheses (f->chain.bank,
      SONAR_IMAGER_HYPOTHESIS_SPACING, indices);
  f->hypotheses = g_new (SonarHypothesis, f->n_hypotheses);
  for (guint h = 0; h < f->n_hypotheses; h++)
    f->hypotheses[h] = sonar_doppler_bank_hypothesis (f->chain.bank,
        indices[h]);
  sonar_cluster_params_init_default (&cp);
  cp.hypotheses = f->n_hypotheses;
  f->clusterer = sonar_clusterer_new (f->grid, &cp, &error);
  g_assert_no_error (error);
  sonar_velocity_params_init_default (&vp);
  f->pool = sonar_velocity_pool_new (f->chain.bank, f->grid, &vp, 0, &error);
  g_assert_no_error (error);
  f->search = sonar_residual_search_new (f->chain.setup, &f->chain.band,
      f->chain.bank, f->grid, f->chain.setup->geometry.n_emitters, &error);
  g_assert_no_error (error);
  f->image = g_new (float, sonar_image_grid_size (f->grid));
}

static void
fixture_clear (Fixture * f)
{
  g_free (f->image);
  sonar_residual_search_free (f->search);
  sonar_velocity_pool_free (f->pool);
  sonar_clusterer_free (f->clusterer);
  g_free (f->hypotheses);
  sonar_imager_free (f->imager);
  sonar_test_chain_clear (&f->chain);
}

/* The ping of @json through the image, the clusters and the estimates, as
 * the elements make them before the search. */
static void
first_estimates (Fixture * f, const char *json)
{
  sonar_test_chain_simulate (&f->chain, json, NOISE);
  sonar_imager_process (f->imager, f->chain.mic_spectra, f->n_hypotheses,
      f->hypotheses, -1, f->image);
  f->n_centroids = sonar_clusterer_process (f->clusterer, f->image,
      f->centroids, MAX_CENTROIDS);
  sonar_velocity_pool_estimate (f->pool, f->chain.mic_spectra, f->centroids,
      f->n_centroids, f->results, f->counts);
}

static SonarVec3
position_of (const SonarVelocityEstimate * e)
{
  return sonar_vec3_scale (sonar_vec3_from_direction (e->echo_azimuth,
          e->echo_elevation), e->echo_range);
}

/* The valid estimates of @n centroids within MATCH_DISTANCE of @where:
 * their number, the last in *@match. */
static guint
valid_near (const SonarVelocityEstimate * results, const guint * counts,
    guint n, SonarVec3 where, const SonarVelocityEstimate ** match)
{
  guint found = 0;

  for (guint k = 0; k < n; k++)
    for (guint i = 0; i < counts[k]; i++) {
      const SonarVelocityEstimate *e = &results[2 * k + i];
      if (e->valid && sonar_vec3_norm (sonar_vec3_sub (position_of (e),
                  where)) < MATCH_DISTANCE) {
        found++;
        *match = e;
      }
    }
  return found;
}

static guint
count_valid (const SonarVelocityEstimate * results, const guint * counts,
    guint n)
{
  guint valid = 0;

  for (guint k = 0; k < n; k++)
    for (guint i = 0; i < counts[k]; i++)
      valid += results[2 * k + i].valid;
  return valid;
}

/* Where @range m and @azimuth degrees (in the fan) are. */
static SonarVec3
point (double range, double azimuth)
{
  return sonar_vec3_scale (sonar_vec3_from_direction (azimuth, 0.0), range);
}

/* A point 14 dB below a strong one (strength 0.2 against 1 at 1.0 and 1.6
 * m: equal after the range compensation, less 14 dB), 0.6 m behind it in
 * its direction: within its pulse (1.5 m), under its cross-talk ridge. The
 * first estimates see the strong one alone; the search finds the other,
 * its velocity within 0.03 m/s (an echo accepted on a residual carries
 * the cancelled model's errors), and nothing at the strong one's own
 * cell (what its cancellation left). */
static void
test_hidden_within_pulse (void)
{
  Fixture f;
  const SonarCentroid *found;
  const SonarVelocityEstimate *results, *e = NULL;
  const guint *counts;
  guint n, units, passes, estimated;

  fixture_init (&f);
  first_estimates (&f, "{\"dimensions\": 2, \"reflectors\": ["
      "{\"range\": 1.0, \"azimuth\": 20, \"strength\": 1,"
      " \"radial-velocity\": -0.5},"
      "{\"range\": 1.6, \"azimuth\": 21, \"strength\": 0.2,"
      " \"radial-velocity\": 0.4}]}");
  g_assert_cmpuint (count_valid (f.results, f.counts, f.n_centroids), ==, 1);
  g_assert_cmpuint (valid_near (f.results, f.counts, f.n_centroids,
          point (1.0, 20.0), &e), ==, 1);
  g_assert_cmpfloat (fabs (e->radial_velocity + 0.5), <, 0.01);
  g_assert_cmpuint (valid_near (f.results, f.counts, f.n_centroids,
          point (1.6, 21.0), &e), ==, 0);

  n = sonar_residual_search_process (f.search, f.pool, f.n_centroids,
      f.results, f.counts, &found, &results, &counts);
  sonar_residual_search_last_work (f.search, &units, &passes, &estimated);
  g_test_message ("residual: %u centroids estimated, %u units, %u passes",
      estimated, units, passes);
  g_assert_cmpuint (n, ==, estimated);
  g_assert_cmpuint (units, >, 0);
  g_assert_cmpuint (count_valid (results, counts, n), ==, 1);
  g_assert_cmpuint (valid_near (results, counts, n, point (1.6, 21.0), &e),
      ==, 1);
  g_test_message ("hidden echo: %.4f m, %.2f deg, %+.4f m/s",
      e->echo_range, e->echo_azimuth, e->radial_velocity);
  g_assert_cmpfloat (fabs (e->radial_velocity - 0.4), <, 0.03);
  fixture_clear (&f);
}

/* The strongest pixel of @image within 2 cm and 3 degrees of @range m,
 * @azimuth degrees. */
static float
peak_near (const float *image, const SonarImageGrid * g, double range,
    double azimuth)
{
  float top = 0.0f;

  for (guint a = 0; a < g->n_azimuth; a++)
    for (guint i = 0; i < g->n_range; i++)
      if (fabs (g->azimuth_first + a * g->azimuth_step - azimuth) <= 3.0
          && fabs (g->range_first + i * g->range_step - range) <= 0.02)
        top = MAX (top, image[(gsize) a * g->n_range + i]);
  return top;
}

/* The ping in @f's spectra (simulated, then altered by the caller)
 * through the image, the clusters and the estimates, then imaged again
 * less its accepted echoes (sonar_velocity_pool_residual ()): how much of
 * the echo at @range m, @azimuth degrees is left, dB under it. Its one
 * valid estimate there goes to *@e. */
static double
echo_left_db (Fixture * f, double range, double azimuth,
    const SonarVelocityEstimate ** e)
{
  const gsize size = (gsize) f->chain.setup->geometry.n_microphones *
      f->chain.band.n_bins;
  g_autofree SonarComplex *residual = g_new (SonarComplex, size);
  float echo, left;

  sonar_imager_process (f->imager, f->chain.mic_spectra, f->n_hypotheses,
      f->hypotheses, -1, f->image);
  echo = peak_near (f->image, f->grid, range, azimuth);
  f->n_centroids = sonar_clusterer_process (f->clusterer, f->image,
      f->centroids, MAX_CENTROIDS);
  sonar_velocity_pool_estimate (f->pool, f->chain.mic_spectra, f->centroids,
      f->n_centroids, f->results, f->counts);
  g_assert_cmpuint (valid_near (f->results, f->counts, f->n_centroids,
          point (range, azimuth), e), ==, 1);
  sonar_velocity_pool_residual (f->pool, f->results, f->counts,
      f->n_centroids, residual);
  sonar_imager_process (f->imager, residual, f->n_hypotheses,
      f->hypotheses, -1, f->image);
  left = peak_near (f->image, f->grid, range, azimuth);
  return 20.0 * log10 (left / echo);
}

/* An echo whose spectrum air has tilted: at 4 m, ISO 9613-1's absorption
 * (20 C, 50 % humidity) takes 4 dB more off its 20 kHz end than the
 * emissions say and 21 dB off its 80 kHz end; here a tilt of 24 dB
 * across the band, linear in dB (of that shape). A model of the
 * emissions' own spectrum, one amplitude over the band, left -9.1 dB of
 * the echo in the image (measured with one shape; two: -18.9, three:
 * -34.0, four: -43.3); the model's
 * amplitude a polynomial in frequency (sonar-velocity.c, MODEL_SHAPES)
 * leaves the noise: more than 30 dB under the echo. */
static void
test_tilted_echo_cancelled (void)
{
  Fixture f;
  const double range = 4.0, azimuth = -25.0;
  const SonarBand *band = &f.chain.band;
  const guint n_mics = 32;
  const SonarVelocityEstimate *e = NULL;
  double left;

  fixture_init (&f);
  g_assert_cmpuint (f.chain.setup->geometry.n_microphones, ==, n_mics);
  sonar_test_chain_simulate (&f.chain, "{\"dimensions\": 2, \"reflectors\": "
      "[{\"range\": 4.0, \"azimuth\": -25, \"strength\": 4,"
      " \"radial-velocity\": 0.7}]}", NOISE);
  for (guint k = 0; k < band->n_bins; k++) {
    const double f_k = sonar_band_frequency (band, k);
    const double db = -24.0 * (f_k - f.chain.setup->band_low) /
        (f.chain.setup->band_high - f.chain.setup->band_low);
    const float gain = (float) pow (10.0, CLAMP (db, -24.0, 0.0) / 20.0);
    for (guint j = 0; j < n_mics; j++)
      f.chain.mic_spectra[(gsize) j * band->n_bins + k] *= gain;
  }
  left = echo_left_db (&f, range, azimuth, &e);
  g_assert_cmpfloat (fabs (e->radial_velocity - 0.7), <, 0.02);
  g_test_message ("tilted echo: %.1f dB of it left", left);
  g_assert_cmpfloat (left, <, -30.0);
  fixture_clear (&f);
}

/* What the residual search's cancellation (sonar_velocity_pool_residual
 * ()) leaves of a lone echo in the residual image, dB under the echo,
 * the array's microphones each off by @gain_db and @phase_deg at most
 * (a fixed spread over them; 0: calibrated). */
static double
echo_left (double gain_db, double phase_deg)
{
  Fixture f;
  const SonarBand *band = &f.chain.band;
  const guint n_mics = 32;
  const SonarVelocityEstimate *e = NULL;
  double left;

  fixture_init (&f);
  g_assert_cmpuint (f.chain.setup->geometry.n_microphones, ==, n_mics);
  sonar_test_chain_simulate (&f.chain, "{\"dimensions\": 2, \"reflectors\": "
      "[{\"range\": 1.0, \"azimuth\": 20, \"strength\": 1,"
      " \"radial-velocity\": -0.5}]}", NOISE);
  for (guint j = 0; j < n_mics; j++) {
    /* -1 .. 1 over the microphones, in an order unrelated to their
     * places. */
    const double u = ((j * 13) % n_mics) / (n_mics - 1.0) * 2.0 - 1.0;
    const SonarComplex gain = (SonarComplex) (pow (10.0, u * gain_db /
            20.0) * cexp (I * G_PI / 180.0 * phase_deg * -u));
    for (guint k = 0; k < band->n_bins; k++)
      f.chain.mic_spectra[(gsize) j * band->n_bins + k] *= gain;
  }
  left = echo_left_db (&f, 1.0, 20.0, &e);
  g_test_message ("echo estimated at %.4f m, %.3f deg", e->echo_range,
      e->echo_azimuth);
  fixture_clear (&f);
  return left;
}

/* A lone echo at 1 m, 20 degrees: its centroid lies 0.1 degree off it
 * (its members' weighted mean), where its model left it at -28 dB; at
 * its explained power's vertex, -43 dB (each microphone's own gain alone:
 * -30). The microphones off by up to 3 dB and 20 degrees: the vertex
 * with one amplitude over the array leaves -36.5 dB, with each
 * microphone's own gain -43. */
static void
test_cancelled_deep (void)
{
  const double calibrated = echo_left (0.0, 0.0);
  const double uncalibrated = echo_left (3.0, 20.0);

  g_test_message ("left of the echo: %.1f dB calibrated, %.1f dB "
      "uncalibrated", calibrated, uncalibrated);
  g_assert_cmpfloat (calibrated, <, -38.0);
  g_assert_cmpfloat (uncalibrated, <, -40.0);
}

/* Noise alone: nothing accepted, so nothing is imaged again. */
static void
test_nothing_accepted (void)
{
  Fixture f;
  const SonarCentroid *found;
  const SonarVelocityEstimate *results;
  const guint *counts;
  guint units, passes, estimated;

  fixture_init (&f);
  first_estimates (&f, "{\"dimensions\": 2, \"reflectors\": []}");
  g_assert_cmpuint (count_valid (f.results, f.counts, f.n_centroids), ==, 0);
  g_assert_cmpuint (sonar_residual_search_process (f.search, f.pool,
          f.n_centroids, f.results, f.counts, &found, &results, &counts), ==,
      0);
  sonar_residual_search_last_work (f.search, &units, &passes, &estimated);
  g_assert_cmpuint (units, ==, 0);
  g_assert_cmpuint (passes, ==, 0);
  g_assert_cmpuint (estimated, ==, 0);
  fixture_clear (&f);
}

/* sonar_imager_params_set_grid (): the grid alone makes the same grid
 * again, on the fan, the hemisphere and a narrow fan of odd range
 * settings (what mimobeamform's properties may give). */
static void
test_grid_round_trip (void)
{
  SonarTestChain chain;
  SonarImagerParams params[3];

  sonar_test_chain_init (&chain, 4000);
  sonar_imager_params_init_default (&params[0]);
  sonar_imager_params_init_default (&params[1]);
  sonar_imager_params_set_view (&params[1], SONAR_FIELD_OF_VIEW_HEMISPHERE);
  sonar_imager_params_init_default (&params[2]);
  params[2].azimuth_min = -61.3;
  params[2].azimuth_max = 47.9;
  params[2].n_azimuth = 37;
  params[2].range_min = 0.4567;
  params[2].range_max = 3.21;
  params[2].range_resolution = 0.0031;
  for (guint i = 0; i < G_N_ELEMENTS (params); i++) {
    g_autoptr (GError) error = NULL;
    g_autoptr (SonarImager) a = sonar_imager_new (chain.setup, &chain.band,
        &params[i], &error);
    g_autoptr (SonarImager) b = NULL;
    SonarImagerParams again;
    const SonarImageGrid *ga, *gb;

    g_assert_no_error (error);
    ga = sonar_imager_grid (a);
    sonar_imager_params_init_default (&again);
    sonar_imager_params_set_grid (&again, ga);
    b = sonar_imager_new (chain.setup, &chain.band, &again, &error);
    g_assert_no_error (error);
    gb = sonar_imager_grid (b);
    g_assert_true (sonar_image_grid_equal (ga, gb));
    g_assert_cmpuint (ga->n_range, ==, gb->n_range);
    g_assert_cmpuint (ga->n_azimuth, ==, gb->n_azimuth);
    g_assert_cmpuint (ga->n_elevation, ==, gb->n_elevation);
    g_assert_cmpfloat (fabs (ga->range_first - gb->range_first), <, 1e-12);
    g_assert_cmpfloat (fabs (ga->range_step - gb->range_step), <, 1e-15);
  }
  sonar_test_chain_clear (&chain);
}

/* The search images the energyscape's grid as mimobeamform does by
 * default, whatever the set-up's field of view: on the test chain's fan
 * set-up, a 3-D grid coarse by two main lobes of the eRTIS beam (6
 * degrees, as mimobeamform's 3-D image) and the fan by one (3). With one
 * lobe on the 2-degree 3-D grid its coarse pass was 4 degrees: 2.2 times
 * the coarse directions of the image it searches again, on every ping
 * (sonar-bench --sweep hemisphere-fig9). */
static void
test_coarse_grid_follows_image (void)
{
  SonarTestChain chain;

  sonar_test_chain_init_with_bank (&chain, -0.4, 0.4, 0.05);
  g_assert_cmpint (chain.setup->field_of_view, ==, SONAR_FIELD_OF_VIEW_FAN);
  for (guint view = 0; view < 2; view++) {
    g_autoptr (GError) error = NULL;
    g_autoptr (SonarImager) imager = NULL;
    g_autoptr (SonarResidualSearch) search = NULL;
    SonarImagerParams p;
    double azimuth[2], elevation[2];

    sonar_imager_params_init_default (&p);
    if (view)
      sonar_imager_params_set_view (&p, SONAR_FIELD_OF_VIEW_HEMISPHERE);
    sonar_imager_params_fit_beam (&p);
    imager = sonar_imager_new (chain.setup, &chain.band, &p, &error);
    g_assert_no_error (error);
    search = sonar_residual_search_new (chain.setup, &chain.band,
        chain.bank, sonar_imager_grid (imager),
        chain.setup->geometry.n_emitters, &error);
    g_assert_no_error (error);
    sonar_imager_coarse_spacing (imager, &azimuth[0], &elevation[0]);
    sonar_imager_coarse_spacing (sonar_residual_search_imager (search),
        &azimuth[1], &elevation[1]);
    g_test_message ("%s: coarse %g x %g degrees, the search's %g x %g",
        view ? "3-D" : "fan", azimuth[0], elevation[0], azimuth[1],
        elevation[1]);
    g_assert_cmpfloat (azimuth[0], ==, view ? 6.0 : 3.0);
    g_assert_cmpfloat (elevation[0], ==, view ? 6.0 : 0.0);
    g_assert_cmpfloat (azimuth[1], ==, azimuth[0]);
    g_assert_cmpfloat (elevation[1], ==, elevation[0]);
  }
  sonar_test_chain_clear (&chain);
}

int
main (int argc, char **argv)
{
  g_test_init (&argc, &argv, NULL);
  g_test_add_func ("/residual/hidden-within-pulse", test_hidden_within_pulse);
  g_test_add_func ("/residual/nothing-accepted", test_nothing_accepted);
  g_test_add_func ("/residual/grid-round-trip", test_grid_round_trip);
  g_test_add_func ("/residual/coarse-grid-follows-image",
      test_coarse_grid_follows_image);
  g_test_add_func ("/residual/cancelled-deep", test_cancelled_deep);
  g_test_add_func ("/residual/tilted-echo-cancelled",
      test_tilted_echo_cancelled);
  return g_test_run ();
}
