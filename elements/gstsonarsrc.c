/* gstsonarsrc.c: sonarsrc, the physically simulated MIMO in-air sonar.
 *
 * Each buffer is one ping: the whole recording window of every microphone,
 * interleaved F32LE at the sensor's sample rate, time-stamped at the ping's
 * emission instant. Before the first ping it sends the sticky sonar-setup
 * event (array geometry and waveforms) that every later stage needs; every
 * ping carries its ground truth as a SonarTruthMeta and, if post-messages,
 * as a "sonar-truth" element message. Contracts: docs/CONTRACTS.md.
 *
 * With write-sensor-file it also writes the sensor description of what it
 * emits (docs/FORMATS.md): a WAV of its pings replays through dopplerbank
 * sensor-file= exactly as the live pings.
 *
 * With is-live it pings at its rate whatever downstream does, as the
 * sensor: its latency is the recording window plus the rendering, and the
 * pings recorded while downstream still held the previous one are lost
 * (docs/CONTRACTS.md, section 14).
 *
 * Example:
 *   gst-launch-1.0 -m sonarsrc scene=fig9 num-buffers=3 ! fakesink
 *   gst-launch-1.0 sonarsrc num-buffers=12 write-sensor-file=pings.json \
 *       ! wavenc ! filesink location=pings.wav
 */
#ifdef HAVE_CONFIG_H
#include "config.h"
#include "sonar-error.h"
#endif

#include "gstsonarsrc.h"
#include "gstsonarfilter.h"
#include "gstsonarlatency.h"

#include <gio/gio.h>
#include <gst/audio/audio.h>
#include <math.h>
#include <string.h>

#include "sonar-contracts.h"
#include "sonar-memory.h"
#include "sonar-scene.h"
#include "sonar-sensor-file.h"
#include "sonar-setup.h"
#include "sonar-simulator.h"
#include "sonar-waveform.h"

GST_DEBUG_CATEGORY_STATIC (sonar_src_debug);
#define GST_CAT_DEFAULT sonar_src_debug

#define GST_TYPE_SONAR_SCENE_PRESET (gst_sonar_scene_preset_get_type ())
#define GST_TYPE_SONAR_WAVEFORM (gst_sonar_waveform_get_type ())

/* From the core's table of presets (sonar-scene.c). */
static GType
gst_sonar_scene_preset_get_type (void)
{
  static GType type = 0;

  if (g_once_init_enter (&type)) {
    guint n;
    const SonarScenePresetInfo *presets = sonar_scene_presets (&n);
    /* Registered for the process's lifetime, as a static table would be. */
    GEnumValue *values = g_new0 (GEnumValue, n + 1);
    for (guint i = 0; i < n; i++) {
      values[i].value = presets[i].preset;
      values[i].value_name = presets[i].description;
      values[i].value_nick = presets[i].nick;
    }
    g_once_init_leave (&type, g_enum_register_static ("GstSonarScenePreset",
            values));
  }
  return type;
}

/* From the core's table of waveform kinds (sonar-waveform.c). */
static GType
gst_sonar_waveform_get_type (void)
{
  static GType type = 0;

  if (g_once_init_enter (&type)) {
    guint n;
    const SonarWaveformKindInfo *kinds = sonar_waveform_kinds (&n);
    /* Registered for the process's lifetime, as a static table would be. */
    GEnumValue *values = g_new0 (GEnumValue, n + 1);
    for (guint i = 0; i < n; i++) {
      values[i].value = kinds[i].kind;
      values[i].value_name = kinds[i].description;
      values[i].value_nick = kinds[i].nick;
    }
    g_once_init_leave (&type, g_enum_register_static ("GstSonarWaveform",
            values));
  }
  return type;
}

#define DEFAULT_SCENE SONAR_SCENE_PRESET_DEFAULT
#define DEFAULT_WAVEFORM SONAR_WAVEFORM_NOISE
#define DEFAULT_WAVEFORM_SEED 1
#define DEFAULT_MAX_RANGE 5.0
#define DEFAULT_PING_RATE 12.0
#define DEFAULT_NOISE_AMPLITUDE 0.01
#define DEFAULT_NOISE_SEED 0
#define DEFAULT_IS_LIVE FALSE
#define DEFAULT_POST_MESSAGES TRUE

enum
{
  PROP_0,
  PROP_SCENE,
  PROP_SCENE_FILE,
  PROP_GEOMETRY_FILE,
  PROP_WAVEFORM,
  PROP_WAVEFORMS_FILE,
  PROP_WAVEFORM_SEED,
  PROP_WAVEFORM_LENGTH,
  PROP_SAMPLE_RATE,
  PROP_BAND_LOW,
  PROP_BAND_HIGH,
  PROP_SPEED_OF_SOUND,
  PROP_MAX_RANGE,
  PROP_PING_RATE,
  PROP_NOISE_AMPLITUDE,
  PROP_NOISE_SEED,
  PROP_CLIP,
  PROP_AIR_ABSORPTION,
  PROP_DIRECT_PATH,
  PROP_IS_LIVE,
  PROP_POST_MESSAGES,
  PROP_WRITE_SENSOR_FILE,
  PROP_MAX_MEMORY,
  PROP_FRAME_ID,
};

