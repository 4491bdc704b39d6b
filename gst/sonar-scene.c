/* sonar-scene.c: presets, scene files and their validation. */
#include "sonar-scene.h"
#include "sonar-error.h"
#include "sonar-json.h"

#include <gio/gio.h>
#include <string.h>

/* Faster than this (m/s), relative to the air, nothing echoes like a sonar
 * target any more: the validator rejects it. */
#define MAX_SPEED 100.0
#define MAX_DISTANCE 1000.0
#define MAX_RADIUS 10.0
#define MAX_STRENGTH 1e6

#define SET_ERROR(error, ...) \
  g_set_error (error, SONAR_ERROR, SONAR_ERROR_FORMAT, __VA_ARGS__)

/* Default: something to look at in every stage, one object approaching. */
static const SonarPresetObject default_objects[] = {
  {SONAR_REFLECTOR_POINT, 1.5, -30.0, 0.0, 0.0, 0.0, 1.0},
  {SONAR_REFLECTOR_CYLINDER, 2.2, 10.0, -1.0, 0.4, 0.05, 1.0},
  {SONAR_REFLECTOR_POINT, 3.0, 40.0, 0.5, 0.0, 0.0, 1.0},
};

/* Paper Fig. 9: a still sensor, four still cylinders of different sizes
 * and two movers of several m/s, one approaching, one receding. */
static const SonarPresetObject fig9_objects[] = {
  {SONAR_REFLECTOR_CYLINDER, 1.2, -65.0, 0.0, 0.0, 0.04, 1.0},
  {SONAR_REFLECTOR_CYLINDER, 3.8, -10.0, 0.0, 0.0, 0.10, 1.0},
  {SONAR_REFLECTOR_CYLINDER, 1.6, 15.0, 0.0, 0.0, 0.03, 1.0},
  {SONAR_REFLECTOR_CYLINDER, 2.6, 60.0, 0.0, 0.0, 0.06, 1.0},
  {SONAR_REFLECTOR_CYLINDER, 2.0, -40.0, -3.0, 1.0, 0.05, 1.0},
  {SONAR_REFLECTOR_CYLINDER, 3.0, 35.0, 1.8, -0.8, 0.05, 1.0},
};

/* Paper Fig. 10: the robot drives forward at 0.3 m/s past still objects
 * at 0.5-5 m and -80..80 degrees; radial speeds are -0.3 cos(azimuth). */
static const SonarPresetObject fig10_objects[] = {
  {SONAR_REFLECTOR_CYLINDER, 0.6, -70.0, 0.0, 0.0, 0.03, 1.0},
  {SONAR_REFLECTOR_CYLINDER, 1.0, 40.0, 0.0, 0.0, 0.03, 1.0},
  {SONAR_REFLECTOR_CYLINDER, 1.8, -25.0, 0.0, 0.0, 0.05, 1.0},
  {SONAR_REFLECTOR_CYLINDER, 2.5, 75.0, 0.0, 0.0, 0.05, 1.0},
  {SONAR_REFLECTOR_CYLINDER, 3.3, 10.0, 0.0, 0.0, 0.08, 1.0},
  {SONAR_REFLECTOR_CYLINDER, 4.5, -50.0, 0.0, 0.0, 0.10, 1.0},
};

/* A driving sensor among crossing movers: the sensor drives forward at
 * 0.3 m/s towards a still wall of seven posts (z = 4 m in the world, x =
 * -2.4..2.4 m, 0.8 m apart); two walkers (cylinders of 5 cm) cross in
 * front of it at different speeds, both reaching the world point (0.3, 0,
 * 2.4) m at t = 1.25 s (ping 15 at 12 Hz), where they overlap: walker A
 * from (-0.95, 0, 2.7125) m at (1.0, 0, -0.25) m/s (1.03 m/s), walker B
 * from (1.05, 0, 2.025) m at (-0.6, 0, 0.3) m/s (0.67 m/s). Relative to
 * the sensor their radial velocities there are -0.40 and -0.09 m/s. */
