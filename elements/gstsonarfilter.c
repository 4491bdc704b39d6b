/* gstsonarfilter.c: see gstsonarfilter.h. */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstsonarfilter.h"
#include "gstsonarlatency.h"

GST_DEBUG_CATEGORY_STATIC (sonar_filter_debug);
#define GST_CAT_DEFAULT sonar_filter_debug

#define DEFAULT_QOS TRUE

enum
{
  PROP_0,
  PROP_QOS,
  PROP_DROPPED,
};

typedef struct
{
  GstPad *sinkpad, *srcpad;

  GstCaps *in_caps;
  GstEvent *segment;            /* held until the output caps are out */
  SonarSetup *setup;
  GstEvent *setup_event;
  SonarDopplerBank *bank;
  SonarBand band;
  GstEvent *bank_event;
  gboolean configured;
  GstBufferPool *pool;          /* output buffers, when the subclass asked */

  /* Live: the processing time of each ping, and QoS. */
  GstSonarLatency latency;
  GstClockTime processing_start;        /* monotonic ns */
  GstSegment time_segment;      /* the input's, for running times */
  gboolean qos;                 /* property; object lock */
  GstClockTime earliest_time;   /* running time, from QoS; object lock */
  double proportion;            /* object lock */
  guint64 processed;            /* pings pushed since start */
  guint64 dropped;              /* pings dropped since start; object lock */
  /* A run of late pings not reported yet: late_first .. late_end - 1. */
  guint64 late_first, late_end;
  GstClockTimeDiff late_by;     /* the most any of them was late */
} GstSonarFilterPrivate;

G_DEFINE_ABSTRACT_TYPE_WITH_CODE (GstSonarFilter, gst_sonar_filter,
    GST_TYPE_ELEMENT, G_ADD_PRIVATE (GstSonarFilter);
    GST_DEBUG_CATEGORY_INIT (sonar_filter_debug, "sonarfilter", 0,
        "sonar processing element base"));

#define PRIV(f) ((GstSonarFilterPrivate *) \
    gst_sonar_filter_get_instance_private (GST_SONAR_FILTER (f)))

SonarSetup *
gst_sonar_filter_get_setup (GstSonarFilter * filter)
{
  return PRIV (filter)->setup;
}

SonarDopplerBank *
gst_sonar_filter_get_bank (GstSonarFilter * filter)
{
  return PRIV (filter)->bank;
}

const SonarBand *
gst_sonar_filter_get_band (GstSonarFilter * filter)
{
  return PRIV (filter)->bank ? &PRIV (filter)->band : NULL;
}

GstPad *
gst_sonar_filter_get_srcpad (GstSonarFilter * filter)
{
  return PRIV (filter)->srcpad;
}

void
gst_sonar_filter_set_bank (GstSonarFilter * filter, SonarDopplerBank * bank,
    const SonarBand * band)
{
  GstSonarFilterPrivate *priv = PRIV (filter);

  g_clear_pointer (&priv->bank, sonar_doppler_bank_unref);
  gst_clear_event (&priv->bank_event);
  priv->bank = sonar_doppler_bank_ref (bank);
  priv->band = *band;
  priv->bank_event = sonar_bank_event_new (bank, band);
}

