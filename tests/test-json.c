/* test-json.c: the JSON reader every file loader shares (scene, geometry,
 * waveforms): what it refuses before json-glib parses, and how. */
#include <errno.h>
#include <fcntl.h>
#include <gio/gio.h>
#include <glib/gstdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "sonar-error.h"
#include "sonar-json.h"
#include "sonar-scene.h"
#include "sonar-setup.h"
#include "sonar-test-gst.h"

/* Loads @path as a scene, a geometry and a waveforms file: each must fail
 * with exactly @expected (where "@" stands for the path). */
static void
assert_every_loader_fails (const char *path, const char *expected)
{
  g_autoptr (GString) message = g_string_new (expected);
  SonarScene scene = { 0 };
  SonarGeometry geometry = { 0 };
  guint n, length;
  double rate, low, high;
  GError *error = NULL;

  g_string_replace (message, "@", path, 0);
  g_assert_false (sonar_scene_load_file (&scene, path, &error));
  g_assert_cmpstr (error->message, ==, message->str);
  g_clear_error (&error);
  g_assert_false (sonar_geometry_load_file (&geometry, path, &error));
  g_assert_cmpstr (error->message, ==, message->str);
  g_clear_error (&error);
  g_assert_null (sonar_waveforms_load_file (path, &n, &length, &rate, &low,
          &high, &error));
  g_assert_cmpstr (error->message, ==, message->str);
  g_clear_error (&error);
}

/* /dev/zero never ends and a FIFO with no writer blocks: both are refused
 * at once, before a byte is read. */
static void
test_not_a_regular_file (void)
{
  g_autofree char *dir = g_dir_make_tmp ("sonar-json-XXXXXX", NULL);
  g_autofree char *fifo = g_build_filename (dir, "scene.json", NULL);
  const char *expected = "@: not a regular file (devices, FIFOs and "
      "directories are not read)";
  g_autofree char *message = NULL;

  g_assert_cmpint (mkfifo (fifo, 0600), ==, 0);
  assert_every_loader_fails ("/dev/zero", expected);
  assert_every_loader_fails (fifo, expected);
  assert_every_loader_fails (dir, expected);
  g_unlink (fifo);
  g_rmdir (dir);

  message = sonar_test_run_pipeline ("sonarsrc scene-file=/dev/zero "
      "num-buffers=1 ! fakesink");
  g_assert_nonnull (message);
  g_assert_true (g_str_has_prefix (message, "/dev/zero: not a regular file"));
}

static void
test_missing_file (void)
{
  GError *error = NULL;
  SonarScene scene = { 0 };

  g_assert_false (sonar_scene_load_file (&scene, "/nonexistent/s.json",
          &error));
  g_assert_error (error, SONAR_ERROR, SONAR_ERROR_FILE);
  g_assert_cmpstr (error->message, ==,
      "/nonexistent/s.json: cannot open: No such file or directory");
  g_error_free (error);
}

/* The size is checked on the file's metadata: a sparse file one byte over
 * the limit costs no disk and is never read. */
static void
test_file_too_large (void)
{
  g_autofree char *path = sonar_test_write_temp ("large.json", "{}");
  g_autofree char *expected = g_strdup_printf ("@: %u bytes, larger than "
      "the 256 MiB allowed for a JSON file", SONAR_JSON_MAX_FILE_SIZE + 1);
  int fd = open (path, O_WRONLY);

  g_assert_cmpint (fd, >=, 0);
  g_assert_cmpint (ftruncate (fd, SONAR_JSON_MAX_FILE_SIZE + 1), ==, 0);
  close (fd);
  assert_every_loader_fails (path, expected);
}

static char *
nested (const char *open, const char *inner, const char *close, guint depth)
{
  GString *text = g_string_new (NULL);

  for (guint i = 0; i < depth; i++)
    g_string_append (text, open);
  g_string_append (text, inner);
  for (guint i = 0; i < depth; i++)
    g_string_append (text, close);
  return g_string_free (text, FALSE);
}

/* 100,000 levels overflowed the stack inside json-glib's parser. */
static void
test_nesting_depth (void)
{
  g_autofree char *arrays = nested ("[", "", "]", 100000);
  g_autofree char *objects = nested ("{\"a\": ", "1", "}", 100000);
  g_autofree char *deepest_allowed = nested ("[", "", "]",
      SONAR_JSON_MAX_DEPTH - 1);
  g_autofree char *allowed = g_strdup_printf ("{\"a\": %s}", deepest_allowed);
  g_autofree char *arrays_path = sonar_test_write_temp ("deep.json", arrays);
  g_autofree char *objects_path = sonar_test_write_temp ("deep.json",
      objects);
  JsonObject *root;
  GError *error = NULL;
  JsonNode *node;

  assert_every_loader_fails (arrays_path, "@: line 1, column 65: nested "
      "deeper than 64 arrays and objects");
  assert_every_loader_fails (objects_path, "@: line 1, column 385: nested "
      "deeper than 64 arrays and objects");

  node = sonar_json_parse (NULL, allowed, "allowed", &root, &error);
  g_assert_no_error (error);
  g_assert_nonnull (node);
  json_node_unref (node);
}

