/* test-golden.c: the whole chain's detections on the presets against
 * files committed before the steering and clustering refactors
 * (tests/data/golden-*.jsonl), to the last digit the JSON prints (within
 * one unit of it for the numbers printed finer than their uncertainty,
 * which gcc and clang may round apart): a refactor that changes what
 * users see fails here.
 *
 * Rejected centroids are kept (keep-rejected=true) so that the ghosts'
 * positions, which the coherence prescreen refines, are guarded too.
 * Members are compared by name, so a key added to the JSON later does not
 * break the comparison; a key of the file missing from the output does.
 *
 * SONAR_UPDATE_GOLDEN=1 rewrites the files from the current build instead
 * (only after a change meant to alter the detections; say why in its
 * commit). */
#include <gst/app/gstappsink.h>
#include <math.h>
#include <json-glib/json-glib.h>
#include <string.h>

#include "sonar-test-gst.h"

typedef struct
{
  const char *name;             /* tests/data/golden-<name>.jsonl */
  const char *source;           /* sonarsrc's properties */
  const char *bank;             /* dopplerbank's properties */
  const char *imager;           /* mimobeamform's properties */
} GoldenCase;

/* The README's recipes: Fig. 10 with its +-0.4 / 0.02 m/s bank, Fig. 9
 * and the default scene with the elements' defaults; and a small 3-D
 * image, whose steering has elevations. */
static const GoldenCase cases[] = {
  {"default", "num-buffers=2", "", ""},
  {"fig9", "scene=fig9 num-buffers=1", "", ""},
  {"fig10", "scene=fig10 num-buffers=3",
      "velocity-min=-0.4 velocity-max=0.4 velocity-step=0.02", ""},
  {"default-3d", "num-buffers=1",
        "velocity-min=-1.5 velocity-max=1.5",
      "azimuth-min=-45 azimuth-max=45 azimuth-count=31 elevation-min=-12 "
        "elevation-max=12 elevation-count=9"},
};

/* The JSON lines of the chain's output, one per ping. */
static GString *
run_chain (const GoldenCase * c)
{
  g_autofree char *launch = g_strdup_printf ("sonarsrc %s ! dopplerbank %s "
      "! mimobeamform %s ! wardcluster ! velocityest keep-rejected=true "
      "! appsink name=sink sync=false", c->source, c->bank, c->imager);
  g_autoptr (SonarTestRun) run = sonar_test_run (launch);
  g_autofree char *text = NULL;

  g_assert_null (run->error_text);
  text = sonar_test_run_text (run, "sink");
  return g_string_new (text);
}

static JsonObject *
parse_line (JsonParser * parser, const char *line)
{
  GError *error = NULL;

  json_parser_load_from_data (parser, line, -1, &error);
  g_assert_no_error (error);
  return json_node_get_object (json_parser_get_root (parser));
}

/* "<where> <name>=<value>": the text a failed comparison shows. */
static char *
describe_member (JsonObject * object, const char *name, const char *where)
{
  JsonNode *node = json_object_get_member (object, name);
  g_autofree char *value = node ? json_to_string (node, FALSE) :
      g_strdup ("(missing)");

  return g_strdup_printf ("%s: %s=%s", where, name, value);
}

/* One unit of the last decimal the JSON prints @name with
 * (sonar-contracts.c; 0 where it must match exactly). Positions,
 * directions and velocities are printed finer than their uncertainty, so
 * one at a rounding boundary rounds either way with gcc and clang, whose
 * floating-point contractions differ. */
static double
last_unit (const char *name)
{
  static const struct
  {
    const char *name;
    double unit;
  } units[] = {
    {"range", 1e-7}, {"x", 1e-7}, {"y", 1e-7}, {"z", 1e-7},
    {"azimuth", 1e-5}, {"elevation", 1e-5}, {"radial_velocity", 1e-6},
  };

  for (guint k = 0; k < G_N_ELEMENTS (units); k++)
    if (strcmp (name, units[k].name) == 0)
      return units[k].unit;
  return 0.0;
}

/* Whether member @name's @got is @want within one unit of its last
 * printed digit: the decimals above, and the uncertainties' third
 * significant digit. */
