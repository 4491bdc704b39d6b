/* gstwardcluster.c: wardcluster, the reflectors' centroids (paper Section
 * III.A, Fig. 5).
 *
 * Keeps the pixels that stand above the noise at a set probability of
 * false alarm per pixel (pfa, for an image that is the maximum over the
 * caps' "hypotheses"), above the noise floor along their direction
 * (cross-talk ridges) and above the sidelobes of their range's strongest
 * pixel (and, if set, relative to the ping's maximum and absolutely),
 * finds their local peaks and merges them by agglomerative
 * hierarchical clustering (Ward's minimum variance by default; single,
 * complete, average and centroid linkage for comparison), stopping where
 * the inconsistency of the last levels jumps (or at a distance). The image
 * passes through unchanged with a SonarCentroidsMeta; each ping's centroids
 * are also posted as a "sonar-centroids" element message.
 *
 * With range-compensation (the default) the thresholds and the clustering
 * see the image times r^2 (sonar-cluster.h).
 */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstwardcluster.h"
#include "sonar-workers.h"

GST_DEBUG_CATEGORY_STATIC (ward_cluster_debug);
#define GST_CAT_DEFAULT ward_cluster_debug

/* Centroids per ping, the strongest kept (max-centroids; docs/CONTRACTS.md,
 * section 8): more is noise clustered into dust, not reflectors. The
 * default holds a 20 x 20 grid of objects (400, each its own centroid);
 * the array is allocated when the caps are set, (max-centroids + 1) x
 * sizeof (SonarCentroid) (104) bytes: 0.1 MB at the default, 0.4 MB at
 * most. */
#define DEFAULT_MAX_CENTROIDS 1024
#define MAX_MAX_CENTROIDS 4096
#define DEFAULT_POST_MESSAGES TRUE

/* From the core's table of linkage methods (sonar-linkage.c). */
#define GST_TYPE_SONAR_LINKAGE (sonar_linkage_get_type ())
static GType
sonar_linkage_get_type (void)
{
  static GType type = 0;

  if (g_once_init_enter (&type)) {
    guint n;
    const SonarLinkageInfo *methods = sonar_linkage_methods (&n);
    /* Registered for the process's lifetime, as a static table would be. */
    GEnumValue *values = g_new0 (GEnumValue, n + 1);
    for (guint i = 0; i < n; i++) {
      values[i].value = methods[i].linkage;
      values[i].value_name = methods[i].description;
      values[i].value_nick = methods[i].nick;
    }
    g_once_init_leave (&type, g_enum_register_static ("GstSonarLinkage",
            values));
  }
  return type;
}

#define GST_TYPE_SONAR_STOP (sonar_stop_get_type ())
static GType
sonar_stop_get_type (void)
{
  static GType type = 0;
  static const GEnumValue values[] = {
    {SONAR_STOP_INCONSISTENCY, "Inconsistency of the last merge levels",
        "inconsistency"},
    {SONAR_STOP_DISTANCE, "Merge height above distance", "distance"},
    {0, NULL, NULL}
  };
  if (g_once_init_enter (&type))
    g_once_init_leave (&type, g_enum_register_static ("GstSonarStop",
            values));
  return type;
}

enum
{
  PROP_0,
  PROP_THRESHOLD,
  PROP_ABSOLUTE_THRESHOLD,
  PROP_SIDELOBE,
  PROP_PFA,
  PROP_LINKAGE,
  PROP_STOP,
  PROP_INCONSISTENCY,
  PROP_DEPTH,
  PROP_DISTANCE,
  PROP_MAX_PEAKS,
  PROP_MAX_CENTROIDS,
  PROP_RANGE_COMPENSATION,
  PROP_THREADS,
  PROP_POST_MESSAGES,
};

struct _GstWardCluster
{
  GstSonarFilter parent;

  SonarClusterParams params;    /* protected by the object lock */
  gboolean retune;              /* params changed while playing: at the
                                 * next ping (object lock) */
  gboolean post_messages;