gboolean
gst_sonar_filter_use_pool (GstSonarFilter * filter, GstCaps * caps,
    gsize size)
{
  GstSonarFilterPrivate *priv = PRIV (filter);
  GstQuery *query;
  GstBufferPool *pool = NULL;
  GstAllocator *allocator = NULL;
  GstAllocationParams params;
  GstStructure *config;
  guint min = GST_SONAR_FILTER_POOL_MIN_BUFFERS, max = 0;

  /* The pool's size is a guint: a larger one would wrap. */
  if (size > G_MAXUINT)
    return FALSE;
  /* Downstream has its say, as in GstBaseTransform's decide_allocation:
   * its pool if it offers one, else a pool of our own on the allocator
   * and parameters (alignment, padding) it asks for. */
  gst_allocation_params_init (&params);
  query = gst_query_new_allocation (caps, TRUE);
  if (gst_pad_peer_query (priv->srcpad, query)) {
    if (gst_query_get_n_allocation_params (query) > 0)
      gst_query_parse_nth_allocation_param (query, 0, &allocator, &params);
    if (gst_query_get_n_allocation_pools (query) > 0) {
      guint offered_size, offered_min, offered_max;
      gst_query_parse_nth_allocation_pool (query, 0, &pool, &offered_size,
          &offered_min, &offered_max);
      min = MAX (min, offered_min);
      /* A bounded pool would stall a tee or queue holding pings. */
      max = offered_max == 0 || offered_max >= min + 2 ? offered_max : 0;
    }
  }
  gst_query_unref (query);
  /* Downstream's pool, or when it will not take our buffers, our own. */
  for (int own = pool == NULL; own <= 1 && !priv->pool; own++) {
    if (own) {
      g_clear_object (&pool);
      pool = gst_buffer_pool_new ();
      min = GST_SONAR_FILTER_POOL_MIN_BUFFERS;
      max = 0;
    }
    config = gst_buffer_pool_get_config (pool);
    gst_buffer_pool_config_set_params (config, caps, size, min, max);
    gst_buffer_pool_config_set_allocator (config, allocator, &params);
    if (gst_buffer_pool_set_config (pool, config)
        && gst_buffer_pool_set_active (pool, TRUE))
      priv->pool = g_steal_pointer (&pool);
  }
  g_clear_object (&pool);
  if (allocator)
    gst_object_unref (allocator);
  return priv->pool != NULL;
}

GstBuffer *
gst_sonar_filter_new_buffer (GstSonarFilter * filter, gsize size)
{
  GstSonarFilterPrivate *priv = PRIV (filter);
  GstBuffer *buffer = NULL;

  if (!priv->pool)
    return gst_buffer_new_allocate (NULL, size, NULL);
  if (gst_buffer_pool_acquire_buffer (priv->pool, &buffer, NULL) !=
      GST_FLOW_OK)
    return NULL;
  return buffer;
}

/* The bus warning for pings first .. end - 1; @total: the count since
 * start. */
static void
post_dropped (GstSonarFilter * filter, guint64 first, guint64 end,
    const char *why, guint64 total)
{
  g_autofree char *which = end - first == 1 ? g_strdup_printf ("ping %"
      G_GUINT64_FORMAT, first) : g_strdup_printf ("pings %" G_GUINT64_FORMAT
      " to %" G_GUINT64_FORMAT, first, end - 1);

  GST_ELEMENT_WARNING_WITH_DETAILS (filter, STREAM, DEMUX,
      ("Dropped %s, %s (%" G_GUINT64_FORMAT " dropped since start)", which,
          why, total), (NULL),
      ("sonar-dropped", G_TYPE_UINT64, total,
          "first-ping", G_TYPE_UINT64, first,
          "pings", G_TYPE_UINT64, end - first, NULL));
}

void
gst_sonar_filter_drop_pings (GstSonarFilter * filter, guint64 first,
    guint64 end, const char *why)
{
  GstSonarFilterPrivate *priv = PRIV (filter);
  guint64 total;

  if (end <= first)
    return;
  GST_OBJECT_LOCK (filter);
  priv->dropped += end - first;
  total = priv->dropped;
  GST_OBJECT_UNLOCK (filter);
  post_dropped (filter, first, end, why, total);
}

/* The run of late pings ended (or the stream did): one warning for it.
 * They were counted as they were dropped. */
static void
report_late_run (GstSonarFilter * filter)
{
  GstSonarFilterPrivate *priv = PRIV (filter);
  const guint64 n = priv->late_end - priv->late_first;
  g_autofree char *why = NULL;
  guint64 total;

  if (n == 0)
    return;
  why = g_strdup_printf ("too late for the sink: %s %.0f ms behind the live "
      "stream (QoS)", n == 1 ? "it was" : "they were up to",
      (double) priv->late_by / GST_MSECOND);
  GST_OBJECT_LOCK (filter);
  total = priv->dropped;
  GST_OBJECT_UNLOCK (filter);
  post_dropped (filter, priv->late_first, priv->late_end, why, total);
  priv->late_first = priv->late_end = 0;
  priv->late_by = 0;
}

