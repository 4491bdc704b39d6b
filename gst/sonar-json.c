/* sonar-json.c: see sonar-json.h. */
#include "sonar-json.h"
#include "sonar-error.h"

#include <errno.h>
#include <fcntl.h>
#include <gio/gio.h>
#include <math.h>
#include <stdarg.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define SET_ERROR(error, ...) \
  g_set_error (error, SONAR_ERROR, SONAR_ERROR_FORMAT, __VA_ARGS__)

/* Reads the whole of @path, refusing what is not a regular file (a FIFO
 * with no writer would block, /dev/zero never ends) or is larger than
 * SONAR_JSON_MAX_FILE_SIZE, before reading a byte. */
static char *
read_json_file (const char *path, gsize * length, GError ** error)
{
  struct stat st;
  char *contents;
  gsize done = 0;
  int fd;

  /* O_NONBLOCK: opening a FIFO for reading must not wait for a writer. */
  fd = open (path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    int saved_errno = errno;
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_FILE,
        "%s: cannot open: %s", path, g_strerror (saved_errno));
    return NULL;
  }
  if (fstat (fd, &st) != 0 || !S_ISREG (st.st_mode)) {
    SET_ERROR (error, "%s: not a regular file (devices, FIFOs and "
        "directories are not read)", path);
    close (fd);
    return NULL;
  }
  if (st.st_size > SONAR_JSON_MAX_FILE_SIZE) {
    SET_ERROR (error, "%s: %" G_GINT64_FORMAT " bytes, larger than the %u "
        "MiB allowed for a JSON file", path, (gint64) st.st_size,
        SONAR_JSON_MAX_FILE_SIZE / (1024 * 1024));
    close (fd);
    return NULL;
  }
  /* A file that grows while it is read is cut at its size when stat'ed. */
  contents = g_malloc ((gsize) st.st_size + 1);
  while (done < (gsize) st.st_size) {
    ssize_t n = read (fd, contents + done, (gsize) st.st_size - done);
    if (n < 0 && errno == EINTR)
      continue;
    if (n < 0) {
      int saved_errno = errno;
      g_set_error (error, SONAR_ERROR, SONAR_ERROR_FILE,
          "%s: cannot read: %s", path, g_strerror (saved_errno));
      g_free (contents);
      close (fd);
      return NULL;
    }
    if (n == 0)
      break;
    done += (gsize) n;
  }
  close (fd);
  contents[done] = '\0';
  *length = done;
  return contents;
}

/* The pre-scan's record of one open array or object, to name the member
 * where a number is out of range. */
typedef struct
{
  gboolean is_object;
  gboolean expects_key;         /* object: the next string is a key */
  const char *key;              /* object: the member being read, as written */
  gsize key_length;
  guint index;                  /* array: the element being read */
} ScanLevel;

/* "reflectors[0].strength": where the scan is, for messages. */
static char *
scan_path (const ScanLevel * levels, guint depth)
{
  GString *path = g_string_new (NULL);

  for (guint d = 0; d < depth; d++) {
    if (!levels[d].is_object)
      g_string_append_printf (path, "[%u]", levels[d].index);
    else if (levels[d].key)
      g_string_append_printf (path, "%s%.*s", path->len ? "." : "",
          (int) MIN (levels[d].key_length, 64), levels[d].key);
  }
  if (path->len == 0)
    g_string_append (path, "top level");
  return g_string_free (path, FALSE);
}

static void
line_and_column (const char *text, gsize offset, guint * line,
    guint * column)
{
  gsize line_start = 0;

  *line = 1;
  for (gsize i = 0; i < offset; i++) {
    if (text[i] == '\n') {
      (*line)++;
      line_start = i + 1;
    }
  }
  *column = (guint) (offset - line_start) + 1;
}

/* Checks the number written at @text[0 .. @length): an integer must fit
 * in 64 bits and any number in a double (json-glib would silently read
 * 18446744073709551617 as -1 and 1e400 as infinity). What is not a
 * well-formed number is left to json-glib's syntax errors. */
static gboolean
number_in_range (const char *text, gsize length, gboolean * is_integer)
{
  char buffer[64];
  g_autofree char *copy = NULL;
  const char *number;
  char *end;

  *is_integer = !memchr (text, '.', length) && !memchr (text, 'e', length)
      && !memchr (text, 'E', length);
  if (length < sizeof (buffer)) {
    memcpy (buffer, text, length);
    buffer[length] = '\0';
    number = buffer;
  } else
    number = copy = g_strndup (text, length);
  errno = 0;
  if (*is_integer)
    (void) g_ascii_strtoll (number, &end, 10);
  else                          /* underflow to 0 or a denormal is fine */
    errno = isinf (g_ascii_strtod (number, &end)) ? ERANGE : 0;
  return !(errno == ERANGE && *end == '\0');
}

