/* sonar-contracts.c: see sonar-contracts.h and docs/CONTRACTS.md. */
#include "sonar-contracts.h"
#include "sonar-error.h"
#include "sonar-json.h"

#include <gio/gio.h>
#include <json-glib/json-glib.h>
#include <math.h>
#include <string.h>

/* The set-up event ------------------------------------------------------*/

/* Arrays of numbers travel as base64 text of their little-endian IEEE
 * 754 values: a structure of strings survives serialisation
 * (gst_structure_to_string (), GStreamer's data protocol, gdppay) bit for
 * bit, which GBytes fields do not. */
static char *
doubles_to_base64 (const double *v, gsize n)
{
  g_autofree guint64 *le = g_new (guint64, MAX (n, 1));

  for (gsize i = 0; i < n; i++) {
    guint64 bits;
    memcpy (&bits, &v[i], sizeof bits);
    le[i] = GUINT64_TO_LE (bits);
  }
  return g_base64_encode ((const guchar *) le, n * sizeof (guint64));
}

static char *
floats_to_base64 (const float *v, gsize n)
{
  g_autofree guint32 *le = g_new (guint32, MAX (n, 1));

  for (gsize i = 0; i < n; i++) {
    guint32 bits;
    memcpy (&bits, &v[i], sizeof bits);
    le[i] = GUINT32_TO_LE (bits);
  }
  return g_base64_encode ((const guchar *) le, n * sizeof (guint32));
}

static char *
vec3_to_base64 (const SonarVec3 * v, guint n)
{
  g_autofree double *xyz = g_new (double, 3 * (gsize) MAX (n, 1));

  for (guint i = 0; i < n; i++) {
    xyz[3 * i] = v[i].x;
    xyz[3 * i + 1] = v[i].y;
    xyz[3 * i + 2] = v[i].z;
  }
  return doubles_to_base64 (xyz, 3 * (gsize) n);
}

GstEvent *
sonar_setup_event_new (const SonarSetup * setup)
{
  const SonarGeometry *g = &setup->geometry;
  g_autofree char *microphones = vec3_to_base64 (g->microphones,
      g->n_microphones);
  g_autofree char *emitters = vec3_to_base64 (g->emitters, g->n_emitters);
  g_autofree char *waveforms = floats_to_base64 (setup->waveforms,
      (gsize) g->n_emitters * setup->waveform_length);
  GstStructure *s = gst_structure_new (SONAR_SETUP_EVENT_NAME,
      "sample-rate", G_TYPE_DOUBLE, setup->sample_rate,
      "speed-of-sound", G_TYPE_DOUBLE, setup->speed_of_sound,
      "band-low", G_TYPE_DOUBLE, setup->band_low,
      "band-high", G_TYPE_DOUBLE, setup->band_high,
      "ping-length", G_TYPE_UINT, setup->ping_length,
      "ping-period", G_TYPE_DOUBLE, setup->ping_period,
      "ping-stride", G_TYPE_DOUBLE, setup->ping_stride,
      "trigger-offset", G_TYPE_UINT64, setup->trigger_offset,
      "field-of-view", G_TYPE_STRING,
      sonar_field_of_view_to_string (setup->field_of_view),
      "waveform-length", G_TYPE_UINT, setup->waveform_length,
      "n-microphones", G_TYPE_UINT, g->n_microphones,
      "n-emitters", G_TYPE_UINT, g->n_emitters,
      "microphones", G_TYPE_STRING, microphones,
      "emitters", G_TYPE_STRING, emitters,
      "waveforms", G_TYPE_STRING, waveforms, NULL);

  /* Only when set: set-up events saved before frame ids read the same. */
  if (setup->frame_id[0])
    gst_structure_set (s, "frame-id", G_TYPE_STRING, setup->frame_id, NULL);
  return gst_event_new_custom (GST_EVENT_CUSTOM_DOWNSTREAM_STICKY, s);
}

/* The bits of an event's type that GStreamer's data protocol carries. */
#define DATA_PROTOCOL_TYPE_MASK 0xffff

gboolean
sonar_event_is_setup (GstEvent * event)
{
  const guint type = GST_EVENT_TYPE (event);

  return (type == GST_EVENT_CUSTOM_DOWNSTREAM_STICKY
      || type == (GST_EVENT_CUSTOM_DOWNSTREAM_STICKY &
          DATA_PROTOCOL_TYPE_MASK))
      && gst_event_has_name (event, SONAR_SETUP_EVENT_NAME);
}

GstEvent *
sonar_setup_event_restore (GstEvent * event)
{
  GstEvent *restored;

  if (GST_EVENT_TYPE (event) == GST_EVENT_CUSTOM_DOWNSTREAM_STICKY)
    return event;
  restored = gst_event_new_custom (GST_EVENT_CUSTOM_DOWNSTREAM_STICKY,
      gst_structure_copy (gst_event_get_structure (event)));
  gst_event_unref (event);
  return restored;
}

/* The @n values of @width bytes each that field @field of @s encodes
 * (see doubles_to_base64 ()), in host order: g_free them. */
static gpointer
get_base64_array (const GstStructure * s, const char *field, gsize n,
    gsize width, GError ** error)
{
  const char *text = gst_structure_get_string (s, field);
  guchar *data;
  gsize size;

  if (!text) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_FORMAT,
        "sonar-setup event: missing string field \"%s\"", field);
    return NULL;
  }
  data = g_base64_decode (text, &size);
  if (size != n * width) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_FORMAT,
        "sonar-setup event: \"%s\" holds %" G_GSIZE_FORMAT " bytes, "
        "expected %" G_GSIZE_FORMAT " values of %" G_GSIZE_FORMAT " bytes",
        field, size, n, width);
    g_free (data);
    return NULL;
  }
  for (gsize i = 0; i < n; i++) {
    if (width == sizeof (guint64)) {
      guint64 *v = (guint64 *) (gpointer) data + i;
      *v = GUINT64_FROM_LE (*v);
    } else {
      guint32 *v = (guint32 *) (gpointer) data + i;
      *v = GUINT32_FROM_LE (*v);
    }
  }
  return data;
}

