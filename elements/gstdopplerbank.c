/* gstdopplerbank.c: dopplerbank, the Doppler-tuned matched-filter bank.
 *
 * Once per set-up it makes every emission time-scaled for every radial
 * velocity of its grid (velocity-min .. velocity-max by velocity-step) and
 * the spectra of those templates on the band; it sends them downstream as
 * the sticky sonar-doppler-bank event. Per ping it takes the microphone
 * recordings onto the same band (one FFT per microphone): the matched
 * filters of paper eq. 10 are then a product per bin, made where they are
 * needed (mimobeamform for the image, velocityest at the reflectors) rather
 * than for the whole datacube. Contracts: docs/CONTRACTS.md.
 *
 * Input: the recording, one ping per set-up ping-length samples, whatever
 * the buffer sizes. Output: application/x-sonar-spectra, one buffer per ping.
 *
 * A recording made elsewhere (a WAV file) carries no set-up event: give
 * waveforms-file, ping-length and, unless the array is the built-in one,
 * geometry-file (docs/FORMATS.md):
 *
 *   gst-launch-1.0 filesrc location=pings.wav ! wavparse ! dopplerbank \
 *       waveforms-file=waveforms.json ping-length=17261 ! mimobeamform ! ...
 *
 *   gst-launch-1.0 sonarsrc ! dopplerbank velocity-min=-0.4 velocity-max=0.4 \
 *       velocity-step=0.02 ! mimobeamform ! fakesink
 */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstdopplerbank.h"
#include "sonar-memory.h"

#include <gio/gio.h>
#include <gst/audio/audio.h>
#include <gst/base/gstadapter.h>

GST_DEBUG_CATEGORY_STATIC (doppler_bank_debug);
#define GST_CAT_DEFAULT doppler_bank_debug

#define DEFAULT_VELOCITY_MIN -7.0
#define DEFAULT_VELOCITY_MAX 7.0
#define DEFAULT_VELOCITY_STEP 0.05

enum
{
  PROP_0,
  PROP_VELOCITY_MIN,
  PROP_VELOCITY_MAX,
  PROP_VELOCITY_STEP,
  PROP_GEOMETRY_FILE,
  PROP_WAVEFORMS_FILE,
  PROP_PING_LENGTH,
  PROP_SPEED_OF_SOUND,
  PROP_MAX_MEMORY,
};

struct _GstDopplerBank
{
  GstSonarFilter parent;

  /* Properties, protected by the object lock. */
  double velocity_min, velocity_max, velocity_step;
  char *geometry_file, *waveforms_file;
  guint64 max_memory;
  guint ping_length_setting;
  double speed_of_sound;

  /* Configured state. */
  guint channels;
  guint ping_length;
  SonarBand band;
  SonarSpectrum *analyzer;
  GstAdapter *adapter;
  guint64 ping_index;
  gboolean warned_non_finite;
};

G_DEFINE_TYPE (GstDopplerBank, gst_doppler_bank, GST_TYPE_SONAR_FILTER);
GST_ELEMENT_REGISTER_DEFINE_WITH_CODE (dopplerbank, "dopplerbank",
    GST_RANK_NONE, GST_TYPE_DOPPLER_BANK,
    GST_DEBUG_CATEGORY_INIT (doppler_bank_debug, "dopplerbank", 0,
        "Doppler matched-filter bank"));

static GstStaticPadTemplate sink_template = GST_STATIC_PAD_TEMPLATE ("sink",
    GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS (SONAR_RECORDING_CAPS));
static GstStaticPadTemplate src_template = GST_STATIC_PAD_TEMPLATE ("src",
    GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS (SONAR_SPECTRA_CAPS));

/* With waveforms-file set, the set-up comes from the files, whatever
 * arrives from upstream. */