/* What the properties say; read under the object lock, used at start. */
typedef struct
{
  SonarScenePreset scene;
  char *scene_file;
  char *geometry_file;
  SonarWaveformParams waveform;
  char *waveforms_file;
  double speed_of_sound;
  double max_range;
  double ping_rate;
  SonarSimulatorParams simulation;
  gboolean post_messages;
  char *write_sensor_file;
  guint64 max_memory;
  char *frame_id;
} SonarSrcSettings;

struct _GstSonarSrc
{
  GstPushSrc parent;

  SonarSrcSettings settings;    /* protected by the object lock */

  /* Streaming state, made in start(), dropped in stop(). */
  SonarSetup *setup;
  SonarScene scene;
  SonarSimulator *simulator;
  float *planar;                /* n_microphones x ping_length */
  SonarTruth *truths;
  GstCaps *caps;
  double ping_rate;
  gboolean post_messages;
  gboolean setup_event_pending;
  guint64 ping_index;
  GstClockID clock_id;          /* live pacing wait, protected by the object lock */
  gboolean flushing;
  GstSonarLatency latency;      /* rendering a ping */
  guint64 pushed, lost;         /* live pings pushed, and lost (fell behind) */
};

G_DEFINE_TYPE (GstSonarSrc, gst_sonar_src, GST_TYPE_PUSH_SRC);
GST_ELEMENT_REGISTER_DEFINE_WITH_CODE (sonarsrc, "sonarsrc", GST_RANK_NONE,
    GST_TYPE_SONAR_SRC,
    GST_DEBUG_CATEGORY_INIT (sonar_src_debug, "sonarsrc", 0,
        "simulated MIMO sonar"));

static GstStaticPadTemplate src_template = GST_STATIC_PAD_TEMPLATE ("src",
    GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS (SONAR_RECORDING_CAPS));

static void
gst_sonar_src_init (GstSonarSrc * self)
{
  SonarSrcSettings *s = &self->settings;

  s->scene = DEFAULT_SCENE;
  sonar_waveform_params_init_default (&s->waveform);
  s->waveform.kind = DEFAULT_WAVEFORM;
  s->waveform.seed = DEFAULT_WAVEFORM_SEED;
  s->speed_of_sound = SONAR_DEFAULT_SPEED_OF_SOUND;
  s->max_range = DEFAULT_MAX_RANGE;
  s->ping_rate = DEFAULT_PING_RATE;
  sonar_simulator_params_init_default (&s->simulation);
  s->simulation.noise_amplitude = DEFAULT_NOISE_AMPLITUDE;
  s->simulation.seed = DEFAULT_NOISE_SEED;
  s->post_messages = DEFAULT_POST_MESSAGES;
  s->max_memory = SONAR_DEFAULT_MAX_MEMORY;

  gst_base_src_set_format (GST_BASE_SRC (self), GST_FORMAT_TIME);
  gst_base_src_set_live (GST_BASE_SRC (self), DEFAULT_IS_LIVE);
}

static void
gst_sonar_src_finalize (GObject * object)
{
  GstSonarSrc *self = GST_SONAR_SRC (object);

  g_free (self->settings.scene_file);
  g_free (self->settings.geometry_file);
  g_free (self->settings.waveforms_file);
  g_free (self->settings.write_sensor_file);
  g_free (self->settings.frame_id);
  G_OBJECT_CLASS (gst_sonar_src_parent_class)->finalize (object);
}

static void
gst_sonar_src_set_property (GObject * object, guint prop_id,
    const GValue * value, GParamSpec * pspec)
{
  GstSonarSrc *self = GST_SONAR_SRC (object);
  SonarSrcSettings *s = &self->settings;

  /* GstBaseSrc reads is-live as it starts: changed later, a running source
   * would neither pace its pings nor report its latency as told. */
  if (!gst_sonar_property_settable (GST_ELEMENT (self), pspec))
    return;
  if (prop_id == PROP_IS_LIVE) {
    gst_base_src_set_live (GST_BASE_SRC (self), g_value_get_boolean (value));
    return;
  }
  GST_OBJECT_LOCK (self);
  switch (prop_id) {
    case PROP_SCENE:
      s->scene = g_value_get_enum (value);
      break;
    case PROP_SCENE_FILE:
      g_free (s->scene_file);
      s->scene_file = g_value_dup_string (value);
      break;
    case PROP_FRAME_ID:
      g_free (s->frame_id);
      s->frame_id = g_value_dup_string (value);
      break;
    case PROP_GEOMETRY_FILE:
      g_free (s->geometry_file);
      s->geometry_file = g_value_dup_string (value);
      break;
    case PROP_WAVEFORM:
      s->waveform.kind = g_value_get_enum (value);
      break;
    case PROP_WAVEFORMS_FILE:
      g_free (s->waveforms_file);
      s->waveforms_file = g_value_dup_string (value);
      break;
    case PROP_WAVEFORM_SEED:
      s->waveform.seed = g_value_get_uint64 (value);
      break;
    case PROP_WAVEFORM_LENGTH:
      s->waveform.length = g_value_get_uint (value);
      break;
    case PROP_SAMPLE_RATE:
      s->waveform.sample_rate = g_value_get_int (value);
      break;
    case PROP_BAND_LOW:
      s->waveform.band_low = g_value_get_double (value);
      break;
    case PROP_BAND_HIGH:
      s->waveform.band_high = g_value_get_double (value);
      break;
    case PROP_SPEED_OF_SOUND:
      s->speed_of_sound = g_value_get_double (value);
      break;
    case PROP_MAX_RANGE:
      s->max_range = g_value_get_double (value);
      break;
    case PROP_PING_RATE:
      s->ping_rate = g_value_get_double (value);
      break;
    case PROP_NOISE_AMPLITUDE:
      s->simulation.noise_amplitude = g_value_get_double (value);
      break;
    case PROP_NOISE_SEED:
      s->simulation.seed = g_value_get_uint64 (value);
      break;
    case PROP_CLIP:
      s->simulation.clip = g_value_get_boolean (value);
      break;
    case PROP_AIR_ABSORPTION:
      s->simulation.air_absorption = g_value_get_boolean (value);
      break;
    case PROP_DIRECT_PATH:
      s->simulation.direct_path = g_value_get_double (value);
      break;
    case PROP_POST_MESSAGES:
      s->post_messages = g_value_get_boolean (value);
      break;
    case PROP_WRITE_SENSOR_FILE:
      g_free (s->write_sensor_file);
      s->write_sensor_file = g_value_dup_string (value);
      break;
    case PROP_MAX_MEMORY:
      s->max_memory = g_value_get_uint64 (value);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID (object, prop_id, pspec);
      break;
  }
  GST_OBJECT_UNLOCK (self);
}

