/* test-velocityest.c: wardcluster and velocityest at the end of the whole
 * chain (sonarsrc ! dopplerbank ! mimobeamform ! wardcluster ! velocityest):
 * near-far scenes, the edges of the fan, speeds beyond the bank, sub-step
 * refinement, the linkages, errors, bus messages and state changes. Every
 * case is one ping on a narrow bank, scored against the simulator's truth. */
#include <gst/app/gstappsink.h>
#include <json-glib/json-glib.h>
#include <math.h>
#include <string.h>

#include "sonar-contracts.h"
#include "sonar-test-gst.h"

#define NARROW_BANK "velocity-min=-1.5 velocity-max=1.5 velocity-step=0.05"
#define FIG10_BANK "velocity-min=-0.4 velocity-max=0.4 velocity-step=0.02"
#define CHAIN_DEFAULT "sonarsrc num-buffers=1 ! dopplerbank " NARROW_BANK \
  " ! mimobeamform azimuth-count=91 ! wardcluster ! velocityest"

/* A detection within this distance of a true object is that object (as in
 * test-pipeline.c). */
#define MATCH_DISTANCE 0.05

/* Helpers ------------------------------------------------------------------*/

static GstElement *
parse_pipeline (const char *launch)
{
  GError *error = NULL;
  GstElement *pipeline = gst_parse_launch (launch, &error);

  if (error)
    g_error ("%s: %s", launch, error->message);
  g_assert_nonnull (pipeline);
  return pipeline;
}

/* Fails on the first ERROR message on @bus. */
static void
assert_no_bus_error (GstBus * bus)
{
  GstMessage *msg = gst_bus_pop_filtered (bus, GST_MESSAGE_ERROR);

  if (msg) {
    GError *error = NULL;
    gst_message_parse_error (msg, &error, NULL);
    g_error ("unexpected error from %s: %s", GST_OBJECT_NAME
        (GST_MESSAGE_SRC (msg)), error->message);
  }
}

/* Runs @launch to EOS; it ends in @n_sinks appsinks named sink0, sink1, ...
 * (or one named sink), each of which must receive exactly one ping: its
 * sample goes to @samples[i] (unref them). Fails on any bus error. */
static void
run_one_ping (const char *launch, guint n_sinks, GstSample ** samples)
{
  g_autoptr (SonarTestRun) run = sonar_test_run (launch);

  if (run->error_text)
    g_error ("%s: %s", launch, run->error_text);
  for (guint i = 0; i < n_sinks; i++) {
    g_autofree char *name = n_sinks == 1 ? g_strdup ("sink") :
        g_strdup_printf ("sink%u", i);
    GPtrArray *got = sonar_test_run_samples (run, name);

    g_assert_cmpuint (got->len, ==, 1);
    samples[i] = gst_sample_ref (got->pdata[0]);
  }
}

static SonarDetectionsMeta *
sample_detections (GstSample * sample)
{
  SonarDetectionsMeta *dets =
      sonar_buffer_get_detections_meta (gst_sample_get_buffer (sample));
  g_assert_nonnull (dets);
  return dets;
}

static SonarTruthMeta *
sample_truth (GstSample * sample)
{
  SonarTruthMeta *truth =
      sonar_buffer_get_truth_meta (gst_sample_get_buffer (sample));
  g_assert_nonnull (truth);
  return truth;
}

static char *
sample_text (GstSample * sample)
{
  GstBuffer *buffer = gst_sample_get_buffer (sample);
  GstMapInfo map;
  char *text;

  g_assert_true (gst_buffer_map (buffer, &map, GST_MAP_READ));
  text = g_strndup ((const char *) map.data, map.size);
  gst_buffer_unmap (buffer, &map);
  return text;
}

static double
distance_to (const SonarDetection * d, const SonarTruth * t)
{
  return sonar_vec3_norm (sonar_vec3_sub (d->position, t->position));
}

/* Index of the true object @d is (within MATCH_DISTANCE), or -1. */
static int
truth_of (const SonarDetection * d, const SonarTruthMeta * truth)
{
  for (guint k = 0; k < truth->n_truths; k++)
    if (distance_to (d, &truth->truths[k]) < MATCH_DISTANCE)
      return k;
  return -1;
}

static void
print_detections (const char *what, const SonarDetectionsMeta * dets)
{
  for (guint i = 0; i < dets->n_detections; i++) {
    const SonarDetection *d = &dets->detections[i];
    g_test_message ("%s: %.4f m %+.2f deg v %+.4f m/s conf %.3f%s%s", what,
        d->range, d->azimuth, d->radial_velocity, d->confidence,
        d->out_of_range ? " out-of-range" : "", d->valid ? "" : " rejected");
  }
}

typedef struct
{
  guint matched, false_positives, n_truth;
  double sum_error, max_error;
} Score;

/* Every true object must be found exactly once among the valid detections;
 * counts the valid detections that are no object. */
static Score
score_sample (GstSample * sample, const char *what)
{
  SonarTruthMeta *truth = sample_truth (sample);
  SonarDetectionsMeta *dets = sample_detections (sample);
  Score s = { 0 };

  s.n_truth = truth->n_truths;
  for (guint k = 0; k < truth->n_truths; k++) {
    const SonarTruth *t = &truth->truths[k];
    guint found = 0;
    for (guint i = 0; i < dets->n_detections; i++) {
      const SonarDetection *d = &dets->detections[i];
      if (!d->valid || distance_to (d, t) >= MATCH_DISTANCE)
        continue;
      {
        const double err = fabs (d->radial_velocity - t->radial_velocity);
        g_test_message ("%s: %.2f m %+.1f deg truth %+.4f estimate %+.4f "
            "m/s (error %.4f)", what, t->range, t->azimuth,
            t->radial_velocity, d->radial_velocity, err);
        if (found++ == 0) {
          s.sum_error += err;
          s.max_error = MAX (s.max_error, err);
        }
      }
    }
    if (found == 0)
      g_test_message ("%s: missed %.2f m %+.1f deg", what, t->range,
          t->azimuth);
    g_assert_cmpuint (found, <=, 1);
    s.matched += found > 0;
  }
  for (guint i = 0; i < dets->n_detections; i++) {
    const SonarDetection *d = &dets->detections[i];
    if (d->valid && truth_of (d, truth) < 0) {
      g_test_message ("%s: false positive at %.3f m %+.2f deg, %+.4f m/s",
          what, d->range, d->azimuth, d->radial_velocity);
      s.false_positives++;
    }
  }
  return s;
}

/* 1. Near-far ---------------------------------------------------------------
 *
 * A reflector 100 times stronger at 0.5 m (40 dB above the one at 2.5 m in
 * the range-compensated image) makes cross-talk ridges from 0.5 to 2 m
 * behind it: the centroids wardcluster gives them velocityest must all
 * reject; both objects must be reported with their velocities. */
