/* gstsonarlatency.c: see gstsonarlatency.h. */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstsonarlatency.h"

/* Headroom over the longest ping measured: pings vary with what the scene
 * holds; without it every slightly longer ping would redistribute the
 * pipeline's latency. */
#define HEADROOM_NUM 5
#define HEADROOM_DEN 4

void
gst_sonar_latency_reset (GstElement * element, GstSonarLatency * latency,
    gboolean live)
{
  GST_OBJECT_LOCK (element);
  latency->longest = 0;
  latency->reported = 0;
  latency->warm = FALSE;
  latency->live = live;
  GST_OBJECT_UNLOCK (element);
}

void
gst_sonar_latency_add (GstElement * element, GstSonarLatency * latency,
    GstClockTime elapsed)
{
  gboolean rose = FALSE, live;
  GstClockTime reported;

  GST_LOG_OBJECT (element, "a ping took %" GST_TIME_FORMAT,
      GST_TIME_ARGS (elapsed));
  GST_OBJECT_LOCK (element);
  if (!latency->warm) {
    latency->warm = TRUE;
  } else {
    latency->longest = MAX (latency->longest, elapsed);
    if (latency->longest > latency->reported) {
      latency->reported = gst_util_uint64_scale_ceil (latency->longest,
          HEADROOM_NUM, HEADROOM_DEN);
      rose = TRUE;
    }
  }
  reported = latency->reported;
  live = latency->live;
  GST_OBJECT_UNLOCK (element);
  if (!rose)
    return;
  GST_INFO_OBJECT (element, "a ping took %" GST_TIME_FORMAT ": latency %"
      GST_TIME_FORMAT, GST_TIME_ARGS (elapsed), GST_TIME_ARGS (reported));
  if (live)
    gst_element_post_message (element,
        gst_message_new_latency (GST_OBJECT (element)));
}

GstClockTime
gst_sonar_latency_get (GstElement * element, GstSonarLatency * latency)
{
  GstClockTime reported;

  GST_OBJECT_LOCK (element);
  reported = latency->reported;
  GST_OBJECT_UNLOCK (element);
  return reported;
}