const GstSegment *
gst_sonar_filter_get_segment (GstSonarFilter * filter)
{
  return &PRIV (filter)->time_segment;
}

void
gst_sonar_post_ping_message (GstElement * element,
    const GstSegment * segment, GstClockTime pts, GstStructure * s)
{
  GstClockTime stream_time = GST_CLOCK_TIME_NONE;
  GstClockTime running_time = GST_CLOCK_TIME_NONE;

  if (segment->format == GST_FORMAT_TIME && GST_CLOCK_TIME_IS_VALID (pts)) {
    stream_time = gst_segment_to_stream_time (segment, GST_FORMAT_TIME, pts);
    running_time = gst_segment_to_running_time (segment, GST_FORMAT_TIME,
        pts);
  }
  gst_structure_set (s, "stream-time", G_TYPE_UINT64, stream_time,
      "running-time", G_TYPE_UINT64, running_time, NULL);
  gst_element_post_message (element, gst_message_new_element (GST_OBJECT
          (element), s));
}

gboolean
gst_sonar_filter_drop_late (GstSonarFilter * filter, guint64 index,
    GstClockTime pts, GstClockTime duration)
{
  GstSonarFilterPrivate *priv = PRIV (filter);
  GstClockTime running_time, earliest_time;
  GstMessage *message;
  double proportion;
  gboolean qos;
  guint64 dropped;

  if (priv->time_segment.format != GST_FORMAT_TIME
      || !GST_CLOCK_TIME_IS_VALID (pts))
    return FALSE;
  running_time = gst_segment_to_running_time (&priv->time_segment,
      GST_FORMAT_TIME, pts);
  GST_OBJECT_LOCK (filter);
  qos = priv->qos;
  earliest_time = priv->earliest_time;
  proportion = priv->proportion;
  GST_OBJECT_UNLOCK (filter);
  if (!qos || !GST_CLOCK_TIME_IS_VALID (running_time)
      || !GST_CLOCK_TIME_IS_VALID (earliest_time)
      || running_time > earliest_time)
    return FALSE;

  if (priv->late_end != priv->late_first && priv->late_end != index)
    report_late_run (filter);
  if (priv->late_end == priv->late_first)
    priv->late_first = index;
  priv->late_end = index + 1;
  priv->late_by = MAX (priv->late_by, GST_CLOCK_DIFF (running_time,
          earliest_time));
  GST_OBJECT_LOCK (filter);
  dropped = ++priv->dropped;
  GST_OBJECT_UNLOCK (filter);
  GST_DEBUG_OBJECT (filter, "ping %" G_GUINT64_FORMAT " late: running time %"
      GST_TIME_FORMAT " <= %" GST_TIME_FORMAT, index,
      GST_TIME_ARGS (running_time), GST_TIME_ARGS (earliest_time));
  message = gst_message_new_qos (GST_OBJECT (filter), FALSE, running_time,
      gst_segment_to_stream_time (&priv->time_segment, GST_FORMAT_TIME, pts),
      pts, duration);
  gst_message_set_qos_values (message, GST_CLOCK_DIFF (running_time,
          earliest_time), proportion, 1000000);
  gst_message_set_qos_stats (message, GST_FORMAT_BUFFERS, priv->processed,
      dropped);
  gst_element_post_message (GST_ELEMENT (filter), message);
  return TRUE;
}

GstFlowReturn
gst_sonar_filter_push (GstSonarFilter * filter, GstBuffer * buffer)
{
  GstSonarFilterPrivate *priv = PRIV (filter);
  GstFlowReturn ret;

  gst_sonar_latency_add (GST_ELEMENT (filter), &priv->latency,
      gst_util_get_timestamp () - priv->processing_start);
  report_late_run (filter);
  priv->processed++;
  ret = gst_pad_push (priv->srcpad, buffer);
  /* A subclass may push several pings per input buffer. */
  priv->processing_start = gst_util_get_timestamp ();
  return ret;
}

static void
reset_qos (GstSonarFilter * filter)
{
  GstSonarFilterPrivate *priv = PRIV (filter);

  GST_OBJECT_LOCK (filter);
  priv->earliest_time = GST_CLOCK_TIME_NONE;
  priv->proportion = 1.0;
  GST_OBJECT_UNLOCK (filter);
}

