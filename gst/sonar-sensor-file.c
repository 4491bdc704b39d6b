/* sonar-sensor-file.c: see sonar-sensor-file.h and docs/FORMATS.md. */
#include "sonar-sensor-file.h"
#include "sonar-error.h"
#include "sonar-json.h"

#include <gio/gio.h>
#include <math.h>
#include <sndfile.h>

#define SET_ERROR(error, ...) \
  g_set_error (error, SONAR_ERROR, SONAR_ERROR_FORMAT, __VA_ARGS__)

/* Times given in seconds that land within this many samples of a whole
 * sample are that sample: a file's decimal seconds must not turn an
 * integer delay into an interpolated one. */
#define WHOLE_SAMPLE_TOLERANCE 1e-6

static double
snap_to_sample (double samples)
{
  const double whole = round (samples);
  return fabs (samples - whole) < WHOLE_SAMPLE_TOLERANCE ? whole : samples;
}

/* The emissions as a WAV file, one channel per emitter: rows of samples
 * (integer formats read as fractions of full scale). */
static float *
load_emissions_wav (const char *path, const char *origin, double sample_rate,
    guint * n_rows, guint * length, GError ** error)
{
  SF_INFO info = { 0 };
  SNDFILE *file = sf_open (path, SFM_READ, &info);
  g_autofree float *frames = NULL;
  float *rows;

  if (!file) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_FILE,
        "%s: \"waveforms\": cannot read %s as a sound file (%s)", origin,
        path, sf_strerror (NULL));
    return NULL;
  }
  if (info.channels < 1 || info.channels > SONAR_MAX_EMITTERS
      || info.frames < 16 || info.frames > SONAR_MAX_WAVEFORM_LENGTH
      || info.samplerate != sample_rate) {
    SET_ERROR (error, "%s: \"waveforms\": %s holds %d channels of %"
        G_GINT64_FORMAT " samples at %d Hz; expected one channel per emitter "
        "(1 to %u), 16 to %u samples, at the sample-rate %.10g Hz", origin,
        path, info.channels, (gint64) info.frames, info.samplerate,
        SONAR_MAX_EMITTERS, SONAR_MAX_WAVEFORM_LENGTH, sample_rate);
    sf_close (file);
    return NULL;
  }
  frames = g_new (float, (gsize) info.frames * info.channels);
  if (sf_readf_float (file, frames, info.frames) != info.frames) {
    SET_ERROR (error, "%s: \"waveforms\": %s ends before its %" G_GINT64_FORMAT
        " samples", origin, path, (gint64) info.frames);
    sf_close (file);
    return NULL;
  }
  sf_close (file);
  rows = g_new (float, (gsize) info.frames * info.channels);
  for (int n = 0; n < info.channels; n++)
    for (sf_count_t i = 0; i < info.frames; i++)
      rows[(gsize) n * info.frames + i] = frames[i * info.channels + n];
  *n_rows = info.channels;
  *length = info.frames;
  return rows;
}

/* "waveforms": a WAV file's name (relative to the description's folder) or
 * the rows themselves. */
static float *
load_waveforms (JsonObject * root, const char *path, double sample_rate,
    guint * n_rows, guint * length, GError ** error)
{
  const char *name = NULL;
  float *rows = NULL;

  if (!json_object_has_member (root, "waveforms")) {
    SET_ERROR (error, "%s: missing member \"waveforms\"", path);
    return NULL;
  }
  if (JSON_NODE_HOLDS_ARRAY (json_object_get_member (root, "waveforms"))) {
    sonar_json_get_sample_rows (root, "waveforms", path, SONAR_MAX_EMITTERS,
        16, SONAR_MAX_WAVEFORM_LENGTH, SONAR_MAX_WAVEFORM_SAMPLE, &rows,
        n_rows, length, error);
    return rows;
  }
  if (!sonar_json_get_string (root, "waveforms", TRUE, path, &name, NULL)) {
    SET_ERROR (error, "%s: \"waveforms\" must be a WAV file name or an "
        "array of sample arrays, one per emitter", path);
    return NULL;
  }
  if (g_path_is_absolute (name)) {
    rows = load_emissions_wav (name, path, sample_rate, n_rows, length,
        error);
  } else {
    g_autofree char *folder = g_path_get_dirname (path);
    g_autofree char *wav = g_build_filename (folder, name, NULL);
    rows = load_emissions_wav (wav, path, sample_rate, n_rows, length,
        error);
  }
  return rows;
}

/* A member that must be a whole number of samples from @min to @max. */
static gboolean
get_samples (JsonObject * root, const char *member, const char *path,
    double min, double max, double *value, GError ** error)
{
  if (!sonar_json_get_double (root, member, FALSE, path, value, error))
    return FALSE;
  if (!(*value >= min && *value <= max)) {
    SET_ERROR (error, "%s: \"%s\" is %g samples (allowed: %g to %g)", path,
        member, *value, min, max);
    return FALSE;
  }
  return TRUE;
}

