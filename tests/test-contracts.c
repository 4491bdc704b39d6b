/* test-contracts.c: the GStreamer side of the set-up: the sticky event
 * carries every field of it, and a malformed one is named. */
#include <string.h>

#include "sonar-contracts.h"
#include "sonar-error.h"
#include "sonar-sensor-file.h"
#include <glib/gstdio.h>
#include "sonar-test-gst.h"

static void
test_setup_event_round_trip (void)
{
  g_autoptr (SonarSetup) setup = sonar_test_default_setup (5000);
  GstEvent *event = sonar_setup_event_new (setup);
  GError *error = NULL;
  g_autoptr (SonarSetup) copy = NULL;
  GstStructure *broken;

  g_assert_true (sonar_event_is_setup (event));
  g_assert_true (GST_EVENT_IS_STICKY (event));
  copy = sonar_setup_from_event (event, &error);
  g_assert_no_error (error);
  g_assert_true (sonar_setup_equal (setup, copy));
  g_assert_cmpuint (copy->ping_length, ==, 5000);
  g_assert_cmpfloat (copy->ping_period, ==, setup->ping_period);
  g_assert_cmpint (copy->field_of_view, ==, setup->field_of_view);

  broken = gst_structure_copy (gst_event_get_structure (event));
  gst_structure_remove_field (broken, "emitters");
  g_assert_null (sonar_setup_from_structure (broken, &error));
  g_assert_cmpstr (error->message, ==,
      "sonar-setup event: missing string field \"emitters\"");
  g_clear_error (&error);
  /* "abc" in base64: 3 bytes, not 8 positions of 3 doubles. */
  gst_structure_set (broken, "emitters", G_TYPE_STRING, "YWJj", NULL);
  g_assert_null (sonar_setup_from_structure (broken, &error));
  g_assert_error (error, SONAR_ERROR, SONAR_ERROR_FORMAT);
  g_assert_cmpstr (error->message, ==, "sonar-setup event: \"emitters\" "
      "holds 3 bytes, expected 24 values of 8 bytes");
  g_clear_error (&error);
  gst_structure_free (broken);
  gst_event_unref (event);
}

/* The set-up survives serialisation as text (what GStreamer's data
 * protocol, gdppay, sends across a network) bit for bit, and an event
 * whose type the data protocol cut to 16 bits is still the set-up. */
static void
test_setup_event_serialised (void)
{
  g_autoptr (SonarSetup) setup = sonar_test_default_setup (5000);
  GstEvent *event = sonar_setup_event_new (setup);
  g_autofree char *text = gst_structure_to_string (gst_event_get_structure
      (event));
  GstStructure *parsed = gst_structure_from_string (text, NULL);
  GstEvent *cut, *restored;
  GError *error = NULL;
  g_autoptr (SonarSetup) copy = NULL;

  g_assert_nonnull (parsed);
  copy = sonar_setup_from_structure (parsed, &error);
  g_assert_no_error (error);
  g_assert_true (sonar_setup_equal (setup, copy));
  g_assert_cmpmem (setup->waveforms, sizeof (float) *
      setup->geometry.n_emitters * setup->waveform_length, copy->waveforms,
      sizeof (float) * copy->geometry.n_emitters * copy->waveform_length);

  /* As gdpdepay makes it: the type's lower 16 bits, the same structure. */
  cut = gst_event_new_custom (GST_EVENT_CUSTOM_DOWNSTREAM_STICKY & 0xffff,
      parsed);
  g_assert_cmpint (GST_EVENT_TYPE (cut), !=,
      GST_EVENT_CUSTOM_DOWNSTREAM_STICKY);
  g_assert_true (sonar_event_is_setup (cut));
  restored = sonar_setup_event_restore (cut);
  g_assert_cmpint (GST_EVENT_TYPE (restored), ==,
      GST_EVENT_CUSTOM_DOWNSTREAM_STICKY);
  g_assert_true (gst_structure_is_equal (gst_event_get_structure (restored),
          gst_event_get_structure (event)));
  /* Another event of that cut type is not the set-up. */
  cut = gst_event_new_custom (GST_EVENT_CUSTOM_DOWNSTREAM_STICKY & 0xffff,
      gst_structure_new_empty ("something-else"));
  g_assert_false (sonar_event_is_setup (cut));
  gst_event_unref (cut);
  gst_event_unref (restored);
  gst_event_unref (event);
}

/* A frame id rides in the set-up event (and a sensor file) to whoever
 * reads it; none is the empty string, and a malformed one is refused by
 * name. */
static void
test_frame_id (void)
{
  g_autoptr (SonarSetup) plain = sonar_test_default_setup (5000);
  SonarSetupParams p;
  g_autoptr (SonarSetup) tagged = NULL;
  g_autoptr (SonarSetup) copy = NULL;
  g_autoptr (SonarSetup) loaded = NULL;
  g_autofree char *dir = g_dir_make_tmp ("sonar-frame-XXXXXX", NULL);
  g_autofree char *path = g_build_filename (dir, "sensor.json", NULL);
  GError *error = NULL;
  GstEvent *event;

  g_assert_cmpstr (plain->frame_id, ==, "");
  event = sonar_setup_event_new (plain);
  g_assert_false (gst_structure_has_field (gst_event_get_structure (event),
          "frame-id"));
  gst_event_unref (event);

  sonar_test_setup_params (&p, plain);
  p.frame_id = "sonar_front";
  tagged = sonar_setup_new (&p, &error);
  g_assert_no_error (error);
  g_assert_false (sonar_setup_equal (plain, tagged));
  event = sonar_setup_event_new (tagged);
  copy = sonar_setup_from_event (event, &error);
  g_assert_no_error (error);
  g_assert_cmpstr (copy->frame_id, ==, "sonar_front");
  g_assert_true (sonar_setup_equal (tagged, copy));
  gst_event_unref (event);

  g_assert_true (sonar_sensor_file_save (tagged, path, &error));
  g_assert_no_error (error);
  loaded = sonar_sensor_file_load (path, &error);
  g_assert_no_error (error);
  g_assert_cmpstr (loaded->frame_id, ==, "sonar_front");
  g_unlink (path);
  g_rmdir (dir);

  p.frame_id = "tab\there";
  g_assert_null (sonar_setup_new (&p, &error));
  g_assert_cmpstr (error->message, ==, "frame id \"tab\there\" must be at "
      "most 63 bytes of printable ASCII");
  g_clear_error (&error);
}

int
main (int argc, char **argv)
{
  sonar_test_init_gst (&argc, &argv);
  g_test_add_func ("/contracts/setup-event-round-trip",
      test_setup_event_round_trip);
  g_test_add_func ("/contracts/frame-id", test_frame_id);
  g_test_add_func ("/contracts/setup-event-serialised",
      test_setup_event_serialised);
  return g_test_run ();
}