/* Unlike strchr, never matches the terminating NUL: a NUL byte in the
 * text is not whitespace. */
static gboolean
char_in (char c, const char *set)
{
  return c != '\0' && strchr (set, c) != NULL;
}

/* One pass over the text before json-glib parses it: nesting depth,
 * numbers out of range, and characters strict JSON does not allow outside
 * strings. json-glib accepts comments and single-quoted strings; they are
 * refused here so that no bracket json-glib sees escapes this count. */
static gboolean
prescan_json (const char *text, gsize length, const char *origin,
    GError ** error)
{
  ScanLevel levels[SONAR_JSON_MAX_DEPTH] = { 0 };
  guint depth = 0, line, column;
  gsize i = 0;

  while (i < length) {
    const char c = text[i];
    ScanLevel *top = depth ? &levels[depth - 1] : NULL;

    if (c == '"') {
      const gsize start = ++i;
      while (i < length && text[i] != '"')
        i += text[i] == '\\' ? 2 : 1;
      if (top && top->is_object && top->expects_key) {
        top->key = text + start;
        top->key_length = MIN (i, length) - start;
        top->expects_key = FALSE;
      }
      i++;
    } else if (c == '{' || c == '[') {
      if (depth == SONAR_JSON_MAX_DEPTH) {
        line_and_column (text, i, &line, &column);
        SET_ERROR (error, "%s: line %u, column %u: nested deeper than %d "
            "arrays and objects", origin, line, column, SONAR_JSON_MAX_DEPTH);
        return FALSE;
      }
      levels[depth++] = (ScanLevel) {.is_object = c == '{',
        .expects_key = c == '{'};
      i++;
    } else if (c == '}' || c == ']') {
      depth -= depth > 0;
      i++;
    } else if (c == ',') {
      if (top && top->is_object)
        top->expects_key = TRUE;
      else if (top)
        top->index++;
      i++;
    } else if (c == '-' || g_ascii_isdigit (c)) {
      const gsize start = i;
      gboolean is_integer;
      while (i < length && (g_ascii_isdigit (text[i])
              || char_in (text[i], "+-.eE")))
        i++;
      if (!number_in_range (text + start, i - start, &is_integer)) {
        g_autofree char *path = scan_path (levels, depth);
        if (is_integer)
          SET_ERROR (error, "%s: %s: %.*s is out of range (integers: %"
              G_GINT64_FORMAT " to %" G_GINT64_FORMAT ")", origin, path,
              (int) MIN (i - start, 64), text + start, G_MININT64,
              G_MAXINT64);
        else
          SET_ERROR (error, "%s: %s: %.*s is out of range (numbers: "
              "magnitude at most %g)", origin, path,
              (int) MIN (i - start, 64), text + start, G_MAXDOUBLE);
        return FALSE;
      }
    } else if (g_ascii_isalpha (c) || char_in (c, " \t\r\n:")) {
      /* Whitespace, separators and the letters of true, false and null. */
      i++;
    } else {
      line_and_column (text, i, &line, &column);
      SET_ERROR (error, "%s: line %u, column %u: unexpected character "
          "'%s' (strict JSON: no comments, strings in double quotes)",
          origin, line, column, g_ascii_isprint (c) ? (char[]) {c, 0} : "?");
      return FALSE;
    }
  }
  return TRUE;
}

/* json-glib keeps the last of repeated members silently; the parser's
 * object-member signal comes after the member is set, so an object that
 * did not grow already had it. */
typedef struct
{
  GHashTable *members_seen;     /* JsonObject -> members parsed so far */
  char *repeated;               /* the first repeated member */
} RepeatCheck;

static void
on_object_member (JsonParser * parser, JsonObject * object,
    const char *member, RepeatCheck * check)
{
  guint seen = GPOINTER_TO_UINT (g_hash_table_lookup (check->members_seen,
          object)) + 1;

  g_hash_table_insert (check->members_seen, object, GUINT_TO_POINTER (seen));
  if (!check->repeated && json_object_get_size (object) < seen)
    check->repeated = g_strdup (member);
}