SonarSetup *
sonar_sensor_file_load (const char *path, GError ** error)
{
  static const char *const members[] = { "description", "sample-rate",
    "speed-of-sound", "microphones", "emitters", "waveforms", "band",
    "emitter-delays", "trigger-offset", "ping-period", "ping-length",
    "ping-stride", "field-of-view", "frame-id", NULL
  };
  g_autoptr (JsonNode) node = NULL;
  JsonObject *root;
  SonarSetupParams params;
  SonarGeometry geometry = { 0 };
  g_autofree float *emissions = NULL, *delayed = NULL;
  g_autofree double *delays = NULL;
  const char *view = NULL;
  guint n_rows = 0, length = 0, n_delays = 0;
  double trigger = 0.0, whole_trigger, ping_length = 0.0, latest = 0.0;
  double band[2] = { 0.0, 0.0 };
  SonarSetup *setup = NULL;

  sonar_setup_params_init (&params);
  node = sonar_json_parse (path, NULL, path, &root, error);
  if (!node)
    return NULL;
  if (!sonar_json_check_members (root, path, members, error)
      || !sonar_json_get_double (root, "sample-rate", TRUE, path,
          &params.sample_rate, error)
      || !sonar_json_get_double (root, "speed-of-sound", FALSE, path,
          &params.speed_of_sound, error)
      || !sonar_json_get_double (root, "ping-period", TRUE, path,
          &params.ping_period, error)
      || !sonar_json_get_double (root, "trigger-offset", FALSE, path,
          &trigger, error)
      || !sonar_json_get_string (root, "field-of-view", FALSE, path, &view,
          error)
      || !sonar_json_get_string (root, "frame-id", FALSE, path,
          &params.frame_id, error))
    return NULL;
  if (!(params.sample_rate >= 1000.0 && params.sample_rate <= 1e8)) {
    SET_ERROR (error, "%s: \"sample-rate\" is %g Hz (allowed: 1 kHz to "
        "100 MHz)", path, params.sample_rate);
    return NULL;
  }
  if (!(params.ping_period > 0.0
          && params.ping_period <= SONAR_MAX_PING_PERIOD)) {
    SET_ERROR (error, "%s: \"ping-period\" is %g s (allowed: above 0, up to "
        "%g s)", path, params.ping_period, SONAR_MAX_PING_PERIOD);
    return NULL;
  }
  if (!(trigger >= 0.0 && trigger <= SONAR_MAX_TRIGGER_OFFSET)) {
    SET_ERROR (error, "%s: \"trigger-offset\" is %g s (allowed: 0 to %g s)",
        path, trigger, SONAR_MAX_TRIGGER_OFFSET);
    return NULL;
  }
  if (view) {
    if (!sonar_field_of_view_from_string (view, &params.field_of_view)) {
      SET_ERROR (error, "%s: \"field-of-view\" is \"%s\" (allowed: \"fan\", "
          "\"hemisphere\")", path, view);
      return NULL;
    }
  }
  params.ping_stride = params.ping_period * params.sample_rate;
  if (!get_samples (root, "ping-stride", path, 1.0, G_MAXUINT32,
          &params.ping_stride, error))
    return NULL;
  ping_length = floor (params.ping_stride);
  if (!get_samples (root, "ping-length", path, 16.0, SONAR_MAX_PING_LENGTH,
          &ping_length, error))
    return NULL;
  if (ping_length != floor (ping_length)) {
    SET_ERROR (error, "%s: \"ping-length\" must be a whole number of "
        "samples, not %g", path, ping_length);
    return NULL;
  }
  params.ping_length = (guint) ping_length;

  if (!sonar_json_get_vec3_list (root, "microphones", TRUE, path,
          SONAR_MAX_MICROPHONES, &geometry.microphones,
          &geometry.n_microphones, error)
      || !sonar_json_get_vec3_list (root, "emitters", TRUE, path,
          SONAR_MAX_EMITTERS, &geometry.emitters, &geometry.n_emitters,
          error))
    goto done;
  if (!view)
    params.field_of_view = sonar_geometry_field_of_view (&geometry);

  emissions = load_waveforms (root, path, params.sample_rate, &n_rows,
      &length, error);
  if (!emissions)
    goto done;
  if (n_rows != geometry.n_emitters) {
    SET_ERROR (error, "%s: \"waveforms\" holds %u waveforms, but there are "
        "%u emitters", path, n_rows, geometry.n_emitters);
    goto done;
  }
  if (json_object_has_member (root, "band")) {
    g_autofree double *edges = NULL;
    guint two = 2;
    if (!sonar_json_get_double_list (root, "band", TRUE, path, 2, &edges,
            &two, error))
      goto done;
    band[0] = edges[0];
    band[1] = edges[1];
  } else {
    sonar_waveforms_estimate_band (emissions, n_rows, length,
        params.sample_rate, 1e-4, &band[0], &band[1]);
  }
  params.band_low = band[0];
  params.band_high = band[1];

  /* Late emitters and a trigger between two samples: each emitter's
   * waveform, delayed, counted from the trigger's sample. */
  n_delays = geometry.n_emitters;
  if (json_object_has_member (root, "emitter-delays")) {
    if (!sonar_json_get_double_list (root, "emitter-delays", TRUE, path,
            SONAR_MAX_EMITTERS, &delays, &n_delays, error))
      goto done;
  } else {
    delays = g_new0 (double, n_delays);
  }
  trigger = snap_to_sample (trigger * params.sample_rate);
  whole_trigger = floor (trigger);
  params.trigger_offset = (guint64) whole_trigger;
  for (guint n = 0; n < n_delays; n++) {
    if (!(delays[n] >= 0.0 && delays[n] <= SONAR_MAX_EMITTER_DELAY)) {
      SET_ERROR (error, "%s: \"emitter-delays\"[%u] is %g s (allowed: 0 to "
          "%g s)", path, n, delays[n], SONAR_MAX_EMITTER_DELAY);
      goto done;
    }
    latest = MAX (latest, delays[n]);
    delays[n] = snap_to_sample (delays[n] * params.sample_rate + trigger -
        whole_trigger);
  }
  delayed = sonar_waveforms_delay (emissions, n_rows, length, delays,
      &params.waveform_length);
  /* The setup's own check would speak of the delayed length alone. */
  if (params.waveform_length > params.ping_length && length <=
      params.ping_length) {
    SET_ERROR (error, "%s: the emissions (%u samples) delayed by "
        "\"emitter-delays\" (up to %g s) span %u samples, more than "
        "\"ping-length\" (%u)", path, length, latest,
        params.waveform_length, params.ping_length);
    goto done;
  }

  params.geometry = &geometry;
  params.waveforms = delayed;
  setup = sonar_setup_new (&params, error);
  if (!setup)
    g_prefix_error (error, "%s: ", path);
done:
  sonar_geometry_clear (&geometry);
  return setup;
}