static void
check_near_far_with (const char *scene_json, double v_strong,
    double v_normal, const char *wardcluster_props)
{
  g_autofree char *scene = sonar_test_write_temp ("near-far.json",
      scene_json);
  g_autofree char *launch = g_strdup_printf ("sonarsrc scene-file=%s "
      "num-buffers=1 ! dopplerbank " NARROW_BANK " ! mimobeamform "
      "azimuth-count=91 ! wardcluster %s ! velocityest keep-rejected=true ! "
      "appsink name=sink sync=false", scene, wardcluster_props);
  GstSample *sample;
  SonarTruthMeta *truth;
  SonarDetectionsMeta *dets;
  SonarCentroidsMeta *centroids;
  guint rejected = 0, valid = 0;
  gboolean strong = FALSE, normal = FALSE;

  run_one_ping (launch, 1, &sample);
  truth = sample_truth (sample);
  dets = sample_detections (sample);
  centroids = sonar_buffer_get_centroids_meta (gst_sample_get_buffer
      (sample));
  g_assert_nonnull (centroids);
  g_assert_cmpuint (truth->n_truths, ==, 2);
  g_assert_cmpfloat (fabs (truth->truths[0].radial_velocity - v_strong), <,
      1e-3);
  g_assert_cmpfloat (fabs (truth->truths[1].radial_velocity - v_normal), <,
      1e-3);

  for (guint i = 0; i < dets->n_detections; i++) {
    const SonarDetection *d = &dets->detections[i];
    const int k = truth_of (d, truth);
    if (!d->valid) {
      rejected++;
      continue;
    }
    valid++;
    g_test_message ("reported: %.4f m %+.2f deg, %+.4f m/s (truth %+.4f)",
        d->range, d->azimuth, d->radial_velocity,
        k >= 0 ? truth->truths[k].radial_velocity : NAN);
    /* No ghost: every reported detection is one of the two objects, with
     * its velocity. */
    g_assert_cmpint (k, >=, 0);
    g_assert_false (d->out_of_range);
    g_assert_cmpfloat (fabs (d->radial_velocity -
            truth->truths[k].radial_velocity), <=, 0.02);
    if (k == 0) {
      g_assert_false (strong);
      strong = TRUE;
    } else {
      g_assert_false (normal);
      normal = TRUE;
    }
  }
  g_test_message ("%u centroids: %u reported, %u rejected (cross-talk "
      "ridges and sidelobes)", centroids->n_centroids, valid, rejected);
  g_assert_true (strong);
  /* The ridges are there, and were all rejected: at the defaults
   * wardcluster's column floor keeps most of their peaks out, so this is
   * checked where more of them pass (pfa 1e-6). */
  if (*wardcluster_props)
    g_assert_cmpuint (rejected, >, 0);
  /* The object at 2.5 m is 40 dB below the strong one in the
   * range-compensated image, the ridges 3-25 dB above it: wardcluster's
   * column floor (along each direction) keeps the ridges' peaks out, its
   * sidelobe threshold is relative to each range's own strongest pixel,
   * and the imager refines what stands above the noise, so it arrives. */
  g_assert_true (normal);
  gst_sample_unref (sample);
}

/* At the defaults, and with the ridges' peaks let through to velocityest. */
static void
check_near_far (const char *scene_json, double v_strong, double v_normal)
{
  check_near_far_with (scene_json, v_strong, v_normal, "");
  check_near_far_with (scene_json, v_strong, v_normal, "pfa=1e-6");
}

static void
test_near_far_strong_still (void)
{
  check_near_far ("{\"dimensions\": 2, \"reflectors\": ["
      " {\"range\": 0.5, \"azimuth\": 0, \"strength\": 100},"
      " {\"range\": 2.5, \"azimuth\": 40, \"radial-velocity\": 0.6}]}",
      0.0, 0.6);
}

static void
test_near_far_strong_moving (void)
{
  check_near_far ("{\"dimensions\": 2, \"reflectors\": ["
      " {\"range\": 0.5, \"azimuth\": 0, \"strength\": 100,"
      "  \"radial-velocity\": -0.7},"
      " {\"range\": 2.5, \"azimuth\": 40}]}", -0.7, 0.0);
}

/* Within the pulse: a point 14 dB below a strong one (after the range
 * compensation), 0.6 m behind it in its direction, lies under its
 * cross-talk ridge and makes no centroid. At the defaults velocityest's
 * residual search finds it on the ping less the strong echo, with its
 * velocity, numbered after the ping's centroids; residual-search=false
 * reports the strong one alone. */
static void
check_hidden_within_pulse (gboolean search)
{
  g_autofree char *scene = sonar_test_write_temp ("hidden.json",
      "{\"dimensions\": 2, \"reflectors\": ["
      " {\"range\": 1.0, \"azimuth\": 20, \"radial-velocity\": -0.5},"
      " {\"range\": 1.6, \"azimuth\": 21, \"strength\": 0.2,"
      "  \"radial-velocity\": 0.4}]}");
  g_autofree char *launch = g_strdup_printf ("sonarsrc scene-file=%s "
      "num-buffers=1 ! dopplerbank " NARROW_BANK " ! mimobeamform "
      "azimuth-count=91 ! wardcluster ! velocityest residual-search=%s ! "
      "appsink name=sink sync=false", scene, search ? "true" : "false");
  GstSample *sample;
  SonarTruthMeta *truth;
  SonarDetectionsMeta *dets;
  SonarCentroidsMeta *centroids;
  gboolean seen[2] = { FALSE, FALSE };

  run_one_ping (launch, 1, &sample);
  truth = sample_truth (sample);
  dets = sample_detections (sample);
  centroids = sonar_buffer_get_centroids_meta (gst_sample_get_buffer
      (sample));
  g_assert_nonnull (centroids);
  for (guint i = 0; i < dets->n_detections; i++) {
    const SonarDetection *d = &dets->detections[i];
    const int k = truth_of (d, truth);
    g_test_message ("%s: %.4f m %+.2f deg, %+.4f m/s, centroid %u of %u",
        launch, d->range, d->azimuth, d->radial_velocity, d->centroid,
        centroids->n_centroids);
    g_assert_true (d->valid);
    g_assert_cmpint (k, >=, 0);
    g_assert_false (seen[k]);
    seen[k] = TRUE;
    g_assert_cmpfloat (fabs (d->radial_velocity -
            truth->truths[k].radial_velocity), <=, k == 0 ? 0.01 : 0.03);
    if (k == 0)
      g_assert_cmpuint (d->centroid, <, centroids->n_centroids);
    else
      g_assert_cmpuint (d->centroid, >=, centroids->n_centroids);
  }
  g_assert_true (seen[0]);
  g_assert_true (seen[1] == search);
  gst_sample_unref (sample);
}

static void
test_hidden_within_pulse (void)
{
  check_hidden_within_pulse (TRUE);
  check_hidden_within_pulse (FALSE);
}

/* One ping of the two objects of 3-D scene @scene_json (at mimobeamform's
 * hemisphere defaults, a -1..1 / 0.05 m/s bank): each detection valid,
 * within MATCH_DISTANCE of an object and 0.02 m/s of its velocity, and
 * each object found exactly once. */