static gboolean
get_vec3_array (const GstStructure * s, const char *field, guint n,
    SonarVec3 ** out, GError ** error)
{
  g_autofree double *xyz = get_base64_array (s, field, 3 * (gsize) n,
      sizeof (double), error);

  if (!xyz)
    return FALSE;
  *out = g_new (SonarVec3, n);
  for (guint i = 0; i < n; i++)
    (*out)[i] = sonar_vec3 (xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
  return TRUE;
}

SonarSetup *
sonar_setup_from_structure (const GstStructure * s, GError ** error)
{
  SonarSetupParams p;
  SonarGeometry geometry = { 0 };
  const char *view = NULL;
  g_autofree float *waveforms = NULL;
  SonarSetup *setup = NULL;

  sonar_setup_params_init (&p);
  if (!gst_structure_has_name (s, SONAR_SETUP_EVENT_NAME)
      || !gst_structure_get (s, "sample-rate", G_TYPE_DOUBLE, &p.sample_rate,
          "speed-of-sound", G_TYPE_DOUBLE, &p.speed_of_sound,
          "band-low", G_TYPE_DOUBLE, &p.band_low,
          "band-high", G_TYPE_DOUBLE, &p.band_high,
          "ping-length", G_TYPE_UINT, &p.ping_length,
          "ping-period", G_TYPE_DOUBLE, &p.ping_period,
          "ping-stride", G_TYPE_DOUBLE, &p.ping_stride,
          "trigger-offset", G_TYPE_UINT64, &p.trigger_offset,
          "waveform-length", G_TYPE_UINT, &p.waveform_length,
          "n-microphones", G_TYPE_UINT, &geometry.n_microphones,
          "n-emitters", G_TYPE_UINT, &geometry.n_emitters, NULL)
      || !(view = gst_structure_get_string (s, "field-of-view"))
      || !sonar_field_of_view_from_string (view, &p.field_of_view)
      || (gst_structure_has_field (s, "frame-id")
          && !(p.frame_id = gst_structure_get_string (s, "frame-id")))) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_FORMAT,
        "sonar-setup event: missing or mistyped field (see "
        "docs/CONTRACTS.md)");
    return NULL;
  }
  if (geometry.n_microphones > SONAR_MAX_MICROPHONES
      || geometry.n_emitters > SONAR_MAX_EMITTERS
      || p.waveform_length > SONAR_MAX_WAVEFORM_LENGTH) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_FORMAT,
        "sonar-setup event: sizes out of range");
    return NULL;
  }
  waveforms = get_base64_array (s, "waveforms", (gsize) geometry.n_emitters *
      p.waveform_length, sizeof (float), error);
  if (waveforms
      && get_vec3_array (s, "microphones", geometry.n_microphones,
          &geometry.microphones, error)
      && get_vec3_array (s, "emitters", geometry.n_emitters,
          &geometry.emitters, error)) {
    p.geometry = &geometry;
    p.waveforms = waveforms;
    setup = sonar_setup_new (&p, error);
  }
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
    g_value_take_boxed (&item, gst_structure_new ("reflector",
            "id", G_TYPE_UINT, t->reflector,
            "kind", G_TYPE_STRING, sonar_reflector_kind_to_string (t->kind),
            "range", G_TYPE_DOUBLE, t->range,
            "azimuth", G_TYPE_DOUBLE, t->azimuth,
            "elevation", G_TYPE_DOUBLE, t->elevation,
            "radial_velocity", G_TYPE_DOUBLE, t->radial_velocity,
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

/* Microphone spectra ------------------------------------------------------*/

GstCaps *
sonar_spectra_caps_new (guint channels, const SonarBand * band)
{
  return gst_caps_new_simple (SONAR_SPECTRA_MEDIA_TYPE,
      "channels", G_TYPE_INT, (int) channels,
      "rate", G_TYPE_INT, (int) band->sample_rate,
      "fft-size", G_TYPE_INT, (int) band->fft_size,
      "first-bin", G_TYPE_INT, (int) band->first_bin,
      "bins", G_TYPE_INT, (int) band->n_bins, NULL);
}

gboolean
sonar_spectra_caps_parse (const GstCaps * caps, guint * channels,
    SonarBand * band)
{
  const GstStructure *s;
  int ch, rate, size, first, bins;

  if (!gst_caps_is_fixed (caps))
    return FALSE;
  s = gst_caps_get_structure (caps, 0);
  if (!gst_structure_has_name (s, SONAR_SPECTRA_MEDIA_TYPE)
      || !gst_structure_get (s, "channels", G_TYPE_INT, &ch,
          "rate", G_TYPE_INT, &rate, "fft-size", G_TYPE_INT, &size,
          "first-bin", G_TYPE_INT, &first, "bins", G_TYPE_INT, &bins, NULL)
      || ch < 1 || rate < 1 || size < 2 || first < 0 || bins < 1
      || first + bins > size / 2 + 1)
    return FALSE;
  *channels = ch;
  band->sample_rate = rate;
  band->fft_size = size;
  band->first_bin = first;
  band->n_bins = bins;
  return TRUE;
}

/* The Doppler bank event --------------------------------------------------*/

GType
sonar_doppler_bank_get_type (void)
{
  static GType type = 0;

  if (g_once_init_enter (&type)) {
    GType t = g_type_from_name ("SonarDopplerBank");
    if (!t)
      t = g_boxed_type_register_static ("SonarDopplerBank",
          (GBoxedCopyFunc) sonar_doppler_bank_ref,
          (GBoxedFreeFunc) sonar_doppler_bank_unref);
    g_once_init_leave (&type, t);
  }
  return type;
}

GstEvent *
sonar_bank_event_new (SonarDopplerBank * bank, const SonarBand * band)
{
  const guint n = sonar_doppler_bank_n_velocities (bank);
  GstStructure *s = gst_structure_new (SONAR_BANK_EVENT_NAME,
      "bank", SONAR_TYPE_DOPPLER_BANK, bank,
      "velocity-min", G_TYPE_DOUBLE, sonar_doppler_bank_velocity (bank, 0),
      "velocity-max", G_TYPE_DOUBLE, sonar_doppler_bank_velocity (bank, n - 1),
      "velocity-step", G_TYPE_DOUBLE, sonar_doppler_bank_step (bank),
      "velocities", G_TYPE_UINT, n,
      "rate", G_TYPE_INT, (int) band->sample_rate,
      "fft-size", G_TYPE_INT, (int) band->fft_size,
      "first-bin", G_TYPE_INT, (int) band->first_bin,
      "bins", G_TYPE_INT, (int) band->n_bins, NULL);
  return gst_event_new_custom (GST_EVENT_CUSTOM_DOWNSTREAM_STICKY, s);
}

gboolean
sonar_event_is_bank (GstEvent * event)
{
  return GST_EVENT_TYPE (event) == GST_EVENT_CUSTOM_DOWNSTREAM_STICKY
      && gst_event_has_name (event, SONAR_BANK_EVENT_NAME);
}

SonarDopplerBank *
sonar_bank_from_event (GstEvent * event, SonarBand * band)
{
  const GstStructure *s = gst_event_get_structure (event);
  SonarDopplerBank *bank = NULL;
  int rate, size, first, bins;

  if (!gst_structure_get (s, "bank", SONAR_TYPE_DOPPLER_BANK, &bank,
          "rate", G_TYPE_INT, &rate, "fft-size", G_TYPE_INT, &size,
          "first-bin", G_TYPE_INT, &first, "bins", G_TYPE_INT, &bins, NULL))
    return NULL;
  band->sample_rate = rate;
  band->fft_size = size;
  band->first_bin = first;
  band->n_bins = bins;
  return bank;
}

/* The spectra meta --------------------------------------------------------*/

GType
sonar_spectra_meta_api_get_type (void)
{
  static GType type = 0;
  static const gchar *tags[] = { NULL };

  if (g_once_init_enter (&type)) {
    GType t = g_type_from_name ("SonarSpectraMetaAPI");
    if (!t)
      t = gst_meta_api_type_register ("SonarSpectraMetaAPI", tags);
    g_once_init_leave (&type, t);
  }
  return type;
}

static gboolean
spectra_meta_init (GstMeta * meta, gpointer params, GstBuffer * buffer)
{
  ((SonarSpectraMeta *) meta)->spectra = NULL;
  return TRUE;
}

static void
spectra_meta_free (GstMeta * meta, GstBuffer * buffer)
{
  gst_clear_buffer (&((SonarSpectraMeta *) meta)->spectra);
}

static gboolean
spectra_meta_transform (GstBuffer * dest, GstMeta * meta, GstBuffer * buffer,
    GQuark type, gpointer data)
{
  SonarSpectraMeta *m = (SonarSpectraMeta *) meta;
  return sonar_buffer_add_spectra_meta (dest, m->spectra, m->channels,
      &m->band) != NULL;
}

static const GstMetaInfo *
sonar_spectra_meta_get_info (void)
{
  static const GstMetaInfo *info = NULL;

  if (g_once_init_enter ((GstMetaInfo **) & info)) {
    const GstMetaInfo *mi = gst_meta_get_info ("SonarSpectraMeta");
    if (!mi)
      mi = gst_meta_register (SONAR_SPECTRA_META_API_TYPE, "SonarSpectraMeta",
          sizeof (SonarSpectraMeta), spectra_meta_init, spectra_meta_free,
          spectra_meta_transform);
    g_once_init_leave ((GstMetaInfo **) & info, (GstMetaInfo *) mi);
  }
  return info;
}

SonarSpectraMeta *
sonar_buffer_add_spectra_meta (GstBuffer * buffer, GstBuffer * spectra,
    guint channels, const SonarBand * band)
{
  SonarSpectraMeta *m = (SonarSpectraMeta *) gst_buffer_add_meta (buffer,
      sonar_spectra_meta_get_info (), NULL);

  if (!m)
    return NULL;
  m->spectra = gst_buffer_ref (spectra);
  m->channels = channels;
  m->band = *band;
  return m;
}

/* Energyscapes ------------------------------------------------------------*/

GstCaps *
sonar_energyscape_caps_new (const SonarImageGrid * grid, guint records,
    guint hypotheses)
{
  return gst_caps_new_simple (SONAR_ENERGYSCAPE_MEDIA_TYPE,
      "records", G_TYPE_INT, (int) records,
      "hypotheses", G_TYPE_INT, (int) hypotheses,
      "n-azimuth", G_TYPE_INT, (int) grid->n_azimuth,
      "azimuth-first", G_TYPE_DOUBLE, grid->azimuth_first,
      "azimuth-step", G_TYPE_DOUBLE, grid->azimuth_step,
      "n-elevation", G_TYPE_INT, (int) grid->n_elevation,
      "elevation-first", G_TYPE_DOUBLE, grid->elevation_first,
      "elevation-step", G_TYPE_DOUBLE, grid->elevation_step,
      "n-range", G_TYPE_INT, (int) grid->n_range,
      "range-first", G_TYPE_DOUBLE, grid->range_first,
      "range-step", G_TYPE_DOUBLE, grid->range_step, NULL);
}

gboolean
sonar_energyscape_caps_parse (const GstCaps * caps, SonarImageGrid * grid,
    guint * records, guint * hypotheses)
{
  const GstStructure *s;
  int n_rec, n_az, n_el, n_r, n_hyp = 1;

  if (!gst_caps_is_fixed (caps))
    return FALSE;
  s = gst_caps_get_structure (caps, 0);
  if (!gst_structure_has_name (s, SONAR_ENERGYSCAPE_MEDIA_TYPE)
      || !gst_structure_get (s, "records", G_TYPE_INT, &n_rec,
          "n-azimuth", G_TYPE_INT, &n_az,
          "azimuth-first", G_TYPE_DOUBLE, &grid->azimuth_first,
          "azimuth-step", G_TYPE_DOUBLE, &grid->azimuth_step,
          "n-elevation", G_TYPE_INT, &n_el,
          "elevation-first", G_TYPE_DOUBLE, &grid->elevation_first,
          "elevation-step", G_TYPE_DOUBLE, &grid->elevation_step,
          "n-range", G_TYPE_INT, &n_r,
          "range-first", G_TYPE_DOUBLE, &grid->range_first,
          "range-step", G_TYPE_DOUBLE, &grid->range_step, NULL)
      || n_rec < 1 || n_az < 1 || n_el < 1 || n_r < 1)
    return FALSE;
  /* Absent (an image made elsewhere): a single envelope per pixel. */
  if (gst_structure_has_field (s, "hypotheses")
      && (!gst_structure_get_int (s, "hypotheses", &n_hyp) || n_hyp < 1))
    return FALSE;
  if (hypotheses)
    *hypotheses = n_hyp;
  grid->n_azimuth = n_az;
  grid->n_elevation = n_el;
  grid->n_range = n_r;
  *records = n_rec;
  return TRUE;
}

void
sonar_energyscape_header_init (SonarEnergyscapeHeader * h,
    const SonarImageGrid * grid, guint64 ping_index, double velocity,
    int emitter)
{
  memset (h, 0, sizeof (*h));
  memcpy (h->magic, SONAR_ENERGYSCAPE_MAGIC, 8);
  h->header_size = sizeof (*h);
  h->n_azimuth = grid->n_azimuth;
  h->n_elevation = grid->n_elevation;
  h->n_range = grid->n_range;
  h->ping_index = ping_index;
  h->azimuth_first = grid->azimuth_first;
  h->azimuth_step = grid->azimuth_step;
  h->elevation_first = grid->elevation_first;
  h->elevation_step = grid->elevation_step;
  h->range_first = grid->range_first;
  h->range_step = grid->range_step;
  h->velocity = velocity;
  h->emitter = emitter;
}

gboolean
sonar_energyscape_header_parse (const SonarEnergyscapeHeader * h,
    SonarImageGrid * grid)
{
  if (memcmp (h->magic, SONAR_ENERGYSCAPE_MAGIC, 8) != 0
      || h->header_size != sizeof (*h) || h->n_azimuth == 0
      || h->n_elevation == 0 || h->n_range == 0)
    return FALSE;
  grid->n_azimuth = h->n_azimuth;
  grid->n_elevation = h->n_elevation;
  grid->n_range = h->n_range;
  grid->azimuth_first = h->azimuth_first;
  grid->azimuth_step = h->azimuth_step;
  grid->elevation_first = h->elevation_first;
  grid->elevation_step = h->elevation_step;
  grid->range_first = h->range_first;
  grid->range_step = h->range_step;
  return TRUE;
}

/* Array metas: centroids and detections -----------------------------------*/

/* Both metas hold a ping index and a copied array; they differ only in the
 * element type. */
typedef struct
{
  GstMeta meta;
  guint64 ping_index;
  guint n;
  gpointer items;
} ArrayMeta;

static gboolean
array_meta_init (GstMeta * meta, gpointer params, GstBuffer * buffer)
{
  ArrayMeta *m = (ArrayMeta *) meta;
  m->ping_index = 0;
  m->n = 0;
  m->items = NULL;
  return TRUE;
}

static void
array_meta_free (GstMeta * meta, GstBuffer * buffer)
{
  g_free (((ArrayMeta *) meta)->items);
}

static GType
array_meta_api_type (const char *name)
{
  static const gchar *tags[] = { NULL };
  GType t = g_type_from_name (name);
  return t ? t : gst_meta_api_type_register (name, tags);
}

static const GstMetaInfo *
array_meta_info (GType api, const char *name, GstMetaTransformFunction
    transform)
{
  const GstMetaInfo *mi = gst_meta_get_info (name);
  return mi ? mi : gst_meta_register (api, name, sizeof (ArrayMeta),
      array_meta_init, array_meta_free, transform);
}

static ArrayMeta *
array_meta_add (GstBuffer * buffer, const GstMetaInfo * info,
    guint64 ping_index, gconstpointer items, guint n, gsize item_size)
{
  ArrayMeta *m = (ArrayMeta *) gst_buffer_add_meta (buffer, info, NULL);
  if (!m)
    return NULL;
  m->ping_index = ping_index;
  m->n = n;
  m->items = g_memdup2 (items, item_size * n);
  return m;
}

GType
sonar_centroids_meta_api_get_type (void)
{
  static GType type = 0;
  if (g_once_init_enter (&type))
    g_once_init_leave (&type, array_meta_api_type ("SonarCentroidsMetaAPI"));
  return type;
}

static gboolean
centroids_meta_transform (GstBuffer * dest, GstMeta * meta,
    GstBuffer * buffer, GQuark type, gpointer data)
{
  ArrayMeta *m = (ArrayMeta *) meta;
  return sonar_buffer_add_centroids_meta (dest, m->ping_index, m->items,
      m->n) != NULL;
}

SonarCentroidsMeta *
sonar_buffer_add_centroids_meta (GstBuffer * buffer, guint64 ping_index,
    const SonarCentroid * centroids, guint n)
{
  static const GstMetaInfo *info = NULL;
  if (g_once_init_enter ((GstMetaInfo **) & info))
    g_once_init_leave ((GstMetaInfo **) & info, (GstMetaInfo *)
        array_meta_info (SONAR_CENTROIDS_META_API_TYPE, "SonarCentroidsMeta",
            centroids_meta_transform));
  return (SonarCentroidsMeta *) array_meta_add (buffer, info, ping_index,
      centroids, n, sizeof (SonarCentroid));
}

GType
sonar_detections_meta_api_get_type (void)
{
  static GType type = 0;
  if (g_once_init_enter (&type))
    g_once_init_leave (&type, array_meta_api_type ("SonarDetectionsMetaAPI"));
  return type;
}

static gboolean
detections_meta_transform (GstBuffer * dest, GstMeta * meta,
    GstBuffer * buffer, GQuark type, gpointer data)
{
  ArrayMeta *m = (ArrayMeta *) meta;
  return sonar_buffer_add_detections_meta (dest, m->ping_index, m->items,
      m->n) != NULL;
}

SonarDetectionsMeta *
sonar_buffer_add_detections_meta (GstBuffer * buffer, guint64 ping_index,
    const SonarDetection * detections, guint n)
{
  static const GstMetaInfo *info = NULL;
  if (g_once_init_enter ((GstMetaInfo **) & info))
    g_once_init_leave ((GstMetaInfo **) & info, (GstMetaInfo *)
        array_meta_info (SONAR_DETECTIONS_META_API_TYPE,
            "SonarDetectionsMeta", detections_meta_transform));
  return (SonarDetectionsMeta *) array_meta_add (buffer, info, ping_index,
      detections, n, sizeof (SonarDetection));
}

static GstStructure *
list_message (const char *name, guint64 ping_index, GstClockTime timestamp,
    const char *field, GValue * array)
{
  GstStructure *s = gst_structure_new (name,
      "ping", G_TYPE_UINT64, ping_index,
      "timestamp", G_TYPE_UINT64, timestamp, NULL);
  gst_structure_take_value (s, field, array);
  return s;
}

GstStructure *
sonar_centroids_to_structure (guint64 ping_index, GstClockTime timestamp,
    const SonarCentroid * centroids, guint n)
{
  GValue array = G_VALUE_INIT;

  g_value_init (&array, GST_TYPE_ARRAY);
  for (guint k = 0; k < n; k++) {
    const SonarCentroid *c = &centroids[k];
    GValue item = G_VALUE_INIT;
    g_value_init (&item, GST_TYPE_STRUCTURE);
    g_value_take_boxed (&item, gst_structure_new ("centroid",
            "range", G_TYPE_DOUBLE, c->range,
            "azimuth", G_TYPE_DOUBLE, c->azimuth,
            "elevation", G_TYPE_DOUBLE, c->elevation,
            "x", G_TYPE_DOUBLE, c->position.x,
            "y", G_TYPE_DOUBLE, c->position.y,
            "z", G_TYPE_DOUBLE, c->position.z,
            "peak", G_TYPE_DOUBLE, c->peak_value,
            "members", G_TYPE_UINT, c->n_members, NULL));
    gst_value_array_append_and_take_value (&array, &item);
  }
  return list_message (SONAR_CENTROIDS_MESSAGE_NAME, ping_index, timestamp,
      "centroids", &array);
}

GstStructure *
sonar_detections_to_structure (guint64 ping_index, GstClockTime timestamp,
    const char *frame_id, const SonarDetection * detections, guint n)
{
  GValue array = G_VALUE_INIT;
  GstStructure *s;

  g_value_init (&array, GST_TYPE_ARRAY);
  for (guint k = 0; k < n; k++) {
    const SonarDetection *d = &detections[k];
    GValue item = G_VALUE_INIT;
    g_value_init (&item, GST_TYPE_STRUCTURE);
    g_value_take_boxed (&item, gst_structure_new ("detection",
            "range", G_TYPE_DOUBLE, d->range,
            "azimuth", G_TYPE_DOUBLE, d->azimuth,
            "elevation", G_TYPE_DOUBLE, d->elevation,
            "x", G_TYPE_DOUBLE, d->position.x,
            "y", G_TYPE_DOUBLE, d->position.y,
            "z", G_TYPE_DOUBLE, d->position.z,
            "instant", G_TYPE_DOUBLE, d->instant,
            "radial_velocity", G_TYPE_DOUBLE, d->radial_velocity,
            "approaching", G_TYPE_BOOLEAN, d->approaching,
            "confidence", G_TYPE_DOUBLE, d->confidence,
            "out_of_range", G_TYPE_BOOLEAN, d->out_of_range,
            "valid", G_TYPE_BOOLEAN, d->valid,
            "amplitude", G_TYPE_DOUBLE, d->amplitude,
            "snr", G_TYPE_DOUBLE, d->snr,
            "range_sigma", G_TYPE_DOUBLE, d->range_sigma,
            "azimuth_sigma", G_TYPE_DOUBLE, d->azimuth_sigma,
            "elevation_sigma", G_TYPE_DOUBLE, d->elevation_sigma,
            "radial_velocity_sigma", G_TYPE_DOUBLE, d->radial_velocity_sigma,
            "frame_id", G_TYPE_STRING, d->frame_id, NULL));
    gst_value_array_append_and_take_value (&array, &item);
  }
  s = list_message (SONAR_DETECTIONS_MESSAGE_NAME, ping_index, timestamp,
      "detections", &array);
  gst_structure_set (s, "frame_id", G_TYPE_STRING, frame_id ? frame_id : "",
      NULL);
  return s;
}

/* JSON built with json-glib's JsonBuilder, written by sonar_json_to_line
 * () (json-glib's generator, but numbers at their shortest). Each number
 * is rounded to a fixed number of decimals, an uncertainty to 3
 * significant digits; a non-finite one is null. */
static void
add_number (JsonBuilder * b, const char *name, double value, int decimals)
{
  const double scale = pow (10.0, decimals);

  json_builder_set_member_name (b, name);
  if (isfinite (value))
    json_builder_add_double_value (b, round (value * scale) / scale);
  else
    json_builder_add_null_value (b);
}

/* Decimals of positions (m), directions (degrees) and velocities (m/s):
 * units under the smallest uncertainty detections report (0.27 um,
 * 0.0006 degree, 2e-5 m/s on the presets' 65-75 dB echoes), so that
 * rounding (an rms of unit / sqrt (12)) adds at most 4 % to the error a
 * sigma states (with 0.1 mm, 0.01 degree, 0.1 mm/s it was the larger
 * error of ranges above 35 dB). */
#define METRE_DECIMALS 7
#define DEGREE_DECIMALS 5
#define VELOCITY_DECIMALS 6

static double significant (double value, int digits);

/* A point in the sensor frame, as detections and tracks give it: range,
 * azimuth, elevation, then x, y, z. */
static void
add_point (JsonBuilder * b, double range, double azimuth, double elevation,
    SonarVec3 position)
{
  add_number (b, "range", range, METRE_DECIMALS);
  add_number (b, "azimuth", azimuth, DEGREE_DECIMALS);
  add_number (b, "elevation", elevation, DEGREE_DECIMALS);
  add_number (b, "x", position.x, METRE_DECIMALS);
  add_number (b, "y", position.y, METRE_DECIMALS);
  add_number (b, "z", position.z, METRE_DECIMALS);
}

/* A number that spans decades (an uncertainty) to @digits significant
 * digits. */
static void
add_significant (JsonBuilder * b, const char *name, double value, int digits)
{
  json_builder_set_member_name (b, name);
  if (isfinite (value))
    json_builder_add_double_value (b, significant (value, digits));
  else
    json_builder_add_null_value (b);
}

static void
add_boolean (JsonBuilder * b, const char *name, gboolean value)
{
  json_builder_set_member_name (b, name);
  json_builder_add_boolean_value (b, value);
}

static void
add_string (JsonBuilder * b, const char *name, const char *value)
{
  json_builder_set_member_name (b, name);
  if (value)
    json_builder_add_string_value (b, value);
  else
    json_builder_add_null_value (b);
}

/* The ping's members every JSON line starts with. */
static JsonBuilder *
begin_ping (guint64 ping_index, GstClockTime timestamp)
{
  JsonBuilder *b = json_builder_new ();

  json_builder_begin_object (b);
  json_builder_set_member_name (b, "ping");
  json_builder_add_int_value (b, (gint64) ping_index);
  add_number (b, "time", GST_CLOCK_TIME_IS_VALID (timestamp) ?
      timestamp / (double) GST_SECOND : NAN, 6);
  return b;
}

/* Closes @b's object and returns its text and a newline. */
static char *
end_ping (JsonBuilder * b)
{
  g_autoptr (JsonNode) root = NULL;
  char *text, *line;

  json_builder_end_object (b);
  root = json_builder_get_root (b);
  g_object_unref (b);
  text = sonar_json_to_line (root);
  line = g_strconcat (text, "\n", NULL);
  g_free (text);
  return line;
}

char *
sonar_detections_to_json (guint64 ping_index, GstClockTime timestamp,
    const char *frame_id, const SonarDetection * detections, guint n)
{
  JsonBuilder *b = begin_ping (ping_index, timestamp);

  add_string (b, "frame_id", frame_id ? frame_id : "");
  json_builder_set_member_name (b, "detections");
  json_builder_begin_array (b);
  for (guint k = 0; k < n; k++) {
    const SonarDetection *d = &detections[k];
    json_builder_begin_object (b);
    add_point (b, d->range, d->azimuth, d->elevation, d->position);
    add_number (b, "instant", d->instant, 7);
    add_number (b, "radial_velocity", d->radial_velocity, VELOCITY_DECIMALS);
    add_boolean (b, "approaching", d->approaching);
    add_number (b, "confidence", d->confidence, 3);
    add_boolean (b, "out_of_range", d->out_of_range);
    add_boolean (b, "valid", d->valid);
    add_number (b, "amplitude", d->amplitude, 2);
    add_number (b, "snr", d->snr, 2);
    add_significant (b, "range_sigma", d->range_sigma, 3);
    add_significant (b, "azimuth_sigma", d->azimuth_sigma, 3);
    add_significant (b, "elevation_sigma", d->elevation_sigma, 3);
    add_significant (b, "radial_velocity_sigma", d->radial_velocity_sigma,
        3);
    add_string (b, "frame_id", d->frame_id);
    json_builder_end_object (b);
  }
  json_builder_end_array (b);
  return end_ping (b);
}

/* Errors -----------------------------------------------------------------*/

void
sonar_element_post_error (GstElement * element, const GError * error,
    const char *debug, const char *file, const char *function, int line)
{
  gst_element_message_full (element, GST_MESSAGE_ERROR, error->domain,
      error->code, g_strdup (error->message), g_strdup (debug), file,
      function, line);
}

/* Tracks -----------------------------------------------------------------*/

GType
sonar_tracks_meta_api_get_type (void)
{
  static GType type = 0;
  if (g_once_init_enter (&type))
    g_once_init_leave (&type, array_meta_api_type ("SonarTracksMetaAPI"));
  return type;
}

static gboolean
tracks_meta_init (GstMeta * meta, gpointer params, GstBuffer * buffer)
{
  SonarTracksMeta *m = (SonarTracksMeta *) meta;
  m->ping_index = 0;
  memset (&m->ego, 0, sizeof m->ego);
  m->n_tracks = 0;
  m->tracks = NULL;
  m->frame_id[0] = '\0';
  return TRUE;
}

static void
tracks_meta_free (GstMeta * meta, GstBuffer * buffer)
{
  g_free (((SonarTracksMeta *) meta)->tracks);
}

static gboolean
tracks_meta_transform (GstBuffer * dest, GstMeta * meta, GstBuffer * buffer,
    GQuark type, gpointer data)
{
  SonarTracksMeta *m = (SonarTracksMeta *) meta;
  SonarTracksMeta *copy = sonar_buffer_add_tracks_meta (dest, m->ping_index,
      &m->ego, m->tracks, m->n_tracks);

  if (copy)
    memcpy (copy->frame_id, m->frame_id, sizeof copy->frame_id);
  return copy != NULL;
}

SonarTracksMeta *
sonar_buffer_add_tracks_meta (GstBuffer * buffer, guint64 ping_index,
    const SonarEgoMotion * ego, const SonarTrack * tracks, guint n)
{
  static const GstMetaInfo *info = NULL;
  SonarTracksMeta *m;

  if (g_once_init_enter ((GstMetaInfo **) & info)) {
    const GstMetaInfo *mi = gst_meta_get_info ("SonarTracksMeta");
    if (!mi)
      mi = gst_meta_register (SONAR_TRACKS_META_API_TYPE, "SonarTracksMeta",
          sizeof (SonarTracksMeta), tracks_meta_init, tracks_meta_free,
          tracks_meta_transform);
    g_once_init_leave ((GstMetaInfo **) & info, (GstMetaInfo *) mi);
  }
  m = (SonarTracksMeta *) gst_buffer_add_meta (buffer, info, NULL);
  if (!m)
    return NULL;
  m->ping_index = ping_index;
  m->ego = *ego;
  m->n_tracks = n;
  m->tracks = g_memdup2 (tracks, sizeof (SonarTrack) * n);
  return m;
}

static void
take_doubles (GstStructure * s, const char *field, const double *values,
    guint n)
{
  GValue array = G_VALUE_INIT;

  g_value_init (&array, GST_TYPE_ARRAY);
  for (guint i = 0; i < n; i++) {
    GValue item = G_VALUE_INIT;
    g_value_init (&item, G_TYPE_DOUBLE);
    g_value_set_double (&item, values[i]);
    gst_value_array_append_and_take_value (&array, &item);
  }
  gst_structure_take_value (s, field, &array);
}

static const char *
ego_reason (const SonarEgoMotion * ego)
{
  return ego->status == SONAR_EGO_OBSERVED ? NULL :
      sonar_ego_status_to_string (ego->status);
}

GstStructure *
sonar_tracks_to_structure (guint64 ping_index, GstClockTime timestamp,
    const char *frame_id, const SonarEgoMotion * ego,
    const SonarTrack * tracks, guint n)
{
  const gboolean observed = ego->status == SONAR_EGO_OBSERVED;
  GValue array = G_VALUE_INIT;
  GstStructure *s;

  g_value_init (&array, GST_TYPE_ARRAY);
  for (guint k = 0; k < n; k++) {
    const SonarTrack *t = &tracks[k];
    const double velocity[3] = { t->velocity.x, t->velocity.y,
      t->velocity.z
    };
    GValue item = G_VALUE_INIT;
    GstStructure *track = gst_structure_new ("track",
        "id", G_TYPE_UINT64, t->id,
        "state", G_TYPE_STRING, sonar_track_state_to_string (t->state),
        "moving", G_TYPE_BOOLEAN, t->moving,
        "instant", G_TYPE_DOUBLE, t->instant,
        "range", G_TYPE_DOUBLE, t->range,
        "azimuth", G_TYPE_DOUBLE, t->azimuth,
        "elevation", G_TYPE_DOUBLE, t->elevation,
        "x", G_TYPE_DOUBLE, t->position.x,
        "y", G_TYPE_DOUBLE, t->position.y,
        "z", G_TYPE_DOUBLE, t->position.z,
        "radial_velocity", G_TYPE_DOUBLE, t->radial_velocity,
        "radius", G_TYPE_DOUBLE, t->radius,
        "hits", G_TYPE_UINT, t->hits,
        "misses", G_TYPE_UINT, t->misses,
        "detection", G_TYPE_INT, t->detection, NULL);
    take_doubles (track, "velocity", velocity, 3);
    take_doubles (track, "position_covariance", &t->position_covariance[0][0],
        9);
    take_doubles (track, "velocity_covariance", &t->velocity_covariance[0][0],
        9);
    g_value_init (&item, GST_TYPE_STRUCTURE);
    g_value_take_boxed (&item, track);
    gst_value_array_append_and_take_value (&array, &item);
  }
  s = list_message (SONAR_TRACKS_MESSAGE_NAME, ping_index, timestamp,
      "tracks", &array);
  gst_structure_set (s, "frame_id", G_TYPE_STRING, frame_id ? frame_id : "",
      "ego_status", G_TYPE_STRING, observed ? "observed" :
      "unobservable", "ego_still", G_TYPE_UINT, ego->n_still, NULL);
  if (observed) {
    const double velocity[3] = { ego->velocity.x, ego->velocity.y,
      ego->velocity.z
    };
    gst_structure_set (s, "ego_dimensions", G_TYPE_UINT, ego->dimensions,
        NULL);
    take_doubles (s, "ego_velocity", velocity, 3);
    take_doubles (s, "ego_covariance", &ego->covariance[0][0], 9);
  } else {
    gst_structure_set (s, "ego_reason", G_TYPE_STRING, ego_reason (ego),
        NULL);
  }
  return s;
}

/* A number to @digits significant digits (covariances span decades). */
static double
significant (double value, int digits)
{
  double scale;

  if (!isfinite (value) || value == 0.0)
    return value;
  scale = pow (10.0, digits - 1 - (int) floor (log10 (fabs (value))));
  return round (value * scale) / scale;
}

static void
add_vector (JsonBuilder * b, const char *name, SonarVec3 v, int decimals)
{
  const double c[3] = { v.x, v.y, v.z };
  const double scale = pow (10.0, decimals);

  json_builder_set_member_name (b, name);
  json_builder_begin_array (b);
  for (guint i = 0; i < 3; i++) {
    if (isfinite (c[i]))
      json_builder_add_double_value (b, round (c[i] * scale) / scale);
    else
      json_builder_add_null_value (b);
  }
  json_builder_end_array (b);
}

static void
add_matrix (JsonBuilder * b, const char *name, const double m[3][3])
{
  json_builder_set_member_name (b, name);
  json_builder_begin_array (b);
  for (guint r = 0; r < 3; r++) {
    json_builder_begin_array (b);
    for (guint c = 0; c < 3; c++) {
      if (isfinite (m[r][c]))
        json_builder_add_double_value (b, significant (m[r][c], 4));
      else
        json_builder_add_null_value (b);
    }
    json_builder_end_array (b);
  }
  json_builder_end_array (b);
}

char *
sonar_tracks_to_json (guint64 ping_index, GstClockTime timestamp,
    const char *frame_id, const SonarEgoMotion * ego,
    const SonarTrack * tracks, guint n)
{
  const gboolean observed = ego->status == SONAR_EGO_OBSERVED;
  JsonBuilder *b = begin_ping (ping_index, timestamp);

  add_string (b, "frame_id", frame_id ? frame_id : "");
  add_string (b, "ego_status", observed ? "observed" : "unobservable");
  add_string (b, "ego_reason", ego_reason (ego));
  if (observed) {
    add_vector (b, "ego_velocity", ego->velocity, VELOCITY_DECIMALS);
    add_matrix (b, "ego_covariance", ego->covariance);
    json_builder_set_member_name (b, "ego_dimensions");
    json_builder_add_int_value (b, ego->dimensions);
  } else {
    json_builder_set_member_name (b, "ego_velocity");
    json_builder_add_null_value (b);
    json_builder_set_member_name (b, "ego_covariance");
    json_builder_add_null_value (b);
    json_builder_set_member_name (b, "ego_dimensions");
    json_builder_add_null_value (b);
  }
  json_builder_set_member_name (b, "ego_still");
  json_builder_add_int_value (b, ego->n_still);
  json_builder_set_member_name (b, "tracks");
  json_builder_begin_array (b);
  for (guint k = 0; k < n; k++) {
    const SonarTrack *t = &tracks[k];
    json_builder_begin_object (b);
    json_builder_set_member_name (b, "id");
    json_builder_add_int_value (b, (gint64) t->id);
    add_string (b, "state", sonar_track_state_to_string (t->state));
    add_boolean (b, "moving", t->moving);
    add_number (b, "instant", t->instant, 7);
    add_point (b, t->range, t->azimuth, t->elevation, t->position);
    add_number (b, "radial_velocity", t->radial_velocity, VELOCITY_DECIMALS);
    add_vector (b, "velocity", t->velocity, VELOCITY_DECIMALS);
    add_number (b, "radius", t->radius, METRE_DECIMALS);
    add_matrix (b, "position_covariance", t->position_covariance);
    add_matrix (b, "velocity_covariance", t->velocity_covariance);
    json_builder_set_member_name (b, "hits");
    json_builder_add_int_value (b, t->hits);
    json_builder_set_member_name (b, "misses");
    json_builder_add_int_value (b, t->misses);
    json_builder_set_member_name (b, "detection");
    if (t->detection >= 0)
      json_builder_add_int_value (b, t->detection);
    else
      json_builder_add_null_value (b);
    json_builder_end_object (b);
  }
  json_builder_end_array (b);
  return end_ping (b);
}

GstEvent *
sonar_ego_prior_event_new (SonarVec3 velocity, double sigma)
{
  return gst_event_new_custom (GST_EVENT_CUSTOM_UPSTREAM,
      gst_structure_new (SONAR_EGO_PRIOR_EVENT_NAME,
          "vx", G_TYPE_DOUBLE, velocity.x,
          "vy", G_TYPE_DOUBLE, velocity.y,
          "vz", G_TYPE_DOUBLE, velocity.z,
          "sigma", G_TYPE_DOUBLE, sigma, NULL));
}

gboolean
sonar_ego_prior_event_parse (GstEvent * event, SonarVec3 * velocity,
    double *sigma)
{
  const GstStructure *s;

  if (GST_EVENT_TYPE (event) != GST_EVENT_CUSTOM_UPSTREAM
      || !gst_event_has_name (event, SONAR_EGO_PRIOR_EVENT_NAME))
    return FALSE;
  s = gst_event_get_structure (event);
  return gst_structure_get_double (s, "vx", &velocity->x)
      && gst_structure_get_double (s, "vy", &velocity->y)
      && gst_structure_get_double (s, "vz", &velocity->z)
      && gst_structure_get_double (s, "sigma", sigma);
}
