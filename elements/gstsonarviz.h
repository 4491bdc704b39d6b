/* gstsonarviz.h: the energyscape and its detections as video. */
#ifndef GST_SONAR_VIZ_H
#define GST_SONAR_VIZ_H

#include <gst/gst.h>
#include <gst/base/gstaggregator.h>

G_BEGIN_DECLS

#define GST_TYPE_SONAR_VIZ (gst_sonar_viz_get_type ())
G_DECLARE_FINAL_TYPE (GstSonarViz, gst_sonar_viz, GST, SONAR_VIZ,
    GstAggregator)

GST_ELEMENT_REGISTER_DECLARE (sonarviz);

G_END_DECLS

#endif