static const SonarPresetObject crossing_objects[] = {
  {SONAR_REFLECTOR_CYLINDER, 2.8240, -19.3018, -0.5665, 0.8612, 0.05, 1.0},
  {SONAR_REFLECTOR_CYLINDER, 2.2310, 27.4076, -0.0099, -0.6707, 0.05, 1.0},
  {SONAR_REFLECTOR_CYLINDER, 4.6348, -30.9638, 0.0, 0.0, 0.03, 1.0},
  {SONAR_REFLECTOR_CYLINDER, 4.2781, -21.8014, 0.0, 0.0, 0.03, 1.0},
  {SONAR_REFLECTOR_CYLINDER, 4.0492, -11.3099, 0.0, 0.0, 0.03, 1.0},
  {SONAR_REFLECTOR_CYLINDER, 3.9700, 0.0, 0.0, 0.0, 0.03, 1.0},
  {SONAR_REFLECTOR_CYLINDER, 4.0492, 11.3099, 0.0, 0.0, 0.03, 1.0},
  {SONAR_REFLECTOR_CYLINDER, 4.2781, 21.8014, 0.0, 0.0, 0.03, 1.0},
  {SONAR_REFLECTOR_CYLINDER, 4.6348, 30.9638, 0.0, 0.0, 0.03, 1.0},
};

#define OBJECTS(a) a, G_N_ELEMENTS (a)

static const SonarScenePresetInfo presets[] = {
  {SONAR_SCENE_PRESET_DEFAULT, "default",
      "Three objects, one approaching at 1 m/s", {0, 0, 0},
      OBJECTS (default_objects)},
  {SONAR_SCENE_PRESET_FIG9, "fig9",
      "Paper Fig. 9: still sensor, 4 still and 2 moving objects", {0, 0, 0},
      OBJECTS (fig9_objects)},
  {SONAR_SCENE_PRESET_FIG10, "fig10",
      "Paper Fig. 10: sensor driving at 0.3 m/s past 6 objects", {0, 0, 0.3},
      OBJECTS (fig10_objects)},
  {SONAR_SCENE_PRESET_EMPTY, "empty", "No reflector (noise only)", {0, 0, 0},
      NULL, 0},
  {SONAR_SCENE_PRESET_CROSSING, "crossing",
        "Sensor driving at 0.3 m/s towards a still wall of 7 posts, two "
        "walkers crossing at 1.03 and 0.67 m/s", {0, 0, 0.3},
      OBJECTS (crossing_objects)},
};

const SonarScenePresetInfo *
sonar_scene_presets (guint * n_presets)
{
  *n_presets = G_N_ELEMENTS (presets);
  return presets;
}

void
sonar_scene_init_preset (SonarScene * scene, SonarScenePreset preset)
{
  const SonarScenePresetInfo *info;

  g_return_if_fail ((guint) preset < G_N_ELEMENTS (presets));
  info = &presets[preset];
  memset (scene, 0, sizeof (*scene));
  scene->dimensions = 2;
  scene->sensor_position = sonar_vec3 (0, 0, 0);
  scene->sensor_velocity = info->sensor_velocity;
  scene->n_reflectors = info->n_objects;
  scene->reflectors = g_new0 (SonarReflector, info->n_objects);
  for (guint k = 0; k < info->n_objects; k++) {
    const SonarPresetObject *o = &info->objects[k];
    const SonarVec3 radial = sonar_vec3_from_direction (o->azimuth, 0.0);
    const SonarVec3 tangential = sonar_vec3_from_direction (o->azimuth + 90.0,
        0.0);
    SonarReflector *r = &scene->reflectors[k];

    r->kind = o->kind;
    r->radius = o->radius;
    r->strength = o->strength;
    /* A cylinder's surface, not its axis, is at the given range. */
    r->position = sonar_vec3_scale (radial, o->range + o->radius);
    r->velocity = sonar_vec3_add (sonar_vec3_scale (radial,
            o->radial_velocity), sonar_vec3_scale (tangential,
            o->tangential_velocity));
  }
}

