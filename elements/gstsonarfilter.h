/* gstsonarfilter.h: the base of the processing elements (dopplerbank,
 * mimobeamform, wardcluster, velocityest).
 *
 * Every stage needs the sensor's set-up (and, after dopplerbank, the
 * Doppler bank) before it can say what it outputs. The base holds the
 * input caps and segment back until the first buffer, when the set-up is
 * known; it then asks the subclass to configure itself, pushes the
 * subclass's output caps, the segment, the set-up event and the bank event
 * in that order, and hands buffers to the subclass from then on. A new
 * set-up, bank or input caps configures again before the next buffer.
 *
 * Live pipelines (docs/CONTRACTS.md, "Live pipelines"): the base answers
 * the LATENCY query with upstream's latency plus its own processing time
 * (gstsonarlatency.h), measured on every ping the subclass pushes. It
 * keeps the QoS events from downstream and drops whole pings that would
 * reach the sink too late, as GstBaseTransform does (property "qos"); it
 * counts every ping the element drops (property "dropped") and reports it
 * on the bus (gst_sonar_filter_drop_pings).
 */
#ifndef GST_SONAR_FILTER_H
#define GST_SONAR_FILTER_H

#include <gst/gst.h>

#include "sonar-contracts.h"

G_BEGIN_DECLS

#define GST_TYPE_SONAR_FILTER (gst_sonar_filter_get_type ())
G_DECLARE_DERIVABLE_TYPE (GstSonarFilter, gst_sonar_filter, GST,
    SONAR_FILTER, GstElement)

/* What an element does with the Doppler bank. */
typedef enum
{
  /* configure() needs the bank event from upstream: data before it is an
   * error (mimobeamform, wardcluster, velocityest). */
  GST_SONAR_FILTER_USES_BANK,
  /* The element makes the bank (gst_sonar_filter_set_bank ()) and sends
   * it downstream; a bank event from upstream is stale and dropped
   * (dopplerbank). */
  GST_SONAR_FILTER_MAKES_BANK,
} GstSonarFilterBankRole;

struct _GstSonarFilterClass
{
  GstElementClass parent_class;

  GstSonarFilterBankRole bank_role;
  /* Whether the input is a stream the subclass cuts into pings
   * (dopplerbank): it then checks each ping with
   * gst_sonar_filter_drop_late() itself. Otherwise every input buffer is
   * one ping, its OFFSET the ping's index, and the base checks it. */
  gboolean frames_pings;

  /* Optional: a set-up of the element's own (dopplerbank, from files, for
   * recordings). NULL without error: use the upstream set-up event. */
  SonarSetup *(*make_setup) (GstSonarFilter * filter, GstCaps * in_caps,
      GError ** error);
  /* Makes the subclass ready for @in_caps with the filter's set-up (and
   * bank); returns the output caps, or NULL with @error set: the base posts
   * it as the element's error. May set a new bank with
   * gst_sonar_filter_set_bank(). */
  GstCaps *(*configure) (GstSonarFilter * filter, GstCaps * in_caps,
      GError ** error);
  /* Processes one input buffer (takes it); pushes output with
   * gst_sonar_filter_push(). */
  GstFlowReturn (*process) (GstSonarFilter * filter, GstBuffer * buffer);
  /* Forgets buffered data (flush), or handles what is left (EOS, drain ==
   * TRUE). Optional. */
  void (*reset) (GstSonarFilter * filter, gboolean drain);
  /* Frees what configure() made (also on stop). Optional. */
  void (*unconfigure) (GstSonarFilter * filter);
  /* Optional, once configured: the output stream's time at the input
   * stream's @time, and the inverse, for a subclass whose output times are
   * not its input's (dopplerbank: a recording of windows stored back to
   * back, whose pings it stamps with their instants). The base maps the
   * segment it sends, the seeks it takes and its answers to position and
   * duration queries with them. NULL: the same times. */
  GstClockTime (*output_time) (GstSonarFilter * filter, GstClockTime time);
  GstClockTime (*input_time) (GstSonarFilter * filter, GstClockTime time);
};

/* Valid during configure() and process(). */
SonarSetup *gst_sonar_filter_get_setup (GstSonarFilter * filter);
SonarDopplerBank *gst_sonar_filter_get_bank (GstSonarFilter * filter);
const SonarBand *gst_sonar_filter_get_band (GstSonarFilter * filter);

/* dopplerbank: the bank it made, sent downstream after the set-up. */
void gst_sonar_filter_set_bank (GstSonarFilter * filter,
    SonarDopplerBank * bank, const SonarBand * band);

/* In configure(): output buffers of @size bytes come from a pool made now,
 * so that steady streaming allocates nothing per ping. The pool allocates
 * GST_SONAR_FILTER_POOL_MIN_BUFFERS of them at once; FALSE for a size a
 * pool cannot hold (more than G_MAXUINT bytes: check it first with
 * sonar_memory_check_buffers to say why). */
#define GST_SONAR_FILTER_POOL_MIN_BUFFERS 2
gboolean gst_sonar_filter_use_pool (GstSonarFilter * filter, GstCaps * caps,
    gsize size);
/* A buffer of the pool's size (or a new one of @size when there is no
 * pool); NULL only when the pool is flushing. */
GstBuffer *gst_sonar_filter_new_buffer (GstSonarFilter * filter, gsize size);

/* Pushes one ping's output; the time since the ping's processing began
 * (the input's arrival, or the previous push) is its processing time. */
GstFlowReturn gst_sonar_filter_push (GstSonarFilter * filter,
    GstBuffer * buffer);

/* Pings first .. end - 1 are dropped (never part of one): counted in the
 * "dropped" property and posted as one bus warning, "Dropped ping N, @why
 * (M dropped since start)", whose details hold sonar-dropped (uint64, M),
 * first-ping and pings. */
void gst_sonar_filter_drop_pings (GstSonarFilter * filter, guint64 first,
    guint64 end, const char *why);
/* QoS: TRUE when ping @index, time-stamped @pts, would reach the sink too
 * late after what downstream's QoS events said: it is then dropped and
 * reported (a QoS message now; a run of late pings as one warning when it
 * ends), and must not be processed. */
gboolean gst_sonar_filter_drop_late (GstSonarFilter * filter, guint64 index,
    GstClockTime pts, GstClockTime duration);
GstPad *gst_sonar_filter_get_srcpad (GstSonarFilter * filter);
/* The input's segment (what its buffers' times are in). */
const GstSegment *gst_sonar_filter_get_segment (GstSonarFilter * filter);

/* Posts @s, a ping's element message (CONTRACTS section 10), from
 * @element with the stream and running time of the ping's @pts in
 * @segment added ("stream-time", "running-time"; GST_CLOCK_TIME_NONE out
 * of a time segment or without a PTS), as level and spectrum do: what an
 * application matches with the pipeline's clock. */
void gst_sonar_post_ping_message (GstElement * element,
    const GstSegment * segment, GstClockTime pts, GstStructure * s);

/* Whether @pspec of @element may be set now: one marked
 * GST_PARAM_MUTABLE_READY (gst-inspect: "changeable only in NULL or READY
 * state") is read as the element starts, and set beyond READY it would
 * hold a value the element does not use; it is then ignored with a
 * warning ("src: is-live can only be changed in the NULL or READY state,
 * not in PLAYING: ignored"). Every element's set_property asks first. */
gboolean gst_sonar_property_settable (GstElement * element,
    GParamSpec * pspec);

G_END_DECLS

#endif
