/* gstsonarviz.c: sonarviz, the energyscape and its detections as video
 * (the picture: gst/sonar-render.h).
 *
 * Two inputs, paired by ping: the always pad "sink" takes energyscapes
 * (mimobeamform's or wardcluster's output), the request pad "detections"
 * velocityest's output, whose SonarDetectionsMeta gives each detection's
 * position and radial velocity. velocityest outputs detections, not the
 * image, so the image reaches sonarviz through a tee before velocityest:
 *
 *   gst-launch-1.0 sonarsrc scene=fig9 num-buffers=24 ! dopplerbank \
 *       ! mimobeamform ! wardcluster ! tee name=t \
 *       sonarviz name=viz ! videoconvert ! autovideosink \
 *       t. ! queue ! viz.sink \
 *       t. ! queue ! velocityest ! viz.detections
 *
 * The detections pad takes sonartrack's output as well (it carries
 * velocityest's SonarDetectionsMeta on): then each confirmed track of its
 * SonarTracksMeta is drawn too, its id beside it and an arrow of its
 * velocity in the world to where it goes in arrow-time seconds:
 *
 *       t. ! queue ! velocityest ! sonartrack ! viz.detections
 *
 * Without a "detections" pad it draws the images alone. With one, each
 * image waits for its ping's detections (GstAggregator waits until both
 * pads hold data; detections of an older ping than the image are
 * dropped, an image whose ping has no detections, because velocityest
 * dropped or skipped it, is drawn without them).
 *
 * The ground truth (sonarsrc's SonarTruthMeta, on either input) is drawn
 * when show-truth is set. Each frame carries the truth and detections it
 * shows as metas, its PTS and duration are the image's. The frame rate of
 * the caps is the set-up's ping rate (0/1 when there is no set-up).
 */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstsonarviz.h"
#include "gstsonarfilter.h"

#include <gst/video/video.h>
#include <math.h>

#include "sonar-contracts.h"
#include "sonar-render.h"

GST_DEBUG_CATEGORY_STATIC (sonar_viz_debug);
#define GST_CAT_DEFAULT sonar_viz_debug

#define DEFAULT_WIDTH 1280
#define DEFAULT_HEIGHT 720
#define DEFAULT_DYNAMIC_RANGE 40.0
#define DEFAULT_RANGE_COMPENSATION TRUE
#define DEFAULT_SHOW_TRUTH TRUE
#define DEFAULT_SHOW_REJECTED FALSE
#define DEFAULT_SHOW_TRACKS TRUE
#define DEFAULT_ARROW_TIME SONAR_RENDER_DEFAULT_ARROW_TIME

enum
{
  PROP_0,
  PROP_WIDTH,
  PROP_HEIGHT,
  PROP_DYNAMIC_RANGE,
  PROP_RANGE_COMPENSATION,
  PROP_SHOW_TRUTH,
  PROP_SHOW_REJECTED,
  PROP_SHOW_TRACKS,
  PROP_ARROW_TIME,
};

struct _GstSonarViz
{
  GstAggregator parent;

  GstAggregatorPad *scape_pad;
  GstAggregatorPad *detections_pad;     /* request pad, object lock */

  /* Properties, object lock. */
  guint width, height;
  double dynamic_range;
  gboolean range_compensation;
  gboolean show_truth;
  gboolean show_rejected;
  gboolean show_tracks;
  double arrow_time;

  /* Streaming state (the source pad's task). */
  gboolean have_grid;
  SonarImageGrid grid;
  guint records;
  gint fps_n, fps_d;
  GstVideoInfo info;
  gboolean negotiated;
  SonarRenderer *renderer;
  GArray *truths, *detections;  /* SonarRenderPoint, reused */
  GArray *tracks;               /* SonarRenderTrack, reused */
};

G_DEFINE_TYPE (GstSonarViz, gst_sonar_viz, GST_TYPE_AGGREGATOR);
GST_ELEMENT_REGISTER_DEFINE_WITH_CODE (sonarviz, "sonarviz", GST_RANK_NONE,
    GST_TYPE_SONAR_VIZ, GST_DEBUG_CATEGORY_INIT (sonar_viz_debug,
        "sonarviz", 0, "energyscape and detections as video"));

#define VIDEO_CAPS "video/x-raw, format=(string)RGB, " \
  "width=(int)[ 160, 8192 ], height=(int)[ 160, 8192 ], " \
  "framerate=(fraction)[ 0/1, MAX ], pixel-aspect-ratio=(fraction)1/1"

static GstStaticPadTemplate sink_template = GST_STATIC_PAD_TEMPLATE ("sink",
    GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS (SONAR_ENERGYSCAPE_CAPS));