JsonNode *
sonar_json_parse (const char *path, const char *data, const char *origin,
    JsonObject ** root, GError ** error)
{
  g_autoptr (JsonParser) parser = json_parser_new_immutable ();
  g_autofree char *contents = NULL;
  RepeatCheck check = { g_hash_table_new (NULL, NULL), NULL };
  GError *parse_error = NULL;
  JsonNode *node;
  gsize length;
  gboolean ok;

  if (path) {
    contents = read_json_file (path, &length, error);
    if (!contents)
      return NULL;
    data = contents;
  } else
    length = strlen (data);
  if (!prescan_json (data, length, origin, error))
    return NULL;

  g_signal_connect (parser, "object-member", G_CALLBACK (on_object_member),
      &check);
  ok = json_parser_load_from_data (parser, data, (gssize) length,
      &parse_error);
  g_hash_table_destroy (check.members_seen);
  if (!ok) {
    SET_ERROR (error, "%s: %s", origin, parse_error->message);
    g_error_free (parse_error);
    g_free (check.repeated);
    return NULL;
  }
  if (check.repeated) {
    SET_ERROR (error, "%s: member \"%s\" appears twice in one object",
        origin, check.repeated);
    g_free (check.repeated);
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
  if (!node || !JSON_NODE_HOLDS_VALUE (node))
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

/* An absent member: fine when optional, else an error that names it. */
static gboolean
absent_member_ok (const char *member, gboolean required, const char *origin,
    GError ** error)
{
  if (required)
    SET_ERROR (error, "%s: missing member \"%s\"", origin, member);
  return !required;
}

gboolean
sonar_json_get_double (JsonObject * object, const char *member,
    gboolean required, const char *origin, double *value, GError ** error)
{
  JsonNode *node = json_object_get_member (object, member);

  if (!node)
    return absent_member_ok (member, required, origin, error);
  if (!node_to_double (node, value)) {
    SET_ERROR (error, "%s: \"%s\" must be a finite number", origin, member);
    return FALSE;
  }
  return TRUE;
}

gboolean
sonar_json_node_get_number (JsonNode * node, double min, double max,
    double *value, GError ** error, const char *format, ...)
{
  g_autofree char *where = NULL;
  double number;
  va_list args;

  if (node_to_double (node, &number) && number >= min && number <= max) {
    *value = number;
    return TRUE;
  }
  va_start (args, format);
  where = g_strdup_vprintf (format, args);
  va_end (args);
  if (!node_to_double (node, &number))
    SET_ERROR (error, "%s must be a finite number in [%g, %g]", where, min,
        max);
  else
    SET_ERROR (error, "%s is %g, out of range (allowed: %g to %g)", where,
        number, min, max);
  return FALSE;
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

  if (!node)
    return absent_member_ok (member, required, origin, error);
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

  if (!node)
    return absent_member_ok (member, required, origin, error);
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

  if (!node)
    return absent_member_ok (member, required, origin, error);
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

  if (!node)
    return absent_member_ok (member, required, origin, error);
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
      if (!sonar_json_node_get_number (json_array_get_element (row, i),
              -max_abs, max_abs, &value, error, "%s: \"%s\"[%u][%u]",
              origin, member, n, i)) {
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

static void
append_node (GString * out, JsonNode * node)
{
  switch (JSON_NODE_TYPE (node)) {
    case JSON_NODE_OBJECT:{
      JsonObject *object = json_node_get_object (node);
      g_autoptr (GList) names = json_object_get_members (object);
      g_string_append_c (out, '{');
      for (GList * l = names; l; l = l->next) {
        g_autoptr (JsonNode) name = json_node_new (JSON_NODE_VALUE);
        g_autofree char *quoted = NULL;
        json_node_set_string (name, l->data);
        quoted = json_to_string (name, FALSE);
        g_string_append_printf (out, "%s%s: ", l != names ? ", " : "",
            quoted);
        append_node (out, json_object_get_member (object, l->data));
      }
      g_string_append_c (out, '}');
      break;
    }
    case JSON_NODE_ARRAY:{
      JsonArray *array = json_node_get_array (node);
      g_string_append_c (out, '[');
      for (guint i = 0; i < json_array_get_length (array); i++) {
        if (i)
          g_string_append (out, ", ");
        append_node (out, json_array_get_element (array, i));
      }
      g_string_append_c (out, ']');
      break;
    }
    case JSON_NODE_VALUE:
      if (json_node_get_value_type (node) == G_TYPE_DOUBLE) {
        const double v = json_node_get_double (node);
        char buffer[G_ASCII_DTOSTR_BUF_SIZE];
        if (!isfinite (v)) {
          g_string_append (out, "null");
          break;
        }
        g_ascii_formatd (buffer, sizeof buffer, "%.15g", v);
        if (g_ascii_strtod (buffer, NULL) != v)
          g_ascii_formatd (buffer, sizeof buffer, "%.17g", v);
        g_string_append (out, buffer);
        /* Still a number with a fraction or exponent, as json-glib's. */
        if (!strpbrk (buffer, ".eE"))
          g_string_append (out, ".0");
      } else {
        g_autofree char *text = json_to_string (node, FALSE);
        g_string_append (out, text);
      }
      break;
    case JSON_NODE_NULL:
      g_string_append (out, "null");
      break;
  }
}

char *
sonar_json_to_line (JsonNode * node)
{
  GString *out = g_string_new (NULL);

  append_node (out, node);
  return g_string_free (out, FALSE);
}
