/* gstsonarlatency.h: the processing latency an element reports.
 *
 * In a live pipeline the sinks hold every ping until its capture instant
 * plus the latency the elements report (the LATENCY query); the time an
 * element spends on a ping is part of that. Each element measures the wall
 * time it spends on every ping and reports 5/4 of the longest it measured
 * since its set-up (the first ping after a set-up is not counted: it pays
 * the set-up's cold caches and pool). When a ping takes longer than what
 * it reports, it raises the latency and posts a latency message, on which
 * the application calls gst_bin_recalculate_latency () (gst-launch-1.0
 * does). Contracts: docs/CONTRACTS.md, "Live pipelines".
 */
#ifndef GST_SONAR_LATENCY_H
#define GST_SONAR_LATENCY_H

#include <gst/gst.h>

G_BEGIN_DECLS

typedef struct
{
  GstClockTime longest;         /* longest ping measured since the set-up */
  GstClockTime reported;        /* what the element reports (0: nothing yet) */
  gboolean warm;                /* the first ping after the set-up is done */
  gboolean live;                /* post latency messages */
} GstSonarLatency;

/* At a set-up: nothing measured yet, the next ping is a warm-up; @live:
 * whether the stream is live (only then is a rise worth a message). */
void gst_sonar_latency_reset (GstElement * element, GstSonarLatency * latency,
    gboolean live);
/* One ping took @elapsed ns: raises the latency (and posts the message)
 * when it took longer than the latency reported. */
void gst_sonar_latency_add (GstElement * element, GstSonarLatency * latency,
    GstClockTime elapsed);
/* What @element reports (its own part, ns). */
GstClockTime gst_sonar_latency_get (GstElement * element,
    GstSonarLatency * latency);

G_END_DECLS

#endif
