/* gstsonartrack.c: sonartrack, the sensor's own motion from the still world
 * and tracks with full velocity across pings.
 *
 * Takes velocityest's output (its SonarDetectionsMeta) and, per ping:
 *  - estimates the sensor's velocity relative to the still world from the
 *    detections' directions and radial velocities, robust to movers, or
 *    says it is unobservable (gst/sonar-egomotion.h);
 *  - tracks the detections across pings: identities, position, radial
 *    velocity and the velocity in the world, which the Doppler and the
 *    change in position give together, with covariances; still or moving
 *    (gst/sonar-track.h).
 *
 * Results, per ping, three ways (docs/CONTRACTS.md): a line of JSON as the
 * output buffer, a SonarTracksMeta on it, and a "sonar-tracks" element
 * message. An application may send its own estimate of the sensor's
 * velocity (odometry) as a "sonar-ego-prior" upstream event, or set
 * prior-velocity and prior-sigma.
 *
 *   gst-launch-1.0 sonarsrc scene=fig10 num-buffers=30 ! dopplerbank \
 *       velocity-min=-0.4 velocity-max=0.4 velocity-step=0.02 ! \
 *       mimobeamform ! wardcluster ! velocityest ! sonartrack ! fdsink
 */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstsonartrack.h"
#include "gstsonarfilter.h"

#include <math.h>
#include <string.h>

#include "sonar-contracts.h"
#include "sonar-egomotion.h"
#include "sonar-track.h"

GST_DEBUG_CATEGORY_STATIC (sonar_track_debug);
#define GST_CAT_DEFAULT sonar_track_debug

#define DEFAULT_DIMENSIONS 0
#define DEFAULT_PRIOR_SIGMA 0.0
#define DEFAULT_POST_MESSAGES TRUE

enum
{
  PROP_0,
  PROP_DIMENSIONS,
  PROP_RANGE_SIGMA,
  PROP_DIRECTION_SIGMA,
  PROP_VELOCITY_SIGMA,
  PROP_STILL_GATE,
  PROP_MIN_STILL,
  PROP_MIN_SPREAD,
  PROP_AMBIGUITY,
  PROP_PRIOR_VELOCITY,
  PROP_PRIOR_SIGMA,
  PROP_ACCELERATION,
  PROP_SENSOR_ACCELERATION,
  PROP_MAX_SPEED,
  PROP_OBJECT_RADIUS,
  PROP_GATE,
  PROP_CONFIRM_HITS,
  PROP_MAX_MISSES,
  PROP_MAX_COAST,
  PROP_MOVING_SPEED,
  PROP_POST_MESSAGES,
};

struct _GstSonarTrack
{
  GstBaseTransform parent;

  /* Properties, protected by the object lock. */
  guint dimensions;
  SonarSigmaModel sigma;
  SonarEgoParams ego_params;
  SonarTrackerParams tracker_params;
  SonarVec3 prior_velocity;
  double prior_sigma;
  gboolean prior_changed;       /* by the property or the event */
  gboolean post_messages;

  /* What the set-up says (streaming thread). */
  SonarSetup *setup;
  gboolean rebuild;

  /* Working state (streaming thread). */
  SonarEgoEstimator *ego;
  SonarTracker *tracker;
  GArray *measurements;         /* SonarMeasurement */
  GArray *labels;               /* SonarEgoLabel */
  GArray *indices;              /* guint: a measurement's detection */
  GArray *tracks;               /* SonarTrack, indices mapped back */
};

G_DEFINE_TYPE (GstSonarTrack, gst_sonar_track, GST_TYPE_BASE_TRANSFORM);
GST_ELEMENT_REGISTER_DEFINE_WITH_CODE (sonartrack, "sonartrack",
    GST_RANK_NONE, GST_TYPE_SONAR_TRACK,
    GST_DEBUG_CATEGORY_INIT (sonar_track_debug, "sonartrack", 0,
        "ego-motion and tracks"));

static GstStaticPadTemplate sink_template = GST_STATIC_PAD_TEMPLATE ("sink",
    GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS (SONAR_DETECTIONS_CAPS));
