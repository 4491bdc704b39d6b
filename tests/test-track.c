/* test-track.c: the sensor's own motion (sonar-egomotion) and tracks
 * (sonar-track) against the simulator's truth, without a pipeline: on
 * detections made from the truth with the nominal errors added, and on
 * the whole chain's detections of the Fig. 10 drive
 * (tests/data/golden-fig10.jsonl). The element's test (test-sonartrack.c)
 * runs the goals through the real chain. */
#include <json-glib/json-glib.h>
#include <math.h>
#include <string.h>

#include "sonar-egomotion.h"
#include "sonar-error.h"
#include "sonar-linalg.h"
#include "sonar-rng.h"
#include "sonar-scene.h"
#include "sonar-simulator.h"
#include "sonar-test-util.h"
#include "sonar-track.h"

#define PING_PERIOD (1.0 / 12.0)
/* The synthetic detections' errors, against the nominal sigmas the
 * estimators assume: the chain's measured errors are about half of them
 * (README: direction sine 0.0006-0.0009 against 0.002, radial velocity
 * 0.002-0.003 m/s against 0.005, range 0.3 mm against 3 mm). */
#define ERROR_SCALE 0.5

/* A detection of a true object: as a planar array reports it (an object
 * behind the array in front), with the nominal errors drawn from @rng
 * (none when @rng is NULL). */
static SonarMeasurement
measure_truth (const SonarTruth * t, double ping_time, SonarRng * rng,
    gboolean planar)
{
  SonarSigmaModel model;
  SonarMeasurement m;
  SonarVec3 p = t->position;

  sonar_sigma_model_init_default (&model);
  if (planar && p.z < 0.0)
    p.z = -p.z;
  m.range = t->range;
  sonar_vec3_to_direction (p, &m.azimuth, &m.elevation);
  m.radial_velocity = t->radial_velocity;
  m.instant = ping_time + t->echo_delay / 2.0;
  sonar_measurement_set_nominal_sigma (&m, &model);
  if (rng) {
    m.range += ERROR_SCALE * m.sigma_range * sonar_rng_gaussian (rng);
    m.azimuth += ERROR_SCALE * m.sigma_azimuth * sonar_rng_gaussian (rng)
        * 180.0 / M_PI;
    if (m.elevation != 0.0)
      m.elevation += ERROR_SCALE * m.sigma_elevation * sonar_rng_gaussian
          (rng) * 180.0 / M_PI;
    m.radial_velocity += ERROR_SCALE * m.sigma_radial_velocity
        * sonar_rng_gaussian (rng);
  }
  return m;
}

/* The true objects of a scene at ping @ping (seen from the sensor). */
static guint
scene_truth (const SonarScene * scene, guint ping, SonarTruth * truth)
{
  g_autoptr (SonarSetup) setup = sonar_test_default_setup (17500);
  sonar_simulator_truth (setup, scene, ping * PING_PERIOD, truth);
  return scene->n_reflectors;
}

static double
distance (SonarVec3 a, SonarVec3 b)
{
  return sonar_vec3_norm (sonar_vec3_sub (a, b));
}

static SonarEgoEstimator *
ego_new (const SonarEgoParams * p)
{
  GError *error = NULL;
  SonarEgoEstimator *est = sonar_ego_estimator_new (p, &error);
  g_assert_no_error (error);
  return est;
}

static SonarTracker *
tracker_new (const SonarTrackerParams * p)
{
  GError *error = NULL;
  SonarTracker *tr = sonar_tracker_new (p, &error);
  g_assert_no_error (error);
  return tr;
}

/* 1. The small matrices. */
static void
test_linalg (void)
{
  /* A = L L^T with a known inverse. */
  double a[9] = { 4, 2, 0.4, 2, 5, 1, 0.4, 1, 3 }, inv[9], prod[9], ld;
  const double m[3][3] = { {2, -1, 0.5}, {-1, 3, 0.2}, {0.5, 0.2, 1} };
  double values[3], vectors[3][3], singular[4] = { 1, 1, 1, 1 };

  memcpy (inv, a, sizeof a);
  g_assert_true (sonar_linalg_invert_spd (inv, 3, &ld));
  sonar_linalg_multiply (a, inv, prod, 3, 3, 3);
  for (guint i = 0; i < 9; i++)
    g_assert_cmpfloat_with_epsilon (prod[i], i % 4 == 0 ? 1.0 : 0.0, 1e-12);
  /* det = 4 (5 * 3 - 1) - 2 (2 * 3 - 0.4) + 0.4 (2 - 2) = 44.8 */
  g_assert_cmpfloat_with_epsilon (ld, log (44.8), 1e-12);
  g_assert_false (sonar_linalg_invert_spd (singular, 2, NULL));

  sonar_linalg_eigen_symmetric3 (m, values, vectors);
  g_assert_cmpfloat (values[0], >=, values[1]);
  g_assert_cmpfloat (values[1], >=, values[2]);
  for (guint k = 0; k < 3; k++)
    for (guint r = 0; r < 3; r++) {
      double mv = 0.0;
      for (guint c = 0; c < 3; c++)
        mv += m[r][c] * vectors[k][c];
      g_assert_cmpfloat_with_epsilon (mv, values[k] * vectors[k][r], 1e-10);
    }
}

