/* sonar-setup.c: see sonar-setup.h. */
#include "sonar-setup.h"
#include "sonar-error.h"
#include "sonar-fftw.h"
#include "sonar-interp.h"
#include "sonar-json.h"
#include "sonar-spectrum.h"
#include "sonar-waveform.h"

#include <fftw3.h>
#include <gio/gio.h>
#include <math.h>
#include <string.h>

#define SET_ERROR(error, ...) \
  g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS, __VA_ARGS__)

/* Two elements closer than this are one element entered twice. */
#define MIN_ELEMENT_SPACING 1e-4
/* Elements must sit on a sensor, not metres away from it. */
#define MAX_ELEMENT_OFFSET 1.0

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

SonarFieldOfView
sonar_geometry_field_of_view (const SonarGeometry * geometry)
{
  double y_min = G_MAXDOUBLE, y_max = -G_MAXDOUBLE;

  /* A line of elements along x cannot tell up from down. */
  for (guint j = 0; j < geometry->n_microphones; j++) {
    y_min = MIN (y_min, geometry->microphones[j].y);
    y_max = MAX (y_max, geometry->microphones[j].y);
  }
  for (guint n = 0; n < geometry->n_emitters; n++) {
    y_min = MIN (y_min, geometry->emitters[n].y);
    y_max = MAX (y_max, geometry->emitters[n].y);
  }
  return y_max - y_min > MIN_ELEMENT_SPACING ? SONAR_FIELD_OF_VIEW_HEMISPHERE
      : SONAR_FIELD_OF_VIEW_FAN;
}

gboolean
sonar_geometry_is_planar (const SonarGeometry * g)
{
  const double tolerance = 1e-6;

  for (guint i = 0; i < g->n_microphones; i++)
    if (fabs (g->microphones[i].z) > tolerance)
      return FALSE;
  for (guint i = 0; i < g->n_emitters; i++)
    if (fabs (g->emitters[i].z) > tolerance)
      return FALSE;
  return TRUE;
}

static const char *const field_of_view_names[] = { "fan", "hemisphere" };

const char *
sonar_field_of_view_to_string (SonarFieldOfView view)
{
  return field_of_view_names[view];
}

gboolean
sonar_field_of_view_from_string (const char *name, SonarFieldOfView * view)
{
  for (guint i = 0; i < G_N_ELEMENTS (field_of_view_names); i++) {
    if (g_strcmp0 (name, field_of_view_names[i]) == 0) {
      *view = (SonarFieldOfView) i;
      return TRUE;
    }
  }
  return FALSE;
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
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_FORMAT, "%s: %s", path,
        local_error->message);
    g_error_free (local_error);
    sonar_geometry_clear (&loaded);
    return FALSE;
  }
  *geometry = loaded;
  return TRUE;
}

void
sonar_waveforms_estimate_band (const float *waveforms, guint n_rows, guint length,
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
  guint n_rows, n_cols;
  float *waveforms;

  node = sonar_json_parse (path, NULL, path, &root, error);
  if (!node)
    return NULL;
  if (!sonar_json_check_members (root, path, members, error)
      || !sonar_json_get_double (root, "sample-rate", TRUE, path, sample_rate,
          error))
    return NULL;
  if (*sample_rate <= 0.0) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_FORMAT,
        "%s: \"sample-rate\" must be positive (Hz), not %g", path,
        *sample_rate);
    return NULL;
  }
  if (!sonar_json_get_sample_rows (root, "waveforms", path,
          SONAR_MAX_EMITTERS, 16, SONAR_MAX_WAVEFORM_LENGTH,
          SONAR_MAX_WAVEFORM_SAMPLE, &waveforms, &n_rows, &n_cols, error))
    return NULL;
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
      g_set_error (error, SONAR_ERROR, SONAR_ERROR_FORMAT,
          "%s: \"band\" must be [low, high] in Hz with 0 < low < high <= "
          "sample-rate / 2", path);
      g_free (waveforms);
      return NULL;
    }
  } else {
    sonar_waveforms_estimate_band (waveforms, n_rows, n_cols, *sample_rate,
        1e-4, band_low, band_high);
  }
  *n_emitters = n_rows;
  *length = n_cols;
  return waveforms;
}

