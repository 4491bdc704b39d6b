/* test-scene.c: presets and scene files. */
#include <gio/gio.h>
#include <string.h>

#include "sonar-scene.h"
#include "sonar-test-util.h"

static double
azimuth_of (SonarVec3 p)
{
  double az, el;
  sonar_vec3_to_direction (p, &az, &el);
  return az;
}

static void
test_presets_valid (void)
{
  guint n;
  const SonarScenePresetInfo *presets = sonar_scene_presets (&n);

  g_assert_cmpuint (n, ==, SONAR_SCENE_PRESET_CROSSING + 1);
  for (guint i = 0; i < n; i++) {
    const SonarScenePreset p = presets[i].preset;
    SonarScene scene;
    GError *error = NULL;
    SonarScenePreset round_trip;

    /* The table is in enum order, each entry described. */
    g_assert_cmpint (p, ==, i);
    g_assert_true (presets[i].nick && presets[i].description);
    sonar_scene_init_preset (&scene, p);
    g_assert_cmpuint (scene.n_reflectors, ==, presets[i].n_objects);
    g_assert_true (sonar_scene_validate (&scene, &error));
    g_assert_no_error (error);
    g_assert_true (sonar_scene_preset_from_string
        (sonar_scene_preset_to_string (p), &round_trip));
    g_assert_cmpint (round_trip, ==, p);
    sonar_scene_clear (&scene);
  }
  {
    SonarScenePreset p;
    g_assert_false (sonar_scene_preset_from_string ("fig11", &p));
  }
}

/* Fig. 9: still sensor, four still objects, two movers of several m/s. */
static void
test_fig9 (void)
{
  SonarScene scene;
  guint still = 0, moving = 0;

  sonar_scene_init_preset (&scene, SONAR_SCENE_PRESET_FIG9);
  g_assert_cmpuint (scene.n_reflectors, ==, 6);
  g_assert_cmpfloat (sonar_vec3_norm (scene.sensor_velocity), ==, 0.0);
  for (guint k = 0; k < scene.n_reflectors; k++) {
    const double speed = sonar_vec3_norm (scene.reflectors[k].velocity);
    if (speed == 0.0)
      still++;
    else {
      g_assert_cmpfloat (speed, >, 1.0);
      moving++;
    }
  }
  g_assert_cmpuint (still, ==, 4);
  g_assert_cmpuint (moving, ==, 2);
  sonar_scene_clear (&scene);
}

/* Fig. 10: the sensor drives at 0.3 m/s past still objects at 0.5-5 m,
 * -80..80 degrees. */
static void
test_fig10 (void)
{
  SonarScene scene;
  double min_az = 0, max_az = 0;

  sonar_scene_init_preset (&scene, SONAR_SCENE_PRESET_FIG10);
  g_assert_cmpfloat (sonar_vec3_norm (scene.sensor_velocity), ==, 0.3);
  for (guint k = 0; k < scene.n_reflectors; k++) {
    const SonarReflector *r = &scene.reflectors[k];
    const double surface = sonar_vec3_norm (r->position) - r->radius;
    const double az = azimuth_of (r->position);
    g_assert_cmpfloat (sonar_vec3_norm (r->velocity), ==, 0.0);
    g_assert_cmpfloat (surface, >=, 0.5 - 1e-9);
    g_assert_cmpfloat (surface, <=, 5.0);
    g_assert_cmpfloat (fabs (az), <=, 80.0);
    min_az = MIN (min_az, az);
    max_az = MAX (max_az, az);
  }
  g_assert_cmpfloat (min_az, <, -60.0);
  g_assert_cmpfloat (max_az, >, 60.0);
  sonar_scene_clear (&scene);
}

static void
test_scene_file (void)
{
  const char *json = "{\"dimensions\": 3,"
      " \"sensor\": {\"position\": [0, 0, 1], \"velocity\": [0, 0, 0.3]},"
      " \"reflectors\": ["
      "  {\"kind\": \"point\", \"position\": [1, 0.5, 2],"
      "   \"velocity\": [0, 0, -1], \"strength\": 2},"
      "  {\"kind\": \"cylinder\", \"range\": 2, \"azimuth\": 90,"
      "   \"radius\": 0.1, \"radial-velocity\": -1.5},"
      "  {\"range\": 1, \"azimuth\": 0, \"elevation\": 30}]}";
  SonarScene scene;
  GError *error = NULL;
  const SonarReflector *r;

  g_assert_true (sonar_scene_load_data (&scene, json, "test", &error));
  g_assert_no_error (error);
  g_assert_cmpuint (scene.dimensions, ==, 3);
  g_assert_cmpuint (scene.n_reflectors, ==, 3);
  r = &scene.reflectors[0];
  g_assert_cmpint (r->kind, ==, SONAR_REFLECTOR_POINT);
  g_assert_cmpfloat (r->position.y, ==, 0.5);
  g_assert_cmpfloat (r->velocity.z, ==, -1);
  g_assert_cmpfloat (r->strength, ==, 2);
  /* Polar placement is relative to the sensor, to the cylinder's surface;
   * radial velocity is relative to the sensor's own motion. */
  r = &scene.reflectors[1];
  g_assert_cmpint (r->kind, ==, SONAR_REFLECTOR_CYLINDER);
  g_assert_cmpfloat_with_epsilon (r->position.x, 2.1, 1e-12);
  g_assert_cmpfloat_with_epsilon (r->position.z, 1.0, 1e-12);
  g_assert_cmpfloat_with_epsilon (r->velocity.x, -1.5, 1e-12);
  g_assert_cmpfloat_with_epsilon (r->velocity.z, 0.3, 1e-12);
  r = &scene.reflectors[2];
  g_assert_cmpfloat_with_epsilon (r->position.y, 0.5, 1e-12);
  g_assert_cmpfloat (r->strength, ==, 1.0);
  sonar_scene_clear (&scene);
}

