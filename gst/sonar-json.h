/* sonar-json.h: strict readers for the project's JSON files, so that every
 * file format reports a bad value the same way: "<file>: <member>: <what>". */
#ifndef SONAR_JSON_H
#define SONAR_JSON_H

#include <json-glib/json-glib.h>
#include "sonar-vec3.h"

G_BEGIN_DECLS

/* Parses @path (or @data when @path is NULL) and returns its root object,
 * or NULL with @error set. @origin names the input in messages. */
JsonNode *sonar_json_parse (const char *path, const char *data,
    const char *origin, JsonObject ** root, GError ** error);

/* Rejects members not in @allowed: a misspelt "velocty" must not silently
 * leave an object standing still. @where names the object in messages. */
gboolean sonar_json_check_members (JsonObject * object, const char *where,
    const char *const *allowed, GError ** error);

/* Each returns FALSE with @error set when the member has the wrong type or
 * is not finite. Optional readers leave *value untouched when absent. */
gboolean sonar_json_get_double (JsonObject * object, const char *member,
    gboolean required, const char *origin, double *value, GError ** error);
gboolean sonar_json_get_vec3 (JsonObject * object, const char *member,
    gboolean required, const char *origin, SonarVec3 * value,
    GError ** error);
gboolean sonar_json_get_string (JsonObject * object, const char *member,
    gboolean required, const char *origin, const char **value,
    GError ** error);
/* A member that is an array of [x, y, z] triples; *values is g_new'ed. */
gboolean sonar_json_get_vec3_list (JsonObject * object, const char *member,
    gboolean required, const char *origin, guint max_count,
    SonarVec3 ** values, guint * count, GError ** error);

/* A member that is an array of exactly @count finite numbers (@count 0:
 * any count up to @max_count, returned in *count); *values is g_new'ed. */
gboolean sonar_json_get_double_list (JsonObject * object, const char *member,
    gboolean required, const char *origin, guint max_count,
    double **values, guint * count, GError ** error);

/* A member that is an array of 1 to @max_rows rows of @min_length to
 * @max_length numbers each, all rows as long as the first, every number
 * finite and within +-@max_abs: waveforms. *samples (row-major) is
 * g_new'ed. */
gboolean sonar_json_get_sample_rows (JsonObject * object, const char *member,
    const char *origin, guint max_rows, guint min_length, guint max_length,
    double max_abs, float **samples, guint * n_rows, guint * length,
    GError ** error);

G_END_DECLS

#endif
