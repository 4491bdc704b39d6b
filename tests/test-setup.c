/* test-setup.c: the sensor description, its files and its event. */
#include <gio/gio.h>
#include <json-glib/json-glib.h>
#include <string.h>

#include <glib/gstdio.h>
#include <math.h>
#include <sndfile.h>

#include "sonar-interp.h"
#include "sonar-sensor-file.h"
#include "sonar-setup.h"
#include "sonar-test-util.h"
#include "sonar-error.h"

/* The built-in microphone table is the published eRTIS layout. */
static void
test_default_geometry_is_ertis (void)
{
  g_autofree char *path = sonar_test_source_path
      ("data/ertis-microphones.json");
  g_autoptr (JsonParser) parser = json_parser_new ();
  SonarGeometry geometry;
  JsonArray *mics;

  g_assert_true (json_parser_load_from_file (parser, path, NULL));
  mics = json_object_get_array_member (json_node_get_object
      (json_parser_get_root (parser)), "microphones");
  sonar_geometry_init_default (&geometry);
  g_assert_cmpuint (geometry.n_microphones, ==, 32);
  g_assert_cmpuint (json_array_get_length (mics), ==, 32);
  for (guint j = 0; j < 32; j++) {
    JsonArray *p = json_array_get_array_element (mics, j);
    g_assert_cmpfloat (geometry.microphones[j].x, ==,
        json_array_get_double_element (p, 0));
    g_assert_cmpfloat (geometry.microphones[j].y, ==,
        json_array_get_double_element (p, 1));
    g_assert_cmpfloat (geometry.microphones[j].z, ==,
        json_array_get_double_element (p, 2));
  }
  g_assert_cmpuint (geometry.n_emitters, ==, 8);
  /* Emitters sit around the microphones, outside their aperture. */
  for (guint n = 0; n < 8; n++) {
    double nearest = G_MAXDOUBLE;
    for (guint j = 0; j < 32; j++)
      nearest = MIN (nearest, sonar_vec3_norm (sonar_vec3_sub
              (geometry.emitters[n], geometry.microphones[j])));
    g_assert_cmpfloat (nearest, >, 0.005);
    g_assert_cmpfloat (sonar_vec3_norm (geometry.emitters[n]), <, 0.06);
  }
  g_assert_no_error (NULL);
  g_assert_true (sonar_geometry_validate (&geometry, NULL));
  sonar_geometry_clear (&geometry);
}

static void
test_geometry_file (void)
{
  g_autofree char *shared = sonar_test_source_path
      ("data/ertis-microphones.json");
  g_autofree char *with_emitters = sonar_test_write_temp ("array.json",
      "{\"units\": \"m\", \"microphones\": [[0.01, 0, 0], [-0.01, 0, 0]],"
      " \"emitters\": [[0, 0.02, 0]]}");
  SonarGeometry g;
  GError *error = NULL;

  /* The published microphone file loads as is, keeping default emitters. */
  g_assert_true (sonar_geometry_load_file (&g, shared, &error));
  g_assert_no_error (error);
  g_assert_cmpuint (g.n_microphones, ==, 32);
  g_assert_cmpuint (g.n_emitters, ==, 8);
  sonar_geometry_clear (&g);

  g_assert_true (sonar_geometry_load_file (&g, with_emitters, &error));
  g_assert_cmpuint (g.n_microphones, ==, 2);
  g_assert_cmpuint (g.n_emitters, ==, 1);
  g_assert_cmpfloat (g.emitters[0].y, ==, 0.02);
  sonar_geometry_clear (&g);
}

typedef struct
{
  const char *json;
  const char *expected;         /* part of the error message */
} BadFile;