static void
test_scene_file_errors (void)
{
  const struct
  {
    const char *json;
    const char *expected;
  } cases[] = {
    {"{", "t.json: "},
    {"{\"dimensions\": 2}", "\"reflectors\" must be an array"},
    {"{\"dimensions\": 4, \"reflectors\": []}", "\"dimensions\" must be 2 or 3"},
    {"{\"reflectors\": [{\"position\": [0, 0, 1], \"velocty\": [0, 0, 1]}]}",
        "reflectors[0]: unknown member \"velocty\""},
    {"{\"reflectors\": [{\"kind\": \"sphere\", \"position\": [0, 0, 1]}]}",
        "\"kind\" must be \"point\" or \"cylinder\", not \"sphere\""},
    {"{\"reflectors\": [{\"position\": [0, 0, 1], \"range\": 2}]}",
        "either \"position\""},
    {"{\"reflectors\": [{\"azimuth\": 10}]}", "either \"position\""},
    {"{\"reflectors\": [{\"range\": -1}]}", "\"range\" must be positive"},
    {"{\"reflectors\": [{\"position\": [0, 0, 1], \"radial-velocity\": 1}]}",
        "\"radial-velocity\" needs the object given by \"range\""},
    {"{\"reflectors\": [{\"range\": 1, \"radial-velocity\": 1, "
          "\"velocity\": [0, 0, 1]}]}", "not both"},
    {"{\"reflectors\": [{\"range\": 1, \"radial-velocity\": 200}]}",
        "reflector 0: speed 200 m/s is not below 100"},
    {"{\"reflectors\": [{\"range\": 1, \"strength\": -1}]}",
        "strength -1 must be in"},
    {"{\"reflectors\": [{\"position\": [0, 0, 1], \"radius\": 0.1}]}",
        "a cylinder needs a radius"},
    {"{\"dimensions\": 2, \"reflectors\": [{\"position\": [0, 1, 1]}]}",
        "a 2-D scene keeps every reflector in the y = 0 plane"},
    {"{\"sensor\": {\"speed\": 1}, \"reflectors\": []}",
        "sensor: unknown member \"speed\""},
    {"{\"reflectors\": [{\"position\": [0, 0, 1e9]}]}", "m from the sensor"},
    {"{\"reflectors\": [{\"position\": [0, 0, 1], \"strength\": \"big\"}]}",
        "\"strength\" must be a finite number"},
  };
  for (guint i = 0; i < G_N_ELEMENTS (cases); i++) {
    g_autofree char *path = sonar_test_write_temp ("t.json", cases[i].json);
    SonarScene scene = { 0 };
    GError *error = NULL;

    g_assert_false (sonar_scene_load_file (&scene, path, &error));
    g_assert_nonnull (error);
    g_test_message ("%s -> %s", cases[i].json, error->message);
    g_assert_nonnull (strstr (error->message, cases[i].expected));
    g_assert_nonnull (strstr (error->message, path));
    g_assert_null (scene.reflectors);
    g_error_free (error);
  }
}

/* Every scene file shipped in pipelines/ loads. */
static void
test_shipped_scene_files (void)
{
  g_autofree char *dir_path = sonar_test_source_path ("pipelines/scenes");
  g_autoptr (GDir) dir = g_dir_open (dir_path, 0, NULL);
  const char *name;
  guint count = 0;

  g_assert_nonnull (dir);
  while ((name = g_dir_read_name (dir))) {
    g_autofree char *path = g_build_filename (dir_path, name, NULL);
    SonarScene scene;
    GError *error = NULL;
    if (!g_str_has_suffix (name, ".json"))
      continue;
    g_assert_true (sonar_scene_load_file (&scene, path, &error));
    g_assert_no_error (error);
    g_assert_cmpuint (scene.n_reflectors, >, 0);
    sonar_scene_clear (&scene);
    count++;
  }
  g_assert_cmpuint (count, >, 0);
}

int
main (int argc, char **argv)
{
  g_test_init (&argc, &argv, NULL);
  g_test_add_func ("/scene/presets-valid", test_presets_valid);
  g_test_add_func ("/scene/fig9", test_fig9);
  g_test_add_func ("/scene/fig10", test_fig10);
  g_test_add_func ("/scene/file", test_scene_file);
  g_test_add_func ("/scene/file-errors", test_scene_file_errors);
  g_test_add_func ("/scene/shipped-files", test_shipped_scene_files);
  return g_test_run ();
}
