/* test-sonarsrc.c: the sonarsrc element as users compose it. */
#include <gst/app/gstappsink.h>
#include <gst/audio/audio.h>
#include <gst/check/gstharness.h>
#include <glib/gstdio.h>
#include <math.h>
#include <string.h>

#include "sonar-contracts.h"
#include "sonar-error.h"
#include "sonar-test-gst.h"

/* Pulls events until the set-up event; returns its set-up. */
static SonarSetup *
pull_setup (GstHarness * h)
{
  GstEvent *event;
  while ((event = gst_harness_pull_event (h))) {
    if (sonar_event_is_setup (event)) {
      GError *error = NULL;
      SonarSetup *setup = sonar_setup_from_event (event, &error);
      g_assert_no_error (error);
      gst_event_unref (event);
      return setup;
    }
    gst_event_unref (event);
  }
  g_assert_not_reached ();
}

static void
test_caps_buffers_timestamps (void)
{
  GstHarness *h = gst_harness_new_parse ("sonarsrc ping-rate=10");
  g_autoptr (SonarSetup) setup = NULL;
  GstCaps *caps;
  GstStructure *s;
  GstAudioInfo info;
  guint expected_length;
  double max_offset = 0;

  gst_harness_play (h);
  for (guint k = 0; k < 3; k++) {
    GstBuffer *buffer = gst_harness_pull (h);
    if (k == 0) {
      setup = pull_setup (h);
      for (guint j = 0; j < setup->geometry.n_microphones; j++)
        max_offset = MAX (max_offset,
            sonar_vec3_norm (setup->geometry.microphones[j]));
      for (guint n = 0; n < setup->geometry.n_emitters; n++)
        max_offset = MAX (max_offset,
            sonar_vec3_norm (setup->geometry.emitters[n]));
      /* Default window: whole echoes up to 5 m. */
      expected_length = (guint) ceil (2.0 * (5.0 + max_offset) / 343.0
          * 450000.0 + 4000.0);
      g_assert_cmpuint (setup->ping_length, ==, expected_length);
      g_assert_cmpuint (setup->geometry.n_microphones, ==, 32);
      g_assert_cmpuint (setup->geometry.n_emitters, ==, 8);
      g_assert_cmpuint (setup->waveform_length, ==, 4000);
    }
    g_assert_cmpuint (gst_buffer_get_size (buffer), ==,
        sizeof (float) * 32 * setup->ping_length);
    g_assert_cmpuint (GST_BUFFER_PTS (buffer), ==, k * GST_SECOND / 10);
    g_assert_cmpuint (GST_BUFFER_DURATION (buffer), ==,
        gst_util_uint64_scale_round (setup->ping_length, GST_SECOND, 450000));
    g_assert_nonnull (sonar_buffer_get_truth_meta (buffer));
    g_assert_cmpuint (sonar_buffer_get_truth_meta (buffer)->ping_index, ==,
        k);
    g_assert_cmpuint (sonar_buffer_get_truth_meta (buffer)->n_truths, ==, 3);
    gst_buffer_unref (buffer);
  }

  caps = gst_pad_get_current_caps (h->sinkpad);
  s = gst_caps_get_structure (caps, 0);
  g_assert_true (gst_audio_info_from_caps (&info, caps));
  g_assert_cmpint (GST_AUDIO_INFO_RATE (&info), ==, 450000);
  g_assert_cmpint (GST_AUDIO_INFO_CHANNELS (&info), ==, 32);
  g_assert_cmpint (GST_AUDIO_INFO_FORMAT (&info), ==, GST_AUDIO_FORMAT_F32LE);
  g_assert_cmpint (GST_AUDIO_INFO_LAYOUT (&info), ==,
      GST_AUDIO_LAYOUT_INTERLEAVED);
  {
    guint64 mask = 1;
    g_assert_true (gst_structure_get (s, "channel-mask", GST_TYPE_BITMASK,
            &mask, NULL));
    g_assert_cmpuint (mask, ==, 0);
  }
  gst_caps_unref (caps);
  gst_harness_teardown (h);
}

/* The interleaved buffer is the simulator's render of the ping, channel j
 * being microphone j, and the truth meta is the scene's truth. */