/* 2. The Fig. 10 drive from the truth with errors like the chain's: every
 * ping's ego velocity within 0.005 m/s and within 4 of its reported
 * standard deviations, 2-D, every object still; the object that goes
 * behind the array (seen mirrored) is still and behind. */
static void
test_ego_fig10_truth (void)
{
  SonarScene scene;
  SonarEgoParams p;
  SonarTruth truth[16];
  SonarRng rng;
  guint behind = 0;

  sonar_scene_init_preset (&scene, SONAR_SCENE_PRESET_FIG10);
  sonar_ego_params_init_default (&p);
  p.mirror_z = TRUE;
  sonar_rng_init (&rng, 10, 0);
  {
    g_autoptr (SonarEgoEstimator) est = ego_new (&p);
    for (guint ping = 0; ping < 30; ping++) {
      const guint n = scene_truth (&scene, ping, truth);
      SonarMeasurement m[16];
      SonarEgoLabel labels[16];
      SonarEgoMotion ego;
      SonarVec3 error;

      for (guint k = 0; k < n; k++)
        m[k] = measure_truth (&truth[k], ping * PING_PERIOD, &rng, TRUE);
      sonar_ego_estimate (est, m, n, &ego, labels);
      g_assert_cmpint (ego.status, ==, SONAR_EGO_OBSERVED);
      g_assert_cmpuint (ego.dimensions, ==, 2);
      error = sonar_vec3_sub (ego.velocity, scene.sensor_velocity);
      g_assert_cmpfloat (sonar_vec3_norm (error), <=, 0.005);
      g_assert_cmpfloat (fabs (error.x), <=, 4 * sqrt (ego.covariance[0][0]));
      g_assert_cmpfloat (fabs (error.z), <=, 4 * sqrt (ego.covariance[2][2]));
      g_assert_cmpfloat (ego.velocity.y, ==, 0.0);
      for (guint k = 0; k < n; k++) {
        g_assert_true (labels[k].still);
        g_assert_cmpfloat (labels[k].statistic, <=, p.gate);
        /* Well behind: the mirror image fits, the front one does not. */
        if (truth[k].position.z < -0.2 && labels[k].behind)
          behind++;
        if (truth[k].position.z > 0.2)
          g_assert_false (labels[k].behind);
      }
    }
  }
  /* The object at -70 degrees goes behind the array from ping 10 on. */
  g_assert_cmpuint (behind, >=, 10);
  sonar_scene_clear (&scene);
}

/* 3. The whole chain's detections of the Fig. 10 drive (the golden file,
 * bank -0.4..0.4 / 0.02): the ego velocity within 0.005 m/s of 0.3 m/s
 * forward on each ping, every detection still. */
static void
test_ego_fig10_chain (void)
{
  g_autofree char *path = sonar_test_source_path
      ("tests/data/golden-fig10.jsonl");
  g_autofree char *text = NULL;
  g_auto (GStrv) lines = NULL;
  SonarEgoParams p;
  SonarSigmaModel model;
  guint pings = 0;

  g_assert_true (g_file_get_contents (path, &text, NULL, NULL));
  lines = g_strsplit (text, "\n", -1);
  sonar_ego_params_init_default (&p);
  p.mirror_z = TRUE;
  sonar_sigma_model_init_default (&model);
  {
    g_autoptr (SonarEgoEstimator) est = ego_new (&p);
    for (guint l = 0; lines[l] && *lines[l]; l++) {
      g_autoptr (JsonParser) parser = json_parser_new ();
      JsonArray *dets;
      SonarMeasurement m[32];
      SonarEgoLabel labels[32];
      SonarEgoMotion ego;
      guint n = 0;

      g_assert_true (json_parser_load_from_data (parser, lines[l], -1, NULL));
      dets = json_object_get_array_member (json_node_get_object
          (json_parser_get_root (parser)), "detections");
      for (guint k = 0; k < json_array_get_length (dets) && n < 32; k++) {
        JsonObject *d = json_array_get_object_element (dets, k);
        if (!json_object_get_boolean_member (d, "valid"))
          continue;
        m[n].range = json_object_get_double_member (d, "range");
        m[n].azimuth = json_object_get_double_member (d, "azimuth");
        m[n].elevation = json_object_get_double_member (d, "elevation");
        m[n].radial_velocity = json_object_get_double_member (d,
            "radial_velocity");
        m[n].instant = json_object_get_double_member (d, "instant");
        sonar_measurement_set_nominal_sigma (&m[n], &model);
        n++;
      }
      g_assert_cmpuint (n, >=, 5);
      sonar_ego_estimate (est, m, n, &ego, labels);
      g_assert_cmpint (ego.status, ==, SONAR_EGO_OBSERVED);
      g_test_message ("ping %u: ego (%.4f, %.4f) m/s, %u still of %u", l,
          ego.velocity.x, ego.velocity.z, ego.n_still, n);
      g_assert_cmpfloat (distance (ego.velocity, sonar_vec3 (0, 0, 0.3)), <=,
          0.005);
      for (guint k = 0; k < n; k++)
        g_assert_true (labels[k].still);
      pings++;
    }
  }
  g_assert_cmpuint (pings, ==, 3);
}