static void
unconfigure (GstSonarFilter * filter)
{
  GstSonarFilterClass *klass = GST_SONAR_FILTER_GET_CLASS (filter);
  GstSonarFilterPrivate *priv = PRIV (filter);

  if (priv->configured && klass->unconfigure)
    klass->unconfigure (filter);
  priv->configured = FALSE;
  if (priv->pool) {
    gst_buffer_pool_set_active (priv->pool, FALSE);
    gst_clear_object (&priv->pool);
  }
}

static void
clear_state (GstSonarFilter * filter)
{
  GstSonarFilterPrivate *priv = PRIV (filter);

  unconfigure (filter);
  gst_clear_caps (&priv->in_caps);
  gst_clear_event (&priv->segment);
  gst_clear_event (&priv->setup_event);
  gst_clear_event (&priv->bank_event);
  g_clear_pointer (&priv->setup, sonar_setup_unref);
  g_clear_pointer (&priv->bank, sonar_doppler_bank_unref);
}

static gboolean
upstream_is_live (GstSonarFilter * filter)
{
  GstQuery *query = gst_query_new_latency ();
  gboolean live = FALSE;

  if (gst_pad_peer_query (PRIV (filter)->sinkpad, query))
    gst_query_parse_latency (query, &live, NULL, NULL);
  gst_query_unref (query);
  return live;
}

/* @time through @map, one of the subclass's (GstSonarFilterClass
 * output_time, input_time), once configured; else the same. */
static GstClockTime
map_time (GstSonarFilter * filter,
    GstClockTime (*map) (GstSonarFilter *, GstClockTime), GstClockTime time)
{
  return map && PRIV (filter)->configured && GST_CLOCK_TIME_IS_VALID (time) ?
      map (filter, time) : time;
}

/* The segment event to send for the input's @event, in the output's
 * times; it is also the segment the output's running times are in. */
static GstEvent *
output_segment (GstSonarFilter * filter, GstEvent * event)
{
  GstSonarFilterPrivate *priv = PRIV (filter);
  GstSonarFilterClass *klass = GST_SONAR_FILTER_GET_CLASS (filter);
  GstSegment *segment = &priv->time_segment;
  GstEvent *out;

  gst_event_copy_segment (event, segment);
  if (segment->format != GST_FORMAT_TIME || !klass->output_time)
    return gst_event_ref (event);
  segment->start = map_time (filter, klass->output_time, segment->start);
  segment->stop = map_time (filter, klass->output_time, segment->stop);
  segment->time = map_time (filter, klass->output_time, segment->time);
  segment->position = map_time (filter, klass->output_time,
      segment->position);
  segment->duration = map_time (filter, klass->output_time,
      segment->duration);
  out = gst_event_new_segment (segment);
  gst_event_set_seqnum (out, gst_event_get_seqnum (event));
  return out;
}

