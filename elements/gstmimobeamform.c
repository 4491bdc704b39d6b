/* gstmimobeamform.c: mimobeamform, the MIMO virtual-array energyscape.
 *
 * Per ping it matched-filters the microphone spectra with the bank's
 * templates and delay-and-sums them over emitters and microphones (paper
 * eq. 10-13) into an image of direction x range (sonar-imager.h).
 *
 * mode=detection (default): the maximum over Doppler hypotheses spaced
 * hypothesis-spacing m/s across the bank, so that fast movers, which a
 * filter tuned to the wrong speed loses, appear too. mode=fixed: the image
 * at one velocity. mode=datacube: one image per velocity of the bank (the
 * paper's Fig. 3; costly, for comparison). emitter=n images one emitter's
 * echoes only (the single-emitter images of Fig. 4f).
 *
 * Output: application/x-sonar-energyscape (docs/CONTRACTS.md): records of a
 * 96-byte header and float32 pixels; filesink saves them as a file that
 * tools/plot-energyscape.py draws. Each image carries the ping's spectra
 * (SonarSpectraMeta) for velocityest.
 */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstmimobeamform.h"
#include "sonar-memory.h"

#include <math.h>
#include <string.h>

GST_DEBUG_CATEGORY_STATIC (mimo_beamform_debug);
#define GST_CAT_DEFAULT mimo_beamform_debug

typedef enum
{
  IMAGE_MODE_DETECTION,
  IMAGE_MODE_FIXED,
  IMAGE_MODE_DATACUBE,
} ImageMode;

#define GST_TYPE_SONAR_IMAGE_MODE (sonar_image_mode_get_type ())
static GType
sonar_image_mode_get_type (void)
{
  static GType type = 0;
  static const GEnumValue values[] = {
    {IMAGE_MODE_DETECTION, "Maximum over Doppler hypotheses across the bank",
        "detection"},
    {IMAGE_MODE_FIXED, "One image at the velocity property", "fixed"},
    {IMAGE_MODE_DATACUBE, "One image per velocity of the bank (costly)",
        "datacube"},
    {0, NULL, NULL}
  };
  if (g_once_init_enter (&type))
    g_once_init_leave (&type, g_enum_register_static ("GstSonarImageMode",
            values));
  return type;
}

#define DEFAULT_MODE IMAGE_MODE_DETECTION
#define DEFAULT_VELOCITY 0.0
#define DEFAULT_HYPOTHESIS_SPACING 0.0    /* the sensor's */
#define DEFAULT_EMITTER -1

enum
{
  PROP_0,
  PROP_AZIMUTH_MIN,
  PROP_AZIMUTH_MAX,
  PROP_AZIMUTH_COUNT,
  PROP_ELEVATION_MIN,
  PROP_ELEVATION_MAX,
  PROP_ELEVATION_COUNT,
  PROP_RANGE_MIN,
  PROP_RANGE_MAX,
  PROP_RANGE_RESOLUTION,
  PROP_FOCUS_ZONES,
  PROP_COARSE_SPACING,
  PROP_REFINE_DB,
  PROP_REFINE_PFA,
  PROP_COARSE_BAND,
  PROP_COARSE_BAND_PFA,
  PROP_MODE,
  PROP_VELOCITY,
  PROP_HYPOTHESIS_SPACING,
  PROP_EMITTER,
  PROP_THREADS,
  PROP_MAX_MEMORY,
};

struct _GstMimoBeamform
{
  GstSonarFilter parent;

  /* Properties, protected by the object lock. */
  SonarImagerParams params;
  /* Whether the directions and coarse spacing were set: unless they were,
   * they follow the set-up's field of view. */
  gboolean directions_set, coarse_spacing_set;
  /* What the image uses once configured (the set-up's view and beam where
   * the properties were not set): what those properties read back. */
  SonarImagerParams params_in_use;
  gboolean have_params_in_use;
  ImageMode mode;
  double velocity;
  double hypothesis_spacing;
  int emitter;
  guint64 max_memory;
  gboolean retune;              /* refine-db/-pfa, velocity or emitter changed
                                 * while playing: at the next ping (object
                                 * lock) */

  /* Configured state. */
  SonarImager *imager;
  guint channels;
  ImageMode active_mode;
  int active_emitter;
  double active_velocity;       /* mode=fixed */
  guint n_hypotheses;
  guint *indices;               /* the hypotheses' bank velocity indices */
  SonarHypothesis *hypotheses;
};

G_DEFINE_TYPE (GstMimoBeamform, gst_mimo_beamform, GST_TYPE_SONAR_FILTER);
GST_ELEMENT_REGISTER_DEFINE_WITH_CODE (mimobeamform, "mimobeamform",
    GST_RANK_NONE, GST_TYPE_MIMO_BEAMFORM,
    GST_DEBUG_CATEGORY_INIT (mimo_beamform_debug, "mimobeamform", 0,
        "MIMO virtual-array beamformer"));

static GstStaticPadTemplate sink_template = GST_STATIC_PAD_TEMPLATE ("sink",
    GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS (SONAR_SPECTRA_CAPS));
static GstStaticPadTemplate src_template = GST_STATIC_PAD_TEMPLATE ("src",
    GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS (SONAR_ENERGYSCAPE_CAPS));

