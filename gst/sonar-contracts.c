/* sonar-contracts.c: see sonar-contracts.h and docs/CONTRACTS.md. */
#include "sonar-contracts.h"

#include <gio/gio.h>
#include <string.h>

/* The set-up event ------------------------------------------------------*/

static GBytes *
vec3_bytes (const SonarVec3 * v, guint n)
{
  double *xyz = g_new (double, 3 * n);
  for (guint i = 0; i < n; i++) {
    xyz[3 * i] = v[i].x;
    xyz[3 * i + 1] = v[i].y;
    xyz[3 * i + 2] = v[i].z;
  }
  return g_bytes_new_take (xyz, sizeof (double) * 3 * n);
}

GstEvent *
sonar_setup_event_new (const SonarSetup * setup)
{
  const SonarGeometry *g = &setup->geometry;
  g_autoptr (GBytes) microphones = vec3_bytes (g->microphones,
      g->n_microphones);
  g_autoptr (GBytes) emitters = vec3_bytes (g->emitters, g->n_emitters);
  g_autoptr (GBytes) waveforms = g_bytes_new (setup->waveforms,
      sizeof (float) * g->n_emitters * setup->waveform_length);
  GstStructure *s = gst_structure_new (SONAR_SETUP_EVENT_NAME,
      "sample-rate", G_TYPE_DOUBLE, setup->sample_rate,
      "speed-of-sound", G_TYPE_DOUBLE, setup->speed_of_sound,
      "band-low", G_TYPE_DOUBLE, setup->band_low,
      "band-high", G_TYPE_DOUBLE, setup->band_high,
      "ping-length", G_TYPE_UINT, setup->ping_length,
      "waveform-length", G_TYPE_UINT, setup->waveform_length,
      "n-microphones", G_TYPE_UINT, g->n_microphones,
      "n-emitters", G_TYPE_UINT, g->n_emitters,
      "microphones", G_TYPE_BYTES, microphones,
      "emitters", G_TYPE_BYTES, emitters,
      "waveforms", G_TYPE_BYTES, waveforms, NULL);

  return gst_event_new_custom (GST_EVENT_CUSTOM_DOWNSTREAM_STICKY, s);
}

gboolean
sonar_event_is_setup (GstEvent * event)
{
  return GST_EVENT_TYPE (event) == GST_EVENT_CUSTOM_DOWNSTREAM_STICKY
      && gst_event_has_name (event, SONAR_SETUP_EVENT_NAME);
}