static void
test_geometry_file_errors (void)
{
  const BadFile cases[] = {
    {"not json", "array.json: "},
    {"[1, 2]", "the top level must be a JSON object"},
    {"{\"emitters\": [[0, 0, 0]]}", "missing member \"microphones\""},
    {"{\"microphones\": [[0, 0]]}", "\"microphones\"[0] must be an array of 3"},
    {"{\"microphones\": [[0, 0, \"a\"]]}", "\"microphones\"[0] must be"},
    {"{\"microphones\": []}", "\"microphones\" has 0 entries"},
    {"{\"microphones\": [[0, 0, 0], [0, 0, 0]]}",
        "microphones 0 and 1 are at the same position"},
    {"{\"microphones\": [[5, 0, 0]]}", "is not within 1 m of the array"},
    {"{\"microphones\": [[0, 0, 0]], \"units\": \"mm\"}",
        "\"units\" must be \"m\""},
    {"{\"microphones\": [[0, 0, 0]], \"emiters\": []}",
        "unknown member \"emiters\""},
  };
  for (guint i = 0; i < G_N_ELEMENTS (cases); i++) {
    g_autofree char *path = sonar_test_write_temp ("array.json",
        cases[i].json);
    SonarGeometry g = { 0 };
    GError *error = NULL;

    g_assert_false (sonar_geometry_load_file (&g, path, &error));
    g_assert_nonnull (error);
    g_test_message ("%s -> %s", cases[i].json, error->message);
    g_assert_nonnull (strstr (error->message, cases[i].expected));
    /* Every message names the file. */
    g_assert_nonnull (strstr (error->message, path));
    g_assert_null (g.microphones);
    g_error_free (error);
  }
  {
    SonarGeometry g = { 0 };
    GError *error = NULL;
    g_assert_false (sonar_geometry_load_file (&g, "/nonexistent/a.json",
            &error));
    g_assert_error (error, SONAR_ERROR, SONAR_ERROR_FILE);
    g_assert_nonnull (strstr (error->message, "/nonexistent/a.json"));
    g_error_free (error);
  }
}

static void
test_waveforms_file (void)
{
  g_autofree char *good = sonar_test_write_temp ("wf.json",
      "{\"sample-rate\": 450000, \"waveforms\": [" "[0,1,0,-1,0,1,0,-1,0,1,0,-1,0,1,0,-1],"
      "[1,0,-1,0,1,0,-1,0,1,0,-1,0,1,0,-1,0.5]]}");
  const BadFile bad[] = {
    {"{\"waveforms\": [[0]]}", "missing member \"sample-rate\""},
    {"{\"sample-rate\": -1, \"waveforms\": [[0]]}", "must be positive"},
    {"{\"sample-rate\": 450000, \"waveforms\": []}", "must be an array of 1"},
    {"{\"sample-rate\": 450000, \"waveforms\": [[0, 1]]}",
        "\"waveforms\"[0] must be an array of 16"},
    {"{\"sample-rate\": 450000, \"waveforms\": [[0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0],"
          "[0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0]]}", "as long as the first"},
    {"{\"sample-rate\": 450000, \"waveforms\": [[0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,\"x\"]]}",
        "\"waveforms\"[0][15] must be a finite number"},
  };
  guint n, length;
  double rate, low, high;
  GError *error = NULL;
  g_autofree float *w = sonar_waveforms_load_file (good, &n, &length, &rate,
      &low, &high, &error);

  g_assert_no_error (error);
  g_assert_cmpuint (n, ==, 2);
  g_assert_cmpuint (length, ==, 16);
  g_assert_cmpfloat (rate, ==, 450000);
  g_assert_cmpfloat (w[1], ==, 1.0f);
  g_assert_cmpfloat (w[16 + 15], ==, 0.5f);
  for (guint i = 0; i < G_N_ELEMENTS (bad); i++) {
    g_autofree char *path = sonar_test_write_temp ("wf.json", bad[i].json);
    float *none = sonar_waveforms_load_file (path, &n, &length, &rate,
        &low, &high, &error);
    g_assert_null (none);
    g_test_message ("%s", error->message);
    g_assert_nonnull (strstr (error->message, bad[i].expected));
    g_clear_error (&error);
  }
}