static GstStaticPadTemplate detections_template =
GST_STATIC_PAD_TEMPLATE ("detections", GST_PAD_SINK, GST_PAD_REQUEST,
    GST_STATIC_CAPS (SONAR_DETECTIONS_CAPS));
static GstStaticPadTemplate src_template = GST_STATIC_PAD_TEMPLATE ("src",
    GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS (VIDEO_CAPS));

/* Pads --------------------------------------------------------------------*/

static GstAggregatorPad *
gst_sonar_viz_create_new_pad (GstAggregator * agg, GstPadTemplate * templ,
    const gchar * req_name, const GstCaps * caps)
{
  GstSonarViz *self = GST_SONAR_VIZ (agg);
  GstAggregatorPad *pad = NULL;

  if (templ->direction != GST_PAD_SINK || templ->presence != GST_PAD_REQUEST
      || g_strcmp0 (templ->name_template, "detections") != 0)
    return NULL;
  GST_OBJECT_LOCK (self);
  if (!self->detections_pad) {
    pad = g_object_new (GST_TYPE_AGGREGATOR_PAD, "name", "detections",
        "direction", GST_PAD_SINK, "template", templ, NULL);
    self->detections_pad = pad;
  }
  GST_OBJECT_UNLOCK (self);
  if (!pad)
    GST_WARNING_OBJECT (self, "sonarviz has one detections pad");
  return pad;
}

static void
gst_sonar_viz_release_pad (GstElement * element, GstPad * pad)
{
  GstSonarViz *self = GST_SONAR_VIZ (element);

  GST_OBJECT_LOCK (self);
  if (pad == GST_PAD (self->detections_pad))
    self->detections_pad = NULL;
  GST_OBJECT_UNLOCK (self);
  GST_ELEMENT_CLASS (gst_sonar_viz_parent_class)->release_pad (element, pad);
}

/* Events ------------------------------------------------------------------*/

static gboolean
gst_sonar_viz_sink_event (GstAggregator * agg, GstAggregatorPad * pad,
    GstEvent * event)
{
  GstSonarViz *self = GST_SONAR_VIZ (agg);

  switch (GST_EVENT_TYPE (event)) {
    case GST_EVENT_CAPS:
      if (pad == self->scape_pad) {
        GstCaps *caps;
        SonarImageGrid grid;
        guint records;

        gst_event_parse_caps (event, &caps);
        if (!sonar_energyscape_caps_parse (caps, &grid, &records, NULL)) {
          GST_ELEMENT_ERROR (self, CORE, NEGOTIATION, ("sonarviz: the "
                  "energyscape caps are malformed: %" GST_PTR_FORMAT, caps),
              (NULL));
          gst_event_unref (event);
          return FALSE;
        }
        if (!self->have_grid || memcmp (&grid, &self->grid, sizeof grid)
            != 0)
          g_clear_pointer (&self->renderer, sonar_renderer_free);
        self->grid = grid;
        self->records = records;
        self->have_grid = TRUE;
      }
      /* The video's caps are the source pad's own. */
      gst_event_unref (event);
      return TRUE;
    case GST_EVENT_CUSTOM_DOWNSTREAM_STICKY:
      if (pad == self->scape_pad && sonar_event_is_setup (event)) {
        SonarSetup *setup = sonar_setup_from_event (event, NULL);
        gint n = 0, d = 1;

        /* The video runs at the ping rate. */
        if (setup && setup->ping_period > 0)
          gst_util_double_to_fraction (1.0 / setup->ping_period, &n, &d);
        if (n != self->fps_n || d != self->fps_d) {
          self->fps_n = n;
          self->fps_d = d;
          gst_pad_mark_reconfigure (GST_AGGREGATOR_SRC_PAD (agg));
        }
        g_clear_pointer (&setup, sonar_setup_unref);
      }
      /* The sonar's set-up and bank mean nothing to video elements. */
      gst_event_unref (event);
      return TRUE;
    default:
      return GST_AGGREGATOR_CLASS (gst_sonar_viz_parent_class)->sink_event
          (agg, pad, event);
  }
}

/* Negotiation and allocation ---------------------------------------------*/