static gboolean
get_vec3_bytes (const GstStructure * s, const char *field, guint n,
    SonarVec3 ** out, GError ** error)
{
  const GValue *value = gst_structure_get_value (s, field);
  GBytes *bytes;
  gsize size;
  const double *xyz;

  if (!value || !G_VALUE_HOLDS (value, G_TYPE_BYTES)
      || !(bytes = g_value_get_boxed (value))) {
    g_set_error (error, G_IO_ERROR, G_IO_ERROR_INVALID_DATA,
        "sonar-setup event: missing field \"%s\"", field);
    return FALSE;
  }
  xyz = g_bytes_get_data (bytes, &size);
  if (size != sizeof (double) * 3 * n) {
    g_set_error (error, G_IO_ERROR, G_IO_ERROR_INVALID_DATA,
        "sonar-setup event: \"%s\" holds %" G_GSIZE_FORMAT " bytes, "
        "expected %u positions", field, size, n);
    return FALSE;
  }
  *out = g_new (SonarVec3, n);
  for (guint i = 0; i < n; i++)
    (*out)[i] = sonar_vec3 (xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
  return TRUE;
}

SonarSetup *
sonar_setup_from_structure (const GstStructure * s, GError ** error)
{
  double sample_rate, speed_of_sound, band_low, band_high;
  guint ping_length, waveform_length;
  SonarGeometry geometry = { 0 };
  const GValue *value;
  GBytes *waveforms;
  SonarSetup *setup = NULL;

  if (!gst_structure_has_name (s, SONAR_SETUP_EVENT_NAME)
      || !gst_structure_get (s, "sample-rate", G_TYPE_DOUBLE, &sample_rate,
          "speed-of-sound", G_TYPE_DOUBLE, &speed_of_sound,
          "band-low", G_TYPE_DOUBLE, &band_low,
          "band-high", G_TYPE_DOUBLE, &band_high,
          "ping-length", G_TYPE_UINT, &ping_length,
          "waveform-length", G_TYPE_UINT, &waveform_length,
          "n-microphones", G_TYPE_UINT, &geometry.n_microphones,
          "n-emitters", G_TYPE_UINT, &geometry.n_emitters, NULL)) {
    g_set_error (error, G_IO_ERROR, G_IO_ERROR_INVALID_DATA,
        "sonar-setup event: missing or mistyped field (see "
        "docs/CONTRACTS.md)");
    return NULL;
  }
  if (geometry.n_microphones > SONAR_MAX_MICROPHONES
      || geometry.n_emitters > SONAR_MAX_EMITTERS
      || waveform_length > SONAR_MAX_WAVEFORM_LENGTH) {
    g_set_error (error, G_IO_ERROR, G_IO_ERROR_INVALID_DATA,
        "sonar-setup event: sizes out of range");
    return NULL;
  }
  value = gst_structure_get_value (s, "waveforms");
  if (!value || !G_VALUE_HOLDS (value, G_TYPE_BYTES)
      || !(waveforms = g_value_get_boxed (value))
      || g_bytes_get_size (waveforms) !=
      sizeof (float) * geometry.n_emitters * waveform_length) {
    g_set_error (error, G_IO_ERROR, G_IO_ERROR_INVALID_DATA,
        "sonar-setup event: \"waveforms\" must hold n-emitters x "
        "waveform-length floats");
    return NULL;
  }
  if (get_vec3_bytes (s, "microphones", geometry.n_microphones,
          &geometry.microphones, error)
      && get_vec3_bytes (s, "emitters", geometry.n_emitters,
          &geometry.emitters, error))
    setup = sonar_setup_new (sample_rate, speed_of_sound, band_low,
        band_high, &geometry, waveform_length,
        g_bytes_get_data (waveforms, NULL), ping_length, error);
  sonar_geometry_clear (&geometry);
  return setup;
}

SonarSetup *
sonar_setup_from_event (GstEvent * event, GError ** error)
{
  return sonar_setup_from_structure (gst_event_get_structure (event), error);
}

/* The ground-truth meta -------------------------------------------------*/

GType
sonar_truth_meta_api_get_type (void)
{
  static GType type = 0;
  /* No tags: GstBaseTransform copies only metas without tags. */
  static const gchar *tags[] = { NULL };

  /* The core is linked into the plugin and into applications: whichever
   * copy comes second finds the type the first one registered. */
  if (g_once_init_enter (&type)) {
    GType t = g_type_from_name ("SonarTruthMetaAPI");
    if (!t)
      t = gst_meta_api_type_register ("SonarTruthMetaAPI", tags);
    g_once_init_leave (&type, t);
  }
  return type;
}

static gboolean
truth_meta_init (GstMeta * meta, gpointer params, GstBuffer * buffer)
{
  SonarTruthMeta *m = (SonarTruthMeta *) meta;
  m->ping_index = 0;
  m->n_truths = 0;
  m->truths = NULL;
  return TRUE;
}

static void
truth_meta_free (GstMeta * meta, GstBuffer * buffer)
{
  g_free (((SonarTruthMeta *) meta)->truths);
}

static gboolean
truth_meta_transform (GstBuffer * dest, GstMeta * meta, GstBuffer * buffer,
    GQuark type, gpointer data)
{
  SonarTruthMeta *m = (SonarTruthMeta *) meta;
  /* The truth describes the ping, not its bytes: it holds for any copy or
   * conversion of the buffer. */
  return sonar_buffer_add_truth_meta (dest, m->ping_index, m->truths,
      m->n_truths) != NULL;
}

const GstMetaInfo *
sonar_truth_meta_get_info (void)
{
  static const GstMetaInfo *info = NULL;

  if (g_once_init_enter ((GstMetaInfo **) & info)) {
    const GstMetaInfo *mi = gst_meta_get_info ("SonarTruthMeta");
    if (!mi)
      mi = gst_meta_register (SONAR_TRUTH_META_API_TYPE, "SonarTruthMeta",
          sizeof (SonarTruthMeta), truth_meta_init, truth_meta_free,
          truth_meta_transform);
    g_once_init_leave ((GstMetaInfo **) & info, (GstMetaInfo *) mi);
  }
  return info;
}

SonarTruthMeta *
sonar_buffer_add_truth_meta (GstBuffer * buffer, guint64 ping_index,
    const SonarTruth * truths, guint n_truths)
{
  SonarTruthMeta *m = (SonarTruthMeta *) gst_buffer_add_meta (buffer,
      sonar_truth_meta_get_info (), NULL);

  if (!m)
    return NULL;
  m->ping_index = ping_index;
  m->n_truths = n_truths;
  m->truths = g_memdup2 (truths, sizeof (SonarTruth) * n_truths);
  return m;
}

/* Bus messages ----------------------------------------------------------*/

GstStructure *
sonar_truth_to_structure (guint64 ping_index, GstClockTime timestamp,
    const SonarTruth * truths, guint n_truths)
{
  GValue list = G_VALUE_INIT;
  GstStructure *s;

  g_value_init (&list, GST_TYPE_ARRAY);
  for (guint k = 0; k < n_truths; k++) {
    const SonarTruth *t = &truths[k];
    GValue item = G_VALUE_INIT;
    g_value_init (&item, GST_TYPE_STRUCTURE);
    gst_value_set_structure (&item, gst_structure_new ("reflector",
            "id", G_TYPE_UINT, t->reflector,
            "kind", G_TYPE_STRING, sonar_reflector_kind_to_string (t->kind),
            "range", G_TYPE_DOUBLE, t->range,
            "azimuth", G_TYPE_DOUBLE, t->azimuth,
            "elevation", G_TYPE_DOUBLE, t->elevation,
            "radial-velocity", G_TYPE_DOUBLE, t->radial_velocity,
            "x", G_TYPE_DOUBLE, t->position.x,
            "y", G_TYPE_DOUBLE, t->position.y,
            "z", G_TYPE_DOUBLE, t->position.z, NULL));
    gst_value_array_append_and_take_value (&list, &item);
  }
  s = gst_structure_new (SONAR_TRUTH_MESSAGE_NAME,
      "ping", G_TYPE_UINT64, ping_index,
      "timestamp", G_TYPE_UINT64, timestamp, NULL);
  gst_structure_take_value (s, "reflectors", &list);
  return s;
}