static void
test_data_is_simulation (void)
{
  g_autofree char *scene_path = sonar_test_write_temp ("one.json",
      "{\"reflectors\": [{\"range\": 1.5, \"azimuth\": 20,"
      " \"radial-velocity\": -2}]}");
  g_autofree char *launch = g_strdup_printf ("sonarsrc scene-file=%s "
      "noise-amplitude=0.003 noise-seed=5", scene_path);
  GstHarness *h = gst_harness_new_parse (launch);
  g_autoptr (SonarSetup) setup = NULL;
  GstBuffer *buffer;
  SonarTruthMeta *meta;
  SonarScene scene;
  SonarSimulatorParams params;
  SonarSimulator *sim;
  SonarTruth truth;
  float *planar;
  GstMapInfo map;
  const float *out;
  guint length;

  gst_harness_play (h);
  gst_harness_pull (h);         /* ping 0 */
  setup = pull_setup (h);
  buffer = gst_harness_pull (h);        /* ping 1 at t = 1/12 s */
  length = setup->ping_length;
  meta = sonar_buffer_get_truth_meta (buffer);
  g_assert_cmpuint (meta->n_truths, ==, 1);
  /* Truth: range grows from 1.5 m at -2 m/s, at the reflection instant. */
  g_assert_cmpfloat (fabs (meta->truths[0].range - (1.5 - 2.0 / 12.0)), <,
      0.02);
  g_assert_cmpfloat (fabs (meta->truths[0].azimuth - 20.0), <, 0.01);
  g_assert_cmpfloat (fabs (meta->truths[0].radial_velocity + 2.0), <, 1e-6);

  g_assert_true (sonar_scene_load_file (&scene, scene_path, NULL));
  sonar_simulator_params_init_default (&params);
  params.noise_amplitude = 0.003;
  params.seed = 5;
  sim = sonar_simulator_new (setup, &params, NULL);
  planar = g_new (float, 32 * (gsize) length);
  sonar_simulator_render (sim, &scene, 1, 1.0 / 12.0, planar, &truth);
  g_assert_cmpmem (&truth, sizeof truth, &meta->truths[0], sizeof truth);

  gst_buffer_map (buffer, &map, GST_MAP_READ);
  out = (const float *) map.data;
  for (guint j = 0; j < 32; j++)
    for (guint i = 0; i < length; i++)
      if (out[(gsize) i * 32 + j] != planar[(gsize) j * length + i])
        g_error ("sample %u of channel %u differs", i, j);
  gst_buffer_unmap (buffer, &map);
  gst_buffer_unref (buffer);
  g_free (planar);
  sonar_simulator_free (sim);
  sonar_scene_clear (&scene);
  gst_harness_teardown (h);
}

static SonarSetup *
appsink_setup (GstElement * pipeline, const char *name)
{
  GstElement *sink = gst_bin_get_by_name (GST_BIN (pipeline), name);
  GstPad *pad = gst_element_get_static_pad (sink, "sink");
  GstEvent *event = gst_pad_get_sticky_event (pad,
      GST_EVENT_CUSTOM_DOWNSTREAM_STICKY, 0);
  SonarSetup *setup;

  g_assert_nonnull (event);
  g_assert_true (sonar_event_is_setup (event));
  setup = sonar_setup_from_event (event, NULL);
  gst_event_unref (event);
  gst_object_unref (pad);
  gst_object_unref (sink);
  return setup;
}

/* The set-up survives tee and queue; so does the truth meta, even through
 * a transform (audioconvert) on one branch. */
