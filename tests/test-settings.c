/* test-settings.c: settings the elements cannot honour are refused or
 * reported, never silently changed: is-live and other NULL-or-READY
 * properties while playing, more agreeing emitters than emitters, more
 * centroids than wardcluster keeps. */
#include <gst/app/gstappsink.h>
#include <string.h>

#include "sonar-contracts.h"
#include "sonar-test-gst.h"

/* Brings @pipeline to PLAYING, and waits until it is there. */
static void
play (GstElement * pipeline)
{
  g_assert_cmpint (gst_element_set_state (pipeline, GST_STATE_PLAYING), !=,
      GST_STATE_CHANGE_FAILURE);
  g_assert_cmpint (gst_element_get_state (pipeline, NULL, NULL,
          10 * GST_SECOND), ==, GST_STATE_CHANGE_SUCCESS);
}

/* is-live is documented as changeable only in NULL or READY: GstBaseSrc
 * reads it as it starts, so a later change is refused, with a warning. */
static void
test_is_live_while_playing (void)
{
  GstElement *pipeline = gst_parse_launch ("sonarsrc name=src max-range=1 "
      "! fakesink sync=false", NULL);
  GstElement *src = gst_bin_get_by_name (GST_BIN (pipeline), "src");
  gboolean live = TRUE;

  play (pipeline);
  g_test_expect_message ("sonar", G_LOG_LEVEL_WARNING, "src: is-live can "
      "only be changed in the NULL or READY state, not in PLAYING: ignored");
  g_object_set (src, "is-live", TRUE, NULL);
  g_test_assert_expected_messages ();
  g_object_get (src, "is-live", &live, NULL);
  g_assert_false (live);

  gst_element_set_state (pipeline, GST_STATE_NULL);
  g_object_set (src, "is-live", TRUE, NULL);
  g_object_get (src, "is-live", &live, NULL);
  g_assert_true (live);
  gst_object_unref (src);
  gst_object_unref (pipeline);
}

/* So is every element's property marked for NULL or READY alone (here
 * wardcluster's linkage and mimobeamform's azimuth-count): set while
 * playing it was taken silently and read back, unused. Those that may
 * change while playing (wardcluster's threshold) still do. */
static void
test_ready_only_while_playing (void)
{
  GstElement *pipeline = gst_parse_launch ("sonarsrc max-range=1 "
      "! dopplerbank velocity-min=0 velocity-max=0 ! mimobeamform name=m "
      "! wardcluster name=c ! fakesink sync=false", NULL);
  GstElement *c = gst_bin_get_by_name (GST_BIN (pipeline), "c");
  GstElement *m = gst_bin_get_by_name (GST_BIN (pipeline), "m");
  gint linkage = -1;
  guint count = 0;
  double threshold = 0.0;

  play (pipeline);
  g_test_expect_message ("sonar", G_LOG_LEVEL_WARNING, "c: linkage can "
      "only be changed in the NULL or READY state, not in PLAYING: ignored");
  gst_util_set_object_arg (G_OBJECT (c), "linkage", "single");
  g_test_expect_message ("sonar", G_LOG_LEVEL_WARNING, "m: azimuth-count "
      "can only be changed in the NULL or READY state, not in PLAYING: "
      "ignored");
  g_object_set (m, "azimuth-count", 61, NULL);
  g_test_assert_expected_messages ();
  g_object_set (c, "threshold", -30.0, NULL);
  g_object_get (c, "threshold", &threshold, NULL);
  g_assert_cmpfloat (threshold, ==, -30.0);
  g_object_get (m, "azimuth-count", &count, NULL);
  g_assert_cmpuint (count, ==, 181);
  g_object_get (c, "linkage", &linkage, NULL);
  g_assert_cmpstr (g_enum_get_value (g_type_class_peek (G_PARAM_SPEC_VALUE_TYPE
              (g_object_class_find_property (G_OBJECT_GET_CLASS (c),
                      "linkage"))), linkage)->value_nick, ==, "ward");
  gst_element_set_state (pipeline, GST_STATE_NULL);
  gst_object_unref (c);
  gst_object_unref (m);
  gst_object_unref (pipeline);
}