static GstStaticPadTemplate src_template = GST_STATIC_PAD_TEMPLATE ("src",
    GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS (SONAR_DETECTIONS_CAPS));

/* (Re)makes the estimators from the properties and the set-up: every
 * track starts again. */
static gboolean
build (GstSonarTrack * self, GError ** error)
{
  SonarEgoParams ego;
  SonarTrackerParams tracker;
  guint dimensions;

  GST_OBJECT_LOCK (self);
  ego = self->ego_params;
  tracker = self->tracker_params;
  dimensions = self->dimensions;
  ego.has_prior = self->prior_sigma > 0.0;
  ego.prior_velocity = self->prior_velocity;
  ego.prior_sigma = self->prior_sigma;
  self->prior_changed = FALSE;
  GST_OBJECT_UNLOCK (self);

  if (dimensions == 0)
    dimensions = self->setup && self->setup->field_of_view ==
        SONAR_FIELD_OF_VIEW_FAN ? 2 : 3;
  /* A fan sees the y = 0 plane only; in 3-D the ego-motion takes what
   * the directions allow. */
  ego.dimensions = dimensions == 2 ? 2 : 0;
  tracker.dimensions = dimensions;
  ego.mirror_z = tracker.mirror_z = self->setup
      && sonar_geometry_is_planar (&self->setup->geometry);

  g_clear_pointer (&self->ego, sonar_ego_estimator_free);
  g_clear_pointer (&self->tracker, sonar_tracker_free);
  self->ego = sonar_ego_estimator_new (&ego, error);
  if (!self->ego)
    return FALSE;
  self->tracker = sonar_tracker_new (&tracker, error);
  if (!self->tracker) {
    g_clear_pointer (&self->ego, sonar_ego_estimator_free);
    return FALSE;
  }
  self->rebuild = FALSE;
  return TRUE;
}

static gboolean
gst_sonar_track_start (GstBaseTransform * trans)
{
  GstSonarTrack *self = GST_SONAR_TRACK (trans);
  GError *error = NULL;

  if (!build (self, &error)) {
    g_prefix_error (&error, "sonartrack: ");
    SONAR_ELEMENT_POST_ERROR (self, error, NULL);
    g_error_free (error);
    return FALSE;
  }
  return TRUE;
}

static gboolean
gst_sonar_track_stop (GstBaseTransform * trans)
{
  GstSonarTrack *self = GST_SONAR_TRACK (trans);

  g_clear_pointer (&self->ego, sonar_ego_estimator_free);
  g_clear_pointer (&self->tracker, sonar_tracker_free);
  g_clear_pointer (&self->setup, sonar_setup_unref);
  return TRUE;
}

static gboolean
gst_sonar_track_sink_event (GstBaseTransform * trans, GstEvent * event)
{
  GstSonarTrack *self = GST_SONAR_TRACK (trans);

  if (sonar_event_is_setup (event)) {
    GError *error = NULL;
    SonarSetup *setup = sonar_setup_from_event (event, &error);
    if (!setup) {
      g_prefix_error (&error, "sonartrack: ");
      SONAR_ELEMENT_POST_ERROR (self, error, NULL);
      g_error_free (error);
      gst_event_unref (event);
      return FALSE;
    }
    /* A new sensor: the tracks start again. */
    if (!self->setup || !sonar_setup_equal (self->setup, setup)) {
      g_clear_pointer (&self->setup, sonar_setup_unref);
      self->setup = setup;
      self->rebuild = TRUE;
    } else {
      sonar_setup_unref (setup);
    }
  } else if (GST_EVENT_TYPE (event) == GST_EVENT_FLUSH_STOP) {
    if (self->tracker)
      sonar_tracker_reset (self->tracker);
  }
  return GST_BASE_TRANSFORM_CLASS (gst_sonar_track_parent_class)->sink_event
      (trans, event);
}

