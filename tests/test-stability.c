/* test-stability.c: the whole chain at the edges of its range and over
 * time: state changes, long runs (memory stays flat), extreme scenes and
 * amplitudes. SONAR_LONG_RUN=1 runs the 10,000 pings. */
#include <gst/app/gstappsink.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "sonar-contracts.h"
#include "sonar-test-util.h"

/* A light chain: small bank, 31 directions, 2 m. */
#define CHAIN "dopplerbank velocity-min=-0.5 velocity-max=0.5 velocity-step=0.05 " \
  "! mimobeamform azimuth-count=31 range-max=2.0 ! wardcluster ! velocityest"

/* Resident memory of this process, in MB. */
static double
resident_mb (void)
{
  long pages = 0, resident = 0;
  FILE *f = fopen ("/proc/self/statm", "r");

  if (f) {
    if (fscanf (f, "%ld %ld", &pages, &resident) != 2)
      resident = 0;
    fclose (f);
  }
  return resident * (double) sysconf (_SC_PAGESIZE) / (1024.0 * 1024.0);
}

/* NULL -> PLAYING -> EOS -> NULL, 100 times on one pipeline object: every
 * run gives the same detections and memory does not grow. */
static void
test_state_changes (void)
{
  GstElement *pipeline = gst_parse_launch ("sonarsrc num-buffers=1 "
      "max-range=2.0 ! " CHAIN " ! appsink name=sink sync=false", NULL);
  GstElement *sink = gst_bin_get_by_name (GST_BIN (pipeline), "sink");
  g_autofree char *first = NULL;
  double mb_10 = 0.0;

  for (guint run = 0; run < 100; run++) {
    GstSample *sample;
    GstMapInfo map;
    g_autofree char *json = NULL;

    gst_element_set_state (pipeline, GST_STATE_PLAYING);
    sample = gst_app_sink_pull_sample (GST_APP_SINK (sink));
    g_assert_nonnull (sample);
    gst_buffer_map (gst_sample_get_buffer (sample), &map, GST_MAP_READ);
    json = g_strndup ((const char *) map.data, map.size);
    gst_buffer_unmap (gst_sample_get_buffer (sample), &map);
    gst_sample_unref (sample);
    gst_element_set_state (pipeline, GST_STATE_NULL);
    if (!first)
      first = g_strdup (json);
    g_assert_cmpstr (json, ==, first);
    if (run == 9)
      mb_10 = resident_mb ();
  }
  g_test_message ("resident memory after 10 runs %.1f MB, after 100 %.1f MB",
      mb_10, resident_mb ());
  g_assert_cmpfloat (resident_mb () - mb_10, <, 8.0);
  gst_object_unref (sink);
  gst_object_unref (pipeline);
}

/* Many pings: memory stays flat once the pools are warm. */
static void
test_long_run (void)
{
  const guint pings = g_getenv ("SONAR_LONG_RUN") ? 10000 : 300;
  g_autofree char *launch = g_strdup_printf ("sonarsrc num-buffers=%u "
      "max-range=2.0 ping-rate=25 ! " CHAIN " ! appsink name=sink "
      "sync=false", pings);
  GstElement *pipeline = gst_parse_launch (launch, NULL);
  GstElement *sink = gst_bin_get_by_name (GST_BIN (pipeline), "sink");
  GstSample *sample;
  guint count = 0;
  double mb_warm = 0.0;

  gst_element_set_state (pipeline, GST_STATE_PLAYING);
  while ((sample = gst_app_sink_pull_sample (GST_APP_SINK (sink)))) {
    SonarDetectionsMeta *meta =
        sonar_buffer_get_detections_meta (gst_sample_get_buffer (sample));
    g_assert_nonnull (meta);
    g_assert_cmpuint (meta->ping_index, ==, count);
    gst_sample_unref (sample);
    if (++count == 50)
      mb_warm = resident_mb ();
  }
  g_test_message ("%u pings: resident memory %.1f MB after 50, %.1f MB at "
      "the end", count, mb_warm, resident_mb ());
  g_assert_cmpuint (count, ==, pings);
  g_assert_cmpfloat (resident_mb () - mb_warm, <, 8.0);
  gst_element_set_state (pipeline, GST_STATE_NULL);
  gst_object_unref (sink);
  gst_object_unref (pipeline);
}

/* Runs the chain on one ping of @scene_json (extra sonarsrc properties in
 * @src) and returns its detections meta's copy; n in *n. */
static SonarDetection *
detect (const char *scene_json, const char *src, guint * n)
{
  g_autofree char *scene = sonar_test_write_temp ("scene.json", scene_json);
  g_autofree char *launch = g_strdup_printf ("sonarsrc scene-file=%s "
      "num-buffers=1 %s ! " CHAIN " ! appsink name=sink sync=false", scene,
      src);
  GstElement *pipeline = gst_parse_launch (launch, NULL);
  GstElement *sink = gst_bin_get_by_name (GST_BIN (pipeline), "sink");
  GstSample *sample;
  SonarDetectionsMeta *meta;
  SonarDetection *out;

  gst_element_set_state (pipeline, GST_STATE_PLAYING);
  sample = gst_app_sink_pull_sample (GST_APP_SINK (sink));
  g_assert_nonnull (sample);
  meta = sonar_buffer_get_detections_meta (gst_sample_get_buffer (sample));
  *n = meta->n_detections;
  out = g_memdup2 (meta->detections, sizeof (SonarDetection) * *n);
  for (guint d = 0; d < *n; d++) {
    g_assert_true (isfinite (out[d].range));
    g_assert_true (isfinite (out[d].radial_velocity));
    g_test_message ("  %.3f m %+.1f deg %+.4f m/s%s", out[d].range,
        out[d].azimuth, out[d].radial_velocity, out[d].out_of_range ?
        " (out of range)" : "");
  }
  gst_sample_unref (sample);
  gst_element_set_state (pipeline, GST_STATE_NULL);
  gst_object_unref (sink);
  gst_object_unref (pipeline);
  return out;
}