static gboolean
same_to_last_digit (const char *name, JsonNode * want, JsonNode * got)
{
  double w, g, unit;

  if (!JSON_NODE_HOLDS_VALUE (want) || !JSON_NODE_HOLDS_VALUE (got)
      || json_node_get_value_type (want) != G_TYPE_DOUBLE
      || json_node_get_value_type (got) != G_TYPE_DOUBLE)
    return FALSE;
  w = json_node_get_double (want);
  g = json_node_get_double (got);
  unit = g_str_has_suffix (name, "_sigma") ? (w > 0.0 ?
      pow (10.0, floor (log10 (w)) - 2.0) : 0.0) : last_unit (name);
  return unit > 0.0 && fabs (g - w) <= 1.000001 * unit;
}

/* Every member of @expected is in @actual with the same value (numbers as
 * parsed from their printed digits, within one unit of the last where
 * same_to_last_digit () says). */
static void
assert_members_equal (JsonObject * expected, JsonObject * actual,
    const char *where)
{
  g_autoptr (GList) names = json_object_get_members (expected);

  for (GList * l = names; l; l = l->next) {
    const char *name = l->data;
    JsonNode *want = json_object_get_member (expected, name);
    JsonNode *got = json_object_get_member (actual, name);

    if (JSON_NODE_HOLDS_ARRAY (want) && got && JSON_NODE_HOLDS_ARRAY (got))
      continue;                 /* the detections, compared one by one */
    if (!got || !(json_node_equal (want, got) || same_to_last_digit (name,
                want, got))) {
      g_autofree char *w = describe_member (expected, name, where);
      g_autofree char *g = describe_member (actual, name, where);
      g_assert_cmpstr (g, ==, w);
    }
  }
}

static void
compare_line (const char *expected, const char *actual, guint ping)
{
  g_autoptr (JsonParser) want_parser = json_parser_new ();
  g_autoptr (JsonParser) got_parser = json_parser_new ();
  JsonObject *want = parse_line (want_parser, expected);
  JsonObject *got = parse_line (got_parser, actual);
  JsonArray *want_dets = json_object_get_array_member (want, "detections");
  JsonArray *got_dets = json_object_get_array_member (got, "detections");
  g_autofree char *where = g_strdup_printf ("ping %u", ping);

  assert_members_equal (want, got, where);
  g_assert_cmpuint (json_array_get_length (got_dets), ==,
      json_array_get_length (want_dets));
  for (guint d = 0; d < json_array_get_length (want_dets); d++) {
    g_autofree char *det = g_strdup_printf ("ping %u, detection %u", ping, d);
    assert_members_equal (json_array_get_object_element (want_dets, d),
        json_array_get_object_element (got_dets, d), det);
  }
}

static void
test_golden (gconstpointer data)
{
  const GoldenCase *c = data;
  g_autofree char *basename = g_strdup_printf ("golden-%s.jsonl", c->name);
  g_autofree char *relative = g_build_filename ("tests", "data", basename,
      NULL);
  g_autofree char *path = sonar_test_source_path (relative);
  g_autoptr (GString) output = run_chain (c);
  g_autofree char *golden = NULL;
  g_auto (GStrv) want = NULL, got = NULL;
  GError *error = NULL;
  guint n;

  if (g_getenv ("SONAR_UPDATE_GOLDEN")) {
    g_file_set_contents (path, output->str, output->len, &error);
    g_assert_no_error (error);
    g_test_message ("wrote %s", path);
  }
  g_file_get_contents (path, &golden, NULL, &error);
  g_assert_no_error (error);
  want = g_strsplit (g_strchomp (golden), "\n", -1);
  got = g_strsplit (g_strchomp (output->str), "\n", -1);
  n = g_strv_length (want);
  g_assert_cmpuint (g_strv_length (got), ==, n);
  for (guint p = 0; p < n; p++)
    compare_line (want[p], got[p], p);
}

int
main (int argc, char **argv)
{
  sonar_test_init_gst (&argc, &argv);
  for (guint i = 0; i < G_N_ELEMENTS (cases); i++) {
    g_autofree char *name = g_strdup_printf ("/golden/%s", cases[i].name);
    g_test_add_data_func (name, &cases[i], test_golden);
  }
  return g_test_run ();
}