static void
gst_sonar_src_get_property (GObject * object, guint prop_id, GValue * value,
    GParamSpec * pspec)
{
  GstSonarSrc *self = GST_SONAR_SRC (object);
  SonarSrcSettings *s = &self->settings;

  if (prop_id == PROP_IS_LIVE) {
    g_value_set_boolean (value, gst_base_src_is_live (GST_BASE_SRC (self)));
    return;
  }
  GST_OBJECT_LOCK (self);
  switch (prop_id) {
    case PROP_SCENE:
      g_value_set_enum (value, s->scene);
      break;
    case PROP_SCENE_FILE:
      g_value_set_string (value, s->scene_file);
      break;
    case PROP_FRAME_ID:
      g_value_set_string (value, s->frame_id);
      break;
    case PROP_GEOMETRY_FILE:
      g_value_set_string (value, s->geometry_file);
      break;
    case PROP_WAVEFORM:
      g_value_set_enum (value, s->waveform.kind);
      break;
    case PROP_WAVEFORMS_FILE:
      g_value_set_string (value, s->waveforms_file);
      break;
    case PROP_WAVEFORM_SEED:
      g_value_set_uint64 (value, s->waveform.seed);
      break;
    case PROP_WAVEFORM_LENGTH:
      g_value_set_uint (value, s->waveform.length);
      break;
    case PROP_SAMPLE_RATE:
      g_value_set_int (value, (int) s->waveform.sample_rate);
      break;
    case PROP_BAND_LOW:
      g_value_set_double (value, s->waveform.band_low);
      break;
    case PROP_BAND_HIGH:
      g_value_set_double (value, s->waveform.band_high);
      break;
    case PROP_SPEED_OF_SOUND:
      g_value_set_double (value, s->speed_of_sound);
      break;
    case PROP_MAX_RANGE:
      g_value_set_double (value, s->max_range);
      break;
    case PROP_PING_RATE:
      g_value_set_double (value, s->ping_rate);
      break;
    case PROP_NOISE_AMPLITUDE:
      g_value_set_double (value, s->simulation.noise_amplitude);
      break;
    case PROP_NOISE_SEED:
      g_value_set_uint64 (value, s->simulation.seed);
      break;
    case PROP_CLIP:
      g_value_set_boolean (value, s->simulation.clip);
      break;
    case PROP_AIR_ABSORPTION:
      g_value_set_boolean (value, s->simulation.air_absorption);
      break;
    case PROP_DIRECT_PATH:
      g_value_set_double (value, s->simulation.direct_path);
      break;
    case PROP_POST_MESSAGES:
      g_value_set_boolean (value, s->post_messages);
      break;
    case PROP_WRITE_SENSOR_FILE:
      g_value_set_string (value, s->write_sensor_file);
      break;
    case PROP_MAX_MEMORY:
      g_value_set_uint64 (value, s->max_memory);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID (object, prop_id, pspec);
      break;
  }
  GST_OBJECT_UNLOCK (self);
}

static void
settings_copy (SonarSrcSettings * dest, const SonarSrcSettings * src)
{
  *dest = *src;
  dest->scene_file = g_strdup (src->scene_file);
  dest->geometry_file = g_strdup (src->geometry_file);
  dest->waveforms_file = g_strdup (src->waveforms_file);
  dest->write_sensor_file = g_strdup (src->write_sensor_file);
  dest->frame_id = g_strdup (src->frame_id);
}

