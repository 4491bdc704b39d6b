/* sonar-json.c: see sonar-json.h. */
#include "sonar-json.h"

#include <gio/gio.h>
#include <math.h>
#include <string.h>

#define SET_ERROR(error, ...) \
  g_set_error (error, G_IO_ERROR, G_IO_ERROR_INVALID_DATA, __VA_ARGS__)

JsonNode *
sonar_json_parse (const char *path, const char *data, const char *origin,
    JsonObject ** root, GError ** error)
{
  g_autoptr (JsonParser) parser = json_parser_new_immutable ();
  GError *parse_error = NULL;
  JsonNode *node;
  gboolean ok = path ? json_parser_load_from_file (parser, path, &parse_error)
      : json_parser_load_from_data (parser, data, -1, &parse_error);

  if (!ok) {
    g_set_error (error, G_IO_ERROR,
        parse_error->domain == G_FILE_ERROR ? G_IO_ERROR_NOT_FOUND :
        G_IO_ERROR_INVALID_DATA, "%s: %s", origin, parse_error->message);
    g_error_free (parse_error);
    return NULL;
  }
  node = json_parser_steal_root (parser);
  if (!node || !JSON_NODE_HOLDS_OBJECT (node)) {
    SET_ERROR (error, "%s: the top level must be a JSON object", origin);
    if (node)
      json_node_unref (node);
    return NULL;
  }
  *root = json_node_get_object (node);
  return node;
}

gboolean
sonar_json_check_members (JsonObject * object, const char *where,
    const char *const *allowed, GError ** error)
{
  g_autoptr (GList) members = json_object_get_members (object);

  for (GList * l = members; l; l = l->next) {
    if (!g_strv_contains (allowed, l->data)) {
      g_autofree char *list = g_strjoinv (", ", (char **) allowed);
      SET_ERROR (error, "%s: unknown member \"%s\" (expected one of: %s)",
          where, (const char *) l->data, list);
      return FALSE;
    }
  }
  return TRUE;
}

static gboolean
node_to_double (JsonNode * node, double *value)
{
  if (!JSON_NODE_HOLDS_VALUE (node))
    return FALSE;
  switch (json_node_get_value_type (node)) {
    case G_TYPE_INT64:
      *value = (double) json_node_get_int (node);
      return TRUE;
    case G_TYPE_DOUBLE:
      *value = json_node_get_double (node);
      return isfinite (*value);
    default:
      return FALSE;
  }
}

gboolean
sonar_json_get_double (JsonObject * object, const char *member,
    gboolean required, const char *origin, double *value, GError ** error)
{
  JsonNode *node = json_object_get_member (object, member);

  if (!node) {
    if (required)
      SET_ERROR (error, "%s: missing member \"%s\"", origin, member);
    return !required;
  }
  if (!node_to_double (node, value)) {
    SET_ERROR (error, "%s: \"%s\" must be a finite number", origin, member);
    return FALSE;
  }
  return TRUE;
}

static gboolean
node_to_vec3 (JsonNode * node, SonarVec3 * value)
{
  JsonArray *array;
  double v[3];

  if (!JSON_NODE_HOLDS_ARRAY (node))
    return FALSE;
  array = json_node_get_array (node);
  if (json_array_get_length (array) != 3)
    return FALSE;
  for (guint i = 0; i < 3; i++)
    if (!node_to_double (json_array_get_element (array, i), &v[i]))
      return FALSE;
  *value = sonar_vec3 (v[0], v[1], v[2]);
  return TRUE;
}

gboolean
sonar_json_get_vec3 (JsonObject * object, const char *member,
    gboolean required, const char *origin, SonarVec3 * value,
    GError ** error)
{
  JsonNode *node = json_object_get_member (object, member);

  if (!node) {
    if (required)
      SET_ERROR (error, "%s: missing member \"%s\"", origin, member);
    return !required;
  }
  if (!node_to_vec3 (node, value)) {
    SET_ERROR (error, "%s: \"%s\" must be an array of 3 finite numbers "
        "[x, y, z]", origin, member);
    return FALSE;
  }
  return TRUE;
}

gboolean
sonar_json_get_string (JsonObject * object, const char *member,
    gboolean required, const char *origin, const char **value,
    GError ** error)
{
  JsonNode *node = json_object_get_member (object, member);

  if (!node) {
    if (required)
      SET_ERROR (error, "%s: missing member \"%s\"", origin, member);
    return !required;
  }
  if (!JSON_NODE_HOLDS_VALUE (node)
      || json_node_get_value_type (node) != G_TYPE_STRING) {
    SET_ERROR (error, "%s: \"%s\" must be a string", origin, member);
    return FALSE;
  }
  *value = json_node_get_string (node);
  return TRUE;
}

