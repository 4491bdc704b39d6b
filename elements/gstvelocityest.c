/* gstvelocityest.c: velocityest, the radial velocity of every reflector
 * (paper Section III.B, eq. 15, Fig. 4f-g).
 *
 * For each centroid from wardcluster it evaluates every emitter's
 * single-emitter image at every velocity of the Doppler bank in a small
 * window around the centroid (spanning its member peaks' ranges),
 * multiplies the N Doppler-ACF curves and takes the product's peak,
 * refined below the bank's step (sonar-velocity.h). Centroids whose curves
 * are not peaked (sidelobes, cross-talk ghosts) are dropped
 * (keep-rejected=true keeps them, marked "valid": false). Two separate
 * peaks in one centroid (objects a few centimetres apart in range, of
 * different speeds) give two detections. In a crowd, the centroids that
 * fail though they stand out of the pooled interference are estimated
 * again with the accepted echoes' models cancelled, in rounds
 * (sonar-velocity.h). Then (residual-search) the ping less every accepted
 * echo is imaged, clustered and estimated again: echoes under a stronger
 * one's cross-talk, which made no centroid (sonar-residual.h).
 *
 * The centroids are shared out between `threads` workers
 * (SonarVelocityPool); the output does not depend on their number.
 *
 * Each detection also carries the echo's amplitude and SNR, the 1-sigma
 * uncertainties of its range, direction and radial velocity from the
 * ping's own noise and peaks (sonar-uncertainty.h), and the set-up's
 * frame id.
 *
 * Results, per ping, three ways (docs/CONTRACTS.md): a line of JSON as the
 * output buffer (text/x-raw, utf8: fdsink or filesink write it), a
 * SonarDetectionsMeta on that buffer (appsink), and a "sonar-detections"
 * element message.
 *
 *   gst-launch-1.0 sonarsrc scene=fig10 num-buffers=5 ! dopplerbank \
 *       velocity-min=-0.4 velocity-max=0.4 velocity-step=0.02 ! \
 *       mimobeamform ! wardcluster ! velocityest ! fdsink
 */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstvelocityest.h"

#include <math.h>
#include <string.h>

#include "sonar-memory.h"
#include "sonar-residual.h"
#include "sonar-uncertainty.h"
#include "sonar-velocity.h"

GST_DEBUG_CATEGORY_STATIC (velocity_est_debug);
#define GST_CAT_DEFAULT velocity_est_debug

#define DEFAULT_KEEP_REJECTED FALSE
#define DEFAULT_THREADS 0
#define MAX_THREADS SONAR_VELOCITY_MAX_THREADS
#define DEFAULT_POST_MESSAGES TRUE
#define DEFAULT_RESIDUAL_SEARCH TRUE

enum
{
  PROP_0,
  PROP_WINDOW_DIRECTIONS,
  PROP_WINDOW_RANGES,
  PROP_REFINE,
  PROP_MIN_VARIANCE,
  PROP_MIN_AGREEING_EMITTERS,
  PROP_MIN_COHERENCE,
  PROP_COHERENCE_PFA,
  PROP_POOLED_SNR,
  PROP_SECOND_PEAK,
  PROP_EMITTERS,
  PROP_KEEP_REJECTED,
  PROP_THREADS,
  PROP_POST_MESSAGES,
  PROP_RESIDUAL_SEARCH,
  PROP_MAX_MEMORY,
};

struct _GstVelocityEst
{
  GstSonarFilter parent;

  /* Properties, protected by the object lock. */
  SonarVelocityParams params;
  /* Set by the application: more than the emitters is then an error; the
   * default is lowered to their number on a sensor with fewer. */
  gboolean min_agreeing_set;
  /* The streaming thread's: min-agreeing-emitters as the pool has it (a
   * refused change goes back to it). */
  guint min_agreeing_in_effect;
  gboolean min_agreeing_set_in_effect;
  gboolean keep_rejected;
  gboolean post_messages;
  gboolean residual_search;
  guint64 max_memory;
  gboolean retune;              /* thresholds changed while playing: at
                                 * the next ping (object lock) */

  guint threads;

  /* Configured state. */
  SonarVelocityPool *pool;
  SonarResidualSearch *residual;        /* NULL: residual-search=false */
  SonarNoiseMeter *noise;       /* the image's noise, for the sigmas */
  SonarImageGrid grid;
  guint hypotheses;             /* Doppler hypotheses each pixel is the maximum of */
  guint n_emitters;
  double emission_centre;       /* s after the trigger */
  GArray *detections;           /* SonarDetection, reused every ping */
  SonarVelocityEstimate *results;       /* 2 per centroid, reused */
  guint *counts;                /* estimates per centroid */
  guint capacity;               /* centroids results and counts can hold */
  double coherence_threshold;   /* the coherence test's, as configured */
  gboolean warned_incoherent;   /* check_strongest ()'s warning, once */
};