/* A set-up of 32-sample waveforms. */
static SonarSetup *
small_setup_new (double sample_rate, double speed_of_sound, double band_low,
    double band_high, const SonarGeometry * geometry,
    const float *waveforms, guint ping_length, GError ** error)
{
  return sonar_setup_new (&(SonarSetupParams) {
        .sample_rate = sample_rate, .speed_of_sound = speed_of_sound,
        .band_low = band_low, .band_high = band_high, .geometry = geometry,
        .waveform_length = 32, .waveforms = waveforms,
        .ping_length = ping_length}, error);
}

static SonarSetup *
make_small_setup (guint ping_length, GError ** error)
{
  SonarGeometry g;
  float waveforms[8 * 32];
  SonarSetup *setup;

  for (guint i = 0; i < G_N_ELEMENTS (waveforms); i++)
    waveforms[i] = (float) sin (0.3 * i);
  sonar_geometry_init_default (&g);
  setup = small_setup_new (450000, 343, 20000, 80000, &g, waveforms,
      ping_length, error);
  sonar_geometry_clear (&g);
  return setup;
}

static void
test_setup_validation (void)
{
  GError *error = NULL;
  g_autoptr (SonarSetup) setup = make_small_setup (1000, &error);
  SonarGeometry g;
  float nan_wave[8 * 32] = { 0 };

  g_assert_no_error (error);
  g_assert_cmpuint (setup->geometry.n_microphones, ==, 32);
  g_assert_cmpfloat (sonar_setup_waveform (setup, 1)[0], ==,
      (float) sin (0.3 * 32));

  g_assert_null (make_small_setup (10, &error));
  g_assert_nonnull (strstr (error->message, "ping length 10 samples"));
  g_clear_error (&error);

  sonar_geometry_init_default (&g);
  g_assert_null (small_setup_new (450000, 343, 90000, 80000, &g, nan_wave,
          100, &error));
  g_assert_nonnull (strstr (error->message, "band 90000 to 80000 Hz"));
  g_clear_error (&error);
  g_assert_null (small_setup_new (450000, 3430, 20000, 80000, &g, nan_wave,
          100, &error));
  g_assert_nonnull (strstr (error->message, "speed of sound 3430 m/s"));
  g_clear_error (&error);
  nan_wave[40] = NAN;
  g_assert_null (small_setup_new (450000, 343, 20000, 80000, &g, nan_wave,
          100, &error));
  g_assert_nonnull (strstr (error->message,
          "waveform of emitter 1 has a non-finite sample at 8"));
  g_clear_error (&error);
  sonar_geometry_clear (&g);
}

/* The event carries the whole set-up, bit for bit. */
/* A sensor description of 2 microphones on a line and 2 emitters, with
 * @extra members (ending in a comma), 20-sample waveforms and (unless
 * @extra gives one) a ping period of 10 ms. */
static char *
sensor_json (const char *extra)
{
  return g_strdup_printf ("{%s%s \"sample-rate\": 100000, "
      "\"microphones\": [[-0.01, 0, 0], [0.01, 0, 0]], \"emitters\": "
      "[[0, 0.02, 0], [0, -0.02, 0]], \"waveforms\": ["
      "[0,1,0,-1,0,1,0,-1,0,1,0,-1,0,1,0,-1,0,1,0,-1],"
      "[1,0,-1,0,1,0,-1,0,1,0,-1,0,1,0,-1,0,1,0,-1,0]]}", extra,
      strstr (extra, "\"ping-period\"") ? "" : " \"ping-period\": 0.01,");
}

/* The sensor file's members land where they belong; a saved set-up loads
 * back equal. */