static SonarSetup *
gst_doppler_bank_make_setup (GstSonarFilter * filter, GstCaps * in_caps,
    GError ** error)
{
  GstDopplerBank *self = GST_DOPPLER_BANK (filter);
  g_autofree char *geometry = NULL, *waveforms = NULL;
  guint ping_length;
  double c;

  GST_OBJECT_LOCK (self);
  geometry = g_strdup (self->geometry_file);
  waveforms = g_strdup (self->waveforms_file);
  ping_length = self->ping_length_setting;
  c = self->speed_of_sound;
  GST_OBJECT_UNLOCK (self);

  if (!waveforms) {
    if (geometry || ping_length)
      g_set_error (error, G_IO_ERROR, G_IO_ERROR_INVALID_ARGUMENT,
          "dopplerbank: geometry-file and ping-length need waveforms-file "
          "too");
    return NULL;
  }
  if (ping_length == 0) {
    g_set_error (error, G_IO_ERROR, G_IO_ERROR_INVALID_ARGUMENT,
        "dopplerbank: waveforms-file needs ping-length, the samples per "
        "channel of one ping of the recording");
    return NULL;
  }
  return sonar_setup_new_from_files (geometry, waveforms, c, ping_length,
      error);
}

static GstCaps *
gst_doppler_bank_configure (GstSonarFilter * filter, GstCaps * in_caps,
    GError ** error)
{
  GstDopplerBank *self = GST_DOPPLER_BANK (filter);
  SonarSetup *setup = gst_sonar_filter_get_setup (filter);
  g_autoptr (SonarDopplerBank) bank = NULL;
  GstAudioInfo info;
  GstCaps *out_caps;
  double v_min, v_max, v_step;
  guint64 max_memory, bank_bytes;
  guint n_velocities;
  SonarBand ping_band;

  if (!in_caps || !gst_audio_info_from_caps (&info, in_caps)) {
    g_set_error (error, GST_CORE_ERROR, GST_CORE_ERROR_NEGOTIATION,
        "dopplerbank: the input is not a sonar recording");
    return NULL;
  }
  if ((guint) GST_AUDIO_INFO_CHANNELS (&info) !=
      setup->geometry.n_microphones
      || GST_AUDIO_INFO_RATE (&info) != (int) setup->sample_rate) {
    g_set_error (error, GST_CORE_ERROR, GST_CORE_ERROR_NEGOTIATION,
        "dopplerbank: the recording has %d channels at %d Hz, but the set-up "
        "describes %u microphones at %.0f Hz",
        GST_AUDIO_INFO_CHANNELS (&info), GST_AUDIO_INFO_RATE (&info),
        setup->geometry.n_microphones, setup->sample_rate);
    return NULL;
  }

  GST_OBJECT_LOCK (self);
  v_min = self->velocity_min;
  v_max = self->velocity_max;
  v_step = self->velocity_step;
  max_memory = self->max_memory;
  GST_OBJECT_UNLOCK (self);

  bank_bytes = sonar_doppler_bank_memory (setup, v_min, v_max, v_step,
      &n_velocities, &ping_band);
  if (!sonar_memory_check_buffers (bank_bytes, sizeof (SonarComplex) *
          (guint64) ping_band.n_bins * setup->geometry.n_microphones,
          GST_SONAR_FILTER_POOL_MIN_BUFFERS, max_memory, error,
          "dopplerbank: a bank of %u velocities (velocity-min %g, "
          "velocity-max %g, velocity-step %g m/s) for %u emitters and %u "
          "output buffers of %u microphones x %u band bins", n_velocities,
          v_min, v_max, v_step, setup->geometry.n_emitters,
          GST_SONAR_FILTER_POOL_MIN_BUFFERS, setup->geometry.n_microphones,
          ping_band.n_bins))
    return NULL;
  bank = sonar_doppler_bank_new (setup, v_min, v_max, v_step, error);
  if (!bank)
    return NULL;
  self->channels = setup->geometry.n_microphones;
  self->ping_length = setup->ping_length;
  sonar_doppler_bank_prepare_ping_band (bank);
  self->band = *sonar_doppler_bank_band (bank);
  self->analyzer = sonar_spectrum_new (&self->band);
  gst_sonar_filter_set_bank (filter, bank, &self->band);
  GST_INFO_OBJECT (self, "%u velocities, FFT %u, %u band bins",
      sonar_doppler_bank_n_velocities (bank), self->band.fft_size,
      self->band.n_bins);
  out_caps = sonar_spectra_caps_new (self->channels, &self->band);
  if (!gst_sonar_filter_use_pool (filter, out_caps, sizeof (SonarComplex) *
          self->band.n_bins * self->channels)) {
    g_set_error (error, GST_CORE_ERROR, GST_CORE_ERROR_FAILED,
        "dopplerbank: could not make its buffer pool");
    gst_caps_unref (out_caps);
    return NULL;
  }
  return out_caps;
}