float *
sonar_waveforms_delay (const float *waveforms, guint n_rows, guint length,
    const double *delays, guint * delayed_length)
{
  double longest = 0.0;
  guint out_length;
  float *out;

  for (guint n = 0; n < n_rows; n++)
    longest = MAX (longest, delays[n]);
  out_length = length + (guint) ceil (longest);
  out = g_new0 (float, (gsize) n_rows * out_length);
  for (guint n = 0; n < n_rows; n++) {
    const float *row = waveforms + (gsize) n * length;
    float *delayed = out + (gsize) n * out_length;
    const double whole = floor (delays[n]);

    if (delays[n] == whole) {
      /* Whole samples: the samples themselves, bit for bit. */
      memcpy (delayed + (guint) whole, row, sizeof (float) * length);
    } else {
      g_autoptr (SonarInterp) interp = sonar_interp_new (row, length);
      /* The band-limited row rings a little before its first sample and
       * after its last; what falls before the trigger is not emitted. */
      for (guint i = 0; i < out_length; i++)
        delayed[i] = sonar_interp_at (interp, i - delays[n]);
    }
  }
  *delayed_length = out_length;
  return out;
}

/* The farthest element from the array centre. */
static double
geometry_extent (const SonarGeometry * g)
{
  double offset = 0.0;

  for (guint j = 0; j < g->n_microphones; j++)
    offset = MAX (offset, sonar_vec3_norm (g->microphones[j]));
  for (guint n = 0; n < g->n_emitters; n++)
    offset = MAX (offset, sonar_vec3_norm (g->emitters[n]));
  return offset;
}

SonarSetup *
sonar_setup_new_default (double max_range, GError ** error)
{
  g_autofree float *waveforms = NULL;
  SonarWaveformParams wp;
  SonarGeometry geometry;
  SonarSetup *setup = NULL;

  sonar_geometry_init_default (&geometry);
  sonar_waveform_params_init_default (&wp);
  wp.n_emitters = geometry.n_emitters;
  waveforms = g_new (float, (gsize) wp.n_emitters * wp.length);
  if (sonar_waveform_generate (&wp, waveforms, error))
    setup = sonar_setup_new (&(SonarSetupParams) {
          .sample_rate = wp.sample_rate,
          .speed_of_sound = SONAR_DEFAULT_SPEED_OF_SOUND,
          .band_low = wp.band_low, .band_high = wp.band_high,
          .geometry = &geometry, .waveform_length = wp.length,
          .waveforms = waveforms,
          .ping_length = sonar_ping_length_for_range (&geometry,
              SONAR_DEFAULT_SPEED_OF_SOUND, wp.sample_rate, wp.length,
              max_range)}, error);
  sonar_geometry_clear (&geometry);
  return setup;
}

guint
sonar_ping_length_for_range (const SonarGeometry * g, double speed_of_sound,
    double sample_rate, guint waveform_length, double max_range)
{
  const double window = 2.0 * (max_range + geometry_extent (g)) /
      speed_of_sound * sample_rate + waveform_length;

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
  SonarSetupParams params;
  guint n_rows;
  SonarSetup *setup = NULL;

  if (geometry_file) {
    if (!sonar_geometry_load_file (&geometry, geometry_file, error))
      return NULL;
  } else {
    sonar_geometry_init_default (&geometry);
  }
  sonar_setup_params_init (&params);
  waveforms = sonar_waveforms_load_file (waveforms_file, &n_rows,
      &params.waveform_length, &params.sample_rate, &params.band_low,
      &params.band_high, error);
  if (!waveforms)
    goto done;
  if (n_rows != geometry.n_emitters) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_FORMAT,
        "%s: holds %u waveforms, but the array has %u emitters",
        waveforms_file, n_rows, geometry.n_emitters);
    goto done;
  }
  params.speed_of_sound = speed_of_sound;
  params.geometry = &geometry;
  params.waveforms = waveforms;
  params.ping_length = ping_length;
  setup = sonar_setup_new (&params, error);
done:
  sonar_geometry_clear (&geometry);
  return setup;
}

void
sonar_setup_params_init (SonarSetupParams * params)
{
  *params = (SonarSetupParams) {
    .speed_of_sound = SONAR_DEFAULT_SPEED_OF_SOUND,
    .field_of_view = SONAR_FIELD_OF_VIEW_FAN,
  };
}

static gboolean
frame_id_is_printable (const char *id)
{
  for (const char *c = id; *c; c++)
    if (!g_ascii_isprint (*c))
      return FALSE;
  return TRUE;
}