void
sonar_scene_clear (SonarScene * scene)
{
  g_clear_pointer (&scene->reflectors, g_free);
  scene->n_reflectors = 0;
}

void
sonar_scene_copy (SonarScene * dest, const SonarScene * src)
{
  *dest = *src;
  dest->reflectors = g_memdup2 (src->reflectors,
      sizeof (SonarReflector) * src->n_reflectors);
}

static gboolean
vec3_is_planar (SonarVec3 v)
{
  return v.y == 0.0;
}

gboolean
sonar_scene_validate (const SonarScene * scene, GError ** error)
{
  if (scene->dimensions != 2 && scene->dimensions != 3) {
    SET_ERROR (error, "scene: \"dimensions\" must be 2 or 3, not %u",
        scene->dimensions);
    return FALSE;
  }
  if (scene->n_reflectors > SONAR_MAX_REFLECTORS) {
    SET_ERROR (error, "scene: %u reflectors, at most %u are allowed",
        scene->n_reflectors, SONAR_MAX_REFLECTORS);
    return FALSE;
  }
  if (sonar_vec3_norm (scene->sensor_velocity) >= MAX_SPEED
      || sonar_vec3_norm (scene->sensor_position) > MAX_DISTANCE) {
    SET_ERROR (error, "scene: sensor: position must be within %g m of the "
        "origin and speed below %g m/s", MAX_DISTANCE, MAX_SPEED);
    return FALSE;
  }
  if (scene->dimensions == 2 && !(vec3_is_planar (scene->sensor_position)
          && vec3_is_planar (scene->sensor_velocity))) {
    SET_ERROR (error, "scene: a 2-D scene keeps the sensor in the y = 0 "
        "plane (position and velocity y must be 0)");
    return FALSE;
  }
  for (guint k = 0; k < scene->n_reflectors; k++) {
    const SonarReflector *r = &scene->reflectors[k];
    const double distance =
        sonar_vec3_norm (sonar_vec3_sub (r->position, scene->sensor_position));

    if (!(distance <= MAX_DISTANCE)) {
      SET_ERROR (error, "scene: reflector %u: position is %g m from the "
          "sensor (at most %g m)", k, distance, MAX_DISTANCE);
      return FALSE;
    }
    if (!(sonar_vec3_norm (r->velocity) < MAX_SPEED)) {
      SET_ERROR (error, "scene: reflector %u: speed %g m/s is not below %g "
          "m/s", k, sonar_vec3_norm (r->velocity), MAX_SPEED);
      return FALSE;
    }
    if (!(r->strength >= 0.0 && r->strength <= MAX_STRENGTH)) {
      SET_ERROR (error, "scene: reflector %u: strength %g must be in [0, %g]",
          k, r->strength, MAX_STRENGTH);
      return FALSE;
    }
    if (r->kind == SONAR_REFLECTOR_CYLINDER ?
        !(r->radius > 0.0 && r->radius <= MAX_RADIUS) : r->radius != 0.0) {
      SET_ERROR (error, "scene: reflector %u: a cylinder needs a radius in "
          "(0, %g] m and a point none", k, MAX_RADIUS);
      return FALSE;
    }
    if (scene->dimensions == 2 && !(vec3_is_planar (r->position)
            && vec3_is_planar (r->velocity))) {
      SET_ERROR (error, "scene: reflector %u: a 2-D scene keeps every "
          "reflector in the y = 0 plane (position and velocity y must be 0)",
          k);
      return FALSE;
    }
  }
  return TRUE;
}

