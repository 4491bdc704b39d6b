/* test-contracts.c: the GStreamer side of the set-up: the sticky event
 * carries every field of it, and a malformed one is named. */
#include <string.h>

#include "sonar-contracts.h"
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
  g_assert_nonnull (strstr (error->message, "missing field \"emitters\""));
  g_clear_error (&error);
  gst_structure_set (broken, "emitters", G_TYPE_BYTES,
      g_bytes_new_static ("abc", 3), NULL);
  g_assert_null (sonar_setup_from_structure (broken, &error));
  g_assert_nonnull (strstr (error->message, "expected 8 positions"));
  g_clear_error (&error);
  gst_structure_free (broken);
  gst_event_unref (event);
}

int
main (int argc, char **argv)
{
  sonar_test_init_gst (&argc, &argv);
  g_test_add_func ("/contracts/setup-event-round-trip",
      test_setup_event_round_trip);
  return g_test_run ();
}
