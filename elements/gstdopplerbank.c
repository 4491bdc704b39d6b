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
 * Input: the recording, interleaved, float or integer samples, with or
 * without a channel-mask, cut into buffers of any size. The set-up's ping
 * framing says where each ping starts (its trigger sample), how many
 * samples it spans and when it happened; samples between pings are
 * skipped. Output: application/x-sonar-spectra, one buffer per ping,
 * OFFSET the ping's index in the stream, PTS its trigger instant.
 *
 * A ping that the stream does not hold whole (the stream starts or ends
 * inside it, a gap, a seek) is dropped, counted, and reported in a bus
 * warning; never framed across the hole.
 *
 * A recording made elsewhere (a WAV file) carries no set-up event: give its
 * sensor description (docs/FORMATS.md):
 *
 *   gst-launch-1.0 filesrc location=pings.wav ! wavparse \
 *       ! dopplerbank sensor-file=pings.json ! mimobeamform ! ...
 *
 *   gst-launch-1.0 sonarsrc ! dopplerbank velocity-min=-0.4 velocity-max=0.4 \
 *       velocity-step=0.02 ! mimobeamform ! fakesink
 */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstdopplerbank.h"
#include "sonar-direct-path.h"
#include "sonar-error.h"
#include "sonar-memory.h"
#include "sonar-workers.h"

#include <gio/gio.h>
#include <gst/audio/audio.h>
#include <gst/base/gstadapter.h>
#include <math.h>

#include "sonar-sensor-file.h"

GST_DEBUG_CATEGORY_STATIC (doppler_bank_debug);
#define GST_CAT_DEFAULT doppler_bank_debug

#define DEFAULT_VELOCITY_MIN -7.0
#define DEFAULT_VELOCITY_MAX 7.0
#define DEFAULT_VELOCITY_STEP 0.05
#define DEFAULT_DIRECT_PATH SONAR_DIRECT_PATH_AUTO

#define GST_TYPE_SONAR_DIRECT_PATH_MODE (sonar_direct_path_mode_get_type ())
static GType
sonar_direct_path_mode_get_type (void)
{
  static GType type = 0;
  static const GEnumValue values[] = {
    {SONAR_DIRECT_PATH_OFF, "Leave the recording as it is", "off"},
    {SONAR_DIRECT_PATH_AUTO, "Subtract it from the microphones where it "
          "holds a fifth or more of what they record meanwhile", "auto"},
    {SONAR_DIRECT_PATH_ALWAYS, "Subtract the fit from every microphone",
        "always"},
    {0, NULL, NULL}
  };

  if (g_once_init_enter (&type))
    g_once_init_leave (&type,
        g_enum_register_static ("GstSonarDirectPath", values));
  return type;
}

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
  PROP_SENSOR_FILE,
  PROP_THREADS,
  PROP_MAX_MEMORY,
  PROP_DIRECT_PATH,
  PROP_DIRECT_PATH_TAPS,
};

struct _GstDopplerBank
{
  GstSonarFilter parent;

  /* Properties, protected by the object lock. */
  double velocity_min, velocity_max, velocity_step;
  char *sensor_file, *geometry_file, *waveforms_file;
  guint64 max_memory;
  guint ping_length_setting;
  double speed_of_sound;
  guint threads;
  SonarDirectPathMode direct_path_mode;
  guint direct_path_taps;

  /* Configured state. */
  SonarSetup *setup;            /* the filter's: valid while configured */
  GstAudioInfo info;
  guint channels;
  guint ping_length;
  SonarBand band;
  SonarChannelSpectra *analyzer;
  SonarDirectPath *direct_path; /* NULL with direct-path=off */
  gboolean told_direct_path;
  float *converted;             /* one ping as float, for other formats */
  gpointer unpacked;            /* one ping unpacked by GstAudioFormatInfo */
  gboolean warned_non_finite, warned_overflow, warned_clipped;
  gboolean warned_glitches, warned_loud;

  /* Framing: the adapter holds the stream from sample adapter_position on;
   * next_ping is the first ping not yet output or dropped. */
  GstAdapter *adapter;
  gboolean position_known;
  guint64 adapter_position;
  guint64 next_ping;
  gboolean reached_ping;        /* the stream reached a ping's window */
  GstClockTime stream_start_pts;        /* PTS of stream sample 0 */
  /* The input's times are its samples' (a recording read with its own
   * sensor description: wavparse's), not its pings' instants (sonarsrc's,
   * whose set-up event came with them). */
  gboolean samples_timed;
};

G_DEFINE_TYPE (GstDopplerBank, gst_doppler_bank, GST_TYPE_SONAR_FILTER);
GST_ELEMENT_REGISTER_DEFINE_WITH_CODE (dopplerbank, "dopplerbank",
    GST_RANK_NONE, GST_TYPE_DOPPLER_BANK,
    GST_DEBUG_CATEGORY_INIT (doppler_bank_debug, "dopplerbank", 0,
        "Doppler matched-filter bank"));

