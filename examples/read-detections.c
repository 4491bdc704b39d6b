/* read-detections.c: an application reading the sonar's detections from
 * the installed plugin, through the installed contracts library.
 *
 * It runs the chain into an appsink and reads each ping's
 * SonarDetectionsMeta (and sonarsrc's SonarTruthMeta, when the pings come
 * from the simulator) off the buffers:
 *
 *   cc read-detections.c -o read-detections \
 *       $(pkg-config --cflags --libs gstsonarcontracts-1.0 gstreamer-app-1.0)
 *   ./read-detections                  # 3 pings of sonarsrc's default scene
 *   ./read-detections "sonarsrc scene=fig9 num-buffers=2 ! dopplerbank \
 *       ! mimobeamform ! wardcluster ! velocityest"
 *
 * The plugin must be where GStreamer looks: installed under another
 * prefix than GStreamer's, GST_PLUGIN_PATH=<prefix>/<libdir>/gstreamer-1.0.
 */
#include <gst/app/gstappsink.h>
#include <gst/gst.h>
#include <stdio.h>

#include <sonar-contracts.h>

#define DEFAULT_CHAIN "sonarsrc num-buffers=3 ! dopplerbank velocity-min=-1.5 " \
  "velocity-max=1.5 ! mimobeamform ! wardcluster ! velocityest"

/* Prints @msg if it is an error (and takes it): 1 then, else 0. */
static int
report_error (GstMessage * msg)
{
  GError *error = NULL;
  const gboolean is_error = GST_MESSAGE_TYPE (msg) == GST_MESSAGE_ERROR;

  if (is_error) {
    gst_message_parse_error (msg, &error, NULL);
    fprintf (stderr, "read-detections: %s\n", error->message);
    g_error_free (error);
  }
  gst_message_unref (msg);
  return is_error;
}

int
main (int argc, char **argv)
{
  GError *error = NULL;
  GstElement *pipeline, *sink;
  GstSample *sample;
  GstMessage *msg;
  gchar *launch;
  int status = 0;

  gst_init (&argc, &argv);
  launch = g_strdup_printf ("%s ! appsink name=sink sync=false",
      argc > 1 ? argv[1] : DEFAULT_CHAIN);
  pipeline = gst_parse_launch (launch, &error);
  g_free (launch);
  if (!pipeline) {
    fprintf (stderr, "read-detections: %s\n", error->message);
    return 1;
  }
  sink = gst_bin_get_by_name (GST_BIN (pipeline), "sink");
  gst_element_set_state (pipeline, GST_STATE_PLAYING);

  while ((sample = gst_app_sink_pull_sample (GST_APP_SINK (sink)))) {
    GstBuffer *buffer = gst_sample_get_buffer (sample);
    SonarDetectionsMeta *dets = sonar_buffer_get_detections_meta (buffer);
    SonarTruthMeta *truth = sonar_buffer_get_truth_meta (buffer);

    if (!dets) {
      fprintf (stderr, "read-detections: a buffer without detections: the "
          "chain must end in velocityest\n");
      status = 1;
    }
    for (guint k = 0; dets && k < dets->n_detections; k++) {
      const SonarDetection *d = &dets->detections[k];
      printf ("ping %" G_GUINT64_FORMAT " detection: range %.4f m, azimuth "
          "%.2f deg, elevation %.2f deg, x %.4f y %.4f z %.4f m, radial "
          "velocity %+.4f m/s, valid %d, SNR %.1f dB, 1-sigma %.2g m "
          "%.2g deg %.2g m/s, frame \"%s\"\n", dets->ping_index, d->range,
          d->azimuth, d->elevation, d->position.x, d->position.y,
          d->position.z, d->radial_velocity, d->valid, d->snr,
          d->range_sigma, d->azimuth_sigma, d->radial_velocity_sigma,
          d->frame_id);
    }
    for (guint k = 0; truth && k < truth->n_truths; k++) {
      const SonarTruth *t = &truth->truths[k];
      printf ("ping %" G_GUINT64_FORMAT " truth: range %.4f m, azimuth "
          "%.2f deg, elevation %.2f deg, x %.4f y %.4f z %.4f m, radial "
          "velocity %+.4f m/s\n", truth->ping_index, t->range, t->azimuth,
          t->elevation, t->position.x, t->position.y, t->position.z,
          t->radial_velocity);
    }
    gst_sample_unref (sample);
    /* The elements post a few messages every ping (post-messages): taken
     * as they come, or they pile up on the bus. */
    while ((msg = gst_bus_pop (GST_ELEMENT_BUS (pipeline))))
      status |= report_error (msg);
  }
  while ((msg = gst_bus_pop (GST_ELEMENT_BUS (pipeline))))
    status |= report_error (msg);
  gst_element_set_state (pipeline, GST_STATE_NULL);
  gst_object_unref (sink);
  gst_object_unref (pipeline);
  return status;
}
