/* gstsonarsrc.h: the simulated MIMO sonar, a live or non-live source. */
#ifndef GST_SONAR_SRC_H
#define GST_SONAR_SRC_H

#include <gst/base/gstpushsrc.h>

G_BEGIN_DECLS

#define GST_TYPE_SONAR_SRC (gst_sonar_src_get_type ())
G_DECLARE_FINAL_TYPE (GstSonarSrc, gst_sonar_src, GST, SONAR_SRC, GstPushSrc)

GST_ELEMENT_REGISTER_DECLARE (sonarsrc);

G_END_DECLS

#endif