static void
settings_clear (SonarSrcSettings * s)
{
  g_clear_pointer (&s->scene_file, g_free);
  g_clear_pointer (&s->geometry_file, g_free);
  g_clear_pointer (&s->waveforms_file, g_free);
  g_clear_pointer (&s->write_sensor_file, g_free);
  g_clear_pointer (&s->frame_id, g_free);
}

/* Builds the sensor the settings describe, resolving the directions of a
 * scene of @dimensions (2: the horizontal fan). */
static SonarSetup *
make_setup (const SonarSrcSettings * s, guint dimensions, GError ** error)
{
  g_autofree float *waveforms = NULL;
  SonarGeometry geometry = { 0 };
  SonarWaveformParams wp = s->waveform;
  SonarSetup *setup = NULL;
  guint ping_length;

  if (s->geometry_file) {
    if (!sonar_geometry_load_file (&geometry, s->geometry_file, error))
      return NULL;
  } else {
    sonar_geometry_init_default (&geometry);
  }
  wp.n_emitters = geometry.n_emitters;

  if (s->waveforms_file) {
    guint n_rows;
    double file_rate;
    waveforms = sonar_waveforms_load_file (s->waveforms_file, &n_rows,
        &wp.length, &file_rate, &wp.band_low, &wp.band_high, error);
    if (!waveforms)
      goto done;
    if (n_rows != geometry.n_emitters || file_rate != wp.sample_rate) {
      g_set_error (error, SONAR_ERROR, SONAR_ERROR_FORMAT,
          "%s: holds %u waveforms at %g Hz, but the sensor has %u emitters "
          "at %g Hz (sample-rate property)", s->waveforms_file, n_rows,
          file_rate, geometry.n_emitters, wp.sample_rate);
      goto done;
    }
  } else {
    waveforms = g_new (float, (gsize) wp.n_emitters * wp.length);
    if (!sonar_waveform_generate (&wp, waveforms, error))
      goto done;
  }

  ping_length = sonar_ping_length_for_range (&geometry, s->speed_of_sound,
      wp.sample_rate, wp.length, s->max_range);
  if (ping_length > SONAR_MAX_PING_LENGTH) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS,
        "max-range %g m needs a recording window longer than the %u "
        "samples supported", s->max_range, SONAR_MAX_PING_LENGTH);
    goto done;
  }
  if (ping_length / wp.sample_rate > 1.0 / s->ping_rate) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS,
        "ping-rate %g Hz is too fast for max-range %g m with waveforms of "
        "%u samples: the %.1f ms recording window (the echoes out to "
        "max-range, and a waveform of %.1f ms) is longer than the %.1f ms "
        "between pings", s->ping_rate, s->max_range, wp.length,
        1e3 * ping_length / wp.sample_rate, 1e3 * wp.length / wp.sample_rate,
        1e3 / s->ping_rate);
    goto done;
  }
  /* The pings are stored back to back (one buffer each), but happen
   * 1 / ping-rate apart. */
  setup = sonar_setup_new (&(SonarSetupParams) {
        .sample_rate = wp.sample_rate, .speed_of_sound = s->speed_of_sound,
        .band_low = wp.band_low, .band_high = wp.band_high,
        .geometry = &geometry, .waveform_length = wp.length,
        .waveforms = waveforms, .ping_length = ping_length,
        .ping_period = 1.0 / s->ping_rate, .ping_stride = ping_length,
        .field_of_view = dimensions == 2 ? SONAR_FIELD_OF_VIEW_FAN :
        SONAR_FIELD_OF_VIEW_HEMISPHERE,.frame_id = s->frame_id}, error);
done:
  sonar_geometry_clear (&geometry);
  return setup;
}

static gboolean
gst_sonar_src_start (GstBaseSrc * bsrc)
{
  GstSonarSrc *self = GST_SONAR_SRC (bsrc);
  SonarSrcSettings s;
  GError *error = NULL;
  const SonarGeometry *g;

  GST_OBJECT_LOCK (self);
  settings_copy (&s, &self->settings);
  GST_OBJECT_UNLOCK (self);

  if (s.scene_file) {
    if (!sonar_scene_load_file (&self->scene, s.scene_file, &error))
      goto failed;
  } else {
    sonar_scene_init_preset (&self->scene, s.scene);
  }
  self->setup = make_setup (&s, self->scene.dimensions, &error);
  if (!self->setup)
    goto failed;
  if (s.write_sensor_file && !sonar_sensor_file_save (self->setup,
          s.write_sensor_file, &error))
    goto failed;
  /* The simulator, the planar window and the buffer pushed. */
  g = &self->setup->geometry;
  if (!sonar_memory_check (sonar_simulator_memory (self->setup, 2),
          s.max_memory, &error, "sonarsrc: %u emitters x %u-sample "
          "waveforms (waveform-length) and %u microphones x %u-sample "
          "recording windows (max-range %g m)", g->n_emitters,
          self->setup->waveform_length, g->n_microphones,
          self->setup->ping_length, s.max_range))
    goto failed;
  self->simulator = sonar_simulator_new (self->setup, &s.simulation, &error);
  if (!self->simulator)
    goto failed;

  self->planar = g_new (float, (gsize) g->n_microphones *
      self->setup->ping_length);
  self->truths = g_new0 (SonarTruth, MAX (self->scene.n_reflectors, 1));
  self->caps = gst_caps_new_simple ("audio/x-raw",
      "format", G_TYPE_STRING, GST_AUDIO_NE (F32),
      "layout", G_TYPE_STRING, "interleaved",
      "rate", G_TYPE_INT, (int) self->setup->sample_rate,
      "channels", G_TYPE_INT, (int) g->n_microphones,
      "channel-mask", GST_TYPE_BITMASK, (guint64) 0, NULL);
  self->ping_rate = s.ping_rate;
  self->post_messages = s.post_messages;
  self->setup_event_pending = TRUE;
  self->ping_index = 0;
  self->flushing = FALSE;
  self->pushed = self->lost = 0;
  gst_sonar_latency_reset (GST_ELEMENT (self), &self->latency,
      gst_base_src_is_live (GST_BASE_SRC (self)));
  GST_INFO_OBJECT (self, "%u microphones, %u emitters, %u reflectors, "
      "%u samples per ping", g->n_microphones, g->n_emitters,
      self->scene.n_reflectors, self->setup->ping_length);
  settings_clear (&s);
  return TRUE;

failed:
  SONAR_ELEMENT_POST_ERROR (self, error,
      "sonarsrc could not set up the sensor or the scene");
  g_error_free (error);
  settings_clear (&s);
  return FALSE;
}