static GstFlowReturn
gst_sonar_viz_update_src_caps (GstAggregator * agg, GstCaps * downstream,
    GstCaps ** ret)
{
  GstSonarViz *self = GST_SONAR_VIZ (agg);
  GstCaps *ours = gst_caps_from_string (VIDEO_CAPS);

  gst_caps_set_simple (ours, "framerate", GST_TYPE_FRACTION, self->fps_n,
      self->fps_d, NULL);
  *ret = gst_caps_intersect (downstream, ours);
  if (gst_caps_is_empty (*ret)) {
    GST_ELEMENT_ERROR (self, CORE, NEGOTIATION, ("sonarviz: downstream "
            "takes none of %" GST_PTR_FORMAT " (it takes %" GST_PTR_FORMAT
            "): after sonarviz, videoconvert converts the format, "
            "videoscale the size, videorate the frame rate", ours,
            downstream), (NULL));
    gst_caps_unref (ours);
    gst_clear_caps (ret);
    return GST_FLOW_NOT_NEGOTIATED;
  }
  gst_caps_unref (ours);
  return GST_FLOW_OK;
}

static GstCaps *
gst_sonar_viz_fixate_src_caps (GstAggregator * agg, GstCaps * caps)
{
  GstSonarViz *self = GST_SONAR_VIZ (agg);
  GstStructure *s;
  guint width, height;

  GST_OBJECT_LOCK (self);
  width = self->width;
  height = self->height;
  GST_OBJECT_UNLOCK (self);
  caps = gst_caps_truncate (gst_caps_make_writable (caps));
  s = gst_caps_get_structure (caps, 0);
  gst_structure_fixate_field_nearest_int (s, "width", (int) width);
  gst_structure_fixate_field_nearest_int (s, "height", (int) height);
  gst_structure_fixate_field_nearest_fraction (s, "framerate", self->fps_n,
      self->fps_d);
  return gst_caps_fixate (caps);
}

static gboolean
gst_sonar_viz_negotiated_src_caps (GstAggregator * agg, GstCaps * caps)
{
  GstSonarViz *self = GST_SONAR_VIZ (agg);
  GstVideoInfo info;

  if (!gst_video_info_from_caps (&info, caps))
    return FALSE;
  if (!self->negotiated || info.width != self->info.width
      || info.height != self->info.height)
    g_clear_pointer (&self->renderer, sonar_renderer_free);
  self->info = info;
  self->negotiated = TRUE;
  return TRUE;
}

static gboolean
gst_sonar_viz_decide_allocation (GstAggregator * agg, GstQuery * query)
{
  GstBufferPool *pool = NULL;
  GstStructure *config;
  GstCaps *caps;
  GstVideoInfo info;
  guint size, min = 2, max = 0;

  gst_query_parse_allocation (query, &caps, NULL);
  if (!caps || !gst_video_info_from_caps (&info, caps))
    return FALSE;
  size = (guint) info.size;
  if (gst_query_get_n_allocation_pools (query) > 0) {
    gst_query_parse_nth_allocation_pool (query, 0, &pool, &size, &min, &max);
    size = MAX (size, (guint) info.size);
    min = MAX (min, 2);
  }
  if (!pool)
    pool = gst_video_buffer_pool_new ();
  config = gst_buffer_pool_get_config (pool);
  gst_buffer_pool_config_set_params (config, caps, size, min, max);
  if (!gst_buffer_pool_set_config (pool, config)) {
    /* A downstream pool that wants other settings: our own. */
    gst_object_unref (pool);
    pool = gst_video_buffer_pool_new ();
    config = gst_buffer_pool_get_config (pool);
    gst_buffer_pool_config_set_params (config, caps, (guint) info.size, 2,
        0);
    if (!gst_buffer_pool_set_config (pool, config)) {
      gst_object_unref (pool);
      return FALSE;
    }
    size = (guint) info.size;
    min = 2;
    max = 0;
  }
  if (gst_query_get_n_allocation_pools (query) > 0)
    gst_query_set_nth_allocation_pool (query, 0, pool, size, min, max);
  else
    gst_query_add_allocation_pool (query, pool, size, min, max);
  gst_object_unref (pool);
  return TRUE;
}

/* Drawing -----------------------------------------------------------------*/

static void
add_truths (GstSonarViz * self, GstBuffer * buffer)
{
  SonarTruthMeta *meta = buffer ? sonar_buffer_get_truth_meta (buffer) :
      NULL;

  if (!meta || self->truths->len > 0)
    return;
  for (guint k = 0; k < meta->n_truths; k++) {
    const SonarTruth *t = &meta->truths[k];
    SonarRenderPoint p = { t->range, t->azimuth, t->elevation,
      t->radial_velocity, FALSE
    };
    g_array_append_val (self->truths, p);
  }
}