static void
test_sensor_file (void)
{
  g_autofree char *text = sensor_json ("\"speed-of-sound\": 340, "
      "\"trigger-offset\": 0.0005, \"ping-length\": 800, "
      "\"field-of-view\": \"fan\", \"band\": [10000, 40000],");
  g_autofree char *path = sonar_test_write_temp ("sensor.json", text);
  g_autofree char *saved = sonar_test_write_temp ("saved.json", "{}");
  GError *error = NULL;
  g_autoptr (SonarSetup) setup = sonar_sensor_file_load (path, &error);
  g_autoptr (SonarSetup) again = NULL;

  g_assert_no_error (error);
  g_assert_cmpfloat (setup->sample_rate, ==, 100000);
  g_assert_cmpfloat (setup->speed_of_sound, ==, 340);
  g_assert_cmpfloat (setup->band_low, ==, 10000);
  g_assert_cmpuint (setup->geometry.n_microphones, ==, 2);
  g_assert_cmpuint (setup->waveform_length, ==, 20);
  g_assert_cmpuint (setup->ping_length, ==, 800);
  g_assert_cmpfloat (setup->ping_period, ==, 0.01);
  g_assert_cmpfloat (setup->ping_stride, ==, 1000);
  g_assert_cmpuint (setup->trigger_offset, ==, 50);
  g_assert_cmpuint (sonar_setup_ping_start (setup, 3), ==, 3050);
  g_assert_cmpint (setup->field_of_view, ==, SONAR_FIELD_OF_VIEW_FAN);

  g_assert_true (sonar_sensor_file_save (setup, saved, &error));
  again = sonar_sensor_file_load (saved, &error);
  g_assert_no_error (error);
  g_assert_true (sonar_setup_equal (setup, again));
}

/* A planar array resolves the hemisphere, a line of elements only the
 * fan; a continuous recording's pings fill the period. */
static void
test_sensor_file_defaults (void)
{
  g_autofree char *text = sensor_json ("");
  g_autofree char *path = sonar_test_write_temp ("sensor.json", text);
  g_autoptr (SonarSetup) setup = sonar_sensor_file_load (path, NULL);
  SonarGeometry line = { 0 };

  g_assert_nonnull (setup);
  g_assert_cmpint (setup->field_of_view, ==,
      SONAR_FIELD_OF_VIEW_HEMISPHERE);
  g_assert_cmpuint (setup->ping_length, ==, 1000);
  g_assert_cmpuint (setup->trigger_offset, ==, 0);
  g_assert_cmpfloat (setup->speed_of_sound, ==, 343);

  sonar_geometry_copy (&line, &setup->geometry);
  line.emitters[0].y = line.emitters[1].y = 0.0;
  line.emitters[0].x = 0.03;
  g_assert_cmpint (sonar_geometry_field_of_view (&line), ==,
      SONAR_FIELD_OF_VIEW_FAN);
  sonar_geometry_clear (&line);
}

/* Emitters that start late send their waveform delayed, read between
 * samples for a fraction of a sample; a trigger between two samples adds
 * its fraction to every emitter. */
static void
test_sensor_file_delays (void)
{
  /* 25 us at 100 kHz: 2.5 samples; trigger 12.5 samples -> 12 + 0.5. */
  g_autofree char *text = sensor_json ("\"emitter-delays\": [0.00002, "
      "0.000025], \"trigger-offset\": 0.000125,");
  g_autofree char *path = sonar_test_write_temp ("sensor.json", text);
  GError *error = NULL;
  g_autoptr (SonarSetup) setup = sonar_sensor_file_load (path, &error);
  const float row0[20] = { 0, 1, 0, -1, 0, 1, 0, -1, 0, 1, 0, -1, 0, 1, 0,
    -1, 0, 1, 0, -1
  };
  g_autoptr (SonarInterp) interp = sonar_interp_new (row0, 20);
  const float *w0, *w1;

  g_assert_no_error (error);
  g_assert_cmpuint (setup->trigger_offset, ==, 12);
  /* Emitter 0: 2 + 0.5 samples late; emitter 1: 2.5 + 0.5 = 3, exact. */
  g_assert_cmpuint (setup->waveform_length, ==, 23);
  w0 = sonar_setup_waveform (setup, 0);
  w1 = sonar_setup_waveform (setup, 1);
  for (guint i = 0; i < 3; i++)
    g_assert_cmpfloat (w1[i], ==, 0.0f);
  for (guint i = 0; i < 20; i++) {
    g_assert_cmpfloat (w1[3 + i], ==, (i % 2) ? 0.0f : (i % 4 ? -1.0f :
            1.0f));
    g_assert_cmpfloat (w0[3 + i], ==, sonar_interp_at (interp, i + 0.5));
  }
}

