/* sonar-test-gst.c: see sonar-test-gst.h. */
#include "sonar-test-gst.h"

#include <gst/app/gstappsink.h>

#include <math.h>

#include "sonar-contracts.h"

/* The appsinks of @pipeline (a bin, or one element). */
static GPtrArray *
app_sinks (GstElement * pipeline)
{
  GPtrArray *sinks = g_ptr_array_new_with_free_func (gst_object_unref);
  GstIterator *it;
  GValue item = G_VALUE_INIT;

  if (!GST_IS_BIN (pipeline)) {
    if (GST_IS_APP_SINK (pipeline))
      g_ptr_array_add (sinks, gst_object_ref (pipeline));
    return sinks;
  }
  it = gst_bin_iterate_recurse (GST_BIN (pipeline));
  while (gst_iterator_next (it, &item) == GST_ITERATOR_OK) {
    GstElement *e = g_value_get_object (&item);
    if (GST_IS_APP_SINK (e))
      g_ptr_array_add (sinks, gst_object_ref (e));
    g_value_reset (&item);
  }
  g_value_unset (&item);
  gst_iterator_free (it);
  return sinks;
}

/* Takes @sink's queued samples (waiting up to @timeout for the first). */
static void
drain_sink (SonarTestRun * run, GstElement * sink, GstClockTime timeout)
{
  GPtrArray *samples = g_hash_table_lookup (run->samples,
      GST_OBJECT_NAME (sink));
  GstSample *sample;

  while ((sample = gst_app_sink_try_pull_sample (GST_APP_SINK (sink),
              timeout))) {
    g_ptr_array_add (samples, sample);
    timeout = 0;
  }
}

SonarTestRun *
sonar_test_run (const char *launch)
{
  return sonar_test_run_with (launch, NULL, NULL);
}

SonarTestRun *
sonar_test_run_with (const char *launch, SonarTestPrepare prepare,
    gpointer data)
{
  SonarTestRun *run = g_new0 (SonarTestRun, 1);
  GError *error = NULL;
  g_autoptr (GPtrArray) sinks = NULL;
  GstBus *bus;
  gboolean done = FALSE;
  const gint64 deadline = g_get_monotonic_time () + 300 * G_TIME_SPAN_SECOND;

  run->samples = g_hash_table_new_full (g_str_hash, g_str_equal, g_free,
      (GDestroyNotify) g_ptr_array_unref);
  run->warnings = g_ptr_array_new_with_free_func (g_free);
  run->infos = g_ptr_array_new_with_free_func (g_free);
  run->messages = g_ptr_array_new_with_free_func ((GDestroyNotify)
      gst_structure_free);
  run->pipeline = gst_parse_launch (launch, &error);
  if (error) {
    run->error_text = g_strdup_printf ("parse error: %s", error->message);
    run->error = error;
    g_clear_object (&run->pipeline);
    return run;
  }
  sinks = app_sinks (run->pipeline);
  for (guint i = 0; i < sinks->len; i++)
    g_hash_table_insert (run->samples, g_strdup (GST_OBJECT_NAME
            (sinks->pdata[i])), g_ptr_array_new_with_free_func
        ((GDestroyNotify) gst_sample_unref));
  bus = gst_element_get_bus (run->pipeline);
  if (prepare)
    prepare (run->pipeline, data);
  gst_element_set_state (run->pipeline, GST_STATE_PLAYING);
  while (!done && g_get_monotonic_time () < deadline) {
    GstMessage *msg;
    /* The appsinks are drained as the pipeline plays: their queues are
     * bounded only by memory, but a test's pings are few. */
    for (guint i = 0; i < sinks->len; i++)
      drain_sink (run, sinks->pdata[i], GST_MSECOND * 20 / sinks->len);
    while ((msg = gst_bus_timed_pop_filtered (bus, sinks->len ? 0 :
                GST_MSECOND * 20, GST_MESSAGE_EOS | GST_MESSAGE_ERROR |
                GST_MESSAGE_WARNING | GST_MESSAGE_INFO |
                GST_MESSAGE_ELEMENT))) {
      GError *e = NULL;
      char *debug = NULL;
      switch (GST_MESSAGE_TYPE (msg)) {
        case GST_MESSAGE_ERROR:
          gst_message_parse_error (msg, &e, &debug);
          run->error_text = g_strdup_printf ("%s\n%s", e->message,
              debug ? debug : "");
          run->error = g_steal_pointer (&e);
          done = TRUE;
          break;
        case GST_MESSAGE_WARNING:
          gst_message_parse_warning (msg, &e, &debug);
          g_ptr_array_add (run->warnings, g_strdup (e->message));
          break;
        case GST_MESSAGE_INFO:
          gst_message_parse_info (msg, &e, &debug);
          g_ptr_array_add (run->infos, g_strdup (e ? e->message : debug));
          break;
        case GST_MESSAGE_ELEMENT:
          if (gst_message_get_structure (msg))
            g_ptr_array_add (run->messages, gst_structure_copy
                (gst_message_get_structure (msg)));
          break;
        default:
          done = TRUE;          /* EOS */
          break;
      }
      g_clear_error (&e);
      g_free (debug);
      gst_message_unref (msg);
      if (done)
        break;
    }
  }
  /* Samples queued before EOS. */
  for (guint i = 0; i < sinks->len && !run->error; i++)
    drain_sink (run, sinks->pdata[i], 0);
  if (!done && !run->error_text)
    run->error_text = g_strdup ("timeout: no EOS within 300 s");
  gst_object_unref (bus);
  return run;
}

void
sonar_test_run_free (SonarTestRun * run)
{
  if (!run)
    return;
  if (run->pipeline) {
    gst_element_set_state (run->pipeline, GST_STATE_NULL);
    gst_object_unref (run->pipeline);
  }
  g_hash_table_unref (run->samples);
  g_ptr_array_unref (run->warnings);
  g_ptr_array_unref (run->infos);
  g_ptr_array_unref (run->messages);
  g_clear_error (&run->error);
  g_free (run->error_text);
  g_free (run);
}

GPtrArray *
sonar_test_run_samples (const SonarTestRun * run, const char *sink)
{
  GPtrArray *samples = g_hash_table_lookup (run->samples, sink);

  g_assert_nonnull (samples);
  return samples;
}

char *
sonar_test_run_text (const SonarTestRun * run, const char *sink)
{
  GPtrArray *samples = sonar_test_run_samples (run, sink);
  GString *text = g_string_new (NULL);

  for (guint i = 0; i < samples->len; i++) {
    GstBuffer *buffer = gst_sample_get_buffer (samples->pdata[i]);
    GstMapInfo map;
    g_assert_true (gst_buffer_map (buffer, &map, GST_MAP_READ));
    g_string_append_len (text, (const char *) map.data, map.size);
    gst_buffer_unmap (buffer, &map);
  }
  return g_string_free (text, FALSE);
}

char *
sonar_test_run_pipeline (const char *launch)
{
  g_autoptr (SonarTestRun) run = sonar_test_run (launch);

  return g_steal_pointer (&run->error_text);
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
