/* sonar-setup.c: see sonar-setup.h. */
#include "sonar-setup.h"
#include "sonar-json.h"
#include "sonar-spectrum.h"

#include <gio/gio.h>
#include <math.h>
#include <string.h>

#define SET_ERROR(error, ...) \
  g_set_error (error, G_IO_ERROR, G_IO_ERROR_INVALID_ARGUMENT, __VA_ARGS__)

/* Two elements closer than this are one element entered twice. */
#define MIN_ELEMENT_SPACING 1e-4
/* Elements must sit on a sensor, not metres away from it. */
#define MAX_ELEMENT_OFFSET 1.0
/* Largest magnitude of a waveform sample read from a file. */
#define MAX_SAMPLE 1e6

void
sonar_geometry_clear (SonarGeometry * geometry)
{
  g_clear_pointer (&geometry->microphones, g_free);
  g_clear_pointer (&geometry->emitters, g_free);
  geometry->n_microphones = geometry->n_emitters = 0;
}

void
sonar_geometry_copy (SonarGeometry * dest, const SonarGeometry * src)
{
  dest->n_microphones = src->n_microphones;
  dest->microphones = g_memdup2 (src->microphones,
      sizeof (SonarVec3) * src->n_microphones);
  dest->n_emitters = src->n_emitters;
  dest->emitters = g_memdup2 (src->emitters,
      sizeof (SonarVec3) * src->n_emitters);
}

static gboolean
validate_elements (const SonarVec3 * p, guint n, guint max_n,
    const char *what, GError ** error)
{
  if (n == 0 || n > max_n) {
    SET_ERROR (error, "geometry: %u %s (allowed: 1 to %u)", n, what, max_n);
    return FALSE;
  }
  for (guint i = 0; i < n; i++) {
    if (!isfinite (p[i].x) || !isfinite (p[i].y) || !isfinite (p[i].z)
        || sonar_vec3_norm (p[i]) > MAX_ELEMENT_OFFSET) {
      SET_ERROR (error, "geometry: %s %u at (%g, %g, %g) m is not within "
          "%g m of the array centre", what, i, p[i].x, p[i].y, p[i].z,
          MAX_ELEMENT_OFFSET);
      return FALSE;
    }
    for (guint k = 0; k < i; k++) {
      if (sonar_vec3_norm (sonar_vec3_sub (p[i], p[k])) < MIN_ELEMENT_SPACING) {
        SET_ERROR (error, "geometry: %s %u and %u are at the same position "
            "(%g, %g, %g) m", what, k, i, p[i].x, p[i].y, p[i].z);
        return FALSE;
      }
    }
  }
  return TRUE;
}

gboolean
sonar_geometry_validate (const SonarGeometry * geometry, GError ** error)
{
  return validate_elements (geometry->microphones, geometry->n_microphones,
      SONAR_MAX_MICROPHONES, "microphones", error)
      && validate_elements (geometry->emitters, geometry->n_emitters,
      SONAR_MAX_EMITTERS, "emitters", error);
}

gboolean
sonar_geometry_load_file (SonarGeometry * geometry, const char *path,
    GError ** error)
{
  static const char *const members[] = { "description", "frame", "units",
    "microphones", "emitters", NULL
  };
  g_autoptr (JsonNode) node = NULL;
  JsonObject *root;
  const char *units = "m";
  SonarGeometry loaded = { 0 };
  GError *local_error = NULL;

  node = sonar_json_parse (path, NULL, path, &root, error);
  if (!node)
    return FALSE;
  if (!sonar_json_check_members (root, path, members, error)
      || !sonar_json_get_string (root, "units", FALSE, path, &units, error))
    return FALSE;
  if (strcmp (units, "m") != 0) {
    SET_ERROR (error, "%s: \"units\" must be \"m\" (positions in metres), "
        "not \"%s\"", path, units);
    return FALSE;
  }
  if (!sonar_json_get_vec3_list (root, "microphones", TRUE, path,
          SONAR_MAX_MICROPHONES, &loaded.microphones, &loaded.n_microphones,
          error))
    return FALSE;
  /* A microphone-only file (like the published eRTIS layout) keeps the
   * default emitters. */
  if (json_object_has_member (root, "emitters")) {
    if (!sonar_json_get_vec3_list (root, "emitters", TRUE, path,
            SONAR_MAX_EMITTERS, &loaded.emitters, &loaded.n_emitters,
            error)) {
      sonar_geometry_clear (&loaded);
      return FALSE;
    }
  } else {
    SonarGeometry defaults;
    sonar_geometry_init_default (&defaults);
    loaded.emitters = g_steal_pointer (&defaults.emitters);
    loaded.n_emitters = defaults.n_emitters;
    sonar_geometry_clear (&defaults);
  }
  if (!sonar_geometry_validate (&loaded, &local_error)) {
    g_set_error (error, G_IO_ERROR, G_IO_ERROR_INVALID_DATA, "%s: %s", path,
        local_error->message);
    g_error_free (local_error);
    sonar_geometry_clear (&loaded);
    return FALSE;
  }
  *geometry = loaded;
  return TRUE;
}