/* Every problem names the file and the member. */
static void
test_sensor_file_errors (void)
{
  const BadFile bad[] = {
    {"{\"sample-rate\": 100000}", "missing member \"ping-period\""},
    {"\"ping-period\": -1,", "\"ping-period\" is -1 s (allowed: above 0"},
    {"\"trigger-offset\": -0.1,", "\"trigger-offset\" is -0.1 s (allowed: 0"},
    {"\"field-of-view\": \"cone\",", "\"field-of-view\" is \"cone\" "
          "(allowed: \"fan\", \"hemisphere\")"},
    {"\"emitter-delays\": [0],", "\"emitter-delays\" must be an array of 2 "
          "numbers"},
    {"\"emitter-delays\": [0, 2],", "\"emitter-delays\"[1] is 2 s (allowed: "
          "0 to 1 s)"},
    {"\"ping-length\": 1500,", "the windows would overlap"},
    {"\"ping-length\": 100, \"emitter-delays\": [0, 0.002],", "the "
          "emissions (20 samples) delayed by \"emitter-delays\" (up to "
          "0.002 s) span 220 samples, more than \"ping-length\" (100)"},
    {"\"ping-length\": 100.5,", "\"ping-length\" must be a whole number of "
          "samples"},
    {"\"velocity\": 3,", "unknown member \"velocity\""},
    {"{\"sample-rate\": 100000, \"ping-period\": 0.01, \"microphones\": "
          "[[0, 0, 0]], \"emitters\": [[0, 0.01, 0]], \"waveforms\": "
          "\"nowhere.wav\"}", "\"waveforms\": cannot read"},
    {"{\"sample-rate\": 100000, \"ping-period\": 0.01, \"microphones\": "
          "[[0, 0, 0]], \"emitters\": [[0, 0.01, 0]], \"waveforms\": 3}",
        "\"waveforms\" must be a WAV file name or an array"},
  };

  for (guint i = 0; i < G_N_ELEMENTS (bad); i++) {
    g_autofree char *text = bad[i].json[0] == '{' ? g_strdup (bad[i].json) :
        sensor_json (bad[i].json);
    g_autofree char *path = sonar_test_write_temp ("bad-sensor.json", text);
    GError *error = NULL;
    SonarSetup *none = sonar_sensor_file_load (path, &error);

    g_assert_null (none);
    g_assert_nonnull (error);
    g_test_message ("%s", error->message);
    g_assert_true (g_str_has_prefix (error->message, path));
    if (!strstr (error->message, bad[i].expected))
      g_error ("\"%s\" does not say \"%s\"", error->message,
          bad[i].expected);
    g_error_free (error);
  }
}

/* The emissions as a WAV, one channel per emitter, next to the
 * description; 16-bit samples are fractions of full scale. */