static gboolean
gst_sonar_track_src_event (GstBaseTransform * trans, GstEvent * event)
{
  GstSonarTrack *self = GST_SONAR_TRACK (trans);
  SonarVec3 velocity;
  double sigma;

  if (sonar_ego_prior_event_parse (event, &velocity, &sigma)) {
    GST_OBJECT_LOCK (self);
    self->prior_velocity = velocity;
    self->prior_sigma = MAX (sigma, 0.0);
    self->prior_changed = TRUE;
    GST_OBJECT_UNLOCK (self);
    g_object_notify (G_OBJECT (self), "prior-velocity");
    g_object_notify (G_OBJECT (self), "prior-sigma");
    gst_event_unref (event);
    return TRUE;
  }
  return GST_BASE_TRANSFORM_CLASS (gst_sonar_track_parent_class)->src_event
      (trans, event);
}

/* The ping's valid detections as the estimators read them. */
static void
read_detections (GstSonarTrack * self, const SonarDetectionsMeta * meta)
{
  SonarSigmaModel sigma;

  GST_OBJECT_LOCK (self);
  sigma = self->sigma;
  GST_OBJECT_UNLOCK (self);
  g_array_set_size (self->measurements, 0);
  g_array_set_size (self->indices, 0);
  for (guint k = 0; k < meta->n_detections; k++) {
    const SonarDetection *d = &meta->detections[k];
    SonarMeasurement m;
    if (!d->valid || !isfinite (d->range) || !isfinite (d->azimuth)
        || !isfinite (d->elevation))
      continue;
    m.instant = d->instant;
    m.range = d->range;
    m.azimuth = d->azimuth;
    m.elevation = d->elevation;
    /* A speed at the bank's edge may lie beyond it: position only. */
    m.radial_velocity = d->out_of_range ? NAN : d->radial_velocity;
    sonar_measurement_set_nominal_sigma (&m, &sigma);
    /* The detection's own uncertainty (velocityest's, from the ping's
     * noise) where it is larger: a weak echo. The model stays the floor:
     * it covers what the noise does not (the presets' measured biases,
     * extended objects, the array's calibration), which at high SNR is
     * most of the error. */
    if (d->range_sigma > m.sigma_range)
      m.sigma_range = d->range_sigma;
    if (d->azimuth_sigma * G_PI / 180.0 > m.sigma_azimuth)
      m.sigma_azimuth = d->azimuth_sigma * G_PI / 180.0;
    if (d->elevation_sigma * G_PI / 180.0 > m.sigma_elevation)
      m.sigma_elevation = d->elevation_sigma * G_PI / 180.0;
    if (d->radial_velocity_sigma > m.sigma_radial_velocity)
      m.sigma_radial_velocity = d->radial_velocity_sigma;
    g_array_append_val (self->measurements, m);
    g_array_append_val (self->indices, k);
  }
  g_array_set_size (self->labels, self->measurements->len);
}