static void
add_detections (GstSonarViz * self, const SonarDetectionsMeta * meta,
    gboolean show_rejected)
{
  for (guint k = 0; meta && k < meta->n_detections; k++) {
    const SonarDetection *d = &meta->detections[k];
    SonarRenderPoint p = { d->range, d->azimuth, d->elevation,
      d->radial_velocity, !d->valid
    };
    if (d->valid || show_rejected)
      g_array_append_val (self->detections, p);
  }
}

/* The confirmed tracks (a tentative one may be noise that the next pings
 * drop). */
static void
add_tracks (GstSonarViz * self, const SonarTracksMeta * meta)
{
  for (guint k = 0; meta && k < meta->n_tracks; k++) {
    const SonarTrack *t = &meta->tracks[k];
    SonarRenderTrack r = { t->id, {t->position.x, t->position.y,
            t->position.z}, {t->velocity.x, t->velocity.y, t->velocity.z}
    };
    if (t->state == SONAR_TRACK_CONFIRMED)
      g_array_append_val (self->tracks, r);
  }
}

/* The energyscape's ping and records; FALSE (with an error posted) when
 * the buffer is not what its caps say. */
static gboolean
check_energyscape (GstSonarViz * self, GstMapInfo * map, guint64 * ping,
    gsize * record_stride)
{
  const gsize pixels = sonar_image_grid_size (&self->grid);
  const gsize record_size = sizeof (SonarEnergyscapeHeader) +
      pixels * sizeof (float);
  SonarImageGrid grid;

  if (map->size < self->records * record_size
      || !sonar_energyscape_header_parse ((const SonarEnergyscapeHeader *)
          map->data, &grid) || sonar_image_grid_size (&grid) != pixels) {
    GST_ELEMENT_ERROR (self, STREAM, FORMAT, ("sonarviz: an energyscape "
            "buffer of %" G_GSIZE_FORMAT " bytes, but its caps say %u "
            "record(s) of %" G_GSIZE_FORMAT " bytes, each starting with a "
            "\"" SONAR_ENERGYSCAPE_MAGIC "\" header (docs/CONTRACTS.md, "
            "section 7)", map->size, self->records, record_size), (NULL));
    return FALSE;
  }
  *ping = ((const SonarEnergyscapeHeader *) map->data)->ping_index;
  *record_stride = record_size / sizeof (float);
  return TRUE;
}

/* @detections: the ping's, or NULL (@detections_missing: a detections pad
 * had none for it). */