static void
test_sensor_file_emissions_wav (void)
{
  g_autofree char *dir = g_dir_make_tmp ("sonar-sensor-XXXXXX", NULL);
  g_autofree char *wav = g_build_filename (dir, "emissions.wav", NULL);
  g_autofree char *json = g_build_filename (dir, "sensor.json", NULL);
  SF_INFO info = {.samplerate = 100000,.channels = 2,
    .format = SF_FORMAT_WAV | SF_FORMAT_PCM_16
  };
  SNDFILE *file = sf_open (wav, SFM_WRITE, &info);
  short frames[2 * 32];
  GError *error = NULL;
  g_autoptr (SonarSetup) setup = NULL;

  g_assert_nonnull (file);
  for (guint i = 0; i < 32; i++) {
    frames[2 * i] = (short) (i * 1000);
    frames[2 * i + 1] = (short) (-16384);
  }
  g_assert_cmpint (sf_writef_short (file, frames, 32), ==, 32);
  sf_close (file);
  g_assert_true (g_file_set_contents (json, "{\"sample-rate\": 100000, "
          "\"ping-period\": 0.01, \"microphones\": [[0, 0, 0]], "
          "\"emitters\": [[0, 0.01, 0], [0.01, 0, 0]], \"waveforms\": "
          "\"emissions.wav\"}", -1, NULL));
  setup = sonar_sensor_file_load (json, &error);
  g_assert_no_error (error);
  g_assert_cmpuint (setup->waveform_length, ==, 32);
  g_assert_cmpfloat (sonar_setup_waveform (setup, 0)[3], ==, 3000 /
      32768.0f);
  g_assert_cmpfloat (sonar_setup_waveform (setup, 1)[7], ==, -0.5f);
  /* A description whose rate is not the file's says both as they are. */
  g_assert_true (g_file_set_contents (json, "{\"sample-rate\": 100000.5, "
          "\"ping-period\": 0.01, \"microphones\": [[0, 0, 0]], "
          "\"emitters\": [[0, 0.01, 0], [0.01, 0, 0]], \"waveforms\": "
          "\"emissions.wav\"}", -1, NULL));
  g_assert_null (sonar_sensor_file_load (json, &error));
  g_assert_nonnull (error);
  g_test_message ("%s", error->message);
  g_assert_nonnull (strstr (error->message, "samples at 100000 Hz; "));
  g_assert_nonnull (strstr (error->message, "at the sample-rate 100000.5 "
          "Hz"));
  g_clear_error (&error);
  g_unlink (wav);
  g_unlink (json);
  g_rmdir (dir);
}

/* A copy of @setup with @geometry (NULL: its own) and @waveforms. */
static SonarSetup *
setup_with (const SonarSetup * setup, const SonarGeometry * geometry,
    const float *waveforms)
{
  SonarSetup *copy = sonar_setup_new (&(SonarSetupParams) {
        .sample_rate = setup->sample_rate,
        .speed_of_sound = setup->speed_of_sound,
        .band_low = setup->band_low, .band_high = setup->band_high,
        .geometry = geometry ? geometry : &setup->geometry,
        .waveform_length = setup->waveform_length, .waveforms = waveforms,
        .ping_length = setup->ping_length,
        .field_of_view = SONAR_FIELD_OF_VIEW_HEMISPHERE}, NULL);
  g_assert_nonnull (copy);
  return copy;
}

/* A copy of @setup with emitter @late's waveform @delay samples later
 * (every row longer by it). */
static SonarSetup *
setup_with_delay (const SonarSetup * setup, guint late, double delay)
{
  const guint n_emitters = setup->geometry.n_emitters;
  g_autofree double *delays = g_new0 (double, n_emitters);
  g_autofree float *delayed = NULL;
  guint length;
  SonarSetup *copy;

  delays[late] = delay;
  delayed = sonar_waveforms_delay (setup->waveforms, n_emitters,
      setup->waveform_length, delays, &length);
  copy = sonar_setup_new (&(SonarSetupParams) {
        .sample_rate = setup->sample_rate,
        .speed_of_sound = setup->speed_of_sound,
        .band_low = setup->band_low,.band_high = setup->band_high,
        .geometry = &setup->geometry,.waveform_length = length,
        .waveforms = delayed,.ping_length = setup->ping_length + length,
        .field_of_view = setup->field_of_view}, NULL);
  g_assert_nonnull (copy);
  return copy;
}

/* The Doppler hypotheses' spacing follows the emissions: the built-in
 * sensor's 0.3 m/s; one emitter 14 ms late (its energy centred 14 ms
 * after the others'): c / (6 f0 D) = 0.082; all emissions ten times as
 * long (89 ms of the same noise, stretched): 0.85 c / (2 f0 T) = 0.033. */