static GstFlowReturn
gst_sonar_track_generate_output (GstBaseTransform * trans,
    GstBuffer ** outbuf)
{
  GstSonarTrack *self = GST_SONAR_TRACK (trans);
  GstBuffer *in = trans->queued_buf;
  SonarDetectionsMeta *meta;
  SonarTracksMeta *tracks_meta;
  const char *frame_id;
  SonarEgoMotion motion;
  const SonarTrack *tracks;
  GError *error = NULL;
  GstClockTime pts;
  double ping_time;
  guint n_tracks;
  char *json;

  *outbuf = NULL;
  if (!in)
    return GST_FLOW_OK;
  trans->queued_buf = NULL;
  meta = sonar_buffer_get_detections_meta (in);
  if (!meta) {
    GST_ELEMENT_ERROR (self, STREAM, FORMAT, ("sonartrack: a buffer without "
            "detections: sonartrack takes velocityest's output (its "
            "SonarDetectionsMeta): ... ! velocityest ! sonartrack"), (NULL));
    gst_buffer_unref (in);
    return GST_FLOW_ERROR;
  }
  pts = GST_BUFFER_PTS (in);
  if (GST_CLOCK_TIME_IS_VALID (pts))
    ping_time = (double) pts / GST_SECOND;
  else if (self->setup && self->setup->ping_period > 0.0)
    ping_time = meta->ping_index * self->setup->ping_period;
  else {
    GST_ELEMENT_ERROR (self, STREAM, FORMAT, ("sonartrack: ping %"
            G_GUINT64_FORMAT " has no timestamp and no sonar-setup event "
            "gives the ping period: tracks need the time between pings",
            meta->ping_index), (NULL));
    gst_buffer_unref (in);
    return GST_FLOW_ERROR;
  }
  if (self->rebuild && !build (self, &error)) {
    g_prefix_error (&error, "sonartrack: ");
    SONAR_ELEMENT_POST_ERROR (self, error, NULL);
    g_error_free (error);
    gst_buffer_unref (in);
    return GST_FLOW_ERROR;
  }
  GST_OBJECT_LOCK (self);
  if (self->prior_changed) {
    sonar_ego_estimator_set_prior (self->ego, self->prior_velocity,
        self->prior_sigma);
    self->prior_changed = FALSE;
  }
  GST_OBJECT_UNLOCK (self);

  read_detections (self, meta);
  sonar_ego_estimate (self->ego, (SonarMeasurement *) self->measurements->data,
      self->measurements->len, &motion,
      (SonarEgoLabel *) self->labels->data);
  if (!sonar_tracker_process (self->tracker, ping_time,
          (SonarMeasurement *) self->measurements->data,
          self->measurements->len, &motion,
          (SonarEgoLabel *) self->labels->data, &error)) {
    GST_ELEMENT_ERROR (self, STREAM, FORMAT, ("sonartrack: ping %"
            G_GUINT64_FORMAT ": %s", meta->ping_index, error->message),
        (NULL));
    g_error_free (error);
    gst_buffer_unref (in);
    return GST_FLOW_ERROR;
  }
  /* Each track's detection: its index in velocityest's list. */
  tracks = sonar_tracker_tracks (self->tracker, &n_tracks);
  g_array_set_size (self->tracks, n_tracks);
  for (guint i = 0; i < n_tracks; i++) {
    SonarTrack *t = &g_array_index (self->tracks, SonarTrack, i);
    *t = tracks[i];
    if (t->detection >= 0)
      t->detection = g_array_index (self->indices, guint, t->detection);
  }
  tracks = (const SonarTrack *) self->tracks->data;

  frame_id = self->setup ? self->setup->frame_id : "";
  json = sonar_tracks_to_json (meta->ping_index, pts, frame_id, &motion,
      tracks, n_tracks);
  *outbuf = gst_buffer_new_wrapped (json, strlen (json));
  gst_buffer_copy_into (*outbuf, in, GST_BUFFER_COPY_TIMESTAMPS |
      GST_BUFFER_COPY_META, 0, -1);
  tracks_meta = sonar_buffer_add_tracks_meta (*outbuf, meta->ping_index,
      &motion, tracks, n_tracks);
  if (tracks_meta)
    g_strlcpy (tracks_meta->frame_id, frame_id, sizeof tracks_meta->frame_id);
  if (self->post_messages)
    gst_sonar_post_ping_message (GST_ELEMENT (self),
        &GST_BASE_TRANSFORM (self)->segment, pts,
        sonar_tracks_to_structure (meta->ping_index, pts, frame_id, &motion,
            tracks, n_tracks));
  gst_buffer_unref (in);
  return GST_FLOW_OK;
}