G_DEFINE_TYPE (GstVelocityEst, gst_velocity_est, GST_TYPE_SONAR_FILTER);
GST_ELEMENT_REGISTER_DEFINE_WITH_CODE (velocityest, "velocityest",
    GST_RANK_NONE, GST_TYPE_VELOCITY_EST,
    GST_DEBUG_CATEGORY_INIT (velocity_est_debug, "velocityest", 0,
        "radial velocity estimation"));

static GstStaticPadTemplate sink_template = GST_STATIC_PAD_TEMPLATE ("sink",
    GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS (SONAR_ENERGYSCAPE_CAPS));
static GstStaticPadTemplate src_template = GST_STATIC_PAD_TEMPLATE ("src",
    GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS (SONAR_DETECTIONS_CAPS));

static GstCaps *
gst_velocity_est_configure (GstSonarFilter * filter, GstCaps * in_caps,
    GError ** error)
{
  GstVelocityEst *self = GST_VELOCITY_EST (filter);
  SonarSetup *setup = gst_sonar_filter_get_setup (filter);
  const SonarBand *band = gst_sonar_filter_get_band (filter);
  SonarVelocityParams params;
  gboolean min_agreeing_set, residual_search;
  guint64 max_memory;
  guint records, threads;

  if (!in_caps || !sonar_energyscape_caps_parse (in_caps, &self->grid,
          &records, &self->hypotheses) || records != 1) {
    g_set_error (error, GST_CORE_ERROR, GST_CORE_ERROR_NEGOTIATION,
        "velocityest: it needs one energyscape per ping with centroids "
        "(mimobeamform ! wardcluster ! velocityest)");
    return NULL;
  }
  GST_OBJECT_LOCK (self);
  params = self->params;
  min_agreeing_set = self->min_agreeing_set;
  threads = self->threads;
  residual_search = self->residual_search;
  max_memory = self->max_memory;
  GST_OBJECT_UNLOCK (self);
  if (residual_search && !sonar_memory_check (sonar_residual_search_memory
          (setup, band, &self->grid), max_memory, error, "velocityest: the "
          "residual search (residual-search) on an image of %u azimuths x %u "
          "elevations x %u ranges and %u microphones x %u band bins",
          self->grid.n_azimuth, self->grid.n_elevation, self->grid.n_range,
          setup->geometry.n_microphones, band->n_bins))
    return NULL;
  self->pool = sonar_velocity_pool_new (gst_sonar_filter_get_bank (filter),
      &self->grid, &params, threads, error);
  if (!self->pool)
    return NULL;
  self->min_agreeing_in_effect = params.min_agreeing_emitters;
  self->min_agreeing_set_in_effect = min_agreeing_set;
  self->noise = sonar_noise_meter_new (&self->grid, self->hypotheses);
  self->warned_incoherent = FALSE;
  /* Confidence is the share of the emitters that enter the product. */
  self->n_emitters = params.emitters ? params.emitters :
      setup->geometry.n_emitters;
  self->emission_centre = sonar_setup_emission_centre (setup);
  self->coherence_threshold =
      sonar_velocity_params_coherence_threshold (&params, self->n_emitters);
  /* One emitter leaves the product nothing to compare: the coherence and
   * agreement tests pass every centroid, the array's sidelobes too (a
   * one-emitter recording of two objects: hundreds of detections). */
  if (self->n_emitters < 2)
    GST_ELEMENT_WARNING (self, LIBRARY, SETTINGS, ("velocityest: one "
            "emitter enters the Doppler-ACF product (%s): the tests that "
            "compare the emitters (coherence, agreement) cannot tell an "
            "echo from a sidelobe or a ghost, and every centroid may be "
            "reported; use two emitters or more", params.emitters ?
            "emitters=1" : "the set-up has one"), (NULL));
  if (min_agreeing_set && params.min_agreeing_emitters > self->n_emitters) {
    g_set_error (error, GST_CORE_ERROR, GST_CORE_ERROR_NEGOTIATION,
        "velocityest: min-agreeing-emitters is %u, but only %u emitters "
        "enter the product (emitters=%u%s)", params.min_agreeing_emitters,
        self->n_emitters, params.emitters,
        params.emitters ? "" : ": all of the set-up's");
    g_clear_pointer (&self->pool, sonar_velocity_pool_free);
    g_clear_pointer (&self->noise, sonar_noise_meter_free);
    return NULL;
  }
  if (residual_search) {
    /* An energyscape whose grid the search cannot image again loses the
     * search, not the stream. */
    g_autoptr (GError) why = NULL;
    self->residual = sonar_residual_search_new (setup, band,
        gst_sonar_filter_get_bank (filter), &self->grid, self->n_emitters,
        &why);
    if (!self->residual)
      GST_ELEMENT_WARNING (self, LIBRARY, SETTINGS, ("velocityest: %s: "
              "residual-search is off for this stream", why->message),
          (NULL));
  }
  return gst_caps_from_string (SONAR_DETECTIONS_CAPS);
}

