/* sonar-json.h: strict readers for the project's JSON files, so that every
 * file format reports a bad value the same way: "<file>: <member>: <what>". */
#ifndef SONAR_JSON_H
#define SONAR_JSON_H

#include <json-glib/json-glib.h>
#include "sonar-vec3.h"

G_BEGIN_DECLS

/* Limits of every JSON input (docs/FORMATS.md), checked before json-glib
 * sees it: the largest file read, in bytes (a waveforms file of 8 emitters
 * at the longest length, as sonar-waveforms writes it, is ~120 MB), and
 * the deepest nesting of arrays and objects (json-glib's parser recurses
 * once per level: 100,000 levels overflow the stack). */
#define SONAR_JSON_MAX_FILE_SIZE (256u * 1024 * 1024)
#define SONAR_JSON_MAX_DEPTH 64

/* Parses @path (or @data when @path is NULL) and returns its root object,
 * or NULL with @error set. @origin names the input in messages. A file
 * must be a regular file of at most SONAR_JSON_MAX_FILE_SIZE bytes; the
 * text must be strict JSON (no comments), nested at most
 * SONAR_JSON_MAX_DEPTH deep, with no number beyond the range of a 64-bit
 * integer or a double, and no object repeating a member. */
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
/* A number in [@min, @max] from @node (an element of an array, say); the
 * printf-style @format names it in messages ("<file>: <where>"), formatted
 * only on error. A node of the wrong type is an error like any other, with
 * no critical logged. */
gboolean sonar_json_node_get_number (JsonNode * node, double min, double max,
    double *value, GError ** error, const char *format, ...)
    G_GNUC_PRINTF (6, 7);
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

/* @node as one line of JSON ("a": 1, "b": [2, 3]), as JsonGenerator
 * writes it but for its numbers: json-glib 1.6 writes every double with 17 significant
 * digits (0.1 as 0.10000000000000001); here each is the shortest text
 * that reads back as the same double (at most 15 digits when it is, else
 * 17). Object members in their order of insertion. g_free it. */
char *sonar_json_to_line (JsonNode * node);

G_END_DECLS

#endif