static void
gst_sonar_track_set_property (GObject * object, guint prop_id,
    const GValue * value, GParamSpec * pspec)
{
  GstSonarTrack *self = GST_SONAR_TRACK (object);
  SonarEgoParams *e = &self->ego_params;
  SonarTrackerParams *t = &self->tracker_params;

  if (!gst_sonar_property_settable (GST_ELEMENT (object), pspec))
    return;

  GST_OBJECT_LOCK (self);
  switch (prop_id) {
    case PROP_DIMENSIONS:
      self->dimensions = g_value_get_uint (value);
      break;
    case PROP_RANGE_SIGMA:
      self->sigma.range = g_value_get_double (value);
      break;
    case PROP_DIRECTION_SIGMA:
      self->sigma.direction_sine = g_value_get_double (value);
      break;
    case PROP_VELOCITY_SIGMA:
      self->sigma.radial_velocity = g_value_get_double (value);
      break;
    case PROP_STILL_GATE:
      e->gate = g_value_get_double (value);
      break;
    case PROP_MIN_STILL:
      e->min_still = g_value_get_uint (value);
      break;
    case PROP_MIN_SPREAD:
      e->min_spread = g_value_get_double (value);
      break;
    case PROP_AMBIGUITY:
      e->ambiguity = g_value_get_double (value);
      break;
    case PROP_PRIOR_VELOCITY:
      if (gst_value_array_get_size (value) == 3) {
        double c[3];
        for (guint i = 0; i < 3; i++) {
          const GValue *v = gst_value_array_get_value (value, i);
          c[i] = G_VALUE_HOLDS_DOUBLE (v) ? g_value_get_double (v) :
              G_VALUE_HOLDS_INT (v) ? g_value_get_int (v) : NAN;
        }
        if (isfinite (c[0]) && isfinite (c[1]) && isfinite (c[2])) {
          self->prior_velocity = sonar_vec3 (c[0], c[1], c[2]);
          self->prior_changed = TRUE;
          break;
        }
      }
      g_warning ("sonartrack: prior-velocity takes three numbers, vx, vy, "
          "vz in m/s (sensor frame): \"<0, 0, 0.3>\"");
      break;
    case PROP_PRIOR_SIGMA:
      self->prior_sigma = g_value_get_double (value);
      self->prior_changed = TRUE;
      break;
    case PROP_ACCELERATION:
      t->acceleration = g_value_get_double (value);
      break;
    case PROP_SENSOR_ACCELERATION:
      t->sensor_acceleration = g_value_get_double (value);
      break;
    case PROP_MAX_SPEED:
      t->max_speed = g_value_get_double (value);
      break;
    case PROP_OBJECT_RADIUS:
      t->object_radius = g_value_get_double (value);
      break;
    case PROP_GATE:
      t->gate = g_value_get_double (value);
      break;
    case PROP_CONFIRM_HITS:
      t->confirm_hits = g_value_get_uint (value);
      break;
    case PROP_MAX_MISSES:
      t->max_misses = g_value_get_uint (value);
      break;
    case PROP_MAX_COAST:
      t->max_coast = g_value_get_double (value);
      break;
    case PROP_MOVING_SPEED:
      t->moving_speed = g_value_get_double (value);
      break;
    case PROP_POST_MESSAGES:
      self->post_messages = g_value_get_boolean (value);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID (object, prop_id, pspec);
      break;
  }
  GST_OBJECT_UNLOCK (self);
}

static void
set_double_array (GValue * value, const double *c, guint n)
{
  for (guint i = 0; i < n; i++) {
    GValue v = G_VALUE_INIT;
    g_value_init (&v, G_TYPE_DOUBLE);
    g_value_set_double (&v, c[i]);
    gst_value_array_append_and_take_value (value, &v);
  }
}