static void
gst_velocity_est_unconfigure (GstSonarFilter * filter)
{
  GstVelocityEst *self = GST_VELOCITY_EST (filter);

  g_clear_pointer (&self->pool, sonar_velocity_pool_free);
  g_clear_pointer (&self->residual, sonar_residual_search_free);
  g_clear_pointer (&self->noise, sonar_noise_meter_free);
}

/* Thresholds set while playing take effect at the next ping
 * (sonar_velocity_pool_retune ()). */
static void
retune (GstVelocityEst * self)
{
  SonarVelocityParams params;
  gboolean min_agreeing_set;
  GError *error = NULL;

  GST_OBJECT_LOCK (self);
  params = self->params;
  min_agreeing_set = self->min_agreeing_set;
  if (!self->retune) {
    GST_OBJECT_UNLOCK (self);
    return;
  }
  self->retune = FALSE;
  GST_OBJECT_UNLOCK (self);
  if (min_agreeing_set && params.min_agreeing_emitters > self->n_emitters) {
    /* Refused alone: the property goes back to the value in effect (unless
     * set again meanwhile), the other thresholds take effect. */
    const guint refused = params.min_agreeing_emitters;
    GST_ELEMENT_WARNING (self, LIBRARY, SETTINGS, ("velocityest: "
            "min-agreeing-emitters is %u, but only %u emitters enter the "
            "product: it stays %u", refused, self->n_emitters,
            MIN (self->min_agreeing_in_effect, self->n_emitters)), (NULL));
    params.min_agreeing_emitters = self->min_agreeing_in_effect;
    min_agreeing_set = self->min_agreeing_set_in_effect;
    GST_OBJECT_LOCK (self);
    if (self->params.min_agreeing_emitters == refused) {
      self->params.min_agreeing_emitters = params.min_agreeing_emitters;
      self->min_agreeing_set = min_agreeing_set;
    }
    GST_OBJECT_UNLOCK (self);
    g_object_notify (G_OBJECT (self), "min-agreeing-emitters");
  }
  if (!sonar_velocity_pool_retune (self->pool, &params, &error)) {
    /* The properties' ranges keep the values valid: this would be a bug. */
    GST_ELEMENT_WARNING (self, LIBRARY, SETTINGS, ("%s", error->message),
        (NULL));
    g_error_free (error);
    return;
  }
  self->min_agreeing_in_effect = params.min_agreeing_emitters;
  self->min_agreeing_set_in_effect = min_agreeing_set;
  self->coherence_threshold =
      sonar_velocity_params_coherence_threshold (&params, self->n_emitters);
}

/* @image: the ping's energyscape (its pixels); @noise_power: its noise
 * (sonar-uncertainty.h), read once per ping. */
static void
add_detection (GstVelocityEst * self, const SonarCentroid * centroid,
    guint index, const SonarVelocityEstimate * e, GstClockTime ping_time,
    const float *image, double noise_power)
{
  const SonarSetup *setup = gst_sonar_filter_get_setup (GST_SONAR_FILTER
      (self));
  const double c = setup->speed_of_sound;
  SonarDetection d;
  SonarUncertainty u;
  double delay;

  /* Position and velocity at one instant: the velocity's. */
  d.centroid = index;
  d.range = sonar_velocity_centre_range (e->echo_range, e->radial_velocity,
      c, self->emission_centre, &delay);
  d.azimuth = e->echo_azimuth;
  d.elevation = e->echo_elevation;
  d.position = sonar_vec3_scale (sonar_vec3_from_direction (d.azimuth,
          d.elevation), d.range);
  d.instant = GST_CLOCK_TIME_IS_VALID (ping_time) ?
      (double) ping_time / GST_SECOND + delay : NAN;
  d.radial_velocity = e->radial_velocity;
  d.approaching = sonar_velocity_approaching (e->radial_velocity);
  d.confidence = (double) e->agreeing_emitters / self->n_emitters;
  d.out_of_range = e->at_bank_edge;
  d.valid = e->valid;
  d.peak_db = e->peak_db;
  d.variance = e->variance;
  {
    /* An echo velocityest found away from the centroid's strongest member
     * (a blend of two echoes, sonar-velocity.c) is measured at its own
     * direction's pixel. */
    const SonarImageGrid *g = &self->grid;
    SonarCentroid own = *centroid;
    const double step = fabs (g->azimuth_step);
    if (step > 0.0 && fabs (e->azimuth - (g->azimuth_first +
                centroid->peak_azimuth_index * g->azimuth_step)) > 1.5 * step)
      own.peak_azimuth_index = (guint) CLAMP (lround ((e->azimuth -
                  g->azimuth_first) / g->azimuth_step), 0,
          (long) g->n_azimuth - 1);
    sonar_uncertainty_measure (image, &self->grid, noise_power, &own, e,
        self->n_emitters, &u);
  }
  d.amplitude = u.amplitude_db;
  d.snr = u.snr_db;
  /* The range is moved on to the instant at the estimated velocity
   * (over delay - range / c): its error adds to the range's. */
  d.range_sigma = isfinite (u.radial_velocity_sigma) ? hypot (u.range_sigma,
      (delay - e->range / c) * u.radial_velocity_sigma) : u.range_sigma;
  d.azimuth_sigma = u.azimuth_sigma;
  d.elevation_sigma = u.elevation_sigma;
  d.radial_velocity_sigma = u.radial_velocity_sigma;
  if (d.out_of_range) {
    /* The velocity is the bank's edge, a bound: its error, and the range's
     * moved on at it, are unknown (they read 0.0005 m/s and 1240 m/s, 5 m,
     * off by 0.2 m/s). */
    d.radial_velocity_sigma = NAN;
    d.range_sigma = NAN;
  }
  g_strlcpy (d.frame_id, setup->frame_id, sizeof d.frame_id);
  g_array_append_val (self->detections, d);
}