static gboolean
configure (GstSonarFilter * filter)
{
  GstSonarFilterClass *klass = GST_SONAR_FILTER_GET_CLASS (filter);
  GstSonarFilterPrivate *priv = PRIV (filter);
  GError *error = NULL;
  GstCaps *out_caps;

  if (klass->make_setup) {
    SonarSetup *own = klass->make_setup (filter, priv->in_caps, &error);
    if (error) {
      SONAR_ELEMENT_POST_ERROR (filter, error, NULL);
      g_error_free (error);
      return FALSE;
    }
    if (own) {
      g_clear_pointer (&priv->setup, sonar_setup_unref);
      priv->setup = own;
      gst_clear_event (&priv->setup_event);
      priv->setup_event = sonar_setup_event_new (own);
    }
  }
  if (!priv->setup) {
    GST_ELEMENT_ERROR (filter, CORE, NEGOTIATION,
        ("No sonar set-up arrived before the data: %s needs the array "
            "geometry and emission waveforms (the sonar-setup event that "
            "sonarsrc sends; for a recording, set dopplerbank's "
            "sensor-file)", GST_OBJECT_NAME (filter)),
        (NULL));
    return FALSE;
  }
  if (klass->bank_role == GST_SONAR_FILTER_USES_BANK && !priv->bank) {
    GST_ELEMENT_ERROR (filter, CORE, NEGOTIATION,
        ("No Doppler bank arrived before the data: %s must follow "
            "dopplerbank", GST_OBJECT_NAME (filter)), (NULL));
    return FALSE;
  }
  unconfigure (filter);
  gst_sonar_latency_reset (GST_ELEMENT (filter), &priv->latency,
      upstream_is_live (filter));
  out_caps = klass->configure (filter, priv->in_caps, &error);
  if (!out_caps) {
    SONAR_ELEMENT_POST_ERROR (filter, error, NULL);
    g_error_free (error);
    return FALSE;
  }
  priv->configured = TRUE;
  if (!gst_pad_push_event (priv->srcpad, gst_event_new_caps (out_caps))) {
    g_autofree char *text = gst_caps_to_string (out_caps);
    GST_ELEMENT_ERROR (filter, CORE, NEGOTIATION,
        ("Downstream does not accept the output of %s: %s",
            GST_OBJECT_NAME (filter), text), (NULL));
    gst_caps_unref (out_caps);
    return FALSE;
  }
  gst_caps_unref (out_caps);
  if (priv->segment)
    gst_pad_push_event (priv->srcpad, output_segment (filter,
            priv->segment));
  gst_pad_push_event (priv->srcpad, gst_event_ref (priv->setup_event));
  if (priv->bank_event)
    gst_pad_push_event (priv->srcpad, gst_event_ref (priv->bank_event));
  return TRUE;
}

static GstFlowReturn
gst_sonar_filter_chain (GstPad * pad, GstObject * parent, GstBuffer * buffer)
{
  GstSonarFilter *filter = GST_SONAR_FILTER (parent);
  GstSonarFilterClass *klass = GST_SONAR_FILTER_GET_CLASS (filter);
  GstSonarFilterPrivate *priv = PRIV (filter);

  /* From the ping's arrival (a set-up's time falls on the first ping
   * after it, which is not counted). */
  priv->processing_start = gst_util_get_timestamp ();
  if (!priv->configured && !configure (filter)) {
    gst_buffer_unref (buffer);
    return GST_FLOW_NOT_NEGOTIATED;
  }
  if (!klass->frames_pings && gst_sonar_filter_drop_late (filter,
          GST_BUFFER_OFFSET (buffer), GST_BUFFER_PTS (buffer),
          GST_BUFFER_DURATION (buffer))) {
    gst_buffer_unref (buffer);
    return GST_FLOW_OK;
  }
  return klass->process (filter, buffer);
}

/* Upstream's latency plus this element's processing time; position and
 * duration in the output's times. */
static gboolean
gst_sonar_filter_src_query (GstPad * pad, GstObject * parent,
    GstQuery * query)
{
  GstSonarFilter *filter = GST_SONAR_FILTER (parent);
  GstSonarFilterPrivate *priv = PRIV (filter);
  GstClockTime min, max, own;
  gboolean live;

  if (GST_QUERY_TYPE (query) == GST_QUERY_POSITION
      || GST_QUERY_TYPE (query) == GST_QUERY_DURATION) {
    GstFormat format;
    gint64 value;
    if (!gst_pad_query_default (pad, parent, query))
      return FALSE;
    if (GST_QUERY_TYPE (query) == GST_QUERY_POSITION) {
      gst_query_parse_position (query, &format, &value);
      if (format == GST_FORMAT_TIME && value >= 0)
        gst_query_set_position (query, format, map_time (filter,
                GST_SONAR_FILTER_GET_CLASS (filter)->output_time, value));
    } else {
      gst_query_parse_duration (query, &format, &value);
      if (format == GST_FORMAT_TIME && value >= 0)
        gst_query_set_duration (query, format, map_time (filter,
                GST_SONAR_FILTER_GET_CLASS (filter)->output_time, value));
    }
    return TRUE;
  }
  if (GST_QUERY_TYPE (query) != GST_QUERY_LATENCY)
    return gst_pad_query_default (pad, parent, query);
  if (!gst_pad_peer_query (priv->sinkpad, query))
    return FALSE;
  gst_query_parse_latency (query, &live, &min, &max);
  own = gst_sonar_latency_get (GST_ELEMENT (filter), &priv->latency);
  GST_DEBUG_OBJECT (filter, "upstream %" GST_TIME_FORMAT ", own %"
      GST_TIME_FORMAT, GST_TIME_ARGS (min), GST_TIME_ARGS (own));
  /* It holds each ping that long: what upstream can buffer grows too. */
  gst_query_set_latency (query, live, min + own,
      GST_CLOCK_TIME_IS_VALID (max) ? max + own : max);
  return TRUE;
}