static GstStaticPadTemplate sink_template = GST_STATIC_PAD_TEMPLATE ("sink",
    GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS (SONAR_RECORDING_SINK_CAPS));
static GstStaticPadTemplate src_template = GST_STATIC_PAD_TEMPLATE ("src",
    GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS (SONAR_SPECTRA_CAPS));

/* With waveforms-file set, the set-up comes from the files, whatever
 * arrives from upstream. */
static SonarSetup *
gst_doppler_bank_make_setup (GstSonarFilter * filter, GstCaps * in_caps,
    GError ** error)
{
  GstDopplerBank *self = GST_DOPPLER_BANK (filter);
  g_autofree char *sensor = NULL, *geometry = NULL, *waveforms = NULL;
  guint ping_length;
  double c;

  GST_OBJECT_LOCK (self);
  sensor = g_strdup (self->sensor_file);
  geometry = g_strdup (self->geometry_file);
  waveforms = g_strdup (self->waveforms_file);
  ping_length = self->ping_length_setting;
  c = self->speed_of_sound;
  GST_OBJECT_UNLOCK (self);
  self->samples_timed = sensor || waveforms;

  if (sensor) {
    if (geometry || waveforms || ping_length) {
      g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS,
          "dopplerbank: sensor-file describes the whole sensor: leave "
          "geometry-file, waveforms-file and ping-length unset");
      return NULL;
    }
    return sonar_sensor_file_load (sensor, error);
  }
  if (!waveforms) {
    if (geometry || ping_length)
      g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS,
          "dopplerbank: geometry-file and ping-length need waveforms-file "
          "too");
    return NULL;
  }
  if (ping_length == 0) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS,
        "dopplerbank: waveforms-file needs ping-length, the samples per "
        "channel of one ping of the recording");
    return NULL;
  }
  return sonar_setup_new_from_files (geometry, waveforms, c, ping_length,
      error);
}

/* GstAudioInfo of a recording: GStreamer 1.22 wants a channel-mask for
 * more than 2 channels, which plain WAVs do not carry; the channels are
 * microphones, not loudspeaker positions, so mask 0 is what they are. */
static gboolean
recording_info_from_caps (GstAudioInfo * info, GstCaps * caps)
{
  g_autoptr (GstCaps) masked = gst_caps_copy (caps);
  GstStructure *s = gst_caps_get_structure (masked, 0);

  if (!gst_structure_has_field (s, "channel-mask"))
    gst_structure_set (s, "channel-mask", GST_TYPE_BITMASK, (guint64) 0,
        NULL);
  return gst_audio_info_from_caps (info, masked)
      && GST_AUDIO_INFO_LAYOUT (info) == GST_AUDIO_LAYOUT_INTERLEAVED;
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
  guint64 max_memory, bank_bytes, direct_bytes;
  guint n_velocities, threads, direct_path_taps;
  SonarDirectPathMode direct_path_mode;
  SonarBand ping_band;

  if (!in_caps || !recording_info_from_caps (&info, in_caps)) {
    g_autofree char *text = in_caps ? gst_caps_to_string (in_caps) : NULL;
    g_set_error (error, GST_CORE_ERROR, GST_CORE_ERROR_NEGOTIATION,
        "dopplerbank: the input is not an interleaved recording of %s "
        "samples: %s", SONAR_RECORDING_FORMATS, text ? text : "no caps");
    return NULL;
  }
  if ((guint) GST_AUDIO_INFO_CHANNELS (&info) !=
      setup->geometry.n_microphones
      || GST_AUDIO_INFO_RATE (&info) != setup->sample_rate) {
    g_set_error (error, GST_CORE_ERROR, GST_CORE_ERROR_NEGOTIATION,
        "dopplerbank: the recording has %d channels at %d Hz, but the sensor "
        "description has %u microphones at %g Hz",
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
  GST_OBJECT_LOCK (self);
  direct_path_mode = self->direct_path_mode;
  direct_path_taps = self->direct_path_taps;
  GST_OBJECT_UNLOCK (self);
  if (direct_path_taps == 0)
    direct_path_taps = sonar_direct_path_default_taps (setup);
  else if (direct_path_taps <= SONAR_DIRECT_PATH_LEAD) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS, "dopplerbank: "
        "direct-path-taps %u: at least %u (%u before a path's delay and one "
        "after), or 0 for the sensor's", direct_path_taps,
        SONAR_DIRECT_PATH_LEAD + 1, SONAR_DIRECT_PATH_LEAD);
    return NULL;
  }
  direct_bytes = direct_path_mode == SONAR_DIRECT_PATH_OFF ? 0 :
      sonar_direct_path_memory (setup, direct_path_taps);
  if (!sonar_memory_check_buffers (bank_bytes + direct_bytes,
          sizeof (SonarComplex) * (guint64) ping_band.n_bins *
          setup->geometry.n_microphones, GST_SONAR_FILTER_POOL_MIN_BUFFERS,
          max_memory, error, "dopplerbank: a bank of %u velocities "
          "(velocity-min %g, velocity-max %g, velocity-step %g m/s) for %u "
          "emitters, %s and %u output buffers of %u microphones x %u band "
          "bins", n_velocities, v_min, v_max, v_step,
          setup->geometry.n_emitters, direct_bytes ? "the direct path's fit "
          "(direct-path)" : "no direct-path fit",
          GST_SONAR_FILTER_POOL_MIN_BUFFERS, setup->geometry.n_microphones,
          ping_band.n_bins))
    return NULL;
  bank = sonar_doppler_bank_new (setup, v_min, v_max, v_step, error);
  if (!bank)
    return NULL;
  self->setup = setup;
  self->info = info;
  self->channels = setup->geometry.n_microphones;
  self->ping_length = setup->ping_length;
  self->converted = g_new (float, (gsize) self->channels *
      self->ping_length);
  if (GST_AUDIO_INFO_FORMAT (&info) != GST_AUDIO_FORMAT_F32LE)
    self->unpacked = g_malloc ((gsize) self->channels * self->ping_length *
        (GST_AUDIO_INFO_IS_FLOAT (&info) ? sizeof (double) :
            sizeof (gint32)));
  sonar_doppler_bank_prepare_ping_band (bank);
  self->band = *sonar_doppler_bank_band (bank);
  gst_sonar_filter_set_bank (filter, bank, &self->band);
  GST_OBJECT_LOCK (self);
  threads = self->threads;
  GST_OBJECT_UNLOCK (self);
  self->analyzer = sonar_channel_spectra_new (&self->band, self->channels,
      threads, error);
  if (!self->analyzer)
    return NULL;
  if (direct_path_mode != SONAR_DIRECT_PATH_OFF) {
    g_autoptr (GError) why = NULL;
    self->direct_path = sonar_direct_path_new (setup, direct_path_taps,
        &why);
    if (!self->direct_path && direct_path_mode == SONAR_DIRECT_PATH_ALWAYS) {
      g_set_error (error, why->domain, why->code, "dopplerbank: "
          "direct-path=always: %s", why->message);
      return NULL;
    }
    if (!self->direct_path)
      GST_INFO_OBJECT (self, "no direct-path subtraction: %s", why->message);
    sonar_channel_spectra_set_direct_path (self->analyzer,
        self->direct_path, direct_path_mode);
  }
  {
    g_autofree char *problems = sonar_setup_check (setup);
    if (problems)
      GST_ELEMENT_WARNING (self, STREAM, FORMAT, ("The sensor cannot work "
              "as the chain needs: %s", problems), (NULL));
  }
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

  g_clear_pointer (&self->analyzer, sonar_channel_spectra_free);
  g_clear_pointer (&self->direct_path, sonar_direct_path_free);
  g_clear_pointer (&self->converted, g_free);
  g_clear_pointer (&self->unpacked, g_free);
  self->setup = NULL;
  gst_adapter_clear (self->adapter);
  self->position_known = FALSE;
}