  SonarClusterer *clusterer;
  SonarImageGrid grid;
  guint hypotheses;             /* the energyscape caps' */
  guint max_centroids;          /* the property (object lock) */
  guint capacity;               /* centroids kept, set when configured */
  /* capacity + 1: room for one more tells when some were dropped. */
  SonarCentroid *centroids;
  gboolean warned_dropped;      /* the bus warning is posted once */
};

G_DEFINE_TYPE (GstWardCluster, gst_ward_cluster, GST_TYPE_SONAR_FILTER);
GST_ELEMENT_REGISTER_DEFINE_WITH_CODE (wardcluster, "wardcluster",
    GST_RANK_NONE, GST_TYPE_WARD_CLUSTER,
    GST_DEBUG_CATEGORY_INIT (ward_cluster_debug, "wardcluster", 0,
        "hierarchical clustering of sonar images"));

static GstStaticPadTemplate sink_template = GST_STATIC_PAD_TEMPLATE ("sink",
    GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS (SONAR_ENERGYSCAPE_CAPS));
static GstStaticPadTemplate src_template = GST_STATIC_PAD_TEMPLATE ("src",
    GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS (SONAR_ENERGYSCAPE_CAPS));

static GstCaps *
gst_ward_cluster_configure (GstSonarFilter * filter, GstCaps * in_caps,
    GError ** error)
{
  GstWardCluster *self = GST_WARD_CLUSTER (filter);
  SonarClusterParams params;
  guint records, hypotheses;

  if (!in_caps || !sonar_energyscape_caps_parse (in_caps, &self->grid,
          &records, &hypotheses) || records != 1) {
    g_set_error (error, GST_CORE_ERROR, GST_CORE_ERROR_NEGOTIATION,
        "wardcluster: it needs one energyscape per ping (mimobeamform "
        "mode=detection or mode=fixed, not datacube)");
    return NULL;
  }
  GST_OBJECT_LOCK (self);
  params = self->params;
  GST_OBJECT_UNLOCK (self);
  params.hypotheses = hypotheses;
  self->hypotheses = hypotheses;
  self->clusterer = sonar_clusterer_new (&self->grid, &params, error);
  if (!self->clusterer)
    return NULL;
  GST_OBJECT_LOCK (self);
  self->capacity = self->max_centroids;
  GST_OBJECT_UNLOCK (self);
  g_free (self->centroids);
  self->centroids = g_new (SonarCentroid, self->capacity + 1);
  self->warned_dropped = FALSE;
  return gst_caps_ref (in_caps);
}

static void
gst_ward_cluster_unconfigure (GstSonarFilter * filter)
{
  g_clear_pointer (&GST_WARD_CLUSTER (filter)->clusterer,
      sonar_clusterer_free);
  g_clear_pointer (&GST_WARD_CLUSTER (filter)->centroids, g_free);
}

/* Thresholds and the stop criterion set while playing take effect at the
 * next ping (sonar_clusterer_retune ()). */
static void
retune (GstWardCluster * self)
{
  SonarClusterParams params;
  GError *error = NULL;

  GST_OBJECT_LOCK (self);
  params = self->params;
  if (!self->retune) {
    GST_OBJECT_UNLOCK (self);
    return;
  }
  self->retune = FALSE;
  GST_OBJECT_UNLOCK (self);
  params.hypotheses = self->hypotheses;
  if (!sonar_clusterer_retune (self->clusterer, &params, &error)) {
    /* The properties' ranges keep the values valid: this would be a bug. */
    GST_ELEMENT_WARNING (self, LIBRARY, SETTINGS, ("%s", error->message),
        (NULL));
    g_error_free (error);
  }
}