static void
gst_sonar_track_get_property (GObject * object, guint prop_id,
    GValue * value, GParamSpec * pspec)
{
  GstSonarTrack *self = GST_SONAR_TRACK (object);
  const SonarEgoParams *e = &self->ego_params;
  const SonarTrackerParams *t = &self->tracker_params;

  GST_OBJECT_LOCK (self);
  switch (prop_id) {
    case PROP_DIMENSIONS:
      g_value_set_uint (value, self->dimensions);
      break;
    case PROP_RANGE_SIGMA:
      g_value_set_double (value, self->sigma.range);
      break;
    case PROP_DIRECTION_SIGMA:
      g_value_set_double (value, self->sigma.direction_sine);
      break;
    case PROP_VELOCITY_SIGMA:
      g_value_set_double (value, self->sigma.radial_velocity);
      break;
    case PROP_STILL_GATE:
      g_value_set_double (value, e->gate);
      break;
    case PROP_MIN_STILL:
      g_value_set_uint (value, e->min_still);
      break;
    case PROP_MIN_SPREAD:
      g_value_set_double (value, e->min_spread);
      break;
    case PROP_AMBIGUITY:
      g_value_set_double (value, e->ambiguity);
      break;
    case PROP_PRIOR_VELOCITY:{
      const double c[3] = { self->prior_velocity.x, self->prior_velocity.y,
        self->prior_velocity.z
      };
      set_double_array (value, c, 3);
      break;
    }
    case PROP_PRIOR_SIGMA:
      g_value_set_double (value, self->prior_sigma);
      break;
    case PROP_ACCELERATION:
      g_value_set_double (value, t->acceleration);
      break;
    case PROP_SENSOR_ACCELERATION:
      g_value_set_double (value, t->sensor_acceleration);
      break;
    case PROP_MAX_SPEED:
      g_value_set_double (value, t->max_speed);
      break;
    case PROP_OBJECT_RADIUS:
      g_value_set_double (value, t->object_radius);
      break;
    case PROP_GATE:
      g_value_set_double (value, t->gate);
      break;
    case PROP_CONFIRM_HITS:
      g_value_set_uint (value, t->confirm_hits);
      break;
    case PROP_MAX_MISSES:
      g_value_set_uint (value, t->max_misses);
      break;
    case PROP_MAX_COAST:
      g_value_set_double (value, t->max_coast);
      break;
    case PROP_MOVING_SPEED:
      g_value_set_double (value, t->moving_speed);
      break;
    case PROP_POST_MESSAGES:
      g_value_set_boolean (value, self->post_messages);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID (object, prop_id, pspec);
      break;
  }
  GST_OBJECT_UNLOCK (self);
}

static void
gst_sonar_track_finalize (GObject * object)
{
  GstSonarTrack *self = GST_SONAR_TRACK (object);

  g_clear_pointer (&self->ego, sonar_ego_estimator_free);
  g_clear_pointer (&self->tracker, sonar_tracker_free);
  g_clear_pointer (&self->setup, sonar_setup_unref);
  g_array_unref (self->measurements);
  g_array_unref (self->labels);
  g_array_unref (self->indices);
  g_array_unref (self->tracks);
  G_OBJECT_CLASS (gst_sonar_track_parent_class)->finalize (object);
}

static void
gst_sonar_track_init (GstSonarTrack * self)
{
  self->dimensions = DEFAULT_DIMENSIONS;
  sonar_sigma_model_init_default (&self->sigma);
  sonar_ego_params_init_default (&self->ego_params);
  sonar_tracker_params_init_default (&self->tracker_params);
  self->prior_velocity = sonar_vec3 (0, 0, 0);
  self->prior_sigma = DEFAULT_PRIOR_SIGMA;
  self->post_messages = DEFAULT_POST_MESSAGES;
  self->measurements = g_array_new (FALSE, FALSE, sizeof (SonarMeasurement));
  self->labels = g_array_new (FALSE, FALSE, sizeof (SonarEgoLabel));
  self->indices = g_array_new (FALSE, FALSE, sizeof (guint));
  self->tracks = g_array_new (FALSE, FALSE, sizeof (SonarTrack));
  /* Every ping makes a new buffer (generate_output): never passthrough. */
  gst_base_transform_set_passthrough (GST_BASE_TRANSFORM (self), FALSE);
  gst_base_transform_set_in_place (GST_BASE_TRANSFORM (self), FALSE);
}