static gboolean
gst_sonar_src_stop (GstBaseSrc * bsrc)
{
  GstSonarSrc *self = GST_SONAR_SRC (bsrc);

  g_clear_pointer (&self->simulator, sonar_simulator_free);
  g_clear_pointer (&self->setup, sonar_setup_unref);
  sonar_scene_clear (&self->scene);
  g_clear_pointer (&self->planar, g_free);
  g_clear_pointer (&self->truths, g_free);
  gst_clear_caps (&self->caps);
  return TRUE;
}

static GstCaps *
gst_sonar_src_get_caps (GstBaseSrc * bsrc, GstCaps * filter)
{
  GstSonarSrc *self = GST_SONAR_SRC (bsrc);
  GstCaps *caps = self->caps ? gst_caps_ref (self->caps)
      : gst_pad_get_pad_template_caps (GST_BASE_SRC_PAD (bsrc));

  if (filter) {
    GstCaps *result = gst_caps_intersect_full (filter, caps,
        GST_CAPS_INTERSECT_FIRST);
    gst_caps_unref (caps);
    caps = result;
  }
  return caps;
}

static gboolean
gst_sonar_src_negotiate (GstBaseSrc * bsrc)
{
  GstSonarSrc *self = GST_SONAR_SRC (bsrc);

  /* The format is fixed by the sensor: say plainly when downstream wants
   * something else, instead of a bare "not-negotiated". */
  if (!gst_pad_peer_query_accept_caps (GST_BASE_SRC_PAD (bsrc), self->caps)) {
    g_autofree char *caps = gst_caps_to_string (self->caps);
    GST_ELEMENT_ERROR (self, CORE, NEGOTIATION,
        ("Downstream does not accept the sonar recording format: %u "
            "channels of F32LE at %d Hz", self->setup->geometry.n_microphones,
            (int) self->setup->sample_rate),
        ("sonarsrc produces %s; remove or change the caps filter after it",
            caps));
    return FALSE;
  }
  return gst_base_src_set_caps (bsrc, self->caps);
}

static gboolean
gst_sonar_src_query (GstBaseSrc * bsrc, GstQuery * query)
{
  GstSonarSrc *self = GST_SONAR_SRC (bsrc);

  if (GST_QUERY_TYPE (query) == GST_QUERY_LATENCY && self->setup) {
    /* A ping is complete when its window has been recorded, and out when
     * it has been rendered; it waits at most until the next ping replaces
     * it (live pings the source could not push in time are lost). */
    const GstClockTime window = gst_util_uint64_scale_round
        (self->setup->ping_length, GST_SECOND,
        (guint64) self->setup->sample_rate);
    const GstClockTime min = window + gst_sonar_latency_get (GST_ELEMENT
        (self), &self->latency);
    gst_query_set_latency (query, gst_base_src_is_live (bsrc), min, min +
        (GstClockTime) llround (GST_SECOND / self->ping_rate));
    return TRUE;
  }
  return GST_BASE_SRC_CLASS (gst_sonar_src_parent_class)->query (bsrc, query);
}

/* Live mode: wait until the ping's window has been recorded. */
static GstFlowReturn
wait_for_ping (GstSonarSrc * self, GstClockTime ready_time)
{
  GstClock *clock = gst_element_get_clock (GST_ELEMENT (self));
  GstClockReturn ret;

  if (!clock)
    return GST_FLOW_OK;
  GST_OBJECT_LOCK (self);
  if (self->flushing) {
    GST_OBJECT_UNLOCK (self);
    gst_object_unref (clock);
    return GST_FLOW_FLUSHING;
  }
  self->clock_id = gst_clock_new_single_shot_id (clock,
      GST_ELEMENT_CAST (self)->base_time + ready_time);
  GST_OBJECT_UNLOCK (self);

  ret = gst_clock_id_wait (self->clock_id, NULL);

  GST_OBJECT_LOCK (self);
  gst_clock_id_unref (self->clock_id);
  self->clock_id = NULL;
  GST_OBJECT_UNLOCK (self);
  gst_object_unref (clock);
  return ret == GST_CLOCK_UNSCHEDULED ? GST_FLOW_FLUSHING : GST_FLOW_OK;
}