/* Random still points in front of a sensor moving at @velocity, and
 * movers; planar arrays aside (mirror_z off). */
static guint
random_scene (SonarRng * rng, guint n_still, guint n_movers,
    SonarVec3 velocity, gboolean three, SonarMeasurement * m,
    gboolean * moving)
{
  SonarSigmaModel model;
  guint n = 0;

  sonar_sigma_model_init_default (&model);
  for (guint k = 0; k < n_still + n_movers; k++) {
    const double az = -70.0 + 140.0 * sonar_rng_uniform (rng);
    const double el = three ? -60.0 + 120.0 * sonar_rng_uniform (rng) : 0.0;
    const SonarVec3 u = sonar_vec3_from_direction (az, el);
    SonarVec3 world = sonar_vec3 (0, 0, 0);

    if (k >= n_still) {
      /* A walker: 0.5-1.5 m/s in any direction of the plane. */
      const double heading = 2 * M_PI * sonar_rng_uniform (rng);
      const double speed = 0.5 + sonar_rng_uniform (rng);
      world = sonar_vec3 (speed * sin (heading), 0, speed * cos (heading));
    }
    m[n].range = 1.0 + 3.0 * sonar_rng_uniform (rng);
    m[n].azimuth = az;
    m[n].elevation = el;
    m[n].instant = NAN;
    m[n].radial_velocity = sonar_vec3_dot (u, sonar_vec3_sub (world,
            velocity));
    sonar_measurement_set_nominal_sigma (&m[n], &model);
    m[n].radial_velocity += ERROR_SCALE * m[n].sigma_radial_velocity
        * sonar_rng_gaussian (rng);
    m[n].azimuth += ERROR_SCALE * m[n].sigma_azimuth * sonar_rng_gaussian
        (rng) * 180 / M_PI;
    moving[n] = k >= n_still;
    n++;
  }
  return n;
}

/* 4. 3-D: directions over the hemisphere give all three components. */
static void
test_ego_3d (void)
{
  const SonarVec3 truth = sonar_vec3 (0.2, -0.1, 0.5);
  SonarEgoParams p;
  SonarRng rng;
  SonarMeasurement m[64];
  gboolean moving[64];
  SonarEgoLabel labels[64];
  SonarEgoMotion ego;
  guint n;

  sonar_ego_params_init_default (&p);
  sonar_rng_init (&rng, 3, 0);
  {
    g_autoptr (SonarEgoEstimator) est = ego_new (&p);
    n = random_scene (&rng, 10, 4, truth, TRUE, m, moving);
    sonar_ego_estimate (est, m, n, &ego, labels);
    g_assert_cmpint (ego.status, ==, SONAR_EGO_OBSERVED);
    g_assert_cmpuint (ego.dimensions, ==, 3);
    g_assert_cmpfloat (distance (ego.velocity, truth), <=, 0.01);
    g_assert_cmpfloat (ego.covariance[1][1], >, 0.0);
    for (guint k = 0; k < n; k++)
      g_assert_cmpint (labels[k].still, ==, !moving[k]);
  }
}

/* 5. Robustness over 450 random scenes of 0-8 still objects among 0-12
 * walkers: with 5 or more still objects and at most as many movers, the
 * estimate is right (within 0.02 m/s and 5 of its standard deviations)
 * and observed but for 1 % (a chance group of movers, a still object
 * outside its gate); with fewer still objects it is right or
 * unobservable, wrong on at most 1 % of the pings it observes (chance
 * consensuses, at the rate max-chance allows). */