/* QoS from downstream: pings up to this running time would be late
 * (GstBaseTransform's rule). */
static gboolean
gst_sonar_filter_src_event (GstPad * pad, GstObject * parent,
    GstEvent * event)
{
  GstSonarFilter *filter = GST_SONAR_FILTER (parent);
  GstSonarFilterPrivate *priv = PRIV (filter);

  if (GST_EVENT_TYPE (event) == GST_EVENT_QOS) {
    double proportion;
    GstClockTimeDiff diff;
    GstClockTime timestamp;

    gst_event_parse_qos (event, NULL, &proportion, &diff, &timestamp);
    GST_OBJECT_LOCK (filter);
    priv->proportion = proportion;
    priv->earliest_time = GST_CLOCK_TIME_IS_VALID (timestamp)
        && (diff >= 0 || timestamp >= (GstClockTime) - diff) ?
        timestamp + diff : GST_CLOCK_TIME_NONE;
    GST_OBJECT_UNLOCK (filter);
  } else if (GST_EVENT_TYPE (event) == GST_EVENT_SEEK
      && GST_SONAR_FILTER_GET_CLASS (filter)->input_time) {
    /* A seek to output times, made one to the input's. */
    double rate;
    GstFormat format;
    GstSeekFlags flags;
    GstSeekType start_type, stop_type;
    gint64 start, stop;
    GstEvent *seek;

    gst_event_parse_seek (event, &rate, &format, &flags, &start_type, &start,
        &stop_type, &stop);
    if (format == GST_FORMAT_TIME) {
      GstClockTime (*map) (GstSonarFilter *, GstClockTime) =
          GST_SONAR_FILTER_GET_CLASS (filter)->input_time;
      if (start_type == GST_SEEK_TYPE_SET && start >= 0)
        start = map_time (filter, map, start);
      if (stop_type == GST_SEEK_TYPE_SET && stop >= 0)
        stop = map_time (filter, map, stop);
      seek = gst_event_new_seek (rate, format, flags, start_type, start,
          stop_type, stop);
      gst_event_set_seqnum (seek, gst_event_get_seqnum (event));
      gst_event_unref (event);
      event = seek;
    }
  }
  return gst_pad_event_default (pad, parent, event);
}