static void
check_3d_both_found_once (const char *scene_json)
{
  g_autofree char *scene = sonar_test_write_temp ("scene-3d.json",
      scene_json);
  g_autofree char *launch = g_strdup_printf ("sonarsrc scene-file=%s "
      "num-buffers=1 ! dopplerbank velocity-min=-1 velocity-max=1 "
      "velocity-step=0.05 ! mimobeamform ! wardcluster ! velocityest ! "
      "appsink name=sink sync=false", scene);
  GstSample *sample;
  SonarTruthMeta *truth;
  SonarDetectionsMeta *dets;
  gboolean found[2] = { FALSE, FALSE };

  run_one_ping (launch, 1, &sample);
  truth = sample_truth (sample);
  dets = sample_detections (sample);
  g_assert_cmpuint (truth->n_truths, ==, 2);
  for (guint i = 0; i < dets->n_detections; i++) {
    const SonarDetection *d = &dets->detections[i];
    const int k = truth_of (d, truth);
    g_test_message ("reported: %.4f m %+.2f %+.2f deg, %+.4f m/s", d->range,
        d->azimuth, d->elevation, d->radial_velocity);
    g_assert_true (d->valid);
    g_assert_cmpint (k, >=, 0);
    g_assert_false (found[k]);
    g_assert_cmpfloat (fabs (d->radial_velocity -
            truth->truths[k].radial_velocity), <=, 0.02);
    found[k] = TRUE;
  }
  g_assert_true (found[0]);
  g_assert_true (found[1]);
  gst_sample_unref (sample);
}

/* 3-D, at mimobeamform's hemisphere defaults (2-degree grid, coarse 6):
 * an object 30 dB below a near one in the range-compensated image, far
 * below refine-db, between coarse directions (-21, 9: 3 degrees from the
 * nearest coarse azimuths). Only interpolated, its peak landed about a
 * degree off, where its emitters no longer added up, and velocityest
 * rejected it (it did with refine-pfa=0); refine-pfa's noise gate images
 * it in full. */
static void
test_near_far_3d (void)
{
  check_3d_both_found_once ("{\"dimensions\": 3, \"reflectors\": ["
      " {\"range\": 0.6, \"azimuth\": 0, \"elevation\": 0, "
      "\"strength\": 30},"
      " {\"range\": 2.5, \"azimuth\": -21, \"elevation\": 9, "
      "\"radial-velocity\": 0.6}]}");
}

/* 3-D, one still point at each corner of the hemisphere (60 degrees of
 * azimuth and of elevation): one detection each. There a degree of
 * azimuth spans half what it does at boresight, and wardcluster split
 * each echo into centroids 3-4 degrees apart; two of them passed every
 * test, and the estimates, compared in degrees, were not found to be one
 * echo (a false object on every ping). */
static void
test_one_echo_off_boresight_3d (void)
{
  check_3d_both_found_once ("{\"dimensions\": 3, \"reflectors\": ["
      " {\"range\": 2.5, \"azimuth\": -60, \"elevation\": -60, "
      "\"radial-velocity\": 0.1},"
      " {\"range\": 1.8, \"azimuth\": 60, \"elevation\": 60}]}");
}

/* Objects half a degree inside the fan's edges (+-89.5 degrees), moving:
 * every detection lies in front of the array. The direction of its
 * echo's model (a parabola's vertex a quarter step beyond the edge
 * direction at most) read +-90.125 degrees on one ping: behind the array,
 * outside docs/detections.schema.json. */
static void
test_directions_at_the_edges (void)
{
  g_autofree char *scene = sonar_test_write_temp ("edges.json",
      "{\"dimensions\": 2, \"reflectors\": ["
      " {\"range\": 2.0, \"azimuth\": 89.5, \"radial-velocity\": -0.5},"
      " {\"range\": 3.0, \"azimuth\": -89.5, "
      "\"radial-velocity\": 0.3}]}");
  g_autofree char *launch = g_strdup_printf ("sonarsrc scene-file=%s "
      "num-buffers=3 ! dopplerbank ! mimobeamform ! wardcluster ! "
      "velocityest ! appsink name=sink sync=false", scene);
  g_autoptr (SonarTestRun) run = sonar_test_run (launch);
  GPtrArray *samples;
  guint valid = 0;

  g_assert_null (run->error_text);
  samples = sonar_test_run_samples (run, "sink");
  g_assert_cmpuint (samples->len, ==, 3);
  for (guint p = 0; p < samples->len; p++) {
    SonarDetectionsMeta *dets = sample_detections (samples->pdata[p]);
    for (guint i = 0; i < dets->n_detections; i++) {
      const SonarDetection *d = &dets->detections[i];
      g_test_message ("ping %u: %.4f m %+.3f deg, %s", p, d->range,
          d->azimuth, d->valid ? "valid" : "rejected");
      g_assert_cmpfloat (fabs (d->azimuth), <=, 90.0);
      g_assert_cmpfloat (fabs (d->elevation), <=, 90.0);
      valid += d->valid;
    }
  }
  g_assert_cmpuint (valid, >=, 4);
}

/* One emitter in the product (emitters=1) is warned of: nothing is left
 * to compare across emitters, and the ghost tests pass every centroid. */
static void
test_one_emitter_warned (void)
{
  g_autoptr (SonarTestRun) run = sonar_test_run ("sonarsrc num-buffers=1 "
      "! dopplerbank ! mimobeamform ! wardcluster ! velocityest emitters=1 "
      "! fakesink");
  gboolean warned = FALSE;

  g_assert_null (run->error_text);
  for (guint i = 0; i < run->warnings->len; i++)
    warned |= g_strcmp0 (run->warnings->pdata[i], "velocityest: one "
        "emitter enters the Doppler-ACF product (emitters=1): the tests "
        "that compare the emitters (coherence, agreement) cannot tell an "
        "echo from a sidelobe or a ghost, and every centroid may be "
        "reported; use two emitters or more") == 0;
  g_assert_true (warned);
}

/* With the ridges out of the image (range-min above them), the same
 * recording gives the normal reflector with its velocity: the near-far
 * limitation above is the clustering's, not the estimator's. */
static void
test_near_far_normal_alone_in_image (void)
{
  g_autofree char *scene = sonar_test_write_temp ("near-far.json",
      "{\"dimensions\": 2, \"reflectors\": ["
      " {\"range\": 0.5, \"azimuth\": 0, \"strength\": 100},"
      " {\"range\": 2.5, \"azimuth\": 40, \"radial-velocity\": 0.6}]}");
  g_autofree char *launch = g_strdup_printf ("sonarsrc scene-file=%s "
      "num-buffers=1 ! dopplerbank " NARROW_BANK " ! mimobeamform "
      "azimuth-count=91 range-min=2.2 ! wardcluster ! velocityest ! "
      "appsink name=sink sync=false", scene);
  GstSample *sample;
  Score s;

  run_one_ping (launch, 1, &sample);
  s = score_sample (sample, "range-min=2.2");
  g_assert_cmpuint (s.matched, ==, 1);
  g_assert_cmpuint (s.false_positives, ==, 0);
  g_assert_cmpfloat (s.max_error, <=, 0.02);
  gst_sample_unref (sample);
}

/* 1b. Sensitivity at the defaults -------------------------------------------
 *
 * Every element at its defaults (the -7..7 m/s bank, 47 detection
 * hypotheses, wardcluster's pfa 1e-10). Per-channel SNR as the README
 * defines it: (strength / (2 r)^2)^2 x the emissions' summed mean square
 * (0.5593 for sonarsrc's default noise waveforms) over noise-amplitude^2. */
#define EMISSION_POWER 0.5593

/* The @n pings of the appsink "sink" of @launch into @samples (unref
 * them). Fails on any bus error. */