/* The bank velocity nearest @velocity, for mode=fixed; FALSE with @error
 * when it lies outside the bank. */
static gboolean
fixed_velocity_index (SonarDopplerBank * bank, double velocity, guint * index,
    GError ** error)
{
  const guint n_bank = sonar_doppler_bank_n_velocities (bank);
  const guint i = sonar_doppler_bank_nearest (bank, velocity);

  if (fabs (sonar_doppler_bank_velocity (bank, i) - velocity) >
      0.5 * sonar_doppler_bank_step (bank) + 1e-9) {
    g_set_error (error, GST_CORE_ERROR, GST_CORE_ERROR_NEGOTIATION,
        "mimobeamform: velocity %g m/s is outside the Doppler bank "
        "(%g to %g m/s)", velocity, sonar_doppler_bank_velocity (bank, 0),
        sonar_doppler_bank_velocity (bank, n_bank - 1));
    return FALSE;
  }
  *index = i;
  return TRUE;
}

/* An emitter the sensor has, or -1; FALSE with @error otherwise. */
static gboolean
emitter_exists (const SonarSetup * setup, int emitter, GError ** error)
{
  if (emitter < (int) setup->geometry.n_emitters)
    return TRUE;
  g_set_error (error, GST_CORE_ERROR, GST_CORE_ERROR_NEGOTIATION,
      "mimobeamform: emitter %d does not exist (the sensor has %u: 0 to "
      "%u, or -1 for all)", emitter, setup->geometry.n_emitters,
      setup->geometry.n_emitters - 1);
  return FALSE;
}

/* A grid whose directions lose more than this between them (dB, half the
 * amplitude) is coarser than the array's beam: a warning says so. */
#define GRID_LOSS_WARNING_DB 6.0

/* Directions over @n - 1 steps of @step degrees at steps @factor times
 * that. */
static guint
directions_at (guint n, double step, double factor)
{
  return (guint) ceil ((n - 1) * step / (factor * step) - 1e-9) + 1;
}

/* Warns when the image's grid is coarser than the array's beam: an echo
 * between its directions is imaged more than GRID_LOSS_WARNING_DB low,
 * and its sidelobes can pass wardcluster's sidelobe test as objects
 * (measured: the 3-D hemisphere at 4 degrees, sonar-bench --sweep
 * hemisphere-fig9-grid). */
static void
warn_coarse_grid (GstMimoBeamform * self)
{
  const SonarImageGrid *g = sonar_imager_grid (self->imager);
  const double loss = sonar_imager_sampling_loss (self->imager);
  double f;

  if (!(loss > GRID_LOSS_WARNING_DB))
    return;
  f = sonar_imager_step_factor (self->imager, GRID_LOSS_WARNING_DB);
  if (g->n_azimuth > 1 && g->azimuth_step > 0.0 && g->n_elevation > 1
      && g->elevation_step > 0.0)
    GST_ELEMENT_WARNING (self, RESOURCE, SETTINGS,
        ("the image's %g x %g degree steps (azimuth x elevation) are coarser "
            "than the array's beam: a point at the centre of a cell of four "
            "directions is imaged %.1f dB below its peak at boresight, where "
            "its sidelobes can pass as objects; steps of at most %.2f x %.2f "
            "degrees "
            "(%u x %u directions) keep that within %g dB", g->azimuth_step,
            g->elevation_step, loss, f * g->azimuth_step,
            f * g->elevation_step, directions_at (g->n_azimuth,
                g->azimuth_step, f), directions_at (g->n_elevation,
                g->elevation_step, f), GRID_LOSS_WARNING_DB), (NULL));
  else {
    const gboolean azimuth = g->n_azimuth > 1 && g->azimuth_step > 0.0;
    const guint n = azimuth ? g->n_azimuth : g->n_elevation;
    const double step = azimuth ? g->azimuth_step : g->elevation_step;
    GST_ELEMENT_WARNING (self, RESOURCE, SETTINGS,
        ("the image's %g degree %s step is coarser than the array's beam: "
            "a point halfway between two directions is imaged %.1f dB below "
            "its peak at boresight, where its sidelobes can pass as objects; "
            "a step of at most %.2f degrees (%u directions) keeps that within "
            "%g dB",
            step, azimuth ? "azimuth" : "elevation", loss, f * step,
            directions_at (n, step, f), GRID_LOSS_WARNING_DB), (NULL));
  }
}

/* A coarse pass on a sub-band (coarse-band) sees each echo by the band's
 * share weaker than the whole band does: beyond this many dB it is
 * warned of (sonar-bench --sweep coarse-band: down to a twelfth, 10.8
 * dB, the presets' strong objects stay; at 0.01, 20 dB, none of the
 * default scene's three is found). */
#define COARSE_BAND_WARNING_DB 10.0

static void
warn_coarse_band (GstMimoBeamform * self, double share)
{
  const double loss = -10.0 * log10 (share);

  if (loss > COARSE_BAND_WARNING_DB)
    GST_ELEMENT_WARNING (self, RESOURCE, SETTINGS,
        ("mimobeamform: coarse-band %g: the coarse pass sees each echo "
            "%.1f dB weaker than the whole band does, and may miss any echo "
            "less than that over wardcluster's threshold (a share of at "
            "least %.2f keeps the loss within %g dB)", share, loss,
            pow (10.0, -COARSE_BAND_WARNING_DB / 10.0),
            COARSE_BAND_WARNING_DB), (NULL));
}

