/* sonar-test-gst.c: see sonar-test-gst.h. */
#include "sonar-test-gst.h"

#include <math.h>

#include "sonar-contracts.h"

char *
sonar_test_run_pipeline (const char *description, GstElement ** pipeline_out)
{
  GError *error = NULL;
  GstElement *pipeline = gst_parse_launch (description, &error);
  GstBus *bus;
  GstMessage *msg;
  char *result = NULL;

  if (!pipeline || error) {
    result = g_strdup_printf ("parse error: %s",
        error ? error->message : "?");
    g_clear_error (&error);
    if (pipeline)
      gst_object_unref (pipeline);
    return result;
  }
  bus = gst_element_get_bus (pipeline);
  gst_element_set_state (pipeline, GST_STATE_PLAYING);
  msg = gst_bus_timed_pop_filtered (bus, 300 * GST_SECOND,
      GST_MESSAGE_EOS | GST_MESSAGE_ERROR);
  if (!msg) {
    result = g_strdup ("timeout: no EOS within 300 s");
  } else if (GST_MESSAGE_TYPE (msg) == GST_MESSAGE_ERROR) {
    char *debug = NULL;
    gst_message_parse_error (msg, &error, &debug);
    result = g_strdup_printf ("%s\n%s", error->message, debug ? debug : "");
    g_clear_error (&error);
    g_free (debug);
  }
  if (msg)
    gst_message_unref (msg);
  gst_element_set_state (pipeline, GST_STATE_NULL);
  gst_object_unref (bus);
  if (pipeline_out)
    *pipeline_out = pipeline;
  else
    gst_object_unref (pipeline);
  return result;
}

void
sonar_test_init_gst (int *argc, char ***argv)
{
  g_test_init (argc, argv, NULL);
  gst_init (argc, argv);
}


void
sonar_test_score_ping (GstBuffer * buffer, SonarTestScore * s)
{
  SonarTruthMeta *truth = sonar_buffer_get_truth_meta (buffer);
  SonarDetectionsMeta *dets = sonar_buffer_get_detections_meta (buffer);

  g_assert_nonnull (truth);
  g_assert_nonnull (dets);
  g_assert_cmpuint (truth->ping_index, ==, dets->ping_index);
  for (guint k = 0; k < truth->n_truths; k++) {
    const SonarTruth *t = &truth->truths[k];
    gboolean found = FALSE;
    for (guint d = 0; d < dets->n_detections && !found; d++) {
      const SonarDetection *x = &dets->detections[d];
      if (sonar_vec3_norm (sonar_vec3_sub (x->position, t->position)) < 0.05) {
        const double err = fabs (x->radial_velocity - t->radial_velocity);
        g_test_message ("ping %" G_GUINT64_FORMAT ": %.2f m %+.1f deg "
            "truth %+.4f, estimate %+.4f m/s", truth->ping_index,
            t->range, t->azimuth, t->radial_velocity, x->radial_velocity);
        s->sum_error += err;
        s->max_error = MAX (s->max_error, err);
        found = TRUE;
      }
    }
    s->matched += found;
    if (!found)
      g_test_message ("ping %" G_GUINT64_FORMAT ": missed %.2f m %+.1f deg",
          truth->ping_index, t->range, t->azimuth);
  }
  for (guint d = 0; d < dets->n_detections; d++) {
    gboolean real = FALSE;
    for (guint k = 0; k < truth->n_truths; k++)
      real |= sonar_vec3_norm (sonar_vec3_sub (dets->detections[d].position,
              truth->truths[k].position)) < 0.05;
    if (!real) {
      g_test_message ("ping %" G_GUINT64_FORMAT ": false positive at %.2f m "
          "%+.1f deg", truth->ping_index, dets->detections[d].range,
          dets->detections[d].azimuth);
      s->false_positives++;
    }
  }
  s->n_truth += truth->n_truths;
  s->n_pings++;
}