/* json-glib keeps the last of repeated members without a word. */
static void
test_repeated_member (void)
{
  const struct
  {
    const char *json, *expected;
  } cases[] = {
    {"{\"dimensions\": 2, \"dimensions\": 3, \"reflectors\": []}",
        "t: member \"dimensions\" appears twice in one object"},
    {"{\"reflectors\": [{\"position\": [0, 0, 1], \"strength\": 1, "
          "\"strength\": 2}]}",
        "t: member \"strength\" appears twice in one object"},
    /* The same name spelt with an escape is the same member. */
    {"{\"reflectors\": [{\"position\": [0, 0, 1], \"str\\u0065ngth\": 1, "
          "\"strength\": 2}]}",
        "t: member \"strength\" appears twice in one object"},
  };

  for (guint i = 0; i < G_N_ELEMENTS (cases); i++) {
    SonarScene scene = { 0 };
    GError *error = NULL;

    g_assert_false (sonar_scene_load_data (&scene, cases[i].json, "t",
            &error));
    g_assert_cmpstr (error->message, ==, cases[i].expected);
    g_error_free (error);
  }
}

/* json-glib reads 18446744073709551617 as -1 and 1e400 as infinity. */
static void
test_number_range (void)
{
  const struct
  {
    const char *json, *expected;
  } cases[] = {
    {"{\"dimensions\": 18446744073709551617, \"reflectors\": []}",
        "t: dimensions: 18446744073709551617 is out of range (integers: "
          "-9223372036854775808 to 9223372036854775807)"},
    {"{\"reflectors\": [{\"range\": 1, \"strength\": -9223372036854775809}]}",
        "t: reflectors[0].strength: -9223372036854775809 is out of range "
          "(integers: -9223372036854775808 to 9223372036854775807)"},
    {"{\"reflectors\": [{\"position\": [0, 0, 1e400]}]}",
        "t: reflectors[0].position[2]: 1e400 is out of range (numbers: "
          "magnitude at most 1.79769e+308)"},
    /* The member's own range, once the number is one. */
    {"{\"dimensions\": 1e300, \"reflectors\": []}",
        "t: \"dimensions\" must be 2 or 3, not 1e+300"},
    {"{\"reflectors\": [{\"range\": 1, \"strength\": 9223372036854775807}]}",
        "t: scene: reflector 0: strength 9.22337e+18 must be in [0, 1e+06]"},
  };

  for (guint i = 0; i < G_N_ELEMENTS (cases); i++) {
    SonarScene scene = { 0 };
    GError *error = NULL;

    g_assert_false (sonar_scene_load_data (&scene, cases[i].json, "t",
            &error));
    g_assert_cmpstr (error->message, ==, cases[i].expected);
    g_error_free (error);
  }
}

/* json-glib accepts comments and single quotes; counting brackets before
 * it parses needs strict JSON. */
static void
test_strict_json (void)
{
  SonarScene scene = { 0 };
  GError *error = NULL;

  g_assert_false (sonar_scene_load_data (&scene,
          "{\"reflectors\": []\n /* [[[ */}", "t", &error));
  g_assert_cmpstr (error->message, ==, "t: line 2, column 2: unexpected "
      "character '/' (strict JSON: no comments, strings in double quotes)");
  g_clear_error (&error);
  g_assert_false (sonar_scene_load_data (&scene, "{'reflectors': []}", "t",
          &error));
  g_assert_cmpstr (error->message, ==, "t: line 1, column 2: unexpected "
      "character ''' (strict JSON: no comments, strings in double quotes)");
  g_clear_error (&error);
}

static void
assert_waveforms_error (const char *json, const char *expected)
{
  g_autofree char *path = sonar_test_write_temp ("wf.json", json);
  g_autoptr (GString) message = g_string_new (expected);
  guint n, length;
  double rate, low, high;
  GError *error = NULL;

  g_string_replace (message, "@", path, 0);
  g_assert_null (sonar_waveforms_load_file (path, &n, &length, &rate, &low,
          &high, &error));
  g_assert_cmpstr (error->message, ==, message->str);
  g_error_free (error);
}

#define SAMPLES_15 "0,0,0,0,0,0,0,0,0,0,0,0,0,0,0"

/* A sample out of range names its range; members of the wrong type are the
 * loader's error, with no Json-CRITICAL first (criticals abort tests). */
static void
test_waveforms_values (void)
{
  assert_waveforms_error ("{\"sample-rate\": 450000, \"waveforms\": [["
      SAMPLES_15 ", 1e300]]}", "@: \"waveforms\"[0][15] is 1e+300, out of "
      "range (allowed: -1e+06 to 1e+06)");
  assert_waveforms_error ("{\"sample-rate\": 450000, \"waveforms\": [["
      SAMPLES_15 ", {}]]}", "@: \"waveforms\"[0][15] must be a finite "
      "number in [-1e+06, 1e+06]");
  for (guint i = 0; i < 3; i++) {
    const char *bands[] = { "[{}, 80000]", "[20000, [80000]]",
      "[\"low\", null]"
    };
    g_autofree char *json = g_strdup_printf ("{\"sample-rate\": 450000, "
        "\"band\": %s, \"waveforms\": [[" SAMPLES_15 ", 1]]}", bands[i]);
    assert_waveforms_error (json, "@: \"band\" must be [low, high] in Hz "
        "with 0 < low < high <= sample-rate / 2");
  }
}

int
main (int argc, char **argv)
{
  sonar_test_init_gst (&argc, &argv);
  g_test_add_func ("/json/not-a-regular-file", test_not_a_regular_file);
  g_test_add_func ("/json/missing-file", test_missing_file);
  g_test_add_func ("/json/file-too-large", test_file_too_large);
  g_test_add_func ("/json/nesting-depth", test_nesting_depth);
  g_test_add_func ("/json/repeated-member", test_repeated_member);
  g_test_add_func ("/json/number-range", test_number_range);
  g_test_add_func ("/json/strict-json", test_strict_json);
  g_test_add_func ("/json/waveforms-values", test_waveforms_values);
  return g_test_run ();
}