/* Integer samples this close to full scale (unpacked to 32 bits: the
 * 16-bit format's largest, 32767 << 16; 8-bit formats' is 127 << 24) are
 * taken as clipped. */
static gint64
clipped_sample (const GstAudioFormatInfo * format)
{
  return MIN (0x7fff0000, G_GINT64_CONSTANT (0x80000000) - (G_GINT64_CONSTANT
          (1) << (32 - MIN (GST_AUDIO_FORMAT_INFO_DEPTH (format), 31))));
}

/* The ping's samples as float: F32LE as it is, other formats unpacked by
 * GStreamer's own format table, integers as fractions of full scale (and
 * clipped ones reported once: the ADC saturated, the echoes are
 * distorted). */
static const float *
ping_samples (GstDopplerBank * self, const guint8 * data, guint64 index)
{
  const GstAudioFormatInfo *format = self->info.finfo;
  const gsize n = (gsize) self->channels * self->ping_length;

  if (!self->unpacked)
    return (const float *) data;
  format->unpack_func (format, GST_AUDIO_PACK_FLAG_NONE, self->unpacked,
      data, (int) n);
  if (GST_AUDIO_FORMAT_INFO_IS_FLOAT (format)) {
    const double *unpacked = self->unpacked;
    for (gsize i = 0; i < n; i++)
      self->converted[i] = (float) unpacked[i];
  } else {
    /* Unpacked integers fill the 32 bits, whatever their width. */
    const gint32 *unpacked = self->unpacked;
    const gint64 clip = clipped_sample (format);
    gsize clipped = 0;
    for (gsize i = 0; i < n; i++) {
      self->converted[i] = unpacked[i] * (1.0f / 2147483648.0f);
      clipped += ABS ((gint64) unpacked[i]) >= clip;
    }
    if (clipped > 0 && !self->warned_clipped) {
      GST_ELEMENT_WARNING (self, STREAM, FORMAT, ("The recording is "
              "clipped: %" G_GSIZE_FORMAT " samples of ping %" G_GUINT64_FORMAT
              " at full scale; their echoes are distorted (lower the "
              "recording's gain)", clipped, index), (NULL));
      self->warned_clipped = TRUE;
    }
  }
  return self->converted;
}