static gboolean
gst_sonar_src_unlock (GstBaseSrc * bsrc)
{
  GstSonarSrc *self = GST_SONAR_SRC (bsrc);

  GST_OBJECT_LOCK (self);
  self->flushing = TRUE;
  if (self->clock_id)
    gst_clock_id_unschedule (self->clock_id);
  GST_OBJECT_UNLOCK (self);
  return TRUE;
}

static gboolean
gst_sonar_src_unlock_stop (GstBaseSrc * bsrc)
{
  GstSonarSrc *self = GST_SONAR_SRC (bsrc);

  GST_OBJECT_LOCK (self);
  self->flushing = FALSE;
  GST_OBJECT_UNLOCK (self);
  return TRUE;
}

static GstClockTime
ping_pts (GstSonarSrc * self, guint64 index)
{
  return (GstClockTime) llround (index / self->ping_rate * GST_SECOND);
}

/* Live: the sensor pings at its rate whether or not downstream takes the
 * pings, as the real one does; when the source comes back later than the
 * end of the next ping's window, the pings in between are lost whole and
 * the newest recorded one comes next. Reported as a QoS message (as
 * v4l2src does for lost frames); dopplerbank then counts them. */
static void
skip_lost_pings (GstSonarSrc * self, GstClockTime window)
{
  GstClock *clock = gst_element_get_clock (GST_ELEMENT (self));
  GstClockTime now, base_time;
  guint64 newest = self->ping_index;
  GstMessage *message;

  if (!clock)
    return;
  now = gst_clock_get_time (clock);
  gst_object_unref (clock);
  base_time = gst_element_get_base_time (GST_ELEMENT (self));
  if (now < base_time)
    return;
  now -= base_time;
  while (ping_pts (self, newest + 1) + window <= now)
    newest++;
  if (newest == self->ping_index)
    return;
  self->lost += newest - self->ping_index;
  GST_DEBUG_OBJECT (self, "pings %" G_GUINT64_FORMAT " to %" G_GUINT64_FORMAT
      " lost: downstream took ping %" G_GUINT64_FORMAT " too late",
      self->ping_index, newest - 1, self->ping_index - 1);
  message = gst_message_new_qos (GST_OBJECT (self), TRUE,
      ping_pts (self, self->ping_index), ping_pts (self, self->ping_index),
      ping_pts (self, self->ping_index), ping_pts (self, newest) -
      ping_pts (self, self->ping_index));
  gst_message_set_qos_values (message, GST_CLOCK_DIFF (ping_pts (self,
              self->ping_index) + window, now), 1.0, 1000000);
  gst_message_set_qos_stats (message, GST_FORMAT_BUFFERS, self->pushed,
      self->lost);
  gst_element_post_message (GST_ELEMENT (self), message);
  self->ping_index = newest;
}

static GstFlowReturn
gst_sonar_src_create (GstPushSrc * psrc, GstBuffer ** outbuf)
{
  GstSonarSrc *self = GST_SONAR_SRC (psrc);
  const guint n_mics = self->setup->geometry.n_microphones;
  const guint length = self->setup->ping_length;
  const GstClockTime duration = gst_util_uint64_scale_round (length,
      GST_SECOND, (guint64) self->setup->sample_rate);
  double ping_time;
  GstClockTime pts, render_start;
  GstBuffer *buffer;
  GstMapInfo map;
  float *out;

  if (self->setup_event_pending) {
    gst_pad_push_event (GST_BASE_SRC_PAD (psrc),
        sonar_setup_event_new (self->setup));
    self->setup_event_pending = FALSE;
  }
  if (gst_base_src_is_live (GST_BASE_SRC (psrc))) {
    GstFlowReturn ret = wait_for_ping (self, ping_pts (self,
            self->ping_index) + duration);
    if (ret != GST_FLOW_OK)
      return ret;
    skip_lost_pings (self, duration);
  }
  ping_time = self->ping_index / self->ping_rate;
  pts = ping_pts (self, self->ping_index);
  render_start = gst_util_get_timestamp ();

  sonar_simulator_render (self->simulator, &self->scene, self->ping_index,
      ping_time, self->planar, self->truths);

  buffer = gst_buffer_new_allocate (NULL, sizeof (float) * n_mics * length,
      NULL);
  gst_buffer_map (buffer, &map, GST_MAP_WRITE);
  out = (float *) map.data;
  for (guint j = 0; j < n_mics; j++) {
    const float *channel = self->planar + (gsize) j * length;
    for (guint i = 0; i < length; i++)
      out[(gsize) i * n_mics + j] = channel[i];
  }
  gst_buffer_unmap (buffer, &map);

  GST_BUFFER_PTS (buffer) = pts;
  GST_BUFFER_DURATION (buffer) = duration;
  GST_BUFFER_OFFSET (buffer) = self->ping_index * length;
  GST_BUFFER_OFFSET_END (buffer) = (self->ping_index + 1) * length;
  if (self->ping_index == 0)
    GST_BUFFER_FLAG_SET (buffer, GST_BUFFER_FLAG_DISCONT);
  sonar_buffer_add_truth_meta (buffer, self->ping_index, self->truths,
      self->scene.n_reflectors);
  if (self->post_messages) {
    gst_sonar_post_ping_message (GST_ELEMENT (self),
        &GST_BASE_SRC (self)->segment, pts,
        sonar_truth_to_structure (self->ping_index, pts, self->truths,
            self->scene.n_reflectors));
  }
  self->ping_index++;
  self->pushed++;
  gst_sonar_latency_add (GST_ELEMENT (self), &self->latency,
      gst_util_get_timestamp () - render_start);
  *outbuf = buffer;
  return GST_FLOW_OK;
}