static void
gst_doppler_bank_unconfigure (GstSonarFilter * filter)
{
  GstDopplerBank *self = GST_DOPPLER_BANK (filter);

  g_clear_pointer (&self->analyzer, sonar_spectrum_free);
  gst_adapter_clear (self->adapter);
}

/* One ping: the spectra of its channels. */
static GstBuffer *
analyse_ping (GstDopplerBank * self, const float *samples)
{
  const gsize bins = self->band.n_bins;
  GstBuffer *out = gst_sonar_filter_new_buffer (GST_SONAR_FILTER (self),
      sizeof (SonarComplex) * bins * self->channels);
  GstMapInfo map;
  guint n_bad = 0;

  if (!out)
    return NULL;

  gst_buffer_map (out, &map, GST_MAP_WRITE);
  for (guint j = 0; j < self->channels; j++)
    sonar_spectrum_process (self->analyzer, samples + j, self->ping_length,
        self->channels, (SonarComplex *) map.data + j * bins, &n_bad);
  gst_buffer_unmap (out, &map);
  if (n_bad > 0 && !self->warned_non_finite) {
    GST_ELEMENT_WARNING (self, STREAM, FORMAT,
        ("The recording holds NaN or infinite samples (%u in ping %"
            G_GUINT64_FORMAT "); they are read as 0", n_bad,
            self->ping_index), (NULL));
    self->warned_non_finite = TRUE;
  }
  return out;
}

static GstFlowReturn
gst_doppler_bank_process (GstSonarFilter * filter, GstBuffer * buffer)
{
  GstDopplerBank *self = GST_DOPPLER_BANK (filter);
  const gsize ping_bytes = sizeof (float) * self->channels * self->ping_length;
  GstFlowReturn ret = GST_FLOW_OK;

  /* A whole ping in one buffer (sonarsrc): keep its timestamps and metas
   * (ground truth). Otherwise (a file), cut pings out of the stream. */
  if (gst_adapter_available (self->adapter) == 0
      && gst_buffer_get_size (buffer) == ping_bytes) {
    GstMapInfo map;
    GstBuffer *out;
    gst_buffer_map (buffer, &map, GST_MAP_READ);
    out = analyse_ping (self, (const float *) map.data);
    gst_buffer_unmap (buffer, &map);
    if (!out) {
      gst_buffer_unref (buffer);
      return GST_FLOW_FLUSHING;
    }
    gst_buffer_copy_into (out, buffer, GST_BUFFER_COPY_TIMESTAMPS |
        GST_BUFFER_COPY_FLAGS | GST_BUFFER_COPY_META, 0, -1);
    GST_BUFFER_OFFSET (out) = self->ping_index++;
    GST_BUFFER_OFFSET_END (out) = self->ping_index;
    gst_buffer_unref (buffer);
    return gst_sonar_filter_push (filter, out);
  }

  gst_adapter_push (self->adapter, buffer);
  while (ret == GST_FLOW_OK
      && gst_adapter_available (self->adapter) >= ping_bytes) {
    guint64 distance;
    GstClockTime pts = gst_adapter_prev_pts (self->adapter, &distance);
    const float *samples = gst_adapter_map (self->adapter, ping_bytes);
    GstBuffer *out = analyse_ping (self, samples);

    gst_adapter_unmap (self->adapter);
    if (!out)
      return GST_FLOW_FLUSHING;
    gst_adapter_flush (self->adapter, ping_bytes);
    if (GST_CLOCK_TIME_IS_VALID (pts))
      pts += gst_util_uint64_scale_int (distance / (sizeof (float) *
              self->channels), GST_SECOND, (int) self->band.sample_rate);
    GST_BUFFER_PTS (out) = pts;
    GST_BUFFER_DURATION (out) = gst_util_uint64_scale_int (self->ping_length,
        GST_SECOND, (int) self->band.sample_rate);
    GST_BUFFER_OFFSET (out) = self->ping_index++;
    GST_BUFFER_OFFSET_END (out) = self->ping_index;
    ret = gst_sonar_filter_push (filter, out);
  }
  return ret;
}