static void
test_ego_movers (void)
{
  const SonarVec3 truth = sonar_vec3 (0.05, 0, 0.4);
  SonarEgoParams p;
  SonarRng rng;
  guint observed = 0, unobservable = 0, runs = 0, unexpected = 0;
  guint still = 0, missed = 0, wrong = 0, well_posed = 0;

  sonar_ego_params_init_default (&p);
  sonar_rng_init (&rng, 5, 0);
  {
    g_autoptr (SonarEgoEstimator) est = ego_new (&p);
    for (guint n_still = 0; n_still <= 8; n_still++)
      for (guint n_movers = 0; n_movers <= 12; n_movers += 3)
        for (guint trial = 0; trial < 10; trial++) {
          SonarMeasurement m[32];
          gboolean moving[32];
          SonarEgoLabel labels[32];
          SonarEgoMotion ego;
          const guint n = random_scene (&rng, n_still, n_movers, truth,
              FALSE, m, moving);
          SonarVec3 e;

          sonar_ego_estimate (est, m, n, &ego, labels);
          runs++;
          well_posed += n_still >= 5 && n_movers <= n_still;
          if (ego.status != SONAR_EGO_OBSERVED) {
            unobservable++;
            if (n_still >= 5 && n_movers <= n_still) {
              g_test_message ("%u still, %u movers, trial %u: %s, %u still",
                  n_still, n_movers, trial, sonar_ego_status_to_string
                  (ego.status), ego.n_still);
              unexpected++;
            }
            for (guint k = 0; k < n; k++)
              g_assert_true (isnan (labels[k].statistic));
            continue;
          }
          observed++;
          e = sonar_vec3_sub (ego.velocity, truth);
          if (!(sonar_vec3_norm (e) <= 0.02 && fabs (e.x) <= 5 * sqrt
                  (ego.covariance[0][0]) && fabs (e.z) <= 5 * sqrt
                  (ego.covariance[2][2]))) {
            g_test_message ("%u still, %u movers, trial %u: ego (%.3f, "
                "%.3f), truth (%.3f, %.3f), %u still found: wrong",
                n_still, n_movers, trial, ego.velocity.x, ego.velocity.z,
                truth.x, truth.z, ego.n_still);
            wrong++;
            g_assert_false (n_still >= 5 && n_movers <= n_still);
          }
          for (guint k = 0; k < n; k++)
            if (!moving[k]) {
              still++;
              missed += !labels[k].still;
            }
        }
  }
  g_test_message ("%u random scenes: %u observed (%u wrong), %u "
      "unobservable (%u of the %u with 5 or more still objects and at most "
      "as many movers); %u of %u still objects labelled moving", runs,
      observed, wrong, unobservable, unexpected, well_posed, missed, still);
  /* Movers agree by chance at the rate max-chance allows, on pings with
   * few still objects; a 3-sigma gate leaves still objects out rarely. */
  g_assert_cmpuint (wrong, <=, observed / 100);
  g_assert_cmpuint (missed, <=, still / 100);
  g_assert_cmpuint (unexpected, <=, well_posed / 50);
}

/* 6. The unobservable cases, each named: too few still objects, too little
 * spread, a group of movers sharing one apparent velocity nearly as large
 * as the still world; and a prior velocity (odometry) that resolves it. */
static void
test_ego_unobservable (void)
{
  const SonarVec3 truth = sonar_vec3 (0, 0, 0.3);
  SonarSigmaModel model;
  SonarEgoParams p;
  SonarEgoMotion ego;
  SonarEgoLabel labels[16];
  SonarMeasurement m[16];
  guint n = 0;

  sonar_sigma_model_init_default (&model);
  sonar_ego_params_init_default (&p);
  {
    g_autoptr (SonarEgoEstimator) est = ego_new (&p);

    sonar_ego_estimate (est, m, 0, &ego, labels);
    g_assert_cmpint (ego.status, ==, SONAR_EGO_TOO_FEW_STILL);
    g_assert_cmpstr (sonar_ego_status_to_string (ego.status), ==,
        "too-few-still");

    /* Six still objects within 3 degrees of each other: no spread. */
    for (guint k = 0; k < 6; k++) {
      m[k].range = 2.0 + 0.3 * k;
      m[k].azimuth = 10.0 + 0.5 * k;
      m[k].elevation = 0.0;
      m[k].instant = NAN;
      m[k].radial_velocity = -sonar_vec3_dot (sonar_vec3_from_direction
          (m[k].azimuth, 0), truth);
      sonar_measurement_set_nominal_sigma (&m[k], &model);
    }
    sonar_ego_estimate (est, m, 6, &ego, labels);
    g_assert_cmpint (ego.status, ==, SONAR_EGO_NO_SPREAD);
    g_assert_true (isnan (labels[0].statistic));

    /* Five still objects spread out, and a group of four walking together
     * at 1 m/s to the right: another "still world". */
    for (guint k = 0; k < 9; k++) {
      const double az = -60.0 + 15.0 * k;
      const SonarVec3 world = k % 2 ? sonar_vec3 (1.0, 0, 0) :
          sonar_vec3 (0, 0, 0);
      m[k].range = 2.0;
      m[k].azimuth = az;
      m[k].elevation = 0.0;
      m[k].instant = NAN;
      m[k].radial_velocity = sonar_vec3_dot (sonar_vec3_from_direction (az,
              0), sonar_vec3_sub (world, truth));
      sonar_measurement_set_nominal_sigma (&m[k], &model);
      n = k + 1;
    }
    sonar_ego_estimate (est, m, n, &ego, labels);
    g_assert_cmpint (ego.status, ==, SONAR_EGO_AMBIGUOUS);
    /* The application's odometry says which world is still. */
    sonar_ego_estimator_set_prior (est, sonar_vec3 (0.02, 0, 0.25), 0.1);
    sonar_ego_estimate (est, m, n, &ego, labels);
    g_assert_cmpint (ego.status, ==, SONAR_EGO_OBSERVED);
    g_assert_cmpfloat (distance (ego.velocity, truth), <=, 0.005);
    g_assert_cmpuint (ego.n_still, ==, 5);
    for (guint k = 0; k < n; k++)
      g_assert_cmpint (labels[k].still, ==, k % 2 == 0);
    /* ... and a prior far from both finds no world. */
    sonar_ego_estimator_set_prior (est, sonar_vec3 (0, 0, -2), 0.1);
    sonar_ego_estimate (est, m, n, &ego, labels);
    g_assert_cmpint (ego.status, !=, SONAR_EGO_OBSERVED);
  }
}