static void
run_pings (const char *launch, guint n, GstSample ** samples)
{
  g_autoptr (SonarTestRun) run = sonar_test_run (launch);
  GPtrArray *got;

  if (run->error_text)
    g_error ("%s: %s", launch, run->error_text);
  got = sonar_test_run_samples (run, "sink");
  g_assert_cmpuint (got->len, ==, n);
  for (guint i = 0; i < n; i++)
    samples[i] = gst_sample_ref (got->pdata[i]);
}

/* tests/test-live.c's near scene (two points at 1 and 1.5 m, the
 * defaults' -7..7 m/s bank), pinged 40 times a second: its ping 16 gave
 * a false object on the residual (0.84 m, -27.8 degrees, +4.5 m/s) once
 * the residual's models took the echoes' spectral shapes, with 7 of 8
 * emitters agreeing; a new estimate there counts only when all agree.
 * Each of the 17 pings: both objects, nothing else. */
static void
test_residual_no_debris (void)
{
  g_autofree char *scene = sonar_test_write_temp ("near.json",
      "{\"dimensions\": 2, \"reflectors\": ["
      " {\"range\": 1.0, \"azimuth\": 15, \"radial-velocity\": 0.1},"
      " {\"range\": 1.5, \"azimuth\": -30}]}");
  g_autofree char *launch = g_strdup_printf ("sonarsrc ping-rate=40 "
      "max-range=2 scene-file=%s num-buffers=17 ! dopplerbank ! "
      "mimobeamform ! wardcluster ! velocityest ! appsink name=sink "
      "sync=false", scene);
  GstSample *samples[17];

  run_pings (launch, 17, samples);
  for (guint k = 0; k < 17; k++) {
    const Score score = score_sample (samples[k], "near scene");
    g_assert_cmpuint (score.matched, ==, 2);
    g_assert_cmpuint (score.false_positives, ==, 0);
    gst_sample_unref (samples[k]);
  }
}

#define FAINT_PINGS 10
#define FAINT_RANGE 7.0
#define FAINT_SNR_DB -28.0

/* A unit point reflector at 7 m, -28 dB per channel (issue 12's goal:
 * found with probability 0.9 or more; sonar-bench --sweep detection
 * measured 0.98 over 50 pings): found in at least 9 of 10 pings with its
 * velocity, and nothing else reported. */
static void
test_faint_far_object (void)
{
  const double noise = pow (2.0 * FAINT_RANGE, -2.0) * sqrt (EMISSION_POWER)
      / pow (10.0, FAINT_SNR_DB / 20.0);
  g_autofree char *scene = sonar_test_write_temp ("faint.json",
      "{\"dimensions\": 2, \"reflectors\": ["
      " {\"range\": 7.0, \"azimuth\": 23, \"radial-velocity\": -0.45}]}");
  g_autofree char *launch = g_strdup_printf ("sonarsrc scene-file=%s "
      "max-range=8 noise-amplitude=%.6f num-buffers=%d ! dopplerbank ! "
      "mimobeamform ! wardcluster ! velocityest ! appsink name=sink "
      "sync=false", scene, noise, FAINT_PINGS);
  GstSample *samples[FAINT_PINGS];
  guint found = 0;

  g_test_message ("noise-amplitude %.4f for %.0f dB per channel at %.0f m",
      noise, FAINT_SNR_DB, FAINT_RANGE);
  run_pings (launch, FAINT_PINGS, samples);
  for (guint p = 0; p < FAINT_PINGS; p++) {
    const Score s = score_sample (samples[p], "faint");
    g_assert_cmpuint (s.false_positives, ==, 0);
    if (s.matched)
      g_assert_cmpfloat (s.max_error, <=, 0.05);
    found += s.matched;
    gst_sample_unref (samples[p]);
  }
  g_test_message ("found in %u of %d pings", found, FAINT_PINGS);
  g_assert_cmpuint (found, >=, FAINT_PINGS - 1);
}

#define NOISE_PINGS 100
/* Under the sanitizers (meson test --setup asan) the same code runs about
 * five times slower: a tenth of the pings checks its memory accesses,
 * and the plain and clang runs check the false-alarm rate on all. */
#define NOISE_PINGS_SANITIZED 10

/* Noise alone (sonarsrc scene=empty), 100 pings at the defaults: no
 * object (sonar-bench --sweep noise: 1000 pings). keep-rejected shows
 * the centroids velocityest rejected, if any. */
static void
test_noise_only_no_false_objects (void)
{
  const guint n_pings = sonar_test_sanitized () ?
      NOISE_PINGS_SANITIZED : NOISE_PINGS;
  g_autofree char *launch = g_strdup_printf ("sonarsrc scene=empty "
      "num-buffers=%u ! dopplerbank ! mimobeamform ! wardcluster ! "
      "velocityest keep-rejected=true ! appsink name=sink sync=false",
      n_pings);
  GstSample *samples[NOISE_PINGS];
  guint centroids = 0;

  run_pings (launch, n_pings, samples);
  for (guint p = 0; p < n_pings; p++) {
    SonarDetectionsMeta *dets = sample_detections (samples[p]);
    for (guint i = 0; i < dets->n_detections; i++) {
      g_test_message ("ping %u: %s at %.3f m %+.1f deg", p,
          dets->detections[i].valid ? "FALSE OBJECT" : "rejected",
          dets->detections[i].range, dets->detections[i].azimuth);
      g_assert_false (dets->detections[i].valid);
    }
    centroids += dets->n_detections;
    gst_sample_unref (samples[p]);
  }
  g_test_message ("%u noise centroids on %u pings, all rejected", centroids,
      n_pings);
}

/* 2. Near +-90 degrees ------------------------------------------------------
 *
 * The point spread function widens as 1 / cos (azimuth): 13 degrees at 80.
 * Each reflector must still be one centroid and one detection, with its
 * velocity (on the default 181-direction grid, where the wide lobe holds
 * the most peaks). */
#define WIDE_SCENE "{\"dimensions\": 2, \"reflectors\": [" \
  " {\"range\": 2.0, \"azimuth\": 80}," \
  " {\"range\": 1.5, \"azimuth\": -85, \"radial-velocity\": -0.5}]}"

static void
test_wide_angles_not_split (void)
{
  g_autofree char *scene = sonar_test_write_temp ("wide.json", WIDE_SCENE);
  g_autofree char *launch = g_strdup_printf ("sonarsrc scene-file=%s "
      "num-buffers=1 ! dopplerbank " NARROW_BANK " ! mimobeamform ! "
      "wardcluster ! velocityest keep-rejected=true ! appsink name=sink "
      "sync=false", scene);
  GstSample *sample;
  SonarDetectionsMeta *dets;
  SonarCentroidsMeta *centroids;
  Score s;

  run_one_ping (launch, 1, &sample);
  dets = sample_detections (sample);
  centroids = sonar_buffer_get_centroids_meta (gst_sample_get_buffer
      (sample));
  print_detections ("wide", dets);
  for (guint k = 0; k < centroids->n_centroids; k++)
    g_test_message ("centroid %.4f m %+.2f deg, %u peaks",
        centroids->centroids[k].range, centroids->centroids[k].azimuth,
        centroids->centroids[k].n_members);
  g_assert_cmpuint (centroids->n_centroids, ==, 2);
  /* keep-rejected=true: a split would show as a third detection. */
  g_assert_cmpuint (dets->n_detections, ==, 2);
  s = score_sample (sample, "wide");
  g_assert_cmpuint (s.matched, ==, 2);
  g_assert_cmpuint (s.false_positives, ==, 0);
  g_assert_cmpfloat (s.max_error, <=, 0.02);
  gst_sample_unref (sample);
}