static void
gst_doppler_bank_reset (GstSonarFilter * filter, gboolean drain)
{
  GstDopplerBank *self = GST_DOPPLER_BANK (filter);
  const gsize left = gst_adapter_available (self->adapter);

  /* An incomplete ping cannot be filtered: say so rather than drop it
   * silently. */
  if (drain && left > 0)
    GST_ELEMENT_WARNING (self, STREAM, DECODE,
        ("The stream ended inside a ping: %" G_GSIZE_FORMAT " of %u samples "
            "per channel; that partial ping is ignored",
            left / (sizeof (float) * self->channels), self->ping_length),
        (NULL));
  gst_adapter_clear (self->adapter);
  if (!drain) {
    self->ping_index = 0;
    self->warned_non_finite = FALSE;
  }
}

static void
gst_doppler_bank_set_property (GObject * object, guint prop_id,
    const GValue * value, GParamSpec * pspec)
{
  GstDopplerBank *self = GST_DOPPLER_BANK (object);

  GST_OBJECT_LOCK (self);
  switch (prop_id) {
    case PROP_VELOCITY_MIN:
      self->velocity_min = g_value_get_double (value);
      break;
    case PROP_VELOCITY_MAX:
      self->velocity_max = g_value_get_double (value);
      break;
    case PROP_VELOCITY_STEP:
      self->velocity_step = g_value_get_double (value);
      break;
    case PROP_GEOMETRY_FILE:
      g_free (self->geometry_file);
      self->geometry_file = g_value_dup_string (value);
      break;
    case PROP_WAVEFORMS_FILE:
      g_free (self->waveforms_file);
      self->waveforms_file = g_value_dup_string (value);
      break;
    case PROP_PING_LENGTH:
      self->ping_length_setting = g_value_get_uint (value);
      break;
    case PROP_SPEED_OF_SOUND:
      self->speed_of_sound = g_value_get_double (value);
      break;
    case PROP_MAX_MEMORY:
      self->max_memory = g_value_get_uint64 (value);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID (object, prop_id, pspec);
      break;
  }
  GST_OBJECT_UNLOCK (self);
}