/* dB over the image's noise from which a ping's strongest centroid is an
 * echo that passes the coherence test: alone an echo scores 0.95 and
 * more, 16 dB over its interference 0.8 (sonar-velocity.h); the
 * strongest of a ping has no stronger one's cross-talk on it. */
#define COHERENT_SNR_DB 25.0
/* The coherence factor an echo that strong reaches alone, at least (the
 * property's blurb): a threshold set above it rejects echoes by the
 * user's choice, which check_strongest () does not blame on the set-up. */
#define COHERENT_ECHO 0.9

/* Warns, once a stream, when the strongest centroid of a ping, at least
 * COHERENT_SNR_DB over the noise (*@noise_power, measured here if it is
 * not yet, -1), fails the emitters' coherence test: its emitters do not
 * add up as the set-up's emissions say. Each emitter radiating through
 * its own resonance (foreign_sim.py emitter_resonance, 35-60 kHz, Q 2-6)
 * left every echo of a scene rejected, none reported. */
static void
check_strongest (GstVelocityEst * self, const SonarCentroid * strongest,
    const SonarVelocityEstimate * e, const float *image, double *noise_power,
    guint64 ping)
{
  const SonarImageGrid *g = &self->grid;
  double peak, snr_db;

  if (self->warned_incoherent || e->valid || !(e->coherence <
          MIN (self->coherence_threshold, COHERENT_ECHO)))
    return;
  peak = image[((gsize) MIN (strongest->peak_elevation_index,
              g->n_elevation - 1) * g->n_azimuth +
          MIN (strongest->peak_azimuth_index, g->n_azimuth - 1)) *
      g->n_range + MIN (strongest->peak_range_index, g->n_range - 1)];
  if (*noise_power < 0.0)
    *noise_power = sonar_noise_meter_power (self->noise, image);
  snr_db = 10.0 * log10 (peak * peak / *noise_power);
  if (!(snr_db >= COHERENT_SNR_DB))
    return;
  self->warned_incoherent = TRUE;
  GST_ELEMENT_WARNING (self, STREAM, FAILED, ("velocityest: ping %"
          G_GUINT64_FORMAT "'s strongest echo (%.0f dB over the noise, at "
          "%.2f m, azimuth %.1f, elevation %.1f degrees) fails the "
          "emitters' coherence test (%.2f, %.2f passes): its emitters do "
          "not add up as the set-up describes them, and echoes like it are "
          "not reported. The emissions, emitter-delays or emitter positions "
          "of the sensor file may not be what the sensor radiates (each "
          "emitter's own resonance, a trigger delay)", ping, snr_db,
          strongest->range, e->azimuth, e->elevation, e->coherence,
          self->coherence_threshold), (NULL));
}

/* The detections of @n centroids' estimates (@results, 2 per centroid,
 * @counts each), the centroids numbered from @first; *@noise_power is
 * measured on the first (-1 until then). */
static void
add_detections (GstVelocityEst * self, const SonarCentroid * centroids,
    guint first, guint n, const SonarVelocityEstimate * results,
    const guint * counts, gboolean keep_rejected, GstClockTime ping_time,
    const float *image, double *noise_power)
{
  for (guint k = 0; k < n; k++)
    for (guint i = 0; i < counts[k]; i++) {
      if (!results[2 * k + i].valid && !keep_rejected)
        continue;
      /* Once per ping, and only with something to report. */
      if (*noise_power < 0.0)
        *noise_power = sonar_noise_meter_power (self->noise, image);
      add_detection (self, &centroids[k], first + k, &results[2 * k + i],
          ping_time, image, *noise_power);
    }
}