/* The same at threshold=-20 and without the noise-floor test (pfa=1): each wide lobe
 * now has several peaks that must merge into one centroid, and the
 * emitters' cross-talk ridges, which smear over +-70..90 degrees, give some
 * 240 more centroids that velocityest must all reject. */
static void
test_wide_angles_low_threshold (void)
{
  g_autofree char *scene = sonar_test_write_temp ("wide.json", WIDE_SCENE);
  g_autofree char *launch = g_strdup_printf ("sonarsrc scene-file=%s "
      "num-buffers=1 ! dopplerbank " NARROW_BANK " ! mimobeamform ! "
      "wardcluster threshold=-20 pfa=1 ! velocityest ! appsink name=sink "
      "sync=false", scene);
  GstSample *sample;
  SonarCentroidsMeta *centroids;
  guint merged = 0;
  Score s;

  run_one_ping (launch, 1, &sample);
  centroids = sonar_buffer_get_centroids_meta (gst_sample_get_buffer
      (sample));
  print_detections ("wide, -20 dB", sample_detections (sample));
  for (guint k = 0; k < 2 && k < centroids->n_centroids; k++) {
    g_test_message ("centroid %.4f m %+.2f deg, %u peaks",
        centroids->centroids[k].range, centroids->centroids[k].azimuth,
        centroids->centroids[k].n_members);
    merged += centroids->centroids[k].n_members;
  }
  g_test_message ("%u centroids in all", centroids->n_centroids);
  g_assert_cmpuint (centroids->n_centroids, >, 2);
  /* The two strongest centroids are the objects, made of more than one
   * peak between them. */
  g_assert_cmpuint (merged, >, 2);
  g_assert_cmpuint (sample_detections (sample)->n_detections, ==, 2);
  s = score_sample (sample, "wide, -20 dB");
  g_assert_cmpuint (s.matched, ==, 2);
  g_assert_cmpuint (s.false_positives, ==, 0);
  g_assert_cmpfloat (s.max_error, <=, 0.02);
  gst_sample_unref (sample);
}

/* 3. Beyond the bank ----------------------------------------------------------
 *
 * A reflector approaching at 1.0 m/s with the -0.4..0.4 bank: it may go
 * unreported or be reported "out_of_range", but never as a confident
 * in-range wrong speed. Strength 10, so that its (Doppler-mismatched,
 * smeared) echo does make centroids; a still control object must come out
 * right. keep-rejected=true shows everything velocityest saw. */
static void
test_beyond_the_bank (void)
{
  g_autofree char *scene = sonar_test_write_temp ("fast.json",
      "{\"dimensions\": 2, \"reflectors\": ["
      " {\"range\": 2.0, \"azimuth\": 20, \"radial-velocity\": -1.0,"
      "  \"strength\": 10},"
      " {\"range\": 1.5, \"azimuth\": -30}]}");
  g_autofree char *launch = g_strdup_printf ("sonarsrc scene-file=%s "
      "num-buffers=1 ! dopplerbank " FIG10_BANK " ! mimobeamform "
      "azimuth-count=91 ! wardcluster ! velocityest keep-rejected=true ! "
      "appsink name=sink sync=false", scene);
  GstSample *sample;
  SonarTruthMeta *truth;
  SonarDetectionsMeta *dets;
  guint near_mover = 0, flagged = 0, control = 0;

  run_one_ping (launch, 1, &sample);
  truth = sample_truth (sample);
  dets = sample_detections (sample);
  g_assert_cmpuint (truth->n_truths, ==, 2);
  for (guint i = 0; i < dets->n_detections; i++) {
    const SonarDetection *d = &dets->detections[i];
    const SonarTruth *still = &truth->truths[1];
    if (distance_to (d, still) < MATCH_DISTANCE) {
      g_test_message ("control: %.4f m %+.2f deg %+.4f m/s%s", d->range,
          d->azimuth, d->radial_velocity, d->valid ? "" : " rejected");
      g_assert_true (d->valid);
      g_assert_false (d->out_of_range);
      g_assert_cmpfloat (fabs (d->radial_velocity - still->radial_velocity),
          <=, 0.02);
      control++;
      continue;
    }
    /* Everything else is the fast reflector or its smear (measured:
     * 1.6 to 3.3 m, 17 to 23 degrees). */
    near_mover++;
    flagged += d->out_of_range || !d->valid;
    if (d->valid)
      g_test_message ("reported near the mover: %.4f m %+.2f deg %+.4f m/s "
          "out_of_range %d", d->range, d->azimuth, d->radial_velocity,
          d->out_of_range);
    g_assert_false (d->valid && !d->out_of_range
        && !(fabs (d->radial_velocity - (-1.0)) <= 0.1));
  }
  g_test_message ("%u detections around the mover (%u rejected or out of "
      "range), control found %u time(s)", near_mover, flagged, control);
  g_assert_cmpuint (control, ==, 1);
  gst_sample_unref (sample);
}

/* Just beyond the edge (-0.6 m/s, within a Doppler main lobe of -0.4): the
 * reflector is found, at the bank's edge, and flagged "out_of_range". */
static void
test_beyond_the_bank_edge (void)
{
  g_autofree char *scene = sonar_test_write_temp ("edge.json",
      "{\"dimensions\": 2, \"reflectors\": ["
      " {\"range\": 2.0, \"azimuth\": 20, \"radial-velocity\": -0.6},"
      " {\"range\": 1.5, \"azimuth\": -30}]}");
  g_autofree char *launch = g_strdup_printf ("sonarsrc scene-file=%s "
      "num-buffers=1 ! dopplerbank " FIG10_BANK " ! mimobeamform "
      "azimuth-count=91 ! wardcluster ! velocityest ! appsink name=sink "
      "sync=false", scene);
  GstSample *sample;
  SonarTruthMeta *truth;
  SonarDetectionsMeta *dets;
  guint mover = 0, still = 0;

  run_one_ping (launch, 1, &sample);
  truth = sample_truth (sample);
  dets = sample_detections (sample);
  print_detections ("edge", dets);
  for (guint i = 0; i < dets->n_detections; i++) {
    const SonarDetection *d = &dets->detections[i];
    const int k = truth_of (d, truth);
    g_assert_cmpint (k, >=, 0);
    if (k == 0) {
      g_assert_true (d->out_of_range);
      g_assert_true (d->approaching);
      g_assert_cmpfloat (d->radial_velocity, <=, -0.38);
      mover++;
    } else {
      g_assert_false (d->out_of_range);
      g_assert_cmpfloat (fabs (d->radial_velocity), <=, 0.02);
      still++;
    }
  }
  g_assert_cmpuint (mover, ==, 1);
  g_assert_cmpuint (still, ==, 1);
  gst_sample_unref (sample);
}