static GstFlowReturn
render (GstSonarViz * self, GstBuffer * scape, GstBuffer * detections,
    gboolean detections_missing, GstBuffer ** out)
{
  GstAggregator *agg = GST_AGGREGATOR (self);
  SonarDetectionsMeta *dmeta = detections ?
      sonar_buffer_get_detections_meta (detections) : NULL;
  SonarTracksMeta *track_meta = detections ?
      sonar_buffer_get_tracks_meta (detections) : NULL;
  SonarRenderFrame frame = { 0 };
  GstBufferPool *pool;
  GstVideoFrame video;
  GstMapInfo map;
  GstFlowReturn ret;
  gsize stride;
  guint64 ping;
  gboolean show_truth, show_rejected, show_tracks;

  GST_OBJECT_LOCK (self);
  frame.dynamic_range = self->dynamic_range;
  frame.range_compensation = self->range_compensation;
  show_truth = self->show_truth;
  show_rejected = self->show_rejected;
  show_tracks = self->show_tracks;
  frame.arrow_time = self->arrow_time;
  GST_OBJECT_UNLOCK (self);

  if (!self->renderer) {
    GError *error = NULL;
    self->renderer = sonar_renderer_new (&self->grid,
        GST_VIDEO_INFO_WIDTH (&self->info),
        GST_VIDEO_INFO_HEIGHT (&self->info), &error);
    if (!self->renderer) {
      SONAR_ELEMENT_POST_ERROR (self, error, NULL);
      g_error_free (error);
      return GST_FLOW_NOT_NEGOTIATED;
    }
  }

  pool = gst_aggregator_get_buffer_pool (agg);
  if (!pool)
    return GST_FLOW_NOT_NEGOTIATED;
  if (!gst_buffer_pool_is_active (pool))
    gst_buffer_pool_set_active (pool, TRUE);
  ret = gst_buffer_pool_acquire_buffer (pool, out, NULL);
  gst_object_unref (pool);
  if (ret != GST_FLOW_OK)
    return ret;

  if (!gst_buffer_map (scape, &map, GST_MAP_READ))
    return GST_FLOW_ERROR;
  if (!check_energyscape (self, &map, &ping, &stride)) {
    gst_buffer_unmap (scape, &map);
    return GST_FLOW_ERROR;
  }
  g_array_set_size (self->truths, 0);
  g_array_set_size (self->detections, 0);
  if (show_truth) {
    add_truths (self, scape);
    add_truths (self, detections);
  }
  add_detections (self, dmeta, show_rejected);
  g_array_set_size (self->tracks, 0);
  if (show_tracks)
    add_tracks (self, track_meta);
  frame.image = (const float *) (map.data + sizeof (SonarEnergyscapeHeader));
  frame.records = self->records;
  frame.record_stride = stride;
  frame.truths = (const SonarRenderPoint *) self->truths->data;
  frame.n_truths = self->truths->len;
  frame.detections = (const SonarRenderPoint *) self->detections->data;
  frame.n_detections = self->detections->len;
  frame.detections_missing = detections_missing;
  frame.tracks = (const SonarRenderTrack *) self->tracks->data;
  frame.n_tracks = self->tracks->len;
  frame.ping = (gint64) ping;
  frame.time = GST_BUFFER_PTS_IS_VALID (scape) ?
      (double) GST_BUFFER_PTS (scape) / GST_SECOND : NAN;

  if (!gst_video_frame_map (&video, &self->info, *out, GST_MAP_WRITE)) {
    gst_buffer_unmap (scape, &map);
    return GST_FLOW_ERROR;
  }
  sonar_renderer_draw (self->renderer, &frame,
      GST_VIDEO_FRAME_PLANE_DATA (&video, 0),
      GST_VIDEO_FRAME_PLANE_STRIDE (&video, 0));
  gst_video_frame_unmap (&video);
  gst_buffer_unmap (scape, &map);

  /* What the frame shows, for applications (and tests). */
  {
    SonarTruthMeta *tmeta = sonar_buffer_get_truth_meta (scape);
    if (!tmeta && detections)
      tmeta = sonar_buffer_get_truth_meta (detections);
    if (tmeta)
      sonar_buffer_add_truth_meta (*out, tmeta->ping_index, tmeta->truths,
          tmeta->n_truths);
    if (dmeta)
      sonar_buffer_add_detections_meta (*out, dmeta->ping_index,
          dmeta->detections, dmeta->n_detections);
    if (track_meta && show_tracks)
      sonar_buffer_add_tracks_meta (*out, track_meta->ping_index,
          &track_meta->ego, track_meta->tracks, track_meta->n_tracks);
  }
  GST_BUFFER_PTS (*out) = GST_BUFFER_PTS (scape);
  GST_BUFFER_DURATION (*out) = GST_BUFFER_DURATION (scape);
  if (!GST_BUFFER_DURATION_IS_VALID (scape) && self->fps_n > 0)
    GST_BUFFER_DURATION (*out) = gst_util_uint64_scale (GST_SECOND,
        self->fps_d, self->fps_n);
  GST_BUFFER_OFFSET (*out) = ping;
  return GST_FLOW_OK;
}

/* The detections buffer of @ping on @pad, dropping older pings'. NULL when
 * the next one is of a later ping (this ping has none) or the pad is at
 * its end; *wait when it has no buffer yet. */
static GstFlowReturn
detections_for_ping (GstSonarViz * self, GstAggregatorPad * pad,
    guint64 ping, GstBuffer ** detections, gboolean * wait)
{
  GstBuffer *buffer;

  *detections = NULL;
  *wait = FALSE;
  while ((buffer = gst_aggregator_pad_peek_buffer (pad))) {
    SonarDetectionsMeta *meta = sonar_buffer_get_detections_meta (buffer);

    if (!meta) {
      gboolean gap = GST_BUFFER_FLAG_IS_SET (buffer, GST_BUFFER_FLAG_GAP);
      gst_buffer_unref (buffer);
      if (gap) {
        gst_aggregator_pad_drop_buffer (pad);
        continue;
      }
      GST_ELEMENT_ERROR (self, STREAM, FORMAT, ("sonarviz: the detections "
              "pad takes velocityest's output, a SonarDetectionsMeta on "
              "every buffer (... ! velocityest ! sonarviz.detections), or "
              "sonartrack's, which carries it on"), (NULL));
      return GST_FLOW_ERROR;
    }
    if (meta->ping_index < ping) {
      GST_LOG_OBJECT (self, "detections of ping %" G_GUINT64_FORMAT
          " have no image", meta->ping_index);
      gst_buffer_unref (buffer);
      gst_aggregator_pad_drop_buffer (pad);
      continue;
    }
    if (meta->ping_index == ping)
      *detections = buffer;
    else
      gst_buffer_unref (buffer);
    return GST_FLOW_OK;
  }
  *wait = !gst_aggregator_pad_is_eos (pad);
  return GST_FLOW_OK;
}