/* Removes @buffer's spectra meta, if any. */
static void
release_spectra (GstBuffer * buffer)
{
  SonarSpectraMeta *meta = sonar_buffer_get_spectra_meta (buffer);

  if (meta)
    gst_buffer_remove_meta (buffer, (GstMeta *) meta);
}

static GstFlowReturn
gst_velocity_est_process (GstSonarFilter * filter, GstBuffer * buffer)
{
  GstVelocityEst *self = GST_VELOCITY_EST (filter);
  SonarCentroidsMeta *centroids = sonar_buffer_get_centroids_meta (buffer);
  SonarSpectraMeta *spectra = sonar_buffer_get_spectra_meta (buffer);
  const SonarBand *band = gst_sonar_filter_get_band (filter);
  GstBuffer *out;
  GstMapInfo map, image_map;
  const float *image;
  gboolean mapped;
  double noise_power;
  char *json;
  guint64 ping;
  gboolean keep_rejected;

  if (!centroids || !spectra || !sonar_band_equal (&spectra->band, band)) {
    GST_ELEMENT_ERROR (self, STREAM, FORMAT, ("An energyscape without "
            "centroids or spectra: velocityest needs mimobeamform ! "
            "wardcluster before it"), (NULL));
    gst_buffer_unref (buffer);
    return GST_FLOW_ERROR;
  }
  ping = centroids->ping_index;
  retune (self);
  GST_OBJECT_LOCK (self);
  keep_rejected = self->keep_rejected;
  GST_OBJECT_UNLOCK (self);
  g_array_set_size (self->detections, 0);
  if (centroids->n_centroids > self->capacity) {
    self->capacity = centroids->n_centroids;
    self->results = g_renew (SonarVelocityEstimate, self->results,
        2 * self->capacity);
    self->counts = g_renew (guint, self->counts, self->capacity);
  }
  gst_buffer_map (spectra->spectra, &map, GST_MAP_READ);
  sonar_velocity_pool_estimate (self->pool, (const SonarComplex *) map.data,
      centroids->centroids, centroids->n_centroids, self->results,
      self->counts);
  gst_buffer_unmap (spectra->spectra, &map);
  mapped = gst_buffer_map (buffer, &image_map, GST_MAP_READ);
  if (mapped && image_map.size < sizeof (SonarEnergyscapeHeader) +
      sizeof (float) * sonar_image_grid_size (&self->grid)) {
    gst_buffer_unmap (buffer, &image_map);
    mapped = FALSE;
  }
  if (!mapped) {
    GST_ELEMENT_ERROR (self, STREAM, FORMAT, ("An energyscape smaller than "
            "its caps say"), (NULL));
    gst_buffer_unref (buffer);
    return GST_FLOW_ERROR;
  }
  image = (const float *) (image_map.data + sizeof (SonarEnergyscapeHeader));
  noise_power = -1.0;
  /* Centroids are numbered strongest first (sonar-cluster.h). */
  if (centroids->n_centroids > 0 && self->counts[0] > 0)
    check_strongest (self, &centroids->centroids[0], &self->results[0],
        image, &noise_power, ping);
  add_detections (self, centroids->centroids, 0, centroids->n_centroids,
      self->results, self->counts, keep_rejected, GST_BUFFER_PTS (buffer),
      image, &noise_power);
  if (self->residual) {
    const SonarCentroid *found;
    const SonarVelocityEstimate *results;
    const guint *counts;
    /* Its spectra meta still holds the ping: the residual is the pool's
     * copy of them less the accepted echoes. */
    const guint n = sonar_residual_search_process (self->residual,
        self->pool, centroids->n_centroids, self->results, self->counts,
        &found, &results, &counts);
    /* Its valid ones alone: what fails there is mostly what the
     * cancellations left, not a centroid of the ping's. */
    add_detections (self, found, centroids->n_centroids, n, results, counts,
        FALSE, GST_BUFFER_PTS (buffer), image, &noise_power);
  }
  gst_buffer_unmap (buffer, &image_map);

  json = sonar_detections_to_json (ping, GST_BUFFER_PTS (buffer),
      gst_sonar_filter_get_setup (GST_SONAR_FILTER (self))->frame_id,
      (SonarDetection *) self->detections->data, self->detections->len);
  out = gst_buffer_new_wrapped (json, strlen (json));
  gst_buffer_copy_into (out, buffer, GST_BUFFER_COPY_TIMESTAMPS |
      GST_BUFFER_COPY_META, 0, -1);
  /* The results let go of the ping's spectra (a reference to its largest
   * buffer, 0.7 MB at the defaults), which only this stage reads: a
   * queue of JSON lines holds kilobytes, not pings. */
  release_spectra (out);
  sonar_buffer_add_detections_meta (out, ping,
      (SonarDetection *) self->detections->data, self->detections->len);
  if (self->post_messages)
    gst_sonar_post_ping_message (GST_ELEMENT (self),
        gst_sonar_filter_get_segment (GST_SONAR_FILTER (self)),
        GST_BUFFER_PTS (buffer), sonar_detections_to_structure (ping,
            GST_BUFFER_PTS (buffer),
            gst_sonar_filter_get_setup (GST_SONAR_FILTER (self))->frame_id,
            (SonarDetection *) self->detections->data,
            self->detections->len));
  gst_buffer_unref (buffer);
  return gst_sonar_filter_push (filter, out);
}