/* 7. Settings out of range are named. */
static void
test_errors (void)
{
  SonarEgoParams p;
  SonarTrackerParams t;
  GError *error = NULL;

  sonar_ego_params_init_default (&p);
  p.min_still = 1;
  g_assert_null (sonar_ego_estimator_new (&p, &error));
  g_assert_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS);
  g_assert_cmpstr (error->message, ==, "ego-motion: min-still must be in "
      "[2, 1000], not 1");
  g_clear_error (&error);
  sonar_ego_params_init_default (&p);
  p.dimensions = 4;
  g_assert_null (sonar_ego_estimator_new (&p, &error));
  g_assert_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS);
  g_clear_error (&error);

  sonar_tracker_params_init_default (&t);
  t.gate = 1.0;
  g_assert_null (sonar_tracker_new (&t, &error));
  g_assert_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS);
  g_assert_cmpstr (error->message, ==, "tracks: the gate probability must "
      "be in [0.5, 1), not 1");
  g_clear_error (&error);
  /* The property's limits run (0.5 was refused). */
  t.gate = 0.5;
  sonar_tracker_free (sonar_tracker_new (&t, &error));
  g_assert_no_error (error);
  t.gate = 0.999999999;
  sonar_tracker_free (sonar_tracker_new (&t, &error));
  g_assert_no_error (error);
  sonar_tracker_params_init_default (&t);
  t.dimensions = 1;
  g_assert_null (sonar_tracker_new (&t, &error));
  g_assert_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS);
  g_clear_error (&error);
}

/* Runs a scene's truth through ego-motion and tracks for @pings pings
 * (skipping those in @drop), the detections with nominal errors; calls
 * @check after each ping with the tracks and the truth. */
typedef void (*TrackCheck) (guint ping, const SonarTrack * tracks, guint n,
    const SonarTruth * truth, guint n_truth, const SonarScene * scene,
    gpointer data);

static void
run_tracks (const SonarScene * scene, const SonarTrackerParams * tp,
    guint pings, const guint * drop, guint n_drop, TrackCheck check,
    gpointer data)
{
  SonarEgoParams ep;
  SonarTruth truth[64];
  SonarRng rng;
  g_autoptr (SonarEgoEstimator) est = NULL;
  g_autoptr (SonarTracker) tr = tracker_new (tp);

  sonar_ego_params_init_default (&ep);
  ep.mirror_z = tp->mirror_z;
  ep.dimensions = tp->dimensions == 2 ? 2 : 0;
  est = ego_new (&ep);
  sonar_rng_init (&rng, 42, 0);
  for (guint ping = 0; ping < pings; ping++) {
    const guint n = scene_truth (scene, ping, truth);
    SonarMeasurement m[64];
    SonarEgoLabel labels[64];
    SonarEgoMotion ego;
    const SonarTrack *tracks;
    GError *error = NULL;
    guint n_tracks;
    gboolean dropped = FALSE;

    for (guint d = 0; d < n_drop; d++)
      dropped |= drop[d] == ping;
    if (dropped)
      continue;
    for (guint k = 0; k < n; k++)
      m[k] = measure_truth (&truth[k], ping * PING_PERIOD, &rng,
          tp->mirror_z);
    sonar_ego_estimate (est, m, n, &ego, labels);
    g_assert_true (sonar_tracker_process (tr, ping * PING_PERIOD, m, n, &ego,
            labels, &error));
    g_assert_no_error (error);
    tracks = sonar_tracker_tracks (tr, &n_tracks);
    check (ping, tracks, n_tracks, truth, n, scene, data);
  }
}