static void
gst_sonar_src_class_init (GstSonarSrcClass * klass)
{
  GObjectClass *gobject_class = G_OBJECT_CLASS (klass);
  GstElementClass *element_class = GST_ELEMENT_CLASS (klass);
  GstBaseSrcClass *basesrc_class = GST_BASE_SRC_CLASS (klass);
  GstPushSrcClass *pushsrc_class = GST_PUSH_SRC_CLASS (klass);
  const GParamFlags flags = G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS
      | GST_PARAM_MUTABLE_READY;

  gobject_class->set_property = gst_sonar_src_set_property;
  gobject_class->get_property = gst_sonar_src_get_property;
  gobject_class->finalize = gst_sonar_src_finalize;

  g_object_class_install_property (gobject_class, PROP_SCENE,
      g_param_spec_enum ("scene", "Scene", "Built-in scene (preset) to "
          "simulate; ignored when scene-file is set",
          GST_TYPE_SONAR_SCENE_PRESET, DEFAULT_SCENE, flags));
  g_object_class_install_property (gobject_class, PROP_SCENE_FILE,
      g_param_spec_string ("scene-file", "Scene file", "JSON scene file "
          "(format: docs/FORMATS.md); overrides scene", NULL, flags));
  g_object_class_install_property (gobject_class, PROP_FRAME_ID,
      g_param_spec_string ("frame-id", "Frame id", "Name of this sensor's "
          "frame (as ROS's header.frame_id, up to 63 printable ASCII "
          "characters): carried in the set-up event to every detection "
          "(\"frame_id\"), so that one host can tell several sensors' "
          "results apart; NULL: none", NULL, flags));
  g_object_class_install_property (gobject_class, PROP_GEOMETRY_FILE,
      g_param_spec_string ("geometry-file", "Geometry file", "JSON array "
          "geometry file (format: docs/FORMATS.md); default: the 32-microphone "
          "eRTIS array and 8 built-in emitters", NULL, flags));
  g_object_class_install_property (gobject_class, PROP_WAVEFORM,
      g_param_spec_enum ("waveform", "Waveform", "Kind of emission waveform "
          "to generate; ignored when waveforms-file is set",
          GST_TYPE_SONAR_WAVEFORM, DEFAULT_WAVEFORM, flags));
  g_object_class_install_property (gobject_class, PROP_WAVEFORMS_FILE,
      g_param_spec_string ("waveforms-file", "Waveforms file", "JSON file of "
          "the emission waveforms, one per emitter (format: "
          "docs/FORMATS.md); overrides waveform", NULL, flags));
  g_object_class_install_property (gobject_class, PROP_WAVEFORM_SEED,
      g_param_spec_uint64 ("waveform-seed", "Waveform seed", "Seed of the "
          "generated waveforms: the same seed gives the same waveforms",
          0, G_MAXUINT64, DEFAULT_WAVEFORM_SEED, flags));
  g_object_class_install_property (gobject_class, PROP_WAVEFORM_LENGTH,
      g_param_spec_uint ("waveform-length", "Waveform length", "Length of "
          "each generated emission, in samples", 16, SONAR_MAX_WAVEFORM_LENGTH,
          SONAR_DEFAULT_WAVEFORM_LENGTH, flags));
  g_object_class_install_property (gobject_class, PROP_SAMPLE_RATE,
      g_param_spec_int ("sample-rate", "Sample rate", "Sample rate of "
          "emission and recording, in Hz", 1000, 100000000,
          (int) SONAR_DEFAULT_SAMPLE_RATE, flags));
  g_object_class_install_property (gobject_class, PROP_BAND_LOW,
      g_param_spec_double ("band-low", "Band low", "Lower edge of the "
          "emission band, in Hz", 1.0, 5e7, SONAR_DEFAULT_BAND_LOW, flags));
  g_object_class_install_property (gobject_class, PROP_BAND_HIGH,
      g_param_spec_double ("band-high", "Band high", "Upper edge of the "
          "emission band, in Hz (at most sample-rate / 2)", 1.0, 5e7,
          SONAR_DEFAULT_BAND_HIGH, flags));
  g_object_class_install_property (gobject_class, PROP_SPEED_OF_SOUND,
      g_param_spec_double ("speed-of-sound", "Speed of sound", "Speed of "
          "sound in the air, in m/s", 100.0, 2000.0,
          SONAR_DEFAULT_SPEED_OF_SOUND, flags));
  g_object_class_install_property (gobject_class, PROP_MAX_RANGE,
      g_param_spec_double ("max-range", "Maximum range", "Range in metres "
          "whose echoes the recording window holds whole; sets the samples "
          "per ping", 0.05, 1000.0, DEFAULT_MAX_RANGE, flags));
  g_object_class_install_property (gobject_class, PROP_PING_RATE,
      g_param_spec_double ("ping-rate", "Ping rate", "Pings per second, in "
          "Hz (the eRTIS runs at 12 Hz); the scene moves on 1/ping-rate "
          "seconds between pings", 0.01, 1000.0, DEFAULT_PING_RATE, flags));
  g_object_class_install_property (gobject_class, PROP_NOISE_AMPLITUDE,
      g_param_spec_double ("noise-amplitude", "Noise amplitude", "RMS of the "
          "white Gaussian noise added to every microphone sample (full "
          "scale is 1.0; each emission has unit peak)", 0.0, 1000.0,
          DEFAULT_NOISE_AMPLITUDE, flags));
  g_object_class_install_property (gobject_class, PROP_NOISE_SEED,
      g_param_spec_uint64 ("noise-seed", "Noise seed", "Seed of the noise: "
          "ping p of a given seed is always the same", 0, G_MAXUINT64,
          DEFAULT_NOISE_SEED, flags));
  g_object_class_install_property (gobject_class, PROP_CLIP,
      g_param_spec_boolean ("clip", "Clip", "Saturate the recording at "
          "+-1.0 like the microphones' ADC", FALSE, flags));
  g_object_class_install_property (gobject_class, PROP_AIR_ABSORPTION,
      g_param_spec_boolean ("air-absorption", "Air absorption", "Apply the "
          "frequency-dependent absorption of air (ISO 9613-1, 20 C, 50 % "
          "relative humidity) along each echo's path", FALSE, flags));
  g_object_class_install_property (gobject_class, PROP_DIRECT_PATH,
      g_param_spec_double ("direct-path", "Direct path", "The microphones "
          "also hear the emitters straight, as a real sensor's do: each "
          "emission |m - e| / c after it starts, times this over |m - e|^2 "
          "(the emitter-microphone distance; 0.1: 33-71 dB over a unit "
          "reflector's echo at 1 m on the default sensor); 0: none. "
          "dopplerbank subtracts it (its direct-path)", 0.0, 1e6, 0.0,
          flags));
  g_object_class_install_property (gobject_class, PROP_IS_LIVE,
      g_param_spec_boolean ("is-live", "Is live", "Pace the pings in real "
          "time like the real sensor (one every 1/ping-rate seconds); pings "
          "recorded while downstream still holds the previous one are lost "
          "whole, as the sensor's (a QoS message says how many)",
          DEFAULT_IS_LIVE, flags));
  g_object_class_install_property (gobject_class, PROP_WRITE_SENSOR_FILE,
      g_param_spec_string ("write-sensor-file", "Write sensor file", "At "
          "start, write the sensor description of what this source emits "
          "to this file (docs/FORMATS.md): give it to dopplerbank's "
          "sensor-file to process a recording of these pings", NULL,
          G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS |
          GST_PARAM_MUTABLE_READY));
  g_object_class_install_property (gobject_class, PROP_POST_MESSAGES,
      g_param_spec_boolean ("post-messages", "Post messages", "Post a "
          "\"sonar-truth\" element message with the ground truth of every "
          "ping", DEFAULT_POST_MESSAGES, flags));
  g_object_class_install_property (gobject_class, PROP_MAX_MEMORY,
      sonar_memory_param_spec (flags));

  gst_element_class_add_static_pad_template (element_class, &src_template);
  gst_element_class_set_static_metadata (element_class,
      "MIMO sonar simulator", "Source/Audio/Sensor",
      "Simulates the pings of a MIMO in-air imaging sonar (8 emitters, 32 "
      "microphones by default) looking at moving reflectors, with exact "
      "Doppler and ground truth", "gst-sonar-velocity developers");

  basesrc_class->start = GST_DEBUG_FUNCPTR (gst_sonar_src_start);
  basesrc_class->stop = GST_DEBUG_FUNCPTR (gst_sonar_src_stop);
  basesrc_class->get_caps = GST_DEBUG_FUNCPTR (gst_sonar_src_get_caps);
  basesrc_class->negotiate = GST_DEBUG_FUNCPTR (gst_sonar_src_negotiate);
  basesrc_class->query = GST_DEBUG_FUNCPTR (gst_sonar_src_query);
  basesrc_class->unlock = GST_DEBUG_FUNCPTR (gst_sonar_src_unlock);
  basesrc_class->unlock_stop = GST_DEBUG_FUNCPTR (gst_sonar_src_unlock_stop);
  pushsrc_class->create = GST_DEBUG_FUNCPTR (gst_sonar_src_create);

  gst_type_mark_as_plugin_api (GST_TYPE_SONAR_SCENE_PRESET, 0);
  gst_type_mark_as_plugin_api (GST_TYPE_SONAR_WAVEFORM, 0);
}