static void
gst_velocity_est_set_property (GObject * object, guint prop_id,
    const GValue * value, GParamSpec * pspec)
{
  GstVelocityEst *self = GST_VELOCITY_EST (object);
  SonarVelocityParams *p = &self->params;

  if (!gst_sonar_property_settable (GST_ELEMENT (object), pspec))
    return;

  GST_OBJECT_LOCK (self);
  switch (prop_id) {
    case PROP_WINDOW_DIRECTIONS:
      p->window_directions = g_value_get_uint (value);
      break;
    case PROP_WINDOW_RANGES:
      p->window_ranges = g_value_get_uint (value);
      break;
    case PROP_REFINE:
      p->refine = g_value_get_boolean (value);
      break;
    case PROP_MIN_VARIANCE:
      p->min_variance = g_value_get_double (value);
      break;
    case PROP_MIN_AGREEING_EMITTERS:
      p->min_agreeing_emitters = g_value_get_uint (value);
      self->min_agreeing_set = TRUE;
      break;
    case PROP_MIN_COHERENCE:
      p->min_coherence = g_value_get_double (value);
      break;
    case PROP_COHERENCE_PFA:
      p->coherence_pfa = g_value_get_double (value);
      break;
    case PROP_POOLED_SNR:
      p->pooled_snr_db = g_value_get_double (value);
      break;
    case PROP_SECOND_PEAK:
      p->second_peak_db = g_value_get_double (value);
      break;
    case PROP_EMITTERS:
      p->emitters = g_value_get_uint (value);
      break;
    case PROP_KEEP_REJECTED:
      self->keep_rejected = g_value_get_boolean (value);
      break;
    case PROP_THREADS:
      self->threads = g_value_get_uint (value);
      break;
    case PROP_POST_MESSAGES:
      self->post_messages = g_value_get_boolean (value);
      break;
    case PROP_RESIDUAL_SEARCH:
      self->residual_search = g_value_get_boolean (value);
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
gst_velocity_est_get_property (GObject * object, guint prop_id,
    GValue * value, GParamSpec * pspec)
{
  GstVelocityEst *self = GST_VELOCITY_EST (object);
  const SonarVelocityParams *p = &self->params;

  GST_OBJECT_LOCK (self);
  switch (prop_id) {
    case PROP_WINDOW_DIRECTIONS:
      g_value_set_uint (value, p->window_directions);
      break;
    case PROP_WINDOW_RANGES:
      g_value_set_uint (value, p->window_ranges);
      break;
    case PROP_REFINE:
      g_value_set_boolean (value, p->refine);
      break;
    case PROP_MIN_VARIANCE:
      g_value_set_double (value, p->min_variance);
      break;
    case PROP_MIN_AGREEING_EMITTERS:
      g_value_set_uint (value, p->min_agreeing_emitters);
      break;
    case PROP_MIN_COHERENCE:
      g_value_set_double (value, p->min_coherence);
      break;
    case PROP_COHERENCE_PFA:
      g_value_set_double (value, p->coherence_pfa);
      break;
    case PROP_POOLED_SNR:
      g_value_set_double (value, p->pooled_snr_db);
      break;
    case PROP_SECOND_PEAK:
      g_value_set_double (value, p->second_peak_db);
      break;
    case PROP_EMITTERS:
      g_value_set_uint (value, p->emitters);
      break;
    case PROP_KEEP_REJECTED:
      g_value_set_boolean (value, self->keep_rejected);
      break;
    case PROP_THREADS:
      g_value_set_uint (value, self->threads);
      break;
    case PROP_POST_MESSAGES:
      g_value_set_boolean (value, self->post_messages);
      break;
    case PROP_RESIDUAL_SEARCH:
      g_value_set_boolean (value, self->residual_search);
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
gst_velocity_est_finalize (GObject * object)
{
  GstVelocityEst *self = GST_VELOCITY_EST (object);

  g_array_unref (self->detections);
  g_free (self->results);
  g_free (self->counts);
  G_OBJECT_CLASS (gst_velocity_est_parent_class)->finalize (object);
}

static void
gst_velocity_est_init (GstVelocityEst * self)
{
  sonar_velocity_params_init_default (&self->params);
  self->keep_rejected = DEFAULT_KEEP_REJECTED;
  self->post_messages = DEFAULT_POST_MESSAGES;
  self->threads = DEFAULT_THREADS;
  self->residual_search = DEFAULT_RESIDUAL_SEARCH;
  self->max_memory = SONAR_DEFAULT_MAX_MEMORY;
  self->detections = g_array_new (FALSE, FALSE, sizeof (SonarDetection));
}

static void
gst_velocity_est_class_init (GstVelocityEstClass * klass)
{
  GObjectClass *gobject_class = G_OBJECT_CLASS (klass);
  GstElementClass *element_class = GST_ELEMENT_CLASS (klass);
  GstSonarFilterClass *filter_class = GST_SONAR_FILTER_CLASS (klass);
  const GParamFlags flags = G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS
      | GST_PARAM_MUTABLE_READY;
  /* What sonar_velocity_pool_retune () takes, and keep-rejected: changed
   * while playing, it holds from the next ping on. */
  const GParamFlags tunable = G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS
      | GST_PARAM_MUTABLE_PLAYING;
  SonarVelocityParams d;

  sonar_velocity_params_init_default (&d);
  gobject_class->set_property = gst_velocity_est_set_property;
  gobject_class->get_property = gst_velocity_est_get_property;
  gobject_class->finalize = gst_velocity_est_finalize;

  g_object_class_install_property (gobject_class, PROP_WINDOW_DIRECTIONS,
      g_param_spec_uint ("window-directions", "Window directions", "Half "
          "width of the Doppler-ACF window (eq. 15) in image direction steps "
          "(0: the centroid's direction only; 1: 3 directions, 3x the "
          "work)", 0, 32, d.window_directions, flags));
  g_object_class_install_property (gobject_class, PROP_WINDOW_RANGES,
      g_param_spec_uint ("window-ranges", "Window ranges", "Half width of "
          "the Doppler-ACF window in image range steps, beyond the ranges "
          "the centroid's member peaks span (1: 3 ranges around a single "
          "peak, each refined on a 4x finer grid)", 0,
          256, d.window_ranges, flags));
  g_object_class_install_property (gobject_class, PROP_REFINE,
      g_param_spec_boolean ("refine", "Refine", "Refine the peak below the "
          "bank's step with a parabola through the log product", d.refine,
          flags));
  g_object_class_install_property (gobject_class, PROP_MIN_VARIANCE,
      g_param_spec_double ("min-variance", "Minimum variance", "The paper's "
          "false-positive test: a centroid whose normalised Doppler-ACF "
          "product varies less than this is not a reflector", 0.0, 1.0,
          d.min_variance, tunable));
  g_object_class_install_property (gobject_class, PROP_MIN_AGREEING_EMITTERS,
      g_param_spec_uint ("min-agreeing-emitters", "Minimum agreeing "
          "emitters", "A reflector needs at least this many emitters whose "
          "own Doppler-ACF curve comes within 3 dB of its maximum within half "
          "a Doppler main lobe of the product's peak; set above the emitters "
          "entering the product, an error at start (the default is lowered "
          "to their number; set so while playing, a warning, and it "
          "goes back to the value in effect)", 0, 64, d.min_agreeing_emitters, tunable));
  g_object_class_install_property (gobject_class, PROP_MIN_COHERENCE,
      g_param_spec_double ("min-coherence", "Minimum coherence", "A fixed "
          "floor under coherence-pfa's threshold on the coherence factor "
          "|sum|^2 / (N sum of powers) of a reflector's emitters at its "
          "velocity (0: coherence-pfa's alone)", 0.0, 1.0,
          d.min_coherence, tunable));
  g_object_class_install_property (gobject_class, PROP_COHERENCE_PFA,
      g_param_spec_double ("coherence-pfa", "Coherence false-alarm rate",
          "A reflector's emitters add up coherently at its velocity: its "
          "coherence factor |sum|^2 / (N sum of powers), the power its N "
          "emitters share against the interference left at the pixel, is "
          "at least what interference independent across the emitters "
          "reaches with this probability, 1 - pfa^(1/(N-1)) (1.3e-5: 0.80 "
          "over 8 emitters; an echo 16 dB above its interference passes 8 "
          "times in 10, an isolated one scores above 0.9, cross-talk ridges "
          "0.4-0.8; see pooled-snr for crowds)", 1e-15, 1.0,
          d.coherence_pfa, tunable));
  g_object_class_install_property (gobject_class, PROP_POOLED_SNR,
      g_param_spec_double ("pooled-snr", "Pooled SNR", "dB (0: off). A "
          "reflector whose coherence factor falls short of coherence-pfa's "
          "threshold still passes when the power its emitters share stands "
          "this far above the interference pooled over the window's pixels "
          "and detection hypotheses (the power the emitters do not share "
          "there), and the interference at its own pixel is at most twice "
          "that: in a crowd the others' cross-talk lowers a real echo's "
          "coherence factor (13 dB above it: 0.75 on average), which the "
          "pixel alone measures with 7 degrees of freedom, the pool with "
          "21 or more; min-coherence still holds. Real echoes of a crowd "
          "passing this way stand 14.5-17 dB above the pool, cross-talk "
          "ghosts 14.2 at most: the default leaves 1.8 dB over them. A "
          "centroid that fails though its emitters' shared power stands "
          "this far above the pool is estimated again with the accepted "
          "echoes cancelled, in rounds (after the first, those 3 dB less "
          "too), an estimate on the residual kept when its beam falls as "
          "one echo's (0 turns that off too)", 0.0, 100.0,
          d.pooled_snr_db, tunable));
  g_object_class_install_property (gobject_class, PROP_SECOND_PEAK,
      g_param_spec_double ("second-peak", "Second peak", "A second "
          "Doppler-ACF product peak, more than half a Doppler main lobe "
          "away, at most this many dB (per emitter) below the first, is a "
          "second reflector in the centroid when it stands out of the "
          "product's floor (4 interquartile ranges above its median) and "
          "passes the same tests; each then reports its own range",
          0.01, 100.0, d.second_peak_db, tunable));
  g_object_class_install_property (gobject_class, PROP_EMITTERS,
      g_param_spec_uint ("emitters", "Emitters", "Only the first this many "
          "emitters' Doppler-ACF curves enter the product and the "
          "false-positive tests (0: all); fewer is cheaper and less "
          "selective, more than the sensor has is an error at start",
          0, 64, d.emitters, flags));
  g_object_class_install_property (gobject_class, PROP_KEEP_REJECTED,
      g_param_spec_boolean ("keep-rejected", "Keep rejected", "Report the "
          "centroids that fail the false-positive tests too, with "
          "\"valid\": false", DEFAULT_KEEP_REJECTED, tunable));
  g_object_class_install_property (gobject_class, PROP_THREADS,
      g_param_spec_uint ("threads", "Threads", "Workers sharing the "
          "centroids of a ping (0: one per processor); the results do not "
          "depend on it", 0, MAX_THREADS, DEFAULT_THREADS, flags));
  g_object_class_install_property (gobject_class, PROP_POST_MESSAGES,
      g_param_spec_boolean ("post-messages", "Post messages", "Post a "
          "\"sonar-detections\" element message per ping",
          DEFAULT_POST_MESSAGES, flags));
  g_object_class_install_property (gobject_class, PROP_RESIDUAL_SEARCH,
      g_param_spec_boolean ("residual-search", "Residual search", "After a "
          "ping's estimates, cancel every accepted echo from its spectra, "
          "image and cluster what is left as mimobeamform and wardcluster "
          "do at their defaults, and estimate at each new centroid: echoes "
          "10-30 dB weaker within a pulse length (1.5 m) of a stronger one "
          "lie under its cross-talk and make no centroid of their own. A "
          "new estimate within an accepted echo's cell (2 cm, 5 degrees at "
          "broadside, 0.15 m/s) is what its cancellation left and is "
          "dropped, and one counts only when every emitter in the product "
          "agrees. Costs about one more image and clustering per "
          "ping with an echo",
          DEFAULT_RESIDUAL_SEARCH, flags));
  g_object_class_install_property (gobject_class, PROP_MAX_MEMORY,
      sonar_memory_param_spec (flags));

  gst_element_class_add_static_pad_template (element_class, &sink_template);
  gst_element_class_add_static_pad_template (element_class, &src_template);
  gst_element_class_set_static_metadata (element_class,
      "Sonar radial velocity estimator", "Filter/Analyzer/Sonar",
      "Estimates each reflector's radial velocity from the product of its "
      "per-emitter Doppler-ACF curves; outputs one JSON line per ping",
      "gst-sonar-velocity developers");

  filter_class->bank_role = GST_SONAR_FILTER_USES_BANK;
  filter_class->configure = GST_DEBUG_FUNCPTR (gst_velocity_est_configure);
  filter_class->unconfigure = GST_DEBUG_FUNCPTR (gst_velocity_est_unconfigure);
  filter_class->process = GST_DEBUG_FUNCPTR (gst_velocity_est_process);
}