static void
test_setup_through_tee_queue (void)
{
  GstElement *pipeline = gst_parse_launch ("sonarsrc scene=fig9 ! tee name=t "
      "t. ! queue ! appsink name=a t. ! queue ! audioconvert ! appsink name=b",
      NULL);
  GstElement *sink = gst_bin_get_by_name (GST_BIN (pipeline), "b");
  g_autoptr (SonarSetup) a = NULL;
  g_autoptr (SonarSetup) b = NULL;
  GstSample *sample;
  SonarTruthMeta *meta;

  /* Prerolled, each sink holds its first ping and its sticky events. */
  g_assert_cmpint (gst_element_set_state (pipeline, GST_STATE_PAUSED), ==,
      GST_STATE_CHANGE_ASYNC);
  g_assert_cmpint (gst_element_get_state (pipeline, NULL, NULL,
          60 * GST_SECOND), ==, GST_STATE_CHANGE_SUCCESS);
  a = appsink_setup (pipeline, "a");
  b = appsink_setup (pipeline, "b");
  g_assert_true (sonar_setup_equal (a, b));
  g_assert_cmpuint (a->geometry.n_emitters, ==, 8);

  sample = gst_app_sink_try_pull_preroll (GST_APP_SINK (sink), GST_SECOND);
  g_assert_nonnull (sample);
  meta = sonar_buffer_get_truth_meta (gst_sample_get_buffer (sample));
  g_assert_nonnull (meta);
  g_assert_cmpuint (meta->n_truths, ==, 6);
  gst_sample_unref (sample);

  gst_element_set_state (pipeline, GST_STATE_NULL);
  gst_object_unref (sink);
  gst_object_unref (pipeline);
}

static GByteArray *
collect_samples (const char *launch)
{
  GstElement *pipeline = gst_parse_launch (launch, NULL);
  GstElement *sink = gst_bin_get_by_name (GST_BIN (pipeline), "sink");
  GByteArray *data = g_byte_array_new ();
  GstSample *sample;

  gst_element_set_state (pipeline, GST_STATE_PLAYING);
  while ((sample = gst_app_sink_pull_sample (GST_APP_SINK (sink)))) {
    GstMapInfo map;
    gst_buffer_map (gst_sample_get_buffer (sample), &map, GST_MAP_READ);
    g_byte_array_append (data, map.data, map.size);
    gst_buffer_unmap (gst_sample_get_buffer (sample), &map);
    gst_sample_unref (sample);
  }
  gst_element_set_state (pipeline, GST_STATE_NULL);
  gst_object_unref (sink);
  gst_object_unref (pipeline);
  return data;
}

/* wavenc ! filesink saves pings bit for bit; wavparse reads them back. */
static void
test_wav_round_trip (void)
{
  g_autofree char *dir = g_dir_make_tmp ("sonar-wav-XXXXXX", NULL);
  g_autofree char *wav = g_build_filename (dir, "pings.wav", NULL);
  g_autofree char *save = g_strdup_printf ("sonarsrc num-buffers=2 "
      "scene=fig10 ! wavenc ! filesink location=%s", wav);
  g_autofree char *error = sonar_test_run_pipeline (save);
  g_autofree char *load = g_strdup_printf ("filesrc location=%s ! wavparse "
      "! appsink name=sink sync=false", wav);
  GByteArray *direct = collect_samples ("sonarsrc num-buffers=2 scene=fig10 "
      "! appsink name=sink sync=false");
  GByteArray *loaded;

  g_assert_null (error);
  loaded = collect_samples (load);
  g_assert_cmpuint (direct->len, >, 0);
  g_assert_cmpmem (loaded->data, loaded->len, direct->data, direct->len);
  g_byte_array_unref (direct);
  g_byte_array_unref (loaded);
  g_unlink (wav);
  g_rmdir (dir);
}

