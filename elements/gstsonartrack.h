/* gstsonartrack.h: the sensor's own motion and tracks across pings. */
#ifndef GST_SONAR_TRACK_H
#define GST_SONAR_TRACK_H

#include <gst/base/gstbasetransform.h>

G_BEGIN_DECLS

#define GST_TYPE_SONAR_TRACK (gst_sonar_track_get_type ())
G_DECLARE_FINAL_TYPE (GstSonarTrack, gst_sonar_track, GST, SONAR_TRACK,
    GstBaseTransform)

GST_ELEMENT_REGISTER_DECLARE (sonartrack);

G_END_DECLS

#endif
