/* stability-cycles.c: the whole chain on one pipeline object, taken from
 * NULL to PLAYING and back CYCLES times (argument; default 6), for
 * tests/test-valgrind.sh to run under memcheck (or any build under
 * AddressSanitizer). Even cycles run to EOS, odd ones are stopped after
 * the first ping, while the next is being processed. Every cycle must give
 * the same first ping, and the process's threads must not pile up (a
 * leaked worker pool keeps its threads); exits 0 when so, 1 otherwise. */
#include <gst/app/gstappsink.h>
#include <gst/gst.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define LAUNCH "sonarsrc num-buffers=3 max-range=2.0 ! dopplerbank " \
  "velocity-min=-0.3 velocity-max=0.3 velocity-step=0.05 ! mimobeamform " \
  "azimuth-count=31 range-max=2.0 threads=2 ! wardcluster ! velocityest " \
  "threads=2 ! appsink name=sink sync=false"

/* Threads of this process (/proc/self/status), or 0 if unknown. */
static guint
thread_count (void)
{
  char line[256];
  guint threads = 0;
  FILE *f = fopen ("/proc/self/status", "r");

  while (f && fgets (line, sizeof (line), f))
    if (sscanf (line, "Threads: %u", &threads) == 1)
      break;
  if (f)
    fclose (f);
  return threads;
}

static char *
sample_text (GstSample * sample)
{
  GstBuffer *buffer = gst_sample_get_buffer (sample);
  GstMapInfo map;
  char *text;

  gst_buffer_map (buffer, &map, GST_MAP_READ);
  text = g_strndup ((const char *) map.data, map.size);
  gst_buffer_unmap (buffer, &map);
  return text;
}

int
main (int argc, char **argv)
{
  const guint cycles = argc > 1 ? (guint) atoi (argv[1]) : 6;
  GError *error = NULL;
  GstElement *pipeline, *sink;
  GstBus *bus;
  char *first = NULL;
  int status = 0;
  guint threads = 0, threads_0 = 0;

  gst_init (&argc, &argv);
  pipeline = gst_parse_launch (LAUNCH, &error);
  if (!pipeline || error) {
    g_printerr ("%s\n", error ? error->message : "no pipeline");
    return 1;
  }
  sink = gst_bin_get_by_name (GST_BIN (pipeline), "sink");
  bus = gst_element_get_bus (pipeline);

  for (guint c = 0; c < cycles && status == 0; c++) {
    const guint expected = c % 2 == 0 ? 3 : 1;
    GstSample *sample;
    GstMessage *msg;
    guint pings = 0;

    if (gst_element_set_state (pipeline, GST_STATE_PLAYING) ==
        GST_STATE_CHANGE_FAILURE) {
      g_printerr ("cycle %u: cannot go to PLAYING\n", c);
      status = 1;
      break;
    }
    while (pings < expected
        && (sample = gst_app_sink_pull_sample (GST_APP_SINK (sink)))) {
      char *text = sample_text (sample);
      if (pings == 0 && !first) {
        first = text;
      } else {
        if (pings == 0 && strcmp (text, first) != 0) {
          g_printerr ("cycle %u: first ping differs:\n%s%s", c, first, text);
          status = 1;
        }
        g_free (text);
      }
      gst_sample_unref (sample);
      pings++;
    }
    if (pings != expected) {
      g_printerr ("cycle %u: %u pings, expected %u\n", c, pings, expected);
      status = 1;
    }
    if ((msg = gst_bus_pop_filtered (bus, GST_MESSAGE_ERROR))) {
      gst_message_parse_error (msg, &error, NULL);
      g_printerr ("cycle %u: %s\n", c, error->message);
      g_clear_error (&error);
      gst_message_unref (msg);
      status = 1;
    }
    if (gst_element_set_state (pipeline, GST_STATE_NULL) !=
        GST_STATE_CHANGE_SUCCESS) {
      g_printerr ("cycle %u: cannot go back to NULL\n", c);
      status = 1;
    }
    gst_bus_set_flushing (bus, TRUE);
    gst_bus_set_flushing (bus, FALSE);
    threads = thread_count ();
    g_print ("cycle %u: %u ping(s), %u threads in NULL\n", c, pings,
        threads);
    if (c == 0)
      threads_0 = threads;
  }
  /* Streaming threads are pooled (GLib keeps up to 2 idle ones), so the
   * count wavers by one or two; a leaked worker pool adds its threads
   * every cycle. */
  if (threads > threads_0 + 3) {
    g_printerr ("threads grew from %u to %u\n", threads_0, threads);
    status = 1;
  }

  g_free (first);
  gst_object_unref (bus);
  gst_object_unref (sink);
  gst_object_unref (pipeline);
  gst_deinit ();
  return status;
}