gboolean
sonar_json_get_vec3_list (JsonObject * object, const char *member,
    gboolean required, const char *origin, guint max_count,
    SonarVec3 ** values, guint * count, GError ** error)
{
  JsonNode *node = json_object_get_member (object, member);
  JsonArray *array;
  guint n;

  if (!node) {
    if (required)
      SET_ERROR (error, "%s: missing member \"%s\"", origin, member);
    return !required;
  }
  if (!JSON_NODE_HOLDS_ARRAY (node)) {
    SET_ERROR (error, "%s: \"%s\" must be an array of [x, y, z] positions",
        origin, member);
    return FALSE;
  }
  array = json_node_get_array (node);
  n = json_array_get_length (array);
  if (n == 0 || n > max_count) {
    SET_ERROR (error, "%s: \"%s\" has %u entries (allowed: 1 to %u)",
        origin, member, n, max_count);
    return FALSE;
  }
  *values = g_new (SonarVec3, n);
  for (guint i = 0; i < n; i++) {
    if (!node_to_vec3 (json_array_get_element (array, i), &(*values)[i])) {
      SET_ERROR (error, "%s: \"%s\"[%u] must be an array of 3 finite "
          "numbers [x, y, z]", origin, member, i);
      g_clear_pointer (values, g_free);
      return FALSE;
    }
  }
  *count = n;
  return TRUE;
}

gboolean
sonar_json_get_double_list (JsonObject * object, const char *member,
    gboolean required, const char *origin, guint max_count,
    double **values, guint * count, GError ** error)
{
  JsonNode *node = json_object_get_member (object, member);
  JsonArray *array;
  guint n;

  if (!node) {
    if (required)
      SET_ERROR (error, "%s: missing member \"%s\"", origin, member);
    return !required;
  }
  n = JSON_NODE_HOLDS_ARRAY (node) ?
      json_array_get_length (json_node_get_array (node)) : 0;
  if (!JSON_NODE_HOLDS_ARRAY (node) || n == 0 || n > max_count
      || (*count != 0 && n != *count)) {
    if (*count != 0)
      SET_ERROR (error, "%s: \"%s\" must be an array of %u numbers",
          origin, member, *count);
    else
      SET_ERROR (error, "%s: \"%s\" must be an array of 1 to %u numbers",
          origin, member, max_count);
    return FALSE;
  }
  array = json_node_get_array (node);
  *values = g_new (double, n);
  for (guint i = 0; i < n; i++) {
    if (!node_to_double (json_array_get_element (array, i), &(*values)[i])) {
      SET_ERROR (error, "%s: \"%s\"[%u] must be a finite number", origin,
          member, i);
      g_clear_pointer (values, g_free);
      return FALSE;
    }
  }
  *count = n;
  return TRUE;
}

gboolean
sonar_json_get_sample_rows (JsonObject * object, const char *member,
    const char *origin, guint max_rows, guint min_length, guint max_length,
    double max_abs, float **samples, guint * n_rows, guint * length,
    GError ** error)
{
  JsonNode *node = json_object_get_member (object, member);
  JsonArray *rows;
  guint n_cols = 0, count;

  if (!node || !JSON_NODE_HOLDS_ARRAY (node)
      || (count = json_array_get_length (json_node_get_array (node))) == 0
      || count > max_rows) {
    SET_ERROR (error, "%s: \"%s\" must be an array of 1 to %u arrays of "
        "samples, one per emitter", origin, member, max_rows);
    return FALSE;
  }
  rows = json_node_get_array (node);
  for (guint n = 0; n < count; n++) {
    JsonNode *row = json_array_get_element (rows, n);
    guint len = JSON_NODE_HOLDS_ARRAY (row) ?
        json_array_get_length (json_node_get_array (row)) : 0;
    if (len < min_length || len > max_length || (n > 0 && len != n_cols)) {
      SET_ERROR (error, "%s: \"%s\"[%u] must be an array of %u to %u "
          "samples, as long as the first one", origin, member, n, min_length,
          max_length);
      return FALSE;
    }
    n_cols = len;
  }
  *samples = g_new (float, (gsize) count * n_cols);
  for (guint n = 0; n < count; n++) {
    JsonArray *row = json_node_get_array (json_array_get_element (rows, n));
    for (guint i = 0; i < n_cols; i++) {
      double value;
      if (!node_to_double (json_array_get_element (row, i), &value)) {
        SET_ERROR (error, "%s: \"%s\"[%u][%u] must be a finite number",
            origin, member, n, i);
        g_clear_pointer (samples, g_free);
        return FALSE;
      }
      if (fabs (value) > max_abs) {
        SET_ERROR (error, "%s: \"%s\"[%u][%u] is %g, beyond the allowed "
            "+-%g", origin, member, n, i, value, max_abs);
        g_clear_pointer (samples, g_free);
        return FALSE;
      }
      (*samples)[(gsize) n * n_cols + i] = (float) value;
    }
  }
  *n_rows = count;
  *length = n_cols;
  return TRUE;
}