/* Samples beyond this would overflow float sums downstream: a ping's FFT
 * sums 10^4 of them, the matched filters and the velocity stage's
 * correlations multiply and sum again (three objects at 1.6e28 in a 5 m
 * ping lost one to it, 1e30 all: /stability/amplitudes-1e-30-1e30). */
#define MAX_SAFE_SAMPLE 1e20f

/* A ping of huge samples, scaled down by a power of two: exact, and no
 * position or velocity depends on the scale. */
static const float *
tame_overflow (GstDopplerBank * self, const float *samples, guint64 index)
{
  const gsize n = (gsize) self->channels * self->ping_length;
  float peak = 0.0f, scale;
  int exponent;

  for (gsize i = 0; i < n; i++)
    if (isfinite (samples[i]))
      peak = MAX (peak, fabsf (samples[i]));
  if (peak <= MAX_SAFE_SAMPLE)
    return samples;
  frexpf (peak / MAX_SAFE_SAMPLE, &exponent);
  scale = ldexpf (1.0f, -exponent);
  for (gsize i = 0; i < n; i++)
    self->converted[i] = samples[i] * scale;
  if (!self->warned_overflow) {
    GST_ELEMENT_WARNING (self, STREAM, FORMAT, ("The recording's samples "
            "reach %g in ping %" G_GUINT64_FORMAT ", beyond what float "
            "spectra hold; such pings are scaled by 2^-%d, which changes "
            "no position or velocity", peak, index, exponent), (NULL));
    self->warned_overflow = TRUE;
  }
  return self->converted;
}

/* The first ping whose trigger sample is at or after @position. */
static guint64
first_ping_from (const SonarSetup * setup, guint64 position)
{
  guint64 index;

  if (position <= setup->trigger_offset)
    return 0;
  index = (guint64) ceil ((position - setup->trigger_offset) /
      setup->ping_stride - 1e-9);
  /* The rounding of sonar_setup_ping_start can put a start a sample
   * either side of the exact quotient. */
  while (index > 0 && sonar_setup_ping_start (setup, index - 1) >= position)
    index--;
  while (sonar_setup_ping_start (setup, index) < position)
    index++;
  return index;
}

/* Seconds from the stream's first sample to sample @position. A ping's
 * samples follow its trigger instant at the sample rate, and ping k is
 * triggered trigger-offset / rate + k x ping-period after the stream's
 * start: a stream of pings stored back to back (sonarsrc's) is not
 * continuous in time. */
static double
position_time (const SonarSetup * setup, guint64 position)
{
  guint64 ping;

  if (position < setup->trigger_offset)
    return position / setup->sample_rate;
  ping = first_ping_from (setup, position + 1) - 1;
  return (setup->trigger_offset + (double) (position -
          sonar_setup_ping_start (setup, ping))) / setup->sample_rate +
      ping * setup->ping_period;
}

/* The inverse: the sample at @seconds from the stream's start. */
static guint64
time_position (const SonarSetup * setup, double seconds)
{
  const double trigger = setup->trigger_offset / setup->sample_rate;
  guint64 ping;

  if (seconds < trigger)
    return (guint64) llround (seconds * setup->sample_rate);
  ping = (guint64) floor ((seconds - trigger) / setup->ping_period);
  return sonar_setup_ping_start (setup, ping) + (guint64) llround ((seconds -
          trigger - ping * setup->ping_period) * setup->sample_rate);
}

/* The instants of a recording's times (sample position / rate from the
 * stream's start, as wavparse's) and back: a recording of windows stored
 * back to back (sonarsrc's) is not continuous in time, and its pings are
 * stamped with their instants; a continuous recording maps to itself, and
 * so does an input already in instants (samples_timed unset). */
static GstClockTime
gst_doppler_bank_output_time (GstSonarFilter * filter, GstClockTime time)
{
  const GstDopplerBank *self = GST_DOPPLER_BANK (filter);
  const SonarSetup *setup = self->setup;
  guint64 position;

  if (!setup || !self->samples_timed)
    return time;
  position = (guint64) llround ((double) time / GST_SECOND *
      setup->sample_rate);
  return (GstClockTime) llround (position_time (setup, position) *
      GST_SECOND);
}

static GstClockTime
gst_doppler_bank_input_time (GstSonarFilter * filter, GstClockTime time)
{
  const GstDopplerBank *self = GST_DOPPLER_BANK (filter);
  const SonarSetup *setup = self->setup;
  guint64 position;

  if (!setup || !self->samples_timed)
    return time;
  position = time_position (setup, (double) time / GST_SECOND);
  return (GstClockTime) llround ((double) position / setup->sample_rate *
      GST_SECOND);
}

/* Ping @index's trigger instant (one rule for live pings and replays). */
static GstClockTime
ping_pts (GstDopplerBank * self, guint64 index)
{
  if (!GST_CLOCK_TIME_IS_VALID (self->stream_start_pts))
    return GST_CLOCK_TIME_NONE;
  return self->stream_start_pts + (GstClockTime) llround (position_time
      (self->setup, sonar_setup_ping_start (self->setup, index)) *
      GST_SECOND);
}