static gboolean
load_reflector (JsonObject * object, guint index, const SonarScene * scene,
    const char *origin, SonarReflector * r, GError ** error)
{
  static const char *const members[] = { "name", "kind", "position",
    "range", "azimuth", "elevation", "velocity", "radial-velocity",
    "tangential-velocity", "radius", "strength", NULL
  };
  g_autofree char *where = g_strdup_printf ("%s: reflectors[%u]", origin,
      index);
  const char *kind = "point";
  gboolean polar = json_object_has_member (object, "range");
  gboolean relative_velocity = json_object_has_member (object,
      "radial-velocity") || json_object_has_member (object,
      "tangential-velocity");
  double range = 0, azimuth = 0, elevation = 0, vr = 0, vt = 0;
  SonarVec3 radial, tangential;

  if (!sonar_json_check_members (object, where, members, error)
      || !sonar_json_get_string (object, "kind", FALSE, where, &kind, error))
    return FALSE;
  if (strcmp (kind, "point") == 0)
    r->kind = SONAR_REFLECTOR_POINT;
  else if (strcmp (kind, "cylinder") == 0)
    r->kind = SONAR_REFLECTOR_CYLINDER;
  else {
    SET_ERROR (error, "%s: \"kind\" must be \"point\" or \"cylinder\", not "
        "\"%s\"", where, kind);
    return FALSE;
  }
  r->strength = 1.0;
  r->radius = r->kind == SONAR_REFLECTOR_CYLINDER ? 0.05 : 0.0;
  if (!sonar_json_get_double (object, "strength", FALSE, where, &r->strength,
          error)
      || !sonar_json_get_double (object, "radius", FALSE, where, &r->radius,
          error))
    return FALSE;

  if (polar == json_object_has_member (object, "position")) {
    SET_ERROR (error, "%s: give either \"position\" [x, y, z] or \"range\" "
        "(with \"azimuth\", \"elevation\"), exactly one of them", where);
    return FALSE;
  }
  if (relative_velocity && json_object_has_member (object, "velocity")) {
    SET_ERROR (error, "%s: give either \"velocity\" [vx, vy, vz] or "
        "\"radial-velocity\"/\"tangential-velocity\", not both", where);
    return FALSE;
  }
  if (!sonar_json_get_double (object, "range", FALSE, where, &range, error)
      || !sonar_json_get_double (object, "azimuth", FALSE, where, &azimuth,
          error)
      || !sonar_json_get_double (object, "elevation", FALSE, where,
          &elevation, error)
      || !sonar_json_get_double (object, "radial-velocity", FALSE, where, &vr,
          error)
      || !sonar_json_get_double (object, "tangential-velocity", FALSE, where,
          &vt, error))
    return FALSE;
  if (polar && !(range > 0.0)) {
    SET_ERROR (error, "%s: \"range\" must be positive (m)", where);
    return FALSE;
  }
  if (relative_velocity && !polar) {
    SET_ERROR (error, "%s: \"radial-velocity\" needs the object given by "
        "\"range\" and \"azimuth\"", where);
    return FALSE;
  }

  radial = sonar_vec3_from_direction (azimuth, elevation);
  tangential = sonar_vec3_from_direction (azimuth + 90.0, 0.0);
  if (polar) {
    /* Range is to the surface: the axis of a cylinder is one radius further. */
    r->position = sonar_vec3_add (scene->sensor_position,
        sonar_vec3_scale (radial, range + r->radius));
  } else if (!sonar_json_get_vec3 (object, "position", TRUE, where,
          &r->position, error))
    return FALSE;

  r->velocity = sonar_vec3 (0, 0, 0);
  if (relative_velocity)
    r->velocity = sonar_vec3_add (scene->sensor_velocity,
        sonar_vec3_add (sonar_vec3_scale (radial, vr),
            sonar_vec3_scale (tangential, vt)));
  else if (!sonar_json_get_vec3 (object, "velocity", FALSE, where,
          &r->velocity, error))
    return FALSE;
  return TRUE;
}