static void
gst_sonar_track_class_init (GstSonarTrackClass * klass)
{
  GObjectClass *gobject_class = G_OBJECT_CLASS (klass);
  GstElementClass *element_class = GST_ELEMENT_CLASS (klass);
  GstBaseTransformClass *trans_class = GST_BASE_TRANSFORM_CLASS (klass);
  const GParamFlags flags = G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS
      | GST_PARAM_MUTABLE_READY;
  SonarSigmaModel s;
  SonarEgoParams e;
  SonarTrackerParams t;

  sonar_sigma_model_init_default (&s);
  sonar_ego_params_init_default (&e);
  sonar_tracker_params_init_default (&t);
  gobject_class->set_property = gst_sonar_track_set_property;
  gobject_class->get_property = gst_sonar_track_get_property;
  gobject_class->finalize = gst_sonar_track_finalize;

  g_object_class_install_property (gobject_class, PROP_DIMENSIONS,
      g_param_spec_uint ("dimensions", "Dimensions", "2: the world is the "
          "y = 0 plane (what a fan sees); 3: space; 0: from the set-up "
          "event (fan: 2, hemisphere: 3; none: 3)", 0, 3, DEFAULT_DIMENSIONS,
          flags));
  g_object_class_install_property (gobject_class, PROP_RANGE_SIGMA,
      g_param_spec_double ("range-sigma", "Range sigma", "Nominal 1-sigma "
          "error of a detection's range (m)", 1e-6, 10.0, s.range, flags));
  g_object_class_install_property (gobject_class, PROP_DIRECTION_SIGMA,
      g_param_spec_double ("direction-sigma", "Direction sigma", "Nominal "
          "1-sigma error of a detection's direction cosines (the sine of "
          "the angle from boresight): 0.002 is 0.11 degrees at boresight, "
          "more towards the array's plane", 1e-6, 1.0, s.direction_sine,
          flags));
  g_object_class_install_property (gobject_class, PROP_VELOCITY_SIGMA,
      g_param_spec_double ("velocity-sigma", "Velocity sigma", "Nominal "
          "1-sigma error of a detection's radial velocity (m/s)", 1e-6, 10.0,
          s.radial_velocity, flags));
  g_object_class_install_property (gobject_class, PROP_STILL_GATE,
      g_param_spec_double ("still-gate", "Still gate", "A detection whose "
          "radial velocity is within this many standard deviations of what "
          "a still object's would be is still in the world", 0.1, 100.0,
          e.gate, flags));
  g_object_class_install_property (gobject_class, PROP_MIN_STILL,
      g_param_spec_uint ("min-still", "Minimum still", "Still detections "
          "that must agree on the sensor's velocity (at least one more than "
          "its dimensions), else the ego-motion is unobservable", 2, 1000,
          e.min_still, flags));
  g_object_class_install_property (gobject_class, PROP_MIN_SPREAD,
      g_param_spec_double ("min-spread", "Minimum spread", "RMS angle "
          "(degrees) the still detections' directions must spread about "
          "their mean direction (2-D) or plane (3-D), else the ego-motion "
          "is unobservable", 0.0, 45.0, e.min_spread, flags));
  g_object_class_install_property (gobject_class, PROP_AMBIGUITY,
      g_param_spec_double ("ambiguity", "Ambiguity", "Another sensor "
          "velocity that fits this share of as many detections as the "
          "winner, two or more of them detections the winner rejects, and "
          "not by chance, makes the ping ambiguous: unobservable", 0.01, 1.0,
          e.ambiguity, flags));
  g_object_class_install_property (gobject_class, PROP_PRIOR_VELOCITY,
      gst_param_spec_array ("prior-velocity", "Prior velocity", "The "
          "sensor's velocity from elsewhere (odometry), vx, vy, vz m/s in "
          "the sensor frame, used when prior-sigma > 0 (also the "
          "sonar-ego-prior upstream event)", g_param_spec_double ("v",
              "v", "m/s", -100.0, 100.0, 0.0, G_PARAM_READWRITE |
              G_PARAM_STATIC_STRINGS), G_PARAM_READWRITE |
          G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING));
  g_object_class_install_property (gobject_class, PROP_PRIOR_SIGMA,
      g_param_spec_double ("prior-sigma", "Prior sigma", "1-sigma error "
          "(m/s per axis) of prior-velocity; 0: no prior", 0.0, 100.0,
          DEFAULT_PRIOR_SIGMA, G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS |
          GST_PARAM_MUTABLE_PLAYING));
  g_object_class_install_property (gobject_class, PROP_ACCELERATION,
      g_param_spec_double ("acceleration", "Acceleration", "Objects' "
          "accelerations (m/s^2, 1 sigma, white noise): how fast a track's "
          "velocity may change", 0.0, 1000.0, t.acceleration, flags));
  g_object_class_install_property (gobject_class, PROP_SENSOR_ACCELERATION,
      g_param_spec_double ("sensor-acceleration", "Sensor acceleration",
          "The sensor's accelerations (m/s^2, 1 sigma) between pings",
          0.0, 1000.0, t.sensor_acceleration, flags));
  g_object_class_install_property (gobject_class, PROP_MAX_SPEED,
      g_param_spec_double ("max-speed", "Maximum speed", "1-sigma spread of "
          "a velocity not measured yet (m/s): a new track's tangential "
          "velocity, the sensor's before any ping observed it", 0.01, 100.0,
          t.max_speed, flags));
  g_object_class_install_property (gobject_class, PROP_OBJECT_RADIUS,
      g_param_spec_double ("object-radius", "Object radius", "1-sigma "
          "spread (m) of the radius of an object's echoing surface before "
          "it is measured: the echo comes from the surface point nearest "
          "the sensor, which slides round the object as the line of sight "
          "turns (0: every object a point)", 0.0, 10.0, t.object_radius,
          flags));
  g_object_class_install_property (gobject_class, PROP_GATE,
      g_param_spec_double ("gate", "Gate", "Chi-square probability of the "
          "association gate (position and radial velocity together) and of "
          "the moving test", 0.5, 0.999999999, t.gate, flags));
  g_object_class_install_property (gobject_class, PROP_CONFIRM_HITS,
      g_param_spec_uint ("confirm-hits", "Confirm hits", "Detections a "
          "track needs to be confirmed", 1, 1000, t.confirm_hits, flags));
  g_object_class_install_property (gobject_class, PROP_MAX_MISSES,
      g_param_spec_uint ("max-misses", "Maximum misses", "A confirmed track "
          "missed on more pings in a row ends", 0, 1000, t.max_misses,
          flags));
  g_object_class_install_property (gobject_class, PROP_MAX_COAST,
      g_param_spec_double ("max-coast", "Maximum coast", "A confirmed track "
          "without a detection for longer (s) ends (dropped pings)", 0.001,
          3600.0, t.max_coast, flags));
  g_object_class_install_property (gobject_class, PROP_MOVING_SPEED,
      g_param_spec_double ("moving-speed", "Moving speed", "A track moves "
          "in the world when its speed is significant (the gate) and at "
          "least this (m/s)", 0.0, 100.0, t.moving_speed, flags));
  g_object_class_install_property (gobject_class, PROP_POST_MESSAGES,
      g_param_spec_boolean ("post-messages", "Post messages", "Post a "
          "\"sonar-tracks\" element message per ping", DEFAULT_POST_MESSAGES,
          flags));

  gst_element_class_add_static_pad_template (element_class, &sink_template);
  gst_element_class_add_static_pad_template (element_class, &src_template);
  gst_element_class_set_static_metadata (element_class,
      "Sonar ego-motion and tracker", "Filter/Analyzer/Sonar",
      "Estimates the sensor's velocity from the still objects' radial "
      "velocities and tracks the detections across pings with their "
      "velocity in the world; outputs one JSON line per ping",
      "gst-sonar-velocity developers");

  trans_class->start = GST_DEBUG_FUNCPTR (gst_sonar_track_start);
  trans_class->stop = GST_DEBUG_FUNCPTR (gst_sonar_track_stop);
  trans_class->sink_event = GST_DEBUG_FUNCPTR (gst_sonar_track_sink_event);
  trans_class->src_event = GST_DEBUG_FUNCPTR (gst_sonar_track_src_event);
  trans_class->generate_output =
      GST_DEBUG_FUNCPTR (gst_sonar_track_generate_output);
}