/* The confirmed track nearest the truth's echo point, within 0.1 m. */
static const SonarTrack *
track_of (const SonarTruth * t, const SonarTrack * tracks, guint n)
{
  const SonarTrack *best = NULL;
  double best_d = 0.1;

  for (guint i = 0; i < n; i++) {
    const double d = distance (tracks[i].position, t->position);
    if (tracks[i].state == SONAR_TRACK_CONFIRMED && d < best_d) {
      best = &tracks[i];
      best_d = d;
    }
  }
  return best;
}

typedef struct
{
  guint64 ids[64];              /* per true object: its track, 0 none yet */
  guint switches;
  double worst_velocity;        /* movers, after ping 10 */
  double worst_still;           /* still objects' speed, confirmed */
  guint matched;
} Identity;

static void
check_identities (guint ping, const SonarTrack * tracks, guint n,
    const SonarTruth * truth, guint n_truth, const SonarScene * scene,
    gpointer data)
{
  Identity *id = data;

  for (guint k = 0; k < n_truth; k++) {
    const SonarTrack *t = track_of (&truth[k], tracks, n);
    const SonarVec3 world = scene->reflectors[truth[k].reflector].velocity;
    const gboolean mover = sonar_vec3_norm (world) > 0.0;
    if (!t)
      continue;
    id->matched++;
    if (id->ids[k] && id->ids[k] != t->id)
      id->switches++;
    id->ids[k] = t->id;
    g_assert_cmpint (t->moving, ==, mover);
    if (mover && ping >= 10)
      id->worst_velocity = MAX (id->worst_velocity,
          distance (t->velocity, world));
    if (!mover)
      id->worst_still = MAX (id->worst_still, sonar_vec3_norm (t->velocity));
  }
}

/* 8. The crossing preset from its truth: the walkers keep their
 * identities through the crossing (they meet at ping 15), their velocity
 * in the world within 0.05 m/s after 10 pings, moving; the wall still
 * (slower than moving-speed). */
static void
test_tracks_crossing (void)
{
  SonarScene scene;
  SonarTrackerParams tp;
  Identity id = { {0} };

  sonar_scene_init_preset (&scene, SONAR_SCENE_PRESET_CROSSING);
  sonar_tracker_params_init_default (&tp);
  tp.dimensions = 2;
  tp.mirror_z = TRUE;
  run_tracks (&scene, &tp, 30, NULL, 0, check_identities, &id);
  g_test_message ("crossing: %u matches, %u switches, walkers within %.3f "
      "m/s, still objects below %.3f m/s", id.matched, id.switches,
      id.worst_velocity, id.worst_still);
  g_assert_cmpuint (id.switches, ==, 0);
  g_assert_cmpuint (id.matched, >=, 9 * 27);
  g_assert_cmpfloat (id.worst_velocity, <=, 0.05);
  g_assert_cmpfloat (id.worst_still, <, tp.moving_speed);
  sonar_scene_clear (&scene);
}

/* 9. Dropped pings are longer steps: the Fig. 9 world with pings 4-6
 * missing keeps every identity, and the fast mover passing 0.6 m away
 * has its velocity within 0.05 m/s after ping 10, thanks to the radius
 * of its echoing surface (a 5 cm pole whose echo point slides). Without
 * the radius (object-radius 0) the same run is off by more. */
static void
test_tracks_gaps_and_extent (void)
{
  const guint drop[] = { 4, 5, 6 };
  SonarScene scene;
  SonarTrackerParams tp;
  Identity id = { {0} }, point = { {0} };

  sonar_scene_init_preset (&scene, SONAR_SCENE_PRESET_FIG9);
  sonar_tracker_params_init_default (&tp);
  tp.dimensions = 2;
  tp.mirror_z = TRUE;
  run_tracks (&scene, &tp, 12, drop, G_N_ELEMENTS (drop), check_identities,
      &id);
  g_test_message ("fig9, pings 4-6 dropped: %u matches, %u switches, movers "
      "within %.3f m/s", id.matched, id.switches, id.worst_velocity);
  g_assert_cmpuint (id.switches, ==, 0);
  g_assert_cmpuint (id.matched, >=, 6 * 7);
  g_assert_cmpfloat (id.worst_velocity, <=, 0.05);

  tp.object_radius = 0.0;
  run_tracks (&scene, &tp, 12, drop, G_N_ELEMENTS (drop), check_identities,
      &point);
  g_test_message ("fig9, pings 4-6 dropped, every object a point: movers "
      "within %.3f m/s", point.worst_velocity);
  g_assert_cmpfloat (point.worst_velocity, >, 0.05);
  sonar_scene_clear (&scene);
}