/* 4. Sub-step refinement ------------------------------------------------------
 *
 * The same fig10 ping through velocityest refine=false and refine=true (a
 * tee after wardcluster): the refined estimates must be closer to the
 * truth than the bank's 0.02 m/s grid. */
static void
test_refine_beats_the_grid (void)
{
  GstSample *samples[2];
  Score coarse, fine;

  run_one_ping ("sonarsrc scene=fig10 num-buffers=1 ! dopplerbank "
      FIG10_BANK " ! mimobeamform ! wardcluster ! tee name=t "
      "t. ! queue ! velocityest refine=false ! appsink name=sink0 sync=false "
      "t. ! queue ! velocityest refine=true ! appsink name=sink1 sync=false",
      2, samples);
  coarse = score_sample (samples[0], "refine=false");
  fine = score_sample (samples[1], "refine=true");
  g_test_message ("refine=false: %u of %u, mean error %.4f m/s, worst "
      "%.4f m/s", coarse.matched, coarse.n_truth,
      coarse.sum_error / MAX (coarse.matched, 1), coarse.max_error);
  g_test_message ("refine=true: %u of %u, mean error %.4f m/s, worst "
      "%.4f m/s", fine.matched, fine.n_truth,
      fine.sum_error / MAX (fine.matched, 1), fine.max_error);
  g_assert_cmpuint (coarse.n_truth, ==, 6);
  g_assert_cmpuint (coarse.matched, ==, 6);
  g_assert_cmpuint (fine.matched, ==, 6);
  g_assert_cmpuint (coarse.false_positives, ==, 0);
  g_assert_cmpuint (fine.false_positives, ==, 0);
  g_assert_cmpfloat (fine.sum_error / fine.matched, <,
      coarse.sum_error / coarse.matched);
  gst_sample_unref (samples[0]);
  gst_sample_unref (samples[1]);
}

/* 5. Linkages -----------------------------------------------------------------
 *
 * The default scene (three objects, one approaching at 1 m/s) with single
 * linkage, and with Ward cut at 0.1 m instead of by inconsistency (one
 * image, teed into both). */
static void
test_linkages_default_scene (void)
{
  const char *what[2] = { "linkage=single", "stop=distance distance=0.1" };
  GstSample *samples[2];

  run_one_ping ("sonarsrc num-buffers=1 ! dopplerbank " NARROW_BANK
      " ! mimobeamform ! tee name=t "
      "t. ! queue ! wardcluster linkage=single ! velocityest ! "
      "appsink name=sink0 sync=false "
      "t. ! queue ! wardcluster stop=distance distance=0.1 ! velocityest ! "
      "appsink name=sink1 sync=false", 2, samples);
  for (guint i = 0; i < 2; i++) {
    Score s = score_sample (samples[i], what[i]);
    g_test_message ("%s: %u of %u, %u false positives, worst error %.4f m/s",
        what[i], s.matched, s.n_truth, s.false_positives, s.max_error);
    g_assert_cmpuint (s.n_truth, ==, 3);
    g_assert_cmpuint (s.matched, ==, 3);
    g_assert_cmpuint (s.false_positives, ==, 0);
    g_assert_cmpfloat (s.max_error, <=, 0.02);
    gst_sample_unref (samples[i]);
  }
}

/* velocityest's results do not hold the ping's spectra (the largest
 * buffer of the chain) while they wait downstream; the truth and the
 * detections stay with them. */
static void
test_results_release_spectra (void)
{
  GstSample *sample;
  GstBuffer *buffer;

  run_one_ping ("sonarsrc num-buffers=1 ! dopplerbank " NARROW_BANK
      " ! mimobeamform ! wardcluster ! velocityest ! appsink name=sink "
      "sync=false", 1, &sample);
  buffer = gst_sample_get_buffer (sample);
  g_assert_null (sonar_buffer_get_spectra_meta (buffer));
  g_assert_nonnull (sonar_buffer_get_detections_meta (buffer));
  g_assert_cmpuint (sample_truth (sample)->n_truths, ==, 3);
  g_assert_cmpuint (sample_detections (sample)->n_detections, ==, 3);
  /* Small: the JSON line, not the spectra. */
  g_assert_cmpuint (gst_buffer_get_size (buffer), <, 4096);
  gst_sample_unref (sample);
}

/* 6. Errors -------------------------------------------------------------------*/

static void
assert_run_error (const char *launch, const char *needle)
{
  g_autofree char *error = sonar_test_run_pipeline (launch);

  g_assert_nonnull (error);
  g_test_message ("%s\n  -> %s", launch, error);
  g_assert_nonnull (strstr (error, needle));
}

static void
test_error_velocityest_without_wardcluster (void)
{
  assert_run_error ("sonarsrc num-buffers=1 ! dopplerbank velocity-min=-0.4 "
      "velocity-max=0.4 velocity-step=0.2 ! mimobeamform azimuth-count=31 ! "
      "velocityest ! fakesink", "wardcluster");
}

static void
test_error_wardcluster_after_datacube (void)
{
  assert_run_error ("sonarsrc num-buffers=1 ! dopplerbank velocity-min=-0.4 "
      "velocity-max=0.4 velocity-step=0.2 ! mimobeamform azimuth-count=31 "
      "mode=datacube ! wardcluster ! fakesink", "datacube");
}

/* Without dopplerbank the recordings cannot link to mimobeamform, nor the
 * spectra or energyscapes to the wrong stage. */
static void
test_error_wrong_order_does_not_link (void)
{
  const char *launches[] = {
    "sonarsrc num-buffers=1 ! mimobeamform ! velocityest ! fakesink",
    "sonarsrc num-buffers=1 ! dopplerbank ! velocityest ! fakesink",
    "sonarsrc num-buffers=1 ! dopplerbank ! wardcluster ! mimobeamform ! "
        "fakesink",
    "sonarsrc num-buffers=1 ! dopplerbank ! mimobeamform ! velocityest ! "
        "wardcluster ! fakesink",
  };

  for (guint i = 0; i < G_N_ELEMENTS (launches); i++) {
    GError *error = NULL;
    GstElement *pipeline = gst_parse_launch (launches[i], &error);
    g_assert_nonnull (error);
    g_test_message ("%s\n  -> %s", launches[i], error->message);
    g_assert_true (g_error_matches (error, GST_PARSE_ERROR,
            GST_PARSE_ERROR_LINK));
    g_assert_nonnull (strstr (error->message, "could not link"));
    g_clear_error (&error);
    if (pipeline)
      gst_object_unref (pipeline);
  }
}

/* Out-of-range property values are refused by the GParamSpec ranges: GLib
 * warns naming the property, the pipeline still builds and the property
 * keeps its default. (wardcluster's own checks, "cluster: max-peaks must be
 * 1 to 4096", cannot be reached through the properties.) */