SonarSetup *
sonar_setup_new (const SonarSetupParams * p, GError ** error)
{
  const SonarGeometry *geometry = p->geometry;
  const double ping_period = p->ping_period > 0.0 ? p->ping_period :
      p->ping_length / p->sample_rate;
  const double ping_stride = p->ping_stride > 0.0 ? p->ping_stride :
      p->ping_period > 0.0 ? p->ping_period * p->sample_rate :
      p->ping_length;
  SonarSetup *setup;

  if (!(p->sample_rate >= 1000.0 && p->sample_rate <= 1e8)) {
    SET_ERROR (error, "sample rate %g Hz is out of range (1 kHz to 100 MHz)",
        p->sample_rate);
    return NULL;
  }
  if (!(p->speed_of_sound >= 100.0 && p->speed_of_sound <= 2000.0)) {
    SET_ERROR (error, "speed of sound %g m/s is out of range (100 to 2000)",
        p->speed_of_sound);
    return NULL;
  }
  if (!(p->band_low > 0.0 && p->band_low < p->band_high
          && p->band_high <= p->sample_rate / 2.0)) {
    SET_ERROR (error, "band %g to %g Hz must satisfy 0 < low < high <= "
        "sample rate / 2 (%g Hz)", p->band_low, p->band_high,
        p->sample_rate / 2.0);
    return NULL;
  }
  if (!sonar_geometry_validate (geometry, error))
    return NULL;
  if (p->waveform_length < 16
      || p->waveform_length > SONAR_MAX_WAVEFORM_LENGTH) {
    SET_ERROR (error, "waveform length %u is out of range (16 to %u samples)",
        p->waveform_length, SONAR_MAX_WAVEFORM_LENGTH);
    return NULL;
  }
  if (p->ping_length < p->waveform_length
      || p->ping_length > SONAR_MAX_PING_LENGTH) {
    SET_ERROR (error, "ping length %u samples must be at least the waveform "
        "length (%u) and at most %u", p->ping_length, p->waveform_length,
        SONAR_MAX_PING_LENGTH);
    return NULL;
  }
  if (!(isfinite (ping_period) && ping_period <= SONAR_MAX_PING_PERIOD)) {
    SET_ERROR (error, "ping period %g s is out of range (up to %g s)",
        ping_period, SONAR_MAX_PING_PERIOD);
    return NULL;
  }
  /* Overlapping windows would need each sample in two pings at once. */
  if (!(ping_stride + 0.5 >= p->ping_length)) {
    SET_ERROR (error, "pings start %.3f samples apart in the recording "
        "(ping period %g s at %g Hz), less than the ping length of %u "
        "samples: the windows would overlap", ping_stride, ping_period,
        p->sample_rate, p->ping_length);
    return NULL;
  }
  for (gsize i = 0; i < (gsize) geometry->n_emitters * p->waveform_length;
      i++) {
    if (!isfinite (p->waveforms[i])) {
      SET_ERROR (error, "waveform of emitter %u has a non-finite sample at "
          "%u", (guint) (i / p->waveform_length),
          (guint) (i % p->waveform_length));
      return NULL;
    }
  }

  if (p->frame_id && (strlen (p->frame_id) >= SONAR_FRAME_ID_MAX
          || !frame_id_is_printable (p->frame_id))) {
    SET_ERROR (error, "frame id \"%s\" must be at most %d bytes of "
        "printable ASCII", p->frame_id, SONAR_FRAME_ID_MAX - 1);
    return NULL;
  }

  setup = g_new0 (SonarSetup, 1);
  setup->ref_count = 1;
  setup->sample_rate = p->sample_rate;
  setup->speed_of_sound = p->speed_of_sound;
  setup->band_low = p->band_low;
  setup->band_high = p->band_high;
  sonar_geometry_copy (&setup->geometry, geometry);
  setup->waveform_length = p->waveform_length;
  setup->waveforms = g_memdup2 (p->waveforms,
      sizeof (float) * geometry->n_emitters * p->waveform_length);
  setup->ping_length = p->ping_length;
  setup->ping_period = ping_period;
  setup->ping_stride = ping_stride;
  setup->trigger_offset = p->trigger_offset;
  setup->field_of_view = p->field_of_view;
  g_strlcpy (setup->frame_id, p->frame_id ? p->frame_id : "",
      SONAR_FRAME_ID_MAX);
  return setup;
}

guint64
sonar_setup_ping_start (const SonarSetup * setup, guint64 index)
{
  return setup->trigger_offset + (guint64) floor (index * setup->ping_stride
      + 0.5);
}

double
sonar_setup_recorded_range (const SonarSetup * setup)
{
  const double whole_echo = 0.5 * setup->speed_of_sound *
      (setup->ping_length - setup->waveform_length) / setup->sample_rate -
      geometry_extent (&setup->geometry);

  return MAX (floor (whole_echo * 1000.0) / 1000.0, 0.0);
}