/* A 2-D tracker's default parameters, the nominal sigma model and an ego
 * motion of @status (all else zero). */
static void
planar_tracking (SonarTrackerParams * tp, SonarSigmaModel * model,
    SonarEgoMotion * ego, SonarEgoStatus status)
{
  sonar_tracker_params_init_default (tp);
  tp->dimensions = 2;
  sonar_sigma_model_init_default (model);
  memset (ego, 0, sizeof *ego);
  ego->status = status;
}

/* 10. Life of a track, ids and timing: confirmed at the third detection,
 * a confirmed track coasts over max-misses pings then ends, a tentative
 * one ends at its second miss; ids are never reused; pings must come in
 * time order. */
static void
test_track_life (void)
{
  SonarTrackerParams tp;
  SonarSigmaModel model;
  SonarMeasurement m[2];
  SonarEgoMotion ego;
  const SonarTrack *tracks;
  GError *error = NULL;
  guint n;

  planar_tracking (&tp, &model, &ego, SONAR_EGO_OBSERVED);
  tp.max_misses = 2;
  ego.dimensions = 2;
  ego.covariance[0][0] = ego.covariance[2][2] = 1e-6;
  for (guint k = 0; k < 2; k++) {
    m[k].range = 1.0 + k;
    m[k].azimuth = 20.0 * k;
    m[k].elevation = 0.0;
    m[k].radial_velocity = 0.0;
    m[k].instant = NAN;
    sonar_measurement_set_nominal_sigma (&m[k], &model);
  }
  {
    g_autoptr (SonarTracker) tr = tracker_new (&tp);
    for (guint ping = 0; ping < 3; ping++) {
      g_assert_true (sonar_tracker_process (tr, ping * 0.1, m, ping ? 1 : 2,
              &ego, NULL, &error));
      tracks = sonar_tracker_tracks (tr, &n);
      g_assert_cmpuint (tracks[0].id, ==, 1);
      g_assert_cmpint (tracks[0].state, ==, ping == 2 ?
          SONAR_TRACK_CONFIRMED : SONAR_TRACK_TENTATIVE);
      g_assert_cmpint (tracks[0].detection, ==, 0);
      g_assert_cmpfloat (tracks[0].instant, ==, ping * 0.1);
      /* Track 2 was seen once: it ends at its second miss. */
      g_assert_cmpuint (n, ==, ping < 2 ? 2 : 1);
    }
    g_assert_cmpstr (sonar_track_state_to_string (tracks[0].state), ==,
        "confirmed");
    /* Earlier than the last ping: refused, nothing changes. */
    g_assert_false (sonar_tracker_process (tr, 0.15, m, 1, &ego, NULL,
            &error));
    g_assert_error (error, SONAR_ERROR, SONAR_ERROR_FORMAT);
    g_clear_error (&error);
    tracks = sonar_tracker_tracks (tr, &n);
    g_assert_cmpuint (n, ==, 1);
    g_assert_cmpuint (tracks[0].hits, ==, 3);
    /* Missed on 2 pings: it coasts, on the third it ends. */
    for (guint ping = 3; ping < 6; ping++) {
      g_assert_true (sonar_tracker_process (tr, ping * 0.1, m, 0, &ego, NULL,
              &error));
      tracks = sonar_tracker_tracks (tr, &n);
      g_assert_cmpuint (n, ==, ping < 5 ? 1 : 0);
      if (n) {
        g_assert_cmpuint (tracks[0].misses, ==, ping - 2);
        g_assert_cmpint (tracks[0].detection, ==, -1);
        g_assert_cmpfloat_with_epsilon (tracks[0].instant, ping * 0.1,
            1e-12);
      }
    }
    /* The same object again: a new identity. */
    g_assert_true (sonar_tracker_process (tr, 0.6, m, 1, &ego, NULL,
            &error));
    tracks = sonar_tracker_tracks (tr, &n);
    g_assert_cmpuint (n, ==, 1);
    g_assert_cmpuint (tracks[0].id, ==, 3);
  }
}

/* 11. Detections without a place or a speed: the estimators leave them
 * out (untested, no track) and nothing they report is NaN. */