static void
test_error_wardcluster_absurd_properties (void)
{
  const struct
  {
    const char *property, *value;
    guint expected;
  } cases[] = {
    {"max-peaks", "0", 2000},
    {"depth", "0", 3},
    {"max-peaks", "5000", 2000},
  };

  for (guint i = 0; i < G_N_ELEMENTS (cases); i++) {
    g_autofree char *launch = g_strdup_printf ("wardcluster name=w %s=%s",
        cases[i].property, cases[i].value);
    g_autofree char *pattern = g_strdup_printf ("*invalid or out of range "
        "for property '%s'*", cases[i].property);
    GError *error = NULL;
    GstElement *element, *w;
    guint value;

    g_test_expect_message ("GLib-GObject", G_LOG_LEVEL_WARNING, pattern);
    element = gst_parse_launch (launch, &error);
    g_test_assert_expected_messages ();
    g_assert_no_error (error);
    g_assert_nonnull (element);
    w = GST_IS_BIN (element) ? gst_bin_get_by_name (GST_BIN (element), "w")
        : gst_object_ref (element);
    g_object_get (w, cases[i].property, &value, NULL);
    g_test_message ("%s -> warning; %s stays %u", launch, cases[i].property,
        value);
    g_assert_cmpuint (value, ==, cases[i].expected);
    gst_object_unref (w);
    gst_object_unref (element);
  }
}

static void
test_error_min_coherence_range (void)
{
  GstElement *v = gst_element_factory_make ("velocityest", NULL);
  double value;

  g_assert_nonnull (v);
  g_object_set (v, "min-coherence", 0.9, NULL);
  g_test_expect_message ("GLib-GObject", G_LOG_LEVEL_WARNING,
      "*invalid or out of range for property 'min-coherence'*");
  g_object_set (v, "min-coherence", 1.5, NULL);
  g_test_assert_expected_messages ();
  g_object_get (v, "min-coherence", &value, NULL);
  g_assert_cmpfloat (value, ==, 0.9);
  g_test_expect_message ("GLib-GObject", G_LOG_LEVEL_WARNING,
      "*invalid or out of range for property 'min-coherence'*");
  g_object_set (v, "min-coherence", -0.1, NULL);
  g_test_assert_expected_messages ();
  g_object_get (v, "min-coherence", &value, NULL);
  g_assert_cmpfloat (value, ==, 0.9);
  gst_object_unref (v);
}

/* 7. Messages -----------------------------------------------------------------*/

static guint
message_list_size (GstMessage * msg, const char *field)
{
  const GValue *list = gst_structure_get_value (gst_message_get_structure
      (msg), field);
  g_assert_nonnull (list);
  return gst_value_array_get_size (list);
}

static void
test_messages (void)
{
  GstElement *pipeline = parse_pipeline (CHAIN_DEFAULT " post-messages=false"
      " ! appsink name=sink sync=false");
  GstElement *sink = gst_bin_get_by_name (GST_BIN (pipeline), "sink");
  GstBus *bus = gst_element_get_bus (pipeline);
  GstSample *sample;
  SonarCentroidsMeta *centroids;
  GstMessage *msg;
  guint n_centroid_msgs = 0, n_detection_msgs = 0;

  gst_element_set_state (pipeline, GST_STATE_PLAYING);
  sample = gst_app_sink_pull_sample (GST_APP_SINK (sink));
  g_assert_nonnull (sample);
  g_assert_null (gst_app_sink_pull_sample (GST_APP_SINK (sink)));
  centroids = sonar_buffer_get_centroids_meta (gst_sample_get_buffer
      (sample));
  g_assert_nonnull (centroids);
  g_assert_cmpuint (centroids->n_centroids, >=, 3);
  while ((msg = gst_bus_pop_filtered (bus, GST_MESSAGE_ELEMENT |
              GST_MESSAGE_ERROR))) {
    g_assert_cmpint (GST_MESSAGE_TYPE (msg), ==, GST_MESSAGE_ELEMENT);
    if (gst_message_has_name (msg, SONAR_CENTROIDS_MESSAGE_NAME)) {
      const GstStructure *s = gst_message_get_structure (msg);
      guint64 ping = G_MAXUINT64;
      g_assert_true (g_str_has_prefix (GST_OBJECT_NAME (GST_MESSAGE_SRC
                  (msg)), "wardcluster"));
      g_assert_true (gst_structure_get_uint64 (s, "ping", &ping));
      g_assert_cmpuint (ping, ==, centroids->ping_index);
      g_test_message ("sonar-centroids: %u centroids, meta %u",
          message_list_size (msg, "centroids"), centroids->n_centroids);
      g_assert_cmpuint (message_list_size (msg, "centroids"), ==,
          centroids->n_centroids);
      n_centroid_msgs++;
    }
    n_detection_msgs += gst_message_has_name (msg,
        SONAR_DETECTIONS_MESSAGE_NAME);
    gst_message_unref (msg);
  }
  g_assert_cmpuint (n_centroid_msgs, ==, 1);
  g_assert_cmpuint (n_detection_msgs, ==, 0);
  gst_sample_unref (sample);
  gst_element_set_state (pipeline, GST_STATE_NULL);
  gst_object_unref (bus);
  gst_object_unref (sink);
  gst_object_unref (pipeline);
}

/* 8. State changes ------------------------------------------------------------*/

/* GStreamer warnings (and worse) of the plugin's debug categories. */
static guint plugin_warnings;

static void
count_plugin_warnings (GstDebugCategory * category, GstDebugLevel level,
    const gchar * file, const gchar * function, gint line, GObject * object,
    GstDebugMessage * message, gpointer user_data)
{
  static const char *names[] = { "sonarsrc", "dopplerbank", "mimobeamform",
    "wardcluster", "velocityest", "sonarfilter"
  };

  if (level > GST_LEVEL_WARNING)
    return;
  for (guint i = 0; i < G_N_ELEMENTS (names); i++) {
    if (strcmp (gst_debug_category_get_name (category), names[i]) == 0) {
      g_test_message ("%s warning: %s", names[i],
          gst_debug_message_get (message));
      g_atomic_int_inc (&plugin_warnings);
    }
  }
}

static void
watch_plugin_warnings (gboolean on)
{
  static const char *names[] = { "sonarsrc", "dopplerbank", "mimobeamform",
    "wardcluster", "velocityest", "sonarfilter"
  };

  for (guint i = 0; i < G_N_ELEMENTS (names); i++) {
    if (on)
      gst_debug_set_threshold_for_name (names[i], GST_LEVEL_WARNING);
    else
      gst_debug_unset_threshold_for_name (names[i]);
  }
  if (on) {
    plugin_warnings = 0;
    gst_debug_add_log_function (count_plugin_warnings, NULL, NULL);
  } else {
    gst_debug_remove_log_function (count_plugin_warnings);
  }
}

/* Runs @pipeline (already built, in NULL) to EOS and returns its JSON. */
static char *
run_to_eos (GstElement * pipeline, guint expected_pings)
{
  GstElement *sink = gst_bin_get_by_name (GST_BIN (pipeline), "sink");
  GstBus *bus = gst_element_get_bus (pipeline);
  GString *json = g_string_new (NULL);
  GstSample *sample;
  GstMessage *msg;
  guint pings = 0;

  g_assert_cmpint (gst_element_set_state (pipeline, GST_STATE_PLAYING), !=,
      GST_STATE_CHANGE_FAILURE);
  while ((sample = gst_app_sink_pull_sample (GST_APP_SINK (sink)))) {
    g_autofree char *text = sample_text (sample);
    g_string_append (json, text);
    pings++;
    gst_sample_unref (sample);
  }
  msg = gst_bus_timed_pop_filtered (bus, 10 * GST_SECOND,
      GST_MESSAGE_EOS | GST_MESSAGE_ERROR);
  g_assert_nonnull (msg);
  if (GST_MESSAGE_TYPE (msg) == GST_MESSAGE_ERROR)
    assert_no_bus_error (bus);
  g_assert_cmpint (GST_MESSAGE_TYPE (msg), ==, GST_MESSAGE_EOS);
  gst_message_unref (msg);
  g_assert_cmpint (gst_element_set_state (pipeline, GST_STATE_NULL), ==,
      GST_STATE_CHANGE_SUCCESS);
  gst_bus_set_flushing (bus, TRUE);
  gst_bus_set_flushing (bus, FALSE);
  g_assert_cmpuint (pings, ==, expected_pings);
  gst_object_unref (bus);
  gst_object_unref (sink);
  return g_string_free (json, FALSE);
}