static gboolean
load_scene (SonarScene * scene, const char *path, const char *data,
    const char *origin, GError ** error)
{
  static const char *const members[] = { "description", "dimensions",
    "sensor", "reflectors", NULL
  };
  static const char *const sensor_members[] = { "position", "velocity",
    NULL
  };
  g_autoptr (JsonNode) node = NULL;
  JsonObject *root;
  JsonNode *sensor, *reflectors;
  SonarScene loaded = { 0 };
  double dimensions = 3;
  GError *local_error = NULL;

  node = sonar_json_parse (path, data, origin, &root, error);
  if (!node)
    return FALSE;
  if (!sonar_json_check_members (root, origin, members, error)
      || !sonar_json_get_double (root, "dimensions", FALSE, origin,
          &dimensions, error))
    return FALSE;
  if (dimensions != 2.0 && dimensions != 3.0) {
    SET_ERROR (error, "%s: \"dimensions\" must be 2 or 3, not %g", origin,
        dimensions);
    return FALSE;
  }
  loaded.dimensions = (guint) dimensions;

  sensor = json_object_get_member (root, "sensor");
  if (sensor) {
    g_autofree char *where = g_strdup_printf ("%s: sensor", origin);
    if (!JSON_NODE_HOLDS_OBJECT (sensor)) {
      SET_ERROR (error, "%s: must be an object with \"position\" and "
          "\"velocity\"", where);
      return FALSE;
    }
    if (!sonar_json_check_members (json_node_get_object (sensor), where,
            sensor_members, error)
        || !sonar_json_get_vec3 (json_node_get_object (sensor), "position",
            FALSE, where, &loaded.sensor_position, error)
        || !sonar_json_get_vec3 (json_node_get_object (sensor), "velocity",
            FALSE, where, &loaded.sensor_velocity, error))
      return FALSE;
  }

  reflectors = json_object_get_member (root, "reflectors");
  if (!reflectors || !JSON_NODE_HOLDS_ARRAY (reflectors)) {
    SET_ERROR (error, "%s: \"reflectors\" must be an array (it may be empty)",
        origin);
    return FALSE;
  }
  loaded.n_reflectors = json_array_get_length (json_node_get_array
      (reflectors));
  if (loaded.n_reflectors > SONAR_MAX_REFLECTORS) {
    SET_ERROR (error, "%s: %u reflectors, at most %u are allowed", origin,
        loaded.n_reflectors, SONAR_MAX_REFLECTORS);
    return FALSE;
  }
  loaded.reflectors = g_new0 (SonarReflector, loaded.n_reflectors);
  for (guint k = 0; k < loaded.n_reflectors; k++) {
    JsonNode *item = json_array_get_element (json_node_get_array (reflectors),
        k);
    if (!JSON_NODE_HOLDS_OBJECT (item)) {
      SET_ERROR (error, "%s: reflectors[%u] must be an object", origin, k);
      sonar_scene_clear (&loaded);
      return FALSE;
    }
    if (!load_reflector (json_node_get_object (item), k, &loaded, origin,
            &loaded.reflectors[k], error)) {
      sonar_scene_clear (&loaded);
      return FALSE;
    }
  }
  if (!sonar_scene_validate (&loaded, &local_error)) {
    SET_ERROR (error, "%s: %s", origin, local_error->message);
    g_error_free (local_error);
    sonar_scene_clear (&loaded);
    return FALSE;
  }
  *scene = loaded;
  return TRUE;
}

gboolean
sonar_scene_load_file (SonarScene * scene, const char *path, GError ** error)
{
  return load_scene (scene, path, NULL, path, error);
}

gboolean
sonar_scene_load_data (SonarScene * scene, const char *json,
    const char *origin, GError ** error)
{
  return load_scene (scene, NULL, json, origin, error);
}

const char *
sonar_scene_preset_to_string (SonarScenePreset preset)
{
  return (guint) preset < G_N_ELEMENTS (presets) ? presets[preset].nick :
      NULL;
}

gboolean
sonar_scene_preset_from_string (const char *name, SonarScenePreset * preset)
{
  for (guint i = 0; name && i < G_N_ELEMENTS (presets); i++) {
    if (strcmp (name, presets[i].nick) == 0) {
      *preset = presets[i].preset;
      return TRUE;
    }
  }
  return FALSE;
}

const char *
sonar_reflector_kind_to_string (SonarReflectorKind kind)
{
  return kind == SONAR_REFLECTOR_CYLINDER ? "cylinder" : "point";
}