static GstFlowReturn
gst_ward_cluster_process (GstSonarFilter * filter, GstBuffer * buffer)
{
  GstWardCluster *self = GST_WARD_CLUSTER (filter);
  const gsize expected = sizeof (SonarEnergyscapeHeader) + sizeof (float) *
      sonar_image_grid_size (&self->grid);
  const SonarEnergyscapeHeader *header;
  GstMapInfo map;
  guint64 ping;
  guint n;

  if (gst_buffer_get_size (buffer) != expected) {
    GST_ELEMENT_ERROR (self, STREAM, FORMAT, ("An energyscape of %"
            G_GSIZE_FORMAT " bytes, expected %" G_GSIZE_FORMAT,
            gst_buffer_get_size (buffer), expected), (NULL));
    gst_buffer_unref (buffer);
    return GST_FLOW_ERROR;
  }
  retune (self);
  gst_buffer_map (buffer, &map, GST_MAP_READ);
  header = (const SonarEnergyscapeHeader *) map.data;
  ping = header->ping_index;
  n = sonar_clusterer_process (self->clusterer,
      (const float *) (map.data + sizeof (SonarEnergyscapeHeader)),
      self->centroids, self->capacity + 1);
  gst_buffer_unmap (buffer, &map);
  if (n > self->capacity) {
    n = self->capacity;
    if (!self->warned_dropped) {
      self->warned_dropped = TRUE;
      GST_ELEMENT_WARNING (self, STREAM, FAILED, ("wardcluster: ping %"
              G_GUINT64_FORMAT " has more than %u centroids: only the %u "
              "strongest are kept, on this ping and any other (a smaller pfa, "
              "a higher threshold, or stop=distance with a larger distance, "
              "gives fewer)", ping, self->capacity, self->capacity), (NULL));
    }
  }
  GST_LOG_OBJECT (self, "ping %" G_GUINT64_FORMAT ": %u peaks, %u centroids",
      ping, sonar_clusterer_n_peaks (self->clusterer), n);

  buffer = gst_buffer_make_writable (buffer);
  sonar_buffer_add_centroids_meta (buffer, ping, self->centroids, n);
  if (self->post_messages)
    gst_sonar_post_ping_message (GST_ELEMENT (self),
        gst_sonar_filter_get_segment (filter), GST_BUFFER_PTS (buffer),
        sonar_centroids_to_structure (ping, GST_BUFFER_PTS (buffer),
            self->centroids, n));
  return gst_sonar_filter_push (filter, buffer);
}