static GstFlowReturn
gst_sonar_viz_aggregate (GstAggregator * agg, gboolean timeout)
{
  GstSonarViz *self = GST_SONAR_VIZ (agg);
  GstAggregatorPad *det_pad;
  GstBuffer *scape, *detections = NULL, *out = NULL;
  GstFlowReturn ret = GST_FLOW_OK;
  SonarEnergyscapeHeader header;
  gboolean wait = FALSE;

  scape = gst_aggregator_pad_peek_buffer (self->scape_pad);
  if (!scape) {
    if (gst_aggregator_pad_is_eos (self->scape_pad))
      return GST_FLOW_EOS;
    return GST_AGGREGATOR_FLOW_NEED_DATA;
  }
  if (gst_buffer_get_size (scape) == 0) {
    /* A gap: nothing to draw. */
    gst_buffer_unref (scape);
    gst_aggregator_pad_drop_buffer (self->scape_pad);
    return GST_FLOW_OK;
  }
  if (!self->have_grid) {
    gst_buffer_unref (scape);
    GST_ELEMENT_ERROR (self, CORE, NEGOTIATION, ("sonarviz: an energyscape "
            "arrived before its caps"), (NULL));
    return GST_FLOW_NOT_NEGOTIATED;
  }
  if (gst_buffer_extract (scape, 0, &header, sizeof header) != sizeof header) {
    gst_buffer_unref (scape);
    GST_ELEMENT_ERROR (self, STREAM, FORMAT, ("sonarviz: an energyscape "
            "buffer shorter than its header"), (NULL));
    return GST_FLOW_ERROR;
  }

  GST_OBJECT_LOCK (self);
  det_pad = self->detections_pad ? gst_object_ref (self->detections_pad) :
      NULL;
  GST_OBJECT_UNLOCK (self);
  if (det_pad) {
    ret = detections_for_ping (self, det_pad, header.ping_index,
        &detections, &wait);
    if (ret == GST_FLOW_OK && wait)
      ret = GST_AGGREGATOR_FLOW_NEED_DATA;
  }
  if (ret == GST_FLOW_OK && !self->negotiated
      && !gst_aggregator_negotiate (agg))
    ret = GST_FLOW_NOT_NEGOTIATED;
  if (ret == GST_FLOW_OK)
    ret = render (self, scape, detections, det_pad && !detections, &out);
  if (ret == GST_FLOW_OK) {
    GstAggregatorPad *src = GST_AGGREGATOR_PAD (GST_AGGREGATOR_SRC_PAD (agg));

    gst_aggregator_selected_samples (agg, GST_BUFFER_PTS (out),
        GST_CLOCK_TIME_NONE, GST_BUFFER_DURATION (out), NULL);
    gst_aggregator_pad_drop_buffer (self->scape_pad);
    if (detections)
      gst_aggregator_pad_drop_buffer (det_pad);
    if (GST_BUFFER_PTS_IS_VALID (out)) {
      GST_OBJECT_LOCK (src);
      src->segment.position = GST_BUFFER_PTS (out);
      GST_OBJECT_UNLOCK (src);
    }
    ret = gst_aggregator_finish_buffer (agg, out);
    out = NULL;
  }
  gst_clear_buffer (&out);
  gst_clear_buffer (&detections);
  gst_buffer_unref (scape);
  gst_clear_object (&det_pad);
  return ret;
}

/* State ------------------------------------------------------------------*/

static gboolean
gst_sonar_viz_stop (GstAggregator * agg)
{
  GstSonarViz *self = GST_SONAR_VIZ (agg);

  g_clear_pointer (&self->renderer, sonar_renderer_free);
  self->negotiated = FALSE;
  self->have_grid = FALSE;
  return TRUE;
}

static void
gst_sonar_viz_set_property (GObject * object, guint prop_id,
    const GValue * value, GParamSpec * pspec)
{
  GstSonarViz *self = GST_SONAR_VIZ (object);
  gboolean resize = FALSE;

  if (!gst_sonar_property_settable (GST_ELEMENT (object), pspec))
    return;

  GST_OBJECT_LOCK (self);
  switch (prop_id) {
    case PROP_WIDTH:
      resize = self->width != g_value_get_uint (value);
      self->width = g_value_get_uint (value);
      break;
    case PROP_HEIGHT:
      resize = self->height != g_value_get_uint (value);
      self->height = g_value_get_uint (value);
      break;
    case PROP_DYNAMIC_RANGE:
      self->dynamic_range = g_value_get_double (value);
      break;
    case PROP_RANGE_COMPENSATION:
      self->range_compensation = g_value_get_boolean (value);
      break;
    case PROP_SHOW_TRUTH:
      self->show_truth = g_value_get_boolean (value);
      break;
    case PROP_SHOW_REJECTED:
      self->show_rejected = g_value_get_boolean (value);
      break;
    case PROP_SHOW_TRACKS:
      self->show_tracks = g_value_get_boolean (value);
      break;
    case PROP_ARROW_TIME:
      self->arrow_time = g_value_get_double (value);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID (object, prop_id, pspec);
      break;
  }
  GST_OBJECT_UNLOCK (self);
  /* A new size is negotiated before the next frame. */
  if (resize)
    gst_pad_mark_reconfigure (GST_AGGREGATOR_SRC_PAD (self));
}