static void
gst_doppler_bank_get_property (GObject * object, guint prop_id,
    GValue * value, GParamSpec * pspec)
{
  GstDopplerBank *self = GST_DOPPLER_BANK (object);

  GST_OBJECT_LOCK (self);
  switch (prop_id) {
    case PROP_VELOCITY_MIN:
      g_value_set_double (value, self->velocity_min);
      break;
    case PROP_VELOCITY_MAX:
      g_value_set_double (value, self->velocity_max);
      break;
    case PROP_VELOCITY_STEP:
      g_value_set_double (value, self->velocity_step);
      break;
    case PROP_GEOMETRY_FILE:
      g_value_set_string (value, self->geometry_file);
      break;
    case PROP_WAVEFORMS_FILE:
      g_value_set_string (value, self->waveforms_file);
      break;
    case PROP_PING_LENGTH:
      g_value_set_uint (value, self->ping_length_setting);
      break;
    case PROP_SPEED_OF_SOUND:
      g_value_set_double (value, self->speed_of_sound);
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
gst_doppler_bank_finalize (GObject * object)
{
  GstDopplerBank *self = GST_DOPPLER_BANK (object);

  g_object_unref (self->adapter);
  g_free (self->geometry_file);
  g_free (self->waveforms_file);
  G_OBJECT_CLASS (gst_doppler_bank_parent_class)->finalize (object);
}

static void
gst_doppler_bank_init (GstDopplerBank * self)
{
  self->velocity_min = DEFAULT_VELOCITY_MIN;
  self->velocity_max = DEFAULT_VELOCITY_MAX;
  self->velocity_step = DEFAULT_VELOCITY_STEP;
  self->speed_of_sound = SONAR_DEFAULT_SPEED_OF_SOUND;
  self->max_memory = SONAR_DEFAULT_MAX_MEMORY;
  self->adapter = gst_adapter_new ();
}

static void
gst_doppler_bank_class_init (GstDopplerBankClass * klass)
{
  GObjectClass *gobject_class = G_OBJECT_CLASS (klass);
  GstElementClass *element_class = GST_ELEMENT_CLASS (klass);
  GstSonarFilterClass *filter_class = GST_SONAR_FILTER_CLASS (klass);
  const GParamFlags flags = G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS
      | GST_PARAM_MUTABLE_READY;

  gobject_class->set_property = gst_doppler_bank_set_property;
  gobject_class->get_property = gst_doppler_bank_get_property;
  gobject_class->finalize = gst_doppler_bank_finalize;

  g_object_class_install_property (gobject_class, PROP_VELOCITY_MIN,
      g_param_spec_double ("velocity-min", "Minimum velocity", "Slowest "
          "radial velocity of the bank, in m/s (negative: approaching)",
          -80.0, 80.0, DEFAULT_VELOCITY_MIN, flags));
  g_object_class_install_property (gobject_class, PROP_VELOCITY_MAX,
      g_param_spec_double ("velocity-max", "Maximum velocity", "Fastest "
          "radial velocity of the bank, in m/s (positive: receding)",
          -80.0, 80.0, DEFAULT_VELOCITY_MAX, flags));
  g_object_class_install_property (gobject_class, PROP_VELOCITY_STEP,
      g_param_spec_double ("velocity-step", "Velocity step", "Spacing of the "
          "bank's velocities, in m/s (the paper uses 0.05 and 0.02)",
          0.0001, 100.0, DEFAULT_VELOCITY_STEP, flags));

  g_object_class_install_property (gobject_class, PROP_GEOMETRY_FILE,
      g_param_spec_string ("geometry-file", "Geometry file", "For "
          "recordings: JSON array geometry (docs/FORMATS.md); default the "
          "built-in eRTIS array. Needs waveforms-file", NULL, flags));
  g_object_class_install_property (gobject_class, PROP_WAVEFORMS_FILE,
      g_param_spec_string ("waveforms-file", "Waveforms file", "For "
          "recordings: JSON emission waveforms (docs/FORMATS.md). When set, "
          "the set-up comes from these files instead of upstream", NULL,
          flags));
  g_object_class_install_property (gobject_class, PROP_PING_LENGTH,
      g_param_spec_uint ("ping-length", "Ping length", "For recordings: "
          "samples per channel of one ping (sonarsrc's pings: see its "
          "set-up; 17261 by default)", 0, SONAR_MAX_PING_LENGTH, 0, flags));
  g_object_class_install_property (gobject_class, PROP_SPEED_OF_SOUND,
      g_param_spec_double ("speed-of-sound", "Speed of sound", "For "
          "recordings: speed of sound, in m/s", 100.0, 2000.0,
          SONAR_DEFAULT_SPEED_OF_SOUND, flags));
  g_object_class_install_property (gobject_class, PROP_MAX_MEMORY,
      sonar_memory_param_spec (flags));

  gst_element_class_add_static_pad_template (element_class, &sink_template);
  gst_element_class_add_static_pad_template (element_class, &src_template);
  gst_element_class_set_static_metadata (element_class,
      "Doppler matched-filter bank", "Filter/Analyzer/Sonar",
      "Builds the Doppler-scaled templates of every emission once and takes "
      "each ping's microphone recordings onto their band",
      "gst-sonar-velocity developers");

  filter_class->needs_bank = FALSE;
  filter_class->make_setup = GST_DEBUG_FUNCPTR (gst_doppler_bank_make_setup);
  filter_class->configure = GST_DEBUG_FUNCPTR (gst_doppler_bank_configure);
  filter_class->unconfigure = GST_DEBUG_FUNCPTR (gst_doppler_bank_unconfigure);
  filter_class->process = GST_DEBUG_FUNCPTR (gst_doppler_bank_process);
  filter_class->reset = GST_DEBUG_FUNCPTR (gst_doppler_bank_reset);
}