/* Beyond this many turns of phase at the focus zones' ends the images
 * lose their objects (the default scene: range-min 0.02 m, 3.4 turns, 1
 * of 3 found; 0.01 m, 6.7 turns, none), short of it they keep them
 * (0.05 m, 1.3 turns, and tools/foreign-scenes.py's array 2.5 times as
 * wide as eRTIS at the defaults, 1.1 turns: every object, the same errors
 * as with the 18 zones of a quarter turn; the default: 0.21). */
#define FOCUS_WARNING_TURNS 2.0

/* The nearest range-min from which @zones focus zones keep the array
 * within a quarter turn of focus to @range_max, @turns that of one zone
 * from @range_min. */
static double
range_min_in_focus (double turns, double range_min, double range_max,
    guint zones)
{
  const double per_inverse_m = turns / (1.0 / range_min - 1.0 / range_max);

  return 1.0 / (0.25 * zones / per_inverse_m + 1.0 / range_max);
}

/* Focus zones too few for the image's ranges. */
static void
warn_focus (GstMimoBeamform * self, const SonarSetup * setup,
    const SonarImagerParams * p, double range_max)
{
  const double turns = sonar_imager_focus_turns (setup, p->range_min,
      range_max);
  const guint needed = (guint) ceil (turns / 0.25);
  g_autofree char *remedy = NULL;

  if (!(turns / p->focus_zones > FOCUS_WARNING_TURNS))
    return;
  remedy = needed <= SONAR_IMAGER_MAX_FOCUS_ZONES ?
      g_strdup_printf ("focus-zones=%u, or range-min=%.2g with %u zones",
      needed, range_min_in_focus (turns, p->range_min, range_max,
          p->focus_zones), p->focus_zones) :
      g_strdup_printf ("range-min=%.2g with %u zones (%.2g with %u)",
      range_min_in_focus (turns, p->range_min, range_max, p->focus_zones),
      p->focus_zones, range_min_in_focus (turns, p->range_min, range_max,
          SONAR_IMAGER_MAX_FOCUS_ZONES), SONAR_IMAGER_MAX_FOCUS_ZONES);
  GST_ELEMENT_WARNING (self, RESOURCE, SETTINGS,
      ("mimobeamform: from range-min %g m to %.3g m, %u focus zones leave "
          "the array's outer elements %.2g turns out of phase at the zones' "
          "ends (at %g Hz): images blur there and echoes may be missed; %s "
          "keeps it within a quarter turn", p->range_min, range_max,
          p->focus_zones, turns / p->focus_zones, setup->band_high, remedy),
      (NULL));
}