static void
gst_sonar_viz_get_property (GObject * object, guint prop_id, GValue * value,
    GParamSpec * pspec)
{
  GstSonarViz *self = GST_SONAR_VIZ (object);

  GST_OBJECT_LOCK (self);
  switch (prop_id) {
    case PROP_WIDTH:
      g_value_set_uint (value, self->width);
      break;
    case PROP_HEIGHT:
      g_value_set_uint (value, self->height);
      break;
    case PROP_DYNAMIC_RANGE:
      g_value_set_double (value, self->dynamic_range);
      break;
    case PROP_RANGE_COMPENSATION:
      g_value_set_boolean (value, self->range_compensation);
      break;
    case PROP_SHOW_TRUTH:
      g_value_set_boolean (value, self->show_truth);
      break;
    case PROP_SHOW_REJECTED:
      g_value_set_boolean (value, self->show_rejected);
      break;
    case PROP_SHOW_TRACKS:
      g_value_set_boolean (value, self->show_tracks);
      break;
    case PROP_ARROW_TIME:
      g_value_set_double (value, self->arrow_time);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID (object, prop_id, pspec);
      break;
  }
  GST_OBJECT_UNLOCK (self);
}

static void
gst_sonar_viz_finalize (GObject * object)
{
  GstSonarViz *self = GST_SONAR_VIZ (object);

  sonar_renderer_free (self->renderer);
  g_array_unref (self->truths);
  g_array_unref (self->detections);
  g_array_unref (self->tracks);
  G_OBJECT_CLASS (gst_sonar_viz_parent_class)->finalize (object);
}

static void
gst_sonar_viz_init (GstSonarViz * self)
{
  GstPadTemplate *templ = gst_static_pad_template_get (&sink_template);

  self->scape_pad = g_object_new (GST_TYPE_AGGREGATOR_PAD, "name", "sink",
      "direction", GST_PAD_SINK, "template", templ, NULL);
  gst_object_unref (templ);
  gst_element_add_pad (GST_ELEMENT (self), GST_PAD (self->scape_pad));

  self->width = DEFAULT_WIDTH;
  self->height = DEFAULT_HEIGHT;
  self->dynamic_range = DEFAULT_DYNAMIC_RANGE;
  self->range_compensation = DEFAULT_RANGE_COMPENSATION;
  self->show_truth = DEFAULT_SHOW_TRUTH;
  self->show_rejected = DEFAULT_SHOW_REJECTED;
  self->show_tracks = DEFAULT_SHOW_TRACKS;
  self->arrow_time = DEFAULT_ARROW_TIME;
  self->fps_n = 0;
  self->fps_d = 1;
  self->truths = g_array_new (FALSE, FALSE, sizeof (SonarRenderPoint));
  self->detections = g_array_new (FALSE, FALSE, sizeof (SonarRenderPoint));
  self->tracks = g_array_new (FALSE, FALSE, sizeof (SonarRenderTrack));
}