/* A reflector at 0.1 m echoes while the emitters still send and, 47 dB
 * stronger than one at 1.5 m, drowns the image under wardcluster's
 * relative threshold (the near-far limit of tests/test-velocityest.c): the
 * chain must stay finite and invent nothing. */
static void
test_blind_zone (void)
{
  guint n;
  g_autofree SonarDetection *d = detect ("{\"dimensions\": 2, "
      "\"reflectors\": [{\"range\": 0.1, \"azimuth\": 0},"
      " {\"range\": 0.1, \"azimuth\": 60, \"radial-velocity\": -7},"
      " {\"range\": 1.5, \"azimuth\": 24, \"radial-velocity\": -0.25}]}",
      "", &n);

  for (guint i = 0; i < n; i++) {
    g_assert_cmpfloat (d[i].range, <=, 2.0);
    /* Only the true object, if anything, and at its speed. */
    g_assert_cmpfloat (fabs (d[i].range - 1.5), <, 0.05);
    g_assert_cmpfloat (fabs (d[i].radial_velocity + 0.25), <, 0.02);
  }
}

/* Beyond the window and at +-90 degrees: no crash, no invented object; the
 * normal reflector is found with its speed. It sits on the 6-degree grid
 * of CHAIN: 2 degrees off it, the 2.3-degree MIMO beam samples 6-9 dB
 * down, at the edge of wardcluster's -10 dB threshold. */
static void
test_edges (void)
{
  guint n;
  g_autofree SonarDetection *d = detect ("{\"dimensions\": 2, "
      "\"reflectors\": ["
      " {\"range\": 6.0, \"azimuth\": 10, \"radial-velocity\": -2},"
      " {\"range\": 1.0, \"azimuth\": 90},"
      " {\"range\": 1.2, \"azimuth\": -90, \"radial-velocity\": 0.3},"
      " {\"range\": 1.5, \"azimuth\": 24, \"radial-velocity\": -0.25}]}",
      "", &n);
  gboolean found = FALSE;

  for (guint i = 0; i < n; i++) {
    g_assert_cmpfloat (d[i].range, <=, 2.0);
    if (fabs (d[i].range - 1.5) < 0.05 && fabs (d[i].azimuth - 24) < 2) {
      g_assert_cmpfloat (fabs (d[i].radial_velocity + 0.25), <, 0.02);
      found = TRUE;
    }
  }
  g_assert_true (found);
}

/* Two reflectors 1 cm apart in range, same speed: reported as one object
 * (or two) at the right speed, never a wrong one. */
static void
test_two_reflectors_one_cm (void)
{
  guint n;
  g_autofree SonarDetection *d = detect ("{\"dimensions\": 2, "
      "\"reflectors\": [{\"range\": 1.2, \"azimuth\": -15, "
      "\"radial-velocity\": 0.2}, {\"range\": 1.21, \"azimuth\": -15, "
      "\"radial-velocity\": 0.2}]}", "", &n);

  g_assert_cmpuint (n, >=, 1);
  for (guint i = 0; i < n; i++)
    g_assert_cmpfloat (fabs (d[i].radial_velocity - 0.2), <, 0.02);
}

/* Huge and tiny amplitudes, and full-scale clipping: the same answer (or,
 * clipped, a finite one) at the same place. */
static void
test_amplitudes (void)
{
  const char *scene_format = "{\"dimensions\": 2, \"reflectors\": ["
      "{\"range\": 1.0, \"azimuth\": 30, \"radial-velocity\": -0.3, "
      "\"strength\": %g}]}";
  const double strengths[] = { 1.0, 1e-6, 1e4 };
  double reference = NAN;

  for (guint s = 0; s < G_N_ELEMENTS (strengths); s++) {
    g_autofree char *json = g_strdup_printf (scene_format, strengths[s]);
    guint n;
    /* Noise scaled with the echo: the same signal-to-noise ratio. */
    g_autofree char *src = g_strdup_printf ("noise-amplitude=%g",
        0.01 * strengths[s]);
    g_autofree SonarDetection *d = detect (json, src, &n);
    g_test_message ("strength %g: %u detections", strengths[s], n);
    g_assert_cmpuint (n, ==, 1);
    if (isnan (reference))
      reference = d[0].radial_velocity;
    g_assert_cmpfloat (fabs (d[0].radial_velocity - reference), <, 1e-3);
  }
  {
    /* A strong near echo clipped at full scale by the ADC. */
    guint n;
    g_autofree SonarDetection *d = detect ("{\"dimensions\": 2, "
        "\"reflectors\": [{\"range\": 0.5, \"azimuth\": 0, \"strength\": "
        "1000}]}", "clip=true", &n);
    g_test_message ("clipped: %u detections", n);
  }
}

int
main (int argc, char **argv)
{
  sonar_test_init_gst (&argc, &argv);
  g_test_add_func ("/stability/state-changes", test_state_changes);
  g_test_add_func ("/stability/long-run", test_long_run);
  g_test_add_func ("/stability/blind-zone", test_blind_zone);
  g_test_add_func ("/stability/edges", test_edges);
  g_test_add_func ("/stability/two-reflectors-1-cm",
      test_two_reflectors_one_cm);
  g_test_add_func ("/stability/amplitudes", test_amplitudes);
  return g_test_run ();
}