static void
test_bad_input (void)
{
  SonarSigmaModel model;
  SonarEgoParams ep;
  SonarTrackerParams tp;
  SonarMeasurement m[6];
  SonarEgoLabel labels[6];
  SonarEgoMotion ego;
  const SonarTrack *tracks;
  GError *error = NULL;
  guint n;

  sonar_sigma_model_init_default (&model);
  sonar_ego_params_init_default (&ep);
  sonar_tracker_params_init_default (&tp);
  for (guint k = 0; k < 6; k++) {
    m[k].range = 1.0 + 0.5 * k;
    m[k].azimuth = -50.0 + 20.0 * k;
    m[k].elevation = 0.0;
    m[k].instant = NAN;
    /* A still sensor among still objects: the same detections every
     * ping. */
    m[k].radial_velocity = 0.0;
    sonar_measurement_set_nominal_sigma (&m[k], &model);
  }
  m[4].radial_velocity = NAN;   /* at the bank's edge: a place only */
  m[5].azimuth = NAN;           /* nowhere */
  {
    g_autoptr (SonarEgoEstimator) est = ego_new (&ep);
    g_autoptr (SonarTracker) tr = tracker_new (&tp);
    sonar_ego_estimate (est, m, 6, &ego, labels);
    g_assert_cmpint (ego.status, ==, SONAR_EGO_OBSERVED);
    g_assert_cmpuint (ego.n_used, ==, 4);
    g_assert_cmpfloat (sonar_vec3_norm (ego.velocity), <, 1e-9);
    g_assert_true (isnan (labels[4].statistic) && !labels[4].still);
    g_assert_true (isnan (labels[5].statistic) && !labels[5].still);
    for (guint ping = 0; ping < 3; ping++)
      g_assert_true (sonar_tracker_process (tr, ping * 0.1, m, 6, &ego,
              labels, &error));
    tracks = sonar_tracker_tracks (tr, &n);
    g_assert_cmpuint (n, ==, 5);
    for (guint i = 0; i < n; i++) {
      g_assert_cmpint (tracks[i].state, ==, SONAR_TRACK_CONFIRMED);
      g_assert_true (isfinite (tracks[i].radial_velocity)
          && isfinite (sonar_vec3_norm (tracks[i].velocity))
          && isfinite (tracks[i].velocity_covariance[2][2]));
      g_assert_false (tracks[i].moving);
    }
    /* A ping time that is not a number is refused. */
    g_assert_false (sonar_tracker_process (tr, NAN, m, 6, &ego, labels,
            &error));
    g_assert_error (error, SONAR_ERROR, SONAR_ERROR_FORMAT);
    g_clear_error (&error);
  }
}

/* The robot's motion unobservable (no still object, no odometry): a
 * mover approaching at 1 m/s (its range falling 1/12 m a ping) keeps the
 * radial velocity it is measured at, from its first ping (it read half of
 * it then, 0.75 at the second: the sensor's prior variance counted as the
 * measurement's noise), and its world velocity is that one over the
 * still sensor the prior says. */
static void
test_unobservable_ego (void)
{
  SonarTrackerParams tp;
  SonarSigmaModel model;
  SonarEgoMotion ego;
  const SonarTrack *tracks;
  GError *error = NULL;
  guint n;

  planar_tracking (&tp, &model, &ego, SONAR_EGO_TOO_FEW_STILL);
  {
    g_autoptr (SonarTracker) tr = tracker_new (&tp);
    for (guint ping = 0; ping < 4; ping++) {
      SonarMeasurement m;
      m.range = 2.0 - ping / 12.0;
      m.azimuth = 0.0;
      m.elevation = 0.0;
      m.radial_velocity = -1.0;
      m.instant = ping / 12.0;
      sonar_measurement_set_nominal_sigma (&m, &model);
      g_assert_true (sonar_tracker_process (tr, ping / 12.0, &m, 1, &ego,
              NULL, &error));
      tracks = sonar_tracker_tracks (tr, &n);
      g_assert_cmpuint (n, ==, 1);
      g_test_message ("ping %u: radial velocity %.4f, world %.4f", ping,
          tracks[0].radial_velocity, tracks[0].velocity.z);
      g_assert_cmpfloat (fabs (tracks[0].radial_velocity + 1.0), <, 0.01);
      g_assert_cmpfloat (fabs (tracks[0].velocity.z + 1.0), <, 0.01);
    }
  }
}

int
main (int argc, char **argv)
{
  g_test_init (&argc, &argv, NULL);
  g_test_add_func ("/track/linalg", test_linalg);
  g_test_add_func ("/track/ego-fig10-truth", test_ego_fig10_truth);
  g_test_add_func ("/track/ego-fig10-chain", test_ego_fig10_chain);
  g_test_add_func ("/track/ego-3d", test_ego_3d);
  g_test_add_func ("/track/ego-movers", test_ego_movers);
  g_test_add_func ("/track/ego-unobservable", test_ego_unobservable);
  g_test_add_func ("/track/errors", test_errors);
  g_test_add_func ("/track/crossing", test_tracks_crossing);
  g_test_add_func ("/track/gaps-and-extent", test_tracks_gaps_and_extent);
  g_test_add_func ("/track/life", test_track_life);
  g_test_add_func ("/track/unobservable-ego", test_unobservable_ego);
  g_test_add_func ("/track/bad-input", test_bad_input);
  return g_test_run ();
}