static GstCaps *
gst_mimo_beamform_configure (GstSonarFilter * filter, GstCaps * in_caps,
    GError ** error)
{
  GstMimoBeamform *self = GST_MIMO_BEAMFORM (filter);
  SonarSetup *setup = gst_sonar_filter_get_setup (filter);
  SonarDopplerBank *bank = gst_sonar_filter_get_bank (filter);
  const guint n_bank = sonar_doppler_bank_n_velocities (bank);
  SonarImagerParams params;
  SonarBand band;
  double velocity, spacing, range_max;
  GstCaps *out_caps;
  const SonarImageGrid *grid;
  guint64 max_memory, buffer_size;
  guint records;

  if (!in_caps || !sonar_spectra_caps_parse (in_caps, &self->channels, &band)
      || !sonar_band_equal (&band, gst_sonar_filter_get_band (filter))) {
    g_set_error (error, GST_CORE_ERROR, GST_CORE_ERROR_NEGOTIATION,
        "mimobeamform: the input spectra are not on the Doppler bank's band");
    return NULL;
  }

  GST_OBJECT_LOCK (self);
  params = self->params;
  if (!self->directions_set || !self->coarse_spacing_set) {
    SonarImagerParams view = params;
    sonar_imager_params_set_view (&view, setup->field_of_view);
    if (!self->directions_set) {
      params.azimuth_min = view.azimuth_min;
      params.azimuth_max = view.azimuth_max;
      params.n_azimuth = view.n_azimuth;
      params.elevation_min = view.elevation_min;
      params.elevation_max = view.elevation_max;
      params.n_elevation = view.n_elevation;
    }
    if (!self->coarse_spacing_set)
      sonar_imager_params_fit_beam (&params);
  }
  self->params_in_use = params;
  self->have_params_in_use = TRUE;
  self->active_mode = self->mode;
  self->active_emitter = self->emitter;
  velocity = self->velocity;
  spacing = self->hypothesis_spacing > 0.0 ? self->hypothesis_spacing :
      sonar_setup_hypothesis_spacing (setup);
  max_memory = self->max_memory;
  GST_OBJECT_UNLOCK (self);

  if (!emitter_exists (setup, self->active_emitter, error))
    return NULL;
  self->imager = sonar_imager_new (setup, &band, &params, error);
  if (!self->imager)
    return NULL;
  {
    /* The coarse grid it chose (a number of main lobes, or degrees). */
    double azimuth, elevation;
    sonar_imager_coarse_spacing (self->imager, &azimuth, &elevation);
    GST_OBJECT_LOCK (self);
    self->params_in_use.coarse_spacing = MAX (azimuth, elevation);
    GST_OBJECT_UNLOCK (self);
  }
  range_max = sonar_imager_range_max (setup, params.range_max);
  if (params.range_max > range_max)
    GST_ELEMENT_WARNING (self, RESOURCE, SETTINGS,
        ("range-max %g m is beyond what one ping records: the image stops "
            "at %.3f m, the end of the %u-sample window", params.range_max,
            range_max, setup->ping_length), (NULL));
  warn_coarse_grid (self);
  warn_coarse_band (self, params.coarse_band);
  warn_focus (self, setup, &params, range_max);

  self->indices = g_new (guint, n_bank + 2);
  switch (self->active_mode) {
    case IMAGE_MODE_DETECTION:
      self->n_hypotheses = sonar_doppler_bank_hypotheses (bank, spacing,
          self->indices);
      break;
    case IMAGE_MODE_FIXED:{
      guint i;
      if (!fixed_velocity_index (bank, velocity, &i, error))
        return NULL;
      self->active_velocity = velocity;
      self->indices[0] = i;
      self->n_hypotheses = 1;
      break;
    }
    case IMAGE_MODE_DATACUBE:
      for (guint i = 0; i < n_bank; i++)
        self->indices[i] = i;
      self->n_hypotheses = n_bank;
      break;
  }
  self->hypotheses = g_new (SonarHypothesis, self->n_hypotheses);
  for (guint h = 0; h < self->n_hypotheses; h++)
    self->hypotheses[h] = sonar_doppler_bank_hypothesis (bank,
        self->indices[h]);
  GST_INFO_OBJECT (self, "%u Doppler hypotheses", self->n_hypotheses);
  records = self->active_mode == IMAGE_MODE_DATACUBE ? self->n_hypotheses : 1;
  grid = sonar_imager_grid (self->imager);
  buffer_size = sonar_memory_array (records, sizeof (SonarEnergyscapeHeader)
      + sizeof (float) * (guint64) sonar_image_grid_size (grid));
  if (!sonar_memory_check_buffers (0, buffer_size,
          GST_SONAR_FILTER_POOL_MIN_BUFFERS, max_memory, error,
          "mimobeamform: %u output buffers of %u image%s of %u azimuths x "
          "%u elevations x %u ranges (azimuth-count, elevation-count, "
          "range-min, range-max, range-resolution)",
          GST_SONAR_FILTER_POOL_MIN_BUFFERS, records,
          records > 1 ? "s (mode=datacube)" : "", grid->n_azimuth,
          grid->n_elevation, grid->n_range))
    return NULL;
  out_caps = sonar_energyscape_caps_new (grid, records,
      records == 1 ? self->n_hypotheses : 1);
  if (!gst_sonar_filter_use_pool (filter, out_caps, buffer_size)) {
    g_set_error (error, GST_CORE_ERROR, GST_CORE_ERROR_FAILED,
        "mimobeamform: could not make its buffer pool");
    gst_caps_unref (out_caps);
    return NULL;
  }
  return out_caps;
}

static void
gst_mimo_beamform_unconfigure (GstSonarFilter * filter)
{
  GstMimoBeamform *self = GST_MIMO_BEAMFORM (filter);

  g_clear_pointer (&self->imager, sonar_imager_free);
  g_clear_pointer (&self->indices, g_free);
  g_clear_pointer (&self->hypotheses, g_free);
}

/* A setting retune () refused (@error): the warning names the value in
 * effect (@in_effect), to which the caller has set @property back. */
static void
refused (GstMimoBeamform * self, GError * error, const char *property,
    double in_effect)
{
  GST_ELEMENT_WARNING (self, LIBRARY, SETTINGS, ("%s: %s stays %g",
          error->message, property, in_effect), (NULL));
  g_error_free (error);
  g_object_notify (G_OBJECT (self), property);
}

/* refine-db, refine-pfa, velocity (mode=fixed) and emitter set while
 * playing take effect at the next ping. One the sensor or bank cannot take
 * is refused alone: a warning, and its property goes back to the value in
 * effect (unless set again since); the others take effect. */
static void
retune (GstMimoBeamform * self)
{
  GstSonarFilter *filter = GST_SONAR_FILTER (self);
  SonarDopplerBank *bank = gst_sonar_filter_get_bank (filter);
  double refine_db, refine_pfa, velocity;
  int emitter;
  GError *error = NULL;
  guint i;

  GST_OBJECT_LOCK (self);
  if (!self->retune) {
    GST_OBJECT_UNLOCK (self);
    return;
  }
  self->retune = FALSE;
  refine_db = self->params.refine_db;
  refine_pfa = self->params.refine_pfa;
  velocity = self->velocity;
  emitter = self->emitter;
  GST_OBJECT_UNLOCK (self);

  if (!sonar_imager_set_refine (self->imager, refine_db, refine_pfa,
          &error)) {
    /* The properties' ranges are the imager's: this would be a bug. */
    GST_ELEMENT_WARNING (self, LIBRARY, SETTINGS, ("%s", error->message),
        (NULL));
    g_clear_error (&error);
  }
  if (emitter_exists (gst_sonar_filter_get_setup (filter), emitter, &error)) {
    self->active_emitter = emitter;
  } else {
    GST_OBJECT_LOCK (self);
    if (self->emitter == emitter)
      self->emitter = self->active_emitter;
    GST_OBJECT_UNLOCK (self);
    refused (self, error, "emitter", self->active_emitter);
    error = NULL;
  }
  if (self->active_mode != IMAGE_MODE_FIXED
      || velocity == self->active_velocity)
    return;
  if (fixed_velocity_index (bank, velocity, &i, &error)) {
    self->active_velocity = velocity;
    self->indices[0] = i;
    self->hypotheses[0] = sonar_doppler_bank_hypothesis (bank, i);
  } else {
    GST_OBJECT_LOCK (self);
    if (self->velocity == velocity)
      self->velocity = self->active_velocity;
    GST_OBJECT_UNLOCK (self);
    refused (self, error, "velocity", self->active_velocity);
  }
}