static GstClockTime
ping_duration (GstDopplerBank * self)
{
  return gst_util_uint64_scale_round (self->ping_length, GST_SECOND,
      (guint64) self->setup->sample_rate);
}

/* Ping @index: the spectra of its channels, time-stamped from the
 * framing. */
static GstBuffer *
analyse_ping (GstDopplerBank * self, const guint8 * data, guint64 index)
{
  GstBuffer *out = gst_sonar_filter_new_buffer (GST_SONAR_FILTER (self),
      sizeof (SonarComplex) * self->band.n_bins * self->channels);
  const float *samples;
  GstMapInfo map;
  guint n_bad = 0;

  if (!out)
    return NULL;

  samples = tame_overflow (self, ping_samples (self, data, index), index);
  gst_buffer_map (out, &map, GST_MAP_WRITE);
  n_bad = sonar_channel_spectra_process (self->analyzer, samples,
      self->ping_length, (SonarComplex *) map.data);
  gst_buffer_unmap (out, &map);
  if (self->direct_path && !self->told_direct_path) {
    double largest_db;
    const guint removed = sonar_channel_spectra_direct_path_removed
        (self->analyzer, &largest_db);
    if (removed > 0) {
      /* Once a stream: what the user's recording holds, and what was
       * done; the text as the debug string too, which gst-launch-1.0
       * prints of an info message. */
      g_autofree char *text = g_strdup_printf ("The recording holds the "
          "emissions' direct path to the microphones (from ping %"
          G_GUINT64_FORMAT ", on %u of %u, up to %.0f dB over the rest of "
          "what they record meanwhile); it is subtracted before the matched "
          "filters%s (direct-path=off keeps it)", index, removed,
          self->channels, largest_db,
          sonar_direct_path_rang (self->direct_path) ? ", with "
          G_STRINGIFY (SONAR_DIRECT_PATH_RINGING_TAPS) " taps where the "
          "emitters ring past direct-path-taps" : "");
      g_autoptr (GError) info = g_error_new_literal (GST_STREAM_ERROR,
          GST_STREAM_ERROR_FORMAT, text);
      GST_INFO_OBJECT (self, "%s", text);
      gst_element_post_message (GST_ELEMENT (self),
          gst_message_new_info (GST_OBJECT (self), info, text));
      self->told_direct_path = TRUE;
    }
  }
  if (n_bad > 0 && !self->warned_non_finite) {
    GST_ELEMENT_WARNING (self, STREAM, FORMAT,
        ("The recording holds NaN or infinite samples (%u in ping %"
            G_GUINT64_FORMAT "); they are read as 0", n_bad, index), (NULL));
    self->warned_non_finite = TRUE;
  }
  if (!self->warned_glitches) {
    float largest;
    const guint zeroed = sonar_channel_spectra_glitches (self->analyzer,
        &largest);
    if (zeroed > 0) {
      GST_ELEMENT_WARNING (self, STREAM, FORMAT, ("The recording holds "
              "glitches, samples louder than %g times their channel's "
              "quiet peak and %g times every sample within %d of them, "
              "which no echo is (%u in ping %" G_GUINT64_FORMAT ", up to "
              "%g); they are read as 0", SONAR_GLITCH_OVER_QUIET,
              SONAR_GLITCH_OVER_NEIGHBOURS, SONAR_GLITCH_FLANK, zeroed,
              index, largest), (NULL));
      self->warned_glitches = TRUE;
    }
  }
  if (!self->warned_loud) {
    guint first;
    double db;
    const guint loud = sonar_channel_spectra_loud (self->analyzer, &first,
        &db);
    if (loud > 0) {
      GST_ELEMENT_WARNING (self, STREAM, FORMAT, ("The recording holds loud "
              "microphones, %.0f dB or more over the median one where they "
              "record no echo: a hum or a bad channel (%u in ping %"
              G_GUINT64_FORMAT ", the first microphone %u, up to %.0f dB); "
              "they are read as 0", 20.0 * log10 (SONAR_LOUD_CHANNEL_RATIO),
              loud, index, first, db), (NULL));
      self->warned_loud = TRUE;
    }
  }
  GST_BUFFER_PTS (out) = ping_pts (self, index);
  GST_BUFFER_DURATION (out) = ping_duration (self);
  GST_BUFFER_OFFSET (out) = index;
  GST_BUFFER_OFFSET_END (out) = index + 1;
  return out;
}

static void
drop_pings (GstDopplerBank * self, guint64 first, guint64 end,
    const char *why)
{
  g_autofree char *text = g_strdup_printf ("not held whole by the stream: "
      "%s", why);

  gst_sonar_filter_drop_pings (GST_SONAR_FILTER (self), first, end, text);
}