/* The band holding all but @fraction of the waveforms' energy at each end. */
static void
estimate_band (const float *waveforms, guint n_rows, guint length,
    double sample_rate, double fraction, double *low, double *high)
{
  SonarBand band;
  g_autoptr (SonarSpectrum) analyzer = NULL;
  SonarComplex *spectrum;
  double *power, total = 0.0, below = 0.0, above = 0.0;
  guint lo, hi;

  sonar_band_init (&band, sample_rate, length, 0.0, sample_rate / 2.0);
  analyzer = sonar_spectrum_new (&band);
  spectrum = g_new (SonarComplex, band.n_bins);
  power = g_new0 (double, band.n_bins);
  for (guint n = 0; n < n_rows; n++) {
    sonar_spectrum_process (analyzer, waveforms + (gsize) n * length, length,
        1, spectrum, NULL);
    for (guint k = 0; k < band.n_bins; k++)
      power[k] += crealf (spectrum[k] * conjf (spectrum[k]));
  }
  for (guint k = 0; k < band.n_bins; k++)
    total += power[k];
  for (lo = 0; lo + 1 < band.n_bins && below + power[lo] < fraction * total;
      lo++)
    below += power[lo];
  for (hi = band.n_bins - 1; hi > lo && above + power[hi] < fraction * total;
      hi--)
    above += power[hi];
  *low = MAX (sonar_band_frequency (&band, lo), 0.5 * sample_rate /
      band.fft_size);
  *high = MAX (sonar_band_frequency (&band, hi), *low + sample_rate /
      band.fft_size);
  *high = MIN (*high, sample_rate / 2.0);
  g_free (spectrum);
  g_free (power);
}