static void
gst_ward_cluster_set_property (GObject * object, guint prop_id,
    const GValue * value, GParamSpec * pspec)
{
  GstWardCluster *self = GST_WARD_CLUSTER (object);
  SonarClusterParams *p = &self->params;

  if (!gst_sonar_property_settable (GST_ELEMENT (object), pspec))
    return;

  GST_OBJECT_LOCK (self);
  switch (prop_id) {
    case PROP_THRESHOLD:
      p->threshold_db = g_value_get_double (value);
      break;
    case PROP_ABSOLUTE_THRESHOLD:
      p->absolute_threshold = g_value_get_double (value);
      break;
    case PROP_SIDELOBE:
      p->sidelobe_db = g_value_get_double (value);
      break;
    case PROP_PFA:
      p->pfa = g_value_get_double (value);
      break;
    case PROP_LINKAGE:
      p->linkage = g_value_get_enum (value);
      break;
    case PROP_STOP:
      p->stop = g_value_get_enum (value);
      break;
    case PROP_INCONSISTENCY:
      p->inconsistency = g_value_get_double (value);
      break;
    case PROP_DEPTH:
      p->depth = g_value_get_uint (value);
      break;
    case PROP_DISTANCE:
      p->distance = g_value_get_double (value);
      break;
    case PROP_MAX_PEAKS:
      p->max_peaks = g_value_get_uint (value);
      break;
    case PROP_POST_MESSAGES:
      self->post_messages = g_value_get_boolean (value);
      break;
    case PROP_MAX_CENTROIDS:
      self->max_centroids = g_value_get_uint (value);
      break;
    case PROP_RANGE_COMPENSATION:
      p->range_compensation = g_value_get_boolean (value);
      break;
    case PROP_THREADS:
      p->threads = g_value_get_uint (value);
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
gst_ward_cluster_get_property (GObject * object, guint prop_id,
    GValue * value, GParamSpec * pspec)
{
  GstWardCluster *self = GST_WARD_CLUSTER (object);
  const SonarClusterParams *p = &self->params;

  GST_OBJECT_LOCK (self);
  switch (prop_id) {
    case PROP_THRESHOLD:
      g_value_set_double (value, p->threshold_db);
      break;
    case PROP_ABSOLUTE_THRESHOLD:
      g_value_set_double (value, p->absolute_threshold);
      break;
    case PROP_SIDELOBE:
      g_value_set_double (value, p->sidelobe_db);
      break;
    case PROP_PFA:
      g_value_set_double (value, p->pfa);
      break;
    case PROP_LINKAGE:
      g_value_set_enum (value, p->linkage);
      break;
    case PROP_STOP:
      g_value_set_enum (value, p->stop);
      break;
    case PROP_INCONSISTENCY:
      g_value_set_double (value, p->inconsistency);
      break;
    case PROP_DEPTH:
      g_value_set_uint (value, p->depth);
      break;
    case PROP_DISTANCE:
      g_value_set_double (value, p->distance);
      break;
    case PROP_MAX_PEAKS:
      g_value_set_uint (value, p->max_peaks);
      break;
    case PROP_POST_MESSAGES:
      g_value_set_boolean (value, self->post_messages);
      break;
    case PROP_MAX_CENTROIDS:
      g_value_set_uint (value, self->max_centroids);
      break;
    case PROP_RANGE_COMPENSATION:
      g_value_set_boolean (value, p->range_compensation);
      break;
    case PROP_THREADS:
      g_value_set_uint (value, p->threads);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID (object, prop_id, pspec);
      break;
  }
  GST_OBJECT_UNLOCK (self);
}

static void
gst_ward_cluster_init (GstWardCluster * self)
{
  sonar_cluster_params_init_default (&self->params);
  self->post_messages = DEFAULT_POST_MESSAGES;
  self->max_centroids = DEFAULT_MAX_CENTROIDS;
}

static void
gst_ward_cluster_class_init (GstWardClusterClass * klass)
{
  GObjectClass *gobject_class = G_OBJECT_CLASS (klass);
  GstElementClass *element_class = GST_ELEMENT_CLASS (klass);
  GstSonarFilterClass *filter_class = GST_SONAR_FILTER_CLASS (klass);
  const GParamFlags flags = G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS
      | GST_PARAM_MUTABLE_READY;
  /* What sonar_clusterer_retune () takes: changed while playing, it holds
   * from the next ping on. */
  const GParamFlags tunable = G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS
      | GST_PARAM_MUTABLE_PLAYING;
  SonarClusterParams d;

  sonar_cluster_params_init_default (&d);
  gobject_class->set_property = gst_ward_cluster_set_property;
  gobject_class->get_property = gst_ward_cluster_get_property;

  g_object_class_install_property (gobject_class, PROP_THRESHOLD,
      g_param_spec_double ("threshold", "Threshold", "Pixels weaker than "
          "this, in dB relative to the ping's strongest, are no peaks "
          "(-200: off; the sidelobe and noise-floor tests bound what a "
          "strong echo leaves elsewhere)",
          -200.0, 0.0, d.threshold_db, tunable));
  g_object_class_install_property (gobject_class, PROP_SIDELOBE,
      g_param_spec_double ("sidelobe-threshold", "Sidelobe threshold",
          "Pixels weaker than this, in dB relative to the strongest pixel "
          "of their range (within 2 cm, any direction), are no "
          "peaks: a point's sidelobes lie at its range, at most 21.8 dB "
          "below it in the MIMO image (-200: off)",
          -200.0, 0.0, d.sidelobe_db, tunable));
  g_object_class_install_property (gobject_class, PROP_ABSOLUTE_THRESHOLD,
      g_param_spec_double ("absolute-threshold", "Absolute threshold",
          "Pixels weaker than this envelope value (range-compensated if "
          "range-compensation is on) are no peaks (0: off)",
          0.0, G_MAXDOUBLE, d.absolute_threshold, tunable));
  g_object_class_install_property (gobject_class, PROP_PFA,
      g_param_spec_double ("pfa", "Probability of false alarm",
          "Probability that a pixel of noise alone passes the noise-floor "
          "test, per pixel and ping: pixels below the lower quartile of "
          "their range over the directions times the factor noise exceeds "
          "that rarely (from the image's Doppler hypotheses, caps field "
          "\"hypotheses\") are no peaks (1: off)",
          1e-15, 1.0, d.pfa, tunable));
  g_object_class_install_property (gobject_class, PROP_LINKAGE,
      g_param_spec_enum ("linkage", "Linkage", "How the distance between "
          "two clusters is measured", GST_TYPE_SONAR_LINKAGE, d.linkage,
          flags));
  g_object_class_install_property (gobject_class, PROP_STOP,
      g_param_spec_enum ("stop", "Stop criterion", "When merging stops",
          GST_TYPE_SONAR_STOP, d.stop, tunable));
  g_object_class_install_property (gobject_class, PROP_INCONSISTENCY,
      g_param_spec_double ("inconsistency", "Inconsistency", "stop="
          "inconsistency: largest inconsistency coefficient of a merge "
          "(height minus the mean of the levels below, over their standard "
          "deviation)", 0.0, 100.0, d.inconsistency, tunable));
  g_object_class_install_property (gobject_class, PROP_DEPTH,
      g_param_spec_uint ("depth", "Depth", "Merge levels in the "
          "inconsistency coefficient (the paper uses 3 sub-branches)", 1, 64,
          d.depth, tunable));
  g_object_class_install_property (gobject_class, PROP_DISTANCE,
      g_param_spec_double ("distance", "Distance", "stop=distance: highest "
          "merge, in metres (the linkage's own height)", 0.0, 1000.0,
          d.distance, tunable));
  g_object_class_install_property (gobject_class, PROP_MAX_PEAKS,
      g_param_spec_uint ("max-peaks", "Maximum peaks", "Peaks clustered per "
          "ping, the strongest kept (complete and average linkage keep a "
          "distance matrix of 8 x max-peaks^2 bytes)", 1, 4096,
          d.max_peaks, flags));
  g_object_class_install_property (gobject_class, PROP_MAX_CENTROIDS,
      g_param_spec_uint ("max-centroids", "Maximum centroids", "Centroids "
          "kept per ping, the strongest (more post one warning); held in "
          "(max-centroids + 1) x 104 bytes", 1, MAX_MAX_CENTROIDS,
          DEFAULT_MAX_CENTROIDS, flags));
  g_object_class_install_property (gobject_class, PROP_RANGE_COMPENSATION,
      g_param_spec_boolean ("range-compensation", "Range compensation",
          "Threshold and cluster the image times range squared, undoing the "
          "spreading loss (paper eq. 6), so far objects are kept",
          d.range_compensation, flags));
  g_object_class_install_property (gobject_class, PROP_THREADS,
      g_param_spec_uint ("threads", "Threads", "Workers sharing the passes "
          "over an image (range compensation, noise floors; 0: one per "
          "processor); the centroids do not depend on it", 0,
          SONAR_MAX_WORKERS, d.threads, flags));
  g_object_class_install_property (gobject_class, PROP_POST_MESSAGES,
      g_param_spec_boolean ("post-messages", "Post messages", "Post a "
          "\"sonar-centroids\" element message per ping",
          DEFAULT_POST_MESSAGES, tunable));

  gst_element_class_add_static_pad_template (element_class, &sink_template);
  gst_element_class_add_static_pad_template (element_class, &src_template);
  gst_element_class_set_static_metadata (element_class,
      "Sonar reflector clustering", "Filter/Analyzer/Sonar",
      "Finds the centroids of the reflectors in an energyscape by "
      "thresholding, peak finding and hierarchical clustering",
      "gst-sonar-velocity developers");

  filter_class->bank_role = GST_SONAR_FILTER_USES_BANK;
  filter_class->configure = GST_DEBUG_FUNCPTR (gst_ward_cluster_configure);
  filter_class->unconfigure = GST_DEBUG_FUNCPTR (gst_ward_cluster_unconfigure);
  filter_class->process = GST_DEBUG_FUNCPTR (gst_ward_cluster_process);

  gst_type_mark_as_plugin_api (GST_TYPE_SONAR_LINKAGE, 0);
  gst_type_mark_as_plugin_api (GST_TYPE_SONAR_STOP, 0);
}