/* Pings none of whose samples came: dropped upstream, whole. */
static void
missing_pings (GstDopplerBank * self, guint64 first, guint64 end,
    guint64 expected, guint64 position)
{
  g_autofree char *text = g_strdup_printf ("missing from the stream: it "
      "jumps from sample %" G_GUINT64_FORMAT " to %" G_GUINT64_FORMAT " (a "
      "live source that fell behind or a leaky queue dropped them)",
      expected, position);

  gst_sonar_filter_drop_pings (GST_SONAR_FILTER (self), first, end, text);
}

/* Where @buffer's first sample lies in the stream: its OFFSET (the sample
 * offset of raw audio, trusted when OFFSET_END - OFFSET is the buffer's
 * sample count: some sources put byte offsets there), else its PTS, else
 * right after what came before. */
static guint64
buffer_position (GstDopplerBank * self, GstBuffer * buffer, guint64 expected)
{
  const guint64 frames = gst_buffer_get_size (buffer) /
      GST_AUDIO_INFO_BPF (&self->info);

  if (GST_BUFFER_OFFSET_IS_VALID (buffer)
      && GST_BUFFER_OFFSET_END_IS_VALID (buffer)
      && GST_BUFFER_OFFSET_END (buffer) - GST_BUFFER_OFFSET (buffer) ==
      frames)
    return GST_BUFFER_OFFSET (buffer);
  if (GST_BUFFER_PTS_IS_VALID (buffer)
      && GST_CLOCK_TIME_IS_VALID (self->stream_start_pts)
      && GST_BUFFER_PTS (buffer) >= self->stream_start_pts)
    return time_position (self->setup, (double) (GST_BUFFER_PTS (buffer) -
            self->stream_start_pts) / GST_SECOND);
  return expected;
}

/* Takes @buffer into the framing: a jump in position drops what the
 * adapter held of an incomplete ping. */
static void
take_buffer (GstDopplerBank * self, GstBuffer * buffer)
{
  const gsize frame = GST_AUDIO_INFO_BPF (&self->info);
  const guint64 expected = self->adapter_position +
      gst_adapter_available (self->adapter) / frame;
  const guint64 position = buffer_position (self, buffer, expected);

  if (!self->position_known) {
    /* The stream's first buffer (or the first after a flush): a ping
     * already under way is not whole. */
    const guint64 first = first_ping_from (self->setup, position);
    if (GST_BUFFER_PTS_IS_VALID (buffer))
      self->stream_start_pts = GST_BUFFER_PTS (buffer) -
          MIN (GST_BUFFER_PTS (buffer), (GstClockTime) llround
          (position_time (self->setup, position) * GST_SECOND));
    if (first > 0 && position < sonar_setup_ping_start (self->setup,
            first - 1) + self->ping_length)
      drop_pings (self, first - 1, first, "the stream starts inside it");
    self->next_ping = first;
    self->adapter_position = position;
    self->position_known = TRUE;
  } else if (position != expected) {
    const guint64 resume = first_ping_from (self->setup, position);
    const gboolean partial = gst_adapter_available (self->adapter) > 0
        && expected > sonar_setup_ping_start (self->setup, self->next_ping);
    g_autofree char *why = g_strdup_printf ("the stream jumps from sample %"
        G_GUINT64_FORMAT " to %" G_GUINT64_FORMAT, expected, position);

    gst_adapter_clear (self->adapter);
    if (position > expected && !partial && resume > self->next_ping
        && sonar_setup_ping_start (self->setup, resume - 1) +
        self->ping_length <= position)
      missing_pings (self, self->next_ping, resume, expected, position);
    else if (position > expected)
      drop_pings (self, self->next_ping, resume, why);
    else if (partial)
      drop_pings (self, self->next_ping, self->next_ping + 1, why);
    self->next_ping = resume;
    self->adapter_position = position;
  }
  gst_adapter_push (self->adapter, buffer);
}

static GstFlowReturn
gst_doppler_bank_process (GstSonarFilter * filter, GstBuffer * buffer)
{
  GstDopplerBank *self = GST_DOPPLER_BANK (filter);
  const gsize frame = GST_AUDIO_INFO_BPF (&self->info);
  const gsize ping_bytes = frame * self->ping_length;
  GstFlowReturn ret = GST_FLOW_OK;
  gboolean whole_ping;

  /* A buffer that is exactly the next ping (sonarsrc's) keeps its metas
   * (ground truth). */
  take_buffer (self, buffer);
  whole_ping = self->adapter_position ==
      sonar_setup_ping_start (self->setup, self->next_ping)
      && gst_adapter_available (self->adapter) == ping_bytes;
  while (ret == GST_FLOW_OK) {
    const guint64 start = sonar_setup_ping_start (self->setup,
        self->next_ping);
    const gsize available = gst_adapter_available (self->adapter);
    GstBuffer *in, *out;
    GstMapInfo map;

    if (self->adapter_position < start) {
      /* Between two pings' windows: not part of any ping. */
      const gsize skip = MIN (available / frame, start -
          self->adapter_position);
      gst_adapter_flush (self->adapter, skip * frame);
      self->adapter_position += skip;
      if (self->adapter_position < start)
        break;
      continue;
    }
    self->reached_ping = TRUE;
    if (available < ping_bytes)
      break;
    if (gst_sonar_filter_drop_late (filter, self->next_ping, ping_pts (self,
                self->next_ping), ping_duration (self))) {
      gst_adapter_flush (self->adapter, ping_bytes);
      self->adapter_position += self->ping_length;
      self->next_ping++;
      continue;
    }
    in = gst_adapter_take_buffer_fast (self->adapter, ping_bytes);
    self->adapter_position += self->ping_length;
    gst_buffer_map (in, &map, GST_MAP_READ);
    out = analyse_ping (self, map.data, self->next_ping);
    gst_buffer_unmap (in, &map);
    if (!out) {
      gst_buffer_unref (in);
      return GST_FLOW_FLUSHING;
    }
    if (whole_ping)
      gst_buffer_copy_into (out, in, GST_BUFFER_COPY_FLAGS |
          GST_BUFFER_COPY_META, 0, -1);
    gst_buffer_unref (in);
    self->next_ping++;
    ret = gst_sonar_filter_push (filter, out);
  }
  return ret;
}