static GstFlowReturn
gst_mimo_beamform_process (GstSonarFilter * filter, GstBuffer * buffer)
{
  GstMimoBeamform *self = GST_MIMO_BEAMFORM (filter);
  const SonarImageGrid *grid = sonar_imager_grid (self->imager);
  const gsize pixels = sonar_image_grid_size (grid);
  const gsize record_size = sizeof (SonarEnergyscapeHeader) +
      sizeof (float) * pixels;
  const gboolean datacube = self->active_mode == IMAGE_MODE_DATACUBE;
  const guint records = datacube ? self->n_hypotheses : 1;
  const gsize expected = sizeof (SonarComplex) * self->channels *
      gst_sonar_filter_get_band (filter)->n_bins;
  GstBuffer *out;
  GstMapInfo in_map, out_map;

  if (gst_buffer_get_size (buffer) != expected) {
    GST_ELEMENT_ERROR (self, STREAM, FORMAT, ("A spectra buffer of %"
            G_GSIZE_FORMAT " bytes, expected %" G_GSIZE_FORMAT,
            gst_buffer_get_size (buffer), expected), (NULL));
    gst_buffer_unref (buffer);
    return GST_FLOW_ERROR;
  }
  retune (self);
  out = gst_sonar_filter_new_buffer (filter, record_size * records);
  if (!out) {
    gst_buffer_unref (buffer);
    return GST_FLOW_FLUSHING;
  }
  gst_buffer_map (buffer, &in_map, GST_MAP_READ);
  gst_buffer_map (out, &out_map, GST_MAP_WRITE);
  for (guint r = 0; r < records; r++)
    sonar_energyscape_header_init ((SonarEnergyscapeHeader *) (out_map.data +
            r * record_size), grid, GST_BUFFER_OFFSET (buffer),
        datacube || self->n_hypotheses == 1 ?
        self->hypotheses[r].velocity : NAN,
        self->active_emitter);
  if (datacube)
    sonar_imager_process_each (self->imager,
        (const SonarComplex *) in_map.data, self->n_hypotheses,
        self->hypotheses, self->active_emitter,
        (float *) (out_map.data + sizeof (SonarEnergyscapeHeader)),
        record_size / sizeof (float));
  else
    sonar_imager_process (self->imager, (const SonarComplex *) in_map.data,
        self->n_hypotheses, self->hypotheses, self->active_emitter,
        (float *) (out_map.data + sizeof (SonarEnergyscapeHeader)));
  if (gst_debug_category_get_threshold (GST_CAT_DEFAULT) >= GST_LEVEL_DEBUG) {
    guint units, dense_units, passes, dense_passes;
    sonar_imager_last_work (self->imager, &units, &dense_units, &passes,
        &dense_passes);
    GST_DEBUG_OBJECT (self, "ping %" G_GUINT64_FORMAT ": imaged %u of the "
        "dense image's %u units, %u of its %u passes (%.1f %%)",
        GST_BUFFER_OFFSET (buffer), units, dense_units, passes, dense_passes,
        100.0 * passes / MAX (dense_passes, 1u));
  }
  gst_buffer_unmap (out, &out_map);
  gst_buffer_unmap (buffer, &in_map);

  gst_buffer_copy_into (out, buffer, GST_BUFFER_COPY_TIMESTAMPS |
      GST_BUFFER_COPY_FLAGS | GST_BUFFER_COPY_META, 0, -1);
  sonar_buffer_add_spectra_meta (out, buffer, self->channels,
      gst_sonar_filter_get_band (filter));
  gst_buffer_unref (buffer);
  return gst_sonar_filter_push (filter, out);
}