static void
add_positions (JsonBuilder * builder, const char *member,
    const SonarVec3 * p, guint n)
{
  json_builder_set_member_name (builder, member);
  json_builder_begin_array (builder);
  for (guint i = 0; i < n; i++) {
    json_builder_begin_array (builder);
    json_builder_add_double_value (builder, p[i].x);
    json_builder_add_double_value (builder, p[i].y);
    json_builder_add_double_value (builder, p[i].z);
    json_builder_end_array (builder);
  }
  json_builder_end_array (builder);
}

static void
add_double (JsonBuilder * builder, const char *member, double value)
{
  json_builder_set_member_name (builder, member);
  json_builder_add_double_value (builder, value);
}

gboolean
sonar_sensor_file_save (const SonarSetup * setup, const char *path,
    GError ** error)
{
  const SonarGeometry *g = &setup->geometry;
  g_autoptr (JsonBuilder) builder = json_builder_new ();
  g_autoptr (JsonGenerator) generator = json_generator_new ();
  g_autoptr (JsonNode) root = NULL;
  GError *write_error = NULL;

  json_builder_begin_object (builder);
  json_builder_set_member_name (builder, "description");
  json_builder_add_string_value (builder, "sensor description written by "
      "gst-sonar-velocity (docs/FORMATS.md)");
  add_double (builder, "sample-rate", setup->sample_rate);
  add_double (builder, "speed-of-sound", setup->speed_of_sound);
  add_positions (builder, "microphones", g->microphones, g->n_microphones);
  add_positions (builder, "emitters", g->emitters, g->n_emitters);
  json_builder_set_member_name (builder, "band");
  json_builder_begin_array (builder);
  json_builder_add_double_value (builder, setup->band_low);
  json_builder_add_double_value (builder, setup->band_high);
  json_builder_end_array (builder);
  add_double (builder, "trigger-offset", setup->trigger_offset /
      setup->sample_rate);
  add_double (builder, "ping-period", setup->ping_period);
  add_double (builder, "ping-stride", setup->ping_stride);
  json_builder_set_member_name (builder, "ping-length");
  json_builder_add_int_value (builder, setup->ping_length);
  json_builder_set_member_name (builder, "field-of-view");
  json_builder_add_string_value (builder,
      sonar_field_of_view_to_string (setup->field_of_view));
  if (setup->frame_id[0]) {
    json_builder_set_member_name (builder, "frame-id");
    json_builder_add_string_value (builder, setup->frame_id);
  }
  json_builder_set_member_name (builder, "waveforms");
  json_builder_begin_array (builder);
  for (guint n = 0; n < g->n_emitters; n++) {
    const float *row = sonar_setup_waveform (setup, n);
    json_builder_begin_array (builder);
    for (guint i = 0; i < setup->waveform_length; i++)
      json_builder_add_double_value (builder, row[i]);
    json_builder_end_array (builder);
  }
  json_builder_end_array (builder);
  json_builder_end_object (builder);

  root = json_builder_get_root (builder);
  json_generator_set_root (generator, root);
  if (!json_generator_to_file (generator, path, &write_error)) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_FILE,
        "cannot write the sensor description %s: %s", path,
        write_error->message);
    g_error_free (write_error);
    return FALSE;
  }
  return TRUE;
}