static void
gst_doppler_bank_reset (GstSonarFilter * filter, gboolean drain)
{
  GstDopplerBank *self = GST_DOPPLER_BANK (filter);

  /* An incomplete ping cannot be filtered: say so rather than drop it
   * silently. */
  if (drain && self->setup && gst_adapter_available (self->adapter) > 0
      && self->adapter_position >= sonar_setup_ping_start (self->setup,
          self->next_ping)) {
    g_autofree char *why = g_strdup_printf ("the stream ended inside a ping, "
        "%" G_GSIZE_FORMAT " of its %u samples per channel in",
        gst_adapter_available (self->adapter) /
        GST_AUDIO_INFO_BPF (&self->info), self->ping_length);
    drop_pings (self, self->next_ping, self->next_ping + 1, why);
  }
  /* A stream that ends before its first ping's window (a trigger-offset
   * past the recording's end) gives nothing: say so. */
  if (drain && self->setup && self->position_known && !self->reached_ping)
    GST_ELEMENT_WARNING (self, STREAM, DEMUX, ("dopplerbank: the stream "
            "ended at %.6g s, before ping %" G_GUINT64_FORMAT "'s window, "
            "which starts at %.6g s (the sensor's trigger-offset and "
            "ping-period): no ping was analysed", (double)
            (self->adapter_position + gst_adapter_available (self->adapter)
                / GST_AUDIO_INFO_BPF (&self->info)) /
            self->setup->sample_rate, self->next_ping, (double)
            sonar_setup_ping_start (self->setup, self->next_ping) /
            self->setup->sample_rate), (NULL));
  gst_adapter_clear (self->adapter);
  self->position_known = FALSE;
  if (!drain) {
    self->reached_ping = FALSE;
    self->warned_non_finite = self->warned_overflow = FALSE;
    self->warned_clipped = self->warned_glitches = FALSE;
    self->warned_loud = FALSE;
    self->told_direct_path = FALSE;
    self->stream_start_pts = GST_CLOCK_TIME_NONE;
  }
}

