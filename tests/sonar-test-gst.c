/* sonar-test-gst.c: see sonar-test-gst.h. */
#include "sonar-test-gst.h"

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