/* Every bad setting ends in an error that says what is wrong. */
static void
test_errors_are_clear (void)
{
  g_autofree char *bad_scene = sonar_test_write_temp ("bad.json",
      "{\"reflectors\": [{\"range\": 1, \"azimut\": 3}]}");
  g_autofree char *bad_waves = sonar_test_write_temp ("w.json",
      "{\"sample-rate\": 450000, \"waveforms\": [[0,1,0,1,0,1,0,1,0,1,0,1,0,"
      "1,0,1]]}");
  const struct
  {
    char *launch;
    const char *expected;
  } cases[] = {
    {g_strdup ("sonarsrc scene-file=/nonexistent/scene.json ! fakesink"),
        "/nonexistent/scene.json"},
    {g_strdup_printf ("sonarsrc scene-file=%s ! fakesink", bad_scene),
        "unknown member \"azimut\""},
    {g_strdup ("sonarsrc geometry-file=/nonexistent/array.json ! fakesink"),
        "/nonexistent/array.json"},
    {g_strdup_printf ("sonarsrc waveforms-file=%s ! fakesink", bad_waves),
        "holds 1 waveforms at 450000 Hz, but the sensor has 8 emitters"},
    {g_strdup ("sonarsrc ping-rate=100 ! fakesink"),
        "ping-rate 100 Hz is too fast for max-range 5 m"},
    {g_strdup ("sonarsrc band-high=300000 ! fakesink"), "band_high"},
    {g_strdup ("sonarsrc waveform-length=1048576 ! fakesink"), "ping-rate "
        "12 Hz is too fast for max-range 5 m with waveforms of 1048576 "
        "samples: the 2359.6 ms recording window (the echoes out to "
        "max-range, and a waveform of 2330.2 ms) is longer than the 83.3 ms "
        "between pings"},
    {g_strdup ("sonarsrc ! audio/x-raw,channels=2 ! fakesink"),
        "Downstream does not accept the sonar recording format: 32 channels"},
    {g_strdup ("sonarsrc ! audio/x-raw,rate=48000 ! fakesink"),
        "at 450000 Hz"},
  };
  for (guint i = 0; i < G_N_ELEMENTS (cases); i++) {
    g_autofree char *error = sonar_test_run_pipeline (cases[i].launch);
    g_test_message ("%s -> %s", cases[i].launch, error);
    g_assert_nonnull (error);
    g_assert_nonnull (strstr (error, cases[i].expected));
    g_free (cases[i].launch);
  }
  /* The properties' own limits run (1e6 was refused as out of range). */
  {
    g_autofree char *error = sonar_test_run_pipeline ("sonarsrc "
        "num-buffers=1 direct-path=1000000 noise-amplitude=1000 ! fakesink");
    g_assert_null (error);
  }
}

/* The core's errors reach the bus with their own domain and code
 * (SONAR_ERROR, sonar-error.h): an application tells a bad setting from
 * a bad file or a missing one without reading the message. */
static void
test_error_codes (void)
{
  g_autofree char *bad_scene = sonar_test_write_temp ("bad.json",
      "{\"reflectors\": [{\"range\": 1, \"azimut\": 3}]}");
  g_autofree char *launch = g_strdup_printf ("sonarsrc scene-file=%s ! "
      "fakesink", bad_scene);
  SonarTestRun *run;

  run = sonar_test_run ("sonarsrc ping-rate=100 ! fakesink");
  g_assert_error (run->error, SONAR_ERROR, SONAR_ERROR_SETTINGS);
  g_assert_nonnull (strstr (run->error->message,
          "ping-rate 100 Hz is too fast"));
  sonar_test_run_free (run);
  run = sonar_test_run (launch);
  g_assert_error (run->error, SONAR_ERROR, SONAR_ERROR_FORMAT);
  g_assert_nonnull (strstr (run->error->message,
          "unknown member \"azimut\""));
  sonar_test_run_free (run);
  run = sonar_test_run ("sonarsrc scene-file=/nonexistent/scene.json ! "
      "fakesink");
  g_assert_error (run->error, SONAR_ERROR, SONAR_ERROR_FILE);
  sonar_test_run_free (run);
}

static void
test_truth_messages (void)
{
  GstElement *pipeline = gst_parse_launch ("sonarsrc num-buffers=3 "
      "scene=fig10 ! fakesink", NULL);
  GstBus *bus = gst_element_get_bus (pipeline);
  GstMessage *msg;
  guint64 expected_ping = 0;

  gst_element_set_state (pipeline, GST_STATE_PLAYING);
  while ((msg = gst_bus_timed_pop_filtered (bus, 60 * GST_SECOND,
              GST_MESSAGE_ELEMENT | GST_MESSAGE_EOS | GST_MESSAGE_ERROR))) {
    const GstStructure *s = gst_message_get_structure (msg);
    if (GST_MESSAGE_TYPE (msg) != GST_MESSAGE_ELEMENT) {
      g_assert_cmpint (GST_MESSAGE_TYPE (msg), ==, GST_MESSAGE_EOS);
      gst_message_unref (msg);
      break;
    }
    if (gst_structure_has_name (s, SONAR_TRUTH_MESSAGE_NAME)) {
      guint64 ping;
      const GValue *reflectors = gst_structure_get_value (s, "reflectors");
      const GstStructure *first;
      double rv, az;
      g_assert_true (gst_structure_get_uint64 (s, "ping", &ping));
      g_assert_cmpuint (ping, ==, expected_ping);
      expected_ping++;
      g_assert_cmpuint (gst_value_array_get_size (reflectors), ==, 6);
      first = gst_value_get_structure (gst_value_array_get_value (reflectors,
              0));
      g_assert_true (gst_structure_get_double (first, "radial_velocity", &rv));
      g_assert_true (gst_structure_get_double (first, "azimuth", &az));
      /* Still object, sensor driving forward at 0.3 m/s. */
      g_assert_cmpfloat (fabs (rv + 0.3 * cos (az * M_PI / 180.0)), <, 0.01);
    }
    gst_message_unref (msg);
  }
  g_assert_cmpuint (expected_ping, ==, 3);
  gst_element_set_state (pipeline, GST_STATE_NULL);
  gst_object_unref (bus);
  gst_object_unref (pipeline);
}