static void
gst_doppler_bank_set_property (GObject * object, guint prop_id,
    const GValue * value, GParamSpec * pspec)
{
  GstDopplerBank *self = GST_DOPPLER_BANK (object);

  if (!gst_sonar_property_settable (GST_ELEMENT (object), pspec))
    return;

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
    case PROP_SENSOR_FILE:
      g_free (self->sensor_file);
      self->sensor_file = g_value_dup_string (value);
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
    case PROP_THREADS:
      self->threads = g_value_get_uint (value);
      break;
    case PROP_MAX_MEMORY:
      self->max_memory = g_value_get_uint64 (value);
      break;
    case PROP_DIRECT_PATH:
      self->direct_path_mode = g_value_get_enum (value);
      break;
    case PROP_DIRECT_PATH_TAPS:
      self->direct_path_taps = g_value_get_uint (value);
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
    case PROP_SENSOR_FILE:
      g_value_set_string (value, self->sensor_file);
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
    case PROP_THREADS:
      g_value_set_uint (value, self->threads);
      break;
    case PROP_MAX_MEMORY:
      g_value_set_uint64 (value, self->max_memory);
      break;
    case PROP_DIRECT_PATH:
      g_value_set_enum (value, self->direct_path_mode);
      break;
    case PROP_DIRECT_PATH_TAPS:
      g_value_set_uint (value, self->direct_path_taps);
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
  g_free (self->sensor_file);
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
  self->direct_path_mode = DEFAULT_DIRECT_PATH;
  self->direct_path_taps = 0;
  self->adapter = gst_adapter_new ();
  self->stream_start_pts = GST_CLOCK_TIME_NONE;
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

  g_object_class_install_property (gobject_class, PROP_SENSOR_FILE,
      g_param_spec_string ("sensor-file", "Sensor file", "For recordings: "
          "the sensor description (docs/FORMATS.md: array, emissions, "
          "sample rate, speed of sound, ping timing, field of view). When "
          "set, the set-up comes from it instead of upstream", NULL, flags));
  g_object_class_install_property (gobject_class, PROP_GEOMETRY_FILE,
      g_param_spec_string ("geometry-file", "Geometry file", "Older form "
          "of sensor-file, with waveforms-file and ping-length: JSON array "
          "geometry (docs/FORMATS.md); default the built-in eRTIS array",
          NULL, flags));
  g_object_class_install_property (gobject_class, PROP_WAVEFORMS_FILE,
      g_param_spec_string ("waveforms-file", "Waveforms file", "Older form "
          "of sensor-file: JSON emission waveforms (docs/FORMATS.md); pings "
          "back to back from the first sample, in the horizontal fan", NULL,
          flags));
  g_object_class_install_property (gobject_class, PROP_PING_LENGTH,
      g_param_spec_uint ("ping-length", "Ping length", "With "
          "waveforms-file: samples per channel of one ping (sonarsrc's at "
          "its defaults: 17262)", 0, SONAR_MAX_PING_LENGTH, 0, flags));
  g_object_class_install_property (gobject_class, PROP_SPEED_OF_SOUND,
      g_param_spec_double ("speed-of-sound", "Speed of sound", "With "
          "waveforms-file: speed of sound, in m/s (a sensor file gives its "
          "own)", 100.0, 2000.0, SONAR_DEFAULT_SPEED_OF_SOUND, flags));
  g_object_class_install_property (gobject_class, PROP_THREADS,
      g_param_spec_uint ("threads", "Threads", "Workers sharing the "
          "microphones' transforms of a ping (0: one per processor); the "
          "spectra do not depend on it", 0, SONAR_MAX_WORKERS, 0, flags));
  g_object_class_install_property (gobject_class, PROP_MAX_MEMORY,
      sonar_memory_param_spec (flags));
  g_object_class_install_property (gobject_class, PROP_DIRECT_PATH,
      g_param_spec_enum ("direct-path", "Direct path", "A real sensor's "
          "microphones hear its emitters directly, far louder than any echo: "
          "after the matched filters an echo at range 0 whose sidelobes and "
          "tails cover the image. Per microphone, each emitter's waveform "
          "through a filter of direct-path-taps taps at its path's delay "
          "(from the geometry) is fitted by least squares and subtracted "
          "before the spectra; auto "
          "does so where the fit holds a fifth or more of what the "
          "microphone records over the direct path's samples (an info "
          "message says so once a stream), so a recording without one is "
          "left bit for bit as it was",
          GST_TYPE_SONAR_DIRECT_PATH_MODE, DEFAULT_DIRECT_PATH, flags));
  gst_type_mark_as_plugin_api (GST_TYPE_SONAR_DIRECT_PATH_MODE, 0);
  g_object_class_install_property (gobject_class, PROP_DIRECT_PATH_TAPS,
      g_param_spec_uint ("direct-path-taps", "Direct-path taps", "Taps of "
          "each path's filter in the direct path's fit, 2 before its delay "
          "and the rest after (0: the sensor's, 7 for the built-in one, more "
          "as the band reaches towards Nyquist: 28 for 80 kHz at 192 kHz, "
          "where 7 fits a delay between samples poorly); a transducer that "
          "rings (a resonance the "
          "waveforms lack) needs more (a resonance of Q 1.5-3: 58 of 72 "
          "foreign objects found at 7, 66 at 41, 68 without a direct path); "
          "each tap costs 8 dot products of a waveform per microphone and "
          "ping when a direct path is there, and its fit (taps x emitters)^2 "
          "doubles per microphone", 0, SONAR_DIRECT_PATH_MAX_TAPS, 0,
          flags));

  gst_element_class_add_static_pad_template (element_class, &sink_template);
  gst_element_class_add_static_pad_template (element_class, &src_template);
  gst_element_class_set_static_metadata (element_class,
      "Doppler matched-filter bank", "Filter/Analyzer/Sonar",
      "Builds the Doppler-scaled templates of every emission once and takes "
      "each ping's microphone recordings onto their band",
      "gst-sonar-velocity developers");

  filter_class->bank_role = GST_SONAR_FILTER_MAKES_BANK;
  filter_class->frames_pings = TRUE;
  filter_class->make_setup = GST_DEBUG_FUNCPTR (gst_doppler_bank_make_setup);
  filter_class->configure = GST_DEBUG_FUNCPTR (gst_doppler_bank_configure);
  filter_class->unconfigure = GST_DEBUG_FUNCPTR (gst_doppler_bank_unconfigure);
  filter_class->process = GST_DEBUG_FUNCPTR (gst_doppler_bank_process);
  filter_class->reset = GST_DEBUG_FUNCPTR (gst_doppler_bank_reset);
  filter_class->output_time = GST_DEBUG_FUNCPTR
      (gst_doppler_bank_output_time);
  filter_class->input_time = GST_DEBUG_FUNCPTR (gst_doppler_bank_input_time);
}