static void
test_rerun_identical (void)
{
  GstElement *pipeline = parse_pipeline ("sonarsrc num-buffers=2 ! "
      "dopplerbank " NARROW_BANK " ! mimobeamform azimuth-count=91 ! "
      "wardcluster ! velocityest ! appsink name=sink sync=false");
  g_autofree char *first = NULL;

  watch_plugin_warnings (TRUE);
  first = run_to_eos (pipeline, 2);
  g_test_message ("run 1: %s", first);
  g_assert_nonnull (strstr (first, "\"ping\": 1,"));
  g_assert_nonnull (strstr (first, "\"radial_velocity\""));
  for (guint run = 2; run <= 3; run++) {
    g_autofree char *again = run_to_eos (pipeline, 2);
    g_assert_cmpstr (again, ==, first);
  }
  watch_plugin_warnings (FALSE);
  g_assert_cmpuint (plugin_warnings, ==, 0);
  gst_object_unref (pipeline);
}

static void
collect_elements (const GValue * item, gpointer user_data)
{
  g_ptr_array_add (user_data, g_value_get_object (item));
}

/* Stopped after the first ping, while the second is being processed: no
 * crash, no warning, no error; every element is freed when the pipeline
 * is; and the same pipeline then runs again from ping 0. */
static void
test_stop_mid_run (void)
{
  GstElement *pipeline = parse_pipeline ("sonarsrc num-buffers=3 ! "
      "dopplerbank " NARROW_BANK " ! mimobeamform azimuth-count=91 ! "
      "wardcluster ! velocityest ! appsink name=sink sync=false");
  GstElement *sink = gst_bin_get_by_name (GST_BIN (pipeline), "sink");
  GstBus *bus = gst_element_get_bus (pipeline);
  GPtrArray *elements = g_ptr_array_new ();
  GstIterator *it = gst_bin_iterate_elements (GST_BIN (pipeline));
  gpointer weak[8] = { NULL };
  GstSample *sample;
  g_autofree char *first_ping = NULL;

  watch_plugin_warnings (TRUE);
  gst_iterator_foreach (it, collect_elements, elements);
  gst_iterator_free (it);
  g_assert_cmpuint (elements->len, ==, 6);
  g_ptr_array_add (elements, pipeline);
  for (guint i = 0; i < elements->len; i++) {
    weak[i] = elements->pdata[i];
    g_object_add_weak_pointer (G_OBJECT (weak[i]), &weak[i]);
  }

  for (guint round = 0; round < 2; round++) {
    g_autofree char *text = NULL;
    gst_element_set_state (pipeline, GST_STATE_PLAYING);
    sample = gst_app_sink_pull_sample (GST_APP_SINK (sink));
    g_assert_nonnull (sample);
    text = sample_text (sample);
    gst_sample_unref (sample);
    g_assert_true (g_str_has_prefix (text, "{\"ping\": 0,"));
    if (round == 0)
      first_ping = g_strdup (text);
    else
      g_assert_cmpstr (text, ==, first_ping);
    g_assert_cmpint (gst_element_set_state (pipeline, GST_STATE_NULL), ==,
        GST_STATE_CHANGE_SUCCESS);
    assert_no_bus_error (bus);
    gst_bus_set_flushing (bus, TRUE);
    gst_bus_set_flushing (bus, FALSE);
  }
  watch_plugin_warnings (FALSE);
  g_assert_cmpuint (plugin_warnings, ==, 0);

  gst_object_unref (bus);
  gst_object_unref (sink);
  gst_object_unref (pipeline);
  for (guint i = 0; i < elements->len; i++)
    g_assert_null (weak[i]);
  g_ptr_array_unref (elements);
}

int
main (int argc, char **argv)
{
  sonar_test_init_gst (&argc, &argv);
  g_test_add_func ("/velocityest/sensitivity/faint-far-object",
      test_faint_far_object);
  g_test_add_func ("/velocityest/sensitivity/noise-only",
      test_noise_only_no_false_objects);
  g_test_add_func ("/velocityest/near-far/hidden-within-pulse",
      test_hidden_within_pulse);
  g_test_add_func ("/velocityest/near-far/residual-no-debris",
      test_residual_no_debris);
  g_test_add_func ("/velocityest/near-far/strong-still",
      test_near_far_strong_still);
  g_test_add_func ("/velocityest/near-far/strong-moving",
      test_near_far_strong_moving);
  g_test_add_func ("/velocityest/one-emitter-warned",
      test_one_emitter_warned);
  g_test_add_func ("/velocityest/directions-at-the-edges",
      test_directions_at_the_edges);
  g_test_add_func ("/velocityest/one-echo-off-boresight-3d",
      test_one_echo_off_boresight_3d);
  g_test_add_func ("/velocityest/near-far/3d-off-the-coarse-grid",
      test_near_far_3d);
  g_test_add_func ("/velocityest/near-far/normal-alone-in-image",
      test_near_far_normal_alone_in_image);
  g_test_add_func ("/velocityest/wide-angles-not-split",
      test_wide_angles_not_split);
  g_test_add_func ("/velocityest/wide-angles-low-threshold",
      test_wide_angles_low_threshold);
  g_test_add_func ("/velocityest/beyond-the-bank/far", test_beyond_the_bank);
  g_test_add_func ("/velocityest/beyond-the-bank/edge",
      test_beyond_the_bank_edge);
  g_test_add_func ("/velocityest/refine-beats-the-grid",
      test_refine_beats_the_grid);
  g_test_add_func ("/velocityest/linkages-default-scene",
      test_linkages_default_scene);
  g_test_add_func ("/velocityest/error/without-wardcluster",
      test_error_velocityest_without_wardcluster);
  g_test_add_func ("/velocityest/error/wardcluster-after-datacube",
      test_error_wardcluster_after_datacube);
  g_test_add_func ("/velocityest/error/wrong-order-does-not-link",
      test_error_wrong_order_does_not_link);
  g_test_add_func ("/velocityest/error/wardcluster-absurd-properties",
      test_error_wardcluster_absurd_properties);
  g_test_add_func ("/velocityest/error/min-coherence-range",
      test_error_min_coherence_range);
  g_test_add_func ("/velocityest/messages", test_messages);
  g_test_add_func ("/velocityest/results-release-spectra",
      test_results_release_spectra);
  g_test_add_func ("/velocityest/state/rerun-identical",
      test_rerun_identical);
  g_test_add_func ("/velocityest/state/stop-mid-run", test_stop_mid_run);
  return g_test_run ();
}