static gboolean
gst_sonar_filter_sink_event (GstPad * pad, GstObject * parent,
    GstEvent * event)
{
  GstSonarFilter *filter = GST_SONAR_FILTER (parent);
  GstSonarFilterClass *klass = GST_SONAR_FILTER_GET_CLASS (filter);
  GstSonarFilterPrivate *priv = PRIV (filter);

  /* A set-up that crossed a network (gdppay) comes with its type cut. */
  if (sonar_event_is_setup (event))
    event = sonar_setup_event_restore (event);
  switch (GST_EVENT_TYPE (event)) {
    case GST_EVENT_CAPS:{
      GstCaps *caps;
      gst_event_parse_caps (event, &caps);
      gst_caps_replace (&priv->in_caps, caps);
      unconfigure (filter);
      gst_event_unref (event);
      return TRUE;
    }
    case GST_EVENT_SEGMENT:{
      GstEvent *out;
      gst_event_copy_segment (event, &priv->time_segment);
      gst_event_replace (&priv->segment, event);
      if (!priv->configured) {
        gst_event_unref (event);
        return TRUE;
      }
      out = output_segment (filter, event);
      gst_event_unref (event);
      return gst_pad_push_event (priv->srcpad, out);
    }
    case GST_EVENT_CUSTOM_DOWNSTREAM_STICKY:
      if (sonar_event_is_setup (event)) {
        GError *error = NULL;
        SonarSetup *setup = sonar_setup_from_event (event, &error);
        if (!setup) {
          SONAR_ELEMENT_POST_ERROR (filter, error, NULL);
          g_error_free (error);
          gst_event_unref (event);
          return FALSE;
        }
        if (priv->setup && sonar_setup_equal (priv->setup, setup)) {
          sonar_setup_unref (setup);
          gst_event_unref (event);
          return TRUE;
        }
        g_clear_pointer (&priv->setup, sonar_setup_unref);
        priv->setup = setup;
        gst_event_replace (&priv->setup_event, event);
        gst_event_unref (event);
        unconfigure (filter);
        return TRUE;
      }
      if (sonar_event_is_bank (event)
          && klass->bank_role == GST_SONAR_FILTER_USES_BANK) {
        SonarBand band;
        SonarDopplerBank *bank = sonar_bank_from_event (event, &band);
        if (!bank) {
          GST_ELEMENT_ERROR (filter, STREAM, FORMAT,
              ("Malformed %s event", SONAR_BANK_EVENT_NAME), (NULL));
          gst_event_unref (event);
          return FALSE;
        }
        g_clear_pointer (&priv->bank, sonar_doppler_bank_unref);
        priv->bank = bank;
        priv->band = band;
        gst_event_replace (&priv->bank_event, event);
        gst_event_unref (event);
        unconfigure (filter);
        return TRUE;
      }
      if (sonar_event_is_bank (event)) {
        /* dopplerbank makes its own bank: an upstream one is stale. */
        gst_event_unref (event);
        return TRUE;
      }
      break;
    case GST_EVENT_FLUSH_STOP:
      if (klass->reset)
        klass->reset (filter, FALSE);
      report_late_run (filter);
      reset_qos (filter);
      break;
    case GST_EVENT_EOS:
      if (priv->configured && klass->reset)
        klass->reset (filter, TRUE);
      report_late_run (filter);
      break;
    default:
      break;
  }
  return gst_pad_event_default (pad, parent, event);
}

static GstStateChangeReturn
gst_sonar_filter_change_state (GstElement * element,
    GstStateChange transition)
{
  GstSonarFilterPrivate *priv = PRIV (element);
  GstStateChangeReturn ret;

  if (transition == GST_STATE_CHANGE_READY_TO_PAUSED) {
    gst_segment_init (&priv->time_segment, GST_FORMAT_UNDEFINED);
    reset_qos (GST_SONAR_FILTER (element));
    GST_OBJECT_LOCK (element);
    priv->dropped = 0;
    GST_OBJECT_UNLOCK (element);
    priv->processed = 0;
    priv->late_first = priv->late_end = 0;
    priv->late_by = 0;
  }
  ret = GST_ELEMENT_CLASS (gst_sonar_filter_parent_class)->change_state
      (element, transition);
  if (transition == GST_STATE_CHANGE_PAUSED_TO_READY) {
    GstSonarFilterClass *klass = GST_SONAR_FILTER_GET_CLASS (element);
    report_late_run (GST_SONAR_FILTER (element));
    if (klass->reset)
      klass->reset (GST_SONAR_FILTER (element), FALSE);
    clear_state (GST_SONAR_FILTER (element));
  }
  return ret;
}

static void
gst_sonar_filter_finalize (GObject * object)
{
  clear_state (GST_SONAR_FILTER (object));
  G_OBJECT_CLASS (gst_sonar_filter_parent_class)->finalize (object);
}

gboolean
gst_sonar_property_settable (GstElement * element, GParamSpec * pspec)
{
  GstState state;

  if (!(pspec->flags & GST_PARAM_MUTABLE_READY)
      || (pspec->flags & (GST_PARAM_MUTABLE_PAUSED |
              GST_PARAM_MUTABLE_PLAYING)))
    return TRUE;
  GST_OBJECT_LOCK (element);
  state = MAX (GST_STATE (element), GST_STATE_PENDING (element));
  GST_OBJECT_UNLOCK (element);
  if (state <= GST_STATE_READY)
    return TRUE;
  g_warning ("%s: %s can only be changed in the NULL or READY state, not in "
      "%s: ignored", GST_OBJECT_NAME (element), pspec->name,
      gst_element_state_get_name (state));
  return FALSE;
}