#define VELOCITY_CHAIN "sonarsrc num-buffers=1 max-range=2 ! dopplerbank " \
  "velocity-step=0.5 ! mimobeamform range-max=2 ! wardcluster ! velocityest "

static void
assert_first_line (const char *launch, const char *expected)
{
  g_autofree char *message = sonar_test_run_pipeline (launch);

  if (!expected) {
    g_assert_null (message);
    return;
  }
  g_assert_nonnull (message);
  *strchrnul (message, '\n') = '\0';
  g_assert_cmpstr (message, ==, expected);
}

/* Like emitters=9 on an 8-emitter sensor, an impossible agreement is an
 * error, not clamped to what the sensor has. */
static void
test_min_agreeing_emitters (void)
{
  assert_first_line (VELOCITY_CHAIN "min-agreeing-emitters=9 ! fakesink",
      "velocityest: min-agreeing-emitters is 9, but only 8 emitters enter "
      "the product (emitters=0: all of the set-up's)");
  assert_first_line (VELOCITY_CHAIN "emitters=4 min-agreeing-emitters=5 ! "
      "fakesink", "velocityest: min-agreeing-emitters is 5, but only 4 "
      "emitters enter the product (emitters=4)");
  /* The default (5) is lowered to the emitters there are, as before. */
  assert_first_line (VELOCITY_CHAIN "emitters=4 ! fakesink", NULL);
  assert_first_line (VELOCITY_CHAIN "min-agreeing-emitters=8 ! fakesink",
      NULL);
}

/* Noise clustered with no merging gives more than the 256 centroids a
 * ping keeps at max-centroids=256: the strongest 256 are kept and one
 * warning says so. */
static void
test_centroids_dropped_warning (void)
{
  GstElement *pipeline = gst_parse_launch ("sonarsrc scene=empty "
      "num-buffers=3 ! dopplerbank velocity-step=0.5 ! mimobeamform "
      "coarse-spacing=0 ! wardcluster stop=distance distance=0 pfa=1 "
      "sidelobe-threshold=-200 max-peaks=4096 max-centroids=256 ! appsink name=sink "
      "sync=false", NULL);
  GstElement *sink = gst_bin_get_by_name (GST_BIN (pipeline), "sink");
  GstBus *bus = gst_element_get_bus (pipeline);
  GstSample *sample;
  GstMessage *msg;
  guint pings = 0, warnings = 0;

  gst_element_set_state (pipeline, GST_STATE_PLAYING);
  while ((sample = gst_app_sink_pull_sample (GST_APP_SINK (sink)))) {
    SonarCentroidsMeta *meta =
        sonar_buffer_get_centroids_meta (gst_sample_get_buffer (sample));
    g_assert_nonnull (meta);
    g_assert_cmpuint (meta->n_centroids, ==, 256);
    gst_sample_unref (sample);
    pings++;
  }
  g_assert_cmpuint (pings, ==, 3);
  while ((msg = gst_bus_pop_filtered (bus, GST_MESSAGE_WARNING |
              GST_MESSAGE_ERROR))) {
    GError *error = NULL;
    g_assert_cmpint (GST_MESSAGE_TYPE (msg), ==, GST_MESSAGE_WARNING);
    gst_message_parse_warning (msg, &error, NULL);
    g_assert_cmpstr (error->message, ==, "wardcluster: ping 0 has more than "
        "256 centroids: only the 256 strongest are kept, on this ping and any "
        "other (a smaller pfa, a higher threshold, or stop=distance with a "
        "larger distance, gives fewer)");
    g_error_free (error);
    gst_message_unref (msg);
    warnings++;
  }
  g_assert_cmpuint (warnings, ==, 1);
  gst_element_set_state (pipeline, GST_STATE_NULL);
  gst_object_unref (bus);
  gst_object_unref (sink);
  gst_object_unref (pipeline);
}

int
main (int argc, char **argv)
{
  sonar_test_init_gst (&argc, &argv);
  g_test_add_func ("/settings/is-live-while-playing",
      test_is_live_while_playing);
  g_test_add_func ("/settings/ready-only-while-playing",
      test_ready_only_while_playing);
  g_test_add_func ("/settings/min-agreeing-emitters",
      test_min_agreeing_emitters);
  g_test_add_func ("/settings/centroids-dropped-warning",
      test_centroids_dropped_warning);
  return g_test_run ();
}