static void
gst_mimo_beamform_set_property (GObject * object, guint prop_id,
    const GValue * value, GParamSpec * pspec)
{
  GstMimoBeamform *self = GST_MIMO_BEAMFORM (object);
  SonarImagerParams *p = &self->params;

  if (!gst_sonar_property_settable (GST_ELEMENT (object), pspec))
    return;

  GST_OBJECT_LOCK (self);
  switch (prop_id) {
    case PROP_AZIMUTH_MIN:
      self->directions_set = TRUE;
      p->azimuth_min = g_value_get_double (value);
      break;
    case PROP_AZIMUTH_MAX:
      self->directions_set = TRUE;
      p->azimuth_max = g_value_get_double (value);
      break;
    case PROP_AZIMUTH_COUNT:
      self->directions_set = TRUE;
      p->n_azimuth = g_value_get_uint (value);
      break;
    case PROP_ELEVATION_MIN:
      self->directions_set = TRUE;
      p->elevation_min = g_value_get_double (value);
      break;
    case PROP_ELEVATION_MAX:
      self->directions_set = TRUE;
      p->elevation_max = g_value_get_double (value);
      break;
    case PROP_ELEVATION_COUNT:
      self->directions_set = TRUE;
      p->n_elevation = g_value_get_uint (value);
      break;
    case PROP_RANGE_MIN:
      p->range_min = g_value_get_double (value);
      break;
    case PROP_RANGE_MAX:
      p->range_max = g_value_get_double (value);
      break;
    case PROP_RANGE_RESOLUTION:
      p->range_resolution = g_value_get_double (value);
      break;
    case PROP_FOCUS_ZONES:
      p->focus_zones = g_value_get_uint (value);
      break;
    case PROP_COARSE_SPACING:
      self->coarse_spacing_set = TRUE;
      p->coarse_spacing = g_value_get_double (value);
      break;
    case PROP_REFINE_DB:
      p->refine_db = g_value_get_double (value);
      break;
    case PROP_REFINE_PFA:
      p->refine_pfa = g_value_get_double (value);
      break;
    case PROP_COARSE_BAND:
      p->coarse_band = g_value_get_double (value);
      break;
    case PROP_COARSE_BAND_PFA:
      p->coarse_pfa = g_value_get_double (value);
      break;
    case PROP_MODE:
      self->mode = g_value_get_enum (value);
      break;
    case PROP_VELOCITY:
      self->velocity = g_value_get_double (value);
      break;
    case PROP_HYPOTHESIS_SPACING:
      self->hypothesis_spacing = g_value_get_double (value);
      break;
    case PROP_EMITTER:
      self->emitter = g_value_get_int (value);
      break;
    case PROP_THREADS:
      p->threads = g_value_get_uint (value);
      break;
    case PROP_MAX_MEMORY:
      self->max_memory = g_value_get_uint64 (value);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID (object, prop_id, pspec);
      break;
  }
  if (pspec->flags & GST_PARAM_MUTABLE_PLAYING)
    self->retune = TRUE;
  GST_OBJECT_UNLOCK (self);
}

static void
gst_mimo_beamform_get_property (GObject * object, guint prop_id,
    GValue * value, GParamSpec * pspec)
{
  GstMimoBeamform *self = GST_MIMO_BEAMFORM (object);
  const SonarImagerParams *p = &self->params;
  const SonarImagerParams *d, *coarse;

  GST_OBJECT_LOCK (self);
  /* Directions and a coarse spacing not set follow the set-up: once
   * configured, they read back what the image uses. */
  d = self->directions_set || !self->have_params_in_use ? p :
      &self->params_in_use;
  coarse = self->coarse_spacing_set || !self->have_params_in_use ? p :
      &self->params_in_use;
  switch (prop_id) {
    case PROP_AZIMUTH_MIN:
      g_value_set_double (value, d->azimuth_min);
      break;
    case PROP_AZIMUTH_MAX:
      g_value_set_double (value, d->azimuth_max);
      break;
    case PROP_AZIMUTH_COUNT:
      g_value_set_uint (value, d->n_azimuth);
      break;
    case PROP_ELEVATION_MIN:
      g_value_set_double (value, d->elevation_min);
      break;
    case PROP_ELEVATION_MAX:
      g_value_set_double (value, d->elevation_max);
      break;
    case PROP_ELEVATION_COUNT:
      g_value_set_uint (value, d->n_elevation);
      break;
    case PROP_RANGE_MIN:
      g_value_set_double (value, p->range_min);
      break;
    case PROP_RANGE_MAX:
      g_value_set_double (value, p->range_max);
      break;
    case PROP_RANGE_RESOLUTION:
      g_value_set_double (value, p->range_resolution);
      break;
    case PROP_FOCUS_ZONES:
      g_value_set_uint (value, p->focus_zones);
      break;
    case PROP_COARSE_SPACING:
      g_value_set_double (value, coarse->coarse_spacing);
      break;
    case PROP_REFINE_DB:
      g_value_set_double (value, p->refine_db);
      break;
    case PROP_REFINE_PFA:
      g_value_set_double (value, p->refine_pfa);
      break;
    case PROP_COARSE_BAND:
      g_value_set_double (value, p->coarse_band);
      break;
    case PROP_COARSE_BAND_PFA:
      g_value_set_double (value, p->coarse_pfa);
      break;
    case PROP_MODE:
      g_value_set_enum (value, self->mode);
      break;
    case PROP_VELOCITY:
      g_value_set_double (value, self->velocity);
      break;
    case PROP_HYPOTHESIS_SPACING:
      g_value_set_double (value, self->hypothesis_spacing);
      break;
    case PROP_EMITTER:
      g_value_set_int (value, self->emitter);
      break;
    case PROP_THREADS:
      g_value_set_uint (value, p->threads);
      break;
    case PROP_MAX_MEMORY:
      g_value_set_uint64 (value, self->max_memory);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID (object, prop_id, pspec);
      break;
  }
  GST_OBJECT_UNLOCK (self);
}

