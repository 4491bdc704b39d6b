/* gstvelocityest.h: radial velocity of every reflector. */
#ifndef GST_VELOCITY_EST_H
#define GST_VELOCITY_EST_H

#include "gstsonarfilter.h"

G_BEGIN_DECLS

#define GST_TYPE_VELOCITY_EST (gst_velocity_est_get_type ())
G_DECLARE_FINAL_TYPE (GstVelocityEst, gst_velocity_est, GST, VELOCITY_EST,
    GstSonarFilter)

GST_ELEMENT_REGISTER_DECLARE (velocityest);

G_END_DECLS

#endif