float *
sonar_waveforms_load_file (const char *path, guint * n_emitters,
    guint * length, double *sample_rate, double *band_low,
    double *band_high, GError ** error)
{
  static const char *const members[] = { "description", "sample-rate",
    "band", "waveforms", NULL
  };
  JsonNode *band_node;
  g_autoptr (JsonNode) node = NULL;
  JsonObject *root;
  JsonNode *rows_node;
  JsonArray *rows;
  guint n_rows, n_cols = 0;
  float *waveforms;

  node = sonar_json_parse (path, NULL, path, &root, error);
  if (!node)
    return NULL;
  if (!sonar_json_check_members (root, path, members, error)
      || !sonar_json_get_double (root, "sample-rate", TRUE, path, sample_rate,
          error))
    return NULL;
  if (*sample_rate <= 0.0) {
    g_set_error (error, G_IO_ERROR, G_IO_ERROR_INVALID_DATA,
        "%s: \"sample-rate\" must be positive (Hz), not %g", path,
        *sample_rate);
    return NULL;
  }
  rows_node = json_object_get_member (root, "waveforms");
  if (!rows_node || !JSON_NODE_HOLDS_ARRAY (rows_node)
      || (n_rows = json_array_get_length (json_node_get_array (rows_node)))
      == 0 || n_rows > SONAR_MAX_EMITTERS) {
    g_set_error (error, G_IO_ERROR, G_IO_ERROR_INVALID_DATA,
        "%s: \"waveforms\" must be an array of 1 to %u arrays of samples, "
        "one per emitter", path, SONAR_MAX_EMITTERS);
    return NULL;
  }
  rows = json_node_get_array (rows_node);
  for (guint n = 0; n < n_rows; n++) {
    JsonNode *row = json_array_get_element (rows, n);
    guint len = JSON_NODE_HOLDS_ARRAY (row) ?
        json_array_get_length (json_node_get_array (row)) : 0;
    if (len < 16 || len > SONAR_MAX_WAVEFORM_LENGTH
        || (n > 0 && len != n_cols)) {
      g_set_error (error, G_IO_ERROR, G_IO_ERROR_INVALID_DATA,
          "%s: \"waveforms\"[%u] must be an array of 16 to %u samples, "
          "as long as the first one", path, n, SONAR_MAX_WAVEFORM_LENGTH);
      return NULL;
    }
    n_cols = len;
  }
  waveforms = g_new (float, (gsize) n_rows * n_cols);
  for (guint n = 0; n < n_rows; n++) {
    JsonArray *row = json_node_get_array (json_array_get_element (rows, n));
    for (guint i = 0; i < n_cols; i++) {
      double value;
      if (!sonar_json_node_get_number (json_array_get_element (row, i),
              -MAX_SAMPLE, MAX_SAMPLE, &value, error,
              "%s: \"waveforms\"[%u][%u]", path, n, i)) {
        g_free (waveforms);
        return NULL;
      }
      waveforms[(gsize) n * n_cols + i] = (float) value;
    }
  }
  band_node = json_object_get_member (root, "band");
  if (band_node) {
    JsonArray *edges = JSON_NODE_HOLDS_ARRAY (band_node) ?
        json_node_get_array (band_node) : NULL;
    if (!edges || json_array_get_length (edges) != 2
        || !sonar_json_node_get_number (json_array_get_element (edges, 0),
            0.0, *sample_rate / 2.0, band_low, NULL, "band")
        || !sonar_json_node_get_number (json_array_get_element (edges, 1),
            0.0, *sample_rate / 2.0, band_high, NULL, "band")
        || !(*band_low > 0.0 && *band_high > *band_low)) {
      g_set_error (error, G_IO_ERROR, G_IO_ERROR_INVALID_DATA,
          "%s: \"band\" must be [low, high] in Hz with 0 < low < high <= "
          "sample-rate / 2", path);
      g_free (waveforms);
      return NULL;
    }
  } else {
    estimate_band (waveforms, n_rows, n_cols, *sample_rate, 1e-4, band_low,
        band_high);
  }
  *n_emitters = n_rows;
  *length = n_cols;
  return waveforms;
}

guint
sonar_ping_length_for_range (const SonarGeometry * g, double speed_of_sound,
    double sample_rate, guint waveform_length, double max_range)
{
  double offset = 0.0, window;

  for (guint j = 0; j < g->n_microphones; j++)
    offset = MAX (offset, sonar_vec3_norm (g->microphones[j]));
  for (guint n = 0; n < g->n_emitters; n++)
    offset = MAX (offset, sonar_vec3_norm (g->emitters[n]));
  window = 2.0 * (max_range + offset) / speed_of_sound * sample_rate +
      waveform_length;
  return window < SONAR_MAX_PING_LENGTH ? (guint) ceil (window) :
      SONAR_MAX_PING_LENGTH + 1;
}

SonarSetup *
sonar_setup_new_from_files (const char *geometry_file,
    const char *waveforms_file, double speed_of_sound, guint ping_length,
    GError ** error)
{
  SonarGeometry geometry = { 0 };
  g_autofree float *waveforms = NULL;
  guint n_rows, length;
  double rate, low, high;
  SonarSetup *setup = NULL;

  if (geometry_file) {
    if (!sonar_geometry_load_file (&geometry, geometry_file, error))
      return NULL;
  } else {
    sonar_geometry_init_default (&geometry);
  }
  waveforms = sonar_waveforms_load_file (waveforms_file, &n_rows, &length,
      &rate, &low, &high, error);
  if (!waveforms)
    goto done;
  if (n_rows != geometry.n_emitters) {
    g_set_error (error, G_IO_ERROR, G_IO_ERROR_INVALID_DATA,
        "%s: holds %u waveforms, but the array has %u emitters",
        waveforms_file, n_rows, geometry.n_emitters);
    goto done;
  }
  setup = sonar_setup_new (rate, speed_of_sound, low, high, &geometry,
      length, waveforms, ping_length, error);
done:
  sonar_geometry_clear (&geometry);
  return setup;
}