static void
gst_mimo_beamform_init (GstMimoBeamform * self)
{
  sonar_imager_params_init_default (&self->params);
  self->mode = DEFAULT_MODE;
  self->velocity = DEFAULT_VELOCITY;
  self->hypothesis_spacing = DEFAULT_HYPOTHESIS_SPACING;
  self->emitter = DEFAULT_EMITTER;
  self->max_memory = SONAR_DEFAULT_MAX_MEMORY;
}

static void
gst_mimo_beamform_class_init (GstMimoBeamformClass * klass)
{
  GObjectClass *gobject_class = G_OBJECT_CLASS (klass);
  GstElementClass *element_class = GST_ELEMENT_CLASS (klass);
  GstSonarFilterClass *filter_class = GST_SONAR_FILTER_CLASS (klass);
  const GParamFlags flags = G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS
      | GST_PARAM_MUTABLE_READY;
  /* What retune () takes: changed while playing, it holds from the next
   * ping on. */
  const GParamFlags tunable = G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS
      | GST_PARAM_MUTABLE_PLAYING;
  SonarImagerParams d;

  sonar_imager_params_init_default (&d);
  gobject_class->set_property = gst_mimo_beamform_set_property;
  gobject_class->get_property = gst_mimo_beamform_get_property;

  g_object_class_install_property (gobject_class, PROP_AZIMUTH_MIN,
      g_param_spec_double ("azimuth-min", "Minimum azimuth", "First "
          "direction of the image, degrees from boresight towards +x. The "
          "directions default to the sensor's field of view: this fan, or "
          "-90..90 x -90..90 every 2 degrees for a hemisphere (the "
          "properties then read back those in use once a stream has "
          "started); setting any azimuth or elevation property makes them "
          "all the properties'",
          -90.0, 90.0, d.azimuth_min, flags));
  g_object_class_install_property (gobject_class, PROP_AZIMUTH_MAX,
      g_param_spec_double ("azimuth-max", "Maximum azimuth", "Last "
          "direction of the image, degrees", -90.0, 90.0, d.azimuth_max,
          flags));
  g_object_class_install_property (gobject_class, PROP_AZIMUTH_COUNT,
      g_param_spec_uint ("azimuth-count", "Azimuth count", "Number of "
          "azimuths, evenly spaced from azimuth-min to azimuth-max. A step "
          "wider than the beam lets sidelobes pass as objects (a 3-D "
          "hemisphere at 4 degrees, 46 x 46: sonar-bench --sweep "
          "hemisphere-fig9-grid): a grid that images a point between its "
          "directions more than 6 dB low (the default sensor: azimuth steps "
          "over 3.04 degrees, 3-D steps over 2.55) is warned of at start", 1,
          65536, d.n_azimuth, flags));
  g_object_class_install_property (gobject_class, PROP_ELEVATION_MIN,
      g_param_spec_double ("elevation-min", "Minimum elevation", "Lowest "
          "elevation, degrees towards +y (0 with elevation-count=1: the "
          "horizontal 2-D fan)", -90.0, 90.0, d.elevation_min, flags));
  g_object_class_install_property (gobject_class, PROP_ELEVATION_MAX,
      g_param_spec_double ("elevation-max", "Maximum elevation", "Highest "
          "elevation, degrees", -90.0, 90.0, d.elevation_max, flags));
  g_object_class_install_property (gobject_class, PROP_ELEVATION_COUNT,
      g_param_spec_uint ("elevation-count", "Elevation count", "Number of "
          "elevations (1: a 2-D image; more: a 3-D azimuth x elevation grid; "
          "a grid coarser than the beam is warned of at start, see "
          "azimuth-count)",
          1, 65536, d.n_elevation, flags));
  g_object_class_install_property (gobject_class, PROP_RANGE_MIN,
      g_param_spec_double ("range-min", "Minimum range", "Nearest range of "
          "the image, in m", 0.01, 1000.0, d.range_min, flags));
  g_object_class_install_property (gobject_class, PROP_RANGE_MAX,
      g_param_spec_double ("range-max", "Maximum range", "Farthest range of "
          "the image, in m; 0: the farthest whose whole echo one ping "
          "records. Beyond the ping's window it is clamped there, with a "
          "warning", 0.0, 1000.0, d.range_max, flags));
  g_object_class_install_property (gobject_class, PROP_RANGE_RESOLUTION,
      g_param_spec_double ("range-resolution", "Range resolution", "Largest "
          "allowed spacing of the range bins, in m (the band may make them "
          "finer)", 0.0001, 1.0, d.range_resolution, flags));
  g_object_class_install_property (gobject_class, PROP_FOCUS_ZONES,
      g_param_spec_uint ("focus-zones", "Focus zones", "Range zones, even "
          "in 1/range, each focused at its own range (near-field "
          "correction: more zones, sharper near images, more work; far too "
          "few for range-min are warned of at start)", 1,
          SONAR_IMAGER_MAX_FOCUS_ZONES, d.focus_zones, flags));
  g_object_class_install_property (gobject_class, PROP_COARSE_SPACING,
      g_param_spec_double ("coarse-spacing", "Coarse spacing", "Modes "
          "detection and fixed image a grid this coarse first, in degrees, "
          "then in full only around what it finds (within refine-db), the "
          "rest interpolated; 0: every direction in full. Default: one "
          "main lobe of the array's beam (the step whose point halfway "
          "between two directions is imaged 6 dB down: 3 on the eRTIS "
          "array), two on a grid of rows and columns, as the hemisphere (6 "
          "on eRTIS), whatever the set-up's field of view; the property "
          "reads back the spacing in use once a stream has started", 0.0,
          90.0,
          d.coarse_spacing, flags));
  g_object_class_install_property (gobject_class, PROP_REFINE_DB,
      g_param_spec_double ("refine-db", "Refine level", "dB below the "
          "coarse image's maximum (weighted by range^2) down to which the "
          "directions around a coarse one are imaged in full (more: fewer "
          "echoes missed, more work)", 0.1, 200.0, d.refine_db, tunable));
  g_object_class_install_property (gobject_class, PROP_REFINE_PFA,
      g_param_spec_double ("refine-pfa", "Refine false-alarm rate", "Also "
          "image in full around a coarse direction where a pixel stands "
          "over its range's noise floor (wardcluster's) by what noise alone "
          "exceeds with this probability per coarse pixel, so that an echo "
          "far below the strongest is not only interpolated (its peak half "
          "a coarse step off, rejected by velocityest); more: fewer echoes "
          "missed, more work; 0: off (refine-db alone)", 0.0, 0.999,
          d.refine_pfa, tunable));
  g_object_class_install_property (gobject_class, PROP_COARSE_BAND,
      g_param_spec_double ("coarse-band", "Coarse band", "Share of the "
          "band, from its low edge, that the coarse pass sums (its "
          "transforms shorter, its Doppler hypotheses thinned by the band's "
          "top frequency over the sub-band's); what it finds is imaged again "
          "over the whole band on the coarse directions, the rest keeps its "
          "image mapped onto the whole band's noise statistics. Less: less "
          "work, faint echoes (its SNR is the share's, -4.8 dB for a third) "
          "missed; below 0.1 (-10 dB) a warning at start; 1: the whole band",
          0.01, 1.0, d.coarse_band, flags));
  g_object_class_install_property (gobject_class, PROP_COARSE_BAND_PFA,
      g_param_spec_double ("coarse-band-pfa", "Coarse band false-alarm "
          "rate", "With coarse-band below 1: a coarse pixel is imaged again "
          "over the whole band where it stands over its range's noise floor "
          "by what noise alone exceeds with this probability (or within "
          "refine-db of the strongest echo); more: fewer faint echoes "
          "missed, more work", 1e-12, 0.5, d.coarse_pfa, flags));
  g_object_class_install_property (gobject_class, PROP_MODE,
      g_param_spec_enum ("mode", "Mode", "Which Doppler hypotheses to image",
          GST_TYPE_SONAR_IMAGE_MODE, DEFAULT_MODE, flags));
  g_object_class_install_property (gobject_class, PROP_VELOCITY,
      g_param_spec_double ("velocity", "Velocity", "Radial velocity of the "
          "image in mode=fixed, in m/s (the nearest bank velocity; set while "
          "playing outside the bank, a warning and it goes back)", -80.0,
          80.0, DEFAULT_VELOCITY, tunable));
  g_object_class_install_property (gobject_class, PROP_HYPOTHESIS_SPACING,
      g_param_spec_double ("hypothesis-spacing", "Hypothesis spacing",
          "Largest spacing of the Doppler hypotheses of mode=detection, in "
          "m/s; 0: the sensor's, within a Doppler main lobe with the "
          "emitters in phase (0.3 for the built-in sensor, less for longer "
          "or staggered emissions)", 0.0, 100.0, DEFAULT_HYPOTHESIS_SPACING,
          flags));
  g_object_class_install_property (gobject_class, PROP_EMITTER,
      g_param_spec_int ("emitter", "Emitter", "-1: the MIMO image of all "
          "emitters; n: the image of emitter n alone (set while playing to "
          "one the sensor lacks, a warning and it goes back)", -1, 63,
          DEFAULT_EMITTER, tunable));

  g_object_class_install_property (gobject_class, PROP_THREADS,
      g_param_spec_uint ("threads", "Threads", "Workers sharing the "
          "directions of an image (0: one per processor); the image does not "
          "depend on it", 0, SONAR_MAX_WORKERS, d.threads, flags));
  g_object_class_install_property (gobject_class, PROP_MAX_MEMORY,
      sonar_memory_param_spec (flags));

  gst_element_class_add_static_pad_template (element_class, &sink_template);
  gst_element_class_add_static_pad_template (element_class, &src_template);
  gst_element_class_set_static_metadata (element_class,
      "MIMO sonar beamformer", "Filter/Analyzer/Sonar",
      "Matched-filters and delay-and-sums every emitter-microphone pair into "
      "an energyscape (direction x range) of the MIMO virtual array",
      "gst-sonar-velocity developers");

  filter_class->bank_role = GST_SONAR_FILTER_USES_BANK;
  filter_class->configure = GST_DEBUG_FUNCPTR (gst_mimo_beamform_configure);
  filter_class->unconfigure =
      GST_DEBUG_FUNCPTR (gst_mimo_beamform_unconfigure);
  filter_class->process = GST_DEBUG_FUNCPTR (gst_mimo_beamform_process);

  gst_type_mark_as_plugin_api (GST_TYPE_SONAR_FILTER, 0);
  gst_type_mark_as_plugin_api (GST_TYPE_SONAR_IMAGE_MODE, 0);
}