/* is-live paces pings like the real sensor: 4 pings at 20 Hz take at least
 * three periods of wall time. */
static void
test_live_pacing (void)
{
  gint64 start = g_get_monotonic_time ();
  g_autofree char *error = sonar_test_run_pipeline ("sonarsrc is-live=true "
      "ping-rate=20 num-buffers=4 scene=empty ! fakesink sync=true");
  double elapsed = (g_get_monotonic_time () - start) / 1e6;

  g_assert_null (error);
  g_test_message ("4 live pings at 20 Hz took %.3f s", elapsed);
  g_assert_cmpfloat (elapsed, >=, 0.15);
}

/* A scene at the extremes renders finite pings. */
static void
test_extreme_scene (void)
{
  g_autofree char *path = sonar_test_write_temp ("x.json",
      "{\"reflectors\": ["
      " {\"range\": 0.1, \"azimuth\": 0},"
      " {\"range\": 20, \"azimuth\": 0},"
      " {\"range\": 1, \"azimuth\": 90, \"radial-velocity\": 10},"
      " {\"range\": 1, \"azimuth\": -90, \"radial-velocity\": -10},"
      " {\"range\": 2, \"elevation\": 90},"
      " {\"range\": 2.0, \"azimuth\": 1, \"strength\": 1000000},"
      " {\"range\": 2.001, \"azimuth\": 1}]}");
  g_autofree char *launch = g_strdup_printf ("sonarsrc scene-file=%s clip=true",
      path);
  GstHarness *h = gst_harness_new_parse (launch);
  GstBuffer *buffer;
  GstMapInfo map;
  const float *out;
  double energy = 0;

  gst_harness_play (h);
  buffer = gst_harness_pull (h);
  gst_buffer_map (buffer, &map, GST_MAP_READ);
  out = (const float *) map.data;
  for (gsize i = 0; i < map.size / sizeof (float); i++) {
    g_assert_true (isfinite (out[i]));
    g_assert_cmpfloat (fabs (out[i]), <=, 1.0f);
    energy += out[i] * out[i];
  }
  g_assert_cmpfloat (energy, >, 0.0);
  gst_buffer_unmap (buffer, &map);
  gst_buffer_unref (buffer);
  gst_harness_teardown (h);
}

int
main (int argc, char **argv)
{
  sonar_test_init_gst (&argc, &argv);
  g_test_add_func ("/sonarsrc/caps-buffers-timestamps",
      test_caps_buffers_timestamps);
  g_test_add_func ("/sonarsrc/data-is-simulation", test_data_is_simulation);
  g_test_add_func ("/sonarsrc/setup-through-tee-queue",
      test_setup_through_tee_queue);
  g_test_add_func ("/sonarsrc/wav-round-trip", test_wav_round_trip);
  g_test_add_func ("/sonarsrc/errors-are-clear", test_errors_are_clear);
  g_test_add_func ("/sonarsrc/error-codes", test_error_codes);
  g_test_add_func ("/sonarsrc/truth-messages", test_truth_messages);
  g_test_add_func ("/sonarsrc/live-pacing", test_live_pacing);
  g_test_add_func ("/sonarsrc/extreme-scene", test_extreme_scene);
  return g_test_run ();
}