static void
gst_sonar_viz_class_init (GstSonarVizClass * klass)
{
  GObjectClass *gobject_class = G_OBJECT_CLASS (klass);
  GstElementClass *element_class = GST_ELEMENT_CLASS (klass);
  GstAggregatorClass *agg_class = GST_AGGREGATOR_CLASS (klass);
  /* Display settings: they take effect at the next ping. */
  const GParamFlags flags = G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS
      | GST_PARAM_MUTABLE_PLAYING;

  gobject_class->set_property = gst_sonar_viz_set_property;
  gobject_class->get_property = gst_sonar_viz_get_property;
  gobject_class->finalize = gst_sonar_viz_finalize;

  g_object_class_install_property (gobject_class, PROP_WIDTH,
      g_param_spec_uint ("width", "Width", "Frame width in pixels, unless "
          "downstream's caps fix another", SONAR_RENDER_MIN_SIZE,
          SONAR_RENDER_MAX_SIZE, DEFAULT_WIDTH, flags));
  g_object_class_install_property (gobject_class, PROP_HEIGHT,
      g_param_spec_uint ("height", "Height", "Frame height in pixels, unless "
          "downstream's caps fix another", SONAR_RENDER_MIN_SIZE,
          SONAR_RENDER_MAX_SIZE, DEFAULT_HEIGHT, flags));
  g_object_class_install_property (gobject_class, PROP_DYNAMIC_RANGE,
      g_param_spec_double ("dynamic-range", "Dynamic range", "dB below the "
          "frame's strongest pixel that the colour scale spans; weaker "
          "pixels take its lowest colour", 1.0, 200.0,
          DEFAULT_DYNAMIC_RANGE, flags));
  g_object_class_install_property (gobject_class, PROP_RANGE_COMPENSATION,
      g_param_spec_boolean ("range-compensation", "Range compensation",
          "Colour the image times r^2, the spreading loss undone (as "
          "wardcluster sees it), so that far objects look as strong as near "
          "ones; off: the envelope as imaged", DEFAULT_RANGE_COMPENSATION,
          flags));
  g_object_class_install_property (gobject_class, PROP_SHOW_TRUTH,
      g_param_spec_boolean ("show-truth", "Show truth", "Ring each true "
          "object in white when the pings carry their ground truth "
          "(sonarsrc's SonarTruthMeta)", DEFAULT_SHOW_TRUTH, flags));
  g_object_class_install_property (gobject_class, PROP_SHOW_REJECTED,
      g_param_spec_boolean ("show-rejected", "Show rejected", "Draw the "
          "detections velocityest rejected as false positives too, in grey "
          "(with its keep-rejected=true)", DEFAULT_SHOW_REJECTED, flags));
  g_object_class_install_property (gobject_class, PROP_SHOW_TRACKS,
      g_param_spec_boolean ("show-tracks", "Show tracks", "Draw the "
          "confirmed tracks in magenta when the detections pad takes "
          "sonartrack's output: a square labelled with the track's id and "
          "an arrow of its velocity in the world", DEFAULT_SHOW_TRACKS,
          flags));
  g_object_class_install_property (gobject_class, PROP_ARROW_TIME,
      g_param_spec_double ("arrow-time", "Arrow time", "Seconds of motion "
          "a track's arrow shows: it ends where the track's world velocity "
          "takes it in this long (0.5: an arrow of 1.5 m at 3 m/s; in the "
          "3-D map, the direction it turns to)", 0.01, 60.0,
          DEFAULT_ARROW_TIME, flags));

  gst_element_class_add_static_pad_template_with_gtype (element_class,
      &sink_template, GST_TYPE_AGGREGATOR_PAD);
  gst_element_class_add_static_pad_template_with_gtype (element_class,
      &detections_template, GST_TYPE_AGGREGATOR_PAD);
  gst_element_class_add_static_pad_template_with_gtype (element_class,
      &src_template, GST_TYPE_AGGREGATOR_PAD);
  gst_element_class_set_static_metadata (element_class,
      "Sonar energyscape display", "Visualization/Sonar",
      "Draws each ping's energyscape (a fan in metres, or azimuth x "
      "elevation in 3-D) on a dB colour scale with a legend, each detection "
      "labelled with its radial velocity (red approaching, green receding "
      "or still), the ground truth ringed and sonartrack's tracks with "
      "their ids and velocity arrows, as RGB video",
      "gst-sonar-velocity developers");

  element_class->release_pad = GST_DEBUG_FUNCPTR (gst_sonar_viz_release_pad);
  agg_class->create_new_pad = GST_DEBUG_FUNCPTR (gst_sonar_viz_create_new_pad);
  agg_class->sink_event = GST_DEBUG_FUNCPTR (gst_sonar_viz_sink_event);
  agg_class->update_src_caps = GST_DEBUG_FUNCPTR (gst_sonar_viz_update_src_caps);
  agg_class->fixate_src_caps = GST_DEBUG_FUNCPTR (gst_sonar_viz_fixate_src_caps);
  agg_class->negotiated_src_caps =
      GST_DEBUG_FUNCPTR (gst_sonar_viz_negotiated_src_caps);
  agg_class->decide_allocation =
      GST_DEBUG_FUNCPTR (gst_sonar_viz_decide_allocation);
  agg_class->aggregate = GST_DEBUG_FUNCPTR (gst_sonar_viz_aggregate);
  agg_class->stop = GST_DEBUG_FUNCPTR (gst_sonar_viz_stop);
}