static void
test_hypothesis_spacing (void)
{
  g_autoptr (SonarSetup) setup = sonar_test_default_setup (17262);
  g_autoptr (SonarSetup) late = setup_with_delay (setup, 7, 0.014 * 450000);
  const guint n_emitters = setup->geometry.n_emitters;
  const guint length = 10 * setup->waveform_length;
  g_autofree float *stretched = g_new (float, (gsize) n_emitters * length);
  g_autoptr (SonarSetup) longer = NULL;
  const double f0 = 50000.0, c = setup->speed_of_sound;

  g_assert_cmpfloat (sonar_setup_hypothesis_spacing (setup), ==, 0.3);
  g_test_message ("one emitter 14 ms late: %.4f m/s",
      sonar_setup_hypothesis_spacing (late));
  g_assert_cmpfloat (fabs (sonar_setup_hypothesis_spacing (late) - c /
          (6.0 * f0 * 0.014)), <, 0.004);
  for (guint n = 0; n < n_emitters; n++)
    for (guint i = 0; i < length; i++)
      stretched[(gsize) n * length + i] = sonar_setup_waveform (setup,
          n)[i / 10];
  longer = sonar_setup_new (&(SonarSetupParams) {
        .sample_rate = setup->sample_rate,
        .speed_of_sound = c,.band_low = setup->band_low,
        .band_high = setup->band_high,.geometry = &setup->geometry,
        .waveform_length = length,.waveforms = stretched,
        .ping_length = setup->ping_length + length,
        .field_of_view = setup->field_of_view}, NULL);
  g_assert_nonnull (longer);
  g_test_message ("emissions of 89 ms: %.4f m/s",
      sonar_setup_hypothesis_spacing (longer));
  g_assert_cmpfloat (fabs (sonar_setup_hypothesis_spacing (longer) - 0.85 *
          c / (2.0 * f0 * length / 450000.0)), <, 0.003);
}

/* A set-up that cannot do what the chain needs says so, in words: no
 * aperture, an emitter sending nothing or out of band, emissions too alike
 * to tell apart. The default sensor passes. */
static void
test_setup_check (void)
{
  g_autoptr (SonarSetup) setup = sonar_test_default_setup (17262);
  const gsize n = (gsize) setup->geometry.n_emitters *
      setup->waveform_length;
  g_autofree float *w = g_memdup2 (setup->waveforms, sizeof (float) * n);
  g_autofree char *fine = sonar_setup_check (setup);
  SonarGeometry point = { 0 };
  SonarVec3 origin = { 0, 0, 0 }, above = { 0, 0.0005, 0 };

  g_assert_null (fine);
  /* Emitter 3 silent, emitter 5 a 5 kHz tone, emitter 7 a copy of 6. */
  memset (w + 3 * setup->waveform_length, 0, sizeof (float) *
      setup->waveform_length);
  for (guint i = 0; i < setup->waveform_length; i++)
    w[5 * setup->waveform_length + i] = (float) sin (2 * G_PI * 5000.0 * i /
        setup->sample_rate);
  memcpy (w + 7 * setup->waveform_length, w + 6 * setup->waveform_length,
      sizeof (float) * setup->waveform_length);
  {
    g_autoptr (SonarSetup) bad = setup_with (setup, NULL, w);
    g_autofree char *problems = sonar_setup_check (bad);
    g_test_message ("%s", problems);
    g_assert_nonnull (strstr (problems, "emitter 3 sends nothing"));
    g_assert_nonnull (strstr (problems, "emitter 5 sends only 0 % of its "
            "energy in the band"));
    g_assert_nonnull (strstr (problems, "the emissions of emitters 6 and 7 "
            "are too alike to be told apart (cross-correlation peak 0.0 dB"));
  }
  /* One microphone and one emitter half a millimetre apart. */
  point.n_microphones = point.n_emitters = 1;
  point.microphones = &origin;
  point.emitters = &above;
  {
    g_autoptr (SonarSetup) blind = sonar_setup_new (&(SonarSetupParams) {
          .sample_rate = setup->sample_rate, .speed_of_sound = 343,
          .band_low = setup->band_low, .band_high = setup->band_high,
          .geometry = &point, .waveform_length = setup->waveform_length,
          .waveforms = setup->waveforms, .ping_length = 17262}, NULL);
    g_autofree char *problems = sonar_setup_check (blind);
    g_test_message ("%s", problems);
    g_assert_cmpstr (problems, ==, "the array (1 microphones, 1 emitters) "
        "spans less than a quarter wavelength (1.1 mm) along x: it cannot "
        "resolve azimuth (a line along y images elevation alone: "
        "mimobeamform azimuth-count=1 and elevation's range)");
  }
  /* A line along x imaged as a hemisphere: no elevation. */
  {
    SonarVec3 line[2] = { {-0.05, 0, 0}, {0.05, 0, 0} };
    SonarGeometry horizontal = { 0 };
    horizontal.n_microphones = 2;
    horizontal.microphones = line;
    horizontal.n_emitters = 1;
    horizontal.emitters = &origin;
    {
      g_autoptr (SonarSetup) flat = sonar_setup_new (&(SonarSetupParams) {
            .sample_rate = setup->sample_rate,.speed_of_sound = 343,
            .band_low = setup->band_low,.band_high = setup->band_high,
            .geometry = &horizontal,.waveform_length = setup->waveform_length,
            .waveforms = setup->waveforms,.ping_length = 17262,
            .field_of_view = SONAR_FIELD_OF_VIEW_HEMISPHERE}, NULL);
      g_autofree char *problems = sonar_setup_check (flat);
      g_test_message ("%s", problems);
      g_assert_nonnull (problems);
      g_assert_nonnull (strstr (problems, "along y: it cannot resolve "
              "elevation (a line along x: the sensor file's field-of-view "
              "\"fan\")"));
    }
  }
}