SonarSetup *
sonar_setup_new (double sample_rate, double speed_of_sound, double band_low,
    double band_high, const SonarGeometry * geometry, guint waveform_length,
    const float *waveforms, guint ping_length, GError ** error)
{
  SonarSetup *setup;

  if (!(sample_rate >= 1000.0 && sample_rate <= 1e8)) {
    SET_ERROR (error, "sample rate %g Hz is out of range (1 kHz to 100 MHz)",
        sample_rate);
    return NULL;
  }
  if (!(speed_of_sound >= 100.0 && speed_of_sound <= 2000.0)) {
    SET_ERROR (error, "speed of sound %g m/s is out of range (100 to 2000)",
        speed_of_sound);
    return NULL;
  }
  if (!(band_low > 0.0 && band_low < band_high
          && band_high <= sample_rate / 2.0)) {
    SET_ERROR (error, "band %g to %g Hz must satisfy 0 < low < high <= "
        "sample rate / 2 (%g Hz)", band_low, band_high, sample_rate / 2.0);
    return NULL;
  }
  if (!sonar_geometry_validate (geometry, error))
    return NULL;
  if (waveform_length < 16 || waveform_length > SONAR_MAX_WAVEFORM_LENGTH) {
    SET_ERROR (error, "waveform length %u is out of range (16 to %u samples)",
        waveform_length, SONAR_MAX_WAVEFORM_LENGTH);
    return NULL;
  }
  if (ping_length < waveform_length || ping_length > SONAR_MAX_PING_LENGTH) {
    SET_ERROR (error, "ping length %u samples must be at least the waveform "
        "length (%u) and at most %u", ping_length, waveform_length,
        SONAR_MAX_PING_LENGTH);
    return NULL;
  }
  for (gsize i = 0; i < (gsize) geometry->n_emitters * waveform_length; i++) {
    if (!isfinite (waveforms[i])) {
      SET_ERROR (error, "waveform of emitter %u has a non-finite sample at "
          "%u", (guint) (i / waveform_length), (guint) (i % waveform_length));
      return NULL;
    }
  }

  setup = g_new0 (SonarSetup, 1);
  setup->ref_count = 1;
  setup->sample_rate = sample_rate;
  setup->speed_of_sound = speed_of_sound;
  setup->band_low = band_low;
  setup->band_high = band_high;
  sonar_geometry_copy (&setup->geometry, geometry);
  setup->waveform_length = waveform_length;
  setup->waveforms = g_memdup2 (waveforms,
      sizeof (float) * geometry->n_emitters * waveform_length);
  setup->ping_length = ping_length;
  return setup;
}

SonarSetup *
sonar_setup_ref (SonarSetup * setup)
{
  g_return_val_if_fail (setup != NULL, NULL);
  g_atomic_int_inc (&setup->ref_count);
  return setup;
}

void
sonar_setup_unref (SonarSetup * setup)
{
  if (setup && g_atomic_int_dec_and_test (&setup->ref_count)) {
    sonar_geometry_clear (&setup->geometry);
    g_free ((gpointer) setup->waveforms);
    g_free (setup);
  }
}

gboolean
sonar_setup_equal (const SonarSetup * a, const SonarSetup * b)
{
  const SonarGeometry *ga = &a->geometry, *gb = &b->geometry;

  return a->sample_rate == b->sample_rate
      && a->speed_of_sound == b->speed_of_sound
      && a->band_low == b->band_low && a->band_high == b->band_high
      && a->waveform_length == b->waveform_length
      && a->ping_length == b->ping_length
      && ga->n_microphones == gb->n_microphones
      && ga->n_emitters == gb->n_emitters
      && memcmp (ga->microphones, gb->microphones,
      sizeof (SonarVec3) * ga->n_microphones) == 0
      && memcmp (ga->emitters, gb->emitters,
      sizeof (SonarVec3) * ga->n_emitters) == 0
      && memcmp (a->waveforms, b->waveforms,
      sizeof (float) * ga->n_emitters * a->waveform_length) == 0;
}