double
sonar_setup_window_range (const SonarSetup * setup)
{
  return 0.5 * setup->speed_of_sound * setup->ping_length /
      setup->sample_rate;
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

double
sonar_setup_emission_centre (const SonarSetup * setup)
{
  double moment = 0.0, energy = 0.0;

  for (guint n = 0; n < setup->geometry.n_emitters; n++) {
    const float *row = sonar_setup_waveform (setup, n);
    for (guint i = 0; i < setup->waveform_length; i++) {
      const double e = (double) row[i] * row[i];
      moment += e * i;
      energy += e;
    }
  }
  return energy > 0.0 ? moment / energy / setup->sample_rate : 0.0;
}

double
sonar_setup_hypothesis_spacing (const SonarSetup * setup)
{
  const double f0 = 0.5 * (setup->band_low + setup->band_high);
  const double c = setup->speed_of_sound, rate = setup->sample_rate;
  double first = G_MAXDOUBLE, last = -G_MAXDOUBLE, longest = 0.0;
  double spacing = SONAR_HYPOTHESIS_SPACING_MAX;

  for (guint n = 0; n < setup->geometry.n_emitters; n++) {
    const float *row = sonar_setup_waveform (setup, n);
    double energy = 0.0, moment = 0.0, second = 0.0, centre;
    for (guint i = 0; i < setup->waveform_length; i++) {
      const double e = (double) row[i] * row[i];
      energy += e;
      moment += e * i;
      second += e * i * i;
    }
    if (!(energy > 0.0))
      continue;
    centre = moment / energy;
    first = MIN (first, centre);
    last = MAX (last, centre);
    longest = MAX (longest, sqrt (12.0 * MAX (second / energy - centre *
                centre, 0.0)) / rate);
  }
  if (longest > 0.0)
    spacing = MIN (spacing, SONAR_HYPOTHESIS_SPACING_LOBES * c / (2.0 * f0 *
            longest));
  if (last > first)
    spacing = MIN (spacing, c / (6.0 * f0 * (last - first) / rate));
  return spacing;
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
      && a->ping_period == b->ping_period
      && a->ping_stride == b->ping_stride
      && a->trigger_offset == b->trigger_offset
      && a->field_of_view == b->field_of_view
      && strcmp (a->frame_id, b->frame_id) == 0
      && ga->n_microphones == gb->n_microphones
      && ga->n_emitters == gb->n_emitters
      && memcmp (ga->microphones, gb->microphones,
      sizeof (SonarVec3) * ga->n_microphones) == 0
      && memcmp (ga->emitters, gb->emitters,
      sizeof (SonarVec3) * ga->n_emitters) == 0
      && memcmp (a->waveforms, b->waveforms,
      sizeof (float) * ga->n_emitters * a->waveform_length) == 0;
}

/* Extent of the virtual array (emitter + microphone) along @axis. */
static double
virtual_aperture (const SonarGeometry * g, SonarVec3 axis)
{
  double low = G_MAXDOUBLE, high = -G_MAXDOUBLE;

  for (guint n = 0; n < g->n_emitters; n++) {
    for (guint j = 0; j < g->n_microphones; j++) {
      const double x = sonar_vec3_dot (sonar_vec3_add (g->emitters[n],
              g->microphones[j]), axis);
      low = MIN (low, x);
      high = MAX (high, x);
    }
  }
  return high - low;
}

/* Appends to @problems the emissions' band energy and cross-talk: every
 * emission's spectrum once (FFT of twice the length: linear, not circular,
 * correlations), then each pair's correlation by an inverse FFT. */
static void
check_emissions (const SonarSetup * setup, GString * problems)
{
  const guint n = setup->geometry.n_emitters, length = setup->waveform_length;
  const guint size = sonar_fft_good_size (2 * length), bins = size / 2 + 1;
  float *signal = fftwf_alloc_real (size);
  fftwf_complex *spectra = fftwf_alloc_complex ((gsize) bins * n);
  fftwf_complex *product = fftwf_alloc_complex (bins);
  float *correlation = fftwf_alloc_real (size);
  double *energy = g_new0 (double, n), *power = g_new0 (double, n);
  fftwf_plan forward, inverse;
  double worst = 0.0;
  guint worst_a = 0, worst_b = 0;

  sonar_fftw_lock ();
  /* Each emission's spectrum goes to its own row: rows after the first
   * need not have the plan's alignment. */
  forward = fftwf_plan_dft_r2c_1d (size, signal, spectra,
      FFTW_ESTIMATE | FFTW_UNALIGNED);
  inverse = fftwf_plan_dft_c2r_1d (size, product, correlation,
      FFTW_ESTIMATE);
  sonar_fftw_unlock ();
  for (guint e = 0; e < n; e++) {
    double in_band = 0.0;
    memset (signal, 0, sizeof (float) * size);
    memcpy (signal, sonar_setup_waveform (setup, e), sizeof (float) * length);
    for (guint i = 0; i < length; i++)
      power[e] += (double) signal[i] * signal[i];
    fftwf_execute_dft_r2c (forward, signal, spectra + (gsize) e * bins);
    for (guint k = 0; k < bins; k++) {
      const double f = k * setup->sample_rate / size;
      const fftwf_complex s = spectra[(gsize) e * bins + k];
      const double p = crealf (s * conjf (s));
      energy[e] += p;
      if (f >= setup->band_low && f <= setup->band_high)
        in_band += p;
    }
    if (!(energy[e] > 0.0))
      g_string_append_printf (problems, "; emitter %u sends nothing", e);
    else if (in_band < SONAR_MIN_BAND_ENERGY * energy[e])
      g_string_append_printf (problems, "; emitter %u sends only %.0f %% "
          "of its energy in the band %g-%g Hz", e, 100.0 * in_band /
          energy[e], setup->band_low, setup->band_high);
  }
  for (guint a = 0; a < n; a++) {
    for (guint b = a + 1; b < n; b++) {
      double peak = 0.0;
      if (!(energy[a] > 0.0 && energy[b] > 0.0))
        continue;
      for (guint k = 0; k < bins; k++)
        product[k] = spectra[(gsize) a * bins + k] *
            conjf (spectra[(gsize) b * bins + k]);
      fftwf_execute (inverse);
      for (guint i = 0; i < size; i++)
        peak = MAX (peak, fabs (correlation[i]));
      /* The unnormalised inverse transform multiplies by size. */
      peak /= size * sqrt (power[a] * power[b]);
      if (peak > worst) {
        worst = peak;
        worst_a = a;
        worst_b = b;
      }
    }
  }
  if (n > 1 && 20.0 * log10 (worst) > SONAR_MAX_CROSS_CORRELATION_DB)
    g_string_append_printf (problems, "; the emissions of emitters %u and "
        "%u are too alike to be told apart (cross-correlation peak %.1f dB "
        "of their energy; at most %.0f dB)", worst_a, worst_b,
        20.0 * log10 (worst), SONAR_MAX_CROSS_CORRELATION_DB);
  sonar_fftw_lock ();
  fftwf_destroy_plan (forward);
  fftwf_destroy_plan (inverse);
  sonar_fftw_unlock ();
  fftwf_free (signal);
  fftwf_free (spectra);
  fftwf_free (product);
  fftwf_free (correlation);
  g_free (energy);
  g_free (power);
}

char *
sonar_setup_check (const SonarSetup * setup)
{
  const double wavelength = setup->speed_of_sound / setup->band_high;
  GString *problems = g_string_new (NULL);
  const SonarVec3 x = { 1.0, 0.0, 0.0 }, y = { 0.0, 1.0, 0.0 };

  /* Less than a quarter wavelength of aperture along an axis the image
   * spans: no direction there. */
  {
    const gboolean narrow_x = virtual_aperture (&setup->geometry, x) <
        0.25 * wavelength;
    const gboolean narrow_y = setup->field_of_view ==
        SONAR_FIELD_OF_VIEW_HEMISPHERE && virtual_aperture (&setup->geometry,
        y) < 0.25 * wavelength;
    if (narrow_x || narrow_y)
      g_string_append_printf (problems, "; the array (%u microphones, %u "
          "emitters) spans less than a quarter wavelength (%.1f mm) %s: it "
          "cannot resolve %s", setup->geometry.n_microphones,
          setup->geometry.n_emitters, 250.0 * wavelength,
          narrow_x && narrow_y ? "along x and along y" : narrow_x ?
          "along x" : "along y", narrow_x && narrow_y ? "direction" :
          narrow_x ? "azimuth (a line along y images elevation alone: "
          "mimobeamform azimuth-count=1 and elevation's range)" :
          "elevation (a line along x: the sensor file's field-of-view "
          "\"fan\")");
  }
  check_emissions (setup, problems);
  if (problems->len == 0) {
    g_string_free (problems, TRUE);
    return NULL;
  }
  g_string_erase (problems, 0, 2);
  return g_string_free (problems, FALSE);
}