/* The default sensor the benchmark and the FFTW wisdom use: sonarsrc's
 * without files, its 5 m window the 17,262 samples the benchmark prints,
 * its waveforms the default ones (seed 1). */
static void
test_default_setup (void)
{
  GError *error = NULL;
  g_autoptr (SonarSetup) setup = sonar_setup_new_default (5.0, &error);
  g_autoptr (SonarSetup) longer = sonar_setup_new_default (12.7, &error);
  g_autoptr (SonarSetup) reference = sonar_test_default_setup (17262);

  g_assert_no_error (error);
  g_assert_cmpuint (setup->geometry.n_microphones, ==, 32);
  g_assert_cmpuint (setup->geometry.n_emitters, ==, 8);
  g_assert_cmpuint (setup->ping_length, ==, 17262);
  g_assert_cmpuint (longer->ping_length, >, setup->ping_length);
  g_assert_cmpfloat (setup->speed_of_sound, ==, 343.0);
  g_assert_cmpuint (setup->waveform_length, ==, reference->waveform_length);
  g_assert_cmpmem (sonar_setup_waveform (setup, 7), sizeof (float) *
      setup->waveform_length, sonar_setup_waveform (reference, 7),
      sizeof (float) * reference->waveform_length);
}

int
main (int argc, char **argv)
{
  g_test_init (&argc, &argv, NULL);
  g_test_add_func ("/setup/default-geometry-is-ertis",
      test_default_geometry_is_ertis);
  g_test_add_func ("/setup/geometry-file", test_geometry_file);
  g_test_add_func ("/setup/default", test_default_setup);
  g_test_add_func ("/setup/geometry-file-errors", test_geometry_file_errors);
  g_test_add_func ("/setup/waveforms-file", test_waveforms_file);
  g_test_add_func ("/setup/validation", test_setup_validation);
  g_test_add_func ("/setup/check", test_setup_check);
  g_test_add_func ("/setup/hypothesis-spacing", test_hypothesis_spacing);
  g_test_add_func ("/setup/sensor-file", test_sensor_file);
  g_test_add_func ("/setup/sensor-file-defaults", test_sensor_file_defaults);
  g_test_add_func ("/setup/sensor-file-delays", test_sensor_file_delays);
  g_test_add_func ("/setup/sensor-file-errors", test_sensor_file_errors);
  g_test_add_func ("/setup/sensor-file-emissions-wav",
      test_sensor_file_emissions_wav);
  return g_test_run ();
}