static void
gst_sonar_filter_set_property (GObject * object, guint prop_id,
    const GValue * value, GParamSpec * pspec)
{
  GstSonarFilterPrivate *priv = PRIV (object);

  if (!gst_sonar_property_settable (GST_ELEMENT (object), pspec))
    return;

  switch (prop_id) {
    case PROP_QOS:
      GST_OBJECT_LOCK (object);
      priv->qos = g_value_get_boolean (value);
      GST_OBJECT_UNLOCK (object);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID (object, prop_id, pspec);
      break;
  }
}

static void
gst_sonar_filter_get_property (GObject * object, guint prop_id,
    GValue * value, GParamSpec * pspec)
{
  GstSonarFilterPrivate *priv = PRIV (object);

  GST_OBJECT_LOCK (object);
  switch (prop_id) {
    case PROP_QOS:
      g_value_set_boolean (value, priv->qos);
      break;
    case PROP_DROPPED:
      g_value_set_uint64 (value, priv->dropped);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID (object, prop_id, pspec);
      break;
  }
  GST_OBJECT_UNLOCK (object);
}

static void
gst_sonar_filter_init (GstSonarFilter * filter)
{
  GstSonarFilterPrivate *priv = PRIV (filter);

  priv->qos = DEFAULT_QOS;
  priv->earliest_time = GST_CLOCK_TIME_NONE;
  priv->proportion = 1.0;
  gst_segment_init (&priv->time_segment, GST_FORMAT_UNDEFINED);
}

/* The pads come from the subclass's templates: during instance init the
 * object still has the base's class, so they are made once constructed. */
static void
gst_sonar_filter_constructed (GObject * object)
{
  GstSonarFilter *filter = GST_SONAR_FILTER (object);
  GstElementClass *klass = GST_ELEMENT_GET_CLASS (filter);
  GstSonarFilterPrivate *priv = PRIV (filter);

  G_OBJECT_CLASS (gst_sonar_filter_parent_class)->constructed (object);

  priv->sinkpad = gst_pad_new_from_template
      (gst_element_class_get_pad_template (klass, "sink"), "sink");
  gst_pad_set_chain_function (priv->sinkpad, gst_sonar_filter_chain);
  gst_pad_set_event_function (priv->sinkpad, gst_sonar_filter_sink_event);
  gst_element_add_pad (GST_ELEMENT (filter), priv->sinkpad);

  priv->srcpad = gst_pad_new_from_template
      (gst_element_class_get_pad_template (klass, "src"), "src");
  gst_pad_use_fixed_caps (priv->srcpad);
  gst_pad_set_query_function (priv->srcpad, gst_sonar_filter_src_query);
  gst_pad_set_event_function (priv->srcpad, gst_sonar_filter_src_event);
  gst_element_add_pad (GST_ELEMENT (filter), priv->srcpad);
}

static void
gst_sonar_filter_class_init (GstSonarFilterClass * klass)
{
  GObjectClass *gobject_class = G_OBJECT_CLASS (klass);

  gobject_class->constructed = gst_sonar_filter_constructed;
  gobject_class->finalize = gst_sonar_filter_finalize;
  gobject_class->set_property = gst_sonar_filter_set_property;
  gobject_class->get_property = gst_sonar_filter_get_property;
  GST_ELEMENT_CLASS (klass)->change_state = gst_sonar_filter_change_state;

  g_object_class_install_property (gobject_class, PROP_QOS,
      g_param_spec_boolean ("qos", "QoS", "Drop whole pings that would "
          "reach the sink too late, after the QoS events of a synchronised "
          "sink with qos=true (GstBaseTransform's rule: running time at or "
          "before the last late ping's plus its lateness)", DEFAULT_QOS,
          G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS));
  g_object_class_install_property (gobject_class, PROP_DROPPED,
      g_param_spec_uint64 ("dropped", "Dropped pings", "Pings dropped "
          "since start, each reported by a bus warning: too late for the "
          "sink (qos), or, in dopplerbank, not held whole by the stream (it "
          "started or ended inside one, a gap, a seek, pings a live source "
          "or a leaky queue before it dropped)", 0, G_MAXUINT64, 0,
          G_PARAM_READABLE | G_PARAM_STATIC_STRINGS));
}
